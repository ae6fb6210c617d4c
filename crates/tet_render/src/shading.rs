//! Optional shading (off by default): Blinn–Phong lighting with the
//! interpolated per-vertex gradient as the normal, modulating emission,
//! several lights (a headlight, directional and point lights, ambient),
//! each optionally attenuated by the volume's own shadow; and silhouette
//! enhancement α·(1 − |ĝ·v|)^p (Song et al., "Ray casting of unstructured
//! meshes…", 2009 §6).
//!
//! The model, the same in every renderer and in the reference. At a point
//! x of a ray with unit normal n̂ (the gradient, normalized), unit vector v̂
//! towards the eye, and for light i the unit vector l̂ᵢ towards it, its
//! intensity Iᵢ and the volume's transmittance Vᵢ(x) from x to the light
//! (1 without shadows):
//!
//! ```text
//! D(x) = ka + Σᵢ Iᵢ Vᵢ kd |n̂·l̂ᵢ|          (multiplies the emitted colour)
//! S(x) = Σᵢ Iᵢ Vᵢ ks |n̂·ĥᵢ|^p,  ĥᵢ = (l̂ᵢ + v̂)/|l̂ᵢ + v̂|   (white, times extinction)
//! ```
//!
//! so a segment of colour C and opacity α becomes C·D + α·S when D and S
//! are taken as constant over it (the fast renderers, at the segment's
//! emission centroid, splitting it where they vary: [`light_segment`]),
//! and the reference integrates D and S along the ray with the
//! TF's emission and extinction. Lighting is two-sided: a gradient's sign
//! does not say which side is out. With the default single headlight
//! (l̂ = ĥ = v̂) this is the classic `C·(ka + kd|n̂·v̂|) + ks|n̂·v̂|^p·α`.
//!
//! Where the model has no answer the result is finite and documented:
//! * a zero or non-finite gradient has no direction: the sample is lit as
//!   an isotropic medium, `D = ka + Σᵢ Iᵢ Vᵢ kd` (every light at full
//!   diffuse strength, dimmed by its shadow), S = 0, no silhouette — with
//!   the default headlight that is D = 1, the sample as without lighting;
//!   below [`Shading::gradient_floor`] the terms blend linearly from these
//!   to the surface terms (a vanishing gradient's direction is noise);
//! * a point light at the sample itself has no direction: that light adds
//!   nothing there;
//! * a light exactly behind the sample as seen from the eye (l̂ = −v̂) has
//!   no half vector: no highlight from that light there (the diffuse term
//!   stays).

use glam::DVec3;
use serde::{Deserialize, Serialize};

use crate::RenderError;

/// Blinn–Phong coefficients; colour becomes C·(ambient + diffuse·|n·l|) +
/// specular·|n·h|^shininess·α (white highlight, premultiplied), summed over
/// the lights (see the module docs).
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct Light {
    pub ambient: f32,
    pub diffuse: f32,
    pub specular: f32,
    pub shininess: f32,
}

impl Default for Light {
    fn default() -> Self {
        Light { ambient: 0.3, diffuse: 0.7, specular: 0.2, shininess: 20.0 }
    }
}

/// Most lights one scene may have.
pub const MAX_LIGHTS: usize = 8;

/// A light, positions and directions in world coordinates (as in the view
/// file). No distance attenuation (VTK's default).
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(tag = "type", rename_all = "lowercase", deny_unknown_fields)]
pub enum LightSource {
    /// At the eye: l̂ = −(the ray's direction). Casts no shadow (its shadow
    /// would lie behind what it lights, as seen from the eye).
    Headlight {
        #[serde(default = "unit_intensity")]
        intensity: f64,
    },
    /// At infinity, light travelling along `direction` (from the light into
    /// the scene; any non-zero length, kept as a unit vector in a
    /// [`LightSet`]).
    Directional {
        direction: [f64; 3],
        #[serde(default = "unit_intensity")]
        intensity: f64,
    },
    /// At `position`, shining in all directions.
    Point {
        position: [f64; 3],
        #[serde(default = "unit_intensity")]
        intensity: f64,
    },
}

fn unit_intensity() -> f64 {
    1.0
}

impl LightSource {
    pub fn intensity(&self) -> f64 {
        match *self {
            LightSource::Headlight { intensity }
            | LightSource::Directional { intensity, .. }
            | LightSource::Point { intensity, .. } => intensity,
        }
    }

    /// Whether the light can cast a shadow (all but the headlight).
    pub fn casts_shadow(&self) -> bool {
        !matches!(self, LightSource::Headlight { .. })
    }

    /// Unit vector from `pos_in_world` towards the light and the distance to
    /// it (infinite for directional lights); `None` where it has no
    /// direction (a point light at the point itself). `view_dir` is the
    /// ray's unit direction (eye towards the sample).
    pub fn towards(&self, pos_in_world: DVec3, view_dir: DVec3) -> Option<(DVec3, f64)> {
        match *self {
            LightSource::Headlight { .. } => Some((-view_dir, f64::INFINITY)),
            LightSource::Directional { direction, .. } => {
                // A LightSet stores unit directions; others are normalized here.
                let d = DVec3::from(direction);
                let d = if (d.length_squared() - 1.0).abs() < 1e-12 { d } else { d.normalize() };
                Some((-d, f64::INFINITY))
            }
            LightSource::Point { position, .. } => {
                let d = DVec3::from(position) - pos_in_world;
                let len = d.length();
                (len > 0.0 && len.is_finite()).then(|| (d / len, len))
            }
        }
    }

    fn validate(&self, index: usize) -> Result<(), RenderError> {
        let bad = |why: &str| Err(RenderError::View(format!("lighting: light {index}: {why}")));
        let i = self.intensity();
        if !(i >= 0.0 && i.is_finite()) {
            return bad(&format!("intensity {i} is not a finite number ≥ 0"));
        }
        match *self {
            LightSource::Headlight { .. } => Ok(()),
            LightSource::Directional { direction, .. } => {
                let d = DVec3::from(direction);
                if !d.is_finite() || d.length_squared() == 0.0 || !d.normalize().is_finite() {
                    return bad(&format!("direction {direction:?} is zero or not finite"));
                }
                Ok(())
            }
            LightSource::Point { position, .. } => {
                if !DVec3::from(position).is_finite() {
                    return bad(&format!("position {position:?} is not finite"));
                }
                Ok(())
            }
        }
    }
}

