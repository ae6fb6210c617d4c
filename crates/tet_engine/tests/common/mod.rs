//! Fixtures the engine's integration tests share.
#![allow(dead_code)]

use tet_bundle::{Bundle, BundleMeta};
use tet_mesh::{build_adjacency, tetrahedralize, Block, ConvertOptions, Field, SourceMesh};

/// An n³-point grid, 5-split, with a smooth scalar (or a constant one).
pub fn grid_bundle(n: usize, constant: bool) -> Bundle {
    let mut points = vec![];
    let mut s = vec![];
    for k in 0..n {
        for j in 0..n {
            for i in 0..n {
                let p = [i as f64, j as f64, k as f64 * 0.8];
                s.push(if constant { 2.5 } else { (p[0] * 0.7).sin() + 0.1 * p[1] * p[2] });
                points.push(p);
            }
        }
    }
    let src = SourceMesh {
        points,
        blocks: vec![Block::Structured { dims: [n, n, n], first_point: 0 }],
        point_fields: vec![Field::new("s", 1, s)],
        ..Default::default()
    };
    let opts = ConvertOptions { scalar: Some("s".into()), ..Default::default() };
    let (mesh, _) = tetrahedralize(&src, &opts, &mut |_| {}).unwrap();
    let adjacency = build_adjacency(&mesh.points, &mesh.tets).unwrap();
    Bundle::new(mesh, adjacency, BundleMeta::default())
}
