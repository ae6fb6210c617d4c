//! Insertion order: biased randomized insertion order (BRIO) rounds, each
//! round sorted along a Hilbert curve.
//!
//! Random rounds keep the expected cost of Bowyer–Watson low whatever the
//! input order (a sorted lidar file would otherwise build long thin tets
//! first); Hilbert order within a round keeps consecutive points close, so
//! the walk from the last inserted tet is short and memory stays warm.

use rayon::prelude::*;
pub use tet_mesh::SplitMix64;

/// Grid resolution per axis: 2^48 cells is far finer than any point
/// cloud we sort, and fewer bits make the keys cheaper.
const BITS: u32 = 16;

/// Position along a 3D Hilbert curve of a point on a 2^16 grid (Skilling's
/// transpose algorithm).
fn hilbert_key(mut x: [u32; 3]) -> u64 {
    let m = 1u32 << (BITS - 1);
    let mut q = m;
    while q > 1 {
        let p = q - 1;
        for i in 0..3 {
            if x[i] & q != 0 {
                x[0] ^= p;
            } else {
                let t = (x[0] ^ x[i]) & p;
                x[0] ^= t;
                x[i] ^= t;
            }
        }
        q >>= 1;
    }
    x[1] ^= x[0];
    x[2] ^= x[1];
    let mut t = 0;
    q = m;
    while q > 1 {
        if x[2] & q != 0 {
            t ^= q - 1;
        }
        q >>= 1;
    }
    for xi in &mut x {
        *xi ^= t;
    }
    let mut key = 0u64;
    for b in (0..BITS).rev() {
        for xi in &x {
            key = (key << 1) | ((xi >> b) & 1) as u64;
        }
    }
    key
}

/// Hilbert keys of `points` on a grid over their bounding box (one scale
/// for all axes: a flat layer must not be stretched into a cube, which
/// would scatter its points along the curve). Coordinates must be finite.
pub fn hilbert_keys(points: &[[f64; 3]]) -> Vec<u64> {
    let (lo, hi) = tet_mesh::stats::bounds(points);
    let extent = (0..3).map(|a| hi[a] - lo[a]).fold(0.0f64, f64::max);
    let scale = if extent > 0.0 { ((1u32 << BITS) - 1) as f64 / extent } else { 0.0 };
    points
        .par_iter()
        .with_min_len(1 << 13)
        .map(|p| {
            let g = |a: usize| (((p[a] - lo[a]) * scale) as u32).min((1 << BITS) - 1);
            hilbert_key([g(0), g(1), g(2)])
        })
        .collect()
}

/// Maps every point to the first (smallest-index) point with the same
/// coordinates, or to itself: what `tet_mesh::merge::merge_duplicate_points`
/// gives with tolerance 0 (−0.0 equal to +0.0; coordinates must be finite),
/// by a parallel sort instead of one thread's hash table. Identical points
/// share a Hilbert key (`keys`, [`hilbert_keys`]), so ordering by key, then
/// coordinates, then index puts each group of copies together, smallest
/// index first; points that share a grid cell without being equal only
/// cost a comparison of coordinates.
pub fn exact_duplicates(points: &[[f64; 3]], keys: &[u64]) -> Vec<u32> {
    let folded = |i: u32| points[i as usize].map(|c| (c + 0.0).to_bits());
    let mut order: Vec<(u64, u32)> = keys.par_iter().enumerate().map(|(i, &k)| (k, i as u32)).collect();
    order.par_sort_unstable_by(|a, b| a.0.cmp(&b.0).then_with(|| folded(a.1).cmp(&folded(b.1))).then(a.1.cmp(&b.1)));
    let mut rep: Vec<u32> = (0..points.len() as u32).collect();
    let mut first = 0;
    for k in 1..order.len() {
        let (a, b) = (order[first], order[k]);
        if a.0 == b.0 && folded(a.1) == folded(b.1) {
            rep[b.1 as usize] = a.1;
        } else {
            first = k;
        }
    }
    rep
}

