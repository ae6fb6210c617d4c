//! The transfer-function editor's drawing and input: the 1D curve and colour
//! bar, band widgets' controls, and the 2D widget editor over the joint histogram.

use super::*;

/// Draws and edits the 1D TF: the opacity curve (drag points; click adds,
/// right-click removes) over a colour bar with its nodes (click adds or
/// selects, drag moves, right-click removes).
pub(crate) fn tf_editor(ui: &mut egui::Ui, model: &mut TfModel, st: &mut EditorState) {
    let width = ui.available_width().max(120.0);
    let (rect, resp) = ui.allocate_exact_size(Vec2::new(width, 170.0), Sense::click_and_drag());
    let curve = Rect::from_min_max(rect.min, Pos2::new(rect.max.x, rect.max.y - 26.0));
    let bar = Rect::from_min_max(Pos2::new(rect.min.x, rect.max.y - 20.0), rect.max);
    let [lo, hi] = model.range();
    let a_max = st.a_max.max(1e-9);
    let x_px = |x: f64| curve.min.x + ((x - lo) / (hi - lo)) as f32 * curve.width();
    let px_x = |p: f32| lo + ((p - curve.min.x) / curve.width()) as f64 * (hi - lo);
    let a_py = |a: f64| curve.max.y - (a / a_max).min(1.05) as f32 * curve.height();
    let py_a = |p: f32| ((curve.max.y - p) / curve.height()) as f64 * a_max;
    let srgb = |rgb: [f64; 3]| {
        let c = rgb.map(|v| (tet_render::image::linear_to_srgb(v.clamp(0.0, 1.0) as f32) * 255.0).round() as u8);
        Color32::from_rgb(c[0], c[1], c[2])
    };

    let painter = ui.painter_at(rect);
    painter.rect_filled(curve, 2.0, Color32::from_gray(30));
    let columns = 96;
    for k in 0..columns {
        let x0 = bar.min.x + bar.width() * k as f32 / columns as f32;
        let x1 = bar.min.x + bar.width() * (k + 1) as f32 / columns as f32;
        let x = px_x(0.5 * (x0 + x1));
        painter.rect_filled(
            Rect::from_min_max(Pos2::new(x0, bar.min.y), Pos2::new(x1, bar.max.y)),
            0.0,
            srgb(model.color_at(x)),
        );
    }
    let nodes = model.opacity_nodes();
    let mut line = vec![Pos2::new(curve.min.x, a_py(nodes[0].a))];
    line.extend(nodes.iter().map(|o| Pos2::new(x_px(o.x), a_py(o.a))));
    line.push(Pos2::new(curve.max.x, a_py(nodes[nodes.len() - 1].a)));
    painter.add(egui::Shape::line(line, Stroke::new(1.5, Color32::WHITE)));
    for (i, o) in nodes.iter().enumerate() {
        let hot = st.drag == Some(Drag::Opacity(i));
        painter.circle(
            Pos2::new(x_px(o.x), a_py(o.a)),
            if hot { 6.0 } else { 4.5 },
            srgb(model.color_at(o.x)),
            Stroke::new(1.5, Color32::WHITE),
        );
    }
    for (i, c) in model.color_nodes().iter().enumerate() {
        let sel = st.selected_color == Some(i);
        let centre = Pos2::new(x_px(c.x), bar.center().y);
        painter.rect(
            Rect::from_center_size(centre, Vec2::new(8.0, 16.0)),
            1.0,
            srgb(c.rgb),
            Stroke::new(if sel { 2.5 } else { 1.0 }, if sel { Color32::YELLOW } else { Color32::WHITE }),
            egui::StrokeKind::Outside,
        );
    }
    painter.text(
        curve.left_top() + Vec2::new(4.0, 2.0),
        egui::Align2::LEFT_TOP,
        format!("opacity to {a_max:.3}, scalar {lo:.4} to {hi:.4}"),
        egui::FontId::proportional(11.0),
        Color32::GRAY,
    );

    let Some(p) = resp.interact_pointer_pos().or(resp.hover_pos()) else { return };
    let near_opacity = |m: &TfModel, p: Pos2| {
        m.opacity_nodes()
            .iter()
            .enumerate()
            .map(|(i, o)| (i, Pos2::new(x_px(o.x), a_py(o.a)).distance(p)))
            .filter(|(_, d)| *d < 9.0)
            .min_by(|a, b| a.1.total_cmp(&b.1))
            .map(|x| x.0)
    };
    let near_color = |m: &TfModel, p: Pos2| {
        m.color_nodes()
            .iter()
            .enumerate()
            .map(|(i, c)| (i, (x_px(c.x) - p.x).abs()))
            .filter(|(_, d)| *d < 7.0)
            .min_by(|a, b| a.1.total_cmp(&b.1))
            .map(|x| x.0)
    };
    let in_bar = |p: Pos2| p.y >= bar.min.y - 3.0;
    if resp.drag_started() {
        // Hit-test where the button went down: a drag starts only after the
        // pointer has moved a few pixels.
        let o = ui.input(|i| i.pointer.press_origin()).unwrap_or(p);
        st.drag = if in_bar(o) {
            near_color(model, o).map(Drag::Color)
        } else {
            near_opacity(model, o).or_else(|| model.add_opacity(px_x(o.x), py_a(o.y))).map(Drag::Opacity)
        };
        if let Some(Drag::Color(i)) = st.drag {
            st.selected_color = Some(i);
        }
    }
    if resp.dragged() {
        match st.drag {
            Some(Drag::Opacity(i)) => model.move_opacity(i, px_x(p.x), py_a(p.y).min(a_max)),
            Some(Drag::Color(i)) => model.move_color(i, px_x(p.x)),
            None => {}
        }
    }
    if resp.drag_stopped() {
        st.drag = None;
    }
    if resp.clicked() {
        if in_bar(p) {
            st.selected_color = near_color(model, p).or_else(|| model.add_color(px_x(p.x)));
        } else if near_opacity(model, p).is_none() {
            model.add_opacity(px_x(p.x), py_a(p.y));
        }
    }
    if resp.secondary_clicked() {
        if in_bar(p) {
            if let Some(i) = near_color(model, p) {
                model.remove_color(i);
                st.selected_color = None;
            }
        } else if let Some(i) = near_opacity(model, p) {
            model.remove_opacity(i);
        }
    }
}

