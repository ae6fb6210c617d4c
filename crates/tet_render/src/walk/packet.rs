//! The packet walk: eight rays advance one tet a step together, one ray a
//! lane of 256-bit AVX2 vectors (x86-64, chosen at run time with
//! `is_x86_feature_detected!`). The second place in this crate with
//! `unsafe` code: the intrinsics.
//!
//! A step is [`WalkCtx::step`]'s operations, lane by lane, in the same
//! order and precision (no fused multiply-add, the same sums in the same
//! association): the tet records and vertices of the eight lanes are loaded
//! and transposed, the ray's sides against the three edges from the vertex
//! opposite the entry face are computed with [`edge::side`]'s value and
//! error bound, the exit face is read from [`EXIT_BY_SIDES`] by a byte
//! shuffle, and the exit point follows [`ray::face_point`]. A lane the
//! vector step cannot decide — an edge value within its error bound (the
//! exact predicate decides), no exit, the step bound — takes the scalar
//! step instead ([`PacketTile::scalar_step`]), as does everything that is
//! not a step: starting rays and runs, finishing rays. So every segment is
//! the scalar walker's, bit for bit.
//!
//! Segments go into one batch a packet (each tagged with its lane), shaded
//! in one call when the next step might not fit and when a ray finishes,
//! and composited per lane in step order as [`WalkCtx::flush`] does; a ray
//! stops once α reaches [`RasterOptions::opaque_alpha`], noticed at the
//! packet's next shading. The colours are the scalar walker's; a ray may
//! walk a few tets more or fewer past the point where it turned opaque, so
//! crossings and runs (not fragments) may differ (`tests/walk.rs`).
//!
//! Views whose near plane cuts the mesh (the eye inside it) step the same
//! way in homogeneous coordinates ([`hom`]): each edge value in f64 lanes,
//! four to a vector, from the vertex with the smaller id, with
//! `hom::canonical`'s error bound; the exit point is the weights
//! normalised one by one ([`Homogeneous`]'s face point) and a segment
//! entered before the near plane is dropped or cut there, as
//! [`WalkCtx::step`] does.
//!
//! Adaptive sampling hands the packets each level's rays as one list
//! ([`adaptive_fill`]). What the packet walk does not do — lighting and
//! bivariate methods (both read the exit points' weights) — and CPUs
//! without AVX2 take the scalar walk, its portable twin.
#![allow(unsafe_code)]

use super::*;
use std::arch::x86_64::*;

/// Rays in a packet: the lanes of a 256-bit vector of 32-bit values.
const LANES: usize = 8;

/// Packets a tile walks at once, one step each in turn: the walks are
/// chains of dependent loads, and independent chains overlap their cache
/// misses (`crates/tetview/results/walker.md`, the packet prototype: 1 to
/// 8 packets).
const PACKETS: usize = 8;

/// Whether this CPU runs the packet walk.
pub(crate) fn available() -> bool {
    is_x86_feature_detected!("avx2")
}

/// The vector state of a packet's lanes (32-byte aligned rows, one value a
/// lane). Idle lanes keep `t = 0`, `f_in = 0`: the step loads a valid
/// record for them and discards it.
#[repr(C, align(32))]
#[derive(Clone, Copy, Default)]
struct Lanes {
    t: [u32; LANES],
    f_in: [u32; LANES],
    fx: [f32; LANES],
    fy: [f32; LANES],
    len_per_depth: [f32; LANES],
    depth_in: [f32; LANES],
    scalar_in: [f32; LANES],
    steps_left: [u32; LANES],
    crossings: [u32; LANES],
    /// −1: the lane is in a run (the vector step advances it); 0: idle.
    active: [i32; LANES],
}

/// A lane's ray, the part the vector step does not touch.
#[derive(Clone, Copy, Default)]
struct LaneRay {
    has_ray: bool,
    in_run: bool,
    /// Pixel index in the tile.
    pix: u32,
    /// Its entries left: `entries[next_entry..end]`.
    next_entry: usize,
    end: usize,
}

/// A packet's segments waiting for the shader, each with its lane, and
/// the lanes' colours.
struct PacketShade {
    segs: SegmentBatch,
    lane_of: [u8; BATCH],
    rgba: [Rgba32; BATCH],
    acc: [[f32; 4]; LANES],
    /// Lanes whose ray turned opaque at the last shading and still walks.
    opaque: u32,
}

struct Packet {
    lanes: Lanes,
    rays: [LaneRay; LANES],
    shade: PacketShade,
}

impl Packet {
    fn new() -> Packet {
        Packet {
            lanes: Lanes::default(),
            rays: [LaneRay::default(); LANES],
            shade: PacketShade {
                segs: SegmentBatch::default(),
                lane_of: [0; BATCH],
                rgba: [[0.0; 4]; BATCH],
                acc: [[0.0; 4]; LANES],
                opaque: 0,
            },
        }
    }
}

/// What the packet walk reads of a view's geometry beyond
/// [`RayGeometry`]: its vertices as rows of four floats (x, y, w, scalar:
/// [`WalkVertex`] or [`HomVertex`], both 16 bytes in that order).
pub(crate) trait PacketGeometry: RayGeometry {
    /// The view's vertices, row `i` at floats `4i..4i + 4` (one row a
    /// vertex of the mesh).
    fn vertex_rows(&self) -> *const f32;
    /// [`Projected::k_view`] (unused by the homogeneous geometry).
    fn k_view(&self) -> f32;
    /// A parallel projection ([`Projected::parallel`]; homogeneous views
    /// are perspective).
    fn parallel(&self) -> bool;
}

impl PacketGeometry for Projected<'_> {
    fn vertex_rows(&self) -> *const f32 {
        self.verts.as_ptr().cast::<f32>()
    }
    fn k_view(&self) -> f32 {
        self.k_view
    }
    fn parallel(&self) -> bool {
        self.parallel
    }
}

