//! The reference with lighting and shadows: the ground truth of every lit
//! or shadowed image.
//!
//! Along each camera ray the emitted radiance is, at every point,
//! `w(s)·κ(s)·D(x) + ρ(s)·S(x)` (w = ρ for density emission, 1 for
//! independent emission; D and S the lighting terms of
//! [`crate::shading`]), attenuated by the ray's transmittance. Inside each
//! ray–tet segment the TF's nodes split the segment into pieces on which
//! κ and ρ are linear; each piece is split where its optical depth reaches
//! ½, 1, 2, 4, … and integrated by adaptive Gauss–Kronrod (7/15 points,
//! halving until the Kronrod–Gauss difference is below the tolerance) with
//! the transmittance in closed form, so the only error is the
//! quadrature's, bounded by [`LitReference::tolerance`]. D and S come
//! from the gradient interpolated linearly in the tet (exact at every
//! node) and, with shadows, from an exact shadow ray cast from each node
//! to each light ([`ShadowMode::Exact`]) or from the [`ShadowField`]'s
//! maps looked up there ([`ShadowMode::Field`]), which
//! separates the field's error from the fast renderers' lighting error.
//!
//! Silhouettes are a per-segment effect of the fast renderers, not part of
//! the optical model: the reference ignores them.

use glam::DVec3;
use tet_preint::{Emission, TransferFunction};

use super::{LineSegment, RayResult, RayScratch, ReferenceOptions, ReferenceRenderer, ReferenceStats};
use crate::shading::Shading;
use crate::shadow::{ShadowMode, ShadowScratch};
use crate::{Camera, Image, RenderError};

/// `progress(rows_done, rows_total)`, called from worker threads.
pub type RowProgress<'p> = &'p (dyn Fn(u32, u32) + Sync);

/// Lighting for a reference render.
#[derive(Debug, Clone, Copy)]
pub struct LitReference<'a> {
    pub shading: Shading,
    /// Per-vertex gradients (world frame), one per mesh point.
    pub gradients: &'a [[f64; 3]],
    pub shadows: ShadowMode<'a>,
    /// Largest quadrature error allowed per TF piece, in premultiplied
    /// colour (the default 1e-6 keeps a ray's error far below 8-bit steps).
    pub tolerance: f64,
    /// Early termination, as for the unlit reference.
    pub options: ReferenceOptions,
}

impl<'a> LitReference<'a> {
    pub fn new(shading: Shading, gradients: &'a [[f64; 3]], shadows: ShadowMode<'a>) -> LitReference<'a> {
        LitReference { shading, gradients, shadows, tolerance: 1e-6, options: ReferenceOptions::default() }
    }
}

// Gauss–Kronrod 7/15 nodes on [−1, 1] (x ≥ 0 half) and weights.
const XGK: [f64; 8] = [
    0.991_455_371_120_812_6,
    0.949_107_912_342_758_5,
    0.864_864_423_359_769_1,
    0.741_531_185_599_394_4,
    0.586_087_235_467_691_1,
    0.405_845_151_377_397_2,
    0.207_784_955_007_898_5,
    0.0,
];
const WGK: [f64; 8] = [
    0.022_935_322_010_529_22,
    0.063_092_092_629_978_55,
    0.104_790_010_322_250_18,
    0.140_653_259_715_525_92,
    0.169_004_726_639_267_9,
    0.190_350_578_064_785_4,
    0.204_432_940_075_298_9,
    0.209_482_141_084_727_83,
];
// Gauss weights of the nodes XGK[1], XGK[3], XGK[5], XGK[7].
const WG: [f64; 4] =
    [0.129_484_966_168_869_7, 0.279_705_391_489_276_7, 0.381_830_050_505_118_9, 0.417_959_183_673_469_4];

/// Deepest halving of one piece (2^−20 of it).
const MAX_DEPTH: u32 = 20;

/// One linear piece of a segment: parameters, colours and extinctions at
/// both ends.
struct Piece {
    t0: f64,
    d: f64,
    c0: [f64; 3],
    c1: [f64; 3],
    rho0: f64,
    rho1: f64,
}

struct LitRay<'r, 'a> {
    r: &'r ReferenceRenderer<'a>,
    lit: &'r LitReference<'r>,
    tf: &'r TransferFunction,
    view_dir: DVec3,
    line: &'r super::Line,
    seg: &'r LineSegment,
    g_front: [f64; 3],
    g_back: [f64; 3],
}

impl LitRay<'_, '_> {
    /// The lighting terms at parameter t of the segment.
    fn terms(&self, t: f64, shadow: &mut ShadowScratch, stats: &mut ReferenceStats) -> (f64, f64) {
        let u = self.seg.frac(t);
        let g =
            DVec3::from(std::array::from_fn::<f64, 3, _>(|c| self.g_front[c] + u * (self.g_back[c] - self.g_front[c])));
        let pos = self.line.at(t);
        let lights = self.lit.shading.sources;
        let p = self.lit.shading.lit_point(g, pos, self.view_dir, |i| match self.lit.shadows {
            ShadowMode::Exact => (-self.r.depth_to_light(pos, &lights.lights()[i], self.tf, shadow, stats)).exp(),
            ShadowMode::Field(f) => (-f.depth_at(i, pos)).exp(),
        });
        (p.diffuse, p.specular)
    }

