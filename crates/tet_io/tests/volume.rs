//! Raw and NRRD volume readers on a 16³ sub-block of the real ironProt
//! volume, written in every variant by Teem's `unu` (see
//! tests/data/volume/LICENSE.md for the commands).

mod common;

use common::Lcg;
use tet_io::cursor::{Endian, ScalarType};
use tet_io::raw::{self, parse_scalar_type, RawSpec};
use tet_io::{nrrd, FormatError, Location};
use tet_mesh::{Block, SourceMesh};

const DIR: &str = concat!(env!("CARGO_MANIFEST_DIR"), "/../../tests/data/volume/");

fn load(name: &str) -> Vec<u8> {
    std::fs::read(format!("{DIR}{name}")).unwrap_or_else(|e| panic!("{name}: {e}"))
}

/// Loads detached data files from the test data directory, as the CLI does
/// relative to the header's directory.
fn from_dir(name: &str) -> std::io::Result<Vec<u8>> {
    std::fs::read(format!("{DIR}{name}"))
}

fn read_nrrd(name: &str) -> Result<SourceMesh, FormatError> {
    nrrd::read(&load(name), &mut from_dir)
}

/// The sub-block's voxels as f64, straight from the raw bytes.
fn iron_values() -> Vec<f64> {
    load("iron16.raw").iter().map(|&b| f64::from(b)).collect()
}

fn iron_spec() -> RawSpec {
    RawSpec {
        dims: [16, 16, 16],
        scalar_type: ScalarType::U8,
        endian: Endian::Little,
        spacing: [1.0; 3],
        origin: [26.0; 3],
        header_bytes: 0,
        name: "density".into(),
    }
}

#[test]
fn raw_iron_block() {
    let m = raw::read(&load("iron16.raw"), &iron_spec()).unwrap();
    assert_eq!(m.points.len(), 4096);
    assert_eq!(m.num_cells(), 15 * 15 * 15);
    assert_eq!(m.blocks, vec![Block::Structured { dims: [16, 16, 16], first_point: 0 }]);
    let f = &m.point_fields[0];
    assert_eq!((f.name.as_str(), f.num_components), ("density", 1));
    assert_eq!(f.values.iter().sum::<f64>(), 399_019.0);
    assert_eq!(f.values[16 * 16 * 8 + 16 * 8 + 8], 130.0);
    assert_eq!(m.points[0], [26.0; 3]);
    assert_eq!(m.points[4095], [41.0; 3]);
    assert_eq!(m.points[1 + 16 * 2 + 256 * 3], [27.0, 28.0, 29.0]);
    assert!(m.notes.is_empty());
}

#[test]
fn raw_header_bytes_endianness_and_sizes() {
    // The ushort file has 7 junk bytes before little-endian samples.
    let spec = RawSpec { scalar_type: ScalarType::U16, header_bytes: 7, ..iron_spec() };
    let m = raw::read(&load("iron16_u16_skip.dat"), &spec).unwrap();
    assert_eq!(m.point_fields[0].values, iron_values());
    // Read as big-endian the same bytes give byte-swapped values.
    let be = raw::read(&load("iron16_u16_skip.dat"), &RawSpec { endian: Endian::Big, ..spec.clone() }).unwrap();
    assert_eq!(be.point_fields[0].values[4095], iron_values()[4095] * 256.0);

    let bytes = load("iron16.raw");
    let e = raw::read(&bytes[..4000], &iron_spec()).unwrap_err();
    assert!(e.message.contains("4096 bytes expected, file has 4000"), "{}", e.message);
    let mut longer = bytes.clone();
    longer.extend([1, 2, 3]);
    let m = raw::read(&longer, &iron_spec()).unwrap();
    assert!(m.notes.iter().any(|n| n.contains("3 bytes after")), "{:?}", m.notes);
    // Spacing scales the lattice.
    let m = raw::read(&bytes, &RawSpec { spacing: [0.5, 1.0, 2.0], origin: [0.0; 3], ..iron_spec() }).unwrap();
    assert_eq!(m.points[4095], [7.5, 15.0, 30.0]);
    for (s, t) in
        [("u8", ScalarType::U8), ("int16", ScalarType::I16), ("float", ScalarType::F32), ("f64", ScalarType::F64)]
    {
        assert_eq!(parse_scalar_type(s), Some(t));
    }
}

