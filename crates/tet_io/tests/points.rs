//! Point-cloud readers on the real star catalogue (PLY) and Autzen lidar
//! (LAS), and on inputs generated from them: ASCII and big-endian PLY, LAZ
//! (compressed at test time with the `laz` crate's LASzip compressor), OBJ,
//! CSV and GLB. Expected figures were computed independently with Python's
//! `struct` module on the raw bytes (see tests/data/points/LICENSE.md for the
//! files' provenance).

mod common;

use common::Lcg;
use std::fmt::Write as _;
use std::io::Cursor;
use std::path::Path;

use tet_io::{detect_format, las, ply, read_file, Format, ReadOptions};
use tet_mesh::{Field, SourceMesh};

const DIR: &str = concat!(env!("CARGO_MANIFEST_DIR"), "/../../tests/data/points/");

fn load(name: &str) -> Vec<u8> {
    std::fs::read(Path::new(DIR).join(name)).unwrap()
}

fn field<'a>(m: &'a SourceMesh, name: &str) -> &'a Field {
    m.point_fields.iter().find(|f| f.name == name).unwrap_or_else(|| panic!("no field {name}"))
}

fn range(v: &[f64]) -> (f64, f64) {
    v.iter().fold((f64::MAX, f64::MIN), |(a, b), &x| (a.min(x), b.max(x)))
}

fn column(m: &SourceMesh, k: usize) -> Vec<f64> {
    m.points.iter().map(|p| p[k]).collect()
}

/// Reads every truncation of `bytes` at 200 random lengths and 200 copies
/// with one random byte replaced: any result is fine, a panic is not.
fn never_panics(bytes: &[u8], seed: u64, read: impl Fn(&[u8]) -> Result<SourceMesh, tet_io::FormatError>) {
    let mut rng = Lcg(seed);
    for _ in 0..200 {
        let cut = rng.next() as usize % bytes.len();
        let _ = read(&bytes[..cut]);
    }
    let mut b = bytes.to_vec();
    for _ in 0..200 {
        // Half the flips land in the first 512 bytes, where the headers are.
        let at = if rng.next().is_multiple_of(2) {
            rng.next() as usize % b.len().min(512)
        } else {
            rng.next() as usize % b.len()
        };
        let keep = b[at];
        b[at] = (rng.next() & 0xff) as u8;
        if let Ok(m) = read(&b) {
            m.check().unwrap();
        }
        b[at] = keep;
    }
}

// ---------------------------------------------------------------- PLY

const STARS: usize = 107_857;

#[test]
fn stars_binary_ply_counts_and_ranges() {
    let m = ply::read(&load("stars_lum_ci.ply")).unwrap();
    assert_eq!(m.format, "PLY (binary little-endian)");
    assert_eq!(m.points.len(), STARS);
    assert!(m.blocks.is_empty());
    assert_eq!(m.point_fields.iter().map(|f| f.name.as_str()).collect::<Vec<_>>(), ["lum", "ci"]);
    // min, max and in-order sum of each column, from Python's struct.iter_unpack('<5f').
    let expect: [(&str, Vec<f64>, f64, f64, f64); 5] = [
        ("x", column(&m, 0), -975.5131225585938, 977.3650512695312, -52198.889489931404),
        ("y", column(&m, 1), -962.0454711914062, 966.23974609375, 186515.20280109346),
        ("z", column(&m, 2), -978.8370971679688, 970.2427368164062, -767768.01547103),
        ("lum", field(&m, "lum").values.clone(), 2.9484922379197087e-06, 67483.875, 7161273.420812202),
        ("ci", field(&m, "ci").values.clone(), -0.4000000059604645, 5.460000038146973, 75611.14298287872),
    ];
    for (name, v, lo, hi, sum) in expect {
        assert_eq!(range(&v), (lo, hi), "{name}");
        assert_eq!(v.iter().sum::<f64>(), sum, "{name}");
    }
    assert_eq!(m.points[0], [4.999999873689376e-06, 0.0, 0.0]);
    // The one exactly duplicated star is kept twice (merging is Delaunay's job).
    let dup = [-20.00828742980957, 8.179862976074219, -8.578490257263184];
    assert_eq!(m.points.iter().filter(|p| **p == dup).count(), 2);
}

