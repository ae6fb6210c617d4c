//! The rays of one tile (`WalkCtx`): entry lists, the step from tet to
//! tet (edge sides, exit face, face points), segments batched for the
//! shader, compositing.

use super::*;
use crate::shading::LitPoint;
use tet_preint::Segment;

pub(crate) struct WalkCtx<'a> {
    pub(crate) mesh: &'a WalkMesh,
    pub(crate) view: &'a WalkView,
    pub(crate) visible: Option<&'a [bool]>,
    pub(crate) shader: &'a dyn SegmentShader,
    pub(crate) opts: &'a RasterOptions,
    pub(crate) want_grad_mag: bool,
    pub(crate) lit: bool,
    /// Lighting reads the shadow field (shadows on and a field given).
    pub(crate) lit_shadows: Option<&'a crate::ShadowField>,
    /// Lighting needs each sample's position (point lights, shadow maps).
    pub(crate) lit_position: bool,
    /// Rays walked at once ([`RasterOptions::walk_interleave`]).
    pub(crate) lanes: usize,
    /// Request the records of the next step's candidate tets ([`RasterOptions::walk_prefetch`]).
    pub(crate) prefetch: bool,
    /// Image-space adaptive sampling's tolerance ([`RasterOptions::walk_adaptive`]).
    pub(crate) adaptive: Option<f32>,
    /// Walk eight rays a step in SIMD lanes where the frame and the CPU
    /// allow ([`RasterOptions::walk_packets`]).
    pub(crate) packets: bool,
}

/// The rays of a tile given its entries ([`WalkCtx::entries`], sorted by
/// pixel): (pixel, first entry, end) in pixel order.
pub(crate) fn rays_of(entries: &[(u32, f32, u32)]) -> Vec<(u32, usize, usize)> {
    let mut rays = Vec::new();
    let mut k = 0;
    while k < entries.len() {
        let pix = entries[k].0;
        let mut end = k + 1;
        while end < entries.len() && entries[end].0 == pix {
            end += 1;
        }
        rays.push((pix, k, end));
        k = end;
    }
    rays
}

/// Premultiplied colour `c` composited under `acc` (front to back).
#[inline(always)]
pub(crate) fn composite_under(acc: &mut [f32; 4], c: Rgba32) {
    let t = 1.0 - acc[3];
    acc[0] += t * c[0];
    acc[1] += t * c[1];
    acc[2] += t * c[2];
    acc[3] += t * c[3];
}

/// A point on a face along one ray: depth, scalar and the barycentric
/// weights of the face's three vertices (world space).
#[derive(Clone, Copy, Default)]
pub(crate) struct FacePoint {
    pub(crate) depth: f32,
    pub(crate) scalar: f32,
    pub(crate) ids: [u32; 3],
    pub(crate) lam: [f32; 3],
}

/// Where the ray meets face `ids` given its three edge-function values
/// `l[k]` (edge opposite vertex k) oriented so that inside is positive
/// after multiplying by `orient`.
#[inline(always)]
pub(crate) fn face_point(verts: &[WalkVertex], ids: [u32; 3], l: [f32; 3], orient: f32, parallel: bool) -> FacePoint {
    let q = ids.map(|i| verts[i as usize]);
    // Rounding can make a value slightly negative next to an edge.
    // (Comparisons rather than `max`, which also handles NaN at a cost.)
    let l = l.map(|v| {
        let v = v * orient;
        if v > 0.0 {
            v
        } else {
            0.0
        }
    });
    // The weights stay unnormalized until one division: depth and scalar
    // are the weighted sums times 1/Σ (the normalized weights only feed the
    // gradients, which not every frame reads).
    let (lam, depth, scalar);
    if parallel {
        let sum = l[0] + l[1] + l[2];
        if sum > 0.0 {
            let inv = 1.0 / sum;
            lam = l.map(|v| v * inv);
            depth = (l[0] * q[0].w + l[1] * q[1].w + l[2] * q[2].w) * inv;
            scalar = (l[0] * q[0].scalar + l[1] * q[1].scalar + l[2] * q[2].scalar) * inv;
        } else {
            lam = [1.0 / 3.0; 3];
            depth = (q[0].w + q[1].w + q[2].w) * (1.0 / 3.0);
            scalar = (q[0].scalar + q[1].scalar + q[2].scalar) * (1.0 / 3.0);
        }
    } else {
        let lw = [l[0] * q[0].w, l[1] * q[1].w, l[2] * q[2].w];
        let sum_w = lw[0] + lw[1] + lw[2];
        if sum_w > 0.0 {
            let inv = 1.0 / sum_w;
            lam = lw.map(|v| v * inv);
            depth = (l[0] + l[1] + l[2]) * inv;
            scalar = (lw[0] * q[0].scalar + lw[1] * q[1].scalar + lw[2] * q[2].scalar) * inv;
        } else {
            // The centre on a vertex: any point of the face is that vertex.
            lam = [1.0 / 3.0; 3];
            depth = 3.0 / (q[0].w + q[1].w + q[2].w);
            scalar = (q[0].scalar + q[1].scalar + q[2].scalar) * (1.0 / 3.0);
        }
    }
    FacePoint { depth, scalar, ids, lam }
}

/// Where one ray's walk stands between steps.
#[derive(Clone, Copy)]
pub(crate) struct RayState {
    pub(crate) fx: f32,
    pub(crate) fy: f32,
    pub(crate) len_per_depth: f32,
    /// Its entries left: `entries[next_entry..end]`.
    pub(crate) next_entry: usize,
    pub(crate) end: usize,
    /// The run in progress: tet, entry face, entry point, steps it may
    /// still take.
    pub(crate) t: usize,
    pub(crate) f_in: usize,
    pub(crate) p_in: FacePoint,
    pub(crate) steps_left: u32,
    pub(crate) in_run: bool,
    pub(crate) acc: [f32; 4],
    /// Segments to gather before the next shading.
    pub(crate) cap: usize,
    pub(crate) crossings: u64,
}

/// A lit segment's face points and the fraction of the way from `a` to `b`
/// where it starts (0 unless the near plane cut it).
#[derive(Clone, Copy, Default)]
pub(crate) struct LitEnds {
    /// The face points `a` (entry) and `b` (exit).
    pub(crate) ab: [FacePoint; 2],
    pub(crate) u_front: f32,
}

