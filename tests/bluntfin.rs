//! Blunt Fin (NASA, PLOT3D) end to end: exact tet counts for both splits,
//! volume conservation against the trilinear hexahedra, no cracks, valid
//! adjacency, and a bundle round trip.

use std::collections::HashMap;
use std::path::{Path, PathBuf};
use tetkit::bundle::{Bundle, BundleMeta};
use tetkit::io::{read_file, ReadOptions};
use tetkit::mesh::split::structured_hex;
use tetkit::mesh::{
    build_adjacency, check_adjacency, check_tet_mesh, mesh_stats, tetrahedralize, Block, ConvertOptions, Finding,
    SourceMesh, SplitMode,
};

fn data(p: &str) -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/data").join(p)
}

fn bluntfin() -> SourceMesh {
    let opts = ReadOptions { q_path: Some(data("plot3d/bluntfinq.bin")), ..Default::default() };
    read_file(&data("plot3d/bluntfinxyz.bin"), &opts).expect("Blunt Fin reads")
}

/// Exact volume of a trilinear hexahedron (VTK order): det J is at most
/// quadratic per axis, so 2×2×2 Gauss points integrate it exactly.
fn trilinear_hex_volume(p: &[[f64; 3]; 8]) -> f64 {
    let corners = tetkit::mesh::split::UNIT_HEX;
    let g = [0.5 - 0.5 / 3f64.sqrt(), 0.5 + 0.5 / 3f64.sqrt()];
    let mut vol = 0.0;
    for &u in &g {
        for &v in &g {
            for &w in &g {
                let mut j = [[0.0; 3]; 3]; // j[param][axis]
                for (c, q) in corners.iter().zip(p) {
                    let f = |t: f64, s: f64| if s == 1.0 { t } else { 1.0 - t };
                    let df = |s: f64| if s == 1.0 { 1.0 } else { -1.0 };
                    let d = [
                        df(c[0]) * f(v, c[1]) * f(w, c[2]),
                        f(u, c[0]) * df(c[1]) * f(w, c[2]),
                        f(u, c[0]) * f(v, c[1]) * df(c[2]),
                    ];
                    for a in 0..3 {
                        for x in 0..3 {
                            j[a][x] += d[a] * q[x];
                        }
                    }
                }
                let det = j[0][0] * (j[1][1] * j[2][2] - j[1][2] * j[2][1])
                    - j[0][1] * (j[1][0] * j[2][2] - j[1][2] * j[2][0])
                    + j[0][2] * (j[1][0] * j[2][1] - j[1][1] * j[2][0]);
                vol += det / 8.0;
            }
        }
    }
    vol
}

fn hex_volume_total(src: &SourceMesh) -> f64 {
    let Block::Structured { dims, first_point } = src.blocks[0] else { panic!("structured") };
    let mut total = 0.0;
    for k in 0..dims[2] - 1 {
        for j in 0..dims[1] - 1 {
            for i in 0..dims[0] - 1 {
                let n = structured_hex(dims, first_point, i, j, k);
                total += trilinear_hex_volume(&n.map(|x| src.points[x])).abs();
            }
        }
    }
    total
}

#[test]
fn bluntfin_five_and_six_splits() {
    let src = bluntfin();
    assert_eq!(src.points.len(), 40 * 32 * 32);
    assert_eq!(src.num_cells(), 37_479);
    let hex_volume = hex_volume_total(&src);

    for (mode, expected_split) in [(SplitMode::Five, 187_395usize), (SplitMode::Six, 224_874)] {
        let opts = ConvertOptions { split: mode, scalar: Some("density".into()), ..Default::default() };
        let (mesh, report) = tetrahedralize(&src, &opts, &mut |_| {}).unwrap();
        assert_eq!(report.split_tets, expected_split, "{mode:?}");
        // The grid has 39 coincident point pairs ((i,0,0) ≡ (i,1,0), a collapsed
        // edge at the fin's foot): they are merged, and the tets that become
        // flat there are dropped and counted; nothing else is lost.
        let merged = report.findings.iter().find_map(|f| match f {
            Finding::MergedDuplicatePoints { count, .. } => Some(*count),
            _ => None,
        });
        assert_eq!(merged, Some(39));
        let dropped = report
            .findings
            .iter()
            .find_map(|f| match f {
                Finding::DroppedZeroVolumeTets { count, .. } => Some(*count),
                _ => None,
            })
            .unwrap_or(0);
        assert_eq!(mesh.tets.len() + dropped, expected_split);
        assert_eq!(mesh.points.len(), 40 * 32 * 32 - 39);
        check_tet_mesh(&mesh).unwrap();

        let stats = mesh_stats(&mesh.points, &mesh.tets, &mesh.scalar);
        let rel = (stats.total_volume - hex_volume).abs() / hex_volume;
        assert!(rel < 1e-9, "{mode:?}: tet volume {} vs hexahedral {hex_volume}: rel {rel:e}", stats.total_volume);
        assert!(stats.tet_volume.min > 0.0);
        assert!(stats.scalar_min > 0.18 && stats.scalar_max < 5.0, "{} {}", stats.scalar_min, stats.scalar_max);

        let adj = build_adjacency(&mesh.points, &mesh.tets).unwrap();
        check_adjacency(&mesh.tets, &adj).unwrap();
        assert!(!adj.convex, "the fin makes the domain non-convex");
        assert_no_interior_boundary_faces(&src, &mesh.points, &mesh.tets, &adj.boundary_faces);

        if mode == SplitMode::Five {
            let dir = tempfile::tempdir().unwrap();
            let path = dir.path().join("bluntfin.tetb");
            let bundle = Bundle::new(mesh, adj, BundleMeta { split: "5".into(), ..Default::default() });
            bundle.write(&path).unwrap();
            assert_eq!(Bundle::read(&path).unwrap(), bundle);
        }
    }
}

/// No cracks: every face with a single tet lies on one side of the grid's
/// boundary (i, j or k at its minimum or maximum).
fn assert_no_interior_boundary_faces(src: &SourceMesh, points: &[[f64; 3]], tets: &[[u32; 4]], boundary: &[u32]) {
    let Block::Structured { dims, .. } = src.blocks[0] else { panic!("structured") };
    let mut ijk: HashMap<[u64; 3], Vec<[usize; 3]>> = HashMap::new();
    for (n, p) in src.points.iter().enumerate() {
        let (i, j, k) = (n % dims[0], (n / dims[0]) % dims[1], n / (dims[0] * dims[1]));
        ijk.entry(p.map(f64::to_bits)).or_default().push([i, j, k]);
    }
    for &b in boundary {
        let f = tetkit::mesh::adjacency::boundary_face_vertices(tets, b);
        let cands: Vec<&Vec<[usize; 3]>> = f.iter().map(|&v| &ijk[&points[v as usize].map(f64::to_bits)]).collect();
        let on_side = (0..3)
            .any(|axis| [0, dims[axis] - 1].iter().any(|&end| cands.iter().all(|c| c.iter().any(|q| q[axis] == end))));
        assert!(on_side, "boundary face {b} ({f:?}) is inside the grid: a crack");
    }
}