impl PacketGeometry for Homogeneous<'_> {
    fn vertex_rows(&self) -> *const f32 {
        self.verts.as_ptr().cast::<f32>()
    }
    fn k_view(&self) -> f32 {
        0.0
    }
    fn parallel(&self) -> bool {
        false
    }
}

/// One tile's packet walk.
struct PacketTile<'c, 'a, G: PacketGeometry> {
    c: &'c WalkCtx<'a>,
    g: &'c G,
    entries: Vec<(u32, f32, u32)>,
    /// The tile's rays: (pixel, first entry, end).
    rays: Vec<(u32, usize, usize)>,
    next_ray: usize,
    acc: Vec<[f32; 4]>,
    st: WalkStats,
    counters: EdgeCounters,
}

/// Walks tile `ti` by packets: what [`WalkCtx::tile_with`] gives for a
/// projected view without gradients, bit for bit.
///
/// # Panics
/// Where [`available`] is false (callers check).
pub(crate) fn tile<G: PacketGeometry>(c: &WalkCtx, g: &G, ti: usize) -> (Vec<[f32; 4]>, WalkStats) {
    assert!(available(), "the packet walk needs AVX2");
    let (rect, stride) = c.view.tile_rect(ti);
    let mut st = WalkStats::default();
    let mut counters = EdgeCounters::default();
    let entries = c.entries(g, ti, rect, stride, &mut counters, &mut st);
    let rays = rays_of(&entries);
    let mut t = PacketTile {
        c,
        g,
        entries,
        rays,
        next_ray: 0,
        acc: vec![[0.0f32; 4]; stride * (rect[3] - rect[1] + 1) as usize],
        st,
        counters,
    };
    let mut packets: Vec<Packet> = (0..PACKETS).map(|_| Packet::new()).collect();
    let (x0, y0) = (rect[0], rect[1]);
    // Walks `t.rays` from `t.next_ray` on; every lane idle after.
    let walk_all = |t: &mut PacketTile<G>, packets: &mut [Packet]| {
        for p in packets.iter_mut() {
            for k in 0..LANES {
                t.service(p, k, x0, y0, stride);
            }
        }
        // SAFETY: `available()` (asserted above) checked that the CPU has
        // AVX2, the only target feature `walk` enables.
        unsafe { t.walk(packets, x0, y0, stride) };
    };
    if let Some(tol) = c.adaptive {
        // Each level's rays in one list through the packets.
        let rays = std::mem::take(&mut t.rays);
        let mut acc = std::mem::take(&mut t.acc);
        let rows = acc.len() / stride;
        let mut interpolated = WalkStats::default();
        adaptive_fill(&rays, stride, rows, tol, &mut acc, &mut interpolated, &mut |list, acc, _| {
            t.rays.clear();
            t.rays.extend_from_slice(list);
            t.next_ray = 0;
            std::mem::swap(&mut t.acc, acc);
            walk_all(&mut t, &mut packets);
            std::mem::swap(&mut t.acc, acc);
        });
        t.acc = acc;
        t.st.rays_interpolated += interpolated.rays_interpolated;
    } else {
        walk_all(&mut t, &mut packets);
    }
    t.st.exact_tests = t.counters.exact;
    t.st.packet_rays = t.st.rays;
    (t.acc, t.st)
}

/// Eight 16-byte (a, b, c, d) rows, one a lane, as four vectors (a of
/// every lane, b, c, d).
///
/// # Safety
/// AVX must be available and each pointer must address 16 readable bytes.
#[target_feature(enable = "avx2")]
#[inline]
unsafe fn transpose_rows(p: [*const f32; LANES]) -> [__m256; 4] {
    // SAFETY: each pointer addresses 16 readable bytes (caller).
    let row = |a: *const f32, b: *const f32| unsafe {
        _mm256_insertf128_ps::<1>(_mm256_castps128_ps256(_mm_loadu_ps(a)), _mm_loadu_ps(b))
    };
    let (r0, r1, r2, r3) = (row(p[0], p[4]), row(p[1], p[5]), row(p[2], p[6]), row(p[3], p[7]));
    let (t0, t1) = (_mm256_unpacklo_ps(r0, r1), _mm256_unpackhi_ps(r0, r1));
    let (t2, t3) = (_mm256_unpacklo_ps(r2, r3), _mm256_unpackhi_ps(r2, r3));
    [
        _mm256_shuffle_ps::<0x44>(t0, t2),
        _mm256_shuffle_ps::<0xEE>(t0, t2),
        _mm256_shuffle_ps::<0x44>(t1, t3),
        _mm256_shuffle_ps::<0xEE>(t1, t3),
    ]
}

/// Per lane, `a[k]` where the lane's index is k (masks `m[k]`: index == k,
/// k = 1, 2, 3; index 0 otherwise).
#[target_feature(enable = "avx2")]
#[inline]
fn select_ps(a: [__m256; 4], m: [__m256i; 3]) -> __m256 {
    let r = _mm256_blendv_ps(a[0], a[1], _mm256_castsi256_ps(m[0]));
    let r = _mm256_blendv_ps(r, a[2], _mm256_castsi256_ps(m[1]));
    _mm256_blendv_ps(r, a[3], _mm256_castsi256_ps(m[2]))
}

/// [`select_ps`] for 32-bit integers.
#[target_feature(enable = "avx2")]
#[inline]
fn select_epi32(a: [__m256i; 4], m: [__m256i; 3]) -> __m256i {
    let r = _mm256_blendv_epi8(a[0], a[1], m[0]);
    let r = _mm256_blendv_epi8(r, a[2], m[1]);
    _mm256_blendv_epi8(r, a[3], m[2])
}

/// The masks of [`select_ps`] for index vector `idx` (values 0 to 3).
#[target_feature(enable = "avx2")]
#[inline]
fn index_masks(idx: __m256i) -> [__m256i; 3] {
    [1, 2, 3].map(|k| _mm256_cmpeq_epi32(idx, _mm256_set1_epi32(k)))
}

