//! Writes an N³-point grid, tetrahedralized (conforming 6-tet split), as a
//! binary appended VTU with a smooth scalar — the ≥1M-tet benchmark input.
//!
//!     cargo run --release --example make_grid_vtu -- 100 out/grid100.vtu
use tetkit::mesh::split::split_hexahedron;

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let mut args = std::env::args().skip(1);
    let n: usize = args.next().unwrap_or_else(|| "100".into()).parse()?;
    let out = args.next().unwrap_or_else(|| format!("grid{n}.vtu"));
    let h = 1.0 / (n - 1) as f64;
    let mut points = Vec::with_capacity(n * n * n);
    for k in 0..n {
        for j in 0..n {
            for i in 0..n {
                points.push([i as f64 * h, j as f64 * h, k as f64 * h]);
            }
        }
    }
    let scalar: Vec<f64> = points.iter().map(|p| (6.0 * p[0]).sin() * (4.0 * p[1]).cos() + p[2] * p[2]).collect();
    let id = |i: usize, j: usize, k: usize| (i + n * (j + n * k)) as u32;
    let mut tets = Vec::with_capacity((n - 1).pow(3) * 6);
    for k in 0..n - 1 {
        for j in 0..n - 1 {
            for i in 0..n - 1 {
                let hex = [
                    id(i, j, k),
                    id(i + 1, j, k),
                    id(i + 1, j + 1, k),
                    id(i, j + 1, k),
                    id(i, j, k + 1),
                    id(i + 1, j, k + 1),
                    id(i + 1, j + 1, k + 1),
                    id(i, j + 1, k + 1),
                ];
                split_hexahedron(&hex, &mut |t| tets.push(t));
            }
        }
    }
    let file = std::io::BufWriter::new(std::fs::File::create(&out)?);
    let field = tetkit::mesh::Field::new("wave", 1, scalar);
    tetkit::io::vtk_xml::write_vtu(file, &points, &tets, &[field], &[])?;
    println!("wrote {out}: {} points, {} tets", points.len(), tets.len());
    Ok(())
}
