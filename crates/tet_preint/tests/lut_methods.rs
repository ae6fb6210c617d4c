//! `.tetl` round trips and damage detection for every method id (poly1/2/4,
//! biv-approx, and the untabulated exact, pt-linear and biv-exact), and the
//! committed poly2 sample.
use std::path::Path;
use tet_preint::{
    bake, load_shader, make_shader, BakeOptions, LutError, LutFile, Method, Precision, Segment, TableDomain,
    TransferFunction,
};

fn tf() -> TransferFunction {
    TransferFunction::from_json(include_str!("data/vtk/tf_mild.json")).unwrap()
}

fn tf_widgets() -> TransferFunction {
    TransferFunction::from_json(
        r#"{"color": [[0, 0.2, 0.4, 0.6], [1, 0.8, 0.3, 0.1]], "opacity": [[0, 0.1], [1, 0.9]],
            "unit_distance": 1,
            "widgets": [{"type": "gaussian", "center": [0.5, 1.0], "width": [0.1, 0.5],
                         "color": [1, 1, 0], "opacity": 3}]}"#,
    )
    .unwrap()
}

fn opts(precision_2d: Precision) -> BakeOptions {
    let mut o = BakeOptions { poly_res: 24, fb_res: 16, biv_subsegments: 3, precision_2d, ..Default::default() };
    o.table3d.n_s = 8;
    o.table3d.n_l = 4;
    o.psi.res = 16;
    o
}

fn segs() -> Vec<Segment> {
    (0..60)
        .map(|i| {
            let x = i as f32 / 59.0;
            Segment {
                s_front: x,
                s_back: (x * 7.0).fract(),
                grad_front: 2.0 * (x * 5.0).fract(),
                grad_back: 2.0 * (x * 3.0).fract(),
                len_world: 2.0 * (x * 3.0).fract(),
            }
        })
        .collect()
}

fn cases() -> Vec<(Method, TransferFunction, Precision)> {
    let mut v = vec![];
    for m in [Method::Poly1, Method::Poly2, Method::Poly4] {
        for p in [Precision::F32, Precision::F16] {
            v.push((m, tf(), p));
        }
    }
    for p in Precision::ALL {
        v.push((Method::BivApprox, tf_widgets(), p));
    }
    v.push((Method::BivExact, tf_widgets(), Precision::F32));
    v.push((Method::Exact, tf(), Precision::F32));
    v.push((Method::PtLinear, tf(), Precision::F32));
    v
}

#[test]
fn every_method_round_trips_and_matches_the_in_memory_shader() {
    let dir = tempfile::tempdir().unwrap();
    let domain = TableDomain::new(0.0, 1.0, 0.4, 2.0).unwrap();
    for (method, tf, precision) in cases() {
        let lut = bake(method, &tf, &domain, &opts(precision)).unwrap();
        let path = dir.path().join(format!("{method}-{precision}.tetl"));
        lut.write(&path).unwrap();
        let back = LutFile::read(&path).unwrap();
        assert_eq!(back, lut, "{method} {precision}");
        assert_eq!(back.transfer_function().unwrap(), tf);
        let loaded = load_shader(&back, &path).unwrap();
        let direct = make_shader(method, &tf, &domain, &opts(precision)).unwrap();
        assert_eq!(loaded.method(), method);
        for s in segs() {
            let (a, b) = (loaded.shade(&s), direct.shade(&s));
            assert_eq!(a, b, "{method} {precision} {s:?}");
            assert!(a.iter().all(|v| v.is_finite()));
        }
        // A method bakes a table exactly when it says so (`Method::is_tabulated`).
        assert_eq!(lut.header.sections.is_empty(), !method.is_tabulated(), "{method}");
        if !method.is_tabulated() {
            assert_eq!(lut.header.params["tabulated"], false);
        }
    }
}

#[test]
fn normalized_widget_tf_survives_the_header() {
    // Unbounded clip sides must stay finite (±f64::MAX) after denormalizing.
    let tf = TransferFunction::from_json(
        r#"{"normalized": true, "color": [[0, 1, 1, 1]], "opacity": [[0, 0.1]], "unit_distance": 1,
            "widgets": [{"type": "gaussian", "center": [0.5, 1.0], "width": [0.1, 0.5], "color": [1, 1, 0],
                         "opacity": 3}]}"#,
    )
    .unwrap();
    let domain = TableDomain::new(0.0, 6.0, 5.0, 2.0).unwrap();
    let lut = bake(Method::BivApprox, &tf, &domain, &opts(Precision::F32)).unwrap();
    let back = LutFile::from_bytes(&lut.to_bytes(), Path::new("w.tetl")).unwrap();
    assert_eq!(back.transfer_function().unwrap(), tf.denormalize(0.0, 6.0).unwrap());
    assert!(load_shader(&back, Path::new("w.tetl")).is_ok());
}

