//! Per-tet setup: silhouette edges, face planes and the fields along a
//! pixel's ray (`TetSetup`, `Fragment`), and their f32 span form
//! (`SpanEval`) the rasterizer evaluates.

use super::*;

/// One silhouette edge as a coverage test. The edge function is evaluated
/// from the endpoint with the smaller key, so both silhouettes sharing an
/// edge compute bit-identical values and the sign flip is exact.
#[derive(Debug, Clone, Copy, Default)]
pub(crate) struct Edge {
    pub(crate) ax: f64,
    pub(crate) ay: f64,
    pub(crate) dx: f64,
    pub(crate) dy: f64,
    pub(crate) sign: f64,
    /// `sign·dy`: the edge function changes by −slope per unit x.
    pub(crate) slope: f64,
    pub(crate) tie: bool,
    /// dx/dy (0 when horizontal): where the edge's line crosses a row, for
    /// the starting guess of [`TetSetup::row_span`] only.
    pub(crate) x_per_y: f64,
}

impl Edge {
    pub(crate) fn new(u: [f64; 2], ku: u64, v: [f64; 2], kv: u64) -> Edge {
        let (a, b, sign) = if ku <= kv { (u, v, 1.0) } else { (v, u, -1.0) };
        let (dx, dy) = (b[0] - a[0], b[1] - a[1]);
        // A centre exactly on the edge belongs to the side for which the
        // directed edge points down (or right when horizontal): exactly one of
        // the two directions does.
        let (ddx, ddy) = (sign * dx, sign * dy);
        let x_per_y = if dy != 0.0 { dx / dy } else { 0.0 };
        Edge { ax: a[0], ay: a[1], dx, dy, sign, slope: ddy, tie: ddy > 0.0 || (ddy == 0.0 && ddx > 0.0), x_per_y }
    }

    #[inline(always)]
    pub(crate) fn inside(&self, x: f64, y: f64) -> bool {
        let e = self.sign * (self.dx * (y - self.ay) - self.dy * (x - self.ax));
        e > 0.0 || (e == 0.0 && self.tie)
    }
}

/// A quantity linear in world space inside one tet, along the ray through
/// pixel p at depth z: `a(p) + z·b(p)` with a, b affine in the pixel
/// coordinates (`[c0, c_x, c_y]`).
#[derive(Debug, Clone, Copy, Default)]
pub(crate) struct Field {
    pub(crate) a: [f64; 3],
    pub(crate) b: [f64; 3],
}

impl Field {
    #[inline(always)]
    pub(crate) fn at(&self, x: f64, y: f64, z: f64) -> f64 {
        (self.a[0] + self.a[1] * x + self.a[2] * y) + z * (self.b[0] + self.b[1] * x + self.b[2] * y)
    }

    /// The field with gradient `g` (camera frame) and value `f0` at camera point `x0`.
    pub(crate) fn new(frame: &Frame, g: DVec3, f0: f64, x0: DVec3) -> Field {
        let c = f0 - g.dot(x0);
        if frame.parallel {
            // X = (x_c, y_c, z).
            Field { a: [c + g.x * frame.bx + g.y * frame.by, g.x * frame.ax, g.y * frame.ay], b: [g.z, 0.0, 0.0] }
        } else {
            // X = z·(x_c, y_c, 1).
            Field { a: [c, 0.0, 0.0], b: [g.x * frame.bx + g.y * frame.by + g.z, g.x * frame.ax, g.y * frame.ay] }
        }
    }
}

/// The ray segment through one tet at one pixel.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Fragment {
    pub s_front: f64,
    pub s_back: f64,
    pub g_front: f64,
    pub g_back: f64,
    pub len_world: f64,
    pub z_front: f64,
    pub z_back: f64,
}

