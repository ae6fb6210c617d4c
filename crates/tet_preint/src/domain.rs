//! The (Sf, Sb, l) domain a table is baked over, and the errors of building
//! tables.
//!
//! A bundle can only produce segments with Sf, Sb in its scalar range,
//! |Sf − Sb| ≤ the largest per-cell scalar range and l ≤ the largest cell
//! diameter (see `tet_analysis::limits`). Tables are baked over the band
//! |Sf − Sb| ≤ `max_ds` around the diagonal and l ∈ [0, `len_max_world`];
//! lookups outside are clamped into it.

use serde::{Deserialize, Serialize};

/// A table parameter or domain that cannot be used.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum TableError {
    #[error("table domain: {what}")]
    Domain { what: String },
    #[error("{what} = {value}: must be between {min} and {max}")]
    Resolution { what: &'static str, value: u64, min: u64, max: u64 },
    #[error("table of {entries} entries is larger than the {max} this build allows")]
    TooLarge { entries: u64, max: u64 },
    #[error("{0}")]
    Invalid(String),
}

/// Largest number of RGBA entries one table may hold (2^28 ≈ 4 GiB of f32).
pub const MAX_TABLE_ENTRIES: u64 = 1 << 28;

/// Scalar range, largest |Sf − Sb| and largest segment length a table covers.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct TableDomain {
    /// Lowest scalar on the Sf/Sb axes (data units).
    pub s_lo: f64,
    /// Highest scalar on the Sf/Sb axes; `s_hi > s_lo`.
    pub s_hi: f64,
    /// Largest |Sf − Sb| baked (≥ 0; values above `s_hi − s_lo` mean the full square).
    pub max_ds: f64,
    /// Largest segment length baked, world units (> 0).
    pub len_max_world: f64,
    /// Where the data's scalars lie ([`ScalarQuantiles`]), when the domain
    /// came from a bundle: what [`crate::ScalarAxis::Data`] places its
    /// samples by. Not stored in `.tetl` headers (the axis's knots are).
    #[serde(skip)]
    pub s_quantiles: Option<ScalarQuantiles>,
}

/// Probabilities of [`ScalarQuantiles`]: 0, 1/QUANTILES, …, 1.
pub const QUANTILES: usize = 32;

/// The scalar at probabilities k / [`QUANTILES`] of a bundle's per-vertex
/// scalars (k = 0..=QUANTILES; non-decreasing, first = min, last = max):
/// a summary small enough to keep [`TableDomain`] `Copy`.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ScalarQuantiles(pub [f64; QUANTILES + 1]);

/// A constant scalar's range widened by a relative 1e-6, so tables have a
/// span.
fn widen_constant(mut lo: f64, mut hi: f64) -> (f64, f64) {
    if lo.is_finite() && hi.is_finite() && lo >= hi {
        let pad = 1e-6 * lo.abs().max(1.0);
        lo -= pad;
        hi += pad;
    }
    (lo, hi)
}

impl ScalarQuantiles {
    /// Quantiles of the finite values of `scalars`; `None` when there are none.
    pub fn of(scalars: &[f64]) -> Option<ScalarQuantiles> {
        let mut v: Vec<f64> = scalars.iter().copied().filter(|x| x.is_finite()).collect();
        if v.is_empty() {
            return None;
        }
        v.sort_unstable_by(f64::total_cmp);
        let n = v.len() - 1;
        let mut q = [0.0; QUANTILES + 1];
        for (k, qk) in q.iter_mut().enumerate() {
            *qk = v[(k * n + QUANTILES / 2) / QUANTILES];
        }
        Some(ScalarQuantiles(q))
    }

    /// The data's cumulative share at `s`, piecewise linear through the
    /// quantiles (a run of equal quantiles is a step).
    pub fn cdf(&self, s: f64) -> f64 {
        let q = &self.0;
        if s <= q[0] {
            return 0.0;
        }
        if s >= q[QUANTILES] {
            return 1.0;
        }
        let k = q.partition_point(|&x| x <= s) - 1;
        let (a, b) = (q[k], q[k + 1]);
        (k as f64 + if b > a { (s - a) / (b - a) } else { 0.0 }) / QUANTILES as f64
    }
}

impl TableDomain {
    /// A checked domain: finite numbers, `s_lo < s_hi`, `max_ds ≥ 0`,
    /// `len_max_world > 0`. `max_ds` is capped at `s_hi − s_lo`.
    pub fn new(s_lo: f64, s_hi: f64, max_ds: f64, len_max_world: f64) -> Result<Self, TableError> {
        let bad = |what: String| Err(TableError::Domain { what });
        if !(s_lo.is_finite() && s_hi.is_finite() && s_lo < s_hi) {
            return bad(format!("scalar range [{s_lo}, {s_hi}] needs finite lo < hi"));
        }
        if max_ds.is_nan() || max_ds < 0.0 {
            return bad(format!("max |Sf − Sb| = {max_ds} must be ≥ 0"));
        }
        if !(len_max_world > 0.0 && len_max_world.is_finite()) {
            return bad(format!("largest segment length {len_max_world} must be positive and finite"));
        }
        Ok(TableDomain { s_lo, s_hi, max_ds: max_ds.min(s_hi - s_lo), len_max_world, s_quantiles: None })
    }

