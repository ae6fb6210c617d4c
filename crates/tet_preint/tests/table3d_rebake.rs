//! `Table3d::rebake`: after a TF edit, the re-baked table equals a full bake
//! of the new TF bit for bit, recomputing only the pairs the edit can reach
//! when the scalar axis stays.
mod common;

use proptest::prelude::*;
use tet_preint::table3d::{Build3d, FullRebake, ScalarAxis, Table3dParams};
use tet_preint::*;

fn tf(color: &[(f64, [f64; 3])], opacity: &[(f64, f64)], emission: Emission) -> TransferFunction {
    TransferFunction::new(
        color.iter().map(|&(x, rgb)| ColorNode { x, rgb }).collect(),
        opacity.iter().map(|&(x, a)| OpacityNode { x, a }).collect(),
        0.7,
        emission,
        false,
    )
    .unwrap()
}

fn base_tf(emission: Emission) -> TransferFunction {
    tf(
        &[(0.0, [0.1, 0.2, 0.9]), (0.35, [0.9, 0.8, 0.2]), (0.6, [0.3, 0.9, 0.4]), (1.0, [1.0, 0.1, 0.0])],
        &[(0.0, 0.0), (0.2, 0.4), (0.5, 2.5), (0.55, 0.3), (0.8, 1.2), (1.0, 0.6)],
        emission,
    )
}

/// A skewed scalar distribution, so the data axis is not uniform.
fn domain() -> TableDomain {
    let mut d = TableDomain::new(0.0, 1.0, 0.35, 2.0).unwrap();
    let scalars: Vec<f64> = (0..=1000).map(|i| (i as f64 / 1000.0).powi(2)).collect();
    d.s_quantiles = ScalarQuantiles::of(&scalars);
    d
}

fn params(build: Build3d, s_axis: ScalarAxis) -> Table3dParams {
    Table3dParams { n_s: 40, n_l: 24, build, s_axis, ..Default::default() }
}

const BUILDS: [Build3d; 4] = [
    Build3d::Adaptive { tolerance: 1e-5 },
    Build3d::SliceRecurrence { oversampling: 2.0 },
    Build3d::Exact,
    Build3d::Blend { steps: 16, accumulation: Accumulation::F32 },
];
const AXES: [ScalarAxis; 3] = [ScalarAxis::Uniform, ScalarAxis::TfNodes, ScalarAxis::Data];

/// Re-bakes a table of `old` for `new` and checks it against a full bake.
fn rebake_matches(old: &TransferFunction, new: &TransferFunction, p: &Table3dParams) -> RebakeStats {
    let d = domain();
    let mut t = Table3d::build(old, &d, p).unwrap();
    let stats = t.rebake(old, new).unwrap();
    let full = Table3d::build(new, &d, p).unwrap();
    assert_eq!(t.s_knots(), full.s_knots(), "{p:?}");
    let (got, want) = (t.storage().as_f32().unwrap(), full.storage().as_f32().unwrap());
    assert_eq!(got.len(), want.len());
    let differ = got.iter().zip(want).filter(|(a, b)| a.to_bits() != b.to_bits()).count();
    assert_eq!(differ, 0, "{p:?}: {differ} values differ from a full bake ({stats:?})");
    assert_eq!(t.reconstruction(), full.reconstruction(), "{p:?}");
    assert_eq!(t.reconstruction_gap().to_bits(), full.reconstruction_gap().to_bits(), "{p:?}");
    assert_eq!(t.memory_bytes(), full.memory_bytes(), "{p:?}");
    // Lookups too. Regression: the lookup's per-row pair offsets were not
    // renewed when an edit changed the axis (and with it the band), so the
    // re-baked table read the old layout (tet_viewer's fresh-engine test).
    let mut b = SegmentBatch::default();
    for i in 0..BATCH {
        let u = i as f32 / BATCH as f32;
        b.push(Segment {
            s_front: u,
            s_back: (u * 7.3).fract(),
            len_world: 2.0 * (u * 3.1).fract(),
            ..Default::default()
        });
    }
    let (mut got, mut want) = ([[0.0f32; 4]; BATCH], [[0.0f32; 4]; BATCH]);
    t.shade_batch(&b, &mut got);
    full.shade_batch(&b, &mut want);
    assert_eq!(got, want, "{p:?}: batch lookups differ after the re-bake");
    for i in 0..BATCH {
        assert_eq!(t.shade(&b.get(i)), full.shade(&b.get(i)), "{p:?}: lookup {i} differs after the re-bake");
    }
    stats
}

