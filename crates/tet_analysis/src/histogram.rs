//! Volume-weighted histograms of the scalar (1D) and of scalar × |∇s| (2D).
//!
//! # The distribution of a linear function over a tet
//!
//! Let s be linear on a tet with vertex values sorted s0 ≤ s1 ≤ s2 ≤ s3. The
//! fraction of the tet's volume where s ≤ t, F(t), is the cumulative
//! distribution of the push-forward of the uniform measure on the simplex
//! under s, whose density is the cubic B-spline with knots s0..s3 normalized
//! to unit integral (Curry & Schoenberg, "On Pólya frequency functions IV:
//! the fundamental spline functions and their limits", J. Analyse Math. 17,
//! 1966). So the density is piecewise quadratic and F piecewise cubic:
//!
//! - t ≤ s0: F = 0; t ≥ s3: F = 1;
//! - s0 ≤ t ≤ s1: F = a³ / ((s1−s0)(s2−s0)(s3−s0)) with a = t − s0
//!   (a small tet cut off the s0 corner, similar to the whole);
//! - s2 ≤ t ≤ s3: F = 1 − b³ / ((s3−s0)(s3−s1)(s3−s2)) with b = s3 − t;
//! - s1 ≤ t ≤ s2: F = F(s1) + ∫ M, with the density from the B-spline
//!   recurrence M(t) = 3/(s3−s0)·[(t−s0)(s2−t)/((s2−s0)(s2−s1)) +
//!   (s3−t)(t−s1)/((s3−s1)(s2−s1))] and F(s1) = (s1−s0)²/((s2−s0)(s3−s0)).
//!
//! Each piece is evaluated as products of ratios that lie in [0, 1] on that
//! piece ((t−s0)/(s1−s0) and so on), so coincident or nearly coincident
//! vertex values (the usual case: flat regions, constant fields) cost no
//! precision and never divide by zero; a tet with s0 = s3 puts all its volume
//! at that value. A bin (e_k, e_k+1] then receives V·(F(e_k+1) − F(e_k))
//! exactly, up to rounding, and the masses of one tet telescope to V.
//!
//! The 2D histogram uses the per-tet gradient magnitude, constant on each
//! tet, so each tet's scalar distribution lands in one |∇s| row.

use crate::gradient::TetGradients;
use crate::AnalysisError;
use rayon::prelude::*;
use serde::{Deserialize, Serialize};

/// How bin edges are spaced.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize, Default)]
pub enum Scale {
    #[default]
    Linear,
    /// Geometric spacing; needs lo > 0.
    Log,
}

/// One histogram axis: `bins` bins between `lo` and `hi`.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct Axis {
    pub lo: f64,
    pub hi: f64,
    pub bins: u32,
    pub scale: Scale,
}

/// Most bins per axis (a 4096² f64 joint histogram is 128 MiB).
pub const MAX_BINS: u32 = 4096;

impl Axis {
    pub fn new(lo: f64, hi: f64, bins: u32, scale: Scale) -> Result<Axis, AnalysisError> {
        let bad = |why: &str| AnalysisError::BadAxis { lo, hi, bins, why: why.to_string() };
        if bins == 0 || bins > MAX_BINS {
            return Err(bad(&format!("the bin count must be 1..={MAX_BINS}")));
        }
        if !(lo.is_finite() && hi.is_finite() && lo < hi) {
            return Err(bad("the range must be finite with lo < hi"));
        }
        if scale == Scale::Log && lo <= 0.0 {
            return Err(bad("a log axis needs lo > 0"));
        }
        Ok(Axis { lo, hi, bins, scale })
    }

    /// Edge k of the bins, k = 0..=bins; edge 0 is `lo` and edge `bins` is `hi` exactly.
    pub fn edge(&self, k: usize) -> f64 {
        let n = self.bins as usize;
        if k == 0 {
            return self.lo;
        }
        if k >= n {
            return self.hi;
        }
        let f = k as f64 / n as f64;
        match self.scale {
            Scale::Linear => self.lo + f * (self.hi - self.lo),
            Scale::Log => (self.lo.ln() + f * (self.hi.ln() - self.lo.ln())).exp(),
        }
    }

