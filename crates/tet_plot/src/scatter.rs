//! Scatter plots of (cost, error) points per method with the Pareto front —
//! the "run time against error" figures of tetlut and tetview.

use crate::canvas::{Canvas, Rgb, BLACK, GREY, LIGHT_GREY};
use crate::scale::{decade_ticks, fmt_num, nice_ticks, SERIES};

/// One point; `label` is drawn beside the marker (e.g. a resolution).
#[derive(Debug, Clone, PartialEq)]
pub struct Point {
    pub x: f64,
    pub y: f64,
    pub label: Option<String>,
}

/// A named group of points (one method), drawn in one colour.
#[derive(Debug, Clone, PartialEq)]
pub struct Series {
    pub name: String,
    pub points: Vec<Point>,
}

/// A scatter plot; points with a non-finite coordinate, or a non-positive
/// one on a log axis, are left out (and counted in the footer).
#[derive(Debug, Clone, PartialEq, Default)]
pub struct ScatterPlot {
    pub title: String,
    pub x_label: String,
    pub y_label: String,
    pub log_x: bool,
    pub log_y: bool,
    pub series: Vec<Series>,
    /// Draw the Pareto front (smaller x and smaller y are better).
    pub pareto: bool,
}

/// Indices (series, point) of the points no other point beats in both x
/// and y, sorted by x.
pub fn pareto_front(series: &[Series]) -> Vec<(usize, usize)> {
    let mut all: Vec<(f64, f64, usize, usize)> = series
        .iter()
        .enumerate()
        .flat_map(|(s, ser)| ser.points.iter().enumerate().map(move |(i, p)| (p.x, p.y, s, i)))
        .filter(|p| p.0.is_finite() && p.1.is_finite())
        .collect();
    all.sort_by(|a, b| a.0.total_cmp(&b.0).then(a.1.total_cmp(&b.1)));
    let mut best = f64::INFINITY;
    let mut out = Vec::new();
    for (_, y, s, i) in all {
        if y < best {
            best = y;
            out.push((s, i));
        }
    }
    out
}

struct Axis {
    log: bool,
    lo: f64,
    hi: f64,
}

impl Axis {
    fn fit(values: impl Iterator<Item = f64>, log: bool) -> Axis {
        let (mut lo, mut hi) = (f64::INFINITY, f64::NEG_INFINITY);
        for v in values {
            lo = lo.min(v);
            hi = hi.max(v);
        }
        if !lo.is_finite() {
            return Axis { log, lo: if log { 0.1 } else { 0.0 }, hi: 1.0 };
        }
        if log {
            let (a, b) = (10f64.powf(lo.log10().floor()), 10f64.powf(hi.log10().ceil()));
            Axis { log, lo: a, hi: if b > a { b } else { a * 10.0 } }
        } else {
            let pad = if hi > lo { 0.05 * (hi - lo) } else { 0.5 * lo.abs().max(1.0) };
            Axis { log, lo: lo - pad, hi: hi + pad }
        }
    }

    /// Position in [0, 1].
    fn frac(&self, v: f64) -> f64 {
        if self.log {
            (v.log10() - self.lo.log10()) / (self.hi.log10() - self.lo.log10())
        } else {
            (v - self.lo) / (self.hi - self.lo)
        }
    }

    fn ticks(&self) -> Vec<f64> {
        if self.log {
            decade_ticks(self.lo, self.hi)
        } else {
            nice_ticks(self.lo, self.hi, 6)
        }
    }

    fn usable(&self, v: f64) -> bool {
        v.is_finite() && (!self.log || v > 0.0)
    }
}

