//! GPU pre-integration and the GPU table lookup against tet_preint: the
//! per-fragment lookup (probed at random triples) against
//! `Table3d::lookup` on both scalar axes, the compute-shader bake against
//! the CPU bake entry by entry and against `exact`, and images rendered with
//! the GPU-baked table against the CPU table's. Skip with a printed reason
//! where no adapter exists (fail instead with TETKIT_REQUIRE_GPU=1). Sizes
//! are small: lavapipe runs them on the CPU.

mod common;

use common::{cpu_image_and_order, cpu_pt_renderer, gpu, grid, Mesh};
use tet_gpu::{GpuAccumulation, GpuRenderer, GpuShader, GpuTable3d};
use tet_preint::{
    integrate_segment, uniform_triples, Emission, Reconstruction, ScalarAxis, Table3d, Table3dParams, TableDomain,
    TransferFunction,
};
use tet_render::{diff, Camera, ViewSpec};

/// Control points off the uniform grids used here, a steep opacity ramp.
fn tf() -> TransferFunction {
    TransferFunction::from_json(
        r#"{"color": [[0, 0.1, 0.2, 1], [0.37, 1, 0.8, 0.1], [1, 1, 0.1, 0.1]],
            "opacity": [[0, 0.5], [0.41, 4], [0.53, 0.3], [0.77, 6], [1, 8]], "unit_distance": 1}"#,
    )
    .unwrap()
}

fn params(n_s: usize, n_l: usize, s_axis: ScalarAxis) -> Table3dParams {
    Table3dParams { n_s, n_l, s_axis, ..Default::default() }
}

/// max |Δ| over every channel.
fn max_abs(a: &[[f32; 4]], b: &[[f32; 4]]) -> f32 {
    a.iter().zip(b).flat_map(|(x, y)| (0..4).map(move |c| (x[c] - y[c]).abs())).fold(0.0, f32::max)
}

/// `tf()` with its opacity scaled down 100×: α changes little per grid
/// step, so the table keeps the trilinear reconstruction.
fn thin_tf() -> TransferFunction {
    TransferFunction::from_json(
        r#"{"color": [[0, 0.1, 0.2, 1], [0.37, 1, 0.8, 0.1], [1, 1, 0.1, 0.1]],
            "opacity": [[0, 0.005], [0.41, 0.04], [0.53, 0.003], [0.77, 0.06], [1, 0.08]], "unit_distance": 1}"#,
    )
    .unwrap()
}

