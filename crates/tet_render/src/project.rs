//! Projection of tets: the per-view vertex transform, exact front/back
//! decisions for every face, Shirley–Tuchman classification of each tet's
//! projection, near-plane clipping, and the per-tet setup that turns a
//! pixel into its ray segment (Sf, Sb, l).
//!
//! How a fragment gets its segment. Shirley–Tuchman split the silhouette
//! into 3 or 4 triangles around the thick vertex; within each triangle the
//! front and back surfaces are single planes (faces of the tet), so
//! perspective-correct interpolation of Sf and Sb across a triangle is the
//! same as evaluating the scalar where the pixel's ray meets those planes.
//! We do the latter directly: every face plane gives an affine function of
//! the pixel position (1/depth for perspective, depth for parallel), the
//! entry is the farthest front plane and the exit the nearest back plane (a
//! tet is convex), and the scalar there is `A(p) + z·B(p)`. That is exact
//! for Sf, Sb and l, needs no division by a projected area (the classic
//! instability of near-coplanar projections), and a near-edge-on plane can
//! only lose the min/max, never produce a NaN. The classification gives the
//! silhouette (the pixels to visit) and the thick vertex (which `pt-linear`
//! shades once and interpolates). The rasterizer evaluates the same planes
//! in f32 (`SpanEval`), as depths relative to the tet's centroid and pixel
//! offsets from its bounding-box corner so the values stay of the tet's
//! size; the f64 form (`TetSetup::fragment`) serves the thick point and
//! is the oracle the span path is tested against.
//!
//! Coverage is decided with edge functions evaluated in one canonical
//! vertex order per edge and a tie rule that gives a pixel centre exactly on
//! a shared edge to exactly one side, so neighbouring silhouettes neither
//! miss nor double-cover it whatever order they are drawn in.

use crate::camera::Camera;
use crate::scene::Scene;
use glam::DVec3;
use rayon::prelude::*;
use robust::{orient2d, Coord};
use tet_mesh::predicates::{side_of_oriented_plane, TetOrientation};
use tet_mesh::FACE_OUTWARD;
use wide::{f64x4, CmpEq, CmpGt};

/// The camera in the scene's frame (positions relative to the mesh centre),
/// with the pixel ↔ camera-space maps the rasterizer needs.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Frame {
    pub eye_rel: DVec3,
    pub right: DVec3,
    pub up: DVec3,
    pub forward: DVec3,
    pub parallel: bool,
    /// Depth below which geometry is clipped (−∞ for parallel).
    pub near_depth: f64,
    pub width: u32,
    pub height: u32,
    /// x_cam = ax·x_px + bx and y_cam = ay·y_px + by, where camera x/y are
    /// at depth 1 (perspective: tangent space) or world units (parallel).
    pub ax: f64,
    pub bx: f64,
    pub ay: f64,
    pub by: f64,
}

impl Frame {
    /// Same basis and extents as [`Camera`] (VTK semantics), shifted so the
    /// eye is relative to `centre_in_world`.
    pub fn new(camera: &Camera, centre_in_world: DVec3) -> Frame {
        let spec = camera.spec();
        let pos = DVec3::from(spec.position);
        let forward = camera.forward();
        let right = forward.cross(DVec3::from(spec.view_up)).normalize();
        let up = right.cross(forward);
        let (w, h) = (spec.size[0] as f64, spec.size[1] as f64);
        let half_h = if spec.parallel { spec.parallel_scale } else { (0.5 * spec.view_angle.to_radians()).tan() };
        let half_w = half_h * w / h;
        Frame {
            eye_rel: pos - centre_in_world,
            right,
            up,
            forward,
            parallel: spec.parallel,
            near_depth: camera.near_depth(),
            width: spec.size[0],
            height: spec.size[1],
            ax: 2.0 * half_w / w,
            bx: -half_w,
            ay: -2.0 * half_h / h,
            by: half_h,
        }
    }

    /// Camera coordinates (right, up, depth) of a position relative to the centre.
    #[inline]
    pub fn to_cam(&self, p_rel: [f64; 3]) -> [f64; 3] {
        let d = DVec3::from(p_rel) - self.eye_rel;
        [d.dot(self.right), d.dot(self.up), d.dot(self.forward)]
    }

    /// Pixel coordinates of a camera-space point (perspective: depth must be > 0).
    #[inline]
    pub fn cam_to_px(&self, x: [f64; 3]) -> [f64; 2] {
        let (cx, cy) = if self.parallel { (x[0], x[1]) } else { (x[0] / x[2], x[1] / x[2]) };
        [(cx - self.bx) / self.ax, (cy - self.by) / self.ay]
    }

    /// World length per unit of depth along the ray through a pixel: |d(p)|
    /// for perspective (d has unit depth), 1 for parallel.
    #[inline]
    pub fn len_per_depth(&self, x_px: f64, y_px: f64) -> f64 {
        if self.parallel {
            1.0
        } else {
            let (cx, cy) = (self.ax * x_px + self.bx, self.ay * y_px + self.by);
            (1.0 + cx * cx + cy * cy).sqrt()
        }
    }

    /// Unit world direction of the ray through a pixel.
    #[inline]
    pub fn view_dir(&self, x_px: f64, y_px: f64) -> DVec3 {
        if self.parallel {
            self.forward
        } else {
            let (cx, cy) = (self.ax * x_px + self.bx, self.ay * y_px + self.by);
            (self.forward + self.right * cx + self.up * cy).normalize()
        }
    }
}

/// Face `f` of a tet seen from the eye: bit `f` set when the eye is strictly
/// outside it (front face), bit `4 + f` when strictly inside (back face);
/// neither when the eye lies in its plane.
pub const FRONT: u8 = 0x0f;
/// See [`FRONT`].
pub const BACK: u8 = 0xf0;

/// Everything about a view that does not depend on the transfer function:
/// per-vertex camera and pixel coordinates and per-tet face masks.
#[derive(Debug, Clone)]
pub struct ViewGeometry {
    pub frame: Frame,
    /// Camera coordinates (right, up, depth) per vertex.
    pub cam: Vec<[f64; 3]>,
    /// Pixel coordinates per vertex (NaN for vertices in front of the near plane's clip).
    pub px: Vec<[f64; 2]>,
    /// Per tet, [`FRONT`]/[`BACK`] bits per face.
    pub face_mask: Vec<u8>,
}

impl ViewGeometry {
    pub fn new(scene: &Scene, camera: &Camera) -> ViewGeometry {
        let frame = Frame::new(camera, scene.centre_in_world());
        let cam: Vec<[f64; 3]> = scene.positions_rel().par_iter().map(|&p| frame.to_cam(p)).collect();
        let px = cam
            .par_iter()
            .map(|&x| if frame.parallel || x[2] >= frame.near_depth { frame.cam_to_px(x) } else { [f64::NAN; 2] })
            .collect();
        let pos = scene.positions_rel();
        let eye: [f64; 3] = frame.eye_rel.into();
        let face_mask = scene
            .tets()
            .par_iter()
            .map(|t| {
                let mut m = 0u8;
                // Vertex − eye, shared by the tet's four faces: the same
                // differences Shewchuk's orient3d forms with the eye as pd.
                let d = t.map(|v| {
                    let p = &pos[v as usize];
                    [p[0] - eye[0], p[1] - eye[1], p[2] - eye[2]]
                });
                for (f, fv) in FACE_OUTWARD.iter().enumerate() {
                    let ids = [t[fv[0]], t[fv[1]], t[fv[2]]];
                    let side = if frame.parallel {
                        parallel_side(pos, ids, frame.forward)
                    } else {
                        match orient3d_filtered(&d[fv[0]], &d[fv[1]], &d[fv[2]]) {
                            Some(side) => side,
                            None => side_of_oriented_plane(
                                &pos[ids[0] as usize],
                                &pos[ids[1] as usize],
                                &pos[ids[2] as usize],
                                &eye,
                            ),
                        }
                    };
                    match side {
                        TetOrientation::Positive => m |= 1 << f,
                        TetOrientation::Negative => m |= 1 << (4 + f),
                        TetOrientation::Flat => {}
                    }
                }
                m
            })
            .collect();
        ViewGeometry { frame, cam, px, face_mask }
    }
}

