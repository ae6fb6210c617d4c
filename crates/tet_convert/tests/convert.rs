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

/// A real tet mesh (VTK's `tetraMesh.vtk`) made quadratic: each cell given
/// its six edge midpoints (shared between cells) and a quadratic field at
/// all ten nodes, written as VTK_QUADRATIC_TETRA cells. The conversion cuts
/// each cell at its nodes into 8 conforming tets (same volume, four times
/// the boundary triangles, no face unmatched) that carry the mid-edge
/// values, and so follow the field more closely than the cells' corners.
#[test]
fn quadratic_tets_are_split_at_their_nodes() {
    use std::collections::HashMap;
    use std::fmt::Write;
    let linear = tet_io::read_file(&data("vtk/tetraMesh.vtk"), &Default::default()).unwrap();
    let tet_mesh::Block::Unstructured(cells) = &linear.blocks[0] else { panic!("unstructured") };
    let f = |p: &[f64; 3]| p[0] * p[0] - 0.5 * p[1] * p[2] + 3.0 * p[2];
    let mut points = linear.points.clone();
    let mut mid: HashMap<(u32, u32), u32> = HashMap::new();
    let mut text = String::new();
    let mut conn = String::new();
    for c in 0..cells.len() {
        let n = cells.nodes(c);
        let mut ten: Vec<u32> = n.to_vec();
        for (a, b) in [(0, 1), (1, 2), (2, 0), (0, 3), (1, 3), (2, 3)] {
            let key = (n[a].min(n[b]), n[a].max(n[b]));
            let id = *mid.entry(key).or_insert_with(|| {
                let (p, q) = (points[n[a] as usize], points[n[b] as usize]);
                points.push([0, 1, 2].map(|k| 0.5 * (p[k] + q[k])));
                (points.len() - 1) as u32
            });
            ten.push(id);
        }
        writeln!(conn, "10 {}", ten.iter().map(u32::to_string).collect::<Vec<_>>().join(" ")).unwrap();
    }
    writeln!(text, "# vtk DataFile Version 2.0\nquadratic tets\nASCII\nDATASET UNSTRUCTURED_GRID").unwrap();
    writeln!(text, "POINTS {} double", points.len()).unwrap();
    for p in &points {
        writeln!(text, "{:.17e} {:.17e} {:.17e}", p[0], p[1], p[2]).unwrap();
    }
    writeln!(text, "CELLS {} {}\n{conn}CELL_TYPES {}", cells.len(), 11 * cells.len(), cells.len()).unwrap();
    text.push_str(&"24\n".repeat(cells.len()));
    writeln!(text, "POINT_DATA {}\nSCALARS f double 1\nLOOKUP_TABLE default", points.len()).unwrap();
    for p in &points {
        writeln!(text, "{:.17e}", f(p)).unwrap();
    }
    let dir = tempfile::tempdir().unwrap();
    let quad_path = dir.path().join("quadratic.vtk");
    std::fs::write(&quad_path, text).unwrap();

    let quad = convert(&quad_path, &ConvertRequest::default(), &mut |_| {}).unwrap().bundle;
    let corners = convert(&data("vtk/tetraMesh.vtk"), &ConvertRequest::default(), &mut |_| {}).unwrap().bundle;
    assert_eq!(quad.mesh.tets.len(), 8 * cells.len());
    assert_eq!(quad.mesh.points.len(), points.len());
    assert_eq!(quad.adjacency.boundary_faces.len(), 4 * corners.adjacency.boundary_faces.len());
    let (vq, vc) = (quad.meta.stats.total_volume, corners.meta.stats.total_volume);
    assert!((vq - vc).abs() <= 1e-9 * vc, "{vq} {vc}");
    for (p, s) in quad.mesh.points.iter().zip(&quad.mesh.scalar) {
        assert!((s - f(p)).abs() <= 1e-9 * (1.0 + f(p).abs()), "{p:?}: {s} against {}", f(p));
    }
    // The field at each tet's centroid against the linear interpolant of
    // its vertices, on the quadratic cells' tets and on the corner tets
    // (the corner mesh's scalar set to f at its vertices).
    let worst = |points: &[[f64; 3]], tets: &[[u32; 4]], value: &dyn Fn(usize) -> f64| {
        tets.iter()
            .map(|t| {
                let c = [0, 1, 2].map(|k| t.iter().map(|&v| points[v as usize][k]).sum::<f64>() / 4.0);
                (t.iter().map(|&v| value(v as usize)).sum::<f64>() / 4.0 - f(&c)).abs()
            })
            .fold(0.0, f64::max)
    };
    let split_error = worst(&quad.mesh.points, &quad.mesh.tets, &|v| quad.mesh.scalar[v]);
    let corner_error = worst(&corners.mesh.points, &corners.mesh.tets, &|v| f(&corners.mesh.points[v]));
    eprintln!("centroid error: split {split_error:.3e}, corners {corner_error:.3e}");
    assert!(split_error < 0.5 * corner_error, "split {split_error:.3e} against corners {corner_error:.3e}");
}
