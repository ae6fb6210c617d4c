//! `tetprep partition` and `tetprep info` of a manifest as users run them:
//! the pieces keep the volume, lie in their boxes and are valid bundles;
//! time steps survive; bad input exits with the right code and names the
//! piece or path.
use std::path::{Path, PathBuf};
use std::process::{Command, Output};
use tet_bundle::manifest::{Manifest, MANIFEST_FILE};
use tet_bundle::Bundle;
use tet_mesh::predicates::signed_tet_volume;

fn data(p: &str) -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("../../tests/data").join(p)
}

fn arg(p: &Path) -> &str {
    p.to_str().expect("a UTF-8 path")
}

fn tetprep(args: &[&str]) -> Output {
    Command::new(env!("CARGO_BIN_EXE_tetprep")).args(args).output().expect("tetprep runs")
}

fn stderr(o: &Output) -> String {
    String::from_utf8_lossy(&o.stderr).into_owned()
}

fn ok(o: &Output) {
    assert!(o.status.success(), "failed: {}", stderr(o));
}

/// `input` converted into `dir`, with extra convert flags.
fn convert(dir: &Path, input: &Path, extra: &[&str]) -> PathBuf {
    let out = dir.join("source.tetb");
    let mut args = vec!["convert", arg(input), "-o", arg(&out), "-q"];
    args.extend_from_slice(extra);
    ok(&tetprep(&args));
    out
}

fn volume(b: &Bundle) -> f64 {
    let m = &b.mesh;
    m.tets
        .iter()
        .map(|t| {
            let p = |k: usize| &m.points[t[k] as usize];
            signed_tet_volume(p(0), p(1), p(2), p(3))
        })
        .sum()
}

/// Area of the boundary faces of `b` that do not lie in a face of `bounds`.
fn boundary_area_off(b: &Bundle, bounds: &tet_bundle::manifest::BoxBounds) -> f64 {
    let m = &b.mesh;
    b.adjacency
        .boundary_faces
        .iter()
        .map(|&f| {
            let t = m.tets[(f / 4) as usize];
            let v = tet_mesh::FACE_OUTWARD[(f % 4) as usize].map(|c| m.points[t[c] as usize]);
            let on_box =
                (0..3).any(|a| v.iter().all(|p| p[a] == bounds.min[a]) || v.iter().all(|p| p[a] == bounds.max[a]));
            if on_box {
                return 0.0;
            }
            let (e1, e2) = ([0, 1, 2].map(|c| v[1][c] - v[0][c]), [0, 1, 2].map(|c| v[2][c] - v[0][c]));
            let n = [e1[1] * e2[2] - e1[2] * e2[1], e1[2] * e2[0] - e1[0] * e2[2], e1[0] * e2[1] - e1[1] * e2[0]];
            0.5 * (n[0] * n[0] + n[1] * n[1] + n[2] * n[2]).sqrt()
        })
        .sum()
}

/// Every piece valid, inside its box, within the whole scalar range; the
/// pieces' volume is the source's; the pieces are conforming: their
/// boundary off their boxes' faces is the source's boundary (off the root
/// box), so no cut left a hole or a hanging face inside a piece.
fn check(source: &Bundle, dir: &Path, parts: usize) -> Manifest {
    let m = Manifest::load(&dir.join(MANIFEST_FILE), true).unwrap();
    assert_eq!(m.parts, parts);
    assert_eq!(m.pieces.len(), parts);
    assert_eq!(m.scalar_range.min, source.scalar_range().0);
    assert_eq!(m.scalar_range.max, source.scalar_range().1);
    let mut total = 0.0;
    let mut area = 0.0;
    for (k, p) in m.pieces.iter().enumerate() {
        let b = m.load_piece(dir, k).unwrap();
        tet_mesh::check_tet_mesh(&b.mesh).unwrap_or_else(|e| panic!("piece {k}: {e}"));
        tet_mesh::check_adjacency(&b.mesh.tets, &b.adjacency).unwrap();
        assert!(b.mesh.points.iter().all(|x| p.bounds.contains(x)), "piece {k} leaves its box");
        assert!(b.mesh.scalar.iter().all(|&s| m.scalar_range.min <= s && s <= m.scalar_range.max));
        assert_eq!(p.tets as usize, b.mesh.tets.len());
        total += volume(&b);
        area += boundary_area_off(&b, &p.bounds);
    }
    let want_area = boundary_area_off(source, m.tree[0].bounds());
    assert!((area - want_area).abs() <= 1e-9 * want_area, "boundary {area} vs {want_area}");
    let want = volume(source);
    assert!((total - want).abs() <= 1e-12 * want.abs(), "volume {total} vs {want}");
    m
}

