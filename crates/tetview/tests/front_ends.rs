//! Every front end is a client of `tet_engine`: the same request gives the
//! same image, bit for bit, whether it goes through `tetview render`,
//! `tetview reference` or the engine called as a library — on Blunt Fin
//! (NASA, tests/data/plot3d/LICENSE.md) with a held-out style TF of narrow
//! peaks, with and without lighting.

use std::path::{Path, PathBuf};
use std::process::Command;

use tet_bundle::{Bundle, BundleMeta};
use tet_engine::{
    resolve_tf, CpuFrameRenderer, FrameRenderer, FrameRequest, Look, ReferenceFrameRenderer, TfRequest, TfSource,
};
use tet_preint::Method;
use tet_render::{CpuRenderer, Image, Light, Shading, ViewSpec};

const DATA: &str = concat!(env!("CARGO_MANIFEST_DIR"), "/../../tests/data/plot3d");

fn bluntfin(dir: &Path) -> PathBuf {
    let read = tet_io::ReadOptions { q_path: Some(Path::new(DATA).join("bluntfinq.bin")), ..Default::default() };
    let source = tet_io::read_file(&Path::new(DATA).join("bluntfinxyz.bin"), &read).unwrap();
    let convert = tet_mesh::ConvertOptions { scalar: Some("density".into()), ..Default::default() };
    let (mesh, _) = tet_mesh::tetrahedralize(&source, &convert, &mut |_| {}).unwrap();
    let adjacency = tet_mesh::build_adjacency(&mesh.points, &mesh.tets).unwrap();
    let path = dir.join("bf.tetb");
    Bundle::new(mesh, adjacency, BundleMeta::default()).write(&path).unwrap();
    path
}

/// Five narrow opacity peaks over the normalized range, colours changing
/// between them.
fn peaks_tf(dir: &Path) -> PathBuf {
    let mut opacity = vec![];
    for k in 0..5 {
        let c = 0.15 + 0.17 * k as f64;
        opacity.extend([[c - 0.02, 0.0], [c, 8.0], [c + 0.02, 0.0]]);
    }
    let json = format!(
        r#"{{"normalized": true, "color": [[0, 0.1, 0.2, 1], [0.5, 1, 0.9, 0.2], [1, 1, 0.1, 0]], "opacity": {opacity:?}, "unit_distance": 1}}"#
    );
    let p = dir.join("peaks.json");
    std::fs::write(&p, json).unwrap();
    p
}

fn tetview(args: &[&str]) {
    let out = Command::new(env!("CARGO_BIN_EXE_tetview")).args(args).output().unwrap();
    assert!(out.status.success(), "{args:?}: {}", String::from_utf8_lossy(&out.stderr));
}

fn same_bits(a: &Image, b: &Image, what: &str) {
    assert_eq!((a.width(), a.height()), (b.width(), b.height()), "{what}");
    let differ = a.pixels().iter().zip(b.pixels()).filter(|(p, q)| p.map(f32::to_bits) != q.map(f32::to_bits)).count();
    assert_eq!(differ, 0, "{what}: {differ} pixels differ");
    assert!(a.pixels().iter().any(|p| p[3] > 0.05), "{what}: an empty image proves nothing");
}

