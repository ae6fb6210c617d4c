//! `table3d`: the 3D pre-integration table T(Sf, Sb, l) of premultiplied RGBA
//! with trilinear lookup (Röttger, Kraus & Ertl 2000; Röttger & Ertl 2002), or, where α bends within
//! a grid step, trilinear in optical depth ([`Reconstruction`]).
//!
//! Axes: Sf and Sb take `n_s` values over the domain's scalar range, equally
//! spaced or ([`ScalarAxis::TfNodes`]) piecewise equally spaced with a sample
//! on every TF control point, which removes the dominant interpolation
//! error (the TF's kinks), or ([`ScalarAxis::Data`]) denser where the
//! bundle's scalars are; l takes `n_l` values k·Δl, k = 0..n_l−1, up to
//! `len_max_world` (slice 0 is l = 0, all zeros). Only pairs in the band
//! |Sf − Sb| ≤ `max_ds` (plus a grid step so trilinear corners exist) are
//! stored: row a holds b ∈ [lo(a), hi(a)] (a ± w on a uniform axis), each
//! pair's n_l entries contiguous.
//!
//! # Builds ([`Build3d`])
//!
//! * `Adaptive` (what [`crate::BakeOptions`] bakes with): per (Sf, Sb)
//!   pair, density emission, the segment is cut at the TF's control points
//!   into pieces where ρ and κ are linear, and each piece into the fewest
//!   intervals whose estimated colour error stays below the tolerance. On
//!   an interval ln T is the chord plus a bend βx(1 − x) (exact, ρ linear),
//!   integrated to first order in β in closed form, so the error falls as
//!   (intervals)⁻⁴: a smooth TF needs a handful per pair where the slice
//!   recurrence takes two per grid step. All slices of an interval at once
//!   (vectorized over l). Independent emission: the slice recurrence.
//! * `SliceRecurrence` (`Build3d::default()`, tet_gpu's compute-shader
//!   bake): per (Sf, Sb) pair the segment is cut into n
//!   intervals (n = ⌈o·|b − a|⌉, o the oversampling factor per grid step;
//!   one interval on the diagonal, where it is exact). The optical depth from
//!   the entry to sample i is l·Dᵢ with Dᵢ = ∫₀^{uᵢ} ρ exact (trapezoids:
//!   ρ is linear between samples), so Tᵢ(l_k) = exp(−k·Δl·Dᵢ) = Tᵢ(l_{k−1})·Gᵢ:
//!   slice k comes from slice k−1's transmittances by one multiplication per
//!   sample, no exp. Colour, density emission, integrated by parts:
//!   C = κ₀ − κₙTₙ + Σᵢ Δκᵢ·∫ᵢT du, with ∫ᵢT = (Tᵢ − Tᵢ₊₁)/λᵢ (exact when ρ
//!   is constant on the interval, λᵢ its optical depth; a series below
//!   λ = 0.05). Independent emission: C = l·Σᵢ κ̄ᵢ·∫ᵢT. α = 1 − Tₙ. The inner
//!   loop runs over plain f32 arrays in 8 lanes without branches; pairs are
//!   distributed over threads with rayon.
//! * `Blend`: Röttger & Ertl's (2002) hardware pre-integration emulated: per slice, n
//!   steps blended back to front with each step's (colour, 1 − e^{−ρl/n})
//!   at the sample midpoint (Stein's constant-chromaticity step), the running
//!   sums rounded to the accumulation precision after every step (Table 1).
//! * `Incremental`: O(N³); slice k composites a front piece of length Δl
//!   (mean extinction from the prefix integral, mean colour of its ends) over
//!   slice k−1 looked up bilinearly at (Sm, Sb), as VTK's incremental table.
//! * `Exact`: every entry by the f64 [`crate::integrate_segment`] (the
//!   per-entry reference build).
//!
//! Every build but `Incremental` computes a pair from the TF over the
//! pair's own interval [Sf, Sb] only (the optical depth is integrated from
//! Sf), which lets [`Table3d::rebake`] recompute after a TF edit only the
//! pairs the edit reaches, bit for bit as a full bake.

use crate::domain::{check_res, TableDomain, TableError, MAX_TABLE_ENTRIES};
use crate::exact::integrate_segment_with;
use crate::method::{self, Method, Rgba32, Segment, SegmentBatch, SegmentShader};
use crate::precision::{Accumulation, Precision, Storage};
use crate::simd::{no_nan, vmax, vmin};
use crate::tf::{Emission, TransferFunction};
use glam::Vec4;
use rayon::prelude::*;
use serde::{Deserialize, Serialize};
use wide::{f32x8, CmpGt, CmpLt};

/// How the table is computed.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(tag = "kind", rename_all = "kebab-case")]
pub enum Build3d {
    /// Transmittance recurrence over l with `oversampling` intervals per
    /// scalar grid step (module docs).
    SliceRecurrence { oversampling: f32 },
    /// Density emission: per (Sf, Sb) pair the fewest pieces whose
    /// estimated colour error is at most `tolerance` (absolute, per
    /// entry), each integrated with the bend of ln T to first order, and
    /// every slice l at once (module docs). Independent emission: the slice
    /// recurrence with oversampling 2.
    Adaptive { tolerance: f32 },
    /// The frame-buffer integration of Röttger & Ertl, "A Two-Step Approach
    /// for Interactive Pre-Integrated Volume Rendering of Unstructured
    /// Grids", 2002: `steps` samples per segment, sums
    /// rounded to `accumulation` after each step.
    Blend { steps: u32, accumulation: Accumulation },
    /// Composite a short front piece over the previous slice (O(N³)).
    Incremental,
    /// f64 exact integration per entry.
    Exact,
}

impl Default for Build3d {
    fn default() -> Self {
        Build3d::SliceRecurrence { oversampling: 2.0 }
    }
}

/// [`Build3d::Adaptive`]'s tolerance in [`Table3dParams::data`] (so in
/// `BakeOptions`): estimated colour error per entry. On Blunt Fin with
/// `tf_normalized.json` the entries' max error against the per-entry exact
/// build is 1.1e-5 (slice recurrence, o = 2: 1.5e-5) at about 1/7 of the
/// slice recurrence's bake time (crates/tetlut/results/bluntfin.md).
pub const ADAPTIVE_TOLERANCE: f32 = 1e-5;

/// Where the `n_s` samples of the Sf and Sb axes lie.
///
/// The table's error is dominated by the TF's control points: ρ and κ have
/// a kink there, so α and C have one along Sf = node and Sb = node (and a
/// sharp bend near the diagonal), which a uniform grid straddles with an
/// error of order |Δslope|·Δs·l. `TfNodes` puts a grid sample on every
/// control point inside the scalar range (the steps between two control
/// points are uniform, their count proportional to the gap, at least one),
/// so trilinear interpolation never straddles a kink; on the Blunt Fin
/// uniform set this lowers the max error of 128 × 128 × 256 from 2.4e-3 to
/// below 1e-3 (crates/tetlut/results/bluntfin.md).
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "kebab-case")]
pub enum ScalarAxis {
    /// Equal steps over [s_lo, s_hi] (format version 1's only axis).
    #[default]
    Uniform,
    /// Piecewise uniform with a sample on every TF control point; falls back
    /// to uniform steps when the TF has more control points in range than
    /// the axis has steps.
    TfNodes,
    /// Samples with a density that is half uniform over the scalar range,
    /// half ∝ √(the data's scalar density) (from the domain's
    /// [`ScalarQuantiles`]; all uniform when it has none), refined near
    /// every TF control point (steps there half the uniform step, growing
    /// as √distance: [`node_step_cap`]), and a sample on every control
    /// point. A table's error grows with l·|dρ/ds|·Δs where the segments
    /// are, so a bundle whose scalars crowd into a sliver of the range (the
    /// stars' luminosities: half below 3e-4 of it, all inside the first
    /// step of a uniform 128-sample axis) needs its samples there; and
    /// across a control point the error is first order in the step there,
    /// wherever the samples are, so those steps must be small too.
    ///
    /// [`ScalarQuantiles`]: crate::domain::ScalarQuantiles
    Data,
}

/// Resolution, build and storage of a [`Table3d`].
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct Table3dParams {
    /// Samples along Sf and along Sb (≥ 2).
    pub n_s: usize,
    /// Samples along l, including l = 0 (≥ 2).
    pub n_l: usize,
    pub build: Build3d,
    pub precision: Precision,
    /// Placement of the scalar samples; absent in format-1 files (uniform).
    #[serde(default)]
    pub s_axis: ScalarAxis,
}

impl Default for Table3dParams {
    /// 128 × 128 × 256, slice recurrence with oversampling 2, f32, uniform
    /// scalar axis (format version 1's layout; `BakeOptions`, what tetlut,
    /// the CPU renderer and tetview bake with, defaults to
    /// [`Table3dParams::data`]).
    fn default() -> Self {
        Table3dParams {
            n_s: 128,
            n_l: 256,
            build: Build3d::default(),
            precision: Precision::F32,
            s_axis: ScalarAxis::Uniform,
        }
    }
}

impl Table3dParams {
    /// The defaults with a sample on every TF control point: the accurate
    /// choice on the CPU.
    pub fn tf_nodes() -> Self {
        Table3dParams { s_axis: ScalarAxis::TfNodes, ..Default::default() }
    }

    /// The defaults with samples following the data and on every TF control
    /// point ([`ScalarAxis::Data`]), built adaptively
    /// ([`Build3d::Adaptive`] at [`ADAPTIVE_TOLERANCE`]): what
    /// [`crate::BakeOptions`] bakes with. tet_gpu's compute-shader bake
    /// runs the slice recurrence: give it `build: Build3d::default()` (the
    /// same axis; entries agree to ~1e-5).
    pub fn data() -> Self {
        Table3dParams {
            s_axis: ScalarAxis::Data,
            build: Build3d::Adaptive { tolerance: ADAPTIVE_TOLERANCE },
            ..Default::default()
        }
    }
}