/// Up to [`MAX_LIGHTS`] lights (a fixed array, so [`Shading`] stays `Copy`).
/// The default is one headlight of intensity 1.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(try_from = "Vec<LightSource>", into = "Vec<LightSource>")]
pub struct LightSet {
    n: usize,
    items: [LightSource; MAX_LIGHTS],
}

impl Default for LightSet {
    fn default() -> Self {
        LightSet::new(&[LightSource::Headlight { intensity: 1.0 }]).expect("one valid light")
    }
}

impl LightSet {
    /// Checks every light (finite positions, non-zero directions, finite
    /// intensities ≥ 0) and that there are at most [`MAX_LIGHTS`].
    pub fn new(lights: &[LightSource]) -> Result<LightSet, RenderError> {
        if lights.len() > MAX_LIGHTS {
            return Err(RenderError::View(format!("lighting: {} lights, at most {MAX_LIGHTS}", lights.len())));
        }
        let mut items = [LightSource::Headlight { intensity: 0.0 }; MAX_LIGHTS];
        for (i, l) in lights.iter().enumerate() {
            l.validate(i)?;
            items[i] = match *l {
                // Stored as a unit vector: lighting uses it per sample.
                LightSource::Directional { direction, intensity } => {
                    LightSource::Directional { direction: DVec3::from(direction).normalize().into(), intensity }
                }
                other => other,
            };
        }
        Ok(LightSet { n: lights.len(), items })
    }

    pub fn lights(&self) -> &[LightSource] {
        &self.items[..self.n]
    }

    /// Whether any light casts a shadow.
    pub fn any_shadow(&self) -> bool {
        self.lights().iter().any(LightSource::casts_shadow)
    }
}

impl TryFrom<Vec<LightSource>> for LightSet {
    type Error = RenderError;
    fn try_from(v: Vec<LightSource>) -> Result<Self, RenderError> {
        LightSet::new(&v)
    }
}

impl From<LightSet> for Vec<LightSource> {
    fn from(s: LightSet) -> Self {
        s.lights().to_vec()
    }
}

/// What shading to apply; `Shading::default()` applies none.
#[derive(Debug, Clone, Copy, PartialEq, Default, Serialize, Deserialize)]
pub struct Shading {
    /// The material; `None`: no lighting.
    pub light: Option<Light>,
    /// Silhouette exponent p: opacity and colour scaled by (1 − |ĝ·v|)^p.
    pub silhouette: Option<f32>,
    /// The lights (with `light` set); default one headlight.
    #[serde(default)]
    pub sources: LightSet,
    /// Attenuate each shadow-casting light by the volume's transmittance
    /// towards it (a shadow field the renderer is given; the reference
    /// casts exact shadow rays).
    #[serde(default)]
    pub shadows: bool,
    /// Gradient magnitude (scalar units per world length) below which
    /// surface shading fades linearly into the isotropic medium's (see the
    /// module docs): at |g| = 0 no normal is used, from |g| ≥
    /// `gradient_floor` fully shaded. Where the gradient vanishes (a peak,
    /// a plateau) its direction is noise and swings within a cell; the fade
    /// keeps the lighting continuous there. 0 (the default): no fade.
    /// [`Shading::gradient_floor_for`] picks one.
    #[serde(default)]
    pub gradient_floor: f32,
}

/// `x.powi(n)` inline, bit for bit: the square-and-multiply sequence of
/// the runtime's `__powidf2` (what `powi` with an exponent known only at run
/// time calls), without the call (a lit sample evaluates it per light).
#[inline(always)]
fn powi_inline(mut x: f64, mut n: u32) -> f64 {
    let mut r = 1.0;
    loop {
        if n & 1 == 1 {
            r *= x;
        }
        n >>= 1;
        if n == 0 {
            return r;
        }
        x *= x;
    }
}

/// x^p for x in [0, 1]: by multiplications when p is a whole number up to
/// 128 (the usual shininess; a tenth of `powf`'s cost), else `powf`.
#[inline]
fn pow_shininess(x: f64, p: f32) -> f64 {
    if p == p.trunc() && (0.0..=128.0).contains(&p) {
        powi_inline(x, p as u32)
    } else {
        x.powf(p as f64)
    }
}

/// The lighting terms at one point: emitted colour times `diffuse`, plus
/// white `specular` times extinction (see the module docs); `silhouette`
/// scales everything.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct LitPoint {
    pub diffuse: f64,
    pub specular: f64,
    pub silhouette: f64,
}

impl LitPoint {
    /// Unshaded: the sample as without lighting.
    pub const NONE: LitPoint = LitPoint { diffuse: 1.0, specular: 0.0, silhouette: 1.0 };

    /// Premultiplied `rgba` of a segment lit by these (constant) terms.
    pub fn apply(&self, rgba: [f32; 4]) -> [f32; 4] {
        let (d, s, k) = (self.diffuse as f32, self.specular as f32, self.silhouette as f32);
        [(rgba[0] * d + s * rgba[3]) * k, (rgba[1] * d + s * rgba[3]) * k, (rgba[2] * d + s * rgba[3]) * k, rgba[3] * k]
    }
}

impl Shading {
    /// The default fade for a scene: 2% of the scalar range over the
    /// bounding-box diagonal (the gradient of a field rising through its
    /// range 50 times slower than across the whole mesh).
    pub fn gradient_floor_for(scalar_range: [f64; 2], bounds_min: [f64; 3], bounds_max: [f64; 3]) -> f32 {
        let diag = DVec3::from(bounds_max).distance(DVec3::from(bounds_min));
        let floor = 0.02 * (scalar_range[1] - scalar_range[0]) / diag;
        if floor.is_finite() && floor > 0.0 {
            floor as f32
        } else {
            0.0
        }
    }

    /// Whether any shading is on (then the scene needs gradients).
    pub fn is_active(&self) -> bool {
        self.light.is_some() || self.silhouette.is_some()
    }

    /// Whether lighting needs shadow transmittances (lights on, shadows on,
    /// and a light that casts one).
    pub fn wants_shadows(&self) -> bool {
        self.light.is_some() && self.shadows && self.sources.any_shadow()
    }

    /// Whether any light needs the sample's position (point lights).
    pub fn needs_position(&self) -> bool {
        self.light.is_some() && self.sources.lights().iter().any(|l| matches!(l, LightSource::Point { .. }))
    }

