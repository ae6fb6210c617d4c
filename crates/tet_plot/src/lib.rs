//! Small PNG plots for tetkit's reports, with no system fonts or native
//! libraries: `tetprep hist`'s histograms, and the run-time-against-error
//! Pareto plots of `tetlut bench` and `tetview bench`.
//!
//! * [`Canvas`] (module [`canvas`]): an RGB raster with rectangles, lines,
//!   markers and text in a built-in 5×7 [`font`], written as PNG.
//! * [`ScatterPlot`] / [`Series`] / [`Point`] (module [`scatter`]): log or
//!   linear axes, one colour per series, labels, and the [`pareto_front`].
//! * [`scale`]: [`viridis`], series colours, round-number ticks, number labels.
//!
//! ```
//! use tet_plot::{Point, ScatterPlot, Series};
//! let plot = ScatterPlot {
//!     title: "error against bake time".into(),
//!     x_label: "bake time [s]".into(),
//!     y_label: "max error".into(),
//!     log_x: true,
//!     log_y: true,
//!     series: vec![Series {
//!         name: "table3d".into(),
//!         points: vec![Point { x: 0.05, y: 1e-3, label: Some("64".into()) }],
//!     }],
//!     pareto: true,
//! };
//! let png = plot.draw(800, 500).to_png()?;
//! assert_eq!(&png[1..4], b"PNG");
//! # Ok::<(), tet_plot::PlotError>(())
//! ```
#![forbid(unsafe_code)]

pub mod canvas;
pub mod font;
pub mod scale;
pub mod scatter;

pub use canvas::{Canvas, Rgb};
pub use scale::{fmt_num, nice_ticks, viridis, with_colorbar};
pub use scatter::{pareto_front, Point, ScatterPlot, Series};

use std::path::PathBuf;

#[derive(Debug, thiserror::Error)]
pub enum PlotError {
    #[error("PNG encoding: {0}")]
    Png(String),
    #[error("{source}: {path}")]
    Io { source: std::io::Error, path: PathBuf },
}
