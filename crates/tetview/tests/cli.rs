//! `tetview render` end to end on a tiny bundle.
use std::path::Path;
use std::process::Command;
use tet_bundle::{Bundle, BundleMeta};
use tet_mesh::{build_adjacency, TetMesh};

fn bundle(dir: &Path) -> std::path::PathBuf {
    bundle_with(dir, "cube.tetb", |p| p[0] + 0.5 * p[1], "")
}

/// The cube of [`bundle`] with another scalar and `meta.split` (the source
/// kind: `delaunay` marks a point cloud).
fn bundle_with(dir: &Path, name: &str, scalar: fn([f64; 3]) -> f64, split: &str) -> std::path::PathBuf {
    // A cube of 5 tets with a linear scalar.
    let points = tet_mesh::split::UNIT_HEX.to_vec();
    let tets = vec![[0, 1, 3, 4], [1, 2, 3, 6], [1, 6, 4, 5], [3, 4, 6, 7], [1, 3, 4, 6]];
    let tets = tets
        .into_iter()
        .map(|mut t: [u32; 4]| {
            let p = |i: usize| points[t[i] as usize];
            let d = |a: [f64; 3], b: [f64; 3]| [b[0] - a[0], b[1] - a[1], b[2] - a[2]];
            let (a, b, c) = (d(p(0), p(1)), d(p(0), p(2)), d(p(0), p(3)));
            let det = a[0] * (b[1] * c[2] - b[2] * c[1]) - a[1] * (b[0] * c[2] - b[2] * c[0])
                + a[2] * (b[0] * c[1] - b[1] * c[0]);
            if det < 0.0 {
                t.swap(2, 3);
            }
            t
        })
        .collect();
    let scalar = points.iter().map(|p| scalar(*p)).collect();
    let mesh = TetMesh { points, tets, scalar_name: "s".into(), scalar, point_fields: vec![] };
    let adjacency = build_adjacency(&mesh.points, &mesh.tets).unwrap();
    let meta = BundleMeta {
        stats: tet_mesh::mesh_stats(&mesh.points, &mesh.tets, &mesh.scalar),
        split: split.into(),
        ..Default::default()
    };
    let path = dir.join(name);
    Bundle::new(mesh, adjacency, meta).write(&path).unwrap();
    path
}

