//! The tetprep binary as users run it: outputs, JSON keys, exit codes and
//! error messages on bad input.
use std::path::{Path, PathBuf};
use std::process::{Command, Output};

fn data(p: &str) -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("../../tests/data").join(p)
}

/// `p` as a command-line argument (the tests' paths are UTF-8).
fn path_arg(p: &Path) -> &str {
    p.to_str().expect("a UTF-8 path")
}

fn tetprep(args: &[&str]) -> Output {
    Command::new(env!("CARGO_BIN_EXE_tetprep")).args(args).output().expect("tetprep runs")
}

fn stderr(o: &Output) -> String {
    String::from_utf8_lossy(&o.stderr).into_owned()
}

fn json(o: &Output) -> serde_json::Value {
    assert!(o.status.success(), "failed: {}", stderr(o));
    serde_json::from_slice(&o.stdout).expect("valid JSON")
}

#[test]
fn bluntfin_convert_info_export() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("bf.tetb");
    let o = tetprep(&[
        "convert",
        path_arg(&data("plot3d/bluntfinxyz.bin")),
        "--q",
        path_arg(&data("plot3d/bluntfinq.bin")),
        "--scalar",
        "density",
        "-o",
        path_arg(&out),
        "--json",
    ]);
    let v = json(&o);
    assert_eq!(v["split_tets"], 187_395);
    assert_eq!(v["source"]["cells"], 37_479);
    assert!(v["timings_s"]["total"].as_f64().unwrap() > 0.0);

    let info = json(&tetprep(&["info", path_arg(&out), "--json"]));
    for key in
        ["points", "tets", "total_volume", "min_tet_volume", "bounds", "boundary_faces", "convex", "max_cell_diameter"]
    {
        assert!(!info[key].is_null(), "info --json lacks '{key}'");
    }
    assert_eq!(info["scalar"]["name"], "density");
    assert!(info["scalar"]["min"].as_f64().unwrap() > 0.18);
    assert_eq!(info["convex"], false);
    assert_eq!(info["points"], 40_960 - 39);

    let text = tetprep(&["info", path_arg(&out)]);
    assert!(text.status.success());
    assert!(String::from_utf8_lossy(&text.stdout).contains("merged 39 duplicate points"));

    let vtu = dir.path().join("bf.vtu");
    let e = tetprep(&["export", path_arg(&out), "-o", path_arg(&vtu)]);
    assert!(e.status.success(), "{}", stderr(&e));
    let back = tet_io::read_file(&vtu, &Default::default()).unwrap();
    assert_eq!(back.num_cells() as u64, info["tets"].as_u64().unwrap());
    assert!(back.point_fields.iter().any(|f| f.name == "density"));
    assert!(back.point_fields.iter().any(|f| f.name == "momentum" && f.num_components == 3));
}

#[test]
fn wrong_scalar_lists_the_fields_and_exits_2() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("x.tetb");
    let o = tetprep(&["convert", path_arg(&data("vtk/post.vtk")), "--scalar", "Nope", "-o", path_arg(&out)]);
    // A --scalar the file lacks is a bad flag value (usage, exit 2).
    assert_eq!(o.status.code(), Some(2), "{}", stderr(&o));
    let e = stderr(&o);
    assert!(e.contains("no scalar named 'Nope'") && e.contains("Pressure"), "{e}");
    assert!(!out.exists(), "a failed conversion must not leave an output");
}

#[test]
fn missing_and_garbage_inputs_exit_3_naming_the_path() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("x.tetb");
    let o = tetprep(&["convert", "/nonexistent/mesh.vtu", "-o", path_arg(&out)]);
    assert_eq!(o.status.code(), Some(3));
    assert!(stderr(&o).contains("/nonexistent/mesh.vtu"));

    let garbage = dir.path().join("garbage.vtk");
    std::fs::write(
        &garbage,
        b"# vtk DataFile Version 3.0\nx\nBINARY\nDATASET UNSTRUCTURED_GRID\nPOINTS 99999999999 float\n\x01\x02",
    )
    .unwrap();
    let o = tetprep(&["convert", path_arg(&garbage), "-o", path_arg(&out)]);
    assert_eq!(o.status.code(), Some(3), "{}", stderr(&o));
    assert!(stderr(&o).contains("garbage.vtk"));

    let unknown = dir.path().join("data.unknown");
    std::fs::write(&unknown, b"hello").unwrap();
    let o = tetprep(&["convert", path_arg(&unknown), "-o", path_arg(&out)]);
    assert_eq!(o.status.code(), Some(3));
    assert!(stderr(&o).contains("--format"));
}

