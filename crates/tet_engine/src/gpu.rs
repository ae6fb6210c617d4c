//! The GPU renderer behind the [`FrameRenderer`] trait (cargo feature
//! `gpu`): projected tetrahedra on tet_gpu, with the CPU's visibility order
//! and the look's own tables, so GPU and CPU images agree.
//!
//! Per frame: the view's geometry and visibility order come from
//! tet_render exactly as the CPU renderer computes them (every tet ordered;
//! the GPU compacts the culled ones out), then culling, classification,
//! rasterization and compositing run on the device and the linear image is
//! read back. The order is kept while the view and the sort method stay;
//! the look's tables (uploaded, or baked on the device) while its key
//! stays; the cull's data while the TF stays.

use std::time::Instant;

use tet_bundle::Bundle;
use tet_gpu::{
    FrameOptions, GpuAccumulation, GpuContext, GpuCull, GpuError, GpuFrame, GpuOrder, GpuRenderStats, GpuRenderer,
    GpuScene, GpuShader, GpuTable3d, RasterPath, ShadowMaps, ToneResult, GPU_METHODS,
};
use tet_preint::{BakeOptions, Build3d, Method, Table3dParams, TransferFunction};
use tet_render::project::ViewGeometry;
use tet_render::{visibility_order, Camera, Display, Scene, ShadowField, SortMethod, ViewSpec, VisibilityOrder};

use crate::{count_table_bake, EngineError, Frame, FrameRenderer, FrameRequest, FrameStats, GpuFailure, Look};

/// Where a GPU frame's time went and what it drew (wall-clock seconds; each
/// device stage waited for on its own so it can be timed).
#[derive(Debug, Clone, PartialEq)]
pub struct GpuFrameStats {
    /// The device's stages and counts.
    pub render: GpuRenderStats,
    /// The adapter ([`GpuContext::describe`]).
    pub device: String,
    /// The order's method id and the cycles it broke.
    pub sort_method: &'static str,
    pub cycles_broken: usize,
    pub tets_total: usize,
    /// The view's geometry and order were computed this frame (a new view
    /// or sort method); 0 seconds for both when they were kept.
    pub recomputed_order: bool,
    pub view_seconds: f64,
    pub sort_seconds: f64,
    /// Tables baked on the device this frame (0 otherwise; a CPU bake is
    /// the look's [`Look::shader_seconds`]).
    pub device_bake_seconds: f64,
    pub device_bake_setup_seconds: f64,
    /// The cull's TF data was built this frame (a new TF, time step or
    /// gradients).
    pub recomputed_cull: bool,
    /// Building the cull's TF data this frame.
    pub cull_setup_seconds: f64,
    /// Tables uploaded or baked and the cull built this frame (0 when the
    /// look was the last frame's).
    pub setup_seconds: f64,
    /// Computing the shadow field (on the CPU) and its maps this frame (0
    /// when the last frame's still held, or without shadows).
    pub shadow_seconds: f64,
}

/// How the GPU renderer draws.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub struct GpuFrameOptions {
    /// The compute-shader tile rasterizer or the hardware one (same images).
    pub raster: RasterPath,
}

/// Projected tetrahedra on the GPU, lit (headlight, directional and point
/// lights, silhouettes) as the CPU's projected tetrahedra light a fragment,
/// with their shadows: the shadow field's deep shadow maps (a point light's
/// cube of them inside or beside the mesh's box), computed on the CPU as
/// the CPU renderers compute them and kept while the lights, TF and scalar
/// stay.
pub struct GpuFrameRenderer {
    ctx: GpuContext,
    /// `None` only while gradients are being added (as `gpu_scene`).
    scene: Option<Scene>,
    gpu_scene: Option<GpuScene>,
    renderer: GpuRenderer,
    options: GpuFrameOptions,
    /// The shader of the look with this key.
    shader: Option<(u64, GpuShader)>,
    /// The cull of this TF.
    cull: Option<(TransferFunction, GpuCull)>,
    /// The visibility order of this view and sort method.
    order: Option<(ViewSpec, SortMethod, VisibilityOrder)>,
    /// The shadow field of the last shadowed frame (its key says for which
    /// lights, TF and scalar) and its maps for the device.
    shadows: Option<(ShadowField, ShadowMaps)>,
    /// The last frame (its HDR texture, for [`GpuFrameRenderer::tonemap_last`]).
    last: Option<GpuFrame>,
    /// Seconds to open the device.
    pub device_seconds: f64,
}