fn tf(dir: &Path) -> std::path::PathBuf {
    let p = dir.join("tf.json");
    std::fs::write(&p, r#"{"normalized": true, "color": [[0, 0, 0, 1], [1, 1, 0.5, 0]], "opacity": [[0, 0.5], [1, 3]], "unit_distance": 1}"#).unwrap();
    p
}

/// `p` as a command-line argument (the tests' paths are UTF-8).
fn path_arg(p: &Path) -> &str {
    p.to_str().expect("a UTF-8 path")
}

/// The cube bundle and the TF in `dir` as arguments, and a namer of more
/// files there.
fn cube_tf_and_paths(dir: &Path) -> (String, String, impl Fn(&str) -> String + '_) {
    let (b, t) = (bundle(dir), tf(dir));
    let (b, t) = (path_arg(&b).to_string(), path_arg(&t).to_string());
    (b, t, move |name: &str| path_arg(&dir.join(name)).to_string())
}

fn tetview(args: &[&str]) -> std::process::Output {
    Command::new(env!("CARGO_BIN_EXE_tetview")).args(args).output().unwrap()
}

#[test]
fn renders_png_npy_and_view_with_json_stats() {
    let dir = tempfile::tempdir().unwrap();
    let (b, t) = (bundle(dir.path()), tf(dir.path()));
    let (png, npy, view) = (dir.path().join("a.png"), dir.path().join("a.npy"), dir.path().join("v.json"));
    for method in ["pt-linear", "exact"] {
        let out = tetview(&[
            "render",
            path_arg(&b),
            "--tf",
            path_arg(&t),
            "--method",
            method,
            "--size",
            "40x30",
            "--azimuth",
            "30",
            "--elevation",
            "-20",
            "-o",
            path_arg(&png),
            "--float",
            path_arg(&npy),
            "--save-view",
            path_arg(&view),
            "--json",
        ]);
        assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
        let stats: serde_json::Value = serde_json::from_slice(&out.stdout).unwrap();
        assert_eq!(stats["tets_drawn"], 5);
        // The ray walker by default: no visibility sort.
        assert_eq!(stats["renderer"], "walk");
        assert_eq!(stats["sort_method"], "none");
        assert_eq!(stats["walk_step_limit"], 0);
        assert_eq!(stats["method"], method);
        let img = tet_render::Image::read_npy(&npy).unwrap();
        assert_eq!((img.width(), img.height()), (40, 30));
        assert!(img.pixels().iter().any(|p| p[3] > 0.2));
        assert!(std::fs::metadata(&png).unwrap().len() > 100);
    }
    // The saved view reproduces the image.
    let npy2 = dir.path().join("b.npy");
    let out = tetview(&[
        "render",
        path_arg(&b),
        "--tf",
        path_arg(&t),
        "--method",
        "exact",
        "--view",
        path_arg(&view),
        "-o",
        path_arg(&png),
        "--float",
        path_arg(&npy2),
        "--tonemap",
        "none",
    ]);
    assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
    assert_eq!(tet_render::Image::read_npy(&npy).unwrap(), tet_render::Image::read_npy(&npy2).unwrap());
}

/// Without `--method`, `render` uses table3d (the method that meets the
/// accuracy target; see tests/golden.rs), baked once on the fly; pt-linear
/// bakes nothing.
#[test]
fn default_method_is_table3d_baked_once() {
    let dir = tempfile::tempdir().unwrap();
    let (b, t) = (bundle(dir.path()), tf(dir.path()));
    let png = dir.path().join("a.png");
    let stats = |extra: &[&str]| -> serde_json::Value {
        let mut a = vec!["render", path_arg(&b), "--tf", path_arg(&t), "--size", "24x24"];
        a.extend_from_slice(&["-o", path_arg(&png), "--json"]);
        a.extend_from_slice(extra);
        let out = tetview(&a);
        assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
        serde_json::from_slice(&out.stdout).unwrap()
    };
    let s = stats(&[]);
    assert_eq!(s["method"], "table3d");
    assert_eq!(s["tables_baked"], 1, "{s}");
    assert!(s["shader_seconds"].as_f64().is_some_and(|x| x > 0.0), "{s}");
    let s = stats(&["--method", "pt-linear"]);
    assert_eq!(s["tables_baked"], 0, "{s}");
}

/// Every method renders through `--tf --method` (tables baked on the fly)
/// and close to `exact`; a baked `.tetl` renders through `--lut` like the
/// same method baked on the fly.
#[test]
fn every_method_and_baked_tables_render() {
    let dir = tempfile::tempdir().unwrap();
    let (b, t) = (bundle(dir.path()), tf(dir.path()));
    let render = |extra: &[&str], name: &str| {
        let npy = dir.path().join(format!("{name}.npy"));
        let png = dir.path().join(format!("{name}.png"));
        let mut args = vec!["render", path_arg(&b), "--size", "48x40", "-o", path_arg(&png)];
        args.extend_from_slice(&["--float", path_arg(&npy)]);
        args.extend_from_slice(extra);
        let out = tetview(&args);
        assert!(out.status.success(), "{name}: {}", String::from_utf8_lossy(&out.stderr));
        tet_render::Image::read_npy(&npy).unwrap()
    };
    let exact = render(&["--tf", path_arg(&t), "--method", "exact"], "exact");
    for (method, tol) in
        [("table3d", 2e-2), ("atlas2d", 5e-2), ("poly1", 2e-2), ("poly2", 2e-2), ("poly4", 2e-2), ("partial", 1e-4)]
    {
        let img = render(&["--tf", path_arg(&t), "--method", method], method);
        let d = tet_render::diff(&img, &exact).unwrap();
        assert!(d.max_abs < tol, "{method}: max {} (rms {})", d.max_abs, d.rmse);
    }
    // Bake table3d over the bundle's domain as `tetlut bake` does, then render it.
    let bundle = Bundle::read(&b).unwrap();
    let domain = tet_preint::TableDomain::from_bundle(&bundle).unwrap();
    let text = std::fs::read_to_string(&t).unwrap();
    let tf = tet_preint::TransferFunction::from_json(&text).unwrap();
    let tf = tet_preint::tf_for_domain(&tf, &domain).unwrap();
    let lut = tet_preint::bake(tet_preint::Method::Table3d, &tf, &domain, &Default::default()).unwrap();
    let lut_path = dir.path().join("t.tetl");
    lut.write(&lut_path).unwrap();
    let from_lut = render(&["--lut", path_arg(&lut_path)], "lut");
    let on_the_fly = render(&["--tf", path_arg(&t), "--method", "table3d"], "fly");
    assert!(tet_render::diff(&from_lut, &on_the_fly).unwrap().max_abs < 1e-6);
}

#[test]
fn bad_methods_luts_and_input_are_clear_errors() {
    let dir = tempfile::tempdir().unwrap();
    let (b, t) = (bundle(dir.path()), tf(dir.path()));
    let png = dir.path().join("a.png");
    // A 2D-widget TF with a 1D method: refused, pointing to the bivariate methods.
    let wt = dir.path().join("w.json");
    std::fs::write(
        &wt,
        r#"{"color": [[0, 1, 1, 1], [2, 1, 1, 1]], "opacity": [[0, 0], [2, 0]], "unit_distance": 1,
        "widgets": [{"type": "box", "center": [1.0, 1.0], "width": [0.5, 1.0], "color": [1, 0, 0], "opacity": 1}]}"#,
    )
    .unwrap();
    let out = tetview(&["render", path_arg(&b), "--tf", path_arg(&wt), "--method", "pt-linear", "-o", path_arg(&png)]);
    // Exit code 6 (the method cannot bake with this TF), as `tetlut bake`.
    assert_eq!(out.status.code(), Some(6), "{}", String::from_utf8_lossy(&out.stderr));
    assert!(String::from_utf8_lossy(&out.stderr).contains("biv-exact"), "{}", String::from_utf8_lossy(&out.stderr));
    // A missing or damaged .tetl is an input error naming the file.
    let out = tetview(&["render", path_arg(&b), "--lut", "x.tetl", "-o", path_arg(&png)]);
    assert_eq!(out.status.code(), Some(3), "{}", String::from_utf8_lossy(&out.stderr));
    assert!(String::from_utf8_lossy(&out.stderr).contains("x.tetl"));
    let bad = dir.path().join("bad.tetl");
    std::fs::write(&bad, b"\x89TETL\r\n\x1a garbage").unwrap();
    let out = tetview(&["render", path_arg(&b), "--lut", path_arg(&bad), "-o", path_arg(&png)]);
    assert_eq!(out.status.code(), Some(3), "{}", String::from_utf8_lossy(&out.stderr));
    let out = tetview(&["render", path_arg(&b), "--tf", path_arg(&t), "--method", "table4d", "-o", path_arg(&png)]);
    assert_eq!(out.status.code(), Some(2));
    let out = tetview(&["render", "missing.tetb", "--tf", path_arg(&t), "-o", path_arg(&png)]);
    assert_eq!(out.status.code(), Some(3), "{}", String::from_utf8_lossy(&out.stderr));
    let out = tetview(&["render", path_arg(&b), "--tf", path_arg(&t), "--size", "0x10", "-o", path_arg(&png)]);
    assert_eq!(out.status.code(), Some(2), "{}", String::from_utf8_lossy(&out.stderr));
}

