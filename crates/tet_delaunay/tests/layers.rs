//! Layered (2.5D) mode: prisms between layers, conforming and positive.

use std::collections::HashMap;
use tet_delaunay::{tetrahedralize_layers, DelaunayError, SplitMix64};
use tet_mesh::predicates::{signed_tet_volume, tet_orientation, TetOrientation};

fn layers(columns: usize, n_layers: usize, seed: u64) -> Vec<Vec<[f64; 3]>> {
    let mut rng = SplitMix64(seed);
    let xy: Vec<[f64; 2]> = (0..columns).map(|_| [rng.next_f64(), rng.next_f64()]).collect();
    (0..n_layers)
        .map(|k| xy.iter().map(|p| [p[0], p[1], k as f64 + 0.3 * (p[0] * 7.0 + k as f64).sin()]).collect())
        .collect()
}

#[test]
fn prisms_are_positive_conforming_and_fill_the_layers() {
    let ls = layers(200, 4, 9);
    let out = tetrahedralize_layers(&ls).unwrap();
    assert_eq!(out.columns, 200);
    assert_eq!(out.tets.len(), out.triangles * 3 * 3);
    let flat: Vec<[f64; 3]> = ls.iter().flatten().copied().collect();
    let p = |i: u32| &flat[i as usize];
    let mut faces: HashMap<[u32; 3], usize> = HashMap::new();
    let mut vol = 0.0;
    for t in &out.tets {
        assert_eq!(tet_orientation(p(t[0]), p(t[1]), p(t[2]), p(t[3])), TetOrientation::Positive);
        vol += signed_tet_volume(p(t[0]), p(t[1]), p(t[2]), p(t[3]));
        for f in [[t[1], t[2], t[3]], [t[0], t[2], t[3]], [t[0], t[1], t[3]], [t[0], t[1], t[2]]] {
            let mut k = f;
            k.sort_unstable();
            *faces.entry(k).or_default() += 1;
        }
        // Every tet spans exactly two consecutive layers.
        let layer = |v: u32| v as usize / 200;
        let lo = t.iter().map(|&v| layer(v)).min().unwrap();
        assert!(t.iter().all(|&v| layer(v) == lo || layer(v) == lo + 1));
    }
    assert!(faces.values().all(|&c| c <= 2), "a face in more than two tets: prisms do not conform");
    // Volume between the bottom and top piecewise-linear surfaces, from the
    // layer-0 triangles recovered as the bottom faces of layer-0 tets.
    let mut expected = 0.0;
    for (f, &c) in &faces {
        if c == 1 && f.iter().all(|&v| v < 200) {
            let [a, b, cc] = f.map(|v| flat[v as usize]);
            let area = ((b[0] - a[0]) * (cc[1] - a[1]) - (cc[0] - a[0]) * (b[1] - a[1])).abs() / 2.0;
            let top = |v: u32| flat[v as usize + 3 * 200][2] - flat[v as usize][2];
            expected += area * (top(f[0]) + top(f[1]) + top(f[2])) / 3.0;
        }
    }
    assert!((vol - expected).abs() < 1e-9 * expected, "{vol} vs {expected}");
}

#[test]
fn layered_errors_name_the_problem() {
    let ls = layers(10, 2, 1);
    assert!(matches!(tetrahedralize_layers(&ls[..1]), Err(DelaunayError::TooFewLayers(1))));
    let mut short = ls.clone();
    short[1].pop();
    assert!(matches!(
        tetrahedralize_layers(&short),
        Err(DelaunayError::LayerSizeMismatch { layer: 1, expected: 10, found: 9 })
    ));
    let mut down = ls.clone();
    down[1][4][2] = down[0][4][2] - 1.0;
    assert!(matches!(tetrahedralize_layers(&down), Err(DelaunayError::LayersNotAscending { layer: 1, column: 4, .. })));
    let mut dup = ls.clone();
    for l in &mut dup {
        l[7][0] = l[2][0];
        l[7][1] = l[2][1];
    }
    assert!(matches!(tetrahedralize_layers(&dup), Err(DelaunayError::DuplicateColumn { first: 2, second: 7 })));
    let mut nan = ls.clone();
    nan[1][3][0] = f64::NAN;
    assert!(matches!(tetrahedralize_layers(&nan), Err(DelaunayError::NonFinite { index: 13, .. })));
    let line: Vec<Vec<[f64; 3]>> = (0..2).map(|k| (0..5).map(|i| [i as f64, i as f64, k as f64]).collect()).collect();
    assert!(matches!(tetrahedralize_layers(&line), Err(DelaunayError::CollinearColumns { columns: 5 })));
}
