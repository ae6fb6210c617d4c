//! The renderer as stages that recompute only what a change invalidates
//! (the shared state with change notification of Vollrath, Weiskopf & Ertl,
//! "A Generic Software Framework for the GPU Volume Rendering Pipeline",
//! VMV 2005, done with types):
//!
//! | change | invalidates |
//! |---|---|
//! | [`Renderer::set_view`] | view geometry (vertex transform, face sides), the order and the per-tet setup |
//! | [`Renderer::set_culler`] (a new TF) | the cull mask; the per-tet setup when the mask differs; the order only for the radix sort, which sorts visible tets only |
//! | [`Renderer::set_shader`] | nothing cached (shading happens per fragment) |
//! | [`Renderer::set_sort`] | the order and the per-tet setup |
//! | [`Renderer::set_raster_options`] | the per-tet setup |
//!
//! The per-tet setup (the rasterizer's fast path: each tet's planes, fields
//! and covered pixels for this view, [`crate::raster::PreparedFrame`]) is
//! kept within [`RasterOptions::setup_cache_bytes`], so a frame after a new
//! shader, method or transfer function that culls the same cells only
//! shades and composites. It is kept from the second frame of a view on:
//! while the camera moves every frame, keeping it would only cost (on the
//! 1.2M-tet grid ~10% of each frame, writing 324 MiB that is never read).
//!
//! [`Renderer::render`] recomputes what is stale and reports what it redid
//! in [`RenderStats`].
//!
//! Two CPU renderers share these stages ([`CpuRenderer`]): the ray walker
//! ([`crate::walk`], the default) needs only the vertices projected once per
//! view and the front boundary faces binned ([`WalkView`]), the cull mask and
//! the shader — no order and no per-tet setup; projected tetrahedra
//! (`Pt`) use every stage above. A view the walker cannot draw yet (the
//! near plane cuts the mesh) is drawn by projected tetrahedra, and
//! [`RenderStats::walk_fallback`] says why.

use crate::camera::{Camera, ViewSpec};
use crate::cull::{cull, CellCuller, CullMask};
use crate::image::Image;
use crate::project::ViewGeometry;
use crate::raster::{rasterize_cached, PreparedFrame, RasterOptions, RasterStats};
use crate::scene::Scene;
use crate::sort::{visibility_order, SortMethod, VisibilityOrder};
use crate::walk::{walk_frame, WalkMesh, WalkView};
use crate::RenderError;
use std::sync::Arc;
use std::time::Instant;
use tet_preint::SegmentShader;

/// Which CPU algorithm draws a frame.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, serde::Serialize, serde::Deserialize)]
pub enum CpuRenderer {
    /// Face-adjacency ray walking ([`crate::walk`]): cost follows pixels ×
    /// tets along each ray.
    #[default]
    Walk,
    /// Projected tetrahedra in a visibility order (Shirley–Tuchman; the
    /// papers' algorithm and the GPU's).
    Pt,
}

impl CpuRenderer {
    /// The id used on command lines (`walk`, `pt`).
    pub fn id(self) -> &'static str {
        match self {
            CpuRenderer::Walk => "walk",
            CpuRenderer::Pt => "pt",
        }
    }
}

impl std::str::FromStr for CpuRenderer {
    type Err = String;
    fn from_str(s: &str) -> Result<Self, Self::Err> {
        match s {
            "walk" => Ok(CpuRenderer::Walk),
            "pt" => Ok(CpuRenderer::Pt),
            _ => Err(format!("unknown renderer {s:?} (walk, pt)")),
        }
    }
}

impl std::fmt::Display for CpuRenderer {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(self.id())
    }
}

