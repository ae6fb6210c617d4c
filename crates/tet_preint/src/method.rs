//! Method ids shared by tetlut, tetview and every benchmark (README
//! "Methods"), and the [`SegmentShader`] contract every method implements.
//!
//! A shader turns one ray segment through a linear tet into premultiplied
//! (C, α). The renderer calls it per fragment (or per thick vertex for
//! `pt-linear`), so implementations must be cheap, `Sync`, and must never
//! return NaN: degenerate input (l = 0, Sf = Sb, values outside the baked
//! domain) is clamped or handled, not propagated.

use crate::exact::integrate_segment_with;
use crate::tf::TransferFunction;
use std::fmt;
use std::str::FromStr;

/// One method id.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum Method {
    Exact,
    PtLinear,
    Table3d,
    Atlas2d,
    Poly1,
    Poly2,
    Poly4,
    Partial,
    BivExact,
    BivApprox,
}

impl Method {
    /// Every method, in `Method::ALL`'s order.
    pub const ALL: [Method; 10] = [
        Method::Exact,
        Method::PtLinear,
        Method::Table3d,
        Method::Atlas2d,
        Method::Poly1,
        Method::Poly2,
        Method::Poly4,
        Method::Partial,
        Method::BivExact,
        Method::BivApprox,
    ];

    /// The id as written on command lines and in files (`table3d`, `biv-exact`, …).
    pub fn id(self) -> &'static str {
        match self {
            Method::Exact => "exact",
            Method::PtLinear => "pt-linear",
            Method::Table3d => "table3d",
            Method::Atlas2d => "atlas2d",
            Method::Poly1 => "poly1",
            Method::Poly2 => "poly2",
            Method::Poly4 => "poly4",
            Method::Partial => "partial",
            Method::BivExact => "biv-exact",
            Method::BivApprox => "biv-approx",
        }
    }

    /// Whether the method needs per-vertex gradient magnitudes (bivariate TFs).
    pub fn is_bivariate(self) -> bool {
        matches!(self, Method::BivExact | Method::BivApprox)
    }

    /// Whether the method bakes a table: every method but the integrators
    /// `exact`, `pt-linear` and `biv-exact`, which evaluate the TF for each
    /// segment (their `.tetl` holds the TF and no table section).
    pub fn is_tabulated(self) -> bool {
        !matches!(self, Method::Exact | Method::PtLinear | Method::BivExact)
    }

    /// Whether projected tetrahedra shade one segment per tet, the thickest
    /// (`pt-linear`: Shirley & Tuchman, "A polygonal approximation to direct
    /// scalar volume rendering", 1990, colour interpolated across the
    /// projection) rather than one per fragment.
    pub fn shades_per_tet(self) -> bool {
        self == Method::PtLinear
    }
}

impl fmt::Display for Method {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(self.id())
    }
}

/// A method id that is not one of [`Method::ALL`].
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
#[error("unknown method '{given}'; known: exact, pt-linear, table3d, atlas2d, poly1, poly2, poly4, partial, biv-exact, biv-approx")]
pub struct UnknownMethod {
    pub given: String,
}

impl FromStr for Method {
    type Err = UnknownMethod;
    fn from_str(s: &str) -> Result<Self, Self::Err> {
        Method::ALL.into_iter().find(|m| m.id() == s).ok_or_else(|| UnknownMethod { given: s.to_string() })
    }
}

/// One ray segment through a linear tet: scalar at entry and exit, gradient
/// magnitude at entry and exit (0 when the method is not bivariate), and the
/// segment length in world units.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct Segment {
    pub s_front: f32,
    pub s_back: f32,
    pub grad_front: f32,
    pub grad_back: f32,
    pub len_world: f32,
}

/// Premultiplied colour and opacity of one segment: `[R, G, B, A]`, each in
/// [0, 1] for A and [0, A·max κ] for RGB.
pub type Rgba32 = [f32; 4];

/// Capacity of a [`SegmentBatch`].
pub const BATCH: usize = 64;

/// Up to [`BATCH`] segments in structure-of-arrays form: what a rasterizer
/// collects (the fragments of one or more tets, in compositing order)
/// before one shader call, so a table's index arithmetic vectorizes over
/// them and its memory reads for many fragments overlap. Lanes at and above
/// `len` hold stale but finite values: a shader may compute them and must
/// not write their results.
#[derive(Debug, Clone, PartialEq)]
pub struct SegmentBatch {
    pub s_front: [f32; BATCH],
    pub s_back: [f32; BATCH],
    pub grad_front: [f32; BATCH],
    pub grad_back: [f32; BATCH],
    pub len_world: [f32; BATCH],
    pub len: usize,
}

