//! Visibility order against brute force: along many rays, every pair of
//! tets whose intervals are disjoint must appear in ray order. MPVO and
//! MPVONC are exact on Delaunay meshes (no cycles for any viewpoint); MPVONC
//! also orders two separate blocks one behind the other, where plain MPVO
//! cannot; cycles are broken and counted.
mod common;

use common::*;
use glam::DVec3;
use tet_delaunay::{tetrahedralize_points, DelaunayOptions};
use tet_render::project::ViewGeometry;
use tet_render::{visibility_order, Camera, Scene, SortMethod, ViewSpec};

fn delaunay_scene(n: usize, seed: u64) -> Scene {
    let mut rng = Rng(seed);
    let pts: Vec<[f64; 3]> = (0..n).map(|_| [rng.next_f64(), rng.next_f64(), rng.next_f64()]).collect();
    let d = tetrahedralize_points(&pts, &DelaunayOptions::default()).unwrap();
    let s: Vec<f64> = pts.iter().map(|p| p[0]).collect();
    Scene::new(&pts, d.tets, s).unwrap()
}

/// Pairs (A before B along some ray) that the order puts the other way round.
fn violations(scene: &Scene, camera: &Camera, order: &[u32], rays: u32) -> usize {
    let mut pos = vec![usize::MAX; scene.num_tets()];
    for (i, &t) in order.iter().enumerate() {
        pos[t as usize] = i;
    }
    let c = scene.centre_in_world();
    let pts: Vec<DVec3> = scene.positions_rel().iter().map(|p| DVec3::from(*p) + c).collect();
    let mut bad = 0;
    let (w, h) = (camera.width() as f64, camera.height() as f64);
    for j in 0..rays {
        for i in 0..rays {
            let (o, d) = camera.ray((i as f64 + 0.37) * w / rays as f64, (j as f64 + 0.61) * h / rays as f64);
            let mut hits: Vec<(f64, f64, usize)> = scene
                .tets()
                .iter()
                .enumerate()
                .filter_map(|(t, tet)| {
                    let p = tet.map(|v| pts[v as usize]);
                    ray_tet(&p, o, d).filter(|&(_, t1)| t1 > 0.0).map(|(t0, t1)| (t0, t1, t))
                })
                .filter(|&(_, _, t)| pos[t] != usize::MAX)
                .collect();
            hits.sort_by(|a, b| a.0.total_cmp(&b.0));
            for a in 0..hits.len() {
                for b in a + 1..hits.len() {
                    // Strictly separated along the ray (shared faces touch).
                    if hits[a].1 <= hits[b].0 + 1e-12
                        && hits[b].1 - hits[b].0 > 1e-9
                        && hits[a].1 - hits[a].0 > 1e-9
                        && pos[hits[a].2] > pos[hits[b].2]
                    {
                        bad += 1;
                    }
                }
            }
        }
    }
    bad
}

fn views() -> Vec<ViewSpec> {
    let base = ViewSpec::framing([0.0; 3], [1.0; 3], [64, 64]);
    let mut v = Vec::new();
    for (k, (az, el)) in [(0.0, 0.0), (37.0, 20.0), (-120.0, -45.0), (200.0, 70.0)].into_iter().enumerate() {
        let mut s = base.orbit(az, el, 1.0);
        s.parallel = k % 2 == 1;
        v.push(s);
    }
    // Close up, perspective, camera just outside; and inside the hull.
    let mut close = base.orbit(15.0, 10.0, 1.0);
    close.position = [0.5, 0.5, 1.3];
    v.push(close);
    let mut inside = base.clone();
    inside.position = [0.45, 0.52, 0.55];
    inside.focal_point = [0.5, 0.5, 0.0];
    v.push(inside);
    v
}

#[test]
fn mpvo_is_exact_on_delaunay_meshes() {
    for seed in [3u64, 11] {
        let scene = delaunay_scene(150, seed);
        assert!(scene.is_convex());
        for view in views() {
            let camera = Camera::new(&view).unwrap();
            let geo = ViewGeometry::new(&scene, &camera);
            for m in [SortMethod::Mpvo, SortMethod::Mpvonc] {
                let o = visibility_order(&scene, &geo, m, None);
                assert_eq!(o.tets.len(), scene.num_tets());
                let mut seen = o.tets.clone();
                seen.sort();
                seen.dedup();
                assert_eq!(seen.len(), scene.num_tets(), "every tet exactly once");
                assert_eq!(o.cycles_broken, 0, "{m:?} {view:?}");
                let bad = violations(&scene, &camera, &o.tets, 24);
                assert_eq!(bad, 0, "{m:?} on seed {seed}, view {view:?}");
            }
            let radix = visibility_order(&scene, &geo, SortMethod::Radix, None);
            assert_eq!(radix.tets.len(), scene.num_tets());
        }
    }
}

