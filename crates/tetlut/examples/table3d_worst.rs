//! Where a table3d's largest errors are: bakes 128 × 128 × 256 tables on a
//! bundle's domain with several scalar axes and prints, per axis, the RMS and
//! max error over the two segment sets of `tetlut bench` (10⁶ cell segments,
//! seed 0x7e71; 10⁶ uniform triples, seed 0x7e72) and the worst segments
//! with their table cell, the grid steps there and the nearest TF node.
//!
//! `cargo run --release -p tetlut --example table3d_worst -- B.tetb tf.json [samples] [axes]`
//!
//! axes: comma-separated of `uniform`, `tf-nodes`, `data`, or
//! `graded:C:P` — the data axis with steps near every TF node capped
//! at max(C·u, (C·u)^(1−P)·r^P) (u the uniform step, r the distance to the
//! node), prototyped here before it went into `tet_preint`.

use std::time::Instant;

use rayon::prelude::*;
use tet_preint::table3d::{tf_nodes_in, ScalarAxis, Table3d, Table3dParams};
use tet_preint::{integrate_segment_with, Segment, SegmentShader, TableDomain, TransferFunction};

mod common;

/// Prototype: the data axis's measure with the step near every node capped.
fn graded_knots(tf: &TransferFunction, d: &TableDomain, n_s: usize, c: f64, p: f64) -> Vec<(f64, usize)> {
    let (lo, hi) = (d.s_lo, d.s_hi);
    let span = d.scalar_span();
    let u = span / (n_s - 1) as f64;
    let nodes = tf_nodes_in(tf, d);
    let q = d.s_quantiles.expect("bundle domain has quantiles").0;
    // Data density per unit scalar (√ of the quantile bins' density), normalized.
    let fine = 64 * n_s;
    let xs: Vec<f64> = (0..=fine).map(|i| lo + span * i as f64 / fine as f64).collect();
    let dens_data = |s: f64| -> f64 {
        let k = q.partition_point(|&x| x <= s).clamp(1, q.len() - 1);
        let w = (q[k] - q[k - 1]).max(1e-12 * span);
        (1.0 / w).sqrt()
    };
    let total_data: f64 = xs.windows(2).map(|w| dens_data(0.5 * (w[0] + w[1])) * (w[1] - w[0])).sum();
    let g = |s: f64| 0.5 / span + 0.5 * dens_data(s) / total_data;
    let cap = |s: f64| -> f64 {
        nodes
            .iter()
            .map(|&n| {
                let r = (s - n).abs();
                let h0 = c * u;
                1.0 / h0.max(h0.powf(1.0 - p) * r.powf(p))
            })
            .fold(0.0, f64::max)
    };
    let steps = (n_s - 1) as f64;
    let integral = |lam: f64| -> f64 {
        xs.windows(2)
            .map(|w| {
                let m = 0.5 * (w[0] + w[1]);
                (lam * g(m)).max(cap(m)) * (w[1] - w[0])
            })
            .sum()
    };
    let lam = bisect(integral, steps, (0.0, steps), 60);
    let mut cum = vec![0.0f64; xs.len()];
    for i in 1..xs.len() {
        let m = 0.5 * (xs[i - 1] + xs[i]);
        cum[i] = cum[i - 1] + (lam * g(m)).max(cap(m)) * (xs[i] - xs[i - 1]);
    }
    let gg = |s: f64| -> f64 {
        let i = ((s - lo) / span * fine as f64).floor().clamp(0.0, (fine - 1) as f64) as usize;
        let t = (s - xs[i]) / (xs[i + 1] - xs[i]);
        cum[i] + t * (cum[i + 1] - cum[i])
    };
    // Knots: nodes, steps per interval ∝ G-measure (largest remainder, ≥ 1).
    let mut ks = vec![lo];
    ks.extend(&nodes);
    ks.push(hi);
    let total = gg(hi);
    let ideal: Vec<f64> = ks.windows(2).map(|w| steps * (gg(w[1]) - gg(w[0])) / total).collect();
    let mut count: Vec<usize> = ideal.iter().map(|&r| (r.floor() as usize).max(1)).collect();
    while count.iter().sum::<usize>() < n_s - 1 {
        let j = (0..count.len())
            .max_by(|&x, &y| (ideal[x] - count[x] as f64).total_cmp(&(ideal[y] - count[y] as f64)))
            .unwrap();
        count[j] += 1;
    }
    while count.iter().sum::<usize>() > n_s - 1 {
        let j = (0..count.len())
            .filter(|&j| count[j] > 1)
            .min_by(|&x, &y| (ideal[x] - count[x] as f64).total_cmp(&(ideal[y] - count[y] as f64)))
            .unwrap();
        count[j] -= 1;
    }
    let mut grid = vec![];
    for (w, &cnt) in ks.windows(2).zip(&count) {
        let (g0, g1) = (gg(w[0]), gg(w[1]));
        grid.push(w[0]);
        for j in 1..cnt {
            let target = g0 + (g1 - g0) * j as f64 / cnt as f64;
            grid.push(bisect(gg, target, (w[0], w[1]), 80));
        }
    }
    grid.push(hi);
    grid.into_iter().enumerate().map(|(i, s)| (s, i)).collect()
}

