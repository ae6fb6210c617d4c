//! Size statistics of a tetrahedral mesh (what `tetprep info` prints).

use crate::predicates::{dist2, signed_tet_volume, tet_orientation, TetOrientation};
use crate::MeshError;
use rayon::prelude::*;
use serde::{Deserialize, Serialize};
use std::cmp::Ordering;
use std::sync::atomic::{AtomicUsize, Ordering::Relaxed};

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

/// Running min, max and bit-pattern histogram of one quantity.
struct Acc {
    min: f64,
    max: f64,
    hist: Vec<u32>,
}

impl Acc {
    fn new() -> Acc {
        Acc { min: f64::INFINITY, max: f64::NEG_INFINITY, hist: vec![0; BINS] }
    }

    #[inline]
    fn add(&mut self, v: f64) {
        self.min = self.min.min(v);
        self.max = self.max.max(v);
        self.hist[(order_key(v) >> KEY_SHIFT) as usize] += 1;
    }

    fn merge(mut self, b: Acc) -> Acc {
        self.min = self.min.min(b.min);
        self.max = self.max.max(b.max);
        self.hist.iter_mut().zip(&b.hist).for_each(|(x, y)| *x += y);
        self
    }

    /// The bin holding the element of rank ⌊n/2⌋ and the count below it.
    fn median_bin(&self, n: usize) -> (u64, u64) {
        let rank = (n / 2) as u64;
        let mut below = 0u64;
        for (b, &c) in self.hist.iter().enumerate() {
            if below + c as u64 > rank {
                return (b as u64, below);
            }
            below += c as u64;
        }
        (0, below)
    }
}

/// Picks the element of rank ⌊n/2⌋ from the values of its bin.
fn median_of_bin(mut in_bin: Vec<f64>, n: usize, below: u64) -> f64 {
    let rank = (n / 2) as u64;
    let (_, median, _) = in_bin.select_nth_unstable_by((rank - below) as usize, f64::total_cmp);
    *median
}

/// Inputs from this many groups try [`Spread::bracketed`] first, with this
/// many groups sampled.
const SAMPLED_MIN: usize = 1 << 15;
const SAMPLE_GROUPS: usize = 1 << 14;

/// Few, large folds: each allocates its 2 MiB histograms.
fn fold_min_chunks(n_chunks: usize) -> usize {
    n_chunks.div_ceil(rayon::current_num_threads() * 2).max(1)
}

/// Groups a pass takes in one piece. The piece sums are added in piece
/// order, so the sum is the same number whatever the thread count or how
/// the work was split between threads (rayon's folds split as threads
/// steal work, and a sum added up in fold order differed between runs).
const SUM_CHUNK: usize = 1 << 14;

/// The groups of piece `c`.
fn piece(c: usize, n_groups: usize) -> std::ops::Range<usize> {
    c * SUM_CHUNK..((c + 1) * SUM_CHUNK).min(n_groups)
}

/// Piece sums `(piece, sum)` in any order, added in piece order.
fn sum_in_piece_order(mut parts: Vec<(usize, f64)>) -> f64 {
    parts.sort_unstable_by_key(|p| p.0);
    parts.iter().fold(0.0, |acc, p| acc + p.1)
}

impl Spread {
    /// Exact min, median (the element of rank ⌊n/2⌋) and max of all values
    /// of `group(0..n_groups)` (K values each), without materializing them:
    /// one parallel pass builds min, max and a histogram over the values'
    /// bit patterns, a second collects only the bin holding the median.
    pub fn of_groups<const K: usize>(n_groups: usize, group: impl Fn(usize) -> [f64; K] + Sync) -> Spread {
        let (a, _, _) = Spread::of_two_groups(n_groups, |g| (group(g), [0.0; 0]));
        a
    }

    /// [`Spread::of_groups`] of two quantities computed together (one
    /// evaluation of `group` a pass, which matters when it gathers from
    /// memory), and the sum of the first.
    ///
    /// Large inputs first try one pass: a fixed sample of groups brackets
    /// each median between two sample values, and the pass counts the
    /// values below the bracket and collects those inside it, which holds
    /// the median unless the sample was unlucky (then the two histogram
    /// passes run). Either way the median is exact.
    pub fn of_two_groups<const K: usize, const L: usize>(
        n_groups: usize,
        group: impl Fn(usize) -> ([f64; K], [f64; L]) + Sync,
    ) -> (Spread, Spread, f64) {
        if n_groups == 0 {
            return (Spread::default(), Spread::default(), 0.0);
        }
        if n_groups >= SAMPLED_MIN {
            if let Some(r) = Spread::bracketed(n_groups, &group, SAMPLE_GROUPS) {
                return r;
            }
        }
        Spread::by_histograms(n_groups, &group)
    }

