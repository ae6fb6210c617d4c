//! The ray walker against projected tetrahedra and the exact reference:
//! the same segments (crossings = PT fragments), images as accurate as
//! PT's, re-entry into non-convex meshes, parallel views, thread-count
//! independence, culling, lighting, every method, and bad input.

mod common;

use common::{grid_mesh, tf};
use std::path::{Path, PathBuf};
use std::sync::Arc;
use tet_bundle::{Bundle, BundleMeta};
use tet_io::{read_file, ReadOptions};
use tet_mesh::{build_adjacency, tetrahedralize, ConvertOptions, TetMesh};
use tet_preint::{make_shader, BakeOptions, ExactShader, Method, SegmentShader, TableDomain, TransferFunction};
use tet_render::{
    diff, render_reference, Camera, CpuRenderer, Image, Light, RasterOptions, ReferenceOptions, RenderStats, Renderer,
    Scene, Shading, TfCuller, ViewSpec,
};

fn data(p: &str) -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("../../tests/data").join(p)
}

fn bluntfin_bundle() -> Bundle {
    let opts = ReadOptions { q_path: Some(data("plot3d/bluntfinq.bin")), ..Default::default() };
    let src = read_file(&data("plot3d/bluntfinxyz.bin"), &opts).unwrap();
    let conv = ConvertOptions { scalar: Some("density".into()), ..Default::default() };
    let (mesh, _) = tetrahedralize(&src, &conv, &mut |_| {}).unwrap();
    let adj = build_adjacency(&mesh.points, &mesh.tets).unwrap();
    Bundle::new(mesh, adj, BundleMeta::default())
}

fn sample_tf(lo: f64, hi: f64) -> TransferFunction {
    let text =
        std::fs::read_to_string(Path::new(env!("CARGO_MANIFEST_DIR")).join("../../formats/samples/tf_normalized.json"))
            .unwrap();
    TransferFunction::from_json(&text).unwrap().denormalize(lo, hi).unwrap()
}

fn render(
    scene: &Scene,
    kind: CpuRenderer,
    view: &ViewSpec,
    shader: Arc<dyn SegmentShader>,
    opts: RasterOptions,
) -> (Image, RenderStats) {
    let mut r = Renderer::new(scene.clone());
    r.set_renderer(kind);
    r.set_view(view).unwrap();
    r.set_shader(shader);
    r.set_raster_options(opts);
    r.render(&|_, _| {}).unwrap()
}

fn mesh_of(points: Vec<[f64; 3]>, tets: Vec<[u32; 4]>, scalar: Vec<f64>) -> (TetMesh, tet_mesh::Adjacency) {
    let adj = build_adjacency(&points, &tets).unwrap();
    let mesh = TetMesh { points, tets: tets.into(), scalar_name: "s".into(), scalar, point_fields: Vec::new() };
    (mesh, adj)
}

/// On NASA Blunt Fin (187k tets, a non-convex curvilinear grid) the walker
/// crosses the tets PT rasterizes, gives PT's image and is as accurate
/// against the exact reference.
/// Blunt Fin with the sample TF over its range, table3d baked for it, and
/// its scene.
fn bluntfin_table3d() -> (Bundle, TransferFunction, Arc<dyn SegmentShader>, Scene) {
    let bundle = bluntfin_bundle();
    let s = &bundle.meta.stats;
    let tf = sample_tf(s.scalar_min, s.scalar_max);
    let domain = TableDomain::from_bundle(&bundle).unwrap();
    let shader: Arc<dyn SegmentShader> =
        make_shader(Method::Table3d, &tf, &domain, &BakeOptions::default()).unwrap().into();
    let scene = Scene::from_bundle(&bundle).unwrap();
    (bundle, tf, shader, scene)
}

#[test]
fn bluntfin_walk_matches_pt_segments_and_accuracy() {
    let (bundle, tf, shader, scene) = bluntfin_table3d();
    let (lo, hi) = scene.bounds();
    let view = ViewSpec::framing(lo, hi, [96, 80]).orbit(30.0, 20.0, 1.0);
    // No early termination: every covered (tet, pixel) pair is composited.
    let all = RasterOptions { opaque_alpha: 2.0, ..Default::default() };
    let (walk, ws) = render(&scene, CpuRenderer::Walk, &view, shader.clone(), all);
    let (pt, ps) = render(&scene, CpuRenderer::Pt, &view, shader.clone(), all);
    assert_eq!(ws.renderer, "walk");
    assert_eq!(ps.renderer, "pt");
    assert_eq!(ws.walk_non_manifold + ws.walk_step_limit, 0, "{ws:?}");
    assert!(ws.crossings >= ps.fragments, "walk crossings {} < PT fragments {}", ws.crossings, ps.fragments);
    // Fragments of zero length (slivers) are dropped by each in its own f32.
    let dfrag = ws.fragments.abs_diff(ps.fragments) as f64;
    assert!(dfrag <= 2e-3 * ps.fragments as f64, "walk {} vs PT {} fragments", ws.fragments, ps.fragments);
    let d = diff(&walk, &pt).unwrap();
    assert!(d.rmse < 1e-6 && d.max_abs < 1e-4, "walk vs PT: {d:?}");

    let cam = Camera::new(&view).unwrap();
    let (reference, _) =
        render_reference(&bundle.mesh, &bundle.adjacency, &cam, &tf, &ReferenceOptions::default(), &|_, _| {}).unwrap();
    let (walk_t, _) = render(&scene, CpuRenderer::Walk, &view, shader.clone(), RasterOptions::default());
    let (pt_t, _) = render(&scene, CpuRenderer::Pt, &view, shader, RasterOptions::default());
    let (ew, ep) = (diff(&walk_t, &reference).unwrap(), diff(&pt_t, &reference).unwrap());
    assert!(ew.rmse <= ep.rmse * 1.05 + 1e-7, "walk {ew:?} vs PT {ep:?}");
    assert!(ew.max_abs <= ep.max_abs * 1.2 + 1e-6, "walk {ew:?} vs PT {ep:?}");
}

