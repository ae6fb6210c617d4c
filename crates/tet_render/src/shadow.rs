//! Volumetric shadows: each light's transmittance through the volume.
//!
//! [`ShadowField`] holds, per shadow-casting light, the optical depth ∫ρ
//! from points of the volume to the light, found with the reference's
//! exact walk (exact predicates, so a line through an edge or a vertex is
//! neither lost nor counted twice) and the exact optical depth of each
//! linear piece of the TF ([`tet_preint::optical_depth_with`]); renderers
//! take exp(−depth). Two forms:
//!
//! * **Directional lights: a deep shadow map** ([`DeepShadowMap`]): a grid
//!   of [`MAP_RAYS`] rays across the light's view of the bounding box,
//!   each walked through the mesh, its depth kept at every tet crossing
//!   and TF node, looked up by position (bilinear across rays, linear
//!   between knots). Its
//!   resolution is the grid's, not the mesh's: a shadow edge inside a
//!   large cell stays sharp to a ray spacing.
//! * **Point lights outside the mesh's bounding box: a deep shadow map**
//!   of rays fanning out from the light over the mesh (looked up by
//!   direction from the light and distance).
//! * **Other point lights (inside or beside the box): per vertex**, walked
//!   from each vertex towards the light and interpolated linearly inside
//!   each tet like the gradients.
//!   Each vertex's value is the limit at the vertex from inside one of its
//!   (visible) tets: the walk starts a hair inside that tet and drops the
//!   segments that only circle the vertex (those leaving by faces that
//!   hold it), so a vertex on a lit boundary face sees 1 however dense the
//!   medium; the walk ends at the light (a light inside the mesh), and a
//!   vertex at the light's position sees 1. Vertices no visible tet uses
//!   get no walk. A shadow changing within a cell is blurred to the
//!   cell; a medium so dense that light dies within a small part of a
//!   cell is lit only at the boundary vertices facing the light.
//!
//! The reference instead casts a shadow ray at every integration node
//! ([`ShadowMode::Exact`]), or reads this field ([`ShadowMode::Field`]) so
//! that the field's error and the lighting's are measured apart.
//!
//! The field depends on the mesh, the TF and the lights, not on the
//! camera: a camera move reuses it ([`ShadowKey`] says what it was made
//! for). Self-shadowing needs no bias: walks start at the point they
//! shade, so a thin sheet shadows only what lies behind it (no acne).
//! Depths stop at [`OPAQUE_DEPTH`] (transmittance 1e-20), never NaN or
//! infinite.

use std::sync::atomic::{AtomicUsize, Ordering};

use glam::DVec3;
use rayon::prelude::*;
use tet_preint::{optical_depth_with, TransferFunction};

use crate::cull::CellCuller;
use crate::reference::{Line, ReferenceRenderer, ReferenceStats};
use crate::shading::{LightSet, LightSource};
use crate::RenderError;

mod map;

pub use map::{DeepShadowMap, MapLayout, MAP_RAYS};

/// How far into one of its tets a vertex's walk starts, as a fraction of
/// the way to the tet's centroid.
const START_INSIDE: f64 = 1e-7;

/// Optical depth at which a shadow walk stops: transmittance below
/// e^−46 ≈ 1e-20 changes no pixel (what is stored is the transmittance so
/// far, ≤ 1e-20; past e^−746 it is 0).
pub const OPAQUE_DEPTH: f64 = 46.0;

/// How a renderer obtains shadow transmittances.
#[derive(Debug, Clone, Copy)]
pub enum ShadowMode<'a> {
    /// An exact shadow ray from every sample point (the reference only).
    Exact,
    /// The per-vertex field, interpolated linearly inside each tet.
    Field(&'a ShadowField),
}

/// What a shadow field was computed for: the lights and a fingerprint of
/// the TF and scalar (any change means recomputing).
#[derive(Debug, Clone, PartialEq)]
pub struct ShadowKey {
    pub lights: LightSet,
    /// The TF it was walked with (in scalar units).
    pub tf: TransferFunction,
    /// The scene's scalar range and vertex count, a guard against using a
    /// field with another time step's scalar.
    pub scalar_range: [f64; 2],
    pub num_points: usize,
}

/// What one light's shadow is held as.
#[derive(Debug, Clone)]
enum LightShadow {
    /// The light casts none (the headlight).
    None,
    /// Optical depth per vertex (at most [`OPAQUE_DEPTH`]): point lights.
    Vertices(Vec<f32>),
    /// A deep shadow map: directional lights, point lights outside the box.
    Map(DeepShadowMap),
}

/// Each light's optical depth through the volume: per vertex for point
/// lights, a light-space deep shadow map for directional lights.
#[derive(Debug, Clone)]
pub struct ShadowField {
    key: ShadowKey,
    per_light: Vec<LightShadow>,
    /// Where the frame the field was walked in has its origin, in world
    /// coordinates (the scene's centre): map lookups subtract it.
    frame_origin_in_world: DVec3,
    stats: ReferenceStats,
}

