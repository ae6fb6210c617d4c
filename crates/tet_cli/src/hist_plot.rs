//! The histogram figure the front ends share (`tetprep hist`, the Python
//! package's `Bundle.histogram_png`): drawn here so that both show the same
//! picture of the same [`Histograms`].

use tet_analysis::{Axis, Histograms, Scale};
use tet_plot::canvas::{Canvas, Rgb, BLACK, GREY, WHITE};
use tet_plot::{fmt_num, nice_ticks, viridis};

const EMPTY: Rgb = [246, 246, 246];
const BAR: Rgb = [55, 80, 140];

/// Maps a bin volume to [0, 1] (None: empty bin).
struct ValueScale {
    log: bool,
    lo: f64,
    hi: f64,
}

impl ValueScale {
    fn new(values: &[f64], log: bool) -> ValueScale {
        let hi = values.iter().copied().fold(0.0, f64::max);
        let min_pos = values.iter().copied().filter(|&v| v > 0.0).fold(f64::INFINITY, f64::min);
        // Six decades at most: below that, bins are rounding noise of empty ones.
        let lo = if log { min_pos.max(hi * 1e-6) } else { 0.0 };
        ValueScale { log, lo, hi: if hi > 0.0 { hi } else { 1.0 } }
    }

    fn map(&self, v: f64) -> Option<f64> {
        if v <= 0.0 {
            return None;
        }
        Some(if self.log {
            if self.hi <= self.lo {
                1.0
            } else {
                ((v.max(self.lo)).log10() - self.lo.log10()) / (self.hi.log10() - self.lo.log10())
            }
        } else {
            v / self.hi
        })
    }

    /// Tick values and their positions in [0, 1].
    fn ticks(&self) -> Vec<(f64, f64)> {
        if self.log {
            let (a, b) = (self.lo.log10().ceil() as i32, self.hi.log10().floor() as i32);
            let mut t: Vec<(f64, f64)> = (a..=b).map(|e| 10f64.powi(e)).map(|v| (v, self.map(v).unwrap())).collect();
            if t.len() < 2 {
                t = vec![(self.lo, 0.0), (self.hi, 1.0)];
            }
            t
        } else {
            nice_ticks(0.0, self.hi, 5).into_iter().map(|v| (v, v / self.hi)).collect()
        }
    }
}

/// Ticks of a data axis: (value, fraction along the axis).
fn axis_ticks(a: &Axis) -> Vec<(f64, f64)> {
    match a.scale {
        Scale::Linear => nice_ticks(a.lo, a.hi, 6).into_iter().map(|v| (v, (v - a.lo) / (a.hi - a.lo))).collect(),
        Scale::Log => {
            let (l0, l1) = (a.lo.log10(), a.hi.log10());
            (l0.ceil() as i32..=l1.floor() as i32).map(|e| (10f64.powi(e), (e as f64 - l0) / (l1 - l0))).collect()
        }
    }
}

/// Units for the axis labels, when the user knows them.
#[derive(Debug, Clone, Default)]
pub struct AxisUnits {
    pub scalar: Option<String>,
    pub length: Option<String>,
}

impl AxisUnits {
    /// The x axis's label: `s = name [unit]`.
    pub fn scalar_label(&self, name: &str) -> String {
        match &self.scalar {
            Some(u) => format!("s = {name} [{u}]"),
            None => format!("s = {name}"),
        }
    }

    /// The y axis's label: `|∇s| [unit / length]`.
    pub fn gradient_label(&self) -> String {
        match (&self.scalar, &self.length) {
            (Some(u), Some(l)) => format!("|∇s| [{u} / {l}]"),
            (Some(u), None) => format!("|∇s| [{u} per length unit]"),
            (None, Some(l)) => format!("|∇s| (per {l})"),
            (None, None) => "|∇s| (per length unit)".to_string(),
        }
    }
}

