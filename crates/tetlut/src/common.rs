//! Command line and what every subcommand shares: reading a
//! transfer function, a bundle or a `.tetl`, the (Sf, Sb, l) domain, and the
//! bake options.

use std::path::{Path, PathBuf};

use anyhow::{Context, Result};
use clap::{Args, Parser, Subcommand};
use tet_cli::{usage, ExitKind, KindExt};
use tet_preint::{BakeOptions, Build3d, Method, Precision, TableDomain, TransferFunction};

/// Pre-integration tables for ray segments through linear tetrahedra: bake
/// them to .tetl files, draw them, probe them, and measure bake time,
/// memory and error of every method against the exact integral.
///
/// Methods (`tet_preint::Method`): exact, pt-linear, table3d, atlas2d, poly1, poly2,
/// poly4, partial, biv-exact, biv-approx.
///
/// Exit codes: listed below (`tet_cli::ExitKind`, the same in every tetkit program).
#[derive(Debug, Parser)]
#[command(name = "tetlut", version, about, long_about, after_help = tet_cli::EXIT_CODES_HELP)]
pub struct Cli {
    #[command(subcommand)]
    pub command: Command,
}

#[derive(Debug, Subcommand)]
pub enum Command {
    /// Bake one method's tables for a TF over a bundle's domain into a .tetl.
    ///
    /// The domain is the bundle's: scalar range, |Sf − Sb| up to the largest
    /// per-cell range (a band around the diagonal) and l up to the largest
    /// cell diameter; without --bundle give --range and --max-len.
    ///
    /// Example: tetlut bake --bundle bluntfin.tetb --tf tf.json --method table3d -o bluntfin.tetl
    Bake(crate::bake::BakeArgs),
    /// Draw a .tetl's tables as a labelled PNG (l-slices, the cylindrical
    /// atlas, Ψ, ρ̂ and colour coefficients, F and B).
    ///
    /// Example: tetlut show bluntfin.tetl -o bluntfin.png --slices 8
    Show(crate::show::ShowArgs),
    /// Read segments "Sf Sb l [gf gb]" (one per line) and print
    /// premultiplied "R G B A" per line.
    ///
    /// Example: echo "0.2 0.4 1.5" | tetlut probe --tf tf.json --method exact
    Probe(crate::probe::ProbeArgs),
    /// Bake time, memory and RMS/max error against exact of every method
    /// over a range of resolutions; a Pareto plot as PNG.
    ///
    /// Example: tetlut bench --bundle bluntfin.tetb --tf tf.json -o pareto.png --json bench.json
    Bench(crate::bench::BenchArgs),
}

/// Runs the subcommand.
pub fn run(cli: Cli) -> Result<()> {
    match cli.command {
        Command::Bake(args) => crate::bake::run(&args),
        Command::Show(args) => crate::show::run(&args),
        Command::Probe(args) => crate::probe::run(&args),
        Command::Bench(args) => crate::bench::run(&args),
    }
}

pub fn parse_method(s: &str) -> std::result::Result<Method, String> {
    s.parse::<Method>().map_err(|e| e.to_string())
}

pub fn parse_precision(s: &str) -> std::result::Result<Precision, String> {
    s.parse::<Precision>()
}

/// Reads a TF with the loader every tetkit program uses
/// (`tet_preint::load_tf`: formats/tf.md JSON, or a ParaView preset imported
/// normalized with unit distance 1). Its errors classify themselves: a file
/// that cannot be read is an input error (3), contents that are not a valid
/// TF a usage error (2), the same as `tetview`'s `--tf`.
pub fn read_tf(path: &Path) -> Result<TransferFunction> {
    Ok(tet_preint::load_tf(path)?)
}