/// Timings (seconds) and counts of one [`Renderer::render`].
#[derive(Debug, Clone, Default, PartialEq, serde::Serialize)]
pub struct RenderStats {
    /// Vertex transform and face sides (0 when the view was unchanged).
    pub view_seconds: f64,
    pub cull_seconds: f64,
    pub sort_seconds: f64,
    /// Binning tets into tiles.
    pub project_seconds: f64,
    /// Tile rasterization and compositing.
    pub raster_seconds: f64,
    pub total_seconds: f64,
    pub tets_total: usize,
    pub tets_culled: usize,
    /// Tets in the visibility order (visible ones).
    pub tets_drawn: usize,
    pub fraction_culled: f64,
    pub cycles_broken: usize,
    pub sort_method: String,
    pub fragments: u64,
    /// Tet setups: once per tet on the fast path (0 from a kept setup), once
    /// per tile a tet spans on the per-tile path and for clipped tets.
    pub setups: u64,
    pub tiles_terminated: usize,
    /// Which stages this call recomputed.
    pub recomputed_view: bool,
    pub recomputed_cull: bool,
    pub recomputed_order: bool,
    /// The fast path's per-tet setup came from the previous frame (same view
    /// and order): no tet was set up.
    pub reused_setup: bool,
    /// The algorithm that drew the frame (`walk` or `pt`).
    pub renderer: String,
    /// Walker: why this view was drawn by projected tetrahedra instead.
    pub walk_fallback: Option<String>,
    /// Walker: tets crossed (culled included), runs walked, edge tests
    /// decided exactly, runs ended at non-manifold links or the step bound.
    pub crossings: u64,
    pub walk_runs: u64,
    /// Walker: covered pixels walked, and covered pixels interpolated by
    /// adaptive sampling (`RasterOptions::walk_adaptive`).
    pub walk_rays: u64,
    pub walk_rays_interpolated: u64,
    pub walk_exact_tests: u64,
    pub walk_non_manifold: u64,
    pub walk_step_limit: u64,
    /// Walker: front boundary faces of the view, and rays stopped at `opaque_alpha`.
    pub walk_front_faces: usize,
    pub walk_terminated: u64,
    /// Walker: rays walked eight at a time in SIMD lanes (`RasterOptions::walk_packets`).
    pub walk_packet_rays: u64,
    /// Walker: the near plane cut the mesh (homogeneous walk, segments
    /// clipped at the near depth), and whether the eye was in a visible tet.
    pub walk_near_clipped: bool,
    pub walk_eye_inside: bool,
}

impl RenderStats {
    /// Drawn tets per second of total time.
    pub fn tets_per_second(&self) -> f64 {
        if self.total_seconds > 0.0 {
            self.tets_drawn as f64 / self.total_seconds
        } else {
            0.0
        }
    }

    /// "T M tets/s, cpu C s = N ns/fragment", as the frame profiles print
    /// it: throughput, and `cpu_seconds` of process CPU time spent on the
    /// frame ([`process_cpu_seconds`] before and after) in all and per
    /// fragment.
    pub fn throughput_summary(&self, cpu_seconds: f64) -> String {
        format!(
            "{:.2} M tets/s, cpu {:.2} s = {:.1} ns/fragment",
            self.tets_per_second() / 1e6,
            cpu_seconds,
            cpu_seconds * 1e9 / self.fragments.max(1) as f64
        )
    }
}

/// User + system CPU seconds of this process, all threads, from
/// `/proc/self/stat` (Linux; 0 elsewhere): set against wall time, how many
/// cores a frame kept busy.
pub fn process_cpu_seconds() -> f64 {
    let Ok(stat) = std::fs::read_to_string("/proc/self/stat") else { return 0.0 };
    // Fields after the parenthesised command name; utime and stime are the
    // 14th and 15th, in clock ticks (100 a second).
    let rest = stat.rsplit_once(')').map_or("", |(_, r)| r);
    let f: Vec<&str> = rest.split_whitespace().collect();
    let ticks = |i: usize| f.get(i).and_then(|v| v.parse::<f64>().ok()).unwrap_or(0.0);
    (ticks(11) + ticks(12)) / 100.0
}

