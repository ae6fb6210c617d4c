//! Transfer-function parsing, validation, serde and ParaView import.
use tet_preint::{Emission, TfError, TransferFunction};

fn err(text: &str) -> TfError {
    TransferFunction::from_json(text).unwrap_err()
}

#[test]
fn samples_parse_and_round_trip() {
    for text in [
        include_str!("../../../formats/samples/tf_mild.json"),
        include_str!("../../../formats/samples/tf_normalized.json"),
    ] {
        let t = TransferFunction::from_json(text).unwrap();
        assert_eq!(TransferFunction::from_json(&t.to_json()).unwrap(), t);
        let via_serde: TransferFunction = serde_json::from_str(&serde_json::to_string(&t).unwrap()).unwrap();
        assert_eq!(via_serde, t);
    }
}

#[test]
fn evaluation_is_linear_and_clamped() {
    let t = TransferFunction::from_json(
        r#"{"color": [[0, 0, 0, 0], [2, 1, 0.5, 0]], "opacity": [[1, 2], [3, 4]], "unit_distance": 0.5, "emission": "independent"}"#,
    )
    .unwrap();
    assert_eq!(t.color(1.0), [0.5, 0.25, 0.0]);
    assert_eq!(t.color(-5.0), [0.0; 3]);
    assert_eq!(t.color(9.0), [1.0, 0.5, 0.0]);
    assert_eq!(t.extinction(0.0), 4.0);
    assert_eq!(t.extinction(2.0), 6.0);
    assert_eq!(t.extinction(7.0), 8.0);
    assert_eq!(t.emission(), Emission::Independent);
}

#[test]
fn bad_files_name_the_entry() {
    let base = |c: &str, o: &str, u: &str| format!(r#"{{"color": {c}, "opacity": {o}, "unit_distance": {u}}}"#);
    let c = "[[0,1,1,1],[1,0,0,0]]";
    let o = "[[0,0],[1,1]]";
    assert_eq!(err(&base("[[0,1,1,1],[0,0,0,0]]", o, "1")), TfError::Duplicate { list: "color", index: 1, x: 0.0 });
    assert_eq!(
        err(&base(c, "[[0,0],[1,1],[0.5,1]]", "1")),
        TfError::Unsorted { list: "opacity", index: 2, x: 0.5, prev: 1.0 }
    );
    assert_eq!(err(&base(c, "[[0,0],[1,-1]]", "1")), TfError::Negative { list: "opacity", index: 1 });
    assert_eq!(err(&base("[]", o, "1")), TfError::Empty { list: "color" });
    assert_eq!(
        err(&base(c, "[[0,0],[1,1,2]]", "1")),
        TfError::Arity { list: "opacity", index: 1, expected: 2, found: 3 }
    );
    assert_eq!(err(&base(c, o, "0")), TfError::UnitDistance(0.0));
    assert!(matches!(err(&base(c, o, "1e999")), TfError::Json(_)));
    assert!(matches!(
        err(r#"{"color": [[0,1,1,1]], "opacity": [[0,1]], "unit_distance": 1, "colour": 2}"#),
        TfError::Json(_)
    ));
    let msg = err(&base(c, "[[0,0],[1,1],[0.5,1]]", "1")).to_string();
    assert!(msg.contains("opacity[2]"), "{msg}");
}

#[test]
fn denormalize_maps_unit_interval() {
    let t = TransferFunction::from_json(include_str!("../../../formats/samples/tf_normalized.json")).unwrap();
    let d = t.denormalize(-5.0, 5.0).unwrap();
    assert!(!d.normalized());
    assert_eq!(d.opacity_nodes()[1].x, 0.0);
    assert_eq!(d.color(5.0), t.color(1.0));
    assert!(t.denormalize(1.0, 1.0).is_err());
}

#[test]
fn paraview_preset_import() {
    let text = r#"[{"Name": "a", "RGBPoints": [-1, 0, 0, 1, 1, 1, 0, 0]},
                   {"Name": "b", "RGBPoints": [0, 0, 0, 0, 10, 1, 1, 1], "Points": [0, 0, 0.5, 0, 10, 1, 0.5, 0]}]"#;
    let a = TransferFunction::from_paraview_json(text, None, 1.0).unwrap();
    assert!(a.normalized());
    assert_eq!(a.color_nodes()[1].x, 1.0);
    assert_eq!(a.extinction(0.3), 1.0);
    let b = TransferFunction::from_paraview_json(text, Some("b"), 2.0).unwrap();
    assert_eq!(b.extinction(0.5), 0.25);
    let bad = r#"{"RGBPoints": [0, 0, 0, 0, 1, 1, 1, 1], "Points": [0, 0, 0.3, 0, 1, 1, 0.5, 0]}"#;
    assert!(matches!(TransferFunction::from_paraview_json(bad, None, 1.0), Err(TfError::Preset(_))));
    assert!(TransferFunction::from_paraview_json(text, Some("zz"), 1.0).is_err());
}

/// `extinction_knots` gives ρ at the segment's ends and opacity nodes, in
/// the segment's direction, linear between: its trapezoid sum is the exact
/// optical depth, and ρ at every knot is the TF's there — on the sample TF
/// and the held-out ones (narrow peaks, a sharp 8-node TF, steps, plateaus),
/// both directions, segments inside one piece and across many.
#[test]
fn extinction_knots_sum_to_the_exact_depth() {
    let dir = std::path::Path::new(env!("CARGO_MANIFEST_DIR"));
    let mut tfs = vec![include_str!("../../../formats/samples/tf_normalized.json").to_string()];
    for name in ["tf_peaks12", "tf_sharp8", "tf_steps", "tf_plateaus"] {
        tfs.push(std::fs::read_to_string(dir.join(format!("tests/data/heldout/{name}.json"))).unwrap());
    }
    let (mut knots, mut scratch) = (Vec::new(), Vec::new());
    let mut state = 0x9e37_79b9_7f4a_7c15u64;
    let mut unit = || {
        state = state.wrapping_mul(6_364_136_223_846_793_005).wrapping_add(1_442_695_040_888_963_407);
        (state >> 11) as f64 / (1u64 << 53) as f64
    };
    for text in &tfs {
        let tf = TransferFunction::from_json(text).unwrap().denormalize(-1.0, 3.0).unwrap();
        for k in 0..4000 {
            let (sf, sb) = (-1.5 + 5.0 * unit(), -1.5 + 5.0 * unit());
            // Every tenth segment is short (inside one piece, or on a node).
            let sb = if k % 10 == 0 { sf + (sb - sf) * 1e-3 } else { sb };
            let len = 0.01 + 3.0 * unit();
            tf.extinction_knots(sf, sb, &mut knots);
            assert!(knots.len() >= 2 && knots[0][0] == 0.0 && knots[knots.len() - 1][0] == 1.0);
            assert!(knots.windows(2).all(|w| w[0][0] < w[1][0]), "{knots:?}");
            for &[f, rho] in &knots {
                let want = tf.extinction(sf + f * (sb - sf));
                assert!((rho - want).abs() <= 1e-9 * want.abs().max(1.0), "{sf} {sb} at {f}: {rho} {want}");
            }
            let sum: f64 = knots.windows(2).map(|w| len * (w[1][0] - w[0][0]) * 0.5 * (w[0][1] + w[1][1])).sum();
            let exact = tet_preint::optical_depth_with(&tf, sf, sb, len, &mut scratch);
            assert!((sum - exact).abs() <= 1e-10 * exact.max(1e-300), "{sf} {sb} {len}: {sum} {exact}");
        }
    }
}
