//! The transfer-function editor's model, without a window: control points
//! that the editor adds, drags and removes, kept valid at every step.
//!
//! Contract: after any sequence of edits, [`TfModel::to_tf`] succeeds — both
//! node lists are non-empty, strictly increasing in x and inside
//! [`TfModel::range`], colours and opacities finite and ≥ 0. A drag never
//! reorders nodes (a node stops `min_gap` short of its neighbours, as in
//! ParaView's editor), so the index a UI holds stays valid during a drag.
//! The model works in data units: a normalized TF is mapped onto the
//! bundle's scalar range when loaded, and saved denormalized.

use tet_analysis::Histograms;
use tet_preint::widget::{box_support, MAX_FREQUENCY, UNBOUNDED};
use tet_preint::{ColorNode, Emission, OpacityNode, Shape, TfError, TransferFunction, Widget};

/// The four widget kinds of Song et al. 2009, for creating one with defaults
/// ([`TfModel::add_widget_in`]).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum WidgetKind {
    Box,
    Gaussian,
    /// Triangle-wave bands in s.
    Triangle,
    /// Sine-wave bands in s.
    Sine,
}

impl WidgetKind {
    pub const ALL: [WidgetKind; 4] = [WidgetKind::Box, WidgetKind::Gaussian, WidgetKind::Triangle, WidgetKind::Sine];

    /// The name used in TF JSON (`"box"`, `"gaussian"`, `"triangle"`, `"sine"`).
    pub fn id(self) -> &'static str {
        match self {
            WidgetKind::Box => "box",
            WidgetKind::Gaussian => "gaussian",
            WidgetKind::Triangle => "triangle",
            WidgetKind::Sine => "sine",
        }
    }

    pub fn of(shape: &Shape) -> WidgetKind {
        match shape {
            Shape::Box { .. } => WidgetKind::Box,
            Shape::Gaussian { .. } => WidgetKind::Gaussian,
            Shape::Triangle { .. } => WidgetKind::Triangle,
            Shape::Sine { .. } => WidgetKind::Sine,
        }
    }
}

/// How many bands a new banded widget puts across its region.
pub const DEFAULT_BANDS: f64 = 4.0;

/// The (scalar, |∇s|) rectangle `[[s_lo, s_hi], [g_lo, g_hi]]` that holds
/// the joint histogram's volume but for a fraction `tail` (clamped to
/// [0, 0.49]) cut from each end of each marginal, snapped out to bin edges;
/// `None` when the joint histogram is empty or its arrays do not match its
/// axes. New widgets are placed in it, where the data are.
pub fn populated_region(h: &Histograms, tail: f64) -> Option<[[f64; 2]; 2]> {
    let (ns, ng) = (h.scalar_axis.bins as usize, h.gradient_axis.bins as usize);
    if h.joint.len() != ns.checked_mul(ng)? || ns == 0 || ng == 0 {
        return None;
    }
    let mut s_marg = vec![0.0; ns];
    let mut g_marg = vec![0.0; ng];
    for (g, row) in h.joint.chunks_exact(ns).enumerate() {
        for (s, &v) in row.iter().enumerate() {
            if v.is_finite() && v > 0.0 {
                s_marg[s] += v;
                g_marg[g] += v;
            }
        }
    }
    let total: f64 = s_marg.iter().sum();
    if total.is_nan() || total <= 0.0 {
        return None;
    }
    let cut = total * if tail.is_finite() { tail.clamp(0.0, 0.49) } else { 0.0 };
    // First bin whose cumulative volume passes `cut` (and holds volume).
    let first = |m: &[f64]| {
        let mut acc = 0.0;
        m.iter().position(|&v| {
            acc += v;
            v > 0.0 && acc > cut
        })
    };
    let span = |m: &[f64]| -> Option<[usize; 2]> {
        let lo = first(m)?;
        let rev: Vec<f64> = m.iter().rev().copied().collect();
        let hi = m.len() - 1 - first(&rev)?;
        Some([lo, hi.max(lo)])
    };
    let [s0, s1] = span(&s_marg)?;
    let [g0, g1] = span(&g_marg)?;
    Some([
        [h.scalar_axis.edge(s0), h.scalar_axis.edge(s1 + 1)],
        [h.gradient_axis.edge(g0), h.gradient_axis.edge(g1 + 1)],
    ])
}

/// Frequency and phase of `bands` bands across `s_range` with a peak at its
/// centre (x = f·s − φ is 0 there).
pub fn band_defaults(s_range: [f64; 2], bands: f64) -> (f64, f64) {
    let width = s_range[1] - s_range[0];
    let width = if width.is_finite() && width > 0.0 { width } else { 1.0 };
    let bands = if bands.is_finite() && bands > 0.0 { bands } else { DEFAULT_BANDS };
    let frequency = (bands / width).min(MAX_FREQUENCY);
    let centre = 0.5 * (s_range[0] + s_range[1]);
    let phase = frequency * centre;
    (frequency, if phase.is_finite() { phase } else { 0.0 })
}

/// An editable transfer function over a scalar range (data units).
#[derive(Debug, Clone, PartialEq)]
pub struct TfModel {
    range: [f64; 2],
    color: Vec<ColorNode>,
    opacity: Vec<OpacityNode>,
    unit_distance: f64,
    emission: Emission,
    widgets: Vec<Widget>,
    /// Incremented by every edit that changes the TF.
    revision: u64,
}

