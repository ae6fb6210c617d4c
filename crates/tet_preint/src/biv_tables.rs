//! The pre-integrated tables of Song et al., "Bivariate Transfer Functions
//! on Unstructured Grids", 2009: Gaussian ([`GaussErfTable`]) and triangle- and
//! sine-wave ([`BandTable`]) tables for the emission-only model
//! (`"emission": "independent"`), used by `biv-exact`. The band tables are
//! built the same way as the Gaussian one described here.
//!
//! Along a segment a Gaussian widget's shape is e^{−q_min}·e^{−u²} with
//! u = k(x + B/A) linear in x (see `bivariate::gaussian_depth`), so the
//! transmittance from the piece's entry u₀ is T(u) = exp(−P·(erf u − erf u₀))
//! with P = (opacity/unit)·l·e^{−q_min}·(√π/2)/k, and the emission-only
//! colour of a constant-colour piece needs the window integral
//!
//!   W(P, u₀, u₁) = ∫_{u₀}^{u₁} exp(−P·(erf τ − erf u₀)) dτ.
//!
//! The seed tabulates ∫ exp(−P·erf t) dt over (P, t) and differences two
//! entries, which overflows (e^{P·erf B}) and cancels for large P. This
//! table stores the same integral anchored at its lower end instead,
//! F(P, u) = ∫_u^U exp(−P·(erf τ − erf u)) dτ (0 ≤ F ≤ U − u, U = 6 where
//! erfc is below 2e-17), so W = F(P, u₀) − T_seg·F(P, u₁) with T_seg the
//! piece's transmittance, which the caller has in closed form: no
//! exponential growth, and both terms are bounded. Outside [−U, U] erf is
//! ±1 to f64 precision and W is continued exactly (the integrand is
//! constant there). Short windows (u₁ − u₀ < [`SHORT_WINDOW`]), where the
//! difference would cancel, use 6-point Gauss–Legendre on the integrand.
//!
//! Layout: rows at ln(1 + P) uniform over [0, ln(1 + P_max)], columns at u
//! uniform over [−U, U]; each entry stores F and ∂F/∂u
//! (= −1 + P·(2/√π)e^{−u²}·F), interpolated by cubic Hermite along u and a
//! 4-point Lagrange cubic across rows. Entries are integrated in f64 cell by
//! cell from u = U down (8-point Gauss–Legendre per cell, exact recurrence
//! F(u_j) = ∫_{u_j}^{u_{j+1}} … + e^{−P(erf u_{j+1} − erf u_j)}·F(u_{j+1})).

use crate::special::erfcx;

/// |u| beyond which erf is ±1 in f64 (erfc(6) ≈ 2.2e-17).
pub const U_MAX: f64 = 6.0;
/// Windows shorter than this (in u) are integrated directly.
pub const SHORT_WINDOW: f64 = 0.05;

/// erfc(x) for x ≥ 0 without underflow trouble.
fn erfc_pos(x: f64) -> f64 {
    erfcx(x) * (-x * x).exp()
}

/// erf(b) − erf(a) for a ≤ b, without cancellation in the tails.
pub fn erf_diff(a: f64, b: f64) -> f64 {
    if a >= 0.0 {
        erfc_pos(a) - erfc_pos(b)
    } else if b <= 0.0 {
        erfc_pos(-b) - erfc_pos(-a)
    } else {
        2.0 - erfc_pos(b) - erfc_pos(-a)
    }
}

use crate::bivariate::GL8_NODES as GL8;

/// ∫_a^b exp(−P·(erf τ − erf a)) dτ by 8-point Gauss–Legendre on `panels`
/// equal panels (the reference and the short-window path).
pub fn window_quadrature(p: f64, a: f64, b: f64, panels: usize) -> f64 {
    gl8_panels(a, b, panels, |x| (-p * erf_diff(a, x)).exp())
}

/// ∫_a^b f by 8-point Gauss–Legendre on `panels` equal panels (0 when b ≤ a).
fn gl8_panels(a: f64, b: f64, panels: usize, f: impl Fn(f64) -> f64) -> f64 {
    if b <= a {
        return 0.0;
    }
    let h = (b - a) / panels as f64;
    let mut sum = 0.0;
    for i in 0..panels {
        let x0 = a + i as f64 * h;
        for &(t, w) in &GL8 {
            sum += w * f(x0 + h * t);
        }
    }
    sum * h
}

