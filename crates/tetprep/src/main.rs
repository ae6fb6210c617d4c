//! `tetprep`: meshes, grids and volumes in, validated tetkit bundles out.
//! Exit codes: `tet_cli::ExitKind`, the same in every tetkit program.
use clap::Parser;
use std::process::ExitCode;

mod analysis;
mod cli;
mod convert;
mod info;
mod partition;
mod plot;

fn main() -> ExitCode {
    tet_cli::exit_status("tetprep", cli::run(cli::Cli::parse()))
}
