//! `tetprep analyze` and the analysis options of `convert`; the analysis
//! part of `info`.

use crate::cli::{AnalysisArgs, GradientArg};
use anyhow::Context;
use serde_json::{json, Value};
use std::fmt::Write as _;
use std::path::Path;
use std::time::Instant;
use tet_analysis::{Analysis, AnalysisOptions, Analyzer, GradientMethod, HistogramOptions};
use tet_bundle::Bundle;
use tet_cli::{ExitKind, KindExt};

pub fn method(g: GradientArg) -> GradientMethod {
    match g {
        GradientArg::Lsq => GradientMethod::LeastSquares,
        GradientArg::TetAverage => GradientMethod::TetAverage,
    }
}

pub fn histogram_options(a: &AnalysisArgs) -> HistogramOptions {
    HistogramOptions {
        scalar_bins: a.bins[0],
        gradient_bins: a.bins[1],
        scalar_range: a.scalar_range,
        gradient_range: a.gradient_range,
        ..Default::default()
    }
}

/// The options `args` ask for, or `None` when they ask for nothing.
pub fn requested(args: &AnalysisArgs) -> Option<AnalysisOptions> {
    (args.gradients || args.histogram).then(|| AnalysisOptions {
        gradients: args.gradients.then(|| method(args.gradient_method)),
        histogram: args.histogram.then(|| histogram_options(args)),
        ..Default::default()
    })
}

/// Runs the analysis on a bundle's mesh.
pub fn analyze(bundle: &Bundle, opts: &AnalysisOptions) -> anyhow::Result<Analysis> {
    let an = Analyzer::from_mesh(&bundle.mesh).context("the bundle's mesh cannot be analysed")?;
    Ok(an.analyze(opts)?)
}

/// A time series' bundle with every step's per-vertex gradients by
/// `method` (the `GRAD` sections), so a time's gradients are read, not
/// computed, by every renderer; a bundle without steps is returned as it is.
pub fn with_step_gradients(mut bundle: Bundle, method: tet_analysis::GradientMethod) -> anyhow::Result<Bundle> {
    let Some(steps) = bundle.steps.take() else { return Ok(bundle) };
    let mesh = &bundle.mesh;
    let per_step = (0..steps.len())
        .map(|k| {
            let an = Analyzer::new(&mesh.points, &mesh.tets, steps.scalar(k))
                .with_context(|| format!("time step {k} (time {}) cannot be analysed", steps.times()[k]))?;
            Ok(an.vertex_gradients(method).to_vec())
        })
        .collect::<anyhow::Result<Vec<_>>>()?;
    let steps = steps.with_gradients(method, per_step).map_err(anyhow::Error::msg)?;
    bundle.with_steps(steps).map_err(anyhow::Error::msg)
}

pub fn run_analyze(path: &Path, output: Option<&Path>, args: &AnalysisArgs, as_json: bool) -> anyhow::Result<()> {
    let bundle = Bundle::read(path)?;
    // Keep what the bundle already has: its gradient method and histogram axes.
    let old = bundle.analysis.as_ref();
    let gradients = if args.gradients {
        Some(method(args.gradient_method))
    } else {
        old.and_then(|a| a.gradients.as_ref()).map(|g| g.method)
    };
    let histogram = if args.histogram {
        Some(histogram_options(args))
    } else {
        old.and_then(|a| a.histograms.as_ref()).map(|h| h.same_axes())
    };
    let t = Instant::now();
    let analysis = analyze(&bundle, &AnalysisOptions { gradients, histogram, ..Default::default() })?;
    let bundle = bundle.with_analysis(analysis);
    let bundle = match gradients {
        Some(m) => with_step_gradients(bundle, m)?,
        None => bundle,
    };
    let secs = t.elapsed().as_secs_f64();
    let out = output.unwrap_or(path);
    bundle.write(out).context("writing the bundle failed").kind(ExitKind::Output)?;
    if as_json {
        let mut v = info_json(&bundle);
        v["output"] = json!(out.display().to_string());
        v["analysis_s"] = json!(secs);
        println!("{}", serde_json::to_string_pretty(&v)?);
    } else {
        println!("wrote {} (analysis {secs:.3} s)", out.display());
        print!("{}", info_text(&bundle));
    }
    Ok(())
}

