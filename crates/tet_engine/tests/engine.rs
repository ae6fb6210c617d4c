//! The engine's contracts: it draws what the staged renderer wired by hand
//! draws; what it caches between frames never changes a frame; one TF
//! policy with clear errors.

use std::sync::Arc;

mod common;

use common::grid_bundle;
use tet_engine::{
    resolve_tf, CpuFrameRenderer, EngineError, FrameRenderer, FrameRequest, Look, ReferenceFrameRenderer, TfRequest,
    TfSource,
};
use tet_preint::{Method, TransferFunction};
use tet_render::{CpuRenderer, Image, Renderer, Scene, TfCuller, ViewSpec};

fn peaks() -> TransferFunction {
    TransferFunction::from_json(
        r#"{"normalized": true, "color": [[0, 1, 0.2, 0], [1, 0.1, 0.4, 1]],
            "opacity": [[0.2, 0], [0.25, 6], [0.3, 0], [0.6, 0], [0.62, 9], [0.64, 0], [0.9, 0], [1, 2]],
            "unit_distance": 1}"#,
    )
    .unwrap()
}

fn bits(img: &Image) -> Vec<[u32; 4]> {
    img.pixels().iter().map(|p| p.map(f32::to_bits)).collect()
}

#[test]
fn the_engine_draws_what_the_staged_renderer_draws() {
    let bundle = grid_bundle(9, false);
    let tf = resolve_tf(&bundle, &TfRequest { source: TfSource::Given(peaks()), ..TfRequest::default() }).unwrap().tf;
    let look = Look::bake(&bundle, Method::Table3d, tf.clone()).unwrap();
    let view = ViewSpec::framing([0.0; 3], [8.0, 8.0, 6.4], [80, 64]).orbit(35.0, 20.0, 1.0);
    for cpu in [CpuRenderer::Walk, CpuRenderer::Pt] {
        let mut by_hand = Renderer::new(Scene::from_bundle(&bundle).unwrap());
        by_hand.set_view(&view).unwrap();
        by_hand.set_renderer(cpu);
        by_hand.set_shader(look.shader().expect("baked"));
        by_hand.set_culler(Some(Arc::new(TfCuller::new(&tf))));
        let (expect, _) = by_hand.render(&|_, _| {}).unwrap();
        let mut engine = CpuFrameRenderer::new(&bundle).unwrap();
        let got = engine.render(&look, &FrameRequest { cpu, ..FrameRequest::new(view.clone()) }, &|_, _| {}).unwrap();
        assert!(bits(&expect) == bits(&got.image), "{cpu}");
        assert_eq!(engine.id(), cpu.id());
    }
}

/// A renderer reused across views, looks and culling settings draws each
/// request exactly as a fresh one does.
#[test]
fn caches_never_change_a_frame() {
    let bundle = grid_bundle(8, false);
    let tf = resolve_tf(&bundle, &TfRequest { source: TfSource::Given(peaks()), ..TfRequest::default() }).unwrap().tf;
    let table = Look::bake(&bundle, Method::Table3d, tf.clone()).unwrap();
    let linear = Look::bake(&bundle, Method::PtLinear, tf).unwrap();
    let base = ViewSpec::framing([0.0; 3], [7.0, 7.0, 5.6], [48, 40]);
    let requests: Vec<FrameRequest> = [0.0, 70.0, 0.0]
        .into_iter()
        .flat_map(|az| [true, false].map(|cull| FrameRequest { cull, ..FrameRequest::new(base.orbit(az, 10.0, 1.0)) }))
        .collect();
    let mut reused = CpuFrameRenderer::new(&bundle).unwrap();
    for look in [&table, &linear, &table] {
        for req in &requests {
            let warm = reused.render(look, req, &|_, _| {}).unwrap();
            let cold = CpuFrameRenderer::new(&bundle).unwrap().render(look, req, &|_, _| {}).unwrap();
            assert!(bits(&warm.image) == bits(&cold.image), "{:?} cull {}", look.method, req.cull);
        }
    }
}

#[test]
fn the_reference_and_the_walker_agree_on_a_certified_table() {
    let bundle = grid_bundle(8, false);
    let tf = resolve_tf(&bundle, &TfRequest { source: TfSource::Given(peaks()), ..TfRequest::default() }).unwrap().tf;
    let look = Look::bake(&bundle, Method::Table3d, tf.clone()).unwrap();
    let req = FrameRequest::new(ViewSpec::framing([0.0; 3], [7.0, 7.0, 5.6], [48, 40]).orbit(20.0, 30.0, 1.0));
    let walk = CpuFrameRenderer::new(&bundle).unwrap().render(&look, &req, &|_, _| {}).unwrap();
    let exact = ReferenceFrameRenderer::new(&bundle).unwrap().render(&Look::exact(tf), &req, &|_, _| {}).unwrap();
    let d = tet_render::diff(&walk.image, &exact.image).unwrap();
    assert!(d.max_abs < 1.0 / 255.0, "max {}", d.max_abs);
}

