//! TetGen reader on meshes written by TetGen 1.5.0 (see tests/data/tetgen/LICENSE.md).
//! Expected counts are the headers TetGen wrote and its console report.

mod common;

use common::Lcg;
use std::path::Path;

use tet_io::tetgen;
use tet_mesh::{Block, CellType, Cells, SourceMesh};

const DIR: &str = concat!(env!("CARGO_MANIFEST_DIR"), "/../../tests/data/tetgen/");

fn load_pair(base: &str) -> (Vec<u8>, Vec<u8>) {
    let (node, ele) = tetgen::companion_paths(&Path::new(DIR).join(base));
    (std::fs::read(&node).unwrap(), std::fs::read(&ele).unwrap())
}

fn read(base: &str) -> SourceMesh {
    let (node, ele) = load_pair(base);
    tetgen::read(&node, &ele).unwrap_or_else(|e| panic!("{base}: {e}"))
}

fn cells(m: &SourceMesh) -> &Cells {
    match &m.blocks[0] {
        Block::Unstructured(c) => c,
        Block::Structured { .. } => panic!("structured block"),
    }
}

fn field<'a>(fields: &'a [tet_mesh::Field], name: &str) -> &'a tet_mesh::Field {
    fields.iter().find(|f| f.name == name).unwrap_or_else(|| panic!("no field {name}"))
}

#[test]
fn two_regions_with_boundary_markers() {
    let m = read("twobox.1.node");
    assert_eq!(m.format, "TetGen .node/.ele");
    assert_eq!(m.points.len(), 795);
    assert_eq!(cells(&m).len(), 3170);
    // The first tetrahedron line: "1  721 718 747 787  10".
    assert_eq!(cells(&m).nodes(0), &[720, 717, 746, 786]);
    let region = field(&m.cell_fields, "region");
    assert_eq!(region.values.iter().filter(|&&r| r == 10.0).count(), 2238);
    assert_eq!(region.values.iter().filter(|&&r| r == 20.0).count(), 932);
    let markers = field(&m.point_fields, "boundary_marker");
    assert_eq!(markers.values.iter().filter(|&&v| v == 0.0).count(), 213);
    assert_eq!(markers.values.iter().filter(|&&v| v == 1.0).count(), 183);
    // Markers 2..7 are the facets x = 2, x = 1, y = 0, y = 1, z = 0, z = 1 of twobox.poly
    // (marker 1, the facet x = 0, is also what TetGen gives points on segments).
    for (p, &v) in m.points.iter().zip(&markers.values) {
        let on_facet = match v as i32 {
            2 => p[0] == 2.0,
            3 => p[0] == 1.0,
            4 => p[1] == 0.0,
            5 => p[1] == 1.0,
            6 => p[2] == 0.0,
            7 => p[2] == 1.0,
            _ => true,
        };
        assert!(on_facet, "marker {v} at {p:?}");
    }
    assert_eq!(m.point_fields.len(), 1);
    // Region 10 is the cube x in [0, 1]: every tetrahedron lies on its side.
    for (c, &r) in region.values.iter().enumerate() {
        let xs = cells(&m).nodes(c).iter().map(|&n| m.points[n as usize][0]);
        if r == 10.0 {
            assert!(xs.clone().all(|x| x <= 1.0), "cell {c}");
        } else {
            assert!(xs.clone().all(|x| x >= 1.0), "cell {c}");
        }
    }
}

