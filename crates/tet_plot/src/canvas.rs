//! An RGB raster with rectangles, lines, markers and text in the built-in
//! 5×7 font, written as PNG.

use crate::{font, PlotError};
use std::path::Path;

pub type Rgb = [u8; 3];
pub const WHITE: Rgb = [255, 255, 255];
pub const BLACK: Rgb = [0, 0, 0];
pub const GREY: Rgb = [90, 90, 90];
pub const LIGHT_GREY: Rgb = [220, 220, 220];

/// An RGB image, row 0 at the top; drawing outside it is clipped.
#[derive(Debug, Clone, PartialEq)]
pub struct Canvas {
    pub w: usize,
    pub h: usize,
    /// `w × h × 3` bytes.
    pub px: Vec<u8>,
}

impl Canvas {
    /// A white canvas.
    pub fn new(w: usize, h: usize) -> Canvas {
        Canvas { w, h, px: vec![255; w * h * 3] }
    }

    pub fn set(&mut self, x: usize, y: usize, c: Rgb) {
        if x < self.w && y < self.h {
            let i = (y * self.w + x) * 3;
            self.px[i..i + 3].copy_from_slice(&c);
        }
    }

    pub fn get(&self, x: usize, y: usize) -> Rgb {
        let i = (y * self.w + x) * 3;
        [self.px[i], self.px[i + 1], self.px[i + 2]]
    }

    /// `self` above `below` on one white canvas as wide as the wider.
    pub fn above(&self, below: &Canvas) -> Canvas {
        let mut c = Canvas::new(self.w.max(below.w), self.h + below.h);
        for (img, y0) in [(self, 0), (below, self.h)] {
            for y in 0..img.h {
                for x in 0..img.w {
                    c.set(x, y0 + y, img.get(x, y));
                }
            }
        }
        c
    }

    pub fn rect(&mut self, x0: usize, y0: usize, w: usize, h: usize, c: Rgb) {
        for y in y0..(y0 + h).min(self.h) {
            for x in x0..(x0 + w).min(self.w) {
                self.set(x, y, c);
            }
        }
    }

    pub fn frame(&mut self, x0: usize, y0: usize, w: usize, h: usize, c: Rgb) {
        if w == 0 || h == 0 {
            return;
        }
        self.rect(x0, y0, w, 1, c);
        self.rect(x0, y0 + h - 1, w, 1, c);
        self.rect(x0, y0, 1, h, c);
        self.rect(x0 + w - 1, y0, 1, h, c);
    }

    /// A line of the given width in pixels between two points (any
    /// coordinates; clipped).
    pub fn line(&mut self, x0: f64, y0: f64, x1: f64, y1: f64, width: usize, c: Rgb) {
        if !(x0.is_finite() && y0.is_finite() && x1.is_finite() && y1.is_finite()) {
            return;
        }
        let steps = ((x1 - x0).abs().max((y1 - y0).abs()).ceil() as usize).clamp(1, 1 << 16);
        let half = width as f64 / 2.0;
        for k in 0..=steps {
            let t = k as f64 / steps as f64;
            let (x, y) = (x0 + t * (x1 - x0) - half, y0 + t * (y1 - y0) - half);
            if x >= -(width as f64) && y >= -(width as f64) {
                self.rect(x.round().max(0.0) as usize, y.round().max(0.0) as usize, width.max(1), width.max(1), c);
            }
        }
    }

    /// A filled square marker of side `size` centred at (x, y), outlined in black.
    pub fn marker(&mut self, x: f64, y: f64, size: usize, c: Rgb) {
        if !(x.is_finite() && y.is_finite()) || x < 0.0 || y < 0.0 {
            return;
        }
        let (x0, y0) = ((x - size as f64 / 2.0).max(0.0) as usize, (y - size as f64 / 2.0).max(0.0) as usize);
        self.rect(x0, y0, size, size, c);
        self.frame(x0, y0, size, size, BLACK);
    }

    pub fn text_width(s: &str, scale: usize) -> usize {
        s.chars().count() * font::ADVANCE * scale
    }

    /// Left-aligned text with its top-left corner at (x, y).
    pub fn text(&mut self, x: usize, y: usize, s: &str, scale: usize, c: Rgb) {
        for (i, ch) in s.chars().enumerate() {
            let g = font::glyph(ch);
            for (row, bits) in g.iter().enumerate() {
                for col in 0..5 {
                    if bits >> (4 - col) & 1 == 1 {
                        let (px, py) = (x + (i * font::ADVANCE + col) * scale, y + row * scale);
                        self.rect(px, py, scale, scale, c);
                    }
                }
            }
        }
    }

    /// Text rotated 90° counter-clockwise (reading upwards), its bounding
    /// box's top-left at (x, y).
    pub fn text_up(&mut self, x: usize, y: usize, s: &str, scale: usize, c: Rgb) {
        let len = Self::text_width(s, scale);
        for (i, ch) in s.chars().enumerate() {
            let g = font::glyph(ch);
            for (row, bits) in g.iter().enumerate() {
                for col in 0..5 {
                    if bits >> (4 - col) & 1 == 1 {
                        // Unrotated (u, v) → rotated (v, len − 1 − u).
                        let u = (i * font::ADVANCE + col) * scale;
                        let v = row * scale;
                        self.rect(x + v, y + len - u - scale, scale, scale, c);
                    }
                }
            }
        }
    }

    /// PNG bytes (8-bit RGB).
    pub fn to_png(&self) -> Result<Vec<u8>, PlotError> {
        let mut out = Vec::new();
        {
            let mut enc = png::Encoder::new(&mut out, self.w as u32, self.h as u32);
            enc.set_color(png::ColorType::Rgb);
            enc.set_depth(png::BitDepth::Eight);
            let mut w = enc.write_header().map_err(|e| PlotError::Png(e.to_string()))?;
            w.write_image_data(&self.px).map_err(|e| PlotError::Png(e.to_string()))?;
        }
        Ok(out)
    }

    pub fn write_png(&self, path: &Path) -> Result<(), PlotError> {
        let bytes = self.to_png()?;
        std::fs::write(path, bytes).map_err(|source| PlotError::Io { source, path: path.to_path_buf() })
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn above_stacks_and_pads_with_white() {
        let mut a = Canvas::new(3, 2);
        a.set(2, 1, BLACK);
        let mut b = Canvas::new(5, 1);
        b.set(4, 0, GREY);
        let c = a.above(&b);
        assert_eq!((c.w, c.h), (5, 3));
        assert_eq!(c.get(2, 1), BLACK);
        assert_eq!(c.get(4, 2), GREY);
        assert_eq!(c.get(4, 0), WHITE, "right of the narrower canvas");
    }
}
