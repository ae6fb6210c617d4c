//! The 2D-table methods on the GPU (poly1/2/4, partial, atlas2d) and the
//! bivariate ones (biv-approx, biv-exact) against tet_preint's CPU shaders — per segment through `GpuShader::probe`, and
//! per image against tet_render's CPU renderer with the same MPVO order —
//! and culling with compaction on the GPU against tet_render's `TfCuller`.
//! Skip with a printed reason where no adapter exists (fail instead with
//! TETKIT_REQUIRE_GPU=1); on this kind of machine they run on lavapipe.

mod common;

use common::{
    assert_close_images, cpu_image_and_order, cpu_pt_renderer, gpu, gpu_and_cpu_pt_images, gpu_with_scene, grid, tf,
    Mesh,
};
use std::sync::Arc;
use tet_gpu::{FrameOptions, GpuContext, GpuCull, GpuOrder, GpuRenderer, GpuScene, GpuShader, RasterPath};
use tet_preint::{
    BakeOptions, Baked, Emission, Method, PsiParams, ScalarAxis, Segment, SegmentShader, Table3dParams, TableDomain,
    TransferFunction,
};
use tet_render::cull::cull;
use tet_render::{diff, Camera, TfCuller, ViewSpec};

/// A 1D part plus 2D widgets over (s, |∇s|) (the grid's |∇s| is about 0–4):
/// a Gaussian, a clipped box and clipped triangle bands.
fn tf_with_widgets(emission: &str) -> TransferFunction {
    TransferFunction::from_json(&format!(
        r#"{{"color": [[0, 0.1, 0.2, 1], [1, 1, 0.1, 0.1]], "opacity": [[0, 0.2], [1, 1]], "unit_distance": 1,
            "emission": "{emission}",
            "widgets": [
              {{"type": "gaussian", "center": [0.5, 1.5], "width": [0.1, 0.8], "color": [1, 0.9, 0.2], "opacity": 6}},
              {{"type": "box", "center": [0.3, 2.2], "width": [0.13, 1.7], "color": [0.1, 1, 0.3], "opacity": 3}},
              {{"type": "triangle", "frequency": 7.3, "phase": 0.2, "color": [0.8, 0.2, 1], "opacity": 2,
                "clip": [[0.55, 0.95], [0.3, 3.1]]}}
            ]}}"#
    ))
    .unwrap()
}

/// Zero opacity below 0.3 and above 0.7: cells whose range lies there are culled.
fn tf_with_gaps() -> TransferFunction {
    TransferFunction::from_json(
        r#"{"color": [[0, 0.1, 0.2, 1], [0.5, 1, 0.8, 0.1], [1, 1, 0.1, 0.1]],
            "opacity": [[0, 0], [0.3, 0], [0.45, 6], [0.55, 2], [0.7, 0], [1, 0]], "unit_distance": 1}"#,
    )
    .unwrap()
}

fn domain(mesh: &Mesh) -> TableDomain {
    let (max_ds, len) = mesh.cell_limits();
    TableDomain::new(0.0, 1.0, max_ds, len).unwrap()
}

/// Small tables (the tests compare GPU and CPU lookups of the same table,
/// not the tables' accuracy).
fn opts() -> BakeOptions {
    BakeOptions {
        table3d: Table3dParams { n_s: 32, n_l: 32, s_axis: ScalarAxis::TfNodes, ..Default::default() },
        psi: PsiParams { res: 256, ..Default::default() },
        poly_res: 64,
        // The GPU samples the table as baked (no splits at TF nodes, no
        // exact intervals): the CPU side of every comparison uses the same.
        certify: tet_preint::certify::CertifyOptions::off(),
        ..Default::default()
    }
}

fn bake(method: Method, tf: &TransferFunction, mesh: &Mesh) -> Baked {
    Baked::build(method, tf, &domain(mesh), &opts()).unwrap()
}

/// (name, baked) for every 2D-table method, with poly2 and partial also
/// under independent emission and poly2 as a full square (no band).
fn methods(mesh: &Mesh) -> Vec<(String, Baked)> {
    let mut out: Vec<(String, Baked)> = [Method::Poly1, Method::Poly2, Method::Poly4, Method::Partial, Method::Atlas2d]
        .into_iter()
        .map(|m| (m.id().to_string(), bake(m, &tf(), mesh)))
        .collect();
    out.push(("poly2 independent".into(), bake(Method::Poly2, &tf().with_emission(Emission::Independent), mesh)));
    out.push(("partial independent".into(), bake(Method::Partial, &tf().with_emission(Emission::Independent), mesh)));
    // Rates far above 8: the GPU's quadrature against the CPU's closed form.
    let dense = TransferFunction::from_json(
        r#"{"color": [[0, 0.1, 0.2, 1], [0.5, 1, 0.8, 0.1], [1, 1, 0.1, 0.1]],
            "opacity": [[0, 0.5], [0.4, 400], [0.5, 3], [0.6, 2000], [1, 30]], "unit_distance": 1,
            "emission": "independent"}"#,
    )
    .unwrap();
    out.push(("partial independent dense".into(), bake(Method::Partial, &dense, mesh)));
    let full =
        Baked::build(Method::Poly2, &tf(), &TableDomain::full(0.0, 1.0, domain(mesh).len_max_world).unwrap(), &opts())
            .unwrap();
    out.push(("poly2 full square".into(), full));
    out
}

