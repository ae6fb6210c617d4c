//! A view for the walker (`WalkView`): every vertex projected once, the
//! near plane's homogeneous form, front boundary faces binned into tiles.

use super::*;

/// One view for the walker: every vertex projected once, and the
/// front-facing boundary faces binned into tiles.
#[derive(Debug, Clone)]
pub struct WalkView {
    pub(crate) frame: Frame,
    pub(crate) verts: Vec<WalkVertex>,
    /// The near plane cuts the mesh: the view is walked in homogeneous
    /// coordinates (`hom`; `verts` is empty).
    pub(crate) near_clipped: bool,
    pub(crate) hom: Vec<HomVertex>,
    /// Near-clipped views: the tet holding the eye (walk order).
    pub(crate) eye_tet: Option<u32>,
    /// Bounds |x| and |y| of every projected vertex and pixel centre.
    pub(crate) k_view: f32,
    pub(crate) tile: u32,
    pub(crate) tiles_x: usize,
    pub(crate) tiles_y: usize,
    /// Entry faces facing the eye, per tile (CSR: `bin_start[i]..bin_start[i + 1]`).
    pub(crate) bin_start: Vec<u32>,
    pub(crate) bin_faces: Vec<u32>,
    /// Each binned face's walk vertex ids (outward order), beside `bin_faces`.
    pub(crate) bin_verts: Vec<[u32; 3]>,
    pub(crate) front_faces: usize,
    pub(crate) max_steps: u32,
    pub(crate) unsupported: Option<String>,
}

