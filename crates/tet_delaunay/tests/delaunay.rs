//! Invariants of the 3D Delaunay tetrahedralization, checked brute force on
//! small random and degenerate point sets, and on a 30³ lattice.

use proptest::prelude::*;
use robust::{insphere, orient3d, Coord3D};
use std::collections::HashMap;
use tet_delaunay::{tetrahedralize_points, DelaunayError, DelaunayOptions, SplitMix64};

fn c(p: &[f64; 3]) -> Coord3D<f64> {
    Coord3D { x: p[0], y: p[1], z: p[2] }
}

/// Tetkit orientation sign (positive when det[p1−p0, p2−p0, p3−p0] > 0).
fn orient(a: &[f64; 3], b: &[f64; 3], cc: &[f64; 3], d: &[f64; 3]) -> f64 {
    -orient3d(c(a), c(b), c(cc), c(d))
}

fn volume(a: &[f64; 3], b: &[f64; 3], cc: &[f64; 3], d: &[f64; 3]) -> f64 {
    tet_mesh::predicates::signed_tet_volume(a, b, cc, d)
}

/// Checks a tetrahedralization structurally and returns its boundary
/// faces: every tet positive, every face in at most two tets and then
/// with opposite orientations, Euler characteristic of a ball.
fn check_structure(pts: &[[f64; 3]], tets: &[[u32; 4]]) -> Vec<[u32; 3]> {
    let p = |i: u32| &pts[i as usize];
    let mut faces: HashMap<[u32; 3], Vec<[u32; 3]>> = HashMap::new();
    let mut edges = std::collections::HashSet::new();
    let mut verts = std::collections::HashSet::new();
    for t in tets {
        assert!(orient(p(t[0]), p(t[1]), p(t[2]), p(t[3])) > 0.0, "tet {t:?} not positive");
        // Outward faces of a positive tet.
        for f in [[t[1], t[2], t[3]], [t[0], t[3], t[2]], [t[0], t[1], t[3]], [t[0], t[2], t[1]]] {
            let mut k = f;
            k.sort_unstable();
            faces.entry(k).or_default().push(f);
        }
        for i in 0..4 {
            verts.insert(t[i]);
            for j in i + 1..4 {
                edges.insert((t[i].min(t[j]), t[i].max(t[j])));
            }
        }
    }
    let mut boundary = Vec::new();
    for (k, fs) in &faces {
        assert!(fs.len() <= 2, "face {k:?} in {} tets", fs.len());
        if fs.len() == 2 {
            // Opposite orientation: the two outward triangles are mirror
            // cyclic orders of one another.
            let rot = |f: [u32; 3]| {
                let m = (0..3).min_by_key(|&i| f[i]).unwrap();
                [f[m], f[(m + 1) % 3], f[(m + 2) % 3]]
            };
            let (a, b) = (rot(fs[0][0..3].try_into().unwrap()), rot(fs[1]));
            assert_eq!((a[1], a[2]), (b[2], b[1]), "face {k:?} not shared with opposite orientations");
        } else {
            boundary.push(fs[0]);
        }
    }
    let euler = verts.len() as i64 - edges.len() as i64 + faces.len() as i64 - tets.len() as i64;
    assert_eq!(euler, 1, "Euler characteristic of a ball");
    boundary
}

/// No point lies strictly inside any tet's circumsphere (exact).
fn check_empty_spheres(pts: &[[f64; 3]], tets: &[[u32; 4]]) {
    for t in tets {
        let [a, b, cc, d] = t.map(|i| c(&pts[i as usize]));
        for (i, q) in pts.iter().enumerate() {
            if t.contains(&(i as u32)) {
                continue;
            }
            // Shewchuk's insphere wants his positive orientation (ours
            // negative): swap two vertices.
            let s = insphere(b, a, cc, d, c(q));
            assert!(s <= 0.0, "point {i} strictly inside the circumsphere of {t:?}");
        }
    }
}

