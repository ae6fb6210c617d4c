//! Frame requests and the renderers that answer them.

use std::sync::Arc;
use std::time::Instant;

use tet_bundle::Bundle;
use tet_preint::TransferFunction;
use tet_render::{
    Camera, CpuRenderer, Image, LitReference, RasterOptions, ReferenceOptions, ReferenceRenderer, ReferenceStats,
    RenderStats, Renderer, Scene, Shading, ShadowMode, SortMethod, TfCuller, ViewSpec,
};

use crate::{EngineError, Look};

/// The note for a scene that got per-vertex gradients now because the
/// bundle stores none (front ends that add them themselves say the same).
pub const GRADIENTS_NOTE: &str = "the bundle has no gradients: per-vertex gradients (least squares) computed now \
                                  (tetprep convert --gradients stores them)";

/// Everything about a frame but its look: where from, how big, how lit,
/// which CPU algorithm, what may be skipped.
#[derive(Debug, Clone, PartialEq)]
pub struct FrameRequest {
    pub view: ViewSpec,
    /// Lighting, shadows and silhouettes (the scene gets per-vertex
    /// gradients when the bundle has none). A `gradient_floor` of 0 gets
    /// the scene's default ([`Shading::gradient_floor_for`]). The CPU
    /// renderers light from a shadow field they compute when the lights,
    /// the TF or the scalar change (a camera move reuses it); the
    /// reference casts exact shadow rays and ignores silhouettes.
    pub shading: Shading,
    /// The CPU algorithm of [`CpuFrameRenderer`].
    pub cpu: CpuRenderer,
    /// Visibility order of projected tetrahedra.
    pub sort: SortMethod,
    /// Skip cells the TF makes fully transparent ([`TfCuller`]).
    pub cull: bool,
    /// Stop rays once nothing behind can change the pixel (the reference:
    /// α ≥ 1 − 1e-9; the CPU renderers: their opaque α).
    pub early_termination: bool,
    /// The walker only: image-space adaptive sampling at this tolerance
    /// (`tet_render::RasterOptions::walk_adaptive`: faster, the error
    /// measured, not bounded). `None`: every pixel's ray is walked.
    pub adaptive: Option<f32>,
}

/// Checks an adaptive-sampling request ([`FrameRequest::adaptive`]): a
/// tolerance in [0, 1] (a difference of premultiplied channels) for the
/// walker. `tetview` and the Python package check their arguments with it
/// before loading anything; [`CpuFrameRenderer`] checks every request.
pub fn check_adaptive(tol: f32, cpu: CpuRenderer) -> Result<(), EngineError> {
    if !(0.0..=1.0).contains(&tol) {
        return Err(EngineError::Adaptive { tol, why: "need a tolerance in [0, 1] (e.g. 0.004)" });
    }
    if cpu != CpuRenderer::Walk {
        return Err(EngineError::Adaptive { tol, why: "the walker only (not projected tetrahedra or the GPU)" });
    }
    Ok(())
}

impl FrameRequest {
    /// A request with the defaults of `tetview render`: no shading, the
    /// walker, automatic order, culling and early termination on.
    pub fn new(view: ViewSpec) -> FrameRequest {
        FrameRequest {
            view,
            shading: Shading::default(),
            cpu: CpuRenderer::default(),
            sort: SortMethod::Auto,
            cull: true,
            early_termination: true,
            adaptive: None,
        }
    }
}

/// What a renderer reports about a frame.
#[derive(Debug, Clone, PartialEq)]
pub enum FrameStats {
    /// [`CpuFrameRenderer`]: the staged pipeline's timings and counts.
    Cpu(RenderStats),
    /// [`ReferenceFrameRenderer`]: ray counts and the render's seconds.
    Reference { stats: ReferenceStats, render_seconds: f64 },
    /// [`crate::GpuFrameRenderer`]: the device's stages and counts.
    #[cfg(feature = "gpu")]
    Gpu(Box<crate::GpuFrameStats>),
}

/// A rendered frame: linear premultiplied RGBA and how it was made.
#[derive(Debug, Clone)]
pub struct Frame {
    pub image: Image,
    pub stats: FrameStats,
    /// What a front end may tell the user (e.g. gradients computed now).
    pub notes: Vec<String>,
}

/// A way to draw frames of one bundle. Implementations keep what they can
/// reuse between frames (the view's geometry while only the look changes,
/// the look's cull mask while only the view changes); the image depends
/// only on the look and the request, never on what was drawn before or on
/// the thread count.
pub trait FrameRenderer {
    /// Short id for reports (`walk`, `pt`, `reference`).
    fn id(&self) -> &'static str;
    /// Draws `look` as `req` asks; `progress(done, total)` may be called
    /// from worker threads.
    fn render(
        &mut self,
        look: &Look,
        req: &FrameRequest,
        progress: &(dyn Fn(usize, usize) + Sync),
    ) -> Result<Frame, EngineError>;
}

