//! Every bundled real input, one test per format family, through the whole
//! data path: read → tetrahedralize → adjacency → bundle bytes → read back,
//! with the invariant checkers on the result.
use std::path::{Path, PathBuf};
use tetkit::bundle::{Bundle, BundleMeta};
use tetkit::io::{read_file, Format, ReadOptions};
use tetkit::mesh::{build_adjacency, check_adjacency, check_tet_mesh, tetrahedralize, ConvertOptions};

fn data(p: &str) -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/data").join(p)
}

/// Converts and checks; returns (tets, points, convex).
fn convert(path: &Path, opts: &ReadOptions, scalar: Option<&str>) -> (usize, usize, bool) {
    let src = read_file(path, opts).unwrap_or_else(|e| panic!("{e}"));
    let copts = ConvertOptions { scalar: scalar.map(str::to_string), ..Default::default() };
    let (mesh, _) = tetrahedralize(&src, &copts, &mut |_| {}).unwrap_or_else(|e| panic!("{}: {e}", path.display()));
    check_tet_mesh(&mesh).unwrap();
    let adj = build_adjacency(&mesh.points, &mesh.tets).unwrap();
    check_adjacency(&mesh.tets, &adj).unwrap();
    let (tets, points, convex) = (mesh.tets.len(), mesh.points.len(), adj.convex);
    let b = Bundle::new(mesh, adj, BundleMeta::default());
    // Compared as bytes: carried fields may hold NaN (e.g. PLOT3D Mach where
    // the pressure is negative), and NaN != NaN.
    let bytes = b.to_bytes();
    assert!(
        Bundle::from_bytes(&bytes, path).unwrap().to_bytes() == bytes,
        "{}: bundle round trip differs",
        path.display()
    );
    (tets, points, convex)
}

fn plain(p: &str) -> (usize, usize, bool) {
    convert(&data(p), &ReadOptions::default(), None)
}

#[test]
fn legacy_vtk_inputs() {
    assert_eq!(plain("vtk/tetraMesh.vtk"), (160, 55, false));
    assert_eq!(plain("vtk/CylinderLinear.vtk"), (1522, 465, false));
    // 10,648 hexahedra, 6 conforming tets each; the box is convex.
    assert_eq!(plain("vtk/hexa.vtk"), (63_888, 12_167, true));
    // 88 duplicated points in the native post mesh are merged.
    assert_eq!(plain("vtk/post.vtk"), (8750, 2200, false));
    assert_eq!(plain("vtk/office.binary.vtk"), (20 * 19 * 19 * 5, 8400, true));
    assert_eq!(plain("vtk/rectilinear.binary.vtk"), (120, 60, true));
    // Tet, hexahedron, voxel, wedge, pyramid (1 + 6 + 6 + 3 + 2) and a
    // 10-node tet cut at its nodes into 8.
    assert_eq!(plain("vtk/mixed.v51.binary.vtk").0, 26);
}

#[test]
fn vtk_xml_inputs() {
    assert_eq!(plain("vtu/cylinder3D_solution.vtu"), (27_591, 5696, false));
    assert_eq!(convert(&data("vtu/cylinder3D_solution.vtu"), &ReadOptions::default(), Some("Mach")).0, 27_591);
    assert_eq!(plain("vtu/can.vtu"), (28_800, 6724, false));
    // Two pieces: the shared points along the cut are merged back.
    assert_eq!(plain("vtu/cyl_2pieces.pvtu"), (1522, 465, false));
    assert_eq!(plain("vtu/office_sub.vts").0, 1575);
    assert_eq!(plain("vtu/iron_sub_rotated.vti"), (3465, 960, true));
}

#[test]
fn plot3d_inputs() {
    let opts = |q: &str| ReadOptions { q_path: Some(data(q)), ..Default::default() };
    let (tets, points, convex) = convert(&data("plot3d/combxyz.bin"), &opts("plot3d/combq.bin"), Some("density"));
    assert_eq!(points, 57 * 33 * 25);
    assert!(tets > 200_000 && tets <= 215_040, "{tets}");
    assert!(!convex);
}

#[test]
fn gmsh_and_tetgen_inputs() {
    assert_eq!(plain("gmsh/boxcyl_41_bin.msh"), (1333, 419, false));
    assert_eq!(plain("gmsh/boxcyl_22_ascii.msh"), (1333, 419, false));
    assert_eq!(plain("gmsh/hexbox_41_bin.msh"), (960, 270, true));
    assert_eq!(plain("gmsh/mixed_41_ascii.msh"), (984, 280, false));
    // TetGen: either file of the pair names the mesh.
    assert_eq!(plain("tetgen/twobox.1.ele"), (3170, 795, true));
    assert_eq!(plain("tetgen/twobox.1.node"), (3170, 795, true));
}

#[test]
fn volume_inputs() {
    let want = (15 * 15 * 15 * 5, 4096, true);
    assert_eq!(plain("volume/iron16_gzip.nrrd"), want);
    assert_eq!(plain("volume/iron16_detached.nhdr"), want);
    let raw = ReadOptions {
        format: Some(Format::Raw),
        raw: Some(tetkit::io::raw::RawSpec {
            dims: [16, 16, 16],
            scalar_type: tetkit::io::raw::parse_scalar_type("u8").unwrap(),
            endian: tetkit::io::cursor::Endian::Little,
            spacing: [1.0, 1.0, 2.0],
            origin: [0.0; 3],
            header_bytes: 0,
            name: "density".into(),
        }),
        ..Default::default()
    };
    assert_eq!(convert(&data("volume/iron16.raw"), &raw, None), want);
    assert_eq!(plain("vtk/ironProt.vtk"), (67 * 67 * 67 * 5, 68 * 68 * 68, true));
}

#[test]
fn format_is_detected_from_content_when_the_extension_lies() {
    let dir = tempfile::tempdir().unwrap();
    for (src, name) in [("vtk/tetraMesh.vtk", "a.dat"), ("vtu/can.vtu", "b.xml"), ("gmsh/mixed_22_ascii.msh", "c.txt")]
    {
        let p = dir.path().join(name);
        std::fs::copy(data(src), &p).unwrap();
        assert_eq!(
            read_file(&p, &ReadOptions::default()).unwrap().points.len(),
            read_file(&data(src), &ReadOptions::default()).unwrap().points.len()
        );
    }
}
