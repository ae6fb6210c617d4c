//! Every WGSL module, exactly as the GPU receives it, parses and validates
//! with naga (the version wgpu uses): needs no GPU.

#[test]
fn every_shader_parses_and_validates() {
    let sources = tet_gpu::shader_sources();
    assert_eq!(sources.len(), 9);
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
            "bin" => &["bin_count", "bin_fill", "tile_ranges", "composite"],
            "sort" => &["scan_blocks", "scan_sums", "scan_add", "depth_keys", "rs_hist", "rs_scatter"],
            "tonemap" => &["reduce", "fit", "map"],
            "bake" => &["bake"],
            "probe" => &["probe"],
            "poly_bake" => &["poly_bake"],
            "cull" => &["cull_flags", "cull_scatter"],
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
    assert_eq!(
        names,
        [
            "bake.wgsl",
            "bin.wgsl",
            "biv_exact.wgsl",
            "classify.wgsl",
            "common.wgsl",
            "cull.wgsl",
            "fragment.wgsl",
            "lighting.wgsl",
            "poly_bake.wgsl",
            "probe.wgsl",
            "raster.wgsl",
            "sort.wgsl",
            "tonemap.wgsl"
        ]
    );
}

/// Every Pod struct of gpu_types.rs has the size and field offsets naga
/// gives its WGSL mirror.
#[test]
fn pod_layouts_match_the_wgsl_structs() {
    use std::mem::{offset_of, size_of};
    use tet_gpu::gpu_types::*;
    macro_rules! layout {
        ($ty:ty, $wgsl:literal, [$($field:ident),*]) => {
            (stringify!($ty), $wgsl, size_of::<$ty>(), vec![$((stringify!($field), offset_of!($ty, $field))),*])
        };
    }
    let expected = [
        layout!(
            FrameUniforms,
            "Frame",
            [
                eye_rel,
                right,
                up,
                forward,
                ax,
                bx,
                ay,
                by,
                width,
                height,
                near_depth,
                parallel,
                n_slots,
                method,
                n_color_nodes,
                n_opacity_nodes,
                table_s_lo,
                table_inv_ds,
                table_inv_dl,
                table_reach,
                table_n_s,
                table_n_l,
                groups_x,
                table_axis_segs,
                table_optical_depth,
                _pad0,
                _pad1,
                _pad2
            ]
        ),
        layout!(TetGeom, "TetGeom", [hull, thick, n_hull, mode]),
        layout!(TetShade, "TetShade", [planes, s_a, s_b, extra]),
        layout!(
            ToneParams,
            "ToneParams",
            [background, width, height, n_partials, reinhard, key, exposure, groups_x, _pad]
        ),
        layout!(ToneFit, "ToneFit", [scale, white_sq, log_average, _pad]),
        layout!(SortParams, "SortParams", [eye_rel, forward, n, shift, n_blocks, groups_x]),
        layout!(BinParams, "BinParams", [tiles_x, tiles_y, n_slots, groups_x, slot_lo, slot_hi, pair_base, n_pairs]),
        layout!(
            BakeParams,
            "BakeParams",
            [n_s, n_l, n_color, n_opacity, n_breaks, row_width, independent, f16, dl, len_max, oversampling, bend]
        ),
        layout!(
            PolyBakeParams,
            "PolyBakeParams",
            [degree, res, row_len, band, n_nodes, independent, _pad0, _pad1, l_max, _pad2, _pad3, _pad4]
        ),
        layout!(
            ShadeParams,
            "ShadeParams",
            [
                s_lo,
                s_scale,
                inv_l_max,
                alpha_inv_step,
                max_color,
                res,
                band,
                degree,
                independent,
                alpha_len,
                planes,
                cols,
                knots,
                n_knots,
                widgets,
                n_widgets,
                subsegments
            ]
        ),
        layout!(CullParams, "CullParams", [n, n_intervals, groups_x, n_widgets, use_g, _pad0, _pad1, _pad2]),
        layout!(GpuLight, "GpuLight", [v, kind, _pad0, _pad1, _pad2]),
        layout!(
            LightParams,
            "LightParams",
            [
                ambient,
                diffuse,
                specular,
                shininess,
                n_lights,
                lit,
                silhouette,
                silhouette_exp,
                gradient_floor,
                split_tolerance,
                max_pieces,
                enabled,
                resplit_tolerance,
                max_subpieces,
                subpiece_budget,
                _pad,
                lights
            ]
        ),
        layout!(
            GpuShadowMap,
            "ShadowMap",
            [
                e1,
                e2,
                d,
                origin,
                u0,
                v0,
                t0,
                du,
                dv,
                bin_len,
                nu,
                nv,
                knot_base,
                index_base,
                has_map,
                cube,
                fine_base,
                finer_base,
                finest_base,
                _pad2
            ]
        ),
    ];
    let modules: Vec<naga::Module> =
        tet_gpu::shader_sources().iter().map(|(_, src)| naga::front::wgsl::parse_str(src).unwrap()).collect();
    for (rust, wgsl, size, fields) in expected {
        let (members, span) = modules
            .iter()
            .flat_map(|m| m.types.iter())
            .find_map(|(_, ty)| match (&ty.name, &ty.inner) {
                (Some(n), naga::TypeInner::Struct { members, span }) if n == wgsl => Some((members.clone(), *span)),
                _ => None,
            })
            .unwrap_or_else(|| panic!("struct {wgsl} not found in the WGSL"));
        assert_eq!(span as usize, size, "{rust} vs {wgsl}: size");
        assert_eq!(members.len(), fields.len(), "{rust} vs {wgsl}: field count");
        for (m, (name, off)) in members.iter().zip(fields) {
            assert_eq!(m.name.as_deref(), Some(name), "{rust} vs {wgsl}: field order");
            assert_eq!(m.offset as usize, off, "{rust}.{name}: offset");
        }
    }
}
