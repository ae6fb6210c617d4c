//! Optional per-fragment shading (off by default): Blinn–Phong lighting with
//! the interpolated per-vertex gradient as the normal, modulating emission,
//! and silhouette enhancement α·(1 − |ĝ·v|)^p (Song et al. 2009 §6). The light is a
//! headlight (at the eye), so the half vector is the view vector and the
//! lighting is two-sided: a gradient's sign does not say which side is out.

use glam::DVec3;
use serde::{Deserialize, Serialize};

/// Blinn–Phong coefficients; colour becomes C·(ambient + diffuse·|n·l|) +
/// specular·|n·h|^shininess·α (white highlight, premultiplied).
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct Light {
    pub ambient: f32,
    pub diffuse: f32,
    pub specular: f32,
    pub shininess: f32,
}

impl Default for Light {
    fn default() -> Self {
        Light { ambient: 0.3, diffuse: 0.7, specular: 0.2, shininess: 20.0 }
    }
}

/// What shading to apply; `Shading::default()` applies none.
#[derive(Debug, Clone, Copy, PartialEq, Default, Serialize, Deserialize)]
pub struct Shading {
    pub light: Option<Light>,
    /// Silhouette exponent p: opacity and colour scaled by (1 − |ĝ·v|)^p.
    pub silhouette: Option<f32>,
}

impl Shading {
    /// Whether any shading is on (then the scene needs gradients).
    pub fn is_active(&self) -> bool {
        self.light.is_some() || self.silhouette.is_some()
    }

    /// Modulates premultiplied `rgba` for gradient `grad` (any length, world
    /// frame) seen along unit `view_dir` (eye towards the sample). A zero or
    /// non-finite gradient has no direction: the sample is left unchanged.
    pub fn apply(&self, rgba: [f32; 4], grad: DVec3, view_dir: DVec3) -> [f32; 4] {
        let len = grad.length();
        if !(len > 0.0 && len.is_finite()) {
            return rgba;
        }
        let n_dot_v = (grad.dot(view_dir) / len).abs().min(1.0) as f32;
        let mut out = rgba;
        if let Some(l) = self.light {
            let diffuse = l.ambient + l.diffuse * n_dot_v;
            let spec = l.specular * n_dot_v.powf(l.shininess) * rgba[3];
            for c in &mut out[..3] {
                *c = *c * diffuse + spec;
            }
        }
        if let Some(p) = self.silhouette {
            let k = (1.0 - n_dot_v).max(0.0).powf(p);
            for c in &mut out {
                *c *= k;
            }
        }
        out
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn off_by_default_and_silhouette_fades_facing_surfaces() {
        let s = Shading::default();
        assert!(!s.is_active());
        let px = [0.2, 0.1, 0.0, 0.5];
        assert_eq!(s.apply(px, DVec3::Z, DVec3::Z), px);
        let s = Shading { light: None, silhouette: Some(2.0) };
        // Gradient along the view: face-on, fully faded; across it: kept.
        assert_eq!(s.apply(px, DVec3::Z, DVec3::Z), [0.0; 4]);
        assert_eq!(s.apply(px, DVec3::X, DVec3::Z), px);
        assert_eq!(s.apply(px, DVec3::ZERO, DVec3::Z), px);
    }

    #[test]
    fn headlight_is_two_sided() {
        let s = Shading { light: Some(Light::default()), silhouette: None };
        let a = s.apply([0.5, 0.5, 0.5, 0.5], DVec3::Z, DVec3::Z);
        let b = s.apply([0.5, 0.5, 0.5, 0.5], -DVec3::Z, DVec3::Z);
        assert_eq!(a, b);
        assert!((a[0] - (0.5 * 1.0 + 0.2 * 0.5)).abs() < 1e-6);
        assert_eq!(a[3], 0.5);
    }
}
