//! The viewer's renderer, without a window: a request (view, TF, method,
//! display) in, an 8-bit image and statistics out, recomputing only what
//! changed since the last request. A client of tet_engine: the frames are
//! [`CpuFrameRenderer`]'s or [`GpuFrameRenderer`]'s, drawn with
//! [`Look`]s; this module decides which look and which renderer.
//!
//! * Looks: a new TF revision, method or table resolution bakes a new one
//!   (the CPU path's options for both renderers); a camera move keeps it.
//!   table3d keeps its plain table, so a TF edit re-bakes only the pairs
//!   it reaches ([`Look::rebake`]). That plain table is drawn at once; the
//!   certified bake of the same TF ([`Certifier`]: the bake measures its
//!   own error and refines until it holds 1e-3, for any TF) runs on a
//!   thread beside the frames and replaces it when done
//!   ([`Engine::poll_certification`]; the frame's [`TableAccuracy`] says
//!   which one is on screen). One bake runs at a time: while a TF is
//!   dragged, only the newest revision is queued.
//! * CPU ([`CpuFrameRenderer`]): a new view redoes the view's work only; a
//!   new TF re-culls; a new method or table of the same TF re-culls
//!   nothing.
//! * GPU ([`GpuFrameRenderer`], every method of
//!   [`GpuFrameRenderer::supports_method`] — all but `exact` — when an
//!   adapter exists): the CPU's visibility order, recomputed only when the
//!   camera moves; culling on the device, redone for a new TF; the look's
//!   tables uploaded when the look changes; the bivariate methods'
//!   per-vertex |∇s| uploaded once, when one is first chosen. Its table3d
//!   is the plain table (the GPU's lookup neither splits at TF nodes nor
//!   integrates exactly).

use crate::ViewerError;
use std::sync::Arc;
use std::time::Instant;
use tet_bundle::Bundle;
use tet_engine::{
    Certifier, CpuFrameRenderer, EngineError, FrameRenderer, FrameStats as EngineStats, GpuFailure, GpuFrameRenderer,
    Look,
};
use tet_preint::{BakeOptions, CertifyOptions, Method, Table3dParams, TableDomain, TransferFunction};
use tet_render::{Display, Image, Scene, Shading, ViewSpec};

/// Everything a frame depends on.
#[derive(Clone)]
pub struct FrameRequest {
    pub view: ViewSpec,
    /// In data units (the TF model's; the cull reads it as it is).
    pub tf: Arc<TransferFunction>,
    /// Changes whenever `tf` does (the engine compares revisions, not TFs).
    pub tf_revision: u64,
    pub method: Method,
    /// table3d: samples along Sf and Sb (along l twice as many).
    pub table_n_s: usize,
    /// Use the GPU when it can render `method`.
    pub prefer_gpu: bool,
    pub display: Display,
    /// A time-series bundle's time (`None`: the scalar as loaded, the
    /// first step).
    pub time: Option<f64>,
    /// Lighting and shadows (on the GPU when preferred).
    pub shading: Shading,
    /// The CPU walker's adaptive sampling (`tet_engine::FrameRequest::adaptive`),
    /// which the window asks for while the user drags; other renderers
    /// draw every pixel.
    pub adaptive: Option<f32>,
}

impl FrameRequest {
    /// Whether two requests render the same image.
    pub fn same_frame(&self, other: &FrameRequest) -> bool {
        self.view == other.view
            && self.tf_revision == other.tf_revision
            && self.method == other.method
            && self.table_n_s == other.table_n_s
            && self.prefer_gpu == other.prefer_gpu
            && self.display == other.display
            && self.time == other.time
            && self.shading == other.shading
            && self.adaptive == other.adaptive
    }
}

/// What a frame cost and what it recomputed.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct FrameStats {
    /// "CPU" or "GPU: <adapter>", with why the CPU was used when a GPU was asked for.
    pub backend: String,
    pub frame_seconds: f64,
    /// Shader / table bake of this frame (0 when reused).
    pub bake_seconds: f64,
    /// The last bake, whenever it happened.
    pub last_bake_seconds: f64,
    /// View work: PT's view geometry and visibility sort, the walker's
    /// vertex projection and face binning.
    pub sort_seconds: f64,
    pub tets_total: usize,
    pub tets_culled: usize,
    pub tets_drawn: usize,
    /// The frame's look is not the last frame's of its renderer: baked for
    /// a new TF, method or resolution, or the certified table swapped in.
    pub rebaked: bool,
    pub recomputed_cull: bool,
    /// The view's work was redone (a camera move; PT's radix order after a TF edit).
    pub resorted: bool,
    pub size: [u32; 2],
    /// Which table3d drew the frame, measured how.
    pub accuracy: TableAccuracy,
}

/// Where the frame's table stands against the certify target
/// ([`tet_preint::certify`], 1e-3 per segment by default).
#[derive(Debug, Clone, Default, PartialEq)]
pub enum TableAccuracy {
    /// Not a CPU table3d frame (other methods carry their own error; the
    /// GPU's lookup neither splits at TF nodes nor integrates exactly, so
    /// its table3d is the plain one: [`TableAccuracy::GpuPlain`]).
    #[default]
    NotApplicable,
    /// The plain table (re-baked for the last TF edit) is drawn; its
    /// certified bake runs beside the frames.
    Certifying,
    /// The certified bake's table is drawn.
    Measured {
        certified: bool,
        /// The largest per-segment error the bake measured.
        max_error: f64,
        target: f64,
    },
    /// The certified bake failed; the plain table stays, unmeasured.
    Failed(String),
    /// The GPU drew table3d with the plain table.
    GpuPlain,
}

