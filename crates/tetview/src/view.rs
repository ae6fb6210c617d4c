//! `tetview view`: the interactive window (crate tet_viewer).

use anyhow::Result;
use std::path::PathBuf;
use tet_cli::{classify, ExitKind};
use tet_preint::{Colormap, Method};
use tet_viewer::ViewerError;

/// Open BUNDLE in a window.
///
/// Mouse on the image: left-drag orbits, right-/middle-drag or shift+left
/// pans, the wheel dollies, double-click or R resets the view. Frames render
/// at a reduced resolution while dragging and in full when idle.
#[derive(Debug, clap::Args)]
pub struct ViewArgs {
    /// The bundle (.tetb) written by `tetprep convert`.
    pub bundle: PathBuf,
    /// Transfer function: JSON (formats/tf.md) or a ParaView preset (its
    /// first); a normalized TF is mapped onto the bundle's scalar range.
    /// Default: the bundle's automatic TF (the one `tetview render` builds
    /// without --tf; none for a constant scalar: exit 4, as render).
    #[arg(long)]
    pub tf: Option<PathBuf>,
    /// Colour map of the automatic TF (without --tf), or the colours that
    /// replace those of --tf over its nodes' span: viridis, inferno, magma,
    /// plasma, cool-to-warm, turbo, grayscale (as `tetview render --colormap`).
    #[arg(long, value_parser = crate::tf_choice::parse_colormap)]
    pub colormap: Option<Colormap>,
    /// Method id (exact, pt-linear, table3d, atlas2d, poly1/2/4, partial,
    /// biv-exact, biv-approx); all but exact run on the GPU.
    #[arg(long, default_value = "pt-linear")]
    pub method: String,
    /// View JSON (as `tetview render --view`); the reset view.
    #[arg(long)]
    pub view: Option<PathBuf>,
    #[arg(long, value_parser = tet_cli::parse_direction, allow_hyphen_values = true,
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
    /// Window size WxH in points (each side 64..=16384).
    #[arg(long, default_value = "1100x720", value_parser = tet_cli::parse_window_size)]
    pub window: [f32; 2],
    /// Scripted run: render N full-resolution frames, save a screenshot of
    /// the window to --screenshot, and exit (for tests and CI); frames of an
    /// unchanged view (no --spin) are not drawn again.
    #[arg(long, requires = "screenshot")]
    pub frames: Option<usize>,
    /// PNG of the window's contents, written after --frames.
    #[arg(long, requires = "frames")]
    pub screenshot: Option<PathBuf>,
    /// A time-series bundle's time to open at (default: its first step);
    /// the window's time slider moves it.
    #[arg(long, allow_hyphen_values = true)]
    pub time: Option<f64>,
    /// Scripted run: time advanced between frames (a time-series bundle).
    #[arg(long, default_value_t = 0.0, requires = "frames")]
    pub time_step: f64,
    /// Scripted run: degrees of azimuth between frames.
    #[arg(long, default_value_t = 0.0, allow_hyphen_values = true)]
    pub spin: f64,
}

/// The viewer's options for `args` (a method id that does not exist is a
/// usage error).
pub fn options(args: &ViewArgs) -> Result<tet_viewer::ViewerOptions> {
    let method: Method = args.method.parse()?;
    let mut opts = tet_viewer::ViewerOptions::new(args.bundle.clone());
    opts.tf = args.tf.clone();
    opts.colormap = args.colormap;
    opts.method = method;
    opts.view = args.view.clone();
    opts.view_up = args.view_up;
    opts.cpu_only = args.cpu;
    opts.prefer_gpu = args.gpu;
    opts.window_size = args.window;
    opts.frames = args.frames;
    opts.screenshot = args.screenshot.clone();
    opts.spin_deg = args.spin;
    opts.time = args.time;
    opts.time_step = args.time_step;
    Ok(opts)
}

