//! The reference renderer: exact ray casting through the tets, the ground
//! truth every image error is measured against.
//!
//! Per pixel centre the camera's ray is cast; every boundary face through
//! which its line enters the mesh is found with a [`BoundaryBvh`]; from each
//! entry the ray walks tet to tet through the face adjacency until it leaves
//! through the boundary (a non-convex mesh is re-entered at its next entry
//! farther along). In each tet the exit face is decided by exact,
//! symbolically perturbed Plücker side tests (module `sos`), so a ray
//! through an edge or a vertex is neither lost nor counted twice; exit points
//! come from the Plücker barycentric coordinates of the exit face (always
//! inside it), the scalar there by barycentric interpolation. Each ray–tet
//! segment (Sf, Sb, l) is integrated with `exact` in f64 and composited
//! front to back in f64 (premultiplied "over").
//!
//! Walks start at boundary entries along the whole line, also behind the
//! eye, and segments are clipped at the camera's near depth: a camera inside
//! the mesh therefore needs no point location.

mod lit;
mod sos;

pub use lit::LitReference;

use crate::boundary::BoundaryBvh;
use crate::{Camera, Image, RenderError};
use glam::DVec3;
use rayon::prelude::*;
use sos::line_side;
use std::sync::atomic::{AtomicU32, Ordering};
use tet_mesh::{Adjacency, TetMesh, FACE_OUTWARD, NO_NEIGHBOR};
use tet_preint::{integrate_segment_with, TransferFunction};

/// Choices for a reference render.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ReferenceOptions {
    /// Stop a ray once its accumulated opacity reaches `alpha_cutoff`.
    pub early_termination: bool,
    /// Default 1 − 1e-9: what is left changes no output by more than 1e-9.
    pub alpha_cutoff: f64,
}

impl Default for ReferenceOptions {
    fn default() -> Self {
        ReferenceOptions { early_termination: true, alpha_cutoff: 1.0 - 1e-9 }
    }
}

/// Counts from one render (or one ray). All are exact integers, summed in a
/// fixed order, so they are deterministic.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub struct ReferenceStats {
    pub rays: u64,
    /// Rays whose line entered the mesh in front of the near plane.
    pub rays_hit: u64,
    /// Boundary entries walked from.
    pub entries: u64,
    /// Ray–tet steps taken (including zero-length and clipped ones).
    pub steps: u64,
    /// Segments of positive length integrated.
    pub segments: u64,
    /// Rays stopped by early termination.
    pub terminated_early: u64,
    /// Walks that could not find an exit face or a way back through the
    /// adjacency, or ran past the tet count. 0 on any valid mesh.
    pub walk_failures: u64,
    /// Most steps one ray took.
    pub max_steps_per_ray: u64,
}

impl ReferenceStats {
    pub(crate) fn add(&mut self, o: &ReferenceStats) {
        self.rays += o.rays;
        self.rays_hit += o.rays_hit;
        self.entries += o.entries;
        self.steps += o.steps;
        self.segments += o.segments;
        self.terminated_early += o.terminated_early;
        self.walk_failures += o.walk_failures;
        self.max_steps_per_ray = self.max_steps_per_ray.max(o.max_steps_per_ray);
    }
}

/// Premultiplied RGBA of one ray in f64 and its counts.
#[derive(Debug, Clone, Copy, Default, PartialEq)]
pub struct RayResult {
    pub rgba: [f64; 4],
    pub stats: ReferenceStats,
}

/// A mesh prepared for reference rendering: the boundary hierarchy is built
/// once here and reused for every view and transfer function.
#[derive(Debug)]
pub struct ReferenceRenderer<'a> {
    points: &'a [[f64; 3]],
    tets: &'a [[u32; 4]],
    scalar: &'a [f64],
    neighbors: &'a [[u32; 4]],
    convex: bool,
    bvh: BoundaryBvh,
}

