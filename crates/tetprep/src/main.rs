//! `tetprep`: meshes, grids and volumes in, validated tetkit bundles out.
//! Exit codes: `tet_cli::ExitKind`, the same in every tetkit program.
use clap::Parser;
use std::process::ExitCode;

mod analysis;
mod cli;
mod convert;
mod info;
mod plot;

fn main() -> ExitCode {
    match cli::run(cli::Cli::parse()) {
        Ok(()) => ExitCode::SUCCESS,
        Err(e) => {
            eprintln!("tetprep: {}", tet_cli::describe(&e));
            ExitCode::from(tet_cli::exit_code(&e))
        }
    }
}
