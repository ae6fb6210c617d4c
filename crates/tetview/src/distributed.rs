//! `tetview render --distributed MANIFEST`: a partition's pieces drawn by
//! one rank each and composited in the k-d tree's visibility order.
//!
//! Under `mpirun` (tetview built with its `mpi` feature) each process is a
//! rank; otherwise the ranks are threads of this process, composited the
//! same way (`tet_distributed::ThreadComm`). Every rank reads the manifest
//! and only its own piece (size and CRC-32 checked), resolves the TF over
//! the whole mesh's scalar range (the manifest's, as one process would over
//! the unsplit bundle) — or, without a TF, builds the automatic TF from the
//! pieces' histograms summed over the ranks (`tet_distributed::reduce`) —
//! frames the default view on the whole mesh's box,
//! and draws its piece over the whole screen with the engine's renderer
//! (the CPU walker, projected tetrahedra, or `--gpu` on the rank's
//! adapter), premultiplied RGBA. The ranks
//! then agree (`tet_distributed::agree`: the first rank's error, or the
//! first request that differs, stops every rank with the same message and
//! exit code) and composite by binary swap front to back; rank 0 writes
//! the PNG, the `.npy`, the view and the statistics.
//!
//! Pieces lie inside their boxes and the boxes tile the mesh's, so the
//! tree's order from the eye is a visibility order and compositing the
//! ranks' images is the single-process image up to f32 rounding — where
//! every ray is walked to its end. Early ray termination stops a ray on
//! the α it gathered in one piece, not in the pieces before it, so a
//! nearly opaque ray keeps up to 1 − opaque α of what one process would
//! have dropped (`--no-early-termination` on both sides compares exactly).

use anyhow::{Context, Result};
use std::path::{Path, PathBuf};
use tet_bundle::manifest::{Manifest, MANIFEST_FILE};
use tet_cli::{usage, ExitKind, KindExt};
use tet_distributed::{agree, composite, reduce, Comm, CompositeStats, DistributedError, ThreadComm};
use tet_engine::{
    CpuFrameRenderer, FrameRenderer, FrameStats, GpuFrameOptions, GpuFrameRenderer, ReferenceFrameRenderer,
};
use tet_gpu::RasterPath;
use tet_preint::{AutoTfOptions, Method, TransferFunction};
use tet_render::{Image, Scene, ViewSpec};

use crate::render::RenderArgs;

/// What one rank drew, kept for rank 0's report.
struct RankFrame {
    image: Image,
    view: ViewSpec,
    lighting: Option<tet_render::Lighting>,
    /// The renderer's statistics as JSON (CPU or GPU).
    stats: serde_json::Value,
    tets_drawn: usize,
    tets_total: usize,
    seconds: f64,
    order: Vec<usize>,
    method: String,
}

/// Rank 0's result: the composited image and what to report.
struct Composited {
    image: Image,
    frame: RankFrame,
    composite: CompositeStats,
    ranks: usize,
}

/// The manifest file: `path` itself, or `path/manifest.json` for a directory.
fn manifest_path(path: &Path) -> PathBuf {
    if path.is_dir() {
        path.join(MANIFEST_FILE)
    } else {
        path.to_path_buf()
    }
}

/// How many ranks `mpirun` started this process among, from the launcher's
/// environment (Open MPI, MPICH/PMI, PMIx); `None` outside a launcher.
fn launcher_size() -> Option<usize> {
    ["OMPI_COMM_WORLD_SIZE", "PMI_SIZE", "PMIX_SIZE", "MPI_LOCALNRANKS"]
        .iter()
        .find_map(|v| std::env::var(v).ok().and_then(|s| s.trim().parse::<usize>().ok()))
}