/// Rewrites a binary little-endian PLY of `x y z lum ci` floats with the
/// first `n` records as ASCII (values printed as the f64 they widen to, so
/// they parse back exactly) or as big-endian.
fn re_encode_stars(n: usize, ascii: bool) -> Vec<u8> {
    let bin = load("stars_lum_ci.ply");
    let start = bin.windows(11).position(|w| w == b"end_header\n").unwrap() + 11;
    let header =
        std::str::from_utf8(&bin[..start]).unwrap().replace(&format!("vertex {STARS}"), &format!("vertex {n}"));
    let target = if ascii { "format ascii 1.0" } else { "format binary_big_endian 1.0" };
    let mut out = header.replace("format binary_little_endian 1.0", target).into_bytes();
    let mut text = String::new();
    for rec in bin[start..].chunks_exact(20).take(n) {
        for (k, v) in rec.chunks_exact(4).enumerate() {
            let v = f32::from_le_bytes(v.try_into().unwrap());
            if ascii {
                write!(text, "{}{}", if k > 0 { " " } else { "" }, v as f64).unwrap();
            } else {
                out.extend_from_slice(&v.to_be_bytes());
            }
        }
        if ascii {
            text.push('\n');
        }
    }
    out.extend_from_slice(text.as_bytes());
    out
}

fn first_n(m: &SourceMesh, n: usize) -> SourceMesh {
    let mut m = m.clone();
    m.points.truncate(n);
    for f in &mut m.point_fields {
        f.values.truncate(n);
    }
    m
}

#[test]
fn ascii_big_and_little_endian_ply_agree() {
    let little = ply::read(&load("stars_lum_ci.ply")).unwrap();
    let ascii = ply::read(&re_encode_stars(STARS, true)).unwrap();
    assert_eq!(ascii.format, "PLY (ascii)");
    assert_eq!(ascii.points, little.points);
    assert_eq!(ascii.point_fields, little.point_fields);
    let big = ply::read(&re_encode_stars(STARS, false)).unwrap();
    assert_eq!(big.format, "PLY (binary big-endian)");
    assert_eq!(big.points, little.points);
    assert_eq!(big.point_fields, little.point_fields);
    let few = ply::read(&re_encode_stars(10, true)).unwrap();
    assert_eq!(few.points, first_n(&little, 10).points);
}

#[test]
fn ply_truncated_and_corrupted_never_panic() {
    never_panics(&re_encode_stars(2000, false), 0x9e37_79b9, ply::read);
    never_panics(&re_encode_stars(2000, true), 0x7f4a_7c15, ply::read);
}

#[test]
fn ply_hostile_headers() {
    let head = |h: &str| format!("ply\nformat binary_little_endian 1.0\n{h}end_header\n").into_bytes();
    for h in [
        "element vertex 99999999999\nproperty float x\nproperty float y\nproperty float z\n",
        "element vertex 2\nproperty float x\nproperty float y\nproperty float z\nproperty float128 w\n",
        "element vertex 2\nproperty float x\nproperty float y\nproperty list double float z\n",
        "element vertex 2\nproperty float x\nproperty float x\nproperty float z\n",
        "property float x\n",
        "element vertex -1\nproperty float x\n",
        "element edge 18446744073709551615\nproperty list uint uint v\nelement vertex 1\nproperty float x\nproperty float y\nproperty float z\n",
    ] {
        let mut f = head(h);
        f.extend_from_slice(&[0x41; 64]);
        assert!(ply::read(&f).is_err(), "{h}");
    }
    // A header with no end, and an empty-property element with a huge count in ASCII.
    assert!(ply::read(b"ply\nformat ascii 1.0\nelement vertex 1\n").is_err());
    let m = ply::read(
        b"ply\nformat ascii 1.0\nelement nothing 18446744073709551615\nelement vertex 1\nproperty float x\nproperty float y\nproperty float z\nend_header\n1 2 3\n",
    )
    .unwrap();
    assert_eq!(m.points, vec![[1.0, 2.0, 3.0]]);
}

// ---------------------------------------------------------------- LAS / LAZ

const AUTZEN: usize = 110_000;