/// The table of F(P, u) (module docs).
#[derive(Debug, Clone, PartialEq)]
pub struct GaussErfTable {
    n_p: usize,
    n_u: usize,
    p_max: f64,
    /// (n_p − 1) / ln(1 + p_max).
    inv_dlp: f64,
    du: f64,
    /// Per entry (F, ∂F/∂u), row-major [n_p][n_u].
    entries: Vec<[f64; 2]>,
}

/// Default rows (P) and columns (u).
pub const DEFAULT_ERF_TABLE: (usize, usize, f64) = (192, 769, 64.0);

impl GaussErfTable {
    /// Builds an `n_p` × `n_u` table for P ∈ [0, p_max] (n_p ≥ 4, n_u ≥ 2,
    /// p_max > 0 and finite; clamped into [4, 4096], [2, 1 << 16] and
    /// [1e-3, 1e4] otherwise).
    pub fn build(n_p: usize, n_u: usize, p_max: f64) -> GaussErfTable {
        let n_p = n_p.clamp(4, 4096);
        let n_u = n_u.clamp(2, 1 << 16);
        let p_max = if p_max.is_finite() { p_max.clamp(1e-3, 1e4) } else { 64.0 };
        let lp_max = p_max.ln_1p();
        let du = 2.0 * U_MAX / (n_u - 1) as f64;
        let u_at = |j: usize| -U_MAX + j as f64 * du;
        let mut entries = vec![[0.0; 2]; n_p * n_u];
        // erf differences of each cell's GL nodes from its start, shared by rows.
        let cell: Vec<[f64; 9]> = (0..n_u - 1)
            .map(|j| {
                let a = u_at(j);
                let mut d = [0.0; 9];
                for (k, &(t, _)) in GL8.iter().enumerate() {
                    d[k] = erf_diff(a, a + du * t);
                }
                d[8] = erf_diff(a, u_at(j + 1));
                d
            })
            .collect();
        for i in 0..n_p {
            let p = (i as f64 / inv_dlp(n_p, lp_max)).exp_m1();
            let row = &mut entries[i * n_u..(i + 1) * n_u];
            let mut f = 0.0;
            row[n_u - 1] = [0.0, -1.0];
            for j in (0..n_u - 1).rev() {
                let d = &cell[j];
                let inner: f64 = GL8.iter().enumerate().map(|(k, &(_, w))| w * (-p * d[k]).exp()).sum::<f64>() * du;
                f = inner + (-p * d[8]).exp() * f;
                let u = u_at(j);
                row[j] = [f, -1.0 + p * std::f64::consts::FRAC_2_SQRT_PI * (-u * u).exp() * f];
            }
        }
        GaussErfTable { n_p, n_u, p_max, inv_dlp: inv_dlp(n_p, lp_max), du, entries }
    }

    /// Largest P the table covers.
    pub fn p_max(&self) -> f64 {
        self.p_max
    }
    pub fn memory_bytes(&self) -> usize {
        self.entries.len() * 16
    }

    /// F(P, u) for P ∈ [0, p_max] and u ∈ [−U, U] (clamped).
    pub fn f(&self, p: f64, u: f64) -> f64 {
        let xp = (p.max(0.0).ln_1p() * self.inv_dlp).clamp(0.0, (self.n_p - 1) as f64);
        let xu = ((u + U_MAX) / self.du).clamp(0.0, (self.n_u - 1) as f64);
        rows_hermite_cols_lagrange(&self.entries, self.n_p, self.n_u, self.du, xp, xu)
    }

    /// W(P, u₀, u₁) = ∫_{u₀}^{u₁} exp(−P·(erf τ − erf u₀)) dτ given the
    /// window's transmittance `t_seg` = exp(−P·(erf u₁ − erf u₀)); `None`
    /// when P is beyond the table (the caller integrates otherwise).
    pub fn window(&self, p: f64, u0: f64, u1: f64, t_seg: f64) -> Option<f64> {
        if !((0.0..=self.p_max).contains(&p) && u0.is_finite() && u1.is_finite()) {
            return None;
        }
        if u1 <= u0 {
            return Some(0.0);
        }
        if u1 - u0 < SHORT_WINDOW {
            return Some(window_quadrature(p, u0, u1, 1));
        }
        let mut acc = 0.0;
        let mut a = u0;
        if a < -U_MAX {
            // erf ≡ −1 = erf u₀ here: the integrand is 1.
            let b = u1.min(-U_MAX);
            acc += b - a;
            a = b;
        }
        let m = u1.min(U_MAX);
        if a < m {
            let fm = if m >= U_MAX { 0.0 } else { self.f(p, m) };
            acc += self.f(p, a) - t_seg * fm;
        }
        if u1 > U_MAX {
            // erf ≡ 1 here: the integrand is T_seg.
            acc += (u1 - U_MAX.max(a)) * t_seg;
        }
        Some(acc.max(0.0))
    }
}

