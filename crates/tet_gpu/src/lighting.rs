//! `tet_render::Shading` as the GPU's [`LightParams`] (lighting.wgsl):
//! the material, up to 8 lights in the GPU's frame (point lights relative
//! to the mesh centre), silhouettes, the gradient floor and the split rule
//! of `tet_render::shading::light_segment`; and shadows: each
//! shadow-casting light's deep shadow map (`tet_render::ShadowField`'s maps:
//! directional lights, point lights outside the mesh's box) as
//! [`ShadowMaps`], looked up in lighting.wgsl as `DeepShadowMap::depth_at`
//! looks it up, in f32; a point light inside or beside the box has a cube
//! of six maps, read in the face `tet_render::shadow::cube_face` picks.

use glam::DVec3;
use tet_render::shading::{LIT_MAX_PIECES, LIT_MAX_SUBPIECES, LIT_RESPLIT_TOLERANCE, LIT_SPLIT_TOLERANCE};
use tet_render::shadow::NO_RAY;
use tet_render::{LightSource, Shading, ShadowField};

use crate::gpu_types::{
    GpuLight, GpuShadowMap, LightParams, LIGHT_DIRECTIONAL, LIGHT_HEADLIGHT, LIGHT_POINT, MAX_GPU_LIGHTS, SHADOW_BINS,
    SHADOW_LEVELS, SHADOW_LEVEL_TILE, SHADOW_SHORT_RAY, SHADOW_SLOTS,
};
use crate::GpuError;

/// Every light's shadow for the GPU: [`SHADOW_SLOTS`] [`GpuShadowMap`]
/// slots a light (its map in the first, or a cube's six faces; inactive
/// for lights without one), and the maps' knots and ray index concatenated.
/// Each value made by [`ShadowMaps::new`] has its own id (kept by clones),
/// so a renderer uploads it once however many frames it lights.
#[derive(Debug, Clone, PartialEq)]
pub struct ShadowMaps {
    pub(crate) maps: [GpuShadowMap; SHADOW_SLOTS * MAX_GPU_LIGHTS],
    pub(crate) knots: Vec<[f32; 2]>,
    pub(crate) index: Vec<u32>,
    /// 0 for [`ShadowMaps::none`] (always the same content).
    pub(crate) id: u64,
}

/// The last id given to a [`ShadowMaps`].
static SHADOW_MAPS_ID: std::sync::atomic::AtomicU64 = std::sync::atomic::AtomicU64::new(0);

impl ShadowMaps {
    /// No shadows: every map inactive (one knot and index entry, so the
    /// buffers are never empty).
    pub fn none() -> ShadowMaps {
        ShadowMaps {
            maps: [bytemuck::Zeroable::zeroed(); SHADOW_SLOTS * MAX_GPU_LIGHTS],
            knots: vec![[0.0; 2]],
            index: vec![0],
            id: 0,
        }
    }

    /// `field`'s maps (a cube's six faces for a point light inside or
    /// beside the box) in the frame of a scene whose positions are relative
    /// to `centre_in_world`. A map too large for u32 offsets or not finite
    /// in f32 is [`GpuError::Input`].
    pub fn new(field: &ShadowField, centre_in_world: DVec3) -> Result<ShadowMaps, GpuError> {
        if field.num_lights() > MAX_GPU_LIGHTS {
            return Err(GpuError::Input(format!("{} lights, at most {MAX_GPU_LIGHTS}", field.num_lights())));
        }
        let mut out = ShadowMaps::none();
        out.id = SHADOW_MAPS_ID.fetch_add(1, std::sync::atomic::Ordering::Relaxed) + 1;
        out.knots.clear();
        out.index.clear();
        // The map's frame is `field`'s; the GPU's positions are relative to
        // `centre_in_world`: p_map = p_gpu + off.
        let off = centre_in_world - field.frame_origin_in_world();
        for i in 0..field.num_lights() {
            let maps: Vec<&tet_render::shadow::DeepShadowMap> = match (field.map(i), field.cube(i)) {
                (Some(m), _) => vec![m],
                (None, Some(faces)) => faces.iter().collect(),
                (None, None) => continue,
            };
            for (k, map) in maps.iter().enumerate() {
                let slot = out.add(map, off, i)?;
                out.maps[SHADOW_SLOTS * i + k] = slot;
            }
            out.maps[SHADOW_SLOTS * i].cube = u32::from(maps.len() == 6);
        }
        if out.knots.is_empty() {
            out.knots.push([0.0; 2]);
        }
        if out.index.is_empty() {
            out.index.push(0);
        }
        Ok(out)
    }

