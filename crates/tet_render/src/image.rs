//! Float images of linear premultiplied RGBA (row 0 at the top), their
//! NumPy `.npy` form for measurement, display through tone mapping to 8-bit
//! PNG, and image differences.
//!
//! Display pipeline: composite over the background (C + (1−α)·bg), then
//! either `ToneMap::None` — the linear colour clamped to [0, 1] and written
//! without a transfer curve, which is what VTK's framebuffer holds and so
//! what comparisons with other renderers need — or `ToneMap::Reinhard`,
//! Reinhard's global operator on luminance with the log-average luminance
//! of the covered pixels (as in Vollrath, Weiskopf & Ertl, "A Generic Software
//! Framework for the GPU Volume Rendering Pipeline", VMV 2005), colour kept,
//! followed by the sRGB curve.
//! [`PictureMetrics`] measures what a viewer sees in the 8-bit result.

use crate::RenderError;
use std::io::Write;
use std::path::Path;

/// Linear premultiplied RGBA in f32, `width × height`, row-major, row 0 at
/// the top.
#[derive(Debug, Clone, PartialEq)]
pub struct Image {
    width: u32,
    height: u32,
    pixels: Vec<[f32; 4]>,
}

impl Image {
    /// A transparent image.
    pub fn new(width: u32, height: u32) -> Image {
        Image { width, height, pixels: vec![[0.0; 4]; width as usize * height as usize] }
    }

    /// Wraps pixels; their count must be `width × height`.
    pub fn from_pixels(width: u32, height: u32, pixels: Vec<[f32; 4]>) -> Result<Image, RenderError> {
        if pixels.len() != width as usize * height as usize {
            return Err(RenderError::ImageSize { expected: [width, height], pixels: pixels.len() });
        }
        Ok(Image { width, height, pixels })
    }

    pub fn width(&self) -> u32 {
        self.width
    }
    pub fn height(&self) -> u32 {
        self.height
    }
    pub fn pixels(&self) -> &[[f32; 4]] {
        &self.pixels
    }
    pub fn pixels_mut(&mut self) -> &mut [[f32; 4]] {
        &mut self.pixels
    }
    /// The pixels, row-major from the top (handing them on without a copy).
    pub fn into_pixels(self) -> Vec<[f32; 4]> {
        self.pixels
    }
    pub fn pixel(&self, x: u32, y: u32) -> [f32; 4] {
        self.pixels[y as usize * self.width as usize + x as usize]
    }

    /// NumPy `.npy` v1.0 bytes: little-endian float32, shape (H, W, 4).
    pub fn to_npy_bytes(&self) -> Vec<u8> {
        let dict =
            format!("{{'descr': '<f4', 'fortran_order': False, 'shape': ({}, {}, 4), }}", self.height, self.width);
        // Magic (6) + version (2) + header length (2) + dict + '\n', padded to 64.
        let unpadded = 10 + dict.len() + 1;
        let pad = (64 - unpadded % 64) % 64;
        let header_len = dict.len() + pad + 1;
        let mut out = Vec::with_capacity(10 + header_len + self.pixels.len() * 16);
        out.extend_from_slice(b"\x93NUMPY\x01\x00");
        out.extend_from_slice(&(header_len as u16).to_le_bytes());
        out.extend_from_slice(dict.as_bytes());
        out.extend(std::iter::repeat_n(b' ', pad));
        out.push(b'\n');
        for px in &self.pixels {
            for c in px {
                out.extend_from_slice(&c.to_le_bytes());
            }
        }
        out
    }

