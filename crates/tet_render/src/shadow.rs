//! Volumetric shadows: each light's transmittance through the volume.
//!
//! [`ShadowField`] holds, per shadow-casting light and per mesh vertex, the
//! transmittance exp(−∫ρ) from the vertex to the light, found by walking
//! the mesh from the vertex towards the light with the reference's exact
//! walk (exact predicates, so a line through an edge or a vertex is neither
//! lost nor counted twice) and the exact optical depth of each linear
//! piece of the TF ([`tet_preint::optical_depth_with`]). Renderers
//! interpolate it linearly inside each tet, like the gradients: the only
//! approximation is that interpolation (the reference casts a shadow ray
//! at every integration node instead, [`ShadowMode::Exact`]).
//!
//! The field depends on the mesh, the TF and the lights, not on the
//! camera: a camera move reuses it ([`ShadowKey`] says what it was made
//! for). Self-shadowing needs no bias: the walk starts exactly at the
//! vertex and integrates from there, so a thin sheet shadows only what lies
//! behind it (no acne; a vertex on the sheet's lit face sees transmittance
//! 1 in the limit).
//!
//! A light inside the mesh (a point light) ends each walk at the light; a
//! vertex at a point light's position sees transmittance 1. Huge
//! extinction underflows to transmittance 0 (never NaN).

use std::sync::atomic::{AtomicUsize, Ordering};

use glam::DVec3;
use rayon::prelude::*;
use tet_preint::{optical_depth_with, TransferFunction};

use crate::reference::{Line, ReferenceRenderer, ReferenceStats};
use crate::shading::{LightSet, LightSource};
use crate::RenderError;

/// Optical depth beyond which transmittance is 0 in f64 (e^−746 underflows).
pub const OPAQUE_DEPTH: f64 = 746.0;

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
    /// The TF's JSON text (denormalized) — cheap beside the field itself.
    pub tf_json: String,
    /// The scene's scalar range and vertex count, a guard against using a
    /// field with another time step's scalar.
    pub scalar_range: [f64; 2],
    pub num_points: usize,
}

/// Per-vertex transmittance towards each light.
#[derive(Debug, Clone)]
pub struct ShadowField {
    key: ShadowKey,
    /// `per_light[i][v]`: transmittance from vertex v to light i; empty
    /// for lights that cast no shadow (the headlight).
    per_light: Vec<Vec<f32>>,
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
        let points = reference.points();
        let n = points.len();
        // Each vertex's walk starts a hair inside one of its tets (towards
        // that tet's centroid, 1e-7 of the way): the transmittance the
        // tets interpolate is the limit from inside the mesh, also where
        // the light grazes a boundary face through the vertex (there the
        // vertex itself is on the line's perturbed outside).
        let tets = reference.tets();
        let mut owner = vec![u32::MAX; n];
        for (t, tet) in tets.iter().enumerate() {
            for &v in tet {
                if owner[v as usize] == u32::MAX {
                    owner[v as usize] = t as u32;
                }
            }
        }
        let start = |v: usize| -> DVec3 {
            let p = DVec3::from(points[v]);
            match owner[v] {
                u32::MAX => p,
                t => {
                    let c = tets[t as usize].iter().map(|&w| DVec3::from(points[w as usize])).sum::<DVec3>() * 0.25;
                    p + (c - p) * 1e-7
                }
            }
        };
        let casting: Vec<usize> =
            lights.lights().iter().enumerate().filter(|(_, l)| l.casts_shadow()).map(|(i, _)| i).collect();
        let total = n * casting.len();
        let done = AtomicUsize::new(0);
        let mut per_light = vec![Vec::new(); lights.lights().len()];
        let mut stats = ReferenceStats::default();
        for &i in &casting {
            let light = lights.lights()[i];
            let chunks: Vec<std::ops::Range<usize>> = (0..n).step_by(4096).map(|a| a..(a + 4096).min(n)).collect();
            let rows: Vec<(Vec<f32>, ReferenceStats)> = chunks
                .into_par_iter()
                .map_init(ShadowScratch::default, |scratch, range| {
                    let mut st = ReferenceStats::default();
                    let len = range.len();
                    let v = range
                        .map(|v| {
                            let depth = reference.depth_to_light(start(v), &light, tf, scratch, &mut st);
                            (-depth).exp() as f32
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
            per_light[i] = field;
        }
        let key =
            ShadowKey { lights: *lights, tf_json: tf.to_json(), scalar_range: reference.scalar_range(), num_points: n };
        Ok(ShadowField { key, per_light, stats })
    }

    pub fn key(&self) -> &ShadowKey {
        &self.key
    }

    /// The walks' counts (one ray per vertex and light).
    pub fn stats(&self) -> &ReferenceStats {
        &self.stats
    }

    /// Transmittance from vertex `v` to light `i` (1 for a light without a
    /// shadow).
    #[inline]
    pub fn at(&self, light: usize, v: u32) -> f32 {
        self.per_light.get(light).and_then(|f| f.get(v as usize)).copied().unwrap_or(1.0)
    }

    /// Whether light `i` has a field.
    pub fn has_light(&self, light: usize) -> bool {
        self.per_light.get(light).is_some_and(|f| !f.is_empty())
    }

    /// Number of lights (with or without fields).
    pub fn num_lights(&self) -> usize {
        self.per_light.len()
    }

    /// Bytes held.
    pub fn memory_bytes(&self) -> usize {
        self.per_light.iter().map(|f| f.len() * 4).sum()
    }
}

/// Reusable buffers of shadow rays.
#[derive(Debug, Default)]
pub struct ShadowScratch {
    pub(crate) entries: Vec<crate::reference::Entry>,
    pub(crate) breakpoints: Vec<f64>,
}

impl ReferenceRenderer<'_> {
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
        // The headlight's direction depends on the view: it casts none.
        if !light.casts_shadow() {
            return 0.0;
        }
        let Some((to_light, dist)) = light.towards(from, DVec3::Z) else { return 0.0 };
        let Some(line) = Line::through(from, from + to_light) else { return 0.0 };
        let mut depth = 0.0;
        let breakpoints = &mut scratch.breakpoints;
        stats.rays += 1;
        self.walk_line(&line, 0.0, &mut scratch.entries, stats, &mut |seg| {
            if seg.t_front >= dist {
                return true;
            }
            let t_back = seg.back.t.min(dist);
            let s_back = if t_back < seg.back.t {
                seg.front.s + (seg.back.s - seg.front.s) * seg.frac(t_back)
            } else {
                seg.back.s
            };
            depth += optical_depth_with(tf, seg.s_front(), s_back, t_back - seg.t_front, breakpoints);
            depth >= OPAQUE_DEPTH || t_back >= dist
        });
        depth
    }
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
        Ok(field)
    }
}
