//! GPU images against a CPU reference that shades exact ray segments with
//! the same method (tet_preint's `Table3d::lookup`, `PtLinearShader`).
//! Skip with a printed reason where no adapter exists (fail instead with
//! TETKIT_REQUIRE_GPU=1); on this kind of machine they run on lavapipe.

mod common;

use common::{
    assert_close_images, cpu_pt_renderer, gpu, gpu_and_cpu_pt_images, gpu_with_scene, grid, report, single_tet,
    table_on_axis, tf, Mesh,
};
use tet_gpu::{centroid_order, GpuContext, GpuRenderer, GpuScene, GpuShader};
use tet_preint::{PtLinearShader, ScalarAxis, Table3d};
use tet_render::{Camera, Display, Image, ToneMap, ViewSpec};

/// The table the CPU renders with by default: a grid sample on every TF
/// control point (`ScalarAxis::TfNodes`, a non-uniform axis here).
fn table_for(mesh: &Mesh) -> Table3d {
    table_on_axis(mesh, ScalarAxis::TfNodes)
}

/// [`table_for`] `mesh`, and its GPU shader.
fn table3d_for(ctx: &GpuContext, mesh: &Mesh) -> (Table3d, GpuShader) {
    let table = table_for(mesh);
    let shader = GpuShader::table3d(ctx, &table).unwrap();
    (table, shader)
}

fn view(mesh: &Mesh, size: [u32; 2], az: f64, el: f64) -> Camera {
    let (lo, hi) = mesh.bounds();
    Camera::new(&ViewSpec::framing(lo, hi, size).orbit(az, el, 1.0)).unwrap()
}

#[test]
fn single_tet_table3d_and_pt_linear_match_the_cpu() {
    let mesh = single_tet();
    let Some((ctx, scene, renderer)) = gpu_with_scene(&mesh) else { return };
    let (table, t3) = table3d_for(&ctx, &mesh);
    for (az, el) in [(0.0, 0.0), (40.0, 25.0), (-110.0, -60.0)] {
        let cam = view(&mesh, [96, 80], az, el);
        let frame = renderer.render(&ctx, &scene, &cam, &[0], &t3).unwrap();
        let cpu = mesh.reference(&cam, &table);
        assert_close_images(&format!("single tet table3d az {az} el {el}"), &frame.image, &cpu);
    }
    // pt-linear shades the thick point once and interpolates: where the
    // thick vertex projects onto a pixel centre, that pixel must equal the
    // CPU shader on the exact segment there. The apex (0.3, 0.3, 0.8) is on
    // the view axis, which an odd-sized image puts on pixel (32, 24)'s centre.
    let mesh = Mesh {
        points: vec![[0.0, 0.0, 0.0], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.3, 0.3, 0.8]],
        tets: vec![[0, 1, 2, 3]],
        scalar: vec![0.2, 0.7, 0.9, 0.45],
    };
    let scene = mesh.gpu_scene(&ctx);
    let pt = GpuShader::pt_linear(&ctx, &tf()).unwrap();
    let cam = Camera::new(&ViewSpec::looking_at([0.3, 0.3, 4.0], [0.3, 0.3, 0.4], [0.0, 1.0, 0.0], [65, 49])).unwrap();
    let img = renderer.render(&ctx, &scene, &cam, &[0], &pt).unwrap().image;
    let exact = mesh.reference(&cam, &PtLinearShader::new(tf()));
    let (g, c) = (img.pixel(32, 24), exact.pixel(32, 24));
    eprintln!("pt-linear at the thick point: GPU {g:?}, CPU {c:?}");
    for ch in 0..4 {
        assert!((g[ch] - c[ch]).abs() < 1e-4, "{g:?} vs {c:?}");
    }
    // Elsewhere the tent falls linearly to 0 at the silhouette: never above the peak.
    assert!(img.pixels().iter().all(|p| p[3] <= g[3] + 1e-6));
    assert!(img.pixels().iter().filter(|p| p[3] > 0.0).count() > 100);
}