/// A scene with its cached per-view and per-TF state.
pub struct Renderer {
    scene: Scene,
    camera: Option<Camera>,
    view: Option<ViewGeometry>,
    shader: Option<Arc<dyn SegmentShader>>,
    culler: Option<Arc<dyn CellCuller>>,
    cull: Option<CullMask>,
    sort: SortMethod,
    order: Option<VisibilityOrder>,
    raster: RasterOptions,
    /// The fast path's per-tet setup of the current view, order and mask.
    prepared: Option<PreparedFrame>,
    /// The cull mask a new culler replaced (what `prepared` was made for),
    /// compared with the new one when it is computed.
    replaced_cull: Option<CullMask>,
    /// Frames rendered from the current view and order.
    frames_in_view: u32,
    kind: CpuRenderer,
    /// The walker's per-scene links and per-view projection.
    walk_mesh: Option<WalkMesh>,
    walk_view: Option<WalkView>,
    /// `walk_view` is of an earlier view (its buffers are reused).
    walk_view_stale: bool,
    /// The cull mask in the walker's tet order (None: nothing culled or
    /// not yet made for the current mask).
    walk_visible: Option<Vec<bool>>,
    /// The faces rays enter the visible tets by, for the current mask.
    walk_entries: Option<crate::walk::EntryFaces>,
}

impl Renderer {
    pub fn new(scene: Scene) -> Renderer {
        Renderer {
            scene,
            camera: None,
            view: None,
            shader: None,
            culler: None,
            cull: None,
            sort: SortMethod::Auto,
            order: None,
            raster: RasterOptions::default(),
            prepared: None,
            replaced_cull: None,
            frames_in_view: 0,
            kind: CpuRenderer::default(),
            walk_mesh: None,
            walk_view: None,
            walk_view_stale: true,
            walk_visible: None,
            walk_entries: None,
        }
    }

    /// Chooses the CPU algorithm (the walker by default).
    pub fn set_renderer(&mut self, kind: CpuRenderer) {
        self.kind = kind;
    }

    pub fn renderer(&self) -> CpuRenderer {
        self.kind
    }

    /// Bytes the walker holds beyond the scene (links, boundary, projected
    /// vertices, binned faces); 0 before its first frame.
    pub fn walk_bytes(&self) -> usize {
        self.walk_mesh.as_ref().map_or(0, WalkMesh::memory_bytes)
            + self.walk_view.as_ref().map_or(0, WalkView::memory_bytes)
    }

    pub fn scene(&self) -> &Scene {
        &self.scene
    }

    /// The scene back, dropping every cached stage (e.g. to add gradients
    /// with [`Scene::ensure_gradients`] and start a new renderer on it).
    pub fn into_scene(self) -> Scene {
        self.scene
    }

    /// Replaces the scene's scalar (a time series' step): the walker keeps
    /// its per-scene links and vertex order and PT its view geometry and
    /// order (unless it is a radix order of culled tets), while the cull
    /// mask, the walker's projection (it carries the scalar) and PT's
    /// per-tet setup are redone. Gradients are dropped with the old scalar
    /// (the walker's copy with them).
    pub fn set_scalar(&mut self, scalar: Vec<f64>) -> Result<(), RenderError> {
        self.set_scalar_with_gradients(scalar, None)
    }

    /// [`Renderer::set_scalar`] with the new scalar's per-vertex gradients
    /// where they are known (a time series' stored ones), so that lighting
    /// and bivariate methods need not compute them.
    pub fn set_scalar_with_gradients(
        &mut self,
        scalar: Vec<f64>,
        gradients: Option<Vec<[f64; 3]>>,
    ) -> Result<(), RenderError> {
        if let Some(g) = &gradients {
            if g.len() != self.scene.positions_rel().len() {
                return Err(RenderError::Scene(format!(
                    "{} gradients for {} points",
                    g.len(),
                    self.scene.positions_rel().len()
                )));
            }
        }
        self.scene.set_scalar(scalar)?;
        if let Some(g) = gradients {
            self.scene.set_gradients(g)?;
        }
        if let Some(m) = &mut self.walk_mesh {
            m.set_scalar(&self.scene);
        }
        self.walk_view_stale = true;
        self.prepared = None;
        self.cull = None;
        self.replaced_cull = None;
        self.walk_visible = None;
        self.walk_entries = None;
        if self.order.as_ref().is_some_and(|o| o.method == SortMethod::Radix) {
            self.order = None;
        }
        Ok(())
    }

