//! The exact f64 reference integrator (method id `exact`).
//!
//! A segment is split at every transfer-function node between its end
//! scalars; on each piece colour and extinction are linear in t and the
//! integrals have closed forms (Moreland & Angel 2004, see
//! `formats/tf.md`): with a = D·τ_f, b = D·(τ_b − τ_f) and
//! Ψ = ∫₀¹ exp(−a x − b x²/2) dx,
//!
//! * density emission:     C = c_f (1 − Ψ) + c_b (Ψ − ζ),   ζ = exp(−(a + b/2));
//! * independent emission: C = D [c_f Ψ + (c_b − c_f) Ψ₁],  Ψ₁ = ∫₀¹ x exp(…) dx;
//!
//! and α = 1 − ζ in both. Pieces are composited front to back.

use crate::special::{dawson, erfcx};
use crate::tf::{Emission, TransferFunction};

/// Premultiplied colour and opacity of a segment (or of an accumulation).
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct Rgba {
    /// Premultiplied emitted colour C.
    pub color: [f64; 3],
    /// Opacity α = 1 − transmittance.
    pub alpha: f64,
}

impl Rgba {
    /// `self` in front of `back`, premultiplied "over".
    pub fn over(self, back: Rgba) -> Rgba {
        let t = 1.0 - self.alpha;
        Rgba { color: std::array::from_fn(|k| self.color[k] + t * back.color[k]), alpha: self.alpha + t * back.alpha }
    }
    /// `[R, G, B, A]`.
    pub fn to_array(self) -> [f64; 4] {
        [self.color[0], self.color[1], self.color[2], self.alpha]
    }
}

/// Below this |b| the series in b is used (its 9 terms are exact to below
/// 1e-17; above it the erfcx/Dawson forms lose at most a factor
/// √(π/2|b|) ≈ 13 to cancellation).
pub(crate) const B_SERIES: f64 = 0.01;

/// Mₙ(a) = ∫₀¹ xⁿ e^{−a x} dx for a ≥ 0.
fn moment(n: u32, a: f64) -> f64 {
    if a <= 40.0 {
        // e^{−a} Σ_k a^k / ((n+1)(n+2)…(n+1+k)): positive terms, no cancellation.
        let mut term = 1.0 / f64::from(n + 1);
        let mut sum = term;
        let mut k = 1.0;
        while term > 1e-18 * sum {
            term *= a / (f64::from(n + 1) + k);
            sum += term;
            k += 1.0;
        }
        (-a).exp() * sum
    } else {
        // n!/a^{n+1} (1 − e^{−a} Σ_{k≤n} a^k/k!); the bracket is ≥ 1 − 1e-5 here.
        let mut lead = 1.0 / a;
        let mut term = (-a).exp();
        let mut tail = term;
        for i in 1..=n {
            lead *= f64::from(i) / a;
            term *= a / f64::from(i);
            tail += term;
        }
        lead * (1.0 - tail)
    }
}

/// Ψ and Ψ₁ by the series Σ_j (−b/2)^j/j! M_{2j(+1)}(a), for |b| ≤ B_SERIES.
pub(crate) fn psi_series(a: f64, b: f64) -> (f64, f64) {
    let mut coef = 1.0;
    let (mut p0, mut p1) = (0.0, 0.0);
    for j in 0..9u32 {
        p0 += coef * moment(2 * j, a);
        p1 += coef * moment(2 * j + 1, a);
        coef *= -0.5 * b / f64::from(j + 1);
    }
    (p0, p1)
}

/// Ψ(a, b) for |b| > B_SERIES; `b_end` = a + b ≥ 0 (passed separately so
/// rounding cannot make it negative); `zeta` = exp(−(a + b/2)).
fn psi_closed(a: f64, b: f64, b_end: f64, zeta: f64) -> f64 {
    let k = 1.0 / (2.0 * b.abs()).sqrt();
    let f = a * k;
    let e = b_end.max(0.0) * k;
    if b > 0.0 {
        std::f64::consts::PI.sqrt() * k * (erfcx(f) - zeta * erfcx(e))
    } else {
        2.0 * k * (dawson(f) - zeta * dawson(e))
    }
}

