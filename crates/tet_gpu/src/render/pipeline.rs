//! Pipeline, bind-group, dispatch, buffer and texture helpers every GPU
//! pass uses.

use super::check_size;
use crate::{map_read, GpuContext, GpuError};
use wgpu::util::DeviceExt;

/// A WGSL module from `source` (already assembled by a `shader_source_*`
/// function).
pub(crate) fn shader_module(dev: &wgpu::Device, label: &str, source: String) -> wgpu::ShaderModule {
    dev.create_shader_module(wgpu::ShaderModuleDescriptor {
        label: Some(label),
        source: wgpu::ShaderSource::Wgsl(source.into()),
    })
}

/// A shader module with the one bind group layout (group 0) its entry
/// points use, and the pipeline layout over that group alone.
pub(crate) struct BoundModule {
    pub(crate) layout: wgpu::BindGroupLayout,
    pub(crate) pipeline_layout: wgpu::PipelineLayout,
    pub(crate) module: wgpu::ShaderModule,
}

impl BoundModule {
    /// Group 0's layout from `entries`, over `module`.
    pub(crate) fn new(
        dev: &wgpu::Device,
        label: &str,
        entries: &[wgpu::BindGroupLayoutEntry],
        module: wgpu::ShaderModule,
    ) -> BoundModule {
        let layout = dev.create_bind_group_layout(&wgpu::BindGroupLayoutDescriptor { label: Some(label), entries });
        let pipeline_layout = dev.create_pipeline_layout(&wgpu::PipelineLayoutDescriptor {
            label: Some(label),
            bind_group_layouts: &[Some(&layout)],
            immediate_size: 0,
        });
        BoundModule { layout, pipeline_layout, module }
    }

    /// The compute pipeline of entry point `entry`, with values for the
    /// module's overridable constants.
    pub(crate) fn compute(&self, dev: &wgpu::Device, entry: &str, constants: &[(&str, f64)]) -> wgpu::ComputePipeline {
        dev.create_compute_pipeline(&wgpu::ComputePipelineDescriptor {
            label: Some(entry),
            layout: Some(&self.pipeline_layout),
            module: &self.module,
            entry_point: Some(entry),
            compilation_options: wgpu::PipelineCompilationOptions { constants, ..Default::default() },
            cache: None,
        })
    }
}

/// A compute pipeline over one bind group: the group's layout from
/// `entries`, the module from `source` (already assembled by a
/// `shader_source_*` function), and entry point `entry`.
pub(crate) fn compute_pipeline(
    dev: &wgpu::Device,
    label: &str,
    entries: &[wgpu::BindGroupLayoutEntry],
    source: String,
    entry: &str,
) -> (wgpu::BindGroupLayout, wgpu::ComputePipeline) {
    compute_pipeline_with(dev, label, entries, source, entry, &[])
}

/// [`compute_pipeline`] with values for the module's overridable constants.
pub(crate) fn compute_pipeline_with(
    dev: &wgpu::Device,
    label: &str,
    entries: &[wgpu::BindGroupLayoutEntry],
    source: String,
    entry: &str,
    constants: &[(&str, f64)],
) -> (wgpu::BindGroupLayout, wgpu::ComputePipeline) {
    let bound = BoundModule::new(dev, label, entries, shader_module(dev, label, source));
    let pipeline = bound.compute(dev, entry, constants);
    (bound.layout, pipeline)
}

/// A bind group of `layout` from `entries` (see [`bind`], [`bind_view`]).
pub(crate) fn bind_group(
    dev: &wgpu::Device,
    label: &str,
    layout: &wgpu::BindGroupLayout,
    entries: &[wgpu::BindGroupEntry<'_>],
) -> wgpu::BindGroup {
    dev.create_bind_group(&wgpu::BindGroupDescriptor { label: Some(label), layout, entries })
}

/// Buffer `buf`, whole, at `binding`.
pub(crate) fn bind(binding: u32, buf: &wgpu::Buffer) -> wgpu::BindGroupEntry<'_> {
    wgpu::BindGroupEntry { binding, resource: buf.as_entire_binding() }
}

/// Buffers `bufs`, whole, at bindings `first`, `first + 1`, ….
pub(crate) fn bind_all<'a>(first: u32, bufs: &[&'a wgpu::Buffer]) -> Vec<wgpu::BindGroupEntry<'a>> {
    (first..).zip(bufs).map(|(binding, buf)| bind(binding, buf)).collect()
}

