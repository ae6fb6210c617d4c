//! Ray segments drawn from a mesh's own cells — the distribution of
//! (Sf, Sb, l) a renderer actually asks a pre-integration method for, used
//! to measure every method's error against the exact integral.
//!
//! A draw: a cell chosen uniformly, a point uniform inside it, a direction
//! uniform on the sphere; the segment is the chord of that line through the
//! cell, entry first. Deterministic for a seed, whatever the thread count.

use rayon::prelude::*;
use tet_mesh::SplitMix64;

/// One ray segment through a linear tet, entry ("front") first.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct SampledSegment {
    pub s_front: f64,
    pub s_back: f64,
    /// |∇s| at entry and exit (0 without gradients).
    pub grad_front: f64,
    pub grad_back: f64,
    pub len_world: f64,
    /// The tet the segment crosses.
    pub tet: u32,
}

const CHUNK: usize = 4096;

/// `count` segments through random cells of the mesh. Cells with (near)
/// zero volume cannot be crossed and are redrawn; an empty mesh or one with
/// only flat cells gives no segments. `grad_magnitude`, if given, holds
/// |∇s| per vertex.
pub fn sample_cell_segments(
    points: &[[f64; 3]],
    tets: &[[u32; 4]],
    scalar: &[f64],
    grad_magnitude: Option<&[f64]>,
    count: usize,
    seed: u64,
) -> Vec<SampledSegment> {
    if tets.is_empty() || count == 0 {
        return Vec::new();
    }
    let chunks = count.div_ceil(CHUNK);
    let mut out: Vec<SampledSegment> = (0..chunks)
        .into_par_iter()
        .flat_map_iter(|c| {
            let mut rng = SplitMix64(seed ^ (c as u64).wrapping_mul(0xD1B5_4A32_D192_ED03));
            let n = CHUNK.min(count - c * CHUNK);
            let mut seg = Vec::with_capacity(n);
            // Bounded redraws: a mesh of flat cells must not loop forever.
            let mut tries = 0usize;
            while seg.len() < n && tries < 64 * n {
                tries += 1;
                let t = rng.below(tets.len());
                if let Some(s) = chord(points, tets[t], scalar, grad_magnitude, &mut rng) {
                    seg.push(SampledSegment { tet: t as u32, ..s });
                }
            }
            seg
        })
        .collect();
    out.truncate(count);
    out
}

fn chord(
    points: &[[f64; 3]],
    tet: [u32; 4],
    scalar: &[f64],
    grad: Option<&[f64]>,
    rng: &mut SplitMix64,
) -> Option<SampledSegment> {
    let p = tet.map(|v| points[v as usize]);
    let e = |k: usize| [p[k][0] - p[0][0], p[k][1] - p[0][1], p[k][2] - p[0][2]];
    let (e1, e2, e3) = (e(1), e(2), e(3));
    let det = dot(e1, cross(e2, e3));
    let scale = norm(e1).max(norm(e2)).max(norm(e3));
    if det.is_nan() || det.abs() <= 1e-12 * scale * scale * scale {
        return None;
    }
    // Rows of the inverse of [e1 e2 e3]: gradients of barycentrics 1..3.
    let inv = [cross(e2, e3), cross(e3, e1), cross(e1, e2)].map(|r| r.map(|x| x / det));
    // A uniform point inside: sorted uniforms give uniform barycentrics.
    let mut u = [rng.next_f64(), rng.next_f64(), rng.next_f64()];
    u.sort_by(f64::total_cmp);
    let lam = [u[0], u[1] - u[0], u[2] - u[1], 1.0 - u[2]];
    // Uniform direction on the sphere.
    let z = 2.0 * rng.next_f64() - 1.0;
    let phi = std::f64::consts::TAU * rng.next_f64();
    let r = (1.0 - z * z).max(0.0).sqrt();
    let d = [r * phi.cos(), r * phi.sin(), z];
    let dl123 = [dot(inv[0], d), dot(inv[1], d), dot(inv[2], d)];
    let dl = [-(dl123[0] + dl123[1] + dl123[2]), dl123[0], dl123[1], dl123[2]];
    let (mut t_in, mut t_out) = (f64::NEG_INFINITY, f64::INFINITY);
    for k in 0..4 {
        if dl[k] > 0.0 {
            t_in = t_in.max(-lam[k] / dl[k]);
        } else if dl[k] < 0.0 {
            t_out = t_out.min(-lam[k] / dl[k]);
        }
    }
    if !(t_in.is_finite() && t_out.is_finite() && t_out >= t_in) {
        return None;
    }
    let at =
        |t: f64, f: &dyn Fn(usize) -> f64| (0..4).map(|k| (lam[k] + t * dl[k]).clamp(0.0, 1.0) * f(k)).sum::<f64>();
    let s = |k: usize| scalar[tet[k] as usize];
    let (gf, gb) = match grad {
        Some(g) => {
            let gk = |k: usize| g[tet[k] as usize];
            (at(t_in, &gk), at(t_out, &gk))
        }
        None => (0.0, 0.0),
    };
    Some(SampledSegment {
        s_front: at(t_in, &s),
        s_back: at(t_out, &s),
        grad_front: gf,
        grad_back: gb,
        len_world: t_out - t_in,
        tet: 0,
    })
}

fn dot(a: [f64; 3], b: [f64; 3]) -> f64 {
    a[0] * b[0] + a[1] * b[1] + a[2] * b[2]
}
fn cross(a: [f64; 3], b: [f64; 3]) -> [f64; 3] {
    [a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0]]
}
fn norm(a: [f64; 3]) -> f64 {
    dot(a, a).sqrt()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn chords_lie_in_the_cell_and_match_the_linear_field() {
        // Unit right tet with s = x + 2y + 3z: along a chord of length l the
        // scalar changes by at most |∇s|·l, and both ends lie on the faces.
        let points = [[0.0, 0.0, 0.0], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]];
        let scalar: Vec<f64> = points.iter().map(|p| p[0] + 2.0 * p[1] + 3.0 * p[2]).collect();
        let segs = sample_cell_segments(&points, &[[0, 1, 2, 3]], &scalar, None, 10_000, 7);
        assert_eq!(segs.len(), 10_000);
        let max_l = 2f64.sqrt() + 1e-12;
        for s in &segs {
            assert!(s.len_world > 0.0 && s.len_world <= max_l, "{s:?}");
            assert!((s.s_front - s.s_back).abs() <= 14f64.sqrt() * s.len_world + 1e-9);
            assert!((0.0..=3.0 + 1e-9).contains(&s.s_front) && (0.0..=3.0 + 1e-9).contains(&s.s_back));
        }
        let again = sample_cell_segments(&points, &[[0, 1, 2, 3]], &scalar, None, 10_000, 7);
        assert_eq!(segs, again);
    }

    #[test]
    fn flat_cells_give_no_segments_without_looping() {
        let points = [[0.0, 0.0, 0.0], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [1.0, 1.0, 0.0]];
        let segs = sample_cell_segments(&points, &[[0, 1, 2, 3]], &[0.0; 4], None, 100, 1);
        assert!(segs.is_empty());
    }
}
