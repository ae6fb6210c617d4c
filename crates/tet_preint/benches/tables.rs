//! Table builds at the sizes of the accuracy targets: table3d 128×128×256
//! (slice recurrence vs incremental vs per-entry exact), atlas2d from that
//! table (N and 4N planes), partial Ψ at 1024². TF: tests/data/vtk/tf_ramp.json
//! over its node range, full square, l_max = 2.
//!
//! Group `table3d_bluntfin`: the issue's 1e-3 target configuration, the
//! NASA Blunt Fin domain (s ∈ [0.1926, 4.9775], |Sf − Sb| ≤ 2.0032,
//! l ≤ 3.6486) with formats/samples/tf_normalized.json: bake and
//! `shade_span` over 100 000 uniform segments, uniform against tf-nodes
//! scalar axis, and the default (`BakeOptions`: data axis from the
//! bundle's scalars, adaptive build) against the same with the slice
//! recurrence.
//!
//! Group `table3d_rebake_bluntfin`: `Table3d::rebake` of the default table
//! after edits of `tf_normalized.json`'s control points (on a copy of the
//! table made outside the timing): the middle node's opacity (every pair),
//! the last node's opacity (the pairs above the middle node), the middle
//! node's colour, and the middle node moved along s (a new axis: every
//! pair, in place); and the full bake it replaces.
//!
//! Group `biv_gauss_independent`: `biv-exact` under the emission-only model
//! on crates/tetlut/results/tf_gauss_independent.json (one Gaussian widget),
//! 20 000 segments with s uniform over [0.19, 2], |∇s| over [0, 1.5], l up to
//! 3.65: Song et al.'s (2009) Gaussian table against the quadrature path, and the
//! table's build.
//!
//! Group `biv_band_independent`: the same for Song et al.'s (2009) triangle- and
//! sine-wave tables, one band widget alone (frequency 5 / 3 bands per unit,
//! the test TF's), emission-only, 20 000 segments with s over [−0.1, 1.1],
//! |∇s| over [0, 2.5], l up to 2; and the tables' builds.
use criterion::{criterion_group, criterion_main, Criterion, Throughput};
use tet_preint::table3d::{Build3d, ScalarAxis, Table3dParams};
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

fn bench_bluntfin(c: &mut Criterion) {
    let tf = TransferFunction::from_json(include_str!("../../../formats/samples/tf_normalized.json")).unwrap();
    let d = TableDomain::new(0.1926, 4.9775, 2.0032, 3.6486).unwrap();
    let tf = tf_for_domain(&tf, &d).unwrap();
    let segs: Vec<Segment> = uniform_triples(&d, 100_000, 5)
        .into_iter()
        .map(|t| Segment { s_front: t[0], s_back: t[1], len_world: t[2], ..Default::default() })
        .collect();
    let mut out = vec![[0.0f32; 4]; segs.len()];
    let mut g = c.benchmark_group("table3d_bluntfin");
    g.sample_size(10);
    for (name, s_axis) in [("uniform", ScalarAxis::Uniform), ("tf_nodes", ScalarAxis::TfNodes)] {
        let p = Table3dParams { s_axis, ..Default::default() };
        g.throughput(Throughput::Elements(1));
        g.bench_function(format!("bake_128x128x256_{name}"), |b| b.iter(|| Table3d::build(&tf, &d, &p).unwrap()));
        let t = Table3d::build(&tf, &d, &p).unwrap();
        g.throughput(Throughput::Elements(segs.len() as u64));
        g.bench_function(format!("shade_span_100k_{name}"), |b| b.iter(|| t.shade_span(&segs, &mut out)));
    }
    g.finish();
}

fn bench_biv_gauss(c: &mut Criterion) {
    let tf = TransferFunction::from_json(include_str!("../../tetlut/results/tf_gauss_independent.json")).unwrap();
    let mut state = 11u64;
    let mut next = move || {
        state = state.wrapping_mul(6364136223846793005).wrapping_add(1442695040888963407);
        (state >> 40) as f32 / (1u32 << 24) as f32
    };
    let segs: Vec<Segment> = (0..20_000)
        .map(|_| Segment {
            s_front: 0.19 + 1.81 * next(),
            s_back: 0.19 + 1.81 * next(),
            grad_front: 1.5 * next(),
            grad_back: 1.5 * next(),
            len_world: 3.65 * next(),
        })
        .collect();
    let mut out = vec![[0.0f32; 4]; segs.len()];
    let mut g = c.benchmark_group("biv_gauss_independent");
    g.sample_size(10);
    g.throughput(Throughput::Elements(segs.len() as u64));
    let table = BivExact::new(tf.clone());
    let quad = BivExact::with_gauss_table(tf.clone(), None);
    g.bench_function("shade_20k_erf_table", |b| b.iter(|| table.shade_span(&segs, &mut out)));
    g.bench_function("shade_20k_quadrature", |b| b.iter(|| quad.shade_span(&segs, &mut out)));
    g.throughput(Throughput::Elements(1));
    let (n_p, n_u, p_max) = tet_preint::biv_tables::DEFAULT_ERF_TABLE;
    g.bench_function("build_erf_table_192x769", |b| b.iter(|| GaussErfTable::build(n_p, n_u, p_max)));
    g.finish();
}

