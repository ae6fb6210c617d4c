//! poly1/poly2/poly4 against the exact integrator, stability cases, the
//! band layout and stored parts.
use proptest::prelude::*;
use tet_preint::{
    integrate_segment, AlphaTable, Emission, PolyError, PolyParams, PolyTable, Segment, SegmentShader, TransferFunction,
};

fn ramp() -> TransferFunction {
    TransferFunction::from_json(include_str!("data/vtk/tf_ramp.json")).unwrap()
}

/// Smooth TF with a zero-extinction gap over [0.2, 0.4].
fn gap() -> TransferFunction {
    TransferFunction::from_json(
        r#"{"color": [[0, 1, 0, 0], [0.5, 0, 1, 0], [1, 0, 0, 1]],
            "opacity": [[0, 1], [0.2, 0], [0.4, 0], [0.7, 2], [1, 0.5]], "unit_distance": 1}"#,
    )
    .unwrap()
}

use tet_preint::lcg_unit as lcg;

/// (rms, max) of |C| and |α| errors against exact over random in-range triples.
fn errors(table: &PolyTable, tf: &TransferFunction, l_max: f64, n: usize) -> (f64, f64, f64) {
    let mut next = lcg(7);
    let (mut sc, mut mc, mut ma) = (0.0f64, 0.0f64, 0.0f64);
    for _ in 0..n {
        let (sf, sb, l) = (next() as f32, next() as f32, (next() * l_max) as f32);
        let got = table.lookup(sf, sb, l);
        let want = integrate_segment(tf, sf as f64, sb as f64, l as f64);
        for (g, w) in got.iter().zip(want.color) {
            let d = (*g as f64 - w).abs();
            sc += d * d;
            mc = mc.max(d);
        }
        ma = ma.max((got[3] as f64 - want.alpha).abs());
    }
    ((sc / (3 * n) as f64).sqrt(), mc, ma)
}

#[test]
fn accuracy_improves_with_degree_and_matches_exact() {
    for emission in [Emission::Density, Emission::Independent] {
        let tf = gap().with_emission(emission);
        let mut rms = Vec::new();
        for degree in [1, 2, 4] {
            let t = PolyTable::build(&tf, &PolyParams::new(degree, 256, 0.0, 1.0, 2.0)).unwrap();
            assert_eq!(t.method().id(), format!("poly{degree}"));
            let (r, mc, ma) = errors(&t, &tf, 2.0, 20_000);
            // Bilinear over a 256² grid of a TF with slopes ≤ 7 per unit: α within 2e-3.
            assert!(ma < 2e-3, "{emission:?} n={degree}: max α error {ma}");
            assert!(mc < 2e-2, "{emission:?} n={degree}: max C error {mc}");
            rms.push(r);
        }
        assert!(rms[1] < rms[0] && rms[2] <= rms[1] * 1.05, "{emission:?}: rms by degree {rms:?}");
        assert!(rms[2] < 2e-3, "{emission:?}: {rms:?}");
    }
}

#[test]
fn exact_at_the_grid_nodes_for_slice_lengths() {
    // At grid scalars and at the fitted slice lengths the only error is f32 + 16-bit α.
    let tf = ramp();
    let t = PolyTable::build(&tf, &PolyParams::new(2, 101, 0.0, 1.0, 1.0)).unwrap();
    for (i, j) in [(0, 100), (40, 45), (45, 40), (10, 90), (57, 57), (99, 3)] {
        let (sf, sb) = (i as f32 / 100.0, j as f32 / 100.0);
        for l in [0.5f32, 1.0] {
            let got = t.lookup(sf, sb, l);
            let want = integrate_segment(&tf, sf as f64, sb as f64, l as f64);
            assert!((got[3] as f64 - want.alpha).abs() < 2e-5, "{i} {j} {l}");
            for c in 0..3 {
                assert!((got[c] as f64 - want.color[c]).abs() < 1e-4, "{i} {j} {l} {c}: {got:?} {want:?}");
            }
        }
    }
}

#[test]
fn stability_cases() {
    for emission in [Emission::Density, Emission::Independent] {
        let tf = gap().with_emission(emission);
        let t = PolyTable::build(&tf, &PolyParams::new(2, 64, 0.0, 1.0, 1.0)).unwrap();
        // l = 0 and negative or NaN l: nothing.
        assert_eq!(t.lookup(0.1, 0.9, 0.0), [0.0; 4]);
        assert_eq!(t.lookup(0.1, 0.9, -1.0), [0.0; 4]);
        assert_eq!(t.lookup(0.1, 0.9, f32::NAN), [0.0; 4]);
        // NaN scalars and huge l: finite.
        for px in [t.lookup(f32::NAN, 0.5, 0.3), t.lookup(0.5, f32::INFINITY, 0.3), t.lookup(0.6, 0.9, 1e30)] {
            assert!(px.iter().all(|v| v.is_finite()), "{px:?}");
        }
        // Large ρ·l saturates α to 1 with a bounded colour.
        let px = t.lookup(0.7, 0.7, 1e6);
        assert_eq!(px[3], 1.0);
        let mc = tf.max_color();
        for c in 0..3 {
            let bound = if emission == Emission::Density { mc[c] } else { 1e6 * mc[c] };
            assert!(px[c] >= 0.0 && px[c] <= bound as f32 * 1.0001);
        }
        // Inside the zero-extinction gap: α = 0; density C = 0, independent C = κ·l.
        let px = t.lookup(0.25, 0.35, 0.5);
        assert_eq!(px[3], 0.0);
        let want = integrate_segment(&tf, 0.25f32 as f64, 0.35f32 as f64, 0.5);
        for c in 0..3 {
            assert!((px[c] as f64 - want.color[c]).abs() < 1e-3, "{emission:?} {px:?} {want:?}");
        }
        // Sf = Sb and l → 0: continuous (colour/l and α/l tend to limits).
        let a = t.lookup(0.8, 0.8, 1e-6);
        let b = t.lookup(0.8, 0.8, 2e-6);
        assert!(a[3] > 0.0 && ((b[3] / a[3]) - 2.0).abs() < 0.05, "{a:?} {b:?}");
    }
}

