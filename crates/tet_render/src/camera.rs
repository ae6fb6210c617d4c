//! A camera with VTK's semantics, so a view set here can be set in
//! ParaView/VTK and back: position, focal point, view-up, vertical view
//! angle in degrees, parallel projection with a parallel scale (half the
//! viewport height in world units), and the image size.
//!
//! Pixel conventions: pixel (i, j) covers x ∈ [i, i+1), y ∈ [j, j+1) in
//! pixel coordinates with row 0 at the top; its centre is (i+½, j+½).
//! `depth` is the distance along the view direction from the eye (positive
//! in front), which is what visibility ordering and near-plane clipping use.

use crate::RenderError;
use glam::{DMat3, DQuat, DVec3};
use serde::{Deserialize, Serialize};

/// Largest image side accepted; far beyond any display, small enough that
/// `width * height * 16` bytes cannot overflow or exhaust memory silently.
pub const MAX_IMAGE_SIDE: u32 = 16384;

fn default_view_angle() -> f64 {
    30.0
}
fn default_parallel_scale() -> f64 {
    1.0
}

/// VTK's default view-up.
pub const Y_UP: [f64; 3] = [0.0, 1.0, 0.0];
/// The view-up of point clouds and terrain (see [`z_up_data`]).
pub const Z_UP: [f64; 3] = [0.0, 0.0, 1.0];
/// How far above the horizon the default view of z-up data looks from, in
/// degrees: a side view of flat terrain would show only its edge.
pub const Z_UP_ELEVATION_DEG: f64 = 30.0;

/// Whether data is z-up by the documented rule: it came from a point cloud
/// (a bundle whose tets are a Delaunay or layered tetrahedralization of
/// points: LAS/LAZ, PLY, CSV/XYZ, OBJ, glTF), or its bounds are flat in z
/// (the z extent is under a fifth of the smaller of the x and y extents:
/// terrain, seabeds, strata). Everything else keeps VTK's +y up.
pub fn z_up_data(from_point_cloud: bool, bounds_min: [f64; 3], bounds_max: [f64; 3]) -> bool {
    let extent = |k: usize| bounds_max[k] - bounds_min[k];
    let (dx, dy, dz) = (extent(0), extent(1), extent(2));
    let flat = dx.is_finite() && dy.is_finite() && dz >= 0.0 && dz < 0.2 * dx.min(dy);
    from_point_cloud || flat
}

/// [`z_up_data`] for a bundle: its `split` records a point-cloud source
/// (`delaunay` or `layered`), its statistics the bounds.
pub fn bundle_is_z_up(meta: &tet_bundle::BundleMeta) -> bool {
    let from_point_cloud = matches!(meta.split.as_str(), "delaunay" | "layered");
    z_up_data(from_point_cloud, meta.stats.bounds_min, meta.stats.bounds_max)
}

/// The view file (`--view view.json`), field names as in VTK's vtkCamera.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct ViewSpec {
    pub position: [f64; 3],
    pub focal_point: [f64; 3],
    pub view_up: [f64; 3],
    /// Vertical view angle in degrees (VTK's default 30).
    #[serde(default = "default_view_angle")]
    pub view_angle: f64,
    #[serde(default)]
    pub parallel: bool,
    /// Half the viewport height in world units, for parallel projection.
    #[serde(default = "default_parallel_scale")]
    pub parallel_scale: f64,
    /// Image width and height in pixels.
    pub size: [u32; 2],
}

impl ViewSpec {
    /// Parses a view file. Its `"lighting"` object, if any, belongs to
    /// [`crate::shading::Lighting::from_view_json`] and is skipped here.
    pub fn from_json(text: &str) -> Result<ViewSpec, RenderError> {
        let mut v: serde_json::Value = serde_json::from_str(text).map_err(|e| RenderError::View(e.to_string()))?;
        if let Some(o) = v.as_object_mut() {
            o.remove("lighting");
        }
        serde_json::from_value(v).map_err(|e| RenderError::View(e.to_string()))
    }

    pub fn to_json(&self) -> String {
        serde_json::to_string_pretty(self).expect("a ViewSpec always serializes")
    }

