//! Bivariate (scalar × gradient magnitude) pre-integration, Song et al. 2009:
//! `biv-exact` ([`BivExact`]), `biv-approx` ([`BivApprox`] with the F/B
//! tables of [`FbTable`]) and the adaptive-quadrature reference
//! ([`reference_segment`]).
//!
//! Along a segment s and g are both linear in x = t/l ∈ [0, 1]. The segment
//! is split at every x where the integrand has a kink or a jump: the 1D
//! transfer function's nodes, each widget's support edges (in s and in g),
//! and each band's half-period crossings (so every band piece is monotone —
//! Song et al.'s (2009) "at most one peak" holds per piece whatever the frequency).
//!
//! `biv-exact`, per piece: every part's optical depth in closed form (1D
//! linear: trapezoid; box: ρ·d; triangle: linear; sine: sinc form; Gaussian:
//! erfcx form, [`gaussian_depth`]), so α is exact. The colour is exact in
//! closed form when one part carries the piece — density emission: a widget
//! alone gives C = c·α (docs/design.md, §1), the 1D part alone goes through
//! [`crate::integrate_segment`]; independent emission: the 1D part alone.
//! Where parts overlap (or a widget emits independently of its extinction),
//! C = ∫ E·T is integrated by panelled 8-point Gauss–Legendre with T from the
//! closed-form depths (agrees with the reference to ~1e-10, tested) — the
//! composition rule is summed extinctions, not compositing of widgets.
//!
//! Emission-only model (`"emission": "independent"`), a piece carried by one
//! Gaussian widget with the 1D part transparent and its colour constant on
//! the piece: C = (κ₁D + c)·l/k·W(P, u₀, u₁) from Song et al.'s (2009) Gaussian table
//! ([`GaussErfTable`], built once per `BivExact` when the TF has such a
//! widget) instead of the quadrature; P beyond the table falls back to it.
//! Likewise a piece carried by one triangle- or sine-wave widget uses Song
//! et al.'s (2009) band tables ([`BandTable`], one per kind present): the piece lies
//! within half a period, so its phase φ is monotone and
//! C = (κ₁D + c)·l/|dφ/dx|·W(P, φ₀, φ₁).

use crate::biv_tables::{BandKind, BandTable, GaussErfTable, DEFAULT_ERF_TABLE};
use crate::exact::{integrate_segment_with, Rgba};
use crate::method::{sat_f32, Method, Rgba32, Segment, SegmentShader};
use crate::poly::{integrate_entry, Knot};
use crate::special::erfcx;
use crate::tf::{Emission, TransferFunction};
use crate::widget::{Shape, Widget};
use std::sync::Arc;

/// A segment in f64: s and g at x = 0 and x = 1, length l.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Seg2 {
    pub sf: f64,
    pub sb: f64,
    pub gf: f64,
    pub gb: f64,
    pub len: f64,
}

impl Seg2 {
    fn s(&self, x: f64) -> f64 {
        self.sf + x * (self.sb - self.sf)
    }
    fn g(&self, x: f64) -> f64 {
        self.gf + x * (self.gb - self.gf)
    }
}

impl From<&Segment> for Seg2 {
    fn from(s: &Segment) -> Self {
        Seg2 {
            sf: f64::from(s.s_front),
            sb: f64::from(s.s_back),
            gf: f64::from(s.grad_front),
            gb: f64::from(s.grad_back),
            len: f64::from(s.len_world).max(0.0),
        }
    }
}

/// More band crossings than this on one segment and band breakpoints are
/// dropped (the result degrades instead of the time exploding).
const MAX_BREAKS: usize = 1 << 16;