#[test]
fn pieces_of_a_mesh_for_several_counts() {
    let dir = tempfile::tempdir().unwrap();
    let src = convert(dir.path(), &data("vtu/can.vtu"), &[]);
    let source = Bundle::read(&src).unwrap();
    for parts in [1usize, 2, 3, 4, 7] {
        let out = dir.path().join(format!("p{parts}"));
        let n = parts.to_string();
        let o = tetprep(&["partition", arg(&src), "--parts", &n, "-o", arg(&out), "--json"]);
        ok(&o);
        let v: serde_json::Value = serde_json::from_slice(&o.stdout).unwrap();
        assert_eq!(v["parts"], parts);
        let m = check(&source, &out, parts);
        assert_eq!(m.source.file, "source.tetb");
        assert_eq!(m.front_to_back([0.0, 0.0, 100.0]).len(), parts);
        // info of the manifest (the file or its directory), text and JSON.
        let info = tetprep(&["info", arg(&out), "--json"]);
        ok(&info);
        let iv: serde_json::Value = serde_json::from_slice(&info.stdout).unwrap();
        assert_eq!(iv["pieces_ok"], true);
        assert_eq!(iv["pieces"].as_array().unwrap().len(), parts);
        let text = tetprep(&["info", arg(&out.join(MANIFEST_FILE))]);
        ok(&text);
        let t = String::from_utf8_lossy(&text.stdout);
        assert!(t.contains("tree:") && t.contains("checksum ok"), "{t}");
    }
}

#[test]
fn pieces_of_a_tetgen_delaunay_mesh() {
    let dir = tempfile::tempdir().unwrap();
    let src = convert(dir.path(), &data("tetgen/cloud.1.ele"), &[]);
    let source = Bundle::read(&src).unwrap();
    for parts in [2usize, 6] {
        let out = dir.path().join(format!("p{parts}"));
        ok(&tetprep(&["partition", arg(&src), "--parts", &parts.to_string(), "-o", arg(&out), "-q"]));
        assert_eq!(check(&source, &out, parts).cost, "tets");
    }
    // Balanced by expected crossings (each tet's surface area): as exact.
    let out = dir.path().join("crossings");
    ok(&tetprep(&["partition", arg(&src), "--parts", "3", "--cost", "crossings", "-o", arg(&out), "-q"]));
    assert_eq!(check(&source, &out, 3).cost, "crossings");
}

#[test]
fn time_steps_survive_the_cut() {
    let dir = tempfile::tempdir().unwrap();
    let src = convert(dir.path(), &data("series/isabel_eye.pvd"), &[]);
    let source = Bundle::read(&src).unwrap();
    let steps = source.steps.as_ref().expect("a series").len();
    let out = dir.path().join("parts");
    ok(&tetprep(&["partition", arg(&src), "--parts", "3", "-o", arg(&out), "-q"]));
    let m = check(&source, &out, 3);
    assert_eq!(m.steps.len(), steps);
    for k in 0..3 {
        let b = Bundle::read(&m.piece_path(&out, k)).unwrap();
        let st = b.steps.as_ref().expect("the piece keeps the steps");
        assert_eq!(st.times(), source.steps.as_ref().unwrap().times());
        let (lo, hi) = st.scalar_range();
        assert!(m.scalar_range.min <= lo && hi <= m.scalar_range.max);
    }
}