#[test]
fn cli_and_library_draw_the_same_frames() {
    let dir = tempfile::tempdir().unwrap();
    let (b, t) = (bluntfin(dir.path()), peaks_tf(dir.path()));
    let (bs, ts) = (b.to_str().unwrap(), t.to_str().unwrap());
    let bundle = Bundle::read(&b).unwrap();
    let tf = resolve_tf(&bundle, &TfRequest { source: TfSource::File(t.clone()), ..TfRequest::default() }).unwrap().tf;
    let look = Look::bake(&bundle, Method::Table3d, tf).unwrap();
    let mut cpu = CpuFrameRenderer::new(&bundle).unwrap();

    for (renderer, light) in [("walk", false), ("pt", false), ("walk", true)] {
        let (npy, view) = (dir.path().join(format!("{renderer}{light}.npy")), dir.path().join("view.json"));
        let png = dir.path().join("x.png");
        let mut args = vec!["render", bs, "--tf", ts, "--renderer", renderer, "--size", "96x72", "--azimuth", "40"];
        args.extend(["-o", png.to_str().unwrap(), "--float", npy.to_str().unwrap()]);
        args.extend(["--save-view", view.to_str().unwrap()]);
        if light {
            args.push("--light");
        }
        tetview(&args);
        let spec = ViewSpec::from_json(&std::fs::read_to_string(&view).unwrap()).unwrap();
        let request = FrameRequest {
            cpu: renderer.parse::<CpuRenderer>().unwrap(),
            shading: Shading { light: light.then(Light::default), silhouette: None },
            ..FrameRequest::new(spec)
        };
        // The same renderer object across requests: its caches must not
        // change what a request draws.
        let frame = cpu.render(&look, &request, &|_, _| {}).unwrap();
        same_bits(
            &Image::read_npy(&npy).unwrap(),
            &frame.image,
            &format!("render --renderer {renderer}, light {light}"),
        );
    }

    let (npy, view) = (dir.path().join("ref.npy"), dir.path().join("view.json"));
    tetview(
        &["reference", bs, "--tf", ts, "--size", "64x48", "--elevation", "25"]
            .into_iter()
            .chain(["--float", npy.to_str().unwrap(), "--save-view", view.to_str().unwrap()])
            .collect::<Vec<_>>(),
    );
    let spec = ViewSpec::from_json(&std::fs::read_to_string(&view).unwrap()).unwrap();
    let mut exact = ReferenceFrameRenderer::new(&bundle).unwrap();
    let frame = exact.render(&Look::exact(look.tf.clone()), &FrameRequest::new(spec), &|_, _| {}).unwrap();
    same_bits(&Image::read_npy(&npy).unwrap(), &frame.image, "reference");
}

/// `render --gpu` is the engine's GPU renderer: the same look and request
/// drawn by the library give the same bits (skipped without an adapter
/// unless TETKIT_REQUIRE_GPU=1), and a second look on the same renderer
/// replaces the first's tables and cull (not reused by mistake).
#[test]
fn gpu_cli_and_library_draw_the_same_frames() {
    if let Err(e) = tet_gpu::GpuContext::new_headless() {
        assert!(!tet_gpu::gpu_required(), "TETKIT_REQUIRE_GPU is set but there is no adapter: {e}");
        eprintln!("skipped: no GPU adapter ({e})");
        return;
    }
    let dir = tempfile::tempdir().unwrap();
    let (b, t) = (bluntfin(dir.path()), peaks_tf(dir.path()));
    let (bs, ts) = (b.to_str().unwrap(), t.to_str().unwrap());
    let bundle = Bundle::read(&b).unwrap();
    let tf = resolve_tf(&bundle, &TfRequest { source: TfSource::File(t.clone()), ..TfRequest::default() }).unwrap().tf;
    let scene = tet_render::Scene::from_bundle(&bundle).unwrap();
    let mut gpu = tet_engine::GpuFrameRenderer::new(&bundle, scene, Default::default()).unwrap();
    let mut frames = vec![];
    for method in ["pt-linear", "table3d"] {
        let (npy, view) = (dir.path().join(format!("{method}.npy")), dir.path().join("view.json"));
        let png = dir.path().join("x.png");
        let mut args = vec!["render", bs, "--tf", ts, "--gpu", "--method", method, "--size", "96x72"];
        args.extend(["--azimuth", "40", "-o", png.to_str().unwrap(), "--float", npy.to_str().unwrap()]);
        args.extend(["--save-view", view.to_str().unwrap()]);
        tetview(&args);
        let spec = ViewSpec::from_json(&std::fs::read_to_string(&view).unwrap()).unwrap();
        let look = Look::bake(&bundle, method.parse::<Method>().unwrap(), tf.clone()).unwrap();
        let frame = gpu.render(&look, &FrameRequest::new(spec), &|_, _| {}).unwrap();
        same_bits(&Image::read_npy(&npy).unwrap(), &frame.image, &format!("render --gpu --method {method}"));
        frames.push(frame.image);
    }
    assert_ne!(frames[0].pixels(), frames[1].pixels(), "two methods, two images");
}