impl WalkView {
    /// Tile `ti`'s pixels, [x0, y0, x1, y1] inclusive, and its width.
    pub(crate) fn tile_rect(&self, ti: usize) -> ([u32; 4], usize) {
        let (w, h, tile) = (self.frame.width, self.frame.height, self.tile);
        let (i, j) = ((ti % self.tiles_x) as u32, (ti / self.tiles_x) as u32);
        let rect = [i * tile, j * tile, ((i + 1) * tile).min(w) - 1, ((j + 1) * tile).min(h) - 1];
        (rect, (rect[2] - rect[0] + 1) as usize)
    }

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
        entry_faces: &EntryFaces,
    ) -> WalkView {
        let prev_eye = old.as_ref().and_then(|v| v.eye_tet);
        let was_near_clipped = old.as_ref().is_some_and(|v| v.near_clipped);
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
            bin_verts: Vec::new(),
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
        // The common case in one pass (the arrays of a 20M-tet mesh's 4M
        // vertices are read once, not once per check): every vertex
        // projected, with whether any lies nearer than the near plane, any
        // projects to no finite pixel, and the largest pixel coordinate.
        let unrepresentable = |v: &WalkVertex| !(v.x_px.abs() < 1e30 && v.y_px.abs() < 1e30);
        let is_near = |c: [f64; 3]| !parallel && c[2].partial_cmp(&near).is_none_or(|o| o.is_lt());
        // Every vertex in homogeneous coordinates, and whether any lies
        // nearer than the near plane.
        let project_hom = |hom: &mut Vec<HomVertex>| -> bool {
            hom.resize(mesh.pos_rel.len(), HomVertex::default());
            hom.par_iter_mut()
                .zip(mesh.pos_rel.par_iter())
                .zip(mesh.scalar.par_iter())
                .map(|((out, &p), &scalar)| {
                    let c = frame.to_cam(p);
                    // x_px = (x_cam / depth − bx) / ax, times the depth.
                    *out = HomVertex {
                        x_hom: ((c[0] - frame.bx * c[2]) / frame.ax) as f32,
                        y_hom: ((c[1] - frame.by * c[2]) / frame.ay) as f32,
                        w_depth: c[2] as f32,
                        scalar,
                    };
                    is_near(c)
                })
                .reduce(|| false, |a, b| a | b)
        };
        // A view after a near-clipped one (the eye inside the mesh, moving)
        // most likely is one too: the homogeneous pass first, so that such
        // frames read the vertices once; the projected pass only where no
        // vertex turned out near.
        let hom_first = was_near_clipped && !parallel && project_hom(&mut old_hom);
        let (any_near, any_bad, k_max) = if hom_first {
            (true, false, p_max)
        } else {
            old_verts.resize(mesh.pos_rel.len(), WalkVertex::default());
            old_verts
                .par_iter_mut()
                .zip(mesh.pos_rel.par_iter())
                .zip(mesh.scalar.par_iter())
                .map(|((out, &p), &scalar)| {
                    let c = frame.to_cam(p);
                    let q = frame.cam_to_px(c);
                    let w = if parallel { c[2] as f32 } else { (1.0 / c[2]) as f32 };
                    *out = WalkVertex { x_px: q[0] as f32, y_px: q[1] as f32, w, scalar };
                    (is_near(c), unrepresentable(out), out.x_px.abs().max(out.y_px.abs()))
                })
                .reduce(|| (false, false, p_max), |a, b| (a.0 | b.0, a.1 | b.1, a.2.max(b.2)))
        };
        if any_near {
            if !hom_first {
                project_hom(&mut old_hom);
            }
            view.hom = old_hom;
            view.near_clipped = true;
            if let Some(i) = view.hom.par_iter().position_first(|v| !(v.x_hom.abs() < 1e30 && v.y_hom.abs() < 1e30)) {
                view.unsupported =
                    Some(format!("vertex {} projects outside the representable range", mesh.scene_vertex[i]));
                return view;
            }
            // The eye's tet: walked to from the previous view's (the eye
            // moves little between frames); where that walk leaves the mesh
            // or runs long, the scan below.
            match prev_eye.and_then(|t| walk_to_eye(mesh, &view.hom, t)) {
                Some(Ok(t)) => view.eye_tet = Some(t),
                Some(Err(t)) => {
                    view.unsupported = Some(on_a_face_plane(mesh.scene_tet[t as usize]));
                    return view;
                }
                None => {
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
                        view.unsupported = Some(on_a_face_plane(mesh.scene_tet[*t]));
                        return view;
                    }
                    view.eye_tet = located.first().map(|&(t, _)| t as u32);
                }
            }
            view.bin_front_faces(mesh, entry_faces);
            return view;
        }
        view.verts = old_verts;
        if any_bad {
            let i = view.verts.par_iter().position_first(unrepresentable).unwrap_or(0);
            view.unsupported =
                Some(format!("vertex {} projects outside the representable range", mesh.scene_vertex[i]));
            return view;
        }
        view.k_view = k_max;
        view.bin_front_faces(mesh, entry_faces);
        view
    }

    /// Bins a new set of entry faces (a new cull mask), keeping the projection.
    pub fn rebin(&mut self, mesh: &WalkMesh, entry_faces: &EntryFaces) {
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
        (self.verts.len() + self.hom.len()) * 16
            + (self.bin_start.len() + self.bin_faces.len()) * 4
            + self.bin_verts.len() * 12
    }

    pub(crate) fn bin_front_faces(&mut self, mesh: &WalkMesh, entry_faces: &EntryFaces) {
        let (w, h) = (self.frame.width, self.frame.height);
        let tile = self.tile;
        let pos = Projector { frame: &self.frame, pos_rel: &mesh.pos_rel };
        // Per front face, its tile rectangle; back faces and faces that
        // cover no pixel centre get none. A face is an entry when its
        // projection's exact orientation is the front one: the walk lives
        // in the projected arrangement, so this is the test it agrees with
        // (a face exactly edge-on covers no centre under the perturbation).
        let rects: Vec<Option<[u32; 4]>> = entry_faces
            .verts
            .par_iter()
            .map(|&ids| {
                if self.near_clipped {
                    let q = ids.map(|v| self.hom[v as usize]);
                    if hom::face_orientation(&q[0], &q[1], &q[2]) != Some(true) {
                        return None;
                    }
                    return hom::face_rect(q, w, h).map(|r| in_tiles(r, tile));
                }
                // The view's f32 positions decide wherever the exact
                // answer on the f64 ones they were rounded from is certain
                // (nearly every face); the rest recompute those.
                let q = ids.map(|v| {
                    let v = &self.verts[v as usize];
                    [v.x_px, v.y_px]
                });
                let front = match rounded_orientation(&q) {
                    Some(o) => (o > 0.0) == FRONT_IS_LEFT,
                    None => {
                        let p = ids.map(|v| pos.px(v));
                        let o = orient2d(
                            Coord { x: p[0][0], y: p[0][1] },
                            Coord { x: p[1][0], y: p[1][1] },
                            Coord { x: p[2][0], y: p[2][1] },
                        );
                        o != 0.0 && (o > 0.0) == FRONT_IS_LEFT
                    }
                };
                if !front {
                    return None;
                }
                match rounded_tile_rect(&q, w, h, tile) {
                    Some(rect) => rect,
                    None => pixel_rect(&ids.map(|v| pos.px(v)), w, h).map(|r| in_tiles(r, tile)),
                }
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
        self.bin_verts = vec![[0; 3]; start as usize];
        for ((r, &packed), &ids) in rects.iter().zip(&entry_faces.packed).zip(&entry_faces.verts) {
            let Some(r) = r else { continue };
            for j in r[1]..=r[3] {
                for i in r[0]..=r[2] {
                    let k = j as usize * self.tiles_x + i as usize;
                    self.bin_faces[fill[k] as usize] = packed;
                    self.bin_verts[fill[k] as usize] = ids;
                    fill[k] += 1;
                }
            }
        }
    }
}

/// The f64 pixel positions the view's f32 ones were rounded from,
/// recomputed on demand (the exact predicate needs them rarely).
pub(crate) struct Projector<'a> {
    pub(crate) frame: &'a Frame,
    pub(crate) pos_rel: &'a [[f64; 3]],
}

