//! Per-pixel accuracy against an independent f64 reference: single tets of
//! every shape (random, slivers, edge-on, crossing the near plane, camera
//! inside) with the exact integrator, and whole meshes under a constant
//! transfer function, where every ray's opacity is known in closed form —
//! which also proves there are no seam pixels (a missed or doubled shared
//! edge would change a pixel's total length).
mod common;

use common::*;
use glam::DVec3;
use std::sync::Arc;
use tet_preint::{ExactShader, TransferFunction};
use tet_render::{Camera, Scene, ViewSpec};

const RAMP: &str = r#"{"color": [[0, 1, 0.2, 0], [0.5, 0.1, 1, 0.3], [1, 0, 0.3, 1]],
    "opacity": [[0, 0.2], [0.3, 3], [0.7, 0.5], [1, 2]], "unit_distance": 1}"#;

fn single_tet_case(p: [[f64; 3]; 4], s: [f64; 4], view: &ViewSpec, tf: &TransferFunction, tol: f64) -> usize {
    let scene = Scene::new(&p, vec![[0, 1, 2, 3]], s.to_vec()).unwrap();
    let img = render(scene, view, Arc::new(ExactShader::new(tf.clone())));
    assert_finite(&img);
    let cam = Camera::new(view).unwrap();
    let pd = p.map(DVec3::from);
    let mut covered = 0;
    for y in 0..view.size[1] {
        for x in 0..view.size[0] {
            let want = reference_single(&cam, &pd, s, tf, x as f64 + 0.5, y as f64 + 0.5);
            let got = img.pixel(x, y);
            for c in 0..4 {
                assert!(
                    (got[c] as f64 - want[c]).abs() <= tol,
                    "pixel ({x},{y}) channel {c}: got {got:?} want {want:?} (tet {p:?})"
                );
            }
            if want[3] > 1e-6 {
                covered += 1;
            }
        }
    }
    covered
}

fn positive(mut p: [[f64; 3]; 4]) -> [[f64; 3]; 4] {
    let d = |a: [f64; 3], b: [f64; 3]| DVec3::from(b) - DVec3::from(a);
    if d(p[0], p[1]).dot(d(p[0], p[2]).cross(d(p[0], p[3]))) < 0.0 {
        p.swap(2, 3);
    }
    p
}

#[test]
fn random_tets_match_the_exact_integral_per_pixel() {
    let tf = tf(RAMP);
    let mut rng = Rng(0x5eed_0001);
    for case in 0..12 {
        let p = positive(std::array::from_fn(|_| std::array::from_fn(|_| rng.range(-1.0, 1.0))));
        let s = std::array::from_fn(|_| rng.next_f64());
        let mut view =
            ViewSpec::framing([-1.0; 3], [1.0; 3], [40, 32]).orbit(rng.range(0.0, 360.0), rng.range(-60.0, 60.0), 1.0);
        view.parallel = case % 2 == 1;
        single_tet_case(p, s, &view, &tf, 2e-5);
    }
}

#[test]
fn slivers_and_edge_on_tets_are_finite_and_exact() {
    let tf = tf(RAMP);
    let view = ViewSpec::framing([-1.0; 3], [1.0; 3], [48, 48]);
    for parallel in [false, true] {
        let mut v = view.clone();
        v.parallel = parallel;
        // A sliver: four nearly coplanar points (thickness 1e-7).
        let sliver = positive([[-0.8, -0.7, 0.0], [0.9, -0.6, 1e-7], [0.1, 0.8, 0.0], [0.0, 0.0, 2e-7]]);
        single_tet_case(sliver, [0.0, 1.0, 0.5, 0.2], &v, &tf, 2e-5);
        // A needle along the view direction (projects to almost a point).
        let needle = positive([[0.0, 0.0, -0.9], [0.01, 0.0, 0.9], [0.0, 0.012, 0.9], [0.005, 0.004, 0.0]]);
        single_tet_case(needle, [0.2, 0.9, 0.4, 0.6], &v, &tf, 2e-5);
        // A face exactly edge-on (the face x = 0 contains the view direction −z).
        let edge_on = positive([[0.0, -0.5, -0.5], [0.0, 0.5, -0.5], [0.0, 0.0, 0.5], [0.7, 0.0, 0.0]]);
        let covered = single_tet_case(edge_on, [0.1, 0.5, 0.9, 0.3], &v, &tf, 2e-5);
        assert!(covered > 50, "edge-on tet covered only {covered} pixels");
        // Class 1 with the thick vertex exactly on the silhouette edge.
        let on_edge = positive([[-0.8, -0.8, 0.0], [0.8, -0.8, 0.0], [0.0, 0.8, 0.0], [0.0, -0.8, 0.7]]);
        single_tet_case(on_edge, [0.0, 0.3, 1.0, 0.6], &v, &tf, 2e-5);
    }
}

