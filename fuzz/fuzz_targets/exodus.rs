#![no_main]
use libfuzzer_sys::fuzz_target;

// The first byte picks the time step (0-3), the rest is the file.
fuzz_target!(|data: &[u8]| {
    let Some((&step, file)) = data.split_first() else { return };
    let opts = tet_io::exodus::ExodusOptions { time_step: Some(usize::from(step & 3)) };
    let _ = tet_io::exodus::read(file, &opts);
});
