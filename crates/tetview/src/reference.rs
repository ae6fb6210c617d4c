//! `tetview reference BUNDLE --tf T`: the exact ray-cast reference render
//! (the same as `tetview render --reference`), the ground truth for
//! `tetview diff`.

use anyhow::{Context, Result};
use clap::Args;
use std::io::Write;
use std::path::PathBuf;
use tet_cli::{usage, ExitKind, KindExt};
use tet_engine::{FrameRenderer, FrameRequest, FrameStats, Look, ReferenceFrameRenderer};
use tet_render::Camera;

#[derive(Debug, Clone, Args)]
pub struct ReferenceArgs {
    /// The bundle (.tetb) to render.
    pub bundle: PathBuf,
    /// Transfer function (formats/tf.md JSON or a ParaView preset); a normalized one is mapped
    /// onto the bundle's scalar range (or --range). Without it: the
    /// automatic TF of the bundle, as `tetview render` builds it.
    #[arg(long)]
    pub tf: Option<PathBuf>,
    #[command(flatten)]
    pub tf_choice: crate::tf_choice::TfChoiceArgs,
    /// Scalar range LO,HI for a normalized transfer function.
    #[arg(long, value_parser = tet_cli::parse_range, allow_hyphen_values = true)]
    pub range: Option<(f64, f64)>,
    #[command(flatten)]
    pub time: crate::cli::TimeArgs,
    #[command(flatten)]
    pub camera: crate::camera_args::CameraArgs,
    #[command(flatten)]
    pub lighting: crate::camera_args::LightingArgs,
    /// With --shadows: take shadows from the shadow field (deep shadow maps) the
    /// CPU renderers use instead of exact shadow rays (their difference is
    /// the field's error).
    #[arg(long, requires = "shadows")]
    pub shadow_field: bool,
    /// PNG output (8-bit sRGB after tone mapping, over --background).
    #[arg(short, long)]
    pub output: Option<PathBuf>,
    /// Float output: NumPy .npy, float32 H×W×4 linear premultiplied RGBA, row 0 at the top.
    #[arg(long)]
    pub float: Option<PathBuf>,
    #[command(flatten)]
    pub display: crate::camera_args::DisplayArgs,
    /// Integrate every ray to its end (default: stop at α ≥ 1 − 1e-9).
    #[arg(long)]
    pub no_early_termination: bool,
    /// Write the camera actually used as JSON (for `tetview render --view`, VTK, ParaView).
    #[arg(long)]
    pub save_view: Option<PathBuf>,
    /// Print the summary as JSON.
    #[arg(long)]
    pub json: bool,
}

pub fn run(args: &ReferenceArgs) -> Result<()> {
    if args.output.is_none() && args.float.is_none() {
        return Err(usage("nothing to write: give -o out.png and/or --float out.npy"));
    }
    let bundle = args.time.read_bundle(&args.bundle)?;
    let mesh = &bundle.mesh;
    crate::cli::warn_if_constant_scalar(&bundle);
    let tf = crate::tf_choice::resolve(args.tf.as_deref(), args.range, &bundle, &args.tf_choice)?;

    let z_up = tet_render::camera::bundle_is_z_up(&bundle.meta);
    let (spec, lighting) = args.camera.resolve_lit(&args.lighting, bounds(&mesh.points), z_up)?;
    let camera = Camera::new(&spec)?;
    if let Some(p) = &args.save_view {
        std::fs::write(p, crate::camera_args::view_json(&spec, lighting.as_ref()))
            .with_context(|| format!("writing {}", p.display()))
            .kind(ExitKind::Output)?;
    }

    let mut renderer = ReferenceFrameRenderer::new(&bundle)?;
    let setup_s = renderer.setup_seconds;
    // The reference integrates the TF exactly, whatever a method would do.
    let look = Look::exact(tf);
    let shading = lighting.as_ref().map(|l| l.shading(None)).unwrap_or_default();
    if args.shadow_field {
        renderer.use_shadow_field(&look.tf, &shading.sources)?;
    }
    let request =
        FrameRequest { early_termination: !args.no_early_termination, shading, ..FrameRequest::new(spec.clone()) };
    let bar = indicatif::ProgressBar::new(camera.height() as u64);
    bar.set_style(
        indicatif::ProgressStyle::with_template("reference {bar:30} {pos}/{len} rows, {elapsed_precise} (eta {eta})")
            .expect("valid template"),
    );
    let frame = renderer.render(&look, &request, &|done, _| bar.set_position(done as u64))?;
    bar.finish_and_clear();
    let (image, FrameStats::Reference { stats, render_seconds: render_s }) = (frame.image, frame.stats) else {
        unreachable!("the reference renderer reports reference statistics")
    };

    if let Some(p) = &args.float {
        image.write_npy(p)?;
    }
    if let Some(p) = &args.output {
        image.write_png(p, &args.display.display())?;
    }
    let seg_per_s = stats.segments as f64 / render_s.max(1e-9);
    // writeln! rather than println!: a closed pipe is an error, not a panic.
    let mut out = std::io::stdout().lock();
    if args.json {
        let j = serde_json::json!({
            "bundle": args.bundle.display().to_string(),
            "tets": mesh.tets.len(),
            "size": spec.size,
            "setup_s": setup_s,
            "render_s": render_s,
            "rays": stats.rays,
            "rays_hit": stats.rays_hit,
            "entries": stats.entries,
            "steps": stats.steps,
            "segments": stats.segments,
            "segments_per_s": seg_per_s,
            "terminated_early": stats.terminated_early,
            "walk_failures": stats.walk_failures,
            "max_steps_per_ray": stats.max_steps_per_ray,
            "view": spec,
            "png": args.output.as_ref().map(|p| p.display().to_string()),
            "float": args.float.as_ref().map(|p| p.display().to_string()),
        });
        writeln!(out, "{}", serde_json::to_string_pretty(&j)?)?;
    } else {
        writeln!(
            out,
            "reference: {}x{}, {} tets, boundary hierarchy {:.3} s, render {:.3} s",
            spec.size[0],
            spec.size[1],
            mesh.tets.len(),
            setup_s,
            render_s
        )?;
        writeln!(
            out,
            "  {} rays ({} hit), {} segments ({:.2} M segments/s), {} stopped early, {} walk failures",
            stats.rays,
            stats.rays_hit,
            stats.segments,
            seg_per_s / 1e6,
            stats.terminated_early,
            stats.walk_failures
        )?;
        for p in [&args.output, &args.float].into_iter().flatten() {
            writeln!(out, "  wrote {}", p.display())?;
        }
    }
    if stats.walk_failures > 0 {
        eprintln!(
            "warning: {} ray walks failed (the adjacency does not match the geometry); those rays are incomplete",
            stats.walk_failures
        );
    }
    Ok(())
}

fn bounds(points: &[[f64; 3]]) -> ([f64; 3], [f64; 3]) {
    let mut lo = [f64::INFINITY; 3];
    let mut hi = [f64::NEG_INFINITY; 3];
    for p in points {
        for a in 0..3 {
            lo[a] = lo[a].min(p[a]);
            hi[a] = hi[a].max(p[a]);
        }
    }
    (lo, hi)
}
