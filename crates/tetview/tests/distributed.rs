//! `tetview render --distributed`: a partition (`tetprep partition`) drawn
//! one rank a piece and composited in its k-d tree's order equals the
//! unsplit bundle's image, at np = 1…4, camera outside and inside, convex
//! and non-convex meshes; bad partitions stop with one clear error. The
//! ranks here are threads of one process; `mpirun` runs them as processes
//! (feature `mpi`, the last tests).
use std::path::{Path, PathBuf};
use std::process::{Command, Output};
use tet_bundle::Bundle;
use tet_convert::partition::{write_partition, PartitionRequest, TetCost};
use tet_render::Image;

fn data(rel: &str) -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("../../tests/data").join(rel)
}

fn tetview(args: &[&str]) -> Output {
    Command::new(env!("CARGO_BIN_EXE_tetview")).args(args).output().expect("tetview runs")
}

fn arg(p: &Path) -> &str {
    p.to_str().expect("a UTF-8 path")
}

/// `input` converted as `tetprep convert` does, written to `dir/name`.
fn convert(dir: &Path, input: &Path, name: &str) -> PathBuf {
    let c = tet_convert::convert(input, &Default::default(), &mut |_| {}).unwrap();
    let p = dir.join(name);
    c.bundle.write(&p).unwrap();
    p
}

/// `src` cut into `parts` pieces in `out` (`tetprep partition`).
fn partition(src: &Path, out: &Path, parts: usize) {
    let b = Bundle::read(src).unwrap();
    let req = PartitionRequest { parts, cost: TetCost::Uniform };
    write_partition(&b, src, out, &req, false, &mut |_, b| Ok(b), &mut |_| {}).unwrap();
}

fn tf(dir: &Path) -> PathBuf {
    let p = dir.join("tf.json");
    std::fs::write(
        &p,
        r#"{"normalized": true, "color": [[0, 0.1, 0.2, 0.9], [0.5, 0.9, 0.8, 0.2], [1, 1, 0.2, 0]], "opacity": [[0, 0.2], [0.45, 4], [0.55, 0.5], [1, 3]], "unit_distance": 1}"#,
    )
    .unwrap();
    p
}

/// A view from inside the mesh's box: at its centre, looking down -z.
fn inside_view(dir: &Path, src: &Path) -> PathBuf {
    let b = Bundle::read(src).unwrap();
    let (lo, hi) = (b.meta.stats.bounds_min, b.meta.stats.bounds_max);
    let c: Vec<f64> = (0..3).map(|k| 0.5 * (lo[k] + hi[k])).collect();
    let p = dir.join("inside.json");
    let text = format!(
        r#"{{"position": [{}, {}, {}], "focal_point": [{}, {}, {}], "view_up": [0, 1, 0], "view_angle": 70, "size": [48, 40]}}"#,
        c[0] + 0.1 * (hi[0] - lo[0]),
        c[1],
        c[2],
        c[0],
        c[1] + 0.2 * (hi[1] - lo[1]),
        c[2] - (hi[2] - lo[2]),
    );
    std::fs::write(&p, text).unwrap();
    p
}

/// Renders `input` (a bundle, or with `distributed` a partition) to
/// `dir/name.npy` and `.png`; returns the float image and the PNG's bytes.
fn render(dir: &Path, input: &Path, name: &str, distributed: bool, extra: &[&str]) -> (Image, Vec<u8>) {
    let (npy, png, tf) = (dir.join(format!("{name}.npy")), dir.join(format!("{name}.png")), dir.join("tf.json"));
    let mut a = vec!["render", arg(input), "--tf", arg(&tf), "-o", arg(&png), "--float", arg(&npy)];
    if distributed {
        a.push("--distributed");
    }
    a.extend_from_slice(extra);
    let out = tetview(&a);
    assert!(out.status.success(), "{a:?}: {}", String::from_utf8_lossy(&out.stderr));
    (Image::read_npy(&npy).unwrap(), decode_png(&png))
}

fn decode_png(p: &Path) -> Vec<u8> {
    let decoder = png::Decoder::new(std::io::BufReader::new(std::fs::File::open(p).unwrap()));
    let mut reader = decoder.read_info().unwrap();
    let mut buf = vec![0; reader.output_buffer_size()];
    let info = reader.next_frame(&mut buf).unwrap();
    buf.truncate(info.buffer_size());
    buf
}

