//! The staged renderer: determinism across thread counts, stability far
//! from the origin, what each change recomputes, culling that changes
//! nothing visible, and shading.
mod common;

use common::*;
use std::sync::Arc;
use tet_preint::{ExactShader, PtLinearShader};
use tet_render::{CpuRenderer, RasterOptions, Renderer, Scene, Shading, SortMethod, TfCuller, ViewSpec};

const TF: &str = r#"{"color": [[0, 0.2, 0.4, 1], [0.5, 1, 1, 0.2], [1, 1, 0, 0]],
    "opacity": [[0, 0], [0.35, 0], [0.6, 4], [1, 1]], "unit_distance": 0.5}"#;

/// Invisible below 0.55: most of the wave field.
const SPARSE: &str = r#"{"color": [[0, 0.2, 0.4, 1], [1, 1, 0, 0]],
    "opacity": [[0, 0], [0.55, 0], [0.8, 4], [1, 1]], "unit_distance": 0.5}"#;

fn wave(p: [f64; 3]) -> f64 {
    0.5 + 0.5 * (6.0 * p[0]).sin() * (5.0 * p[1] + 1.0).cos() * (0.5 + p[2])
}

fn view() -> ViewSpec {
    ViewSpec::framing([0.0; 3], [1.0; 3], [96, 80]).orbit(25.0, 30.0, 1.3)
}

#[test]
fn same_image_for_any_thread_count() {
    let (p, t, s) = grid_mesh(6, 0.3, [0.0; 3], 9, wave);
    let mut images = Vec::new();
    for threads in [1, 2, 3, 4] {
        let pool = rayon::ThreadPoolBuilder::new().num_threads(threads).build().unwrap();
        let img = pool.install(|| {
            let mut r = Renderer::new(Scene::new(&p, t.clone(), s.clone()).unwrap());
            r.set_view(&view()).unwrap();
            r.set_shader(Arc::new(ExactShader::new(tf(TF))));
            r.set_raster_options(RasterOptions { tile: 16, ..Default::default() });
            r.render(&|_, _| {}).unwrap().0
        });
        images.push(img);
    }
    assert!(images[0].pixels().iter().any(|p| p[3] > 0.1));
    for img in &images[1..] {
        assert!(img == &images[0], "images differ between thread counts");
    }
}

#[test]
fn coordinates_offset_by_a_million_render_the_same() {
    let off = [1.0e6, -2.0e6, 1.0e6];
    let mut images = Vec::new();
    for o in [[0.0; 3], off] {
        let (p, t, s) = grid_mesh(5, 0.3, o, 4, wave);
        let mut v = view();
        for (a, oa) in o.iter().enumerate() {
            v.position[a] += oa;
            v.focal_point[a] += oa;
        }
        let scene = Scene::new(&p, t, s).unwrap();
        images.push(render(scene, &v, Arc::new(ExactShader::new(tf(TF)))));
    }
    let d = tet_render::diff(&images[0], &images[1]).unwrap();
    assert!(images[0].pixels().iter().any(|p| p[3] > 0.1));
    assert!(d.max_abs < 1e-4, "max |Δ| {} with a 1e6 offset", d.max_abs);
}

