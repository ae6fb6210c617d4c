//! `Build3d::Adaptive` under density emission: one (Sf, Sb) pair, all
//! slices.

use super::{attenuation, Grid, LAM_SMALL, LANES, T_FLUSH};
use crate::tf::TransferFunction;

/// [`Build3d::Adaptive`] under independent emission: the slice recurrence
/// with this oversampling.
///
/// [`Build3d::Adaptive`]: crate::Build3d::Adaptive
pub(super) const ADAPTIVE_INDEPENDENT_OVERSAMPLING: f32 = 2.0;
/// Below this λ, [`Build3d::Adaptive`] takes ∫₀¹ x(1−x)e^{−λx} dx from its
/// series (seven terms, relative error < 1e-7); above, from the moments'
/// recursion, whose rounding grows as 1/λ².
///
/// [`Build3d::Adaptive`]: crate::Build3d::Adaptive
const LAM_SMALL_2: f32 = 0.5;
/// Most pieces [`Build3d::Adaptive`] cuts one TF piece of a segment into.
///
/// [`Build3d::Adaptive`]: crate::Build3d::Adaptive
const ADAPTIVE_MAX_SPLIT: usize = 256;

/// Per-pair arrays of the adaptive build (length n_l), reused across pairs.
#[derive(Default)]
pub(super) struct AdaptiveScratch {
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
///
/// [`Build3d::Adaptive`]: crate::Build3d::Adaptive
#[allow(clippy::too_many_arguments)]
pub(super) fn adaptive_pair(
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
