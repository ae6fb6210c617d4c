use std::path::Path;
use tet_bundle::{Bundle, BundleError, BundleMeta, FORMAT_VERSION};
use tet_mesh::{build_adjacency, tetrahedralize, Block, ConvertOptions, Field, SourceMesh};

/// A 3×3×3-point structured block with a scalar and a vector field.
fn sample_bundle() -> Bundle {
    let mut points = Vec::new();
    for k in 0..3 {
        for j in 0..3 {
            for i in 0..3 {
                points.push([i as f64, j as f64 * 0.5, k as f64 * 2.0]);
            }
        }
    }
    let s = points.iter().map(|p| p[0] * p[1] - p[2]).collect();
    let v = points.iter().flat_map(|p| [p[0], p[1], p[2]]).collect();
    let source = SourceMesh {
        points,
        blocks: vec![Block::Structured { dims: [3, 3, 3], first_point: 0 }],
        point_fields: vec![Field::new("s", 1, s), Field::new("v", 3, v)],
        ..Default::default()
    };
    let (mesh, report) = tetrahedralize(&source, &ConvertOptions::default(), &mut |_| {}).unwrap();
    let adj = build_adjacency(&mesh.points, &mesh.tets).unwrap();
    let meta = BundleMeta {
        source_format: "test".into(),
        split_tets: report.split_tets as u64,
        split: "5".into(),
        findings: report.findings.iter().map(|f| f.to_string()).collect(),
        ..Default::default()
    };
    Bundle::new(mesh, adj, meta)
}

/// Writes `b` to `name` in a fresh directory and asserts that it reads back
/// equal: the directory (kept while it is held), the file and what it
/// read as.
fn assert_round_trips(b: &Bundle, name: &str) -> (tempfile::TempDir, std::path::PathBuf, Bundle) {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join(name);
    b.write(&path).unwrap();
    let back = Bundle::read(&path).unwrap();
    assert_eq!(&back, b);
    (dir, path, back)
}

#[test]
fn write_then_read_gives_the_same_bundle() {
    let b = sample_bundle();
    assert_eq!(b.mesh.tets.len(), 8 * 5);
    let (dir, _, _) = assert_round_trips(&b, "s.tetb");
    // Atomic write leaves no temporary files behind.
    let names: Vec<_> = std::fs::read_dir(dir.path()).unwrap().map(|e| e.unwrap().file_name()).collect();
    assert_eq!(names.len(), 1, "{names:?}");
}

#[test]
fn rejects_wrong_magic_newer_version_and_bad_checksum() {
    let bytes = sample_bundle().to_bytes();
    let p = Path::new("x.tetb");

    let mut wrong = bytes.clone();
    wrong[1] = b'X';
    assert!(matches!(Bundle::from_bytes(&wrong, p), Err(BundleError::BadMagic { .. })));
    assert!(matches!(Bundle::from_bytes(b"# vtk DataFile", p), Err(BundleError::BadMagic { .. })));

    let mut newer = bytes.clone();
    newer[8..12].copy_from_slice(&(FORMAT_VERSION + 1).to_le_bytes());
    let e = Bundle::from_bytes(&newer, p).unwrap_err();
    assert!(matches!(e, BundleError::NewerVersion { found, .. } if found == FORMAT_VERSION + 1), "{e}");

    // Flip one byte in the middle of the POINTS payload.
    let sections = Bundle::sections(&bytes, p).unwrap();
    let pts = sections.iter().find(|s| s.name == "POINTS").unwrap();
    let mut corrupt = bytes.clone();
    corrupt[(pts.offset + pts.length / 2) as usize] ^= 0x40;
    let e = Bundle::from_bytes(&corrupt, p).unwrap_err();
    assert!(matches!(&e, BundleError::BadChecksum { section, .. } if section == "POINTS"), "{e}");
    assert!(e.to_string().contains("x.tetb"));
}