impl ShadowField {
    /// Walks from every vertex towards every shadow-casting light of
    /// `lights` through `reference`'s mesh with `tf` (in scalar units, not
    /// normalized). Vertices in parallel; the result does not depend on the
    /// thread count. `progress(done, total)` counts vertices.
    pub fn compute(
        reference: &ReferenceRenderer,
        tf: &TransferFunction,
        lights: &LightSet,
        progress: &(dyn Fn(usize, usize) + Sync),
    ) -> Result<ShadowField, RenderError> {
        if tf.normalized() {
            return Err(RenderError::NormalizedTransferFunction);
        }
        if !tf.widgets().is_empty() {
            return Err(RenderError::Scene(
                "shadows need a 1D transfer function (this one has 2D widgets, whose extinction depends on |∇s|)"
                    .into(),
            ));
        }
        let points = reference.points();
        let n = points.len();
        // Each vertex's walk starts a hair inside one of its tets (towards
        // that tet's centroid, 1e-7 of the way): the transmittance the
        // tets interpolate is the limit from inside the mesh, also where
        // the light grazes a boundary face through the vertex (there the
        // vertex itself is on the line's perturbed outside).
        let tets = reference.tets();
        let scalar = reference.scalars();
        let culler = crate::TfCuller::new(tf);
        // Only point lights walk from the vertices (directional ones build
        // a map): without one, no vertex needs a tet.
        let any_point = lights.lights().iter().any(|l| matches!(l, LightSource::Point { .. }));
        let mut owner = vec![u32::MAX; if any_point { n } else { 0 }];
        for (t, tet) in tets.iter().enumerate().filter(|_| any_point) {
            let s = tet.map(|v| scalar[v as usize]);
            let range =
                [s.iter().copied().fold(f64::INFINITY, f64::min), s.iter().copied().fold(f64::NEG_INFINITY, f64::max)];
            if culler.is_invisible(range, None) {
                continue;
            }
            for &v in tet {
                if owner[v as usize] == u32::MAX {
                    owner[v as usize] = t as u32;
                }
            }
        }
        // The start point, its tet and the scalar there.
        let start = |v: usize| -> Option<(DVec3, usize, f64)> {
            let t = owner[v];
            if t == u32::MAX {
                return None;
            }
            let tet = &tets[t as usize];
            let p = DVec3::from(points[v]);
            let c = tet.iter().map(|&w| DVec3::from(points[w as usize])).sum::<DVec3>() * 0.25;
            let s_mean = tet.iter().map(|&w| scalar[w as usize]).sum::<f64>() * 0.25;
            Some((p + (c - p) * START_INSIDE, t as usize, scalar[v] + (s_mean - scalar[v]) * START_INSIDE))
        };
        let casting: Vec<usize> =
            lights.lights().iter().enumerate().filter(|(_, l)| l.casts_shadow()).map(|(i, _)| i).collect();
        let total = n * casting.len();
        let done = AtomicUsize::new(0);
        let mut per_light = vec![LightShadow::None; lights.lights().len()];
        let mut stats = ReferenceStats::default();
        for &i in &casting {
            let light = lights.lights()[i];
            if let LightSource::Directional { direction, .. } = light {
                let d = DVec3::from(direction).normalize();
                per_light[i] = LightShadow::Map(DeepShadowMap::build(reference, d, tf, &mut stats));
                progress(done.fetch_add(n, Ordering::Relaxed) + n, total);
                continue;
            }
            if let LightSource::Point { position, .. } = light {
                if let Some(m) = DeepShadowMap::build_point(reference, DVec3::from(position), tf, &mut stats) {
                    per_light[i] = LightShadow::Map(m);
                    progress(done.fetch_add(n, Ordering::Relaxed) + n, total);
                    continue;
                }
            }
            let chunks: Vec<std::ops::Range<usize>> = (0..n).step_by(4096).map(|a| a..(a + 4096).min(n)).collect();
            let rows: Vec<(Vec<f32>, ReferenceStats)> = chunks
                .into_par_iter()
                .map_init(ShadowScratch::default, |scratch, range| {
                    let mut st = ReferenceStats::default();
                    let len = range.len();
                    let v = range
                        .map(|v| {
                            let depth: f64 = match start(v) {
                                Some((p, t, s)) => {
                                    reference.depth_to_light_from(p, t, s, Some(v as u32), &light, tf, scratch, &mut st)
                                }
                                // A point no visible tet uses: never drawn.
                                None => 0.0,
                            };
                            depth.min(OPAQUE_DEPTH) as f32
                        })
                        .collect();
                    progress(done.fetch_add(len, Ordering::Relaxed) + len, total);
                    (v, st)
                })
                .collect();
            let mut field = Vec::with_capacity(n);
            for (v, st) in rows {
                field.extend(v);
                stats.add(&st);
            }
            per_light[i] = LightShadow::Vertices(field);
        }
        let key = ShadowKey { lights: *lights, tf: tf.clone(), scalar_range: reference.scalar_range(), num_points: n };
        Ok(ShadowField { key, per_light, frame_origin_in_world: DVec3::ZERO, stats })
    }

