//! Scene upload, shaders (pt-linear, table3d), the classify and raster
//! passes, and the centroid visibility order.

use crate::gpu_types::{
    FrameUniforms, TetGeom, TetShade, CLASSIFY_WG, METHOD_PT_LINEAR, METHOD_TABLE3D, VERTS_PER_SLOT,
};
use crate::{read_texture, shader_source, GpuContext, GpuError, CLASSIFY_WGSL, RASTER_WGSL};
use glam::DVec3;
use rayon::prelude::*;
use std::time::Instant;
use tet_preint::{Table3d, TransferFunction};
use tet_render::{Camera, Image};
use wgpu::util::DeviceExt;

/// The HDR target format (needs FLOAT32_BLENDABLE).
pub(crate) const HDR_FORMAT: wgpu::TextureFormat = wgpu::TextureFormat::Rgba32Float;

/// A mesh on the GPU. Positions are stored relative to the bounding-box
/// centre (as tet_render's `Scene`), in f32, so far-from-origin meshes keep
/// their sub-cell precision.
pub struct GpuScene {
    centre_in_world: DVec3,
    n_points: usize,
    /// Kept for the CPU centroid sort.
    pos_rel: Vec<[f32; 3]>,
    tets: Vec<[u32; 4]>,
    positions: wgpu::Buffer,
    tet_buf: wgpu::Buffer,
    scalars: wgpu::Buffer,
}

impl GpuScene {
    /// Uploads a mesh: `tets` positively oriented (as every bundle's are),
    /// one scalar per point. Indices out of range, non-finite values and
    /// sizes beyond the device's storage-binding limit are errors.
    pub fn new(ctx: &GpuContext, points: &[[f64; 3]], tets: &[[u32; 4]], scalar: &[f64]) -> Result<GpuScene, GpuError> {
        if scalar.len() != points.len() {
            return Err(GpuError::Input(format!("{} scalars for {} points", scalar.len(), points.len())));
        }
        if points.is_empty() || tets.is_empty() {
            return Err(GpuError::Input(format!("{} points and {} tets: nothing to draw", points.len(), tets.len())));
        }
        if let Some(i) = points.iter().position(|p| !p.iter().all(|v| v.is_finite())) {
            return Err(GpuError::Input(format!("point {i} has a non-finite coordinate")));
        }
        if let Some(i) = scalar.iter().position(|s| !s.is_finite()) {
            return Err(GpuError::Input(format!("scalar of point {i} is not finite")));
        }
        if let Some((t, v)) = tets
            .iter()
            .enumerate()
            .find_map(|(t, tet)| tet.iter().find(|&&v| v as usize >= points.len()).map(|&v| (t, v)))
        {
            return Err(GpuError::Input(format!("tet {t} refers to point {v}; the mesh has {}", points.len())));
        }
        // Per-slot buffers are the largest bindings: check them now.
        let limit = ctx.device.limits().max_storage_buffer_binding_size;
        check_size("per-tet shading data (112 bytes a tet)", tets.len() as u64 * 112, limit)?;
        check_size("point positions (16 bytes a point)", points.len() as u64 * 16, limit)?;
        if tets.len() as u64 * VERTS_PER_SLOT as u64 > u32::MAX as u64 {
            return Err(GpuError::Input(format!("{} tets: too many vertices for one draw", tets.len())));
        }
        let (mut lo, mut hi) = ([f64::INFINITY; 3], [f64::NEG_INFINITY; 3]);
        for p in points {
            for k in 0..3 {
                lo[k] = lo[k].min(p[k]);
                hi[k] = hi[k].max(p[k]);
            }
        }
        let centre = (DVec3::from(lo) + DVec3::from(hi)) * 0.5;
        let pos_rel: Vec<[f32; 3]> = points.iter().map(|p| (DVec3::from(*p) - centre).as_vec3().to_array()).collect();
        let pos4: Vec<[f32; 4]> = pos_rel.iter().map(|p| [p[0], p[1], p[2], 0.0]).collect();
        let s32: Vec<f32> = scalar.iter().map(|&s| s as f32).collect();
        let storage = wgpu::BufferUsages::STORAGE | wgpu::BufferUsages::COPY_DST;
        let init = |label: &str, contents: &[u8]| {
            ctx.device.create_buffer_init(&wgpu::util::BufferInitDescriptor {
                label: Some(label),
                contents,
                usage: storage,
            })
        };
        let (positions, tet_buf, scalars) = ctx.checked(|| {
            (
                init("positions", bytemuck::cast_slice(&pos4)),
                init("tets", bytemuck::cast_slice(tets)),
                init("scalars", bytemuck::cast_slice(&s32)),
            )
        })?;
        Ok(GpuScene {
            centre_in_world: centre,
            n_points: points.len(),
            pos_rel,
            tets: tets.to_vec(),
            positions,
            tet_buf,
            scalars,
        })
    }

