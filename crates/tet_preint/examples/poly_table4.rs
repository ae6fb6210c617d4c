//! Table 4 of Guthe et al., "High-Quality Unstructured Volume Rendering on
//! the PC Platform", 2002, on this machine: bake time of the 512² `poly1`,
//! `poly2`, `poly4` tables, and their error against `exact` over uniform
//! random (Sf, Sb, l) triples.
//!
//! `cargo run --release -p tet_preint --example poly_table4 [-- TF.json L_MAX]`
//! (default: tests/data/vtk/tf_ramp.json, l_max = 1).
use std::time::Instant;
use tet_preint::{integrate_segment_with, PolyParams, PolyTable, TransferFunction};

fn main() {
    let args: Vec<String> = std::env::args().collect();
    let text = match args.get(1) {
        Some(p) => std::fs::read_to_string(p).expect("read TF"),
        None => include_str!("../tests/data/vtk/tf_ramp.json").to_string(),
    };
    let l_max: f64 = args.get(2).map_or(1.0, |s| s.parse().expect("L_MAX"));
    let tf = TransferFunction::from_json(&text).expect("TF");
    let (lo, hi) = (0.0, 1.0);
    println!("threads: {}", rayon::current_num_threads());
    println!(
        "{:<8} {:>10} {:>10} {:>12} {:>12} {:>12} {:>12}",
        "method", "res", "bake_ms", "rms_C", "max_C", "rms_a", "max_a"
    );
    // Fixed LCG so every run draws the same triples.
    let mut next = tet_preint::lcg_unit(0x2545_f491_4f6c_dd1d);
    let triples: Vec<[f32; 3]> =
        (0..200_000).map(|_| [next() as f32, next() as f32, (next() * l_max) as f32]).collect();
    let mut scratch = Vec::new();
    let exact: Vec<[f64; 4]> = triples
        .iter()
        .map(|t| integrate_segment_with(&tf, t[0] as f64, t[1] as f64, t[2] as f64, &mut scratch).to_array())
        .collect();
    for degree in [1, 2, 4] {
        let p = PolyParams::new(degree, 512, lo, hi, l_max);
        // Best of 5 bakes (the machine is shared).
        let mut best = f64::INFINITY;
        let mut table = None;
        for _ in 0..5 {
            let t0 = Instant::now();
            let t = PolyTable::build(&tf, &p).expect("bake");
            best = best.min(t0.elapsed().as_secs_f64());
            table = Some(t);
        }
        let table = table.unwrap();
        let (mut sc, mut mc, mut sa, mut ma) = (0.0f64, 0.0f64, 0.0f64, 0.0f64);
        for (t, e) in triples.iter().zip(&exact) {
            let got = table.lookup(t[0], t[1], t[2]);
            for c in 0..3 {
                let d = (got[c] as f64 - e[c]).abs();
                sc += d * d;
                mc = mc.max(d);
            }
            let d = (got[3] as f64 - e[3]).abs();
            sa += d * d;
            ma = ma.max(d);
        }
        let n = triples.len() as f64;
        println!(
            "poly{:<4} {:>10} {:>10.1} {:>12.3e} {:>12.3e} {:>12.3e} {:>12.3e}",
            degree,
            "512²",
            best * 1e3,
            (sc / (3.0 * n)).sqrt(),
            mc,
            (sa / n).sqrt(),
            ma
        );
    }
}
