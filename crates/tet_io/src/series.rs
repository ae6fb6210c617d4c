//! Time series: which files (or which steps of one file) make up a series,
//! and at what times.
//!
//! * ParaView's `.pvd` collection: `<VTKFile type="Collection"><Collection>`
//!   with one `<DataSet timestep="T" part="0" file="name.vtu"/>` per step
//!   (files relative to the `.pvd`). A time with several parts (pieces of
//!   one step) is refused: merge them first (ParaView: Merge Blocks).
//! * ParaView's file-series JSON (`name.vtu.series`, `name.vtk.series`):
//!   `{"file-series-version": "1.0", "files": [{"name": "a.vtu", "time": 0}, …]}`.
//! * An Exodus II file's time steps (`time_whole`) and an OpenFOAM case's
//!   time directories, when asked for ([`series_steps`] with `all_steps`).
//!
//! [`StepFields`] reads the later steps of an Exodus file or OpenFOAM case
//! as their fields alone, the mesh read once.
//!
//! Steps come back sorted by time; two steps at one time, a non-finite
//! time, a listed file that does not exist or an empty list are errors
//! naming the index file and the entry.

use std::path::{Path, PathBuf};

use crate::{Format, Location, ReadError, ReadOptions};

/// One step of a time series: its time and how to read it.
#[derive(Debug, Clone, PartialEq)]
pub struct SeriesStep {
    pub time: f64,
    /// The file (or OpenFOAM case) to read.
    pub path: PathBuf,
    /// The step inside `path` (Exodus, OpenFOAM), or `None` for a file
    /// holding one step.
    pub time_step: Option<usize>,
    /// What to call the step in reports (`isabel_03.vti`, `disk.ex2 step 4`).
    pub label: String,
}

/// The later steps of a series that is the time steps of one Exodus file
/// or OpenFOAM case, read as their fields alone: an Exodus step reads only
/// its variables from the file's bytes held once
/// (`exodus::read_step_fields`), an OpenFOAM step only its time
/// directory's fields, laid out on the cells built once
/// (`openfoam::CaseSteps`). So `--all-steps` reads the mesh once, not once
/// a step.
pub struct StepFields {
    path: PathBuf,
    source: StepSource,
}

enum StepSource {
    Exodus(Vec<u8>),
    OpenFoam(crate::openfoam::CaseSteps),
}

impl StepFields {
    /// For `steps` that are all time steps of one Exodus file or OpenFOAM
    /// case (as [`series_steps`] lists them); `None` for any other series,
    /// whose steps are then read whole.
    pub fn open(steps: &[SeriesStep], opts: &ReadOptions) -> Result<Option<StepFields>, ReadError> {
        let Some(first) = steps.first() else {
            return Ok(None);
        };
        if steps.iter().any(|s| s.time_step.is_none() || s.path != first.path) {
            return Ok(None);
        }
        let path = first.path.clone();
        let format = match opts.format {
            Some(f) => f,
            None if path.is_dir() => Format::OpenFoam,
            None => {
                let bytes = crate::read_all(&path)?;
                if crate::detect_format(&path, &bytes[..bytes.len().min(4096)], opts) != Some(Format::Exodus) {
                    return Ok(None);
                }
                return Ok(Some(StepFields { path, source: StepSource::Exodus(bytes) }));
            }
        };
        let source = match format {
            Format::Exodus => StepSource::Exodus(crate::read_all(&path)?),
            Format::OpenFoam => StepSource::OpenFoam(crate::openfoam::CaseSteps::open(&path)?),
            _ => return Ok(None),
        };
        Ok(Some(StepFields { path, source }))
    }

    /// `step`'s fields (point and cell fields, notes), with no points and
    /// no cells: the mesh is the first step's, read once.
    pub fn fields(&self, step: &SeriesStep) -> Result<tet_mesh::SourceMesh, ReadError> {
        let k = step.time_step.unwrap_or(0);
        match &self.source {
            StepSource::Exodus(bytes) => {
                let f = crate::exodus::read_step_fields(bytes, k).map_err(|e| ReadError::Malformed {
                    format: Format::Exodus,
                    message: e.message,
                    at: e.at,
                    path: self.path.clone(),
                })?;
                Ok(tet_mesh::SourceMesh {
                    format: "Exodus II".into(),
                    point_fields: f.point_fields,
                    cell_fields: f.cell_fields,
                    notes: f.notes,
                    ..Default::default()
                })
            }
            StepSource::OpenFoam(case) => case.fields(k),
        }
    }
}