impl PixelPositions for Projector<'_> {
    #[inline]
    fn px(&self, vertex: u32) -> [f64; 2] {
        self.frame.cam_to_px(self.frame.to_cam(self.pos_rel[vertex as usize]))
    }
}

/// Inclusive pixel rectangle of the centres a triangle's bounding box can
/// hold, clipped to the image; `None` when empty.
/// Why a near-clipped view with the eye on a face's plane is not walked.
fn on_a_face_plane(scene_tet: u32) -> String {
    format!("the eye lies on the plane of a face of tet {scene_tet} (no tet holds it strictly)")
}

/// Steps a walk to the eye may take before the scan takes over.
const EYE_WALK_STEPS: usize = 1 << 16;

/// The tet holding the eye (the origin of `hom`), walked to from tet
/// `start` (walk order) through faces the eye lies beyond: `Ok` a tet
/// whose four faces all face away from the eye (it holds the eye
/// strictly), `Err` a tet whose closure holds it on a face's plane; `None`
/// where the walk leaves the mesh, meets a broken link or runs past
/// [`EYE_WALK_STEPS`] (a hole, a non-convex boundary in the way, a cycle).
/// In a mesh whose tets do not overlap, at most one tet holds the eye
/// strictly and none other holds it at all, so this is the tet (or the
/// refusal) [`WalkView::recycle`]'s scan of every tet finds. The faces are
/// tried from a different one each step, so that a walk cannot cycle
/// through one choice of faces for ever.
pub(crate) fn walk_to_eye(mesh: &WalkMesh, hom: &[HomVertex], start: u32) -> Option<Result<u32, u32>> {
    let mut t = start as usize;
    for step in 0..EYE_WALK_STEPS {
        let rec = mesh.tets.get(t)?;
        match hom::eye_beyond(&rec.verts.map(|v| hom[v as usize]), step % 4) {
            hom::EyeSide::Inside => return Some(Ok(t as u32)),
            hom::EyeSide::OnPlane => return Some(Err(t as u32)),
            hom::EyeSide::Beyond(f) if rec.links[f] < LINK_BROKEN => t = (rec.links[f] / 4) as usize,
            hom::EyeSide::Beyond(_) => return None,
        }
    }
    None
}

