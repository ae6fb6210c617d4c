//! `tetview bench BUNDLE... --tf T`: run time against image error of every
//! method on real data.
//!
//! For each bundle and view, the exact ray-cast reference is rendered once
//! (and cached as `.npy` under `--cache`, keyed by a hash of the bundle's
//! bytes, the view, the TF file and the size, so re-runs skip it). Every
//! method is then baked (timed) and rendered by each CPU renderer
//! (`--renderers`: the ray walker and projected tetrahedra, through
//! tet_engine's [`CpuFrameRenderer`]) `--repeat` times
//! from a fresh camera, so each frame redoes the view (the walker's vertex
//! projection and entry faces; PT's view geometry, visibility sort and
//! per-tet setup) — what a camera move costs; the cull mask (a TF change) is
//! kept. Each frame's process CPU time over its wall time is reported too
//! (near the thread count when every core worked). The best total
//! frame time is reported with its sort / raster split, and the best of as
//! many frames of the unchanged view ("same view": what a new method or a
//! TF edit that culls the same cells costs, from the kept per-tet setup). Errors are over
//! linear premultiplied RGBA against the reference (RMSE and max abs over
//! all four channels), and the largest 8-bit difference after compositing
//! over black, Reinhard tone mapping fitted to the reference (applied to
//! both) and sRGB encoding — what `tetview diff` reports.

use anyhow::{Context, Result};
use serde_json::json;
use std::path::{Path, PathBuf};
use std::time::Instant;
use tet_bundle::Bundle;
use tet_cli::{usage, ExitKind, KindExt};
use tet_engine::{CpuFrameRenderer, FrameRenderer, FrameRequest, FrameStats, Look, ReferenceFrameRenderer};
use tet_plot::{Point, ScatterPlot, Series};
use tet_preint::{Method, TransferFunction};
use tet_render::pipeline::process_cpu_seconds;
use tet_render::{diff, CpuRenderer, Image, RenderStats, Scene, SortMethod, ViewSpec};

#[derive(Debug, clap::Args)]
pub struct BenchArgs {
    /// Bundles (.tetb) to measure, each with its own table.
    #[arg(required = true)]
    pub bundles: Vec<PathBuf>,
    /// Transfer function (formats/tf.md JSON or a ParaView preset); a normalized one is mapped onto
    /// each bundle's scalar range.
    #[arg(long)]
    pub tf: PathBuf,
    /// Methods: all, or a comma-separated list of ids. biv-* are skipped (with
    /// a note): the reference integrates the 1D TF only.
    #[arg(long, default_value = "all")]
    pub methods: String,
    /// Image size WxH.
    #[arg(long, default_value = "512x512", value_parser = tet_cli::parse_size)]
    pub size: [u32; 2],
    /// Views per bundle: the default framing orbited by 360°/N steps of azimuth.
    #[arg(long, default_value_t = 1)]
    pub views: u32,
    /// Renders per method and view; the best total frame time is reported.
    #[arg(long, default_value_t = 3)]
    pub repeat: u32,
    /// CPU renderers to measure, comma-separated: walk (ray walker), pt
    /// (projected tetrahedra).
    #[arg(long, default_value = "walk,pt", value_delimiter = ',')]
    pub renderers: Vec<CpuRenderer>,
    /// Visibility order for PT (auto: MPVO on convex meshes, MPVONC otherwise).
    #[arg(long, default_value = "auto")]
    pub sort: SortMethod,
    /// Also run the walker with adaptive image-space sampling at these
    /// tolerances (`tetview render --adaptive`), each a row of its own
    /// ("walk~TOL"), so its speed is set against its error.
    #[arg(long, value_delimiter = ',', value_name = "TOL,...")]
    pub adaptive: Vec<f32>,
    /// Pareto plot PNG: image error against frame time, one series per method.
    #[arg(short, long, value_name = "pareto.png")]
    pub output: Option<PathBuf>,
    /// Every row as JSON.
    #[arg(long, value_name = "out.json")]
    pub json: Option<PathBuf>,
    /// Where reference renders are cached (default: `bench-cache/` next to
    /// -o, else next to --json, else in the current directory).
    #[arg(long)]
    pub cache: Option<PathBuf>,
}