    /// Attaches (or drops) the shadow field lighting reads (see
    /// [`crate::shadow`]); nothing else is recomputed.
    pub fn set_shadows(&mut self, field: Option<Arc<crate::ShadowField>>) -> Result<(), RenderError> {
        self.scene.set_shadows(field)?;
        if let Some(m) = &mut self.walk_mesh {
            m.set_shadows(&self.scene);
        }
        Ok(())
    }

    /// Sets the camera; the view geometry and the order become stale unless
    /// the view is identical to the current one.
    pub fn set_view(&mut self, spec: &ViewSpec) -> Result<(), RenderError> {
        if self.camera.as_ref().is_some_and(|c| c.spec() == spec) {
            return Ok(());
        }
        self.camera = Some(Camera::new(spec)?);
        self.view = None;
        self.order = None;
        self.walk_view_stale = true;
        Ok(())
    }

    /// Forgets the camera: the next frame's view (even the same one) redoes
    /// the view geometry, the order and the walker's projection, as after a
    /// camera move — what benchmarks of a camera move time. The per-scene
    /// stages and the cull mask stay.
    pub fn forget_view(&mut self) {
        self.camera = None;
        self.view = None;
        self.order = None;
        self.walk_view_stale = true;
    }

    /// Sets the method's shader (what turns a segment into colour).
    pub fn set_shader(&mut self, shader: Arc<dyn SegmentShader>) {
        self.shader = Some(shader);
    }

    /// Drops the shader (and the renderer's reference to its tables, so
    /// their owner can update them in place); rendering needs a new one.
    pub fn clear_shader(&mut self) {
        self.shader = None;
    }

    /// Sets the culler of a new transfer function (`None`: draw every
    /// tet); the cull mask becomes stale, and so does a radix order.
    pub fn set_culler(&mut self, culler: Option<Arc<dyn CellCuller>>) {
        self.culler = culler;
        if let Some(mask) = self.cull.take() {
            self.replaced_cull = Some(mask);
        }
        if self.order.as_ref().is_some_and(|o| o.method == SortMethod::Radix) {
            self.order = None;
        }
    }

    pub fn set_sort(&mut self, sort: SortMethod) {
        if sort != self.sort {
            self.sort = sort;
            self.order = None;
        }
    }

    pub fn set_raster_options(&mut self, opts: RasterOptions) {
        if opts != self.raster {
            self.prepared = None;
        }
        if opts.tile != self.raster.tile {
            self.walk_view_stale = true;
        }
        self.raster = opts;
    }

    /// The current order, if computed.
    pub fn order(&self) -> Option<&VisibilityOrder> {
        self.order.as_ref()
    }
    /// Bytes held by the kept per-tet setup of the current view (0 when none).
    pub fn setup_bytes(&self) -> usize {
        self.prepared.as_ref().map_or(0, PreparedFrame::memory_bytes)
    }
    /// The current view geometry, if computed.
    pub fn view_geometry(&self) -> Option<&ViewGeometry> {
        self.view.as_ref()
    }