    pub fn centre_in_world(&self) -> DVec3 {
        self.centre_in_world
    }
    pub fn num_tets(&self) -> usize {
        self.tets.len()
    }
    pub fn num_points(&self) -> usize {
        self.n_points
    }
}

fn check_size(what: &'static str, bytes: u64, limit: u64) -> Result<(), GpuError> {
    if bytes > limit {
        return Err(GpuError::TooLarge { what, bytes, limit });
    }
    Ok(())
}

/// Tets sorted front to back by the depth of their centroids (the fast
/// approximate order; exact for none but simple meshes, as tet_render's
/// radix sort). Computed on the CPU with rayon in this increment.
pub fn centroid_order(scene: &GpuScene, camera: &Camera) -> Vec<u32> {
    let eye = (camera.eye_in_world() - scene.centre_in_world).as_vec3();
    let fwd = camera.forward().as_vec3();
    let mut keyed: Vec<(f32, u32)> = scene
        .tets
        .par_iter()
        .enumerate()
        .map(|(i, t)| {
            let mut c = glam::Vec3::ZERO;
            for &v in t {
                c += glam::Vec3::from(scene.pos_rel[v as usize]);
            }
            ((c * 0.25 - eye).dot(fwd), i as u32)
        })
        .collect();
    keyed.par_sort_unstable_by(|a, b| a.0.total_cmp(&b.0).then(a.1.cmp(&b.1)));
    keyed.into_iter().map(|(_, i)| i).collect()
}

/// What colours fragments: a method with its data on the GPU.
pub struct GpuShader {
    method: u32,
    tf_nodes: wgpu::Buffer,
    n_color: u32,
    n_opacity: u32,
    table: wgpu::Texture,
    table_params: [f32; 4],
    table_dims: [u32; 2],
}

impl GpuShader {
    /// `pt-linear`: the thick point's segment shaded once per tet with the
    /// transfer function (κ mean, α = 1 − e^{−l·ρ̄}), interpolated towards
    /// the silhouette. Clipped tets are shaded per fragment.
    pub fn pt_linear(ctx: &GpuContext, tf: &TransferFunction) -> Result<GpuShader, GpuError> {
        let dummy = table_texture(ctx, [1, 1, 1], &[[0.0; 4]])?;
        GpuShader::with_table(ctx, METHOD_PT_LINEAR, Some(tf), dummy, [0.0, 1.0, 1.0, 0.0], [2, 2])
    }

    /// `table3d`: the band of the table expanded into a full
    /// n_l × n_s × n_s Rgba32Float 3D texture (zeros outside the band, which
    /// a lookup never reaches) and looked up trilinearly per fragment with
    /// `Table3d::lookup`'s clamping (8 texel loads; no hardware filtering,
    /// whose 8-bit weights would differ from the CPU).
    pub fn table3d(ctx: &GpuContext, table: &Table3d) -> Result<GpuShader, GpuError> {
        let p = table.params();
        let d = table.domain();
        let (n_s, n_l) = (p.n_s, p.n_l);
        let max3d = ctx.device.limits().max_texture_dimension_3d as usize;
        if n_s > max3d || n_l > max3d {
            return Err(GpuError::TooLarge {
                what: "table3d axis (texels)",
                bytes: n_s.max(n_l) as u64,
                limit: max3d as u64,
            });
        }
        let bytes = (n_s * n_s * n_l * 16) as u64;
        check_size("table3d as a full cube", bytes, 1 << 31)?;
        let mut texels = vec![[0.0f32; 4]; n_s * n_s * n_l];
        texels.par_chunks_mut(n_s * n_l).enumerate().for_each(|(a, plane)| {
            for b in 0..n_s {
                for k in 0..n_l {
                    if let Some(e) = table.entry(a, b, k) {
                        plane[b * n_l + k] = e;
                    }
                }
            }
        });
        let tex = table_texture(ctx, [n_l as u32, n_s as u32, n_s as u32], &texels)?;
        // The same f64 → f32 steps as Table3d::from_parts and Band::new, so
        // the grid coordinates agree bit for bit with the CPU lookup.
        let span = d.scalar_span();
        let step = span / (n_s - 1) as f64;
        let reach = (d.max_ds / step).min((n_s - 1) as f64) as f32;
        let inv_ds = ((n_s - 1) as f64 / span) as f32;
        let inv_dl = ((n_l - 1) as f64 / d.len_max_world) as f32;
        GpuShader::with_table(
            ctx,
            METHOD_TABLE3D,
            None,
            tex,
            [d.s_lo as f32, inv_ds, inv_dl, reach],
            [n_s as u32, n_l as u32],
        )
    }

