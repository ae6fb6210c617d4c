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

/// Runs a scripted view and checks its screenshot; `extra` adds flags.
fn scripted_view(x: &Xvfb, method: &str, extra: &[&str]) {
    let dir = tempfile::tempdir().unwrap();
    let shot = dir.path().join("shot.png");
    let bundle = samples().join("cube5.tetb");
    let tf = samples().join("tf_normalized.json");
    let out = Command::new(env!("CARGO_BIN_EXE_tetview"))
        .args(["view", bundle.to_str().unwrap(), "--tf", tf.to_str().unwrap(), "--method", method])
        .args(["--window", "760x480", "--frames", "3", "--spin", "25", "--screenshot", shot.to_str().unwrap()])
        .args(extra)
        .env("DISPLAY", &x.display)
        .env_remove("WAYLAND_DISPLAY")
        .output()
        .unwrap();
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

#[test]
fn view_renders_frames_and_saves_a_window_screenshot() {
    if Command::new("Xvfb").arg("-help").stderr(Stdio::null()).stdout(Stdio::null()).status().is_err() {
        println!("skipped: Xvfb is not installed (make test installs it: apt-get install xvfb)");
        return;
    }
    let Some(x) = Xvfb::start() else {
        println!("skipped: Xvfb did not start");
        return;
    };
    // CPU renderer with a baked table; tet_gpu where an adapter exists (the
    // engine falls back to the CPU otherwise); the default choice.
    scripted_view(&x, "table3d", &["--cpu"]);
    scripted_view(&x, "pt-linear", &["--gpu"]);
    scripted_view(&x, "exact", &[]);
}
