//! Frame times at 512² on Blunt Fin (NASA, bundled in tests/data) and on a
//! generated ≥1M-tet grid: the sort alone (MPVO, MPVONC, radix) and whole
//! frames with pt-linear, table3d (128 × 128 × 128, banded), poly2 (N = 256)
//! and exact (exact on Blunt Fin only: seconds per frame). Throughput is reported in tets per second (criterion's
//! "elements"). Each configuration also prints one frame's stage times.
//!
//! `cargo bench -p tet_render --bench render`; `-- none` runs no criterion
//! benchmark but still prints every configuration's best-of-3 warm frame,
//! and `TET_BENCH_ONLY=grid1m/table3d` keeps only matching frame configurations.

use criterion::{criterion_group, criterion_main, BenchmarkId, Criterion, Throughput};
use std::path::Path;
use std::sync::Arc;
use tet_io::{read_file, ReadOptions};
use tet_mesh::{tetrahedralize, ConvertOptions, SourceMesh};
use tet_preint::{
    ExactShader, PolyParams, PolyTable, PtLinearShader, SegmentShader, Table3d, Table3dParams, TableDomain,
    TransferFunction,
};
use tet_render::pipeline::process_cpu_seconds;
use tet_render::project::ViewGeometry;
use tet_render::{visibility_order, Camera, Renderer, Scene, SortMethod, TfCuller, ViewSpec};

fn bluntfin() -> Scene {
    let data = Path::new(env!("CARGO_MANIFEST_DIR")).join("../../tests/data/plot3d");
    let opts = ReadOptions { q_path: Some(data.join("bluntfinq.bin")), ..Default::default() };
    let src = read_file(&data.join("bluntfinxyz.bin"), &opts).expect("Blunt Fin reads");
    let copts = ConvertOptions { scalar: Some("density".into()), ..Default::default() };
    let (m, _) = tetrahedralize(&src, &copts, &mut |_| {}).unwrap();
    Scene::new(&m.points, m.tets, m.scalar).unwrap()
}

/// n³ cells 5-split: n = 59 gives 1,026,895 tets.
fn grid(n: usize) -> Scene {
    let mut points = Vec::new();
    let mut s = Vec::new();
    for k in 0..=n {
        for j in 0..=n {
            for i in 0..=n {
                let p = [i as f64 / n as f64, j as f64 / n as f64, k as f64 / n as f64];
                s.push(0.5 + 0.5 * (7.0 * p[0]).sin() * (5.0 * p[1] + 1.0).cos() * (0.3 + p[2]));
                points.push(p);
            }
        }
    }
    let src = SourceMesh::structured([n + 1; 3], points, "s", s);
    let opts = ConvertOptions { scalar: Some("s".into()), ..Default::default() };
    let (m, _) = tetrahedralize(&src, &opts, &mut |_| {}).unwrap();
    Scene::new(&m.points, m.tets, m.scalar).unwrap()
}

fn tf(scene: &Scene) -> TransferFunction {
    // Semi-transparent over the whole range: every tet is drawn (no culling,
    // little early termination), the honest case for throughput.
    let [lo, hi] = scene.scalar_range();
    let extent = {
        let (a, b) = scene.bounds();
        ((b[0] - a[0]).powi(2) + (b[1] - a[1]).powi(2) + (b[2] - a[2]).powi(2)).sqrt()
    };
    let json = format!(
        r#"{{"normalized": true, "color": [[0, 0.2, 0.3, 1], [0.5, 0.9, 0.9, 0.9], [1, 1, 0.3, 0.1]],
            "opacity": [[0, 0.3], [0.5, 1], [1, 2]], "unit_distance": {}}}"#,
        extent
    );
    TransferFunction::from_json(&json).unwrap().denormalize(lo, hi).unwrap()
}

/// The table domain a tool would bake for this mesh: the scalar range, the
/// largest per-cell scalar range (band) and the largest cell diameter.
fn domain(scene: &Scene) -> TableDomain {
    let (mut max_ds, mut len_max) = (0.0f64, 0.0f64);
    let (p, s) = (scene.positions_rel(), scene.scalar());
    for t in scene.tets() {
        let sv = t.map(|v| s[v as usize]);
        let lo = sv.iter().copied().fold(f64::INFINITY, f64::min);
        let hi = sv.iter().copied().fold(f64::NEG_INFINITY, f64::max);
        max_ds = max_ds.max(hi - lo);
        for i in 0..4 {
            for j in i + 1..4 {
                let (a, b) = (p[t[i] as usize], p[t[j] as usize]);
                len_max = len_max.max(((a[0] - b[0]).powi(2) + (a[1] - b[1]).powi(2) + (a[2] - b[2]).powi(2)).sqrt());
            }
        }
    }
    let [lo, hi] = scene.scalar_range();
    TableDomain::new(lo, hi, max_ds, len_max).unwrap()
}

