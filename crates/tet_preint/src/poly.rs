//! `poly1`, `poly2`, `poly4`: Guthe et al.'s 2D tables (2002, §3).
//!
//! The 3D table T(Sf, Sb, l) is replaced by
//!
//! * ρ̂(Sf, Sb), the mean extinction over [Sf, Sb] (exact, from a prefix
//!   integral of the piecewise-linear ρ; ρ(Sf) on the diagonal), so that
//!   α = 1 − exp(−l·ρ̂) — read from a 1D table of 1 − e^(−x) stored at 16 bits
//!   ([`AlphaTable`]), as in the paper;
//! * the normalized colour Ĉ(l) = C/w(l) as a polynomial Σᵢ C̃ᵢ(Sf,Sb)·(l/l_max)^i
//!   of degree n ∈ {1, 2, 4}, interpolating n+1 slices at l = i·l_max/n, the
//!   slice at l → 0 being the limit.
//!
//! The weight w depends on the emission model. Density (κ·ρ, the paper's):
//! w = α, and the l → 0 limit is Ĉ₀ = ∫κρ ds / ∫ρ ds over [Sf, Sb] (the mean
//! colour ∫κ ds / (Sb − Sf) where ∫ρ = 0, so the colour stays defined where
//! α = 0). Independent (κ alone, as in Röttger & Ertl, "A Two-Step Approach
//! for Interactive Pre-Integrated Volume Rendering of Unstructured Grids",
//! 2002, and Song et al., "Bivariate Transfer Functions on Unstructured
//! Grids", 2009): C/α is unbounded where ρ = 0
//! (C = κ·l while α = 0), so w = β = ∫₀ˡ exp(−ρ̂ t) dt = l·(1 − e^(−x))/x with
//! x = l·ρ̂ instead; then Ĉ₀ is the plain mean of κ over [Sf, Sb].
//!
//! Lookup: bilinear in (Sf, Sb) for ρ̂ and the C̃ᵢ, α from the 16-bit table,
//! C = w·Σ C̃ᵢ tⁱ with t = l/l_max clamped to [0, 1] (no extrapolation past the
//! baked lengths), clamped componentwise to [0, α·max κ] (density) or
//! [0, l·max κ] (independent). Scalars outside [s_lo, s_hi] are clamped to it.
//!
//! Only the band |Sf − Sb| ≤ `max_ds` (the largest per-cell scalar range of
//! the bundle) needs baking; when that band is narrower than the table the
//! rows are stored as diagonal bands ([`PolyTable::memory_bytes`] and
//! [`PolyTable::full_memory_bytes`] report the saving).

use rayon::prelude::*;

use crate::bivariate::GL6_NODES;
use crate::method::{Method, Rgba32, Segment, SegmentBatch, SegmentShader, BATCH};
use crate::simd::{no_nan, vmax, vmin};
use crate::tf::{Emission, TransferFunction};
use glam::Vec4;
use wide::f32x8;

/// Bake parameters: plain numbers (the lead unifies them with the other
/// tables' domain type later).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct PolyParams {
    /// Polynomial degree n: 1, 2 or 4 (methods `poly1`, `poly2`, `poly4`).
    pub degree: usize,
    /// Table resolution N (N × N samples over [s_lo, s_hi]², endpoints included).
    pub res: usize,
    /// Scalar range covered by the table.
    pub s_lo: f64,
    pub s_hi: f64,
    /// Largest |Sf − Sb| a segment can have (largest per-cell scalar range);
    /// `f64::INFINITY` bakes the full square.
    pub max_ds: f64,
    /// Largest segment length (largest cell diameter), world units.
    pub l_max: f64,
}

impl PolyParams {
    /// Full square over [s_lo, s_hi]² (no band restriction).
    pub fn new(degree: usize, res: usize, s_lo: f64, s_hi: f64, l_max: f64) -> Self {
        PolyParams { degree, res, s_lo, s_hi, max_ds: f64::INFINITY, l_max }
    }
    /// Restricts the baked domain to |Sf − Sb| ≤ `max_ds`.
    pub fn with_max_ds(mut self, max_ds: f64) -> Self {
        self.max_ds = max_ds;
        self
    }
}

