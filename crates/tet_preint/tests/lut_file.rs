//! `.tetl` round trips for table3d, atlas2d and partial, the committed
//! sample, and rejection of damaged files.
use std::path::Path;
use tet_preint::table3d::{Build3d, Table3dParams};
use tet_preint::{
    bake, integrate_segment, load_shader, BakeOptions, LutError, LutFile, Method, Precision, PsiParams, Segment,
    SegmentShader, TableDomain, TransferFunction,
};

fn tf() -> TransferFunction {
    TransferFunction::from_json(include_str!("data/vtk/tf_mild.json")).unwrap()
}

/// Asserts that `sh` on the segment (Sf, Sb, l) is within 2e-3 of `exact`
/// in every channel (an f16 table's rounding); `node` is the grid node
/// (i, j, k) named on failure.
fn assert_near_exact(
    sh: &dyn SegmentShader,
    tf: &TransferFunction,
    (sf, sb, l): (f64, f64, f64),
    node: (usize, usize, usize),
) {
    let got = sh.shade(&Segment { s_front: sf as f32, s_back: sb as f32, len_world: l as f32, ..Default::default() });
    let want = integrate_segment(tf, sf, sb, l).to_array();
    let (i, j, k) = node;
    for c in 0..4 {
        assert!((got[c] as f64 - want[c]).abs() < 2e-3, "{i} {j} {k}: {got:?} vs {want:?}");
    }
}

fn opts(precision: Precision) -> BakeOptions {
    BakeOptions {
        table3d: Table3dParams {
            n_s: 12,
            n_l: 6,
            build: Build3d::default(),
            precision,
            s_axis: tet_preint::ScalarAxis::TfNodes,
        },
        atlas_planes_quarters: 16,
        psi: PsiParams { res: 32, first_moment: false, precision },
        ..Default::default()
    }
}

fn segs() -> Vec<Segment> {
    (0..50)
        .map(|i| {
            let x = i as f32 / 49.0;
            Segment { s_front: x, s_back: (x * 7.0).fract(), len_world: 2.0 * (x * 3.0).fract(), ..Default::default() }
        })
        .collect()
}

#[test]
fn every_method_round_trips_through_a_file() {
    let dir = tempfile::tempdir().unwrap();
    let domain = TableDomain::new(0.0, 1.0, 0.6, 2.0).unwrap();
    for method in [Method::Table3d, Method::Atlas2d, Method::Partial] {
        for precision in Precision::ALL {
            let lut = bake(method, &tf(), &domain, &opts(precision)).unwrap();
            let path = dir.path().join(format!("{method}-{precision}.tetl"));
            lut.write(&path).unwrap();
            let back = LutFile::read(&path).unwrap();
            assert_eq!(back, lut);
            assert_eq!(back.transfer_function().unwrap(), tf());
            let (a, b) = (load_shader(&lut, &path).unwrap(), load_shader(&back, &path).unwrap());
            assert_eq!(a.method(), method);
            for s in segs() {
                assert_eq!(a.shade(&s), b.shade(&s));
                assert!(a.shade(&s).iter().all(|v| v.is_finite()));
            }
        }
    }
    // No temporary files left beside the outputs.
    assert!(std::fs::read_dir(dir.path()).unwrap().all(|e| e.unwrap().path().extension().unwrap() == "tetl"));
}

#[test]
fn committed_sample_reads_and_matches_exact() {
    let path = Path::new(env!("CARGO_MANIFEST_DIR")).join("../../formats/samples/mild8.tetl");
    let lut = LutFile::read(&path).unwrap();
    assert_eq!(lut.header.method, "table3d");
    assert_eq!(lut.header.params["s_axis"], "tf-nodes");
    let sh = load_shader(&lut, &path).unwrap();
    // Samples on tf_mild's control points 0.3 and 0.7: steps 2, 3 and 2.
    let grid = [0.0, 0.15, 0.3, 0.3 + 0.4 / 3.0, 0.3 + 0.8 / 3.0, 0.7, 0.85, 1.0];
    // At grid nodes (l = 2k/3) the f16 exact-built table is within f16 rounding.
    let tf = lut.transfer_function().unwrap();
    for (i, j, k) in [(0, 0, 1), (3, 5, 2), (7, 4, 3), (2, 2, 3), (5, 6, 3)] {
        let (sf, sb, l) = (grid[i], grid[j], 2.0 * k as f64 / 3.0);
        assert_near_exact(sh.as_ref(), &tf, (sf, sb, l), (i, j, k));
    }
}