/// Every `step`-th prefix of a bundle's `bytes` is refused (an error, not
/// a panic).
fn assert_truncations_are_errors(bytes: &[u8], p: &Path, step: usize) {
    for len in (0..bytes.len()).step_by(step) {
        assert!(Bundle::from_bytes(&bytes[..len], p).is_err(), "truncated at {len} was accepted");
    }
}

/// `count` copies of `bytes`, each with one bit flipped at a byte chosen by
/// a xorshift generator from `seed`: (that byte, the copy).
fn bit_flips(bytes: &[u8], mut seed: u64, count: usize) -> impl Iterator<Item = (usize, Vec<u8>)> + '_ {
    (0..count).map(move |_| {
        seed ^= seed << 13;
        seed ^= seed >> 7;
        seed ^= seed << 17;
        let i = (seed % bytes.len() as u64) as usize;
        let mut b = bytes.to_vec();
        b[i] ^= 1 << (seed >> 60 & 7);
        (i, b)
    })
}

#[test]
fn every_truncation_and_byte_flip_is_an_error_not_a_panic() {
    let bytes = sample_bundle().to_bytes();
    let p = Path::new("t.tetb");
    assert_truncations_are_errors(&bytes, p, 7);
    let good = Bundle::from_bytes(&bytes, p).unwrap();
    for (i, b) in bit_flips(&bytes, 0x2545_f491_4f6c_dd1d, 2000) {
        // Either detected, or the flip hit padding and changed nothing.
        if let Ok(x) = Bundle::from_bytes(&b, p) {
            assert_eq!(x, good, "flip at byte {i} changed the content undetected");
        }
    }
}

/// `Bundle::read` reads a file section by section, not through
/// `from_bytes`: it must agree with it on every file, good or damaged — the
/// same bundle, or an error (with the path) where `from_bytes` has one.
#[test]
fn reading_a_file_agrees_with_reading_its_bytes() {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("f.tetb");
    for good in [sample_bundle(), analyzed_bundle()] {
        let bytes = good.to_bytes();
        std::fs::write(&path, &bytes).unwrap();
        assert_eq!(Bundle::read(&path).unwrap(), good);
        for len in (0..bytes.len()).step_by(5) {
            std::fs::write(&path, &bytes[..len]).unwrap();
            let e = Bundle::read(&path).expect_err("a truncated file was accepted");
            assert!(e.to_string().contains("f.tetb"), "{e}");
        }
        for (i, b) in bit_flips(&bytes, 0x9e37_79b9_7f4a_7c15, 600) {
            std::fs::write(&path, &b).unwrap();
            match (Bundle::read(&path), Bundle::from_bytes(&b, &path)) {
                (Ok(x), Ok(y)) => assert_eq!(x, y, "flip at byte {i}"),
                (Err(_), Err(_)) => {}
                (x, y) => panic!("flip at byte {i}: the file gave {x:?}, the bytes {y:?}"),
            }
        }
    }
    let e = Bundle::read(&dir.path().join("absent.tetb")).unwrap_err();
    assert!(matches!(e, BundleError::Io { action: "read", .. }), "{e}");
}

#[test]
fn sample_in_formats_reads() {
    let path = Path::new(concat!(env!("CARGO_MANIFEST_DIR"), "/../../formats/samples/cube5.tetb"));
    let b = Bundle::read(path).unwrap();
    assert_eq!(b.mesh.points.len(), 8);
    assert_eq!(b.mesh.tets.len(), 5);
    assert_eq!(b.mesh.scalar_name, "s");
    assert_eq!(b.adjacency.boundary_faces.len(), 12);
    assert!(b.adjacency.convex);
    assert_eq!(b.analysis, None, "the v1 sample predates the analysis sections");
    assert!((b.meta.stats.total_volume - 1.0).abs() < 1e-12);
    tet_mesh::check_tet_mesh(&b.mesh).unwrap();
    tet_mesh::check_adjacency(&b.mesh.tets, &b.adjacency).unwrap();
}