/// Lanes 0–3 and 4–7 of `v` as f64 (exact).
#[target_feature(enable = "avx2")]
#[inline]
fn f64_halves(v: __m256) -> [__m256d; 2] {
    [_mm256_cvtps_pd(_mm256_castps256_ps128(v)), _mm256_cvtps_pd(_mm256_extractf128_ps::<1>(v))]
}

/// Two halves of f64 lanes rounded to f32 (to nearest, as `as f32`).
#[target_feature(enable = "avx2")]
#[inline]
fn f32_of_halves(v: [__m256d; 2]) -> __m256 {
    _mm256_set_m128(_mm256_cvtpd_ps(v[1]), _mm256_cvtpd_ps(v[0]))
}

/// Eight 32-bit lane masks from two halves' 64-bit masks.
#[target_feature(enable = "avx2")]
#[inline]
fn mask_of_halves(m: [__m256d; 2]) -> __m256i {
    let low_dwords = _mm256_setr_epi32(0, 2, 4, 6, 1, 3, 5, 7);
    let lo = _mm256_permutevar8x32_epi32(_mm256_castpd_si256(m[0]), low_dwords);
    let hi = _mm256_permutevar8x32_epi32(_mm256_castpd_si256(m[1]), low_dwords);
    _mm256_inserti128_si256::<1>(lo, _mm256_castsi256_si128(hi))
}

/// Two halves' 64-bit masks from eight 32-bit lane masks.
#[target_feature(enable = "avx2")]
#[inline]
fn halves_of_mask(m: __m256i) -> [__m256d; 2] {
    [
        _mm256_castsi256_pd(_mm256_cvtepi32_epi64(_mm256_castsi256_si128(m))),
        _mm256_castsi256_pd(_mm256_cvtepi32_epi64(_mm256_extracti128_si256::<1>(m))),
    ]
}

/// `hom::canonical`'s edge value and error bound for the edge a → b, each
/// (X, Y, W) in f64 lanes, at the pixel centre (px, py): the same
/// products, differences and sums in the same association.
#[target_feature(enable = "avx2")]
#[inline]
fn hom_edge(a: [__m256d; 3], b: [__m256d; 3], px: __m256d, py: __m256d) -> (__m256d, __m256d) {
    let ([ax, ay, aw], [bx, by, bw]) = (a, b);
    let (c1, c2) = (_mm256_mul_pd(ay, bw), _mm256_mul_pd(aw, by));
    let (c3, c4) = (_mm256_mul_pd(aw, bx), _mm256_mul_pd(ax, bw));
    let (c5, c6) = (_mm256_mul_pd(ax, by), _mm256_mul_pd(ay, bx));
    let (cx, cy, cz) = (_mm256_sub_pd(c1, c2), _mm256_sub_pd(c3, c4), _mm256_sub_pd(c5, c6));
    let e = _mm256_add_pd(_mm256_add_pd(_mm256_mul_pd(cx, px), _mm256_mul_pd(cy, py)), cz);
    let sign = _mm256_set1_pd(-0.0);
    let abs = |v: __m256d| _mm256_andnot_pd(sign, v);
    let perm = _mm256_add_pd(
        _mm256_add_pd(
            _mm256_add_pd(
                _mm256_mul_pd(_mm256_add_pd(abs(c1), abs(c2)), abs(px)),
                _mm256_mul_pd(_mm256_add_pd(abs(c3), abs(c4)), abs(py)),
            ),
            abs(c5),
        ),
        abs(c6),
    );
    (e, _mm256_mul_pd(_mm256_set1_pd(hom::EDGE_BOUND), perm))
}

/// Per lane, the directed edge a → b's value in canonical order
/// (`hom::side`): computed from the vertex with the smaller id, negated
/// where the order was swapped; with its error bound, f64 halves.
#[target_feature(enable = "avx2")]
#[inline]
fn hom_directed(
    a: [__m256; 3],
    b: [__m256; 3],
    id_a: __m256i,
    id_b: __m256i,
    px: [__m256d; 2],
    py: [__m256d; 2],
) -> ([__m256d; 2], [__m256d; 2]) {
    let bias = _mm256_set1_epi32(i32::MIN);
    let swap = _mm256_cmpgt_epi32(_mm256_xor_si256(id_a, bias), _mm256_xor_si256(id_b, bias));
    let swap_ps = _mm256_castsi256_ps(swap);
    let lo = [0, 1, 2].map(|c| f64_halves(_mm256_blendv_ps(a[c], b[c], swap_ps)));
    let hi = [0, 1, 2].map(|c| f64_halves(_mm256_blendv_ps(b[c], a[c], swap_ps)));
    let negate = halves_of_mask(swap).map(|m| _mm256_and_pd(m, _mm256_set1_pd(-0.0)));
    let mut e = [_mm256_setzero_pd(); 2];
    let mut bound = [_mm256_setzero_pd(); 2];
    for h in 0..2 {
        let (v, b) = hom_edge([lo[0][h], lo[1][h], lo[2][h]], [hi[0][h], hi[1][h], hi[2][h]], px[h], py[h]);
        (e[h], bound[h]) = (_mm256_xor_pd(v, negate[h]), b);
    }
    (e, bound)
}

