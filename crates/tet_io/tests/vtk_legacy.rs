//! Legacy VTK reader against real files (tests/data/vtk, see LICENSE.md
//! there). Expected counts, ids and ranges are what VTK 9.7's
//! `vtkDataSetReader` reports for the same files.

mod common;

use common::{assert_structured, Lcg};
use tet_io::vtk_legacy::read;
use tet_mesh::{Block, CellType, Field, SourceMesh};

fn data(name: &str) -> Vec<u8> {
    let path = format!("{}/../../tests/data/vtk/{name}", env!("CARGO_MANIFEST_DIR"));
    std::fs::read(&path).unwrap_or_else(|e| panic!("{path}: {e}"))
}

fn load(name: &str) -> SourceMesh {
    read(&data(name)).unwrap_or_else(|e| panic!("{name}: {e}"))
}

fn field<'m>(fields: &'m [Field], name: &str) -> &'m Field {
    fields
        .iter()
        .find(|f| f.name == name)
        .unwrap_or_else(|| panic!("no field '{name}' among {:?}", fields.iter().map(|f| &f.name).collect::<Vec<_>>()))
}

/// Min and max of component `c`.
fn range(f: &Field, c: usize) -> (f64, f64) {
    f.values
        .iter()
        .skip(c)
        .step_by(f.num_components)
        .fold((f64::INFINITY, f64::NEG_INFINITY), |(lo, hi), &v| (lo.min(v), hi.max(v)))
}

/// Equal up to float32 rounding (ASCII files are parsed to f64 directly,
/// VTK rounds them to float32 first).
fn close(a: f64, b: f64) -> bool {
    (a - b).abs() <= 1e-6 * a.abs().max(b.abs()).max(1e-3)
}

fn assert_close(a: f64, b: f64, what: &str) {
    assert!(close(a, b), "{what}: {a} != {b}");
}

fn assert_range(f: &Field, c: usize, lo: f64, hi: f64) {
    let (a, b) = range(f, c);
    assert_close(a, lo, &format!("min of {} [{c}]", f.name));
    assert_close(b, hi, &format!("max of {} [{c}]", f.name));
}

fn assert_point(m: &SourceMesh, i: usize, p: [f64; 3]) {
    for (&got, want) in m.points[i].iter().zip(p) {
        assert_close(got, want, &format!("point {i}"));
    }
}

fn unstructured(m: &SourceMesh) -> &tet_mesh::Cells {
    match &m.blocks[..] {
        [Block::Unstructured(c)] => c,
        b => panic!("expected one unstructured block, got {b:?}"),
    }
}

fn connectivity_sum(m: &SourceMesh) -> u64 {
    unstructured(m).connectivity.iter().map(|&p| u64::from(p)).sum()
}

/// What VTK reports of an unstructured grid: the point and cell counts,
/// the first and the last cell's nodes and the sum of every connectivity
/// entry.
fn assert_unstructured(m: &SourceMesh, points: usize, cells: usize, first_and_last: [&[u32]; 2], sum: u64) {
    assert_eq!(m.points.len(), points);
    let grid = unstructured(m);
    assert_eq!(grid.len(), cells);
    assert_eq!(grid.nodes(0), first_and_last[0]);
    assert_eq!(grid.nodes(cells - 1), first_and_last[1]);
    assert_eq!(connectivity_sum(m), sum);
}

#[test]
fn tetra_mesh_ascii() {
    let m = load("tetraMesh.vtk");
    assert_eq!(m.format, "legacy VTK (ASCII)");
    assert_unstructured(&m, 55, 160, [&[54, 32, 26, 7], &[18, 14, 15, 13]], 18388);
    assert!(unstructured(&m).types.iter().all(|&t| t == CellType::Tetra));
    assert_point(&m, 0, [9.780320167541504, -1.8030699491500854, 0.9875400066375732]);
    // The file has an empty CELL_DATA section and int scalars with a named
    // lookup table.
    assert!(m.cell_fields.is_empty());
    let s = field(&m.point_fields, "scalars");
    assert_eq!(s.num_components, 1);
    assert_range(s, 0, 0.0, 4.0);
    assert_eq!(s.values[0], 4.0);
}