/// The exact method on both sides, every ray walked to its end: the
/// distributed image is the unsplit one within f32 rounding.
fn check_equal(src: &Path, dir: &Path, label: &str, views: &[(&str, Vec<&str>)]) {
    for (vname, view) in views {
        let mut flags = vec!["--method", "exact", "--no-early-termination"];
        flags.extend(view.iter().copied());
        let (whole, whole_png) = render(dir, src, &format!("whole_{vname}"), false, &flags);
        assert!(whole.pixels().iter().any(|p| p[3] > 0.05), "{label} {vname}: the view shows the mesh");
        for np in 1..=4 {
            let part = dir.join(format!("part{np}"));
            if !part.exists() {
                partition(src, &part, np);
            }
            let (img, img_png) = render(dir, &part, &format!("dist{np}_{vname}"), true, &flags);
            let d = tet_render::diff(&whole, &img).unwrap();
            let max8 = whole_png.iter().zip(&img_png).map(|(a, b)| a.abs_diff(*b)).max().unwrap();
            eprintln!("{label} {vname} np {np}: rmse {:.2e}, max {:.2e}, 8-bit max {max8}", d.rmse, d.max_abs);
            // 8-bit: equal, but for a pixel whose float difference (f32
            // rounding, ~1e-6) lands across a quantization step.
            assert!(d.rmse <= 1e-6 && d.max_abs <= 1e-5, "{label} {vname} np {np}: {d:?}");
            assert!(max8 <= 1, "{label} {vname} np {np}: 8-bit max {max8}");
        }
    }
}

/// `--reference`: every rank traces its piece with the exact f64 reference
/// ray caster, so the composite is `tetview reference`'s image of the
/// unsplit bundle to f32 rounding and its 8-bit output the same, at np =
/// 1…4, outside and inside, on a convex grid and a non-convex mesh (where
/// the walker's f32 geometry leaves a pixel one 8-bit step off).
#[test]
fn the_reference_drawn_distributed_equals_the_unsplit_reference_8_bit_for_8_bit() {
    let dir = tempfile::tempdir().unwrap();
    for (name, input) in [("iron", data("vtu/iron_sub.vti")), ("boxcyl", data("gmsh/boxcyl_41_bin.msh"))] {
        let d = dir.path().join(name);
        std::fs::create_dir(&d).unwrap();
        let tf = tf(&d);
        let src = convert(&d, &input, "src.tetb");
        let inside = inside_view(&d, &src);
        let views = [
            ("outside", vec!["--size", "48x40", "--azimuth", "35", "--elevation", "25"]),
            ("inside", vec!["--view", arg(&inside)]),
        ];
        for (vname, view) in views {
            let (npy, png) = (d.join(format!("ref_{vname}.npy")), d.join(format!("ref_{vname}.png")));
            let mut a = vec!["reference", arg(&src), "--tf", arg(&tf), "--no-early-termination"];
            a.extend_from_slice(&["-o", arg(&png), "--float", arg(&npy)]);
            a.extend(view.iter().copied());
            let out = tetview(&a);
            assert!(out.status.success(), "{a:?}: {}", String::from_utf8_lossy(&out.stderr));
            let (whole, whole_png) = (Image::read_npy(&npy).unwrap(), decode_png(&png));
            assert!(whole.pixels().iter().any(|p| p[3] > 0.05), "{name} {vname}: the view shows the mesh");
            for np in 1..=4 {
                let part = d.join(format!("part{np}"));
                if !part.exists() {
                    partition(&src, &part, np);
                }
                let mut flags = vec!["--reference", "--no-early-termination"];
                flags.extend(view.iter().copied());
                let (img, img_png) = render(&d, &part, &format!("dist{np}_{vname}"), true, &flags);
                let diff = tet_render::diff(&whole, &img).unwrap();
                let max8 = whole_png.iter().zip(&img_png).map(|(a, b)| a.abs_diff(*b)).max().unwrap();
                eprintln!("{name} {vname} np {np}: rmse {:.2e}, max {:.2e}, 8-bit max {max8}", diff.rmse, diff.max_abs);
                assert!(diff.rmse <= 1e-6 && diff.max_abs <= 1e-5, "{name} {vname} np {np}: {diff:?}");
                assert_eq!(max8, 0, "{name} {vname} np {np}");
            }
        }
    }
}

