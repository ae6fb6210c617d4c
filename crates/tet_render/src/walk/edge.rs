//! The walker's one geometric predicate: on which side of a projected mesh
//! edge the ray through a pixel centre passes.
//!
//! Every perspective ray starts at the eye, so the side of a ray and an
//! edge (the sign of their Plücker product) is the 2D orientation of the
//! edge's projected endpoints and the pixel centre; under parallel
//! projection it is the same 2D test. The f32 value is the cross product of
//! the endpoints translated to the pixel centre, which is exactly
//! antisymmetric ([`value`]), so the tets sharing an edge agree bit for bit
//! and a ray can neither leak between them nor cross both.
//!
//! The value is computed in f32 from the f32 vertex positions; where it is
//! too close to zero for its sign to be certain (a bound on the rounding of
//! the f64 positions to f32 and of the arithmetic, [`side`]), the sign is
//! decided by Shewchuk's exact `orient2d` on the f64 positions. An exact
//! zero (the centre on the edge's line) is broken by symbolic perturbation:
//! the pixel centre is moved by (−ε, ε²), which puts it left of an edge
//! pointing down (+y) or, when horizontal, right (+x) — the rasterizer's
//! tie rule ([`crate::project`]). So every decision equals the exact sign
//! of one fixed perturbed arrangement of the f64 projected points, and a
//! walk through it always finds an exit (see the module above).

use robust::{orient2d, Coord};
use wide::{f32x4, CmpGt, CmpLt};

/// A vertex of one view for the walker: pixel position and the two values
/// interpolated across faces. Perspective: `w` is 1/depth (affine in screen
/// space); parallel: `w` is the depth itself (then affine).
#[derive(Debug, Clone, Copy, Default, PartialEq)]
#[repr(C, align(16))]
pub struct WalkVertex {
    pub x_px: f32,
    pub y_px: f32,
    pub w: f32,
    pub scalar: f32,
}

/// Unit roundoff of f32 (round to nearest).
const U32: f32 = f32::EPSILON * 0.5;

/// The f32 edge function's error bound is `BOUND_REL·k·(s_a + s_b) +
/// BOUND_ABS·k²`, with s = |x − px| + |y − py| of each endpoint as computed
/// and k a bound on every |coordinate| of the view ([`side`]).
pub(crate) const BOUND_REL: f32 = 10.0 * U32;
pub(crate) const BOUND_ABS: f32 = 64.0 * U32 * U32;

/// Edge function of the directed edge a → b at pixel centre (px, py) in
/// f32: twice the signed area of (a, b, p), positive when p is left of
/// a → b (counter-clockwise in pixel coordinates), computed as the cross
/// product of the endpoints translated to the centre,
/// (a − p) × (b − p). Each translation rounds once per vertex, whatever the
/// edge, and `x·y′ − y·x′` is exactly antisymmetric in IEEE arithmetic
/// (no fused multiply-add), so a → b and b → a give the same number negated
/// (a zero is +0 both ways), in every tet that holds the edge (Woop, Benthin & Wald,
/// "Watertight ray/triangle intersection", 2013, translate the same way).
#[inline(always)]
pub fn value(a: &WalkVertex, b: &WalkVertex, px: f32, py: f32) -> f32 {
    let (ax, ay) = (a.x_px - px, a.y_px - py);
    let (bx, by) = (b.x_px - px, b.y_px - py);
    ax * by - ay * bx
}

/// Where the exact predicate finds a vertex's f64 pixel position (the one
/// its f32 position was rounded from).
pub trait PixelPositions {
    fn px(&self, vertex: u32) -> [f64; 2];
}

impl PixelPositions for [[f64; 2]] {
    #[inline]
    fn px(&self, vertex: u32) -> [f64; 2] {
        self[vertex as usize]
    }
}

/// Counters of how often the exact predicate decided.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub struct EdgeCounters {
    /// Edge tests whose f32 value was too close to zero to call.
    pub exact: u64,
}

