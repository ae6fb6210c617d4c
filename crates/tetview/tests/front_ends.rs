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

/// `p` as a command-line argument (the tests' paths are UTF-8).
fn path_arg(p: &Path) -> &str {
    p.to_str().expect("a UTF-8 path")
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
    let (bs, ts) = (path_arg(&b), path_arg(&t));
    let bundle = Bundle::read(&b).unwrap();
    let tf = resolve_tf(&bundle, &TfRequest { source: TfSource::File(t.clone()), ..TfRequest::default() }).unwrap().tf;
    let look = Look::bake(&bundle, Method::Table3d, tf).unwrap();
    let mut cpu = CpuFrameRenderer::new(&bundle).unwrap();

    for (renderer, light) in [("walk", false), ("pt", false), ("walk", true)] {
        let (npy, view) = (dir.path().join(format!("{renderer}{light}.npy")), dir.path().join("view.json"));
        let png = dir.path().join("x.png");
        let mut args = vec!["render", bs, "--tf", ts, "--renderer", renderer, "--size", "96x72", "--azimuth", "40"];
        args.extend(["-o", path_arg(&png), "--float", path_arg(&npy)]);
        args.extend(["--save-view", path_arg(&view)]);
        if light {
            args.push("--light");
        }
        tetview(&args);
        let spec = ViewSpec::from_json(&std::fs::read_to_string(&view).unwrap()).unwrap();
        let request = FrameRequest {
            cpu: renderer.parse::<CpuRenderer>().unwrap(),
            shading: Shading { light: light.then(Light::default), silhouette: None, ..Default::default() },
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
            .chain(["--float", path_arg(&npy), "--save-view", path_arg(&view)])
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
    let (bs, ts) = (path_arg(&b), path_arg(&t));
    let bundle = Bundle::read(&b).unwrap();
    let tf = resolve_tf(&bundle, &TfRequest { source: TfSource::File(t.clone()), ..TfRequest::default() }).unwrap().tf;
    let scene = tet_render::Scene::from_bundle(&bundle).unwrap();
    let mut gpu = tet_engine::GpuFrameRenderer::new(&bundle, scene, Default::default()).unwrap();
    let mut frames = vec![];
    for method in ["pt-linear", "table3d"] {
        let (npy, view) = (dir.path().join(format!("{method}.npy")), dir.path().join("view.json"));
        let png = dir.path().join("x.png");
        let mut args = vec!["render", bs, "--tf", ts, "--gpu", "--method", method, "--size", "96x72"];
        args.extend(["--azimuth", "40", "-o", path_arg(&png), "--float", path_arg(&npy)]);
        args.extend(["--save-view", path_arg(&view)]);
        tetview(&args);
        let spec = ViewSpec::from_json(&std::fs::read_to_string(&view).unwrap()).unwrap();
        let look = Look::bake(&bundle, method.parse::<Method>().unwrap(), tf.clone()).unwrap();
        let frame = gpu.render(&look, &FrameRequest::new(spec), &|_, _| {}).unwrap();
        same_bits(&Image::read_npy(&npy).unwrap(), &frame.image, &format!("render --gpu --method {method}"));
        frames.push(frame.image);
    }
    assert_ne!(frames[0].pixels(), frames[1].pixels(), "two methods, two images");

    // A new scalar (a time step) on the same renderer draws what a fresh
    // renderer on a bundle with that scalar draws.
    let spec = ViewSpec::from_json(&std::fs::read_to_string(dir.path().join("view.json")).unwrap()).unwrap();
    let look = Look::bake(&bundle, Method::Table3d, tf.clone()).unwrap();
    let (lo, hi) = (bundle.meta.stats.scalar_min, bundle.meta.stats.scalar_max);
    let flipped: Vec<f64> = bundle.mesh.scalar.iter().map(|s| lo + hi - s).collect();
    gpu.set_scalar(flipped.clone()).unwrap();
    let moved = gpu.render(&look, &FrameRequest::new(spec.clone()), &|_, _| {}).unwrap().image;
    let mut other = bundle.clone();
    other.mesh.scalar = flipped;
    let scene = tet_render::Scene::from_bundle(&other).unwrap();
    let mut fresh = tet_engine::GpuFrameRenderer::new(&other, scene, Default::default()).unwrap();
    let want = fresh.render(&look, &FrameRequest::new(spec), &|_, _| {}).unwrap().image;
    same_bits(&moved, &want, "GPU after set_scalar");
    assert_ne!(moved.pixels(), frames[1].pixels());
}

/// Hurricane Isabel's eye over four steps (tests/data/series/LICENSE.md)
/// as a time-series bundle built as `tetprep convert` builds it.
fn isabel_series(dir: &Path) -> PathBuf {
    let series = Path::new(DATA).join("../series");
    let read = |t: u32| tet_io::read_file(&series.join(format!("isabel_eye_0{t}.vti")), &Default::default()).unwrap();
    let first = read(2);
    let (mesh, report) = tet_mesh::tetrahedralize(&first, &Default::default(), &mut |_| {}).unwrap();
    let mapper = tet_mesh::StepMapper::new(&first, &mesh, &report).unwrap();
    let scalars: Vec<Vec<f64>> = (2..6).map(|t| mapper.scalar(&read(t), &mesh).unwrap()).collect();
    let steps = tet_bundle::TimeSteps::new(vec![2.0, 3.0, 4.0, 5.0], scalars, (2..6).map(|t| format!("{t}")).collect())
        .unwrap();
    let adjacency = tet_mesh::build_adjacency(&mesh.points, &mesh.tets).unwrap();
    let bundle = Bundle::new(mesh, adjacency, BundleMeta::default()).with_steps(steps).unwrap();
    let path = dir.join("isabel.tetb");
    bundle.write(&path).unwrap();
    path
}

/// `render --time T` draws the scalar interpolated at T over the series'
/// range: the library's `Bundle::set_time` and the engine give the same
/// bits; a time between steps differs from both steps; a time outside the
/// steps or on a bundle without steps is a usage error.
#[test]
fn time_series_frames_are_the_scalar_at_that_time() {
    let dir = tempfile::tempdir().unwrap();
    let (b, t) = (isabel_series(dir.path()), peaks_tf(dir.path()));
    let (bs, ts) = (path_arg(&b), path_arg(&t));
    let mut images = vec![];
    for time in ["3", "3.25", "4"] {
        let (npy, view, png) =
            (dir.path().join(format!("{time}.npy")), dir.path().join("v.json"), dir.path().join("x.png"));
        let mut args = vec!["render", bs, "--tf", ts, "--time", time, "--size", "80x64", "--elevation", "50"];
        args.extend(["-o", path_arg(&png), "--float", path_arg(&npy), "--save-view", path_arg(&view)]);
        tetview(&args);
        let mut bundle = Bundle::read(&b).unwrap();
        bundle.set_time(time.parse().unwrap()).unwrap();
        let tf =
            resolve_tf(&bundle, &TfRequest { source: TfSource::File(t.clone()), ..TfRequest::default() }).unwrap().tf;
        let look = Look::bake(&bundle, Method::Table3d, tf).unwrap();
        let spec = ViewSpec::from_json(&std::fs::read_to_string(&view).unwrap()).unwrap();
        let frame =
            CpuFrameRenderer::new(&bundle).unwrap().render(&look, &FrameRequest::new(spec), &|_, _| {}).unwrap();
        let cli = Image::read_npy(&npy).unwrap();
        same_bits(&cli, &frame.image, &format!("render --time {time}"));
        images.push(cli);
    }
    assert_ne!(images[1].pixels(), images[0].pixels());
    assert_ne!(images[1].pixels(), images[2].pixels());
    // Without --time a series draws its first step with the series' TF
    // range: the same bits as --time at the first step.
    let (first, plain) = (dir.path().join("first.npy"), dir.path().join("plain.npy"));
    for (npy, time) in [(&first, Some("2")), (&plain, None)] {
        let png = dir.path().join("y.png");
        let mut args = vec!["render", bs, "--tf", ts, "--size", "40x32", "-o", path_arg(&png)];
        args.extend(["--float", path_arg(npy)]);
        if let Some(t) = time {
            args.extend(["--time", t]);
        }
        tetview(&args);
    }
    same_bits(&Image::read_npy(&first).unwrap(), &Image::read_npy(&plain).unwrap(), "--time 2 against no --time");

    let png = dir.path().join("x.png");
    for (bundle, time, want) in [(bs, "9", "outside the bundle's steps, 2 to 5"), (bs, "-1", "outside")] {
        let out = Command::new(env!("CARGO_BIN_EXE_tetview"))
            .args(["render", bundle, "--tf", ts, "--time", time, "-o", path_arg(&png)])
            .output()
            .unwrap();
        let err = String::from_utf8_lossy(&out.stderr);
        assert_eq!(out.status.code(), Some(2), "{err}");
        assert!(err.contains(want), "{err}");
    }
    let plain = bluntfin(dir.path());
    let out = Command::new(env!("CARGO_BIN_EXE_tetview"))
        .args(["reference", path_arg(&plain), "--time", "1", "-o", path_arg(&png)])
        .output()
        .unwrap();
    assert_eq!(out.status.code(), Some(2));
    assert!(String::from_utf8_lossy(&out.stderr).contains("no time steps"));
}

/// Decoded 8-bit RGBA of a PNG, and the APNG frame count when animated.
fn png_pixels(path: &Path) -> (Vec<u8>, Option<u32>) {
    let decoder = png::Decoder::new(std::fs::File::open(path).unwrap());
    let mut reader = decoder.read_info().unwrap();
    let frames = reader.info().animation_control().map(|a| a.num_frames);
    let mut buf = vec![0; reader.output_buffer_size()];
    let info = reader.next_frame(&mut buf).unwrap();
    buf.truncate(info.buffer_size());
    (buf, frames)
}

/// `animate` on a time series: one frame a step by default, an APNG and
/// numbered frames; without a fitted tone map each frame is the picture
/// `render --time` draws at its time, pixel for pixel; one table is baked
/// for all frames. An orbit of a plain bundle loops; bad ranges and counts
/// are usage errors.
#[test]
fn animate_draws_each_time_as_render_does() {
    let dir = tempfile::tempdir().unwrap();
    let (b, t) = (isabel_series(dir.path()), peaks_tf(dir.path()));
    let (bs, ts) = (path_arg(&b), path_arg(&t));
    let (apng, frames) = (dir.path().join("a.png"), dir.path().join("frames"));
    let common = ["--tf", ts, "--size", "64x48", "--elevation", "50", "--tonemap", "none"];
    let out = Command::new(env!("CARGO_BIN_EXE_tetview"))
        .args(["animate", bs, "-o", path_arg(&apng), "--frames-dir", path_arg(&frames), "--json"])
        .args(common)
        .output()
        .unwrap();
    assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
    let v: serde_json::Value = serde_json::from_slice(&out.stdout).unwrap();
    assert_eq!((v["frames"].as_u64(), v["tables_baked"].as_u64()), (Some(4), Some(1)), "{v}");
    assert_eq!(v["time_range"], serde_json::json!([2.0, 5.0]));
    let (first, count) = png_pixels(&apng);
    assert_eq!(count, Some(4));
    assert_eq!(first, png_pixels(&frames.join("frame_0000.png")).0);
    for (i, time) in ["2", "3", "4", "5"].iter().enumerate() {
        let png = dir.path().join(format!("r{time}.png"));
        let mut args = vec!["render", bs, "--time", time, "-o", path_arg(&png)];
        args.extend(common);
        tetview(&args);
        assert_eq!(
            png_pixels(&frames.join(format!("frame_{i:04}.png"))).0,
            png_pixels(&png).0,
            "frame {i} against render --time {time}"
        );
    }

    // An orbit of a bundle without steps (default 360°, 36 frames asked down to 6).
    let bf = bluntfin(dir.path());
    let orbit = dir.path().join("o.png");
    tetview(&["animate", path_arg(&bf), "--tf", ts, "--frames", "6", "--size", "48x40", "-o", path_arg(&orbit)]);
    assert_eq!(png_pixels(&orbit).1, Some(6));

    for (bundle, extra, want) in [
        (path_arg(&bf), vec!["--time-range", "0,1"], "no time steps"),
        (bs, vec!["--time-range", "1,3"], "outside the bundle's steps"),
        (bs, vec!["--frames", "0"], "--frames 0"),
        (bs, vec!["--fps", "0"], "--fps 0"),
    ] {
        assert_animate_refused(bundle, ts, path_arg(&orbit), &extra, want);
    }
}

/// The frames of a GIF, decoded to RGBA8, and their delays (hundredths of a second).
fn gif_frames(path: &Path) -> Vec<(Vec<u8>, u16)> {
    let mut opts = gif::DecodeOptions::new();
    opts.set_color_output(gif::ColorOutput::RGBA);
    let mut d = opts.read_info(std::fs::File::open(path).unwrap()).unwrap();
    let mut out = vec![];
    while let Some(f) = d.read_next_frame().unwrap() {
        out.push((f.buffer.to_vec(), f.delay));
    }
    out
}

/// `animate --key-views`: the camera passes through every key (the first and
/// last frames are `render --view` of the first and last key, pixel for
/// pixel), frames between move smoothly; GIF output holds every frame at
/// the asked rate; keys that disagree, an unknown extension and a key path
/// with an orbit are usage errors.
#[test]
fn animate_moves_through_key_views_into_a_gif() {
    let dir = tempfile::tempdir().unwrap();
    let (bf, tf) = (bluntfin(dir.path()), peaks_tf(dir.path()));
    let (bs, ts) = (bf.to_str().unwrap(), tf.to_str().unwrap());
    let meta = Bundle::read(&bf).unwrap().meta;
    let framing = ViewSpec::framing(meta.stats.bounds_min, meta.stats.bounds_max, [48, 40]);
    let keys: Vec<PathBuf> = [(30.0, 10.0, 1.0), (120.0, 40.0, 1.6), (200.0, -20.0, 0.8)]
        .iter()
        .enumerate()
        .map(|(k, &(azimuth, elevation, zoom))| {
            let p = dir.path().join(format!("key{k}.json"));
            std::fs::write(&p, framing.orbit(azimuth, elevation, zoom).to_json()).unwrap();
            p
        })
        .collect();
    let key_list = keys.iter().map(|p| p.to_str().unwrap()).collect::<Vec<_>>().join(",");
    let (gif_path, frames) = (dir.path().join("path.gif"), dir.path().join("frames"));
    let out = Command::new(env!("CARGO_BIN_EXE_tetview"))
        .args(["animate", bs, "--tf", ts, "--key-views", &key_list, "--frames", "5", "--fps", "20"])
        .args(["--tonemap", "none", "--json", "-o", gif_path.to_str().unwrap(), "--frames-dir"])
        .arg(&frames)
        .output()
        .unwrap();
    assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
    let v: serde_json::Value = serde_json::from_slice(&out.stdout).unwrap();
    assert_eq!((v["frames"].as_u64(), v["key_views"].as_u64()), (Some(5), Some(3)), "{v}");
    assert_eq!(v["container"], "gif");
    let gif = gif_frames(&gif_path);
    assert_eq!(gif.len(), 5);
    assert!(gif.iter().all(|(px, delay)| px.len() == 48 * 40 * 4 && *delay == 5));
    // Frames 0, 2 and 4 are the keys.
    for (frame, key) in [(0, 0), (2, 1), (4, 2)] {
        let png = dir.path().join(format!("key{key}.png"));
        tetview(
            &["render", bs, "--tf", ts, "--tonemap", "none", "--view", keys[key].to_str().unwrap()]
                .into_iter()
                .chain(["-o", png.to_str().unwrap()])
                .collect::<Vec<_>>(),
        );
        let got = png_pixels(&frames.join(format!("frame_{frame:04}.png"))).0;
        assert_eq!(got, png_pixels(&png).0, "frame {frame} against render --view key {key}");
        // The GIF's 256 colours stay close to the frame's own.
        let worst = gif[frame].0.iter().zip(&got).map(|(a, b)| a.abs_diff(*b)).max().unwrap();
        assert!(worst <= 48, "frame {frame}: GIF colour off by {worst}");
    }
    // Frames between keys are neither key.
    assert_ne!(png_pixels(&frames.join("frame_0001.png")).0, png_pixels(&frames.join("frame_0000.png")).0);

    let mut parallel: ViewSpec = ViewSpec::from_json(&std::fs::read_to_string(&keys[1]).unwrap()).unwrap();
    parallel.parallel = true;
    let pk = dir.path().join("parallel.json");
    std::fs::write(&pk, parallel.to_json()).unwrap();
    let mixed = format!("{},{}", keys[0].display(), pk.display());
    for (extra, out_name, want) in [
        (vec!["--key-views", mixed.as_str()], "m.gif", "key view 1 is parallel"),
        (vec!["--key-views", key_list.as_str()], "m.bmp", "the extension says what to write"),
        (vec!["--key-views", key_list.as_str(), "--orbit", "90"], "m.gif", "cannot be used with"),
    ] {
        let o = dir.path().join(out_name);
        assert_animate_refused(bs, ts, o.to_str().unwrap(), &extra, want);
        assert!(!o.exists());
    }
}

/// A video output goes through ffmpeg: raw RGBA frames on its input, the
/// file renamed into place when it succeeds; no ffmpeg, or one that fails,
/// is an output error (exit 5) naming the way out, and leaves no file.
/// A stand-in ffmpeg (a shell script counting the bytes it is given) checks
/// our side everywhere; a real one, where installed, encodes a playable file.
#[cfg(unix)]
#[test]
fn animate_encodes_video_through_ffmpeg_or_says_why_not() {
    use std::os::unix::fs::PermissionsExt;
    let dir = tempfile::tempdir().unwrap();
    let (bf, tf) = (bluntfin(dir.path()), peaks_tf(dir.path()));
    let (bs, ts) = (bf.to_str().unwrap(), tf.to_str().unwrap());
    let script = |name: &str, body: &str| {
        let p = dir.path().join(name);
        std::fs::write(&p, format!("#!/bin/sh\nif [ \"$1\" = -version ]; then exit 0; fi\n{body}\n")).unwrap();
        std::fs::set_permissions(&p, std::fs::Permissions::from_mode(0o755)).unwrap();
        p
    };
    // The last argument is the file to write.
    let counting = script("ffmpeg-count", r#"for a; do out="$a"; done; wc -c | tr -d ' ' > "$out""#);
    let failing = script("ffmpeg-fail", "cat > /dev/null; echo 'Unknown encoder' >&2; exit 1");
    let videos = dir.path().join("videos");
    std::fs::create_dir(&videos).unwrap();
    let run = |ffmpeg: &str, out_name: &str| {
        let o = videos.join(out_name);
        let out = Command::new(env!("CARGO_BIN_EXE_tetview"))
            .args(["animate", bs, "--tf", ts, "--frames", "3", "--size", "33x20", "--ffmpeg", ffmpeg])
            .args(["-o", o.to_str().unwrap()])
            .output()
            .unwrap();
        (o, out)
    };
    let (o, out) = run(counting.to_str().unwrap(), "orbit.mp4");
    assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
    assert_eq!(std::fs::read_to_string(&o).unwrap().trim(), (33 * 20 * 4 * 3).to_string());
    // An ordinary output's mode, not the temporary file's 0600.
    let probe = dir.path().join("probe");
    std::fs::File::create(&probe).unwrap();
    let mode = |p: &Path| std::fs::metadata(p).unwrap().permissions().mode() & 0o777;
    assert_eq!(mode(&o), mode(&probe));

    for (ffmpeg, name, want) in [
        (dir.path().join("no-such-ffmpeg"), "a.webm", "install ffmpeg, point --ffmpeg at it"),
        (failing, "b.mp4", "Unknown encoder"),
    ] {
        let (o, out) = run(ffmpeg.to_str().unwrap(), name);
        let err = String::from_utf8_lossy(&out.stderr);
        assert_eq!(out.status.code(), Some(5), "{err}");
        assert!(err.contains(want), "{err}");
        assert!(!o.exists());
    }
    let left: Vec<_> = std::fs::read_dir(&videos).unwrap().map(|e| e.unwrap().file_name()).collect();
    assert_eq!(left, [std::ffi::OsString::from("orbit.mp4")], "temporary files left behind");

    if Command::new("ffmpeg").arg("-version").output().is_ok_and(|o| o.status.success()) {
        let (o, out) = run("ffmpeg", "real.mp4");
        assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
        let bytes = std::fs::read(&o).unwrap();
        assert_eq!(&bytes[4..8], b"ftyp", "an MP4 starts with its ftyp box");
    } else {
        eprintln!("note: no ffmpeg on PATH; the video path was checked with a stand-in only");
    }
}

/// `tetview animate BUNDLE --tf TF -o OUT EXTRA…` is a usage error (exit 2)
/// whose message holds `want`.
fn assert_animate_refused(bundle: &str, tf: &str, out: &str, extra: &[&str], want: &str) {
    let run = Command::new(env!("CARGO_BIN_EXE_tetview"))
        .args(["animate", bundle, "--tf", tf, "-o", out])
        .args(extra)
        .output()
        .unwrap();
    let err = String::from_utf8_lossy(&run.stderr);
    assert_eq!(run.status.code(), Some(2), "{extra:?}: {err}");
    assert!(err.contains(want), "{extra:?}: {err}");
}