    fn with_table(
        ctx: &GpuContext,
        method: u32,
        tf: Option<&TransferFunction>,
        table: wgpu::Texture,
        table_params: [f32; 4],
        table_dims: [u32; 2],
    ) -> Result<GpuShader, GpuError> {
        let mut nodes: Vec<[f32; 4]> = Vec::new();
        let (mut n_color, mut n_opacity) = (0, 0);
        if let Some(tf) = tf {
            nodes.extend(
                tf.color_nodes().iter().map(|c| [c.x as f32, c.rgb[0] as f32, c.rgb[1] as f32, c.rgb[2] as f32]),
            );
            let u = tf.unit_distance();
            nodes.extend(tf.opacity_nodes().iter().map(|o| [o.x as f32, (o.a / u) as f32, 0.0, 0.0]));
            n_color = tf.color_nodes().len() as u32;
            n_opacity = tf.opacity_nodes().len() as u32;
        }
        if nodes.is_empty() {
            nodes.push([0.0; 4]);
        }
        let tf_nodes = ctx.checked(|| {
            ctx.device.create_buffer_init(&wgpu::util::BufferInitDescriptor {
                label: Some("tf nodes"),
                contents: bytemuck::cast_slice(&nodes),
                usage: wgpu::BufferUsages::STORAGE,
            })
        })?;
        Ok(GpuShader { method, tf_nodes, n_color, n_opacity, table, table_params, table_dims })
    }

    /// The method id (`pt-linear` or `table3d`).
    pub fn method_id(&self) -> &'static str {
        if self.method == METHOD_TABLE3D {
            "table3d"
        } else {
            "pt-linear"
        }
    }
}

fn table_texture(ctx: &GpuContext, size: [u32; 3], texels: &[[f32; 4]]) -> Result<wgpu::Texture, GpuError> {
    ctx.checked(|| {
        let extent = wgpu::Extent3d { width: size[0], height: size[1], depth_or_array_layers: size[2] };
        let tex = ctx.device.create_texture(&wgpu::TextureDescriptor {
            label: Some("table3d"),
            size: extent,
            mip_level_count: 1,
            sample_count: 1,
            dimension: wgpu::TextureDimension::D3,
            format: wgpu::TextureFormat::Rgba32Float,
            usage: wgpu::TextureUsages::TEXTURE_BINDING | wgpu::TextureUsages::COPY_DST,
            view_formats: &[],
        });
        ctx.queue.write_texture(
            wgpu::TexelCopyTextureInfo {
                texture: &tex,
                mip_level: 0,
                origin: wgpu::Origin3d::ZERO,
                aspect: Default::default(),
            },
            bytemuck::cast_slice(texels),
            wgpu::TexelCopyBufferLayout { offset: 0, bytes_per_row: Some(size[0] * 16), rows_per_image: Some(size[1]) },
            extent,
        );
        tex
    })
}

/// Wall-clock seconds of each stage (each stage is submitted and waited
/// for on its own so it can be timed) and counts.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct GpuRenderStats {
    /// Order upload and per-slot buffer allocation.
    pub upload_seconds: f64,
    pub classify_seconds: f64,
    pub raster_seconds: f64,
    pub readback_seconds: f64,
    pub total_seconds: f64,
    pub tets_drawn: usize,
}

