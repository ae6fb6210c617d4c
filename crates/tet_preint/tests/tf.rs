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
