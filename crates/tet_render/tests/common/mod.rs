//! Shared helpers: small meshes and an independent f64 ray–tet reference.
#![allow(dead_code)]

use glam::DVec3;
use std::sync::Arc;
use tet_mesh::{tetrahedralize, ConvertOptions, SourceMesh};
use tet_preint::{integrate_segment, TransferFunction};
use tet_render::{Camera, Image, Renderer, Scene, ViewSpec};

/// A small xorshift generator (fixed seeds).
pub use tet_mesh::XorShift64 as Rng;

/// An `n³`-cell grid over [0,1]³ (+ `offset`), 5-split into tets, interior
/// points jittered by up to `jitter` cells, scalar `s(p)` of the un-offset
/// position.
pub fn grid_mesh(
    n: usize,
    jitter: f64,
    offset: [f64; 3],
    seed: u64,
    s: impl Fn([f64; 3]) -> f64,
) -> (Vec<[f64; 3]>, Vec<[u32; 4]>, Vec<f64>) {
    let mut rng = Rng(seed | 1);
    let mut points = Vec::new();
    let mut values = Vec::new();
    let h = 1.0 / n as f64;
    for k in 0..=n {
        for j in 0..=n {
            for i in 0..=n {
                let interior = |a: usize| a > 0 && a < n;
                let mut p = [i as f64 * h, j as f64 * h, k as f64 * h];
                for (a, idx) in [i, j, k].into_iter().enumerate() {
                    if interior(idx) {
                        p[a] += rng.range(-jitter, jitter) * h;
                    }
                }
                values.push(s(p));
                points.push([p[0] + offset[0], p[1] + offset[1], p[2] + offset[2]]);
            }
        }
    }
    let src = SourceMesh::structured([n + 1; 3], points, "s", values);
    let opts = ConvertOptions { scalar: Some("s".into()), ..Default::default() };
    let (mesh, _) = tetrahedralize(&src, &opts, &mut |_| {}).expect("grid splits");
    (mesh.points, mesh.tets.into_vec(), mesh.scalar)
}

pub fn tf(json: &str) -> TransferFunction {
    TransferFunction::from_json(json).expect("test TF")
}

/// Entry and exit parameters of the ray o + t·d through a positive tet.
pub fn ray_tet(p: &[DVec3; 4], o: DVec3, d: DVec3) -> Option<(f64, f64)> {
    const FACES: [[usize; 3]; 4] = [[1, 2, 3], [0, 3, 2], [0, 1, 3], [0, 2, 1]];
    let (mut t0, mut t1) = (f64::NEG_INFINITY, f64::INFINITY);
    for f in FACES {
        let (a, b, c) = (p[f[0]], p[f[1]], p[f[2]]);
        let n = (b - a).cross(c - a);
        let nd = n.dot(d);
        let dist = n.dot(a - o);
        if nd == 0.0 {
            if dist < 0.0 {
                return None;
            }
            continue;
        }
        let t = dist / nd;
        if nd < 0.0 {
            t0 = t0.max(t);
        } else {
            t1 = t1.min(t);
        }
    }
    (t1 > t0).then_some((t0, t1))
}

/// Linear interpolation of vertex values inside a tet.
pub fn linear_at(p: &[DVec3; 4], v: [f64; 4], x: DVec3) -> f64 {
    let (e1, e2, e3) = (p[1] - p[0], p[2] - p[0], p[3] - p[0]);
    let det = e1.dot(e2.cross(e3));
    let g = (e2.cross(e3) * (v[1] - v[0]) + e3.cross(e1) * (v[2] - v[0]) + e1.cross(e2) * (v[3] - v[0])) / det;
    v[0] + g.dot(x - p[0])
}

/// Reference pixel of a single tet: exact ray, exact segment, exact integral
/// (clipped at the camera's near depth for perspective).
pub fn reference_single(
    camera: &Camera,
    p: &[DVec3; 4],
    s: [f64; 4],
    tf: &TransferFunction,
    x: f64,
    y: f64,
) -> [f64; 4] {
    let (o, d) = camera.ray(x, y);
    let Some((mut t0, t1)) = ray_tet(p, o, d) else { return [0.0; 4] };
    if !camera.is_parallel() {
        // depth = t·(d·forward); clip at the near depth.
        let near_t = camera.near_depth() / d.dot(camera.forward());
        t0 = t0.max(near_t);
    }
    if t1 <= t0 {
        return [0.0; 4];
    }
    let sf = linear_at(p, s, o + d * t0);
    let sb = linear_at(p, s, o + d * t1);
    let px = integrate_segment(tf, sf, sb, t1 - t0);
    [px.color[0], px.color[1], px.color[2], px.alpha]
}

pub fn render(scene: Scene, view: &ViewSpec, shader: Arc<dyn tet_preint::SegmentShader>) -> Image {
    let mut r = Renderer::new(scene);
    r.set_view(view).expect("view");
    r.set_shader(shader);
    r.render(&|_, _| {}).expect("render").0
}

pub fn assert_finite(img: &Image) {
    for (i, p) in img.pixels().iter().enumerate() {
        assert!(p.iter().all(|v| v.is_finite()), "pixel {i} not finite: {p:?}");
        assert!(p[3] >= 0.0 && p[3] <= 1.0 + 1e-6, "pixel {i} alpha {p:?}");
    }
}