    /// Position of `v`: −1 below `lo`, `bins` above `hi`, else its bin
    /// (the first bin includes `lo`, every bin includes its upper edge up to
    /// rounding).
    pub fn position(&self, v: f64) -> i64 {
        let n = self.bins as i64;
        if v < self.lo {
            return -1;
        }
        if v > self.hi {
            return n;
        }
        let f = match self.scale {
            Scale::Linear => (v - self.lo) / (self.hi - self.lo),
            Scale::Log => (v.ln() - self.lo.ln()) / (self.hi.ln() - self.lo.ln()),
        };
        ((f * n as f64).floor() as i64).clamp(0, n - 1)
    }
}

/// Volume fraction of a tet with linear scalar and sorted vertex values `s`
/// (s[0] ≤ s[1] ≤ s[2] ≤ s[3]) where the scalar is ≤ `t`. See the module docs.
pub fn volume_fraction_below(s: &[f64; 4], t: f64) -> f64 {
    let [s0, s1, s2, s3] = *s;
    if t < s0 {
        return 0.0;
    }
    if t >= s3 {
        return 1.0;
    }
    // Here s0 ≤ t < s3, so s3 − s0 > 0.
    if t <= s1 {
        let a = t - s0;
        return (a / (s1 - s0)) * (a / (s2 - s0)) * (a / (s3 - s0));
    }
    if t >= s2 {
        let b = s3 - t;
        return 1.0 - (b / (s3 - s0)) * (b / (s3 - s1)) * (b / (s3 - s2));
    }
    // s1 < t < s2: every difference below is positive.
    let d0 = s1 - s0;
    let h = s2 - s1;
    let x = t - s1;
    let r = x / h;
    let f1 = (d0 / (s2 - s0)) * (d0 / (s3 - s0));
    // ∫₀ˣ (y + d0)(h − y)/h dy and ∫₀ˣ (e − y) y / h dy, e = s3 − s1.
    let i1 = x * (d0 * (1.0 - r / 2.0) + x * (0.5 - r / 3.0));
    let e = s3 - s1;
    let i2 = x * r * (e / 2.0 - x / 3.0);
    let f = f1 + 3.0 / (s3 - s0) * (i1 / (s2 - s0) + i2 / e);
    f.clamp(0.0, 1.0)
}

/// Options for [`histograms`]. Unset ranges default to the scalar's range
/// and to [0, the volume-weighted 99.9th percentile of per-tet |∇s|].
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct HistogramOptions {
    pub scalar_bins: u32,
    pub gradient_bins: u32,
    pub scalar_range: Option<(f64, f64)>,
    pub gradient_range: Option<(f64, f64)>,
    pub scalar_scale: Scale,
    pub gradient_scale: Scale,
}

impl Default for HistogramOptions {
    fn default() -> Self {
        HistogramOptions {
            scalar_bins: 256,
            gradient_bins: 256,
            scalar_range: None,
            gradient_range: None,
            scalar_scale: Scale::Linear,
            gradient_scale: Scale::Linear,
        }
    }
}

/// Fraction of the volume the default |∇s| axis covers: slivers and shocks
/// make the largest per-tet gradients orders of magnitude above the bulk, and
/// an axis up to them would squeeze everything else into the first bins.
pub const DEFAULT_GRADIENT_QUANTILE: f64 = 0.999;

/// Volume-weighted histograms (world length³ per bin).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Histograms {
    pub scalar_axis: Axis,
    pub gradient_axis: Axis,
    /// Volume per scalar bin.
    pub scalar: Vec<f64>,
    /// Volume below and above the scalar axis.
    pub scalar_below: f64,
    pub scalar_above: f64,
    /// Volume per (|∇s| bin, scalar bin), row-major by |∇s|:
    /// `joint[g * scalar_bins + s]`. |∇s| is the per-tet gradient magnitude.
    pub joint: Vec<f64>,
    /// Volume that falls outside the joint histogram (either axis).
    pub joint_outside: f64,
    /// Total volume of the tets.
    pub total_volume: f64,
}