/// Sorted piece boundaries in [0, 1], 0 and 1 included.
pub fn breakpoints(tf: &TransferFunction, seg: &Seg2) -> Vec<f64> {
    let mut xs = vec![0.0, 1.0];
    let ds = seg.sb - seg.sf;
    let dg = seg.gb - seg.gf;
    let push_cross = |xs: &mut Vec<f64>, v0: f64, dv: f64, level: f64| {
        if dv != 0.0 {
            let x = (level - v0) / dv;
            if x > 0.0 && x < 1.0 {
                xs.push(x);
            }
        }
    };
    if ds != 0.0 {
        let mut nodes = Vec::new();
        tf.breakpoints_between(seg.sf.min(seg.sb), seg.sf.max(seg.sb), &mut nodes);
        for n in nodes {
            push_cross(&mut xs, seg.sf, ds, n);
        }
    }
    for w in tf.widgets() {
        let [[s0, s1], [g0, g1]] = w.support;
        for e in [s0, s1] {
            push_cross(&mut xs, seg.sf, ds, e);
        }
        for e in [g0, g1] {
            push_cross(&mut xs, seg.gf, dg, e);
        }
        match w.shape {
            Shape::Triangle { frequency, phase } | Shape::Sine { frequency, phase } if ds != 0.0 => {
                let v0 = frequency * seg.sf - phase;
                let v1 = frequency * seg.sb - phase;
                let (lo, hi) = (2.0 * v0.min(v1), 2.0 * v0.max(v1));
                let count = hi.floor() - lo.ceil() + 1.0;
                if count > 0.0 && count <= MAX_BREAKS as f64 {
                    let mut k = lo.ceil();
                    while k <= hi {
                        push_cross(&mut xs, v0, v1 - v0, 0.5 * k);
                        k += 1.0;
                    }
                }
            }
            Shape::Gaussian { .. } => {
                // The peak along the segment helps the quadrature paths.
                if let Some(x) = gaussian_peak(w, seg) {
                    if x > 0.0 && x < 1.0 {
                        xs.push(x);
                    }
                }
            }
            _ => {}
        }
    }
    xs.sort_by(f64::total_cmp);
    xs.dedup();
    xs
}

/// Coefficients of the Gaussian exponent q(x) = ½(A x² + 2 B x + C₀).
fn gaussian_quadratic(w: &Widget, seg: &Seg2) -> Option<(f64, f64, f64)> {
    let Shape::Gaussian { center, sigma } = w.shape else { return None };
    let (a_s, b_s) = ((seg.sf - center[0]) / sigma[0], (seg.sb - seg.sf) / sigma[0]);
    let (a_g, b_g) = ((seg.gf - center[1]) / sigma[1], (seg.gb - seg.gf) / sigma[1]);
    Some((b_s * b_s + b_g * b_g, a_s * b_s + a_g * b_g, a_s * a_s + a_g * a_g))
}

fn gaussian_peak(w: &Widget, seg: &Seg2) -> Option<f64> {
    let (a, b, _) = gaussian_quadratic(w, seg)?;
    (a > 0.0).then(|| -b / a)
}

const SQRT_PI_2: f64 = 0.886_226_925_452_758; // √π / 2

/// ∫_{x0}^{x1} m(x) dx of a Gaussian widget's shape along the segment
/// (support ignored), x0 ≤ x1, by the erfcx form of Song et al. 2009 §4.2 written
/// without cancellation: with u = k(x + B/A), k = √(A/2),
/// ∫ e^{−q} = (√π/2)/k·[erfcx(u₀)e^{−q(x₀)} − erfcx(u₁)e^{−q(x₁)}] for u₀ ≥ 0
/// (mirrored for u₁ ≤ 0, and 2e^{−q_min} minus both tails when the peak is
/// inside). Where k·(x1 − x0) < 1e-3 the erf difference would cancel, and
/// 6-point Gauss–Legendre on e^{−q} (which then varies smoothly) is used.
pub fn gaussian_depth(w: &Widget, seg: &Seg2, x0: f64, x1: f64) -> f64 {
    let Some((a, b, c0)) = gaussian_quadratic(w, seg) else { return 0.0 };
    let q = |x: f64| 0.5 * (a * x * x + 2.0 * b * x + c0).max(0.0);
    let k = (0.5 * a).sqrt();
    let dx = x1 - x0;
    if dx <= 0.0 {
        return 0.0;
    }
    if k * dx < 1e-3 {
        return gl6(x0, x1, |x| (-q(x)).exp());
    }
    let shift = b / a;
    let (u0, u1) = (k * (x0 + shift), k * (x1 + shift));
    let (e0, e1) = ((-q(x0)).exp(), (-q(x1)).exp());
    let bracket = if u0 >= 0.0 {
        erfcx(u0) * e0 - erfcx(u1) * e1
    } else if u1 <= 0.0 {
        erfcx(-u1) * e1 - erfcx(-u0) * e0
    } else {
        let qmin = 0.5 * (c0 - b * b / a).max(0.0);
        2.0 * (-qmin).exp() - erfcx(u1) * e1 - erfcx(-u0) * e0
    };
    (SQRT_PI_2 / k * bracket).max(0.0)
}

/// Gauss–Legendre, 6 points on [0, 1]: nodes and weights.
pub(crate) const GL6_NODES: [(f64, f64); 6] = [
    (0.5 * (1.0 - 0.932_469_514_203_152), 0.5 * 0.171_324_492_379_170_4),
    (0.5 * (1.0 - 0.661_209_386_466_264_5), 0.5 * 0.360_761_573_048_138_6),
    (0.5 * (1.0 - 0.238_619_186_083_196_9), 0.5 * 0.467_913_934_572_691),
    (0.5 * (1.0 + 0.238_619_186_083_196_9), 0.5 * 0.467_913_934_572_691),
    (0.5 * (1.0 + 0.661_209_386_466_264_5), 0.5 * 0.360_761_573_048_138_6),
    (0.5 * (1.0 + 0.932_469_514_203_152), 0.5 * 0.171_324_492_379_170_4),
];