    /// The one-pass form of [`Spread::of_two_groups`] with `sample` groups
    /// sampled; `None` when a median falls outside its bracket.
    fn bracketed<const K: usize, const L: usize>(
        n_groups: usize,
        group: &(impl Fn(usize) -> ([f64; K], [f64; L]) + Sync),
        sample: usize,
    ) -> Option<(Spread, Spread, f64)> {
        let (n_a, n_b) = (n_groups * K, n_groups * L);
        // Evenly spaced groups from a fixed offset: deterministic, and
        // spread over the whole input (meshes are ordered in space).
        let sample = sample.min(n_groups);
        let step = n_groups as f64 / sample as f64;
        let (mut sa, mut sb): (Vec<f64>, Vec<f64>) = (Vec::new(), Vec::new());
        for k in 0..sample {
            let (va, vb) = group(((k as f64 + 0.5) * step) as usize);
            sa.extend(va);
            sb.extend(vb);
        }
        // The bracket: sample ranks 5 standard deviations of the sample
        // median's rank either side of it.
        let bracket = |mut v: Vec<f64>| -> (f64, f64) {
            if v.is_empty() {
                return (0.0, 0.0);
            }
            v.sort_unstable_by(f64::total_cmp);
            let m = v.len();
            let half = (5.0 * (m as f64).sqrt() * 0.5).ceil() as usize + 1;
            (v[(m / 2).saturating_sub(half)], v[(m / 2 + half).min(m - 1)])
        };
        let ((lo_a, hi_a), (lo_b, hi_b)) = (bracket(sa), bracket(sb));
        // Values equal to a bracket end are counted, not kept (a grid's
        // edge lengths take a few values); those strictly inside are kept,
        // within a budget shared by all folds: ties inside the bracket, or
        // a sample far from the data, send the input to the histograms.
        // Folds claim room from the budget in blocks, not a value at a
        // time (one shared counter per kept value made the threads take
        // turns on its cache line); room a fold claimed and did not use is
        // lost (at most a block a piece, half the budget in all), which can
        // only send an input to the histograms early.
        let n_chunks = n_groups.div_ceil(SUM_CHUNK);
        let total_budget = (n_a + n_b) / 16 + 1024;
        let budget = AtomicUsize::new(total_budget);
        let claim = (total_budget / (2 * n_chunks)).clamp(1, 1 << 12);
        struct Pass {
            min: [f64; 2],
            max: [f64; 2],
            sums: Vec<(usize, f64)>,
            below: [u64; 2],
            at_lo: [u64; 2],
            at_hi: [u64; 2],
            inside: [Vec<f64>; 2],
            /// Room claimed from the budget and not yet used.
            room: usize,
            over: bool,
        }
        let new = || Pass {
            min: [f64::INFINITY; 2],
            max: [f64::NEG_INFINITY; 2],
            sums: Vec::new(),
            below: [0; 2],
            at_lo: [0; 2],
            at_hi: [0; 2],
            inside: [Vec::new(), Vec::new()],
            room: 0,
            over: false,
        };
        let take = |p: &mut Pass, q: usize, v: f64, lo: f64, hi: f64| {
            p.min[q] = p.min[q].min(v);
            p.max[q] = p.max[q].max(v);
            match (v.total_cmp(&lo), v.total_cmp(&hi)) {
                (Ordering::Less, _) => p.below[q] += 1,
                (Ordering::Equal, _) => p.at_lo[q] += 1,
                (_, Ordering::Equal) => p.at_hi[q] += 1,
                (_, Ordering::Less) => {
                    if p.room == 0 && !p.over {
                        match budget.fetch_update(Relaxed, Relaxed, |b| (b > 0).then(|| b - b.min(claim))) {
                            Ok(b) => p.room = b.min(claim),
                            Err(_) => p.over = true,
                        }
                    }
                    if !p.over {
                        p.room -= 1;
                        p.inside[q].push(v);
                    }
                }
                _ => {}
            }
        };
        let pass = (0..n_chunks)
            .into_par_iter()
            .fold(new, |mut p, c| {
                let mut sum = 0.0;
                for g in piece(c, n_groups) {
                    let (va, vb) = group(g);
                    for v in va {
                        take(&mut p, 0, v, lo_a, hi_a);
                        sum += v;
                    }
                    for v in vb {
                        take(&mut p, 1, v, lo_b, hi_b);
                    }
                }
                p.sums.push((c, sum));
                p
            })
            .reduce(new, |mut x, y| {
                for q in 0..2 {
                    x.min[q] = x.min[q].min(y.min[q]);
                    x.max[q] = x.max[q].max(y.max[q]);
                    x.below[q] += y.below[q];
                    x.at_lo[q] += y.at_lo[q];
                    x.at_hi[q] += y.at_hi[q];
                    x.inside[q].extend_from_slice(&y.inside[q]);
                }
                x.sums.extend_from_slice(&y.sums);
                x.over |= y.over;
                x
            });
        if pass.over {
            return None;
        }
        let mut pass = pass;
        let [mut in_a, mut in_b] = std::mem::take(&mut pass.inside);
        // The element of rank ⌊n/2⌋ in total order, when the bracket holds it.
        let median = |q: usize, lo: f64, hi: f64, n: usize, inside: &mut Vec<f64>| -> Option<f64> {
            let mut rank = ((n / 2) as u64).checked_sub(pass.below[q])?;
            if rank < pass.at_lo[q] {
                return Some(lo);
            }
            rank -= pass.at_lo[q];
            if rank < inside.len() as u64 {
                let (_, m, _) = inside.select_nth_unstable_by(rank as usize, f64::total_cmp);
                return Some(*m);
            }
            rank -= inside.len() as u64;
            (rank < pass.at_hi[q]).then_some(hi)
        };
        let a = Spread { min: pass.min[0], median: median(0, lo_a, hi_a, n_a, &mut in_a)?, max: pass.max[0] };
        let b = if L > 0 {
            Spread { min: pass.min[1], median: median(1, lo_b, hi_b, n_b, &mut in_b)?, max: pass.max[1] }
        } else {
            Spread::default()
        };
        let sum = sum_in_piece_order(std::mem::take(&mut pass.sums));
        Some((a, b, sum))
    }

