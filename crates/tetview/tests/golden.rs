//! Golden images: small renders of real data (tests/data) with pt-linear,
//! table3d and exact by both CPU renderers (projected tetrahedra:
//! `<scene>-<method>.npy`; the ray walker: `<scene>-<method>-walk.npy`), and
//! the ray-cast reference, compared with the files under tests/golden/.
//!
//! The goldens are written only by `make golden` (which sets
//! `TETKIT_WRITE_GOLDEN=1`); otherwise a render that differs from its golden
//! by more than [`MAX_ABS`] (linear premultiplied RGBA, any channel) or
//! [`RMSE`] fails, and `<scene>-<method>-actual.npy` / `-diff.png` are
//! written under the target's temporary directory (the path is printed).
//!
//! The renderer is deterministic; the tolerance leaves room for f32
//! rounding changes in the rasterizer (reordered arithmetic moves values by
//! ~1e-6) and catches real regressions: a dropped tet, a wrong table lookup
//! or a changed visibility order moves pixels by ≥ 1e-2, and even swapping
//! table3d for exact (max 1.2e-3 apart on `post`) fails.
//!
//! The accuracy target of issue 6 (the default method within 1/255 of the
//! reference after tone mapping, and RMSE ≤ 1e-3 in linear RGBA) is checked
//! here on the same scenes for table3d, `tetview render`'s default; pt-linear's
//! known miss is pinned to its measured range.

use std::path::{Path, PathBuf};
use std::sync::Arc;
use tet_bundle::{Bundle, BundleMeta};
use tet_preint::{BakeOptions, Method, SegmentShader, TableDomain, TransferFunction};
use tet_render::image::{diff_image_rgba8, linear_to_srgb, write_png_rgba8, Reinhard};
use tet_render::{
    diff, Camera, CpuRenderer, Image, ReferenceOptions, ReferenceRenderer, Renderer, Scene, TfCuller, ViewSpec,
};

const MAX_ABS: f64 = 5e-4;
const RMSE: f64 = 2e-5;
const SIZE: [u32; 2] = [96, 96];
/// pt-linear's measured error against the reference at [`SIZE`] (post: RMSE
/// 1.448e-3, 8-bit max 6; Blunt Fin: RMSE 1.452e-3, 8-bit max 2), as ranges
/// of about ±10% (the render is deterministic; the margin is for f32
/// rounding changes in the rasterizer, far smaller than this).
const PT_LINEAR_POST_RMSE: std::ops::RangeInclusive<f64> = 1.3e-3..=1.6e-3;
const PT_LINEAR_POST_8BIT: std::ops::RangeInclusive<u8> = 5..=7;
const PT_LINEAR_BLUNTFIN_RMSE: std::ops::RangeInclusive<f64> = 1.3e-3..=1.6e-3;
const PT_LINEAR_BLUNTFIN_8BIT: std::ops::RangeInclusive<u8> = 2..=3;
/// The methods with goldens.
const METHODS: [Method; 3] = [Method::PtLinear, Method::Table3d, Method::Exact];

fn root() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("../..")
}

/// A real dataset converted as `tetprep convert` does (no analysis section).
struct Case {
    name: &'static str,
    bundle: Bundle,
}

fn convert(name: &'static str, file: &str, q: Option<&str>, scalar: Option<&str>) -> Case {
    let opts = tet_io::ReadOptions { q_path: q.map(|q| root().join(q)), ..Default::default() };
    let source = tet_io::read_file(&root().join(file), &opts).unwrap();
    let copts = tet_mesh::ConvertOptions { scalar: scalar.map(String::from), ..Default::default() };
    let (mesh, _) = tet_mesh::tetrahedralize(&source, &copts, &mut |_| {}).unwrap();
    let adjacency = tet_mesh::build_adjacency(&mesh.points, &mesh.tets).unwrap();
    let stats = tet_mesh::mesh_stats(&mesh.points, &mesh.tets, &mesh.scalar);
    Case { name, bundle: Bundle::with_stats(mesh, adjacency, BundleMeta::default(), stats) }
}

/// VTKData `post.vtk` (8,750 tets, Pressure) and NASA Blunt Fin (PLOT3D,
/// 187k tets, density); provenance in tests/data/*/LICENSE.md.
fn cases() -> Vec<Case> {
    vec![
        convert("post", "tests/data/vtk/post.vtk", None, None),
        convert(
            "bluntfin",
            "tests/data/plot3d/bluntfinxyz.bin",
            Some("tests/data/plot3d/bluntfinq.bin"),
            Some("density"),
        ),
    ]
}