/// The GPU lookup (the function every fragment calls) equals
/// `Table3d::lookup` to f32 rounding on both axes and with both
/// reconstructions, including inputs outside the domain and |Sf − Sb|
/// beyond max_ds. A GPU lookup that mapped scalars with the wrong axis
/// would be off by the table's change over a fraction of a grid step, which
/// the second check shows is far above the tolerance.
#[test]
fn gpu_lookup_matches_the_cpu_lookup_on_both_axes() {
    let Some(ctx) = gpu() else { return };
    let domain = TableDomain::new(0.0, 1.0, 0.45, 1.5).unwrap();
    let mut triples = uniform_triples(&domain, 20_000, 0x90b);
    let mut rng = tet_mesh::SplitMix64(11);
    triples.extend((0..2000).map(|_| {
        let mut r = |lo: f64, hi: f64| (lo + (hi - lo) * rng.next_f64()) as f32;
        [r(-0.3, 1.3), r(-0.3, 1.3), r(-0.2, 2.0)]
    }));
    let mut cpu_by_axis = Vec::new();
    // The last: faint, glowing entries next to dense ones (independent
    // emission), whose depths and α the lookup takes by their series.
    let faint = TransferFunction::from_json(
        r#"{"color": [[0, 1, 0.5, 0.25], [1, 0.2, 0.4, 1]],
            "opacity": [[0, 0], [0.3, 1e-4], [0.6, 1e-3], [0.8, 30], [1, 30]],
            "unit_distance": 1, "emission": "independent"}"#,
    )
    .unwrap();
    let cases = [
        (ScalarAxis::Uniform, tf(), Reconstruction::OpticalDepth),
        (ScalarAxis::TfNodes, tf(), Reconstruction::OpticalDepth),
        (ScalarAxis::TfNodes, thin_tf(), Reconstruction::Trilinear),
        (ScalarAxis::Uniform, faint, Reconstruction::OpticalDepth),
    ];
    for (i, (s_axis, f, want)) in cases.into_iter().enumerate() {
        let table = Table3d::build(&f, &domain, &params(40, 24, s_axis)).unwrap();
        assert_eq!(table.is_uniform_axis(), s_axis == ScalarAxis::Uniform);
        assert_eq!(table.reconstruction(), want, "gap {}", table.reconstruction_gap());
        let shader = GpuShader::table3d(&ctx, &table).unwrap();
        let gpu = shader.probe_table3d(&ctx, &triples).unwrap();
        let cpu: Vec<[f32; 4]> = triples.iter().map(|t| table.lookup(t[0], t[1], t[2])).collect();
        let d = max_abs(&gpu, &cpu);
        eprintln!(
            "{s_axis:?} axis, {want:?}: GPU lookup vs Table3d::lookup over {} triples: max |Δ| {d:.3e}",
            triples.len()
        );
        // Vulkan's log is accurate to 2⁻²¹ absolute on [0.5, 2] only: an
        // entry's depth just above the series range (α ≥ 1/64) is then good
        // to ~3e-5 relative, which independent emission's colour (C ≫ α,
        // scaled by α) carries; density emission's colour is bounded by α.
        let tol = if f.emission() == Emission::Independent {
            5e-5 * cpu.iter().flatten().fold(1.0f32, |m, &v| m.max(v.abs()))
        } else {
            2e-6
        };
        assert!(d <= tol, "{s_axis:?} {want:?}: max |Δ| {d} > {tol}");
        if i < 2 {
            cpu_by_axis.push(cpu);
        }
    }
    let apart = max_abs(&cpu_by_axis[0], &cpu_by_axis[1]);
    eprintln!("uniform vs tf-nodes tables at the same triples: max |Δ| {apart:.3e}");
    assert!(apart > 1e-3, "{apart}");
}

/// Every stored entry of the GPU bake against the CPU bake (same axis,
/// same pieces; differences are rounding) and both against `exact` at the
/// grid nodes, for both emission models and both axes.
#[test]
fn gpu_bake_matches_the_cpu_bake() {
    let Some(ctx) = gpu() else { return };
    let domain = TableDomain::new(0.0, 1.0, 0.6, 1.5).unwrap();
    for emission in [Emission::Density, Emission::Independent] {
        let f = tf().with_emission(emission);
        for s_axis in [ScalarAxis::Uniform, ScalarAxis::TfNodes] {
            let p = params(24, 16, s_axis);
            let cpu = Table3d::build(&f, &domain, &p).unwrap();
            let baked = GpuTable3d::bake(&ctx, &f, &domain, &p, GpuAccumulation::F32).unwrap();
            assert_eq!(baked.s_knots(), cpu.s_knots().as_slice());
            let dense = baked.read_back(&ctx).unwrap();
            let (mut d_cpu, mut e_gpu, mut e_cpu, mut n) = (0.0f64, 0.0f64, 0.0f64, 0);
            for a in 0..p.n_s {
                assert_eq!(baked.scalar_at(a), cpu.scalar_at(a));
                for b in 0..p.n_s {
                    for k in 0..p.n_l {
                        let Some(c) = cpu.entry(a, b, k) else { continue };
                        let g = dense[(a * p.n_s + b) * p.n_l + k];
                        let x = integrate_segment(&f, cpu.scalar_at(a), cpu.scalar_at(b), cpu.len_at(k)).to_array();
                        for ch in 0..4 {
                            d_cpu = d_cpu.max((g[ch] - c[ch]).abs() as f64);
                            e_gpu = e_gpu.max((g[ch] as f64 - x[ch]).abs());
                            e_cpu = e_cpu.max((c[ch] as f64 - x[ch]).abs());
                        }
                        n += 1;
                    }
                }
            }
            eprintln!(
                "{emission:?} {s_axis:?}: {n} entries; GPU vs CPU bake max |Δ| {d_cpu:.3e}; vs exact at the nodes: \
                 GPU {e_gpu:.3e}, CPU {e_cpu:.3e}; GPU bake {:.3} s",
                baked.stats().bake_seconds
            );
            assert!(n > 0);
            assert!(d_cpu <= 5e-5, "GPU vs CPU bake {d_cpu}");
            assert!(e_gpu <= e_cpu + 1e-4, "GPU {e_gpu} vs CPU {e_cpu} against exact");
        }
    }
}