/// Error bound of orient3d's floating-point filter (Shewchuk's
/// `o3derrboundA`, as the `robust` crate defines it).
const O3D_ERRBOUND_A: f64 = {
    const EPS: f64 = f64::EPSILON * 0.5;
    (7.0 + 56.0 * EPS) * EPS
};

/// The first, floating-point stage of Shewchuk's orient3d on the
/// differences `a − eye`, `b − eye`, `c − eye` (the same operations in the
/// same order as `robust::orient3d`), as what
/// [`side_of_oriented_plane`]`(a, b, c, eye)` returns; `None` when the filter
/// cannot certify the sign (then the exact predicate decides). Inlined per
/// tet with the differences shared by its faces: the face masks are
/// recomputed for every tet on every camera move.
#[inline(always)]
fn orient3d_filtered(a: &[f64; 3], b: &[f64; 3], c: &[f64; 3]) -> Option<TetOrientation> {
    let [adx, ady, adz] = *a;
    let [bdx, bdy, bdz] = *b;
    let [cdx, cdy, cdz] = *c;
    let (bdxcdy, cdxbdy) = (bdx * cdy, cdx * bdy);
    let (cdxady, adxcdy) = (cdx * ady, adx * cdy);
    let (adxbdy, bdxady) = (adx * bdy, bdx * ady);
    let det = adz * (bdxcdy - cdxbdy) + bdz * (cdxady - adxcdy) + cdz * (adxbdy - bdxady);
    let permanent = (bdxcdy.abs() + cdxbdy.abs()) * adz.abs()
        + (cdxady.abs() + adxcdy.abs()) * bdz.abs()
        + (adxbdy.abs() + bdxady.abs()) * cdz.abs();
    let errbound = O3D_ERRBOUND_A * permanent;
    // tet_mesh's convention: orient3d < 0 is Positive. NaN fails both tests.
    if det > errbound {
        Some(TetOrientation::Negative)
    } else if -det > errbound {
        Some(TetOrientation::Positive)
    } else {
        None
    }
}

/// Side of the eye at infinity (parallel projection) of the oriented face
/// `ids`: `Positive` when its normal points against the view direction.
/// Computed in one canonical vertex order (sorted ids) and flipped by the
/// permutation's parity, so the two tets sharing a face always disagree
/// exactly and MPVO never sees a spurious 2-cycle.
fn parallel_side(pos: &[[f64; 3]], ids: [u32; 3], forward: DVec3) -> TetOrientation {
    let mut s = ids;
    let mut odd = false;
    for i in 0..3 {
        for j in 0..2 - i {
            if s[j] > s[j + 1] {
                s.swap(j, j + 1);
                odd = !odd;
            }
        }
    }
    let p = |i: u32| DVec3::from(pos[i as usize]);
    let n = (p(s[1]) - p(s[0])).cross(p(s[2]) - p(s[0]));
    let d = n.dot(forward);
    if d.abs() <= 1e-14 * n.length() || !d.is_finite() {
        return TetOrientation::Flat;
    }
    // Outward normal against the view direction: the eye sees the outside.
    if (d < 0.0) != odd {
        TetOrientation::Positive
    } else {
        TetOrientation::Negative
    }
}

/// Shirley–Tuchman class of a projected tet.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum ProjClass {
    /// Vertex `thick` projects inside (or onto the boundary of) the triangle
    /// of the other three: 3 triangles around it.
    One { thick: usize },
    /// The projected edges `diag0` and `diag1` cross at the thick point,
    /// `diag0[0] + t·(diag0[1] − diag0[0])`: 4 triangles.
    Two { diag0: [usize; 2], diag1: [usize; 2], t: f64 },
    /// All four vertices project onto one line: no area, no pixels.
    Degenerate,
}

fn coord(p: [f64; 2]) -> Coord<f64> {
    Coord { x: p[0], y: p[1] }
}

/// Classifies the projection of a tet from the exact signs of its four
/// projected faces (oriented as [`FACE_OUTWARD`]): a face whose sign is
/// alone is opposite the thick vertex (class 1); two and two make class 2,
/// whose diagonals are the edge shared by the two positive faces and the
/// edge shared by the two negative ones. Zero-area faces (collinear or
/// coincident projections) fall into the same rules; the signed areas of
/// the four faces sum to zero, so the sign pattern is always consistent.
pub fn classify_projection(p: &[[f64; 2]; 4]) -> ProjClass {
    let mut pos = [0usize; 4];
    let mut neg = [0usize; 4];
    let (mut np, mut nn) = (0, 0);
    for (f, fv) in FACE_OUTWARD.iter().enumerate() {
        let a = orient2d(coord(p[fv[0]]), coord(p[fv[1]]), coord(p[fv[2]]));
        if a > 0.0 {
            pos[np] = f;
            np += 1;
        } else if a < 0.0 {
            neg[nn] = f;
            nn += 1;
        }
    }
    match (np, nn) {
        (0, _) | (_, 0) => ProjClass::Degenerate,
        (1, _) => ProjClass::One { thick: pos[0] },
        (_, 1) => ProjClass::One { thick: neg[0] },
        _ => {
            // (2, 2): the diagonals are {neg faces' vertices} and {pos faces' vertices}.
            let d0 = [neg[0], neg[1]];
            let d1 = [pos[0], pos[1]];
            let o1 = orient2d(coord(p[d1[0]]), coord(p[d1[1]]), coord(p[d0[0]]));
            let o2 = orient2d(coord(p[d1[0]]), coord(p[d1[1]]), coord(p[d0[1]]));
            let t = (o1 / (o1 - o2)).clamp(0.0, 1.0);
            ProjClass::Two { diag0: d0, diag1: d1, t }
        }
    }
}

impl ProjClass {
    /// The silhouette's vertices (local indices), in polygon order.
    pub fn silhouette(&self) -> ([usize; 4], usize) {
        match *self {
            ProjClass::One { thick } => {
                let mut o = [0; 4];
                let mut k = 0;
                for v in 0..4 {
                    if v != thick {
                        o[k] = v;
                        k += 1;
                    }
                }
                (o, 3)
            }
            ProjClass::Two { diag0, diag1, .. } => ([diag0[0], diag1[0], diag0[1], diag1[1]], 4),
            ProjClass::Degenerate => ([0; 4], 0),
        }
    }

    /// Pixel position of the thick point.
    pub fn thick_point(&self, p: &[[f64; 2]; 4]) -> Option<[f64; 2]> {
        match *self {
            ProjClass::One { thick } => Some(p[thick]),
            ProjClass::Two { diag0, t, .. } => {
                let (a, b) = (p[diag0[0]], p[diag0[1]]);
                Some([a[0] + t * (b[0] - a[0]), a[1] + t * (b[1] - a[1])])
            }
            ProjClass::Degenerate => None,
        }
    }
}

/// One silhouette edge as a coverage test. The edge function is evaluated
/// from the endpoint with the smaller key, so both silhouettes sharing an
/// edge compute bit-identical values and the sign flip is exact.
#[derive(Debug, Clone, Copy, Default)]
pub(crate) struct Edge {
    ax: f64,
    ay: f64,
    dx: f64,
    dy: f64,
    sign: f64,
    /// `sign·dy`: the edge function changes by −slope per unit x.
    slope: f64,
    tie: bool,
    /// dx/dy (0 when horizontal): where the edge's line crosses a row, for
    /// the starting guess of [`TetSetup::row_span`] only.
    x_per_y: f64,
}

impl Edge {
    fn new(u: [f64; 2], ku: u64, v: [f64; 2], kv: u64) -> Edge {
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
    fn inside(&self, x: f64, y: f64) -> bool {
        let e = self.sign * (self.dx * (y - self.ay) - self.dy * (x - self.ax));
        e > 0.0 || (e == 0.0 && self.tie)
    }
}

/// A quantity linear in world space inside one tet, along the ray through
/// pixel p at depth z: `a(p) + z·b(p)` with a, b affine in the pixel
/// coordinates (`[c0, c_x, c_y]`).
#[derive(Debug, Clone, Copy, Default)]
pub(crate) struct Field {
    a: [f64; 3],
    b: [f64; 3],
}

impl Field {
    #[inline(always)]
    fn at(&self, x: f64, y: f64, z: f64) -> f64 {
        (self.a[0] + self.a[1] * x + self.a[2] * y) + z * (self.b[0] + self.b[1] * x + self.b[2] * y)
    }

