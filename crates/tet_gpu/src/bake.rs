//! GPU pre-integration: table3d baked by a compute shader (shaders/bake.wgsl)
//! straight into the 3D texture the renderer samples (the probe that runs
//! the renderer's per-fragment lookup on given triples is in methods.rs).
//!
//! The bake integrates every entry as tet_preint's default build
//! (`Build3d::SliceRecurrence`): the same scalar axis
//! ([`Table3d::axis_knots`]), the same pieces along the segment and the
//! same closed forms per piece; bake.wgsl says where it differs (at
//! rounding level). [`GpuAccumulation::F16`] rounds the running sums to f16
//! after every piece, for the precision study.

use crate::gpu_types::{BakeParams, BAKE_WG, METHOD_TABLE3D};
use crate::render::{
    bind_all, bind_group, bind_view, buffer_init, check_table_dims, storage_entries, storage_texture_entry,
    tf_node_rows, GpuShader, TableGrid,
};
use crate::{shader_source_plain, GpuContext, GpuError, BAKE_WGSL};
use std::time::Instant;
use tet_preint::{Build3d, Emission, Precision, Table3d, Table3dParams, TableDomain, TransferFunction};

/// The CPU build's split thresholds (`BEND_INDEPENDENT`, `BEND_DENSITY` in
/// tet_preint's table3d.rs): how far ln T may bend over one piece (its
/// `SPLIT_ERROR` rule is a constant in bake.wgsl).
const BEND_INDEPENDENT: f32 = 0.01;
const BEND_DENSITY: f32 = 1.0;

/// Precision of the bake's running sums (transmittance and colour).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum GpuAccumulation {
    #[default]
    F32,
    /// Rounded to f16 after every piece (emulated by bit arithmetic, ties to
    /// even, so it runs without the SHADER_F16 feature); the texture stays f32.
    F16,
}

impl GpuAccumulation {
    pub fn id(self) -> &'static str {
        match self {
            GpuAccumulation::F32 => "f32",
            GpuAccumulation::F16 => "f16",
        }
    }
}

/// Timings of one bake (wall clock, seconds).
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct GpuBakeStats {
    /// Shader compilation, pipeline and buffer creation.
    pub setup_seconds: f64,
    /// The compute dispatch, from submission until the device is idle.
    pub bake_seconds: f64,
    /// Entries computed (the band's (a, b) pairs × n_l).
    pub entries: u64,
}

/// A table3d baked on the GPU: an n_l × n_s × n_s Rgba32Float 3D texture
/// (texel (k, b, a) = T(s_a, s_b, l_k), zeros outside the band) laid out as
/// [`GpuShader::table3d`] uploads a CPU table, plus its grid.
pub struct GpuTable3d {
    texture: wgpu::Texture,
    domain: TableDomain,
    params: Table3dParams,
    knots: Vec<(f64, usize)>,
    grid: Vec<f64>,
    uniform: bool,
    stats: GpuBakeStats,
}

