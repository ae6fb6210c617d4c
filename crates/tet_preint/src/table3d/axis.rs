//! The Sf and Sb axis of a `Table3d`: where its samples lie ([`ScalarAxis`]:
//! uniform, on the TF's control points, or following the data) and the map
//! from a scalar to a fractional grid index (`Axis::x_of`, `Axis::x_of_lanes`).

use super::{ScalarAxis, Table3dParams, MAX_AXIS, W};
use crate::domain::{check_res, TableDomain, TableError};
use crate::simd::{vmax, vmin};
use crate::tf::TransferFunction;
use wide::{f32x8, CmpGt};

/// The scalar axis of a table: knots (scalar, grid index) with uniform steps
/// between consecutive knots, plus what the f32 lookup needs to map a
/// scalar to a fractional grid index in O(1).
#[derive(Debug, Clone, PartialEq)]
pub(crate) struct Axis {
    pub(super) uniform: bool,
    knot_s: Vec<f64>,
    knot_i: Vec<usize>,
    /// Scalar of every grid index.
    pub(super) grid: Vec<f64>,
    pub(super) lo: f32,
    pub(super) hi: f32,
    /// Per knot interval: first scalar, last scalar, first index, 1/step.
    pub(super) seg_s0: Vec<f32>,
    pub(super) seg_s1: Vec<f32>,
    pub(super) seg_x0: Vec<f32>,
    pub(super) seg_inv: Vec<f32>,
    /// Per bucket of a uniform partition of [lo, hi]: (s0, x0, 1/step) of
    /// the knot interval holding the bucket's start, and the next knot if it
    /// falls inside the bucket (+∞ otherwise; past it, the slow path).
    pub(super) bucket: Vec<[f32; 4]>,
    pub(super) bucket_inv: f32,
    /// Per bucket, the index j of its knot interval (the one `bucket`
    /// holds), and interval j + 1's (s0, x0, 1/step, last scalar) (+∞ for the
    /// last interval; interval j's again where there is none): the AVX2
    /// lookup's second step for scalars past `next`, and where it steps on
    /// from past that.
    #[cfg_attr(not(target_arch = "x86_64"), allow(dead_code))]
    pub(super) bucket_j: Vec<i32>,
    #[cfg_attr(not(target_arch = "x86_64"), allow(dead_code))]
    pub(super) bucket2: Vec<[f32; 4]>,
}

/// Share of a [`ScalarAxis::Data`] axis's steps spread evenly over the range.
pub const DATA_AXIS_UNIFORM_SHARE: f64 = 0.5;
/// A [`ScalarAxis::Data`] axis's sample density follows the data's density
/// to this power: on the stars' cell segments, 1 left the sparse bright tail
/// (3% of the vertices over 99.5% of the range) too coarse (RMS 1.4e-4),
/// 1/2 gave 9.1e-5, 1/3 7.9e-5 but worse at 96 samples
/// (crates/tetlut/examples/table3d_axes.rs).
pub const DATA_AXIS_DENSITY_POWER: f64 = 0.5;
/// The step next to a TF control point on a [`ScalarAxis::Data`] axis, as
/// a share of the uniform step u = span / (n_s − 1); farther out, at
/// distance r, steps up to √(h₀·r) (h₀ this share of u), until the data's
/// own spacing takes over ([`node_step_cap`]). 0.5 halves the worst error
/// of the uniform step's (Blunt Fin, `tf_normalized.json`, 128 × 128 × 256,
/// uniform set: 9.6e-4 at u, 4.8e-4 at u/2, 2.9e-4 at 0.35·u;
/// crates/tetlut/examples/table3d_worst.rs).
pub const DATA_AXIS_NODE_STEP: f64 = 0.5;
/// Largest share of a [`ScalarAxis::Data`] axis's steps the refinement near
/// TF control points may take (a TF with many control points gets a
/// proportionally weaker refinement).
pub const DATA_AXIS_NODE_BUDGET: f64 = 0.5;
/// Cells per axis step of the fine partition a [`ScalarAxis::Data`] axis's
/// density is integrated on.
const FINE_PER_STEP: usize = 64;