impl LitEnds {
    /// A per-vertex field (walk vertex ids) at fraction `w` of the segment
    /// (0 its front, 1 its back).
    #[inline]
    fn at<const N: usize>(&self, w: f32, f: impl Fn(u32) -> [f32; N]) -> [f32; N] {
        let at = |p: &FacePoint| -> [f32; N] {
            let v = p.ids.map(&f);
            std::array::from_fn(|c| p.lam[0] * v[0][c] + p.lam[1] * v[1][c] + p.lam[2] * v[2][c])
        };
        let (fa, fb) = (at(&self.ab[0]), at(&self.ab[1]));
        let u = self.u_front + w * (1.0 - self.u_front);
        std::array::from_fn(|c| fa[c] + u * (fb[c] - fa[c]))
    }
}

/// Segments of one ray waiting for the shader.
pub(crate) struct RayBatch {
    pub(crate) segs: SegmentBatch,
    /// Each segment's ends (lighting only): what is lit is the midpoint.
    pub(crate) lit_ends: [LitEnds; BATCH],
    pub(crate) rgba: [Rgba32; BATCH],
    /// The pieces of a split lit segment ([`crate::shading::light_segment`]).
    pub(crate) pieces: crate::shading::LitPieces,
}

/// The first batch of a ray holds this many segments, each next one twice
/// as many up to [`BATCH`]: most rays that turn opaque do so early, and a
/// ray walks at most one batch past the point where it did.
pub(crate) const FIRST_BATCH: usize = 16;

/// What a view's walk asks of its geometry: the projected form (f32 pixel
/// positions, [`edge`]) or, where the near plane cuts the mesh, the
/// homogeneous one ([`hom`]). Both give the signs and values of the same
/// edge functions, so one walk serves both.
pub(crate) trait RayGeometry: Sync {
    /// Segments are clipped at [`RayGeometry::near_depth`] and rays may
    /// start in the eye's tet.
    const NEAR_CLIP: bool;
    fn side(&self, iu: u32, iv: u32, fx: f32, fy: f32, c: &mut EdgeCounters) -> (f32, bool);
    fn value(&self, iu: u32, iv: u32, fx: f32, fy: f32) -> f32;
    fn sides_from(&self, tet: [u32; 4], skip: usize, fx: f32, fy: f32, c: &mut EdgeCounters) -> ([f32; 4], u32);
    fn face_point(&self, ids: [u32; 3], l: [f32; 3], orient: f32) -> FacePoint;
    /// The centres a front face may cover.
    fn face_rect(&self, ids: [u32; 3]) -> Option<[u32; 4]>;
    fn near_depth(&self) -> f32;
    /// The eye's tet (walk order) and its vertices, when rays start there.
    fn eye_tet(&self) -> Option<(u32, [u32; 4])>;
}

pub(crate) struct Projected<'a> {
    pub(crate) verts: &'a [WalkVertex],
    pub(crate) pos: Projector<'a>,
    pub(crate) k_view: f32,
    pub(crate) parallel: bool,
    pub(crate) size: [u32; 2],
}

impl RayGeometry for Projected<'_> {
    const NEAR_CLIP: bool = false;
    #[inline(always)]
    fn side(&self, iu: u32, iv: u32, fx: f32, fy: f32, c: &mut EdgeCounters) -> (f32, bool) {
        edge::side(self.verts, &self.pos, iu, iv, fx, fy, self.k_view, c)
    }
    #[inline(always)]
    fn value(&self, iu: u32, iv: u32, fx: f32, fy: f32) -> f32 {
        edge::directed_value(self.verts, iu, iv, fx, fy)
    }
    #[inline(always)]
    fn sides_from(&self, tet: [u32; 4], skip: usize, fx: f32, fy: f32, c: &mut EdgeCounters) -> ([f32; 4], u32) {
        edge::sides_from(self.verts, &self.pos, tet, skip, fx, fy, self.k_view, c)
    }
    #[inline(always)]
    fn face_point(&self, ids: [u32; 3], l: [f32; 3], orient: f32) -> FacePoint {
        face_point(self.verts, ids, l, orient, self.parallel)
    }
    fn face_rect(&self, ids: [u32; 3]) -> Option<[u32; 4]> {
        pixel_rect(&ids.map(|i| self.pos.px(i)), self.size[0], self.size[1])
    }
    fn near_depth(&self) -> f32 {
        f32::NEG_INFINITY
    }
    fn eye_tet(&self) -> Option<(u32, [u32; 4])> {
        None
    }
}

pub(crate) struct Homogeneous<'a> {
    pub(crate) verts: &'a [HomVertex],
    pub(crate) near_depth: f32,
    /// The eye's tet when it is visible.
    pub(crate) eye: Option<(u32, [u32; 4])>,
    pub(crate) size: [u32; 2],
}

impl RayGeometry for Homogeneous<'_> {
    const NEAR_CLIP: bool = true;
    #[inline(always)]
    fn side(&self, iu: u32, iv: u32, fx: f32, fy: f32, c: &mut EdgeCounters) -> (f32, bool) {
        hom::side(self.verts, iu, iv, fx, fy, c)
    }
    #[inline(always)]
    fn value(&self, iu: u32, iv: u32, fx: f32, fy: f32) -> f32 {
        hom::directed_value(self.verts, iu, iv, fx, fy)
    }
    #[inline(always)]
    fn sides_from(&self, tet: [u32; 4], skip: usize, fx: f32, fy: f32, c: &mut EdgeCounters) -> ([f32; 4], u32) {
        hom::sides_from(self.verts, tet, skip, fx, fy, c)
    }
    #[inline(always)]
    fn face_point(&self, ids: [u32; 3], l: [f32; 3], orient: f32) -> FacePoint {
        // The edge values are the barycentric weights up to one factor
        // (`hom` module docs); depth and scalar are affine in them.
        let q = ids.map(|i| self.verts[i as usize]);
        let l = l.map(|v| if v * orient > 0.0 { v * orient } else { 0.0 });
        let sum = l[0] + l[1] + l[2];
        let lam = if sum > 0.0 { l.map(|v| v / sum) } else { [1.0 / 3.0; 3] };
        FacePoint {
            depth: lam[0] * q[0].w_depth + lam[1] * q[1].w_depth + lam[2] * q[2].w_depth,
            scalar: lam[0] * q[0].scalar + lam[1] * q[1].scalar + lam[2] * q[2].scalar,
            ids,
            lam,
        }
    }
    fn face_rect(&self, ids: [u32; 3]) -> Option<[u32; 4]> {
        hom::face_rect(ids.map(|i| self.verts[i as usize]), self.size[0], self.size[1])
    }
    fn near_depth(&self) -> f32 {
        self.near_depth
    }
    fn eye_tet(&self) -> Option<(u32, [u32; 4])> {
        self.eye
    }
}

