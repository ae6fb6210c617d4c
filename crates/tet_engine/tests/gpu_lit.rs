//! Lit frames on the GPU against the CPU's projected tetrahedra, the GPU's
//! reference (the same request: view, shading, order, culling): headlight,
//! a directional light and a point light with ambient and specular terms,
//! silhouettes, on a small grid and on Blunt Fin; zero gradients lit as
//! the isotropic medium; shadows (deep shadow maps). Skipped without a GPU adapter
//! (failed instead with TETKIT_REQUIRE_GPU=1); on this kind of machine
//! they run on lavapipe.

use std::path::Path;

mod common;

use common::grid_bundle;
use tet_bundle::{Bundle, BundleMeta};
use tet_engine::{
    resolve_tf, CpuFrameRenderer, FrameRenderer, FrameRequest, FrameStats, GpuFrameOptions, GpuFrameRenderer, Look,
    TfRequest, TfSource,
};
use tet_gpu::RasterPath;
use tet_mesh::{build_adjacency, tetrahedralize, ConvertOptions};
use tet_preint::{BakeOptions, CertifyOptions, Method, TableDomain, TransferFunction};
use tet_render::{
    diff, CpuRenderer, DiffStats, Image, Light, LightSet, LightSource, Lighting, Scene, Shading, ViewSpec,
};

const DATA: &str = concat!(env!("CARGO_MANIFEST_DIR"), "/../../tests/data/plot3d");

/// (RMSE, max |Δ| of one channel) allowed between a lit GPU frame and the
/// CPU's projected tetrahedra (premultiplied linear RGBA), measured on
/// lavapipe and set with a margin of about 20%: overall, and for the
/// lighting alone (where the unlit GPU and CPU frames agree to 1e-4: f32
/// lighting against the CPU's f64, the split count decided in f32).
struct Tolerance {
    overall: (f64, f64),
    lighting: (f64, f64),
}

/// Plain table3d and pt-linear. Measured: overall rmse 1.53e-5, max
/// 1.58e-3 (a few pixels' coverage, as unlit); the lighting alone rmse
/// 5.4e-6, max 1.9e-4.
const PLAIN: Tolerance = Tolerance { overall: (2e-5, 2e-3), lighting: (7e-6, 2.5e-4) };

/// The default table3d look, certified: the GPU looks its table up plainly
/// where the CPU splits segments at TF control points and integrates some
/// exactly, so its frames differ unlit already (here rmse 6.1e-4, max
/// 2.5e-2), and lit ones inherit that. Measured lit: overall rmse 5.1e-4,
/// max 1.49e-2; "the lighting alone" rmse 4.0e-5, max 1.8e-3.
const CERTIFIED: Tolerance = Tolerance { overall: (6e-4, 1.8e-2), lighting: (5e-5, 2.2e-3) };

/// The GPU, or `None` (skip) where there is no adapter; with
/// TETKIT_REQUIRE_GPU=1 a missing adapter fails the test.
fn gpu_renderer(bundle: &Bundle, raster: RasterPath) -> Option<GpuFrameRenderer> {
    let scene = Scene::from_bundle(bundle).unwrap();
    match GpuFrameRenderer::new(bundle, scene, GpuFrameOptions { raster }) {
        Ok(r) => {
            eprintln!("GPU adapter: {}", r.describe());
            Some(r)
        }
        Err(e) => {
            assert!(!tet_gpu::gpu_required(), "TETKIT_REQUIRE_GPU=1 but: {e}");
            eprintln!("skipped: {e}");
            None
        }
    }
}

/// Blunt Fin (NASA's PLOT3D sample, tests/data/plot3d/LICENSE.md), density.
fn bluntfin() -> Bundle {
    let read = tet_io::ReadOptions { q_path: Some(Path::new(DATA).join("bluntfinq.bin")), ..Default::default() };
    let source = tet_io::read_file(&Path::new(DATA).join("bluntfinxyz.bin"), &read).unwrap();
    let convert = ConvertOptions { scalar: Some("density".into()), ..Default::default() };
    let (mesh, _) = tetrahedralize(&source, &convert, &mut |_| {}).unwrap();
    let adjacency = build_adjacency(&mesh.points, &mesh.tets).unwrap();
    Bundle::new(mesh, adjacency, BundleMeta::default())
}

