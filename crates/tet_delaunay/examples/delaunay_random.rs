//! Tetrahedralizes N uniformly random points in [0,1)³ (fixed seed 42) and
//! prints the counts and the time taken.
//!
//! `cargo run --release -p tet_delaunay --example delaunay_random -- 1000000`
//! (wrap in `/usr/bin/time -v` for peak memory).

use std::time::Instant;
use tet_delaunay::{tetrahedralize_points, DelaunayOptions, SplitMix64};

fn main() {
    let n: usize = match std::env::args().nth(1).map(|a| a.parse()) {
        None => 1_000_000,
        Some(Ok(n)) => n,
        Some(Err(e)) => {
            eprintln!("usage: delaunay_random [N]: {e}");
            std::process::exit(2);
        }
    };
    let mut rng = SplitMix64(42);
    let pts: Vec<[f64; 3]> = (0..n).map(|_| [rng.next_f64(), rng.next_f64(), rng.next_f64()]).collect();
    let start = Instant::now();
    match tetrahedralize_points(&pts, &DelaunayOptions::default()) {
        Ok(d) => {
            let secs = start.elapsed().as_secs_f64();
            println!(
                "points {n}  tets {}  tets/point {:.3}  hull facets {}  duplicates {}  walk fallbacks {}  sequential tail {}  time {secs:.3} s",
                d.tets.len(),
                d.tets.len() as f64 / n as f64,
                d.hull_facets,
                d.duplicates,
                d.walk_fallbacks,
                d.parallel_deferred
            );
        }
        Err(e) => {
            eprintln!("error: {e}");
            std::process::exit(1);
        }
    }
}
