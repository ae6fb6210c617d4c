//! Exodus II reader on VTK's rotating-disk results file
//! (tests/data/exodus/LICENSE.md). Every expected figure was read from the
//! same file with an independent netCDF reader (SciPy's `netcdf_file`):
//! dimensions, the first element's connectivity, the first point, and the
//! min/max/mean of each nodal variable at the one stored time step.

mod common;

use std::path::{Path, PathBuf};

use tet_io::exodus::{self, ExodusOptions};
use tet_io::{detect_format, read_file, Format, ReadError, ReadOptions};
use tet_mesh::{tetrahedralize, Block, CellType, ConvertOptions};

const DIR: &str = concat!(env!("CARGO_MANIFEST_DIR"), "/../../tests/data/exodus/");

fn disk() -> Vec<u8> {
    common::gunzip(&Path::new(DIR).join("disk_out_ref.ex2.gz"))
}

fn disk_on_disk(dir: &Path, name: &str) -> PathBuf {
    let p = dir.join(name);
    std::fs::write(&p, disk()).unwrap();
    p
}

/// The tets `tetprep convert` would make of `m` (scalar `scalar`), and
/// their total volume.
fn tets_and_volume(m: &tet_mesh::SourceMesh, scalar: &str) -> (usize, f64) {
    let opts = ConvertOptions { scalar: Some(scalar.into()), ..ConvertOptions::default() };
    let (t, _) = tetrahedralize(m, &opts, &mut |_| {}).unwrap();
    let p = |i: u32| &t.points[i as usize];
    let volume =
        t.tets.iter().map(|v| tet_mesh::predicates::signed_tet_volume(p(v[0]), p(v[1]), p(v[2]), p(v[3])).abs()).sum();
    (t.tets.len(), volume)
}

#[test]
fn the_disk_reads_with_its_declared_counts_connectivity_and_fields() {
    let bytes = disk();
    let opts = ReadOptions::default();
    assert_eq!(detect_format(Path::new("disk.ex2"), &bytes[..4096], &opts), Some(Format::Exodus));
    // Detected by its header's dimension names whatever the file is called.
    assert_eq!(detect_format(Path::new("disk.bin"), &bytes[..4096], &opts), Some(Format::Exodus));
    let m = exodus::read(&bytes, &ExodusOptions::default()).unwrap();
    assert_eq!(m.points.len(), 8499);
    assert_eq!(m.points[0], [0.0, -3.81f32 as f64, 10.16f32 as f64]);
    let Block::Unstructured(c) = &m.blocks[0] else { panic!("unstructured") };
    assert_eq!(c.len(), 7472);
    assert!(c.types.iter().all(|&t| t == CellType::Hexahedron));
    // Exodus numbers nodes from 1: "143 706 3173 1829 6566 6690 7000 6966".
    assert_eq!(c.nodes(0), &[142, 705, 3172, 1828, 6565, 6689, 6999, 6965]);
    let expect = [
        ("Temp", 293.15, 913.15, 425.1635),
        ("VX", -19.949114, 19.949114, 0.0),
        ("VY", -19.949114, 19.949114, 0.0),
        ("VZ", -21.125977, 6.711901, -6.0295005),
        ("Pres", 0.0067855217, 0.028818512, 0.020881083),
        ("AsH3", 0.08047682, 0.18483947, 0.13817315),
        ("GaMe3", 0.00022284436, 0.007213926, 0.0048080296),
        ("CH4", 0.0, 0.0011702392, 0.0005149104),
        ("H2", 0.80761313, 0.9176879, 0.8565039),
    ];
    let names: Vec<_> = m.point_fields.iter().map(|f| f.name.as_str()).collect();
    assert_eq!(names, expect.iter().map(|e| e.0).collect::<Vec<_>>());
    for (f, (name, lo, hi, mean)) in m.point_fields.iter().zip(expect) {
        assert_eq!(f.values.len(), 8499, "{name}");
        let min = f.values.iter().copied().fold(f64::MAX, f64::min);
        let max = f.values.iter().copied().fold(f64::MIN, f64::max);
        let avg = f.values.iter().sum::<f64>() / f.values.len() as f64;
        let tol = 1e-6 * (hi - lo);
        assert!((min - lo).abs() <= tol && (max - hi).abs() <= tol, "{name}: [{min}, {max}]");
        assert!((avg - mean).abs() <= 1e-5 * (hi - lo), "{name}: mean {avg}");
    }
    assert!(m.notes.iter().any(|n| n.contains("1 time step")), "{:?}", m.notes);
}

