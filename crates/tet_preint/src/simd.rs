//! Lane-wise helpers for the tables' [`shade_batch`] overrides: clamps that
//! give, lane by lane, what the scalar lookups' `f32::max`/`f32::min` give.
//!
//! [`shade_batch`]: crate::SegmentShader::shade_batch

use wide::{f32x8, CmpEq};

/// `v` where it is above `lo`, else `lo`: `maxps`, the scalar path's
/// `f32::max` for the NaN-free lanes it gets.
#[inline(always)]
pub(crate) fn vmax(v: f32x8, lo: f32x8) -> f32x8 {
    v.fast_max(lo)
}

/// `v` where it is below `hi`, else `hi` (`minps`); see [`vmax`].
#[inline(always)]
pub(crate) fn vmin(v: f32x8, hi: f32x8) -> f32x8 {
    v.fast_min(hi)
}

/// `v` with NaN lanes replaced by `fill`.
#[inline(always)]
pub(crate) fn no_nan(v: f32x8, fill: f32x8) -> f32x8 {
    v.cmp_eq(v).blend(v, fill)
}
