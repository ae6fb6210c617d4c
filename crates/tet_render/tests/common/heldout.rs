//! What the held-out image test and its example share: the repository
//! root, the held-out TFs and the image comparison they judge by.
#![allow(dead_code)] // the example and the test use different parts

use std::path::{Path, PathBuf};
use tet_preint::TransferFunction;

/// The repository root.
pub fn root() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("../..")
}

/// Held-out TF `name` (crates/tet_preint/tests/data/heldout).
pub fn heldout(name: &str) -> TransferFunction {
    let p = root().join("crates/tet_preint/tests/data/heldout").join(name);
    TransferFunction::from_json(&std::fs::read_to_string(p).unwrap()).unwrap()
}

/// (linear max |difference|, pixels with a channel off by more than 1/255).
pub fn diff(a: &tet_render::Image, b: &tet_render::Image) -> (f64, usize) {
    let mut max = 0.0f64;
    let mut over = 0;
    for (p, q) in a.pixels().iter().zip(b.pixels()) {
        let d = (0..4).map(|c| (f64::from(p[c]) - f64::from(q[c])).abs()).fold(0.0, f64::max);
        max = max.max(d);
        over += usize::from(d > 1.0 / 255.0);
    }
    (max, over)
}
