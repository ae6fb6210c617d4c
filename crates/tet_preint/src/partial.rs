//! `partial`: partial pre-integration (Moreland & Angel 2004; VTK's
//! `vtkUnstructuredGridPartialPreIntegration`).
//!
//! On a piece of a segment where colour and extinction are linear (the
//! segment split at the TF's control points, as `exact` does), with
//! a = d·ρ_front and c = d·ρ_back the piece's optical-depth rates (d its
//! length),
//!
//!   Ψ(a, c) = ∫₀¹ exp(−a x − (c − a) x²/2) dx,    ζ = exp(−(a + c)/2),
//!   density emission:     C = κ_f (1 − Ψ) + κ_b (Ψ − ζ),  α = 1 − ζ,
//!   independent emission: C = d [κ_f Ψ + (κ_b − κ_f) Ψ₁],  Ψ₁ = ∫₀¹ x exp(…) dx.
//!
//! Ψ (and Ψ₁) depend on no transfer function: [`PsiTable`] tabulates them
//! once over γ = x / (1 + x) ∈ [0, 1] per axis (γ = 1 is x = ∞, where
//! Ψ = Ψ₁ = 0), and a TF edit costs nothing. ζ is computed directly.
//! The f64 Ψ uses `exact`'s series in (c − a) near the diagonal and the same
//! erfcx/Dawson closed form elsewhere (with the faster f32-grade Dawson).

use crate::domain::{check_res, TableError};
use crate::exact::{psi_series, B_SERIES};
use crate::method::{Method, Rgba32, Segment, SegmentShader};
use crate::precision::{Precision, Storage};
use crate::special::{dawson_fast, erfcx};
use crate::tf::{Emission, TransferFunction};
use rayon::prelude::*;
use serde::{Deserialize, Serialize};
use std::sync::Arc;

/// (Ψ, Ψ₁) for front/back rates a, c ≥ 0 (finite), in f64.
pub fn psi(a: f64, c: f64) -> (f64, f64) {
    let b = c - a;
    if b.abs() <= B_SERIES {
        return psi_series(a, b);
    }
    let p0 = psi_closed(a, c);
    // a Ψ + b Ψ₁ = 1 − ζ.
    let alpha = -(-(0.5 * (a + c))).exp_m1();
    (p0, (alpha - a * p0) / b)
}

/// Ψ alone (the table without Ψ₁ needs no more): [`psi`]'s first value.
#[inline]
fn psi0(a: f64, c: f64) -> f64 {
    let b = c - a;
    if b.abs() <= B_SERIES {
        return psi_series(a, b).0;
    }
    psi_closed(a, c)
}

/// Ψ in closed form, |c − a| > [`B_SERIES`].
#[inline]
fn psi_closed(a: f64, c: f64) -> f64 {
    let b = c - a;
    let zeta = (-(0.5 * (a + c))).exp();
    let k = 1.0 / (2.0 * b.abs()).sqrt();
    let (f, e) = (a * k, c * k);
    if b > 0.0 {
        std::f64::consts::PI.sqrt() * k * (erfcx(f) - zeta * erfcx(e))
    } else {
        2.0 * k * (dawson_fast(f) - zeta * dawson_fast(e))
    }
}

/// Above this rate independent emission evaluates Ψ, Ψ₁ in closed form:
/// its colour is d·Ψ-weighted, Ψ ~ 1/rate there, and the table's cells near
/// γ = 1 are too coarse for a relative accuracy (density emission weights Ψ
/// by bounded colours and always uses the table).
pub const INDEPENDENT_DIRECT_RATE: f64 = 8.0;

/// γ ↔ x for the table axes.
#[inline]
fn to_gamma(x: f32) -> f32 {
    x / (1.0 + x)
}

/// Resolution and storage of a [`PsiTable`].
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
pub struct PsiParams {
    /// Samples per axis over γ ∈ [0, 1] (VTK uses 512).
    pub res: usize,
    /// Also tabulate Ψ₁ (needed for independent emission only).
    pub first_moment: bool,
    pub precision: Precision,
}

impl Default for PsiParams {
    /// 1024², Ψ only, f32.
    fn default() -> Self {
        PsiParams { res: 1024, first_moment: false, precision: Precision::F32 }
    }
}

/// The transfer-function-independent Ψ (and optionally Ψ₁) table,
/// `res × res` over (γ_front, γ_back), row-major by γ_back.
#[derive(Debug, Clone)]
pub struct PsiTable {
    params: PsiParams,
    data: Storage,
}

