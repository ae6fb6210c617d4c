//! Before/after figures of issue 16 (crates/tetlut/results/certified.md):
//! per TF (the sample and the held-out ones of tests/data/heldout), on the
//! bundled Blunt Fin's domain, the default table3d as it was (128 × 128 ×
//! 256, data axis, plain lookup) and as the certify-and-refine bake makes
//! it, each re-measured on 100 000 fresh segments per set (other seeds
//! than the bake's). Plus the near-constant field case: the same TFs over
//! a scalar range of 1e-2 around 100.
//!
//!     cargo run --release -p tet_preint --example certify_heldout [TF names…]
#[path = "../tests/common/bluntfin.rs"]
mod bluntfin;

use std::path::Path;
use std::time::Instant;
use tet_preint::certify::{self, CertifiedTable3d, CertifyOptions};
use tet_preint::{tf_for_domain, BakeOptions, Table3d, TableDomain, TransferFunction};

fn main() {
    let root = Path::new(env!("CARGO_MANIFEST_DIR"));
    let mesh = bluntfin::mesh();
    let bf = bluntfin::domain(&mesh);
    let cells = |n: usize, seed: u64| bluntfin::cell_triples(&mesh, n, seed);
    let bake_cells = cells(16_384, 0xce11);
    let check_cells = cells(100_000, 0x7e71);
    let near = TableDomain::new(100.0, 100.01, 0.01, bf.len_max_world).unwrap();
    let names: Vec<String> = std::env::args().skip(1).collect();
    let mut tfs: Vec<(String, String)> = vec![(
        "tf_normalized (sample)".into(),
        root.join("../../formats/samples/tf_normalized.json").display().to_string(),
    )];
    for n in ["tf_peaks12", "tf_sharp8", "tf_steps", "tf_plateaus"] {
        tfs.push((n.into(), root.join(format!("tests/data/heldout/{n}.json")).display().to_string()));
    }
    let base = BakeOptions::default().table3d;
    println!("| TF | domain | before: cells / uniform / tf-nodes max | after: table | lookup | bake ms | memory | certificate max | re-measured cells / uniform / tf-nodes max |");
    println!("|---|---|---|---|---|---:|---:|---|---|");
    for (name, path) in &tfs {
        if !names.is_empty() && !names.iter().any(|n| name.starts_with(n.as_str())) {
            continue;
        }
        let tfn = TransferFunction::from_json(&std::fs::read_to_string(path).unwrap()).unwrap();
        for (dname, domain, with_cells) in [("Blunt Fin", &bf, true), ("near-constant", &near, false)] {
            let tf = tf_for_domain(&tfn, domain).unwrap();
            let (bc, cc): (&[[f32; 3]], &[[f32; 3]]) =
                if with_cells { (&bake_cells, &check_cells) } else { (&[], &[]) };
            let before = CertifiedTable3d::plain(Table3d::build(&tf, domain, &base).unwrap());
            let b = certify::remeasure(&before, &tf, domain, 100_000, 0xbeef, cc);
            let t0 = Instant::now();
            let after = certify::bake(&tf, domain, &base, &CertifyOptions::default(), bc).unwrap();
            let ms = t0.elapsed().as_secs_f64() * 1e3;
            let a = certify::remeasure(&after, &tf, domain, 100_000, 0xbeef, cc);
            let c = after.certificate().unwrap();
            let fmt =
                |v: &[certify::SetError]| v.iter().map(|e| format!("{:.2e}", e.max)).collect::<Vec<_>>().join(" / ");
            println!(
                "| {name} | {dname} | {} | {}x{}x{} | {}{}{} | {ms:.0} | {:.1} MiB | {} {:.2e} | {} |",
                fmt(&b),
                after.params().n_s,
                after.params().n_s,
                after.params().n_l,
                after.reconstruction().id(),
                if after.splits_at_tf_nodes() { ", split at TF nodes" } else { "" },
                if c.exact_intervals.is_empty() {
                    String::new()
                } else {
                    format!(
                        ", exact on {}/{} intervals ({:.0}% of segments)",
                        c.exact_intervals.len(),
                        c.intervals,
                        100.0 * c.exact_share
                    )
                },
                after.memory_bytes() as f64 / (1 << 20) as f64,
                if c.certified { "certified" } else { "NOT certified" },
                c.max_error,
                fmt(&a)
            );
            eprintln!("{name} {dname}: attempts {:?}", c.attempts);
            if std::env::var_os("WORST").is_some() {
                let mut all = certify::node_triples(&tf, domain, 100_000, 0xbeef ^ 0x6e6f_6465);
                all.extend(tet_preint::uniform_triples(domain, 100_000, 0xbeef));
                all.extend_from_slice(cc);
                for (t, e) in certify::worst_segments(&after, &tf, &all, 8) {
                    let ex = tet_preint::integrate_segment(&tf, t[0] as f64, t[1] as f64, t[2] as f64);
                    let got = tet_preint::SegmentShader::shade(
                        &after,
                        &tet_preint::Segment { s_front: t[0], s_back: t[1], len_world: t[2], ..Default::default() },
                    );
                    eprintln!("  worst {t:?} err {e:.3e} exact {:?} got {got:?}", ex.to_array());
                }
            }
        }
    }
}