fn analyzed_bundle() -> Bundle {
    let b = sample_bundle();
    let an = tet_analysis::Analyzer::from_mesh(&b.mesh).unwrap();
    let opts = tet_analysis::AnalysisOptions {
        gradients: Some(tet_analysis::GradientMethod::LeastSquares),
        histogram: Some(tet_analysis::HistogramOptions { scalar_bins: 8, gradient_bins: 4, ..Default::default() }),
        ..Default::default()
    };
    let a = an.analyze(&opts).unwrap();
    b.with_analysis(a)
}

#[test]
fn analysis_sections_round_trip_and_are_optional() {
    let b = analyzed_bundle();
    let (_dir, path, back) = assert_round_trips(&b, "a.tetb");
    let a = back.analysis.as_ref().unwrap();
    assert_eq!(a.gradients.as_ref().unwrap().per_point.len(), b.mesh.points.len());
    let names: Vec<String> = Bundle::sections(&b.to_bytes(), &path).unwrap().into_iter().map(|s| s.name).collect();
    for n in ["ANALYSIS", "CELLRANGE", "CELLGRANGE", "GRADIENT"] {
        assert!(names.iter().any(|x| x == n), "{names:?}");
    }
    // Without gradients: no GRADIENT or CELLGRANGE section.
    let mut plain = b.clone();
    let pa = plain.analysis.as_mut().unwrap();
    pa.gradients = None;
    pa.ranges.gradient_magnitude = None;
    pa.histograms = None;
    let bytes = plain.to_bytes();
    assert_eq!(Bundle::from_bytes(&bytes, &path).unwrap(), plain);
    // A bundle without analysis reads as before.
    assert_eq!(Bundle::from_bytes(&sample_bundle().to_bytes(), &path).unwrap().analysis, None);
}

#[test]
fn damaged_analysis_sections_are_errors() {
    let bytes = analyzed_bundle().to_bytes();
    let p = Path::new("a.tetb");
    assert_truncations_are_errors(&bytes, p, 13);
}

/// Three steps of a scalar on the sample's mesh.
fn series_bundle() -> Bundle {
    let b = sample_bundle();
    let n = b.mesh.points.len();
    let scalars: Vec<Vec<f64>> =
        (0..3).map(|k| (0..n).map(|i| (i as f64 * 0.37 + k as f64).sin() * (k + 1) as f64).collect()).collect();
    let steps = tet_bundle::TimeSteps::new(
        vec![0.5, 1.0, 3.0],
        scalars,
        ["a.vtu", "b.vtu", "c.vtu"].map(String::from).to_vec(),
    )
    .unwrap();
    b.with_steps(steps).unwrap()
}

/// A time series' steps round-trip; old readers see the first step as the
/// scalar; `set_time` is the step itself at its time and linear between.
#[test]
fn time_steps_round_trip_and_interpolate() {
    let b = series_bundle();
    let (_dir, _, back) = assert_round_trips(&b, "t.tetb");
    let st = back.steps.as_ref().unwrap();
    assert_eq!((st.len(), st.times(), st.source(2)), (3, &[0.5, 1.0, 3.0][..], "c.vtu"));

    let mut at = back.clone();
    at.set_time(1.0).unwrap();
    assert_eq!(at.mesh.scalar, st.scalar(1));
    assert!(at.analysis.is_none());
    assert_eq!((at.meta.stats.scalar_min, at.meta.stats.scalar_max), st.scalar_range());
    at.set_time(2.5).unwrap();
    for (i, v) in at.mesh.scalar.iter().enumerate() {
        let want = 0.25 * st.scalar(1)[i] + 0.75 * st.scalar(2)[i];
        assert!((v - want).abs() <= 1e-15 * want.abs().max(1.0), "point {i}: {v} vs {want}");
    }
    at.set_time(3.0).unwrap();
    assert_eq!(at.mesh.scalar, st.scalar(2));

    let e = at.set_time(3.5).unwrap_err();
    assert_eq!(e, tet_bundle::TimeError::OutOfRange { time: 3.5, first: 0.5, last: 3.0 });
    assert!(at.set_time(f64::NAN).is_err());
    assert_eq!(sample_bundle().set_time(1.0), Err(tet_bundle::TimeError::NoSteps));
}