/// Gauss–Legendre, 8 points on [0, 1].
pub(crate) const GL8_NODES: [(f64, f64); 8] = [
    (0.5 * (1.0 - 0.960_289_856_497_536_3), 0.5 * 0.101_228_536_290_376_3),
    (0.5 * (1.0 - 0.796_666_477_413_626_7), 0.5 * 0.222_381_034_453_374_5),
    (0.5 * (1.0 - 0.525_532_409_916_329), 0.5 * 0.313_706_645_877_887_3),
    (0.5 * (1.0 - 0.183_434_642_495_649_8), 0.5 * 0.362_683_783_378_362),
    (0.5 * (1.0 + 0.183_434_642_495_649_8), 0.5 * 0.362_683_783_378_362),
    (0.5 * (1.0 + 0.525_532_409_916_329), 0.5 * 0.313_706_645_877_887_3),
    (0.5 * (1.0 + 0.796_666_477_413_626_7), 0.5 * 0.222_381_034_453_374_5),
    (0.5 * (1.0 + 0.960_289_856_497_536_3), 0.5 * 0.101_228_536_290_376_3),
];

fn gl6(x0: f64, x1: f64, f: impl Fn(f64) -> f64) -> f64 {
    let h = x1 - x0;
    GL6_NODES.iter().map(|&(t, w)| w * f(x0 + h * t)).sum::<f64>() * h
}

/// ∫_{x0}^{x1} m(x) dx of one widget's shape along the segment, inside one
/// piece (the support is constant on a piece: tested at its midpoint).
fn widget_shape_integral(w: &Widget, seg: &Seg2, x0: f64, x1: f64) -> f64 {
    let mid = 0.5 * (x0 + x1);
    if !w.contains(seg.s(mid), seg.g(mid)) {
        return 0.0;
    }
    let dx = x1 - x0;
    match w.shape {
        Shape::Box { .. } => dx,
        // Linear on a piece (split at the peaks and troughs).
        Shape::Triangle { .. } => 0.5 * dx * (w.shape_unclipped(seg.s(x0), 0.0) + w.shape_unclipped(seg.s(x1), 0.0)),
        Shape::Sine { frequency, phase } => {
            // ∫ (1 + cos 2πv)/2 dx with v = v0 + q x: Δx/2 + cos(π(v0+v1))·sin(πqΔx)/(2πq).
            let (v0, v1) = (frequency * seg.s(x0) - phase, frequency * seg.s(x1) - phase);
            let z = std::f64::consts::PI * (v1 - v0);
            let sinc = if z.abs() < 1e-4 { 1.0 - z * z / 6.0 } else { z.sin() / z };
            0.5 * dx * (1.0 + (std::f64::consts::PI * (v0 + v1)).cos() * sinc)
        }
        Shape::Gaussian { .. } => gaussian_depth(w, seg, x0, x1),
    }
}

/// Closed-form optical depth over [x0, x1] inside one piece: the 1D part
/// (linear there) plus every widget.
fn piece_depth(tf: &TransferFunction, seg: &Seg2, x0: f64, x1: f64) -> f64 {
    let l = seg.len;
    let mut d = 0.5 * (tf.extinction(seg.s(x0)) + tf.extinction(seg.s(x1))) * (x1 - x0) * l;
    let u = tf.unit_distance();
    for w in tf.widgets() {
        if w.opacity > 0.0 {
            d += w.opacity / u * l * widget_shape_integral(w, seg, x0, x1);
        }
    }
    d
}

/// The `biv-exact` method (see the module docs).
#[derive(Debug, Clone)]
pub struct BivExact {
    tf: TransferFunction,
    tf1d: TransferFunction,
    tables: BivTables,
}

/// The tables of Song et al., "Bivariate Transfer Functions on Unstructured
/// Grids", 2009, that `biv-exact` may use under the emission-only model;
/// each `None` sends its pieces to the quadrature.
#[derive(Debug, Clone, Default)]
pub struct BivTables {
    pub gauss: Option<Arc<GaussErfTable>>,
    pub triangle: Option<Arc<BandTable>>,
    pub sine: Option<Arc<BandTable>>,
}

