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

mod raster;
mod setup;

pub(crate) use raster::*;
pub use setup::Fragment;
pub(crate) use setup::*;

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
pub(crate) const O3D_ERRBOUND_A: f64 = {
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
pub(crate) fn orient3d_filtered(a: &[f64; 3], b: &[f64; 3], c: &[f64; 3]) -> Option<TetOrientation> {
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
pub(crate) fn parallel_side(pos: &[[f64; 3]], ids: [u32; 3], forward: DVec3) -> TetOrientation {
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

pub(crate) fn coord(p: [f64; 2]) -> Coord<f64> {
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

    // A small xorshift generator (fixed seeds).
    use tet_mesh::XorShift64 as Rng;

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
            want_position: false,
            shadows: None,
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
                    specials[(rng.next_f64() * specials.len() as f64) as usize % specials.len()]
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
