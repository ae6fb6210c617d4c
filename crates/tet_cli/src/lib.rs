//! What the three tetkit programs (`tetprep`, `tetlut`, `tetview`) share on
//! the command line, so that one failure gets one exit code everywhere and
//! one flag syntax one parser.
//!
//! * [`ExitKind`]: the documented failure kinds and their exit codes
//!   ([`ExitKind::ALL`] is the table every program's `--help` and the README
//!   print).
//! * [`KindExt::kind`] and [`Tagged`]: a call site that knows what failed
//!   (reading an input or writing an output, a bad flag) tags the error;
//!   [`usage`] and [`fail`] make a new tagged error from a message.
//! * [`exit_code`]: the code of an error chain — the outermost tag wins,
//!   else the first library error in the chain is classified by its type
//!   ([`classify`]), else 1. [`describe`] is the message the programs print.
//! * [`hist_plot::histogram_figure`]: the scalar × |∇s| histogram figure
//!   `tetprep hist` and the Python package draw.
//! * [`parse_size`], [`parse_window_size`], [`parse_range`], [`parse_rgb`]:
//!   clap `value_parser`s for `WxH`, `LO,HI` and `R,G,B`.
//!
//! This crate serves binaries only, so it speaks `anyhow` (the libraries
//! below it return their own `thiserror` types, which [`classify`] knows).
//! It depends on the CPU data-path crates only; errors of the GPU and the
//! window (tet_gpu, tet_viewer) are tagged where `tetview` calls them.
//!
//! ```
//! use tet_cli::{exit_code, ExitKind, KindExt};
//!
//! // A tagged failure keeps its kind through added context.
//! let written: anyhow::Result<()> =
//!     std::fs::write("/nonexistent-dir/out.png", b"x").kind(ExitKind::Output);
//! let e = anyhow::Context::context(written, "writing the image").unwrap_err();
//! assert_eq!(exit_code(&e), 5);
//!
//! // An untagged library error is classified by its type.
//! let e = anyhow::Error::new(tet_bundle::Bundle::read("/nonexistent.tetb".as_ref()).unwrap_err());
//! assert_eq!(exit_code(&e), ExitKind::Input.code());
//!
//! // The shared parsers, as clap value_parsers or directly.
//! assert_eq!(tet_cli::parse_size("640x480"), Ok([640, 480]));
//! assert_eq!(tet_cli::parse_range("-1,2.5"), Ok((-1.0, 2.5)));
//! assert!(tet_cli::parse_range("3,1").is_err());
//! ```
#![forbid(unsafe_code)]

mod args;
mod exit;
pub mod hist_plot;

pub use args::{
    parse_counts3, parse_direction, parse_range, parse_rgb, parse_size, parse_window_size, parse_xyz, WINDOW_SIDE,
};
pub use exit::{
    classify, describe, exit_code, exit_status, fail, report_now, usage, ExitKind, KindExt, Reported, Tagged,
    EXIT_CODES_HELP,
};