#[test]
fn one_tf_policy_with_clear_errors() {
    let bundle = grid_bundle(4, false);
    let (lo, hi) = (bundle.meta.stats.scalar_min, bundle.meta.stats.scalar_max);
    // A normalized TF spans the bundle's range, or the range given.
    let given = |range| TfRequest { source: TfSource::Given(peaks()), range, ..TfRequest::default() };
    let tf = resolve_tf(&bundle, &given(None)).unwrap().tf;
    assert!(!tf.normalized());
    let r = resolve_tf(&bundle, &given(Some((-1.0, 1.0)))).unwrap();
    assert!(r.auto.is_none() && r.notes.is_empty());
    // A constant scalar still gets a TF (a unit-wide range about it).
    let flat = grid_bundle(4, true);
    assert!(!resolve_tf(&flat, &given(None)).unwrap().tf.normalized());
    // A range for a TF in scalar units is refused, not ignored.
    let absolute = TfRequest { source: TfSource::Given(tf.clone()), range: Some((lo, hi)), ..TfRequest::default() };
    assert!(matches!(resolve_tf(&bundle, &absolute), Err(EngineError::RangeForAbsoluteTf)));
    // No TF: the automatic one, which says what it was built from.
    let auto = resolve_tf(&bundle, &TfRequest::default()).unwrap();
    assert!(auto.auto.is_some());
    // A missing file names its path.
    let missing = TfRequest { source: TfSource::File("/nonexistent/tf.json".into()), ..TfRequest::default() };
    let e = resolve_tf(&bundle, &missing).unwrap_err();
    assert!(
        matches!(e, EngineError::Tf(tet_preint::TfError::Read { .. }))
            && e.to_string().contains("/nonexistent/tf.json"),
        "{e}"
    );
    // A .tetl that is not one.
    let dir = tempfile::tempdir().unwrap();
    let bad = dir.path().join("bad.tetl");
    std::fs::write(&bad, b"not a table").unwrap();
    assert!(matches!(Look::from_lut(&bad), Err(EngineError::Lut(_))));
}

/// A look whose tables the GPU bakes is refused by the CPU renderer with a
/// message, not drawn with nothing and not a panic.
#[test]
fn a_look_baked_by_the_gpu_is_refused_on_the_cpu() {
    let bundle = grid_bundle(4, false);
    let tf = resolve_tf(&bundle, &TfRequest { source: TfSource::Given(peaks()), ..TfRequest::default() }).unwrap().tf;
    let look = Look::baked_by_renderer(&bundle, tf, Method::Table3d).unwrap();
    let mut cpu = CpuFrameRenderer::new(&bundle).unwrap();
    let view = ViewSpec::framing([0.0; 3], [3.0; 3], [16, 16]);
    let e = cpu.render(&look, &FrameRequest::new(view), &|_, _| {}).unwrap_err();
    assert!(matches!(e, tet_engine::EngineError::NotBaked { method: Method::Table3d }), "{e}");
    assert!(e.to_string().contains("Look::bake"), "{e}");
}

/// A time step's stored gradients light the frame (no gradients computed,
/// no note), and the frame equals one whose gradients were computed from
/// that step's scalar (least squares of the same scalar: the same image up
/// to rounding); a step without stored gradients computes them again.
#[test]
fn a_time_steps_stored_gradients_light_the_frame() {
    let bundle = grid_bundle(7, false);
    let tf = resolve_tf(&bundle, &TfRequest { source: TfSource::Given(peaks()), ..TfRequest::default() }).unwrap().tf;
    let look = Look::bake(&bundle, Method::Table3d, tf).unwrap();
    let view = ViewSpec::framing([0.0; 3], [6.0, 6.0, 4.8], [48, 40]).orbit(25.0, 15.0, 1.0);
    let lit = tet_render::Lighting::default().shading(None);
    let req = FrameRequest { shading: lit, ..FrameRequest::new(view) };
    let step: Vec<f64> = bundle.mesh.scalar.iter().map(|s| 0.5 * s + 0.25).collect();
    // The least-squares gradients a scene computes for the step's scalar.
    let lsq = Scene::new(&bundle.mesh.points, bundle.mesh.tets.clone(), step.clone())
        .unwrap()
        .ensure_gradients()
        .unwrap()
        .gradients()
        .unwrap()
        .to_vec();
    for cpu in [CpuRenderer::Walk, CpuRenderer::Pt] {
        let req = FrameRequest { cpu, ..req.clone() };
        let mut stored = CpuFrameRenderer::new(&bundle).unwrap();
        stored.render(&look, &req, &|_, _| {}).unwrap();
        stored.set_scalar_with_gradients(step.clone(), Some(lsq.clone())).unwrap();
        let a = stored.render(&look, &req, &|_, _| {}).unwrap();
        assert!(a.notes.is_empty(), "{cpu}: {:?}", a.notes);
        let mut computed = CpuFrameRenderer::new(&bundle).unwrap();
        computed.render(&look, &req, &|_, _| {}).unwrap();
        computed.set_scalar(step.clone()).unwrap();
        let b = computed.render(&look, &req, &|_, _| {}).unwrap();
        assert_eq!(b.notes, [tet_engine::GRADIENTS_NOTE], "{cpu}");
        let d = tet_render::diff(&a.image, &b.image).unwrap();
        assert!(d.max_abs < 1e-6, "{cpu}: {d:?}");
        assert!(
            stored.set_scalar_with_gradients(step.clone(), Some(lsq[1..].to_vec())).is_err(),
            "{cpu}: a gradient short is refused"
        );
    }
}
