//! The viewer's renderer, without a window: a request (view, TF, method,
//! display) in, an 8-bit image and statistics out, recomputing only what
//! changed since the last request.
//!
//! * CPU: tet_render's staged [`Renderer`] — a new view re-sorts only; a
//!   new TF revision, method or table resolution re-bakes the shader and
//!   re-culls. table3d keeps its table and the TF it was baked from, so a
//!   TF edit re-bakes only the pairs it reaches ([`Table3d::rebake`]).
//!   That plain table is drawn at once; the certified bake of the same TF
//!   ([`tet_preint::certify::bake`]: the bake measures its own error and
//!   refines until it holds 1e-3, for any TF) runs on a thread beside the
//!   frames and replaces it when done ([`Engine::poll_certification`]; the
//!   frame's [`TableAccuracy`] says which one is on screen). One bake runs
//!   at a time: while a TF is dragged, only the newest revision is queued.
//! * GPU (tet_gpu, every method of [`tet_gpu::GPU_METHODS`] — all but
//!   `exact` — when an adapter exists): the GPU radix sort
//!   of centroid depths, recomputed only when the camera moves (tet_gpu
//!   caches it), filtered by the CPU cull mask of the current TF; shader
//!   rebuilt on a TF change (baked on the CPU with the CPU path's options,
//!   table3d re-baked in place as there, then uploaded); the bivariate
//!   methods' per-vertex |∇s| uploaded once, when one is first chosen.

use crate::ViewerError;
use std::sync::mpsc::{Receiver, TryRecvError};
use std::sync::Arc;
use std::time::Instant;
use tet_bundle::Bundle;
use tet_gpu::{GpuContext, GpuOrder, GpuRenderer, GpuScene, GpuShader, RasterPath};
use tet_preint::{
    BakeOptions, Baked, CertifiedTable3d, CertifyOptions, Method, SegmentShader, Table3d, Table3dParams, TableDomain,
    TableError, TransferFunction,
};
use tet_render::cull::{cull, CullMask};
use tet_render::{Camera, Display, Image, Renderer, Scene, TfCuller, ViewSpec};

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
    /// Use tet_gpu when it can render `method`.
    pub prefer_gpu: bool,
    pub display: Display,
    /// A time-series bundle's time (`None`: the scalar as loaded, the
    /// first step).
    pub time: Option<f64>,
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

/// The methods the GPU path renders (tet_gpu's [`tet_gpu::GPU_METHODS`]).
pub fn gpu_supports(method: Method) -> bool {
    tet_gpu::GPU_METHODS.contains(&method)
}

struct Gpu {
    ctx: GpuContext,
    scene: GpuScene,
    /// Whether `scene` carries the per-vertex |∇s| (bivariate methods).
    gradients: bool,
    renderer: GpuRenderer,
    /// The shader of (tf revision, method, table n_s).
    shader: Option<((u64, Method, usize), GpuShader)>,
    /// Centroid order of the view it was sorted for.
    order: Option<(ViewSpec, Vec<u32>)>,
}

/// The table3d of the last frames and the TF (data units) it was baked
/// from: the next TF edit re-bakes it in place.
struct HeldTable {
    tf: TransferFunction,
    table: Arc<Table3d>,
}

/// (TF revision, table n_s): what a certified bake is for.
type CertKey = (u64, usize);

/// The certified bakes: one on a thread at a time, the newest request
/// queued behind it, the last result kept.
#[derive(Default)]
struct Certifier {
    running: Option<(CertKey, Receiver<Result<CertifiedTable3d, TableError>>)>,
    /// Wanted after the running one (the newest frame's).
    queued: Option<(CertKey, TransferFunction, Table3dParams)>,
    done: Option<(CertKey, Result<Arc<CertifiedTable3d>, String>)>,
}

