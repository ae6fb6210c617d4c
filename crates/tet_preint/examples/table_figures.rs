//! Prints table3d build time and node error against `exact` for the VTK
//! test transfer functions (program output, not a timed test):
//! `cargo run --release -p tet_preint --example table_figures -- [n_s n_l oversampling...]`
use std::time::Instant;
use tet_preint::*;

fn main() {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let n_s: usize = args.first().map(|a| a.parse().unwrap()).unwrap_or(128);
    let n_l: usize = args.get(1).map(|a| a.parse().unwrap()).unwrap_or(256);
    let overs: Vec<f32> =
        if args.len() > 2 { args[2..].iter().map(|a| a.parse().unwrap()).collect() } else { vec![2.0] };
    let dir = concat!(env!("CARGO_MANIFEST_DIR"), "/tests/data/vtk");
    for name in ["ramp", "dense", "mild"] {
        let tf =
            TransferFunction::from_json(&std::fs::read_to_string(format!("{dir}/tf_{name}.json")).unwrap()).unwrap();
        let lo = tf.opacity_nodes()[0].x.min(tf.color_nodes()[0].x);
        let hi = tf.opacity_nodes().last().unwrap().x.max(tf.color_nodes().last().unwrap().x);
        let d = TableDomain::full(lo, hi, 2.0 * (hi - lo)).unwrap();
        for &o in &overs {
            for build in [Build3d::SliceRecurrence { oversampling: o }] {
                let p = Table3dParams { n_s, n_l, build, precision: Precision::F32 };
                let t0 = Instant::now();
                let t = Table3d::build(&tf, &d, &p).unwrap();
                let secs = t0.elapsed().as_secs_f64();
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
                    "{name:6} {build:?} {n_s}x{n_s}x{n_l}: {secs:.3} s, node max {worst:.2e} at {at:?}, rms {:.2e}",
                    (sum / cnt as f64).sqrt()
                );
            }
        }
    }
}
