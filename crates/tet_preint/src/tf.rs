//! Piecewise-linear 1D transfer functions (spec: `formats/tf.md`) and the
//! import of ParaView colour-map presets.

use serde::{Deserialize, Serialize};

use crate::TfError;

/// How emission enters the colour integral.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum Emission {
    /// C = ∫ κ ρ T dt (VTK, seed 003; the default): a constant colour gives C = κ·α.
    #[default]
    Density,
    /// C = ∫ κ T dt (seeds 000 and 004, eq. 1–2): emission independent of extinction.
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
}

impl TryFrom<TfFile> for TransferFunction {
    type Error = TfError;
    fn try_from(f: TfFile) -> Result<Self, TfError> {
        let color =
            rows::<4>(&f.color, "color")?.into_iter().map(|[x, r, g, b]| ColorNode { x, rgb: [r, g, b] }).collect();
        let opacity = rows::<2>(&f.opacity, "opacity")?.into_iter().map(|[x, a]| OpacityNode { x, a }).collect();
        TransferFunction::new(color, opacity, f.unit_distance, f.emission, f.normalized)
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
        Ok(TransferFunction { normalized, color, opacity, unit_distance, emission })
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
    pub fn from_paraview_json(text: &str, name: Option<&str>, unit_distance: f64) -> Result<Self, TfError> {
        let v: serde_json::Value = serde_json::from_str(text).map_err(|e| TfError::Json(e.to_string()))?;
        let presets: Vec<&serde_json::Value> = match &v {
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
        TransferFunction::new(color, opacity, self.unit_distance, self.emission, false)
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
        let n = &self.opacity;
        let i = n.partition_point(|o| o.x <= s);
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

    /// Every node x (colour and opacity) strictly between `lo` and `hi`, sorted
    /// ascending and deduplicated, appended to `out`.
    pub(crate) fn breakpoints_between(&self, lo: f64, hi: f64, out: &mut Vec<f64>) {
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
