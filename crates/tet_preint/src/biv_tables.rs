//! Seed 004's pre-integrated Gaussian table for the emission-only model
//! (`"emission": "independent"`), used by `biv-exact`.
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

const GL8: [(f64, f64); 8] = [
    (0.5 * (1.0 - 0.960_289_856_497_536_3), 0.5 * 0.101_228_536_290_376_3),
    (0.5 * (1.0 - 0.796_666_477_413_626_7), 0.5 * 0.222_381_034_453_374_5),
    (0.5 * (1.0 - 0.525_532_409_916_329), 0.5 * 0.313_706_645_877_887_3),
    (0.5 * (1.0 - 0.183_434_642_495_649_8), 0.5 * 0.362_683_783_378_362),
    (0.5 * (1.0 + 0.183_434_642_495_649_8), 0.5 * 0.362_683_783_378_362),
    (0.5 * (1.0 + 0.525_532_409_916_329), 0.5 * 0.313_706_645_877_887_3),
    (0.5 * (1.0 + 0.796_666_477_413_626_7), 0.5 * 0.222_381_034_453_374_5),
    (0.5 * (1.0 + 0.960_289_856_497_536_3), 0.5 * 0.101_228_536_290_376_3),
];

/// ∫_a^b exp(−P·(erf τ − erf a)) dτ by 8-point Gauss–Legendre on `panels`
/// equal panels (the reference and the short-window path).
pub fn window_quadrature(p: f64, a: f64, b: f64, panels: usize) -> f64 {
    if b <= a {
        return 0.0;
    }
    let h = (b - a) / panels as f64;
    let mut sum = 0.0;
    for i in 0..panels {
        let x0 = a + i as f64 * h;
        for &(t, w) in &GL8 {
            sum += w * (-p * erf_diff(a, x0 + h * t)).exp();
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
        let j = (xu as usize).min(self.n_u - 2);
        let t = xu - j as f64;
        // Cubic Hermite along u in row i.
        let hermite = |i: usize| {
            let [f0, d0] = self.entries[i * self.n_u + j];
            let [f1, d1] = self.entries[i * self.n_u + j + 1];
            let (t2, t3) = (t * t, t * t * t);
            (2.0 * t3 - 3.0 * t2 + 1.0) * f0
                + (t3 - 2.0 * t2 + t) * self.du * d0
                + (-2.0 * t3 + 3.0 * t2) * f1
                + (t3 - t2) * self.du * d1
        };
        // 4-point Lagrange across rows i0..i0+3 containing xp.
        let i0 = ((xp as usize).saturating_sub(1)).min(self.n_p - 4);
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
}
