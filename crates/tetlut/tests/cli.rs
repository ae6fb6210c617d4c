//! `tetlut` end to end: the built binary on the sample bundle and TFs, small
//! resolutions.
use std::io::Write;
use std::path::{Path, PathBuf};
use std::process::{Command, Output, Stdio};

const SAMPLES: &str = concat!(env!("CARGO_MANIFEST_DIR"), "/../../formats/samples");

fn sample(name: &str) -> String {
    format!("{SAMPLES}/{name}")
}

fn tetlut(args: &[&str], stdin: &str) -> Output {
    let mut child = Command::new(env!("CARGO_BIN_EXE_tetlut"))
        .args(args)
        .stdin(Stdio::piped())
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .expect("tetlut runs");
    // The command may exit before reading its input (argument errors).
    let _ = child.stdin.take().unwrap().write_all(stdin.as_bytes());
    child.wait_with_output().unwrap()
}

fn ok(out: &Output) -> String {
    assert!(out.status.success(), "stderr: {}", String::from_utf8_lossy(&out.stderr));
    String::from_utf8(out.stdout.clone()).unwrap()
}

fn fails(out: &Output, code: i32, needle: &str) {
    let err = String::from_utf8_lossy(&out.stderr);
    assert_eq!(out.status.code(), Some(code), "stderr: {err}");
    assert!(err.contains(needle), "expected {needle:?} in: {err}");
}

/// What the bake tests pass: an output `x.tetl` in `dir`, the sample TF
/// (tf_mild.json) and the sample bundle (cube5.tetb).
fn bake_paths(dir: &Path) -> (String, String, String) {
    (dir.join("x.tetl").to_string_lossy().into_owned(), sample("tf_mild.json"), sample("cube5.tetb"))
}

fn rows(text: &str) -> Vec<Vec<f64>> {
    text.lines().map(|l| l.split_whitespace().map(|x| x.parse().unwrap()).collect()).collect()
}

fn widget_tf(dir: &Path) -> PathBuf {
    let p = dir.join("tf_widgets.json");
    std::fs::write(
        &p,
        r#"{"normalized": true, "color": [[0, 0.2, 0.4, 0.6], [1, 0.8, 0.3, 0.1]], "opacity": [[0, 0.1], [1, 0.5]],
            "unit_distance": 1,
            "widgets": [{"type": "gaussian", "center": [0.5, 1.0], "width": [0.1, 0.5], "color": [1, 1, 0],
                         "opacity": 2}]}"#,
    )
    .unwrap();
    p
}

#[test]
fn probe_exact_matches_library_bit_for_bit() {
    let tf_path = sample("tf_mild.json");
    let out = tetlut(&["probe", "--tf", &tf_path], "0 1 0.5\n\n# comment\n0.2 0.2 1\n");
    let tf = tet_preint::TransferFunction::from_json(&std::fs::read_to_string(&tf_path).unwrap()).unwrap();
    let r = rows(&ok(&out));
    assert_eq!(r.len(), 2);
    assert_eq!(r[0], tet_preint::integrate_segment(&tf, 0.0, 1.0, 0.5).to_array());
    assert_eq!(r[1], tet_preint::integrate_segment(&tf, 0.2, 0.2, 1.0).to_array());
}

#[test]
fn probe_errors_name_the_line_and_exit_3() {
    let tf = sample("tf_mild.json");
    fails(&tetlut(&["probe", "--tf", &tf], "0 1 0.5\n0 1\n"), 3, "line 2");
    fails(&tetlut(&["probe", "--tf", &tf], "0 1 0.5\n0 x 1\n"), 3, "line 2");
    fails(&tetlut(&["probe", "--tf", &tf], "0 1 -1\n"), 3, "line 1");
    let norm = sample("tf_normalized.json");
    fails(&tetlut(&["probe", "--tf", &norm], "0 1 1\n"), 2, "--range");
    ok(&tetlut(&["probe", "--tf", &norm, "--range", "-5,5"], "0 1 1\n"));
    // Tables need a length range.
    fails(&tetlut(&["probe", "--tf", &tf, "--method", "table3d"], ""), 2, "--max-len");
    fails(&tetlut(&["probe", "--tf", &tf, "--method", "table9d"], ""), 2, "unknown method");
}

