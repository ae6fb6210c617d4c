#![no_main]
use libfuzzer_sys::fuzz_target;

// The input is split at its first NUL byte: the SU2 mesh before, a CSV
// solution after (attached when the mesh reads).
fuzz_target!(|data: &[u8]| {
    let split = data.iter().position(|&b| b == 0).unwrap_or(data.len());
    let (mesh, csv) = data.split_at(split);
    if let Ok(mut m) = tet_io::su2::read(mesh) {
        let _ = tet_io::su2::attach_solution(&mut m, csv.get(1..).unwrap_or(&[]));
    }
});
