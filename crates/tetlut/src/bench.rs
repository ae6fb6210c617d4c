//! `tetlut bench`: bake time, memory and error against the exact integral of
//! every method over a range of resolutions, and the Pareto plot.
//!
//! Errors are absolute, over the four channels of premultiplied (C, α),
//! against f64 references computed once (in parallel) per segment set and
//! reused for every method: `exact` for the 1D methods, Song et al.'s (2009) adaptive
//! [`reference_segment`] for `biv-*`. Two segment sets: random rays through
//! random cells of the bundle (`sample_cell_segments`) and triples uniform
//! over the baked domain (`uniform_triples`; |∇s| uniform over [0, max]).
//! The table also gives each method's shading cost per segment on one
//! thread (the run-time side of the trade-off the bake-time plot omits).

use std::path::PathBuf;
use std::time::Instant;

use anyhow::{Context, Result};
use rayon::prelude::*;
use serde_json::json;
use tet_plot::{Point, ScatterPlot, Series};
use tet_preint::bivariate::{reference_segment, Seg2};
use tet_preint::{
    integrate_segment_with, uniform_triples, BakeOptions, Baked, Method, Reconstruction, Segment, TableDomain,
    TransferFunction, RECONSTRUCTION_GAP,
};

use crate::common::{describe_res, human_bytes, read_bundle, read_tf, tf_in_data_units, warn_if_constant_scalar};
use tet_cli::{fail, usage, ExitKind, KindExt};

#[derive(Debug, clap::Args)]
pub struct BenchArgs {
    /// Bundle whose cells the segments are drawn from and whose domain is baked.
    #[arg(long, value_name = "B.tetb")]
    pub bundle: PathBuf,
    /// Transfer function (formats/tf.md JSON or a ParaView preset; a
    /// normalized one is mapped onto the bundle's scalar range).
    #[arg(long, value_name = "tf.json")]
    pub tf: PathBuf,
    /// Methods: all, or a comma-separated list of ids (exact is the reference).
    #[arg(long, default_value = "all")]
    pub methods: String,
    /// Segments per set (cells and uniform); biv-* use at most 50 000 (their
    /// adaptive reference is slow).
    #[arg(long, default_value_t = 1_000_000)]
    pub samples: usize,
    /// Fewer, smaller resolutions, one bake each, 20 000 segments: a smoke run.
    #[arg(long)]
    pub quick: bool,
    /// Bakes per configuration; the best time is reported (default 3, quick 1).
    #[arg(long)]
    pub repeat: Option<usize>,
    /// Bake the whole (Sf, Sb) square instead of the bundle's band.
    #[arg(long)]
    pub full_domain: bool,
    /// Pareto plot PNG (error against bake time, and against memory).
    #[arg(short, long, value_name = "pareto.png")]
    pub output: Option<PathBuf>,
    /// Also write every row as JSON.
    #[arg(long, value_name = "out.json")]
    pub json: Option<PathBuf>,
    /// Print the tables of Röttger & Ertl 2002 (Tables 1–2) and Guthe et al. 2002 (Table 4), reproduced on
    /// this machine for this TF and bundle, as markdown (instead of the sweep).
    #[arg(long)]
    pub paper: bool,
}

/// Largest segment count for the bivariate reference.
const BIV_SAMPLES: usize = 50_000;

/// Segments of one set with their references.
struct SegSet {
    name: &'static str,
    segs: Vec<Segment>,
    reference: Vec<[f64; 4]>,
}

/// (rms, max) of `shader` against the references.
fn errors(baked: &Baked, set: &SegSet) -> (f64, f64) {
    let sh = baked.shader();
    let (sum, max) = set
        .segs
        .par_chunks(4096)
        .zip(set.reference.par_chunks(4096))
        .map(|(s, r)| {
            let (mut sum, mut max) = (0.0f64, 0.0f64);
            for (seg, want) in s.iter().zip(r) {
                let got = sh.shade(seg);
                for c in 0..4 {
                    let e = (f64::from(got[c]) - want[c]).abs();
                    sum += e * e;
                    max = max.max(e);
                }
            }
            (sum, max)
        })
        .reduce(|| (0.0, 0.0), |a, b| (a.0 + b.0, a.1.max(b.1)));
    if set.segs.is_empty() {
        return (0.0, 0.0);
    }
    ((sum / (4 * set.segs.len()) as f64).sqrt(), max)
}

