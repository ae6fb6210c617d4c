//! The walker's geometry for views whose near plane cuts the mesh (the eye
//! inside it or beside it): homogeneous pixel coordinates, in the manner of
//! Olano & Greer, "Triangle scan conversion using 2D homogeneous
//! coordinates" (1997).
//!
//! A vertex keeps (X, Y, W) = (x_px·depth, y_px·depth, depth), a linear map
//! of its camera-space position, so it is defined for vertices behind the
//! eye too, where dividing by the depth would flip them. The side of the
//! line through the eye and pixel centre p = (px, py, 1) against the edge
//! a → b is the sign of det[A, B, p] — W_a·W_b times the projected
//! `orient2d` where both are in front, the Plücker product of the two lines
//! up to a constant positive factor everywhere — so the walk's exit rule
//! ([`super`]) holds unchanged. Three things differ from the projected
//! walk:
//!
//! * for a face (A, B, C) and P = αA + βB + γC, the three edge values are
//!   α, β, γ times det[A, B, C]: the line meets the face when they agree
//!   in sign, in front of the eye when that sign is the face's orientation
//!   sign and behind it when opposite. An entry is a face oriented to the
//!   front whose three edges say front: met in front of the eye;
//! * the eye's own tet (all four faces oriented to the back) starts every
//!   ray, through the face the line meets behind the eye;
//! * segments are clipped at the camera's near depth, as the reference
//!   ([`crate::reference`]) and projected tetrahedra clip them.
//!
//! The values are computed in f64 from the f32 coordinates (each product of
//! two f32 is exact); where a value is too close to zero for its sign to be
//! certain, Shewchuk's exact `orient3d` decides on the same f32 inputs, and
//! an exact zero is broken by the perturbation of [`super::edge`] (the
//! centre moved by (−ε, ε²)), which this form reproduces where both
//! endpoints are in front. The barycentric weights are the edge values
//! normalised: the point's depth and scalar are affine in them.

use super::edge::EdgeCounters;
use super::FRONT_IS_LEFT;
use robust::{orient3d, Coord3D};
use tet_mesh::FACE_OUTWARD;

/// A vertex of one view in homogeneous pixel coordinates: `x_hom / w_depth`
/// and `y_hom / w_depth` are its pixel position, `w_depth` its depth along
/// the view direction (negative behind the eye).
#[derive(Debug, Clone, Copy, Default, PartialEq)]
#[repr(C, align(16))]
pub struct HomVertex {
    pub x_hom: f32,
    pub y_hom: f32,
    pub w_depth: f32,
    pub scalar: f32,
}

impl HomVertex {
    #[inline(always)]
    fn xyw(&self) -> [f64; 3] {
        [self.x_hom as f64, self.y_hom as f64, self.w_depth as f64]
    }
}

/// Unit roundoff of f64.
const U64: f64 = f64::EPSILON * 0.5;

/// An edge value's error bound over its permanent ([`canonical`]; the
/// packet walk's lanes use the same).
pub(crate) const EDGE_BOUND: f64 = 8.0 * U64;

fn coord(p: [f64; 3]) -> Coord3D<f64> {
    Coord3D { x: p[0], y: p[1], z: p[2] }
}

/// det[a, b, c] in exact arithmetic (its sign; the value is an approximation).
#[inline(never)]
pub fn exact_det(a: [f64; 3], b: [f64; 3], c: [f64; 3]) -> f64 {
    // Shewchuk's orient3d(a, b, c, d) is det[a − d; b − d; c − d].
    orient3d(coord(a), coord(b), coord(c), coord([0.0; 3]))
}

/// The canonical edge (a, b) with id(a) < id(b): det[A, B, p] (as f32, for
/// weights) and whether p passes left of a → b, exactly, ties by the
/// perturbation (−ε, ε²) of the centre.
#[inline(always)]
fn canonical(a: &HomVertex, b: &HomVertex, px: f32, py: f32, counters: &mut EdgeCounters) -> (f32, bool) {
    let ([ax, ay, aw], [bx, by, bw]) = (a.xyw(), b.xyw());
    let (px, py) = (px as f64, py as f64);
    let (c1, c2) = (ay * bw, aw * by);
    let (c3, c4) = (aw * bx, ax * bw);
    let (c5, c6) = (ax * by, ay * bx);
    let (cx, cy, cz) = (c1 - c2, c3 - c4, c5 - c6);
    let e = cx * px + cy * py + cz;
    // Each product of two f32 is exact in f64; the three differences, two
    // products and two sums round once each: at most 4u of the permanent
    // (doubled for margin).
    let perm = (c1.abs() + c2.abs()) * px.abs() + (c3.abs() + c4.abs()) * py.abs() + c5.abs() + c6.abs();
    let bound = EDGE_BOUND * perm;
    if e > bound {
        return (e as f32, true);
    }
    if e < -bound {
        return (e as f32, false);
    }
    counters.exact += 1;
    (e as f32, exact_left(a.xyw(), b.xyw(), px, py))
}