fn check_autzen(m: &SourceMesh) {
    assert_eq!(m.points.len(), AUTZEN);
    assert!(m.blocks.is_empty());
    let names: Vec<&str> = m.point_fields.iter().map(|f| f.name.as_str()).collect();
    assert_eq!(
        names,
        ["intensity", "elevation", "classification", "return_number", "gps_time", "red", "green", "blue", "luminance"]
    );
    // Scale 0.01, offset 0: the header's bounds are the points' bounds.
    assert_eq!(range(&column(m, 0)), (636001.76, 637179.22));
    assert_eq!(range(&column(m, 1)), (848935.2000000001, 849497.9));
    assert_eq!(range(&column(m, 2)), (406.26, 520.51));
    assert_eq!(field(m, "elevation").values, column(m, 2));
    let intensity = &field(m, "intensity").values;
    assert_eq!(range(intensity), (0.0, 254.0));
    assert_eq!(intensity.iter().sum::<f64>(), 11220547.0);
    let class = &field(m, "classification").values;
    assert_eq!(class.iter().filter(|&&c| c == 1.0).count(), 83893);
    assert_eq!(class.iter().filter(|&&c| c == 2.0).count(), 26107);
    let ret = &field(m, "return_number").values;
    for (r, n) in [(1.0, 99257), (2.0, 9021), (3.0, 1623), (4.0, 99)] {
        assert_eq!(ret.iter().filter(|&&v| v == r).count(), n, "return {r}");
    }
    assert_eq!(range(&field(m, "gps_time").values), (245379.39843682514, 245385.91112104454));
    for (name, lo, hi, sum) in
        [("red", 40.0, 236.0, 12255922.0), ("green", 55.0, 228.0, 13168529.0), ("blue", 52.0, 219.0, 10938029.0)]
    {
        let v = &field(m, name).values;
        assert_eq!(range(v), (lo, hi), "{name}");
        assert_eq!(v.iter().sum::<f64>(), sum, "{name}");
    }
    let (lo, hi) = range(&field(m, "luminance").values);
    assert!((lo - 51.5944).abs() < 1e-9 && (hi - 227.8316).abs() < 1e-9, "{lo} {hi}");
    assert_eq!(m.points[0], [637177.98, 849393.9500000001, 411.19]);
}

#[test]
fn autzen_las() {
    let m = las::read(&load("autzen_trim.las")).unwrap();
    assert_eq!(m.format, "LAS 1.2 (point format 3)");
    check_autzen(&m);
}

/// The first `n` points of autzen (all if `n` is `None`) as LAS bytes.
fn autzen_subset(n: usize) -> Vec<u8> {
    let mut b = load("autzen_trim.las");
    b[107..111].copy_from_slice(&(n as u32).to_le_bytes());
    b.truncate(2038 + 34 * n);
    b
}

/// Recompresses a LAS 1.2 point-format-3 file as LAZ with the `laz` crate:
/// the existing VLRs are kept, the laszip VLR appended, bit 7 of the point
/// format set, and the point records compressed.
fn to_laz(las: &[u8]) -> Vec<u8> {
    let point_offset = u32::from_le_bytes(las[96..100].try_into().unwrap()) as usize;
    let num_vlrs = u32::from_le_bytes(las[100..104].try_into().unwrap());
    let items = laz::LazItemRecordBuilder::default_for_point_format_id(3, 0).unwrap();
    let vlr = laz::LazVlr::from_laz_items(items);
    let mut payload = Vec::new();
    vlr.write_to(&mut payload).unwrap();

    let mut out = las[..point_offset].to_vec();
    out.extend_from_slice(&[0, 0]);
    let mut user = [0u8; 16];
    user[..14].copy_from_slice(b"laszip encoded");
    out.extend_from_slice(&user);
    out.extend_from_slice(&22204u16.to_le_bytes());
    out.extend_from_slice(&(payload.len() as u16).to_le_bytes());
    out.extend_from_slice(&[0u8; 32]);
    out.extend_from_slice(&payload);
    let new_offset = out.len() as u32;
    out[96..100].copy_from_slice(&new_offset.to_le_bytes());
    out[100..104].copy_from_slice(&(num_vlrs + 1).to_le_bytes());
    out[104] |= 0x80;

    let mut cur = Cursor::new(out);
    cur.set_position(new_offset as u64);
    let mut compressor = laz::LasZipCompressor::new(cur, vlr).unwrap();
    compressor.compress_many(&las[point_offset..]).unwrap();
    compressor.done().unwrap();
    compressor.into_inner().into_inner()
}

