//! The compute rasterizer's pipelines (bin.wgsl): binning a chunk's slots
//! into tiles and compositing each tile in a workgroup.

use crate::gpu_types::BinParams;
use crate::render::{
    shader_module, storage_entries, storage_entry, storage_texture_entry, texture_entry, uint_texture_entry,
    uniform_dyn_entry, uniform_entry, BoundModule, HDR_FORMAT,
};
use crate::{shader_source_fragment, GpuContext, BIN_WGSL};

pub(crate) struct BinPipelines {
    pub(crate) bound: BoundModule,
    pub(crate) count: wgpu::ComputePipeline,
    pub(crate) fill: wgpu::ComputePipeline,
    pub(crate) ranges: wgpu::ComputePipeline,
}

pub(crate) const BIN_PARAMS_SIZE: u64 = std::mem::size_of::<BinParams>() as u64;

impl BinPipelines {
    pub(crate) fn new(ctx: &GpuContext) -> BinPipelines {
        let dev = &ctx.device;
        let cs = wgpu::ShaderStages::COMPUTE;
        let mut entries = vec![uniform_dyn_entry(0, cs), uniform_dyn_entry(1, cs)];
        // Geometries read; counts, pair keys and values written; shades, TF rows read.
        entries.extend(storage_entries(2, cs, &[true, false, false, false, true, true]));
        entries.extend([
            texture_entry(8, cs, wgpu::TextureViewDimension::D3),
            storage_entry(9, cs, false),
            storage_entry(10, cs, false),
            storage_texture_entry(11, cs, HDR_FORMAT, wgpu::TextureViewDimension::D2),
            texture_entry(14, cs, wgpu::TextureViewDimension::D2Array),
            uint_texture_entry(15, cs, wgpu::TextureViewDimension::D1),
            uniform_entry(16, cs),
            storage_entry(18, cs, true),
            uniform_entry(19, cs),
            storage_entry(21, cs, true),
        ]);
        entries.extend(crate::render::shadow_entries(cs));
        let bound =
            BoundModule::new(dev, "bin", &entries, shader_module(dev, "bin.wgsl", shader_source_fragment(BIN_WGSL)));
        BinPipelines {
            count: bound.compute(dev, "bin_count", &[]),
            fill: bound.compute(dev, "bin_fill", &[]),
            ranges: bound.compute(dev, "tile_ranges", &[]),
            bound,
        }
    }

    /// The composite pass specialised by `constants` (the method's `SHADE_METHOD`).
    pub(crate) fn composite_for(&self, ctx: &GpuContext, constants: &[(&str, f64)]) -> wgpu::ComputePipeline {
        self.bound.compute(&ctx.device, "composite", constants)
    }
}
