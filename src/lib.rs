//! tetkit as a library: the crates behind `tetprep`, `tetlut` and `tetview`,
//! re-exported under one name for examples and scripts.
//!
//! - [`mesh`] (`tet_mesh`): source meshes, splitting, validation, adjacency.
//! - [`io`] (`tet_io`): readers for VTK, PLOT3D, Gmsh, TetGen, raw/NRRD; VTU export.
//! - [`bundle`] (`tet_bundle`): the `.tetb` bundle file.
//! - [`preint`] (`tet_preint`): transfer functions, method ids, the exact
//!   integrator and the pre-integration tables (`make_shader`, `.tetl`).
//! - [`render`] (`tet_render`): the CPU renderer (camera, `Renderer`, images,
//!   the reference ray caster).
//! - [`engine`] (`tet_engine`): bundle + TF + method + view → frame, the
//!   path every front end shares (the one TF policy, looks, renderers).
//!
//! `examples/render_image.rs` runs the whole path in one program: read a
//! file, convert it to tets, bake a table for a transfer function, render
//! and write a PNG.
//!
//! ```
//! use tetkit::mesh::{tetrahedralize, ConvertOptions, SourceMesh, Block};
//! let mut points = Vec::new();
//! for k in 0..2 { for j in 0..2 { for i in 0..2 { points.push([i as f64, j as f64, k as f64]); } } }
//! let src = SourceMesh { points, blocks: vec![Block::Structured { dims: [2, 2, 2], first_point: 0 }], ..Default::default() };
//! let (mesh, report) = tetrahedralize(&src, &ConvertOptions::default(), &mut |_| {}).unwrap();
//! assert_eq!(mesh.tets.len(), 5);
//! assert_eq!(mesh.scalar_name, "zero"); // no field: constant zero, with a warning
//! assert!(!report.findings.is_empty());
//! ```
#![forbid(unsafe_code)]

pub use tet_bundle as bundle;
pub use tet_engine as engine;
pub use tet_io as io;
pub use tet_mesh as mesh;
pub use tet_preint as preint;
pub use tet_render as render;