/// The bivariate image tests' two views of a mesh with bounds (lo, hi).
fn two_orbits(lo: [f64; 3], hi: [f64; 3]) -> [(&'static str, ViewSpec); 2] {
    [
        ("az 30 el 20", ViewSpec::framing(lo, hi, [96, 80]).orbit(30.0, 20.0, 1.0)),
        ("az -120 el -35", ViewSpec::framing(lo, hi, [80, 72]).orbit(-120.0, -35.0, 1.3)),
    ]
}

/// Per segment: the GPU's per-fragment function (GpuShader::probe) against
/// the CPU shader's `shade` on random and degenerate (Sf, Sb, l), in and
/// out of the tables' domain.
#[test]
fn probe_matches_the_cpu_shaders() {
    let Some(ctx) = gpu() else { return };
    let mesh = grid(4);
    let len = domain(&mesh).len_max_world as f32;
    let mut rng = tet_mesh::SplitMix64(0x7e7);
    let mut triples: Vec<[f32; 3]> = (0..20_000)
        .map(|_| {
            let sf = rng.next_f64() as f32 * 1.2 - 0.1;
            let sb =
                if rng.next_f64() < 0.5 { sf + (rng.next_f64() as f32 - 0.5) * 0.3 } else { rng.next_f64() as f32 };
            [sf, sb, rng.next_f64() as f32 * 1.3 * len]
        })
        .collect();
    for s in [0.0f32, 0.3, 0.4, 0.5, 0.77, 1.0] {
        for l in [0.0, 1e-6, 1e-3, 0.1, len, 10.0 * len] {
            triples.push([s, s, l]);
            triples.push([s, (s + 0.05).min(1.0), l]);
            triples.push([s, (s - 0.05).max(0.0), l]);
        }
    }
    for (name, baked) in methods(&mesh) {
        let gpu_shader = GpuShader::from_baked(&ctx, &baked).unwrap();
        assert_eq!(gpu_shader.method_id(), baked.method().id());
        let got = gpu_shader.probe(&ctx, &triples).unwrap();
        let cpu = baked.shader();
        let mut worst = (0.0f32, [0.0f32; 3]);
        for (t, g) in triples.iter().zip(&got) {
            let want = cpu.shade(&Segment { s_front: t[0], s_back: t[1], len_world: t[2], ..Default::default() });
            for c in 0..4 {
                assert!(g[c].is_finite(), "{name} {t:?}: {g:?}");
                // Independent emission's C grows like l·κ: relative to max(1, |C|).
                let d = (g[c] - want[c]).abs() / want[c].abs().max(1.0);
                if d > worst.0 {
                    worst = (d, *t);
                }
            }
        }
        eprintln!(
            "{name}: GPU probe vs CPU shade max |Δ| {:.3e} at {:?} ({} triples)",
            worst.0,
            worst.1,
            triples.len()
        );
        // f32 on both sides for poly and atlas2d (same operations; atlas2d
        // normalises in f64 on the CPU); partial accumulates in f64 on the CPU.
        let tol = if name.starts_with("partial") { 2e-5 } else { 5e-6 };
        assert!(worst.0 <= tol, "{name}: {worst:?}");
    }
}

/// Per image: every 2D-table method against tet_render's CPU projected
/// tetrahedra with the same table and the same (MPVO) order.
#[test]
fn methods_match_the_cpu_pt_renderer() {
    let mesh = grid(6);
    let Some((ctx, scene, renderer)) = gpu_with_scene(&mesh) else { return };
    let mut cpu = cpu_pt_renderer(mesh.cpu_scene());
    let shaders: Vec<(String, GpuShader, Arc<dyn SegmentShader>)> = methods(&mesh)
        .into_iter()
        .map(|(name, baked)| {
            let g = GpuShader::from_baked(&ctx, &baked).unwrap();
            (name, g, Arc::from(baked.into_shader()))
        })
        .collect();
    let (lo, hi) = mesh.bounds();
    let mut parallel = ViewSpec::framing(lo, hi, [80, 64]).orbit(20.0, 30.0, 1.0);
    parallel.parallel = true;
    for (view, spec) in
        [("az 30 el 20", ViewSpec::framing(lo, hi, [96, 80]).orbit(30.0, 20.0, 1.0)), ("parallel", parallel)]
    {
        let cam = Camera::new(&spec).unwrap();
        cpu.set_view(&spec).unwrap();
        for (name, gpu_shader, cpu_shader) in &shaders {
            let (got, want, order) =
                gpu_and_cpu_pt_images(&ctx, &renderer, &scene, &cam, &mut cpu, (gpu_shader, cpu_shader));
            assert_close_images(&format!("grid 6³×5 {name} vs CPU PT, {view}"), &got, &want);
            if name == "poly2" {
                // The graphics rasterizer runs the same fragment function.
                let g = renderer
                    .render_with(&ctx, &scene, &cam, GpuOrder::Given(&order), gpu_shader, RasterPath::Graphics)
                    .unwrap()
                    .image;
                assert_close_images(&format!("grid 6³×5 {name} graphics raster vs CPU PT, {view}"), &g, &want);
            }
        }
    }
}

/// A camera inside the mesh: clipped tets shade per fragment with every method.
#[test]
fn methods_shade_clipped_tets() {
    let mesh = grid(4);
    let Some((ctx, scene, renderer)) = gpu_with_scene(&mesh) else { return };
    let spec = ViewSpec {
        view_angle: 60.0,
        ..ViewSpec::looking_at([0.5, 0.45, 0.52], [0.5, 0.45, -1.0], [0.0, 1.0, 0.0], [64, 64])
    };
    let cam = Camera::new(&spec).unwrap();
    for method in [Method::Poly2, Method::Partial, Method::Atlas2d] {
        let baked = bake(method, &tf(), &mesh);
        let shader = GpuShader::from_baked(&ctx, &baked).unwrap();
        let frame = renderer.render(&ctx, &scene, &cam, &mesh.mpvo_order(&cam), &shader).unwrap();
        assert_close_images(
            &format!("grid 4³×5 {method}, camera inside"),
            &frame.image,
            &mesh.reference(&cam, baked.shader()),
        );
        assert!(frame.image.pixel(32, 32)[3] > 0.0);
    }
}

/// GPU culling: the culled count equals tet_render's `TfCuller` over the
/// same order, the image equals the GPU image of the CPU-culled order bit
/// for bit and the unculled image within the tolerance, with a given
/// order, the GPU centroid order and chunked rendering.
#[test]
fn gpu_culling_matches_the_cpu_culler() {
    let Some(ctx) = gpu() else { return };
    let mesh = grid(8);
    let tf = tf_with_gaps();
    let scene = mesh.gpu_scene(&ctx);
    let renderer = GpuRenderer::new(&ctx).unwrap();
    let cpu_scene = mesh.cpu_scene();
    let mask = cull(&cpu_scene, &TfCuller::new(&tf));
    eprintln!("CPU TfCuller: {} of {} tets culled", mask.culled, mesh.tets.len());
    assert!(mask.culled > mesh.tets.len() / 10 && mask.culled < mesh.tets.len());
    let gcull = GpuCull::new(&ctx, &scene, &tf).unwrap();
    assert_eq!(gcull.zero_intervals(), TfCuller::new(&tf).zero_intervals());

    let (lo, hi) = mesh.bounds();
    let spec = ViewSpec::framing(lo, hi, [96, 80]).orbit(-40.0, 25.0, 1.0);
    let cam = Camera::new(&spec).unwrap();
    let order = mesh.mpvo_order(&cam);
    let culled_order: Vec<u32> = order.iter().copied().filter(|&t| mask.visible[t as usize]).collect();
    let mut cpu = cpu_pt_renderer(cpu_scene);
    cpu.set_view(&spec).unwrap();
    cpu.set_culler(Some(Arc::new(TfCuller::new(&tf))));
    for method in [Method::Partial, Method::Table3d] {
        let baked = bake(method, &tf, &mesh);
        let shader = GpuShader::from_baked(&ctx, &baked).unwrap();
        let opts = FrameOptions { raster: RasterPath::Compute, cull: Some(&gcull), ..Default::default() };
        let frame = renderer.render_frame(&ctx, &scene, &cam, GpuOrder::Given(&order), &shader, &opts).unwrap();
        let s = &frame.stats;
        eprintln!(
            "{method}: GPU culled {} of {} ({:.1}%), drawn {}, cull {:.2} ms",
            s.tets_culled,
            order.len(),
            100.0 * s.fraction_culled(),
            s.tets_drawn,
            s.cull_seconds * 1e3
        );
        assert_eq!(s.tets_culled, mask.culled);
        assert_eq!(s.tets_drawn, culled_order.len());
        let filtered = renderer.render(&ctx, &scene, &cam, &culled_order, &shader).unwrap().image;
        let d = diff(&frame.image, &filtered).unwrap();
        assert_eq!(d.max_abs, 0.0, "{method}: GPU compaction vs CPU-filtered order: {d:?}");
        let unculled = renderer.render(&ctx, &scene, &cam, &order, &shader).unwrap().image;
        assert_close_images(&format!("{method}: GPU culled vs unculled"), &frame.image, &unculled);
        cpu.set_shader(Arc::from(baked.into_shader()));
        let (want, st) = cpu.render(&|_, _| {}).unwrap();
        assert_eq!(st.tets_culled, mask.culled);
        assert_close_images(&format!("{method}: GPU culled vs CPU PT culled"), &frame.image, &want);
    }

    // The GPU centroid order compacted, and chunks of 256 slots.
    let shader = GpuShader::from_baked(&ctx, &bake(Method::Partial, &tf, &mesh)).unwrap();
    let opts = FrameOptions { raster: RasterPath::Compute, cull: Some(&gcull), ..Default::default() };
    let plain = renderer
        .render_frame(&ctx, &scene, &cam, GpuOrder::GpuCentroid, &shader, &FrameOptions::default())
        .unwrap()
        .image;
    let frame = renderer.render_frame(&ctx, &scene, &cam, GpuOrder::GpuCentroid, &shader, &opts).unwrap();
    assert_eq!(frame.stats.tets_culled, mask.culled);
    let sorted = renderer.gpu_centroid_order(&ctx, &scene, &cam).unwrap();
    let sorted_visible: Vec<u32> = sorted.into_iter().filter(|&t| mask.visible[t as usize]).collect();
    let want = renderer.render(&ctx, &scene, &cam, &sorted_visible, &shader).unwrap().image;
    assert_eq!(diff(&frame.image, &want).unwrap().max_abs, 0.0);
    assert_close_images("partial GPU centroid order: culled vs unculled", &frame.image, &plain);
    renderer.set_chunk_limits(Some(256), None);
    let chunked = renderer.render_frame(&ctx, &scene, &cam, GpuOrder::Given(&order), &shader, &opts).unwrap();
    assert!(chunked.stats.chunks > 1);
    assert_eq!(chunked.stats.tets_culled, mask.culled);
    let want = renderer.render(&ctx, &scene, &cam, &culled_order, &shader).unwrap().image;
    assert_eq!(diff(&chunked.image, &want).unwrap().max_abs, 0.0);
    renderer.set_chunk_limits(None, None);

    // A TF that culls everything draws nothing; one that culls nothing skips compaction.
    let none =
        TransferFunction::from_json(r#"{"color": [[0, 1, 1, 1]], "opacity": [[0, 0], [1, 0]], "unit_distance": 1}"#)
            .unwrap();
    let all = GpuCull::new(&ctx, &scene, &none).unwrap();
    let f = renderer
        .render_frame(&ctx, &scene, &cam, GpuOrder::Given(&order), &shader, &FrameOptions { cull: Some(&all), ..opts })
        .unwrap();
    assert_eq!(f.stats.tets_culled, mesh.tets.len());
    assert!(f.image.pixels().iter().all(|p| *p == [0.0; 4]));
    let keep = GpuCull::new(&ctx, &scene, &crate::tf()).unwrap();
    assert!(keep.culls_nothing());
    let f = renderer
        .render_frame(&ctx, &scene, &cam, GpuOrder::Given(&order), &shader, &FrameOptions { cull: Some(&keep), ..opts })
        .unwrap();
    assert_eq!((f.stats.tets_culled, f.stats.tets_drawn), (0, order.len()));
}

/// The CPU scene with per-vertex gradients, the GPU scene with the same
/// gradient magnitudes, and those magnitudes: what the bivariate image
/// tests compare.
fn bivariate_scenes(ctx: &GpuContext, mesh: &Mesh) -> (tet_render::Scene, GpuScene, Vec<f64>) {
    let cpu_scene = mesh.cpu_scene().ensure_gradients().unwrap();
    let gm = cpu_scene.gradient_magnitudes().unwrap().to_vec();
    let scene = mesh.gpu_scene(ctx).with_gradient_magnitudes(ctx, &gm).unwrap();
    (cpu_scene, scene, gm)
}

/// biv-approx: per segment (probe with gradient magnitudes) and per image
/// against tet_render's CPU renderer with the scene's per-vertex |∇s|,
/// under both emission models.
#[test]
fn biv_approx_matches_the_cpu() {
    let Some(ctx) = gpu() else { return };
    let mesh = grid(6);
    let (cpu_scene, scene, gm) = bivariate_scenes(&ctx, &mesh);
    let g_max = gm.iter().copied().fold(0.0f64, f64::max);
    eprintln!("|∇s| up to {g_max:.3}");
    let renderer = GpuRenderer::new(&ctx).unwrap();
    let mut cpu = cpu_pt_renderer(cpu_scene);
    let len = domain(&mesh).len_max_world as f32;
    let mut rng = tet_mesh::SplitMix64(0xb1f);
    let segs: Vec<Segment> = (0..20_000)
        .map(|i| {
            let s_front = rng.next_f64() as f32 * 1.2 - 0.1;
            let s_back = if i % 2 == 0 { s_front + (rng.next_f64() as f32 - 0.5) * 0.3 } else { rng.next_f64() as f32 };
            let grad_front = rng.next_f64() as f32 * 4.0;
            let grad_back = if i % 3 == 0 { grad_front } else { rng.next_f64() as f32 * 4.0 };
            let len_world = [0.0, 1e-5, rng.next_f64() as f32 * 1.3 * len][i % 3];
            Segment { s_front, s_back, grad_front, grad_back, len_world }
        })
        .collect();
    let (lo, hi) = mesh.bounds();
    for emission in ["density", "independent"] {
        let tf = tf_with_widgets(emission);
        let baked = bake(Method::BivApprox, &tf, &mesh);
        let shader = GpuShader::from_baked(&ctx, &baked).unwrap();
        assert_eq!(shader.method_id(), "biv-approx");
        let got = shader.probe_segments(&ctx, &segs).unwrap();
        let mut worst = (0.0f32, 0);
        for (i, (seg, g)) in segs.iter().zip(&got).enumerate() {
            let want = baked.shader().shade(seg);
            for c in 0..4 {
                assert!(g[c].is_finite(), "{seg:?}: {g:?}");
                // Independent emission's C grows like l·κ: relative to max(1, |C|).
                let d = (g[c] - want[c]).abs() / want[c].abs().max(1.0);
                if d > worst.0 {
                    worst = (d, i);
                }
            }
        }
        eprintln!("biv-approx {emission}: GPU probe vs CPU shade max |Δ| {:.3e} at {:?}", worst.0, segs[worst.1]);
        assert!(worst.0 <= 2e-5, "{emission}: {worst:?} {:?}", segs[worst.1]);

        let cpu_shader: Arc<dyn SegmentShader> = Arc::from(baked.into_shader());
        cpu.set_shader(cpu_shader);
        for (view, spec) in two_orbits(lo, hi) {
            let cam = Camera::new(&spec).unwrap();
            cpu.set_view(&spec).unwrap();
            let (want, order) = cpu_image_and_order(&mut cpu);
            let got = renderer.render(&ctx, &scene, &cam, &order, &shader).unwrap().image;
            assert_close_images(&format!("grid 6³×5 biv-approx {emission} vs CPU PT, {view}"), &got, &want);
        }
    }
    // Without gradient magnitudes on the scene: an input error.
    let bare = mesh.gpu_scene(&ctx);
    let shader = GpuShader::from_baked(&ctx, &bake(Method::BivApprox, &tf_with_widgets("density"), &mesh)).unwrap();
    let cam = Camera::new(&ViewSpec::framing(lo, hi, [16, 16])).unwrap();
    let err = renderer.render(&ctx, &bare, &cam, &[0], &shader).err().unwrap();
    assert!(err.to_string().contains("gradient magnitudes"), "{err}");
    assert!(mesh.gpu_scene(&ctx).with_gradient_magnitudes(&ctx, &gm[1..]).is_err());
}

/// Culling with 2D widgets (TfCuller's bivariate test): the same culled
/// count as the CPU with and without per-vertex |∇s|, and biv-approx images
/// culled on the GPU against the CPU renderer culled on the CPU.
#[test]
fn gpu_culling_with_widgets_matches_the_cpu_culler() {
    let Some(ctx) = gpu() else { return };
    let mesh = grid(8);
    // The 1D part is invisible outside [0.3, 0.7]; clipped widgets show
    // some of those cells, depending on |∇s| (0 to ~3.7 here).
    let tf = TransferFunction::from_json(
        r#"{"color": [[0, 0.1, 0.2, 1], [1, 1, 0.1, 0.1]],
            "opacity": [[0, 0], [0.3, 0], [0.5, 3], [0.7, 0], [1, 0]], "unit_distance": 1,
            "widgets": [
              {"type": "box", "center": [0.14, 1.2], "width": [0.04, 0.8], "color": [0.1, 1, 0.3], "opacity": 3},
              {"type": "gaussian", "center": [0.82, 2.0], "width": [0.05, 0.5], "color": [1, 0.9, 0.2], "opacity": 6,
               "clip": [[0.8, 0.84], [1.5, 2.5]]},
              {"type": "box", "center": [0.9, 3.0], "width": [0.2, 1.0], "color": [1, 0, 0], "opacity": 0}
            ]}"#,
    )
    .unwrap();
    let bare_cpu = mesh.cpu_scene();
    let cpu_scene = bare_cpu.clone().ensure_gradients().unwrap();
    let gm = cpu_scene.gradient_magnitudes().unwrap().to_vec();
    let culler = TfCuller::new(&tf);
    let (with_g, without_g) = (cull(&cpu_scene, &culler), cull(&bare_cpu, &culler));
    eprintln!("CPU TfCuller with widgets: {} culled with |∇s|, {} without", with_g.culled, without_g.culled);
    assert!(with_g.culled > without_g.culled && without_g.culled > 0);
    let bare = mesh.gpu_scene(&ctx);
    let scene = mesh.gpu_scene(&ctx).with_gradient_magnitudes(&ctx, &gm).unwrap();
    let renderer = GpuRenderer::new(&ctx).unwrap();
    let (lo, hi) = mesh.bounds();
    let spec = ViewSpec::framing(lo, hi, [96, 80]).orbit(50.0, 30.0, 1.0);
    let cam = Camera::new(&spec).unwrap();
    let order = mesh.mpvo_order(&cam);
    let baked = bake(Method::BivApprox, &tf, &mesh);
    let shader = GpuShader::from_baked(&ctx, &baked).unwrap();
    let pt = GpuShader::pt_linear(&ctx, &tf.without_widgets()).unwrap();
    for (what, sc, mask, sh) in [("with |∇s|", &scene, &with_g, &shader), ("without |∇s|", &bare, &without_g, &pt)]
    {
        let gcull = GpuCull::new(&ctx, sc, &tf).unwrap();
        let opts = FrameOptions { raster: RasterPath::Compute, cull: Some(&gcull), ..Default::default() };
        let frame = renderer.render_frame(&ctx, sc, &cam, GpuOrder::Given(&order), sh, &opts).unwrap();
        eprintln!("GPU culling {what}: {} culled", frame.stats.tets_culled);
        assert_eq!(frame.stats.tets_culled, mask.culled, "{what}");
        let kept: Vec<u32> = order.iter().copied().filter(|&t| mask.visible[t as usize]).collect();
        let want = renderer.render(&ctx, sc, &cam, &kept, sh).unwrap().image;
        assert_eq!(diff(&frame.image, &want).unwrap().max_abs, 0.0, "{what}");
    }
    let mut cpu = cpu_pt_renderer(cpu_scene);
    cpu.set_view(&spec).unwrap();
    cpu.set_culler(Some(Arc::new(TfCuller::new(&tf))));
    cpu.set_shader(Arc::from(baked.into_shader()));
    let (want, st) = cpu.render(&|_, _| {}).unwrap();
    assert_eq!(st.tets_culled, with_g.culled);
    let gcull = GpuCull::new(&ctx, &scene, &tf).unwrap();
    let opts = FrameOptions { raster: RasterPath::Compute, cull: Some(&gcull), ..Default::default() };
    let got = renderer.render_frame(&ctx, &scene, &cam, GpuOrder::Given(&order), &shader, &opts).unwrap().image;
    assert_close_images("biv-approx with widgets, culled on the GPU vs CPU PT culled", &got, &want);
}

/// The 2D transfer functions biv-exact is checked with (s ∈ [0, 1], |∇s|
/// about 0–4 on the grid): each widget shape alone over a thin 1D part, a
/// transparent constant-colour 1D part (the CPU's single-widget closed form
/// and, under independent emission, its Song et al. 2009 tables), all four shapes
/// overlapping, the same dense (opacities up to 1000) and bands of very
/// high frequency.
fn biv_exact_tfs(emission: &str) -> Vec<(&'static str, TransferFunction)> {
    let thin = r#""color": [[0, 0.1, 0.2, 1], [0.6, 1, 0.8, 0.1], [1, 1, 0.1, 0.1]], "opacity": [[0, 0.2], [0.5, 1.5], [1, 0.4]]"#;
    let clear = r#""color": [[0, 0.3, 0.6, 0.9]], "opacity": [[0, 0], [1, 0]]"#;
    let gauss =
        r#"{"type": "gaussian", "center": [0.5, 1.5], "width": [0.08, 0.6], "color": [1, 0.9, 0.2], "opacity": 8}"#;
    let gauss_clip = r#"{"type": "gaussian", "center": [0.3, 2.5], "width": [0.2, 0.3], "color": [0.2, 0.9, 1], "opacity": 3,
        "clip": [[0.1, 0.45], [2.0, 3.2]]}"#;
    let bx = r#"{"type": "box", "center": [0.45, 1.8], "width": [0.3, 2.0], "color": [0.1, 1, 0.3], "opacity": 4}"#;
    let tri = r#"{"type": "triangle", "frequency": 7.3, "phase": 0.2, "color": [0.8, 0.2, 1], "opacity": 3,
        "clip": [[0.1, 0.9], [0.3, 3.5]]}"#;
    let sine = r#"{"type": "sine", "frequency": 5.1, "phase": -0.3, "color": [1, 0.4, 0.1], "opacity": 2}"#;
    let dense = r#""color": [[0, 0.1, 0.2, 1], [0.6, 1, 0.8, 0.1], [1, 1, 0.1, 0.1]], "opacity": [[0, 0.5], [0.4, 200], [0.5, 3], [1, 40]]"#;
    let dense_widgets = r#"{"type": "gaussian", "center": [0.5, 1.5], "width": [0.05, 0.4], "color": [1, 0.9, 0.2], "opacity": 1000},
        {"type": "box", "center": [0.3, 2.2], "width": [0.13, 1.7], "color": [0.1, 1, 0.3], "opacity": 300},
        {"type": "sine", "frequency": 3.0, "phase": 0.1, "color": [1, 0.4, 0.1], "opacity": 50, "clip": [[0.6, 1.0], [0.0, 2.5]]}"#;
    let huge = r#"{"type": "sine", "frequency": 1000000, "phase": 0.1, "color": [1, 0.4, 0.1], "opacity": 3, "clip": [[0, 0.5], [0, 10]]},
        {"type": "triangle", "frequency": 100000, "phase": 0.3, "color": [0.2, 0.4, 1], "opacity": 2, "clip": [[0.5, 1], [0, 10]]}"#;
    let tf = |one: &str, widgets: &str| {
        TransferFunction::from_json(&format!(
            r#"{{{one}, "unit_distance": 1, "emission": "{emission}", "widgets": [{widgets}]}}"#
        ))
        .unwrap()
    };
    vec![
        ("box", tf(thin, bx)),
        ("gaussian", tf(thin, &format!("{gauss}, {gauss_clip}"))),
        ("triangle", tf(thin, tri)),
        ("sine", tf(thin, sine)),
        ("box alone", tf(clear, bx)),
        ("gaussian alone", tf(clear, gauss)),
        ("triangle alone", tf(clear, tri)),
        ("sine alone", tf(clear, sine)),
        ("overlapping", tf(thin, &format!("{gauss}, {gauss_clip}, {bx}, {tri}, {sine}"))),
        ("dense", tf(dense, dense_widgets)),
        ("huge frequency", tf(clear, huge)),
    ]
}