/// Frequency, phase and clip of banded widget `i`. Bands run along s only
/// (Song et al.'s (2009) triangle and sine widgets have no orientation); the clip
/// rectangle limits them in s and |∇s|.
pub(crate) fn band_controls(
    ui: &mut egui::Ui,
    model: &mut TfModel,
    i: usize,
    (frequency, phase): (f64, f64),
    support: [[f64; 2]; 2],
    region: Option<[[f64; 2]; 2]>,
) {
    ui.horizontal(|ui| {
        let (mut f, mut p) = (frequency, phase);
        let cf = ui
            .add(
                egui::DragValue::new(&mut f)
                    .speed(0.005 * frequency)
                    .range(1e-12..=MAX_FREQUENCY)
                    .prefix("frequency ")
                    .custom_formatter(|v, _| format!("{v:.5}")),
            )
            .on_hover_text("bands per scalar unit")
            .changed();
        let cp = ui
            .add(egui::DragValue::new(&mut p).speed(0.01).prefix("phase ").custom_formatter(|v, _| format!("{v:.3}")))
            .on_hover_text("peaks where frequency·s − phase is an integer")
            .changed();
        if cf || cp {
            model.set_band(i, f, p);
        }
        ui.label(format!("period {:.4}", 1.0 / frequency));
    });
    ui.horizontal(|ui| {
        if support == UNBOUNDED {
            ui.label("unclipped");
        } else {
            let side = |v: f64| if v.abs() == f64::MAX { "∞".to_string() } else { format!("{v:.4}") };
            let [[s0, s1], [g0, g1]] = support;
            ui.label(format!("clip s {}..{}, |grad s| {}..{}", side(s0), side(s1), side(g0), side(g1)));
        }
        if let Some(r) = region {
            if ui.button("clip to data").clicked() {
                model.set_widget_clip(i, r);
            }
        }
        if support != UNBOUNDED && ui.button("unclip").clicked() {
            model.set_widget_clip(i, UNBOUNDED);
        }
    });
}

