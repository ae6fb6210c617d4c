//! A small fixed-seed random generator for sampling, tests and
//! randomized algorithms, so no crate needs `rand` for reproducible draws.

/// SplitMix64: a small, fixed-seed generator (no `rand` dependency).
#[derive(Debug, Clone)]
pub struct SplitMix64(pub u64);

impl SplitMix64 {
    #[inline]
    pub fn next_u64(&mut self) -> u64 {
        self.0 = self.0.wrapping_add(0x9E37_79B9_7F4A_7C15);
        let mut z = self.0;
        z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
        z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
        z ^ (z >> 31)
    }

    /// Uniform in [0, 1) with 53 random bits.
    #[inline]
    pub fn next_f64(&mut self) -> f64 {
        (self.next_u64() >> 11) as f64 * (1.0 / (1u64 << 53) as f64)
    }

    /// Uniform in [0, n) for n > 0 (multiply-shift; bias < n / 2^64).
    #[inline]
    pub fn below(&mut self, n: usize) -> usize {
        ((self.next_u64() as u128 * n as u128) >> 64) as usize
    }
}

/// Marsaglia's xorshift64 (shifts 13, 7, 17): the generator of tests whose
/// fixed draws predate [`SplitMix64`]. The state must not be 0 (it stays 0).
#[derive(Debug, Clone)]
pub struct XorShift64(pub u64);

impl XorShift64 {
    #[inline]
    pub fn next_u64(&mut self) -> u64 {
        self.0 ^= self.0 << 13;
        self.0 ^= self.0 >> 7;
        self.0 ^= self.0 << 17;
        self.0
    }

    /// Uniform in [0, 1) with 53 random bits.
    #[inline]
    pub fn next_f64(&mut self) -> f64 {
        (self.next_u64() >> 11) as f64 / (1u64 << 53) as f64
    }

    /// Uniform in [lo, hi).
    #[inline]
    pub fn range(&mut self, lo: f64, hi: f64) -> f64 {
        lo + (hi - lo) * self.next_f64()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn xorshift_draws_are_marsaglias_and_in_range() {
        let mut r = XorShift64(1);
        // x ^= x << 13 → 8193; x ^= x >> 7 → 8257; x ^= x << 17 → 8257 ^ (8257 << 17).
        assert_eq!(r.next_u64(), 8257 ^ (8257 << 17));
        let mut r = XorShift64(0x5eed);
        for _ in 0..1000 {
            let u = r.next_f64();
            assert!((0.0..1.0).contains(&u));
            let v = r.range(-2.0, 3.0);
            assert!((-2.0..3.0).contains(&v));
        }
    }
}
