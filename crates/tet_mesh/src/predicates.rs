//! Exact geometric predicates under domain names.
//!
//! Every orientation decision in tetkit goes through here, so that a sliver
//! or a perfectly flat tet is classified the same way on every machine: the
//! adaptive-precision predicates of the `robust` crate (Shewchuk's) give the
//! exact sign of the determinant for any finite f64 input.

use robust::{orient3d, Coord3D};

/// Orientation of an ordered tetrahedron.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum TetOrientation {
    /// det[p1−p0, p2−p0, p3−p0] > 0: the tetkit convention for stored tets.
    Positive,
    /// The same tet with two vertices swapped would be positive.
    Negative,
    /// All four points lie exactly in one plane (zero volume).
    Flat,
}

#[inline]
fn c(p: &[f64; 3]) -> Coord3D<f64> {
    Coord3D { x: p[0], y: p[1], z: p[2] }
}

/// Exact orientation of the tet (p0, p1, p2, p3).
#[inline]
pub fn tet_orientation(p0: &[f64; 3], p1: &[f64; 3], p2: &[f64; 3], p3: &[f64; 3]) -> TetOrientation {
    // Shewchuk's orient3d is det[pa−pd, pb−pd, pc−pd] = −det[p1−p0, p2−p0, p3−p0].
    let d = orient3d(c(p0), c(p1), c(p2), c(p3));
    if d < 0.0 {
        TetOrientation::Positive
    } else if d > 0.0 {
        TetOrientation::Negative
    } else {
        TetOrientation::Flat
    }
}

/// Exact side of `p` relative to the oriented triangle (a, b, c): `Positive`
/// when `p` is on the side its right-hand normal (b−a)×(c−a) points to.
#[inline]
pub fn side_of_oriented_plane(a: &[f64; 3], b: &[f64; 3], cc: &[f64; 3], p: &[f64; 3]) -> TetOrientation {
    tet_orientation(a, b, cc, p)
}

/// Signed volume of (p0, p1, p2, p3), positive for [`TetOrientation::Positive`]
/// tets. Plain floating point: for measuring, not for deciding.
#[inline]
pub fn signed_tet_volume(p0: &[f64; 3], p1: &[f64; 3], p2: &[f64; 3], p3: &[f64; 3]) -> f64 {
    let a = sub(p1, p0);
    let b = sub(p2, p0);
    let cc = sub(p3, p0);
    dot(&a, &cross(&b, &cc)) / 6.0
}

#[inline]
pub(crate) fn sub(a: &[f64; 3], b: &[f64; 3]) -> [f64; 3] {
    [a[0] - b[0], a[1] - b[1], a[2] - b[2]]
}

#[inline]
pub(crate) fn dot(a: &[f64; 3], b: &[f64; 3]) -> f64 {
    a[0] * b[0] + a[1] * b[1] + a[2] * b[2]
}

#[inline]
pub(crate) fn cross(a: &[f64; 3], b: &[f64; 3]) -> [f64; 3] {
    [a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0]]
}

#[inline]
pub(crate) fn dist2(a: &[f64; 3], b: &[f64; 3]) -> f64 {
    let d = sub(a, b);
    dot(&d, &d)
}

#[cfg(test)]
mod tests {
    use super::*;

    const O: [f64; 3] = [0.0, 0.0, 0.0];
    const X: [f64; 3] = [1.0, 0.0, 0.0];
    const Y: [f64; 3] = [0.0, 1.0, 0.0];
    const Z: [f64; 3] = [0.0, 0.0, 1.0];

    #[test]
    fn unit_tet_is_positive_and_volume_agrees() {
        assert_eq!(tet_orientation(&O, &X, &Y, &Z), TetOrientation::Positive);
        assert_eq!(tet_orientation(&O, &Y, &X, &Z), TetOrientation::Negative);
        assert!((signed_tet_volume(&O, &X, &Y, &Z) - 1.0 / 6.0).abs() < 1e-15);
    }

    #[test]
    fn flat_tet_is_exactly_flat_even_with_large_offsets() {
        // Coplanar points far from the origin: naive determinants give noise.
        let off = 1.0e6 + 0.1;
        let p = |x: f64, y: f64| [off + x, off + y, off + 0.3 * x + 0.7 * y];
        assert_eq!(tet_orientation(&p(0.0, 0.0), &p(1.0, 0.0), &p(0.0, 1.0), &p(1.0, 1.0)), TetOrientation::Flat);
    }

    #[test]
    fn sliver_keeps_its_sign() {
        let eps = 1e-300;
        assert_eq!(tet_orientation(&O, &X, &Y, &[0.3, 0.3, eps]), TetOrientation::Positive);
        assert_eq!(tet_orientation(&O, &X, &Y, &[0.3, 0.3, -eps]), TetOrientation::Negative);
    }
}