#[test]
fn value_and_colour_edits_rebake_part_of_the_table_bit_for_bit() {
    for emission in [Emission::Density, Emission::Independent] {
        let old = base_tf(emission);
        // The opacity of the node at 0.8 (its neighbours 0.55 and 1.0).
        let mut op: Vec<(f64, f64)> = old.opacity_nodes().iter().map(|o| (o.x, o.a)).collect();
        op[4].1 = 3.0;
        let col: Vec<(f64, [f64; 3])> = old.color_nodes().iter().map(|c| (c.x, c.rgb)).collect();
        let value_edit = tf(&col, &op, emission);
        // The colour of the node at 0.35.
        let mut col2 = col.clone();
        col2[1].1 = [0.2, 0.2, 0.2];
        let op0: Vec<(f64, f64)> = old.opacity_nodes().iter().map(|o| (o.x, o.a)).collect();
        let colour_edit = tf(&col2, &op0, emission);
        for build in BUILDS {
            for s_axis in AXES {
                let p = params(build, s_axis);
                for new in [&value_edit, &colour_edit] {
                    let st = rebake_matches(&old, new, &p);
                    assert_eq!(st.full, None, "{p:?}");
                    assert!(st.pairs_rebaked > 0 && st.pairs_rebaked < st.pairs, "{p:?}: {st:?}");
                }
                // No change: nothing to do.
                let st = rebake_matches(&old, &old, &p);
                assert_eq!((st.full, st.pairs_rebaked), (None, 0));
            }
        }
    }
}

#[test]
fn moved_added_removed_nodes_and_global_changes() {
    let old = base_tf(Emission::Density);
    let col: Vec<(f64, [f64; 3])> = old.color_nodes().iter().map(|c| (c.x, c.rgb)).collect();
    let op: Vec<(f64, f64)> = old.opacity_nodes().iter().map(|o| (o.x, o.a)).collect();
    let mut moved = op.clone();
    moved[4].0 = 0.75;
    let moved = tf(&col, &moved, Emission::Density);
    let mut added = op.clone();
    added.insert(5, (0.9, 0.1));
    let added = tf(&col, &added, Emission::Density);
    let mut removed = op.clone();
    removed.remove(2);
    let removed = tf(&col, &removed, Emission::Density);
    let emission = tf(&col, &op, Emission::Independent);
    for build in BUILDS {
        for s_axis in AXES {
            let p = params(build, s_axis);
            for new in [&moved, &added, &removed] {
                let st = rebake_matches(&old, new, &p);
                // On a uniform axis the samples stay: a partial re-bake.
                if s_axis == ScalarAxis::Uniform {
                    assert_eq!(st.full, None, "{p:?}");
                    assert!(st.pairs_rebaked < st.pairs, "{p:?}: {st:?}");
                } else {
                    assert_eq!(st.full, Some(FullRebake::AxisChanged), "{p:?}");
                }
            }
            let st = rebake_matches(&old, &emission, &p);
            if s_axis == ScalarAxis::Uniform {
                assert_eq!(st.full, Some(FullRebake::GlobalChange));
            }
        }
    }
    // The incremental build and 16-bit storage bake in full.
    let p = params(Build3d::Incremental, ScalarAxis::Data);
    let mut op2 = op.clone();
    op2[4].1 = 3.0;
    let value_edit = tf(&col, &op2, Emission::Density);
    let mut t = Table3d::build(&old, &domain(), &p).unwrap();
    assert_eq!(t.rebake(&old, &value_edit).unwrap().full, Some(FullRebake::Build));
    let p = Table3dParams { precision: Precision::F16, ..params(BUILDS[0], ScalarAxis::Data) };
    let mut t = Table3d::build(&old, &domain(), &p).unwrap();
    assert_eq!(t.rebake(&old, &value_edit).unwrap().full, Some(FullRebake::Precision));
    assert_eq!(t.storage(), Table3d::build(&value_edit, &domain(), &p).unwrap().storage());
}

