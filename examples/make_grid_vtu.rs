//! Writes an N³-point grid, tetrahedralized (conforming 6-tet split), as a
//! binary appended VTU with a smooth scalar — the ≥1M-tet benchmark input.
//!
//!     cargo run --release --example make_grid_vtu -- 100 out/grid100.vtu
use tetkit::mesh::split::{structured_grid_tets, structured_points};
use tetkit::mesh::SplitMode;

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let mut args = std::env::args().skip(1);
    let n: usize = args.next().unwrap_or_else(|| "100".into()).parse()?;
    let out = args.next().unwrap_or_else(|| format!("grid{n}.vtu"));
    let h = 1.0 / (n - 1) as f64;
    let points = structured_points([n; 3], |ijk| ijk.map(|x| x as f64 * h));
    let scalar: Vec<f64> = points.iter().map(|p| (6.0 * p[0]).sin() * (4.0 * p[1]).cos() + p[2] * p[2]).collect();
    let tets = structured_grid_tets([n - 1; 3], SplitMode::Six);
    let file = std::io::BufWriter::new(std::fs::File::create(&out)?);
    let field = tetkit::mesh::Field::new("wave", 1, scalar);
    tetkit::io::vtk_xml::write_vtu(file, &points, &tets, &[field], &[])?;
    println!("wrote {out}: {} points, {} tets", points.len(), tets.len());
    Ok(())
}
