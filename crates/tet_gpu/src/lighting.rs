//! `tet_render::Shading` as the GPU's [`LightParams`] (lighting.wgsl):
//! the material, up to 8 lights in the GPU's frame (point lights relative
//! to the mesh centre), silhouettes, the gradient floor and the split rule
//! of `tet_render::shading::light_segment`. Shadows are not on the GPU.

use glam::DVec3;
use tet_render::shading::{LIT_MAX_PIECES, LIT_SPLIT_TOLERANCE};
use tet_render::{LightSource, Shading};

use crate::gpu_types::{GpuLight, LightParams, LIGHT_DIRECTIONAL, LIGHT_HEADLIGHT, LIGHT_POINT, MAX_GPU_LIGHTS};
use crate::GpuError;

/// Why `shading` cannot be drawn on the GPU (shadows), or `None`.
pub fn unsupported_shading(shading: &Shading) -> Option<&'static str> {
    shading.wants_shadows().then_some("shadows are CPU-only for now (lighting without shadows is on the GPU)")
}

/// The GPU's lighting parameters for `shading` in a scene whose positions
/// are relative to `centre_in_world` (`GpuScene::centre_in_world`).
/// Unshaded (`Shading::default()`): `enabled` 0. Shadows requested (a
/// shadow-casting light with `shadows` on) are [`GpuError::Unsupported`];
/// a non-finite material, silhouette exponent or gradient floor, or a
/// point light too far for f32 relative to the centre, [`GpuError::Input`].
pub fn light_params(shading: &Shading, centre_in_world: DVec3) -> Result<LightParams, GpuError> {
    let mut p = LightParams {
        split_tolerance: LIT_SPLIT_TOLERANCE as f32,
        max_pieces: LIT_MAX_PIECES as u32,
        ..bytemuck::Zeroable::zeroed()
    };
    if !shading.is_active() {
        return Ok(p);
    }
    if let Some(why) = unsupported_shading(shading) {
        return Err(GpuError::Unsupported(why.into()));
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
        // Silhouettes alone: active, unlit.
        let p = light_params(&Shading { silhouette: Some(1.0), ..Default::default() }, DVec3::ZERO).unwrap();
        assert_eq!((p.enabled, p.lit, p.n_lights), (1, 0, 0));
    }

    #[test]
    fn shadows_are_unsupported_and_bad_numbers_refused() {
        let sources =
            LightSet::new(&[LightSource::Directional { direction: [1.0, 0.0, 0.0], intensity: 1.0 }]).unwrap();
        let s = Shading { light: Some(Light::default()), sources, shadows: true, ..Default::default() };
        assert!(unsupported_shading(&s).is_some());
        assert!(matches!(light_params(&s, DVec3::ZERO), Err(GpuError::Unsupported(_))));
        // Shadows on with only the headlight cast none: drawn.
        let head = Shading { light: Some(Light::default()), shadows: true, ..Default::default() };
        assert!(unsupported_shading(&head).is_none());
        assert!(light_params(&head, DVec3::ZERO).is_ok());
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