#[test]
fn autzen_laz_compressed_at_test_time_matches_las() {
    let las_bytes = load("autzen_trim.las");
    let laz_bytes = to_laz(&las_bytes);
    assert!(laz_bytes.len() < las_bytes.len() / 3, "LAZ {} bytes", laz_bytes.len());
    let m = las::read(&laz_bytes).unwrap();
    assert_eq!(m.format, "LAZ 1.2 (point format 3)");
    check_autzen(&m);
    let plain = las::read(&las_bytes).unwrap();
    assert_eq!(m.points, plain.points);
    assert_eq!(m.point_fields, plain.point_fields);
}

#[test]
fn las_and_laz_truncated_and_corrupted_never_panic() {
    never_panics(&autzen_subset(3000), 0x51ed_270b, las::read);
    never_panics(&to_laz(&autzen_subset(3000)), 0x2545_f491, las::read);
}

#[test]
fn laz_declaring_far_more_points_than_it_can_hold_is_refused() {
    let mut laz_bytes = to_laz(&autzen_subset(100));
    laz_bytes[107..111].copy_from_slice(&u32::MAX.to_le_bytes());
    let e = las::read(&laz_bytes).unwrap_err();
    assert!(e.message.contains("cannot come from"), "{e}");
}

// ---------------------------------------------------------------- OBJ, CSV

/// The first `n` stars as `v x y z` lines, with lum, ci and 0 as a colour.
fn stars_obj(n: usize) -> (SourceMesh, Vec<u8>) {
    let m = first_n(&ply::read(&load("stars_lum_ci.ply")).unwrap(), n);
    let mut s = String::from("# stars\no stars\n");
    for (i, p) in m.points.iter().enumerate() {
        let (lum, ci) = (m.point_fields[0].values[i], m.point_fields[1].values[i]);
        writeln!(s, "v {} {} {} {lum} {ci} 0", p[0], p[1], p[2]).unwrap();
    }
    s.push_str("f 1 2 3\n");
    (m, s.into_bytes())
}

#[test]
fn obj_vertices_match_the_ply() {
    let (m, obj) = stars_obj(500);
    let o = tet_io::obj::read(&obj).unwrap();
    assert_eq!(o.points, m.points);
    assert_eq!(field(&o, "red").values, m.point_fields[0].values);
    assert_eq!(field(&o, "green").values, m.point_fields[1].values);
    assert!(o.notes.iter().any(|n| n.contains("ignored 1 faces")), "{:?}", o.notes);
    never_panics(&obj, 0x1234_5678, tet_io::obj::read);
}

fn stars_csv(n: usize, sep: &str, header: bool) -> (SourceMesh, Vec<u8>) {
    let m = first_n(&ply::read(&load("stars_lum_ci.ply")).unwrap(), n);
    let mut s = String::from("# HYG stars\n");
    if header {
        s.push_str(&["Lum", "X", "Y", "Z", "ci"].join(sep));
        s.push('\n');
    }
    for (i, p) in m.points.iter().enumerate() {
        let row = [m.point_fields[0].values[i], p[0], p[1], p[2], m.point_fields[1].values[i]];
        s.push_str(&row.map(|v| v.to_string()).join(sep));
        s.push('\n');
    }
    (m, s.into_bytes())
}

#[test]
fn csv_variants_match_the_ply() {
    for sep in [",", ";", "\t", "  "] {
        let (m, csv) = stars_csv(300, sep, true);
        let c = tet_io::csv::read(&csv, None).unwrap();
        assert_eq!(c.points, m.points, "sep {sep:?}");
        assert_eq!(field(&c, "Lum").values, m.point_fields[0].values);
        assert_eq!(field(&c, "ci").values, m.point_fields[1].values);
    }
    let (m, csv) = stars_csv(300, " ", false);
    let spec: Vec<String> = ["lum", "x", "y", "z", "_"].iter().map(|s| s.to_string()).collect();
    let c = tet_io::csv::read(&csv, Some(&spec)).unwrap();
    assert_eq!(c.points, m.points);
    assert_eq!(c.point_fields.len(), 1);
    never_panics(&csv, 0xdead_beef, |b| tet_io::csv::read(b, Some(&spec)));
    let (_, csv) = stars_csv(300, ",", true);
    never_panics(&csv, 0xfeed_f00d, |b| tet_io::csv::read(b, None));
}

