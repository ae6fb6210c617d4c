//! The one reader of transfer-function files: `tetlut` (bake, probe,
//! bench), `tetview` (render, reference, bench, view) and the viewer's
//! "load TF" and "import preset" all call [`load_tf`] / [`load_tf_with`].
//!
//! A file is either
//!
//! * tetkit TF JSON (`formats/tf.md`, an object with `color`, `opacity`,
//!   `unit_distance`, …), read by [`TransferFunction::from_json`]; or
//! * a ParaView colour-map preset (`formats/tf.md`, "ParaView presets"): a
//!   JSON list of presets, or one object with ParaView's keys (`RGBPoints`,
//!   `Points`, `ColorSpace`, `Name`, `NanColor`), read by
//!   [`TransferFunction::from_paraview_json`]. It is normalized, with the
//!   unit distance of [`LoadOptions::preset_unit_distance`] (a preset has
//!   none of its own).
//!
//! Which one is decided by the JSON's shape, never by trying both: a
//! tetkit TF is always an object, and none of ParaView's keys is a tetkit
//! field (tetkit JSON refuses unknown fields), so an error is about the
//! format the file is written in.
//!
//! Errors: a file that cannot be read is [`TfError::Read`] (the CLIs exit 3);
//! contents that are not a TF are [`TfError::File`] around the reason
//! (exit 2), whose message ends with the path and, for a JSON syntax error,
//! says the line and column (serde_json's "at line L column C"). Nothing
//! here panics on any input.

use std::path::Path;

use crate::{IoFailure, TfError, TransferFunction};

/// The keys of a ParaView preset object; none is a field of tetkit's JSON.
const PRESET_KEYS: [&str; 5] = ["RGBPoints", "Points", "ColorSpace", "Name", "NanColor"];

/// How [`load_tf_with`] / [`parse_tf`] read a ParaView preset (tetkit JSON
/// carries all of this itself and ignores the options).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct LoadOptions<'a> {
    /// The preset whose `Name` this is; `None`: the file's first preset.
    pub preset_name: Option<&'a str>,
    /// The imported TF's `unit_distance` (world units per opacity 1). The
    /// CLIs use 1; the viewer its current TF's, so an import keeps the
    /// opacity scale the user had.
    pub preset_unit_distance: f64,
}

impl Default for LoadOptions<'_> {
    fn default() -> Self {
        LoadOptions { preset_name: None, preset_unit_distance: 1.0 }
    }
}

/// Reads the transfer function at `path` (tetkit JSON or a ParaView preset,
/// the first preset, unit distance 1): [`load_tf_with`] with the default
/// [`LoadOptions`].
pub fn load_tf(path: &Path) -> Result<TransferFunction, TfError> {
    load_tf_with(path, &LoadOptions::default())
}

/// Reads the transfer function at `path` (see the module docs):
/// [`TfError::Read`] when the file cannot be read, [`TfError::File`] naming
/// `path` when its contents are not a TF.
pub fn load_tf_with(path: &Path, opts: &LoadOptions<'_>) -> Result<TransferFunction, TfError> {
    let bytes = std::fs::read(path).map_err(|e| TfError::Read { source: IoFailure::new(e), path: path.into() })?;
    let in_file = |e: TfError| TfError::File { source: Box::new(e), path: path.into() };
    let text = std::str::from_utf8(&bytes).map_err(|e| in_file(TfError::Json(format!("not UTF-8 text: {e}"))))?;
    parse_tf(text, opts).map_err(in_file)
}