/// Reusable per-thread buffers.
#[derive(Debug, Default)]
pub struct RayScratch {
    breakpoints: Vec<f64>,
    entries: Vec<Entry>,
    /// Shadow rays cast from a lit ray.
    shadow: crate::shadow::ShadowScratch,
}

/// How a walk through the adjacency ended.
#[derive(Debug, Clone, Copy, PartialEq)]
enum WalkEnd {
    /// The line left the mesh at this parameter.
    Left(f64),
    /// The visitor stopped the ray.
    Stopped,
    /// No exit face or no way back through the adjacency (counted).
    Failed,
}

/// Where a line enters the mesh through boundary face `packed_face`.
#[derive(Debug, Clone, Copy)]
pub(crate) struct Entry {
    at: LinePoint,
    packed_face: u32,
}

/// A point of the line on a face: its parameter, the scalar there, and the
/// face's vertices with their (normalized) barycentric weights, so any
/// per-vertex field can be interpolated there.
#[derive(Debug, Clone, Copy)]
pub(crate) struct LinePoint {
    pub(crate) ids: [u32; 3],
    pub(crate) w: [f64; 3],
    pub(crate) t: f64,
    pub(crate) s: f64,
}

impl LinePoint {
    /// A per-vertex field interpolated at this point.
    pub(crate) fn interp<const N: usize>(&self, field: &[[f64; N]]) -> [f64; N] {
        std::array::from_fn(|c| (0..3).map(|k| self.w[k] * field[self.ids[k] as usize][c]).sum())
    }
}

/// One ray–tet segment: the points where the line enters and leaves the
/// tet, and `t_front` (≥ `front.t`) where the segment starts after clipping.
/// Every per-vertex field is linear along it.
#[derive(Debug, Clone, Copy)]
pub(crate) struct LineSegment {
    /// Where the line enters the tet (or, walking from inside a tet, the
    /// start: only its parameter and scalar are meaningful then).
    pub(crate) front: LinePoint,
    /// Where it leaves.
    pub(crate) back: LinePoint,
    pub(crate) t_front: f64,
}

impl LineSegment {
    pub(crate) fn len(&self) -> f64 {
        self.back.t - self.t_front
    }

    /// Fraction of the way from `front` to `back` at parameter `t`.
    pub(crate) fn frac(&self, t: f64) -> f64 {
        let d = self.back.t - self.front.t;
        if d > 0.0 {
            ((t - self.front.t) / d).clamp(0.0, 1.0)
        } else {
            0.0
        }
    }

    /// The scalar at `t_front`.
    pub(crate) fn s_front(&self) -> f64 {
        if self.t_front > self.front.t {
            self.front.s + (self.back.s - self.front.s) * self.frac(self.t_front)
        } else {
            self.front.s
        }
    }
}

/// The line a ray lies on: the exact points `o` and `q` that all decisions
/// use, and the unit direction along which parameters `t` (world length
/// from `o`) are measured.
#[derive(Debug, Clone, Copy)]
pub(crate) struct Line {
    o: [f64; 3],
    q: [f64; 3],
    pub(crate) origin: DVec3,
    pub(crate) unit: DVec3,
}

impl Line {
    /// The line through two distinct finite points.
    pub(crate) fn through(origin: DVec3, through: DVec3) -> Option<Line> {
        let delta = through - origin;
        let len = delta.length();
        (len > 0.0 && len.is_finite()).then(|| Line { o: origin.into(), q: through.into(), origin, unit: delta / len })
    }

    fn q_vec(&self) -> DVec3 {
        DVec3::from(self.q)
    }

    pub(crate) fn at(&self, t: f64) -> DVec3 {
        self.origin + self.unit * t
    }
}