#[test]
fn visible_subset_is_ordered_and_filtered() {
    let scene = delaunay_scene(120, 5);
    let view = views()[1].clone();
    let camera = Camera::new(&view).unwrap();
    let geo = ViewGeometry::new(&scene, &camera);
    let visible: Vec<bool> = (0..scene.num_tets()).map(|t| t % 3 != 0).collect();
    for m in [SortMethod::Mpvo, SortMethod::Mpvonc, SortMethod::Radix] {
        let o = visibility_order(&scene, &geo, m, Some(&visible));
        assert_eq!(o.tets.len(), visible.iter().filter(|&&v| v).count());
        assert!(o.tets.iter().all(|&t| visible[t as usize]));
        if m != SortMethod::Radix {
            assert_eq!(violations(&scene, &camera, &o.tets, 16), 0, "{m:?}");
        }
    }
}

#[test]
fn mpvonc_orders_separate_blocks_by_depth() {
    // Two grids, one behind the other along the view direction: no face
    // connects them, so plain MPVO starts both at once.
    let (p1, t1, s1) = grid_mesh(3, 0.2, [0.0, 0.0, 0.0], 1, |p| p[0]);
    let (p2, t2, s2) = grid_mesh(3, 0.2, [0.3, 0.2, -2.0], 2, |p| p[1]);
    let off = p1.len() as u32;
    let pts: Vec<[f64; 3]> = p1.iter().chain(&p2).copied().collect();
    let tets: Vec<[u32; 4]> = t1.iter().copied().chain(t2.iter().map(|t| t.map(|v| v + off))).collect();
    let s: Vec<f64> = s1.iter().chain(&s2).copied().collect();
    let scene = Scene::new(&pts, tets, s).unwrap();
    assert!(!scene.is_convex());
    let view = ViewSpec {
        view_angle: 40.0,
        ..ViewSpec::looking_at([0.6, 0.6, 4.0], [0.6, 0.6, -1.0], [0.0, 1.0, 0.0], [48, 48])
    };
    let camera = Camera::new(&view).unwrap();
    let geo = ViewGeometry::new(&scene, &camera);
    let nc = visibility_order(&scene, &geo, SortMethod::Auto, None);
    assert_eq!(nc.method, SortMethod::Mpvonc);
    assert_eq!(violations(&scene, &camera, &nc.tets, 20), 0);
    let plain = visibility_order(&scene, &geo, SortMethod::Mpvo, None);
    assert!(violations(&scene, &camera, &plain.tets, 20) > 0, "plain MPVO interleaves the blocks");
}

#[test]
fn cycles_are_broken_and_counted() {
    // Three tets around the edge (p0, p1), each sharing a face with the next;
    // forge the face sides into the cycle 0 → 1 → 2 → 0.
    let (c, s) = (0.5f64, 3f64.sqrt() / 2.0);
    let pts = [[0.0, 0.0, 0.0], [0.0, 0.0, 1.0], [1.0, 0.0, 0.5], [-c, s, 0.5], [-c, -s, 0.5]];
    let mut tets = vec![[0, 1, 2, 3], [0, 1, 3, 4], [0, 1, 4, 2]];
    for t in &mut tets {
        let p = t.map(|v| glam::DVec3::from(pts[v as usize]));
        if (p[1] - p[0]).dot((p[2] - p[0]).cross(p[3] - p[0])) < 0.0 {
            t.swap(2, 3);
        }
    }
    let scene = Scene::new(&pts, tets, vec![0.0; 5]).unwrap();
    let view = ViewSpec::framing([-1.0; 3], [1.0; 3], [16, 16]);
    let camera = Camera::new(&view).unwrap();
    let mut geo = ViewGeometry::new(&scene, &camera);
    let nb = scene.neighbors();
    for (t, nbt) in nb.iter().enumerate() {
        for (f, &n) in nbt.iter().enumerate() {
            if n == tet_mesh::NO_NEIGHBOR {
                continue;
            }
            let bit = if n as usize == (t + 1) % 3 { 1 << (4 + f) } else { 1 << f };
            geo.face_mask[t] = (geo.face_mask[t] & !(0x11 << f)) | bit;
        }
    }
    for m in [SortMethod::Mpvo, SortMethod::Mpvonc] {
        let o = visibility_order(&scene, &geo, m, None);
        assert_eq!(o.cycles_broken, 1, "{m:?}");
        let mut t = o.tets.clone();
        t.sort();
        assert_eq!(t, vec![0, 1, 2]);
    }
}
