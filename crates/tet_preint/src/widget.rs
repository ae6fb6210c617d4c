//! 2D transfer-function widgets over (scalar s, gradient magnitude g), Song et al. 2009:
//! uniform box, Gaussian, triangle-wave bands and sine-wave bands
//! (JSON: `formats/tf.md`, "widgets").
//!
//! Each widget has a constant colour c, a maximum VTK-style opacity a (an
//! optical depth per `unit_distance`, like the 1D opacity), a shape m(s, g) ∈
//! [0, 1] and a closed support rectangle outside which it is zero:
//!
//! * box: m = 1 on [s_c ± w_s/2] × [g_c ± w_g/2];
//! * Gaussian: m = exp(−(s − s_c)²/(2σ_s²) − (g − g_c)²/(2σ_g²)), optional `clip`;
//! * triangle bands: m = 1 − 2|x − round(x)|, x = f·s − φ (peaks where x is an
//!   integer, zeros at half-integers), optional `clip`;
//! * sine bands: m = (1 + cos 2πx)/2, same x, optional `clip`.
//!
//! Combination with the 1D part (Song et al. 2009 sums extinctions): ρ(s, g) =
//! ρ₁D(s) + Σ a_w m_w/u. Density emission: κρ = κ₁D ρ₁D + Σ c_w a_w m_w/u, i.e.
//! the colour is the extinction-weighted mean of the parts. Independent
//! emission: κ = κ₁D(s) + Σ c_w·[(s, g) in support_w] (each widget emits its
//! colour over its support, as Song et al.'s (2009) uniform and Gaussian integrals assume).

use serde::{Deserialize, Serialize};

use crate::TfError;

/// The shape of a widget and its parameters.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Shape {
    /// Uniform over the support rectangle centre ± width/2.
    Box { center: [f64; 2], width: [f64; 2] },
    /// Gaussian with centre and standard deviations.
    Gaussian { center: [f64; 2], sigma: [f64; 2] },
    /// Triangle-wave bands in s: `frequency` bands per scalar unit, peaks at f·s − φ ∈ ℤ.
    Triangle { frequency: f64, phase: f64 },
    /// Sine-wave bands in s: (1 + cos 2π(f·s − φ))/2.
    Sine { frequency: f64, phase: f64 },
}

/// One validated widget.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Widget {
    pub shape: Shape,
    /// Emission colour, not premultiplied, ≥ 0.
    pub color: [f64; 3],
    /// Maximum VTK-style opacity (optical depth per unit distance), ≥ 0.
    pub opacity: f64,
    /// Closed support [[s_lo, s_hi], [g_lo, g_hi]]; ±`f64::MAX` where unbounded
    /// (so it round-trips through JSON).
    pub support: [[f64; 2]; 2],
}

/// The support of an unclipped widget.
pub const UNBOUNDED: [[f64; 2]; 2] = [[-f64::MAX, f64::MAX]; 2];

/// Above this many bands per scalar unit a widget is refused (the band
/// crossings of one segment are enumerated).
pub const MAX_FREQUENCY: f64 = 1e6;

impl Widget {
    /// m(s, g) ∈ [0, 1] inside the support, 0 outside.
    pub fn shape_at(&self, s: f64, g: f64) -> f64 {
        if !self.contains(s, g) {
            return 0.0;
        }
        self.shape_unclipped(s, g)
    }

    /// m(s, g) ignoring the support.
    pub fn shape_unclipped(&self, s: f64, g: f64) -> f64 {
        match self.shape {
            Shape::Box { .. } => 1.0,
            Shape::Gaussian { center, sigma } => {
                let (ds, dg) = ((s - center[0]) / sigma[0], (g - center[1]) / sigma[1]);
                (-0.5 * (ds * ds + dg * dg)).exp()
            }
            Shape::Triangle { frequency, phase } => {
                let x = frequency * s - phase;
                1.0 - 2.0 * (x - x.round()).abs()
            }
            Shape::Sine { frequency, phase } => {
                let x = frequency * s - phase;
                0.5 * (1.0 + (2.0 * std::f64::consts::PI * (x - x.round())).cos())
            }
        }
    }

    /// Whether (s, g) lies in the closed support.
    pub fn contains(&self, s: f64, g: f64) -> bool {
        let [[s0, s1], [g0, g1]] = self.support;
        s >= s0 && s <= s1 && g >= g0 && g <= g1
    }