/// Opacity peaks over the normalized range, colour changing along it.
fn peaks() -> TransferFunction {
    TransferFunction::from_json(
        r#"{"normalized": true, "color": [[0, 1, 0.2, 0], [0.5, 0.9, 0.9, 0.3], [1, 0.1, 0.4, 1]],
            "opacity": [[0.2, 0], [0.25, 3], [0.3, 0], [0.45, 0], [0.5, 2], [0.55, 0], [0.6, 0], [0.62, 4], [0.64, 0],
                        [0.9, 0], [1, 1]],
            "unit_distance": 1}"#,
    )
    .unwrap()
}

/// The lightings compared: the default headlight; one directional light
/// with strong ambient and specular terms; a point light beside the mesh
/// with a dim headlight; the headlight with silhouettes.
fn shadings(bundle: &Bundle) -> Vec<(&'static str, Shading)> {
    let (lo, hi) = tet_mesh::stats::bounds(&bundle.mesh.points);
    let beside = [hi[0] + 0.5 * (hi[0] - lo[0]), 0.5 * (lo[1] + hi[1]), hi[2]];
    let material = Lighting { ambient: 0.25, diffuse: 0.6, specular: 0.5, shininess: 24.0, ..Lighting::default() };
    let lights = |l: &[LightSource]| LightSet::new(l).unwrap();
    vec![
        ("headlight", Lighting::default().shading(None)),
        (
            "directional",
            Lighting {
                lights: lights(&[LightSource::Directional { direction: [1.0, -1.0, -1.0], intensity: 1.0 }]),
                ..material
            }
            .shading(None),
        ),
        (
            "point",
            Lighting {
                lights: lights(&[
                    LightSource::Point { position: beside, intensity: 0.9 },
                    LightSource::Headlight { intensity: 0.3 },
                ]),
                ..material
            }
            .shading(None),
        ),
        ("headlight+silhouette", Lighting::default().shading(Some(2.0))),
    ]
}

/// The CPU projected-tetrahedra frame and the GPU frame of one request.
fn frames(
    gpu: &mut GpuFrameRenderer,
    cpu: &mut CpuFrameRenderer,
    look: &Look,
    req: &FrameRequest,
) -> (Image, Image, FrameStats) {
    let want = cpu.render(look, &FrameRequest { cpu: CpuRenderer::Pt, ..req.clone() }, &|_, _| {}).unwrap();
    let got = gpu.render(look, req, &|_, _| {}).unwrap();
    (got.image, want.image, got.stats)
}

fn report(what: &str, got: &Image, want: &Image) -> DiffStats {
    let d = diff(got, want).unwrap();
    let covered = want.pixels().iter().filter(|p| p[3] > 0.0).count();
    eprintln!(
        "{what}: rmse {:.3e}, max |Δ| {:.3e} ({:.3}/255) at {:?}, mean |Δ| {:.3e}; {covered} covered pixels",
        d.rmse,
        d.max_abs,
        d.max_abs * 255.0,
        d.max_at,
        d.mean_abs
    );
    assert!(covered > 0, "{what}: the CPU image is empty");
    assert!(got.pixels().iter().flatten().all(|v| v.is_finite()), "{what}: non-finite GPU pixels");
    d
}

/// Pixels where the unlit GPU and CPU frames agree to 1e-4 in every
/// channel: the same fragments (elsewhere a sliver's coverage differs).
fn same_fragments(gpu: &Image, cpu: &Image) -> Vec<bool> {
    gpu.pixels().iter().zip(cpu.pixels()).map(|(a, b)| a.iter().zip(b).all(|(x, y)| (x - y).abs() <= 1e-4)).collect()
}

/// (RMSE, max |Δ|, pixels) over the pixels `mask` keeps.
fn masked(got: &Image, want: &Image, mask: &[bool]) -> (f64, f64, usize) {
    let (mut sq, mut max, mut n) = (0.0f64, 0.0f64, 0usize);
    for ((a, b), &keep) in got.pixels().iter().zip(want.pixels()).zip(mask) {
        if !keep {
            continue;
        }
        n += 1;
        for (x, y) in a.iter().zip(b) {
            let d = (*x as f64 - *y as f64).abs();
            sq += d * d;
            max = max.max(d);
        }
    }
    ((sq / (4 * n.max(1)) as f64).sqrt(), max, n)
}

