#![no_main]
use libfuzzer_sys::fuzz_target;

fuzz_target!(|data: &[u8]| {
    if let Ok(m) = tet_io::ply::read(data) {
        m.check().expect("reader output satisfies SourceMesh invariants");
    }
});
