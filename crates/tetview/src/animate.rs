//! `tetview animate`: a camera orbit or a path through key views, and/or a
//! time series, as an animated PNG or GIF, or a video through `ffmpeg`
//! (and numbered PNG frames), drawn by the engine.
//!
//! One look serves every frame: a time-series bundle's table is baked over
//! the scalar's domain at every time (`TableDomain::from_bundle`), so time
//! moves only the scalar ([`CpuFrameRenderer::set_scalar`]: the walker keeps
//! its per-scene links, the GPU its uploaded mesh) and the camera only the
//! view. Reinhard's operator is fitted once to every frame together, so the
//! exposure does not flicker.

use anyhow::{anyhow, Context, Result};
use std::io::{Read, Write};
use std::path::{Path, PathBuf};
use std::process::{Command, Stdio};
use std::time::Instant;
use tet_cli::{usage, ExitKind, KindExt};
use tet_engine::{
    CpuFrameRenderer, EngineError, Frame, FrameRenderer, FrameRequest, FrameStats, GpuFrameOptions, GpuFrameRenderer,
    Look,
};
use tet_render::image::{write_apng_rgba8, write_gif_rgba8, Reinhard};
use tet_render::{Image, KeyPath, Scene, ToneMap, ViewSpec};

/// Render an orbit or a key-view path and/or a time series to an animated
/// PNG or GIF, or a video (through ffmpeg).
#[derive(Debug, clap::Args)]
pub struct AnimateArgs {
    /// The bundle (.tetb); a time-series bundle (`tetprep convert` of a
    /// .pvd, .series or --all-steps input) animates its steps.
    pub bundle: PathBuf,
    /// What the frames are drawn with (as `render`); the tables are baked
    /// once for every frame.
    #[command(flatten)]
    pub look: crate::look_args::LookArgs,
    #[command(flatten)]
    pub camera: crate::camera_args::CameraArgs,
    #[command(flatten)]
    pub display: crate::camera_args::DisplayArgs,
    /// Degrees of azimuth the camera turns over the animation, from the
    /// view the camera flags give (360: one orbit that loops seamlessly).
    /// Default: 360 for a bundle without time steps, 0 for a time series.
    #[arg(long, allow_hyphen_values = true)]
    pub orbit: Option<f64>,
    /// Key views instead of an orbit: view JSON files (as `render --view`),
    /// comma-separated; the camera moves through them in turn, equal time
    /// between each two (focal point on a line, eye turning about it,
    /// distance and zoom changing geometrically). --size resizes them all.
    #[arg(
        long,
        value_delimiter = ',',
        conflicts_with_all = ["orbit", "view", "azimuth", "elevation", "zoom", "view_up", "parallel"]
    )]
    pub key_views: Vec<PathBuf>,
    /// Times T0,T1 of the first and last frame (a time-series bundle;
    /// default: its first and last step), linear in between.
    #[arg(long, value_parser = tet_cli::parse_range, allow_hyphen_values = true)]
    pub time_range: Option<(f64, f64)>,
    /// Number of frames (default: one a time step for a time series, 36
    /// for an orbit, 12 between each two key views).
    #[arg(long)]
    pub frames: Option<u32>,
    /// Frames per second of the animation.
    #[arg(long, default_value_t = 12.0)]
    pub fps: f64,
    /// CPU algorithm (as `render --renderer`).
    #[arg(long, default_value = "walk")]
    pub renderer: tet_render::CpuRenderer,
    /// Render on the GPU (as `render --gpu`: GPU methods, no lighting).
    #[arg(long)]
    pub gpu: bool,
    /// Draw every tet (turn off culling of invisible cells).
    #[arg(long)]
    pub no_cull: bool,
    /// The animation, its kind by extension: .png or .apng (animated PNG,
    /// every colour kept; viewers without APNG show the first frame), .gif
    /// (256 colours a frame), or .mp4, .webm, .mkv, .mov (a video encoded
    /// by ffmpeg, which must be installed; see --ffmpeg).
    #[arg(short, long)]
    pub output: PathBuf,
    /// The ffmpeg program a video output is encoded with.
    #[arg(long, default_value = "ffmpeg")]
    pub ffmpeg: PathBuf,
    /// Also write every frame as DIR/frame_0000.png, … (DIR is created).
    #[arg(long)]
    pub frames_dir: Option<PathBuf>,
    /// Print statistics as JSON on stdout.
    #[arg(long)]
    pub json: bool,
}

