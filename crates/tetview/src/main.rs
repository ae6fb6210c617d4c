//! `tetview`: render tetkit bundles on the CPU (projected tetrahedra with an
//! exact visibility order, HDR tone mapping, float output for measurement).
//! Exit codes: `tet_cli::ExitKind`, the same in every tetkit program.
use clap::Parser;
use std::process::ExitCode;

mod animate;
mod bench;
mod camera_args;
mod cli;
mod diff;
mod distributed;
mod gpu;
mod look_args;
mod reference;
mod render;
mod tf_choice;
mod view;

fn main() -> ExitCode {
    tet_cli::exit_status("tetview", cli::run(cli::Cli::parse()))
}
