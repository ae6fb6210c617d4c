//! Piecewise-linear 1D transfer functions (spec: `formats/tf.md`) and the
//! import of ParaView colour-map presets.

use serde::{Deserialize, Serialize};

use crate::widget::{Widget, WidgetFile};
use crate::TfError;

/// How emission enters the colour integral.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum Emission {
    /// C = ∫ κ ρ T dt (VTK, Guthe et al. 2002; the default): a constant colour gives C = κ·α.
    #[default]
    Density,
    /// C = ∫ κ T dt (Röttger & Ertl 2002 and Song et al. 2009, eq. 1–2): emission independent of extinction.
    Independent,
}

/// A colour node: scalar `x` and non-premultiplied `rgb`.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ColorNode {
    pub x: f64,
    pub rgb: [f64; 3],
}

/// An opacity node: scalar `x` and VTK-style opacity `a` (an optical depth per
/// `unit_distance`, not an alpha; values above 1 are valid).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct OpacityNode {
    pub x: f64,
    pub a: f64,
}

/// A validated piecewise-linear transfer function, clamped outside its nodes.
///
/// Invariants (checked by [`TransferFunction::new`]): both node lists are
/// non-empty, strictly increasing in `x`, all values finite, colour and
/// opacity ≥ 0, `unit_distance` > 0 and finite.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(try_from = "TfFile", into = "TfFile")]
pub struct TransferFunction {
    normalized: bool,
    color: Vec<ColorNode>,
    opacity: Vec<OpacityNode>,
    unit_distance: f64,
    emission: Emission,
    widgets: Vec<Widget>,
}

/// The JSON layout of `formats/tf.md`, before validation.
#[derive(Debug, Clone, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
struct TfFile {
    #[serde(default)]
    normalized: bool,
    color: Vec<Vec<f64>>,
    opacity: Vec<Vec<f64>>,
    unit_distance: f64,
    #[serde(default)]
    emission: Emission,
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    widgets: Vec<WidgetFile>,
}

impl TryFrom<TfFile> for TransferFunction {
    type Error = TfError;
    fn try_from(f: TfFile) -> Result<Self, TfError> {
        let color =
            rows::<4>(&f.color, "color")?.into_iter().map(|[x, r, g, b]| ColorNode { x, rgb: [r, g, b] }).collect();
        let opacity = rows::<2>(&f.opacity, "opacity")?.into_iter().map(|[x, a]| OpacityNode { x, a }).collect();
        let widgets = f.widgets.iter().enumerate().map(|(i, w)| w.validate(i)).collect::<Result<Vec<_>, _>>()?;
        TransferFunction::new(color, opacity, f.unit_distance, f.emission, f.normalized)?.with_widgets(widgets)
    }
}

impl From<TransferFunction> for TfFile {
    fn from(t: TransferFunction) -> Self {
        TfFile {
            normalized: t.normalized,
            color: t.color.iter().map(|c| vec![c.x, c.rgb[0], c.rgb[1], c.rgb[2]]).collect(),
            opacity: t.opacity.iter().map(|o| vec![o.x, o.a]).collect(),
            unit_distance: t.unit_distance,
            emission: t.emission,
            widgets: t.widgets.iter().map(WidgetFile::from_widget).collect(),
        }
    }
}

fn rows<const N: usize>(list: &[Vec<f64>], name: &'static str) -> Result<Vec<[f64; N]>, TfError> {
    list.iter()
        .enumerate()
        .map(|(index, row)| {
            <[f64; N]>::try_from(row.as_slice()).map_err(|_| TfError::Arity {
                list: name,
                index,
                expected: N,
                found: row.len(),
            })
        })
        .collect()
}

