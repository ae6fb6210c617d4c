//! The bakes of a `Table3d` ([`Build3d`]): what every build shares (the
//! grid, the per-pair schedule [`bake_pairs`]), `Blend`, `Exact` and
//! `Incremental`; the slice recurrence and the adaptive build in their own
//! modules.

mod adaptive;
mod recurrence;

use super::axis::Axis;
use super::band::Band;
use super::{Build3d, Table3dParams};
use crate::domain::TableDomain;
use crate::exact::integrate_segment_with;
use crate::precision::Accumulation;
use crate::tf::{Emission, TransferFunction};
use adaptive::{adaptive_pair, AdaptiveScratch, ADAPTIVE_INDEPENDENT_OVERSAMPLING};
use rayon::prelude::*;
use recurrence::{recurrence_pair, PairScratch};

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

/// Smallest λ for which ∫T = (Tᵢ − Tᵢ₊₁)/λ is used (below, the series).
const LAM_SMALL: f32 = 0.05;
/// Transmittances below this are flushed to 0 (keeps f32 out of denormals).
const T_FLUSH: f32 = 1e-30;
const LANES: usize = 8;

/// Grid positions in f64.
pub(super) struct Grid {
    scalars: Vec<f64>,
    dl: f64,
    pub(super) n_l: usize,
}

impl Grid {
    pub(super) fn new(d: &TableDomain, p: &Table3dParams, axis: &Axis) -> Grid {
        Grid { scalars: axis.grid.clone(), dl: d.len_max_world / (p.n_l - 1) as f64, n_l: p.n_l }
    }
    pub(super) fn s(&self, a: usize) -> f64 {
        self.scalars[a]
    }
}

/// Splits the output into one mutable slice per row of the band.
pub(super) fn rows_mut<'a>(values: &'a mut [f32], band: &Band, per_pair: usize) -> Vec<(usize, &'a mut [f32])> {
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

/// Computes, in place, every pair (a, b) of `values` (the band's layout)
/// that `select` picks, by a build whose entries depend only on the TF over
/// the pair's own scalar interval (every build but `Incremental`): what a
/// full bake and [`Table3d::rebake`] share, so a re-baked pair is
/// bit-for-bit the full bake's.
///
/// [`Table3d::rebake`]: super::Table3d::rebake
pub(super) fn bake_pairs(
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

pub(super) fn build_incremental(
    tf: &TransferFunction,
    grid: &Grid,
    band: &Band,
    axis: &Axis,
    domain: &TableDomain,
) -> Vec<f32> {
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