#[test]
fn tetra_mesh_rewritten_as_5_1_binary_matches() {
    let a = load("tetraMesh.vtk");
    let b = load("tetraMesh.v51.binary.vtk");
    assert_eq!(b.format, "legacy VTK (BINARY)");
    assert_eq!(a.blocks, b.blocks);
    assert_eq!(a.points.len(), b.points.len());
    for (p, q) in a.points.iter().zip(&b.points) {
        for k in 0..3 {
            assert_close(p[k], q[k], "point");
        }
    }
    assert_eq!(a.point_fields[0].values, b.point_fields[0].values);
}

#[test]
fn cylinder_linear_binary_field_data() {
    let m = load("CylinderLinear.vtk");
    assert_eq!(m.format, "legacy VTK (BINARY)");
    assert_unstructured(&m, 465, 1522, [&[223, 106, 24, 149], &[105, 230, 28, 150]], 1764088);
    assert_point(&m, 1, [-0.01, 0.0, 0.1]);
    let v = field(&m.point_fields, "velocity");
    assert_eq!(v.num_components, 3);
    assert_eq!(v.values.len(), 465 * 3);
    assert_eq!(range(v, 0), (-0.05678484831776446, 0.1588816305233198));
    assert_eq!(range(v, 2), (-1.0043685178150694, 0.07778774197332797));
    let n = field(&m.point_fields, "vel_norm");
    assert_eq!(range(n, 0), (0.0, 1.0043985381775324));
    assert_close(n.values.iter().sum(), 81.62587898008042, "vel_norm sum");
}

#[test]
fn hexa_ascii() {
    let m = load("hexa.vtk");
    assert_unstructured(
        &m,
        12167,
        10648,
        [&[0, 1, 24, 23, 529, 530, 553, 552], &[11613, 11614, 11637, 11636, 12142, 12143, 12166, 12165]],
        518174272,
    );
    assert!(unstructured(&m).types.iter().all(|&t| t == CellType::Hexahedron));
    assert_point(&m, 12167 / 2, [0.47826099395751953; 3]);
    let s = field(&m.point_fields, "scalars");
    assert_range(s, 0, 0.7530649900436401, 17.320507049560547);
    assert_close(s.values.iter().sum(), 117057.72150850296, "scalars sum");
}

#[test]
fn post_big_endian_binary() {
    let m = load("post.vtk");
    assert_eq!(m.format, "legacy VTK (BINARY)");
    assert_unstructured(&m, 2288, 8750, [&[12, 1, 287, 0], &[2000, 2287, 2286, 2275]], 40022500);
    assert_eq!(m.points[0], [0.5, 0.0, 0.0]);
    assert_eq!(m.points[2287], [2.862497091293335, 0.0, 1.1255464553833008]);
    // The dataset-level FIELD (Properties) is skipped; POINT_DATA's FIELD
    // array becomes the point field.
    assert_eq!(m.point_fields.len(), 1);
    let p = field(&m.point_fields, "Pressure");
    assert_eq!(range(p, 0), (0.3553676903247833, 1.6412404775619507));
    assert_eq!(p.values[0], 0.9558984041213989);
    assert_close(p.values.iter().sum(), 1805.2697458863258, "Pressure sum");
}

#[test]
fn office_structured_grid_binary() {
    let m = load("office.binary.vtk");
    assert_structured(&m, [21, 20, 20], 8400, 7220);
    assert_eq!(m.points[1], [0.05000000074505806, 0.009999998845160007, 0.009999998845160007]);
    assert_eq!(m.points[8399], [4.5, 4.5, 2.5]);
    let s = field(&m.point_fields, "scalars");
    assert_eq!(range(s, 0), (-3.8695590496063232, 0.7185602784156799));
    assert_eq!(s.values[0], -3.8648390769958496);
    let v = field(&m.point_fields, "vectors");
    assert_eq!(v.num_components, 3);
    assert_eq!(range(v, 0), (-0.6728686094284058, 0.20417159795761108));
    assert_eq!(range(v, 2), (-0.3845081031322479, 0.4289461076259613));
}