    /// A perspective view from `position` towards `focal_point` with VTK's
    /// default view angle (30°) and parallel scale (1): set `view_angle`,
    /// or `parallel` and `parallel_scale`, on the result for other views.
    pub fn looking_at(position: [f64; 3], focal_point: [f64; 3], view_up: [f64; 3], size: [u32; 2]) -> ViewSpec {
        ViewSpec {
            position,
            focal_point,
            view_up,
            view_angle: default_view_angle(),
            parallel: false,
            parallel_scale: default_parallel_scale(),
            size,
        }
    }

    /// VTK's `ResetCamera` for the given bounds: looking down −z at the
    /// centre from a distance where the bounding sphere fits the vertical
    /// view angle; `view_up` = +y; parallel scale = the sphere's radius.
    pub fn framing(bounds_min: [f64; 3], bounds_max: [f64; 3], size: [u32; 2]) -> ViewSpec {
        ViewSpec::framing_up(bounds_min, bounds_max, size, Y_UP).expect("+y is a valid view-up")
    }

    /// [`ViewSpec::framing`] with a given view-up: the eye sits on the side
    /// of the centre that +z points to, with +z's component along the up
    /// removed (so +y up looks down −z exactly as `framing`); where the up is
    /// along z, on the −y side (z up: looking along +y, x to the right).
    /// Errors when the up is zero or not finite.
    pub fn framing_up(
        bounds_min: [f64; 3],
        bounds_max: [f64; 3],
        size: [u32; 2],
        view_up_in_world: [f64; 3],
    ) -> Result<ViewSpec, RenderError> {
        let up = DVec3::from(view_up_in_world);
        if !up.is_finite() || up.length() == 0.0 {
            return Err(RenderError::View(format!("view-up {view_up_in_world:?} must be finite and non-zero")));
        }
        let up = up.normalize();
        let away_from = |axis: DVec3| axis - up * up.dot(axis);
        let mut back = away_from(DVec3::Z);
        if back.length() < 1e-6 {
            back = away_from(DVec3::NEG_Y);
        }
        let back = back.normalize();
        let lo = DVec3::from(bounds_min);
        let hi = DVec3::from(bounds_max);
        let (centre, mut radius) = if lo.is_finite() && hi.is_finite() && lo.cmple(hi).all() {
            ((lo + hi) * 0.5, (hi - lo).length() * 0.5)
        } else {
            (DVec3::ZERO, 0.5)
        };
        if radius <= 0.0 || !radius.is_finite() {
            radius = 0.5;
        }
        let angle = default_view_angle();
        let distance = radius / (0.5 * angle.to_radians()).sin();
        Ok(ViewSpec {
            position: (centre + back * distance).into(),
            focal_point: centre.into(),
            view_up: up.into(),
            view_angle: angle,
            parallel: false,
            parallel_scale: radius,
            size,
        })
    }

    /// The view every program starts from when no view file is given: the
    /// bounds framed with `view_up_in_world` when one is given (`--view-up`),
    /// otherwise with the data's own up — +z, seen from −y and
    /// [`Z_UP_ELEVATION_DEG`] above the horizon, for [`z_up_data`], else +y
    /// (VTK's `ResetCamera`).
    pub fn default_for(
        bounds_min: [f64; 3],
        bounds_max: [f64; 3],
        size: [u32; 2],
        z_up: bool,
        view_up_in_world: Option<[f64; 3]>,
    ) -> Result<ViewSpec, RenderError> {
        match view_up_in_world {
            Some(up) => ViewSpec::framing_up(bounds_min, bounds_max, size, up),
            None if z_up => {
                Ok(ViewSpec::framing_up(bounds_min, bounds_max, size, Z_UP)?.orbit(0.0, Z_UP_ELEVATION_DEG, 1.0))
            }
            None => Ok(ViewSpec::framing(bounds_min, bounds_max, size)),
        }
    }

    /// VTK's `Azimuth(deg)`, then `Elevation(deg)` and `OrthogonalizeViewUp`,
    /// then `Zoom(factor)` (perspective: view angle ÷ factor; parallel:
    /// parallel scale ÷ factor).
    pub fn orbit(&self, azimuth_deg: f64, elevation_deg: f64, zoom: f64) -> ViewSpec {
        let focal = DVec3::from(self.focal_point);
        let mut pos = DVec3::from(self.position);
        let mut up = DVec3::from(self.view_up).normalize_or_zero();
        if azimuth_deg != 0.0 && up != DVec3::ZERO {
            pos = focal + rotate(pos - focal, up, azimuth_deg.to_radians());
        }
        if elevation_deg != 0.0 {
            let forward = (focal - pos).normalize_or_zero();
            let right = forward.cross(up).normalize_or_zero();
            if right != DVec3::ZERO {
                // VTK rotates about −(view transform's first row) = −right.
                pos = focal + rotate(pos - focal, -right, elevation_deg.to_radians());
                let forward = (focal - pos).normalize_or_zero();
                up = right.cross(forward).normalize_or_zero();
            }
        }
        let mut out = self.clone();
        out.position = pos.into();
        out.view_up = up.into();
        if zoom > 0.0 && zoom.is_finite() {
            if self.parallel {
                out.parallel_scale /= zoom;
            } else {
                out.view_angle /= zoom;
            }
        }
        out
    }
}