/// Every lighting on `bundle` from `view`, table3d and pt-linear, both GPU
/// rasterizers (a lit frame asked of the compute one runs on the graphics
/// one on llvmpipe, see `tet_gpu::LIT_LOOP_LIMITED_PAIRS`): within the
/// measured tolerance of the CPU overall, and within the tighter one of
/// the lighting alone where the unlit GPU and CPU frames of the same
/// rasterizer agree (elsewhere they differ unlit already); lit frames
/// differ from the unlit one (the lighting is applied, not ignored).
fn lit_frames_match_the_cpu(name: &str, bundle: &Bundle, view: ViewSpec) {
    let tf = resolve_tf(bundle, &TfRequest { source: TfSource::Given(peaks()), ..TfRequest::default() }).unwrap().tf;
    let mut cpu = CpuFrameRenderer::new(bundle).unwrap();
    let Some(compute) = gpu_renderer(bundle, RasterPath::Compute) else { return };
    let graphics = gpu_renderer(bundle, RasterPath::Graphics).expect("a second renderer on the same adapter");
    let mut gpus = [compute, graphics];
    let (mut worst, mut worst_lighting) = ((0.0f64, 0.0f64), (0.0f64, 0.0f64));
    let domain = TableDomain::from_bundle(bundle).unwrap();
    let plain = BakeOptions { certify: CertifyOptions::off(), ..BakeOptions::default() };
    let looks = [
        ("table3d", &CERTIFIED, Look::bake(bundle, Method::Table3d, tf.clone()).unwrap()),
        ("table3d (plain)", &PLAIN, Look::bake_with(&domain, Method::Table3d, tf.clone(), &plain, &[]).unwrap()),
        ("pt-linear", &PLAIN, Look::bake(bundle, Method::PtLinear, tf.clone()).unwrap()),
    ];
    for (method, tol, look) in &looks {
        let look = look.clone();
        let unlit_req = FrameRequest::new(view.clone());
        let want_unlit = cpu.render(&look, &FrameRequest { cpu: CpuRenderer::Pt, ..unlit_req.clone() }, &|_, _| {});
        let want_unlit = want_unlit.unwrap().image;
        // Unlit GPU frames by rasterizer: the lit frames' baseline.
        let mut unlit = vec![];
        for gpu in gpus.iter_mut() {
            let f = gpu.render(&look, &unlit_req, &|_, _| {}).unwrap();
            let FrameStats::Gpu(s) = &f.stats else { panic!("not a GPU frame") };
            report(&format!("{name} {method} unlit ({:?})", s.render.raster_path), &f.image, &want_unlit);
            unlit.push((s.render.raster_path, f.image));
        }
        for (asked, gpu) in [RasterPath::Compute, RasterPath::Graphics].into_iter().zip(gpus.iter_mut()) {
            for (lighting, shading) in shadings(bundle) {
                let req = FrameRequest { shading, ..FrameRequest::new(view.clone()) };
                let (got, want, stats) = frames(gpu, &mut cpu, &look, &req);
                let FrameStats::Gpu(s) = stats else { panic!("not a GPU frame") };
                let path = s.render.raster_path;
                if path != asked {
                    assert!(gpu.is_software(), "{asked:?} fell back to {path:?} on {}", gpu.describe());
                }
                let what = format!("{name} {method} {lighting} (asked {asked:?}, drawn {path:?})");
                let d = report(&what, &got, &want);
                let base = &unlit.iter().find(|(p, _)| *p == path).expect("an unlit frame of each rasterizer").1;
                let (rmse, max, n) = masked(&got, &want, &same_fragments(base, &want_unlit));
                eprintln!("{what}: where the unlit frames agree ({n} pixels): rmse {rmse:.3e}, max {max:.3e}");
                assert!(d.rmse <= tol.overall.0 && d.max_abs <= tol.overall.1, "{what}: {d:?}");
                assert!(n * 2 > want.pixels().len(), "{what}: too few pixels to compare the lighting alone");
                let ok = rmse <= tol.lighting.0 && max <= tol.lighting.1;
                assert!(ok, "{what}: the lighting alone: rmse {rmse}, max {max}");
                worst = (worst.0.max(d.rmse), worst.1.max(d.max_abs));
                worst_lighting = (worst_lighting.0.max(rmse), worst_lighting.1.max(max));
                assert!(diff(&got, base).unwrap().max_abs > 1e-3, "{what}: the lighting changed nothing");
                assert!(s.render.tets_drawn > 0, "{what}");
            }
        }
    }
    eprintln!(
        "{name}: worst rmse {:.3e}, max |Δ| {:.3e}; the lighting alone: rmse {:.3e}, max {:.3e}",
        worst.0, worst.1, worst_lighting.0, worst_lighting.1
    );
}