impl WalkCtx<'_> {
    // One call a tile; kept out of line so profiles can count a frame's
    // walk (the callgrind scripts toggle on it).
    #[inline(never)]
    pub(crate) fn tile(&self, ti: usize) -> (Vec<[f32; 4]>, WalkStats) {
        let view = self.view;
        let size = [view.frame.width, view.frame.height];
        if view.near_clipped {
            let eye = view
                .eye_tet
                .filter(|&t| self.visible.is_none_or(|vis| vis[t as usize]))
                .map(|t| (t, self.mesh.tets[t as usize].verts));
            let g = Homogeneous { verts: &view.hom, near_depth: view.frame.near_depth as f32, eye, size };
            #[cfg(target_arch = "x86_64")]
            if self.packet_walk() {
                return super::packet::tile(self, &g, ti);
            }
            self.tile_full(&g, ti)
        } else {
            let g = Projected {
                verts: &view.verts,
                pos: Projector { frame: &view.frame, pos_rel: &self.mesh.pos_rel },
                k_view: view.k_view,
                parallel: view.frame.parallel,
                size,
            };
            #[cfg(target_arch = "x86_64")]
            if self.packet_walk() {
                return super::packet::tile(self, &g, ti);
            }
            self.tile_full(&g, ti)
        }
    }

    /// Whether a projected view's tiles take the packet walk: asked for,
    /// AVX2 present, and nothing the packet walk leaves to the scalar one
    /// (lighting, bivariate methods).
    #[cfg(target_arch = "x86_64")]
    pub(crate) fn packet_walk(&self) -> bool {
        self.packets && !self.lit && !self.want_grad_mag && super::packet::available()
    }

    /// [`Self::tile_with`], compiled without the per-vertex gradient reads
    /// where the frame needs none (neither lighting nor a bivariate method):
    /// the exit points' weights and vertex ids are then never kept.
    pub(crate) fn tile_full<G: RayGeometry>(&self, g: &G, ti: usize) -> (Vec<[f32; 4]>, WalkStats) {
        if self.lit || self.want_grad_mag {
            self.tile_with::<G, true>(g, ti)
        } else {
            self.tile_with::<G, false>(g, ti)
        }
    }

    pub(crate) fn tile_with<G: RayGeometry, const GRADS: bool>(&self, g: &G, ti: usize) -> (Vec<[f32; 4]>, WalkStats) {
        let (rect, stride) = self.view.tile_rect(ti);
        let mut acc = vec![[0.0f32; 4]; stride * (rect[3] - rect[1] + 1) as usize];
        let mut st = WalkStats::default();
        let mut counters = EdgeCounters::default();
        let entries = self.entries(g, ti, rect, stride, &mut counters, &mut st);
        let rays = rays_of(&entries);
        // Several rays in flight, one step each in turn: each walk is a
        // chain of dependent loads, and independent chains let the core
        // overlap their cache misses (meshes far larger than the caches).
        let lanes = self.lanes;
        let new_batch = || {
            Box::new(RayBatch {
                segs: SegmentBatch::default(),
                lit_ends: [LitEnds::default(); BATCH],
                rgba: [[0.0; 4]; BATCH],
                pieces: Default::default(),
            })
        };
        let mut batches: Vec<Box<RayBatch>> = (0..lanes).map(|_| new_batch()).collect();
        let mut flight: Vec<Option<(u32, RayState)>> = vec![None; lanes];
        let mut next = 0;
        let mut active = 0;
        if let Some(tol) = self.adaptive {
            let batch = &mut batches[0];
            let mut walk = |list: &[(u32, usize, usize)], acc: &mut Vec<[f32; 4]>, st: &mut WalkStats| {
                for &(pix, first, end) in list {
                    let (px, py) = (rect[0] + pix % stride as u32, rect[1] + pix / stride as u32);
                    batch.segs.len = 0;
                    st.rays += 1;
                    let mut ray = self.start_ray(px, py, first, end);
                    while !self.step::<G, GRADS>(g, &mut ray, &entries, batch, st, &mut counters) {}
                    acc[pix as usize] = ray.acc;
                }
            };
            let rows = acc.len() / stride;
            adaptive_fill(&rays, stride, rows, tol, &mut acc, &mut st, &mut walk);
            next = rays.len();
        } else if lanes == 1 {
            // One ray at a time: its state stays a local.
            let batch = &mut batches[0];
            for &(pix, first, end) in &rays {
                let (px, py) = (rect[0] + pix % stride as u32, rect[1] + pix / stride as u32);
                batch.segs.len = 0;
                st.rays += 1;
                let mut ray = self.start_ray(px, py, first, end);
                while !self.step::<G, GRADS>(g, &mut ray, &entries, batch, &mut st, &mut counters) {}
                acc[pix as usize] = ray.acc;
            }
            next = rays.len();
        }
        while next < rays.len() || active > 0 {
            for (lane, slot) in flight.iter_mut().enumerate() {
                if slot.is_none() && next < rays.len() {
                    let (pix, first, end) = rays[next];
                    next += 1;
                    let (px, py) = (rect[0] + pix % stride as u32, rect[1] + pix / stride as u32);
                    batches[lane].segs.len = 0;
                    st.rays += 1;
                    *slot = Some((pix, self.start_ray(px, py, first, end)));
                    active += 1;
                }
                if let Some((pix, ray)) = slot {
                    if self.step::<G, GRADS>(g, ray, &entries, &mut batches[lane], &mut st, &mut counters) {
                        acc[*pix as usize] = ray.acc;
                        *slot = None;
                        active -= 1;
                    }
                }
            }
        }
        st.exact_tests = counters.exact;
        (acc, st)
    }

    /// The tile's entries: (pixel index in the tile, depth, tet·4 + face),
    /// sorted by pixel, then depth. Near-clipped views with the eye in a
    /// visible tet add, for every pixel, the face of that tet its ray meets
    /// behind the eye (a missing one, impossible with exact signs, is
    /// counted with the step bound).
    pub(crate) fn entries<G: RayGeometry>(
        &self,
        g: &G,
        ti: usize,
        rect: [u32; 4],
        stride: usize,
        counters: &mut EdgeCounters,
        st: &mut WalkStats,
    ) -> Vec<(u32, f32, u32)> {
        let view = self.view;
        let bin = view.bin_start[ti] as usize..view.bin_start[ti + 1] as usize;
        let orient = if FRONT_IS_LEFT { 1.0 } else { -1.0 };
        let mut out = Vec::new();
        for (&packed, &ids) in view.bin_faces[bin.clone()].iter().zip(&view.bin_verts[bin]) {
            let Some(r) = g.face_rect(ids) else {
                continue;
            };
            let (x0, y0, x1, y1) = (r[0].max(rect[0]), r[1].max(rect[1]), r[2].min(rect[2]), r[3].min(rect[3]));
            if x0 > x1 || y0 > y1 {
                continue;
            }
            for py in y0..=y1 {
                let fy = py as f32 + 0.5;
                for px in x0..=x1 {
                    let fx = px as f32 + 0.5;
                    let e0 = g.side(ids[1], ids[2], fx, fy, counters);
                    if e0.1 != FRONT_IS_LEFT {
                        continue;
                    }
                    let e1 = g.side(ids[2], ids[0], fx, fy, counters);
                    if e1.1 != FRONT_IS_LEFT {
                        continue;
                    }
                    let e2 = g.side(ids[0], ids[1], fx, fy, counters);
                    if e2.1 != FRONT_IS_LEFT {
                        continue;
                    }
                    let fp = g.face_point(ids, [e0.0, e1.0, e2.0], orient);
                    let pix = (py - rect[1]) as usize * stride + (px - rect[0]) as usize;
                    out.push((pix as u32, fp.depth, packed));
                }
            }
        }
        if let Some((t0, tet)) = g.eye_tet() {
            for py in rect[1]..=rect[3] {
                for px in rect[0]..=rect[2] {
                    let (fx, fy) = (px as f32 + 0.5, py as f32 + 0.5);
                    let pix = (py - rect[1]) as usize * stride + (px - rect[0]) as usize;
                    // The face the line meets behind the eye: the one whose
                    // three edges all say front (`hom` module docs).
                    let behind = FACE_OUTWARD.iter().enumerate().find_map(|(f, fv)| {
                        let ids = [tet[fv[0]], tet[fv[1]], tet[fv[2]]];
                        let mut l = [0.0f32; 3];
                        for (k, lk) in l.iter_mut().enumerate() {
                            let (e, left) = g.side(ids[(k + 1) % 3], ids[(k + 2) % 3], fx, fy, counters);
                            if left != FRONT_IS_LEFT {
                                return None;
                            }
                            *lk = e;
                        }
                        Some((f, ids, l))
                    });
                    match behind {
                        Some((f, ids, l)) => {
                            let fp = g.face_point(ids, l, orient);
                            out.push((pix as u32, fp.depth, t0 * 4 + f as u32));
                        }
                        None => st.step_limit += 1,
                    }
                }
            }
        }
        out.sort_unstable_by(|a, b| a.0.cmp(&b.0).then(a.1.total_cmp(&b.1)).then(a.2.cmp(&b.2)));
        out
    }

    /// Starts the ray through pixel (px, py), whose entries are
    /// `entries[first..end]`.
    pub(crate) fn start_ray(&self, px: u32, py: u32, first: usize, end: usize) -> RayState {
        let (fx, fy) = (px as f32 + 0.5, py as f32 + 0.5);
        RayState {
            fx,
            fy,
            len_per_depth: self.view.frame.len_per_depth(fx as f64, fy as f64) as f32,
            next_entry: first,
            end,
            t: 0,
            f_in: 0,
            p_in: FacePoint { depth: 0.0, scalar: 0.0, ids: [0; 3], lam: [0.0; 3] },
            steps_left: 0,
            in_run: false,
            acc: [0.0; 4],
            cap: FIRST_BATCH,
            crossings: 0,
        }
    }

    /// Advances one ray by one tet (or by starting its next run); true when
    /// the ray is done (its entries walked, or opaque), its colour in
    /// `ray.acc`. The steps of one ray are the same operations in the same
    /// order however rays are interleaved, so the image does not depend on
    /// the interleaving.
    #[inline(always)]
    #[allow(clippy::too_many_arguments)]
    pub(crate) fn step<G: RayGeometry, const GRADS: bool>(
        &self,
        g: &G,
        ray: &mut RayState,
        entries: &[(u32, f32, u32)],
        batch: &mut RayBatch,
        st: &mut WalkStats,
        counters: &mut EdgeCounters,
    ) -> bool {
        let tets = &self.mesh.tets[..];
        let (fx, fy) = (ray.fx, ray.fy);
        if !ray.in_run {
            if ray.next_entry == ray.end {
                return self.finish(ray, batch, st);
            }
            let packed = entries[ray.next_entry].2;
            ray.next_entry += 1;
            st.runs += 1;
            (ray.t, ray.f_in) = ((packed / 4) as usize, (packed % 4) as usize);
            ray.p_in = self.entry_point(g, packed, fx, fy);
            ray.steps_left = self.view.max_steps;
            ray.in_run = true;
        }
        let (t, f_in) = (ray.t, ray.f_in);
        if ray.steps_left == 0 {
            st.step_limit += 1;
            ray.in_run = false;
            return false;
        }
        ray.steps_left -= 1;
        let rec = &tets[t];
        if self.prefetch {
            // The three neighbours the ray may step into: their records are
            // requested while this step's edge tests run (`prefetch`). The
            // fourth, the tet the ray came from, is in the cache already: asking
            // for it too costs less than a branch.
            for &n in &rec.links {
                prefetch::prefetch(tets, (n / 4) as usize);
            }
        }
        let Some((p_out, link)) = self.exit(g, rec, f_in, fx, fy, counters) else {
            // Cannot happen with exact signs (module docs); counted with the
            // step bound rather than trusted.
            st.step_limit += 1;
            ray.in_run = false;
            return false;
        };
        ray.crossings += 1;
        let p_in = ray.p_in;
        let len = (p_out.depth - p_in.depth) * ray.len_per_depth;
        let near = g.near_depth();
        let pushed = if G::NEAR_CLIP && p_in.depth < near {
            // Before the near plane: dropped, or cut there.
            let keep = p_out.depth > near;
            if keep {
                let t_front = (near - p_in.depth) / (p_out.depth - p_in.depth);
                self.push_clipped::<GRADS>(batch, &p_in, &p_out, (p_out.depth - near) * ray.len_per_depth, t_front);
            }
            keep
        } else if len > 0.0 {
            self.push::<GRADS>(batch, &p_in, &p_out, len);
            true
        } else {
            false
        };
        if pushed && batch.segs.len >= ray.cap {
            ray.cap = (ray.cap * 2).min(BATCH);
            if self.flush(batch, &mut ray.acc, fx, fy, st) {
                st.terminated += 1;
                st.crossings += ray.crossings;
                return true;
            }
        }
        if self.ends_run(link, st) {
            ray.in_run = false;
            return false;
        }
        if GRADS {
            ray.p_in = p_out;
        } else {
            // Only depth and scalar are read (`push`): the weights and ids
            // are not worth a store.
            (ray.p_in.depth, ray.p_in.scalar) = (p_out.depth, p_out.scalar);
        }
        ray.t = (link / 4) as usize;
        ray.f_in = (link % 4) as usize;
        false
    }

    /// Where the ray through (fx, fy) enters tet·4 + face `packed` (a run's
    /// first point).
    #[inline(always)]
    pub(crate) fn entry_point<G: RayGeometry>(&self, g: &G, packed: u32, fx: f32, fy: f32) -> FacePoint {
        let fv = FACE_OUTWARD[(packed % 4) as usize];
        let tv = self.mesh.tets[(packed / 4) as usize].verts;
        let ids = [tv[fv[0]], tv[fv[1]], tv[fv[2]]];
        let l = [g.value(ids[1], ids[2], fx, fy), g.value(ids[2], ids[0], fx, fy), g.value(ids[0], ids[1], fx, fy)];
        let front_orient = if FRONT_IS_LEFT { 1.0 } else { -1.0 };
        g.face_point(ids, l, front_orient)
    }

    /// One step's geometry: where the ray through (fx, fy), having entered
    /// tet `rec` through face `f_in`, leaves it, and the link of that face;
    /// `None` where no exit is found (impossible with exact signs).
    #[inline(always)]
    pub(crate) fn exit<G: RayGeometry>(
        &self,
        g: &G,
        rec: &WalkTet,
        f_in: usize,
        fx: f32,
        fy: f32,
        counters: &mut EdgeCounters,
    ) -> Option<(FacePoint, u32)> {
        let tet = rec.verts;
        let (val, bits) = g.sides_from(tet, f_in, fx, fy, counters);
        // One table read: with the candidates' records already requested
        // (the step's prefetch), a branch per candidate no longer lets loads
        // start sooner.
        let exit = EXIT_BY_SIDES[f_in & 3][(bits & 0xf) as usize];
        if exit == NO_EXIT {
            return None;
        }
        let (f_out, x, y) = ((exit & 3) as usize, (exit >> 2 & 3) as usize, (exit >> 4 & 3) as usize);
        // The exit face as (v, x, y), a rotation of its outward order: the
        // edge values opposite v, x and y.
        let (v, tx, ty) = (tet[f_in & 3], tet[x], tet[y]);
        let l = [g.value(tx, ty, fx, fy), -val[y], val[x]];
        let back_orient = if FRONT_IS_LEFT { -1.0 } else { 1.0 };
        Some((g.face_point([v, tx, ty], l, back_orient), rec.links[f_out & 3]))
    }

    /// Whether a run ends at `link`: out of the mesh, or into a culled tet
    /// (the ray's next entry, if any, is where it meets visible tets
    /// again). A link whose neighbour does not point back is counted.
    #[inline(always)]
    pub(crate) fn ends_run(&self, link: u32, st: &mut WalkStats) -> bool {
        if link == LINK_BROKEN {
            st.non_manifold += 1;
        }
        link >= LINK_BROKEN || self.visible.is_some_and(|vis| !vis[(link / 4) as usize])
    }

    /// Shades what is left of the ray's batch; always true (done).
    pub(crate) fn finish(&self, ray: &mut RayState, batch: &mut RayBatch, st: &mut WalkStats) -> bool {
        st.crossings += ray.crossings;
        if batch.segs.len > 0 && self.flush(batch, &mut ray.acc, ray.fx, ray.fy, st) {
            st.terminated += 1;
        }
        true
    }

    /// [`Self::push`] for a segment cut by the near plane: its front values
    /// are those at `t_front` of the way from `a` to `b` (every field is
    /// linear along the ray inside the tet).
    pub(crate) fn push_clipped<const GRADS: bool>(
        &self,
        batch: &mut RayBatch,
        a: &FacePoint,
        b: &FacePoint,
        len: f32,
        t_front: f32,
    ) {
        let k = batch.segs.len;
        self.push::<GRADS>(batch, a, b, len);
        let mix = |fa: f32, fb: f32| fa + t_front * (fb - fa);
        batch.segs.s_front[k] = mix(a.scalar, b.scalar);
        if GRADS && self.want_grad_mag {
            batch.segs.grad_front[k] = mix(batch.segs.grad_front[k], batch.segs.grad_back[k]);
        }
        if GRADS && self.lit {
            // The cut segment's midpoint is halfway from t_front to b.
            batch.lit_ends[k].u_front = t_front;
        }
    }

    #[inline(always)]
    pub(crate) fn push<const GRADS: bool>(&self, batch: &mut RayBatch, a: &FacePoint, b: &FacePoint, len: f32) {
        let k = batch.segs.len;
        batch.segs.s_front[k] = a.scalar;
        batch.segs.s_back[k] = b.scalar;
        batch.segs.len_world[k] = len;
        if !GRADS {
            // The batch was made by this tile's walk with zero gradients
            // (`tile_with`), and nothing here writes them.
        } else if self.want_grad_mag {
            let g = self.mesh.grad_mag.as_deref().expect("checked in want_grad_mag");
            let at = |p: &FacePoint| {
                p.lam[0] * g[p.ids[0] as usize] + p.lam[1] * g[p.ids[1] as usize] + p.lam[2] * g[p.ids[2] as usize]
            };
            batch.segs.grad_front[k] = at(a);
            batch.segs.grad_back[k] = at(b);
        } else {
            batch.segs.grad_front[k] = 0.0;
            batch.segs.grad_back[k] = 0.0;
        }
        if GRADS && self.lit {
            batch.lit_ends[k] = LitEnds { ab: [*a, *b], u_front: 0.0 };
        }
        batch.segs.len = k + 1;
    }

    /// The lighting terms at fraction `w` of a lit segment: the gradient,
    /// the position (point lights) and the shadow field there.
    fn lit_at(&self, ends: &LitEnds, w: f32, view_dir: DVec3) -> LitPoint {
        let m = self.mesh;
        let sh = &self.opts.shading;
        let g = ends.at(w, |v| m.grads.as_deref().expect("checked in lit")[v as usize]);
        let field = self.lit_shadows;
        let pos = if self.lit_position {
            let p = ends.at(w, |v| m.pos_rel[v as usize].map(|x| x as f32));
            DVec3::new(p[0] as f64, p[1] as f64, p[2] as f64) + m.centre_in_world
        } else {
            DVec3::ZERO
        };
        let shadow = |i: usize| match field {
            Some(f) if f.has_light(i) => (-f.depth_at(i, pos)).exp(),
            _ => 1.0,
        };
        sh.lit_point(DVec3::new(g[0] as f64, g[1] as f64, g[2] as f64), pos, view_dir, shadow)
    }

    /// Lights segment `seg` (shaded `c`): see [`crate::shading::light_segment`].
    fn light_segment(
        &self,
        seg: &Segment,
        c: Rgba32,
        front: Option<LitPoint>,
        ends: &LitEnds,
        view_dir: DVec3,
        pieces: &mut crate::shading::LitPieces,
    ) -> (Rgba32, Option<LitPoint>) {
        let lit_at = |w| self.lit_at(ends, w, view_dir);
        crate::shading::light_segment(seg, c, front, lit_at, |b, out| self.shader.shade_batch(b, out), pieces)
    }

    /// Shades the batch and composites it under `acc` in order; true once
    /// the pixel is opaque (the rest of the batch is dropped).
    pub(crate) fn flush(&self, batch: &mut RayBatch, acc: &mut [f32; 4], fx: f32, fy: f32, st: &mut WalkStats) -> bool {
        let n = batch.segs.len;
        if acc[3] >= self.opts.opaque_alpha {
            batch.segs.len = 0;
            return true;
        }
        self.shader.shade_batch(&batch.segs, &mut batch.rgba);
        batch.segs.len = 0;
        let view_dir = self.lit.then(|| self.view.frame.view_dir(fx as f64, fy as f64));
        // The lighting terms at the previous segment's back face point,
        // which is the next one's front when the ray went straight on.
        let mut prev_back: Option<(FacePoint, LitPoint)> = None;
        for k in 0..n {
            let mut c = batch.rgba[k];
            if let Some(vd) = view_dir {
                let segs = &batch.segs;
                let seg = Segment {
                    s_front: segs.s_front[k],
                    s_back: segs.s_back[k],
                    grad_front: segs.grad_front[k],
                    grad_back: segs.grad_back[k],
                    len_world: segs.len_world[k],
                };
                let ends = &batch.lit_ends[k];
                let front = prev_back
                    .filter(|(p, _)| ends.u_front == 0.0 && p.ids == ends.ab[0].ids && p.lam == ends.ab[0].lam)
                    .map(|(_, l)| l);
                let (lit, back) = self.light_segment(&seg, c, front, ends, vd, &mut batch.pieces);
                c = lit;
                prev_back = back.map(|l| (ends.ab[1], l));
            }
            composite_under(acc, c);
            st.fragments += 1;
            if acc[3] >= self.opts.opaque_alpha {
                return true;
            }
        }
        false
    }
}