impl std::fmt::Display for TableAccuracy {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            TableAccuracy::NotApplicable => Ok(()),
            TableAccuracy::Certifying => f.write_str("table: certifying…"),
            TableAccuracy::Measured { certified: true, max_error, target } => {
                write!(f, "table certified: max {max_error:.1e} <= {target:e}")
            }
            TableAccuracy::Measured { certified: false, max_error, target } => {
                write!(f, "table NOT certified: max {max_error:.1e} > {target:e} within the memory budget")
            }
            TableAccuracy::Failed(e) => write!(f, "table not certified: {e}"),
            TableAccuracy::GpuPlain => f.write_str("GPU table: plain, not certified"),
        }
    }
}

impl FrameStats {
    pub fn tets_per_second(&self) -> f64 {
        if self.frame_seconds > 0.0 {
            self.tets_drawn as f64 / self.frame_seconds
        } else {
            0.0
        }
    }
}

/// A rendered frame: 8-bit sRGB RGBA after tone mapping over the background,
/// and the linear image it came from.
pub struct Frame {
    pub rgba8: Vec<u8>,
    pub image: Image,
    pub view: ViewSpec,
    pub stats: FrameStats,
}

/// The methods the GPU path renders ([`GpuFrameRenderer::supports_method`]).
pub fn gpu_supports(method: Method) -> bool {
    GpuFrameRenderer::supports_method(method)
}

/// The bake options of the viewer's looks at table resolution `n_s` (table3d
/// `n_s` × `n_s` × 2`n_s`, plain: its certified bake runs beside the frames;
/// atlas2d from a table of that resolution; the other methods' defaults).
pub fn bake_options(n_s: usize) -> BakeOptions {
    let defaults = BakeOptions::default();
    BakeOptions {
        table3d: Table3dParams { n_s, n_l: 2 * n_s, ..defaults.table3d },
        certify: CertifyOptions::off(),
        ..defaults
    }
}

/// (TF revision, method, table n_s): what a plain look is baked for.
type LookKey = (u64, Method, usize);

/// The staged renderer behind the window.
pub struct Engine {
    cpu: CpuFrameRenderer,
    /// The CPU algorithm of CPU frames.
    cpu_kind: tet_render::CpuRenderer,
    gpu: Option<GpuFrameRenderer>,
    /// Why there is no GPU path (shown in the status line).
    gpu_note: String,
    domain: TableDomain,
    /// The plain table3d look of the last table3d request, re-baked for the
    /// next TF edit.
    table: Option<(LookKey, Look)>,
    /// The look of the last request of another method.
    other: Option<(LookKey, Look)>,
    /// The keys of the looks the CPU and the GPU drew last.
    cpu_drawn: Option<u64>,
    gpu_drawn: Option<u64>,
    last_bake_seconds: f64,
    certifier: Certifier,
    /// The plain look's key of the last CPU table3d frame.
    cert_wanted: Option<u64>,
    /// A time series' steps, and the time the scene's scalar is at.
    steps: Option<tet_bundle::TimeSteps>,
    time: Option<f64>,
    /// The range a normalized TF spans (every step's, for a series).
    scalar_range: [f64; 2],
    /// Seconds the last frame (CPU or GPU) spent on its shadow field.
    shadow_seconds: f64,
}

impl Engine {
    /// Loads the scene; with `try_gpu`, opens a headless GPU renderer (its
    /// failure is not an error: the CPU renders, and [`Engine::gpu_note`]
    /// says why).
    pub fn new(bundle: &Bundle, try_gpu: bool) -> Result<Engine, ViewerError> {
        let scene = Scene::from_bundle(bundle)?;
        let domain = TableDomain::from_bundle(bundle)?;
        let (gpu, gpu_note) = if try_gpu {
            match GpuFrameRenderer::new(bundle, scene.clone(), Default::default()) {
                Ok(g) => {
                    let note = g.describe();
                    (Some(g), note)
                }
                Err(e) => (None, format!("no GPU: {e}")),
            }
        } else {
            (None, "GPU off (--cpu)".to_string())
        };
        let certifier = Certifier::new(bundle, domain, CertifyOptions::default())?;
        Ok(Engine {
            cpu: CpuFrameRenderer::from_scene(scene),
            cpu_kind: tet_render::CpuRenderer::default(),
            gpu,
            gpu_note,
            domain,
            table: None,
            other: None,
            cpu_drawn: None,
            gpu_drawn: None,
            last_bake_seconds: 0.0,
            certifier,
            cert_wanted: None,
            steps: bundle.steps.clone(),
            time: None,
            scalar_range: bundle.scalar_range().into(),
            shadow_seconds: 0.0,
        })
    }

    /// The adapter's description, or why there is none.
    pub fn gpu_note(&self) -> &str {
        &self.gpu_note
    }
    pub fn has_gpu(&self) -> bool {
        self.gpu.is_some()
    }