#[test]
fn office_subgrid_ascii_structured_grid() {
    let m = load("office_voi.ascii.vtk");
    assert_eq!(m.blocks, vec![Block::Structured { dims: [5, 4, 3], first_point: 0 }]);
    assert_eq!(m.num_cells(), 24);
    assert_point(&m, 59, [0.4000000059604645, 0.25, 0.07000000029802322]);
    assert_range(field(&m.point_fields, "scalars"), 0, -3.8650100231170654, -3.7861499786376953);
    assert_range(field(&m.point_fields, "vectors"), 2, -0.005726169794797897, 0.054900601506233215);
}

#[test]
fn iron_protein_structured_points_aspect_ratio() {
    let m = load("ironProt.vtk");
    assert_structured(&m, [68, 68, 68], 314432, 300763);
    assert_eq!(m.points[1], [1.0, 0.0, 0.0]);
    assert_eq!(m.points[314432 / 2], [0.0, 0.0, 34.0]);
    assert_eq!(m.points[314431], [67.0, 67.0, 67.0]);
    let s = field(&m.point_fields, "scalars");
    assert_eq!(range(s, 0), (0.0, 255.0));
    assert_eq!(s.values.iter().sum::<f64>(), 4131089.0);
}

#[test]
fn color_scalars_ascii_and_binary_agree() {
    let a = load("ironProt_voi.ascii.vtk");
    let b = load("ironProt_voi.binary.vtk");
    for m in [&a, &b] {
        assert_eq!(m.blocks, vec![Block::Structured { dims: [6, 4, 3], first_point: 0 }]);
        assert_eq!(m.points[0], [30.0, 30.0, 30.0]);
        assert_eq!(m.points[71], [35.0, 33.0, 32.0]);
        let s = field(&m.point_fields, "scalars");
        assert_eq!(range(s, 0), (118.0, 255.0));
        assert_eq!(s.values[0], 229.0);
    }
    assert_eq!(a.point_fields, b.point_fields);
}

#[test]
fn rectilinear_ascii_and_binary() {
    for name in ["rectilinear.ascii.vtk", "rectilinear.binary.vtk"] {
        let m = load(name);
        assert_eq!(m.blocks, vec![Block::Structured { dims: [4, 3, 5], first_point: 0 }], "{name}");
        assert_eq!(m.points.len(), 60);
        assert_eq!(m.points[0], [0.0, -1.0, 0.0]);
        assert_eq!(m.points[1], [0.5, -1.0, 0.0]);
        assert_eq!(m.points[4], [0.0, 0.0, 0.0]);
        assert_eq!(m.points[59], [3.5, 2.0, 0.8]);
        // density = i + 10 j + 100 k at every point
        let d = field(&m.point_fields, "density");
        for (p, &v) in d.values.iter().enumerate() {
            let (i, j, k) = (p % 4, p / 4 % 3, p / 12);
            assert_eq!(v, (i + 10 * j + 100 * k) as f64, "{name} point {p}");
        }
        let r = field(&m.cell_fields, "region");
        assert_eq!(r.values, (0..24).map(|c| f64::from(c - 5)).collect::<Vec<_>>());
    }
}

