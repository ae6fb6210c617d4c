use thiserror::Error;

/// Why a point set could not be tetrahedralized.
#[derive(Debug, Error, Clone, PartialEq)]
pub enum DelaunayError {
    #[error("point {index} has a non-finite coordinate {coords:?}")]
    NonFinite { index: usize, coords: [f64; 3] },
    #[error(
        "point {index} has a coordinate beyond ±{limit:e} {coords:?}: the exact predicates' products would overflow"
    )]
    CoordinateTooLarge { index: usize, coords: [f64; 3], limit: f64 },
    #[error("{count} points is more than a tetrahedralization with 32-bit tet ids can index")]
    TooManyPoints { count: usize },
    #[error(
        "the {distinct} distinct points span only {dimension} dimension(s); a tetrahedralization needs 4 points not in one plane"
    )]
    Degenerate { distinct: usize, dimension: u8 },
    #[error("max_circumradius must be a positive number, got {0}")]
    BadCircumradius(f64),
    #[error("layered mode needs at least 2 layers, got {0}")]
    TooFewLayers(usize),
    #[error("layer {layer} has {found} points but layer 0 has {expected}; every layer needs one point per column")]
    LayerSizeMismatch { layer: usize, expected: usize, found: usize },
    #[error("layer 0 points {first} and {second} have the same x and y; columns must be distinct")]
    DuplicateColumn { first: usize, second: usize },
    #[error("the {columns} columns of layer 0 are collinear in xy; nothing to triangulate")]
    CollinearColumns { columns: usize },
    #[error("column {column}: z of layer {layer} ({z_upper}) is not above layer {below} ({z_lower}); layers must rise strictly", below = layer - 1)]
    LayersNotAscending { layer: usize, column: usize, z_lower: f64, z_upper: f64 },
    #[error(
        "layered mode: the points form {columns} xy columns holding {min} to {max} points each; every column needs the same number (one point per layer)"
    )]
    UnevenColumns { columns: usize, min: usize, max: usize },
    #[error("the point cloud is empty: there is nothing to tetrahedralize")]
    NoPoints,
    #[error("the xy triangulation rejected point {index}: {reason}")]
    Planar { index: usize, reason: String },
}
