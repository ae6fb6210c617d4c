#![no_main]
//! `.tetl` files: whatever `LutFile::from_bytes` and `load_shader` accept
//! must shade any segment (extreme, negative, NaN) to finite RGBA with
//! α in [0, 1] — the `SegmentShader` contract.
use libfuzzer_sys::fuzz_target;
use tet_preint::{load_shader, LutFile, Segment};

fuzz_target!(|data: &[u8]| {
    let path = std::path::Path::new("fuzz.tetl");
    let Ok(lut) = LutFile::from_bytes(data, path) else { return };
    let Ok(shader) = load_shader(&lut, path) else { return };
    let probe = [0.0f32, 0.5, 1.0, -1.0, 1e30, -1e30, f32::NAN, f32::INFINITY, 1e-30, 255.0];
    for (i, &sf) in probe.iter().enumerate() {
        let sb = probe[(i * 3 + 1) % probe.len()];
        let l = probe[(i * 7 + 2) % probe.len()].abs();
        let g = probe[(i * 5 + 3) % probe.len()];
        let c = shader.shade(&Segment { s_front: sf, s_back: sb, grad_front: g, grad_back: g, len_world: l });
        assert!(c.iter().all(|v| v.is_finite()), "{sf} {sb} {l} {g}: {c:?}");
        assert!((0.0..=1.0).contains(&c[3]), "{sf} {sb} {l} {g}: {c:?}");
    }
});