/// `hom::sides_from` in vector lanes: the directed values v → u_k (f32,
/// v = tet[f_in]), the edges each lane passes left of (bit k) and the
/// active lanes an edge test cannot call (the exact predicate decides
/// those, in the scalar step).
#[target_feature(enable = "avx2")]
#[inline]
#[allow(clippy::too_many_arguments)]
fn hom_sides(
    xv: &[__m256; 4],
    yv: &[__m256; 4],
    wv: &[__m256; 4],
    ids: &[__m256i; 4],
    m_in: [__m256i; 3],
    skip: [__m256i; 4],
    act: __m256i,
    fx: __m256,
    fy: __m256,
) -> ([__m256; 4], __m256i, __m256i) {
    let v = [select_ps(*xv, m_in), select_ps(*yv, m_in), select_ps(*wv, m_in)];
    let v_id = select_epi32(*ids, m_in);
    let (px, py) = (f64_halves(fx), f64_halves(fy));
    let sign = _mm256_set1_pd(-0.0);
    let mut e = [_mm256_setzero_ps(); 4];
    let mut left = _mm256_setzero_si256();
    let mut unsure = _mm256_setzero_si256();
    for k in 0..4 {
        let (val, bound) = hom_directed(v, [xv[k], yv[k], wv[k]], v_id, ids[k], px, py);
        let pos = mask_of_halves([0, 1].map(|h| _mm256_cmp_pd::<_CMP_GT_OQ>(val[h], bound[h])));
        let neg = mask_of_halves([0, 1].map(|h| _mm256_cmp_pd::<_CMP_LT_OQ>(val[h], _mm256_xor_pd(bound[h], sign))));
        e[k] = f32_of_halves(val);
        left = _mm256_or_si256(left, _mm256_and_si256(pos, _mm256_set1_epi32(1 << k)));
        let decided = _mm256_or_si256(_mm256_or_si256(pos, neg), skip[k]);
        unsure = _mm256_or_si256(unsure, _mm256_andnot_si256(decided, act));
    }
    (e, left, unsure)
}

/// `hom::directed_value` of the edge x → y in vector lanes (f32).
#[target_feature(enable = "avx2")]
#[inline]
fn hom_value(x: [__m256; 3], y: [__m256; 3], id_x: __m256i, id_y: __m256i, fx: __m256, fy: __m256) -> __m256 {
    f32_of_halves(hom_directed(x, y, id_x, id_y, f64_halves(fx), f64_halves(fy)).0)
}

/// The lanes set in a mask vector, as bits.
#[target_feature(enable = "avx2")]
#[inline]
fn bits_of(m: __m256i) -> u32 {
    _mm256_movemask_ps(_mm256_castsi256_ps(m)) as u32
}