#[test]
fn each_change_recomputes_only_what_it_invalidates() {
    let (p, t, s) = grid_mesh(4, 0.2, [0.0; 3], 2, wave);
    let mut r = Renderer::new(Scene::new(&p, t, s).unwrap());
    r.set_renderer(CpuRenderer::Pt);
    assert!(r.render(&|_, _| {}).is_err(), "no view yet");
    r.set_view(&view()).unwrap();
    r.set_shader(Arc::new(ExactShader::new(tf(TF))));
    let (_, st) = r.render(&|_, _| {}).unwrap();
    assert!(st.recomputed_view && st.recomputed_cull && st.recomputed_order);
    assert_eq!(st.sort_method, "mpvo");
    assert!(!st.reused_setup && st.setups > 0);
    // A view's first frame keeps no per-tet setup (a moving camera would
    // only pay for it); its second keeps it, the third reuses it.
    assert_eq!(r.setup_bytes(), 0);
    r.set_view(&view()).unwrap();
    let (_, st) = r.render(&|_, _| {}).unwrap();
    assert!(!st.recomputed_view && !st.recomputed_cull && !st.recomputed_order);
    assert!(!st.reused_setup && st.setups > 0 && r.setup_bytes() > 0);
    // Same view again: nothing recomputed, not even the per-tet setup.
    let (_, st) = r.render(&|_, _| {}).unwrap();
    assert!(!st.recomputed_view && !st.recomputed_cull && !st.recomputed_order);
    assert!(st.reused_setup && st.setups == 0);
    // A new TF: recull (the MPVO order covers every tet); the setup is
    // redone when the mask changed, kept when it did not.
    r.set_culler(Some(Arc::new(TfCuller::new(&tf(TF)))));
    let (_, st) = r.render(&|_, _| {}).unwrap();
    assert!(!st.recomputed_view && st.recomputed_cull && !st.recomputed_order);
    assert!(st.tets_culled > 0 && !st.reused_setup);
    r.set_culler(Some(Arc::new(TfCuller::new(&tf(TF)))));
    let (_, st) = r.render(&|_, _| {}).unwrap();
    assert!(st.recomputed_cull && st.reused_setup);
    // A new view: view, order and setup, not culling.
    r.set_view(&view().orbit(10.0, 0.0, 1.0)).unwrap();
    let (_, st) = r.render(&|_, _| {}).unwrap();
    assert!(st.recomputed_view && !st.recomputed_cull && st.recomputed_order && !st.reused_setup);
    assert_eq!(r.setup_bytes(), 0, "a moved camera's first frame keeps nothing");
    // New raster options: the setup again.
    r.set_raster_options(RasterOptions { tile: 8, ..Default::default() });
    let (_, st) = r.render(&|_, _| {}).unwrap();
    assert!(!st.recomputed_order && !st.reused_setup);
    // Radix sorts only visible tets, so a new TF resorts too.
    r.set_sort(SortMethod::Radix);
    let (_, st) = r.render(&|_, _| {}).unwrap();
    assert!(st.recomputed_order && st.sort_method == "radix");
    r.set_culler(None);
    let (_, st) = r.render(&|_, _| {}).unwrap();
    assert!(st.recomputed_cull && st.recomputed_order && st.tets_culled == 0);
}

/// The walker's stages: a view projects the vertices and bins the front
/// faces once; a new shader or TF re-shades without redoing the view; it
/// never sorts or sets a tet up.
#[test]
fn walker_recomputes_only_what_it_invalidates() {
    let (p, t, s) = grid_mesh(4, 0.2, [0.0; 3], 2, wave);
    let mut r = Renderer::new(Scene::new(&p, t, s).unwrap());
    assert_eq!(r.renderer(), CpuRenderer::Walk, "the walker is the default");
    r.set_view(&view()).unwrap();
    r.set_shader(Arc::new(ExactShader::new(tf(TF))));
    let (first, st) = r.render(&|_, _| {}).unwrap();
    assert_eq!(st.renderer, "walk");
    assert!(st.recomputed_view && st.recomputed_cull && !st.recomputed_order);
    assert_eq!((st.setups, st.sort_seconds), (0, 0.0));
    assert!(st.crossings > 0 && r.walk_bytes() > 0);
    let (again, st) = r.render(&|_, _| {}).unwrap();
    assert!(!st.recomputed_view && !st.recomputed_cull);
    assert!(first == again);
    r.set_culler(Some(Arc::new(TfCuller::new(&tf(TF)))));
    r.set_shader(Arc::new(ExactShader::new(tf(SPARSE))));
    let (_, st) = r.render(&|_, _| {}).unwrap();
    assert!(!st.recomputed_view && st.recomputed_cull);
    r.set_view(&view().orbit(10.0, 0.0, 1.0)).unwrap();
    let (_, st) = r.render(&|_, _| {}).unwrap();
    assert!(st.recomputed_view && !st.recomputed_cull);
    // A new tile size rebins the faces.
    r.set_raster_options(RasterOptions { tile: 8, ..Default::default() });
    let (_, st) = r.render(&|_, _| {}).unwrap();
    assert!(st.recomputed_view);
}