    /// The lighting terms for gradient `grad` (any length, world frame) at
    /// `pos_in_world`, seen along unit `view_dir` (eye towards the sample),
    /// with `shadow(i)` the transmittance towards light i (called only for
    /// lights that cast shadows, and only with [`Shading::shadows`] on).
    pub fn lit_point(
        &self,
        grad: DVec3,
        pos_in_world: DVec3,
        view_dir: DVec3,
        mut shadow: impl FnMut(usize) -> f64,
    ) -> LitPoint {
        let len = grad.length();
        let has_direction = len > 0.0 && len.is_finite();
        let n = if has_direction { grad / len } else { DVec3::ZERO };
        // How much of surface shading applies (the rest is the isotropic
        // medium's): 0 without a direction, rising to 1 at the floor.
        let weight = match has_direction {
            false => 0.0,
            true if (len as f32) < self.gradient_floor => len / self.gradient_floor as f64,
            true => 1.0,
        };
        let mut out = LitPoint::NONE;
        if let Some(m) = self.light {
            let to_eye = -view_dir;
            let (mut d_iso, mut d, mut s) = (m.ambient as f64, m.ambient as f64, 0.0);
            for (i, l) in self.sources.lights().iter().enumerate() {
                let Some((to_light, _)) = l.towards(pos_in_world, view_dir) else { continue };
                let mut w = l.intensity();
                if self.shadows && l.casts_shadow() {
                    w *= shadow(i);
                }
                if w == 0.0 {
                    continue;
                }
                d_iso += w * m.diffuse as f64;
                if weight == 0.0 {
                    continue;
                }
                d += w * m.diffuse as f64 * n.dot(to_light).abs().min(1.0);
                let h = to_light + to_eye;
                let h_len = h.length();
                // h_len is 0 (or rounding noise) only for a light exactly
                // behind the sample: no highlight.
                if h_len > 1e-9 {
                    s += w * m.specular as f64 * pow_shininess((n.dot(h) / h_len).abs().min(1.0), m.shininess);
                }
            }
            out.diffuse = d_iso + weight * (d - d_iso);
            out.specular = weight * s;
        }
        if weight == 0.0 {
            return out;
        }
        if let Some(p) = self.silhouette {
            let n_dot_v = n.dot(view_dir).abs().min(1.0);
            out.silhouette = 1.0 + weight * ((1.0 - n_dot_v).max(0.0).powf(p as f64) - 1.0);
        }
        out
    }

    /// Modulates premultiplied `rgba` for gradient `grad` at `pos_in_world`
    /// seen along unit `view_dir`, shadows from `shadow` (see
    /// [`Shading::lit_point`]).
    pub fn apply(
        &self,
        rgba: [f32; 4],
        grad: DVec3,
        pos_in_world: DVec3,
        view_dir: DVec3,
        shadow: impl FnMut(usize) -> f64,
    ) -> [f32; 4] {
        self.lit_point(grad, pos_in_world, view_dir, shadow).apply(rgba)
    }
}

/// Lighting error allowed per segment before it is split: the lighting
/// terms' variation over the segment times its largest premultiplied
/// component (a first-order bound on the one-point rule's error).
pub const LIT_SPLIT_TOLERANCE: f64 = 5e-4;

/// Most pieces a lit segment is split into (at most one shading batch).
pub const LIT_MAX_PIECES: usize = 32;
const _: () = assert!(LIT_MAX_PIECES <= tet_preint::BATCH);

/// [`light_segment`]'s scratch: the pieces of a split segment and their
/// colours, one shading batch, kept by each tile so that a split zeroes no
/// 2 KiB of arrays.
#[derive(Debug, Clone)]
pub struct LitPieces {
    batch: tet_preint::SegmentBatch,
    rgba: [tet_preint::Rgba32; tet_preint::BATCH],
}

impl Default for LitPieces {
    fn default() -> Self {
        LitPieces { batch: tet_preint::SegmentBatch::default(), rgba: [[0.0; 4]; tet_preint::BATCH] }
    }
}

/// Where along a segment of opacity `alpha` its light comes from, as a
/// fraction of its length: the centroid of the emission weight e^(−τu)
/// for a constant extinction of total depth τ = −ln(1 − α), which is
/// 1/τ − (1 − α)/α — ½ for a transparent segment, → 0 (its front) for an
/// opaque one. The one point at which a segment is lit.
pub fn emission_centroid(alpha: f32) -> f32 {
    let a = alpha as f64;
    if a.is_nan() || a <= 1e-4 {
        return 0.5;
    }
    if a >= 1.0 {
        return 0.0;
    }
    let tau = -(-a).ln_1p();
    (1.0 / tau - (1.0 - a) / a).clamp(0.0, 0.5) as f32
}