fn inv_dlp(n_p: usize, lp_max: f64) -> f64 {
    (n_p - 1) as f64 / lp_max
}

/// Which banded widget a [`BandTable`] tabulates. Over one period the
/// shape is written in a phase φ ∈ [0, Φ] that increases along the piece
/// (a decreasing band is mirrored, the shapes being even):
/// triangle Φ = 2, m(φ) = φ on [0, 1] and 2 − φ on [1, 2] (troughs at 0 and
/// 2); sine Φ = 2π, m(φ) = (1 + cos φ)/2 (peaks at 0 and 2π).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum BandKind {
    Triangle,
    Sine,
}

impl BandKind {
    /// Φ, the phase span of one period.
    pub fn period_phase(self) -> f64 {
        match self {
            BandKind::Triangle => 2.0,
            BandKind::Sine => 2.0 * std::f64::consts::PI,
        }
    }
    /// The shape m(φ).
    pub fn shape(self, phi: f64) -> f64 {
        match self {
            BandKind::Triangle => {
                if phi <= 1.0 {
                    phi
                } else {
                    2.0 - phi
                }
            }
            BandKind::Sine => 0.5 * (1.0 + phi.cos()),
        }
    }
    /// M(b) − M(a) with M' = m, a ≤ b, without forming M (no growth with φ).
    pub fn depth_between(self, a: f64, b: f64) -> f64 {
        match self {
            BandKind::Triangle => {
                if b <= 1.0 {
                    0.5 * (b - a) * (b + a)
                } else if a >= 1.0 {
                    0.5 * (b - a) * (4.0 - a - b)
                } else {
                    0.5 * (1.0 - a) * (1.0 + a) + 0.5 * (b - 1.0) * (3.0 - b)
                }
            }
            BandKind::Sine => 0.5 * ((b - a) + 2.0 * (0.5 * (a + b)).cos() * (0.5 * (b - a)).sin()),
        }
    }
    /// Table columns per period that the analysis crate's rule
    /// (`tet_analysis::limits`, tolerance ε on linear interpolation) asks
    /// for: sine 2π/√(8ε), triangle 1/ε. With ε = 1% these are Blunt Fin's
    /// 106 / 472 samples per axis divided by its span in periods (≈ 4.7).
    pub fn samples_per_period(self, epsilon: f64) -> usize {
        let eps = if epsilon.is_finite() { epsilon.clamp(1e-6, 0.5) } else { 0.01 };
        match self {
            BandKind::Triangle => (1.0 / eps).ceil() as usize,
            BandKind::Sine => (2.0 * std::f64::consts::PI / (8.0 * eps).sqrt()).ceil() as usize,
        }
    }
}

/// ∫_a^b exp(−P·(M(τ) − M(a))) dτ by 8-point Gauss–Legendre on `panels`
/// equal panels (the reference and the short-window path of [`BandTable`]).
pub fn band_window_quadrature(kind: BandKind, p: f64, a: f64, b: f64, panels: usize) -> f64 {
    gl8_panels(a, b, panels, |x| (-p * kind.depth_between(a, x)).exp())
}

/// Song et al.'s (2009) triangle- and sine-wave tables for the emission-only model,
/// built like [`GaussErfTable`]: on a piece carried by one band widget the
/// depth from the piece's entry is P·(M(φ) − M(φ₀)) with
/// P = (opacity/unit)·l/|dφ/dx|, and the colour needs
/// W(P, φ₀, φ₁) = ∫_{φ₀}^{φ₁} exp(−P(M(τ) − M(φ₀))) dτ. The table stores
/// F(P, φ) = ∫_φ^Φ exp(−P(M(τ) − M(φ))) dτ (0 ≤ F ≤ Φ − φ), so
/// W = F(P, φ₀) − T·F(P, φ₁) with T the piece's transmittance — the seed's
/// (φ, amax/k) tables anchored at their lower end, bounded, no cancellation
/// beyond the short-window case (< [`SHORT_WINDOW`]·Φ/2, integrated directly).
/// Rows uniform in ln(1 + P) up to `p_max`, `n_phase` columns over [0, Φ]
/// (for the triangle, n_phase − 1 is made even so its peak is a node), each
/// entry F and ∂F/∂φ = −1 + P·m(φ)·F; Hermite along φ, cubic across rows.
#[derive(Debug, Clone, PartialEq)]
pub struct BandTable {
    kind: BandKind,
    n_p: usize,
    n_phase: usize,
    p_max: f64,
    inv_dlp: f64,
    dphi: f64,
    entries: Vec<[f64; 2]>,
}