/// Lattice spacing of [`adaptive_fill`]'s first pass, in pixels.
const ADAPTIVE_SPACING: usize = 4;

/// Walks a list of a tile's rays (pixel, first entry, end), each one's
/// colour written at its pixel of the image given ([`adaptive_fill`]).
pub(crate) type WalkRays<'a> = dyn FnMut(&[(u32, usize, usize)], &mut Vec<[f32; 4]>, &mut WalkStats) + 'a;

/// Image-space adaptive sampling of one tile ([`RasterOptions::walk_adaptive`]):
/// `rays` are the tile's (pixel, first entry, end) in pixel order; `walk`
/// walks a list of them and writes each one's colour at its pixel in the
/// image it is given. Pixels without a ray stay clear.
///
/// Level by level: the rays on a lattice of `ADAPTIVE_SPACING` pixels are
/// walked first; a block whose pixels all have the same number of entries
/// (no silhouette or re-entry inside) and whose four walked corners agree
/// within `tol` in every channel is interpolated bilinearly from them,
/// any other is split in two along each side longer than a pixel, and the
/// children's corners not yet walked are walked together, as one list (so
/// that a walker taking many rays at once gets many). Corners are always
/// walked, never interpolated; a pixel on the edge of blocks of several
/// levels takes the finest one's interpolation. The result does not depend
/// on the order `walk` takes a list's rays in.
pub(crate) fn adaptive_fill(
    rays: &[(u32, usize, usize)],
    stride: usize,
    rows: usize,
    tol: f32,
    acc: &mut Vec<[f32; 4]>,
    st: &mut WalkStats,
    walk: &mut WalkRays<'_>,
) {
    // Per pixel: its ray's index + 1 (0: none), and whether it is walked
    // (or asked for in the list being gathered).
    let mut ray_of = vec![0u32; acc.len()];
    for (r, &(pix, _, _)) in rays.iter().enumerate() {
        ray_of[pix as usize] = r as u32 + 1;
    }
    let mut walked = vec![false; acc.len()];
    let entries = |p: usize| match ray_of[p] {
        0 => 0,
        r => {
            let (_, first, end) = rays[r as usize - 1];
            end - first
        }
    };
    let mut list = Vec::new();
    let ask = |x: usize, y: usize, walked: &mut [bool], list: &mut Vec<(u32, usize, usize)>| {
        let p = y * stride + x;
        if !walked[p] {
            walked[p] = true;
            if ray_of[p] != 0 {
                list.push(rays[ray_of[p] as usize - 1]);
            }
        }
    };
    let lattice = |n: usize| -> Vec<usize> {
        let mut v: Vec<usize> = (0..n).step_by(ADAPTIVE_SPACING).collect();
        if *v.last().unwrap_or(&0) != n.saturating_sub(1) {
            v.push(n - 1);
        }
        v
    };
    let (xs, ys) = (lattice(stride), lattice(rows));
    for &y in &ys {
        for &x in &xs {
            ask(x, y, &mut walked, &mut list);
        }
    }
    // Blocks [x0, x1, y0, y1], inclusive corners.
    let windows = |v: &[usize]| -> Vec<(usize, usize)> {
        if v.len() == 1 {
            vec![(v[0], v[0])]
        } else {
            v.windows(2).map(|w| (w[0], w[1])).collect()
        }
    };
    let mut blocks: Vec<[usize; 4]> = Vec::new();
    for &(y0, y1) in &windows(&ys) {
        for &(x0, x1) in &windows(&xs) {
            blocks.push([x0, x1, y0, y1]);
        }
    }
    let mut smooth: Vec<[usize; 4]> = Vec::new();
    while !list.is_empty() || !blocks.is_empty() {
        walk(&list, acc, st);
        list.clear();
        let mut children = Vec::new();
        for &[x0, x1, y0, y1] in &blocks {
            if x1 - x0 <= 1 && y1 - y0 <= 1 {
                continue;
            }
            let n0 = entries(y0 * stride + x0);
            let same_cover = (y0..=y1).all(|y| (x0..=x1).all(|x| entries(y * stride + x) == n0));
            let c = [acc[y0 * stride + x0], acc[y0 * stride + x1], acc[y1 * stride + x0], acc[y1 * stride + x1]];
            let close = (0..4).all(|k| {
                let (lo, hi) =
                    c.iter().fold((f32::INFINITY, f32::NEG_INFINITY), |(lo, hi), v| (lo.min(v[k]), hi.max(v[k])));
                hi - lo <= tol
            });
            if same_cover && close {
                if n0 != 0 {
                    smooth.push([x0, x1, y0, y1]);
                }
                continue;
            }
            let (xm, ym) = ((x0 + x1) / 2, (y0 + y1) / 2);
            let xsplit: &[(usize, usize)] = if x1 - x0 >= 2 { &[(x0, xm), (xm, x1)] } else { &[(x0, x1)] };
            let ysplit: &[(usize, usize)] = if y1 - y0 >= 2 { &[(y0, ym), (ym, y1)] } else { &[(y0, y1)] };
            for &(ya, yb) in ysplit {
                for &(xa, xb) in xsplit {
                    for (x, y) in [(xa, ya), (xb, ya), (xa, yb), (xb, yb)] {
                        ask(x, y, &mut walked, &mut list);
                    }
                    children.push([xa, xb, ya, yb]);
                }
            }
        }
        blocks = children;
    }
    // Coarse blocks first, so that a finer one's interpolation of a shared
    // edge (from walked corners nearer the pixel) is the one kept.
    for &[x0, x1, y0, y1] in &smooth {
        let c = [acc[y0 * stride + x0], acc[y0 * stride + x1], acc[y1 * stride + x0], acc[y1 * stride + x1]];
        let (dx, dy) = ((x1 - x0) as f32, (y1 - y0) as f32);
        for y in y0..=y1 {
            let v = if dy > 0.0 { (y - y0) as f32 / dy } else { 0.0 };
            for x in x0..=x1 {
                let p = y * stride + x;
                if walked[p] {
                    continue;
                }
                let u = if dx > 0.0 { (x - x0) as f32 / dx } else { 0.0 };
                let w = [(1.0 - u) * (1.0 - v), u * (1.0 - v), (1.0 - u) * v, u * v];
                let mut out = [0.0f32; 4];
                for (k, o) in out.iter_mut().enumerate() {
                    *o = w[0] * c[0][k] + w[1] * c[1][k] + w[2] * c[2][k] + w[3] * c[3][k];
                }
                acc[p] = out;
            }
        }
    }
    st.rays_interpolated += (0..acc.len()).filter(|&p| ray_of[p] != 0 && !walked[p]).count() as u64;
}