#[test]
fn a_convex_grid_drawn_distributed_equals_the_unsplit_image() {
    let dir = tempfile::tempdir().unwrap();
    tf(dir.path());
    let src = convert(dir.path(), &data("vtu/iron_sub.vti"), "iron.tetb");
    let inside = inside_view(dir.path(), &src);
    let views = [
        ("outside", vec!["--size", "48x40", "--azimuth", "35", "--elevation", "25"]),
        ("inside", vec!["--view", arg(&inside)]),
    ];
    check_equal(&src, dir.path(), "iron_sub", &views);
}

#[test]
fn a_non_convex_mesh_drawn_distributed_equals_the_unsplit_image() {
    let dir = tempfile::tempdir().unwrap();
    tf(dir.path());
    // A box with a cylindrical hole: rays leave the mesh and enter again.
    let src = convert(dir.path(), &data("gmsh/boxcyl_41_bin.msh"), "boxcyl.tetb");
    let views = [
        ("outside", vec!["--size", "48x40", "--azimuth", "-50", "--elevation", "15"]),
        ("parallel", vec!["--size", "40x40", "--azimuth", "80", "--parallel"]),
    ];
    check_equal(&src, dir.path(), "boxcyl", &views);
}

#[test]
fn tables_and_early_termination_stay_within_the_methods_tolerance() {
    let dir = tempfile::tempdir().unwrap();
    tf(dir.path());
    let src = convert(dir.path(), &data("vtu/iron_sub.vti"), "iron.tetb");
    let part = dir.path().join("part3");
    partition(&src, &part, 3);
    let flags = ["--size", "48x40", "--azimuth", "20", "--elevation", "-30"];
    let (exact, _) = render(dir.path(), &src, "exact", false, &[&flags[..], &["--method", "exact"]].concat());
    // The default (table3d, early termination), each rank's table baked
    // over its piece's domain: as close to exact as one process's is.
    let (one, _) = render(dir.path(), &src, "one", false, &flags);
    let (dist, _) = render(dir.path(), &part, "dist", true, &flags);
    as_accurate("table3d, one process and 3 ranks", &exact, &one, &dist);
}

/// `dist` is as close to `exact` as `one` is (twice its error at most,
/// with floors for errors near zero).
fn as_accurate(label: &str, exact: &Image, one: &Image, dist: &Image) {
    let (e1, ed) = (tet_render::diff(exact, one).unwrap(), tet_render::diff(exact, dist).unwrap());
    eprintln!("{label} vs exact: rmse {:.2e} / {:.2e}, max {:.2e} / {:.2e}", e1.rmse, ed.rmse, e1.max_abs, ed.max_abs);
    assert!(ed.rmse <= 2.0 * e1.rmse.max(1e-5) && ed.max_abs <= 2.0 * e1.max_abs.max(1e-3), "{label}: {e1:?} {ed:?}");
}

