//! Gmsh reader on meshes written by Gmsh 4.8.4 (see tests/data/gmsh/LICENSE.md).
//! Expected counts are Gmsh's own (its VTK export of each file).

mod common;

use common::Lcg;
use std::collections::BTreeMap;

use tet_io::gmsh;
use tet_mesh::{Block, CellType, Cells, SourceMesh};

const DIR: &str = concat!(env!("CARGO_MANIFEST_DIR"), "/../../tests/data/gmsh/");

const ALL: [&str; 16] = [
    "boxcyl_22_ascii.msh",
    "boxcyl_22_bin.msh",
    "boxcyl_41_ascii.msh",
    "boxcyl_41_bin.msh",
    "boxcyl_o2_41_bin.msh",
    "hexbox_22_ascii.msh",
    "hexbox_41_bin.msh",
    "hexbox_param_41_ascii.msh",
    "hexbox_o3_41_ascii.msh",
    "mixed_22_ascii.msh",
    "mixed_41_ascii.msh",
    "mixed_o2_41_ascii.msh",
    "mixed_o2i_22_bin.msh",
    "mixed_o3_41_bin.msh",
    "boxcyl_o3_41_bin.msh",
    "prismquarter_o3_41_ascii.msh",
];

fn load(name: &str) -> Vec<u8> {
    std::fs::read(format!("{DIR}{name}")).unwrap_or_else(|e| panic!("{name}: {e}"))
}

fn read(name: &str) -> SourceMesh {
    gmsh::read(&load(name)).unwrap_or_else(|e| panic!("{name}: {e}"))
}

fn cells(m: &SourceMesh) -> &Cells {
    assert_eq!(m.blocks.len(), 1);
    match &m.blocks[0] {
        Block::Unstructured(c) => c,
        Block::Structured { .. } => panic!("structured block"),
    }
}

/// Cell counts as (tets, hexes, wedges, pyramids).
fn counts(m: &SourceMesh) -> (usize, usize, usize, usize) {
    let mut by_type = BTreeMap::new();
    for t in &cells(m).types {
        // Quadratic cells counted with their linear family.
        *by_type.entry(format!("{:?}", t.linear())).or_insert(0usize) += 1;
    }
    let get = |k: &str| by_type.get(k).copied().unwrap_or(0);
    (get("Tetra"), get("Hexahedron"), get("Wedge"), get("Pyramid"))
}

fn field<'a>(fields: &'a [tet_mesh::Field], name: &str) -> &'a tet_mesh::Field {
    fields.iter().find(|f| f.name == name).unwrap_or_else(|| panic!("no field {name}"))
}

fn has_note(m: &SourceMesh, text: &str) -> bool {
    m.notes.iter().any(|n| n.contains(text))
}