    /// The CPU algorithm (the ray walker by default; projected tetrahedra
    /// draw as the GPU does).
    pub fn set_cpu_renderer(&mut self, kind: tet_render::CpuRenderer) {
        self.cpu_kind = kind;
    }
    /// Whether the GPU is a software adapter (lavapipe): on such a machine
    /// tet_render's CPU renderer is much faster, so the window starts on it.
    pub fn gpu_is_software(&self) -> bool {
        self.gpu.as_ref().is_some_and(GpuFrameRenderer::is_software)
    }
    pub fn scene(&self) -> &Scene {
        self.cpu.renderer().scene()
    }
    pub fn domain(&self) -> &TableDomain {
        &self.domain
    }
    /// The time steps of a time-series bundle.
    pub fn time_steps(&self) -> Option<&tet_bundle::TimeSteps> {
        self.steps.as_ref()
    }
    /// The scalar range a normalized TF spans: over every step for a time
    /// series (so colours mean the same at every time), else the scene's.
    pub fn scalar_range(&self) -> [f64; 2] {
        self.scalar_range
    }

    /// Moves the scene's scalar to `time` (a time series; `None` keeps it):
    /// the CPU renderer keeps its per-scene walker links, the GPU its mesh
    /// and order; what the scalar feeds (culls, gradients) is redone.
    fn apply_time(&mut self, time: Option<f64>) -> Result<(), ViewerError> {
        let (Some(t), Some(steps)) = (time, &self.steps) else { return Ok(()) };
        if self.time == Some(t) {
            return Ok(());
        }
        let scalar = steps.scalar_at(t).map_err(|e| ViewerError::Input(e.to_string()))?;
        let gradients = steps.gradient_at(t).map_err(|e| ViewerError::Input(e.to_string()))?;
        if let Some(g) = &mut self.gpu {
            g.set_scalar(scalar.clone())?;
        }
        self.cpu.set_scalar_with_gradients(scalar, gradients)?;
        self.time = Some(t);
        Ok(())
    }

    /// Renders `req`, recomputing only what changed since the last call.
    pub fn render(&mut self, req: &FrameRequest) -> Result<Frame, ViewerError> {
        self.apply_time(req.time)?;
        let use_gpu = req.prefer_gpu && self.gpu.is_some() && gpu_supports(req.method);
        let mut refused = None;
        if use_gpu {
            // Lighting and shadows are drawn on the GPU too; a request it
            // cannot draw is drawn on the CPU, saying why.
            match self.render_gpu(req) {
                Err(ViewerError::Engine(EngineError::Gpu { kind: GpuFailure::Unsupported, source })) => {
                    refused = Some(source.to_string())
                }
                other => return other,
            }
        }
        let backend = if let Some(why) = refused {
            format!("CPU ({why})")
        } else if self.gpu.is_none() {
            format!("CPU ({})", self.gpu_note)
        } else if !req.prefer_gpu {
            format!("CPU (GPU {} not selected)", self.gpu_note)
        } else {
            format!("CPU (method {} is not on the GPU)", req.method)
        };
        self.render_cpu(req, backend)
    }

    /// The plain look of `req` (its TF, method and table resolution) and
    /// the seconds baking it took this frame (0 when it was kept). A new TF
    /// revision re-bakes the held table3d in place (the CPU renderer lets
    /// go of it first).
    fn plain_look(&mut self, req: &FrameRequest) -> Result<(Look, f64), ViewerError> {
        let key = (req.tf_revision, req.method, req.table_n_s);
        let held = if req.method == Method::Table3d { &mut self.table } else { &mut self.other };
        if let Some((k, look)) = held.as_ref() {
            if *k == key {
                return Ok((look.clone(), 0.0));
            }
        }
        let t = Instant::now();
        let options = bake_options(req.table_n_s);
        let tf = TransferFunction::clone(&req.tf);
        let look = match held.take() {
            Some((_, prev)) if req.method == Method::Table3d => {
                // The CPU renderer's reference goes, so the table is re-baked
                // in place; it gets the new look before it draws again.
                self.cpu.release_look();
                self.cpu_drawn = None;
                prev.rebake(&self.domain, tf, &options)?
            }
            _ => Look::bake_with(&self.domain, req.method, tf, &options, &[])?,
        };
        let bake_seconds = t.elapsed().as_secs_f64();
        self.last_bake_seconds = bake_seconds;
        let held = if req.method == Method::Table3d { &mut self.table } else { &mut self.other };
        *held = Some((key, look.clone()));
        Ok((look, bake_seconds))
    }

    /// Takes a finished certified bake and starts the queued one; true
    /// when the table for the last CPU table3d frame arrived, so that
    /// re-rendering that frame's request shows it (the window's worker
    /// calls this while it waits for requests).
    pub fn poll_certification(&mut self) -> bool {
        self.certifier.poll().is_some_and(|k| self.cert_wanted == Some(k))
    }

    /// Blocks until no certified bake runs or waits (tests; scripted runs
    /// poll instead).
    pub fn wait_for_certification(&mut self) {
        self.certifier.wait();
    }

