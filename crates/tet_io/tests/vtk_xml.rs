//! Integration tests of the VTK XML reader and VTU writer on real files (see
//! tests/data/vtu/LICENSE.md for where each comes from).

mod common;

use common::{assert_counts, assert_structured, Lcg};
use std::path::{Path, PathBuf};

use tet_io::vtk_xml::{read, read_pvtu, write_vtu, write_vtu_with, WriteOptions};
use tet_io::{Location, ReadError};
use tet_mesh::{Block, CellType, Field, SourceMesh};

const DATA: &str = concat!(env!("CARGO_MANIFEST_DIR"), "/../../tests/data/vtu");

fn path(name: &str) -> PathBuf {
    Path::new(DATA).join(name)
}

fn bytes(name: &str) -> Vec<u8> {
    std::fs::read(path(name)).unwrap_or_else(|e| panic!("{name}: {e}"))
}

fn load(name: &str) -> SourceMesh {
    read(&bytes(name)).unwrap_or_else(|e| panic!("{name}: {e}"))
}

fn unstructured(m: &SourceMesh) -> &tet_mesh::Cells {
    assert_eq!(m.blocks.len(), 1);
    match &m.blocks[0] {
        Block::Unstructured(c) => c,
        b => panic!("expected unstructured block, got {b:?}"),
    }
}

fn field<'m>(fields: &'m [Field], name: &str) -> &'m Field {
    fields.iter().find(|f| f.name == name).unwrap_or_else(|| panic!("no field {name}"))
}

fn close(a: f64, b: f64, rel: f64) -> bool {
    (a - b).abs() <= rel * a.abs().max(b.abs()).max(1e-300)
}

fn point_sum(m: &SourceMesh) -> f64 {
    m.points.iter().flatten().sum()
}

fn conn_sum(m: &SourceMesh) -> u64 {
    unstructured(m).connectivity.iter().map(|&p| p as u64).sum()
}

/// (section, name, RangeMin, RangeMax) of every DataArray in PointData or
/// CellData of the file's XML header. VTK writes the range of the values
/// for one component and of the tuple magnitudes for several.
fn declared_ranges(file: &[u8]) -> Vec<(&'static str, String, f64, f64)> {
    let text = String::from_utf8_lossy(file);
    let end = text.find("<AppendedData").unwrap_or(text.len());
    let text = &text[..end];
    let attr = |tag: &str, key: &str| -> Option<String> {
        let pat = format!(" {key}=\"");
        let at = tag.find(&pat)? + pat.len();
        Some(tag[at..at + tag[at..].find('"')?].to_string())
    };
    let mut out = Vec::new();
    let mut section = "";
    let mut pos = 0;
    while let Some(p) = text[pos..].find('<') {
        let start = pos + p;
        let stop = start + text[start..].find('>').unwrap_or(text.len() - start);
        let tag = &text[start..stop];
        for (open, s) in
            [("<PointData", "point"), ("<CellData", "cell"), ("<FieldData", ""), ("<Points", ""), ("<Cells", "")]
        {
            if tag.starts_with(open) {
                section = s;
            }
        }
        if tag.starts_with("<DataArray") && !section.is_empty() {
            if let (Some(name), Some(lo), Some(hi)) = (attr(tag, "Name"), attr(tag, "RangeMin"), attr(tag, "RangeMax"))
            {
                out.push((section, name, lo.trim().parse().unwrap(), hi.trim().parse().unwrap()));
            }
        }
        pos = stop;
    }
    out
}

/// Min and max of a field's values (one component) or tuple magnitudes.
fn value_range(f: &Field) -> (f64, f64) {
    let mut lo = f64::INFINITY;
    let mut hi = f64::NEG_INFINITY;
    for t in f.values.chunks_exact(f.num_components) {
        let v = if t.len() == 1 { t[0] } else { t.iter().map(|x| x * x).sum::<f64>().sqrt() };
        lo = lo.min(v);
        hi = hi.max(v);
    }
    (lo, hi)
}