impl<'a> ReferenceRenderer<'a> {
    /// Checks that the mesh and adjacency agree (sizes, ids in range, finite
    /// points and scalars) and builds the boundary hierarchy.
    pub fn new(mesh: &'a TetMesh, adjacency: &'a Adjacency) -> Result<ReferenceRenderer<'a>, RenderError> {
        let bad = |why: String| Err(RenderError::InvalidMesh { why });
        let (np, nt) = (mesh.points.len(), mesh.tets.len());
        if nt > (u32::MAX / 4) as usize || np >= u32::MAX as usize {
            return bad(format!("{nt} tets / {np} points exceed the u32 ids"));
        }
        if mesh.scalar.len() != np {
            return bad(format!("{} scalars for {np} points", mesh.scalar.len()));
        }
        if adjacency.neighbors.len() != nt {
            return bad(format!("adjacency has {} tets, the mesh {nt}", adjacency.neighbors.len()));
        }
        if let Some(i) = mesh.points.iter().position(|p| !p.iter().all(|c| c.is_finite())) {
            return bad(format!("point {i} is not finite"));
        }
        if let Some(i) = mesh.scalar.iter().position(|s| !s.is_finite()) {
            return bad(format!("scalar of point {i} is not finite"));
        }
        for (t, (tet, nb)) in mesh.tets.iter().zip(&adjacency.neighbors).enumerate() {
            if tet.iter().any(|&v| v as usize >= np) {
                return bad(format!("tet {t} has a vertex id ≥ {np}"));
            }
            if nb.iter().any(|&n| n != NO_NEIGHBOR && n as usize >= nt) {
                return bad(format!("tet {t} has a neighbour id ≥ {nt}"));
            }
        }
        if let Some(&b) = adjacency.boundary_faces.iter().find(|&&b| b as usize >= 4 * nt) {
            return bad(format!("boundary face {b} is past the last tet"));
        }
        Ok(ReferenceRenderer {
            points: &mesh.points,
            tets: &mesh.tets,
            scalar: &mesh.scalar,
            neighbors: &adjacency.neighbors,
            convex: adjacency.convex,
            bvh: BoundaryBvh::build(&mesh.points, &mesh.tets, &adjacency.boundary_faces),
        })
    }

    pub fn bvh(&self) -> &BoundaryBvh {
        &self.bvh
    }

    /// The mesh's scalar, one per point.
    pub fn scalars(&self) -> &[f64] {
        self.scalar
    }

    /// The mesh's tets.
    pub fn tets(&self) -> &[[u32; 4]] {
        self.tets
    }

    /// The mesh's points (world).
    pub fn points(&self) -> &[[f64; 3]] {
        self.points
    }

    /// Smallest and largest scalar of the mesh.
    pub fn scalar_range(&self) -> [f64; 2] {
        self.scalar.iter().fold([f64::INFINITY, f64::NEG_INFINITY], |[a, b], &s| [a.min(s), b.max(s)])
    }

    /// Renders one image: one ray per pixel centre, rows in parallel. The
    /// result does not depend on the thread count. `tf` must be in the
    /// mesh's scalar units (denormalize a normalized one first).
    /// `progress(rows_done, rows_total)` is called from worker threads.
    pub fn render(
        &self,
        camera: &Camera,
        tf: &TransferFunction,
        options: &ReferenceOptions,
        progress: &(dyn Fn(u32, u32) + Sync),
    ) -> Result<(Image, ReferenceStats), RenderError> {
        if tf.normalized() {
            return Err(RenderError::NormalizedTransferFunction);
        }
        self.render_rows(camera, progress, &|x, y, scratch| self.trace_pixel(camera, x, y, tf, options, scratch))
    }

    /// One ray per pixel centre through `trace(x_px, y_px, scratch)`, rows in
    /// parallel, assembled in a fixed order (no dependence on the thread
    /// count).
    fn render_rows(
        &self,
        camera: &Camera,
        progress: &(dyn Fn(u32, u32) + Sync),
        trace: &(dyn Fn(f64, f64, &mut RayScratch) -> RayResult + Sync),
    ) -> Result<(Image, ReferenceStats), RenderError> {
        let (w, h) = (camera.width(), camera.height());
        let done = AtomicU32::new(0);
        let rows: Vec<(Vec<[f32; 4]>, ReferenceStats)> = (0..h)
            .into_par_iter()
            .map_init(RayScratch::default, |scratch, j| {
                let mut row = Vec::with_capacity(w as usize);
                let mut stats = ReferenceStats::default();
                for i in 0..w {
                    let r = trace(i as f64 + 0.5, j as f64 + 0.5, scratch);
                    row.push(r.rgba.map(|v| v as f32));
                    stats.add(&r.stats);
                }
                progress(done.fetch_add(1, Ordering::Relaxed) + 1, h);
                (row, stats)
            })
            .collect();
        let mut stats = ReferenceStats::default();
        let mut pixels = Vec::with_capacity(w as usize * h as usize);
        for (row, s) in rows {
            pixels.extend_from_slice(&row);
            stats.add(&s);
        }
        Ok((Image::from_pixels(w, h, pixels)?, stats))
    }

    /// The camera's ray through pixel coordinates (x_px, y_px), clipped at
    /// the near depth (perspective) or unclipped (parallel).
    pub fn trace_pixel(
        &self,
        camera: &Camera,
        x_px: f64,
        y_px: f64,
        tf: &TransferFunction,
        options: &ReferenceOptions,
        scratch: &mut RayScratch,
    ) -> RayResult {
        let (origin, dir) = camera.ray(x_px, y_px);
        let t_start = if camera.is_parallel() {
            f64::NEG_INFINITY
        } else {
            // depth = t · (dir · forward); dir · forward ≥ cos(half diagonal angle) > 0.
            camera.near_depth() / dir.dot(camera.forward())
        };
        self.trace_line(origin, origin + dir, t_start, tf, options, scratch)
    }

    /// Integrates along the line through `origin` and `through` (exact
    /// points: every decision is made on this line), from parameter
    /// `t_start` on, where t is world length from `origin` towards
    /// `through` (−∞: the whole line).
    pub fn trace_line(
        &self,
        origin: DVec3,
        through: DVec3,
        t_start: f64,
        tf: &TransferFunction,
        options: &ReferenceOptions,
        scratch: &mut RayScratch,
    ) -> RayResult {
        let mut res = RayResult { stats: ReferenceStats { rays: 1, ..Default::default() }, ..Default::default() };
        let Some(line) = Line::through(origin, through) else { return res };
        let mut acc = [0.0f64; 4];
        let breakpoints = &mut scratch.breakpoints;
        self.walk_line(&line, t_start, &mut scratch.entries, &mut res.stats, &mut |seg| {
            let c = integrate_segment_with(tf, seg.s_front(), seg.back.s, seg.len(), breakpoints);
            let tr = 1.0 - acc[3];
            acc[0] += tr * c.color[0];
            acc[1] += tr * c.color[1];
            acc[2] += tr * c.color[2];
            acc[3] += tr * c.alpha;
            options.early_termination && acc[3] >= options.alpha_cutoff
        });
        res.rgba = acc;
        res
    }

    /// Walks the line from every boundary entry along it (in order of the
    /// entry parameter) and hands `visit` each segment of positive length
    /// beyond `t_start` (clipped there), front to back; `visit` returns
    /// true to stop the ray (early termination). Counts go to `stats`.
    pub(crate) fn walk_line(
        &self,
        line: &Line,
        t_start: f64,
        entries: &mut Vec<Entry>,
        stats: &mut ReferenceStats,
        visit: &mut dyn FnMut(&LineSegment) -> bool,
    ) {
        self.walk_line_entering_after(line, t_start, f64::NEG_INFINITY, entries, stats, visit)
    }

    /// [`ReferenceRenderer::walk_line`] from the entries at parameters ≥
    /// `first_entry` only (the line is known to be outside the mesh just
    /// before it).
    fn walk_line_entering_after(
        &self,
        line: &Line,
        t_start: f64,
        first_entry: f64,
        entries: &mut Vec<Entry>,
        stats: &mut ReferenceStats,
        visit: &mut dyn FnMut(&LineSegment) -> bool,
    ) {
        entries.clear();
        self.bvh.for_each_near_line(line.origin, line.q_vec() - line.origin, |tri| {
            let [p0, p1, p2] = tri.vertices.map(|v| &self.points[v as usize]);
            // Entering through an outward face: the line passes every edge
            // on the positive side.
            let (v01, s01) = line_side(&line.o, &line.q, p0, p1);
            if s01 < 0 {
                return;
            }
            let (v12, s12) = line_side(&line.o, &line.q, p1, p2);
            if s12 < 0 {
                return;
            }
            let (v20, s20) = line_side(&line.o, &line.q, p2, p0);
            if s20 < 0 || s01 == 0 || s12 == 0 || s20 == 0 {
                return;
            }
            let t = &self.tets[(tri.packed_face / 4) as usize];
            let [i, j, k] = FACE_OUTWARD[(tri.packed_face % 4) as usize];
            let ids = [t[i], t[j], t[k]];
            let w = [v12.max(0.0), v20.max(0.0), v01.max(0.0)];
            let at = self.point_on_face(line, ids, w).unwrap_or_else(|| {
                // The line lies in the face's plane: the crossing point is
                // the limit of the perturbed line's, which no float weight
                // gives; the face centroid is as good as any point of it,
                // since a walk starting there keeps t monotone from it.
                self.point_on_face(line, ids, [1.0; 3]).expect("positive weights")
            });
            if at.t >= first_entry {
                entries.push(Entry { at, packed_face: tri.packed_face });
            }
        });
        entries.sort_by(|a, b| a.at.t.total_cmp(&b.at.t).then(a.packed_face.cmp(&b.packed_face)));
        let mut hit = false;
        let mut steps_this_ray = 0u64;
        for e in entries.iter() {
            stats.entries += 1;
            let (tet, f_in) = ((e.packed_face / 4) as usize, (e.packed_face % 4) as usize);
            let (end, steps) = self.walk_from(line, tet, f_in, e.at, t_start, &mut hit, stats, visit);
            steps_this_ray += steps;
            if end == WalkEnd::Stopped {
                break;
            }
        }
        stats.steps += steps_this_ray;
        stats.max_steps_per_ray = stats.max_steps_per_ray.max(steps_this_ray);
        stats.rays_hit = stats.rays_hit.max(hit as u64);
    }

    /// Walks on from `tet`, entered through face `f_in` at `p_in`, until the
    /// line leaves the mesh, `visit` stops it, or the walk fails; returns
    /// how it ended and the steps taken. Segments before `t_start` are
    /// skipped; `hit` is set once one reaches past it.
    #[allow(clippy::too_many_arguments)]
    fn walk_from(
        &self,
        line: &Line,
        mut tet: usize,
        mut f_in: usize,
        mut p_in: LinePoint,
        t_start: f64,
        hit: &mut bool,
        stats: &mut ReferenceStats,
        visit: &mut dyn FnMut(&LineSegment) -> bool,
    ) -> (WalkEnd, u64) {
        let n_tets = self.tets.len() as u64;
        let mut steps = 0u64;
        loop {
            steps += 1;
            if steps > n_tets + 1 {
                stats.walk_failures += 1;
                return (WalkEnd::Failed, steps);
            }
            let Some((f_out, p_raw)) = self.exit(line, tet, f_in) else {
                stats.walk_failures += 1;
                return (WalkEnd::Failed, steps);
            };
            let p_out = match p_raw {
                Some(p) if p.t > p_in.t => p,
                // Degenerate (all weights 0) or rounding put the exit
                // before the entry: a zero-length segment here, the
                // next tet takes the length.
                _ => p_in,
            };
            if p_out.t > t_start {
                *hit = true;
                let seg = LineSegment { front: p_in, back: p_out, t_front: p_in.t.max(t_start) };
                if seg.len() > 0.0 {
                    stats.segments += 1;
                    if visit(&seg) {
                        stats.terminated_early = 1;
                        return (WalkEnd::Stopped, steps);
                    }
                }
            }
            let next = self.neighbors[tet][f_out];
            if next == NO_NEIGHBOR {
                return (WalkEnd::Left(p_out.t), steps);
            }
            let back = self.neighbors[next as usize].iter().position(|&n| n as usize == tet);
            let Some(back) = back else {
                stats.walk_failures += 1;
                return (WalkEnd::Failed, steps);
            };
            tet = next as usize;
            f_in = back;
            p_in = p_out;
        }
    }

    /// The tet holding `p` strictly inside and the scalar there (linear in
    /// the tet), by exact predicates over every tet (a box test first).
    /// `None` when `p` is outside the mesh or on a face, edge or vertex of
    /// the tets around it: callers then walk whole lines instead.
    pub(crate) fn tet_strictly_containing(&self, p: DVec3) -> Option<(usize, f64)> {
        use tet_mesh::predicates::{tet_orientation, TetOrientation::Positive};
        let p = p.to_array();
        let tet = (0..self.tets.len()).into_par_iter().find_first(|&t| {
            let v = self.tets[t].map(|i| &self.points[i as usize]);
            let outside_box = (0..3).any(|k| {
                let (lo, hi) =
                    v.iter().fold((f64::INFINITY, f64::NEG_INFINITY), |(lo, hi), q| (lo.min(q[k]), hi.max(q[k])));
                !(p[k] > lo && p[k] < hi)
            });
            // p strictly on vertex i's side of the face opposite it, for
            // every i: p replaces i and the tet stays positive.
            !outside_box
                && (0..4).all(|i| {
                    let mut q = v;
                    q[i] = &p;
                    tet_orientation(q[0], q[1], q[2], q[3]) == Positive
                })
        })?;
        let v = self.tets[tet].map(|i| self.points[i as usize]);
        let vol = |q: [&[f64; 3]; 4]| tet_mesh::predicates::signed_tet_volume(q[0], q[1], q[2], q[3]);
        let w: [f64; 4] = std::array::from_fn(|i| {
            let mut q = [&v[0], &v[1], &v[2], &v[3]];
            q[i] = &p;
            vol(q)
        });
        let total: f64 = w.iter().sum();
        let s = (0..4).map(|i| w[i] * self.scalar[self.tets[tet][i] as usize]).sum::<f64>() / total;
        Some((tet, s))
    }

    /// Walks the line from `start`, a point strictly inside `tet` with
    /// scalar `s_start`, forwards (t ≥ 0, t = 0 at `start` = the line's
    /// origin) — no boundary hierarchy, no sort, only the tets ahead. Where
    /// the line leaves the mesh of a non-convex domain it may come back:
    /// then the rest is walked from the boundary entries beyond. `visit` as
    /// in [`ReferenceRenderer::walk_line`].
    pub(crate) fn walk_line_from_inside(
        &self,
        line: &Line,
        (tet, s_start): (usize, f64),
        entries: &mut Vec<Entry>,
        stats: &mut ReferenceStats,
        visit: &mut dyn FnMut(&LineSegment) -> bool,
    ) {
        let Some((f_out, Some(p_out))) = self.first_exit(line, tet) else {
            // The line lies in a face's plane: walk it whole.
            return self.walk_line(line, 0.0, entries, stats, visit);
        };
        let t = &self.tets[tet];
        // `start` as a "face point": the tet's vertex 0 with the start's
        // scalar (only t and s of a segment's front are read by visitors
        // that interpolate nothing else; gradients use the back's weights
        // beyond the first segment).
        let p_in = LinePoint { t: 0.0, s: s_start, ids: [t[0], t[0], t[0]], w: [1.0, 0.0, 0.0] };
        let mut hit = false;
        stats.steps += 1;
        if p_out.t > 0.0 {
            let seg = LineSegment { front: p_in, back: p_out, t_front: 0.0 };
            stats.segments += 1;
            if visit(&seg) {
                stats.terminated_early = 1;
                return;
            }
        }
        let next = self.neighbors[tet][f_out];
        let left_at = if next == NO_NEIGHBOR {
            Some(p_out.t)
        } else {
            let Some(back) = self.neighbors[next as usize].iter().position(|&n| n as usize == tet) else {
                stats.walk_failures += 1;
                return;
            };
            let (end, steps) = self.walk_from(line, next as usize, back, p_out, 0.0, &mut hit, stats, visit);
            stats.steps += steps;
            match end {
                WalkEnd::Left(t) => Some(t),
                WalkEnd::Stopped | WalkEnd::Failed => None,
            }
        };
        if let Some(t_left) = left_at {
            if !self.convex {
                // Re-entries further along.
                self.walk_line_entering_after(line, t_left, t_left, entries, stats, visit);
            }
        }
    }

    /// The face through which the line leaves `tet` going forwards, for a
    /// line through a point strictly inside it: the face whose three edges
    /// the line passes on the leaving side (exact, perturbed decisions as
    /// in [`ReferenceRenderer::exit`]).
    fn first_exit(&self, line: &Line, tet: usize) -> Option<(usize, Option<LinePoint>)> {
        let t = &self.tets[tet];
        let p = |l: usize| &self.points[t[l] as usize];
        for (f, &face) in FACE_OUTWARD.iter().enumerate() {
            let mut vals = [0.0f64; 3];
            let mut ok = true;
            for e in 0..3 {
                let (val, s) = line_side(&line.o, &line.q, p(face[e]), p(face[(e + 1) % 3]));
                if s >= 0 {
                    ok = false;
                    break;
                }
                vals[e] = val;
            }
            if ok {
                let w = std::array::from_fn(|i| (-vals[(i + 1) % 3]).max(0.0));
                let ids = [t[face[0]], t[face[1]], t[face[2]]];
                return Some((f, self.point_on_face(line, ids, w)));
            }
        }
        None
    }

    /// Leaving `tet`, entered through face `f_in`: the exit face and, unless
    /// the line lies in the exit face's plane, the exit point. `None` when
    /// no face qualifies (impossible for a positively oriented tet entered
    /// consistently).
    #[inline]
    fn exit(&self, line: &Line, tet: usize, f_in: usize) -> Option<(usize, Option<LinePoint>)> {
        let t = &self.tets[tet];
        let p = |l: usize| &self.points[t[l] as usize];
        // The exit face contains the vertex opposite the entry face (local
        // index f_in); its edge on the entry face is already known to pass
        // correctly, so only the three edges from that vertex decide.
        let v = f_in;
        let mut side = [(0.0f64, 0i8); 4];
        for (w, s) in side.iter_mut().enumerate() {
            if w != v {
                *s = line_side(&line.o, &line.q, p(v), p(w));
            }
        }
        for (f, &face) in FACE_OUTWARD.iter().enumerate() {
            if f == f_in {
                continue;
            }
            // Value of the oriented face edge x → y for the line, and whether
            // it passes on the leaving (negative) side.
            let mut vals = [0.0f64; 3];
            let mut ok = true;
            for e in 0..3 {
                let (x, y) = (face[e], face[(e + 1) % 3]);
                let (val, s) = if x == v {
                    side[y]
                } else if y == v {
                    (-side[x].0, -side[x].1)
                } else {
                    (f64::NAN, -1) // the entry-face edge: computed below if needed
                };
                if s >= 0 {
                    ok = false;
                    break;
                }
                vals[e] = val;
            }
            if !ok {
                continue;
            }
            // Barycentric weight of face vertex i is the value of the edge
            // opposite it (edge i+1 → i+2), negated for the leaving side.
            let mut w = [0.0f64; 3];
            for (i, wi) in w.iter_mut().enumerate() {
                let e = (i + 1) % 3;
                let val = if vals[e].is_nan() {
                    line_side(&line.o, &line.q, p(face[e]), p(face[(e + 1) % 3])).0
                } else {
                    vals[e]
                };
                *wi = (-val).max(0.0);
            }
            let ids = [t[face[0]], t[face[1]], t[face[2]]];
            return Some((f, self.point_on_face(line, ids, w)));
        }
        None
    }

    /// The point with barycentric weights `w` on the triangle `ids`
    /// (normalized there); `None` if the weights sum to zero.
    #[inline]
    fn point_on_face(&self, line: &Line, ids: [u32; 3], w: [f64; 3]) -> Option<LinePoint> {
        let sum = w[0] + w[1] + w[2];
        if !(sum > 0.0 && sum.is_finite()) {
            return None;
        }
        let w = w.map(|x| x / sum);
        let mut pos = DVec3::ZERO;
        let mut s = 0.0;
        for (id, wi) in ids.iter().zip(w) {
            pos += DVec3::from(self.points[*id as usize]) * wi;
            s += self.scalar[*id as usize] * wi;
        }
        Some(LinePoint { t: (pos - line.origin).dot(line.unit), s, ids, w })
    }
}

