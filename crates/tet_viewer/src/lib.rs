//! The interactive viewer behind `tetview view`: an eframe window (OpenGL
//! through glow, so wgpu stays in tet_gpu) showing frames rendered by
//! tet_engine's CPU or GPU renderer, with a transfer-function editor.
//!
//! * [`run`] with [`ViewerOptions`]: opens the window (or, with
//!   `frames`, renders that many frames, saves a screenshot of the window
//!   and exits — the test under Xvfb).
//! * [`Engine`] (module [`engine`]): a [`FrameRequest`] (view, TF revision,
//!   method, table resolution, display) in, an 8-bit [`Frame`] and
//!   [`FrameStats`] out, recomputing only what changed: a camera move
//!   re-sorts only, a TF edit re-bakes and re-culls only. It runs on a
//!   worker thread so the window stays responsive; frames render at a
//!   reduced resolution while the mouse drags.
//! * [`TfModel`] (module [`tf_model`]): the editor's control points, valid
//!   after every add, drag and remove.
//! * [`nav`]: orbit, pan and dolly on a `ViewSpec`.
//! * [`FileDialog`] (module [`file_dialog`]): the in-window file browser
//!   behind the "Browse…" buttons (no system dialog library needed).
//!
//! ```
//! use tet_viewer::TfModel;
//! let mut model = TfModel::ramp([0.0, 10.0], 1.0);
//! let i = model.add_opacity(5.0, 2.0).unwrap();
//! model.move_opacity(i, 50.0, 2.5); // stops short of the last node at x = 10
//! assert!(model.opacity_nodes()[i].x < 10.0);
//! let tf = model.to_tf()?;
//! assert_eq!(tf.opacity_nodes().len(), 3);
//! # Ok::<(), tet_preint::TfError>(())
//! ```
#![forbid(unsafe_code)]

mod app;
pub mod engine;
pub mod file_dialog;
pub mod nav;
pub mod tf_model;

pub use engine::{gpu_supports, Engine, Frame, FrameRequest, FrameStats, TableAccuracy};
pub use file_dialog::FileDialog;
pub use tf_model::TfModel;

use std::path::PathBuf;
use tet_preint::Method;

/// Why the viewer could not start or finish.
#[derive(Debug, thiserror::Error)]
pub enum ViewerError {
    #[error(transparent)]
    Bundle(#[from] tet_bundle::BundleError),
    #[error(transparent)]
    Render(#[from] tet_render::RenderError),
    /// The render engine's (a bake, a frame, the GPU renderer).
    #[error(transparent)]
    Engine(#[from] tet_engine::EngineError),
    #[error(transparent)]
    Tf(#[from] tet_preint::TfError),
    /// The bundle's data spans no table domain (no scalar span, no cell
    /// size): rejected data, as in `tetview render`.
    #[error(transparent)]
    Table(#[from] tet_preint::TableError),
    /// The method cannot be baked for this TF (e.g. 2D widgets on a 1D method).
    #[error("method {0}")]
    Method(String),
    #[error("input: {0}")]
    Input(String),
    #[error("{source}: {path}")]
    Io { source: std::io::Error, path: PathBuf },
    /// The window could not be opened (no display, no OpenGL).
    #[error("window: {0}")]
    Window(String),
    /// A `frames` run did not produce its screenshot.
    #[error("scripted run: {0}")]
    Scripted(String),
}

/// What `tetview view` was asked for.
#[derive(Debug, Clone)]
pub struct ViewerOptions {
    pub bundle: PathBuf,
    /// Transfer function file, read by `tet_preint::load_tf` (tetkit JSON or
    /// a ParaView preset; a normalized one is mapped onto the bundle's
    /// scalar range); the bundle's automatic TF when `None` (an error for a
    /// constant scalar, as in `tetview render`).
    pub tf: Option<PathBuf>,
    /// Colour map of the automatic TF (without `tf`), or the colours that
    /// replace those of `tf` over its nodes' span (tet_preint's `choose_tf`,
    /// as `tetview render --colormap`); `None`: the file's colours, or the
    /// automatic TF's default map.
    pub colormap: Option<tet_preint::Colormap>,
    pub method: Method,
    /// View JSON (as `tetview render --view`); framing the bounds when `None`.
    pub view: Option<PathBuf>,
    /// View-up of the framing when there is no view file; `None`: the
    /// data's own (`tet_render::ViewSpec::default_for`).
    pub view_up: Option<[f64; 3]>,
    /// Never open a GPU context (render on the CPU).
    pub cpu_only: bool,
    /// Start on the GPU even when its adapter is a software one (by
    /// default the window starts on the GPU only for hardware adapters;
    /// the GPU checkbox switches either way).
    pub prefer_gpu: bool,
    /// Window size in points.
    pub window_size: [f32; 2],
    /// Scripted run: render this many full-resolution frames (a view that
    /// does not change is not drawn again), then save a screenshot of the
    /// window to `screenshot` and exit; it always ends, within 300 s.
    pub frames: Option<usize>,
    pub screenshot: Option<PathBuf>,
    /// Scripted run: degrees of azimuth between frames (exercises re-sorting).
    pub spin_deg: f64,
    /// A time-series bundle's time to open at (`None`: its first step);
    /// the window's time slider moves it.
    pub time: Option<f64>,
    /// Scripted run: time advanced between frames (exercises new scalars).
    pub time_step: f64,
}

impl ViewerOptions {
    pub fn new(bundle: PathBuf) -> ViewerOptions {
        ViewerOptions {
            bundle,
            tf: None,
            colormap: None,
            method: Method::PtLinear,
            view: None,
            view_up: None,
            cpu_only: false,
            prefer_gpu: false,
            window_size: [1100.0, 720.0],
            frames: None,
            screenshot: None,
            spin_deg: 0.0,
            time: None,
            time_step: 0.0,
        }
    }
}

/// Opens the viewer and returns when its window closes (or a scripted run ends).
pub fn run(opts: ViewerOptions) -> Result<(), ViewerError> {
    app::run(opts)
}