/// Whether the line through the eye and pixel centre (px, py) passes left
/// of a → b (homogeneous coordinates), exactly, ties broken by moving the
/// centre by (−ε, ε²).
#[inline(never)]
pub fn exact_left(a: [f64; 3], b: [f64; 3], px: f64, py: f64) -> bool {
    let o = exact_det(a, b, [px, py, 1.0]);
    if o != 0.0 {
        return o > 0.0;
    }
    // d/dpx det = cx = a_y b_w − a_w b_y, d/dpy det = cy = a_w b_x − a_x b_w;
    // each product is exact, so the rounded difference has the exact sign.
    let cx = a[1] * b[2] - a[2] * b[1];
    if cx != 0.0 {
        return cx < 0.0;
    }
    let cy = a[2] * b[0] - a[0] * b[2];
    // Zero: the edge's line passes through the eye; the canonical
    // direction gets "right" and the reverse "left", so they still differ.
    cy > 0.0
}

/// The f64 value (as f32) of the directed edge u → v, on the canonical edge.
#[inline(always)]
pub fn directed_value(verts: &[HomVertex], iu: u32, iv: u32, px: f32, py: f32) -> f32 {
    let value = |a: &HomVertex, b: &HomVertex| {
        let ([ax, ay, aw], [bx, by, bw]) = (a.xyw(), b.xyw());
        ((ay * bw - aw * by) * px as f64 + (aw * bx - ax * bw) * py as f64 + (ax * by - ay * bx)) as f32
    };
    if iu < iv {
        value(&verts[iu as usize], &verts[iv as usize])
    } else {
        -value(&verts[iv as usize], &verts[iu as usize])
    }
}

/// [`super::edge::side`] in homogeneous coordinates.
#[inline(always)]
pub fn side(verts: &[HomVertex], iu: u32, iv: u32, px: f32, py: f32, counters: &mut EdgeCounters) -> (f32, bool) {
    if iu < iv {
        canonical(&verts[iu as usize], &verts[iv as usize], px, py, counters)
    } else {
        let (e, left) = canonical(&verts[iv as usize], &verts[iu as usize], px, py, counters);
        (-e, !left)
    }
}

/// [`super::edge::sides_from`] in homogeneous coordinates (scalar lanes).
#[inline(always)]
pub fn sides_from(
    verts: &[HomVertex],
    tet: [u32; 4],
    skip: usize,
    px: f32,
    py: f32,
    counters: &mut EdgeCounters,
) -> ([f32; 4], u32) {
    let v = tet[skip];
    let mut vals = [0.0f32; 4];
    let mut bits = 0u32;
    for k in 0..4 {
        if k != skip {
            let (e, left) = side(verts, v, tet[k], px, py, counters);
            vals[k] = e;
            bits |= (left as u32) << k;
        }
    }
    (vals, bits)
}

/// Whether face (a, b, c), in outward order, is oriented to the front:
/// `Some(true)` front, `Some(false)` back, `None` when its plane holds the
/// eye (exact, on the same coordinates the walk decides on).
pub fn face_orientation(a: &HomVertex, b: &HomVertex, c: &HomVertex) -> Option<bool> {
    let o = exact_det(a.xyw(), b.xyw(), c.xyw());
    (o != 0.0).then_some((o > 0.0) == FRONT_IS_LEFT)
}

/// Whether the eye (the origin of these coordinates) lies strictly inside
/// the tet: `Some(true)` inside, `Some(false)` outside, `None` on the plane
/// of one of its faces with the other faces not ruling it out.
pub fn holds_eye(verts: &[HomVertex], tet: [u32; 4]) -> Option<bool> {
    let q = tet.map(|v| verts[v as usize]);
    // Cheap rejection: the tet's box must hold the origin.
    for axis in 0..3 {
        let c = q.map(|p| p.xyw()[axis]);
        if c.iter().all(|&x| x > 0.0) || c.iter().all(|&x| x < 0.0) {
            return Some(false);
        }
    }
    match eye_beyond(&q, 0) {
        EyeSide::Beyond(_) => Some(false),
        EyeSide::OnPlane => None,
        EyeSide::Inside => Some(true),
    }
}

