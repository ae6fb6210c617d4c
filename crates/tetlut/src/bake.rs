//! `tetlut bake`: one method's tables to a `.tetl`.

use std::path::PathBuf;
use std::time::Instant;

use anyhow::{Context, Result};
use serde_json::json;
use tet_preint::{Baked, Colormap, Method, RECONSTRUCTION_GAP};

use crate::common::{
    describe_res, human_bytes, parse_method, read_bundle, read_tf, tf_in_data_units, warn_if_constant_scalar,
    DomainArgs, TableArgs,
};
use tet_cli::{usage, ExitKind, KindExt};

fn parse_colormap(s: &str) -> std::result::Result<Colormap, String> {
    s.parse().map_err(|e: tet_preint::TfError| e.to_string())
}

#[derive(Debug, clap::Args)]
pub struct BakeArgs {
    /// Transfer function: formats/tf.md JSON or a ParaView preset. Without
    /// it (and with --bundle): the bundle's automatic TF, as `tetview
    /// render` builds it.
    #[arg(long, value_name = "tf.json")]
    pub tf: Option<PathBuf>,
    /// Colour map of the automatic TF, or replacing the colours of --tf:
    /// viridis, inferno, magma, plasma, cool-to-warm, turbo, grayscale.
    #[arg(long, value_parser = parse_colormap)]
    pub colormap: Option<Colormap>,
    /// Multiplies every extinction of the TF.
    #[arg(long, default_value_t = 1.0)]
    pub opacity_scale: f64,
    /// Write the TF baked (formats/tf.md JSON) to edit it.
    #[arg(long, value_name = "tf.json")]
    pub save_tf: Option<PathBuf>,
    /// Method id (exact, pt-linear, table3d, atlas2d, poly1, poly2, poly4,
    /// partial, biv-exact, biv-approx); untabulated methods store the TF only.
    #[arg(long, value_parser = parse_method)]
    pub method: Method,
    #[command(flatten)]
    pub domain: DomainArgs,
    #[command(flatten)]
    pub table: TableArgs,
    /// Output .tetl (written atomically).
    #[arg(short, long, value_name = "lut.tetl")]
    pub output: PathBuf,
    /// Print the summary as JSON.
    #[arg(long)]
    pub json: bool,
}

pub fn run(args: &BakeArgs) -> Result<()> {
    let given = args.tf.as_deref().map(read_tf).transpose()?;
    // The automatic TF needs the bundle (read again by the domain below).
    let bundle = match (&given, &args.domain.bundle) {
        (None, None) => return Err(usage("give --tf, or --bundle for its automatic transfer function")),
        (None, Some(p)) => Some(read_bundle(p)?),
        (Some(_), _) => None,
    };
    let (tf, auto) = tet_preint::choose_tf(given, bundle.as_ref(), args.colormap, args.opacity_scale)?;
    if let Some(note) = auto.as_ref().and_then(|a| a.source.note()) {
        eprintln!("warning: {note}");
    }
    let opts = args.table.options(args.method)?;
    let tabulated = args.method.is_tabulated();
    let (domain, bundle) = args.domain.resolve(&tf, tabulated)?;
    if let Some(b) = &bundle {
        warn_if_constant_scalar(b);
    }
    let tf = tf_in_data_units(&tf, &domain, bundle.as_ref())?;
    if let Some(p) = &args.save_tf {
        std::fs::write(p, tf.to_json()).with_context(|| format!("writing {}", p.display())).kind(ExitKind::Output)?;
    }
    let spinner = (!args.json).then(|| {
        let s = indicatif::ProgressBar::new_spinner();
        s.set_message(format!("baking {} {}", args.method, describe_res(args.method, &opts)));
        s.enable_steady_tick(std::time::Duration::from_millis(200));
        s
    });
    let t0 = Instant::now();
    // table3d certifies against the bundle's own segments too, when it has one.
    let cells = match (&bundle, args.method, opts.certify.max_error) {
        (Some(b), Method::Table3d, Some(_)) => {
            tet_preint::certify::cell_triples(b, &domain, opts.certify.samples, opts.certify.seed ^ 0xce11)
        }
        _ => Vec::new(),
    };
    let baked = Baked::build_with_cells(args.method, &tf, &domain, &opts, &cells)
        .with_context(|| format!("cannot bake {}", args.method))
        .kind(ExitKind::Bake)?;
    let bake_s = t0.elapsed().as_secs_f64();
    if let Some(s) = spinner {
        s.finish_and_clear();
    }
    let lut = baked.to_lut(&tf, &domain);
    lut.write(&args.output).map_err(anyhow::Error::new).kind(ExitKind::Output)?;
    let file_bytes = std::fs::metadata(&args.output).map(|m| m.len()).unwrap_or(0);
    let (mem, full) = (baked.memory_bytes(), baked.full_memory_bytes());
    let saved = if full > 0 { 1.0 - mem as f64 / full as f64 } else { 0.0 };
    // table3d's lookup (formats/lut.md, "Lookup"): chosen from the entries.
    let lookup = match &baked {
        Baked::Table3d(t) => Some((t.reconstruction().id(), t.reconstruction_gap())),
        _ => None,
    };
    let certificate = match &baked {
        Baked::Table3d(t) => t.certificate().cloned(),
        _ => None,
    };
    let final_res = match &baked {
        Baked::Table3d(t) => {
            format!("{}x{}x{} {}", t.params().n_s, t.params().n_s, t.params().n_l, t.params().precision)
        }
        _ => describe_res(args.method, &opts),
    };
    if args.json {
        let v = json!({
            "output": args.output.display().to_string(),
            "method": args.method.id(),
            "resolution": final_res,
            "bundle": bundle.as_ref().and(args.domain.bundle.as_ref()).map(|p| p.display().to_string()),
            "domain": domain,
            "bake_seconds": bake_s,
            "memory_bytes": mem,
            "full_domain_memory_bytes": full,
            "memory_saved_fraction": saved,
            "file_bytes": file_bytes,
            "lookup": lookup.map(|(l, _)| l),
            "reconstruction_gap": lookup.map(|(_, g)| g),
            "certificate": certificate,
        });
        println!("{}", serde_json::to_string_pretty(&v)?);
    } else {
        println!("wrote {} ({})", args.output.display(), human_bytes(file_bytes as usize));
        println!("method      {} {}", args.method, final_res);
        println!(
            "domain      s in [{}, {}], |Sf - Sb| <= {}, l <= {}",
            domain.s_lo, domain.s_hi, domain.max_ds, domain.len_max_world
        );
        println!("bake time   {:.1} ms", bake_s * 1e3);
        if let Some((l, gap)) = lookup {
            println!("lookup      {l} (reconstruction gap {gap:.2e}; optical depth above {RECONSTRUCTION_GAP:e})");
        }
        if let Some(c) = &certificate {
            println!("error       {}", c.summary());
        }
        if tabulated {
            println!(
                "memory      {} (full domain: {}; saved {:.1}%)",
                human_bytes(mem),
                human_bytes(full),
                100.0 * saved
            );
        } else {
            println!("memory      nothing tabulated ({} evaluates the TF per segment)", args.method);
        }
    }
    Ok(())
}