/// Random segments in and around the grid's (s, |∇s|, l) ranges — a third
/// with sb = sf, a third with gb = gf, lengths from 0 to 1.3 l_max — and the
/// degenerate ones: l = 0, 1e-7, 1e30, ∞, NaN; NaN and ∞ in s or g; sf = sb
/// with gf = gb.
fn biv_exact_segments(seed: u64, n: usize, len_max: f32) -> Vec<Segment> {
    let mut rng = tet_mesh::SplitMix64(seed);
    let mut segs: Vec<Segment> = (0..n)
        .map(|i| {
            let s_front = rng.next_f64() as f32 * 1.2 - 0.1;
            let s_back = match i % 3 {
                0 => s_front,
                1 => s_front + (rng.next_f64() as f32 - 0.5) * 0.3,
                _ => rng.next_f64() as f32,
            };
            let grad_front = rng.next_f64() as f32 * 4.0;
            let grad_back = if i % 3 == 1 { grad_front } else { rng.next_f64() as f32 * 4.0 };
            let len_world = rng.next_f64() as f32 * 1.3 * len_max;
            Segment { s_front, s_back, grad_front, grad_back, len_world }
        })
        .collect();
    let base = Segment { s_front: 0.45, s_back: 0.55, grad_front: 1.2, grad_back: 1.9, len_world: len_max };
    for len_world in [0.0, -1.0, 1e-7, 1e30, f32::INFINITY, f32::NAN] {
        segs.push(Segment { len_world, ..base });
    }
    for v in [f32::NAN, f32::INFINITY, f32::NEG_INFINITY] {
        segs.push(Segment { s_front: v, ..base });
        segs.push(Segment { s_back: v, ..base });
        segs.push(Segment { grad_front: v, ..base });
        segs.push(Segment { grad_back: v, ..base });
    }
    for s in [0.0f32, 0.3, 0.45, 0.5, 0.77, 1.0] {
        for g in [0.0f32, 1.5, 2.4] {
            segs.push(Segment { s_front: s, s_back: s, grad_front: g, grad_back: g, len_world: 0.7 * len_max });
        }
    }
    segs
}