/// Wraps a tet_gpu error with what a front end needs to act on it.
pub(crate) fn gpu_error(e: GpuError) -> EngineError {
    let kind = match e {
        GpuError::NoAdapter { .. } | GpuError::MissingFeature { .. } | GpuError::Device { .. } => GpuFailure::NoDevice,
        GpuError::Unsupported(_) => GpuFailure::Unsupported,
        _ => GpuFailure::Failed,
    };
    EngineError::Gpu { kind, source: Box::new(e) }
}

fn unsupported(what: String) -> EngineError {
    gpu_error(GpuError::Unsupported(what))
}

impl GpuFrameRenderer {
    /// Opens the first GPU adapter (headless) and uploads `bundle`'s mesh;
    /// `scene` is the CPU scene of the same bundle (its visibility order;
    /// gradients are added when a bivariate look needs them).
    pub fn new(bundle: &Bundle, scene: Scene, options: GpuFrameOptions) -> Result<GpuFrameRenderer, EngineError> {
        let t = Instant::now();
        let ctx = GpuContext::new_headless().map_err(gpu_error)?;
        let device_seconds = t.elapsed().as_secs_f64();
        let mesh = &bundle.mesh;
        let gpu_scene = GpuScene::new(&ctx, &mesh.points, &mesh.tets, &mesh.scalar).map_err(gpu_error)?;
        let renderer = GpuRenderer::new(&ctx).map_err(gpu_error)?;
        Ok(GpuFrameRenderer {
            ctx,
            scene: Some(scene),
            gpu_scene: Some(gpu_scene),
            renderer,
            options,
            shader: None,
            cull: None,
            order: None,
            shadows: None,
            last: None,
            device_seconds,
        })
    }

    /// Replaces the bundle's scalar (a time step): the mesh on the device
    /// stays, the scalar is written into its buffers; the cull and the
    /// gradients of the old scalar are dropped.
    pub fn set_scalar(&mut self, scalar: Vec<f64>) -> Result<(), EngineError> {
        let gpu_scene = self.gpu_scene.as_mut().expect("a GPU scene outside gradient upload");
        gpu_scene.set_scalar(&self.ctx, &scalar).map_err(gpu_error)?;
        self.scene.as_mut().expect("a scene outside gradient upload").set_scalar(scalar)?;
        self.cull = None;
        Ok(())
    }

    fn gpu_scene(&self) -> &GpuScene {
        self.gpu_scene.as_ref().expect("a GPU scene outside gradient upload")
    }

    /// What the adapter is.
    pub fn describe(&self) -> String {
        self.ctx.describe()
    }

    /// Whether the adapter is a software rasterizer (lavapipe), where the
    /// CPU renderers are usually faster.
    pub fn is_software(&self) -> bool {
        self.ctx.is_software()
    }

    /// Whether the GPU has `method` (every method but `exact`).
    pub fn supports_method(method: Method) -> bool {
        GPU_METHODS.contains(&method)
    }

    /// Whether the GPU draws `method` with `req`'s shading; `Err` says why
    /// not (checked before any device work by front ends that want to).
    /// Every shading is drawn (`req` is not consulted today).
    pub fn supports(method: Method, _req: &FrameRequest) -> Result<(), String> {
        if !GpuFrameRenderer::supports_method(method) {
            let ids: Vec<&str> = GPU_METHODS.iter().map(|m| m.id()).collect();
            return Err(format!("method {method} is not on the GPU yet (GPU methods: {})", ids.join(", ")));
        }
        Ok(())
    }

