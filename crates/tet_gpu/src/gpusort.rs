//! Prefix sums and the stable LSD radix sort of sort.wgsl: the GPU
//! centroid-depth order and the compute rasterizer's tile binning.

use crate::gpu_types::{SortParams, RADIX_BITS, RADIX_BLOCK, SCAN_BLOCK};
use crate::render::{storage_entry, uniform_dyn_entry};
use crate::workspace::{split_groups, Grow, Params};
use crate::{shader_source_plain, GpuContext, GpuError, SORT_WGSL};

pub(crate) struct SortPipelines {
    scan_layout: wgpu::BindGroupLayout,
    radix_layout: wgpu::BindGroupLayout,
    depth_layout: wgpu::BindGroupLayout,
    scan_blocks: wgpu::ComputePipeline,
    scan_sums: wgpu::ComputePipeline,
    scan_add: wgpu::ComputePipeline,
    rs_hist: wgpu::ComputePipeline,
    rs_scatter: wgpu::ComputePipeline,
    depth_keys: wgpu::ComputePipeline,
}

const SORT_PARAMS_SIZE: u64 = std::mem::size_of::<SortParams>() as u64;

fn params(n: u32, shift: u32, n_blocks: u32, groups_x: u32) -> SortParams {
    SortParams { eye_rel: [0.0; 4], forward: [0.0; 4], n, shift, n_blocks, groups_x }
}

impl SortPipelines {
    pub(crate) fn new(ctx: &GpuContext) -> SortPipelines {
        let dev = &ctx.device;
        let cs = wgpu::ShaderStages::COMPUTE;
        let layout = |label, entries: &[wgpu::BindGroupLayoutEntry]| {
            dev.create_bind_group_layout(&wgpu::BindGroupLayoutDescriptor { label: Some(label), entries })
        };
        let scan_layout =
            layout("scan", &[uniform_dyn_entry(0, cs), storage_entry(1, cs, false), storage_entry(2, cs, false)]);
        let radix_layout = layout(
            "radix",
            &[
                uniform_dyn_entry(0, cs),
                storage_entry(3, cs, true),
                storage_entry(4, cs, true),
                storage_entry(5, cs, false),
                storage_entry(6, cs, false),
                storage_entry(7, cs, false),
            ],
        );
        let depth_layout = layout(
            "depth keys",
            &[
                uniform_dyn_entry(0, cs),
                storage_entry(5, cs, false),
                storage_entry(6, cs, false),
                storage_entry(8, cs, true),
                storage_entry(9, cs, true),
            ],
        );
        let module = dev.create_shader_module(wgpu::ShaderModuleDescriptor {
            label: Some("sort.wgsl"),
            source: wgpu::ShaderSource::Wgsl(shader_source_plain(SORT_WGSL).into()),
        });
        let make = |layout: &wgpu::BindGroupLayout, entry: &str| {
            let pl = dev.create_pipeline_layout(&wgpu::PipelineLayoutDescriptor {
                label: Some(entry),
                bind_group_layouts: &[Some(layout)],
                immediate_size: 0,
            });
            dev.create_compute_pipeline(&wgpu::ComputePipelineDescriptor {
                label: Some(entry),
                layout: Some(&pl),
                module: &module,
                entry_point: Some(entry),
                compilation_options: Default::default(),
                cache: None,
            })
        };
        SortPipelines {
            scan_blocks: make(&scan_layout, "scan_blocks"),
            scan_sums: make(&scan_layout, "scan_sums"),
            scan_add: make(&scan_layout, "scan_add"),
            rs_hist: make(&radix_layout, "rs_hist"),
            rs_scatter: make(&radix_layout, "rs_scatter"),
            depth_keys: make(&depth_layout, "depth_keys"),
            scan_layout,
            radix_layout,
            depth_layout,
        }
    }

    /// Encodes an exclusive prefix sum of `data[0..n]` in place; the total
    /// lands in `sums[⌈n / 1024⌉]` (`sums` is grown to hold it).
    pub(crate) fn encode_scan(
        &self,
        ctx: &GpuContext,
        enc: &mut wgpu::CommandEncoder,
        prm: &mut Params,
        data: &wgpu::Buffer,
        n: u32,
        sums: &wgpu::Buffer,
    ) -> Result<(), GpuError> {
        let blocks = n.div_ceil(SCAN_BLOCK).max(1);
        let (gx, gy) = split_groups(blocks);
        let o = prm.push(&params(n, 0, blocks, gx))?;
        let bg = ctx.device.create_bind_group(&wgpu::BindGroupDescriptor {
            label: Some("scan"),
            layout: &self.scan_layout,
            entries: &[
                wgpu::BindGroupEntry { binding: 0, resource: prm.binding(SORT_PARAMS_SIZE) },
                wgpu::BindGroupEntry { binding: 1, resource: data.as_entire_binding() },
                wgpu::BindGroupEntry { binding: 2, resource: sums.as_entire_binding() },
            ],
        });
        let mut pass =
            enc.begin_compute_pass(&wgpu::ComputePassDescriptor { label: Some("scan"), timestamp_writes: None });
        pass.set_bind_group(0, &bg, &[o]);
        pass.set_pipeline(&self.scan_blocks);
        pass.dispatch_workgroups(gx, gy, 1);
        pass.set_pipeline(&self.scan_sums);
        pass.dispatch_workgroups(1, 1, 1);
        pass.set_pipeline(&self.scan_add);
        pass.dispatch_workgroups(gx, gy, 1);
        Ok(())
    }