impl Default for SegmentBatch {
    fn default() -> Self {
        SegmentBatch {
            s_front: [0.0; BATCH],
            s_back: [0.0; BATCH],
            grad_front: [0.0; BATCH],
            grad_back: [0.0; BATCH],
            len_world: [0.0; BATCH],
            len: 0,
        }
    }
}

impl SegmentBatch {
    /// Segment `i` (below `len`).
    #[inline(always)]
    pub fn get(&self, i: usize) -> Segment {
        Segment {
            s_front: self.s_front[i],
            s_back: self.s_back[i],
            grad_front: self.grad_front[i],
            grad_back: self.grad_back[i],
            len_world: self.len_world[i],
        }
    }

    /// Appends a segment; `false` (and nothing stored) when full.
    #[inline(always)]
    pub fn push(&mut self, seg: Segment) -> bool {
        let i = self.len;
        if i >= BATCH {
            return false;
        }
        self.s_front[i] = seg.s_front;
        self.s_back[i] = seg.s_back;
        self.grad_front[i] = seg.grad_front;
        self.grad_back[i] = seg.grad_back;
        self.len_world[i] = seg.len_world;
        self.len = i + 1;
        true
    }

    /// Builds a batch from up to [`BATCH`] segments (the rest are ignored).
    pub fn from_segments(segs: &[Segment]) -> SegmentBatch {
        let mut b = SegmentBatch::default();
        for s in segs.iter().take(BATCH) {
            b.push(*s);
        }
        b
    }
}

/// What the renderer asks of every method: (C, α) for one segment.
pub trait SegmentShader: Send + Sync {
    /// The method this shader implements.
    fn method(&self) -> Method;
    /// Premultiplied (C, α) of the segment; never NaN.
    fn shade(&self, seg: &Segment) -> Rgba32;

    /// Shades a batch: `out[i] = self.shade(&segs[i])` for every `i` below
    /// `min(segs.len(), out.len())`. Renderers pass a tet's fragments in one
    /// call, so a dynamic call covers many fragments; a table may override
    /// this to hoist per-call work (storage dispatch, clamps) out of the loop,
    /// and must then return the same values as [`SegmentShader::shade`].
    fn shade_span(&self, segs: &[Segment], out: &mut [Rgba32]) {
        for (seg, o) in segs.iter().zip(out.iter_mut()) {
            *o = self.shade(seg);
        }
    }

    /// Shades a batch: `out[i] = self.shade(&segs.get(i))` for every
    /// `i < segs.len`, `out[segs.len..]` untouched. The rasterizer's call: one
    /// dynamic call per up to [`BATCH`] fragments, in a layout a table's
    /// index arithmetic vectorizes over. Overrides must return the same
    /// values as [`SegmentShader::shade`].
    fn shade_batch(&self, segs: &SegmentBatch, out: &mut [Rgba32; BATCH]) {
        for (i, o) in out.iter_mut().enumerate().take(segs.len.min(BATCH)) {
            *o = self.shade(&segs.get(i));
        }
    }
}

/// The `exact` method as a shader: f64 integration per call (slow; the
/// reference). Allocation-free for TFs with up to 64 control points.
#[derive(Debug, Clone)]
pub struct ExactShader {
    tf: TransferFunction,
}

impl ExactShader {
    pub fn new(tf: TransferFunction) -> Self {
        ExactShader { tf }
    }
    pub fn transfer_function(&self) -> &TransferFunction {
        &self.tf
    }
}

impl SegmentShader for ExactShader {
    fn method(&self) -> Method {
        Method::Exact
    }
    fn shade(&self, seg: &Segment) -> Rgba32 {
        thread_local! {
            static SCRATCH: std::cell::RefCell<Vec<f64>> = const { std::cell::RefCell::new(Vec::new()) };
        }
        let px = SCRATCH.with(|scratch| {
            integrate_segment_with(
                &self.tf,
                finite_scalar(&self.tf, seg.s_front),
                finite_scalar(&self.tf, seg.s_back),
                (seg.len_world as f64).max(0.0),
                &mut scratch.borrow_mut(),
            )
        });
        [sat_f32(px.color[0]), sat_f32(px.color[1]), sat_f32(px.color[2]), px.alpha as f32]
    }
}

/// `v` as f32, values above the largest f32 held at it: independent emission
/// gives C up to κ·l, beyond f32 for huge colours or lengths. NaN stays NaN
/// (it would be a bug, not something to hide).
#[inline]
pub(crate) fn sat_f32(v: f64) -> f32 {
    if v > f32::MAX as f64 {
        f32::MAX
    } else {
        v as f32
    }
}

