//! `tetview diff A B`: how far an image is from another (usually the
//! reference render, given first).
//!
//! Two float images (`.npy`, linear premultiplied RGBA) are compared over all
//! four channels: RMSE, largest absolute difference (pixel and channel) and
//! mean absolute difference; then both are displayed through the same
//! operator — composited over `--background`, tone mapped with Reinhard
//! fitted to A (so a global brightness error is not normalized away) or with
//! `--tonemap none` — and the largest 8-bit difference is reported. Two
//! PNGs are compared as 8-bit RGBA (values / 255). A float image against a
//! PNG: the float one is displayed first and the 8-bit images compared.

use anyhow::{bail, Context, Result};
use clap::Args;
use std::io::Write;
use std::path::{Path, PathBuf};
use tet_cli::{fail, usage, ExitKind, KindExt};
use tet_render::image::{diff_image_rgba8, linear_to_srgb, Reinhard};
use tet_render::{diff, DiffStats, Image};

#[derive(Debug, Clone, Args)]
pub struct DiffArgs {
    /// First image, the reference (`.npy` float RGBA, or `.png`).
    pub a: PathBuf,
    /// Second image, compared with the first.
    pub b: PathBuf,
    /// Write |A − B| as a PNG: the largest channel difference per pixel in
    /// viridis, with a colour bar giving its scale.
    #[arg(short, long)]
    pub output: Option<PathBuf>,
    /// Print a JSON object instead of text.
    #[arg(long)]
    pub json: bool,
    /// Difference at the top of the `-o` image's colour bar (viridis'
    /// brightest colour; larger ones are clamped to it). Default: the
    /// largest difference.
    #[arg(long)]
    pub scale: Option<f32>,
    /// Background under the volume for the 8-bit comparison, linear R,G,B.
    #[arg(long, value_parser = tet_cli::parse_rgb, default_value = "0,0,0")]
    pub background: [f32; 3],
    /// Display operator for the 8-bit comparison: none (linear, clamped) or
    /// reinhard (fitted to A, applied to both, then sRGB).
    #[arg(long, value_enum, default_value = "reinhard")]
    pub tonemap: crate::camera_args::ToneMapArg,
}

/// An input image: float (from `.npy`) or 8-bit RGBA (from `.png`).
enum Loaded {
    Float(Image),
    Bytes { width: u32, height: u32, rgba: Vec<u8> },
}

impl Loaded {
    fn size(&self) -> [u32; 2] {
        match self {
            Loaded::Float(i) => [i.width(), i.height()],
            Loaded::Bytes { width, height, .. } => [*width, *height],
        }
    }
}

fn is_png(path: &Path) -> bool {
    path.extension().and_then(|e| e.to_str()).is_some_and(|e| e.eq_ignore_ascii_case("png"))
}

/// Reads an input image; any failure is an input error (exit code 3).
fn load(path: &Path) -> Result<Loaded> {
    if is_png(path) {
        let (width, height, rgba) = read_png_rgba8(path).kind(ExitKind::Input)?;
        Ok(Loaded::Bytes { width, height, rgba })
    } else {
        Ok(Loaded::Float(Image::read_npy(path).kind(ExitKind::Input)?))
    }
}

/// Any PNG as 8-bit RGBA (palette and low bit depths expanded, 16 bits cut
/// to 8, grey replicated, missing alpha = 255).
pub fn read_png_rgba8(path: &Path) -> Result<(u32, u32, Vec<u8>)> {
    let file = std::fs::File::open(path).with_context(|| format!("opening {}", path.display()))?;
    let mut decoder = png::Decoder::new(std::io::BufReader::new(file));
    decoder.set_transformations(png::Transformations::EXPAND | png::Transformations::STRIP_16);
    let mut reader = decoder.read_info().with_context(|| format!("not a readable PNG: {}", path.display()))?;
    let (w, h) = (reader.info().width, reader.info().height);
    let max = tet_render::camera::MAX_IMAGE_SIDE;
    if w == 0 || h == 0 || w > max || h > max {
        bail!("PNG of {w}x{h} pixels: each side must be 1..={max}: {}", path.display());
    }
    let mut buf = vec![0u8; reader.output_buffer_size()];
    let info = reader.next_frame(&mut buf).with_context(|| format!("decoding PNG {}", path.display()))?;
    let channels = match info.color_type {
        png::ColorType::Grayscale => 1,
        png::ColorType::GrayscaleAlpha => 2,
        png::ColorType::Rgb => 3,
        png::ColorType::Rgba => 4,
        png::ColorType::Indexed => bail!("palette PNG was not expanded: {}", path.display()),
    };
    let mut out = Vec::with_capacity(w as usize * h as usize * 4);
    for row in buf.chunks(info.line_size).take(h as usize) {
        for px in row[..w as usize * channels].chunks_exact(channels) {
            let rgba = match channels {
                1 => [px[0], px[0], px[0], 255],
                2 => [px[0], px[0], px[0], px[1]],
                3 => [px[0], px[1], px[2], 255],
                _ => [px[0], px[1], px[2], px[3]],
            };
            out.extend_from_slice(&rgba);
        }
    }
    Ok((w, h, out))
}