/// The scalar axis of a table: knots (scalar, grid index) with uniform steps
/// between consecutive knots, plus what the f32 lookup needs to map a
/// scalar to a fractional grid index in O(1).
#[derive(Debug, Clone, PartialEq)]
pub(crate) struct Axis {
    uniform: bool,
    knot_s: Vec<f64>,
    knot_i: Vec<usize>,
    /// Scalar of every grid index.
    grid: Vec<f64>,
    lo: f32,
    hi: f32,
    /// Per knot interval: first scalar, last scalar, first index, 1/step.
    seg_s0: Vec<f32>,
    seg_s1: Vec<f32>,
    seg_x0: Vec<f32>,
    seg_inv: Vec<f32>,
    /// Per bucket of a uniform partition of [lo, hi]: (s0, x0, 1/step) of
    /// the knot interval holding the bucket's start, and the next knot if it
    /// falls inside the bucket (+∞ otherwise; past it, the slow path).
    bucket: Vec<[f32; 4]>,
    bucket_inv: f32,
    /// Per bucket, the index j of its knot interval (the one `bucket`
    /// holds), and interval j + 1's (s0, x0, 1/step, last scalar) (+∞ for the
    /// last interval; interval j's again where there is none): the AVX2
    /// lookup's second step for scalars past `next`, and where it steps on
    /// from past that.
    #[cfg_attr(not(target_arch = "x86_64"), allow(dead_code))]
    bucket_j: Vec<i32>,
    #[cfg_attr(not(target_arch = "x86_64"), allow(dead_code))]
    bucket2: Vec<[f32; 4]>,
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
/// evenly; the first-order error on the issue's Blunt Fin case was the
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
/// range, sorted, without duplicates.
fn tf_nodes_in(tf: &TransferFunction, domain: &TableDomain) -> Vec<f64> {
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
    fn for_params(tf: &TransferFunction, domain: &TableDomain, params: &Table3dParams) -> Result<Axis, TableError> {
        check_res("table3d n_s", params.n_s, 2, MAX_AXIS)?;
        Ok(match params.s_axis {
            ScalarAxis::Uniform => Axis::uniform(domain, params.n_s),
            ScalarAxis::TfNodes => Axis::tf_nodes(tf, domain, params.n_s),
            ScalarAxis::Data => Axis::data(tf, domain, params.n_s),
        })
    }

    fn uniform(domain: &TableDomain, n_s: usize) -> Axis {
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
    fn x_of(&self, s: f32) -> f32 {
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
    fn x_of_lanes(&self, s: f32x8, m: usize) -> f32x8 {
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

/// Largest `n_s` or `n_l`.
pub const MAX_AXIS: usize = 8192;

/// The exact prefix integral P(s) = ∫ ρ of a TF's piecewise-linear
/// extinction (clamped constant outside its nodes), so that the mean
/// extinction over [Sf, Sb] is (P(Sb) − P(Sf)) / (Sb − Sf).
#[derive(Debug, Clone)]
pub struct ExtinctionPrefix {
    xs: Vec<f64>,
    rho: Vec<f64>,
    cum: Vec<f64>,
}

impl ExtinctionPrefix {
    pub fn new(tf: &TransferFunction) -> Self {
        let u = tf.unit_distance();
        let xs: Vec<f64> = tf.opacity_nodes().iter().map(|o| o.x).collect();
        let rho: Vec<f64> = tf.opacity_nodes().iter().map(|o| o.a / u).collect();
        let mut cum = vec![0.0; xs.len()];
        for i in 1..xs.len() {
            cum[i] = cum[i - 1] + 0.5 * (rho[i - 1] + rho[i]) * (xs[i] - xs[i - 1]);
        }
        ExtinctionPrefix { xs, rho, cum }
    }

    /// P(s), with P(first node) = 0.
    pub fn at(&self, s: f64) -> f64 {
        let n = self.xs.len();
        let i = self.xs.partition_point(|&x| x <= s);
        if i == 0 {
            return (s - self.xs[0]) * self.rho[0];
        }
        if i == n {
            return self.cum[n - 1] + (s - self.xs[n - 1]) * self.rho[n - 1];
        }
        let (x0, x1) = (self.xs[i - 1], self.xs[i]);
        let d = s - x0;
        let slope = (self.rho[i] - self.rho[i - 1]) / (x1 - x0);
        self.cum[i - 1] + d * (self.rho[i - 1] + 0.5 * slope * d)
    }

    /// Mean extinction over [sf, sb] (either order); ρ(sf) when they coincide.
    pub fn mean(&self, tf: &TransferFunction, sf: f64, sb: f64) -> f64 {
        if sf == sb {
            tf.extinction(sf)
        } else {
            ((self.at(sb) - self.at(sf)) / (sb - sf)).max(0.0)
        }
    }
}

/// Which (a, b) index pairs are stored: the band |a − b| ≤ w.
#[derive(Debug, Clone, PartialEq)]
pub(crate) struct Band {
    pub n_s: usize,
    /// Stored half-width in grid steps.
    pub w: usize,
    /// Largest |xa − xb| a lookup may use, grid steps (the domain's max_ds).
    pub reach: f32,
    pub row_lo: Vec<usize>,
    pub row_start: Vec<usize>,
    pub pairs: usize,
    /// Per row a, `row_start[a] − row_lo[a]` (wrapping): pair (a, b) is
    /// entry block `pair_off[a] + b` (the lookup's one load instead of two;
    /// part of the band so that it changes with it).
    pub pair_off: Vec<usize>,
    /// `pair_off` truncated to i32 (wrapping values stay wrapped mod 2³²):
    /// the AVX2 lookup's lanes. Its offsets are bounded by the data's
    /// length, which fits in i32 (at most 2³⁰ values).
    #[cfg_attr(not(target_arch = "x86_64"), allow(dead_code))]
    pub pair_off32: Vec<i32>,
}

impl Band {
    /// The band of `axis`: for a uniform axis |a − b| ≤ w as in format 1;
    /// otherwise row a holds every b a lookup with Sf within one step of
    /// s_a and |Sf − Sb| ≤ max_ds can touch, plus one index of margin for
    /// f32 rounding.
    fn for_axis(n_s: usize, domain: &TableDomain, axis: &Axis) -> Band {
        if axis.uniform {
            return Band::new(n_s, domain);
        }
        let x = |s: f64| axis.x_of((s as f32).max(axis.lo).min(axis.hi)) as f64;
        let mut row_lo = Vec::with_capacity(n_s);
        let mut row_start = Vec::with_capacity(n_s + 1);
        let (mut pairs, mut w) = (0, 0);
        for a in 0..n_s {
            let below = axis.grid[a.saturating_sub(1)] - domain.max_ds;
            let above = axis.grid[(a + 1).min(n_s - 1)] + domain.max_ds;
            let lo = ((x(below).floor() as usize).saturating_sub(1)).min(a);
            let hi = (x(above).floor() as usize + 2).min(n_s - 1).max(a);
            row_lo.push(lo);
            row_start.push(pairs);
            pairs += hi - lo + 1;
            w = w.max(a - lo).max(hi - a);
        }
        row_start.push(pairs);
        Band::with_offsets(n_s, w, (n_s - 1) as f32, row_lo, row_start, pairs)
    }

    fn with_offsets(n_s: usize, w: usize, reach: f32, row_lo: Vec<usize>, row_start: Vec<usize>, pairs: usize) -> Band {
        let pair_off: Vec<usize> = (0..n_s).map(|a| row_start[a].wrapping_sub(row_lo[a])).collect();
        let pair_off32 = pair_off.iter().map(|&p| p as i32).collect();
        Band { n_s, w, reach, row_lo, row_start, pairs, pair_off, pair_off32 }
    }

    pub fn new(n_s: usize, domain: &TableDomain) -> Band {
        let step = domain.scalar_span() / (n_s - 1) as f64;
        let reach_steps = (domain.max_ds / step).min((n_s - 1) as f64);
        // A lookup with |xa − xb| ≤ reach touches corners with |a − b| ≤ ⌈reach⌉ + 1.
        let w = ((reach_steps - 1e-9).max(0.0).ceil() as usize + 1).min(n_s - 1);
        let mut row_lo = Vec::with_capacity(n_s);
        let mut row_start = Vec::with_capacity(n_s + 1);
        let mut pairs = 0;
        for a in 0..n_s {
            let lo = a.saturating_sub(w);
            let hi = (a + w).min(n_s - 1);
            row_lo.push(lo);
            row_start.push(pairs);
            pairs += hi - lo + 1;
        }
        row_start.push(pairs);
        Band::with_offsets(n_s, w, reach_steps as f32, row_lo, row_start, pairs)
    }

    #[inline]
    pub fn pair(&self, a: usize, b: usize) -> usize {
        self.row_start[a] + (b - self.row_lo[a])
    }

    /// The b range of row a.
    pub fn row(&self, a: usize) -> std::ops::Range<usize> {
        self.row_lo[a]..self.row_lo[a] + (self.row_start[a + 1] - self.row_start[a])
    }
}

/// A baked 3D table; implements [`SegmentShader`] by lookup ([`Reconstruction`]).
#[derive(Debug, Clone)]
pub struct Table3d {
    domain: TableDomain,
    params: Table3dParams,
    band: Band,
    /// Boxed: keeps `Table3d` (and `Baked`) small.
    axis: Box<Axis>,
    data: Storage,
    /// How lookups interpolate ([`Reconstruction`]), chosen from `pair_gap`.
    recon: Reconstruction,
    /// Per pair, the largest gap between the two reconstructions'
    /// half-way α along l and towards the next pair of its row.
    pair_gap: Vec<f32>,
    /// With [`Reconstruction::OpticalDepth`] on f32 storage, the optical
    /// depth ([`optical_depths`]) of every entry, in entry order: what the
    /// lookup interpolates, computed once per bake, load or re-bake instead
    /// of 8 logarithms per lookup. Empty otherwise.
    depth: Vec<f32>,
    /// 1 / grid step along s (uniform axis) and along l.
    inv_ds: f32,
    inv_dl: f32,
    /// Which code runs the batched lookups ([`LookupKernel`]).
    kernel: LookupKernel,
}

/// Which code runs a [`Table3d`]'s batched lookups
/// ([`SegmentShader::shade_batch`] and [`SegmentShader::shade_span`]; the
/// single lookup [`Table3d::lookup`] is always portable). Both give the same
/// values bit for bit (module `simd_x86`), so the choice is speed only.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub enum LookupKernel {
    /// The AVX2 kernel where the CPU has AVX2 and F16C (checked once per
    /// process) and the environment variable `TET_PREINT_LOOKUP` is not
    /// `portable`; the portable code otherwise (and on other architectures).
    #[default]
    Auto,
    /// Always the portable code (tests compare the two paths with it).
    Portable,
}

/// Smallest λ for which ∫T = (Tᵢ − Tᵢ₊₁)/λ is used (below, the series).
const LAM_SMALL: f32 = 0.05;
/// Transmittances below this are flushed to 0 (keeps f32 out of denormals).
const T_FLUSH: f32 = 1e-30;
const LANES: usize = 8;
/// Largest l_max·|Δρ|·Δu over one interval (how far ln T may bend from
/// linear) before it is split: tight for independent emission, whose colour
/// weights T directly; loose for density emission, whose by-parts form only
/// weights T by Δκ.
const BEND_INDEPENDENT: f64 = 0.01;
const BEND_DENSITY: f64 = 1.0;
/// Largest estimated error of the colour integral, per unit of u (so at most
/// this over a segment), that the chord rule (ln T linear on an interval)
/// may make before an interval is split; r pieces divide an interval's
/// error by r². ln T bends from its chord by up to l·|Δρ|·Δu/8 over an
/// interval, and ∫ of the bend is 2/3 of that, so the estimate is
/// |Δκ|·l_max·|Δρ|·Δu/12 for density emission (the by-parts form weights
/// ∫T by Δκ) and κ·l_max²·|Δρ|·Δu²/12 for independent emission (C = l·∫κT).
/// The bend limits above alone let a steep colour ramp inside one interval
/// where ρ is steep (density), or a long bright segment (independent), err
/// by 1.0e-3–1.7e-3 at the grid nodes (tests/tables_prop.rs's pinned
/// cases); on Blunt Fin's smooth TF it splits no density interval.
const SPLIT_ERROR: f64 = 1e-4;
/// Most pieces one interval is split into.
const MAX_SPLIT: usize = 64;

impl Table3d {
    /// Bakes the table for `tf` (x in data units: denormalize a normalized TF
    /// first) over `domain`.
    pub fn build(tf: &TransferFunction, domain: &TableDomain, params: &Table3dParams) -> Result<Table3d, TableError> {
        check_res("table3d n_s", params.n_s, 2, MAX_AXIS)?;
        check_res("table3d n_l", params.n_l, 2, MAX_AXIS)?;
        let axis = Axis::for_params(tf, domain, params)?;
        Table3d::build_on_axis(tf, domain, params, axis)
    }

    /// Bakes the table on a given scalar axis, (scalar, grid index) knots as
    /// [`Table3d::s_knots`] returns them (e.g. an earlier table's, so that a
    /// TF edit that moved a node keeps the old samples; or knots placed by
    /// the caller). `params.s_axis` must not be `Uniform` (the knots say
    /// where the samples are); invalid knots are an error.
    pub fn build_with_knots(
        tf: &TransferFunction,
        domain: &TableDomain,
        params: &Table3dParams,
        knots: &[(f64, usize)],
    ) -> Result<Table3d, TableError> {
        check_res("table3d n_s", params.n_s, 2, MAX_AXIS)?;
        check_res("table3d n_l", params.n_l, 2, MAX_AXIS)?;
        if params.s_axis == ScalarAxis::Uniform {
            return Err(TableError::Invalid("knots given for a uniform scalar axis".into()));
        }
        let axis = Axis::from_knots(domain, params.n_s, knots).ok_or_else(|| {
            TableError::Invalid(format!(
                "{} scalar axis knots: need (s_lo, 0) … (s_hi, n_s − 1), both strictly increasing",
                knots.len()
            ))
        })?;
        Table3d::build_on_axis(tf, domain, params, axis)
    }

    fn build_on_axis(
        tf: &TransferFunction,
        domain: &TableDomain,
        params: &Table3dParams,
        axis: Axis,
    ) -> Result<Table3d, TableError> {
        let band = Band::for_axis(params.n_s, domain, &axis);
        let entries = band.pairs as u64 * params.n_l as u64;
        if entries > MAX_TABLE_ENTRIES {
            return Err(TableError::TooLarge { entries, max: MAX_TABLE_ENTRIES });
        }
        match params.build {
            Build3d::SliceRecurrence { oversampling } if !(0.01..=1024.0).contains(&oversampling) => {
                return Err(TableError::Invalid(format!("oversampling {oversampling} must be in [0.01, 1024]")));
            }
            Build3d::Adaptive { tolerance } if !(1e-8..=1e-2).contains(&tolerance) => {
                return Err(TableError::Invalid(format!("tolerance {tolerance} must be in [1e-8, 1e-2]")));
            }
            Build3d::Blend { steps, .. } => check_res("blend steps", steps as usize, 1, 1 << 16)?,
            _ => {}
        }
        let grid = Grid::new(domain, params, &axis);
        let values = match params.build {
            Build3d::Incremental => build_incremental(tf, &grid, &band, &axis, domain),
            build => {
                let mut values = vec![0.0f32; band.pairs * grid.n_l * 4];
                bake_pairs(tf, &grid, &band, build, &mut values, &|_, _| true);
                values
            }
        };
        let data = Storage::encode(values, 4, params.precision);
        Ok(Table3d::assemble(domain, params, axis, data).expect("built storage matches its layout"))
    }

    /// Reassembles a table from stored parts (e.g. a `.tetl` file): the
    /// scalar axis's knots (scalar, grid index) are required for
    /// [`ScalarAxis::TfNodes`] and ignored for `Uniform`. `None` when the
    /// knots are invalid or `data` does not hold the band's entries in RGBA.
    pub fn from_parts(
        domain: TableDomain,
        params: Table3dParams,
        s_knots: Option<&[(f64, usize)]>,
        data: Storage,
    ) -> Option<Table3d> {
        if params.n_s < 2 || params.n_l < 2 || params.n_s > MAX_AXIS || params.n_l > MAX_AXIS {
            return None;
        }
        let axis = match params.s_axis {
            ScalarAxis::Uniform => Axis::uniform(&domain, params.n_s),
            ScalarAxis::TfNodes | ScalarAxis::Data => Axis::from_knots(&domain, params.n_s, s_knots?)?,
        };
        Table3d::assemble(&domain, &params, axis, data)
    }

    fn assemble(domain: &TableDomain, params: &Table3dParams, axis: Axis, data: Storage) -> Option<Table3d> {
        let (domain, params) = (*domain, *params);
        let band = Band::for_axis(params.n_s, &domain, &axis);
        if data.channels() != 4 || data.len() != band.pairs * params.n_l * 4 || data.precision() != params.precision {
            return None;
        }
        let inv_ds = ((params.n_s - 1) as f64 / domain.scalar_span()) as f32;
        let inv_dl = ((params.n_l - 1) as f64 / domain.len_max_world) as f32;
        let mut t = Table3d {
            domain,
            params,
            band,
            axis: Box::new(axis),
            data,
            recon: Reconstruction::Trilinear,
            pair_gap: Vec::new(),
            depth: Vec::new(),
            inv_ds,
            inv_dl,
            kernel: LookupKernel::Auto,
        };
        t.update_reconstruction(|_, _| true);
        Some(t)
    }

    pub fn domain(&self) -> &TableDomain {
        &self.domain
    }
    pub fn params(&self) -> &Table3dParams {
        &self.params
    }
    pub fn storage(&self) -> &Storage {
        &self.data
    }
    /// Bytes the table holds: the band's entries as stored, plus (f32
    /// storage) the per-entry optical depths the lookup reads.
    pub fn memory_bytes(&self) -> usize {
        self.data.memory_bytes() + self.depth.len() * 4
    }
    /// Bytes the full n_s × n_s × n_l cube would take in the same precision
    /// (with its optical depths where this table keeps them, as
    /// [`Table3d::memory_bytes`]).
    pub fn full_memory_bytes(&self) -> usize {
        let entries = self.params.n_s * self.params.n_s * self.params.n_l;
        let depth = if self.depth.is_empty() { 0 } else { entries * 4 };
        entries * 4 * self.params.precision.bytes() + depth
    }

    /// How lookups interpolate (chosen at every bake, load and re-bake).
    pub fn reconstruction(&self) -> Reconstruction {
        self.recon
    }

    /// The largest gap between the trilinear and the optical-depth
    /// reconstructions' α half way between neighbouring entries (along l,
    /// and along Sb, which covers Sf by the table's symmetry in α): above
    /// [`RECONSTRUCTION_GAP`], lookups take the optical depth.
    pub fn reconstruction_gap(&self) -> f32 {
        self.pair_gap.iter().fold(0.0, |m, &g| m.max(g))
    }

    /// Recomputes the gaps of the pairs whose entries `which` selects (and
    /// of their row predecessors, whose Sb-neighbour they are), chooses the
    /// reconstruction, and brings the optical depths up to date. Rows in
    /// parallel. After the band changed, `which` must select every pair.
    fn update_reconstruction(&mut self, which: impl Fn(usize, usize) -> bool + Sync) {
        let n_l = self.params.n_l;
        let pairs = self.band.pairs;
        self.pair_gap.resize(pairs, 0.0);
        let (band, data) = (&self.band, &self.data);
        // α of pair p's entries.
        let alpha_of = |p: usize, out: &mut Vec<f32>| {
            out.clear();
            match data.as_f32() {
                Some(d) => out.extend(d[p * n_l * 4..(p + 1) * n_l * 4].chunks_exact(4).map(|e| e[3])),
                None => out.extend((0..n_l).map(|k| data.get4((p * n_l + k) * 4)[3])),
            }
        };
        // √T = √(1 − α): half way between two entries the trilinear α is
        // 1 − (T₀ + T₁)/2 and the optical-depth α is 1 − √(T₀T₁), a gap of
        // (√T₀ − √T₁)²/2 (no logarithm needed).
        let root_t_of = |p: usize, scratch: &mut Vec<f32>, out: &mut Vec<f32>| {
            alpha_of(p, scratch);
            out.clear();
            out.extend(scratch.iter().map(|&a| (1.0 - a).max(0.0).sqrt()));
        };
        // Lane-wise maxima (no NaN: √ of a clamped value), reduced at the end.
        let max_gap = |x: &[f32], y: &[f32]| {
            let mut m = [0.0f32; W];
            for (xc, yc) in x.chunks(W).zip(y.chunks(W)) {
                for i in 0..xc.len() {
                    let g = 0.5 * (xc[i] - yc[i]) * (xc[i] - yc[i]);
                    m[i] = if g > m[i] { g } else { m[i] };
                }
            }
            m.into_iter().fold(0.0f32, f32::max)
        };
        rows_mut(&mut self.pair_gap, band, 1).into_par_iter().for_each(|(a, gaps)| {
            let row = band.row(a);
            let (mut cur, mut next, mut scratch) = (Vec::new(), Vec::new(), Vec::new());
            let mut have_next = false;
            for b in row.clone().rev() {
                let p = band.pair(a, b);
                let has_next = b + 1 < row.end;
                if !(which(a, b) || (has_next && which(a, b + 1))) {
                    have_next = false;
                    continue;
                }
                // `next` gets the previous iteration's pair, (a, b + 1).
                std::mem::swap(&mut cur, &mut next);
                root_t_of(p, &mut scratch, &mut cur);
                let mut g = max_gap(&cur[..n_l - 1], &cur[1..]);
                if has_next {
                    if !have_next {
                        root_t_of(p + 1, &mut scratch, &mut next);
                    }
                    g = g.max(max_gap(&cur, &next));
                }
                gaps[b - row.start] = g;
                have_next = true;
            }
        });
        let recon = if self.reconstruction_gap() > RECONSTRUCTION_GAP {
            Reconstruction::OpticalDepth
        } else {
            Reconstruction::Trilinear
        };
        self.recon = recon;
        if recon == Reconstruction::Trilinear || self.data.as_f32().is_none() {
            self.depth = Vec::new();
            return;
        }
        let refill = self.depth.len() != pairs * n_l;
        if refill {
            self.depth = vec![0.0; pairs * n_l];
        }
        let band = &self.band;
        rows_mut(&mut self.depth, band, n_l).into_par_iter().for_each(|(a, depth)| {
            let row = band.row(a);
            let mut alpha = Vec::with_capacity(n_l);
            for b in row.clone() {
                if !(refill || which(a, b)) {
                    continue;
                }
                alpha_of(band.pair(a, b), &mut alpha);
                let out = &mut depth[(b - row.start) * n_l..(b - row.start + 1) * n_l];
                for (c, o) in alpha.chunks(W).zip(out.chunks_mut(W)) {
                    let mut x = [0.0f32; W];
                    x[..c.len()].copy_from_slice(c);
                    o.copy_from_slice(&optical_depths(f32x8::from(x)).to_array()[..c.len()]);
                }
            }
        });
    }
    /// Stored half-width of the band in grid steps (n_s − 1 when full; the
    /// widest row's for a non-uniform axis).
    pub fn band_half_width(&self) -> usize {
        self.band.w
    }

    /// The scalar axis as (scalar, grid index) knots with uniform steps
    /// between them: two knots for a uniform axis.
    pub fn s_knots(&self) -> Vec<(f64, usize)> {
        self.axis.knots()
    }

    /// The knots [`Table3d::s_knots`] would return for a table built from
    /// these inputs, without building it: for bakes outside this crate
    /// (tet_gpu's compute-shader bake) that must use the same axis.
    pub fn axis_knots(
        tf: &TransferFunction,
        domain: &TableDomain,
        params: &Table3dParams,
    ) -> Result<Vec<(f64, usize)>, TableError> {
        Ok(Axis::for_params(tf, domain, params)?.knots())
    }

    /// Whether the scalar axis has equal steps (a consumer may then map
    /// scalars to indices by one scale; tet_gpu's shader reads either axis).
    pub fn is_uniform_axis(&self) -> bool {
        self.axis.uniform
    }

    /// Grid value: scalar of index `a`.
    pub fn scalar_at(&self, a: usize) -> f64 {
        self.axis.grid[a]
    }
    /// Grid value: length of slice `k`.
    pub fn len_at(&self, k: usize) -> f64 {
        k as f64 * self.domain.len_max_world / (self.params.n_l - 1) as f64
    }

    /// The stored entry at grid indices, `None` outside the band.
    pub fn entry(&self, a: usize, b: usize, k: usize) -> Option<Rgba32> {
        if a >= self.params.n_s || b >= self.params.n_s || k >= self.params.n_l || !self.band.row(a).contains(&b) {
            return None;
        }
        Some(self.data.get4((self.band.pair(a, b) * self.params.n_l + k) * 4))
    }

    /// Slice k as an n_s × n_s RGBA image (row Sb, column Sf), zero outside
    /// the band: what `tetlut show` draws.
    pub fn slice_image(&self, k: usize) -> Vec<Rgba32> {
        let n = self.params.n_s;
        let mut out = vec![[0.0; 4]; n * n];
        for b in 0..n {
            for a in 0..n {
                if let Some(e) = self.entry(a, b, k.min(self.params.n_l - 1)) {
                    out[b * n + a] = e;
                }
            }
        }
        out
    }

    /// The lookup ([`Reconstruction`]); inputs outside the domain (and NaN)
    /// are clamped.
    #[inline]
    pub fn lookup(&self, sf: f32, sb: f32, len_world: f32) -> Rgba32 {
        self.gather_cell(&self.cell_of(sf, sb, len_world))
    }

    /// The lookup in cell `c`, any storage.
    #[inline(always)]
    fn gather_cell(&self, c: &Cell) -> Rgba32 {
        match self.data.as_f32() {
            Some(d) => self.gather_f32(d, c),
            None => self.gather(
                |b| {
                    let (e0, e1) = (self.data.get4(b), self.data.get4(b + 4));
                    [e0[0], e0[1], e0[2], e0[3], e1[0], e1[1], e1[2], e1[3]]
                },
                c,
            ),
        }
    }

    /// The lower corner and fractions of a lookup's cell (no table access).
    #[inline(always)]
    fn cell_of(&self, sf: f32, sb: f32, len_world: f32) -> Cell {
        let (xa, xb) = self.band_coords(sf, sb);
        let xk = (len_world * self.inv_dl).max(0.0).min((self.params.n_l - 1) as f32);
        // x is in [0, n − 1] (clamped, never NaN): an i32 cast is exact and
        // far cheaper than a saturating cast to usize.
        let split = |x: f32, n: usize| {
            let i = (x as i32).min(n as i32 - 2);
            (i as usize, x - i as f32)
        };
        let (a0, fa) = split(xa, self.params.n_s);
        let (b0, fb) = split(xb, self.params.n_s);
        let (k0, fk) = split(xk, self.params.n_l);
        Cell { a0, b0, k0, fa, fb, fk }
    }

    /// [`Table3d::gather`] on f32 storage: the 4 (Sf, Sb) corners' two
    /// l-neighbours are 8 contiguous floats each.
    #[inline(always)]
    fn gather_f32(&self, d: &[f32], c: &Cell) -> Rgba32 {
        self.gather(|b| d[b..b + 8].try_into().expect("8 floats"), c)
    }

    /// Float offsets of entries (a0, b0, k0) and (a0 + 1, b0, k0); pair
    /// (a, b + 1) follows pair (a, b) in its row, so the other two corners
    /// are n_l entries further.
    #[inline(always)]
    fn cell_bases(&self, c: &Cell) -> (usize, usize) {
        let nl = self.params.n_l;
        let base0 = (self.band.pair_off[c.a0].wrapping_add(c.b0) * nl + c.k0) * 4;
        let base1 = (self.band.pair_off[c.a0 + 1].wrapping_add(c.b0) * nl + c.k0) * 4;
        (base0, base1)
    }

    /// The lookup at `c` from the 8 entries around it, `load8(b)` giving
    /// the entries at float offsets b and b + 4 (k0 and k0 + 1 of a corner).
    /// Every storage and lookup path reconstructs here, so they agree bit
    /// for bit; a corner of weight 0 may lie outside the band (its offset
    /// wraps within the data, as `pair_off` is built) and adds 0.
    #[inline(always)]
    fn gather(&self, load8: impl Fn(usize) -> [f32; 8], c: &Cell) -> Rgba32 {
        let Cell { fa, fb, fk, .. } = *c;
        let nl = self.params.n_l;
        let (base0, base1) = self.cell_bases(c);
        let bases = [base0, base0 + nl * 4, base1, base1 + nl * 4];
        // (Explicit, not `array::map`: that was not inlined on this hot path.)
        let e = [load8(bases[0]), load8(bases[1]), load8(bases[2]), load8(bases[3])];
        if self.recon == Reconstruction::Trilinear {
            // Per corner: entries k0 and k0 + 1, interpolated in l (e0 + fk·(e1 − e0)).
            let lerp = |c: &[f32; 8]| {
                let (e0, e1) = (Vec4::new(c[0], c[1], c[2], c[3]), Vec4::new(c[4], c[5], c[6], c[7]));
                e0 + (e1 - e0) * fk
            };
            let (wa0, wa1, wb0, wb1) = (1.0 - fa, fa, 1.0 - fb, fb);
            let out = lerp(&e[0]) * (wa0 * wb0)
                + lerp(&e[1]) * (wa0 * wb1)
                + lerp(&e[2]) * (wa1 * wb0)
                + lerp(&e[3]) * (wa1 * wb1);
            return out.to_array();
        }
        let depth = if self.depth.is_empty() {
            // Non-f32 storage: the depths of the decoded entries.
            let alpha = f32x8::from([e[0][3], e[0][7], e[1][3], e[1][7], e[2][3], e[2][7], e[3][3], e[3][7]]);
            let t = optical_depths(alpha).to_array();
            [[t[0], t[1]], [t[2], t[3]], [t[4], t[5]], [t[6], t[7]]]
        } else {
            let d = |b: usize| [self.depth[b / 4], self.depth[b / 4 + 1]];
            [d(bases[0]), d(bases[1]), d(bases[2]), d(bases[3])]
        };
        reconstruct(&e, &depth, fa, fb, fk)
    }

    /// Forces the portable lookup, or lets the AVX2 kernel run where it can
    /// ([`LookupKernel`]); kept across [`Table3d::rebake`].
    pub fn set_lookup_kernel(&mut self, kernel: LookupKernel) {
        self.kernel = kernel;
    }

    /// [`Table3d::set_lookup_kernel`] by value.
    pub fn with_lookup_kernel(mut self, kernel: LookupKernel) -> Self {
        self.kernel = kernel;
        self
    }

    /// The kernel batched lookups run on now: `"avx2"` or `"portable"`.
    pub fn lookup_kernel_in_use(&self) -> &'static str {
        #[cfg(target_arch = "x86_64")]
        if self.kernel == LookupKernel::Auto && crate::simd_x86::available() {
            return "avx2";
        }
        "portable"
    }

    /// The AVX2 kernel's batched lookup into `out`; `false` (nothing
    /// written) where it does not run.
    #[inline]
    pub(crate) fn shade_batch_lean(&self, segs: &SegmentBatch, out: &mut [Rgba32; method::BATCH]) -> bool {
        #[cfg(target_arch = "x86_64")]
        if self.kernel == LookupKernel::Auto {
            let axis = &*self.axis;
            let lean = crate::simd_x86::Lean {
                uniform: axis.uniform,
                lo: if axis.uniform { self.domain.s_lo as f32 } else { axis.lo },
                hi: axis.hi,
                inv_ds: self.inv_ds,
                reach: self.band.reach,
                max_ds: self.domain.max_ds as f32,
                bucket: &axis.bucket,
                bucket_inv: axis.bucket_inv,
                bucket_j: &axis.bucket_j,
                bucket2: &axis.bucket2,
                seg_s0: &axis.seg_s0,
                seg_s1: &axis.seg_s1,
                seg_x0: &axis.seg_x0,
                seg_inv: &axis.seg_inv,
                n_s: self.params.n_s,
                n_l: self.params.n_l,
                inv_dl: self.inv_dl,
                pair_off: &self.band.pair_off32,
                data: self.data.raw(),
            };
            if self.recon == Reconstruction::Trilinear {
                return crate::simd_x86::shade_batch(&lean, segs, out);
            }
            // Optical depth: the kernel's cells, the portable gather.
            let mut c = crate::simd_x86::Cells::default();
            if !crate::simd_x86::cells(&lean, segs, &mut c) {
                return false;
            }
            for (i, o) in out.iter_mut().enumerate().take(segs.len.min(method::BATCH)) {
                // The kernel's corners are in [0, n − 2] (never negative).
                let cell = Cell {
                    a0: c.a0[i] as usize,
                    b0: c.b0[i] as usize,
                    k0: c.k0[i] as usize,
                    fa: c.fa[i],
                    fb: c.fb[i],
                    fk: c.fk[i],
                };
                *o = self.gather_cell(&cell);
            }
            return true;
        }
        let _ = (segs, out);
        false
    }
}

/// How [`Table3d`] interpolates between its entries.
///
/// Trilinear interpolation of premultiplied RGBA is what Röttger & Ertl 2002 does and
/// is exact enough while α changes little from entry to entry. Where a
/// grid step holds much optical depth (long cells through dense regions:
/// the stars' Delaunay mesh has l up to 562 world units, Δl = 2.2), α bends
/// within a step and trilinear α misses by up to 1e-2; interpolating the
/// optical depth instead is exact along l and far closer along s. A table
/// takes [`Reconstruction::OpticalDepth`] when the two differ by more than
/// [`RECONSTRUCTION_GAP`] half way between some pair of neighbouring
/// entries ([`Table3d::reconstruction_gap`]), and the cheaper trilinear
/// lookup otherwise (it reads no optical depths: the four CFD and volume
/// bundles' tables stay trilinear, bit for bit as before).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Reconstruction {
    /// Premultiplied RGBA trilinear.
    Trilinear,
    /// Optical depth −ln(1 − α) trilinear, colour trilinear scaled by α
    /// over the trilinear α ([`reconstruct`]).
    OpticalDepth,
}

impl Reconstruction {
    /// The name `tetlut` prints (`trilinear`, `optical-depth`).
    pub fn id(self) -> &'static str {
        match self {
            Reconstruction::Trilinear => "trilinear",
            Reconstruction::OpticalDepth => "optical-depth",
        }
    }
}

/// Largest half-way gap between the reconstructions for which a table
/// stays [`Reconstruction::Trilinear`]: a tenth of the 1e-3 accuracy target.
pub const RECONSTRUCTION_GAP: f32 = 1e-4;

/// Transmittance floor of the reconstruction (optical depth 69). An f32 α
/// resolves depths up to 16.6 only (1 − α ≥ 2⁻²⁴ below 1); an entry with
/// α = 1 is usually far deeper, and counting it as 69 makes a lookup between
/// it and a depth-τ entry at weight w give 1 − e^{−(1−w)τ−69w}: opaque
/// within 1e-3 from w = 0.1, as the true depths would. (Counting it as 16.6
/// instead leaves 2.4e-4 of transmittance half way between two opaque
/// slices; neither choice moves the four bundles' errors.)
const MIN_TRANSMITTANCE: f32 = 1e-30;

/// Below this α (and optical depth) the reconstruction uses series: 1 − α
/// in f32 drops α's low bits (all of them below 6e-8), which would zero a
/// faint entry's depth and, through the colour scale, its colour.
const SERIES_BELOW: f32 = 1.0 / 64.0;

/// −ln(max(1 − α, [`MIN_TRANSMITTANCE`])) lane by lane: the optical depth
/// of an entry, as the lookup interpolates it; α + α²/2 + α³/3 + α⁴/4
/// below [`SERIES_BELOW`] (relative error < 2e-9).
#[inline(always)]
fn optical_depths(alpha: f32x8) -> f32x8 {
    let log = -vmax(f32x8::ONE - alpha, f32x8::splat(MIN_TRANSMITTANCE)).ln();
    let (half, third, quarter) = (f32x8::splat(0.5), f32x8::splat(1.0 / 3.0), f32x8::splat(0.25));
    let series = alpha * (f32x8::ONE + alpha * (half + alpha * (third + alpha * quarter)));
    alpha.cmp_lt(f32x8::splat(SERIES_BELOW)).blend(series, log)
}

/// 1 − e^{−τ} for τ ≥ 0, by its series below [`SERIES_BELOW`] (relative
/// error < 2e-9), so a faint lookup keeps its α to f32 precision.
#[inline(always)]
fn alpha_of_depth(tau: f32) -> f32 {
    if tau < SERIES_BELOW {
        tau * (1.0 - tau * (0.5 - tau * (1.0 / 6.0 - tau * (1.0 / 24.0))))
    } else {
        1.0 - (-tau).exp()
    }
}

/// A lookup from the 8 entries around it: `e[c]` holds corner c's entries
/// at slices k0 and k0 + 1 (RGBA, RGBA) and `depth[c]` their
/// [`optical_depths`], corners in the order (a0, b0), (a0, b0 + 1),
/// (a0 + 1, b0), (a0 + 1, b0 + 1); `fa`, `fb`, `fk` are the fractions
/// along Sf, Sb and l.
///
/// The optical depth −ln(1 − α) is interpolated trilinearly, not α: for
/// one (Sf, Sb) it is linear in l (l times the mean extinction), and across
/// (Sf, Sb) it stays smooth where α saturates, so l adds no error to α and
/// long segments through dense cells lose most of theirs (the stars'
/// Delaunay mesh: cell-segment max error 1.3e-2 → 4.4e-4, 128×128×256).
/// The colour is the trilinear colour scaled by α over the trilinear α: it
/// keeps the trilinear chromaticity, is exact in l where the colour is
/// constant (C = κ·α with density emission, C = κ·α/ρ with independent
/// emission), and keeps C ≤ α·max κ. Every lookup path reconstructs here
/// from the same depths, so they agree bit for bit.
#[inline(always)]
fn reconstruct(e: &[[f32; 8]; 4], depth: &[[f32; 2]; 4], fa: f32, fb: f32, fk: f32) -> Rgba32 {
    let (wa0, wa1, wb0, wb1) = (1.0 - fa, fa, 1.0 - fb, fb);
    let w = [wa0 * wb0, wa0 * wb1, wa1 * wb0, wa1 * wb1];
    let lerp_l = |c: &[f32; 8]| -> Vec4 {
        let (e0, e1) = (Vec4::new(c[0], c[1], c[2], c[3]), Vec4::new(c[4], c[5], c[6], c[7]));
        e0 + (e1 - e0) * fk
    };
    let lin = lerp_l(&e[0]) * w[0] + lerp_l(&e[1]) * w[1] + lerp_l(&e[2]) * w[2] + lerp_l(&e[3]) * w[3];
    let lerp_d = |d: &[f32; 2]| d[0] + (d[1] - d[0]) * fk;
    let tau = lerp_d(&depth[0]) * w[0] + lerp_d(&depth[1]) * w[1] + lerp_d(&depth[2]) * w[2] + lerp_d(&depth[3]) * w[3];
    let a = alpha_of_depth(tau.max(0.0));
    // lin.w = 0 only where every weighted α is 0, and then a = 0 too: the
    // colour stays (independent emission glows without absorbing).
    let scale = if lin.w > 0.0 { a / lin.w } else { 1.0 };
    [lin.x * scale, lin.y * scale, lin.z * scale, a]
}

/// What [`Table3d::rebake`] did.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct RebakeStats {
    /// (Sf, Sb) pairs the table stores.
    pub pairs: usize,
    /// Pairs computed again (all of them after a full bake).
    pub pairs_rebaked: usize,
    /// Why the whole table was baked again, if it was.
    pub full: Option<FullRebake>,
}

