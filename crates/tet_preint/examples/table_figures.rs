//! Prints table3d build time and node error against `exact` for the VTK
//! test transfer functions (program output, not a timed test):
//! `cargo run --release -p tet_preint --example table_figures -- [n_s n_l build...]`
use std::time::Instant;

/// User + system CPU seconds of this process (Linux /proc; 0 elsewhere):
/// on a shared machine the wall time is inflated by other loads, the CPU
/// time much less so.
fn cpu_seconds() -> f64 {
    let stat = std::fs::read_to_string("/proc/self/stat").unwrap_or_default();
    let after = stat.rsplit(')').next().unwrap_or("");
    let f: Vec<f64> = after.split_whitespace().map(|x| x.parse().unwrap_or(0.0)).collect();
    // Fields 14 and 15 (utime, stime) are at 11 and 12 after the ')'; 100 ticks/s.
    if f.len() > 12 {
        (f[11] + f[12]) / 100.0
    } else {
        0.0
    }
}
use tet_preint::*;

fn main() {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let n_s: usize = args.first().map(|a| a.parse().unwrap()).unwrap_or(128);
    let n_l: usize = args.get(1).map(|a| a.parse().unwrap()).unwrap_or(256);
    // Builds: a number is the recurrence's oversampling; `incremental`,
    // `exact`, or `blend:STEPS:BITS` (Röttger & Ertl's (2002) emulation).
    let builds: Vec<Build3d> = if args.len() > 2 {
        args[2..]
            .iter()
            .map(|a| match a.as_str() {
                "incremental" => Build3d::Incremental,
                "exact" => Build3d::Exact,
                b if b.starts_with("blend:") => {
                    let v: Vec<&str> = b.split(':').collect();
                    Build3d::Blend {
                        steps: v[1].parse().unwrap(),
                        accumulation: Accumulation::new(v[2].parse().unwrap()).unwrap(),
                    }
                }
                o => Build3d::SliceRecurrence { oversampling: o.parse().unwrap() },
            })
            .collect()
    } else {
        vec![Build3d::default()]
    };
    let dir = concat!(env!("CARGO_MANIFEST_DIR"), "/tests/data/vtk");
    for name in ["ramp", "dense", "mild"] {
        let tf =
            TransferFunction::from_json(&std::fs::read_to_string(format!("{dir}/tf_{name}.json")).unwrap()).unwrap();
        let lo = tf.opacity_nodes()[0].x.min(tf.color_nodes()[0].x);
        let hi = tf.opacity_nodes().last().unwrap().x.max(tf.color_nodes().last().unwrap().x);
        let d = TableDomain::full(lo, hi, 2.0 * (hi - lo)).unwrap();
        {
            for &build in &builds {
                let p = Table3dParams { n_s, n_l, build, precision: Precision::F32, s_axis: Default::default() };
                let (t0, c0) = (Instant::now(), cpu_seconds());
                let t = Table3d::build(&tf, &d, &p).unwrap();
                let (secs, cpu) = (t0.elapsed().as_secs_f64(), cpu_seconds() - c0);
                let (mut worst, mut sum, mut cnt) = (0.0f64, 0.0f64, 0usize);
                let mut at = (0, 0, 0);
                for a in (0..n_s).step_by(3) {
                    for b in (0..n_s).step_by(1) {
                        for k in (0..n_l).step_by(7) {
                            let e = t.entry(a, b, k).unwrap();
                            let x = integrate_segment(&tf, t.scalar_at(a), t.scalar_at(b), t.len_at(k)).to_array();
                            for c in 0..4 {
                                let err = (e[c] as f64 - x[c]).abs();
                                if err > worst {
                                    worst = err;
                                    at = (a, b, k);
                                }
                                sum += err * err;
                                cnt += 1;
                            }
                        }
                    }
                }
                println!(
                    "{name:6} {build:?} {n_s}x{n_s}x{n_l}: {secs:.3} s wall, {cpu:.2} s CPU, node max {worst:.2e} at {at:?}, rms {:.2e}",
                    (sum / cnt as f64).sqrt()
                );
            }
        }
    }
}