/// The figure of `tetprep hist` and Python's `Bundle.histogram_png`: the
/// volume-weighted scalar × |∇s| histogram (log or linear colour scale with a
/// colour bar), the 1D histogram along the top on the same scalar axis,
/// axes labelled with `name` and `units`, `title` on the first line.
pub fn histogram_figure(h: &Histograms, name: &str, title: &str, log: bool, units: &AxisUnits) -> Canvas {
    let (ns, ng) = (h.scalar_axis.bins as usize, h.gradient_axis.bins as usize);
    let s = 2; // text scale: 10×14-pixel glyphs
    let (left, pw) = (110usize, 640usize);
    let (top1, ph1) = (64usize, 130usize);
    let gap = 12usize;
    let (top2, ph2) = (top1 + ph1 + gap, 480usize);
    let (bottom, right) = (90usize, 150usize);
    let (w, hgt) = (left + pw + right, top2 + ph2 + bottom);
    let mut c = Canvas::new(w, hgt);

    c.text(left, 12, title, s, BLACK);
    let sub = format!(
        "volume-weighted, {} colour scale; {}×{} bins; {:.2}% of the volume off the axes",
        if log { "log" } else { "linear" },
        ns,
        ng,
        100.0 * h.joint_outside / h.total_volume.max(f64::MIN_POSITIVE)
    );
    c.text(left, 36, &sub, 1, GREY);

    // 1D histogram along the top, same x axis.
    let sc1 = ValueScale::new(&h.scalar, log);
    c.rect(left, top1, pw, ph1, WHITE);
    for x in 0..pw {
        let bin = x * ns / pw;
        if let Some(t) = sc1.map(h.scalar[bin]) {
            let bar = ((t * (ph1 - 2) as f64).round() as usize).max(1);
            c.rect(left + x, top1 + ph1 - 1 - bar, 1, bar, BAR);
        }
    }
    c.frame(left, top1, pw, ph1, BLACK);
    let lab = |v: f64| fmt_num(v);
    let top_label = lab(sc1.hi);
    c.text(left - 8 - Canvas::text_width(&top_label, 1), top1, &top_label, 1, GREY);
    let bottom_label = if log { lab(sc1.lo) } else { "0".into() };
    c.text(left - 8 - Canvas::text_width(&bottom_label, 1), top1 + ph1 - 7, &bottom_label, 1, GREY);
    c.text_up(left - 50, top1 + 10, "volume", s, BLACK);

    // Joint histogram: rows are |∇s| bins, bottom row = lowest |∇s|.
    let sc2 = ValueScale::new(&h.joint, log);
    for y in 0..ph2 {
        let g = (ph2 - 1 - y) * ng / ph2;
        for x in 0..pw {
            let sb = x * ns / pw;
            let col = sc2.map(h.joint[g * ns + sb]).map(viridis).unwrap_or(EMPTY);
            c.set(left + x, top2 + y, col);
        }
    }
    c.frame(left, top2, pw, ph2, BLACK);

    // x axis: scalar.
    for (v, f) in axis_ticks(&h.scalar_axis) {
        let x = left + ((f * (pw - 1) as f64).round() as usize).min(pw - 1);
        c.rect(x, top2 + ph2, 1, 6, BLACK);
        c.rect(x, top1 + ph1, 1, 4, BLACK);
        let t = fmt_num(v);
        let tw = Canvas::text_width(&t, s);
        c.text(x.saturating_sub(tw / 2).min(w - tw), top2 + ph2 + 10, &t, s, BLACK);
    }
    let xl = units.scalar_label(name);
    c.text(left + (pw - Canvas::text_width(&xl, s).min(pw)) / 2, top2 + ph2 + 44, &xl, s, BLACK);

    // y axis: |∇s|.
    for (v, f) in axis_ticks(&h.gradient_axis) {
        let y = top2 + ph2 - 1 - ((f * (ph2 - 1) as f64).round() as usize).min(ph2 - 1);
        c.rect(left - 6, y, 6, 1, BLACK);
        let t = fmt_num(v);
        c.text(left - 10 - Canvas::text_width(&t, 1), y.saturating_sub(3), &t, 1, BLACK);
    }
    let yl = units.gradient_label();
    let yw = Canvas::text_width(&yl, s);
    c.text_up(left - 90, top2 + (ph2 - yw.min(ph2)) / 2, &yl, s, BLACK);

    // Colour bar.
    let (bx, bw) = (left + pw + 24, 20usize);
    for y in 0..ph2 {
        let t = 1.0 - y as f64 / (ph2 - 1) as f64;
        c.rect(bx, top2 + y, bw, 1, viridis(t));
    }
    c.frame(bx, top2, bw, ph2, BLACK);
    for (v, f) in sc2.ticks() {
        let y = top2 + ph2 - 1 - ((f * (ph2 - 1) as f64).round() as usize).min(ph2 - 1);
        c.rect(bx + bw, y, 5, 1, BLACK);
        c.text(bx + bw + 8, y.saturating_sub(3), &fmt_num(v), 1, BLACK);
    }
    let cl = "volume per bin";
    c.text_up(bx + bw + 60, top2 + (ph2 - Canvas::text_width(cl, s)) / 2, cl, s, BLACK);
    c
}
