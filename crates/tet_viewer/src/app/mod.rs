//! The window: eframe/egui on glow. The UI thread only edits state and
//! shows frames; a worker thread owns the [`Engine`] and renders the newest
//! request (stale ones are dropped), so dragging stays responsive even when
//! a full-resolution CPU frame takes long.

use crate::engine::{gpu_supports, Engine, Frame, FrameRequest, FrameStats, TableAccuracy};
use crate::file_dialog::{self, FileDialog, Mode, Outcome};
use crate::nav;
use crate::tf_model::{populated_region, TfModel, WidgetKind};
use crate::{ViewerError, ViewerOptions};
use eframe::egui;
use egui::{Color32, PointerButton, Pos2, Rect, Sense, Stroke, TextureHandle, Vec2};
use std::path::{Path, PathBuf};
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::mpsc::{channel, Receiver, RecvTimeoutError, Sender};
use std::sync::{Arc, Mutex};
use std::time::{Duration, Instant};
use tet_analysis::{Axis, Histograms, Scale};
use tet_bundle::Bundle;
use tet_preint::widget::{MAX_FREQUENCY, UNBOUNDED};
use tet_preint::{LoadOptions, Method, Shape};
use tet_render::{Display, LightSet, LightSource, Lighting, Shading, ToneMap, ViewSpec};

mod editor;

pub(crate) use editor::*;

pub(crate) type Reply = (u64, Result<Frame, String>);

/// The outcome of a scripted (`frames`) run, filled in by the window.
pub(crate) type ScriptResult = Arc<Mutex<Option<Result<(), String>>>>;

pub fn run(opts: ViewerOptions) -> Result<(), ViewerError> {
    let bundle = Bundle::read(&opts.bundle)?;
    let engine = Engine::new(&bundle, !opts.cpu_only)?;
    let scalar_range = engine.scalar_range();
    let time_steps: Option<Vec<f64>> = engine.time_steps().map(|st| st.times().to_vec());
    if let (Some(t), Some(times)) = (opts.time, &time_steps) {
        if !(t >= times[0] && t <= times[times.len() - 1]) {
            return Err(ViewerError::Input(format!(
                "time {t} is outside the bundle's steps, {} to {}",
                times[0],
                times[times.len() - 1]
            )));
        }
    } else if let (Some(t), None) = (opts.time, &time_steps) {
        return Err(ViewerError::Input(format!("time {t}: the bundle has no time steps")));
    }
    let (lo, hi) = engine.scene().bounds();
    // The TF `tetview render` would use: tet_preint's one loader for `tf`
    // (tetkit JSON or a ParaView preset, unit distance 1 as in the CLIs),
    // else the automatic TF, both through `choose_tf`. A constant scalar
    // has no automatic TF: the same error as `render` (exit 4), by the one
    // constant-scalar policy (tet_preint's auto_tf module docs).
    let given = opts.tf.as_deref().map(tet_preint::load_tf).transpose()?;
    let (tf, _) = tet_preint::choose_tf(given, Some(&bundle), opts.colormap, 1.0)?;
    let model = TfModel::new(&tf, scalar_range)?;
    let constant_warning = tet_preint::constant_scalar_warning(&bundle);
    let home = match &opts.view {
        Some(p) => {
            let text = std::fs::read_to_string(p).map_err(|e| ViewerError::Io { source: e, path: p.clone() })?;
            ViewSpec::from_json(&text)?
        }
        None => {
            let z_up = tet_render::camera::bundle_is_z_up(&bundle.meta);
            ViewSpec::default_for(lo, hi, [512, 512], z_up, opts.view_up)?
        }
    };
    if opts.frames.is_some() != opts.screenshot.is_some() {
        return Err(ViewerError::Input("--frames and --screenshot go together".into()));
    }
    let histograms = bundle.analysis.as_ref().and_then(|a| a.histograms.clone());
    let script_result: ScriptResult = Arc::new(Mutex::new(None));
    let native = eframe::NativeOptions {
        viewport: egui::ViewportBuilder::default()
            .with_inner_size(opts.window_size)
            .with_title(format!("tetview — {}", opts.bundle.display())),
        renderer: eframe::Renderer::Glow,
        ..Default::default()
    };
    let result = script_result.clone();
    let opts2 = opts.clone();
    // The worker is joined before returning: letting the process exit while
    // it still owns a Vulkan device (lavapipe) crashed in Mesa's teardown.
    let quit = Arc::new(AtomicBool::new(false));
    let worker_handle: Arc<Mutex<Option<std::thread::JoinHandle<()>>>> = Arc::new(Mutex::new(None));
    let (quit2, handle2) = (quit.clone(), worker_handle.clone());
    let window = eframe::run_native(
        "tetview",
        native,
        Box::new(move |cc| {
            let (req_tx, req_rx) = channel::<(u64, FrameRequest)>();
            let (rep_tx, rep_rx) = channel::<Reply>();
            let ctx = cc.egui_ctx.clone();
            let has_gpu = engine.has_gpu();
            let start_on_gpu = has_gpu && (opts2.prefer_gpu || !engine.gpu_is_software());
            let gpu_note = if has_gpu && !start_on_gpu {
                format!("software GPU adapter {} off: tick GPU to use it", engine.gpu_note())
            } else {
                engine.gpu_note().to_string()
            };
            let handle = std::thread::Builder::new()
                .name("tetview-render".into())
                .spawn(move || worker(engine, req_rx, rep_tx, ctx, quit2))
                .map_err(|e| Box::new(e) as Box<dyn std::error::Error + Send + Sync>)?;
            *handle2.lock().unwrap_or_else(|e| e.into_inner()) = Some(handle);
            let mut app = ViewerApp::new(
                opts2,
                model,
                home,
                scalar_range,
                (has_gpu, start_on_gpu),
                gpu_note,
                req_tx,
                rep_rx,
                result,
            );
            app.histograms = histograms;
            app.time = time_steps.as_ref().map(|times| app.time.unwrap_or(times[0]));
            app.time_steps = time_steps;
            if let Some(w) = constant_warning {
                app.status = format!("warning: {w}");
            }
            Ok(Box::new(app))
        }),
    )
    .map_err(|e| ViewerError::Window(e.to_string()));
    quit.store(true, Ordering::Relaxed);
    if let Some(h) = worker_handle.lock().unwrap_or_else(|e| e.into_inner()).take() {
        let _ = h.join();
    }
    window?;
    if opts.frames.is_some() {
        let outcome = script_result.lock().unwrap_or_else(|e| e.into_inner()).take();
        match outcome {
            Some(Ok(())) => {}
            Some(Err(e)) => return Err(ViewerError::Scripted(e)),
            None => return Err(ViewerError::Scripted("the window closed before the screenshot".into())),
        }
    }
    Ok(())
}

