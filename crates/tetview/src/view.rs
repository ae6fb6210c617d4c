//! `tetview view`: the interactive window (crate tet_viewer).

use crate::cli::UsageError;
use anyhow::Result;
use std::path::PathBuf;
use tet_preint::Method;

/// Open BUNDLE in a window.
///
/// Mouse on the image: left-drag orbits, right-/middle-drag or shift+left
/// pans, the wheel dollies, double-click or R resets the view. Frames render
/// at a reduced resolution while dragging and in full when idle.
#[derive(Debug, clap::Args)]
pub struct ViewArgs {
    /// The bundle (.tetb) written by `tetprep convert`.
    pub bundle: PathBuf,
    /// Transfer function JSON (formats/tf.md); a normalized TF is mapped onto
    /// the bundle's scalar range. Default: the bundle's automatic TF (the
    /// one `tetview render` builds without --tf).
    #[arg(long)]
    pub tf: Option<PathBuf>,
    /// Method id (exact, pt-linear, table3d, atlas2d, poly1/2/4, partial,
    /// biv-exact, biv-approx); all but exact run on the GPU.
    #[arg(long, default_value = "pt-linear")]
    pub method: String,
    /// View JSON (as `tetview render --view`); the reset view.
    #[arg(long)]
    pub view: Option<PathBuf>,
    #[arg(long, value_parser = crate::cli::parse_view_up, allow_hyphen_values = true,
          conflicts_with = "view", help = crate::cli::VIEW_UP_HELP)]
    pub view_up: Option<[f64; 3]>,
    /// Render on the CPU even where a GPU adapter exists.
    #[arg(long, conflicts_with = "gpu")]
    pub cpu: bool,
    /// Start on the GPU even when the adapter is a software one (lavapipe);
    /// by default the window starts on the GPU only for hardware adapters
    /// (its GPU checkbox switches either way).
    #[arg(long)]
    pub gpu: bool,
    /// Window size WxH in points.
    #[arg(long, default_value = "1100x720", value_parser = parse_size)]
    pub window: [f32; 2],
    /// Scripted run: render N full-resolution frames, save a screenshot of
    /// the window to --screenshot, and exit (for tests and CI); frames of an
    /// unchanged view (no --spin) are not drawn again.
    #[arg(long, requires = "screenshot")]
    pub frames: Option<usize>,
    /// PNG of the window's contents, written after --frames.
    #[arg(long, requires = "frames")]
    pub screenshot: Option<PathBuf>,
    /// Scripted run: degrees of azimuth between frames.
    #[arg(long, default_value_t = 0.0, allow_hyphen_values = true)]
    pub spin: f64,
}

fn parse_size(s: &str) -> Result<[f32; 2], String> {
    let (w, h) = s.split_once(['x', 'X']).ok_or("expected WxH, e.g. 1100x720")?;
    let p = |x: &str| match x.trim().parse::<f32>() {
        Ok(v) if (64.0..=16384.0).contains(&v) => Ok(v),
        Ok(v) => Err(format!("{v}: need 64 to 16384")),
        Err(e) => Err(format!("{x:?}: {e}")),
    };
    Ok([p(w)?, p(h)?])
}

pub fn run(args: &ViewArgs) -> Result<()> {
    let method: Method = args.method.parse().map_err(|e: tet_preint::UnknownMethod| UsageError(e.to_string()))?;
    let mut opts = tet_viewer::ViewerOptions::new(args.bundle.clone());
    opts.tf = args.tf.clone();
    opts.method = method;
    opts.view = args.view.clone();
    opts.view_up = args.view_up;
    opts.cpu_only = args.cpu;
    opts.prefer_gpu = args.gpu;
    opts.window_size = args.window;
    opts.frames = args.frames;
    opts.screenshot = args.screenshot.clone();
    opts.spin_deg = args.spin;
    tet_viewer::run(opts)?;
    Ok(())
}