/// Format version 1 (uniform scalar axis, no `s_axis` in params) still
/// reads, as a uniform table.
#[test]
fn version_1_sample_reads_as_a_uniform_table() {
    let path = Path::new(env!("CARGO_MANIFEST_DIR")).join("../../formats/samples/mild8_v1.tetl");
    let bytes = std::fs::read(&path).unwrap();
    assert_eq!(u32::from_le_bytes(bytes[8..12].try_into().unwrap()), 1);
    let lut = LutFile::read(&path).unwrap();
    assert!(lut.header.params.get("s_axis").is_none());
    let t = tet_preint::Table3d::from_lut(&lut, &path).unwrap();
    assert!(t.is_uniform_axis());
    let sh = load_shader(&lut, &path).unwrap();
    let tf = lut.transfer_function().unwrap();
    for (i, j, k) in [(0, 0, 1), (3, 5, 2), (7, 4, 3), (2, 2, 3)] {
        let (sf, sb, l) = (i as f64 / 7.0, j as f64 / 7.0, 2.0 * k as f64 / 3.0);
        assert_near_exact(sh.as_ref(), &tf, (sf, sb, l), (i, j, k));
    }
}

/// A tf-nodes table whose knots section is missing or damaged gets an
/// error naming the section, not a panic.
#[test]
fn tf_nodes_table_needs_valid_knots() {
    let path = Path::new(env!("CARGO_MANIFEST_DIR")).join("../../formats/samples/mild8.tetl");
    let lut = LutFile::read(&path).unwrap();
    let mut no_axis = lut.clone();
    let i = no_axis.header.sections.iter().position(|s| s.name == "SAXIS").unwrap();
    no_axis.header.sections.remove(i);
    no_axis.payloads.remove(i);
    let e = load_shader(&no_axis, &path).err().unwrap().to_string();
    assert!(e.contains("SAXIS"), "{e}");
    let mut bad = lut.clone();
    let p = &mut bad.payloads[i];
    p[16..24].copy_from_slice(&0.9f64.to_le_bytes()); // second knot's scalar beyond the third's
    let e = load_shader(&bad, &path).err().unwrap().to_string();
    assert!(e.contains("T3D") && e.contains("knots"), "{e}");
}

fn sample_bytes() -> (Vec<u8>, std::path::PathBuf) {
    let domain = TableDomain::new(0.0, 1.0, 0.6, 2.0).unwrap();
    // A uniform axis: no SAXIS section, T3D is the last payload.
    let mut o = opts(Precision::F32);
    o.table3d.s_axis = tet_preint::ScalarAxis::Uniform;
    let lut = bake(Method::Table3d, &tf(), &domain, &o).unwrap();
    (lut.to_bytes(), "x.tetl".into())
}

#[test]
fn rejects_wrong_magic_newer_version_and_bad_checksums() {
    let (bytes, path) = sample_bytes();
    let mut b = bytes.clone();
    b[1] = b'X';
    assert!(matches!(LutFile::from_bytes(&b, &path), Err(LutError::BadMagic { .. })));
    let mut b = bytes.clone();
    b[8..12].copy_from_slice(&6u32.to_le_bytes());
    let e = LutFile::from_bytes(&b, &path).unwrap_err();
    assert!(matches!(e, LutError::NewerVersion { found: 6, supported: 5, .. }), "{e}");
    assert!(e.to_string().ends_with("x.tetl"));
    // Flip a byte in the table, the header JSON and the data payload.
    let last = bytes.len() - 3;
    for (at, section) in [(40usize, "section table"), (bytes.len() - 40 * 4, "T3D"), (last, "T3D")] {
        let mut b = bytes.clone();
        b[at] ^= 0x40;
        match LutFile::from_bytes(&b, &path) {
            Err(LutError::BadChecksum { section: s, .. }) => assert_eq!(s, section, "byte {at}"),
            other => panic!("byte {at}: {other:?}"),
        }
    }
    let mut b = bytes.clone();
    let hdr = b.windows(9).position(|w| w == b"\"writer\":").unwrap();
    b[hdr + 1] ^= 0x20;
    assert!(
        matches!(LutFile::from_bytes(&b, &path), Err(LutError::BadChecksum { section, .. }) if section == "HEADER")
    );
}

