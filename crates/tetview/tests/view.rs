//! `tetview view` under Xvfb: a scripted run renders a few frames (orbiting
//! between them), saves a screenshot of the window and exits; the screenshot
//! must show something. Skips with a printed reason where Xvfb is missing
//! (`make test` installs it).
use std::io::{BufRead, BufReader};
use std::path::{Path, PathBuf};
use std::process::{Child, Command, Stdio};

/// An Xvfb server on a display it picked itself (`-displayfd`), killed on drop.
struct Xvfb {
    child: Child,
    display: String,
}

impl Xvfb {
    fn start() -> Option<Xvfb> {
        let mut child = Command::new("Xvfb")
            .args(["-displayfd", "1", "-screen", "0", "800x600x24", "-nolisten", "tcp"])
            .stdout(Stdio::piped())
            .stderr(Stdio::null())
            .spawn()
            .ok()?;
        let mut line = String::new();
        BufReader::new(child.stdout.take()?).read_line(&mut line).ok()?;
        let n: u32 = line.trim().parse().ok()?;
        Some(Xvfb { child, display: format!(":{n}") })
    }
}

impl Drop for Xvfb {
    fn drop(&mut self) {
        let _ = self.child.kill();
        let _ = self.child.wait();
    }
}

fn samples() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("../../formats/samples")
}

/// `tetview view …` on the Xvfb display, with a private XDG_RUNTIME_DIR:
/// without one, libraries probing for Wayland print "XDG_RUNTIME_DIR is
/// invalid or not set" on every start.
fn tetview_on(x: &Xvfb, runtime_dir: &Path) -> Command {
    let mut c = Command::new(env!("CARGO_BIN_EXE_tetview"));
    c.arg("view").env("DISPLAY", &x.display).env_remove("WAYLAND_DISPLAY").env("XDG_RUNTIME_DIR", runtime_dir);
    c
}

/// Runs a scripted view and checks its screenshot; `extra` adds flags.
fn scripted_view(x: &Xvfb, method: &str, extra: &[&str]) {
    let dir = tempfile::tempdir().unwrap();
    let shot = dir.path().join("shot.png");
    let bundle = samples().join("cube5.tetb");
    let tf = samples().join("tf_normalized.json");
    let out = tetview_on(x, dir.path())
        .args([bundle.to_str().unwrap(), "--tf", tf.to_str().unwrap(), "--method", method])
        .args(["--window", "760x480", "--frames", "3", "--spin", "25", "--screenshot", shot.to_str().unwrap()])
        .args(extra)
        .output()
        .unwrap();
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert!(!stderr.contains("XDG_RUNTIME_DIR"), "{stderr}");
    assert!(
        out.status.success(),
        "tetview view {method} {extra:?}: {:?}\nstderr: {}",
        out.status,
        String::from_utf8_lossy(&out.stderr)
    );
    let decoder = png::Decoder::new(std::io::BufReader::new(std::fs::File::open(&shot).unwrap()));
    let mut reader = decoder.read_info().unwrap();
    let mut buf = vec![0; reader.output_buffer_size()];
    let info = reader.next_frame(&mut buf).unwrap();
    assert!(info.width >= 200 && info.height >= 150, "{}x{}", info.width, info.height);
    let px = &buf[..info.buffer_size()];
    let step = info.color_type.samples();
    let first = &px[..step];
    let distinct = px.chunks(step).filter(|p| *p != first).count();
    assert!(distinct > px.len() / step / 20, "screenshot is (nearly) one colour: {distinct} pixels differ");
    // The volume itself is drawn: the image area (right of the control panel, above the
    // status line) has bright pixels over the black background.
    let (w, h) = (info.width as usize, info.height as usize);
    let mut bright = 0;
    let mut area = 0;
    for y in h / 10..h * 8 / 10 {
        for x in w * 6 / 10..w * 95 / 100 {
            let p = &px[(y * w + x) * step..][..3];
            area += 1;
            if p.iter().any(|&c| c > 100) {
                bright += 1;
            }
        }
    }
    assert!(bright > area / 10, "the image area is (nearly) empty: {bright} of {area} pixels bright");
}

