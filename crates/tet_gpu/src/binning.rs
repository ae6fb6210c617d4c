//! The compute rasterizer's pipelines (bin.wgsl): binning a chunk's slots
//! into tiles and compositing each tile in a workgroup.

use crate::gpu_types::BinParams;
use crate::render::{storage_entry, texture_entry, uint_texture_entry, uniform_dyn_entry, uniform_entry, HDR_FORMAT};
use crate::{shader_source_fragment, GpuContext, BIN_WGSL};

pub(crate) struct BinPipelines {
    pub(crate) layout: wgpu::BindGroupLayout,
    pub(crate) count: wgpu::ComputePipeline,
    pub(crate) fill: wgpu::ComputePipeline,
    pub(crate) ranges: wgpu::ComputePipeline,
    module: wgpu::ShaderModule,
    pl: wgpu::PipelineLayout,
}

pub(crate) const BIN_PARAMS_SIZE: u64 = std::mem::size_of::<BinParams>() as u64;

impl BinPipelines {
    pub(crate) fn new(ctx: &GpuContext) -> BinPipelines {
        let dev = &ctx.device;
        let cs = wgpu::ShaderStages::COMPUTE;
        let layout = dev.create_bind_group_layout(&wgpu::BindGroupLayoutDescriptor {
            label: Some("bin"),
            entries: &[
                uniform_dyn_entry(0, cs),
                uniform_dyn_entry(1, cs),
                storage_entry(2, cs, true),
                storage_entry(3, cs, false),
                storage_entry(4, cs, false),
                storage_entry(5, cs, false),
                storage_entry(6, cs, true),
                storage_entry(7, cs, true),
                texture_entry(8, cs, wgpu::TextureViewDimension::D3),
                storage_entry(9, cs, false),
                storage_entry(10, cs, false),
                wgpu::BindGroupLayoutEntry {
                    binding: 11,
                    visibility: cs,
                    ty: wgpu::BindingType::StorageTexture {
                        access: wgpu::StorageTextureAccess::WriteOnly,
                        format: HDR_FORMAT,
                        view_dimension: wgpu::TextureViewDimension::D2,
                    },
                    count: None,
                },
                texture_entry(14, cs, wgpu::TextureViewDimension::D2Array),
                uint_texture_entry(15, cs, wgpu::TextureViewDimension::D1),
                uniform_entry(16, cs),
                storage_entry(18, cs, true),
            ],
        });
        let module = dev.create_shader_module(wgpu::ShaderModuleDescriptor {
            label: Some("bin.wgsl"),
            source: wgpu::ShaderSource::Wgsl(shader_source_fragment(BIN_WGSL).into()),
        });
        let pl = dev.create_pipeline_layout(&wgpu::PipelineLayoutDescriptor {
            label: Some("bin"),
            bind_group_layouts: &[Some(&layout)],
            immediate_size: 0,
        });
        let make = |entry: &str| {
            dev.create_compute_pipeline(&wgpu::ComputePipelineDescriptor {
                label: Some(entry),
                layout: Some(&pl),
                module: &module,
                entry_point: Some(entry),
                compilation_options: Default::default(),
                cache: None,
            })
        };
        BinPipelines {
            count: make("bin_count"),
            fill: make("bin_fill"),
            ranges: make("tile_ranges"),
            layout,
            module,
            pl,
        }
    }

    /// The composite pass specialised by `options` (the method's `SHADE_METHOD`).
    pub(crate) fn composite_for(
        &self,
        ctx: &GpuContext,
        options: &wgpu::PipelineCompilationOptions<'_>,
    ) -> wgpu::ComputePipeline {
        ctx.device.create_compute_pipeline(&wgpu::ComputePipelineDescriptor {
            label: Some("composite"),
            layout: Some(&self.pl),
            module: &self.module,
            entry_point: Some("composite"),
            compilation_options: options.clone(),
            cache: None,
        })
    }
}