fn bytes_to_image(width: u32, height: u32, rgba: &[u8]) -> Image {
    let px = rgba.chunks_exact(4).map(|p| std::array::from_fn(|c| p[c] as f32 / 255.0)).collect();
    Image::from_pixels(width, height, px).expect("size matches")
}

fn unit_to_u8(v: f32) -> u8 {
    (v.clamp(0.0, 1.0) * 255.0 + 0.5) as u8
}

/// 8-bit display of `img` over `bg` with `op` (None: linear, clamped).
fn display(img: &Image, bg: [f32; 3], op: Option<&Reinhard>) -> Vec<u8> {
    let mut out = Vec::with_capacity(img.pixels().len() * 4);
    for p in img.pixels() {
        let t = 1.0 - p[3].clamp(0.0, 1.0);
        let c = [p[0] + t * bg[0], p[1] + t * bg[1], p[2] + t * bg[2]];
        match op {
            None => out.extend(c.iter().map(|&v| unit_to_u8(v))),
            Some(op) => out.extend(op.apply(c).iter().map(|&v| unit_to_u8(linear_to_srgb(v)))),
        }
        out.push(255);
    }
    out
}

fn composited_rgb(img: &Image, bg: [f32; 3]) -> Vec<[f32; 3]> {
    img.pixels()
        .iter()
        .map(|p| {
            let t = 1.0 - p[3].clamp(0.0, 1.0);
            [p[0] + t * bg[0], p[1] + t * bg[1], p[2] + t * bg[2]]
        })
        .collect()
}

/// Largest 8-bit difference between `a` (the reference) and `b`, both
/// composited over `background`, tone mapped with Reinhard (key 0.18)
/// fitted to `a` and applied to both, then sRGB-encoded: what `tetview
/// diff` reports for two float images. Returns the difference (0..=255) and
/// where: pixel (x, y) and channel.
pub fn max_8bit_reinhard(a: &Image, b: &Image, background: [f32; 3]) -> Result<(u8, (u32, u32, usize))> {
    if (a.width(), a.height()) != (b.width(), b.height()) {
        bail!("images differ in size: {}x{} vs {}x{}", a.width(), a.height(), b.width(), b.height());
    }
    let op = Reinhard::fit(&composited_rgb(a, background), 0.18, 1.0);
    let (da, db) = (display(a, background, Some(&op)), display(b, background, Some(&op)));
    Ok(max_8bit(&da, &db, a.width()))
}

/// What `tetview diff` measured.
#[derive(Debug, Clone, PartialEq)]
pub struct DiffReport {
    pub width: u32,
    pub height: u32,
    /// "float", "png" or "float-vs-png".
    pub kind: &'static str,
    /// Over linear premultiplied RGBA for two float images, over 8-bit / 255
    /// otherwise.
    pub stats: DiffStats,
    /// Largest 8-bit difference of the displayed images (0..=255).
    pub max_8bit: u8,
    /// Largest 8-bit difference: pixel (x, y) and channel.
    pub max_8bit_at: (u32, u32, usize),
}

fn max_8bit(a: &[u8], b: &[u8], width: u32) -> (u8, (u32, u32, usize)) {
    let (mut best, mut at) = (0u8, (0, 0, 0));
    for (i, (x, y)) in a.iter().zip(b).enumerate() {
        let d = x.abs_diff(*y);
        if d > best {
            best = d;
            let px = i / 4;
            at = ((px % width as usize) as u32, (px / width as usize) as u32, i % 4);
        }
    }
    (best, at)
}