/// A [`ScalarAxis::Data`] axis's minimum sample density at `s` (samples per
/// scalar unit) for the TF's control points `nodes` (sorted), u the uniform
/// step: 1/max(h₀, √(h₀·r)), r the distance to the nearest control point,
/// h₀ = [`DATA_AXIS_NODE_STEP`]·u.
///
/// Why: across a control point x₀ where ρ's slope jumps by Δk, the mean
/// extinction ρ̂(x₀ − x, x₀ + y) = ρ(x₀) + (k_R·y² − k_L·x²)/(2(x + y)) is
/// homogeneous of degree one around (x₀, x₀), not smooth: the table cell
/// that has the control point at its corner errs by ∝ Δk·h·l (h its step),
/// whatever the samples' placement, and a cell of step h at distance r by
/// ∝ Δk·h²/r (the function's second derivatives fall off as 1/r). Steps of
/// h₀ at the control point and √(h₀·r) away from it spread that error
/// evenly; the first-order error on the Blunt Fin case was the
/// step next to the control point (crates/tetlut/results/bluntfin.md).
pub fn node_step_cap(nodes: &[f64], s: f64, u: f64) -> f64 {
    let k = nodes.partition_point(|&x| x < s);
    let r = [k.checked_sub(1), Some(k)]
        .into_iter()
        .flatten()
        .filter_map(|j| nodes.get(j))
        .map(|&x| (s - x).abs())
        .fold(f64::INFINITY, f64::min);
    if !r.is_finite() {
        return 0.0;
    }
    let h0 = DATA_AXIS_NODE_STEP * u;
    1.0 / h0.max((h0 * r).sqrt())
}

/// A [`ScalarAxis::Data`] axis's sample density from the data alone,
/// normalized to integrate to 1 over the domain's range: a share
/// [`DATA_AXIS_UNIFORM_SHARE`] uniform, the rest ∝ the data's density to
/// the power [`DATA_AXIS_DENSITY_POWER`] (from the domain's quantiles; all
/// uniform without them).
fn data_density(domain: &TableDomain) -> impl Fn(f64) -> f64 {
    let span = domain.scalar_span();
    let (w, gamma) = (DATA_AXIS_UNIFORM_SHARE, DATA_AXIS_DENSITY_POWER);
    // Per quantile bin, density ∝ (its width)^−γ, i.e. a measure ∝ width^(1−γ).
    let bins: Vec<(f64, f64)> = match domain.s_quantiles {
        Some(mut q) => {
            // Repeated quantiles (many equal scalars) would make the density
            // infinite: spread them by a hair.
            let hair = 1e-6 * span;
            for k in 1..q.0.len() {
                q.0[k] = q.0[k].max(q.0[k - 1] + hair);
            }
            let total: f64 = q.0.windows(2).map(|b| (b[1] - b[0]).powf(1.0 - gamma)).sum();
            q.0.windows(2).map(|b| (b[1], (b[1] - b[0]).powf(-gamma) / total)).collect()
        }
        None => vec![],
    };
    let first = domain.s_quantiles.map_or(f64::INFINITY, |q| q.0[0]);
    move |s: f64| {
        let data = if bins.is_empty() {
            1.0 / span
        } else if s < first {
            0.0
        } else {
            bins.get(bins.partition_point(|b| b.0 < s)).map_or(0.0, |b| b.1)
        };
        w / span + (1.0 - w) * data
    }
}

/// The TF's colour and opacity control points strictly inside the domain's
/// range (by more than 1e-9 of its span), sorted, without duplicates: where
/// the tf-nodes and data axes place or refine samples.
pub fn tf_nodes_in(tf: &TransferFunction, domain: &TableDomain) -> Vec<f64> {
    let (lo, hi) = (domain.s_lo, domain.s_hi);
    let eps = 1e-9 * domain.scalar_span();
    let mut nodes: Vec<f64> = tf
        .color_nodes()
        .iter()
        .map(|c| c.x)
        .chain(tf.opacity_nodes().iter().map(|o| o.x))
        .filter(|&x| x > lo + eps && x < hi - eps)
        .collect();
    nodes.sort_by(f64::total_cmp);
    nodes.dedup_by(|a, b| (*a - *b).abs() <= eps);
    nodes
}