impl Histograms {
    /// Options that histogram another mesh over these axes (bins, ranges,
    /// scales): a re-analysis keeping a bundle's axes, or a partition's
    /// pieces, whose histograms then add up to the whole's.
    pub fn same_axes(&self) -> HistogramOptions {
        let (s, g) = (&self.scalar_axis, &self.gradient_axis);
        HistogramOptions {
            scalar_bins: s.bins,
            gradient_bins: g.bins,
            scalar_range: Some((s.lo, s.hi)),
            gradient_range: Some((g.lo, g.hi)),
            scalar_scale: s.scale,
            gradient_scale: g.scale,
        }
    }

    /// Checks that the arrays match the axes (for data read from a file).
    pub fn check(&self) -> Result<(), String> {
        for a in [&self.scalar_axis, &self.gradient_axis] {
            Axis::new(a.lo, a.hi, a.bins, a.scale).map_err(|e| e.to_string())?;
        }
        let (ns, ng) = (self.scalar_axis.bins as usize, self.gradient_axis.bins as usize);
        if self.scalar.len() != ns || self.joint.len() != ns * ng {
            return Err(format!(
                "histogram arrays of {} and {} values do not match {ns} × {ng} bins",
                self.scalar.len(),
                self.joint.len()
            ));
        }
        Ok(())
    }
}

/// Spreads `vol` over the scalar bins of `axis` by the exact distribution of
/// the sorted vertex values `s`: `add(bin, volume)`, bin −1 / `bins` for the
/// parts below / above the axis.
#[inline]
fn spread(axis: &Axis, s: &[f64; 4], vol: f64, mut add: impl FnMut(i64, f64)) {
    let p0 = axis.position(s[0]);
    let p3 = axis.position(s[3]);
    if p0 == p3 {
        add(p0, vol);
        return;
    }
    // Conceptual bins p0..=p3; the boundary between bins k and k+1 is edge k+1.
    let mut prev = 0.0;
    for k in p0..p3 {
        let f = volume_fraction_below(s, axis.edge((k + 1) as usize)).max(prev);
        add(k, vol * (f - prev));
        prev = f;
    }
    add(p3, vol * (1.0 - prev));
}

/// Builds the 1D and joint histograms from the per-tet gradients.
pub fn histograms(
    tets: &[[u32; 4]],
    scalar: &[f64],
    tg: &TetGradients,
    opts: &HistogramOptions,
) -> Result<Histograms, AnalysisError> {
    let (smin, smax) = scalar.iter().fold((f64::INFINITY, f64::NEG_INFINITY), |(a, b), &v| (a.min(v), b.max(v)));
    let scalar_range = match opts.scalar_range {
        Some(r) => r,
        None if smin < smax => (smin, smax),
        // A constant field: a unit-wide axis centred on the value.
        None => (smin - 0.5, smin + 0.5),
    };
    let gradient_range = match opts.gradient_range {
        Some(r) => r,
        None => {
            let hi = gradient_quantile(tg, DEFAULT_GRADIENT_QUANTILE);
            let lo = if opts.gradient_scale == Scale::Log { hi * 1e-4 } else { 0.0 };
            (lo, if hi > 0.0 { hi } else { 1.0 })
        }
    };
    let sa = Axis::new(scalar_range.0, scalar_range.1, opts.scalar_bins, opts.scalar_scale)?;
    let ga = Axis::new(gradient_range.0, gradient_range.1, opts.gradient_bins, opts.gradient_scale)?;
    let (ns, ng) = (sa.bins as usize, ga.bins as usize);
    // Layout of the accumulator: [below, scalar bins.., above, joint.., joint_outside, total].
    let len = ns + 2 + ns * ng + 2;
    let chunk = tets.len().div_ceil(rayon::current_num_threads() * 2).max(1 << 13);
    let acc = tets
        .par_iter()
        .enumerate()
        .with_min_len(chunk)
        .fold(
            || vec![0.0f64; len],
            |mut acc, (t, tet)| {
                let vol = tg.volume(t);
                if vol <= 0.0 {
                    return acc;
                }
                let mut s = tet.map(|v| scalar[v as usize]);
                s.sort_unstable_by(f64::total_cmp);
                spread(&sa, &s, vol, |k, m| acc[(k + 1) as usize] += m);
                let row = ga.position(tg.magnitude(t));
                if row < 0 || row >= ng as i64 {
                    acc[len - 2] += vol;
                } else {
                    let base = ns + 2 + row as usize * ns;
                    spread(&sa, &s, vol, |k, m| {
                        if k < 0 || k >= ns as i64 {
                            acc[len - 2] += m;
                        } else {
                            acc[base + k as usize] += m;
                        }
                    });
                }
                acc[len - 1] += vol;
                acc
            },
        )
        .reduce(
            || vec![0.0f64; len],
            |mut a, b| {
                a.iter_mut().zip(&b).for_each(|(x, y)| *x += y);
                a
            },
        );
    Ok(Histograms {
        scalar_axis: sa,
        gradient_axis: ga,
        scalar: acc[1..=ns].to_vec(),
        scalar_below: acc[0],
        scalar_above: acc[ns + 1],
        joint: acc[ns + 2..ns + 2 + ns * ng].to_vec(),
        joint_outside: acc[len - 2],
        total_volume: acc[len - 1],
    })
}

