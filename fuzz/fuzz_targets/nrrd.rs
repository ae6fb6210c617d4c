#![no_main]
use libfuzzer_sys::fuzz_target;

// The whole input is the header (plus attached data); a detached data file,
// if the header names one, is the input itself again.
fuzz_target!(|data: &[u8]| {
    let _ = tet_io::nrrd::read(data, &mut |_name: &str| Ok(data.to_vec()));
});