impl BivTables {
    /// Bytes of the tables held (Gaussian erf table and band tables).
    pub fn memory_bytes(&self) -> usize {
        self.gauss.as_ref().map_or(0, |t| t.memory_bytes())
            + self.triangle.as_ref().map_or(0, |t| t.memory_bytes())
            + self.sine.as_ref().map_or(0, |t| t.memory_bytes())
    }

    /// The default tables `tf` can use: none unless its emission is
    /// independent, then one per widget kind present (Gaussian: a few ms;
    /// band tables: [`BandTable::default_for`], ~1 ms).
    pub fn for_tf(tf: &TransferFunction) -> BivTables {
        if tf.emission() != Emission::Independent {
            return BivTables::default();
        }
        let has = |f: fn(&Shape) -> bool| tf.widgets().iter().any(|w| f(&w.shape));
        BivTables {
            gauss: has(|s| matches!(s, Shape::Gaussian { .. })).then(|| {
                let (n_p, n_u, p_max) = DEFAULT_ERF_TABLE;
                Arc::new(GaussErfTable::build(n_p, n_u, p_max))
            }),
            triangle: has(|s| matches!(s, Shape::Triangle { .. }))
                .then(|| Arc::new(BandTable::default_for(BandKind::Triangle))),
            sine: has(|s| matches!(s, Shape::Sine { .. })).then(|| Arc::new(BandTable::default_for(BandKind::Sine))),
        }
    }
}

impl BivExact {
    /// Takes the TF as given (denormalize a normalized TF first). With
    /// independent emission this builds the default tables for the widget
    /// kinds present ([`BivTables::for_tf`]).
    pub fn new(tf: TransferFunction) -> Self {
        let tables = BivTables::for_tf(&tf);
        BivExact::with_tables(tf, tables)
    }

    /// As [`BivExact::new`] with a given Gaussian table (shared between
    /// shaders, or `None` to integrate every Gaussian piece by quadrature)
    /// and no band tables.
    pub fn with_gauss_table(tf: TransferFunction, gauss: Option<Arc<GaussErfTable>>) -> Self {
        BivExact::with_tables(tf, BivTables { gauss, ..BivTables::default() })
    }

    /// As [`BivExact::new`] with the given tables (`BivTables::default()`:
    /// closed forms and quadrature only).
    pub fn with_tables(tf: TransferFunction, tables: BivTables) -> Self {
        let tf1d = tf.without_widgets();
        BivExact { tf, tf1d, tables }
    }

    /// The Gaussian table in use, if any.
    pub fn gauss_table(&self) -> Option<&GaussErfTable> {
        self.tables.gauss.as_deref()
    }
    /// All tables in use.
    pub fn tables(&self) -> &BivTables {
        &self.tables
    }

    /// Emission-only colour of a piece carried by the single Gaussian `w`
    /// with the 1D colour `k1d` constant on it, from the table; `None` where
    /// the table does not apply.
    fn gauss_table_color(
        &self,
        w: &Widget,
        seg: &Seg2,
        x0: f64,
        x1: f64,
        depth: f64,
        k1d: [f64; 3],
    ) -> Option<[f64; 3]> {
        let table = self.tables.gauss.as_deref()?;
        let (a, b, c0) = gaussian_quadratic(w, seg)?;
        let k = (0.5 * a).sqrt();
        if k < 1e-12 {
            return None;
        }
        let qmin = 0.5 * (c0 - b * b / a).max(0.0);
        let p = w.opacity / self.tf.unit_distance() * seg.len * (-qmin).exp() * SQRT_PI_2 / k;
        let shift = b / a;
        let win = table.window(p, k * (x0 + shift), k * (x1 + shift), (-depth).exp())?;
        let scale = seg.len / k * win;
        Some(std::array::from_fn(|c| (k1d[c] + w.color[c]) * scale))
    }

