use thiserror::Error;

/// Why a source mesh could not become a valid tetrahedral mesh.
#[derive(Debug, Error, Clone, PartialEq)]
pub enum MeshError {
    #[error("the input is inconsistent: {0}")]
    BadSource(String),
    #[error(
        "no volume cells to convert (the input has {points} points and no tetrahedra, hexahedra, wedges or pyramids)"
    )]
    NoCells { points: usize },
    /// A later time step whose mesh is not the first step's.
    #[error("this time step's mesh is not the first step's: {what}")]
    StepMeshDiffers { what: String },
    /// A later time step with a non-finite scalar where the mesh needs one
    /// (`--nan drop` cannot drop cells of one step only).
    #[error("scalar '{name}' is {value} at {place} in this time step; the steps share one mesh, so no cells can be dropped for one step: leave the step out of the series")]
    NonFiniteInStep { name: String, place: String, value: f64 },
    #[error("no scalar named '{name}'; this file has: {available}")]
    UnknownScalar { name: String, available: String },
    #[error("scalar '{name}' is {value} at vertex {vertex} (source point index); pass --nan drop to drop the cells touching such vertices")]
    NonFiniteScalar { name: String, vertex: usize, value: f64 },
    #[error("scalar '{name}' is {value} in cell {cell} (source cell index); pass --nan drop to drop such cells")]
    NonFiniteCellScalar { name: String, cell: usize, value: f64 },
    #[error("point {point} (source index) has a non-finite coordinate {coords:?}; pass --nan drop to drop the cells touching it")]
    NonFinitePoint { point: usize, coords: [f64; 3] },
    #[error("face ({}, {}, {}) is shared by {} tets ({}), but a face can bound at most two; the mesh overlaps itself there", face[0], face[1], face[2], tets.len(), join(tets))]
    NonManifoldFace { face: [u32; 3], tets: Vec<u32> },
    /// A tet handed over as positively oriented by exact predicates (a
    /// Delaunay tetrahedralization's) that is not: a fault of the code that
    /// made it, found by the statistics pass's check.
    #[error("tet {tet} was handed over as positively oriented but is {orientation}; the tetrahedralization that made it is at fault (please report it)")]
    NotPositive { tet: usize, orientation: &'static str },
    #[error("every cell was dropped ({reason}); nothing is left to convert")]
    Empty { reason: String },
    #[error("the mesh has {count} {what}, more than the {limit} the bundle format can index")]
    TooLarge { what: &'static str, count: usize, limit: usize },
}

fn join(v: &[u32]) -> String {
    v.iter().map(|t| format!("tet {t}")).collect::<Vec<_>>().join(", ")
}