#[test]
fn nrrd_encodings_agree_with_raw() {
    let expected = iron_values();
    for name in
        ["iron16_raw.nrrd", "iron16_gzip.nrrd", "iron16_ascii.nrrd", "iron16_detached.nhdr", "iron16_gz_detached.nhdr"]
    {
        let m = read_nrrd(name).unwrap_or_else(|e| panic!("{name}: {e}"));
        assert_eq!(m.blocks, vec![Block::Structured { dims: [16, 16, 16], first_point: 0 }], "{name}");
        let f = &m.point_fields[0];
        assert_eq!((f.name.as_str(), f.num_components), ("ironProt", 1), "{name}");
        assert_eq!(f.values, expected, "{name}");
        // Space origin (26,26,26) with unit space directions.
        assert_eq!(m.points[0], [26.0; 3], "{name}");
        assert_eq!(m.points[4095], [41.0; 3], "{name}");
        assert_eq!(m.points[3 + 16 * 5 + 256 * 7], [29.0, 31.0, 33.0], "{name}");
    }
    assert!(read_nrrd("iron16_gzip.nrrd").unwrap().format.contains("gzip"));
    assert!(read_nrrd("iron16_detached.nhdr").unwrap().format.contains("detached"));
}

#[test]
fn nrrd_float_big_endian_with_spacings() {
    let m = read_nrrd("iron16_float_be.nrrd").unwrap();
    let f = &m.point_fields[0];
    assert_eq!(f.name, "density");
    let halves: Vec<f64> = iron_values().iter().map(|v| v * 0.5).collect();
    assert_eq!(f.values, halves);
    assert_eq!(m.points[0], [0.0; 3]);
    assert_eq!(m.points[4095], [7.5; 3]);
}

#[test]
fn nrrd_skips() {
    let expected = iron_values();
    for name in ["iron16_u16_skip.nhdr", "iron16_u16_lines.nhdr", "iron16_u16_end.nhdr"] {
        let m = read_nrrd(name).unwrap_or_else(|e| panic!("{name}: {e}"));
        assert_eq!(m.point_fields[0].values, expected, "{name}");
        assert_eq!(m.point_fields[0].name, "scalars", "{name}");
    }
}

#[test]
fn nrrd_leading_vector_axis() {
    let m = read_nrrd("iron16_vec3.nrrd").unwrap();
    assert_eq!(m.points.len(), 4096);
    let f = &m.point_fields[0];
    assert_eq!(f.num_components, 3);
    for (t, &v) in iron_values().iter().enumerate() {
        assert_eq!(&f.values[3 * t..3 * t + 3], &[v, 255.0 - v, (v / 2.0).floor()], "voxel {t}");
    }
}

#[test]
fn nrrd_detached_errors_are_companion_errors() {
    let header = load("iron16_detached.nhdr");
    let mut missing = |_: &str| -> std::io::Result<Vec<u8>> { Err(std::io::ErrorKind::NotFound.into()) };
    let e = nrrd::read(&header, &mut missing).unwrap_err();
    assert!(e.in_companion && e.message.contains("iron16.raw"), "{e}");
    let mut short = |_: &str| -> std::io::Result<Vec<u8>> { Ok(vec![0u8; 100]) };
    let e = nrrd::read(&header, &mut short).unwrap_err();
    assert!(e.in_companion && e.message.contains("4096 bytes expected, 100 present"), "{e}");
    let gz_header = load("iron16_gz_detached.nhdr");
    let mut not_gzip = |_: &str| -> std::io::Result<Vec<u8>> { Ok(vec![7u8; 100]) };
    let e = nrrd::read(&gz_header, &mut not_gzip).unwrap_err();
    assert!(e.in_companion, "{e}");
    // Attached-data errors are not companion errors.
    let raw = load("iron16_raw.nrrd");
    let e = nrrd::read(&raw[..raw.len() - 10], &mut missing).unwrap_err();
    assert!(!e.in_companion && e.message.contains("truncated"), "{e}");
}