/// The mixed mesh written by VTK in four variants: tet, triangle, hex,
/// voxel, wedge, pyramid, quadratic tet (kept whole).
#[test]
fn mixed_cells_all_variants() {
    for name in ["mixed.v42.ascii.vtk", "mixed.v42.binary.vtk", "mixed.v51.ascii.vtk", "mixed.v51.binary.vtk"] {
        let m = load(name);
        assert_eq!(m.points.len(), 44, "{name}");
        assert_eq!(m.points[43], [12.0, 0.5, 0.5]);
        let cells = unstructured(&m);
        use CellType::*;
        assert_eq!(cells.types, vec![Tetra, Hexahedron, Voxel, Wedge, Pyramid, QuadraticTetra], "{name}");
        assert_eq!(cells.nodes(0), &[0, 1, 2, 3]);
        assert_eq!(cells.nodes(1), &[7, 8, 9, 10, 11, 12, 13, 14]);
        assert_eq!(cells.nodes(4), &[29, 30, 31, 32, 33]);
        assert_eq!(cells.nodes(5), &(34..44).collect::<Vec<u32>>()[..]);
        assert!(!m.notes.iter().any(|n| n.contains("reduced")), "{name}: {:?}", m.notes);
        assert!(m.notes.iter().any(|n| n.contains("skipped 1 surface")), "{name}: {:?}", m.notes);

        let t = field(&m.point_fields, "temperature");
        assert_eq!(range(t, 0), (300.0, 343.0));
        let v = field(&m.point_fields, "velocity");
        assert_eq!(v.num_components, 3);
        assert_eq!((range(v, 0), range(v, 2)), ((0.0, 13.0), (-1.0, 0.0)));
        assert_eq!(range(field(&m.point_fields, "pressure"), 0), (99978.5, 100000.0));
        // `long` in binary is 8 bytes (VTK on LP64); values below -2^31 survive.
        assert_eq!(range(field(&m.point_fields, "long values"), 0), (-3000000000.0, -2999999957.0));

        // The triangle's CELL_DATA tuple is dropped with it; names decode %20.
        assert_eq!(field(&m.cell_fields, "cell id").values, vec![100.0, 102.0, 103.0, 104.0, 105.0, 106.0]);
        assert_eq!(field(&m.cell_fields, "global ids").values, vec![1000.0, 1002.0, 1003.0, 1004.0, 1005.0, 1006.0]);
        let cv = field(&m.cell_fields, "cell vec");
        assert_eq!(cv.num_components, 3);
        assert_eq!(&cv.values[..6], &[0.0, 0.0, -0.0, 2.0, 20.0, -0.5]);
        assert_eq!(cv.values.len(), 18);
    }
}

#[test]
fn polydata_is_refused() {
    let e = read(&data("sphere.polydata.vtk")).unwrap_err();
    assert!(e.message.starts_with("no volume cells: this file holds POLYDATA"), "{e}");
}

const SAMPLES: [&str; 17] = [
    "tetraMesh.vtk",
    "CylinderLinear.vtk",
    "hexa.vtk",
    "office.binary.vtk",
    "post.vtk",
    "ironProt.vtk",
    "tetraMesh.v51.binary.vtk",
    "mixed.v42.ascii.vtk",
    "mixed.v42.binary.vtk",
    "mixed.v51.ascii.vtk",
    "mixed.v51.binary.vtk",
    "rectilinear.ascii.vtk",
    "rectilinear.binary.vtk",
    "ironProt_voi.ascii.vtk",
    "ironProt_voi.binary.vtk",
    "office_voi.ascii.vtk",
    "sphere.polydata.vtk",
];

#[test]
fn truncated_and_corrupted_files_never_panic() {
    let mut rng = Lcg(0x5eed);
    for name in SAMPLES {
        let bytes = data(name);
        // Big files get fewer cuts so the test stays quick.
        let rounds = if bytes.len() > 100_000 { 40 } else { 200 };
        for _ in 0..rounds {
            let cut = rng.below(bytes.len());
            let _ = read(&bytes[..cut]);
        }
        let mut copy = bytes.clone();
        for _ in 0..rounds {
            let at = rng.below(copy.len());
            let old = copy[at];
            copy[at] = rng.below(256) as u8;
            let _ = read(&copy);
            copy[at] = old;
        }
        // Corruption concentrated in the headers, where counts live.
        let head = bytes.len().min(600);
        for _ in 0..rounds {
            let at = rng.below(head);
            let old = copy[at];
            copy[at] = b"0123456789-9 \n"[rng.below(14)];
            let _ = read(&copy);
            copy[at] = old;
        }
    }
}

