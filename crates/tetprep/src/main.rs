//! `tetprep`: meshes, grids and volumes in, validated tetkit bundles out.
use clap::Parser;

mod analysis;
mod cli;
mod convert;
mod info;
mod plot;

fn main() -> std::process::ExitCode {
    let args = cli::Cli::parse();
    match cli::run(args) {
        Ok(()) => std::process::ExitCode::SUCCESS,
        Err(e) => {
            eprintln!("error: {e:#}");
            std::process::ExitCode::from(cli::exit_code(&e))
        }
    }
}
