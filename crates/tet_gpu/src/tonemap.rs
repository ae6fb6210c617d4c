//! Reinhard tone mapping on the GPU (tonemap.wgsl): composite over the
//! background, log-average luminance of the covered pixels by a two-level
//! compute reduction, then
//! the per-pixel mapping to 8-bit sRGB — the same formula as tet_render's
//! `Reinhard::fit` / `apply` and `Image::to_rgba8`.

use crate::gpu_types::{ToneFit, ToneParams, TONE_WG};
use crate::render::{
    bind, bind_all, bind_group, bind_view, buffer, buffer_init, shader_module, storage_entries, texture_entry,
    uniform_entry, BoundModule, GpuFrame, GpuRenderer, HDR_FORMAT, READ_BACK,
};
use crate::workspace::split_groups;
use crate::{map_read, GpuContext, GpuError, TONEMAP_WGSL};
use std::time::Instant;
use tet_render::{Display, Image, ToneMap};
use wgpu::util::DeviceExt;

/// Pixels per invocation of the reduce pass (`PER_THREAD` in tonemap.wgsl).
const PER_THREAD: u32 = 4;

pub(crate) struct TonePipelines {
    bound: BoundModule,
    reduce: wgpu::ComputePipeline,
    fit: wgpu::ComputePipeline,
    map: wgpu::ComputePipeline,
}

impl TonePipelines {
    pub(crate) fn new(ctx: &GpuContext) -> TonePipelines {
        let dev = &ctx.device;
        let cs = wgpu::ShaderStages::COMPUTE;
        let mut entries = vec![uniform_entry(0, cs), texture_entry(1, cs, wgpu::TextureViewDimension::D2)];
        entries.extend(storage_entries(2, cs, &[false; 3]));
        let module = shader_module(dev, "tonemap.wgsl", TONEMAP_WGSL.to_string());
        let bound = BoundModule::new(dev, "tonemap", &entries, module);
        let make = |entry| bound.compute(dev, entry, &[]);
        TonePipelines { reduce: make("reduce"), fit: make("fit"), map: make("map"), bound }
    }
}

/// 8-bit sRGB RGBA (opaque, row 0 at the top) and the fitted operator.
#[derive(Debug, Clone, PartialEq)]
pub struct ToneResult {
    pub rgba8: Vec<u8>,
    /// (scale, L_white², log-average luminance) as tet_render's `Reinhard`;
    /// `None` for `ToneMap::None`.
    pub reinhard: Option<[f32; 3]>,
    pub seconds: f64,
}

impl GpuRenderer {
    /// Tone maps a rendered frame on the GPU as `display` says.
    pub fn tonemap(&self, ctx: &GpuContext, frame: &GpuFrame, display: &Display) -> Result<ToneResult, GpuError> {
        self.tonemap_texture(ctx, &frame.hdr, display)
    }

    /// Uploads a float image and tone maps it on the GPU (what the tests
    /// compare with `Image::to_rgba8` on identical input).
    pub fn tonemap_image(&self, ctx: &GpuContext, image: &Image, display: &Display) -> Result<ToneResult, GpuError> {
        let (w, h) = (image.width(), image.height());
        let tex = ctx.checked(|| {
            ctx.device.create_texture_with_data(
                &ctx.queue,
                &wgpu::TextureDescriptor {
                    label: Some("tonemap input"),
                    size: wgpu::Extent3d { width: w, height: h, depth_or_array_layers: 1 },
                    mip_level_count: 1,
                    sample_count: 1,
                    dimension: wgpu::TextureDimension::D2,
                    format: HDR_FORMAT,
                    usage: wgpu::TextureUsages::TEXTURE_BINDING | wgpu::TextureUsages::COPY_DST,
                    view_formats: &[],
                },
                Default::default(),
                bytemuck::cast_slice(image.pixels()),
            )
        })?;
        self.tonemap_texture(ctx, &tex, display)
    }

    fn tonemap_texture(
        &self,
        ctx: &GpuContext,
        hdr: &wgpu::Texture,
        display: &Display,
    ) -> Result<ToneResult, GpuError> {
        let start = Instant::now();
        let (w, h) = (hdr.width(), hdr.height());
        let n = w as u64 * h as u64;
        let n_partials = (n.div_ceil((TONE_WG * PER_THREAD) as u64) as u32).max(1);
        let (rx, ry) = split_groups(n_partials);
        let (mx, my) = split_groups((n.div_ceil(TONE_WG as u64) as u32).max(1));
        let (reinhard, key, exposure) = match display.tonemap {
            ToneMap::None => (0, 0.18, 1.0),
            ToneMap::Reinhard { key, exposure } => (1, key, exposure),
        };
        let bg = display.background;
        let params = |groups_x| ToneParams {
            background: [bg[0], bg[1], bg[2], 0.0],
            width: w,
            height: h,
            n_partials,
            reinhard,
            key,
            exposure,
            groups_x,
            _pad: 0,
        };
        let dev = &ctx.device;
        let (out, fit_read, out_read) = ctx.checked(|| {
            let storage =
                |label, size| buffer(dev, label, size, wgpu::BufferUsages::STORAGE | wgpu::BufferUsages::COPY_SRC);
            // Two vec4<f32> per reduce workgroup (covered pixels, all pixels).
            let partials = storage("partials", n_partials as u64 * 32);
            let fit = storage("fit", std::mem::size_of::<ToneFit>() as u64);
            let out = storage("rgba8", n * 4);
            let fit_read = buffer(dev, "fit read", std::mem::size_of::<ToneFit>() as u64, READ_BACK);
            let out_read = buffer(dev, "rgba8 read", n * 4, READ_BACK);
            let view = hdr.create_view(&Default::default());
            let group = |groups_x: u32| {
                let uni =
                    buffer_init(dev, "tone params", bytemuck::bytes_of(&params(groups_x)), wgpu::BufferUsages::UNIFORM);
                let mut entries = vec![bind(0, &uni), bind_view(1, &view)];
                entries.extend(bind_all(2, &[&partials, &fit, &out]));
                bind_group(dev, "tonemap", &self.tone.bound.layout, &entries)
            };
            let (bg_reduce, bg_map) = (group(rx), group(mx));
            let mut enc = dev.create_command_encoder(&Default::default());
            {
                let mut pass = enc.begin_compute_pass(&Default::default());
                if reinhard != 0 {
                    pass.set_bind_group(0, &bg_reduce, &[]);
                    pass.set_pipeline(&self.tone.reduce);
                    pass.dispatch_workgroups(rx, ry, 1);
                    pass.set_pipeline(&self.tone.fit);
                    pass.dispatch_workgroups(1, 1, 1);
                }
                pass.set_bind_group(0, &bg_map, &[]);
                pass.set_pipeline(&self.tone.map);
                pass.dispatch_workgroups(mx, my, 1);
            }
            enc.copy_buffer_to_buffer(&fit, 0, &fit_read, 0, None);
            enc.copy_buffer_to_buffer(&out, 0, &out_read, 0, None);
            ctx.queue.submit([enc.finish()]);
            (out, fit_read, out_read)
        })?;
        drop(out);
        let rgba8 = map_read(ctx, &out_read)?;
        let fit: ToneFit = *bytemuck::from_bytes(&map_read(ctx, &fit_read)?);
        Ok(ToneResult {
            rgba8,
            reinhard: (reinhard != 0).then_some([fit.scale, fit.white_sq, fit.log_average]),
            seconds: start.elapsed().as_secs_f64(),
        })
    }
}