/// Checks every field against the RangeMin/RangeMax the file declares, and
/// that every declared array was read.
fn check_declared_ranges(file: &[u8], m: &SourceMesh) {
    let declared = declared_ranges(file);
    assert!(!declared.is_empty());
    for (section, name, lo, hi) in declared {
        let fields = if section == "point" { &m.point_fields } else { &m.cell_fields };
        let (a, b) = value_range(field(fields, &name));
        assert!(close(a, lo, 1e-8) && close(b, hi, 1e-8), "{section} {name}: read {a}..{b}, file says {lo}..{hi}");
    }
}

#[test]
fn su2_cylinder_zlib_appended_base64() {
    let file = bytes("cylinder3D_solution.vtu");
    let m = read(&file).unwrap();
    assert_counts(&m, 5_696, 27_591);
    let cells = unstructured(&m);
    assert!(cells.types.iter().all(|&t| t == CellType::Tetra));
    let names: Vec<&str> = m.point_fields.iter().map(|f| f.name.as_str()).collect();
    assert_eq!(
        names,
        ["Density", "X-Momentum", "Y-Momentum", "Z-Momentum", "Energy", "Pressure", "Temperature", "Cp", "Mach"]
    );
    assert!(m.cell_fields.is_empty());
    check_declared_ranges(&file, &m);
    // Reference sums computed with VTK 9.7 from the same file.
    assert!(close(point_sum(&m), 5698.414126410433, 1e-12));
    assert_eq!(conn_sum(&m), 362_238_724);
    let density: f64 = field(&m.point_fields, "Density").values.iter().sum();
    assert!(close(density, 5560.696205336238, 1e-12));
    assert!(m.format.contains("UnstructuredGrid") && m.format.contains("zlib"), "{}", m.format);
    assert!(m.format.contains("appended base64"), "{}", m.format);
}

#[test]
fn can_appended_raw_uint64_hexahedra() {
    let file = bytes("can.vtu");
    let m = read(&file).unwrap();
    assert_counts(&m, 6_724, 4_800);
    assert!(unstructured(&m).types.iter().all(|&t| t == CellType::Hexahedron));
    for name in ["DISPL", "VEL", "ACCL"] {
        assert_eq!(field(&m.point_fields, name).num_components, 3);
    }
    assert_eq!(field(&m.cell_fields, "EQPS").num_components, 1);
    check_declared_ranges(&file, &m);
    assert!(close(point_sum(&m), -124696.85799534386, 1e-12));
    assert_eq!(conn_sum(&m), 123_690_053);
    let displ: f64 = field(&m.point_fields, "DISPL").values.iter().sum();
    assert!(close(displ, -95554.66146301705, 1e-12));
    let eqps: f64 = field(&m.cell_fields, "EQPS").values.iter().sum();
    assert!(close(eqps, 3725.0174483377486, 1e-12));
    assert!(m.format.contains("(appended)"), "{}", m.format);
}

const CYL_VARIANTS: [&str; 8] = [
    "cyl_ascii.vtu",
    "cyl_binary.vtu",
    "cyl_binary_zlib.vtu",
    "cyl_appended_raw.vtu",
    "cyl_appended_raw_u32_be.vtu",
    "cyl_appended_b64.vtu",
    "cyl_appended_zlib.vtu",
    "cyl_appended_b64_zlib_be.vtu",
];

