//! The face-adjacency ray walker: the CPU renderer whose cost follows the
//! image (pixels × tets along each ray), not the mesh.
//!
//! Per view, each vertex is projected once ([`WalkView`]: pixel position,
//! 1/depth and the scalar in f32; the f64 position is recomputed for exact
//! decisions); there is no per-tet setup and no visibility sort. The entry
//! faces — the boundary of the tets the transfer function does not cull
//! ([`WalkMesh::entry_faces`]: the mesh boundary, and faces shared with a
//! culled tet) — that face the eye are binned into screen tiles. Each tile
//! (one rayon task) rasterizes its faces into per-pixel entry lists ordered
//! by depth, so a ray that leaves a non-convex mesh (a curvilinear grid, a
//! scan with a peeled hull) or the visible part of a culled one re-enters
//! it correctly, empty space costing no steps, and walks every pixel's ray
//! from tet to tet by face adjacency, front to back:
//!
//! * the ray entered tet t through face f; the exit is one of the three
//!   faces around the opposite vertex v, found from the sides of the ray
//!   against the three edges from v ([`edge::side`]: f32 with an exact
//!   fallback, exactly antisymmetric, so neighbours agree bit for bit). The signed areas of a tet's four projected faces cancel at every
//!   point, so with exact, consistently perturbed signs an entry face that
//!   contains the centre always has an exit face that does too;
//! * the exit point's perspective-correct barycentrics (edge-function
//!   values times 1/depth) give the exit depth and scalar; the segment
//!   (Sf, Sb, l) goes into a batch for the shader
//!   ([`SegmentShader::shade_batch`]);
//! * batches are shaded, lit (lighting and silhouettes at the segment's
//!   midpoint, the gradients interpolated like the scalar) and composited
//!   front to back; the ray stops once α reaches
//!   [`RasterOptions::opaque_alpha`], as projected tetrahedra do.
//!
//! On x86-64 CPUs with AVX2, frames without lighting or a bivariate method
//! (near-clipped views and adaptive sampling included) are walked by
//! packets (`walk::packet`): eight rays a step in vector lanes, each lane
//! the scalar step's operations in the same order and precision, a
//! packet's segments shaded in one batch; the image is the scalar walk's,
//! bit for bit ([`RasterOptions::walk_packets`]).
//!
//! A link whose neighbour does not point back (a non-manifold spot) ends
//! that run and the ray continues from its next entry; a run longer than
//! [`WalkView::max_steps`] is cut. Both are counted in [`WalkStats`], never
//! a hang. Each pixel depends only on its own ray, so the image does not
//! depend on the thread count.
//!
//! A perspective view whose near plane cuts the mesh (the eye inside it or
//! beside it) is walked in homogeneous pixel coordinates ([`hom`]): the same
//! walk, entries met in front of the eye only, rays starting in the eye's
//! own tet, segments clipped at the near depth. What the walker cannot draw
//! ([`WalkView::unsupported`]: more tets than its links address, the eye on
//! a face's plane) [`crate::Renderer`] draws by projected tetrahedra.

pub mod edge;
pub mod hom;
#[cfg(target_arch = "x86_64")]
mod packet;
mod prefetch;
mod ray;
mod view;

pub(crate) use ray::*;
pub use view::WalkView;
pub(crate) use view::*;

use crate::camera::Camera;
use crate::image::Image;
use crate::project::Frame;
use crate::raster::RasterOptions;
use crate::scene::Scene;
use edge::{EdgeCounters, PixelPositions, WalkVertex};
use glam::DVec3;
use hom::HomVertex;
use rayon::prelude::*;
use robust::{orient2d, Coord};
use std::sync::atomic::{AtomicUsize, Ordering};
use tet_mesh::{FACE_OUTWARD, NO_NEIGHBOR};
use tet_preint::{Rgba32, SegmentBatch, SegmentShader, BATCH};

/// Whether a face whose outward normal points at the eye passes the
/// centres it covers on their left (counter-clockwise in pixel
/// coordinates). Camera x is right and y up with the eye looking along
/// +forward = −(right × up), so an outward normal towards the eye is
/// counter-clockwise in (right, up); pixel rows run down, which mirrors it.
pub const FRONT_IS_LEFT: bool = false;
pub(crate) const BACK_IS_LEFT: bool = !FRONT_IS_LEFT;