/// `render --gpu` against the CPU path with the same order: pt-linear both
/// ways, table3d (GPU) against `exact` (CPU; the table's discretisation
/// error). Skips with a printed reason where no GPU adapter exists (fails
/// instead with TETKIT_REQUIRE_GPU=1).
#[test]
fn gpu_render_matches_the_cpu_or_skips() {
    let dir = tempfile::tempdir().unwrap();
    let (b, t) = (bundle(dir.path()), tf(dir.path()));
    let png = dir.path().join("g.png");
    let render = |extra: &[&str], npy: &Path| {
        let mut a = vec![
            "render",
            path_arg(&b),
            "--tf",
            path_arg(&t),
            "--size",
            "64x48",
            "--azimuth",
            "30",
            "--elevation",
            "-20",
            "-o",
            path_arg(&png),
            "--float",
            path_arg(npy),
        ];
        a.extend_from_slice(extra);
        tetview(&a)
    };
    // Methods the GPU lacks are a usage error naming the ones it has,
    // whether or not an adapter exists.
    let out = render(&["--gpu", "--method", "exact"], &dir.path().join("x.npy"));
    assert_eq!(out.status.code(), Some(2));
    assert!(String::from_utf8_lossy(&out.stderr)
        .contains("GPU methods: pt-linear, table3d, atlas2d, poly1, poly2, poly4, partial, biv-exact, biv-approx"));

    if let Err(e) = tet_gpu::GpuContext::new_headless() {
        if tet_gpu::gpu_required() {
            panic!("TETKIT_REQUIRE_GPU=1 but: {e}");
        }
        eprintln!("skipped: {e}");
        let out = render(&["--gpu"], &dir.path().join("x.npy"));
        assert_eq!(out.status.code(), Some(7), "{}", String::from_utf8_lossy(&out.stderr));
        return;
    }
    let diff = |a: &Path, b: &Path| {
        let d = tet_render::diff(&tet_render::Image::read_npy(a).unwrap(), &tet_render::Image::read_npy(b).unwrap())
            .unwrap();
        eprintln!(
            "{} vs {}: mean {:.3}/255, max {:.3}/255",
            a.display(),
            b.display(),
            d.mean_abs * 255.0,
            d.max_abs * 255.0
        );
        d
    };
    let (gpu, cpu) = (dir.path().join("gpu.npy"), dir.path().join("cpu.npy"));
    let out = render(&["--gpu", "--method", "pt-linear", "--json"], &gpu);
    assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
    let stats: serde_json::Value = serde_json::from_slice(&out.stdout).unwrap();
    assert_eq!(stats["tables_baked"], 0, "pt-linear needs no table");
    assert_eq!(stats["tets_drawn"], 5);
    assert_eq!(stats["sort_method"], "mpvo");
    assert_eq!(stats["method"], "pt-linear");
    assert_eq!(stats["raster_path"], "compute");
    assert!(stats["device"].as_str().is_some_and(|d| !d.is_empty()));
    for k in ["sort_seconds", "classify_seconds", "raster_seconds", "tonemap_seconds", "total_seconds"] {
        assert!(stats[k].as_f64().is_some_and(|s| s >= 0.0), "{k}: {stats}");
    }
    assert!(std::fs::metadata(&png).unwrap().len() > 100);
    // The GPU draws projected tetrahedra: the CPU PT path is its reference
    // (the walker shades pt-linear per segment, a different image).
    let out = render(&["--method", "pt-linear", "--renderer", "pt"], &cpu);
    assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
    let d = diff(&gpu, &cpu);
    assert!(d.mean_abs <= 0.5 / 255.0 && d.max_abs <= 2.0 / 255.0, "{d:?}");

    let gfx = dir.path().join("gfx.npy");
    let out = render(&["--gpu", "--method", "pt-linear", "--gpu-raster", "graphics", "--json"], &gfx);
    assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
    let stats: serde_json::Value = serde_json::from_slice(&out.stdout).unwrap();
    assert_eq!(stats["raster_path"], "graphics");
    let d = diff(&gfx, &cpu);
    assert!(d.mean_abs <= 0.5 / 255.0 && d.max_abs <= 2.0 / 255.0, "{d:?}");

    // The table is baked once, for the GPU (not also for the CPU shader).
    let out = render(&["--gpu", "--method", "table3d", "--json"], &gpu);
    assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
    let stats: serde_json::Value = serde_json::from_slice(&out.stdout).unwrap();
    assert_eq!(stats["tables_baked"], 1, "{stats}");
    let out = render(&["--method", "exact", "--renderer", "pt"], &cpu);
    assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
    let d = diff(&gpu, &cpu);
    assert!(d.mean_abs <= 0.5 / 255.0 && d.max_abs <= 2.0 / 255.0, "{d:?}");
    let img = tet_render::Image::read_npy(&gpu).unwrap();
    assert!(img.pixels().iter().any(|p| p[3] > 0.2));
    // The same table as the CPU renderer's (tf-nodes axis): the golden-scene
    // tolerance against CPU table3d, baked on the CPU or (--gpu-bake) on the GPU.
    let cpu_t3 = dir.path().join("cpu_t3.npy");
    let out = render(&["--method", "table3d", "--renderer", "pt"], &cpu_t3);
    assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
    let d = diff(&gpu, &cpu_t3);
    assert!(d.mean_abs <= 0.5 / 255.0 && d.max_abs <= 2.0 / 255.0, "{d:?}");
    let baked = dir.path().join("gpu_bake.npy");
    let out = render(&["--gpu", "--method", "table3d", "--gpu-bake", "--json"], &baked);
    assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
    let stats: serde_json::Value = serde_json::from_slice(&out.stdout).unwrap();
    assert_eq!(stats["table_bake_device"], "gpu", "{stats}");
    assert_eq!(stats["tables_baked"], 1, "{stats}");
    assert!(stats["table_bake_seconds"].as_f64().is_some_and(|s| s > 0.0), "{stats}");
    let d = diff(&baked, &cpu_t3);
    assert!(d.mean_abs <= 0.5 / 255.0 && d.max_abs <= 2.0 / 255.0, "{d:?}");
    // --gpu-bake bakes table3d only.
    let out = render(&["--gpu", "--method", "pt-linear", "--gpu-bake"], &baked);
    assert_eq!(out.status.code(), Some(2), "{}", String::from_utf8_lossy(&out.stderr));

    // The 2D-table methods and biv-approx (|∇s| from the CPU scene): the same bake as the CPU path, one table each,
    // culled on the GPU, within the golden-scene tolerance of the CPU image.
    // (poly1 and poly2 run the same shader as poly4: tet_gpu's tests cover them.)
    for method in ["atlas2d", "poly4", "partial", "biv-approx"] {
        let (g, c) = (dir.path().join(format!("gpu_{method}.npy")), dir.path().join(format!("cpu_{method}.npy")));
        let out = render(&["--gpu", "--method", method, "--json"], &g);
        assert!(out.status.success(), "{method}: {}", String::from_utf8_lossy(&out.stderr));
        let stats: serde_json::Value = serde_json::from_slice(&out.stdout).unwrap();
        assert_eq!(stats["method"], method, "{stats}");
        assert_eq!(stats["tables_baked"], 1, "{stats}");
        assert_eq!(stats["cull_device"], "gpu", "{stats}");
        assert_eq!(stats["tets_drawn"].as_u64().unwrap() + stats["tets_culled"].as_u64().unwrap(), 5, "{stats}");
        let out = render(&["--method", method], &c);
        assert!(out.status.success(), "{method}: {}", String::from_utf8_lossy(&out.stderr));
        let d = diff(&g, &c);
        assert!(d.mean_abs <= 0.5 / 255.0 && d.max_abs <= 2.0 / 255.0, "{method}: {d:?}");
        assert!(tet_render::Image::read_npy(&g).unwrap().pixels().iter().any(|p| p[3] > 0.05), "{method}");
    }

    // A backend with no adapter (GL is not compiled in): exit code 7 and a
    // clear message; the CPU path is unaffected.
    let out = Command::new(env!("CARGO_BIN_EXE_tetview"))
        .env("WGPU_BACKEND", "gl")
        .args(["render", path_arg(&b), "--tf", path_arg(&t), "--gpu", "-o", path_arg(&png)])
        .output()
        .unwrap();
    assert_eq!(out.status.code(), Some(7), "{}", String::from_utf8_lossy(&out.stderr));
    assert!(String::from_utf8_lossy(&out.stderr).contains("no GPU adapter"));
}

