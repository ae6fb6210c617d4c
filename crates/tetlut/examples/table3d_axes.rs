//! Where a table3d's error on a bundle's own cell segments comes from, by
//! axis: bakes the default (128 × 128 × 256, TF-node scalar axis) and the
//! same with one axis refined at a time, and bins the error of every
//! segment by its scalar position, |Sf − Sb| and length.
//!
//! `cargo run --release -p tetlut --example table3d_axes -- B.tetb tf.json [segments]`

use std::time::Instant;

use rayon::prelude::*;
use tet_preint::table3d::{ScalarAxis, Table3d, Table3dParams};
use tet_preint::{integrate_segment_with, SegmentShader};

mod common;

fn main() {
    let args: Vec<String> = std::env::args().collect();
    let (bundle, domain, tf) = common::bundle_domain_tf(&args);
    let count: usize = args.get(3).map_or(200_000, |s| s.parse().expect("count"));
    println!("quantiles {:?}", domain.s_quantiles);
    println!(
        "domain s [{:.6e}, {:.6e}] span {:.6e}, max_ds {:.6e}, len_max {:.6e}",
        domain.s_lo,
        domain.s_hi,
        domain.scalar_span(),
        domain.max_ds,
        domain.len_max_world
    );
    let m = &bundle.mesh;
    let segs = tet_analysis::sample_cell_segments(&m.points, &m.tets, &m.scalar, None, count, 0x7e71);
    let refs: Vec<[f64; 4]> = segs
        .par_iter()
        .map_init(Vec::new, |scr, s| integrate_segment_with(&tf, s.s_front, s.s_back, s.len_world, scr).to_array())
        .collect();
    let q = |mut v: Vec<f64>, name: &str| {
        v.sort_by(f64::total_cmp);
        let at = |p: f64| v[((v.len() - 1) as f64 * p) as usize];
        println!(
            "{name:>22}: p1 {:.3e} p10 {:.3e} p50 {:.3e} p90 {:.3e} p99 {:.3e} p99.9 {:.3e} max {:.3e}",
            at(0.01),
            at(0.1),
            at(0.5),
            at(0.9),
            at(0.99),
            at(0.999),
            at(1.0)
        );
    };
    let span = domain.scalar_span();
    q(segs.iter().map(|s| s.len_world / domain.len_max_world).collect(), "l / len_max");
    q(segs.iter().map(|s| (s.s_front.min(s.s_back) - domain.s_lo) / span).collect(), "min(Sf,Sb) normalized");
    q(segs.iter().map(|s| (s.s_front - s.s_back).abs() / span).collect(), "|Sf-Sb| / span");
    q(segs.iter().map(|s| s.len_world * tf.extinction(0.5 * (s.s_front + s.s_back))).collect(), "optical depth (mid)");
    q(refs.iter().map(|r| r[3]).collect(), "reference alpha");
    let base = Table3dParams::tf_nodes();
    let configs: Vec<(String, Table3dParams)> = vec![
        ("128x128x256 tf-nodes".into(), base),
        ("128x128x1024 tf-nodes".into(), Table3dParams { n_l: 1024, ..base }),
        ("128x128x256 data".into(), Table3dParams::data()),
        ("96x96x256 data".into(), Table3dParams { n_s: 96, ..Table3dParams::data() }),
        ("128x128x256 uniform".into(), Table3dParams { s_axis: ScalarAxis::Uniform, ..base }),
    ];
    for (name, p) in configs {
        let t0 = Instant::now();
        let t = match Table3d::build(&tf, &domain, &p) {
            Ok(t) => t,
            Err(e) => {
                println!("{name}: {e}");
                continue;
            }
        };
        let ms = t0.elapsed().as_secs_f64() * 1e3;
        let k = t.s_knots();
        println!("{name}: {} knots, first steps {:?}", k.len(), &k[..k.len().min(4)]);
        let errs: Vec<f64> = segs
            .par_iter()
            .zip(&refs)
            .map(|(s, r)| {
                let seg = tet_preint::Segment {
                    s_front: s.s_front as f32,
                    s_back: s.s_back as f32,
                    len_world: s.len_world as f32,
                    ..Default::default()
                };
                let got = t.shade(&seg);
                (0..4).map(|c| (f64::from(got[c]) - r[c]).abs()).fold(0.0, f64::max)
            })
            .collect();
        // Single-thread shade_span cost over the cell segments (best of 3).
        let ts: Vec<tet_preint::Segment> = segs
            .iter()
            .map(|s| tet_preint::Segment {
                s_front: s.s_front as f32,
                s_back: s.s_back as f32,
                len_world: s.len_world as f32,
                ..Default::default()
            })
            .collect();
        let mut out = vec![[0.0f32; 4]; ts.len()];
        let ns = (0..3)
            .map(|_| {
                let t0 = Instant::now();
                t.shade_span(&ts, &mut out);
                t0.elapsed().as_secs_f64() * 1e9 / ts.len() as f64
            })
            .fold(f64::INFINITY, f64::min);
        println!("{name}: shade_span {ns:.0} ns/segment");
        let rms = (errs.iter().map(|e| e * e).sum::<f64>() / errs.len() as f64).sqrt();
        let max = errs.iter().copied().fold(0.0, f64::max);
        println!(
            "\n{name}: bake {ms:.0} ms, {:.1} MiB; cells RMS(max ch) {rms:.3e} max {max:.3e}",
            t.memory_bytes() as f64 / (1 << 20) as f64
        );
        // Error share by bins: l/len_max decade, normalized scalar decade.
        let bin = |x: f64| if x <= 0.0 { 0 } else { ((x.log10() + 7.0).floor().clamp(0.0, 7.0)) as usize };
        let mut by_l = [(0usize, 0.0f64, 0.0f64); 8];
        let mut by_s = [(0usize, 0.0f64, 0.0f64); 8];
        for (s, e) in segs.iter().zip(&errs) {
            for (arr, x) in [
                (&mut by_l, s.len_world / domain.len_max_world),
                (&mut by_s, (0.5 * (s.s_front + s.s_back) - domain.s_lo) / span),
            ] {
                let b = &mut arr[bin(x)];
                b.0 += 1;
                b.1 += e * e;
                b.2 = b.2.max(*e);
            }
        }
        let total: f64 = errs.iter().map(|e| e * e).sum();
        for (label, arr) in [("l/len_max", &by_l), ("s_mid norm", &by_s)] {
            let cells: Vec<String> = arr
                .iter()
                .enumerate()
                .filter(|b| b.1 .0 > 0)
                .map(|(i, b)| format!("1e{}: n {} sq {:.0}% max {:.1e}", i as i32 - 7, b.0, 100.0 * b.1 / total, b.2))
                .collect();
            println!("  {label}: {}", cells.join(" | "));
        }
    }
}
