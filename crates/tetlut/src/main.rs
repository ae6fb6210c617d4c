//! `tetlut`: pre-integration tables for a transfer function (skeleton).
//!
//! Not built yet (issue "tetlut: transfer functions, an exact reference
//! integrator, every pre-integration table"): this binary only says so.
use clap::Parser;

/// Bake pre-integration tables for a transfer function and measure every
/// method's error against an exact reference. NOT BUILT YET: no subcommand
/// works in this version.
#[derive(Debug, Parser)]
#[command(name = "tetlut", version, about)]
struct Cli {
    /// Planned: bake, show, error, bench.
    command: Option<String>,
}

fn main() -> std::process::ExitCode {
    let cli = Cli::parse();
    eprintln!(
        "tetlut{}: not built yet — transfer functions, the exact integrator and the pre-integration tables \
         (table3d, atlas2d, poly1/2/4, partial, biv-*) are planned; this version only converts meshes (tetprep).",
        cli.command.map(|c| format!(" {c}")).unwrap_or_default()
    );
    std::process::ExitCode::from(2)
}
