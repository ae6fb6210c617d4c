//! Scaled complementary error function and Dawson's integral in f64, for
//! non-negative arguments (the only ones the segment integrator produces).
//!
//! erfcx: the defining series below 0.46875 and Cody's rational Chebyshev
//! approximations (Math. Comp. 1969) above — a few dozen flops instead of
//! a continued fraction of up to 200 divisions. Dawson: Rybicki's
//! exponentially convergent sum with its Gaussian weights computed once.
//! Both are checked against 50-digit mpmath values in the unit tests below.

const FRAC_2_SQRT_PI: f64 = std::f64::consts::FRAC_2_SQRT_PI;
/// 1/√π.
const FRAC_1_SQRT_PI: f64 = 0.5 * std::f64::consts::FRAC_2_SQRT_PI;

/// erfcx(x) = exp(x²)·erfc(x) for x ≥ 0 (NaN for negative or NaN input,
/// 0 at +∞).
#[allow(clippy::excessive_precision)] // Cody's coefficients as published
pub fn erfcx(x: f64) -> f64 {
    if x.is_nan() || x < 0.0 {
        return f64::NAN;
    }
    if x < 0.46875 {
        // exp(x²)·erf(x) = (2/√π) Σ 2ⁿ x^{2n+1} / (2n+1)!!: positive terms, so
        // the only cancellation is exp(x²) − that, at most a factor ~2 here.
        let x2 = x * x;
        let mut term = x;
        let mut sum = x;
        let mut n = 0.0;
        loop {
            n += 1.0;
            term *= 2.0 * x2 / (2.0 * n + 1.0);
            sum += term;
            if term <= 1e-17 * sum {
                break;
            }
        }
        return x2.exp() - FRAC_2_SQRT_PI * sum;
    }
    if x <= 4.0 {
        // Cody (1969), "Rational Chebyshev approximations for the error
        // function", erfc·exp(x²) on [0.46875, 4]: degree 8/8.
        const P: [f64; 9] = [
            5.641_884_969_886_700_89e-1,
            8.883_149_794_388_375_94,
            6.611_919_063_714_162_95e1,
            2.986_351_381_974_001_31e2,
            8.819_522_212_417_690_90e2,
            1.712_047_612_634_070_58e3,
            2.051_078_377_826_071_47e3,
            1.230_339_354_797_997_25e3,
            2.153_115_354_744_038_46e-8,
        ];
        const Q: [f64; 8] = [
            1.574_492_611_070_983_47e1,
            1.176_939_508_913_124_99e2,
            5.371_811_018_620_098_58e2,
            1.621_389_574_566_690_19e3,
            3.290_799_235_733_459_63e3,
            4.362_619_090_143_247_16e3,
            3.439_367_674_143_721_64e3,
            1.230_339_354_803_749_42e3,
        ];
        let mut num = P[8] * x;
        let mut den = x;
        for i in 0..7 {
            num = (num + P[i]) * x;
            den = (den + Q[i]) * x;
        }
        return (num + P[7]) / (den + Q[7]);
    }
    if x >= 6.71e7 {
        // 1 − 1/(2x²) = 1 in f64: the asymptotic series' first term (and 0 at ∞).
        return FRAC_1_SQRT_PI / x;
    }
    // Cody (1969) for x > 4: erfcx = (1/√π − y·R(y))/x with y = 1/x², R degree 4/4.
    const P: [f64; 6] = [
        3.053_266_349_612_323_44e-1,
        3.603_448_999_498_044_39e-1,
        1.257_817_261_112_292_46e-1,
        1.608_378_514_874_227_66e-2,
        6.587_491_615_298_378_03e-4,
        1.631_538_713_730_209_78e-2,
    ];
    const Q: [f64; 5] = [
        2.568_520_192_289_822_42,
        1.872_952_849_923_460_47,
        5.279_051_029_514_284_12e-1,
        6.051_834_131_244_131_91e-2,
        2.335_204_976_268_691_85e-3,
    ];
    let y = 1.0 / (x * x);
    let mut num = P[5] * y;
    let mut den = y;
    for i in 0..4 {
        num = (num + P[i]) * y;
        den = (den + Q[i]) * y;
    }
    (FRAC_1_SQRT_PI - y * (num + P[4]) / (den + Q[4])) / x
}