fn check_xs(xs: impl Iterator<Item = f64>, name: &'static str) -> Result<(), TfError> {
    let mut prev: Option<f64> = None;
    for (index, x) in xs.enumerate() {
        if !x.is_finite() {
            return Err(TfError::NonFinite { list: name, index });
        }
        if let Some(p) = prev {
            if x == p {
                return Err(TfError::Duplicate { list: name, index, x });
            }
            if x < p {
                return Err(TfError::Unsorted { list: name, index, x, prev: p });
            }
        }
        prev = Some(x);
    }
    if prev.is_none() {
        return Err(TfError::Empty { list: name });
    }
    Ok(())
}

impl TransferFunction {
    /// Validates and builds a transfer function.
    pub fn new(
        color: Vec<ColorNode>,
        opacity: Vec<OpacityNode>,
        unit_distance: f64,
        emission: Emission,
        normalized: bool,
    ) -> Result<Self, TfError> {
        check_xs(color.iter().map(|c| c.x), "color")?;
        check_xs(opacity.iter().map(|o| o.x), "opacity")?;
        for (index, c) in color.iter().enumerate() {
            if c.rgb.iter().any(|v| !v.is_finite()) {
                return Err(TfError::NonFinite { list: "color", index });
            }
            if c.rgb.iter().any(|&v| v < 0.0) {
                return Err(TfError::Negative { list: "color", index });
            }
            // A segment's colour is at most the largest κ (density emission),
            // so bounded entries keep f32 results finite.
            if let Some(&value) = c.rgb.iter().find(|&&v| v > f32::MAX as f64) {
                return Err(TfError::TooLarge { list: "color", index, value });
            }
        }
        for (index, o) in opacity.iter().enumerate() {
            if !o.a.is_finite() {
                return Err(TfError::NonFinite { list: "opacity", index });
            }
            if o.a < 0.0 {
                return Err(TfError::Negative { list: "opacity", index });
            }
        }
        if !(unit_distance > 0.0 && unit_distance.is_finite()) {
            return Err(TfError::UnitDistance(unit_distance));
        }
        Ok(TransferFunction { normalized, color, opacity, unit_distance, emission, widgets: Vec::new() })
    }

    /// Returns a copy with these 2D widgets (Song et al. 2009; see [`crate::widget`]),
    /// checked as the JSON is: errors name `widgets[i].field`.
    pub fn with_widgets(mut self, widgets: Vec<Widget>) -> Result<Self, TfError> {
        for (index, w) in widgets.iter().enumerate() {
            let bad = |field: &'static str, reason: &str| TfError::Widget { index, field, reason: reason.into() };
            if w.color.iter().any(|c| !c.is_finite() || *c < 0.0 || *c > f32::MAX as f64) {
                return Err(bad("color", "must be finite, non-negative and at most 3.4e38 (the largest f32)"));
            }
            if !(w.opacity.is_finite() && w.opacity >= 0.0) {
                return Err(bad("opacity", "must be finite and non-negative"));
            }
            if w.support.iter().flatten().any(|x| x.is_nan()) || w.support.iter().any(|r| r[0] > r[1]) {
                return Err(bad("clip", "need lo ≤ hi, not NaN"));
            }
            match w.shape {
                crate::widget::Shape::Box { center, width } => {
                    if center.iter().any(|x| !x.is_finite()) {
                        return Err(bad("center", "value is NaN or infinite"));
                    }
                    if width.iter().any(|x| !(x.is_finite() && *x > 0.0)) {
                        return Err(bad("width", "must be positive"));
                    }
                    if w.support != crate::widget::box_support(center, width) {
                        return Err(bad("clip", "a box's support is its centre ± width/2"));
                    }
                }
                crate::widget::Shape::Gaussian { center, sigma } => {
                    if center.iter().any(|x| !x.is_finite()) {
                        return Err(bad("center", "value is NaN or infinite"));
                    }
                    if sigma.iter().any(|x| !(x.is_finite() && *x > 0.0)) {
                        return Err(bad("width", "must be positive"));
                    }
                }
                crate::widget::Shape::Triangle { frequency, phase }
                | crate::widget::Shape::Sine { frequency, phase } => {
                    if !(frequency > 0.0 && frequency <= crate::widget::MAX_FREQUENCY) {
                        return Err(bad("frequency", "must be positive and at most 1e6"));
                    }
                    if !phase.is_finite() {
                        return Err(bad("phase", "value is NaN or infinite"));
                    }
                }
            }
        }
        self.widgets = widgets;
        Ok(self)
    }