/// Without --tf: the automatic TF from the pieces' summed histograms is
/// the one the unsplit (analysed) bundle gets, and so is the image.
#[test]
fn the_automatic_tf_of_a_partition_is_the_unsplit_bundles() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let src = convert(d, &data("gmsh/boxcyl_41_bin.msh"), "plain.tetb");
    let b = Bundle::read(&src).unwrap();
    let opts = tet_analysis::AnalysisOptions { histogram: Some(Default::default()), ..Default::default() };
    let analysis = tet_analysis::Analyzer::from_mesh(&b.mesh).unwrap().analyze(&opts).unwrap();
    let analysed = d.join("analysed.tetb");
    b.with_analysis(analysis).write(&analysed).unwrap();
    let part = d.join("part3");
    partition(&analysed, &part, 3);
    let (one_tf, dist_tf) = (d.join("one_tf.json"), d.join("dist_tf.json"));
    let flags = ["--size", "40x32", "--azimuth", "40", "--method", "exact", "--no-early-termination"];
    let run = |input: &Path, name: &str, tf: &Path, distributed: bool| {
        let (png, npy) = (d.join(format!("{name}.png")), d.join(format!("{name}.npy")));
        let mut a = vec!["render", arg(input), "-o", arg(&png), "--float", arg(&npy), "--save-tf", arg(tf)];
        if distributed {
            a.push("--distributed");
        }
        a.extend_from_slice(&flags);
        let out = tetview(&a);
        assert!(out.status.success(), "{a:?}: {}", String::from_utf8_lossy(&out.stderr));
        assert!(String::from_utf8_lossy(&out.stderr).contains("automatic transfer function"));
        Image::read_npy(&npy).unwrap()
    };
    let one = run(&analysed, "one", &one_tf, false);
    let dist = run(&part, "dist", &dist_tf, true);
    let node_values = |p: &Path| -> Vec<f64> {
        let v: serde_json::Value = serde_json::from_str(&std::fs::read_to_string(p).unwrap()).unwrap();
        let mut out = vec![v["unit_distance"].as_f64().unwrap()];
        for key in ["opacity", "color"] {
            for node in v[key].as_array().unwrap() {
                out.extend(node.as_array().unwrap().iter().map(|x| x.as_f64().unwrap()));
            }
        }
        out
    };
    let (a, b) = (node_values(&one_tf), node_values(&dist_tf));
    assert_eq!(a.len(), b.len(), "the same nodes");
    let worst = a.iter().zip(&b).map(|(x, y)| (x - y).abs() / x.abs().max(1e-300)).fold(0.0, f64::max);
    assert!(worst <= 1e-9, "TF values differ by {worst:e} relative");
    let diff = tet_render::diff(&one, &dist).unwrap();
    eprintln!(
        "automatic TF: nodes within {worst:.1e} relative; image rmse {:.2e}, max {:.2e}",
        diff.rmse, diff.max_abs
    );
    // Measured: rmse 1.3e-6, max 2.4e-5 — f32 rounding of a denser TF's
    // compositing (the TFs agree to 1e-15), just over the 1e-6 the
    // hand-made TF above stays under.
    assert!(diff.rmse <= 2e-6 && diff.max_abs <= 5e-5, "{diff:?}");
}

/// `--gpu`: each rank draws its piece on its adapter; the composite is the
/// unsplit bundle's GPU image within the method's own change under
/// splitting. Skips where no adapter exists (every rank then exits 7).
#[test]
fn gpu_ranks_draw_what_one_gpu_draws_or_skip() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    tf(d);
    let src = convert(d, &data("gmsh/boxcyl_41_bin.msh"), "boxcyl.tetb");
    let part = d.join("part3");
    partition(&src, &part, 3);
    let flags = ["--size", "48x40", "--azimuth", "-50", "--elevation", "15", "--method", "table3d", "--gpu"];
    if let Err(e) = tet_gpu::GpuContext::new_headless() {
        if tet_gpu::gpu_required() {
            panic!("TETKIT_REQUIRE_GPU=1 but: {e}");
        }
        eprintln!("skipped: {e}");
        let (png, tf) = (d.join("x.png"), d.join("tf.json"));
        let mut a = vec!["render", arg(&part), "--distributed", "--tf", arg(&tf), "-o", arg(&png)];
        a.extend_from_slice(&flags);
        let out = tetview(&a);
        assert_eq!(out.status.code(), Some(7), "{}", String::from_utf8_lossy(&out.stderr));
        return;
    }
    let (one, _) = render(d, &src, "gpu_one", false, &flags);
    let (dist, _) = render(d, &part, "gpu_dist", true, &flags);
    let exact =
        ["--size", "48x40", "--azimuth", "-50", "--elevation", "15", "--method", "exact", "--no-early-termination"];
    let (truth, _) = render(d, &src, "exact", false, &exact);
    // As accurate as one GPU drawing the unsplit bundle (each rank's table
    // baked over its piece).
    as_accurate("--gpu table3d, one GPU and 3 GPU ranks", &truth, &one, &dist);
}