/// `tf` in data units for a table over `domain`: with a bundle, a
/// normalized TF goes onto the bundle's scalar range by the one policy
/// (`tet_preint::tf_for_bundle`, which a constant scalar widens to ±0.5, as
/// `tetview` does), else onto the domain's scalar range.
pub fn tf_in_data_units(
    tf: &TransferFunction,
    domain: &TableDomain,
    bundle: Option<&tet_bundle::Bundle>,
) -> Result<TransferFunction> {
    let tf = match bundle {
        Some(b) => tet_preint::tf_for_bundle(tf, b)?,
        None => tf.clone(),
    };
    tet_preint::tf_for_domain(&tf, domain).kind(ExitKind::Bake)
}

/// Prints the constant-scalar warning (`tet_preint::constant_scalar_warning`,
/// the same text `tetview` prints) for `bundle`.
pub fn warn_if_constant_scalar(bundle: &tet_bundle::Bundle) {
    if let Some(w) = tet_preint::constant_scalar_warning(bundle) {
        eprintln!("warning: {w}");
    }
}

/// Reads a bundle (its errors classify themselves: unreadable or corrupt is
/// an input error).
pub fn read_bundle(path: &Path) -> Result<tet_bundle::Bundle> {
    Ok(tet_bundle::Bundle::read(path)?)
}

/// Where the (Sf, Sb, l) domain comes from.
#[derive(Debug, Clone, Args)]
pub struct DomainArgs {
    /// Bundle (.tetb) whose segments the table serves: scalar range, largest
    /// per-cell scalar range and largest cell diameter.
    #[arg(long, value_name = "B.tetb")]
    pub bundle: Option<PathBuf>,
    /// Scalar range LO,HI (without --bundle); also where a normalized TF's [0,1] goes.
    #[arg(long, value_parser = tet_cli::parse_range, allow_hyphen_values = true, value_name = "LO,HI")]
    pub range: Option<(f64, f64)>,
    /// Largest segment length, world units (without --bundle).
    #[arg(long, value_name = "L")]
    pub max_len: Option<f64>,
    /// Largest |Sf − Sb| baked (without --bundle; default: the whole range).
    #[arg(long, value_name = "D")]
    pub max_ds: Option<f64>,
    /// Bake the whole (Sf, Sb) square instead of the bundle's band.
    #[arg(long)]
    pub full_domain: bool,
}

impl DomainArgs {
    /// The domain, and the bundle when one was given. `need_len`: whether a
    /// length range is required (tables); untabulated methods only need a
    /// scalar range, and not even that for a TF in data units.
    pub fn resolve(&self, tf: &TransferFunction, need_len: bool) -> Result<(TableDomain, Option<tet_bundle::Bundle>)> {
        if let Some(path) = &self.bundle {
            if self.range.is_some() || self.max_len.is_some() || self.max_ds.is_some() {
                return Err(usage("--range, --max-len and --max-ds are taken from --bundle; give one or the other"));
            }
            let b = read_bundle(path)?;
            // A bundle whose data spans no domain is rejected data (its TableError says so).
            let mut d = TableDomain::from_bundle(&b).with_context(|| format!("domain of {}", path.display()))?;
            if self.full_domain {
                d = TableDomain::full(d.s_lo, d.s_hi, d.len_max_world)?;
            }
            return Ok((d, Some(b)));
        }
        let (lo, hi) = match (self.range, tf.normalized()) {
            (Some(r), _) => r,
            (None, true) => {
                return Err(usage("the transfer function is normalized: give --range LO,HI (or --bundle)"));
            }
            (None, false) if !need_len => tf_span(tf),
            (None, false) => return Err(usage("give --bundle B.tetb, or --range LO,HI and --max-len L")),
        };
        let len = match self.max_len {
            Some(l) => l,
            None if !need_len => 1.0,
            None => return Err(usage("this method bakes tables over l: give --max-len L (or --bundle)")),
        };
        let ds = if self.full_domain { f64::INFINITY } else { self.max_ds.unwrap_or(f64::INFINITY) };
        let d = TableDomain::new(lo, hi, ds, len).map_err(|e| usage(e.to_string()))?;
        Ok((d, None))
    }
}

/// The x span of a TF's nodes (a degenerate one widened).
pub fn tf_span(tf: &TransferFunction) -> (f64, f64) {
    tet_preint::auto_tf::node_span(tf)
}

