//! Frame times at 512² on Blunt Fin (NASA, bundled in tests/data) and on a
//! generated ≥1M-tet grid: the sort alone (MPVO, MPVONC, radix) and whole
//! frames with pt-linear and exact (exact on Blunt Fin only: seconds per
//! frame). Throughput is reported in tets per second (criterion's
//! "elements"). Each configuration also prints one frame's stage times.
//!
//! `cargo bench -p tet_render --bench render`

use criterion::{criterion_group, criterion_main, BenchmarkId, Criterion, Throughput};
use std::path::Path;
use std::sync::Arc;
use tet_io::{read_file, ReadOptions};
use tet_mesh::{tetrahedralize, Block, ConvertOptions, Field, SourceMesh};
use tet_preint::{ExactShader, PtLinearShader, SegmentShader, TransferFunction};
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
    let src = SourceMesh {
        points,
        blocks: vec![Block::Structured { dims: [n + 1; 3], first_point: 0 }],
        point_fields: vec![Field::new("s", 1, s)],
        ..Default::default()
    };
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
        let shaders: Vec<(&str, Arc<dyn SegmentShader>)> = if *name == "bluntfin" {
            vec![
                ("pt-linear", Arc::new(PtLinearShader::new(tf.clone()))),
                ("exact", Arc::new(ExactShader::new(tf.clone()))),
            ]
        } else {
            vec![("pt-linear", Arc::new(PtLinearShader::new(tf.clone())))]
        };
        g.throughput(Throughput::Elements(scene.num_tets() as u64));
        for (method, shader) in shaders {
            let mut r = Renderer::new(scene.clone());
            r.set_view(&view(scene)).unwrap();
            r.set_shader(shader);
            r.set_culler(Some(Arc::new(TfCuller::new(&tf))));
            // One cold frame (view, cull, sort) for the stage report.
            let (_, st) = r.render(&|_, _| {}).unwrap();
            eprintln!(
                "{name} {method}: {} tets, cold frame {:.3} s (view {:.3}, sort {} {:.3}, bin {:.3}, raster {:.3}), {} fragments, {:.2} M tets/s",
                st.tets_drawn, st.total_seconds, st.view_seconds, st.sort_method, st.sort_seconds,
                st.project_seconds, st.raster_seconds, st.fragments, st.tets_per_second() / 1e6
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