/// Texture view `view` at `binding`.
pub(crate) fn bind_view(binding: u32, view: &wgpu::TextureView) -> wgpu::BindGroupEntry<'_> {
    wgpu::BindGroupEntry { binding, resource: wgpu::BindingResource::TextureView(view) }
}

/// Encodes one compute pass: `pipeline` with bind group 0 `group` at
/// dynamic `offsets`, over `groups` (x, y) workgroups.
pub(crate) fn dispatch(
    enc: &mut wgpu::CommandEncoder,
    label: &str,
    pipeline: &wgpu::ComputePipeline,
    group: &wgpu::BindGroup,
    offsets: &[u32],
    groups: (u32, u32),
) {
    let mut pass = enc.begin_compute_pass(&wgpu::ComputePassDescriptor { label: Some(label), timestamp_writes: None });
    pass.set_pipeline(pipeline);
    pass.set_bind_group(0, group, offsets);
    pass.dispatch_workgroups(groups.0, groups.1, 1);
}

/// A buffer holding `contents`.
pub(crate) fn buffer_init(dev: &wgpu::Device, label: &str, contents: &[u8], usage: wgpu::BufferUsages) -> wgpu::Buffer {
    dev.create_buffer_init(&wgpu::util::BufferInitDescriptor { label: Some(label), contents, usage })
}

/// An unmapped buffer of `size` bytes.
pub(crate) fn buffer(dev: &wgpu::Device, label: &str, size: u64, usage: wgpu::BufferUsages) -> wgpu::Buffer {
    dev.create_buffer(&wgpu::BufferDescriptor { label: Some(label), size, usage, mapped_at_creation: false })
}

/// Usage of a buffer the CPU reads back ([`map_read`]).
pub(crate) const READ_BACK: wgpu::BufferUsages = wgpu::BufferUsages::COPY_DST.union(wgpu::BufferUsages::MAP_READ);

/// A texture of `size` (width, height, depth or layers) holding `texels`
/// (rows of `size[0]` texels of `format`, row-major, layer by layer),
/// for sampling.
pub(crate) fn upload_texture(
    ctx: &GpuContext,
    label: &str,
    dimension: wgpu::TextureDimension,
    format: wgpu::TextureFormat,
    size: [u32; 3],
    texels: &[u8],
) -> Result<wgpu::Texture, GpuError> {
    let texel_bytes = format.block_copy_size(None).expect("an uncompressed colour format");
    ctx.checked(|| {
        let extent = wgpu::Extent3d { width: size[0], height: size[1], depth_or_array_layers: size[2] };
        let tex = ctx.device.create_texture(&wgpu::TextureDescriptor {
            label: Some(label),
            size: extent,
            mip_level_count: 1,
            sample_count: 1,
            dimension,
            format,
            usage: wgpu::TextureUsages::TEXTURE_BINDING | wgpu::TextureUsages::COPY_DST,
            view_formats: &[],
        });
        ctx.queue.write_texture(
            tex.as_image_copy(),
            texels,
            wgpu::TexelCopyBufferLayout {
                offset: 0,
                bytes_per_row: Some(size[0] * texel_bytes),
                rows_per_image: Some(size[1]),
            },
            extent,
        );
        tex
    })
}

/// The texels of an Rgba32Float texture (2D or 3D, whole), read back row
/// by row, layer by layer; `label` names the read-back buffer in errors.
pub(crate) fn read_rgba32f(
    ctx: &GpuContext,
    tex: &wgpu::Texture,
    label: &'static str,
) -> Result<Vec<[f32; 4]>, GpuError> {
    let extent = tex.size();
    let (w, rows) = (extent.width, extent.height as u64 * extent.depth_or_array_layers as u64);
    let row = w as u64 * 16;
    let align = wgpu::COPY_BYTES_PER_ROW_ALIGNMENT as u64;
    let padded = row.div_ceil(align) * align;
    check_size(label, padded * rows, ctx.device.limits().max_buffer_size)?;
    let buf = ctx.checked(|| {
        let buf = buffer(&ctx.device, label, padded * rows, READ_BACK);
        let mut enc = ctx.device.create_command_encoder(&Default::default());
        enc.copy_texture_to_buffer(
            tex.as_image_copy(),
            wgpu::TexelCopyBufferInfo {
                buffer: &buf,
                layout: wgpu::TexelCopyBufferLayout {
                    offset: 0,
                    bytes_per_row: Some(padded as u32),
                    rows_per_image: Some(extent.height),
                },
            },
            extent,
        );
        ctx.queue.submit([enc.finish()]);
        buf
    })?;
    let bytes = map_read(ctx, &buf)?;
    let mut out = Vec::with_capacity(w as usize * rows as usize);
    for line in bytes.chunks_exact(padded as usize) {
        out.extend(line[..row as usize].chunks_exact(16).map(|px| {
            let f = |i: usize| f32::from_le_bytes([px[4 * i], px[4 * i + 1], px[4 * i + 2], px[4 * i + 3]]);
            [f(0), f(1), f(2), f(3)]
        }));
    }
    Ok(out)
}