    /// The frame request of tet_engine for `req`: the viewer's CPU
    /// algorithm and the request's shading, tet_engine's defaults otherwise
    /// (culled, early termination).
    fn engine_request(&self, req: &FrameRequest) -> tet_engine::FrameRequest {
        tet_engine::FrameRequest {
            cpu: self.cpu_kind,
            shading: req.shading,
            adaptive: req.adaptive.filter(|_| self.cpu_kind == tet_render::CpuRenderer::Walk),
            ..tet_engine::FrameRequest::new(req.view.clone())
        }
    }

    /// Seconds the last frame spent on its shadow field (0 when it reused
    /// one).
    pub fn shadow_seconds(&self) -> f64 {
        self.shadow_seconds
    }

    fn render_cpu(&mut self, req: &FrameRequest, backend: String) -> Result<Frame, ViewerError> {
        let start = Instant::now();
        self.certifier.poll();
        let (plain, bake_seconds) = self.plain_look(req)?;
        let table3d = req.method == Method::Table3d && req.tf.widgets().is_empty();
        // The certified table of this look, when its bake is done, and what
        // the frame says of its table.
        let (look, accuracy) = if table3d {
            self.certifier.certify(&plain)?;
            self.cert_wanted = Some(plain.key());
            match self.certifier.certified(plain.key()) {
                Some(Ok(certified)) => {
                    let accuracy = match certified.baked.as_deref() {
                        Some(tet_preint::Baked::Table3d(t)) => match t.certificate() {
                            Some(c) => TableAccuracy::Measured {
                                certified: c.certified,
                                max_error: c.max_error,
                                target: c.target,
                            },
                            None => TableAccuracy::Failed("the bake measured nothing".into()),
                        },
                        _ => TableAccuracy::Failed("the certified bake gave no table".into()),
                    };
                    (certified.clone(), accuracy)
                }
                Some(Err(e)) => (plain, TableAccuracy::Failed(e.to_string())),
                None => (plain, TableAccuracy::Certifying),
            }
        } else {
            self.cert_wanted = None;
            (plain, TableAccuracy::NotApplicable)
        };
        let rebaked = self.cpu_drawn != Some(look.key());
        let engine_req = self.engine_request(req);
        let frame = self.cpu.render(&look, &engine_req, &|_, _| {})?;
        self.shadow_seconds = self.cpu.shadow_seconds;
        self.cpu_drawn = Some(look.key());
        let EngineStats::Cpu(st) = frame.stats else { unreachable!("the CPU renderer reports CPU statistics") };
        let rgba8 = frame.image.to_rgba8(&req.display);
        let stats = FrameStats {
            // Which CPU algorithm drew it: the walker, or PT (also when the
            // walker handed the view over: the eye inside the mesh).
            backend: format!("{backend} {}", st.renderer),
            frame_seconds: start.elapsed().as_secs_f64(),
            bake_seconds,
            last_bake_seconds: self.last_bake_seconds,
            sort_seconds: st.sort_seconds + st.view_seconds,
            tets_total: st.tets_total,
            tets_culled: st.tets_culled,
            tets_drawn: st.tets_drawn,
            rebaked,
            recomputed_cull: st.recomputed_cull,
            // View work redone: the walker's projection, PT's view and order.
            resorted: st.recomputed_view || st.recomputed_order,
            size: req.view.size,
            accuracy,
        };
        Ok(Frame { rgba8, image: frame.image, view: req.view.clone(), stats })
    }

