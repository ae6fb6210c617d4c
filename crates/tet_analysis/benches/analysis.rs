//! Blunt Fin (187K tets): per-tet gradients, per-vertex gradients (both
//! methods), histograms, per-cell ranges and the whole analysis.
//!
//!     cargo bench -p tet_analysis --bench analysis
//!     RAYON_NUM_THREADS=2 cargo bench -p tet_analysis --bench analysis   # the 2-core target
use criterion::{criterion_group, criterion_main, Criterion, Throughput};
use std::path::Path;
use tet_analysis::{AnalysisOptions, Analyzer, GradientMethod, HistogramOptions};
use tet_mesh::{tetrahedralize, ConvertOptions};

fn bench(c: &mut Criterion) {
    let data = Path::new(env!("CARGO_MANIFEST_DIR")).join("../../tests/data/plot3d");
    let opts = tet_io::ReadOptions { q_path: Some(data.join("bluntfinq.bin")), ..Default::default() };
    let src = tet_io::read_file(&data.join("bluntfinxyz.bin"), &opts).unwrap();
    let copts = ConvertOptions { scalar: Some("density".into()), ..Default::default() };
    let (mesh, _) = tetrahedralize(&src, &copts, &mut |_| {}).unwrap();
    let mut g = c.benchmark_group("bluntfin_analysis");
    g.sample_size(20);
    g.throughput(Throughput::Elements(mesh.tets.len() as u64));
    g.bench_function("tet_gradients", |b| {
        b.iter(|| tet_analysis::tet_gradients(&mesh.points, &mesh.tets, &mesh.scalar))
    });
    for method in [GradientMethod::LeastSquares, GradientMethod::TetAverage] {
        g.bench_function(format!("vertex_gradients_{}", method.name()), |b| {
            b.iter(|| Analyzer::from_mesh(&mesh).unwrap().vertex_gradients(method).len())
        });
    }
    g.bench_function("histograms_256x256", |b| {
        b.iter(|| Analyzer::from_mesh(&mesh).unwrap().histograms(&HistogramOptions::default()).unwrap())
    });
    g.bench_function("ranges_facts_limits", |b| {
        b.iter(|| Analyzer::from_mesh(&mesh).unwrap().analyze(&AnalysisOptions::default()).unwrap())
    });
    // What `tetprep convert --gradients --histogram` adds: everything, sharing work.
    let all = AnalysisOptions {
        gradients: Some(GradientMethod::LeastSquares),
        histogram: Some(HistogramOptions::default()),
        ..Default::default()
    };
    g.bench_function("gradients_histograms_ranges", |b| {
        b.iter(|| Analyzer::from_mesh(&mesh).unwrap().analyze(&all).unwrap())
    });
    g.finish();
}

criterion_group!(benches, bench);
criterion_main!(benches);