/// formats/samples/tf_normalized.json over the bundle's scalar range.
fn tf(bundle: &Bundle) -> TransferFunction {
    let text = std::fs::read_to_string(root().join("formats/samples/tf_normalized.json")).unwrap();
    let s = &bundle.meta.stats;
    TransferFunction::from_json(&text).unwrap().denormalize(s.scalar_min, s.scalar_max).unwrap()
}

/// An oblique view framing the bounds (not axis-aligned, so no face is edge-on).
fn view(bundle: &Bundle) -> ViewSpec {
    let scene = Scene::from_bundle(bundle).unwrap();
    let (lo, hi) = scene.bounds();
    ViewSpec::framing(lo, hi, SIZE).orbit(30.0, 20.0, 1.0)
}

/// What `tetview render --tf … --method m --renderer kind` draws (culling
/// on, sort auto, tables at the default resolutions).
fn render(case: &Case, method: Method, kind: CpuRenderer) -> Image {
    let tf = tf(&case.bundle);
    let domain = TableDomain::from_bundle(&case.bundle).unwrap();
    let shader: Arc<dyn SegmentShader> =
        tet_preint::make_shader(method, &tf, &domain, &BakeOptions::default()).unwrap().into();
    let mut r = Renderer::new(Scene::from_bundle(&case.bundle).unwrap());
    r.set_renderer(kind);
    r.set_view(&view(&case.bundle)).unwrap();
    r.set_shader(shader);
    r.set_culler(Some(Arc::new(TfCuller::new(&tf))));
    r.render(&|_, _| {}).unwrap().0
}

fn reference(case: &Case) -> Image {
    let rr = ReferenceRenderer::new(&case.bundle.mesh, &case.bundle.adjacency).unwrap();
    let camera = Camera::new(&view(&case.bundle)).unwrap();
    let (img, stats) = rr.render(&camera, &tf(&case.bundle), &ReferenceOptions::default(), &|_, _| {}).unwrap();
    assert_eq!(stats.walk_failures, 0, "{}: reference ray walks failed", case.name);
    img
}

/// Largest 8-bit difference after compositing over black, Reinhard fitted to
/// `reference` (applied to both) and sRGB: what `tetview diff` reports.
fn max_8bit(reference: &Image, b: &Image) -> u8 {
    let rgb = |p: &[f32; 4]| [p[0], p[1], p[2]];
    let op = Reinhard::fit(&reference.pixels().iter().map(rgb).collect::<Vec<_>>(), 0.18, 1.0);
    let to8 = |p: &[f32; 4]| op.apply(rgb(p)).map(|v| (linear_to_srgb(v).clamp(0.0, 1.0) * 255.0 + 0.5) as u8);
    reference
        .pixels()
        .iter()
        .zip(b.pixels())
        .flat_map(|(x, y)| {
            let (x, y) = (to8(x), to8(y));
            (0..3).map(move |c| x[c].abs_diff(y[c]))
        })
        .max()
        .unwrap_or(0)
}

fn golden_dir() -> PathBuf {
    root().join("tests/golden")
}

/// Compares `actual` with the golden `<key>.npy` (or writes it under `make
/// golden`); returns a failure message.
fn check(key: &str, actual: &Image) -> Option<String> {
    let path = golden_dir().join(format!("{key}.npy"));
    if std::env::var_os("TETKIT_WRITE_GOLDEN").is_some_and(|v| v == "1") {
        std::fs::create_dir_all(golden_dir()).unwrap();
        actual.write_npy(&path).unwrap();
        eprintln!("wrote {}", path.display());
        return None;
    }
    let golden = match Image::read_npy(&path) {
        Ok(g) => g,
        Err(e) => return Some(format!("{key}: no readable golden ({e}); run `make golden`")),
    };
    let d = match diff(&golden, actual) {
        Ok(d) => d,
        Err(e) => return Some(format!("{key}: {e}")),
    };
    if d.max_abs <= MAX_ABS && d.rmse <= RMSE {
        return None;
    }
    let out = Path::new(env!("CARGO_TARGET_TMPDIR")).join("golden");
    std::fs::create_dir_all(&out).unwrap();
    let (a, p) = (out.join(format!("{key}-actual.npy")), out.join(format!("{key}-diff.png")));
    actual.write_npy(&a).unwrap();
    let scale = if d.max_abs > 0.0 { d.max_abs as f32 } else { 1.0 };
    write_png_rgba8(&p, SIZE[0], SIZE[1], &diff_image_rgba8(&golden, actual, scale).unwrap()).unwrap();
    Some(format!(
        "{key}: max |golden − actual| {:.3e} at {:?} (limit {MAX_ABS:e}), RMSE {:.3e} (limit {RMSE:e}); wrote {} and {}",
        d.max_abs,
        d.max_at,
        d.rmse,
        a.display(),
        p.display()
    ))
}