impl PsiTable {
    pub fn build(params: &PsiParams) -> Result<PsiTable, TableError> {
        check_res("partial psi res", params.res, 2, 1 << 13)?;
        let (res, ch) = (params.res, if params.first_moment { 2 } else { 1 });
        let top = (res - 1) as f64;
        let mut values = vec![0.0f32; res * res * ch];
        // The rate of every sample γ (the same for both axes); γ = 1 is an
        // infinite rate, where Ψ = Ψ₁ = 0.
        let rate: Vec<Option<f64>> = (0..res)
            .map(|i| {
                let g = i as f64 / top;
                (g < 1.0).then(|| g / (1.0 - g))
            })
            .collect();
        values.par_chunks_mut(res * ch).enumerate().for_each(|(j, row)| {
            let Some(c) = rate[j] else { return };
            for (i, a) in rate.iter().enumerate() {
                let Some(a) = *a else { continue };
                if ch == 2 {
                    let (p0, p1) = psi(a, c);
                    (row[i * 2], row[i * 2 + 1]) = (p0 as f32, p1 as f32);
                } else {
                    row[i] = psi0(a, c) as f32;
                }
            }
        });
        Ok(PsiTable { params: *params, data: Storage::encode(values, ch, params.precision) })
    }

    /// Reassembles a table from stored parts.
    pub fn from_parts(params: PsiParams, data: Storage) -> Option<PsiTable> {
        let ch = if params.first_moment { 2 } else { 1 };
        if params.res < 2 || params.res > 1 << 13 {
            return None;
        }
        if data.channels() != ch || data.precision() != params.precision || data.len() != params.res * params.res * ch {
            return None;
        }
        Some(PsiTable { params, data })
    }

    pub fn params(&self) -> &PsiParams {
        &self.params
    }
    pub fn storage(&self) -> &Storage {
        &self.data
    }
    pub fn memory_bytes(&self) -> usize {
        self.data.memory_bytes()
    }

    /// Bilinear (Ψ, Ψ₁) at rates a, c ≥ 0 (Ψ₁ is 0 without the first moment).
    #[inline]
    pub fn lookup(&self, a: f32, c: f32) -> (f32, f32) {
        let top = (self.params.res - 1) as f32;
        let x = (to_gamma(a.max(0.0)) * top).min(top);
        let y = (to_gamma(c.max(0.0)) * top).min(top);
        let (x, y) = (if x.is_nan() { top } else { x }, if y.is_nan() { top } else { y });
        let i0 = (x as usize).min(self.params.res - 2);
        let j0 = (y as usize).min(self.params.res - 2);
        let (fx, fy) = (x - i0 as f32, y - j0 as f32);
        let ch = self.data.channels();
        let at = |i: usize, j: usize, k: usize| self.data.get((j * self.params.res + i) * ch + k);
        let lerp2 = |k: usize| {
            let r0 = at(i0, j0, k) + fx * (at(i0 + 1, j0, k) - at(i0, j0, k));
            let r1 = at(i0, j0 + 1, k) + fx * (at(i0 + 1, j0 + 1, k) - at(i0, j0 + 1, k));
            r0 + fy * (r1 - r0)
        };
        (lerp2(0), if ch == 2 { lerp2(1) } else { 0.0 })
    }
}

/// The `partial` method for one TF: split at its control points, each piece
/// from the shared Ψ table.
#[derive(Debug, Clone)]
pub struct PartialShader {
    tf: TransferFunction,
    psi: Arc<PsiTable>,
}

impl PartialShader {
    /// Fails when `tf` uses independent emission and `psi` lacks Ψ₁.
    pub fn new(tf: TransferFunction, psi: Arc<PsiTable>) -> Result<PartialShader, TableError> {
        if tf.emission() == Emission::Independent && !psi.params().first_moment {
            return Err(TableError::Invalid(
                "partial: independent emission needs a Ψ table built with first_moment".into(),
            ));
        }
        Ok(PartialShader { tf, psi })
    }
    pub fn transfer_function(&self) -> &TransferFunction {
        &self.tf
    }
    pub fn psi(&self) -> &Arc<PsiTable> {
        &self.psi
    }