    /// Reads what [`Image::to_npy_bytes`] writes (float32 little-endian,
    /// C order, shape (H, W, 4)); anything else is an error saying what was found.
    pub fn from_npy_bytes(bytes: &[u8], path: &Path) -> Result<Image, RenderError> {
        let bad = |why: String| RenderError::Npy { why, path: path.to_path_buf() };
        if bytes.len() < 10 || &bytes[..6] != b"\x93NUMPY" {
            return Err(bad("not a .npy file (magic missing)".into()));
        }
        let (header_len, start) = match bytes[6] {
            1 => (u16::from_le_bytes([bytes[8], bytes[9]]) as usize, 10),
            2 | 3 if bytes.len() >= 12 => (u32::from_le_bytes([bytes[8], bytes[9], bytes[10], bytes[11]]) as usize, 12),
            v => return Err(bad(format!("unsupported .npy version {v}"))),
        };
        let header = bytes
            .get(start..start + header_len)
            .and_then(|h| std::str::from_utf8(h).ok())
            .ok_or_else(|| bad("truncated or non-UTF-8 header".into()))?;
        let compact: String = header.chars().filter(|c| !c.is_whitespace()).collect();
        if !compact.contains("'descr':'<f4'") {
            return Err(bad(format!("dtype must be little-endian float32 ('<f4'); header is {header}")));
        }
        if compact.contains("'fortran_order':True") {
            return Err(bad("Fortran order is not supported".into()));
        }
        let shape = compact
            .split("'shape':(")
            .nth(1)
            .and_then(|r| r.split(')').next())
            .ok_or_else(|| bad(format!("no shape in header {header}")))?;
        let dims: Vec<usize> = shape
            .split(',')
            .filter(|s| !s.is_empty())
            .map(|s| s.parse())
            .collect::<Result<_, _>>()
            .map_err(|_| bad(format!("bad shape ({shape})")))?;
        if dims.len() != 3 || dims[2] != 4 {
            return Err(bad(format!("shape must be (H, W, 4), found ({shape})")));
        }
        let (h, w) = (dims[0], dims[1]);
        if h == 0 || w == 0 || h > crate::camera::MAX_IMAGE_SIDE as usize || w > crate::camera::MAX_IMAGE_SIDE as usize
        {
            return Err(bad(format!("image size {w}x{h} out of range")));
        }
        let data = &bytes[start + header_len..];
        let need = h * w * 16;
        if data.len() != need {
            return Err(bad(format!("shape ({h}, {w}, 4) needs {need} data bytes, found {}", data.len())));
        }
        let pixels = data
            .chunks_exact(16)
            .map(|px| {
                let f = |i: usize| f32::from_le_bytes([px[4 * i], px[4 * i + 1], px[4 * i + 2], px[4 * i + 3]]);
                [f(0), f(1), f(2), f(3)]
            })
            .collect();
        Ok(Image { width: w as u32, height: h as u32, pixels })
    }

    pub fn write_npy(&self, path: &Path) -> Result<(), RenderError> {
        write_atomic(path, &self.to_npy_bytes())
    }

    pub fn read_npy(path: &Path) -> Result<Image, RenderError> {
        let bytes = std::fs::read(path).map_err(|e| RenderError::Io { source: e, path: path.to_path_buf() })?;
        Image::from_npy_bytes(&bytes, path)
    }

    /// 8-bit RGBA (opaque) for display: over `display.background`, then tone
    /// mapped. Reinhard's operator is fitted to the covered pixels only
    /// ([`Reinhard::fit_covered`]: α above [`COVERED_ALPHA`]), so the
    /// background never sets the exposure.
    pub fn to_rgba8(&self, display: &Display) -> Vec<u8> {
        let rgb = composite_over(self, display.background);
        let mut out = Vec::with_capacity(rgb.len() * 4);
        match display.tonemap {
            ToneMap::None => {
                for c in &rgb {
                    out.extend(c.iter().map(|&v| unit_to_u8(v)));
                    out.push(255);
                }
            }
            ToneMap::Reinhard { key, exposure } => {
                let alpha: Vec<f32> = self.pixels.iter().map(|p| p[3]).collect();
                let op = Reinhard::fit_covered(&rgb, &alpha, key, exposure);
                for c in &rgb {
                    let m = op.apply(*c);
                    out.extend(m.iter().map(|&v| unit_to_u8(linear_to_srgb(v))));
                    out.push(255);
                }
            }
        }
        out
    }

    /// [`Image::to_rgba8`] with Reinhard's operator given (fitted to a
    /// whole animation by [`Reinhard::fit_sequence`], so the exposure does
    /// not flicker from frame to frame); `ToneMap::None` ignores it.
    pub fn to_rgba8_with(&self, display: &Display, op: &Reinhard) -> Vec<u8> {
        if display.tonemap == ToneMap::None {
            return self.to_rgba8(display);
        }
        let rgb = composite_over(self, display.background);
        let mut out = Vec::with_capacity(rgb.len() * 4);
        for c in &rgb {
            let m = op.apply(*c);
            out.extend(m.iter().map(|&v| unit_to_u8(linear_to_srgb(v))));
            out.push(255);
        }
        out
    }

    /// Writes an 8-bit sRGB PNG after compositing and tone mapping.
    pub fn write_png(&self, path: &Path, display: &Display) -> Result<(), RenderError> {
        write_png_rgba8(path, self.width, self.height, &self.to_rgba8(display))
    }
}

/// How a float image becomes 8-bit.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Display {
    /// Linear RGB under the volume.
    pub background: [f32; 3],
    pub tonemap: ToneMap,
}

