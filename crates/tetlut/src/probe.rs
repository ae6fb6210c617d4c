//! `tetlut probe`: shade segments given as text and print premultiplied RGBA.

use std::io::{BufRead, Write};
use std::path::PathBuf;

use anyhow::{Context, Result};
use tet_preint::bivariate::Seg2;
use tet_preint::{integrate_segment_with, Baked, LutFile, Method, Segment};

use crate::common::{parse_method, read_tf, tf_in_data_units, DomainArgs, TableArgs};
use tet_cli::{fail, usage, ExitKind, KindExt};

/// Reads segments "Sf Sb l [gf gb]", one per line (whitespace-separated;
/// blank lines and lines starting with '#' skipped; gf, gb = |∇s| at entry
/// and exit, 0 when absent), and prints premultiplied "R G B A" per segment.
/// `exact` and `biv-exact` print the f64 integral in shortest round-trip
/// form, the tables what the renderer gets (f32).
#[derive(Debug, clap::Args)]
pub struct ProbeArgs {
    /// A baked .tetl (instead of --tf/--method).
    #[arg(long, value_name = "lut.tetl", conflicts_with_all = ["tf", "method"])]
    lut: Option<PathBuf>,
    /// Transfer function (formats/tf.md JSON or a ParaView preset).
    #[arg(long, value_name = "tf.json", required_unless_present = "lut")]
    tf: Option<PathBuf>,
    /// Method id; tables are baked on the fly over the domain.
    #[arg(long, value_parser = parse_method, default_value = "exact")]
    method: Method,
    #[command(flatten)]
    domain: DomainArgs,
    #[command(flatten)]
    table: TableArgs,
    /// Segments file (stdin when absent).
    file: Option<PathBuf>,
}

pub fn run(args: &ProbeArgs) -> Result<()> {
    let baked = match (&args.lut, &args.tf) {
        (Some(path), _) => {
            let lut = LutFile::read(path).map_err(anyhow::Error::new).kind(ExitKind::Input)?;
            Baked::from_lut(&lut, path).map_err(anyhow::Error::new).kind(ExitKind::Input)?
        }
        (None, Some(tf_path)) => {
            let tf = read_tf(tf_path)?;
            let opts = args.table.options(args.method)?;
            let tabulated = args.method.is_tabulated();
            let (domain, bundle) = args.domain.resolve(&tf, tabulated)?;
            let tf = tf_in_data_units(&tf, &domain, bundle.as_ref())?;
            Baked::build(args.method, &tf, &domain, &opts)
                .with_context(|| format!("cannot bake {}", args.method))
                .kind(ExitKind::Bake)?
        }
        (None, None) => return Err(usage("give --lut L, or --tf T with --method M")),
    };
    let reader: Box<dyn BufRead> = match &args.file {
        Some(p) => Box::new(std::io::BufReader::new(
            std::fs::File::open(p).with_context(|| format!("opening {}", p.display())).kind(ExitKind::Input)?,
        )),
        None => Box::new(std::io::stdin().lock()),
    };
    let name = args.file.as_ref().map(|p| p.display().to_string()).unwrap_or_else(|| "stdin".into());
    let mut out = std::io::BufWriter::new(std::io::stdout().lock());
    let mut scratch = Vec::new();
    for (i, line) in reader.lines().enumerate() {
        let n = i + 1;
        let line = line.with_context(|| format!("{name}: line {n}")).kind(ExitKind::Input)?;
        let t = line.trim();
        if t.is_empty() || t.starts_with('#') {
            continue;
        }
        let v: Vec<f64> = t
            .split_whitespace()
            .map(|x| x.parse::<f64>())
            .collect::<Result<_, _>>()
            .map_err(|_| fail(ExitKind::Input, format!("{name}: line {n}: not numbers: {t:?}")))?;
        let (sf, sb, l, gf, gb) = match v[..] {
            [sf, sb, l] => (sf, sb, l, 0.0, 0.0),
            [sf, sb, l, gf, gb] => (sf, sb, l, gf, gb),
            _ => {
                return Err(fail(
                    ExitKind::Input,
                    format!("{name}: line {n}: expected 3 numbers (Sf Sb l) or 5 (Sf Sb l gf gb), found {}", v.len()),
                ))
            }
        };
        if !(v.iter().all(|x| x.is_finite()) && l >= 0.0 && gf >= 0.0 && gb >= 0.0) {
            return Err(fail(ExitKind::Input, format!("{name}: line {n}: need finite values with l, gf, gb ≥ 0")));
        }
        let px: [f64; 4] = match &baked {
            Baked::Exact(s) => integrate_segment_with(s.transfer_function(), sf, sb, l, &mut scratch).to_array(),
            Baked::BivExact(s) => s.integrate(&Seg2 { sf, sb, gf, gb, len: l }).to_array(),
            other => {
                // f32 in its own shortest form.
                let seg = Segment {
                    s_front: sf as f32,
                    s_back: sb as f32,
                    grad_front: gf as f32,
                    grad_back: gb as f32,
                    len_world: l as f32,
                };
                let p = other.shader().shade(&seg);
                writeln!(out, "{:e} {:e} {:e} {:e}", p[0], p[1], p[2], p[3])?;
                continue;
            }
        };
        writeln!(out, "{:e} {:e} {:e} {:e}", px[0], px[1], px[2], px[3])?;
    }
    out.flush()?;
    Ok(())
}
