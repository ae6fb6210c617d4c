//! Per-cell value ranges, the segment domain they imply, and the frequency
//! limits of banded transfer functions (Song et al. 2009, §6.3).
//!
//! # Segment domain
//!
//! The scalar is linear on a tet, so along any ray segment inside tet c the
//! scalar runs monotonically between two values in [min_c, max_c]: the
//! front/back pair (Sf, Sb) satisfies |Sf − Sb| ≤ R_c = max_c − min_c, and the
//! segment length satisfies l ≤ the tet's diameter, its longest edge (a
//! convex hull's diameter is attained at two of its vertices). A ray passing
//! close to the edge between the extreme vertices attains R_c, so the bounds
//! are tight. Pre-integration tables need only cover |Sf − Sb| ≤ max_c R_c
//! and l ≤ l_max = max_c diameter.
//!
//! # Frequency limit
//!
//! A banded (triangle-wave or sine-wave) transfer function with frequency f
//! (cycles per scalar unit) has peaks spaced P = 1/f apart in s. A closed
//! scalar interval of length L holds at most one peak for every phase of the
//! bands exactly when L < P (for L ≥ P some phase puts two peaks in it). A
//! ray segment in cell c covers an interval of length at most R_c, reached
//! near the extreme edge, so no ray holds more than one peak in any cell
//! when f < 1 / max_c R_c: that is `frequency_limit`. `frequency_limit_99`
//! is 1 / R_99 with R_99 the nearest-rank 99th percentile of the R_c: at
//! frequencies below it at most 1% of cells can hold two peaks on some ray.
//! The same argument with the per-vertex |∇s| (which renderers interpolate
//! linearly along the ray) gives the limits for bands in |∇s|.
//!
//! # Table resolution
//!
//! The finest band a user can see on this mesh without more than 1% of the
//! cells aliasing it has period P = R_99. A pre-integration table over
//! (Sf, Sb) with spacing h reproduces, on its diagonal Sf = Sb (thin
//! segments, silhouettes), the transfer function linearly interpolated at
//! spacing h. For a sine band of amplitude A the interpolation error is at
//! most A·(2π/P)²·h²/8, so a relative tolerance ε needs
//! h ≤ P·√(8ε)/(2π); for a triangle band the worst case is a peak midway
//! between samples, cut by A·h/P, so h ≤ ε·P. The table then needs
//! ⌈(s_max − s_min)/h⌉ + 1 samples per axis ([`TableResolution`]).

use crate::gradient::norm;
use rayon::prelude::*;
use serde::{Deserialize, Serialize};

/// Per-tet (min, max) of the scalar and, when per-vertex gradients exist,
/// of their magnitudes over the tet's four vertices: conservative bounds for
/// culling a cell against a transfer function.
#[derive(Debug, Clone, PartialEq, Default)]
pub struct CellRanges {
    pub scalar: Vec<[f64; 2]>,
    pub gradient_magnitude: Option<Vec<[f64; 2]>>,
}

fn min_max(v: [f64; 4]) -> [f64; 2] {
    [v.iter().copied().fold(f64::INFINITY, f64::min), v.iter().copied().fold(f64::NEG_INFINITY, f64::max)]
}

/// Per-tet ranges of the scalar and (if given) of |per-vertex gradient|.
pub fn cell_ranges(tets: &[[u32; 4]], scalar: &[f64], vertex_gradients: Option<&[[f64; 3]]>) -> CellRanges {
    let scalar_r = tets.par_iter().with_min_len(8192).map(|t| min_max(t.map(|v| scalar[v as usize]))).collect();
    let grad = vertex_gradients.map(|g| {
        let mag: Vec<f64> = g.par_iter().with_min_len(8192).map(norm).collect();
        tets.par_iter().with_min_len(8192).map(|t| min_max(t.map(|v| mag[v as usize]))).collect()
    });
    CellRanges { scalar: scalar_r, gradient_magnitude: grad }
}

/// Nearest-rank percentiles of a per-cell quantity.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize, Default)]
pub struct Percentiles {
    pub p50: f64,
    pub p90: f64,
    pub p99: f64,
    pub p999: f64,
    pub max: f64,
}

impl Percentiles {
    /// Nearest-rank percentiles (the value at rank ⌈q·n⌉) of `values`, which
    /// is reordered.
    pub fn of(values: &mut [f64]) -> Percentiles {
        let n = values.len();
        if n == 0 {
            return Percentiles::default();
        }
        let mut at = |q: f64| {
            let rank = ((q * n as f64).ceil() as usize).clamp(1, n) - 1;
            *values.select_nth_unstable_by(rank, f64::total_cmp).1
        };
        Percentiles { p50: at(0.5), p90: at(0.9), p99: at(0.99), p999: at(0.999), max: at(1.0) }
    }
}

/// What the bundle's ray segments can look like: the (Sf, Sb, l) domain.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize, Default)]
pub struct SegmentFacts {
    /// max over tets of (max − min of the scalar at its vertices) ≥ |Sf − Sb|.
    pub max_cell_scalar_range: f64,
    /// l_max: the longest tet edge (world units) ≥ any segment length l.
    pub max_cell_diameter: f64,
    /// Distribution of the per-tet scalar ranges.
    pub cell_scalar_range: Percentiles,
    /// Distribution of the per-tet ranges of |per-vertex ∇s|, if computed.
    pub cell_gradient_range: Option<Percentiles>,
    /// The scalar's range over the mesh.
    pub scalar_min: f64,
    pub scalar_max: f64,
}