impl Default for Display {
    fn default() -> Self {
        Display { background: [0.0; 3], tonemap: ToneMap::reinhard() }
    }
}

#[derive(Debug, Clone, Copy, PartialEq)]
pub enum ToneMap {
    /// Linear colour clamped to [0, 1], no transfer curve: an opaque region
    /// shows its TF colour as is (what VTK and ParaView write), a
    /// translucent one that colour composited over the background.
    None,
    /// Reinhard's global operator on luminance (Reinhard, Stark, Shirley and
    /// Ferwerda, "Photographic tone reproduction for digital images", 2002):
    /// L_m = key·exposure·L / L̄ with L̄ the log-average luminance of the
    /// covered pixels, L_d = L_m(1 + L_m/L_white²)/(1 + L_m) with L_white the
    /// largest covered L_m at exposure 1 (so exposure moves every pixel,
    /// the brightest included), colour kept (see [`Reinhard::apply`]).
    Reinhard { key: f32, exposure: f32 },
}

impl ToneMap {
    /// Key 0.18 (Reinhard's "middle grey"), exposure 1.
    pub fn reinhard() -> ToneMap {
        ToneMap::Reinhard { key: 0.18, exposure: 1.0 }
    }
}

/// Pixels with α above this are the volume ("covered"); the others are
/// background and take no part in the exposure. Low enough to keep faint
/// structure, high enough that the anti-aliased rim of near-empty rays
/// does not drag the log-average towards black.
pub const COVERED_ALPHA: f32 = 0.02;

/// Rec. 709 luminance of linear RGB.
pub fn luminance(c: [f32; 3]) -> f32 {
    0.2126 * c[0] + 0.7152 * c[1] + 0.0722 * c[2]
}

/// Linear premultiplied RGBA composited over `background`: C + (1 − α)·bg.
pub fn composite_over(img: &Image, background: [f32; 3]) -> Vec<[f32; 3]> {
    img.pixels
        .iter()
        .map(|p| {
            let t = 1.0 - p[3].clamp(0.0, 1.0);
            [p[0] + t * background[0], p[1] + t * background[1], p[2] + t * background[2]]
        })
        .collect()
}

/// Reinhard's operator fitted to one image.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Reinhard {
    /// Multiplier from world luminance to L_m.
    pub scale: f32,
    /// L_white² in L_m units.
    pub white_sq: f32,
    /// The log-average luminance L̄ (of the pixels fitted).
    pub log_average: f32,
}

impl Reinhard {
    /// Fitted to every pixel of `rgb` (all count as covered); for a render
    /// over a background use [`Reinhard::fit_covered`].
    pub fn fit(rgb: &[[f32; 3]], key: f32, exposure: f32) -> Reinhard {
        Reinhard::fit_where(rgb.iter().copied(), key, exposure)
    }

    /// Fitted to the covered pixels (`alpha[i] >` [`COVERED_ALPHA`]) of
    /// `rgb` (already composited): the background takes no part in L̄ or
    /// L_white. With no covered pixel the fit is over all of them.
    pub fn fit_covered(rgb: &[[f32; 3]], alpha: &[f32], key: f32, exposure: f32) -> Reinhard {
        let covered = || rgb.iter().zip(alpha).filter(|(_, &a)| a > COVERED_ALPHA).map(|(c, _)| *c);
        if covered().next().is_none() {
            return Reinhard::fit(rgb, key, exposure);
        }
        Reinhard::fit_where(covered(), key, exposure)
    }

    /// One operator for a sequence of frames (an animation): fitted to the
    /// covered pixels of all of them together (each over `display`'s
    /// background), as [`Reinhard::fit_covered`] fits one frame. `None`
    /// for `ToneMap::None`.
    pub fn fit_sequence(frames: &[Image], display: &Display) -> Option<Reinhard> {
        let ToneMap::Reinhard { key, exposure } = display.tonemap else { return None };
        let composited: Vec<(Vec<[f32; 3]>, &Image)> =
            frames.iter().map(|f| (composite_over(f, display.background), f)).collect();
        let covered = || {
            composited
                .iter()
                .flat_map(|(rgb, f)| rgb.iter().zip(f.pixels()).filter(|(_, p)| p[3] > COVERED_ALPHA).map(|(c, _)| *c))
        };
        Some(if covered().next().is_none() {
            Reinhard::fit_where(composited.iter().flat_map(|(rgb, _)| rgb.iter().copied()), key, exposure)
        } else {
            Reinhard::fit_where(covered(), key, exposure)
        })
    }