#[test]
fn every_truncation_is_an_error() {
    let (bytes, path) = sample_bytes();
    for len in (0..bytes.len()).step_by(7).chain([bytes.len() - 1]) {
        let e = LutFile::from_bytes(&bytes[..len], &path);
        assert!(e.is_err(), "truncated to {len} bytes read fine");
    }
    assert!(LutFile::from_bytes(&bytes, &path).is_ok());
}

#[test]
fn inconsistent_sections_are_rejected() {
    let domain = TableDomain::new(0.0, 1.0, 0.6, 2.0).unwrap();
    let path = Path::new("y.tetl");
    let mut lut = bake(Method::Table3d, &tf(), &domain, &opts(Precision::F32)).unwrap();
    // Dims that disagree with the payload: caught when reading.
    lut.header.sections[0].dims[0] += 1;
    let e = LutFile::from_bytes(&lut.to_bytes(), path).unwrap_err();
    assert!(matches!(&e, LutError::BadSection { section, .. } if section == "T3D"), "{e}");
    // Params that disagree with the data: caught when loading.
    let mut lut = bake(Method::Table3d, &tf(), &domain, &opts(Precision::F32)).unwrap();
    lut.header.params["n_l"] = 7.into();
    let back = LutFile::from_bytes(&lut.to_bytes(), path).unwrap();
    assert!(load_shader(&back, path).is_err());
    // Unknown method.
    let mut lut = bake(Method::Table3d, &tf(), &domain, &opts(Precision::F32)).unwrap();
    lut.header.method = "table4d".into();
    assert!(matches!(load_shader(&lut, path), Err(LutError::Method { .. })));
    // Reading a missing file names it.
    let e = LutFile::read(Path::new("/nonexistent/z.tetl")).unwrap_err();
    assert!(e.to_string().contains("/nonexistent/z.tetl"));
}

/// A data-following scalar axis (format version 3) round trips: same knots,
/// same lookups, and its knots follow the quantiles it was built from.
#[test]
fn data_axis_round_trips_through_a_file() {
    let dir = tempfile::tempdir().unwrap();
    let mut domain = TableDomain::new(0.0, 1.0, 0.6, 2.0).unwrap();
    let scalars: Vec<f64> = (0..=500).map(|i| (i as f64 / 500.0).powi(4)).collect();
    domain.s_quantiles = tet_preint::ScalarQuantiles::of(&scalars);
    let mut o = opts(Precision::F32);
    o.table3d = Table3dParams { n_s: 24, n_l: 6, ..Table3dParams::data() };
    let lut = bake(Method::Table3d, &tf(), &domain, &o).unwrap();
    let path = dir.path().join("data.tetl");
    lut.write(&path).unwrap();
    let back = LutFile::read(&path).unwrap();
    assert_eq!(back, lut);
    let (a, b) = (load_shader(&lut, &path).unwrap(), load_shader(&back, &path).unwrap());
    for s in segs() {
        assert_eq!(a.shade(&s), b.shade(&s));
    }
    let t = tet_preint::Table3d::from_lut(&back, &path).unwrap();
    assert_eq!(t.params().s_axis, tet_preint::ScalarAxis::Data);
    // Every sample is a knot, and over twice the uniform share (23 steps ×
    // 0.0625) lie below the data's median (0.5^4).
    assert_eq!(t.s_knots().len(), 24);
    let below = (0..24).filter(|&i| t.scalar_at(i) < 0.0625).count();
    assert!(below as f64 > 2.0 * 23.0 * 0.0625, "{below}");
}
