//! What the table tests share: random transfer functions for the property
//! tests, and the Blunt Fin mesh the accuracy figures are measured on.
#![allow(dead_code)] // not every test binary uses all of it

pub mod bluntfin;

use proptest::prelude::*;
use tet_preint::{ColorNode, Emission, OpacityNode, TransferFunction};

/// Random TFs on [0, 1] with unit distance `unit_distance`:
/// `opacity_counts` opacity nodes with opacity in [0, `max_opacity`),
/// `color_counts` colour nodes, each list sorted by x with nodes closer
/// than 1e-3 merged, and either emission model.
pub fn arb_tf(
    max_opacity: f64,
    opacity_counts: std::ops::Range<usize>,
    color_counts: std::ops::Range<usize>,
    unit_distance: f64,
) -> impl Strategy<Value = TransferFunction> {
    (
        prop::collection::vec((0.0f64..1.0, 0.0f64..max_opacity), opacity_counts),
        prop::collection::vec((0.0f64..1.0, 0.0f64..1.0, 0.0f64..1.0, 0.0f64..1.0), color_counts),
        prop::bool::ANY,
    )
        .prop_map(move |(mut op, mut col, independent)| {
            op.sort_by(|a, b| a.0.total_cmp(&b.0));
            op.dedup_by(|a, b| (a.0 - b.0).abs() < 1e-3);
            col.sort_by(|a, b| a.0.total_cmp(&b.0));
            col.dedup_by(|a, b| (a.0 - b.0).abs() < 1e-3);
            let opacity = op.into_iter().map(|(x, a)| OpacityNode { x, a }).collect();
            let color = col.into_iter().map(|(x, r, g, b)| ColorNode { x, rgb: [r, g, b] }).collect();
            let e = if independent { Emission::Independent } else { Emission::Density };
            TransferFunction::new(color, opacity, unit_distance, e, false).unwrap()
        })
}