/// Per-tet data for rasterizing one tet: silhouette, planes and fields.
#[derive(Debug, Clone, Default)]
pub(crate) struct TetSetup {
    pub n_hull: usize,
    pub(crate) edges: [Edge; 6],
    /// Inclusive pixel ranges `[x0, y0, x1, y1]`, clipped to the image.
    pub bbox: [i32; 4],
    pub(crate) planes_front: [[f64; 3]; 4],
    pub(crate) n_front: usize,
    pub(crate) planes_back: [[f64; 3]; 4],
    pub(crate) n_back: usize,
    /// Perspective: 1/near when the tet crosses the near plane (an extra entry plane).
    pub(crate) near_w: Option<f64>,
    pub(crate) parallel: bool,
    pub(crate) s: Field,
    pub(crate) g: Option<Field>,
    pub(crate) normal: Option<[Field; 3]>,
    /// Lighting: the position's x, y, z relative to `centre`, when asked
    /// for.
    pub(crate) position: Option<[Field; 3]>,
    pub(crate) centre: DVec3,
    /// The shadow field (its maps looked up by position).
    pub(crate) shadow_maps: Option<std::sync::Arc<crate::ShadowField>>,
    pub(crate) s_range: [f64; 2],
    pub(crate) g_range: [f64; 2],
    pub(crate) len_max: f64,
    pub thick: Option<[f64; 2]>,
    /// Per silhouette edge, the ramp `[c0, cx, cy]` that is 1 at the thick
    /// point and 0 on the edge (edges the thick point lies on are skipped).
    pub(crate) tent_ramps: [[f64; 3]; 6],
    pub(crate) n_ramps: usize,
    /// The tent ramps in f32, re-based at the span's reference pixel.
    pub(crate) span_ramps: [Affine32; 6],
    pub clipped: bool,
    /// The f32 form of the planes and fields the span loop evaluates.
    pub span: SpanEval,
}

/// Number of pixels [`TetSetup::eval_lanes`] evaluates at once (plain arrays
/// that LLVM vectorizes).
pub(crate) const LANES: usize = 8;

/// `c + dx·i + dy·j` for pixel offsets (i, j) from a tet's reference pixel.
#[derive(Debug, Clone, Copy, Default)]
pub(crate) struct Affine32 {
    pub(crate) c: f32,
    pub(crate) dx: f32,
    pub(crate) dy: f32,
}

impl Affine32 {
    /// From `[c0, cx, cy]` in absolute pixel-centre coordinates, re-based at
    /// the pixel centre (xr, yr) in f64 before rounding to f32.
    pub(crate) fn rebased(q: [f64; 3], xr: f64, yr: f64) -> Affine32 {
        Affine32 { c: (q[0] + q[1] * xr + q[2] * yr) as f32, dx: q[1] as f32, dy: q[2] as f32 }
    }
    #[inline(always)]
    pub(crate) fn row(&self, j: f32) -> f32 {
        self.c + self.dy * j
    }
}

/// One face plane for the span loop: where the ray through pixel offset
/// (i, j) meets it, as depth ζ relative to the tet's reference depth z0,
/// is `num / den`; the ray crosses it in front of the eye only where `den`
/// has the sign of the face's role (front: den < 0, entering; back: den > 0).
#[derive(Debug, Clone, Copy, Default)]
pub(crate) struct Plane32 {
    pub(crate) num: Affine32,
    pub(crate) den: Affine32,
}

