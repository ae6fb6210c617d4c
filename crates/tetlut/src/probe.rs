//! `tetlut probe`: integrate (Sf, Sb, l) triples and print premultiplied RGBA.

use std::io::{BufRead, Write};
use std::path::PathBuf;

use anyhow::{bail, Context, Result};
use tet_preint::{integrate_segment_with, TransferFunction};

/// Method ids of DESIGN.md that are planned but not built yet.
const PLANNED: &[&str] =
    &["pt-linear", "table3d", "atlas2d", "poly1", "poly2", "poly4", "partial", "biv-exact", "biv-approx"];

/// Reads (Sf, Sb, l) triples, one per line (whitespace-separated; blank lines
/// and lines starting with '#' skipped), and prints premultiplied `R G B A`
/// per triple in shortest round-trip form.
#[derive(Debug, clap::Args)]
pub struct ProbeArgs {
    /// Transfer function JSON (formats/tf.md).
    #[arg(long)]
    tf: PathBuf,
    /// Integration method; only `exact` is built so far.
    #[arg(long, default_value = "exact")]
    method: String,
    /// Scalar range LO,HI onto which a normalized TF's [0,1] is mapped.
    #[arg(long, value_parser = parse_range, allow_hyphen_values = true)]
    range: Option<(f64, f64)>,
    /// Triples file (stdin when absent).
    file: Option<PathBuf>,
}

fn parse_range(s: &str) -> Result<(f64, f64), String> {
    let (a, b) = s.split_once(',').ok_or("expected LO,HI")?;
    let p = |x: &str| x.trim().parse::<f64>().map_err(|e| format!("{x:?}: {e}"));
    Ok((p(a)?, p(b)?))
}

pub fn run(args: &ProbeArgs) -> Result<()> {
    if args.method != "exact" {
        if PLANNED.contains(&args.method.as_str()) {
            bail!("method {:?} is planned but not built yet; only \"exact\" exists", args.method);
        }
        bail!("unknown method {:?}; only \"exact\" exists", args.method);
    }
    let text = std::fs::read_to_string(&args.tf).with_context(|| format!("reading {}", args.tf.display()))?;
    let mut tf = TransferFunction::from_json(&text).with_context(|| format!("in {}", args.tf.display()))?;
    match (tf.normalized(), args.range) {
        (true, Some((lo, hi))) => tf = tf.denormalize(lo, hi)?,
        (true, None) => bail!("{} is normalized: give --range LO,HI", args.tf.display()),
        (false, Some(_)) => bail!("--range is only for normalized transfer functions"),
        (false, None) => {}
    }
    let input: Box<dyn BufRead> = match &args.file {
        Some(p) => Box::new(std::io::BufReader::new(
            std::fs::File::open(p).with_context(|| format!("opening {}", p.display()))?,
        )),
        None => Box::new(std::io::stdin().lock()),
    };
    let name = args.file.as_ref().map(|p| p.display().to_string()).unwrap_or_else(|| "stdin".into());
    let mut out = std::io::BufWriter::new(std::io::stdout().lock());
    let mut scratch = Vec::new();
    for (i, line) in input.lines().enumerate() {
        let line = line.with_context(|| format!("{name}: line {}", i + 1))?;
        let t = line.trim();
        if t.is_empty() || t.starts_with('#') {
            continue;
        }
        let v: Vec<f64> = t
            .split_whitespace()
            .map(|x| x.parse::<f64>())
            .collect::<Result<_, _>>()
            .with_context(|| format!("{name}: line {}: not numbers: {t:?}", i + 1))?;
        let [sf, sb, l] = v[..] else {
            bail!("{name}: line {}: expected 3 numbers (Sf Sb l), found {}", i + 1, v.len());
        };
        if !(sf.is_finite() && sb.is_finite() && l.is_finite() && l >= 0.0) {
            bail!("{name}: line {}: need finite Sf, Sb and l ≥ 0", i + 1);
        }
        let p = integrate_segment_with(&tf, sf, sb, l, &mut scratch);
        writeln!(out, "{:e} {:e} {:e} {:e}", p.color[0], p.color[1], p.color[2], p.alpha)?;
    }
    out.flush()?;
    Ok(())
}