fn gzip(bytes: &[u8]) -> Vec<u8> {
    use std::io::Write;
    let mut enc = flate2::write::GzEncoder::new(Vec::new(), flate2::Compression::best());
    enc.write_all(bytes).unwrap();
    enc.finish().unwrap()
}

#[test]
fn nrrd_gzip_output_is_bounded() {
    // 64 MiB of zeros compress to ~64 KiB; the header asks for 8 bytes.
    let bomb = gzip(&vec![0u8; 64 << 20]);
    let mut b = b"NRRD0004\ntype: uchar\ndimension: 3\nsizes: 2 2 2\nencoding: gzip\n\n".to_vec();
    b.extend(&bomb);
    let m = nrrd::read(&b, &mut from_dir).unwrap();
    assert_eq!(m.point_fields[0].values, vec![0.0; 8]);
    assert!(m.notes.iter().any(|n| n.contains("more bytes")), "{:?}", m.notes);
    // A header promising more than the stream holds is an error.
    let mut b = b"NRRD0004\ntype: float\ndimension: 3\nsizes: 1000 1000 1000\nendian: big\nencoding: gzip\n\n".to_vec();
    b.extend(gzip(&[1, 2, 3]));
    let e = nrrd::read(&b, &mut from_dir).unwrap_err();
    assert!(e.message.contains("decompress to 3 bytes"), "{}", e.message);
}

#[test]
fn nrrd_hostile_headers() {
    let cases: &[&[u8]] = &[
        b"",
        b"NRRD",
        b"NRRD0006\n\n",
        b"NRRD0004\ntype: uchar\ndimension: 3\nsizes: 18446744073709551615 2 2\nencoding: raw\n\n",
        b"NRRD0004\ntype: uchar\ndimension: 3\nsizes: -1 2 2\nencoding: raw\n\n",
        b"NRRD0004\ntype: uchar\ndimension: 3\nsizes: 0 2 2\nencoding: raw\n\n",
        b"NRRD0004\ntype: uchar\ndimension: 3\nsizes: 2 2\nencoding: raw\n\n",
        b"NRRD0004\ntype: uchar\ndimension: 2\nsizes: 2 2\nencoding: raw\n\n0000",
        b"NRRD0004\ntype: uchar\ndimension: 4\nsizes: 9 2 2 2\nencoding: raw\n\n",
        b"NRRD0004\ntype: block\ndimension: 3\nsizes: 2 2 2\nencoding: raw\n\n",
        b"NRRD0004\ntype: short\ndimension: 3\nsizes: 2 2 2\nencoding: raw\n\n0123456789abcdef",
        b"NRRD0004\ntype: uchar\ndimension: 3\nsizes: 2 2 2\nencoding: bzip2\n\n",
        b"NRRD0004\ntype: uchar\ndimension: 3\nsizes: 2 2 2\nencoding: raw\nbyte skip: -5\n\n01234567",
        b"NRRD0004\ntype: uchar\ndimension: 3\nsizes: 2 2 2\nencoding: raw\nbyte skip: 99999999999\n\n01234567",
        b"NRRD0004\ntype: uchar\ndimension: 3\nsizes: 2 2 2\nencoding: raw\nline skip: 5\n\n01234567",
        b"NRRD0004\ntype: uchar\ndimension: 3\nsizes: 2 2 2\nencoding: raw\nspace directions: (1,0) (0,1,0) (0,0,1)\n\n01234567",
        b"NRRD0004\ntype: uchar\ndimension: 3\nsizes: 2 2 2\nencoding: raw\nspace directions: (1,0,0) none (0,0,1)\n\n01234567",
        b"NRRD0004\ntype: uchar\ndimension: 3\nsizes: 2 2 2\nencoding: raw\nspace origin: (1,x,0)\n\n01234567",
        b"NRRD0004\ntype: uchar\ndimension: 3\nsizes: 2 2 2\nencoding: ascii\n\n1 2 3 x",
        b"NRRD0004\ntype: uchar\ndimension: 3\nsizes: 2 2 2\nencoding: ascii\n\n1 2 3",
        b"NRRD0004\ntype: uchar\ndimension: 3\nsizes: 2 2 2\nencoding: raw\ndata file: LIST\n",
        b"NRRD0004\ntype: uchar\ndimension: 3\nsizes: 2 2 2\nencoding: raw\n",
        b"NRRD0004\nno colon here\n\n",
    ];
    for (i, c) in cases.iter().enumerate() {
        let r = nrrd::read(c, &mut from_dir);
        assert!(r.is_err(), "case {i} should fail: {r:?}");
    }
    // Small valid ones with key/values, comments and CRLF line ends.
    let ok = b"NRRD0005\r\n# comment\r\ntype: int8\r\ndimension: 3\r\nsizes: 2 2 2\r\nencoding: raw\r\nmy key:=has: colons\r\nspacings: 2 2 2\r\naxis mins: 1 1 1\r\n\r\n\x01\x02\x03\x04\x05\x06\x07\xff";
    let m = nrrd::read(ok, &mut from_dir).unwrap();
    assert_eq!(m.point_fields[0].values, vec![1.0, 2.0, 3.0, 4.0, 5.0, 6.0, 7.0, -1.0]);
    assert_eq!(m.points[7], [3.0, 3.0, 3.0]);
    let e =
        nrrd::read(b"NRRD0004\ntype: uchar\ndimension: 3\nsizes: 2 2 2\nencoding: raw\n", &mut from_dir).unwrap_err();
    assert!(e.message.contains("no data"), "{}", e.message);
    assert!(matches!(e.at, Location::Line(_)));
}

