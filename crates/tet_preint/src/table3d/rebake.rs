//! Re-baking after a TF edit ([`Table3d::rebake`]): only the (Sf, Sb) pairs
//! the edit reaches are computed again.

use super::axis::Axis;
use super::band::Band;
use super::build::{bake_pairs, Grid};
use super::{Build3d, Table3d};
use crate::domain::{TableError, MAX_TABLE_ENTRIES};
use crate::precision::Precision;
use crate::tf::TransferFunction;

/// What [`Table3d::rebake`] did.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct RebakeStats {
    /// (Sf, Sb) pairs the table stores.
    pub pairs: usize,
    /// Pairs computed again (all of them after a full bake).
    pub pairs_rebaked: usize,
    /// Why the whole table was baked again, if it was.
    pub full: Option<FullRebake>,
}

/// Why [`Table3d::rebake`] baked the whole table.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum FullRebake {
    /// The new TF puts the scalar samples elsewhere (a control point was
    /// added, removed or moved along s, on a non-uniform axis).
    AxisChanged,
    /// Unit distance, emission model, widgets or normalization changed:
    /// every entry depends on them.
    GlobalChange,
    /// The build is not per pair (`Incremental`).
    Build,
    /// Storage other than f32 (unorm's scale is the whole table's; f16
    /// is rebuilt for simplicity).
    Precision,
}

/// Where two TFs differ, as closed scalar intervals outside which both
/// evaluate (colour, extinction, control points) bit for bit alike: per
/// node list, from the last node of their common prefix to the first of
/// their common suffix (±∞ when there is none). `None`: they differ
/// everywhere (unit distance, emission, normalization, widgets).
fn changed_spans(old: &TransferFunction, new: &TransferFunction) -> Option<Vec<(f64, f64)>> {
    if old.unit_distance().to_bits() != new.unit_distance().to_bits()
        || old.emission() != new.emission()
        || old.normalized() != new.normalized()
        || old.widgets() != new.widgets()
    {
        return None;
    }
    fn span<T>(old: &[T], new: &[T], x: impl Fn(&T) -> f64, same: impl Fn(&T, &T) -> bool) -> Option<(f64, f64)> {
        let prefix = old.iter().zip(new).take_while(|(a, b)| same(a, b)).count();
        if prefix == old.len() && prefix == new.len() {
            return None;
        }
        let suffix = old.iter().rev().zip(new.iter().rev()).take_while(|(a, b)| same(a, b)).count();
        // The common prefix and suffix may overlap when one list is the
        // other with a node removed: keep them apart.
        let suffix = suffix.min(old.len() - prefix).min(new.len() - prefix);
        let lo = if prefix == 0 { f64::NEG_INFINITY } else { x(&old[prefix - 1]) };
        let hi = if suffix == 0 { f64::INFINITY } else { x(&old[old.len() - suffix]) };
        Some((lo, hi))
    }
    let bits = |v: f64| v.to_bits();
    let colour = span(
        old.color_nodes(),
        new.color_nodes(),
        |c| c.x,
        |a, b| bits(a.x) == bits(b.x) && a.rgb.map(bits) == b.rgb.map(bits),
    );
    let opacity = span(
        old.opacity_nodes(),
        new.opacity_nodes(),
        |o| o.x,
        |a, b| bits(a.x) == bits(b.x) && bits(a.a) == bits(b.a),
    );
    Some(colour.into_iter().chain(opacity).collect())
}

impl Table3d {
    /// Re-bakes this table, baked from `old_tf`, for `new_tf` (both in data
    /// units, as [`Table3d::build`] takes them), computing again only the
    /// (Sf, Sb) pairs whose scalar interval meets the part of the TF that
    /// changed: the result equals `Table3d::build(new_tf, self.domain(),
    /// self.params())` bit for bit (tests/table3d_rebake.rs).
    ///
    /// An entry depends on the TF only over its pair's interval [Sf, Sb]
    /// (colour, extinction and control points there; the optical depth is
    /// integrated from Sf, not from a prefix over the whole TF), so a value
    /// or colour edit of one control point re-bakes the pairs that meet the
    /// span between its neighbours. Every pair is baked again
    /// ([`RebakeStats::full`] says why) when the axis the new TF gets
    /// differs (on a `TfNodes` or `Data` axis every control point is a
    /// sample, so moving, adding or removing one moves samples, and every
    /// entry moves with them) or a global field changed, both in the
    /// table's own buffer; and by [`Table3d::build`] for the `Incremental`
    /// build and for storage other than f32.
    /// `old_tf` must be the TF the table was baked from; otherwise the
    /// unchanged pairs keep the old TF's values.
    pub fn rebake(&mut self, old_tf: &TransferFunction, new_tf: &TransferFunction) -> Result<RebakeStats, TableError> {
        let full = |t: &mut Table3d, why: FullRebake| -> Result<RebakeStats, TableError> {
            let kernel = t.kernel;
            *t = Table3d::build(new_tf, &t.domain, &t.params)?;
            t.kernel = kernel;
            Ok(RebakeStats { pairs: t.band.pairs, pairs_rebaked: t.band.pairs, full: Some(why) })
        };
        if self.params.build == Build3d::Incremental {
            return full(self, FullRebake::Build);
        }
        if self.params.precision != Precision::F32 {
            return full(self, FullRebake::Precision);
        }
        let axis = Axis::for_params(new_tf, &self.domain, &self.params)?;
        let spans = if axis != *self.axis {
            Err(FullRebake::AxisChanged)
        } else {
            changed_spans(old_tf, new_tf).ok_or(FullRebake::GlobalChange)
        };
        let n_l = self.params.n_l;
        let spans = match spans {
            Ok(spans) => spans,
            Err(why) => {
                // Every pair, into the same buffer (resized when the band
                // changed with the axis): no fresh 44 MiB to fault in.
                let band = Band::for_axis(self.params.n_s, &self.domain, &axis);
                let entries = band.pairs as u64 * n_l as u64;
                if entries > MAX_TABLE_ENTRIES {
                    return Err(TableError::TooLarge { entries, max: MAX_TABLE_ENTRIES });
                }
                let grid = Grid::new(&self.domain, &self.params, &axis);
                let values = self.data.f32_vec_mut().expect("f32 storage checked above");
                values.resize(band.pairs * n_l * 4, 0.0);
                bake_pairs(new_tf, &grid, &band, self.params.build, values, &|_, _| true);
                let pairs = band.pairs;
                (self.axis, self.band) = (Box::new(axis), band);
                self.update_reconstruction(|_, _| true);
                return Ok(RebakeStats { pairs, pairs_rebaked: pairs, full: Some(why) });
            }
        };
        let grid = Grid::new(&self.domain, &self.params, &self.axis);
        let dirty = |a: usize, b: usize| {
            let (lo, hi) = (grid.s(a).min(grid.s(b)), grid.s(a).max(grid.s(b)));
            spans.iter().any(|&(x0, x1)| x0 <= hi && lo <= x1)
        };
        let pairs_rebaked: usize =
            (0..self.params.n_s).map(|a| self.band.row(a).filter(|&b| dirty(a, b)).count()).sum();
        let values = self.data.f32_vec_mut().expect("f32 storage checked above");
        bake_pairs(new_tf, &grid, &self.band, self.params.build, values, &dirty);
        self.update_reconstruction(dirty);
        Ok(RebakeStats { pairs: self.band.pairs, pairs_rebaked, full: None })
    }
}
