//! CPU rendering of tetrahedral bundles — the reference implementation that
//! every faster path (and the GPU) is measured against.
//!
//! * [`Camera`] / [`ViewSpec`] (module [`camera`]): VTK camera semantics,
//!   the `--view` JSON, framing, orbit, projection and pixel rays.
//! * [`Image`] (module [`image`]): linear premultiplied RGBA f32, `.npy`
//!   read/write, [`Display`] (background + [`ToneMap`]: none or Reinhard with
//!   log-average luminance) to 8-bit PNG, and [`diff`] statistics.
//! * [`ReferenceRenderer`] / [`render_reference`] (module [`reference`]):
//!   exact ray casting through the tets by face adjacency (exact ray–tet
//!   segments, `exact` integration, f64 compositing) — the ground truth for
//!   image errors; [`boundary::BoundaryBvh`] finds where rays enter.
//!
//! ```
//! use tet_render::{Camera, Image, ViewSpec};
//! let view = ViewSpec::framing([0.0; 3], [1.0; 3], [64, 48]);
//! let camera = Camera::new(&view)?;
//! // The focal point lands on the image centre.
//! let p = camera.project(glam::DVec3::splat(0.5));
//! assert!((p.x - 32.0).abs() < 1e-9 && (p.y - 24.0).abs() < 1e-9);
//! let img = Image::new(64, 48);
//! assert_eq!(tet_render::diff(&img, &img)?.max_abs, 0.0);
//! # Ok::<(), tet_render::RenderError>(())
//! ```
#![forbid(unsafe_code)]

pub mod boundary;
pub mod camera;
pub mod image;
pub mod reference;

pub use camera::{Camera, ViewSpec};
pub use image::{diff, DiffStats, Display, Image, ToneMap};
pub use reference::{render_reference, RayResult, RayScratch, ReferenceOptions, ReferenceRenderer, ReferenceStats};

use std::path::PathBuf;

/// Why a render or an image operation failed.
#[derive(Debug, thiserror::Error)]
pub enum RenderError {
    #[error("view: {0}")]
    View(String),
    #[error("image of {expected:?} pixels (width, height) given {pixels} pixels")]
    ImageSize { expected: [u32; 2], pixels: usize },
    #[error("images differ in size: {a:?} vs {b:?} (width, height)")]
    SizeMismatch { a: [u32; 2], b: [u32; 2] },
    #[error("PNG encoding: {0}")]
    Png(String),
    #[error(".npy: {why}: {path}")]
    Npy { why: String, path: PathBuf },
    #[error("{source}: {path}")]
    Io { source: std::io::Error, path: PathBuf },
    #[error("mesh and adjacency disagree: {why}")]
    InvalidMesh { why: String },
    #[error("the transfer function is normalized: map it onto the scalar range first (TransferFunction::denormalize)")]
    NormalizedTransferFunction,
}