/// Where the eye lies against a tet's four faces ([`eye_beyond`]).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum EyeSide {
    /// Beyond face f (it faces the eye): outside the tet, across f.
    Beyond(usize),
    /// Behind every face's plane but on one of them: on the tet's boundary.
    OnPlane,
    /// Strictly inside the tet.
    Inside,
}

/// The faces of tet `q` (outward order) tested from face `first` on, in
/// turn: the first the eye lies beyond, else whether it is on a face's
/// plane or strictly inside (exact, on these coordinates).
pub fn eye_beyond(q: &[HomVertex; 4], first: usize) -> EyeSide {
    let mut on_plane = false;
    for i in 0..4 {
        let f = (first + i) % 4;
        let fv = FACE_OUTWARD[f];
        match face_orientation(&q[fv[0]], &q[fv[1]], &q[fv[2]]) {
            Some(true) => return EyeSide::Beyond(f),
            Some(false) => {}
            None => on_plane = true,
        }
    }
    if on_plane {
        EyeSide::OnPlane
    } else {
        EyeSide::Inside
    }
}

/// Inclusive pixel rectangle of the centres where the line through the
/// eye can meet triangle `p` in front of the eye, clipped to the image (a
/// superset; the edge tests decide). A triangle crossing the eye's plane
/// is first clipped to the view's cone {0 ≤ X ≤ w·W, 0 ≤ Y ≤ h·W}.
pub fn face_rect(p: [HomVertex; 3], w: u32, h: u32) -> Option<[u32; 4]> {
    let mut poly: Vec<[f64; 3]> = p.iter().map(HomVertex::xyw).collect();
    if !poly.iter().all(|q| q[2] > 0.0) {
        let (wf, hf) = (w as f64, h as f64);
        // Half-spaces c · (X, Y, W) ≥ 0.
        for plane in [[1.0, 0.0, 0.0], [-1.0, 0.0, wf], [0.0, 1.0, 0.0], [0.0, -1.0, hf]] {
            poly = clip(&poly, plane);
            if poly.is_empty() {
                return None;
            }
        }
        let w_max = poly.iter().map(|q| q[2].abs()).fold(0.0, f64::max);
        if poly.iter().any(|q| q[2] <= 1e-9 * w_max) {
            // The triangle passes (nearly) through the eye: it may cover
            // any pixel.
            return Some([0, 0, w - 1, h - 1]);
        }
    }
    let (mut x_lo, mut x_hi, mut y_lo, mut y_hi) = (f64::INFINITY, f64::NEG_INFINITY, f64::INFINITY, f64::NEG_INFINITY);
    for q in &poly {
        let (x, y) = (q[0] / q[2], q[1] / q[2]);
        x_lo = x_lo.min(x);
        x_hi = x_hi.max(x);
        y_lo = y_lo.min(y);
        y_hi = y_hi.max(y);
    }
    // Margin for the rounding of the divisions and the clipping.
    let m = 1e-6 * (1.0 + w.max(h) as f64);
    super::centre_rect(x_lo - m, x_hi + m, y_lo - m, y_hi + m, w, h)
}