#[test]
fn lit_gpu_frames_match_the_cpu_on_a_small_grid() {
    let bundle = grid_bundle(8, false);
    let view = ViewSpec::framing([0.0; 3], [7.0, 7.0, 5.6], [72, 60]).orbit(35.0, 20.0, 1.0);
    lit_frames_match_the_cpu("grid", &bundle, view);
}

#[test]
fn lit_gpu_frames_match_the_cpu_on_blunt_fin() {
    let bundle = bluntfin();
    let (lo, hi) = tet_mesh::stats::bounds(&bundle.mesh.points);
    let view = ViewSpec::framing(lo, hi, [96, 72]).orbit(40.0, 15.0, 1.0);
    lit_frames_match_the_cpu("Blunt Fin", &bundle, view);
}

/// A constant scalar has zero gradients everywhere: every light lights it
/// as the isotropic medium (D = ka + Σ Iᵢ kd, no highlight, no
/// silhouette), so the GPU's pixels are finite and equal to the CPU's
/// within the tolerance, and with one light of intensity 1 and the default
/// material (ka + kd = 1) the frame is the unlit one.
#[test]
fn zero_gradients_are_lit_as_the_isotropic_medium() {
    let bundle = grid_bundle(6, true);
    let tf = TransferFunction::from_json(
        r#"{"color": [[0, 0.2, 0.6, 0.9], [5, 0.9, 0.5, 0.1]], "opacity": [[0, 0.3], [5, 0.3]], "unit_distance": 1}"#,
    )
    .unwrap();
    let tf = resolve_tf(&bundle, &TfRequest { source: TfSource::Given(tf), ..TfRequest::default() }).unwrap().tf;
    // The graphics rasterizer: lit frames on llvmpipe take it, so the unlit
    // frame it draws is the one lit frames are compared with bit for bit.
    let Some(mut gpu) = gpu_renderer(&bundle, RasterPath::Graphics) else { return };
    let mut cpu = CpuFrameRenderer::new(&bundle).unwrap();
    let view = ViewSpec::framing([0.0; 3], [5.0, 5.0, 4.0], [48, 40]).orbit(30.0, 25.0, 1.0);
    let look = Look::bake(&bundle, Method::Table3d, tf).unwrap();
    let unlit = gpu.render(&look, &FrameRequest::new(view.clone()), &|_, _| {}).unwrap().image;
    for (lighting, shading) in shadings(&bundle) {
        let req = FrameRequest { shading, ..FrameRequest::new(view.clone()) };
        let (got, want, _) = frames(&mut gpu, &mut cpu, &look, &req);
        let d = report(&format!("constant scalar, {lighting}"), &got, &want);
        assert!(d.rmse <= PLAIN.overall.0 && d.max_abs <= PLAIN.overall.1, "{lighting}: {d:?}");
        if lighting.starts_with("headlight") {
            let d = report(&format!("constant scalar, {lighting} vs unlit"), &got, &unlit);
            assert!(d.max_abs <= 1e-5, "{lighting}: the isotropic medium under ka + kd = 1 is the unlit frame: {d:?}");
        }
    }
    // The isotropic medium's D = ka + kd·I: a dimmer headlight scales the colour.
    let dim = Shading {
        light: Some(Light::default()),
        sources: LightSet::new(&[LightSource::Headlight { intensity: 0.5 }]).unwrap(),
        ..Default::default()
    };
    let req = FrameRequest { shading: dim, ..FrameRequest::new(view.clone()) };
    let (got, want, _) = frames(&mut gpu, &mut cpu, &look, &req);
    let d = report("constant scalar, dim headlight", &got, &want);
    assert!(d.rmse <= PLAIN.overall.0 && d.max_abs <= PLAIN.overall.1, "{d:?}");
    assert!(diff(&got, &unlit).unwrap().max_abs > 1e-3);
}