/// Lights segment `seg`, shaded `c`, whose lighting terms at fraction w
/// (0 front, 1 back) are `lit_at(w)`: at its emission centroid
/// ([`emission_centroid`]; the midpoint for a thin segment) where the terms vary
/// little over it, else split into up to [`LIT_MAX_PIECES`] equal pieces
/// (their number growing with the square root of variation × colour, as
/// the midpoint rule's error falls with the square of the piece), each
/// shaded by `shade_batch` (all pieces in one batch, so a table's batched
/// lookup serves them; [`SegmentShader::shade_batch`] returns what
/// `shade` would, piece by piece) and lit at its own emission centroid,
/// composited in order; a piece across which the terms at the pieces'
/// points still change by more than [`LIT_RESPLIT_TOLERANCE`] is split
/// again (`resplit_pieces`, a second batch). A
/// highlight or a shadow edge inside one long segment is thus not decided
/// by a single point. `front`: the terms at the segment's front when the
/// caller has them (the previous segment's back, returned as the second
/// value when it was computed). Both CPU renderers call this.
///
/// [`SegmentShader::shade_batch`]: tet_preint::SegmentShader::shade_batch
pub fn light_segment(
    seg: &tet_preint::Segment,
    c: [f32; 4],
    front: Option<LitPoint>,
    mut lit_at: impl FnMut(f32) -> LitPoint,
    mut shade_batch: impl FnMut(&tet_preint::SegmentBatch, &mut [tet_preint::Rgba32; tet_preint::BATCH]),
    scratch: &mut LitPieces,
) -> ([f32; 4], Option<LitPoint>) {
    let weight = c.iter().fold(0.0f32, |a, &x| a.max(x)) as f64;
    if weight == 0.0 {
        // Nothing to light (every term scales the colour or the opacity).
        return (c, None);
    }
    let mid = lit_at(emission_centroid(c[3]));
    // The variation of D, S and the silhouette factor is at most about 4
    // (two intervals of each): a segment this faint is never split.
    if weight * 4.0 < LIT_SPLIT_TOLERANCE {
        return (mid.apply(c), None);
    }
    let front = front.unwrap_or_else(|| lit_at(0.0));
    let back = lit_at(1.0);
    let var = |f: fn(&LitPoint) -> f64| (f(&front) - f(&mid)).abs() + (f(&mid) - f(&back)).abs();
    let variation = var(|p| p.diffuse) + var(|p| p.specular) + var(|p| p.silhouette);
    let pieces = ((variation * weight / LIT_SPLIT_TOLERANCE).sqrt().ceil() as usize).clamp(1, LIT_MAX_PIECES);
    if pieces == 1 {
        return (mid.apply(c), Some(back));
    }
    let mut out = [0.0f32; 4];
    let step = 1.0 / pieces as f32;
    let bounds = |j: usize| (j as f32 * step, (j + 1) as f32 * step);
    // LIT_MAX_PIECES ≤ BATCH: every piece in one batch.
    let LitPieces { batch, rgba: shaded } = &mut *scratch;
    for j in 0..pieces {
        let (w0, w1) = bounds(j);
        set_piece(batch, j, seg, (w0, w1), seg.len_world * step);
    }
    batch.len = pieces;
    shade_batch(batch, shaded);
    // Each piece lit at its own emission centroid (the terms there kept
    // for the second level).
    let mut at = [LitPoint::NONE; LIT_MAX_PIECES];
    let mut lit = [[0.0f32; 4]; LIT_MAX_PIECES];
    for (j, &rgba) in shaded.iter().enumerate().take(pieces) {
        let (w0, w1) = bounds(j);
        at[j] = lit_at(w0 + (w1 - w0) * emission_centroid(rgba[3]));
        lit[j] = at[j].apply(rgba);
    }
    let first: [tet_preint::Rgba32; LIT_MAX_PIECES] = std::array::from_fn(|j| shaded[j]);
    resplit_pieces(
        seg,
        pieces,
        &first[..pieces],
        (front, back),
        &at[..pieces],
        &mut lit[..pieces],
        &mut lit_at,
        &mut shade_batch,
        scratch,
    );
    for l in lit.iter().take(pieces) {
        let t = 1.0 - out[3];
        for (o, &c) in out.iter_mut().zip(l) {
            *o += t * c;
        }
    }
    (out, Some(back))
}

/// How much the lighting terms may change across one piece of a split
/// segment, times its colour, before the piece is split again
/// (`resplit_pieces`). Chosen by measurement against the held-out TFs
/// (crates/tet_engine/results/lighting.md): at the split tolerance itself
/// a third of the pieces were split again for little more accuracy than
/// at 4× it, where few are.
pub const LIT_RESPLIT_TOLERANCE: f64 = 4.0 * LIT_SPLIT_TOLERANCE;

/// Most pieces one piece of a split segment is split into again
/// (`resplit_pieces`).
pub const LIT_MAX_SUBPIECES: usize = 8;

/// Sets entry `n` of `batch` to the part of `seg` from fraction `w0` to
/// `w1` (its values linear along it), `len_world` long.
fn set_piece(
    batch: &mut tet_preint::SegmentBatch,
    n: usize,
    seg: &tet_preint::Segment,
    (w0, w1): (f32, f32),
    len_world: f32,
) {
    let lerp = |a: f32, b: f32, w: f32| a + w * (b - a);
    batch.s_front[n] = lerp(seg.s_front, seg.s_back, w0);
    batch.s_back[n] = lerp(seg.s_front, seg.s_back, w1);
    batch.grad_front[n] = lerp(seg.grad_front, seg.grad_back, w0);
    batch.grad_back[n] = lerp(seg.grad_front, seg.grad_back, w1);
    batch.len_world[n] = len_world;
}

/// The terms' difference between two points (the variation measure of
/// [`light_segment`]).
fn jump(a: &LitPoint, b: &LitPoint) -> f64 {
    (a.diffuse - b.diffuse).abs() + (a.specular - b.specular).abs() + (a.silhouette - b.silhouette).abs()
}

/// The second level of [`light_segment`]'s split. The segment's front,
/// middle and back may not show what the terms do inside it (a thin
/// layer's shadow dips the light over a fraction of one piece), and a
/// piece lit at one point is only right where its emission lies where
/// constant extinction puts it (a narrow TF peak inside a piece puts it
/// elsewhere). Where the terms sampled at the pieces' points `at` (the
/// front and back at the ends) change across a piece by more than
/// [`LIT_RESPLIT_TOLERANCE`] over its colour, the piece is split again into up to
/// [`LIT_MAX_SUBPIECES`] equal pieces (as many as the square root of that
/// change over the tolerance, as at the first level), shaded together in
/// one batch, each lit at its own emission centroid, composited in order;
/// `lit[j]` becomes piece j's colour.
#[allow(clippy::too_many_arguments)]
fn resplit_pieces(
    seg: &tet_preint::Segment,
    pieces: usize,
    shaded: &[tet_preint::Rgba32],
    (front, back): (LitPoint, LitPoint),
    at: &[LitPoint],
    lit: &mut [[f32; 4]],
    lit_at: &mut impl FnMut(f32) -> LitPoint,
    shade_batch: &mut impl FnMut(&tet_preint::SegmentBatch, &mut [tet_preint::Rgba32; tet_preint::BATCH]),
    scratch: &mut LitPieces,
) {
    let mut subpieces = [0usize; LIT_MAX_PIECES];
    let mut total = 0;
    for j in 0..pieces {
        let colour = shaded[j].iter().fold(0.0f32, |a, &x| a.max(x)) as f64;
        let prev = if j == 0 { front } else { at[j - 1] };
        let next = if j + 1 == pieces { back } else { at[j + 1] };
        let change = 0.5 * (jump(&prev, &at[j]) + jump(&at[j], &next)) * colour;
        if change <= LIT_RESPLIT_TOLERANCE {
            continue;
        }
        let k = ((change / LIT_SPLIT_TOLERANCE).sqrt().ceil() as usize).clamp(2, LIT_MAX_SUBPIECES);
        let k = k.min(tet_preint::BATCH - total);
        if k < 2 {
            break;
        }
        subpieces[j] = k;
        total += k;
    }
    if total == 0 {
        return;
    }
    let step = 1.0 / pieces as f32;
    let LitPieces { batch, rgba: sub_shaded } = scratch;
    let mut n = 0;
    for (j, &k) in subpieces.iter().enumerate().take(pieces) {
        for q in 0..k {
            let (w0, w1) = ((j as f32 + q as f32 / k as f32) * step, (j as f32 + (q + 1) as f32 / k as f32) * step);
            set_piece(batch, n, seg, (w0, w1), seg.len_world * (w1 - w0));
            n += 1;
        }
    }
    batch.len = n;
    shade_batch(batch, sub_shaded);
    let mut n = 0;
    for (j, &k) in subpieces.iter().enumerate().take(pieces) {
        if k == 0 {
            continue;
        }
        let mut out = [0.0f32; 4];
        for q in 0..k {
            let rgba = sub_shaded[n];
            n += 1;
            let w = (j as f32 + (q as f32 + emission_centroid(rgba[3])) / k as f32) * step;
            let c = lit_at(w).apply(rgba);
            let t = 1.0 - out[3];
            for (o, x) in out.iter_mut().zip(c) {
                *o += t * x;
            }
        }
        lit[j] = out;
    }
}

