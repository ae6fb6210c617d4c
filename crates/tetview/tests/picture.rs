//! Issue 17's "how we will know": `tetview render B -o x.png` with no TF,
//! no tone-mapping or opacity flag, on Blunt Fin and on data kinds the
//! defaults were not tuned on (curvilinear CFD, a CT-like volume, a point
//! cloud, and aerial lidar from a LAS file, which tetview frames z-up),
//! gives a picture with visible structure and colour. Over the
//! covered pixels of the PNG (α > tet_render's COVERED_ALPHA in the float
//! image written beside it): luminance spread (p95 − p5 of luma) ≥ 0.08, at
//! most 40% near-white pixels, median chroma ≥ 0.15. Before issue 17 the
//! demo's picture measured 0.02, 99% and 0.07.
//!
//! Images are 128² so the test stays fast; data provenance is in
//! tests/data/*/LICENSE.md.

use std::path::{Path, PathBuf};
use std::process::Command;
use tet_analysis::{AnalysisOptions, Analyzer, GradientMethod, HistogramOptions};
use tet_bundle::{Bundle, BundleMeta};
use tet_render::{Image, PictureMetrics};

fn root() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("../..")
}

/// Converts `file` as `tetprep convert` does with its defaults (point
/// clouds by 3D Delaunay, recorded in the bundle's `split` and `delaunay`
/// as tetprep records them, which is what makes tetview frame them z-up),
/// with `--gradients --histogram` when `analysis`.
fn bundle(file: &str, q: Option<&str>, scalar: Option<&str>, analysis: bool) -> Bundle {
    let opts = tet_io::ReadOptions { q_path: q.map(|q| root().join(q)), ..Default::default() };
    let mut source = tet_io::read_file(&root().join(file), &opts).unwrap();
    let mut meta = BundleMeta::default();
    if source.num_cells() == 0 {
        let cloud = tet_delaunay::triangulate_cloud(
            &mut source,
            tet_delaunay::CloudMode::Delaunay,
            &tet_delaunay::DelaunayOptions::default(),
            1e-10,
            false,
        )
        .unwrap();
        meta.split = "delaunay".into();
        meta.delaunay = cloud.fills_convex_hull;
    }
    let copts = tet_mesh::ConvertOptions { scalar: scalar.map(String::from), ..Default::default() };
    let (mesh, _) = tet_mesh::tetrahedralize(&source, &copts, &mut |_| {}).unwrap();
    let adjacency = tet_mesh::build_adjacency(&mesh.points, &mesh.tets).unwrap();
    let stats = tet_mesh::mesh_stats(&mesh.points, &mesh.tets, &mesh.scalar);
    let b = Bundle::with_stats(mesh, adjacency, meta, stats);
    if !analysis {
        return b;
    }
    let opts = AnalysisOptions {
        gradients: Some(GradientMethod::LeastSquares),
        histogram: Some(HistogramOptions::default()),
        ..Default::default()
    };
    let a = Analyzer::from_mesh(&b.mesh).unwrap().analyze(&opts).unwrap();
    b.with_analysis(a)
}

fn tetview(args: &[&str]) -> std::process::Output {
    Command::new(env!("CARGO_BIN_EXE_tetview")).args(args).output().unwrap()
}

/// Renders `b` with `extra` flags and measures the PNG.
fn render_metrics(dir: &Path, name: &str, b: &Path, extra: &[&str]) -> (PictureMetrics, String) {
    let (png, npy) = (dir.join(format!("{name}.png")), dir.join(format!("{name}.npy")));
    let mut args = vec!["render", b.to_str().unwrap(), "--size", "128x128", "-o", png.to_str().unwrap()];
    args.extend(["--float", npy.to_str().unwrap()]);
    args.extend(extra);
    let out = tetview(&args);
    let stderr = String::from_utf8_lossy(&out.stderr).to_string();
    assert!(out.status.success(), "{name}: {stderr}");
    let img = Image::read_npy(&npy).unwrap();
    let covered: Vec<bool> = img.pixels().iter().map(|p| p[3] > tet_render::image::COVERED_ALPHA).collect();
    let file = std::fs::File::open(&png).unwrap();
    let mut reader = png::Decoder::new(std::io::BufReader::new(file)).read_info().unwrap();
    let mut buf = vec![0u8; reader.output_buffer_size()];
    reader.next_frame(&mut buf).unwrap();
    (PictureMetrics::of_rgba8(&buf, &covered), stderr)
}