    /// The field with gradient `g` (camera frame) and value `f0` at camera point `x0`.
    fn new(frame: &Frame, g: DVec3, f0: f64, x0: DVec3) -> Field {
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
    edges: [Edge; 6],
    /// Inclusive pixel ranges `[x0, y0, x1, y1]`, clipped to the image.
    pub bbox: [i32; 4],
    planes_front: [[f64; 3]; 4],
    n_front: usize,
    planes_back: [[f64; 3]; 4],
    n_back: usize,
    /// Perspective: 1/near when the tet crosses the near plane (an extra entry plane).
    near_w: Option<f64>,
    parallel: bool,
    s: Field,
    g: Option<Field>,
    normal: Option<[Field; 3]>,
    s_range: [f64; 2],
    g_range: [f64; 2],
    len_max: f64,
    pub thick: Option<[f64; 2]>,
    /// Per silhouette edge, the ramp `[c0, cx, cy]` that is 1 at the thick
    /// point and 0 on the edge (edges the thick point lies on are skipped).
    tent_ramps: [[f64; 3]; 6],
    n_ramps: usize,
    /// The tent ramps in f32, re-based at the span's reference pixel.
    span_ramps: [Affine32; 6],
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
    c: f32,
    dx: f32,
    dy: f32,
}

impl Affine32 {
    /// From `[c0, cx, cy]` in absolute pixel-centre coordinates, re-based at
    /// the pixel centre (xr, yr) in f64 before rounding to f32.
    fn rebased(q: [f64; 3], xr: f64, yr: f64) -> Affine32 {
        Affine32 { c: (q[0] + q[1] * xr + q[2] * yr) as f32, dx: q[1] as f32, dy: q[2] as f32 }
    }
    #[inline(always)]
    fn row(&self, j: f32) -> f32 {
        self.c + self.dy * j
    }
}

/// One face plane for the span loop: where the ray through pixel offset
/// (i, j) meets it, as depth ζ relative to the tet's reference depth z0,
/// is `num / den`; the ray crosses it in front of the eye only where `den`
/// has the sign of the face's role (front: den < 0, entering; back: den > 0).
#[derive(Debug, Clone, Copy, Default)]
struct Plane32 {
    num: Affine32,
    den: Affine32,
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
    planes: [Plane32; 4],
    n_front: usize,
    n_planes: usize,
    /// Entry bound from the near plane (−∞ when not clipped).
    zeta_near: f32,
    s0: Affine32,
    sb: Affine32,
    /// Gradient-magnitude fields (bivariate methods) present.
    has_g: bool,
    g0: Affine32,
    gb: Affine32,
    s_range: [f32; 2],
    g_range: [f32; 2],
    len_max: f32,
    /// Perspective: tangent-space x/y of the reference pixel centre and per pixel.
    perspective: bool,
    cx: Affine32,
    cy: Affine32,
}

impl SpanEval {
    /// The reference pixel (the bbox corner) and the tangent-space map of
    /// pixel centres; no planes, fields or ramps yet.
    fn new(frame: &Frame, bbox: [i32; 4]) -> SpanEval {
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
    fn ref_cam_xy(&self, frame: &Frame) -> (f64, f64) {
        let (xr, yr) = (self.ref_px[0] as f64 + 0.5, self.ref_px[1] as f64 + 0.5);
        (frame.ax * xr + frame.bx, frame.ay * yr + frame.by)
    }

    /// The `pt-linear` tent ramps (absolute pixel coordinates), re-based at
    /// the reference pixel into `out`.
    fn rebase_ramps(&self, ramps: &[[f64; 3]], out: &mut [Affine32; 6]) {
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
    fn set_segments(
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

/// Per-lane results of [`TetSetup::eval_lanes`]: a lane with `len == 0`
/// has no fragment.
#[derive(Debug, Clone, Copy, Default)]
pub(crate) struct Lanes {
    pub s_front: [f32; LANES],
    pub s_back: [f32; LANES],
    pub g_front: [f32; LANES],
    pub g_back: [f32; LANES],
    pub len_world: [f32; LANES],
    /// ζ at the segment's midpoint (lighting).
    pub zeta_mid: [f32; LANES],
}

/// What the setup needs besides the tet: optional per-vertex fields.
pub(crate) struct SetupInputs<'a> {
    pub scene: &'a Scene,
    pub view: &'a ViewGeometry,
    pub want_grad_mag: bool,
    pub want_normals: bool,
    /// The f64 thick-point data `pt-linear` shades once per tet.
    pub want_thick: bool,
    /// The f32 span data per-fragment methods evaluate (always built for clipped tets).
    pub want_span: bool,
}

/// Pixel bounding box `[x0, y0, x1, y1]` (inclusive, clipped to the image) of
/// the pixel centres a tet may cover, or `None` when it covers none.
pub(crate) fn tet_bbox(view: &ViewGeometry, tet: &[u32; 4]) -> Option<[i32; 4]> {
    let mut pts = [[0.0; 2]; 6];
    let mut keys = [0u64; 6];
    let n = screen_points(view, tet, &mut pts, &mut keys);
    bbox_of(&pts[..n], view.frame.width, view.frame.height)
}

fn bbox_of(pts: &[[f64; 2]], w: u32, h: u32) -> Option<[i32; 4]> {
    if pts.is_empty() {
        return None;
    }
    let (mut lo, mut hi) = ([f64::INFINITY; 2], [f64::NEG_INFINITY; 2]);
    for p in pts {
        for k in 0..2 {
            lo[k] = lo[k].min(p[k]);
            hi[k] = hi[k].max(p[k]);
        }
    }
    if !(lo[0].is_finite() && lo[1].is_finite() && hi[0].is_finite() && hi[1].is_finite()) {
        return None;
    }
    // Centre i + ½ inside [lo, hi] ⇔ i ∈ [ceil(lo − ½), floor(hi − ½)]
    // (ceil_i64/floor_i64: no libm call per tet; exact for these finite values).
    let c = |v: i64, max: u32| v.clamp(-1, i64::from(max)) as i32;
    let x0 = c(ceil_i64(lo[0] - 0.5), w);
    let y0 = c(ceil_i64(lo[1] - 0.5), h);
    let x1 = c(floor_i64(hi[0] - 0.5), w - 1);
    let y1 = c(floor_i64(hi[1] - 0.5), h - 1);
    let (x0, y0) = (x0.max(0), y0.max(0));
    if x0 > x1 || y0 > y1 || x1 < 0 || y1 < 0 {
        return None;
    }
    Some([x0, y0, x1, y1])
}

/// The tet's projected points: its 4 vertices, or, when it crosses the near
/// plane, the vertices in front of it plus the points where its edges cross
/// it (at most 6). Keys identify points across tets (vertex id, or the
/// canonical edge) so shared silhouette edges are evaluated identically.
fn screen_points(view: &ViewGeometry, tet: &[u32; 4], pts: &mut [[f64; 2]; 6], keys: &mut [u64; 6]) -> usize {
    let f = &view.frame;
    let z = tet.map(|v| view.cam[v as usize][2]);
    if f.parallel || z.iter().all(|&z| z >= f.near_depth) {
        for k in 0..4 {
            pts[k] = view.px[tet[k] as usize];
            keys[k] = vertex_key(tet[k]);
        }
        return 4;
    }
    let mut n = 0;
    for k in 0..4 {
        if z[k] >= f.near_depth {
            pts[n] = view.px[tet[k] as usize];
            keys[n] = vertex_key(tet[k]);
            n += 1;
        }
    }
    if n == 0 {
        return 0;
    }
    for i in 0..4 {
        for j in i + 1..4 {
            if (z[i] >= f.near_depth) != (z[j] >= f.near_depth) {
                let (a, b) = if tet[i] < tet[j] { (tet[i], tet[j]) } else { (tet[j], tet[i]) };
                let (xa, xb) = (view.cam[a as usize], view.cam[b as usize]);
                let t = (f.near_depth - xa[2]) / (xb[2] - xa[2]);
                let x = [xa[0] + t * (xb[0] - xa[0]), xa[1] + t * (xb[1] - xa[1]), f.near_depth];
                pts[n] = f.cam_to_px(x);
                keys[n] = ((a as u64) << 32) | b as u64;
                n += 1;
            }
        }
    }
    n
}

/// [`TetSetup::row_span`] over the silhouette edges `edges`.
#[inline]
fn row_span_of(edges: &[Edge], py: u32, x_lo: u32, x_hi: u32) -> Option<(u32, u32)> {
    let y = py as f64 + 0.5;
    let (mut lo, mut hi) = (x_lo as i64, x_hi as i64);
    for e in edges {
        if lo > hi {
            return None;
        }
        let at = |i: i64| e.inside(i as f64 + 0.5, y);
        let slope = e.slope;
        if slope == 0.0 {
            if !at(lo) {
                return None;
            }
            continue;
        }
        // The crossing's x, off by far less than a pixel: the exact tests
        // below usually just confirm the pixel next to it (a NaN or huge
        // crossing saturates, is clamped, and costs a longer walk).
        let run = e.x_per_y * (y - e.ay);
        let x_cross = e.ax + run - 0.5;
        // Fast path: pixel i's test decides i + ½ against the edge's
        // crossing, so when x_cross is farther from an integer than the
        // rounding of x_cross and of the test itself (each a few ulps of
        // `scale`; the margin is ~300× that), ⌈x_cross⌉ / ⌊x_cross⌋ is
        // exactly the boundary the tests below would settle on.
        let scale = e.ax.abs() + run.abs() + 1.0;
        if scale < 1e12 {
            let fl = floor_below_2_51(x_cross);
            let frac = x_cross - fl;
            if frac > 1e-12 * scale && frac < 1.0 - 1e-12 * scale {
                // frac > 0: ⌈x_cross⌉ = ⌊x_cross⌋ + 1.
                let f = fl as i64;
                if slope < 0.0 {
                    lo = lo.max((f + 1).min(hi + 1));
                } else {
                    hi = hi.min(f.max(lo - 1));
                }
                continue;
            }
        }
        if slope < 0.0 {
            // Inside for x ≥ boundary: the first inside pixel ≥ lo.
            let mut i = ceil_i64(x_cross).clamp(lo, hi + 1);
            if i <= hi && at(i) {
                while i > lo && at(i - 1) {
                    i -= 1;
                }
            } else {
                while i <= hi && !at(i) {
                    i += 1;
                }
            }
            lo = i;
        } else {
            // Inside for x ≤ boundary: the last inside pixel ≤ hi.
            let mut i = floor_i64(x_cross).clamp(lo - 1, hi);
            if i >= lo && at(i) {
                while i < hi && at(i + 1) {
                    i += 1;
                }
            } else {
                while i >= lo && !at(i) {
                    i -= 1;
                }
            }
            hi = i;
        }
    }
    (lo <= hi).then_some((lo as u32, hi as u32))
}

/// ⌊v⌋ for |v| < 2⁵¹, exactly, without a libm call or an integer round
/// trip: adding 1.5·2⁵² rounds v to an integer in the mantissa.
#[inline(always)]
fn floor_below_2_51(v: f64) -> f64 {
    const M: f64 = 6_755_399_441_055_744.0;
    let r = (v + M) - M;
    if r > v {
        r - 1.0
    } else {
        r
    }
}

/// ⌈v⌉ for |v| ≤ 1e15 (beyond: ±1e15; NaN → 0), without a libm call on
/// baseline x86-64.
#[inline(always)]
fn ceil_i64(v: f64) -> i64 {
    let v = v.clamp(-1e15, 1e15);
    let t = v as i64;
    if (t as f64) < v {
        t + 1
    } else {
        t
    }
}

/// ⌊v⌋, as [`ceil_i64`].
#[inline(always)]
fn floor_i64(v: f64) -> i64 {
    let v = v.clamp(-1e15, 1e15);
    let t = v as i64;
    if (t as f64) > v {
        t - 1
    } else {
        t
    }
}

#[inline]
fn vertex_key(v: u32) -> u64 {
    ((v as u64) << 32) | v as u64
}

/// Convex hull (positively oriented, exact orientation tests) of up to 6 points.
fn hull_of(pts: &[[f64; 2]], keys: &[u64], out: &mut [[f64; 2]; 6], out_keys: &mut [u64; 6]) -> usize {
    let mut idx: Vec<usize> = (0..pts.len()).collect();
    idx.sort_by(|&a, &b| pts[a][0].total_cmp(&pts[b][0]).then(pts[a][1].total_cmp(&pts[b][1])));
    let mut h: Vec<usize> = Vec::with_capacity(12);
    for pass in 0..2 {
        let start = h.len();
        let iter: Box<dyn Iterator<Item = &usize>> =
            if pass == 0 { Box::new(idx.iter()) } else { Box::new(idx.iter().rev()) };
        for &i in iter {
            while h.len() >= start + 2
                && orient2d(coord(pts[h[h.len() - 2]]), coord(pts[h[h.len() - 1]]), coord(pts[i])) <= 0.0
            {
                h.pop();
            }
            h.push(i);
        }
        h.pop();
    }
    let n = h.len().min(6);
    for (k, &i) in h.iter().take(n).enumerate() {
        out[k] = pts[i];
        out_keys[k] = keys[i];
    }
    n
}

impl TetSetup {
    /// Sets up tet `t`, or `None` when it can cover no pixel (fully behind
    /// the near plane, zero projected area, zero volume, off screen).
    #[cfg(test)]
    pub fn new(inp: &SetupInputs, t: usize) -> Option<TetSetup> {
        let mut s = TetSetup::default();
        s.build(inp, t).then_some(s)
    }

    /// Sets up tet `t` in place (a setup is large: the rasterizer reuses one
    /// per tile rather than moving a new one around for every tet); `false`
    /// when the tet can cover no pixel (fully behind the near plane, zero
    /// projected area, zero volume, off screen, or no exit face). Builds the
    /// f64 thick-point data (planes, fields; thick point and tent unless
    /// clipped) when `want_thick`, and the f32 span data when `want_span` or
    /// clipped.
    pub fn build(&mut self, inp: &SetupInputs, t: usize) -> bool {
        let scene = inp.scene;
        let view = inp.view;
        let frame = &view.frame;
        let tet = &scene.tets()[t];
        let mut pts = [[0.0; 2]; 6];
        let mut keys = [0u64; 6];
        let n = screen_points(view, tet, &mut pts, &mut keys);
        if n < 3 {
            return false;
        }
        let mut hull = [[0.0; 2]; 6];
        let mut hull_keys = [0u64; 6];
        let clipped = n != 4 || (!frame.parallel && tet.iter().any(|&v| view.cam[v as usize][2] < frame.near_depth));
        let (n_hull, thick) = if clipped {
            (hull_of(&pts[..n], &keys[..n], &mut hull, &mut hull_keys), None)
        } else {
            let p4 = [pts[0], pts[1], pts[2], pts[3]];
            let (class, ns) = silhouette_hull(&p4, &[keys[0], keys[1], keys[2], keys[3]], &mut hull, &mut hull_keys);
            (ns, class.thick_point(&p4))
        };
        if n_hull < 3 {
            return false;
        }
        let Some(bbox) = bbox_of(&hull[..n_hull], frame.width, frame.height) else { return false };

        // Linear fields from the camera-space vertices.
        let x = tet.map(|v| DVec3::from(view.cam[v as usize]));
        let (e1, e2, e3) = (x[1] - x[0], x[2] - x[0], x[3] - x[0]);
        let (c23, c31, c12) = (e2.cross(e3), e3.cross(e1), e1.cross(e2));
        let det = e1.dot(c23);
        if det == 0.0 || !det.is_finite() {
            return false;
        }
        // f64 planes and fields whenever asked (the thick point, and tests'
        // per-pixel oracle); the thick point itself only for unclipped tets.
        let thick_path = inp.want_thick;
        let span_path = inp.want_span || clipped;
        let grad_of = |f: &[f64; 4]| (c23 * (f[1] - f[0]) + c31 * (f[2] - f[0]) + c12 * (f[3] - f[0])) / det;
        let field_of = |f: &[f64; 4]| Field::new(frame, grad_of(f), f[0], x[0]);
        let sv = tet.map(|v| scene.scalar()[v as usize]);
        let range = |f: &[f64; 4]| {
            [f.iter().copied().fold(f64::INFINITY, f64::min), f.iter().copied().fold(f64::NEG_INFINITY, f64::max)]
        };
        let g_vals = match (inp.want_grad_mag, scene.gradient_magnitudes()) {
            (true, Some(gm)) => Some(tet.map(|v| gm[v as usize])),
            _ => None,
        };
        self.s = if thick_path { field_of(&sv) } else { Field::default() };
        self.s_range = range(&sv);
        self.g = g_vals.as_ref().filter(|_| thick_path).map(field_of);
        self.g_range = g_vals.as_ref().map_or([0.0, 0.0], range);
        self.normal = match (inp.want_normals, scene.gradients()) {
            (true, Some(gr)) => {
                let comp = |c: usize| field_of(&tet.map(|v| gr[v as usize][c]));
                Some([comp(0), comp(1), comp(2)])
            }
            _ => None,
        };
        let mut len_max: f64 = 0.0;
        for i in 0..4 {
            for j in i + 1..4 {
                len_max = len_max.max((x[i] - x[j]).length_squared());
            }
        }
        self.len_max = len_max.sqrt();
        self.n_hull = n_hull;
        for k in 0..n_hull {
            let j = (k + 1) % n_hull;
            self.edges[k] = Edge::new(hull[k], hull_keys[k], hull[j], hull_keys[j]);
        }
        self.bbox = bbox;
        self.near_w = if clipped && !frame.parallel { Some(1.0 / frame.near_depth) } else { None };
        self.parallel = frame.parallel;
        self.clipped = clipped;
        self.thick = if thick_path { thick } else { None }; // None when clipped
        self.n_ramps = 0;
        self.n_front = 0;
        self.n_back = 0;
        self.span = SpanEval::new(frame, bbox);

        if thick_path {
            if let Some(t) = thick {
                for k in 0..n_hull {
                    let (u, v) = (hull[k], hull[(k + 1) % n_hull]);
                    let (dx, dy) = (v[0] - u[0], v[1] - u[1]);
                    let et = dx * (t[1] - u[1]) - dy * (t[0] - u[0]);
                    if et > 0.0 {
                        // (dx·(y − u_y) − dy·(x − u_x)) / et as an affine function.
                        self.tent_ramps[self.n_ramps] = [(dy * u[0] - dx * u[1]) / et, -dy / et, dx / et];
                        self.n_ramps += 1;
                    }
                }
            }
            self.span.rebase_ramps(&self.tent_ramps[..self.n_ramps], &mut self.span_ramps);
            if !self.set_f64_planes(frame, &x, view.face_mask[t]) {
                return false;
            }
        }
        if span_path {
            let near = if clipped && !frame.parallel { Some(frame.near_depth) } else { None };
            let ranges = (self.s_range, self.g_range, self.len_max);
            if !self.span.set_segments(frame, &x, &sv, g_vals.as_ref(), view.face_mask[t], near, ranges) {
                return false;
            }
        }
        true
    }

    /// The f64 face planes of [`TetSetup::fragment`]; `false` when none is an exit.
    fn set_f64_planes(&mut self, frame: &Frame, x: &[DVec3; 4], mask: u8) -> bool {
        for (f, fv) in FACE_OUTWARD.iter().enumerate() {
            let front = mask & (1 << f) != 0;
            let back = mask & (1 << (4 + f)) != 0;
            if !front && !back {
                continue;
            }
            let (a, b, c) = (x[fv[0]], x[fv[1]], x[fv[2]]);
            // The camera basis (right, up, forward) is left-handed, so the
            // outward normal's components are (c − a) × (b − a) there.
            let nrm = (c - a).cross(b - a);
            let k = nrm.dot(a);
            let q = if frame.parallel {
                // Depth where the ray (x_c, y_c, ·) meets n·X = k.
                let nz = nrm.z;
                let agrees = if front { nz < 0.0 } else { nz > 0.0 };
                if !agrees {
                    continue; // rounding disagrees with the exact side: edge-on, skip
                }
                [(k - nrm.x * frame.bx - nrm.y * frame.by) / nz, -nrm.x * frame.ax / nz, -nrm.y * frame.ay / nz]
            } else {
                // 1/depth where the ray z·(x_c, y_c, 1) meets n·X = k; the eye
                // (origin) is outside a front face: k < 0.
                let agrees = if front { k < 0.0 } else { k > 0.0 };
                if !agrees {
                    continue;
                }
                [(nrm.x * frame.bx + nrm.y * frame.by + nrm.z) / k, nrm.x * frame.ax / k, nrm.y * frame.ay / k]
            };
            if !q.iter().all(|v| v.is_finite()) {
                continue;
            }
            if front {
                self.planes_front[self.n_front] = q;
                self.n_front += 1;
            } else {
                self.planes_back[self.n_back] = q;
                self.n_back += 1;
            }
        }
        self.n_back > 0
    }

    /// The pixels of row `py` within `[x_lo, x_hi]` whose centres the
    /// silhouette covers, as an inclusive range, decided by the same edge
    /// functions and tie rule as [`TetSetup::covers`] (so exactly the pixels
    /// it accepts): each edge's test is monotone in x along a row, so its
    /// boundary is estimated from the edge's crossing and then settled with
    /// the exact test.
    pub fn row_span(&self, py: u32, x_lo: u32, x_hi: u32) -> Option<(u32, u32)> {
        row_span_of(&self.edges[..self.n_hull], py, x_lo, x_hi)
    }

    /// Segments for the `LANES` pixels `(px0 + l, py)`, l = 0..LANES, in f32
    /// (see [`SpanEval`]); lanes outside the tet get `len_world == 0`.
    /// Scalars are clamped into the tet's vertex range and lengths into
    /// [0, longest edge], so no lane is ever NaN.
    #[inline]
    pub fn eval_lanes(&self, px0: u32, py: u32, out: &mut Lanes) {
        self.span.eval_row(px0, py, out);
    }

    /// The `pt-linear` tent weights for the `LANES` pixels `(px0 + l, py)`
    /// (see [`TetSetup::tent`]), in f32.
    #[inline]
    pub fn tent_lanes(&self, px0: u32, py: u32, out: &mut [f32; LANES]) {
        let sp = &self.span;
        let i0 = (px0 as i32 - sp.ref_px[0]) as f32;
        let j = (py as i32 - sp.ref_px[1]) as f32;
        *out = [1.0; LANES];
        for r in &self.span_ramps[..self.n_ramps] {
            let rr = r.row(j);
            for (l, o) in out.iter_mut().enumerate() {
                let v = rr + r.dx * (i0 + l as f32);
                *o = if v < *o { v } else { *o };
            }
        }
        for o in out.iter_mut() {
            *o = if *o > 0.0 { o.min(1.0) } else { 0.0 };
        }
    }

    /// Whether pixel centre (x, y) is covered (edge functions, tie rule);
    /// the per-pixel definition [`TetSetup::row_span`] must agree with.
    #[cfg(test)]
    pub fn covers(&self, x: f64, y: f64) -> bool {
        self.edges[..self.n_hull].iter().all(|e| e.inside(x, y))
    }

    /// The segment along the ray through pixel position (x, y); `None` where
    /// the ray misses the tet or the segment has no length.
    #[inline]
    pub fn fragment(&self, frame: &Frame, x: f64, y: f64) -> Option<Fragment> {
        let ev = |q: &[f64; 3]| q[0] + q[1] * x + q[2] * y;
        let (z_f, z_b) = if self.parallel {
            let mut zf = f64::NEG_INFINITY;
            for q in &self.planes_front[..self.n_front] {
                zf = zf.max(ev(q));
            }
            let mut zb = f64::INFINITY;
            for q in &self.planes_back[..self.n_back] {
                zb = zb.min(ev(q));
            }
            (zf, zb)
        } else {
            // Entry: the smallest positive 1/depth over front planes (and the
            // near plane); exit: the largest over back planes.
            let mut wf = self.near_w.unwrap_or(f64::INFINITY);
            for q in &self.planes_front[..self.n_front] {
                let w = ev(q);
                if w > 0.0 && w < wf {
                    wf = w;
                }
            }
            let mut wb = 0.0f64;
            for q in &self.planes_back[..self.n_back] {
                wb = wb.max(ev(q));
            }
            // (f64::max drops NaNs, so wb is a number.)
            if wb <= 0.0 || wf == f64::INFINITY {
                return None;
            }
            (1.0 / wf, 1.0 / wb)
        };
        if !z_f.is_finite() || !z_b.is_finite() || z_b <= z_f {
            return None;
        }
        let len = ((z_b - z_f) * frame.len_per_depth(x, y)).min(self.len_max);
        let clamp = |v: f64, r: [f64; 2]| if v.is_nan() { r[0] } else { v.clamp(r[0], r[1]) };
        let (g_front, g_back) = match &self.g {
            Some(g) => (clamp(g.at(x, y, z_f), self.g_range), clamp(g.at(x, y, z_b), self.g_range)),
            None => (0.0, 0.0),
        };
        Some(Fragment {
            s_front: clamp(self.s.at(x, y, z_f), self.s_range),
            s_back: clamp(self.s.at(x, y, z_b), self.s_range),
            g_front,
            g_back,
            len_world: len,
            z_front: z_f,
            z_back: z_b,
        })
    }

    /// The interpolated per-vertex gradient (world frame) at depth z on the
    /// ray through (x, y), when normals were requested.
    #[inline]
    pub fn normal_at(&self, x: f64, y: f64, z: f64) -> Option<DVec3> {
        self.normal.as_ref().map(|n| DVec3::new(n[0].at(x, y, z), n[1].at(x, y, z), n[2].at(x, y, z)))
    }

    /// The tent weight of the thick point at pixel (x, y): 1 at the thick
    /// point, 0 on the silhouette, linear on each of the Shirley–Tuchman
    /// triangles (on a convex silhouette the tent is the minimum of the
    /// per-edge ramps, so no triangle lookup is needed). The f64 definition
    /// [`TetSetup::tent_lanes`] evaluates in f32.
    #[cfg(test)]
    pub fn tent(&self, x: f64, y: f64) -> f64 {
        if self.thick.is_none() {
            return 0.0;
        }
        let mut lam = 1.0f64;
        for r in &self.tent_ramps[..self.n_ramps] {
            lam = lam.min(r[0] + r[1] * x + r[2] * y);
        }
        lam.clamp(0.0, 1.0)
    }
}

/// Which pixels of its bounding box a prepared tet covers.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(crate) enum Cover {
    /// Bounding box at most [`MASK_SIDE`] pixels wide and high: bit
    /// `8·j + i` is pixel (bbox x0 + i, bbox y0 + j).
    Mask(u64),
    /// Larger: one inclusive pixel range per row of the bounding box, from
    /// this index on in the rows list (`[1, 0]` for an empty row).
    Rows(u32),
}

/// Side of the bounding boxes whose coverage is a [`Cover::Mask`].
pub(crate) const MASK_SIDE: i32 = 8;

/// The silhouette of an unclipped tet's projected vertices `p4` (keys
/// `keys4`) in `hull`/`hull_keys`, positively oriented (interior on the left
/// of each directed edge): its Shirley–Tuchman class and vertex count (0
/// when degenerate).
fn silhouette_hull(
    p4: &[[f64; 2]; 4],
    keys4: &[u64; 4],
    hull: &mut [[f64; 2]; 6],
    hull_keys: &mut [u64; 6],
) -> (ProjClass, usize) {
    let class = classify_projection(p4);
    let (sil, ns) = class.silhouette();
    for k in 0..ns {
        hull[k] = p4[sil[k]];
        hull_keys[k] = keys4[sil[k]];
    }
    let area: f64 = (0..ns)
        .map(|k| {
            let (u, v) = (hull[k], hull[(k + 1) % ns]);
            u[0] * v[1] - u[1] * v[0]
        })
        .sum();
    if area < 0.0 {
        hull[..ns].reverse();
        hull_keys[..ns].reverse();
    }
    (class, ns)
}

/// What [`prepare_span`] made of a tet.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(crate) enum Prepared {
    /// Covers no pixel (what [`TetSetup::build`] returns `false` for).
    Nothing,
    /// Crosses the near plane: only [`TetSetup::build`] clips.
    Clipped,
    /// `span` holds the tet's planes and fields; `cover` its pixels.
    Span { bbox: [i32; 4], cover: Cover },
}

/// The per-fragment (span) setup of one unclipped tet, once per tet rather
/// than once per tile it touches: the same silhouette, bounding box, edge
/// tests and [`SpanEval`] as [`TetSetup::build`] with `want_span`, so the
/// rasterizer's fast path draws the same fragments with the same values.
/// The row spans over the whole bounding box are computed here, where the
/// edges are at hand ([`row_span_of`] on a sub-range of a row gives that
/// sub-range of the full span).
pub(crate) fn prepare_span(inp: &SetupInputs, t: usize, span: &mut SpanEval, rows: &mut Vec<[u16; 2]>) -> Prepared {
    let scene = inp.scene;
    let view = inp.view;
    let frame = &view.frame;
    let tet = &scene.tets()[t];
    if !frame.parallel && tet.iter().any(|&v| view.cam[v as usize][2] < frame.near_depth) {
        return Prepared::Clipped;
    }
    let p4 = tet.map(|v| view.px[v as usize]);
    let mut hull = [[0.0; 2]; 6];
    let mut hull_keys = [0u64; 6];
    let (_, ns) = silhouette_hull(&p4, &tet.map(vertex_key), &mut hull, &mut hull_keys);
    if ns < 3 {
        return Prepared::Nothing;
    }
    let Some(bbox) = bbox_of(&hull[..ns], frame.width, frame.height) else { return Prepared::Nothing };
    let x = tet.map(|v| DVec3::from(view.cam[v as usize]));
    let (e1, e2, e3) = (x[1] - x[0], x[2] - x[0], x[3] - x[0]);
    let det = e1.dot(e2.cross(e3));
    if det == 0.0 || !det.is_finite() {
        return Prepared::Nothing;
    }
    let sv = tet.map(|v| scene.scalar()[v as usize]);
    let range = |f: &[f64; 4]| {
        [f.iter().copied().fold(f64::INFINITY, f64::min), f.iter().copied().fold(f64::NEG_INFINITY, f64::max)]
    };
    let g_vals = match (inp.want_grad_mag, scene.gradient_magnitudes()) {
        (true, Some(gm)) => Some(tet.map(|v| gm[v as usize])),
        _ => None,
    };
    let g_range = g_vals.as_ref().map_or([0.0, 0.0], range);
    let mut len_max: f64 = 0.0;
    for i in 0..4 {
        for j in i + 1..4 {
            len_max = len_max.max((x[i] - x[j]).length_squared());
        }
    }
    *span = SpanEval::new(frame, bbox);
    let ranges = (range(&sv), g_range, len_max.sqrt());
    if !span.set_segments(frame, &x, &sv, g_vals.as_ref(), view.face_mask[t], None, ranges) {
        return Prepared::Nothing;
    }
    let mut edges = [Edge::default(); 4];
    for k in 0..ns {
        let j = (k + 1) % ns;
        edges[k] = Edge::new(hull[k], hull_keys[k], hull[j], hull_keys[j]);
    }
    let (w, h) = (bbox[2] - bbox[0] + 1, bbox[3] - bbox[1] + 1);
    if w <= MASK_SIDE && h <= MASK_SIDE {
        return Prepared::Span { bbox, cover: Cover::Mask(cover_mask(&edges[..ns], bbox)) };
    }
    let first = rows.len() as u32;
    for py in bbox[1]..=bbox[3] {
        let r = row_span_of(&edges[..ns], py as u32, bbox[0] as u32, bbox[2] as u32);
        rows.push(r.map_or([1, 0], |(a, b)| [a as u16, b as u16]));
    }
    Prepared::Span { bbox, cover: Cover::Rows(first) }
}

/// The pixel centres of a bounding box at most [`MASK_SIDE`] square that
/// every edge accepts, as a [`Cover::Mask`]: [`Edge::inside`] for each,
/// with its row term `dx·(y − ay)` and column term `dy·(x − ax)` computed
/// once per row and column (the same operations, so the same decisions),
/// eight columns at a time.
fn cover_mask(edges: &[Edge], bbox: [i32; 4]) -> u64 {
    const S: usize = MASK_SIDE as usize;
    let (w, h) = ((bbox[2] - bbox[0] + 1) as usize, (bbox[3] - bbox[1] + 1) as usize);
    let cols: u64 = (1u64 << w) - 1;
    let mut mask = 0u64;
    for j in 0..h {
        mask |= cols << (S * j);
    }
    let x = |i: usize| (bbox[0] + i as i32) as f64 + 0.5;
    let (x_lo, x_hi) = (f64x4::from([x(0), x(1), x(2), x(3)]), f64x4::from([x(4), x(5), x(6), x(7)]));
    let zero = f64x4::ZERO;
    for e in edges {
        let (ax, dy, sign) = (f64x4::splat(e.ax), f64x4::splat(e.dy), f64x4::splat(e.sign));
        let (c_lo, c_hi) = (dy * (x_lo - ax), dy * (x_hi - ax));
        let tie = if e.tie { f64x4::splat(f64::from_bits(u64::MAX)) } else { zero };
        let mut m = 0u64;
        for j in 0..h {
            let row = f64x4::splat(e.dx * ((bbox[1] + j as i32) as f64 + 0.5 - e.ay));
            let bits = |c: f64x4| {
                let v = sign * (row - c);
                (v.cmp_gt(zero) | (v.cmp_eq(zero) & tie)).move_mask() as u64
            };
            m |= (bits(c_lo) | bits(c_hi) << 4) << (S * j);
        }
        mask &= m;
    }
    mask
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn class_one_when_a_vertex_projects_inside() {
        let p = [[0.0, 0.0], [10.0, 0.0], [0.0, 10.0], [2.0, 2.0]];
        assert_eq!(classify_projection(&p), ProjClass::One { thick: 3 });
        let p = [[2.0, 2.0], [10.0, 0.0], [0.0, 10.0], [0.0, 0.0]];
        assert_eq!(classify_projection(&p), ProjClass::One { thick: 0 });
    }

    #[test]
    fn class_two_when_edges_cross() {
        // Square with diagonals (0,2) and (1,3) crossing at its centre.
        let p = [[0.0, 0.0], [10.0, 0.0], [10.0, 10.0], [0.0, 10.0]];
        match classify_projection(&p) {
            c @ ProjClass::Two { diag0, diag1, t } => {
                let mut d = [diag0, diag1].map(|mut e| {
                    e.sort();
                    e
                });
                d.sort();
                assert_eq!(d, [[0, 2], [1, 3]]);
                assert!((t - 0.5).abs() < 1e-15);
                assert_eq!(c.thick_point(&p), Some([5.0, 5.0]));
                assert_eq!(c.silhouette().1, 4);
            }
            c => panic!("{c:?}"),
        }
    }

    #[test]
    fn degenerate_projections() {
        // A vertex exactly on an edge: class 1 with the thick vertex on the boundary.
        let p = [[0.0, 0.0], [10.0, 0.0], [0.0, 10.0], [5.0, 0.0]];
        assert_eq!(classify_projection(&p), ProjClass::One { thick: 3 });
        // Two vertices coincide (an edge seen end-on).
        let p = [[0.0, 0.0], [10.0, 0.0], [3.0, 3.0], [3.0, 3.0]];
        assert!(matches!(classify_projection(&p), ProjClass::One { thick: 2 | 3 }));
        // All collinear: nothing to draw.
        let p = [[0.0, 0.0], [1.0, 1.0], [2.0, 2.0], [5.0, 5.0]];
        assert_eq!(classify_projection(&p), ProjClass::Degenerate);
        let p = [[1.0, 1.0]; 4];
        assert_eq!(classify_projection(&p), ProjClass::Degenerate);
    }

    #[test]
    fn shared_edge_ties_go_to_exactly_one_side() {
        // Edge from (0,0) to (4,4) passing through the centre (1.5,1.5);
        // the two triangles on either side use it in opposite directions.
        let (a, b) = ([0.0, 0.0], [4.0, 4.0]);
        let e1 = Edge::new(a, 1, b, 2);
        let e2 = Edge::new(b, 2, a, 1);
        assert!(e1.inside(1.5, 1.5) != e2.inside(1.5, 1.5));
        let h1 = Edge::new([0.0, 1.5], 1, [4.0, 1.5], 2);
        let h2 = Edge::new([4.0, 1.5], 2, [0.0, 1.5], 1);
        assert!(h1.inside(2.5, 1.5) != h2.inside(2.5, 1.5));
    }

    /// A small xorshift generator (fixed seeds).
    struct Rng(u64);
    impl Rng {
        fn next(&mut self) -> f64 {
            self.0 ^= self.0 << 13;
            self.0 ^= self.0 >> 7;
            self.0 ^= self.0 << 17;
            (self.0 >> 11) as f64 / (1u64 << 53) as f64
        }
        fn range(&mut self, lo: f64, hi: f64) -> f64 {
            lo + (hi - lo) * self.next()
        }
    }

    /// Compares the span path (row spans, f32 lanes) with the per-pixel f64
    /// path on one tet: identical coverage; lengths within 1e-5 of the
    /// longest edge; scalars within 1e-5 of the vertex range wherever the
    /// segment is longer than 1e-3 of the longest edge (on shorter ones the
    /// scalar is ill-conditioned and weighs nothing); tents within 1e-5.
    /// Returns the number of covered pixels.
    fn span_matches_per_pixel(p: [[f64; 3]; 4], view: &crate::ViewSpec) -> usize {
        let d = |a: [f64; 3], b: [f64; 3]| DVec3::from(b) - DVec3::from(a);
        let p = if d(p[0], p[1]).dot(d(p[0], p[2]).cross(d(p[0], p[3]))) < 0.0 { [p[0], p[1], p[3], p[2]] } else { p };
        let scene = Scene::new(&p, vec![[0, 1, 2, 3]], vec![0.1, 0.9, 0.4, 0.7]).unwrap();
        let camera = Camera::new(view).unwrap();
        let geo = ViewGeometry::new(&scene, &camera);
        let inp = SetupInputs {
            scene: &scene,
            view: &geo,
            want_grad_mag: false,
            want_normals: false,
            want_thick: true,
            want_span: true,
        };
        let Some(s) = TetSetup::new(&inp, 0) else { return 0 };
        let mut covered = 0;
        let mut lanes = Lanes::default();
        let mut tent = [0.0f32; LANES];
        let [x0, y0, x1, y1] = s.bbox.map(|v| v as u32);
        for py in y0..=y1 {
            let span = s.row_span(py, x0, x1);
            for px in x0..=x1 {
                let (x, y) = (px as f64 + 0.5, py as f64 + 0.5);
                let inside = span.is_some_and(|(a, b)| a <= px && px <= b);
                assert_eq!(inside, s.covers(x, y), "pixel ({px}, {py}) of {p:?} in {view:?}");
                if !inside {
                    continue;
                }
                covered += 1;
                s.eval_lanes(px, py, &mut lanes);
                // The fast path's gathered evaluation (this pixel in lane 3
                // among others) gives the row's lane bit for bit.
                let mut one = Lanes::default();
                let (ri, rj) = ((px as i32 - s.span.ref_px[0]) as f32, (py as i32 - s.span.ref_px[1]) as f32);
                let mut i = [ri + 5.0; LANES];
                i[3] = ri;
                s.span.eval_pixels(&i, &[rj; LANES], &mut one);
                let bits = |l: &Lanes, k: usize| {
                    [l.s_front, l.s_back, l.g_front, l.g_back, l.len_world, l.zeta_mid].map(|a| a[k].to_bits())
                };
                assert_eq!(bits(&one, 3), bits(&lanes, 0), "gathered lane at ({px}, {py})");
                let want = s.fragment(&geo.frame, x, y);
                let got_len = lanes.len_world[0] as f64;
                let want_len = want.map_or(0.0, |f| f.len_world);
                assert!((got_len - want_len).abs() <= 1e-5 * s.len_max, "len {got_len} vs {want_len} at ({px}, {py})");
                if let Some(f) = want {
                    if f.len_world > 1e-3 * s.len_max && got_len > 0.0 {
                        let tol = 1e-5 * (s.s_range[1] - s.s_range[0]);
                        assert!((lanes.s_front[0] as f64 - f.s_front).abs() <= tol, "sf at ({px}, {py})");
                        assert!((lanes.s_back[0] as f64 - f.s_back).abs() <= tol, "sb at ({px}, {py})");
                    }
                }
                if s.thick.is_some() {
                    // Within 1e-5 of the tent's change over one pixel when that is steeper than 1.
                    let slope = s.tent_ramps[..s.n_ramps].iter().map(|r| r[1].abs() + r[2].abs()).fold(1.0, f64::max);
                    s.tent_lanes(px, py, &mut tent);
                    let (got, want) = (tent[0] as f64, s.tent(x, y));
                    assert!((got - want).abs() <= 1e-5 * slope, "tent at ({px}, {py}): {got} vs {want}");
                }
            }
        }
        covered
    }

    #[test]
    fn span_path_matches_the_per_pixel_path_on_random_tets() {
        let mut rng = Rng(0x5eed_5a11);
        let mut covered = 0;
        for case in 0..200 {
            let p = std::array::from_fn(|_| std::array::from_fn(|_| rng.range(-1.0, 1.0)));
            let mut view = crate::ViewSpec::framing([-1.0; 3], [1.0; 3], [37, 29]).orbit(
                rng.range(0.0, 360.0),
                rng.range(-80.0, 80.0),
                rng.range(0.5, 3.0),
            );
            view.parallel = case % 3 == 1;
            if case % 7 == 3 {
                // Eye inside the box the tets live in: some tets cross the near plane.
                view.position = std::array::from_fn(|_| rng.range(-0.5, 0.5));
            }
            covered += span_matches_per_pixel(p, &view);
        }
        assert!(covered > 10_000, "only {covered} pixels were compared");
    }

    #[test]
    fn span_path_matches_on_slivers_needles_and_grid_aligned_edges() {
        let view = crate::ViewSpec::framing([-1.0; 3], [1.0; 3], [48, 48]);
        for parallel in [false, true] {
            let mut v = view.clone();
            v.parallel = parallel;
            span_matches_per_pixel([[-0.8, -0.7, 0.0], [0.9, -0.6, 1e-7], [0.1, 0.8, 0.0], [0.0, 0.0, 2e-7]], &v);
            span_matches_per_pixel([[0.0, 0.0, -0.9], [0.01, 0.0, 0.9], [0.0, 0.012, 0.9], [0.005, 0.004, 0.0]], &v);
            span_matches_per_pixel([[0.0, -0.5, -0.5], [0.0, 0.5, -0.5], [0.0, 0.0, 0.5], [0.7, 0.0, 0.0]], &v);
            // Edges through pixel centres (axis-aligned cube corner).
            span_matches_per_pixel([[0.0, 0.0, 0.0], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]], &v);
            // Edges a few ulps to 1e-9 pixel off pixel centres: row spans'
            // fast path must hand these to the exact tests.
            for d in [1e-15, 1e-13, 1e-11, 1e-9] {
                span_matches_per_pixel([[d, d, 0.0], [1.0 + d, -d, 0.0], [-d, 1.0 + d, 0.0], [d, 0.0, 1.0]], &v);
            }
        }
    }