/// The property tests' TFs: opacity up to 6, unit distance 0.7.
fn arb_tf() -> impl Strategy<Value = TransferFunction> {
    common::arb_tf(6.0, 1..7, 1..6, 0.7)
}

proptest! {
    #![proptest_config(ProptestConfig { cases: 16, rng_seed: proptest::test_runner::RngSeed::Fixed(55), ..ProptestConfig::default() })]

    /// Any single edit of a control point's value or colour (or none), on
    /// any build and axis, re-bakes to the full bake bit for bit.
    #[test]
    fn any_value_edit_rebakes_bit_for_bit(
        old in arb_tf(),
        which in 0usize..64,
        value in 0.0f64..6.0,
        rgb in (0.0f64..1.0, 0.0f64..1.0, 0.0f64..1.0),
        build in 0usize..4,
        axis in 0usize..3,
    ) {
        let col: Vec<(f64, [f64; 3])> = old.color_nodes().iter().map(|c| (c.x, c.rgb)).collect();
        let op: Vec<(f64, f64)> = old.opacity_nodes().iter().map(|o| (o.x, o.a)).collect();
        let (mut col2, mut op2) = (col.clone(), op.clone());
        if which % 2 == 0 {
            let i = (which / 2) % op2.len();
            op2[i].1 = value;
        } else {
            let i = (which / 2) % col2.len();
            col2[i].1 = [rgb.0, rgb.1, rgb.2];
        }
        let new = tf(&col2, &op2, old.emission());
        let p = params(BUILDS[build], AXES[axis]);
        let st = rebake_matches(&old, &new, &p);
        prop_assert_eq!(st.full, None);
    }
}

/// An edit that moves the table across [`RECONSTRUCTION_GAP`] (a thin TF
/// made dense at one node, and back) switches the reconstruction: the
/// re-baked table chooses as a full bake does and looks up the same, though
/// only part of it was re-baked (the optical depths of the pairs it did not
/// touch are computed then, or dropped).
#[test]
fn an_edit_across_the_gap_switches_the_reconstruction() {
    let col = [(0.0, [0.1, 0.2, 0.9]), (0.35, [0.9, 0.8, 0.2]), (1.0, [1.0, 0.1, 0.0])];
    let thin = tf(&col, &[(0.0, 0.001), (0.5, 0.004), (0.8, 0.002), (1.0, 0.001)], Emission::Density);
    let dense = tf(&col, &[(0.0, 0.001), (0.5, 0.004), (0.8, 6.0), (1.0, 0.001)], Emission::Density);
    let p = params(Build3d::Adaptive { tolerance: 1e-5 }, ScalarAxis::Uniform);
    let d = domain();
    assert_eq!(Table3d::build(&thin, &d, &p).unwrap().reconstruction(), Reconstruction::Trilinear);
    assert_eq!(Table3d::build(&dense, &d, &p).unwrap().reconstruction(), Reconstruction::OpticalDepth);
    for (old, new) in [(&thin, &dense), (&dense, &thin)] {
        let stats = rebake_matches(old, new, &p);
        assert!(stats.full.is_none() && stats.pairs_rebaked < stats.pairs, "{stats:?}");
    }
}