/// Shadows on the GPU: the deep shadow maps of a directional light and of
/// a point light outside the mesh's box, computed on the CPU as the CPU
/// renderer computes them and looked up where each piece is lit, against
/// the CPU's projected tetrahedra with the same field (both rasterizers;
/// the shadows darken the frame, and a camera move keeps the field); a
/// point light inside the box (its cube of six maps) likewise; shadows
/// asked of the headlight alone (it casts none) are drawn.
#[test]
fn shadowed_gpu_frames_match_the_cpu() {
    let bundle = grid_bundle(8, false);
    let view = ViewSpec::framing([0.0; 3], [7.0, 7.0, 5.6], [72, 60]).orbit(35.0, 20.0, 1.0);
    let lights = LightSet::new(&[
        LightSource::Directional { direction: [0.6, -1.0, -0.5], intensity: 0.8 },
        LightSource::Point { position: [-6.0, 12.0, 9.0], intensity: 0.7 },
        LightSource::Headlight { intensity: 0.2 },
    ])
    .unwrap();
    let material = Lighting { ambient: 0.2, specular: 0.4, lights, ..Lighting::default() };
    let lit = FrameRequest { shading: material.shading(None), ..FrameRequest::new(view.clone()) };
    let shadowed = FrameRequest { shading: Lighting { shadows: true, ..material }.shading(None), ..lit.clone() };
    assert_eq!(GpuFrameRenderer::supports(Method::Table3d, &shadowed), Ok(()));
    let tf = resolve_tf(&bundle, &TfRequest { source: TfSource::Given(peaks()), ..TfRequest::default() }).unwrap().tf;
    let domain = TableDomain::from_bundle(&bundle).unwrap();
    let plain = BakeOptions { certify: CertifyOptions::off(), ..BakeOptions::default() };
    let look = Look::bake_with(&domain, Method::Table3d, tf.clone(), &plain, &[]).unwrap();
    let mut cpu = CpuFrameRenderer::new(&bundle).unwrap();
    let Some(compute) = gpu_renderer(&bundle, RasterPath::Compute) else { return };
    let graphics = gpu_renderer(&bundle, RasterPath::Graphics).expect("a second renderer on the same adapter");
    for mut gpu in [compute, graphics] {
        let (got, want, stats) = frames(&mut gpu, &mut cpu, &look, &shadowed);
        let FrameStats::Gpu(s) = stats else { panic!("not a GPU frame") };
        assert!(s.shadow_seconds > 0.0, "the first shadowed frame computes the field");
        let what = format!("shadowed ({:?})", s.render.raster_path);
        let d = report(&what, &got, &want);
        assert!(d.rmse <= PLAIN.overall.0 && d.max_abs <= PLAIN.overall.1, "{what}: {d:?}");
        let (unshadowed, _, _) = frames(&mut gpu, &mut cpu, &look, &lit);
        assert!(diff(&got, &unshadowed).unwrap().max_abs > 1e-2, "{what}: the shadows changed nothing");
        // A camera move with the lights, TF and scalar kept reuses the field.
        let moved = FrameRequest { view: view.orbit(20.0, 0.0, 1.0), ..shadowed.clone() };
        let (got, want, stats) = frames(&mut gpu, &mut cpu, &look, &moved);
        let FrameStats::Gpu(s) = stats else { panic!("not a GPU frame") };
        assert_eq!(s.shadow_seconds, 0.0, "{what}: a camera move recomputed the shadows");
        let d = report(&format!("{what}, camera moved"), &got, &want);
        assert!(d.rmse <= PLAIN.overall.0 && d.max_abs <= PLAIN.overall.1, "{what}, moved: {d:?}");
    }
    let Some(mut gpu) = gpu_renderer(&bundle, RasterPath::Graphics) else { return };
    let inside = LightSet::new(&[LightSource::Point { position: [3.5, 3.5, 2.8], intensity: 1.0 }]).unwrap();
    let inside = Lighting { lights: inside, shadows: true, ..Lighting::default() }.shading(None);
    let req = FrameRequest { shading: inside, ..lit.clone() };
    let (got, want, _) = frames(&mut gpu, &mut cpu, &look, &req);
    let d = report("a point light inside, its cube of maps", &got, &want);
    assert!(d.rmse <= PLAIN.overall.0 && d.max_abs <= PLAIN.overall.1, "inside: {d:?}");
    let head = FrameRequest { shading: Shading { shadows: true, ..Lighting::default().shading(Some(1.0)) }, ..lit };
    let frame = gpu.render(&look, &head, &|_, _| {}).unwrap();
    assert!(frame.image.pixels().iter().any(|p| p[3] > 0.0));
}
