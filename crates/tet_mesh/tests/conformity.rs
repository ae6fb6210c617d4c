//! Property tests: mixed hexahedron/voxel/pyramid meshes with arbitrary
//! global numbering and jittered points split into tets that conform (no
//! cracks: the only boundary faces are the domain's), fill the volume, and
//! pass the invariant checkers.
use proptest::prelude::*;
use tet_mesh::predicates::signed_tet_volume;
use tet_mesh::split::{structured_hex, structured_points, UNIT_HEX};
use tet_mesh::{
    build_adjacency, check_adjacency, check_tet_mesh, tetrahedralize, Block, CellType, Cells, ConvertOptions,
    SourceMesh, SplitMode,
};

#[derive(Debug, Clone, Copy)]
enum Kind {
    Hex,
    Voxel,
    SixPyramids,
}

/// Grid point (i, j, k) at (i, j, k) moved by `jitter`'s entries, cycled
/// through in grid order.
fn jittered_grid(dims: [usize; 3], jitter: &[f64]) -> Vec<[f64; 3]> {
    structured_points(dims, |ijk| {
        let g = ijk[0] + dims[0] * (ijk[1] + dims[1] * ijk[2]);
        [0, 1, 2].map(|a| ijk[a] as f64 + jitter[(g * 3 + a) % jitter.len()])
    })
}

fn mesh(dims: [usize; 3], kinds: &[Kind], perm_seed: u64, jitter: &[f64]) -> SourceMesh {
    let [nx, ny, nz] = dims;
    let np = (nx + 1) * (ny + 1) * (nz + 1);
    // A random permutation of the grid point ids (changes every min-id choice).
    let mut perm: Vec<u32> = (0..np as u32).collect();
    let mut s = perm_seed | 1;
    for i in (1..np).rev() {
        s ^= s << 13;
        s ^= s >> 7;
        s ^= s << 17;
        perm.swap(i, (s % (i as u64 + 1)) as usize);
    }
    let grid = [nx + 1, ny + 1, nz + 1];
    let mut points = vec![[0.0; 3]; np];
    for (g, p) in jittered_grid(grid, jitter).into_iter().enumerate() {
        points[perm[g] as usize] = p;
    }
    let mut cells = Cells::new();
    let mut c = 0;
    for k in 0..nz {
        for j in 0..ny {
            for i in 0..nx {
                let h = structured_hex(grid, 0, i, j, k).map(|g| perm[g]);
                match kinds[c % kinds.len()] {
                    Kind::Hex => cells.push(CellType::Hexahedron, &h),
                    Kind::Voxel => cells.push(CellType::Voxel, &[h[0], h[1], h[3], h[2], h[4], h[5], h[7], h[6]]),
                    Kind::SixPyramids => {
                        let centre = points.len() as u32;
                        let mut m = [0.0; 3];
                        for v in h {
                            for a in 0..3 {
                                m[a] += points[v as usize][a] / 8.0;
                            }
                        }
                        points.push(m);
                        for f in [[0, 1, 2, 3], [4, 5, 6, 7], [0, 1, 5, 4], [1, 2, 6, 5], [2, 3, 7, 6], [3, 0, 4, 7]] {
                            cells.push(CellType::Pyramid, &[h[f[0]], h[f[1]], h[f[2]], h[f[3]], centre]);
                        }
                    }
                }
                c += 1;
            }
        }
    }
    SourceMesh { points, blocks: vec![Block::Unstructured(cells)], ..Default::default() }
}

fn kind() -> impl Strategy<Value = Kind> {
    prop_oneof![Just(Kind::Hex), Just(Kind::Voxel), Just(Kind::SixPyramids)]
}

proptest! {
    #![proptest_config(ProptestConfig { cases: 64, ..ProptestConfig::default() })]

    #[test]
    fn mixed_cells_conform(
        dims in [1usize..4, 1usize..4, 1usize..4],
        kinds in prop::collection::vec(kind(), 1..6),
        perm_seed in any::<u64>(),
        jitter in prop::collection::vec(-0.15f64..0.15, 7..40),
    ) {
        let src = mesh(dims, &kinds, perm_seed, &jitter);
        let (m, report) = tetrahedralize(&src, &ConvertOptions::default(), &mut |_| {}).unwrap();
        prop_assert_eq!(report.split_tets, m.tets.len(), "no tet may be flat here");
        check_tet_mesh(&m).unwrap();
        let adj = build_adjacency(&m.points, &m.tets).unwrap();
        check_adjacency(&m.tets, &adj).unwrap();
        let [nx, ny, nz] = dims;
        prop_assert_eq!(adj.boundary_faces.len(), 4 * (nx * ny + ny * nz + nx * nz), "cracks inside the domain");
        // The tets' volume is the volume bounded by the split boundary, which
        // is the same for any cell mix: compare with the all-hexahedra mesh.
        let hex_only = mesh(dims, &[Kind::Hex], perm_seed, &jitter);
        let (h, _) = tetrahedralize(&hex_only, &ConvertOptions::default(), &mut |_| {}).unwrap();
        let vol = |m: &tet_mesh::TetMesh| -> f64 {
            m.tets.iter().map(|t| signed_tet_volume(&m.points[t[0] as usize], &m.points[t[1] as usize], &m.points[t[2] as usize], &m.points[t[3] as usize])).sum()
        };
        prop_assert!((vol(&m) - vol(&h)).abs() < 1e-9 * vol(&h));
    }

    #[test]
    fn structured_splits_conform(dims in [2usize..6, 2usize..6, 2usize..6], jitter in prop::collection::vec(-0.2f64..0.2, 5..30), six in any::<bool>()) {
        let points = jittered_grid(dims, &jitter);
        let src = SourceMesh { points, blocks: vec![Block::Structured { dims, first_point: 0 }], ..Default::default() };
        let split = if six { SplitMode::Six } else { SplitMode::Five };
        let (m, report) = tetrahedralize(&src, &ConvertOptions { split, ..Default::default() }, &mut |_| {}).unwrap();
        let cells = (dims[0] - 1) * (dims[1] - 1) * (dims[2] - 1);
        prop_assert_eq!(report.split_tets, cells * if six { 6 } else { 5 });
        check_tet_mesh(&m).unwrap();
        let adj = build_adjacency(&m.points, &m.tets).unwrap();
        check_adjacency(&m.tets, &adj).unwrap();
        let [a, b, c] = [dims[0] - 1, dims[1] - 1, dims[2] - 1];
        prop_assert_eq!(adj.boundary_faces.len(), 4 * (a * b + b * c + a * c));
    }
}

