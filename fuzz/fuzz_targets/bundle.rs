#![no_main]
use libfuzzer_sys::fuzz_target;
use std::path::Path;

fuzz_target!(|data: &[u8]| {
    let from_bytes = tet_bundle::Bundle::from_bytes(data, Path::new("fuzz.tetb"));
    if let Ok(b) = &from_bytes {
        // Whatever is accepted must round-trip.
        let again = tet_bundle::Bundle::from_bytes(&b.to_bytes(), Path::new("fuzz.tetb")).unwrap();
        assert_eq!(again.mesh, b.mesh);
    }
    // The file reader (section by section, tet_container::SectionFile)
    // agrees with the bytes' parser: the same bundle, or an error.
    let path = std::env::temp_dir().join(format!("tetkit-fuzz-bundle-{}.tetb", std::process::id()));
    std::fs::write(&path, data).unwrap();
    let from_file = tet_bundle::Bundle::read(&path);
    match (&from_file, &from_bytes) {
        (Ok(x), Ok(y)) => assert_eq!(x, y),
        (Err(_), Err(_)) => {}
        (x, y) => panic!("the file reader gave {:?}, the bytes' parser {:?}", x.is_ok(), y.is_ok()),
    }
    // An accepted bundle streamed (mesh and neighbours first, the rest at
    // finish, tet_bundle::BundleStream) reads back as itself.
    if let Ok(b) = &from_bytes {
        let streamed = std::env::temp_dir().join(format!("tetkit-fuzz-stream-{}.tetb", std::process::id()));
        let mut s = tet_bundle::BundleStream::create(&streamed).unwrap();
        s.write_mesh(&b.mesh).unwrap();
        s.write_neighbors(&b.adjacency.neighbors).unwrap();
        s.finish(b).unwrap();
        assert_eq!(&tet_bundle::Bundle::read(&streamed).unwrap(), b);
    }
});