impl Axis {
    /// [`ScalarAxis::Data`]: the samples follow the density
    /// D(s) = max(λ·g(s), cap(s)), with g the data's density (a share
    /// [`DATA_AXIS_UNIFORM_SHARE`] uniform, the rest ∝ the data's density to
    /// the power [`DATA_AXIS_DENSITY_POWER`]; uniform when the domain has no
    /// quantiles), cap(s) the refinement near the TF's control points
    /// ([`node_step_cap`]) and λ chosen so that D has n_s − 1 steps. Each
    /// interval between control points gets steps ∝ its D-measure (so every
    /// control point is a sample) and its samples at equal steps of D's
    /// integral; every sample is a knot.
    fn data(tf: &TransferFunction, domain: &TableDomain, n_s: usize) -> Axis {
        let (lo, hi, span) = (domain.s_lo, domain.s_hi, domain.scalar_span());
        let steps = (n_s - 1) as f64;
        // D on a fine partition of the range (midpoint values), integrated
        // into the piecewise-linear measure G.
        let fine = FINE_PER_STEP * (n_s - 1);
        let dx = span / fine as f64;
        let mid = |i: usize| lo + (i as f64 + 0.5) * dx;
        let data_density = data_density(domain);
        let g: Vec<f64> = (0..fine).map(|i| data_density(mid(i))).collect();
        let nodes = tf_nodes_in(tf, domain);
        let u = span / steps;
        let mut cap: Vec<f64> = (0..fine).map(|i| node_step_cap(&nodes, mid(i), u)).collect();
        // Many control points: the refinement may take at most its budget.
        let cap_steps: f64 = cap.iter().sum::<f64>() * dx;
        if cap_steps > DATA_AXIS_NODE_BUDGET * steps {
            let f = DATA_AXIS_NODE_BUDGET * steps / cap_steps;
            cap.iter_mut().for_each(|c| *c *= f);
        }
        // λ: ∫ max(λ·g, cap) = steps (increasing in λ; λ = steps overshoots
        // as ∫g = 1).
        let total = |lam: f64| -> f64 { g.iter().zip(&cap).map(|(&g, &c)| (lam * g).max(c)).sum::<f64>() * dx };
        let (mut a, mut b) = (0.0, steps);
        for _ in 0..100 {
            let m = 0.5 * (a + b);
            if total(m) < steps {
                a = m;
            } else {
                b = m;
            }
        }
        let lam = b;
        let mut cum = Vec::with_capacity(fine + 1);
        cum.push(0.0f64);
        for (&gi, &ci) in g.iter().zip(&cap) {
            cum.push(cum[cum.len() - 1] + (lam * gi).max(ci) * dx);
        }
        let measure = |s: f64| -> f64 {
            let x = ((s - lo) / dx).clamp(0.0, fine as f64);
            let i = (x as usize).min(fine - 1);
            cum[i] + (x - i as f64) * (cum[i + 1] - cum[i])
        };
        // Inverse of `measure` (strictly increasing: D ≥ λ·g > 0).
        let inverse = |t: f64| -> f64 {
            let i = cum.partition_point(|&c| c <= t).clamp(1, fine) - 1;
            lo + (i as f64 + ((t - cum[i]) / (cum[i + 1] - cum[i])).clamp(0.0, 1.0)) * dx
        };
        let Some((knot_s, knot_i)) = node_knots(tf, domain, n_s, &measure) else {
            return Axis::tf_nodes(tf, domain, n_s);
        };
        let mut grid = Vec::with_capacity(n_s);
        for (ks, ki) in knot_s.windows(2).zip(knot_i.windows(2)) {
            let (g0, g1) = (measure(ks[0]), measure(ks[1]));
            let n = ki[1] - ki[0];
            grid.push(ks[0]);
            grid.extend((1..n).map(|j| inverse(g0 + (g1 - g0) * j as f64 / n as f64)));
        }
        grid.push(hi);
        let knots: Vec<(f64, usize)> = grid.into_iter().enumerate().map(|(i, s)| (s, i)).collect();
        Axis::from_knots(domain, n_s, &knots).unwrap_or_else(|| Axis::tf_nodes(tf, domain, n_s))
    }

    /// The axis [`Table3d::build`] gives `params` for `tf` over `domain`.
    ///
    /// [`Table3d::build`]: super::Table3d::build
    pub(super) fn for_params(
        tf: &TransferFunction,
        domain: &TableDomain,
        params: &Table3dParams,
    ) -> Result<Axis, TableError> {
        check_res("table3d n_s", params.n_s, 2, MAX_AXIS)?;
        Ok(match params.s_axis {
            ScalarAxis::Uniform => Axis::uniform(domain, params.n_s),
            ScalarAxis::TfNodes => Axis::tf_nodes(tf, domain, params.n_s),
            ScalarAxis::Data => Axis::data(tf, domain, params.n_s),
        })
    }

    pub(super) fn uniform(domain: &TableDomain, n_s: usize) -> Axis {
        Axis::from_knots_unchecked(domain, n_s, vec![domain.s_lo, domain.s_hi], vec![0, n_s - 1], true)
    }