/// The per-pixel part of a tet setup in f32, relative to the tet's
/// reference pixel (its bounding box corner) and reference depth z0 (its
/// centroid's, or the near plane's when that is farther), so the values
/// the loop combines are of the size of the tet, not of the scene: the
/// point at pixel p and depth z0 + ζ has scalar `s0(p) + ζ·sb(p)`, the
/// segment is `[max(fronts, near), min(backs)]` in ζ, and its world length
/// is `Δζ·|d(p)|` with `|d| = sqrt(1 + cx² + cy²)` (perspective) or 1.
#[derive(Debug, Clone, Copy, Default)]
pub(crate) struct SpanEval {
    /// Reference pixel (offsets are taken from its centre).
    pub ref_px: [i32; 2],
    /// Reference depth, camera units (f64: lighting evaluates fields at z0 + ζ).
    pub z0: f64,
    /// Fronts first, then backs.
    pub(crate) planes: [Plane32; 4],
    pub(crate) n_front: usize,
    pub(crate) n_planes: usize,
    /// Entry bound from the near plane (−∞ when not clipped).
    pub(crate) zeta_near: f32,
    pub(crate) s0: Affine32,
    pub(crate) sb: Affine32,
    /// Gradient-magnitude fields (bivariate methods) present.
    pub(crate) has_g: bool,
    pub(crate) g0: Affine32,
    pub(crate) gb: Affine32,
    pub(crate) s_range: [f32; 2],
    pub(crate) g_range: [f32; 2],
    pub(crate) len_max: f32,
    /// Perspective: tangent-space x/y of the reference pixel centre and per pixel.
    pub(crate) perspective: bool,
    pub(crate) cx: Affine32,
    pub(crate) cy: Affine32,
}

impl SpanEval {
    /// The reference pixel (the bbox corner) and the tangent-space map of
    /// pixel centres; no planes, fields or ramps yet.
    pub(crate) fn new(frame: &Frame, bbox: [i32; 4]) -> SpanEval {
        let ref_px = [bbox[0], bbox[1]];
        let (xr, yr) = (ref_px[0] as f64 + 0.5, ref_px[1] as f64 + 0.5);
        let (cx, cy) = (frame.ax * xr + frame.bx, frame.ay * yr + frame.by);
        SpanEval {
            ref_px,
            perspective: !frame.parallel,
            cx: Affine32 { c: cx as f32, dx: frame.ax as f32, dy: 0.0 },
            cy: Affine32 { c: cy as f32, dx: 0.0, dy: frame.ay as f32 },
            ..Default::default()
        }
    }

    /// Tangent-space (perspective) or world (parallel) x/y of the reference pixel centre.
    pub(crate) fn ref_cam_xy(&self, frame: &Frame) -> (f64, f64) {
        let (xr, yr) = (self.ref_px[0] as f64 + 0.5, self.ref_px[1] as f64 + 0.5);
        (frame.ax * xr + frame.bx, frame.ay * yr + frame.by)
    }

    /// The `pt-linear` tent ramps (absolute pixel coordinates), re-based at
    /// the reference pixel into `out`.
    pub(crate) fn rebase_ramps(&self, ramps: &[[f64; 3]], out: &mut [Affine32; 6]) {
        let (xr, yr) = (self.ref_px[0] as f64 + 0.5, self.ref_px[1] as f64 + 0.5);
        for (k, r) in ramps.iter().enumerate() {
            out[k] = Affine32::rebased(*r, xr, yr);
        }
    }

    /// The segments of [`TetSetup::eval_lanes`]: pixels `(px0 + l, py)`.
    #[inline]
    pub(crate) fn eval_row(&self, px0: u32, py: u32, out: &mut Lanes) {
        let i0 = (px0 as i32 - self.ref_px[0]) as f32;
        let j = (py as i32 - self.ref_px[1]) as f32;
        self.eval_pixels(&std::array::from_fn(|l| i0 + l as f32), &[j; LANES], out);
    }