    pub fn key(&self) -> &ShadowKey {
        &self.key
    }

    /// The walks' counts (one ray per vertex and light).
    pub fn stats(&self) -> &ReferenceStats {
        &self.stats
    }

    /// Optical depth from vertex `v` to light `i` (0 for a light without a
    /// per-vertex field). Renderers interpolate the depth inside a tet and
    /// take exp(−depth): exact where the depth is linear (a uniform medium),
    /// and never a transmittance above the vertices'.
    #[inline]
    pub fn depth_at(&self, light: usize, v: u32) -> f32 {
        match self.per_light.get(light) {
            Some(LightShadow::Vertices(f)) => f.get(v as usize).copied().unwrap_or(0.0),
            _ => 0.0,
        }
    }

    /// Transmittance from vertex `v` to light `i` (per-vertex lights):
    /// exp(−depth).
    pub fn at(&self, light: usize, v: u32) -> f32 {
        (-self.depth_at(light, v)).exp()
    }

    /// Optical depth from the light to `pos_in_world`, for lights held as a
    /// deep shadow map (`None` for the others: interpolate
    /// [`ShadowField::depth_at`] instead).
    #[inline]
    pub fn map_depth_at(&self, light: usize, pos_in_world: DVec3) -> Option<f64> {
        match self.per_light.get(light) {
            Some(LightShadow::Map(m)) => Some(m.depth_at(pos_in_world - self.frame_origin_in_world)),
            _ => None,
        }
    }

    /// Light `i`'s deep shadow map, if its shadow is held as one.
    pub fn map(&self, light: usize) -> Option<&DeepShadowMap> {
        match self.per_light.get(light) {
            Some(LightShadow::Map(m)) => Some(m),
            _ => None,
        }
    }

    /// Whether any light's shadow is held per vertex (a point light inside
    /// or beside the mesh's box).
    pub fn has_vertex_lights(&self) -> bool {
        self.per_light.iter().any(|f| matches!(f, LightShadow::Vertices(_)))
    }

    /// Where the frame the maps were walked in has its origin, in world
    /// coordinates (a map lookup's position is relative to it).
    pub fn frame_origin_in_world(&self) -> DVec3 {
        self.frame_origin_in_world
    }

    /// Whether light `i` has a shadow (of either kind).
    pub fn has_light(&self, light: usize) -> bool {
        self.per_light.get(light).is_some_and(|f| !matches!(f, LightShadow::None))
    }

    /// Whether any light's shadow is a map (renderers then need every
    /// sample's position).
    pub fn has_maps(&self) -> bool {
        self.per_light.iter().any(|f| matches!(f, LightShadow::Map(_)))
    }

    /// Number of lights (with or without shadows).
    pub fn num_lights(&self) -> usize {
        self.per_light.len()
    }

    /// Bytes held.
    pub fn memory_bytes(&self) -> usize {
        self.per_light
            .iter()
            .map(|f| match f {
                LightShadow::None => 0,
                LightShadow::Vertices(v) => v.len() * 4,
                LightShadow::Map(m) => m.memory_bytes(),
            })
            .sum()
    }
}

/// Reusable buffers of shadow rays.
#[derive(Debug, Default)]
pub struct ShadowScratch {
    pub(crate) entries: Vec<crate::reference::Entry>,
    pub(crate) breakpoints: Vec<f64>,
}