/// Bad parameters or inconsistent table parts.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum PolyError {
    #[error("polynomial degree {0}: must be 1, 2 or 4")]
    Degree(usize),
    #[error("resolution {0}: must be between 2 and 16384")]
    Resolution(usize),
    #[error("scalar range [{lo}, {hi}]: need finite lo < hi")]
    Range { lo: f64, hi: f64 },
    #[error("l_max = {0}: must be positive and finite")]
    LMax(f64),
    #[error("max_ds = {0}: must be positive (or infinite)")]
    MaxDs(f64),
    #[error("{what}: expected {expected} values, found {found}")]
    Length { what: &'static str, expected: usize, found: usize },
    #[error("{what}[{index}]: value is NaN or infinite")]
    NonFinite { what: &'static str, index: usize },
    #[error("the transfer function has {0} 2D widgets; poly tables are 1D (use biv-exact or biv-approx)")]
    Widgets(usize),
    #[error("alpha table: x_max = {x_max} must be positive and finite, with at least 2 entries (found {len})")]
    AlphaTable { x_max: f32, len: usize },
}

/// α(x) = 1 − e^(−x) sampled at 16 bits (65535 = 1), linearly interpolated
/// over [0, x_max]; 1 beyond (at 16 bits 1 − e^(−x) rounds to 1 for
/// x > ln(131070) ≈ 11.8).
#[derive(Debug, Clone, PartialEq)]
pub struct AlphaTable {
    x_max: f32,
    data: Vec<u16>,
    inv_step: f32,
}

impl AlphaTable {
    /// Entries used by [`AlphaTable::standard`]; linear interpolation error
    /// (≤ h²/8 ≈ 1e-6) stays below the 16-bit step (7.6e-6).
    pub const STANDARD_LEN: usize = 4096;
    /// Range used by [`AlphaTable::standard`].
    pub const STANDARD_X_MAX: f32 = 12.0;

    /// The default table: 4096 entries over [0, 12].
    pub fn standard() -> Self {
        let n = Self::STANDARD_LEN;
        let x_max = Self::STANDARD_X_MAX;
        let data = (0..n)
            .map(|k| {
                let x = f64::from(x_max) * k as f64 / (n - 1) as f64;
                (-(-x).exp_m1() * 65535.0).round() as u16
            })
            .collect();
        AlphaTable { x_max, data, inv_step: (n - 1) as f32 / x_max }
    }

    /// Rebuilds a table from stored parts.
    pub fn from_parts(x_max: f32, data: Vec<u16>) -> Result<Self, PolyError> {
        if !(x_max > 0.0 && x_max.is_finite()) || data.len() < 2 {
            return Err(PolyError::AlphaTable { x_max, len: data.len() });
        }
        let inv_step = (data.len() - 1) as f32 / x_max;
        Ok(AlphaTable { x_max, data, inv_step })
    }

    pub fn x_max(&self) -> f32 {
        self.x_max
    }
    /// The 16-bit samples (65535 = 1) at x = k·x_max/(len − 1).
    pub fn data(&self) -> &[u16] {
        &self.data
    }

    /// α for optical depth `x` (≥ 0; NaN and negatives give 0).
    #[inline]
    pub fn alpha(&self, x: f32) -> f32 {
        let u = (x * self.inv_step).max(0.0);
        let last = self.data.len() - 1;
        if u >= last as f32 {
            return f32::from(self.data[last]) * (1.0 / 65535.0);
        }
        let k = u as usize;
        let f = u - k as f32;
        let a = f32::from(self.data[k]);
        let b = f32::from(self.data[k + 1]);
        (a + f * (b - a)) * (1.0 / 65535.0)
    }
}

/// A baked `poly1`/`poly2`/`poly4` table; implements [`SegmentShader`].
///
/// Storage (for a later file format): `res` rows of `row_len` entries. With
/// `band == None` entry (i, j) is at column j (a full res × res square); with
/// `band == Some(b)` it is at column j − i + b, row_len = 2b + 1, and columns
/// whose j falls outside [0, res) repeat the nearest valid j. Per entry:
/// `rho[e]` (ρ̂, per world length) and `coef[e·3(n+1) ..]` = C̃₀ RGB, C̃₁ RGB, ….
#[derive(Debug, Clone, PartialEq)]
pub struct PolyTable {
    degree: usize,
    res: usize,
    band: Option<usize>,
    s_lo: f32,
    s_hi: f32,
    l_max: f32,
    emission: Emission,
    max_color: [f32; 3],
    rho: Vec<f32>,
    coef: Vec<f32>,
    alpha: AlphaTable,
    // Derived.
    inv_ds: f32,
    inv_l_max: f32,
}

fn check_params(p: &PolyParams) -> Result<(), PolyError> {
    if ![1, 2, 4].contains(&p.degree) {
        return Err(PolyError::Degree(p.degree));
    }
    if !(2..=16384).contains(&p.res) {
        return Err(PolyError::Resolution(p.res));
    }
    if !(p.s_lo.is_finite() && p.s_hi.is_finite() && p.s_lo < p.s_hi) {
        return Err(PolyError::Range { lo: p.s_lo, hi: p.s_hi });
    }
    if !(p.l_max > 0.0 && p.l_max.is_finite()) {
        return Err(PolyError::LMax(p.l_max));
    }
    if p.max_ds.is_nan() || p.max_ds <= 0.0 {
        return Err(PolyError::MaxDs(p.max_ds));
    }
    Ok(())
}

/// Band half-width (in samples) needed for |Sf − Sb| ≤ max_ds, or None when
/// the band would be as wide as the square: the storage layout of
/// [`PolyTable`]'s banded tables, for bakes outside this crate (tet_gpu).
pub fn band_for(res: usize, s_lo: f64, s_hi: f64, max_ds: f64) -> Option<usize> {
    let step = (s_hi - s_lo) / (res - 1) as f64;
    let m = max_ds / step;
    // Bilinear corners lie up to one sample further from the diagonal.
    if !m.is_finite() || m + 2.0 >= res as f64 {
        return None;
    }
    let b = m.ceil() as usize + 1;
    (2 * b + 1 < res).then_some(b)
}

/// (Vandermonde at tᵢ = i/n)⁻¹ in f64, row-major (n+1)²: C̃ = V⁻¹ Ĉ
/// (the chromaticity polynomials' fit, also used by tet_gpu's bake).
pub fn inverse_vandermonde(n: usize) -> Vec<f64> {
    let m = n + 1;
    let mut a = vec![0.0f64; m * 2 * m];
    for i in 0..m {
        let t = i as f64 / n as f64;
        for k in 0..m {
            a[i * 2 * m + k] = t.powi(k as i32);
        }
        a[i * 2 * m + m + i] = 1.0;
    }
    // Gauss–Jordan with partial pivoting; m ≤ 5 and the nodes are distinct.
    for col in 0..m {
        let piv = (col..m).max_by(|&x, &y| a[x * 2 * m + col].abs().total_cmp(&a[y * 2 * m + col].abs())).unwrap();
        if piv != col {
            for k in 0..2 * m {
                a.swap(col * 2 * m + k, piv * 2 * m + k);
            }
        }
        let d = a[col * 2 * m + col];
        for k in 0..2 * m {
            a[col * 2 * m + k] /= d;
        }
        for r in 0..m {
            if r != col {
                let f = a[r * 2 * m + col];
                if f != 0.0 {
                    for k in 0..2 * m {
                        a[r * 2 * m + k] -= f * a[col * 2 * m + k];
                    }
                }
            }
        }
    }
    (0..m).flat_map(|r| (0..m).map(move |c| (r, c))).map(|(r, c)| a[r * 2 * m + m + c]).collect()
}

/// The transfer function's nodes (colour and opacity merged) with κ and ρ at
/// each, so a segment's linear pieces are found without binary searches.
struct Nodes {
    s: Vec<f64>,
    rho: Vec<f64>,
    kappa: Vec<[f64; 3]>,
}

impl Nodes {
    fn new(tf: &TransferFunction) -> Self {
        let mut s = Vec::new();
        tf.breakpoints_between(f64::NEG_INFINITY, f64::INFINITY, &mut s);
        let rho = s.iter().map(|&x| tf.extinction(x)).collect();
        let kappa = s.iter().map(|&x| tf.color(x)).collect();
        Nodes { s, rho, kappa }
    }
}

/// One point of a segment's piecewise-linear profile: scalar, ρ, κ.
pub(crate) type Knot = (f64, f64, [f64; 3]);

/// Largest exponent change per Gauss–Legendre panel: with 6 nodes the
/// relative error on exp(−E) is then about 1e-12.
const PANEL_DEPTH: f64 = 1.5;

/// What one (Sf, Sb) entry needs: ∫ρ ds, ∫κρ ds, ∫κ ds over the scalar span
/// and, for each slice l_k = k·l_max/n (k = 1..n), C_k and α_k.
pub(crate) struct EntryIntegrals {
    int_rho: f64,
    int_krho: [f64; 3],
    int_k: [f64; 3],
    pub(crate) color: [[f64; 3]; 4],
    pub(crate) alpha: [f64; 4],
}

/// Integrates all n slices of one entry at once. Each linear piece uses
/// α = 1 − e^(−D) exactly and the Moreland–Angel form C = c_f·G + c_b·(α − G)
/// (density) or d·(c_f Ψ + (c_b − c_f) Ψ₁) (independent), with G = 1 − Ψ =
/// ∫₀¹ (1 − e^(−E(x))) dx evaluated by panelled 6-point Gauss–Legendre. The
/// slices share the nodes: slice k's exponent is (k/n)·E, so one `expm1` per
/// node serves every slice (1 − e^(−kE/n) = m·Σ_{q<k} (1 − m)^q, m = 1 − e^(−E/n)).
/// Agrees with `exact` to ~1e-9 (tested); about 10× faster than calling it n times.
pub(crate) fn integrate_entry(knots: &[Knot], l_max: f64, n: usize, emission: Emission) -> EntryIntegrals {
    let span = (knots[knots.len() - 1].0 - knots[0].0).abs();
    let per_scalar = l_max / span;
    let inv_n = 1.0 / n as f64;
    let mut out =
        EntryIntegrals { int_rho: 0.0, int_krho: [0.0; 3], int_k: [0.0; 3], color: [[0.0; 3]; 4], alpha: [0.0; 4] };
    let mut depth_total = 0.0; // of the l_max slice
    let mut trans = [1.0f64; 4];
    let mut saturated = false;
    for w in knots.windows(2) {
        let ((s0, r0, k0), (s1, r1, k1)) = (w[0], w[1]);
        let ds = (s1 - s0).abs();
        out.int_rho += 0.5 * ds * (r0 + r1);
        for c in 0..3 {
            out.int_k[c] += 0.5 * ds * (k0[c] + k1[c]);
            let km = 0.5 * (k0[c] + k1[c]);
            let rm = 0.5 * (r0 + r1);
            out.int_krho[c] += ds / 6.0 * (k0[c] * r0 + 4.0 * km * rm + k1[c] * r1);
        }
        if saturated {
            continue;
        }
        let d = ds * per_scalar; // world length of the piece in the l_max slice
        let a = r0 * d;
        let a_end = r1 * d;
        let b = a_end - a;
        let depth = 0.5 * (a + a_end);
        depth_total += depth;
        if depth == 0.0 {
            if emission == Emission::Independent {
                for k in 1..=n {
                    let dk = d * k as f64 * inv_n;
                    for c in 0..3 {
                        out.color[k - 1][c] += trans[k - 1] * dk * 0.5 * (k0[c] + k1[c]);
                    }
                }
            }
            continue;
        }
        // G_k = ∫(1 − e^{−kE/n}), Ψ1_k = ∫ x e^{−kE/n} over [0, 1].
        let mut g = [0.0f64; 4];
        let mut p0 = [0.0f64; 4];
        let mut p1 = [0.0f64; 4];
        // The loop below stops once the exponent passes 40·n, after at most
        // ~27·n + 1 panels, whatever this count is.
        let panels = ((a.max(a_end) / PANEL_DEPTH).ceil() as usize).clamp(1, 1 << 40);
        let h = 1.0 / panels as f64;
        for p in 0..panels {
            let x0 = p as f64 * h;
            // Past this the remaining integrand of the shortest slice is < e^{-40}.
            if (a * x0 + 0.5 * b * x0 * x0) * inv_n > 40.0 {
                for k in 1..=n {
                    // 1 − e^{−…} ≈ 1 over the rest.
                    g[k - 1] += 1.0 - x0;
                }
                break;
            }
            for &(xn, wn) in &GL6_NODES {
                let x = x0 + h * xn;
                let e = (a + 0.5 * b * x) * x * inv_n;
                // exp is cheaper than exp_m1; 1 − e1 loses relative precision
                // only where e < 0.05, and there exp_m1 is used.
                let (m, e1) = if e > 0.05 {
                    let e1 = (-e).exp();
                    (1.0 - e1, e1)
                } else {
                    let m = -(-e).exp_m1();
                    (m, 1.0 - m)
                };
                let (mut pow, mut geo) = (1.0, 0.0); // e1^k, Σ_{q<k} e1^q
                for k in 1..=n {
                    geo += pow;
                    pow *= e1;
                    g[k - 1] += wn * h * m * geo;
                    p0[k - 1] += wn * h * pow;
                    p1[k - 1] += wn * h * x * pow;
                }
            }
        }
        for k in 1..=n {
            let frac = k as f64 * inv_n;
            let alpha_piece = -(-depth * frac).exp_m1();
            let t = trans[k - 1];
            let col = &mut out.color[k - 1];
            match emission {
                Emission::Density => {
                    let gk = g[k - 1];
                    for c in 0..3 {
                        col[c] += t * (k0[c] * gk + k1[c] * (alpha_piece - gk));
                    }
                }
                Emission::Independent => {
                    let psi = p0[k - 1];
                    let dk = d * frac;
                    for c in 0..3 {
                        col[c] += t * dk * (k0[c] * psi + (k1[c] - k0[c]) * p1[k - 1]);
                    }
                }
            }
            trans[k - 1] = t * (1.0 - alpha_piece);
        }
        saturated = trans[0] < 1e-30;
    }
    for k in 1..=n {
        out.alpha[k - 1] = -(-depth_total * k as f64 * inv_n).exp_m1();
    }
    out
}

/// ∫ over [lo, hi] (lo < hi) of ρ by walking the TF's pieces (trapezoids are
/// exact for the linear pieces).
fn integral_rho(tf: &TransferFunction, lo: f64, hi: f64, scratch: &mut Vec<f64>) -> f64 {
    scratch.clear();
    scratch.push(lo);
    tf.breakpoints_between(lo, hi, scratch);
    scratch.push(hi);
    scratch.windows(2).map(|w| 0.5 * (w[1] - w[0]) * (tf.extinction(w[0]) + tf.extinction(w[1]))).sum()
}

/// P(sᵢ) = ∫_{s₀}^{sᵢ} ρ at every grid scalar (exact).
fn prefix_extinction(tf: &TransferFunction, grid: &[f64]) -> Vec<f64> {
    let mut out = Vec::with_capacity(grid.len());
    let mut acc = 0.0;
    let mut scratch = Vec::new();
    out.push(0.0);
    for w in grid.windows(2) {
        acc += integral_rho(tf, w[0], w[1], &mut scratch);
        out.push(acc);
    }
    out
}

/// β = ∫₀ˡ exp(−ρ̂ t) dt = l·(1 − e^(−x))/x, x = l·ρ̂: the colour weight under
/// independent emission (bounded where α/ρ̂ is 0/0).
#[inline]
fn beta_f64(l: f64, rho_hat: f64) -> f64 {
    let x = l * rho_hat;
    if x > 1e-8 {
        -(-x).exp_m1() / rho_hat
    } else {
        l * (1.0 - 0.5 * x)
    }
}

impl PolyTable {
    /// Bakes the table for `tf` (its x taken as given: denormalize a
    /// normalized TF first), rows in parallel on rayon's pool.
    pub fn build(tf: &TransferFunction, p: &PolyParams) -> Result<Self, PolyError> {
        check_params(p)?;
        if !tf.widgets().is_empty() {
            return Err(PolyError::Widgets(tf.widgets().len()));
        }
        let n = p.degree;
        let res = p.res;
        let band = band_for(res, p.s_lo, p.s_hi, p.max_ds);
        let row_len = band.map_or(res, |b| 2 * b + 1);
        let step = (p.s_hi - p.s_lo) / (res - 1) as f64;
        let grid: Vec<f64> = (0..res).map(|i| if i + 1 == res { p.s_hi } else { p.s_lo + i as f64 * step }).collect();
        let prefix = prefix_extinction(tf, &grid);
        let vinv = inverse_vandermonde(n);
        let emission = tf.emission();
        let stride = 3 * (n + 1);
        let mut rho = vec![0.0f32; res * row_len];
        let mut coef = vec![0.0f32; res * row_len * stride];
        let slice_l: Vec<f64> = (1..=n).map(|i| p.l_max * i as f64 / n as f64).collect();

        let nodes = Nodes::new(tf);
        // Nodes strictly inside (grid[i], grid[j]) are nodes[above[i]..below[j]].
        let above: Vec<usize> = grid.iter().map(|&x| nodes.s.partition_point(|&y| y <= x)).collect();
        let below: Vec<usize> = grid.iter().map(|&x| nodes.s.partition_point(|&y| y < x)).collect();
        let at_grid: Vec<Knot> = grid.iter().map(|&x| (x, tf.extinction(x), tf.color(x))).collect();
        let knot = |q: usize| (nodes.s[q], nodes.rho[q], nodes.kappa[q]);

        rho.par_chunks_mut(row_len).zip(coef.par_chunks_mut(row_len * stride)).enumerate().for_each(
            |(i, (rho_row, coef_row))| {
                let mut knots: Vec<Knot> = Vec::new();
                let mut chat = [[0.0f64; 3]; 5];
                for col in 0..row_len {
                    let j = match band {
                        None => col,
                        Some(b) => (i + col).saturating_sub(b).min(res - 1),
                    };
                    let (sf, sb) = (grid[i], grid[j]);
                    // ρ̂ from the prefix integral; ρ(Sf) on the diagonal.
                    let rho_hat = if i == j { at_grid[i].1 } else { (prefix[j] - prefix[i]) / (sb - sf) }.max(0.0);
                    if i == j {
                        // Constant κ along the segment: Ĉ(l) = κ for every l.
                        chat[..=n].fill(at_grid[i].2);
                    } else {
                        knots.clear();
                        knots.push(at_grid[i]);
                        if i < j {
                            knots.extend((above[i]..below[j]).map(knot));
                        } else {
                            knots.extend((above[j]..below[i]).rev().map(knot));
                        }
                        knots.push(at_grid[j]);
                        let e = integrate_entry(&knots, p.l_max, n, emission);
                        let width = (sb - sf).abs();
                        // Slice 0: the l → 0 limit.
                        chat[0] = match emission {
                            Emission::Density if e.int_rho > 0.0 => std::array::from_fn(|c| e.int_krho[c] / e.int_rho),
                            _ => std::array::from_fn(|c| e.int_k[c] / width),
                        };
                        for k in 1..=n {
                            let l = slice_l[k - 1];
                            let w = match emission {
                                Emission::Density => e.alpha[k - 1],
                                Emission::Independent => beta_f64(l, rho_hat),
                            };
                            // Below this the ratio is noise and Ĉ(l) = Ĉ₀ + O(l·ρ̂).
                            chat[k] = if w > 1e-9 * l.min(1.0) && w > 1e-12 {
                                std::array::from_fn(|c| e.color[k - 1][c] / w)
                            } else {
                                chat[0]
                            };
                        }
                    }
                    rho_row[col] = rho_hat as f32;
                    let out = &mut coef_row[col * stride..(col + 1) * stride];
                    for r in 0..=n {
                        for c in 0..3 {
                            let mut v = 0.0;
                            for (q, ch) in chat[..=n].iter().enumerate() {
                                v += vinv[r * (n + 1) + q] * ch[c];
                            }
                            out[r * 3 + c] = v as f32;
                        }
                    }
                }
            },
        );
        let mc = tf.max_color();
        Ok(Self::assemble(
            n,
            res,
            band,
            [p.s_lo as f32, p.s_hi as f32, p.l_max as f32],
            emission,
            [mc[0] as f32, mc[1] as f32, mc[2] as f32],
            rho,
            coef,
            AlphaTable::standard(),
        ))
    }

    #[allow(clippy::too_many_arguments)]
    fn assemble(
        degree: usize,
        res: usize,
        band: Option<usize>,
        [s_lo, s_hi, l_max]: [f32; 3],
        emission: Emission,
        max_color: [f32; 3],
        rho: Vec<f32>,
        coef: Vec<f32>,
        alpha: AlphaTable,
    ) -> Self {
        PolyTable {
            degree,
            res,
            band,
            s_lo,
            s_hi,
            l_max,
            emission,
            max_color,
            rho,
            coef,
            alpha,
            inv_ds: (res - 1) as f32 / (s_hi - s_lo),
            inv_l_max: 1.0 / l_max,
        }
    }

    /// This table's dimensions, range, emission and colour bound with other
    /// ρ̂, coefficients and α table, checked as [`PolyTable::from_parts`]
    /// checks them (e.g. the same values rounded to another precision).
    pub fn with_values(&self, rho: Vec<f32>, coef: Vec<f32>, alpha: AlphaTable) -> Result<Self, PolyError> {
        PolyTable::from_parts(
            self.degree(),
            self.res(),
            self.band(),
            self.s_range(),
            self.l_max(),
            self.emission(),
            self.max_color(),
            rho,
            coef,
            alpha,
        )
    }

    /// Rebuilds a table from stored parts (see the type's storage layout);
    /// checks every length against the dimensions and every value for NaN.
    #[allow(clippy::too_many_arguments)]
    pub fn from_parts(
        degree: usize,
        res: usize,
        band: Option<usize>,
        s_range: [f32; 2],
        l_max: f32,
        emission: Emission,
        max_color: [f32; 3],
        rho: Vec<f32>,
        coef: Vec<f32>,
        alpha: AlphaTable,
    ) -> Result<Self, PolyError> {
        let [s_lo, s_hi] = s_range;
        check_params(&PolyParams {
            degree,
            res,
            s_lo: f64::from(s_lo),
            s_hi: f64::from(s_hi),
            max_ds: f64::INFINITY,
            l_max: f64::from(l_max),
        })?;
        let row_len = match band {
            None => res,
            Some(b) if 2 * b + 1 < res => 2 * b + 1,
            Some(_) => return Err(PolyError::Length { what: "band row", expected: res, found: 0 }),
        };
        let cells = res * row_len;
        if rho.len() != cells {
            return Err(PolyError::Length { what: "rho", expected: cells, found: rho.len() });
        }
        let stride = 3 * (degree + 1);
        if coef.len() != cells * stride {
            return Err(PolyError::Length { what: "coef", expected: cells * stride, found: coef.len() });
        }
        if let Some(index) = rho.iter().position(|v| !v.is_finite() || *v < 0.0) {
            return Err(PolyError::NonFinite { what: "rho", index });
        }
        if let Some(index) = coef.iter().position(|v| !v.is_finite()) {
            return Err(PolyError::NonFinite { what: "coef", index });
        }
        if let Some(index) = max_color.iter().position(|v| !v.is_finite()) {
            return Err(PolyError::NonFinite { what: "max_color", index });
        }
        Ok(Self::assemble(degree, res, band, [s_lo, s_hi, l_max], emission, max_color, rho, coef, alpha))
    }

    pub fn degree(&self) -> usize {
        self.degree
    }
    pub fn res(&self) -> usize {
        self.res
    }
    /// Band half-width in samples, or None for the full square.
    pub fn band(&self) -> Option<usize> {
        self.band
    }
    /// Entries per stored row (res, or 2·band + 1).
    pub fn row_len(&self) -> usize {
        self.band.map_or(self.res, |b| 2 * b + 1)
    }
    pub fn s_range(&self) -> [f32; 2] {
        [self.s_lo, self.s_hi]
    }
    pub fn l_max(&self) -> f32 {
        self.l_max
    }
    pub fn emission(&self) -> Emission {
        self.emission
    }
    pub fn max_color(&self) -> [f32; 3] {
        self.max_color
    }
    /// ρ̂ per stored entry (res · row_len).
    pub fn rho(&self) -> &[f32] {
        &self.rho
    }
    /// C̃ coefficients per stored entry, 3·(degree + 1) each.
    pub fn coef(&self) -> &[f32] {
        &self.coef
    }
    pub fn alpha_table(&self) -> &AlphaTable {
        &self.alpha
    }
    /// Bytes held by the 2D tables and the α table.
    pub fn memory_bytes(&self) -> usize {
        4 * (self.rho.len() + self.coef.len()) + 2 * self.alpha.data.len()
    }
    /// Bytes the same tables would take without the band restriction.
    pub fn full_memory_bytes(&self) -> usize {
        4 * self.res * self.res * (1 + 3 * (self.degree + 1)) + 2 * self.alpha.data.len()
    }

    #[inline]
    fn entry(&self, i: usize, j: usize) -> usize {
        match self.band {
            None => i * self.res + j,
            Some(b) => i * (2 * b + 1) + (j + b).saturating_sub(i).min(2 * b),
        }
    }

    /// Premultiplied (C, α) for one segment (see the module docs).
    #[inline]
    pub fn lookup(&self, sf: f32, sb: f32, len_world: f32) -> Rgba32 {
        // NaN inputs collapse to 0 through max/min (they ignore NaN operands).
        // (not clamp: it keeps NaN)
        #[allow(clippy::manual_clamp)]
        let l = len_world.max(0.0).min(1e30);
        if l == 0.0 {
            return [0.0; 4];
        }
        let top = (self.res - 1) as f32;
        let u = ((sf - self.s_lo) * self.inv_ds).max(0.0).min(top);
        let v = ((sb - self.s_lo) * self.inv_ds).max(0.0).min(top);
        let i0 = (u as usize).min(self.res - 2);
        let j0 = (v as usize).min(self.res - 2);
        let (fu, fv) = (u - i0 as f32, v - j0 as f32);
        let w = [(1.0 - fu) * (1.0 - fv), fu * (1.0 - fv), (1.0 - fu) * fv, fu * fv];
        self.shade_cell(l, i0, j0, w, (l * self.inv_l_max).min(1.0))
    }

    /// The lookup's body once the cell is located: entries (i0, j0) to
    /// (i0 + 1, j0 + 1) with bilinear weights `w` (that order), length
    /// `l` > 0 and t = min(l / l_max, 1). [`PolyTable::lookup`] and the
    /// lane-wise `shade_batch` both end here, so they agree bit for bit.
    #[inline(always)]
    fn shade_cell(&self, l: f32, i0: usize, j0: usize, w: [f32; 4], t: f32) -> Rgba32 {
        let e = [self.entry(i0, j0), self.entry(i0 + 1, j0), self.entry(i0, j0 + 1), self.entry(i0 + 1, j0 + 1)];
        let mut rho_hat = 0.0;
        for k in 0..4 {
            rho_hat += w[k] * self.rho[e[k]];
        }
        let x = l * rho_hat;
        let alpha = self.alpha.alpha(x);
        let stride = 3 * (self.degree + 1);
        // Per channel Σ_r t^r Σ_k w_k·coef (Vec4 lanes are the channels).
        let mut chat = Vec4::ZERO;
        let mut tp = 1.0f32;
        for r in 0..=self.degree {
            let mut v = Vec4::ZERO;
            for k in 0..4 {
                let c = &self.coef[e[k] * stride + r * 3..e[k] * stride + r * 3 + 3];
                v += Vec4::new(c[0], c[1], c[2], 0.0) * w[k];
            }
            chat += v * tp;
            tp *= t;
        }
        let (weight, bound) = match self.emission {
            Emission::Density => (alpha, alpha),
            Emission::Independent => {
                let beta = if x > 1e-4 { -(-x).exp_m1() / rho_hat } else { l * (1.0 - 0.5 * x) };
                (beta, l)
            }
        };
        let chat = chat.to_array();
        let mut out = [0.0f32, 0.0, 0.0, alpha];
        for c in 0..3 {
            out[c] = (weight * chat[c]).max(0.0).min(bound * self.max_color[c]);
        }
        out
    }
}

impl SegmentShader for PolyTable {
    fn method(&self) -> Method {
        match self.degree {
            1 => Method::Poly1,
            2 => Method::Poly2,
            _ => Method::Poly4,
        }
    }
    fn shade(&self, seg: &Segment) -> Rgba32 {
        self.lookup(seg.s_front, seg.s_back, seg.len_world)
    }

    /// [`PolyTable::lookup`] eight segments at a time: the (Sf, Sb) cells,
    /// weights and l terms lane-wise (vectorized), then per lane the ρ̂ and
    /// colour-polynomial sums with the three channels in one vector: the
    /// same operations in the same order, so the same values.
    fn shade_batch(&self, segs: &SegmentBatch, out: &mut [Rgba32; BATCH]) {
        const W: usize = 8;
        let n = segs.len.min(BATCH);
        let (top, top_i) = (f32x8::splat((self.res - 1) as f32), f32x8::splat((self.res - 2) as f32));
        let (lo, inv) = (f32x8::splat(self.s_lo), f32x8::splat(self.inv_ds));
        let (zero, one) = (f32x8::ZERO, f32x8::ONE);
        for blk in (0..n).step_by(W) {
            let lanes = |a: &[f32; BATCH]| -> f32x8 {
                let v: [f32; W] = a[blk..blk + W].try_into().expect("BATCH is a multiple of W");
                f32x8::from(v)
            };
            let l = vmin(vmax(no_nan(lanes(&segs.len_world), zero), zero), f32x8::splat(1e30));
            let cell = |s: f32x8| {
                let u = vmin(vmax(no_nan((s - lo) * inv, zero), zero), top);
                let i = vmin(u, top_i).fast_trunc_int();
                (i.to_array(), u - f32x8::from_i32x8(i))
            };
            let ((i0, fu), (j0, fv)) = (cell(lanes(&segs.s_front)), cell(lanes(&segs.s_back)));
            let w = [(one - fu) * (one - fv), fu * (one - fv), (one - fu) * fv, fu * fv].map(|v| v.to_array());
            let t = vmin(l * f32x8::splat(self.inv_l_max), one).to_array();
            let l = l.to_array();
            for lane in 0..(n - blk).min(W) {
                let o = &mut out[blk + lane];
                let l = l[lane];
                if l == 0.0 {
                    *o = [0.0; 4];
                    continue;
                }
                let wk = [w[0][lane], w[1][lane], w[2][lane], w[3][lane]];
                *o = self.shade_cell(l, i0[lane] as usize, j0[lane] as usize, wk, t[lane]);
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn vandermonde_inverse_reproduces_polynomials() {
        for n in [1, 2, 4] {
            let vi = inverse_vandermonde(n);
            // Samples of 1 + 2t − 3t² at tᵢ = i/n recover the coefficients (padded).
            let f = |t: f64| 1.0 + 2.0 * t - if n >= 2 { 3.0 * t * t } else { 0.0 };
            let ys: Vec<f64> = (0..=n).map(|i| f(i as f64 / n as f64)).collect();
            let c: Vec<f64> = (0..=n).map(|r| (0..=n).map(|q| vi[r * (n + 1) + q] * ys[q]).sum()).collect();
            assert!((c[0] - 1.0).abs() < 1e-12 && (c[1] - 2.0).abs() < 1e-12, "{c:?}");
            if n >= 2 {
                assert!((c[2] + 3.0).abs() < 1e-12);
            }
        }
    }

    #[test]
    fn alpha_table_is_accurate_to_16_bits() {
        let t = AlphaTable::standard();
        for k in 0..10_000 {
            let x = k as f32 * 0.0015;
            let want = -(-(x as f64)).exp_m1();
            assert!((t.alpha(x) as f64 - want).abs() < 1.2e-5, "x = {x}");
        }
        assert_eq!(t.alpha(f32::NAN), 0.0);
        assert_eq!(t.alpha(1e30), 1.0);
    }

    fn knots_for(tf: &TransferFunction, sf: f64, sb: f64) -> Vec<Knot> {
        let mut xs = vec![sf];
        tf.breakpoints_between(sf.min(sb), sf.max(sb), &mut xs);
        if sb < sf {
            xs[1..].reverse();
        }
        xs.push(sb);
        xs.iter().map(|&x| (x, tf.extinction(x), tf.color(x))).collect()
    }

    #[test]
    fn entry_kernel_matches_exact() {
        let base = TransferFunction::from_json(include_str!("../tests/data/vtk/tf_ramp.json")).unwrap();
        let mut next = crate::lcg_unit(12345);
        for emission in [Emission::Density, Emission::Independent] {
            let tf = base.clone().with_emission(emission);
            for _ in 0..2000 {
                let (sf, sb) = (next() * 1.2 - 0.1, next() * 1.2 - 0.1);
                let l_max = [0.01, 1.0, 30.0, 1e4][(next() * 4.0) as usize];
                for n in [1, 2, 4] {
                    let e = integrate_entry(&knots_for(&tf, sf, sb), l_max, n, emission);
                    for k in 1..=n {
                        let want = crate::integrate_segment(&tf, sf, sb, l_max * k as f64 / n as f64);
                        let tol = 1e-9 * (1.0 + want.color.iter().fold(0.0f64, |m, v| m.max(v.abs())));
                        assert!((e.alpha[k - 1] - want.alpha).abs() < 1e-12, "{sf} {sb} {l_max} {n} {k}");
                        for c in 0..3 {
                            assert!(
                                (e.color[k - 1][c] - want.color[c]).abs() < tol,
                                "{emission:?} sf {sf} sb {sb} l {l_max} n {n} k {k}: {} vs {}",
                                e.color[k - 1][c],
                                want.color[c]
                            );
                        }
                    }
                }
            }
        }
    }

    #[test]
    fn band_layout_indices() {
        assert_eq!(band_for(512, 0.0, 1.0, f64::INFINITY), None);
        assert_eq!(band_for(512, 0.0, 1.0, 0.9), None);
        let b = band_for(512, 0.0, 1.0, 0.1).unwrap();
        assert!(b as f64 >= 0.1 * 511.0 + 1.0);
    }
}
