//! `tetview render`: one image of a bundle.

use anyhow::{Context, Result};
use std::path::PathBuf;
use tet_cli::{usage, ExitKind, KindExt};
use tet_engine::{CpuFrameRenderer, FrameRenderer, FrameRequest, FrameStats};
use tet_render::{Scene, Shading, SortMethod};

/// Render BUNDLE with a transfer function and method (or a baked table).
#[derive(Debug, clap::Args)]
pub struct RenderArgs {
    /// The bundle (.tetb) written by `tetprep convert`; with
    /// --distributed, a partition's manifest (or its directory) written by
    /// `tetprep partition`.
    pub bundle: PathBuf,
    /// Draw a partition (`tetprep partition`): one rank a piece, composited
    /// front to back in its k-d tree's order; the image is the unsplit
    /// bundle's. Under `mpirun -np N` (tetview built with `--features mpi`)
    /// each process is a rank; otherwise the ranks are threads of this
    /// process. A normalized TF spans the whole mesh's range; without --tf
    /// the automatic TF is built from the pieces' summed histograms (a
    /// source analysed with --histogram before partitioning).
    #[arg(long)]
    pub distributed: bool,
    /// With --distributed: each rank draws its piece with the exact
    /// reference ray caster (as `tetview reference`: the pieces' geometry
    /// and the TF's integral in f64, whatever --method says), so the image
    /// is `tetview reference`'s of the unsplit bundle to f32 rounding — its
    /// 8-bit output the same. Slow; for checking and for images that must
    /// be exact.
    #[arg(long, requires = "distributed", conflicts_with = "gpu")]
    pub reference: bool,
    #[command(flatten)]
    pub look: crate::look_args::LookArgs,
    #[command(flatten)]
    pub time: crate::cli::TimeArgs,
    #[command(flatten)]
    pub camera: crate::camera_args::CameraArgs,
    #[command(flatten)]
    pub display: crate::camera_args::DisplayArgs,
    /// CPU algorithm: walk (face-adjacency ray walking, the default; cost
    /// follows the image) or pt (projected tetrahedra in a visibility
    /// order, as on the GPU). A view whose near plane cuts the mesh is drawn
    /// by pt either way (the JSON's walk_fallback says so).
    #[arg(long, default_value = "walk")]
    pub renderer: tet_render::CpuRenderer,
    /// Visibility order (pt only): mpvo (exact on convex meshes), mpvonc (non-convex),
    /// radix (centroid depth, approximate), auto.
    #[arg(long, default_value = "auto")]
    pub sort: SortMethod,
    /// Walker only: adaptive image-space sampling for previews — rays on a
    /// 4-pixel lattice first, blocks whose corners differ by at most TOL
    /// (premultiplied linear RGBA, e.g. 0.004) filled by interpolation,
    /// others refined down to single pixels. Faster where the image is
    /// smooth; its error is measured (`tetview bench --adaptive`), not
    /// bounded: thin features between lattice rays can be missed.
    #[arg(long, value_name = "TOL")]
    pub adaptive: Option<f32>,
    #[command(flatten)]
    pub lighting: crate::camera_args::LightingArgs,
    /// Silhouette enhancement exponent p: α·(1 − |ĝ·v|)^p.
    #[arg(long)]
    pub silhouette: Option<f32>,
    /// Draw every tet (turn off culling of invisible cells).
    #[arg(long)]
    pub no_cull: bool,
    /// Walk every ray to its end (no early ray termination at α 0.9999):
    /// the image no longer depends on where a mesh is split
    /// (--distributed's exact comparisons use it).
    #[arg(long)]
    pub no_early_termination: bool,
    /// Output PNG (8-bit sRGB after tone mapping, over the background).
    #[arg(short, long)]
    pub output: PathBuf,
    /// Also write linear premultiplied RGBA as float32 .npy (H×W×4, row 0 at the top).
    #[arg(long = "float")]
    pub float: Option<PathBuf>,
    /// Write the view used as JSON (reusable with --view, and in ParaView).
    #[arg(long)]
    pub save_view: Option<PathBuf>,
    /// Print statistics as JSON on stdout.
    #[arg(long)]
    pub json: bool,
    /// Render on the GPU (tet_gpu; methods pt-linear, table3d, atlas2d,
    /// poly1/2/4, partial, biv-exact and biv-approx; the same
    /// visibility order and tables as the CPU, culling on the GPU; lit by
    /// --light, --light-dir or the view file's lights, and --silhouette, as
    /// the CPU's projected tetrahedra light; not --shadows). Exit code 7
    /// where no GPU adapter exists; without --gpu tetview renders on the
    /// CPU.
    #[arg(long)]
    pub gpu: bool,
    /// With --gpu: the compute-shader tile rasterizer or the hardware
    /// rasterizer with blending (same images; speed differs by device).
    #[arg(long, value_enum, default_value = "compute", requires = "gpu")]
    pub gpu_raster: crate::gpu::GpuRasterArg,
    /// With --gpu and table3d: bake the table on the GPU (a compute shader,
    /// the CPU bake's integration; matches it to ~1e-5) straight into the
    /// texture the renderer samples, instead of on the CPU and uploading it.
    #[arg(long, requires = "gpu")]
    pub gpu_bake: bool,
}