    /// Whether the closed rectangle [s_range] × [g_range] meets the support.
    pub fn support_meets(&self, s_range: [f64; 2], g_range: [f64; 2]) -> bool {
        let [[s0, s1], [g0, g1]] = self.support;
        s_range[1] >= s0 && s_range[0] <= s1 && g_range[1] >= g0 && g_range[0] <= g1
    }

    /// The band frequency, for banded widgets.
    pub fn frequency(&self) -> Option<f64> {
        match self.shape {
            Shape::Triangle { frequency, .. } | Shape::Sine { frequency, .. } => Some(frequency),
            _ => None,
        }
    }

    /// The widget after the scalar map s' = lo + s·(hi − lo) (g unchanged).
    pub(crate) fn denormalized(&self, lo: f64, hi: f64) -> Widget {
        let span = hi - lo;
        let m = |x: f64| lo + x * span;
        let shape = match self.shape {
            Shape::Box { center, width } => {
                Shape::Box { center: [m(center[0]), center[1]], width: [width[0] * span, width[1]] }
            }
            Shape::Gaussian { center, sigma } => {
                Shape::Gaussian { center: [m(center[0]), center[1]], sigma: [sigma[0] * span, sigma[1]] }
            }
            Shape::Triangle { frequency, phase } => {
                Shape::Triangle { frequency: frequency / span, phase: phase + frequency * lo / span }
            }
            Shape::Sine { frequency, phase } => {
                Shape::Sine { frequency: frequency / span, phase: phase + frequency * lo / span }
            }
        };
        // ±f64::MAX marks an unbounded side: keep it (scaling would overflow
        // to ±inf, which JSON cannot hold).
        let side = |x: f64| if x.abs() == f64::MAX { x } else { m(x) };
        let [[s0, s1], g] = self.support;
        Widget { shape, support: [[side(s0), side(s1)], g], ..*self }
    }
}

/// A widget as written in JSON, before validation.
#[derive(Debug, Clone, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub(crate) struct WidgetFile {
    #[serde(rename = "type")]
    kind: String,
    color: Vec<f64>,
    opacity: f64,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    center: Option<Vec<f64>>,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    width: Option<Vec<f64>>,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    frequency: Option<f64>,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    phase: Option<f64>,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    clip: Option<Vec<Vec<f64>>>,
}

/// The support of a box widget.
pub fn box_support(center: [f64; 2], width: [f64; 2]) -> [[f64; 2]; 2] {
    [[center[0] - 0.5 * width[0], center[0] + 0.5 * width[0]], [center[1] - 0.5 * width[1], center[1] + 0.5 * width[1]]]
}

fn err(index: usize, field: &'static str, reason: impl Into<String>) -> TfError {
    TfError::Widget { index, field, reason: reason.into() }
}

fn pair(index: usize, field: &'static str, v: &Option<Vec<f64>>) -> Result<[f64; 2], TfError> {
    let v = v.as_ref().ok_or_else(|| err(index, field, "missing"))?;
    let p: [f64; 2] =
        v.as_slice().try_into().map_err(|_| err(index, field, format!("expected 2 numbers, found {}", v.len())))?;
    if p.iter().any(|x| !x.is_finite()) {
        return Err(err(index, field, "value is NaN or infinite"));
    }
    Ok(p)
}

fn positive_pair(index: usize, field: &'static str, v: &Option<Vec<f64>>) -> Result<[f64; 2], TfError> {
    let p = pair(index, field, v)?;
    if p.iter().any(|&x| x <= 0.0) {
        return Err(err(index, field, "must be positive"));
    }
    Ok(p)
}

