//! SU2 reader on SU2's own deformation test mesh (tests/data/su2/LICENSE.md)
//! and on the real SU2 cylinder solution (tests/data/vtu), written out as an
//! SU2 mesh plus a CSV restart in SU2's layout and read back.

mod common;

use std::path::Path;

use tet_io::{detect_format, read_file, su2, Format, ReadError, ReadOptions};
use tet_mesh::{tetrahedralize, Block, CellType, ConvertOptions, SourceMesh};

const DIR: &str = concat!(env!("CARGO_MANIFEST_DIR"), "/../../tests/data/");

fn brick() -> Vec<u8> {
    common::gunzip(&Path::new(DIR).join("su2/mesh_brick_prism_ffd.su2.gz"))
}

fn volume(m: &SourceMesh, scalar: &str) -> f64 {
    let opts = ConvertOptions { scalar: Some(scalar.into()), ..ConvertOptions::default() };
    let (t, _) = tetrahedralize(m, &opts, &mut |_| {}).unwrap();
    t.tets
        .iter()
        .map(|v| {
            let p = v.map(|i| &t.points[i as usize]);
            tet_mesh::predicates::signed_tet_volume(p[0], p[1], p[2], p[3]).abs()
        })
        .sum()
}

#[test]
fn the_brick_mesh_reads_with_the_counts_its_header_declares() {
    let bytes = brick();
    assert_eq!(detect_format(Path::new("m.su2"), &bytes[..4096], &ReadOptions::default()), Some(Format::Su2));
    assert_eq!(detect_format(Path::new("m.mesh"), &bytes[..4096], &ReadOptions::default()), Some(Format::Su2));
    let m = su2::read(&bytes).unwrap();
    assert_eq!(m.points.len(), 16_800);
    let Block::Unstructured(c) = &m.blocks[0] else { panic!("unstructured") };
    assert_eq!(c.len(), 29_640);
    assert!(c.types.iter().all(|&t| t == CellType::Wedge));
    // The first element line: "13 116 115 0 916 915 800 0".
    assert_eq!(c.nodes(0), &[116, 115, 0, 916, 915, 800]);
    assert_eq!(m.points[1], [5.128205128205128e-02, 1.0, 0.0]);
    // Prisms filling a box: their volume is the box's.
    let (lo, hi) = m.points.iter().fold(([f64::MAX; 3], [f64::MIN; 3]), |(lo, hi), p| {
        (std::array::from_fn(|k| lo[k].min(p[k])), std::array::from_fn(|k| hi[k].max(p[k])))
    });
    let box_volume: f64 = (0..3).map(|k| hi[k] - lo[k]).product();
    let v = volume(&m, "x");
    assert!((v - box_volume).abs() < 1e-9 * box_volume, "prisms {v}, box {box_volume}");
}

/// The cylinder solution as SU2 would have written it: the mesh (tets,
/// trailing element and point indices, a marker section) and a
/// `restart_flow.csv` with PointID, coordinates and the fields.
fn cylinder_as_su2(dir: &Path) -> (SourceMesh, std::path::PathBuf, std::path::PathBuf) {
    let vtu = read_file(&Path::new(DIR).join("vtu/cylinder3D_solution.vtu"), &ReadOptions::default()).unwrap();
    let Block::Unstructured(c) = &vtu.blocks[0] else { panic!("unstructured") };
    let mut mesh = format!("%\n% Problem dimension\n%\nNDIME= 3\nNELEM= {}\n", c.len());
    for i in 0..c.len() {
        let n = c.nodes(i);
        mesh += &format!("10\t{}\t{}\t{}\t{}\t{i}\n", n[0], n[1], n[2], n[3]);
    }
    mesh += &format!("NPOIN= {}\n", vtu.points.len());
    for (i, p) in vtu.points.iter().enumerate() {
        mesh += &format!("{:.15e}\t{:.15e}\t{:.15e}\t{i}\n", p[0], p[1], p[2]);
    }
    mesh += "NMARK= 1\nMARKER_TAG= wall\nMARKER_ELEMS= 1\n5\t0\t1\t2\n";
    let scalars: Vec<_> = vtu.point_fields.iter().filter(|f| f.num_components == 1).collect();
    let mut csv = String::from("\"PointID\",\"x\",\"y\",\"z\"");
    for f in &scalars {
        csv += &format!(",\"{}\"", f.name);
    }
    csv += "\n";
    // Rows in reverse: matched by PointID, not by order.
    for i in (0..vtu.points.len()).rev() {
        let p = vtu.points[i];
        csv += &format!("{i},{:.15e},{:.15e},{:.15e}", p[0], p[1], p[2]);
        for f in &scalars {
            csv += &format!(",{:.15e}", f.values[i]);
        }
        csv += "\n";
    }
    let (m, s) = (dir.join("cylinder.su2"), dir.join("restart_flow.csv"));
    std::fs::write(&m, mesh).unwrap();
    std::fs::write(&s, csv).unwrap();
    (vtu, m, s)
}

#[test]
fn a_real_solution_reads_back_with_its_fields() {
    let d = tempfile::tempdir().unwrap();
    let (vtu, mesh, sol) = cylinder_as_su2(d.path());
    let opts = ReadOptions { solution: Some(sol), ..ReadOptions::default() };
    let m = read_file(&mesh, &opts).unwrap();
    assert_eq!(m.format, "SU2");
    assert_eq!((m.points.len(), m.num_cells()), (5_696, 27_591));
    for f in vtu.point_fields.iter().filter(|f| f.num_components == 1) {
        let g = m.point_fields.iter().find(|g| g.name == f.name).unwrap_or_else(|| panic!("no {}", f.name));
        let worst = f.values.iter().zip(&g.values).map(|(a, b)| (a - b).abs() / a.abs().max(1e-30)).fold(0.0, f64::max);
        assert!(worst < 1e-14, "{}: relative difference {worst}", f.name);
    }
    let (v_su2, v_vtu) = (volume(&m, "Density"), volume(&vtu, "Density"));
    assert!((v_su2 - v_vtu).abs() < 1e-12 * v_vtu, "{v_su2} vs {v_vtu}");
}

#[test]
fn solution_errors_name_the_solution_file() {
    let d = tempfile::tempdir().unwrap();
    let (_, mesh, sol) = cylinder_as_su2(d.path());
    // Drop the last row: a count mismatch, reported in the CSV's name.
    let text = std::fs::read_to_string(&sol).unwrap();
    let cut = text.trim_end().rsplit_once('\n').unwrap().0.to_string() + "\n";
    std::fs::write(&sol, cut).unwrap();
    let opts = ReadOptions { solution: Some(sol.clone()), ..ReadOptions::default() };
    match read_file(&mesh, &opts) {
        Err(ReadError::Malformed { format: Format::Su2, message, path, .. }) => {
            assert_eq!(path, sol);
            assert!(message.contains("5695 rows, the mesh 5696 points"), "{message}");
        }
        other => panic!("expected a malformed solution, got {other:?}"),
    }
}

#[test]
fn truncated_brick_is_an_error_not_a_panic() {
    let bytes = brick();
    for cut in [10, 1000, bytes.len() / 3, bytes.len() / 2, bytes.len() - 7] {
        // Any prefix either reads (the sections after NPOIN are optional)
        // or fails with a message; never panics.
        if let Err(e) = su2::read(&bytes[..cut]) {
            assert!(!e.message.is_empty());
        }
    }
}