impl GpuTable3d {
    /// Bakes `tf` (x in data units) over `domain` at `params`' resolution
    /// and scalar axis. Only the slice-recurrence build at f32 storage is
    /// on the GPU (other builds and precisions are an input error).
    pub fn bake(
        ctx: &GpuContext,
        tf: &TransferFunction,
        domain: &TableDomain,
        params: &Table3dParams,
        accumulation: GpuAccumulation,
    ) -> Result<GpuTable3d, GpuError> {
        let t_setup = Instant::now();
        let Build3d::SliceRecurrence { oversampling } = params.build else {
            return Err(GpuError::Input(format!(
                "GPU bake: build {:?} is CPU-only (the GPU bakes the slice recurrence)",
                params.build
            )));
        };
        if !(0.01..=1024.0).contains(&oversampling) {
            return Err(GpuError::Input(format!("GPU bake: oversampling {oversampling} must be in [0.01, 1024]")));
        }
        if params.precision != Precision::F32 {
            return Err(GpuError::Input(format!(
                "GPU bake: storage precision {} is CPU-only (the texture is f32)",
                params.precision.id()
            )));
        }
        let (n_s, n_l) = (params.n_s, params.n_l);
        if n_l < 2 {
            return Err(GpuError::Input(format!("GPU bake: n_l {n_l} must be at least 2")));
        }
        check_table_dims(ctx, n_s, n_l)?;
        let knots = Table3d::axis_knots(tf, domain, params).map_err(|e| GpuError::Input(format!("GPU bake: {e}")))?;
        let uniform = knots.len() == 2;
        let grid = grid_of(domain, n_s, &knots);
        let rows = band_rows(domain, n_s, &knots, &grid, uniform);
        let row_width = rows.iter().map(|r| r[1] - r[0] + 1).max().unwrap_or(1);
        let entries = rows.iter().map(|r| (r[1] - r[0] + 1) as u64).sum::<u64>() * n_l as u64;

        let mut breaks: Vec<f32> =
            tf.color_nodes().iter().map(|c| c.x as f32).chain(tf.opacity_nodes().iter().map(|o| o.x as f32)).collect();
        breaks.sort_by(f32::total_cmp);
        breaks.dedup();
        let independent = tf.emission() == Emission::Independent;
        let bp = BakeParams {
            n_s: n_s as u32,
            n_l: n_l as u32,
            n_color: tf.color_nodes().len() as u32,
            n_opacity: tf.opacity_nodes().len() as u32,
            n_breaks: breaks.len() as u32,
            row_width,
            independent: independent as u32,
            f16: (accumulation == GpuAccumulation::F16) as u32,
            dl: (domain.len_max_world / (n_l - 1) as f64) as f32,
            len_max: domain.len_max_world as f32,
            oversampling,
            bend: if independent { BEND_INDEPENDENT } else { BEND_DENSITY },
        };
        let grid_f32: Vec<f32> = grid.iter().map(|&s| s as f32).collect();
        if breaks.is_empty() {
            breaks.push(0.0);
        }
        let dev = &ctx.device;
        let (texture, pipeline, group) = ctx.checked(|| {
            let texture = dev.create_texture(&wgpu::TextureDescriptor {
                label: Some("table3d (GPU bake)"),
                size: wgpu::Extent3d { width: n_l as u32, height: n_s as u32, depth_or_array_layers: n_s as u32 },
                mip_level_count: 1,
                sample_count: 1,
                dimension: wgpu::TextureDimension::D3,
                format: wgpu::TextureFormat::Rgba32Float,
                usage: wgpu::TextureUsages::TEXTURE_BINDING
                    | wgpu::TextureUsages::STORAGE_BINDING
                    | wgpu::TextureUsages::COPY_SRC,
                view_formats: &[],
            });
            let cs = wgpu::ShaderStages::COMPUTE;
            // Parameters, TF rows, grid, rows and breaks read; the table written.
            let mut entries = vec![crate::render::uniform_entry(0, cs)];
            entries.extend(storage_entries(1, cs, &[true; 4]));
            entries.push(storage_texture_entry(
                5,
                cs,
                wgpu::TextureFormat::Rgba32Float,
                wgpu::TextureViewDimension::D3,
            ));
            let source = shader_source_plain(BAKE_WGSL);
            let (layout, pipeline) = crate::render::compute_pipeline(dev, "bake", &entries, source, "bake");
            let buf = |label: &str, contents: &[u8], usage| buffer_init(dev, label, contents, usage);
            let storage = wgpu::BufferUsages::STORAGE;
            let params_buf = buf("bake params", bytemuck::bytes_of(&bp), wgpu::BufferUsages::UNIFORM);
            let tf_buf = buf("bake tf", bytemuck::cast_slice(&tf_node_rows(tf)), storage);
            let grid_buf = buf("bake grid", bytemuck::cast_slice(&grid_f32), storage);
            let rows_buf = buf("bake rows", bytemuck::cast_slice(&rows), storage);
            let breaks_buf = buf("bake breaks", bytemuck::cast_slice(&breaks), storage);
            let view = texture.create_view(&Default::default());
            let mut entries = bind_all(0, &[&params_buf, &tf_buf, &grid_buf, &rows_buf, &breaks_buf]);
            entries.push(bind_view(5, &view));
            let group = bind_group(dev, "bake", &layout, &entries);
            (texture, pipeline, group)
        })?;
        let (setup_seconds, bake_seconds) = time_setup_and_bake(ctx, t_setup, |enc| {
            let mut pass = enc.begin_compute_pass(&Default::default());
            pass.set_pipeline(&pipeline);
            pass.set_bind_group(0, &group, &[]);
            pass.dispatch_workgroups((n_l as u32).div_ceil(BAKE_WG), row_width, n_s as u32);
        })?;
        Ok(GpuTable3d {
            texture,
            domain: *domain,
            params: *params,
            knots,
            grid,
            uniform,
            stats: GpuBakeStats { setup_seconds, bake_seconds, entries },
        })
    }