/// Where `v` lies along a histogram axis, 0 at `lo` and 1 at `hi`.
pub(crate) fn axis_frac(a: &Axis, v: f64) -> f64 {
    match a.scale {
        Scale::Linear => (v - a.lo) / (a.hi - a.lo),
        Scale::Log => (v.max(f64::MIN_POSITIVE) / a.lo).ln() / (a.hi / a.lo).ln(),
    }
}

pub(crate) fn axis_value(a: &Axis, f: f64) -> f64 {
    match a.scale {
        Scale::Linear => a.lo + f * (a.hi - a.lo),
        Scale::Log => a.lo * (a.hi / a.lo).powf(f),
    }
}

/// The 2D widget editor's UI state.
#[derive(Default)]
pub(crate) struct WidgetState {
    pub(crate) selected: Option<usize>,
    /// Widget dragged, whether the drag resizes (shift) rather than moves,
    /// and its centre minus the grab point (so a move does not jump).
    pub(crate) drag: Option<(usize, bool, [f64; 2])>,
    pub(crate) texture: Option<TextureHandle>,
}

/// The point a drag moves: a box's or Gaussian's centre, a band widget's
/// clip centre (on an unbounded axis: `None`, the move leaves it alone).
pub(crate) fn widget_center(w: &tet_preint::Widget) -> Option<[f64; 2]> {
    match w.shape {
        Shape::Box { center, .. } | Shape::Gaussian { center, .. } => Some(center),
        Shape::Triangle { .. } | Shape::Sine { .. } => Some([bounded_mid(w.support[0])?, bounded_mid(w.support[1])?]),
    }
}

/// The middle of a clip side, `None` when it is unbounded (±`f64::MAX`).
pub(crate) fn bounded_mid([lo, hi]: [f64; 2]) -> Option<f64> {
    (lo.abs() < f64::MAX && hi.abs() < f64::MAX).then_some(0.5 * (lo + hi))
}

/// The joint (scalar, |∇s|) histogram as an image, |∇s| up: empty bins
/// black, the others grey on a log scale from the smallest non-zero bin
/// (dark grey) to the largest (white). Volume-weighted bins span many
/// decades, so a scale anchored at the maximum alone left all but the
/// peak nearly black.
pub(crate) fn histogram_image(h: &Histograms) -> egui::ColorImage {
    let (ns, ng) = (h.scalar_axis.bins as usize, h.gradient_axis.bins as usize);
    let px = log_grey(&h.joint, ns, ng);
    egui::ColorImage { size: [ns, ng], source_size: Vec2::new(ns as f32, ng as f32), pixels: px }
}

/// Grey levels of a row-major `ns × ng` count grid (row 0 = the last `g`
/// row, so larger values of the second axis are up): 0 for an empty bin,
/// 60 to 255 along `ln(v / min) / ln(max / min)` over the non-zero bins.
pub(crate) fn log_grey(counts: &[f64], ns: usize, ng: usize) -> Vec<Color32> {
    let positive = counts.iter().copied().filter(|v| *v > 0.0 && v.is_finite());
    let (min, max) = positive.fold((f64::INFINITY, 0.0f64), |(a, b), v| (a.min(v), b.max(v)));
    let span = (max / min).ln();
    let mut px = Vec::with_capacity(ns * ng);
    for row in 0..ng {
        let g = ng - 1 - row;
        for s in 0..ns {
            let v = counts.get(g * ns + s).copied().unwrap_or(0.0);
            let grey = if v > 0.0 && v.is_finite() {
                let t = if span > 0.0 { (v / min).ln() / span } else { 1.0 };
                60.0 + 195.0 * t.clamp(0.0, 1.0)
            } else {
                0.0
            };
            px.push(Color32::from_gray(grey.round() as u8));
        }
    }
    px
}