fn shaders(scene: &Scene, tf: &TransferFunction, with_exact: bool) -> Vec<(&'static str, Arc<dyn SegmentShader>)> {
    let d = domain(scene);
    let table = Table3d::build(tf, &d, &Table3dParams { n_s: 128, n_l: 128, ..Default::default() }).unwrap();
    let poly =
        PolyTable::build(tf, &PolyParams::new(2, 256, d.s_lo, d.s_hi, d.len_max_world).with_max_ds(d.max_ds)).unwrap();
    let mut v: Vec<(&'static str, Arc<dyn SegmentShader>)> = vec![
        ("pt-linear", Arc::new(PtLinearShader::new(tf.clone()))),
        ("table3d", Arc::new(table)),
        ("poly2", Arc::new(poly)),
    ];
    if with_exact {
        v.push(("exact", Arc::new(ExactShader::new(tf.clone()))));
    }
    v
}

fn view(scene: &Scene) -> ViewSpec {
    let (lo, hi) = scene.bounds();
    ViewSpec::framing(lo, hi, [512, 512]).orbit(30.0, 20.0, 1.0)
}

fn bench(c: &mut Criterion) {
    let scenes = [("bluntfin", bluntfin()), ("grid1m", grid(59))];
    let mut g = c.benchmark_group("sort");
    g.sample_size(10);
    for (name, scene) in &scenes {
        let camera = Camera::new(&view(scene)).unwrap();
        let geo = ViewGeometry::new(scene, &camera);
        g.throughput(Throughput::Elements(scene.num_tets() as u64));
        for m in [SortMethod::Mpvo, SortMethod::Mpvonc, SortMethod::Radix] {
            g.bench_with_input(BenchmarkId::new(m.id(), name), &m, |b, &m| {
                b.iter(|| visibility_order(scene, &geo, m, None))
            });
        }
    }
    g.finish();

    let mut g = c.benchmark_group("frame_512");
    g.sample_size(10);
    for (name, scene) in &scenes {
        let tf = tf(scene);
        let shaders = shaders(scene, &tf, *name == "bluntfin");
        g.throughput(Throughput::Elements(scene.num_tets() as u64));
        for (method, shader) in shaders {
            // `TET_BENCH_ONLY=grid1m/table3d` (a substring of "scene/method")
            // restricts the frames, e.g. for profiling one configuration.
            if std::env::var("TET_BENCH_ONLY").is_ok_and(|only| !format!("{name}/{method}").contains(&only)) {
                continue;
            }
            let mut r = Renderer::new(scene.clone());
            r.set_view(&view(scene)).unwrap();
            r.set_shader(shader);
            r.set_culler(Some(Arc::new(TfCuller::new(&tf))));
            // One cold frame (view, cull, sort) for the stage report.
            let (_, st) = r.render(&|_, _| {}).unwrap();
            eprintln!(
                "{name} {method}: {} tets, cold frame {:.3} s (view {:.3}, sort {} {:.3}, bin {:.3}, raster {:.3}), {} fragments, {} setups, {:.2} M tets/s",
                st.tets_drawn, st.total_seconds, st.view_seconds, st.sort_method, st.sort_seconds,
                st.project_seconds, st.raster_seconds, st.fragments, st.setups, st.tets_per_second() / 1e6
            );
            // Best of 3 warm frames, printed so a run filtered to no benchmark
            // (`-- none`) still gives every configuration's figure quickly.
            // On a shared machine the wall time depends on the other load; the
            // process CPU time per frame (all threads) much less so.
            let (best, cpu) = (0..3)
                .map(|_| {
                    let c0 = process_cpu_seconds();
                    let st = r.render(&|_, _| {}).unwrap().1;
                    (st, process_cpu_seconds() - c0)
                })
                .min_by(|a, b| a.0.total_seconds.total_cmp(&b.0.total_seconds))
                .unwrap();
            eprintln!(
                "{name} {method}: warm best of 3 {:.3} s (bin {:.3}, raster {:.3}), {}",
                best.total_seconds,
                best.project_seconds,
                best.raster_seconds,
                best.throughput_summary(cpu)
            );
            // Warm frames: the view is unchanged, so only binning and raster run.
            g.bench_function(BenchmarkId::new(format!("{method}_cached_order"), name), |b| {
                b.iter(|| r.render(&|_, _| {}).unwrap())
            });
            // Full frames: a new view each time (resort), as when orbiting.
            let mut az = 30.0;
            g.bench_function(BenchmarkId::new(format!("{method}_new_view"), name), |b| {
                b.iter(|| {
                    az += 1e-3;
                    r.set_view(&view(scene).orbit(az - 30.0, 0.0, 1.0)).unwrap();
                    r.render(&|_, _| {}).unwrap()
                })
            });
        }
    }
    g.finish();
}

criterion_group!(benches, bench);
criterion_main!(benches);