/// Whether `path` names a series index by its extension (`.pvd`, `.series`).
pub fn is_series_index(path: &Path) -> bool {
    let name = path.file_name().and_then(|n| n.to_str()).unwrap_or("").to_ascii_lowercase();
    name.ends_with(".pvd") || name.ends_with(".series")
}

fn bad(path: &Path, at: Location, message: impl Into<String>) -> ReadError {
    ReadError::BadSeries { message: message.into(), at, path: path.to_path_buf() }
}

/// The steps of `path`: every step a `.pvd` or `.series` lists; with
/// `all_steps`, every time step of an Exodus file or OpenFOAM case; `None`
/// for an input that is one mesh at one time.
pub fn series_steps(path: &Path, opts: &ReadOptions, all_steps: bool) -> Result<Option<Vec<SeriesStep>>, ReadError> {
    if is_series_index(path) {
        let bytes = std::fs::read(path).map_err(|source| ReadError::Io { source, path: path.to_path_buf() })?;
        let lower = path.to_string_lossy().to_ascii_lowercase();
        let steps = if lower.ends_with(".pvd") { parse_pvd(&bytes, path)? } else { parse_series_json(&bytes, path)? };
        return finish(steps, path).map(Some);
    }
    if !all_steps {
        return Ok(None);
    }
    let format = match opts.format {
        Some(f) => f,
        None if path.is_dir() => Format::OpenFoam,
        None => {
            let bytes = crate::read_all(path)?;
            crate::detect_format(path, &bytes[..bytes.len().min(4096)], opts).unwrap_or(Format::VtkLegacy)
        }
    };
    let name = path.file_name().map(|n| n.to_string_lossy().into_owned()).unwrap_or_default();
    let steps: Vec<SeriesStep> = match format {
        Format::Exodus => {
            let bytes = crate::read_all(path)?;
            let times = crate::exodus::times(&bytes).map_err(|e| ReadError::Malformed {
                format,
                message: e.message,
                at: e.at,
                path: path.to_path_buf(),
            })?;
            times
                .into_iter()
                .enumerate()
                .map(|(k, time)| SeriesStep {
                    time,
                    path: path.to_path_buf(),
                    time_step: Some(k),
                    label: format!("{name} step {k}"),
                })
                .collect()
        }
        Format::OpenFoam => crate::openfoam::case_times(path)?
            .into_iter()
            .enumerate()
            .map(|(k, (time, dir))| SeriesStep {
                time,
                path: path.to_path_buf(),
                time_step: Some(k),
                label: format!("{name} time {dir}"),
            })
            .collect(),
        other => {
            return Err(bad(
                path,
                Location::Whole,
                format!(
                    "--all-steps reads the time steps of Exodus files and OpenFOAM cases; this is {other} \
                     (list the files of a series in a .pvd or .series file)"
                ),
            ))
        }
    };
    finish(steps, path).map(Some)
}

/// Sorts by time and checks: at least one step, finite and distinct times.
fn finish(mut steps: Vec<SeriesStep>, path: &Path) -> Result<Vec<SeriesStep>, ReadError> {
    if steps.is_empty() {
        return Err(bad(path, Location::Whole, "the series lists no steps"));
    }
    if let Some(s) = steps.iter().find(|s| !s.time.is_finite()) {
        return Err(bad(path, Location::Whole, format!("{}: time {} is not finite", s.label, s.time)));
    }
    steps.sort_by(|a, b| a.time.total_cmp(&b.time));
    if let Some(w) = steps.windows(2).find(|w| w[0].time == w[1].time) {
        return Err(bad(
            path,
            Location::Whole,
            format!("{} and {} have the same time {} (one step per time)", w[0].label, w[1].label, w[0].time),
        ));
    }
    Ok(steps)
}

/// A listed file, relative to the index's directory; it must exist.
fn listed(index: &Path, name: &str, at: Location) -> Result<PathBuf, ReadError> {
    if name.is_empty() {
        return Err(bad(index, at, "an entry names no file"));
    }
    let p = index.parent().map_or_else(|| PathBuf::from(name), |d| d.join(name));
    if !p.exists() {
        return Err(bad(index, at, format!("listed file {} does not exist", p.display())));
    }
    Ok(p)
}