/// `links[t][f]` across a boundary face.
pub(crate) const LINK_BOUNDARY: u32 = u32::MAX;
/// `links[t][f]` for a link whose neighbour does not list `t` (a
/// non-manifold spot or a corrupted adjacency).
pub(crate) const LINK_BROKEN: u32 = u32::MAX - 1;
/// Rays a tile walks at once by default ([`RasterOptions::walk_interleave`]).
pub const WALK_LANES: usize = 8;
/// Most tets the packed links can address (2 bits hold the face).
pub const MAX_WALK_TETS: usize = (u32::MAX / 4 - 1) as usize;

/// For entry face `f_in` and candidate exit face `f`: the two local vertices
/// (x, y) other than `f_in` and `f` such that face `f` in outward order
/// reads (…, v, x, y, …) cyclically with v = local vertex `f_in`.
pub(crate) const EXIT_EDGES: [[[usize; 2]; 4]; 4] = exit_edges();

/// `EXIT_CANDIDATES[f_in]`: the three faces around v (local vertex f_in)
/// that the ray can leave by, each with its [`EXIT_EDGES`] pair (x, y):
/// the face reads (v, x, y) in outward order, up to rotation.
pub(crate) const EXIT_CANDIDATES: [[(usize, usize, usize); 3]; 4] = {
    let mut out = [[(0usize, 0usize, 0usize); 3]; 4];
    let mut f_in = 0;
    while f_in < 4 {
        let (mut f, mut k) = (0, 0);
        while f < 4 {
            if f != f_in {
                let [x, y] = EXIT_EDGES[f_in][f];
                out[f_in][k] = (f, x, y);
                k += 1;
            }
            f += 1;
        }
        f_in += 1;
    }
    out
};

/// `EXIT_BY_SIDES[f_in][bits]`: the first of [`EXIT_CANDIDATES`]`[f_in]`
/// the sides `bits` (bit k set where the centre passes left of v → local
/// vertex k) leave by, packed as `f | x << 2 | y << 4`, or [`NO_EXIT`].
pub(crate) const EXIT_BY_SIDES: [[u8; 16]; 4] = {
    let mut out = [[NO_EXIT; 16]; 4];
    let mut f_in = 0;
    while f_in < 4 {
        let mut bits = 0;
        while bits < 16 {
            let mut c = 0;
            while c < 3 {
                let (f, x, y) = EXIT_CANDIDATES[f_in][c];
                if (bits >> x & 1 == 1) == BACK_IS_LEFT && (bits >> y & 1 == 1) != BACK_IS_LEFT {
                    out[f_in][bits] = (f | x << 2 | y << 4) as u8;
                    break;
                }
                c += 1;
            }
            bits += 1;
        }
        f_in += 1;
    }
    out
};
pub(crate) const NO_EXIT: u8 = u8::MAX;

pub(crate) const fn exit_edges() -> [[[usize; 2]; 4]; 4] {
    let mut out = [[[0usize; 2]; 4]; 4];
    let mut f_in = 0;
    while f_in < 4 {
        let mut f = 0;
        while f < 4 {
            if f != f_in {
                let fv = FACE_OUTWARD[f];
                let mut j = 0;
                while fv[j] != f_in {
                    j += 1;
                }
                out[f_in][f] = [fv[(j + 1) % 3], fv[(j + 2) % 3]];
            }
            f += 1;
        }
        f_in += 1;
    }
    out
}

/// One tet as a step reads it: its four walk vertex ids and its four links,
/// each packed as `neighbour · 4 + the neighbour's face that points back`.
/// 32 bytes, aligned: a step reads one cache line, and one prefetch of a
/// neighbour's record brings both halves.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
#[repr(C, align(32))]
pub struct WalkTet {
    pub verts: [u32; 4],
    pub links: [u32; 4],
}