/// Dawson's integral F(x) = exp(−x²)∫₀ˣ exp(t²) dt for x ≥ 0 (NaN for
/// negative or NaN input, 0 at +∞).
pub fn dawson(x: f64) -> f64 {
    if x.is_nan() || x < 0.0 {
        return f64::NAN;
    }
    if x < 0.2 {
        // F(x) = Σ (−1)ⁿ 2ⁿ x^{2n+1} / (2n+1)!!.
        let x2 = x * x;
        let mut term = x;
        let mut sum = x;
        let mut n = 0.0;
        loop {
            n += 1.0;
            term *= -2.0 * x2 / (2.0 * n + 1.0);
            sum += term;
            if term.abs() <= 1e-17 * sum.abs() {
                break;
            }
        }
        return sum;
    }
    if x < CHEB_HI {
        return dawson_rybicki(x);
    }
    dawson_asymptotic(x)
}

/// Dawson's integral for x ≥ 0 in about a tenth of [`dawson`]'s time, to
/// within 4e-15 relative (checked against mpmath below; [`dawson`] is within
/// 2e-15): piecewise Chebyshev interpolants on [0.2, 12). For tables stored
/// in f32, such as partial pre-integration's Ψ.
pub fn dawson_fast(x: f64) -> f64 {
    if (CHEB_LO..CHEB_HI).contains(&x) {
        dawson_chebyshev(x)
    } else {
        dawson(x)
    }
}

fn dawson_asymptotic(x: f64) -> f64 {
    // Asymptotic F(x) = 1/(2x)·Σ (2n−1)!!/(2x²)ⁿ: at x ≥ 12 the terms fall
    // by ≥ 14× each for the dozen terms f64 needs.
    let y = 0.5 / (x * x);
    let mut term = 1.0;
    let mut sum = 1.0;
    let mut n = 0.0;
    while term > 1e-17 * sum {
        n += 1.0;
        term *= (2.0 * n - 1.0) * y;
        sum += term;
    }
    0.5 / x * sum
}

/// Chebyshev pieces of Dawson's integral on [0.2, 12): interval width and
/// polynomial degree (11 coefficients; the interpolation error on a 0.05
/// wide piece is far below f64 rounding).
const CHEB_LO: f64 = 0.2;
const CHEB_HI: f64 = 12.0;
const CHEB_WIDTH: f64 = 0.05;
const CHEB_PIECES: usize = 236;
const CHEB_N: usize = 11;

/// Dawson on [0.2, 12) from piecewise Chebyshev interpolants of
/// [`dawson_rybicki`], fitted once on first use (2,596 evaluations, well
/// under a millisecond): a Clenshaw sum instead of 17 exponentials-weighted
/// divisions per call.
fn dawson_chebyshev(x: f64) -> f64 {
    static PIECES: std::sync::LazyLock<Vec<[f64; CHEB_N]>> = std::sync::LazyLock::new(|| {
        (0..CHEB_PIECES)
            .map(|i| {
                let (a, b) = (CHEB_LO + i as f64 * CHEB_WIDTH, CHEB_LO + (i + 1) as f64 * CHEB_WIDTH);
                let (mid, half) = (0.5 * (a + b), 0.5 * (b - a));
                let n = CHEB_N as f64;
                let f: [f64; CHEB_N] = std::array::from_fn(|k| {
                    dawson_rybicki(mid + half * (std::f64::consts::PI * (k as f64 + 0.5) / n).cos())
                });
                std::array::from_fn(|j| {
                    let c: f64 = (0..CHEB_N)
                        .map(|k| f[k] * (std::f64::consts::PI * j as f64 * (k as f64 + 0.5) / n).cos())
                        .sum();
                    if j == 0 {
                        c / n
                    } else {
                        2.0 * c / n
                    }
                })
            })
            .collect()
    });
    let i = (((x - CHEB_LO) / CHEB_WIDTH) as usize).min(CHEB_PIECES - 1);
    let a = CHEB_LO + i as f64 * CHEB_WIDTH;
    let t = (x - a) / CHEB_WIDTH * 2.0 - 1.0;
    let c = &PIECES[i];
    // Clenshaw.
    let (mut b1, mut b2) = (0.0, 0.0);
    for &ck in c[1..].iter().rev() {
        let b0 = 2.0 * t * b1 - b2 + ck;
        b2 = b1;
        b1 = b0;
    }
    t * b1 - b2 + c[0]
}