    /// The inlined orient3d filter never disagrees with the exact predicate,
    /// and defers on eyes in (or numerically near) a face's plane.
    #[test]
    fn orient3d_filter_agrees_with_the_exact_predicate() {
        let mut rng = Rng(0x0f11_7e25);
        let mut deferred = 0;
        for i in 0..50_000 {
            let mut p = || [rng.range(-3.0, 3.0), rng.range(-3.0, 3.0), rng.range(1e3, 1e3 + 6.0)];
            let (a, b, c) = (p(), p(), p());
            let eye = match i % 3 {
                0 => p(),
                // On the plane through a, b, c (up to rounding): the hard case.
                1 => {
                    let (u, v) = (rng.range(-2.0, 2.0), rng.range(-2.0, 2.0));
                    std::array::from_fn(|k| a[k] + u * (b[k] - a[k]) + v * (c[k] - a[k]))
                }
                // Exactly on an edge's line, coplanar: Flat.
                _ => std::array::from_fn(|k| a[k] + 2.0 * (b[k] - a[k])),
            };
            let d = |q: [f64; 3]| [q[0] - eye[0], q[1] - eye[1], q[2] - eye[2]];
            let exact = side_of_oriented_plane(&a, &b, &c, &eye);
            match orient3d_filtered(&d(a), &d(b), &d(c)) {
                Some(side) => assert_eq!(side, exact, "{a:?} {b:?} {c:?} {eye:?}"),
                None => deferred += 1,
            }
        }
        assert!(deferred > 1000, "the near-plane cases should reach the exact predicate ({deferred})");
    }

