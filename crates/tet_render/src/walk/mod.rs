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
mod prefetch;

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
const BACK_IS_LEFT: bool = !FRONT_IS_LEFT;

/// `links[t][f]` across a boundary face.
const LINK_BOUNDARY: u32 = u32::MAX;
/// `links[t][f]` for a link whose neighbour does not list `t` (a
/// non-manifold spot or a corrupted adjacency).
const LINK_BROKEN: u32 = u32::MAX - 1;
/// Most tets the packed links can address (2 bits hold the face).
pub const MAX_WALK_TETS: usize = (u32::MAX / 4 - 1) as usize;

/// For entry face `f_in` and candidate exit face `f`: the two local vertices
/// (x, y) other than `f_in` and `f` such that face `f` in outward order
/// reads (…, v, x, y, …) cyclically with v = local vertex `f_in`.
const EXIT_EDGES: [[[usize; 2]; 4]; 4] = exit_edges();

/// `EXIT_CANDIDATES[f_in]`: the three faces around v (local vertex f_in)
/// that the ray can leave by, each with its [`EXIT_EDGES`] pair (x, y):
/// the face reads (v, x, y) in outward order, up to rotation.
const EXIT_CANDIDATES: [[(usize, usize, usize); 3]; 4] = {
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
const EXIT_BY_SIDES: [[u8; 16]; 4] = {
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
const NO_EXIT: u8 = u8::MAX;

const fn exit_edges() -> [[[usize; 2]; 4]; 4] {
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

/// What the walker keeps of a scene across views: the tets renumbered along
/// a Morton curve of their centroids and the vertices in order of first use
/// by them (a tile's rays then touch a few hundred pages, not one page a
/// step, on meshes far larger than the caches), each tet one [`WalkTet`];
/// the boundary faces; the scalars and, when the scene has them, f32
/// gradients (lighting, bivariate methods) in the new vertex order.
#[derive(Debug, Clone)]
pub struct WalkMesh {
    /// Tets in walk order: walk vertex ids and links.
    tets: Vec<WalkTet>,
    /// `scene_tet[t]`: the scene's id of walk tet t.
    scene_tet: Vec<u32>,
    /// `scene_vertex[v]`: the scene's id of walk vertex v.
    scene_vertex: Vec<u32>,
    /// Positions (relative to the scene's centre) and scalars in walk
    /// order: a view reads them front to back.
    pos_rel: Vec<[f64; 3]>,
    scalar: Vec<f32>,
    boundary: Vec<u32>,
    broken_links: usize,
    grads: Option<Vec<[f32; 3]>>,
    grad_mag: Option<Vec<f32>>,
}

/// Interleaves the low 21 bits of x, y, z (Morton order).
fn morton3(x: u64, y: u64, z: u64) -> u64 {
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
        let verts: Vec<[u32; 4]> =
            scene_tet.par_iter().map(|&t| stets[t as usize].map(|v| walk_of_vertex[v as usize])).collect();
        // Scenes larger than the packing can address are walked as if
        // every face were a boundary: `Renderer` draws them by PT instead
        // (`WalkView::unsupported`).
        let links: Vec<[u32; 4]> = scene_tet
            .par_iter()
            .map(|&t| {
                nbs[t as usize].map(|n| {
                    if n == NO_NEIGHBOR || nbs.len() > MAX_WALK_TETS {
                        return LINK_BOUNDARY;
                    }
                    match nbs[n as usize].iter().position(|&m| m == t) {
                        Some(f) => walk_of_tet[n as usize] * 4 + f as u32,
                        None => LINK_BROKEN,
                    }
                })
            })
            .collect();
        let broken_links = links.iter().map(|l| l.iter().filter(|&&x| x == LINK_BROKEN).count()).sum();
        let boundary = links
            .iter()
            .enumerate()
            .flat_map(|(t, l)| (0..4).filter(move |&f| l[f] == LINK_BOUNDARY).map(move |f| (t * 4 + f) as u32))
            .collect();
        let by_vertex = |v: &[f64]| -> Vec<f32> { scene_vertex.iter().map(|&i| v[i as usize] as f32).collect() };
        let tets = verts.into_par_iter().zip(links).map(|(verts, links)| WalkTet { verts, links }).collect();
        WalkMesh {
            tets,
            boundary,
            broken_links,
            grads: scene.gradients().map(|g| scene_vertex.iter().map(|&i| g[i as usize].map(|c| c as f32)).collect()),
            grad_mag: scene.gradient_magnitudes().map(by_vertex),
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
        self.grads = None;
        self.grad_mag = None;
    }

    /// The faces through which rays enter the tets marked `visible` (walk
    /// order; `None`: all): faces of visible tets on the mesh boundary or
    /// shared with a culled tet. Rays then walk visible tets only: a run
    /// ends where it leaves them, and the next entry in depth order picks
    /// the ray up where it meets them again, so empty (culled) space costs
    /// no steps at all.
    pub fn entry_faces(&self, visible: Option<&[bool]>) -> Vec<u32> {
        let Some(vis) = visible else { return self.boundary.clone() };
        self.tets
            .par_iter()
            .enumerate()
            .filter(|(t, _)| vis[*t])
            .flat_map_iter(|(t, rec)| {
                let l = rec.links;
                (0..4)
                    .filter(move |&f| l[f] == LINK_BOUNDARY || (l[f] < LINK_BROKEN && !vis[(l[f] / 4) as usize]))
                    .map(move |f| (t * 4 + f) as u32)
            })
            .collect()
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
        &self.boundary
    }

    /// Bytes held beyond the scene.
    pub fn memory_bytes(&self) -> usize {
        self.tets.len() * std::mem::size_of::<WalkTet>()
            + self.scene_tet.len() * 4
            + self.scene_vertex.len() * 4
            + self.pos_rel.len() * 24
            + self.scalar.len() * 4
            + self.boundary.len() * 4
            + self.grads.as_ref().map_or(0, |g| g.len() * 12)
            + self.grad_mag.as_ref().map_or(0, |g| g.len() * 4)
    }
}

/// One view for the walker: every vertex projected once, and the
/// front-facing boundary faces binned into tiles.
#[derive(Debug, Clone)]
pub struct WalkView {
    frame: Frame,
    verts: Vec<WalkVertex>,
    /// The near plane cuts the mesh: the view is walked in homogeneous
    /// coordinates (`hom`; `verts` is empty).
    near_clipped: bool,
    hom: Vec<HomVertex>,
    /// Near-clipped views: the tet holding the eye (walk order).
    eye_tet: Option<u32>,
    /// Bounds |x| and |y| of every projected vertex and pixel centre.
    k_view: f32,
    tile: u32,
    tiles_x: usize,
    tiles_y: usize,
    /// Entry faces facing the eye, per tile (CSR: `bin_start[i]..bin_start[i + 1]`).
    bin_start: Vec<u32>,
    bin_faces: Vec<u32>,
    front_faces: usize,
    max_steps: u32,
    unsupported: Option<String>,
}

impl WalkView {
    /// Projects the scene's vertices for `camera` and bins its front
    /// boundary faces into tiles of `tile` pixels.
    pub fn new(scene: &Scene, mesh: &WalkMesh, camera: &Camera, tile: u32) -> WalkView {
        Self::recycle(None, scene, mesh, camera, tile, &mesh.boundary)
    }

    /// [`WalkView::new`] reusing the buffers of an earlier view (a camera
    /// moving every frame would otherwise fault in fresh pages for every
    /// vertex array each frame).
    /// `entry_faces` are the faces rays may enter by
    /// ([`WalkMesh::entry_faces`]).
    pub fn recycle(
        old: Option<WalkView>,
        scene: &Scene,
        mesh: &WalkMesh,
        camera: &Camera,
        tile: u32,
        entry_faces: &[u32],
    ) -> WalkView {
        let (mut old_verts, mut old_hom) = old.map_or((Vec::new(), Vec::new()), |v| (v.verts, v.hom));
        let frame = Frame::new(camera, scene.centre_in_world());
        let tile = tile.clamp(4, 1024);
        let (w, h) = (frame.width, frame.height);
        let (tiles_x, tiles_y) = (w.div_ceil(tile) as usize, h.div_ceil(tile) as usize);
        let max_steps = (scene.num_tets() as u64 + 16).min(1 << 22) as u32;
        let p_max = w.max(h) as f32 + 1.0;
        let mut view = WalkView {
            frame,
            verts: Vec::new(),
            near_clipped: false,
            hom: Vec::new(),
            eye_tet: None,
            k_view: p_max,
            tile,
            tiles_x,
            tiles_y,
            bin_start: vec![0; tiles_x * tiles_y + 1],
            bin_faces: Vec::new(),
            front_faces: 0,
            max_steps,
            unsupported: None,
        };
        if scene.num_tets() > MAX_WALK_TETS {
            view.unsupported =
                Some(format!("{} tets: the walker's links address at most {MAX_WALK_TETS}", scene.num_tets()));
            return view;
        }
        // One pass over the vertices in walk order: pixel position, w and
        // the scalar. A vertex nearer than the near plane (perspective)
        // switches the view to homogeneous coordinates; one projecting to
        // no finite pixel marks it.
        let parallel = frame.parallel;
        let near = frame.near_depth;
        if !parallel
            && mesh.pos_rel.par_iter().any(|&p| frame.to_cam(p)[2].partial_cmp(&near).is_none_or(|o| o.is_lt()))
        {
            old_hom.resize(mesh.pos_rel.len(), HomVertex::default());
            old_hom.par_iter_mut().zip(mesh.pos_rel.par_iter()).zip(mesh.scalar.par_iter()).for_each(
                |((out, &p), &scalar)| {
                    let c = frame.to_cam(p);
                    // x_px = (x_cam / depth − bx) / ax, times the depth.
                    *out = HomVertex {
                        x_hom: ((c[0] - frame.bx * c[2]) / frame.ax) as f32,
                        y_hom: ((c[1] - frame.by * c[2]) / frame.ay) as f32,
                        w_depth: c[2] as f32,
                        scalar,
                    };
                },
            );
            view.hom = old_hom;
            view.near_clipped = true;
            if let Some(i) = view.hom.par_iter().position_first(|v| !(v.x_hom.abs() < 1e30 && v.y_hom.abs() < 1e30)) {
                view.unsupported =
                    Some(format!("vertex {} projects outside the representable range", mesh.scene_vertex[i]));
                return view;
            }
            // The eye's tet: the first (walk order) whose four faces all
            // face away from it, decided on the walk's own coordinates.
            let located: Vec<(usize, Option<bool>)> = mesh
                .tets
                .par_iter()
                .enumerate()
                .map(|(t, rec)| (t, hom::holds_eye(&view.hom, rec.verts)))
                .filter(|(_, h)| *h != Some(false))
                .collect();
            if let Some((t, _)) = located.iter().find(|(_, h)| h.is_none()) {
                view.unsupported = Some(format!(
                    "the eye lies on the plane of a face of tet {} (no tet holds it strictly)",
                    mesh.scene_tet[*t]
                ));
                return view;
            }
            view.eye_tet = located.first().map(|&(t, _)| t as u32);
            view.bin_front_faces(mesh, entry_faces);
            return view;
        }
        old_verts.resize(mesh.pos_rel.len(), WalkVertex::default());
        old_verts.par_iter_mut().zip(mesh.pos_rel.par_iter()).zip(mesh.scalar.par_iter()).for_each(
            |((out, &p), &scalar)| {
                let c = frame.to_cam(p);
                let q = frame.cam_to_px(c);
                let w = if parallel { c[2] as f32 } else { (1.0 / c[2]) as f32 };
                *out = WalkVertex { x_px: q[0] as f32, y_px: q[1] as f32, w, scalar };
            },
        );
        view.verts = old_verts;
        let unrepresentable = |v: &WalkVertex| !(v.x_px.abs() < 1e30 && v.y_px.abs() < 1e30);
        if let Some(i) = view.verts.par_iter().position_first(unrepresentable) {
            view.unsupported =
                Some(format!("vertex {} projects outside the representable range", mesh.scene_vertex[i]));
            return view;
        }
        view.k_view = view.verts.par_iter().map(|v| v.x_px.abs().max(v.y_px.abs())).reduce(|| p_max, f32::max);
        view.bin_front_faces(mesh, entry_faces);
        view
    }

    /// Bins a new set of entry faces (a new cull mask), keeping the projection.
    pub fn rebin(&mut self, mesh: &WalkMesh, entry_faces: &[u32]) {
        // (`unsupported` views have no binning to redo.)
        if self.unsupported.is_none() {
            self.front_faces = 0;
            self.bin_start.iter_mut().for_each(|s| *s = 0);
            self.bin_front_faces(mesh, entry_faces);
        }
    }

    /// Why the walker cannot render this view (then projected tetrahedra do).
    pub fn unsupported(&self) -> Option<&str> {
        self.unsupported.as_deref()
    }

    /// Tile side the faces were binned for.
    pub fn tile(&self) -> u32 {
        self.tile
    }

    /// Most tets one run may cross before it is cut (counted).
    pub fn max_steps(&self) -> u32 {
        self.max_steps
    }

    /// Entry faces facing the eye.
    pub fn front_faces(&self) -> usize {
        self.front_faces
    }

    /// Whether the near plane cuts the mesh (walked in homogeneous
    /// coordinates, segments clipped at the near depth).
    pub fn near_clipped(&self) -> bool {
        self.near_clipped
    }

    /// Near-clipped views: the tet holding the eye, as the scene numbers it.
    pub fn eye_tet(&self, mesh: &WalkMesh) -> Option<u32> {
        self.eye_tet.map(|t| mesh.scene_tet[t as usize])
    }

    /// Bytes held by this view.
    pub fn memory_bytes(&self) -> usize {
        (self.verts.len() + self.hom.len()) * 16 + (self.bin_start.len() + self.bin_faces.len()) * 4
    }

    fn bin_front_faces(&mut self, mesh: &WalkMesh, entry_faces: &[u32]) {
        let tets = &mesh.tets;
        let (w, h) = (self.frame.width, self.frame.height);
        let tile = self.tile;
        let pos = Projector { frame: &self.frame, pos_rel: &mesh.pos_rel };
        // Per front face, its tile rectangle; back faces and faces that
        // cover no pixel centre get none. A face is an entry when its
        // projection's exact orientation is the front one: the walk lives
        // in the projected arrangement, so this is the test it agrees with
        // (a face exactly edge-on covers no centre under the perturbation).
        let rects: Vec<Option<[u32; 4]>> = entry_faces
            .par_iter()
            .map(|&packed| {
                let (t, f) = ((packed / 4) as usize, (packed % 4) as usize);
                let fv = FACE_OUTWARD[f];
                if self.near_clipped {
                    let q = [0, 1, 2].map(|k| self.hom[tets[t].verts[fv[k]] as usize]);
                    if hom::face_orientation(&q[0], &q[1], &q[2]) != Some(true) {
                        return None;
                    }
                    return hom::face_rect(q, w, h)
                        .map(|[x0, y0, x1, y1]| [x0 / tile, y0 / tile, x1 / tile, y1 / tile]);
                }
                let p = [0, 1, 2].map(|k| pos.px(tets[t].verts[fv[k]]));
                let o = orient2d(
                    Coord { x: p[0][0], y: p[0][1] },
                    Coord { x: p[1][0], y: p[1][1] },
                    Coord { x: p[2][0], y: p[2][1] },
                );
                if o == 0.0 || (o > 0.0) != FRONT_IS_LEFT {
                    return None;
                }
                pixel_rect(&p, w, h).map(|[x0, y0, x1, y1]| [x0 / tile, y0 / tile, x1 / tile, y1 / tile])
            })
            .collect();
        let mut count = vec![0u32; self.tiles_x * self.tiles_y];
        for r in rects.iter().flatten() {
            self.front_faces += 1;
            for j in r[1]..=r[3] {
                for i in r[0]..=r[2] {
                    count[j as usize * self.tiles_x + i as usize] += 1;
                }
            }
        }
        let mut start = 0u32;
        for (i, c) in count.iter().enumerate() {
            self.bin_start[i] = start;
            start += c;
        }
        self.bin_start[count.len()] = start;
        let mut fill: Vec<u32> = self.bin_start[..count.len()].to_vec();
        self.bin_faces = vec![0; start as usize];
        for (r, &packed) in rects.iter().zip(entry_faces) {
            let Some(r) = r else { continue };
            for j in r[1]..=r[3] {
                for i in r[0]..=r[2] {
                    let k = j as usize * self.tiles_x + i as usize;
                    self.bin_faces[fill[k] as usize] = packed;
                    fill[k] += 1;
                }
            }
        }
    }
}

/// The f64 pixel positions the view's f32 ones were rounded from,
/// recomputed on demand (the exact predicate needs them rarely).
struct Projector<'a> {
    frame: &'a Frame,
    pos_rel: &'a [[f64; 3]],
}

impl PixelPositions for Projector<'_> {
    #[inline]
    fn px(&self, vertex: u32) -> [f64; 2] {
        self.frame.cam_to_px(self.frame.to_cam(self.pos_rel[vertex as usize]))
    }
}

/// Inclusive pixel rectangle of the centres a triangle's bounding box can
/// hold, clipped to the image; `None` when empty.
fn pixel_rect(p: &[[f64; 2]; 3], w: u32, h: u32) -> Option<[u32; 4]> {
    let (x_lo, x_hi) = (p[0][0].min(p[1][0]).min(p[2][0]), p[0][0].max(p[1][0]).max(p[2][0]));
    let (y_lo, y_hi) = (p[0][1].min(p[1][1]).min(p[2][1]), p[0][1].max(p[1][1]).max(p[2][1]));
    centre_rect(x_lo, x_hi, y_lo, y_hi, w, h)
}

/// Inclusive pixel rectangle of the centres in [x_lo, x_hi] × [y_lo, y_hi],
/// clipped to the image; `None` when empty.
fn centre_rect(x_lo: f64, x_hi: f64, y_lo: f64, y_hi: f64, w: u32, h: u32) -> Option<[u32; 4]> {
    // Centres at i + 0.5 inside [lo, hi].
    let x0 = (x_lo - 0.5).ceil().max(0.0);
    let y0 = (y_lo - 0.5).ceil().max(0.0);
    let x1 = (x_hi - 0.5).floor().min(w as f64 - 1.0);
    let y1 = (y_hi - 0.5).floor().min(h as f64 - 1.0);
    (x0 <= x1 && y0 <= y1).then_some([x0 as u32, y0 as u32, x1 as u32, y1 as u32])
}

/// Counters of one walked frame.
#[derive(Debug, Clone, Copy, Default, PartialEq, serde::Serialize)]
pub struct WalkStats {
    /// Entry faces facing the eye (the entries' candidates).
    pub front_faces: usize,
    /// Pixels whose ray meets the mesh.
    pub rays: u64,
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
    /// The near plane cut the mesh: walked in homogeneous coordinates,
    /// segments clipped at the near depth.
    pub near_clipped: bool,
    /// Near-clipped views: rays started in the (visible) tet holding the eye.
    pub eye_inside: bool,
    pub walk_seconds: f64,
}

impl WalkStats {
    fn add(&mut self, o: &WalkStats) {
        self.rays += o.rays;
        self.runs += o.runs;
        self.crossings += o.crossings;
        self.fragments += o.fragments;
        self.exact_tests += o.exact_tests;
        self.non_manifold += o.non_manifold;
        self.step_limit += o.step_limit;
        self.terminated += o.terminated;
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
    let ctx = WalkCtx {
        mesh,
        view,
        visible,
        shader,
        opts,
        want_grad_mag: shader.method().is_bivariate() && mesh.grad_mag.is_some(),
        lit: opts.shading.is_active() && mesh.grads.is_some(),
        lanes: opts.walk_interleave.unwrap_or(1).clamp(1, 64),
        prefetch: opts.walk_prefetch,
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

struct WalkCtx<'a> {
    mesh: &'a WalkMesh,
    view: &'a WalkView,
    visible: Option<&'a [bool]>,
    shader: &'a dyn SegmentShader,
    opts: &'a RasterOptions,
    want_grad_mag: bool,
    lit: bool,
    /// Rays walked at once ([`RasterOptions::walk_interleave`]).
    lanes: usize,
    /// Request the records of the next step's candidate tets ([`RasterOptions::walk_prefetch`]).
    prefetch: bool,
}

/// A point on a face along one ray: depth, scalar and the barycentric
/// weights of the face's three vertices (world space).
#[derive(Clone, Copy)]
struct FacePoint {
    depth: f32,
    scalar: f32,
    ids: [u32; 3],
    lam: [f32; 3],
}

/// Where the ray meets face `ids` given its three edge-function values
/// `l[k]` (edge opposite vertex k) oriented so that inside is positive
/// after multiplying by `orient`.
#[inline(always)]
fn face_point(verts: &[WalkVertex], ids: [u32; 3], l: [f32; 3], orient: f32, parallel: bool) -> FacePoint {
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
struct RayState {
    fx: f32,
    fy: f32,
    len_per_depth: f32,
    /// Its entries left: `entries[next_entry..end]`.
    next_entry: usize,
    end: usize,
    /// The run in progress: tet, entry face, entry point, steps it may
    /// still take.
    t: usize,
    f_in: usize,
    p_in: FacePoint,
    steps_left: u32,
    in_run: bool,
    acc: [f32; 4],
    /// Segments to gather before the next shading.
    cap: usize,
    crossings: u64,
}

/// Segments of one ray waiting for the shader.
struct RayBatch {
    segs: SegmentBatch,
    /// Gradient at each segment's midpoint (lighting only).
    grad_mid: [[f32; 3]; BATCH],
    rgba: [Rgba32; BATCH],
}

/// The first batch of a ray holds this many segments, each next one twice
/// as many up to [`BATCH`]: most rays that turn opaque do so early, and a
/// ray walks at most one batch past the point where it did.
const FIRST_BATCH: usize = 16;

/// What a view's walk asks of its geometry: the projected form (f32 pixel
/// positions, [`edge`]) or, where the near plane cuts the mesh, the
/// homogeneous one ([`hom`]). Both give the signs and values of the same
/// edge functions, so one walk serves both.
trait RayGeometry: Sync {
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

struct Projected<'a> {
    verts: &'a [WalkVertex],
    pos: Projector<'a>,
    k_view: f32,
    parallel: bool,
    size: [u32; 2],
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

struct Homogeneous<'a> {
    verts: &'a [HomVertex],
    near_depth: f32,
    /// The eye's tet when it is visible.
    eye: Option<(u32, [u32; 4])>,
    size: [u32; 2],
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
    fn tile(&self, ti: usize) -> (Vec<[f32; 4]>, WalkStats) {
        let view = self.view;
        let size = [view.frame.width, view.frame.height];
        if view.near_clipped {
            let eye = view
                .eye_tet
                .filter(|&t| self.visible.is_none_or(|vis| vis[t as usize]))
                .map(|t| (t, self.mesh.tets[t as usize].verts));
            let g = Homogeneous { verts: &view.hom, near_depth: view.frame.near_depth as f32, eye, size };
            self.tile_full(&g, ti)
        } else {
            let g = Projected {
                verts: &view.verts,
                pos: Projector { frame: &view.frame, pos_rel: &self.mesh.pos_rel },
                k_view: view.k_view,
                parallel: view.frame.parallel,
                size,
            };
            self.tile_full(&g, ti)
        }
    }

    /// [`Self::tile_with`], compiled without the per-vertex gradient reads
    /// where the frame needs none (neither lighting nor a bivariate method):
    /// the exit points' weights and vertex ids are then never kept.
    fn tile_full<G: RayGeometry>(&self, g: &G, ti: usize) -> (Vec<[f32; 4]>, WalkStats) {
        if self.lit || self.want_grad_mag {
            self.tile_with::<G, true>(g, ti)
        } else {
            self.tile_with::<G, false>(g, ti)
        }
    }

    fn tile_with<G: RayGeometry, const GRADS: bool>(&self, g: &G, ti: usize) -> (Vec<[f32; 4]>, WalkStats) {
        let view = self.view;
        let (w, h) = (view.frame.width, view.frame.height);
        let tile = view.tile;
        let (i, j) = ((ti % view.tiles_x) as u32, (ti / view.tiles_x) as u32);
        let rect = [i * tile, j * tile, ((i + 1) * tile).min(w) - 1, ((j + 1) * tile).min(h) - 1];
        let stride = (rect[2] - rect[0] + 1) as usize;
        let mut acc = vec![[0.0f32; 4]; stride * (rect[3] - rect[1] + 1) as usize];
        let mut st = WalkStats::default();
        let mut counters = EdgeCounters::default();
        let entries = self.entries(g, ti, rect, stride, &mut counters, &mut st);
        // The rays of the tile: (pixel, first entry, end).
        let mut rays: Vec<(u32, usize, usize)> = Vec::new();
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
        // Several rays in flight, one step each in turn: each walk is a
        // chain of dependent loads, and independent chains let the core
        // overlap their cache misses (meshes far larger than the caches).
        let lanes = self.lanes;
        let new_batch = || {
            Box::new(RayBatch { segs: SegmentBatch::default(), grad_mid: [[0.0; 3]; BATCH], rgba: [[0.0; 4]; BATCH] })
        };
        let mut batches: Vec<Box<RayBatch>> = (0..lanes).map(|_| new_batch()).collect();
        let mut flight: Vec<Option<(u32, RayState)>> = vec![None; lanes];
        let mut next = 0;
        let mut active = 0;
        if lanes == 1 {
            // One ray at a time (the default): its state stays a local.
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
    fn entries<G: RayGeometry>(
        &self,
        g: &G,
        ti: usize,
        rect: [u32; 4],
        stride: usize,
        counters: &mut EdgeCounters,
        st: &mut WalkStats,
    ) -> Vec<(u32, f32, u32)> {
        let view = self.view;
        let tets = &self.mesh.tets;
        let faces = &view.bin_faces[view.bin_start[ti] as usize..view.bin_start[ti + 1] as usize];
        let orient = if FRONT_IS_LEFT { 1.0 } else { -1.0 };
        let mut out = Vec::new();
        for &packed in faces {
            let (t, f) = ((packed / 4) as usize, (packed % 4) as usize);
            let fv = FACE_OUTWARD[f];
            let tv = tets[t].verts;
            let ids = [tv[fv[0]], tv[fv[1]], tv[fv[2]]];
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
    fn start_ray(&self, px: u32, py: u32, first: usize, end: usize) -> RayState {
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
    fn step<G: RayGeometry, const GRADS: bool>(
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
        let front_orient = if FRONT_IS_LEFT { 1.0 } else { -1.0 };
        let back_orient = -front_orient;
        if !ray.in_run {
            if ray.next_entry == ray.end {
                return self.finish(ray, batch, st);
            }
            let packed = entries[ray.next_entry].2;
            ray.next_entry += 1;
            st.runs += 1;
            (ray.t, ray.f_in) = ((packed / 4) as usize, (packed % 4) as usize);
            let fv = FACE_OUTWARD[ray.f_in];
            let tv = tets[ray.t].verts;
            let ids = [tv[fv[0]], tv[fv[1]], tv[fv[2]]];
            let l = [g.value(ids[1], ids[2], fx, fy), g.value(ids[2], ids[0], fx, fy), g.value(ids[0], ids[1], fx, fy)];
            ray.p_in = g.face_point(ids, l, front_orient);
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
        let tet = rec.verts;
        let (val, bits) = g.sides_from(tet, f_in, fx, fy, counters);
        // One table read: with the candidates' records already requested
        // (above), a branch per candidate no longer lets loads start sooner.
        let exit = EXIT_BY_SIDES[f_in & 3][(bits & 0xf) as usize];
        if exit == NO_EXIT {
            // Cannot happen with exact signs (module docs); counted with the
            // step bound rather than trusted.
            st.step_limit += 1;
            ray.in_run = false;
            return false;
        }
        let (f_out, x, y) = ((exit & 3) as usize, (exit >> 2 & 3) as usize, (exit >> 4 & 3) as usize);
        ray.crossings += 1;
        let link = rec.links[f_out & 3];
        // The exit face as (v, x, y), a rotation of its outward order: the
        // edge values opposite v, x and y.
        let (v, tx, ty) = (tet[f_in & 3], tet[x], tet[y]);
        let l = [g.value(tx, ty, fx, fy), -val[y], val[x]];
        let p_out = g.face_point([v, tx, ty], l, back_orient);
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
        // Out of the mesh, or into a culled tet: the run ends (the ray's
        // next entry, if any, is where it meets visible tets again).
        if link >= LINK_BROKEN || self.visible.is_some_and(|vis| !vis[(link / 4) as usize]) {
            if link == LINK_BROKEN {
                st.non_manifold += 1;
            }
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

    /// Shades what is left of the ray's batch; always true (done).
    fn finish(&self, ray: &mut RayState, batch: &mut RayBatch, st: &mut WalkStats) -> bool {
        st.crossings += ray.crossings;
        if batch.segs.len > 0 && self.flush(batch, &mut ray.acc, ray.fx, ray.fy, st) {
            st.terminated += 1;
        }
        true
    }

    /// [`Self::push`] for a segment cut by the near plane: its front values
    /// are those at `t_front` of the way from `a` to `b` (every field is
    /// linear along the ray inside the tet).
    fn push_clipped<const GRADS: bool>(
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
            // push() left the mean of the two ends; the cut segment's
            // midpoint is t_front/2 further towards b.
            let g = self.mesh.grads.as_deref().expect("checked in lit");
            let at = |p: &FacePoint, c: usize| {
                p.lam[0] * g[p.ids[0] as usize][c]
                    + p.lam[1] * g[p.ids[1] as usize][c]
                    + p.lam[2] * g[p.ids[2] as usize][c]
            };
            batch.grad_mid[k] = std::array::from_fn(|c| {
                let (ga, gb) = (at(a, c), at(b, c));
                0.5 * (mix(ga, gb) + gb)
            });
        }
    }

    #[inline(always)]
    fn push<const GRADS: bool>(&self, batch: &mut RayBatch, a: &FacePoint, b: &FacePoint, len: f32) {
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
            let g = self.mesh.grads.as_deref().expect("checked in lit");
            let mut mid = [0.0f32; 3];
            for p in [a, b] {
                for (c, m) in mid.iter_mut().enumerate() {
                    *m += 0.5
                        * (p.lam[0] * g[p.ids[0] as usize][c]
                            + p.lam[1] * g[p.ids[1] as usize][c]
                            + p.lam[2] * g[p.ids[2] as usize][c]);
                }
            }
            batch.grad_mid[k] = mid;
        }
        batch.segs.len = k + 1;
    }

    /// Shades the batch and composites it under `acc` in order; true once
    /// the pixel is opaque (the rest of the batch is dropped).
    fn flush(&self, batch: &mut RayBatch, acc: &mut [f32; 4], fx: f32, fy: f32, st: &mut WalkStats) -> bool {
        let n = batch.segs.len;
        if acc[3] >= self.opts.opaque_alpha {
            batch.segs.len = 0;
            return true;
        }
        self.shader.shade_batch(&batch.segs, &mut batch.rgba);
        batch.segs.len = 0;
        let view_dir = self.lit.then(|| self.view.frame.view_dir(fx as f64, fy as f64));
        for k in 0..n {
            let mut c = batch.rgba[k];
            if let Some(vd) = view_dir {
                let g = batch.grad_mid[k];
                c = self.opts.shading.apply(c, DVec3::new(g[0] as f64, g[1] as f64, g[2] as f64), vd);
            }
            let t = 1.0 - acc[3];
            acc[0] += t * c[0];
            acc[1] += t * c[1];
            acc[2] += t * c[2];
            acc[3] += t * c[3];
            st.fragments += 1;
            if acc[3] >= self.opts.opaque_alpha {
                return true;
            }
        }
        false
    }
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
