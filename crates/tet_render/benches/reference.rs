//! Reference renderer on NASA Blunt Fin (187,318 tets) at 128²: one render
//! with the sample normalized TF (segments split at its nodes, closed-form
//! pieces) and one with a constant TF (one piece per segment: mostly the
//! walk's cost). Throughput is in ray–tet segments per second.
//!
//! `cargo bench -p tet_render --bench reference`

use criterion::{criterion_group, criterion_main, Criterion, Throughput};
use std::path::Path;
use tet_io::{read_file, ReadOptions};
use tet_mesh::{build_adjacency, tetrahedralize, ConvertOptions};
use tet_preint::{ColorNode, Emission, OpacityNode, TransferFunction};
use tet_render::{Camera, ReferenceOptions, ReferenceRenderer, ViewSpec};

fn bench(c: &mut Criterion) {
    let data = Path::new(env!("CARGO_MANIFEST_DIR")).join("../../tests/data/plot3d");
    let opts = ReadOptions { q_path: Some(data.join("bluntfinq.bin")), ..Default::default() };
    let src = read_file(&data.join("bluntfinxyz.bin"), &opts).unwrap();
    let conv = ConvertOptions { scalar: Some("density".into()), ..Default::default() };
    let (mesh, _) = tetrahedralize(&src, &conv, &mut |_| {}).unwrap();
    let adj = build_adjacency(&mesh.points, &mesh.tets).unwrap();
    let (lo, hi) = mesh.scalar.iter().fold((f64::INFINITY, f64::NEG_INFINITY), |(a, b), &s| (a.min(s), b.max(s)));
    let text =
        std::fs::read_to_string(Path::new(env!("CARGO_MANIFEST_DIR")).join("../../formats/samples/tf_normalized.json"))
            .unwrap();
    let tf_sample = TransferFunction::from_json(&text).unwrap().denormalize(lo, hi).unwrap();
    let tf_const = TransferFunction::new(
        vec![ColorNode { x: 0.0, rgb: [1.0, 0.8, 0.6] }],
        vec![OpacityNode { x: 0.0, a: 0.01 }],
        1.0,
        Emission::Density,
        false,
    )
    .unwrap();
    let (bmin, bmax) = tet_mesh::stats::bounds(&mesh.points);
    let cam = Camera::new(&ViewSpec::framing(bmin, bmax, [128, 128]).orbit(40.0, 25.0, 1.5)).unwrap();
    let mut group = c.benchmark_group("reference_bluntfin_128");
    group.sample_size(10);
    group.bench_function("build_boundary_bvh", |b| b.iter(|| ReferenceRenderer::new(&mesh, &adj).unwrap()));
    let r = ReferenceRenderer::new(&mesh, &adj).unwrap();
    for (name, tf) in [("tf_sample", &tf_sample), ("tf_constant", &tf_const)] {
        let options = ReferenceOptions::default();
        let (_, stats) = r.render(&cam, tf, &options, &|_, _| {}).unwrap();
        eprintln!("{name}: {stats:?}");
        group.throughput(Throughput::Elements(stats.segments));
        group.bench_function(name, |b| b.iter(|| r.render(&cam, tf, &options, &|_, _| {}).unwrap()));
    }
    group.finish();
}

criterion_group!(benches, bench);
criterion_main!(benches);