#[test]
fn a_failed_conversion_keeps_the_previous_output() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("keep.tetb");
    std::fs::write(&out, b"previous").unwrap();
    let o = tetprep(&["convert", path_arg(&data("vtk/post.vtk")), "--scalar", "Nope", "-o", path_arg(&out)]);
    assert!(!o.status.success());
    assert_eq!(std::fs::read(&out).unwrap(), b"previous");
}

/// An output path that cannot be written is an output error (5) naming
/// it, found before the input is converted (the bundle's file is started
/// first), and nothing is left behind.
#[test]
fn an_unwritable_output_fails_before_the_conversion() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("missing").join("x.tetb");
    let o = tetprep(&["convert", path_arg(&data("vtk/post.vtk")), "-o", path_arg(&out)]);
    assert_eq!(o.status.code(), Some(5), "{}", stderr(&o));
    let e = stderr(&o);
    assert!(e.contains("x.tetb") && e.contains("writing the bundle failed"), "{e}");
    assert!(!e.contains("reading"), "failed before reading: {e}");
    assert_eq!(std::fs::read_dir(dir.path()).unwrap().count(), 0);
}

#[test]
fn non_manifold_input_names_tets_and_source_cells() {
    let dir = tempfile::tempdir().unwrap();
    let vtk = dir.path().join("fan.vtk");
    // Three tets on one triangle (0,1,2): a face bounding three cells.
    std::fs::write(
        &vtk,
        "# vtk DataFile Version 3.0\nfan\nASCII\nDATASET UNSTRUCTURED_GRID\nPOINTS 6 float\n\
         0 0 0 1 0 0 0 1 0 0 0 1 0 0 -1 0.2 0.2 2\nCELLS 3 15\n4 0 1 2 3\n4 0 1 2 4\n4 0 1 2 5\n\
         CELL_TYPES 3\n10 10 10\n",
    )
    .unwrap();
    let out = dir.path().join("fan.tetb");
    let o = tetprep(&["convert", path_arg(&vtk), "-o", path_arg(&out)]);
    assert_eq!(o.status.code(), Some(4));
    let e = stderr(&o);
    assert!(e.contains("shared by 3 tets") && e.contains("input cells 0, 1, 2"), "{e}");
    // The mesh was being written while its adjacency was built: the
    // unfinished file is gone, nothing is left beside the input.
    assert!(!out.exists());
    let names: Vec<_> = std::fs::read_dir(dir.path()).unwrap().map(|e| e.unwrap().file_name()).collect();
    assert_eq!(names, ["fan.vtk"], "{names:?}");
}

#[test]
fn nan_scalar_is_an_error_unless_dropped() {
    let dir = tempfile::tempdir().unwrap();
    let vtk = dir.path().join("nan.vtk");
    std::fs::write(
        &vtk,
        "# vtk DataFile Version 3.0\nnan\nASCII\nDATASET UNSTRUCTURED_GRID\nPOINTS 5 float\n\
         0 0 0 1 0 0 0 1 0 0 0 1 1 1 1\nCELLS 2 10\n4 0 1 2 3\n4 1 2 3 4\nCELL_TYPES 2\n10 10\n\
         POINT_DATA 5\nSCALARS t float 1\nLOOKUP_TABLE default\n0 1 2 3 nan\n",
    )
    .unwrap();
    let out = dir.path().join("nan.tetb");
    let o = tetprep(&["convert", path_arg(&vtk), "-o", path_arg(&out)]);
    assert_eq!(o.status.code(), Some(4));
    assert!(stderr(&o).contains("vertex 4"), "{}", stderr(&o));
    let o = tetprep(&["convert", path_arg(&vtk), "--nan", "drop", "-o", path_arg(&out), "--json"]);
    let v = json(&o);
    assert_eq!(v["tets"], 1);
    assert_eq!(v["points"], 4);
}

#[test]
fn sample_bundle_info() {
    let sample = Path::new(env!("CARGO_MANIFEST_DIR")).join("../../formats/samples/cube5.tetb");
    let v = json(&tetprep(&["info", path_arg(&sample), "--json"]));
    assert_eq!(v["tets"], 5);
    assert_eq!(v["convex"], true);
    let o = tetprep(&["info", path_arg(&data("vtk/post.vtk"))]);
    assert_eq!(o.status.code(), Some(3), "{}", stderr(&o));
    assert!(stderr(&o).contains("not a tetkit bundle"));
}