/// A segment end's scalar for the integrator: finite values unchanged; NaN
/// and −∞ at the transfer function's first control point and +∞ at its
/// last (it is constant beyond them), as a table lookup lands NaN on the
/// low edge of its domain. Keeps [`SegmentShader::shade`]'s "never NaN".
fn finite_scalar(tf: &TransferFunction, s: f32) -> f64 {
    if s.is_finite() {
        return s as f64;
    }
    let first = tf.color_nodes()[0].x.min(tf.opacity_nodes()[0].x);
    let last = tf.color_nodes()[tf.color_nodes().len() - 1].x.max(tf.opacity_nodes()[tf.opacity_nodes().len() - 1].x);
    if s == f32::INFINITY {
        last
    } else {
        first
    }
}

/// `pt-linear` (Shirley–Tuchman): the thick vertex gets the mean colour of
/// κ(Sf) and κ(Sb) and α = 1 − exp(−l·(ρ(Sf)+ρ(Sb))/2); the rasterizer then
/// interpolates this RGBA linearly towards zero at the silhouette rather than
/// calling the shader per fragment.
#[derive(Debug, Clone)]
pub struct PtLinearShader {
    tf: TransferFunction,
}

impl PtLinearShader {
    pub fn new(tf: TransferFunction) -> Self {
        PtLinearShader { tf }
    }
    pub fn transfer_function(&self) -> &TransferFunction {
        &self.tf
    }
}

impl SegmentShader for PtLinearShader {
    fn method(&self) -> Method {
        Method::PtLinear
    }
    fn shade(&self, seg: &Segment) -> Rgba32 {
        let (sf, sb) = (seg.s_front as f64, seg.s_back as f64);
        let l = (seg.len_world as f64).max(0.0);
        let (cf, cb) = (self.tf.color(sf), self.tf.color(sb));
        let rho = 0.5 * (self.tf.extinction(sf) + self.tf.extinction(sb));
        let alpha = -(-(l * rho)).exp_m1();
        [
            sat_f32(0.5 * (cf[0] + cb[0]) * alpha),
            sat_f32(0.5 * (cf[1] + cb[1]) * alpha),
            sat_f32(0.5 * (cf[2] + cb[2]) * alpha),
            alpha as f32,
        ]
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn ids_round_trip() {
        for m in Method::ALL {
            assert_eq!(m.id().parse::<Method>().unwrap(), m);
        }
        let err = "table4d".parse::<Method>().unwrap_err();
        assert!(err.to_string().contains("table4d"));
    }

    #[test]
    fn exact_shader_matches_integrator_and_handles_zero_length() {
        let tf = TransferFunction::from_json(
            r#"{"color": [[0, 1, 0, 0], [1, 0, 0, 1]], "opacity": [[0, 0], [1, 4]], "unit_distance": 1}"#,
        )
        .unwrap();
        let sh = ExactShader::new(tf.clone());
        let seg = Segment { s_front: 0.2, s_back: 0.9, len_world: 0.5, ..Default::default() };
        let got = sh.shade(&seg);
        let want = crate::integrate_segment(&tf, 0.2f32 as f64, 0.9f32 as f64, 0.5);
        assert!((got[3] as f64 - want.alpha).abs() < 1e-7);
        let zero = sh.shade(&Segment { len_world: 0.0, ..seg });
        assert_eq!(zero, [0.0; 4]);
        let pt = PtLinearShader::new(tf).shade(&Segment { len_world: 0.0, ..seg });
        assert_eq!(pt, [0.0; 4]);
    }

    /// Regression: `ExactShader` returned NaN for a NaN or infinite scalar
    /// (found by the `shade_batch` property test); it now lands NaN and −∞
    /// on the first control point and +∞ on the last.
    #[test]
    fn exact_shader_is_finite_for_non_finite_scalars() {
        let tf = TransferFunction::from_json(
            r#"{"color": [[0, 1, 0, 0], [1, 0, 0, 1]], "opacity": [[0, 1], [1, 4]], "unit_distance": 1}"#,
        )
        .unwrap();
        let sh = ExactShader::new(tf.clone());
        for (sf, at) in [(f32::NAN, 0.0), (f32::NEG_INFINITY, 0.0), (f32::INFINITY, 1.0)] {
            let got = sh.shade(&Segment { s_front: sf, s_back: at, len_world: 0.5, ..Default::default() });
            assert!(got.iter().all(|v| v.is_finite()), "{sf}: {got:?}");
            let want = sh.shade(&Segment { s_front: at, s_back: at, len_world: 0.5, ..Default::default() });
            assert_eq!(got, want, "{sf}");
        }
    }
}