impl<G: PacketGeometry> PacketTile<'_, '_, G> {
    /// The packets stepped in turn until every ray of the tile is done.
    ///
    /// # Safety
    /// AVX2 must be available.
    #[target_feature(enable = "avx2")]
    unsafe fn walk(&mut self, packets: &mut [Packet], x0: u32, y0: u32, stride: usize) {
        let tets = &self.c.mesh.tets[..];
        let verts_ptr = self.g.vertex_rows();
        let near = _mm256_set1_ps(self.g.near_depth());
        let orient_back = if FRONT_IS_LEFT { -1.0f32 } else { 1.0 };
        let k_view = self.g.k_view();
        let parallel = self.g.parallel();
        let c_rel = _mm256_set1_ps(edge::BOUND_REL * k_view);
        let c_abs = _mm256_set1_ps(edge::BOUND_ABS * k_view * k_view);
        let sign = _mm256_set1_ps(-0.0);
        let zero = _mm256_setzero_ps();
        let one = _mm256_set1_ps(1.0);
        let third = _mm256_set1_ps(1.0f32 / 3.0f32);
        let three = _mm256_set1_ps(3.0);
        let orient = _mm256_set1_ps(orient_back);
        let three_i = _mm256_set1_epi32(3);
        // EXIT_BY_SIDES[k] as a 16-byte table in both halves, indexed by
        // the low byte of each lane (the other bytes' index has its top bit
        // set: they read 0).
        let exit_rows: [__m256i; 4] = std::array::from_fn(|k| {
            // SAFETY: a row of 16 bytes.
            let row = unsafe { _mm_loadu_si128(EXIT_BY_SIDES[k].as_ptr().cast()) };
            _mm256_set_m128i(row, row)
        });
        let byte_index_high = _mm256_set1_epi32(0x8080_8000u32 as i32);
        let no_exit = _mm256_set1_epi32(NO_EXIT as i32);
        // Links ≥ LINK_BROKEN (unsigned): compared with the sign bit flipped.
        let bias = _mm256_set1_epi32(i32::MIN);
        let broken_biased = _mm256_set1_epi32((LINK_BROKEN - 1) as i32 ^ i32::MIN);
        let tets_ptr = tets.as_ptr().cast::<f32>();
        let visible = self.c.visible;
        let prefetch = self.c.prefetch;
        loop {
            let mut any = false;
            for p in packets.iter_mut() {
                // Room for one step's segments; lanes turned opaque stop.
                if p.shade.segs.len + LANES > BATCH {
                    p.shade.opaque |= self.shade(&mut p.shade);
                }
                while p.shade.opaque != 0 {
                    let k = p.shade.opaque.trailing_zeros() as usize;
                    p.shade.opaque &= p.shade.opaque - 1;
                    if p.rays[k].has_ray {
                        p.rays[k].in_run = false;
                        p.rays[k].next_entry = p.rays[k].end;
                        self.service(p, k, x0, y0, stride);
                    }
                }
                let l = &mut p.lanes;
                // SAFETY (the loads and stores of `l`'s rows below): each row
                // is 8 values of 4 bytes, 32-byte aligned (`Lanes`).
                let act = unsafe { _mm256_load_si256(l.active.as_ptr().cast()) };
                if bits_of(act) == 0 {
                    continue;
                }
                any = true;
                let (t, f_in, fx, fy) = unsafe {
                    (
                        _mm256_load_si256(l.t.as_ptr().cast()),
                        _mm256_load_si256(l.f_in.as_ptr().cast()),
                        _mm256_load_ps(l.fx.as_ptr()),
                        _mm256_load_ps(l.fy.as_ptr()),
                    )
                };
                // The lanes' records: vertex ids and links. SAFETY: every
                // lane's t indexes `tets` (idle lanes hold 0, a mesh has a
                // tet), and a record is 32 bytes (`WalkTet`).
                let rec: [*const f32; LANES] = std::array::from_fn(|i| unsafe { tets_ptr.add(l.t[i] as usize * 8) });
                let ids = unsafe { transpose_rows(rec) }.map(|v| _mm256_castps_si256(v));
                let links = unsafe { transpose_rows(rec.map(|q| q.add(4))) }.map(|v| _mm256_castps_si256(v));
                // Their vertices (x, y, w, scalar).
                let (mut xv, mut yv, mut wv, mut sv) = ([zero; 4], [zero; 4], [zero; 4], [zero; 4]);
                for k in 0..4 {
                    let mut id = [0u32; LANES];
                    // SAFETY: 8 ids into a local array of 8.
                    unsafe { _mm256_storeu_si256(id.as_mut_ptr().cast(), ids[k]) };
                    // SAFETY: the ids are the mesh's vertex ids, each < the
                    // view's vertex count (`WalkMesh` checks them), and a
                    // vertex row is 16 bytes (`PacketGeometry::vertex_rows`).
                    [xv[k], yv[k], wv[k], sv[k]] = unsafe { transpose_rows(id.map(|v| verts_ptr.add(v as usize * 4))) };
                }
                let m_in = index_masks(f_in);
                let skip = [_mm256_cmpeq_epi32(f_in, _mm256_setzero_si256()), m_in[0], m_in[1], m_in[2]];
                // The sides against v → u_k, v = tet[f_in]: each lane's
                // directed edge values `e` (f32), the edges it passes left
                // of (bit k) and the lanes an edge test cannot call.
                let (e, left, unsure) = if G::NEAR_CLIP {
                    hom_sides(&xv, &yv, &wv, &ids, m_in, skip, act, fx, fy)
                } else {
                    // `edge::sides_from`, x and y relative to the pixel
                    // centre as `edge::value` translates them.
                    let xr = xv.map(|x| _mm256_sub_ps(x, fx));
                    let yr = yv.map(|y| _mm256_sub_ps(y, fy));
                    let (vx, vy) = (select_ps(xr, m_in), select_ps(yr, m_in));
                    let s_v = _mm256_add_ps(_mm256_andnot_ps(sign, vx), _mm256_andnot_ps(sign, vy));
                    let mut e = [zero; 4];
                    let mut left = _mm256_setzero_si256();
                    let mut unsure = _mm256_setzero_si256();
                    for k in 0..4 {
                        e[k] = _mm256_sub_ps(_mm256_mul_ps(vx, yr[k]), _mm256_mul_ps(vy, xr[k]));
                        let s = _mm256_add_ps(_mm256_andnot_ps(sign, xr[k]), _mm256_andnot_ps(sign, yr[k]));
                        let bound = _mm256_add_ps(_mm256_mul_ps(c_rel, _mm256_add_ps(s_v, s)), c_abs);
                        let pos = _mm256_castps_si256(_mm256_cmp_ps::<_CMP_GT_OQ>(e[k], bound));
                        let neg = _mm256_castps_si256(_mm256_cmp_ps::<_CMP_LT_OQ>(e[k], _mm256_xor_ps(bound, sign)));
                        left = _mm256_or_si256(left, _mm256_and_si256(pos, _mm256_set1_epi32(1 << k)));
                        let decided = _mm256_or_si256(_mm256_or_si256(pos, neg), skip[k]);
                        unsure = _mm256_or_si256(unsure, _mm256_andnot_si256(decided, act));
                    }
                    (e, left, unsure)
                };
                let idx = _mm256_or_si256(left, byte_index_high);
                let exit = select_epi32(exit_rows.map(|row| _mm256_shuffle_epi8(row, idx)), m_in);
                let steps = unsafe { _mm256_load_si256(l.steps_left.as_ptr().cast()) };
                let out_of_steps = _mm256_cmpeq_epi32(steps, _mm256_setzero_si256());
                let scalar_lanes = _mm256_and_si256(
                    act,
                    _mm256_or_si256(unsure, _mm256_or_si256(_mm256_cmpeq_epi32(exit, no_exit), out_of_steps)),
                );
                let ok = _mm256_andnot_si256(scalar_lanes, act);
                let m_out = index_masks(_mm256_and_si256(exit, three_i));
                let m_x = index_masks(_mm256_and_si256(_mm256_srli_epi32::<2>(exit), three_i));
                let m_y = index_masks(_mm256_and_si256(_mm256_srli_epi32::<4>(exit), three_i));
                let link = select_epi32(links, m_out);
                // The exit face (v, x, y): l = [value(x, y), −val[y], val[x]]
                // times the back orientation, clamped at 0 (`face_point`).
                let clamp = |v: __m256| _mm256_and_ps(v, _mm256_cmp_ps::<_CMP_GT_OQ>(v, zero));
                let value_xy = if G::NEAR_CLIP {
                    let pick = |a: &[__m256; 4]| (select_ps(*a, m_x), select_ps(*a, m_y));
                    let ((x_x, x_y), (y_x, y_y), (w_x, w_y)) = (pick(&xv), pick(&yv), pick(&wv));
                    let (id_x, id_y) = (select_epi32(ids, m_x), select_epi32(ids, m_y));
                    hom_value([x_x, y_x, w_x], [x_y, y_y, w_y], id_x, id_y, fx, fy)
                } else {
                    let (xr_x, yr_x) = (_mm256_sub_ps(select_ps(xv, m_x), fx), _mm256_sub_ps(select_ps(yv, m_x), fy));
                    let (xr_y, yr_y) = (_mm256_sub_ps(select_ps(xv, m_y), fx), _mm256_sub_ps(select_ps(yv, m_y), fy));
                    _mm256_sub_ps(_mm256_mul_ps(xr_x, yr_y), _mm256_mul_ps(yr_x, xr_y))
                };
                let l0 = clamp(_mm256_mul_ps(value_xy, orient));
                let l1 = clamp(_mm256_mul_ps(_mm256_xor_ps(select_ps(e, m_y), sign), orient));
                let l2 = clamp(_mm256_mul_ps(select_ps(e, m_x), orient));
                let (w_v, w_x, w_y) = (select_ps(wv, m_in), select_ps(wv, m_x), select_ps(wv, m_y));
                let (s_v0, s_x, s_y) = (select_ps(sv, m_in), select_ps(sv, m_x), select_ps(sv, m_y));
                let (depth, scalar) = if G::NEAR_CLIP {
                    // `Homogeneous::face_point`: the weights normalised one
                    // by one, depth and scalar affine in them.
                    let sum = _mm256_add_ps(_mm256_add_ps(l0, l1), l2);
                    let good = _mm256_cmp_ps::<_CMP_GT_OQ>(sum, zero);
                    let lam = [l0, l1, l2].map(|v| _mm256_blendv_ps(third, _mm256_div_ps(v, sum), good));
                    let dot = |a: __m256, b: __m256, c: __m256| {
                        _mm256_add_ps(
                            _mm256_add_ps(_mm256_mul_ps(lam[0], a), _mm256_mul_ps(lam[1], b)),
                            _mm256_mul_ps(lam[2], c),
                        )
                    };
                    (dot(w_v, w_x, w_y), dot(s_v0, s_x, s_y))
                } else if parallel {
                    let sum = _mm256_add_ps(_mm256_add_ps(l0, l1), l2);
                    let inv = _mm256_div_ps(one, sum);
                    let dot = |a: __m256, b: __m256, c: __m256| {
                        _mm256_add_ps(_mm256_add_ps(_mm256_mul_ps(l0, a), _mm256_mul_ps(l1, b)), _mm256_mul_ps(l2, c))
                    };
                    let good = _mm256_cmp_ps::<_CMP_GT_OQ>(sum, zero);
                    let depth = _mm256_mul_ps(dot(w_v, w_x, w_y), inv);
                    let scalar = _mm256_mul_ps(dot(s_v0, s_x, s_y), inv);
                    let depth_c = _mm256_mul_ps(_mm256_add_ps(_mm256_add_ps(w_v, w_x), w_y), third);
                    let scalar_c = _mm256_mul_ps(_mm256_add_ps(_mm256_add_ps(s_v0, s_x), s_y), third);
                    (_mm256_blendv_ps(depth_c, depth, good), _mm256_blendv_ps(scalar_c, scalar, good))
                } else {
                    let (lw0, lw1, lw2) = (_mm256_mul_ps(l0, w_v), _mm256_mul_ps(l1, w_x), _mm256_mul_ps(l2, w_y));
                    let sum_w = _mm256_add_ps(_mm256_add_ps(lw0, lw1), lw2);
                    let inv = _mm256_div_ps(one, sum_w);
                    let depth = _mm256_mul_ps(_mm256_add_ps(_mm256_add_ps(l0, l1), l2), inv);
                    let scalar = _mm256_mul_ps(
                        _mm256_add_ps(
                            _mm256_add_ps(_mm256_mul_ps(lw0, s_v0), _mm256_mul_ps(lw1, s_x)),
                            _mm256_mul_ps(lw2, s_y),
                        ),
                        inv,
                    );
                    let good = _mm256_cmp_ps::<_CMP_GT_OQ>(sum_w, zero);
                    let depth_c = _mm256_div_ps(three, _mm256_add_ps(_mm256_add_ps(w_v, w_x), w_y));
                    let scalar_c = _mm256_mul_ps(_mm256_add_ps(_mm256_add_ps(s_v0, s_x), s_y), third);
                    (_mm256_blendv_ps(depth_c, depth, good), _mm256_blendv_ps(scalar_c, scalar, good))
                };
                let (depth_in, scalar_in, len_per_depth) = unsafe {
                    (
                        _mm256_load_ps(l.depth_in.as_ptr()),
                        _mm256_load_ps(l.scalar_in.as_ptr()),
                        _mm256_load_ps(l.len_per_depth.as_ptr()),
                    )
                };
                let len = _mm256_mul_ps(_mm256_sub_ps(depth, depth_in), len_per_depth);
                let positive = _mm256_castps_si256(_mm256_cmp_ps::<_CMP_GT_OQ>(len, zero));
                // Near-clipped views: a segment entered before the near plane
                // is dropped, or cut there (`WalkCtx::step`, `push_clipped`).
                let (s_front, len, push) = if G::NEAR_CLIP {
                    let clip = _mm256_cmp_ps::<_CMP_LT_OQ>(depth_in, near);
                    let keep = _mm256_castps_si256(_mm256_cmp_ps::<_CMP_GT_OQ>(depth, near));
                    let t_front = _mm256_div_ps(_mm256_sub_ps(near, depth_in), _mm256_sub_ps(depth, depth_in));
                    let s_cut = _mm256_add_ps(scalar_in, _mm256_mul_ps(t_front, _mm256_sub_ps(scalar, scalar_in)));
                    let len_cut = _mm256_mul_ps(_mm256_sub_ps(depth, near), len_per_depth);
                    let pushed = _mm256_blendv_epi8(positive, keep, _mm256_castps_si256(clip));
                    (
                        _mm256_blendv_ps(scalar_in, s_cut, clip),
                        _mm256_blendv_ps(len, len_cut, clip),
                        _mm256_and_si256(ok, pushed),
                    )
                } else {
                    (scalar_in, len, _mm256_and_si256(ok, positive))
                };
                let push_bits = bits_of(push);
                if push_bits != 0 {
                    // The pushed lanes' segments packed to the batch's end in
                    // lane order (as one `append` a lane would put them): eight
                    // values written, the count of pushed lanes kept.
                    let sh = &mut p.shade;
                    let j = sh.segs.len;
                    assert!(j + LANES <= BATCH);
                    let order = PACK_LANES[push_bits as usize];
                    let perm = _mm256_cvtepu8_epi32(_mm_cvtsi64_si128(order as i64));
                    // SAFETY: j + 8 ≤ BATCH (asserted; the walk shades the
                    // batch before a step that might not fit), so the 8 values
                    // (8 bytes) written at j lie in each array.
                    unsafe {
                        _mm256_storeu_ps(sh.segs.s_front.as_mut_ptr().add(j), _mm256_permutevar8x32_ps(s_front, perm));
                        _mm256_storeu_ps(sh.segs.s_back.as_mut_ptr().add(j), _mm256_permutevar8x32_ps(scalar, perm));
                        _mm256_storeu_ps(sh.segs.len_world.as_mut_ptr().add(j), _mm256_permutevar8x32_ps(len, perm));
                        sh.lane_of.as_mut_ptr().add(j).cast::<u64>().write_unaligned(order);
                    }
                    sh.segs.len = j + push_bits.count_ones() as usize;
                }
                // ok lanes: a crossing, a step spent (ok is −1 in them).
                unsafe {
                    let crossings = _mm256_load_si256(l.crossings.as_ptr().cast());
                    _mm256_store_si256(l.crossings.as_mut_ptr().cast(), _mm256_sub_epi32(crossings, ok));
                    _mm256_store_si256(l.steps_left.as_mut_ptr().cast(), _mm256_add_epi32(steps, ok));
                }
                let end_run = _mm256_and_si256(ok, _mm256_cmpgt_epi32(_mm256_xor_si256(link, bias), broken_biased));
                let t_next = _mm256_srli_epi32::<2>(link);
                let mut t_new = [0u32; LANES];
                // SAFETY: 8 values into a local array of 8.
                unsafe { _mm256_storeu_si256(t_new.as_mut_ptr().cast(), t_next) };
                let mut advance_bits = bits_of(_mm256_andnot_si256(end_run, ok));
                // Into a culled tet: the run ends there, as out of the mesh.
                let mut culled_bits = 0u32;
                if let Some(vis) = visible {
                    let mut b = advance_bits;
                    while b != 0 {
                        let k = b.trailing_zeros() as usize;
                        b &= b - 1;
                        if !vis[t_new[k] as usize] {
                            culled_bits |= 1 << k;
                        }
                    }
                    advance_bits &= !culled_bits;
                }
                let advance = _mm256_cmpgt_epi32(
                    _mm256_and_si256(
                        _mm256_set1_epi32(advance_bits as i32),
                        _mm256_setr_epi32(1, 2, 4, 8, 16, 32, 64, 128),
                    ),
                    _mm256_setzero_si256(),
                );
                let advance_ps = _mm256_castsi256_ps(advance);
                unsafe {
                    _mm256_store_si256(l.t.as_mut_ptr().cast(), _mm256_blendv_epi8(t, t_next, advance));
                    let f_next = _mm256_and_si256(link, three_i);
                    _mm256_store_si256(l.f_in.as_mut_ptr().cast(), _mm256_blendv_epi8(f_in, f_next, advance));
                    _mm256_store_ps(l.depth_in.as_mut_ptr(), _mm256_blendv_ps(depth_in, depth, advance_ps));
                    _mm256_store_ps(l.scalar_in.as_mut_ptr(), _mm256_blendv_ps(scalar_in, scalar, advance_ps));
                }
                if prefetch {
                    let mut b = advance_bits;
                    while b != 0 {
                        let k = b.trailing_zeros() as usize;
                        b &= b - 1;
                        prefetch::prefetch(tets, t_new[k] as usize);
                    }
                }
                let scalar_bits = bits_of(scalar_lanes);
                let end_bits = bits_of(end_run);
                let mut b = scalar_bits | end_bits | culled_bits;
                if b == 0 {
                    continue;
                }
                let mut link_of = [0u32; LANES];
                // SAFETY: 8 values into a local array of 8.
                unsafe { _mm256_storeu_si256(link_of.as_mut_ptr().cast(), link) };
                while b != 0 {
                    let k = b.trailing_zeros() as usize;
                    b &= b - 1;
                    if scalar_bits >> k & 1 == 1 {
                        if let Some(seg) = self.scalar_step(p, k) {
                            append(&mut p.shade, k, seg);
                        }
                    } else {
                        if link_of[k] == LINK_BROKEN {
                            self.st.non_manifold += 1;
                        }
                        p.rays[k].in_run = false;
                    }
                    if !p.rays[k].in_run {
                        self.service(p, k, x0, y0, stride);
                    }
                }
            }
            if !any {
                break;
            }
        }
    }

