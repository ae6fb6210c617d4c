//! Scalar analysis of a tetrahedral mesh: what transfer-function design,
//! shading, culling and table baking need to know about the data.
//!
//! - [`Analyzer`] — borrows a mesh and computes on request, caching what
//!   several results share (per-tet gradients, vertex–tet incidence,
//!   per-vertex gradients), so nothing is computed that was not asked for
//!   and nothing twice.
//! - [`GradientMethod`] — per-vertex gradients by least squares over the
//!   one-ring (default) or volume-weighted tet average ([`gradient`]).
//! - [`Histograms`] — exact volume-weighted 1D histogram of the scalar and
//!   joint histogram of scalar × per-tet |∇s| ([`histogram`] derives the
//!   per-tet distribution).
//! - [`CellRanges`], [`SegmentFacts`], [`FrequencyLimits`] — per-cell value
//!   ranges for conservative culling, the (Sf, Sb, l) domain of ray
//!   segments, and the frequency limit of banded transfer functions with the
//!   table resolution it implies ([`limits`] has the derivation).
//! - [`sample_cell_segments`] — random rays through random cells: the
//!   (Sf, Sb, l) distribution that table errors are measured over.
//! - [`Analysis`] — everything [`Analyzer::analyze`] returns in one value,
//!   what the bundle stores.
//!
//! ```
//! use tet_analysis::{AnalysisOptions, Analyzer, GradientMethod, HistogramOptions};
//! let points = vec![[0., 0., 0.], [1., 0., 0.], [0., 1., 0.], [0., 0., 1.]];
//! let tets = vec![[0, 1, 2, 3]];
//! let scalar: Vec<f64> = points.iter().map(|p| 2.0 * p[0] + p[2]).collect();
//! let an = Analyzer::new(&points, &tets, &scalar).unwrap();
//! // Least squares is exact for a linear field.
//! let g = an.vertex_gradients(GradientMethod::LeastSquares);
//! assert!((g[3][0] - 2.0).abs() < 1e-12 && (g[3][2] - 1.0).abs() < 1e-12);
//! let opts = AnalysisOptions { histogram: Some(HistogramOptions::default()), ..Default::default() };
//! let a = an.analyze(&opts).unwrap();
//! let h = a.histograms.unwrap();
//! // Exact up to the rounding of summing 256 bins.
//! assert!((h.scalar.iter().sum::<f64>() - 1.0 / 6.0).abs() < 1e-14);
//! assert_eq!(a.facts.max_cell_scalar_range, 2.0);
//! assert_eq!(a.limits.frequency_limit, Some(0.5));
//! ```

#![forbid(unsafe_code)]

pub mod gradient;
pub mod histogram;
pub mod limits;
pub mod segments;

pub use gradient::{tet_gradients, vertex_gradients, GradientMethod, TetGradients, VertexTets};
pub use histogram::{volume_fraction_below, Axis, HistogramOptions, Histograms, Scale};
pub use limits::{
    cell_ranges, frequency_limits, segment_facts, CellRanges, FrequencyLimits, Percentiles, SegmentFacts,
    TableResolution, DEFAULT_TABLE_TOLERANCE,
};
pub use segments::{sample_cell_segments, SampledSegment};

use std::cell::OnceCell;

/// Why an analysis could not run; indices refer to the mesh's arrays.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum AnalysisError {
    #[error("{scalars} scalar values for {points} points")]
    ScalarLength { scalars: usize, points: usize },
    #[error("tet {tet} refers to point {vertex}, but the mesh has {points} points")]
    TetIndex { tet: usize, vertex: u32, points: usize },
    #[error("the {what} of point {index} is not finite")]
    NonFinite { what: &'static str, index: usize },
    #[error("histogram axis [{lo}, {hi}] with {bins} bins is invalid: {why}")]
    BadAxis { lo: f64, hi: f64, bins: u32, why: String },
    #[error("table tolerance {0} must be in (0, 1)")]
    BadTolerance(f64),
}

/// Per-vertex gradients and how they were computed.
#[derive(Debug, Clone, PartialEq)]
pub struct VertexGradients {
    pub method: GradientMethod,
    /// ∇s per point, scalar units per world length.
    pub per_point: Vec<[f64; 3]>,
}

/// What to compute in [`Analyzer::analyze`]. Ranges, segment facts and
/// frequency limits are always computed (one cheap pass).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct AnalysisOptions {
    pub gradients: Option<GradientMethod>,
    pub histogram: Option<HistogramOptions>,
    /// Relative tolerance ε for [`TableResolution`].
    pub table_tolerance: f64,
}

impl Default for AnalysisOptions {
    fn default() -> Self {
        AnalysisOptions { gradients: None, histogram: None, table_tolerance: DEFAULT_TABLE_TOLERANCE }
    }
}