    /// As `gauss_table_color` for a piece carried by one band widget: the
    /// piece lies between two half-period crossings, so with v = f·s − φ
    /// (mirrored to increase along x) the phase within the period holding
    /// the piece's midpoint runs monotonically from φ₀ to φ₁.
    fn band_table_color(
        &self,
        w: &Widget,
        seg: &Seg2,
        x0: f64,
        x1: f64,
        depth: f64,
        k1d: [f64; 3],
    ) -> Option<[f64; 3]> {
        let (frequency, phase, table) = match w.shape {
            Shape::Triangle { frequency, phase } => (frequency, phase, self.tables.triangle.as_deref()?),
            Shape::Sine { frequency, phase } => (frequency, phase, self.tables.sine.as_deref()?),
            _ => return None,
        };
        let dv = frequency * (seg.sb - seg.sf);
        if dv.is_nan() || dv.abs() <= 1e-12 {
            return None;
        }
        let sign = dv.signum();
        // Phase units per unit v, and the v at which the phase is 0: a
        // trough (v = ½ mod 1) for the triangle, a peak (v ∈ ℤ) for the sine.
        let (per_v, offset) = match table.kind() {
            BandKind::Triangle => (2.0, 0.5),
            BandKind::Sine => (2.0 * std::f64::consts::PI, 0.0),
        };
        let v = |x: f64| sign * (frequency * seg.s(x) - phase) + offset;
        let base = v(0.5 * (x0 + x1)).floor();
        let (phi0, phi1) = (per_v * (v(x0) - base), per_v * (v(x1) - base));
        let dphi_dx = per_v * dv.abs();
        let p = w.opacity / self.tf.unit_distance() * seg.len / dphi_dx;
        let win = table.window(p, phi0, phi1, (-depth).exp())?;
        let scale = seg.len / dphi_dx * win;
        Some(std::array::from_fn(|c| (k1d[c] + w.color[c]) * scale))
    }
    pub fn transfer_function(&self) -> &TransferFunction {
        &self.tf
    }

    /// Premultiplied (C, α) of one segment in f64. Non-finite s or g give
    /// zero; l ≤ 0 gives zero.
    pub fn integrate(&self, seg: &Seg2) -> Rgba {
        let finite = [seg.sf, seg.sb, seg.gf, seg.gb].iter().all(|v| v.is_finite());
        if !finite || seg.len.is_nan() || seg.len <= 0.0 {
            return Rgba::default();
        }
        let seg = Seg2 { len: seg.len.min(1e300), ..*seg };
        let tf = &self.tf;
        let xs = breakpoints(tf, &seg);
        let mut scratch = Vec::new();
        let mut color = [0.0f64; 3];
        let mut depth_total = 0.0;
        let mut trans = 1.0;
        for p in xs.windows(2) {
            let (x0, x1) = (p[0], p[1]);
            let mid = 0.5 * (x0 + x1);
            let (sm, gm) = (seg.s(mid), seg.g(mid));
            let d = (x1 - x0) * seg.len;
            let one_d = tf.extinction(seg.s(x0)) > 0.0 || tf.extinction(seg.s(x1)) > 0.0;
            let in_support: Vec<&Widget> = tf.widgets().iter().filter(|w| w.contains(sm, gm)).collect();
            let opaque: Vec<&&Widget> = in_support.iter().filter(|w| w.opacity > 0.0).collect();
            let depth = piece_depth(tf, &seg, x0, x1);
            let alpha = -(-depth).exp_m1();
            let piece_color: [f64; 3] = match tf.emission() {
                Emission::Density if !one_d && opaque.is_empty() => [0.0; 3],
                Emission::Density if !one_d && opaque.len() == 1 => opaque[0].color.map(|c| c * alpha),
                Emission::Density if opaque.is_empty() => {
                    integrate_segment_with(&self.tf1d, seg.s(x0), seg.s(x1), d, &mut scratch).color
                }
                Emission::Independent if in_support.is_empty() => {
                    integrate_segment_with(&self.tf1d, seg.s(x0), seg.s(x1), d, &mut scratch).color
                }
                Emission::Independent
                    if !one_d
                        && in_support.len() == 1
                        && matches!(in_support[0].shape, Shape::Gaussian { .. })
                        && tf.color(seg.s(x0)) == tf.color(seg.s(x1)) =>
                {
                    self.gauss_table_color(in_support[0], &seg, x0, x1, depth, tf.color(seg.s(x0)))
                        .unwrap_or_else(|| quadrature_color(tf, &seg, x0, x1, depth))
                }
                Emission::Independent
                    if !one_d
                        && in_support.len() == 1
                        && matches!(in_support[0].shape, Shape::Triangle { .. } | Shape::Sine { .. })
                        && tf.color(seg.s(x0)) == tf.color(seg.s(x1)) =>
                {
                    self.band_table_color(in_support[0], &seg, x0, x1, depth, tf.color(seg.s(x0)))
                        .unwrap_or_else(|| quadrature_color(tf, &seg, x0, x1, depth))
                }
                _ => quadrature_color(tf, &seg, x0, x1, depth),
            };
            for c in 0..3 {
                color[c] += trans * piece_color[c];
            }
            trans *= 1.0 - alpha;
            depth_total += depth;
            if trans < 1e-300 {
                break;
            }
        }
        Rgba { color, alpha: -(-depth_total).exp_m1() }
    }
}