impl WidgetFile {
    pub(crate) fn validate(&self, index: usize) -> Result<Widget, TfError> {
        let color: [f64; 3] = self
            .color
            .as_slice()
            .try_into()
            .map_err(|_| err(index, "color", format!("expected 3 numbers, found {}", self.color.len())))?;
        if color.iter().any(|x| !x.is_finite()) {
            return Err(err(index, "color", "value is NaN or infinite"));
        }
        if color.iter().any(|&x| x < 0.0) {
            return Err(err(index, "color", "negative value"));
        }
        if !self.opacity.is_finite() {
            return Err(err(index, "opacity", "value is NaN or infinite"));
        }
        if self.opacity < 0.0 {
            return Err(err(index, "opacity", "negative value"));
        }
        let unbounded = UNBOUNDED;
        let clip = match &self.clip {
            None => unbounded,
            Some(rows) => {
                if rows.len() != 2 {
                    return Err(err(
                        index,
                        "clip",
                        format!("expected [[s_lo, s_hi], [g_lo, g_hi]], found {} rows", rows.len()),
                    ));
                }
                let mut out = unbounded;
                for (k, row) in rows.iter().enumerate() {
                    let r: [f64; 2] = row
                        .as_slice()
                        .try_into()
                        .map_err(|_| err(index, "clip", format!("row {k}: expected 2 numbers, found {}", row.len())))?;
                    if r.iter().any(|x| x.is_nan()) || r[0] > r[1] {
                        return Err(err(index, "clip", format!("row {k}: need lo ≤ hi, not NaN")));
                    }
                    out[k] = r;
                }
                out
            }
        };
        let refuse = |field: &'static str, present: bool| {
            if present {
                Err(err(index, field, format!("not a field of a {} widget", self.kind)))
            } else {
                Ok(())
            }
        };
        let banded = |index: usize| -> Result<(f64, f64), TfError> {
            let f = self.frequency.ok_or_else(|| err(index, "frequency", "missing"))?;
            if !(f > 0.0 && f <= MAX_FREQUENCY) {
                return Err(err(index, "frequency", format!("must be positive and at most {MAX_FREQUENCY}")));
            }
            let p = self.phase.unwrap_or(0.0);
            if !p.is_finite() {
                return Err(err(index, "phase", "value is NaN or infinite"));
            }
            Ok((f, p))
        };
        let (shape, support) = match self.kind.as_str() {
            "box" => {
                refuse("frequency", self.frequency.is_some())?;
                refuse("phase", self.phase.is_some())?;
                refuse("clip", self.clip.is_some())?;
                let c = pair(index, "center", &self.center)?;
                let w = positive_pair(index, "width", &self.width)?;
                (Shape::Box { center: c, width: w }, box_support(c, w))
            }
            "gaussian" => {
                refuse("frequency", self.frequency.is_some())?;
                refuse("phase", self.phase.is_some())?;
                let center = pair(index, "center", &self.center)?;
                let sigma = positive_pair(index, "width", &self.width)?;
                (Shape::Gaussian { center, sigma }, clip)
            }
            "triangle" | "sine" => {
                refuse("center", self.center.is_some())?;
                refuse("width", self.width.is_some())?;
                let (frequency, phase) = banded(index)?;
                let shape = if self.kind == "triangle" {
                    Shape::Triangle { frequency, phase }
                } else {
                    Shape::Sine { frequency, phase }
                };
                (shape, clip)
            }
            other => {
                return Err(err(
                    index,
                    "type",
                    format!("unknown widget type {other:?} (box, gaussian, triangle, sine)"),
                ))
            }
        };
        Ok(Widget { shape, color, opacity: self.opacity, support })
    }

    pub(crate) fn from_widget(w: &Widget) -> Self {
        let finite_clip = |s: [[f64; 2]; 2]| (s != UNBOUNDED).then(|| s.iter().map(|r| r.to_vec()).collect::<Vec<_>>());
        let base = WidgetFile {
            kind: String::new(),
            color: w.color.to_vec(),
            opacity: w.opacity,
            center: None,
            width: None,
            frequency: None,
            phase: None,
            clip: None,
        };
        match w.shape {
            Shape::Box { center, width } => {
                WidgetFile { kind: "box".into(), center: Some(center.to_vec()), width: Some(width.to_vec()), ..base }
            }
            Shape::Gaussian { center, sigma } => WidgetFile {
                kind: "gaussian".into(),
                center: Some(center.to_vec()),
                width: Some(sigma.to_vec()),
                clip: finite_clip(w.support),
                ..base
            },
            Shape::Triangle { frequency, phase } | Shape::Sine { frequency, phase } => WidgetFile {
                kind: if matches!(w.shape, Shape::Triangle { .. }) { "triangle" } else { "sine" }.into(),
                frequency: Some(frequency),
                phase: Some(phase),
                clip: finite_clip(w.support),
                ..base
            },
        }
    }
}