#[test]
fn f16_poly_files_are_half_the_size_and_stay_accurate() {
    let domain = TableDomain::new(0.0, 1.0, 0.4, 2.0).unwrap();
    // At 64² the 8 KB α table no longer dominates.
    let o = |p| BakeOptions { poly_res: 64, ..opts(p) };
    let a = bake(Method::Poly2, &tf(), &domain, &o(Precision::F32)).unwrap().to_bytes();
    let b = bake(Method::Poly2, &tf(), &domain, &o(Precision::F16)).unwrap().to_bytes();
    assert!(b.len() * 10 < a.len() * 6, "{} vs {}", b.len(), a.len());
    let exact = make_shader(Method::Exact, &tf(), &domain, &opts(Precision::F32)).unwrap();
    let half = make_shader(Method::Poly2, &tf(), &domain, &opts(Precision::F16)).unwrap();
    for s in segs().iter().filter(|s| (s.s_front - s.s_back).abs() <= 0.4) {
        let (x, y) = (exact.shade(s), half.shade(s));
        for c in 0..4 {
            assert!((x[c] - y[c]).abs() < 0.05, "{s:?}: {x:?} vs {y:?}");
        }
    }
}

/// (name, offset, length) of every section, from the section table.
fn sections_of(bytes: &[u8]) -> Vec<(String, u64, u64)> {
    let count = u32::from_le_bytes(bytes[12..16].try_into().unwrap()) as usize;
    (0..count)
        .map(|i| {
            let e = &bytes[32 + 40 * i..32 + 40 * (i + 1)];
            let name = String::from_utf8(e[..16].iter().copied().take_while(|&b| b != 0).collect()).unwrap();
            let u = |o: usize| u64::from_le_bytes(e[o..o + 8].try_into().unwrap());
            (name, u(16), u(24))
        })
        .collect()
}

#[test]
fn damage_in_any_section_of_any_method_is_detected() {
    let domain = TableDomain::new(0.0, 1.0, 0.4, 2.0).unwrap();
    let path = Path::new("d.tetl");
    for (method, tf, precision) in cases() {
        let lut = bake(method, &tf, &domain, &opts(precision)).unwrap();
        let bytes = lut.to_bytes();
        let sections = sections_of(&bytes);
        for (name, offset, len) in sections {
            for at in [offset, offset + len / 2, offset + len - 1] {
                let mut b = bytes.clone();
                b[at as usize] ^= 0x10;
                match LutFile::from_bytes(&b, path) {
                    Err(LutError::BadChecksum { section, .. }) => assert_eq!(section, name, "{method} byte {at}"),
                    other => panic!("{method} {name} byte {at}: {other:?}"),
                }
            }
        }
        for len in (0..bytes.len()).step_by(97) {
            assert!(LutFile::from_bytes(&bytes[..len], path).is_err(), "{method}: truncated to {len}");
        }
    }
}

#[test]
fn inconsistent_params_are_rejected_when_loading() {
    let domain = TableDomain::new(0.0, 1.0, 0.4, 2.0).unwrap();
    let path = Path::new("p.tetl");
    let reload = |lut: &LutFile| LutFile::from_bytes(&lut.to_bytes(), path).and_then(|l| load_shader(&l, path));
    for (method, field, value) in [
        (Method::Poly2, "res", serde_json::json!(25)),
        (Method::Poly2, "degree", serde_json::json!(4)),
        (Method::Poly4, "band", serde_json::json!(null)),
        (Method::Poly1, "precision", serde_json::json!("f16")),
        (Method::Poly1, "alpha_x_max", serde_json::json!(-1.0)),
        (Method::BivApprox, "res", serde_json::json!(17)),
        (Method::BivApprox, "subsegments", serde_json::json!(0)),
        (Method::BivApprox, "precision", serde_json::json!("unorm8")),
        (Method::Exact, "tabulated", serde_json::json!("yes")),
    ] {
        let t = if method.is_bivariate() { tf_widgets() } else { tf() };
        let mut lut = bake(method, &t, &domain, &opts(Precision::F32)).unwrap();
        lut.header.params[field] = value.clone();
        let e = reload(&lut).err().unwrap_or_else(|| panic!("{method} {field} = {value} loaded"));
        assert!(e.to_string().ends_with("p.tetl"), "{e}");
    }
    // A 1D method's file holding a TF with widgets is refused.
    let mut lut = bake(Method::Exact, &tf(), &domain, &opts(Precision::F32)).unwrap();
    lut.header.tf = serde_json::from_str(&tf_widgets().to_json()).unwrap();
    assert!(reload(&lut).err().unwrap().to_string().contains("widgets"));
    // A poly table's section swapped for another's.
    let mut lut = bake(Method::Poly2, &tf(), &domain, &opts(Precision::F32)).unwrap();
    lut.header.method = "poly1".into();
    assert!(reload(&lut).is_err());
}

#[test]
fn committed_poly2_sample_reads_and_is_close_to_exact() {
    let path = Path::new(env!("CARGO_MANIFEST_DIR")).join("../../formats/samples/mild_poly2.tetl");
    let lut = LutFile::read(&path).unwrap();
    assert_eq!(lut.header.method, "poly2");
    let sh = load_shader(&lut, &path).unwrap();
    let tf = lut.transfer_function().unwrap();
    let domain = TableDomain::new(0.0, 1.0, 0.5, 2.0).unwrap();
    let (rms, max) = tet_preint::table_error(sh.as_ref(), &tf, &tet_preint::uniform_triples(&domain, 2000, 3));
    assert!(rms < 5e-3 && max < 0.05, "{rms} {max}");
}