/// Smallest x distance between neighbouring nodes, as a fraction of the range.
const MIN_GAP_FRACTION: f64 = 1e-4;

impl TfModel {
    /// The model of `tf` over `scalar_range` (a normalized TF is mapped onto
    /// it). The editor's range is `scalar_range` widened to the TF's nodes.
    pub fn new(tf: &TransferFunction, scalar_range: [f64; 2]) -> Result<TfModel, TfError> {
        let [mut lo, mut hi] = scalar_range;
        if !(lo.is_finite() && hi.is_finite()) {
            (lo, hi) = (0.0, 1.0);
        }
        // The one constant-scalar policy (as tetlut's and tetview's).
        (lo, hi) = tet_preint::normalized_tf_range(lo, hi);
        let tf = if tf.normalized() { tf.denormalize(lo, hi)? } else { tf.clone() };
        let xs = tf.color_nodes().iter().map(|c| c.x).chain(tf.opacity_nodes().iter().map(|o| o.x));
        for x in xs {
            lo = lo.min(x);
            hi = hi.max(x);
        }
        Ok(TfModel {
            range: [lo, hi],
            color: tf.color_nodes().to_vec(),
            opacity: tf.opacity_nodes().to_vec(),
            unit_distance: tf.unit_distance(),
            emission: tf.emission(),
            widgets: tf.widgets().to_vec(),
            revision: 0,
        })
    }

    /// A fixed blue-to-orange colour ramp with a linear opacity ramp over
    /// `scalar_range`, for tests and examples (the viewer opens on
    /// tet_preint's `choose_tf`: the given TF or the bundle's automatic
    /// one); `unit_distance` sets the scale of opacity.
    pub fn ramp(scalar_range: [f64; 2], unit_distance: f64) -> TfModel {
        let u = if unit_distance > 0.0 && unit_distance.is_finite() { unit_distance } else { 1.0 };
        let tf = TransferFunction::new(
            vec![ColorNode { x: 0.0, rgb: [0.1, 0.2, 1.0] }, ColorNode { x: 1.0, rgb: [1.0, 0.4, 0.1] }],
            vec![OpacityNode { x: 0.0, a: 0.0 }, OpacityNode { x: 1.0, a: 1.0 }],
            u,
            Emission::Density,
            true,
        )
        .expect("constant nodes are valid");
        TfModel::new(&tf, scalar_range).expect("a finite, non-empty range denormalizes")
    }

    pub fn range(&self) -> [f64; 2] {
        self.range
    }
    pub fn color_nodes(&self) -> &[ColorNode] {
        &self.color
    }
    pub fn opacity_nodes(&self) -> &[OpacityNode] {
        &self.opacity
    }
    pub fn unit_distance(&self) -> f64 {
        self.unit_distance
    }
    /// Changes with every edit (the viewer re-bakes when it does).
    pub fn revision(&self) -> u64 {
        self.revision
    }

    fn min_gap(&self) -> f64 {
        (self.range[1] - self.range[0]) * MIN_GAP_FRACTION
    }

    /// `x` clamped into the range and strictly between the neighbours of
    /// node `i` of a list with these xs (`None`: not inside, for inserts).
    fn clamp_between(&self, xs: &[f64], i: usize, x: f64) -> f64 {
        let gap = self.min_gap();
        let lo = if i > 0 { xs[i - 1] + gap } else { self.range[0] };
        let hi = if i + 1 < xs.len() { xs[i + 1] - gap } else { self.range[1] };
        let x = if x.is_finite() { x } else { xs[i] };
        if lo > hi {
            xs[i]
        } else {
            x.clamp(lo, hi)
        }
    }

    /// Where a new node at `x` goes, or `None` when it would sit within
    /// `min_gap` of an existing node (or `x` is not finite).
    fn insert_slot(&self, xs: &[f64], x: f64) -> Option<(usize, f64)> {
        if !x.is_finite() {
            return None;
        }
        let x = x.clamp(self.range[0], self.range[1]);
        let gap = self.min_gap();
        if xs.iter().any(|&p| (p - x).abs() < gap) {
            return None;
        }
        Some((xs.partition_point(|&p| p < x), x))
    }

    fn bump(&mut self) {
        self.revision += 1;
    }

    /// A new revision when `changed`; returns `changed`.
    fn bump_if(&mut self, changed: bool) -> bool {
        if changed {
            self.bump();
        }
        changed
    }

    /// Adds an opacity node (x clamped into the range, `a` to ≥ 0); returns
    /// its index, or `None` next to an existing node.
    pub fn add_opacity(&mut self, x: f64, a: f64) -> Option<usize> {
        let xs: Vec<f64> = self.opacity.iter().map(|o| o.x).collect();
        let (i, x) = self.insert_slot(&xs, x)?;
        self.opacity.insert(i, OpacityNode { x, a: clean_nonneg(a, 0.0) });
        self.bump();
        Some(i)
    }