#[test]
fn every_vtk_data_layout_gives_identical_data() {
    let reference = load("cyl_appended_raw.vtu");
    assert_eq!(reference.points.len(), 465);
    assert_eq!(reference.num_cells(), 1_522);
    assert!(unstructured(&reference).types.iter().all(|&t| t == CellType::Tetra));
    assert!(close(point_sum(&reference), 23.438956596298187, 1e-12));
    assert_eq!(conn_sum(&reference), 1_764_088);
    let velocity = field(&reference.point_fields, "velocity");
    assert_eq!(velocity.num_components, 3);
    assert!(close(velocity.values.iter().sum(), -80.31245876265376, 1e-12));
    let cell_norm = field(&reference.cell_fields, "vel_norm");
    assert!(close(cell_norm.values.iter().sum(), 513.9189479847342, 1e-12));
    for name in CYL_VARIANTS {
        let file = bytes(name);
        let m = read(&file).unwrap_or_else(|e| panic!("{name}: {e}"));
        assert_eq!(m.points, reference.points, "{name}");
        assert_eq!(m.blocks, reference.blocks, "{name}");
        assert_eq!(m.point_fields, reference.point_fields, "{name}");
        assert_eq!(m.cell_fields, reference.cell_fields, "{name}");
        check_declared_ranges(&file, &m);
    }
    assert!(load("cyl_ascii.vtu").format.contains("ascii"));
    assert!(load("cyl_binary_zlib.vtu").format.contains("inline binary, zlib"));
    assert!(load("cyl_appended_b64.vtu").format.contains("appended base64"));
}

#[test]
fn lz4_is_an_unsupported_compressor() {
    let e = read(&bytes("cyl_lz4.vtu")).unwrap_err();
    assert!(e.message.contains("unsupported compressor vtkLZ4DataCompressor"), "{e}");
}

/// Cells as lists of node coordinates, sorted: compares meshes whose point
/// numbering differs.
fn cell_coordinates(m: &SourceMesh) -> Vec<Vec<[u64; 3]>> {
    let cells = unstructured(m);
    let mut out: Vec<Vec<[u64; 3]>> = (0..cells.len())
        .map(|c| cells.nodes(c).iter().map(|&p| m.points[p as usize].map(|v| (v as f32).to_bits() as u64)).collect())
        .collect();
    out.sort();
    out
}

#[test]
fn two_pieces_in_one_file_are_concatenated() {
    let m = load("cyl_2pieces_onefile.vtu");
    // 359 + 355 points: border points stay duplicated.
    assert_eq!(m.points.len(), 714);
    assert_eq!(m.num_cells(), 1_522);
    assert_eq!(conn_sum(&m), 1_772_289);
    assert!(m.notes.iter().any(|n| n.contains("2 pieces")), "{:?}", m.notes);
    assert!(close(field(&m.cell_fields, "vel_norm").values.iter().sum(), 513.9189479847342, 1e-12));
    assert!(close(field(&m.point_fields, "vel_norm").values.iter().sum(), 127.78140447983651, 1e-12));
    // The same cells as the whole mesh (points are Float32 in the pieces).
    assert_eq!(cell_coordinates(&m), cell_coordinates(&load("cyl_appended_raw.vtu")));
}

#[test]
fn pvtu_reads_its_pieces() {
    let m = read_pvtu(&path("cyl_2pieces.pvtu")).unwrap();
    assert_eq!(m.points.len(), 714);
    assert_eq!(m.num_cells(), 1_522);
    assert_eq!(conn_sum(&m), 1_772_289);
    assert!(close(point_sum(&m), 36.41331955167065, 1e-9));
    let onefile = load("cyl_2pieces_onefile.vtu");
    assert_eq!(m.points, onefile.points);
    assert_eq!(m.blocks, onefile.blocks);
    assert_eq!(m.point_fields, onefile.point_fields);
    assert_eq!(m.cell_fields, onefile.cell_fields);
    assert!(m.format.contains("PUnstructuredGrid, 2 pieces"), "{}", m.format);
    // A serial reader refuses the index file and says why.
    let e = read(&bytes("cyl_2pieces.pvtu")).unwrap_err();
    assert!(e.message.contains("parallel"), "{e}");
}

