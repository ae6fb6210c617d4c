//! `tetlut probe` end to end.
use std::io::Write;
use std::process::{Command, Output, Stdio};

const TF: &str = concat!(env!("CARGO_MANIFEST_DIR"), "/../../formats/samples/tf_mild.json");
const TF_NORM: &str = concat!(env!("CARGO_MANIFEST_DIR"), "/../../formats/samples/tf_normalized.json");

fn probe(args: &[&str], stdin: &str) -> Output {
    let mut child = Command::new(env!("CARGO_BIN_EXE_tetlut"))
        .arg("probe")
        .args(args)
        .stdin(Stdio::piped())
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .expect("tetlut runs");
    child.stdin.take().unwrap().write_all(stdin.as_bytes()).unwrap();
    child.wait_with_output().unwrap()
}

#[test]
fn probe_matches_library_bit_for_bit() {
    let out = probe(&["--tf", TF], "0 1 0.5\n\n# comment\n0.2 0.2 1\n");
    assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
    let tf = tet_preint::TransferFunction::from_json(&std::fs::read_to_string(TF).unwrap()).unwrap();
    let text = String::from_utf8(out.stdout).unwrap();
    let rows: Vec<Vec<f64>> =
        text.lines().map(|l| l.split_whitespace().map(|x| x.parse().unwrap()).collect()).collect();
    assert_eq!(rows.len(), 2);
    assert_eq!(rows[0], tet_preint::integrate_segment(&tf, 0.0, 1.0, 0.5).to_array());
    assert_eq!(rows[1], tet_preint::integrate_segment(&tf, 0.2, 0.2, 1.0).to_array());
}

#[test]
fn probe_errors_name_the_line_and_refuse_unbuilt_methods() {
    let out = probe(&["--tf", TF], "0 1 0.5\n0 1\n");
    assert!(!out.status.success());
    assert!(String::from_utf8_lossy(&out.stderr).contains("line 2"));
    let out = probe(&["--tf", TF], "0 1 0.5\n0 x 1\n");
    assert!(String::from_utf8_lossy(&out.stderr).contains("line 2"));
    let out = probe(&["--tf", TF, "--method", "table3d"], "");
    assert!(!out.status.success());
    assert!(String::from_utf8_lossy(&out.stderr).contains("not built yet"));
    let out = probe(&["--tf", TF_NORM], "0 1 1\n");
    assert!(String::from_utf8_lossy(&out.stderr).contains("--range"));
    let out = probe(&["--tf", TF_NORM, "--range", "-5,5"], "0 1 1\n");
    assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
}