/// Faces rays may enter by (`tet * 4 + face`, walk order) with each
/// face's three walk vertex ids in its outward order: binning a view and
/// rasterizing a tile's entries read the ids here, in face order, instead
/// of each face's tet record (on meshes far larger than the caches a miss
/// a face).
#[derive(Debug, Clone, Default, PartialEq, Eq)]
pub struct EntryFaces {
    pub(crate) packed: Vec<u32>,
    pub(crate) verts: Vec<[u32; 3]>,
}

impl EntryFaces {
    fn of(tets: &[WalkTet], packed: Vec<u32>) -> EntryFaces {
        let verts = packed
            .par_iter()
            .map(|&p| {
                let (t, f) = ((p / 4) as usize, (p % 4) as usize);
                FACE_OUTWARD[f].map(|k| tets[t].verts[k])
            })
            .collect();
        EntryFaces { packed, verts }
    }

    fn memory_bytes(&self) -> usize {
        self.packed.len() * 16
    }
}

/// What the walker keeps of a scene across views: the tets renumbered along
/// a Morton curve of their centroids and the vertices in order of first use
/// by them (a tile's rays then touch a few hundred pages, not one page a
/// step, on meshes far larger than the caches), each tet one [`WalkTet`];
/// the boundary faces; the scalars and, when the scene has them, f32
/// gradients (lighting, bivariate methods) in the new vertex order.
#[derive(Debug, Clone)]
pub struct WalkMesh {
    /// Tets in walk order: walk vertex ids and links.
    pub(crate) tets: Vec<WalkTet>,
    /// `scene_tet[t]`: the scene's id of walk tet t.
    pub(crate) scene_tet: Vec<u32>,
    /// `scene_vertex[v]`: the scene's id of walk vertex v.
    pub(crate) scene_vertex: Vec<u32>,
    /// Positions (relative to the scene's centre) and scalars in walk
    /// order: a view reads them front to back.
    pub(crate) pos_rel: Vec<[f64; 3]>,
    pub(crate) scalar: Vec<f32>,
    pub(crate) boundary: EntryFaces,
    pub(crate) broken_links: usize,
    pub(crate) grads: Option<Vec<[f32; 3]>>,
    pub(crate) grad_mag: Option<Vec<f32>>,
    /// The scene's centre (positions are relative to it) and its shadow
    /// field (scene vertex ids), for lighting.
    pub(crate) centre_in_world: DVec3,
    pub(crate) shadows: Option<std::sync::Arc<crate::ShadowField>>,
}

/// Interleaves the low 21 bits of x, y, z (Morton order).
pub(crate) fn morton3(x: u64, y: u64, z: u64) -> u64 {
    fn split(mut v: u64) -> u64 {
        v &= 0x1f_ffff;
        v = (v | v << 32) & 0x1f00000000ffff;
        v = (v | v << 16) & 0x1f0000ff0000ff;
        v = (v | v << 8) & 0x100f00f00f00f00f;
        v = (v | v << 4) & 0x10c30c30c30c30c3;
        (v | v << 2) & 0x1249249249249249
    }
    split(x) | split(y) << 1 | split(z) << 2
}