/// Parses the text of a transfer-function file (tetkit JSON or a ParaView
/// preset; see the module docs). The errors do not name a file; those of
/// [`load_tf_with`] do.
pub fn parse_tf(text: &str, opts: &LoadOptions<'_>) -> Result<TransferFunction, TfError> {
    if text.trim().is_empty() {
        return Err(TfError::Json(
            "the file is empty (expected a tetkit TF object, formats/tf.md, or a ParaView preset)".into(),
        ));
    }
    let value: serde_json::Value = serde_json::from_str(text).map_err(|e| TfError::Json(e.to_string()))?;
    if is_preset(&value) {
        TransferFunction::from_paraview_value(&value, opts.preset_name, opts.preset_unit_distance)
    } else {
        // Parsed again from the text so that errors keep their line and column.
        TransferFunction::from_json(text)
    }
}

/// Whether parsed JSON is a ParaView preset file: a list (tetkit's TF is an
/// object), or an object with one of ParaView's keys.
fn is_preset(v: &serde_json::Value) -> bool {
    match v {
        serde_json::Value::Array(_) => true,
        serde_json::Value::Object(o) => PRESET_KEYS.iter().any(|k| o.contains_key(*k)),
        _ => false,
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::io::ErrorKind;

    const TETKIT: &str = r#"{"color": [[0, 1, 0, 0], [1, 0, 0, 1]], "opacity": [[0, 0.5]], "unit_distance": 2}"#;
    const PRESETS: &str = r#"[{"Name": "first", "RGBPoints": [-1, 0, 0, 1, 1, 1, 0, 0]},
        {"Name": "second", "RGBPoints": [0, 0, 0, 0, 10, 1, 1, 1], "Points": [0, 0, 0.5, 0, 10, 1, 0.5, 0]}]"#;

    fn write(dir: &Path, name: &str, text: &str) -> std::path::PathBuf {
        let p = dir.join(name);
        std::fs::write(&p, text).unwrap();
        p
    }

    #[test]
    fn tetkit_json_is_read_as_from_json_reads_it() {
        let dir = tempfile::tempdir().unwrap();
        let p = write(dir.path(), "t.json", TETKIT);
        let tf = load_tf(&p).unwrap();
        assert_eq!(tf, TransferFunction::from_json(TETKIT).unwrap());
        // Preset options do not touch tetkit JSON.
        let opts = LoadOptions { preset_name: Some("x"), preset_unit_distance: 9.0 };
        assert_eq!(load_tf_with(&p, &opts).unwrap().unit_distance(), 2.0);
    }

    #[test]
    fn a_paraview_preset_is_normalized_with_the_unit_distance_asked_for() {
        let dir = tempfile::tempdir().unwrap();
        let p = write(dir.path(), "presets.json", PRESETS);
        let first = load_tf(&p).unwrap();
        assert!(first.normalized());
        assert_eq!(first.unit_distance(), 1.0);
        assert_eq!(first, TransferFunction::from_paraview_json(PRESETS, None, 1.0).unwrap());
        let opts = LoadOptions { preset_name: Some("second"), preset_unit_distance: 3.0 };
        let second = load_tf_with(&p, &opts).unwrap();
        assert_eq!(second, TransferFunction::from_paraview_json(PRESETS, Some("second"), 3.0).unwrap());
        // One preset object, not in a list.
        let one = write(dir.path(), "one.json", r#"{"Name": "x", "RGBPoints": [0, 0, 0, 0, 1, 1, 1, 1]}"#);
        assert!(load_tf(&one).unwrap().normalized());
        // A name the file lacks.
        let e = load_tf_with(&p, &LoadOptions { preset_name: Some("zz"), ..Default::default() }).unwrap_err();
        assert!(matches!(e.contents(), TfError::Preset(m) if m.contains("\"zz\"")), "{e}");
    }

    #[test]
    fn the_shared_fixture_files_load_or_fail_as_the_clis_expect() {
        let data = Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/data/tf");
        let preset = load_tf(&data.join("preset_cool_to_warm.json")).unwrap();
        assert!(preset.normalized() && preset.color_nodes().len() == 3 && preset.opacity_nodes().len() == 2);
        assert_eq!((preset.color_nodes()[1].x, preset.opacity_nodes()[1].a), (0.5, 2.0));
        let e = load_tf(&data.join("bad_syntax.json")).unwrap_err();
        assert!(e.to_string().contains("at line 3 column 22"), "{e}");
        let e = load_tf(&data.join("bad_unsorted.json")).unwrap_err();
        assert!(matches!(e.contents(), TfError::Unsorted { list: "opacity", index: 1, .. }), "{e}");
    }

    #[test]
    fn a_missing_file_is_the_read_variant_naming_the_path_last() {
        let dir = tempfile::tempdir().unwrap();
        let p = dir.path().join("absent.json");
        let e = load_tf(&p).unwrap_err();
        match &e {
            TfError::Read { source, path } => {
                assert_eq!(path, &p);
                assert_eq!(source.io().kind(), ErrorKind::NotFound);
            }
            other => panic!("expected Read, got {other:?}"),
        }
        let msg = e.to_string();
        assert!(msg.starts_with("cannot read transfer function: "), "{msg}");
        assert!(msg.ends_with(&format!(": {}", p.display())), "{msg}");
        // A directory cannot be read either.
        assert!(matches!(load_tf(dir.path()), Err(TfError::Read { .. })));
    }

    #[test]
    fn malformed_json_says_line_and_column_and_names_the_file() {
        let dir = tempfile::tempdir().unwrap();
        let p = write(dir.path(), "bad.json", "{\n  \"color\": [[0, 1, 0, 0]],\n  \"opacity\": [[0, 1]\n}\n");
        let e = load_tf(&p).unwrap_err();
        assert!(matches!(&e, TfError::File { path, .. } if path == &p), "{e:?}");
        assert!(matches!(e.contents(), TfError::Json(_)), "{e:?}");
        let msg = e.to_string();
        assert!(msg.contains("line 4 column 1"), "{msg}");
        assert!(msg.ends_with(&format!(": {}", p.display())), "{msg}");
        // Invalid values keep the validation error (and the path).
        let p = write(dir.path(), "neg.json", r#"{"color": [[0, 1, 0, 0]], "opacity": [[0, -1]], "unit_distance": 1}"#);
        let e = load_tf(&p).unwrap_err();
        assert_eq!(e.contents(), &TfError::Negative { list: "opacity", index: 0 });
        // Not UTF-8, a JSON scalar, an unknown field: errors, no panic.
        std::fs::write(dir.path().join("bin.json"), [0xff, 0xfe, 0x00]).unwrap();
        assert!(matches!(load_tf(&dir.path().join("bin.json")).unwrap_err().contents(), TfError::Json(_)));
        assert!(matches!(parse_tf("42", &LoadOptions::default()), Err(TfError::Json(_))));
        let e = parse_tf(r#"{"colour": []}"#, &LoadOptions::default()).unwrap_err();
        assert!(e.to_string().contains("colour") && e.to_string().contains("line 1"), "{e}");
    }

    #[test]
    fn an_empty_file_is_a_clear_error() {
        let dir = tempfile::tempdir().unwrap();
        for text in ["", "  \n\t"] {
            let p = write(dir.path(), "empty.json", text);
            let e = load_tf(&p).unwrap_err();
            assert!(matches!(e.contents(), TfError::Json(m) if m.contains("empty")), "{e}");
            assert!(e.to_string().ends_with(&p.display().to_string()), "{e}");
        }
    }

    #[test]
    fn a_preset_without_rgbpoints_is_a_preset_error() {
        for text in [r#"[{"Name": "no colour", "Points": [0, 0, 0.5, 0]}]"#, r#"{"ColorSpace": "Diverging"}"#, "[]"] {
            let e = parse_tf(text, &LoadOptions::default()).unwrap_err();
            assert!(matches!(&e, TfError::Preset(_)), "{text}: {e:?}");
        }
        let e = parse_tf(r#"{"Name": "x", "Points": []}"#, &LoadOptions::default()).unwrap_err();
        assert_eq!(e, TfError::Preset("no RGBPoints".into()));
    }
}
