//! Size statistics of a tetrahedral mesh (what `tetprep info` prints).

use crate::predicates::{dist2, signed_tet_volume};
use rayon::prelude::*;
use serde::{Deserialize, Serialize};

/// Minimum, median and maximum of a per-cell quantity.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize, Default)]
pub struct Spread {
    pub min: f64,
    pub median: f64,
    pub max: f64,
}

/// Order-preserving map of an f64 to a u64 (total order, negatives first).
#[inline]
fn order_key(v: f64) -> u64 {
    let b = v.to_bits();
    if b >> 63 == 1 {
        !b
    } else {
        b | 1 << 63
    }
}

/// Histogram bins are the top 19 bits of the order key: sign, exponent and
/// 7 mantissa bits, so each bin spans under 1% of its value, whatever the
/// range of the data.
const KEY_SHIFT: u32 = 45;
const BINS: usize = 1 << (64 - KEY_SHIFT);

impl Spread {
    /// Exact min, median (the element of rank ⌊n/2⌋) and max of all values
    /// of `group(0..n_groups)` (K values each), without materializing them:
    /// one parallel pass builds min, max and a histogram over the values'
    /// bit patterns, a second collects only the bin holding the median.
    pub fn of_groups<const K: usize>(n_groups: usize, group: impl Fn(usize) -> [f64; K] + Sync) -> Spread {
        let n = n_groups * K;
        if n == 0 {
            return Spread::default();
        }
        struct Acc {
            min: f64,
            max: f64,
            hist: Vec<u32>,
        }
        let new = || Acc { min: f64::INFINITY, max: f64::NEG_INFINITY, hist: vec![0; BINS] };
        // Few, large chunks: each fold allocates a 2 MiB histogram.
        let chunk = n_groups.div_ceil(rayon::current_num_threads() * 2).max(1 << 14);
        let acc = (0..n_groups)
            .into_par_iter()
            .with_min_len(chunk)
            .fold(new, |mut a, g| {
                for v in group(g) {
                    a.min = a.min.min(v);
                    a.max = a.max.max(v);
                    a.hist[(order_key(v) >> KEY_SHIFT) as usize] += 1;
                }
                a
            })
            .reduce(new, |mut a, b| {
                a.min = a.min.min(b.min);
                a.max = a.max.max(b.max);
                a.hist.iter_mut().zip(&b.hist).for_each(|(x, y)| *x += y);
                a
            });
        let rank = (n / 2) as u64;
        let (mut target, mut below) = (0u64, 0u64);
        for (b, &c) in acc.hist.iter().enumerate() {
            if below + c as u64 > rank {
                target = b as u64;
                break;
            }
            below += c as u64;
        }
        let mut in_bin: Vec<f64> = (0..n_groups)
            .into_par_iter()
            .flat_map_iter(|g| group(g).into_iter().filter(|&v| order_key(v) >> KEY_SHIFT == target))
            .collect();
        let (_, median, _) = in_bin.select_nth_unstable_by((rank - below) as usize, f64::total_cmp);
        Spread { min: acc.min, median: *median, max: acc.max }
    }
}

/// Geometry facts of a mesh.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize, Default)]
pub struct MeshStats {
    pub bounds_min: [f64; 3],
    pub bounds_max: [f64; 3],
    pub total_volume: f64,
    pub tet_volume: Spread,
    /// Over all six edges of every tet (shared edges counted per tet).
    pub edge_length: Spread,
    /// Largest distance between two vertices of one tet: its longest edge.
    pub max_cell_diameter: f64,
    pub scalar_min: f64,
    pub scalar_max: f64,
}

const EDGES: [(usize, usize); 6] = [(0, 1), (0, 2), (0, 3), (1, 2), (1, 3), (2, 3)];

/// Axis-aligned bounds `(min, max)` of the finite points; `(+∞, −∞)` per
/// axis when there are none.
pub fn bounds(points: &[[f64; 3]]) -> ([f64; 3], [f64; 3]) {
    let mut lo = [f64::INFINITY; 3];
    let mut hi = [f64::NEG_INFINITY; 3];
    for p in points.iter().filter(|p| p.iter().all(|c| c.is_finite())) {
        for a in 0..3 {
            lo[a] = lo[a].min(p[a]);
            hi[a] = hi[a].max(p[a]);
        }
    }
    (lo, hi)
}

/// Computes [`MeshStats`]; volumes and lengths in the mesh's units.
pub fn mesh_stats(points: &[[f64; 3]], tets: &[[u32; 4]], scalar: &[f64]) -> MeshStats {
    let (lo, hi) = bounds(points);
    let volume = |t: usize| {
        let t = &tets[t];
        let p = |k: usize| &points[t[k] as usize];
        [signed_tet_volume(p(0), p(1), p(2), p(3))]
    };
    let edges = |t: usize| {
        let p = tets[t].map(|v| &points[v as usize]);
        EDGES.map(|(a, b)| dist2(p[a], p[b]).sqrt())
    };
    let total_volume = (0..tets.len()).into_par_iter().map(|t| volume(t)[0]).sum();
    let edge_length = Spread::of_groups(tets.len(), edges);
    MeshStats {
        bounds_min: lo,
        bounds_max: hi,
        total_volume,
        tet_volume: Spread::of_groups(tets.len(), volume),
        max_cell_diameter: edge_length.max,
        edge_length,
        scalar_min: scalar.iter().copied().fold(f64::INFINITY, f64::min),
        scalar_max: scalar.iter().copied().fold(f64::NEG_INFINITY, f64::max),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn median_is_exact_for_skewed_and_tied_values() {
        let v: Vec<f64> = (0..100_001).map(|i| ((i * 7919) % 100_001) as f64).map(|x| x * x * x).collect();
        let s = Spread::of_groups(v.len(), |i| [v[i]]);
        let mut sorted = v.clone();
        sorted.sort_by(f64::total_cmp);
        assert_eq!((s.min, s.median, s.max), (sorted[0], sorted[50_000], sorted[100_000]));
        let same = Spread::of_groups(5, |_| [2.5, 2.5]);
        assert_eq!((same.min, same.median, same.max), (2.5, 2.5, 2.5));
        let two = Spread::of_groups(4, |i| [[1.0, 1.0, 1e-300, 1.0][i]]);
        let neg = Spread::of_groups(5, |i| [[-3.0, 2.0, -1.0, 0.0, 5.0][i]]);
        assert_eq!((neg.min, neg.median, neg.max), (-3.0, 0.0, 5.0));
        assert_eq!(two.median, 1.0);
    }

    #[test]
    fn unit_tet_stats() {
        let p = [[0., 0., 0.], [1., 0., 0.], [0., 1., 0.], [0., 0., 1.]];
        let s = mesh_stats(&p, &[[0, 1, 2, 3]], &[1.0, 2.0, 3.0, 4.0]);
        assert!((s.total_volume - 1.0 / 6.0).abs() < 1e-15);
        assert!((s.max_cell_diameter - 2f64.sqrt()).abs() < 1e-15);
        assert_eq!(s.edge_length.min, 1.0);
        assert_eq!((s.scalar_min, s.scalar_max), (1.0, 4.0));
    }
}