pub fn run(args: &RenderArgs) -> Result<()> {
    let path = manifest_path(&args.bundle);
    let under_launcher = launcher_size().is_some_and(|n| n > 1);
    #[cfg(feature = "mpi")]
    if under_launcher {
        let comm = tet_distributed::MpiComm::init()
            .ok_or_else(|| tet_cli::fail(ExitKind::Internal, "MPI was initialized twice"))?;
        return match rank_main(&comm, args, &path) {
            Ok(Some(c)) => write_outputs(args, c),
            Ok(None) => Ok(()),
            Err(e) => {
                // Every rank prints its error, then waits for the others
                // before it exits: mpirun ends the job at the first failing
                // exit, which cut off ranks that had not printed yet.
                let e = tet_cli::report_now("tetview", e);
                let _ = comm.barrier();
                Err(e)
            }
        };
    }
    if under_launcher {
        return Err(usage(format!(
            "--distributed under mpirun ({} ranks), but this tetview was built without MPI: \
             build it with `cargo install --path crates/tetview --features mpi` (Open MPI's libopenmpi-dev), \
             or run one process, whose ranks are threads",
            launcher_size().unwrap_or(0)
        )));
    }
    // One process: one thread rank per piece. The manifest is read first
    // to know how many (each rank reads it again, as MPI ranks do).
    let manifest = Manifest::load(&path, false)?;
    let ranks = manifest.pieces.len();
    let results = ThreadComm::run(ranks, |comm| rank_main(comm, args, &path));
    let mut results = results.into_iter();
    let first = results.next().expect("a manifest has one piece at least");
    // After the agreement every rank has the same error, or none.
    let first = first?;
    write_outputs(args, first.expect("rank 0 holds the image"))
}

/// One rank's whole frame: its piece read, the first agreement (every
/// rank has its piece), the automatic TF from the pieces' summed
/// histograms where no TF is given, its piece drawn, the second agreement
/// (the same request everywhere), compositing. Rank 0 returns the
/// composited image; the others `None`. After each agreement all ranks
/// fail alike or none does.
fn rank_main<C: Comm + ?Sized>(comm: &C, args: &RenderArgs, path: &Path) -> Result<Option<Composited>> {
    let (rank, size) = (comm.rank(), comm.size());
    let loaded = load_piece(rank, size, args, path);
    let state = match &loaded {
        Ok(l) => Ok(format!("manifest={:08x}", l.manifest_crc)),
        Err(e) => Err(encode_error(e)),
    };
    agree(comm, state).map_err(agreed_error)?;
    let loaded = loaded.expect("agreed: every rank read its piece");
    let auto =
        if args.look.lut.is_none() && args.look.tf.is_none() { Some(automatic_tf(comm, &loaded, args)?) } else { None };
    let drawn = draw_piece(rank, loaded, auto, args);
    let state = match &drawn {
        Ok((frame, fingerprint)) => Ok(format!("{fingerprint}\norder={:?}", frame.order)),
        Err(e) => Err(encode_error(e)),
    };
    agree(comm, state).map_err(agreed_error)?;
    let (frame, _) = drawn.expect("agreed: every rank drew");
    let (image, stats) = composite(comm, frame.image.clone(), &frame.order).map_err(agreed_error)?;
    Ok(image.map(|image| Composited { image, frame, composite: stats, ranks: size }))
}

/// A rank's error as it travels to the others: its exit code, a tab, its message.
fn encode_error(e: &anyhow::Error) -> String {
    format!("{}\t{}", ExitKind::of(e).code(), tet_cli::describe(e))
}

/// A failed agreement as the error every rank returns: a rank's own
/// failure keeps its message and exit code; ranks that were given
/// different requests are a usage error; a lost or garbled message is ours.
fn agreed_error(e: DistributedError) -> anyhow::Error {
    match e {
        DistributedError::RankFailed { rank, message } => {
            let (kind, text) = match message.split_once('\t') {
                Some((code, text)) => {
                    let kind = code.parse::<u8>().ok().and_then(|c| ExitKind::ALL.into_iter().find(|k| k.code() == c));
                    (kind.unwrap_or(ExitKind::Internal), text.to_string())
                }
                None => (ExitKind::Internal, message),
            };
            tet_cli::fail(kind, format!("rank {rank}: {text}"))
        }
        e @ DistributedError::Disagree { .. } => tet_cli::fail(ExitKind::Usage, e.to_string()),
        e => tet_cli::fail(ExitKind::Internal, e.to_string()),
    }
}

/// A rank's share: the manifest, its piece (at `--time`), and the
/// manifest file's checksum (part of what ranks agree on).
struct Loaded {
    manifest: Manifest,
    manifest_crc: u32,
    bundle: tet_bundle::Bundle,
}

