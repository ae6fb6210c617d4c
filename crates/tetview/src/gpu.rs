//! `tetview render --gpu`: the same outputs as the CPU path (PNG, `--float`
//! .npy, `--save-view`, `--json` statistics), rendered by tet_gpu.
//!
//! The visibility order comes from tet_render exactly as the CPU renderer
//! computes it (`visibility_order` with `--sort`) and the tables from the
//! same bake (tet_preint's `Baked` with the default options, or the `--lut`
//! file), so GPU and CPU images agree; culling (`TfCuller`'s semantics,
//! unless `--no-cull`), projection, rasterization, compositing and tone
//! mapping run on the GPU.

use crate::render::RenderArgs;
use anyhow::{Context, Result};
use std::time::Instant;
use tet_bundle::Bundle;
use tet_cli::{fail, usage, ExitKind, KindExt};
use tet_gpu::{
    FrameOptions, GpuAccumulation, GpuContext, GpuCull, GpuError, GpuOrder, GpuRenderer, GpuScene, GpuShader,
    GpuTable3d, RasterPath, GPU_METHODS,
};
use tet_preint::{BakeOptions, Baked, Build3d, LutFile, Method, Table3dParams, TableDomain, TransferFunction};
use tet_render::project::ViewGeometry;
use tet_render::{visibility_order, Camera, Display, Scene, ViewSpec};

/// The methods `--gpu` renders, comma-separated.
pub fn gpu_methods() -> String {
    GPU_METHODS.iter().map(|m| m.id()).collect::<Vec<_>>().join(", ")
}

/// A method or input the GPU path lacks is a usage error (exit code 2).
fn unsupported(e: GpuError) -> anyhow::Error {
    match e {
        GpuError::Unsupported(_) => usage(format!("--gpu: {e}; run without --gpu to render on the CPU")),
        e => e.into(),
    }
}

/// Checks what the GPU path cannot do before any work (exit code 2).
pub fn check_args(args: &RenderArgs, method: Method) -> Result<()> {
    if !GPU_METHODS.contains(&method) {
        return Err(usage(format!("--gpu: method {method} is not on the GPU yet (GPU methods: {})", gpu_methods())));
    }
    if args.light || args.silhouette.is_some() {
        return Err(usage("--gpu: --light and --silhouette are CPU-only for now"));
    }
    if args.gpu_bake && method != Method::Table3d {
        return Err(usage(format!("--gpu-bake: method {method} has no table to bake (only table3d)")));
    }
    Ok(())
}