/// 64-bit FNV-1a: a stable content key for the reference cache (not a
/// security hash; a collision only reuses a wrong cached image).
fn fnv1a(bytes: &[u8], mut h: u64) -> u64 {
    for &b in bytes {
        h ^= u64::from(b);
        h = h.wrapping_mul(0x0100_0000_01b3);
    }
    h
}
const FNV_OFFSET: u64 = 0xcbf2_9ce4_8422_2325;

/// The methods to measure and notes on the ones left out.
pub fn select_methods(spec: &str, has_widgets: bool) -> Result<(Vec<Method>, Vec<String>)> {
    let asked: Vec<Method> = if spec == "all" {
        Method::ALL.to_vec()
    } else {
        spec.split(',').map(|s| s.trim().parse::<Method>().kind(ExitKind::Usage)).collect::<Result<_>>()?
    };
    let mut notes = vec![];
    let mut out = vec![];
    for m in asked {
        if m.is_bivariate() {
            notes.push(if has_widgets {
                format!("{m}: skipped (the reference ray caster integrates the 1D TF only; no 2D-widget ground truth)")
            } else {
                format!("{m}: skipped (the TF has no 2D widgets)")
            });
        } else if !out.contains(&m) {
            out.push(m);
        }
    }
    if has_widgets && !out.is_empty() {
        notes.push("1D methods and the reference use the TF's 1D part (its widgets dropped)".into());
    }
    Ok((out, notes))
}

/// One method on one view of one bundle.
#[derive(Debug, Clone)]
struct Sample {
    bake_s: f64,
    sort_s: f64,
    /// Binning and tile rasterization.
    raster_s: f64,
    total_s: f64,
    /// The same view drawn again (what a new TF that culls the same cells,
    /// or a new method, costs: the kept per-tet setup, no sort).
    same_view_s: f64,
    tets_drawn: usize,
    /// Process CPU seconds (all threads) over wall seconds of the best frame.
    cpu_per_wall: f64,
    rmse: f64,
    max_abs: f64,
    max_8bit: u8,
}

/// One table row: a method on a bundle, over all views.
struct Row {
    bundle: String,
    method: Method,
    renderer: CpuRenderer,
    adaptive: Option<f32>,
    views: Vec<Sample>,
}

/// A renderer as the bench's rows name it: `walk`, `pt`, or `walk~TOL`
/// with adaptive sampling.
fn variant_label(kind: CpuRenderer, adaptive: Option<f32>) -> String {
    match adaptive {
        Some(tol) => format!("{kind}~{tol}"),
        None => kind.to_string(),
    }
}

impl Row {
    fn mean(&self, f: impl Fn(&Sample) -> f64) -> f64 {
        self.views.iter().map(f).sum::<f64>() / self.views.len().max(1) as f64
    }
    fn bake_s(&self) -> f64 {
        self.views.first().map_or(0.0, |s| s.bake_s)
    }
    fn total_s(&self) -> f64 {
        self.mean(|s| s.total_s)
    }
    fn tets_per_s(&self) -> f64 {
        self.mean(|s| if s.total_s > 0.0 { s.tets_drawn as f64 / s.total_s } else { 0.0 })
    }
    /// RMSE over every pixel of every view (views have the same size).
    fn rmse(&self) -> f64 {
        self.mean(|s| s.rmse * s.rmse).sqrt()
    }
    fn max_abs(&self) -> f64 {
        self.views.iter().map(|s| s.max_abs).fold(0.0, f64::max)
    }
    fn max_8bit(&self) -> u8 {
        self.views.iter().map(|s| s.max_8bit).max().unwrap_or(0)
    }
}

fn cache_dir(args: &BenchArgs) -> PathBuf {
    if let Some(c) = &args.cache {
        return c.clone();
    }
    let beside = args.output.as_ref().or(args.json.as_ref()).and_then(|p| p.parent()).map(Path::to_path_buf);
    beside.unwrap_or_default().join("bench-cache")
}