    /// Tone maps the last frame on the device as `display` says (8-bit
    /// sRGB; the same operator as [`tet_render::Image::to_rgba8`]).
    pub fn tonemap_last(&self, display: &Display) -> Result<ToneResult, EngineError> {
        let frame = self.last.as_ref().ok_or_else(|| gpu_error(GpuError::Input("no frame rendered yet".into())))?;
        self.renderer.tonemap(&self.ctx, frame, display).map_err(gpu_error)
    }

    /// The look's shader on the device: its tables uploaded, or (a look
    /// [`Look::baked_by_renderer`] of table3d) baked on the device with the
    /// CPU's axis and resolution. Returns (device bake, its setup) seconds.
    fn ensure_shader(&mut self, look: &Look) -> Result<(f64, f64), EngineError> {
        if self.shader.as_ref().is_some_and(|(k, _)| *k == look.key()) {
            return Ok((0.0, 0.0));
        }
        self.shader = None;
        let (shader, seconds) = match &look.baked {
            Some(baked) => (GpuShader::from_baked(&self.ctx, baked).map_err(gpu_error)?, (0.0, 0.0)),
            None if look.method == Method::Table3d => {
                let domain = look.domain.ok_or(EngineError::NotBaked { method: look.method })?;
                count_table_bake();
                // The slice recurrence on the device (the CPU default is the
                // adaptive build): same axis and resolution, entries within ~1e-5.
                let params = Table3dParams { build: Build3d::default(), ..BakeOptions::default().table3d };
                let table =
                    GpuTable3d::bake(&self.ctx, &look.tf, &domain, &params, GpuAccumulation::F32).map_err(gpu_error)?;
                let s = table.stats();
                let seconds = (s.bake_seconds, s.setup_seconds);
                (GpuShader::table3d_baked(&self.ctx, &table).map_err(gpu_error)?, seconds)
            }
            None => return Err(EngineError::NotBaked { method: look.method }),
        };
        self.shader = Some((look.key(), shader));
        Ok(seconds)
    }
}

