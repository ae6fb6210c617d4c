//! Table builds at the sizes of issue 5's targets: table3d 128×128×256
//! (slice recurrence vs incremental vs per-entry exact), atlas2d from that
//! table (N and 4N planes), partial Ψ at 1024². TF: tests/data/vtk/tf_ramp.json
//! over its node range, full square, l_max = 2.
use criterion::{criterion_group, criterion_main, Criterion};
use tet_preint::table3d::{Build3d, Table3dParams};
use tet_preint::*;

fn bench(c: &mut Criterion) {
    let tf = TransferFunction::from_json(include_str!("../tests/data/vtk/tf_ramp.json")).unwrap();
    let d = TableDomain::full(0.0, 1.0, 2.0).unwrap();
    let mut g = c.benchmark_group("tables");
    g.sample_size(10);
    for (name, build) in [
        ("table3d_128x128x256_slice_recurrence", Build3d::default()),
        ("table3d_128x128x256_incremental", Build3d::Incremental),
        ("table3d_128x128x256_exact_per_entry", Build3d::Exact),
    ] {
        let p = Table3dParams { build, ..Default::default() };
        g.bench_function(name, |b| b.iter(|| Table3d::build(&tf, &d, &p).unwrap()));
    }
    let banded = TableDomain::new(0.0, 1.0, 0.1, 2.0).unwrap();
    g.bench_function("table3d_128x128x256_slice_recurrence_band_0.1", |b| {
        b.iter(|| Table3d::build(&tf, &banded, &Table3dParams::default()).unwrap())
    });
    let t = Table3d::build(&tf, &d, &Table3dParams::default()).unwrap();
    for quarters in [4, 16] {
        let p = Atlas2dParams::for_table(&t, quarters, Precision::F32);
        g.bench_function(format!("atlas2d_128_{}_planes", p.planes), |b| b.iter(|| Atlas2d::build(&t, &p).unwrap()));
    }
    g.bench_function("partial_psi_1024", |b| b.iter(|| PsiTable::build(&PsiParams::default()).unwrap()));
    g.finish();
}

criterion_group!(benches, bench);
criterion_main!(benches);
