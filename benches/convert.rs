//! Conversion pipeline benchmarks: Blunt Fin (PLOT3D, 187K tets) read →
//! tetrahedralize → adjacency, and a 60³ structured grid (1.23M tets, 6-split).
//!
//!     cargo bench -p tetkit --bench convert
use criterion::{criterion_group, criterion_main, Criterion, Throughput};
use std::path::Path;
use tetkit::io::{read_file, ReadOptions};
use tetkit::mesh::{build_adjacency, tetrahedralize, Block, ConvertOptions, Field, SourceMesh, SplitMode};

fn grid(n: usize) -> SourceMesh {
    let mut points = Vec::with_capacity(n * n * n);
    for k in 0..n {
        for j in 0..n {
            for i in 0..n {
                points.push([i as f64, j as f64 * 1.1, k as f64 * 0.9]);
            }
        }
    }
    let s = points.iter().map(|p| (p[0] * 0.1).sin() + p[1] * p[2] * 1e-3).collect();
    SourceMesh {
        points,
        blocks: vec![Block::Structured { dims: [n, n, n], first_point: 0 }],
        point_fields: vec![Field::new("s", 1, s)],
        ..Default::default()
    }
}

fn bench(c: &mut Criterion) {
    let data = Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/data/plot3d");
    let opts = ReadOptions { q_path: Some(data.join("bluntfinq.bin")), ..Default::default() };
    let xyz = data.join("bluntfinxyz.bin");
    let mut g = c.benchmark_group("bluntfin");
    g.sample_size(20);
    g.throughput(Throughput::Elements(187_395));
    g.bench_function("read", |b| b.iter(|| read_file(&xyz, &opts).unwrap()));
    let src = read_file(&xyz, &opts).unwrap();
    let copts = ConvertOptions { scalar: Some("density".into()), ..Default::default() };
    g.bench_function("tetrahedralize_5", |b| b.iter(|| tetrahedralize(&src, &copts, &mut |_| {}).unwrap()));
    let (mesh, _) = tetrahedralize(&src, &copts, &mut |_| {}).unwrap();
    g.bench_function("adjacency", |b| b.iter(|| build_adjacency(&mesh.points, &mesh.tets).unwrap()));
    g.bench_function("read_convert_adjacency", |b| {
        b.iter(|| {
            let src = read_file(&xyz, &opts).unwrap();
            let (mesh, _) = tetrahedralize(&src, &copts, &mut |_| {}).unwrap();
            build_adjacency(&mesh.points, &mesh.tets).unwrap()
        })
    });
    g.finish();

    let n = 60;
    let src = grid(n);
    let tets = (n - 1).pow(3) * 6;
    let mut g = c.benchmark_group("grid60");
    g.sample_size(10);
    g.throughput(Throughput::Elements(tets as u64));
    let copts = ConvertOptions { split: SplitMode::Six, ..Default::default() };
    g.bench_function("tetrahedralize_6", |b| b.iter(|| tetrahedralize(&src, &copts, &mut |_| {}).unwrap()));
    let (mesh, _) = tetrahedralize(&src, &copts, &mut |_| {}).unwrap();
    g.bench_function("adjacency", |b| b.iter(|| build_adjacency(&mesh.points, &mesh.tets).unwrap()));
    g.finish();
}

criterion_group!(benches, bench);
criterion_main!(benches);
