//! Cost of re-baking the default table3d after a TF edit.
//!
//! `cargo run --release -p tetlut --example table3d_rebake -- B.tetb tf.json [repeats]`
use std::time::Instant;
use tet_preint::table3d::Build3d;
use tet_preint::{BakeOptions, Table3d, TableDomain, TransferFunction};

fn main() {
    let args: Vec<String> = std::env::args().collect();
    let bundle = tet_bundle::Bundle::read(std::path::Path::new(&args[1])).expect("bundle");
    let tf = TransferFunction::from_json(&std::fs::read_to_string(&args[2]).expect("tf")).expect("tf json");
    let repeats: usize = args.get(3).map_or(5, |s| s.parse().expect("repeats"));
    let domain = TableDomain::from_bundle(&bundle).expect("domain");
    let tf = tet_preint::tf_for_domain(&tf, &domain).expect("tf for domain");
    let base = BakeOptions::default().table3d;
    let only_adaptive = std::env::var("ONLY_ADAPTIVE").is_ok();
    let exact = Table3d::build(&tf, &domain, &tet_preint::Table3dParams { build: Build3d::Exact, ..base }).unwrap();
    let builds: Vec<Build3d> = if only_adaptive {
        vec![Build3d::Adaptive { tolerance: 1e-5 }]
    } else {
        vec![
            Build3d::SliceRecurrence { oversampling: 2.0 },
            Build3d::Adaptive { tolerance: 1e-5 },
            Build3d::Adaptive { tolerance: 1e-6 },
        ]
    };
    for build in builds {
        let p = tet_preint::Table3dParams { build, ..base };
        let mut best = f64::INFINITY;
        let mut t = None;
        for _ in 0..repeats {
            let t0 = Instant::now();
            let b = Table3d::build(&tf, &domain, &p).expect("bake");
            best = best.min(t0.elapsed().as_secs_f64());
            t = Some(b);
        }
        let t = t.unwrap();
        let (a, b) = (t.storage().as_f32().unwrap(), exact.storage().as_f32().unwrap());
        let max = a.iter().zip(b).map(|(x, y)| (x - y).abs()).fold(0.0f32, f32::max);
        let rms = (a.iter().zip(b).map(|(x, y)| ((x - y) as f64).powi(2)).sum::<f64>() / a.len() as f64).sqrt();
        println!(
            "{build:?}: best of {repeats} {:.1} ms ({} threads); node error vs exact: max {max:.3e} rms {rms:.3e}",
            best * 1e3,
            rayon::current_num_threads()
        );
    }
}