/// Most bytes of linear frames kept for the sequence's tone-mapping fit.
const MAX_KEPT_BYTES: u64 = 8 << 30;

/// The CPU or GPU renderer of the animation.
enum Animator {
    Cpu(Box<CpuFrameRenderer>),
    Gpu(Box<GpuFrameRenderer>),
}

impl Animator {
    fn render(&mut self, look: &Look, req: &FrameRequest) -> Result<Frame, EngineError> {
        match self {
            Animator::Cpu(r) => r.render(look, req, &|_, _| {}),
            Animator::Gpu(r) => r.render(look, req, &|_, _| {}),
        }
    }
    /// A time's scalar, and its gradients where the bundle stores them (the
    /// CPU lights with them; the GPU draws unlit and needs none).
    fn set_scalar(&mut self, scalar: Vec<f64>, gradients: Option<Vec<[f64; 3]>>) -> Result<(), EngineError> {
        match self {
            Animator::Cpu(r) => r.set_scalar_with_gradients(scalar, gradients),
            Animator::Gpu(r) => r.set_scalar(scalar),
        }
    }
}

/// What `--output` is written as, by its extension.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum Container {
    Apng,
    Gif,
    /// A video container ffmpeg picks the encoder for.
    Video,
}

impl Container {
    fn of(path: &Path) -> Result<Container> {
        let ext = path.extension().and_then(|e| e.to_str()).map(str::to_ascii_lowercase);
        match ext.as_deref() {
            Some("png" | "apng") => Ok(Container::Apng),
            Some("gif") => Ok(Container::Gif),
            Some("mp4" | "webm" | "mkv" | "mov") => Ok(Container::Video),
            _ => Err(usage(format!(
                "-o {}: the extension says what to write: .png or .apng (animated PNG), .gif, \
                 or .mp4, .webm, .mkv, .mov (video through ffmpeg)",
                path.display()
            ))),
        }
    }
    fn id(self) -> &'static str {
        match self {
            Container::Apng => "apng",
            Container::Gif => "gif",
            Container::Video => "video",
        }
    }
}

/// Fails unless `ffmpeg` runs (`-version`), before any frame is drawn.
fn check_ffmpeg(ffmpeg: &Path, output: &Path) -> Result<()> {
    let status = Command::new(ffmpeg).arg("-version").stdout(Stdio::null()).stderr(Stdio::null()).status();
    match status {
        Ok(s) if s.success() => Ok(()),
        Ok(s) => {
            Err(anyhow!("`{} -version` failed ({s}): {} needs a working ffmpeg", ffmpeg.display(), output.display()))
                .kind(ExitKind::Output)
        }
        Err(e) => Err(anyhow!(
            "{} is a video, encoded by ffmpeg, and `{}` cannot be run ({e}): install ffmpeg, point --ffmpeg at it, \
             or write .png (animated PNG) or .gif",
            output.display(),
            ffmpeg.display()
        ))
        .kind(ExitKind::Output),
    }
}

