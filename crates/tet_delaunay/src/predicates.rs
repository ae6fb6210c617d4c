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

/// Shewchuk's relative error bounds of the floating-point stage of
/// `orient3d` and `insphere` (ε = 2^-53), as in `robust`.
const EPS: f64 = f64::EPSILON / 2.0;
const ORIENT_BOUND_A: f64 = (7.0 + 56.0 * EPS) * EPS;
const IN_SPHERE_BOUND_A: f64 = (16.0 + 224.0 * EPS) * EPS;

/// Static filters for the two predicates on one point set (CGAL-style):
/// the plain floating-point determinant decides whenever it exceeds a
/// fixed error bound valid for any points in the set's bounding box, and
/// only the rest go to the adaptive exact code.
///
/// Why the bound holds: Shewchuk bounds the error of his first stage by
/// `ε_A · permanent`, where the permanent is the same expression over
/// absolute values, evaluated in floating point. Every coordinate
/// difference is at most `m` (the largest box extent, rounded), and
/// rounding is monotone, so the permanent evaluated in floating point is at
/// most its value with every difference replaced by `m`: 6·m³ for the
/// orientation (3 terms of 2 products times a coordinate) and 72·m⁵ for the
/// in-sphere (4 lifts of at most 3·m², times 3 terms of 2 products times a
/// coordinate), each times (1 + ε)^k for the k ≤ 12 roundings on the way;
/// the factor 1 + 2^-30 covers those. The determinant is computed exactly
/// as `robust` computes it, so the bound applies to it unchanged. When the
/// bound would overflow or come near underflow (where the error analysis
/// fails) it is infinite, i.e. every decision goes to the exact code.
#[derive(Debug, Clone, Copy)]
pub(crate) struct StaticFilter {
    orient_bound: f64,
    in_sphere_bound: f64,
}

impl StaticFilter {
    pub(crate) fn new(points: &[[f64; 3]]) -> Self {
        let (lo, hi) = tet_mesh::stats::bounds(points);
        let m = (0..3).map(|a| hi[a] - lo[a]).fold(0.0f64, f64::max);
        let margin = 1.0 + 1.0 / (1u64 << 30) as f64;
        let bound = |b: f64| if b.is_finite() && b > 1e-250 { b } else { f64::INFINITY };
        StaticFilter {
            orient_bound: bound(ORIENT_BOUND_A * 6.0 * m * m * m * margin),
            in_sphere_bound: bound(IN_SPHERE_BOUND_A * 72.0 * m * m * m * m * m * margin),
        }
    }

    /// [`orient`], filtered: same sign.
    #[inline(always)]
    pub(crate) fn orient(&self, a: &[f64; 3], b: &[f64; 3], cc: &[f64; 3], d: &[f64; 3]) -> f64 {
        // robust's orient3d(a, b, cc, d), negated.
        let (adx, bdx, cdx) = (a[0] - d[0], b[0] - d[0], cc[0] - d[0]);
        let (ady, bdy, cdy) = (a[1] - d[1], b[1] - d[1], cc[1] - d[1]);
        let (adz, bdz, cdz) = (a[2] - d[2], b[2] - d[2], cc[2] - d[2]);
        let det = adz * (bdx * cdy - cdx * bdy) + bdz * (cdx * ady - adx * cdy) + cdz * (adx * bdy - bdx * ady);
        if det > self.orient_bound || -det > self.orient_bound {
            return -det;
        }
        orient(a, b, cc, d)
    }

    /// [`in_sphere_exact`], filtered: same sign.
    #[inline(always)]
    pub(crate) fn in_sphere(&self, a: &[f64; 3], b: &[f64; 3], cc: &[f64; 3], d: &[f64; 3], q: &[f64; 3]) -> f64 {
        // robust's insphere(a, b, cc, d, q), negated.
        let (aex, bex, cex, dex) = (a[0] - q[0], b[0] - q[0], cc[0] - q[0], d[0] - q[0]);
        let (aey, bey, cey, dey) = (a[1] - q[1], b[1] - q[1], cc[1] - q[1], d[1] - q[1]);
        let (aez, bez, cez, dez) = (a[2] - q[2], b[2] - q[2], cc[2] - q[2], d[2] - q[2]);
        let ab = aex * bey - bex * aey;
        let bc = bex * cey - cex * bey;
        let cd = cex * dey - dex * cey;
        let da = dex * aey - aex * dey;
        let ac = aex * cey - cex * aey;
        let bd = bex * dey - dex * bey;
        let abc = aez * bc - bez * ac + cez * ab;
        let bcd = bez * cd - cez * bd + dez * bc;
        let cda = cez * da + dez * ac + aez * cd;
        let dab = dez * ab + aez * bd + bez * da;
        let alift = aex * aex + aey * aey + aez * aez;
        let blift = bex * bex + bey * bey + bez * bez;
        let clift = cex * cex + cey * cey + cez * cez;
        let dlift = dex * dex + dey * dey + dez * dez;
        let det = (dlift * abc - clift * dab) + (blift * cda - alift * bcd);
        if det > self.in_sphere_bound || -det > self.in_sphere_bound {
            return -det;
        }
        in_sphere_exact(a, b, cc, d, q)
    }
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

    fn sign(x: f64) -> i8 {
        (x > 0.0) as i8 - (x < 0.0) as i8
    }

    #[test]
    fn static_filter_agrees_with_the_exact_predicates() {
        // Near-degenerate configurations (tiny offsets from a plane and a
        // sphere) where the filter must defer, and random ones where it
        // decides.
        let mut rng = crate::sort::SplitMix64(11);
        let mut pts: Vec<[f64; 3]> = (0..64).map(|_| [rng.next_f64(), rng.next_f64(), rng.next_f64()]).collect();
        for k in 0..32 {
            let e = (k as f64 - 16.0) * f64::EPSILON;
            pts.push([0.5 + e, 0.5, 0.0]);
            pts.push([1.0, 1.0, 1.0 + e]);
        }
        pts.extend_from_slice(&[O, X, Y, Z]);
        let f = StaticFilter::new(&pts);
        let n = pts.len();
        for _ in 0..20_000 {
            let i = [0; 5].map(|_| rng.below(n));
            let [a, b, c, d, q] = i.map(|k| &pts[k]);
            assert_eq!(sign(f.orient(a, b, c, d)), sign(orient(a, b, c, d)));
            assert_eq!(sign(f.in_sphere(a, b, c, d, q)), sign(in_sphere_exact(a, b, c, d, q)));
        }
        for e in [f64::EPSILON, -f64::EPSILON, 0.0] {
            let w = [1.0, 1.0, 1.0 + e];
            assert_eq!(sign(f.in_sphere(&O, &X, &Y, &Z, &w)), sign(in_sphere_exact(&O, &X, &Y, &Z, &w)));
            let p = [0.5, 0.5, e];
            assert_eq!(sign(f.orient(&O, &X, &Y, &p)), sign(orient(&O, &X, &Y, &p)));
        }
    }
}
