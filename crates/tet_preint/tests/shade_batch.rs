//! `SegmentShader::shade_batch` (the rasterizer's call) returns what `shade`
//! returns, lane by lane, for table3d's lane-wise override on every scalar
//! axis, poly1/2/4's (banded and full, both emission models) and the
//! default of the others; inputs include NaN, ±∞,
//! scalars outside the domain, |Sf − Sb| beyond the band and lengths beyond
//! the table, and batches of every length (partial blocks of eight).
use proptest::prelude::*;
use tet_preint::table3d::{Build3d, ScalarAxis, Table3dParams};
use tet_preint::*;

const TF: &str = r#"{"color": [[0, 0.2, 0.4, 1], [0.35, 1, 1, 0.2], [1, 1, 0, 0]],
    "opacity": [[0, 0.2], [0.3, 0.1], [0.6, 4], [1, 1]], "unit_distance": 0.5}"#;

fn odd(v: u8) -> Option<f32> {
    match v % 16 {
        0 => Some(f32::NAN),
        1 => Some(f32::INFINITY),
        2 => Some(f32::NEG_INFINITY),
        3 => Some(-5.0),
        4 => Some(7.0),
        _ => None,
    }
}

fn batch(raw: &[(f32, f32, f32, u8)]) -> SegmentBatch {
    let mut b = SegmentBatch::default();
    for &(s_front, s_back, len_world, tag) in raw.iter().take(BATCH) {
        let mut seg = Segment { s_front, s_back, len_world, ..Default::default() };
        match tag % 3 {
            0 => seg.s_front = odd(tag / 3).unwrap_or(s_front),
            1 => seg.s_back = odd(tag / 3).unwrap_or(s_back),
            _ => seg.len_world = odd(tag / 3).unwrap_or(len_world),
        }
        b.push(seg);
    }
    b
}

fn check(shader: &dyn SegmentShader, b: &SegmentBatch) -> Result<(), TestCaseError> {
    let mut out = [[-1.0f32; 4]; BATCH];
    shader.shade_batch(b, &mut out);
    for (i, got) in out.iter().enumerate().take(b.len) {
        let want = shader.shade(&b.get(i));
        // Equal values (a zero's sign may differ: min/max of ±0).
        prop_assert!(*got == want, "{:?} lane {i} {:?}: batch {got:?} vs shade {want:?}", shader.method(), b.get(i));
        prop_assert!(got.iter().all(|v| v.is_finite()), "lane {i}: {got:?}");
    }
    prop_assert!(out[b.len..].iter().all(|o| *o == [-1.0; 4]), "lanes past len were written");
    Ok(())
}

fn tables() -> Vec<Box<dyn SegmentShader>> {
    let tf = TransferFunction::from_json(TF).unwrap();
    let scalars: Vec<f64> = (0..=1000).map(|i| (i as f64 / 1000.0).powi(3)).collect();
    let mut d = TableDomain::new(0.0, 1.0, 0.4, 2.0).unwrap();
    d.s_quantiles = ScalarQuantiles::of(&scalars);
    let mut v: Vec<Box<dyn SegmentShader>> = [ScalarAxis::Uniform, ScalarAxis::TfNodes, ScalarAxis::Data]
        .into_iter()
        .map(|s_axis| {
            let p = Table3dParams {
                n_s: 40,
                n_l: 24,
                build: Build3d::SliceRecurrence { oversampling: 2.0 },
                s_axis,
                ..Default::default()
            };
            Box::new(Table3d::build(&tf, &d, &p).unwrap()) as Box<dyn SegmentShader>
        })
        .collect();
    // A decoded (non-f32) table takes the per-lane path.
    let p = Table3dParams { n_s: 24, n_l: 12, precision: Precision::F16, ..Default::default() };
    v.push(Box::new(Table3d::build(&tf, &d, &p).unwrap()));
    for degree in [1, 2, 4] {
        for max_ds in [0.3, 2.0] {
            let p = PolyParams::new(degree, 48, 0.0, 1.0, 2.0).with_max_ds(max_ds);
            v.push(Box::new(PolyTable::build(&tf, &p).unwrap()));
        }
    }
    let ind = tf.clone().with_emission(Emission::Independent);
    v.push(Box::new(PolyTable::build(&ind, &PolyParams::new(2, 32, 0.0, 1.0, 2.0)).unwrap()));
    v.push(Box::new(PtLinearShader::new(tf.clone())));
    v.push(Box::new(ExactShader::new(tf)));
    v
}

proptest! {
    #![proptest_config(ProptestConfig { cases: 64, rng_seed: proptest::test_runner::RngSeed::Fixed(77), ..ProptestConfig::default() })]

    #[test]
    fn shade_batch_is_shade_lane_by_lane(
        raw in prop::collection::vec((-0.2f32..1.2, -0.2f32..1.2, -0.5f32..2.5, any::<u8>()), 0..=BATCH),
    ) {
        let b = batch(&raw);
        for shader in tables() {
            check(shader.as_ref(), &b)?;
        }
    }
}

#[test]
fn stale_lanes_past_len_do_not_matter() {
    // A full batch of odd values, then a shorter batch over the same storage.
    let mut b = batch(&(0..BATCH as u8).map(|i| (0.5, 0.5, 1.0, i.wrapping_mul(3))).collect::<Vec<_>>());
    b.len = 5;
    for shader in tables() {
        check(shader.as_ref(), &b).unwrap();
    }
}