/// Encodes RGBA8 frames into the video `output` with ffmpeg (raw frames on
/// its standard input; yuv420p, odd sizes padded by a pixel, so any player
/// shows it), through a temporary file beside it renamed into place: a
/// failed encode leaves no half-written video.
fn write_video(ffmpeg: &Path, output: &Path, size: [u32; 2], fps: f64, frames: &[Vec<u8>]) -> Result<()> {
    let dir = match output.parent() {
        Some(d) if !d.as_os_str().is_empty() => d,
        _ => Path::new("."),
    };
    // ffmpeg picks the container by the extension: the temporary file keeps it.
    let ext = output.extension().and_then(|e| e.to_str()).unwrap_or("mp4");
    let mut builder = tempfile::Builder::new();
    let suffix = format!(".{ext}");
    builder.prefix(".tetvid-").suffix(&suffix);
    // The video is an ordinary output: the mode `File::create` gives (as
    // every other tetkit output, tet_container::write_atomic), not the
    // temporary file's private 0600.
    #[cfg(unix)]
    {
        use std::os::unix::fs::PermissionsExt;
        builder.permissions(std::fs::Permissions::from_mode(0o666));
    }
    let tmp = builder
        .tempfile_in(dir)
        .with_context(|| format!("creating a temporary file beside {}", output.display()))
        .kind(ExitKind::Output)?;
    let mut child = Command::new(ffmpeg)
        .args(["-hide_banner", "-loglevel", "error", "-nostdin", "-y", "-f", "rawvideo", "-pix_fmt", "rgba"])
        .args(["-s", &format!("{}x{}", size[0], size[1]), "-framerate", &format!("{fps}"), "-i", "pipe:0"])
        .args(["-an", "-vf", "pad=ceil(iw/2)*2:ceil(ih/2)*2", "-pix_fmt", "yuv420p"])
        .arg(tmp.path())
        .stdin(Stdio::piped())
        .stdout(Stdio::null())
        .stderr(Stdio::piped())
        .spawn()
        .with_context(|| format!("starting {}", ffmpeg.display()))
        .kind(ExitKind::Output)?;
    // Its messages are read beside the frames, so a chatty ffmpeg cannot
    // block on a full pipe while we block on its input.
    let mut stderr = child.stderr.take().expect("piped");
    let messages = std::thread::spawn(move || {
        let mut text = String::new();
        let _ = stderr.read_to_string(&mut text);
        text
    });
    let mut stdin = child.stdin.take().expect("piped");
    let fed: std::io::Result<()> = frames.iter().try_for_each(|f| stdin.write_all(f));
    drop(stdin);
    let status = child.wait().with_context(|| format!("waiting for {}", ffmpeg.display())).kind(ExitKind::Output)?;
    let text = messages.join().unwrap_or_default();
    if !status.success() || fed.is_err() {
        let tail: Vec<&str> = text.lines().rev().take(6).collect::<Vec<_>>().into_iter().rev().collect();
        return Err(anyhow!(
            "ffmpeg could not encode {} ({status}{}): {}",
            output.display(),
            fed.err().map_or(String::new(), |e| format!(", frames not taken: {e}")),
            if tail.is_empty() { "no message".to_string() } else { tail.join(" / ") }
        ))
        .kind(ExitKind::Output);
    }
    tet_container::persist_temp(tmp.into_temp_path(), output)
        .with_context(|| format!("putting the encoded video in place as {}", output.display()))
        .kind(ExitKind::Output)?;
    Ok(())
}

/// Where frame `i` of `n` is: its azimuth offset and its time.
fn frame_at(i: u32, n: u32, orbit: f64, times: Option<(f64, f64)>) -> (f64, Option<f64>) {
    let azimuth = orbit * i as f64 / n as f64;
    // The last frame at t1 itself, whatever the rounding.
    let time = times.map(|(t0, t1)| if n > 1 { (t0 + (t1 - t0) * i as f64 / (n - 1) as f64).min(t1) } else { t0 });
    (azimuth, time)
}