/// Compares two files; also returns the |A − B| image's 8-bit pixels.
pub fn compare(args: &DiffArgs) -> Result<(DiffReport, Vec<u8>)> {
    let a = load(&args.a)?;
    let b = load(&args.b)?;
    if a.size() != b.size() {
        let ([aw, ah], [bw, bh]) = (a.size(), b.size());
        return Err(fail(
            ExitKind::Rejected,
            format!(
                "images differ in size: {} is {aw}x{ah}, {} is {bw}x{bh} (width x height); render both at the same --size",
                args.a.display(),
                args.b.display()
            ),
        ));
    }
    let [width, height] = a.size();
    let reinhard = args.tonemap == crate::camera_args::ToneMapArg::Reinhard;
    // Fitted to A's covered pixels, as `render` displays A.
    let op_for = |img: &Image| {
        let alpha: Vec<f32> = img.pixels().iter().map(|p| p[3]).collect();
        reinhard.then(|| Reinhard::fit_covered(&composited_rgb(img, args.background), &alpha, 0.18, 1.0))
    };
    let (kind, fa, fb, da, db) = match (&a, &b) {
        (Loaded::Float(x), Loaded::Float(y)) => {
            let op = op_for(x);
            (
                "float",
                x.clone(),
                y.clone(),
                display(x, args.background, op.as_ref()),
                display(y, args.background, op.as_ref()),
            )
        }
        (Loaded::Bytes { rgba: x, .. }, Loaded::Bytes { rgba: y, .. }) => {
            ("png", bytes_to_image(width, height, x), bytes_to_image(width, height, y), x.clone(), y.clone())
        }
        (Loaded::Float(x), Loaded::Bytes { rgba: y, .. }) => {
            let dx = display(x, args.background, op_for(x).as_ref());
            ("float-vs-png", bytes_to_image(width, height, &dx), bytes_to_image(width, height, y), dx, y.clone())
        }
        (Loaded::Bytes { rgba: x, .. }, Loaded::Float(y)) => {
            let dy = display(y, args.background, op_for(y).as_ref());
            ("float-vs-png", bytes_to_image(width, height, x), bytes_to_image(width, height, &dy), x.clone(), dy)
        }
    };
    let stats = diff(&fa, &fb)?;
    let (max_8bit, max_8bit_at) = max_8bit(&da, &db, width);
    let scale = args.scale.unwrap_or(stats.max_abs as f32);
    let scale = if scale > 0.0 && scale.is_finite() { scale } else { 1.0 };
    let picture = diff_image_rgba8(&fa, &fb, scale)?;
    Ok((DiffReport { width, height, kind, stats, max_8bit, max_8bit_at }, picture))
}

const CHANNELS: [&str; 4] = ["R", "G", "B", "A"];

/// The grey |A − B| picture of [`compare`] (white = `full_scale`) in
/// viridis, with a colour bar labelled from 0 to `full_scale`.
fn colour_diff_picture(grey: &[u8], width: u32, height: u32, full_scale: f64) -> tet_plot::Canvas {
    let mut img = tet_plot::Canvas::new(width as usize, height as usize);
    for (i, px) in grey.chunks_exact(4).enumerate() {
        img.set(i % width as usize, i / width as usize, tet_plot::viridis(px[0] as f64 / 255.0));
    }
    tet_plot::with_colorbar(&img, full_scale, "|A-B|", tet_plot::viridis)
}