    fn fit_where(pixels: impl Iterator<Item = [f32; 3]> + Clone, key: f32, exposure: f32) -> Reinhard {
        // δ keeps log finite on black pixels (Reinhard et al. 2002).
        const DELTA: f64 = 1e-4;
        let (mut n, mut sum_log, mut max_l) = (0usize, 0.0f64, 0.0f32);
        for c in pixels {
            let l = luminance(c).max(0.0);
            n += 1;
            sum_log += (DELTA + l as f64).ln();
            max_l = max_l.max(l);
        }
        let log_average = (sum_log / n.max(1) as f64).exp() as f32;
        let scale = key * exposure / log_average;
        // The white point is fixed at exposure 1, so a lower exposure darkens
        // the brightest pixels too instead of re-stretching them to white.
        let max_lm = max_l * key / log_average;
        Reinhard { scale, white_sq: (max_lm * max_lm).max(f32::MIN_POSITIVE), log_average }
    }

    /// Tone-mapped linear RGB in [0, 1]: RGB scaled by L_d / L (hue and
    /// saturation kept). A colour whose largest channel would pass 1 is
    /// brought into gamut keeping its hue, never by clipping each channel
    /// (which turns a bright red into pink and then white): see [`fit_gamut`].
    pub fn apply(&self, c: [f32; 3]) -> [f32; 3] {
        let l = luminance(c).max(0.0);
        if !(l > 0.0 && l.is_finite()) {
            return [0.0; 3];
        }
        let lm = l * self.scale;
        let ld = (lm * (1.0 + lm / self.white_sq) / (1.0 + lm)).min(1.0);
        let k = ld / l;
        fit_gamut([c[0].max(0.0) * k, c[1].max(0.0) * k, c[2].max(0.0) * k], ld)
    }
}

/// Share of an out-of-gamut colour's correction done by desaturation; the
/// rest darkens it at full saturation. Both keep the hue (they move along
/// the same line through grey), so any mix does: pure desaturation would
/// reach white for every L_d near 1 whatever the colour (a saturated red
/// cannot be bright), pure darkening would lose the brightness order.
pub const DESATURATION: f32 = 0.25;

/// Brings `rgb` (luminance `l` ≤ 1) into [0, 1]³ with its hue kept: the mix
/// (by [`DESATURATION`]) of the least desaturation towards the grey of
/// luminance `l` that fits and the colour scaled by 1/max channel.
pub fn fit_gamut(rgb: [f32; 3], l: f32) -> [f32; 3] {
    let max = rgb[0].max(rgb[1]).max(rgb[2]);
    if max <= 1.0 {
        return rgb;
    }
    let t = ((1.0 - l) / (max - l)).clamp(0.0, 1.0);
    rgb.map(|v| {
        let desaturated = l + t * (v - l);
        let darkened = v / max;
        (darkened + DESATURATION * (desaturated - darkened)).clamp(0.0, 1.0)
    })
}

pub fn linear_to_srgb(v: f32) -> f32 {
    let v = v.clamp(0.0, 1.0);
    if v <= 0.003_130_8 {
        12.92 * v
    } else {
        1.055 * v.powf(1.0 / 2.4) - 0.055
    }
}

fn unit_to_u8(v: f32) -> u8 {
    // NaN maps to 0 through the clamp's comparison semantics.
    (v.clamp(0.0, 1.0) * 255.0 + 0.5) as u8
}

/// Writes 8-bit RGBA rows (row 0 at the top) as a PNG, atomically.
pub fn write_png_rgba8(path: &Path, width: u32, height: u32, rgba: &[u8]) -> Result<(), RenderError> {
    write_atomic(path, &encode_png_rgba8(width, height, rgba)?)
}

/// The bytes of an 8-bit RGBA PNG (`rgba`: width × height × 4 values).
pub fn encode_png_rgba8(width: u32, height: u32, rgba: &[u8]) -> Result<Vec<u8>, RenderError> {
    let mut bytes = Vec::new();
    {
        let mut enc = png::Encoder::new(&mut bytes, width, height);
        enc.set_color(png::ColorType::Rgba);
        enc.set_depth(png::BitDepth::Eight);
        let mut w = enc.write_header().map_err(|e| RenderError::Png(e.to_string()))?;
        w.write_image_data(rgba).map_err(|e| RenderError::Png(e.to_string()))?;
    }
    Ok(bytes)
}