/// Rybicki's sum for Dawson's integral, x ≥ 0.2: exact to f64 rounding but
/// ~20 divisions per call, so only used to fit [`dawson_chebyshev`].
fn dawson_rybicki(x: f64) -> f64 {
    // Rybicki: F(x) ≈ (1/√π) Σ_{n odd} exp(−(x − n h)²)/n, with the sum
    // centred on the even n0 nearest x/h. The discretisation error is
    // ~exp(−(π/2h)²) ≈ 1e-27 at h = 0.2; terms with |n − n0|·h > 6.4 are
    // below 1e-17 of the sum.
    const H: f64 = 0.2;
    const N_SIDE: usize = 17;
    let n0 = 2.0 * (0.5 * x / H).round();
    let xp = x - n0 * H;
    let e1 = (2.0 * xp * H).exp();
    let e2 = e1 * e1;
    let mut up = e1; // exp(2 xp h (2i+1))
    let mut sum = 0.0;
    static WEIGHTS: std::sync::LazyLock<[f64; N_SIDE]> = std::sync::LazyLock::new(|| {
        std::array::from_fn(|i| {
            let m = (2 * i + 1) as f64;
            (-(m * H) * (m * H)).exp()
        })
    });
    let weights = &*WEIGHTS;
    for (i, &c) in weights.iter().enumerate() {
        let m = (2 * i + 1) as f64;
        // n = n0 + m and n = n0 − m
        sum += c * (up / (n0 + m) + 1.0 / ((n0 - m) * up));
        up *= e2;
    }
    FRAC_1_SQRT_PI * (-xp * xp).exp() * sum
}

#[cfg(test)]
#[allow(clippy::excessive_precision)] // reference values keep all 20 digits
mod tests {
    use super::*;

    fn rel(a: f64, b: f64) -> f64 {
        ((a - b) / b).abs()
    }