#[test]
fn probe_every_method_on_the_fly_is_close_to_exact() {
    let tf = sample("tf_mild.json");
    let segs = "0.1 0.3 0.5\n0.5 0.5 1.5\n0.9 0.6 0.2\n";
    let exact = rows(&ok(&tetlut(&["probe", "--tf", &tf], segs)));
    for (m, res) in [
        ("pt-linear", None),
        ("table3d", Some("32")),
        ("atlas2d", Some("32")),
        ("partial", Some("128")),
        ("poly1", Some("64")),
        ("poly2", Some("64")),
        ("poly4", Some("64")),
        ("biv-exact", None),
        ("biv-approx", Some("64")),
    ] {
        let mut args = vec!["probe", "--tf", &tf, "--method", m, "--range", "0,1", "--max-len", "2"];
        if let Some(r) = res {
            args.extend(["--res", r]);
        }
        let got = rows(&ok(&tetlut(&args, segs)));
        let tol = if m == "pt-linear" { 0.1 } else { 0.02 };
        for (g, e) in got.iter().zip(&exact) {
            for c in 0..4 {
                assert!((g[c] - e[c]).abs() < tol, "{m}: {g:?} vs {e:?}");
            }
        }
    }
}

#[test]
fn bake_then_probe_and_show_every_table_method() {
    let dir = tempfile::tempdir().unwrap();
    let bundle = sample("cube5.tetb");
    let tf = sample("tf_normalized.json");
    let wtf = widget_tf(dir.path());
    let segs = "1 2 0.5 0.5 1.5\n3 3 1 1 1\n";
    for (m, res, tf) in [
        ("table3d", "16", &tf),
        ("table3d", "16x16x8", &tf),
        ("atlas2d", "16", &tf),
        ("partial", "64", &tf),
        ("poly1", "32", &tf),
        ("poly2", "32", &tf),
        ("poly4", "32", &tf),
        ("biv-approx", "32", &wtf.to_string_lossy().into_owned()),
    ] {
        let lut = dir.path().join(format!("{m}-{}.tetl", res.replace('x', "_")));
        let lut_s = lut.to_string_lossy().into_owned();
        let out =
            tetlut(&["bake", "--bundle", &bundle, "--tf", tf, "--method", m, "--res", res, "-o", &lut_s, "--json"], "");
        let v: serde_json::Value = serde_json::from_str(&ok(&out)).unwrap();
        assert_eq!(v["method"], m);
        assert!(v["memory_bytes"].as_u64().unwrap() > 0);
        assert!(v["memory_bytes"].as_u64() <= v["full_domain_memory_bytes"].as_u64());
        assert!(v["bake_seconds"].as_f64().unwrap() >= 0.0);
        // probe --lut equals probe --tf --method on the fly over the same domain.
        let a = ok(&tetlut(&["probe", "--lut", &lut_s], segs));
        let b = ok(&tetlut(&["probe", "--tf", tf, "--method", m, "--bundle", &bundle, "--res", res], segs));
        assert_eq!(a, b, "{m}");
        assert_eq!(rows(&a).len(), 2);
        let png = dir.path().join(format!("{m}.png"));
        let text = ok(&tetlut(&["show", &lut_s, "-o", &png.to_string_lossy(), "--slices", "3"], ""));
        assert!(text.contains("wrote"));
        let bytes = std::fs::read(&png).unwrap();
        assert_eq!(&bytes[1..4], b"PNG");
    }
}

