//! A light-space deep shadow map for a directional light (after Lokovic &
//! Veach, "Deep Shadow Maps", SIGGRAPH 2000): a grid of rays travelling
//! with the light across the mesh's bounding box, each walked exactly
//! through the mesh, recording the optical depth from the light at evenly
//! spaced depths. A point's depth is interpolated bilinearly between the
//! four nearest rays and linearly in depth, so its resolution is the
//! grid's, not the mesh's: a shadow edge inside a large cell stays sharp
//! to a texel.

use glam::DVec3;
use rayon::prelude::*;
use tet_preint::{optical_depth_with, TransferFunction};

use super::{ShadowScratch, OPAQUE_DEPTH};
use crate::reference::{Line, ReferenceRenderer, ReferenceStats};

/// Rays across the longer side of the light's view of the bounding box.
pub const MAP_RAYS: usize = 256;
/// Depth samples along each ray.
pub const MAP_DEPTHS: usize = 128;

/// Optical depth from a directional light over a grid of its rays.
#[derive(Debug, Clone)]
pub struct DeepShadowMap {
    /// Unit vectors across the rays and along them (the light's travel).
    e1: DVec3,
    e2: DVec3,
    d: DVec3,
    /// Coordinates of the first ray's centre and first depth sample, and
    /// the spacing of rays and samples (in the frame of the mesh the map
    /// was walked in).
    u0: f64,
    v0: f64,
    t0: f64,
    du: f64,
    dv: f64,
    dt: f64,
    nu: usize,
    nv: usize,
    nt: usize,
    /// `depth[(j·nu + i)·nt + k]`: optical depth at sample k of ray (i, j).
    depth: Vec<f32>,
}

impl DeepShadowMap {
    /// Walks `MAP_RAYS` × (as many as the aspect gives) rays of a light
    /// travelling along unit `d` through `reference`'s mesh (points in the
    /// frame the map is looked up in).
    pub(crate) fn build(
        reference: &ReferenceRenderer,
        d: DVec3,
        tf: &TransferFunction,
        stats: &mut ReferenceStats,
    ) -> DeepShadowMap {
        let e1 = d.any_orthonormal_vector();
        let e2 = d.cross(e1);
        let (mut lo, mut hi) = (DVec3::splat(f64::INFINITY), DVec3::splat(f64::NEG_INFINITY));
        for p in reference.points() {
            let p = DVec3::from(*p);
            let q = DVec3::new(p.dot(e1), p.dot(e2), p.dot(d));
            lo = lo.min(q);
            hi = hi.max(q);
        }
        let ext = (hi - lo).max(DVec3::splat(1e-300));
        let longest = ext.x.max(ext.y);
        let (nu, nv) = if ext.x >= ext.y {
            (MAP_RAYS, ((MAP_RAYS as f64 * ext.y / longest).ceil() as usize).clamp(2, MAP_RAYS))
        } else {
            (((MAP_RAYS as f64 * ext.x / longest).ceil() as usize).clamp(2, MAP_RAYS), MAP_RAYS)
        };
        // Ray centres span the box edge to edge, drawn in by 1e-7 of it:
        // a ray along the rim would run along boundary faces of a box-like
        // mesh, where the exact walk (rightly) finds no inside; a point on
        // the rim takes the value just inside. Samples from the first
        // depth to the last.
        let inset = ext.x.max(ext.y) * 1e-7;
        let (du, dv) = ((ext.x - 2.0 * inset) / (nu - 1) as f64, (ext.y - 2.0 * inset) / (nv - 1) as f64);
        let nt = MAP_DEPTHS;
        let dt = ext.z / (nt - 1) as f64;
        let (u0, v0, t0) = (lo.x + inset, lo.y + inset, lo.z);
        let rows: Vec<(Vec<f32>, ReferenceStats)> = (0..nv)
            .into_par_iter()
            .map_init(ShadowScratch::default, |scratch, j| {
                let mut st = ReferenceStats::default();
                let mut row = vec![0.0f32; nu * nt];
                for i in 0..nu {
                    let start = e1 * (u0 + i as f64 * du) + e2 * (v0 + j as f64 * dv) + d * t0;
                    let out = &mut row[i * nt..(i + 1) * nt];
                    walk_ray(reference, start, d, dt, tf, scratch, &mut st, out);
                }
                (row, st)
            })
            .collect();
        let mut depth = Vec::with_capacity(nu * nv * nt);
        for (row, st) in rows {
            depth.extend(row);
            stats.add(&st);
        }
        DeepShadowMap { e1, e2, d, u0, v0, t0, du, dv, dt, nu, nv, nt, depth }
    }