#[test]
fn bad_partitions_and_requests_stop_with_one_clear_error() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    tf(d);
    let src = convert(d, &data("vtu/can.vtu"), "can.tetb");
    let part = d.join("part");
    partition(&src, &part, 3);
    let run = |input: &Path, extra: &[&str]| {
        let png = d.join("bad.png");
        let mut a = vec!["render", arg(input), "--distributed", "-o", arg(&png), "--size", "16x16"];
        a.extend_from_slice(extra);
        tetview(&a)
    };
    let tf = d.join("tf.json");
    let expect = |out: Output, code: i32, words: &[&str]| {
        let err = String::from_utf8_lossy(&out.stderr).to_string();
        assert_eq!(out.status.code(), Some(code), "{err}");
        for w in words {
            assert!(err.contains(w), "{w:?} not in: {err}");
        }
        assert!(!d.join("bad.png").exists(), "no image written: {err}");
    };
    // No TF, and pieces without histograms to sum: every rank says so.
    expect(run(&part, &[]), 2, &["rank 0", "no scalar × |∇s| histogram", "tetprep analyze"]);
    // A bundle, not a manifest.
    expect(run(&src, &["--tf", arg(&tf)]), 3, &["not a tetkit partition manifest"]);
    // A method the GPU does not have.
    expect(run(&part, &["--tf", arg(&tf), "--gpu", "--method", "exact"]), 2, &["--gpu", "exact"]);
    // Shadows: a rank holds only its piece, so it would miss the others'
    // occluders (regression: each piece was drawn with its own shadows).
    expect(run(&part, &["--tf", arg(&tf), "--light-dir", "1,0,0", "--shadows"]), 2, &["--shadows", "occluders"]);
    // --reference needs --distributed, and is not --gpu.
    expect(run(&part, &["--tf", arg(&tf), "--reference", "--gpu"]), 2, &["--reference"]);
    // A corrupt piece: every rank stops with rank 1's message.
    let p1 = part.join("piece_0001.tetb");
    let mut bytes = std::fs::read(&p1).unwrap();
    let k = bytes.len() / 2;
    bytes[k] ^= 0x5a;
    std::fs::write(&p1, &bytes).unwrap();
    expect(run(&part, &["--tf", arg(&tf)]), 3, &["rank 1", "piece 1", "corrupt"]);
    // A missing piece.
    std::fs::remove_file(&p1).unwrap();
    expect(run(&part, &["--tf", arg(&tf)]), 3, &["rank 1", "piece 1", "missing"]);
    // A manifest whose piece list does not match its tree.
    let m = part.join("manifest.json");
    let text = std::fs::read_to_string(&m).unwrap();
    let mut v: serde_json::Value = serde_json::from_str(&text).unwrap();
    v["pieces"].as_array_mut().unwrap().pop();
    std::fs::write(&m, v.to_string()).unwrap();
    expect(run(&part, &["--tf", arg(&tf)]), 3, &["manifest"]);
}

/// Under mpirun (feature `mpi`): the processes' image is the threads' bit
/// for bit; np different from the pieces stops every rank with one message.
#[cfg(feature = "mpi")]
mod mpi {
    use super::*;

    fn mpirun(np: usize, args: &[&str]) -> Output {
        let mut c = Command::new("mpirun");
        c.args(["--oversubscribe", "-np", &np.to_string()]);
        if Command::new("id").arg("-u").output().is_ok_and(|o| o.stdout.starts_with(b"0")) {
            c.arg("--allow-run-as-root");
        }
        c.arg(env!("CARGO_BIN_EXE_tetview")).args(args);
        c.output().expect("mpirun runs (Open MPI's openmpi-bin)")
    }

    #[test]
    fn mpirun_ranks_draw_what_thread_ranks_draw() {
        let dir = tempfile::tempdir().unwrap();
        let d = dir.path();
        tf(d);
        let src = convert(d, &data("vtu/can.vtu"), "can.tetb");
        let part = d.join("part");
        partition(&src, &part, 3);
        let flags = ["--size", "40x32", "--azimuth", "30", "--method", "exact"];
        let (threads, _) = render(d, &part, "threads", true, &flags);
        let (npy, png) = (d.join("mpi.npy"), d.join("mpi.png"));
        let tf = d.join("tf.json");
        let mut a = vec!["render", arg(&part), "--distributed", "--tf", arg(&tf)];
        a.extend(["-o", arg(&png), "--float", arg(&npy)]);
        a.extend_from_slice(&flags);
        let out = mpirun(3, &a);
        assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
        assert!(Image::read_npy(&npy).unwrap() == threads, "the same image over MPI");
        // Two ranks for three pieces: every rank says so, nothing written.
        std::fs::remove_file(&png).unwrap();
        let out = mpirun(2, &a);
        let err = String::from_utf8_lossy(&out.stderr);
        assert_eq!(out.status.code(), Some(2), "{err}");
        assert_eq!(err.matches("2 ranks for a partition of 3 pieces").count(), 2, "{err}");
        assert!(!png.exists());
    }
}