/// Resolution and storage flags shared by `bake` and `probe`.
#[derive(Debug, Clone, Args)]
pub struct TableArgs {
    /// Resolution: N (table3d/atlas2d: N × N × 2N; partial: Ψ N²; poly: N²;
    /// biv-approx: F/B N²) or NsxNsxNl for table3d/atlas2d.
    #[arg(long, value_name = "N|NsxNsxNl")]
    pub res: Option<String>,
    /// Storage precision: f32 (default), f16, unorm16, unorm8 (poly: f32 or f16).
    #[arg(long, value_parser = parse_precision, value_name = "P")]
    pub precision: Option<Precision>,
    /// atlas2d plane count: 4n (exact reconstruction), n (default) or n/2.
    #[arg(long, value_name = "4n|n|n/2")]
    pub planes: Option<String>,
    /// biv-approx: sub-segments per segment (default 4).
    #[arg(long, value_name = "K")]
    pub k: Option<usize>,
    /// table3d/atlas2d build: adaptive[:TOLERANCE] (default adaptive:1e-5),
    /// slice[:OVERSAMPLING] (slice: oversampling 2), incremental, exact
    /// (f64 per entry) or blend:STEPS:BITS (Röttger & Ertl 2002).
    #[arg(long, value_name = "BUILD")]
    pub build: Option<String>,
    /// table3d: the largest per-segment error (any channel, against exact)
    /// the bake certifies; it measures itself and refines (lookup split at
    /// TF nodes, exact integration where the table cannot follow the TF,
    /// resolution) until the target holds or the memory budget is spent,
    /// and says which. Default 1e-3; --res is then the starting resolution.
    #[arg(long, value_name = "E")]
    pub max_error: Option<f64>,
    /// table3d: memory (MiB) the refinement may give the table (default 256).
    #[arg(long, value_name = "MIB")]
    pub memory_budget: Option<f64>,
    /// table3d: bake --res as given and measure nothing (no certificate).
    #[arg(long, conflicts_with_all = ["max_error", "memory_budget"])]
    pub no_certify: bool,
}

/// Parses `--build`.
pub fn parse_build(s: &str) -> Result<Build3d> {
    let bad =
        || usage(format!("--build {s:?}: expected adaptive[:TOL], slice[:O], incremental, exact or blend:STEPS:BITS"));
    let parts: Vec<&str> = s.split(':').collect();
    Ok(match parts[..] {
        ["adaptive"] => Build3d::Adaptive { tolerance: tet_preint::table3d::ADAPTIVE_TOLERANCE },
        ["adaptive", t] => Build3d::Adaptive { tolerance: t.parse().map_err(|_| bad())? },
        ["slice"] => Build3d::default(),
        ["slice", o] => Build3d::SliceRecurrence { oversampling: o.parse().map_err(|_| bad())? },
        ["incremental"] => Build3d::Incremental,
        ["exact"] => Build3d::Exact,
        ["blend", n, b] => Build3d::Blend {
            steps: n.parse().map_err(|_| bad())?,
            accumulation: tet_preint::Accumulation::new(b.parse().map_err(|_| bad())?)
                .ok_or_else(|| usage(format!("--build {s:?}: accumulation bits must be 2..=24 or 32")))?,
        },
        _ => return Err(bad()),
    })
}