#[test]
fn pvtu_errors_name_the_piece() {
    let dir = tempfile::tempdir().unwrap();
    std::fs::copy(path("cyl_2pieces.pvtu"), dir.path().join("x.pvtu")).unwrap();
    std::fs::copy(path("cyl_2pieces_0.vtu"), dir.path().join("cyl_2pieces_0.vtu")).unwrap();
    match read_pvtu(&dir.path().join("x.pvtu")) {
        Err(ReadError::Io { path, .. }) => assert!(path.ends_with("cyl_2pieces_1.vtu"), "{path:?}"),
        other => panic!("expected a missing-piece error, got {other:?}"),
    }
    let mut broken = bytes("cyl_2pieces_1.vtu");
    let cut = broken.len() - 2000;
    broken.truncate(cut);
    std::fs::write(dir.path().join("cyl_2pieces_1.vtu"), broken).unwrap();
    match read_pvtu(&dir.path().join("x.pvtu")) {
        Err(e @ ReadError::Malformed { .. }) => {
            let text = e.to_string();
            assert!(text.contains("cyl_2pieces_1.vtu") && text.contains("piece 1"), "{text}");
        }
        other => panic!("expected a malformed-piece error, got {other:?}"),
    }
}

#[test]
fn structured_grid_vts() {
    let file = bytes("office_sub.vts");
    let m = read(&file).unwrap();
    assert_structured(&m, [10, 8, 6], 480, 315);
    assert!(m.points[0].iter().all(|&v| close(v, 0.01, 1e-6)), "{:?}", m.points[0]);
    assert!(m.points[479].iter().zip([2.1, 1.6, 0.4]).all(|(&v, w)| close(v, w, 1e-6)), "{:?}", m.points[479]);
    assert!(close(point_sum(&m), 709.8800003044307, 1e-9));
    assert_eq!(field(&m.point_fields, "vectors").num_components, 3);
    assert_eq!(field(&m.cell_fields, "scalars").values.len(), 315);
    check_declared_ranges(&file, &m);
    assert!(m.format.contains("StructuredGrid (inline binary, zlib)"), "{}", m.format);
}

#[test]
fn image_data_vti_with_origin_spacing_and_direction() {
    let file = bytes("iron_sub.vti");
    let m = read(&file).unwrap();
    assert_structured(&m, [12, 10, 8], 960, 693);
    // Extent starts at (20, 22, 24): origin + spacing × index.
    assert_eq!(m.points[0], [11.5, 3.5, 48.25]);
    assert_eq!(m.points[1], [12.0, 3.5, 48.25]);
    assert_eq!(m.points[959], [17.0, 5.75, 62.25]);
    let scalars = field(&m.point_fields, "scalars");
    assert_eq!(scalars.values.iter().sum::<f64>(), 49_229.0);
    check_declared_ranges(&file, &m);

    let rotated = load("iron_sub_rotated.vti");
    assert_eq!(rotated.point_fields, m.point_fields);
    // VTK's TransformIndexToPhysicalPoint(21, 23, 25): local index (1, 1, 1).
    assert_eq!(rotated.points[1 + 12 * (1 + 10)], [-4.25, 8.5, 50.25]);
}

#[test]
fn rectilinear_grid_vtr() {
    let m = load("rect.vtr");
    assert_eq!(m.points.len(), 24);
    assert_eq!(m.blocks, vec![Block::Structured { dims: [4, 3, 2], first_point: 0 }]);
    assert_eq!(m.points[0], [0.0, -1.0, 5.0]);
    assert_eq!(m.points[1], [1.0, -1.0, 5.0]);
    assert_eq!(m.points[4], [0.0, 0.0, 5.0]);
    assert_eq!(m.points[23], [7.0, 2.0, 6.5]);
    assert_eq!(field(&m.cell_fields, "cellid").values, vec![0.0, 1.0, 2.0, 3.0, 4.0, 5.0]);
}

#[test]
fn bluntfin_tets_from_shared_data() {
    // The shared data folder sits beside the repository (in CI too); the
    // 2.6 MB file is not copied into the repo.
    let p = Path::new(env!("CARGO_MANIFEST_DIR")).join("../../../shared/data/bluntfin/bluntfin_tets.vtu");
    let Ok(file) = std::fs::read(&p) else {
        println!("skipping: {} not present", p.display());
        return;
    };
    let m = read(&file).unwrap();
    assert_eq!(m.points.len(), 40_960);
    assert_eq!(m.num_cells(), 187_395);
    assert!(unstructured(&m).types.iter().all(|&t| t == CellType::Tetra));
    check_declared_ranges(&file, &m);
    let (lo, hi) = value_range(field(&m.point_fields, "Density"));
    assert!((0.19..0.2).contains(&lo) && (4.97..4.98).contains(&hi));
}