/// C = ∫ E(x)·T(x) l dx over one piece by 8-point Gauss–Legendre panels,
/// T from the closed-form depth from x0. Each panel is halved until its
/// depth is ≤ 0.5 (and it resolves Gaussian bumps), the next one starts at
/// twice the width; stops once T < e^{-45}.
fn quadrature_color(tf: &TransferFunction, seg: &Seg2, x0: f64, x1: f64, _depth: f64) -> [f64; 3] {
    let mut h_max = x1 - x0;
    for w in tf.widgets() {
        if let Some((a, _, _)) = gaussian_quadratic(w, seg) {
            let k = (0.5 * a).sqrt();
            if k > 0.0 {
                h_max = h_max.min(0.5 / k);
            }
        }
    }
    let mut out = [0.0f64; 3];
    let mut depth_before = 0.0; // from x0 to the panel start
    let mut a = x0;
    let mut h = h_max;
    while a < x1 && depth_before <= 45.0 {
        h = h.min(x1 - a);
        let mut pd = piece_depth(tf, seg, a, a + h);
        let mut halvings = 0;
        while pd > 0.5 && halvings < 200 {
            h *= 0.5;
            pd = piece_depth(tf, seg, a, a + h);
            halvings += 1;
        }
        for &(t, w) in &GL8_NODES {
            let x = a + h * t;
            let tau = depth_before + piece_depth(tf, seg, a, x);
            let e = tf.emission2(seg.s(x), seg.g(x));
            let wt = w * h * seg.len * (-tau).exp();
            for c in 0..3 {
                out[c] += wt * e[c];
            }
        }
        depth_before += pd;
        a = if h >= x1 - a { x1 } else { a + h };
        h = (2.0 * h).min(h_max);
    }
    out
}

impl SegmentShader for BivExact {
    fn method(&self) -> Method {
        Method::BivExact
    }
    fn shade(&self, seg: &Segment) -> Rgba32 {
        let px = self.integrate(&Seg2::from(seg));
        [sat_f32(px.color[0]), sat_f32(px.color[1]), sat_f32(px.color[2]), px.alpha as f32]
    }
}

/// The brute-force reference for 2D transfer functions: adaptive bisection
/// per piece, each panel by nested 10-point Gauss–Legendre (the transmittance
/// at each node from its own quadrature of ρ(s, g)), using only point
/// evaluations of [`TransferFunction::extinction2`] and
/// [`TransferFunction::emission2`] — none of `biv-exact`'s closed forms.
/// Panels are accepted when halving changes C and T by less than `tol`
/// (absolute); `tol` = 1e-12 gives results good to ~1e-10.
pub fn reference_segment(tf: &TransferFunction, seg: &Seg2, tol: f64) -> Rgba {
    if seg.len.is_nan() || seg.len <= 0.0 {
        return Rgba::default();
    }
    let xs = breakpoints(tf, seg);
    let mut acc = Rgba::default();
    let mut depth = 0.0f64;
    for p in xs.windows(2) {
        if depth > 60.0 {
            break; // transmittance < 1e-26: nothing behind is visible
        }
        let (c, d) = adaptive(tf, seg, p[0], p[1], tol, 0);
        let t = (-depth).exp();
        for (a, ck) in acc.color.iter_mut().zip(c) {
            *a += t * ck;
        }
        depth += d;
    }
    acc.alpha = -(-depth).exp_m1();
    acc
}

fn gl10() -> [(f64, f64); 10] {
    const X: [f64; 5] = [
        0.148_874_338_981_631_2,
        0.433_395_394_129_247_2,
        0.679_409_568_299_024_4,
        0.865_063_366_688_984_5,
        0.973_906_528_517_171_7,
    ];
    const W: [f64; 5] = [
        0.295_524_224_714_752_9,
        0.269_266_719_309_996_4,
        0.219_086_362_515_982,
        0.149_451_349_150_580_6,
        0.066_671_344_308_688_1,
    ];
    let mut out = [(0.0, 0.0); 10];
    for i in 0..5 {
        out[2 * i] = (0.5 * (1.0 - X[i]), 0.5 * W[i]);
        out[2 * i + 1] = (0.5 * (1.0 + X[i]), 0.5 * W[i]);
    }
    out
}

/// (C, depth) of [a, b] by nested Gauss–Legendre.
fn panel(tf: &TransferFunction, seg: &Seg2, a: f64, b: f64) -> ([f64; 3], f64) {
    let nodes = gl10();
    let rho = |x: f64| tf.extinction2(seg.s(x), seg.g(x));
    let h = (b - a) * seg.len;
    let mut c = [0.0; 3];
    let mut depth = 0.0;
    for &(t, w) in &nodes {
        let x = a + (b - a) * t;
        let tau: f64 = nodes.iter().map(|&(t2, w2)| w2 * rho(a + (x - a) * t2)).sum::<f64>() * (x - a) * seg.len;
        let e = tf.emission2(seg.s(x), seg.g(x));
        let wt = w * h * (-tau).exp();
        for k in 0..3 {
            c[k] += wt * e[k];
        }
        depth += w * h * rho(x);
    }
    (c, depth)
}

