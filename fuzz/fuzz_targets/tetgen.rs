#![no_main]
use libfuzzer_sys::fuzz_target;

// The input is split at its first NUL byte: .node before, .ele after.
fuzz_target!(|data: &[u8]| {
    let split = data.iter().position(|&b| b == 0).unwrap_or(data.len());
    let (node, ele) = data.split_at(split);
    let ele = ele.get(1..).unwrap_or(&[]);
    let _ = tet_io::tetgen::read(node, ele);
});
