//! Formats tetkit recognises but does not read yet: one error variant that
//! says what the file is, never "pass --format" (no --format reads them).
//! (OpenFOAM was one; it is read now, and its recognition is checked here.)
use std::path::Path;
use tet_io::{read_file, ReadError, ReadOptions, Unsupported};

fn kind_of(path: &Path) -> Unsupported {
    match read_file(path, &ReadOptions::default()) {
        Err(e @ ReadError::Unsupported { .. }) => {
            let msg = e.to_string();
            assert!(!msg.contains("pass --format"), "{msg}");
            assert!(msg.contains("does not read yet") && msg.ends_with(&path.display().to_string()), "{msg}");
            let ReadError::Unsupported { kind, .. } = e else { unreachable!() };
            kind
        }
        other => panic!("{}: expected Unsupported, got {other:?}", path.display()),
    }
}

fn file(dir: &Path, name: &str, bytes: &[u8]) -> std::path::PathBuf {
    let p = dir.join(name);
    std::fs::write(&p, bytes).unwrap();
    p
}

/// Exodus II is read in both its netCDF classic and netCDF-4 (HDF5) forms,
/// so a truncated header of either is a malformed Exodus file, not an
/// unknown or unsupported one.
#[test]
fn exodus_netcdf_and_hdf5_flavours() {
    let d = tempfile::tempdir().unwrap();
    for (name, magic) in [
        ("d.exo", &b"\x89HDF\r\n\x1a\n\0\0"[..]),
        ("a.exo", b"CDF\x01\0\0\0\0"),
        ("b.ex2", b"CDF\x02\0\0\0\0"),
        ("c.e", b"CDF\x01\0\0\0\0"),
        // `.g` is also PLOT3D's grid extension: the magic decides.
        ("e.g", b"CDF\x02\0\0\0\0"),
    ] {
        let p = file(d.path(), name, magic);
        let e = read_file(&p, &ReadOptions::default()).unwrap_err();
        assert!(matches!(e, ReadError::Malformed { format: tet_io::Format::Exodus, .. }), "{name}: {e:?}");
        assert!(e.to_string().contains(name), "{e}");
    }
}

#[test]
fn bare_netcdf_and_hdf5() {
    let d = tempfile::tempdir().unwrap();
    assert_eq!(kind_of(&file(d.path(), "data.bin", b"CDF\x01\0\0\0\0")), Unsupported::NetCdf);
    assert_eq!(kind_of(&file(d.path(), "data.xyz", b"\x89HDF\r\n\x1a\n\0")), Unsupported::Hdf5);
    assert_eq!(kind_of(&file(d.path(), "data.h5", b"anything")), Unsupported::Hdf5);
}

#[test]
fn cgns_hdf5_and_adf() {
    let d = tempfile::tempdir().unwrap();
    assert_eq!(kind_of(&file(d.path(), "m.cgns", b"\x89HDF\r\n\x1a\n\0")), Unsupported::Cgns);
    assert_eq!(kind_of(&file(d.path(), "m.cgns", b"ADF Database Version A02011>")), Unsupported::Cgns);
}

/// OpenFOAM is read now (tests/openfoam.rs): a case directory, a `.foam`
/// file and a FoamFile dictionary are recognised as OpenFOAM, and a case
/// without a mesh is a malformed-OpenFOAM error naming the path, no longer
/// `Unsupported`.
#[test]
fn openfoam_inputs_are_recognised_and_a_case_without_a_mesh_names_its_path() {
    let d = tempfile::tempdir().unwrap();
    let case = d.path().join("cavity");
    std::fs::create_dir_all(case.join("constant/polyMesh")).unwrap();
    let dict = b"FoamFile\n{\n    version 2.0;\n    class vectorField;\n}\n";
    for p in [case.clone(), file(&case, "cavity.foam", b""), file(&case.join("constant/polyMesh"), "points.txt", dict)]
    {
        let e = read_file(&p, &ReadOptions::default()).unwrap_err();
        match &e {
            ReadError::Malformed { format: tet_io::Format::OpenFoam, path, .. } => assert_eq!(path, &case, "{e}"),
            other => panic!("{}: expected a malformed OpenFOAM case, got {other:?}", p.display()),
        }
        let msg = e.to_string();
        assert!(msg.contains("has no mesh") && msg.contains("constant/polyMesh/points"), "{msg}");
    }
    // A dictionary outside any case says so, naming the file.
    let lone = file(d.path(), "points", dict);
    let e = read_file(&lone, &ReadOptions::default()).unwrap_err();
    let msg = e.to_string();
    assert!(msg.contains("not inside an OpenFOAM case") && msg.contains(&lone.display().to_string()), "{msg}");
}

#[test]
fn other_unknown_files_still_ask_for_a_format() {
    let d = tempfile::tempdir().unwrap();
    let e = read_file(&file(d.path(), "mystery.dat", b"\x01\x02\x03"), &ReadOptions::default()).unwrap_err();
    assert!(matches!(e, ReadError::UnknownFormat { .. }), "{e:?}");
    // A PLOT3D `.g` grid is still a PLOT3D grid (it fails as one here).
    let e = read_file(&file(d.path(), "grid.g", b"\x01\x00\x00\x00"), &ReadOptions::default()).unwrap_err();
    assert!(matches!(e, ReadError::Malformed { format: tet_io::Format::Plot3d, .. }), "{e:?}");
}