fn references_1d(tf: &TransferFunction, segs: &[Segment]) -> Vec<[f64; 4]> {
    segs.par_chunks(1024)
        .flat_map_iter(|c| {
            let mut scratch = Vec::new();
            c.iter()
                .map(|s| {
                    integrate_segment_with(
                        tf,
                        f64::from(s.s_front),
                        f64::from(s.s_back),
                        f64::from(s.len_world),
                        &mut scratch,
                    )
                    .to_array()
                })
                .collect::<Vec<_>>()
        })
        .collect()
}

fn references_2d(tf: &TransferFunction, segs: &[Segment]) -> Vec<[f64; 4]> {
    segs.par_iter().map(|s| reference_segment(tf, &Seg2::from(s), 1e-10).to_array()).collect()
}

/// Nanoseconds per `shade` call on one thread over up to 100 000 segments
/// (best of 3 passes).
fn shade_cost(baked: &Baked, segs: &[Segment]) -> f64 {
    let segs = &segs[..segs.len().min(100_000)];
    if segs.is_empty() {
        return f64::NAN;
    }
    let sh = baked.shader();
    let mut best = f64::INFINITY;
    for _ in 0..3 {
        let t = Instant::now();
        let mut acc = 0.0f32;
        for s in segs {
            acc += sh.shade(s)[3];
        }
        std::hint::black_box(acc);
        best = best.min(t.elapsed().as_secs_f64());
    }
    best * 1e9 / segs.len() as f64
}