#[test]
fn bake_reports_the_band_saving_and_handles_untabulated_methods() {
    let dir = tempfile::tempdir().unwrap();
    let tf = sample("tf_mild.json");
    let out = dir.path().join("band.tetl");
    let o = out.to_string_lossy().into_owned();
    let base = ["bake", "--tf", &tf, "--range", "0,1", "--max-len", "2", "--method", "table3d", "--res", "32"];
    let banded: serde_json::Value =
        serde_json::from_str(&ok(&tetlut(&[&base[..], &["--max-ds", "0.1", "-o", &o, "--json"]].concat(), "")))
            .unwrap();
    assert!(banded["memory_saved_fraction"].as_f64().unwrap() > 0.5, "{banded}");
    let full: serde_json::Value = serde_json::from_str(&ok(&tetlut(
        &[&base[..], &["--max-ds", "0.1", "--full-domain", "-o", &o, "--json"]].concat(),
        "",
    )))
    .unwrap();
    assert_eq!(full["memory_saved_fraction"].as_f64().unwrap(), 0.0);
    // Text output names the saving too.
    let text = ok(&tetlut(&[&base[..], &["--max-ds", "0.1", "-o", &o]].concat(), ""));
    assert!(text.contains("saved") && text.contains("bake time"), "{text}");
    // And which lookup the table chose (formats/lut.md, "Lookup").
    assert!(text.contains("lookup      trilinear") || text.contains("lookup      optical-depth"), "{text}");
    let gap = banded["reconstruction_gap"].as_f64().unwrap();
    let want = if gap > 1e-4 { "optical-depth" } else { "trilinear" };
    assert_eq!(banded["lookup"].as_str(), Some(want), "{banded}");
    // biv-exact stores the TF only; show refuses it clearly.
    let wtf = widget_tf(dir.path());
    let be = dir.path().join("be.tetl");
    let be_s = be.to_string_lossy().into_owned();
    let text = ok(&tetlut(
        &["bake", "--tf", &wtf.to_string_lossy(), "--range", "0,1", "--method", "biv-exact", "-o", &be_s],
        "",
    ));
    assert!(text.contains("nothing tabulated"), "{text}");
    fails(&tetlut(&["show", &be_s, "-o", &dir.path().join("x.png").to_string_lossy()], ""), 3, "tabulates nothing");
    let r = rows(&ok(&tetlut(&["probe", "--lut", &be_s], "0.5 0.5 1 1 1\n")));
    assert!(r[0][3] > 0.5, "{r:?}");
}