/// A camera path through key views (`tetview animate --key-views`): the
/// view at any fraction of the way from the first key to the last, moving
/// through each key in turn, equal time per pair of keys.
///
/// Between two keys the focal point moves on a straight line, the camera
/// turns (view direction and up as one rotation, the shortest way) with
/// the eye behind the focal point, the eye's distance changes geometrically
/// (so a zoom in and a zoom out take equal time), and the view angle
/// (perspective) or parallel scale (parallel; geometric, as the distance)
/// changes with them. Every key is reached exactly.
#[derive(Debug, Clone, PartialEq)]
pub struct KeyPath {
    keys: Vec<ViewSpec>,
}

impl KeyPath {
    /// Checks the keys: at least one, each a valid [`Camera`], all of one
    /// projection (perspective or parallel) and one image size; the error
    /// names the key (0-based) that breaks the rule.
    pub fn new(keys: Vec<ViewSpec>) -> Result<KeyPath, RenderError> {
        let Some(first) = keys.first() else {
            return Err(RenderError::View("a camera path needs at least one key view".into()));
        };
        for (k, v) in keys.iter().enumerate() {
            Camera::new(v).map_err(|e| RenderError::View(format!("key view {k}: {e}")))?;
            if v.parallel != first.parallel {
                return Err(RenderError::View(format!(
                    "key view {k} is {} but key view 0 is {}: a path keeps one projection",
                    if v.parallel { "parallel" } else { "perspective" },
                    if first.parallel { "parallel" } else { "perspective" }
                )));
            }
            if v.size != first.size {
                return Err(RenderError::View(format!(
                    "key view {k} is {}x{} but key view 0 is {}x{}: give every key one size (or --size)",
                    v.size[0], v.size[1], first.size[0], first.size[1]
                )));
            }
        }
        Ok(KeyPath { keys })
    }

    pub fn keys(&self) -> &[ViewSpec] {
        &self.keys
    }

    /// The view at fraction `u` of the path (clamped to [0, 1]; 0 is the
    /// first key, 1 the last).
    pub fn at(&self, u: f64) -> ViewSpec {
        let segments = self.keys.len() - 1;
        if segments == 0 || u.is_nan() || u <= 0.0 {
            return self.keys[0].clone();
        }
        if u >= 1.0 {
            return self.keys[segments].clone();
        }
        let x = u * segments as f64;
        let k = (x.floor() as usize).min(segments - 1);
        between(&self.keys[k], &self.keys[k + 1], x - k as f64)
    }
}

/// The view fraction `t` ∈ [0, 1) of the way from `a` to `b` ([`KeyPath`]):
/// the camera's orientation (view direction and up together) turns by the
/// spherical interpolation of the two keys' rotations — the shortest turn,
/// so eyes on opposite sides of the focal point orbit about the shared
/// view-up — and the eye sits behind the moving focal point along the
/// turned view direction.
fn between(a: &ViewSpec, b: &ViewSpec, t: f64) -> ViewSpec {
    if t <= 0.0 {
        return a.clone();
    }
    let lerp = |x: f64, y: f64| x + (y - x) * t;
    let geo = |x: f64, y: f64| if x > 0.0 && y > 0.0 { x * (y / x).powf(t) } else { lerp(x, y) };
    // Valid keys (KeyPath::new: Camera::new) have the eye off the focal
    // point and an up not along the view direction.
    let orientation = |v: &ViewSpec| {
        let back = (DVec3::from(v.position) - DVec3::from(v.focal_point)).normalize();
        let right = DVec3::from(v.view_up).cross(back).normalize();
        DQuat::from_mat3(&DMat3::from_cols(right, back.cross(right), back))
    };
    let turn = orientation(a).slerp(orientation(b), t);
    let dist = |v: &ViewSpec| DVec3::from(v.position).distance(DVec3::from(v.focal_point));
    let focal = DVec3::from(a.focal_point).lerp(DVec3::from(b.focal_point), t);
    let position = focal + (turn * DVec3::Z) * geo(dist(a), dist(b));
    ViewSpec {
        position: position.into(),
        focal_point: focal.into(),
        view_up: (turn * DVec3::Y).normalize().into(),
        view_angle: lerp(a.view_angle, b.view_angle),
        parallel: a.parallel,
        parallel_scale: geo(a.parallel_scale, b.parallel_scale),
        size: a.size,
    }
}

