//! Per-tet and per-vertex gradients of the piecewise-linear scalar.
//!
//! All geometry is taken relative to a local origin (a tet's first vertex,
//! or the vertex whose gradient is fitted), so meshes far from the origin
//! (coordinates around 1e6) lose no more precision than the differences of
//! their coordinates carry.

use rayon::prelude::*;
use serde::{Deserialize, Serialize};

/// How per-vertex gradients are computed.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize, Default)]
pub enum GradientMethod {
    /// Weighted least-squares fit of s(q) − s(p) ≈ g·(q − p) over the vertex's
    /// one-ring (every vertex sharing a tet with it), weights 1/|q − p|².
    /// Directions the one-ring does not span well fall back to the
    /// tet-average gradient.
    #[default]
    LeastSquares,
    /// Volume-weighted average of the gradients of the tets around the vertex.
    TetAverage,
}

impl GradientMethod {
    /// The name used on the command line and in reports (`lsq`, `tet-average`).
    pub fn name(self) -> &'static str {
        match self {
            GradientMethod::LeastSquares => "lsq",
            GradientMethod::TetAverage => "tet-average",
        }
    }
}

/// Per-tet facts every analysis builds on: the (constant) gradient of the
/// linear interpolant on each tet and the tet's volume.
#[derive(Debug, Clone, PartialEq)]
pub struct TetGradients {
    /// ∇s on each tet, scalar units per world length. Zero on a tet whose
    /// floating-point volume is not positive (a sliver flatter than f64 can
    /// measure), whose gradient is not determined by its vertices.
    pub gradient: Vec<[f64; 3]>,
    /// 6 × volume·∇s = Σ Δs_i (e_j × e_k): finite even for slivers, which is
    /// what makes the volume-weighted average robust.
    pub(crate) six_vol_gradient: Vec<[f64; 3]>,
    /// Six times the volume, clamped at 0 (world length³).
    pub(crate) six_volume: Vec<f64>,
}

impl TetGradients {
    /// Volume of tet `t` in world length³.
    pub fn volume(&self, t: usize) -> f64 {
        self.six_volume[t] / 6.0
    }

    /// |∇s| of tet `t`.
    pub fn magnitude(&self, t: usize) -> f64 {
        norm(&self.gradient[t])
    }
}

#[inline]
pub(crate) fn sub(a: &[f64; 3], b: &[f64; 3]) -> [f64; 3] {
    [a[0] - b[0], a[1] - b[1], a[2] - b[2]]
}

#[inline]
fn cross(a: &[f64; 3], b: &[f64; 3]) -> [f64; 3] {
    [a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0]]
}

#[inline]
fn dot(a: &[f64; 3], b: &[f64; 3]) -> f64 {
    a[0] * b[0] + a[1] * b[1] + a[2] * b[2]
}

#[inline]
pub(crate) fn norm(a: &[f64; 3]) -> f64 {
    dot(a, a).sqrt()
}

/// The gradient of the linear interpolant on every tet.
///
/// With e_i = p_i − p_0 and Δs_i = s_i − s_0, ∇s solves e_i·∇s = Δs_i, whose
/// solution by Cramer's rule is Σ Δs_i (e_j × e_k) / det[e_1 e_2 e_3] over
/// the cyclic (i, j, k). The numerator is kept separately (see
/// [`TetGradients`]).
pub fn tet_gradients(points: &[[f64; 3]], tets: &[[u32; 4]], scalar: &[f64]) -> TetGradients {
    let per: Vec<([f64; 3], [f64; 3], f64)> = tets
        .par_iter()
        .with_min_len(4096)
        .map(|t| {
            let p0 = &points[t[0] as usize];
            let e = [1, 2, 3].map(|k| sub(&points[t[k] as usize], p0));
            let s0 = scalar[t[0] as usize];
            let ds = [1, 2, 3].map(|k| scalar[t[k] as usize] - s0);
            let c = [cross(&e[1], &e[2]), cross(&e[2], &e[0]), cross(&e[0], &e[1])];
            let det = dot(&e[0], &c[0]);
            let w = [0, 1, 2].map(|a| ds[0] * c[0][a] + ds[1] * c[1][a] + ds[2] * c[2][a]);
            if det > 0.0 && det.is_finite() {
                let g = w.map(|x| x / det);
                if g.iter().all(|x| x.is_finite()) {
                    return (g, w, det);
                }
            }
            ([0.0; 3], [0.0; 3], 0.0)
        })
        .collect();
    let mut out = TetGradients {
        gradient: Vec::with_capacity(per.len()),
        six_vol_gradient: Vec::with_capacity(per.len()),
        six_volume: Vec::with_capacity(per.len()),
    };
    for (g, w, v) in per {
        out.gradient.push(g);
        out.six_vol_gradient.push(w);
        out.six_volume.push(v);
    }
    out
}

