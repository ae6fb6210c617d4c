//! The transfer function `render` and `reference` use: `--tf`, or the
//! automatic one of the bundle (tet_preint's `auto_tf`, the same the viewer
//! opens on), with `--colormap`, `--opacity-scale` and `--save-tf`.

use anyhow::{Context, Result};
use std::path::{Path, PathBuf};
use tet_bundle::Bundle;
use tet_cli::{usage, ExitKind, KindExt};
use tet_preint::{choose_tf, Colormap, TransferFunction};

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

/// Reads `tf_path` (or builds the automatic TF of `bundle`), applies the
/// options, maps a normalized TF onto `range` (or the bundle's scalar
/// range), writes `--save-tf`, and prints a note on stderr for an
/// automatic TF (and a warning when its histogram had to be computed).
pub fn resolve(
    tf_path: Option<&Path>,
    range: Option<(f64, f64)>,
    bundle: &Bundle,
    args: &TfChoiceArgs,
) -> Result<TransferFunction> {
    // tet_preint's one loader: unreadable is an input error (3), contents
    // that are not a valid TF a usage error (2), as in tetlut.
    let given = tf_path.map(tet_preint::load_tf).transpose()?;
    let (mut tf, auto) = choose_tf(given, Some(bundle), args.colormap, args.opacity_scale)?;
    if let Some(a) = &auto {
        if let Some(note) = a.source.note() {
            eprintln!("warning: {note}");
        }
        eprintln!(
            "note: no --tf: automatic transfer function (opacity on the scalar × |∇s| boundaries, {} over {:.4}..{:.4}); --save-tf writes it",
            args.colormap.unwrap_or_default(),
            a.color_range.0,
            a.color_range.1
        );
    }
    if let (true, Some((lo, hi))) = (tf.normalized(), range) {
        tf = tf.denormalize(lo, hi)?;
    } else if tf.normalized() {
        // The one constant-scalar policy (tet_preint::tf_for_bundle).
        tf = tet_preint::tf_for_bundle(&tf, bundle)?;
    } else if range.is_some() {
        return Err(usage("--range is only for normalized transfer functions"));
    }
    if let Some(p) = &args.save_tf {
        std::fs::write(p, tf.to_json()).with_context(|| format!("writing {}", p.display())).kind(ExitKind::Output)?;
    }
    Ok(tf)
}