/// One Sutherland–Hodgman step: the part of `poly` where `plane · q` ≥ 0.
fn clip(poly: &[[f64; 3]], plane: [f64; 3]) -> Vec<[f64; 3]> {
    let dot = |q: &[f64; 3]| plane[0] * q[0] + plane[1] * q[1] + plane[2] * q[2];
    let mut out = Vec::with_capacity(poly.len() + 1);
    for (i, a) in poly.iter().enumerate() {
        let b = &poly[(i + 1) % poly.len()];
        let (da, db) = (dot(a), dot(b));
        if da >= 0.0 {
            out.push(*a);
        }
        if (da >= 0.0) != (db >= 0.0) {
            let t = da / (da - db);
            out.push(std::array::from_fn(|k| a[k] + t * (b[k] - a[k])));
        }
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;
    use proptest::prelude::*;

    fn hv(p: [f64; 3]) -> HomVertex {
        HomVertex { x_hom: p[0] as f32, y_hom: p[1] as f32, w_depth: p[2] as f32, scalar: 0.0 }
    }

    #[test]
    fn exact_det_is_the_determinant() {
        assert!(exact_det([1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]) > 0.0);
        assert!(exact_det([0.0, 1.0, 0.0], [1.0, 0.0, 0.0], [0.0, 0.0, 1.0]) < 0.0);
        assert_eq!(exact_det([1.0, 2.0, 3.0], [2.0, 4.0, 6.0], [0.0, 0.0, 1.0]), 0.0);
    }

    proptest! {
        /// The filtered sign is the exact sign on the same coordinates,
        /// however close the centre is to the edge, and the two directions
        /// of an edge disagree.
        #[test]
        fn filtered_sign_is_the_exact_sign(
            ax in -600.0f64..600.0, ay in -600.0f64..600.0, bx in -600.0f64..600.0, by in -600.0f64..600.0,
            wa in 0.01f64..50.0, wb in 0.01f64..50.0, ix in 0u32..512, iy in 0u32..512, on_line in any::<bool>(),
        ) {
            let (px, py) = (ix as f32 + 0.5, iy as f32 + 0.5);
            // Optionally an edge through the centre (a tie in exact arithmetic).
            let b2 = if on_line { [2.0 * px as f64 - ax, 2.0 * py as f64 - ay] } else { [bx, by] };
            let a = hv([ax * wa, ay * wa, wa]);
            let b = hv([b2[0] * wb, b2[1] * wb, wb]);
            let mut c = EdgeCounters::default();
            let (_, left) = side(&[a, b], 0, 1, px, py, &mut c);
            let o = exact_det(a.xyw(), b.xyw(), [px as f64, py as f64, 1.0]);
            if o != 0.0 {
                prop_assert_eq!(left, o > 0.0);
            }
            let (_, right) = side(&[a, b], 1, 0, px, py, &mut c);
            prop_assert_eq!(right, !left);
        }
    }

    #[test]
    fn ties_follow_the_projected_rule() {
        // Edge through the centre (3.5, 2.5), both endpoints in front: the
        // projected rule says left iff dy > 0 or (dy = 0 and dx > 0).
        for (a, b, wa, wb) in
            [([3.5, 0.0], [3.5, 9.0], 2.0, 5.0), ([0.0, 2.5], [7.0, 2.5], 1.0, 3.0), ([1.5, 1.5], [5.5, 3.5], 4.0, 0.5)]
        {
            let ah = [a[0] * wa, a[1] * wa, wa];
            let bh = [b[0] * wb, b[1] * wb, wb];
            assert_eq!(exact_det(ah, bh, [3.5, 2.5, 1.0]), 0.0);
            let (dx, dy) = (b[0] - a[0], b[1] - a[1]);
            assert_eq!(exact_left(ah, bh, 3.5, 2.5), dy > 0.0 || (dy == 0.0 && dx > 0.0), "{a:?} {b:?}");
        }
    }

    #[test]
    fn eye_location_and_faces_behind() {
        // A tet around the origin (the eye) in camera-like coordinates.
        let verts = [hv([-1.0, -1.0, -1.0]), hv([3.0, -1.0, -1.0]), hv([-1.0, 3.0, -1.0]), hv([-1.0, -1.0, 3.0])];
        // Exactly one of the two orientations has all four faces to the back.
        let both = [holds_eye(&verts, [0, 1, 2, 3]), holds_eye(&verts, [1, 0, 2, 3])];
        assert_eq!(both.iter().filter(|&&h| h == Some(true)).count(), 1, "{both:?}");
        let far = [hv([1.0, 1.0, 1.0]), hv([3.0, 1.0, 1.0]), hv([1.0, 3.0, 1.0]), hv([1.0, 1.0, 3.0])];
        assert_eq!(holds_eye(&far, [0, 1, 2, 3]), Some(false));
        // A triangle straddling the eye's plane gets a finite rectangle.
        let r = face_rect([hv([-5.0, 10.0, -1.0]), hv([30.0, 10.0, 2.0]), hv([10.0, 30.0, 2.0])], 32, 32);
        assert!(r.is_some_and(|r| r[2] < 32 && r[3] < 32), "{r:?}");
        // Wholly behind the eye: nothing.
        assert_eq!(face_rect([hv([1.0, 1.0, -1.0]), hv([2.0, 1.0, -1.0]), hv([1.0, 2.0, -2.0])], 32, 32), None);
    }
}