#[test]
fn raw_volume_from_the_command_line() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("iron.tetb");
    let raw = data("volume/iron16.raw");
    let v = json(&tetprep(&[
        "convert",
        path_arg(&raw),
        "--format",
        "raw",
        "--dims",
        "16,16,16",
        "--type",
        "u8",
        "--endian",
        "little",
        "--spacing",
        "1,1,2",
        "-o",
        path_arg(&out),
        "--json",
    ]));
    assert_eq!(v["tets"], 15 * 15 * 15 * 5);
    assert_eq!(v["bounds"]["max"][2], 30.0);
    // Missing layout options are a clear error, not a guess: an option the
    // input needs is a usage error (exit 2).
    let o = tetprep(&["convert", path_arg(&raw), "--format", "raw", "-o", path_arg(&out)]);
    assert_eq!(o.status.code(), Some(2), "{}", stderr(&o));
    assert!(stderr(&o).contains("--dims"), "{}", stderr(&o));
    // A file shorter than the declared dims says by how much.
    let o = tetprep(&[
        "convert",
        path_arg(&raw),
        "--format",
        "raw",
        "--dims",
        "32,32,32",
        "--type",
        "u8",
        "-o",
        path_arg(&out),
    ]);
    assert_eq!(o.status.code(), Some(3));
    assert!(stderr(&o).contains("iron16.raw"), "{}", stderr(&o));
    // Non-finite spacing or origin, and zero dims, are refused on the command
    // line (exit 2); a negative origin is a number, not a flag.
    let raw_with = |extra: &[&str]| {
        let base = ["convert", path_arg(&raw), "--format", "raw", "--type", "u8", "-o", path_arg(&out)];
        tetprep(&[&base[..], extra].concat())
    };
    for (bad, says) in [
        (&["--dims", "16,16,16", "--spacing", "nan,1,1"][..], "finite"),
        (&["--dims", "16,16,16", "--origin", "0,inf,0"], "finite"),
        (&["--dims", "16,0,16"], "I,J,K"),
    ] {
        let o = raw_with(bad);
        assert_eq!(o.status.code(), Some(2), "{bad:?}: {}", stderr(&o));
        assert!(stderr(&o).contains(says), "{bad:?}: {}", stderr(&o));
    }
    let o = raw_with(&["--dims", "16,16,16", "--origin", "-8,-8,-16"]);
    assert!(o.status.success(), "{}", stderr(&o));
}

#[test]
fn six_split_and_coordinate_scalar() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("bf6.tetb");
    let v = json(&tetprep(&[
        "convert",
        path_arg(&data("plot3d/bluntfinxyz.bin")),
        "--q",
        path_arg(&data("plot3d/bluntfinq.bin")),
        "--split",
        "6",
        "--scalar",
        "x",
        "--scalar-only",
        "-o",
        path_arg(&out),
        "--json",
    ]));
    assert_eq!(v["split_tets"], 224_874);
    assert_eq!(v["scalar"]["name"], "x");
    assert_eq!(v["point_fields"].as_array().unwrap().len(), 0);
}