/// biv-exact: per segment (probe with gradient magnitudes) against
/// tet_preint's f64 `BivExact` for every widget shape, both emission models,
/// overlapping, thin and dense widgets and degenerate segments; per image
/// against tet_render's CPU renderer with the scene's per-vertex |∇s|.
#[test]
fn biv_exact_matches_the_cpu() {
    let Some(ctx) = gpu() else { return };
    let mesh = grid(6);
    let len_max = domain(&mesh).len_max_world as f32;
    let segs = biv_exact_segments(0xb1e, 3000, len_max);
    // Very high band frequencies (sine 1e6, triangle 1e5 per scalar unit):
    // scalar steps ≤ 0.02, where the CPU still splits at every crossing (up
    // to 65 536; beyond, its pieces span many periods and its band tables no
    // longer apply), and every fourth ≤ 5e-5, where the GPU splits too (up
    // to 256; beyond, it integrates the bands' depths over many periods in
    // closed form and the colour by quadrature).
    let huge_segs: Vec<Segment> = biv_exact_segments(0xb1f, 300, len_max)
        .into_iter()
        .enumerate()
        .map(|(i, s)| {
            let reach = if i % 4 == 1 { 5e-5 } else { 0.02 };
            Segment { s_back: s.s_front + (s.s_back - s.s_front).clamp(-reach, reach), ..s }
        })
        .collect();
    let mut worst_all = 0.0f32;
    for emission in ["density", "independent"] {
        for (name, tf) in biv_exact_tfs(emission) {
            let baked = bake(Method::BivExact, &tf, &mesh);
            let shader = GpuShader::from_baked(&ctx, &baked).unwrap();
            assert_eq!(shader.method_id(), "biv-exact");
            let segs = if name == "huge frequency" { &huge_segs } else { &segs };
            let start = std::time::Instant::now();
            let got = shader.probe_segments(&ctx, segs).unwrap();
            let gpu_s = start.elapsed().as_secs_f64();
            let cpu = baked.shader();
            let mut worst = (0.0f32, 0);
            for (i, (seg, g)) in segs.iter().zip(&got).enumerate() {
                // The GPU clamps l to 1e30 as its other methods; the CPU to
                // 1e300, where its quadrature's 200 halvings no longer reach
                // a panel of depth ≤ 0.5 (C comes out ~0): compare l = ∞
                // with the CPU at 1e30, which it resolves.
                let at = if seg.len_world == f32::INFINITY { Segment { len_world: 1e30, ..*seg } } else { *seg };
                let want = cpu.shade(&at);
                for c in 0..4 {
                    assert!(g[c].is_finite() && g[c] >= 0.0, "{name} {emission} {seg:?}: {g:?}");
                    // Independent emission's C grows like l·κ: relative to max(1, |C|).
                    let d = (g[c] - want[c]).abs() / want[c].abs().max(1.0);
                    if d > worst.0 {
                        worst = (d, i);
                    }
                }
                let finite = [seg.s_front, seg.s_back, seg.grad_front, seg.grad_back].iter().all(|v| v.is_finite());
                if !finite || seg.len_world.is_nan() || seg.len_world <= 0.0 {
                    assert_eq!(*g, [0.0; 4], "{name} {emission} {seg:?}");
                }
            }
            eprintln!(
                "biv-exact {name} {emission}: GPU probe vs CPU max |Δ| {:.3e} at {:?} ({} segments, {gpu_s:.2} s)",
                worst.0,
                segs[worst.1],
                segs.len()
            );
            worst_all = worst_all.max(worst.0);
            assert!(worst.0 <= 1e-4, "{name} {emission}: {worst:?} {:?}", segs[worst.1]);
        }
    }
    eprintln!("biv-exact: GPU probe vs CPU max |Δ| over every case {worst_all:.3e}");

    let (cpu_scene, scene, _) = bivariate_scenes(&ctx, &mesh);
    let renderer = GpuRenderer::new(&ctx).unwrap();
    let mut cpu = cpu_pt_renderer(cpu_scene);
    let (lo, hi) = mesh.bounds();
    for emission in ["density", "independent"] {
        for (name, tf) in biv_exact_tfs(emission).into_iter().filter(|(n, _)| ["overlapping", "dense"].contains(n)) {
            let baked = bake(Method::BivExact, &tf, &mesh);
            let shader = GpuShader::from_baked(&ctx, &baked).unwrap();
            cpu.set_shader(Arc::from(baked.into_shader()));
            for (view, spec) in two_orbits(lo, hi) {
                let cam = Camera::new(&spec).unwrap();
                cpu.set_view(&spec).unwrap();
                let (want, order) = cpu_image_and_order(&mut cpu);
                let start = std::time::Instant::now();
                let frame = renderer.render(&ctx, &scene, &cam, &order, &shader).unwrap();
                // llvmpipe's loop-iteration limit sends biv-exact to the
                // graphics rasterizer there (GpuContext::limits_loop_iterations).
                if ctx.describe().contains("llvmpipe") {
                    assert_eq!(frame.stats.raster_path, RasterPath::Graphics);
                }
                let got = frame.image;
                let what = format!("grid 6³×5 biv-exact {name} {emission} vs CPU PT, {view}");
                eprintln!("{what}: GPU frame {:.2} s", start.elapsed().as_secs_f64());
                assert_close_images(&what, &got, &want);
            }
        }
    }
    // Without gradient magnitudes on the scene: an input error, as biv-approx.
    let bare = mesh.gpu_scene(&ctx);
    let shader = GpuShader::from_baked(&ctx, &bake(Method::BivExact, &biv_exact_tfs("density")[0].1, &mesh)).unwrap();
    let cam = Camera::new(&ViewSpec::framing(lo, hi, [16, 16])).unwrap();
    let err = renderer.render(&ctx, &bare, &cam, &[0], &shader).err().unwrap();
    assert!(err.to_string().contains("gradient magnitudes"), "{err}");
}