// ---------------------------------------------------------------- glTF

/// A minimal GLB: JSON chunk (padded with spaces) and BIN chunk (padded with zeros).
fn glb(json: &str, bin: &[u8]) -> Vec<u8> {
    let mut j = json.as_bytes().to_vec();
    while !j.len().is_multiple_of(4) {
        j.push(b' ');
    }
    let mut b = bin.to_vec();
    while !b.len().is_multiple_of(4) {
        b.push(0);
    }
    let total = 12 + 8 + j.len() + 8 + b.len();
    let mut out = Vec::new();
    out.extend_from_slice(b"glTF");
    out.extend_from_slice(&2u32.to_le_bytes());
    out.extend_from_slice(&(total as u32).to_le_bytes());
    out.extend_from_slice(&(j.len() as u32).to_le_bytes());
    out.extend_from_slice(b"JSON");
    out.extend_from_slice(&j);
    out.extend_from_slice(&(b.len() as u32).to_le_bytes());
    out.extend_from_slice(b"BIN\0");
    out.extend_from_slice(&b);
    out
}

/// Two POINTS primitives (3 + 2 points) under a scaled parent and a
/// translated child, with normalized u8 RGBA colours and a `_SCALAR`; one
/// triangle primitive to skip.
fn sample_glb() -> Vec<u8> {
    let mut bin = Vec::new();
    let f32s = |bin: &mut Vec<u8>, v: &[f32]| v.iter().for_each(|x| bin.extend_from_slice(&x.to_le_bytes()));
    f32s(&mut bin, &[0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 1.0, 0.0]); // 0: positions A, 36 bytes
    f32s(&mut bin, &[10.0, 20.0, 30.0]); // 36: scalar A, 12 bytes
    bin.extend_from_slice(&[255, 0, 0, 255, 0, 255, 0, 255, 0, 0, 255, 255]); // 48: colour A (u8 RGBA), 12 bytes
    f32s(&mut bin, &[0.0, 0.0, 1.0, 1.0, 1.0, 1.0]); // 60: positions B, 24 bytes
    f32s(&mut bin, &[40.0, 50.0]); // 84: scalar B, 8 bytes
    bin.extend_from_slice(&[51, 51, 51, 255, 102, 102, 102, 255]); // 92: colour B, 8 bytes
    let json = r#"{"asset":{"version":"2.0"},"scene":0,"scenes":[{"nodes":[0]}],
      "nodes":[{"scale":[2,2,2],"children":[1],"mesh":0},{"translation":[0,0,5],"mesh":1}],
      "meshes":[
        {"primitives":[{"mode":0,"attributes":{"POSITION":0,"_SCALAR":1,"COLOR_0":2}},
                       {"mode":4,"attributes":{"POSITION":0}}]},
        {"primitives":[{"mode":0,"attributes":{"POSITION":3,"_SCALAR":4,"COLOR_0":5}}]}],
      "buffers":[{"byteLength":100}],
      "bufferViews":[{"buffer":0,"byteOffset":0,"byteLength":36},{"buffer":0,"byteOffset":36,"byteLength":12},
                     {"buffer":0,"byteOffset":48,"byteLength":12},{"buffer":0,"byteOffset":60,"byteLength":24},
                     {"buffer":0,"byteOffset":84,"byteLength":8},{"buffer":0,"byteOffset":92,"byteLength":8}],
      "accessors":[
        {"bufferView":0,"componentType":5126,"count":3,"type":"VEC3","min":[0,0,0],"max":[1,1,0]},
        {"bufferView":1,"componentType":5126,"count":3,"type":"SCALAR"},
        {"bufferView":2,"componentType":5121,"normalized":true,"count":3,"type":"VEC4"},
        {"bufferView":3,"componentType":5126,"count":2,"type":"VEC3","min":[0,0,1],"max":[1,1,1]},
        {"bufferView":4,"componentType":5126,"count":2,"type":"SCALAR"},
        {"bufferView":5,"componentType":5121,"normalized":true,"count":2,"type":"VEC4"}]}"#;
    glb(json, &bin)
}

