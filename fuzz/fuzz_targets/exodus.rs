#![no_main]
use libfuzzer_sys::fuzz_target;

// The first byte picks the time step (0-3), the rest is the file: read
// whole, and that step's fields alone (as a time series reads later steps).
fuzz_target!(|data: &[u8]| {
    let Some((&step, file)) = data.split_first() else { return };
    let opts = tet_io::exodus::ExodusOptions { time_step: Some(usize::from(step & 3)) };
    let _ = tet_io::exodus::read(file, &opts);
    let _ = tet_io::exodus::read_step_fields(file, usize::from(step & 3));
});