/// Renders the newest request, replies, and wakes the UI.
pub(crate) fn worker(
    mut engine: Engine,
    rx: Receiver<(u64, FrameRequest)>,
    tx: Sender<Reply>,
    ctx: egui::Context,
    quit: Arc<AtomicBool>,
) {
    let mut last: Option<(u64, FrameRequest)> = None;
    loop {
        if quit.load(Ordering::Relaxed) {
            return;
        }
        let mut msg = match rx.recv_timeout(Duration::from_millis(50)) {
            Ok(m) => m,
            // The certified table of the frame on screen is done: the same
            // request again (same sequence number), now drawn with it.
            Err(RecvTimeoutError::Timeout) => match last.take() {
                Some(m) if engine.poll_certification() => m,
                other => {
                    last = other;
                    continue;
                }
            },
            Err(RecvTimeoutError::Disconnected) => return,
        };
        while let Ok(newer) = rx.try_recv() {
            msg = newer;
        }
        let res = engine.render(&msg.1).map_err(|e| e.to_string());
        last = Some(msg.clone());
        if tx.send((msg.0, res)).is_err() {
            return;
        }
        ctx.request_repaint();
    }
}

/// How often a scripted run looks at its progress.
pub(crate) const SCRIPT_POLL: Duration = Duration::from_millis(20);

/// Render scale choices (fraction of the window's pixels along each axis).
pub(crate) const SCALES: [(f32, &str); 4] = [(1.0, "100%"), (0.75, "75%"), (0.5, "50%"), (0.25, "25%")];

/// The walker's adaptive-sampling tolerance while dragging: an order of
/// magnitude closer to the full frame than half resolution, for less of a
/// speed-up (both measured in `crates/tetview/results/walker.md`).
pub(crate) const DRAG_ADAPTIVE_TOL: f32 = 0.008;

pub(crate) const TABLE_SIZES: [usize; 5] = [16, 32, 64, 128, 256];

#[derive(Debug, Clone, Copy, PartialEq)]
pub(crate) enum Drag {
    Opacity(usize),
    Color(usize),
}

/// Which path field a file dialog fills (and, for loads, what it loads).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(crate) enum Browse {
    LoadTf,
    SaveTf,
    Preset,
    View,
    Image,
    Shot,
}

impl Browse {
    pub(crate) fn title(self) -> &'static str {
        match self {
            Browse::LoadTf => "Load transfer function",
            Browse::SaveTf => "Save transfer function as",
            Browse::Preset => "Import ParaView preset",
            Browse::View => "Save view JSON as",
            Browse::Image => "Save image PNG as",
            Browse::Shot => "Save window screenshot as",
        }
    }
    pub(crate) fn mode(self) -> Mode {
        match self {
            Browse::LoadTf | Browse::Preset => Mode::Open,
            _ => Mode::Save,
        }
    }
    pub(crate) fn extensions(self) -> &'static [&'static str] {
        match self {
            Browse::Image | Browse::Shot => &["png"],
            _ => &["json"],
        }
    }
}

/// The TF editor's UI state (the TF itself is the [`TfModel`]).
pub(crate) struct EditorState {
    pub(crate) drag: Option<Drag>,
    pub(crate) selected_color: Option<usize>,
    /// Opacity at the top of the curve area.
    pub(crate) a_max: f64,
}

pub(crate) struct Script {
    pub(crate) frames: usize,
    pub(crate) done: usize,
    pub(crate) spin_deg: f64,
    /// Time advanced between frames (clamped to the last step).
    pub(crate) time_step: f64,
    pub(crate) path: PathBuf,
    pub(crate) requested: bool,
    pub(crate) started: Instant,
    pub(crate) result: ScriptResult,
}