    /// [`WalkCtx::step`] for lane `k` of packet `p` in scalar arithmetic
    /// (the edge tests the vector step could not decide go to the exact
    /// predicate), its segment returned rather than batched.
    #[inline(never)]
    fn scalar_step(&mut self, p: &mut Packet, k: usize) -> Option<[f32; 3]> {
        let (c, g) = (self.c, self.g);
        let (l, ray) = (&mut p.lanes, &mut p.rays[k]);
        if l.steps_left[k] == 0 {
            self.st.step_limit += 1;
            ray.in_run = false;
            return None;
        }
        l.steps_left[k] -= 1;
        let (fx, fy) = (l.fx[k], l.fy[k]);
        let (t, f_in) = (l.t[k] as usize, l.f_in[k] as usize);
        let Some((p_out, link)) = c.exit(g, &c.mesh.tets[t], f_in, fx, fy, &mut self.counters) else {
            self.st.step_limit += 1;
            ray.in_run = false;
            return None;
        };
        l.crossings[k] += 1;
        let (d_in, s_in, lpd) = (l.depth_in[k], l.scalar_in[k], l.len_per_depth[k]);
        let near = g.near_depth();
        let seg = if G::NEAR_CLIP && d_in < near {
            // Before the near plane: dropped, or cut there (`WalkCtx::step`).
            (p_out.depth > near).then(|| {
                let t_front = (near - d_in) / (p_out.depth - d_in);
                [s_in + t_front * (p_out.scalar - s_in), p_out.scalar, (p_out.depth - near) * lpd]
            })
        } else {
            let len = (p_out.depth - d_in) * lpd;
            (len > 0.0).then_some([s_in, p_out.scalar, len])
        };
        if c.ends_run(link, &mut self.st) {
            ray.in_run = false;
            return seg;
        }
        (l.depth_in[k], l.scalar_in[k]) = (p_out.depth, p_out.scalar);
        l.t[k] = link / 4;
        l.f_in[k] = link % 4;
        seg
    }