    /// The whole square [s_lo, s_hi]² × [0, len_max_world] (no band).
    pub fn full(s_lo: f64, s_hi: f64, len_max_world: f64) -> Result<Self, TableError> {
        Self::new(s_lo, s_hi, f64::INFINITY, len_max_world)
    }

    /// The domain a bundle's segments can reach: its scalar range, the largest
    /// per-cell scalar range (from `CELLRANGE`'s facts when the bundle was
    /// analysed, else computed from the tets) and the largest cell diameter.
    /// A constant field gets a tiny non-empty range around its value.
    pub fn from_bundle(bundle: &tet_bundle::Bundle) -> Result<Self, TableError> {
        let stats = &bundle.meta.stats;
        let max_cell_range = |s: &[f64]| {
            bundle
                .mesh
                .tets
                .iter()
                .map(|t| {
                    let v = t.map(|i| s.get(i as usize).copied().unwrap_or(0.0));
                    let (mn, mx) = v.iter().fold((f64::INFINITY, f64::NEG_INFINITY), |(a, b), &x| (a.min(x), b.max(x)));
                    mx - mn
                })
                .fold(0.0, f64::max)
        };
        if let Some(steps) = &bundle.steps {
            // A time series: one domain for every time, so one table draws
            // them all. Between steps k and k+1 the scalar is a convex
            // combination of theirs, so its range is inside the steps' and
            // a cell's range is at most the larger of its two steps'.
            let (lo, hi) = steps.scalar_range();
            let max_ds = (0..steps.len()).map(|k| max_cell_range(steps.scalar(k))).fold(0.0, f64::max);
            let (lo, hi) = widen_constant(lo, hi);
            let mut d = Self::new(lo, hi, max_ds, stats.max_cell_diameter)?;
            // The data's distribution over every step (at most ~4M values).
            let total: usize = (0..steps.len()).map(|k| steps.scalar(k).len()).sum();
            let stride = total.div_ceil(1 << 22).max(1);
            let all: Vec<f64> =
                (0..steps.len()).flat_map(|k| steps.scalar(k).iter().copied()).step_by(stride).collect();
            d.s_quantiles = ScalarQuantiles::of(&all);
            return Ok(d);
        }
        let (lo, hi, max_ds, len) = match &bundle.analysis {
            Some(a) => {
                (a.facts.scalar_min, a.facts.scalar_max, a.facts.max_cell_scalar_range, a.facts.max_cell_diameter)
            }
            None => (stats.scalar_min, stats.scalar_max, max_cell_range(&bundle.mesh.scalar), stats.max_cell_diameter),
        };
        let (lo, hi) = widen_constant(lo, hi);
        let mut d = Self::new(lo, hi, max_ds, len)?;
        d.s_quantiles = ScalarQuantiles::of(&bundle.mesh.scalar);
        Ok(d)
    }

    /// s_hi − s_lo.
    pub fn scalar_span(&self) -> f64 {
        self.s_hi - self.s_lo
    }

    /// Whether the band covers the whole square.
    pub fn is_full(&self) -> bool {
        self.max_ds >= self.scalar_span()
    }
}

/// Checks `value ∈ [min, max]` for a resolution parameter.
pub(crate) fn check_res(what: &'static str, value: usize, min: usize, max: usize) -> Result<(), TableError> {
    if value < min || value > max {
        return Err(TableError::Resolution { what, value: value as u64, min: min as u64, max: max as u64 });
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn rejects_bad_domains() {
        assert!(TableDomain::new(1.0, 1.0, 0.1, 1.0).is_err());
        assert!(TableDomain::new(0.0, 1.0, -0.1, 1.0).is_err());
        assert!(TableDomain::new(0.0, 1.0, f64::NAN, 1.0).is_err());
        assert!(TableDomain::new(0.0, 1.0, 0.1, 0.0).is_err());
        assert!(TableDomain::new(0.0, f64::INFINITY, 0.1, 1.0).is_err());
        let d = TableDomain::new(0.0, 2.0, 5.0, 1.0).unwrap();
        assert_eq!(d.max_ds, 2.0);
        assert!(d.is_full());
    }

    #[test]
    fn quantiles_and_cdf() {
        let v: Vec<f64> = (0..=320).map(|i| (i as f64 / 320.0).powi(3)).collect();
        let q = ScalarQuantiles::of(&v).unwrap();
        assert_eq!(q.0[0], 0.0);
        assert_eq!(q.0[QUANTILES], 1.0);
        assert!((q.0[16] - 0.125).abs() < 1e-12);
        assert!((q.cdf(0.125) - 0.5).abs() < 1e-12);
        assert_eq!(q.cdf(-1.0), 0.0);
        assert_eq!(q.cdf(2.0), 1.0);
        assert!(ScalarQuantiles::of(&[f64::NAN]).is_none());
    }
}