/// Rodrigues rotation of `v` about unit `axis` by `angle` radians
/// (right-handed, as vtkTransform::RotateWXYZ).
fn rotate(v: DVec3, axis: DVec3, angle: f64) -> DVec3 {
    let (s, c) = angle.sin_cos();
    v * c + axis.cross(v) * s + axis * axis.dot(v) * (1.0 - c)
}

/// A validated camera ready for projection and ray generation.
#[derive(Debug, Clone, PartialEq)]
pub struct Camera {
    spec: ViewSpec,
    eye_in_world: DVec3,
    /// Unit view direction (towards the focal point).
    forward: DVec3,
    /// Unit screen right and up in world space (orthonormal with forward).
    right: DVec3,
    up: DVec3,
    /// Half extent of the image plane at depth 1 (perspective) or in world
    /// units (parallel), vertically and horizontally.
    half_height: f64,
    half_width: f64,
    near_depth: f64,
}

impl Camera {
    /// Checks the view (finite numbers, position ≠ focal point, view-up not
    /// along the view direction, 0 < angle < 180, size within limits).
    pub fn new(spec: &ViewSpec) -> Result<Camera, RenderError> {
        let bad = |why: &str| Err(RenderError::View(why.to_string()));
        let [w, h] = spec.size;
        if w == 0 || h == 0 || w > MAX_IMAGE_SIDE || h > MAX_IMAGE_SIDE {
            return bad(&format!("size {w}x{h}: each side must be 1..={MAX_IMAGE_SIDE}"));
        }
        let pos = DVec3::from(spec.position);
        let focal = DVec3::from(spec.focal_point);
        let up_hint = DVec3::from(spec.view_up);
        if !(pos.is_finite() && focal.is_finite() && up_hint.is_finite()) {
            return bad("position, focal_point and view_up must be finite");
        }
        let dist = (focal - pos).length();
        if dist <= 0.0 || !dist.is_finite() {
            return bad("position equals focal_point: no view direction");
        }
        let forward = (focal - pos) / dist;
        let right = forward.cross(up_hint);
        if right.length() <= 1e-12 * up_hint.length().max(1e-300) || up_hint.length() == 0.0 {
            return bad("view_up is zero or parallel to the view direction");
        }
        let right = right.normalize();
        let up = right.cross(forward);
        let aspect = w as f64 / h as f64;
        let half_height = if spec.parallel {
            if !(spec.parallel_scale > 0.0 && spec.parallel_scale.is_finite()) {
                return bad("parallel_scale must be positive");
            }
            spec.parallel_scale
        } else {
            if !(spec.view_angle > 0.0 && spec.view_angle < 180.0) {
                return bad("view_angle must be in (0, 180) degrees");
            }
            (0.5 * spec.view_angle.to_radians()).tan()
        };
        Ok(Camera {
            spec: spec.clone(),
            eye_in_world: pos,
            forward,
            right,
            up,
            half_height,
            half_width: half_height * aspect,
            // Anything nearer than this is clipped away; small against the
            // focal distance so a camera inside the mesh loses nothing visible.
            near_depth: if spec.parallel { f64::NEG_INFINITY } else { 1e-6 * dist },
        })
    }

    pub fn spec(&self) -> &ViewSpec {
        &self.spec
    }
    pub fn width(&self) -> u32 {
        self.spec.size[0]
    }
    pub fn height(&self) -> u32 {
        self.spec.size[1]
    }
    pub fn is_parallel(&self) -> bool {
        self.spec.parallel
    }
    pub fn eye_in_world(&self) -> DVec3 {
        self.eye_in_world
    }
    /// Unit view direction.
    pub fn forward(&self) -> DVec3 {
        self.forward
    }
    /// Points with `depth < near_depth()` are behind the near plane
    /// (−∞ for parallel projection: nothing is clipped).
    pub fn near_depth(&self) -> f64 {
        self.near_depth
    }