/// Whether pixel centre (px, py) is left of a → b in exact arithmetic on
/// the f64 positions, ties broken by the perturbation (−ε, ε²) of the centre.
#[inline(never)]
pub fn exact_left(a: [f64; 2], b: [f64; 2], px: f64, py: f64) -> bool {
    let o = orient2d(Coord { x: a[0], y: a[1] }, Coord { x: b[0], y: b[1] }, Coord { x: px, y: py });
    if o != 0.0 {
        return o > 0.0;
    }
    // The exact sign of a difference of two f64 values is the sign of its
    // rounded value.
    let (dx, dy) = (b[0] - a[0], b[1] - a[1]);
    dy > 0.0 || (dy == 0.0 && dx > 0.0)
}

/// The exact side of the directed edge u → v, decided on the canonical
/// edge (smaller id first) so that the tie rule, which is antisymmetric
/// except for coincident endpoints, gives both directions opposite answers.
#[inline(never)]
fn exact_side<P: PixelPositions + ?Sized>(pos_f64: &P, iu: u32, iv: u32, px: f32, py: f32) -> bool {
    if iu < iv {
        exact_left(pos_f64.px(iu), pos_f64.px(iv), px as f64, py as f64)
    } else {
        !exact_left(pos_f64.px(iv), pos_f64.px(iu), px as f64, py as f64)
    }
}

/// The directed edge u → v (vertex ids iu, iv) at pixel centre (px, py):
/// its f32 value ([`value`]) and whether p passes left of it. `k_view`
/// bounds |x| and |y| of every projected vertex (f64 and f32) and pixel
/// centre of the view.
///
/// The value decides where it exceeds its error bound: rounding each f64
/// coordinate to f32 moves it by at most u·k, each translation rounds once
/// more (u·|x − px|), each product carries both into an error of at most
/// u·k·(|x| + |y′|) + 2u·|x·y′|, and the products and the difference round
/// once each; with |x·y′| + |y·x′| ≤ k·(s_a + s_b) the whole is at most
/// 5u·k·(s_a + s_b) plus terms in u²·k², doubled for margin
/// ([`BOUND_REL`], [`BOUND_ABS`]; ARCHITECTURE.md, "The walker"). Closer
/// to zero, Shewchuk's exact `orient2d` decides on the f64 positions, an
/// exact zero broken by the perturbation of [`exact_left`]. So every
/// decision equals the exact sign of one fixed perturbed arrangement.
#[inline(always)]
#[allow(clippy::too_many_arguments)]
pub fn side<P: PixelPositions + ?Sized>(
    verts: &[WalkVertex],
    pos_f64: &P,
    iu: u32,
    iv: u32,
    px: f32,
    py: f32,
    k_view: f32,
    counters: &mut EdgeCounters,
) -> (f32, bool) {
    let (a, b) = (&verts[iu as usize], &verts[iv as usize]);
    let (ax, ay) = (a.x_px - px, a.y_px - py);
    let (bx, by) = (b.x_px - px, b.y_px - py);
    let e = ax * by - ay * bx;
    let bound = BOUND_REL * k_view * ((ax.abs() + ay.abs()) + (bx.abs() + by.abs())) + BOUND_ABS * k_view * k_view;
    if e > bound {
        return (e, true);
    }
    if e < -bound {
        return (e, false);
    }
    counters.exact += 1;
    (e, exact_side(pos_f64, iu, iv, px, py))
}

/// The f32 value of the directed edge u → v ([`value`]: the same number,
/// negated, for v → u).
#[inline(always)]
pub fn directed_value(verts: &[WalkVertex], iu: u32, iv: u32, px: f32, py: f32) -> f32 {
    value(&verts[iu as usize], &verts[iv as usize], px, py)
}