/// The exit kind of a viewer failure. Its transparent variants hide the
/// library error from the chain, so it is classified here by variant.
fn viewer_kind(e: &ViewerError) -> ExitKind {
    match e {
        ViewerError::Bundle(e) => classify(e).unwrap_or(ExitKind::Internal),
        ViewerError::Render(e) => classify(e).unwrap_or(ExitKind::Internal),
        ViewerError::Tf(e) => classify(e).unwrap_or(ExitKind::Usage),
        // A bundle whose data spans no table domain: rejected data (4), as
        // `render`'s TableError::Domain.
        ViewerError::Table(e) => classify(e).unwrap_or(ExitKind::Rejected),
        // The method cannot be baked for this TF (as `render`'s make_shader).
        ViewerError::Method(_) => ExitKind::Bake,
        // Options that cannot go together.
        ViewerError::Input(_) => ExitKind::Usage,
        // Reading --tf or --view.
        ViewerError::Io { .. } => ExitKind::Input,
        // The engine's own meanings (a bake: 5; a GPU failure that still
        // ends the run), else the lower crate's error it wraps.
        ViewerError::Engine(e) => {
            classify(e).or_else(|| std::error::Error::source(e).and_then(classify)).unwrap_or(ExitKind::Internal)
        }
        // No window (no display) or a scripted run without its screenshot
        // is unexpected.
        ViewerError::Window(_) | ViewerError::Scripted(_) => ExitKind::Internal,
    }
}

pub fn run(args: &ViewArgs) -> Result<()> {
    let opts = options(args)?;
    tet_viewer::run(opts).map_err(|e| anyhow::Error::new(tet_cli::Tagged::new(viewer_kind(&e), e)))
}

#[cfg(test)]
mod tests {
    use super::*;
    use clap::Parser;

    /// `tetview view`'s arguments on their own.
    #[derive(Debug, Parser)]
    struct ViewOnly {
        #[command(flatten)]
        view: ViewArgs,
    }

    fn parse(args: &[&str]) -> Result<ViewArgs, clap::Error> {
        ViewOnly::try_parse_from(std::iter::once("view").chain(args.iter().copied())).map(|v| v.view)
    }

    #[test]
    fn colormap_is_parsed_and_passed_to_the_viewer() {
        let opts = options(&parse(&["b.tetb", "--colormap", "inferno"]).unwrap()).unwrap();
        assert_eq!(opts.colormap, Some(Colormap::Inferno));
        let opts = options(&parse(&["b.tetb", "--tf", "t.json", "--colormap", "cool-to-warm"]).unwrap()).unwrap();
        assert_eq!(opts.colormap, Some(Colormap::CoolToWarm));
        assert_eq!(opts.tf.as_deref(), Some(std::path::Path::new("t.json")));
        assert_eq!(options(&parse(&["b.tetb"]).unwrap()).unwrap().colormap, None);
        let e = parse(&["b.tetb", "--colormap", "rainbow"]).unwrap_err();
        assert_eq!(e.kind(), clap::error::ErrorKind::ValueValidation);
        assert!(e.to_string().contains("rainbow"), "{e}");
    }

    #[test]
    fn a_bundle_without_a_table_domain_is_rejected_data_as_in_render() {
        let e = ViewerError::Table(tet_preint::TableError::Domain { what: "no scalar span".into() });
        assert_eq!(viewer_kind(&e), ExitKind::Rejected);
        // What `render` gets for the same failure (tet_cli's classify).
        let same = tet_preint::TableError::Domain { what: "no scalar span".into() };
        assert_eq!(classify(&same), Some(ExitKind::Rejected));
        let read = tet_preint::load_tf(std::path::Path::new("/nonexistent/tf.json")).unwrap_err();
        assert_eq!(viewer_kind(&ViewerError::Tf(read)), ExitKind::Input);
    }

    #[test]
    fn window_size_and_method_use_the_shared_parsers_and_kinds() {
        let opts = options(&parse(&["b.tetb", "--window", "800x600"]).unwrap()).unwrap();
        assert_eq!(opts.window_size, [800.0, 600.0]);
        assert!(parse(&["b.tetb", "--window", "10x600"]).is_err());
        let e = options(&parse(&["b.tetb", "--method", "table9d"]).unwrap()).unwrap_err();
        assert_eq!(tet_cli::exit_code(&e), 2);
    }
}