fn tets_of(m: &SourceMesh) -> Vec<[u32; 4]> {
    let cells = unstructured(m);
    (0..cells.len()).map(|c| cells.nodes(c).try_into().unwrap()).collect()
}

#[test]
fn writer_roundtrips_a_real_mesh() {
    let m = load("cylinder3D_solution.vtu");
    let tets = tets_of(&m);
    let cell_ids = Field::new("cell id", 1, (0..tets.len()).map(|c| c as f64).collect());
    for options in [WriteOptions { compress: false }, WriteOptions { compress: true }] {
        let mut out = Vec::new();
        write_vtu_with(&mut out, &m.points, &tets, &m.point_fields, std::slice::from_ref(&cell_ids), options).unwrap();
        let back = read(&out).unwrap();
        assert_eq!(back.points, m.points);
        assert_eq!(back.blocks, m.blocks);
        assert_eq!(back.point_fields, m.point_fields);
        assert_eq!(back.cell_fields, vec![cell_ids.clone()]);
        assert_eq!(back.format.contains("zlib"), options.compress);
    }
    // Through a file, with the plain entry point.
    let dir = tempfile::tempdir().unwrap();
    let p = dir.path().join("out.vtu");
    write_vtu(std::fs::File::create(&p).unwrap(), &m.points, &tets, &m.point_fields, &[]).unwrap();
    let back = read(&std::fs::read(&p).unwrap()).unwrap();
    assert_eq!(back.points, m.points);
    assert_eq!(back.point_fields, m.point_fields);
}

#[test]
fn truncated_and_corrupted_files_never_panic() {
    let samples = [
        "cylinder3D_solution.vtu",
        "can.vtu",
        "cyl_ascii.vtu",
        "cyl_binary_zlib.vtu",
        "cyl_appended_b64_zlib_be.vtu",
        "cyl_appended_raw_u32_be.vtu",
        "cyl_2pieces_onefile.vtu",
        "office_sub.vts",
        "iron_sub.vti",
        "rect.vtr",
    ];
    let mut rng = Lcg(0x5eed_1234);
    for name in samples {
        let file = bytes(name);
        let xml_len = String::from_utf8_lossy(&file).find("<AppendedData").unwrap_or(file.len());
        for _ in 0..200 {
            let cut = rng.below(file.len());
            let _ = read(&file[..cut]);
        }
        for i in 0..200 {
            let mut bad = file.clone();
            // Half the flips hit the XML header, where they change structure.
            let at = if i % 2 == 0 { rng.below(xml_len) } else { rng.below(file.len()) };
            bad[at] ^= (rng.next() as u8) | 1;
            let _ = read(&bad);
        }
    }
}

fn tiny(piece: &str, cells: &str) -> String {
    format!(
        r#"<VTKFile type="UnstructuredGrid" byte_order="LittleEndian"><UnstructuredGrid>
<Piece {piece}><Points><DataArray type="Float64" NumberOfComponents="3" format="ascii">
0 0 0 1 0 0 0 1 0 0 0 1</DataArray></Points>
<Cells>{cells}</Cells></Piece></UnstructuredGrid></VTKFile>"#
    )
}

const GOOD_CELLS: &str = r#"<DataArray type="Int32" Name="connectivity" format="ascii">0 1 2 3</DataArray>
<DataArray type="Int32" Name="offsets" format="ascii">4</DataArray>
<DataArray type="UInt8" Name="types" format="ascii">10</DataArray>"#;