/// Default rows (P) and P_max of the band tables; the columns follow
/// [`BandKind::samples_per_period`] at [`DEFAULT_BAND_EPSILON`] times
/// [`BandKind::default_refine`].
pub const DEFAULT_BAND_ROWS: (usize, f64) = (192, 256.0);
/// ε of the default band tables: the analysis crate's default tolerance.
pub const DEFAULT_BAND_EPSILON: f64 = 0.01;

impl BandKind {
    /// The analysis rule sizes a linearly interpolated (Sf, Sb) table to 1%;
    /// this table's windows near the troughs at large P need more columns
    /// for ~1e-6 (measured: sine at the bare rule, 24 columns, errs 1.7e-2,
    /// ×16 = 369 columns 2.3e-7; triangle 101 columns 6e-6, ×2 = 201
    /// columns ~1e-6; see crates/tetlut/results/bluntfin.md).
    pub fn default_refine(self) -> usize {
        match self {
            BandKind::Triangle => 2,
            BandKind::Sine => 16,
        }
    }
}

impl BandTable {
    /// The default table for `kind`: 192 rows up to P = 256, columns from
    /// the frequency-limit rule at ε = 1% times [`BandKind::default_refine`]
    /// (triangle 201, sine 369).
    pub fn default_for(kind: BandKind) -> BandTable {
        let (n_p, p_max) = DEFAULT_BAND_ROWS;
        let cols = kind.samples_per_period(DEFAULT_BAND_EPSILON) * kind.default_refine() + 1;
        BandTable::build(kind, n_p, cols, p_max)
    }

    /// The table sized by a mesh's analysis (`tet_analysis`, stored in
    /// the bundle): columns per period from the rule at the analysis's
    /// tolerance times [`BandKind::default_refine`], default rows. In phase
    /// units one period is the whole table, so the period itself (1 /
    /// `frequency_limit_99`) drops out: Blunt Fin's 106 (sine) / 472
    /// (triangle) samples per axis over ≈ 4.7 periods are the rule's 23 /
    /// 100 per period.
    pub fn for_resolution(kind: BandKind, res: &tet_analysis::TableResolution) -> BandTable {
        let (n_p, p_max) = DEFAULT_BAND_ROWS;
        let cols = kind.samples_per_period(res.tolerance) * kind.default_refine() + 1;
        BandTable::build(kind, n_p, cols, p_max)
    }

    /// Builds an `n_p` × `n_phase` table for P ∈ [0, p_max] (clamped into
    /// [4, 4096], [3, 1 << 16] and [1e-3, 1e5]; non-finite p_max gives 256).
    pub fn build(kind: BandKind, n_p: usize, n_phase: usize, p_max: f64) -> BandTable {
        let n_p = n_p.clamp(4, 4096);
        let mut n_phase = n_phase.clamp(3, 1 << 16);
        if kind == BandKind::Triangle && (n_phase - 1) % 2 == 1 {
            n_phase += 1;
        }
        let p_max = if p_max.is_finite() { p_max.clamp(1e-3, 1e5) } else { 256.0 };
        let span = kind.period_phase();
        let dphi = span / (n_phase - 1) as f64;
        let phi_at = |j: usize| if j + 1 == n_phase { span } else { j as f64 * dphi };
        let inv = inv_dlp(n_p, p_max.ln_1p());
        // Depth differences of each cell's GL nodes from its start (P = 1).
        let cell: Vec<[f64; 9]> = (0..n_phase - 1)
            .map(|j| {
                let (a, b) = (phi_at(j), phi_at(j + 1));
                let mut d = [0.0; 9];
                for (k, &(t, _)) in GL8.iter().enumerate() {
                    d[k] = kind.depth_between(a, a + (b - a) * t);
                }
                d[8] = kind.depth_between(a, b);
                d
            })
            .collect();
        let mut entries = vec![[0.0; 2]; n_p * n_phase];
        for i in 0..n_p {
            let p = (i as f64 / inv).exp_m1();
            let row = &mut entries[i * n_phase..(i + 1) * n_phase];
            row[n_phase - 1] = [0.0, -1.0];
            let mut f = 0.0;
            for j in (0..n_phase - 1).rev() {
                let d = &cell[j];
                let h = phi_at(j + 1) - phi_at(j);
                let inner: f64 = GL8.iter().enumerate().map(|(k, &(_, w))| w * (-p * d[k]).exp()).sum::<f64>() * h;
                f = inner + (-p * d[8]).exp() * f;
                row[j] = [f, -1.0 + p * kind.shape(phi_at(j)) * f];
            }
        }
        BandTable { kind, n_p, n_phase, p_max, inv_dlp: inv, dphi, entries }
    }