#[test]
fn the_disk_tetrahedralizes_into_a_closed_volume() {
    let m = exodus::read(&disk(), &ExodusOptions::default()).unwrap();
    let (tets, volume) = tets_and_volume(&m, "Temp");
    assert_eq!(tets, 7472 * 6);
    // The disk is two 36-sided prisms around the z axis: an annulus of radii
    // 3.81 and 5.75 for -10 <= z <= 0 and a full disk of radius 5.75 for
    // 0 <= z <= 10.16 (radii and heights as stored, in f32). A regular
    // 36-gon of radius r has area 18 r^2 sin(2 pi / 36).
    let (r0, r1) = (3.81f32 as f64, 5.75f32 as f64);
    let k = 18.0 * (2.0 * std::f64::consts::PI / 36.0).sin();
    let expect = k * ((r1 * r1 - r0 * r0) * 10.0 + r1 * r1 * (10.16f32 as f64));
    assert!((volume - expect).abs() < 1e-6 * expect, "tets {volume}, prisms {expect}");
}

#[test]
fn a_time_step_past_the_end_names_how_many_there_are() {
    let d = tempfile::tempdir().unwrap();
    let p = disk_on_disk(d.path(), "disk.ex2");
    let e = read_file(&p, &ReadOptions { time_step: Some(3), ..ReadOptions::default() }).unwrap_err();
    let msg = e.to_string();
    assert!(matches!(e, ReadError::Malformed { format: Format::Exodus, .. }), "{e:?}");
    assert!(msg.contains('3') && msg.contains('1') && msg.contains("disk.ex2"), "{msg}");
    let ok = read_file(&p, &ReadOptions { time_step: Some(0), ..ReadOptions::default() }).unwrap();
    assert_eq!(ok.points.len(), 8499);
}

/// Every prefix of a real file is an error, never a panic; the header is
/// never trusted for an allocation past the bytes there are.
#[test]
fn truncated_files_are_errors() {
    let bytes = disk();
    // The data ends at byte 704,396; the file carries 4 bytes after it.
    assert_eq!(bytes.len(), 704_400);
    assert!(exodus::read(&bytes[..704_396], &ExodusOptions::default()).is_ok());
    for len in (0..704_396).step_by(997).chain([704_395]) {
        assert!(exodus::read(&bytes[..len], &ExodusOptions::default()).is_err(), "prefix {len}");
    }
}

fn small() -> Vec<u8> {
    std::fs::read(Path::new(DIR).join("small.exo")).unwrap()
}

fn field<'m>(m: &'m tet_mesh::SourceMesh, name: &str) -> &'m [f64] {
    let f = m.point_fields.iter().chain(&m.cell_fields).find(|f| f.name == name);
    &f.unwrap_or_else(|| panic!("no field {name}")).values
}