    /// The 2D widgets (empty for a purely 1D transfer function).
    pub fn widgets(&self) -> &[Widget] {
        &self.widgets
    }

    /// The 1D part alone (widgets dropped).
    pub fn without_widgets(&self) -> Self {
        TransferFunction { widgets: Vec::new(), ..self.clone() }
    }

    /// Parses and validates the JSON of `formats/tf.md`.
    pub fn from_json(text: &str) -> Result<Self, TfError> {
        let raw: TfFile = serde_json::from_str(text).map_err(|e| TfError::Json(e.to_string()))?;
        raw.try_into()
    }

    /// The JSON of `formats/tf.md` (round-trips through [`Self::from_json`]).
    pub fn to_json(&self) -> String {
        serde_json::to_string_pretty(&TfFile::from(self.clone())).expect("plain numbers serialize")
    }

    /// Imports a ParaView colour-map preset (a JSON list of presets, or one
    /// object): the first preset, or the one whose "Name" is `name`.
    ///
    /// "RGBPoints" (flat x,r,g,b,…) gives the colour; "Points" (flat
    /// x,a,midpoint,sharpness,…) the opacity, or a constant 1 when absent.
    /// Only midpoint 0.5 and sharpness 0 (which are exactly linear) are
    /// accepted; other values are an error rather than silently wrong. The
    /// colour is interpolated linearly in RGB whatever "ColorSpace" says (the
    /// optical model needs linear pieces). The result is `normalized`: x is
    /// rescaled from the preset's own span onto [0, 1], as ParaView rescales
    /// a preset to the data range.
    ///
    /// To read a file, use [`crate::load_tf`], which takes either format.
    pub fn from_paraview_json(text: &str, name: Option<&str>, unit_distance: f64) -> Result<Self, TfError> {
        let v: serde_json::Value = serde_json::from_str(text).map_err(|e| TfError::Json(e.to_string()))?;
        Self::from_paraview_value(&v, name, unit_distance)
    }

