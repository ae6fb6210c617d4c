//! 2D widgets: JSON, culling, biv-exact against the adaptive reference,
//! biv-approx convergence in k.
use proptest::prelude::*;
use tet_preint::bivariate::{gaussian_depth, reference_segment, Seg2};
use tet_preint::{integrate_segment, BivApprox, BivExact, Emission, FbTable, TfError, TransferFunction};

const WIDGETS: &str = r#"{"color": [[0, 0.2, 0.2, 0.2], [1, 0.9, 0.8, 0.1]],
 "opacity": [[0, 0], [0.3, 0], [0.6, 0.8], [1, 0.2]], "unit_distance": 0.5,
 "widgets": [
   {"type": "box", "center": [0.2, 1.0], "width": [0.2, 1.0], "color": [1, 0, 0], "opacity": 2},
   {"type": "gaussian", "center": [0.5, 0.5], "width": [0.08, 0.3], "color": [0, 1, 0], "opacity": 3},
   {"type": "triangle", "frequency": 5, "phase": 0.25, "color": [0, 0, 1], "opacity": 1.5, "clip": [[0.1, 0.9], [0.0, 2.0]]},
   {"type": "sine", "frequency": 3, "phase": 0.0, "color": [1, 1, 0], "opacity": 1, "clip": [[0.0, 1.0], [0.5, 3.0]]}
 ]}"#;

fn full() -> TransferFunction {
    TransferFunction::from_json(WIDGETS).unwrap()
}