/// biv-exact's work budget (biv_exact.wgsl's BIV_MAX_WORK): segments with
/// more pieces than the budget pays for — eight unclipped sine bands, each
/// split at its ~60 half-period crossings — end in one piece with frozen
/// coefficients: α stays exact (the bands' depths are closed forms over any
/// interval), C is finite and within the emission's bound, and the probe
/// returns (no fragment loops without bound).
#[test]
fn biv_exact_work_is_bounded() {
    let Some(ctx) = gpu() else { return };
    let mesh = grid(2);
    let widgets: Vec<String> = (0..8)
        .map(|i| {
            format!(
                r#"{{"type": "sine", "frequency": {}, "phase": {}, "color": [{}, 0.5, {}], "opacity": {}}}"#,
                29.0 + 1.3 * i as f64,
                0.1 * i as f64,
                0.1 * i as f64,
                1.0 - 0.1 * i as f64,
                0.5 + 0.25 * i as f64
            )
        })
        .collect();
    let mut rng = tet_mesh::SplitMix64(0xb0d);
    let segs: Vec<Segment> = (0..256)
        .map(|_| Segment {
            s_front: rng.next_f64() as f32 * 0.1,
            s_back: 0.9 + rng.next_f64() as f32 * 0.1,
            grad_front: rng.next_f64() as f32 * 4.0,
            grad_back: rng.next_f64() as f32 * 4.0,
            len_world: 0.05 + rng.next_f64() as f32,
        })
        .collect();
    for emission in ["density", "independent"] {
        let tf = TransferFunction::from_json(&format!(
            r#"{{"color": [[0, 0.3, 0.6, 0.9]], "opacity": [[0, 0], [1, 0]], "unit_distance": 1,
                "emission": "{emission}", "widgets": [{}]}}"#,
            widgets.join(", ")
        ))
        .unwrap();
        let baked = bake(Method::BivExact, &tf, &mesh);
        let shader = GpuShader::from_baked(&ctx, &baked).unwrap();
        let start = std::time::Instant::now();
        let got = shader.probe_segments(&ctx, &segs).unwrap();
        let gpu_s = start.elapsed().as_secs_f64();
        let cpu = baked.shader();
        // Every colour channel of every part is ≤ 1: density emission's C ≤ α
        // per channel of the largest sum, independent emission's C ≤ l·Σ.
        let parts = 1.0 + tf.widgets().len() as f32;
        let mut worst_alpha = 0.0f32;
        for (seg, g) in segs.iter().zip(&got) {
            let want = cpu.shade(seg);
            assert!(g.iter().all(|v| v.is_finite() && *v >= 0.0), "{emission} {seg:?}: {g:?}");
            let bound = if emission == "density" { g[3] } else { seg.len_world * parts };
            assert!(g[..3].iter().all(|&c| c <= bound * 1.0001), "{emission} {seg:?}: {g:?} above {bound}");
            worst_alpha = worst_alpha.max((g[3] - want[3]).abs());
        }
        eprintln!(
            "biv-exact over budget ({emission}): α max |Δ| {worst_alpha:.3e} ({} segments, {gpu_s:.2} s)",
            segs.len()
        );
        assert!(worst_alpha <= 1e-4, "{emission}: {worst_alpha}");
    }
}