/// f16 accumulation is measurably worse than f32 against `exact`, and
/// still a usable table (the precision study's two ends).
#[test]
fn f16_accumulation_loses_precision_within_bounds() {
    let Some(ctx) = gpu() else { return };
    let domain = TableDomain::full(0.0, 1.0, 1.5).unwrap();
    let p = params(24, 16, ScalarAxis::TfNodes);
    let mut errs = Vec::new();
    for acc in [GpuAccumulation::F32, GpuAccumulation::F16] {
        let baked = GpuTable3d::bake(&ctx, &tf(), &domain, &p, acc).unwrap();
        let dense = baked.read_back(&ctx).unwrap();
        let mut e = 0.0f64;
        for a in 0..p.n_s {
            for b in 0..p.n_s {
                for k in 1..p.n_l {
                    let g = dense[(a * p.n_s + b) * p.n_l + k];
                    let x = integrate_segment(&tf(), baked.scalar_at(a), baked.scalar_at(b), k as f64 * 1.5 / 15.0);
                    for (gc, xc) in g.iter().zip(x.to_array()) {
                        e = e.max((*gc as f64 - xc).abs());
                    }
                }
            }
        }
        eprintln!("{} accumulation: max |error| vs exact at the nodes {e:.3e}", acc.id());
        errs.push(e);
    }
    assert!(errs[1] > errs[0], "{errs:?}");
    assert!(errs[1] < 0.02, "{errs:?}");
}

/// Images with the GPU-baked table (sampled where it was baked) against
/// tet_render's CPU renderer with the CPU-baked table, same MPVO order.
#[test]
fn gpu_baked_table_renders_as_the_cpu_table() {
    let Some(ctx) = gpu() else { return };
    let mesh: Mesh = grid(6);
    let (max_ds, len) = mesh.cell_limits();
    let domain = TableDomain::new(0.0, 1.0, max_ds, len).unwrap();
    let p = params(48, 48, ScalarAxis::TfNodes);
    let cpu_table = std::sync::Arc::new(Table3d::build(&tf(), &domain, &p).unwrap());
    let baked = GpuTable3d::bake(&ctx, &tf(), &domain, &p, GpuAccumulation::F32).unwrap();
    let shader = GpuShader::table3d_baked(&ctx, &baked).unwrap();
    let scene = mesh.gpu_scene(&ctx);
    let renderer = GpuRenderer::new(&ctx).unwrap();
    let mut cpu = cpu_pt_renderer(mesh.cpu_scene());
    cpu.set_shader(cpu_table);
    for (az, el) in [(30.0, 20.0), (-130.0, -40.0)] {
        let (lo, hi) = mesh.bounds();
        let spec = ViewSpec::framing(lo, hi, [96, 80]).orbit(az, el, 1.0);
        cpu.set_view(&spec).unwrap();
        let (want, order) = cpu_image_and_order(&mut cpu);
        let got = renderer.render(&ctx, &scene, &Camera::new(&spec).unwrap(), &order, &shader).unwrap().image;
        let d = diff(&got, &want).unwrap();
        eprintln!(
            "GPU-baked table3d vs CPU PT with the CPU table az {az} el {el}: mean {:.3}/255, max {:.3}/255",
            d.mean_abs * 255.0,
            d.max_abs * 255.0
        );
        assert!(want.pixels().iter().any(|p| p[3] > 0.0));
        assert!(d.mean_abs <= 0.5 / 255.0 && d.max_abs <= 2.0 / 255.0, "{d:?}");
    }
}