pub(crate) struct ViewerApp {
    pub(crate) model: TfModel,
    pub(crate) scalar_range: [f64; 2],
    /// A time series' step times and the time shown (the slider's).
    pub(crate) time_steps: Option<Vec<f64>>,
    pub(crate) time: Option<f64>,
    pub(crate) editor: EditorState,
    pub(crate) widgets: WidgetState,
    /// The bundle's joint (scalar, |∇s|) histogram, under the 2D widget editor.
    pub(crate) histograms: Option<Histograms>,
    pub(crate) view: ViewSpec,
    pub(crate) home: ViewSpec,
    pub(crate) method: Method,
    pub(crate) table_n_s: usize,
    pub(crate) prefer_gpu: bool,
    pub(crate) has_gpu: bool,
    pub(crate) gpu_note: String,
    pub(crate) scale: f32,
    pub(crate) drag_scale: f32,
    /// While dragging, the CPU walker samples adaptively
    /// ([`DRAG_ADAPTIVE_TOL`]) at the drag resolution.
    pub(crate) drag_adaptive: bool,
    pub(crate) exposure: f32,
    pub(crate) tonemap: bool,
    /// Lighting: a key light from (azimuth, elevation) degrees about the
    /// home view (from its eye side, above its horizon), a dim headlight,
    /// and the key light's volumetric shadow.
    pub(crate) light: bool,
    pub(crate) shadows: bool,
    pub(crate) light_azimuth: f32,
    pub(crate) light_elevation: f32,
    pub(crate) tx: Sender<(u64, FrameRequest)>,
    pub(crate) rx: Receiver<Reply>,
    pub(crate) seq: u64,
    pub(crate) last_sent: Option<FrameRequest>,
    pub(crate) latest: Option<(u64, FrameStats)>,
    pub(crate) full_frame: Option<(Vec<u8>, [u32; 2])>,
    /// Render size when nobody drags.
    pub(crate) idle_size: [u32; 2],
    pub(crate) texture: Option<TextureHandle>,
    pub(crate) last_scroll: Option<Instant>,
    pub(crate) last_ui: Option<Instant>,
    pub(crate) ui_ms: f64,
    pub(crate) status: String,
    pub(crate) tf_path: String,
    pub(crate) preset_path: String,
    pub(crate) preset_name: String,
    pub(crate) view_path: String,
    pub(crate) image_path: String,
    pub(crate) shot_path: String,
    pub(crate) shot_slot: Arc<Mutex<Option<Result<PathBuf, String>>>>,
    /// The open file dialog and the field it fills.
    pub(crate) dialog: Option<(FileDialog, Browse)>,
    pub(crate) script: Option<Script>,
}

/// The direction a key light at (azimuth, elevation) degrees travels: on
/// the eye side of `home`, turned about its view-up by the azimuth (towards
/// the right for positive angles) and raised above its horizon by the
/// elevation, shining towards the focal point.
pub(crate) fn key_light_direction(home: &ViewSpec, azimuth_deg: f64, elevation_deg: f64) -> [f64; 3] {
    use glam::DVec3;
    let forward = (DVec3::from(home.focal_point) - DVec3::from(home.position)).normalize_or(DVec3::NEG_Z);
    let right = forward.cross(DVec3::from(home.view_up)).normalize_or(DVec3::X);
    let up = right.cross(forward);
    let (az, el) = (azimuth_deg.to_radians(), elevation_deg.to_radians());
    let from = (-forward * az.cos() + right * az.sin()) * el.cos() + up * el.sin();
    (-from).into()
}

impl ViewerApp {
    #[allow(clippy::too_many_arguments)]
    pub(crate) fn new(
        opts: ViewerOptions,
        model: TfModel,
        home: ViewSpec,
        scalar_range: [f64; 2],
        (has_gpu, start_on_gpu): (bool, bool),
        gpu_note: String,
        tx: Sender<(u64, FrameRequest)>,
        rx: Receiver<Reply>,
        result: ScriptResult,
    ) -> ViewerApp {
        let a_max = model.opacity_nodes().iter().map(|o| o.a).fold(1.0, f64::max);
        let script = match (opts.frames, &opts.screenshot) {
            (Some(frames), Some(path)) => Some(Script {
                frames: frames.max(1),
                done: 0,
                spin_deg: opts.spin_deg,
                time_step: opts.time_step,
                path: path.clone(),
                requested: false,
                started: Instant::now(),
                result,
            }),
            _ => None,
        };
        ViewerApp {
            model,
            scalar_range,
            time_steps: None,
            time: opts.time,
            editor: EditorState { drag: None, selected_color: None, a_max },
            widgets: WidgetState::default(),
            histograms: None,
            view: home.clone(),
            home,
            method: opts.method,
            table_n_s: 64,
            prefer_gpu: start_on_gpu,
            has_gpu,
            gpu_note,
            scale: 1.0,
            drag_scale: 0.5,
            drag_adaptive: false,
            exposure: 1.0,
            tonemap: true,
            light: false,
            shadows: false,
            light_azimuth: -40.0,
            light_elevation: 45.0,
            tx,
            rx,
            seq: 0,
            last_sent: None,
            latest: None,
            full_frame: None,
            idle_size: [0, 0],
            texture: None,
            last_scroll: None,
            last_ui: None,
            ui_ms: 0.0,
            status: String::new(),
            tf_path: opts.tf.as_ref().map(|p| p.display().to_string()).unwrap_or_else(|| "tf.json".into()),
            preset_path: String::new(),
            preset_name: String::new(),
            view_path: "view.json".into(),
            image_path: "tetview.png".into(),
            shot_path: "tetview_window.png".into(),
            shot_slot: Arc::new(Mutex::new(None)),
            dialog: None,
            script,
        }
    }

    pub(crate) fn display(&self) -> Display {
        Display {
            background: [0.0; 3],
            tonemap: if self.tonemap {
                ToneMap::Reinhard { key: 0.18, exposure: self.exposure }
            } else {
                ToneMap::None
            },
        }
    }

    /// Takes replies; shows the newest frame.
    pub(crate) fn receive(&mut self, ctx: &egui::Context) {
        while let Ok((seq, res)) = self.rx.try_recv() {
            match res {
                Ok(frame) => {
                    let [w, h] = frame.view.size;
                    let img = egui::ColorImage::from_rgba_unmultiplied([w as usize, h as usize], &frame.rgba8);
                    match &mut self.texture {
                        Some(t) => t.set(img, egui::TextureOptions::LINEAR),
                        None => self.texture = Some(ctx.load_texture("frame", img, egui::TextureOptions::LINEAR)),
                    }
                    if seq == self.seq && self.is_full_size(&frame.view) {
                        self.full_frame = Some((frame.rgba8, frame.view.size));
                    }
                    self.latest = Some((seq, frame.stats));
                    if seq == self.seq && self.status.starts_with("render error") {
                        self.status.clear();
                    }
                }
                Err(e) => {
                    self.latest = self.latest.take().map(|(_, s)| (seq, s));
                    self.status = format!("render error: {e}");
                    if let Some(s) = &self.script {
                        *s.result.lock().unwrap_or_else(|e| e.into_inner()) = Some(Err(self.status.clone()));
                        ctx.send_viewport_cmd(egui::ViewportCommand::Close);
                    }
                }
            }
        }
    }