#[cfg(test)]
mod adaptive_tests {
    use super::*;

    /// Runs [`adaptive_fill`] over a `w`×`h` tile whose covered pixels
    /// (`entries(x, y)` > 0 entries) have the colour `colour(x, y)`;
    /// returns the image and the walked pixels.
    fn close(a: [f32; 4], b: [f32; 4]) -> bool {
        (0..4).all(|k| (a[k] - b[k]).abs() < 1e-6)
    }

    fn fill(
        w: usize,
        h: usize,
        tol: f32,
        entries: impl Fn(usize, usize) -> usize,
        colour: impl Fn(usize, usize) -> [f32; 4],
    ) -> (Vec<[f32; 4]>, Vec<u32>, WalkStats) {
        let mut rays = Vec::new();
        let mut next = 0;
        for y in 0..h {
            for x in 0..w {
                let n = entries(x, y);
                if n > 0 {
                    rays.push(((y * w + x) as u32, next, next + n));
                    next += n;
                }
            }
        }
        let mut acc = vec![[0.0f32; 4]; w * h];
        let mut st = WalkStats::default();
        let mut walked = Vec::new();
        let mut walk = |list: &[(u32, usize, usize)], acc: &mut Vec<[f32; 4]>, st: &mut WalkStats| {
            for &(pix, _, _) in list {
                st.rays += 1;
                walked.push(pix);
                acc[pix as usize] = colour(pix as usize % w, pix as usize / w);
            }
        };
        adaptive_fill(&rays, w, h, tol, &mut acc, &mut st, &mut walk);
        (acc, walked, st)
    }