fn bench_biv_band(c: &mut Criterion) {
    let mut state = 12u64;
    let mut next = move || {
        state = state.wrapping_mul(6364136223846793005).wrapping_add(1442695040888963407);
        (state >> 40) as f32 / (1u32 << 24) as f32
    };
    let segs: Vec<Segment> = (0..20_000)
        .map(|_| Segment {
            s_front: 1.2 * next() - 0.1,
            s_back: 1.2 * next() - 0.1,
            grad_front: 2.5 * next(),
            grad_back: 2.5 * next(),
            len_world: 2.0 * next(),
        })
        .collect();
    let mut out = vec![[0.0f32; 4]; segs.len()];
    let mut g = c.benchmark_group("biv_band_independent");
    g.sample_size(10);
    for (name, widget, kind) in [
        (
            "triangle",
            r#"{"type": "triangle", "frequency": 5, "phase": 0.25, "color": [0, 0, 1], "opacity": 1.5, "clip": [[0.1, 0.9], [0.0, 2.0]]}"#,
            BandKind::Triangle,
        ),
        (
            "sine",
            r#"{"type": "sine", "frequency": 3, "phase": 0.0, "color": [1, 1, 0], "opacity": 1, "clip": [[0.0, 1.0], [0.5, 3.0]]}"#,
            BandKind::Sine,
        ),
    ] {
        let json = format!(
            r#"{{"color": [[0, 0, 0, 0]], "opacity": [[0, 0]], "unit_distance": 0.5, "emission": "independent", "widgets": [{widget}]}}"#
        );
        let tf = TransferFunction::from_json(&json).unwrap();
        let table = BivExact::new(tf.clone());
        let quad = BivExact::with_tables(tf, BivTables::default());
        g.throughput(Throughput::Elements(segs.len() as u64));
        g.bench_function(format!("shade_20k_{name}_table"), |b| b.iter(|| table.shade_span(&segs, &mut out)));
        g.bench_function(format!("shade_20k_{name}_quadrature"), |b| b.iter(|| quad.shade_span(&segs, &mut out)));
        g.throughput(Throughput::Elements(1));
        g.bench_function(format!("build_{name}_table_default"), |b| b.iter(|| BandTable::default_for(kind)));
    }
    g.finish();
}

/// The Blunt Fin bundle's domain as `TableDomain::from_bundle` makes it
/// (scalar range, largest per-cell range and diameter, quantiles).
fn bluntfin_domain() -> TableDomain {
    let data = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("../../tests/data/plot3d");
    let opts = tet_io::ReadOptions { q_path: Some(data.join("bluntfinq.bin")), ..Default::default() };
    let src = tet_io::read_file(&data.join("bluntfinxyz.bin"), &opts).unwrap();
    let conv = tet_mesh::ConvertOptions { scalar: Some("density".into()), ..Default::default() };
    let (mesh, _) = tet_mesh::tetrahedralize(&src, &conv, &mut |_| {}).unwrap();
    let adj = tet_mesh::build_adjacency(&mesh.points, &mesh.tets).unwrap();
    let bundle = tet_bundle::Bundle::new(mesh, adj, Default::default());
    TableDomain::from_bundle(&bundle).unwrap()
}

fn bench_default_and_rebake(c: &mut Criterion) {
    let d = bluntfin_domain();
    let tf = TransferFunction::from_json(include_str!("../../../formats/samples/tf_normalized.json")).unwrap();
    let tf = tf_for_domain(&tf, &d).unwrap();
    let p = BakeOptions::default().table3d;
    let segs: Vec<Segment> = uniform_triples(&d, 100_000, 5)
        .into_iter()
        .map(|t| Segment { s_front: t[0], s_back: t[1], len_world: t[2], ..Default::default() })
        .collect();
    let mut out = vec![[0.0f32; 4]; segs.len()];
    let mut g = c.benchmark_group("table3d_bluntfin");
    g.sample_size(10);
    for (name, build) in [("data_adaptive", p.build), ("data_slice_recurrence", Build3d::default())] {
        let q = Table3dParams { build, ..p };
        g.throughput(Throughput::Elements(1));
        g.bench_function(format!("bake_128x128x256_{name}"), |b| b.iter(|| Table3d::build(&tf, &d, &q).unwrap()));
    }
    let t = Table3d::build(&tf, &d, &p).unwrap();
    g.throughput(Throughput::Elements(segs.len() as u64));
    g.bench_function("shade_span_100k_data", |b| b.iter(|| t.shade_span(&segs, &mut out)));
    g.finish();

    let (col, op) = (tf.color_nodes().to_vec(), tf.opacity_nodes().to_vec());
    let edited = |col: Vec<ColorNode>, op: Vec<OpacityNode>| {
        TransferFunction::new(col, op, tf.unit_distance(), tf.emission(), false).unwrap()
    };
    let mut mid_opacity = op.clone();
    mid_opacity[1].a *= 1.5;
    let mut last_opacity = op.clone();
    last_opacity[2].a *= 0.8;
    let mut mid_colour = col.clone();
    mid_colour[1].rgb = [0.5, 0.4, 0.3];
    let mut moved = op.clone();
    moved[1].x += 0.02 * (op[2].x - op[1].x);
    let edits = [
        ("mid_opacity", edited(col.clone(), mid_opacity)),
        ("last_opacity", edited(col.clone(), last_opacity)),
        ("mid_colour", edited(mid_colour, op.clone())),
        ("mid_moved", edited(col.clone(), moved)),
    ];
    let mut g = c.benchmark_group("table3d_rebake_bluntfin");
    g.sample_size(10);
    for (name, new) in &edits {
        g.bench_function(format!("rebake_{name}"), |b| {
            b.iter_batched_ref(|| t.clone(), |table| table.rebake(&tf, new).unwrap(), criterion::BatchSize::LargeInput)
        });
    }
    g.bench_function("full_bake_mid_opacity", |b| b.iter(|| Table3d::build(&edits[0].1, &d, &p).unwrap()));
    g.finish();
}

criterion_group!(benches, bench, bench_bluntfin, bench_default_and_rebake, bench_biv_gauss, bench_biv_band);
criterion_main!(benches);