pub fn run(args: &AnimateArgs) -> Result<()> {
    let start = Instant::now();
    let bundle = tet_bundle::Bundle::read(&args.bundle)?;
    crate::cli::warn_if_constant_scalar(&bundle);
    let steps = bundle.steps.clone();
    let times = match (&steps, args.time_range) {
        (None, Some((a, b))) => {
            return Err(usage(format!(
                "--time-range {a},{b}: {} has no time steps (convert a .pvd, .series or --all-steps input)",
                args.bundle.display()
            )))
        }
        (Some(st), range) => {
            let (first, last) = (st.times()[0], st.times()[st.len() - 1]);
            let (t0, t1) = range.unwrap_or((first, last));
            if t0 < first || t1 > last {
                return Err(usage(format!(
                    "--time-range {t0},{t1}: outside the bundle's steps, {first} to {last} ({})",
                    args.bundle.display()
                )));
            }
            Some((t0, t1))
        }
        (None, None) => None,
    };
    let container = Container::of(&args.output)?;
    let keyed = !args.key_views.is_empty();
    let orbit = args.orbit.unwrap_or(if times.is_some() || keyed { 0.0 } else { 360.0 });
    if !orbit.is_finite() {
        return Err(usage(format!("--orbit {orbit}: need a finite angle")));
    }
    let n = args.frames.unwrap_or(match &steps {
        Some(st) if args.time_range.is_none() => st.len() as u32,
        _ if keyed => 12 * (args.key_views.len() as u32 - 1).max(1),
        _ => 36,
    });
    if n == 0 || n > 100_000 {
        return Err(usage(format!("--frames {n}: need 1 to 100000")));
    }
    if !(args.fps.is_finite() && args.fps > 0.0) {
        return Err(usage(format!("--fps {}: need a positive rate", args.fps)));
    }
    if times.is_none() && orbit == 0.0 && args.key_views.len() < 2 && n > 1 {
        eprintln!("warning: no time steps, no orbit and no second key view: every frame is the same picture");
    }
    if container == Container::Video {
        check_ffmpeg(&args.ffmpeg, &args.output)?;
    }

    let chosen = args.look.resolve(&bundle)?;
    let method = chosen.method;
    let scene = Scene::from_bundle(&bundle).with_context(|| format!("in {}", args.bundle.display()))?;
    let path = if keyed { Some(key_path(&args.key_views, args.camera.size)?) } else { None };
    let base = match &path {
        Some(p) => p.at(0.0),
        None => args.camera.resolve(scene.bounds(), tet_render::camera::bundle_is_z_up(&bundle.meta))?,
    };
    let request = |view| FrameRequest { cpu: args.renderer, cull: !args.no_cull, ..FrameRequest::new(view) };
    if args.gpu {
        if let Err(why) = GpuFrameRenderer::supports(method, &request(base.clone())) {
            return Err(usage(format!("--gpu: {why}; run without --gpu to render on the CPU")));
        }
    }
    let display = args.display.display();
    let frame_bytes = base.size[0] as u64 * base.size[1] as u64 * 16;
    let keep_linear = display.tonemap != ToneMap::None;
    if keep_linear && frame_bytes * n as u64 > MAX_KEPT_BYTES {
        return Err(usage(format!(
            "{n} frames of {}x{} are {:.1} GiB of linear images for the animation's one tone-mapping fit \
             (at most {} GiB): fewer frames, a smaller --size, or --tonemap none (no fit, frames streamed)",
            base.size[0],
            base.size[1],
            (frame_bytes * n as u64) as f64 / (1u64 << 30) as f64,
            MAX_KEPT_BYTES >> 30
        )));
    }
    let mut animator = if args.gpu {
        let r =
            GpuFrameRenderer::new(&bundle, scene, GpuFrameOptions::default()).map_err(crate::gpu::on_cpu_instead)?;
        Animator::Gpu(Box::new(r))
    } else {
        Animator::Cpu(Box::new(CpuFrameRenderer::from_scene(scene)))
    };
    let look = chosen.look(&bundle)?;
    if let Some(dir) = &args.frames_dir {
        std::fs::create_dir_all(dir).with_context(|| format!("creating {}", dir.display())).kind(ExitKind::Output)?;
    }

    let bar = if args.json { indicatif::ProgressBar::hidden() } else { indicatif::ProgressBar::new(n as u64) };
    bar.set_style(
        indicatif::ProgressStyle::with_template("{msg} [{bar:30}] {pos}/{len} frames ({eta} left)")
            .expect("static template")
            .progress_chars("=> "),
    );
    bar.set_message("rendering");
    let (mut linear, mut rgba8): (Vec<Image>, Vec<Vec<u8>>) = (Vec::new(), Vec::new());
    let (mut render_seconds, mut crossings) = (0.0, 0u64);
    let mut notes: Vec<String> = Vec::new();
    let mut last_time = None;
    for i in 0..n {
        let (azimuth, time) = frame_at(i, n, orbit, times);
        if let (Some(t), Some(st)) = (time, &steps) {
            if last_time != Some(t) {
                let at = |e: tet_bundle::TimeError| usage(format!("frame {i}: {e}"));
                animator.set_scalar(st.scalar_at(t).map_err(at)?, st.gradient_at(t).map_err(at)?)?;
                last_time = Some(t);
            }
        }
        let t = Instant::now();
        let view = match &path {
            Some(p) => p.at(if n > 1 { i as f64 / (n - 1) as f64 } else { 0.0 }),
            None if azimuth == 0.0 => base.clone(),
            None => base.orbit(azimuth, 0.0, 1.0),
        };
        let frame = animator.render(&look, &request(view))?;
        render_seconds += t.elapsed().as_secs_f64();
        if let FrameStats::Cpu(s) = &frame.stats {
            crossings += s.crossings;
        }
        for note in frame.notes {
            if !notes.contains(&note) {
                eprintln!("note: {note}");
                notes.push(note);
            }
        }
        if keep_linear {
            linear.push(frame.image);
        } else {
            let px = frame.image.to_rgba8(&display);
            write_frame(args, i, &base.size, &px)?;
            rgba8.push(px);
        }
        bar.inc(1);
    }
    bar.finish_and_clear();
    let fit = Reinhard::fit_sequence(&linear, &display);
    if let Some(op) = &fit {
        for (i, img) in linear.iter().enumerate() {
            let px = img.to_rgba8_with(&display, op);
            write_frame(args, i as u32, &base.size, &px)?;
            rgba8.push(px);
        }
    }
    let [w, h] = base.size;
    match container {
        Container::Apng => write_apng_rgba8(&args.output, w, h, &rgba8, args.fps)?,
        Container::Gif => write_gif_rgba8(&args.output, w, h, &rgba8, args.fps)?,
        Container::Video => write_video(&args.ffmpeg, &args.output, base.size, args.fps, &rgba8)?,
    }
    let total = start.elapsed().as_secs_f64();
    if args.json {
        let v = serde_json::json!({
            "frames": n,
            "size": base.size,
            "fps": args.fps,
            "orbit_degrees": orbit,
            "key_views": args.key_views.len(),
            "container": container.id(),
            "time_range": times.map(|(a, b)| [a, b]),
            "method": method.id(),
            "renderer": if args.gpu { "gpu" } else { args.renderer.id() },
            "render_seconds": render_seconds,
            "seconds_per_frame": render_seconds / n as f64,
            "crossings": crossings,
            "tables_baked": tet_engine::tables_baked(),
            "total_seconds": total,
            "output": args.output.display().to_string(),
        });
        println!("{}", serde_json::to_string_pretty(&v)?);
    } else {
        eprintln!(
            "{n} frames {}x{} ({method}, {}{}{}{}) in {total:.2} s ({:.3} s a frame) → {}",
            base.size[0],
            base.size[1],
            if args.gpu { "gpu" } else { args.renderer.id() },
            if orbit != 0.0 { format!(", orbit {orbit}°") } else { String::new() },
            if keyed { format!(", {} key views", args.key_views.len()) } else { String::new() },
            times.map_or(String::new(), |(a, b)| format!(", t = {a} to {b}")),
            render_seconds / n as f64,
            args.output.display()
        );
    }
    Ok(())
}

