//! The conversion as a library: stages reported in order with their
//! timings, time series mapped, and requests that do not fit the input
//! refused with errors naming it.

use std::path::{Path, PathBuf};
use tet_convert::{convert, ConvertError, ConvertRequest, Stage};

fn data(p: &str) -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("../../tests/data").join(p)
}

#[test]
fn stages_timings_and_time_steps() {
    let mut stages = vec![];
    let done = convert(&data("series/isabel_eye.pvd"), &ConvertRequest::default(), &mut |s| stages.push(s)).unwrap();
    assert_eq!(stages[0], Stage::Reading);
    assert!(stages.contains(&Stage::Adjacency));
    assert_eq!(stages.last(), Some(&Stage::TimeStep { index: 4, count: 4, label: "isabel_eye_05.vti".into() }));
    let keys: Vec<&str> = done.timings.iter().map(|t| t.0).collect();
    assert_eq!(keys, ["read", "select_scalar", "merge", "split", "validate", "adjacency_stats", "time_steps"]);
    let st = done.bundle.steps.as_ref().unwrap();
    assert_eq!(st.times(), [2.0, 3.0, 4.0, 5.0]);
    assert_eq!(done.bundle.mesh.scalar, st.scalar(0));
}

#[test]
fn requests_that_do_not_fit_the_input_are_refused() {
    let req = ConvertRequest { max_circumradius: Some(1.0), ..Default::default() };
    let e = convert(&data("vtk/hexa.vtk"), &req, &mut |_| {}).unwrap_err();
    assert!(matches!(e, ConvertError::CloudOptions { .. }), "{e}");
    assert!(e.to_string().contains("hexa.vtk"), "{e}");
    let e = convert(&data("no/such.vtu"), &ConvertRequest::default(), &mut |_| {}).unwrap_err();
    assert!(matches!(e, ConvertError::Read(_)), "{e}");
}

/// Converts `path` with every time step on `scalar`: `count` steps, each
/// equal, bit for bit, to the file's step read whole and mapped onto the
/// first step's mesh; `unit` ("step", "time") names them in failures.
fn assert_steps_equal_whole_reads(path: &Path, scalar: &str, count: usize, unit: &str) {
    let convert_opts = tet_mesh::ConvertOptions { scalar: Some(scalar.into()), ..Default::default() };
    let req = ConvertRequest { all_steps: true, convert: convert_opts.clone(), ..Default::default() };
    let done = convert(path, &req, &mut |_| {}).unwrap();
    let st = done.bundle.steps.as_ref().unwrap_or_else(|| panic!("{scalar}: {count} {unit}s"));
    assert_eq!(st.len(), count, "{scalar}");
    // Each step read whole and mapped onto the first step's mesh.
    let read =
        |k: usize| tet_io::read_file(path, &tet_io::ReadOptions { time_step: Some(k), ..Default::default() }).unwrap();
    let first = read(0);
    let (mesh, report) = tet_mesh::tetrahedralize(&first, &convert_opts, &mut |_| {}).unwrap();
    let mapper = tet_mesh::StepMapper::new(&first, &mesh, &report).unwrap();
    for k in 0..count {
        let whole = mapper.scalar(&read(k), &mesh).unwrap();
        let bits = |v: &[f64]| v.iter().map(|x| x.to_bits()).collect::<Vec<_>>();
        assert_eq!(bits(st.scalar(k)), bits(&whole), "{scalar}, {unit} {k}");
    }
}

/// An Exodus file's later steps, read as their variables alone, map to
/// what reading each step whole and mapping it gives, bit for bit: for a
/// nodal variable, the element block id (a cell field) and a coordinate.
#[test]
fn exodus_steps_read_once_equal_steps_read_whole() {
    for scalar in ["T", "P", "block_id", "z"] {
        assert_steps_equal_whole_reads(&data("exodus/small.exo"), scalar, 2, "step");
    }
}

/// An OpenFOAM case's later times, read as their fields alone on the cells
/// built once, map to what reading each time whole gives, bit for bit.
#[test]
fn openfoam_times_read_once_equal_times_read_whole() {
    for scalar in ["p", "U:mag", "x"] {
        assert_steps_equal_whole_reads(&data("openfoam/cavity"), scalar, 6, "time");
    }
}