fn parse_time(text: &str, index: &Path, at: Location) -> Result<f64, ReadError> {
    text.trim()
        .parse::<f64>()
        .ok()
        .filter(|t| t.is_finite())
        .ok_or_else(|| bad(index, at, format!("time '{text}' is not a finite number")))
}

/// The steps of a `.pvd` collection.
pub fn parse_pvd(bytes: &[u8], index: &Path) -> Result<Vec<SeriesStep>, ReadError> {
    use quick_xml::events::Event;
    let mut reader = quick_xml::Reader::from_reader(bytes);
    let mut steps = Vec::new();
    let mut collection = false;
    let mut buf = Vec::new();
    loop {
        let at = Location::Byte(reader.buffer_position());
        let event = reader.read_event_into(&mut buf).map_err(|e| bad(index, at, format!("XML: {e}")))?;
        match event {
            Event::Eof => break,
            Event::Start(e) | Event::Empty(e) => {
                let tag = e.name().as_ref().to_vec();
                if tag == b"VTKFile" {
                    let ty = attr(&e, b"type", index, at)?;
                    if ty.as_deref() != Some("Collection") {
                        return Err(bad(
                            index,
                            at,
                            format!("a .pvd is a VTKFile of type Collection, this one is {:?}", ty.unwrap_or_default()),
                        ));
                    }
                    collection = true;
                } else if tag == b"DataSet" {
                    let file = attr(&e, b"file", index, at)?.unwrap_or_default();
                    let time = match attr(&e, b"timestep", index, at)? {
                        Some(t) => parse_time(&t, index, at)?,
                        // ParaView writes timestep on every DataSet; without
                        // one, a collection is not a time series.
                        None => return Err(bad(index, at, format!("DataSet {file:?} has no timestep"))),
                    };
                    let part = attr(&e, b"part", index, at)?.unwrap_or_else(|| "0".into());
                    if part.trim() != "0" {
                        return Err(bad(
                            index,
                            at,
                            format!(
                                "DataSet {file:?} is part {part} of time {time}: steps split into parts are not read \
                                 yet (merge each step into one file, e.g. ParaView's Merge Blocks)"
                            ),
                        ));
                    }
                    let path = listed(index, &file, at)?;
                    steps.push(SeriesStep { time, path, time_step: None, label: file });
                }
            }
            _ => {}
        }
        buf.clear();
    }
    if !collection {
        return Err(bad(index, Location::Whole, "no <VTKFile type=\"Collection\"> element: not a .pvd collection"));
    }
    Ok(steps)
}

fn attr(
    e: &quick_xml::events::BytesStart<'_>,
    name: &[u8],
    index: &Path,
    at: Location,
) -> Result<Option<String>, ReadError> {
    for a in e.attributes() {
        let a = a.map_err(|err| bad(index, at, format!("XML attribute: {err}")))?;
        if a.key.as_ref() == name {
            let v = a.unescape_value().map_err(|err| bad(index, at, format!("XML attribute: {err}")))?;
            return Ok(Some(v.into_owned()));
        }
    }
    Ok(None)
}