#[test]
fn renders_match_golden_images() {
    let mut failures = vec![];
    for case in cases() {
        let r = reference(&case);
        failures.extend(check(&format!("{}-reference", case.name), &r));
        for m in METHODS {
            failures.extend(check(&format!("{}-{}", case.name, m.id()), &render(&case, m, CpuRenderer::Pt)));
            failures.extend(check(&format!("{}-{}-walk", case.name, m.id()), &render(&case, m, CpuRenderer::Walk)));
        }
    }
    assert!(failures.is_empty(), "{}", failures.join("\n"));
}

/// The accuracy target's figures for `method` on every scene: (scene,
/// RMSE in linear RGBA, largest 8-bit difference after tone mapping).
fn accuracy(method: Method, kind: CpuRenderer) -> Vec<(&'static str, f64, u8)> {
    cases()
        .into_iter()
        .map(|case| {
            let (r, img) = (reference(&case), render(&case, method, kind));
            let d = diff(&r, &img).unwrap();
            let m8 = max_8bit(&r, &img);
            eprintln!("{} {method} {kind}: RMSE {:.3e}, max abs {:.3e}, 8-bit max {m8}", case.name, d.rmse, d.max_abs);
            (case.name, d.rmse, m8)
        })
        .collect()
}

/// table3d, `tetview render`'s default method (baked on the fly at its
/// default 128×128×256 f32), meets the target on both scenes with both
/// renderers.
#[test]
fn default_method_table3d_meets_the_accuracy_target() {
    let failures: Vec<String> = [CpuRenderer::Walk, CpuRenderer::Pt]
        .into_iter()
        .flat_map(|k| accuracy(Method::Table3d, k).into_iter().map(move |a| (k, a)))
        .filter(|&(_, (_, rmse, m8))| rmse > 1e-3 || m8 > 1)
        .map(|(k, (name, rmse, m8))| {
            format!("{name} table3d {k}: RMSE {rmse:.3e} (target 1e-3), 8-bit max {m8} (target 1)")
        })
        .collect();
    assert!(failures.is_empty(), "{}", failures.join("\n"));
}

/// pt-linear by projected tetrahedra (the papers' algorithm: shaded once
/// at the thick vertex, interpolated across the silhouette) misses the
/// target: a measured fact, asserted as the range it was measured in so
/// that a change either way shows (see the figures in the assertions).
#[test]
fn pt_linear_misses_the_accuracy_target_by_its_measured_margin() {
    for (name, rmse, m8) in accuracy(Method::PtLinear, CpuRenderer::Pt) {
        let (rmse_range, m8_range) = match name {
            "post" => (PT_LINEAR_POST_RMSE, PT_LINEAR_POST_8BIT),
            _ => (PT_LINEAR_BLUNTFIN_RMSE, PT_LINEAR_BLUNTFIN_8BIT),
        };
        assert!(rmse_range.contains(&rmse), "{name} pt-linear: RMSE {rmse:.3e} outside measured {rmse_range:?}");
        assert!(m8_range.contains(&m8), "{name} pt-linear: 8-bit max {m8} outside measured {m8_range:?}");
        assert!(rmse > 1e-3 || m8 > 1, "{name} pt-linear now meets the target: make it a candidate default");
    }
}

/// The walker shades pt-linear's formula per ray segment (there is no
/// silhouette to interpolate over), so it is far closer to the reference
/// than PT's pt-linear: at most a third of its RMSE on both scenes.
#[test]
fn walker_pt_linear_is_per_segment_and_closer_than_pt() {
    let pt = accuracy(Method::PtLinear, CpuRenderer::Pt);
    let walk = accuracy(Method::PtLinear, CpuRenderer::Walk);
    for ((name, rmse_pt, _), (_, rmse_walk, _)) in pt.into_iter().zip(walk) {
        assert!(rmse_walk < rmse_pt / 3.0, "{name}: walker pt-linear RMSE {rmse_walk:.3e}, PT's {rmse_pt:.3e}");
    }
}