/// Unit roundoff of f32, as f64.
const U32_AS_F64: f64 = f32::EPSILON as f64 * 0.5;

/// How far (in pixels, each axis) the f64 pixel position a view's f32 one
/// was rounded from (to nearest) can lie from it, for positions of
/// magnitude at most `m`: half an f32 ulp, doubled for margin.
fn rounding_reach(m: f64) -> f64 {
    2.0 * U32_AS_F64 * m
}

/// The orientation (`orient2d`'s sign convention) of the triangle whose
/// f64 pixel positions the view's f32 positions `q` were rounded from, when
/// `q` alone decides it: `Some(o)` with o of that sign, never 0; `None`
/// where the exact test on the f64 positions must decide (the triangle is
/// too close to edge-on for the rounding).
pub(crate) fn rounded_orientation(q: &[[f32; 2]; 3]) -> Option<f64> {
    let p = q.map(|v| v.map(f64::from));
    let (a, b) = (p[1][0] - p[0][0], p[2][1] - p[0][1]);
    let (c, d) = (p[1][1] - p[0][1], p[2][0] - p[0][0]);
    let (ab, cd) = (a * b, c * d);
    let o = ab - cd;
    let m = p.iter().flatten().fold(0.0f64, |m, x| m.max(x.abs()));
    // Each difference of the f64 positions lies within 2·reach of the one
    // computed here; the products and the difference add a few f64
    // roundings (each at most 2⁻⁵³ of |ab| + |cd|, counted as 2⁻⁵⁰).
    let dd = 2.0 * rounding_reach(m);
    let bound = dd * (a.abs() + b.abs() + c.abs() + d.abs()) + 2.0 * dd * dd + (ab.abs() + cd.abs()) * 2f64.powi(-50);
    (o.is_finite() && o.abs() > 2.0 * bound).then_some(o)
}

/// [`pixel_rect`] of the triangle's f64 positions, in tiles of `tile`
/// pixels, when the view's f32 positions `q` decide it (the rect of the
/// box grown by the rounding's reach is the one of the box shrunk by it);
/// `None` where the f64 positions must decide.
pub(crate) fn rounded_tile_rect(q: &[[f32; 2]; 3], w: u32, h: u32, tile: u32) -> Option<Option<[u32; 4]>> {
    let p = q.map(|v| v.map(f64::from));
    let m = p.iter().flatten().fold(0.0f64, |m, x| m.max(x.abs()));
    let r = rounding_reach(m);
    let (x_lo, x_hi) = (p[0][0].min(p[1][0]).min(p[2][0]), p[0][0].max(p[1][0]).max(p[2][0]));
    let (y_lo, y_hi) = (p[0][1].min(p[1][1]).min(p[2][1]), p[0][1].max(p[1][1]).max(p[2][1]));
    let grown = centre_rect(x_lo - r, x_hi + r, y_lo - r, y_hi + r, w, h).map(|p| in_tiles(p, tile));
    let shrunk = centre_rect(x_lo + r, x_hi - r, y_lo + r, y_hi - r, w, h).map(|p| in_tiles(p, tile));
    (grown == shrunk && r.is_finite()).then_some(grown)
}

/// An inclusive pixel rectangle as the inclusive rectangle of the tiles of
/// `tile` pixels it touches.
fn in_tiles([x0, y0, x1, y1]: [u32; 4], tile: u32) -> [u32; 4] {
    [x0 / tile, y0 / tile, x1 / tile, y1 / tile]
}

pub(crate) fn pixel_rect(p: &[[f64; 2]; 3], w: u32, h: u32) -> Option<[u32; 4]> {
    let (x_lo, x_hi) = (p[0][0].min(p[1][0]).min(p[2][0]), p[0][0].max(p[1][0]).max(p[2][0]));
    let (y_lo, y_hi) = (p[0][1].min(p[1][1]).min(p[2][1]), p[0][1].max(p[1][1]).max(p[2][1]));
    centre_rect(x_lo, x_hi, y_lo, y_hi, w, h)
}

