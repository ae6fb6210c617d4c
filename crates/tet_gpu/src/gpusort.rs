//! Prefix sums and the stable LSD radix sort of sort.wgsl: the GPU
//! centroid-depth order and the compute rasterizer's tile binning.

use crate::gpu_types::{SortParams, RADIX_BITS, RADIX_BLOCK, SCAN_BLOCK};
use crate::render::{
    bind, bind_all, bind_group, dispatch, shader_module, storage_entry, uniform_dyn_entry, BoundModule,
};
use crate::workspace::{split_groups, Grow, Params};
use crate::{shader_source_plain, GpuContext, GpuError, SORT_WGSL};

pub(crate) struct SortPipelines {
    scan: BoundModule,
    radix: BoundModule,
    depth: BoundModule,
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
        let module = shader_module(dev, "sort.wgsl", shader_source_plain(SORT_WGSL));
        // Each layout: the parameters at 0, then storage buffers (binding, read-only).
        let bound = |label, storage: &[(u32, bool)]| {
            let mut entries = vec![uniform_dyn_entry(0, cs)];
            entries.extend(storage.iter().map(|&(b, ro)| storage_entry(b, cs, ro)));
            BoundModule::new(dev, label, &entries, module.clone())
        };
        let scan = bound("scan", &[(1, false), (2, false)]);
        let radix = bound("radix", &[(3, true), (4, true), (5, false), (6, false), (7, false)]);
        let depth = bound("depth keys", &[(5, false), (6, false), (8, true), (9, true)]);
        SortPipelines {
            scan_blocks: scan.compute(dev, "scan_blocks", &[]),
            scan_sums: scan.compute(dev, "scan_sums", &[]),
            scan_add: scan.compute(dev, "scan_add", &[]),
            rs_hist: radix.compute(dev, "rs_hist", &[]),
            rs_scatter: radix.compute(dev, "rs_scatter", &[]),
            depth_keys: depth.compute(dev, "depth_keys", &[]),
            scan,
            radix,
            depth,
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
        let entries = [
            wgpu::BindGroupEntry { binding: 0, resource: prm.binding(SORT_PARAMS_SIZE) },
            bind(1, data),
            bind(2, sums),
        ];
        let bg = bind_group(&ctx.device, "scan", &self.scan.layout, &entries);
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
            let mut entries = vec![wgpu::BindGroupEntry { binding: 0, resource: prm.binding(SORT_PARAMS_SIZE) }];
            entries.extend(bind_all(3, &[keys[src], vals[src], keys[dst], vals[dst], hist]));
            let bg = bind_group(&ctx.device, "radix", &self.radix.layout, &entries);
            dispatch(enc, "rs_hist", &self.rs_hist, &bg, &[o], (gx, gy));
            self.encode_scan(ctx, enc, prm, hist, 16 * blocks, sums)?;
            dispatch(enc, "rs_scatter", &self.rs_scatter, &bg, &[o], (gx, gy));
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
        let mut entries = vec![wgpu::BindGroupEntry { binding: 0, resource: prm.binding(SORT_PARAMS_SIZE) }];
        entries.extend(bind_all(5, &[keys, vals]));
        entries.extend(bind_all(8, &[positions, tets]));
        let bg = bind_group(&ctx.device, "depth keys", &self.depth.layout, &entries);
        dispatch(enc, "depth_keys", &self.depth_keys, &bg, &[o], (gx, gy));
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