    /// Lane `k` of packet `p` out of a run: finishes its ray (shading the
    /// packet's batch, which may hold its last segments) and takes the
    /// tile's next, starts its next run, until it is in a run or idle.
    #[inline(never)]
    fn service(&mut self, p: &mut Packet, k: usize, x0: u32, y0: u32, stride: usize) {
        let (c, g) = (self.c, self.g);
        loop {
            let ray = &mut p.rays[k];
            let l = &mut p.lanes;
            if !ray.has_ray {
                if self.next_ray < self.rays.len() {
                    let (pix, first, end) = self.rays[self.next_ray];
                    self.next_ray += 1;
                    let (px, py) = (x0 + pix % stride as u32, y0 + pix / stride as u32);
                    let r = c.start_ray(px, py, first, end);
                    *ray = LaneRay { has_ray: true, in_run: false, pix, next_entry: first, end };
                    (l.fx[k], l.fy[k], l.len_per_depth[k], l.crossings[k]) = (r.fx, r.fy, r.len_per_depth, 0);
                    p.shade.acc[k] = [0.0; 4];
                    self.st.rays += 1;
                    continue;
                }
                (l.active[k], l.t[k], l.f_in[k]) = (0, 0, 0);
                return;
            }
            if !ray.in_run {
                if ray.next_entry == ray.end {
                    // Done: its segments may still wait in the batch.
                    self.st.crossings += l.crossings[k] as u64;
                    let pix = ray.pix as usize;
                    ray.has_ray = false;
                    p.shade.opaque |= self.shade(&mut p.shade);
                    p.shade.opaque &= !(1 << k);
                    self.acc[pix] = p.shade.acc[k];
                    continue;
                }
                let packed = self.entries[ray.next_entry].2;
                ray.next_entry += 1;
                self.st.runs += 1;
                let p_in = c.entry_point(g, packed, l.fx[k], l.fy[k]);
                (l.depth_in[k], l.scalar_in[k], l.t[k], l.f_in[k]) = (p_in.depth, p_in.scalar, packed / 4, packed % 4);
                l.steps_left[k] = c.view.max_steps;
                ray.in_run = true;
            }
            l.active[k] = -1;
            return;
        }
    }

