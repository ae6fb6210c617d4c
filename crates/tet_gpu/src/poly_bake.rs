//! The poly1/2/4 tables (tet_preint's `PolyTable`, Guthe et al. 2002) baked by a
//! compute shader (shaders/poly_bake.wgsl) in f32 and read back into a
//! `PolyTable`, which the CPU shades with and `GpuShader::poly` uploads
//! for the GPU renderer.

use crate::bake::{time_setup_and_bake, GpuBakeStats};
use crate::gpu_types::PolyBakeParams;
use crate::render::{bind_all, bind_group, buffer, buffer_init, dispatch, storage_entries, READ_BACK};
use crate::{map_read, shader_source_plain, GpuContext, GpuError, POLY_BAKE_WGSL};
use std::time::Instant;
use tet_preint::poly::{band_for, inverse_vandermonde};
use tet_preint::{AlphaTable, Emission, PolyParams, PolyTable, TransferFunction};

/// Bakes `PolyTable::build(tf, p)`'s tables on the GPU (f32 throughout,
/// where the CPU integrates in f64) and reads them back into a
/// [`PolyTable`] with the standard α table. Errors: parameters the CPU
/// build rejects, a TF with widgets (as the CPU), device limits.
pub fn bake_poly(
    ctx: &GpuContext,
    tf: &TransferFunction,
    p: &PolyParams,
) -> Result<(PolyTable, GpuBakeStats), GpuError> {
    let t_setup = Instant::now();
    let bad = |why: String| GpuError::Input(format!("GPU poly bake: {why}"));
    if ![1, 2, 4].contains(&p.degree) || !(2..=16384).contains(&p.res) {
        return Err(bad(format!("degree {} must be 1, 2 or 4 and res {} in [2, 16384]", p.degree, p.res)));
    }
    let range_ok = p.s_lo.is_finite() && p.s_hi.is_finite() && p.s_lo < p.s_hi;
    if !(range_ok && p.l_max > 0.0 && p.l_max.is_finite()) {
        return Err(bad(format!(
            "range [{}, {}] and l_max {} must be finite, ordered, positive",
            p.s_lo, p.s_hi, p.l_max
        )));
    }
    if p.max_ds.is_nan() || p.max_ds <= 0.0 {
        return Err(bad(format!("max_ds {} must be positive", p.max_ds)));
    }
    if !tf.widgets().is_empty() {
        return Err(bad(format!("{} TF widgets: rasterize them first", tf.widgets().len())));
    }
    let (n, res) = (p.degree, p.res);
    let band = band_for(res, p.s_lo, p.s_hi, p.max_ds);
    let row_len = band.map_or(res, |b| 2 * b + 1);
    let stride = 3 * (n + 1);
    let cells = res * row_len;
    let rho_bytes = (cells * 4) as u64;
    let coef_bytes = (cells * stride * 4) as u64;
    let limit = ctx.device.limits().max_storage_buffer_binding_size;
    crate::render::check_size("poly coefficients", coef_bytes, limit)?;
    if row_len > 65535 * 64 || res > 65535 {
        return Err(bad(format!("res {res} exceeds one dispatch")));
    }
    let step = (p.s_hi - p.s_lo) / (res - 1) as f64;
    let grid: Vec<f32> =
        (0..res).map(|i| if i + 1 == res { p.s_hi } else { p.s_lo + i as f64 * step } as f32).collect();
    let mut xs: Vec<f64> = tf.color_nodes().iter().map(|c| c.x).chain(tf.opacity_nodes().iter().map(|o| o.x)).collect();
    xs.sort_by(f64::total_cmp);
    xs.dedup();
    let nodes: Vec<[f32; 4]> = xs
        .iter()
        .flat_map(|&x| {
            let k = tf.color(x);
            [[x as f32, tf.extinction(x) as f32, 0.0, 0.0], [k[0] as f32, k[1] as f32, k[2] as f32, 0.0]]
        })
        .collect();
    let vinv: Vec<f32> = inverse_vandermonde(n).iter().map(|&v| v as f32).collect();
    let params = PolyBakeParams {
        degree: n as u32,
        res: res as u32,
        row_len: row_len as u32,
        band: band.map_or(u32::MAX, |b| b as u32),
        n_nodes: xs.len() as u32,
        independent: (tf.emission() == Emission::Independent) as u32,
        l_max: p.l_max as f32,
        ..bytemuck::Zeroable::zeroed()
    };
    let dev = &ctx.device;
    let (pipeline, group, rho_buf, coef_buf, rho_read, coef_read) = ctx.checked(|| {
        let cs = wgpu::ShaderStages::COMPUTE;
        // Parameters, nodes, the inverse Vandermonde matrix and grid read; ρ and coefficients written.
        let mut entries = vec![crate::render::uniform_entry(0, cs)];
        entries.extend(storage_entries(1, cs, &[true, true, true, false, false]));
        let source = shader_source_plain(POLY_BAKE_WGSL);
        let (layout, pipeline) = crate::render::compute_pipeline(dev, "poly bake", &entries, source, "poly_bake");
        let init = |label: &str, contents: &[u8], usage| buffer_init(dev, label, contents, usage);
        let empty = |label: &str, size: u64, usage| buffer(dev, label, size, usage);
        let st = wgpu::BufferUsages::STORAGE;
        let out = st | wgpu::BufferUsages::COPY_SRC;
        let read = READ_BACK;
        let uni = init("poly params", bytemuck::bytes_of(&params), wgpu::BufferUsages::UNIFORM);
        let nodes_buf = init("poly nodes", bytemuck::cast_slice(&nodes), st);
        let vinv_buf = init("poly vinv", bytemuck::cast_slice(&vinv), st);
        let grid_buf = init("poly grid", bytemuck::cast_slice(&grid), st);
        let rho_buf = empty("poly rho", rho_bytes, out);
        let coef_buf = empty("poly coef", coef_bytes, out);
        let rho_read = empty("poly rho read-back", rho_bytes, read);
        let coef_read = empty("poly coef read-back", coef_bytes, read);
        let buffers = [&uni, &nodes_buf, &vinv_buf, &grid_buf, &rho_buf, &coef_buf];
        let group = bind_group(dev, "poly bake", &layout, &bind_all(0, &buffers));
        (pipeline, group, rho_buf, coef_buf, rho_read, coef_read)
    })?;
    let (setup_seconds, bake_seconds) = time_setup_and_bake(ctx, t_setup, |enc| {
        dispatch(enc, "poly bake", &pipeline, &group, &[], ((row_len as u32).div_ceil(64), res as u32));
    })?;
    ctx.checked(|| {
        let mut enc = dev.create_command_encoder(&Default::default());
        enc.copy_buffer_to_buffer(&rho_buf, 0, &rho_read, 0, rho_bytes);
        enc.copy_buffer_to_buffer(&coef_buf, 0, &coef_read, 0, coef_bytes);
        ctx.queue.submit([enc.finish()]);
    })?;
    let rho: Vec<f32> = bytemuck::pod_collect_to_vec(&map_read(ctx, &rho_read)?);
    let coef: Vec<f32> = bytemuck::pod_collect_to_vec(&map_read(ctx, &coef_read)?);
    let mc = tf.max_color();
    let table = PolyTable::from_parts(
        n,
        res,
        band,
        [p.s_lo as f32, p.s_hi as f32],
        p.l_max as f32,
        tf.emission(),
        [mc[0] as f32, mc[1] as f32, mc[2] as f32],
        rho,
        coef,
        AlphaTable::standard(),
    )
    .map_err(|e| GpuError::Readback(format!("GPU poly bake: {e}")))?;
    Ok((table, GpuBakeStats { setup_seconds, bake_seconds, entries: cells as u64 }))
}
