//! Every WGSL module, exactly as the GPU receives it, parses and validates
//! with naga (the version wgpu uses): needs no GPU.

#[test]
fn every_shader_parses_and_validates() {
    let sources = tet_gpu::shader_sources();
    assert_eq!(sources.len(), 3);
    for (name, src) in sources {
        let module = naga::front::wgsl::parse_str(&src)
            .unwrap_or_else(|e| panic!("{name}.wgsl does not parse:\n{}", e.emit_to_string(&src)));
        let mut v =
            naga::valid::Validator::new(naga::valid::ValidationFlags::all(), naga::valid::Capabilities::default());
        if let Err(e) = v.validate(&module) {
            panic!("{name}.wgsl does not validate:\n{}", e.emit_to_string(&src));
        }
        let entries: Vec<&str> = module.entry_points.iter().map(|e| e.name.as_str()).collect();
        let want: &[&str] = match name {
            "classify" => &["classify"],
            "raster" => &["vs", "fs"],
            "tonemap" => &["reduce", "fit", "map"],
            other => panic!("unexpected module {other}"),
        };
        for w in want {
            assert!(entries.contains(w), "{name}: entry point {w} missing (found {entries:?})");
        }
    }
}

#[test]
fn shader_files_on_disk_are_all_included() {
    let dir = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("shaders");
    let mut names: Vec<String> = std::fs::read_dir(&dir)
        .unwrap()
        .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
        .filter(|n| n.ends_with(".wgsl"))
        .collect();
    names.sort();
    assert_eq!(names, ["classify.wgsl", "common.wgsl", "raster.wgsl", "tonemap.wgsl"]);
}