/// `render --gpu` lit (`--light`, `--light-dir`, `--silhouette`, a view
/// file's lights) draws what the CPU's projected tetrahedra draw with the
/// same flags, shadows (`--shadows`, a view file's, a point light's inside
/// the mesh) included. Skips where no GPU adapter exists (fails instead
/// with TETKIT_REQUIRE_GPU=1).
#[test]
fn gpu_render_lit_matches_the_cpu_or_skips() {
    let dir = tempfile::tempdir().unwrap();
    let (b, t) = (bundle(dir.path()), tf(dir.path()));
    let f = |name: &str| dir.path().join(name);
    let png = f("x.png");
    let render = |extra: &[&str], npy: &Path| {
        let mut a = vec!["render", path_arg(&b), "--tf", path_arg(&t), "--size", "64x48", "--azimuth", "30"];
        a.extend(["--elevation", "-20", "-o", path_arg(&png), "--float", path_arg(npy)]);
        a.extend_from_slice(extra);
        tetview(&a)
    };
    // A view file with shadows, and one whose point light sits inside the
    // mesh (its shadow a cube of maps).
    let shadow_view = f("shadow_view.json");
    let out = render(&["--light-dir", "-1,-0.5,-0.8", "--shadows", "--save-view", path_arg(&shadow_view)], &f("x.npy"));
    assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
    let mut v: serde_json::Value = serde_json::from_str(&std::fs::read_to_string(&shadow_view).unwrap()).unwrap();
    let centre = v["focal_point"].clone();
    v["lighting"]["lights"] = serde_json::json!([{"type": "point", "position": centre, "intensity": 1.0}]);
    let inside_view = f("inside_view.json");
    std::fs::write(&inside_view, v.to_string()).unwrap();
    let with_view = |view: &Path, extra: &[&str], npy: &Path| {
        let mut a = vec!["render", path_arg(&b), "--tf", path_arg(&t), "--view", path_arg(view)];
        a.extend(["-o", path_arg(&png), "--float", path_arg(npy)]);
        a.extend_from_slice(extra);
        tetview(&a)
    };

    if let Err(e) = tet_gpu::GpuContext::new_headless() {
        if tet_gpu::gpu_required() {
            panic!("TETKIT_REQUIRE_GPU=1 but: {e}");
        }
        eprintln!("skipped: {e}");
        let out = render(&["--gpu", "--light"], &f("x.npy"));
        assert_eq!(out.status.code(), Some(7), "{}", String::from_utf8_lossy(&out.stderr));
        return;
    }
    // The same lit view from a view file too (its lights, no shadows).
    let (lit_view, unlit) = (f("lit_view.json"), f("unlit.npy"));
    let out = render(&["--gpu", "--method", "pt-linear"], &unlit);
    assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
    let cases: [(&str, &[&str]); 5] = [
        ("pt-linear", &["--light"]),
        ("pt-linear", &["--light-dir", "-1,-0.5,-0.8", "--silhouette", "2", "--save-view", path_arg(&lit_view)]),
        ("table3d", &["--light-dir", "-1,-0.5,-0.8"]),
        ("table3d", &["--light", "--silhouette", "1"]),
        ("table3d", &["--light-dir", "-1,-0.5,-0.8", "--shadows"]),
    ];
    for (k, (method, flags)) in cases.iter().enumerate() {
        let (gpu, cpu) = (f(&format!("gpu{k}.npy")), f(&format!("cpu{k}.npy")));
        let mut g = vec!["--gpu", "--method", method, "--json"];
        g.extend_from_slice(flags);
        let out = render(&g, &gpu);
        assert!(out.status.success(), "{method} {flags:?}: {}", String::from_utf8_lossy(&out.stderr));
        let stats: serde_json::Value = serde_json::from_slice(&out.stdout).unwrap();
        assert!(stats["device"].as_str().is_some_and(|d| !d.is_empty()), "{stats}");
        let mut c = vec!["--renderer", "pt", "--method", method];
        c.extend(flags.iter().filter(|a| !a.ends_with(".json") && **a != "--save-view"));
        let out = render(&c, &cpu);
        assert!(out.status.success(), "{method} {flags:?}: {}", String::from_utf8_lossy(&out.stderr));
        let (gi, ci) = (tet_render::Image::read_npy(&gpu).unwrap(), tet_render::Image::read_npy(&cpu).unwrap());
        let d = tet_render::diff(&gi, &ci).unwrap();
        eprintln!("--gpu {method} {flags:?} vs --renderer pt: rmse {:.3e}, max {:.3e}", d.rmse, d.max_abs);
        // Measured on lavapipe: rmse ≤ 1.7e-7, max ≤ 1.9e-6.
        assert!(d.rmse <= 1e-6 && d.max_abs <= 1e-5, "{method} {flags:?}: {d:?}");
        if *method == "pt-linear" {
            let u = tet_render::diff(&gi, &tet_render::Image::read_npy(&unlit).unwrap()).unwrap();
            assert!(u.max_abs > 1e-3, "{flags:?} changed nothing on the GPU");
        }
    }
    // A view file's shadows draw what the CPU draws with it. Measured on
    // lavapipe: rmse 1.7e-7 / 4.5e-7, max 1.9e-6 / 3.1e-5 (the light inside
    // the mesh: the cube's lookups in f32 near the light).
    for (view, max) in [(&shadow_view, 1e-5), (&inside_view, 5e-5)] {
        let (gpu, cpu) = (f("gpu_shadow_view.npy"), f("cpu_shadow_view.npy"));
        let out = with_view(view, &["--gpu"], &gpu);
        assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
        let out = with_view(view, &["--renderer", "pt"], &cpu);
        assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
        let (g, c) = (tet_render::Image::read_npy(&gpu).unwrap(), tet_render::Image::read_npy(&cpu).unwrap());
        let d = tet_render::diff(&g, &c).unwrap();
        eprintln!("--gpu --view {} vs --renderer pt: rmse {:.3e}, max {:.3e}", view.display(), d.rmse, d.max_abs);
        assert!(d.rmse <= 1e-6 && d.max_abs <= max, "shadows from {}: {d:?}", view.display());
    }
    let (from_view, direct) = (f("from_view.npy"), f("gpu1.npy"));
    let out = tetview(&[
        "render",
        path_arg(&b),
        "--tf",
        path_arg(&t),
        "--gpu",
        "--method",
        "pt-linear",
        "--view",
        path_arg(&lit_view),
        "--silhouette",
        "2",
        "-o",
        path_arg(&f("x.png")),
        "--float",
        path_arg(&from_view),
    ]);
    assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
    // `--gpu --save-view` writes the lighting too (it once wrote the view alone).
    let same = tet_render::Image::read_npy(&from_view).unwrap() == tet_render::Image::read_npy(&direct).unwrap();
    assert!(same, "a view file's lights draw what --light-dir drew");
}