    /// Whether a frame has the idle (not reduced-while-dragging) size.
    pub(crate) fn is_full_size(&self, v: &ViewSpec) -> bool {
        v.size == self.idle_size
    }

    /// Whether the last request's frame is on screen.
    pub(crate) fn idle(&self) -> bool {
        self.latest.as_ref().is_some_and(|(s, _)| *s == self.seq)
    }

    pub(crate) fn send(&mut self, req: FrameRequest) {
        if self.last_sent.as_ref().is_some_and(|r| r.same_frame(&req)) {
            return;
        }
        self.seq += 1;
        let _ = self.tx.send((self.seq, req.clone()));
        self.last_sent = Some(req);
    }

    pub(crate) fn request(&self, size_px: [u32; 2]) -> Result<FrameRequest, String> {
        let mut tf = self.model.to_tf().map_err(|e| e.to_string())?;
        if !self.method.is_bivariate() {
            // 1D methods read only the 1D part (and refuse a TF with widgets).
            tf = tf.without_widgets();
        }
        let mut view = self.view.clone();
        view.size = size_px;
        Ok(FrameRequest {
            view,
            tf: Arc::new(tf),
            tf_revision: self.model.revision(),
            method: self.method,
            table_n_s: self.table_n_s,
            prefer_gpu: self.prefer_gpu,
            display: self.display(),
            time: self.time,
            shading: self.shading(),
            adaptive: None,
        })
    }

    /// The shading the light controls ask for.
    pub(crate) fn shading(&self) -> Shading {
        if !self.light {
            return Shading::default();
        }
        let key = key_light_direction(&self.home, self.light_azimuth as f64, self.light_elevation as f64);
        let lights =
            [LightSource::Directional { direction: key, intensity: 0.9 }, LightSource::Headlight { intensity: 0.3 }];
        let lights = LightSet::new(&lights).expect("a finite key light and a headlight");
        Lighting { lights, shadows: self.shadows, ..Default::default() }.shading(None)
    }

