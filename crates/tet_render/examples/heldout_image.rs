//! Figures for crates/tetlut/results/certified.md (issue 16), as
//! tests/heldout_image.rs but before and after, every TF, SIZE² (default 256):
//!
//!     cargo run --release -p tet_render --example heldout_image [SIZE]
//!
//! Issue 16 at the image level: the default table3d bake (certified to
//! 1e-3 per segment) on the bundled NASA Blunt Fin with held-out TFs
//! (crates/tet_preint/tests/data/heldout: sharp nodes, narrow peaks) against
//! the f64 reference ray caster, at 96², linear max over R, G, B, A with no
//! tone mapping. Before the certify-and-refine bake the sharp TF missed
//! 1/255 (crates/tetlut/results/certified.md).
use std::sync::Arc;
use tet_io::{read_file, ReadOptions};
use tet_mesh::{tetrahedralize, ConvertOptions};
use tet_preint::{make_shader, tf_for_domain, BakeOptions, Method, SegmentShader, TransferFunction};
use tet_render::{Camera, ReferenceOptions, ReferenceRenderer};

// The held-out TFs and the comparison, as tests/heldout_image.rs.
#[path = "../tests/common/heldout.rs"]
mod heldout_data;
use heldout_data::{diff, framed, heldout, renderer_at, root};

fn main() {
    let size: u32 = std::env::args().nth(1).map_or(256, |s| s.parse().unwrap());
    let data = root().join("tests/data/plot3d");
    let opts = ReadOptions { q_path: Some(data.join("bluntfinq.bin")), ..Default::default() };
    let src = read_file(&data.join("bluntfinxyz.bin"), &opts).unwrap();
    let conv = ConvertOptions { scalar: Some("density".into()), ..Default::default() };
    let (mesh, _) = tetrahedralize(&src, &conv, &mut |_| {}).unwrap();
    let (adj, domain, view) = framed(&mesh, size, 40.0, 25.0);
    let cam = Camera::new(&view).unwrap();
    let reference = ReferenceRenderer::new(&mesh, &adj).unwrap();
    let mut r = renderer_at(&mesh, &view);
    println!("| TF | before: linear max, px > 1/255, frame ms | after: linear max, px > 1/255, frame ms | bake ms before / after |");
    println!("|---|---|---|---|");
    let sample = root().join("formats/samples/tf_normalized.json");
    let sample = TransferFunction::from_json(&std::fs::read_to_string(sample).unwrap()).unwrap();
    let mut tfs = vec![("tf_normalized (sample)".to_string(), sample)];
    for n in ["tf_peaks12", "tf_sharp8", "tf_steps", "tf_plateaus"] {
        tfs.push((n.to_string(), heldout(&format!("{n}.json"))));
    }
    for (name, tfn) in tfs {
        let tf = tf_for_domain(&tfn, &domain).unwrap();
        let (want, _) = reference.render(&cam, &tf, &ReferenceOptions::default(), &|_, _| {}).unwrap();
        let mut cells = Vec::new();
        for certify in [false, true] {
            let mut o = BakeOptions::default();
            if !certify {
                o.certify = tet_preint::CertifyOptions::off();
            }
            let t0 = std::time::Instant::now();
            let shader: Arc<dyn SegmentShader> = make_shader(Method::Table3d, &tf, &domain, &o).unwrap().into();
            let bake = t0.elapsed().as_secs_f64() * 1e3;
            r.set_shader(shader);
            r.render(&|_, _| {}).unwrap();
            let t1 = std::time::Instant::now();
            let (got, _) = r.render(&|_, _| {}).unwrap();
            let frame = t1.elapsed().as_secs_f64() * 1e3;
            let (max, over) = diff(&got, &want);
            cells.push((format!("{max:.2e} ({:.2}/255), {over}, {frame:.0}", max * 255.0), bake));
        }
        println!("| {name} | {} | {} | {:.0} / {:.0} |", cells[0].0, cells[1].0, cells[0].1, cells[1].1);
    }
}
