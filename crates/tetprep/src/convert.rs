//! `tetprep convert`: read → tetrahedralize → validate → adjacency → write.

use crate::cli::{ConvertArgs, EndianArg, ModeArg, NanArg, SplitArg};
use anyhow::Context;
use indicatif::{ProgressBar, ProgressStyle};
use serde_json::json;
use std::time::{Duration, Instant};
use tet_bundle::{Bundle, BundleMeta};
use tet_cli::{usage, ExitKind, KindExt};
use tet_delaunay::{triangulate_cloud, CloudMode, DelaunayOptions};
use tet_io::cursor::Endian;
use tet_io::{plot3d::Plot3dOptions, raw::RawSpec, ReadOptions};
use tet_mesh::{build_adjacency, tetrahedralize_merged, ConvertOptions, NanPolicy, SplitMode, Step};

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
struct Progress {
    bar: Option<ProgressBar>,
}

impl Progress {
    fn new(quiet: bool) -> Progress {
        if quiet {
            return Progress { bar: None };
        }
        let bar = ProgressBar::new_spinner();
        bar.set_style(ProgressStyle::with_template("{spinner} {msg} ({elapsed})").expect("valid template"));
        bar.enable_steady_tick(Duration::from_millis(1000));
        Progress { bar: Some(bar) }
    }

    fn step(&self, msg: &'static str) {
        if let Some(b) = &self.bar {
            b.set_message(msg);
        }
    }

    fn set(&self, msg: String) {
        if let Some(b) = &self.bar {
            b.set_message(msg);
        }
    }

    fn finish(&self) {
        if let Some(b) = &self.bar {
            b.finish_and_clear();
        }
    }
}

