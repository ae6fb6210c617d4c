#![no_main]
//! View JSON (VTK camera fields): whatever `ViewSpec::from_json` and
//! `Camera::new` accept must project points without panicking.
use libfuzzer_sys::fuzz_target;
use tet_render::{Camera, ViewSpec};

fuzz_target!(|data: &[u8]| {
    let Ok(text) = std::str::from_utf8(data) else { return };
    let Ok(spec) = ViewSpec::from_json(text) else { return };
    let Ok(camera) = Camera::new(&spec) else { return };
    for p in [[0.0, 0.0, 0.0], [1e6, -1e6, 3.0], [f64::NAN, 0.0, 1.0]] {
        let _ = camera.project(glam::DVec3::from(p));
    }
    let _ = spec.orbit(30.0, 20.0, 1.5);
});