#[test]
fn bad_requests_exit_with_their_codes() {
    let dir = tempfile::tempdir().unwrap();
    let src = convert(dir.path(), &data("vtk/tetraMesh.vtk"), &[]);
    let tets = Bundle::read(&src).unwrap().mesh.tets.len();
    let out = dir.path().join("parts");
    // N = 0 and N above the tet count: the flag's value (2).
    let o = tetprep(&["partition", arg(&src), "--parts", "0", "-o", arg(&out)]);
    assert_eq!(o.status.code(), Some(2), "{}", stderr(&o));
    let too_many = (tets + 1).to_string();
    let o = tetprep(&["partition", arg(&src), "--parts", &too_many, "-o", arg(&out)]);
    assert_eq!(o.status.code(), Some(2), "{}", stderr(&o));
    assert!(stderr(&o).contains(&format!("{tets} tets")), "{}", stderr(&o));
    assert!(!out.exists(), "a failed partition leaves no output");
    // A missing or corrupt source (3), naming the path.
    let o = tetprep(&["partition", "/nonexistent/x.tetb", "--parts", "2", "-o", arg(&out)]);
    assert_eq!(o.status.code(), Some(3));
    assert!(stderr(&o).contains("/nonexistent/x.tetb"));
    let corrupt = dir.path().join("corrupt.tetb");
    let mut bytes = std::fs::read(&src).unwrap();
    let mid = bytes.len() / 2;
    bytes[mid] ^= 0xFF;
    std::fs::write(&corrupt, &bytes).unwrap();
    let o = tetprep(&["partition", arg(&corrupt), "--parts", "2", "-o", arg(&out)]);
    assert_eq!(o.status.code(), Some(3), "{}", stderr(&o));
    assert!(stderr(&o).contains("corrupt.tetb"));
    // An existing non-empty directory (5) unless --force.
    std::fs::create_dir(&out).unwrap();
    std::fs::write(out.join("keep.txt"), b"x").unwrap();
    let o = tetprep(&["partition", arg(&src), "--parts", "2", "-o", arg(&out)]);
    assert_eq!(o.status.code(), Some(5), "{}", stderr(&o));
    assert!(stderr(&o).contains("--force"));
    assert!(out.join("keep.txt").exists());
    ok(&tetprep(&["partition", arg(&src), "--parts", "2", "-o", arg(&out), "--force", "-q"]));
    assert!(!out.join("keep.txt").exists());
    Manifest::load(&out.join(MANIFEST_FILE), true).unwrap();
    // An existing empty directory is used.
    let empty = dir.path().join("empty");
    std::fs::create_dir(&empty).unwrap();
    ok(&tetprep(&["partition", arg(&src), "--parts", "2", "-o", arg(&empty), "-q"]));
}

/// `Manifest::load_piece`'s error for piece `k`, as text.
fn m_load_piece_error(manifest: &Path, k: usize) -> String {
    let m = Manifest::load(manifest, false).unwrap();
    m.load_piece(manifest.parent().unwrap(), k).map(|_| ()).unwrap_err().to_string()
}

#[test]
fn damaged_partitions_name_the_piece() {
    let dir = tempfile::tempdir().unwrap();
    let src = convert(dir.path(), &data("vtk/tetraMesh.vtk"), &[]);
    let out = dir.path().join("parts");
    ok(&tetprep(&["partition", arg(&src), "--parts", "3", "-o", arg(&out), "-q"]));
    let manifest = out.join(MANIFEST_FILE);
    // A flipped byte: info reports the piece, the loader refuses it.
    let p2 = out.join("piece_0002.tetb");
    let mut bytes = std::fs::read(&p2).unwrap();
    bytes[40] ^= 1;
    std::fs::write(&p2, &bytes).unwrap();
    let o = tetprep(&["info", arg(&manifest)]);
    ok(&o);
    let t = String::from_utf8_lossy(&o.stdout);
    assert!(t.contains("BAD: piece 2 is corrupt") && t.contains("piece_0002.tetb"), "{t}");
    let e = Manifest::load(&manifest, true).unwrap_err();
    assert!(matches!(e, tet_bundle::ManifestError::PieceChecksum { piece: 2, .. }), "{e}");
    let e = m_load_piece_error(&manifest, 2);
    assert!(e.contains("piece 2") && e.contains("piece_0002.tetb"), "{e}");
    // A missing piece.
    std::fs::remove_file(&p2).unwrap();
    let e = Manifest::load(&manifest, true).unwrap_err();
    assert!(matches!(e, tet_bundle::ManifestError::MissingPiece { piece: 2, .. }), "{e}");
    assert!(e.to_string().contains("piece_0002.tetb"));
    // A truncated piece: its size.
    let p1 = out.join("piece_0001.tetb");
    let bytes = std::fs::read(&p1).unwrap();
    std::fs::write(&p1, &bytes[..bytes.len() - 8]).unwrap();
    let m = Manifest::load(&manifest, false).unwrap();
    let e = m.verify_piece(&out, 1).unwrap_err();
    assert!(matches!(e, tet_bundle::ManifestError::PieceSize { piece: 1, .. }), "{e}");
    // N that does not match the pieces: info and the loader refuse (3).
    let text = std::fs::read_to_string(&manifest).unwrap();
    let edited = text.replacen("\"parts\": 3", "\"parts\": 4", 1);
    assert_ne!(edited, text);
    std::fs::write(&manifest, edited).unwrap();
    let o = tetprep(&["info", arg(&manifest)]);
    assert_eq!(o.status.code(), Some(3), "{}", stderr(&o));
    assert!(stderr(&o).contains("4 parts but 3 pieces"), "{}", stderr(&o));
    assert!(matches!(Manifest::load(&manifest, false), Err(tet_bundle::ManifestError::Inconsistent { .. })));
}