    /// Bytes the scan's `sums` needs for `n` elements.
    pub(crate) fn sums_bytes(n: u32) -> u64 {
        (n.div_ceil(SCAN_BLOCK).max(1) as u64 + 1) * 4
    }

    /// Encodes a stable sort of `keys[0][0..n]` / `vals[0][0..n]` on their
    /// low `bits` bits; returns which of the two pairs of buffers holds the
    /// result. `hist` and `sums` must hold [`SortPipelines::hist_bytes`] and
    /// the scan's sums for `16 · ⌈n / 256⌉` elements.
    #[allow(clippy::too_many_arguments)]
    pub(crate) fn encode_radix(
        &self,
        ctx: &GpuContext,
        enc: &mut wgpu::CommandEncoder,
        prm: &mut Params,
        keys: [&wgpu::Buffer; 2],
        vals: [&wgpu::Buffer; 2],
        n: u32,
        bits: u32,
        hist: &wgpu::Buffer,
        sums: &wgpu::Buffer,
    ) -> Result<usize, GpuError> {
        let blocks = n.div_ceil(RADIX_BLOCK).max(1);
        let (gx, gy) = split_groups(blocks);
        let passes = bits.div_ceil(RADIX_BITS);
        let mut src = 0usize;
        for p in 0..passes {
            let o = prm.push(&params(n, p * RADIX_BITS, blocks, gx))?;
            let dst = 1 - src;
            let bg = ctx.device.create_bind_group(&wgpu::BindGroupDescriptor {
                label: Some("radix"),
                layout: &self.radix_layout,
                entries: &[
                    wgpu::BindGroupEntry { binding: 0, resource: prm.binding(SORT_PARAMS_SIZE) },
                    wgpu::BindGroupEntry { binding: 3, resource: keys[src].as_entire_binding() },
                    wgpu::BindGroupEntry { binding: 4, resource: vals[src].as_entire_binding() },
                    wgpu::BindGroupEntry { binding: 5, resource: keys[dst].as_entire_binding() },
                    wgpu::BindGroupEntry { binding: 6, resource: vals[dst].as_entire_binding() },
                    wgpu::BindGroupEntry { binding: 7, resource: hist.as_entire_binding() },
                ],
            });
            {
                let mut pass = enc.begin_compute_pass(&wgpu::ComputePassDescriptor {
                    label: Some("rs_hist"),
                    timestamp_writes: None,
                });
                pass.set_bind_group(0, &bg, &[o]);
                pass.set_pipeline(&self.rs_hist);
                pass.dispatch_workgroups(gx, gy, 1);
            }
            self.encode_scan(ctx, enc, prm, hist, 16 * blocks, sums)?;
            let mut pass = enc
                .begin_compute_pass(&wgpu::ComputePassDescriptor { label: Some("rs_scatter"), timestamp_writes: None });
            pass.set_bind_group(0, &bg, &[o]);
            pass.set_pipeline(&self.rs_scatter);
            pass.dispatch_workgroups(gx, gy, 1);
            src = dst;
        }
        Ok(src)
    }

    pub(crate) fn hist_bytes(n: u32) -> u64 {
        16 * n.div_ceil(RADIX_BLOCK).max(1) as u64 * 4
    }

    /// Encodes the centroid-depth keys of every tet into `keys`/`vals`.
    #[allow(clippy::too_many_arguments)]
    pub(crate) fn encode_depth_keys(
        &self,
        ctx: &GpuContext,
        enc: &mut wgpu::CommandEncoder,
        prm: &mut Params,
        eye_rel: [f32; 4],
        forward: [f32; 4],
        n: u32,
        positions: &wgpu::Buffer,
        tets: &wgpu::Buffer,
        keys: &wgpu::Buffer,
        vals: &wgpu::Buffer,
    ) -> Result<(), GpuError> {
        let (gx, gy) = split_groups(n.div_ceil(RADIX_BLOCK));
        let mut p = params(n, 0, 0, gx);
        p.eye_rel = eye_rel;
        p.forward = forward;
        let o = prm.push(&p)?;
        let bg = ctx.device.create_bind_group(&wgpu::BindGroupDescriptor {
            label: Some("depth keys"),
            layout: &self.depth_layout,
            entries: &[
                wgpu::BindGroupEntry { binding: 0, resource: prm.binding(SORT_PARAMS_SIZE) },
                wgpu::BindGroupEntry { binding: 5, resource: keys.as_entire_binding() },
                wgpu::BindGroupEntry { binding: 6, resource: vals.as_entire_binding() },
                wgpu::BindGroupEntry { binding: 8, resource: positions.as_entire_binding() },
                wgpu::BindGroupEntry { binding: 9, resource: tets.as_entire_binding() },
            ],
        });
        let mut pass =
            enc.begin_compute_pass(&wgpu::ComputePassDescriptor { label: Some("depth_keys"), timestamp_writes: None });
        pass.set_bind_group(0, &bg, &[o]);
        pass.set_pipeline(&self.depth_keys);
        pass.dispatch_workgroups(gx, gy, 1);
        Ok(())
    }
}

/// Keeps the borrow checker out of the way when a sort needs two pairs of
/// grown buffers: ensures all four hold `bytes`.
pub(crate) fn ensure_pairs(
    ctx: &GpuContext,
    keys: &mut [Grow; 2],
    vals: &mut [Grow; 2],
    bytes: u64,
    limit: u64,
) -> Result<usize, GpuError> {
    let mut grown = 0;
    for g in keys.iter_mut().chain(vals.iter_mut()) {
        grown += g.ensure(ctx, bytes, limit)? as usize;
    }
    Ok(grown)
}
