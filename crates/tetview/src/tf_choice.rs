//! The transfer function `render` and `reference` use: `--tf`, or the
//! automatic one of the bundle (tet_preint's `auto_tf`, the same the viewer
//! opens on), with `--colormap`, `--opacity-scale` and `--save-tf`.

use anyhow::{Context, Result};
use std::path::{Path, PathBuf};
use tet_bundle::Bundle;
use tet_cli::{ExitKind, KindExt};
use tet_engine::{TfRequest, TfSource};
use tet_preint::{Colormap, TransferFunction};

/// The TF options `render` and `reference` share.
#[derive(Debug, Clone, clap::Args)]
pub struct TfChoiceArgs {
    /// Colour map of the automatic TF (without --tf), or the colours that
    /// replace those of --tf over its nodes' span: viridis, inferno, magma,
    /// plasma, cool-to-warm, turbo, grayscale.
    #[arg(long, value_parser = parse_colormap)]
    pub colormap: Option<Colormap>,
    /// Multiplies every extinction of the TF (automatic or --tf): above 1
    /// denser, below 1 clearer.
    #[arg(long, default_value_t = 1.0, value_parser = parse_scale)]
    pub opacity_scale: f64,
    /// Write the TF used (formats/tf.md JSON, what --tf reads) to edit it.
    #[arg(long)]
    pub save_tf: Option<PathBuf>,
}

pub fn parse_colormap(s: &str) -> std::result::Result<Colormap, String> {
    s.parse().map_err(|e: tet_preint::TfError| e.to_string())
}

fn parse_scale(s: &str) -> std::result::Result<f64, String> {
    match s.trim().parse::<f64>() {
        Ok(v) if v.is_finite() && v >= 0.0 => Ok(v),
        Ok(v) => Err(format!("{v}: need a finite factor ≥ 0")),
        Err(e) => Err(format!("{s:?}: {e}")),
    }
}

/// The engine's TF policy ([`tet_engine::resolve_tf`]) for `tf_path` (or
/// the automatic TF of `bundle`) with the options; writes `--save-tf`, and
/// prints a note on stderr for an automatic TF (and a warning when its
/// histogram had to be computed).
pub fn resolve(
    tf_path: Option<&Path>,
    range: Option<(f64, f64)>,
    bundle: &Bundle,
    args: &TfChoiceArgs,
) -> Result<TransferFunction> {
    let source = tf_path.map_or(TfSource::Auto, |p| TfSource::File(p.to_path_buf()));
    let request = TfRequest { source, colormap: args.colormap, opacity_scale: args.opacity_scale, range };
    let resolved = tet_engine::resolve_tf(bundle, &request)?;
    for note in &resolved.notes {
        eprintln!("warning: {note}");
    }
    if let Some(a) = &resolved.auto {
        eprintln!(
            "note: no --tf: automatic transfer function (opacity on the scalar × |∇s| boundaries, {} over {:.4}..{:.4}); --save-tf writes it",
            args.colormap.unwrap_or_default(),
            a.color_range.0,
            a.color_range.1
        );
    }
    if let Some(p) = &args.save_tf {
        let tf = &resolved.tf;
        std::fs::write(p, tf.to_json()).with_context(|| format!("writing {}", p.display())).kind(ExitKind::Output)?;
    }
    Ok(resolved.tf)
}