    /// Shades the packet's batch and composites each segment under its
    /// lane's colour in order, as [`WalkCtx::flush`] does (a lane already
    /// opaque takes no more); the lanes that turned opaque, as bits.
    fn shade(&mut self, sh: &mut PacketShade) -> u32 {
        let n = sh.segs.len;
        if n == 0 {
            return 0;
        }
        self.c.shader.shade_batch(&sh.segs, &mut sh.rgba);
        sh.segs.len = 0;
        let opaque = self.c.opts.opaque_alpha;
        let (mut newly, mut fragments) = (0u32, 0u64);
        for (&k, &rgba) in sh.lane_of[..n].iter().zip(&sh.rgba[..n]) {
            let acc = &mut sh.acc[k as usize];
            if acc[3] >= opaque {
                continue;
            }
            composite_under(acc, rgba);
            fragments += 1;
            if acc[3] >= opaque {
                newly |= 1 << k;
            }
        }
        self.st.fragments += fragments;
        self.st.terminated += newly.count_ones() as u64;
        newly
    }
}

/// For each mask of lanes, the lanes it holds in order, one a byte (the
/// bytes after them 0): the permutation that packs a step's segments.
const PACK_LANES: [u64; 256] = {
    let mut out = [0u64; 256];
    let mut m = 0;
    while m < 256 {
        let (mut k, mut n) = (0, 0);
        while k < LANES {
            if m >> k & 1 == 1 {
                out[m] |= (k as u64) << (8 * n);
                n += 1;
            }
            k += 1;
        }
        m += 1;
    }
    out
};

/// Lane `k`'s segment (Sf, Sb, l) into the packet's batch (which has room:
/// the walk shades it before a step that might not fit).
#[inline(always)]
fn append(sh: &mut PacketShade, k: usize, [sf, sb, len]: [f32; 3]) {
    let j = sh.segs.len;
    sh.segs.s_front[j] = sf;
    sh.segs.s_back[j] = sb;
    sh.segs.len_world[j] = len;
    sh.lane_of[j] = k as u8;
    sh.segs.len = j + 1;
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_pack_table_lists_each_masks_lanes_in_order() {
        for (mask, &packed) in PACK_LANES.iter().enumerate() {
            let lanes: Vec<u64> = (0..LANES as u64).filter(|&k| mask >> k & 1 == 1).collect();
            for (n, &k) in lanes.iter().enumerate() {
                assert_eq!(packed >> (8 * n) & 0xff, k, "mask {mask:#010b}, slot {n}");
            }
            // The bytes after the lanes are 0 (a permutation index in range).
            assert_eq!(packed.checked_shr(8 * lanes.len() as u32).unwrap_or(0), 0, "mask {mask:#010b}");
        }
    }
}