#[test]
fn culling_skips_invisible_tets_without_changing_the_image() {
    let (p, t, s) = grid_mesh(6, 0.3, [0.0; 3], 5, wave);
    let scene = Scene::new(&p, t, s).unwrap();
    let n = scene.num_tets();
    // Projected tetrahedra (the walker's culling: tests/walk.rs). This
    // mesh folds (jitter 0.3): PT composites overlapping tets, the walker
    // counts missing exits.
    let mut r = Renderer::new(scene);
    r.set_renderer(CpuRenderer::Pt);
    r.set_view(&view()).unwrap();
    r.set_shader(Arc::new(ExactShader::new(tf(SPARSE))));
    let (full, st0) = r.render(&|_, _| {}).unwrap();
    assert_eq!(st0.tets_drawn, n);
    r.set_culler(Some(Arc::new(TfCuller::new(&tf(SPARSE)))));
    let (culled, st1) = r.render(&|_, _| {}).unwrap();
    assert!(st1.tets_culled > n / 10, "culled {} of {n}", st1.tets_culled);
    assert_eq!(st1.tets_drawn, n - st1.tets_culled);
    assert!((st1.fraction_culled - st1.tets_culled as f64 / n as f64).abs() < 1e-12);
    let d = tet_render::diff(&full, &culled).unwrap();
    assert!(full == culled, "culled tets contributed: max {} rmse {}", d.max_abs, d.rmse);
}

/// A frame drawn from the kept per-tet setup (new TF, new cull mask, new
/// shader) is bit-identical to a fresh renderer's frame of the same state,
/// and to one with the cache off.
#[test]
fn kept_setup_renders_what_a_fresh_renderer_renders() {
    let (p, t, s) = grid_mesh(6, 0.3, [0.0; 3], 8, wave);
    let scene = Scene::new(&p, t, s).unwrap();
    let fresh = |tf_json: &str, cache: bool| {
        let mut r = Renderer::new(scene.clone());
        r.set_renderer(CpuRenderer::Pt);
        r.set_view(&view()).unwrap();
        let opts = RasterOptions { setup_cache_bytes: if cache { 1 << 30 } else { 0 }, ..Default::default() };
        r.set_raster_options(opts);
        r.set_shader(Arc::new(ExactShader::new(tf(tf_json))));
        r.set_culler(Some(Arc::new(TfCuller::new(&tf(tf_json)))));
        r.render(&|_, _| {}).unwrap().0
    };
    let mut r = Renderer::new(scene.clone());
    r.set_renderer(CpuRenderer::Pt);
    r.set_view(&view()).unwrap();
    for tf_json in [TF, SPARSE, TF] {
        r.set_shader(Arc::new(ExactShader::new(tf(tf_json))));
        r.set_culler(Some(Arc::new(TfCuller::new(&tf(tf_json)))));
        let (img, _) = r.render(&|_, _| {}).unwrap();
        assert!(img == fresh(tf_json, true), "kept setup differs from a fresh renderer");
        assert!(img == fresh(tf_json, false), "kept setup differs from no cache");
    }
}