/// The Xvfb server, or `None` after printing why the test skips.
fn xvfb_or_skip() -> Option<Xvfb> {
    if Command::new("Xvfb").arg("-help").stderr(Stdio::null()).stdout(Stdio::null()).status().is_err() {
        println!("skipped: Xvfb is not installed (make test installs it: apt-get install xvfb)");
        return None;
    }
    let x = Xvfb::start();
    if x.is_none() {
        println!("skipped: Xvfb did not start");
    }
    x
}

/// Regression: `--frames N --screenshot` without `--spin` never exited (the
/// event loop slept once the image stopped changing; `--frames 2` happened
/// to get by on egui's own extra repaints). Every variant must exit with its
/// screenshot within a minute; they run side by side, and a run past the
/// minute is killed and fails the test.
#[test]
fn every_scripted_run_exits() {
    let Some(x) = xvfb_or_skip() else { return };
    let dir = tempfile::tempdir().unwrap();
    let bundle = samples().join("cube5.tetb");
    let variants: Vec<(usize, Option<&str>, bool)> = vec![
        (2, None, false),
        (5, None, false),
        (10, None, false),
        (5, Some("25"), false),
        (10, Some("10"), false),
        (5, None, true),
        (5, Some("25"), true),
    ];
    let spawn = |i: usize| {
        let (frames, spin, cpu) = variants[i];
        let shot = dir.path().join(format!("shot{i}.png"));
        // Each run's stderr goes to a file, quoted when the run fails.
        let err = std::fs::File::create(dir.path().join(format!("stderr{i}.txt"))).unwrap();
        let mut c = tetview_on(&x, dir.path());
        c.args([bundle.to_str().unwrap(), "--window", "320x240", "--frames", &frames.to_string()])
            .args(["--screenshot", shot.to_str().unwrap()])
            .stdout(Stdio::null())
            .stderr(err);
        if let Some(deg) = spin {
            c.args(["--spin", deg]);
        }
        if cpu {
            c.arg("--cpu");
        }
        (format!("--frames {frames} spin {spin:?} cpu {cpu}"), c.spawn().unwrap(), shot)
    };
    let mut runs: Vec<_> = (0..variants.len()).map(|i| (spawn(i), i, 0)).collect();
    let deadline = std::time::Instant::now() + std::time::Duration::from_secs(60);
    let mut failures = Vec::new();
    while let Some(((what, mut child, shot), i, retries)) = runs.pop() {
        let stderr = || std::fs::read_to_string(dir.path().join(format!("stderr{i}.txt"))).unwrap_or_default();
        let status = loop {
            if let Some(status) = child.try_wait().unwrap() {
                break Some(status);
            }
            if std::time::Instant::now() > deadline {
                let _ = child.kill();
                let _ = child.wait();
                break None;
            }
            std::thread::sleep(std::time::Duration::from_millis(50));
        };
        match status {
            Some(s) if s.success() && shot.exists() => {}
            // Under a loaded CI host one of the seven clients connecting at
            // once was refused by the X server before drawing anything
            // (winit's "Failed to open connection to X server"): that is the
            // test's display, not the viewer, so the run starts again (twice
            // at most). A run that hangs is never retried.
            Some(_) if retries < 2 && stderr().contains("Failed to open connection to X server") => {
                println!("{what}: the X server refused the connection; starting it again");
                runs.push((spawn(i), i, retries + 1));
            }
            Some(s) => {
                failures.push(format!("{what}: {s}, screenshot written: {}; stderr: {}", shot.exists(), stderr()))
            }
            None => failures.push(format!("{what}: still running after 60 s (killed); stderr: {}", stderr())),
        }
    }
    assert!(failures.is_empty(), "{failures:#?}");
}