/// Why [`Table3d::rebake`] baked the whole table.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum FullRebake {
    /// The new TF puts the scalar samples elsewhere (a control point was
    /// added, removed or moved along s, on a non-uniform axis).
    AxisChanged,
    /// Unit distance, emission model, widgets or normalization changed:
    /// every entry depends on them.
    GlobalChange,
    /// The build is not per pair (`Incremental`).
    Build,
    /// Storage other than f32 (unorm's scale is the whole table's; f16
    /// is rebuilt for simplicity).
    Precision,
}

/// Where two TFs differ, as closed scalar intervals outside which both
/// evaluate (colour, extinction, control points) bit for bit alike: per
/// node list, from the last node of their common prefix to the first of
/// their common suffix (±∞ when there is none). `None`: they differ
/// everywhere (unit distance, emission, normalization, widgets).
fn changed_spans(old: &TransferFunction, new: &TransferFunction) -> Option<Vec<(f64, f64)>> {
    if old.unit_distance().to_bits() != new.unit_distance().to_bits()
        || old.emission() != new.emission()
        || old.normalized() != new.normalized()
        || old.widgets() != new.widgets()
    {
        return None;
    }
    fn span<T>(old: &[T], new: &[T], x: impl Fn(&T) -> f64, same: impl Fn(&T, &T) -> bool) -> Option<(f64, f64)> {
        let prefix = old.iter().zip(new).take_while(|(a, b)| same(a, b)).count();
        if prefix == old.len() && prefix == new.len() {
            return None;
        }
        let suffix = old.iter().rev().zip(new.iter().rev()).take_while(|(a, b)| same(a, b)).count();
        // The common prefix and suffix may overlap when one list is the
        // other with a node removed: keep them apart.
        let suffix = suffix.min(old.len() - prefix).min(new.len() - prefix);
        let lo = if prefix == 0 { f64::NEG_INFINITY } else { x(&old[prefix - 1]) };
        let hi = if suffix == 0 { f64::INFINITY } else { x(&old[old.len() - suffix]) };
        Some((lo, hi))
    }
    let bits = |v: f64| v.to_bits();
    let colour = span(
        old.color_nodes(),
        new.color_nodes(),
        |c| c.x,
        |a, b| bits(a.x) == bits(b.x) && a.rgb.map(bits) == b.rgb.map(bits),
    );
    let opacity = span(
        old.opacity_nodes(),
        new.opacity_nodes(),
        |o| o.x,
        |a, b| bits(a.x) == bits(b.x) && bits(a.a) == bits(b.a),
    );
    Some(colour.into_iter().chain(opacity).collect())
}