/// The steps of a ParaView file-series JSON (`*.series`).
pub fn parse_series_json(bytes: &[u8], index: &Path) -> Result<Vec<SeriesStep>, ReadError> {
    let v: serde_json::Value = serde_json::from_slice(bytes).map_err(|e| {
        bad(index, Location::Line(e.line()), format!("JSON: {e} (a .series file is ParaView's file-series JSON)"))
    })?;
    let files = v.get("files").and_then(|f| f.as_array()).ok_or_else(|| {
        bad(
            index,
            Location::Whole,
            "no \"files\" array (expected {\"file-series-version\": \"1.0\", \"files\": [...]})",
        )
    })?;
    let mut steps = Vec::with_capacity(files.len());
    for (i, f) in files.iter().enumerate() {
        let at = Location::Whole;
        let name = f
            .get("name")
            .and_then(|n| n.as_str())
            .ok_or_else(|| bad(index, at, format!("files[{i}] has no \"name\" string")))?;
        let time = match f.get("time") {
            Some(serde_json::Value::Number(n)) => n.as_f64().filter(|t| t.is_finite()),
            Some(serde_json::Value::String(s)) => s.trim().parse::<f64>().ok().filter(|t| t.is_finite()),
            _ => None,
        }
        .ok_or_else(|| bad(index, at, format!("files[{i}] ({name}) has no finite \"time\"")))?;
        let path = listed(index, name, at)?;
        steps.push(SeriesStep { time, path, time_step: None, label: name.to_string() });
    }
    Ok(steps)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn dir_with(files: &[&str]) -> tempfile::TempDir {
        let d = tempfile::tempdir().unwrap();
        for f in files {
            std::fs::write(d.path().join(f), b"x").unwrap();
        }
        d
    }

    #[test]
    fn pvd_and_series_list_steps_by_time() {
        let d = dir_with(&["a.vtu", "b.vtu", "c.vtu"]);
        let pvd = d.path().join("s.pvd");
        std::fs::write(
            &pvd,
            r#"<?xml version="1.0"?><VTKFile type="Collection" version="0.1"><Collection>
<DataSet timestep="2.5" part="0" file="b.vtu"/>
<DataSet timestep="1" group="" part="0" file="a.vtu"/>
<DataSet timestep="1e1" file="c.vtu"/>
</Collection></VTKFile>"#,
        )
        .unwrap();
        let s = series_steps(&pvd, &ReadOptions::default(), false).unwrap().unwrap();
        assert_eq!(s.iter().map(|s| s.time).collect::<Vec<_>>(), [1.0, 2.5, 10.0]);
        assert_eq!(s[0].path, d.path().join("a.vtu"));
        assert_eq!(s[2].label, "c.vtu");

        let js = d.path().join("s.vtu.series");
        std::fs::write(
            &js,
            r#"{"file-series-version": "1.0", "files": [{"name": "c.vtu", "time": 3}, {"name": "a.vtu", "time": "0.5"}]}"#,
        )
        .unwrap();
        let s = series_steps(&js, &ReadOptions::default(), false).unwrap().unwrap();
        assert_eq!(s.iter().map(|s| (s.time, s.label.as_str())).collect::<Vec<_>>(), [(0.5, "a.vtu"), (3.0, "c.vtu")]);

        // Not an index, not asked for steps: one mesh.
        assert_eq!(series_steps(&d.path().join("a.vtu"), &ReadOptions::default(), false).unwrap(), None);
    }

    #[test]
    fn bad_indexes_say_what_is_wrong() {
        let d = dir_with(&["a.vtu", "b.vtu"]);
        let check = |name: &str, text: &str, want: &str| {
            let p = d.path().join(name);
            std::fs::write(&p, text).unwrap();
            let e = series_steps(&p, &ReadOptions::default(), false).unwrap_err();
            assert!(matches!(e, ReadError::BadSeries { .. }), "{e}");
            assert!(e.to_string().contains(want), "{name}: {e}");
            assert!(e.to_string().contains(name), "{e}");
        };
        let pvd = |body: &str| format!(r#"<VTKFile type="Collection"><Collection>{body}</Collection></VTKFile>"#);
        check("missing.pvd", &pvd(r#"<DataSet timestep="0" file="nope.vtu"/>"#), "does not exist");
        check(
            "twice.pvd",
            &pvd(r#"<DataSet timestep="1" file="a.vtu"/><DataSet timestep="1" file="b.vtu"/>"#),
            "same time",
        );
        check("nan.pvd", &pvd(r#"<DataSet timestep="NaN" file="a.vtu"/>"#), "not a finite number");
        check("parts.pvd", &pvd(r#"<DataSet timestep="0" part="1" file="a.vtu"/>"#), "part 1");
        check("notime.pvd", &pvd(r#"<DataSet file="a.vtu"/>"#), "no timestep");
        check("empty.pvd", &pvd(""), "no steps");
        check("grid.pvd", r#"<VTKFile type="UnstructuredGrid"></VTKFile>"#, "Collection");
        check("broken.pvd", "<VTKFile type=\"Collection\"><Collection><DataSet", "XML");
        check("x.series", "{\"files\": [{\"name\": \"a.vtu\"}]}", "finite \"time\"");
        check("y.series", "{\"files\": 3}", "\"files\" array");
        check("z.series", "{not json", "JSON");
        check("w.series", "{\"files\": [{\"time\": 1}]}", "\"name\"");
    }
}
