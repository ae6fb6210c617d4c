//! `tetview render --gpu`: the same outputs as the CPU path (PNG, `--float`
//! .npy, `--save-view`, `--json` statistics), drawn by the engine's
//! [`GpuFrameRenderer`] from the same [`Look`] and [`FrameRequest`] as the
//! CPU path.
//!
//! The visibility order comes from tet_render exactly as the CPU renderer
//! computes it (`visibility_order` with `--sort`) and the tables from the
//! same bake (`Look::bake`, or the `--lut` file), so GPU and CPU images
//! agree; culling (`TfCuller`'s semantics, unless `--no-cull`), projection,
//! rasterization, compositing and tone mapping run on the GPU.

use crate::render::RenderArgs;
use anyhow::{Context, Result};
use std::time::Instant;
use tet_bundle::Bundle;
use tet_cli::{fail, usage, ExitKind, KindExt};
use tet_engine::{
    EngineError, FrameRenderer, FrameRequest, FrameStats, GpuFailure, GpuFrameOptions, GpuFrameRenderer, Look,
};
use tet_gpu::{RasterPath, GPU_METHODS};
use tet_preint::{LutFile, Method, TransferFunction};
use tet_render::{Display, Scene};

/// The methods `--gpu` renders, comma-separated.
pub fn gpu_methods() -> String {
    GPU_METHODS.iter().map(|m| m.id()).collect::<Vec<_>>().join(", ")
}

/// Checks what the GPU path cannot do before any work (exit code 2).
pub fn check_args(args: &RenderArgs, method: Method) -> Result<()> {
    if !GPU_METHODS.contains(&method) {
        return Err(usage(format!("--gpu: method {method} is not on the GPU yet (GPU methods: {})", gpu_methods())));
    }
    // Lighting (--light, --light-dir, a view file's lights), --silhouette
    // and --shadows are drawn on the GPU.
    if args.gpu_bake && method != Method::Table3d {
        return Err(usage(format!("--gpu-bake: method {method} has no table to bake (only table3d)")));
    }
    Ok(())
}

/// A missing device (exit code 7) or a request beyond the GPU renderer
/// (exit code 2) says how to go on without `--gpu`.
pub fn on_cpu_instead(e: EngineError) -> anyhow::Error {
    match &e {
        EngineError::Gpu { kind: GpuFailure::NoDevice, .. } => {
            fail(ExitKind::NoGpu, format!("--gpu: {e}; run without --gpu to render on the CPU"))
        }
        EngineError::Gpu { kind: GpuFailure::Unsupported, .. } => {
            usage(format!("--gpu: {e}; run without --gpu to render on the CPU"))
        }
        _ => e.into(),
    }
}

