//! Pipeline and bind-group-layout helpers every GPU pass uses.

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
    let layout = dev.create_bind_group_layout(&wgpu::BindGroupLayoutDescriptor { label: Some(label), entries });
    let module = dev.create_shader_module(wgpu::ShaderModuleDescriptor {
        label: Some(label),
        source: wgpu::ShaderSource::Wgsl(source.into()),
    });
    let pl = dev.create_pipeline_layout(&wgpu::PipelineLayoutDescriptor {
        label: Some(label),
        bind_group_layouts: &[Some(&layout)],
        immediate_size: 0,
    });
    let pipeline = dev.create_compute_pipeline(&wgpu::ComputePipelineDescriptor {
        label: Some(label),
        layout: Some(&pl),
        module: &module,
        entry_point: Some(entry),
        compilation_options: wgpu::PipelineCompilationOptions { constants, ..Default::default() },
        cache: None,
    });
    (layout, pipeline)
}

pub(crate) fn storage_entry(
    binding: u32,
    visibility: wgpu::ShaderStages,
    read_only: bool,
) -> wgpu::BindGroupLayoutEntry {
    wgpu::BindGroupLayoutEntry {
        binding,
        visibility,
        ty: wgpu::BindingType::Buffer {
            ty: wgpu::BufferBindingType::Storage { read_only },
            has_dynamic_offset: false,
            min_binding_size: None,
        },
        count: None,
    }
}

pub(crate) fn uniform_entry(binding: u32, visibility: wgpu::ShaderStages) -> wgpu::BindGroupLayoutEntry {
    wgpu::BindGroupLayoutEntry {
        binding,
        visibility,
        ty: wgpu::BindingType::Buffer {
            ty: wgpu::BufferBindingType::Uniform,
            has_dynamic_offset: false,
            min_binding_size: None,
        },
        count: None,
    }
}

/// A uniform bound at a dynamic offset into the parameter arena.
pub(crate) fn uniform_dyn_entry(binding: u32, visibility: wgpu::ShaderStages) -> wgpu::BindGroupLayoutEntry {
    wgpu::BindGroupLayoutEntry {
        binding,
        visibility,
        ty: wgpu::BindingType::Buffer {
            ty: wgpu::BufferBindingType::Uniform,
            has_dynamic_offset: true,
            min_binding_size: None,
        },
        count: None,
    }
}

/// An unsigned-integer texture (poly's 16-bit α table), read with textureLoad.
pub(crate) fn uint_texture_entry(
    binding: u32,
    visibility: wgpu::ShaderStages,
    dim: wgpu::TextureViewDimension,
) -> wgpu::BindGroupLayoutEntry {
    wgpu::BindGroupLayoutEntry {
        binding,
        visibility,
        ty: wgpu::BindingType::Texture {
            sample_type: wgpu::TextureSampleType::Uint,
            view_dimension: dim,
            multisampled: false,
        },
        count: None,
    }
}

pub(crate) fn texture_entry(
    binding: u32,
    visibility: wgpu::ShaderStages,
    dim: wgpu::TextureViewDimension,
) -> wgpu::BindGroupLayoutEntry {
    wgpu::BindGroupLayoutEntry {
        binding,
        visibility,
        ty: wgpu::BindingType::Texture {
            sample_type: wgpu::TextureSampleType::Float { filterable: false },
            view_dimension: dim,
            multisampled: false,
        },
        count: None,
    }
}
