//! Renders a structured-grid mesh (n³ cells × 5 tets) on the GPU with
//! table3d and prints the adapter, the per-stage times and tets/s for each
//! rasterizer (graphics, compute) and order (the CPU centroid sort
//! uploaded, the GPU radix sort), turning the camera by 0.5° a frame so
//! every frame re-sorts; then the largest difference between the two
//! rasterizers' images.
//!
//! cargo run --release -p tet_gpu --example gpu_render -- [CELLS] [SIZE] [FRAMES] [OUT_PREFIX]
//! e.g. `-- 60 1024 5 /tmp/g` renders 1.08M tets at 1024² five times per
//! mode (the first frame includes warm-up and buffer growth) and writes
//! /tmp/g.png and /tmp/g.npy (compute raster, GPU order).

use std::time::Instant;
use tet_gpu::{centroid_order, GpuContext, GpuOrder, GpuRenderer, GpuScene, GpuShader, RasterPath};
use tet_preint::{Table3d, Table3dParams, TableDomain, TransferFunction};
use tet_render::{Camera, Display, ViewSpec};

// The test meshes (structured grid, smooth scalar) the GPU tests render.
#[path = "../tests/common/mod.rs"]
mod common;

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let args: Vec<String> = std::env::args().collect();
    let (cells, size, frames) = common::cells_size_frames(&args, (20, 512, 3), 1)?;
    let out = args.get(4);

    let t = Instant::now();
    let ctx = GpuContext::new_headless()?;
    println!("adapter: {}  (context {:.3} s)", ctx.describe(), t.elapsed().as_secs_f64());
    let lim = ctx.device.limits();
    println!(
        "limits: storage binding {} MiB, buffer {} MiB, 3D texture {}",
        lim.max_storage_buffer_binding_size >> 20,
        lim.max_buffer_size >> 20,
        lim.max_texture_dimension_3d
    );
    let t = Instant::now();
    let common::Mesh { points, tets, scalar } = common::grid(cells);
    println!(
        "mesh: {cells}³ cells × 5 = {} tets, {} points (built in {:.3} s)",
        tets.len(),
        points.len(),
        t.elapsed().as_secs_f64()
    );

    let tf = TransferFunction::from_json(
        r#"{"color": [[0, 0.1, 0.2, 1], [0.5, 1, 0.8, 0.1], [1, 1, 0.1, 0.1]],
            "opacity": [[0, 0.5], [0.4, 4], [0.6, 1], [1, 8]], "unit_distance": 1}"#,
    )?;
    let len_max = 3f64.sqrt() / cells as f64;
    // The 5-tet split's largest per-cell scalar range is bounded by the field's; use the full square.
    let domain = TableDomain::full(0.0, 1.0, len_max)?;
    let t = Instant::now();
    let table = Table3d::build(&tf, &domain, &Table3dParams { n_s: 128, n_l: 128, ..Default::default() })?;
    println!("table3d 128×128×128 baked on the CPU in {:.3} s", t.elapsed().as_secs_f64());

    let t = Instant::now();
    let scene = GpuScene::new(&ctx, &points, &tets, &scalar)?;
    let shader = GpuShader::table3d(&ctx, &table)?;
    let renderer = GpuRenderer::new(&ctx)?;
    println!("upload + pipelines: {:.3} s", t.elapsed().as_secs_f64());

    println!(
        "raster    order  frame  sort    upload  classify  bin     raster  readback  tonemap  total   pairs     tets/s(total)  tets/s(GPU stages)"
    );
    let mut images = Vec::new();
    let mut last = None;
    for (raster, gpu_order) in [
        (RasterPath::Graphics, false),
        (RasterPath::Compute, false),
        (RasterPath::Graphics, true),
        (RasterPath::Compute, true),
    ] {
        for f in 0..frames {
            let spec = ViewSpec::framing([0.0; 3], [1.0; 3], [size, size]).orbit(30.0 + 0.5 * f as f64, 20.0, 1.0);
            let camera = Camera::new(&spec)?;
            let t = Instant::now();
            let cpu_order = if gpu_order { Vec::new() } else { centroid_order(&scene, &camera) };
            let cpu_sort_s = t.elapsed().as_secs_f64();
            let order = if gpu_order { GpuOrder::GpuCentroid } else { GpuOrder::Given(&cpu_order) };
            let frame = renderer.render_with(&ctx, &scene, &camera, order, &shader, raster)?;
            let tone = renderer.tonemap(&ctx, &frame, &Display::default())?;
            let s = &frame.stats;
            let sort_s = cpu_sort_s + s.sort_seconds;
            let total = cpu_sort_s + s.total_seconds + tone.seconds;
            let gpu_stages = s.sort_seconds + s.classify_seconds + s.bin_seconds + s.raster_seconds;
            println!(
                "{:<8}  {:<5}  {f:>5}  {sort_s:>6.4}  {:>6.4}  {:>8.4}  {:>6.4}  {:>6.4}  {:>8.4}  {:>7.4}  {total:>6.4}  {:>8}  {:>13.3e}  {:>18.3e}",
                s.raster_path.id(),
                if gpu_order { "gpu" } else { "cpu" },
                s.upload_seconds,
                s.classify_seconds,
                s.bin_seconds,
                s.raster_seconds,
                s.readback_seconds,
                tone.seconds,
                s.pairs,
                tets.len() as f64 / total,
                tets.len() as f64 / gpu_stages,
            );
            if f == 0 && !gpu_order {
                images.push(frame.image.clone());
            }
            last = Some((frame, tone));
        }
    }
    if let [g, c] = &images[..] {
        let d = tet_render::diff(g, c)?;
        println!(
            "graphics vs compute raster (same CPU order, first frame): mean {:.4}/255, max {:.4}/255",
            d.mean_abs * 255.0,
            d.max_abs * 255.0
        );
    }
    if let (Some(prefix), Some((frame, tone))) = (out, last) {
        frame.image.write_npy(std::path::Path::new(&format!("{prefix}.npy")))?;
        tet_render::image::write_png_rgba8(std::path::Path::new(&format!("{prefix}.png")), size, size, &tone.rgba8)?;
        println!("wrote {prefix}.npy and {prefix}.png (GPU tone mapped)");
    }
    Ok(())
}