impl WalkMesh {
    pub fn new(scene: &Scene) -> WalkMesh {
        let nbs = scene.neighbors();
        let stets = scene.tets();
        let pos = scene.positions_rel();
        // Morton keys of the centroids over the bounding box (ties by id,
        // so the order is deterministic).
        let (lo, hi) = scene.bounds();
        let c = scene.centre_in_world();
        let lo_rel = [lo[0] - c.x, lo[1] - c.y, lo[2] - c.z];
        let scale: [f64; 3] = std::array::from_fn(|a| {
            let ext = hi[a] - lo[a];
            if ext > 0.0 {
                2_097_151.0 / ext
            } else {
                0.0
            }
        });
        let mut keyed: Vec<(u64, u32)> = stets
            .par_iter()
            .enumerate()
            .map(|(t, tet)| {
                let q: [u64; 3] = std::array::from_fn(|a| {
                    let m = tet.iter().map(|&v| pos[v as usize][a]).sum::<f64>() * 0.25;
                    ((m - lo_rel[a]) * scale[a]).clamp(0.0, 2_097_151.0) as u64
                });
                (morton3(q[0], q[1], q[2]), t as u32)
            })
            .collect();
        keyed.par_sort_unstable();
        let scene_tet: Vec<u32> = keyed.into_iter().map(|(_, t)| t).collect();
        let mut walk_of_tet = vec![0u32; stets.len()];
        for (w, &t) in scene_tet.iter().enumerate() {
            walk_of_tet[t as usize] = w as u32;
        }
        let mut walk_of_vertex = vec![u32::MAX; pos.len()];
        let mut scene_vertex = Vec::with_capacity(pos.len());
        for &t in &scene_tet {
            for &v in &stets[t as usize] {
                if walk_of_vertex[v as usize] == u32::MAX {
                    walk_of_vertex[v as usize] = scene_vertex.len() as u32;
                    scene_vertex.push(v);
                }
            }
        }
        // One pass builds each record whole: no arrays of vertex ids and of
        // links beside the records (32 bytes a tet less at the peak).
        let tets: Vec<WalkTet> = scene_tet
            .par_iter()
            .map(|&t| WalkTet {
                verts: stets[t as usize].map(|v| walk_of_vertex[v as usize]),
                // Scenes larger than the packing can address are walked as
                // if every face were a boundary: `Renderer` draws them by PT
                // instead (`WalkView::unsupported`).
                links: nbs[t as usize].map(|n| {
                    if n == NO_NEIGHBOR || nbs.len() > MAX_WALK_TETS {
                        return LINK_BOUNDARY;
                    }
                    match nbs[n as usize].iter().position(|&m| m == t) {
                        Some(f) => walk_of_tet[n as usize] * 4 + f as u32,
                        None => LINK_BROKEN,
                    }
                }),
            })
            .collect();
        drop(walk_of_tet);
        let broken_links = tets.iter().map(|r| r.links.iter().filter(|&&x| x == LINK_BROKEN).count()).sum();
        let boundary = EntryFaces::of(
            &tets,
            tets.iter()
                .enumerate()
                .flat_map(|(t, r)| {
                    (0..4).filter(move |&f| r.links[f] == LINK_BOUNDARY).map(move |f| (t * 4 + f) as u32)
                })
                .collect(),
        );
        let by_vertex = |v: &[f64]| -> Vec<f32> { scene_vertex.iter().map(|&i| v[i as usize] as f32).collect() };
        WalkMesh {
            tets,
            boundary,
            broken_links,
            grads: scene.gradients().map(|g| scene_vertex.iter().map(|&i| g[i as usize].map(|c| c as f32)).collect()),
            grad_mag: scene.gradient_magnitudes().map(by_vertex),
            centre_in_world: scene.centre_in_world(),
            shadows: scene.shadows().cloned(),
            pos_rel: scene_vertex.iter().map(|&v| pos[v as usize]).collect(),
            scalar: by_vertex(scene.scalar()),
            scene_tet,
            scene_vertex,
        }
    }

    /// Takes the scene's scalar again (a time step; the links, order and
    /// positions stay). The scene must be the one this mesh was built from,
    /// without gradients (a scene whose scalar changed has none).
    pub fn set_scalar(&mut self, scene: &Scene) {
        let s = scene.scalar();
        self.scalar = self.scene_vertex.iter().map(|&i| s[i as usize] as f32).collect();
        self.set_gradients(scene);
        self.shadows = None;
    }

    /// Takes the scene's gradients (and magnitudes) again, in walk order.
    pub fn set_gradients(&mut self, scene: &Scene) {
        let sv = &self.scene_vertex;
        self.grads = scene.gradients().map(|g| sv.iter().map(|&i| g[i as usize].map(|c| c as f32)).collect());
        self.grad_mag = scene.gradient_magnitudes().map(|m| sv.iter().map(|&i| m[i as usize] as f32).collect());
    }

    /// Takes the scene's shadow field again (lights or TF changed).
    pub fn set_shadows(&mut self, scene: &Scene) {
        self.shadows = scene.shadows().cloned();
    }