    pub(crate) fn controls(&mut self, ui: &mut egui::Ui) {
        if let (Some(times), Some(t)) = (&self.time_steps, &mut self.time) {
            ui.heading("Time");
            let (first, last) = (times[0], times[times.len() - 1]);
            ui.add(egui::Slider::new(t, first..=last).text("time"));
            // The step at or before the time, and stepping buttons.
            let k = times.partition_point(|&x| x <= *t).saturating_sub(1);
            ui.horizontal(|ui| {
                if ui.button("< step").clicked() {
                    *t = times[if times[k] < *t { k } else { k.saturating_sub(1) }];
                }
                ui.label(format!("step {} of {} (t = {})", k + 1, times.len(), times[k]));
                if ui.button("step >").clicked() {
                    *t = times[(k + 1).min(times.len() - 1)];
                }
            });
            ui.separator();
        }
        ui.heading("Render");
        egui::ComboBox::from_label("method").selected_text(self.method.id()).show_ui(ui, |ui| {
            for m in Method::ALL {
                let label = if gpu_supports(m) { format!("{} (GPU)", m.id()) } else { m.id().to_string() };
                ui.selectable_value(&mut self.method, m, label);
            }
        });
        if matches!(self.method, Method::Table3d | Method::Atlas2d) {
            egui::ComboBox::from_label("table n_s (n_l = 2 n_s)").selected_text(self.table_n_s.to_string()).show_ui(
                ui,
                |ui| {
                    for n in TABLE_SIZES {
                        ui.selectable_value(&mut self.table_n_s, n, n.to_string());
                    }
                },
            );
        }
        ui.add_enabled_ui(self.has_gpu, |ui| ui.checkbox(&mut self.prefer_gpu, "GPU (pt-linear, table3d)"))
            .response
            .on_disabled_hover_text(self.gpu_note.clone());
        let label = |s: f32| SCALES.iter().find(|x| x.0 == s).map_or("?", |x| x.1);
        egui::ComboBox::from_label("resolution").selected_text(label(self.scale)).show_ui(ui, |ui| {
            for (s, l) in SCALES {
                ui.selectable_value(&mut self.scale, s, l);
            }
        });
        egui::ComboBox::from_label("while dragging").selected_text(label(self.drag_scale)).show_ui(ui, |ui| {
            for (s, l) in SCALES {
                ui.selectable_value(&mut self.drag_scale, s, l);
            }
        });
        ui.checkbox(&mut self.drag_adaptive, "adaptive while dragging").on_hover_text(
            "CPU walker: rays on a 4-pixel lattice, smooth blocks interpolated, edges walked (sharper than a lower resolution)",
        );
        ui.horizontal(|ui| {
            ui.checkbox(&mut self.light, "Light").on_hover_text("key light and headlight, gradients as normals (CPU)");
            ui.add_enabled(self.light, egui::Checkbox::new(&mut self.shadows, "Shadows"))
                .on_hover_text("the key light's volumetric shadow (recomputed when the light or the TF changes)");
        });
        ui.add_enabled_ui(self.light, |ui| {
            ui.add(egui::Slider::new(&mut self.light_azimuth, -180.0..=180.0).text("light azimuth °"));
            ui.add(egui::Slider::new(&mut self.light_elevation, -89.0..=89.0).text("light elevation °"));
        });
        ui.horizontal(|ui| {
            ui.checkbox(&mut self.tonemap, "Reinhard");
            ui.add_enabled(self.tonemap, egui::Slider::new(&mut self.exposure, 0.1..=10.0).logarithmic(true))
                .on_hover_text("exposure");
        });

        ui.separator();
        ui.heading("Transfer function");
        tf_editor(ui, &mut self.model, &mut self.editor);
        ui.horizontal(|ui| {
            ui.label("opacity scale");
            ui.add(egui::DragValue::new(&mut self.editor.a_max).speed(0.05).range(0.01..=1e6));
            let mut u = self.model.unit_distance();
            ui.label("unit distance");
            let speed = u * 0.01;
            if ui.add(egui::DragValue::new(&mut u).speed(speed).range(1e-12..=1e12)).changed() {
                self.model.set_unit_distance(u);
            }
        });
        if let Some(i) = self.editor.selected_color.filter(|&i| i < self.model.color_nodes().len()) {
            let node = self.model.color_nodes()[i];
            ui.horizontal(|ui| {
                ui.label(format!("colour node {i} at {:.4}", node.x));
                let mut rgb = node.rgb.map(|v| v.clamp(0.0, 1.0) as f32);
                if ui.color_edit_button_rgb(&mut rgb).changed() {
                    self.model.set_color(i, rgb.map(f64::from));
                }
                if ui.button("remove").clicked() && self.model.remove_color(i) {
                    self.editor.selected_color = None;
                }
            });
        }
        ui.label("drag points; click the curve to add one, the colour bar to add a colour; right-click removes");
        ui.horizontal(|ui| {
            ui.text_edit_singleline(&mut self.tf_path);
        });
        ui.horizontal(|ui| {
            self.browse_button(ui, "Browse… (load)", Browse::LoadTf);
            self.browse_button(ui, "Browse… (save)", Browse::SaveTf);
            if ui.button("load TF").clicked() {
                self.status = match self.load_tf(Path::new(&self.tf_path.clone())) {
                    Ok(()) => format!("loaded {}", self.tf_path),
                    Err(e) => format!("load TF: {e}"),
                };
            }
            if ui.button("save TF").clicked() {
                self.status = match self.model.to_tf().map(|tf| std::fs::write(&self.tf_path, tf.to_json())) {
                    Ok(Ok(())) => format!("saved {}", self.tf_path),
                    Ok(Err(e)) => format!("save TF {}: {e}", self.tf_path),
                    Err(e) => format!("save TF: {e}"),
                };
            }
        });
        ui.horizontal(|ui| {
            ui.label("ParaView preset");
            ui.text_edit_singleline(&mut self.preset_path);
            self.browse_button(ui, "Browse…", Browse::Preset);
        });
        ui.horizontal(|ui| {
            ui.label("name (optional)");
            ui.text_edit_singleline(&mut self.preset_name);
            if ui.button("import").clicked() {
                self.status = match self.import_preset() {
                    Ok(()) => format!("imported {}", self.preset_path),
                    Err(e) => format!("import preset: {e}"),
                };
            }
        });

        ui.separator();
        egui::CollapsingHeader::new(format!("2D widgets ({})", self.model.widgets().len()))
            .default_open(self.histograms.is_some())
            .show(ui, |ui| {
                if !self.method.is_bivariate() {
                    ui.colored_label(
                        Color32::LIGHT_YELLOW,
                        format!("{} ignores widgets: use biv-exact or biv-approx", self.method),
                    );
                }
                // Where new widgets go: the histogram's populated region, 1% tails cut.
                let mut region = None;
                match &self.histograms {
                    Some(h) => {
                        widget_editor(ui, &mut self.model, &mut self.widgets, h);
                        region = populated_region(h, 0.01);
                    }
                    None => {
                        ui.label("this bundle has no 2D histogram (tetprep convert --gradients --histogram)");
                    }
                }
                ui.horizontal(|ui| {
                    ui.label("add");
                    for kind in WidgetKind::ALL {
                        let b = ui
                            .add_enabled(region.is_some(), egui::Button::new(kind.id()))
                            .on_hover_text("centred on the histogram's populated region")
                            .on_disabled_hover_text("needs a 2D histogram with volume in it");
                        if b.clicked() {
                            if let Some(i) =
                                region.and_then(|r| self.model.add_widget_in(kind, r, [1.0, 0.6, 0.2], 1.0))
                            {
                                self.widgets.selected = Some(i);
                            }
                        }
                    }
                });
                ui.label(
                    "drag a widget (a band widget: its clip rectangle) to move it, shift-drag to resize; \
                     click empty space to add a box; right-click removes",
                );
                if let Some(i) = self.widgets.selected.filter(|&i| i < self.model.widgets().len()) {
                    let w = self.model.widgets()[i];
                    ui.horizontal(|ui| {
                        ui.label(format!("widget {i} ({})", WidgetKind::of(&w.shape).id()));
                        let mut rgb = w.color.map(|v| v.clamp(0.0, 1.0) as f32);
                        let mut a = w.opacity;
                        let c = ui.color_edit_button_rgb(&mut rgb).changed();
                        let o = ui
                            .add(egui::DragValue::new(&mut a).speed(0.02).range(0.0..=1e6).prefix("opacity "))
                            .changed();
                        if c || o {
                            self.model.style_widget(i, rgb.map(f64::from), a);
                        }
                        let toggle = match w.shape {
                            Shape::Box { .. } | Shape::Gaussian { .. } => "box/gaussian",
                            Shape::Triangle { .. } | Shape::Sine { .. } => "triangle/sine",
                        };
                        if ui.button(toggle).clicked() {
                            self.model.toggle_widget_shape(i);
                        }
                        if ui.button("remove").clicked() && self.model.remove_widget(i) {
                            self.widgets.selected = None;
                        }
                    });
                    if let Shape::Triangle { frequency, phase } | Shape::Sine { frequency, phase } = w.shape {
                        band_controls(ui, &mut self.model, i, (frequency, phase), w.support, region);
                    }
                }
            });

        ui.separator();
        ui.heading("View");
        ui.horizontal(|ui| {
            if ui.button("reset view (R)").clicked() {
                self.view = self.home.clone();
            }
        });
        ui.horizontal(|ui| {
            ui.text_edit_singleline(&mut self.view_path);
            self.browse_button(ui, "Browse…", Browse::View);
            if ui.button("save view JSON").clicked() {
                let mut v = self.view.clone();
                v.size = self.idle_size;
                self.status = match std::fs::write(&self.view_path, v.to_json()) {
                    Ok(()) => format!("saved {}", self.view_path),
                    Err(e) => format!("save view {}: {e}", self.view_path),
                };
            }
        });
        ui.horizontal(|ui| {
            ui.text_edit_singleline(&mut self.image_path);
            self.browse_button(ui, "Browse…", Browse::Image);
            if ui.button("save image PNG").clicked() {
                self.status = match &self.full_frame {
                    Some((rgba, [w, h])) => {
                        match tet_render::image::write_png_rgba8(Path::new(&self.image_path), *w, *h, rgba) {
                            Ok(()) => format!("saved {} ({w}x{h})", self.image_path),
                            Err(e) => format!("save image: {e}"),
                        }
                    }
                    None => "no full-resolution frame yet".into(),
                };
            }
        });
        ui.horizontal(|ui| {
            ui.text_edit_singleline(&mut self.shot_path);
            self.browse_button(ui, "Browse…", Browse::Shot);
            if ui.button("window screenshot").clicked() {
                request_screenshot(ui.ctx(), PathBuf::from(&self.shot_path), self.shot_slot.clone());
            }
        });
    }