    /// Computes the cull mask when stale (a new culler), and drops the kept
    /// per-tet setup when the mask differs from the one it was made for.
    fn ensure_cull(&mut self, stats: &mut RenderStats) {
        if self.cull.is_some() {
            return;
        }
        let t = Instant::now();
        let mask = match &self.culler {
            Some(c) => cull(&self.scene, c.as_ref()),
            None => CullMask::all(self.scene.num_tets()),
        };
        // The kept setup covers the replaced mask's visible tets.
        if self.replaced_cull.take().is_none_or(|old| old.visible != mask.visible) {
            self.prepared = None;
        }
        self.cull = Some(mask);
        self.walk_visible = None;
        self.walk_entries = None;
        stats.cull_seconds = t.elapsed().as_secs_f64();
        stats.recomputed_cull = true;
    }

    /// The walker's stages — the scene's links once, the cull mask in walk
    /// order and the faces rays enter the visible tets by (once per mask),
    /// the view's projection (once per view) and face bins (per view and
    /// mask) — then every ray, or `None` when the view is one the walker
    /// cannot draw (the reason in `stats`).
    fn render_walk(
        &mut self,
        camera: &Camera,
        shader: &dyn SegmentShader,
        stats: &mut RenderStats,
        start: Instant,
        progress: &(dyn Fn(usize, usize) + Sync),
    ) -> Option<Image> {
        if self.walk_mesh.is_none() {
            self.walk_mesh = Some(WalkMesh::new(&self.scene));
        }
        self.ensure_cull(stats);
        let mesh = self.walk_mesh.as_ref().expect("built above");
        let mask = self.cull.as_ref().expect("computed above");
        let mut rebin = false;
        if self.walk_entries.is_none() {
            self.walk_visible = (mask.culled > 0).then(|| mesh.to_walk_order(&mask.visible));
            self.walk_entries = Some(mesh.entry_faces(self.walk_visible.as_deref()));
            rebin = true;
        }
        let entries = self.walk_entries.as_ref().expect("computed above");
        if self.walk_view_stale {
            let t = Instant::now();
            let old = self.walk_view.take();
            self.walk_view = Some(WalkView::recycle(old, &self.scene, mesh, camera, self.raster.tile, entries));
            self.walk_view_stale = false;
            stats.view_seconds = t.elapsed().as_secs_f64();
            stats.recomputed_view = true;
        } else if rebin {
            let t = Instant::now();
            self.walk_view.as_mut().expect("not stale").rebin(mesh, entries);
            stats.view_seconds = t.elapsed().as_secs_f64();
        }
        let wv = self.walk_view.as_ref().expect("built above");
        if let Some(why) = wv.unsupported() {
            stats.walk_fallback = Some(why.to_string());
            return None;
        }
        let visible = self.walk_visible.as_deref();
        let (image, ws) = walk_frame(mesh, wv, visible, shader, &self.raster, progress);
        stats.renderer = CpuRenderer::Walk.id().to_string();
        stats.tets_culled = mask.culled;
        stats.fraction_culled = mask.fraction_culled();
        stats.tets_drawn = mask.visible.len() - mask.culled;
        stats.fragments = ws.fragments;
        stats.crossings = ws.crossings;
        stats.walk_runs = ws.runs;
        stats.walk_rays = ws.rays;
        stats.walk_rays_interpolated = ws.rays_interpolated;
        stats.walk_exact_tests = ws.exact_tests;
        stats.walk_non_manifold = ws.non_manifold;
        stats.walk_step_limit = ws.step_limit;
        stats.walk_front_faces = ws.front_faces;
        stats.walk_terminated = ws.terminated;
        stats.walk_packet_rays = ws.packet_rays;
        stats.walk_near_clipped = ws.near_clipped;
        stats.walk_eye_inside = ws.eye_inside;
        stats.sort_method = "none".to_string();
        stats.raster_seconds = ws.walk_seconds;
        stats.total_seconds = start.elapsed().as_secs_f64();
        Some(image)
    }