fn adaptive(tf: &TransferFunction, seg: &Seg2, a: f64, b: f64, tol: f64, level: u32) -> ([f64; 3], f64) {
    let (c, d) = panel(tf, seg, a, b);
    let m = 0.5 * (a + b);
    let (cl, dl) = panel(tf, seg, a, m);
    let (cr, dr) = panel(tf, seg, m, b);
    let tl = (-dl).exp();
    let c2: [f64; 3] = std::array::from_fn(|k| cl[k] + tl * cr[k]);
    let d2 = dl + dr;
    let err = (0..3).map(|k| (c[k] - c2[k]).abs()).fold(((-d).exp() - (-d2).exp()).abs(), f64::max);
    // A panel deeper than 2 is always split: its nodes could all sit behind
    // the part that emits (false convergence).
    if (err <= tol && d2 <= 2.0) || level >= 50 {
        return (c2, d2);
    }
    // The tolerance is not halved per level: f64 cannot reach tol·2^-40, and
    // the panels number in the hundreds, so the sum stays ~100·tol.
    let (cl, dl) = adaptive(tf, seg, a, m, tol, level + 1);
    // Behind an optical depth of 60 the right half is invisible (< 1e-26).
    let (cr, dr) = if dl > 60.0 { (cr, dr) } else { adaptive(tf, seg, m, b, tol, level + 1) };
    let tl = (-dl).exp();
    (std::array::from_fn(|k| cl[k] + tl * cr[k]), dl + dr)
}

/// Song et al.'s (2009) approximated-mode tables. For a sub-segment with colour κ and
/// extinction ρ linear between its ends, C = κ_f·F + κ_b·B (density) and
/// C = β·(κ_f·F + κ_b·B) (independent, β = d·(1 − e^(−D))/D, D = (a_f + a_b)/2).
/// F and B depend on the optical depths a_f = ρ_f·d, a_b = ρ_b·d only, so
/// the seed's (a_f, a_b, d) table collapses exactly to 2D; it is stored over
/// (α_f, α_b) = (1 − e^(−a_f), 1 − e^(−a_b)) ∈ [0, 1]² (the last row and
/// column stand for a = 1e6), `res` × `res`, row-major in α_f, bilinear.
#[derive(Debug, Clone, PartialEq)]
pub struct FbTable {
    res: usize,
    emission: Emission,
    f: Vec<f32>,
    b: Vec<f32>,
}

fn depth_of_alpha(alpha: f64) -> f64 {
    if alpha >= 1.0 {
        1e6
    } else {
        -(-alpha).ln_1p()
    }
}

impl FbTable {
    /// Bakes F and B for `emission` at `res` × `res` (res in 2..=4096).
    pub fn build(emission: Emission, res: usize) -> Option<Self> {
        if !(2..=4096).contains(&res) {
            return None;
        }
        use rayon::prelude::*;
        let rows: Vec<(Vec<f32>, Vec<f32>)> = (0..res)
            .into_par_iter()
            .map(|i| {
                let af = depth_of_alpha(i as f64 / (res - 1) as f64);
                let mut fr = Vec::with_capacity(res);
                let mut br = Vec::with_capacity(res);
                for j in 0..res {
                    let ab = depth_of_alpha(j as f64 / (res - 1) as f64);
                    let knots: [Knot; 2] = [(0.0, af, [1.0, 0.0, 0.0]), (1.0, ab, [0.0, 1.0, 0.0])];
                    let e = integrate_entry(&knots, 1.0, 1, emission);
                    let norm = match emission {
                        Emission::Density => 1.0,
                        Emission::Independent => {
                            let d = 0.5 * (af + ab);
                            if d > 1e-8 {
                                d / -(-d).exp_m1()
                            } else {
                                1.0 + 0.5 * d
                            }
                        }
                    };
                    fr.push((e.color[0][0] * norm) as f32);
                    br.push((e.color[0][1] * norm) as f32);
                }
                (fr, br)
            })
            .collect();
        let (f, b) = rows.into_iter().fold((Vec::new(), Vec::new()), |(mut f, mut b), (fr, br)| {
            f.extend(fr);
            b.extend(br);
            (f, b)
        });
        Some(FbTable { res, emission, f, b })
    }