/// The sides of the ray against the four edges v → u_k, u_k = `tet[k]`, of
/// one tet at once (lane `skip`, v itself, is meaningless): the f32 values
/// of v → u_k and, as bits, whether the centre passes left of each. Each
/// lane computes the operations of [`side`] in the same order, so values
/// and decisions are the same.
#[inline(always)]
#[allow(clippy::too_many_arguments)]
pub fn sides_from<P: PixelPositions + ?Sized>(
    verts: &[WalkVertex],
    pos_f64: &P,
    tet: [u32; 4],
    skip: usize,
    px: f32,
    py: f32,
    k_view: f32,
    counters: &mut EdgeCounters,
) -> ([f32; 4], u32) {
    let q = tet.map(|i| verts[i as usize]);
    let [xs, ys, _, _] = f32x4::transpose(q.map(|v| f32x4::from([v.x_px, v.y_px, v.w, v.scalar])));
    let (xr, yr) = (xs - f32x4::splat(px), ys - f32x4::splat(py));
    let (xa, ya) = (xr.to_array(), yr.to_array());
    let (vx, vy) = (xa[skip & 3], ya[skip & 3]);
    let e = f32x4::splat(vx) * yr - f32x4::splat(vy) * xr;
    let s = xr.abs() + yr.abs();
    let s_v = vx.abs() + vy.abs();
    let bound = f32x4::splat(BOUND_REL * k_view) * (f32x4::splat(s_v) + s) + f32x4::splat(BOUND_ABS * k_view * k_view);
    let pos = e.cmp_gt(bound).move_mask() as u32;
    let neg = e.cmp_lt(-bound).move_mask() as u32;
    let mut left = pos;
    let mut unsure = !(pos | neg) & 0xf & !(1 << skip);
    while unsure != 0 {
        let l = unsure.trailing_zeros() as usize;
        unsure &= unsure - 1;
        counters.exact += 1;
        if exact_side(pos_f64, tet[skip & 3], tet[l], px, py) {
            left |= 1 << l;
        }
    }
    (e.to_array(), left)
}

#[cfg(test)]
mod tests {
    use super::*;
    use proptest::prelude::*;

    fn vert(p: [f64; 2]) -> WalkVertex {
        WalkVertex { x_px: p[0] as f32, y_px: p[1] as f32, w: 1.0, scalar: 0.0 }
    }

    proptest! {
        /// The filtered sign equals the exact sign (with the tie rule) for
        /// any points, however close the centre is to the edge.
        #[test]
        fn filtered_sign_is_the_exact_sign(
            ax in -600.0f64..600.0, ay in -600.0f64..600.0,
            bx in -600.0f64..600.0, by in -600.0f64..600.0,
            t in 0.0f64..1.0, off in -1e-3f64..1e-3,
            ix in 0u32..512, iy in 0u32..512, near in any::<bool>(),
        ) {
            let a = [ax, ay];
            let b = [bx, by];
            // A pixel centre, or one moved onto (nearly) the edge's line by
            // choosing the edge through it.
            let (px, py) = (ix as f32 + 0.5, iy as f32 + 0.5);
            let b = if near {
                let d = [px as f64 - ax, py as f64 - ay];
                [ax + d[0] / t.max(1e-3) + off, ay + d[1] / t.max(1e-3)]
            } else { b };
            let pos = [a, b];
            let verts = [vert(a), vert(b)];
            // The view's bound on every coordinate.
            let k = [a[0], a[1], b[0], b[1], px as f64, py as f64].iter().fold(0.0f64, |m, v| m.max(v.abs())) as f32;
            let mut c = EdgeCounters::default();
            let (e_ab, left) = side(&verts, &pos[..], 0, 1, px, py, k, &mut c);
            prop_assert_eq!(left, exact_left(a, b, px as f64, py as f64));
            let (e_ba, right) = side(&verts, &pos[..], 1, 0, px, py, k, &mut c);
            prop_assert_eq!(right, !left);
            // Both directions: the same value negated (zero is +0 both ways).
            prop_assert_eq!(e_ab, -e_ba);
        }
    }