#[test]
fn tets_crossing_the_near_plane_are_clipped_not_dropped() {
    let tf = tf(RAMP);
    let p = positive([[-1.0, -1.0, -1.0], [1.5, -1.0, -1.0], [-1.0, 1.5, -1.0], [-1.0, -1.0, 1.5]]);
    // Camera inside the tet, looking in several directions.
    for (k, dir) in [[0.0, 0.0, -1.0], [0.3, 0.2, 1.0], [1.0, -0.4, 0.1]].into_iter().enumerate() {
        let eye = [-0.5, -0.5, -0.4];
        let view = ViewSpec {
            view_angle: 60.0,
            ..ViewSpec::looking_at(eye, [eye[0] + dir[0], eye[1] + dir[1], eye[2] + dir[2]], [0.0, 1.0, 0.3], [32, 24])
        };
        let covered = single_tet_case(p, [0.0, 1.0, 0.4, 0.8], &view, &tf, 2e-5);
        assert_eq!(covered, 32 * 24, "case {k}: the whole image sees the inside of the tet");
    }
    // Eye outside, near plane cutting through the tet's corner.
    let view = ViewSpec {
        view_angle: 90.0,
        ..ViewSpec::looking_at([-1.0 - 1e-7, -0.2, 0.0], [1.0, -0.2, 0.0], [0.0, 0.0, 1.0], [32, 32])
    };
    single_tet_case(p, [0.0, 1.0, 0.4, 0.8], &view, &tf, 2e-5);
}

/// Length of the ray o + t·d (t ≥ t_min) inside the box [lo, hi].
fn ray_box(o: DVec3, d: DVec3, lo: DVec3, hi: DVec3, t_min: f64) -> f64 {
    let (mut t0, mut t1) = (t_min, f64::INFINITY);
    for a in 0..3 {
        if d[a] == 0.0 {
            if o[a] < lo[a] || o[a] > hi[a] {
                return 0.0;
            }
            continue;
        }
        let (ta, tb) = ((lo[a] - o[a]) / d[a], (hi[a] - o[a]) / d[a]);
        t0 = t0.max(ta.min(tb));
        t1 = t1.min(ta.max(tb));
    }
    (t1 - t0).max(0.0)
}

/// Constant scalar, constant extinction ρ: α = 1 − exp(−ρ·L) with L the
/// ray's length inside the (convex, box-shaped) mesh.
fn constant_tf_mesh(view: &ViewSpec, n: usize, jitter: f64, tol: f64, skip: impl Fn(u32, u32) -> bool) {
    let (pts, tets, s) = grid_mesh(n, jitter, [0.0; 3], 7, |_| 0.5);
    let rho = 1.3;
    let tf = tf(&format!(r#"{{"color": [[0, 1, 1, 1]], "opacity": [[0, {rho}]], "unit_distance": 1}}"#));
    let scene = Scene::new(&pts, tets, s).unwrap();
    let img = render(scene, view, Arc::new(ExactShader::new(tf)));
    assert_finite(&img);
    let cam = Camera::new(view).unwrap();
    let mut worst = 0.0f64;
    let mut checked = 0;
    for y in 0..view.size[1] {
        for x in 0..view.size[0] {
            if skip(x, y) {
                continue;
            }
            let (o, d) = cam.ray(x as f64 + 0.5, y as f64 + 0.5);
            let t_min = if cam.is_parallel() { f64::NEG_INFINITY } else { cam.near_depth() / d.dot(cam.forward()) };
            let l = ray_box(o, d, DVec3::ZERO, DVec3::ONE, t_min);
            let want = -(-rho * l).exp_m1();
            let got = img.pixel(x, y)[3] as f64;
            worst = worst.max((got - want).abs());
            assert!((got - want).abs() <= tol, "pixel ({x},{y}): alpha {got} want {want} (L = {l})");
            checked += 1;
        }
    }
    assert!(checked > 100, "only {checked} pixels checked");
    eprintln!("worst |Δα| = {worst:e} over {checked} pixels");
}

#[test]
fn constant_tf_mesh_has_no_seams_perspective_and_parallel() {
    for parallel in [false, true] {
        let mut view = ViewSpec::framing([0.0; 3], [1.0; 3], [64, 64]).orbit(33.0, 21.0, 1.2);
        view.parallel = parallel;
        constant_tf_mesh(&view, 5, 0.3, 2e-5, |_, _| false);
    }
}

#[test]
fn pixel_centres_exactly_on_shared_edges_are_counted_once() {
    // Parallel view down −z; pixel centres land exactly on the grid lines
    // x, y = k/4 and on the cells' face diagonals (all binary fractions).
    let b = 1.0 / 32.0;
    let view = ViewSpec {
        parallel: true,
        parallel_scale: 20.0 * b,
        ..ViewSpec::looking_at(
            [0.5 + b / 2.0, 0.5 + b / 2.0, 5.0],
            [0.5 + b / 2.0, 0.5 + b / 2.0, 0.5],
            [0.0, 1.0, 0.0],
            [40, 40],
        )
    };
    // Pixel i's centre is at x = 0.5 + (i − 19)/32: the box edges x = 0, 1
    // are at i = 3 and 35 (rays grazing the boundary are ambiguous: skipped).
    let on_boundary = |i: u32| i == 3 || i == 35;
    let skip = |x: u32, y: u32| on_boundary(x) || on_boundary(39 - y) || on_boundary(y);
    constant_tf_mesh(&view, 4, 0.0, 2e-6, skip);
}

#[test]
fn camera_inside_the_mesh_sees_every_pixel() {
    let view = ViewSpec {
        view_angle: 70.0,
        ..ViewSpec::looking_at([0.41, 0.52, 0.47], [0.9, 0.7, 0.2], [0.0, 0.0, 1.0], [48, 40])
    };
    constant_tf_mesh(&view, 4, 0.25, 2e-5, |_, _| false);
}