impl Table3d {
    /// Re-bakes this table, baked from `old_tf`, for `new_tf` (both in data
    /// units, as [`Table3d::build`] takes them), computing again only the
    /// (Sf, Sb) pairs whose scalar interval meets the part of the TF that
    /// changed: the result equals `Table3d::build(new_tf, self.domain(),
    /// self.params())` bit for bit (tests/table3d_rebake.rs).
    ///
    /// An entry depends on the TF only over its pair's interval [Sf, Sb]
    /// (colour, extinction and control points there; the optical depth is
    /// integrated from Sf, not from a prefix over the whole TF), so a value
    /// or colour edit of one control point re-bakes the pairs that meet the
    /// span between its neighbours. Every pair is baked again
    /// ([`RebakeStats::full`] says why) when the axis the new TF gets
    /// differs (on a `TfNodes` or `Data` axis every control point is a
    /// sample, so moving, adding or removing one moves samples, and every
    /// entry moves with them) or a global field changed, both in the
    /// table's own buffer; and by [`Table3d::build`] for the `Incremental`
    /// build and for storage other than f32.
    /// `old_tf` must be the TF the table was baked from; otherwise the
    /// unchanged pairs keep the old TF's values.
    pub fn rebake(&mut self, old_tf: &TransferFunction, new_tf: &TransferFunction) -> Result<RebakeStats, TableError> {
        let full = |t: &mut Table3d, why: FullRebake| -> Result<RebakeStats, TableError> {
            let kernel = t.kernel;
            *t = Table3d::build(new_tf, &t.domain, &t.params)?;
            t.kernel = kernel;
            Ok(RebakeStats { pairs: t.band.pairs, pairs_rebaked: t.band.pairs, full: Some(why) })
        };
        if self.params.build == Build3d::Incremental {
            return full(self, FullRebake::Build);
        }
        if self.params.precision != Precision::F32 {
            return full(self, FullRebake::Precision);
        }
        let axis = Axis::for_params(new_tf, &self.domain, &self.params)?;
        let spans = if axis != *self.axis {
            Err(FullRebake::AxisChanged)
        } else {
            changed_spans(old_tf, new_tf).ok_or(FullRebake::GlobalChange)
        };
        let n_l = self.params.n_l;
        let spans = match spans {
            Ok(spans) => spans,
            Err(why) => {
                // Every pair, into the same buffer (resized when the band
                // changed with the axis): no fresh 44 MiB to fault in.
                let band = Band::for_axis(self.params.n_s, &self.domain, &axis);
                let entries = band.pairs as u64 * n_l as u64;
                if entries > MAX_TABLE_ENTRIES {
                    return Err(TableError::TooLarge { entries, max: MAX_TABLE_ENTRIES });
                }
                let grid = Grid::new(&self.domain, &self.params, &axis);
                let values = self.data.f32_vec_mut().expect("f32 storage checked above");
                values.resize(band.pairs * n_l * 4, 0.0);
                bake_pairs(new_tf, &grid, &band, self.params.build, values, &|_, _| true);
                let pairs = band.pairs;
                (self.axis, self.band) = (Box::new(axis), band);
                self.update_reconstruction(|_, _| true);
                return Ok(RebakeStats { pairs, pairs_rebaked: pairs, full: Some(why) });
            }
        };
        let grid = Grid::new(&self.domain, &self.params, &self.axis);
        let dirty = |a: usize, b: usize| {
            let (lo, hi) = (grid.s(a).min(grid.s(b)), grid.s(a).max(grid.s(b)));
            spans.iter().any(|&(x0, x1)| x0 <= hi && lo <= x1)
        };
        let pairs_rebaked: usize =
            (0..self.params.n_s).map(|a| self.band.row(a).filter(|&b| dirty(a, b)).count()).sum();
        let values = self.data.f32_vec_mut().expect("f32 storage checked above");
        bake_pairs(new_tf, &grid, &self.band, self.params.build, values, &dirty);
        self.update_reconstruction(dirty);
        Ok(RebakeStats { pairs: self.band.pairs, pairs_rebaked, full: None })
    }
}

/// A lookup's lower grid corner and fractional position in its cell.
#[derive(Debug, Clone, Copy, Default)]
struct Cell {
    a0: usize,
    b0: usize,
    k0: usize,
    fa: f32,
    fb: f32,
    fk: f32,
}

/// Segments whose cells [`SegmentShader::shade_span`] locates before
/// reading any entry.
const SPAN_BLOCK: usize = 64;

impl Table3d {
    /// Fractional grid indices (xa, xb) of a lookup: clamped to the axis,
    /// and xb to within the domain's max_ds of xa (so every corner is in the
    /// band). f32::max/min drop NaN, so NaN lands on the low edge.
    #[inline(always)]
    fn band_coords(&self, sf: f32, sb: f32) -> (f32, f32) {
        if self.axis.uniform {
            let top = (self.params.n_s - 1) as f32;
            let lo = self.domain.s_lo as f32;
            let xa = ((sf - lo) * self.inv_ds).max(0.0).min(top);
            let xb = ((sb - lo) * self.inv_ds).max(0.0).min(top);
            (xa, xb.max(xa - self.band.reach).min(xa + self.band.reach))
        } else {
            let (lo, hi, ds) = (self.axis.lo, self.axis.hi, self.domain.max_ds as f32);
            let sf = sf.max(lo).min(hi);
            let sb = sb.max(lo).min(hi).max(sf - ds).min(sf + ds);
            (self.axis.x_of(sf), self.axis.x_of(sb))
        }
    }
}

