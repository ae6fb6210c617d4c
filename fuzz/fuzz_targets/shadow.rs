//! Lights and volumetric shadows on meshes built from the input bytes
//! (Delaunay tets of lattice or arbitrary f64 points, as the walk target),
//! with a transfer function of narrow opacity peaks and steps whose
//! extinction reaches 10⁴ (transmittance underflow), and one or two lights
//! from the bytes: directional along any direction (the view's included),
//! point lights inside the mesh, on a vertex, beside its box or far off.
//! A light set the library refuses (a zero direction, a non-finite
//! position) is an error, not a panic. Where the field is made:
//! - every light's optical depth at the vertices, the tets' centroids and
//!   points around the box is a number ≥ 0 (+∞ allowed: no light left),
//!   never NaN; the field made again (bit 6 of the mode byte) is the
//!   same (no thread-order dependence);
//! - both CPU renderers draw finite pixels with α in [0, 1], lit with and
//!   without the field, and the shadowed image's α is the lit one's (the
//!   field scales light, not opacity) while no colour channel brightens
//!   past the lighting split's tolerance (shadows only take light away).
#![no_main]
mod common;

use glam::DVec3;
use libfuzzer_sys::fuzz_target;
use std::sync::Arc;
use tet_preint::{ExactShader, SegmentShader, TransferFunction};
use tet_render::{CpuRenderer, Light, LightSet, LightSource, RasterOptions, Renderer, Shading, ViewSpec};

/// A TF of `peaks` narrow opacity peaks (width 1/64 of the range, heights
/// from the bytes up to 10⁴) over a floor, or of steps where `steps` is set.
fn tf_from(bytes: [u8; 4]) -> Option<TransferFunction> {
    let [shape, height, floor, shift] = bytes;
    let top = 10f64.powf(height as f64 / 64.0); // 1 … 10⁴
    let base = floor as f64 / 255.0;
    let n = 1 + (shape % 12) as usize;
    let mut opacity = vec![[0.0, base]];
    for k in 0..n {
        let at = (k as f64 + 0.5 + (shift as f64 / 255.0 - 0.5) * 0.5) / n as f64;
        let at = at.clamp(0.02, 0.98);
        if shape & 0x80 != 0 {
            // A step: up at `at`, down again halfway to the next.
            opacity.push([at, top * (k % 2) as f64 + base]);
        } else {
            opacity.push([at - 1.0 / 128.0, base]);
            opacity.push([at, top]);
            opacity.push([at + 1.0 / 128.0, base]);
        }
    }
    opacity.push([1.0, base]);
    // Nodes must increase strictly: drop any that do not.
    opacity.dedup_by(|b, a| b[0] <= a[0]);
    let nodes = |v: &[[f64; 2]]| v.iter().map(|[x, y]| format!("[{x}, {y}]")).collect::<Vec<_>>().join(", ");
    let json = format!(
        r#"{{"color": [[0, 1, 0.3, 0.1], [0.5, 0.2, 1, 0.4], [1, 0.3, 0.4, 1]], "opacity": [{}], "unit_distance": 1}}"#,
        nodes(&opacity)
    );
    TransferFunction::from_json(&json).ok()
}

/// A light from 7 bytes: its kind and where, relative to the box `lo..hi`.
fn light_from(b: &[u8], lo: DVec3, hi: DVec3, view_dir: DVec3, vertex: DVec3) -> LightSource {
    let unit = |x: u8| x as f64 / 127.5 - 1.0; // −1 … 1
    let dir = DVec3::new(unit(b[1]), unit(b[2]), unit(b[3]));
    let (c, half) = ((lo + hi) / 2.0, (hi - lo) / 2.0);
    let intensity = 0.5 + b[4] as f64 / 255.0;
    let point = |p: DVec3| LightSource::Point { position: p.to_array(), intensity };
    match b[0] % 7 {
        0 => LightSource::Directional { direction: dir.to_array(), intensity },
        // Along the view, either way.
        1 => LightSource::Directional { direction: (view_dir * dir.x.signum()).to_array(), intensity },
        // Inside the box (inside the mesh or in a hole of it).
        2 => point(c + half * dir * 0.9),
        // On a vertex of the mesh.
        3 => point(vertex),
        // Beside the box, within its size.
        4 => point(c + half * (DVec3::ONE + dir.abs()) * dir.signum()),
        // Far off: 10³ … 10⁹ box sizes.
        5 => point(c + (hi - lo).max_element() * 10f64.powi(3 + (b[5] % 7) as i32) * dir),
        // A bad light: zero or non-finite.
        _ => {
            if b[5] & 1 == 0 {
                LightSource::Directional { direction: [0.0; 3], intensity }
            } else {
                point(DVec3::new(f64::NAN, f64::INFINITY, c.z))
            }
        }
    }
}