#[test]
fn glb_points_with_transforms_colours_and_scalar() {
    let m = tet_io::read_bytes(&sample_glb(), Format::Gltf).unwrap();
    assert_eq!(m.format, "glTF (binary .glb)");
    // Parent scales by 2; the child adds (0,0,5) before that scale.
    assert_eq!(m.points, vec![[0.0, 0.0, 0.0], [2.0, 0.0, 0.0], [0.0, 2.0, 0.0], [0.0, 0.0, 12.0], [2.0, 2.0, 12.0]]);
    assert_eq!(field(&m, "_SCALAR").values, vec![10.0, 20.0, 30.0, 40.0, 50.0]);
    assert_eq!(field(&m, "red").values, vec![1.0, 0.0, 0.0, 0.2, 0.4]);
    assert_eq!(field(&m, "blue").values, vec![0.0, 0.0, 1.0, 0.2, 0.4]);
    assert!(m.notes.iter().any(|n| n.contains("Triangles")), "{:?}", m.notes);
    never_panics(&sample_glb(), 0x0bad_cafe, |b| tet_io::read_bytes(b, Format::Gltf));
}

// ---------------------------------------------------------------- detection and read_file

#[test]
fn formats_are_detected_and_read_through_read_file() {
    let dir = tempfile::tempdir().unwrap();
    let write = |name: &str, bytes: &[u8]| {
        let p = dir.path().join(name);
        std::fs::write(&p, bytes).unwrap();
        p
    };
    let (_, csv) = stars_csv(20, ",", true);
    let (_, obj) = stars_obj(20);
    let cases: Vec<(std::path::PathBuf, Format, usize)> = vec![
        (write("stars.dat", &re_encode_stars(20, true)), Format::Ply, 20),
        (write("lidar.bin", &autzen_subset(20)), Format::Las, 20),
        (write("lidar.laz", &to_laz(&autzen_subset(20))), Format::Las, 20),
        (write("cloud.glb", &sample_glb()), Format::Gltf, 5),
        (write("stars.obj", &obj), Format::Obj, 20),
        (write("stars.csv", &csv), Format::Csv, 20),
        (write("stars.xyz", b"x y z v\n0.5 1 2 3\n"), Format::Csv, 1),
        (write("pts.txt", b"0.5\t1\t2\n"), Format::Csv, 1),
    ];
    for (path, format, n) in cases {
        let bytes = std::fs::read(&path).unwrap();
        assert_eq!(detect_format(&path, &bytes, &ReadOptions::default()), Some(format), "{}", path.display());
        let m = read_file(&path, &ReadOptions::default()).unwrap_or_else(|e| panic!("{e}"));
        assert_eq!(m.points.len(), n, "{}", path.display());
        assert!(m.blocks.is_empty());
    }
    // An ASCII PLOT3D grid keeps its `.xyz` meaning.
    let grid = write("grid.xyz", b"2 2 2\n0 1 0 1 0 1 0 1\n");
    assert_eq!(detect_format(&grid, b"2 2 2\n0 1 0 1 0 1 0 1\n", &ReadOptions::default()), Some(Format::Plot3d));
    // --columns makes an integer table a point table, and names its columns.
    let ints = write("ints.xyz", b"1 2 3 4\n5 6 7 8\n");
    let opts =
        ReadOptions { columns: Some(vec!["x".into(), "y".into(), "z".into(), "value".into()]), ..Default::default() };
    let m = read_file(&ints, &opts).unwrap();
    assert_eq!(m.points, vec![[1.0, 2.0, 3.0], [5.0, 6.0, 7.0]]);
    assert_eq!(field(&m, "value").values, vec![4.0, 8.0]);
    // Errors name format, line and path.
    let bad = write("bad.csv", b"x,y,z\n1,2,3\n4,5\n");
    let e = read_file(&bad, &ReadOptions::default()).unwrap_err().to_string();
    assert!(e.contains("CSV") && e.contains("line 3") && e.contains("bad.csv"), "{e}");
    for name in ["ply", "las", "laz", "obj", "gltf", "glb", "csv"] {
        assert!(Format::from_name(name).is_some_and(Format::is_point_cloud), "{name}");
    }
}