/// One rendered frame: the linear premultiplied image and the HDR texture
/// it came from (input of [`GpuRenderer::tonemap`]).
pub struct GpuFrame {
    pub image: Image,
    pub stats: GpuRenderStats,
    pub(crate) hdr: wgpu::Texture,
}

/// Pipelines of the classify, raster and tone-mapping passes.
pub struct GpuRenderer {
    classify_layout: wgpu::BindGroupLayout,
    classify: wgpu::ComputePipeline,
    raster_layout: wgpu::BindGroupLayout,
    raster: wgpu::RenderPipeline,
    pub(crate) tone: crate::tonemap::TonePipelines,
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

impl GpuRenderer {
    /// Compiles the shaders and builds the pipelines.
    pub fn new(ctx: &GpuContext) -> Result<GpuRenderer, GpuError> {
        ctx.checked(|| {
            let dev = &ctx.device;
            let cs = wgpu::ShaderStages::COMPUTE;
            let (vs, fs) = (wgpu::ShaderStages::VERTEX, wgpu::ShaderStages::FRAGMENT);
            let classify_layout = dev.create_bind_group_layout(&wgpu::BindGroupLayoutDescriptor {
                label: Some("classify"),
                entries: &[
                    uniform_entry(0, cs),
                    storage_entry(1, cs, true),
                    storage_entry(2, cs, true),
                    storage_entry(3, cs, true),
                    storage_entry(4, cs, true),
                    storage_entry(5, cs, false),
                    storage_entry(6, cs, false),
                    storage_entry(7, cs, true),
                ],
            });
            let module = dev.create_shader_module(wgpu::ShaderModuleDescriptor {
                label: Some("classify.wgsl"),
                source: wgpu::ShaderSource::Wgsl(shader_source(CLASSIFY_WGSL).into()),
            });
            let layout = dev.create_pipeline_layout(&wgpu::PipelineLayoutDescriptor {
                label: Some("classify"),
                bind_group_layouts: &[Some(&classify_layout)],
                immediate_size: 0,
            });
            let classify = dev.create_compute_pipeline(&wgpu::ComputePipelineDescriptor {
                label: Some("classify"),
                layout: Some(&layout),
                module: &module,
                entry_point: Some("classify"),
                compilation_options: Default::default(),
                cache: None,
            });

            let raster_layout = dev.create_bind_group_layout(&wgpu::BindGroupLayoutDescriptor {
                label: Some("raster"),
                entries: &[
                    uniform_entry(0, vs | fs),
                    storage_entry(5, vs, true),
                    storage_entry(6, fs, true),
                    storage_entry(7, fs, true),
                    texture_entry(8, fs, wgpu::TextureViewDimension::D3),
                ],
            });
            let module = dev.create_shader_module(wgpu::ShaderModuleDescriptor {
                label: Some("raster.wgsl"),
                source: wgpu::ShaderSource::Wgsl(shader_source(RASTER_WGSL).into()),
            });
            let layout = dev.create_pipeline_layout(&wgpu::PipelineLayoutDescriptor {
                label: Some("raster"),
                bind_group_layouts: &[Some(&raster_layout)],
                immediate_size: 0,
            });
            // Front to back "under": dst += (1 − dst.α)·src, for colour and α.
            let under = wgpu::BlendComponent {
                src_factor: wgpu::BlendFactor::OneMinusDstAlpha,
                dst_factor: wgpu::BlendFactor::One,
                operation: wgpu::BlendOperation::Add,
            };
            let raster = dev.create_render_pipeline(&wgpu::RenderPipelineDescriptor {
                label: Some("raster"),
                layout: Some(&layout),
                vertex: wgpu::VertexState {
                    module: &module,
                    entry_point: Some("vs"),
                    compilation_options: Default::default(),
                    buffers: &[],
                },
                primitive: wgpu::PrimitiveState { cull_mode: None, ..Default::default() },
                depth_stencil: None,
                multisample: Default::default(),
                fragment: Some(wgpu::FragmentState {
                    module: &module,
                    entry_point: Some("fs"),
                    compilation_options: Default::default(),
                    targets: &[Some(wgpu::ColorTargetState {
                        format: HDR_FORMAT,
                        blend: Some(wgpu::BlendState { color: under, alpha: under }),
                        write_mask: wgpu::ColorWrites::ALL,
                    })],
                }),
                multiview_mask: None,
                cache: None,
            });
            let tone = crate::tonemap::TonePipelines::new(ctx);
            GpuRenderer { classify_layout, classify, raster_layout, raster, tone }
        })
    }