impl TableArgs {
    /// The bake options for `method` (flags a method does not read are refused).
    pub fn options(&self, method: Method) -> Result<BakeOptions> {
        let mut o = BakeOptions::default();
        let is_3d = matches!(method, Method::Table3d | Method::Atlas2d);
        if let Some(r) = &self.res {
            let dims: Vec<usize> = r
                .split('x')
                .map(|v| v.trim().parse::<usize>())
                .collect::<std::result::Result<_, _>>()
                .map_err(|_| usage(format!("--res {r:?}: expected N or NsxNsxNl")))?;
            match (&dims[..], is_3d) {
                (&[n], true) => (o.table3d.n_s, o.table3d.n_l) = (n, 2 * n),
                (&[a, b, l], true) if a == b => (o.table3d.n_s, o.table3d.n_l) = (a, l),
                (&[n], false) | (&[n, _], false) if dims.iter().all(|&d| d == n) => match method {
                    Method::Partial => o.psi.res = n,
                    Method::Poly1 | Method::Poly2 | Method::Poly4 => o.poly_res = n,
                    Method::BivApprox => o.fb_res = n,
                    _ => return Err(usage(format!("method {method} has no tables: --res does not apply"))),
                },
                _ => {
                    return Err(usage(format!(
                        "--res {r:?} for {method}: expected {}",
                        if is_3d { "N or NxNxNl (square in Sf, Sb)" } else { "N (square tables)" }
                    )))
                }
            }
        }
        if let Some(p) = self.precision {
            o.table3d.precision = p;
            o.psi.precision = p;
            o.precision_2d = p;
        }
        if let Some(p) = &self.planes {
            if method != Method::Atlas2d {
                return Err(usage("--planes is for atlas2d only"));
            }
            o.atlas_planes_quarters = match p.as_str() {
                "4n" | "4N" => 16,
                "n" | "N" => 4,
                "n/2" | "N/2" => 2,
                _ => return Err(usage(format!("--planes {p:?}: expected 4n, n or n/2"))),
            };
        }
        if let Some(k) = self.k {
            if method != Method::BivApprox {
                return Err(usage("--k is for biv-approx only"));
            }
            o.biv_subsegments = k;
        }
        if let Some(b) = &self.build {
            if !is_3d {
                return Err(usage("--build is for table3d and atlas2d only"));
            }
            o.table3d.build = parse_build(b)?;
        }
        if (self.max_error.is_some() || self.memory_budget.is_some() || self.no_certify) && method != Method::Table3d {
            return Err(usage("--max-error, --memory-budget and --no-certify are for table3d only"));
        }
        if let Some(e) = self.max_error {
            if !(e.is_finite() && e > 0.0) {
                return Err(usage(format!("--max-error {e}: must be a positive number")));
            }
            o.certify.max_error = Some(e);
        }
        if let Some(m) = self.memory_budget {
            if !(m.is_finite() && m > 0.0) {
                return Err(usage(format!("--memory-budget {m}: must be a positive number of MiB")));
            }
            o.certify.memory_budget = (m * (1u64 << 20) as f64) as usize;
        }
        if self.no_certify {
            o.certify = tet_preint::CertifyOptions::off();
        }
        Ok(o)
    }
}

/// "N×N×M" style description of what a method bakes with `o`.
pub fn describe_res(method: Method, o: &BakeOptions) -> String {
    match method {
        Method::Table3d | Method::Atlas2d => {
            let t = &o.table3d;
            let base = format!("{}x{}x{} {}", t.n_s, t.n_s, t.n_l, t.precision);
            if method == Method::Atlas2d {
                let planes = (t.n_s * o.atlas_planes_quarters / 4).max(2);
                format!("{base}, {planes} planes")
            } else {
                base
            }
        }
        Method::Partial => format!("{}^2 {}", o.psi.res, o.psi.precision),
        Method::Poly1 | Method::Poly2 | Method::Poly4 => format!("{}^2 {}", o.poly_res, o.precision_2d),
        Method::BivApprox => format!("{}^2 {}, k={}", o.fb_res, o.precision_2d, o.biv_subsegments),
        _ => "-".into(),
    }
}

/// Bytes in human units.
pub fn human_bytes(b: usize) -> String {
    let b = b as f64;
    if b >= 1024.0 * 1024.0 * 1024.0 {
        format!("{:.2} GiB", b / (1024.0 * 1024.0 * 1024.0))
    } else if b >= 1024.0 * 1024.0 {
        format!("{:.2} MiB", b / (1024.0 * 1024.0))
    } else if b >= 1024.0 {
        format!("{:.1} KiB", b / 1024.0)
    } else {
        format!("{b} B")
    }
}
