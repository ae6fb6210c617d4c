//! What the held-out image test and its example share: the repository
//! root, the held-out TFs and the image comparison they judge by.
#![allow(dead_code)] // the example and the test use different parts

use glam::DVec3;
use std::path::{Path, PathBuf};
use tet_mesh::{build_adjacency, Adjacency, TetMesh};
use tet_preint::{TableDomain, TransferFunction};
use tet_render::{Renderer, Scene, ViewSpec};

/// The repository root.
pub fn root() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("../..")
}

/// Held-out TF `name` (crates/tet_preint/tests/data/heldout).
pub fn heldout(name: &str) -> TransferFunction {
    let p = root().join("crates/tet_preint/tests/data/heldout").join(name);
    TransferFunction::from_json(&std::fs::read_to_string(p).unwrap()).unwrap()
}

/// (linear max |difference|, pixels with a channel off by more than 1/255).
pub fn diff(a: &tet_render::Image, b: &tet_render::Image) -> (f64, usize) {
    let mut max = 0.0f64;
    let mut over = 0;
    for (p, q) in a.pixels().iter().zip(b.pixels()) {
        let d = (0..4).map(|c| (f64::from(p[c]) - f64::from(q[c])).abs()).fold(0.0, f64::max);
        max = max.max(d);
        over += usize::from(d > 1.0 / 255.0);
    }
    (max, over)
}

/// What the comparison needs of `mesh`: its face adjacency, the bundle's
/// table domain (as tetview render computes it) and the view framing the
/// mesh from (`azimuth`, `elevation`) at `size`².
pub fn framed(mesh: &TetMesh, size: u32, azimuth: f64, elevation: f64) -> (Adjacency, TableDomain, ViewSpec) {
    let adj = build_adjacency(&mesh.points, &mesh.tets).unwrap();
    let stats = tet_mesh::mesh_stats(&mesh.points, &mesh.tets, &mesh.scalar);
    let bundle = tet_bundle::Bundle::with_stats(mesh.clone(), adj.clone(), Default::default(), stats);
    let domain = TableDomain::from_bundle(&bundle).unwrap();
    let (lo, hi) =
        mesh.points.iter().fold((DVec3::splat(f64::INFINITY), DVec3::splat(f64::NEG_INFINITY)), |(a, b), p| {
            (a.min(DVec3::from(*p)), b.max(DVec3::from(*p)))
        });
    let view = ViewSpec::framing(lo.into(), hi.into(), [size, size]).orbit(azimuth, elevation, 1.2);
    (adj, domain, view)
}

/// The default CPU renderer of `mesh` at `view`.
pub fn renderer_at(mesh: &TetMesh, view: &ViewSpec) -> Renderer {
    let scene = Scene::new(&mesh.points, mesh.tets.clone(), mesh.scalar.clone()).unwrap();
    let mut r = Renderer::new(scene);
    r.set_view(view).unwrap();
    r
}