    fn render_gpu(&mut self, req: &FrameRequest) -> Result<Frame, ViewerError> {
        let start = Instant::now();
        let (look, bake_seconds) = self.plain_look(req)?;
        let rebaked = self.gpu_drawn != Some(look.key());
        let engine_req = self.engine_request(req);
        let gpu = self.gpu.as_mut().expect("checked by render");
        let frame = gpu.render(&look, &engine_req, &|_, _| {})?;
        self.gpu_drawn = Some(look.key());
        let tone = gpu.tonemap_last(&req.display)?;
        let EngineStats::Gpu(st) = frame.stats else { unreachable!("the GPU renderer reports GPU statistics") };
        self.shadow_seconds = st.shadow_seconds;
        let stats = FrameStats {
            backend: format!("GPU: {}", self.gpu_note),
            frame_seconds: start.elapsed().as_secs_f64(),
            bake_seconds,
            last_bake_seconds: self.last_bake_seconds,
            sort_seconds: st.view_seconds + st.sort_seconds,
            tets_total: st.tets_total,
            tets_culled: st.render.tets_culled,
            tets_drawn: st.render.tets_drawn,
            rebaked,
            recomputed_cull: st.recomputed_cull,
            resorted: st.recomputed_order,
            size: req.view.size,
            accuracy: if req.method == Method::Table3d {
                TableAccuracy::GpuPlain
            } else {
                TableAccuracy::NotApplicable
            },
        };
        Ok(Frame { rgba8: tone.rgba8, image: frame.image, view: req.view.clone(), stats })
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::tf_model::TfModel;
    use tet_render::Camera;

    fn request(engine: &Engine, model: &TfModel, method: Method, prefer_gpu: bool) -> FrameRequest {
        let (lo, hi) = engine.scene().bounds();
        FrameRequest {
            view: ViewSpec::framing(lo, hi, [48, 40]),
            tf: Arc::new(model.to_tf().unwrap()),
            tf_revision: model.revision(),
            method,
            table_n_s: 32,
            prefer_gpu,
            display: Display::default(),
            time: None,
            shading: Shading::default(),
            adaptive: None,
        }
    }

    /// An engine on the GPU path, or `None` with the reason printed where
    /// it has none (the test skips; with TETKIT_REQUIRE_GPU=1 it fails).
    fn gpu_engine(bundle: &Bundle) -> Option<Engine> {
        let engine = Engine::new(bundle, true).unwrap();
        if !engine.has_gpu() {
            if tet_gpu::gpu_required() {
                panic!("TETKIT_REQUIRE_GPU=1 but {}", engine.gpu_note());
            }
            println!("skipped: {}", engine.gpu_note());
            return None;
        }
        Some(engine)
    }

    fn sample_bundle() -> Bundle {
        let path = concat!(env!("CARGO_MANIFEST_DIR"), "/../../formats/samples/cube5.tetb");
        Bundle::read(std::path::Path::new(path)).unwrap()
    }

    /// Camera motion re-sorts only; a TF edit re-bakes and re-culls only.
    #[test]
    fn cpu_stages_recompute_only_what_changed() {
        let bundle = sample_bundle();
        let mut engine = Engine::new(&bundle, false).unwrap();
        let s = engine.scene().scalar_range();
        let mut model = TfModel::ramp(s, 0.5);
        let mut req = request(&engine, &model, Method::Table3d, false);
        let f = engine.render(&req).unwrap();
        assert!(f.stats.rebaked && f.stats.resorted && f.stats.recomputed_cull);
        assert!(f.rgba8.chunks(4).any(|p| p[..3] != [0, 0, 0]), "something visible");
        // The table's certified bake runs on a thread; whichever frame comes
        // after it finishes swaps it in (no new bake, still `rebaked`). Wait
        // for it and draw once, so the camera move below is decided by the
        // camera alone (a race that failed this test once in CI).
        engine.wait_for_certification();
        let f = engine.render(&req).unwrap();
        assert!(!f.stats.resorted && !f.stats.recomputed_cull, "{:?}", f.stats);

        req.view = req.view.orbit(20.0, 5.0, 1.0);
        let f = engine.render(&req).unwrap();
        assert!(!f.stats.rebaked && f.stats.resorted && !f.stats.recomputed_cull, "{:?}", f.stats);

        model.move_opacity(1, s[1], 3.0);
        req.tf = Arc::new(model.to_tf().unwrap());
        req.tf_revision = model.revision();
        let f = engine.render(&req).unwrap();
        assert!(f.stats.rebaked && f.stats.recomputed_cull && !f.stats.resorted);

        req.table_n_s = 16;
        let f = engine.render(&req).unwrap();
        assert!(f.stats.rebaked && !f.stats.recomputed_cull && !f.stats.resorted);
        assert!(f.stats.backend.starts_with("CPU"));
    }

    fn bits(img: &Image) -> Vec<[u32; 4]> {
        img.pixels().iter().map(|p| p.map(f32::to_bits)).collect()
    }

    /// The viewer's CPU frames are tet_engine's: for the same bundle, TF,
    /// method and view, [`tet_engine::CpuFrameRenderer`] with a look baked
    /// by tet_engine (the viewer's bake options; for table3d the plain
    /// table, then the certified one of [`tet_engine::Certifier`]) draws the
    /// same image, bit for bit, on the walker and on PT.
    #[test]
    fn cpu_frames_are_tet_engine_frames() {
        use tet_engine::{Certifier, CpuFrameRenderer, FrameRenderer, Look};
        let bundle = sample_bundle();
        let domain = TableDomain::from_bundle(&bundle).unwrap();
        let mut certifier = Certifier::new(&bundle, domain, CertifyOptions::default()).unwrap();
        for kind in [tet_render::CpuRenderer::Walk, tet_render::CpuRenderer::Pt] {
            let mut engine = Engine::new(&bundle, false).unwrap();
            engine.set_cpu_renderer(kind);
            let model = TfModel::ramp(engine.scene().scalar_range(), 0.5);
            let mut direct = CpuFrameRenderer::new(&bundle).unwrap();
            for method in [Method::PtLinear, Method::Table3d] {
                let req = request(&engine, &model, method, false);
                let tf = TransferFunction::clone(&req.tf);
                let look = Look::bake_with(&domain, method, tf, &bake_options(req.table_n_s), &[]).unwrap();
                let direct_req =
                    tet_engine::FrameRequest { cpu: kind, ..tet_engine::FrameRequest::new(req.view.clone()) };
                let want = direct.render(&look, &direct_req, &|_, _| {}).unwrap().image;
                let got = engine.render(&req).unwrap();
                assert!(bits(&got.image) == bits(&want), "{kind} {method}");
                assert_eq!(got.rgba8, want.to_rgba8(&req.display), "{kind} {method}");
                if method == Method::Table3d {
                    engine.wait_for_certification();
                    let got = engine.render(&req).unwrap();
                    assert!(matches!(got.stats.accuracy, TableAccuracy::Measured { .. }), "{:?}", got.stats);
                    certifier.certify(&look).unwrap();
                    certifier.wait();
                    let certified = certifier.certified(look.key()).unwrap().unwrap();
                    let want = direct.render(certified, &direct_req, &|_, _| {}).unwrap().image;
                    assert!(bits(&got.image) == bits(&want), "{kind} certified");
                }
            }
        }
    }

    /// A TF edit re-bakes the held table3d in place: the frame is the one a
    /// fresh engine renders for the edited TF, bit for bit; a value edit
    /// and a moved node alike.
    #[test]
    fn table3d_tf_edits_rebake_to_a_fresh_bake() {
        let bundle = sample_bundle();
        let mut engine = Engine::new(&bundle, false).unwrap();
        let s = engine.scene().scalar_range();
        let mut model = TfModel::ramp(s, 0.5);
        let mid = 0.5 * (s[0] + s[1]);
        model.add_opacity(mid, 1.0).unwrap();
        let req = request(&engine, &model, Method::Table3d, false);
        engine.render(&req).unwrap();
        let i = model.opacity_nodes().iter().position(|o| o.x == mid).unwrap();
        for (x, a) in [(mid, 2.0), (mid + 0.1 * (s[1] - s[0]), 2.0)] {
            model.move_opacity(i, x, a);
            let req = request(&engine, &model, Method::Table3d, false);
            let f = engine.render(&req).unwrap();
            assert!(f.stats.rebaked);
            let mut fresh = Engine::new(&bundle, false).unwrap();
            let g = fresh.render(&req).unwrap();
            assert_eq!(f.image.pixels(), g.image.pixels(), "edit to ({x}, {a})");
        }
    }

    /// `plain` lit by `light` alone, with its shadows.
    fn shadowed(plain: &FrameRequest, light: tet_render::LightSource) -> FrameRequest {
        let lights = tet_render::LightSet::new(&[light]).unwrap();
        FrameRequest {
            shading: tet_render::Lighting { lights, shadows: true, ..Default::default() }.shading(None),
            ..plain.clone()
        }
    }

    /// Lighting with shadows on the CPU (no GPU here): different from the
    /// unlit frame; the shadow field is computed for the first lit frame
    /// and reused when only the camera moves.
    #[test]
    fn lit_frames_with_shadows_reuse_their_field_across_camera_moves() {
        let bundle = sample_bundle();
        let mut engine = Engine::new(&bundle, false).unwrap();
        let model = TfModel::ramp(engine.scene().scalar_range(), 0.5);
        let plain = request(&engine, &model, Method::Table3d, true);
        let unlit = engine.render(&plain).unwrap();
        let sun = tet_render::LightSource::Directional { direction: [0.5, -0.7, -0.5], intensity: 1.0 };
        let lit = shadowed(&plain, sun);
        assert!(!lit.same_frame(&plain));
        let f = engine.render(&lit).unwrap();
        assert!(f.stats.backend.starts_with("CPU"), "{}", f.stats.backend);
        assert!(engine.shadow_seconds() > 0.0);
        assert!(tet_render::diff(&f.image, &unlit.image).unwrap().max_abs > 1e-3);
        let moved = FrameRequest { view: lit.view.orbit(15.0, 0.0, 1.0), ..lit.clone() };
        engine.render(&moved).unwrap();
        assert_eq!(engine.shadow_seconds(), 0.0, "a camera move keeps the field");
    }

    /// With the GPU preferred, shadowed frames (a directional light's map,
    /// a point light's cube of maps inside the mesh) are drawn on the GPU,
    /// the field kept across a camera move.
    #[test]
    fn shadowed_frames_go_to_the_gpu() {
        let bundle = sample_bundle();
        let Some(mut engine) = gpu_engine(&bundle) else { return };
        let model = TfModel::ramp(engine.scene().scalar_range(), 0.5);
        let plain = request(&engine, &model, Method::Table3d, true);
        let sun = tet_render::LightSource::Directional { direction: [0.5, -0.7, -0.5], intensity: 1.0 };
        let lit = shadowed(&plain, sun);
        let f = engine.render(&lit).unwrap();
        assert!(f.stats.backend.starts_with("GPU"), "{}", f.stats.backend);
        assert!(engine.shadow_seconds() > 0.0);
        let moved = FrameRequest { view: lit.view.orbit(15.0, 0.0, 1.0), ..lit.clone() };
        engine.render(&moved).unwrap();
        assert_eq!(engine.shadow_seconds(), 0.0, "a camera move keeps the field");
        let (lo, hi) = engine.scene().bounds();
        let centre = std::array::from_fn(|k| 0.5 * (lo[k] + hi[k]));
        let req = shadowed(&plain, tet_render::LightSource::Point { position: centre, intensity: 1.0 });
        let f = engine.render(&req).unwrap();
        assert!(f.stats.backend.starts_with("GPU"), "{}", f.stats.backend);
        assert!(engine.shadow_seconds() > 0.0);
    }

    /// A held-out TF (a dozen narrow opacity peaks): the first table3d frame
    /// draws the plain table while its certified bake runs; once that is
    /// done, the same request draws the certified table, which meets 1/255
    /// of the f64 reference ray caster (linear, no tone mapping) where the
    /// plain table does not; a TF edit goes back to the plain table.
    #[test]
    fn table3d_frames_switch_to_the_certified_table() {
        let bundle = sample_bundle();
        let mut engine = Engine::new(&bundle, false).unwrap();
        let path = concat!(env!("CARGO_MANIFEST_DIR"), "/../tet_preint/tests/data/heldout/tf_peaks12.json");
        let tf = TransferFunction::from_json(&std::fs::read_to_string(path).unwrap()).unwrap();
        // In data units, as the window's TF model gives it.
        let tf = tet_preint::tf_for_domain(&tf, engine.domain()).unwrap();
        let (lo, hi) = engine.scene().bounds();
        let mut req = FrameRequest {
            view: ViewSpec::framing(lo, hi, [48, 48]).orbit(30.0, 20.0, 1.0),
            tf: Arc::new(tf.clone()),
            tf_revision: 7,
            method: Method::Table3d,
            table_n_s: 32,
            prefer_gpu: false,
            display: Display::default(),
            time: None,
            shading: Shading::default(),
            adaptive: None,
        };
        let plain = engine.render(&req).unwrap();
        assert_eq!(plain.stats.accuracy, TableAccuracy::Certifying);
        engine.wait_for_certification();
        let cert = engine.render(&req).unwrap();
        assert!(cert.stats.rebaked && !cert.stats.resorted && !cert.stats.recomputed_cull, "{:?}", cert.stats);
        let TableAccuracy::Measured { certified, max_error, target } = cert.stats.accuracy.clone() else {
            panic!("{:?}", cert.stats.accuracy)
        };
        assert!(certified && max_error <= target, "{:?}", cert.stats.accuracy);

        let reference = tet_render::ReferenceRenderer::new(&bundle.mesh, &bundle.adjacency).unwrap();
        let cam = Camera::new(&req.view).unwrap();
        let opts = tet_render::ReferenceOptions::default();
        let (want, _) = reference.render(&cam, &tf, &opts, &|_, _| {}).unwrap();
        assert!(want.pixels().iter().any(|p| p[3] > 0.05), "the view shows something");
        let max = |img: &Image| {
            img.pixels()
                .iter()
                .zip(want.pixels())
                .flat_map(|(p, q)| (0..4).map(move |c| (p[c] - q[c]).abs()))
                .fold(0.0f32, f32::max)
        };
        let (e_plain, e_cert) = (max(&plain.image), max(&cert.image));
        assert!(e_cert <= 1.0 / 255.0, "certified table: linear max {e_cert:e}");
        assert!(e_plain > e_cert, "plain {e_plain:e}, certified {e_cert:e}");

        req.tf_revision = 8;
        let edited = engine.render(&req).unwrap();
        assert_eq!(edited.stats.accuracy, TableAccuracy::Certifying);
        assert_eq!(edited.image.pixels(), plain.image.pixels(), "the plain table again");
    }

    /// The same staging on the GPU path, and methods it lacks fall back to
    /// the CPU with the reason in the backend line.
    #[test]
    fn gpu_stages_and_fallback() {
        let bundle = sample_bundle();
        let Some(mut engine) = gpu_engine(&bundle) else { return };
        let s = engine.scene().scalar_range();
        let mut model = TfModel::ramp(s, 0.5);
        let mut req = request(&engine, &model, Method::Table3d, true);
        let f = engine.render(&req).unwrap();
        assert!(f.stats.backend.starts_with("GPU"), "{}", f.stats.backend);
        assert!(f.stats.rebaked && f.stats.resorted && f.stats.recomputed_cull);
        assert!(f.rgba8.chunks(4).any(|p| p[..3] != [0, 0, 0]), "something visible");
        let gpu_image = f.image;

        req.view = req.view.orbit(20.0, 5.0, 1.0);
        let f = engine.render(&req).unwrap();
        assert!(!f.stats.rebaked && f.stats.resorted && !f.stats.recomputed_cull);

        model.move_opacity(1, s[1], 3.0);
        req.tf = Arc::new(model.to_tf().unwrap());
        req.tf_revision = model.revision();
        let f = engine.render(&req).unwrap();
        assert!(f.stats.rebaked && f.stats.recomputed_cull && !f.stats.resorted);

        req.method = Method::Exact;
        let f = engine.render(&req).unwrap();
        assert!(f.stats.backend.contains("not on the GPU"), "{}", f.stats.backend);

        // The first GPU frame agrees with the CPU renderer's (same TF, view, table).
        let mut cpu = Engine::new(&bundle, false).unwrap();
        let model0 = TfModel::ramp(s, 0.5);
        let cpu_image = cpu.render(&request(&cpu, &model0, Method::Table3d, false)).unwrap().image;
        let d = tet_render::diff(&gpu_image, &cpu_image).unwrap();
        assert!(d.max_abs < 2.0 / 255.0 && d.mean_abs < 0.5 / 255.0, "{d:?}");
    }

    /// Every method tet_gpu renders takes the GPU path in the window and
    /// agrees with the CPU engine's frame (same TF, view and bake options);
    /// the bivariate methods with a box widget (|∇s| uploaded on first use).
    #[test]
    fn every_gpu_method_matches_the_cpu_engine() {
        let bundle = sample_bundle();
        let Some(mut gpu) = gpu_engine(&bundle) else { return };
        let mut cpu = Engine::new(&bundle, false).unwrap();
        // The GPU draws projected tetrahedra; so does its reference.
        cpu.set_cpu_renderer(tet_render::CpuRenderer::Pt);
        let s = gpu.scene().scalar_range();
        let mut model = TfModel::ramp(s, 0.5);
        let mut methods: Vec<Method> = tet_gpu::GPU_METHODS.into_iter().filter(|m| !m.is_bivariate()).collect();
        methods.extend(tet_gpu::GPU_METHODS.into_iter().filter(|m| m.is_bivariate()));
        for m in methods {
            if m.is_bivariate() && model.widgets().is_empty() {
                let mid = 0.5 * (s[0] + s[1]);
                model.add_box_widget([mid, 0.0], [0.5 * (s[1] - s[0]), 1e6], [0.9, 0.5, 0.1], 0.8).unwrap();
            }
            let f = gpu.render(&request(&gpu, &model, m, true)).unwrap();
            assert!(f.stats.backend.starts_with("GPU"), "{m}: {}", f.stats.backend);
            assert!(f.rgba8.chunks(4).any(|p| p[..3] != [0, 0, 0]), "{m}: something visible");
            let c = cpu.render(&request(&cpu, &model, m, false)).unwrap();
            let d = tet_render::diff(&f.image, &c.image).unwrap();
            assert!(d.max_abs < 2.0 / 255.0 && d.mean_abs < 0.5 / 255.0, "{m}: {d:?}");
        }
    }

    /// A time-series bundle: a new time redraws the scalar at that time
    /// (the engine's frame equals a fresh engine on the bundle moved there
    /// with `set_time`), on the CPU and, where an adapter exists, the GPU;
    /// the TF's range is every step's; a time outside the steps is an error.
    #[test]
    fn a_new_time_draws_the_scalar_at_that_time() {
        let mut bundle = sample_bundle();
        let n = bundle.mesh.points.len();
        let steps: Vec<Vec<f64>> =
            (0..3).map(|k| (0..n).map(|i| ((i * 7 + k * 3) % 11) as f64 * 0.1 + k as f64).collect()).collect();
        let st = tet_bundle::TimeSteps::new(vec![0.0, 1.0, 2.0], steps, vec![String::new(); 3]).unwrap();
        let range: [f64; 2] = st.scalar_range().into();
        bundle = bundle.with_steps(st).unwrap();
        for try_gpu in [false, true] {
            let mut engine = Engine::new(&bundle, try_gpu).unwrap();
            if try_gpu && !engine.has_gpu() {
                assert!(!tet_gpu::gpu_required(), "TETKIT_REQUIRE_GPU is set but there is no adapter");
                continue;
            }
            assert_eq!(engine.scalar_range(), range);
            let model = TfModel::new(
                &TransferFunction::from_json(
                    r#"{"color": [[0, 1, 0, 0], [3, 0, 0, 1]],
                "opacity": [[0, 0.5], [1.5, 3], [3, 1]], "unit_distance": 1}"#,
                )
                .unwrap(),
                engine.scalar_range(),
            )
            .unwrap();
            let mut req = request(&engine, &model, Method::PtLinear, try_gpu);
            let first = engine.render(&req).unwrap();
            req.time = Some(1.25);
            let moved = engine.render(&req).unwrap();
            assert_ne!(moved.image.pixels(), first.image.pixels());
            let mut there = bundle.clone();
            there.set_time(1.25).unwrap();
            let mut fresh = Engine::new(&there, try_gpu).unwrap();
            req.time = None;
            let want = fresh.render(&req).unwrap();
            assert_eq!(moved.image.pixels(), want.image.pixels(), "gpu {try_gpu}");
            req.time = Some(2.5);
            let Err(e) = engine.render(&req) else { panic!("time 2.5 is outside the steps") };
            assert!(e.to_string().contains("outside"), "{e}");
        }
    }