#[test]
fn bluntfin_gradients_histogram_hist_png_and_analyze() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("bf.tetb");
    let (xyz, q) = (data("plot3d/bluntfinxyz.bin"), data("plot3d/bluntfinq.bin"));
    let v = json(&tetprep(&[
        "convert",
        path_arg(&xyz),
        "--q",
        path_arg(&q),
        "--scalar",
        "density",
        "--gradients",
        "--histogram",
        "--bins",
        "64,32",
        "-o",
        path_arg(&out),
        "--json",
    ]));
    assert!(v["timings_s"]["analysis"].as_f64().unwrap() > 0.0);
    let info = json(&tetprep(&["info", path_arg(&out), "--json"]));
    assert_eq!(info["gradients"], "lsq");
    assert_eq!(info["histogram"]["scalar_bins"], 64);
    let range = info["max_cell_scalar_range"].as_f64().unwrap();
    assert!(range > 0.0 && range < 4.977 - 0.1926);
    assert_eq!(info["frequency_limit"].as_f64().unwrap(), 1.0 / range);
    assert!(info["frequency_limit_99"].as_f64().unwrap() >= info["frequency_limit"].as_f64().unwrap());
    assert!(info["max_cell_diameter"].as_f64().unwrap() > 0.0);
    assert!(info["table_resolution"]["triangle"].as_u64().unwrap() > 1);

    let png = dir.path().join("h.png");
    let csv = dir.path().join("h.csv");
    let o = tetprep(&[
        "hist",
        path_arg(&out),
        "-o",
        path_arg(&png),
        "--csv",
        path_arg(&csv),
        "--units",
        "kg/m^3",
        "--length-units",
        "m",
    ]);
    assert!(o.status.success(), "{}", stderr(&o));
    let bytes = std::fs::read(&png).unwrap();
    assert_eq!(&bytes[..8], b"\x89PNG\r\n\x1a\n");
    let text = std::fs::read_to_string(&csv).unwrap();
    assert_eq!(text.lines().filter(|l| l.starts_with("1d,")).count(), 64);
    assert_eq!(text.lines().filter(|l| l.starts_with("2d,")).count(), 64 * 32);
    // Every bin volume plus what fell off the axes is the mesh volume.
    let mass: f64 = text
        .lines()
        .filter(|l| l.starts_with("2d,"))
        .map(|l| l.rsplit(',').next().unwrap().parse::<f64>().unwrap())
        .sum();
    let outside: f64 = text.lines().next().unwrap().rsplit("joint_outside=").next().unwrap().parse().unwrap();
    let total = info["total_volume"].as_f64().unwrap();
    assert!((mass + outside - total).abs() < 1e-9 * total, "{mass} + {outside} vs {total}");

    let vtu = dir.path().join("bf.vtu");
    assert!(tetprep(&["export", path_arg(&out), "-o", path_arg(&vtu)]).status.success());
    let back = tet_io::read_file(&vtu, &Default::default()).unwrap();
    assert!(back.point_fields.iter().any(|f| f.name == "density_gradient" && f.num_components == 3));
    assert!(back.point_fields.iter().any(|f| f.name == "density_gradient_magnitude"));

    // A plain bundle gains the analysis later, in place; limits are shown before.
    let plain = dir.path().join("plain.tetb");
    let o =
        tetprep(&["convert", path_arg(&xyz), "--q", path_arg(&q), "--scalar", "density", "-q", "-o", path_arg(&plain)]);
    assert!(o.status.success(), "{}", stderr(&o));
    let before = json(&tetprep(&["info", path_arg(&plain), "--json"]));
    assert_eq!(before["analysis_stored"], false);
    assert_eq!(before["frequency_limit"], info["frequency_limit"]);
    let a = json(&tetprep(&["analyze", path_arg(&plain), "--gradients", "--gradient-method", "tet-average", "--json"]));
    assert_eq!(a["gradients"], "tet-average");
    let after = json(&tetprep(&["info", path_arg(&plain), "--json"]));
    assert_eq!(after["analysis_stored"], true);
    assert!(after["histogram"].is_null());

    let bad = tetprep(&["hist", path_arg(&out), "-o", path_arg(&png), "--bins", "0,5"]);
    assert_eq!(bad.status.code(), Some(2));
}

#[test]
fn point_clouds_are_tetrahedralized() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("stars.tetb");
    let v = json(&tetprep(&[
        "convert",
        path_arg(&data("points/stars_lum_ci.ply")),
        "--scalar",
        "lum",
        "-o",
        path_arg(&out),
        "--json",
    ]));
    // One star is listed twice: merged and reported; the Delaunay mesh fills
    // the convex hull and the bundle says so.
    assert_eq!(v["points"], 107_856);
    assert_eq!(v["split"], "delaunay");
    assert_eq!(v["delaunay"], true);
    assert_eq!(v["convex"], true);
    let findings = v["findings"].as_array().unwrap();
    assert!(findings.iter().any(|f| f.as_str().unwrap().starts_with("merged 1 duplicate points")), "{findings:?}");
    // The Delaunay insertion's adjacency is handed over, and it is the one
    // the faces give.
    assert!(findings.iter().any(|f| f.as_str().unwrap().contains("face adjacency handed over")), "{findings:?}");
    let b = tet_bundle::Bundle::read(&out).unwrap();
    assert_eq!(b.adjacency, tet_mesh::build_adjacency(&b.mesh.points, &b.mesh.tets).unwrap());

    let out = dir.path().join("autzen.tetb");
    let v = json(&tetprep(&[
        "convert",
        path_arg(&data("points/autzen_trim.las")),
        "--scalar",
        "intensity",
        "--max-circumradius",
        "20",
        "-o",
        path_arg(&out),
        "--json",
    ]));
    assert_eq!(v["delaunay"], false, "peeled: no longer the convex hull");
    assert_eq!(v["convex"], false);
    assert!(v["findings"].as_array().unwrap().iter().any(|f| f.as_str().unwrap().starts_with("removed ")));
}

