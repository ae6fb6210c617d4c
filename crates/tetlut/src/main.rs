//! `tetlut`: bake, inspect, probe and benchmark pre-integration tables.
//!
//! Subcommands: `bake` (a method's tables to `.tetl`), `show` (a `.tetl` as
//! labelled images), `probe` (segments in, premultiplied RGBA out) and
//! `bench` (bake time, memory and error of every method; `--paper`
//! reproduces the tables of Röttger & Ertl 2002 (Tables 1–2) and Guthe et al. 2002 (Table 4)).
//! Exit codes: `tet_cli::ExitKind`, the same in every tetkit program.
mod bake;
mod bench;
mod common;
mod paper;
mod probe;
mod show;

use clap::Parser;
use std::process::ExitCode;

fn main() -> ExitCode {
    tet_cli::exit_status("tetlut", common::run(common::Cli::parse()))
}
