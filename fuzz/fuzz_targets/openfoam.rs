#![no_main]
use libfuzzer_sys::fuzz_target;

// The input is split at NUL bytes into the four polyMesh files: points,
// faces, owner, neighbour (missing parts are empty). A mesh that reads must
// satisfy SourceMesh's invariants and tetrahedralize without panicking.
fuzz_target!(|data: &[u8]| {
    let mut parts = data.splitn(4, |&b| b == 0);
    let mut next = || parts.next().unwrap_or(&[]);
    let (points, faces, owner, neighbour) = (next(), next(), next(), next());
    if let Ok(m) = tet_io::openfoam::read_poly_mesh(points, faces, owner, neighbour) {
        assert!(m.check().is_ok());
        let _ = tet_mesh::tetrahedralize(&m, &tet_mesh::ConvertOptions::default(), &mut |_| {});
    }
});
