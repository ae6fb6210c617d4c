//! `tetview`: render tetkit bundles on the CPU (projected tetrahedra with an
//! exact visibility order, HDR tone mapping, float output for measurement).
use clap::Parser;

mod bench;
mod cli;
mod diff;
mod gpu;
mod reference;
mod render;
mod tf_choice;
mod view;

fn main() -> std::process::ExitCode {
    let args = cli::Cli::parse();
    match cli::run(args) {
        Ok(()) => std::process::ExitCode::SUCCESS,
        Err(e) => {
            eprintln!("tetview: {e:#}");
            std::process::ExitCode::from(cli::exit_code(&e))
        }
    }
}