#[test]
fn pt_linear_is_close_to_exact_on_a_fine_smooth_mesh() {
    let (p, t, s) = grid_mesh(8, 0.0, [0.0; 3], 1, |p| 0.3 + 0.4 * p[0]);
    let gentle = r#"{"color": [[0, 1, 0.5, 0.2], [1, 0.2, 0.5, 1]], "opacity": [[0, 1], [1, 2]], "unit_distance": 1}"#;
    let mut v = view();
    v.size = [48, 40];
    let a = render(Scene::new(&p, t.clone(), s.clone()).unwrap(), &v, Arc::new(ExactShader::new(tf(gentle))));
    let b = render(Scene::new(&p, t, s).unwrap(), &v, Arc::new(PtLinearShader::new(tf(gentle))));
    assert_finite(&b);
    let d = tet_render::diff(&a, &b).unwrap();
    // pt-linear interpolates α linearly towards the silhouette; on small,
    // thin-per-cell segments that is within a few percent of exact.
    assert!(d.max_abs < 0.05, "pt-linear vs exact max |Δ| {}", d.max_abs);
}

#[test]
fn lighting_and_silhouettes_need_gradients_and_stay_finite() {
    let (p, t, s) = grid_mesh(5, 0.2, [0.0; 3], 3, wave);
    let shading = Shading { light: Some(Default::default()), silhouette: Some(1.5), ..Default::default() };
    let mut r = Renderer::new(Scene::new(&p, t.clone(), s.clone()).unwrap());
    r.set_view(&view()).unwrap();
    r.set_shader(Arc::new(ExactShader::new(tf(TF))));
    r.set_raster_options(RasterOptions { shading, ..Default::default() });
    assert!(r.render(&|_, _| {}).unwrap_err().to_string().contains("gradients"));
    let scene = Scene::new(&p, t, s).unwrap().ensure_gradients().unwrap();
    let mut r = Renderer::new(scene);
    r.set_view(&view()).unwrap();
    r.set_shader(Arc::new(ExactShader::new(tf(TF))));
    let (plain, _) = r.render(&|_, _| {}).unwrap();
    r.set_raster_options(RasterOptions { shading, ..Default::default() });
    let (lit, _) = r.render(&|_, _| {}).unwrap();
    assert_finite(&lit);
    assert!(tet_render::diff(&plain, &lit).unwrap().max_abs > 1e-3);
}

/// The rasterizer's fast path (each tet set up once, coverage as a bit mask
/// or row spans) draws exactly what the per-tile path draws: bit-identical
/// images for table and exact shaders, perspective and parallel views, a
/// camera inside the mesh (clipped tets go through the per-tile setup in
/// order), tets large on screen (row spans) and small (masks), and
/// several thread counts.
#[test]
fn fast_path_is_bit_identical_to_the_per_tile_path() {
    let (p, t, s) = grid_mesh(5, 0.3, [0.0; 3], 11, wave);
    let scene = Scene::new(&p, t, s).unwrap();
    let tf = tf(TF);
    let domain = tet_preint::TableDomain::new(0.0, 1.0, 1.0, 2.0).unwrap();
    let table: Arc<dyn tet_preint::SegmentShader> =
        Arc::new(tet_preint::Table3d::build(&tf, &domain, &tet_preint::Table3dParams::tf_nodes()).unwrap());
    let exact: Arc<dyn tet_preint::SegmentShader> = Arc::new(ExactShader::new(tf.clone()));
    let inside = ViewSpec {
        view_angle: 70.0,
        ..ViewSpec::looking_at([0.41, 0.52, 0.47], [0.9, 0.7, 0.2], [0.0, 0.0, 1.0], [48, 40])
    };
    let mut parallel = view();
    parallel.parallel = true;
    // Small on screen (masks), large (row spans), parallel, inside.
    let views = [
        ViewSpec::framing([0.0; 3], [1.0; 3], [40, 32]).orbit(25.0, 30.0, 1.0),
        ViewSpec::framing([0.0; 3], [1.0; 3], [300, 260]).orbit(-40.0, 15.0, 1.0),
        parallel,
        inside,
    ];
    for (k, v) in views.iter().enumerate() {
        for shader in [&table, &exact] {
            for threads in [1, 3] {
                let pool = rayon::ThreadPoolBuilder::new().num_threads(threads).build().unwrap();
                let [fast, general] = [true, false].map(|fast_path| {
                    pool.install(|| {
                        let mut r = Renderer::new(scene.clone());
                        r.set_renderer(CpuRenderer::Pt);
                        r.set_view(v).unwrap();
                        r.set_shader(shader.clone());
                        r.set_raster_options(RasterOptions { tile: 16, fast_path, ..Default::default() });
                        r.render(&|_, _| {}).unwrap()
                    })
                });
                assert!(fast.0.pixels().iter().any(|p| p[3] > 0.05), "view {k}: nothing drawn");
                assert!(fast.0 == general.0, "view {k}, {threads} threads: fast path image differs");
                assert_eq!(fast.1.fragments, general.1.fragments, "view {k}: fragment counts differ");
            }
        }
    }
}

