#![no_main]
use libfuzzer_sys::fuzz_target;

fuzz_target!(|data: &[u8]| {
    if let Ok(b) = tet_bundle::Bundle::from_bytes(data, std::path::Path::new("fuzz.tetb")) {
        // Whatever is accepted must round-trip.
        let again = tet_bundle::Bundle::from_bytes(&b.to_bytes(), std::path::Path::new("fuzz.tetb")).unwrap();
        assert_eq!(again.mesh, b.mesh);
    }
});