    /// The optical depth from the light to `p` (in the map's frame).
    pub fn depth_at(&self, p: DVec3) -> f64 {
        let coord = |x: f64, x0: f64, dx: f64, n: usize| {
            let f = if dx > 0.0 { ((x - x0) / dx).clamp(0.0, (n - 1) as f64) } else { 0.0 };
            let i = (f as usize).min(n - 2);
            (i, f - i as f64)
        };
        let (i, wu) = coord(p.dot(self.e1), self.u0, self.du, self.nu);
        let (j, wv) = coord(p.dot(self.e2), self.v0, self.dv, self.nv);
        let (k, wt) = coord(p.dot(self.d), self.t0, self.dt, self.nt);
        let at = |i: usize, j: usize| {
            let base = (j * self.nu + i) * self.nt + k;
            let (a, b) = (self.depth[base] as f64, self.depth[base + 1] as f64);
            a + wt * (b - a)
        };
        let bottom = at(i, j) + wu * (at(i + 1, j) - at(i, j));
        let top = at(i, j + 1) + wu * (at(i + 1, j + 1) - at(i, j + 1));
        bottom + wv * (top - bottom)
    }

    pub fn memory_bytes(&self) -> usize {
        self.depth.len() * 4
    }

    /// Rays across and along, and samples along each ray.
    pub fn resolution(&self) -> [usize; 3] {
        [self.nu, self.nv, self.nt]
    }
}

/// Walks the ray from `start` along `d`, writing the optical depth at
/// parameters k·dt (k = 0…) into `out`.
#[allow(clippy::too_many_arguments)]
fn walk_ray(
    reference: &ReferenceRenderer,
    start: DVec3,
    d: DVec3,
    dt: f64,
    tf: &TransferFunction,
    scratch: &mut ShadowScratch,
    stats: &mut ReferenceStats,
    out: &mut [f32],
) {
    let Some(line) = Line::through(start, start + d) else { return };
    let (mut acc, mut k) = (0.0f64, 0usize);
    let n = out.len();
    let breakpoints = &mut scratch.breakpoints;
    stats.rays += 1;
    reference.walk_line(&line, f64::NEG_INFINITY, &mut scratch.entries, stats, &mut |seg| {
        let s0 = seg.s_front();
        // Samples before this segment see the depth so far.
        while k < n && (k as f64) * dt < seg.t_front {
            out[k] = acc.min(OPAQUE_DEPTH) as f32;
            k += 1;
        }
        while k < n && (k as f64) * dt <= seg.back.t {
            let t = k as f64 * dt;
            let s = s0 + (seg.back.s - s0) * ((t - seg.t_front) / seg.len()).clamp(0.0, 1.0);
            out[k] = (acc + optical_depth_with(tf, s0, s, t - seg.t_front, breakpoints)).min(OPAQUE_DEPTH) as f32;
            k += 1;
        }
        acc += optical_depth_with(tf, s0, seg.back.s, seg.len(), breakpoints);
        acc >= OPAQUE_DEPTH || k >= n
    });
    for x in &mut out[k..] {
        *x = acc.min(OPAQUE_DEPTH) as f32;
    }
}