/// Convex hull volume brute force: for every supporting plane (through 3
/// points, all points on one side), the area of the 2D hull of the points
/// on it times its distance from an interior point, over 3.
fn hull_volume(pts: &[[f64; 3]]) -> f64 {
    let n = pts.len();
    let mut centroid = [0.0; 3];
    for p in pts {
        for a in 0..3 {
            centroid[a] += p[a] / n as f64;
        }
    }
    let mut seen = std::collections::HashSet::new();
    let mut vol = 0.0;
    for i in 0..n {
        for j in i + 1..n {
            for k in j + 1..n {
                let (a, b, cc) = (&pts[i], &pts[j], &pts[k]);
                let sides: Vec<f64> = pts.iter().map(|q| orient(a, b, cc, q)).collect();
                if sides.iter().all(|&s| s == 0.0) {
                    continue; // collinear triple (the input is never flat here)
                }
                let (pos, neg) = (sides.iter().any(|&s| s > 0.0), sides.iter().any(|&s| s < 0.0));
                if (pos && neg) || (!pos && !neg) {
                    continue;
                }
                let on: Vec<usize> = (0..n).filter(|&m| sides[m] == 0.0).collect();
                if !seen.insert(on.clone()) {
                    continue;
                }
                let sub = |u: &[f64; 3], v: &[f64; 3]| [u[0] - v[0], u[1] - v[1], u[2] - v[2]];
                let (u, v) = (sub(b, a), sub(cc, a));
                let nrm = [u[1] * v[2] - u[2] * v[1], u[2] * v[0] - u[0] * v[2], u[0] * v[1] - u[1] * v[0]];
                let len = (nrm[0] * nrm[0] + nrm[1] * nrm[1] + nrm[2] * nrm[2]).sqrt();
                if len == 0.0 {
                    continue;
                }
                let ax = (0..3).max_by(|&x, &y| nrm[x].abs().total_cmp(&nrm[y].abs())).unwrap();
                let (x, y) = ((ax + 1) % 3, (ax + 2) % 3);
                let mut q2: Vec<[f64; 2]> = on.iter().map(|&m| [pts[m][x], pts[m][y]]).collect();
                let area = hull_area_2d(&mut q2) * len / nrm[ax].abs();
                let g = sub(a, &centroid);
                let dist = ((g[0] * nrm[0] + g[1] * nrm[1] + g[2] * nrm[2]) / len).abs();
                vol += area * dist / 3.0;
            }
        }
    }
    vol
}

fn hull_area_2d(p: &mut [[f64; 2]]) -> f64 {
    p.sort_by(|a, b| a[0].total_cmp(&b[0]).then(a[1].total_cmp(&b[1])));
    let cross = |o: [f64; 2], a: [f64; 2], b: [f64; 2]| (a[0] - o[0]) * (b[1] - o[1]) - (a[1] - o[1]) * (b[0] - o[0]);
    let mut h: Vec<[f64; 2]> = Vec::new();
    for pass in 0..2 {
        let start = h.len();
        let it: Box<dyn Iterator<Item = &[f64; 2]>> =
            if pass == 0 { Box::new(p.iter()) } else { Box::new(p.iter().rev()) };
        for &q in it {
            while h.len() >= start + 2 && cross(h[h.len() - 2], h[h.len() - 1], q) <= 0.0 {
                h.pop();
            }
            h.push(q);
        }
        h.pop();
    }
    let m = h.len();
    (0..m).map(|i| h[i][0] * h[(i + 1) % m][1] - h[(i + 1) % m][0] * h[i][1]).sum::<f64>().abs() / 2.0
}

/// The full check: structure, empty spheres, volume = hull volume, every
/// distinct point used, duplicates mapped to a used point.
fn check_all(pts: &[[f64; 3]]) {
    let d = tetrahedralize_points(pts, &DelaunayOptions::default()).expect("tetrahedralize");
    // The library's own checker must agree with the independent one below.
    tet_delaunay::check_delaunay(pts, &d, true).expect("check_delaunay");
    let boundary = check_structure(pts, &d.tets);
    assert_eq!(boundary.len(), d.hull_facets);
    check_empty_spheres(pts, &d.tets);
    let vol: f64 = d
        .tets
        .iter()
        .map(|t| volume(&pts[t[0] as usize], &pts[t[1] as usize], &pts[t[2] as usize], &pts[t[3] as usize]))
        .sum();
    let hull = hull_volume(pts);
    assert!((vol - hull).abs() <= 1e-9 * hull.max(1.0), "volume {vol} vs hull {hull}");
    let used: std::collections::HashSet<u32> = d.tets.iter().flatten().copied().collect();
    for (i, &r) in d.merged_into.iter().enumerate() {
        assert!(used.contains(&r), "point {i} (as {r}) not in any tet");
        assert_eq!(pts[i], pts[r as usize]);
    }
    assert_eq!(d.duplicates, pts.len() - used.len());
    assert_eq!(d.walk_fallbacks, 0);
}