    /// Emitted radiance (rgb) at local distance v into `piece`, attenuated
    /// by the piece's own transmittance from its front.
    fn integrand(&self, p: &Piece, v: f64, shadow: &mut ShadowScratch, stats: &mut ReferenceStats) -> [f64; 3] {
        let f = if p.d > 0.0 { v / p.d } else { 0.0 };
        let rho = p.rho0 + f * (p.rho1 - p.rho0);
        let depth = p.rho0 * v + 0.5 * (p.rho1 - p.rho0) * v * f;
        let tr = (-depth).exp();
        if tr == 0.0 {
            return [0.0; 3];
        }
        let (d, s) = self.terms(p.t0 + v, shadow, stats);
        let w = match self.tf.emission() {
            Emission::Density => rho,
            Emission::Independent => 1.0,
        };
        std::array::from_fn(|k| tr * (w * (p.c0[k] + f * (p.c1[k] - p.c0[k])) * d + rho * s))
    }

    /// ∫ over the whole piece: split where its optical depth from the front
    /// reaches ½, 1, 2, 4, … (so that no interval holds more than a
    /// doubling of depth, and an opaque piece's light, all in a thin layer
    /// at its front, is not missed by the quadrature nodes), each interval
    /// integrated adaptively; intervals beyond depth 46 (transmittance
    /// 1e-20) are dropped.
    fn integrate_piece(&self, p: &Piece, tol: f64, shadow: &mut ShadowScratch, stats: &mut ReferenceStats) -> [f64; 3] {
        // Depth τ(v) = ρ0 v + (ρ1 − ρ0) v² / (2d), increasing; v(τ) solves
        // the quadratic in its stable form.
        let a = 0.5 * (p.rho1 - p.rho0) / p.d;
        let total = 0.5 * (p.rho0 + p.rho1) * p.d;
        let v_at = |tau: f64| {
            let disc = (p.rho0 * p.rho0 + 4.0 * a * tau).max(0.0).sqrt();
            (2.0 * tau / (p.rho0 + disc)).clamp(0.0, p.d)
        };
        let mut out = [0.0; 3];
        let (mut v0, mut tau) = (0.0, 0.5);
        loop {
            let last = tau >= total || tau > 46.0;
            let v1 = if last { p.d } else { v_at(tau) };
            if v1 > v0 {
                let part = self.integrate(p, v0, v1, tol, 0, shadow, stats);
                for (o, x) in out.iter_mut().zip(part) {
                    *o += x;
                }
            }
            if last {
                return out;
            }
            v0 = v1;
            tau *= 2.0;
        }
    }

    /// ∫ over [a, b] ⊂ [0, d] of the piece's integrand, adaptively.
    #[allow(clippy::too_many_arguments)]
    fn integrate(
        &self,
        p: &Piece,
        a: f64,
        b: f64,
        tol: f64,
        depth: u32,
        shadow: &mut ShadowScratch,
        stats: &mut ReferenceStats,
    ) -> [f64; 3] {
        let (mid, half) = (0.5 * (a + b), 0.5 * (b - a));
        let mut kron = [0.0; 3];
        let mut gauss = [0.0; 3];
        for (j, (&x, &wk)) in XGK.iter().zip(&WGK).enumerate() {
            let nodes: &[f64] = if x == 0.0 { &[0.0] } else { &[-x, x] };
            for &xn in nodes {
                let val = self.integrand(p, mid + half * xn, shadow, stats);
                for k in 0..3 {
                    kron[k] += wk * val[k];
                    if j % 2 == 1 {
                        gauss[k] += WG[j / 2] * val[k];
                    }
                }
            }
        }
        let err = (0..3).map(|k| (kron[k] - gauss[k]).abs() * half).fold(0.0, f64::max);
        if err <= tol || depth >= MAX_DEPTH {
            return kron.map(|v| v * half);
        }
        let l = self.integrate(p, a, mid, 0.5 * tol, depth + 1, shadow, stats);
        let r = self.integrate(p, mid, b, 0.5 * tol, depth + 1, shadow, stats);
        std::array::from_fn(|k| l[k] + r[k])
    }
}