/// The smallest |∇s| below which a fraction `q` of the volume lies (per-tet
/// gradients, exact by sorting).
pub fn gradient_quantile(tg: &TetGradients, q: f64) -> f64 {
    let mut v: Vec<(f64, f64)> =
        (0..tg.gradient.len()).map(|t| (tg.magnitude(t), tg.volume(t))).filter(|p| p.1 > 0.0).collect();
    if v.is_empty() {
        return 0.0;
    }
    v.par_sort_unstable_by(|a, b| a.0.total_cmp(&b.0));
    let total: f64 = v.iter().map(|p| p.1).sum();
    let target = q * total;
    let mut acc = 0.0;
    for &(g, w) in &v {
        acc += w;
        if acc >= target {
            return g;
        }
    }
    v.last().map(|p| p.0).unwrap_or(0.0)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn cdf_pieces_meet_and_span_zero_to_one() {
        let s = [0.0, 1.0, 3.0, 4.0];
        assert_eq!(volume_fraction_below(&s, -1.0), 0.0);
        assert_eq!(volume_fraction_below(&s, 4.0), 1.0);
        for t in [1.0, 3.0] {
            let below = volume_fraction_below(&s, t - 1e-12);
            let above = volume_fraction_below(&s, t + 1e-12);
            assert!((below - above).abs() < 1e-10, "jump at {t}: {below} {above}");
        }
        // Symmetric values: half the volume below the midpoint.
        assert!((volume_fraction_below(&s, 2.0) - 0.5).abs() < 1e-15);
        // Coincident values: no division by zero.
        assert_eq!(volume_fraction_below(&[1.0, 1.0, 1.0, 1.0], 1.0), 1.0);
        assert_eq!(volume_fraction_below(&[1.0, 1.0, 1.0, 1.0], 0.5), 0.0);
        let f = volume_fraction_below(&[0.0, 0.0, 0.0, 1.0], 0.5);
        assert!((f - (1.0 - 0.125)).abs() < 1e-15);
        let f = volume_fraction_below(&[0.0, 1.0, 1.0, 1.0], 0.5);
        assert!((f - 0.125).abs() < 1e-15);
    }

    #[test]
    fn axis_positions_and_edges() {
        let a = Axis::new(0.0, 1.0, 4, Scale::Linear).unwrap();
        assert_eq!((a.position(-0.1), a.position(0.0), a.position(1.0), a.position(1.1)), (-1, 0, 3, 4));
        assert_eq!(a.edge(2), 0.5);
        let l = Axis::new(1.0, 1000.0, 3, Scale::Log).unwrap();
        assert!((l.edge(1) - 10.0).abs() < 1e-12 && (l.edge(2) - 100.0).abs() < 1e-10);
        assert_eq!(l.position(50.0), 1);
        assert!(Axis::new(0.0, 1.0, 0, Scale::Linear).is_err());
        assert!(Axis::new(0.0, 1.0, 4, Scale::Log).is_err());
        assert!(Axis::new(1.0, 1.0, 4, Scale::Linear).is_err());
    }
}