    pub(crate) fn field(&mut self, b: Browse) -> &mut String {
        match b {
            Browse::LoadTf | Browse::SaveTf => &mut self.tf_path,
            Browse::Preset => &mut self.preset_path,
            Browse::View => &mut self.view_path,
            Browse::Image => &mut self.image_path,
            Browse::Shot => &mut self.shot_path,
        }
    }

    /// A "Browse…" button that opens the file dialog for field `b`.
    pub(crate) fn browse_button(&mut self, ui: &mut egui::Ui, label: &str, b: Browse) {
        if ui.button(label).on_hover_text(b.title()).clicked() {
            let field = self.field(b).clone();
            self.dialog = Some((FileDialog::for_field(b.mode(), &field, b.extensions()), b));
        }
    }

    /// Draws the open file dialog; on a choice fills its field and, for
    /// loads, loads.
    pub(crate) fn file_dialog(&mut self, ctx: &egui::Context) {
        let Some((d, b)) = &mut self.dialog else { return };
        let b = *b;
        let Some(outcome) = file_dialog::show(ctx, b.title(), d) else { return };
        self.dialog = None;
        let Outcome::Chosen(path) = outcome else { return };
        *self.field(b) = path.display().to_string();
        self.status = match b {
            Browse::LoadTf => match self.load_tf(&path) {
                Ok(()) => format!("loaded {}", path.display()),
                Err(e) => format!("load TF: {e}"),
            },
            Browse::Preset => match self.import_preset() {
                Ok(()) => format!("imported {}", path.display()),
                Err(e) => format!("import preset: {e}"),
            },
            _ => format!("{}: press save to write it", path.display()),
        };
    }

    /// "Load TF": tet_preint's one loader (tetkit JSON, or a ParaView
    /// preset imported with the current TF's unit distance).
    pub(crate) fn load_tf(&mut self, path: &Path) -> Result<(), String> {
        let opts = LoadOptions { preset_name: None, preset_unit_distance: self.model.unit_distance() };
        let tf = tet_preint::load_tf_with(path, &opts).map_err(|e| e.to_string())?;
        self.model.replace(&tf, self.scalar_range).map_err(|e| e.to_string())?;
        self.editor.selected_color = None;
        self.widgets.selected = None;
        self.editor.a_max = self.model.opacity_nodes().iter().map(|o| o.a).fold(self.editor.a_max, f64::max);
        Ok(())
    }

    /// "Import preset": the same loader, picking the preset by its name
    /// (the first without one), with the current TF's unit distance.
    pub(crate) fn import_preset(&mut self) -> Result<(), String> {
        let name = Some(self.preset_name.trim()).filter(|n| !n.is_empty());
        let opts = LoadOptions { preset_name: name, preset_unit_distance: self.model.unit_distance() };
        let tf = tet_preint::load_tf_with(Path::new(&self.preset_path), &opts).map_err(|e| e.to_string())?;
        self.model.replace(&tf, self.scalar_range).map_err(|e| e.to_string())?;
        self.editor.selected_color = None;
        Ok(())
    }

    pub(crate) fn status_line(&self, ui: &mut egui::Ui) {
        let text = match &self.latest {
            Some((_, s)) => format!(
                "{} | {}x{} | frame {:.1} ms | {} tets/s | drawn {} of {} ({:.1}% culled) | bake {:.1} ms | view {:.1} ms{} | UI {:.0} ms{}",
                s.backend,
                s.size[0],
                s.size[1],
                1e3 * s.frame_seconds,
                si(s.tets_per_second()),
                s.tets_drawn,
                s.tets_total,
                if s.tets_total > 0 { 100.0 * s.tets_culled as f64 / s.tets_total as f64 } else { 0.0 },
                1e3 * s.last_bake_seconds,
                1e3 * s.sort_seconds,
                redone(s),
                self.ui_ms,
                match &s.accuracy {
                    TableAccuracy::NotApplicable => String::new(),
                    a => format!(" | {a}"),
                },
            ),
            None => format!("rendering… ({})", self.gpu_note),
        };
        ui.label(text);
        if !self.status.is_empty() {
            ui.colored_label(Color32::LIGHT_YELLOW, &self.status);
        }
    }

