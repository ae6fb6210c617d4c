//! The CPU renderer on meshes built from the input bytes: Delaunay tets of
//! points on a coarse grid (slivers, shared planes, edge-on faces) or of
//! arbitrary f64 points, scalars and a camera from the bytes (orbit, zoom
//! that puts the eye inside the mesh: near-plane clipping, parallel or
//! perspective). Projected tetrahedra (fast and per-tile paths) and the
//! reference ray caster must give finite pixels with α in [0, 1], or a
//! documented error — never a panic.
#![no_main]
mod common;

use libfuzzer_sys::fuzz_target;
use std::sync::Arc;
use tet_preint::{ExactShader, PtLinearShader, SegmentShader};
use tet_render::{Camera, RasterOptions, ReferenceOptions, Renderer, ViewSpec};

fuzz_target!(|data: &[u8]| {
    let Some((head, rest)) = data.split_first_chunk::<6>() else { return };
    let [mode, az, el, zoom, sbyte, _] = *head;
    let Some(common::DelaunayScene { points: pts, tets, scalar, scene }) =
        common::delaunay_scene(mode, rest, 48, 24, sbyte)
    else {
        return;
    };
    let (lo, hi) = scene.bounds();
    let mut view = ViewSpec::framing(lo, hi, [12, 10]);
    view.parallel = mode & 2 != 0;
    // Zoom up to 64×: the eye can end up inside the mesh.
    let view = view.orbit(az as f64 * 360.0 / 256.0, el as f64 * 178.0 / 256.0 - 89.0, 1.0 + zoom as f64 / 4.0);
    let tf = common::tf();
    let mut r = Renderer::new(scene);
    // This target is projected tetrahedra's (the walker has its own, walk.rs).
    r.set_renderer(tet_render::CpuRenderer::Pt);
    if r.set_view(&view).is_err() {
        return;
    }
    let shaders: [Arc<dyn SegmentShader>; 2] =
        [Arc::new(ExactShader::new(tf.clone())), Arc::new(PtLinearShader::new(tf.clone()))];
    for shader in shaders {
        r.set_shader(shader);
        for fast_path in [true, false] {
            r.set_raster_options(RasterOptions { fast_path, ..Default::default() });
            if let Ok((img, _)) = r.render(&|_, _| {}) {
                common::check_pixels(&img, if fast_path { "fast path" } else { "per-tile path" });
            }
        }
    }
    // The reference ray caster on the same mesh and camera.
    let Ok(adjacency) = tet_mesh::build_adjacency(&pts, &tets) else { return };
    let mesh = tet_mesh::TetMesh {
        points: pts.clone(),
        tets: tets.clone().into(),
        scalar,
        scalar_name: "s".into(),
        point_fields: Vec::new(),
    };
    let Ok(camera) = Camera::new(&view) else { return };
    if let Ok((img, _)) =
        tet_render::render_reference(&mesh, &adjacency, &camera, &tf, &ReferenceOptions::default(), &|_, _| {})
    {
        common::check_pixels(&img, "reference");
    }
});