/// Reads the manifest and piece `rank` (its size and CRC-32 checked).
fn load_piece(rank: usize, size: usize, args: &RenderArgs, path: &Path) -> Result<Loaded> {
    let manifest = Manifest::load(path, false)?;
    if manifest.pieces.len() != size {
        return Err(usage(format!(
            "{} ranks for a partition of {} pieces (one rank a piece): run mpirun -np {} ({})",
            size,
            manifest.pieces.len(),
            manifest.pieces.len(),
            path.display()
        )));
    }
    let (manifest_crc, _) = tet_bundle::manifest::file_crc32(path)
        .with_context(|| format!("reading {}", path.display()))
        .kind(ExitKind::Input)?;
    let dir = path.parent().unwrap_or(Path::new("."));
    let mut bundle = manifest.load_piece(dir, rank)?;
    if let Some(t) = args.time.time {
        let piece = manifest.piece_path(dir, rank);
        bundle.set_time(t).map_err(|e| usage(format!("--time {t}: {e} ({})", piece.display())))?;
    }
    Ok(Loaded { manifest, manifest_crc, bundle })
}

/// What each rank contributes to the automatic TF: its piece's histograms
/// and the finite range of its scalar.
#[derive(serde::Serialize, serde::Deserialize)]
struct Summary {
    hist: tet_analysis::Histograms,
    scalar_min: f64,
    scalar_max: f64,
}

/// The automatic TF one process would build over the unsplit bundle: the
/// pieces' scalar × |∇s| histograms (cut over the source's axes by
/// `tetprep partition`, so they add up to the source's) summed across the
/// ranks, with the whole mesh's scalar range, box and volume. Needs
/// histograms in the pieces (a source analysed with `--histogram`); every
/// rank returns the same TF or the same error.
fn automatic_tf<C: Comm + ?Sized>(comm: &C, loaded: &Loaded, args: &RenderArgs) -> Result<TransferFunction> {
    let rank = comm.rank();
    let mine = (|| -> Result<Vec<u8>> {
        let b = &loaded.bundle;
        let hist = b.analysis.as_ref().and_then(|a| a.histograms.clone()).filter(|h| h.check().is_ok()).ok_or_else(|| {
            usage(format!(
                "piece {rank} has no scalar × |∇s| histogram, which the automatic TF of a partition sums over the pieces: \
                 store one in the source (`tetprep analyze SRC --histogram`) before `tetprep partition`, or pass --tf or --lut"
            ))
        })?;
        let finite = b.mesh.scalar.iter().copied().filter(|v| v.is_finite());
        let (scalar_min, scalar_max) =
            finite.fold((f64::INFINITY, f64::NEG_INFINITY), |(a, c), v| (a.min(v), c.max(v)));
        Ok(serde_json::to_vec(&Summary { hist, scalar_min, scalar_max })?)
    })();
    let summed = reduce(comm, mine.map_err(|e| encode_error(&e)), |parts| {
        let mut all = parts.iter().map(|p| serde_json::from_slice::<Summary>(p).map_err(|e| format!("1\t{e}")));
        let mut total = all.next().expect("one rank at least")?;
        for (k, s) in all.enumerate() {
            let s = s?;
            let h = &mut total.hist;
            if (s.hist.scalar_axis, s.hist.gradient_axis) != (h.scalar_axis, h.gradient_axis) {
                return Err(format!(
                    "{}\tpiece {}'s histogram axes differ from piece 0's: the pieces were not cut from one analysed source; \
                     pass --tf or --lut",
                    ExitKind::Rejected.code(),
                    k + 1
                ));
            }
            h.scalar.iter_mut().zip(&s.hist.scalar).for_each(|(a, b)| *a += b);
            h.joint.iter_mut().zip(&s.hist.joint).for_each(|(a, b)| *a += b);
            h.scalar_below += s.hist.scalar_below;
            h.scalar_above += s.hist.scalar_above;
            h.joint_outside += s.hist.joint_outside;
            h.total_volume += s.hist.total_volume;
            total.scalar_min = total.scalar_min.min(s.scalar_min);
            total.scalar_max = total.scalar_max.max(s.scalar_max);
        }
        serde_json::to_vec(&total).map_err(|e| format!("1\t{e}"))
    })
    .map_err(agreed_error)?;
    let total: Summary = serde_json::from_slice(&summed).context("the summed histograms").kind(ExitKind::Internal)?;
    let root = loaded.manifest.tree.first().expect("a checked manifest has a root").bounds();
    let opts = AutoTfOptions { colormap: args.look.tf_choice.colormap.unwrap_or_default(), ..Default::default() };
    let auto = tet_preint::auto_tf_from_histograms(
        &total.hist,
        (total.scalar_min, total.scalar_max),
        (root.min, root.max),
        loaded.manifest.source.total_volume,
        &opts,
    )?;
    let scale = args.look.tf_choice.opacity_scale;
    let tf = if scale == 1.0 { auto.tf } else { auto.tf.with_opacity_scale(scale)? };
    if rank == 0 {
        eprintln!(
            "note: no --tf: automatic transfer function of the whole partition (the pieces' histograms summed; opacity on the scalar × |∇s| boundaries, {} over {:.4}..{:.4}); --save-tf writes it",
            opts.colormap, auto.color_range.0, auto.color_range.1
        );
        if let Some(p) = &args.look.tf_choice.save_tf {
            std::fs::write(p, tf.to_json())
                .with_context(|| format!("writing {}", p.display()))
                .kind(ExitKind::Output)?;
        }
    }
    Ok(tf)
}