#[test]
fn bench_prints_a_table_writes_plot_and_json_and_caches_the_reference() {
    let dir = tempfile::tempdir().unwrap();
    let (b, t) = (bundle(dir.path()), tf(dir.path()));
    let (png, json) = (dir.path().join("pareto.png"), dir.path().join("bench.json"));
    let args = [
        "bench",
        path_arg(&b),
        "--tf",
        path_arg(&t),
        "--methods",
        "exact,pt-linear,table3d",
        "--size",
        "24x16",
        "--views",
        "2",
        "--repeat",
        "1",
        "-o",
        path_arg(&png),
        "--json",
        path_arg(&json),
    ];
    let out = tetview(&args);
    let (stdout, stderr) = (String::from_utf8_lossy(&out.stdout), String::from_utf8_lossy(&out.stderr));
    assert!(out.status.success(), "{stderr}");
    assert!(stdout.contains("| method | renderer | bake ms |"), "{stdout}");
    assert!(stdout.contains("| table3d | walk |") && stdout.contains("| table3d | pt |"), "{stdout}");
    assert_eq!(stderr.matches("reference cube view").count(), 2, "{stderr}");
    assert!(std::fs::read(&png).unwrap().starts_with(b"\x89PNG"));
    let v: serde_json::Value = serde_json::from_slice(&std::fs::read(&json).unwrap()).unwrap();
    let rows = v["rows"].as_array().unwrap();
    // Three methods, each by both renderers.
    assert_eq!(rows.len(), 6);
    // The exact method matches the exact reference to f32 rounding, by either renderer.
    for row in &rows[..2] {
        assert_eq!(row["method"], "exact");
        assert!(row["max_abs"].as_f64().unwrap() < 1e-4, "{row}");
        assert_eq!(row["views"].as_array().unwrap().len(), 2);
    }
    assert_eq!((rows[0]["renderer"].as_str(), rows[1]["renderer"].as_str()), (Some("walk"), Some("pt")));
    // A second run reads both references from the cache next to -o.
    let out = tetview(&args);
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert!(out.status.success() && stderr.matches(": cached ").count() == 2, "{stderr}");
    // Bad arguments are usage errors.
    let out = tetview(&["bench", path_arg(&b), "--tf", path_arg(&t), "--methods", "nope"]);
    assert_eq!(out.status.code(), Some(2));
}

/// `--renderer pt` draws by projected tetrahedra (a visibility order), the
/// walker (default) gives the same image for a per-fragment method, and an
/// unknown renderer is a usage error.
#[test]
fn renderer_flag_chooses_walk_or_pt() {
    let dir = tempfile::tempdir().unwrap();
    let (b, t) = (bundle(dir.path()), tf(dir.path()));
    let run = |extra: &[&str], npy: &Path| {
        let mut a = vec![
            "render",
            path_arg(&b),
            "--tf",
            path_arg(&t),
            "--method",
            "exact",
            "--size",
            "32x24",
            "--azimuth",
            "20",
            "--elevation",
            "15",
            "-o",
            "/dev/null",
            "--float",
            path_arg(npy),
            "--json",
        ];
        a.extend_from_slice(extra);
        tetview(&a)
    };
    let (walk, pt) = (dir.path().join("walk.npy"), dir.path().join("pt.npy"));
    let out = run(&[], &walk);
    assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
    let stats: serde_json::Value = serde_json::from_slice(&out.stdout).unwrap();
    assert_eq!(stats["renderer"], "walk");
    assert!(stats["crossings"].as_u64().is_some_and(|c| c > 0), "{stats}");
    let out = run(&["--renderer", "pt"], &pt);
    assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
    let stats: serde_json::Value = serde_json::from_slice(&out.stdout).unwrap();
    assert_eq!(stats["renderer"], "pt");
    assert_eq!(stats["sort_method"], "mpvo");
    let d = tet_render::diff(&tet_render::Image::read_npy(&walk).unwrap(), &tet_render::Image::read_npy(&pt).unwrap())
        .unwrap();
    assert!(d.max_abs < 1e-5, "{d:?}");
    let out = run(&["--renderer", "zsweep"], &pt);
    assert_eq!(out.status.code(), Some(2));
    assert!(String::from_utf8_lossy(&out.stderr).contains("walk, pt"));
    // --adaptive: the walker's preview sampling; every covered pixel
    // walked or interpolated, close to the full walk on this smooth cube.
    let ad = dir.path().join("adaptive.npy");
    let out = run(&["--adaptive", "0.01"], &ad);
    assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
    let st: serde_json::Value = serde_json::from_slice(&out.stdout).unwrap();
    let full: serde_json::Value = serde_json::from_slice(&run(&[], &walk).stdout).unwrap();
    assert_eq!(
        st["walk_rays"].as_u64().unwrap() + st["walk_rays_interpolated"].as_u64().unwrap(),
        full["walk_rays"].as_u64().unwrap(),
        "{st}"
    );
    let d = tet_render::diff(&tet_render::Image::read_npy(&walk).unwrap(), &tet_render::Image::read_npy(&ad).unwrap())
        .unwrap();
    assert!(d.max_abs < 0.02, "{d:?}");
    for bad in [&["--adaptive=-0.1"][..], &["--adaptive", "NaN"], &["--adaptive", "0.01", "--renderer", "pt"]] {
        let out = run(bad, &ad);
        assert_eq!(out.status.code(), Some(2), "{bad:?}");
        assert!(String::from_utf8_lossy(&out.stderr).contains("adaptive"), "{bad:?}");
    }
}

