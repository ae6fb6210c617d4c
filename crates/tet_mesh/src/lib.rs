//! Tetrahedral mesh core (overview filled in as modules land).
#![forbid(unsafe_code)]

pub mod source;
pub use source::{Block, CellType, Cells, Field, SourceMesh};