    /// Knots on the TF's control points (see [`ScalarAxis::TfNodes`]).
    fn tf_nodes(tf: &TransferFunction, domain: &TableDomain, n_s: usize) -> Axis {
        match node_knots(tf, domain, n_s, &|s| s) {
            Some((knot_s, knot_i)) if knot_s.len() > 2 => {
                Axis::from_knots_unchecked(domain, n_s, knot_s, knot_i, false)
            }
            _ => Axis::uniform(domain, n_s),
        }
    }

    /// Validated knots (e.g. read from a file): `None` unless the first is
    /// (s_lo, 0), the last (s_hi, n_s − 1) and both strictly increase.
    pub(crate) fn from_knots(domain: &TableDomain, n_s: usize, knots: &[(f64, usize)]) -> Option<Axis> {
        if knots.len() < 2 || knots.len() > n_s {
            return None;
        }
        let (first, last) = (knots[0], knots[knots.len() - 1]);
        let tol = 1e-12 * domain.scalar_span().max(domain.s_lo.abs()).max(domain.s_hi.abs());
        if first.1 != 0
            || last.1 != n_s - 1
            || (first.0 - domain.s_lo).abs() > tol
            || (last.0 - domain.s_hi).abs() > tol
        {
            return None;
        }
        if !knots.windows(2).all(|w| w[0].0 < w[1].0 && w[0].1 < w[1].1) || !knots.iter().all(|k| k.0.is_finite()) {
            return None;
        }
        let mut s: Vec<f64> = knots.iter().map(|k| k.0).collect();
        (s[0], *s.last_mut().expect("two knots")) = (domain.s_lo, domain.s_hi);
        Some(Axis::from_knots_unchecked(domain, n_s, s, knots.iter().map(|k| k.1).collect(), knots.len() == 2))
    }

    fn from_knots_unchecked(
        domain: &TableDomain,
        n_s: usize,
        knot_s: Vec<f64>,
        knot_i: Vec<usize>,
        uniform: bool,
    ) -> Axis {
        let mut grid = Vec::with_capacity(n_s);
        for (w, wi) in knot_s.windows(2).zip(knot_i.windows(2)) {
            let step = (w[1] - w[0]) / (wi[1] - wi[0]) as f64;
            grid.extend((0..wi[1] - wi[0]).map(|k| w[0] + k as f64 * step));
        }
        grid.push(domain.s_hi);
        let nseg = knot_s.len() - 1;
        let seg_s0: Vec<f32> = knot_s[..nseg].iter().map(|&s| s as f32).collect();
        let seg_s1: Vec<f32> = knot_s[1..].iter().map(|&s| s as f32).collect();
        let seg_x0: Vec<f32> = knot_i[..nseg].iter().map(|&i| i as f32).collect();
        let seg_inv: Vec<f32> =
            (0..nseg).map(|j| ((knot_i[j + 1] - knot_i[j]) as f64 / (knot_s[j + 1] - knot_s[j])) as f32).collect();
        let nb = 4 * n_s;
        let bucket_inv = (nb as f64 / domain.scalar_span()) as f32;
        let (bucket, bucket_j): (Vec<[f32; 4]>, Vec<i32>) = (0..nb)
            .map(|b| {
                let start = domain.s_lo + b as f64 * domain.scalar_span() / nb as f64;
                let end = domain.s_lo + (b + 1) as f64 * domain.scalar_span() / nb as f64;
                let j = knot_s[1..nseg].partition_point(|&s| s <= start);
                let next = if j + 1 < nseg && knot_s[j + 1] < end { knot_s[j + 1] as f32 } else { f32::INFINITY };
                ([seg_s0[j], seg_x0[j], seg_inv[j], next], j as i32)
            })
            .unzip();
        let bucket2 = bucket_j
            .iter()
            .map(|&j| {
                let k = (j as usize + 1).min(nseg - 1);
                let end = if k + 1 < nseg { seg_s1[k] } else { f32::INFINITY };
                [seg_s0[k], seg_x0[k], seg_inv[k], end]
            })
            .collect();
        Axis {
            uniform,
            knot_s,
            knot_i,
            grid,
            lo: domain.s_lo as f32,
            hi: domain.s_hi as f32,
            seg_s0,
            seg_s1,
            seg_x0,
            seg_inv,
            bucket,
            bucket_inv,
            bucket_j,
            bucket2,
        }
    }

