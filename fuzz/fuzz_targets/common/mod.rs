//! What the Delaunay and renderer targets build from their input bytes.
#![allow(dead_code)] // not every target uses all of it

use tet_preint::TransferFunction;

/// Points from `bytes`: with bit 0 of `mode` clear, at most `lattice`
/// points on the coarse grid {0, …, 4}³ (3 bytes each: massive
/// cospherical, coplanar and collinear ties and duplicates); with it set,
/// at most `raw` points of arbitrary f64 bit patterns (24 bytes each).
pub fn points(mode: u8, bytes: &[u8], lattice: usize, raw: usize) -> Vec<[f64; 3]> {
    if mode & 1 == 0 {
        bytes.chunks_exact(3).take(lattice).map(|c| [c[0], c[1], c[2]].map(|b| (b % 5) as f64)).collect()
    } else {
        bytes
            .chunks_exact(24)
            .take(raw)
            .map(|c| {
                let f = |k: usize| f64::from_le_bytes(c[8 * k..8 * k + 8].try_into().unwrap());
                [f(0), f(1), f(2)]
            })
            .collect()
    }
}

/// A Delaunay mesh of the input's points and the scene over it: what the
/// renderer targets draw.
pub struct DelaunayScene {
    pub points: Vec<[f64; 3]>,
    pub tets: Vec<[u32; 4]>,
    pub scalar: Vec<f64>,
    pub scene: tet_render::Scene,
}

/// [`points`] of `bytes` tetrahedralized, with [`scalars`] varied by
/// `sbyte`; `None` where the points make no tet or the scene refuses them.
pub fn delaunay_scene(mode: u8, bytes: &[u8], lattice: usize, raw: usize, sbyte: u8) -> Option<DelaunayScene> {
    let points = points(mode, bytes, lattice, raw);
    let d = tet_delaunay::tetrahedralize_points(&points, &tet_delaunay::DelaunayOptions::default()).ok()?;
    if d.tets.is_empty() {
        return None;
    }
    let scalar = scalars(points.len(), sbyte);
    let scene = tet_render::Scene::new(&points, d.tets.clone(), scalar.clone()).ok()?;
    Some(DelaunayScene { points, tets: d.tets, scalar, scene })
}

/// One scalar in [0, 1] per point, varied by `sbyte`.
pub fn scalars(n: usize, sbyte: u8) -> Vec<f64> {
    (0..n).map(|i| ((i as u32 * 7 + sbyte as u32) % 11) as f64 / 10.0).collect()
}

/// The renderer targets' transfer function.
pub fn tf() -> TransferFunction {
    TransferFunction::from_json(
        r#"{"color": [[0, 1, 0, 0], [0.5, 0, 1, 0], [1, 0, 0, 1]], "opacity": [[0, 0.5], [0.6, 4], [1, 1]], "unit_distance": 1}"#,
    )
    .unwrap()
}

/// Every pixel finite with α in [0, 1] (to rounding); `what` names the
/// image in the failure.
pub fn check_pixels(img: &tet_render::Image, what: &str) {
    for p in img.pixels() {
        assert!(p.iter().all(|v| v.is_finite()), "{what}: {p:?}");
        assert!(p[3] >= 0.0 && p[3] <= 1.0 + 1e-5, "{what}: {p:?}");
    }
}