/// The reference image of `view`, from the cache or rendered now (and cached).
fn reference_image(
    bundle: &Bundle,
    tf: &TransferFunction,
    spec: &ViewSpec,
    path: &Path,
    label: &str,
) -> Result<(Image, Option<f64>)> {
    if let Ok(img) = Image::read_npy(path) {
        if [img.width(), img.height()] == spec.size {
            return Ok((img, None));
        }
    }
    let t = Instant::now();
    let mut renderer = ReferenceFrameRenderer::new(bundle)?;
    let bar = indicatif::ProgressBar::new(u64::from(spec.size[1]));
    bar.set_style(
        indicatif::ProgressStyle::with_template("{msg} {bar:30} {pos}/{len} rows (eta {eta})").expect("valid template"),
    );
    bar.set_message(format!("reference {label}"));
    let look = Look::exact(tf.clone());
    let frame = renderer.render(&look, &FrameRequest::new(spec.clone()), &|done, _| bar.set_position(done as u64))?;
    bar.finish_and_clear();
    let (img, FrameStats::Reference { stats, .. }) = (frame.image, frame.stats) else {
        unreachable!("the reference renderer reports reference statistics")
    };
    if stats.walk_failures > 0 {
        eprintln!("warning: {label}: {} reference ray walks failed; those rays are incomplete", stats.walk_failures);
    }
    if let Some(dir) = path.parent() {
        std::fs::create_dir_all(dir).with_context(|| format!("creating {}", dir.display()))?;
    }
    img.write_npy(path)?;
    Ok((img, Some(t.elapsed().as_secs_f64())))
}