#[test]
fn inverted_cells_are_reoriented_and_flat_ones_dropped() {
    // A hexahedron listed upside down (top quad first) and a flat tet.
    let mut points = UNIT_HEX.to_vec();
    points.push([0.5, 0.5, 0.0]);
    let mut cells = Cells::new();
    cells.push(CellType::Hexahedron, &[4, 5, 6, 7, 0, 1, 2, 3]);
    cells.push(CellType::Tetra, &[0, 1, 2, 8]);
    let src = SourceMesh { points, blocks: vec![Block::Unstructured(cells)], ..Default::default() };
    let (m, report) = tetrahedralize(&src, &ConvertOptions::default(), &mut |_| {}).unwrap();
    check_tet_mesh(&m).unwrap();
    assert_eq!(m.tets.len(), 6);
    assert_eq!(m.points.len(), 8, "the flat tet's extra point is unused and removed");
    let text: Vec<String> = report.findings.iter().map(|f| f.to_string()).collect();
    assert!(text.iter().any(|t| t.starts_with("re-oriented")), "{text:?}");
    assert!(text.iter().any(|t| t.starts_with("dropped 1 zero-volume tets (first from source cell 1)")), "{text:?}");
    assert!(text.iter().any(|t| t.starts_with("removed 1 unused points")), "{text:?}");
}

#[test]
fn large_coordinate_offsets_keep_exact_orientation() {
    // A 4×4×4 grid at 1e6 with cells of 1e-3: f32 would collapse it, f64 with
    // exact predicates must keep every tet.
    let points = structured_points([4; 3], |ijk| ijk.map(|x| 1e6 + x as f64 * 1e-3));
    let src = SourceMesh {
        points,
        blocks: vec![Block::Structured { dims: [4, 4, 4], first_point: 0 }],
        ..Default::default()
    };
    let (m, report) = tetrahedralize(&src, &ConvertOptions::default(), &mut |_| {}).unwrap();
    assert_eq!(m.tets.len(), 27 * 5);
    assert_eq!(report.split_tets, 135);
    check_tet_mesh(&m).unwrap();
}

#[test]
fn cell_scalar_is_volume_weighted_onto_points() {
    // Two unit-height slabs of 1×1 cross-section: volumes 1 and 3, values 1 and 5.
    let mut points = UNIT_HEX.to_vec();
    points.extend([[0., 0., 4.], [1., 0., 4.], [1., 1., 4.], [0., 1., 4.]]);
    let mut cells = Cells::new();
    cells.push(CellType::Hexahedron, &[0, 1, 2, 3, 4, 5, 6, 7]);
    cells.push(CellType::Hexahedron, &[4, 5, 6, 7, 8, 9, 10, 11]);
    let src = SourceMesh {
        points,
        blocks: vec![Block::Unstructured(cells)],
        cell_fields: vec![tet_mesh::Field::new("c", 1, vec![1.0, 5.0])],
        ..Default::default()
    };
    let (m, report) = tetrahedralize(&src, &ConvertOptions::default(), &mut |_| {}).unwrap();
    assert!(report.findings.iter().any(|f| matches!(f, tet_mesh::Finding::CellScalarAveragedToPoints { .. })));
    // Bottom points see only cell 0; top points only cell 1. Middle points see
    // both, but each point's incident-tet volume differs with the split, so
    // only bounds and the exact ends are checked here.
    assert_eq!(m.scalar[0], 1.0);
    assert_eq!(m.scalar[8], 5.0);
    for v in &m.scalar[4..8] {
        assert!(*v > 1.0 && *v < 5.0);
    }
}

