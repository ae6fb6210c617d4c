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
//! * [`Scene`] (module [`scene`]): the renderer's copy of a bundle,
//!   positions relative to the mesh centre.
//! * [`Renderer`] (module [`pipeline`]): projected tetrahedra with cached
//!   stages — view geometry ([`project`]), culling ([`cull`]), visibility
//!   order ([`sort`]: MPVO, MPVONC, radix), tile-parallel rasterization
//!   ([`raster`]: per-fragment methods without lighting take a fast path
//!   that sets each tet up once per frame and shades fragments in SoA
//!   batches through [`tet_preint::SegmentShader::shade_batch`], with images
//!   bit-identical to the per-tile path) and optional lighting/silhouettes
//!   ([`shading`]: [`Shading`], [`LightSet`], the view file's [`Lighting`])
//!   with volumetric shadows ([`shadow`]: [`ShadowField`], a deep shadow
//!   map per directional light or point light outside the mesh's box, a
//!   cube of six maps around a point light inside or beside it); the
//!   reference lights by quadrature with exact shadow rays
//!   ([`LitReference`]).
//!
//! ```
//! use std::sync::Arc;
//! use tet_render::{Camera, Image, Renderer, Scene, ViewSpec};
//! let view = ViewSpec::framing([0.0; 3], [1.0; 3], [64, 48]);
//! let camera = Camera::new(&view)?;
//! // The focal point lands on the image centre.
//! let p = camera.project(glam::DVec3::splat(0.5));
//! assert!((p.x - 32.0).abs() < 1e-9 && (p.y - 24.0).abs() < 1e-9);
//! let img = Image::new(64, 48);
//! assert_eq!(tet_render::diff(&img, &img)?.max_abs, 0.0);
//!
//! // One tet, constant scalar, rendered with the exact integrator.
//! let pts = [[0.0, 0.0, 0.0], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]];
//! let scene = Scene::new(&pts, vec![[0, 1, 2, 3]], vec![0.5; 4])?;
//! let tf = tet_preint::TransferFunction::from_json(
//!     r#"{"color": [[0, 1, 1, 1]], "opacity": [[0, 2]], "unit_distance": 1}"#,
//! ).unwrap();
//! let mut r = Renderer::new(scene);
//! r.set_view(&view)?;
//! r.set_shader(Arc::new(tet_preint::ExactShader::new(tf)));
//! let (img, stats) = r.render(&|_, _| {})?;
//! assert_eq!(stats.tets_drawn, 1);
//! assert!(stats.fragments > 0 && img.pixels().iter().any(|p| p[3] > 0.0));
//! # Ok::<(), tet_render::RenderError>(())
//! ```
// Unsafe code: denied everywhere except `walk::prefetch` (a cache hint
// with its SAFETY note; `deny`, not `forbid`, so that one module may allow it).
#![deny(unsafe_code)]

pub mod boundary;
pub mod camera;
pub mod cull;
pub mod image;
pub mod pipeline;
pub mod project;
pub mod raster;
pub mod reference;
pub mod scene;
pub mod shading;
pub mod shadow;
pub mod sort;
pub mod walk;

pub use camera::{Camera, KeyPath, ViewSpec};
pub use cull::{CellCuller, CullMask, TfCuller};
pub use image::{diff, DiffStats, Display, Image, PictureMetrics, ToneMap};
pub use pipeline::{CpuRenderer, RenderStats, Renderer};
pub use raster::{RasterOptions, RasterStats};
pub use reference::{
    render_reference, LitReference, RayResult, RayScratch, ReferenceOptions, ReferenceRenderer, ReferenceStats,
};
pub use scene::Scene;
pub use shading::{Light, LightSet, LightSource, Lighting, LitPoint, Shading, MAX_LIGHTS};
pub use shadow::{ShadowField, ShadowKey, ShadowMode};
pub use sort::{visibility_order, SortMethod, VisibilityOrder};
pub use walk::{walk_frame, WalkMesh, WalkStats, WalkView};

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
    #[error("GIF encoding: {0}")]
    Gif(String),
    #[error(".npy: {why}: {path}")]
    Npy { why: String, path: PathBuf },
    #[error("{source}: {path}")]
    Io { source: std::io::Error, path: PathBuf },
    #[error("mesh and adjacency disagree: {why}")]
    InvalidMesh { why: String },
    #[error("the transfer function is normalized: map it onto the scalar range first (TransferFunction::denormalize)")]
    NormalizedTransferFunction,
    /// The mesh arrays cannot be rendered (what is wrong, with indices).
    #[error("scene: {0}")]
    Scene(String),
    /// `render` was called before something it needs was set.
    #[error("renderer not ready: {0}")]
    NotReady(&'static str),
}
