#![no_main]
//! Any legacy VTK file the reader accepts must convert to a valid mesh or a
//! clean error: the invariant checkers hold on every success.
use libfuzzer_sys::fuzz_target;

fuzz_target!(|data: &[u8]| {
    let Ok(src) = tet_io::read_bytes(data, tet_io::Format::VtkLegacy) else { return };
    if src.points.len() > 100_000 {
        return;
    }
    let opts = tet_mesh::ConvertOptions { nan: tet_mesh::NanPolicy::Drop, ..Default::default() };
    if let Ok((mesh, _)) = tet_mesh::tetrahedralize(&src, &opts, &mut |_| {}) {
        tet_mesh::check_tet_mesh(&mesh).unwrap();
        if let Ok(adj) = tet_mesh::build_adjacency(&mesh.points, &mesh.tets) {
            tet_mesh::check_adjacency(&mesh.tets, &adj).unwrap();
        }
    }
});