/// Writes an animated PNG (APNG): `frames` of 8-bit RGBA, each
/// `width`×`height`, shown `1/fps` s each, looping forever. Viewers without
/// APNG support show the first frame.
pub fn write_apng_rgba8(path: &Path, width: u32, height: u32, frames: &[Vec<u8>], fps: f64) -> Result<(), RenderError> {
    let png_err = |e: png::EncodingError| RenderError::Png(e.to_string());
    if frames.is_empty() || frames.len() > u32::MAX as usize {
        return Err(RenderError::Png(format!("an animation of {} frames", frames.len())));
    }
    if !(fps.is_finite() && fps > 0.0) {
        return Err(RenderError::Png(format!("{fps} frames per second")));
    }
    // The delay as a fraction with a u16 numerator and denominator.
    let (num, den) = if fps >= 1.0 {
        (1, fps.round().clamp(1.0, 65535.0) as u16)
    } else {
        ((1.0 / fps).round().min(65535.0) as u16, 1)
    };
    let mut bytes = Vec::new();
    {
        let mut enc = png::Encoder::new(&mut bytes, width, height);
        enc.set_color(png::ColorType::Rgba);
        enc.set_depth(png::BitDepth::Eight);
        enc.set_animated(frames.len() as u32, 0).map_err(png_err)?;
        enc.set_frame_delay(num, den).map_err(png_err)?;
        let mut w = enc.write_header().map_err(png_err)?;
        for f in frames {
            w.write_image_data(f).map_err(png_err)?;
        }
        w.finish().map_err(png_err)?;
    }
    write_atomic(path, &bytes)
}

/// Writes `frames` (RGBA8 rows, `width`×`height` each, as
/// [`write_apng_rgba8`] takes them) as a looping animated GIF at `fps`
/// frames per second. GIF holds 256 colours a frame: each frame gets its own
/// palette (NeuQuant quantization, the `gif` crate's
/// `Frame::from_rgba_speed`), so smooth gradients band slightly where the
/// APNG keeps every colour. Delays are whole hundredths of a second, at
/// least two (browsers slow shorter ones down to a tenth).
pub fn write_gif_rgba8(path: &Path, width: u32, height: u32, frames: &[Vec<u8>], fps: f64) -> Result<(), RenderError> {
    let gif_err = |e: gif::EncodingError| RenderError::Gif(e.to_string());
    if frames.is_empty() {
        return Err(RenderError::Gif("an animation of 0 frames".into()));
    }
    if !(fps.is_finite() && fps > 0.0) {
        return Err(RenderError::Gif(format!("{fps} frames per second")));
    }
    let (Ok(w), Ok(h)) = (u16::try_from(width), u16::try_from(height)) else {
        return Err(RenderError::Gif(format!("{width}x{height}: GIF images are at most 65535 pixels a side")));
    };
    let pixels = width as usize * height as usize;
    let delay_cs = (100.0 / fps).round().clamp(2.0, 65535.0) as u16;
    let mut bytes = Vec::new();
    {
        let mut enc = gif::Encoder::new(&mut bytes, w, h, &[]).map_err(gif_err)?;
        enc.set_repeat(gif::Repeat::Infinite).map_err(gif_err)?;
        for (i, f) in frames.iter().enumerate() {
            if f.len() != pixels * 4 {
                let e = RenderError::ImageSize { expected: [width, height], pixels: f.len() / 4 };
                return Err(RenderError::Gif(format!("frame {i}: {e}")));
            }
            let mut rgba = f.clone();
            // Speed 10: NeuQuant's default sampling (1 is slowest and best).
            let mut frame = gif::Frame::from_rgba_speed(w, h, &mut rgba, 10);
            frame.delay = delay_cs;
            enc.write_frame(&frame).map_err(gif_err)?;
        }
    }
    write_atomic(path, &bytes)
}

/// Writes through a temporary file in the same directory and renames, so a
/// failed write never leaves a half-written image under the final name.
/// tet_container's writer, shared by every output of every program, gives
/// the file the mode `File::create` would.
pub(crate) fn write_atomic(path: &Path, bytes: &[u8]) -> Result<(), RenderError> {
    tet_container::write_atomic(path, ".tetimg-", |w: &mut dyn Write| w.write_all(bytes))
        .map_err(|e| RenderError::Io { source: std::io::Error::other(e), path: path.to_path_buf() })
}

/// What a displayed picture shows over its covered pixels, on 8-bit sRGB
/// values scaled to [0, 1]: luma Y = 0.2126 R + 0.7152 G + 0.0722 B and
/// chroma max(R, G, B) − min(R, G, B). A flat silhouette has a small
/// luminance spread, a saturated one many near-white pixels, a colourless
/// one a small median chroma.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct PictureMetrics {
    pub covered_pixels: usize,
    /// 95th minus 5th percentile of luma.
    pub luminance_spread: f64,
    /// Fraction of pixels with every channel ≥ 0.9.
    pub near_white: f64,
    pub median_chroma: f64,
}