/// Returns `ids` reordered for insertion: shuffled (seeded), cut into rounds
/// of geometrically growing size (each round 8× the previous, the last
/// holding about 7/8 of the points), each round in Hilbert order over the
/// bounding box of all points. Coordinates must be finite.
#[cfg(test)]
pub fn brio_order(points: &[[f64; 3]], ids: Vec<u32>, seed: u64) -> Vec<u32> {
    brio_order_keyed(&hilbert_keys(points), ids, seed).0
}

/// [`brio_order`] given the Hilbert key of every point (indexed by id);
/// duplicates of a point share its key, so they may be among the keys.
/// Also returns where each round ends in the order (the last end is
/// `ids.len()`).
pub fn brio_order_keyed(keys: &[u64], ids: Vec<u32>, seed: u64) -> (Vec<u32>, Vec<usize>) {
    let n = ids.len();
    if n < 2 {
        return (ids, vec![n]);
    }
    let mut keyed: Vec<(u64, u32)> = ids.iter().map(|&i| (keys[i as usize], i)).collect();
    let mut rng = SplitMix64(seed);
    for i in (1..n).rev() {
        let j = rng.below(i + 1);
        keyed.swap(i, j);
    }
    let mut ends = vec![n];
    let mut end = n;
    while end > 2000 {
        end /= 8;
        ends.push(end);
    }
    ends.push(0);
    ends.reverse();
    for w in ends.windows(2) {
        keyed[w[0]..w[1]].sort_unstable();
    }
    ends.remove(0);
    (keyed.into_iter().map(|(_, i)| i).collect(), ends)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn hilbert_keys_are_a_bijection_with_unit_steps_on_a_small_grid() {
        // The curve visits grid cells in unit steps; check its first 4096
        // cells, which fill the 16³ cube at the origin.
        let mut cells: Vec<(u64, [u32; 3])> = Vec::new();
        for x in 0..16 {
            for y in 0..16 {
                for z in 0..16 {
                    cells.push((hilbert_key([x, y, z]), [x, y, z]));
                }
            }
        }
        cells.sort_unstable();
        assert_eq!(cells[0].0, 0);
        assert_eq!(cells.last().unwrap().0, 4095);
        for w in cells.windows(2) {
            let d: u32 = (0..3).map(|a| w[0].1[a].abs_diff(w[1].1[a])).sum();
            assert_eq!(d, 1, "{:?} -> {:?}", w[0], w[1]);
        }
    }

    /// The sort finds the copies the hash table finds: bit-identical
    /// points (−0.0 as +0.0) in a cloud with many copies, many points in
    /// one grid cell that are not copies, and a far outlier squeezing the
    /// rest into few cells.
    #[test]
    fn exact_duplicates_equal_the_hash_merge() {
        let mut rng = SplitMix64(3);
        let mut pts: Vec<[f64; 3]> = (0..20_000).map(|_| [rng.next_f64(), rng.next_f64(), rng.next_f64()]).collect();
        for k in 0..3000 {
            let src = pts[(rng.next_u64() % pts.len() as u64) as usize];
            pts.push(if k % 7 == 0 { src.map(|c| if c == 0.0 { -0.0 } else { c }) } else { src });
        }
        pts.push([0.0, 0.5, 0.5]);
        pts.push([-0.0, 0.5, 0.5]);
        let mut clustered: Vec<[f64; 3]> =
            (0..5000).map(|i| [1e-9 * (i % 50) as f64, 1e-9 * (i / 50 % 7) as f64, 0.0]).collect();
        clustered.push([1e6, 1e6, 1e6]);
        for p in [pts, clustered] {
            let keys = hilbert_keys(&p);
            assert_eq!(exact_duplicates(&p, &keys), tet_mesh::merge::merge_duplicate_points(&p, 0.0));
        }
    }

    #[test]
    fn brio_is_a_permutation() {
        let mut rng = SplitMix64(7);
        let pts: Vec<[f64; 3]> = (0..10_000).map(|_| [rng.next_f64(), rng.next_f64(), rng.next_f64()]).collect();
        let mut o = brio_order(&pts, (0..10_000).collect(), 1);
        o.sort_unstable();
        assert!(o.iter().enumerate().all(|(i, &v)| i as u32 == v));
    }
}