/// A U-shaped block seen across its arms: every ray through both arms
/// leaves the mesh and re-enters it; the walker's runs do that and the
/// image matches the exact reference.
#[test]
fn rays_leave_and_reenter_a_non_convex_mesh() {
    let (points, tets, scalar) = grid_mesh(6, 0.15, [0.0; 3], 7, |p| 0.3 + 0.5 * p[0] + 0.2 * p[2]);
    // Remove the cells of the middle third in x above y = 0.3.
    let keep: Vec<[u32; 4]> = tets
        .into_iter()
        .filter(|t| {
            let c = t.iter().fold([0.0; 3], |a, &v| {
                let p = points[v as usize];
                [a[0] + p[0] / 4.0, a[1] + p[1] / 4.0, a[2] + p[2] / 4.0]
            });
            !(c[0] > 0.34 && c[0] < 0.66 && c[1] > 0.3)
        })
        .collect();
    let (mesh, adj) = mesh_of(points, keep, scalar);
    let scene = Scene::new(&mesh.points, mesh.tets.clone(), mesh.scalar.clone()).unwrap();
    let tf =
        tf(r#"{"color": [[0, 1, 0.5, 0.2], [1, 0.2, 0.6, 1]], "opacity": [[0, 1.5], [1, 3]], "unit_distance": 1}"#);
    let shader: Arc<dyn SegmentShader> = Arc::new(ExactShader::new(tf.clone()));
    // Looking along x, slightly from above: rays through the upper part cross both arms.
    let view = ViewSpec::framing([0.0; 3], [1.0; 3], [48, 48]).orbit(90.0, 8.0, 1.0);
    for parallel in [false, true] {
        let mut v = view.clone();
        v.parallel = parallel;
        let (walk, ws) = render(&scene, CpuRenderer::Walk, &v, shader.clone(), RasterOptions::default());
        assert_eq!(ws.renderer, "walk");
        assert!(
            ws.walk_runs > ws.walk_front_faces as u64 / 1000 && ws.walk_runs as f64 > 1.2 * count_rays(&walk) as f64,
            "no re-entries: {ws:?}"
        );
        assert_eq!(ws.walk_non_manifold + ws.walk_step_limit, 0);
        let cam = Camera::new(&v).unwrap();
        let (reference, _) =
            render_reference(&mesh, &adj, &cam, &tf, &ReferenceOptions::default(), &|_, _| {}).unwrap();
        let d = diff(&walk, &reference).unwrap();
        assert!(d.max_abs < 2e-5, "parallel {parallel}: walk vs reference {d:?}");
    }
}

fn count_rays(img: &Image) -> usize {
    img.pixels().iter().filter(|p| p[3] > 0.0).count()
}

/// Pixels depend only on their own ray: one thread or two give the same bits.
#[test]
fn same_image_for_any_thread_count() {
    let (points, tets, scalar) = grid_mesh(5, 0.2, [0.0; 3], 3, |p| (p[0] * 5.0).sin() + p[1]);
    let scene = Scene::new(&points, tets, scalar).unwrap();
    let tf =
        tf(r#"{"color": [[-1, 1, 0, 0], [2, 0, 0, 1]], "opacity": [[-1, 0.5], [0.5, 4], [2, 1]], "unit_distance": 1}"#);
    let shader: Arc<dyn SegmentShader> = Arc::new(ExactShader::new(tf));
    let view = ViewSpec::framing([0.0; 3], [1.0; 3], [40, 36]).orbit(20.0, 30.0, 1.2);
    let one = rayon::ThreadPoolBuilder::new().num_threads(1).build().unwrap();
    let two = rayon::ThreadPoolBuilder::new().num_threads(2).build().unwrap();
    let (a, _) = one.install(|| render(&scene, CpuRenderer::Walk, &view, shader.clone(), RasterOptions::default()));
    let (b, _) = two.install(|| render(&scene, CpuRenderer::Walk, &view, shader.clone(), RasterOptions::default()));
    assert_eq!(a.pixels(), b.pixels());
}

/// Every method id renders through the walker as through PT (per-fragment
/// methods give PT's image; pt-linear is shaded per segment by the walker,
/// so it is compared with the exact reference instead), culling changes
/// nothing, and lighting matches PT's.
#[test]
fn every_method_culling_and_lighting() {
    let (points, tets, scalar) = grid_mesh(6, 0.2, [0.0; 3], 11, |p| 0.2 + 0.6 * p[0] * p[1] + 0.2 * p[2]);
    let (mesh, adj) = mesh_of(points, tets, scalar);
    let bundle = Bundle::new(mesh.clone(), adj.clone(), BundleMeta::default());
    let scene = Scene::from_bundle(&bundle).unwrap().ensure_gradients().unwrap();
    // Opacity zero below 0.3: a culling TF; a 2D widget term for the bivariate methods.
    let tf = tf(r#"{"color": [[0, 0.9, 0.3, 0.1], [0.5, 0.2, 0.9, 0.3], [1, 0.1, 0.2, 1]],
        "opacity": [[0, 0], [0.3, 0], [0.45, 3], [0.7, 1], [1, 4]], "unit_distance": 1}"#);
    let domain = TableDomain::from_bundle(&bundle).unwrap();
    let view = ViewSpec::framing([0.0; 3], [1.0; 3], [40, 40]).orbit(35.0, 25.0, 1.1);
    let cam = Camera::new(&view).unwrap();
    let (reference, _) = render_reference(&mesh, &adj, &cam, &tf, &ReferenceOptions::default(), &|_, _| {}).unwrap();
    for m in Method::ALL {
        if m.is_bivariate() {
            continue; // below, with a 2D-widget TF
        }
        let shader: Arc<dyn SegmentShader> = make_shader(m, &tf, &domain, &BakeOptions::default()).unwrap().into();
        let (walk, ws) = render(&scene, CpuRenderer::Walk, &view, shader.clone(), RasterOptions::default());
        assert_eq!(ws.renderer, "walk");
        assert!(walk.pixels().iter().all(|p| p.iter().all(|c| c.is_finite()) && (0.0..=1.0).contains(&p[3])));
        if m == Method::PtLinear {
            let d = diff(&walk, &reference).unwrap();
            assert!(d.rmse < 2e-2, "{m}: {d:?}");
            continue;
        }
        let (pt, _) = render(&scene, CpuRenderer::Pt, &view, shader.clone(), RasterOptions::default());
        let d = diff(&walk, &pt).unwrap();
        assert!(d.max_abs < 2e-4, "{m}: walk vs PT {d:?}");
        // Culling skips lookups; it changes the image only by what the
        // method gave the culled (zero-opacity) segments: nothing for the
        // exact integrator, the table's own error for the approximations
        // (atlas2d's is ~2e-5 there).
        let mut r = Renderer::new(scene.clone());
        r.set_view(&view).unwrap();
        r.set_shader(shader.clone());
        r.set_culler(Some(Arc::new(TfCuller::new(&tf))));
        let (culled, cs) = r.render(&|_, _| {}).unwrap();
        assert!(cs.tets_culled > 0, "{m}: the TF culls nothing");
        assert!(cs.fragments < ws.fragments);
        let d = diff(&culled, &walk).unwrap();
        let tol = if m == Method::Exact { 1e-7 } else { 5e-5 };
        assert!(d.max_abs < tol, "{m}: culled vs not {d:?}");
    }
    let shader: Arc<dyn SegmentShader> =
        make_shader(Method::Table3d, &tf, &domain, &BakeOptions::default()).unwrap().into();
    for shading in [
        Shading { light: Some(Light::default()), silhouette: None, ..Default::default() },
        Shading { light: None, silhouette: Some(2.0), ..Default::default() },
    ] {
        let opts = RasterOptions { shading, ..Default::default() };
        let (walk, _) = render(&scene, CpuRenderer::Walk, &view, shader.clone(), opts);
        let (pt, _) = render(&scene, CpuRenderer::Pt, &view, shader.clone(), opts);
        let d = diff(&walk, &pt).unwrap();
        assert!(d.max_abs < 1e-3 && d.rmse < 1e-4, "{shading:?}: walk vs PT {d:?}");
    }
}

/// Bivariate methods (a 2D widget over scalar × |∇s|) through the walker
/// give PT's image.
#[test]
fn bivariate_methods_match_pt() {
    let (points, tets, scalar) = grid_mesh(5, 0.2, [0.0; 3], 5, |p| (3.0 * p[0]).sin() * p[1] + p[2]);
    let (mesh, adj) = mesh_of(points, tets, scalar);
    let bundle = Bundle::new(mesh, adj, BundleMeta::default());
    let scene = Scene::from_bundle(&bundle).unwrap().ensure_gradients().unwrap();
    let gmax = scene.gradient_magnitudes().unwrap().iter().cloned().fold(0.0, f64::max);
    let (lo, hi) = (scene.scalar_range()[0], scene.scalar_range()[1]);
    let tf = tf(&format!(
        r#"{{"color": [[{lo}, 1, 0.5, 0], [{hi}, 0, 0.5, 1]], "opacity": [[{lo}, 0.5], [{hi}, 1.5]], "unit_distance": 1,
        "widgets": [{{"type": "box", "center": [{c}, {g}], "width": [{ws}, {g}], "color": [0.2, 1, 0.2], "opacity": 3}}]}}"#,
        c = lo + 0.5 * (hi - lo),
        ws = 0.4 * (hi - lo),
        g = 0.6 * gmax
    ));
    let domain = TableDomain::from_bundle(&bundle).unwrap();
    let view = ViewSpec::framing([0.0; 3], [1.0; 3], [32, 32]).orbit(-30.0, 15.0, 1.1);
    for m in [Method::BivExact, Method::BivApprox] {
        let shader: Arc<dyn SegmentShader> = make_shader(m, &tf, &domain, &BakeOptions::default()).unwrap().into();
        let (walk, _) = render(&scene, CpuRenderer::Walk, &view, shader.clone(), RasterOptions::default());
        let (pt, _) = render(&scene, CpuRenderer::Pt, &view, shader, RasterOptions::default());
        let d = diff(&walk, &pt).unwrap();
        assert!(d.max_abs < 2e-4, "{m}: walk vs PT {d:?}");
        assert!(walk.pixels().iter().any(|p| p[1] > p[0] + 1e-3), "{m}: the widget's green shows nowhere");
    }
}