#[test]
fn unsupported_inputs_are_errors() {
    let Some(ctx) = gpu() else { return };
    let mesh = grid(2);
    let scene = mesh.gpu_scene(&ctx);
    let other = mesh.gpu_scene(&ctx);
    let renderer = GpuRenderer::new(&ctx).unwrap();
    // Exact is not on the GPU.
    let err = GpuShader::from_baked(&ctx, &bake(Method::Exact, &tf(), &mesh)).err().unwrap();
    assert!(err.to_string().contains("exact"), "{err}");
    // A GpuCull of another scene.
    let c = GpuCull::new(&ctx, &other, &tf_with_gaps()).unwrap();
    let shader = GpuShader::pt_linear(&ctx, &tf()).unwrap();
    let cam = Camera::new(&ViewSpec::framing([0.0; 3], [1.0; 3], [16, 16])).unwrap();
    let err = renderer
        .render_frame(
            &ctx,
            &scene,
            &cam,
            GpuOrder::GpuCentroid,
            &shader,
            &FrameOptions { cull: Some(&c), ..Default::default() },
        )
        .err()
        .unwrap();
    assert!(err.to_string().contains("another scene"), "{err}");
    // probe_table3d stays table3d-only.
    assert!(shader.probe_table3d(&ctx, &[[0.5, 0.5, 0.5]]).is_err());
    assert_eq!(shader.probe(&ctx, &[[0.5, 0.5, 0.0]]).unwrap(), vec![[0.0; 4]]);
}
