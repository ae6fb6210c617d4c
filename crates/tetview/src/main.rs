//! `tetview`: render bundles (skeleton).
//!
//! Not built yet (issues for the CPU and GPU renderers): this binary only
//! says so.
use clap::Parser;

/// Render tetkit bundles with projected tetrahedra, exact visibility order
/// and HDR tone mapping. NOT BUILT YET: no subcommand works in this version.
#[derive(Debug, Parser)]
#[command(name = "tetview", version, about)]
struct Cli {
    /// Planned: render, view, bench.
    command: Option<String>,
}

fn main() -> std::process::ExitCode {
    let cli = Cli::parse();
    eprintln!(
        "tetview{}: not built yet — the CPU renderer (MPVO, projected tetrahedra, every table method) and the \
         wgpu renderer are planned; use `tetprep export` and ParaView to look at a bundle meanwhile.",
        cli.command.map(|c| format!(" {c}")).unwrap_or_default()
    );
    std::process::ExitCode::from(2)
}