    pub fn kind(&self) -> BandKind {
        self.kind
    }
    /// Largest P the table covers.
    pub fn p_max(&self) -> f64 {
        self.p_max
    }
    /// (rows, columns).
    pub fn dims(&self) -> (usize, usize) {
        (self.n_p, self.n_phase)
    }
    pub fn memory_bytes(&self) -> usize {
        self.entries.len() * 16
    }

    /// F(P, φ) for P ∈ [0, p_max] and φ ∈ [0, Φ] (clamped).
    pub fn f(&self, p: f64, phi: f64) -> f64 {
        let xp = (p.max(0.0).ln_1p() * self.inv_dlp).clamp(0.0, (self.n_p - 1) as f64);
        let xu = (phi / self.dphi).clamp(0.0, (self.n_phase - 1) as f64);
        rows_hermite_cols_lagrange(&self.entries, self.n_p, self.n_phase, self.dphi, xp, xu)
    }

    /// W(P, φ₀, φ₁) given the window's transmittance `t_seg`
    /// = exp(−P·(M(φ₁) − M(φ₀))); 0 ≤ φ₀ ≤ φ₁ ≤ Φ (clamped). `None` when P
    /// is beyond the table or not finite (the caller integrates otherwise).
    pub fn window(&self, p: f64, phi0: f64, phi1: f64, t_seg: f64) -> Option<f64> {
        if !((0.0..=self.p_max).contains(&p) && phi0.is_finite() && phi1.is_finite()) {
            return None;
        }
        let span = self.kind.period_phase();
        let (a, b) = (phi0.clamp(0.0, span), phi1.clamp(0.0, span));
        if b <= a {
            return Some(0.0);
        }
        if b - a < SHORT_WINDOW * 0.5 * span {
            // A panel per optical depth of ~2 keeps 8-point GL at ~1e-10.
            let panels = 1 + ((p * (b - a)) as usize / 2).min(63);
            return Some(band_window_quadrature(self.kind, p, a, b, panels));
        }
        let fb = if b >= span { 0.0 } else { self.f(p, b) };
        Some((self.f(p, a) - t_seg * fb).max(0.0))
    }
}

