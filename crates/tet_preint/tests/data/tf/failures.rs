//! The expected failures of this folder's transfer-function files, shared
//! by tetlut's and tetview's CLI tests (each includes this file): one
//! loader (`tet_preint::load_tf`), one message, one exit code.

/// This folder.
pub const TF_DATA: &str = concat!(env!("CARGO_MANIFEST_DIR"), "/../tet_preint/tests/data/tf");

/// The first stderr line for each TF file here (and a missing one),
/// without the program's name, and its exit code.
pub fn tf_failures() -> Vec<(String, i32, String)> {
    let p = |name: &str| format!("{TF_DATA}/{name}");
    vec![
        (
            p("bad_unsorted.json"),
            2,
            format!(
                "opacity[1]: x = 0.2 is below the previous control point's 0.5 (points must increase): {}",
                p("bad_unsorted.json")
            ),
        ),
        (
            p("bad_syntax.json"),
            2,
            format!("transfer function JSON: expected `,` or `]` at line 3 column 22: {}", p("bad_syntax.json")),
        ),
        (
            p("absent.json"),
            3,
            format!(
                "cannot read transfer function: {}: {}",
                std::fs::read(p("absent.json")).unwrap_err(),
                p("absent.json")
            ),
        ),
    ]
}