    /// Rebuilds a table from stored parts; None when the lengths disagree
    /// with `res` or a value is not finite.
    pub fn from_parts(emission: Emission, res: usize, f: Vec<f32>, b: Vec<f32>) -> Option<Self> {
        let ok = (2..=4096).contains(&res)
            && f.len() == res * res
            && b.len() == res * res
            && f.iter().chain(&b).all(|v| v.is_finite());
        ok.then_some(FbTable { res, emission, f, b })
    }
    pub fn res(&self) -> usize {
        self.res
    }
    pub fn emission(&self) -> Emission {
        self.emission
    }
    pub fn f(&self) -> &[f32] {
        &self.f
    }
    pub fn b(&self) -> &[f32] {
        &self.b
    }

    /// (F, B) at (α_f, α_b), bilinear, clamped to [0, 1]².
    pub fn lookup(&self, alpha_f: f32, alpha_b: f32) -> (f32, f32) {
        let top = (self.res - 1) as f32;
        let u = (alpha_f * top).max(0.0).min(top);
        let v = (alpha_b * top).max(0.0).min(top);
        let i = (u as usize).min(self.res - 2);
        let j = (v as usize).min(self.res - 2);
        let (fu, fv) = (u - i as f32, v - j as f32);
        let at = |t: &[f32]| {
            let r0 = i * self.res + j;
            let r1 = r0 + self.res;
            (1.0 - fu) * ((1.0 - fv) * t[r0] + fv * t[r0 + 1]) + fu * ((1.0 - fv) * t[r1] + fv * t[r1 + 1])
        };
        (at(&self.f), at(&self.b))
    }
}

/// The `biv-approx` method: the segment cut into `k` equal sub-segments
/// (Song et al. 2009 §5, ray segment subdivision); at each end (s, g) gives κ and ρ
/// (pre-classification), each sub-segment is looked up in the [`FbTable`],
/// and the sub-segments are composited front to back.
#[derive(Debug, Clone)]
pub struct BivApprox {
    tf: TransferFunction,
    table: FbTable,
    k: usize,
}

impl BivApprox {
    /// `k` ≥ 1 sub-segments; the table's emission model must match the TF's.
    pub fn new(tf: TransferFunction, table: FbTable, k: usize) -> Option<Self> {
        ((1..=1024).contains(&k) && table.emission == tf.emission()).then_some(BivApprox { tf, table, k })
    }

    /// Bakes the table at `res` and builds the shader.
    pub fn build(tf: TransferFunction, res: usize, k: usize) -> Option<Self> {
        let table = FbTable::build(tf.emission(), res)?;
        Self::new(tf, table, k)
    }
    pub fn table(&self) -> &FbTable {
        &self.table
    }
    pub fn transfer_function(&self) -> &TransferFunction {
        &self.tf
    }
    pub fn subsegments(&self) -> usize {
        self.k
    }

    pub fn integrate(&self, seg: &Seg2) -> Rgba {
        let finite = [seg.sf, seg.sb, seg.gf, seg.gb].iter().all(|v| v.is_finite());
        if !finite || seg.len.is_nan() || seg.len <= 0.0 {
            return Rgba::default();
        }
        let len = seg.len.min(1e30);
        let d = len / self.k as f64;
        let at = |x: f64| {
            let (s, g) = (seg.s(x), seg.g(x));
            (self.tf.extinction2(s, g), self.tf.color2(s, g))
        };
        let (mut r0, mut k0) = at(0.0);
        let mut acc = [0.0f64; 3];
        let mut trans = 1.0f64;
        for j in 1..=self.k {
            let (r1, k1) = at(j as f64 / self.k as f64);
            let (a0, a1) = (r0 * d, r1 * d);
            let (f, b) = self.table.lookup(-(-a0).exp_m1() as f32, -(-a1).exp_m1() as f32);
            let depth = 0.5 * (a0 + a1);
            let alpha = -(-depth).exp_m1();
            let scale = match self.tf.emission() {
                Emission::Density => 1.0,
                Emission::Independent => {
                    if depth > 1e-8 {
                        alpha * d / depth
                    } else {
                        d * (1.0 - 0.5 * depth)
                    }
                }
            };
            for c in 0..3 {
                acc[c] += trans * scale * (k0[c] * f64::from(f) + k1[c] * f64::from(b));
            }
            trans *= 1.0 - alpha;
            (r0, k0) = (r1, k1);
        }
        Rgba { color: acc, alpha: 1.0 - trans }
    }
}

impl SegmentShader for BivApprox {
    fn method(&self) -> Method {
        Method::BivApprox
    }
    fn shade(&self, seg: &Segment) -> Rgba32 {
        let px = self.integrate(&Seg2::from(seg));
        [sat_f32(px.color[0]), sat_f32(px.color[1]), sat_f32(px.color[2]), px.alpha as f32]
    }
}