/// The TF with only widget `i` (1D part transparent and black).
fn only(i: usize) -> TransferFunction {
    let tf = full();
    let w = tf.widgets()[i];
    TransferFunction::from_json(r#"{"color": [[0, 0, 0, 0]], "opacity": [[0, 0]], "unit_distance": 0.5}"#)
        .unwrap()
        .with_widgets(vec![w])
        .unwrap()
}

use tet_preint::lcg_unit as lcg;

fn random_seg(next: &mut impl FnMut() -> f64) -> Seg2 {
    Seg2 { sf: next() * 1.2 - 0.1, sb: next() * 1.2 - 0.1, gf: next() * 2.5, gb: next() * 2.5, len: next() * 2.0 }
}

fn max_diff(a: tet_preint::Rgba, b: tet_preint::Rgba) -> f64 {
    (0..4).map(|k| (a.to_array()[k] - b.to_array()[k]).abs()).fold(0.0, f64::max)
}

/// tf_ramp.json (no widgets) under density, then independent emission.
fn ramp_under_both_emissions() -> [TransferFunction; 2] {
    let tf = TransferFunction::from_json(include_str!("data/vtk/tf_ramp.json")).unwrap();
    [Emission::Density, Emission::Independent].map(|e| tf.clone().with_emission(e))
}

/// The largest channel error of `with` and of `without` (biv-exact on `tf`
/// with and without its tables) against the adaptive reference, over 400
/// random segments from `seed`.
fn errors_with_and_without(tf: &TransferFunction, with: &BivExact, without: &BivExact, seed: u64) -> (f64, f64) {
    let mut next = lcg(seed);
    let (mut e_with, mut e_without) = (0.0f64, 0.0f64);
    for _ in 0..400 {
        let seg = random_seg(&mut next);
        let r = reference_segment(tf, &seg, 1e-12);
        e_with = e_with.max(max_diff(with.integrate(&seg), r));
        e_without = e_without.max(max_diff(without.integrate(&seg), r));
    }
    (e_with, e_without)
}

#[test]
fn json_round_trip_and_old_files_stay_valid() {
    let tf = full();
    assert_eq!(tf.widgets().len(), 4);
    let back = TransferFunction::from_json(&tf.to_json()).unwrap();
    assert_eq!(back, tf);
    let old = TransferFunction::from_json(include_str!("data/vtk/tf_ramp.json")).unwrap();
    assert!(old.widgets().is_empty());
    assert!(!old.to_json().contains("widgets"));
}

#[test]
fn json_errors_name_the_widget_and_field() {
    let cases = [
        (
            r#"{"type": "box", "center": [0, 0], "width": [0.1, -1], "color": [1, 0, 0], "opacity": 1}"#,
            "widgets[1].width: must be positive",
        ),
        (r#"{"type": "blob", "color": [1, 0, 0], "opacity": 1}"#, "widgets[1].type: unknown widget type"),
        (r#"{"type": "gaussian", "width": [0.1, 1], "color": [1, 0, 0], "opacity": 1}"#, "widgets[1].center: missing"),
        (
            r#"{"type": "sine", "frequency": 0, "color": [1, 0, 0], "opacity": 1}"#,
            "widgets[1].frequency: must be positive",
        ),
        (
            r#"{"type": "triangle", "frequency": 2, "color": [1, 0], "opacity": 1}"#,
            "widgets[1].color: expected 3 numbers",
        ),
        (r#"{"type": "triangle", "frequency": 2, "color": [1, 0, 0], "opacity": -1}"#, "widgets[1].opacity: negative"),
        (
            r#"{"type": "triangle", "frequency": 2, "color": [1, 0, 0], "opacity": 1, "clip": [[1, 0], [0, 1]]}"#,
            "widgets[1].clip: row 0",
        ),
        (
            r#"{"type": "box", "center": [0, 0], "width": [1, 1], "phase": 1, "color": [1, 0, 0], "opacity": 1}"#,
            "widgets[1].phase: not a field",
        ),
    ];
    for (w, want) in cases {
        let text = format!(
            r#"{{"color": [[0, 1, 1, 1]], "opacity": [[0, 1]], "unit_distance": 1, "widgets": [
                {{"type": "box", "center": [0, 0], "width": [1, 1], "color": [1, 0, 0], "opacity": 1}}, {w}]}}"#
        );
        let err = TransferFunction::from_json(&text).unwrap_err();
        assert!(matches!(err, TfError::Widget { index: 1, .. }), "{err}");
        assert!(err.to_string().starts_with(want), "{err} (wanted {want})");
    }
    // Unknown fields inside a widget are refused too.
    let e = TransferFunction::from_json(
        r#"{"color": [[0, 1, 1, 1]], "opacity": [[0, 1]], "unit_distance": 1, "widgets": [{"type": "box", "colour": [1,0,0]}]}"#,
    )
    .unwrap_err();
    assert!(e.to_string().contains("colour"), "{e}");
}

#[test]
fn no_widgets_is_the_1d_exact_integrator() {
    let mut next = lcg(1);
    for tf in ramp_under_both_emissions() {
        let biv = BivExact::new(tf.clone());
        for _ in 0..500 {
            let seg = random_seg(&mut next);
            let want = integrate_segment(&tf, seg.sf, seg.sb, seg.len);
            assert!(max_diff(biv.integrate(&seg), want) < 1e-12);
        }
    }
}

#[test]
fn reference_agrees_with_exact_in_1d() {
    let mut next = lcg(2);
    for tf in ramp_under_both_emissions() {
        for _ in 0..200 {
            let seg = random_seg(&mut next);
            let d = max_diff(reference_segment(&tf, &seg, 1e-12), integrate_segment(&tf, seg.sf, seg.sb, seg.len));
            assert!(d < 1e-10, "{:?} {seg:?}: {d}", tf.emission());
        }
    }
}

#[test]
fn biv_exact_matches_reference_per_widget_and_combined() {
    let mut next = lcg(3);
    let mut tfs: Vec<(String, TransferFunction)> = (0..4).map(|i| (format!("widget {i}"), only(i))).collect();
    tfs.push(("all + 1D".into(), full()));
    for (name, tf) in tfs {
        for emission in [Emission::Density, Emission::Independent] {
            let tf = tf.clone().with_emission(emission);
            // Closed forms and quadrature only: Song et al.'s (2009) Gaussian table
            // (emission-only) has its own bound in gauss_erf_table_….
            let biv = BivExact::with_gauss_table(tf.clone(), None);
            let mut worst = 0.0f64;
            for _ in 0..300 {
                let seg = random_seg(&mut next);
                let d = max_diff(biv.integrate(&seg), reference_segment(&tf, &seg, 1e-12));
                worst = worst.max(d);
            }
            assert!(worst < 1e-9, "{name} {emission:?}: max |Δ| = {worst}");
        }
    }
}

#[test]
fn single_widget_density_is_c_times_alpha() {
    let tf = only(1);
    let biv = BivExact::new(tf);
    let px = biv.integrate(&Seg2 { sf: 0.3, sb: 0.7, gf: 0.2, gb: 0.9, len: 1.5 });
    assert!(px.alpha > 0.1);
    assert!(px.color[0].abs() < 1e-15 && (px.color[1] - px.alpha).abs() < 1e-14 && px.color[2].abs() < 1e-15);
}

#[test]
fn stability_cases() {
    let tf = full();
    let biv = BivExact::new(tf.clone());
    let approx = BivApprox::build(tf.clone(), 64, 8).unwrap();
    let segs = [
        Seg2 { sf: 0.5, sb: 0.5, gf: 0.5, gb: 0.5, len: 1.0 }, // Sf = Sb, g constant
        Seg2 { sf: 0.5, sb: 0.5, gf: 0.0, gb: 0.0, len: 1.0 }, // g = 0
        Seg2 { sf: 0.2, sb: 0.8, gf: 1.0, gb: 1.0, len: 1e-12 }, // l → 0
        Seg2 { sf: 0.4, sb: 0.6, gf: 0.4, gb: 0.6, len: 1e6 }, // ρ·l huge
        Seg2 { sf: 0.0, sb: 0.05, gf: 3.0, gb: 3.5, len: 1.0 }, // (almost) zero extinction
    ];
    for seg in segs {
        for px in [biv.integrate(&seg), approx.integrate(&seg)] {
            assert!(px.to_array().iter().all(|v| v.is_finite()), "{seg:?}: {px:?}");
            assert!(px.alpha >= 0.0 && px.alpha <= 1.0);
        }
        let r = reference_segment(&tf, &seg, 1e-12);
        assert!(max_diff(biv.integrate(&seg), r) < 1e-9, "{seg:?}");
    }
    // Only the (unbounded) Gaussian's far tail reaches there.
    assert!(biv.integrate(&segs[4]).alpha < 1e-20);
    assert_eq!(biv.integrate(&segs[3]).alpha, 1.0);
    let nan = Seg2 { sf: f64::NAN, ..segs[0] };
    assert_eq!(biv.integrate(&nan).alpha, 0.0);
}

#[test]
fn gaussian_depth_closed_form_matches_quadrature() {
    let tf = only(1);
    let w = tf.widgets()[0];
    let mut next = lcg(4);
    for _ in 0..2000 {
        let mut seg = random_seg(&mut next);
        if next() < 0.2 {
            seg.sb = seg.sf + 1e-7 * (next() - 0.5); // tiny k: the GL branch
            seg.gb = seg.gf;
        }
        let (x0, x1) = (next() * 0.5, 0.5 + next() * 0.5);
        let got = gaussian_depth(&w, &seg, x0, x1);
        // Composite Simpson with 20000 panels.
        let n = 20_000;
        let h = (x1 - x0) / n as f64;
        let f = |x: f64| w.shape_unclipped(seg.sf + x * (seg.sb - seg.sf), seg.gf + x * (seg.gb - seg.gf));
        let mut want = f(x0) + f(x1);
        for i in 1..n {
            want += f(x0 + i as f64 * h) * if i % 2 == 1 { 4.0 } else { 2.0 };
        }
        want *= h / 3.0;
        assert!((got - want).abs() < 1e-11 * (1.0 + want), "{seg:?} [{x0}, {x1}]: {got} vs {want}");
    }
}

#[test]
fn biv_approx_converges_with_subdivision() {
    let tf = full();
    let mut next = lcg(5);
    let segs: Vec<Seg2> = (0..300).map(|_| random_seg(&mut next)).collect();
    let refs: Vec<_> = segs.iter().map(|s| reference_segment(&tf, s, 1e-12)).collect();
    let mut errs = Vec::new();
    for k in [1, 4, 16, 64] {
        let a = BivApprox::build(tf.clone(), 256, k).unwrap();
        let e = segs.iter().zip(&refs).map(|(s, r)| max_diff(a.integrate(s), *r)).fold(0.0, f64::max);
        errs.push(e);
    }
    assert!(errs[3] < errs[1] && errs[1] < errs[0], "{errs:?}");
    // At least first-order convergence overall (box edges and clips are
    // discontinuities, where subdivision converges like 1/k).
    assert!(errs[3] < errs[0] / 10.0, "{errs:?}");
}

#[test]
fn fb_table_parts_and_limits() {
    let t = FbTable::build(Emission::Density, 33).unwrap();
    // α_f = α_b = 0: F = B = 0; constant depth a: F + B = α.
    assert_eq!(t.lookup(0.0, 0.0), (0.0, 0.0));
    let (f, b) = t.lookup(0.5, 0.5);
    assert!((f + b - 0.5).abs() < 1e-6);
    let back = FbTable::from_parts(Emission::Density, 33, t.f().to_vec(), t.b().to_vec()).unwrap();
    assert_eq!(back, t);
    assert!(FbTable::from_parts(Emission::Density, 33, t.f()[1..].to_vec(), t.b().to_vec()).is_none());
    assert!(FbTable::build(Emission::Density, 1).is_none());
    assert!(BivApprox::new(full().with_emission(Emission::Independent), t, 4).is_none());
}

#[test]
fn band_frequency_limit() {
    let tf = full();
    // Triangle f = 5, sine f = 3: limits 1/0.25 = 4 flags the triangle only.
    let v = tf.band_frequency_violations(0.25);
    assert_eq!(v.len(), 1);
    assert_eq!(v[0].0, 2);
    assert!(tf.band_frequency_violations(0.1).is_empty());
}

#[test]
fn culling_examples() {
    let tf = full();
    // Below every widget support in g? Box g ∈ [0.5, 1.5]; Gaussian is unbounded: never culled.
    assert!(!tf.cell_is_invisible([0.0, 0.05], [3.0, 3.5]));
    let no_gauss = TransferFunction::from_json(WIDGETS)
        .unwrap()
        .with_widgets(full().widgets().iter().enumerate().filter(|(i, _)| *i != 1).map(|(_, w)| *w).collect())
        .unwrap();
    // s ∈ [0, 0.05], g ∈ [3.5, 4]: 1D opacity 0 there, box (s ≥ 0.1), triangle (s ≥ 0.1), sine (g ≤ 3) miss it.
    assert!(no_gauss.cell_is_invisible([0.0, 0.05], [3.5, 4.0]));
    assert!(!no_gauss.cell_is_invisible([0.0, 0.05], [2.5, 4.0]));
    // Independent emission: the 1D colour emits where the opacity is 0.
    assert!(!no_gauss.clone().with_emission(Emission::Independent).cell_is_invisible([0.0, 0.05], [3.5, 4.0]));
    assert!(!no_gauss.cell_is_invisible([f64::NAN, 0.05], [3.5, 4.0]));
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(400))]
    /// Never cull a visible cell: if a box is culled, ρ and the emission are 0
    /// at random points of it and biv-exact gives nothing for a segment in it.
    #[test]
    fn culling_is_conservative(s0 in -0.2f64..1.2, ds in 0.0f64..0.4, g0 in 0.0f64..4.0, dg in 0.0f64..1.0,
                               drop in 0usize..4, indep in any::<bool>(), pts in prop::collection::vec((0.0f64..=1.0, 0.0f64..=1.0), 8)) {
        let widgets: Vec<_> = full().widgets().iter().enumerate().filter(|(i, _)| *i != drop).map(|(_, w)| *w).collect();
        let mut tf = TransferFunction::from_json(WIDGETS).unwrap().with_widgets(widgets).unwrap();
        if indep { tf = tf.with_emission(Emission::Independent); }
        let (s_range, g_range) = ([s0, s0 + ds], [g0, g0 + dg]);
        if tf.cell_is_invisible(s_range, g_range) {
            for (a, b) in pts {
                let (s, g) = (s0 + a * ds, g0 + b * dg);
                prop_assert_eq!(tf.extinction2(s, g), 0.0);
                prop_assert_eq!(tf.emission2(s, g), [0.0; 3]);
            }
            let seg = Seg2 { sf: s0, sb: s0 + ds, gf: g0 + dg, gb: g0, len: 1.0 };
            prop_assert_eq!(BivExact::new(tf).integrate(&seg).to_array(), [0.0; 4]);
        }
    }
}