    /// One level's list walked in any order gives the same image and the
    /// same walked rays (the walker may take a list's rays in any order),
    /// and every ray is walked at most once.
    #[test]
    fn the_order_a_list_is_walked_in_changes_nothing() {
        let (w, h) = (21, 18);
        let entries = |x: usize, y: usize| if x * x + y * y < 40 { 0 } else { 1 + (x > 15) as usize };
        let colour = |x: usize, y: usize| {
            let v = if (x, y) == (8, 8) { 1.0 } else { 0.001 * x as f32 + 0.00005 * (y * y) as f32 };
            [v, 0.5 * v, 0.1, 0.3]
        };
        let mut rays = Vec::new();
        for y in 0..h {
            for x in 0..w {
                let n = entries(x, y);
                if n > 0 {
                    rays.push(((y * w + x) as u32, 0, n));
                }
            }
        }
        let run = |reverse: bool| {
            let mut acc = vec![[0.0f32; 4]; w * h];
            let mut st = WalkStats::default();
            let mut walked = Vec::new();
            let mut walk = |list: &[(u32, usize, usize)], acc: &mut Vec<[f32; 4]>, st: &mut WalkStats| {
                let mut order: Vec<_> = list.to_vec();
                if reverse {
                    order.reverse();
                }
                for (pix, _, _) in order {
                    st.rays += 1;
                    walked.push(pix);
                    acc[pix as usize] = colour(pix as usize % w, pix as usize / w);
                }
            };
            adaptive_fill(&rays, w, h, 0.01, &mut acc, &mut st, &mut walk);
            walked.sort_unstable();
            (acc, walked, st)
        };
        let ((a, wa, sa), (b, wb, sb)) = (run(false), run(true));
        assert_eq!(a, b);
        assert_eq!(wa, wb);
        assert!(wa.windows(2).all(|p| p[0] < p[1]), "a ray walked twice");
        assert_eq!((sa.rays, sa.rays_interpolated), (sb.rays, sb.rays_interpolated));
        assert_eq!(sa.rays + sa.rays_interpolated, rays.len() as u64);
        assert!(
            sa.rays_interpolated > 0 && wa.contains(&(8 * w as u32 + 9)) && wa.contains(&(7 * w as u32 + 7)),
            "{sa:?}"
        );
    }