fn saved_view(path: &Path) -> tet_render::ViewSpec {
    tet_render::ViewSpec::from_json(&std::fs::read_to_string(path).unwrap()).unwrap()
}

/// `--view-up` sets the up of the default view in render and reference; the
/// saved view keeps it and reproduces the image; point clouds are z-up by
/// default (seen from −y, above the horizon).
#[test]
fn view_up_flag_default_z_up_and_saved_views_round_trip() {
    let dir = tempfile::tempdir().unwrap();
    let (b, t) = (bundle(dir.path()), tf(dir.path()));
    let f = |name: &str| path_arg(&dir.path().join(name)).to_string();
    let (png, npy, npy2, view) = (f("a.png"), f("a.npy"), f("b.npy"), f("v.json"));
    let (b, t) = (path_arg(&b).to_string(), path_arg(&t).to_string());
    let render = |extra: &[&str]| {
        let mut a = vec!["render", &b, "--tf", &t, "--method", "exact", "--size", "32x24", "--tonemap", "none"];
        a.extend_from_slice(extra);
        tetview(&a)
    };
    let out = render(&["--view-up", "0,0,1", "--azimuth", "20", "-o", &png, "--float", &npy, "--save-view", &view]);
    assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
    let v = saved_view(Path::new(&view));
    assert!(v.view_up[2] > 0.999, "{:?}", v.view_up);
    let out = render(&["--view", &view, "-o", &png, "--float", &npy2]);
    assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
    assert_eq!(
        tet_render::Image::read_npy(Path::new(&npy)).unwrap(),
        tet_render::Image::read_npy(Path::new(&npy2)).unwrap()
    );
    // reference takes the flag too and frames the same view.
    let rv = f("rv.json");
    let out = tetview(&[
        "reference",
        &b,
        "--tf",
        &t,
        "--size",
        "32x24",
        "--view-up",
        "0,0,1",
        "--azimuth",
        "20",
        "--float",
        &npy2,
        "--save-view",
        &rv,
    ]);
    assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
    assert_eq!(saved_view(Path::new(&rv)), v);
    // Bad values and --view together with --view-up are command-line errors.
    for bad in [&["--view-up", "0,0,0"][..], &["--view-up", "1,2"], &["--view", &view, "--view-up", "0,1,0"]] {
        let out = tetview(&[&["render", &b, "--tf", &t, "-o", &png][..], bad].concat());
        assert_eq!(out.status.code(), Some(2), "{bad:?}: {}", String::from_utf8_lossy(&out.stderr));
    }
    // A point cloud's default view is z-up, from −y and above.
    let cloud = bundle_with(dir.path(), "cloud.tetb", |p| p[0], "delaunay");
    let out = tetview(&["render", path_arg(&cloud), "--tf", &t, "--size", "16x16", "-o", &png, "--save-view", &view]);
    assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
    let v = saved_view(Path::new(&view));
    assert!(v.view_up[2] > 0.8 && v.position[1] < v.focal_point[1] && v.position[2] > v.focal_point[2], "{v:?}");
    // Everything else keeps VTK's +y up, looking down −z.
    let out = tetview(&["render", &b, "--tf", &t, "--size", "16x16", "-o", &png, "--save-view", &view]);
    assert!(out.status.success());
    assert_eq!(saved_view(Path::new(&view)).view_up, [0.0, 1.0, 0.0]);
}

/// `render` and `reference` take one set of camera and display flags
/// (`camera_args`): the same orbit, zoom, projection and size give the same
/// saved view; a view file with orbit or projection flags is refused by both
/// (before, `reference` orbited the file's camera and `render` refused); the
/// same tone-map values are accepted.
#[test]
fn render_and_reference_share_the_camera_and_display_flags() {
    let dir = tempfile::tempdir().unwrap();
    let (b, t, f) = cube_tf_and_paths(dir.path());
    let (png, npy, rv, vv) = (f("a.png"), f("a.npy"), f("r.json"), f("v.json"));
    let camera = ["--azimuth", "-25", "--elevation", "30", "--zoom", "1.5", "--parallel", "--size", "40x24"];
    let out = tetview(&[&["render", &b, "--tf", &t, "-o", &png, "--save-view", &vv][..], &camera].concat());
    assert!(out.status.success(), "{}", stderr(&out));
    let out = tetview(&[&["reference", &b, "--tf", &t, "--float", &npy, "--save-view", &rv][..], &camera].concat());
    assert!(out.status.success(), "{}", stderr(&out));
    let (v, r) = (saved_view(Path::new(&vv)), saved_view(Path::new(&rv)));
    assert_eq!(v, r);
    assert!(v.parallel && v.size == [40, 24], "{v:?}");
    for cmd in [["render", "-o", png.as_str()], ["reference", "--float", npy.as_str()]] {
        for bad in [
            &["--view", vv.as_str(), "--azimuth", "10"][..],
            &["--view", vv.as_str(), "--parallel"],
            &["--tonemap", "filmic"],
        ] {
            let out = tetview(&[&[cmd[0], &b, "--tf", &t, cmd[1], cmd[2]][..], bad].concat());
            assert_eq!(out.status.code(), Some(2), "{} {bad:?}: {}", cmd[0], stderr(&out));
        }
        let out = tetview(&[cmd[0], &b, "--tf", &t, cmd[1], cmd[2], "--view", &vv, "--tonemap", "none"]);
        assert!(out.status.success(), "{}: {}", cmd[0], stderr(&out));
    }
}

/// A bundle whose scalar is constant renders, with a warning naming the value.
#[test]
fn constant_scalar_warns_with_its_value() {
    let dir = tempfile::tempdir().unwrap();
    let (b, t) = (bundle_with(dir.path(), "flat.tetb", |_| 0.75, ""), tf(dir.path()));
    let png = dir.path().join("a.png");
    let out = tetview(&["render", path_arg(&b), "--tf", path_arg(&t), "--size", "16x16", "-o", path_arg(&png)]);
    assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
    let e = String::from_utf8_lossy(&out.stderr);
    assert!(e.contains("warning: the scalar 's' is constant (0.75)"), "{e}");
}

