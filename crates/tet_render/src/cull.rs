//! Conservative per-cell culling (Song et al. 2009 §3.1): a cell whose value range
//! maps to nothing visible over the whole range is neither drawn nor (with
//! the radix sort) sorted.
//!
//! Within a linear tet the scalar takes every value between its vertices'
//! minimum and maximum and no other, so "the transfer function is zero on
//! [min, max]" is exact, not a heuristic. Bivariate culling (scalar range ×
//! |∇s| range) plugs in through [`CellCuller`] or a closure.

use crate::scene::Scene;
use rayon::prelude::*;
use tet_preint::{Emission, TransferFunction};

/// Decides whether a cell contributes nothing. Must be conservative: return
/// `true` only when every (s, |∇s|) in the ranges gives zero colour and
/// opacity.
pub trait CellCuller: Send + Sync {
    /// `scalar` is `[min, max]` of the cell's vertex scalars; `grad_mag` the
    /// same for per-vertex gradient magnitudes when the scene has them.
    fn is_invisible(&self, scalar: [f64; 2], grad_mag: Option<[f64; 2]>) -> bool;
}

impl<F> CellCuller for F
where
    F: Fn([f64; 2], Option<[f64; 2]>) -> bool + Send + Sync,
{
    fn is_invisible(&self, scalar: [f64; 2], grad_mag: Option<[f64; 2]>) -> bool {
        self(scalar, grad_mag)
    }
}

/// Culling for a transfer function: the maximal closed intervals on which
/// its 1D part is invisible (extinction zero and, with independent emission,
/// colour zero too), precomputed once per TF; with 2D widgets, a cell is also
/// checked against the widgets over its (scalar, |∇s|) box.
#[derive(Debug, Clone)]
pub struct TfCuller {
    /// Sorted, disjoint `[lo, hi]` (±∞ at the clamped ends).
    zero: Vec<[f64; 2]>,
    /// The TF when it has widgets (their test needs the gradient range).
    widgets: Option<TransferFunction>,
}

impl TfCuller {
    pub fn new(tf: &TransferFunction) -> TfCuller {
        let mut xs: Vec<f64> =
            tf.opacity_nodes().iter().map(|o| o.x).chain(tf.color_nodes().iter().map(|c| c.x)).collect();
        xs.sort_by(f64::total_cmp);
        xs.dedup();
        let independent = tf.emission() == Emission::Independent;
        // Every component is linear between merged breakpoints and ≥ 0, so it
        // is zero on a piece exactly when it is zero at both ends.
        let zero_at = |x: f64| tf.extinction(x) == 0.0 && (!independent || tf.color(x).iter().all(|&c| c == 0.0));
        let mut zero: Vec<[f64; 2]> = Vec::new();
        for (i, &x) in xs.iter().enumerate() {
            if !zero_at(x) {
                continue;
            }
            let lo = if i == 0 { f64::NEG_INFINITY } else { x };
            let hi = if i + 1 == xs.len() { f64::INFINITY } else { x };
            match zero.last_mut() {
                // Joined to the previous zero node by a zero piece.
                Some(last) if i > 0 && last[1] == xs[i - 1] && zero_at(xs[i - 1]) => last[1] = hi,
                _ => zero.push([lo, hi]),
            }
        }
        let widgets = (!tf.widgets().is_empty()).then(|| tf.clone());
        TfCuller { zero, widgets }
    }

    /// The invisible intervals (for reports and tests).
    pub fn zero_intervals(&self) -> &[[f64; 2]] {
        &self.zero
    }
}

impl CellCuller for TfCuller {
    fn is_invisible(&self, scalar: [f64; 2], grad_mag: Option<[f64; 2]>) -> bool {
        let i = self.zero.partition_point(|z| z[1] < scalar[1]);
        let zero_1d = self.zero.get(i).is_some_and(|z| z[0] <= scalar[0] && scalar[1] <= z[1]);
        match &self.widgets {
            None => zero_1d,
            // Without gradients any |∇s| is possible.
            Some(tf) => zero_1d && tf.cell_is_invisible(scalar, grad_mag.unwrap_or([0.0, f64::INFINITY])),
        }
    }
}

/// Which tets survive culling.
#[derive(Debug, Clone, PartialEq)]
pub struct CullMask {
    /// `visible[t]` for every tet.
    pub visible: Vec<bool>,
    pub culled: usize,
}