#[test]
fn boxcyl_all_four_encodings_agree() {
    let reference = read("boxcyl_22_ascii.msh");
    for (name, format) in [
        ("boxcyl_22_ascii.msh", "Gmsh 2.2 (ASCII)"),
        ("boxcyl_22_bin.msh", "Gmsh 2.2 (binary)"),
        ("boxcyl_41_ascii.msh", "Gmsh 4.1 (ASCII)"),
        ("boxcyl_41_bin.msh", "Gmsh 4.1 (binary)"),
    ] {
        let m = read(name);
        assert_eq!(m.format, format);
        assert_eq!(m.points.len(), 419, "{name}");
        assert_eq!(counts(&m), (1333, 0, 0, 0), "{name}");
        assert!(has_note(&m, "skipped 728 lower-dimensional elements"), "{name}: {:?}", m.notes);
        assert!(has_note(&m, "kept the last of 2 time steps"), "{name}: {:?}", m.notes);
        assert!(has_note(&m, "7 \"solid\""), "{name}: {:?}", m.notes);
        assert!(has_note(&m, "$InterpolationScheme"), "{name}: {:?}", m.notes);
        assert_eq!(cells(&m), cells(&reference), "{name}");
        for (p, q) in m.points.iter().zip(&reference.points) {
            for k in 0..3 {
                assert!((p[k] - q[k]).abs() <= 1e-12, "{name}: {p:?} vs {q:?}");
            }
        }

        // pressure = 1000 + x + 10 y + 100 z in the last time step, at every node.
        let pressure = field(&m.point_fields, "pressure_Combine");
        assert_eq!(pressure.num_components, 1);
        for (p, &v) in m.points.iter().zip(&pressure.values) {
            let expected = 1000.0 + p[0] + 10.0 * p[1] + 100.0 * p[2];
            assert!((v - expected).abs() < 1e-9, "{name}: pressure {v} at {p:?}");
        }
        let velocity = field(&m.point_fields, "velocity");
        assert_eq!(velocity.num_components, 3);
        for (p, v) in m.points.iter().zip(velocity.values.chunks(3)) {
            for k in 0..3 {
                assert!((v[k] - p[k]).abs() < 1e-12, "{name}: velocity {v:?} at {p:?}");
            }
        }
        let icn = field(&m.cell_fields, "ICN 3D");
        assert_eq!(icn.values.len(), 1333);
        let (lo, hi) = icn.values.iter().fold((f64::MAX, f64::MIN), |(a, b), &v| (a.min(v), b.max(v)));
        assert!((lo - 0.390106224220188).abs() < 1e-12 && (hi - 1.0).abs() < 1e-12, "{name}: {lo} {hi}");
        assert!(field(&m.cell_fields, "gmsh:physical").values.iter().all(|&v| v == 7.0));
        assert!(field(&m.cell_fields, "gmsh:geometrical").values.iter().all(|&v| v == 3.0));
    }
}

#[test]
fn hexahedra_are_in_vtk_order() {
    for name in ["hexbox_22_ascii.msh", "hexbox_41_bin.msh", "hexbox_param_41_ascii.msh"] {
        let m = read(name);
        assert_eq!(m.points.len(), 270, "{name}");
        assert_eq!(counts(&m), (0, 160, 0, 0), "{name}");
        assert!(has_note(&m, "skipped 260 lower-dimensional"), "{name}: {:?}", m.notes);
        // No physical groups in hexbox.geo: no gmsh:physical field.
        assert!(m.cell_fields.iter().all(|f| f.name != "gmsh:physical"));
        let c = cells(&m);
        for i in 0..c.len() {
            let p: Vec<[f64; 3]> = c.nodes(i).iter().map(|&n| m.points[n as usize]).collect();
            // Bottom quad at one z, top quad above it, vertical edges i -> i + 4,
            // consecutive bottom corners along one axis (a quad, not a bow tie).
            let differ = |a: f64, b: f64| (a - b).abs() > 1e-9;
            for k in 0..4 {
                assert!(!differ(p[k][2], p[0][2]), "{name} cell {i}");
                assert!(p[k + 4][2] > p[k][2], "{name} cell {i}");
                assert!(!differ(p[k + 4][0], p[k][0]) && !differ(p[k + 4][1], p[k][1]), "{name} cell {i}");
                let next = p[(k + 1) % 4];
                let moved = differ(p[k][0], next[0]) as u8 + differ(p[k][1], next[1]) as u8;
                assert_eq!(moved, 1, "{name} cell {i}");
            }
        }
    }
    let param = read("hexbox_param_41_ascii.msh");
    assert_eq!(param.points, read("hexbox_22_ascii.msh").points);
}