    /// A colour linear in the pixel is interpolated exactly from the
    /// lattice: a 16×16 tile walks its 5×5 lattice rays only.
    #[test]
    fn linear_colour_walks_the_lattice_only() {
        let colour = |x: usize, y: usize| [0.01 * x as f32, 0.02 * y as f32, 0.3, 0.5];
        let (acc, walked, st) = fill(16, 16, 1.0, |_, _| 1, colour);
        assert_eq!(walked.len(), 25);
        assert_eq!((st.rays, st.rays_interpolated), (25, 256 - 25));
        for y in 0..16 {
            for x in 0..16 {
                let (got, want) = (acc[y * 16 + x], colour(x, y));
                assert!((0..4).all(|k| (got[k] - want[k]).abs() < 1e-6), "({x}, {y}): {got:?} vs {want:?}");
            }
        }
        // A ragged tile (13×7: the last lattice column and row closer).
        let (acc, walked, _) = fill(13, 7, 1.0, |_, _| 1, colour);
        assert_eq!(walked.len(), 4 * 3, "lattice 0,4,8,12 × 0,4,6");
        assert!((0..91).all(|p| (acc[p][0] - colour(p % 13, p / 13)[0]).abs() < 1e-6));
    }

    /// A bright pixel on the lattice makes its blocks refine down to single
    /// pixels: every pixel next to it is walked, none smeared.
    #[test]
    fn a_spike_on_the_lattice_is_refined_around() {
        let colour = |x: usize, y: usize| if (x, y) == (8, 4) { [1.0; 4] } else { [0.1, 0.1, 0.1, 0.2] };
        let (acc, walked, _) = fill(16, 16, 0.01, |_, _| 1, colour);
        for y in 0..16 {
            for x in 0..16 {
                assert!(close(acc[y * 16 + x], colour(x, y)), "({x}, {y})");
            }
        }
        for (x, y) in [(7, 3), (9, 5), (7, 5), (8, 3)] {
            assert!(walked.contains(&((y * 16 + x) as u32)), "({x}, {y}) not walked");
        }
    }