impl ScatterPlot {
    pub fn draw(&self, w: usize, h: usize) -> Canvas {
        let w = w.max(320);
        let h = h.max(240);
        let mut c = Canvas::new(w, h);
        let (left, right, top, bottom) = (90usize, 200usize, 40usize, 60usize);
        let (pw, ph) = (w - left - right, h - top - bottom);
        let pts = || self.series.iter().flat_map(|s| s.points.iter());
        let x_axis = Axis::fit(pts().map(|p| p.x).filter(|&v| v.is_finite() && (!self.log_x || v > 0.0)), self.log_x);
        let y_axis = Axis::fit(pts().map(|p| p.y).filter(|&v| v.is_finite() && (!self.log_y || v > 0.0)), self.log_y);
        let to_px =
            |p: &Point| (left as f64 + x_axis.frac(p.x) * pw as f64, (top + ph) as f64 - y_axis.frac(p.y) * ph as f64);
        c.text(left, 12, &self.title, 2, BLACK);
        for v in x_axis.ticks() {
            let x = left + (x_axis.frac(v) * pw as f64).round() as usize;
            c.rect(x, top, 1, ph, LIGHT_GREY);
            let t = fmt_num(v);
            c.text(x.saturating_sub(Canvas::text_width(&t, 1) / 2), top + ph + 6, &t, 1, BLACK);
        }
        for v in y_axis.ticks() {
            let y = top + ph - (y_axis.frac(v) * ph as f64).round() as usize;
            c.rect(left, y, pw, 1, LIGHT_GREY);
            let t = fmt_num(v);
            c.text(left.saturating_sub(6 + Canvas::text_width(&t, 1)), y.saturating_sub(3), &t, 1, BLACK);
        }
        c.frame(left, top, pw, ph, BLACK);
        let xl = &self.x_label;
        c.text(left + pw.saturating_sub(Canvas::text_width(xl, 1)) / 2, top + ph + 24, xl, 1, BLACK);
        let yl = &self.y_label;
        c.text_up(16, top + ph.saturating_sub(Canvas::text_width(yl, 1)) / 2, yl, 1, BLACK);
        if self.pareto {
            let front = pareto_front(&self.series);
            let mut prev: Option<(f64, f64)> = None;
            for (s, i) in front {
                let p = &self.series[s].points[i];
                if !(x_axis.usable(p.x) && y_axis.usable(p.y)) {
                    continue;
                }
                let q = to_px(p);
                if let Some(a) = prev {
                    c.line(a.0, a.1, q.0, a.1, 1, GREY);
                    c.line(q.0, a.1, q.0, q.1, 1, GREY);
                }
                prev = Some(q);
            }
        }
        let mut skipped = 0;
        for (k, s) in self.series.iter().enumerate() {
            let col: Rgb = SERIES[k % SERIES.len()];
            for p in &s.points {
                if !(x_axis.usable(p.x) && y_axis.usable(p.y)) {
                    skipped += 1;
                    continue;
                }
                let (x, y) = to_px(p);
                c.marker(x, y, 7, col);
                if let Some(l) = &p.label {
                    c.text(x as usize + 6, (y as usize).saturating_sub(10), l, 1, GREY);
                }
            }
            let ly = top + 4 + 16 * k;
            c.marker((left + pw + 16) as f64, ly as f64 + 3.0, 7, col);
            c.text(left + pw + 26, ly, &s.name, 1, BLACK);
        }
        if self.pareto {
            let ly = top + 8 + 16 * self.series.len();
            c.line((left + pw + 10) as f64, ly as f64, (left + pw + 22) as f64, ly as f64, 1, GREY);
            c.text(left + pw + 26, ly - 3, "Pareto front", 1, GREY);
        }
        if skipped > 0 {
            let t = format!("{skipped} point(s) off a log axis or not finite: not drawn");
            c.text(left, h - 14, &t, 1, GREY);
        }
        c
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn pt(x: f64, y: f64) -> Point {
        Point { x, y, label: None }
    }

    #[test]
    fn pareto_front_keeps_only_undominated_points() {
        let s = vec![
            Series { name: "a".into(), points: vec![pt(1.0, 5.0), pt(2.0, 6.0), pt(4.0, 1.0)] },
            Series { name: "b".into(), points: vec![pt(2.0, 2.0), pt(f64::NAN, 0.0), pt(3.0, 3.0)] },
        ];
        assert_eq!(pareto_front(&s), vec![(0, 0), (1, 0), (0, 2)]);
    }

    #[test]
    fn draws_markers_on_log_axes_and_skips_unusable_points() {
        let plot = ScatterPlot {
            title: "t".into(),
            x_label: "x".into(),
            y_label: "y".into(),
            log_x: true,
            log_y: true,
            series: vec![Series { name: "m".into(), points: vec![pt(0.01, 1e-3), pt(1.0, 1e-6), pt(0.0, 1.0)] }],
            pareto: true,
        };
        let c = plot.draw(640, 400);
        assert_eq!((c.w, c.h), (640, 400));
        // The series colour appears (a marker was drawn).
        let col = SERIES[0];
        assert!((0..c.h).any(|y| (0..c.w).any(|x| c.get(x, y) == col)));
    }
}