    /// The two-pass form of [`Spread::of_two_groups`]: min, max and a
    /// histogram over the values' bit patterns, then the values of the
    /// median's bin.
    fn by_histograms<const K: usize, const L: usize>(
        n_groups: usize,
        group: &(impl Fn(usize) -> ([f64; K], [f64; L]) + Sync),
    ) -> (Spread, Spread, f64) {
        let (n_a, n_b) = (n_groups * K, n_groups * L);
        let n_chunks = n_groups.div_ceil(SUM_CHUNK);
        let (acc_a, acc_b, sums) = (0..n_chunks)
            .into_par_iter()
            .with_min_len(fold_min_chunks(n_chunks))
            .fold(
                || (Acc::new(), Acc::new(), Vec::new()),
                |(mut a, mut b, mut sums), c| {
                    let mut sum = 0.0;
                    for g in piece(c, n_groups) {
                        let (va, vb) = group(g);
                        for v in va {
                            a.add(v);
                            sum += v;
                        }
                        for v in vb {
                            b.add(v);
                        }
                    }
                    sums.push((c, sum));
                    (a, b, sums)
                },
            )
            .reduce_with(|mut x, y| {
                x.2.extend_from_slice(&y.2);
                (x.0.merge(y.0), x.1.merge(y.1), x.2)
            })
            .expect("n_groups > 0");
        let sum = sum_in_piece_order(sums);
        let (bin_a, below_a) = acc_a.median_bin(n_a);
        let (bin_b, below_b) = acc_b.median_bin(n_b);
        let in_bin = |v: f64, bin: u64| order_key(v) >> KEY_SHIFT == bin;
        let (vals_a, vals_b): (Vec<f64>, Vec<f64>) = (0..n_groups)
            .into_par_iter()
            .fold(
                || (Vec::new(), Vec::new()),
                |(mut xa, mut xb), g| {
                    let (va, vb) = group(g);
                    xa.extend(va.into_iter().filter(|&v| in_bin(v, bin_a)));
                    xb.extend(vb.into_iter().filter(|&v| in_bin(v, bin_b)));
                    (xa, xb)
                },
            )
            .reduce(
                || (Vec::new(), Vec::new()),
                |(mut a1, mut b1), (a2, b2)| {
                    a1.extend(a2);
                    b1.extend(b2);
                    (a1, b1)
                },
            );
        let a = Spread { min: acc_a.min, median: median_of_bin(vals_a, n_a, below_a), max: acc_a.max };
        let b = if L > 0 {
            Spread { min: acc_b.min, median: median_of_bin(vals_b, n_b, below_b), max: acc_b.max }
        } else {
            Spread::default()
        };
        (a, b, sum)
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
    stats_with(points, bounds(points), tets, scalar, |_, _| {})
}

/// [`mesh_stats`] that also confirms, in the same pass over the tets, that
/// every tet is positively oriented: a tet whose floating-point volume is
/// not clearly positive is decided by the exact predicate
/// ([`tet_orientation`]). For tets a caller vouches for (a Delaunay
/// tetrahedralization's, `tetrahedralize_tets` with
/// `GivenOrientation::ExactlyPositive`), so that the check costs no pass of
/// its own. Err names the first tet (lowest index) that is flat or negative.
///
/// Why the volume decides: it is computed as det[p1−p0, p2−p0, p3−p0]/6 in
/// the form of Shewchuk's orient3d first stage, whose error is at most
/// 7ε(1 + 8ε) times its permanent; with every coordinate difference at most
/// `m` (the points' largest box extent) the permanent is at most 6m³, so a
/// volume above 16εm³ (more than twice that bound, over 6) has a positive
/// exact determinant. Near overflow or underflow, where that analysis
/// fails, every tet goes to the exact predicate.
pub fn mesh_stats_confirming_orientation(
    points: &[[f64; 3]],
    tets: &[[u32; 4]],
    scalar: &[f64],
) -> Result<MeshStats, MeshError> {
    let (lo, hi) = bounds(points);
    let m = (0..3).map(|a| hi[a] - lo[a]).fold(0.0f64, f64::max);
    let bound = 16.0 * (f64::EPSILON / 2.0) * m * m * m;
    let certain_above = if bound.is_finite() && bound > 1e-250 { bound } else { f64::INFINITY };
    // Tets left to the exact predicate; few (slivers), so a lock is cheap.
    let uncertain = std::sync::Mutex::new(Vec::new());
    let stats = stats_with(points, (lo, hi), tets, scalar, |t, volume| {
        // (A NaN volume is not clearly positive either.)
        if volume <= certain_above || volume.is_nan() {
            uncertain.lock().unwrap_or_else(std::sync::PoisonError::into_inner).push(t as u32);
        }
    });
    let mut uncertain = uncertain.into_inner().unwrap_or_else(std::sync::PoisonError::into_inner);
    // (The statistics may evaluate a tet more than once.)
    uncertain.par_sort_unstable();
    uncertain.dedup();
    let wrong = uncertain.par_iter().find_first(|&&t| {
        let p = tets[t as usize].map(|v| &points[v as usize]);
        tet_orientation(p[0], p[1], p[2], p[3]) != TetOrientation::Positive
    });
    match wrong {
        None => Ok(stats),
        Some(&t) => {
            let p = tets[t as usize].map(|v| &points[v as usize]);
            let orientation = match tet_orientation(p[0], p[1], p[2], p[3]) {
                TetOrientation::Flat => "flat",
                _ => "negatively oriented",
            };
            Err(MeshError::NotPositive { tet: t as usize, orientation })
        }
    }
}

/// The statistics (with the points' bounds already found), calling
/// `each_volume(tet, volume)` for every tet evaluated (some more than once).
fn stats_with(
    points: &[[f64; 3]],
    (lo, hi): ([f64; 3], [f64; 3]),
    tets: &[[u32; 4]],
    scalar: &[f64],
    each_volume: impl Fn(usize, f64) + Sync,
) -> MeshStats {
    // Volume and the six squared edge lengths of each tet from one gather
    // of its vertices. The square root is monotone and correctly rounded,
    // so the order statistics of the lengths are the roots of those of the
    // squares, bit for bit: six roots a tet saved for three.
    let (tet_volume, edge_length2, total_volume) = Spread::of_two_groups(tets.len(), |t| {
        let p = tets[t].map(|v| &points[v as usize]);
        let volume = signed_tet_volume(p[0], p[1], p[2], p[3]);
        each_volume(t, volume);
        ([volume], EDGES.map(|(a, b)| dist2(p[a], p[b])))
    });
    let edge_length =
        Spread { min: edge_length2.min.sqrt(), median: edge_length2.median.sqrt(), max: edge_length2.max.sqrt() };
    MeshStats {
        bounds_min: lo,
        bounds_max: hi,
        total_volume,
        tet_volume,
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

    /// Two quantities together give what each gives alone.
    #[test]
    fn two_groups_match_one_group_each() {
        let f = |i: usize| ((i * 7919) % 1009) as f64 - 300.5;
        let g = |i: usize| [f(i) * 1e-3, (f(i) * 3.0).abs(), -f(i)];
        let (a, b, sum) = Spread::of_two_groups(50_001, |i| ([f(i)], g(i)));
        assert_eq!(a, Spread::of_groups(50_001, |i| [f(i)]));
        assert_eq!(b, Spread::of_groups(50_001, g));
        let direct: f64 = (0..50_001).map(f).sum();
        assert!((sum - direct).abs() <= 1e-9 * direct.abs().max(1.0), "{sum} {direct}");
    }

    /// The one-pass bracket gives the exact median or declines, for
    /// smooth, skewed, sorted, tied and few-valued data, whatever the
    /// sample size; the histogram passes agree.
    #[test]
    fn bracketed_median_is_exact_or_declines() {
        let n = 70_001;
        type Values = Box<dyn Fn(usize) -> f64 + Sync>;
        let data: Vec<(&str, Values)> = vec![
            ("hashed", Box::new(|i| ((i * 7919) % 100_003) as f64 - 5e4)),
            ("cubed", Box::new(|i| (((i * 104_729) % 70_001) as f64).powi(3))),
            ("sorted", Box::new(|i| i as f64 * 1e-3)),
            ("four values", Box::new(|i| [1.0, 2.0f64.sqrt(), 3.0f64.sqrt(), 2.0][(i * 31) % 4])),
            ("one value", Box::new(|_| 0.25)),
            ("mostly one value", Box::new(|i| if i % 97 == 0 { i as f64 } else { -0.0 })),
        ];
        for (name, f) in &data {
            let group = |i: usize| ([f(i)], [f(i) * 2.0, -f(n - 1 - i)]);
            let truth = |k: usize| {
                let mut v: Vec<f64> =
                    (0..n).flat_map(|i| if k == 0 { vec![group(i).0[0]] } else { group(i).1.to_vec() }).collect();
                v.sort_by(f64::total_cmp);
                (v[0], v[v.len() / 2], v[v.len() - 1])
            };
            let (ta, tb) = (truth(0), truth(1));
            let hist = Spread::by_histograms(n, &group);
            assert_eq!((hist.0.min, hist.0.median, hist.0.max), ta, "{name}");
            assert_eq!((hist.1.min, hist.1.median, hist.1.max), tb, "{name}");
            let mut declined = 0;
            for sample in [1, 2, 7, 100, 1 << 14] {
                match Spread::bracketed(n, &group, sample) {
                    Some((a, b, sum)) => {
                        assert_eq!((a, b), (hist.0, hist.1), "{name}, sample {sample}");
                        assert!((sum - hist.2).abs() <= 1e-9 * hist.2.abs().max(1.0), "{name}");
                    }
                    None => declined += 1,
                }
            }
            // The full sample finds every median here.
            assert!(declined < 5, "{name}");
            let all = Spread::of_two_groups(n, group);
            assert_eq!((all.0, all.1), (hist.0, hist.1), "{name}");
        }
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

    /// A jittered 5-split grid big enough for the one-pass bracket: the
    /// edge statistics equal those of the sorted lengths bit for bit (the
    /// roots of the squares' order statistics), and every figure, the
    /// volume sum included, is the same in pools of 1, 2 and 3 threads.
    #[test]
    fn mesh_stats_are_exact_and_do_not_depend_on_the_thread_count() {
        let n = [26usize; 3];
        let mut rng = crate::SplitMix64(11);
        let points = crate::split::structured_points(n, |p| p.map(|x| x as f64 + 0.3 * rng.next_f64()));
        let mesh = crate::split::structured_grid_tets(n.map(|k| k - 1), crate::SplitMode::Five);
        assert!(mesh.len() >= SAMPLED_MIN, "{} tets take the histogram path only", mesh.len());
        let scalar: Vec<f64> = points.iter().map(|p| p[0] * p[1]).collect();
        let in_pool = |threads: usize| {
            let pool = rayon::ThreadPoolBuilder::new().num_threads(threads).build().unwrap();
            pool.install(|| mesh_stats(&points, &mesh, &scalar))
        };
        let one = in_pool(1);
        assert_eq!(one, in_pool(2));
        assert_eq!(one, in_pool(3));
        let mut lengths: Vec<f64> = mesh
            .iter()
            .flat_map(|t| EDGES.map(|(a, b)| dist2(&points[t[a] as usize], &points[t[b] as usize]).sqrt()))
            .collect();
        lengths.sort_by(f64::total_cmp);
        let m = lengths.len();
        assert_eq!(one.edge_length, Spread { min: lengths[0], median: lengths[m / 2], max: lengths[m - 1] });
        assert_eq!(one.max_cell_diameter, lengths[m - 1]);
        // The one-pass and histogram forms agree, the sum included.
        let group = |t: usize| {
            let p = mesh[t].map(|v| &points[v as usize]);
            ([signed_tet_volume(p[0], p[1], p[2], p[3])], EDGES.map(|(a, b)| dist2(p[a], p[b])))
        };
        let hist = Spread::by_histograms(mesh.len(), &group);
        assert_eq!(Spread::bracketed(mesh.len(), &group, SAMPLE_GROUPS), Some(hist));
    }

    /// The confirming form gives the same statistics on a positive mesh,
    /// decides slivers below its float bound exactly, and names the first
    /// tet that is flat or negative, however small its volume.
    #[test]
    fn orientation_is_confirmed_in_the_statistics_pass() {
        let n = [26usize; 3];
        let mut rng = crate::SplitMix64(12);
        let mut points = crate::split::structured_points(n, |p| p.map(|x| x as f64 + 0.3 * rng.next_f64()));
        let mut mesh = crate::split::structured_grid_tets(n.map(|k| k - 1), crate::SplitMode::Five);
        let scalar: Vec<f64> = points.iter().map(|p| p[2]).collect();
        assert_eq!(mesh_stats_confirming_orientation(&points, &mesh, &scalar), Ok(mesh_stats(&points, &mesh, &scalar)));
        // Slivers far below the float bound (16ε·m³ with m = 25): a tet
        // over a point raised by ±1e-30 from a face's plane.
        let base = points.len() as u32;
        points.extend([[0.0, 0.0, 0.0], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.25, 0.25, 1e-30], [0.25, 0.25, -1e-30]]);
        points.push([0.25, 0.25, 0.0]);
        let scalar: Vec<f64> = points.iter().map(|p| p[2]).collect();
        let sliver = [base, base + 1, base + 2, base + 3];
        mesh.push(sliver);
        let stats = mesh_stats_confirming_orientation(&points, &mesh, &scalar).expect("a positive sliver");
        assert_eq!(
            stats.tet_volume.min,
            signed_tet_volume(
                &points[base as usize],
                &points[base as usize + 1],
                &points[base as usize + 2],
                &points[base as usize + 3]
            )
        );
        let at = mesh.len();
        for (last, orientation) in [(base + 4, "negatively oriented"), (base + 5, "flat")] {
            mesh.push([base, base + 1, base + 2, last]);
            assert_eq!(
                mesh_stats_confirming_orientation(&points, &mesh, &scalar),
                Err(MeshError::NotPositive { tet: at, orientation })
            );
            mesh.pop();
        }
        // A plainly flipped tet among many: the first one is named.
        mesh.swap(3, 7);
        let t = mesh[100];
        mesh[100] = [t[1], t[0], t[2], t[3]];
        mesh[2000] = [mesh[2000][1], mesh[2000][0], mesh[2000][2], mesh[2000][3]];
        assert_eq!(
            mesh_stats_confirming_orientation(&points, &mesh, &scalar),
            Err(MeshError::NotPositive { tet: 100, orientation: "negatively oriented" })
        );
    }
}