    /// The faces through which rays enter the tets marked `visible` (walk
    /// order; `None`: all): faces of visible tets on the mesh boundary or
    /// shared with a culled tet. Rays then walk visible tets only: a run
    /// ends where it leaves them, and the next entry in depth order picks
    /// the ray up where it meets them again, so empty (culled) space costs
    /// no steps at all.
    pub fn entry_faces(&self, visible: Option<&[bool]>) -> EntryFaces {
        let Some(vis) = visible else { return self.boundary.clone() };
        let packed = self
            .tets
            .par_iter()
            .enumerate()
            .filter(|(t, _)| vis[*t])
            .flat_map_iter(|(t, rec)| {
                let l = rec.links;
                (0..4)
                    .filter(move |&f| l[f] == LINK_BOUNDARY || (l[f] < LINK_BROKEN && !vis[(l[f] / 4) as usize]))
                    .map(move |f| (t * 4 + f) as u32)
            })
            .collect();
        EntryFaces::of(&self.tets, packed)
    }

    /// A per-scene-tet mask (a [`crate::CullMask`]'s) in walk order.
    pub fn to_walk_order(&self, per_scene_tet: &[bool]) -> Vec<bool> {
        self.scene_tet.par_iter().map(|&t| per_scene_tet[t as usize]).collect()
    }

    /// Links whose neighbour does not point back (non-manifold spots).
    pub fn broken_links(&self) -> usize {
        self.broken_links
    }

    /// Boundary faces (`tet * 4 + face`).
    pub fn boundary_faces(&self) -> &[u32] {
        &self.boundary.packed
    }

    /// Bytes held beyond the scene.
    pub fn memory_bytes(&self) -> usize {
        self.tets.len() * std::mem::size_of::<WalkTet>()
            + self.scene_tet.len() * 4
            + self.scene_vertex.len() * 4
            + self.pos_rel.len() * 24
            + self.scalar.len() * 4
            + self.boundary.memory_bytes()
            + self.grads.as_ref().map_or(0, |g| g.len() * 12)
            + self.grad_mag.as_ref().map_or(0, |g| g.len() * 4)
    }
}

/// Counters of one walked frame.
#[derive(Debug, Clone, Copy, Default, PartialEq, serde::Serialize)]
pub struct WalkStats {
    /// Entry faces facing the eye (the entries' candidates).
    pub front_faces: usize,
    /// Pixels whose ray meets the mesh and was walked.
    pub rays: u64,
    /// Pixels whose ray meets the mesh but whose colour was interpolated
    /// from walked neighbours ([`RasterOptions::walk_adaptive`]).
    pub rays_interpolated: u64,
    /// Runs walked (a ray re-entering a non-convex mesh walks several).
    pub runs: u64,
    /// Tets crossed (visible ones only: culled tets are never entered).
    pub crossings: u64,
    /// Segments shaded and composited (non-culled, of positive length,
    /// before the pixel was opaque): what projected tetrahedra call fragments.
    pub fragments: u64,
    /// Edge tests the f32 value could not call (decided exactly).
    pub exact_tests: u64,
    /// Runs ended at a link whose neighbour does not point back.
    pub non_manifold: u64,
    /// Runs cut at [`WalkView::max_steps`].
    pub step_limit: u64,
    /// Rays stopped early at `opaque_alpha`.
    pub terminated: u64,
    /// Rays walked eight at a time in SIMD lanes ([`RasterOptions::walk_packets`]).
    pub packet_rays: u64,
    /// The near plane cut the mesh: walked in homogeneous coordinates,
    /// segments clipped at the near depth.
    pub near_clipped: bool,
    /// Near-clipped views: rays started in the (visible) tet holding the eye.
    pub eye_inside: bool,
    pub walk_seconds: f64,
}

impl WalkStats {
    pub(crate) fn add(&mut self, o: &WalkStats) {
        self.rays += o.rays;
        self.rays_interpolated += o.rays_interpolated;
        self.runs += o.runs;
        self.crossings += o.crossings;
        self.fragments += o.fragments;
        self.exact_tests += o.exact_tests;
        self.non_manifold += o.non_manifold;
        self.step_limit += o.step_limit;
        self.terminated += o.terminated;
        self.packet_rays += o.packet_rays;
    }