impl ReferenceRenderer<'_> {
    /// [`ReferenceRenderer::depth_to_light`] from `from`, a point strictly
    /// inside `tet` with scalar `s_from`: the walk starts there and covers
    /// only the tets towards the light. With `near_vertex`, `from` stands
    /// for that vertex of `tet` approached from inside the tet: the depth
    /// is the limit there (a vertex on a lit boundary face sees 1 however
    /// dense the medium).
    #[allow(clippy::too_many_arguments)]
    pub fn depth_to_light_from(
        &self,
        from: DVec3,
        tet: usize,
        s_from: f64,
        near_vertex: Option<u32>,
        light: &LightSource,
        tf: &TransferFunction,
        scratch: &mut ShadowScratch,
        stats: &mut ReferenceStats,
    ) -> f64 {
        self.depth_along(from, Some((tet, s_from, near_vertex)), light, tf, scratch, stats)
    }

    /// Optical depth from `from` (world) to `light` through the mesh:
    /// exact walk, exact depth per segment; stops once the depth reaches
    /// [`OPAQUE_DEPTH`]. 0 where the light has no direction from `from`.
    pub fn depth_to_light(
        &self,
        from: DVec3,
        light: &LightSource,
        tf: &TransferFunction,
        scratch: &mut ShadowScratch,
        stats: &mut ReferenceStats,
    ) -> f64 {
        self.depth_along(from, None, light, tf, scratch, stats)
    }

    /// The optical depth from `from` to `light`: walked from `inside` (a
    /// tet holding `from`, the scalar there, and the vertex `from` stands
    /// for) or, without it, from the boundary entries of the whole line.
    fn depth_along(
        &self,
        from: DVec3,
        inside: Option<(usize, f64, Option<u32>)>,
        light: &LightSource,
        tf: &TransferFunction,
        scratch: &mut ShadowScratch,
        stats: &mut ReferenceStats,
    ) -> f64 {
        // The headlight's direction depends on the view: it casts none.
        if !light.casts_shadow() {
            return 0.0;
        }
        let Some((to_light, dist)) = light.towards(from, DVec3::Z) else { return 0.0 };
        let Some(line) = Line::through(from, from + to_light) else { return 0.0 };
        let mut depth = 0.0;
        let breakpoints = &mut scratch.breakpoints;
        stats.rays += 1;
        // Started a hair from a vertex: while the ray leaves tets by faces
        // holding that vertex it is still circling it, and those segments
        // vanish in the limit of starting at the vertex.
        let mut circling = inside.and_then(|(_, _, v)| v);
        let mut visit = |seg: &crate::reference::LineSegment| {
            if let Some(v) = circling {
                if seg.back.ids.contains(&v) {
                    return false;
                }
                circling = None;
            }
            accumulate_depth(seg, dist, tf, breakpoints, &mut depth)
        };
        match inside {
            Some((tet, s_from, _)) => {
                self.walk_line_from_inside(&line, (tet, s_from), &mut scratch.entries, stats, &mut visit)
            }
            None => self.walk_line(&line, 0.0, &mut scratch.entries, stats, &mut visit),
        }
        depth
    }
}

/// Adds a shadow ray's segment (up to the light at `dist`) to `depth`;
/// true once the ray is done (past the light, or opaque).
fn accumulate_depth(
    seg: &crate::reference::LineSegment,
    dist: f64,
    tf: &TransferFunction,
    breakpoints: &mut Vec<f64>,
    depth: &mut f64,
) -> bool {
    if seg.t_front >= dist {
        return true;
    }
    let t_back = seg.back.t.min(dist);
    let s_back =
        if t_back < seg.back.t { seg.front.s + (seg.back.s - seg.front.s) * seg.frac(t_back) } else { seg.back.s };
    *depth += optical_depth_with(tf, seg.s_front(), s_back, t_back - seg.t_front, breakpoints);
    *depth >= OPAQUE_DEPTH || t_back >= dist
}

impl crate::Scene {
    /// The shadow field of this scene for `tf` (scalar units) and `lights`
    /// (world coordinates): the walks run on the scene's centred positions
    /// (point lights moved the same way), so a mesh far from the origin
    /// keeps its precision. `progress(done, total)` counts vertices.
    pub fn compute_shadows(
        &self,
        tf: &TransferFunction,
        lights: &LightSet,
        progress: &(dyn Fn(usize, usize) + Sync),
    ) -> Result<ShadowField, RenderError> {
        let centre = self.centre_in_world();
        let mesh = tet_mesh::TetMesh {
            points: self.positions_rel().to_vec(),
            tets: self.tets().to_vec(),
            scalar_name: String::new(),
            scalar: self.scalar().to_vec(),
            point_fields: Vec::new(),
        };
        let neighbors = self.neighbors().to_vec();
        let boundary_faces = neighbors
            .iter()
            .enumerate()
            .flat_map(|(t, nb)| {
                (0..4).filter(move |&f| nb[f] == tet_mesh::NO_NEIGHBOR).map(move |f| (4 * t + f) as u32)
            })
            .collect();
        let adjacency = tet_mesh::Adjacency { neighbors, boundary_faces, convex: self.is_convex() };
        let reference = ReferenceRenderer::new(&mesh, &adjacency)?;
        let moved: Vec<LightSource> = lights
            .lights()
            .iter()
            .map(|l| match *l {
                LightSource::Point { position, intensity } => {
                    LightSource::Point { position: (DVec3::from(position) - centre).into(), intensity }
                }
                other => other,
            })
            .collect();
        let mut field = ShadowField::compute(&reference, tf, &LightSet::new(&moved)?, progress)?;
        field.key.lights = *lights;
        field.frame_origin_in_world = centre;
        Ok(field)
    }
}
