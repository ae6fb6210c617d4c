//! table3d's batched lookup (`SegmentShader::shade_batch`, 64 segments a
//! call, single thread): the portable path against the AVX2 kernel, f32
//! against f16 storage, on a bundle's own cell segments; and what the
//! kernel and f16 storage change in the values (max |Δ| against the
//! portable path, against the f32 table and against the exact integrator).
//!
//! `cargo run --release -p tet_preint --example lookup_bench -- B.tetb tf.json [segments] [rounds]`
//!
//! Tables: `BakeOptions::default().table3d` (128 × 128 × 256, data axis,
//! adaptive build) on the bundle's domain, f32 and f16; and the same with
//! the TF's unit distance divided by 50 (50× the extinction), which makes the
//! table take the optical-depth reconstruction. Segment streams:
//!
//! * `random`: `tet_analysis::sample_cell_segments` (random cells, random
//!   chords) in draw order: every lookup in a different part of the table,
//!   cache misses dominate.
//! * `frame`: a frame's stream, approximately: every tet in id order (the
//!   bundle's ids follow the grid, so neighbours are near), 32 chords
//!   (Blunt Fin at 512² has ~32 fragments a tet) parallel to one view
//!   direction through random points of the tet; consecutive lookups share
//!   cells and cache lines as a tet's fragments do.
//! * `hot`: uniform in a window of 2 × 2 scalar steps × 4 length steps
//!   inside the band: the table cache-resident, the compute floor.
use rayon::prelude::*;
use std::time::Instant;
use tet_preint::*;

