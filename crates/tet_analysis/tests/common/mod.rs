//! Test meshes: structured grids (optionally jittered) and an embedded sliver.
#![allow(dead_code)]

use tet_mesh::predicates::{tet_orientation, TetOrientation};
use tet_mesh::{tetrahedralize, Block, ConvertOptions, Field, SourceMesh, SplitMode, TetMesh};

/// Deterministic xorshift in [0, 1).
pub use tet_mesh::XorShift64 as Rng;

/// An n³-point grid on [0,1]³ (5-tet split), interior points jittered by
/// `jitter` × spacing, offset by `offset`, with scalar `f` of the
/// un-offset position.
pub fn grid(n: usize, jitter: f64, offset: f64, f: impl Fn([f64; 3]) -> f64) -> TetMesh {
    let h = 1.0 / (n - 1) as f64;
    let mut rng = Rng(0x9e37_79b9_7f4a_7c15);
    let mut local = Vec::with_capacity(n * n * n);
    for k in 0..n {
        for j in 0..n {
            for i in 0..n {
                let mut p = [i as f64 * h, j as f64 * h, k as f64 * h];
                let interior = [i, j, k].iter().all(|&c| c > 0 && c < n - 1);
                if interior && jitter > 0.0 {
                    for c in p.iter_mut() {
                        *c += (rng.next_f64() - 0.5) * jitter * h;
                    }
                }
                local.push(p);
            }
        }
    }
    let s: Vec<f64> = local.iter().map(|&p| f(p)).collect();
    let points = local.iter().map(|p| p.map(|c| c + offset)).collect();
    let source = SourceMesh {
        points,
        blocks: vec![Block::Structured { dims: [n, n, n], first_point: 0 }],
        point_fields: vec![Field::new("s", 1, s)],
        ..Default::default()
    };
    let opts = ConvertOptions { split: SplitMode::Five, ..Default::default() };
    tetrahedralize(&source, &opts, &mut |_| {}).unwrap().0
}

/// True when point `p` of an n³ grid on [0,1]³ lies on the boundary.
pub fn on_boundary(p: [f64; 3], offset: f64) -> bool {
    p.iter().any(|&c| (c - offset).abs() < 1e-9 || (c - offset - 1.0).abs() < 1e-9)
}

/// A sliver — the unit square's corners with one lifted by `eps` — capped
/// by one apex above and one below, so every vertex has regular tets too.
pub fn capped_sliver(eps: f64, f: impl Fn([f64; 3]) -> f64) -> TetMesh {
    let points =
        vec![[0.0, 0.0, 0.0], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [1.0, 1.0, eps], [0.5, 0.5, 1.0], [0.5, 0.5, -1.0]];
    let orient = |t: [u32; 4]| -> [u32; 4] {
        let p = t.map(|v| points[v as usize]);
        match tet_orientation(&p[0], &p[1], &p[2], &p[3]) {
            TetOrientation::Positive => t,
            TetOrientation::Negative => [t[1], t[0], t[2], t[3]],
            TetOrientation::Flat => panic!("flat tet {t:?}"),
        }
    };
    let sliver = orient([0, 1, 2, 3]);
    let mut tets = vec![sliver];
    for (f, face) in tet_mesh::FACE_OUTWARD.iter().enumerate() {
        let _ = f;
        let [a, b, c] = face.map(|k| points[sliver[k] as usize]);
        let n_z = (b[0] - a[0]) * (c[1] - a[1]) - (b[1] - a[1]) * (c[0] - a[0]);
        let apex = if n_z > 0.0 { 4 } else { 5 };
        tets.push(orient([sliver[face[0]], sliver[face[1]], sliver[face[2]], apex]));
    }
    let scalar = points.iter().map(|&p| f(p)).collect();
    TetMesh { points, tets: tets.into(), scalar_name: "s".into(), scalar, point_fields: vec![] }
}
