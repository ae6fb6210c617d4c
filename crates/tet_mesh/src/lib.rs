//! Tetrahedral mesh core: everything between "a reader parsed a file" and
//! "a validated tet mesh with adjacency".
//!
//! - [`SourceMesh`] — what readers produce: mixed cells, structured blocks, fields.
//! - [`tetrahedralize`] — splits cells into conforming tets ([`SplitMode`]),
//!   selects the scalar, merges duplicates, orients, drops degenerate cells
//!   and returns a [`TetMesh`] with a [`ConversionReport`] of typed [`Finding`]s.
//! - [`build_adjacency`] — face neighbours, boundary faces and convexity
//!   ([`Adjacency`]), what MPVO sorting needs.
//! - [`mesh_stats`] — bounds, volumes, edge lengths, max cell diameter.
//! - [`predicates`] — exact orientation tests every geometric decision uses.
//! - [`polyhedron`] — polyhedral cells as conforming tets around added centre points
//!   ([`PolyhedronSplitter`]), for the readers that meet them.
//! - [`lagrange`] — higher-order cells of any order (VTK's Lagrange cells,
//!   Gmsh's complete ones): where their nodes lie and their split at them.
//! - [`bezier`] — VTK's Bézier volume cells (polynomial or rational) evaluated
//!   at their lattice into Lagrange cells ([`BezierEvaluator`]).
//! - [`SharedArray`] — how a [`TetMesh`] holds its tets and an [`Adjacency`]
//!   its neighbours: owned, or shared with a bundle file mapped into memory.
//!
//! ```
//! use tet_mesh::{tetrahedralize, build_adjacency, Block, ConvertOptions, Field, SourceMesh, SplitMode};
//! // One unit cube as a 2×2×2 structured block with a linear scalar.
//! let mut points = Vec::new();
//! for k in 0..2 { for j in 0..2 { for i in 0..2 { points.push([i as f64, j as f64, k as f64]); } } }
//! let scalar = points.iter().map(|p| p[0] + p[1] + p[2]).collect();
//! let source = SourceMesh {
//!     points,
//!     blocks: vec![Block::Structured { dims: [2, 2, 2], first_point: 0 }],
//!     point_fields: vec![Field::new("s", 1, scalar)],
//!     ..Default::default()
//! };
//! let opts = ConvertOptions { split: SplitMode::Five, ..Default::default() };
//! let (mesh, _report) = tetrahedralize(&source, &opts, &mut |_| {}).unwrap();
//! assert_eq!(mesh.tets.len(), 5);
//! let adj = build_adjacency(&mesh.points, &mesh.tets).unwrap();
//! assert_eq!(adj.boundary_faces.len(), 12);
//! assert!(adj.convex);
//! ```
#![forbid(unsafe_code)]

pub mod adjacency;
pub mod bezier;
pub mod convert;
mod error;
pub mod lagrange;
pub mod merge;
pub mod polyhedron;
pub mod predicates;
pub mod rng;
pub mod scalar;
pub mod series;
pub mod shared;
pub mod source;
pub mod split;
pub mod stats;

pub use adjacency::{
    adjacency_from_neighbors, build_adjacency, check_adjacency, check_neighbors, Adjacency, FACE_OUTWARD, NO_NEIGHBOR,
};
pub use bezier::{BezierEvaluator, BezierReport};
pub use convert::{
    check_tet_mesh, tetrahedralize, tetrahedralize_merged, tetrahedralize_tets, ConversionReport, ConvertOptions,
    Finding, GivenOrientation, NanPolicy, Step, TetMesh,
};
pub use error::MeshError;
pub use polyhedron::PolyhedronSplitter;
pub use rng::{SplitMix64, XorShift64};
pub use series::StepMapper;
pub use shared::SharedArray;
pub use source::{Block, CellType, Cells, Field, SourceMesh};
pub use split::SplitMode;
pub use stats::{mesh_stats, mesh_stats_confirming_orientation, MeshStats, Spread};
