//! The reference renderer on real data: NASA Blunt Fin (187,318 tets, a
//! curvilinear grid split 5 ways), small images so the test stays fast.
//!
//! With constant extinction ρ a pixel's opacity is 1 − exp(−ρ L), L the
//! length of the ray inside the mesh, which an independent brute force over
//! all boundary triangles gives (Σ exit t − Σ entry t). Rays passing within
//! a hair of a boundary edge are ambiguous for the float brute force and are
//! skipped (and counted).

use glam::DVec3;
use std::path::{Path, PathBuf};
use tet_io::{read_file, ReadOptions};
use tet_mesh::{build_adjacency, tetrahedralize, Adjacency, ConvertOptions, TetMesh};
use tet_preint::{ColorNode, Emission, OpacityNode, TransferFunction};
use tet_render::{Camera, ReferenceOptions, ReferenceRenderer, ViewSpec};

fn data(p: &str) -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("../../tests/data").join(p)
}

fn bluntfin() -> (TetMesh, Adjacency) {
    let opts = ReadOptions { q_path: Some(data("plot3d/bluntfinq.bin")), ..Default::default() };
    let src = read_file(&data("plot3d/bluntfinxyz.bin"), &opts).unwrap();
    let conv = ConvertOptions { scalar: Some("density".into()), ..Default::default() };
    let (mesh, _) = tetrahedralize(&src, &conv, &mut |_| {}).unwrap();
    let adj = build_adjacency(&mesh.points, &mesh.tets).unwrap();
    (mesh, adj)
}

fn bounds(mesh: &TetMesh) -> (DVec3, DVec3) {
    mesh.points.iter().fold((DVec3::splat(f64::INFINITY), DVec3::splat(f64::NEG_INFINITY)), |(lo, hi), p| {
        (lo.min(DVec3::from(*p)), hi.max(DVec3::from(*p)))
    })
}

/// Length inside the mesh of the ray from `t_start`, by brute force over the
/// boundary; `None` when some crossing is too close to a triangle's edge to
/// decide in floating point.
fn brute_length(mesh: &TetMesh, adj: &Adjacency, o: DVec3, d: DVec3, t_start: f64) -> Option<f64> {
    let mut len = 0.0;
    for &b in &adj.boundary_faces {
        let [a, bb, c] =
            tet_mesh::adjacency::boundary_face_vertices(&mesh.tets, b).map(|v| DVec3::from(mesh.points[v as usize]));
        let n = (bb - a).cross(c - a);
        let denom = n.dot(d);
        if denom == 0.0 {
            continue;
        }
        let t = n.dot(a - o) / denom;
        let p = o + d * t;
        // Barycentric coordinates by sub-areas along n.
        let nn = n.length_squared();
        let w =
            [(bb - p).cross(c - p).dot(n) / nn, (c - p).cross(a - p).dot(n) / nn, (a - p).cross(bb - p).dot(n) / nn];
        let min = w.iter().copied().fold(f64::INFINITY, f64::min);
        if min.abs() < 1e-7 {
            return None;
        }
        if min > 0.0 {
            // Outward normal: along d means leaving.
            let tc = t.max(t_start);
            len += if denom > 0.0 { tc } else { -tc };
        }
    }
    Some(len)
}

#[test]
fn bluntfin_constant_extinction_matches_brute_force_path_length() {
    let (mesh, adj) = bluntfin();
    assert_eq!(mesh.tets.len(), 187_318); // 187,395 split, zero-volume ones dropped
    let r = ReferenceRenderer::new(&mesh, &adj).unwrap();
    let (lo, hi) = bounds(&mesh);
    let rho = 1.0 / (hi - lo).length();
    let tf = TransferFunction::new(
        vec![ColorNode { x: 0.0, rgb: [1.0, 1.0, 1.0] }],
        vec![OpacityNode { x: 0.0, a: rho }],
        1.0,
        Emission::Density,
        false,
    )
    .unwrap();
    let base = ViewSpec::framing(lo.into(), hi.into(), [20, 16]);
    let (mut checked, mut skipped) = (0, 0);
    for spec in [base.orbit(30.0, 20.0, 1.3), base.orbit(-100.0, -35.0, 1.6), {
        let mut v = base.orbit(200.0, 60.0, 1.4);
        v.parallel = true;
        v
    }] {
        let cam = Camera::new(&spec).unwrap();
        let (img, stats) = r.render(&cam, &tf, &ReferenceOptions::default(), &|_, _| {}).unwrap();
        assert_eq!(stats.walk_failures, 0);
        assert!(stats.rays_hit > 50, "{stats:?}");
        for j in 0..cam.height() {
            for i in 0..cam.width() {
                let (o, d) = cam.ray(i as f64 + 0.5, j as f64 + 0.5);
                let ts = if cam.is_parallel() { f64::NEG_INFINITY } else { cam.near_depth() / d.dot(cam.forward()) };
                let ts = ts.max(-1e3 * (hi - lo).length()); // a finite start for the parallel line
                let Some(len) = brute_length(&mesh, &adj, o, d, ts) else {
                    skipped += 1;
                    continue;
                };
                let want = 1.0 - (-rho * len).exp();
                let got = img.pixel(i, j)[3] as f64;
                assert!((got - want).abs() < 1e-6, "pixel ({i}, {j}): α {got}, brute force {want} (L = {len})");
                checked += 1;
            }
        }
    }
    assert!(checked > 900 && skipped < 20, "checked {checked}, skipped {skipped}");
}

#[test]
fn bluntfin_density_render_is_finite_and_deterministic() {
    let (mesh, adj) = bluntfin();
    let r = ReferenceRenderer::new(&mesh, &adj).unwrap();
    let (lo, hi) = mesh.scalar.iter().fold((f64::INFINITY, f64::NEG_INFINITY), |(a, b), &s| (a.min(s), b.max(s)));
    let text =
        std::fs::read_to_string(Path::new(env!("CARGO_MANIFEST_DIR")).join("../../formats/samples/tf_normalized.json"))
            .unwrap();
    let tf = TransferFunction::from_json(&text).unwrap().denormalize(lo, hi).unwrap();
    let (blo, bhi) = bounds(&mesh);
    let cam = Camera::new(&ViewSpec::framing(blo.into(), bhi.into(), [32, 32]).orbit(40.0, 25.0, 1.5)).unwrap();
    let (img, stats) = r.render(&cam, &tf, &ReferenceOptions::default(), &|_, _| {}).unwrap();
    assert_eq!(stats.walk_failures, 0);
    assert!(stats.segments > 10_000, "{stats:?}");
    assert!(img.pixels().iter().flatten().all(|v| v.is_finite() && *v >= 0.0));
    assert!(img.pixels().iter().any(|p| p[3] > 0.05));
    let (again, _) = r.render(&cam, &tf, &ReferenceOptions::default(), &|_, _| {}).unwrap();
    assert_eq!(img, again);
}
