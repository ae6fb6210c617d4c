//! The renderer as stages that recompute only what a change invalidates
//! (seed 001's shared state with change notification, done with types):
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

use crate::camera::{Camera, ViewSpec};
use crate::cull::{cull, CellCuller, CullMask};
use crate::image::Image;
use crate::project::ViewGeometry;
use crate::raster::{rasterize_cached, PreparedFrame, RasterOptions, RasterStats};
use crate::scene::Scene;
use crate::sort::{visibility_order, SortMethod, VisibilityOrder};
use crate::RenderError;
use std::sync::Arc;
use std::time::Instant;
use tet_preint::SegmentShader;

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
        }
    }

    pub fn scene(&self) -> &Scene {
        &self.scene
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
        Ok(())
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

    /// Renders, recomputing stale stages first.
    pub fn render(&mut self, progress: &(dyn Fn(usize, usize) + Sync)) -> Result<(Image, RenderStats), RenderError> {
        let start = Instant::now();
        let camera = self.camera.as_ref().ok_or(RenderError::NotReady("no view set"))?;
        let shader = self.shader.clone().ok_or(RenderError::NotReady("no shader set"))?;
        if self.raster.shading.is_active() && self.scene.gradients().is_none() {
            return Err(RenderError::NotReady("lighting and silhouettes need per-vertex gradients"));
        }
        let mut stats = RenderStats { tets_total: self.scene.num_tets(), ..Default::default() };

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
        if self.cull.is_none() {
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
            stats.cull_seconds = t.elapsed().as_secs_f64();
            stats.recomputed_cull = true;
        }
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