impl CullMask {
    /// Everything visible (no culler).
    pub fn all(n: usize) -> CullMask {
        CullMask { visible: vec![true; n], culled: 0 }
    }
    /// Fraction of tets culled, 0 for an empty mesh.
    pub fn fraction_culled(&self) -> f64 {
        if self.visible.is_empty() {
            0.0
        } else {
            self.culled as f64 / self.visible.len() as f64
        }
    }
}

/// Applies a culler to every tet of the scene (in parallel).
pub fn cull(scene: &Scene, culler: &dyn CellCuller) -> CullMask {
    let s = scene.scalar();
    let g = scene.gradient_magnitudes();
    let range = |v: [f64; 4]| {
        [v.iter().copied().fold(f64::INFINITY, f64::min), v.iter().copied().fold(f64::NEG_INFINITY, f64::max)]
    };
    let visible: Vec<bool> = scene
        .tets()
        .par_iter()
        .map(|t| {
            let sr = range(t.map(|v| s[v as usize]));
            let gr = g.map(|g| range(t.map(|v| g[v as usize])));
            !culler.is_invisible(sr, gr)
        })
        .collect();
    let culled = visible.iter().filter(|&&v| !v).count();
    CullMask { visible, culled }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn tf(json: &str) -> TransferFunction {
        TransferFunction::from_json(json).unwrap()
    }

    #[test]
    fn zero_intervals_of_a_tent() {
        // Opacity 0 below 0.2, a tent up to 0.5, 0 from 0.8 on.
        let t = tf(r#"{"color": [[0, 1, 1, 1]], "opacity": [[0.2, 0], [0.5, 1], [0.8, 0]], "unit_distance": 1}"#);
        let c = TfCuller::new(&t);
        assert_eq!(c.zero_intervals(), &[[f64::NEG_INFINITY, 0.2], [0.8, f64::INFINITY]]);
        assert!(c.is_invisible([-5.0, 0.2], None));
        assert!(!c.is_invisible([0.1, 0.3], None));
        assert!(c.is_invisible([0.8, 9.0], None));
        assert!(!c.is_invisible([0.0, 1.0], None)); // spans the visible tent
        assert!(!c.is_invisible([0.5, 0.5], None));
    }

    #[test]
    fn zero_in_the_middle_and_independent_emission() {
        let t = tf(r#"{"color": [[0, 1, 0, 0]], "opacity": [[0, 1], [0.4, 0], [0.6, 0], [1, 1]], "unit_distance": 1}"#);
        let c = TfCuller::new(&t);
        assert_eq!(c.zero_intervals(), &[[0.4, 0.6]]);
        assert!(c.is_invisible([0.45, 0.55], None));
        assert!(!c.is_invisible([0.3, 0.5], None));
        // With emission independent of extinction, red still shows where ρ = 0.
        let c = TfCuller::new(&t.with_emission(Emission::Independent));
        assert!(c.zero_intervals().is_empty());
        assert!(!c.is_invisible([0.45, 0.55], None));
    }

    #[test]
    fn closures_are_cullers() {
        let f = |s: [f64; 2], _g: Option<[f64; 2]>| s[1] < 0.0;
        let c: &dyn CellCuller = &f;
        assert!(c.is_invisible([-2.0, -1.0], None));
        assert!(!c.is_invisible([-2.0, 1.0], None));
    }

    /// Regression: the culler once looked at the 1D part only and culled
    /// cells that a 2D widget makes visible.
    #[test]
    fn widgets_keep_their_cells_visible() {
        let t = tf(r#"{"color": [[0, 1, 1, 1], [1, 1, 1, 1]], "opacity": [[0, 0], [1, 0]], "unit_distance": 1,
            "widgets": [{"type": "box", "center": [0.5, 2.0], "width": [0.2, 1.0], "color": [1, 0, 0], "opacity": 1}]}"#);
        let c = TfCuller::new(&t);
        // Inside the box's scalar band: visible unless the gradients miss it.
        assert!(!c.is_invisible([0.45, 0.55], Some([1.8, 2.2])));
        assert!(!c.is_invisible([0.45, 0.55], None));
        assert!(c.is_invisible([0.45, 0.55], Some([3.0, 4.0])));
        // Outside it in s: invisible whatever the gradient.
        assert!(c.is_invisible([0.8, 0.9], None));
    }
}