impl Table3d {
    /// [`Table3d::band_coords`] for eight lanes (the first `m` valid; the
    /// rest computed on stale, finite inputs and ignored). NaN inputs are
    /// replaced first by what `f32::max` makes of them in the scalar path.
    #[inline(always)]
    fn band_coords_lanes(&self, sf_in: f32x8, sb_in: f32x8, m: usize) -> (f32x8, f32x8) {
        if self.axis.uniform {
            let top = f32x8::splat((self.params.n_s - 1) as f32);
            let lo = f32x8::splat(self.domain.s_lo as f32);
            let (inv, reach) = (f32x8::splat(self.inv_ds), f32x8::splat(self.band.reach));
            let (sf, sb) = (no_nan(sf_in, lo), no_nan(sb_in, lo));
            let xa = vmin(vmax((sf - lo) * inv, f32x8::ZERO), top);
            let b = vmin(vmax((sb - lo) * inv, f32x8::ZERO), top);
            (xa, vmin(vmax(b, xa - reach), xa + reach))
        } else {
            let (lo, hi) = (f32x8::splat(self.axis.lo), f32x8::splat(self.axis.hi));
            let ds = f32x8::splat(self.domain.max_ds as f32);
            let sf = vmin(vmax(no_nan(sf_in, lo), lo), hi);
            let b = vmin(vmax(no_nan(sb_in, lo), lo), hi);
            let sb = vmin(vmax(b, sf - ds), sf + ds);
            (self.axis.x_of_lanes(sf, m), self.axis.x_of_lanes(sb, m))
        }
    }
}

/// Lanes of [`SegmentShader::shade_batch`]'s lane-wise arithmetic.
const W: usize = 8;

impl SegmentShader for Table3d {
    fn method(&self) -> Method {
        Method::Table3d
    }
    fn shade(&self, seg: &Segment) -> Rgba32 {
        self.lookup(seg.s_front, seg.s_back, seg.len_world)
    }
    /// Eight segments at a time: the cells are located with the same values
    /// as [`Table3d::cell_of`] by lane-wise arithmetic that vectorizes (only
    /// the non-uniform axis's bucket reads and the entries are per lane).
    /// Where the CPU has AVX2 and F16C ([`LookupKernel::Auto`]), the
    /// `simd_x86` kernel does it instead, on every storage, with the same
    /// values bit for bit (for optical-depth tables it locates the cells
    /// and the gather below finishes).
    fn shade_batch(&self, segs: &SegmentBatch, out: &mut [Rgba32; method::BATCH]) {
        if self.shade_batch_lean(segs, out) {
            return;
        }
        let n = segs.len.min(method::BATCH);
        let Some(d) = self.data.as_f32() else {
            for (i, o) in out.iter_mut().enumerate().take(n) {
                *o = self.lookup(segs.s_front[i], segs.s_back[i], segs.len_world[i]);
            }
            return;
        };
        // Two passes: locate every cell (lane-wise arithmetic), then gather
        // (a short loop of independent reads whose cache misses overlap).
        let mut cells = [Cell::default(); method::BATCH];
        let (top_s, top_l) = (f32x8::splat((self.params.n_s - 2) as f32), f32x8::splat((self.params.n_l - 2) as f32));
        let (inv_dl, xk_max) = (f32x8::splat(self.inv_dl), f32x8::splat((self.params.n_l - 1) as f32));
        for blk in (0..n).step_by(W) {
            let m = (n - blk).min(W);
            let lanes = |a: &[f32; method::BATCH]| -> f32x8 {
                let v: [f32; W] = a[blk..blk + W].try_into().expect("BATCH is a multiple of W");
                f32x8::from(v)
            };
            let (xa, xb) = self.band_coords_lanes(lanes(&segs.s_front), lanes(&segs.s_back), m);
            let len = no_nan(lanes(&segs.len_world), f32x8::ZERO);
            let xk = vmin(vmax(len * inv_dl, f32x8::ZERO), xk_max);
            // Cell corner min(⌊x⌋, n − 2) (x ≥ 0: truncation of the clamped value) and fraction.
            let (a0, b0, k0) =
                (vmin(xa, top_s).fast_trunc_int(), vmin(xb, top_s).fast_trunc_int(), vmin(xk, top_l).fast_trunc_int());
            let fa = (xa - f32x8::from_i32x8(a0)).to_array();
            let fb = (xb - f32x8::from_i32x8(b0)).to_array();
            let fk = (xk - f32x8::from_i32x8(k0)).to_array();
            let (a0, b0, k0) = (a0.to_array(), b0.to_array(), k0.to_array());
            for l in 0..m {
                cells[blk + l] = Cell {
                    a0: a0[l] as usize,
                    b0: b0[l] as usize,
                    k0: k0[l] as usize,
                    fa: fa[l],
                    fb: fb[l],
                    fk: fk[l],
                };
            }
        }
        for (c, o) in cells[..n].iter().zip(out.iter_mut()) {
            *o = self.gather_f32(d, c);
        }
    }

    fn shade_span(&self, segs: &[Segment], out: &mut [Rgba32]) {
        let mut done = 0;
        if self.lookup_kernel_in_use() == "avx2" {
            // Through the batched kernel, BATCH segments at a time (the same
            // values: every path is bit-identical to `lookup`).
            let mut batch = SegmentBatch::default();
            let mut rgba = [[0.0f32; 4]; method::BATCH];
            for (sb, ob) in segs.chunks(method::BATCH).zip(out.chunks_mut(method::BATCH)) {
                for (i, seg) in sb.iter().enumerate() {
                    (batch.s_front[i], batch.s_back[i], batch.len_world[i]) = (seg.s_front, seg.s_back, seg.len_world);
                }
                batch.len = sb.len();
                if !self.shade_batch_lean(&batch, &mut rgba) {
                    break;
                }
                let k = ob.len().min(sb.len());
                ob[..k].copy_from_slice(&rgba[..k]);
                done += k;
            }
        }
        let (segs, out) = (&segs[done.min(segs.len())..], &mut out[done..]);
        match self.data.as_f32() {
            Some(d) => {
                // Two passes per block: locating a cell is arithmetic (and,
                // on a non-uniform axis, a bucket lookup and a rare search);
                // the entries are cache misses. Kept apart, the second loop
                // is short enough that the CPU overlaps many segments'
                // misses, whatever the axis (one loop: 91 ns per segment on
                // the TF-node axis against 42 on the uniform, on Blunt Fin).
                let mut cells = [Cell::default(); SPAN_BLOCK];
                for (sb, ob) in segs.chunks(SPAN_BLOCK).zip(out.chunks_mut(SPAN_BLOCK)) {
                    for (seg, c) in sb.iter().zip(cells.iter_mut()) {
                        *c = self.cell_of(seg.s_front, seg.s_back, seg.len_world);
                    }
                    for (c, o) in cells.iter().zip(ob.iter_mut()) {
                        *o = self.gather_f32(d, c);
                    }
                }
            }
            None => {
                for (seg, o) in segs.iter().zip(out.iter_mut()) {
                    *o = self.lookup(seg.s_front, seg.s_back, seg.len_world);
                }
            }
        }
    }
}

/// Grid positions in f64.
struct Grid {
    scalars: Vec<f64>,
    dl: f64,
    n_l: usize,
}

impl Grid {
    fn new(d: &TableDomain, p: &Table3dParams, axis: &Axis) -> Grid {
        Grid { scalars: axis.grid.clone(), dl: d.len_max_world / (p.n_l - 1) as f64, n_l: p.n_l }
    }
    fn s(&self, a: usize) -> f64 {
        self.scalars[a]
    }
}

/// Splits the output into one mutable slice per row of the band.
fn rows_mut<'a>(values: &'a mut [f32], band: &Band, per_pair: usize) -> Vec<(usize, &'a mut [f32])> {
    let mut rest = values;
    let mut out = Vec::with_capacity(band.n_s);
    for a in 0..band.n_s {
        let len = (band.row_start[a + 1] - band.row_start[a]) * per_pair;
        let (row, tail) = rest.split_at_mut(len);
        out.push((a, row));
        rest = tail;
    }
    out
}

/// Per-pair arrays of the recurrence build, reused across pairs.
#[derive(Default)]
struct PairScratch {
    g: Vec<f32>,
    t: Vec<f32>,
    c: Vec<f32>,
    inv_c: Vec<f32>,
    /// Independent emission: κ at each interval's start; density: unused.
    w: [Vec<f32>; 3],
    /// κ's increment over each interval.
    dw: [Vec<f32>; 3],
    p: Vec<f64>,
    u: Vec<f64>,
    nodes: Vec<f64>,
}

/// Computes, in place, every pair (a, b) of `values` (the band's layout)
/// that `select` picks, by a build whose entries depend only on the TF over
/// the pair's own scalar interval (every build but `Incremental`): what a
/// full bake and [`Table3d::rebake`] share, so a re-baked pair is
/// bit-for-bit the full bake's.
fn bake_pairs(
    tf: &TransferFunction,
    grid: &Grid,
    band: &Band,
    build: Build3d,
    values: &mut [f32],
    select: &(dyn Fn(usize, usize) -> bool + Sync),
) {
    let n_l = grid.n_l;
    let independent = tf.emission() == Emission::Independent;
    let rows = rows_mut(values, band, n_l * 4)
        .into_iter()
        .filter(|(a, _)| band.row(*a).any(|b| select(*a, b)))
        .collect::<Vec<_>>();
    let pairs = |row: &mut [f32], a: usize, f: &mut dyn FnMut(usize, &mut [f32])| {
        for (j, b) in band.row(a).enumerate() {
            if select(a, b) {
                f(b, &mut row[j * n_l * 4..(j + 1) * n_l * 4]);
            }
        }
    };
    let recurrence = |rows: Vec<(usize, &mut [f32])>, o: f32| {
        rows.into_par_iter().for_each_init(PairScratch::default, |sc, (a, row)| {
            pairs(row, a, &mut |b, out| recurrence_pair(tf, grid, a, b, o, independent, sc, out));
        })
    };
    match build {
        Build3d::SliceRecurrence { oversampling } => recurrence(rows, oversampling),
        Build3d::Adaptive { .. } if independent => recurrence(rows, ADAPTIVE_INDEPENDENT_OVERSAMPLING),
        Build3d::Adaptive { tolerance } => {
            let kf: Vec<f32> = (0..n_l).map(|k| k as f32).collect();
            let inv_k: Vec<f32> = (0..n_l).map(|k| if k == 0 { 0.0 } else { 1.0 / k as f32 }).collect();
            rows.into_par_iter().for_each_init(AdaptiveScratch::default, |sc, (a, row)| {
                pairs(row, a, &mut |b, out| adaptive_pair(tf, grid, a, b, tolerance as f64, &kf, &inv_k, sc, out));
            })
        }
        Build3d::Blend { steps, accumulation } => rows.into_par_iter().for_each_init(
            || (Vec::new(), Vec::new()),
            |(rho, kap), (a, row)| {
                pairs(row, a, &mut |b, out| blend_pair(tf, grid, a, b, steps as usize, accumulation, rho, kap, out));
            },
        ),
        Build3d::Exact => rows.into_par_iter().for_each_init(Vec::new, |scratch, (a, row)| {
            pairs(row, a, &mut |b, out| {
                out[..4].fill(0.0);
                for k in 1..n_l {
                    let px = integrate_segment_with(tf, grid.s(a), grid.s(b), k as f64 * grid.dl, scratch);
                    for (oc, v) in out[k * 4..k * 4 + 4].iter_mut().zip(px.to_array()) {
                        *oc = v as f32;
                    }
                }
            });
        }),
        Build3d::Incremental => unreachable!("bake_pairs: the incremental build is not per pair"),
    }
}