/// The tets around each vertex, compressed: the tets of vertex v are
/// `tets[start[v]..start[v + 1]]`.
#[derive(Debug, Clone, PartialEq)]
pub struct VertexTets {
    pub start: Vec<u32>,
    pub tets: Vec<u32>,
}

impl VertexTets {
    /// Builds the incidence; every tet index must be below `num_points`.
    pub fn new(num_points: usize, tets: &[[u32; 4]]) -> VertexTets {
        let mut count = vec![0u32; num_points + 1];
        for t in tets {
            for &v in t {
                count[v as usize + 1] += 1;
            }
        }
        for i in 0..num_points {
            count[i + 1] += count[i];
        }
        let start = count.clone();
        let mut fill = count;
        let mut out = vec![0u32; tets.len() * 4];
        for (ti, t) in tets.iter().enumerate() {
            for &v in t {
                out[fill[v as usize] as usize] = ti as u32;
                fill[v as usize] += 1;
            }
        }
        VertexTets { start, tets: out }
    }

    /// The tets containing vertex `v`.
    pub fn of(&self, v: usize) -> &[u32] {
        &self.tets[self.start[v] as usize..self.start[v + 1] as usize]
    }
}

/// Eigenvalues below this fraction of the largest mark directions the
/// one-ring does not determine: with unit-direction weights the error of the
/// fitted component along an eigenvector grows like 1/√λ, so 1e-3 bounds the
/// amplification at about 30× the per-edge difference error before the
/// fallback takes over.
pub const LSQ_RELATIVE_EIGEN_FLOOR: f64 = 1e-3;

/// Volume-weighted average gradient at vertex `v` (zero if its tets have no
/// measurable volume).
fn tet_average_at(v: usize, vt: &VertexTets, tg: &TetGradients) -> [f64; 3] {
    let mut w = [0.0; 3];
    let mut vol = 0.0;
    for &t in vt.of(v) {
        let t = t as usize;
        for (wa, ga) in w.iter_mut().zip(&tg.six_vol_gradient[t]) {
            *wa += ga;
        }
        vol += tg.six_volume[t];
    }
    if vol > 0.0 {
        w.map(|x| x / vol)
    } else {
        [0.0; 3]
    }
}

/// Per-vertex gradients by `method`, given the per-tet gradients and the
/// vertex–tet incidence.
pub fn vertex_gradients(
    points: &[[f64; 3]],
    tets: &[[u32; 4]],
    scalar: &[f64],
    tg: &TetGradients,
    vt: &VertexTets,
    method: GradientMethod,
) -> Vec<[f64; 3]> {
    match method {
        GradientMethod::TetAverage => {
            (0..points.len()).into_par_iter().with_min_len(2048).map(|v| tet_average_at(v, vt, tg)).collect()
        }
        GradientMethod::LeastSquares => (0..points.len())
            .into_par_iter()
            .with_min_len(2048)
            .map_init(Vec::new, |ring: &mut Vec<u32>, v| {
                ring.clear();
                for &t in vt.of(v) {
                    ring.extend(tets[t as usize].iter().copied().filter(|&q| q as usize != v));
                }
                ring.sort_unstable();
                ring.dedup();
                lsq_at(v, ring, points, scalar, || tet_average_at(v, vt, tg))
            })
            .collect(),
    }
}

/// Least-squares gradient at `v` from its one-ring `ring`.
///
/// Weighted by 1/|d|², the normal equations are A g = b with
/// A = Σ û ûᵀ and b = Σ (Δs/|d|) û over unit directions û = d/|d|: A is
/// dimensionless and well scaled whatever the cell sizes or aspect ratios.
/// A is diagonalized (Jacobi); eigen-directions with λ ≥
/// [`LSQ_RELATIVE_EIGEN_FLOOR`]·λ_max are solved from the fit, the others
/// take the fallback's component. Both parts are exact for a linear field.
fn lsq_at(
    v: usize,
    ring: &[u32],
    points: &[[f64; 3]],
    scalar: &[f64],
    fallback: impl FnOnce() -> [f64; 3],
) -> [f64; 3] {
    let p = &points[v];
    let sp = scalar[v];
    let mut a = [[0.0f64; 3]; 3];
    let mut b = [0.0f64; 3];
    for &q in ring {
        let d = sub(&points[q as usize], p);
        let len = norm(&d);
        if len <= 0.0 || !len.is_finite() {
            continue;
        }
        let u = d.map(|x| x / len);
        let r = (scalar[q as usize] - sp) / len;
        for i in 0..3 {
            b[i] += r * u[i];
            for j in 0..3 {
                a[i][j] += u[i] * u[j];
            }
        }
    }
    let (lambda, vecs) = sym_eigen3(a);
    let lmax = lambda.iter().copied().fold(0.0, f64::max);
    let mut g = [0.0; 3];
    let mut fb: Option<[f64; 3]> = None;
    let mut fallback = Some(fallback);
    for k in 0..3 {
        let e = vecs[k];
        let c = if lmax > 0.0 && lambda[k] >= LSQ_RELATIVE_EIGEN_FLOOR * lmax {
            dot(&e, &b) / lambda[k]
        } else {
            let f = *fb.get_or_insert_with(|| (fallback.take().expect("called once"))());
            dot(&e, &f)
        };
        for i in 0..3 {
            g[i] += c * e[i];
        }
    }
    g
}