    /// (C, α) of a segment; non-finite or negative input gives 0.
    pub fn integrate(&self, sf: f32, sb: f32, len_world: f32, scratch: &mut Vec<f64>) -> Rgba32 {
        if !(sf.is_finite() && sb.is_finite() && len_world > 0.0) {
            return [0.0; 4];
        }
        let (sf, sb, len) = (sf as f64, sb as f64, (len_world as f64).min(1e30));
        let independent = self.tf.emission() == Emission::Independent;
        scratch.clear();
        scratch.push(sf);
        if sf != sb {
            self.tf.breakpoints_between(sf.min(sb), sf.max(sb), scratch);
            if sb < sf {
                scratch[1..].reverse();
            }
        }
        scratch.push(sb);
        let per_scalar = if sf == sb { 0.0 } else { len / (sb - sf).abs() };
        let (mut color, mut trans, mut depth) = ([0.0f64; 3], 1.0f64, 0.0f64);
        let (mut c0, mut r0) = (self.tf.color(sf), self.tf.extinction(sf));
        for w in scratch.windows(2) {
            let (c1, r1) = (self.tf.color(w[1]), self.tf.extinction(w[1]));
            let d = if sf == sb { len } else { (w[1] - w[0]).abs() * per_scalar };
            let (a, c) = (d * r0, d * r1);
            let piece_depth = 0.5 * (a + c);
            let zeta = (-piece_depth).exp();
            let (p0, p1) = if independent && a.max(c) > INDEPENDENT_DIRECT_RATE {
                psi(a, c)
            } else {
                let (p0, p1) = self.psi.lookup(a as f32, c as f32);
                (p0 as f64, p1 as f64)
            };
            for k in 0..3 {
                let ck = if independent {
                    d * (c0[k] * p0 + (c1[k] - c0[k]) * p1)
                } else {
                    c0[k] * (1.0 - p0) + c1[k] * (p0 - zeta)
                };
                color[k] += trans * ck.max(0.0);
            }
            trans *= zeta;
            depth += piece_depth;
            (c0, r0) = (c1, r1);
        }
        let alpha = -(-depth).exp_m1();
        [color[0] as f32, color[1] as f32, color[2] as f32, alpha as f32]
    }
}

impl SegmentShader for PartialShader {
    fn method(&self) -> Method {
        Method::Partial
    }
    fn shade(&self, seg: &Segment) -> Rgba32 {
        thread_local! {
            static SCRATCH: std::cell::RefCell<Vec<f64>> = const { std::cell::RefCell::new(Vec::new()) };
        }
        SCRATCH.with(|s| self.integrate(seg.s_front, seg.s_back, seg.len_world, &mut s.borrow_mut()))
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::integrate_segment;

    #[test]
    fn psi_limits() {
        let (p, p1) = psi(0.0, 0.0);
        assert!((p - 1.0).abs() < 1e-15 && (p1 - 0.5).abs() < 1e-15);
        // Constant rate a: Ψ = (1 − e^{−a})/a.
        let (p, _) = psi(2.0, 2.0);
        assert!((p - (1.0 - (-2.0f64).exp()) / 2.0).abs() < 1e-14);
        // Both sides of the series switch agree.
        let (x, _) = psi(1.0, 1.0099);
        let (y, _) = psi(1.0, 1.0101);
        assert!((x - y).abs() < 1e-4);
    }

    #[test]
    fn partial_matches_exact() {
        let tf = TransferFunction::from_json(
            r#"{"color": [[0, 0.1, 0.2, 0.9], [0.5, 0.9, 0.9, 0.2], [1, 1, 0.1, 0]],
                "opacity": [[0, 0], [0.4, 0.05], [0.45, 3], [0.55, 3], [0.6, 0.1], [1, 0.4]], "unit_distance": 0.5}"#,
        )
        .unwrap();
        let psi = Arc::new(PsiTable::build(&PsiParams { res: 256, first_moment: true, ..Default::default() }).unwrap());
        for emission in [Emission::Density, Emission::Independent] {
            let tf = tf.clone().with_emission(emission);
            let sh = PartialShader::new(tf.clone(), psi.clone()).unwrap();
            let mut worst = 0.0f64;
            for i in 0..40 {
                for j in 0..40 {
                    for l in [0.0, 1e-4, 0.05, 0.5, 3.0, 100.0] {
                        let (sf, sb) = (i as f32 / 39.0 * 1.2 - 0.1, j as f32 / 39.0 * 1.2 - 0.1);
                        let got = sh.shade(&Segment { s_front: sf, s_back: sb, len_world: l, ..Default::default() });
                        let want = integrate_segment(&tf, sf as f64, sb as f64, l as f64).to_array();
                        for c in 0..4 {
                            assert!(got[c].is_finite());
                            // Independent emission's C grows like l·κ (no α bound):
                            // its error is relative to max(1, |C|).
                            worst = worst.max((got[c] as f64 - want[c]).abs() / want[c].abs().max(1.0));
                        }
                    }
                }
            }
            assert!(worst < 2e-3, "{emission:?}: {worst}");
        }
        let no_moment = Arc::new(PsiTable::build(&PsiParams { res: 16, ..Default::default() }).unwrap());
        assert!(PartialShader::new(tf.with_emission(Emission::Independent), no_moment).is_err());
    }
}