    /// Dragging with adaptive sampling: the walker draws the engine's
    /// adaptive frame; projected tetrahedra ignore the request (every pixel).
    #[test]
    fn adaptive_requests_reach_the_walker_only() {
        let bundle = sample_bundle();
        let domain = TableDomain::from_bundle(&bundle).unwrap();
        for kind in [tet_render::CpuRenderer::Walk, tet_render::CpuRenderer::Pt] {
            let mut engine = Engine::new(&bundle, false).unwrap();
            engine.set_cpu_renderer(kind);
            let model = TfModel::ramp(engine.scene().scalar_range(), 0.5);
            let plain = request(&engine, &model, Method::Table3d, false);
            let req = FrameRequest { adaptive: Some(0.05), ..plain.clone() };
            assert!(!req.same_frame(&plain));
            let tf = TransferFunction::clone(&req.tf);
            let look = Look::bake_with(&domain, Method::Table3d, tf, &bake_options(req.table_n_s), &[]).unwrap();
            let adaptive = (kind == tet_render::CpuRenderer::Walk).then_some(0.05);
            let direct_req =
                tet_engine::FrameRequest { cpu: kind, adaptive, ..tet_engine::FrameRequest::new(req.view.clone()) };
            let want = CpuFrameRenderer::new(&bundle).unwrap().render(&look, &direct_req, &|_, _| {}).unwrap().image;
            let got = engine.render(&req).unwrap();
            assert!(bits(&got.image) == bits(&want), "{kind}");
        }
    }
}