/// What the CPU path does from the scene on, on the GPU.
#[allow(clippy::too_many_arguments)]
pub fn render(
    args: &RenderArgs,
    bundle: &Bundle,
    scene: &Scene,
    tf: &TransferFunction,
    method: Method,
    view: &ViewSpec,
    display: &Display,
    lut: Option<&(LutFile, std::path::PathBuf)>,
) -> Result<()> {
    let start = Instant::now();
    let t = Instant::now();
    let ctx = GpuContext::new_headless().map_err(|e| match e {
        GpuError::NoAdapter { .. } | GpuError::MissingFeature { .. } | GpuError::Device { .. } => {
            // No usable adapter (exit code 7): `tetview render` without `--gpu` works.
            fail(ExitKind::NoGpu, format!("--gpu: {e}; run without --gpu to render on the CPU"))
        }
        e => e.into(),
    })?;
    let device_seconds = t.elapsed().as_secs_f64();

    let camera = Camera::new(view)?;
    let t = Instant::now();
    let geometry = ViewGeometry::new(scene, &camera);
    let view_seconds = t.elapsed().as_secs_f64();
    // Every tet is ordered; the GPU compacts the culled ones out of the order.
    let t = Instant::now();
    let order = visibility_order(scene, &geometry, args.sort, None);
    let tets = &order.tets;
    let sort_seconds = t.elapsed().as_secs_f64();

    let t = Instant::now();
    let mut bake_seconds = 0.0;
    let mut bake_setup_seconds = 0.0;
    let shader = match method {
        // The CPU renderer's table parameters (BakeOptions: the data-driven scalar axis),
        // so --gpu and CPU images agree.
        Method::Table3d if args.gpu_bake => {
            let domain = TableDomain::from_bundle(bundle)?;
            tet_engine::count_table_bake();
            // The GPU bakes the slice recurrence (the CPU default is the
            // adaptive build): same axis and resolution, entries within ~1e-5.
            let params = Table3dParams { build: Build3d::default(), ..BakeOptions::default().table3d };
            let table = GpuTable3d::bake(&ctx, tf, &domain, &params, GpuAccumulation::F32)?;
            bake_seconds = table.stats().bake_seconds;
            bake_setup_seconds = table.stats().setup_seconds;
            GpuShader::table3d_baked(&ctx, &table)?
        }
        // The CPU renderer's tables: the same bake (or the same file).
        _ => {
            let tb = Instant::now();
            let baked = match lut {
                Some((lut, path)) => Baked::from_lut(lut, path)?,
                None => {
                    if method.is_tabulated() {
                        tet_engine::count_table_bake();
                    }
                    Baked::build(method, tf, &TableDomain::from_bundle(bundle)?, &BakeOptions::default())?
                }
            };
            if method.is_tabulated() {
                bake_seconds = tb.elapsed().as_secs_f64();
            }
            GpuShader::from_baked(&ctx, &baked).map_err(unsupported)?
        }
    };
    let mesh = &bundle.mesh;
    let mut gpu_scene = GpuScene::new(&ctx, &mesh.points, &mesh.tets, &mesh.scalar)?;
    if method.is_bivariate() {
        // The CPU scene's per-vertex |∇s| (computed above for bivariate methods).
        let g = scene.gradient_magnitudes().context("the bivariate method needs gradient magnitudes")?;
        gpu_scene = gpu_scene.with_gradient_magnitudes(&ctx, g)?;
    }
    let renderer = GpuRenderer::new(&ctx)?;
    let t_cull = Instant::now();
    let gpu_cull = if args.no_cull { None } else { Some(GpuCull::new(&ctx, &gpu_scene, tf).map_err(unsupported)?) };
    let cull_setup_seconds = t_cull.elapsed().as_secs_f64();
    let setup_seconds = t.elapsed().as_secs_f64();

    let raster = match args.gpu_raster {
        GpuRasterArg::Compute => RasterPath::Compute,
        GpuRasterArg::Graphics => RasterPath::Graphics,
    };
    let opts = FrameOptions { raster, cull: gpu_cull.as_ref() };
    let frame = renderer.render_frame(&ctx, &gpu_scene, &camera, GpuOrder::Given(tets), &shader, &opts)?;
    let tone = renderer.tonemap(&ctx, &frame, display)?;
    tet_render::image::write_png_rgba8(&args.output, view.size[0], view.size[1], &tone.rgba8)?;
    if let Some(p) = &args.float {
        frame.image.write_npy(p)?;
    }
    if let Some(p) = &args.save_view {
        std::fs::write(p, view.to_json()).with_context(|| format!("writing {}", p.display())).kind(ExitKind::Output)?;
    }
    let total_seconds = start.elapsed().as_secs_f64();
    let s = &frame.stats;
    let gpu_seconds = s.total_seconds + tone.seconds;
    if args.json {
        let v = serde_json::json!({
            "method": method.id(),
            "device": ctx.describe(),
            "raster_path": s.raster_path.id(),
            "sort_method": order.method.id(),
            "cycles_broken": order.cycles_broken,
            "tets_total": scene.num_tets(),
            "tets_culled": s.tets_culled,
            "tets_drawn": s.tets_drawn,
            "fraction_culled": s.fraction_culled(),
            "cull_device": if args.no_cull { "none" } else { "gpu" },
            "device_seconds": device_seconds,
            "view_seconds": view_seconds,
            "cull_seconds": s.cull_seconds,
            "cull_setup_seconds": cull_setup_seconds,
            "sort_seconds": sort_seconds,
            "table_bake_seconds": bake_seconds,
            "table_bake_device": if !method.is_tabulated() { "none" } else if args.gpu_bake { "gpu" } else { "cpu" },
            "table_bake_setup_seconds": bake_setup_seconds,
            "tables_baked": tet_engine::tables_baked(),
            "setup_seconds": setup_seconds,
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
            ctx.describe(),
            s.raster_path.id(),
            s.tets_drawn,
            scene.num_tets(),
            100.0 * s.fraction_culled(),
            order.method.id(),
            sort_seconds,
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