#[test]
fn view_renders_frames_and_saves_a_window_screenshot() {
    let Some(x) = xvfb_or_skip() else { return };
    // CPU renderer with a baked table; tet_gpu where an adapter exists (the
    // engine falls back to the CPU otherwise); the default choice.
    scripted_view(&x, "table3d", &["--cpu"]);
    scripted_view(&x, "pt-linear", &["--gpu"]);
    scripted_view(&x, "exact", &[]);
}

/// `--colormap` reaches the window as it reaches `tetview render`: with
/// `grayscale` the volume in the screenshot's image area is grey (R = G = B
/// within rounding), where the file's own colours (blue, white, red) are not.
#[test]
fn view_colormap_recolours_the_volume() {
    let Some(x) = xvfb_or_skip() else { return };
    let dir = tempfile::tempdir().unwrap();
    let bundle = samples().join("cube5.tetb");
    let tf = samples().join("tf_normalized.json");
    // The share of bright image-area pixels whose channels differ by more than 24.
    let coloured_share = |extra: &[&str], name: &str| -> f64 {
        let shot = dir.path().join(name);
        let out = tetview_on(&x, dir.path())
            .args([bundle.to_str().unwrap(), "--tf", tf.to_str().unwrap(), "--method", "pt-linear", "--cpu"])
            .args(["--window", "760x480", "--frames", "2", "--screenshot", shot.to_str().unwrap()])
            .args(extra)
            .output()
            .unwrap();
        assert!(out.status.success(), "{extra:?}: {}", String::from_utf8_lossy(&out.stderr));
        let decoder = png::Decoder::new(std::io::BufReader::new(std::fs::File::open(&shot).unwrap()));
        let mut reader = decoder.read_info().unwrap();
        let mut buf = vec![0; reader.output_buffer_size()];
        let info = reader.next_frame(&mut buf).unwrap();
        let (w, h, step) = (info.width as usize, info.height as usize, info.color_type.samples());
        let (mut bright, mut coloured) = (0usize, 0usize);
        for y in h / 10..h * 8 / 10 {
            for x in w * 6 / 10..w * 95 / 100 {
                let p = &buf[(y * w + x) * step..][..3];
                if p.iter().any(|&c| c > 60) {
                    bright += 1;
                    if p.iter().max().unwrap() - p.iter().min().unwrap() > 24 {
                        coloured += 1;
                    }
                }
            }
        }
        assert!(bright > 100, "{extra:?}: the image area is (nearly) empty");
        coloured as f64 / bright as f64
    };
    let own = coloured_share(&[], "own.png");
    let grey = coloured_share(&["--colormap", "grayscale"], "grey.png");
    eprintln!("coloured share of the volume: own colours {own:.3}, grayscale {grey:.3}");
    assert!(own > 0.2, "the file's colours: {own}");
    assert!(grey < 0.05, "--colormap grayscale: {grey} of the volume is coloured");
}

/// `tetview view` with no display: the failures before the window opens.
fn view_without_display(args: &[&str]) -> std::process::Output {
    Command::new(env!("CARGO_BIN_EXE_tetview"))
        .arg("view")
        .args(args)
        .arg("--cpu")
        .env_remove("DISPLAY")
        .env_remove("WAYLAND_DISPLAY")
        .output()
        .unwrap()
}

