#![no_main]
use libfuzzer_sys::fuzz_target;

// The first byte picks the index kind (even: .pvd XML, odd: .series JSON),
// the rest is the index. Listed files are looked up relative to a directory
// holding none, so entries end in "does not exist" or in a parse error:
// what is exercised is the parsing, never a panic.
fuzz_target!(|data: &[u8]| {
    let Some((&kind, text)) = data.split_first() else { return };
    let index = std::path::Path::new("/nonexistent-fuzz-dir/series");
    let _ = if kind & 1 == 0 {
        tet_io::series::parse_pvd(text, index)
    } else {
        tet_io::series::parse_series_json(text, index)
    };
});