fuzz_target!(|data: &[u8]| {
    let Some((head, rest)) = data.split_first_chunk::<24>() else { return };
    let (mode, az, el, sbyte, size) = (head[0], head[1], head[2], head[3], head[4]);
    let tf_bytes = [head[5], head[6], head[7], head[8]];
    let Some(common::DelaunayScene { points: pts, tets, scene, .. }) =
        common::delaunay_scene(mode, rest, 48, 16, sbyte)
    else {
        return;
    };
    let Ok(scene) = scene.ensure_gradients() else { return };
    let Some(tf) = tf_from(tf_bytes) else { return };
    let (lo, hi) = scene.bounds();
    let (lo, hi) = (DVec3::from(lo), DVec3::from(hi));
    let side = 6 + (size % 10) as u32;
    let view = ViewSpec::framing(lo.to_array(), hi.to_array(), [side, side + 1]).orbit(
        az as f64 * 360.0 / 256.0,
        el as f64 * 178.0 / 256.0 - 89.0,
        1.0,
    );
    let view_dir = (DVec3::from(view.focal_point) - DVec3::from(view.position)).normalize_or_zero();
    let vertex = DVec3::from(pts[tets[0][0] as usize]);
    let n_lights = 1 + (mode >> 4) as usize % 2;
    let sources: Vec<LightSource> =
        (0..n_lights).map(|k| light_from(&head[9 + 7 * k..16 + 7 * k], lo, hi, view_dir, vertex)).collect();
    let Ok(sources) = LightSet::new(&sources) else { return };
    let Ok(field) = scene.compute_shadows(&tf, &sources, &|_, _| {}) else { return };

    // Optical depths: numbers ≥ 0 (+∞: no light left), the same when the
    // field is made again (with bit 6 of the mode: a map takes most of an
    // input's time).
    let again = if mode & 0x40 != 0 {
        Some(scene.compute_shadows(&tf, &sources, &|_, _| {}).expect("made once, made again"))
    } else {
        None
    };
    let mut probes: Vec<DVec3> = pts.iter().map(|&p| DVec3::from(p)).collect();
    probes.extend(tets.iter().map(|t| t.iter().map(|&v| DVec3::from(pts[v as usize])).sum::<DVec3>() / 4.0));
    for k in 0..27 {
        let f = DVec3::new((k % 3) as f64, (k / 3 % 3) as f64, (k / 9) as f64) * 0.75 - 0.25;
        probes.push(lo + (hi - lo) * f);
    }
    for light in 0..field.num_lights() {
        for &p in &probes {
            let a = field.depth_at(light, p);
            assert!(a >= 0.0, "light {light}: depth {a} at {p}");
            if let Some(b) = again.as_ref().map(|f| f.depth_at(light, p)) {
                assert!(a == b, "light {light}: depth {a} then {b} at {p}");
            }
        }
    }

    let field = Arc::new(field);
    let shader: Arc<dyn SegmentShader> = Arc::new(ExactShader::new(tf.clone()));
    let floor = Shading::gradient_floor_for(scene.scalar_range(), lo.to_array(), hi.to_array());
    let shading = |shadows: bool| Shading {
        light: Some(Light::default()),
        silhouette: None,
        sources,
        shadows,
        gradient_floor: floor,
    };
    for kind in [CpuRenderer::Walk, CpuRenderer::Pt] {
        let draw = |shadows: bool| {
            let mut r = Renderer::new(scene.clone());
            r.set_renderer(kind);
            r.set_shadows(shadows.then(|| field.clone())).ok()?;
            r.set_view(&view).ok()?;
            r.set_shader(shader.clone());
            r.set_raster_options(RasterOptions { shading: shading(shadows), opaque_alpha: 2.0, ..Default::default() });
            r.render(&|_, _| {}).ok().map(|(img, _)| img)
        };
        let (Some(lit), Some(shadowed)) = (draw(false), draw(true)) else { return };
        common::check_pixels(&lit, &format!("{kind} lit"));
        common::check_pixels(&shadowed, &format!("{kind} shadowed"));
        for (i, (a, b)) in lit.pixels().iter().zip(shadowed.pixels()).enumerate() {
            assert!((a[3] - b[3]).abs() <= 1e-4, "{kind}: pixel {i} α {} lit, {} shadowed", a[3], b[3]);
            for c in 0..3 {
                assert!(b[c] <= a[c] + 2e-2, "{kind}: pixel {i} channel {c} {} shadowed > {} lit", b[c], a[c]);
            }
        }
    }
});