/// The `"lighting"` object of a view file: the material, the lights and
/// the shadow switch.
///
/// ```json
/// "lighting": {"ambient": 0.2, "diffuse": 0.8, "specular": 0.3, "shininess": 30,
///              "lights": [{"type": "directional", "direction": [1, -1, -1]},
///                         {"type": "point", "position": [0, 5, 0], "intensity": 0.5}],
///              "shadows": true}
/// ```
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Lighting {
    #[serde(default = "default_ambient")]
    pub ambient: f32,
    #[serde(default = "default_diffuse")]
    pub diffuse: f32,
    #[serde(default = "default_specular")]
    pub specular: f32,
    #[serde(default = "default_shininess")]
    pub shininess: f32,
    #[serde(default)]
    pub lights: LightSet,
    #[serde(default)]
    pub shadows: bool,
}

fn default_ambient() -> f32 {
    Light::default().ambient
}
fn default_diffuse() -> f32 {
    Light::default().diffuse
}
fn default_specular() -> f32 {
    Light::default().specular
}
fn default_shininess() -> f32 {
    Light::default().shininess
}

impl Default for Lighting {
    fn default() -> Self {
        let m = Light::default();
        Lighting {
            ambient: m.ambient,
            diffuse: m.diffuse,
            specular: m.specular,
            shininess: m.shininess,
            lights: LightSet::default(),
            shadows: false,
        }
    }
}

impl Lighting {
    /// The `"lighting"` object of a view file's JSON text, if it has one.
    pub fn from_view_json(text: &str) -> Result<Option<Lighting>, RenderError> {
        let v: serde_json::Value = serde_json::from_str(text).map_err(|e| RenderError::View(e.to_string()))?;
        let Some(l) = v.get("lighting") else { return Ok(None) };
        let l: Lighting = serde_json::from_value(l.clone()).map_err(|e| RenderError::View(format!("lighting: {e}")))?;
        let m = l.material();
        for (name, x) in [("ambient", m.ambient), ("diffuse", m.diffuse), ("specular", m.specular)] {
            if !(x >= 0.0 && x.is_finite()) {
                return Err(RenderError::View(format!("lighting: {name} {x} is not a finite number ≥ 0")));
            }
        }
        if !(m.shininess >= 0.0 && m.shininess.is_finite()) {
            return Err(RenderError::View(format!("lighting: shininess {} is not a finite number ≥ 0", m.shininess)));
        }
        Ok(Some(l))
    }

    /// The lighting a front end renders with, from what the user gave: a
    /// view file's `"lighting"` (which turns lighting on), else one
    /// directional light travelling along `light_dir`, else the headlight
    /// when `light` or `shadows` is set; `shadows` turns shadows on. `None`:
    /// unlit. A `light_dir` beside a view file's lighting, a zero or
    /// non-finite `light_dir`, and shadows with only a headlight are
    /// errors (what to change in the message).
    pub fn choose(
        from_view: Option<Lighting>,
        light: bool,
        light_dir: Option<[f64; 3]>,
        shadows: bool,
    ) -> Result<Option<Lighting>, RenderError> {
        let mut lighting = match (from_view, light_dir) {
            (Some(_), Some(_)) => {
                return Err(RenderError::View(
                    "light direction: the view file has its own \"lighting\" (edit its lights)".into(),
                ))
            }
            (Some(l), None) => l,
            (None, Some(d)) => {
                let lights = LightSet::new(&[LightSource::Directional { direction: d, intensity: 1.0 }])?;
                Lighting { lights, ..Default::default() }
            }
            (None, None) if light || shadows => Lighting::default(),
            (None, None) => return Ok(None),
        };
        lighting.shadows |= shadows;
        if lighting.shadows && !lighting.lights.any_shadow() {
            return Err(RenderError::View(
                "shadows: the headlight casts no shadow; add a directional or point light (a light direction, or \"lights\" in the view file)".into(),
            ));
        }
        Ok(Some(lighting))
    }

    pub fn material(&self) -> Light {
        Light { ambient: self.ambient, diffuse: self.diffuse, specular: self.specular, shininess: self.shininess }
    }

    /// Shading with this lighting (and `silhouette`).
    pub fn shading(&self, silhouette: Option<f32>) -> Shading {
        Shading {
            light: Some(self.material()),
            silhouette,
            sources: self.lights,
            shadows: self.shadows,
            gradient_floor: 0.0,
        }
    }