#[test]
fn layered_csv_points_become_prisms() {
    let dir = tempfile::tempdir().unwrap();
    let csv = dir.path().join("strata.csv");
    let mut text = String::from("x,y,z,temperature\n");
    for k in 0..4 {
        for j in 0..5 {
            for i in 0..6 {
                let z = k as f64 * 10.0 + 0.3 * i as f64 + 0.1 * j as f64;
                text.push_str(&format!("{},{},{},{}\n", i as f64 * 2.0, j as f64 * 3.0, z, 15.0 - z * 0.5));
            }
        }
    }
    std::fs::write(&csv, text).unwrap();
    let out = dir.path().join("strata.tetb");
    let v = json(&tetprep(&["convert", path_arg(&csv), "--mode", "layered", "-o", path_arg(&out), "--json"]));
    // 5×4 quads → 40 triangles per layer gap, 3 gaps, 3 tets per prism.
    assert_eq!(v["tets"], 40 * 3 * 3);
    assert_eq!(v["split"], "layered");
    assert!((v["total_volume"].as_f64().unwrap() - 10.0 * 3.0 * 10.0 * 12.0).abs() < 1e-9);
    // --mode layered on a mesh with cells is a usage error, not a silent no-op.
    let o = tetprep(&["convert", path_arg(&data("vtk/post.vtk")), "--mode", "layered", "-o", path_arg(&out)]);
    assert!(!o.status.success());
    assert!(stderr(&o).contains("point clouds"), "{}", stderr(&o));
}

/// Regression: SU2, Exodus, HDF5 and OpenFOAM inputs were told to "pass
/// --format" though no --format reads them; now the error says what the file
/// is (exit 3, an input problem, as for any unreadable input). SU2 and
/// Exodus II (classic netCDF and netCDF-4/HDF5) are read now: a broken one is
/// a malformed file of that format, still exit 3 and naming the path. OpenFOAM is read now too:
/// a case without a mesh is a malformed OpenFOAM case naming its directory
/// (not "does not read yet"), and the cavity tutorial converts.
#[test]
fn unsupported_formats_say_what_they_are() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("x.tetb");
    let case = dir.path().join("cavity");
    std::fs::create_dir_all(case.join("system")).unwrap();
    std::fs::write(case.join("system/controlDict"), b"FoamFile {}").unwrap();
    for (name, bytes, what, read) in [
        ("wing.su2", &b"NDIME= 3\n"[..], "SU2", true),
        ("blade.exo", b"CDF\x01\0\0\0\0", "Exodus II", true),
        ("blade4.exo", b"\x89HDF\r\n\x1a\n", "Exodus II", true),
        ("data.h5", b"\x89HDF\r\n\x1a\n", "HDF5", false),
    ] {
        let p = dir.path().join(name);
        std::fs::write(&p, bytes).unwrap();
        let o = tetprep(&["convert", path_arg(&p), "-o", path_arg(&out)]);
        assert_eq!(o.status.code(), Some(3), "{name}: {}", stderr(&o));
        let e = stderr(&o);
        assert!(e.contains(what) && !e.contains("pass --format"), "{e}");
        assert_eq!(e.contains("does not read yet"), !read, "{e}");
        assert!(e.contains(name), "{e}");
    }
    let o = tetprep(&["convert", path_arg(&case), "-o", path_arg(&out)]);
    assert_eq!(o.status.code(), Some(3));
    let e = stderr(&o);
    assert!(e.contains("OpenFOAM") && e.contains("has no mesh") && !e.contains("does not read yet"), "{e}");
    assert!(e.contains(path_arg(&case)), "{e}");
    let cavity = data("openfoam/cavity");
    let v = json(&tetprep(&["convert", path_arg(&cavity), "-o", path_arg(&out), "--json"]));
    assert_eq!(v["tets"], 400 * 6);
    assert!((v["total_volume"].as_f64().unwrap() - 1e-4).abs() < 1e-15, "{v}");
}

/// A scalar with one value everywhere is reported with that value.
#[test]
fn constant_scalar_is_a_warning_with_its_value() {
    let dir = tempfile::tempdir().unwrap();
    let vtk = dir.path().join("flat.vtk");
    std::fs::write(
        &vtk,
        b"# vtk DataFile Version 3.0\nt\nASCII\nDATASET UNSTRUCTURED_GRID\nPOINTS 4 float\n0 0 0 1 0 0 0 1 0 0 0 1\n\
CELLS 1 5\n4 0 1 2 3\nCELL_TYPES 1\n10\nPOINT_DATA 4\nSCALARS p float 1\nLOOKUP_TABLE default\n2.5 2.5 2.5 2.5\n",
    )
    .unwrap();
    let out = dir.path().join("flat.tetb");
    let o = tetprep(&["convert", path_arg(&vtk), "-o", path_arg(&out)]);
    assert!(o.status.success(), "{}", stderr(&o));
    let text = String::from_utf8_lossy(&o.stdout);
    assert!(text.contains("warning: the scalar 'p' is constant (2.5)"), "{text}");
}

