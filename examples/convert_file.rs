//! Read any supported input, convert it to tets and print what happened —
//! the library path behind `tetprep convert`, without writing a bundle.
//!
//!     cargo run --release --example convert_file -- tests/data/vtk/post.vtk [SCALAR]
use tetkit::io::{read_file, ReadOptions};
use tetkit::mesh::{build_adjacency, mesh_stats, tetrahedralize, ConvertOptions};

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let mut args = std::env::args().skip(1);
    let path = args.next().ok_or("usage: convert_file INPUT [SCALAR]")?;
    let source = read_file(path.as_ref(), &ReadOptions::default())?;
    println!("{}: {} points, {} cells ({})", path, source.points.len(), source.num_cells(), source.format);
    let opts = ConvertOptions { scalar: args.next(), ..Default::default() };
    let (mesh, report) = tetrahedralize(&source, &opts, &mut |step| eprintln!("  {step:?}…"))?;
    let adjacency = build_adjacency(&mesh.points, &mesh.tets)?;
    let stats = mesh_stats(&mesh.points, &mesh.tets, &mesh.scalar);
    println!(
        "{} tets, {} points, scalar {} in [{}, {}]",
        mesh.tets.len(),
        mesh.points.len(),
        mesh.scalar_name,
        stats.scalar_min,
        stats.scalar_max
    );
    println!(
        "total volume {}, {} boundary faces, convex: {}",
        stats.total_volume,
        adjacency.boundary_faces.len(),
        adjacency.convex
    );
    for f in &report.findings {
        println!("  - {f}");
    }
    Ok(())
}