    // 20-digit values from mpmath 1.4.1 at 50 digits: erfc(x)·exp(x²) and √π/2·exp(−x²)·erfi(x).
    const ERFCX_REF: &[(f64, f64)] = &[
        (1e-300, 1.0),
        (1e-10, 0.9999999998871620833),
        (1e-05, 0.99998871630832829263),
        (0.01, 0.98881546104634251033),
        (0.1, 0.89645697996912663666),
        (0.19, 0.8171324929293523269),
        (0.2, 0.80901951990158073283),
        (0.21, 0.80103616550403047233),
        (0.3, 0.73459933456765514992),
        (0.5, 0.61569034419292587487),
        (0.7, 0.52593033734944095849),
        (0.9, 0.45653165132311703252),
        (0.99, 0.43033121306414827169),
        (1.0, 0.42758357615580700441),
        (1.01, 0.42486681431119998368),
        (1.2, 0.37853741692923973161),
        (1.5, 0.32158541645431750235),
        (2.0, 0.25539567631050574387),
        (2.5, 0.21080636406114358065),
        (3.0, 0.17900115118138995042),
        (4.0, 0.13699945762506138989),
        (5.0, 0.11070463773306862637),
        (7.5, 0.074573693062876683005),
        (10.0, 0.056140992743822585858),
        (15.0, 0.037529606388505765746),
        (26.0, 0.021683584850562906616),
        (30.0, 0.018795888861416751497),
        (50.0, 0.0112815362653237725),
        (100.0, 0.0056416137829894329036),
        (199.0, 0.0028350877406612603057),
        (201.0, 0.0028068786141067683422),
        (1000.0, 0.0005641893014533876542),
        (10000.0, 0.000056418958072680841152),
        (1000000.0, 5.6418958354747419216e-7),
        (10000000000.0, 5.6418958354775628695e-11),
        (1e+100, 5.6418958354775627798e-101),
    ];
    const DAWSON_REF: &[(f64, f64)] = &[
        (1e-300, 1.0000000000000000251e-300),
        (1e-10, 1.0000000000000000364e-10),
        (1e-05, 9.9999999993333341514e-6),
        (0.01, 0.0099993333599992383203),
        (0.1, 0.099335992397852866591),
        (0.19, 0.18549268702269874939),
        (0.2, 0.19475103336802805989),
        (0.21, 0.20393355044308953452),
        (0.3, 0.28263166502131191946),
        (0.5, 0.42443638350202229593),
        (0.7, 0.51050405755923176605),
        (0.9, 0.54072431872629867566),
        (0.99, 0.53879454681449784772),
        (1.0, 0.53807950691276841914),
        (1.01, 0.53727208394450477692),
        (1.2, 0.50727349640773962383),
        (1.5, 0.42824907108539862548),
        (2.0, 0.30134038892379196603),
        (2.5, 0.22308372216743548113),
        (3.0, 0.17827103061055828734),
        (4.0, 0.12934800123600511559),
        (5.0, 0.10213407442427683544),
        (7.5, 0.067275811644630615987),
        (10.0, 0.050253847187598528033),
        (15.0, 0.033407906808639225873),
        (26.0, 0.019245024851840634084),
        (30.0, 0.016675941401059175798),
        (50.0, 0.010002001201201683031),
        (100.0, 0.0050002500375093782827),
        (199.0, 0.0025125945387489016633),
        (201.0, 0.002487592976096538037),
        (1000.0, 0.00050000025000037500094),
        (10000.0, 0.00005000000025000000375),
        (1000000.0, 5.0000000000025e-7),
        (10000000000.0, 5.0e-11),
    ];

    #[test]
    fn erfcx_matches_mpmath() {
        for &(x, v) in ERFCX_REF {
            assert!(rel(erfcx(x), v) < 2e-15, "erfcx({x}) = {} vs {v}: rel {}", erfcx(x), rel(erfcx(x), v));
        }
    }

    #[test]
    fn dawson_matches_mpmath() {
        for &(x, v) in DAWSON_REF {
            assert!(rel(dawson(x), v) < 2e-15, "dawson({x}) = {} vs {v}: rel {}", dawson(x), rel(dawson(x), v));
        }
    }

    #[test]
    fn dawson_fast_matches_mpmath() {
        for &(x, v) in DAWSON_REF {
            let f = dawson_fast(x);
            assert!(rel(f, v) < 4e-15, "dawson_fast({x}) = {f} vs {v}: rel {}", rel(f, v));
        }
        // And the fit against Rybicki's sum on a dense grid, piece edges included.
        for i in 0..=23_600 {
            let x = 0.2 + i as f64 * 5e-4;
            let (f, r) = (dawson_fast(x), dawson(x));
            assert!(rel(f, r) < 4e-15, "x = {x}: {f} vs {r}");
        }
    }

    #[test]
    fn edge_values() {
        assert_eq!(erfcx(0.0), 1.0);
        assert_eq!(dawson(0.0), 0.0);
        assert_eq!(erfcx(f64::INFINITY), 0.0);
        assert!(erfcx(-1.0).is_nan() && dawson(-1.0).is_nan());
        assert!(rel(dawson(1e9), 0.5e-9) < 1e-15);
    }
}