    /// Depth of a world point: distance along the view direction from the eye.
    pub fn depth(&self, pos_in_world: DVec3) -> f64 {
        (pos_in_world - self.eye_in_world).dot(self.forward)
    }

    /// `[x_px, y_px, depth]`. For perspective the caller must make sure
    /// `depth ≥ near_depth()` (clip first); pixel coordinates of points
    /// behind the eye are meaningless.
    pub fn project(&self, pos_in_world: DVec3) -> DVec3 {
        let rel = pos_in_world - self.eye_in_world;
        let depth = rel.dot(self.forward);
        let (x, y) = (rel.dot(self.right), rel.dot(self.up));
        let scale = if self.spec.parallel { 1.0 } else { 1.0 / depth };
        let ndc_x = x * scale / self.half_width;
        let ndc_y = y * scale / self.half_height;
        DVec3::new((ndc_x + 1.0) * 0.5 * self.width() as f64, (1.0 - ndc_y) * 0.5 * self.height() as f64, depth)
    }

    /// The ray through pixel coordinates (x_px, y_px) — pass (i+½, j+½) for
    /// a pixel centre: origin on the eye (perspective) or on the plane
    /// through the eye (parallel), unit direction.
    pub fn ray(&self, x_px: f64, y_px: f64) -> (DVec3, DVec3) {
        let ndc_x = 2.0 * x_px / self.width() as f64 - 1.0;
        let ndc_y = 1.0 - 2.0 * y_px / self.height() as f64;
        let off = self.right * (ndc_x * self.half_width) + self.up * (ndc_y * self.half_height);
        if self.spec.parallel {
            (self.eye_in_world + off, self.forward)
        } else {
            (self.eye_in_world, (self.forward + off).normalize())
        }
    }