/// Where the increasing `f` reaches `target` within `bracket`: the
/// midpoint of the bracket after `halvings` bisection steps.
fn bisect(f: impl Fn(f64) -> f64, target: f64, bracket: (f64, f64), halvings: usize) -> f64 {
    let (mut a, mut b) = bracket;
    for _ in 0..halvings {
        let m = 0.5 * (a + b);
        if f(m) < target {
            a = m;
        } else {
            b = m;
        }
    }
    0.5 * (a + b)
}

fn main() {
    let args: Vec<String> = std::env::args().collect();
    let (bundle, domain, tf) = common::bundle_domain_tf(&args);
    let count: usize = args.get(3).map_or(1_000_000, |s| s.parse().expect("count"));
    let axes = args.get(4).map_or("tf-nodes,data", |s| s.as_str());
    println!(
        "domain s [{:.6e}, {:.6e}], max_ds {:.6e}, len_max {:.6e}; nodes {:?}",
        domain.s_lo,
        domain.s_hi,
        domain.max_ds,
        domain.len_max_world,
        tf_nodes_in(&tf, &domain)
    );
    let m = &bundle.mesh;
    let cells: Vec<Segment> = tet_analysis::sample_cell_segments(&m.points, &m.tets, &m.scalar, None, count, 0x7e71)
        .into_iter()
        .map(|s| Segment {
            s_front: s.s_front as f32,
            s_back: s.s_back as f32,
            len_world: s.len_world as f32,
            ..Default::default()
        })
        .collect();
    let uniform: Vec<Segment> = tet_preint::uniform_triples(&domain, count, 0x7e72)
        .into_iter()
        .map(|t| Segment { s_front: t[0], s_back: t[1], len_world: t[2], ..Default::default() })
        .collect();
    let refs = |segs: &[Segment]| -> Vec<[f64; 4]> {
        segs.par_iter()
            .map_init(Vec::new, |scr, s| {
                integrate_segment_with(&tf, s.s_front as f64, s.s_back as f64, s.len_world as f64, scr).to_array()
            })
            .collect()
    };
    let sets = [("cells", refs(&cells), &cells), ("uniform", refs(&uniform), &uniform)];
    let nodes = tf_nodes_in(&tf, &domain);
    for name in axes.split(',') {
        let base = Table3dParams::data();
        let t0 = Instant::now();
        let t = if let Some(rest) = name.strip_prefix("graded:") {
            let v: Vec<f64> = rest.split(':').map(|x| x.parse().expect("number")).collect();
            let knots = graded_knots(&tf, &domain, base.n_s, v[0], v[1]);
            Table3d::build_with_knots(&tf, &domain, &base, &knots).expect("bake")
        } else {
            let s_axis = match name {
                "uniform" => ScalarAxis::Uniform,
                "tf-nodes" => ScalarAxis::TfNodes,
                "data" => ScalarAxis::Data,
                _ => panic!("axis {name}"),
            };
            Table3d::build(&tf, &domain, &Table3dParams { s_axis, ..base }).expect("bake")
        };
        let ms = t0.elapsed().as_secs_f64() * 1e3;
        let grid: Vec<f64> = (0..base.n_s).map(|a| t.scalar_at(a)).collect();
        let steps: Vec<f64> = grid.windows(2).map(|w| w[1] - w[0]).collect();
        let u = domain.scalar_span() / (base.n_s - 1) as f64;
        println!("\n== {name}: bake {ms:.0} ms (one run, load: see uptime); {} knots", t.s_knots().len());
        for &n in &nodes {
            let i = grid.iter().position(|&g| (g - n).abs() < 1e-9 * domain.scalar_span());
            if let Some(i) = i {
                let around: Vec<String> =
                    (i.saturating_sub(4)..(i + 4).min(steps.len())).map(|j| format!("{:.2}", steps[j] / u)).collect();
                println!("  node {n:.4} = sample {i}; steps/u around it: {}", around.join(" "));
            } else {
                println!("  node {n:.4} not a sample");
            }
        }
        let smin = steps.iter().copied().fold(f64::INFINITY, f64::min) / u;
        let smax = steps.iter().copied().fold(0.0, f64::max) / u;
        println!("  steps/u: min {smin:.3} max {smax:.3}");
        for (set, r, segs) in &sets {
            let mut errs: Vec<(f64, usize, usize)> = segs
                .par_iter()
                .zip(r.par_iter())
                .enumerate()
                .map(|(i, (s, want))| {
                    let got = t.shade(s);
                    let (mut e, mut ch) = (0.0f64, 0);
                    for c in 0..4 {
                        let d = (f64::from(got[c]) - want[c]).abs();
                        if d > e {
                            (e, ch) = (d, c);
                        }
                    }
                    (e, ch, i)
                })
                .collect();
            // RMS over the four channels, as tetlut bench.
            let sq: f64 = segs
                .par_iter()
                .zip(r.par_iter())
                .map(|(s, want)| {
                    let got = t.shade(s);
                    (0..4).map(|c| (f64::from(got[c]) - want[c]).powi(2)).sum::<f64>()
                })
                .sum();
            let rms = (sq / (4 * segs.len()) as f64).sqrt();
            errs.sort_by(|a, b| b.0.total_cmp(&a.0));
            println!("  {set}: RMS {rms:.3e} max {:.3e}", errs[0].0);
            for &(e, ch, i) in errs.iter().take(6) {
                let s = &segs[i];
                let cell = |x: f64| grid.partition_point(|&g| g <= x).clamp(1, grid.len() - 1) - 1;
                let (a0, b0) = (cell(s.s_front as f64), cell(s.s_back as f64));
                let near = nodes
                    .iter()
                    .map(|&n| ((s.s_front as f64 - n) / u, (s.s_back as f64 - n) / u))
                    .min_by(|x, y| (x.0.abs() + x.1.abs()).total_cmp(&(y.0.abs() + y.1.abs())));
                println!(
                    "    {e:.3e} ch {ch}: Sf {:.5} Sb {:.5} l {:.4} | cell ({a0},{b0}) steps/u {:.2} {:.2} | (Sf,Sb)-node in u {:?}",
                    s.s_front,
                    s.s_back,
                    s.len_world,
                    steps[a0] / u,
                    steps[b0] / u,
                    near.map(|(x, y)| (format!("{x:.2}"), format!("{y:.2}")))
                );
            }
        }
    }
}