/// What the CPU path does from the scene on, by the engine's GPU renderer:
/// the same look (the same bake, or the same file) and request.
#[allow(clippy::too_many_arguments)]
pub fn render(
    args: &RenderArgs,
    bundle: &Bundle,
    scene: Scene,
    tf: &TransferFunction,
    method: Method,
    request: &FrameRequest,
    display: &Display,
    lut: Option<&(LutFile, std::path::PathBuf)>,
    lighting: Option<&tet_render::Lighting>,
) -> Result<()> {
    let start = Instant::now();
    // What the GPU renderer refuses, before the device opens.
    GpuFrameRenderer::supports(method, request).map_err(|why| usage(format!("--gpu: {why}")))?;
    let raster = match args.gpu_raster {
        GpuRasterArg::Compute => RasterPath::Compute,
        GpuRasterArg::Graphics => RasterPath::Graphics,
    };
    // The device first: without one nothing is baked.
    let t = Instant::now();
    let mut renderer = GpuFrameRenderer::new(bundle, scene, GpuFrameOptions { raster }).map_err(on_cpu_instead)?;
    let upload_seconds = t.elapsed().as_secs_f64() - renderer.device_seconds;
    let look = if args.gpu_bake {
        Look::baked_by_renderer(bundle, tf.clone(), method)?
    } else {
        match lut {
            Some((lut, path)) => Look::from_lut_file(lut, path)?,
            None => Look::bake(bundle, method, tf.clone())?,
        }
    };
    let frame = renderer.render(&look, request, &|_, _| {}).map_err(on_cpu_instead)?;
    let FrameStats::Gpu(g) = &frame.stats else { unreachable!("the GPU renderer reports GPU statistics") };
    for note in &frame.notes {
        eprintln!("note: {note}");
    }
    let tone = renderer.tonemap_last(display)?;
    let view = &request.view;
    tet_render::image::write_png_rgba8(&args.output, view.size[0], view.size[1], &tone.rgba8)?;
    if let Some(p) = &args.float {
        frame.image.write_npy(p)?;
    }
    if let Some(p) = &args.save_view {
        // The view and its lighting, as the CPU path writes them.
        std::fs::write(p, crate::camera_args::view_json(view, lighting))
            .with_context(|| format!("writing {}", p.display()))
            .kind(ExitKind::Output)?;
    }
    let total_seconds = start.elapsed().as_secs_f64();
    let s = &g.render;
    let gpu_seconds = s.total_seconds + tone.seconds;
    let bake_seconds = if args.gpu_bake {
        g.device_bake_seconds
    } else if method.is_tabulated() {
        look.shader_seconds
    } else {
        0.0
    };
    let setup_seconds = upload_seconds + look.shader_seconds + g.setup_seconds;
    if args.json {
        let v = serde_json::json!({
            "method": method.id(),
            "device": g.device,
            "raster_path": s.raster_path.id(),
            "sort_method": g.sort_method,
            "cycles_broken": g.cycles_broken,
            "tets_total": g.tets_total,
            "tets_culled": s.tets_culled,
            "tets_drawn": s.tets_drawn,
            "fraction_culled": s.fraction_culled(),
            "cull_device": if args.no_cull { "none" } else { "gpu" },
            "device_seconds": renderer.device_seconds,
            "view_seconds": g.view_seconds,
            "cull_seconds": s.cull_seconds,
            "cull_setup_seconds": g.cull_setup_seconds,
            "sort_seconds": g.sort_seconds,
            "table_bake_seconds": bake_seconds,
            "table_bake_device": if !method.is_tabulated() { "none" } else if args.gpu_bake { "gpu" } else { "cpu" },
            "table_bake_setup_seconds": g.device_bake_setup_seconds,
            "tables_baked": tet_engine::tables_baked(),
            "setup_seconds": setup_seconds,
            "shadow_seconds": g.shadow_seconds,
            "upload_seconds": s.upload_seconds,
            "classify_seconds": s.classify_seconds,
            "bin_seconds": s.bin_seconds,
            "raster_seconds": s.raster_seconds,
            "chunks": s.chunks,
            "tile_pairs": s.pairs,
            "readback_seconds": s.readback_seconds,
            "tonemap_seconds": tone.seconds,
            "gpu_seconds": gpu_seconds,
            "total_seconds": total_seconds,
            "tets_per_second": if gpu_seconds > 0.0 { s.tets_drawn as f64 / gpu_seconds } else { 0.0 },
            "output": args.output.display().to_string(),
            "size": view.size,
        });
        println!("{}", serde_json::to_string_pretty(&v)?);
    } else {
        eprintln!(
            "{} on {} ({} raster): {} of {} tets drawn ({:.1}% culled on the GPU, sort {} {:.3} s), {}x{}: GPU {:.3} s \
             (cull {:.3}, classify {:.3}, bin {:.3}, raster {:.3}, tonemap {:.3}), total {:.3} s → {}",
            method,
            g.device,
            s.raster_path.id(),
            s.tets_drawn,
            g.tets_total,
            100.0 * s.fraction_culled(),
            g.sort_method,
            g.sort_seconds,
            view.size[0],
            view.size[1],
            gpu_seconds,
            s.cull_seconds,
            s.classify_seconds,
            s.bin_seconds,
            s.raster_seconds,
            tone.seconds,
            total_seconds,
            args.output.display()
        );
    }
    Ok(())
}

/// `--gpu-raster`: the compute-shader tile rasterizer (default) or the
/// hardware rasterizer with blending.
#[derive(Debug, Clone, Copy, PartialEq, Eq, clap::ValueEnum)]
pub enum GpuRasterArg {
    Compute,
    Graphics,
}
