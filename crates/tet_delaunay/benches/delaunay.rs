//! Delaunay tetrahedralization of uniformly random points in [0,1)³
//! (fixed seed) at 100k and 1M points.

use criterion::{criterion_group, criterion_main, Criterion};
use std::hint::black_box;
use tet_delaunay::{tetrahedralize_points, DelaunayOptions, SplitMix64};

fn random_points(n: usize, seed: u64) -> Vec<[f64; 3]> {
    let mut rng = SplitMix64(seed);
    (0..n).map(|_| [rng.next_f64(), rng.next_f64(), rng.next_f64()]).collect()
}

fn bench(c: &mut Criterion) {
    let mut g = c.benchmark_group("delaunay_random");
    g.sample_size(10);
    for n in [100_000usize, 1_000_000] {
        let pts = random_points(n, 42);
        g.bench_function(format!("{n}"), |b| {
            b.iter(|| tetrahedralize_points(black_box(&pts), &DelaunayOptions::default()).unwrap().tets.len())
        });
    }
    g.finish();
}

criterion_group!(benches, bench);
criterion_main!(benches);