/// Regression: tetview wrote its images with mode 0600 (a private temporary
/// file renamed into place) where tetprep's bundles got 0644. Every output
/// now gets the mode File::create gives.
#[cfg(unix)]
#[test]
fn every_output_gets_the_mode_file_create_gives() {
    use std::os::unix::fs::PermissionsExt;
    let dir = tempfile::tempdir().unwrap();
    let (b, t) = (bundle(dir.path()), tf(dir.path()));
    let plain = dir.path().join("plain");
    std::fs::File::create(&plain).unwrap();
    let mode = |p: &Path| std::fs::metadata(p).unwrap().permissions().mode() & 0o777;
    let f = |name: &str| dir.path().join(name);
    let (png, npy, view, rpng, rnpy, dpng) = (f("a.png"), f("a.npy"), f("v.json"), f("r.png"), f("r.npy"), f("d.png"));
    let s = |p: &Path| path_arg(p).to_string();
    let runs: Vec<Vec<String>> = vec![
        vec![
            "render".into(),
            s(&b),
            "--tf".into(),
            s(&t),
            "--size".into(),
            "16x16".into(),
            "-o".into(),
            s(&png),
            "--float".into(),
            s(&npy),
            "--save-view".into(),
            s(&view),
        ],
        vec![
            "reference".into(),
            s(&b),
            "--tf".into(),
            s(&t),
            "--size".into(),
            "16x16".into(),
            "-o".into(),
            s(&rpng),
            "--float".into(),
            s(&rnpy),
        ],
        vec!["diff".into(), s(&npy), s(&rnpy), "-o".into(), s(&dpng)],
    ];
    for args in runs {
        let out = Command::new(env!("CARGO_BIN_EXE_tetview")).args(&args).output().unwrap();
        assert!(out.status.success(), "{args:?}: {}", String::from_utf8_lossy(&out.stderr));
    }
    for p in [&png, &npy, &view, &rpng, &rnpy, &dpng] {
        assert_eq!(mode(p), mode(&plain), "{}", p.display());
    }
}

fn stderr(out: &std::process::Output) -> String {
    String::from_utf8_lossy(&out.stderr).into_owned()
}