    /// Drags opacity node `i` towards (x, a): x stays between its
    /// neighbours, `a` ≥ 0. Out-of-range `i` is ignored.
    pub fn move_opacity(&mut self, i: usize, x: f64, a: f64) {
        if i >= self.opacity.len() {
            return;
        }
        let xs: Vec<f64> = self.opacity.iter().map(|o| o.x).collect();
        let x = self.clamp_between(&xs, i, x);
        let a = clean_nonneg(a, self.opacity[i].a);
        if self.opacity[i].x != x || self.opacity[i].a != a {
            self.opacity[i] = OpacityNode { x, a };
            self.bump();
        }
    }

    /// Removes opacity node `i` unless it is the last one; whether it did.
    pub fn remove_opacity(&mut self, i: usize) -> bool {
        let removed = remove_unless_last(&mut self.opacity, i);
        self.bump_if(removed)
    }

    /// Adds a colour node at `x` with the colour the TF has there now.
    pub fn add_color(&mut self, x: f64) -> Option<usize> {
        let xs: Vec<f64> = self.color.iter().map(|c| c.x).collect();
        let (i, x) = self.insert_slot(&xs, x)?;
        let rgb = self.color_at(x);
        self.color.insert(i, ColorNode { x, rgb });
        self.bump();
        Some(i)
    }

    /// Drags colour node `i` along x (between its neighbours).
    pub fn move_color(&mut self, i: usize, x: f64) {
        if i >= self.color.len() {
            return;
        }
        let xs: Vec<f64> = self.color.iter().map(|c| c.x).collect();
        let x = self.clamp_between(&xs, i, x);
        if self.color[i].x != x {
            self.color[i].x = x;
            self.bump();
        }
    }

    /// Sets colour node `i`'s RGB (non-finite or negative channels keep
    /// their old value or become 0).
    pub fn set_color(&mut self, i: usize, rgb: [f64; 3]) {
        let Some(node) = self.color.get_mut(i) else { return };
        let new = [0, 1, 2].map(|k| clean_nonneg(rgb[k], node.rgb[k]));
        if new != node.rgb {
            node.rgb = new;
            self.bump();
        }
    }

    /// Removes colour node `i` unless it is the last one.
    pub fn remove_color(&mut self, i: usize) -> bool {
        let removed = remove_unless_last(&mut self.color, i);
        self.bump_if(removed)
    }

    /// Sets the distance over which opacity `a` is an optical depth of `a`.
    pub fn set_unit_distance(&mut self, u: f64) {
        if u > 0.0 && u.is_finite() && u != self.unit_distance {
            self.unit_distance = u;
            self.bump();
        }
    }

    /// The 2D widgets (read by `biv-exact` and `biv-approx` only).
    pub fn widgets(&self) -> &[Widget] {
        &self.widgets
    }

    /// Adds a box widget over (scalar, |∇s|) centred at `center` with
    /// `width` (non-positive or non-finite widths become a small positive
    /// one); returns its index, or `None` for a non-finite centre.
    pub fn add_box_widget(
        &mut self,
        center: [f64; 2],
        width: [f64; 2],
        color: [f64; 3],
        opacity: f64,
    ) -> Option<usize> {
        if center.iter().any(|c| !c.is_finite()) {
            return None;
        }
        let width = width.map(clean_width);
        self.push_widget(Shape::Box { center, width }, box_support(center, width), color, opacity)
    }

    /// Adds a widget of `kind` placed in `region` ([[s_lo, s_hi], [g_lo,
    /// g_hi]], e.g. from [`populated_region`]): a box of half the region's
    /// size at its centre; a Gaussian there with σ a sixth of the region
    /// (unclipped); or [`DEFAULT_BANDS`] triangle or sine bands across the
    /// region's s range, peaking at its centre and clipped to the region.
    /// `None` when the region is not finite.
    pub fn add_widget_in(
        &mut self,
        kind: WidgetKind,
        region: [[f64; 2]; 2],
        color: [f64; 3],
        opacity: f64,
    ) -> Option<usize> {
        if region.iter().flatten().any(|v| !v.is_finite()) {
            return None;
        }
        let center = region.map(|r| 0.5 * (r[0] + r[1]));
        let size = region.map(|r| (r[1] - r[0]).abs());
        match kind {
            WidgetKind::Box => self.add_box_widget(center, size.map(|x| 0.5 * x), color, opacity),
            WidgetKind::Gaussian => {
                let sigma = size.map(|x| clean_width(x / 6.0));
                self.push_widget(Shape::Gaussian { center, sigma }, UNBOUNDED, color, opacity)
            }
            WidgetKind::Triangle | WidgetKind::Sine => {
                let (frequency, phase) = band_defaults(region[0], DEFAULT_BANDS);
                self.add_band_widget(kind, frequency, phase, region, color, opacity)
            }
        }
    }