#[test]
fn mixed_prisms_pyramids_and_orders() {
    for (name, points) in [
        ("mixed_22_ascii.msh", 280),
        ("mixed_41_ascii.msh", 280),
        ("mixed_o2_41_ascii.msh", 1738),
        ("mixed_o2i_22_bin.msh", 1305),
    ] {
        let m = read(name);
        assert_eq!(m.points.len(), points, "{name}");
        assert_eq!(counts(&m), (286, 48, 126, 16), "{name}");
        assert!(has_note(&m, "skipped 444 lower-dimensional"), "{name}: {:?}", m.notes);
        // Second order, complete or not, is kept whole (cut at all nodes).
        assert!(!has_note(&m, "reduced"), "{name}: {:?}", m.notes);
        let c = cells(&m);
        for i in 0..c.len() {
            let p: Vec<[f64; 3]> = c.nodes(i).iter().map(|&n| m.points[n as usize]).collect();
            match c.types[i] {
                // Extruded prisms: triangle 0-1-2 below 3-4-5, edges k -> k + 3 vertical.
                CellType::Wedge | CellType::QuadraticWedge => {
                    for k in 0..3 {
                        assert_eq!((p[k + 3][0], p[k + 3][1]), (p[k][0], p[k][1]), "{name} cell {i}");
                        assert!(p[k + 3][2] > p[k][2], "{name} cell {i}");
                    }
                }
                // Pyramids sit on the hexahedra's top quads (z = 0.5), apex above.
                CellType::Pyramid | CellType::QuadraticPyramid => {
                    for corner in &p[..4] {
                        assert!((corner[2] - 0.5).abs() < 1e-12, "{name} cell {i}");
                    }
                    assert!(p[4][2] > 0.5, "{name} cell {i}");
                }
                _ => {}
            }
        }
    }
    let linear = read("mixed_41_ascii.msh");
    let quadratic = read("mixed_o2_41_ascii.msh");
    // Corner nodes come first in Gmsh's numbering too, so corners match the linear mesh.
    let lc = cells(&linear);
    let qc = cells(&quadratic);
    for i in 0..lc.len() {
        let a: Vec<[f64; 3]> = lc.nodes(i).iter().map(|&n| linear.points[n as usize]).collect();
        let b: Vec<[f64; 3]> = qc.nodes(i)[..a.len()].iter().map(|&n| quadratic.points[n as usize]).collect();
        assert_eq!(a, b, "cell {i}");
    }
}

#[test]
fn higher_orders() {
    // Second-order tets alone keep their ten nodes (cut at them later).
    let m = read("boxcyl_o2_41_bin.msh");
    assert_eq!(m.points.len(), 2195);
    assert!(cells(&m).types.iter().all(|&t| t == CellType::QuadraticTetra) && cells(&m).len() == 1133);
    assert!(!has_note(&m, "reduced") && has_note(&m, "skipped 656 lower"), "{:?}", m.notes);

    let m = read("hexbox_o3_41_ascii.msh");
    assert_eq!((m.points.len(), counts(&m)), (490, (0, 12, 0, 0)));
    assert!(has_note(&m, "skipped 68 lower"), "{:?}", m.notes);

    let m = read("mixed_o3_41_bin.msh");
    assert_eq!((m.points.len(), counts(&m)), (3573, (189, 48, 54, 16)));
    assert!(!has_note(&m, "reduced") && has_note(&m, "skipped 278 lower"), "{:?}", m.notes);
}