impl ReferenceRenderer<'_> {
    fn check_lit(&self, lit: &LitReference) -> Result<(), RenderError> {
        if lit.gradients.len() != self.points.len() {
            return Err(RenderError::Scene(format!(
                "{} gradients for {} points",
                lit.gradients.len(),
                self.points.len()
            )));
        }
        if let Some(i) = lit.gradients.iter().position(|g| !g.iter().all(|c| c.is_finite())) {
            return Err(RenderError::Scene(format!("gradient of point {i} is not finite")));
        }
        if let ShadowMode::Field(f) = lit.shadows {
            if f.key().num_points != self.points.len() || f.key().lights != lit.shading.sources {
                return Err(RenderError::Scene(
                    "the shadow field was computed for another mesh or other lights".to_string(),
                ));
            }
        }
        if !(lit.tolerance > 0.0 && lit.tolerance.is_finite()) {
            return Err(RenderError::Scene(format!("quadrature tolerance {} is not > 0", lit.tolerance)));
        }
        Ok(())
    }

    /// [`ReferenceRenderer::render`] with lighting (and shadows): see the
    /// module docs. Without lighting (`lit.shading.light` None) the image
    /// is the unlit reference's.
    pub fn render_lit(
        &self,
        camera: &Camera,
        tf: &TransferFunction,
        lit: &LitReference,
        progress: RowProgress,
    ) -> Result<(Image, ReferenceStats), RenderError> {
        let options = &lit.options;
        self.check_lit(lit)?;
        if tf.normalized() {
            return Err(RenderError::NormalizedTransferFunction);
        }
        if lit.shading.light.is_some() && !tf.widgets().is_empty() {
            return Err(RenderError::Scene(
                "the lit reference needs a 1D transfer function (this one has 2D widgets)".into(),
            ));
        }
        self.render_rows(camera, progress, &|x, y, scratch| {
            if lit.shading.light.is_none() {
                return self.trace_pixel(camera, x, y, tf, options, scratch);
            }
            let (origin, dir) = camera.ray(x, y);
            let t_start =
                if camera.is_parallel() { f64::NEG_INFINITY } else { camera.near_depth() / dir.dot(camera.forward()) };
            match super::Line::through(origin, origin + dir) {
                Some(line) => self.trace_line_lit(&line, t_start, tf, lit, scratch),
                None => RayResult { stats: ReferenceStats { rays: 1, ..Default::default() }, ..Default::default() },
            }
        })
    }

    /// [`ReferenceRenderer::trace_line`] with lighting, along `line` from
    /// parameter `t_start` on.
    fn trace_line_lit(
        &self,
        line: &super::Line,
        t_start: f64,
        tf: &TransferFunction,
        lit: &LitReference,
        scratch: &mut RayScratch,
    ) -> RayResult {
        let options = &lit.options;
        let mut res = RayResult { stats: ReferenceStats { rays: 1, ..Default::default() }, ..Default::default() };
        let mut acc = [0.0f64; 4];
        let (breakpoints, shadow) = (&mut scratch.breakpoints, &mut scratch.shadow);
        let mut shadow_stats = ReferenceStats::default();
        self.walk_line(line, t_start, &mut scratch.entries, &mut res.stats, &mut |seg| {
            let ray = LitRay {
                r: self,
                lit,
                tf,
                view_dir: line.unit,
                line,
                seg,
                g_front: seg.front.interp(lit.gradients),
                g_back: seg.back.interp(lit.gradients),
            };
            // The TF's nodes between the two scalars, in the order the ray
            // meets them, as parameters.
            let (s0, s1, t0, len) = (seg.s_front(), seg.back.s, seg.t_front, seg.len());
            breakpoints.clear();
            breakpoints.push(s0);
            if s0 != s1 {
                tf.breakpoints_between(s0.min(s1), s0.max(s1), breakpoints);
                if s1 < s0 {
                    breakpoints[1..].reverse();
                }
            }
            breakpoints.push(s1);
            let at_t = |s: f64| if s1 == s0 { t0 } else { t0 + len * ((s - s0) / (s1 - s0)).clamp(0.0, 1.0) };
            for k in 0..breakpoints.len() - 1 {
                let (sa, sb) = (breakpoints[k], breakpoints[k + 1]);
                let ta = if k == 0 { t0 } else { at_t(sa) };
                let tb = if k + 2 == breakpoints.len() { t0 + len } else { at_t(sb) };
                let d = tb - ta;
                if d <= 0.0 {
                    continue;
                }
                let piece = Piece {
                    t0: ta,
                    d,
                    c0: tf.color(sa),
                    c1: tf.color(sb),
                    rho0: tf.extinction(sa),
                    rho1: tf.extinction(sb),
                };
                let depth = 0.5 * (piece.rho0 + piece.rho1) * d;
                let alpha = -(-depth).exp_m1();
                let silent = piece.rho0 == 0.0
                    && piece.rho1 == 0.0
                    && (tf.emission() == Emission::Density || (piece.c0 == [0.0; 3] && piece.c1 == [0.0; 3]));
                let c = if silent {
                    [0.0; 3]
                } else {
                    ray.integrate_piece(&piece, lit.tolerance, shadow, &mut shadow_stats)
                };
                let tr = 1.0 - acc[3];
                for (a, ck) in acc.iter_mut().zip(c) {
                    *a += tr * ck;
                }
                acc[3] += tr * alpha;
                if options.early_termination && acc[3] >= options.alpha_cutoff {
                    return true;
                }
            }
            false
        });
        res.rgba = acc;
        res
    }
}