    /// Adds triangle- or sine-wave bands (`kind` Triangle or Sine; `None`
    /// for the others, for a frequency outside (0, [`MAX_FREQUENCY`]] or a
    /// non-finite phase). `clip` bounds the support: NaN sides are
    /// unbounded, reversed sides are swapped.
    pub fn add_band_widget(
        &mut self,
        kind: WidgetKind,
        frequency: f64,
        phase: f64,
        clip: [[f64; 2]; 2],
        color: [f64; 3],
        opacity: f64,
    ) -> Option<usize> {
        if !(frequency > 0.0 && frequency <= MAX_FREQUENCY && phase.is_finite()) {
            return None;
        }
        let shape = match kind {
            WidgetKind::Triangle => Shape::Triangle { frequency, phase },
            WidgetKind::Sine => Shape::Sine { frequency, phase },
            WidgetKind::Box | WidgetKind::Gaussian => return None,
        };
        self.push_widget(shape, clean_clip(clip), color, opacity)
    }

    fn push_widget(&mut self, shape: Shape, support: [[f64; 2]; 2], color: [f64; 3], opacity: f64) -> Option<usize> {
        self.widgets.push(Widget {
            shape,
            color: color.map(|c| clean_nonneg(c, 0.0)),
            opacity: clean_nonneg(opacity, 0.0),
            support,
        });
        self.bump();
        Some(self.widgets.len() - 1)
    }

    /// Sets a banded widget's frequency (bands per scalar unit, clamped to
    /// [`MAX_FREQUENCY`]; non-positive or non-finite keeps the old one) and
    /// phase (non-finite keeps the old one). Other widgets are unchanged.
    pub fn set_band(&mut self, i: usize, frequency: f64, phase: f64) {
        let Some(w) = self.widgets.get_mut(i) else { return };
        let old = *w;
        if let Shape::Triangle { frequency: f, phase: p } | Shape::Sine { frequency: f, phase: p } = &mut w.shape {
            if frequency > 0.0 && frequency.is_finite() {
                *f = frequency.min(MAX_FREQUENCY);
            }
            if phase.is_finite() {
                *p = phase;
            }
        }
        if *w != old {
            self.bump();
        }
    }

    /// Sets the clip rectangle of a Gaussian or banded widget (as in
    /// [`add_band_widget`](Self::add_band_widget); [`UNBOUNDED`] removes
    /// it). A box's support is its shape: use `move_widget`/`resize_widget`.
    pub fn set_widget_clip(&mut self, i: usize, clip: [[f64; 2]; 2]) {
        let Some(w) = self.widgets.get_mut(i) else { return };
        if matches!(w.shape, Shape::Box { .. }) {
            return;
        }
        let clip = clean_clip(clip);
        if clip != w.support {
            w.support = clip;
            self.bump();
        }
    }

    /// Moves a box or Gaussian widget's centre, or a banded widget's clip
    /// rectangle (its bounded axes) to be centred at `center` — the bands
    /// stay where they are in s.
    pub fn move_widget(&mut self, i: usize, center: [f64; 2]) {
        self.reshape_widget(i, Some(center), None);
    }

    /// Sets a box widget's widths, a Gaussian's standard deviations, or the
    /// widths of a banded widget's clip rectangle (its bounded axes).
    pub fn resize_widget(&mut self, i: usize, width: [f64; 2]) {
        self.reshape_widget(i, None, Some(width.map(clean_width)));
    }

    fn reshape_widget(&mut self, i: usize, center: Option<[f64; 2]>, width: Option<[f64; 2]>) {
        let Some(w) = self.widgets.get_mut(i) else { return };
        if center.is_some_and(|c| c.iter().any(|v| !v.is_finite())) {
            return;
        }
        let old = *w;
        match &mut w.shape {
            Shape::Box { center: c, width: wd } => {
                *c = center.unwrap_or(*c);
                *wd = width.unwrap_or(*wd);
                w.support = box_support(*c, *wd);
            }
            Shape::Gaussian { center: c, sigma } => {
                *c = center.unwrap_or(*c);
                *sigma = width.unwrap_or(*sigma);
            }
            Shape::Triangle { .. } | Shape::Sine { .. } => {
                for k in 0..2 {
                    let [lo, hi] = w.support[k];
                    if lo.abs() == f64::MAX || hi.abs() == f64::MAX {
                        continue; // unbounded on this axis: nothing to move
                    }
                    let c = center.map_or(0.5 * (lo + hi), |c| c[k]);
                    let half = width.map_or(0.5 * (hi - lo), |wd| 0.5 * wd[k]);
                    let side = [c - half, c + half];
                    if side.iter().all(|v| v.is_finite() && v.abs() < f64::MAX) {
                        w.support[k] = side;
                    }
                }
            }
        }
        if *w != old {
            self.bump();
        }
    }

    /// Switches a box to the Gaussian with σ = width/2 over the same centre
    /// (unclipped), a Gaussian to the box of width 2σ, and triangle bands to
    /// sine bands of the same frequency, phase and clip (and back).
    pub fn toggle_widget_shape(&mut self, i: usize) {
        let Some(w) = self.widgets.get_mut(i) else { return };
        match w.shape {
            Shape::Box { center, width } => {
                let sigma = width.map(|x| clean_width(0.5 * x));
                w.shape = Shape::Gaussian { center, sigma };
                w.support = UNBOUNDED;
            }
            Shape::Gaussian { center, sigma } => {
                let width = sigma.map(|x| clean_width(2.0 * x));
                w.shape = Shape::Box { center, width };
                w.support = box_support(center, width);
            }
            Shape::Triangle { frequency, phase } => w.shape = Shape::Sine { frequency, phase },
            Shape::Sine { frequency, phase } => w.shape = Shape::Triangle { frequency, phase },
        }
        self.bump();
    }

