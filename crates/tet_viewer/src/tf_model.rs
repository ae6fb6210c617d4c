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

use tet_preint::{ColorNode, Emission, OpacityNode, Shape, TfError, TransferFunction, Widget};

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
        if hi <= lo {
            (lo, hi) = (lo - 0.5, lo + 0.5);
        }
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

    /// A grey ramp with a linear opacity ramp over `scalar_range` (the
    /// viewer's TF when none is given); `unit_distance` sets the scale of opacity.
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
        if i >= self.opacity.len() || self.opacity.len() <= 1 {
            return false;
        }
        self.opacity.remove(i);
        self.bump();
        true
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
        if i >= self.color.len() || self.color.len() <= 1 {
            return false;
        }
        self.color.remove(i);
        self.bump();
        true
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
        self.widgets.push(Widget {
            shape: Shape::Box { center, width },
            color: color.map(|c| clean_nonneg(c, 0.0)),
            opacity: clean_nonneg(opacity, 0.0),
            support: tet_preint::widget::box_support(center, width),
        });
        self.bump();
        Some(self.widgets.len() - 1)
    }

    /// Moves a box or Gaussian widget's centre (band widgets have none).
    pub fn move_widget(&mut self, i: usize, center: [f64; 2]) {
        self.reshape_widget(i, Some(center), None);
    }

    /// Sets a box widget's widths or a Gaussian's standard deviations.
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
                w.support = tet_preint::widget::box_support(*c, *wd);
            }
            Shape::Gaussian { center: c, sigma } => {
                *c = center.unwrap_or(*c);
                *sigma = width.unwrap_or(*sigma);
            }
            Shape::Triangle { .. } | Shape::Sine { .. } => {}
        }
        if *w != old {
            self.bump();
        }
    }

    /// Switches a box to the Gaussian with σ = width/2 over the same centre
    /// (unclipped), and a Gaussian to the box of width 2σ.
    pub fn toggle_widget_shape(&mut self, i: usize) {
        let Some(w) = self.widgets.get_mut(i) else { return };
        match w.shape {
            Shape::Box { center, width } => {
                let sigma = width.map(|x| clean_width(0.5 * x));
                w.shape = Shape::Gaussian { center, sigma };
                w.support = tet_preint::widget::UNBOUNDED;
            }
            Shape::Gaussian { center, sigma } => {
                let width = sigma.map(|x| clean_width(2.0 * x));
                w.shape = Shape::Box { center, width };
                w.support = tet_preint::widget::box_support(center, width);
            }
            Shape::Triangle { .. } | Shape::Sine { .. } => return,
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
