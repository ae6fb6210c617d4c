//! The walker's one geometric predicate: on which side of a projected mesh
//! edge the ray through a pixel centre passes.
//!
//! Every perspective ray starts at the eye, so the side of a ray and an
//! edge (the sign of their Plücker product) is the 2D orientation of the
//! edge's projected endpoints and the pixel centre; under parallel
//! projection it is the same 2D test. The predicate is evaluated per edge
//! in one canonical vertex order (smaller vertex id first) and negated for
//! the other direction, so the tets sharing an edge agree bit for bit and a
//! ray can neither leak between them nor cross both.
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
use wide::{f32x4, i32x4, CmpGt, CmpLt};

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

/// Edge function of the directed edge a → b at pixel centre (px, py) in
/// f32: twice the signed area of (a, b, p), positive when p is left of
/// a → b (counter-clockwise in pixel coordinates). Only for barycentric
/// weights; signs come from [`side`].
#[inline(always)]
pub fn value(a: &WalkVertex, b: &WalkVertex, px: f32, py: f32) -> f32 {
    (b.x_px - a.x_px) * (py - a.y_px) - (b.y_px - a.y_px) * (px - a.x_px)
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

/// The canonical edge (a, b) with id(a) < id(b): its f32 value at p and
/// whether p passes left of a → b (ties by the perturbation above).
/// `pos_f64` holds the f64 pixel positions the f32 ones were rounded from;
/// `p_max` bounds |px| and |py|.
#[inline(always)]
#[allow(clippy::too_many_arguments)]
fn canonical<P: PixelPositions + ?Sized>(
    a: &WalkVertex,
    b: &WalkVertex,
    ia: u32,
    ib: u32,
    pos_f64: &P,
    px: f32,
    py: f32,
    p_max: f32,
    counters: &mut EdgeCounters,
) -> (f32, bool) {
    let f1 = b.x_px - a.x_px;
    let g1 = py - a.y_px;
    let f2 = b.y_px - a.y_px;
    let g2 = px - a.x_px;
    let p1 = f1 * g1;
    let p2 = f2 * g2;
    let e = p1 - p2;
    // |e − e_exact| for the f64 inputs: rounding each input to f32 moves it
    // by at most u·k, each difference carries that into its product, and
    // the two products and the difference round once more. Doubled for
    // margin (derivation in ARCHITECTURE.md, "The walker").
    let k = a.x_px.abs().max(a.y_px.abs()).max(b.x_px.abs()).max(b.y_px.abs()).max(p_max);
    let bound = 2.0 * U32 * (k * (f1.abs() + f2.abs() + 2.0 * (g1.abs() + g2.abs())) + 4.0 * (p1.abs() + p2.abs()))
        + 16.0 * U32 * U32 * k * k;
    if e > bound {
        return (e, true);
    }
    if e < -bound {
        return (e, false);
    }
    counters.exact += 1;
    (e, exact_left(pos_f64.px(ia), pos_f64.px(ib), px as f64, py as f64))
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

/// The directed edge u → v (vertex ids iu, iv) at pixel centre (px, py):
/// its f32 value (for weights) and whether p passes left of it, decided on
/// the canonical edge so both directions and every tet agree.
#[inline(always)]
#[allow(clippy::too_many_arguments)]
pub fn side<P: PixelPositions + ?Sized>(
    verts: &[WalkVertex],
    pos_f64: &P,
    iu: u32,
    iv: u32,
    px: f32,
    py: f32,
    p_max: f32,
    counters: &mut EdgeCounters,
) -> (f32, bool) {
    if iu < iv {
        canonical(&verts[iu as usize], &verts[iv as usize], iu, iv, pos_f64, px, py, p_max, counters)
    } else {
        let (e, left) = canonical(&verts[iv as usize], &verts[iu as usize], iv, iu, pos_f64, px, py, p_max, counters);
        (-e, !left)
    }
}

/// The f32 value of the directed edge u → v, computed on the canonical edge
/// (so it is the same number, negated, for v → u).
#[inline(always)]
pub fn directed_value(verts: &[WalkVertex], iu: u32, iv: u32, px: f32, py: f32) -> f32 {
    if iu < iv {
        value(&verts[iu as usize], &verts[iv as usize], px, py)
    } else {
        -value(&verts[iv as usize], &verts[iu as usize], px, py)
    }
}

/// `LANE_MASKS[bits]`: all-ones in the lanes whose bit is set.
const LANE_MASKS: [[u32; 4]; 16] = {
    let mut m = [[0u32; 4]; 16];
    let mut b = 0;
    while b < 16 {
        let mut l = 0;
        while l < 4 {
            if b >> l & 1 == 1 {
                m[b][l] = u32::MAX;
            }
            l += 1;
        }
        b += 1;
    }
    m
};

/// Bit k set where `ids[k] < v` (unsigned), in four lanes: flipping the
/// top bit makes the signed comparison the unsigned one.
#[inline(always)]
fn below_mask(ids: [u32; 4], v: u32) -> usize {
    let top = i32x4::splat(i32::MIN);
    let lanes = i32x4::from(ids.map(|x| x as i32)) ^ top;
    lanes.cmp_lt(i32x4::splat(v as i32) ^ top).move_mask() as usize
}

/// The sides of the ray against the four edges v → u_k, u_k = `tet[k]`, of
/// one tet at once (lane `skip`, v itself, is meaningless): the f32 values
/// of v → u_k and, as bits, whether the centre passes left of each. Each
/// lane computes the same canonical-order operations as [`side`], so the
/// values are the same numbers; `k_view` bounds |x| and |y| of every
/// projected vertex and pixel centre of the view.
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
    let v = tet[skip];
    // Four separate loads (an array indexed by `skip` would go through the
    // stack and stall store forwarding).
    let vv = verts[v as usize];
    let (q0, q1, q2, q3) =
        (verts[tet[0] as usize], verts[tet[1] as usize], verts[tet[2] as usize], verts[tet[3] as usize]);
    let ux = f32x4::from([q0.x_px, q1.x_px, q2.x_px, q3.x_px]);
    let uy = f32x4::from([q0.y_px, q1.y_px, q2.y_px, q3.y_px]);
    let (vx, vy) = (f32x4::splat(vv.x_px), f32x4::splat(vv.y_px));
    // Lanes whose canonical edge is u → v (u has the smaller id), as bits
    // and as a lane mask.
    let flip_bits = below_mask(tet, v);
    let swap = f32x4::from(LANE_MASKS[flip_bits].map(f32::from_bits));
    let (ax, ay) = (swap.blend(ux, vx), swap.blend(uy, vy));
    let (bx, by) = (swap.blend(vx, ux), swap.blend(vy, uy));
    let (pxv, pyv) = (f32x4::splat(px), f32x4::splat(py));
    let f1 = bx - ax;
    let g1 = pyv - ay;
    let f2 = by - ay;
    let g2 = pxv - ax;
    let p1 = f1 * g1;
    let p2 = f2 * g2;
    let e = p1 - p2;
    // The bound of `canonical` with the view's bound on every coordinate.
    // The bound of `canonical` loosened to one product: |g| ≤ 2k, so
    // 4(|p1| + |p2|) ≤ 8k(|f1| + |f2|) and the whole is at most
    // 18u·k·(|f1| + |f2| + |g1| + |g2|) (+ the u² term). A few more
    // exact decisions (still a fraction of a per mille) for fewer operations.
    let bound = f32x4::splat(18.0 * U32 * k_view) * ((f1.abs() + f2.abs()) + (g1.abs() + g2.abs()))
        + f32x4::splat(16.0 * U32 * U32 * k_view * k_view);
    let pos = e.cmp_gt(bound).move_mask() as u32;
    let neg = e.cmp_lt(-bound).move_mask() as u32;
    let mut left_canon = pos;
    let mut unsure = !(pos | neg) & 0xf & !(1 << skip);
    while unsure != 0 {
        let l = unsure.trailing_zeros() as usize;
        unsure &= unsure - 1;
        counters.exact += 1;
        let (ia, ib) = if flip_bits >> l & 1 == 1 { (tet[l], v) } else { (v, tet[l]) };
        if exact_left(pos_f64.px(ia), pos_f64.px(ib), px as f64, py as f64) {
            left_canon |= 1 << l;
        }
    }
    // v → u is the canonical edge negated: flip the sign bit.
    let vals = (e ^ (swap & f32x4::splat(-0.0))).to_array();
    (vals, (left_canon ^ flip_bits as u32) & 0xf)
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
            let mut c = EdgeCounters::default();
            let (_, left) = side(&verts, &pos[..], 0, 1, px, py, 512.0, &mut c);
            prop_assert_eq!(left, exact_left(a, b, px as f64, py as f64));
            let (_, right) = side(&verts, &pos[..], 1, 0, px, py, 512.0, &mut c);
            prop_assert_eq!(right, !left);
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
                let (val, left) = side(&verts, &pos[..], tet[skip], tet[k], px, py, 512.0, &mut cnt);
                prop_assert_eq!(vals[k].to_bits(), val.to_bits());
                prop_assert_eq!(bits >> k & 1 == 1, left);
            }
        }
    }

    #[test]
    fn below_mask_is_the_unsigned_comparison() {
        let big = [0u32, 1, 1 << 31, (1 << 31) - 1, u32::MAX - 1, u32::MAX, 12345, 3 << 30];
        for &v in &big {
            for a in big.chunks_exact(4).chain([&[u32::MAX, 0, 1 << 31, 7][..]]) {
                let ids = [a[0], a[1], a[2], a[3]];
                let want = (0..4).fold(0, |m, k| m | usize::from(ids[k] < v) << k);
                assert_eq!(below_mask(ids, v), want, "{ids:?} < {v}");
            }
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
