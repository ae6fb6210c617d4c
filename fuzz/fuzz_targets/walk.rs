//! The ray walker on meshes built from the input bytes: Delaunay tets of
//! points on a coarse lattice (degenerate grids: shared planes, slivers,
//! cospherical points, faces edge-on to axis-aligned cameras) or of
//! arbitrary f64 points, with cameras orbiting, edge-on (multiples of 90°),
//! zoomed until the eye is inside the mesh, perspective or parallel. On a
//! valid mesh no run may fail (every exit found, no step bound hit) and
//! every pixel is finite with α in [0, 1]. The image is not compared with
//! PT's: on edge-on views a pixel centre can lie exactly on a silhouette
//! edge, which the walker decides by exact predicates with symbolic
//! perturbation and PT by f64 rounding, so they may differ by one whole ray
//! there (fuzz finding, pinned in crates/tet_render/tests/walk.rs).
//! Adaptive sampling must give every pixel the full walk covers a colour,
//! walked or interpolated, and finite pixels too. The scalar walk must give
//! the packet walk's image bit for bit and the same counts (where the CPU
//! has AVX2 the default is the packet walk). A second view drawn after the
//! first by the same renderer (the eye's tet walked to from the last view's)
//! must be what a fresh renderer draws.
#![no_main]
mod common;

use libfuzzer_sys::fuzz_target;
use std::sync::Arc;
use tet_preint::{ExactShader, SegmentShader};
use tet_render::{CpuRenderer, RasterOptions, Renderer, ViewSpec};

fuzz_target!(|data: &[u8]| {
    let Some((head, rest)) = data.split_first_chunk::<6>() else { return };
    let [mode, az, el, zoom, sbyte, size] = *head;
    let Some(common::DelaunayScene { scene, .. }) = common::delaunay_scene(mode, rest, 64, 24, sbyte) else { return };
    let (lo, hi) = scene.bounds();
    let side = 8 + (size % 24) as u32;
    let mut view = ViewSpec::framing(lo, hi, [side, side + 3]);
    view.parallel = mode & 2 != 0;
    // Edge-on views of the lattice's planes, or any angle.
    let (az, el) = if mode & 4 != 0 {
        ((az % 4) as f64 * 90.0, ((el % 3) as f64 - 1.0) * 45.0)
    } else {
        (az as f64 * 360.0 / 256.0, el as f64 * 178.0 / 256.0 - 89.0)
    };
    let view = view.orbit(az, el, 1.0 + zoom as f64 / 4.0);
    let tf = common::tf();
    let shader: Arc<dyn SegmentShader> = Arc::new(ExactShader::new(tf));
    // The walker's adaptive sampling at a tolerance from the input, too.
    let tol = (sbyte % 16) as f32 / 256.0;
    let mut walked = None;
    let passes = [
        (CpuRenderer::Walk, None, true),
        (CpuRenderer::Pt, None, true),
        (CpuRenderer::Walk, Some(tol), true),
        (CpuRenderer::Walk, None, false),
        (CpuRenderer::Walk, Some(tol), false),
    ];
    let mut adaptive_packets = None;
    for (kind, adaptive, walk_packets) in passes {
        let mut r = Renderer::new(scene.clone());
        r.set_renderer(kind);
        if r.set_view(&view).is_err() {
            return;
        }
        r.set_shader(shader.clone());
        // No early termination: both composite every segment.
        r.set_raster_options(RasterOptions {
            opaque_alpha: 2.0,
            walk_adaptive: adaptive,
            walk_packets,
            ..Default::default()
        });
        let Ok((img, st)) = r.render(&|_, _| {}) else { return };
        assert_eq!(st.walk_non_manifold + st.walk_step_limit, 0, "walk failures on a valid mesh: {st:?}");
        common::check_pixels(&img, &kind.to_string());
        match (adaptive, &walked) {
            (None, None) if kind == CpuRenderer::Walk => walked = Some((img, st)),
            // The scalar walk against the packet walk.
            (None, Some((packet, ps))) if kind == CpuRenderer::Walk && !walk_packets => {
                assert!(img.pixels() == packet.pixels(), "the scalar and the packet walk differ");
                let counts = |s: &tet_render::RenderStats| {
                    (s.crossings, s.fragments, s.walk_runs, s.walk_rays, s.walk_exact_tests, s.walk_step_limit)
                };
                assert_eq!(counts(&st), counts(ps), "{st:?} vs {ps:?}");
            }
            // Adaptive sampling covers the pixels the full walk covers,
            // each walked or interpolated.
            (Some(_), Some((_, fs))) if st.renderer == "walk" && fs.renderer == "walk" => {
                assert_eq!(st.walk_rays + st.walk_rays_interpolated, fs.walk_rays, "{st:?} vs {fs:?}");
                // Each level's rays by packets or one by one: one image.
                match adaptive_packets.take() {
                    None => adaptive_packets = Some((img, st)),
                    Some((packet, ps)) => {
                        assert!(img.pixels() == packet.pixels(), "adaptive: the scalar and the packet walk differ");
                        let counts = |s: &tet_render::RenderStats| (s.fragments, s.walk_rays, s.walk_rays_interpolated);
                        assert_eq!(counts(&st), counts(&ps), "{st:?} vs {ps:?}");
                    }
                }
            }
            _ => {}
        }
    }
    // A moving camera: a renderer drawing a second view after this one
    // (its view recycled: the eye's tet walked to from the last one's,
    // the homogeneous projection first) draws what a fresh renderer draws.
    let next = view.orbit(2.0 + (sbyte % 7) as f64, 1.0 + (size % 3) as f64, 1.0);
    let opts = RasterOptions { opaque_alpha: 2.0, ..Default::default() };
    let renderer = || {
        let mut r = Renderer::new(scene.clone());
        r.set_shader(shader.clone());
        r.set_raster_options(opts);
        r
    };
    let mut moving = renderer();
    if moving.set_view(&view).is_err() || moving.render(&|_, _| {}).is_err() || moving.set_view(&next).is_err() {
        return;
    }
    let mut fresh = renderer();
    if fresh.set_view(&next).is_err() {
        return;
    }
    let (Ok((a, sa)), Ok((b, sb))) = (moving.render(&|_, _| {}), fresh.render(&|_, _| {})) else { return };
    assert!(a.pixels() == b.pixels(), "a recycled view draws another image: {sa:?} vs {sb:?}");
    assert_eq!(
        (sa.renderer.as_str(), sa.walk_near_clipped, sa.walk_eye_inside, sa.walk_fallback.is_some()),
        (sb.renderer.as_str(), sb.walk_near_clipped, sb.walk_eye_inside, sb.walk_fallback.is_some())
    );
});