/// One linear piece: colours at its front and back, extinctions τ (per world
/// length) at its front and back, length `d` (world).
fn piece(emission: Emission, cf: [f64; 3], cb: [f64; 3], tf: f64, tb: f64, d: f64) -> (Rgba, f64) {
    let a = d * tf;
    let a_end = d * tb;
    let b = a_end - a;
    let depth = 0.5 * (a + a_end);
    let zeta = (-depth).exp();
    let alpha = -(-depth).exp_m1();
    let (psi, psi1) = if b.abs() <= B_SERIES {
        psi_series(a, b)
    } else {
        let p = psi_closed(a, b, a_end, zeta);
        let p1 = match emission {
            // a Ψ + b Ψ₁ = 1 − ζ (integrate the exponent's derivative).
            Emission::Independent => (alpha - a * p) / b,
            Emission::Density => 0.0,
        };
        (p, p1)
    };
    let color = match emission {
        Emission::Density => std::array::from_fn(|k| cf[k] * (1.0 - psi) + cb[k] * (psi - zeta)),
        Emission::Independent => std::array::from_fn(|k| d * (cf[k] * psi + (cb[k] - cf[k]) * psi1)),
    };
    (Rgba { color, alpha }, depth)
}

/// Optical depth ∫ρ of the segment entering at scalar `sf`, leaving at
/// `sb`, of world length `len`: exact for the piecewise-linear extinction
/// (the length times ρ's mean over [sf, sb], summed over the linear pieces
/// between `tf`'s nodes). Transmittance is `exp(−depth)`. `len ≤ 0` gives 0.
pub fn optical_depth_with(tf: &TransferFunction, sf: f64, sb: f64, len: f64, scratch: &mut Vec<f64>) -> f64 {
    if len.is_nan() || sf.is_nan() || sb.is_nan() {
        return f64::NAN;
    }
    if len <= 0.0 {
        return 0.0;
    }
    if sf == sb {
        return len * tf.extinction(sf);
    }
    let (lo, hi) = (sf.min(sb), sf.max(sb));
    scratch.clear();
    scratch.push(lo);
    tf.breakpoints_between(lo, hi, scratch);
    scratch.push(hi);
    let mut mean_times_width = 0.0;
    for w in scratch.windows(2) {
        mean_times_width += 0.5 * (tf.extinction(w[0]) + tf.extinction(w[1])) * (w[1] - w[0]);
    }
    len * mean_times_width / (hi - lo)
}

/// Integrates the segment entering at scalar `sf`, leaving at `sb`, of world
/// length `len`, exactly for the piecewise-linear `tf` (its x taken as given:
/// denormalize a normalized TF first). Returns premultiplied (C, α).
///
/// `len ≤ 0` gives zero; NaN inputs give NaN; `len` is clamped to 1e300.
pub fn integrate_segment(tf: &TransferFunction, sf: f64, sb: f64, len: f64) -> Rgba {
    let mut scratch = Vec::new();
    integrate_segment_with(tf, sf, sb, len, &mut scratch)
}

/// [`integrate_segment`] reusing a scratch buffer for the breakpoints.
pub fn integrate_segment_with(tf: &TransferFunction, sf: f64, sb: f64, len: f64, scratch: &mut Vec<f64>) -> Rgba {
    if sf.is_nan() || sb.is_nan() || len.is_nan() {
        return Rgba { color: [f64::NAN; 3], alpha: f64::NAN };
    }
    if len <= 0.0 {
        return Rgba::default();
    }
    // Beyond this the result is saturated for any ρ the TF can hold, and
    // clamping keeps len/|Sb − Sf| and τ·len finite.
    let len = len.min(1e300);
    let emission = tf.emission();
    if sf == sb {
        let c = tf.color(sf);
        let t = tf.extinction(sf);
        return piece(emission, c, c, t, t, len).0;
    }
    scratch.clear();
    scratch.push(sf);
    tf.breakpoints_between(sf.min(sb), sf.max(sb), scratch);
    if sb < sf {
        scratch[1..].reverse();
    }
    scratch.push(sb);
    let per_scalar = len / (sb - sf).abs();
    let mut color = [0.0f64; 3];
    let mut transmittance = 1.0;
    let mut depth = 0.0;
    let (mut c0, mut t0) = (tf.color(sf), tf.extinction(sf));
    for w in scratch.windows(2) {
        let (c1, t1) = (tf.color(w[1]), tf.extinction(w[1]));
        let d = (w[1] - w[0]).abs() * per_scalar;
        let (p, dp) = piece(emission, c0, c1, t0, t1, d);
        for (acc, c) in color.iter_mut().zip(p.color) {
            *acc += transmittance * c;
        }
        transmittance *= 1.0 - p.alpha;
        depth += dp;
        (c0, t0) = (c1, t1);
    }
    Rgba { color, alpha: -(-depth).exp_m1() }
}