    /// Appends `map`'s knots and index (light `light`'s, moved by `off`
    /// into the GPU's frame) and returns its slot.
    fn add(
        &mut self,
        map: &tet_render::shadow::DeepShadowMap,
        off: DVec3,
        light: usize,
    ) -> Result<GpuShadowMap, GpuError> {
        let m = map.layout();
        if m.bins != SHADOW_BINS
            || m.short_ray != SHADOW_SHORT_RAY
            || m.tile != SHADOW_LEVEL_TILE
            || m.levels.len() > SHADOW_LEVELS
        {
            return Err(GpuError::Input(format!(
                "a shadow map of {} bins scanning rays of up to {} knots whole, {} finer grids in tiles of {} \
                 positions a side; the GPU reads {SHADOW_BINS} and {SHADOW_SHORT_RAY}, up to {SHADOW_LEVELS} grids \
                 in tiles of {SHADOW_LEVEL_TILE}",
                m.bins,
                m.short_ray,
                m.levels.len(),
                m.tile
            )));
        }
        let (knot_base, index_base) = (self.knots.len(), self.index.len());
        // Each finer grid's table after the index, one after the other.
        let mut level_base = [NO_RAY; SHADOW_LEVELS];
        let mut end = index_base + m.index.len();
        for (base, table) in level_base.iter_mut().zip(&m.levels) {
            *base = end.min(NO_RAY as usize) as u32;
            end += table.len();
        }
        if knot_base + m.knots.len() > u32::MAX as usize || end >= NO_RAY as usize {
            return Err(GpuError::Input("shadow maps beyond 2³² knots".into()));
        }
        // Parallel rays read p·e1, p·e2, p·d − t0 of the map's frame: the
        // offset folds into the first ray's coordinates and t0. A fan's
        // origin moves into the GPU's frame instead.
        let (u0, v0, t0, origin) = match m.origin {
            None => (m.u0 - off.dot(m.e1), m.v0 - off.dot(m.e2), m.t0 - off.dot(m.d), [0.0; 4]),
            Some(o) => {
                let o = (o - off).as_vec3();
                (m.u0, m.v0, m.t0, [o.x, o.y, o.z, 1.0])
            }
        };
        let v3 = |v: DVec3| {
            let v = v.as_vec3();
            [v.x, v.y, v.z, 0.0]
        };
        let slot = GpuShadowMap {
            e1: v3(m.e1),
            e2: v3(m.e2),
            d: v3(m.d),
            origin,
            u0: u0 as f32,
            v0: v0 as f32,
            t0: t0 as f32,
            du: m.du as f32,
            dv: m.dv as f32,
            bin_len: m.bin_len,
            nu: m.nu as u32,
            nv: m.nv as u32,
            knot_base: knot_base as u32,
            index_base: index_base as u32,
            has_map: 1,
            cube: 0,
            fine_base: level_base[0],
            finer_base: level_base[1],
            finest_base: level_base[2],
            _pad2: 0,
        };
        let floats = [slot.u0, slot.v0, slot.t0, slot.du, slot.dv, slot.bin_len];
        if !floats.iter().chain(&slot.origin).all(|x| x.is_finite()) || m.nu < 2 || m.nv < 2 {
            return Err(GpuError::Input(format!("light {light}'s shadow map is not representable in f32")));
        }
        self.knots.extend_from_slice(m.knots);
        self.index.extend_from_slice(&m.index);
        for table in &m.levels {
            self.index.extend_from_slice(table);
        }
        Ok(slot)
    }
}