pub fn run(args: &BenchArgs) -> Result<()> {
    if args.views == 0 || args.repeat == 0 {
        return Err(usage("--views and --repeat must be at least 1"));
    }
    if args.renderers.is_empty() {
        return Err(usage("--renderers: name at least one of walk, pt"));
    }
    for &tol in &args.adaptive {
        tet_engine::check_adaptive(tol, CpuRenderer::Walk).context("--adaptive")?;
    }
    if !args.adaptive.is_empty() && !args.renderers.contains(&CpuRenderer::Walk) {
        return Err(usage("--adaptive: the walker only; add walk to --renderers"));
    }
    // Each renderer as it is, then the walker at each adaptive tolerance.
    let variants: Vec<(CpuRenderer, Option<f32>)> = args
        .renderers
        .iter()
        .map(|&k| (k, None))
        .chain(args.adaptive.iter().map(|&tol| (CpuRenderer::Walk, Some(tol))))
        .collect();
    // The bytes key the cache; the TF comes from the one loader.
    let tf_text = std::fs::read(&args.tf)
        .map_err(|e| tet_preint::TfError::Read { source: tet_preint::IoFailure::new(e), path: args.tf.clone() })?;
    let tf_file = tet_preint::load_tf(&args.tf)?;
    let has_widgets = !tf_file.widgets().is_empty();
    let (methods, notes) = select_methods(&args.methods, has_widgets)?;
    let cache = cache_dir(args);
    let threads = rayon::current_num_threads();
    let mut rows: Vec<Row> = vec![];
    let mut out = String::new();
    for note in &notes {
        out.push_str(&format!("note: {note}\n"));
    }
    for bundle_path in &args.bundles {
        let bundle_bytes = std::fs::read(bundle_path)
            .with_context(|| format!("reading {}", bundle_path.display()))
            .kind(ExitKind::Input)?;
        let bundle = Bundle::read(bundle_path)?;
        let name = bundle_path.file_stem().map_or("bundle".into(), |s| s.to_string_lossy().into_owned());
        let tf = tet_preint::tf_for_bundle(&tf_file.without_widgets(), &bundle)?;
        let scene = Scene::from_bundle(&bundle).with_context(|| format!("in {}", bundle_path.display()))?;
        let (lo, hi) = scene.bounds();
        let z_up = tet_render::camera::bundle_is_z_up(&bundle.meta);
        let base = ViewSpec::default_for(lo, hi, args.size, z_up, None)?;
        let views: Vec<ViewSpec> =
            (0..args.views).map(|i| base.orbit(360.0 * f64::from(i) / f64::from(args.views), 0.0, 1.0)).collect();
        let key = fnv1a(&tf_text, fnv1a(&bundle_bytes, FNV_OFFSET));
        drop(bundle_bytes);

        let mut references = vec![];
        for (i, v) in views.iter().enumerate() {
            let vkey = fnv1a(v.to_json().as_bytes(), key);
            let path = cache.join(format!("ref-{name}-v{i}-{}x{}-{vkey:016x}.npy", v.size[0], v.size[1]));
            let (img, took) = reference_image(&bundle, &tf, v, &path, &format!("{name} view {i}"))?;
            match took {
                Some(s) => eprintln!("reference {name} view {i}: {s:.2} s → {}", path.display()),
                None => eprintln!("reference {name} view {i}: cached {}", path.display()),
            }
            references.push(img);
        }

        // The engine's CPU renderer: the culled cells are the TF's, so the
        // cull mask is computed once and kept across methods.
        let mut r = CpuFrameRenderer::from_scene(scene);
        let first = rows.len();
        let mut culled = 0.0;
        let mut sort_used = String::new();
        for &m in &methods {
            let t = Instant::now();
            let look = Look::bake(&bundle, m, tf.clone())?;
            let bake_s = t.elapsed().as_secs_f64();
            for &(kind, adaptive) in &variants {
                let mut samples = vec![];
                for (v, reference) in views.iter().zip(&references) {
                    let req = FrameRequest { cpu: kind, sort: args.sort, adaptive, ..FrameRequest::new(v.clone()) };
                    let frame = |r: &mut CpuFrameRenderer| -> Result<(Image, RenderStats)> {
                        let f = r.render(&look, &req, &|_, _| {})?;
                        let FrameStats::Cpu(st) = f.stats else {
                            unreachable!("the CPU renderer reports CPU statistics")
                        };
                        Ok((f.image, st))
                    };
                    let mut best: Option<(Image, RenderStats, f64)> = None;
                    for _ in 0..args.repeat {
                        // Every frame redoes the view, as a camera move does.
                        r.forget_view();
                        let c0 = process_cpu_seconds();
                        let (img, st) = frame(&mut r)?;
                        let cpu = process_cpu_seconds() - c0;
                        if best.as_ref().is_none_or(|b| st.total_seconds < b.1.total_seconds) {
                            best = Some((img, st, cpu));
                        }
                    }
                    // Then unchanged: best of `repeat` frames from the kept state.
                    let same_view_s = (0..args.repeat)
                        .map(|_| frame(&mut r).map(|(_, st)| st.total_seconds))
                        .collect::<Result<Vec<_>>>()?
                        .into_iter()
                        .fold(f64::INFINITY, f64::min);
                    let (img, st, cpu) = best.expect("repeat ≥ 1");
                    if let Some(why) = &st.walk_fallback {
                        eprintln!("note: {name} {m} walk: drawn by pt: {why}");
                    }
                    culled = st.fraction_culled;
                    if kind == CpuRenderer::Pt {
                        sort_used = st.sort_method.clone();
                    }
                    let d = diff(reference, &img)?;
                    let (max_8bit, _) = crate::diff::max_8bit_reinhard(reference, &img, [0.0; 3])?;
                    samples.push(Sample {
                        bake_s,
                        sort_s: st.sort_seconds,
                        raster_s: st.project_seconds + st.raster_seconds,
                        total_s: st.total_seconds,
                        same_view_s,
                        tets_drawn: st.tets_drawn,
                        cpu_per_wall: cpu / st.total_seconds.max(1e-9),
                        rmse: d.rmse,
                        max_abs: d.max_abs,
                        max_8bit,
                    });
                }
                rows.push(Row { bundle: name.clone(), method: m, renderer: kind, adaptive, views: samples });
            }
            eprintln!("{name} {m}: done");
        }

        out.push_str(&format!(
            "\n### {} — {} tets, {}x{}, {} view(s), PT sort {}, {:.1}% culled, best of {} frames, {} threads\n\n",
            bundle_path.display(),
            bundle.mesh.tets.len(),
            args.size[0],
            args.size[1],
            args.views,
            sort_used,
            100.0 * culled,
            args.repeat,
            threads
        ));
        out.push_str(
            "| method | renderer | bake ms | sort ms | raster ms | frame ms | M tets/s | CPU/wall | same-view ms | M tets/s | RMSE (linear) | max abs (linear) | 8-bit max |\n",
        );
        out.push_str("|---|---|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|\n");
        for row in &rows[first..] {
            out.push_str(&format!(
                "| {} | {} | {:.1} | {:.1} | {:.1} | {:.1} | {:.2} | {:.2} | {:.1} | {:.2} | {:.2e} | {:.2e} | {} |\n",
                row.method,
                variant_label(row.renderer, row.adaptive),
                row.bake_s() * 1e3,
                row.mean(|s| s.sort_s) * 1e3,
                row.mean(|s| s.raster_s) * 1e3,
                row.total_s() * 1e3,
                row.tets_per_s() / 1e6,
                row.mean(|s| s.cpu_per_wall),
                row.mean(|s| s.same_view_s) * 1e3,
                row.mean(|s| s.tets_drawn as f64 / s.same_view_s.max(1e-12)) / 1e6,
                row.rmse(),
                row.max_abs(),
                row.max_8bit()
            ));
        }
    }
    print!("{out}");

    if let Some(path) = &args.json {
        let v = json!({
            "tf": args.tf.display().to_string(),
            "size": args.size,
            "views": args.views,
            "repeat": args.repeat,
            "threads": threads,
            "notes": notes,
            "rows": rows.iter().map(|r| json!({
                "bundle": r.bundle,
                "method": r.method.id(),
                "renderer": r.renderer.id(),
                "adaptive": r.adaptive,
                "bake_seconds": r.bake_s(),
                "frame_seconds": r.total_s(),
                "tets_per_second": r.tets_per_s(),
                "rmse": r.rmse(),
                "max_abs": r.max_abs(),
                "max_8bit": r.max_8bit(),
                "views": r.views.iter().map(|s| json!({
                    "sort_seconds": s.sort_s,
                    "raster_seconds": s.raster_s,
                    "frame_seconds": s.total_s,
                    "same_view_frame_seconds": s.same_view_s,
                    "tets_drawn": s.tets_drawn,
                    "cpu_per_wall": s.cpu_per_wall,
                    "rmse": s.rmse,
                    "max_abs": s.max_abs,
                    "max_8bit": s.max_8bit,
                })).collect::<Vec<_>>(),
            })).collect::<Vec<_>>(),
        });
        std::fs::write(path, serde_json::to_string_pretty(&v)?)
            .with_context(|| format!("writing {}", path.display()))?;
        eprintln!("wrote {}", path.display());
    }
    if let Some(path) = &args.output {
        let series = |y: &dyn Fn(&Row) -> f64| -> Vec<Series> {
            methods
                .iter()
                .flat_map(|m| variants.iter().map(move |&(k, a)| (*m, k, a)))
                .map(|(m, k, a)| Series {
                    name: format!("{m} {}", variant_label(k, a)),
                    points: rows
                        .iter()
                        .filter(|r| r.method == m && r.renderer == k && r.adaptive == a)
                        .map(|r| Point {
                            x: r.total_s(),
                            y: y(r),
                            // One bundle: the legend says it all.
                            label: (args.bundles.len() > 1).then(|| r.bundle.clone()),
                        })
                        .collect(),
                })
                .collect()
        };
        let plot = |title: &str, y_label: &str, y: &dyn Fn(&Row) -> f64| {
            ScatterPlot {
                title: title.into(),
                x_label: "frame time [s]".into(),
                y_label: y_label.into(),
                log_x: true,
                log_y: true,
                series: series(y),
                pareto: true,
            }
            .draw(1000, 520)
        };
        let a = plot("image RMSE against frame time", "RMSE, linear RGBA", &|r| r.rmse());
        let b = plot("largest image error against frame time", "max abs error, linear RGBA", &|r| r.max_abs());
        a.above(&b).write_png(path).with_context(|| format!("writing {}", path.display()))?;
        eprintln!("wrote {}", path.display());
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn method_selection_and_hash() {
        let (m, notes) = select_methods("all", false).unwrap();
        assert_eq!(m.len(), 8);
        assert!(m.contains(&Method::Exact) && !m.iter().any(|m| m.is_bivariate()));
        assert_eq!(notes.len(), 2);
        let (m, notes) = select_methods("table3d, pt-linear,table3d", true).unwrap();
        assert_eq!(m, vec![Method::Table3d, Method::PtLinear]);
        assert_eq!(notes.len(), 1);
        assert!(select_methods("table4d", false).is_err());
        assert_ne!(fnv1a(b"a", FNV_OFFSET), fnv1a(b"b", FNV_OFFSET));
        assert_eq!(fnv1a(b"", FNV_OFFSET), FNV_OFFSET);
    }
}