/// Gmsh's complete third order (tet20, hex64, prism40) is read as VTK's Lagrange
/// cells and cut at all its nodes: the straight-sided hexahedra keep their
/// corners' volume, the curved tetrahedra around the cylinder come closer
/// to the exact volume than second order did (1.808307, error 4.7e-3).
#[test]
fn third_order_cells_are_cut_at_their_nodes() {
    use common::converted;
    let hexes = read("hexbox_o3_41_ascii.msh");
    assert!(cells(&hexes).types.iter().all(|&t| t == CellType::LagrangeHexahedron([3, 3, 3])));
    assert!(!has_note(&hexes, "reduced"), "{:?}", hexes.notes);
    let mut corners = hexes.clone();
    corners.reduce_to_corners();
    let ((n, cut), (_, by_corners)) = (converted(&hexes), converted(&corners));
    assert_eq!(n, 12 * 27 * 6);
    assert!((cut - by_corners).abs() < 1e-12, "{cut} {by_corners}");

    let tets = read("boxcyl_o3_41_bin.msh");
    assert!(cells(&tets).types.iter().all(|&t| t == CellType::LagrangeTetra(3)) && cells(&tets).len() == 1149);
    let mut corners = tets.clone();
    corners.reduce_to_corners();
    let ((n, cut), (_, by_corners)) = (converted(&tets), converted(&corners));
    assert_eq!(n, 1149 * 27);
    let exact = 2.0 - std::f64::consts::PI / 16.0;
    eprintln!("volume: cut {cut:.6}, corners {by_corners:.6}, exact {exact:.6}");
    assert!((cut - exact).abs() < 0.25 * (by_corners - exact).abs(), "cut {cut}, corners {by_corners}");
    assert!((cut - exact).abs() < (1.808307 - exact), "cut {cut}: not closer than second order");

    // Gmsh's mixed mesh at third order (tet20, hex64, prism40, pyramid30;
    // straight-sided): every cell cut at its nodes, conforming across all
    // the kinds of faces, the corners' volume.
    let mixed = read("mixed_o3_41_bin.msh");
    let types = &cells(&mixed).types;
    for t in [
        CellType::LagrangeTetra(3),
        CellType::LagrangeHexahedron([3; 3]),
        CellType::LagrangeWedge(3, 3),
        CellType::LagrangePyramid(3),
    ] {
        assert!(types.contains(&t), "{t:?}");
    }
    let mut corners = mixed.clone();
    corners.reduce_to_corners();
    let ((n, cut), (_, by_corners)) = (converted(&mixed), converted(&corners));
    assert_eq!(n, 189 * 27 + 48 * 27 * 6 + 54 * 27 * 3 + 16 * (2 * (14 + 5) + 16));
    assert!((cut - by_corners).abs() < 1e-12 * by_corners, "{cut} {by_corners}");

    // Curved third-order prisms (a quarter disk extruded; exact volume π/4).
    let prisms = read("prismquarter_o3_41_ascii.msh");
    let n_prisms = cells(&prisms).len();
    assert!(n_prisms > 20 && cells(&prisms).types.iter().all(|&t| t == CellType::LagrangeWedge(3, 3)));
    let mut corners = prisms.clone();
    corners.reduce_to_corners();
    let ((n, cut), (_, by_corners)) = (converted(&prisms), converted(&corners));
    assert_eq!(n, n_prisms * 27 * 3);
    let exact = std::f64::consts::FRAC_PI_4;
    eprintln!("prisms: volume cut {cut:.6}, corners {by_corners:.6}, exact {exact:.6}");
    assert!((cut - exact).abs() < 0.25 * (by_corners - exact).abs(), "cut {cut}, corners {by_corners}");
}

#[test]
fn truncated_and_corrupted_files_never_panic() {
    let mut rng = Lcg(0x5eed_6d73);
    for name in ALL {
        let bytes = load(name);
        for _ in 0..200 {
            let cut = rng.next() as usize % bytes.len();
            let _ = gmsh::read(&bytes[..cut]);
        }
        let mut damaged = bytes.clone();
        for _ in 0..200 {
            let at = rng.next() as usize % damaged.len();
            let original = damaged[at];
            damaged[at] = (rng.next() & 0xff) as u8;
            let _ = gmsh::read(&damaged);
            damaged[at] = original;
        }
    }
}

#[test]
fn truncated_binary_reports_a_byte_offset() {
    let bytes = load("boxcyl_41_bin.msh");
    let e = gmsh::read(&bytes[..bytes.len() / 2]).unwrap_err();
    assert!(matches!(e.at, tet_io::Location::Byte(_)), "{e}");
    let e = gmsh::read(&load("boxcyl_41_ascii.msh")[..60_000]).unwrap_err();
    assert!(matches!(e.at, tet_io::Location::Line(_)), "{e}");
}

