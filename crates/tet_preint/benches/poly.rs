//! Bake times: poly1/poly2/poly4 at 512² (Guthe et al.'s (2002) Table 4 setting) on the
//! ramp TF, a banded poly2, and the biv-approx F/B tables.
use criterion::{criterion_group, criterion_main, Criterion};
use tet_preint::{Emission, FbTable, PolyParams, PolyTable, TransferFunction};

fn bench(c: &mut Criterion) {
    let tf = TransferFunction::from_json(include_str!("../tests/data/vtk/tf_ramp.json")).unwrap();
    let mut g = c.benchmark_group("bake");
    g.sample_size(10);
    for degree in [1, 2, 4] {
        let p = PolyParams::new(degree, 512, 0.0, 1.0, 1.0);
        g.bench_function(format!("poly{degree}_512"), |b| b.iter(|| PolyTable::build(&tf, &p).unwrap()));
    }
    let p = PolyParams::new(2, 512, 0.0, 1.0, 1.0).with_max_ds(0.1);
    g.bench_function("poly2_512_band_0.1", |b| b.iter(|| PolyTable::build(&tf, &p).unwrap()));
    for res in [128, 256] {
        g.bench_function(format!("fb_density_{res}"), |b| b.iter(|| FbTable::build(Emission::Density, res).unwrap()));
    }
    g.finish();
}

criterion_group!(benches, bench);
criterion_main!(benches);
