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
//!   each walked through the mesh, its depth kept at every tet crossing,
//!   TF node and 0.05 of depth between, looked up by position (linear
//!   between knots; across rays bilinear, bicubic where the four nearest
//!   rays differ by more than [`CUBIC_ABOVE`]). Its
//!   resolution is the grid's, not the mesh's: a shadow edge inside a
//!   large cell stays sharp to a ray spacing. Around cells whose depths
//!   are too rough for the bicubic lookup ([`REFINE_ABOVE`]) the rays
//!   halfway between are walked too (a fine grid), around the fine
//!   grid's rough cells ([`REFINE_FINER_ABOVE`]) the rays halfway between
//!   those, and so on up to [`MAX_LEVELS`] finer grids (their tables of
//!   rays kept by tiles of [`LEVEL_TILE`]² positions, only around the
//!   rays added), and lookups read the finest grid whose rays surround
//!   the point.
//! * **Point lights outside the mesh's bounding box: a deep shadow map**
//!   of rays fanning out from the light over the mesh (looked up by
//!   direction from the light and distance; refined alike).
//! * **Other point lights (inside the mesh or beside its box): a cube of
//!   six such maps** around the light ([`DeepShadowMap`]s of [`CUBE_RAYS`]²
//!   rays each over slopes in [−1, 1]² along ±x, ±y, ±z), each ray walked
//!   from the light outwards; a point is looked up in the face its largest
//!   coordinate relative to the light points into. A point at the light
//!   sees 1.
//!
//! The reference instead casts a shadow ray at every integration node
//! ([`ShadowMode::Exact`]), or reads this field ([`ShadowMode::Field`]) so
//! that the field's error and the lighting's are measured apart.
//!
//! The field depends on the mesh, the TF and the lights, not on the
//! camera: a camera move reuses it ([`ShadowKey`] says what it was made
//! for). Self-shadowing needs no bias: a map's rays keep the depth at
//! every crossing and a point reads it at its own distance along the
//! light, so a thin sheet shadows only what lies behind it (no acne).
//! Depths stop at [`OPAQUE_DEPTH`] (transmittance 1e-20) along exact
//! shadow rays and at [`MAP_OPAQUE_DEPTH`] (1.1e-7) in maps, never NaN or
//! infinite.

use glam::DVec3;
use tet_preint::{optical_depth_with, TransferFunction};

use crate::reference::{Line, ReferenceRenderer, ReferenceStats};
use crate::shading::{LightSet, LightSource};
use crate::RenderError;

mod map;

pub use map::{
    catmull_rom, cube_face, DeepShadowMap, MapLayout, CUBE_RAYS, CUBIC_ABOVE, LEVELS_BUDGET_BYTES, LEVEL_TILE,
    MAP_OPAQUE_DEPTH, MAP_RAYS, MAX_LEVELS, NO_RAY, REFINE_ABOVE, REFINE_FINER_ABOVE, SHORT_RAY,
};

/// Optical depth at which a shadow walk stops: transmittance below
/// e^−46 ≈ 1e-20 changes no pixel (what is stored is the transmittance so
/// far, ≤ 1e-20; past e^−746 it is 0).
pub const OPAQUE_DEPTH: f64 = 46.0;

/// How a renderer obtains shadow transmittances.
#[derive(Debug, Clone, Copy)]
pub enum ShadowMode<'a> {
    /// An exact shadow ray from every sample point (the reference only).
    Exact,
    /// The shadow field's maps, looked up at every sample point.
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
    /// A deep shadow map: directional lights, point lights outside the box.
    Map(Box<DeepShadowMap>),
    /// A cube of six maps around a point light inside or beside the box.
    Cube(Box<[DeepShadowMap; 6]>),
}