/// The path through the key view files; `size` (--size) resizes every key.
fn key_path(files: &[PathBuf], size: Option<[u32; 2]>) -> Result<KeyPath> {
    let mut keys = Vec::with_capacity(files.len());
    for p in files {
        let text = std::fs::read_to_string(p)
            .with_context(|| format!("reading view {}", p.display()))
            .kind(ExitKind::Input)?;
        let mut v = ViewSpec::from_json(&text).with_context(|| format!("in {}", p.display())).kind(ExitKind::Input)?;
        if let Some(s) = size {
            v.size = s;
        }
        keys.push(v);
    }
    KeyPath::new(keys).map_err(|e| usage(format!("--key-views: {e}")))
}

fn write_frame(args: &AnimateArgs, i: u32, size: &[u32; 2], px: &[u8]) -> Result<()> {
    if let Some(dir) = &args.frames_dir {
        tet_render::image::write_png_rgba8(&dir.join(format!("frame_{i:04}.png")), size[0], size[1], px)?;
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn frames_span_the_times_and_an_orbit_loops() {
        assert_eq!(frame_at(0, 4, 360.0, None), (0.0, None));
        assert_eq!(frame_at(2, 4, 360.0, None), (180.0, None));
        let t: Vec<f64> = (0..4).map(|i| frame_at(i, 4, 0.0, Some((2.0, 5.0))).1.unwrap()).collect();
        assert_eq!(t, [2.0, 3.0, 4.0, 5.0]);
        assert_eq!(frame_at(0, 1, 90.0, Some((1.0, 2.0))), (0.0, Some(1.0)));
    }
}
