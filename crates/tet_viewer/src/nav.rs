//! Mouse navigation on a [`ViewSpec`], as ParaView's default interactor:
//! drag to orbit about the focal point, pan in the view plane, dolly
//! towards the focal point.

use glam::DVec3;
use tet_render::ViewSpec;

/// Degrees of orbit per pixel dragged.
pub const ORBIT_DEG_PER_PX: f64 = 0.4;

/// Orbits by a drag of (dx, dy) pixels: right turns the object right, down
/// tilts it towards the viewer.
pub fn orbit(view: &ViewSpec, dx_px: f64, dy_px: f64) -> ViewSpec {
    view.orbit(-dx_px * ORBIT_DEG_PER_PX, dy_px * ORBIT_DEG_PER_PX, 1.0)
}

/// World units per pixel at the focal plane for an image `height_px` tall.
fn world_per_px(view: &ViewSpec, height_px: f64) -> f64 {
    let h = height_px.max(1.0);
    if view.parallel {
        2.0 * view.parallel_scale / h
    } else {
        let dist = (DVec3::from(view.position) - DVec3::from(view.focal_point)).length();
        2.0 * dist * (0.5 * view.view_angle.to_radians()).tan() / h
    }
}

/// Pans so that the point under the cursor follows a drag of (dx, dy)
/// pixels on a displayed image `height_px` tall.
pub fn pan(view: &ViewSpec, dx_px: f64, dy_px: f64, height_px: f64) -> ViewSpec {
    let pos = DVec3::from(view.position);
    let focal = DVec3::from(view.focal_point);
    let forward = (focal - pos).normalize_or_zero();
    let up = DVec3::from(view.view_up).normalize_or_zero();
    let right = forward.cross(up).normalize_or_zero();
    let up = right.cross(forward);
    let s = world_per_px(view, height_px);
    let shift = (-right * dx_px + up * dy_px) * s;
    let mut out = view.clone();
    out.position = (pos + shift).into();
    out.focal_point = (focal + shift).into();
    out
}

/// Dollies by `factor` (> 1 moves closer; parallel projection scales
/// instead), as VTK's `Dolly`. The camera never reaches the focal point.
pub fn dolly(view: &ViewSpec, factor: f64) -> ViewSpec {
    if !(factor > 0.0 && factor.is_finite()) {
        return view.clone();
    }
    let mut out = view.clone();
    if view.parallel {
        out.parallel_scale /= factor;
    } else {
        let focal = DVec3::from(view.focal_point);
        let pos = DVec3::from(view.position);
        out.position = (focal + (pos - focal) / factor).into();
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn pan_moves_focal_point_and_position_together_and_dolly_keeps_direction() {
        let v = ViewSpec::framing([0.0; 3], [1.0; 3], [100, 100]);
        let p = pan(&v, 10.0, 0.0, 100.0);
        let d0 = DVec3::from(v.position) - DVec3::from(v.focal_point);
        let d1 = DVec3::from(p.position) - DVec3::from(p.focal_point);
        assert!((d0 - d1).length() < 1e-12);
        // Dragging right moves the camera left (−x looking down −z).
        assert!(p.focal_point[0] < v.focal_point[0]);
        let d = dolly(&v, 2.0);
        let d2 = DVec3::from(d.position) - DVec3::from(d.focal_point);
        assert!((d2.length() - d0.length() / 2.0).abs() < 1e-12);
        assert!(d2.normalize().dot(d0.normalize()) > 1.0 - 1e-12);
        let o = orbit(&v, 0.0, 0.0);
        assert_eq!(o.position, v.position);
    }
}