#[test]
fn hostile_headers_are_errors() {
    let head = "# vtk DataFile Version 3.0\nx\n";
    let cases = [
        "ASCII\nDATASET UNSTRUCTURED_GRID\nPOINTS 999999999999999 float\n0 0 0\n",
        "BINARY\nDATASET UNSTRUCTURED_GRID\nPOINTS 999999999999999 double\n\0\0\0",
        "BINARY\nDATASET UNSTRUCTURED_GRID\nPOINTS 3074457345618258603 double\n\0\0\0",
        "ASCII\nDATASET UNSTRUCTURED_GRID\nPOINTS -3 float\n",
        "ASCII\nDATASET UNSTRUCTURED_GRID\nPOINTS 1 float\n0 0 0\nCELLS -1 5\n",
        "ASCII\nDATASET UNSTRUCTURED_GRID\nPOINTS 1 float\n0 0 0\nCELLS 1 999999999999\n4 0 0 0 0\n",
        "BINARY\nDATASET UNSTRUCTURED_GRID\nPOINTS 1 float\n\0\0\0\0\0\0\0\0\0\0\0\0\nCELLS 2 4\nOFFSETS vtktypeint64\n",
        "ASCII\nDATASET UNSTRUCTURED_GRID\nPOINTS 4 float\n0 0 0 1 0 0 0 1 0 0 0 1\nCELLS 1 5\n99 0 1 2 3\nCELL_TYPES 1\n10\n",
        "ASCII\nDATASET UNSTRUCTURED_GRID\nPOINTS 4 float\n0 0 0 1 0 0 0 1 0 0 0 1\nCELLS 1 5\n4 0 1 2 9\nCELL_TYPES 1\n10\n",
        "ASCII\nDATASET UNSTRUCTURED_GRID\nPOINTS 4 float\n0 0 0 1 0 0 0 1 0 0 0 1\nCELLS 1 5\n4 0 1 2 3\nCELL_TYPES 1\n-10\n",
        "ASCII\nDATASET UNSTRUCTURED_GRID\nPOINTS 4 quaternion\n0 0 0 1 0 0 0 1 0 0 0 1\n",
        "ASCII\nDATASET UNSTRUCTURED_GRID\nPOINTS 4 float\n0 0 0 1 0 0 0 1 0 0 0 1\nCELLS 1 5\n4 0 1 2 3\nCELL_TYPES 1\n10\nPOINT_DATA 4\nSCALARS s float 0\n",
        "ASCII\nDATASET UNSTRUCTURED_GRID\nPOINTS 4 float\n0 0 0 1 0 0 0 1 0 0 0 1\nCELLS 1 5\n4 0 1 2 3\nCELL_TYPES 1\n10\nPOINT_DATA 99999999999\nSCALARS s float\n1\n",
        "ASCII\nDATASET UNSTRUCTURED_GRID\nPOINTS 4 float\n0 0 0 1 0 0 0 1 0 0 0 1\nCELLS 1 5\n4 0 1 2 3\nCELL_TYPES 1\n10\nPOINT_DATA 4\nFIELD f 1\na 99999999 99999999999 double\n",
        "ASCII\nDATASET STRUCTURED_POINTS\nDIMENSIONS 2000000 2000000 2000000\nPOINT_DATA 8\n",
        "ASCII\nDATASET STRUCTURED_POINTS\nDIMENSIONS 2 2 -2\n",
        "ASCII\nDATASET STRUCTURED_GRID\nDIMENSIONS 2 2 2\nPOINTS 7 float\n0 0 0 0 0 0 0 0 0 0 0 0 0 0 0 0 0 0 0 0 0\n",
        "ASCII\nDATASET RECTILINEAR_GRID\nDIMENSIONS 3000 3000 3000\nX_COORDINATES 1 float\n0\n",
        "ASCII\nDATASET UNSTRUCTURED_GRID\nLINES 3 4\n",
        "EBCDIC\nDATASET UNSTRUCTURED_GRID\n",
        "ASCII\nDATASET TABLE\n",
        "ASCII\nPOINT_DATA 4\n",
    ];
    for body in cases {
        let text = format!("{head}{body}");
        match read(text.as_bytes()) {
            Ok(_) => panic!("accepted: {body:?}"),
            Err(e) => eprintln!("{e}"),
        }
    }
    assert!(read(b"").is_err());
    assert!(read(b"# vtk DataFile Version 3.0").is_err());
    assert!(read(b"solid cube\nfacet normal 0 0 1\n").is_err());
}