/// The box with a cylindrical hole meshed by Gmsh with second-order tets
/// (mid-edge nodes on the curved hole): cut at their ten nodes, the 1133
/// cells give 8 positive tets each (none re-oriented or dropped) that
/// conform, and a volume nearer the true one (2 − π/16) than the cells'
/// corners give.
#[test]
fn second_order_tets_are_cut_at_their_nodes() {
    let quadratic = read("boxcyl_o2_41_bin.msh");
    let mut corners = quadratic.clone();
    for b in &mut corners.blocks {
        if let tet_mesh::Block::Unstructured(c) = b {
            assert_eq!(c.reduce_to_corners(), 1133);
        }
    }
    let volume = |m: &SourceMesh, tets: usize| {
        let (n, volume) = common::converted(m);
        assert_eq!(n, tets);
        volume
    };
    let exact = 2.0 - std::f64::consts::PI / 16.0;
    let (cut, by_corners) = (volume(&quadratic, 8 * 1133), volume(&corners, 1133));
    eprintln!("volume: cut {cut:.6}, corners {by_corners:.6}, exact {exact:.6}");
    assert!((cut - exact).abs() < 0.5 * (by_corners - exact).abs(), "cut {cut}, corners {by_corners}, exact {exact}");
}

/// Gmsh's second order, incomplete (10-node tets, 20-node hexahedra,
/// 15-node prisms, 13-node pyramids) and complete (27-node hexahedra,
/// 18-node prisms, 14-node pyramids), on straight edges, read in VTK's node
/// orders: each edge node sits at the middle of the edge VTK's order puts
/// it on, each face or body node at the centroid of its corners; cut at all
/// nodes the mesh is conforming, with no flat tet and the volume of the
/// first-order mesh of the same geometry.
#[test]
fn second_order_cells_are_cut_at_their_nodes() {
    let convert = |m: &SourceMesh| {
        let (mesh, report) = tet_mesh::tetrahedralize(m, &Default::default(), &mut |_| {}).unwrap();
        assert!(
            !report.findings.iter().any(|f| matches!(f, tet_mesh::Finding::DroppedZeroVolumeTets { .. })),
            "{:?}",
            report.findings
        );
        tet_mesh::build_adjacency(&mesh.points, &mesh.tets).expect("conforming");
        (mesh.tets.len(), tet_mesh::mesh_stats(&mesh.points, &mesh.tets, &mesh.scalar).total_volume)
    };
    let (linear_tets, linear) = convert(&read("mixed_41_ascii.msh"));
    assert_eq!(linear_tets, 984);
    // (286 tets, 48 hexahedra, 126 prisms, 16 pyramids: 8, 22 or 48, 14–15
    // or 24, and 13 or 16 tets each, against 1, 6, 3 and 2.)
    for (name, tets) in [
        ("mixed_o2i_22_bin.msh", 5300..=5500),
        ("mixed_o2_41_ascii.msh", 2288 + 2304 + 3024 + 256..=2288 + 2304 + 3024 + 256),
    ] {
        let m = read(name);
        let c = cells(&m);
        for i in 0..c.len() {
            let n = c.nodes(i);
            let p = |k: usize| m.points[n[k] as usize];
            // Each edge node at its edge's middle, each face or body node at
            // its corners' centroid, in VTK's order.
            let parents = c.types[i].straight_sided_parents();
            assert!(!parents.is_empty(), "{:?} is not a second-order cell", c.types[i]);
            let corners = n.len() - parents.len();
            let wanted =
                parents.iter().map(|f| [0, 1, 2].map(|x| f.iter().map(|&k| p(k)[x]).sum::<f64>() / f.len() as f64));
            for (k, w) in wanted.enumerate() {
                let at = p(corners + k);
                let off = (0..3).map(|x| (at[x] - w[x]).abs()).fold(0.0, f64::max);
                assert!(off < 1e-9, "{name} cell {i} ({:?}) node {}", c.types[i], corners + k);
            }
        }
        let (cut_tets, cut) = convert(&m);
        assert!(tets.contains(&cut_tets), "{name}: {cut_tets} tets");
        assert!((cut - linear).abs() < 1e-12 * linear, "{name}: {cut} against {linear}");
    }
}
