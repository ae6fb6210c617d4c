//! Which (Sf, Sb) pairs a `Table3d` stores (`Band`: rows and their offsets)
//! and where a lookup falls among them (`Table3d::band_coords`).

use super::axis::Axis;
use super::Table3d;
use crate::domain::TableDomain;
use crate::simd::{no_nan, vmax, vmin};
use wide::f32x8;

/// Which (a, b) index pairs are stored: the band |a − b| ≤ w.
#[derive(Debug, Clone, PartialEq)]
pub(crate) struct Band {
    pub n_s: usize,
    /// Stored half-width in grid steps.
    pub w: usize,
    /// Largest |xa − xb| a lookup may use, grid steps (the domain's max_ds).
    pub reach: f32,
    pub row_lo: Vec<usize>,
    pub row_start: Vec<usize>,
    pub pairs: usize,
    /// Per row a, `row_start[a] − row_lo[a]` (wrapping): pair (a, b) is
    /// entry block `pair_off[a] + b` (the lookup's one load instead of two;
    /// part of the band so that it changes with it).
    pub pair_off: Vec<usize>,
    /// `pair_off` truncated to i32 (wrapping values stay wrapped mod 2³²):
    /// the AVX2 lookup's lanes. Its offsets are bounded by the data's
    /// length, which fits in i32 (at most 2³⁰ values).
    #[cfg_attr(not(target_arch = "x86_64"), allow(dead_code))]
    pub pair_off32: Vec<i32>,
}

impl Band {
    /// The band of `axis`: for a uniform axis |a − b| ≤ w as in format 1;
    /// otherwise row a holds every b a lookup with Sf within one step of
    /// s_a and |Sf − Sb| ≤ max_ds can touch, plus one index of margin for
    /// f32 rounding.
    pub(super) fn for_axis(n_s: usize, domain: &TableDomain, axis: &Axis) -> Band {
        if axis.uniform {
            return Band::new(n_s, domain);
        }
        let x = |s: f64| axis.x_of((s as f32).max(axis.lo).min(axis.hi)) as f64;
        let mut row_lo = Vec::with_capacity(n_s);
        let mut row_start = Vec::with_capacity(n_s + 1);
        let (mut pairs, mut w) = (0, 0);
        for a in 0..n_s {
            let below = axis.grid[a.saturating_sub(1)] - domain.max_ds;
            let above = axis.grid[(a + 1).min(n_s - 1)] + domain.max_ds;
            let lo = ((x(below).floor() as usize).saturating_sub(1)).min(a);
            let hi = (x(above).floor() as usize + 2).min(n_s - 1).max(a);
            row_lo.push(lo);
            row_start.push(pairs);
            pairs += hi - lo + 1;
            w = w.max(a - lo).max(hi - a);
        }
        row_start.push(pairs);
        Band::with_offsets(n_s, w, (n_s - 1) as f32, row_lo, row_start, pairs)
    }

    fn with_offsets(n_s: usize, w: usize, reach: f32, row_lo: Vec<usize>, row_start: Vec<usize>, pairs: usize) -> Band {
        let pair_off: Vec<usize> = (0..n_s).map(|a| row_start[a].wrapping_sub(row_lo[a])).collect();
        let pair_off32 = pair_off.iter().map(|&p| p as i32).collect();
        Band { n_s, w, reach, row_lo, row_start, pairs, pair_off, pair_off32 }
    }

    pub fn new(n_s: usize, domain: &TableDomain) -> Band {
        let step = domain.scalar_span() / (n_s - 1) as f64;
        let reach_steps = (domain.max_ds / step).min((n_s - 1) as f64);
        // A lookup with |xa − xb| ≤ reach touches corners with |a − b| ≤ ⌈reach⌉ + 1.
        let w = ((reach_steps - 1e-9).max(0.0).ceil() as usize + 1).min(n_s - 1);
        let mut row_lo = Vec::with_capacity(n_s);
        let mut row_start = Vec::with_capacity(n_s + 1);
        let mut pairs = 0;
        for a in 0..n_s {
            let lo = a.saturating_sub(w);
            let hi = (a + w).min(n_s - 1);
            row_lo.push(lo);
            row_start.push(pairs);
            pairs += hi - lo + 1;
        }
        row_start.push(pairs);
        Band::with_offsets(n_s, w, reach_steps as f32, row_lo, row_start, pairs)
    }

    #[inline]
    pub fn pair(&self, a: usize, b: usize) -> usize {
        self.row_start[a] + (b - self.row_lo[a])
    }

    /// The b range of row a.
    pub fn row(&self, a: usize) -> std::ops::Range<usize> {
        self.row_lo[a]..self.row_lo[a] + (self.row_start[a + 1] - self.row_start[a])
    }
}

impl Table3d {
    /// Fractional grid indices (xa, xb) of a lookup: clamped to the axis,
    /// and xb to within the domain's max_ds of xa (so every corner is in the
    /// band). f32::max/min drop NaN, so NaN lands on the low edge.
    #[inline(always)]
    pub(super) fn band_coords(&self, sf: f32, sb: f32) -> (f32, f32) {
        if self.axis.uniform {
            let top = (self.params.n_s - 1) as f32;
            let lo = self.domain.s_lo as f32;
            let xa = ((sf - lo) * self.inv_ds).max(0.0).min(top);
            let xb = ((sb - lo) * self.inv_ds).max(0.0).min(top);
            (xa, xb.max(xa - self.band.reach).min(xa + self.band.reach))
        } else {
            let (lo, hi, ds) = (self.axis.lo, self.axis.hi, self.domain.max_ds as f32);
            let sf = sf.max(lo).min(hi);
            let sb = sb.max(lo).min(hi).max(sf - ds).min(sf + ds);
            (self.axis.x_of(sf), self.axis.x_of(sb))
        }
    }
}

impl Table3d {
    /// [`Table3d::band_coords`] for eight lanes (the first `m` valid; the
    /// rest computed on stale, finite inputs and ignored). NaN inputs are
    /// replaced first by what `f32::max` makes of them in the scalar path.
    #[inline(always)]
    pub(super) fn band_coords_lanes(&self, sf_in: f32x8, sb_in: f32x8, m: usize) -> (f32x8, f32x8) {
        if self.axis.uniform {
            let top = f32x8::splat((self.params.n_s - 1) as f32);
            let lo = f32x8::splat(self.domain.s_lo as f32);
            let (inv, reach) = (f32x8::splat(self.inv_ds), f32x8::splat(self.band.reach));
            let (sf, sb) = (no_nan(sf_in, lo), no_nan(sb_in, lo));
            let xa = vmin(vmax((sf - lo) * inv, f32x8::ZERO), top);
            let b = vmin(vmax((sb - lo) * inv, f32x8::ZERO), top);
            (xa, vmin(vmax(b, xa - reach), xa + reach))
        } else {
            let (lo, hi) = (f32x8::splat(self.axis.lo), f32x8::splat(self.axis.hi));
            let ds = f32x8::splat(self.domain.max_ds as f32);
            let sf = vmin(vmax(no_nan(sf_in, lo), lo), hi);
            let b = vmin(vmax(no_nan(sb_in, lo), lo), hi);
            let sb = vmin(vmax(b, sf - ds), sf + ds);
            (self.axis.x_of_lanes(sf, m), self.axis.x_of_lanes(sb, m))
        }
    }
}