    proptest! {
        /// The four-lane form gives the scalar form's values and sides.
        #[test]
        fn sides_from_equals_side(
            c in proptest::collection::vec((-600.0f64..600.0, -600.0f64..600.0), 4),
            ids in proptest::sample::subsequence((0u32..8).collect::<Vec<_>>(), 4),
            skip in 0usize..4, ix in 0u32..512, iy in 0u32..512, snap in any::<bool>(),
        ) {
            let mut pos = [[0.0f64; 2]; 8];
            let (px, py) = (ix as f32 + 0.5, iy as f32 + 0.5);
            for (k, &i) in ids.iter().enumerate() {
                // Optionally put a vertex exactly on the pixel centre's row.
                pos[i as usize] = [c[k].0, if snap && k == 1 { py as f64 } else { c[k].1 }];
            }
            let verts: Vec<WalkVertex> = pos.iter().map(|&p| vert(p)).collect();
            let tet = [ids[0], ids[1], ids[2], ids[3]];
            let mut cnt = EdgeCounters::default();
            let (vals, bits) = sides_from(&verts, &pos[..], tet, skip, px, py, 601.0, &mut cnt);
            for k in 0..4 {
                if k == skip { continue; }
                let (val, left) = side(&verts, &pos[..], tet[skip], tet[k], px, py, 601.0, &mut cnt);
                prop_assert_eq!(vals[k].to_bits(), val.to_bits());
                prop_assert_eq!(bits >> k & 1 == 1, left);
                let (p, q) = (pos[tet[skip] as usize], pos[tet[k] as usize]);
                prop_assert_eq!(left, exact_left(p, q, px as f64, py as f64) || (p == q && tet[skip] > tet[k]));
            }
        }
    }

    proptest! {
        /// Coordinates that do not round to f32 exactly, vertices far off
        /// screen and centres within rounding of the edge: the filter
        /// never decides against the exact sign.
        #[test]
        fn filter_holds_for_rounded_and_far_vertices(
            ax in -5e4f64..5e4, ay in -5e4f64..5e4, dir in 0.0f64..std::f64::consts::TAU,
            len in 1e-3f64..1e4, off in -1e-2f64..1e-2, ix in 0u32..2048, iy in 0u32..2048,
        ) {
            // An edge from a through (nearly) the centre, continued by `len`.
            let (px, py) = (ix as f32 + 0.5, iy as f32 + 0.5);
            let a = [ax, ay];
            let d = [px as f64 - ax, py as f64 - ay];
            let n = (d[0] * d[0] + d[1] * d[1]).sqrt().max(1e-9);
            let b = [px as f64 + d[0] / n * len + off * dir.cos(), py as f64 + d[1] / n * len + off * dir.sin()];
            let pos = [a, b];
            let verts = [vert(a), vert(b)];
            let k = [a[0], a[1], b[0], b[1], px as f64, py as f64].iter().fold(0.0f64, |m, v| m.max(v.abs())) as f32;
            let mut c = EdgeCounters::default();
            let (_, left) = side(&verts, &pos[..], 0, 1, px, py, k, &mut c);
            prop_assert_eq!(left, exact_left(a, b, px as f64, py as f64));
        }
    }

    #[test]
    fn centre_on_a_shared_edge_goes_to_exactly_one_side() {
        // Vertical, horizontal and diagonal edges through the centre.
        for (a, b) in [([3.5, 0.0], [3.5, 9.0]), ([0.0, 2.5], [7.0, 2.5]), ([1.5, 1.5], [5.5, 5.5])] {
            let left_ab = exact_left(a, b, 3.5, 2.5);
            let left_ba = exact_left(b, a, 3.5, 2.5);
            if (a[1] - 2.5) * (b[0] - a[0]) == (b[1] - a[1]) * (a[0] - 3.5) {
                assert_ne!(left_ab, left_ba, "{a:?} {b:?}");
            }
        }
        // A zero-length edge: p is on neither side in both directions'
        // canonical form, so the reversed direction gives the other answer.
        let v = [vert([1.0, 1.0]), vert([1.0, 1.0])];
        let pos = [[1.0, 1.0], [1.0, 1.0]];
        let mut c = EdgeCounters::default();
        assert_ne!(
            side(&v, &pos[..], 0, 1, 1.5, 1.5, 8.0, &mut c).1,
            side(&v, &pos[..], 1, 0, 1.5, 1.5, 8.0, &mut c).1
        );
    }
}