impl RenderArgs {
    /// The engine's request for `view` lit by `lighting` with these flags
    /// (what `render` and each rank of `render --distributed` draw).
    pub fn frame_request(&self, view: &tet_render::ViewSpec, lighting: Option<&tet_render::Lighting>) -> FrameRequest {
        let shading = match lighting {
            Some(l) => l.shading(self.silhouette),
            None => Shading { silhouette: self.silhouette, ..Default::default() },
        };
        FrameRequest {
            shading,
            cpu: self.renderer,
            sort: self.sort,
            cull: !self.no_cull,
            adaptive: self.adaptive,
            early_termination: !self.no_early_termination,
            ..FrameRequest::new(view.clone())
        }
    }
}

pub fn run(args: &RenderArgs) -> Result<()> {
    if args.distributed {
        return crate::distributed::run(args);
    }
    let bundle = args.time.read_bundle(&args.bundle)?;
    crate::cli::warn_if_constant_scalar(&bundle);
    // Either a baked .tetl (its TF travels in the file) or a TF and a method.
    let chosen = args.look.resolve(&bundle)?;
    let (tf, method) = (chosen.tf.clone(), chosen.method);

    if let Some(p) = args.silhouette {
        if !(p >= 0.0 && p.is_finite()) {
            return Err(usage(format!("--silhouette {p}: need a finite exponent ≥ 0")));
        }
    }
    if let Some(tol) = args.adaptive {
        let cpu = if args.gpu { tet_render::CpuRenderer::Pt } else { args.renderer };
        tet_engine::check_adaptive(tol, cpu).context("--adaptive")?;
    }
    if args.gpu {
        crate::gpu::check_args(args, method)?;
    }
    let z_up = tet_render::camera::bundle_is_z_up(&bundle.meta);
    // The scene's bounds (`Scene::bounds` is the same function of the points).
    let bounds = tet_mesh::stats::bounds(&bundle.mesh.points);
    let (view, lighting) = args.camera.resolve_lit(&args.lighting, bounds, z_up)?;
    let display = args.display.display();
    let request = args.frame_request(&view, lighting.as_ref());
    let in_bundle = || format!("in {}", args.bundle.display());
    if args.gpu {
        let scene = Scene::from_bundle(&bundle).with_context(in_bundle)?;
        // The GPU path opens its device before baking (without one nothing
        // is baked), and --gpu-bake bakes on the device instead.
        return crate::gpu::render(
            args,
            &bundle,
            scene,
            &tf,
            method,
            &request,
            &display,
            chosen.lut.as_ref(),
            lighting.as_ref(),
        );
    }
    let look = chosen.look(&bundle)?;
    // Nothing below needs the bundle: its arrays move into the scene, so a
    // mesh near the memory's size is held once, not twice.
    let scene = Scene::from_bundle_owned(bundle).with_context(in_bundle)?;
    let mut renderer = CpuFrameRenderer::from_scene(scene);
    let bar = if args.json { indicatif::ProgressBar::hidden() } else { indicatif::ProgressBar::new(0) };
    bar.set_style(
        indicatif::ProgressStyle::with_template("{msg} [{bar:30}] {pos}/{len} tiles")
            .expect("static template")
            .progress_chars("=> "),
    );
    bar.set_message("rendering");
    let frame = renderer.render(&look, &request, &|done, total| {
        bar.set_length(total as u64);
        bar.set_position(done as u64);
    })?;
    bar.finish_and_clear();
    for note in &frame.notes {
        eprintln!("note: {note}");
    }
    let (image, FrameStats::Cpu(st)) = (frame.image, frame.stats) else {
        unreachable!("the CPU renderer reports CPU statistics")
    };

    image.write_png(&args.output, &display)?;
    if let Some(p) = &args.float {
        image.write_npy(p)?;
    }
    if let Some(p) = &args.save_view {
        std::fs::write(p, crate::camera_args::view_json(&view, lighting.as_ref()))
            .with_context(|| format!("writing {}", p.display()))
            .kind(ExitKind::Output)?;
    }
    if args.json {
        let mut v = serde_json::to_value(&st)?;
        v["method"] = method.id().into();
        v["shader_seconds"] = look.shader_seconds.into();
        v["tables_baked"] = tet_engine::tables_baked().into();
        v["tets_per_second"] = st.tets_per_second().into();
        v["walk_bytes"] = renderer.renderer().walk_bytes().into();
        v["shadow_seconds"] = renderer.shadow_seconds.into();
        v["output"] = args.output.display().to_string().into();
        v["size"] = serde_json::json!(view.size);
        println!("{}", serde_json::to_string_pretty(&v)?);
    } else {
        if let Some(why) = &st.walk_fallback {
            eprintln!("note: projected tetrahedra drew this view: {why}");
        }
        if st.walk_non_manifold + st.walk_step_limit > 0 {
            eprintln!(
                "warning: {} ray runs ended at non-manifold links, {} at the step bound (the rays went on from their next entry)",
                st.walk_non_manifold, st.walk_step_limit
            );
        }
        eprintln!(
            "{} ({}): {} of {} tets drawn ({:.1}% culled, sort {}{}), {}x{} in {:.3} s (sort {:.3} s, raster {:.3} s) → {}",
            method,
            st.renderer,
            st.tets_drawn,
            st.tets_total,
            100.0 * st.fraction_culled,
            st.sort_method,
            if st.cycles_broken > 0 { format!(", {} cycles broken", st.cycles_broken) } else { String::new() },
            view.size[0],
            view.size[1],
            st.total_seconds,
            st.sort_seconds,
            st.raster_seconds,
            args.output.display()
        );
        if args.adaptive.is_some() {
            eprintln!(
                "adaptive sampling: {} covered pixels walked, {} interpolated",
                st.walk_rays, st.walk_rays_interpolated
            );
        }
    }
    Ok(())
}