/// The staged renderer behind the window.
pub struct Engine {
    cpu: Renderer,
    domain: TableDomain,
    gpu: Option<Gpu>,
    /// Why there is no GPU path (shown in the status line).
    gpu_note: String,
    /// (TF revision, method, table n_s, whether the certified table3d).
    cpu_key: Option<(u64, Method, usize, bool)>,
    /// CPU cull mask of a TF revision (the GPU path's filter).
    mask: Option<(u64, CullMask)>,
    last_bake_seconds: f64,
    table: Option<HeldTable>,
    certifier: Certifier,
    /// The certified table's key of the last CPU table3d frame.
    cert_wanted: Option<CertKey>,
    /// Segments through the bundle's cells, measured by every certified
    /// bake besides its own sets ([`tet_preint::certify::cell_triples`]).
    cells: Arc<Vec<[f32; 3]>>,
    /// A time series' steps, and the time the scene's scalar is at.
    steps: Option<tet_bundle::TimeSteps>,
    time: Option<f64>,
    /// The range a normalized TF spans (every step's, for a series).
    scalar_range: [f64; 2],
}

impl Engine {
    /// Loads the scene; with `try_gpu`, opens a headless tet_gpu context
    /// (its failure is not an error: the CPU renders, and
    /// [`Engine::gpu_note`] says why).
    pub fn new(bundle: &Bundle, try_gpu: bool) -> Result<Engine, ViewerError> {
        let scene = Scene::from_bundle(bundle)?;
        let domain = TableDomain::from_bundle(bundle)?;
        let (gpu, gpu_note) = if try_gpu {
            match open_gpu(bundle) {
                Ok(g) => {
                    let note = g.ctx.describe();
                    (Some(g), note)
                }
                Err(e) => (None, format!("no GPU: {e}")),
            }
        } else {
            (None, "GPU off (--cpu)".to_string())
        };
        let opts = CertifyOptions::default();
        let cells = Arc::new(tet_preint::certify::cell_triples(bundle, &domain, opts.samples, opts.seed));
        Ok(Engine {
            cpu: Renderer::new(scene),
            domain,
            gpu,
            gpu_note,
            cpu_key: None,
            mask: None,
            last_bake_seconds: 0.0,
            table: None,
            certifier: Certifier::default(),
            cert_wanted: None,
            cells,
            steps: bundle.steps.clone(),
            time: None,
            scalar_range: bundle.scalar_range().into(),
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
        self.cpu.set_renderer(kind);
    }
    /// Whether the GPU is a software adapter (lavapipe): on such a machine
    /// tet_render's CPU renderer is much faster, so the window starts on it.
    pub fn gpu_is_software(&self) -> bool {
        self.gpu.as_ref().is_some_and(|g| g.ctx.is_software())
    }
    pub fn scene(&self) -> &Scene {
        self.cpu.scene()
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
    /// the CPU renderer keeps its per-scene walker links, the GPU its mesh;
    /// what the scalar feeds (culls, gradients) is redone.
    fn apply_time(&mut self, time: Option<f64>) -> Result<(), ViewerError> {
        let (Some(t), Some(steps)) = (time, &self.steps) else { return Ok(()) };
        if self.time == Some(t) {
            return Ok(());
        }
        let scalar = steps.scalar_at(t).map_err(|e| ViewerError::Input(e.to_string()))?;
        if let Some(g) = &mut self.gpu {
            g.scene.set_scalar(&g.ctx, &scalar)?;
            g.gradients = false;
        }
        self.cpu.set_scalar(scalar)?;
        self.mask = None;
        self.time = Some(t);
        Ok(())
    }

    /// Renders `req`, recomputing only what changed since the last call.
    pub fn render(&mut self, req: &FrameRequest) -> Result<Frame, ViewerError> {
        self.apply_time(req.time)?;
        let use_gpu = req.prefer_gpu && self.gpu.is_some() && gpu_supports(req.method);
        if use_gpu {
            return self.render_gpu(req);
        }
        let backend = if self.gpu.is_none() {
            format!("CPU ({})", self.gpu_note)
        } else if !req.prefer_gpu {
            format!("CPU (GPU {} not selected)", self.gpu_note)
        } else {
            format!("CPU (method {} is not on the GPU)", req.method)
        };
        self.render_cpu(req, backend)
    }

    fn bake_options(n_s: usize) -> BakeOptions {
        let mut o = BakeOptions::default();
        o.table3d = Table3dParams { n_s, n_l: 2 * n_s, ..o.table3d };
        o
    }

    /// The table3d for `tf` at `n_s`: the held table re-baked for the TF
    /// edit since it was baked (only the pairs the edit reaches, the same
    /// bits as a fresh bake), or a fresh bake.
    fn table3d(&mut self, tf: &TransferFunction, n_s: usize) -> Result<Arc<Table3d>, ViewerError> {
        let err = |e: tet_preint::TableError| ViewerError::Method(format!("table3d: {e}"));
        let tf = tet_preint::tf_for_domain(tf, &self.domain).map_err(err)?;
        let params = Self::bake_options(n_s).table3d;
        if let Some(mut held) = self.table.take().filter(|h| *h.table.params() == params) {
            // In place when nothing else holds the table (the CPU path drops
            // the renderer's reference first), else on a copy.
            Arc::make_mut(&mut held.table).rebake(&held.tf, &tf).map_err(err)?;
            held.tf = tf;
            let table = held.table.clone();
            self.table = Some(held);
            return Ok(table);
        }
        let table = Arc::new(Table3d::build(&tf, &self.domain, &params).map_err(err)?);
        self.table = Some(HeldTable { tf, table: table.clone() });
        Ok(table)
    }

    /// The 2D methods need per-vertex gradients: computed once, on first use.
    fn ensure_cpu_gradients(&mut self) -> Result<(), ViewerError> {
        if self.cpu.scene().gradients().is_none() {
            let scene = self.cpu.scene().clone().ensure_gradients()?;
            let kind = self.cpu.renderer();
            self.cpu = Renderer::new(scene);
            self.cpu.set_renderer(kind);
            self.cpu_key = None;
        }
        Ok(())
    }

    /// Takes a finished certified bake and starts the queued one; true
    /// when the table for the last CPU table3d frame arrived, so that
    /// re-rendering that frame's request shows it (the window's worker
    /// calls this while it waits for requests).
    pub fn poll_certification(&mut self) -> bool {
        let c = &mut self.certifier;
        let Some((key, rx)) = &c.running else { return false };
        let res = match rx.try_recv() {
            Ok(r) => r.map(Arc::new).map_err(|e| e.to_string()),
            Err(TryRecvError::Empty) => return false,
            Err(TryRecvError::Disconnected) => Err("the certified bake stopped".to_string()),
        };
        let key = *key;
        c.running = None;
        c.done = Some((key, res));
        if let Some((k, tf, params)) = c.queued.take() {
            if k != key {
                self.start_certification(k, tf, params);
            }
        }
        self.cert_wanted == Some(key)
    }

    /// Runs the certified bake of `tf` (data units) at `params` on a
    /// thread, or queues it behind the one running.
    fn start_certification(&mut self, key: CertKey, tf: TransferFunction, params: Table3dParams) {
        let c = &mut self.certifier;
        if c.running.as_ref().is_some_and(|r| r.0 == key) || c.done.as_ref().is_some_and(|d| d.0 == key) {
            return;
        }
        if c.running.is_some() {
            c.queued = Some((key, tf, params));
            return;
        }
        let (tx, rx) = std::sync::mpsc::channel();
        let (domain, cells) = (self.domain, self.cells.clone());
        std::thread::spawn(move || {
            let res = tet_preint::certify::bake(&tf, &domain, &params, &CertifyOptions::default(), &cells);
            // The engine may be gone (window closed): nothing to tell.
            let _ = tx.send(res);
        });
        c.running = Some((key, rx));
    }

    /// Blocks until no certified bake runs or waits (tests; scripted runs
    /// poll instead).
    pub fn wait_for_certification(&mut self) {
        while self.certifier.running.is_some() {
            if !self.poll_certification() {
                std::thread::sleep(std::time::Duration::from_millis(5));
            }
        }
    }

    fn render_cpu(&mut self, req: &FrameRequest, backend: String) -> Result<Frame, ViewerError> {
        let start = Instant::now();
        self.poll_certification();
        let table3d = req.method == Method::Table3d && req.tf.widgets().is_empty();
        let cert_key = (req.tf_revision, req.table_n_s);
        // The certified table of this TF and resolution, when it is done,
        // and what the frame says of its table.
        let (certified, accuracy) = match &self.certifier.done {
            _ if !table3d => (None, TableAccuracy::NotApplicable),
            Some((k, Ok(t))) if *k == cert_key => {
                let accuracy = match t.certificate() {
                    Some(c) => {
                        TableAccuracy::Measured { certified: c.certified, max_error: c.max_error, target: c.target }
                    }
                    None => TableAccuracy::Failed("the bake measured nothing".into()),
                };
                (Some(t.clone()), accuracy)
            }
            Some((k, Err(e))) if *k == cert_key => (None, TableAccuracy::Failed(e.clone())),
            _ => (None, TableAccuracy::Certifying),
        };
        // The key says which table is drawn: plain (false) or certified.
        let key = (req.tf_revision, req.method, req.table_n_s, certified.is_some());
        let mut bake_seconds = 0.0;
        if req.method.is_bivariate() {
            self.ensure_cpu_gradients()?;
        }
        let rebaked = self.cpu_key != Some(key);
        if rebaked {
            let prev_key = self.cpu_key;
            let t = Instant::now();
            // Swapping in the certified table bakes nothing: the bake
            // figures stay those of the last bake.
            let swap = certified.is_some();
            let shader: Arc<dyn SegmentShader> = if let Some(c) = certified {
                c
            } else if table3d {
                // Let go of the renderer's reference, so the held table can
                // be re-baked in place (a failed bake forgets the key, so
                // the renderer gets a shader before it draws again).
                self.cpu.clear_shader();
                self.cpu_key = None;
                let table = self.table3d(&req.tf, req.table_n_s)?;
                let held = self.table.as_ref().expect("set by table3d");
                self.start_certification(cert_key, held.tf.clone(), *table.params());
                table
            } else {
                tet_preint::make_shader(req.method, &req.tf, &self.domain, &Self::bake_options(req.table_n_s))
                    .map_err(|e| ViewerError::Method(format!("{}: {e}", req.method)))?
                    .into()
            };
            if !swap {
                bake_seconds = t.elapsed().as_secs_f64();
                self.last_bake_seconds = bake_seconds;
            }
            self.cpu.set_shader(shader);
            // A new TF re-culls; a new method, resolution or the certified
            // table alone does not.
            if prev_key.map(|k| k.0) != Some(req.tf_revision) {
                self.cpu.set_culler(Some(Arc::new(TfCuller::new(&req.tf))));
            }
            self.cpu_key = Some(key);
        }
        self.cert_wanted = table3d.then_some(cert_key);
        self.cpu.set_view(&req.view)?;
        let (image, st) = self.cpu.render(&|_, _| {})?;
        let rgba8 = image.to_rgba8(&req.display);
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
        Ok(Frame { rgba8, image, view: req.view.clone(), stats })
    }

    fn render_gpu(&mut self, req: &FrameRequest) -> Result<Frame, ViewerError> {
        let start = Instant::now();
        if req.method.is_bivariate() && !self.gpu.as_ref().expect("checked by render").gradients {
            // |∇s| per vertex, computed on the CPU scene once (as the CPU
            // path does) and uploaded.
            self.ensure_cpu_gradients()?;
            let g = self.cpu.scene().gradient_magnitudes().expect("gradients ensured above").to_vec();
            let Gpu { ctx, scene, renderer, shader, order, .. } = self.gpu.take().expect("checked by render");
            let scene = scene.with_gradient_magnitudes(&ctx, &g)?;
            self.gpu = Some(Gpu { ctx, scene, gradients: true, renderer, shader, order });
        }
        let recomputed_cull = self.mask.as_ref().map(|m| m.0) != Some(req.tf_revision);
        if recomputed_cull {
            self.mask = Some((req.tf_revision, cull(self.cpu.scene(), &TfCuller::new(&req.tf))));
        }
        let key = (req.tf_revision, req.method, req.table_n_s);
        let mut bake_seconds = 0.0;
        let rebaked = self.gpu.as_ref().expect("checked by render").shader.as_ref().map(|s| s.0) != Some(key);
        if rebaked {
            let t = Instant::now();
            let tf =
                tet_preint::tf_for_domain(&req.tf, &self.domain).map_err(|e| ViewerError::Method(e.to_string()))?;
            let shader = match req.method {
                Method::Table3d if req.tf.widgets().is_empty() => {
                    // Re-baked in place like the CPU path's, then uploaded.
                    let table = self.table3d(&req.tf, req.table_n_s)?;
                    GpuShader::table3d(&self.gpu.as_ref().expect("checked by render").ctx, &table)?
                }
                Method::PtLinear => GpuShader::pt_linear(&self.gpu.as_ref().expect("checked by render").ctx, &tf)?,
                // The CPU path's bake (same options), uploaded.
                m => {
                    let baked = Baked::build(m, &req.tf, &self.domain, &Self::bake_options(req.table_n_s))
                        .map_err(|e| ViewerError::Method(format!("{m}: {e}")))?;
                    GpuShader::from_baked(&self.gpu.as_ref().expect("checked by render").ctx, &baked)?
                }
            };
            bake_seconds = t.elapsed().as_secs_f64();
            self.last_bake_seconds = bake_seconds;
            self.gpu.as_mut().expect("checked by render").shader = Some((key, shader));
        }
        let scene = self.cpu.scene();
        let mask = &self.mask.as_ref().expect("set above").1;
        let gpu = self.gpu.as_mut().expect("checked by render");
        let camera = Camera::new(&req.view)?;
        let t = Instant::now();
        let resorted = gpu.order.as_ref().is_none_or(|o| o.0 != req.view);
        if resorted {
            let order = gpu.renderer.gpu_centroid_order(&gpu.ctx, &gpu.scene, &camera)?;
            gpu.order = Some((req.view.clone(), order));
        }
        let sort_seconds = t.elapsed().as_secs_f64();
        let order = &gpu.order.as_ref().expect("set above").1;
        let tets: Vec<u32> = if mask.culled > 0 {
            order.iter().copied().filter(|&t| mask.visible[t as usize]).collect()
        } else {
            order.clone()
        };
        let shader = &gpu.shader.as_ref().expect("set above").1;
        let frame = gpu.renderer.render_with(
            &gpu.ctx,
            &gpu.scene,
            &camera,
            GpuOrder::Given(&tets),
            shader,
            RasterPath::Compute,
        )?;
        let tone = gpu.renderer.tonemap(&gpu.ctx, &frame, &req.display)?;
        let stats = FrameStats {
            backend: format!("GPU: {}", self.gpu_note),
            frame_seconds: start.elapsed().as_secs_f64(),
            bake_seconds,
            last_bake_seconds: self.last_bake_seconds,
            sort_seconds,
            tets_total: scene.num_tets(),
            tets_culled: mask.culled,
            tets_drawn: tets.len(),
            rebaked,
            recomputed_cull,
            resorted,
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

fn open_gpu(bundle: &Bundle) -> Result<Gpu, tet_gpu::GpuError> {
    let ctx = GpuContext::new_headless()?;
    let m = &bundle.mesh;
    let scene = GpuScene::new(&ctx, &m.points, &m.tets, &m.scalar)?;
    let renderer = GpuRenderer::new(&ctx)?;
    Ok(Gpu { ctx, scene, gradients: false, renderer, shader: None, order: None })
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::tf_model::TfModel;

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
        }
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
        let mut engine = Engine::new(&bundle, true).unwrap();
        if !engine.has_gpu() {
            if tet_gpu::gpu_required() {
                panic!("TETKIT_REQUIRE_GPU=1 but {}", engine.gpu_note());
            }
            println!("skipped: {}", engine.gpu_note());
            return;
        }
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
        let mut gpu = Engine::new(&bundle, true).unwrap();
        if !gpu.has_gpu() {
            if tet_gpu::gpu_required() {
                panic!("TETKIT_REQUIRE_GPU=1 but {}", gpu.gpu_note());
            }
            println!("skipped: {}", gpu.gpu_note());
            return;
        }
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
}