/// The Gaussian table of Song et al., "Bivariate Transfer Functions on
/// Unstructured Grids", 2009 (emission-only model): the window integral
/// against 400-panel Gauss–Legendre over fixed-seed random (P, u₀, u₁),
/// and `biv-exact` using it against the adaptive reference. Measured
/// maxima (default 192 × 769 table): window 1.7e-7 relative to max(W, 1),
/// segment 1.1e-7 (quadrature path: 4e-15); printed with --nocapture.
#[test]
fn gauss_erf_table_matches_quadrature_and_reference() {
    use tet_preint::biv_tables::{erf_diff, window_quadrature, GaussErfTable, DEFAULT_ERF_TABLE, U_MAX};
    let (n_p, n_u, p_max) = DEFAULT_ERF_TABLE;
    let t = GaussErfTable::build(n_p, n_u, p_max);
    let mut next = lcg(41);
    let mut worst = 0.0f64;
    for _ in 0..3000 {
        let p = (next() * (p_max + 1.0).ln()).exp() - 1.0;
        let u0 = next() * 16.0 - 8.0;
        let u1 = u0 + next() * 10.0;
        let t_seg = (-p * erf_diff(u0.clamp(-U_MAX, U_MAX), u1.clamp(-U_MAX, U_MAX))).exp();
        let got = t.window(p, u0, u1, t_seg).unwrap();
        let want = window_quadrature(p, u0, u1, 600);
        worst = worst.max((got - want).abs() / want.max(1.0));
    }
    println!("gauss erf table {}x{} ({} KiB): window max rel error {worst:.2e}", n_p, n_u, t.memory_bytes() / 1024);
    assert!(worst < 3e-7, "{worst:e}");

    // biv-exact with the table against the adaptive reference, independent
    // emission, the Gaussian alone over a transparent black 1D part (so the
    // table applies to every piece inside the support).
    let tf = only(1).with_emission(Emission::Independent);
    let with = BivExact::new(tf.clone());
    assert!(with.gauss_table().is_some());
    let without = BivExact::with_gauss_table(tf.clone(), None);
    let (e_with, e_without) = errors_with_and_without(&tf, &with, &without, 7);
    println!("biv-exact vs reference, Gaussian emission-only: table {e_with:.2e}, quadrature {e_without:.2e}");
    assert!(e_with < 3e-7 && e_without < 1e-12, "{e_with:e} {e_without:e}");
}