/// Builds a [`ReferenceRenderer`] and renders one image; keep the renderer
/// instead when rendering several views of one mesh.
///
/// ```
/// use tet_mesh::{build_adjacency, TetMesh};
/// use tet_preint::{ColorNode, Emission, OpacityNode, TransferFunction};
/// use tet_render::{render_reference, Camera, ReferenceOptions, ViewSpec};
/// let mesh = TetMesh {
///     points: vec![[0.0, 0.0, 0.0], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]],
///     tets: vec![[0, 1, 2, 3]].into(),
///     scalar: vec![0.0; 4],
///     scalar_name: "s".into(),
///     point_fields: Vec::new(),
/// };
/// let adj = build_adjacency(&mesh.points, &mesh.tets).unwrap();
/// let tf = TransferFunction::new(
///     vec![ColorNode { x: 0.0, rgb: [1.0, 0.5, 0.25] }],
///     vec![OpacityNode { x: 0.0, a: 2.0 }],
///     1.0,
///     Emission::Density,
///     false,
/// )?;
/// // Looking down −z at the point (0.2, 0.2): the chord through the tet is 0.6.
/// let view = ViewSpec {
///     position: [0.2, 0.2, 5.0], focal_point: [0.2, 0.2, 0.0], view_up: [0.0, 1.0, 0.0],
///     view_angle: 30.0, parallel: true, parallel_scale: 0.01, size: [1, 1],
/// };
/// let camera = Camera::new(&view)?;
/// let (img, stats) = render_reference(&mesh, &adj, &camera, &tf, &ReferenceOptions::default(), &|_, _| {})?;
/// let alpha = 1.0 - (-2.0f64 * 0.6).exp();
/// assert!((img.pixel(0, 0)[3] as f64 - alpha).abs() < 1e-6);
/// assert_eq!(stats.walk_failures, 0);
/// # Ok::<(), Box<dyn std::error::Error>>(())
/// ```
pub fn render_reference(
    mesh: &TetMesh,
    adjacency: &Adjacency,
    camera: &Camera,
    tf: &TransferFunction,
    options: &ReferenceOptions,
    progress: &(dyn Fn(u32, u32) + Sync),
) -> Result<(Image, ReferenceStats), RenderError> {
    ReferenceRenderer::new(mesh, adjacency)?.render(camera, tf, options, progress)
}