#[test]
fn hostile_headers_are_errors() {
    let ok = tiny(r#"NumberOfPoints="4" NumberOfCells="1""#, GOOD_CELLS);
    let m = read(ok.as_bytes()).unwrap();
    assert_eq!(m.num_cells(), 1);

    for piece in [
        r#"NumberOfPoints="18446744073709551615" NumberOfCells="1""#,
        r#"NumberOfPoints="4" NumberOfCells="18446744073709551615""#,
        r#"NumberOfPoints="-4" NumberOfCells="1""#,
        r#"NumberOfPoints="4" NumberOfCells="-1""#,
        r#"NumberOfPoints="four" NumberOfCells="1""#,
        r#"NumberOfPoints="5" NumberOfCells="1""#,
        r#"NumberOfCells="1""#,
    ] {
        let e = read(tiny(piece, GOOD_CELLS).as_bytes()).unwrap_err();
        assert!(matches!(e.at, Location::Line(_)), "{piece}: {e}");
    }
    let piece = r#"NumberOfPoints="4" NumberOfCells="1""#;
    for (cells, expect) in [
        (
            GOOD_CELLS.replace(r#"type="Int32" Name="connectivity""#, r#"type="Float32" Name="connectivity""#),
            "integers",
        ),
        (GOOD_CELLS.replace(r#"type="Int32" Name="offsets""#, r#"type="Float128" Name="offsets""#), "Float128"),
        (GOOD_CELLS.replace(">4<", ">-4<"), "offset"),
        (GOOD_CELLS.replace(">4<", ">99999999999<"), "offset"),
        (GOOD_CELLS.replace(">10<", ">300<"), "300"),
        (GOOD_CELLS.replace(">0 1 2 3<", ">0 1 2 -3<"), "point -3"),
        (GOOD_CELLS.replace(r#"format="ascii">10"#, r#"format="appended" offset="0">10"#), "AppendedData"),
        (GOOD_CELLS.replace(r#"format="ascii">10"#, r#"format="binary">//////8="#), "truncated"),
        (GOOD_CELLS.replace(r#"format="ascii">10"#, r#"format="binary">!!!!"#), "base64"),
        (GOOD_CELLS.replace(r#"format="ascii">10"#, r#"format="zip">10"#), "format"),
    ] {
        let e = read(tiny(piece, &cells).as_bytes()).unwrap_err();
        assert!(e.message.contains(expect), "expected '{expect}' in: {e}");
    }
    let zero_comp = tiny(r#"NumberOfPoints="4" NumberOfCells="1""#, GOOD_CELLS)
        .replace(r#"NumberOfComponents="3""#, r#"NumberOfComponents="0""#);
    assert!(read(zero_comp.as_bytes()).is_err());
    assert!(read(b"").is_err());
    assert!(read(b"<VTKFile").is_err());
    assert!(read(b"<NotVTK/>").is_err());
    assert!(read(br#"<VTKFile type="PolyData"><PolyData/></VTKFile>"#).unwrap_err().message.contains("PolyData"));
    let mut huge_appended = br#"<VTKFile type="ImageData" header_type="UInt64"><ImageData WholeExtent="0 1 0 1 0 1">
<Piece Extent="0 1 0 1 0 1"><PointData><DataArray type="Float64" Name="v" format="appended" offset="0"/></PointData>
</Piece></ImageData><AppendedData encoding="raw">_"#
        .to_vec();
    huge_appended.extend_from_slice(&u64::MAX.to_le_bytes());
    huge_appended.extend_from_slice(b"</AppendedData></VTKFile>");
    let e = read(&huge_appended).unwrap_err();
    assert!(matches!(e.at, Location::Byte(_)), "{e}");
}

/// VTK's Lagrange cells (written by VTK's own `vtkCellTypeSource`, bent onto
/// a quarter of a cylindrical shell of volume 3π/4: `make_lagrange.py`) are
/// cut into linear tets at all their nodes: the volume equals that of VTK's
/// own linear tessellation of the same cells (every sub-face is planar
/// here, so the two cuts enclose the same volume), three to ten times
/// closer to the exact one than the corners' — and the point field and
/// HigherOrderDegrees are read as VTK wrote them.
#[test]
fn lagrange_cells_are_cut_at_all_their_nodes() {
    let exact = 3.0 * std::f64::consts::PI / 4.0;
    // (file, cells, tets, volume of VTK's tessellation)
    for (name, cells, tets, vtk_volume) in [
        ("lagrange_hex_o3.vtu", 4, 4 * 27 * 6, 2.329371385288),
        ("lagrange_tet_o3.vtu", 48, 48 * 27, 2.329371385288),
        ("lagrange_wedge_o4.vtu", 8, 8 * 16 * 4 * 3, 2.341083778250),
        ("lagrange_hex_231.vtu", 1, 2 * 3 * 6, 2.250000014693),
        ("lagrange_hex_o1.vtu", 4, 4 * 6, 2.121320307255),
    ] {
        let m = load(name);
        assert_eq!(m.num_cells(), cells, "{name}");
        assert!(m.notes.iter().all(|n| !n.contains("reduced") && !n.contains("skipped")), "{name}: {:?}", m.notes);
        assert_eq!(m.point_fields.len(), 1, "{name}");
        let r2 = field(&m.point_fields, "r2");
        assert!(r2.values.iter().all(|&v| (1.0..=4.0 + 1e-12).contains(&v)), "{name}");
        assert!(m.cell_fields.is_empty(), "{name}: HigherOrderDegrees is no field");
        let (n, volume) = common::converted(&m);
        assert_eq!(n, tets, "{name}");
        assert!(close(volume, vtk_volume, 1e-9), "{name}: volume {volume}, VTK's tessellation {vtk_volume}");
        eprintln!("{name}: {n} tets, volume {volume:.9} (exact {exact:.9})");
    }
    let corners = 2.121320307255;
    assert!((2.329371385288 - exact).abs() * 8.0 < (corners - exact).abs());
    assert_eq!(unstructured(&load("lagrange_hex_231.vtu")).types, vec![CellType::LagrangeHexahedron([2, 3, 1])]);
    assert_eq!(unstructured(&load("lagrange_hex_o1.vtu")).types[0], CellType::Hexahedron);
}

/// Lagrange cells whose node count fits no order are errors naming the
/// cell and the count.
#[test]
fn lagrange_cells_with_wrong_node_counts_are_errors() {
    for (id, conn) in [(72, "0 1 2 3 0 1 2"), (71, "0 1 2 3 0 1 2 3 0 1 2"), (73, "0 1 2 3 0 1 2")] {
        let n = conn.split_whitespace().count();
        let file = tiny(
            r#"NumberOfPoints="4" NumberOfCells="1""#,
            &format!(
                r#"<DataArray type="Int64" Name="connectivity" format="ascii">{conn}</DataArray><DataArray type="Int64" Name="offsets" format="ascii">{n}</DataArray><DataArray type="UInt8" Name="types" format="ascii">{id}</DataArray>"#
            ),
        );
        let err = read(file.as_bytes()).unwrap_err().to_string();
        assert!(err.contains(&format!("cell 0 (VTK type {id})")) && err.contains(&format!("{n} nodes")), "{err}");
    }
}

/// VTK's Bézier tetrahedra, hexahedra (equal and unequal orders) and wedges,
/// polynomial and rational (`make_bezier.py`, written by VTK 9.7.2), become
/// Lagrange cells whose nodes are where VTK's own `EvaluateLocation` puts
/// the cells' lattice points, with the point scalar VTK interpolates there
/// (`bezier_nodes.txt`); the rational hexahedron's nodes lie on its
/// cylinders; two hexahedra sharing a face share their new points there,
/// so the tets conform.
#[test]
fn bezier_cells_are_evaluated_at_their_lattice_as_vtk_evaluates_them() {
    let dump = std::fs::read_to_string(path("bezier_nodes.txt")).unwrap();
    let mut checked = 0;
    for (name, cells, types) in [
        (
            "bezier_cells.vtu",
            6,
            vec![
                CellType::LagrangeTetra(3),
                CellType::LagrangeHexahedron([2, 2, 2]),
                CellType::LagrangeHexahedron([2, 2, 2]),
                CellType::LagrangeHexahedron([1, 2, 3]),
                CellType::LagrangeWedge(2, 1),
                CellType::LagrangeWedge(3, 3),
            ],
        ),
        ("bezier_rational.vtu", 2, vec![CellType::LagrangeHexahedron([2, 2, 2]), CellType::LagrangeTetra(2)]),
    ] {
        let m = load(name);
        assert_eq!(m.num_cells(), cells, "{name}");
        let c = unstructured(&m);
        assert_eq!(c.types, types, "{name}");
        let rational = name.contains("rational");
        let note = format!("evaluated {cells} {}Bézier cells", if rational { "rational " } else { "" });
        assert!(m.notes.iter().any(|n| n.contains(&note)), "{name}: {:?}", m.notes);
        let s = field(&m.point_fields, "s");
        for line in dump.lines().filter(|l| l.starts_with(name)) {
            let v: Vec<f64> = line.split_whitespace().skip(1).map(|x| x.parse().unwrap()).collect();
            let (cell, node) = (v[0] as usize, v[1] as usize);
            let p = c.nodes(cell)[node] as usize;
            let (x, want) = (m.points[p], [v[2], v[3], v[4]]);
            assert!(
                (0..3).all(|a| (x[a] - want[a]).abs() < 1e-12),
                "{name} cell {cell} node {node}: {x:?} vs VTK {want:?}"
            );
            assert!(
                (s.values[p] - v[5]).abs() < 1e-12,
                "{name} cell {cell} node {node}: s {} vs VTK {}",
                s.values[p],
                v[5]
            );
            checked += 1;
        }
        let (n, volume) = common::converted(&m);
        assert!(n > 0 && volume > 0.0, "{name}");
    }
    assert_eq!(checked, 187);
    // The stacked hexahedra (cells 1 and 2) name one point wherever their
    // nodes meet: 9 on the shared face.
    let m = load("bezier_cells.vtu");
    let c = unstructured(&m);
    let mut shared = 0;
    for &a in c.nodes(1) {
        for &b in c.nodes(2) {
            let (pa, pb) = (m.points[a as usize], m.points[b as usize]);
            if (0..3).all(|k| (pa[k] - pb[k]).abs() < 1e-9) {
                assert_eq!(a, b, "{pa:?}");
                shared += 1;
            }
        }
    }
    assert_eq!(shared, 9);
    // The rational hexahedron: radius 1, 1.5 or 2 at every node.
    let m = load("bezier_rational.vtu");
    for &p in unstructured(&m).nodes(0) {
        let [x, y, _] = m.points[p as usize];
        let r = x.hypot(y);
        assert!([1.0, 1.5, 2.0].iter().any(|&want| (r - want).abs() < 1e-14), "radius {r}");
    }
}

/// A `RationalWeights` attribute naming no array, and weights that are not
/// positive, are errors naming the piece; nothing is reduced silently.
#[test]
fn bezier_cells_with_bad_rational_weights_are_errors() {
    let text = String::from_utf8(bytes("bezier_rational.vtu")).unwrap();
    let missing = text.replace(r#"RationalWeights="RationalWeights""#, r#"RationalWeights="nope""#);
    let e = read(missing.as_bytes()).unwrap_err().to_string();
    assert!(e.contains("RationalWeights 'nope'"), "{e}");
    let start = text.find(r#"Name="RationalWeights""#).unwrap();
    let body = text[start..].find('>').unwrap() + start + 1;
    let mut zero = text.clone();
    let first = zero[body..].find(|c: char| c.is_ascii_digit()).unwrap() + body;
    let end = zero[first..].find(|c: char| c.is_whitespace()).unwrap() + first;
    zero.replace_range(first..end, "-0.5");
    let e = read(zero.as_bytes()).unwrap_err().to_string();
    assert!(e.contains("Bézier cells") && e.contains("weight -0.5"), "{e}");
}