/// The stored analysis, or ranges and limits computed now (cheap) when the
/// bundle has none; the flag says which.
fn stored_or_computed(b: &Bundle) -> (std::borrow::Cow<'_, Analysis>, bool) {
    match &b.analysis {
        Some(a) => (std::borrow::Cow::Borrowed(a), true),
        None => {
            let a = Analyzer::from_mesh(&b.mesh)
                .and_then(|an| an.analyze(&AnalysisOptions::default()))
                .expect("a bundle's mesh is valid and finite");
            (std::borrow::Cow::Owned(a), false)
        }
    }
}

/// Analysis keys merged into the `info --json` summary.
pub fn info_json(b: &Bundle) -> Value {
    let (a, stored) = stored_or_computed(b);
    let f = &a.facts;
    let l = &a.limits;
    let pct = |p: &tet_analysis::Percentiles| json!({"p50": p.p50, "p90": p.p90, "p99": p.p99, "p99.9": p.p999, "max": p.max});
    json!({
        "analysis_stored": stored,
        "gradients": a.gradients.as_ref().map(|g| g.method.name()),
        "histogram": a.histograms.as_ref().map(|h| json!({
            "scalar_bins": h.scalar_axis.bins,
            "gradient_bins": h.gradient_axis.bins,
            "scalar_range": [h.scalar_axis.lo, h.scalar_axis.hi],
            "gradient_range": [h.gradient_axis.lo, h.gradient_axis.hi],
            "volume_outside": h.joint_outside,
        })),
        "frequency_limit": l.frequency_limit,
        "frequency_limit_99": l.frequency_limit_99,
        "gradient_frequency_limit": l.gradient_frequency_limit,
        "gradient_frequency_limit_99": l.gradient_frequency_limit_99,
        "max_cell_scalar_range": f.max_cell_scalar_range,
        "max_cell_diameter": f.max_cell_diameter,
        "cell_scalar_range": pct(&f.cell_scalar_range),
        "cell_gradient_range": f.cell_gradient_range.as_ref().map(pct),
        "table_resolution": l.table.map(|t| json!({
            "tolerance": t.tolerance, "period": t.period, "sine": t.samples_sine, "triangle": t.samples_triangle,
        })),
    })
}

fn opt(x: Option<f64>) -> String {
    x.map(|v| format!("{v:.6e}")).unwrap_or_else(|| "none (constant)".into())
}

/// Analysis lines of the `info` text.
pub fn info_text(b: &Bundle) -> String {
    let (a, stored) = stored_or_computed(b);
    let (f, l) = (&a.facts, &a.limits);
    let mut o = String::new();
    let _ = writeln!(
        o,
        "analysis    {}; gradients {}; histogram {}",
        if stored { "stored" } else { "not stored (ranges and limits computed now)" },
        a.gradients.as_ref().map(|g| g.method.name()).unwrap_or("no"),
        a.histograms
            .as_ref()
            .map(|h| format!("{}×{} bins", h.scalar_axis.bins, h.gradient_axis.bins))
            .unwrap_or_else(|| "no".into())
    );
    let r = &f.cell_scalar_range;
    let _ = writeln!(
        o,
        "segments    |Sf−Sb| ≤ {:.6e} (max cell scalar range), l ≤ {:.6e} (l_max); cell ranges p50 {:.3e} / p90 {:.3e} / p99 {:.3e} / p99.9 {:.3e}",
        f.max_cell_scalar_range, f.max_cell_diameter, r.p50, r.p90, r.p99, r.p999
    );
    let _ = writeln!(
        o,
        "bands       frequency limit {} (all cells), {} (99% of cells) cycles per scalar unit",
        opt(l.frequency_limit),
        opt(l.frequency_limit_99)
    );
    if let Some(t) = l.table {
        let _ = writeln!(
            o,
            "tables      {} samples per Sf/Sb axis (sine bands), {} (triangle bands) resolve period {:.3e} to {}%",
            t.samples_sine,
            t.samples_triangle,
            t.period,
            t.tolerance * 100.0
        );
    }
    o
}
