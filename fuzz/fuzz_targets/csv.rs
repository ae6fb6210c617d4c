#![no_main]
use libfuzzer_sys::fuzz_target;

// The first byte picks a column spec (none, or one of a few), the rest is the table.
fuzz_target!(|data: &[u8]| {
    let Some((&pick, table)) = data.split_first() else { return };
    let specs: [&[&str]; 3] = [&["x", "y", "z"], &["v", "_", "x", "y", "z"], &["X", "y", "Z", "x"]];
    let spec: Option<Vec<String>> = match pick % 4 {
        0 => None,
        k => Some(specs[k as usize - 1].iter().map(|s| s.to_string()).collect()),
    };
    if let Ok(m) = tet_io::csv::read(table, spec.as_deref()) {
        m.check().expect("reader output satisfies SourceMesh invariants");
    }
});