/// Everything one analysis produced.
#[derive(Debug, Clone, PartialEq)]
pub struct Analysis {
    pub gradients: Option<VertexGradients>,
    pub ranges: CellRanges,
    pub facts: SegmentFacts,
    pub limits: FrequencyLimits,
    pub histograms: Option<Histograms>,
}

/// A mesh under analysis; results are computed on first use and cached.
pub struct Analyzer<'a> {
    points: &'a [[f64; 3]],
    tets: &'a [[u32; 4]],
    scalar: &'a [f64],
    tet_gradients: OnceCell<TetGradients>,
    vertex_tets: OnceCell<VertexTets>,
    /// Indexed by method: 0 least squares, 1 tet average.
    vertex_gradients: [OnceCell<Vec<[f64; 3]>>; 2],
}

impl<'a> Analyzer<'a> {
    /// Checks the arrays (sizes, indices, finite values) and borrows them.
    pub fn new(points: &'a [[f64; 3]], tets: &'a [[u32; 4]], scalar: &'a [f64]) -> Result<Self, AnalysisError> {
        if scalar.len() != points.len() {
            return Err(AnalysisError::ScalarLength { scalars: scalar.len(), points: points.len() });
        }
        for (t, tet) in tets.iter().enumerate() {
            if let Some(&v) = tet.iter().find(|&&v| v as usize >= points.len()) {
                return Err(AnalysisError::TetIndex { tet: t, vertex: v, points: points.len() });
            }
        }
        if let Some(i) = scalar.iter().position(|s| !s.is_finite()) {
            return Err(AnalysisError::NonFinite { what: "scalar", index: i });
        }
        if let Some(i) = points.iter().position(|p| p.iter().any(|c| !c.is_finite())) {
            return Err(AnalysisError::NonFinite { what: "position", index: i });
        }
        Ok(Analyzer {
            points,
            tets,
            scalar,
            tet_gradients: OnceCell::new(),
            vertex_tets: OnceCell::new(),
            vertex_gradients: [OnceCell::new(), OnceCell::new()],
        })
    }

    /// An analyzer over a [`tet_mesh::TetMesh`] and its scalar.
    pub fn from_mesh(mesh: &'a tet_mesh::TetMesh) -> Result<Self, AnalysisError> {
        Analyzer::new(&mesh.points, &mesh.tets, &mesh.scalar)
    }

    /// Per-tet gradients and volumes (computed once).
    pub fn tet_gradients(&self) -> &TetGradients {
        self.tet_gradients.get_or_init(|| tet_gradients(self.points, self.tets, self.scalar))
    }

    /// The vertex–tet incidence (computed once).
    pub fn vertex_tets(&self) -> &VertexTets {
        self.vertex_tets.get_or_init(|| VertexTets::new(self.points.len(), self.tets))
    }

    /// Per-vertex gradients by `method` (computed once per method).
    pub fn vertex_gradients(&self, method: GradientMethod) -> &[[f64; 3]] {
        let slot = match method {
            GradientMethod::LeastSquares => 0,
            GradientMethod::TetAverage => 1,
        };
        self.vertex_gradients[slot].get_or_init(|| {
            vertex_gradients(self.points, self.tets, self.scalar, self.tet_gradients(), self.vertex_tets(), method)
        })
    }

    /// Volume-weighted 1D and joint histograms.
    pub fn histograms(&self, opts: &HistogramOptions) -> Result<Histograms, AnalysisError> {
        histogram::histograms(self.tets, self.scalar, self.tet_gradients(), opts)
    }

    /// Per-cell ranges; gradient-magnitude ranges only with a `method`.
    pub fn cell_ranges(&self, method: Option<GradientMethod>) -> CellRanges {
        cell_ranges(self.tets, self.scalar, method.map(|m| self.vertex_gradients(m)))
    }

    /// Ranges, segment facts and frequency limits, plus what `opts` asks for.
    pub fn analyze(&self, opts: &AnalysisOptions) -> Result<Analysis, AnalysisError> {
        if !(opts.table_tolerance > 0.0 && opts.table_tolerance < 1.0) {
            return Err(AnalysisError::BadTolerance(opts.table_tolerance));
        }
        let histograms = opts.histogram.as_ref().map(|h| self.histograms(h)).transpose()?;
        let ranges = self.cell_ranges(opts.gradients);
        let facts = segment_facts(self.points, self.tets, &ranges);
        let limits = frequency_limits(&facts, opts.table_tolerance);
        let gradients =
            opts.gradients.map(|m| VertexGradients { method: m, per_point: self.vertex_gradients(m).to_vec() });
        Ok(Analysis { gradients, ranges, facts, limits, histograms })
    }
}