/// Interpolates a table of (value, derivative) entries, `n_p` rows of
/// `n_cols`: cubic Hermite along a row (column step `step`, fractional
/// column `xu`), 4-point Lagrange across the rows around fractional row
/// `xp`. Both fractional indices must already be clamped to the table.
fn rows_hermite_cols_lagrange(entries: &[[f64; 2]], n_p: usize, n_cols: usize, step: f64, xp: f64, xu: f64) -> f64 {
    let j = (xu as usize).min(n_cols - 2);
    let t = xu - j as f64;
    let hermite = |i: usize| {
        let [f0, d0] = entries[i * n_cols + j];
        let [f1, d1] = entries[i * n_cols + j + 1];
        let (t2, t3) = (t * t, t * t * t);
        (2.0 * t3 - 3.0 * t2 + 1.0) * f0
            + (t3 - 2.0 * t2 + t) * step * d0
            + (-2.0 * t3 + 3.0 * t2) * f1
            + (t3 - t2) * step * d1
    };
    let i0 = ((xp as usize).saturating_sub(1)).min(n_p - 4);
    let s = xp - i0 as f64;
    let mut out = 0.0;
    for a in 0..4 {
        let mut w = 1.0;
        for b in 0..4 {
            if a != b {
                w *= (s - b as f64) / (a as f64 - b as f64);
            }
        }
        out += w * hermite(i0 + a);
    }
    out.max(0.0)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn erf_diff_matches_known_values() {
        // erf(1) = 0.8427007929497149, erf(0.5) = 0.5204998778130465.
        assert!((erf_diff(0.0, 1.0) - 0.842_700_792_949_714_9).abs() < 1e-15);
        assert!((erf_diff(-0.5, 1.0) - (0.842_700_792_949_714_9 + 0.520_499_877_813_046_5)).abs() < 1e-15);
        assert!((erf_diff(-1.0, -0.5) - (0.842_700_792_949_714_9 - 0.520_499_877_813_046_5)).abs() < 1e-15);
        // Far tail without cancellation: erfc(5) − erfc(6) ≈ 1.5375e-12.
        let d = erf_diff(5.0, 6.0);
        assert!((d - (1.537_459_794_428_035e-12 - 2.151_973_671_249_892e-17)).abs() < 1e-24, "{d:e}");
    }

    #[test]
    fn nodes_match_quadrature_and_p0_is_length() {
        let t = GaussErfTable::build(24, 97, 32.0);
        for u in [-6.0, -2.5, 0.0, 1.25, 5.875] {
            assert!((t.f(0.0, u) - (U_MAX - u)).abs() < 1e-12, "{u}");
        }
        for p in [0.5, 3.0, 31.0] {
            for (u0, u1) in [(-3.0f64, 2.0f64), (-0.7, 0.4), (1.0, 4.0), (-8.0, 7.0), (0.2, 0.23)] {
                let t_seg = (-p * erf_diff(u0.max(-U_MAX), u1.min(U_MAX))).exp();
                let want = window_quadrature(p, u0, u1, 400);
                let got = t.window(p, u0, u1, t_seg).unwrap();
                // This small table: ~1e-3 absolute; the default is far finer.
                assert!((got - want).abs() < 2e-3 * want.max(1.0), "P {p} [{u0}, {u1}]: {got} vs {want}");
            }
        }
        assert!(t.window(33.0, 0.0, 1.0, 0.5).is_none());
        assert!(t.window(f64::NAN, 0.0, 1.0, 0.5).is_none());
    }

    #[test]
    fn band_tables_match_quadrature_at_p0_and_inside() {
        for kind in [BandKind::Triangle, BandKind::Sine] {
            let span = kind.period_phase();
            let t = BandTable::build(kind, 32, 65, 64.0);
            for phi in [0.0, 0.3, 1.0, 2.5, span - 0.01] {
                let phi = phi.min(span);
                assert!((t.f(0.0, phi) - (span - phi)).abs() < 1e-12, "{kind:?} {phi}");
            }
            // M over a whole period is ½Φ·mean(m)… = 1 (triangle) and π (sine).
            let full = kind.depth_between(0.0, span);
            assert!((full - if kind == BandKind::Sine { std::f64::consts::PI } else { 1.0 }).abs() < 1e-14);
            for p in [0.5, 3.0, 40.0] {
                for (a, b) in [(0.0, span), (0.1, 0.9), (0.2 * span, 0.7 * span), (0.5, 0.52)] {
                    let t_seg = (-p * kind.depth_between(a, b)).exp();
                    let want = band_window_quadrature(kind, p, a, b, 400);
                    let got = t.window(p, a, b, t_seg).unwrap();
                    assert!((got - want).abs() < 2e-3 * want.max(1.0), "{kind:?} P {p} [{a}, {b}]: {got} vs {want}");
                }
            }
            assert!(t.window(65.0, 0.0, 1.0, 0.5).is_none());
        }
        assert_eq!(BandTable::build(BandKind::Triangle, 8, 10, 1.0).dims().1, 11);
        assert_eq!(BandKind::Sine.samples_per_period(0.01), 23);
        assert_eq!(BandKind::Triangle.samples_per_period(0.01), 100);
        let res =
            tet_analysis::TableResolution { tolerance: 0.01, period: 1.0, samples_sine: 106, samples_triangle: 472 };
        assert_eq!(BandTable::for_resolution(BandKind::Sine, &res), BandTable::default_for(BandKind::Sine));
        assert_eq!(BandTable::for_resolution(BandKind::Triangle, &res).dims(), (192, 201));
    }
}