/// Draws piece `rank` over the whole screen with the look and view one
/// process would use for the unsplit bundle; returns the frame and the
/// fingerprint of the request ranks must agree on.
fn draw_piece(
    rank: usize,
    loaded: Loaded,
    auto: Option<TransferFunction>,
    args: &RenderArgs,
) -> Result<(RankFrame, String)> {
    let Loaded { manifest, manifest_crc, bundle: piece } = loaded;
    let (manifest, bundle) = (&manifest, &piece);
    let (tf, method, look) = match auto {
        Some(tf) => {
            let method: Method = args.look.method.parse()?;
            // (The reference integrates the TF exactly: nothing to bake.)
            let look = if args.reference {
                tet_engine::Look::exact(tf.clone())
            } else if args.gpu_bake {
                tet_engine::Look::baked_by_renderer(bundle, tf.clone(), method)?
            } else {
                tet_engine::Look::bake(bundle, method, tf.clone())?
            };
            (tf, method, look)
        }
        None => {
            // A normalized TF spans the whole mesh's range (unless --range).
            let mut look_args = args.look.clone();
            if let Some(tf_path) = &args.look.tf {
                let tf = tet_preint::load_tf(tf_path)?;
                if tf.normalized() && look_args.range.is_none() {
                    let r = &manifest.scalar_range;
                    look_args.range = Some(tet_preint::normalized_tf_range(r.min, r.max));
                }
            }
            let chosen = look_args.resolve(bundle)?;
            let (tf, method) = (chosen.tf.clone(), chosen.method);
            let look = if args.reference {
                tet_engine::Look::exact(tf.clone())
            } else if args.gpu_bake {
                tet_engine::Look::baked_by_renderer(bundle, tf.clone(), method)?
            } else {
                chosen.look(bundle)?
            };
            (tf, method, look)
        }
    };
    if args.gpu {
        crate::gpu::check_args(args, method)?;
    }
    let in_piece = || format!("piece {rank}");
    let root = manifest.tree.first().expect("a checked manifest has a root").bounds();
    let bounds = (root.min, root.max);
    let z_up = tet_render::camera::z_up_data(manifest.source.from_point_cloud(), root.min, root.max);
    let (view, lighting) = args.camera.resolve_lit(&args.lighting, bounds, z_up)?;
    let request = args.frame_request(&view, lighting.as_ref());
    if request.shading.wants_shadows() {
        return Err(usage(
            "--shadows with --distributed: a rank holds only its piece, so its shadows would miss the \
             other pieces' occluders; draw shadowed frames in one process",
        ));
    }
    let order = if view.parallel {
        let d = [0, 1, 2].map(|k| view.focal_point[k] - view.position[k]);
        manifest.front_to_back_parallel(d)
    } else {
        manifest.front_to_back(view.position)
    };
    let (image, stats, tets_drawn, tets_total, seconds) = if args.gpu {
        // The engine's GPU renderer on this rank's adapter (no adapter:
        // exit code 7 on every rank).
        GpuFrameRenderer::supports(method, &request).map_err(|why| usage(format!("--gpu: {why}")))?;
        let raster = match args.gpu_raster {
            crate::gpu::GpuRasterArg::Compute => RasterPath::Compute,
            crate::gpu::GpuRasterArg::Graphics => RasterPath::Graphics,
        };
        let scene = Scene::from_bundle(bundle).with_context(in_piece)?;
        let mut renderer =
            GpuFrameRenderer::new(bundle, scene, GpuFrameOptions { raster }).map_err(crate::gpu::on_cpu_instead)?;
        let frame = renderer.render(&look, &request, &|_, _| {}).map_err(crate::gpu::on_cpu_instead)?;
        let FrameStats::Gpu(g) = &frame.stats else { unreachable!("the GPU renderer reports GPU statistics") };
        let stats = serde_json::json!({
            "renderer": "gpu",
            "device": g.device,
            "raster_path": g.render.raster_path.id(),
            "tets_total": g.tets_total,
            "tets_drawn": g.render.tets_drawn,
            "gpu_seconds": g.render.total_seconds,
        });
        (frame.image, stats, g.render.tets_drawn, g.tets_total, g.render.total_seconds)
    } else if args.reference {
        // The exact reference on the piece: f64 geometry and integration,
        // so the composite is the unsplit reference image to f32 rounding.
        let mut renderer = ReferenceFrameRenderer::new(bundle).with_context(in_piece)?;
        let frame = renderer.render(&look, &request, &|_, _| {})?;
        let (image, FrameStats::Reference { stats, render_seconds }) = (frame.image, frame.stats) else {
            unreachable!("the reference renderer reports reference statistics")
        };
        let tets = bundle.mesh.tets.len();
        let stats = serde_json::json!({
            "renderer": "reference",
            "rays_hit": stats.rays_hit,
            "segments": stats.segments,
            "walk_failures": stats.walk_failures,
            "render_seconds": render_seconds,
        });
        (image, stats, tets, tets, render_seconds)
    } else {
        // The piece's arrays move into the scene: a rank holds them once.
        let scene = Scene::from_bundle_owned(piece).with_context(in_piece)?;
        let mut renderer = CpuFrameRenderer::from_scene(scene);
        let frame = renderer.render(&look, &request, &|_, _| {})?;
        let (image, FrameStats::Cpu(st)) = (frame.image, frame.stats) else {
            unreachable!("the CPU renderer reports CPU statistics")
        };
        (image, serde_json::to_value(&st)?, st.tets_drawn, st.tets_total, st.total_seconds)
    };
    let fingerprint = format!(
        "manifest={:08x}\nview={}\ntf={}\nmethod={}\nrenderer={}\nshading={:?}\nearly={}\ncull={}\nadaptive={:?}",
        manifest_crc,
        serde_json::to_string(&view)?,
        tf.to_json().replace('\n', " "),
        method.id(),
        if args.gpu {
            format!("gpu {:?}", args.gpu_raster)
        } else if args.reference {
            "reference".to_string()
        } else {
            format!("{:?}", args.renderer)
        },
        request.shading,
        request.early_termination,
        request.cull,
        request.adaptive,
    );
    let method = method.id().to_string();
    let frame = RankFrame { image, view, lighting, stats, tets_drawn, tets_total, seconds, order, method };
    Ok((frame, fingerprint))
}