#[test]
fn bake_errors_have_clear_messages_and_exit_codes() {
    let dir = tempfile::tempdir().unwrap();
    let (o, tf, bundle) = bake_paths(dir.path());
    // Missing bundle, bad TF, unknown method, usage.
    fails(
        &tetlut(&["bake", "--bundle", "/nonexistent/b.tetb", "--tf", &tf, "--method", "table3d", "-o", &o], ""),
        3,
        "/nonexistent/b.tetb",
    );
    let bad = dir.path().join("bad.json");
    std::fs::write(&bad, r#"{"color": [[0, 1, 1, 1]], "opacity": [[0.5, 1], [0.2, 1]], "unit_distance": 1}"#).unwrap();
    // A TF file with invalid contents is a usage error (as `tetview render --tf`).
    fails(
        &tetlut(&["bake", "--bundle", &bundle, "--tf", &bad.to_string_lossy(), "--method", "table3d", "-o", &o], ""),
        2,
        "opacity[1]",
    );
    fails(
        &tetlut(&["bake", "--bundle", &bundle, "--tf", &tf, "--method", "table4d", "-o", &o], ""),
        2,
        "unknown method",
    );
    fails(&tetlut(&["bake", "--tf", &tf, "--method", "table3d", "-o", &o], ""), 2, "--bundle");
    fails(
        &tetlut(&["bake", "--bundle", &bundle, "--tf", &tf, "--method", "poly2", "--planes", "4n", "-o", &o], ""),
        2,
        "--planes",
    );
    fails(
        &tetlut(&["bake", "--bundle", &bundle, "--tf", &tf, "--method", "table3d", "--res", "8x9x4", "-o", &o], ""),
        2,
        "--res",
    );
    // Cannot bake: widgets for a 1D method, a too large table, unorm poly.
    let wtf = widget_tf(dir.path());
    fails(
        &tetlut(&["bake", "--bundle", &bundle, "--tf", &wtf.to_string_lossy(), "--method", "exact", "-o", &o], ""),
        6,
        "biv-exact",
    );
    fails(
        &tetlut(&["bake", "--bundle", &bundle, "--tf", &tf, "--method", "table3d", "--res", "9000", "-o", &o], ""),
        6,
        "n_s",
    );
    fails(
        &tetlut(
            &["bake", "--bundle", &bundle, "--tf", &tf, "--method", "poly2", "--precision", "unorm8", "-o", &o],
            "",
        ),
        6,
        "unorm8",
    );
    // Output directory missing.
    fails(
        &tetlut(
            &[
                "bake",
                "--bundle",
                &bundle,
                "--tf",
                &tf,
                "--method",
                "poly1",
                "--res",
                "8",
                "-o",
                "/nonexistent/dir/x.tetl",
            ],
            "",
        ),
        5,
        "/nonexistent/dir",
    );
}

#[test]
fn corrupted_lut_is_refused_by_probe_and_show() {
    let dir = tempfile::tempdir().unwrap();
    let lut = dir.path().join("c.tetl");
    let l = lut.to_string_lossy().into_owned();
    ok(&tetlut(
        &[
            "bake",
            "--tf",
            &sample("tf_mild.json"),
            "--range",
            "0,1",
            "--max-len",
            "1",
            "--method",
            "poly2",
            "--res",
            "16",
            "-o",
            &l,
        ],
        "",
    ));
    let mut bytes = std::fs::read(&lut).unwrap();
    let n = bytes.len();
    bytes[n - 5] ^= 0x55;
    std::fs::write(&lut, &bytes).unwrap();
    fails(&tetlut(&["probe", "--lut", &l], "0 1 1\n"), 3, "corrupt");
    fails(&tetlut(&["show", &l, "-o", &dir.path().join("c.png").to_string_lossy()], ""), 3, "corrupt");
    std::fs::write(&lut, b"not a table").unwrap();
    fails(&tetlut(&["probe", "--lut", &l], "0 1 1\n"), 3, "not a tetkit lookup table");
    // The committed samples read.
    let r = rows(&ok(&tetlut(&["probe", "--lut", &sample("mild_poly2.tetl")], "0.2 0.4 1\n")));
    assert_eq!(r.len(), 1);
    ok(&tetlut(&["show", &sample("mild8.tetl"), "-o", &dir.path().join("m.png").to_string_lossy()], ""));
}

#[test]
fn bench_quick_writes_table_json_and_plot() {
    let dir = tempfile::tempdir().unwrap();
    let png = dir.path().join("p.png");
    let js = dir.path().join("b.json");
    let out = tetlut(
        &[
            "bench",
            "--bundle",
            &sample("cube5.tetb"),
            "--tf",
            &sample("tf_normalized.json"),
            "--quick",
            "--samples",
            "2000",
            "--methods",
            "pt-linear,table3d,poly2,partial",
            "-o",
            &png.to_string_lossy(),
            "--json",
            &js.to_string_lossy(),
        ],
        "",
    );
    let text = ok(&out);
    assert!(text.contains("| table3d |") && text.contains("| poly2 |"), "{text}");
    let v: serde_json::Value = serde_json::from_str(&std::fs::read_to_string(&js).unwrap()).unwrap();
    let rows = v["rows"].as_array().unwrap();
    assert_eq!(rows.len(), 1 + 2 + 2 + 2);
    for r in rows {
        for e in r["errors"].as_array().unwrap() {
            let (rms, max) = (e["rms"].as_f64().unwrap(), e["max"].as_f64().unwrap());
            assert!(rms <= max && max < 0.2, "{r}");
        }
    }
    assert_eq!(&std::fs::read(&png).unwrap()[1..4], b"PNG");
    // --paper --quick prints the three markdown tables.
    let text = ok(&tetlut(
        &["bench", "--bundle", &sample("cube5.tetb"), "--tf", &sample("tf_mild.json"), "--paper", "--quick"],
        "",
    ));
    for t in ["Table 1", "Table 2", "Table 4", "| poly4 |"] {
        assert!(text.contains(t), "{t} missing: {text}");
    }
}

/// The exit codes every tetkit program shares (tet_cli::ExitKind), for the
/// failures `tetprep` and `tetview` test the same way in their tests/cli.rs.
#[test]
fn exit_codes_are_the_shared_ones() {
    let dir = tempfile::tempdir().unwrap();
    let (o, tf, bundle) = bake_paths(dir.path());
    let bake = |bundle: &str, tf: &str, out: &str| {
        tetlut(&["bake", "--bundle", bundle, "--tf", tf, "--method", "poly1", "--res", "8", "-o", out], "")
    };
    // 3: a truncated bundle (as `tetprep info` and `tetview render`), a missing TF file.
    let cut = dir.path().join("cut.tetb");
    let bytes = std::fs::read(&bundle).unwrap();
    std::fs::write(&cut, &bytes[..bytes.len() / 2]).unwrap();
    fails(&bake(&cut.to_string_lossy(), &tf, &o), 3, "cut.tetb");
    fails(&bake(&bundle, &dir.path().join("none.json").to_string_lossy(), &o), 3, "none.json");
    // 2: a typo in the TF file (not JSON at all, or an unknown colour map name).
    let typo = dir.path().join("typo.json");
    std::fs::write(&typo, r#"{"color": [[0, 1, 1, 1]], "opacity": [[0, 1] [1, 1]], "unit_distance": 1}"#).unwrap();
    fails(&bake(&bundle, &typo.to_string_lossy(), &o), 2, "typo.json");
    fails(&tetlut(&["probe", "--tf", &tf, "--range", "1,0"], ""), 2, "below");
    // 5: an output in a directory that does not exist, for every writer.
    let nowhere = dir.path().join("no/such/dir");
    fails(&bake(&bundle, &tf, &nowhere.join("x.tetl").to_string_lossy()), 5, "no/such/dir");
    fails(
        &tetlut(&["show", &sample("mild8.tetl"), "-o", &nowhere.join("m.png").to_string_lossy()], ""),
        5,
        "no/such/dir",
    );
    // --help lists the table.
    let help = String::from_utf8_lossy(&tetlut(&["--help"], "").stdout).into_owned();
    assert!(help.contains("Exit codes") && help.contains("6  the method cannot bake"), "{help}");
}

// The TF files' expected failures, the same table tetview's CLI test uses.
#[path = "../../tet_preint/tests/data/tf/failures.rs"]
mod tf_files;
use tf_files::{tf_failures, TF_DATA};

#[test]
fn tf_files_fail_as_in_tetview_and_a_paraview_preset_bakes() {
    let dir = tempfile::tempdir().unwrap();
    let o = dir.path().join("x.tetl").to_string_lossy().into_owned();
    let bundle = sample("cube5.tetb");
    let bake = |tf: &str, extra: &[&str]| {
        let args = [&["bake", "--bundle", &bundle, "--tf", tf, "--method", "poly1", "--res", "8", "-o", &o][..], extra];
        tetlut(&args.concat(), "")
    };
    for (tf, code, line) in tf_failures() {
        let out = bake(&tf, &[]);
        let err = String::from_utf8_lossy(&out.stderr).into_owned();
        assert_eq!(out.status.code(), Some(code), "{tf}: {err}");
        assert_eq!(err.lines().next(), Some(format!("tetlut: {line}").as_str()), "{tf}");
    }
    // A ParaView preset: imported normalized, mapped onto the bundle's
    // scalar range as tetview maps it (tet_preint::tf_for_bundle).
    let preset = format!("{TF_DATA}/preset_cool_to_warm.json");
    let saved = dir.path().join("saved.json");
    ok(&bake(&preset, &["--save-tf", &saved.to_string_lossy()]));
    let want = tet_preint::tf_for_bundle(
        &tet_preint::load_tf(Path::new(&preset)).unwrap(),
        &tet_bundle::Bundle::read(Path::new(&bundle)).unwrap(),
    )
    .unwrap();
    assert_eq!(tet_preint::load_tf(&saved).unwrap(), want);
    assert!(!want.normalized() && want.color_nodes().len() == 3);
}