/// Bad steps are refused when built and when read: a step section missing
/// or short, times not increasing.
#[test]
fn damaged_time_steps_are_named() {
    let ok =
        |t: Vec<f64>| tet_bundle::TimeSteps::new(t.clone(), vec![vec![1.0]; t.len()], vec![String::new(); t.len()]);
    assert!(ok(vec![1.0, 1.0]).unwrap_err().contains("increase"));
    assert!(ok(vec![]).is_err());
    assert!(ok(vec![0.0, f64::INFINITY]).is_err());
    assert!(tet_bundle::TimeSteps::new(vec![0.0], vec![vec![f64::NAN]], vec![String::new()]).is_err());
    assert!(sample_bundle()
        .with_steps(tet_bundle::TimeSteps::new(vec![0.0], vec![vec![1.0; 2]], vec![String::new()]).unwrap())
        .is_err());

    // A file whose TIMES lists a step without its section.
    let b = series_bundle();
    let bytes = b.to_bytes();
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("t.tetb");
    let table = Bundle::sections(&bytes, &path).unwrap();
    let step2 = table.iter().find(|e| e.name == "STEP00002").unwrap();
    // Renaming the section (and fixing the table's checksum) hides it.
    let mut renamed = bytes.clone();
    let at = 32 + 40 * table.iter().position(|e| e.name == "STEP00002").unwrap();
    renamed[at..at + 9].copy_from_slice(b"XTEP00002");
    let crc = crc32fast::hash(&renamed[32..32 + 40 * table.len()]);
    renamed[24..28].copy_from_slice(&crc.to_le_bytes());
    let e = Bundle::from_bytes(&renamed, &path).unwrap_err();
    assert!(e.to_string().contains("STEP00002 is missing"), "{e}");
    assert!(step2.length > 0);
}

/// Per-step gradients (`STEPGRAD`, `GRAD00000`…) round-trip; `set_time`
/// makes the time's gradients the bundle's, weighted as the scalar is;
/// a bundle without them reads as before; bad arrays are refused and a
/// missing array is named.
#[test]
fn step_gradients_round_trip_and_interpolate() {
    let b = series_bundle();
    let n = b.mesh.points.len();
    let grads: Vec<Vec<[f64; 3]>> =
        (0..3).map(|k| (0..n).map(|i| [i as f64, k as f64, (i * k) as f64 * 0.5]).collect()).collect();
    let method = tet_analysis::GradientMethod::TetAverage;
    let steps = b.steps.clone().unwrap().with_gradients(method, grads.clone()).unwrap();
    let b = b.with_steps(steps).unwrap();
    let (_dir, _, back) = assert_round_trips(&b, "g.tetb");
    let st = back.steps.as_ref().unwrap();
    assert_eq!(st.gradient_method(), Some(method));
    assert_eq!(st.gradient(2), Some(&grads[2][..]));
    assert!(back.gradients().is_none(), "no analysis and no time set");

    let mut at = back.clone();
    at.set_time(2.5).unwrap();
    let g = at.gradients().expect("the time's gradients");
    assert_eq!(g.method, method);
    for (i, v) in g.per_point.iter().enumerate() {
        for c in 0..3 {
            let want = 0.25 * grads[1][i][c] + 0.75 * grads[2][i][c];
            assert!((v[c] - want).abs() <= 1e-12 * want.abs().max(1.0), "point {i}");
        }
    }
    at.set_time(1.0).unwrap();
    assert_eq!(at.gradients().unwrap().per_point, grads[1]);
    // Without stored gradients a time has none.
    let mut plain = series_bundle();
    plain.set_time(1.0).unwrap();
    assert!(plain.gradients().is_none());

    let st0 = series_bundle().steps.unwrap();
    assert!(st0.clone().with_gradients(method, grads[..2].to_vec()).unwrap_err().contains("2 gradient arrays for 3"));
    let mut nan = grads.clone();
    nan[1][0][2] = f64::NAN;
    assert!(st0.clone().with_gradients(method, nan).unwrap_err().contains("step 1"));
    let short = vec![vec![[0.0; 3]; n - 1]; 3];
    assert!(st0.with_gradients(method, short).unwrap_err().contains("gradients for"));

    // A STEPGRAD whose GRAD00001 is gone.
    let bytes = b.to_bytes();
    let path = Path::new("g.tetb");
    let table = Bundle::sections(&bytes, path).unwrap();
    let mut renamed = bytes.clone();
    let at = 32 + 40 * table.iter().position(|e| e.name == "GRAD00001").unwrap();
    renamed[at..at + 9].copy_from_slice(b"XRAD00001");
    let crc = crc32fast::hash(&renamed[32..32 + 40 * table.len()]);
    renamed[24..28].copy_from_slice(&crc.to_le_bytes());
    let e = Bundle::from_bytes(&renamed, path).unwrap_err();
    assert!(e.to_string().contains("GRAD00001 is missing"), "{e}");
}