fn small_int_point() -> impl Strategy<Value = [f64; 3]> {
    (0i32..4, 0i32..4, 0i32..4).prop_map(|(x, y, z)| [x as f64, y as f64, z as f64])
}

proptest! {
    #![proptest_config(ProptestConfig { cases: 200, ..ProptestConfig::default() })]

    #[test]
    fn random_points_are_delaunay(pts in prop::collection::vec(prop::array::uniform3(-10.0f64..10.0), 4..40)) {
        check_all(&pts);
    }

    /// Points on a small integer grid: massive cospherical and coplanar
    /// ties, collinear runs and duplicates.
    #[test]
    fn lattice_subsets_are_delaunay(pts in prop::collection::vec(small_int_point(), 8..48)) {
        let distinct: std::collections::HashSet<[u64; 3]> = pts.iter().map(|p| p.map(f64::to_bits)).collect();
        let flat = {
            let v: Vec<&[f64; 3]> = pts.iter().collect();
            v.iter().all(|q| (0..v.len()).all(|i| (0..v.len()).all(|j|
                orient(v[0], v[i], v[j], q) == 0.0)))
        };
        prop_assume!(distinct.len() >= 4 && !flat);
        check_all(&pts);
    }

    /// Coplanar layers: a few z planes of random xy points.
    #[test]
    fn coplanar_layers_are_delaunay(xy in prop::collection::vec(prop::array::uniform2(0.0f64..1.0), 3..10), layers in 2usize..4) {
        let mut pts = Vec::new();
        for k in 0..layers {
            for p in &xy {
                pts.push([p[0], p[1], k as f64 * 0.5]);
            }
        }
        // Collinear xy columns make the point set flat in one direction
        // only if all xy are collinear; skip those.
        let flat = xy.iter().all(|q| robust::orient2d(
            robust::Coord { x: xy[0][0], y: xy[0][1] }, robust::Coord { x: xy[1][0], y: xy[1][1] }, robust::Coord { x: q[0], y: q[1] }) == 0.0);
        prop_assume!(!flat);
        check_all(&pts);
    }
}

#[test]
fn collinear_runs_and_a_cospherical_ring() {
    // Points on three axes (collinear runs) plus points on a sphere.
    let mut pts = Vec::new();
    for i in -5..=5 {
        pts.push([i as f64, 0.0, 0.0]);
        pts.push([0.0, i as f64, 0.0]);
        pts.push([0.0, 0.0, i as f64]);
    }
    for (x, y, z) in [(3.0, 4.0, 0.0), (0.0, 3.0, 4.0), (4.0, 0.0, 3.0), (-3.0, -4.0, 0.0), (0.0, -3.0, -4.0)] {
        pts.push([x, y, z]);
    }
    check_all(&pts);
}

#[test]
fn random_thousand_points_are_delaunay() {
    let mut rng = SplitMix64(3);
    let pts: Vec<[f64; 3]> = (0..1000).map(|_| [rng.next_f64(), rng.next_f64(), rng.next_f64()]).collect();
    let d = tetrahedralize_points(&pts, &DelaunayOptions::default()).unwrap();
    check_structure(&pts, &d.tets);
    check_empty_spheres(&pts, &d.tets);
}

#[test]
fn lattice_30_cubed_fills_the_box() {
    let n = 30;
    let mut pts = Vec::new();
    for k in 0..n {
        for j in 0..n {
            for i in 0..n {
                pts.push([i as f64, j as f64, k as f64]);
            }
        }
    }
    let d = tetrahedralize_points(&pts, &DelaunayOptions::default()).unwrap();
    let boundary = check_structure(&pts, &d.tets);
    assert_eq!(boundary.len(), d.hull_facets);
    // Every cube face on the box's surface is split into two triangles.
    assert_eq!(d.hull_facets, 6 * 29 * 29 * 2);
    let vol: f64 = d
        .tets
        .iter()
        .map(|t| volume(&pts[t[0] as usize], &pts[t[1] as usize], &pts[t[2] as usize], &pts[t[3] as usize]))
        .sum();
    assert!((vol - 29.0f64.powi(3)).abs() < 1e-6, "volume {vol}");
    assert_eq!(d.walk_fallbacks, 0);
    println!("30³ lattice: {} tets", d.tets.len());
}

