//! Exact orientation and symbolically perturbed in-sphere tests.
//!
//! Orientation is never perturbed: a finite tet is kept only when its four
//! points are exactly non-coplanar, so no output tet can have zero volume.
//! Only the in-sphere test is perturbed, by lifting each point's paraboloid
//! coordinate |p|² by an infinitesimal amount that is larger for smaller
//! point ids (simulation of simplicity on the lifted points, as CGAL and
//! geogram do). The result is the exact regular triangulation of a generic
//! weighted point set whose weights are infinitesimal, so every tie between
//! cospherical points is broken the same way wherever it is evaluated.

use robust::{insphere, orient3d, Coord3D};

#[inline]
fn c(p: &[f64; 3]) -> Coord3D<f64> {
    Coord3D { x: p[0], y: p[1], z: p[2] }
}

/// Exact orientation in tetkit's convention: positive when
/// det[b−a, c−a, d−a] > 0, zero exactly when the points are coplanar.
#[inline]
pub(crate) fn orient(a: &[f64; 3], b: &[f64; 3], cc: &[f64; 3], d: &[f64; 3]) -> f64 {
    // Shewchuk's orient3d is det[a−d, b−d, c−d] = −det[b−a, c−a, d−a].
    -orient3d(c(a), c(b), c(cc), c(d))
}

/// Exact in-sphere sign for a positively oriented (tetkit convention) tet:
/// positive when `q` lies strictly inside the circumsphere, zero when
/// cospherical.
#[inline]
pub(crate) fn in_sphere_exact(a: &[f64; 3], b: &[f64; 3], cc: &[f64; 3], d: &[f64; 3], q: &[f64; 3]) -> f64 {
    // Shewchuk's insphere expects his positive orientation, which is our
    // negative one, so its sign is reversed here.
    -insphere(c(a), c(b), c(cc), c(d), c(q))
}

/// Whether point `q` (id `iq`) is in conflict with the positively oriented
/// finite tet `t` (ids `it`): strictly inside its circumsphere, ties broken
/// by the symbolic perturbation described in the module docs. Never
/// undecided for distinct ids and a non-flat tet.
#[cfg(test)]
pub(crate) fn in_sphere_sos(t: [&[f64; 3]; 4], it: [u32; 4], q: &[f64; 3], iq: u32) -> bool {
    let d = in_sphere_exact(t[0], t[1], t[2], t[3], q);
    if d != 0.0 {
        return d > 0.0;
    }
    in_sphere_tie(t, it, q, iq)
}

/// The perturbed decision for five exactly cospherical points (see
/// [`in_sphere_sos`]).
#[cold]
pub(crate) fn in_sphere_tie(t: [&[f64; 3]; 4], it: [u32; 4], q: &[f64; 3], iq: u32) -> bool {
    // Raising the lift of tet vertex j by δ moves the lifted plane at q by
    // λ_j·δ, where λ_j (q's barycentric coordinate) has the sign of the tet
    // with vertex j replaced by q; raising q's own lift moves q outside.
    // The largest perturbation (smallest id) that decides anything wins.
    let mut order = [(it[0], 0usize), (it[1], 1), (it[2], 2), (it[3], 3), (iq, 4)];
    order.sort_unstable();
    for &(_, j) in &order {
        if j == 4 {
            return false;
        }
        let mut v = t;
        v[j] = q;
        let s = orient(v[0], v[1], v[2], v[3]);
        if s != 0.0 {
            return s > 0.0;
        }
    }
    unreachable!("the query point always decides")
}

#[cfg(test)]
mod tests {
    use super::*;

    const O: [f64; 3] = [0.0, 0.0, 0.0];
    const X: [f64; 3] = [1.0, 0.0, 0.0];
    const Y: [f64; 3] = [0.0, 1.0, 0.0];
    const Z: [f64; 3] = [0.0, 0.0, 1.0];

    #[test]
    fn signs_follow_tetkit_convention() {
        assert!(orient(&O, &X, &Y, &Z) > 0.0);
        assert!(orient(&O, &Y, &X, &Z) < 0.0);
        assert!(in_sphere_exact(&O, &X, &Y, &Z, &[0.2, 0.2, 0.2]) > 0.0);
        assert!(in_sphere_exact(&O, &X, &Y, &Z, &[2.0, 2.0, 2.0]) < 0.0);
        // (1,1,1) is a corner of the cube whose circumsphere this is.
        assert_eq!(in_sphere_exact(&O, &X, &Y, &Z, &[1.0, 1.0, 1.0]), 0.0);
    }

    #[test]
    fn cospherical_tie_is_decided_consistently() {
        // The cube corner W = (1,1,1) versus the corner tet, and the corner
        // tet's vertex O versus the tet (X, Y, Z, W): both tests read the
        // same perturbed 5-point determinant, so they must agree, or both
        // triangulations of the 5 cospherical points (2 tets across XYZ, or
        // 3 around OW) would pass, or neither.
        let w = [1.0, 1.0, 1.0];
        let a = in_sphere_sos([&O, &X, &Y, &Z], [0, 1, 2, 3], &w, 4);
        // (X, Y, Z, W) positively oriented?
        let (t2, i2) = if orient(&X, &Y, &Z, &w) > 0.0 {
            ([&X, &Y, &Z, &w], [1, 2, 3, 4])
        } else {
            ([&Y, &X, &Z, &w], [2, 1, 3, 4])
        };
        let b = in_sphere_sos(t2, i2, &O, 0);
        assert_eq!(a, b);
    }
}