/// The CPU renderers of [`tet_render::Renderer`]: the face-adjacency
/// walker or projected tetrahedra, as [`FrameRequest::cpu`] says.
pub struct CpuFrameRenderer {
    /// `None` only while gradients are being added.
    renderer: Option<Renderer>,
    /// The key of the look whose shader is set ([`Look::key`]).
    look: Option<u64>,
    /// What the culler was set for: [`FrameRequest::cull`] and the TF it
    /// reads (the mask stays while the TF does: a new method, resolution or
    /// table of the same TF re-culls nothing).
    cull: Option<(bool, TransferFunction)>,
    /// Seconds the last frame spent computing its shadow field (0 when it
    /// reused one or has no shadows).
    pub shadow_seconds: f64,
}

/// `shading` with the scene's default gradient floor where it has none.
pub fn shading_for_scene(shading: Shading, scene: &Scene) -> Shading {
    if shading.gradient_floor > 0.0 {
        return shading;
    }
    let (lo, hi) = scene.bounds();
    Shading { gradient_floor: Shading::gradient_floor_for(scene.scalar_range(), lo, hi), ..shading }
}

impl CpuFrameRenderer {
    /// The renderer's copy of `bundle` (positions about the mesh centre).
    pub fn new(bundle: &Bundle) -> Result<CpuFrameRenderer, EngineError> {
        Ok(CpuFrameRenderer::from_scene(Scene::from_bundle(bundle)?))
    }

    pub fn from_scene(scene: Scene) -> CpuFrameRenderer {
        CpuFrameRenderer { renderer: Some(Renderer::new(scene)), look: None, cull: None, shadow_seconds: 0.0 }
    }

    /// The staged renderer (its scene, the walker's memory, the order).
    pub fn renderer(&self) -> &Renderer {
        self.renderer.as_ref().expect("a renderer outside ensure_gradients")
    }

    /// Replaces the bundle's scalar (a time step, e.g. from
    /// [`tet_bundle::TimeSteps::scalar_at`]): the per-scene and per-view
    /// geometry stays, what depends on the scalar is redone (see
    /// [`Renderer::set_scalar`]).
    pub fn set_scalar(&mut self, scalar: Vec<f64>) -> Result<(), EngineError> {
        self.set_scalar_with_gradients(scalar, None)
    }

    /// [`CpuFrameRenderer::set_scalar`] with the scalar's gradients where
    /// the bundle stores them ([`tet_bundle::TimeSteps::gradient_at`]): lit
    /// and bivariate frames then use them instead of computing them.
    pub fn set_scalar_with_gradients(
        &mut self,
        scalar: Vec<f64>,
        gradients: Option<Vec<[f64; 3]>>,
    ) -> Result<(), EngineError> {
        // The culler stays (it reads the scene's scalar when the mask is redone).
        self.renderer.as_mut().expect("a renderer").set_scalar_with_gradients(scalar, gradients)?;
        Ok(())
    }

    /// Drops the renderer's reference to the last look's tables, so that
    /// [`Look::rebake`] can re-bake them in place; the next frame sets its
    /// look again (the cull mask and the view's work stay).
    pub fn release_look(&mut self) {
        self.renderer.as_mut().expect("a renderer").clear_shader();
        self.look = None;
    }

    /// Forgets the camera: the next frame redoes its view's work (the
    /// walker's projection; PT's view geometry, order and per-tet setup)
    /// even for the same view, as a camera move does — what `tetview bench`
    /// times. The look's cull mask stays.
    pub fn forget_view(&mut self) {
        self.renderer.as_mut().expect("a renderer").forget_view();
    }

    /// Adds per-vertex gradients to the scene if it has none; true when it
    /// computed them.
    fn ensure_gradients(&mut self) -> Result<bool, EngineError> {
        if self.renderer().scene().gradients().is_some() {
            return Ok(false);
        }
        let scene = self.renderer.take().expect("a renderer").into_scene();
        match scene.ensure_gradients() {
            Ok(scene) => {
                self.renderer = Some(Renderer::new(scene));
                self.look = None;
                self.cull = None;
                Ok(true)
            }
            Err(e) => Err(e.into()),
        }
    }
}