fn main() {
    let args: Vec<String> = std::env::args().collect();
    if args.len() < 3 {
        eprintln!("usage: lookup_bench B.tetb tf.json [segments] [rounds]");
        std::process::exit(2);
    }
    let bundle = tet_bundle::Bundle::read(std::path::Path::new(&args[1])).expect("bundle");
    let tf_text = std::fs::read_to_string(&args[2]).expect("tf");
    let count: usize = args.get(3).map_or(2_000_000, |s| s.parse().expect("segments"));
    let rounds: usize = args.get(4).map_or(7, |s| s.parse().expect("rounds"));
    let domain = TableDomain::from_bundle(&bundle).expect("domain");
    let m = &bundle.mesh;
    let sampled = tet_analysis::sample_cell_segments(&m.points, &m.tets, &m.scalar, None, count, 0x7e71);
    let seg = |s: &tet_analysis::SampledSegment| Segment {
        s_front: s.s_front as f32,
        s_back: s.s_back as f32,
        len_world: s.len_world as f32,
        ..Default::default()
    };
    let random: Vec<Segment> = sampled.iter().map(seg).collect();
    let frame = frame_segments(m, [0.36, 0.48, 0.8], 32);
    let hot: Vec<Segment> = {
        let (span, dl) = (domain.scalar_span(), domain.len_max_world / 255.0);
        let (s0, ds) = (domain.s_lo + 0.2 * span, span / 127.0);
        let mut rng = tet_mesh::SplitMix64(0x40f);
        (0..frame.len())
            .map(|_| Segment {
                s_front: (s0 + 2.0 * ds * rng.next_f64()) as f32,
                s_back: (s0 + 2.0 * ds * rng.next_f64()) as f32,
                len_world: (40.0 * dl + 4.0 * dl * rng.next_f64()) as f32,
                ..Default::default()
            })
            .collect()
    };
    let n = random.len();
    println!(
        "{} tets; segments: random {n}, frame {}, hot {}; domain s [{:.4}, {:.4}], max_ds {:.4}, l_max {:.4}",
        m.tets.len(),
        frame.len(),
        hot.len(),
        domain.s_lo,
        domain.s_hi,
        domain.max_ds,
        domain.len_max_world
    );

    let dense_text = {
        let mut v: serde_json::Value = serde_json::from_str(&tf_text).expect("tf json");
        let u = v["unit_distance"].as_f64().unwrap_or(1.0);
        v["unit_distance"] = serde_json::json!(u / 50.0);
        v.to_string()
    };
    // `LOOKUP_BENCH_ONLY="avx2 f32"` (a kernel and storage), `LOOKUP_BENCH_STREAM`,
    // `LOOKUP_BENCH_TF=0|1`: time one case only (e.g. under a profiler).
    let only = std::env::var("LOOKUP_BENCH_ONLY").ok();
    let o_stream = std::env::var("LOOKUP_BENCH_STREAM").unwrap_or_default();
    let tf_only: Option<usize> = std::env::var("LOOKUP_BENCH_TF").ok().and_then(|v| v.parse().ok());
    // `LOOKUP_BENCH_AXIS=uniform|tf-nodes|data` (default data, `BakeOptions`').
    let s_axis = match std::env::var("LOOKUP_BENCH_AXIS").as_deref() {
        Ok("uniform") => ScalarAxis::Uniform,
        Ok("tf-nodes") => ScalarAxis::TfNodes,
        _ => ScalarAxis::Data,
    };
    for (k, (tf_name, text)) in [("tf", &tf_text), ("tf, extinction x50", &dense_text)].into_iter().enumerate() {
        if tf_only.is_some_and(|t| t != k) {
            continue;
        }
        let tf = tf_for_domain(&TransferFunction::from_json(text).expect("tf"), &domain).expect("tf for domain");
        let bake = |precision: Precision| {
            let p = Table3dParams { precision, s_axis, ..BakeOptions::default().table3d };
            let t0 = Instant::now();
            let t = Table3d::build(&tf, &domain, &p).expect("bake");
            eprintln!("baked {precision} in {:.1} s", t0.elapsed().as_secs_f64());
            t
        };
        let (t32, t16) = (bake(Precision::F32), bake(Precision::F16));
        println!(
            "\n## {tf_name}, {s_axis:?} axis: {} reconstruction (gap {:.2e}), f32 {:.1} MiB, f16 {:.1} MiB, kernel {}",
            t32.reconstruction().id(),
            t32.reconstruction_gap(),
            t32.memory_bytes() as f64 / (1 << 20) as f64,
            t16.memory_bytes() as f64 / (1 << 20) as f64,
            t32.lookup_kernel_in_use()
        );
        // Values: kernel vs portable (both storages), f16 vs f32, both vs exact.
        let shade_all = |t: &Table3d, segs: &[Segment]| -> Vec<Rgba32> {
            let mut out = Vec::with_capacity(segs.len());
            let mut o = [[0.0f32; 4]; BATCH];
            for c in segs.chunks(BATCH) {
                t.shade_batch(&SegmentBatch::from_segments(c), &mut o);
                out.extend_from_slice(&o[..c.len()]);
            }
            out
        };
        let max_diff = |a: &[Rgba32], b: &[Rgba32]| -> f64 {
            a.iter()
                .zip(b)
                .flat_map(|(x, y)| (0..4).map(move |c| (x[c] as f64 - y[c] as f64).abs()))
                .fold(0.0, f64::max)
        };
        let portable = |t: &Table3d| t.clone().with_lookup_kernel(LookupKernel::Portable);
        let (p32, p16) = (portable(&t32), portable(&t16));
        let (a32, a16) = (shade_all(&t32, &random), shade_all(&t16, &random));
        let (q32, q16) = (shade_all(&p32, &random), shade_all(&p16, &random));
        let exact_n = n.min(200_000);
        let exact: Vec<Rgba32> = random[..exact_n]
            .par_iter()
            .map_init(Vec::new, |scr, s| {
                let r = integrate_segment_with(&tf, s.s_front as f64, s.s_back as f64, s.len_world as f64, scr);
                r.to_array().map(|v| v as f32)
            })
            .collect();
        let rms = |a: &[Rgba32], b: &[Rgba32]| -> f64 {
            let s: f64 =
                a.iter().zip(b).flat_map(|(x, y)| (0..4).map(move |c| (x[c] as f64 - y[c] as f64).powi(2))).sum();
            (s / (4 * a.len()) as f64).sqrt()
        };
        println!("max |avx2 − portable|: f32 {:.3e}, f16 {:.3e}", max_diff(&a32, &q32), max_diff(&a16, &q16));
        println!("max |f16 − f32 table| {:.3e} (RMS {:.3e})", max_diff(&a16, &a32), rms(&a16, &a32));
        println!(
            "vs exact ({exact_n} segments): f32 max {:.3e} RMS {:.3e}; f16 max {:.3e} RMS {:.3e}",
            max_diff(&a32[..exact_n], &exact),
            rms(&a32[..exact_n], &exact),
            max_diff(&a16[..exact_n], &exact),
            rms(&a16[..exact_n], &exact)
        );
        // Timings: batches built outside the timing; the cases interleaved
        // round by round (a load spike from another process then hits all
        // of them), best of `rounds` each.
        for (stream, segs) in [("random", &random), ("frame", &frame), ("hot", &hot)] {
            if !stream.contains(o_stream.as_str()) {
                continue;
            }
            let n = segs.len();
            let batches: Vec<SegmentBatch> = segs.chunks(BATCH).map(SegmentBatch::from_segments).collect();
            let cases: Vec<(&str, &Table3d)> =
                [("portable f32", &p32), ("avx2 f32", &t32), ("portable f16", &p16), ("avx2 f16", &t16)]
                    .into_iter()
                    .filter(|(name, _)| only.as_ref().is_none_or(|o| name.contains(o.as_str())))
                    .collect();
            let mut best = vec![f64::INFINITY; cases.len()];
            let mut sink = 0.0f32;
            let mut out = [[0.0f32; 4]; BATCH];
            for _ in 0..rounds {
                for (k, (_, t)) in cases.iter().enumerate() {
                    let t0 = Instant::now();
                    for b in &batches {
                        t.shade_batch(b, &mut out);
                        sink += out[0][3];
                    }
                    best[k] = best[k].min(t0.elapsed().as_secs_f64());
                }
            }
            for ((name, _), b) in cases.iter().zip(&best) {
                println!("{stream:>6} {name:>13}: {:6.2} ns/segment", b * 1e9 / n as f64);
            }
            println!("(sink {sink:.3})");
        }
    }
}