    /// The `"lighting"` value for a view file.
    pub fn to_json_value(&self) -> serde_json::Value {
        serde_json::to_value(self).expect("lighting always serializes")
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn no_shadow(_: usize) -> f64 {
        1.0
    }

    fn apply(s: &Shading, px: [f32; 4], g: DVec3, v: DVec3) -> [f32; 4] {
        s.apply(px, g, DVec3::ZERO, v, no_shadow)
    }

    #[test]
    fn powi_inline_is_powi_bit_for_bit() {
        let mut rng = tet_mesh::XorShift64(7);
        let mut xs = vec![0.0, 1.0, 0.5, 1.0 - f64::EPSILON, f64::MIN_POSITIVE, 1e-300, 0.999_999];
        xs.extend((0..200).map(|_| rng.range(0.0, 1.0)));
        for &x in &xs {
            for n in 0..=128u32 {
                // black_box: an exponent LLVM cannot see, as in lit_point.
                let want = x.powi(std::hint::black_box(n as i32));
                assert_eq!(powi_inline(x, n).to_bits(), want.to_bits(), "{x}^{n}");
            }
        }
    }

    const BATCH_STALE: usize = 40;

    /// The two-level split written out plainly: the first level's pieces,
    /// each lit at its own emission centroid, and a piece across which the
    /// terms at the neighbouring points change by more than the resplit
    /// tolerance over its colour split again (subpieces shaded one by one).
    fn lit_by_hand(
        seg: &tet_preint::Segment,
        c: [f32; 4],
        lit_at: impl Fn(f32) -> LitPoint,
        shade_one: impl Fn(&tet_preint::Segment) -> [f32; 4],
    ) -> ([f32; 4], usize, usize) {
        let weight = c.iter().fold(0.0f32, |a, &x| a.max(x)) as f64;
        let (f, m, bk) = (lit_at(0.0), lit_at(emission_centroid(c[3])), lit_at(1.0));
        let var = |g: fn(&LitPoint) -> f64| (g(&f) - g(&m)).abs() + (g(&m) - g(&bk)).abs();
        let variation = var(|p| p.diffuse) + var(|p| p.specular) + var(|p| p.silhouette);
        let pieces = ((variation * weight / LIT_SPLIT_TOLERANCE).sqrt().ceil() as usize).clamp(1, LIT_MAX_PIECES);
        let lerp = |a: f32, b: f32, w: f32| a + w * (b - a);
        let part = |w0: f32, w1: f32| tet_preint::Segment {
            s_front: lerp(seg.s_front, seg.s_back, w0),
            s_back: lerp(seg.s_front, seg.s_back, w1),
            grad_front: lerp(seg.grad_front, seg.grad_back, w0),
            grad_back: lerp(seg.grad_front, seg.grad_back, w1),
            len_world: seg.len_world * (w1 - w0),
        };
        let step = 1.0 / pieces as f32;
        let rgba: Vec<[f32; 4]> =
            (0..pieces).map(|j| shade_one(&part(j as f32 * step, (j + 1) as f32 * step))).collect();
        let at: Vec<LitPoint> =
            (0..pieces).map(|j| lit_at((j as f32 + emission_centroid(rgba[j][3])) * step)).collect();
        let (mut want, mut resplit, mut total) = ([0.0f32; 4], 0, 0);
        let over = |out: &mut [f32; 4], lit: [f32; 4]| {
            let t = 1.0 - out[3];
            for (o, l) in out.iter_mut().zip(lit) {
                *o += t * l;
            }
        };
        for j in 0..pieces {
            let colour = rgba[j].iter().fold(0.0f32, |a, &x| a.max(x)) as f64;
            let (prev, next) = (if j == 0 { f } else { at[j - 1] }, if j + 1 == pieces { bk } else { at[j + 1] });
            let change = 0.5 * (jump(&prev, &at[j]) + jump(&at[j], &next)) * colour;
            let k = ((change / LIT_SPLIT_TOLERANCE).sqrt().ceil() as usize).clamp(2, LIT_MAX_SUBPIECES);
            let k = k.min(tet_preint::BATCH - total);
            if change <= LIT_RESPLIT_TOLERANCE || k < 2 {
                over(&mut want, at[j].apply(rgba[j]));
                continue;
            }
            resplit += 1;
            total += k;
            let mut sub = [0.0f32; 4];
            for q in 0..k {
                let (w0, w1) = ((j as f32 + q as f32 / k as f32) * step, (j as f32 + (q + 1) as f32 / k as f32) * step);
                let r = shade_one(&part(w0, w1));
                over(&mut sub, lit_at((j as f32 + (q as f32 + emission_centroid(r[3])) / k as f32) * step).apply(r));
            }
            over(&mut want, sub);
        }
        (want, pieces, resplit)
    }

    /// A split segment's pieces shaded in batches give what shading them
    /// one by one gave: the same pieces, the same order, each lit at its
    /// own emission centroid; the pieces split again likewise, from a
    /// second batch.
    #[test]
    fn a_split_segment_is_lit_piece_by_piece_from_two_batches() {
        let seg = tet_preint::Segment { s_front: 0.1, s_back: 0.9, grad_front: 0.3, grad_back: 1.7, len_world: 2.0 };
        let shade_one = |p: &tet_preint::Segment| -> [f32; 4] {
            let a = (0.4 * p.len_world * (p.s_front + p.s_back)).min(0.9);
            [0.5 * a, 0.3 * a * p.grad_back, 0.2 * a, a]
        };
        // Terms varying strongly along the segment, and steeply near the
        // back: many pieces, the last ones split again.
        let lit_at = |w: f32| LitPoint {
            diffuse: 0.2 + 3.0 * w as f64 + 4.0 * (w as f64).powi(8),
            specular: (w * w) as f64,
            silhouette: 1.0,
        };
        let c = shade_one(&seg);
        let mut calls = 0;
        let mut scratch = LitPieces::default();
        // Stale pieces from an earlier, longer split must not matter.
        scratch.batch.len = BATCH_STALE;
        scratch.batch.s_front.fill(f32::NAN);
        let (got, back) = light_segment(
            &seg,
            c,
            None,
            lit_at,
            |b, out| {
                calls += 1;
                for (i, o) in out.iter_mut().enumerate().take(b.len) {
                    *o = shade_one(&b.get(i));
                }
            },
            &mut scratch,
        );
        let (want, pieces, resplit) = lit_by_hand(&seg, c, lit_at, shade_one);
        assert!(pieces > 8, "{pieces}");
        assert!(resplit > 0 && resplit < pieces, "{resplit} of {pieces} split again");
        assert_eq!(calls, 2);
        assert_eq!(got, want);
        assert_eq!(back, Some(lit_at(1.0)));
    }

    /// A thin layer's shadow crossing a segment dips the light over a few
    /// percent of it, where a narrow peak of the TF puts most of the
    /// segment's emission: the pieces split again follow both, and the
    /// segment's colour comes within 1e-2 of the integral (a 4096-piece
    /// split; the segment is 0.8 opaque), where one level alone, lit at
    /// points on either side of the dip, misses it by more than ten times
    /// that.
    #[test]
    fn a_shadow_dip_over_a_narrow_peak_is_followed() {
        let seg = tet_preint::Segment { s_front: 0.0, s_back: 1.0, grad_front: 1.0, grad_back: 1.0, len_world: 1.0 };
        // Extinction peaked around s = 0.13; grey emission.
        let kappa = |s: f64| 0.2 + 40.0 * (-((s - 0.13) / 0.02).powi(2)).exp();
        let shade_one = |p: &tet_preint::Segment| -> [f32; 4] {
            let (a, b) = (p.s_front as f64, p.s_back as f64);
            let tau: f64 =
                (0..64).map(|q| kappa(a + (b - a) * (q as f64 + 0.5) / 64.0)).sum::<f64>() / 64.0 * p.len_world as f64;
            let alpha = -(-tau).exp_m1();
            [0.8 * alpha as f32, 0.6 * alpha as f32, 0.4 * alpha as f32, alpha as f32]
        };
        // The light falls gently along the segment (a few pieces) and dips
        // by 0.6 around w = 0.15 over ±0.04, inside one piece.
        let lit_at = |w: f32| LitPoint {
            diffuse: 0.9 - 0.03 * w as f64 - 0.6 * (-((w as f64 - 0.15) / 0.04).powi(2)).exp(),
            specular: 0.0,
            silhouette: 1.0,
        };
        let c = shade_one(&seg);
        let mut scratch = LitPieces::default();
        let (got, _) = light_segment(
            &seg,
            c,
            None,
            lit_at,
            |b, out| {
                for (i, o) in out.iter_mut().enumerate().take(b.len) {
                    *o = shade_one(&b.get(i));
                }
            },
            &mut scratch,
        );
        // `n` equal pieces, each lit at `at(w0, w1, its colour)`, composited.
        let even = |n: usize, at: &dyn Fn(f32, f32, [f32; 4]) -> f32| -> [f32; 4] {
            let mut out = [0.0f32; 4];
            for j in 0..n {
                let (w0, w1) = (j as f32 / n as f32, (j + 1) as f32 / n as f32);
                let p = tet_preint::Segment {
                    s_front: w0,
                    s_back: w1,
                    grad_front: 1.0,
                    grad_back: 1.0,
                    len_world: w1 - w0,
                };
                let r = shade_one(&p);
                let lit = lit_at(at(w0, w1, r)).apply(r);
                let t = 1.0 - out[3];
                for (o, l) in out.iter_mut().zip(lit) {
                    *o += t * l;
                }
            }
            out
        };
        let exact = even(4096, &|w0, w1, _| 0.5 * (w0 + w1));
        let err = |a: [f32; 4]| a.iter().zip(exact).map(|(x, y)| (x - y).abs()).fold(0.0f32, f32::max);
        // One level: the first-level pieces, each lit at its centroid.
        let one_level = {
            let (f, m, bk) = (lit_at(0.0), lit_at(emission_centroid(c[3])), lit_at(1.0));
            let var = (f.diffuse - m.diffuse).abs() + (m.diffuse - bk.diffuse).abs();
            let weight = c.iter().fold(0.0f32, |a, &x| a.max(x)) as f64;
            let pieces = ((var * weight / LIT_SPLIT_TOLERANCE).sqrt().ceil() as usize).clamp(1, LIT_MAX_PIECES);
            even(pieces, &|w0, w1, r| w0 + (w1 - w0) * emission_centroid(r[3]))
        };
        // Measured: 7.0e-3 against 0.23.
        assert!(err(got) < 1e-2, "two levels off by {}", err(got));
        assert!(err(one_level) > 10.0 * err(got), "one level {} against two {}", err(one_level), err(got));
    }

    #[test]
    fn off_by_default_and_silhouette_fades_facing_surfaces() {
        let s = Shading::default();
        assert!(!s.is_active());
        let px = [0.2, 0.1, 0.0, 0.5];
        assert_eq!(apply(&s, px, DVec3::Z, DVec3::Z), px);
        let s = Shading { silhouette: Some(2.0), ..Default::default() };
        // Gradient along the view: face-on, fully faded; across it: kept.
        assert_eq!(apply(&s, px, DVec3::Z, DVec3::Z), [0.0; 4]);
        assert_eq!(apply(&s, px, DVec3::X, DVec3::Z), px);
        assert_eq!(apply(&s, px, DVec3::ZERO, DVec3::Z), px);
    }

    #[test]
    fn headlight_is_two_sided() {
        let s = Shading { light: Some(Light::default()), ..Default::default() };
        let a = apply(&s, [0.5, 0.5, 0.5, 0.5], DVec3::Z, DVec3::Z);
        let b = apply(&s, [0.5, 0.5, 0.5, 0.5], -DVec3::Z, DVec3::Z);
        assert_eq!(a, b);
        assert!((a[0] - (0.5 * 1.0 + 0.2 * 0.5)).abs() < 1e-6);
        assert_eq!(a[3], 0.5);
    }

    #[test]
    fn directional_and_point_lights_add_and_shadows_scale_them() {
        let m = Light { ambient: 0.1, diffuse: 0.5, specular: 0.0, shininess: 1.0 };
        let sources = LightSet::new(&[
            LightSource::Directional { direction: [0.0, 0.0, -2.0], intensity: 1.0 },
            LightSource::Point { position: [3.0, 0.0, 0.0], intensity: 2.0 },
        ])
        .unwrap();
        let s = Shading { light: Some(m), sources, shadows: true, ..Default::default() };
        // Normal +z at the origin: the directional light (from +z) is head
        // on, the point light (on +x) grazes.
        let p = s.lit_point(DVec3::Z, DVec3::ZERO, -DVec3::Z, |_| 1.0);
        assert!((p.diffuse - 0.6).abs() < 1e-6, "{p:?}");
        let p = s.lit_point(DVec3::X, DVec3::ZERO, -DVec3::Z, |_| 1.0);
        assert!((p.diffuse - (0.1 + 2.0 * 0.5)).abs() < 1e-6, "{p:?}");
        // Shadows: light 1 half hidden.
        let p = s.lit_point(DVec3::X, DVec3::ZERO, -DVec3::Z, |i| if i == 1 { 0.5 } else { 1.0 });
        assert!((p.diffuse - (0.1 + 0.5)).abs() < 1e-6, "{p:?}");
        // Without the switch shadows are ignored.
        let s = Shading { shadows: false, ..s };
        let p = s.lit_point(DVec3::X, DVec3::ZERO, -DVec3::Z, |_| 0.0);
        assert!((p.diffuse - 1.1).abs() < 1e-6, "{p:?}");
    }

    #[test]
    fn degenerate_lights_give_finite_documented_terms() {
        let m = Light::default();
        // A point light at the sample: no direction, adds nothing.
        let sources = LightSet::new(&[LightSource::Point { position: [1.0, 2.0, 3.0], intensity: 1.0 }]).unwrap();
        let s = Shading { light: Some(m), sources, ..Default::default() };
        let p = s.lit_point(DVec3::X, DVec3::new(1.0, 2.0, 3.0), DVec3::Z, no_shadow);
        assert_eq!(p, LitPoint { diffuse: m.ambient as f64, specular: 0.0, silhouette: 1.0 });
        // A directional light shining straight at the eye along the view
        // direction: diffuse yes, no half vector, no highlight.
        // (The eye looks along +z; the light travels along −z, at the eye.)
        let sources =
            LightSet::new(&[LightSource::Directional { direction: [0.0, 0.0, -1.0], intensity: 1.0 }]).unwrap();
        let s = Shading { light: Some(m), sources, ..Default::default() };
        let p = s.lit_point(DVec3::Z, DVec3::ZERO, DVec3::Z, no_shadow);
        assert_eq!(p.specular, 0.0);
        assert!((p.diffuse - 1.0).abs() < 1e-6);
        // Zero and non-finite gradients: the isotropic medium (here one
        // light of intensity 1: ka + kd), no highlight.
        for g in [DVec3::ZERO, DVec3::splat(f64::NAN), DVec3::new(f64::INFINITY, 0.0, 0.0)] {
            let p = s.lit_point(g, DVec3::ZERO, DVec3::Z, no_shadow);
            assert!((p.diffuse - 1.0).abs() < 1e-6 && p.specular == 0.0 && p.silhouette == 1.0, "{p:?}");
        }
        // ... dimmed by shadows.
        let shadowed = Shading { shadows: true, ..s };
        let p = shadowed.lit_point(DVec3::ZERO, DVec3::ZERO, DVec3::Z, |_| 0.5);
        assert!((p.diffuse - (0.3 + 0.7 * 0.5)).abs() < 1e-6, "{p:?}");
        let p = s.lit_point(DVec3::new(1e-300, 0.0, 1e-300), DVec3::ZERO, DVec3::Z, no_shadow);
        assert!(p.diffuse.is_finite() && p.specular.is_finite());
    }

    #[test]
    fn shading_fades_out_below_the_gradient_floor() {
        let s =
            Shading { light: Some(Light::default()), silhouette: Some(2.0), gradient_floor: 2.0, ..Default::default() };
        let full = s.lit_point(DVec3::Z * 4.0, DVec3::ZERO, DVec3::Z, no_shadow);
        let half = s.lit_point(DVec3::Z, DVec3::ZERO, DVec3::Z, no_shadow);
        assert!((full.diffuse - 1.0).abs() < 1e-6 && (full.specular - 0.2).abs() < 1e-6, "{full:?}");
        assert_eq!(full.silhouette, 0.0);
        assert!((half.diffuse - 1.0).abs() < 1e-6 && (half.specular - 0.1).abs() < 1e-6, "{half:?}");
        assert!((half.silhouette - 0.5).abs() < 1e-12, "{half:?}");
        let tiny = s.lit_point(DVec3::Z * 1e-12, DVec3::ZERO, DVec3::Z, no_shadow);
        assert!((tiny.diffuse - 1.0).abs() < 1e-6 && tiny.specular < 1e-9 && tiny.silhouette > 1.0 - 1e-9);
        assert!((Shading::gradient_floor_for([0.0, 2.0], [0.0; 3], [3.0, 4.0, 0.0]) - 0.008).abs() < 1e-9);
        assert_eq!(Shading::gradient_floor_for([1.0, 1.0], [0.0; 3], [1.0; 3]), 0.0);
    }

    #[test]
    fn emission_centroid_moves_to_the_front_as_segments_thicken() {
        assert_eq!(emission_centroid(0.0), 0.5);
        assert_eq!(emission_centroid(f32::NAN), 0.5);
        assert_eq!(emission_centroid(1.0), 0.0);
        let mut last = 0.5;
        for a in [0.01f32, 0.1, 0.5, 0.9, 0.999, 0.999999] {
            let u = emission_centroid(a);
            assert!(u < last && u > 0.0, "{a}: {u}");
            last = u;
        }
        // Small α: ½ − α/12.
        assert!((emission_centroid(0.01) - (0.5 - 0.01 / 12.0)).abs() < 1e-4);
        // α = 1 − e^−τ with τ = 10: 1/10 − e^−10/(1 − e^−10).
        let a = 1.0 - (-10.0f64).exp();
        assert!((emission_centroid(a as f32) as f64 - (0.1 - (-10.0f64).exp() / a)).abs() < 1e-4);
    }

    #[test]
    fn bad_lights_are_refused_with_the_index() {
        for (l, needle) in [
            (LightSource::Directional { direction: [0.0; 3], intensity: 1.0 }, "light 1: direction"),
            (LightSource::Point { position: [f64::NAN, 0.0, 0.0], intensity: 1.0 }, "light 1: position"),
            (LightSource::Headlight { intensity: -1.0 }, "light 1: intensity"),
        ] {
            let e = LightSet::new(&[LightSource::Headlight { intensity: 1.0 }, l]).unwrap_err().to_string();
            assert!(e.contains(needle), "{e}");
        }
        let many = [LightSource::Headlight { intensity: 1.0 }; MAX_LIGHTS + 1];
        assert!(LightSet::new(&many).is_err());
    }

    #[test]
    fn view_files_carry_lighting() {
        let text = r#"{"position": [0, 0, 5], "focal_point": [0, 0, 0], "view_up": [0, 1, 0], "size": [8, 8],
            "lighting": {"ambient": 0.2, "lights": [{"type": "directional", "direction": [1, -1, -1]},
                         {"type": "point", "position": [0, 5, 0], "intensity": 0.5}], "shadows": true}}"#;
        let l = Lighting::from_view_json(text).unwrap().unwrap();
        assert_eq!(l.lights.lights().len(), 2);
        assert!(l.shadows && l.ambient == 0.2 && l.diffuse == Light::default().diffuse);
        let back: Lighting = serde_json::from_value(l.to_json_value()).unwrap();
        assert_eq!(back, l);
        assert!(crate::ViewSpec::from_json(text).is_ok(), "a view file with lighting is still a view");
        assert_eq!(Lighting::from_view_json(r#"{"size": [1, 1]}"#).unwrap(), None);
        for bad in [
            r#"{"lighting": {"lights": [{"type": "spot", "position": [0, 0, 0]}]}}"#,
            r#"{"lighting": {"ambient": -1}}"#,
            r#"{"lighting": {"lights": [{"type": "directional", "direction": [0, 0, 0]}]}}"#,
            r#"{"lighting": {"shadow": true}}"#,
        ] {
            assert!(Lighting::from_view_json(bad).is_err(), "{bad}");
        }
    }
}