#[test]
fn grid_table3d_matches_exact_rays() {
    let mesh = grid(6);
    let Some((ctx, scene, renderer)) = gpu_with_scene(&mesh) else { return };
    let (table, shader) = table3d_for(&ctx, &mesh);
    for (az, el) in [(30.0, 20.0), (-75.0, 50.0)] {
        let cam = view(&mesh, [128, 112], az, el);
        let cpu = mesh.reference(&cam, &table);
        let exact_order = mesh.mpvo_order(&cam);
        let frame = renderer.render(&ctx, &scene, &cam, &exact_order, &shader).unwrap();
        assert_close_images(&format!("grid 6³×5 table3d MPVO order az {az} el {el}"), &frame.image, &cpu);
        // The centroid order is approximate: reported, loosely bounded.
        let approx = renderer.render(&ctx, &scene, &cam, &centroid_order(&scene, &cam), &shader).unwrap();
        let d = report(&format!("grid 6³×5 table3d centroid order az {az} el {el}"), &approx.image, &cpu);
        assert!(d.mean_abs <= 2.0 / 255.0, "{d:?}");
    }
}

#[test]
fn parallel_projection_and_clipped_tets_render() {
    let mesh = grid(4);
    let Some((ctx, scene, renderer)) = gpu_with_scene(&mesh) else { return };
    let (table, shader) = table3d_for(&ctx, &mesh);
    let (lo, hi) = mesh.bounds();
    let mut spec = ViewSpec::framing(lo, hi, [80, 64]).orbit(20.0, 30.0, 1.0);
    spec.parallel = true;
    let cam = Camera::new(&spec).unwrap();
    let frame = renderer.render(&ctx, &scene, &cam, &mesh.mpvo_order(&cam), &shader).unwrap();
    assert_close_images("grid 4³×5 table3d parallel", &frame.image, &mesh.reference(&cam, &table));

    // Camera inside the mesh: every tet around the eye crosses the near
    // plane and must be clipped, not dropped.
    let spec = ViewSpec {
        view_angle: 60.0,
        ..ViewSpec::looking_at([0.5, 0.45, 0.52], [0.5, 0.45, -1.0], [0.0, 1.0, 0.0], [64, 64])
    };
    let cam = Camera::new(&spec).unwrap();
    let frame = renderer.render(&ctx, &scene, &cam, &mesh.mpvo_order(&cam), &shader).unwrap();
    assert_close_images(
        "grid 4³×5 table3d, camera inside (near-plane clipping)",
        &frame.image,
        &mesh.reference(&cam, &table),
    );
    assert!(frame.image.pixel(32, 32)[3] > 0.0);
}

#[test]
fn gpu_reinhard_matches_cpu_display() {
    let Some(ctx) = gpu() else { return };
    let renderer = GpuRenderer::new(&ctx).unwrap();
    // A high-dynamic-range image with transparent, dim and very bright pixels.
    let (w, h) = (67u32, 45u32);
    let mut rng = tet_mesh::SplitMix64(7);
    let px: Vec<[f32; 4]> = (0..w * h)
        .map(|i| {
            let a = (rng.next_f64() as f32).powi(2);
            let scale = if i % 17 == 0 { 40.0 } else { 1.0 };
            [
                a * scale * rng.next_f64() as f32,
                a * scale * rng.next_f64() as f32,
                a * scale * rng.next_f64() as f32,
                if i % 5 == 0 { 0.0 } else { a },
            ]
        })
        .collect();
    let img = Image::from_pixels(w, h, px).unwrap();
    for display in [
        Display::default(),
        Display { background: [0.2, 0.3, 0.4], tonemap: ToneMap::Reinhard { key: 0.3, exposure: 1.5 } },
        Display { background: [1.0, 1.0, 1.0], tonemap: ToneMap::None },
    ] {
        let gpu = renderer.tonemap_image(&ctx, &img, &display).unwrap();
        let cpu = img.to_rgba8(&display);
        let max = tet_render::image::diff_rgba8(&gpu.rgba8, &cpu);
        let differing = gpu.rgba8.iter().zip(&cpu).filter(|(a, b)| a != b).count();
        eprintln!("tonemap {display:?}: max 8-bit difference {max}, {differing} of {} bytes differ", cpu.len());
        assert!(max <= 1, "{max}");
        if let ToneMap::Reinhard { key, exposure } = display.tonemap {
            let rgb: Vec<[f32; 3]> = img
                .pixels()
                .iter()
                .map(|p| {
                    let t = 1.0 - p[3].clamp(0.0, 1.0);
                    let bg = display.background;
                    [p[0] + t * bg[0], p[1] + t * bg[1], p[2] + t * bg[2]]
                })
                .collect();
            let alpha: Vec<f32> = img.pixels().iter().map(|p| p[3]).collect();
            let op = tet_render::image::Reinhard::fit_covered(&rgb, &alpha, key, exposure);
            let [scale, white_sq, log_avg] = gpu.reinhard.unwrap();
            eprintln!("  fit GPU (scale {scale}, L_white² {white_sq}, L̄ {log_avg}) CPU {op:?}");
            assert!((log_avg / op.log_average - 1.0).abs() < 1e-4);
            assert!((white_sq / op.white_sq - 1.0).abs() < 1e-4);
        }
    }
}

