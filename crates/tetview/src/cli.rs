//! Command line: subcommands and the flags they share (exit codes: tet_cli).

use clap::{Parser, Subcommand};

/// Render tetkit bundles: projected tetrahedra on the CPU with an exact
/// visibility order (MPVO), per-fragment segment integration, HDR tone
/// mapping, and a float image for measurement.
///
/// Exit codes: listed below (`tet_cli::ExitKind`, the same in every tetkit program).
#[derive(Debug, Parser)]
#[command(name = "tetview", version, about, long_about, after_help = tet_cli::EXIT_CODES_HELP)]
pub struct Cli {
    #[command(subcommand)]
    command: Command,
}

#[derive(Debug, Subcommand)]
enum Command {
    /// Render a bundle to PNG (and optionally a float .npy).
    Render(crate::render::RenderArgs),
    /// Exact ray-cast reference render (ground truth for `tetview diff`).
    Reference(crate::reference::ReferenceArgs),
    /// Compare two images (.npy float or .png): RMSE, max/mean abs, 8-bit max after display.
    Diff(crate::diff::DiffArgs),
    /// An orbit and/or a time series as an animated PNG (and numbered PNG
    /// frames), one look for every frame, one tone-mapping fit for all.
    Animate(crate::animate::AnimateArgs),
    /// Run time against image error of every method, on real bundles, against
    /// the reference render: markdown table, Pareto PNG, JSON.
    Bench(crate::bench::BenchArgs),
    /// Open a window: orbit/zoom/pan, transfer-function editor, method and
    /// resolution selectors, live statistics (CPU, or tet_gpu where an
    /// adapter exists and the method is on the GPU).
    View(crate::view::ViewArgs),
}

pub fn run(cli: Cli) -> anyhow::Result<()> {
    match cli.command {
        Command::Render(args) => crate::render::run(&args),
        Command::Reference(args) => crate::reference::run(&args),
        Command::Diff(args) => crate::diff::run(&args),
        Command::Bench(args) => crate::bench::run(&args),
        Command::Animate(args) => crate::animate::run(&args),
        Command::View(args) => crate::view::run(&args),
    }
}

/// Help shared by every `--view-up` flag.
pub const VIEW_UP_HELP: &str = "View-up X,Y,Z (world) of the default view, which frames the bounds \
    (before --azimuth/--elevation). Default: +z, seen from -y and 30 degrees above, for point clouds \
    and data flat in z (z extent under a fifth of the x and y extents), else +y, seen from +z";

/// Warns on stderr when the bundle's scalar has one value everywhere: every
/// transfer function then draws the mesh in one colour. The text is
/// tet_preint's `constant_scalar_warning`, the one tetlut prints too.
pub fn warn_if_constant_scalar(bundle: &tet_bundle::Bundle) {
    if let Some(w) = tet_preint::constant_scalar_warning(bundle) {
        eprintln!("warning: {w}");
    }
}

/// `--time T`: a time series' scalar at time T (linear between the two
/// steps around it; the normalized TF spans every step's range).
#[derive(Debug, Clone, clap::Args)]
pub struct TimeArgs {
    /// Time to draw a time-series bundle at (`tetprep info` lists its
    /// steps): a step's own scalar at its time, linear between steps;
    /// normalized TFs span the scalar's range over every step, so colours
    /// mean the same at every time. Without --time: the first step.
    #[arg(long, allow_hyphen_values = true)]
    pub time: Option<f64>,
}

impl TimeArgs {
    /// Reads the bundle at `path`, at `--time` if given. A time outside the
    /// steps, or on a bundle without steps, is a usage error (exit code 2).
    pub fn read_bundle(&self, path: &std::path::Path) -> anyhow::Result<tet_bundle::Bundle> {
        let mut bundle = tet_bundle::Bundle::read(path)?;
        if let Some(t) = self.time {
            bundle.set_time(t).map_err(|e| tet_cli::usage(format!("--time {t}: {e} ({})", path.display())))?;
        }
        Ok(bundle)
    }
}
