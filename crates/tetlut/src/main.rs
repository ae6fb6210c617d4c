//! `tetlut`: transfer functions and pre-integration of ray segments.
//!
//! Built: `probe` with the `exact` reference integrator. Not built yet: the
//! tables (table3d, atlas2d, poly1/2/4, partial, biv-*) and the `bake`,
//! `show` and `bench` subcommands.
mod probe;

use clap::{Parser, Subcommand};

/// Pre-integration of ray segments through linear tetrahedra.
///
/// Built: `probe` with method `exact` (the f64 reference). Not built yet:
/// the pre-integration tables (table3d, atlas2d, poly1/2/4, partial,
/// biv-exact, biv-approx) and the bake, show and bench subcommands.
#[derive(Debug, Parser)]
#[command(name = "tetlut", version, about, long_about)]
struct Cli {
    #[command(subcommand)]
    command: Command,
}

#[derive(Debug, Subcommand)]
enum Command {
    Probe(probe::ProbeArgs),
}

fn main() -> std::process::ExitCode {
    let cli = Cli::parse();
    let result = match cli.command {
        Command::Probe(args) => probe::run(&args),
    };
    match result {
        Ok(()) => std::process::ExitCode::SUCCESS,
        Err(e) => {
            eprintln!("tetlut: {e:#}");
            std::process::ExitCode::FAILURE
        }
    }
}