/// The GPU's lighting parameters for `shading` in a scene whose positions
/// are relative to `centre_in_world` (`GpuScene::centre_in_world`).
/// Unshaded (`Shading::default()`): `enabled` 0 (shadows come separately,
/// [`ShadowMaps`]). A non-finite material, silhouette exponent or gradient floor, or a
/// point light too far for f32 relative to the centre, [`GpuError::Input`].
pub fn light_params(shading: &Shading, centre_in_world: DVec3) -> Result<LightParams, GpuError> {
    let mut p = LightParams {
        split_tolerance: LIT_SPLIT_TOLERANCE as f32,
        max_pieces: LIT_MAX_PIECES as u32,
        resplit_tolerance: LIT_RESPLIT_TOLERANCE as f32,
        max_subpieces: LIT_MAX_SUBPIECES as u32,
        subpiece_budget: tet_preint::BATCH as u32,
        ..bytemuck::Zeroable::zeroed()
    };
    if !shading.is_active() {
        return Ok(p);
    }
    let finite = |what: &str, x: f32| {
        if x.is_finite() {
            Ok(x)
        } else {
            Err(GpuError::Input(format!("shading: {what} {x} is not finite")))
        }
    };
    p.enabled = 1;
    p.gradient_floor = finite("gradient floor", shading.gradient_floor)?.max(0.0);
    if let Some(e) = shading.silhouette {
        p.silhouette = 1;
        p.silhouette_exp = finite("silhouette exponent", e)?;
    }
    if let Some(m) = shading.light {
        p.lit = 1;
        p.ambient = finite("ambient", m.ambient)?;
        p.diffuse = finite("diffuse", m.diffuse)?;
        p.specular = finite("specular", m.specular)?;
        p.shininess = finite("shininess", m.shininess)?;
        let lights = shading.sources.lights();
        if lights.len() > MAX_GPU_LIGHTS {
            return Err(GpuError::Input(format!("{} lights, at most {MAX_GPU_LIGHTS}", lights.len())));
        }
        for (slot, l) in p.lights.iter_mut().zip(lights) {
            let intensity = finite("light intensity", l.intensity() as f32)?;
            let (kind, v) = match *l {
                LightSource::Headlight { .. } => (LIGHT_HEADLIGHT, DVec3::ZERO),
                // A LightSet keeps unit directions; others are normalized here.
                LightSource::Directional { direction, .. } => (LIGHT_DIRECTIONAL, DVec3::from(direction).normalize()),
                LightSource::Point { position, .. } => (LIGHT_POINT, DVec3::from(position) - centre_in_world),
            };
            let v = v.as_vec3();
            if !v.is_finite() {
                return Err(GpuError::Input(format!("light {v:?}: not finite in f32 about the mesh centre")));
            }
            *slot = GpuLight { v: [v.x, v.y, v.z, intensity], kind, ..bytemuck::Zeroable::zeroed() };
        }
        p.n_lights = lights.len() as u32;
    }
    Ok(p)
}

#[cfg(test)]
mod tests {
    use super::*;
    use tet_render::{Light, LightSet};

    #[test]
    fn unshaded_is_inactive_and_lights_are_in_the_gpu_frame() {
        let p = light_params(&Shading::default(), DVec3::ONE).unwrap();
        assert_eq!(p.enabled, 0);
        let sources = LightSet::new(&[
            LightSource::Headlight { intensity: 0.5 },
            LightSource::Directional { direction: [0.0, 0.0, -2.0], intensity: 1.0 },
            LightSource::Point { position: [3.0, 1.0, 1.0], intensity: 2.0 },
        ])
        .unwrap();
        let s = Shading {
            light: Some(Light::default()),
            silhouette: Some(2.0),
            sources,
            gradient_floor: 0.25,
            ..Default::default()
        };
        let p = light_params(&s, DVec3::ONE).unwrap();
        assert_eq!((p.enabled, p.lit, p.silhouette, p.n_lights), (1, 1, 1, 3));
        assert_eq!((p.ambient, p.diffuse, p.specular, p.shininess), (0.3, 0.7, 0.2, 20.0));
        assert_eq!((p.silhouette_exp, p.gradient_floor), (2.0, 0.25));
        assert_eq!(p.lights[0].kind, LIGHT_HEADLIGHT);
        assert_eq!(p.lights[0].v[3], 0.5);
        assert_eq!((p.lights[1].kind, p.lights[1].v), (LIGHT_DIRECTIONAL, [0.0, 0.0, -1.0, 1.0]));
        assert_eq!((p.lights[2].kind, p.lights[2].v), (LIGHT_POINT, [2.0, 0.0, 0.0, 2.0]));
        assert_eq!(p.max_pieces as usize, LIT_MAX_PIECES);
        assert_eq!((p.max_subpieces as usize, p.subpiece_budget as usize), (LIT_MAX_SUBPIECES, tet_preint::BATCH));
        // Silhouettes alone: active, unlit.
        let p = light_params(&Shading { silhouette: Some(1.0), ..Default::default() }, DVec3::ZERO).unwrap();
        assert_eq!((p.enabled, p.lit, p.n_lights), (1, 0, 0));
    }

    #[test]
    fn bad_numbers_are_refused() {
        let bad = Shading { light: Some(Light { ambient: f32::NAN, ..Light::default() }), ..Default::default() };
        assert!(matches!(light_params(&bad, DVec3::ZERO), Err(GpuError::Input(_))));
        let far = Shading {
            light: Some(Light::default()),
            sources: LightSet::new(&[LightSource::Point { position: [1e300, 0.0, 0.0], intensity: 1.0 }]).unwrap(),
            ..Default::default()
        };
        assert!(matches!(light_params(&far, DVec3::ZERO), Err(GpuError::Input(_))));
    }
}