#[test]
fn iblanked_points_drop_the_cells_touching_them() {
    let points = structured_points([4; 3], |ijk| ijk.map(|x| x as f64));
    let mut blanked = vec![false; 64];
    blanked[1 + 4 + 16] = true; // interior point (1,1,1): its 8 cells go
    let src = SourceMesh {
        points,
        blocks: vec![Block::Structured { dims: [4, 4, 4], first_point: 0 }],
        point_blanked: Some(blanked),
        ..Default::default()
    };
    let (m, report) = tetrahedralize(&src, &ConvertOptions::default(), &mut |_| {}).unwrap();
    assert!(report.findings.contains(&tet_mesh::Finding::DroppedBlankedCells { count: 8 }));
    assert_eq!(m.tets.len(), (27 - 8) * 5);
    // Points (a,b,c) with a,b,c ∈ {0,1} touch only dropped cells.
    assert_eq!(m.points.len(), 64 - 8);
    check_tet_mesh(&m).unwrap();
    let adj = build_adjacency(&m.points, &m.tets).unwrap();
    assert!(!adj.convex, "a missing corner block makes the domain non-convex");
}

#[test]
fn no_field_gives_a_constant_zero_and_coordinates_are_selectable() {
    let points = structured_points([2; 3], |[i, j, k]| [i as f64, j as f64 * 2.0, k as f64 * 3.0]);
    let src = SourceMesh {
        points,
        blocks: vec![Block::Structured { dims: [2, 2, 2], first_point: 0 }],
        ..Default::default()
    };
    let (m, report) = tetrahedralize(&src, &ConvertOptions::default(), &mut |_| {}).unwrap();
    assert_eq!(m.scalar_name, "zero");
    assert!(m.scalar.iter().all(|&s| s == 0.0));
    assert!(report.findings.contains(&tet_mesh::Finding::NoScalarField));
    let opts = ConvertOptions { scalar: Some("z".into()), ..Default::default() };
    let (m, _) = tetrahedralize(&src, &opts, &mut |_| {}).unwrap();
    assert_eq!(m.scalar_name, "z");
    assert_eq!(m.scalar.iter().cloned().fold(f64::MIN, f64::max), 3.0);
}

#[test]
fn a_constant_field_is_warned_about_with_its_value() {
    let points: Vec<[f64; 3]> = (0..8).map(|i| [(i & 1) as f64, ((i >> 1) & 1) as f64, (i >> 2) as f64]).collect();
    let mut src = SourceMesh {
        points,
        blocks: vec![Block::Structured { dims: [2, 2, 2], first_point: 0 }],
        point_fields: vec![tet_mesh::Field::new("Density", 1, vec![1.25; 8])],
        ..Default::default()
    };
    let (_, report) = tetrahedralize(&src, &ConvertOptions::default(), &mut |_| {}).unwrap();
    let warning = report.findings.iter().map(|f| f.to_string()).find(|f| f.contains("constant (1.25)"));
    assert!(warning.is_some_and(|w| w.starts_with("warning:") && w.contains("'Density'")), "{:?}", report.findings);
    src.point_fields[0].values[3] = 2.0;
    let (_, report) = tetrahedralize(&src, &ConvertOptions::default(), &mut |_| {}).unwrap();
    assert!(!report.findings.iter().any(|f| matches!(f, tet_mesh::Finding::ConstantScalar { .. })));
}

#[test]
fn non_finite_values_matter_only_where_a_tet_uses_them() {
    let mut points = vec![[0., 0., 0.], [1., 0., 0.], [0., 1., 0.], [0., 0., 1.], [f64::NAN, 0., 0.]];
    let mut cells = Cells::new();
    cells.push(CellType::Tetra, &[0, 1, 2, 3]);
    let scalar = tet_mesh::Field::new("s", 1, vec![0.0, 1.0, 2.0, 3.0, f64::INFINITY]);
    let mut src = SourceMesh {
        points: points.clone(),
        blocks: vec![Block::Unstructured(cells.clone())],
        point_fields: vec![scalar],
        ..Default::default()
    };
    // Point 4 (NaN position, infinite scalar) is in no cell: converts fine.
    let (m, _) = tetrahedralize(&src, &ConvertOptions::default(), &mut |_| {}).unwrap();
    assert_eq!(m.points.len(), 4);
    // Once a cell uses it, the error names it.
    points[4] = [1.0, 1.0, 1.0];
    src.points = points;
    cells.push(CellType::Tetra, &[1, 2, 3, 4]);
    src.blocks = vec![Block::Unstructured(cells)];
    let e = tetrahedralize(&src, &ConvertOptions::default(), &mut |_| {}).unwrap_err();
    assert!(matches!(e, tet_mesh::MeshError::NonFiniteScalar { vertex: 4, .. }), "{e}");
    let drop = ConvertOptions { nan: tet_mesh::NanPolicy::Drop, ..Default::default() };
    let (m, report) = tetrahedralize(&src, &drop, &mut |_| {}).unwrap();
    assert_eq!(m.tets.len(), 1);
    assert!(report
        .findings
        .iter()
        .any(|f| matches!(f, tet_mesh::Finding::DroppedNonFinite { tets: 1, first_source_point: Some(4) })));
}