#[allow(clippy::too_many_arguments)]
fn recurrence_pair(
    tf: &TransferFunction,
    grid: &Grid,
    a: usize,
    b: usize,
    oversampling: f32,
    independent: bool,
    sc: &mut PairScratch,
    out: &mut [f32],
) {
    let (sf, sb) = (grid.s(a), grid.s(b));
    // Sample positions u ∈ [0, 1] along the segment: a uniform grid of
    // ⌈o·|b − a|⌉ intervals plus every TF node in between (so κ and ρ are
    // linear on each interval), and intervals over which ρ changes enough
    // to bend ln T (by l_max·|Δρ|·Δu), or whose estimated colour error is
    // too large (SPLIT_ERROR), are split further.
    sc.u.clear();
    sc.u.push(0.0);
    if a != b {
        let m = ((oversampling as f64 * a.abs_diff(b) as f64).ceil() as usize).max(1);
        sc.u.extend((1..m).map(|i| i as f64 / m as f64));
        sc.nodes.clear();
        tf.breakpoints_between(sf.min(sb), sf.max(sb), &mut sc.nodes);
        sc.u.extend(sc.nodes.iter().map(|&x| (x - sf) / (sb - sf)).filter(|&u| u > 0.0 && u < 1.0));
        sc.u.push(1.0);
        sc.u.sort_by(f64::total_cmp);
        sc.u.dedup();
        let bend = if independent { BEND_INDEPENDENT } else { BEND_DENSITY };
        let len_max = grid.dl * (grid.n_l - 1) as f64;
        let mut split = Vec::with_capacity(sc.u.len());
        split.push(0.0);
        let mut rho0 = tf.extinction(sf);
        let mut kap0 = tf.color(sf);
        // Optical depth at l_max in front of the interval.
        let mut depth0 = 0.0f64;
        for w in sc.u.windows(2) {
            let s1 = sf + (sb - sf) * w[1];
            let rho1 = tf.extinction(s1);
            let du = w[1] - w[0];
            let l_drho = len_max * (rho1 - rho0).abs();
            let kap1 = tf.color(s1);
            // Error estimate per unit u times r² (SPLIT_ERROR), at the
            // slice where it peaks: at l = x·l_max the bend is x times its
            // l_max value (x² with independent emission's l·∫κT) and the
            // transmittance in front at most e^{−x·depth0}.
            let err_r2 = if independent {
                let k = (0..3).map(|c| kap0[c].max(kap1[c])).fold(0.0, f64::max);
                k * len_max * l_drho * du / 12.0 * attenuation(depth0)
            } else {
                let dk = (0..3).map(|c| (kap1[c] - kap0[c]).abs()).fold(0.0, f64::max);
                dk * l_drho / 12.0 * attenuation_linear(depth0)
            };
            let r = (l_drho * du / bend).ceil().max((err_r2 / SPLIT_ERROR).sqrt().ceil());
            let r = (r as usize).clamp(1, MAX_SPLIT);
            kap0 = kap1;
            split.extend((1..r).map(|j| w[0] + (w[1] - w[0]) * (j as f64 / r as f64)));
            split.push(w[1]);
            depth0 += len_max * du * 0.5 * (rho0 + rho1);
            rho0 = rho1;
        }
        sc.u = split;
    } else {
        sc.u.push(1.0);
    }
    let n = sc.u.len() - 1;
    let n_pad = n.div_ceil(LANES) * LANES;
    let s_of = |u: f64| if u >= 1.0 { sb } else { sf + (sb - sf) * u };
    // D_i: ∫₀^{u_i} ρ(s(v)) dv, exact by the trapezoid rule (ρ is linear
    // on every interval) and local: it depends on the TF over [Sf, Sb] only
    // (a prefix integral from the TF's first node would carry the rounding
    // of everything before Sf, and a TF edit there would change this pair
    // by rounding: Table3d::rebake relies on it not doing so).
    sc.p.clear();
    if a == b {
        let rho = tf.extinction(sf);
        sc.p.extend([0.0, rho]);
    } else {
        sc.p.push(0.0);
        let mut rho0 = tf.extinction(sf);
        for w in sc.u.windows(2) {
            let rho1 = tf.extinction(s_of(w[1]));
            let d = sc.p[sc.p.len() - 1] + (w[1] - w[0]) * 0.5 * (rho0 + rho1);
            sc.p.push(d);
            rho0 = rho1;
        }
    }
    let d = &sc.p;
    sc.g.clear();
    sc.g.extend(d.iter().map(|&di| (-grid.dl * di).exp() as f32));
    sc.g.resize(n_pad + 1, 0.0);
    sc.t.clear();
    sc.t.resize(n + 1, 1.0);
    sc.t.resize(n_pad + 1, 0.0);
    sc.c.clear();
    sc.c.extend((0..n).map(|i| (grid.dl * (d[i + 1] - d[i])) as f32));
    sc.c.resize(n_pad, 0.0);
    let (k_first, k_last) = (tf.color(sf), tf.color(sb));
    for w in sc.w.iter_mut().chain(sc.dw.iter_mut()) {
        w.clear();
    }
    let mut prev = k_first;
    for i in 0..n {
        let next = tf.color(s_of(sc.u[i + 1]));
        // Independent emission integrates over u, so its weights carry the
        // interval width; density emission's do not.
        let width = if independent { sc.u[i + 1] - sc.u[i] } else { 1.0 };
        for ch in 0..3 {
            if independent {
                sc.w[ch].push((prev[ch] * width) as f32);
            }
            sc.dw[ch].push(((next[ch] - prev[ch]) * width) as f32);
        }
        prev = next;
    }
    for w in sc.w.iter_mut().chain(sc.dw.iter_mut()) {
        w.resize(n_pad, 0.0);
    }
    out[..4].fill(0.0);
    sc.inv_c.clear();
    sc.inv_c.extend(sc.c.iter().map(|&c| if c > 0.0 { 1.0 / c } else { 0.0 }));
    let (g, t, c, inv_c) = (&sc.g[..], &mut sc.t[..], &sc.c[..], &sc.inv_c[..]);
    let [wr, wg, wb] = &sc.w;
    let [dr, dg, db] = &sc.dw;
    // Tᵢ is non-increasing in i (Dᵢ is non-decreasing and rounding is
    // monotone), so once a chunk starts at 0 every later chunk is 0 and
    // contributes nothing: `live` shrinks as slices get longer.
    let mut live = n_pad;
    for k in 1..grid.n_l {
        for (ti, &gi) in t[..live + 1].iter_mut().zip(g) {
            let v = *ti * gi;
            // Branch-free select (a plain `if` compiles to a jump here).
            let keep = 0u32.wrapping_sub((v >= T_FLUSH) as u32);
            *ti = f32::from_bits(v.to_bits() & keep);
        }
        let kf = k as f32;
        let inv_k = 1.0 / kf;
        // λᵢ = k·cᵢ < LAM_SMALL  ⇔  cᵢ < LAM_SMALL / k.
        let c_cut = LAM_SMALL * inv_k;
        while live > 0 && t[live - LANES] == 0.0 {
            live -= LANES;
        }
        let (tl, cl, il) = (&t[..live + 1], &c[..live], &inv_c[..live]);
        let acc = if independent {
            slice_sums_independent(tl, cl, il, [wr, wg, wb], [dr, dg, db], kf, inv_k, c_cut)
        } else {
            slice_sums(tl, cl, il, [dr, dg, db], kf, inv_k, c_cut)
        };
        let sum = |ch: usize| acc[ch];
        let t_end = t[n];
        let o = &mut out[k * 4..k * 4 + 4];
        for ch in 0..3 {
            let v = if independent {
                (k as f64 * grid.dl) as f32 * sum(ch)
            } else {
                k_first[ch] as f32 - k_last[ch] as f32 * t_end + sum(ch)
            };
            o[ch] = v.max(0.0);
        }
        o[3] = (1.0 - t_end).clamp(0.0, 1.0);
    }
}

/// [`Build3d::Adaptive`] under independent emission: the slice recurrence
/// with this oversampling.
const ADAPTIVE_INDEPENDENT_OVERSAMPLING: f32 = 2.0;
/// Below this λ, [`Build3d::Adaptive`] takes ∫₀¹ x(1−x)e^{−λx} dx from its
/// series (seven terms, relative error < 1e-7); above, from the moments'
/// recursion, whose rounding grows as 1/λ².
const LAM_SMALL_2: f32 = 0.5;
/// Most pieces [`Build3d::Adaptive`] cuts one TF piece of a segment into.
const ADAPTIVE_MAX_SPLIT: usize = 256;

/// Per-pair arrays of the adaptive build (length n_l), reused across pairs.
#[derive(Default)]
struct AdaptiveScratch {
    /// Interval ends along the segment, u ∈ [0, 1].
    u: Vec<f64>,
    nodes: Vec<f64>,
    /// T at the current interval's start and end, per slice.
    t0: Vec<f32>,
    t1: Vec<f32>,
    acc: [Vec<f32>; 3],
}

/// T(l_k) = e^{−k·x} for k = 0..n (f32, flushed below [`T_FLUSH`]): the
/// first eight from f64 powers, then eight lanes stepping by e^{−8x}.
fn fill_transmittance(x: f64, t: &mut [f32]) {
    let g = (-x).exp();
    let mut p = 1.0f64;
    for v in t.iter_mut().take(LANES) {
        *v = p as f32;
        p *= g;
    }
    let g8 = (-(LANES as f64) * x).exp() as f32;
    let mut k = LANES;
    while k + LANES <= t.len() {
        let (head, tail) = t.split_at_mut(k);
        let prev: &[f32; LANES] = head[k - LANES..].try_into().expect("LANES");
        for (d, &s) in tail[..LANES].iter_mut().zip(prev) {
            let v = s * g8;
            *d = if v >= T_FLUSH { v } else { 0.0 };
        }
        k += LANES;
    }
    for i in k..t.len() {
        let v = t[i - LANES] * g8;
        t[i] = if v >= T_FLUSH { v } else { 0.0 };
    }
}

/// One (Sf, Sb) pair of [`Build3d::Adaptive`], density emission, all slices.
///
/// C = κ₀ − κₙTₙ + Σᵢ Δκᵢ·qᵢ with qᵢ = ∫₀¹ T(uᵢ + x·Δuᵢ) dx over interval
/// i, where ρ and κ are linear (intervals end at every TF control point).
/// There ln T = ln Tᵢ − λx + βx(1 − x) exactly (λ the interval's optical
/// depth, β = l·Δuᵢ·(ρᵢ₊₁ − ρᵢ)/2 its bend), so
/// qᵢ = Tᵢ·(∫e^{−λx} + β∫x(1−x)e^{−λx}) + O(β²): the chord rule of the
/// slice recurrence plus its first-order correction. The O(β²) remainder,
/// |Δκᵢ|·β²/60 at most, falls as r⁻⁴ when a piece is cut into r intervals,
/// so a piece gets the fewest intervals with
/// |Δκ|·(l_max·Δρ)²·Δu·A(τ₀)/(240·r⁴) ≤ tolerance·Δu (per unit u, so at
/// most `tolerance` over the segment; A = [`attenuation`] of the optical
/// depth τ₀ in front of the piece at l_max) and β ≤ 1/2. Smooth TFs need a
/// handful of intervals where the slice recurrence takes 2 per grid step,
/// and pieces deep inside an opaque segment one.
///
/// Vectorized over l: per interval, T at its end for every slice
/// ([`fill_transmittance`]), then λ = k·cᵢ splits the slices into the
/// ranges where q and the correction use their series or their closed
/// forms (no per-entry select).
#[allow(clippy::too_many_arguments)]
fn adaptive_pair(
    tf: &TransferFunction,
    grid: &Grid,
    a: usize,
    b: usize,
    tolerance: f64,
    kf: &[f32],
    inv_k: &[f32],
    sc: &mut AdaptiveScratch,
    out: &mut [f32],
) {
    let n_l = grid.n_l;
    let (sf, sb) = (grid.s(a), grid.s(b));
    let (k_first, k_last) = (tf.color(sf), tf.color(sb));
    sc.t0.clear();
    sc.t0.resize(n_l, 1.0);
    sc.t1.clear();
    sc.t1.resize(n_l, 0.0);
    for acc in sc.acc.iter_mut() {
        acc.clear();
        acc.resize(n_l, 0.0);
    }
    if a != b {
        let len_max = grid.dl * (n_l - 1) as f64;
        // TF pieces along the segment, each cut into r equal intervals.
        sc.nodes.clear();
        tf.breakpoints_between(sf.min(sb), sf.max(sb), &mut sc.nodes);
        sc.u.clear();
        sc.u.push(0.0);
        sc.u.extend(sc.nodes.iter().map(|&x| (x - sf) / (sb - sf)).filter(|&u| u > 0.0 && u < 1.0));
        sc.u.push(1.0);
        sc.u.sort_by(f64::total_cmp);
        sc.u.dedup();
        let s_of = |u: f64| if u >= 1.0 { sb } else { sf + (sb - sf) * u };
        let pieces = sc.u.len() - 1;
        let mut ends = Vec::with_capacity(2 * pieces + 1);
        ends.push(0.0);
        let (mut rho0, mut kap0) = (tf.extinction(sf), k_first);
        // Optical depth at l_max from the entry to the piece's start.
        let mut depth0 = 0.0f64;
        for p in 0..pieces {
            let (u0, u1) = (sc.u[p], sc.u[p + 1]);
            let s1 = s_of(u1);
            let (rho1, kap1) = (tf.extinction(s1), tf.color(s1));
            let du = u1 - u0;
            let dk = (0..3).map(|c| (kap1[c] - kap0[c]).abs()).fold(0.0, f64::max);
            let l_drho = len_max * (rho1 - rho0).abs();
            // The remainder at slice l = x·l_max is weighted by T ≤ e^{−x·τ₀}
            // and grows as β(l)² ∝ x²: at most attenuation(τ₀) of its l_max value.
            let by_error = (dk * l_drho * l_drho * du * attenuation(depth0) / (240.0 * tolerance)).powf(0.25);
            // Only the colour needs the intervals (α is exact from the
            // depth): a piece of constant colour stays whole. β ≤ 1/2 on
            // every interval (r² ≥ l_max·|Δρ|·Δu) keeps the expansion valid.
            let r = if dk == 0.0 { 1.0 } else { by_error.max((l_drho * du).sqrt()).ceil() };
            let r = (r as usize).clamp(1, ADAPTIVE_MAX_SPLIT);
            ends.extend((1..r).map(|j| u0 + du * (j as f64 / r as f64)));
            ends.push(u1);
            depth0 += len_max * du * 0.5 * (rho0 + rho1);
            (rho0, kap0) = (rho1, kap1);
        }
        // D: ∫₀^u ρ dv by the trapezoid rule, exact and local as in
        // `recurrence_pair`.
        let mut d0 = 0.0f64;
        let (mut rho0, mut kap0) = (tf.extinction(sf), k_first);
        for w in ends.windows(2) {
            let s1 = s_of(w[1]);
            let (rho1, kap1) = (tf.extinction(s1), tf.color(s1));
            let d1 = d0 + (w[1] - w[0]) * 0.5 * (rho0 + rho1);
            fill_transmittance(grid.dl * d1, &mut sc.t1);
            let c = (grid.dl * (d1 - d0)) as f32;
            // β per unit slice index: β(k) = k·e.
            let e = (grid.dl * (w[1] - w[0]) * (rho1 - rho0) * 0.5) as f32;
            let dkap = [0, 1, 2].map(|ch| (kap1[ch] - kap0[ch]) as f32);
            if dkap != [0.0; 3] {
                interval_sums(&sc.t0, &sc.t1, c, e, dkap, kf, inv_k, &mut sc.acc);
            }
            std::mem::swap(&mut sc.t0, &mut sc.t1);
            (d0, rho0, kap0) = (d1, rho1, kap1);
        }
    } else {
        fill_transmittance(grid.dl * tf.extinction(sf), &mut sc.t0);
    }
    // sc.t0 holds Tₙ.
    out[..4].fill(0.0);
    for k in 1..n_l {
        let t_end = sc.t0[k];
        let o = &mut out[k * 4..k * 4 + 4];
        for ch in 0..3 {
            o[ch] = (k_first[ch] as f32 - k_last[ch] as f32 * t_end + sc.acc[ch][k]).max(0.0);
        }
        o[3] = (1.0 - t_end).clamp(0.0, 1.0);
    }
}

/// max over x ∈ [0, 1] of x·e^{−x·τ}: [`attenuation`] for an error that
/// grows linearly with l.
fn attenuation_linear(tau: f64) -> f64 {
    if tau <= 1.0 {
        (-tau).exp()
    } else {
        (-1.0f64).exp() / tau
    }
}

/// max over x ∈ [0, 1] of x²·e^{−x·τ}: how much of its l_max value an
/// interval's bend remainder (∝ β² ∝ x², weighted by the transmittance
/// ≤ e^{−x·τ} in front of it) can reach at any slice.
fn attenuation(tau: f64) -> f64 {
    if tau <= 2.0 {
        (-tau).exp()
    } else {
        4.0 * (-2.0f64).exp() / (tau * tau)
    }
}