/// Samples per axis a pre-integration table needs to resolve the finest
/// band (see the module docs).
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct TableResolution {
    /// Relative interpolation tolerance ε on the transfer function.
    pub tolerance: f64,
    /// Period of the finest band, scalar units (= 1 / `frequency_limit_99`).
    pub period: f64,
    /// Samples per Sf/Sb axis over [scalar_min, scalar_max] for a sine band.
    pub samples_sine: u64,
    /// The same for a triangle band (its corners need finer sampling).
    pub samples_triangle: u64,
}

/// Frequency limits of banded transfer functions, cycles per scalar unit
/// (per |∇s| unit for the gradient ones). `None` where the per-cell ranges
/// are all zero: any frequency is safe.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize, Default)]
pub struct FrequencyLimits {
    /// 1 / max per-cell scalar range: no cell holds two peaks on any ray.
    pub frequency_limit: Option<f64>,
    /// 1 / 99th percentile of per-cell scalar ranges.
    pub frequency_limit_99: Option<f64>,
    pub gradient_frequency_limit: Option<f64>,
    pub gradient_frequency_limit_99: Option<f64>,
    /// Table samples that resolve the band at `frequency_limit_99`.
    pub table: Option<TableResolution>,
}

/// Default ε for [`TableResolution`]: 1% of the band's peak value.
pub const DEFAULT_TABLE_TOLERANCE: f64 = 0.01;

/// Largest table resolution reported; beyond it the count is clamped (a
/// mesh with near-zero cell ranges would otherwise ask for absurd tables).
pub const MAX_TABLE_SAMPLES: u64 = 1 << 24;

fn inverse(x: f64) -> Option<f64> {
    (x > 0.0 && x.is_finite()).then(|| 1.0 / x)
}

/// Segment facts from the per-cell ranges and the mesh geometry.
pub fn segment_facts(points: &[[f64; 3]], tets: &[[u32; 4]], ranges: &CellRanges) -> SegmentFacts {
    let mut r: Vec<f64> = ranges.scalar.par_iter().map(|m| m[1] - m[0]).collect();
    let cell_scalar_range = Percentiles::of(&mut r);
    let cell_gradient_range = ranges.gradient_magnitude.as_ref().map(|g| {
        let mut r: Vec<f64> = g.par_iter().map(|m| m[1] - m[0]).collect();
        Percentiles::of(&mut r)
    });
    let max_cell_diameter = tets
        .par_iter()
        .with_min_len(8192)
        .map(|t| {
            let p = t.map(|v| &points[v as usize]);
            let mut d2 = 0.0f64;
            for (a, b) in [(0, 1), (0, 2), (0, 3), (1, 2), (1, 3), (2, 3)] {
                d2 = d2.max(crate::gradient::sub(p[a], p[b]).iter().map(|x| x * x).sum());
            }
            d2
        })
        .reduce(|| 0.0, f64::max)
        .sqrt();
    let (scalar_min, scalar_max) =
        ranges.scalar.iter().fold((f64::INFINITY, f64::NEG_INFINITY), |(a, b), m| (a.min(m[0]), b.max(m[1])));
    SegmentFacts {
        max_cell_scalar_range: cell_scalar_range.max,
        max_cell_diameter,
        cell_scalar_range,
        cell_gradient_range,
        scalar_min: if tets.is_empty() { 0.0 } else { scalar_min },
        scalar_max: if tets.is_empty() { 0.0 } else { scalar_max },
    }
}

/// Frequency limits and the table resolution at tolerance `epsilon`.
pub fn frequency_limits(facts: &SegmentFacts, epsilon: f64) -> FrequencyLimits {
    let f99 = inverse(facts.cell_scalar_range.p99);
    let table = f99.map(|f| {
        let period = 1.0 / f;
        let span = facts.scalar_max - facts.scalar_min;
        let samples = |h: f64| ((span / h).ceil() as u64).saturating_add(1).min(MAX_TABLE_SAMPLES);
        TableResolution {
            tolerance: epsilon,
            period,
            samples_sine: samples(period * (8.0 * epsilon).sqrt() / (2.0 * std::f64::consts::PI)),
            samples_triangle: samples(epsilon * period),
        }
    });
    FrequencyLimits {
        frequency_limit: inverse(facts.max_cell_scalar_range),
        frequency_limit_99: f99,
        gradient_frequency_limit: facts.cell_gradient_range.and_then(|p| inverse(p.max)),
        gradient_frequency_limit_99: facts.cell_gradient_range.and_then(|p| inverse(p.p99)),
        table,
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn nearest_rank_percentiles() {
        let mut v: Vec<f64> = (1..=1000).rev().map(|i| i as f64).collect();
        let p = Percentiles::of(&mut v);
        assert_eq!((p.p50, p.p90, p.p99, p.p999, p.max), (500.0, 900.0, 990.0, 999.0, 1000.0));
    }

    #[test]
    fn limits_of_one_tet() {
        let pts = [[0., 0., 0.], [2., 0., 0.], [0., 1., 0.], [0., 0., 1.]];
        let ranges = cell_ranges(&[[0, 1, 2, 3]], &[0.0, 4.0, 1.0, 1.0], None);
        let f = segment_facts(&pts, &[[0, 1, 2, 3]], &ranges);
        assert_eq!(f.max_cell_scalar_range, 4.0);
        assert!((f.max_cell_diameter - 5f64.sqrt()).abs() < 1e-15);
        let l = frequency_limits(&f, 0.01);
        assert_eq!(l.frequency_limit, Some(0.25));
        let t = l.table.unwrap();
        assert_eq!(t.samples_triangle, 101);
        let constant = cell_ranges(&[[0, 1, 2, 3]], &[1.0; 4], None);
        let l = frequency_limits(&segment_facts(&pts, &[[0, 1, 2, 3]], &constant), 0.01);
        assert_eq!((l.frequency_limit, l.table), (None, None));
    }
}