    /// The segments of `LANES` arbitrary pixels of the tet, given as offsets
    /// (`i`, `j`) from its reference pixel: the values
    /// [`SpanEval::eval_row`] gives those pixels (each lane computed by the
    /// same operations), for a tet's covered pixels gathered across its
    /// rows so that every lane is used.
    #[inline]
    pub(crate) fn eval_pixels(&self, i: &[f32; LANES], j: &[f32; LANES], out: &mut Lanes) {
        let sp = self;
        let mut zf = [sp.zeta_near; LANES];
        let mut zb = [f32::INFINITY; LANES];
        for (k, p) in sp.planes[..sp.n_planes].iter().enumerate() {
            if k < sp.n_front {
                for l in 0..LANES {
                    let den = p.den.row(j[l]) + p.den.dx * i[l];
                    let z = (p.num.row(j[l]) + p.num.dx * i[l]) / den;
                    // `&` on the comparisons, not `&&`: no branch, so the lanes vectorize.
                    zf[l] = if (den < 0.0) & (z > zf[l]) { z } else { zf[l] };
                }
            } else {
                for l in 0..LANES {
                    let den = p.den.row(j[l]) + p.den.dx * i[l];
                    let z = (p.num.row(j[l]) + p.num.dx * i[l]) / den;
                    zb[l] = if (den > 0.0) & (z < zb[l]) { z } else { zb[l] };
                }
            }
        }
        let mut dlen = [1.0f32; LANES];
        if sp.perspective {
            for l in 0..LANES {
                let (cx, cy) = (sp.cx.c + sp.cx.dx * i[l], sp.cy.row(j[l]));
                dlen[l] = (1.0 + cx * cx + cy * cy).sqrt();
            }
        }
        let clamp = |v: f32, r: [f32; 2]| {
            let v = if v < r[1] { v } else { r[1] };
            if v > r[0] {
                v
            } else {
                r[0]
            }
        };
        for l in 0..LANES {
            let len = (zb[l] - zf[l]) * dlen[l];
            let ok = (len > 0.0) & (len < f32::INFINITY);
            out.len_world[l] = if ok { len.min(sp.len_max) } else { 0.0 };
            let (s0, sb) = (sp.s0.row(j[l]) + sp.s0.dx * i[l], sp.sb.row(j[l]) + sp.sb.dx * i[l]);
            out.s_front[l] = clamp(s0 + zf[l] * sb, sp.s_range);
            out.s_back[l] = clamp(s0 + zb[l] * sb, sp.s_range);
            out.zeta_mid[l] = if ok { 0.5 * (zf[l] + zb[l]) } else { 0.0 };
            out.zeta_half[l] = if ok { 0.5 * (zb[l] - zf[l]) } else { 0.0 };
        }
        if sp.has_g {
            for l in 0..LANES {
                let (g0, gb) = (sp.g0.row(j[l]) + sp.g0.dx * i[l], sp.gb.row(j[l]) + sp.gb.dx * i[l]);
                out.g_front[l] = clamp(g0 + zf[l] * gb, sp.g_range);
                out.g_back[l] = clamp(g0 + zb[l] * gb, sp.g_range);
            }
        } else {
            out.g_front.fill(0.0);
            out.g_back.fill(0.0);
        }
    }