/// Inclusive pixel rectangle of the centres in [x_lo, x_hi] × [y_lo, y_hi],
/// clipped to the image; `None` when empty.
pub(crate) fn centre_rect(x_lo: f64, x_hi: f64, y_lo: f64, y_hi: f64, w: u32, h: u32) -> Option<[u32; 4]> {
    // Centres at i + 0.5 inside [lo, hi].
    let x0 = (x_lo - 0.5).ceil().max(0.0);
    let y0 = (y_lo - 0.5).ceil().max(0.0);
    let x1 = (x_hi - 0.5).floor().min(w as f64 - 1.0);
    let y1 = (y_hi - 0.5).floor().min(h as f64 - 1.0);
    (x0 <= x1 && y0 <= y1).then_some([x0 as u32, y0 as u32, x1 as u32, y1 as u32])
}

#[cfg(test)]
mod tests {
    use super::*;
    use tet_mesh::rng::SplitMix64;

    /// Triangles of f64 pixel positions, many nearly edge-on or with a
    /// corner near a pixel centre's row or column, at several magnitudes.
    fn triangles(seed: u64, n: usize) -> Vec<[[f64; 2]; 3]> {
        let mut rng = SplitMix64(seed);
        let mut u = move || rng.next_f64();
        (0..n)
            .map(|i| {
                let scale = [1.0, 600.0, 1e4, 1e7][i % 4];
                let p0 = [(u() - 0.5) * scale, (u() - 0.5) * scale];
                let p1 = [(u() - 0.5) * scale, (u() - 0.5) * scale];
                // The third corner on the line through the first two, off it
                // by a tiny distance, or anywhere.
                let off = [0.0, 1e-12, 1e-9, 1e-7, 1e-5, 1e-3, 1.0][i % 7] * scale;
                let t = u() * 2.0 - 0.5;
                let n = [p0[1] - p1[1], p1[0] - p0[0]];
                let len = (n[0] * n[0] + n[1] * n[1]).sqrt().max(1e-300);
                let mut p2 =
                    [p0[0] + t * (p1[0] - p0[0]) + off * n[0] / len, p0[1] + t * (p1[1] - p0[1]) + off * n[1] / len];
                if i % 11 == 0 {
                    // A corner just off a pixel centre's column.
                    p2[0] = (p2[0].floor() + 0.5) + [0.0, 1e-9, -1e-9, 1e-6][i % 4];
                }
                [p0, p1, p2]
            })
            .collect()
    }

    #[test]
    fn rounded_decisions_are_the_exact_ones_where_they_decide() {
        let (mut decided, mut rects) = (0, 0);
        for p in triangles(7, 200_000) {
            let q = p.map(|v| v.map(|x| x as f32));
            // The view's f32 positions are these f64 ones rounded: the
            // exact tests read the f64 ones.
            let exact = orient2d(
                Coord { x: p[0][0], y: p[0][1] },
                Coord { x: p[1][0], y: p[1][1] },
                Coord { x: p[2][0], y: p[2][1] },
            );
            if let Some(o) = rounded_orientation(&q) {
                decided += 1;
                assert!(exact != 0.0 && (o > 0.0) == (exact > 0.0), "{p:?}: rounded {o}, exact {exact}");
            }
            for tile in [1, 16] {
                if let Some(r) = rounded_tile_rect(&q, 512, 384, tile) {
                    rects += 1;
                    let want = pixel_rect(&p, 512, 384).map(|r| in_tiles(r, tile));
                    assert_eq!(r, want, "{p:?}, tile {tile}");
                }
            }
        }
        // Most are decided without the f64 positions (a third or more of
        // these triangles are within 1e-7 of edge-on by construction).
        assert!(decided > 80_000 && rects > 300_000, "{decided} orientations, {rects} rects decided");
    }
}