/// A legacy file of VTK's Lagrange tetrahedra (VTK's own legacy writer, no
/// HigherOrderDegrees: the order follows from the node count) is read as
/// the XML one: 48 order-3 tets, each cut into 27.
#[test]
fn lagrange_tets_from_a_legacy_file() {
    let path = concat!(env!("CARGO_MANIFEST_DIR"), "/../../tests/data/vtu/lagrange_tet_o3.vtk");
    let m = tet_io::vtk_legacy::read(&std::fs::read(path).unwrap()).unwrap();
    let cells = unstructured(&m);
    assert_eq!(cells.len(), 48);
    assert!(cells.types.iter().all(|&t| t == tet_mesh::CellType::LagrangeTetra(3)));
    let (tets, volume) = common::converted(&m);
    assert_eq!(tets, 48 * 27);
    assert_close(volume, 2.329371385288, "volume");
}

/// VTK's Bézier cells in a binary legacy file (VTK's own writer; no
/// HigherOrderDegrees or RationalWeights there: equal orders, polynomial)
/// become Lagrange cells whose nodes and point scalar are what VTK's
/// `EvaluateLocation` gives at their lattice points
/// (`tests/data/vtu/make_bezier.py`).
#[test]
fn bezier_cells_from_a_legacy_file_are_evaluated_as_vtk_does() {
    let dir = concat!(env!("CARGO_MANIFEST_DIR"), "/../../tests/data/vtu/");
    let m = read(&std::fs::read(format!("{dir}bezier_cells.vtk")).unwrap()).unwrap();
    let cells = unstructured(&m);
    assert_eq!(
        cells.types,
        vec![
            CellType::LagrangeTetra(3),
            CellType::LagrangeHexahedron([2, 2, 2]),
            CellType::LagrangeHexahedron([2, 2, 2]),
            CellType::LagrangeWedge(3, 3)
        ]
    );
    assert!(m.notes.iter().any(|n| n.contains("evaluated 4 Bézier cells")), "{:?}", m.notes);
    let s = field(&m.point_fields, "s");
    let dump = std::fs::read_to_string(format!("{dir}bezier_nodes.txt")).unwrap();
    let mut checked = 0;
    for line in dump.lines().filter(|l| l.starts_with("bezier_cells.vtk ")) {
        let v: Vec<f64> = line.split_whitespace().skip(1).map(|x| x.parse().unwrap()).collect();
        let p = cells.nodes(v[0] as usize)[v[1] as usize] as usize;
        assert!((0..3).all(|a| (m.points[p][a] - v[2 + a]).abs() < 1e-12), "{line}: {:?}", m.points[p]);
        assert!((s.values[p] - v[5]).abs() < 1e-12, "{line}: s {}", s.values[p]);
        checked += 1;
    }
    assert_eq!(checked, 20 + 27 + 27 + 40);
    let (tets, volume) = common::converted(&m);
    assert!(tets > 0 && volume > 0.0);
}
