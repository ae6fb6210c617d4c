#![no_main]
use libfuzzer_sys::fuzz_target;
use tet_io::plot3d::{read, Plot3dOptions};

// The first byte picks where the input splits into grid and Q file and
// whether the planes layout is assumed; the rest is the two files.
fuzz_target!(|data: &[u8]| {
    let Some((&control, rest)) = data.split_first() else { return };
    let split = rest.len() * usize::from(control & 0x7f) / 127;
    let (xyz, q) = rest.split_at(split.min(rest.len()));
    let opts = Plot3dOptions { planes: control & 0x80 != 0, ..Default::default() };
    let _ = read(xyz, None, &opts);
    let _ = read(xyz, Some(q), &opts);
});
