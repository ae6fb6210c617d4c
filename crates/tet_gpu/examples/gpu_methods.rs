//! Per-method frame times of the GPU renderer on a structured-grid mesh
//! (n³ cells × 5 tets), against tet_render's CPU renderer with the same
//! table, the same MPVO order and the same culling (`TfCuller` on the CPU,
//! `GpuCull` compaction on the GPU): for every method `GpuShader::from_baked`
//! accepts, the CPU bake and upload times, GPU frame times by stage (mean
//! of the frames after the first), one CPU frame, the culled fraction and
//! the GPU-vs-CPU image difference. biv-exact and biv-approx run twice: with
//! the 1D TF and with two 2D widgets added (per-vertex |∇s| from tet_render).
//!
//! cargo run --release -p tet_gpu --example gpu_methods -- [CELLS] [SIZE] [FRAMES] [compute|graphics] [ROWS]
//! (default 30 256 3 compute: 135 000 tets at 256², the compute rasterizer;
//! ROWS: comma-separated row names to run, e.g. `biv-exact,biv-exact+2 widgets`,
//! default every row).

use std::sync::Arc;
use std::time::Instant;
use tet_gpu::{FrameOptions, GpuContext, GpuCull, GpuOrder, GpuRenderer, GpuScene, GpuShader, RasterPath, GPU_METHODS};
use tet_preint::{BakeOptions, Baked, TableDomain, TransferFunction};
use tet_render::project::ViewGeometry;
use tet_render::{visibility_order, Camera, Renderer, Scene, SortMethod, TfCuller, ViewSpec};