pub fn run(args: &DiffArgs) -> Result<()> {
    if let Some(s) = args.scale {
        if !(s > 0.0 && s.is_finite()) {
            return Err(usage(format!("--scale {s}: must be a positive number")));
        }
    }
    let (r, picture) = compare(args)?;
    if let Some(out) = &args.output {
        let full = args.scale.unwrap_or(r.stats.max_abs as f32);
        let full = if full > 0.0 && full.is_finite() { full } else { 1.0 };
        colour_diff_picture(&picture, r.width, r.height, full as f64)
            .write_png(out)
            .with_context(|| format!("writing {}", out.display()))
            .kind(ExitKind::Output)?;
    }
    let s = &r.stats;
    // writeln! rather than println!: a closed pipe is an error, not a panic.
    let mut out = std::io::stdout().lock();
    if args.json {
        let j = serde_json::json!({
            "a": args.a.display().to_string(),
            "b": args.b.display().to_string(),
            "width": r.width,
            "height": r.height,
            "kind": r.kind,
            "rmse": s.rmse,
            "max_abs": s.max_abs,
            "max_at": {"x": s.max_at.0, "y": s.max_at.1, "channel": CHANNELS[s.max_at.2]},
            "mean_abs": s.mean_abs,
            "max_8bit": r.max_8bit,
            "max_8bit_at": {"x": r.max_8bit_at.0, "y": r.max_8bit_at.1, "channel": CHANNELS[r.max_8bit_at.2]},
            "tonemap": args.tonemap.id(),
            "background": args.background,
            "diff_png": args.output.as_ref().map(|p| p.display().to_string()),
        });
        writeln!(out, "{}", serde_json::to_string_pretty(&j)?)?;
    } else {
        let units = if r.kind == "float" { "linear premultiplied RGBA" } else { "8-bit RGBA / 255" };
        writeln!(out, "A {}  B {}  ({}x{}, {})", args.a.display(), args.b.display(), r.width, r.height, r.kind)?;
        writeln!(out, "RMSE        {:.6e}  ({units}, all 4 channels)", s.rmse)?;
        writeln!(
            out,
            "max |A−B|   {:.6e}  at pixel ({}, {}) channel {}",
            s.max_abs, s.max_at.0, s.max_at.1, CHANNELS[s.max_at.2]
        )?;
        writeln!(out, "mean |A−B|  {:.6e}", s.mean_abs)?;
        writeln!(
            out,
            "8-bit max   {}/255 at pixel ({}, {}) channel {}  (tonemap {}, background {},{},{})",
            r.max_8bit,
            r.max_8bit_at.0,
            r.max_8bit_at.1,
            CHANNELS[r.max_8bit_at.2],
            args.tonemap.id(),
            args.background[0],
            args.background[1],
            args.background[2]
        )?;
        if let Some(path) = &args.output {
            writeln!(
                out,
                "wrote {} (viridis, colour bar 0 to {:.3e})",
                path.display(),
                args.scale.unwrap_or(s.max_abs as f32).max(0.0)
            )?;
        }
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    fn args(a: &Path, b: &Path) -> DiffArgs {
        DiffArgs {
            a: a.into(),
            b: b.into(),
            output: None,
            json: false,
            scale: None,
            background: [0.0; 3],
            tonemap: crate::camera_args::ToneMapArg::None,
        }
    }

    #[test]
    fn float_and_png_comparisons() {
        let dir = tempfile::tempdir().unwrap();
        let a = Image::from_pixels(2, 1, vec![[0.25, 0.5, 0.0, 0.5], [0.0; 4]]).unwrap();
        let mut b = a.clone();
        b.pixels_mut()[1][1] = 0.1;
        let (pa, pb) = (dir.path().join("a.npy"), dir.path().join("b.npy"));
        a.write_npy(&pa).unwrap();
        b.write_npy(&pb).unwrap();
        let (r, pic) = compare(&args(&pa, &pb)).unwrap();
        assert_eq!(r.kind, "float");
        assert!((r.stats.max_abs - 0.1).abs() < 1e-7 && r.stats.max_at == (1, 0, 1));
        assert_eq!(r.max_8bit, 26);
        assert_eq!(pic[4..8], [255, 255, 255, 255]);
        // PNG against PNG, and float against PNG of its own display: zero.
        let png_a = dir.path().join("a.png");
        a.write_png(&png_a, &tet_render::Display { background: [0.0; 3], tonemap: tet_render::ToneMap::None }).unwrap();
        let (r, _) = compare(&args(&png_a, &png_a)).unwrap();
        assert_eq!((r.kind, r.max_8bit, r.stats.max_abs), ("png", 0, 0.0));
        let (r, _) = compare(&args(&pa, &png_a)).unwrap();
        assert_eq!((r.kind, r.max_8bit), ("float-vs-png", 0));
        // Size mismatch and bad files are clear errors.
        let small = dir.path().join("s.npy");
        Image::new(1, 1).write_npy(&small).unwrap();
        let e = compare(&args(&pa, &small)).unwrap_err().to_string();
        assert!(e.contains("differ in size") && e.contains("2x1") && e.contains("1x1"), "{e}");
        let junk = dir.path().join("j.npy");
        std::fs::write(&junk, b"nope").unwrap();
        assert!(format!("{:#}", compare(&args(&pa, &junk)).unwrap_err()).contains("j.npy"));
        assert!(compare(&args(&pa, &dir.path().join("missing.png"))).is_err());
    }
}