/// The hand-made file (tests/data/exodus/make_small.py): separate
/// coordinate arrays, three blocks of which the shell is skipped, nodal
/// variables one array each, an element variable the truth table keeps to
/// block 10, and two time steps.
#[test]
fn blocks_steps_and_element_variables_of_a_small_file() {
    let bytes = small();
    let m = exodus::read(&bytes, &ExodusOptions::default()).unwrap();
    assert_eq!(m.points.len(), 10);
    assert_eq!(m.points[8], [0.5, 0.5, 2.0]);
    let Block::Unstructured(c) = &m.blocks[0] else { panic!("unstructured") };
    assert_eq!(c.types, vec![CellType::Hexahedron, CellType::Pyramid]);
    assert_eq!(c.nodes(1), &[4, 5, 6, 7, 8]);
    assert!(m.notes.iter().any(|n| n.contains("block 30 (SHELL4, 1 element)")), "{:?}", m.notes);
    assert!(m.notes.iter().any(|n| n.contains("2 time steps")), "{:?}", m.notes);
    assert_eq!(field(&m, "block_id"), &[10.0, 20.0]);
    let node: Vec<f64> = (1..=10).map(f64::from).collect();
    assert_eq!(field(&m, "T"), node.iter().map(|n| n * 0.5).collect::<Vec<_>>());
    assert_eq!(field(&m, "P"), node.iter().map(|n| -n * 0.5).collect::<Vec<_>>());
    let rho = field(&m, "rho");
    assert_eq!(rho[0], 7.0);
    assert!(rho[1].is_nan(), "the truth table leaves rho out of block 20");

    let m1 = exodus::read(&bytes, &ExodusOptions { time_step: Some(1) }).unwrap();
    assert_eq!(field(&m1, "T"), node.iter().map(|n| n * 1.5).collect::<Vec<_>>());
    assert_eq!(field(&m1, "rho")[0], 8.0);
    assert!(m1.notes.iter().any(|n| n.contains("1.5")), "{:?}", m1.notes);
    let e = exodus::read(&bytes, &ExodusOptions { time_step: Some(2) }).unwrap_err();
    assert!(e.to_string().contains('2'), "{e}");

    // Hex (volume 1) + pyramid on its top face (base 1, height 1: 1/3).
    let (_, volume) = tets_and_volume(&m, "T");
    assert!((volume - 4.0 / 3.0).abs() < 1e-12, "{volume}");
}

/// Every byte of the small file flipped in turn: an error or a mesh, never
/// a panic or a runaway allocation.
#[test]
fn corrupt_bytes_never_panic() {
    let bytes = small();
    for i in 0..bytes.len() {
        for flip in [0x01u8, 0x80, 0xff] {
            let mut b = bytes.clone();
            b[i] ^= flip;
            let _ = exodus::read(&b, &ExodusOptions::default());
        }
    }
}

/// The same files in netCDF-4 (HDF5) form, written by Unidata's `nccopy`
/// (`-k nc4`; `-k nc7 -d 6 -s`: chunked, shuffled and deflated; the disk
/// `-k nc4 -d 9 -s`): detected by extension, read into the same mesh —
/// points, cells, every field at every time step, the notes — as the
/// classic files, and their time steps listed the same.
#[test]
fn netcdf4_files_read_as_their_classic_originals() {
    let d = tempfile::tempdir().unwrap();
    let disk = disk_on_disk(d.path(), "disk.ex2");
    for (classic, nc4, steps) in [
        (Path::new(DIR).join("small.exo"), "small_nc4.exo", 2),
        (Path::new(DIR).join("small.exo"), "small_nc4_deflate.exo", 2),
        (disk.clone(), "disk_out_ref_nc4.exo", 1),
    ] {
        let path = Path::new(DIR).join(nc4);
        let bytes = std::fs::read(&path).unwrap();
        assert!(bytes.starts_with(b"\x89HDF\r\n\x1a\n"), "{nc4}");
        let opts = ReadOptions::default();
        assert_eq!(detect_format(&path, &bytes[..4096], &opts), Some(Format::Exodus), "{nc4}");
        let want_bytes = std::fs::read(&classic).unwrap();
        assert_eq!(exodus::times(&bytes).unwrap(), exodus::times(&want_bytes).unwrap(), "{nc4}");
        for step in 0..steps {
            let o = ReadOptions { time_step: Some(step), ..ReadOptions::default() };
            let (got, want) = (read_file(&path, &o).unwrap(), read_file(&classic, &o).unwrap());
            assert_eq!(got.points, want.points, "{nc4}");
            assert_eq!(got.blocks, want.blocks, "{nc4}");
            assert_eq!(got.notes, want.notes, "{nc4}");
            assert_eq!((got.format.as_str(), want.format.as_str()), ("Exodus II (netCDF-4/HDF5)", "Exodus II"));
            for (g, w) in
                got.point_fields.iter().chain(&got.cell_fields).zip(want.point_fields.iter().chain(&want.cell_fields))
            {
                assert_eq!((&g.name, g.num_components), (&w.name, w.num_components), "{nc4}");
                assert!(
                    g.values.iter().zip(&w.values).all(|(a, b)| a == b || (a.is_nan() && b.is_nan())),
                    "{nc4} {}",
                    g.name
                );
            }
            assert_eq!(
                got.point_fields.len() + got.cell_fields.len(),
                want.point_fields.len() + want.cell_fields.len()
            );
        }
        let e = read_file(&path, &ReadOptions { time_step: Some(steps), ..ReadOptions::default() }).unwrap_err();
        assert!(e.to_string().contains(&steps.to_string()), "{nc4}: {e}");
    }
}