    /// Sets a widget's colour and maximum opacity (clamped to ≥ 0).
    pub fn style_widget(&mut self, i: usize, color: [f64; 3], opacity: f64) {
        let Some(w) = self.widgets.get_mut(i) else { return };
        let color = [0, 1, 2].map(|k| clean_nonneg(color[k], w.color[k]));
        let opacity = clean_nonneg(opacity, w.opacity);
        if color != w.color || opacity != w.opacity {
            w.color = color;
            w.opacity = opacity;
            self.bump();
        }
    }

    pub fn remove_widget(&mut self, i: usize) -> bool {
        if i >= self.widgets.len() {
            return false;
        }
        self.widgets.remove(i);
        self.bump();
        true
    }

    /// Replaces everything by `tf` (loaded or imported), keeping the range
    /// widened to its nodes; counts as one edit.
    pub fn replace(&mut self, tf: &TransferFunction, scalar_range: [f64; 2]) -> Result<(), TfError> {
        let revision = self.revision + 1;
        *self = TfModel::new(tf, scalar_range)?;
        self.revision = revision;
        Ok(())
    }

    /// The colour at `x` (linear interpolation, clamped outside the nodes).
    pub fn color_at(&self, x: f64) -> [f64; 3] {
        let c = &self.color;
        let i = c.partition_point(|n| n.x < x);
        if i == 0 {
            return c[0].rgb;
        }
        if i == c.len() {
            return c[c.len() - 1].rgb;
        }
        let (a, b) = (c[i - 1], c[i]);
        let t = (x - a.x) / (b.x - a.x);
        [0, 1, 2].map(|k| a.rgb[k] + t * (b.rgb[k] - a.rgb[k]))
    }

    /// The validated transfer function (data units, not normalized).
    pub fn to_tf(&self) -> Result<TransferFunction, TfError> {
        TransferFunction::new(self.color.clone(), self.opacity.clone(), self.unit_distance, self.emission, false)?
            .with_widgets(self.widgets.clone())
    }
}

/// A positive, finite width (tiny for bad input, so a widget stays valid).
fn clean_width(w: f64) -> f64 {
    if w.is_finite() && w > 0.0 {
        w.min(f64::MAX / 4.0)
    } else {
        1e-9
    }
}

/// A clip rectangle a widget accepts: NaN sides unbounded (±`f64::MAX`),
/// infinities to ±`f64::MAX`, reversed sides swapped.
fn clean_clip(clip: [[f64; 2]; 2]) -> [[f64; 2]; 2] {
    clip.map(|[a, b]| {
        let a = if a.is_nan() { -f64::MAX } else { a.clamp(-f64::MAX, f64::MAX) };
        let b = if b.is_nan() { f64::MAX } else { b.clamp(-f64::MAX, f64::MAX) };
        [a.min(b), a.max(b)]
    })
}

/// Removes `nodes[i]` unless `i` is out of range or it is the last node
/// (a TF keeps one of each); whether it did.
fn remove_unless_last<T>(nodes: &mut Vec<T>, i: usize) -> bool {
    if i >= nodes.len() || nodes.len() <= 1 {
        return false;
    }
    nodes.remove(i);
    true
}