/// Every tetprep output (bundle, VTU, histogram PNG) gets the mode
/// File::create gives, like tetview's and tetlut's.
#[cfg(unix)]
#[test]
fn outputs_get_the_mode_file_create_gives() {
    use std::os::unix::fs::PermissionsExt;
    let dir = tempfile::tempdir().unwrap();
    let plain = dir.path().join("plain");
    std::fs::File::create(&plain).unwrap();
    let mode = |p: &Path| std::fs::metadata(p).unwrap().permissions().mode() & 0o777;
    let b = dir.path().join("s.tetb");
    let sample = Path::new(env!("CARGO_MANIFEST_DIR")).join("../../formats/samples/cube5.tetb");
    std::fs::copy(&sample, &b).unwrap();
    std::fs::set_permissions(&b, std::fs::Permissions::from_mode(0o600)).unwrap();
    let o = tetprep(&["analyze", path_arg(&b), "--gradients", "--histogram"]);
    assert!(o.status.success(), "{}", stderr(&o));
    let vtu = dir.path().join("s.vtu");
    let png = dir.path().join("h.png");
    assert!(tetprep(&["export", path_arg(&b), "-o", path_arg(&vtu)]).status.success());
    assert!(tetprep(&["hist", path_arg(&b), "-o", path_arg(&png)]).status.success());
    for p in [&b, &vtu, &png] {
        assert_eq!(mode(p), mode(&plain), "{}", p.display());
    }
}

/// The exit codes every tetkit program shares (tet_cli::ExitKind), for the
/// failures `tetlut` and `tetview` test the same way in their tests/cli.rs.
#[test]
fn exit_codes_are_the_shared_ones() {
    let dir = tempfile::tempdir().unwrap();
    let sample = Path::new(env!("CARGO_MANIFEST_DIR")).join("../../formats/samples/cube5.tetb");
    let post = data("vtk/post.vtk");
    // 3: a truncated bundle (as `tetview render`), a missing input.
    let cut = dir.path().join("cut.tetb");
    let bytes = std::fs::read(&sample).unwrap();
    std::fs::write(&cut, &bytes[..bytes.len() / 2]).unwrap();
    for args in [vec!["info", path_arg(&cut)], vec!["export", path_arg(&cut), "-o", "x.vtu"]] {
        let o = tetprep(&args);
        assert_eq!(o.status.code(), Some(3), "{args:?}: {}", stderr(&o));
        assert!(stderr(&o).contains("cut.tetb"), "{}", stderr(&o));
    }
    let o = tetprep(&["info", path_arg(&dir.path().join("missing.tetb"))]);
    assert_eq!(o.status.code(), Some(3), "{}", stderr(&o));
    // 5: outputs in a directory that does not exist (reading worked).
    let nowhere = dir.path().join("no/such/dir");
    let o = tetprep(&["convert", path_arg(&post), "-o", path_arg(&nowhere.join("x.tetb"))]);
    assert_eq!(o.status.code(), Some(5), "{}", stderr(&o));
    assert!(stderr(&o).contains("no/such/dir"), "{}", stderr(&o));
    for args in [
        vec!["export", path_arg(&sample), "-o", path_arg(&nowhere.join("x.vtu"))],
        vec!["hist", path_arg(&sample), "-o", path_arg(&nowhere.join("h.png"))],
        vec!["analyze", path_arg(&sample), "-o", path_arg(&nowhere.join("a.tetb"))],
    ] {
        let o = tetprep(&args);
        assert_eq!(o.status.code(), Some(5), "{args:?}: {}", stderr(&o));
    }
    let ok_png = dir.path().join("h.png");
    let o = tetprep(&["hist", path_arg(&sample), "-o", path_arg(&ok_png), "--csv", path_arg(&nowhere.join("h.csv"))]);
    assert_eq!(o.status.code(), Some(5), "{}", stderr(&o));
    // 2: bad values (a range that is not LO < HI, a --type that does not exist).
    let o = tetprep(&["hist", path_arg(&sample), "-o", path_arg(&ok_png), "--scalar-range", "1,0"]);
    assert_eq!(o.status.code(), Some(2), "{}", stderr(&o));
    let o = tetprep(&["hist", path_arg(&sample), "-o", path_arg(&ok_png), "--scalar-range", "-1,2"]);
    assert!(o.status.success(), "a negative LO is a value, not a flag: {}", stderr(&o));
    let raw = dir.path().join("v.raw");
    std::fs::write(&raw, [0u8; 8]).unwrap();
    let out = dir.path().join("v.tetb");
    let o = tetprep(&[
        "convert",
        path_arg(&raw),
        "--format",
        "raw",
        "--dims",
        "2,2,2",
        "--type",
        "u7",
        "-o",
        path_arg(&out),
    ]);
    assert_eq!(o.status.code(), Some(2), "{}", stderr(&o));
    // 4: the data cannot become a valid mesh (every cell dropped for NaN).
    let nan = dir.path().join("nan.vtk");
    std::fs::write(
        &nan,
        "# vtk DataFile Version 3.0\nnan\nASCII\nDATASET UNSTRUCTURED_GRID\nPOINTS 4 float\n\
         0 0 0 1 0 0 0 1 0 0 0 1\nCELLS 1 5\n4 0 1 2 3\nCELL_TYPES 1\n10\n\
         POINT_DATA 4\nSCALARS t float 1\nLOOKUP_TABLE default\n0 1 2 nan\n",
    )
    .unwrap();
    let o = tetprep(&["convert", path_arg(&nan), "--nan", "drop", "-o", path_arg(&out)]);
    assert_eq!(o.status.code(), Some(4), "{}", stderr(&o));
    // --help lists the table.
    let help = String::from_utf8_lossy(&tetprep(&["--help"]).stdout).into_owned();
    assert!(help.contains("Exit codes") && help.contains("4  input data rejected"), "{help}");
}