/// `per_tet` chords parallel to `dir` through random points of every tet,
/// tets in id order, entry first (module docs: the `frame` stream).
fn frame_segments(m: &tet_mesh::TetMesh, dir: [f64; 3], per_tet: usize) -> Vec<Segment> {
    let norm = (dir[0] * dir[0] + dir[1] * dir[1] + dir[2] * dir[2]).sqrt();
    let d = dir.map(|x| x / norm);
    let mut rng = tet_mesh::SplitMix64(0xf7a3e);
    let mut out = Vec::with_capacity(m.tets.len() * per_tet);
    for t in &m.tets {
        let p = t.map(|v| m.points[v as usize]);
        let s = t.map(|v| m.scalar[v as usize]);
        let e = |k: usize| [p[k][0] - p[0][0], p[k][1] - p[0][1], p[k][2] - p[0][2]];
        let (e1, e2, e3) = (e(1), e(2), e(3));
        let cross = |a: [f64; 3], b: [f64; 3]| {
            [a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0]]
        };
        let dot = |a: [f64; 3], b: [f64; 3]| a[0] * b[0] + a[1] * b[1] + a[2] * b[2];
        let det = dot(e1, cross(e2, e3));
        if det.abs() < 1e-300 {
            continue;
        }
        // Rows of [e1 e2 e3]⁻¹: the gradients of barycentrics 1..3.
        let g = [cross(e2, e3), cross(e3, e1), cross(e1, e2)].map(|r| r.map(|x| x / det));
        // Rate of change of the four barycentrics along d.
        let gd = [dot(g[0], d), dot(g[1], d), dot(g[2], d)];
        let rate = [-(gd[0] + gd[1] + gd[2]), gd[0], gd[1], gd[2]];
        for _ in 0..per_tet {
            // A uniform point: barycentrics from normalized exponentials.
            let w: [f64; 4] = std::array::from_fn(|_| -(1.0 - rng.next_f64()).ln());
            let sum: f64 = w.iter().sum();
            let lam = w.map(|x| x / sum);
            let (mut t_in, mut t_out) = (f64::NEG_INFINITY, f64::INFINITY);
            for i in 0..4 {
                if rate[i] > 0.0 {
                    t_in = t_in.max(-lam[i] / rate[i]);
                } else if rate[i] < 0.0 {
                    t_out = t_out.min(-lam[i] / rate[i]);
                }
            }
            if !(t_in.is_finite() && t_out.is_finite()) {
                continue;
            }
            let at = |t: f64| (0..4).map(|i| (lam[i] + t * rate[i]).max(0.0) * s[i]).sum::<f64>();
            out.push(Segment {
                s_front: at(t_in) as f32,
                s_back: at(t_out) as f32,
                len_world: (t_out - t_in) as f32,
                ..Default::default()
            });
        }
    }
    out
}