/// Song et al.'s (2009) triangle- and sine-wave tables (emission-only model), default
/// sizes (columns from the frequency-limit rule at ε = 1%): the window
/// integral against 600-panel Gauss–Legendre over fixed-seed random
/// (P, φ₀, φ₁), and `biv-exact` using them against the adaptive reference
/// on the triangle and sine widgets alone. Measured maxima printed with
/// --nocapture; the bounds are those maxima rounded up.
#[test]
fn band_tables_match_quadrature_and_reference() {
    use tet_preint::biv_tables::{band_window_quadrature, BandKind, BandTable};
    use tet_preint::BivTables;
    for (kind, widget, win_bound, seg_bound) in [
        (BandKind::Triangle, 2usize, WIN_BOUND_TRI, SEG_BOUND_TRI),
        (BandKind::Sine, 3, WIN_BOUND_SINE, SEG_BOUND_SINE),
    ] {
        let t = BandTable::default_for(kind);
        let span = kind.period_phase();
        let mut next = lcg(43);
        let mut worst = 0.0f64;
        for _ in 0..3000 {
            let p = (next() * (t.p_max() + 1.0).ln()).exp() - 1.0;
            let a = next() * span;
            let b = a + next() * (span - a);
            let t_seg = (-p * kind.depth_between(a, b)).exp();
            let got = t.window(p, a, b, t_seg).unwrap();
            let want = band_window_quadrature(kind, p, a, b, 600);
            worst = worst.max((got - want).abs() / want.max(1.0));
        }
        let (n_p, n_phase) = t.dims();
        println!("{kind:?} table {n_p}x{n_phase} ({} KiB): window max rel error {worst:.2e}", t.memory_bytes() / 1024);
        assert!(worst < win_bound, "{kind:?} window {worst:e}");

        let tf = only(widget).with_emission(Emission::Independent);
        let with = BivExact::new(tf.clone());
        assert!(match kind {
            BandKind::Triangle => with.tables().triangle.is_some(),
            BandKind::Sine => with.tables().sine.is_some(),
        });
        let without = BivExact::with_tables(tf.clone(), BivTables::default());
        let (e_with, e_without) = errors_with_and_without(&tf, &with, &without, 8);
        println!("biv-exact vs reference, {kind:?} emission-only: table {e_with:.2e}, quadrature {e_without:.2e}");
        assert!(e_with < seg_bound && e_without < 1e-10, "{kind:?} {e_with:e} {e_without:e}");
    }
}
// Measured (default tables): triangle window 5.83e-7, segment 2.96e-8;
// sine window 2.32e-7, segment 2.47e-7; quadrature path ≤ 1.0e-11.
const WIN_BOUND_TRI: f64 = 1e-6;
const WIN_BOUND_SINE: f64 = 5e-7;
const SEG_BOUND_TRI: f64 = 5e-8;
const SEG_BOUND_SINE: f64 = 5e-7;