/// Widgets drawn over the 2D histogram (band widgets as their clip
/// rectangle with a line at each peak): drag a widget to move it,
/// shift-drag to resize it, click or drag on empty space to add a box,
/// right-click removes.
pub(crate) fn widget_editor(ui: &mut egui::Ui, model: &mut TfModel, st: &mut WidgetState, h: &Histograms) {
    let tex = st
        .texture
        .get_or_insert_with(|| ui.ctx().load_texture("histogram2d", histogram_image(h), egui::TextureOptions::NEAREST))
        .clone();
    let width = ui.available_width().max(120.0);
    let (rect, resp) = ui.allocate_exact_size(Vec2::new(width, 180.0), Sense::click_and_drag());
    let (sa, ga) = (&h.scalar_axis, &h.gradient_axis);
    let to_px = |s: f64, g: f64| {
        let fx = axis_frac(sa, s).clamp(-0.05, 1.05) as f32;
        let fy = axis_frac(ga, g).clamp(-0.05, 1.05) as f32;
        Pos2::new(rect.min.x + fx * rect.width(), rect.max.y - fy * rect.height())
    };
    let from_px = |p: Pos2| {
        let fx = ((p.x - rect.min.x) / rect.width()) as f64;
        let fy = ((rect.max.y - p.y) / rect.height()) as f64;
        [axis_value(sa, fx), axis_value(ga, fy)]
    };
    let painter = ui.painter_at(rect);
    painter.image(tex.id(), rect, Rect::from_min_max(Pos2::ZERO, Pos2::new(1.0, 1.0)), Color32::WHITE);
    // Displayed rectangle of each movable widget (a Gaussian's: centre ± σ).
    let shown: Vec<Option<Rect>> = model
        .widgets()
        .iter()
        .map(|w| match w.shape {
            Shape::Box { center, width } | Shape::Gaussian { center, sigma: width } => {
                let half = if matches!(w.shape, Shape::Box { .. }) { 0.5 } else { 1.0 };
                let a = to_px(center[0] - half * width[0], center[1] - half * width[1]);
                let b = to_px(center[0] + half * width[0], center[1] + half * width[1]);
                Some(Rect::from_two_pos(a, b))
            }
            // The clip rectangle (unbounded sides at the histogram's edges).
            Shape::Triangle { .. } | Shape::Sine { .. } => {
                let [[s0, s1], [g0, g1]] = w.support;
                Some(Rect::from_two_pos(to_px(s0, g0), to_px(s1, g1)))
            }
        })
        .collect();
    for (i, (w, r)) in model.widgets().iter().zip(&shown).enumerate() {
        let Some(r) = r else { continue };
        let c = w.color.map(|v| (tet_render::image::linear_to_srgb(v.clamp(0.0, 1.0) as f32) * 255.0) as u8);
        let fill = Color32::from_rgba_unmultiplied(c[0], c[1], c[2], 70);
        let sel = st.selected == Some(i);
        let stroke = Stroke::new(if sel { 2.5 } else { 1.2 }, if sel { Color32::YELLOW } else { Color32::WHITE });
        if let Shape::Triangle { frequency, phase } | Shape::Sine { frequency, phase } = w.shape {
            painter.rect(
                *r,
                0.0,
                Color32::from_rgba_unmultiplied(c[0], c[1], c[2], 25),
                stroke,
                egui::StrokeKind::Middle,
            );
            // Peak lines (x = f·s − φ ∈ ℤ) inside the clip, when few enough to see.
            let s_lo = w.support[0][0].max(sa.lo);
            let s_hi = w.support[0][1].min(sa.hi);
            let (k0, k1) = ((frequency * s_lo - phase).ceil(), (frequency * s_hi - phase).floor());
            if k1 >= k0 && k1 - k0 < 256.0 {
                let line = Stroke::new(1.0, Color32::from_rgb(c[0], c[1], c[2]));
                for k in 0..=(k1 - k0) as usize {
                    let x = to_px((k0 + k as f64 + phase) / frequency, ga.lo).x;
                    painter.line_segment([Pos2::new(x, r.min.y), Pos2::new(x, r.max.y)], line);
                }
            }
        } else if matches!(w.shape, Shape::Box { .. }) {
            painter.rect(*r, 0.0, fill, stroke, egui::StrokeKind::Middle);
        } else {
            painter.circle(r.center(), 3.0, fill, stroke);
            painter.rect(*r, r.width().min(r.height()) * 0.5, fill, stroke, egui::StrokeKind::Middle);
        }
    }
    painter.text(
        rect.left_top() + Vec2::new(4.0, 2.0),
        egui::Align2::LEFT_TOP,
        format!("|grad s| {:.3} to {:.3}", ga.lo, ga.hi),
        egui::FontId::proportional(11.0),
        Color32::LIGHT_GRAY,
    );

    let Some(p) = resp.interact_pointer_pos().or(resp.hover_pos()) else { return };
    let hit = |selected: Option<usize>, p: Pos2| {
        // The selected widget first, then the topmost (last drawn).
        let inside = |i: usize| shown[i].is_some_and(|r| r.expand(3.0).contains(p));
        selected.filter(|&i| i < shown.len() && inside(i)).or_else(|| (0..shown.len()).rev().find(|&i| inside(i)))
    };
    let default_width = |at: [f64; 2]| {
        let f = [axis_frac(sa, at[0]), axis_frac(ga, at[1])];
        [
            axis_value(sa, f[0] + 0.05) - axis_value(sa, f[0] - 0.05),
            axis_value(ga, f[1] + 0.05) - axis_value(ga, f[1] - 0.05),
        ]
    };
    if resp.drag_started() {
        let shift = ui.input(|i| i.modifiers.shift);
        let o = ui.input(|i| i.pointer.press_origin()).unwrap_or(p);
        let grab = from_px(o);
        st.drag = match hit(st.selected, o) {
            Some(i) => {
                // On an unbounded clip axis the grab point itself (the move leaves that axis).
                let w = model.widgets()[i];
                let center = match w.shape {
                    Shape::Box { center, .. } | Shape::Gaussian { center, .. } => center,
                    _ => [0, 1].map(|k| bounded_mid(w.support[k]).unwrap_or(grab[k])),
                };
                let offset = [center[0] - grab[0], center[1] - grab[1]];
                Some((i, shift, offset))
            }
            None => model.add_box_widget(grab, default_width(grab), [1.0, 0.6, 0.2], 1.0).map(|i| (i, false, [0.0; 2])),
        };
        st.selected = st.drag.map(|d| d.0);
    }
    if resp.dragged() {
        if let Some((i, resize, offset)) = st.drag {
            let at = from_px(p);
            if resize {
                if let Some((w, center)) = model.widgets().get(i).and_then(|w| Some((*w, widget_center(w)?))) {
                    // A box's and a clip's width is the full extent, a Gaussian's σ half of it.
                    let k = if matches!(w.shape, Shape::Gaussian { .. }) { 1.0 } else { 2.0 };
                    model.resize_widget(i, [k * (at[0] - center[0]).abs(), k * (at[1] - center[1]).abs()]);
                }
            } else {
                model.move_widget(i, [at[0] + offset[0], at[1] + offset[1]]);
            }
        }
    }
    if resp.drag_stopped() {
        st.drag = None;
    }
    if resp.clicked() {
        st.selected = hit(st.selected, p).or_else(|| {
            let at = from_px(p);
            model.add_box_widget(at, default_width(at), [1.0, 0.6, 0.2], 1.0)
        });
    }
    if resp.secondary_clicked() {
        if let Some(i) = hit(st.selected, p) {
            model.remove_widget(i);
            st.selected = None;
        }
    }
}