#[test]
fn band_layout_matches_the_full_square_and_saves_memory() {
    let tf = ramp();
    let full = PolyTable::build(&tf, &PolyParams::new(2, 200, 0.0, 1.0, 1.0)).unwrap();
    let band = PolyTable::build(&tf, &PolyParams::new(2, 200, 0.0, 1.0, 1.0).with_max_ds(0.1)).unwrap();
    assert!(full.band().is_none());
    let b = band.band().unwrap();
    assert!(band.memory_bytes() < full.memory_bytes() / 3, "{} vs {}", band.memory_bytes(), full.memory_bytes());
    assert_eq!(band.full_memory_bytes(), full.memory_bytes());
    assert!(b >= 21);
    let mut next = lcg(3);
    for _ in 0..5000 {
        let sf = next() as f32;
        let sb = (sf + (next() as f32 - 0.5) * 0.2).clamp(0.0, 1.0);
        let l = next() as f32;
        assert_eq!(full.lookup(sf, sb, l), band.lookup(sf, sb, l), "{sf} {sb} {l}");
    }
}

#[test]
fn parts_round_trip_and_bad_parts() {
    let tf = ramp();
    let t = PolyTable::build(&tf, &PolyParams::new(4, 50, 0.0, 1.0, 1.0).with_max_ds(0.2)).unwrap();
    let alpha = AlphaTable::from_parts(t.alpha_table().x_max(), t.alpha_table().data().to_vec()).unwrap();
    let back = PolyTable::from_parts(
        t.degree(),
        t.res(),
        t.band(),
        t.s_range(),
        t.l_max(),
        t.emission(),
        t.max_color(),
        t.rho().to_vec(),
        t.coef().to_vec(),
        alpha.clone(),
    )
    .unwrap();
    assert_eq!(back, t);
    let short = t.with_values(t.rho()[1..].to_vec(), t.coef().to_vec(), alpha.clone());
    assert!(matches!(short, Err(PolyError::Length { what: "rho", .. })));
    let mut coef = t.coef().to_vec();
    coef[7] = f32::NAN;
    let nan = t.with_values(t.rho().to_vec(), coef, alpha);
    assert_eq!(nan.unwrap_err(), PolyError::NonFinite { what: "coef", index: 7 });
    assert!(AlphaTable::from_parts(0.0, vec![0, 1]).is_err());
}

#[test]
fn bad_parameters_are_errors() {
    let tf = ramp();
    let p = PolyParams::new(3, 64, 0.0, 1.0, 1.0);
    assert_eq!(PolyTable::build(&tf, &p).unwrap_err(), PolyError::Degree(3));
    assert!(PolyTable::build(&tf, &PolyParams { res: 1, degree: 2, ..p }).is_err());
    assert!(PolyTable::build(&tf, &PolyParams { s_lo: 1.0, degree: 2, ..p }).is_err());
    assert!(PolyTable::build(&tf, &PolyParams { l_max: f64::NAN, degree: 2, ..p }).is_err());
    let with_widget = TransferFunction::from_json(
        r#"{"color": [[0, 1, 1, 1]], "opacity": [[0, 0]], "unit_distance": 1,
            "widgets": [{"type": "box", "center": [0.5, 1], "width": [0.2, 1], "color": [1, 0, 0], "opacity": 2}]}"#,
    )
    .unwrap();
    assert_eq!(PolyTable::build(&with_widget, &PolyParams { degree: 2, ..p }).unwrap_err(), PolyError::Widgets(1));
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(256))]
    #[test]
    fn bounds_and_no_nan(sf in -0.2f32..1.2, sb in -0.2f32..1.2, l in 0.0f32..5.0, deg in prop::sample::select(vec![1usize, 2, 4])) {
        thread_local! {
            static TABLES: Vec<PolyTable> = [1, 2, 4].iter().map(|&d| PolyTable::build(&ramp(), &PolyParams::new(d, 64, 0.0, 1.0, 2.0)).unwrap()).collect();
        }
        let px = TABLES.with(|t| t[[1, 2, 4].iter().position(|&d| d == deg).unwrap()].shade(&Segment { s_front: sf, s_back: sb, len_world: l, ..Default::default() }));
        let mc = ramp().max_color();
        prop_assert!(px[3] >= 0.0 && px[3] <= 1.0);
        for c in 0..3 {
            prop_assert!(px[c] >= 0.0 && px[c] <= px[3] * mc[c] as f32 * 1.000_001, "{:?}", px);
        }
    }
}