/// A layout entry of `ty` at `binding`, seen by the `visibility` stages.
fn layout_entry(binding: u32, visibility: wgpu::ShaderStages, ty: wgpu::BindingType) -> wgpu::BindGroupLayoutEntry {
    wgpu::BindGroupLayoutEntry { binding, visibility, ty, count: None }
}

/// A buffer of `ty`, at a dynamic offset where `dynamic`.
fn buffer_entry(
    binding: u32,
    visibility: wgpu::ShaderStages,
    ty: wgpu::BufferBindingType,
    dynamic: bool,
) -> wgpu::BindGroupLayoutEntry {
    let ty = wgpu::BindingType::Buffer { ty, has_dynamic_offset: dynamic, min_binding_size: None };
    layout_entry(binding, visibility, ty)
}

pub(crate) fn storage_entry(
    binding: u32,
    visibility: wgpu::ShaderStages,
    read_only: bool,
) -> wgpu::BindGroupLayoutEntry {
    buffer_entry(binding, visibility, wgpu::BufferBindingType::Storage { read_only }, false)
}

/// Storage buffers at bindings `first`, `first + 1`, …, read-only where
/// `read_only` says.
pub(crate) fn storage_entries(
    first: u32,
    visibility: wgpu::ShaderStages,
    read_only: &[bool],
) -> Vec<wgpu::BindGroupLayoutEntry> {
    (first..).zip(read_only).map(|(binding, &ro)| storage_entry(binding, visibility, ro)).collect()
}

pub(crate) fn uniform_entry(binding: u32, visibility: wgpu::ShaderStages) -> wgpu::BindGroupLayoutEntry {
    buffer_entry(binding, visibility, wgpu::BufferBindingType::Uniform, false)
}

/// A uniform bound at a dynamic offset into the parameter arena.
pub(crate) fn uniform_dyn_entry(binding: u32, visibility: wgpu::ShaderStages) -> wgpu::BindGroupLayoutEntry {
    buffer_entry(binding, visibility, wgpu::BufferBindingType::Uniform, true)
}

/// A sampled (textureLoad) texture of `sample_type`.
fn sampled_entry(
    binding: u32,
    visibility: wgpu::ShaderStages,
    sample_type: wgpu::TextureSampleType,
    dim: wgpu::TextureViewDimension,
) -> wgpu::BindGroupLayoutEntry {
    let ty = wgpu::BindingType::Texture { sample_type, view_dimension: dim, multisampled: false };
    layout_entry(binding, visibility, ty)
}

/// An unsigned-integer texture (poly's 16-bit α table), read with textureLoad.
pub(crate) fn uint_texture_entry(
    binding: u32,
    visibility: wgpu::ShaderStages,
    dim: wgpu::TextureViewDimension,
) -> wgpu::BindGroupLayoutEntry {
    sampled_entry(binding, visibility, wgpu::TextureSampleType::Uint, dim)
}

pub(crate) fn texture_entry(
    binding: u32,
    visibility: wgpu::ShaderStages,
    dim: wgpu::TextureViewDimension,
) -> wgpu::BindGroupLayoutEntry {
    sampled_entry(binding, visibility, wgpu::TextureSampleType::Float { filterable: false }, dim)
}

/// A write-only storage texture of `format`.
pub(crate) fn storage_texture_entry(
    binding: u32,
    visibility: wgpu::ShaderStages,
    format: wgpu::TextureFormat,
    dim: wgpu::TextureViewDimension,
) -> wgpu::BindGroupLayoutEntry {
    let ty = wgpu::BindingType::StorageTexture {
        access: wgpu::StorageTextureAccess::WriteOnly,
        format,
        view_dimension: dim,
    };
    layout_entry(binding, visibility, ty)
}