    /// Runs that ended abnormally (non-manifold links or the step bound).
    pub fn failures(&self) -> u64 {
        self.non_manifold + self.step_limit
    }
}

/// Renders one view by walking every pixel's ray. `visible` (per tet in
/// walk order, [`WalkMesh::to_walk_order`] of a [`crate::CullMask`]) marks
/// the tets rays may cross; `view` must have been binned with the matching
/// [`WalkMesh::entry_faces`], through which rays enter the visible tets.
/// `progress(done, total)` is called as tiles finish.
pub fn walk_frame(
    mesh: &WalkMesh,
    view: &WalkView,
    visible: Option<&[bool]>,
    shader: &dyn SegmentShader,
    opts: &RasterOptions,
    progress: &(dyn Fn(usize, usize) + Sync),
) -> (Image, WalkStats) {
    let start = std::time::Instant::now();
    let (w, h) = (view.frame.width, view.frame.height);
    let mut img = Image::new(w, h);
    let mut stats = WalkStats {
        front_faces: view.front_faces,
        near_clipped: view.near_clipped,
        eye_inside: view.eye_tet.is_some_and(|t| visible.is_none_or(|vis| vis[t as usize])),
        ..Default::default()
    };
    if view.unsupported.is_some() {
        return (img, stats);
    }
    let n_tiles = view.tiles_x * view.tiles_y;
    let lit_shadows = mesh.shadows.as_deref().filter(|_| opts.shading.wants_shadows());
    let ctx = WalkCtx {
        mesh,
        view,
        visible,
        shader,
        opts,
        want_grad_mag: shader.method().is_bivariate() && mesh.grad_mag.is_some(),
        lit: opts.shading.is_active() && mesh.grads.is_some(),
        lit_shadows,
        lit_position: opts.shading.needs_position() || lit_shadows.is_some_and(|f| f.has_maps()),
        lanes: opts.walk_interleave.unwrap_or(WALK_LANES).clamp(1, 64),
        prefetch: opts.walk_prefetch,
        packets: opts.walk_packets,
        adaptive: opts.walk_adaptive.filter(|t| t.is_finite() && *t >= 0.0),
    };
    let done = AtomicUsize::new(0);
    let tiles: Vec<(Vec<[f32; 4]>, WalkStats)> = (0..n_tiles)
        .into_par_iter()
        .map(|ti| {
            let out = ctx.tile(ti);
            progress(done.fetch_add(1, Ordering::Relaxed) + 1, n_tiles);
            out
        })
        .collect();
    let px = img.pixels_mut();
    let tile = view.tile;
    for (ti, (acc, st)) in tiles.into_iter().enumerate() {
        stats.add(&st);
        let (i, j) = ((ti % view.tiles_x) as u32, (ti / view.tiles_x) as u32);
        let (x0, y0) = (i * tile, j * tile);
        let tw = ((i + 1) * tile).min(w) - x0;
        for (r, row) in acc.chunks_exact(tw as usize).enumerate() {
            let s = (y0 as usize + r) * w as usize + x0 as usize;
            px[s..s + tw as usize].copy_from_slice(row);
        }
    }
    stats.walk_seconds = start.elapsed().as_secs_f64();
    (img, stats)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::project::ViewGeometry;
    use crate::ViewSpec;

    #[test]
    fn exit_edge_table_reads_each_face_around_v() {
        for (f_in, row) in EXIT_EDGES.iter().enumerate() {
            for (f, &[x, y]) in row.iter().enumerate() {
                if f == f_in {
                    continue;
                }
                let mut s = [f_in, x, y, f];
                s.sort();
                assert_eq!(s, [0, 1, 2, 3]);
            }
        }
    }

    /// A walk to the eye from any tet of a convex mesh ends at the tet the
    /// scan of every tet finds, for eyes inside it at many places.
    #[test]
    fn the_walk_to_the_eye_finds_the_scans_tet_from_anywhere() {
        // A 5×5×5-cell grid, each cube in six tets (Kuhn), jittered.
        let n = 6usize;
        let id = |i: usize, j: usize, k: usize| (i + n * (j + n * k)) as u32;
        let mut rng = tet_mesh::SplitMix64(3);
        let mut pts = Vec::new();
        for k in 0..n {
            for j in 0..n {
                for i in 0..n {
                    let jit = |c: usize, r: f64| c as f64 + if c > 0 && c < n - 1 { 0.2 * (r - 0.5) } else { 0.0 };
                    pts.push([jit(i, rng.next_f64()), jit(j, rng.next_f64()), jit(k, rng.next_f64())]);
                }
            }
        }
        let mut tets = Vec::new();
        for k in 0..n - 1 {
            for j in 0..n - 1 {
                for i in 0..n - 1 {
                    for p in [[0, 1, 2], [0, 2, 1], [1, 0, 2], [1, 2, 0], [2, 0, 1], [2, 1, 0]] {
                        let mut c = [i, j, k];
                        let mut t = [id(c[0], c[1], c[2]); 4];
                        for (s, &axis) in p.iter().enumerate() {
                            c[axis] += 1;
                            t[s + 1] = id(c[0], c[1], c[2]);
                        }
                        let q = t.map(|v| glam::DVec3::from(pts[v as usize]));
                        if (q[1] - q[0]).cross(q[2] - q[0]).dot(q[3] - q[0]) < 0.0 {
                            t.swap(2, 3);
                        }
                        tets.push(t);
                    }
                }
            }
        }
        let scalar = pts.iter().map(|p| p[0]).collect();
        let scene = Scene::new(&pts, tets, scalar).unwrap();
        let mesh = WalkMesh::new(&scene);
        let mut checked = 0;
        for e in 0..40 {
            let f = |a: usize| 0.6 + 3.8 * (((e * 7 + a * 13) % 41) as f64 / 40.0);
            let mut spec = ViewSpec::framing([0.0; 3], [5.0; 3], [16, 16]);
            spec.position = [f(0), f(1), f(2)];
            spec.focal_point = [f(2), f(0), 5.5];
            let camera = Camera::new(&spec).unwrap();
            let view = WalkView::new(&scene, &mesh, &camera, 8);
            let Some(scan) = view.eye_tet else { continue };
            for start in [0, scan, mesh.tets.len() as u32 / 2, mesh.tets.len() as u32 - 1] {
                assert_eq!(view::walk_to_eye(&mesh, &view.hom, start), Some(Ok(scan)), "eye {e}, from {start}");
            }
            checked += 1;
        }
        assert!(checked >= 30, "{checked}");
    }

    /// The projected orientation of a face the eye sees from outside is
    /// the one [`FRONT_IS_LEFT`] states, for perspective and parallel views.
    #[test]
    fn front_faces_have_the_stated_orientation() {
        let pts = [[0.0, 0.0, 0.0], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]];
        let scene = Scene::new(&pts, vec![[0, 1, 2, 3]], vec![0.0; 4]).unwrap();
        for parallel in [false, true] {
            for az in [10.0, 100.0, 200.0, 300.0] {
                let mut spec = ViewSpec::framing([0.0; 3], [1.0; 3], [64, 64]).orbit(az, 25.0, 1.0);
                spec.parallel = parallel;
                let camera = Camera::new(&spec).unwrap();
                let vg = ViewGeometry::new(&scene, &camera);
                for (f, fv) in FACE_OUTWARD.iter().enumerate() {
                    let p = fv.map(|k| vg.px[k]);
                    let o = (p[1][0] - p[0][0]) * (p[2][1] - p[0][1]) - (p[1][1] - p[0][1]) * (p[2][0] - p[0][0]);
                    if vg.face_mask[0] & (1 << f) != 0 {
                        assert_eq!(o > 0.0, FRONT_IS_LEFT, "parallel {parallel} az {az} face {f}");
                    } else if vg.face_mask[0] & (1 << (4 + f)) != 0 {
                        assert_eq!(o > 0.0, BACK_IS_LEFT, "parallel {parallel} az {az} face {f}");
                    }
                }
            }
        }
    }
}