    /// Unit direction from the eye towards a world point (the view vector for
    /// lighting and silhouettes); the view direction for parallel projection.
    pub fn view_dir_to(&self, pos_in_world: DVec3) -> DVec3 {
        if self.spec.parallel {
            self.forward
        } else {
            (pos_in_world - self.eye_in_world).normalize_or(self.forward)
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn cam(parallel: bool) -> Camera {
        let mut spec = ViewSpec::framing([-1.0; 3], [1.0; 3], [200, 100]);
        spec.parallel = parallel;
        Camera::new(&spec).unwrap()
    }

    #[test]
    fn framing_matches_vtk_reset_camera() {
        let spec = ViewSpec::framing([0.0; 3], [2.0, 2.0, 2.0], [64, 64]);
        let r = 3f64.sqrt();
        let d = r / 15f64.to_radians().sin();
        assert_eq!(spec.focal_point, [1.0, 1.0, 1.0]);
        assert!((spec.position[2] - (1.0 + d)).abs() < 1e-12);
        assert!((spec.parallel_scale - r).abs() < 1e-12);
    }

    #[test]
    fn focal_point_projects_to_image_centre_and_rays_round_trip() {
        for parallel in [false, true] {
            let c = cam(parallel);
            let p = c.project(DVec3::ZERO);
            assert!((p.x - 100.0).abs() < 1e-9 && (p.y - 50.0).abs() < 1e-9);
            // Up in the world is up on screen (smaller row index).
            assert!(c.project(DVec3::new(0.0, 0.5, 0.0)).y < 50.0);
            assert!(c.project(DVec3::new(0.5, 0.0, 0.0)).x > 100.0);
            for (x, y) in [(0.5, 0.5), (199.5, 99.5), (37.25, 80.0)] {
                let (o, d) = c.ray(x, y);
                let q = c.project(o + d * 5.0);
                assert!((q.x - x).abs() < 1e-9 && (q.y - y).abs() < 1e-9, "{parallel} {x} {y} {q}");
            }
        }
    }

    #[test]
    fn vertical_view_angle_spans_the_image_height() {
        let c = cam(false);
        let depth = c.depth(DVec3::ZERO);
        let top = DVec3::new(0.0, depth * 15f64.to_radians().tan(), 0.0);
        assert!(c.project(top).y.abs() < 1e-9);
    }

    #[test]
    fn orbit_keeps_distance_and_zoom_narrows() {
        let spec = ViewSpec::framing([-1.0; 3], [1.0; 3], [10, 10]);
        let d0 = (DVec3::from(spec.position) - DVec3::from(spec.focal_point)).length();
        let o = spec.orbit(90.0, 30.0, 2.0);
        let d1 = (DVec3::from(o.position) - DVec3::from(o.focal_point)).length();
        assert!((d0 - d1).abs() < 1e-9);
        assert!((o.view_angle - 15.0).abs() < 1e-12);
        // Azimuth 90 about +y from +z moves the camera to +x (VTK's sense).
        let a = spec.orbit(90.0, 0.0, 1.0);
        assert!((a.position[0] - d0).abs() < 1e-9, "{:?}", a.position);
        // Elevation 90 looks down from +y; view-up stays orthogonal.
        let e = spec.orbit(0.0, 90.0, 1.0);
        assert!((e.position[1] - d0).abs() < 1e-9, "{:?}", e.position);
        assert!(Camera::new(&e).is_ok());
    }

    #[test]
    fn framing_up_puts_the_up_on_screen_and_y_up_is_framing() {
        let (lo, hi) = ([-1.0, -2.0, -0.5], [3.0, 2.0, 0.5]);
        assert_eq!(ViewSpec::framing_up(lo, hi, [64, 48], Y_UP).unwrap(), ViewSpec::framing(lo, hi, [64, 48]));
        for up in [Z_UP, [1.0, 0.0, 0.0], [0.0, 0.0, -2.0], [1.0, 1.0, 1.0]] {
            let v = ViewSpec::framing_up(lo, hi, [64, 48], up).unwrap();
            let c = Camera::new(&v).unwrap();
            let focal = DVec3::from(v.focal_point);
            let u = DVec3::from(up).normalize();
            // World up is screen up, and the distance is framing's.
            assert!(c.project(focal + u).y < c.project(focal).y - 1.0, "{up:?}");
            let d = (DVec3::from(v.position) - focal).length();
            let d0 = (DVec3::from(ViewSpec::framing(lo, hi, [64, 48]).position) - focal).length();
            assert!((d - d0).abs() < 1e-9 * d0);
            assert!((DVec3::from(v.view_up) - u).length() < 1e-12);
        }
        // z up: seen from −y, x to the right.
        let v = ViewSpec::framing_up(lo, hi, [64, 48], Z_UP).unwrap();
        assert!(v.position[1] < v.focal_point[1]);
        let c = Camera::new(&v).unwrap();
        assert!(c.project(DVec3::from(v.focal_point) + DVec3::X).x > 32.0);
        for bad in [[0.0; 3], [f64::NAN, 1.0, 0.0]] {
            assert!(ViewSpec::framing_up(lo, hi, [8, 8], bad).unwrap_err().to_string().contains("view-up"));
        }
    }

    #[test]
    fn z_up_rule_and_default_view() {
        // Point clouds and bounds flat in z are z-up; a cube or a tall box is not.
        assert!(z_up_data(true, [0.0; 3], [1.0; 3]));
        assert!(z_up_data(false, [0.0; 3], [10.0, 8.0, 1.5]));
        assert!(!z_up_data(false, [0.0; 3], [1.0; 3]));
        assert!(!z_up_data(false, [0.0; 3], [10.0, 1.0, 1.5]));
        assert!(!z_up_data(false, [f64::INFINITY; 3], [f64::NEG_INFINITY; 3]));
        let (lo, hi) = ([0.0; 3], [10.0, 8.0, 1.0]);
        assert_eq!(ViewSpec::default_for(lo, hi, [32, 32], false, None).unwrap(), ViewSpec::framing(lo, hi, [32, 32]));
        let z = ViewSpec::default_for(lo, hi, [32, 32], true, None).unwrap();
        // From −y and above the horizon, with z up on screen.
        assert!(z.position[1] < z.focal_point[1] && z.position[2] > z.focal_point[2]);
        assert!(z.view_up[2] > 0.8);
        // An explicit up wins over the rule.
        let y = ViewSpec::default_for(lo, hi, [32, 32], true, Some(Y_UP)).unwrap();
        assert_eq!(y, ViewSpec::framing(lo, hi, [32, 32]));
    }

    #[test]
    fn a_saved_view_keeps_its_up() {
        let v = ViewSpec::default_for([0.0; 3], [4.0, 4.0, 0.5], [40, 30], true, None).unwrap();
        let back = ViewSpec::from_json(&v.to_json()).unwrap();
        assert_eq!(back.view_up, v.view_up);
        assert_eq!(back, v);
    }

    #[test]
    fn bad_views_are_errors() {
        let good = ViewSpec::framing([0.0; 3], [1.0; 3], [8, 8]);
        let mut v = good.clone();
        v.position = v.focal_point;
        assert!(Camera::new(&v).unwrap_err().to_string().contains("focal_point"));
        let mut v = good.clone();
        v.view_up = [0.0, 0.0, 1.0];
        assert!(Camera::new(&v).unwrap_err().to_string().contains("view_up"));
        let mut v = good.clone();
        v.size = [0, 8];
        assert!(Camera::new(&v).is_err());
        let mut v = good;
        v.view_angle = f64::NAN;
        assert!(Camera::new(&v).is_err());
        assert!(ViewSpec::from_json(r#"{"position":[0,0,1]}"#).is_err());
        let j = r#"{"position":[0,0,5],"focal_point":[0,0,0],"view_up":[0,1,0],"size":[4,3]}"#;
        let v = ViewSpec::from_json(j).unwrap();
        assert_eq!(v.view_angle, 30.0);
        assert_eq!(ViewSpec::from_json(&v.to_json()).unwrap(), v);
    }

    #[test]
    fn a_key_path_reaches_every_key_and_moves_smoothly_between() {
        let a = ViewSpec::looking_at([0.0, 0.0, 10.0], [0.0; 3], Y_UP, [16, 12]);
        // Half an orbit about +y, twice as far, looking at a moved point,
        // with a narrower angle.
        let mut b = ViewSpec::looking_at([1.0, 0.0, -20.0], [1.0, 0.0, 0.0], Y_UP, [16, 12]);
        b.view_angle = 20.0;
        let c = a.orbit(0.0, 60.0, 1.0);
        let path = KeyPath::new(vec![a.clone(), b.clone(), c.clone()]).unwrap();
        assert_eq!(path.at(0.0), a);
        assert_eq!(path.at(0.5), b);
        assert_eq!(path.at(1.0), c);
        assert_eq!(path.at(-1.0), a);
        assert_eq!(path.at(2.0), c);
        let mut last = DVec3::from(a.position);
        for i in 1..200 {
            let v = path.at(i as f64 / 200.0);
            Camera::new(&v).expect("every view on the path is valid");
            let (pos, focal, up) = (DVec3::from(v.position), DVec3::from(v.focal_point), DVec3::from(v.view_up));
            assert!(
                (up.length() - 1.0).abs() < 1e-12 && up.dot((focal - pos).normalize()).abs() < 1e-12,
                "{i}: {up} {pos} {focal}"
            );
            // Small steps: no jumps anywhere on the path.
            assert!(pos.distance(last) < 1.0, "step {i}: {pos} after {last}");
            last = pos;
        }
        // Opposite eyes orbit about the up (the eye stays at y = 0), the
        // distance changes geometrically and the angle linearly.
        let mid = path.at(0.25);
        let off = DVec3::from(mid.position) - DVec3::from(mid.focal_point);
        assert!(off.y.abs() < 1e-9, "{off}");
        assert!((off.length() - 200f64.sqrt()).abs() < 1e-9);
        assert!((mid.view_angle - 25.0).abs() < 1e-12);
        assert_eq!(mid.focal_point, [0.5, 0.0, 0.0]);
    }

    #[test]
    fn key_paths_reject_mixed_projections_sizes_and_bad_keys() {
        let a = ViewSpec::looking_at([0.0, 0.0, 10.0], [0.0; 3], Y_UP, [16, 12]);
        assert!(KeyPath::new(vec![]).is_err());
        let mut p = a.clone();
        p.parallel = true;
        assert!(KeyPath::new(vec![a.clone(), p]).unwrap_err().to_string().contains("key view 1 is parallel"));
        let mut s = a.clone();
        s.size = [8, 8];
        assert!(KeyPath::new(vec![a.clone(), s]).unwrap_err().to_string().contains("16x12"));
        let mut bad = a.clone();
        bad.position = bad.focal_point;
        assert!(KeyPath::new(vec![a.clone(), bad]).unwrap_err().to_string().contains("key view 1"));
        // One key: every frame is that view.
        let one = KeyPath::new(vec![a.clone()]).unwrap();
        assert_eq!(one.at(0.7), a);
    }
}