    /// The image with mouse navigation; returns whether the user is interacting.
    pub(crate) fn viewport(&mut self, ui: &mut egui::Ui) -> (bool, [u32; 2]) {
        let panel = ui.available_rect_before_wrap();
        let resp = ui.allocate_rect(panel, Sense::click_and_drag());
        let [w, h] = self.home.size;
        let rect = fit_aspect(panel, w as f32 / h.max(1) as f32);
        let ppp = ui.ctx().pixels_per_point();
        let full = [(rect.width() * ppp).round().max(16.0) as u32, (rect.height() * ppp).round().max(16.0) as u32];
        ui.painter().rect_filled(panel, 0.0, Color32::BLACK);
        if let Some(tex) = &self.texture {
            let uv = Rect::from_min_max(Pos2::ZERO, Pos2::new(1.0, 1.0));
            ui.painter().image(tex.id(), rect, uv, Color32::WHITE);
        }
        let delta = resp.drag_delta();
        let shift = ui.input(|i| i.modifiers.shift);
        if delta != Vec2::ZERO {
            let (dx, dy) = (delta.x as f64, delta.y as f64);
            if resp.dragged_by(PointerButton::Primary) && !shift {
                self.view = nav::orbit(&self.view, dx, dy);
            } else if resp.dragged_by(PointerButton::Secondary)
                || resp.dragged_by(PointerButton::Middle)
                || resp.dragged_by(PointerButton::Primary)
            {
                self.view = nav::pan(&self.view, dx, dy, rect.height() as f64);
            }
        }
        if resp.hovered() {
            let scroll = ui.input(|i| i.smooth_scroll_delta.y) as f64;
            if scroll != 0.0 {
                self.view = nav::dolly(&self.view, (scroll * 0.003).exp());
                self.last_scroll = Some(Instant::now());
            }
        }
        if resp.double_clicked() {
            self.view = self.home.clone();
        }
        let scrolling = self.last_scroll.is_some_and(|t| t.elapsed() < Duration::from_millis(250));
        if scrolling {
            ui.ctx().request_repaint_after(Duration::from_millis(260));
        }
        (resp.dragged() || scrolling, full)
    }

    pub(crate) fn run_script(&mut self, ctx: &egui::Context) {
        let idle = self.idle();
        let Some(s) = &mut self.script else { return };
        // A scripted run takes no input, and a static image asks for no
        // redraw: without this wake-up the event loop would sleep for good
        // once the view stops changing (`--frames 5` without `--spin`), and
        // the timeout below would never be checked.
        ctx.request_repaint_after(SCRIPT_POLL);
        if s.started.elapsed() > Duration::from_secs(300) {
            *s.result.lock().unwrap_or_else(|e| e.into_inner()) = Some(Err("timed out after 300 s".into()));
            ctx.send_viewport_cmd(egui::ViewportCommand::Close);
            return;
        }
        if let Some(res) = self.shot_slot.lock().unwrap_or_else(|e| e.into_inner()).take() {
            *s.result.lock().unwrap_or_else(|e| e.into_inner()) = Some(res.map(|_| ()));
            ctx.send_viewport_cmd(egui::ViewportCommand::Close);
            return;
        }
        if !idle || s.requested {
            return;
        }
        // The screenshot shows the certified table, not the plain one drawn
        // while it was baked.
        if s.done + 1 >= s.frames && self.latest.as_ref().is_some_and(|l| l.1.accuracy == TableAccuracy::Certifying) {
            return;
        }
        s.done += 1;
        if s.done < s.frames {
            self.view = nav::orbit(&self.view, -s.spin_deg / nav::ORBIT_DEG_PER_PX, 0.0);
            if let (Some(t), Some(times)) = (&mut self.time, &self.time_steps) {
                *t = (*t + s.time_step).min(times[times.len() - 1]);
            }
        } else {
            s.requested = true;
            request_screenshot(ctx, s.path.clone(), self.shot_slot.clone());
        }
    }
}

/// The largest rectangle of aspect `w_over_h` inside `panel`, centred. The
/// image takes the home view's aspect, so it shows what `tetview render`
/// draws for that view: the default framing fits the data's bounding sphere
/// into the view's height and, the view being square, its width; a render
/// size taken from a portrait panel would cut it at the sides.
pub(crate) fn fit_aspect(panel: Rect, w_over_h: f32) -> Rect {
    let a = if w_over_h.is_finite() && w_over_h > 0.0 { w_over_h } else { 1.0 };
    let size = if panel.width() > a * panel.height() {
        Vec2::new(a * panel.height(), panel.height())
    } else {
        Vec2::new(panel.width(), panel.width() / a)
    };
    Rect::from_center_size(panel.center(), size)
}

/// 1234567 → "1.23 M".
pub(crate) fn si(v: f64) -> String {
    if v >= 1e9 {
        format!("{:.2} G", v / 1e9)
    } else if v >= 1e6 {
        format!("{:.2} M", v / 1e6)
    } else if v >= 1e3 {
        format!("{:.1} k", v / 1e3)
    } else {
        format!("{v:.0}")
    }
}

pub(crate) fn redone(s: &FrameStats) -> String {
    let mut v = Vec::new();
    if s.rebaked {
        v.push("baked");
    }
    if s.recomputed_cull {
        v.push("culled");
    }
    if s.resorted {
        v.push("view");
    }
    if v.is_empty() {
        String::new()
    } else {
        format!(" | redid: {}", v.join(", "))
    }
}