/// The viewer reads `--tf` with the loader `render` and `tetlut` use: the
/// same exit code and first line (the table of tests/cli.rs, in part).
#[test]
fn view_refuses_bad_tf_files_as_render_does() {
    let data = Path::new(env!("CARGO_MANIFEST_DIR")).join("../tet_preint/tests/data/tf");
    let bundle = samples().join("cube5.tetb");
    let bad = data.join("bad_unsorted.json");
    let absent = data.join("absent.json");
    let cases = [
        (
            &bad,
            2,
            format!(
                "opacity[1]: x = 0.2 is below the previous control point's 0.5 (points must increase): {}",
                bad.display()
            ),
        ),
        (
            &absent,
            3,
            format!("cannot read transfer function: {}: {}", std::fs::read(&absent).unwrap_err(), absent.display()),
        ),
    ];
    for (tf, code, line) in cases {
        let out = view_without_display(&[bundle.to_str().unwrap(), "--tf", tf.to_str().unwrap()]);
        let err = String::from_utf8_lossy(&out.stderr).into_owned();
        assert_eq!(out.status.code(), Some(code), "{err}");
        assert_eq!(err.lines().next(), Some(format!("tetview: {line}").as_str()));
    }
}

/// A constant scalar has no automatic TF, in the viewer as in `render`:
/// exit 4 (input data rejected) with tet_preint's one message.
#[test]
fn view_of_a_constant_scalar_without_tf_is_rejected_as_render_is() {
    use tet_mesh::{build_adjacency, mesh_stats, TetMesh};
    let dir = tempfile::tempdir().unwrap();
    let points = vec![[0., 0., 0.], [1., 0., 0.], [0., 1., 0.], [0., 0., 1.]];
    let tets = vec![[0, 1, 2, 3]];
    let scalar = vec![0.75; 4];
    let stats = mesh_stats(&points, &tets, &scalar);
    let mesh = TetMesh { points, tets: tets.into(), scalar_name: "s".into(), scalar, point_fields: vec![] };
    let adjacency = build_adjacency(&mesh.points, &mesh.tets).unwrap();
    let path = dir.path().join("flat.tetb");
    tet_bundle::Bundle::new(mesh, adjacency, tet_bundle::BundleMeta { stats, ..Default::default() })
        .write(&path)
        .unwrap();
    let out = view_without_display(&[path.to_str().unwrap()]);
    let err = String::from_utf8_lossy(&out.stderr).into_owned();
    assert_eq!(out.status.code(), Some(4), "{err}");
    assert!(err.contains("the scalar is constant (0.75)") && err.contains("give --tf"), "{err}");
}

/// A time-series bundle in the window: a scripted run that moves the time
/// slider every frame exits with its screenshot; a start time outside the
/// steps is refused before a window opens.
#[test]
fn a_time_series_window_steps_through_time() {
    let Some(x) = xvfb_or_skip() else { return };
    let dir = tempfile::tempdir().unwrap();
    let bundle = tet_bundle::Bundle::read(&samples().join("cube5.tetb")).unwrap();
    let n = bundle.mesh.points.len();
    let scalars: Vec<Vec<f64>> =
        (0..3).map(|k| (0..n).map(|i| ((i * 5 + k) % 7) as f64 * 0.5 + k as f64).collect()).collect();
    let steps = tet_bundle::TimeSteps::new(vec![0.0, 1.0, 2.0], scalars, vec![String::new(); 3]).unwrap();
    let series = dir.path().join("series.tetb");
    bundle.with_steps(steps).unwrap().write(&series).unwrap();
    let shot = dir.path().join("shot.png");
    let out = tetview_on(&x, dir.path())
        .args([series.to_str().unwrap(), "--window", "640x420", "--frames", "4", "--time", "0.25"])
        .args(["--time-step", "0.5", "--screenshot", shot.to_str().unwrap()])
        .output()
        .unwrap();
    assert!(out.status.success(), "{:?}: {}", out.status, String::from_utf8_lossy(&out.stderr));
    assert!(shot.exists());
    let out = tetview_on(&x, dir.path())
        .args([series.to_str().unwrap(), "--time", "9", "--frames", "1", "--screenshot", shot.to_str().unwrap()])
        .output()
        .unwrap();
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(!out.status.success() && err.contains("outside the bundle's steps, 0 to 2"), "{err}");
}