fn check(name: &str, m: &PictureMetrics) {
    eprintln!("{name}: {m}");
    assert!(m.covered_pixels > 128 * 128 / 20, "{name}: almost nothing drawn: {m}");
    assert!(m.luminance_spread >= 0.08, "{name}: flat picture: {m}");
    assert!(m.near_white <= 0.40, "{name}: saturated picture: {m}");
    assert!(m.median_chroma >= 0.15, "{name}: colourless picture: {m}");
}

#[test]
fn default_render_shows_structure_and_colour_on_four_kinds_of_data() {
    let dir = tempfile::tempdir().unwrap();
    // (name, file, PLOT3D Q file, scalar, stored analysis)
    type Case = (&'static str, &'static str, Option<&'static str>, Option<&'static str>, bool);
    let cases: [Case; 5] = [
        (
            "bluntfin",
            "tests/data/plot3d/bluntfinxyz.bin",
            Some("tests/data/plot3d/bluntfinq.bin"),
            Some("density"),
            true,
        ),
        ("combustor", "tests/data/plot3d/combxyz.bin", Some("tests/data/plot3d/combq.bin"), Some("density"), false),
        ("iron16", "tests/data/volume/iron16_raw.nrrd", None, None, false),
        ("stars", "tests/data/points/stars_lum_ci.ply", None, Some("lum"), false),
        // Aerial lidar (LAS) with tetprep's default scalar: terrain seen
        // from above the horizon with +z up, not from the top.
        ("autzen", "tests/data/points/autzen_trim.las", None, None, false),
    ];
    for (name, file, q, scalar, analysis) in cases {
        let b = bundle(file, q, scalar, analysis);
        let path = dir.path().join(format!("{name}.tetb"));
        b.write(&path).unwrap();
        let view = dir.path().join(format!("{name}_view.json"));
        let (m, stderr) = render_metrics(dir.path(), name, &path, &["--save-view", view.to_str().unwrap()]);
        assert!(stderr.contains("automatic transfer function"), "{name}: {stderr}");
        // Without a stored histogram the CLI says it computed one.
        assert_eq!(stderr.contains("no histogram section"), !analysis, "{name}: {stderr}");
        check(name, &m);
        // Point clouds get the z-up default view (+z up on screen, looking
        // down on them from above the horizon); the rest VTK's +y up.
        let view = tet_render::ViewSpec::from_json(&std::fs::read_to_string(&view).unwrap()).unwrap();
        let from_cloud = file.starts_with("tests/data/points/");
        assert_eq!(tet_render::camera::bundle_is_z_up(&b.meta), from_cloud, "{name}");
        if from_cloud {
            let forward_z = view.focal_point[2] - view.position[2];
            assert!(view.view_up[2] > 0.8 && forward_z < 0.0, "{name}: not a z-up view: {view:?}");
        } else {
            assert_eq!(view.view_up, tet_render::camera::Y_UP, "{name}");
        }
    }
}

/// Blunt Fin with the sample TF of the old demo: the tone mapping alone
/// (exposure over the covered pixels, colour kept) no longer washes it out.
#[test]
fn sample_tf_on_bluntfin_is_not_a_white_silhouette() {
    let dir = tempfile::tempdir().unwrap();
    let b = bundle("tests/data/plot3d/bluntfinxyz.bin", Some("tests/data/plot3d/bluntfinq.bin"), Some("density"), true);
    let path = dir.path().join("b.tetb");
    b.write(&path).unwrap();
    let tf = root().join("formats/samples/tf_normalized.json");
    let (m, _) = render_metrics(dir.path(), "sample", &path, &["--tf", tf.to_str().unwrap()]);
    eprintln!("bluntfin, sample TF: {m}");
    assert!(m.near_white <= 0.40 && m.luminance_spread >= 0.08, "{m}");
}