/// Each light's optical depth through the volume: a light-space deep shadow
/// map (directional lights, point lights outside the mesh's box) or a cube
/// of them (point lights inside or beside it).
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
    /// Each shadow-casting light of `lights` as a map or a cube of maps,
    /// their rays walked through `reference`'s mesh with `tf` (in scalar
    /// units, not normalized), in parallel; the result does not depend on
    /// the thread count. `progress(done, total)` counts lights.
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
        let n = reference.points().len();
        let casting: Vec<usize> =
            lights.lights().iter().enumerate().filter(|(_, l)| l.casts_shadow()).map(|(i, _)| i).collect();
        let total = casting.len();
        let mut per_light = vec![LightShadow::None; lights.lights().len()];
        let mut stats = ReferenceStats::default();
        for (done, &i) in casting.iter().enumerate() {
            per_light[i] = match lights.lights()[i] {
                LightSource::Directional { direction, .. } => {
                    let d = DVec3::from(direction).normalize();
                    LightShadow::Map(Box::new(DeepShadowMap::build(reference, d, tf, &mut stats)))
                }
                LightSource::Point { position, .. } => {
                    let p = DVec3::from(position);
                    match DeepShadowMap::build_point(reference, p, tf, &mut stats) {
                        Some(m) => LightShadow::Map(Box::new(m)),
                        None => match DeepShadowMap::build_cube(reference, p, tf, &mut stats) {
                            Some(c) => LightShadow::Cube(c),
                            None => {
                                return Err(RenderError::Scene(format!("point light at {position:?} is not finite")))
                            }
                        },
                    }
                }
                LightSource::Headlight { .. } => LightShadow::None,
            };
            progress(done + 1, total);
        }
        let key = ShadowKey { lights: *lights, tf: tf.clone(), scalar_range: reference.scalar_range(), num_points: n };
        Ok(ShadowField { key, per_light, frame_origin_in_world: DVec3::ZERO, stats })
    }

    pub fn key(&self) -> &ShadowKey {
        &self.key
    }

    /// Whether this field holds for `lights` and `tf` over a scene of
    /// scalar range `scalar_range` (else it must be computed again).
    pub fn is_for(&self, lights: &LightSet, tf: &TransferFunction, scalar_range: [f64; 2]) -> bool {
        self.key.lights == *lights && self.key.tf == *tf && self.key.scalar_range == scalar_range
    }

    /// The walks' counts (every map ray).
    pub fn stats(&self) -> &ReferenceStats {
        &self.stats
    }

    /// Optical depth from light `light` to `pos_in_world` (0 for a light
    /// that casts no shadow).
    #[inline]
    pub fn depth_at(&self, light: usize, pos_in_world: DVec3) -> f64 {
        let p = pos_in_world - self.frame_origin_in_world;
        match self.per_light.get(light) {
            Some(LightShadow::Map(m)) => m.depth_at(p),
            Some(LightShadow::Cube(faces)) => {
                let q = p - faces[0].origin().expect("a cube's faces fan out from the light");
                if q == DVec3::ZERO {
                    return 0.0;
                }
                faces[map::cube_face(q)].depth_at(p)
            }
            _ => 0.0,
        }
    }

    /// Light `i`'s deep shadow map, if its shadow is held as one.
    pub fn map(&self, light: usize) -> Option<&DeepShadowMap> {
        match self.per_light.get(light) {
            Some(LightShadow::Map(m)) => Some(m),
            _ => None,
        }
    }

    /// Light `i`'s cube of maps (faces in the order of
    /// [`shadow::cube_face`](cube_face)'s index), if its shadow is held as one.
    pub fn cube(&self, light: usize) -> Option<&[DeepShadowMap; 6]> {
        match self.per_light.get(light) {
            Some(LightShadow::Cube(faces)) => Some(faces),
            _ => None,
        }
    }

    /// Whether any light's shadow is a cube of maps (a point light inside
    /// or beside the mesh's box).
    pub fn has_cube_lights(&self) -> bool {
        self.per_light.iter().any(|f| matches!(f, LightShadow::Cube(_)))
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
        self.per_light.iter().any(|f| !matches!(f, LightShadow::None))
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
                LightShadow::Map(m) => m.memory_bytes(),
                LightShadow::Cube(faces) => faces.iter().map(DeepShadowMap::memory_bytes).sum(),
            })
            .sum()
    }
}

/// Reusable buffers of shadow rays.
#[derive(Debug, Default)]
pub struct ShadowScratch {
    pub(crate) entries: Vec<crate::reference::Entry>,
    pub(crate) breakpoints: Vec<f64>,
    /// A segment's extinction knots (`TransferFunction::extinction_knots`).
    pub(crate) extinction: Vec<[f64; 2]>,
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
            accumulate_depth(seg, dist, tf, breakpoints, &mut depth)
        });
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
            tets: self.tets().to_vec().into(),
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
        let adjacency = tet_mesh::Adjacency { neighbors: neighbors.into(), boundary_faces, convex: self.is_convex() };
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