/// Rank 0's outputs, as `tetview render` writes them.
fn write_outputs(args: &RenderArgs, c: Composited) -> Result<()> {
    let display = args.display.display();
    c.image.write_png(&args.output, &display)?;
    if let Some(p) = &args.float {
        c.image.write_npy(p)?;
    }
    if let Some(p) = &args.save_view {
        std::fs::write(p, crate::camera_args::view_json(&c.frame.view, c.frame.lighting.as_ref()))
            .with_context(|| format!("writing {}", p.display()))
            .kind(ExitKind::Output)?;
    }
    let f = &c.frame;
    if args.json {
        let v = serde_json::json!({
            "distributed": true,
            "ranks": c.ranks,
            "order": c.frame.order,
            "method": c.frame.method,
            "rank0": f.stats,
            "composite_seconds": c.composite.seconds,
            "composite_bytes_sent_rank0": c.composite.bytes_sent,
            "composite_bytes_received_rank0": c.composite.bytes_received,
            "output": args.output.display().to_string(),
            "size": c.frame.view.size,
        });
        println!("{}", serde_json::to_string_pretty(&v)?);
    } else {
        eprintln!(
            "{} pieces on {} ranks, composited front to back ({:?}) in {:.3} s; rank 0 drew {} of {} tets in {:.3} s → {}",
            c.ranks,
            c.ranks,
            c.frame.order,
            c.composite.seconds,
            f.tets_drawn,
            f.tets_total,
            f.seconds,
            args.output.display()
        );
    }
    Ok(())
}
