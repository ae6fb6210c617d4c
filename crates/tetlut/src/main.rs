//! `tetlut`: bake, inspect, probe and benchmark pre-integration tables.
//!
//! Subcommands: `bake` (a method's tables to `.tetl`), `show` (a `.tetl` as
//! labelled images), `probe` (segments in, premultiplied RGBA out) and
//! `bench` (bake time, memory and error of every method; `--paper`
//! reproduces the tables of Röttger & Ertl 2002 (Tables 1–2) and Guthe et al. 2002 (Table 4)).
mod bake;
mod bench;
mod common;
mod paper;
mod probe;
mod show;

use clap::Parser;

fn main() -> std::process::ExitCode {
    let cli = common::Cli::parse();
    let result = match cli.command {
        common::Command::Bake(args) => bake::run(&args),
        common::Command::Show(args) => show::run(&args),
        common::Command::Probe(args) => probe::run(&args),
        common::Command::Bench(args) => bench::run(&args),
    };
    match result {
        Ok(()) => std::process::ExitCode::SUCCESS,
        Err(e) => {
            eprintln!("tetlut: {e:#}");
            std::process::ExitCode::from(common::exit_code(&e))
        }
    }
}
