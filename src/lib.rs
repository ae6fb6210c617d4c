//! tetkit as a library: the crates behind `tetprep`, `tetlut` and `tetview`,
//! re-exported under one name for examples and scripts.
//!
//! - [`mesh`] (`tet_mesh`): source meshes, splitting, validation, adjacency.
//! - [`io`] (`tet_io`): readers for VTK, PLOT3D, Gmsh, TetGen, raw/NRRD; VTU export.
//! - [`bundle`] (`tet_bundle`): the `.tetb` bundle file.
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
pub use tet_io as io;
pub use tet_mesh as mesh;