    /// Renders `order` (tet indices, front to back; e.g. [`centroid_order`]
    /// or tet_render's MPVO) into a linear premultiplied image of the
    /// camera's size.
    pub fn render(
        &self,
        ctx: &GpuContext,
        scene: &GpuScene,
        camera: &Camera,
        order: &[u32],
        shader: &GpuShader,
    ) -> Result<GpuFrame, GpuError> {
        let start = Instant::now();
        if order.len() > scene.num_tets() {
            return Err(GpuError::Input(format!("order of {} tets for a scene of {}", order.len(), scene.num_tets())));
        }
        if let Some(&t) = order.iter().find(|&&t| t as usize >= scene.num_tets()) {
            return Err(GpuError::Input(format!("order refers to tet {t}; the scene has {}", scene.num_tets())));
        }
        let n = order.len().max(1) as u64;
        let dev = &ctx.device;
        let groups = (n as u32).div_ceil(CLASSIFY_WG);
        let groups_x = groups.min(65535);
        let groups_y = groups.div_ceil(groups_x);
        let uniforms = frame_uniforms(camera, scene.centre_in_world, order.len() as u32, shader, groups_x);
        let (w, h) = (camera.width(), camera.height());
        let max2d = dev.limits().max_texture_dimension_2d;
        if w > max2d || h > max2d {
            return Err(GpuError::TooLarge {
                what: "image side (pixels)",
                bytes: w.max(h) as u64,
                limit: max2d as u64,
            });
        }

        let (uni, order_buf, geoms, shades, hdr) = ctx.checked(|| {
            let uni = dev.create_buffer_init(&wgpu::util::BufferInitDescriptor {
                label: Some("frame"),
                contents: bytemuck::bytes_of(&uniforms),
                usage: wgpu::BufferUsages::UNIFORM,
            });
            let order_src: &[u32] = if order.is_empty() { &[0] } else { order };
            let order_buf = dev.create_buffer_init(&wgpu::util::BufferInitDescriptor {
                label: Some("order"),
                contents: bytemuck::cast_slice(order_src),
                usage: wgpu::BufferUsages::STORAGE,
            });
            let slot_buf = |label, size| {
                dev.create_buffer(&wgpu::BufferDescriptor {
                    label: Some(label),
                    size,
                    usage: wgpu::BufferUsages::STORAGE,
                    mapped_at_creation: false,
                })
            };
            let geoms = slot_buf("geoms", n * std::mem::size_of::<TetGeom>() as u64);
            let shades = slot_buf("shades", n * std::mem::size_of::<TetShade>() as u64);
            let hdr = dev.create_texture(&wgpu::TextureDescriptor {
                label: Some("hdr"),
                size: wgpu::Extent3d { width: w, height: h, depth_or_array_layers: 1 },
                mip_level_count: 1,
                sample_count: 1,
                dimension: wgpu::TextureDimension::D2,
                format: HDR_FORMAT,
                usage: wgpu::TextureUsages::RENDER_ATTACHMENT
                    | wgpu::TextureUsages::COPY_SRC
                    | wgpu::TextureUsages::TEXTURE_BINDING,
                view_formats: &[],
            });
            (uni, order_buf, geoms, shades, hdr)
        })?;
        ctx.wait()?;
        let upload_seconds = start.elapsed().as_secs_f64();

        let t = Instant::now();
        ctx.checked(|| {
            let bg = dev.create_bind_group(&wgpu::BindGroupDescriptor {
                label: Some("classify"),
                layout: &self.classify_layout,
                entries: &[
                    bind(0, &uni),
                    bind(1, &scene.positions),
                    bind(2, &scene.tet_buf),
                    bind(3, &scene.scalars),
                    bind(4, &order_buf),
                    bind(5, &geoms),
                    bind(6, &shades),
                    bind(7, &shader.tf_nodes),
                ],
            });
            let mut enc = dev.create_command_encoder(&Default::default());
            if !order.is_empty() {
                let mut pass = enc.begin_compute_pass(&Default::default());
                pass.set_pipeline(&self.classify);
                pass.set_bind_group(0, &bg, &[]);
                pass.dispatch_workgroups(groups_x, groups_y, 1);
            }
            ctx.queue.submit([enc.finish()]);
        })?;
        ctx.wait()?;
        let classify_seconds = t.elapsed().as_secs_f64();

        let t = Instant::now();
        ctx.checked(|| {
            let table_view = shader.table.create_view(&Default::default());
            let bg = dev.create_bind_group(&wgpu::BindGroupDescriptor {
                label: Some("raster"),
                layout: &self.raster_layout,
                entries: &[
                    bind(0, &uni),
                    bind(5, &geoms),
                    bind(6, &shades),
                    bind(7, &shader.tf_nodes),
                    wgpu::BindGroupEntry { binding: 8, resource: wgpu::BindingResource::TextureView(&table_view) },
                ],
            });
            let view = hdr.create_view(&Default::default());
            let mut enc = dev.create_command_encoder(&Default::default());
            {
                let mut pass = enc.begin_render_pass(&wgpu::RenderPassDescriptor {
                    label: Some("raster"),
                    color_attachments: &[Some(wgpu::RenderPassColorAttachment {
                        view: &view,
                        depth_slice: None,
                        resolve_target: None,
                        ops: wgpu::Operations {
                            load: wgpu::LoadOp::Clear(wgpu::Color::TRANSPARENT),
                            store: wgpu::StoreOp::Store,
                        },
                    })],
                    depth_stencil_attachment: None,
                    timestamp_writes: None,
                    occlusion_query_set: None,
                    multiview_mask: None,
                });
                if !order.is_empty() {
                    pass.set_pipeline(&self.raster);
                    pass.set_bind_group(0, &bg, &[]);
                    pass.draw(0..order.len() as u32 * VERTS_PER_SLOT, 0..1);
                }
            }
            ctx.queue.submit([enc.finish()]);
        })?;
        ctx.wait()?;
        let raster_seconds = t.elapsed().as_secs_f64();

        let t = Instant::now();
        let image = read_texture(ctx, &hdr)?;
        let readback_seconds = t.elapsed().as_secs_f64();
        let stats = GpuRenderStats {
            upload_seconds,
            classify_seconds,
            raster_seconds,
            readback_seconds,
            total_seconds: start.elapsed().as_secs_f64(),
            tets_drawn: order.len(),
        };
        Ok(GpuFrame { image, stats, hdr })
    }
}

fn bind(binding: u32, buf: &wgpu::Buffer) -> wgpu::BindGroupEntry<'_> {
    wgpu::BindGroupEntry { binding, resource: buf.as_entire_binding() }
}

