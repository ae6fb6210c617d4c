#![no_main]
//! Partition manifests (`formats/manifest.md`): whatever `Manifest::from_json`
//! accepts has pieces whose files stay inside the manifest's directory, and
//! its visibility orders (perspective and parallel, any eye) name every
//! piece exactly once.
use libfuzzer_sys::fuzz_target;
use std::path::Path;
use tet_bundle::manifest::Manifest;

fuzz_target!(|data: &[u8]| {
    let Ok(m) = Manifest::from_json(data, Path::new("fuzz/manifest.json")) else { return };
    let dir = Path::new("/partition");
    for k in 0..m.pieces.len() {
        let p = m.piece_path(dir, k);
        assert!(p.starts_with(dir) && !p.components().any(|c| c == std::path::Component::ParentDir), "{p:?}");
    }
    let eyes = [[0.0, 0.0, 0.0], [1e300, -1e300, 0.5], [f64::NAN, 1.0, -1.0], [-3.0, 2.0, 1e-300]];
    for eye in eyes {
        for order in [m.front_to_back(eye), m.front_to_back_parallel(eye)] {
            let mut seen = vec![false; m.pieces.len()];
            for &k in &order {
                assert!(k < seen.len() && !std::mem::replace(&mut seen[k], true), "{order:?}");
            }
            assert!(seen.iter().all(|&s| s), "{order:?} misses a piece");
        }
    }
});