/// A bundle streamed (mesh and neighbours first, the rest at `finish`)
/// reads back as the bundle, with analysis and time steps too; neighbours
/// written early that the bundle does not hold make `finish` write the
/// bundle afresh (same result); a stream dropped unfinished leaves nothing.
#[test]
fn a_streamed_bundle_reads_back_as_the_bundle() {
    let dir = tempfile::tempdir().unwrap();
    for (k, b) in [sample_bundle(), analyzed_bundle(), series_bundle()].iter().enumerate() {
        let path = dir.path().join(format!("s{k}.tetb"));
        let mut s = tet_bundle::BundleStream::create(&path).unwrap();
        s.write_mesh(&b.mesh).unwrap();
        s.write_neighbors(&b.adjacency.neighbors).unwrap();
        assert!(!path.exists());
        assert!(s.finish(b).unwrap(), "the early sections are the bundle's");
        assert_eq!(&Bundle::read(&path).unwrap(), b);
        assert_eq!(&Bundle::from_bytes(&std::fs::read(&path).unwrap(), &path).unwrap(), b);
    }
    let b = sample_bundle();
    let path = dir.path().join("rebuilt.tetb");
    let mut s = tet_bundle::BundleStream::create(&path).unwrap();
    s.write_mesh(&b.mesh).unwrap();
    let mut other = b.adjacency.neighbors.clone();
    other.swap(0, 1);
    s.write_neighbors(&other).unwrap();
    assert!(!s.finish(&b).unwrap(), "written afresh");
    assert_eq!(Bundle::read(&path).unwrap(), b);
    let gone = dir.path().join("gone.tetb");
    let mut s = tet_bundle::BundleStream::create(&gone).unwrap();
    s.write_mesh(&b.mesh).unwrap();
    drop(s);
    assert!(!gone.exists());
    let names: Vec<_> = std::fs::read_dir(dir.path()).unwrap().map(|e| e.unwrap().file_name()).collect();
    assert_eq!(names.len(), 4, "no temporary files left: {names:?}");
}

/// A file's two largest arrays (connectivity and adjacency) are mapped, on
/// a little-endian host, not read; a bundle's bytes are read; both give the
/// same bundle, and writing to a mapped array copies it first.
#[test]
fn a_files_largest_arrays_are_mapped_not_read() {
    let good = sample_bundle();
    let (_dir, path, back) = assert_round_trips(&good, "m.tetb");
    let little = cfg!(target_endian = "little");
    assert_eq!(back.mesh.tets.is_shared(), little);
    assert_eq!(back.adjacency.neighbors.is_shared(), little);
    let from_bytes = Bundle::from_bytes(&std::fs::read(&path).unwrap(), &path).unwrap();
    assert!(!from_bytes.mesh.tets.is_shared());
    assert_eq!(from_bytes, back);
    let mut edited = back.clone();
    edited.mesh.tets[0].swap(0, 1);
    assert!(!edited.mesh.tets.is_shared());
    assert_eq!(back, good);
}
