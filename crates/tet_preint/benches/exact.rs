//! Exact segments per second on a realistic TF (6 opacity + 3 colour nodes,
//! a steep ramp) over uniformly random (Sf, Sb, l) triples.
use criterion::{criterion_group, criterion_main, Criterion, Throughput};
use tet_preint::{integrate_segment_with, TransferFunction};

fn bench(c: &mut Criterion) {
    let tf = TransferFunction::from_json(include_str!("../tests/data/vtk/tf_ramp.json")).unwrap();
    // Fixed LCG so every run integrates the same triples.
    let mut next = tet_preint::lcg_unit(0x2545_f491_4f6c_dd1d);
    let triples: Vec<[f64; 3]> = (0..4096).map(|_| [next() * 1.2 - 0.1, next() * 1.2 - 0.1, next() * 2.0]).collect();
    let mut g = c.benchmark_group("exact");
    g.throughput(Throughput::Elements(triples.len() as u64));
    g.bench_function("ramp_tf_4096_segments", |b| {
        let mut scratch = Vec::new();
        b.iter(|| {
            let mut acc = 0.0;
            for t in &triples {
                acc += integrate_segment_with(&tf, t[0], t[1], t[2], &mut scratch).alpha;
            }
            acc
        })
    });
    g.finish();
}

criterion_group!(benches, bench);
criterion_main!(benches);