#[test]
fn corrupted_volumes_never_panic() {
    let mut rng = Lcg(42);
    for name in [
        "iron16_raw.nrrd",
        "iron16_gzip.nrrd",
        "iron16_ascii.nrrd",
        "iron16_float_be.nrrd",
        "iron16_vec3.nrrd",
        "iron16_u16_skip.nhdr",
        "iron16_u16_end.nhdr",
    ] {
        let bytes = load(name);
        for _ in 0..200 {
            let _ = nrrd::read(&bytes[..rng.below(bytes.len())], &mut from_dir);
            let mut bad = bytes.clone();
            // Half the flips land in the header, where they matter most.
            let at = if rng.below(2) == 0 { rng.below(bad.len().min(300)) } else { rng.below(bad.len()) };
            bad[at] ^= 1 << rng.below(8);
            let _ = nrrd::read(&bad, &mut from_dir);
        }
    }
    let data = load("iron16.raw.gz");
    let header = load("iron16_gz_detached.nhdr");
    for _ in 0..200 {
        let mut bad = data.clone();
        let at = rng.below(bad.len());
        bad[at] ^= 0x10;
        let cut = rng.below(data.len());
        let _ = nrrd::read(&header, &mut |_| Ok(bad.clone()));
        let _ = nrrd::read(&header, &mut |_| Ok(data[..cut].to_vec()));
    }
    let raw_bytes = load("iron16.raw");
    for _ in 0..200 {
        let cut = rng.below(raw_bytes.len() + 1);
        let _ = raw::read(&raw_bytes[..cut], &iron_spec());
    }
    let hostile = RawSpec { dims: [usize::MAX, usize::MAX, 2], ..iron_spec() };
    assert!(raw::read(&raw_bytes, &hostile).is_err());
    let hostile = RawSpec { header_bytes: usize::MAX, ..iron_spec() };
    assert!(raw::read(&raw_bytes, &hostile).is_err());
}

