//! `Build3d::SliceRecurrence` (and `Adaptive` under independent emission):
//! one (Sf, Sb) pair, all slices.

use super::{attenuation, attenuation_linear, Grid, LAM_SMALL, LANES, T_FLUSH};
use crate::tf::TransferFunction;

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

/// Per-pair arrays of the recurrence build, reused across pairs.
#[derive(Default)]
pub(super) struct PairScratch {
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

#[allow(clippy::too_many_arguments)]
pub(super) fn recurrence_pair(
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