/// Asks for the window's pixels; the callback writes them as PNG and
/// reports into `slot`.
pub(crate) fn request_screenshot(
    ctx: &egui::Context,
    path: PathBuf,
    slot: Arc<Mutex<Option<Result<PathBuf, String>>>>,
) {
    let wake = ctx.clone();
    ctx.request_screenshot(move |image| {
        let [w, h] = image.size;
        let rgba: Vec<u8> = image.pixels.iter().flat_map(|c| c.to_array()).collect();
        let res = tet_render::image::write_png_rgba8(&path, w as u32, h as u32, &rgba)
            .map(|()| path.clone())
            .map_err(|e| format!("screenshot {}: {e}", path.display()));
        *slot.lock().unwrap_or_else(|e| e.into_inner()) = Some(res);
        wake.request_repaint();
    });
}

impl eframe::App for ViewerApp {
    fn ui(&mut self, ui: &mut egui::Ui, _frame: &mut eframe::Frame) {
        let ctx = ui.ctx().clone();
        let now = Instant::now();
        if let Some(t) = self.last_ui {
            self.ui_ms = 0.9 * self.ui_ms + 0.1 * 1e3 * (now - t).as_secs_f64();
        }
        self.last_ui = Some(now);
        self.receive(&ctx);
        if self.script.is_none() {
            if let Some(res) = self.shot_slot.lock().unwrap_or_else(|e| e.into_inner()).take() {
                self.status = match res {
                    Ok(p) => format!("saved {}", p.display()),
                    Err(e) => e,
                };
            }
        }
        if !ctx.egui_wants_keyboard_input() && ctx.input(|i| i.key_pressed(egui::Key::R)) {
            self.view = self.home.clone();
        }

        egui::Panel::left("controls").resizable(true).default_size(300.0).show(ui, |ui| {
            // A solid, always-visible bar: the controls are taller than a
            // default window, and egui's default floating bar only shows on hover.
            ui.style_mut().spacing.scroll = egui::style::ScrollStyle::solid();
            egui::ScrollArea::vertical()
                .auto_shrink([false, false])
                .scroll_bar_visibility(egui::containers::scroll_area::ScrollBarVisibility::AlwaysVisible)
                .show(ui, |ui| self.controls(ui));
        });
        egui::Panel::bottom("status").show(ui, |ui| self.status_line(ui));
        let (interacting, full) = egui::CentralPanel::default().show(ui, |ui| self.viewport(ui)).inner;
        self.file_dialog(&ctx);

        let interacting = interacting || self.editor.drag.is_some() || self.widgets.drag.is_some();
        let scaled = |s: f32| full.map(|v| ((v as f32 * s).round() as u32).max(16));
        self.idle_size = scaled(self.scale);
        let size = if interacting { scaled(self.scale * self.drag_scale) } else { self.idle_size };
        match self.request(size) {
            Ok(mut req) => {
                req.adaptive = (interacting && self.drag_adaptive).then_some(DRAG_ADAPTIVE_TOL);
                self.send(req)
            }
            Err(e) => self.status = format!("transfer function: {e}"),
        }
        self.run_script(&ctx);
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn key_light_comes_from_the_eye_side_turned_and_raised() {
        let home = ViewSpec::looking_at([0.0, 0.0, 5.0], [0.0; 3], [0.0, 1.0, 0.0], [8, 8]);
        let d = |az, el| glam::DVec3::from(key_light_direction(&home, az, el));
        // Straight from the eye: travels along the view direction (−z).
        assert!((d(0.0, 0.0) - glam::DVec3::NEG_Z).length() < 1e-12);
        // Raised 90°: from above, travelling down.
        assert!((d(0.0, 90.0) - glam::DVec3::NEG_Y).length() < 1e-12);
        // Turned 90° to the right (+x here): travelling towards −x.
        assert!((d(90.0, 0.0) - glam::DVec3::NEG_X).length() < 1e-12);
        assert!((d(-40.0, 45.0).length() - 1.0).abs() < 1e-12);
    }

    #[test]
    fn image_rect_keeps_the_view_aspect_inside_the_panel() {
        // The default window's portrait image panel (570×654) and a wide one.
        for panel in [
            Rect::from_min_size(Pos2::new(310.0, 0.0), Vec2::new(570.0, 654.0)),
            Rect::from_min_size(Pos2::ZERO, Vec2::new(900.0, 300.0)),
        ] {
            for aspect in [1.0f32, 4.0 / 3.0, 0.5] {
                let r = fit_aspect(panel, aspect);
                assert!(panel.expand(1e-3).contains_rect(r), "{panel:?} {r:?}");
                assert!((r.width() / r.height() - aspect).abs() < 1e-4);
                // As large as fits: it touches two opposite sides.
                assert!((r.width() - panel.width()).abs() < 1e-3 || (r.height() - panel.height()).abs() < 1e-3);
                assert!((r.center() - panel.center()).length() < 1e-3);
            }
        }
        assert_eq!(fit_aspect(Rect::from_min_size(Pos2::ZERO, Vec2::splat(10.0)), f32::NAN).size(), Vec2::splat(10.0));
    }

    #[test]
    fn histogram_thumbnail_shows_small_bins() {
        // One huge bin and many bins 1e-8 of it: on the old scale anchored at
        // the maximum they were nearly black; now every non-empty bin is at
        // least dark grey and order is kept.
        let (ns, ng) = (4, 3);
        let mut counts = vec![1e-8; ns * ng];
        counts[0] = 1.0;
        counts[5] = 1e-4;
        counts[7] = 0.0;
        let px = log_grey(&counts, ns, ng);
        let grey = |s: usize, g: usize| px[(ng - 1 - g) * ns + s].r();
        assert_eq!(grey(0, 0), 255);
        assert_eq!(grey(3, 1), 0, "empty bin");
        assert!(grey(1, 0) >= 60);
        assert!(grey(1, 1) > grey(1, 0) + 60, "1e-4 sits mid-scale");
        assert!(log_grey(&[2.0; 4], 2, 2).iter().all(|c| c.r() == 255));
        assert!(log_grey(&[0.0; 4], 2, 2).iter().all(|c| c.r() == 0));
    }
}