fn clean_nonneg(v: f64, fallback: f64) -> f64 {
    if v.is_finite() {
        v.max(0.0)
    } else {
        fallback
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use proptest::prelude::*;

    fn valid(m: &TfModel) {
        let tf = m.to_tf().expect("the model always makes a valid TF");
        let [lo, hi] = m.range();
        for w in tf.opacity_nodes().windows(2) {
            assert!(w[0].x < w[1].x);
        }
        for w in tf.color_nodes().windows(2) {
            assert!(w[0].x < w[1].x);
        }
        assert!(tf.opacity_nodes().iter().all(|o| o.x >= lo && o.x <= hi && o.a >= 0.0));
        assert!(tf.color_nodes().iter().all(|c| c.x >= lo && c.x <= hi && c.rgb.iter().all(|v| *v >= 0.0)));
    }

    #[test]
    fn normalized_tf_maps_onto_the_range_and_saves_in_data_units() {
        let tf = TransferFunction::from_json(
            r#"{"normalized": true, "color": [[0, 0, 0, 1], [1, 1, 0, 0]], "opacity": [[0, 0], [1, 2]], "unit_distance": 1}"#,
        )
        .unwrap();
        let m = TfModel::new(&tf, [10.0, 20.0]).unwrap();
        assert_eq!(m.range(), [10.0, 20.0]);
        let out = m.to_tf().unwrap();
        assert!(!out.normalized());
        assert_eq!(out.opacity_nodes()[1].x, 20.0);
        let back = TransferFunction::from_json(&out.to_json()).unwrap();
        assert_eq!(back, out);
    }

    #[test]
    fn add_drag_remove_keep_order() {
        let mut m = TfModel::ramp([0.0, 1.0], 1.0);
        let i = m.add_opacity(0.5, 3.0).unwrap();
        assert_eq!(i, 1);
        // Dragging past the right neighbour stops short of it.
        m.move_opacity(1, 5.0, -1.0);
        let o = m.opacity_nodes();
        assert!(o[1].x < o[2].x && o[1].a == 0.0);
        // Next to an existing node: refused.
        assert_eq!(m.add_opacity(o[1].x, 1.0), None);
        assert!(m.remove_opacity(1));
        assert!(m.remove_opacity(0));
        assert!(!m.remove_opacity(0), "the last node stays");
        let c = m.add_color(0.25).unwrap();
        let rgb = m.color_nodes()[c].rgb;
        assert!((rgb[0] - (0.1 + 0.25 * 0.9)).abs() < 1e-12);
        m.set_color(c, [f64::NAN, -2.0, 0.5]);
        assert_eq!(m.color_nodes()[c].rgb, [rgb[0], 0.0, 0.5]);
        valid(&m);
    }

    #[test]
    fn edits_bump_the_revision_and_no_ops_do_not() {
        let mut m = TfModel::ramp([0.0, 1.0], 1.0);
        let r0 = m.revision();
        m.move_opacity(0, 0.0, 0.0);
        assert_eq!(m.revision(), r0);
        m.move_opacity(0, 0.0, 0.5);
        assert_eq!(m.revision(), r0 + 1);
        m.move_opacity(7, 0.3, 0.5);
        assert_eq!(m.revision(), r0 + 1);
    }

    #[test]
    fn widgets_move_resize_toggle_and_stay_valid() {
        let mut m = TfModel::ramp([0.0, 1.0], 1.0);
        let i = m.add_box_widget([0.5, 2.0], [0.2, -1.0], [1.0, 0.0, 0.0], 2.0).unwrap();
        assert!(matches!(m.widgets()[i].shape, Shape::Box { width, .. } if width[1] > 0.0));
        m.move_widget(i, [0.25, 1.0]);
        assert_eq!(m.widgets()[i].support[0], [0.15, 0.35]);
        m.toggle_widget_shape(i);
        assert!(matches!(m.widgets()[i].shape, Shape::Gaussian { center: [0.25, 1.0], .. }));
        m.resize_widget(i, [0.05, f64::NAN]);
        m.toggle_widget_shape(i);
        assert!(matches!(m.widgets()[i].shape, Shape::Box { center: [0.25, 1.0], width } if width[0] == 0.1));
        m.style_widget(i, [0.5, -1.0, 2.0], f64::INFINITY);
        assert_eq!((m.widgets()[i].color, m.widgets()[i].opacity), ([0.5, 0.0, 2.0], 2.0));
        valid(&m);
        assert_eq!(m.to_tf().unwrap().without_widgets().widgets().len(), 0);
        assert!(m.remove_widget(i) && !m.remove_widget(i));
    }

    fn histograms(joint_at: &[(usize, usize, f64)]) -> Histograms {
        use tet_analysis::{Axis, Scale};
        let scalar_axis = Axis::new(0.0, 10.0, 10, Scale::Linear).unwrap();
        let gradient_axis = Axis::new(0.01, 100.0, 4, Scale::Log).unwrap();
        let mut joint = vec![0.0; 40];
        for &(g, s, v) in joint_at {
            joint[g * 10 + s] = v;
        }
        let total = joint.iter().sum();
        Histograms {
            scalar_axis,
            gradient_axis,
            scalar: vec![0.0; 10],
            scalar_below: 0.0,
            scalar_above: 0.0,
            joint,
            joint_outside: 0.0,
            total_volume: total,
        }
    }

    #[test]
    fn populated_region_snaps_to_the_occupied_bins() {
        // Volume in scalar bins 2..=6 and gradient bins 1..=2 (edges 0.1 .. 10).
        let h = histograms(&[(1, 2, 1.0), (2, 6, 3.0), (1, 4, 0.001)]);
        let r = populated_region(&h, 0.0).unwrap();
        assert_eq!(r[0], [2.0, 7.0]);
        assert!((r[1][0] - 0.1).abs() < 1e-12 && (r[1][1] - 10.0).abs() < 1e-9, "{r:?}");
        // The ends hold 1 and 3 of 4.001: a 1% tail cuts nothing.
        assert_eq!(populated_region(&h, 0.01).unwrap(), r);
        // A 30% tail cuts bin 2 (25%) and the speck in bin 4 after it.
        assert_eq!(populated_region(&h, 0.3).unwrap()[0], [6.0, 7.0]);
        assert_eq!(populated_region(&histograms(&[]), 0.0), None);
        let mut bad = histograms(&[(0, 0, 1.0)]);
        bad.joint.pop();
        assert_eq!(populated_region(&bad, 0.0), None, "arrays not matching the axes");
    }

    #[test]
    fn every_widget_kind_is_created_centred_in_a_region() {
        let region = [[2.0, 6.0], [0.5, 1.5]];
        let mut m = TfModel::ramp([0.0, 10.0], 1.0);
        for kind in WidgetKind::ALL {
            let i = m.add_widget_in(kind, region, [1.0, 0.5, 0.0], 2.0).unwrap();
            let w = m.widgets()[i];
            assert_eq!(WidgetKind::of(&w.shape), kind);
            // Full strength at the region's centre, none outside the region for clipped kinds.
            assert!((w.shape_at(4.0, 1.0) - 1.0).abs() < 1e-12, "{kind:?}");
            match w.shape {
                Shape::Box { width, .. } => assert_eq!(width, [2.0, 0.5]),
                Shape::Gaussian { sigma, .. } => {
                    assert!((sigma[0] - 4.0 / 6.0).abs() < 1e-12);
                    assert_eq!(w.support, UNBOUNDED);
                }
                Shape::Triangle { frequency, .. } | Shape::Sine { frequency, .. } => {
                    assert_eq!(frequency, DEFAULT_BANDS / 4.0);
                    assert_eq!(w.support, region);
                    // Peaks one band apart, zero half a band from a peak, nothing outside the clip.
                    assert!((w.shape_at(5.0, 1.0) - 1.0).abs() < 1e-12);
                    assert!(w.shape_at(4.5, 1.0).abs() < 1e-12);
                    assert_eq!(w.shape_at(5.0, 1.6), 0.0);
                    assert_eq!(w.shape_at(7.0, 1.0), 0.0);
                }
            }
        }
        valid(&m);
        let tf = m.to_tf().unwrap();
        let back = TransferFunction::from_json(&tf.to_json()).unwrap();
        let kinds: Vec<_> = back.widgets().iter().map(|w| WidgetKind::of(&w.shape).id()).collect();
        assert_eq!(kinds, ["box", "gaussian", "triangle", "sine"]);
        assert_eq!(m.add_widget_in(WidgetKind::Sine, [[0.0, f64::NAN], [0.0, 1.0]], [1.0; 3], 1.0), None);
    }

    #[test]
    fn band_widgets_edit_frequency_phase_clip_and_kind() {
        let mut m = TfModel::ramp([0.0, 10.0], 1.0);
        assert_eq!(m.add_band_widget(WidgetKind::Box, 1.0, 0.0, UNBOUNDED, [1.0; 3], 1.0), None);
        assert_eq!(m.add_band_widget(WidgetKind::Sine, 0.0, 0.0, UNBOUNDED, [1.0; 3], 1.0), None);
        assert_eq!(m.add_band_widget(WidgetKind::Sine, 2.0 * MAX_FREQUENCY, 0.0, UNBOUNDED, [1.0; 3], 1.0), None);
        assert_eq!(m.add_band_widget(WidgetKind::Sine, 1.0, f64::NAN, UNBOUNDED, [1.0; 3], 1.0), None);
        let i =
            m.add_band_widget(WidgetKind::Triangle, 1.0, 0.0, [[8.0, 2.0], [f64::NAN, 3.0]], [1.0; 3], 1.0).unwrap();
        assert_eq!(m.widgets()[i].support, [[2.0, 8.0], [-f64::MAX, 3.0]], "swapped, NaN side unbounded");
        let r = m.revision();
        m.set_band(i, 2.5, 0.25);
        assert_eq!(m.widgets()[i].shape, Shape::Triangle { frequency: 2.5, phase: 0.25 });
        m.set_band(i, -1.0, f64::INFINITY);
        m.set_band(i, f64::NAN, f64::NAN);
        assert_eq!(m.widgets()[i].shape, Shape::Triangle { frequency: 2.5, phase: 0.25 }, "bad values keep the old");
        assert_eq!(m.revision(), r + 1);
        m.set_band(i, 1e300, 0.25);
        assert_eq!(m.widgets()[i].frequency(), Some(MAX_FREQUENCY));
        m.set_band(i, 2.5, 0.25);
        // Moving shifts the bounded clip axes only; resizing sets their widths.
        m.move_widget(i, [6.0, 100.0]);
        assert_eq!(m.widgets()[i].support, [[3.0, 9.0], [-f64::MAX, 3.0]]);
        m.resize_widget(i, [2.0, 50.0]);
        assert_eq!(m.widgets()[i].support, [[5.0, 7.0], [-f64::MAX, 3.0]]);
        m.toggle_widget_shape(i);
        assert_eq!(m.widgets()[i].shape, Shape::Sine { frequency: 2.5, phase: 0.25 });
        assert_eq!(m.widgets()[i].support[0], [5.0, 7.0]);
        m.toggle_widget_shape(i);
        assert!(matches!(m.widgets()[i].shape, Shape::Triangle { .. }));
        m.set_widget_clip(i, UNBOUNDED);
        assert_eq!(m.widgets()[i].support, UNBOUNDED);
        // A box's support follows its shape: set_widget_clip leaves it alone.
        let b = m.add_box_widget([5.0, 1.0], [1.0, 1.0], [1.0; 3], 1.0).unwrap();
        let before = m.widgets()[b];
        m.set_widget_clip(b, [[0.0, 1.0], [0.0, 1.0]]);
        m.set_band(b, 3.0, 0.0);
        assert_eq!(m.widgets()[b], before);
        valid(&m);
        let tf = m.to_tf().unwrap();
        assert_eq!(TransferFunction::from_json(&tf.to_json()).unwrap().widgets()[i].shape, m.widgets()[i].shape);
    }

    #[derive(Debug, Clone)]
    enum Edit {
        AddO(f64, f64),
        MoveO(usize, f64, f64),
        RemoveO(usize),
        AddC(f64),
        MoveC(usize, f64),
        SetC(usize, [f64; 3]),
        RemoveC(usize),
        AddW([f64; 2], [f64; 2], f64),
        MoveW(usize, [f64; 2]),
        ResizeW(usize, [f64; 2]),
        ToggleW(usize),
        RemoveW(usize),
        AddKind(usize, [f64; 2], [f64; 2]),
        SetBand(usize, f64, f64),
        SetClip(usize, [f64; 4]),
    }

    fn edit() -> impl Strategy<Value = Edit> {
        let x = -1.0..2.0f64;
        let a = -1.0..5.0f64;
        prop_oneof![
            (x.clone(), a.clone()).prop_map(|(x, a)| Edit::AddO(x, a)),
            (0..8usize, x.clone(), a).prop_map(|(i, x, a)| Edit::MoveO(i, x, a)),
            (0..8usize).prop_map(Edit::RemoveO),
            x.clone().prop_map(Edit::AddC),
            (0..8usize, x).prop_map(|(i, x)| Edit::MoveC(i, x)),
            (0..8usize, prop::array::uniform3(-1.0..2.0f64)).prop_map(|(i, c)| Edit::SetC(i, c)),
            (0..8usize).prop_map(Edit::RemoveC),
            (prop::array::uniform2(-1.0..2.0f64), prop::array::uniform2(-0.5..1.0f64), -1.0..3.0f64)
                .prop_map(|(c, w, a)| Edit::AddW(c, w, a)),
            (0..4usize, prop::array::uniform2(-1.0..2.0f64)).prop_map(|(i, c)| Edit::MoveW(i, c)),
            (0..4usize, prop::array::uniform2(-0.5..1.0f64)).prop_map(|(i, w)| Edit::ResizeW(i, w)),
            (0..4usize).prop_map(Edit::ToggleW),
            (0..4usize).prop_map(Edit::RemoveW),
            (0..4usize, prop::array::uniform2(-1.0..2.0f64), prop::array::uniform2(-1.0..2.0f64))
                .prop_map(|(k, s, g)| Edit::AddKind(k, s, g)),
            (0..4usize, -1.0..100.0f64, -5.0..5.0f64).prop_map(|(i, f, p)| Edit::SetBand(i, f, p)),
            (0..4usize, prop::array::uniform4(-1.0..2.0f64)).prop_map(|(i, c)| Edit::SetClip(i, c)),
        ]
    }

    proptest! {
        #![proptest_config(ProptestConfig { cases: 256, ..ProptestConfig::default() })]
        /// Every edit keeps the TF valid (JSON round trip included).
        #[test]
        fn any_edit_sequence_keeps_the_tf_valid(edits in prop::collection::vec(edit(), 0..60)) {
            let mut m = TfModel::ramp([0.0, 1.0], 0.5);
            for e in edits {
                let before = m.to_tf().unwrap();
                match e {
                    Edit::AddO(x, a) => { m.add_opacity(x, a); }
                    Edit::MoveO(i, x, a) => m.move_opacity(i, x, a),
                    Edit::RemoveO(i) => { m.remove_opacity(i); }
                    Edit::AddC(x) => { m.add_color(x); }
                    Edit::MoveC(i, x) => m.move_color(i, x),
                    Edit::SetC(i, c) => m.set_color(i, c),
                    Edit::RemoveC(i) => { m.remove_color(i); }
                    Edit::AddW(c, w, a) => { m.add_box_widget(c, w, [1.0, 0.5, 0.0], a); }
                    Edit::MoveW(i, c) => m.move_widget(i, c),
                    Edit::ResizeW(i, w) => m.resize_widget(i, w),
                    Edit::ToggleW(i) => m.toggle_widget_shape(i),
                    Edit::RemoveW(i) => { m.remove_widget(i); }
                    Edit::AddKind(k, s, g) => { m.add_widget_in(WidgetKind::ALL[k], [s, g], [0.2, 0.5, 1.0], 1.0); }
                    Edit::SetBand(i, f, p) => m.set_band(i, f, p),
                    Edit::SetClip(i, c) => m.set_widget_clip(i, [[c[0], c[1]], [c[2], c[3]]]),
                }
                valid(&m);
                // Saved JSON loads back valid. (Equal up to an ulp: serde_json's
                // default float parser, without its `float_roundtrip` feature, can
                // be one ulp off; box supports are recomputed from the centre.)
                let tf = m.to_tf().unwrap();
                let back = TransferFunction::from_json(&tf.to_json()).unwrap();
                prop_assert_eq!(back.opacity_nodes().len(), tf.opacity_nodes().len());
                prop_assert_eq!(back.widgets().len(), tf.widgets().len());
                for (a, b) in back.widgets().iter().zip(tf.widgets()) {
                    for k in 0..2 {
                        for j in 0..2 {
                            let (x, y) = (a.support[k][j], b.support[k][j]);
                            prop_assert!((x - y).abs() <= 1e-12 * x.abs().max(1.0), "{x} vs {y}");
                        }
                    }
                }
                // Node counts change by at most one per edit.
                let after = m.to_tf().unwrap();
                prop_assert!(after.opacity_nodes().len().abs_diff(before.opacity_nodes().len()) <= 1);
            }
        }
    }
}