    /// Renders, recomputing stale stages first.
    pub fn render(&mut self, progress: &(dyn Fn(usize, usize) + Sync)) -> Result<(Image, RenderStats), RenderError> {
        let start = Instant::now();
        let camera = self.camera.as_ref().ok_or(RenderError::NotReady("no view set"))?;
        let shader = self.shader.clone().ok_or(RenderError::NotReady("no shader set"))?;
        if self.raster.shading.is_active() && self.scene.gradients().is_none() {
            return Err(RenderError::NotReady("lighting and silhouettes need per-vertex gradients"));
        }
        if self.raster.shading.wants_shadows() {
            match self.scene.shadows() {
                None => return Err(RenderError::NotReady("shadows need a shadow field (Renderer::set_shadows)")),
                Some(f) if f.key().lights != self.raster.shading.sources => {
                    return Err(RenderError::NotReady("the shadow field was computed for other lights"))
                }
                Some(_) => {}
            }
        }
        let mut stats = RenderStats { tets_total: self.scene.num_tets(), ..Default::default() };
        if self.kind == CpuRenderer::Walk {
            let camera = camera.clone();
            if let Some(image) = self.render_walk(&camera, shader.as_ref(), &mut stats, start, progress) {
                return Ok((image, stats));
            }
        }
        let camera = self.camera.as_ref().expect("checked above");
        stats.renderer = CpuRenderer::Pt.id().to_string();

        if self.view.is_none() || self.order.is_none() {
            self.prepared = None;
            self.frames_in_view = 0;
        }
        if self.view.is_none() {
            let t = Instant::now();
            self.view = Some(ViewGeometry::new(&self.scene, camera));
            stats.view_seconds = t.elapsed().as_secs_f64();
            stats.recomputed_view = true;
        }
        self.ensure_cull(&mut stats);
        let view = self.view.as_ref().expect("computed above");
        let mask = self.cull.as_ref().expect("computed above");
        if self.order.is_none() {
            let t = Instant::now();
            // Graph sorts walk every tet anyway and their order must survive a
            // new TF (newly visible tets need their place): order all, filter
            // at draw time. The radix sort sorts visible tets only.
            let radix = self.sort.resolve(&self.scene) == SortMethod::Radix;
            let visible = (radix && mask.culled > 0).then_some(mask.visible.as_slice());
            self.order = Some(visibility_order(&self.scene, view, self.sort, visible));
            stats.sort_seconds = t.elapsed().as_secs_f64();
            stats.recomputed_order = true;
        }
        let order = self.order.as_ref().expect("computed above");
        // Every order holds each tet once, a radix order only the visible
        // ones: the mask filters the graph orders of a culling TF.
        let drawn = mask.visible.len() - mask.culled;
        let visible = (mask.culled > 0 && order.method != SortMethod::Radix).then_some(mask.visible.as_slice());
        debug_assert_eq!(
            drawn,
            visible.map_or(order.tets.len(), |v| order.tets.iter().filter(|&&t| v[t as usize]).count())
        );
        // A zero budget keeps nothing: `rasterize_cached` fills only what
        // fits, and only from a view's second frame on.
        let keep = self.frames_in_view > 0;
        let (image, rs): (Image, RasterStats) = rasterize_cached(
            &self.scene,
            view,
            &order.tets,
            visible,
            shader.as_ref(),
            &self.raster,
            &mut self.prepared,
            keep,
            progress,
        );
        self.frames_in_view = self.frames_in_view.saturating_add(1);
        stats.reused_setup = rs.reused_setup;
        stats.tets_culled = mask.culled;
        stats.fraction_culled = mask.fraction_culled();
        stats.tets_drawn = drawn;
        stats.cycles_broken = order.cycles_broken;
        stats.sort_method = order.method.id().to_string();
        stats.fragments = rs.fragments;
        stats.setups = rs.setups;
        stats.tiles_terminated = rs.tiles_terminated;
        stats.project_seconds = rs.bin_seconds;
        stats.raster_seconds = rs.raster_seconds;
        stats.total_seconds = start.elapsed().as_secs_f64();
        Ok((image, stats))
    }
}