    /// Coverage comes from the entries: pixels without a ray stay clear,
    /// and no block is interpolated across a silhouette or a change in the
    /// number of entries (a ray re-entering a non-convex mesh).
    #[test]
    fn silhouettes_and_reentries_are_walked_not_interpolated() {
        let entries = |x: usize, y: usize| {
            if x + y < 9 {
                0
            } else if x > 11 {
                2
            } else {
                1
            }
        };
        let colour = |x: usize, _: usize| [0.5, 0.4, 0.3, if x > 11 { 0.9 } else { 0.6 }];
        let (acc, walked, st) = fill(16, 16, 1.0, entries, colour);
        let covered = (0..256).filter(|&p| entries(p % 16, p / 16) > 0).count() as u64;
        assert_eq!(st.rays + st.rays_interpolated, covered);
        for (p, &got) in acc.iter().enumerate() {
            let (x, y) = (p % 16, p / 16);
            if entries(x, y) == 0 {
                assert_eq!(got, [0.0; 4], "({x}, {y}) has no ray");
                assert!(!walked.contains(&(p as u32)));
            } else {
                assert!(close(got, colour(x, y)), "({x}, {y})");
            }
        }
        assert!(st.rays_interpolated > 0, "smooth blocks away from the edges are interpolated");
    }
}