#[test]
fn bad_input_is_an_error_not_a_panic() {
    let Some(ctx) = gpu() else { return };
    let mesh = single_tet();
    let err = GpuScene::new(&ctx, &mesh.points, &[[0, 1, 2, 9]], &mesh.scalar).err().unwrap();
    assert!(err.to_string().contains("tet 0 refers to point 9"), "{err}");
    assert!(GpuScene::new(&ctx, &mesh.points, &mesh.tets, &[0.0]).is_err());
    let scene = mesh.gpu_scene(&ctx);
    let renderer = GpuRenderer::new(&ctx).unwrap();
    let shader = GpuShader::pt_linear(&ctx, &tf()).unwrap();
    let cam = view(&mesh, [8, 8], 0.0, 0.0);
    let err = renderer.render(&ctx, &scene, &cam, &[3], &shader).err().unwrap();
    assert!(err.to_string().contains("tet 3"), "{err}");
    // An empty order draws nothing.
    let img = renderer.render(&ctx, &scene, &cam, &[], &shader).unwrap().image;
    assert!(img.pixels().iter().all(|p| *p == [0.0; 4]));
}

/// Against tet_render's CPU projected-tetrahedra renderer with the same
/// (MPVO) order: table3d per fragment on both scalar axes, and pt-linear's
/// interpolated thick point.
#[test]
fn grid_matches_the_cpu_pt_renderer() {
    let mesh = grid(8);
    let Some((ctx, scene, renderer)) = gpu_with_scene(&mesh) else { return };
    let mut cpu = cpu_pt_renderer(mesh.cpu_scene());
    let mut shaders: Vec<(String, GpuShader, std::sync::Arc<dyn tet_preint::SegmentShader>)> = Vec::new();
    for axis in [ScalarAxis::TfNodes, ScalarAxis::Uniform] {
        let table = std::sync::Arc::new(table_on_axis(&mesh, axis));
        shaders.push((format!("table3d {axis:?} axis"), GpuShader::table3d(&ctx, &table).unwrap(), table));
    }
    shaders.push((
        "pt-linear".into(),
        GpuShader::pt_linear(&ctx, &tf()).unwrap(),
        std::sync::Arc::new(PtLinearShader::new(tf())),
    ));
    for (az, el) in [(30.0, 20.0), (-130.0, -40.0)] {
        let (lo, hi) = mesh.bounds();
        let spec = ViewSpec::framing(lo, hi, [120, 100]).orbit(az, el, 1.0);
        let cam = Camera::new(&spec).unwrap();
        cpu.set_view(&spec).unwrap();
        for (name, gpu_shader, cpu_shader) in &shaders {
            let (got, want, _) =
                gpu_and_cpu_pt_images(&ctx, &renderer, &scene, &cam, &mut cpu, (gpu_shader, cpu_shader));
            assert_close_images(&format!("grid 8³×5 {name} vs CPU PT az {az} el {el}"), &got, &want);
        }
    }
}