    /// Fractional grid index of a scalar already clamped to [lo, hi].
    #[inline(always)]
    pub(super) fn x_of(&self, s: f32) -> f32 {
        // s ≥ lo, so the product is ≥ 0: an i32 cast (cheaper than a
        // saturating cast to usize) is exact below the bucket count.
        let b = (((s - self.lo) * self.bucket_inv) as i32).min(self.bucket.len() as i32 - 1) as usize;
        let [s0, x0, inv, next] = self.bucket[b];
        let top = (self.grid.len() - 1) as f32;
        // f32 rounding may put s just outside its bucket; the map is
        // continuous, so the neighbouring piece's line is off by rounding only.
        let x = if s > next {
            let j = self.seg_s1[..self.seg_s1.len() - 1].partition_point(|&k| k < s);
            self.seg_x0[j] + (s - self.seg_s0[j]) * self.seg_inv[j]
        } else {
            x0 + (s - s0) * inv
        };
        x.max(0.0).min(top)
    }

    /// [`Axis::x_of`] for eight scalars already clamped to [lo, hi], the
    /// same values lane by lane; lanes from `m` on are stale and not fixed up.
    #[inline(always)]
    pub(super) fn x_of_lanes(&self, s: f32x8, m: usize) -> f32x8 {
        let nb = f32x8::splat((self.bucket.len() - 1) as f32);
        let top = f32x8::splat((self.grid.len() - 1) as f32);
        // (s − lo)·inv ≥ 0, so truncation is the floor (min first: in range).
        let b = vmin((s - f32x8::splat(self.lo)) * f32x8::splat(self.bucket_inv), nb).fast_trunc_int().to_array();
        let (mut s0, mut x0, mut inv, mut next) = ([0.0f32; W], [0.0f32; W], [0.0f32; W], [0.0f32; W]);
        for l in 0..W {
            [s0[l], x0[l], inv[l], next[l]] = self.bucket[b[l] as usize];
        }
        let x = f32x8::from(x0) + (s - f32x8::from(s0)) * f32x8::from(inv);
        let mut slow = s.cmp_gt(f32x8::from(next)).move_mask() as u32 & ((1u32 << m) - 1);
        let x = if slow == 0 {
            x
        } else {
            let (mut xs, ss) = (x.to_array(), s.to_array());
            while slow != 0 {
                let l = slow.trailing_zeros() as usize;
                slow &= slow - 1;
                xs[l] = self.x_of(ss[l]);
            }
            f32x8::from(xs)
        };
        vmin(vmax(x, f32x8::ZERO), top)
    }

    /// (scalar, index) knots.
    pub(crate) fn knots(&self) -> Vec<(f64, usize)> {
        self.knot_s.iter().copied().zip(self.knot_i.iter().copied()).collect()
    }
}

/// The TF's control points inside the range as knots (scalar, index), plus
/// the ends, with steps per interval ∝ its measure under the increasing `g`
/// (at least one, summing to n_s − 1); `None` when there are more
/// intervals than steps.
fn node_knots(
    tf: &TransferFunction,
    domain: &TableDomain,
    n_s: usize,
    g: &dyn Fn(f64) -> f64,
) -> Option<(Vec<f64>, Vec<usize>)> {
    let (lo, hi) = (domain.s_lo, domain.s_hi);
    let nodes = tf_nodes_in(tf, domain);
    let steps = n_s - 1;
    let intervals = nodes.len() + 1;
    if intervals > steps {
        return None;
    }
    let mut knot_s = Vec::with_capacity(intervals + 1);
    knot_s.push(lo);
    knot_s.extend(&nodes);
    knot_s.push(hi);
    // Steps per interval ∝ its measure, at least one, summing to `steps`
    // (largest remainder).
    let (g_lo, g_hi) = (g(lo), g(hi));
    let ideal: Vec<f64> = knot_s.windows(2).map(|w| steps as f64 * (g(w[1]) - g(w[0])) / (g_hi - g_lo)).collect();
    let mut count: Vec<usize> = ideal.iter().map(|&r| (r.floor() as usize).max(1)).collect();
    let mut total: usize = count.iter().sum();
    while total < steps {
        let j = (0..intervals)
            .max_by(|&x, &y| (ideal[x] - count[x] as f64).total_cmp(&(ideal[y] - count[y] as f64)))
            .expect("intervals");
        count[j] += 1;
        total += 1;
    }
    while total > steps {
        let j = (0..intervals)
            .filter(|&j| count[j] > 1)
            .min_by(|&x, &y| (ideal[x] - count[x] as f64).total_cmp(&(ideal[y] - count[y] as f64)))
            .expect("intervals ≤ steps leaves one with more than one step");
        count[j] -= 1;
        total -= 1;
    }
    let mut knot_i = vec![0usize];
    for c in count {
        knot_i.push(knot_i.last().expect("nonempty") + c);
    }
    Some((knot_s, knot_i))
}