impl PictureMetrics {
    /// Measures 8-bit RGBA `rgba8` over the pixels where `covered` is true
    /// (all zero when none is).
    pub fn of_rgba8(rgba8: &[u8], covered: &[bool]) -> PictureMetrics {
        let (mut lum, mut chroma, mut white) = (Vec::new(), Vec::new(), 0usize);
        for (px, _) in rgba8.chunks_exact(4).zip(covered).filter(|(_, &c)| c) {
            let [r, g, b] = [px[0], px[1], px[2]].map(|v| v as f64 / 255.0);
            lum.push(0.2126 * r + 0.7152 * g + 0.0722 * b);
            chroma.push(r.max(g).max(b) - r.min(g).min(b));
            white += usize::from(r >= 0.9 && g >= 0.9 && b >= 0.9);
        }
        let n = lum.len();
        if n == 0 {
            return PictureMetrics { covered_pixels: 0, luminance_spread: 0.0, near_white: 0.0, median_chroma: 0.0 };
        }
        lum.sort_unstable_by(f64::total_cmp);
        chroma.sort_unstable_by(f64::total_cmp);
        let q = |v: &[f64], p: f64| v[((n - 1) as f64 * p).round() as usize];
        PictureMetrics {
            covered_pixels: n,
            luminance_spread: q(&lum, 0.95) - q(&lum, 0.05),
            near_white: white as f64 / n as f64,
            median_chroma: q(&chroma, 0.5),
        }
    }

    /// Measures how `img` displays under `display`, over its covered pixels
    /// (α > [`COVERED_ALPHA`]).
    pub fn of_image(img: &Image, display: &Display) -> PictureMetrics {
        let covered: Vec<bool> = img.pixels.iter().map(|p| p[3] > COVERED_ALPHA).collect();
        PictureMetrics::of_rgba8(&img.to_rgba8(display), &covered)
    }
}

impl std::fmt::Display for PictureMetrics {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(
            f,
            "{} covered pixels: luminance spread (p95 − p5) {:.3}, near-white {:.1}%, median chroma {:.3}",
            self.covered_pixels,
            self.luminance_spread,
            100.0 * self.near_white,
            self.median_chroma
        )
    }
}

/// Differences between two images of the same size, over all four channels
/// of linear premultiplied RGBA.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct DiffStats {
    pub rmse: f64,
    pub max_abs: f64,
    /// Pixel (x, y) and channel of the largest difference.
    pub max_at: (u32, u32, usize),
    pub mean_abs: f64,
}

pub fn diff(a: &Image, b: &Image) -> Result<DiffStats, RenderError> {
    if a.width != b.width || a.height != b.height {
        return Err(RenderError::SizeMismatch { a: [a.width, a.height], b: [b.width, b.height] });
    }
    let (mut sq, mut sum, mut max_abs, mut max_at) = (0.0f64, 0.0f64, -1.0f64, (0, 0, 0));
    for (i, (p, q)) in a.pixels.iter().zip(&b.pixels).enumerate() {
        for c in 0..4 {
            let d = (p[c] as f64 - q[c] as f64).abs();
            // A NaN anywhere is the largest difference there is.
            let d = if d.is_nan() { f64::INFINITY } else { d };
            sq += d * d;
            sum += d;
            if d > max_abs {
                max_abs = d;
                max_at = ((i % a.width as usize) as u32, (i / a.width as usize) as u32, c);
            }
        }
    }
    let n = (a.pixels.len() * 4).max(1) as f64;
    Ok(DiffStats { rmse: (sq / n).sqrt(), max_abs: max_abs.max(0.0), max_at, mean_abs: sum / n })
}

/// Largest difference between the 8-bit displays of two images (0..=255).
pub fn diff_rgba8(a: &[u8], b: &[u8]) -> u8 {
    a.iter().zip(b).map(|(x, y)| x.abs_diff(*y)).max().unwrap_or(0)
}