/// The real sub-block cut into detached files as NRRD's multi-file forms
/// lay them out: 16 numbered slices (`%02d`, subdim 2), and four gzip slabs
/// of four slices listed by name (`LIST 3`). Both read back to the voxels.
#[test]
fn nrrd_multi_file_data() {
    let d = tempfile::tempdir().unwrap();
    let raw = load("iron16.raw");
    let geometry = "type: unsigned char\ndimension: 3\nsizes: 16 16 16\nspace directions: (1,0,0) (0,1,0) (0,0,1)\nspace origin: (26,26,26)\n";
    for (k, slice) in raw.chunks(256).enumerate() {
        std::fs::write(d.path().join(format!("iron16.{k:02}.raw")), slice).unwrap();
    }
    let mut slabs = String::new();
    for (k, slab) in raw.chunks(1024).enumerate() {
        let mut gz = flate2::write::GzEncoder::new(Vec::new(), flate2::Compression::default());
        std::io::Write::write_all(&mut gz, slab).unwrap();
        std::fs::write(d.path().join(format!("slab{k}.raw.gz")), gz.finish().unwrap()).unwrap();
        slabs += &format!("slab{k}.raw.gz\n");
    }
    let numbered = format!("NRRD0004\n{geometry}encoding: raw\ndata file: iron16.%02d.raw 0 15 1 2\n");
    let listed = format!("NRRD0004\n{geometry}encoding: gzip\ndata file: LIST 3\n{slabs}");
    let mut load_from = |name: &str| std::fs::read(d.path().join(name));
    for header in [&numbered, &listed] {
        let m = nrrd::read(header.as_bytes(), &mut load_from).unwrap_or_else(|e| panic!("{header}: {e}"));
        assert_eq!(m.point_fields[0].values, iron_values(), "{header}");
        assert_eq!(m.points[4095], [41.0; 3]);
        assert!(m.notes.iter().any(|n| n.contains("detached files")), "{:?}", m.notes);
    }
    // Counting down reads the slices in reverse order.
    let down = format!("NRRD0004\n{geometry}encoding: raw\ndata file: iron16.%02d.raw 15 0 -1\n");
    let m = nrrd::read(down.as_bytes(), &mut load_from).unwrap();
    let reversed: Vec<f64> = raw.chunks(256).rev().flatten().map(|&b| f64::from(b)).collect();
    assert_eq!(m.point_fields[0].values, reversed);

    // Bad input: each a clear error, never a partial volume.
    std::fs::write(d.path().join("iron16.07.raw"), &raw[..100]).unwrap();
    let e = nrrd::read(numbered.as_bytes(), &mut load_from).unwrap_err();
    assert!(e.in_companion && e.message.contains("iron16.07.raw") && e.message.contains("truncated"), "{e}");
    std::fs::remove_file(d.path().join("iron16.07.raw")).unwrap();
    let e = nrrd::read(numbered.as_bytes(), &mut load_from).unwrap_err();
    assert!(e.in_companion && e.message.contains("iron16.07.raw"), "{e}");
    for (value, says) in [
        ("iron16.%02d.raw 0 4 1", "equal size"),
        ("iron16.%02d.raw 0 15 0", "step"),
        ("iron16.%02d.raw 0 15 -1", "step"),
        ("x%d.raw 1 1000000000 1", "files for 4096 samples"),
        ("x.raw 0 15 1", "no %d"),
        ("x%d%d.raw 0 15 1", "exactly one"),
        ("iron16.%02d.raw 0 15 1 1", "subdim"),
        ("two files", "expected one file name"),
    ] {
        let header = format!("NRRD0004\n{geometry}encoding: raw\ndata file: {value}\n");
        let e = nrrd::read(header.as_bytes(), &mut load_from).unwrap_err();
        assert!(e.message.contains(says), "{value}: {e}");
    }
    let e = nrrd::read(format!("NRRD0004\n{geometry}encoding: raw\ndata file: LIST\n\n").as_bytes(), &mut load_from)
        .unwrap_err();
    assert!(e.message.contains("no file names"), "{e}");
}