/// `--exposure` and `--light` change the picture visibly; `--save-tf`
/// writes a TF that `--tf` reads back to the same image; `--colormap`
/// and `--opacity-scale` apply.
#[test]
fn exposure_light_colormap_and_saved_tf() {
    let dir = tempfile::tempdir().unwrap();
    let b = bundle("tests/data/plot3d/bluntfinxyz.bin", Some("tests/data/plot3d/bluntfinq.bin"), Some("density"), true);
    let path = dir.path().join("b.tetb");
    b.write(&path).unwrap();
    let saved = dir.path().join("auto.json");
    let mean_luma = |name: &str, extra: &[&str]| {
        let (m, _) = render_metrics(dir.path(), name, &path, extra);
        let img = Image::read_npy(&dir.path().join(format!("{name}.npy"))).unwrap();
        let file = std::fs::File::open(dir.path().join(format!("{name}.png"))).unwrap();
        let mut reader = png::Decoder::new(std::io::BufReader::new(file)).read_info().unwrap();
        let mut buf = vec![0u8; reader.output_buffer_size()];
        reader.next_frame(&mut buf).unwrap();
        let lum: Vec<f64> = buf
            .chunks_exact(4)
            .map(|p| (0.2126 * p[0] as f64 + 0.7152 * p[1] as f64 + 0.0722 * p[2] as f64) / 255.0)
            .collect();
        (m, img, lum)
    };
    let (_, img1, base) = mean_luma("e1", &["--save-tf", saved.to_str().unwrap()]);
    let covered: Vec<usize> =
        (0..base.len()).filter(|&i| img1.pixels()[i][3] > tet_render::image::COVERED_ALPHA).collect();
    let mean = |l: &[f64]| covered.iter().map(|&i| l[i]).sum::<f64>() / covered.len() as f64;
    let mean_abs_change =
        |l: &[f64]| covered.iter().map(|&i| (l[i] - base[i]).abs()).sum::<f64>() / covered.len() as f64;
    let (_, _, dim) = mean_luma("e02", &["--exposure", "0.2"]);
    eprintln!("mean covered luma: exposure 1 {:.3}, exposure 0.2 {:.3}", mean(&base), mean(&dim));
    assert!(mean(&base) - mean(&dim) > 0.08, "exposure 0.2 barely changes the picture");
    let (_, _, lit) = mean_luma("lit", &["--light"]);
    eprintln!("--light: mean |change| of covered luma {:.3}", mean_abs_change(&lit));
    assert!(mean_abs_change(&lit) > 0.03, "--light barely changes the picture");
    // The saved TF reproduces the automatic one's image.
    let (_, img2, _) = mean_luma("saved", &["--tf", saved.to_str().unwrap()]);
    assert_eq!(img1, img2);
    let (m, _, _) = mean_luma("gray", &["--colormap", "grayscale"]);
    assert!(m.median_chroma < 0.02, "grayscale: {m}");
    let (_, img3, _) = mean_luma("dense", &["--opacity-scale", "3"]);
    let alpha = |i: &Image| i.pixels().iter().map(|p| p[3] as f64).sum::<f64>();
    assert!(alpha(&img3) > 1.2 * alpha(&img1));
    let out = tetview(&["render", path.to_str().unwrap(), "--colormap", "jett", "-o", "x.png"]);
    assert_eq!(out.status.code(), Some(2));
    assert!(String::from_utf8_lossy(&out.stderr).contains("viridis"));
}

/// Decoded 8-bit RGBA of a PNG that tetview wrote.
fn png_rgba8(path: &Path) -> Vec<u8> {
    let file = std::fs::File::open(path).unwrap();
    let mut reader = png::Decoder::new(std::io::BufReader::new(file)).read_info().unwrap();
    let mut buf = vec![0u8; reader.output_buffer_size()];
    reader.next_frame(&mut buf).unwrap();
    buf
}