/// Eigenvalues and unit eigenvectors of a symmetric 3×3 matrix by cyclic
/// Jacobi rotations (converges quadratically; a handful of sweeps).
pub(crate) fn sym_eigen3(mut a: [[f64; 3]; 3]) -> ([f64; 3], [[f64; 3]; 3]) {
    let mut v = [[1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]];
    for _sweep in 0..32 {
        let off = a[0][1] * a[0][1] + a[0][2] * a[0][2] + a[1][2] * a[1][2];
        let diag = a[0][0] * a[0][0] + a[1][1] * a[1][1] + a[2][2] * a[2][2];
        if off <= 1e-32 * diag || off == 0.0 {
            break;
        }
        for (p, q) in [(0, 1), (0, 2), (1, 2)] {
            if a[p][q] == 0.0 {
                continue;
            }
            let theta = (a[q][q] - a[p][p]) / (2.0 * a[p][q]);
            let t = theta.signum() / (theta.abs() + (theta * theta + 1.0).sqrt());
            let t = if theta == 0.0 { 1.0 } else { t };
            let c = 1.0 / (t * t + 1.0).sqrt();
            let s = t * c;
            // A ← Jᵀ A J with J the rotation in the (p, q) plane.
            for row in a.iter_mut() {
                let (akp, akq) = (row[p], row[q]);
                row[p] = c * akp - s * akq;
                row[q] = s * akp + c * akq;
            }
            let (rp, rq) = (a[p], a[q]);
            for k in 0..3 {
                a[p][k] = c * rp[k] - s * rq[k];
                a[q][k] = s * rp[k] + c * rq[k];
            }
            // Columns of V are the eigenvectors.
            for row in v.iter_mut() {
                let vp = row[p];
                let vq = row[q];
                row[p] = c * vp - s * vq;
                row[q] = s * vp + c * vq;
            }
        }
    }
    let vecs = [0, 1, 2].map(|k| [v[0][k], v[1][k], v[2][k]]);
    ([a[0][0], a[1][1], a[2][2]], vecs)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn jacobi_diagonalizes() {
        let a = [[4.0, 1.0, -2.0], [1.0, 2.0, 0.5], [-2.0, 0.5, 3.0]];
        let (l, v) = sym_eigen3(a);
        for k in 0..3 {
            let av = [0, 1, 2].map(|i| dot(&a[i], &v[k]));
            for i in 0..3 {
                assert!((av[i] - l[k] * v[k][i]).abs() < 1e-12, "{av:?} vs {l:?}");
            }
            assert!((norm(&v[k]) - 1.0).abs() < 1e-12);
        }
        let (l, _) = sym_eigen3([[1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 0.0]]);
        assert_eq!(l, [1.0, 1.0, 0.0]);
    }

    #[test]
    fn tet_gradient_of_a_linear_field() {
        let p = [[0., 0., 0.], [1., 0., 0.], [0., 1., 0.], [0., 0., 1.]];
        let s: Vec<f64> = p.iter().map(|q| 1.0 + 2.0 * q[0] - 3.0 * q[1] + 0.5 * q[2]).collect();
        let tg = tet_gradients(&p, &[[0, 1, 2, 3]], &s);
        assert_eq!(tg.gradient[0], [2.0, -3.0, 0.5]);
        assert!((tg.volume(0) - 1.0 / 6.0).abs() < 1e-16);
    }

    #[test]
    fn coplanar_one_ring_takes_the_normal_component_from_the_fallback() {
        // Vertex 0 with neighbours only in the z = 0 plane.
        let pts = [[0., 0., 0.], [1., 0., 0.], [0., 1., 0.], [-1., -1., 0.]];
        let s = [0.0, 2.0, 3.0, -5.0];
        let g = lsq_at(0, &[1, 2, 3], &pts, &s, || [0.0, 0.0, 7.0]);
        assert!((g[0] - 2.0).abs() < 1e-12 && (g[1] - 3.0).abs() < 1e-12, "{g:?}");
        assert!((g[2] - 7.0).abs() < 1e-12);
    }
}
