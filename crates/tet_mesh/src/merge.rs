//! Merging duplicate points within a tolerance.

use std::collections::HashMap;
use std::hash::{BuildHasherDefault, Hasher};

/// A fast hasher for integer cell keys (keys are not attacker-chosen in a
/// way that matters: the worst case is slow, never wrong).
#[derive(Default)]
pub(crate) struct CellHasher(u64);

impl Hasher for CellHasher {
    fn finish(&self) -> u64 {
        self.0
    }
    fn write(&mut self, bytes: &[u8]) {
        for &b in bytes {
            self.0 = (self.0.rotate_left(5) ^ b as u64).wrapping_mul(0x51_7c_c1_b7_27_22_0a_95);
        }
    }
    fn write_i64(&mut self, v: i64) {
        self.0 = (self.0.rotate_left(5) ^ v as u64).wrapping_mul(0x51_7c_c1_b7_27_22_0a_95);
    }
    fn write_u64(&mut self, v: u64) {
        self.write_i64(v as i64)
    }
}

pub(crate) type FastMap<K, V> = HashMap<K, V, BuildHasherDefault<CellHasher>>;

/// Maps every point to the first earlier point within `tolerance` (L∞
/// distance) of it, or to itself. Points with a non-finite coordinate are
/// never merged. With `tolerance == 0` only bit-identical coordinates merge
/// (and +0.0 with −0.0).
pub fn merge_duplicate_points(points: &[[f64; 3]], tolerance: f64) -> Vec<u32> {
    let mut rep: Vec<u32> = (0..points.len() as u32).collect();
    if tolerance <= 0.0 || !tolerance.is_finite() {
        let mut seen: FastMap<[u64; 3], u32> = FastMap::default();
        seen.reserve(points.len());
        for (i, p) in points.iter().enumerate() {
            if !p.iter().all(|c| c.is_finite()) {
                continue;
            }
            let key = p.map(|c| (c + 0.0).to_bits()); // +0.0 folds −0.0 into +0.0
            rep[i] = *seen.entry(key).or_insert(i as u32);
        }
        return rep;
    }
    // Grid of cell size 16·tol: a point's tolerance box (width 2·tol) then
    // straddles a cell border on an axis with probability 1/8, so ~1.4 cells
    // are probed per point. Each cell holds an intrusive list of the
    // representatives in it (`head` → `next`), so no cell allocates.
    let h = 16.0 * tolerance;
    let mut head: FastMap<[i64; 3], u32> = FastMap::default();
    head.reserve(points.len());
    let mut next = vec![u32::MAX; points.len()];
    for (i, p) in points.iter().enumerate() {
        if !p.iter().all(|c| c.is_finite()) {
            continue;
        }
        let lo = p.map(|c| ((c - tolerance) / h).floor() as i64);
        let hi = p.map(|c| ((c + tolerance) / h).floor() as i64);
        let mut found: Option<u32> = None;
        'search: for x in lo[0]..=hi[0] {
            for y in lo[1]..=hi[1] {
                for z in lo[2]..=hi[2] {
                    let mut j = head.get(&[x, y, z]).copied().unwrap_or(u32::MAX);
                    while j != u32::MAX {
                        let q = &points[j as usize];
                        if (0..3).all(|a| (q[a] - p[a]).abs() <= tolerance) {
                            found = Some(j);
                            break 'search;
                        }
                        j = next[j as usize];
                    }
                }
            }
        }
        match found {
            Some(j) => rep[i] = j,
            None => {
                let key = p.map(|c| (c / h).floor() as i64);
                let slot = head.entry(key).or_insert(u32::MAX);
                next[i] = *slot;
                *slot = i as u32;
            }
        }
    }
    rep
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn exact_and_tolerant_merges() {
        let p = vec![[0.0, 0.0, 0.0], [1.0, 0.0, 0.0], [-0.0, 0.0, 0.0], [1.0 + 1e-12, 0.0, 0.0], [f64::NAN, 0.0, 0.0]];
        assert_eq!(merge_duplicate_points(&p, 0.0), vec![0, 1, 0, 3, 4]);
        assert_eq!(merge_duplicate_points(&p, 1e-9), vec![0, 1, 0, 1, 4]);
    }

    #[test]
    fn tolerance_works_across_grid_cell_borders() {
        let t = 1e-3;
        // 0.0159999 and 0.0160001 straddle the cell border at 16·tol = 0.016.
        let p = vec![[0.0159999, 5.0, 5.0], [0.0160001, 5.0, 5.0]];
        assert_eq!(merge_duplicate_points(&p, t), vec![0, 0]);
    }
}