/// A time series (hurricane Isabel's eye, tests/data/series/LICENSE.md) as
/// a .pvd and as a .series: the mesh once, every step's scalar with its
/// time, listed by `info`; Exodus steps and OpenFOAM time directories with
/// --all-steps; a step on another mesh, a step file missing and point
/// clouds are clear errors that write nothing.
#[test]
fn time_series_become_one_bundle_with_steps() {
    let dir = tempfile::tempdir().unwrap();
    let conv = |input: &Path, extra: &[&str], name: &str| {
        let out = dir.path().join(name);
        let mut args = vec!["convert", path_arg(input), "-o", path_arg(&out), "--json"];
        args.extend(extra);
        (tetprep(&args), out)
    };
    let (o, pvd_out) = conv(&data("series/isabel_eye.pvd"), &[], "pvd.tetb");
    let v = json(&o);
    assert_eq!(v["points"], 24 * 24 * 10);
    let steps = &v["time_steps"];
    assert_eq!(steps["count"], 4, "{steps}");
    let times: Vec<f64> = steps["steps"].as_array().unwrap().iter().map(|s| s["time"].as_f64().unwrap()).collect();
    assert_eq!(times, [2.0, 3.0, 4.0, 5.0]);
    assert_eq!(steps["steps"][1]["source"], "isabel_eye_03.vti");
    // Step k is the file converted alone.
    let pvd = tet_bundle::Bundle::read(&pvd_out).unwrap();
    let st = pvd.steps.as_ref().unwrap();
    for k in 0..4 {
        let (o, alone) = conv(&data(&format!("series/isabel_eye_0{}.vti", k + 2)), &[], "alone.tetb");
        assert!(o.status.success(), "{}", stderr(&o));
        let alone = tet_bundle::Bundle::read(&alone).unwrap();
        assert_eq!(alone.mesh.points, pvd.mesh.points);
        assert_eq!(st.scalar(k), &alone.mesh.scalar[..], "step {k}");
    }
    assert_eq!(pvd.mesh.scalar, st.scalar(0));
    let (lo, hi) = st.scalar_range();
    assert_eq!(steps["scalar_range"], serde_json::json!([lo, hi]));

    // The .series index gives the same steps.
    let (o, series_out) = conv(&data("series/isabel_eye.vti.series"), &[], "series.tetb");
    assert!(o.status.success(), "{}", stderr(&o));
    assert_eq!(tet_bundle::Bundle::read(&series_out).unwrap().steps, pvd.steps);

    let info = tetprep(&["info", path_arg(&pvd_out)]);
    let text = String::from_utf8_lossy(&info.stdout);
    assert!(text.contains("time steps  4, t = 2 to 5"), "{text}");
    assert!(text.contains("isabel_eye_05.vti"), "{text}");

    // Exodus steps and OpenFOAM time directories.
    let (o, _) = conv(&data("exodus/small.exo"), &["--all-steps"], "exo.tetb");
    assert_eq!(json(&o)["time_steps"]["count"], 2);
    let (o, _) = conv(&data("openfoam/cavity"), &["--all-steps"], "foam.tetb");
    let v = json(&o);
    assert_eq!(v["time_steps"]["count"], 6);
    assert_eq!(v["time_steps"]["steps"][3]["time"], 1.5);
    let (o, _) = conv(&data("exodus/small.exo"), &["--all-steps", "--time-step", "1"], "x.tetb");
    assert_eq!(o.status.code(), Some(2), "{}", stderr(&o));
    let (o, _) = conv(&data("vtk/hexa.vtk"), &["--all-steps"], "x.tetb");
    assert_eq!(o.status.code(), Some(3), "{}", stderr(&o));
    assert!(stderr(&o).contains("--all-steps reads the time steps of Exodus"), "{}", stderr(&o));

    // A step on another mesh; a listed file that is missing.
    let series = |name: &str, files: &[(f64, &Path)]| {
        let p = dir.path().join(name);
        let body: Vec<String> =
            files.iter().map(|(t, f)| format!(r#"<DataSet timestep="{t}" file="{}"/>"#, f.display())).collect();
        std::fs::write(
            &p,
            format!(r#"<VTKFile type="Collection"><Collection>{}</Collection></VTKFile>"#, body.concat()),
        )
        .unwrap();
        p
    };
    let other = series("other.pvd", &[(0.0, &data("series/isabel_eye_02.vti")), (1.0, &data("vtk/hexa.vtk"))]);
    let (o, out) = conv(&other, &[], "other.tetb");
    assert_eq!(o.status.code(), Some(3), "{}", stderr(&o));
    assert!(stderr(&o).contains("time step 1 (") && stderr(&o).contains("not the first step's"), "{}", stderr(&o));
    assert!(!out.exists(), "a failed series writes nothing");
    let missing = series("missing.pvd", &[(0.0, &data("series/isabel_eye_02.vti")), (1.0, Path::new("gone.vti"))]);
    let (o, _) = conv(&missing, &[], "missing.tetb");
    assert_eq!(o.status.code(), Some(3), "{}", stderr(&o));
    assert!(stderr(&o).contains("gone.vti") && stderr(&o).contains("missing.pvd"), "{}", stderr(&o));
}

/// `convert --gradients` of a time series stores every step's gradients
/// (the method `info` names), each equal to the step's own; at a time
/// between steps the stored ones, interpolated, are the gradients of the
/// interpolated scalar (both methods are linear in the scalar); `analyze
/// --gradients` adds them to a series converted without.
#[test]
fn series_store_every_steps_gradients() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("g.tetb");
    let o =
        tetprep(&["convert", path_arg(&data("series/isabel_eye.pvd")), "-o", path_arg(&out), "--gradients", "--json"]);
    assert!(o.status.success(), "{}", stderr(&o));
    assert_eq!(json(&o)["time_steps"]["gradients"], "lsq");
    let b = tet_bundle::Bundle::read(&out).unwrap();
    let st = b.steps.as_ref().unwrap();
    let lsq = tet_analysis::GradientMethod::LeastSquares;
    let gradients_of = |s: &[f64]| {
        tet_analysis::Analyzer::new(&b.mesh.points, &b.mesh.tets, s).unwrap().vertex_gradients(lsq).to_vec()
    };
    for k in 0..st.len() {
        assert_eq!(st.gradient(k).unwrap(), &gradients_of(st.scalar(k))[..], "step {k}");
    }
    let mut at = b.clone();
    at.set_time(3.25).unwrap();
    let want = gradients_of(&at.mesh.scalar);
    let got = &at.gradients().unwrap().per_point;
    let scale = want.iter().flatten().fold(0.0f64, |m, v| m.max(v.abs()));
    let worst = got.iter().flatten().zip(want.iter().flatten()).fold(0.0f64, |m, (a, b)| m.max((a - b).abs()));
    assert!(worst <= 1e-12 * scale, "largest difference {worst} of {scale}");
    let info = String::from_utf8_lossy(&tetprep(&["info", path_arg(&out)]).stdout).into_owned();
    assert!(info.contains("gradients stored for every step (lsq)"), "{info}");

    let plain = dir.path().join("p.tetb");
    assert!(tetprep(&["convert", path_arg(&data("series/isabel_eye.pvd")), "-o", path_arg(&plain)]).status.success());
    assert!(tet_bundle::Bundle::read(&plain).unwrap().steps.unwrap().gradient_method().is_none());
    let o = tetprep(&["analyze", path_arg(&plain), "--gradients"]);
    assert!(o.status.success(), "{}", stderr(&o));
    let again = tet_bundle::Bundle::read(&plain).unwrap();
    assert_eq!(again.steps.as_ref().unwrap().gradient(3), b.steps.as_ref().unwrap().gradient(3));
}
