//! `tetprep convert`: read → tetrahedralize → validate → adjacency → write.

use crate::cli::{ConvertArgs, EndianArg, ModeArg, NanArg, SplitArg};
use anyhow::Context;
use indicatif::{ProgressBar, ProgressStyle};
use serde_json::json;
use std::time::{Duration, Instant};
use tet_cli::{usage, ExitKind, KindExt};
use tet_convert::Stage;
use tet_delaunay::CloudMode;
use tet_io::cursor::Endian;
use tet_io::{plot3d::Plot3dOptions, raw::RawSpec, ReadOptions};
use tet_mesh::{ConvertOptions, NanPolicy, SplitMode, Step};

fn endian(e: EndianArg) -> Endian {
    match e {
        EndianArg::Little => Endian::Little,
        EndianArg::Big => Endian::Big,
    }
}

fn read_options(args: &ConvertArgs) -> anyhow::Result<ReadOptions> {
    let raw = match (&args.raw.dims, &args.raw.voxel_type) {
        (Some(dims), Some(ty)) => {
            let Some(scalar_type) = tet_io::raw::parse_scalar_type(ty) else {
                return Err(usage(format!("unknown --type '{ty}'; use one of i8 u8 i16 u16 i32 u32 i64 u64 f32 f64")));
            };
            Some(RawSpec {
                dims: *dims,
                scalar_type,
                endian: args.raw.endian.map(endian).unwrap_or(Endian::Little),
                spacing: args.raw.spacing,
                origin: args.raw.origin,
                header_bytes: args.raw.header_bytes,
                name: "value".into(),
            })
        }
        (None, None) => None,
        _ => {
            return Err(usage(
                "a raw volume needs both --dims NX,NY,NZ and --type T (and --endian for multi-byte types)",
            ))
        }
    };
    let plot3d = Plot3dOptions {
        byte_order: args.plot3d.plot3d_endian.map(endian),
        planes: args.plot3d.plot3d_planes,
        gamma: args.plot3d.gamma,
        ..Plot3dOptions::default()
    };
    Ok(ReadOptions {
        format: args.format,
        q_path: args.plot3d.q.clone(),
        plot3d,
        raw,
        solution: args.solution.clone(),
        time_step: args.time_step,
        columns: args.columns.clone(),
    })
}

/// A spinner that appears only for steps that take over a second.
pub(crate) struct Progress {
    bar: Option<ProgressBar>,
}

impl Progress {
    pub(crate) fn new(quiet: bool) -> Progress {
        if quiet {
            return Progress { bar: None };
        }
        let bar = ProgressBar::new_spinner();
        bar.set_style(ProgressStyle::with_template("{spinner} {msg} ({elapsed})").expect("valid template"));
        bar.enable_steady_tick(Duration::from_millis(1000));
        Progress { bar: Some(bar) }
    }

    pub(crate) fn step(&self, msg: &'static str) {
        if let Some(b) = &self.bar {
            b.set_message(msg);
        }
    }

    pub(crate) fn set(&self, msg: String) {
        if let Some(b) = &self.bar {
            b.set_message(msg);
        }
    }

    pub(crate) fn finish(&self) {
        if let Some(b) = &self.bar {
            b.finish_and_clear();
        }
    }
}

pub fn run(args: ConvertArgs) -> anyhow::Result<()> {
    let opts = read_options(&args)?;
    let progress = Progress::new(args.quiet || args.json);
    let t_all = Instant::now();
    let request = tet_convert::ConvertRequest {
        read: opts,
        convert: ConvertOptions {
            split: match args.split {
                SplitArg::Five => SplitMode::Five,
                SplitArg::Six => SplitMode::Six,
            },
            scalar: args.scalar.clone(),
            nan: match args.nan {
                NanArg::Error => NanPolicy::Error,
                NanArg::Drop => NanPolicy::Drop,
            },
            merge_tolerance_rel: args.merge_tolerance,
            keep_point_fields: !args.scalar_only,
        },
        cloud_mode: match args.mode {
            ModeArg::Delaunay => CloudMode::Delaunay,
            ModeArg::Layered => CloudMode::Layered,
        },
        max_circumradius: args.max_circumradius,
        all_steps: args.all_steps,
        // The mesh is written while its adjacency and statistics are computed.
        stream_to: Some(args.output.clone()),
    };
    let converted = tet_convert::convert(&args.input, &request, &mut |stage| match stage {
        Stage::Reading => progress.step("reading"),
        Stage::TetrahedralizingPoints => progress.step("tetrahedralizing the point cloud"),
        Stage::Mesh(Step::Merge) => progress.step("merging duplicate points"),
        Stage::Mesh(Step::Split) => progress.step("splitting cells into tets"),
        Stage::Mesh(Step::Validate) => progress.step("validating tets"),
        Stage::Adjacency => progress.step("building face adjacency"),
        Stage::TimeStep { index, count, label } => progress.set(format!("time step {index} of {count}: {label}")),
    })?;
    let mut timings = converted.timings;
    progress.step("writing the bundle");
    let mut bundle = converted.bundle;
    if let Some(opts) = crate::analysis::requested(&args.analysis) {
        progress.step("analysing the scalar");
        let t = Instant::now();
        let analysis = crate::analysis::analyze(&bundle, &opts)?;
        bundle = bundle.with_analysis(analysis);
        if let Some(m) = opts.gradients {
            bundle = crate::analysis::with_step_gradients(bundle, m)?;
        }
        timings.push(("analysis", t.elapsed().as_secs_f64()));
    }
    let t = Instant::now();
    // The rest of the bundle after the mesh the conversion has written.
    match converted.stream {
        Some(stream) => stream.finish(&bundle).map(|_| ()),
        None => bundle.write(&args.output),
    }
    .context("writing the bundle failed")
    .kind(ExitKind::Output)?;
    timings.push(("write", t.elapsed().as_secs_f64()));
    let total = t_all.elapsed().as_secs_f64();
    progress.finish();

    if args.json {
        let mut v = crate::info::summary_json(&bundle);
        v["output"] = json!(args.output.display().to_string());
        v["timings_s"] =
            timings.iter().map(|(k, s)| (k.to_string(), json!(s))).collect::<serde_json::Map<_, _>>().into();
        v["timings_s"]["total"] = json!(total);
        v["tets_per_s"] = json!(bundle.mesh.tets.len() as f64 / total);
        println!("{}", serde_json::to_string_pretty(&v)?);
    } else if !args.quiet {
        println!("wrote {}", args.output.display());
        print!("{}", crate::info::summary_text(&bundle));
        println!(
            "time        {total:.3} s ({}), {:.2} M tets/s",
            timings.iter().map(|(k, s)| format!("{k} {s:.3}")).collect::<Vec<_>>().join(", "),
            bundle.mesh.tets.len() as f64 / total / 1e6
        );
    }
    Ok(())
}