/// The exit codes every tetkit program shares (tet_cli::ExitKind), for the
/// failures `tetprep` and `tetlut` test the same way in their tests/cli.rs.
#[test]
fn exit_codes_are_the_shared_ones() {
    let dir = tempfile::tempdir().unwrap();
    let (b, t) = (bundle(dir.path()), tf(dir.path()));
    let png = dir.path().join("a.png");
    let render = |bundle: &Path, tf: &Path, out: &Path| {
        tetview(&["render", path_arg(bundle), "--tf", path_arg(tf), "-o", path_arg(out)])
    };
    // 3: a truncated bundle (as `tetprep info`), a missing bundle or TF file.
    let cut = dir.path().join("cut.tetb");
    let bytes = std::fs::read(&b).unwrap();
    std::fs::write(&cut, &bytes[..bytes.len() / 2]).unwrap();
    let out = render(&cut, &t, &png);
    assert_eq!(out.status.code(), Some(3), "{}", stderr(&out));
    assert!(stderr(&out).contains("cut.tetb"), "{}", stderr(&out));
    let out = render(&dir.path().join("missing.tetb"), &t, &png);
    assert_eq!(out.status.code(), Some(3), "{}", stderr(&out));
    let out = render(&b, &dir.path().join("missing.json"), &png);
    assert_eq!(out.status.code(), Some(3), "{}", stderr(&out));
    assert!(stderr(&out).contains("missing.json"), "{}", stderr(&out));
    // 2: a typo in the TF file (as `tetlut bake`), a bad --range or --size.
    let typo = dir.path().join("typo.json");
    std::fs::write(&typo, r#"{"color": [[0, 1, 1, 1]], "opacity": [[0.5, 1], [0.2, 1]], "unit_distance": 1}"#).unwrap();
    let out = render(&b, &typo, &png);
    assert_eq!(out.status.code(), Some(2), "{}", stderr(&out));
    assert!(stderr(&out).contains("opacity[1]"), "{}", stderr(&out));
    let out = tetview(&["render", path_arg(&b), "--tf", path_arg(&t), "--range", "1,0", "-o", path_arg(&png)]);
    assert_eq!(out.status.code(), Some(2), "{}", stderr(&out));
    // 5: an output in a directory that does not exist (PNG, --save-view, reference).
    let out = render(&b, &t, &dir.path().join("no/such/dir/a.png"));
    assert_eq!(out.status.code(), Some(5), "{}", stderr(&out));
    let out = tetview(&[
        "render",
        path_arg(&b),
        "--tf",
        path_arg(&t),
        "-o",
        path_arg(&png),
        "--save-view",
        path_arg(&dir.path().join("no/such/dir/v.json")),
    ]);
    assert_eq!(out.status.code(), Some(5), "{}", stderr(&out));
    let out = tetview(&[
        "reference",
        path_arg(&b),
        "--tf",
        path_arg(&t),
        "--size",
        "16x16",
        "--float",
        path_arg(&dir.path().join("no/such/dir/r.npy")),
    ]);
    assert_eq!(out.status.code(), Some(5), "{}", stderr(&out));
    // 3 for an unreadable image in `diff`, 4 for two that do not match in size.
    let (small, big) = (dir.path().join("s.npy"), dir.path().join("b.npy"));
    for (p, size) in [(&small, "8x8"), (&big, "9x8")] {
        let out = tetview(&["reference", path_arg(&b), "--tf", path_arg(&t), "--size", size, "--float", path_arg(p)]);
        assert!(out.status.success(), "{}", stderr(&out));
    }
    let out = tetview(&["diff", path_arg(&small), path_arg(&dir.path().join("none.npy"))]);
    assert_eq!(out.status.code(), Some(3), "{}", stderr(&out));
    let out = tetview(&["diff", path_arg(&small), path_arg(&big)]);
    assert_eq!(out.status.code(), Some(4), "{}", stderr(&out));
    // `view`'s flags are checked before any window opens: an unknown
    // --colormap (the flag `render` has too) is a usage error.
    let out = tetview(&["view", path_arg(&b), "--colormap", "rainbow"]);
    assert_eq!(out.status.code(), Some(2), "{}", stderr(&out));
    assert!(stderr(&out).contains("rainbow"), "{}", stderr(&out));
    // --help lists the table.
    let out = tetview(&["--help"]);
    let help = String::from_utf8_lossy(&out.stdout);
    assert!(help.contains("Exit codes") && help.contains("7  no usable GPU adapter"), "{help}");
}

// The TF files' expected failures, the same table tetlut's CLI test uses.
#[path = "../../tet_preint/tests/data/tf/failures.rs"]
mod tf_files;
use tf_files::{tf_failures, TF_DATA};

const SAMPLES: &str = concat!(env!("CARGO_MANIFEST_DIR"), "/../../formats/samples");

#[test]
fn tf_files_fail_as_in_tetlut_and_a_paraview_preset_renders() {
    let dir = tempfile::tempdir().unwrap();
    let png = dir.path().join("a.png");
    let bundle = format!("{SAMPLES}/cube5.tetb");
    let render = |tf: &str, extra: &[&str]| {
        let args = [
            &["render", &bundle, "--tf", tf, "--method", "pt-linear", "--size", "16x16", "-o", path_arg(&png)][..],
            extra,
        ];
        tetview(&args.concat())
    };
    for (tf, code, line) in tf_failures() {
        let out = render(&tf, &[]);
        assert_eq!(out.status.code(), Some(code), "{tf}: {}", stderr(&out));
        assert_eq!(stderr(&out).lines().next(), Some(format!("tetview: {line}").as_str()), "{tf}");
    }
    // A ParaView preset: imported normalized, mapped onto the bundle's
    // scalar range as tetlut maps it (tet_preint::tf_for_bundle).
    let preset = format!("{TF_DATA}/preset_cool_to_warm.json");
    let saved = dir.path().join("saved.json");
    let out = render(&preset, &["--save-tf", path_arg(&saved)]);
    assert!(out.status.success(), "{}", stderr(&out));
    let want = tet_preint::tf_for_bundle(
        &tet_preint::load_tf(Path::new(&preset)).unwrap(),
        &Bundle::read(Path::new(&bundle)).unwrap(),
    )
    .unwrap();
    assert_eq!(tet_preint::load_tf(&saved).unwrap(), want);
}

/// A bundle whose scalar is constant has no automatic TF: `render` exits 4
/// with tet_preint's one message (the viewer the same; see tests/view.rs).
#[test]
fn constant_scalar_without_tf_is_rejected_with_the_one_message() {
    let dir = tempfile::tempdir().unwrap();
    let b = bundle_with(dir.path(), "flat.tetb", |_| 0.75, "");
    let png = dir.path().join("a.png");
    let out = tetview(&["render", path_arg(&b), "--size", "16x16", "-o", path_arg(&png)]);
    assert_eq!(out.status.code(), Some(4), "{}", stderr(&out));
    assert!(stderr(&out).contains("the scalar is constant (0.75)"), "{}", stderr(&out));
}

/// Lights from `--light-dir` or the view file, shadows, the lit reference,
/// and the bad combinations.
#[test]
fn lights_and_shadows_render_against_the_lit_reference() {
    let dir = tempfile::tempdir().unwrap();
    let (b, t, f) = cube_tf_and_paths(dir.path());
    let (lit, dark, reference, vv) = (f("lit.npy"), f("dark.npy"), f("ref.npy"), f("v.json"));
    let size = ["--size", "24x24", "--azimuth", "30", "--elevation", "20"];
    let render = |extra: &[&str], npy: &str| {
        tetview(&[&["render", &b, "--tf", &t, "-o", &f("x.png"), "--float", npy][..], &size, extra].concat())
    };
    let out = render(&["--light-dir", "-1,-0.5,-0.8"], &lit);
    assert!(out.status.success(), "{}", stderr(&out));
    let out = render(&["--light-dir", "-1,-0.5,-0.8", "--shadows", "--save-view", &vv], &dark);
    assert!(out.status.success(), "{}", stderr(&out));
    let saved: serde_json::Value = serde_json::from_str(&std::fs::read_to_string(&vv).unwrap()).unwrap();
    assert_eq!(saved["lighting"]["shadows"], true, "{saved}");
    assert_eq!(saved["lighting"]["lights"][0]["type"], "directional", "{saved}");
    // The reference lights from the saved view file alone: with exact
    // shadow rays, and from the renderers' shadow field. On this 5-tet cube
    // the field (8 vertex values) is far from the exact shadow; the
    // renderer must match the reference lit from the same field.
    let field_ref = f("ref_field.npy");
    let out = tetview(&["reference", &b, "--tf", &t, "--view", &vv, "--float", &reference]);
    assert!(out.status.success(), "{}", stderr(&out));
    let out =
        tetview(&["reference", &b, "--tf", &t, "--view", &vv, "--float", &field_ref, "--shadows", "--shadow-field"]);
    assert!(out.status.success(), "{}", stderr(&out));
    let read = |p: &str| tet_render::Image::read_npy(Path::new(p)).unwrap();
    let d = tet_render::diff(&read(&dark), &read(&field_ref)).unwrap();
    assert!(d.rmse < 5e-3, "shadowed render vs the reference lit from its field: {d:?}");
    let exact = read(&reference);
    assert!(exact.pixels().iter().all(|p| p.iter().all(|c| c.is_finite())));
    let shadow = tet_render::diff(&read(&dark), &read(&lit)).unwrap();
    assert!(shadow.max_abs > 1e-3, "shadows change the picture: {shadow:?}");
    // Bad combinations: usage errors (2); a bad lighting object: the view file's error.
    let with_view = |view: &str, extra: &[&str]| {
        tetview(&[&["render", &b, "--tf", &t, "-o", &f("x.png"), "--view", view][..], extra].concat())
    };
    for bad in [&["--shadows"][..], &["--light-dir", "0,0,0"]] {
        let out = render(bad, &lit);
        assert_eq!(out.status.code(), Some(2), "{bad:?}: {}", stderr(&out));
    }
    let out = with_view(&vv, &["--light-dir", "0,0,-1"]);
    assert_eq!(out.status.code(), Some(2), "{}", stderr(&out));
    let broken = f("broken.json");
    let mut v = saved.clone();
    v["lighting"]["lights"][0]["type"] = "spot".into();
    std::fs::write(&broken, v.to_string()).unwrap();
    let out = with_view(&broken, &[]);
    assert!(!out.status.success() && stderr(&out).contains("lighting"), "{}", stderr(&out));
}