/// A visualization of |a − b|: the largest channel difference per pixel,
/// scaled so `full_scale` maps to white.
pub fn diff_image_rgba8(a: &Image, b: &Image, full_scale: f32) -> Result<Vec<u8>, RenderError> {
    if a.width != b.width || a.height != b.height {
        return Err(RenderError::SizeMismatch { a: [a.width, a.height], b: [b.width, b.height] });
    }
    let mut out = Vec::with_capacity(a.pixels.len() * 4);
    for (p, q) in a.pixels.iter().zip(&b.pixels) {
        let d = (0..4).map(|c| (p[c] - q[c]).abs()).fold(0.0f32, f32::max);
        let v = unit_to_u8(d / full_scale.max(f32::MIN_POSITIVE));
        out.extend_from_slice(&[v, v, v, 255]);
    }
    Ok(out)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn ramp() -> Image {
        let px = (0..12).map(|i| [i as f32 / 12.0, 0.5, 0.25, 0.75]).collect();
        Image::from_pixels(4, 3, px).unwrap()
    }

    #[test]
    fn npy_round_trip_and_header_layout() {
        let img = ramp();
        let bytes = img.to_npy_bytes();
        assert_eq!(&bytes[..8], b"\x93NUMPY\x01\x00");
        let header_len = u16::from_le_bytes([bytes[8], bytes[9]]) as usize;
        assert_eq!((10 + header_len) % 64, 0);
        assert!(std::str::from_utf8(&bytes[10..10 + header_len]).unwrap().contains("'shape': (3, 4, 4)"));
        let back = Image::from_npy_bytes(&bytes, Path::new("x.npy")).unwrap();
        assert_eq!(back, img);
        for cut in [0, 5, 9, 20, bytes.len() - 1] {
            assert!(Image::from_npy_bytes(&bytes[..cut], Path::new("x.npy")).is_err(), "cut {cut}");
        }
    }

    #[test]
    fn tonemap_none_is_clamped_linear_over_background() {
        let img = Image::from_pixels(2, 1, vec![[0.5, 0.0, 2.0, 0.5], [0.0; 4]]).unwrap();
        let d = Display { background: [1.0, 1.0, 1.0], tonemap: ToneMap::None };
        let px = img.to_rgba8(&d);
        assert_eq!(&px[..4], &[255, 128, 255, 255]);
        assert_eq!(&px[4..], &[255, 255, 255, 255]);
    }

    #[test]
    fn reinhard_maps_brightest_to_white_and_keeps_order() {
        let rgb = [[0.01f32; 3], [0.5; 3], [10.0; 3], [0.0; 3]];
        let op = Reinhard::fit(&rgb, 0.18, 1.0);
        let out: Vec<f32> = rgb.iter().map(|&c| op.apply(c)[0]).collect();
        assert!((out[2] - 1.0).abs() < 1e-5);
        assert!(out[3] == 0.0 && out[0] < out[1] && out[1] < out[2]);
        let black = Reinhard::fit(&[[0.0; 3]; 4], 0.18, 1.0);
        assert_eq!(black.apply([0.0; 3]), [0.0; 3]);
        assert!(black.scale.is_finite());
    }

    /// A soft disc of TF colour `rgb` with opacity rising to `peak` towards
    /// the centre, over black (premultiplied, density emission: C = rgb·α).
    fn disc(rgb: [f32; 3], peak: f32, scale: f32) -> Image {
        let n = 32u32;
        let px = (0..n * n)
            .map(|i| {
                let (x, y) = ((i % n) as f32 - 15.5, (i / n) as f32 - 15.5);
                let r = (x * x + y * y).sqrt() / 12.0;
                let a = if r < 1.0 { peak * (1.0 - r * r) } else { 0.0 };
                [rgb[0] * a * scale, rgb[1] * a * scale, rgb[2] * a * scale, a]
            })
            .collect();
        Image::from_pixels(n, n, px).unwrap()
    }

    fn covered_mean_luminance(img: &Image, d: &Display) -> f64 {
        let px = img.to_rgba8(d);
        let (mut sum, mut n) = (0.0, 0);
        for (p, q) in px.chunks_exact(4).zip(img.pixels()) {
            if q[3] > COVERED_ALPHA {
                sum += luminance([p[0] as f32, p[1] as f32, p[2] as f32]) as f64 / 255.0;
                n += 1;
            }
        }
        sum / n as f64
    }

    /// The bug of issue 17: the background's black pixels made L̄ tiny, so
    /// every covered pixel mapped near white and exposure did nothing.
    #[test]
    fn background_does_not_set_exposure_and_exposure_works() {
        let img = disc([0.9, 0.8, 0.7], 0.6, 1.0);
        let at = |e: f32| {
            covered_mean_luminance(
                &img,
                &Display { tonemap: ToneMap::Reinhard { key: 0.18, exposure: e }, ..Default::default() },
            )
        };
        let (dim, normal) = (at(0.2), at(1.0));
        eprintln!("mean covered luminance: exposure 0.2 → {dim:.3}, 1 → {normal:.3}");
        assert!(normal < 0.8, "covered pixels saturate: {normal}");
        assert!(normal - dim > 0.1, "exposure 0.2 vs 1: {dim} vs {normal}");
        // The same disc on a 4× larger black canvas tone maps identically.
        let big = Image::from_pixels(64, 64, {
            let mut v = vec![[0.0; 4]; 64 * 64];
            for y in 0..32 {
                for x in 0..32 {
                    v[y * 64 + x] = img.pixel(x as u32, y as u32);
                }
            }
            v
        })
        .unwrap();
        let a = img.to_rgba8(&Display::default());
        let b = big.to_rgba8(&Display::default());
        for y in 0..32 {
            assert_eq!(&a[y * 128..y * 128 + 128], &b[y * 256..y * 256 + 128]);
        }
    }

    /// A mid-opacity red region stays red (hue kept, no push to white) at
    /// any exposure, and the brightest pixels of a saturated colour keep
    /// their hue instead of clipping channel by channel.
    #[test]
    fn red_stays_red() {
        let red = [0.71, 0.02, 0.15];
        for exposure in [0.5, 1.0, 4.0, 50.0] {
            let img = disc(red, 0.5, 3.0);
            let d = Display { tonemap: ToneMap::Reinhard { key: 0.18, exposure }, ..Default::default() };
            let px = img.to_rgba8(&d);
            let m = PictureMetrics::of_image(&img, &d);
            assert_eq!(m.near_white, 0.0, "exposure {exposure}: {m}");
            for (p, q) in px.chunks_exact(4).zip(img.pixels()) {
                if q[3] > 0.1 {
                    let [r, g, b] = [p[0], p[1], p[2]].map(|v| v as i32);
                    assert!(r > g + 20 && r > b + 10 && b >= g - 2, "exposure {exposure}: {p:?} is not red");
                }
            }
        }
        // Desaturation keeps luminance and ordering of channels.
        let op = Reinhard { scale: 1.0, white_sq: 1.0, log_average: 1.0 };
        let out = op.apply([10.0, 0.1, 0.2]);
        assert!(out.iter().all(|v| (0.0..=1.0).contains(v)) && out[0] > out[2] && out[2] > out[1], "{out:?}");
    }

    /// Linear mode: an opaque region shows its TF colour exactly; a
    /// translucent one the colour composited over the background.
    #[test]
    fn tonemap_none_shows_tf_colours_over_background() {
        let tf = [0.71f32, 0.02, 0.15];
        let bg = [0.1f32, 0.2, 0.3];
        let px = vec![[tf[0], tf[1], tf[2], 1.0], [0.5 * tf[0], 0.5 * tf[1], 0.5 * tf[2], 0.5]];
        let img = Image::from_pixels(2, 1, px).unwrap();
        let out = img.to_rgba8(&Display { background: bg, tonemap: ToneMap::None });
        let want = |c: f32| (c * 255.0 + 0.5) as u8;
        assert_eq!(&out[..3], &tf.map(want));
        assert_eq!(&out[4..7], &[0, 1, 2].map(|k| want(0.5 * tf[k] + 0.5 * bg[k])));
    }

    #[test]
    fn picture_metrics_of_flat_and_coloured_pictures() {
        let white = [255u8, 255, 255, 255].repeat(10);
        let m = PictureMetrics::of_rgba8(&white, &[true; 10]);
        assert_eq!((m.luminance_spread, m.near_white, m.median_chroma), (0.0, 1.0, 0.0));
        let ramp: Vec<u8> = (0..10u8).flat_map(|i| [25 * i, 0, 0, 255]).collect();
        let m = PictureMetrics::of_rgba8(&ramp, &[true; 10]);
        assert!(m.luminance_spread > 0.15 && m.near_white == 0.0 && m.median_chroma > 0.4, "{m}");
        assert_eq!(PictureMetrics::of_rgba8(&ramp, &[false; 10]).covered_pixels, 0);
    }

    #[test]
    fn diff_reports_rmse_max_and_location() {
        let a = ramp();
        let mut b = a.clone();
        b.pixels_mut()[6][2] += 0.5;
        let d = diff(&a, &b).unwrap();
        assert!((d.max_abs - 0.5).abs() < 1e-7);
        assert_eq!(d.max_at, (2, 1, 2));
        assert!((d.rmse - (0.25f64 / 48.0).sqrt()).abs() < 1e-7);
        assert!(diff(&a, &Image::new(3, 4)).is_err());
    }
}