#[test]
fn errors_name_the_problem() {
    let mut pts = vec![[0.0, 0.0, 0.0], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]];
    pts.push([f64::NAN, 0.0, 0.0]);
    match tetrahedralize_points(&pts, &DelaunayOptions::default()) {
        Err(DelaunayError::NonFinite { index: 4, .. }) => {}
        other => panic!("{other:?}"),
    }
    pts[4] = [0.0, -1e60, 0.0];
    match tetrahedralize_points(&pts, &DelaunayOptions::default()) {
        Err(e @ DelaunayError::CoordinateTooLarge { index: 4, .. }) => assert!(e.to_string().contains("point 4")),
        other => panic!("{other:?}"),
    }
    // Huge but accepted coordinates (a power of two below the limit) stay exact.
    let s = tet_delaunay::MAX_COORDINATE / 2.0;
    let big = [[0.0, 0.0, 0.0], [s, 0.0, 0.0], [0.0, s, 0.0], [0.0, 0.0, s], [s, s, s], [-s, -s, -s]];
    let d = tetrahedralize_points(&big, &DelaunayOptions::default()).unwrap();
    tet_delaunay::check_delaunay(&big, &d, true).unwrap();
    let flat = [[0.0, 0.0, 0.0], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [1.0, 1.0, 0.0], [2.0, 3.0, 0.0]];
    assert!(matches!(
        tetrahedralize_points(&flat, &DelaunayOptions::default()),
        Err(DelaunayError::Degenerate { distinct: 5, dimension: 2 })
    ));
    let line = [[0.0, 0.0, 0.0], [1.0, 1.0, 1.0], [2.0, 2.0, 2.0], [1.0, 1.0, 1.0]];
    assert!(matches!(
        tetrahedralize_points(&line, &DelaunayOptions::default()),
        Err(DelaunayError::Degenerate { distinct: 3, dimension: 1 })
    ));
    assert!(matches!(tetrahedralize_points(&[], &DelaunayOptions::default()), Err(DelaunayError::Degenerate { .. })));
    let opts = DelaunayOptions { max_circumradius: Some(-1.0) };
    assert!(matches!(tetrahedralize_points(&pts[..4], &opts), Err(DelaunayError::BadCircumradius(_))));
}

#[test]
fn max_circumradius_peels_a_concavity() {
    // A U-shaped set: two dense slabs joined at the bottom, open on top.
    // The notch between the arms is filled by big hull tets.
    let mut pts = Vec::new();
    let mut rng = SplitMix64(11);
    for _ in 0..3000 {
        let (x, y, z) = (rng.next_f64() * 3.0, rng.next_f64(), rng.next_f64() * 3.0);
        if z < 1.0 || !(1.0..=2.0).contains(&x) {
            pts.push([x, y, z]);
        }
    }
    let full = tetrahedralize_points(&pts, &DelaunayOptions::default()).unwrap();
    assert!(full.fills_convex_hull());
    let peeled = tetrahedralize_points(&pts, &DelaunayOptions { max_circumradius: Some(0.3) }).unwrap();
    assert!(peeled.removed_cells > 0);
    assert_eq!(peeled.tets.len() + peeled.removed_cells, full.tets.len());
    // Nothing is left in the middle of the notch.
    let centroid = |t: &[u32; 4]| {
        let mut m = [0.0; 3];
        for &v in t {
            for a in 0..3 {
                m[a] += pts[v as usize][a] / 4.0;
            }
        }
        m
    };
    let in_notch = |m: [f64; 3]| (1.2..1.8).contains(&m[0]) && m[2] > 1.5;
    assert!(full.tets.iter().any(|t| in_notch(centroid(t))));
    assert!(!peeled.tets.iter().any(|t| in_notch(centroid(t))));
}

/// The adjacency the insertion hands over is the one the faces give, with
/// the hull whole and with hull-filling tets peeled off.
#[test]
fn handed_neighbours_equal_the_built_adjacency() {
    let mut rng = SplitMix64(42);
    let pts: Vec<[f64; 3]> = (0..20_000).map(|_| [rng.next_f64(), rng.next_f64(), rng.next_f64() * 0.3]).collect();
    for max_circumradius in [None, Some(0.05)] {
        let d = tetrahedralize_points(&pts, &DelaunayOptions { max_circumradius }).unwrap();
        let built = tet_mesh::build_adjacency(&pts, &d.tets).unwrap();
        let handed = tet_mesh::adjacency_from_neighbors(&pts, &d.tets, d.neighbors.clone()).expect("consistent links");
        assert_eq!(handed, built, "max_circumradius {max_circumradius:?}");
        assert_eq!(max_circumradius.is_some(), d.removed_cells > 0);
    }
}
