//! The whole tetkit path as a library, on the bundled Blunt Fin data (NASA,
//! see tests/data/plot3d/LICENSE.md): read PLOT3D, convert the curvilinear
//! grid to tets, build the bundle in memory, bake the default method's table
//! (table3d) for a transfer function, render on the CPU and write a PNG —
//! what `tetprep convert`, `tetlut bake` and `tetview render` do in turn.
//! With `--check`, it then renders the same view with the exact ray-cast
//! reference (`tetview reference`) and prints the image error, the figure
//! every method is judged by.
//!
//!     cargo run --release --example render_image -- [OUT.png] [AZIMUTH_DEG] [--check]
use std::path::Path;
use tetkit::bundle::{Bundle, BundleMeta};
use tetkit::engine::{
    resolve_tf, CpuFrameRenderer, FrameRenderer, FrameRequest, FrameStats, Look, ReferenceFrameRenderer, TfRequest,
    TfSource,
};
use tetkit::io::{read_file, ReadOptions};
use tetkit::mesh::{build_adjacency, tetrahedralize, ConvertOptions};
use tetkit::preint::Method;
use tetkit::render::{diff, image::diff_rgba8, Display, ViewSpec};

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let (flags, mut args): (Vec<String>, Vec<String>) = std::env::args().skip(1).partition(|a| a.starts_with("--"));
    let check = match flags.as_slice() {
        [] => false,
        [f] if f == "--check" => true,
        _ => return Err(format!("unknown flags {flags:?} (only --check)").into()),
    };
    args.reverse();
    let out = args.pop().unwrap_or_else(|| "bluntfin.png".into());
    let azimuth: f64 = args.pop().map_or(Ok(30.0), |a| a.parse())?;
    let root = Path::new(env!("CARGO_MANIFEST_DIR"));
    let data = root.join("tests/data/plot3d");

    // Read and convert: PLOT3D grid + Q file, the density as the scalar.
    let read = ReadOptions { q_path: Some(data.join("bluntfinq.bin")), ..Default::default() };
    let source = read_file(&data.join("bluntfinxyz.bin"), &read)?;
    let convert = ConvertOptions { scalar: Some("density".into()), ..Default::default() };
    let (mesh, _report) = tetrahedralize(&source, &convert, &mut |_| {})?;
    let adjacency = build_adjacency(&mesh.points, &mesh.tets)?;
    let bundle = Bundle::new(mesh, adjacency, BundleMeta::default());
    let stats = &bundle.meta.stats;
    println!("{} tets, density in [{:.3}, {:.3}]", bundle.mesh.tets.len(), stats.scalar_min, stats.scalar_max);

    // The demo's transfer function (formats/tf.md): normalized, so the
    // engine stretches its [0, 1] over the data's range.
    let tf_path = root.join("formats/samples/tf_normalized.json");
    let request = TfRequest { source: TfSource::File(tf_path), ..TfRequest::default() };
    let tf = resolve_tf(&bundle, &request)?.tf;

    // Bake the table over the (Sf, Sb, l) the bundle's segments can reach.
    let look = Look::bake(&bundle, Method::Table3d, tf)?;
    println!("table3d baked in {:.0} ms", look.shader_seconds * 1e3);

    // Render: a view that frames the bounds, turned by the azimuth; cells
    // the TF makes fully transparent are culled (the request's default).
    let mut renderer = CpuFrameRenderer::new(&bundle)?;
    let (lo, hi) = renderer.renderer().scene().bounds();
    let view = ViewSpec::framing(lo, hi, [512, 512]).orbit(azimuth, 20.0, 1.0);
    let frame = renderer.render(&look, &FrameRequest::new(view.clone()), &|_, _| {})?;
    let (image, FrameStats::Cpu(st)) = (frame.image, frame.stats) else { unreachable!("CPU statistics") };
    println!(
        "{} of {} tets drawn, {} fragments, {:.0} ms ({:.2} M tets/s)",
        st.tets_drawn,
        bundle.mesh.tets.len(),
        st.fragments,
        st.total_seconds * 1e3,
        st.tets_per_second() / 1e6
    );

    // 8-bit sRGB after Reinhard tone mapping, over black.
    let display = Display::default();
    image.write_png(Path::new(&out), &display)?;
    println!("wrote {out}");

    if check {
        // Exact ray–tet segments, exact integration, f64 compositing.
        let t0 = std::time::Instant::now();
        let mut exact = ReferenceFrameRenderer::new(&bundle)?;
        let reference = exact.render(&Look::exact(look.tf.clone()), &FrameRequest::new(view), &|_, _| {})?.image;
        let err = diff(&image, &reference)?;
        let max_8bit = diff_rgba8(&image.to_rgba8(&display), &reference.to_rgba8(&display));
        println!(
            "against the exact reference ({:.1} s): RMSE {:.2e}, max {:.2e} (linear premultiplied RGBA), 8-bit max {max_8bit}/255",
            t0.elapsed().as_secs_f64(),
            err.rmse,
            err.max_abs
        );
    }
    Ok(())
}
