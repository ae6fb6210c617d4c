//! `tetprep hist`: the volume-weighted scalar × |∇s| histogram as a PNG
//! (log or linear colour scale with a colour bar, the 1D histogram along the
//! top, labelled axes) and optionally as CSV.

use anyhow::Context;
use std::io::Write;
use std::path::Path;
use tet_analysis::{HistogramOptions, Histograms};
use tet_bundle::Bundle;
use tet_cli::hist_plot::histogram_figure;
pub use tet_cli::hist_plot::AxisUnits;
use tet_cli::{ExitKind, KindExt};

/// Writes the bin volumes: one row per 1D bin, then one per joint bin.
fn write_csv(h: &Histograms, path: &Path) -> anyhow::Result<()> {
    let f = std::fs::File::create(path)
        .with_context(|| format!("cannot create {}", path.display()))
        .kind(ExitKind::Output)?;
    let mut w = std::io::BufWriter::new(f);
    let io = |e: std::io::Error| {
        tet_cli::Tagged::new(
            ExitKind::Output,
            anyhow::Error::new(e).context(format!("writing {} failed", path.display())),
        )
    };
    writeln!(
        w,
        "# total_volume={} scalar_below={} scalar_above={} joint_outside={}",
        h.total_volume, h.scalar_below, h.scalar_above, h.joint_outside
    )
    .map_err(io)?;
    writeln!(w, "kind,scalar_lo,scalar_hi,gradient_lo,gradient_hi,volume").map_err(io)?;
    let (sa, ga) = (&h.scalar_axis, &h.gradient_axis);
    for (k, v) in h.scalar.iter().enumerate() {
        writeln!(w, "1d,{},{},,,{}", sa.edge(k), sa.edge(k + 1), v).map_err(io)?;
    }
    let ns = sa.bins as usize;
    for g in 0..ga.bins as usize {
        for k in 0..ns {
            let v = h.joint[g * ns + k];
            writeln!(w, "2d,{},{},{},{},{}", sa.edge(k), sa.edge(k + 1), ga.edge(g), ga.edge(g + 1), v).map_err(io)?;
        }
    }
    w.flush().map_err(io)?;
    Ok(())
}

/// What `tetprep hist` was asked to draw; any of `bins`, `scalar_range` or
/// `gradient_range` recomputes the histogram instead of using the stored one.
#[derive(Debug, Clone, Default)]
pub struct HistRequest {
    pub log: bool,
    pub bins: Option<[u32; 2]>,
    pub scalar_range: Option<(f64, f64)>,
    pub gradient_range: Option<(f64, f64)>,
    pub units: AxisUnits,
}

pub fn run_hist(path: &Path, output: &Path, csv: Option<&Path>, req: &HistRequest) -> anyhow::Result<()> {
    let HistRequest { log, bins, scalar_range, gradient_range, ref units } = *req;
    let bundle = Bundle::read(path)?;
    let stored = bundle.analysis.as_ref().and_then(|a| a.histograms.as_ref());
    let recompute = bins.is_some() || scalar_range.is_some() || gradient_range.is_some();
    let computed;
    let h = match stored {
        Some(h) if !recompute => h,
        _ => {
            let [sb, gb] = bins.unwrap_or([256, 256]);
            let opts = HistogramOptions {
                scalar_bins: sb,
                gradient_bins: gb,
                scalar_range,
                gradient_range,
                ..Default::default()
            };
            let an = tet_analysis::Analyzer::from_mesh(&bundle.mesh).context("the bundle's mesh cannot be analysed")?;
            computed = an.histograms(&opts)?;
            &computed
        }
    };
    let name = &bundle.mesh.scalar_name;
    let file = path.file_name().map(|f| f.to_string_lossy().into_owned()).unwrap_or_default();
    let title = format!("{file}: {name} × |∇{name}|");
    histogram_figure(h, name, &title, log, units).write_png(output).kind(ExitKind::Output)?;
    if let Some(csv) = csv {
        write_csv(h, csv)?;
    }
    println!(
        "wrote {}{} ({}×{} bins, {})",
        output.display(),
        csv.map(|c| format!(" and {}", c.display())).unwrap_or_default(),
        h.scalar_axis.bins,
        h.gradient_axis.bins,
        if stored.is_some() && !recompute { "stored histogram" } else { "computed now" }
    );
    Ok(())
}