/// One benchmark row.
struct Row {
    method: Method,
    res: String,
    res_short: String,
    /// A table3d that looks up in optical depth (marked "(τ)" in `res`).
    optical_depth: bool,
    bake_s: f64,
    memory: usize,
    full_memory: usize,
    /// Single-thread shading cost, ns per segment (cells set).
    shade_ns: f64,
    /// (set name, rms, max) per segment set.
    err: Vec<(&'static str, f64, f64)>,
}

/// The sweep of resolutions for a method: (options, short label).
fn sweep(method: Method, quick: bool) -> Vec<(BakeOptions, String)> {
    let base = BakeOptions::default();
    let pick = |full: &[usize], q: &[usize]| if quick { q.to_vec() } else { full.to_vec() };
    match method {
        Method::Exact => vec![],
        Method::PtLinear | Method::BivExact => vec![(base, "-".into())],
        Method::Table3d | Method::Atlas2d => {
            // The sweep: each resolution as it is (certification off); then
            // table3d's default, certify-and-refine bake (label "cert").
            let mut v: Vec<(BakeOptions, String)> = pick(&[32, 64, 128, 256], &[16, 32])
                .into_iter()
                .filter(|&n| method == Method::Table3d || n <= 128)
                .map(|n| {
                    let mut o = base;
                    o.table3d.n_s = n;
                    o.table3d.n_l = 2 * n;
                    o.certify = tet_preint::CertifyOptions::off();
                    (o, n.to_string())
                })
                .collect();
            if method == Method::Table3d && !quick {
                v.push((base, "cert".into()));
            }
            v
        }
        Method::Partial => pick(&[128, 256, 512, 1024], &[64, 256])
            .into_iter()
            .map(|n| {
                let mut o = base;
                o.psi.res = n;
                (o, n.to_string())
            })
            .collect(),
        Method::Poly1 | Method::Poly2 | Method::Poly4 => pick(&[64, 128, 256, 512], &[32, 64])
            .into_iter()
            .map(|n| (BakeOptions { poly_res: n, ..base }, n.to_string()))
            .collect(),
        Method::BivApprox => {
            // Table side and sub-segment count k (the error is mostly k's).
            let pairs: &[(usize, usize)] =
                if quick { &[(16, 4), (32, 16)] } else { &[(16, 4), (64, 4), (128, 4), (64, 16), (64, 64)] };
            pairs
                .iter()
                .map(|&(n, k)| (BakeOptions { fb_res: n, biv_subsegments: k, ..base }, format!("{n}/k{k}")))
                .collect()
        }
    }
}

pub fn run(args: &BenchArgs) -> Result<()> {
    let tf = read_tf(&args.tf)?;
    let bundle = read_bundle(&args.bundle)?;
    let mut domain =
        TableDomain::from_bundle(&bundle).with_context(|| format!("domain of {}", args.bundle.display()))?;
    if args.full_domain {
        domain = TableDomain::full(domain.s_lo, domain.s_hi, domain.len_max_world).kind(ExitKind::Bake)?;
    }
    warn_if_constant_scalar(&bundle);
    let tf = tf_in_data_units(&tf, &domain, Some(&bundle))?;
    let tf1 = tf.without_widgets();
    if args.paper {
        print!("{}", crate::paper::run(&tf1, &domain, args.quick));
        return Ok(());
    }
    let methods: Vec<Method> = if args.methods == "all" {
        Method::ALL.into_iter().filter(|m| *m != Method::Exact).collect()
    } else {
        args.methods
            .split(',')
            .map(|s| s.trim().parse::<Method>().map_err(|e| usage(e.to_string())))
            .collect::<Result<_>>()?
    };
    let has_widgets = !tf.widgets().is_empty();
    let grads: Option<Vec<f64>> = bundle
        .analysis
        .as_ref()
        .and_then(|a| a.gradients.as_ref())
        .map(|g| g.per_point.iter().map(|v| (v[0] * v[0] + v[1] * v[1] + v[2] * v[2]).sqrt()).collect());
    let mut notes = vec![];
    let methods: Vec<Method> = methods
        .into_iter()
        .filter(|m| {
            if m.is_bivariate() && !has_widgets {
                notes.push(format!("{m}: skipped (the TF has no 2D widgets)"));
                false
            } else if m.is_bivariate() && grads.is_none() {
                notes.push(format!("{m}: skipped (the bundle has no gradients: run tetprep analyze --gradients)"));
                false
            } else {
                true
            }
        })
        .collect();
    if has_widgets && methods.iter().any(|m| !m.is_bivariate()) {
        notes.push("1D methods are measured on the TF's 1D part (its widgets dropped)".into());
    }
    let samples = if args.quick { args.samples.min(20_000) } else { args.samples };
    let repeat = args.repeat.unwrap_or(if args.quick { 1 } else { 3 }).max(1);
    let mesh = &bundle.mesh;
    let t0 = Instant::now();
    let cells: Vec<Segment> =
        tet_analysis::sample_cell_segments(&mesh.points, &mesh.tets, &mesh.scalar, grads.as_deref(), samples, 0x7e71)
            .into_iter()
            .map(|s| Segment {
                s_front: s.s_front as f32,
                s_back: s.s_back as f32,
                grad_front: s.grad_front as f32,
                grad_back: s.grad_back as f32,
                len_world: s.len_world as f32,
            })
            .collect();
    if cells.is_empty() {
        return Err(fail(
            ExitKind::Rejected,
            format!("{}: no segment can be drawn (no cell with volume)", args.bundle.display()),
        ));
    }
    let g_max = grads.as_ref().map_or(0.0, |g| g.iter().copied().fold(0.0, f64::max));
    let mut next = tet_preint::lcg_unit(0x51);
    let uniform: Vec<Segment> = uniform_triples(&domain, samples, 0x7e72)
        .into_iter()
        .map(|t| Segment {
            s_front: t[0],
            s_back: t[1],
            grad_front: (next() * g_max) as f32,
            grad_back: (next() * g_max) as f32,
            len_world: t[2],
        })
        .collect();
    let any_1d = methods.iter().any(|m| !m.is_bivariate());
    let any_2d = methods.iter().any(|m| m.is_bivariate());
    let sets_1d = if any_1d {
        vec![
            SegSet { name: "cells", reference: references_1d(&tf1, &cells), segs: cells.clone() },
            SegSet { name: "uniform", reference: references_1d(&tf1, &uniform), segs: uniform.clone() },
        ]
    } else {
        vec![]
    };
    let sets_2d = if any_2d {
        let n = samples.min(BIV_SAMPLES);
        let (c, u) = (cells[..n.min(cells.len())].to_vec(), uniform[..n].to_vec());
        vec![
            SegSet { name: "cells", reference: references_2d(&tf, &c), segs: c },
            SegSet { name: "uniform", reference: references_2d(&tf, &u), segs: u },
        ]
    } else {
        vec![]
    };
    let ref_s = t0.elapsed().as_secs_f64();
    eprintln!(
        "tetlut bench: {} segments per set ({} for biv-*), references in {:.1} s on {} threads",
        samples,
        samples.min(BIV_SAMPLES),
        ref_s,
        rayon::current_num_threads()
    );
    let total: usize = methods.iter().map(|m| sweep(*m, args.quick).len()).sum();
    let bar = indicatif::ProgressBar::new(total as u64);
    bar.set_style(indicatif::ProgressStyle::with_template("{bar:30} {pos}/{len} {msg}").expect("valid template"));
    let mut rows = vec![];
    for &m in &methods {
        let (tfm, sets) = if m.is_bivariate() { (&tf, &sets_2d) } else { (&tf1, &sets_1d) };
        for (opts, short) in sweep(m, args.quick) {
            bar.set_message(format!("{m} {short}"));
            let mut best = f64::INFINITY;
            let mut baked = None;
            for _ in 0..repeat {
                let t = Instant::now();
                let b = Baked::build(m, tfm, &domain, &opts)
                    .with_context(|| format!("cannot bake {m} {short}"))
                    .kind(ExitKind::Bake)?;
                best = best.min(t.elapsed().as_secs_f64());
                baked = Some(b);
            }
            let baked = baked.expect("repeat ≥ 1");
            let shade_ns = shade_cost(&baked, &sets[0].segs);
            let err = sets
                .iter()
                .map(|s| {
                    let (rms, max) = errors(&baked, s);
                    (s.name, rms, max)
                })
                .collect();
            // Which lookup the table chose (formats/lut.md, "Lookup").
            let optical_depth =
                matches!(&baked, Baked::Table3d(t) if t.reconstruction() == Reconstruction::OpticalDepth);
            let res = match &baked {
                // The certified bake's own resolution and lookup.
                Baked::Table3d(t) if t.certificate().is_some() => {
                    let c = t.certificate().expect("checked");
                    format!(
                        "{}x{}x{} {} {}{}{}",
                        t.params().n_s,
                        t.params().n_s,
                        t.params().n_l,
                        t.params().precision,
                        if c.certified { "certified" } else { "NOT certified" },
                        if c.split_at_tf_nodes { ", split" } else { "" },
                        if c.exact_intervals.is_empty() {
                            String::new()
                        } else {
                            format!(", {} exact intervals", c.exact_intervals.len())
                        }
                    )
                }
                _ => describe_res(m, &opts),
            };
            rows.push(Row {
                method: m,
                res: if optical_depth { format!("{res} (τ)") } else { res },
                optical_depth,
                res_short: short,
                bake_s: best,
                memory: baked.memory_bytes(),
                full_memory: baked.full_memory_bytes(),
                shade_ns,
                err,
            });
            bar.inc(1);
        }
    }
    bar.finish_and_clear();

    println!(
        "bundle {} ({} tets); domain s in [{:.6}, {:.6}], |Sf-Sb| <= {:.6}, l <= {:.6}",
        args.bundle.display(),
        mesh.tets.len(),
        domain.s_lo,
        domain.s_hi,
        domain.max_ds,
        domain.len_max_world
    );
    println!(
        "tf {}; {} segments per set; bake time = best of {}; {} threads",
        args.tf.display(),
        samples,
        repeat,
        rayon::current_num_threads()
    );
    for n in &notes {
        println!("note: {n}");
    }
    if rows.iter().any(|r| r.optical_depth) {
        println!("note: (τ): the table3d looks up in optical depth (its reconstruction gap > {RECONSTRUCTION_GAP:e}; formats/lut.md), the others trilinearly");
    }
    println!();
    println!(
        "| method | resolution | bake ms | memory | full domain | shade ns | cells RMS | cells max | uniform RMS | uniform max |"
    );
    println!("|---|---|---:|---:|---:|---:|---:|---:|---:|---:|");
    for r in &rows {
        let e = |i: usize| r.err.get(i).map_or((f64::NAN, f64::NAN), |e| (e.1, e.2));
        println!(
            "| {} | {} | {:.2} | {} | {} | {:.0} | {:.2e} | {:.2e} | {:.2e} | {:.2e} |",
            r.method,
            r.res,
            r.bake_s * 1e3,
            human_bytes(r.memory),
            human_bytes(r.full_memory),
            r.shade_ns,
            e(0).0,
            e(0).1,
            e(1).0,
            e(1).1
        );
    }

    if let Some(path) = &args.json {
        let v = json!({
            "bundle": args.bundle.display().to_string(),
            "tf": args.tf.display().to_string(),
            "domain": domain,
            "samples": samples,
            "biv_samples": samples.min(BIV_SAMPLES),
            "repeat": repeat,
            "threads": rayon::current_num_threads(),
            "notes": notes,
            "rows": rows.iter().map(|r| json!({
                "method": r.method.id(),
                "resolution": r.res,
                "bake_seconds": r.bake_s,
                "memory_bytes": r.memory,
                "full_domain_memory_bytes": r.full_memory,
                "shade_ns_per_segment": r.shade_ns,
                "errors": r.err.iter().map(|e| json!({"set": e.0, "rms": e.1, "max": e.2})).collect::<Vec<_>>(),
            })).collect::<Vec<_>>(),
        });
        std::fs::write(path, serde_json::to_string_pretty(&v)?)
            .with_context(|| format!("writing {}", path.display()))
            .kind(ExitKind::Output)?;
    }
    if let Some(path) = &args.output {
        let series = |x: &dyn Fn(&Row) -> f64| -> Vec<Series> {
            methods
                .iter()
                .map(|m| Series {
                    name: m.id().into(),
                    points: rows
                        .iter()
                        .filter(|r| r.method == *m)
                        .map(|r| Point {
                            x: x(r),
                            y: r.err.get(1).map_or(f64::NAN, |e| e.2),
                            label: Some(r.res_short.clone()),
                        })
                        .collect(),
                })
                .collect()
        };
        let a = ScatterPlot {
            title: "max |error| (uniform over the domain) against bake time".into(),
            x_label: "bake time [s]".into(),
            y_label: "max |error| of (C, alpha)".into(),
            log_x: true,
            log_y: true,
            series: series(&|r| r.bake_s),
            pareto: true,
        }
        .draw(1000, 520);
        let b = ScatterPlot {
            title: "max |error| (uniform over the domain) against memory".into(),
            x_label: "table memory [bytes]".into(),
            y_label: "max |error| of (C, alpha)".into(),
            log_x: true,
            log_y: true,
            series: series(&|r| r.memory as f64),
            pareto: true,
        }
        .draw(1000, 520);
        a.above(&b).write_png(path).map_err(anyhow::Error::new).kind(ExitKind::Output)?;
        eprintln!("wrote {}", path.display());
    }
    Ok(())
}