/// A time step's new scalar on a renderer that drew the old one gives the
/// bits a fresh renderer gives, for both CPU renderers, culled or not, with
/// lighting (whose gradients follow the scalar); the cull is redone, the
/// walker's per-scene links are kept.
#[test]
fn a_new_scalar_draws_what_a_fresh_renderer_draws() {
    let (p, t, s0) = grid_mesh(6, 0.3, [0.0; 3], 9, wave);
    let s1: Vec<f64> = p.iter().map(|&q| 1.0 - wave([q[1], q[2], q[0]])).collect();
    let shading = Shading { light: Some(tet_render::Light::default()), silhouette: None, ..Default::default() };
    for kind in [CpuRenderer::Walk, CpuRenderer::Pt] {
        for (cull, light) in [(false, false), (true, false), (true, true)] {
            let setup = |scalar: &[f64]| {
                let mut scene = Scene::new(&p, t.clone(), scalar.to_vec()).unwrap();
                if light {
                    scene = scene.ensure_gradients().unwrap();
                }
                let mut r = Renderer::new(scene);
                r.set_renderer(kind);
                r.set_view(&view()).unwrap();
                r.set_shader(Arc::new(ExactShader::new(tf(SPARSE))));
                if cull {
                    r.set_culler(Some(Arc::new(TfCuller::new(&tf(SPARSE)))));
                }
                r.set_raster_options(RasterOptions {
                    shading: if light { shading } else { Shading::default() },
                    ..Default::default()
                });
                r
            };
            let mut moving = setup(&s0);
            let first = moving.render(&|_, _| {}).unwrap().0;
            moving.set_scalar(s1.clone()).unwrap();
            if light {
                // The gradients went with the old scalar.
                assert!(moving.scene().gradients().is_none());
                let scene = moving.into_scene().ensure_gradients().unwrap();
                moving = Renderer::new(scene);
                moving.set_renderer(kind);
                moving.set_view(&view()).unwrap();
                moving.set_shader(Arc::new(ExactShader::new(tf(SPARSE))));
                moving.set_culler(Some(Arc::new(TfCuller::new(&tf(SPARSE)))));
                moving.set_raster_options(RasterOptions { shading, ..Default::default() });
            }
            let (moved, st) = moving.render(&|_, _| {}).unwrap();
            let fresh = setup(&s1).render(&|_, _| {}).unwrap().0;
            assert_eq!(moved.pixels(), fresh.pixels(), "{kind:?} cull {cull} light {light}");
            assert_ne!(moved.pixels(), first.pixels(), "{kind:?}: the scalar changed the image");
            if cull {
                assert!(st.recomputed_cull, "{kind:?}: a new scalar re-culls");
            }
        }
    }
    let mut r = Renderer::new(Scene::new(&p, t.clone(), s0.clone()).unwrap());
    assert!(r.set_scalar(vec![0.0; 3]).is_err());
    let mut bad = s0.clone();
    bad[4] = f64::NAN;
    assert!(r.set_scalar(bad).unwrap_err().to_string().contains("point 4"));
}