    /// Planes and fields from the tet's camera-space vertices `x`, vertex
    /// scalars and gradient magnitudes, face mask, near depth when clipped,
    /// and the (scalar range, gradient-magnitude range, longest edge) clamps.
    /// Planes are kept and dropped by the same rules as the f64 ones; `false`
    /// when no face is an exit.
    #[allow(clippy::too_many_arguments)]
    pub(crate) fn set_segments(
        &mut self,
        frame: &Frame,
        x: &[DVec3; 4],
        s_vals: &[f64; 4],
        g_vals: Option<&[f64; 4]>,
        mask: u8,
        near_depth: Option<f64>,
        (s_range, g_range, len_max): ([f64; 2], [f64; 2], f64),
    ) -> bool {
        let (cx, cy) = self.ref_cam_xy(frame);
        let centroid = (x[0] + x[1] + x[2] + x[3]) * 0.25;
        let z0 = match near_depth {
            Some(near) => centroid.z.max(near),
            None => centroid.z,
        };
        let (e1, e2, e3) = (x[1] - x[0], x[2] - x[0], x[3] - x[0]);
        let (c23, c31, c12) = (e2.cross(e3), e3.cross(e1), e1.cross(e2));
        let det = e1.dot(c23);
        let grad_of = |f: &[f64; 4]| (c23 * (f[1] - f[0]) + c31 * (f[2] - f[0]) + c12 * (f[3] - f[0])) / det;
        // A field f = f_c + g·(X − centroid) at X = (z0 + ζ)·d (perspective) or
        // (cx, cy, z0 + ζ) (parallel): f0(p) + ζ·fb(p).
        let field = |f: &[f64; 4]| -> (Affine32, Affine32) {
            let g = grad_of(f);
            let f_c = 0.25 * (f[0] + f[1] + f[2] + f[3]);
            if frame.parallel {
                let p_ref = DVec3::new(cx, cy, z0);
                let f0 = Affine32 {
                    c: (f_c + g.dot(p_ref - centroid)) as f32,
                    dx: (g.x * frame.ax) as f32,
                    dy: (g.y * frame.ay) as f32,
                };
                (f0, Affine32 { c: g.z as f32, dx: 0.0, dy: 0.0 })
            } else {
                let d_ref = DVec3::new(cx, cy, 1.0);
                let f0 = Affine32 {
                    c: (f_c + g.dot(d_ref * z0 - centroid)) as f32,
                    dx: (g.x * frame.ax * z0) as f32,
                    dy: (g.y * frame.ay * z0) as f32,
                };
                (f0, Affine32 { c: g.dot(d_ref) as f32, dx: (g.x * frame.ax) as f32, dy: (g.y * frame.ay) as f32 })
            }
        };
        self.z0 = z0;
        (self.s0, self.sb) = field(s_vals);
        self.has_g = g_vals.is_some();
        (self.g0, self.gb) = g_vals.map(field).unwrap_or_default();
        self.zeta_near = near_depth.map_or(f32::NEG_INFINITY, |near| (near - z0) as f32);
        self.s_range = s_range.map(|v| v as f32);
        self.g_range = g_range.map(|v| v as f32);
        self.len_max = len_max as f32;

        let mut backs = [Plane32::default(); 4];
        let mut n_back = 0;
        self.n_front = 0;
        for (f, fv) in FACE_OUTWARD.iter().enumerate() {
            let front = mask & (1 << f) != 0;
            let back = mask & (1 << (4 + f)) != 0;
            if !front && !back {
                continue;
            }
            let (a, b, c) = (x[fv[0]], x[fv[1]], x[fv[2]]);
            let nrm = (c - a).cross(b - a);
            let len = nrm.length();
            if !(len > 0.0 && len.is_finite()) {
                continue;
            }
            let nrm = nrm / len;
            let (num, den) = if frame.parallel {
                let agrees = if front { nrm.z < 0.0 } else { nrm.z > 0.0 };
                if !agrees {
                    continue;
                }
                // ζ = (n·a − n_x·cx − n_y·cy − n_z·z0) / n_z.
                let num = Affine32 {
                    c: nrm.dot(a - DVec3::new(cx, cy, z0)) as f32,
                    dx: (-nrm.x * frame.ax) as f32,
                    dy: (-nrm.y * frame.ay) as f32,
                };
                (num, Affine32 { c: nrm.z as f32, dx: 0.0, dy: 0.0 })
            } else {
                let agrees = if front { nrm.dot(a) < 0.0 } else { nrm.dot(a) > 0.0 };
                if !agrees {
                    continue;
                }
                // ζ = (n·a − z0·n·d) / (n·d).
                let (den_dx, den_dy) = (nrm.x * frame.ax, nrm.y * frame.ay);
                let num = Affine32 {
                    c: nrm.dot(a - DVec3::new(cx, cy, 1.0) * z0) as f32,
                    dx: (-z0 * den_dx) as f32,
                    dy: (-z0 * den_dy) as f32,
                };
                (num, Affine32 { c: nrm.dot(DVec3::new(cx, cy, 1.0)) as f32, dx: den_dx as f32, dy: den_dy as f32 })
            };
            let plane = Plane32 { num, den };
            if front {
                self.planes[self.n_front] = plane;
                self.n_front += 1;
            } else {
                backs[n_back] = plane;
                n_back += 1;
            }
        }
        self.planes[self.n_front..self.n_front + n_back].copy_from_slice(&backs[..n_back]);
        self.n_planes = self.n_front + n_back;
        n_back > 0
    }
}