// The test meshes (structured grid, smooth scalar) the GPU tests render.
#[path = "../tests/common/mod.rs"]
mod common;

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let args: Vec<String> = std::env::args().collect();
    let (cells, size, frames) = common::cells_size_frames(&args, (30, 256, 3), 2)?;
    let raster: RasterPath = common::arg_or(&args, 4, Default::default())?;
    let rows: Option<Vec<String>> = args.get(5).map(|s| s.split(',').map(str::to_string).collect());

    let ctx = GpuContext::new_headless()?;
    println!("adapter: {}", ctx.describe());
    let mesh = common::grid(cells);
    let (points, tets, scalar) = (&mesh.points, &mesh.tets, &mesh.scalar);
    println!(
        "mesh: {cells}³ cells × 5 = {} tets, {} points; image {size}², {} rasterizer",
        tets.len(),
        points.len(),
        raster.id()
    );
    // Opacity 0 below 0.3 and above 0.7: the cells there are culled.
    let tf = TransferFunction::from_json(
        r#"{"color": [[0, 0.1, 0.2, 1], [0.5, 1, 0.8, 0.1], [1, 1, 0.1, 0.1]],
            "opacity": [[0, 0], [0.3, 0], [0.45, 6], [0.55, 2], [0.7, 0], [1, 0]], "unit_distance": 0.1}"#,
    )?;
    let (max_ds, len) = mesh.cell_limits();
    let domain = TableDomain::new(0.0, 1.0, max_ds, len)?;
    let opts = BakeOptions::default();

    let widgets_tf = TransferFunction::from_json(
        r#"{"color": [[0, 0.1, 0.2, 1], [0.5, 1, 0.8, 0.1], [1, 1, 0.1, 0.1]],
            "opacity": [[0, 0], [0.3, 0], [0.45, 6], [0.55, 2], [0.7, 0], [1, 0]], "unit_distance": 0.1,
            "widgets": [
              {"type": "gaussian", "center": [0.6, 1.5], "width": [0.08, 0.6], "color": [1, 0.9, 0.2], "opacity": 1},
              {"type": "box", "center": [0.3, 2.2], "width": [0.1, 1.5], "color": [0.1, 1, 0.3], "opacity": 0.5}
            ]}"#,
    )?;
    let t = Instant::now();
    let cpu_scene = Scene::new(points, tets.clone(), scalar.clone())?.ensure_gradients()?;
    let gm = cpu_scene.gradient_magnitudes().expect("ensured").to_vec();
    println!("per-vertex gradients on the CPU: {:.3} s", t.elapsed().as_secs_f64());
    let scene = GpuScene::new(&ctx, points, tets, scalar)?.with_gradient_magnitudes(&ctx, &gm)?;
    let renderer = GpuRenderer::new(&ctx)?;
    let spec = ViewSpec::framing([0.0; 3], [1.0; 3], [size, size]).orbit(30.0, 20.0, 1.0);
    let camera = Camera::new(&spec)?;
    let t = Instant::now();
    let order = visibility_order(&cpu_scene, &ViewGeometry::new(&cpu_scene, &camera), SortMethod::Mpvo, None).tets;
    println!("CPU MPVO order of every tet: {:.3} s (shared by both renderers)", t.elapsed().as_secs_f64());
    let mut cpu = Renderer::new(cpu_scene);
    cpu.set_renderer(tet_render::CpuRenderer::Pt);
    cpu.set_view(&spec)?;
    cpu.set_sort(SortMethod::Mpvo);

    println!(
        "method                bake_s  upload_s  gpu_frame_s  cull_s   classify_s  bin_s   raster_s  culled   cpu_frame_s  mean|Δ|/255  max|Δ|/255"
    );
    let runs = GPU_METHODS
        .iter()
        .map(|&m| (m, &tf, m.id().to_string()))
        .chain([
            (tet_preint::Method::BivExact, &widgets_tf, "biv-exact+2 widgets".to_string()),
            (tet_preint::Method::BivApprox, &widgets_tf, "biv-approx+2 widgets".to_string()),
        ])
        .filter(|(_, _, name)| rows.as_ref().is_none_or(|r| r.contains(name)));
    for (method, tf, name) in runs {
        let gcull = GpuCull::new(&ctx, &scene, tf)?;
        cpu.set_culler(Some(Arc::new(TfCuller::new(tf))));
        let t = Instant::now();
        let baked = Baked::build(method, tf, &domain, &opts)?;
        let bake_s = t.elapsed().as_secs_f64();
        let t = Instant::now();
        let shader = GpuShader::from_baked(&ctx, &baked)?;
        let upload_s = t.elapsed().as_secs_f64();
        let fo = FrameOptions { raster, cull: Some(&gcull), ..Default::default() };
        let mut sums = [0.0f64; 5];
        let mut last = None;
        for f in 0..frames {
            let frame = renderer.render_frame(&ctx, &scene, &camera, GpuOrder::Given(&order), &shader, &fo)?;
            let s = &frame.stats;
            if f > 0 {
                for (acc, v) in sums.iter_mut().zip([
                    s.total_seconds,
                    s.cull_seconds,
                    s.classify_seconds,
                    s.bin_seconds,
                    s.raster_seconds,
                ]) {
                    *acc += v / (frames - 1) as f64;
                }
            }
            last = Some(frame);
        }
        let frame = last.expect("frames ≥ 2");
        cpu.set_shader(Arc::from(baked.into_shader()));
        let t = Instant::now();
        let (want, st) = cpu.render(&|_, _| {})?;
        let cpu_s = t.elapsed().as_secs_f64();
        assert_eq!(st.tets_culled, frame.stats.tets_culled, "GPU and CPU culled counts");
        let d = tet_render::diff(&frame.image, &want)?;
        println!(
            "{:<20}  {bake_s:>6.3}  {upload_s:>8.3}  {:>11.4}  {:>6.4}  {:>10.4}  {:>6.4}  {:>8.4}  {:>5.1}%  {cpu_s:>11.4}  {:>11.4}  {:>10.4}",
            name,
            sums[0],
            sums[1],
            sums[2],
            sums[3],
            sums[4],
            100.0 * frame.stats.fraction_culled(),
            d.mean_abs * 255.0,
            d.max_abs * 255.0
        );
    }
    // Culling's effect on one method's frame time.
    let gcull = GpuCull::new(&ctx, &scene, &tf)?;
    let shader = GpuShader::from_baked(&ctx, &Baked::build(tet_preint::Method::Table3d, &tf, &domain, &opts)?)?;
    for (what, c) in [("without culling", None), ("with GPU culling", Some(&gcull))] {
        let fo = FrameOptions { raster, cull: c, ..Default::default() };
        let mut total = 0.0;
        for f in 0..frames {
            let s = renderer.render_frame(&ctx, &scene, &camera, GpuOrder::Given(&order), &shader, &fo)?.stats;
            if f > 0 {
                total += s.total_seconds / (frames - 1) as f64;
            }
        }
        println!("table3d {what}: {total:.4} s a frame");
    }
    Ok(())
}