fn inside_view(eye: [f64; 3], look_at: [f64; 3], size: [u32; 2]) -> ViewSpec {
    let mut view = ViewSpec::framing([0.0; 3], [1.0; 3], size);
    view.position = eye;
    view.focal_point = look_at;
    view
}

/// A camera inside the mesh: rays start in the eye's tet (homogeneous
/// walk, segments clipped at the near plane as PT and the reference clip
/// them) — the walker draws it, without holes, as accurately as PT, and
/// the image does not depend on the thread count.
#[test]
fn camera_inside_the_mesh_is_walked_from_the_eyes_tet() {
    let (points, tets, scalar) = grid_mesh(4, 0.1, [0.0; 3], 9, |p| p[0] + 0.5 * p[1] * p[2]);
    let scene = Scene::new(&points, tets.clone(), scalar.clone()).unwrap();
    let tf = tf(r#"{"color": [[0, 1, 1, 1], [1, 1, 0.2, 0]], "opacity": [[0, 1], [1.5, 2]], "unit_distance": 1}"#);
    let shader: Arc<dyn SegmentShader> = Arc::new(ExactShader::new(tf.clone()));
    let mesh = TetMesh { points, tets: tets.into(), scalar_name: "s".into(), scalar, point_fields: Vec::new() };
    let adj = build_adjacency(&mesh.points, &mesh.tets).unwrap();
    let all = RasterOptions { opaque_alpha: 2.0, ..Default::default() };
    // Looking along an axis, obliquely, and back across the whole block.
    for (eye, at) in [
        ([0.5, 0.45, 0.4], [0.5, 0.5, 1.0]),
        ([0.31, 0.62, 0.53], [1.0, 0.1, 0.9]),
        ([0.9, 0.85, 0.2], [-1.0, -1.0, 1.0]),
    ] {
        let view = inside_view(eye, at, [28, 24]);
        let (walk, st) = render(&scene, CpuRenderer::Walk, &view, shader.clone(), all);
        assert_eq!(st.renderer, "walk", "{st:?}");
        assert!(st.walk_fallback.is_none() && st.walk_near_clipped && st.walk_eye_inside, "{st:?}");
        assert_eq!(st.walk_non_manifold + st.walk_step_limit, 0, "{st:?}");
        assert!(walk.pixels().iter().all(|p| p[3] > 0.0), "holes with the eye inside");
        let (pt, ps) = render(&scene, CpuRenderer::Pt, &view, shader.clone(), all);
        assert_eq!(ps.renderer, "pt");
        let d = diff(&walk, &pt).unwrap();
        assert!(d.rmse < 1e-5 && d.max_abs < 1e-3, "eye {eye:?}: walk vs PT {d:?}");
        let cam = Camera::new(&view).unwrap();
        let opts = ReferenceOptions::default();
        let (reference, _) = render_reference(&mesh, &adj, &cam, &tf, &opts, &|_, _| {}).unwrap();
        let (ew, ep) = (diff(&walk, &reference).unwrap(), diff(&pt, &reference).unwrap());
        assert!(ew.rmse <= ep.rmse * 1.05 + 1e-6, "eye {eye:?}: walk {ew:?} vs PT {ep:?}");
        let one = rayon::ThreadPoolBuilder::new().num_threads(1).build().unwrap();
        let (walk1, _) = one.install(|| render(&scene, CpuRenderer::Walk, &view, shader.clone(), all));
        assert_eq!(walk1.pixels(), walk.pixels());
    }
}

/// The eye inside NASA Blunt Fin (a curvilinear grid whose rays leave and
/// re-enter): walked from the eye's tet, as accurate as PT against the
/// exact reference.
#[test]
fn bluntfin_camera_inside_matches_the_reference() {
    let bundle = bluntfin_bundle();
    let s = &bundle.meta.stats;
    let tf = sample_tf(s.scalar_min, s.scalar_max);
    let shader: Arc<dyn SegmentShader> = Arc::new(ExactShader::new(tf.clone()));
    let scene = Scene::from_bundle(&bundle).unwrap();
    let (lo, hi) = scene.bounds();
    // The centroid of a tet a third of the way through the grid, looking at the far corner.
    let t = bundle.mesh.tets[bundle.mesh.tets.len() / 3];
    let eye = t.iter().fold([0.0; 3], |a, &v| {
        let p = bundle.mesh.points[v as usize];
        [a[0] + 0.25 * p[0], a[1] + 0.25 * p[1], a[2] + 0.25 * p[2]]
    });
    let mut view = ViewSpec::framing(lo, hi, [48, 40]);
    view.position = eye;
    view.focal_point = hi;
    view.view_angle = 60.0;
    let (walk, st) = render(&scene, CpuRenderer::Walk, &view, shader.clone(), RasterOptions::default());
    assert_eq!(st.renderer, "walk", "{st:?}");
    assert!(st.walk_near_clipped && st.walk_eye_inside, "{st:?}");
    assert_eq!(st.walk_non_manifold + st.walk_step_limit, 0, "{st:?}");
    let (pt, _) = render(&scene, CpuRenderer::Pt, &view, shader, RasterOptions::default());
    let cam = Camera::new(&view).unwrap();
    let (reference, _) =
        render_reference(&bundle.mesh, &bundle.adjacency, &cam, &tf, &ReferenceOptions::default(), &|_, _| {}).unwrap();
    let (ew, ep) = (diff(&walk, &reference).unwrap(), diff(&pt, &reference).unwrap());
    assert!(ew.rmse <= ep.rmse * 1.05 + 1e-6, "walk {ew:?} vs PT {ep:?}");
    assert!(ew.max_abs <= ep.max_abs * 1.2 + 1e-5, "walk {ew:?} vs PT {ep:?}");
}

/// The near plane cuts the mesh with the eye outside it (beside a face, the
/// mesh reaching behind the camera), or the eye inside a tet the transfer
/// function culls: entries are the faces met in front of the eye only.
#[test]
fn near_plane_cutting_the_mesh_with_the_eye_outside_or_culled() {
    let (points, tets, scalar) = grid_mesh(4, 0.1, [0.0; 3], 5, |p| p[2]);
    let scene = Scene::new(&points, tets, scalar).unwrap();
    let all = RasterOptions { opaque_alpha: 2.0, ..Default::default() };
    // Beside the block, looking along its face: half the image sees it.
    let beside = inside_view([1.02, 0.5, 0.5], [1.02, 0.5, 2.0], [24, 20]);
    // Looking out of a block from inside its empty (culled) top layer.
    let culled_eye = inside_view([0.5, 0.5, 0.95], [0.5, 0.5, 0.0], [24, 20]);
    // Transparent above z = 0.7: the top layer of cells (z ≥ 0.725 with
    // the jitter) is culled when culling is on.
    let ramp = tf(
        r#"{"color": [[0, 0, 1, 0], [1, 1, 0, 1]], "opacity": [[0, 2], [0.7, 1], [0.7001, 0], [1, 0]], "unit_distance": 1}"#,
    );
    let shader: Arc<dyn SegmentShader> = Arc::new(ExactShader::new(ramp.clone()));
    for (name, view) in [("beside", beside), ("culled eye", culled_eye)] {
        for cull in [false, true] {
            let mut r = Renderer::new(scene.clone());
            r.set_view(&view).unwrap();
            r.set_shader(shader.clone());
            r.set_raster_options(all);
            if cull {
                r.set_culler(Some(Arc::new(TfCuller::new(&ramp))));
            }
            let (walk, st) = r.render(&|_, _| {}).unwrap();
            assert_eq!(st.renderer, "walk", "{name}: {st:?}");
            assert!(st.walk_near_clipped && st.walk_fallback.is_none(), "{name}: {st:?}");
            assert_eq!(st.walk_eye_inside, name == "culled eye" && !cull, "{name} (cull {cull}): {st:?}");
            assert_eq!(st.walk_non_manifold + st.walk_step_limit, 0, "{name}: {st:?}");
            let (pt, _) = render(&scene, CpuRenderer::Pt, &view, shader.clone(), all);
            let d = diff(&walk, &pt).unwrap();
            assert!(d.rmse < 1e-5 && d.max_abs < 1e-3, "{name} (cull {cull}): walk vs PT {d:?}");
            assert!(count_rays(&walk) > 0, "{name}: nothing drawn");
        }
    }
}

/// Makes the first interior link of every `every`-th tet one-way (t → nb
/// kept, nb → t removed); how many were cut.
fn cut_links_one_way(adj: &mut tet_mesh::Adjacency, every: usize) -> usize {
    let mut cut = 0;
    for t in (0..adj.neighbors.len()).step_by(every) {
        if let Some(f) = (0..4).find(|&f| adj.neighbors[t][f] != tet_mesh::NO_NEIGHBOR) {
            let nb = adj.neighbors[t][f] as usize;
            let back = adj.neighbors[nb].iter().position(|&m| m as usize == t).unwrap();
            adj.neighbors[nb][back] = tet_mesh::NO_NEIGHBOR;
            cut += 1;
        }
    }
    cut
}

/// A bundle whose adjacency lists a neighbour that does not point back (a
/// corrupted or non-manifold link): the run ends there, is counted, and the
/// image stays finite — no hang, no panic.
#[test]
fn broken_links_end_runs_and_are_counted() {
    let (points, tets, scalar) = grid_mesh(4, 0.0, [0.0; 3], 1, |p| p[1]);
    let (mesh, mut adj) = mesh_of(points, tets, scalar);
    // Cut one direction of a quarter of the interior links.
    let cut = cut_links_one_way(&mut adj, 4);
    assert!(cut > 0);
    let bundle = Bundle::new(mesh, adj, BundleMeta::default());
    let scene = Scene::from_bundle(&bundle).unwrap();
    let shader: Arc<dyn SegmentShader> =
        Arc::new(ExactShader::new(tf(r#"{"color": [[0, 1, 1, 1]], "opacity": [[0, 1], [1, 2]], "unit_distance": 1}"#)));
    let view = ViewSpec::framing([0.0; 3], [1.0; 3], [32, 32]).orbit(25.0, 35.0, 1.0);
    let (img, st) = render(&scene, CpuRenderer::Walk, &view, shader, RasterOptions::default());
    assert_eq!(st.renderer, "walk");
    assert!(st.walk_non_manifold + st.walk_step_limit > 0, "{st:?}");
    assert!(img.pixels().iter().all(|p| p.iter().all(|c| c.is_finite()) && (0.0..=1.0).contains(&p[3])));
}

/// Fuzz finding (fuzz/fuzz_targets/walk.rs): Delaunay tets of a 2-lattice
/// seen exactly edge-on (azimuth 90°, elevation 0°) put pixel centres on
/// projected silhouette edges. The walker decides those by exact
/// predicates with symbolic perturbation, PT by its f64 edge values, so the
/// two may differ there by a whole ray — and only there: every pixel where
/// they differ has its centre within rounding of a projected edge.
#[test]
fn edge_on_lattice_differs_from_pt_only_on_exact_ties() {
    let pts: Vec<[f64; 3]> = vec![
        [0.0, 0.0, 0.0],
        [2.0, 4.0, 0.0],
        [0.0, 2.0, 0.0],
        [2.0, 2.0, 0.0],
        [0.0, 0.0, 2.0],
        [2.0, 0.0, 2.0],
        [0.0, 2.0, 0.0],
        [2.0, 2.0, 2.0],
        [2.0, 2.0, 1.0],
    ];
    let d = tet_delaunay::tetrahedralize_points(&pts, &tet_delaunay::DelaunayOptions::default()).unwrap();
    let scalar: Vec<f64> = (0..pts.len()).map(|i| ((i as u32 * 7 + 3) % 11) as f64 / 10.0).collect();
    let scene = Scene::new(&pts, d.tets.clone(), scalar).unwrap();
    let (lo, hi) = scene.bounds();
    let view = ViewSpec::framing(lo, hi, [16, 19]).orbit(90.0, 0.0, 1.0);
    let shader: Arc<dyn SegmentShader> = Arc::new(ExactShader::new(tf(
        r#"{"color": [[0, 1, 0, 0], [0.5, 0, 1, 0], [1, 0, 0, 1]], "opacity": [[0, 0.5], [0.6, 4], [1, 1]], "unit_distance": 1}"#,
    )));
    let all = RasterOptions { opaque_alpha: 2.0, ..Default::default() };
    let (walk, ws) = render(&scene, CpuRenderer::Walk, &view, shader.clone(), all);
    let (pt, _) = render(&scene, CpuRenderer::Pt, &view, shader, all);
    assert_eq!(ws.renderer, "walk");
    assert_eq!(ws.walk_non_manifold + ws.walk_step_limit, 0);
    let cam = Camera::new(&view).unwrap();
    let px: Vec<glam::DVec3> = pts.iter().map(|&p| cam.project(glam::DVec3::from(p))).collect();
    let near_an_edge = |x: f64, y: f64| {
        d.tets.iter().any(|t| {
            (0..4).any(|i| {
                (i + 1..4).any(|j| {
                    let (a, b) = (px[t[i] as usize], px[t[j] as usize]);
                    let e = (b.x - a.x) * (y - a.y) - (b.y - a.y) * (x - a.x);
                    e.abs() <= 1e-9 * (1.0 + (b.x - a.x).abs() + (b.y - a.y).abs()) * (1.0 + x.abs() + y.abs())
                })
            })
        })
    };
    let mut differing = 0;
    for j in 0..view.size[1] {
        for i in 0..view.size[0] {
            let (a, b) = (walk.pixel(i, j), pt.pixel(i, j));
            if (0..4).any(|c| (a[c] - b[c]).abs() > 1e-4) {
                differing += 1;
                assert!(
                    near_an_edge(i as f64 + 0.5, j as f64 + 0.5),
                    "pixel ({i}, {j}) differs off any edge: {a:?} vs {b:?}"
                );
            }
        }
    }
    assert!(differing > 0, "the finding no longer reproduces: make the fuzz target compare with PT again");
}

/// A walker on a jittered 6³ wave grid with the exact shader of a TF that
/// is invisible below 0.55 (returned, for its culler).
fn wave_renderer(jitter: f64) -> (Renderer, TransferFunction) {
    let wave = |p: [f64; 3]| 0.5 + 0.5 * ((6.0 * p[0]).sin() * (5.0 * p[1]).cos() * (4.0 * p[2] + 1.0).sin());
    let (p, t, s) = grid_mesh(6, jitter, [0.0; 3], 5, wave);
    let sparse = tf(
        r#"{"color": [[0, 0.2, 0.4, 1], [1, 1, 0, 0]], "opacity": [[0, 0], [0.55, 0], [0.8, 4], [1, 1]], "unit_distance": 0.5}"#,
    );
    let mut r = Renderer::new(Scene::new(&p, t, s).unwrap());
    r.set_view(&ViewSpec::framing([0.0; 3], [1.0; 3], [96, 80]).orbit(25.0, 30.0, 1.3)).unwrap();
    r.set_shader(Arc::new(ExactShader::new(sparse.clone())));
    (r, sparse)
}

/// A grid whose points are jittered by up to 0.3 cells folds: some
/// adjacent tets overlap (both positive, on the same side of their shared
/// face). A ray through a fold finds no exit (the signs are consistent,
/// the mesh is not): that run ends, is counted, the ray goes on from its
/// next entry, and every pixel stays finite. With a TF that culls the fold
/// away the walker never meets it (culled tets are never entered).
#[test]
fn folded_mesh_missing_exits_are_counted_not_hung() {
    let (mut r, sparse) = wave_renderer(0.3);
    let (full, a) = r.render(&|_, _| {}).unwrap();
    assert!(a.walk_step_limit > 0, "the fold is no longer met: {a:?}");
    assert!(full.pixels().iter().all(|p| p.iter().all(|c| c.is_finite()) && (0.0..=1.0).contains(&p[3])));
    r.set_culler(Some(Arc::new(TfCuller::new(&sparse))));
    let (_, b) = r.render(&|_, _| {}).unwrap();
    assert_eq!(b.walk_step_limit + b.walk_non_manifold, 0, "{b:?}");
    assert!(b.crossings < a.crossings && b.walk_runs > a.walk_runs, "culled tets entered: {a:?} {b:?}");
}

/// On a mesh without folds, culling changes the walker's image only by
/// rounding: the runs enter the visible tets through their boundary faces
/// (the entry point computed on the entry face instead of as the exit of a
/// culled tet), and culled tets are zero-opacity.
#[test]
fn culling_changes_the_walkers_image_only_by_rounding() {
    let (mut r, sparse) = wave_renderer(0.15);
    let (full, a) = r.render(&|_, _| {}).unwrap();
    r.set_culler(Some(Arc::new(TfCuller::new(&sparse))));
    let (culled, b) = r.render(&|_, _| {}).unwrap();
    assert_eq!(a.walk_step_limit + a.walk_non_manifold + b.walk_step_limit + b.walk_non_manifold, 0);
    assert!(b.tets_culled > 0 && b.crossings < a.crossings && b.walk_runs > a.walk_runs, "{a:?} {b:?}");
    let d = diff(&full, &culled).unwrap();
    assert!(d.max_abs < 1e-5, "culled vs not: {d:?}");
    assert!(full.pixels().iter().any(|p| p[3] > 0.1));
}

/// Walking several rays at once (one step each in turn) gives the same bits
/// as one at a time, and so does walking without prefetching the next
/// step's records: outside and inside views, culling, lighting, a bivariate
/// method, early termination.
#[test]
fn interleaved_rays_and_prefetch_give_the_same_image() {
    let (points, tets, scalar) = grid_mesh(5, 0.2, [0.0; 3], 13, |p| 0.2 + 0.6 * p[0] * p[1] + 0.2 * p[2]);
    let (mesh, adj) = mesh_of(points, tets, scalar);
    let bundle = Bundle::new(mesh, adj, BundleMeta::default());
    let scene = Scene::from_bundle(&bundle).unwrap().ensure_gradients().unwrap();
    let tf = tf(r#"{"color": [[0, 0.9, 0.3, 0.1], [0.5, 0.2, 0.9, 0.3], [1, 0.1, 0.2, 1]],
        "opacity": [[0, 0], [0.3, 0], [0.45, 30], [0.7, 1], [1, 4]], "unit_distance": 1}"#);
    let domain = TableDomain::from_bundle(&bundle).unwrap();
    let outside = ViewSpec::framing([0.0; 3], [1.0; 3], [36, 30]).orbit(35.0, 25.0, 1.1);
    let inside = inside_view([0.41, 0.52, 0.47], [1.0, 0.2, 0.9], [36, 30]);
    let lit = Shading { light: Some(Light::default()), silhouette: None, ..Default::default() };
    for view in [outside, inside] {
        for m in [Method::Table3d, Method::Exact, Method::BivApprox] {
            let shader: Arc<dyn SegmentShader> = make_shader(m, &tf, &domain, &BakeOptions::default()).unwrap().into();
            for (shading, cull) in [(Shading::default(), false), (lit, true)] {
                let image_with = |lanes: usize, walk_prefetch: bool| {
                    let mut r = Renderer::new(scene.clone());
                    r.set_view(&view).unwrap();
                    r.set_shader(shader.clone());
                    r.set_raster_options(RasterOptions {
                        shading,
                        walk_interleave: Some(lanes),
                        walk_prefetch,
                        // The scalar walk's interleaving (the packet walk's
                        // own test is below).
                        walk_packets: false,
                        ..Default::default()
                    });
                    if cull {
                        r.set_culler(Some(Arc::new(TfCuller::new(&tf))));
                    }
                    r.render(&|_, _| {}).unwrap()
                };
                let image = |lanes: usize| image_with(lanes, true);
                let (one, s1) = image(1);
                assert_eq!(s1.renderer, "walk");
                let (plain, s0) = image_with(1, false);
                assert_eq!(one.pixels(), plain.pixels(), "{m}, no prefetch, cull {cull}");
                assert_eq!((s1.crossings, s1.fragments, s1.walk_runs), (s0.crossings, s0.fragments, s0.walk_runs));
                for lanes in [2, 4, 7] {
                    let (many, sn) = image(lanes);
                    assert_eq!(one.pixels(), many.pixels(), "{m}, {lanes} lanes, cull {cull}");
                    assert_eq!((s1.crossings, s1.fragments, s1.walk_runs), (sn.crossings, sn.fragments, sn.walk_runs));
                }
            }
        }
    }
}

/// Renders `view` twice, by the packet walk and by the scalar walk, and
/// checks they agree: the same bits, the same fragments; with no early
/// termination (`opaque_alpha` > 1) every walk count too. Returns the
/// packet walk's stats.
fn packets_agree(
    scene: &Scene,
    view: &ViewSpec,
    shader: &Arc<dyn SegmentShader>,
    culler: Option<&TransferFunction>,
    opts: RasterOptions,
    what: &str,
) -> RenderStats {
    let run = |walk_packets: bool| {
        let mut r = Renderer::new(scene.clone());
        r.set_view(view).unwrap();
        r.set_shader(shader.clone());
        r.set_raster_options(RasterOptions { walk_packets, ..opts });
        if let Some(tf) = culler {
            r.set_culler(Some(Arc::new(TfCuller::new(tf))));
        }
        r.render(&|_, _| {}).unwrap()
    };
    let ((packet, sp), (scalar, ss)) = (run(true), run(false));
    assert_eq!(sp.renderer, "walk", "{what}");
    assert_eq!(ss.walk_packet_rays, 0, "{what}");
    assert!(packet.pixels() == scalar.pixels(), "{what}: the packet walk's image differs");
    assert_eq!(sp.fragments, ss.fragments, "{what}");
    assert_eq!(sp.walk_rays, ss.walk_rays, "{what}");
    assert_eq!(sp.walk_rays_interpolated, ss.walk_rays_interpolated, "{what}");
    if opts.opaque_alpha > 1.0 {
        let counts = |s: &RenderStats| {
            (s.crossings, s.walk_runs, s.walk_exact_tests, s.walk_non_manifold, s.walk_step_limit, s.walk_terminated)
        };
        assert_eq!(counts(&sp), counts(&ss), "{what}");
    }
    sp
}

/// The packet walk (eight rays a step in AVX2 lanes, where the CPU has
/// them) gives the scalar walk's image bit for bit: Blunt Fin (non-convex,
/// real data) in perspective and parallel, with and without culling and
/// early termination, exact and table methods; a folded mesh (missing
/// exits), one with broken links, and views it leaves to the scalar walk
/// (lighting, a bivariate method, the near plane cutting the mesh).
#[test]
fn packet_walk_gives_the_scalar_walks_image() {
    let simd = cfg!(target_arch = "x86_64") && std::is_x86_feature_detected!("avx2");
    let (bundle, tf, table, scene) = bluntfin_table3d();
    let exact: Arc<dyn SegmentShader> = Arc::new(ExactShader::new(tf.clone()));
    let (lo, hi) = scene.bounds();
    let mut n_packet = 0;
    for parallel in [false, true] {
        let mut view = ViewSpec::framing(lo, hi, [72, 60]).orbit(30.0, 20.0, 1.0);
        view.parallel = parallel;
        for (name, shader) in [("table3d", &table), ("exact", &exact)] {
            for cull in [false, true] {
                for opaque_alpha in [0.9999, 2.0, 0.3] {
                    let what = format!("Blunt Fin, {name}, parallel {parallel}, cull {cull}, opaque {opaque_alpha}");
                    let opts = RasterOptions { opaque_alpha, ..Default::default() };
                    let st = packets_agree(&scene, &view, shader, cull.then_some(&tf), opts, &what);
                    assert_eq!(st.walk_packet_rays, if simd { st.walk_rays } else { 0 }, "{what}");
                    n_packet += st.walk_packet_rays;
                }
            }
        }
    }
    assert!(!simd || n_packet > 0);
    // Adaptive sampling: each level's rays walked by packets, the same
    // rays walked and interpolated and the same image.
    let view = ViewSpec::framing(lo, hi, [72, 60]).orbit(30.0, 20.0, 1.0);
    for tol in [0.004f32, 0.05] {
        for opaque_alpha in [0.9999, 2.0] {
            let what = format!("Blunt Fin, adaptive {tol}, opaque {opaque_alpha}");
            let opts = RasterOptions { walk_adaptive: Some(tol), opaque_alpha, ..Default::default() };
            let st = packets_agree(&scene, &view, &table, None, opts, &what);
            // (At this size only the loose tolerance finds smooth blocks.)
            assert!(tol < 0.01 || st.walk_rays_interpolated > 0, "{what}: {st:?}");
            assert_eq!(st.walk_packet_rays, if simd { st.walk_rays } else { 0 }, "{what}");
        }
    }
    // A folded mesh: runs without an exit, counted alike.
    let (r, sparse) = wave_renderer(0.3);
    let fold = r.scene().clone();
    let view = ViewSpec::framing([0.0; 3], [1.0; 3], [96, 80]).orbit(25.0, 30.0, 1.3);
    let sh: Arc<dyn SegmentShader> = Arc::new(ExactShader::new(sparse.clone()));
    let all = RasterOptions { opaque_alpha: 2.0, ..Default::default() };
    let st = packets_agree(&fold, &view, &sh, None, all, "folded mesh");
    assert!(st.walk_step_limit > 0, "{st:?}");
    packets_agree(&fold, &view, &sh, Some(&sparse), all, "folded mesh, culled");
    // Broken links: runs ended and counted alike.
    let (points, tets, scalar) = grid_mesh(4, 0.0, [0.0; 3], 1, |p| p[1]);
    let (mesh, mut adj) = mesh_of(points, tets, scalar);
    cut_links_one_way(&mut adj, 3);
    let broken = Scene::from_bundle(&Bundle::new(mesh, adj, BundleMeta::default())).unwrap();
    let view = ViewSpec::framing([0.0; 3], [1.0; 3], [32, 32]).orbit(25.0, 35.0, 1.0);
    let st = packets_agree(&broken, &view, &sh, None, all, "broken links");
    assert!(st.walk_non_manifold > 0, "{st:?}");
    // What the packet walk leaves to the scalar walk: lighting and the
    // bivariate methods.
    let lit = Shading { light: Some(Light::default()), silhouette: None, ..Default::default() };
    let scene_g = scene.clone().ensure_gradients().unwrap();
    let view = ViewSpec::framing(lo, hi, [48, 40]).orbit(30.0, 20.0, 1.0);
    let st = packets_agree(&scene_g, &view, &table, None, RasterOptions { shading: lit, ..Default::default() }, "lit");
    assert_eq!(st.walk_packet_rays, 0);
    let domain = TableDomain::from_bundle(&bundle).unwrap();
    let biv: Arc<dyn SegmentShader> =
        make_shader(Method::BivApprox, &tf, &domain, &BakeOptions::default()).unwrap().into();
    let st = packets_agree(&scene_g, &view, &biv, None, RasterOptions::default(), "bivariate");
    assert_eq!(st.walk_packet_rays, 0);
    // The eye inside the mesh (homogeneous coordinates, segments cut at
    // the near plane): packets too, table and exact, culled or not, with
    // and without early termination.
    for (centre, to) in
        [([0.5, 0.5, 0.5], hi), ([0.3, 0.6, 0.4], lo), ([0.7, 0.2, 0.5], lerp3(lo, hi, [0.0, 1.0, 0.5]))]
    {
        let inside = inside_view(lerp3(lo, hi, centre), to, [48, 40]);
        for (name, shader) in [("table3d", &table), ("exact", &exact)] {
            for cull in [false, true] {
                for opaque_alpha in [0.9999, 2.0] {
                    let what = format!("inside at {centre:?}, {name}, cull {cull}, opaque {opaque_alpha}");
                    // Adaptive sampling too, on the last eye's views.
                    let walk_adaptive = (centre[0] > 0.6 && !cull).then_some(0.05);
                    let opts = RasterOptions { opaque_alpha, walk_adaptive, ..Default::default() };
                    let st = packets_agree(&scene, &inside, shader, cull.then_some(&tf), opts, &what);
                    assert!(st.walk_near_clipped, "{what}: {st:?}");
                    assert_eq!(st.walk_packet_rays, if simd { st.walk_rays } else { 0 }, "{what}");
                }
            }
        }
    }
}

fn lerp3(a: [f64; 3], b: [f64; 3], t: [f64; 3]) -> [f64; 3] {
    std::array::from_fn(|k| a[k] + t[k] * (b[k] - a[k]))
}

/// The eye's tet walked to from the previous view's is the one the scan
/// of every tet finds: a camera moving inside Blunt Fin (and once out of
/// it and back), drawn by one renderer whose views each recycle the last
/// and by a fresh renderer a view, gives the same images and the same
/// near-clipped state.
#[test]
fn the_eye_walked_to_from_the_last_view_is_the_scans() {
    let (_, _, shader, scene) = bluntfin_table3d();
    let (lo, hi) = scene.bounds();
    let mut moving = Renderer::new(scene.clone());
    moving.set_shader(shader.clone());
    let mut inside = 0;
    for i in 0..9 {
        let t = i as f64 / 8.0;
        // View 4 stands outside the mesh's box: the next walks from nothing.
        let eye =
            if i == 4 { lerp3(lo, hi, [0.5, 0.5, -0.5]) } else { lerp3(lo, hi, [0.2 + 0.5 * t, 0.5, 0.3 + 0.3 * t]) };
        let view = inside_view(eye, lerp3(lo, hi, [0.9, 0.8 - 0.6 * t, 0.95]), [40, 32]);
        moving.set_view(&view).unwrap();
        let (a, sa) = moving.render(&|_, _| {}).unwrap();
        let mut fresh = Renderer::new(scene.clone());
        fresh.set_shader(shader.clone());
        fresh.set_view(&view).unwrap();
        let (b, sb) = fresh.render(&|_, _| {}).unwrap();
        assert!(a.pixels() == b.pixels(), "view {i}: the images differ");
        assert_eq!((sa.walk_near_clipped, sa.walk_eye_inside), (sb.walk_near_clipped, sb.walk_eye_inside), "view {i}");
        assert_eq!(
            (sa.renderer.as_str(), sa.walk_fallback.as_deref()),
            (sb.renderer.as_str(), sb.walk_fallback.as_deref())
        );
        inside += sa.walk_eye_inside as usize;
    }
    assert!(inside >= 6, "{inside} views with the eye inside");
}

/// The eye exactly on a face's plane inside the mesh (a grid plane through
/// it): no tet holds it strictly, so that view is drawn by PT and the stats
/// say why; the image has no holes.
#[test]
fn eye_on_a_face_plane_is_drawn_by_pt_and_reported() {
    let (points, tets, scalar) = grid_mesh(4, 0.0, [0.0; 3], 3, |p| p[0]);
    let scene = Scene::new(&points, tets, scalar).unwrap();
    let shader: Arc<dyn SegmentShader> =
        Arc::new(ExactShader::new(tf(r#"{"color": [[0, 1, 1, 1]], "opacity": [[0, 1], [1, 2]], "unit_distance": 1}"#)));
    let view = inside_view([0.5, 0.5, 0.5], [0.61, 0.37, 1.0], [20, 16]);
    let (img, st) = render(&scene, CpuRenderer::Walk, &view, shader.clone(), RasterOptions::default());
    assert_eq!(st.renderer, "pt", "{st:?}");
    assert!(st.walk_fallback.as_deref().is_some_and(|w| w.contains("plane of a face")), "{st:?}");
    let (pt, _) = render(&scene, CpuRenderer::Pt, &view, shader, RasterOptions::default());
    assert_eq!(img.pixels(), pt.pixels());
    assert!(img.pixels().iter().all(|p| p[3] > 0.0), "holes with the eye inside");
}

/// Adaptive image-space sampling on Blunt Fin: the same coverage as the
/// full walk (silhouettes walked exactly), every covered pixel either
/// walked or interpolated, fewer crossings, close to the full image at a
/// small tolerance, one image for any thread count, and `None` (the
/// default) unchanged.
#[test]
fn adaptive_sampling_keeps_coverage_and_stays_close() {
    let (_, _, shader, scene) = bluntfin_table3d();
    let (lo, hi) = scene.bounds();
    let view = ViewSpec::framing(lo, hi, [160, 128]).orbit(30.0, 20.0, 1.0);
    let (full, fs) = render(&scene, CpuRenderer::Walk, &view, shader.clone(), RasterOptions::default());
    assert_eq!(fs.walk_rays_interpolated, 0);
    for tol in [0.002f32, 0.016] {
        let opts = RasterOptions { walk_adaptive: Some(tol), ..Default::default() };
        let (ad, st) = render(&scene, CpuRenderer::Walk, &view, shader.clone(), opts);
        assert_eq!(st.walk_rays + st.walk_rays_interpolated, fs.walk_rays, "tol {tol}");
        assert!(st.walk_rays_interpolated > 0 && st.crossings < fs.crossings, "tol {tol}: {st:?}");
        let covered = |img: &Image| img.pixels().iter().map(|p| p[3] > 0.0).collect::<Vec<_>>();
        assert_eq!(covered(&ad), covered(&full), "tol {tol}: coverage");
        let d = diff(&ad, &full).unwrap();
        // Measured 2026-12-05: tol 0.002 RMSE ~1e-5, tol 0.016 ~1e-4; the
        // bounds leave room for table rounding, not for a lost feature.
        let (rmse, max) = if tol < 0.01 { (5e-5, 0.01) } else { (5e-4, 0.05) };
        assert!(d.rmse < rmse && d.max_abs < max, "tol {tol}: {d:?}");
        let one = rayon::ThreadPoolBuilder::new().num_threads(1).build().unwrap();
        let (ad1, _) = one.install(|| render(&scene, CpuRenderer::Walk, &view, shader.clone(), opts));
        assert_eq!(ad1.pixels(), ad.pixels(), "tol {tol}: thread count");
    }
}

/// A scene that takes its bundle (the one-shot `tetview render`, which then
/// holds a large mesh's arrays once) is the scene a borrowed bundle gives:
/// same arrays, same gradients, the same image.
#[test]
fn a_scene_taking_its_bundle_equals_one_borrowing_it() {
    let b = bluntfin_bundle();
    let an = tet_analysis::Analyzer::from_mesh(&b.mesh).unwrap();
    let opts = tet_analysis::AnalysisOptions {
        gradients: Some(tet_analysis::GradientMethod::LeastSquares),
        ..Default::default()
    };
    let analysis = an.analyze(&opts).unwrap();
    let b = b.clone().with_analysis(analysis);
    let borrowed = Scene::from_bundle(&b).unwrap();
    let taken = Scene::from_bundle_owned(b.clone()).unwrap();
    assert_eq!(taken.tets(), borrowed.tets());
    assert_eq!(taken.neighbors(), borrowed.neighbors());
    assert_eq!(taken.positions_rel(), borrowed.positions_rel());
    assert_eq!(taken.scalar(), borrowed.scalar());
    assert!(taken.gradients().is_some());
    assert_eq!(taken.gradients(), borrowed.gradients());
    assert_eq!(taken.bounds(), borrowed.bounds());
}