    pub fn stats(&self) -> GpuBakeStats {
        self.stats
    }
    pub fn params(&self) -> &Table3dParams {
        &self.params
    }
    pub fn domain(&self) -> &TableDomain {
        &self.domain
    }
    /// The scalar axis as (scalar, grid index) knots, as `Table3d::s_knots`.
    pub fn s_knots(&self) -> &[(f64, usize)] {
        &self.knots
    }
    /// Grid value: scalar of index `a`.
    pub fn scalar_at(&self, a: usize) -> f64 {
        self.grid[a]
    }

    /// The whole cube read back: entry (a, b, k) at `(a·n_s + b)·n_l + k`
    /// (zeros outside the band). For tests and measurements; rendering
    /// samples the texture where it is.
    pub fn read_back(&self, ctx: &GpuContext) -> Result<Vec<[f32; 4]>, GpuError> {
        crate::render::read_rgba32f(ctx, &self.texture, "table3d read-back")
    }
}

/// Scalar of every grid index from the knots, as tet_preint's axis computes it.
fn grid_of(domain: &TableDomain, n_s: usize, knots: &[(f64, usize)]) -> Vec<f64> {
    let mut grid = Vec::with_capacity(n_s);
    for w in knots.windows(2) {
        let ((s0, i0), (s1, i1)) = (w[0], w[1]);
        let step = (s1 - s0) / (i1 - i0) as f64;
        grid.extend((0..i1 - i0).map(|k| s0 + k as f64 * step));
    }
    grid.push(domain.s_hi);
    grid
}

/// Per row a, the b range the bake computes: a superset (one index wider
/// each side) of the band tet_preint stores, so every corner a lookup can
/// touch is baked.
fn band_rows(domain: &TableDomain, n_s: usize, knots: &[(f64, usize)], grid: &[f64], uniform: bool) -> Vec<[u32; 2]> {
    let top = n_s - 1;
    if uniform {
        let step = domain.scalar_span() / top as f64;
        let reach = (domain.max_ds / step).min(top as f64);
        let w = ((reach - 1e-9).max(0.0).ceil() as usize + 2).min(top);
        return (0..n_s).map(|a| [a.saturating_sub(w) as u32, (a + w).min(top) as u32]).collect();
    }
    // Fractional index of a scalar: the knot interval's line.
    let x = |s: f64| -> f64 {
        let s = s.clamp(domain.s_lo, domain.s_hi);
        let j = knots[1..knots.len() - 1].partition_point(|k| k.0 < s);
        let ((s0, i0), (s1, i1)) = (knots[j], knots[j + 1]);
        i0 as f64 + (s - s0) * (i1 - i0) as f64 / (s1 - s0)
    };
    (0..n_s)
        .map(|a| {
            let below = grid[a.saturating_sub(1)] - domain.max_ds;
            let above = grid[(a + 1).min(top)] + domain.max_ds;
            let lo = ((x(below).floor() as usize).saturating_sub(2)).min(a);
            let hi = (x(above).floor() as usize + 3).min(top).max(a);
            [lo as u32, hi as u32]
        })
        .collect()
}

impl GpuShader {
    /// `table3d` from a table baked on the GPU: the baked texture is
    /// sampled where it is (no CPU round trip).
    pub fn table3d_baked(ctx: &GpuContext, table: &GpuTable3d) -> Result<GpuShader, GpuError> {
        let p = &table.params;
        // The baked entries stay on the GPU, so the CPU's choice of
        // reconstruction (from every entry) is not made: the optical depth,
        // never the less accurate of the two, is always taken.
        let grid = TableGrid {
            optical_depth: true,
            ..TableGrid::new(&table.domain, p.n_s, p.n_l, &table.knots, table.uniform)
        };
        GpuShader::with_table(ctx, METHOD_TABLE3D, None, table.texture.clone(), grid)
    }
}

/// Waits for the setup begun at `setup_start` to finish (pipelines compile
/// lazily on some drivers, so it is timed apart), then submits the passes
/// `record` encodes and waits for them: (setup seconds, bake seconds), as
/// [`GpuBakeStats`] reports them.
pub(crate) fn time_setup_and_bake(
    ctx: &GpuContext,
    setup_start: Instant,
    record: impl FnOnce(&mut wgpu::CommandEncoder),
) -> Result<(f64, f64), GpuError> {
    ctx.wait()?;
    let setup_seconds = setup_start.elapsed().as_secs_f64();
    let bake_start = Instant::now();
    ctx.checked(|| {
        let mut enc = ctx.device.create_command_encoder(&Default::default());
        record(&mut enc);
        ctx.queue.submit([enc.finish()]);
    })?;
    ctx.wait()?;
    Ok((setup_seconds, bake_start.elapsed().as_secs_f64()))
}