#[test]
fn zero_based_second_order_with_point_attributes() {
    let m = read("cloud.1");
    assert_eq!(m.points.len(), 1742);
    assert_eq!(cells(&m).len(), 1266);
    // "0  43 49 78 48  216 217 218 219 220 221", 0-based, kept whole in
    // VTK's order (TetGen's edge nodes lie on edges 2-3, 0-3, 0-1, 1-2,
    // 1-3, 0-2).
    assert_eq!(cells(&m).types[0], CellType::QuadraticTetra);
    assert_eq!(cells(&m).nodes(0), &[43, 49, 78, 48, 218, 219, 221, 217, 220, 216]);
    assert!(!m.notes.iter().any(|n| n.contains("reduced")), "{:?}", m.notes);
    assert!(m.cell_fields.is_empty());
    let sum = field(&m.point_fields, "attribute_0");
    let (lo, hi) = sum.values.iter().fold((f64::MAX, f64::MIN), |(a, b), &v| (a.min(v), b.max(v)));
    assert_eq!((lo, hi), (0.490479, 15.501588));
    let layer = field(&m.point_fields, "attribute_1");
    assert_eq!(layer.values.iter().filter(|&&v| v == 0.0).count(), 186);
    // The 216 input points keep their attribute x + y + z (to the 6 decimals written).
    for (p, &s) in m.points.iter().zip(&sum.values).take(216) {
        assert!((p[0] + p[1] + p[2] - s).abs() < 2e-6, "{p:?} {s}");
    }
}

#[test]
fn truncated_and_corrupted_files_never_panic() {
    let mut rng = Lcg(0x07e7_6e11);
    for base in ["twobox.1", "cloud.1"] {
        let (node, ele) = load_pair(base);
        for _ in 0..100 {
            let cut = rng.next() as usize % node.len();
            let _ = tetgen::read(&node[..cut], &ele);
            let cut = rng.next() as usize % ele.len();
            let _ = tetgen::read(&node, &ele[..cut]);
        }
        let (mut node_d, mut ele_d) = (node.clone(), ele.clone());
        for _ in 0..100 {
            let at = rng.next() as usize % node_d.len();
            let keep = node_d[at];
            node_d[at] = (rng.next() & 0xff) as u8;
            let _ = tetgen::read(&node_d, &ele);
            node_d[at] = keep;
            let at = rng.next() as usize % ele_d.len();
            let keep = ele_d[at];
            ele_d[at] = (rng.next() & 0xff) as u8;
            if let Err(e) = tetgen::read(&node, &ele_d) {
                assert!(e.in_companion, "{e}");
            }
            ele_d[at] = keep;
        }
    }
}

#[test]
fn ele_truncated_mid_file_is_a_companion_error() {
    let (node, ele) = load_pair("twobox.1");
    let e = tetgen::read(&node, &ele[..ele.len() / 2]).unwrap_err();
    assert!(e.in_companion, "{e}");
    assert!(matches!(e.at, tet_io::Location::Line(l) if l > 1000), "{e}");
}

/// TetGen's second-order output (`-o2`) over two unit cubes and over a
/// jittered point lattice: the ten-node tets are cut at their nodes into
/// 8 positive conforming tets each, of the first-order volume.
#[test]
fn second_order_tets_are_cut_at_their_nodes() {
    for (base, cells_in, volume) in [("twobox_o2.1", 136, Some(2.0)), ("cloud.1", 1266, None)] {
        let m = read(base);
        assert_eq!(cells(&m).len(), cells_in);
        let (mesh, report) = tet_mesh::tetrahedralize(&m, &Default::default(), &mut |_| {}).unwrap();
        assert_eq!(mesh.tets.len(), 8 * cells_in, "{base}");
        assert!(
            !report.findings.iter().any(|f| matches!(f, tet_mesh::Finding::DroppedZeroVolumeTets { .. })),
            "{base}: {:?}",
            report.findings
        );
        tet_mesh::build_adjacency(&mesh.points, &mesh.tets).expect("conforming");
        let cut = tet_mesh::mesh_stats(&mesh.points, &mesh.tets, &mesh.scalar).total_volume;
        let mut corners = m.clone();
        if let tet_mesh::Block::Unstructured(c) = &mut corners.blocks[0] {
            assert_eq!(c.reduce_to_corners(), cells_in);
        }
        let (linear, _) = tet_mesh::tetrahedralize(&corners, &Default::default(), &mut |_| {}).unwrap();
        let by_corners = tet_mesh::mesh_stats(&linear.points, &linear.tets, &linear.scalar).total_volume;
        assert!((cut - by_corners).abs() < 1e-9 * by_corners, "{base}: {cut} against {by_corners}");
        if let Some(v) = volume {
            assert!((cut - v).abs() < 1e-9, "{base}: {cut}");
        }
    }
}
