#![no_main]
use libfuzzer_sys::fuzz_target;
use tet_io::cursor::Endian;
use tet_io::raw::{parse_scalar_type, read, RawSpec};

// The first 8 bytes choose the spec (dims up to 31³, type, order, header
// bytes); the rest is the file.
fuzz_target!(|data: &[u8]| {
    let Some((spec_bytes, file)) = data.split_first_chunk::<8>() else { return };
    let types = ["i8", "u8", "i16", "u16", "i32", "u32", "i64", "u64", "f32", "f64"];
    let Some(ty) = parse_scalar_type(types[usize::from(spec_bytes[3]) % types.len()]) else { return };
    let spec = RawSpec {
        dims: [usize::from(spec_bytes[0] & 31), usize::from(spec_bytes[1] & 31), usize::from(spec_bytes[2] & 31)],
        scalar_type: ty,
        endian: if spec_bytes[4] & 1 == 0 { Endian::Little } else { Endian::Big },
        spacing: [1.0, f64::from(spec_bytes[5]), 0.5],
        origin: [0.0; 3],
        header_bytes: usize::from(u16::from_le_bytes([spec_bytes[6], spec_bytes[7]])),
        name: "v".into(),
    };
    let _ = read(file, &spec);
});