    /// [`Self::from_paraview_json`] of parsed JSON.
    pub(crate) fn from_paraview_value(
        v: &serde_json::Value,
        name: Option<&str>,
        unit_distance: f64,
    ) -> Result<Self, TfError> {
        let presets: Vec<&serde_json::Value> = match v {
            serde_json::Value::Array(a) => a.iter().collect(),
            o @ serde_json::Value::Object(_) => vec![o],
            _ => return Err(TfError::Preset("expected a preset object or a list of them".into())),
        };
        let preset = match name {
            None => presets.first().copied(),
            Some(n) => presets.iter().copied().find(|p| p.get("Name").and_then(|x| x.as_str()) == Some(n)),
        }
        .ok_or_else(|| {
            TfError::Preset(format!("no preset{}", name.map(|n| format!(" named {n:?}")).unwrap_or_default()))
        })?;
        let flat = |key: &'static str| -> Result<Option<Vec<f64>>, TfError> {
            match preset.get(key) {
                None => Ok(None),
                Some(serde_json::Value::Array(a)) => a
                    .iter()
                    .enumerate()
                    .map(|(i, x)| x.as_f64().ok_or_else(|| TfError::Preset(format!("{key}[{i}] is not a number"))))
                    .collect::<Result<Vec<_>, _>>()
                    .map(Some),
                Some(_) => Err(TfError::Preset(format!("{key} is not a list"))),
            }
        };
        let rgb = flat("RGBPoints")?.ok_or_else(|| TfError::Preset("no RGBPoints".into()))?;
        if rgb.is_empty() || rgb.len() % 4 != 0 {
            return Err(TfError::Preset(format!("RGBPoints has {} numbers, not a non-zero multiple of 4", rgb.len())));
        }
        let mut color: Vec<ColorNode> =
            rgb.chunks_exact(4).map(|c| ColorNode { x: c[0], rgb: [c[1], c[2], c[3]] }).collect();
        let mut opacity = match flat("Points")? {
            None => vec![OpacityNode { x: color[0].x, a: 1.0 }],
            Some(p) => {
                if p.is_empty() || p.len() % 4 != 0 {
                    return Err(TfError::Preset(format!(
                        "Points has {} numbers, not a non-zero multiple of 4",
                        p.len()
                    )));
                }
                let mut out = Vec::with_capacity(p.len() / 4);
                for (index, q) in p.chunks_exact(4).enumerate() {
                    if q[2] != 0.5 || q[3] != 0.0 {
                        return Err(TfError::Preset(format!(
                            "Points entry {index}: midpoint {} sharpness {} (only 0.5 and 0, the linear case, are supported)",
                            q[2], q[3]
                        )));
                    }
                    out.push(OpacityNode { x: q[0], a: q[1] });
                }
                out
            }
        };
        let lo = color[0].x.min(opacity[0].x);
        let hi = color[color.len() - 1].x.max(opacity[opacity.len() - 1].x);
        if hi > lo {
            let s = 1.0 / (hi - lo);
            color.iter_mut().for_each(|c| c.x = (c.x - lo) * s);
            opacity.iter_mut().for_each(|o| o.x = (o.x - lo) * s);
        }
        TransferFunction::new(color, opacity, unit_distance, Emission::Density, true)
    }

    /// Maps a normalized TF's x ∈ [0,1] onto [lo, hi] (e.g. a bundle's
    /// scalar range); the result is not normalized. Needs lo < hi, finite.
    pub fn denormalize(&self, lo: f64, hi: f64) -> Result<Self, TfError> {
        if !(lo.is_finite() && hi.is_finite() && lo < hi) {
            return Err(TfError::Range { lo, hi });
        }
        let m = |x: f64| lo + x * (hi - lo);
        let color = self.color.iter().map(|c| ColorNode { x: m(c.x), ..*c }).collect();
        let opacity = self.opacity.iter().map(|o| OpacityNode { x: m(o.x), ..*o }).collect();
        let widgets = self.widgets.iter().map(|w| w.denormalized(lo, hi)).collect();
        TransferFunction::new(color, opacity, self.unit_distance, self.emission, false)?.with_widgets(widgets)
    }

    pub fn normalized(&self) -> bool {
        self.normalized
    }
    pub fn color_nodes(&self) -> &[ColorNode] {
        &self.color
    }
    pub fn opacity_nodes(&self) -> &[OpacityNode] {
        &self.opacity
    }
    /// World length over which opacity `a` is an optical depth of `a`.
    pub fn unit_distance(&self) -> f64 {
        self.unit_distance
    }
    pub fn emission(&self) -> Emission {
        self.emission
    }
    /// Returns a copy with another emission model.
    pub fn with_emission(mut self, emission: Emission) -> Self {
        self.emission = emission;
        self
    }

    /// Emission colour κ(s), clamped outside the nodes.
    pub fn color(&self, s: f64) -> [f64; 3] {
        let n = &self.color;
        let i = n.partition_point(|c| c.x <= s);
        if i == 0 {
            return n[0].rgb;
        }
        if i == n.len() {
            return n[n.len() - 1].rgb;
        }
        let (a, b) = (&n[i - 1], &n[i]);
        let t = (s - a.x) / (b.x - a.x);
        std::array::from_fn(|k| a.rgb[k] + t * (b.rgb[k] - a.rgb[k]))
    }

    /// Extinction ρ(s) = a(s)/u per unit world length, clamped outside the nodes.
    pub fn extinction(&self, s: f64) -> f64 {
        self.extinction_from(self.opacity.partition_point(|o| o.x <= s), s)
    }

    /// [`Self::extinction`] at `s` given the index of the first opacity node
    /// past it (`partition_point(x ≤ s)`).
    fn extinction_from(&self, i: usize, s: f64) -> f64 {
        let n = &self.opacity;
        let a = if i == 0 {
            n[0].a
        } else if i == n.len() {
            n[n.len() - 1].a
        } else {
            let (p, q) = (&n[i - 1], &n[i]);
            p.a + (s - p.x) / (q.x - p.x) * (q.a - p.a)
        };
        a / self.unit_distance
    }

    /// The extinction along a segment whose scalar runs linearly from `sf`
    /// to `sb`: `[fraction of the way, ρ]` at its start, at every opacity
    /// node strictly between, and at its end, in order from `sf` (into
    /// `out`, cleared first). ρ is linear between consecutive entries, so
    /// the optical depth of a length-`len` segment is the trapezoid sum
    /// `len · Σ (f₁ − f₀)(ρ₀ + ρ₁)/2`, exactly [`crate::optical_depth_with`]'s,
    /// and quadratic inside each piece. Colour nodes do not bend ρ and are
    /// left out.
    pub fn extinction_knots(&self, sf: f64, sb: f64, out: &mut Vec<[f64; 2]>) {
        // One search: the nodes strictly inside follow the first past the
        // low end, and the first past the high end follows them.
        let n = &self.opacity;
        let (lo, hi) = (sf.min(sb), sf.max(sb));
        let first = n.partition_point(|o| o.x <= lo);
        let mut end = first;
        while end < n.len() && n[end].x < hi {
            end += 1;
        }
        let mut past_hi = end;
        while past_hi < n.len() && n[past_hi].x <= hi {
            past_hi += 1;
        }
        let (rho_lo, rho_hi) = (self.extinction_from(first, lo), self.extinction_from(past_hi, hi));
        out.clear();
        out.push([0.0, if sf <= sb { rho_lo } else { rho_hi }]);
        if sf != sb {
            let knot = |o: &OpacityNode| [(o.x - sf) / (sb - sf), o.a / self.unit_distance];
            let at = out.len();
            out.extend(n[first..end].iter().map(knot));
            if sb < sf {
                out[at..].reverse();
            }
        }
        out.push([1.0, if sf <= sb { rho_hi } else { rho_lo }]);
    }

    /// The largest colour component at any node (κ never exceeds it).
    pub fn max_color(&self) -> [f64; 3] {
        let mut m = [0.0f64; 3];
        for c in &self.color {
            for (mk, ck) in m.iter_mut().zip(c.rgb) {
                *mk = mk.max(ck);
            }
        }
        m
    }

    /// Extinction ρ(s, g) per unit world length: the 1D part plus every
    /// widget (Song et al. 2009 sums extinctions).
    pub fn extinction2(&self, s: f64, g: f64) -> f64 {
        let mut rho = self.extinction(s);
        for w in &self.widgets {
            rho += w.opacity * w.shape_at(s, g) / self.unit_distance;
        }
        rho
    }

    /// The emission term E(s, g) of dC = E·T dt: κ₁D ρ₁D + Σ c_w ρ_w
    /// (density) or κ₁D + Σ c_w·[in support] (independent). See [`crate::widget`].
    pub fn emission2(&self, s: f64, g: f64) -> [f64; 3] {
        let k = self.color(s);
        match self.emission {
            Emission::Density => {
                let r = self.extinction(s);
                let mut e = [k[0] * r, k[1] * r, k[2] * r];
                for w in &self.widgets {
                    let rw = w.opacity * w.shape_at(s, g) / self.unit_distance;
                    for (ec, wc) in e.iter_mut().zip(w.color) {
                        *ec += wc * rw;
                    }
                }
                e
            }
            Emission::Independent => {
                let mut e = k;
                for w in self.widgets.iter().filter(|w| w.contains(s, g)) {
                    for (ec, wc) in e.iter_mut().zip(w.color) {
                        *ec += wc;
                    }
                }
                e
            }
        }
    }

    /// Colour κ(s, g) such that the emission is κ·ρ (density: the
    /// extinction-weighted mean colour, κ₁D where ρ = 0) or κ (independent).
    pub fn color2(&self, s: f64, g: f64) -> [f64; 3] {
        let e = self.emission2(s, g);
        match self.emission {
            Emission::Independent => e,
            Emission::Density => {
                let r = self.extinction2(s, g);
                if r > 0.0 {
                    [e[0] / r, e[1] / r, e[2] / r]
                } else {
                    self.color(s)
                }
            }
        }
    }

    /// Conservative per-cell culling (Song et al. 2009 §3.1): true only when every
    /// (s, g) in the closed box [s_range] × [g_range] contributes nothing —
    /// zero extinction (density emission), or zero extinction and zero
    /// emission (independent). A true answer is a proof; false may be
    /// pessimistic (banded widgets are never zero on an interval; a
    /// Gaussian's tails are positive everywhere in its clip box).
    /// NaN or reversed ranges are never culled.
    pub fn cell_is_invisible(&self, s_range: [f64; 2], g_range: [f64; 2]) -> bool {
        let ([s0, s1], [g0, g1]) = (s_range, g_range);
        if !(s0 <= s1 && g0 <= g1) {
            return false;
        }
        // Piecewise-linear: the maximum over [s0, s1] is at an end or a node.
        let mut xs = vec![s0, s1];
        self.breakpoints_between(s0, s1, &mut xs);
        if xs.iter().any(|&x| self.extinction(x) > 0.0) {
            return false;
        }
        let independent = self.emission == Emission::Independent;
        if independent && xs.iter().any(|&x| self.color(x).iter().any(|&c| c > 0.0)) {
            return false;
        }
        !self.widgets.iter().any(|w| {
            w.support_meets(s_range, g_range) && (w.opacity > 0.0 || (independent && w.color.iter().any(|&c| c > 0.0)))
        })
    }

    /// The frequency limit of Song et al., "Bivariate Transfer Functions on
    /// Unstructured Grids", 2009: a banded widget's closed forms assume at
    /// most one peak per cell, which holds when its period 1/f exceeds the
    /// largest per-cell scalar range `max_cell_ds`. Returns (widget index,
    /// frequency, largest allowed frequency 1/max_cell_ds) for each widget
    /// over the limit. (`biv-exact` here splits at every band crossing, so it
    /// stays exact past the limit; the check is for the seed's tables.)
    pub fn band_frequency_violations(&self, max_cell_ds: f64) -> Vec<(usize, f64, f64)> {
        let limit = 1.0 / max_cell_ds;
        self.widgets
            .iter()
            .enumerate()
            .filter_map(|(i, w)| w.frequency().filter(|&f| f >= limit).map(|f| (i, f, limit)))
            .collect()
    }

    /// Every node x (colour and opacity) strictly between `lo` and `hi`, sorted
    /// ascending and deduplicated, appended to `out`: between two of them
    /// colour and extinction are linear in the scalar.
    pub fn breakpoints_between(&self, lo: f64, hi: f64, out: &mut Vec<f64>) {
        let start = out.len();
        let c0 = self.color.partition_point(|c| c.x <= lo);
        let o0 = self.opacity.partition_point(|o| o.x <= lo);
        let (mut i, mut j) = (c0, o0);
        loop {
            let cx = self.color.get(i).map(|c| c.x).filter(|&x| x < hi);
            let ox = self.opacity.get(j).map(|o| o.x).filter(|&x| x < hi);
            let x = match (cx, ox) {
                (None, None) => break,
                (Some(a), None) => {
                    i += 1;
                    a
                }
                (None, Some(b)) => {
                    j += 1;
                    b
                }
                (Some(a), Some(b)) => {
                    if a <= b {
                        i += 1;
                    }
                    if b <= a {
                        j += 1;
                    }
                    a.min(b)
                }
            };
            if out.len() == start || out[out.len() - 1] != x {
                out.push(x);
            }
        }
    }
}