/// A thin TF on Blunt Fin, end to end: red emission everywhere, opacity
/// only over the densest scalar range (density ≥ 2, the shock's
/// stagnation region in front of the fin), at an optical depth that gives
/// mid-opacity pixels. Through the CLI's Reinhard tone mapping that region
/// is red in the PNG (red well above green and blue, green and blue equal
/// as in the TF colour, never near-white), at the default exposure and at
/// a high one.
#[test]
fn thin_tf_keeps_bluntfins_densest_region_red() {
    let dir = tempfile::tempdir().unwrap();
    let b =
        bundle("tests/data/plot3d/bluntfinxyz.bin", Some("tests/data/plot3d/bluntfinq.bin"), Some("density"), false);
    let (lo, hi) = (b.meta.stats.scalar_min, b.meta.stats.scalar_max);
    assert!(lo < 1.9 && hi > 4.0, "Blunt Fin's density range moved: {lo}..{hi}");
    let path = dir.path().join("b.tetb");
    b.write(&path).unwrap();
    let tf = dir.path().join("red.json");
    std::fs::write(
        &tf,
        r#"{"color": [[0, 0.9, 0.05, 0.05], [5, 0.9, 0.05, 0.05]],
            "opacity": [[0, 0], [1.9, 0], [2.0, 0.2], [5, 0.2]],
            "unit_distance": 1}"#,
    )
    .unwrap();
    // The demo's orbit, closer in: the region is small in the default framing.
    let view = ["--tf", tf.to_str().unwrap(), "--azimuth", "35", "--elevation", "25", "--zoom", "2"];
    for exposure in ["1", "4"] {
        let mut extra = view.to_vec();
        extra.extend(["--exposure", exposure]);
        let name = format!("red{exposure}");
        let (m, _) = render_metrics(dir.path(), &name, &path, &extra);
        eprintln!("thin red TF, exposure {exposure}: {m}");
        let img = Image::read_npy(&dir.path().join(format!("{name}.npy"))).unwrap();
        let rgba = png_rgba8(&dir.path().join(format!("{name}.png")));
        // Mid opacity: the region is neither faint nor an opaque block.
        let max_alpha = img.pixels().iter().map(|p| p[3]).fold(0.0f32, f32::max);
        assert!((0.3..=0.8).contains(&max_alpha), "exposure {exposure}: largest α {max_alpha}");
        let mid: Vec<[i32; 3]> = img
            .pixels()
            .iter()
            .zip(rgba.chunks_exact(4))
            .filter(|(q, _)| q[3] >= 0.1)
            .map(|(_, p)| [p[0], p[1], p[2]].map(i32::from))
            .collect();
        assert!(mid.len() > 200, "exposure {exposure}: only {} pixels of α ≥ 0.1", mid.len());
        for &[r, g, b] in &mid {
            assert!(r - g.max(b) >= 64 && (g - b).abs() <= 3, "exposure {exposure}: {:?} is not red", [r, g, b]);
            assert!(g.min(b) < 200, "exposure {exposure}: {:?} is near-white", [r, g, b]);
        }
        assert_eq!(m.near_white, 0.0, "exposure {exposure}: {m}");
    }
}

/// `--light` on a bundle without gradients says so on stderr (they are
/// computed now, for the shading normals) and still lights the picture
/// visibly: the mean change of covered luminance against the unlit render
/// is as large as `exposure_light_colormap_and_saved_tf` asks of a bundle
/// with stored gradients.
#[test]
fn light_without_stored_gradients_notes_it_and_shows() {
    let dir = tempfile::tempdir().unwrap();
    let b =
        bundle("tests/data/plot3d/bluntfinxyz.bin", Some("tests/data/plot3d/bluntfinq.bin"), Some("density"), false);
    assert!(b.analysis.is_none());
    let path = dir.path().join("b.tetb");
    b.write(&path).unwrap();
    let note = "note: the bundle has no gradients";
    let (_, plain_err) = render_metrics(dir.path(), "plain", &path, &[]);
    assert!(!plain_err.contains(note), "{plain_err}");
    let (m, lit_err) = render_metrics(dir.path(), "lit", &path, &["--light"]);
    assert!(lit_err.contains(note) && lit_err.contains("computed now"), "{lit_err}");
    check("bluntfin without gradients, --light", &m);
    let covered: Vec<bool> = Image::read_npy(&dir.path().join("plain.npy"))
        .unwrap()
        .pixels()
        .iter()
        .map(|p| p[3] > tet_render::image::COVERED_ALPHA)
        .collect();
    let luma = |name: &str| -> Vec<f64> {
        png_rgba8(&dir.path().join(format!("{name}.png")))
            .chunks_exact(4)
            .map(|p| (0.2126 * p[0] as f64 + 0.7152 * p[1] as f64 + 0.0722 * p[2] as f64) / 255.0)
            .collect()
    };
    let (plain, lit) = (luma("plain"), luma("lit"));
    let n = covered.iter().filter(|&&c| c).count();
    assert!(n > 0);
    let change = (0..plain.len()).filter(|&i| covered[i]).map(|i| (lit[i] - plain[i]).abs()).sum::<f64>() / n as f64;
    eprintln!("--light without stored gradients: mean |change| of covered luma {change:.3}");
    assert!(change > 0.03, "--light barely changes the picture");
}