/// The point of the exact clip: the pieces, each drawn alone with the
/// exact integrator and composited front to back in the manifest's order,
/// give the image of the whole mesh (up to f32 rounding and each piece's
/// early termination).
#[test]
fn composited_pieces_draw_the_whole() {
    use tet_engine::{resolve_tf, CpuFrameRenderer, FrameRenderer, FrameRequest, Look, TfRequest};
    use tet_render::ViewSpec;
    let dir = tempfile::tempdir().unwrap();
    let src = convert(dir.path(), &data("vtu/can.vtu"), &[]);
    let whole = Bundle::read(&src).unwrap();
    let out = dir.path().join("parts");
    ok(&tetprep(&["partition", arg(&src), "--parts", "5", "-o", arg(&out), "-q"]));
    let m = Manifest::load(&out.join(MANIFEST_FILE), true).unwrap();
    // One TF in scalar units for every piece: the whole's.
    let tf = resolve_tf(&whole, &TfRequest::default()).unwrap().tf;
    let s = &whole.meta.stats;
    for (azimuth, elevation) in [(30.0, 20.0), (200.0, -35.0)] {
        let view = ViewSpec::framing(s.bounds_min, s.bounds_max, [96, 96]).orbit(azimuth, elevation, 1.0);
        let draw = |b: &Bundle| {
            let mut r = CpuFrameRenderer::new(b).unwrap();
            r.render(&Look::exact(tf.clone()), &FrameRequest::new(view.clone()), &|_, _| {}).unwrap().image
        };
        let reference = draw(&whole);
        let mut sum = vec![[0.0f32; 4]; reference.pixels().len()];
        for k in m.front_to_back(view.position) {
            let piece = draw(&Bundle::read(&m.piece_path(&out, k)).unwrap());
            for (acc, p) in sum.iter_mut().zip(piece.pixels()) {
                // Premultiplied "under": what is behind shows through the
                // transparency in front.
                let t = 1.0 - acc[3];
                for c in 0..4 {
                    acc[c] += t * p[c];
                }
            }
        }
        let (mut worst, mut sq) = (0.0f32, 0.0f64);
        for (a, b) in sum.iter().zip(reference.pixels()) {
            for c in 0..4 {
                let d = (a[c] - b[c]).abs();
                worst = worst.max(d);
                sq += (d as f64).powi(2);
            }
        }
        let rmse = (sq / (4 * sum.len()) as f64).sqrt();
        let covered = reference.pixels().iter().filter(|p| p[3] > 0.01).count();
        assert!(covered > sum.len() / 10, "the view shows the mesh ({covered} pixels)");
        // The reversed order misses by tenths: the order matters and is right.
        assert!(worst < 1e-3 && rmse < 1e-5, "azimuth {azimuth}: max {worst}, RMSE {rmse}");
    }
}