impl FrameRenderer for CpuFrameRenderer {
    fn id(&self) -> &'static str {
        self.renderer().renderer().id()
    }

    fn render(
        &mut self,
        look: &Look,
        req: &FrameRequest,
        progress: &(dyn Fn(usize, usize) + Sync),
    ) -> Result<Frame, EngineError> {
        if let Some(tol) = req.adaptive {
            check_adaptive(tol, req.cpu)?;
        }
        let mut notes = Vec::new();
        if (req.shading.is_active() || look.method.is_bivariate()) && self.ensure_gradients()? {
            notes.push(GRADIENTS_NOTE.to_string());
        }
        let shader = look.shader()?;
        let same_shader = self.look == Some(look.key());
        let r = self.renderer.as_mut().expect("a renderer");
        r.set_view(&req.view)?;
        r.set_renderer(req.cpu);
        r.set_sort(req.sort);
        if !same_shader {
            r.set_shader(shader);
            self.look = Some(look.key());
        }
        if self.cull.as_ref().is_none_or(|(on, tf)| *on != req.cull || (req.cull && *tf != look.tf)) {
            r.set_culler(req.cull.then(|| Arc::new(TfCuller::new(&look.tf)) as Arc<dyn tet_render::CellCuller>));
            self.cull = Some((req.cull, look.tf.clone()));
        }
        self.shadow_seconds = 0.0;
        if req.shading.wants_shadows() {
            let stale =
                r.scene().shadows().is_none_or(|f| !f.is_for(&req.shading.sources, &look.tf, r.scene().scalar_range()));
            if stale {
                let t = Instant::now();
                let field = r.scene().compute_shadows(&look.tf, &req.shading.sources, &|_, _| {})?;
                r.set_shadows(Some(Arc::new(field)))?;
                self.shadow_seconds = t.elapsed().as_secs_f64();
            }
        }
        let shading = shading_for_scene(req.shading, r.scene());
        let mut raster = RasterOptions { shading, walk_adaptive: req.adaptive, ..Default::default() };
        if !req.early_termination {
            raster.opaque_alpha = f32::INFINITY;
        }
        r.set_raster_options(raster);
        let (image, stats) = r.render(progress)?;
        Ok(Frame { image, stats: FrameStats::Cpu(stats), notes })
    }
}

/// The exact ray caster ([`tet_render::ReferenceRenderer`]): exact ray–tet
/// segments, the exact integral of the look's TF (whatever its method), f64
/// compositing. Draws unshaded and uncropped by culling.
pub struct ReferenceFrameRenderer<'b> {
    renderer: ReferenceRenderer<'b>,
    bundle: &'b Bundle,
    /// The bundle as a scene with gradients, made for the first lit frame.
    scene: Option<Scene>,
    /// Light from this shadow field instead of exact shadow rays
    /// ([`ReferenceFrameRenderer::use_shadow_field`]).
    shadow_field: Option<Arc<tet_render::ShadowField>>,
    /// Seconds to build the boundary hierarchy rays enter by.
    pub setup_seconds: f64,
}

impl<'b> ReferenceFrameRenderer<'b> {
    pub fn new(bundle: &'b Bundle) -> Result<ReferenceFrameRenderer<'b>, EngineError> {
        let t = Instant::now();
        let renderer = ReferenceRenderer::new(&bundle.mesh, &bundle.adjacency)?;
        Ok(ReferenceFrameRenderer {
            renderer,
            bundle,
            scene: None,
            shadow_field: None,
            setup_seconds: t.elapsed().as_secs_f64(),
        })
    }

    /// The bundle as a scene with per-vertex gradients (computed now when
    /// the bundle has none).
    fn scene(&mut self) -> Result<&Scene, EngineError> {
        if self.scene.is_none() {
            self.scene = Some(Scene::from_bundle(self.bundle)?.ensure_gradients()?);
        }
        Ok(self.scene.as_ref().expect("made above"))
    }

    /// Shadows from the shadow field the CPU renderers use, computed
    /// now for `tf` and `lights`, instead of exact shadow rays: the
    /// difference of the two references is the field's own error.
    pub fn use_shadow_field(
        &mut self,
        tf: &TransferFunction,
        lights: &tet_render::LightSet,
    ) -> Result<(), EngineError> {
        let field = self.scene()?.compute_shadows(tf, lights, &|_, _| {})?;
        self.shadow_field = Some(Arc::new(field));
        Ok(())
    }
}

impl FrameRenderer for ReferenceFrameRenderer<'_> {
    fn id(&self) -> &'static str {
        "reference"
    }

    fn render(
        &mut self,
        look: &Look,
        req: &FrameRequest,
        progress: &(dyn Fn(usize, usize) + Sync),
    ) -> Result<Frame, EngineError> {
        let camera = Camera::new(&req.view)?;
        let options = ReferenceOptions { early_termination: req.early_termination, ..Default::default() };
        let t = Instant::now();
        let progress = |done: u32, total: u32| progress(done as usize, total as usize);
        let (image, stats) = if req.shading.light.is_some() {
            self.scene()?;
            let scene = self.scene.as_ref().expect("made above");
            let gradients = scene.gradients().expect("ensure_gradients");
            let shading = shading_for_scene(req.shading, scene);
            let shadows = match &self.shadow_field {
                Some(f) if req.shading.shadows => {
                    let f = f.as_ref();
                    if f.key().lights != req.shading.sources || f.key().tf != look.tf {
                        return Err(EngineError::Render(tet_render::RenderError::NotReady(
                            "the reference's shadow field was made for other lights or another TF",
                        )));
                    }
                    ShadowMode::Field(f)
                }
                _ => ShadowMode::Exact,
            };
            let lit = LitReference { options, ..LitReference::new(shading, gradients, shadows) };
            self.renderer.render_lit(&camera, &look.tf, &lit, &progress)?
        } else {
            self.renderer.render(&camera, &look.tf, &options, &progress)?
        };
        let render_seconds = t.elapsed().as_secs_f64();
        Ok(Frame { image, stats: FrameStats::Reference { stats, render_seconds }, notes: Vec::new() })
    }
}