/// acc[ch][k] += Δκ[ch]·q(k) over slices k ≥ 1 for one interval: T at its
/// start `t0` and end `t1`, optical depth per slice index `c` (λ = k·c),
/// bend per slice index `e` (β = k·e).
#[allow(clippy::too_many_arguments)]
#[inline(never)]
fn interval_sums(
    t0: &[f32],
    t1: &[f32],
    c: f32,
    e: f32,
    dkap: [f32; 3],
    kf: &[f32],
    inv_k: &[f32],
    acc: &mut [Vec<f32>; 3],
) {
    let n = t0.len();
    // First slice index whose λ reaches `cut` (n when none does).
    let first = |cut: f32| -> usize {
        if c <= 0.0 {
            n
        } else {
            ((cut / c).ceil() as usize).clamp(1, n)
        }
    };
    let (k_q, k_2) = (first(LAM_SMALL), first(LAM_SMALL_2));
    let inv_c = if c > 0.0 { 1.0 / c } else { 0.0 };
    let [acc_r, acc_g, acc_b] = acc;
    // φ₂·T by its series: ∫₀¹ x(1−x)e^{−λx} dx = Σ (−λ)ⁿ/(n!·(n+2)(n+3)).
    let phi2_ser = |lam: f32| {
        1.0 / 6.0
            - lam
                * (1.0 / 12.0
                    - lam
                        * (1.0 / 40.0
                            - lam
                                * (1.0 / 180.0 - lam * (1.0 / 1008.0 - lam * (1.0 / 6720.0 - lam * (1.0 / 51840.0))))))
    };
    let mut add = |k: usize, w: f32| {
        acc_r[k] += dkap[0] * w;
        acc_g[k] += dkap[1] * w;
        acc_b[k] += dkap[2] * w;
    };
    for k in 1..k_q {
        let lam = kf[k] * c;
        let q = t0[k] * (1.0 - lam * (0.5 - lam * (1.0 / 6.0 - lam * (1.0 / 24.0))));
        add(k, q + kf[k] * e * t0[k] * phi2_ser(lam));
    }
    for k in k_q.max(1)..k_2 {
        let lam = kf[k] * c;
        let q = (t0[k] - t1[k]) * (inv_c * inv_k[k]);
        add(k, q + kf[k] * e * t0[k] * phi2_ser(lam));
    }
    for k in k_2.max(1)..n {
        let inv_lam = inv_c * inv_k[k];
        let q = (t0[k] - t1[k]) * inv_lam;
        let m1 = (q - t1[k]) * inv_lam;
        let m2 = (2.0 * m1 - t1[k]) * inv_lam;
        add(k, q + kf[k] * e * (m1 - m2));
    }
}

/// Σᵢ wᵢ·∫ᵢT for the three colour weights over one slice: the inner loop of
/// the recurrence build, over plain f32 arrays (length a multiple of LANES,
/// `t` one longer) in LANES independent accumulators so it vectorizes.
fn lanes(v: &[f32], n: usize) -> std::slice::ChunksExact<'_, f32> {
    v[..n].chunks_exact(LANES)
}

#[inline(never)]
fn slice_sums(t: &[f32], c: &[f32], inv_c: &[f32], w: [&[f32]; 3], kf: f32, inv_k: f32, c_cut: f32) -> [f32; 3] {
    let mut acc = [[0.0f32; LANES]; 3];
    let n_pad = c.len();
    let rows = lanes(t, n_pad)
        .zip(lanes(&t[1..], n_pad))
        .zip(lanes(c, n_pad))
        .zip(lanes(inv_c, n_pad))
        .zip(lanes(w[0], n_pad))
        .zip(lanes(w[1], n_pad))
        .zip(lanes(w[2], n_pad));
    for ((((((ti, tn), cc), ic), w0), w1), w2) in rows {
        let ti: &[f32; LANES] = ti.try_into().expect("LANES");
        let tn: &[f32; LANES] = tn.try_into().expect("LANES");
        let cc: &[f32; LANES] = cc.try_into().expect("LANES");
        let ic: &[f32; LANES] = ic.try_into().expect("LANES");
        let w0: &[f32; LANES] = w0.try_into().expect("LANES");
        let w1: &[f32; LANES] = w1.try_into().expect("LANES");
        let w2: &[f32; LANES] = w2.try_into().expect("LANES");
        for j in 0..LANES {
            let lam = kf * cc[j];
            let q_div = (ti[j] - tn[j]) * (ic[j] * inv_k);
            let q_ser = ti[j] * (1.0 - lam * (0.5 - lam * (1.0 / 6.0 - lam * (1.0 / 24.0))));
            let mask = 0u32.wrapping_sub((cc[j] < c_cut) as u32);
            let q = f32::from_bits((q_ser.to_bits() & mask) | (q_div.to_bits() & !mask));
            acc[0][j] += w0[j] * q;
            acc[1][j] += w1[j] * q;
            acc[2][j] += w2[j] * q;
        }
    }
    acc.map(|a| a.iter().sum())
}

/// Below this λ the first moment ∫ᵢ x·T uses its series (six terms, error
/// below 2e-7 relative); above, (Q − Tᵢ₊₁)/λ loses at most ~1e-5 to rounding.
const LAM_SMALL_1: f32 = 0.3;

/// Independent emission: Σᵢ [κᵢ·∫ᵢT + Δκᵢ·∫ᵢ x T] per colour channel, κ
/// linear and ln T linear on each interval (x ∈ [0, 1] across it), in units
/// of the interval width.
#[inline(never)]
#[allow(clippy::too_many_arguments)]
fn slice_sums_independent(
    t: &[f32],
    c: &[f32],
    inv_c: &[f32],
    w: [&[f32]; 3],
    dw: [&[f32]; 3],
    kf: f32,
    inv_k: f32,
    c_cut: f32,
) -> [f32; 3] {
    let mut acc = [[0.0f32; LANES]; 3];
    let n_pad = c.len();
    let c_cut1 = LAM_SMALL_1 * inv_k;
    for base in (0..n_pad).step_by(LANES) {
        let ti: &[f32; LANES] = t[base..base + LANES].try_into().expect("LANES");
        let tn: &[f32; LANES] = t[base + 1..base + 1 + LANES].try_into().expect("LANES");
        let cc: &[f32; LANES] = c[base..base + LANES].try_into().expect("LANES");
        let ic: &[f32; LANES] = inv_c[base..base + LANES].try_into().expect("LANES");
        let mut q = [0.0f32; LANES];
        let mut m1 = [0.0f32; LANES];
        for j in 0..LANES {
            let lam = kf * cc[j];
            let inv_lam = ic[j] * inv_k;
            let q_div = (ti[j] - tn[j]) * inv_lam;
            let q_ser = ti[j] * (1.0 - lam * (0.5 - lam * (1.0 / 6.0 - lam * (1.0 / 24.0))));
            let mask = 0u32.wrapping_sub((cc[j] < c_cut) as u32);
            q[j] = f32::from_bits((q_ser.to_bits() & mask) | (q_div.to_bits() & !mask));
            let m_div = (q[j] - tn[j]) * inv_lam;
            let m_ser = ti[j]
                * (0.5
                    - lam
                        * (1.0 / 3.0
                            - lam * (1.0 / 8.0 - lam * (1.0 / 30.0 - lam * (1.0 / 144.0 - lam * (1.0 / 840.0))))));
            let mask1 = 0u32.wrapping_sub((cc[j] < c_cut1) as u32);
            m1[j] = f32::from_bits((m_ser.to_bits() & mask1) | (m_div.to_bits() & !mask1));
        }
        for ch in 0..3 {
            let wk: &[f32; LANES] = w[ch][base..base + LANES].try_into().expect("LANES");
            let dk: &[f32; LANES] = dw[ch][base..base + LANES].try_into().expect("LANES");
            for j in 0..LANES {
                acc[ch][j] += wk[j] * q[j] + dk[j] * m1[j];
            }
        }
    }
    acc.map(|a| a.iter().sum())
}

/// One pair of the `Blend` build (all slices).
#[allow(clippy::too_many_arguments)]
fn blend_pair(
    tf: &TransferFunction,
    grid: &Grid,
    a: usize,
    b: usize,
    steps: usize,
    acc: Accumulation,
    rho: &mut Vec<f64>,
    kap: &mut Vec<[f64; 3]>,
    out: &mut [f32],
) {
    let independent = tf.emission() == Emission::Independent;
    let (sf, sb) = (grid.s(a), grid.s(b));
    rho.clear();
    kap.clear();
    for i in 0..steps {
        let s = sf + (sb - sf) * ((i as f64 + 0.5) / steps as f64);
        rho.push(tf.extinction(s));
        kap.push(tf.color(s));
    }
    out[..4].fill(0.0);
    for k in 1..grid.n_l {
        let step_len = k as f64 * grid.dl / steps as f64;
        let mut col = [0.0f32; 3];
        let mut trans = 1.0f32;
        // Back to front, as the frame buffer is blended.
        for i in (0..steps).rev() {
            let alpha_step = acc.quantize((-(-rho[i] * step_len).exp_m1()) as f32);
            for ch in 0..3 {
                let e = if independent { kap[i][ch] * step_len } else { kap[i][ch] * alpha_step as f64 };
                let e = acc.quantize(e as f32);
                col[ch] = acc.quantize(e + (1.0 - alpha_step) * col[ch]);
            }
            trans = acc.quantize(trans * (1.0 - alpha_step));
        }
        out[k * 4..k * 4 + 3].copy_from_slice(&col);
        out[k * 4 + 3] = 1.0 - trans;
    }
}

fn build_incremental(tf: &TransferFunction, grid: &Grid, band: &Band, axis: &Axis, domain: &TableDomain) -> Vec<f32> {
    let n_l = grid.n_l;
    let prefix = ExtinctionPrefix::new(tf);
    let independent = tf.emission() == Emission::Independent;
    let mut values = vec![0.0f32; band.pairs * n_l * 4];
    let mut prev = vec![[0.0f32; 4]; band.pairs];
    let mut cur = vec![[0.0f32; 4]; band.pairs];
    // Front piece (sf → sm, length dl): mean extinction exact, colour the
    // mean of its ends.
    let front = |sf: f64, sm: f64| -> ([f64; 3], f64) {
        let x = grid.dl * prefix.mean(tf, sf, sm);
        let alpha = -(-x).exp_m1();
        let (cf, cm) = (tf.color(sf), tf.color(sm));
        let kbar: [f64; 3] = std::array::from_fn(|c| 0.5 * (cf[c] + cm[c]));
        let weight = if independent {
            if x < 1e-8 {
                grid.dl
            } else {
                grid.dl * alpha / x
            }
        } else {
            alpha
        };
        (kbar.map(|k| k * weight), alpha)
    };
    // Lookups in the previous slice as `Table3d::lookup` clamps them.
    let reach = band.reach;
    let coords = |sm: f64, b: usize| -> (f32, f32) {
        if axis.uniform {
            let top = (band.n_s - 1) as f32;
            let ds = domain.scalar_span() / (band.n_s - 1) as f64;
            let xm = (((sm - domain.s_lo) / ds) as f32).clamp(0.0, top);
            (xm, (b as f32).max(xm - reach).min(xm + reach))
        } else {
            let (lo, hi, ds) = (axis.lo, axis.hi, domain.max_ds as f32);
            let sm = (sm as f32).max(lo).min(hi);
            let sb = (grid.s(b) as f32).max(lo).min(hi).max(sm - ds).min(sm + ds);
            (axis.x_of(sm), axis.x_of(sb))
        }
    };
    for k in 1..n_l {
        let prev_ref = &prev;
        cur.par_chunks_mut(1024).enumerate().for_each(|(chunk, out)| {
            let first = chunk * 1024;
            // Find the row of the chunk's first pair, then walk.
            let mut a = band.row_start.partition_point(|&s| s <= first) - 1;
            for (off, o) in out.iter_mut().enumerate() {
                let p = first + off;
                while p >= band.row_start[a + 1] {
                    a += 1;
                }
                let b = band.row_lo[a] + (p - band.row_start[a]);
                let (sf, sb) = (grid.s(a), grid.s(b));
                let sm = if k == 1 { sb } else { sf + (sb - sf) / k as f64 };
                let (cf, af) = front(sf, sm);
                let back = if k == 1 {
                    [0.0; 4]
                } else {
                    let (xm, xb) = coords(sm, b);
                    bilinear(prev_ref, band, xm, xb)
                };
                let t = 1.0 - af as f32;
                *o = [
                    cf[0] as f32 + t * back[0],
                    cf[1] as f32 + t * back[1],
                    cf[2] as f32 + t * back[2],
                    af as f32 + t * back[3],
                ];
            }
        });
        for (p, e) in cur.iter().enumerate() {
            values[(p * n_l + k) * 4..(p * n_l + k) * 4 + 4].copy_from_slice(e);
        }
        std::mem::swap(&mut prev, &mut cur);
    }
    values
}