/// The camera in the scene's frame, as tet_render's `project::Frame`.
fn frame_uniforms(camera: &Camera, centre: DVec3, n_slots: u32, shader: &GpuShader, groups_x: u32) -> FrameUniforms {
    let spec = camera.spec();
    let forward = camera.forward();
    let right = forward.cross(DVec3::from(spec.view_up)).normalize();
    let up = right.cross(forward);
    let (w, h) = (spec.size[0] as f64, spec.size[1] as f64);
    let half_h = if spec.parallel { spec.parallel_scale } else { (0.5 * spec.view_angle.to_radians()).tan() };
    let half_w = half_h * w / h;
    let v4 = |v: DVec3| [v.x as f32, v.y as f32, v.z as f32, 0.0];
    FrameUniforms {
        eye_rel: v4(DVec3::from(spec.position) - centre),
        right: v4(right),
        up: v4(up),
        forward: v4(forward),
        ax: (2.0 * half_w / w) as f32,
        bx: -half_w as f32,
        ay: (-2.0 * half_h / h) as f32,
        by: half_h as f32,
        width: w as f32,
        height: h as f32,
        near_depth: if spec.parallel { 0.0 } else { camera.near_depth() as f32 },
        parallel: spec.parallel as u32,
        n_slots,
        method: shader.method,
        n_color_nodes: shader.n_color,
        n_opacity_nodes: shader.n_opacity,
        table_s_lo: shader.table_params[0],
        table_inv_ds: shader.table_params[1],
        table_inv_dl: shader.table_params[2],
        table_reach: shader.table_params[3],
        table_n_s: shader.table_dims[0],
        table_n_l: shader.table_dims[1],
        groups_x,
        _pad: 0,
    }
}