pub fn run(args: ConvertArgs) -> anyhow::Result<()> {
    let opts = read_options(&args)?;
    let progress = Progress::new(args.quiet || args.json);
    let mut timings: Vec<(&str, f64)> = Vec::new();
    let t_all = Instant::now();

    progress.step("reading");
    let t = Instant::now();
    // A time series: the first step is converted as any input, the others
    // are mapped onto its mesh.
    let series = tet_io::series::series_steps(&args.input, &opts, args.all_steps)
        .with_context(|| format!("reading the time steps of {} failed", args.input.display()))?;
    let mut source = match &series {
        Some(steps) => {
            let first = &steps[0];
            tet_io::read_file(&first.path, &ReadOptions { time_step: first.time_step, ..opts.clone() })
                .with_context(|| format!("reading time step 0 ({}) failed", first.label))?
        }
        None => tet_io::read_file(&args.input, &opts).context("reading the input failed")?,
    };
    timings.push(("read", t.elapsed().as_secs_f64()));

    // A point cloud (points, no cells) is tetrahedralized first; from then
    // on it is a mesh like any other.
    let mut cloud = if source.num_cells() == 0 && !source.points.is_empty() {
        progress.step("tetrahedralizing the point cloud");
        let t = Instant::now();
        let mode = match args.mode {
            ModeArg::Delaunay => CloudMode::Delaunay,
            ModeArg::Layered => CloudMode::Layered,
        };
        let dopts = DelaunayOptions { max_circumradius: args.max_circumradius };
        let r = triangulate_cloud(&mut source, mode, &dopts, args.merge_tolerance, matches!(args.nan, NanArg::Drop))
            .with_context(|| format!("tetrahedralizing the points of {} failed", args.input.display()))?;
        timings.push(("tetrahedralize_points", t.elapsed().as_secs_f64()));
        Some(r)
    } else {
        if args.max_circumradius.is_some() || matches!(args.mode, ModeArg::Layered) {
            return Err(usage(format!(
                "--mode layered and --max-circumradius apply to point clouds; {} has cells",
                args.input.display()
            )));
        }
        None
    };
    if cloud.is_some() && series.is_some() {
        return Err(usage(format!(
            "{} is a time series of point clouds; a series must share one mesh (convert one step at a time)",
            args.input.display()
        )));
    }

    let convert_opts = ConvertOptions {
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
    };
    let mut step_start = (Instant::now(), "select_scalar");
    let mut step_times: Vec<(&str, f64)> = Vec::new();
    // A cloud's points were merged before its triangulation: not again.
    let merged_into = cloud.as_mut().map(|c| std::mem::take(&mut c.merged_into));
    let (mesh, report) = tetrahedralize_merged(&source, &convert_opts, merged_into, &mut |s| {
        let (msg, key) = match s {
            Step::Merge => ("merging duplicate points", "merge"),
            Step::Split => ("splitting cells into tets", "split"),
            Step::Validate => ("validating tets", "validate"),
        };
        step_times.push((step_start.1, step_start.0.elapsed().as_secs_f64()));
        step_start = (Instant::now(), key);
        progress.step(msg)
    })
    .with_context(|| format!("converting {} failed", args.input.display()))?;
    step_times.push((step_start.1, step_start.0.elapsed().as_secs_f64()));
    timings.extend(step_times);

    progress.step("building face adjacency");
    let t = Instant::now();
    // A Delaunay cloud hands over the adjacency its insertion kept, checked
    // in one pass, when the conversion kept its tets as they were (same
    // order, same vertex order); otherwise it is built from the faces.
    let handed = cloud.as_mut().and_then(|c| c.neighbors.take()).filter(|n| {
        n.len() == mesh.tets.len() && report.tet_source_cell.iter().enumerate().all(|(i, &c)| c as usize == i)
    });
    let mut adjacency_source = "built from the faces";
    // Statistics run beside the adjacency, whose face bucketing is serial.
    let (adjacency, stats) = rayon::join(
        || match handed.and_then(|n| tet_mesh::adjacency_from_neighbors(&mesh.points, &mesh.tets, n)) {
            Some(a) => {
                adjacency_source = "handed over by the Delaunay tetrahedralization";
                Ok(a)
            }
            None => build_adjacency(&mesh.points, &mesh.tets),
        },
        || tet_mesh::mesh_stats(&mesh.points, &mesh.tets, &mesh.scalar),
    );
    let adjacency = adjacency.map_err(|e| {
        let cells = match &e {
            tet_mesh::MeshError::NonManifoldFace { tets, .. } => {
                let cells: Vec<String> = tets.iter().map(|&t| report.tet_source_cell[t as usize].to_string()).collect();
                format!(" (they come from input cells {})", cells.join(", "))
            }
            _ => String::new(),
        };
        anyhow::Error::new(e).context(format!("the tets do not form a valid mesh{cells}"))
    })?;
    timings.push(("adjacency_stats", t.elapsed().as_secs_f64()));

    // The other steps' scalars, mapped onto this mesh.
    let steps = match &series {
        Some(list) => {
            let t = Instant::now();
            let mapper = tet_mesh::StepMapper::new(&source, &mesh, &report)?;
            let mut scalars = vec![mesh.scalar.clone()];
            for (k, step) in list.iter().enumerate().skip(1) {
                progress.set(format!("time step {k} of {}: {}", list.len(), step.label));
                let s = tet_io::read_file(&step.path, &ReadOptions { time_step: step.time_step, ..opts.clone() })
                    .with_context(|| format!("reading time step {k} ({}) failed", step.label))?;
                scalars
                    .push(mapper.scalar(&s, &mesh).with_context(|| format!("time step {k} ({}) failed", step.label))?);
            }
            let times = list.iter().map(|s| s.time).collect();
            let labels = list.iter().map(|s| s.label.clone()).collect();
            let steps = tet_bundle::TimeSteps::new(times, scalars, labels)
                .map_err(|e| anyhow::anyhow!("the time steps of {}: {e}", args.input.display()))
                .kind(ExitKind::Input)?;
            timings.push(("time_steps", t.elapsed().as_secs_f64()));
            Some(steps)
        }
        None => None,
    };

    let mut findings: Vec<String> = Vec::new();
    if let Some(st) = &steps {
        let (lo, hi) = st.scalar_range();
        findings.push(format!(
            "time series: {} steps, times {} to {}; scalar '{}' over all steps {lo} to {hi}",
            st.len(),
            st.times()[0],
            st.times()[st.len() - 1],
            mesh.scalar_name
        ));
    }
    let split = if let Some(c) = &cloud {
        match c.mode {
            CloudMode::Delaunay => {
                findings.push(format!(
                    "Delaunay tetrahedralization of {} distinct points: {} tets{}; face adjacency {adjacency_source}",
                    c.distinct_points,
                    c.tets,
                    if c.fills_convex_hull { ", filling the convex hull" } else { "" }
                ));
                if c.removed_cells > 0 {
                    findings.push(format!(
                        "removed {} hull-filling cells with circumradius above {}; the domain is no longer the convex hull",
                        c.removed_cells,
                        args.max_circumradius.unwrap_or(f64::NAN)
                    ));
                }
                "delaunay"
            }
            CloudMode::Layered => {
                findings.push(format!("layered: {} layers × {} columns: {} tets", c.layers, c.columns, c.tets));
                "layered"
            }
        }
    } else if source.blocks.iter().any(|b| matches!(b, tet_mesh::Block::Structured { .. })) {
        match convert_opts.split {
            SplitMode::Five => "5",
            SplitMode::Six => "6",
        }
    } else {
        "6"
    };
    let meta = BundleMeta {
        source_path: args.input.display().to_string(),
        source_format: source.format.clone(),
        source_points: report.source_points as u64,
        source_cells: report.source_cells as u64,
        split_tets: report.split_tets as u64,
        split: split.into(),
        delaunay: cloud.as_ref().is_some_and(|c| c.fills_convex_hull),
        findings: findings.into_iter().chain(report.findings.iter().map(|f| f.to_string())).collect(),
        ..Default::default()
    };
    drop(source);
    progress.step("writing the bundle");
    let mut bundle = Bundle::with_stats(mesh, adjacency, meta, stats);
    if let Some(st) = steps {
        bundle = bundle.with_steps(st).map_err(anyhow::Error::msg)?;
    }
    if let Some(opts) = crate::analysis::requested(&args.analysis) {
        progress.step("analysing the scalar");
        let t = Instant::now();
        let analysis = crate::analysis::analyze(&bundle, &opts)?;
        bundle = bundle.with_analysis(analysis);
        timings.push(("analysis", t.elapsed().as_secs_f64()));
    }
    let t = Instant::now();
    bundle.write(&args.output).context("writing the bundle failed").kind(ExitKind::Output)?;
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