#[test]
fn unsupported_bakes_are_errors() {
    let Some(ctx) = gpu() else { return };
    let domain = TableDomain::full(0.0, 1.0, 1.0).unwrap();
    let exact = Table3dParams { build: tet_preint::Build3d::Exact, ..params(8, 8, ScalarAxis::Uniform) };
    let e = GpuTable3d::bake(&ctx, &tf(), &domain, &exact, GpuAccumulation::F32).err().unwrap();
    assert!(e.to_string().contains("CPU-only"), "{e}");
    let f16 = Table3dParams { precision: tet_preint::Precision::F16, ..params(8, 8, ScalarAxis::Uniform) };
    assert!(GpuTable3d::bake(&ctx, &tf(), &domain, &f16, GpuAccumulation::F32).is_err());
    assert!(GpuTable3d::bake(&ctx, &tf(), &domain, &params(1, 8, ScalarAxis::Uniform), GpuAccumulation::F32).is_err());
    let pt = GpuShader::pt_linear(&ctx, &tf()).unwrap();
    assert!(pt.probe_table3d(&ctx, &[[0.5, 0.5, 0.5]]).is_err());
    for bad in [
        tet_preint::PolyParams::new(3, 16, 0.0, 1.0, 1.0),
        tet_preint::PolyParams::new(2, 1, 0.0, 1.0, 1.0),
        tet_preint::PolyParams::new(2, 16, 1.0, 0.0, 1.0),
        tet_preint::PolyParams::new(2, 16, 0.0, 1.0, f64::NAN),
        tet_preint::PolyParams::new(2, 16, 0.0, 1.0, 1.0).with_max_ds(-1.0),
    ] {
        let e = tet_gpu::bake_poly(&ctx, &tf(), &bad).err().unwrap();
        assert!(e.to_string().contains("GPU poly bake"), "{e}");
    }
}

/// The poly1/2/4 tables baked on the GPU (f32) against `PolyTable::build`
/// (f64): stored ρ̂ and coefficients, and both lookups against `exact`
/// over the band, for both emission models and a banded and a full table.
#[test]
fn gpu_poly_bake_matches_the_cpu_poly_bake() {
    let Some(ctx) = gpu() else { return };
    let domain = TableDomain::new(0.0, 1.0, 0.3, 1.5).unwrap();
    let triples = uniform_triples(&domain, 5000, 0x9017);
    for emission in [Emission::Density, Emission::Independent] {
        let f = tf().with_emission(emission);
        for (degree, res, max_ds) in [(1, 24, f64::INFINITY), (2, 40, 0.3), (4, 32, 0.3)] {
            let p = tet_preint::PolyParams::new(degree, res, 0.0, 1.0, 1.5).with_max_ds(max_ds);
            let cpu = tet_preint::PolyTable::build(&f, &p).unwrap();
            let (gpu, stats) = tet_gpu::bake_poly(&ctx, &f, &p).unwrap();
            assert_eq!((gpu.band(), gpu.row_len()), (cpu.band(), cpu.row_len()));
            let d_rho = cpu.rho().iter().zip(gpu.rho()).map(|(a, b)| (a - b).abs()).fold(0.0f32, f32::max);
            let d_coef = cpu.coef().iter().zip(gpu.coef()).map(|(a, b)| (a - b).abs()).fold(0.0f32, f32::max);
            let (mut e_cpu, mut e_gpu, mut d_look) = (0.0f64, 0.0f64, 0.0f32);
            for t in &triples {
                let x = integrate_segment(&f, t[0] as f64, t[1] as f64, t[2] as f64).to_array();
                let (c, g) = (cpu.lookup(t[0], t[1], t[2]), gpu.lookup(t[0], t[1], t[2]));
                for ch in 0..4 {
                    e_cpu = e_cpu.max((c[ch] as f64 - x[ch]).abs());
                    e_gpu = e_gpu.max((g[ch] as f64 - x[ch]).abs());
                    d_look = d_look.max((c[ch] - g[ch]).abs());
                }
            }
            eprintln!(
                "poly{degree} {res}² band {:?} {emission:?}: max |Δρ̂| {d_rho:.2e}, max |Δcoef| {d_coef:.2e}, \
                 lookups max |Δ| {d_look:.2e}; vs exact: CPU {e_cpu:.3e}, GPU {e_gpu:.3e}; GPU bake {:.4} s",
                cpu.band(),
                stats.bake_seconds
            );
            assert!(d_look <= 1e-4, "lookups differ by {d_look}");
            assert!(e_gpu <= e_cpu + 1e-4, "GPU {e_gpu} vs CPU {e_cpu}");
        }
    }
}
