//! Colour maps, round-number ticks and short number labels.

use crate::canvas::Rgb;

/// Viridis (CC0, matplotlib), nine control points, linearly interpolated;
/// `t` is clamped to [0, 1].
pub fn viridis(t: f64) -> Rgb {
    const C: [Rgb; 9] = [
        [68, 1, 84],
        [71, 44, 122],
        [59, 81, 139],
        [44, 113, 142],
        [33, 144, 141],
        [39, 173, 129],
        [92, 200, 99],
        [170, 220, 50],
        [253, 231, 37],
    ];
    let x = if t.is_nan() { 0.0 } else { t.clamp(0.0, 1.0) * 8.0 };
    let i = (x.floor() as usize).min(7);
    let f = x - i as f64;
    [0, 1, 2].map(|k| (C[i][k] as f64 * (1.0 - f) + C[i + 1][k] as f64 * f).round() as u8)
}

/// Ten distinguishable colours for plot series (Tableau 10).
pub const SERIES: [Rgb; 10] = [
    [31, 119, 180],
    [255, 127, 14],
    [44, 160, 44],
    [214, 39, 40],
    [148, 103, 189],
    [140, 86, 75],
    [227, 119, 194],
    [127, 127, 127],
    [188, 189, 34],
    [23, 190, 207],
];

/// Round-number ticks in [lo, hi], about `n` of them.
pub fn nice_ticks(lo: f64, hi: f64, n: usize) -> Vec<f64> {
    let raw = (hi - lo) / n.max(1) as f64;
    if raw <= 0.0 || !raw.is_finite() {
        return vec![lo];
    }
    let mag = 10f64.powf(raw.log10().floor());
    let step = [1.0, 2.0, 5.0, 10.0].iter().map(|m| m * mag).find(|&s| s >= raw).unwrap_or(10.0 * mag);
    let first = (lo / step).ceil() as i64;
    let last = (hi / step).floor() as i64;
    (first..=last).map(|k| k as f64 * step).collect()
}

/// Powers of ten in [lo, hi] (both > 0); the two ends if there are fewer than two.
pub fn decade_ticks(lo: f64, hi: f64) -> Vec<f64> {
    let t: Vec<f64> = (lo.log10().ceil() as i32..=hi.log10().floor() as i32).map(|e| 10f64.powi(e)).collect();
    if t.len() < 2 {
        vec![lo, hi]
    } else {
        t
    }
}

/// Short number text: fixed point when readable, else scientific.
pub fn fmt_num(v: f64) -> String {
    if v == 0.0 {
        return "0".into();
    }
    let a = v.abs();
    if !(1e-3..1e5).contains(&a) {
        let s = format!("{v:.1e}");
        return s.replace(".0e", "e");
    }
    let digits = (3 - a.log10().floor() as i32).clamp(0, 6) as usize;
    let s = format!("{v:.digits$}");
    if s.contains('.') {
        s.trim_end_matches('0').trim_end_matches('.').to_string()
    } else {
        s
    }
}

/// `image` (RGB, `w × h`, row 0 at the top) with a vertical colour bar to
/// its right: `map(t)` for t from 0 (bottom) to 1 (top), labelled with
/// round-number ticks of [0, `full_scale`] and titled `title`. The bar
/// says what the image's colours mean.
pub fn with_colorbar(image: &crate::Canvas, full_scale: f64, title: &str, map: impl Fn(f64) -> Rgb) -> crate::Canvas {
    use crate::canvas::BLACK;
    let (bar_w, pad, text) = (14usize, 10usize, 1usize);
    let ticks = nice_ticks(0.0, full_scale, 4);
    let label_w = ticks.iter().map(|&t| crate::Canvas::text_width(&fmt_num(t), text)).max().unwrap_or(0);
    let title_w = crate::Canvas::text_width(title, text);
    let h = image.h.max(80);
    let w = image.w + pad + bar_w + 4 + label_w.max(title_w.saturating_sub(bar_w + 4)) + pad;
    let mut c = crate::Canvas::new(w, h);
    for y in 0..image.h {
        for x in 0..image.w {
            c.set(x, y, image.get(x, y));
        }
    }
    let (x0, top, bottom) = (image.w + pad, 14usize, h.saturating_sub(10));
    let span = bottom.saturating_sub(top).max(1);
    for y in top..bottom {
        let t = (bottom - 1 - y) as f64 / (span - 1).max(1) as f64;
        c.rect(x0, y, bar_w, 1, map(t));
    }
    c.frame(x0, top, bar_w, span, BLACK);
    c.text(x0, 2, title, text, BLACK);
    if full_scale > 0.0 && full_scale.is_finite() {
        for t in ticks {
            let y = bottom as f64 - 1.0 - (t / full_scale) * (span - 1) as f64;
            let y = y.round().max(0.0) as usize;
            c.rect(x0 + bar_w, y, 3, 1, BLACK);
            c.text(x0 + bar_w + 4, y.saturating_sub(3), &fmt_num(t), text, BLACK);
        }
    }
    c
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn ticks_and_labels() {
        assert_eq!(nice_ticks(0.0, 1.0, 5), vec![0.0, 0.2, 0.4, 0.6000000000000001, 0.8, 1.0]);
        assert_eq!(decade_ticks(0.003, 20.0), vec![0.01, 0.1, 1.0, 10.0]);
        assert_eq!(fmt_num(0.25), "0.25");
        assert_eq!(fmt_num(1234.0), "1234");
        assert_eq!(fmt_num(2e-5), "2e-5");
        assert_eq!(viridis(0.0), [68, 1, 84]);
        assert_eq!(viridis(1.0), [253, 231, 37]);
        assert_eq!(viridis(f64::NAN), [68, 1, 84]);
    }

    #[test]
    fn colorbar_extends_the_image_and_keeps_it() {
        let mut img = crate::Canvas::new(30, 20);
        img.rect(0, 0, 30, 20, [10, 20, 30]);
        let c = with_colorbar(&img, 0.004, "|A-B|", viridis);
        assert!(c.w > 30 + 14 && c.h >= 80);
        assert_eq!(c.get(5, 5), [10, 20, 30]);
        // The bar runs from map(0) at the bottom to map(1) at the top.
        let x = 30 + 10 + 7;
        let (top, bottom) = (c.get(x, 16), c.get(x, c.h - 12));
        assert!(top[1] > bottom[1] + 150, "{top:?} {bottom:?}");
    }
}
