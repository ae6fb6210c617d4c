//! What a TF edit costs the default table3d (`BakeOptions`: 128 × 128 × 256
//! f32, data axis, adaptive build) on a bundle: the full bake, the slice
//! recurrence for comparison, and `Table3d::rebake` after typical edits of
//! the TF's control points, best of N wall-clock runs each; plus the node
//! error of both builds against the per-entry exact build.
//!
//! `cargo run --release -p tetlut --example table3d_rebake -- B.tetb tf.json [repeats]`
use std::time::Instant;
use tet_preint::table3d::Build3d;
use tet_preint::{BakeOptions, ColorNode, OpacityNode, Table3d, Table3dParams, TransferFunction};

mod common;

fn best_of<T>(repeats: usize, mut f: impl FnMut() -> T) -> (f64, T) {
    let mut best = f64::INFINITY;
    let mut out = None;
    for _ in 0..repeats {
        let t0 = Instant::now();
        let v = f();
        best = best.min(t0.elapsed().as_secs_f64());
        out = Some(v);
    }
    (best * 1e3, out.expect("repeats ≥ 1"))
}

fn with_nodes(tf: &TransferFunction, color: Vec<ColorNode>, opacity: Vec<OpacityNode>) -> TransferFunction {
    TransferFunction::new(color, opacity, tf.unit_distance(), tf.emission(), false).expect("edited TF")
}

fn main() {
    let args: Vec<String> = std::env::args().collect();
    let (_bundle, domain, tf) = common::bundle_domain_tf(&args);
    let repeats: usize = args.get(3).map_or(5, |s| s.parse().expect("repeats"));
    let p = BakeOptions::default().table3d;
    println!("{} threads, best of {repeats}", rayon::current_num_threads());

    // TABLE3D_REBAKE_ONLY=1: the re-bakes alone (for profiling).
    let only_rebake = std::env::var_os("TABLE3D_REBAKE_ONLY").is_some();
    let builds = if only_rebake { vec![] } else { vec![p.build, Build3d::default()] };
    let exact = (!only_rebake)
        .then(|| Table3d::build(&tf, &domain, &Table3dParams { build: Build3d::Exact, ..p }).expect("exact"));
    let node_error = |t: &Table3d| {
        let exact = exact.as_ref().expect("exact table");
        let (a, b) = (t.storage().as_f32().expect("f32"), exact.storage().as_f32().expect("f32"));
        a.iter().zip(b).map(|(x, y)| (x - y).abs()).fold(0.0f32, f32::max)
    };
    for build in builds {
        let q = Table3dParams { build, ..p };
        let (ms, t) = best_of(repeats, || Table3d::build(&tf, &domain, &q).expect("bake"));
        println!("full bake {build:?}: {ms:.1} ms; node max error vs exact {:.2e}", node_error(&t));
    }

    // Edits of the TF's control points, as a TF editor makes them.
    let (col, op) = (tf.color_nodes().to_vec(), tf.opacity_nodes().to_vec());
    let mid = op.len() / 2;
    let mut edits: Vec<(String, TransferFunction)> = vec![];
    let mut o = op.clone();
    o[mid].a *= 1.5;
    edits.push((format!("opacity of node {mid} (x = {:.4})", op[mid].x), with_nodes(&tf, col.clone(), o)));
    let mut o = op.clone();
    o[0].a += 0.05;
    edits.push(("opacity of the first node".into(), with_nodes(&tf, col.clone(), o)));
    let last = op.len() - 1;
    let mut o = op.clone();
    o[last].a *= 0.8;
    edits.push(("opacity of the last node".into(), with_nodes(&tf, col.clone(), o)));
    let cm = col.len() / 2;
    let mut c = col.clone();
    c[cm].rgb = [0.5, 0.4, 0.3];
    edits.push((format!("colour of node {cm}"), with_nodes(&tf, c, op.clone())));
    if op.len() > 2 {
        let mut o = op.clone();
        o[mid].x += 0.02 * (op[mid + 1].x - op[mid].x);
        edits.push((format!("node {mid} moved along s"), with_nodes(&tf, col.clone(), o)));
    }
    let base = Table3d::build(&tf, &domain, &p).expect("bake");
    for (name, new) in &edits {
        let (ms, (_, st)) = best_rebake(repeats, &base, &tf, new);
        println!(
            "rebake, {name}: {ms:.1} ms, {} of {} pairs{}",
            st.pairs_rebaked,
            st.pairs,
            st.full.map_or(String::new(), |f| format!(" (full: {f:?})"))
        );
    }
}

/// Best time of `Table3d::rebake` alone (each run on a fresh clone).
fn best_rebake(
    repeats: usize,
    base: &Table3d,
    old: &TransferFunction,
    new: &TransferFunction,
) -> (f64, (Table3d, tet_preint::RebakeStats)) {
    let mut best = f64::INFINITY;
    let mut out = None;
    for _ in 0..repeats {
        let mut t = base.clone();
        let t0 = Instant::now();
        let st = t.rebake(old, new).expect("rebake");
        best = best.min(t0.elapsed().as_secs_f64());
        out = Some((t, st));
    }
    (best * 1e3, out.expect("repeats ≥ 1"))
}