/// A netCDF-4 file cut short, or with bytes flipped, is an error (or a
/// mesh), never a panic: the HDF5 decoder's own failures come back as
/// errors naming netCDF-4.
#[test]
fn damaged_netcdf4_files_are_errors() {
    let bytes = std::fs::read(Path::new(DIR).join("small_nc4_deflate.exo")).unwrap();
    for len in (0..bytes.len()).step_by(1013) {
        let e = exodus::read(&bytes[..len], &ExodusOptions::default());
        assert!(e.is_err(), "cut at {len}");
    }
    let mut rng = common::Lcg(11);
    for _ in 0..300 {
        let mut b = bytes.clone();
        for _ in 0..4 {
            let i = 8 + rng.below(b.len() - 8);
            b[i] ^= 1 << rng.below(8);
        }
        let _ = exodus::read(&b, &ExodusOptions::default());
    }
}

/// `face_nodes.exo` (`make_face_nodes.py`, SciPy's writer): blocks of
/// TETRA14, TETRA8, WEDGE20 and PYRAMID18 in Ioss's node orders, each a unit
/// cube, with T = 2x − 3y + z/2 + 7 at t = 0 and 2T at t = 1. Each element
/// is completed by added points (a body point; TETRA8 also its 19 distinct
/// edges' midpoints) and cut at all its nodes: positive conforming tets of
/// volume 1 a block, and T exact at the added points at both steps.
#[test]
fn face_node_elements_of_a_file_are_completed_and_cut() {
    let bytes = std::fs::read(Path::new(DIR).join("face_nodes.exo")).unwrap();
    let m = exodus::read(&bytes, &ExodusOptions::default()).unwrap();
    let Block::Unstructured(c) = &m.blocks[0] else { panic!("unstructured") };
    let count = |t: CellType| c.types.iter().filter(|&&x| x == t).count();
    assert_eq!(count(CellType::QuadraticTetraWithCentres), 12);
    assert_eq!(count(CellType::QuadraticWedgeWithCentres), 2);
    assert_eq!(count(CellType::TriquadraticPyramid), 6);
    // 149 file nodes; added: 19 edges and 6 bodies (TETRA8), 6 + 2 + 6 bodies.
    assert_eq!(m.points.len(), 149 + 39);
    assert!(m.notes.iter().any(|n| n.contains("completed 20 elements")), "{:?}", m.notes);
    let linear = |p: &[f64; 3]| 2.0 * p[0] - 3.0 * p[1] + 0.5 * p[2] + 7.0;
    for step in 0..2 {
        let f = exodus::read_step_fields(&bytes, step).unwrap();
        let t = &f.point_fields[0].values;
        assert_eq!(t.len(), m.points.len());
        for (p, v) in m.points.iter().zip(t) {
            assert!((v - (step + 1) as f64 * linear(p)).abs() < 1e-12, "step {step}: {p:?}");
        }
    }
    let (tets, volume) = common::converted(&m);
    assert!((volume - 4.0).abs() < 1e-12, "{volume}");
    assert!(tets >= 20 * 12, "{tets}");
}