impl FrameRenderer for GpuFrameRenderer {
    fn id(&self) -> &'static str {
        "gpu"
    }

    fn render(
        &mut self,
        look: &Look,
        req: &FrameRequest,
        _progress: &(dyn Fn(usize, usize) + Sync),
    ) -> Result<Frame, EngineError> {
        GpuFrameRenderer::supports(look.method, req).map_err(unsupported)?;
        let mut notes = Vec::new();
        let lit = req.shading.is_active();
        let need_mags = look.method.is_bivariate() && !self.gpu_scene().has_gradient_magnitudes();
        let need_grads = lit && !self.gpu_scene().has_gradients();
        if need_mags || need_grads {
            let scene = self.scene.take().expect("a scene outside this block");
            if scene.gradients().is_none() {
                notes.push(crate::GRADIENTS_NOTE.to_string());
            }
            let scene = self.scene.insert(scene.ensure_gradients()?);
            let mut gpu_scene = self.gpu_scene.take().expect("a GPU scene outside this block");
            if need_mags {
                let g = scene.gradient_magnitudes().expect("gradients ensured above");
                gpu_scene = gpu_scene.with_gradient_magnitudes(&self.ctx, g).map_err(gpu_error)?;
                self.cull = None;
            }
            if need_grads {
                let g = scene.gradients().expect("gradients ensured above");
                gpu_scene = gpu_scene.with_gradients(&self.ctx, g).map_err(gpu_error)?;
            }
            self.gpu_scene = Some(gpu_scene);
        }
        let camera = Camera::new(&req.view)?;
        let scene = self.scene.as_ref().expect("a scene");
        let tets_total = scene.num_tets();
        // The CPU's shading: the scene's default gradient floor where the request has none.
        let shading = crate::frame::shading_for_scene(req.shading, scene);
        let recomputed_order = self.order.as_ref().is_none_or(|(v, s, _)| *v != req.view || *s != req.sort);
        let (mut view_seconds, mut sort_seconds) = (0.0, 0.0);
        if recomputed_order {
            // The order depends on the geometry alone (no cull mask): a new
            // scalar or TF keeps it.
            self.order = None;
            let t = Instant::now();
            let geometry = ViewGeometry::new(scene, &camera);
            view_seconds = t.elapsed().as_secs_f64();
            let t = Instant::now();
            let order = visibility_order(scene, &geometry, req.sort, None);
            sort_seconds = t.elapsed().as_secs_f64();
            self.order = Some((req.view.clone(), req.sort, order));
        }

        let t = Instant::now();
        let (device_bake_seconds, device_bake_setup_seconds) = self.ensure_shader(look)?;
        let t_cull = Instant::now();
        let recomputed_cull = req.cull && self.cull.as_ref().is_none_or(|(tf, _)| *tf != look.tf);
        if !req.cull {
            self.cull = None;
        } else if recomputed_cull {
            self.cull = None;
            let cull = GpuCull::new(&self.ctx, self.gpu_scene(), &look.tf).map_err(|e| match e {
                GpuError::Unsupported(w) => unsupported(format!("culling: {w}; draw without culling")),
                e => gpu_error(e),
            })?;
            self.cull = Some((look.tf.clone(), cull));
        }
        let cull_setup_seconds = t_cull.elapsed().as_secs_f64();
        let setup_seconds = t.elapsed().as_secs_f64();

        let mut shadow_seconds = 0.0;
        if shading.wants_shadows() {
            let scene = self.scene.as_ref().expect("a scene");
            let stale = self
                .shadows
                .as_ref()
                .is_none_or(|(f, _)| !f.is_for(&req.shading.sources, &look.tf, scene.scalar_range()));
            if stale {
                self.shadows = None;
                let t = Instant::now();
                let field = scene.compute_shadows(&look.tf, &req.shading.sources, &|_, _| {})?;
                let centre = self.gpu_scene.as_ref().expect("a GPU scene").centre_in_world();
                let maps = ShadowMaps::new(&field, centre).map_err(gpu_error)?;
                self.shadows = Some((field, maps));
                shadow_seconds = t.elapsed().as_secs_f64();
            }
        }

        let shader = &self.shader.as_ref().expect("ensured above").1;
        let order = &self.order.as_ref().expect("set above").2;
        let opts = FrameOptions {
            raster: self.options.raster,
            cull: self.cull.as_ref().map(|c| &c.1),
            shading: lit.then_some(&shading),
            shadows: self.shadows.as_ref().filter(|_| shading.wants_shadows()).map(|(_, m)| m),
        };
        // The previous frame's texture is reused by this one.
        self.last = None;
        let frame = self
            .renderer
            .render_frame(
                &self.ctx,
                self.gpu_scene.as_ref().expect("a GPU scene"),
                &camera,
                GpuOrder::Given(&order.tets),
                shader,
                &opts,
            )
            .map_err(gpu_error)?;
        let stats = GpuFrameStats {
            render: frame.stats.clone(),
            device: self.ctx.describe(),
            sort_method: order.method.id(),
            cycles_broken: order.cycles_broken,
            tets_total,
            recomputed_order,
            view_seconds,
            sort_seconds,
            device_bake_seconds,
            device_bake_setup_seconds,
            recomputed_cull,
            cull_setup_seconds,
            setup_seconds,
            shadow_seconds,
        };
        let image = frame.image.clone();
        self.last = Some(frame);
        Ok(Frame { image, stats: FrameStats::Gpu(Box::new(stats)), notes })
    }
}