    /// `bbox_of`'s libm-free rounding agrees with ceil/floor, on pixel
    /// centres, half-integers, negatives and values past the image.
    #[test]
    fn bbox_rounding_matches_libm() {
        let libm = |pts: &[[f64; 2]], w: u32, h: u32| -> Option<[i32; 4]> {
            let lo = [
                pts.iter().map(|p| p[0]).fold(f64::INFINITY, f64::min),
                pts.iter().map(|p| p[1]).fold(f64::INFINITY, f64::min),
            ];
            let hi = [
                pts.iter().map(|p| p[0]).fold(f64::NEG_INFINITY, f64::max),
                pts.iter().map(|p| p[1]).fold(f64::NEG_INFINITY, f64::max),
            ];
            let c = |v: f64, max: u32| v.clamp(-1.0, max as f64) as i32;
            let (x0, y0) = (c((lo[0] - 0.5).ceil(), w).max(0), c((lo[1] - 0.5).ceil(), h).max(0));
            let (x1, y1) = (c((hi[0] - 0.5).floor(), w - 1), c((hi[1] - 0.5).floor(), h - 1));
            (x0 <= x1 && y0 <= y1 && x1 >= 0 && y1 >= 0).then_some([x0, y0, x1, y1])
        };
        let mut rng = Rng(0x5eed_b0b5);
        let specials = [0.0, 0.5, 1.5, -0.5, -3.25, 99.5, 100.0, 100.5, 1e12, -1e12, 1e300, -1e300];
        for i in 0..20_000 {
            let pick = |rng: &mut Rng, k: usize| {
                if (i + k).is_multiple_of(3) {
                    specials[(rng.next() * specials.len() as f64) as usize % specials.len()]
                } else {
                    rng.range(-20.0, 120.0)
                }
            };
            let pts: Vec<[f64; 2]> = (0..3 + i % 4).map(|k| [pick(&mut rng, k), pick(&mut rng, k + 1)]).collect();
            assert_eq!(bbox_of(&pts, 100, 80), libm(&pts, 100, 80), "{pts:?}");
        }
    }

    #[test]
    fn hull_of_clipped_points() {
        let pts = [[0.0, 0.0], [4.0, 0.0], [4.0, 4.0], [0.0, 4.0], [2.0, 2.0], [2.0, 0.0]];
        let keys = [0, 1, 2, 3, 4, 5];
        let mut h = [[0.0; 2]; 6];
        let mut k = [0; 6];
        let n = hull_of(&pts, &keys, &mut h, &mut k);
        assert_eq!(n, 4);
        let area: f64 = (0..n).map(|i| h[i][0] * h[(i + 1) % n][1] - h[i][1] * h[(i + 1) % n][0]).sum();
        assert!(area > 0.0);
    }
}