/// Bilinear lookup in one slice stored per pair.
fn bilinear(slice: &[[f32; 4]], band: &Band, xa: f32, xb: f32) -> [f32; 4] {
    let n = band.n_s;
    let (a0, b0) = ((xa as usize).min(n - 2), (xb as usize).min(n - 2));
    let (fa, fb) = (xa - a0 as f32, xb - b0 as f32);
    let mut out = [0.0f32; 4];
    for (da, wa) in [(0, 1.0 - fa), (1, fa)] {
        for (db, wb) in [(0, 1.0 - fb), (1, fb)] {
            let w = wa * wb;
            if w == 0.0 {
                continue;
            }
            let e = slice[band.pair(a0 + da, b0 + db)];
            for c in 0..4 {
                out[c] += w * e[c];
            }
        }
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::integrate_segment;

    fn tf(json: &str) -> TransferFunction {
        TransferFunction::from_json(json).unwrap()
    }

    fn ramp() -> TransferFunction {
        tf(r#"{"color": [[0, 0.1, 0.2, 0.9], [0.5, 0.9, 0.9, 0.2], [1, 1, 0.1, 0]],
               "opacity": [[0, 0], [0.4, 0.05], [0.45, 3], [0.55, 3], [0.6, 0.1], [1, 0.4]], "unit_distance": 0.5}"#)
    }

    #[test]
    fn shade_span_equals_shade_for_every_precision() {
        let d = TableDomain::new(0.0, 1.0, 0.3, 2.0).unwrap();
        let segs: Vec<Segment> = (0..500)
            .map(|i| {
                let x = i as f32 * 0.618_034;
                Segment {
                    s_front: (x.fract() * 1.4) - 0.2,
                    s_back: ((x * 1.7).fract() * 1.4) - 0.2,
                    len_world: (x * 2.3).fract() * 2.5,
                    ..Default::default()
                }
            })
            .chain([Segment { s_front: f32::NAN, s_back: 0.5, len_world: f32::NAN, ..Default::default() }])
            .collect();
        for precision in [Precision::F32, Precision::F16, Precision::Unorm8] {
            let p = Table3dParams { n_s: 16, n_l: 8, precision, ..Default::default() };
            let t = Table3d::build(&ramp(), &d, &p).unwrap();
            let mut out = vec![[0.0f32; 4]; segs.len()];
            t.shade_span(&segs, &mut out);
            for (s, o) in segs.iter().zip(&out) {
                assert_eq!(*o, t.shade(s));
            }
        }
    }

    /// The portable lookup can be forced per table (so machines with AVX2
    /// test it too; `TET_PREINT_LOOKUP=portable` forces it per process),
    /// survives a full re-bake, and gives `shade`'s values.
    #[test]
    fn forcing_the_portable_kernel() {
        let d = TableDomain::new(0.0, 1.0, 0.3, 2.0).unwrap();
        let p = Table3dParams { n_s: 16, n_l: 8, precision: Precision::F16, ..Default::default() };
        let mut t = Table3d::build(&ramp(), &d, &p).unwrap();
        t.set_lookup_kernel(LookupKernel::Portable);
        assert_eq!(t.lookup_kernel_in_use(), "portable");
        let stats = t.rebake(&ramp(), &ramp().with_emission(Emission::Independent)).unwrap();
        assert_eq!(stats.full, Some(FullRebake::Precision));
        assert_eq!(t.lookup_kernel_in_use(), "portable");
        let segs: Vec<Segment> = (0..40)
            .map(|i| Segment {
                s_front: i as f32 / 30.0,
                s_back: 0.5,
                len_world: i as f32 / 17.0,
                ..Default::default()
            })
            .collect();
        let mut out = [[0.0f32; 4]; method::BATCH];
        t.shade_batch(&SegmentBatch::from_segments(&segs), &mut out);
        for (s, o) in segs.iter().zip(&out) {
            assert_eq!(*o, t.shade(s));
        }
        let auto = t.with_lookup_kernel(LookupKernel::Auto).lookup_kernel_in_use();
        assert!(auto == "avx2" || auto == "portable");
    }

    fn node_error(t: &Table3d, tf: &TransferFunction) -> f64 {
        let p = t.params();
        let mut worst = 0.0f64;
        for a in (0..p.n_s).step_by(3) {
            for b in 0..p.n_s {
                for k in (0..p.n_l).step_by(5) {
                    if let Some(e) = t.entry(a, b, k) {
                        let x = integrate_segment(tf, t.scalar_at(a), t.scalar_at(b), t.len_at(k)).to_array();
                        for c in 0..4 {
                            worst = worst.max((e[c] as f64 - x[c]).abs());
                        }
                    }
                }
            }
        }
        worst
    }

    #[test]
    fn prefix_integral_matches_trapezoid_sum() {
        let f = ramp();
        let p = ExtinctionPrefix::new(&f);
        let (a, b) = (0.1, 0.9);
        let n = 200_000;
        let h = (b - a) / n as f64;
        let sum: f64 = (0..n).map(|i| f.extinction(a + (i as f64 + 0.5) * h) * h).sum();
        assert!((p.at(b) - p.at(a) - sum).abs() < 1e-8);
        assert!((p.mean(&f, 0.5, 0.5) - 6.0).abs() < 1e-12);
        // Clamped outside the nodes.
        assert!((p.at(1.5) - p.at(1.0) - 0.5 * 0.8).abs() < 1e-12);
    }

    #[test]
    fn recurrence_meets_1e3_at_the_nodes() {
        let f = ramp();
        let d = TableDomain::full(0.0, 1.0, 2.0).unwrap();
        // The error depends on the interval width in s, span / ((n_s − 1)·o):
        // 48 samples with o = 4 are about as fine as the default 128 with o = 2.
        let build = Build3d::SliceRecurrence { oversampling: 4.0 };
        let p = Table3dParams { n_s: 48, n_l: 64, build, ..Default::default() };
        let t = Table3d::build(&f, &d, &p).unwrap();
        let e = node_error(&t, &f);
        assert!(e < 1e-3, "max node error {e}");
        let ind = f.clone().with_emission(Emission::Independent);
        let t = Table3d::build(&ind, &d, &p).unwrap();
        let e = node_error(&t, &ind);
        // Measured 9.0e-5 on these nodes; before the SPLIT_ERROR rule the
        // full grid's max was 1.15e-3 (independent emission weights T directly).
        assert!(e < 1e-3, "independent max node error {e}");
    }

    #[test]
    fn exact_build_is_exact_and_band_saves_memory() {
        let f = ramp();
        let d = TableDomain::new(0.0, 1.0, 0.2, 2.0).unwrap();
        let p = Table3dParams { n_s: 33, n_l: 9, build: Build3d::Exact, ..Default::default() };
        let t = Table3d::build(&f, &d, &p).unwrap();
        assert!(node_error(&t, &f) < 1e-6);
        assert!(t.memory_bytes() < t.full_memory_bytes() / 2, "{} vs {}", t.memory_bytes(), t.full_memory_bytes());
        assert_eq!(t.band_half_width(), 8);
        assert!(t.entry(0, 20, 1).is_none());
    }

    /// A thin TF keeps the trilinear lookup: half way between grid nodes
    /// along every axis it is the mean of the 8 entries; a dense one takes
    /// the optical depth, whose gap the table reports.
    #[test]
    fn reconstruction_follows_the_gap() {
        let thin = tf(
            r#"{"color": [[0, 0.2, 0.5, 1], [1, 1, 0.4, 0]], "opacity": [[0, 0.001], [1, 0.01]], "unit_distance": 1}"#,
        );
        let d = TableDomain::full(0.0, 1.0, 1.0).unwrap();
        let p = Table3dParams { n_s: 16, n_l: 16, ..Default::default() };
        let t = Table3d::build(&thin, &d, &p).unwrap();
        assert_eq!(t.reconstruction(), Reconstruction::Trilinear);
        assert!(t.reconstruction_gap() <= RECONSTRUCTION_GAP && t.memory_bytes() == t.storage().memory_bytes());
        let (a, b, k) = (5, 7, 3);
        let mid = |x0: f64, x1: f64| (0.5 * (x0 + x1)) as f32;
        let got = t.lookup(
            mid(t.scalar_at(a), t.scalar_at(a + 1)),
            mid(t.scalar_at(b), t.scalar_at(b + 1)),
            mid(t.len_at(k), t.len_at(k + 1)),
        );
        let mut want = [0.0f64; 4];
        for (da, db, dk) in (0..8).map(|i| (i & 1, (i >> 1) & 1, i >> 2)) {
            let e = t.entry(a + da, b + db, k + dk).unwrap();
            (0..4).for_each(|c| want[c] += e[c] as f64 / 8.0);
        }
        for c in 0..4 {
            assert!((got[c] as f64 - want[c]).abs() < 1e-6, "{got:?} vs {want:?}");
        }
        let dense =
            tf(r#"{"color": [[0, 0.2, 0.5, 1], [1, 1, 0.4, 0]], "opacity": [[0, 0.5], [1, 40]], "unit_distance": 1}"#);
        let t = Table3d::build(&dense, &d, &p).unwrap();
        assert_eq!(t.reconstruction(), Reconstruction::OpticalDepth);
        assert!(t.reconstruction_gap() > RECONSTRUCTION_GAP && t.memory_bytes() > t.storage().memory_bytes());
    }

    /// Regression: an optical-depth table zeroed the colour of faint
    /// lookups (1 − α rounded α away, and α = 0 scaled the colour by 0),
    /// which independent emission's glowing, barely absorbing entries
    /// show. The faint end of this TF must match `exact` as the dense end
    /// makes the table take the optical depth.
    #[test]
    fn faint_lookups_keep_their_colour_in_optical_depth() {
        let f = tf(r#"{"color": [[0, 1, 0.5, 0.25], [1, 0.2, 0.4, 1]],
                       "opacity": [[0, 0], [0.3, 1e-6], [0.6, 1e-6], [0.8, 50], [1, 50]],
                       "unit_distance": 1, "emission": "independent"}"#);
        let d = TableDomain::full(0.0, 1.0, 1.0).unwrap();
        let t = Table3d::build(&f, &d, &Table3dParams { n_s: 32, n_l: 32, ..Default::default() }).unwrap();
        assert_eq!(t.reconstruction(), Reconstruction::OpticalDepth);
        for (sf, sb, l) in [(0.1, 0.1, 0.5), (0.05, 0.2, 0.7), (0.35, 0.5, 0.3), (0.0, 0.0, 0.99)] {
            let got = t.lookup(sf as f32, sb as f32, l as f32);
            let want = integrate_segment(&f, sf, sb, l);
            for c in 0..3 {
                assert!((got[c] as f64 - want.color[c]).abs() <= 1e-3 * want.color[c].max(1e-3), "{got:?} vs {want:?}");
            }
            // α to the bake's own resolution (α = 1 − T in f32: steps of 6e-8).
            assert!((got[3] as f64 - want.alpha).abs() <= 1e-6, "{got:?} vs {want:?}");
        }
    }

    #[test]
    fn stability_cases() {
        let f = tf(r#"{"color": [[0, 1, 1, 1]], "opacity": [[0, 0], [1, 1e6]], "unit_distance": 1}"#);
        let d = TableDomain::full(0.0, 1.0, 1.0).unwrap();
        let t = Table3d::build(&f, &d, &Table3dParams { n_s: 16, n_l: 16, ..Default::default() }).unwrap();
        assert_eq!(t.lookup(0.3, 0.7, 0.0), [0.0; 4]);
        // l → 0: continuous, within the table's error of exact (ρ reaches
        // 1e6 here, so α at l = 1e-9 is 5e-4; slice 1 is opaque).
        let near0 = t.lookup(0.3, 0.7, 1e-12);
        assert!(near0.iter().all(|&v| (0.0..1e-6).contains(&v)), "{near0:?}");
        let near0 = t.lookup(0.3, 0.7, 1e-9);
        let x0 = integrate_segment(&f, 0.3, 0.7, 1e-9);
        assert!(near0.iter().all(|&v| v >= 0.0) && (near0[3] as f64 - x0.alpha).abs() < 1e-3, "{near0:?} vs {x0:?}");
        let dense = t.lookup(0.9, 0.9, 1.0);
        assert!((dense[3] - 1.0).abs() < 1e-6 && (dense[0] - 1.0).abs() < 1e-5, "{dense:?}");
        for v in [f32::NAN, f32::INFINITY, f32::NEG_INFINITY, -5.0, 7.0] {
            let r = t.lookup(v, 0.5, v);
            assert!(r.iter().all(|x| x.is_finite() && *x >= 0.0), "{v}: {r:?}");
            let r = t.lookup(0.5, v, 0.5);
            assert!(r.iter().all(|x| x.is_finite()), "{v}: {r:?}");
        }
        // Sf = Sb at a grid node, and l → 0 between slices 0 and 1: the
        // optical depth is linear in l there, so the reconstruction between
        // the slices is exact (α = 1 − √(1 − α₁) at half a step; linear
        // interpolation of α would give α₁/2).
        let s3 = t.scalar_at(3);
        let x = integrate_segment(&f, s3, s3, t.len_at(1));
        let r = t.lookup(s3 as f32, s3 as f32, t.len_at(1) as f32);
        assert!((r[3] as f64 - x.alpha).abs() < 1e-5, "{r:?} vs {x:?}");
        let xh = integrate_segment(&f, s3, s3, 0.5 * t.len_at(1));
        let half = t.lookup(s3 as f32, s3 as f32, 0.5 * t.len_at(1) as f32);
        assert!((half[3] as f64 - xh.alpha).abs() < 1e-5, "{half:?} vs {xh:?}");
        assert!((half[0] as f64 - xh.color[0]).abs() < 1e-5, "{half:?} vs {xh:?}");
        assert!(x.alpha > 0.1 && (xh.alpha - 0.5 * x.alpha).abs() > 1e-2, "the case must tell the two apart");
    }

    #[test]
    fn incremental_and_blend_are_close_on_a_mild_tf() {
        let f = tf(r#"{"color": [[0, 0.2, 0.4, 0.6], [1, 0.8, 0.3, 0.1]],
                       "opacity": [[0, 0.1], [0.3, 0.6], [0.7, 0.2], [1, 0.9]], "unit_distance": 1}"#);
        let d = TableDomain::full(0.0, 1.0, 2.0).unwrap();
        let inc = Table3d::build(
            &f,
            &d,
            &Table3dParams { n_s: 32, n_l: 32, build: Build3d::Incremental, ..Default::default() },
        )
        .unwrap();
        assert!(node_error(&inc, &f) < 0.02, "incremental {}", node_error(&inc, &f));
        let bl = Build3d::Blend { steps: 64, accumulation: Accumulation::F32 };
        let blend =
            Table3d::build(&f, &d, &Table3dParams { n_s: 32, n_l: 32, build: bl, ..Default::default() }).unwrap();
        assert!(node_error(&blend, &f) < 0.01, "blend {}", node_error(&blend, &f));
        let bl8 = Build3d::Blend { steps: 64, accumulation: Accumulation::new(8).unwrap() };
        let b8 = Table3d::build(&f, &d, &Table3dParams { n_s: 32, n_l: 32, build: bl8, ..Default::default() }).unwrap();
        assert!(node_error(&b8, &f) > node_error(&blend, &f));
    }

    #[test]
    fn axis_knots_are_the_built_tables() {
        let f = ramp();
        let d = TableDomain::new(0.0, 1.0, 0.3, 2.0).unwrap();
        for s_axis in [ScalarAxis::Uniform, ScalarAxis::TfNodes] {
            let p = Table3dParams { n_s: 40, n_l: 4, s_axis, ..Default::default() };
            let t = Table3d::build(&f, &d, &p).unwrap();
            assert_eq!(Table3d::axis_knots(&f, &d, &p).unwrap(), t.s_knots());
        }
        assert!(Table3d::axis_knots(&f, &d, &Table3dParams { n_s: 1, ..Default::default() }).is_err());
    }

    #[test]
    fn rejects_bad_params() {
        let f = ramp();
        let d = TableDomain::full(0.0, 1.0, 2.0).unwrap();
        assert!(Table3d::build(&f, &d, &Table3dParams { n_s: 1, ..Default::default() }).is_err());
        let bad = Table3dParams { build: Build3d::SliceRecurrence { oversampling: f32::NAN }, ..Default::default() };
        assert!(Table3d::build(&f, &d, &bad).is_err());
        let huge = Table3dParams { n_s: 8192, n_l: 8192, ..Default::default() };
        assert!(matches!(Table3d::build(&f, &d, &huge), Err(TableError::TooLarge { .. })));
    }
}
