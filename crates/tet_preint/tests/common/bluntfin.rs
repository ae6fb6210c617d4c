//! The NASA Blunt Fin mesh (tests/data/plot3d, density) as tetprep splits
//! it, with the (Sf, Sb, l) domain its bundle gets: what the table3d
//! accuracy test and the certify_heldout figures measure on.
#![allow(dead_code)] // not every user needs all of it

use std::path::Path;
use tet_mesh::TetMesh;
use tet_preint::{ScalarQuantiles, TableDomain};

/// The Blunt Fin's density on its tets.
pub fn mesh() -> TetMesh {
    let data = Path::new(env!("CARGO_MANIFEST_DIR")).join("../../tests/data/plot3d");
    let opts = tet_io::ReadOptions { q_path: Some(data.join("bluntfinq.bin")), ..Default::default() };
    let src = tet_io::read_file(&data.join("bluntfinxyz.bin"), &opts).unwrap();
    let conv = tet_mesh::ConvertOptions { scalar: Some("density".into()), ..Default::default() };
    let (mesh, _) = tet_mesh::tetrahedralize(&src, &conv, &mut |_| {}).unwrap();
    mesh
}

/// `mesh`'s table domain with its scalar quantiles: the facts
/// `TableDomain::from_bundle` computes for a bundle without an analysis
/// section.
pub fn domain(mesh: &TetMesh) -> TableDomain {
    let max_ds = mesh
        .tets
        .iter()
        .map(|t| {
            let v = t.map(|i| mesh.scalar[i as usize]);
            v.iter().copied().fold(f64::NEG_INFINITY, f64::max) - v.iter().copied().fold(f64::INFINITY, f64::min)
        })
        .fold(0.0, f64::max);
    let stats = tet_mesh::mesh_stats(&mesh.points, &mesh.tets, &mesh.scalar);
    let mut domain = TableDomain::new(stats.scalar_min, stats.scalar_max, max_ds, stats.max_cell_diameter).unwrap();
    domain.s_quantiles = ScalarQuantiles::of(&mesh.scalar);
    domain
}

/// `count` segments through random cells of `mesh` (fixed `seed`) as
/// (Sf, Sb, l) triples, unclamped.
pub fn cell_triples(mesh: &TetMesh, count: usize, seed: u64) -> Vec<[f32; 3]> {
    tet_analysis::sample_cell_segments(&mesh.points, &mesh.tets, &mesh.scalar, None, count, seed)
        .into_iter()
        .map(|s| [s.s_front as f32, s.s_back as f32, s.len_world as f32])
        .collect()
}
