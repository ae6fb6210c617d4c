//! The frame on the GPU: the classify and raster passes (the compute tile
//! rasterizer and the hardware one), culling compaction, the order's upload
//! or the GPU centroid sort, read-back — `GpuRenderer::render_frame`.
//! Beside it: the mesh on the GPU and the CPU centroid order (`scene`), the
//! shaders of pt-linear and table3d (`shader`; the 2D-table methods are in
//! methods.rs) and the pipeline helpers every pass uses (`pipeline`).

use crate::binning::{BinPipelines, BIN_PARAMS_SIZE};
use crate::cull::{CullBuffers, CullPipelines};
use crate::gpu_types::{
    BinParams, FrameUniforms, LightParams, TetGeom, TetShade, BIN_WG, CLASSIFY_WG, METHOD_BIV_EXACT, METHOD_PT_LINEAR,
    METHOD_TABLE3D, NORMAL_ROWS, RADIX_BLOCK, SCAN_BLOCK, TILE_PX, VERTS_PER_SLOT,
};
use crate::gpusort::SortPipelines;
use crate::methods::Tables2d;
use crate::workspace::{split_groups, Grow, Params};
use crate::{
    map_read_range, read_texture, shader_source, shader_source_fragment, GpuContext, GpuError, CLASSIFY_WGSL,
    RASTER_WGSL,
};
use glam::DVec3;
use rayon::prelude::*;
use std::collections::HashMap;
use std::sync::Mutex;
use std::time::Instant;
use tet_preint::{Method, Reconstruction, Table3d, TableDomain, TransferFunction};
use tet_render::ViewSpec;
use tet_render::{Camera, Image};

/// The HDR target format (needs FLOAT32_BLENDABLE).
pub(crate) const HDR_FORMAT: wgpu::TextureFormat = wgpu::TextureFormat::Rgba32Float;

mod pipeline;
mod scene;
mod shader;

pub(crate) use pipeline::{
    bind, bind_all, bind_group, bind_view, buffer, buffer_init, compute_pipeline, compute_pipeline_with, dispatch,
    read_rgba32f, shader_module, storage_entries, storage_entry, storage_texture_entry, texture_entry,
    uint_texture_entry, uniform_dyn_entry, uniform_entry, upload_texture, BoundModule, READ_BACK,
};
pub(crate) use scene::check_size;
pub use scene::{centroid_order, GpuScene};
pub use shader::GpuShader;
pub(crate) use shader::{check_table_dims, placeholder_3d, tf_node_rows, TableGrid};

/// Which rasterizer composites the classified tets.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum RasterPath {
    /// Tiles in compute shaders (bin.wgsl): tets binned into 16×16 tiles
    /// in visibility order (prefix sums and a stable radix sort), one
    /// workgroup per tile compositing front to back per pixel with early
    /// termination. Needs the image (16 bytes a pixel) within one storage
    /// binding; larger images fall back to [`RasterPath::Graphics`], and so
    /// does biv-exact on llvmpipe (its loop-iteration limit, see
    /// `GpuContext::limits_loop_iterations`).
    #[default]
    Compute,
    /// The hardware rasterizer: a fan of 3 or 4 triangles per tet, "under"
    /// blending into the HDR target (raster.wgsl).
    Graphics,
}

impl RasterPath {
    pub fn id(self) -> &'static str {
        match self {
            RasterPath::Compute => "compute",
            RasterPath::Graphics => "graphics",
        }
    }
}

impl std::str::FromStr for RasterPath {
    type Err = String;
    fn from_str(s: &str) -> Result<Self, String> {
        match s {
            "compute" => Ok(RasterPath::Compute),
            "graphics" => Ok(RasterPath::Graphics),
            _ => Err(format!("unknown raster path '{s}'; known: compute, graphics")),
        }
    }
}

/// The visibility order of a frame.
#[derive(Debug, Clone, Copy)]
pub enum GpuOrder<'a> {
    /// Tet indices front to back computed elsewhere (tet_render's MPVO: the
    /// exact option; [`centroid_order`]); may leave tets out (culled).
    Given(&'a [u32]),
    /// Every tet by centroid depth, radix-sorted on the GPU — the fast
    /// approximate order, recomputed only when the camera (or the scene)
    /// changed since the renderer last sorted.
    GpuCentroid,
}

/// Wall-clock seconds of each stage (each stage is submitted and waited
/// for on its own so it can be timed; chunks add up) and counts.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct GpuRenderStats {
    /// Order upload (a given order).
    pub upload_seconds: f64,
    /// GPU centroid sort (0 when the cached order was reused).
    pub sort_seconds: f64,
    pub classify_seconds: f64,
    /// Compute path: tile counts, prefix sums, pair fill, radix sort by tile.
    pub bin_seconds: f64,
    /// Compute path: the tile composite; graphics path: the draw.
    pub raster_seconds: f64,
    pub readback_seconds: f64,
    pub total_seconds: f64,
    /// Culling on the GPU: flags, prefix sum, compaction and the count's
    /// read-back (0 without [`FrameOptions::cull`]).
    pub cull_seconds: f64,
    /// Tets of the order classified and rasterized (after culling).
    pub tets_drawn: usize,
    /// Tets of the order culled on the GPU.
    pub tets_culled: usize,
    /// Chunks the order was split into (per-slot data beyond one storage
    /// binding).
    pub chunks: usize,
    /// Compute path: (tile, tet) pairs binned.
    pub pairs: u64,
    /// The rasterizer that ran (a compute request can fall back).
    pub raster_path: RasterPath,
    /// Whether this frame ran the GPU centroid sort.
    pub sorted_on_gpu: bool,
    /// Persistent buffers (re)allocated by this frame.
    pub buffers_grown: usize,
}

impl GpuRenderStats {
    /// Culled tets over the order's tets (drawn + culled); 0 for an empty order.
    pub fn fraction_culled(&self) -> f64 {
        let all = self.tets_drawn + self.tets_culled;
        if all == 0 {
            0.0
        } else {
            self.tets_culled as f64 / all as f64
        }
    }
}

/// How to render a frame besides the order and the shader.
#[derive(Clone, Copy, Default)]
pub struct FrameOptions<'a> {
    pub raster: RasterPath,
    /// Cull on the GPU: the order's tets that the TF makes invisible are
    /// compacted out before classification (see [`crate::GpuCull`]).
    pub cull: Option<&'a crate::GpuCull>,
    /// Lighting and silhouettes (`tet_render::Shading`, with the gradient
    /// floor it is to use: the engine gives the scene's default where the
    /// request has none), as the CPU's projected tetrahedra light a
    /// fragment: each segment at its emission centroid, split into pieces
    /// where the terms vary (`tet_render::shading::light_segment`), in f32.
    /// Needs [`GpuScene::with_gradients`]. `None`: unshaded.
    pub shading: Option<&'a tet_render::Shading>,
    /// The shading's shadows ([`crate::ShadowMaps`] of the scene's
    /// `tet_render::ShadowField`): each light's transmittance, looked up
    /// where each piece of a segment is lit. Needed when `shading` wants
    /// shadows; `None` otherwise.
    pub shadows: Option<&'a crate::ShadowMaps>,
}

/// One rendered frame: the linear premultiplied image and the HDR texture
/// it came from (input of [`GpuRenderer::tonemap`]; the renderer reuses the
/// texture, so tone map a frame before rendering the next).
pub struct GpuFrame {
    pub image: Image,
    pub stats: GpuRenderStats,
    pub(crate) hdr: wgpu::Texture,
}

/// Per-slot, order, binning and sort buffers kept across frames.
struct Workspace {
    params: Params,
    order: Grow,
    geoms: Grow,
    shades: Grow,
    counts: Grow,
    sums: Grow,
    hist: Grow,
    ranges: Grow,
    accum: Grow,
    pair_keys: [Grow; 2],
    pair_vals: [Grow; 2],
    depth_keys: [Grow; 2],
    depth_vals: [Grow; 2],
    /// Bivariate methods: the gradient magnitude's field per slot.
    gshades: Grow,
    /// Lighting: the gradient's fields per slot (NORMAL_ROWS rows).
    nshades: Grow,
    /// The frame's [`LightParams`].
    lights: wgpu::Buffer,
    /// Each light's [`crate::gpu_types::GpuShadowMap`], and the maps'
    /// knots and ray index ([`crate::ShadowMaps`]).
    shadow_maps: wgpu::Buffer,
    shadow_knots: Grow,
    shadow_index: Grow,
    /// The id of the `ShadowMaps` these three buffers hold.
    shadows_uploaded: Option<u64>,
    cull_flags: Grow,
    cull_order: Grow,
    readback: Grow,
    /// The GPU centroid order in `depth_vals[.2]`, valid for scene `.0`
    /// seen from `.1`.
    sorted: Option<(u64, ViewSpec, usize)>,
    hdr: Option<wgpu::Texture>,
    /// Caps below the device's (see [`GpuRenderer::set_chunk_limits`]).
    max_chunk_slots: usize,
    max_pairs: u32,
}

impl Workspace {
    fn new(ctx: &GpuContext) -> Workspace {
        let two = |k: &'static str, v: &'static str| [Grow::storage(k), Grow::storage(v)];
        Workspace {
            params: Params::new(ctx),
            order: Grow::storage("order"),
            geoms: Grow::storage("geoms"),
            shades: Grow::storage("shades"),
            counts: Grow::storage("tile counts"),
            sums: Grow::storage("scan sums"),
            hist: Grow::storage("radix histogram"),
            ranges: Grow::storage("tile ranges"),
            accum: Grow::storage("accumulated colour"),
            pair_keys: two("pair keys 0", "pair keys 1"),
            pair_vals: two("pair values 0", "pair values 1"),
            depth_keys: two("depth keys 0", "depth keys 1"),
            depth_vals: two("depth order 0", "depth order 1"),
            gshades: Grow::storage("gradient-magnitude fields"),
            nshades: Grow::storage("gradient fields"),
            lights: buffer(
                &ctx.device,
                "lighting",
                std::mem::size_of::<LightParams>() as u64,
                wgpu::BufferUsages::UNIFORM | wgpu::BufferUsages::COPY_DST,
            ),
            shadow_maps: buffer(
                &ctx.device,
                "shadow maps",
                std::mem::size_of::<
                    [crate::gpu_types::GpuShadowMap; crate::gpu_types::SHADOW_SLOTS * crate::gpu_types::MAX_GPU_LIGHTS],
                >() as u64,
                wgpu::BufferUsages::STORAGE | wgpu::BufferUsages::COPY_DST,
            ),
            shadow_knots: Grow::storage("shadow-map knots"),
            shadow_index: Grow::storage("shadow-map ray index"),
            shadows_uploaded: None,
            cull_flags: Grow::storage("cull flags"),
            cull_order: Grow::storage("culled order"),
            readback: Grow::new("readback", wgpu::BufferUsages::COPY_DST | wgpu::BufferUsages::MAP_READ),
            sorted: None,
            hdr: None,
            max_chunk_slots: usize::MAX,
            max_pairs: u32::MAX,
        }
    }
}

/// Most (tile, tet) pairs of one compute-raster pass on an adapter whose
/// loops share a per-invocation iteration limit (llvmpipe's 65 535). A
/// pixel loops over its tile's list in a pass: per listed tet about a dozen
/// iterations (its hull loaded and tested), per covered fragment what the
/// method's lookup loops (a scalar-axis search: ~15). At 2 Ki pairs even a
/// pass whose every tet covers the pixel stays under the limit for the
/// table methods; 16 Ki still lost fragments in a test of 40 000 tets
/// seen end-on. Methods that loop far more per fragment (biv-exact) take
/// the graphics rasterizer there instead, where each fragment counts alone.
const LOOP_LIMITED_PAIRS: u32 = 2 * 1024;

/// Most (tile, tet) pairs of one compute-raster pass of a lit frame on such
/// an adapter: a lit fragment may shade its segment in up to 32 pieces
/// (`tet_render::shading::LIT_MAX_PIECES`), each with the method's lookup
/// and the lights' loop, about 1 000 iterations in all; 64 such fragments
/// stay under the limit. A shadowed piece adds per light the map's ray
/// reads (4, or 16 where the lookup turns bicubic) and each read's walk
/// through its bin's knots: a frame of many lights in steep shadows can
/// pass the limit even there, and on the graphics rasterizer it is per
/// fragment. Lit frames there take the graphics rasterizer
/// unless [`GpuRenderer::set_chunk_limits`] caps the pairs at this.
pub const LIT_LOOP_LIMITED_PAIRS: u32 = 64;

/// Which pipeline shades fragments: the graphics raster or the compute
/// rasterizer's composite pass.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
enum ShadePass {
    Raster,
    Composite,
}

/// A fragment-shading pipeline specialised to one method.
#[derive(Clone)]
enum ShadePipeline {
    Raster(wgpu::RenderPipeline),
    Composite(wgpu::ComputePipeline),
}

/// Pipelines of the classify, raster (graphics and compute), sort and
/// tone-mapping passes, and the buffers they reuse across frames.
pub struct GpuRenderer {
    classify_module: BoundModule,
    classify: wgpu::ComputePipeline,
    raster: BoundModule,
    /// The pipelines that shade fragments, per method (fragment.wgsl's
    /// `SHADE_METHOD` override) and rasterizer, each built at its first frame.
    per_method: Mutex<HashMap<(u32, ShadePass), ShadePipeline>>,
    bin: BinPipelines,
    sort: SortPipelines,
    cull: CullPipelines,
    pub(crate) tone: crate::tonemap::TonePipelines,
    ws: Mutex<Workspace>,
}

const FRAME_SIZE: u64 = std::mem::size_of::<FrameUniforms>() as u64;

/// lighting.wgsl's shadow maps, knots and ray index (bindings 22–24), read.
pub(crate) fn shadow_entries(stages: wgpu::ShaderStages) -> [wgpu::BindGroupLayoutEntry; 3] {
    [storage_entry(22, stages, true), storage_entry(23, stages, true), storage_entry(24, stages, true)]
}

fn shadow_bindings(ws: &Workspace) -> [wgpu::BindGroupEntry<'_>; 3] {
    [bind(22, &ws.shadow_maps), bind(23, ws.shadow_knots.get()), bind(24, ws.shadow_index.get())]
}

impl GpuRenderer {
    /// Compiles the shaders and builds the pipelines.
    pub fn new(ctx: &GpuContext) -> Result<GpuRenderer, GpuError> {
        ctx.checked(|| {
            let dev = &ctx.device;
            let cs = wgpu::ShaderStages::COMPUTE;
            let (vs, fs) = (wgpu::ShaderStages::VERTEX, wgpu::ShaderStages::FRAGMENT);
            let mut entries = vec![uniform_dyn_entry(0, cs)];
            // Positions, tets, scalars and the order read; geometries and
            // shades written; TF rows read.
            entries.extend(storage_entries(1, cs, &[true, true, true, true, false, false, true]));
            entries.extend([storage_entry(17, cs, true), storage_entry(18, cs, false)]);
            // Lighting: its parameters and the vertex gradients read, the gradient fields written.
            entries.extend([uniform_entry(19, cs), storage_entry(20, cs, true), storage_entry(21, cs, false)]);
            entries.extend(shadow_entries(cs));
            let module = shader_module(dev, "classify.wgsl", shader_source(CLASSIFY_WGSL));
            let classify_module = BoundModule::new(dev, "classify", &entries, module);
            let classify = classify_module.compute(dev, "classify", &[]);

            let raster = BoundModule::new(
                dev,
                "raster",
                &[
                    uniform_dyn_entry(0, vs | fs),
                    storage_entry(5, vs, true),
                    storage_entry(6, fs, true),
                    storage_entry(7, fs, true),
                    texture_entry(8, fs, wgpu::TextureViewDimension::D3),
                    texture_entry(14, fs, wgpu::TextureViewDimension::D2Array),
                    uint_texture_entry(15, fs, wgpu::TextureViewDimension::D1),
                    uniform_entry(16, fs),
                    storage_entry(18, fs, true),
                    uniform_entry(19, fs),
                    storage_entry(21, fs, true),
                    storage_entry(22, fs, true),
                    storage_entry(23, fs, true),
                    storage_entry(24, fs, true),
                ],
                shader_module(dev, "raster.wgsl", shader_source_fragment(RASTER_WGSL)),
            );
            let tone = crate::tonemap::TonePipelines::new(ctx);
            GpuRenderer {
                classify_module,
                classify,
                raster,
                per_method: Mutex::new(HashMap::new()),
                bin: BinPipelines::new(ctx),
                sort: SortPipelines::new(ctx),
                cull: CullPipelines::new(ctx),
                tone,
                ws: Mutex::new(Workspace::new(ctx)),
            }
        })
    }

    /// The fragment-shading pipeline of `method` for `pass` (built now
    /// unless cached: a method compiles only what its frames use).
    fn shade_pipeline(&self, ctx: &GpuContext, method: u32, pass: ShadePass) -> Result<ShadePipeline, GpuError> {
        let mut cache = self.per_method.lock().unwrap_or_else(|e| e.into_inner());
        if let Some(p) = cache.get(&(method, pass)) {
            return Ok(p.clone());
        }
        let constants = [("SHADE_METHOD", method as f64)];
        let dev = &ctx.device;
        let pipeline = ctx.checked(|| {
            if pass == ShadePass::Composite {
                return ShadePipeline::Composite(self.bin.composite_for(ctx, &constants));
            }
            let options = wgpu::PipelineCompilationOptions { constants: &constants, ..Default::default() };
            // Front to back "under": dst += (1 − dst.α)·src, for colour and α.
            let under = wgpu::BlendComponent {
                src_factor: wgpu::BlendFactor::OneMinusDstAlpha,
                dst_factor: wgpu::BlendFactor::One,
                operation: wgpu::BlendOperation::Add,
            };
            let raster = dev.create_render_pipeline(&wgpu::RenderPipelineDescriptor {
                label: Some("raster"),
                layout: Some(&self.raster.pipeline_layout),
                vertex: wgpu::VertexState {
                    module: &self.raster.module,
                    entry_point: Some("vs"),
                    compilation_options: options.clone(),
                    buffers: &[],
                },
                primitive: wgpu::PrimitiveState { cull_mode: None, ..Default::default() },
                depth_stencil: None,
                multisample: Default::default(),
                fragment: Some(wgpu::FragmentState {
                    module: &self.raster.module,
                    entry_point: Some("fs"),
                    compilation_options: options.clone(),
                    targets: &[Some(wgpu::ColorTargetState {
                        format: HDR_FORMAT,
                        blend: Some(wgpu::BlendState { color: under, alpha: under }),
                        write_mask: wgpu::ColorWrites::ALL,
                    })],
                }),
                multiview_mask: None,
                cache: None,
            });
            ShadePipeline::Raster(raster)
        })?;
        cache.insert((method, pass), pipeline.clone());
        Ok(pipeline)
    }

    /// Lowers the chunking thresholds below what the device's storage
    /// binding limit implies: at most `slots` tets a chunk (rounded down to
    /// a multiple of 256, at least 256) and at most `pairs` (tile, tet)
    /// pairs a compute-raster pass; `None` restores the device's. For tests
    /// of the chunked paths on small scenes, and to bound memory.
    pub fn set_chunk_limits(&self, slots: Option<usize>, pairs: Option<u32>) {
        let mut ws = self.ws.lock().unwrap_or_else(|e| e.into_inner());
        ws.max_chunk_slots = slots.map_or(usize::MAX, |s| (s / 256 * 256).max(256));
        ws.max_pairs = pairs.map_or(u32::MAX, |p| p.max(1));
    }

    /// Renders `order` (tet indices, front to back; e.g. [`centroid_order`]
    /// or tet_render's MPVO) into a linear premultiplied image of the
    /// camera's size with the default rasterizer ([`RasterPath::Compute`]).
    pub fn render(
        &self,
        ctx: &GpuContext,
        scene: &GpuScene,
        camera: &Camera,
        order: &[u32],
        shader: &GpuShader,
    ) -> Result<GpuFrame, GpuError> {
        self.render_with(ctx, scene, camera, GpuOrder::Given(order), shader, RasterPath::default())
    }

    /// The GPU centroid-depth order of every tet (sorted now unless cached
    /// for this scene and camera), read back: what [`GpuOrder::GpuCentroid`]
    /// draws.
    pub fn gpu_centroid_order(
        &self,
        ctx: &GpuContext,
        scene: &GpuScene,
        camera: &Camera,
    ) -> Result<Vec<u32>, GpuError> {
        let mut guard = self.ws.lock().unwrap_or_else(|e| e.into_inner());
        let ws = &mut *guard;
        self.sort_centroids(ctx, ws, scene, camera)?;
        let idx = ws.sorted.as_ref().map(|s| s.2).unwrap_or(0);
        let bytes = scene.num_tets() as u64 * 4;
        ws.readback.ensure(ctx, bytes, u64::MAX)?;
        let mut enc = ctx.device.create_command_encoder(&Default::default());
        enc.copy_buffer_to_buffer(ws.depth_vals[idx].get(), 0, ws.readback.get(), 0, bytes);
        ctx.queue.submit([enc.finish()]);
        let data = map_read_range(ctx, ws.readback.get(), bytes)?;
        Ok(bytemuck::cast_slice(&data).to_vec())
    }

    /// Sorts every tet by centroid depth on the GPU into `ws.depth_vals`
    /// unless the cached order is for this scene and camera; returns the
    /// number of buffers grown, or `None` when the cache was used.
    fn sort_centroids(
        &self,
        ctx: &GpuContext,
        ws: &mut Workspace,
        scene: &GpuScene,
        camera: &Camera,
    ) -> Result<Option<usize>, GpuError> {
        if ws.sorted.as_ref().is_some_and(|(id, spec, _)| *id == scene.id && spec == camera.spec()) {
            return Ok(None);
        }
        ws.sorted = None;
        let limit = ctx.device.limits().max_storage_buffer_binding_size;
        let n = scene.num_tets() as u32;
        let mut grown = crate::gpusort::ensure_pairs(ctx, &mut ws.depth_keys, &mut ws.depth_vals, n as u64 * 4, limit)?;
        let blocks = n.div_ceil(RADIX_BLOCK);
        grown += ws.hist.ensure(ctx, SortPipelines::hist_bytes(n), limit)? as usize;
        grown += ws.sums.ensure(ctx, SortPipelines::sums_bytes(16 * blocks), limit)? as usize;
        let eye = (camera.eye_in_world() - scene.centre_in_world).as_vec3();
        let fwd = camera.forward().as_vec3();
        let idx = ctx.checked(|| -> Result<usize, GpuError> {
            let mut enc = ctx.device.create_command_encoder(&Default::default());
            let prm = &mut ws.params;
            self.sort.encode_depth_keys(
                ctx,
                &mut enc,
                prm,
                [eye.x, eye.y, eye.z, 0.0],
                [fwd.x, fwd.y, fwd.z, 0.0],
                n,
                &scene.positions,
                &scene.tet_buf,
                ws.depth_keys[0].get(),
                ws.depth_vals[0].get(),
            )?;
            let keys = [ws.depth_keys[0].get(), ws.depth_keys[1].get()];
            let vals = [ws.depth_vals[0].get(), ws.depth_vals[1].get()];
            let idx = self.sort.encode_radix(ctx, &mut enc, prm, keys, vals, n, 32, ws.hist.get(), ws.sums.get())?;
            prm.flush(ctx);
            ctx.queue.submit([enc.finish()]);
            Ok(idx)
        })??;
        ctx.wait()?;
        ws.sorted = Some((scene.id, camera.spec().clone(), idx));
        Ok(Some(grown))
    }

    /// Renders with a chosen order and rasterizer. The order is drawn in
    /// chunks when its per-slot data (176 bytes a tet) exceeds one storage
    /// binding; buffers persist across calls and grow only when needed.
    pub fn render_with(
        &self,
        ctx: &GpuContext,
        scene: &GpuScene,
        camera: &Camera,
        order: GpuOrder<'_>,
        shader: &GpuShader,
        raster: RasterPath,
    ) -> Result<GpuFrame, GpuError> {
        self.render_frame(ctx, scene, camera, order, shader, &FrameOptions { raster, ..Default::default() })
    }

    /// [`GpuRenderer::render_with`] with options: with
    /// [`FrameOptions::cull`], the order's invisible tets are flagged,
    /// counted by a prefix sum and compacted out on the GPU before
    /// classification (`stats.tets_culled`, `stats.cull_seconds`).
    pub fn render_frame(
        &self,
        ctx: &GpuContext,
        scene: &GpuScene,
        camera: &Camera,
        order: GpuOrder<'_>,
        shader: &GpuShader,
        opts: &FrameOptions<'_>,
    ) -> Result<GpuFrame, GpuError> {
        let raster = opts.raster;
        let start = Instant::now();
        if let Some(c) = opts.cull {
            if c.scene_id != scene.id() {
                return Err(GpuError::Input("the GpuCull was built for another scene".into()));
            }
        }
        let lights = match opts.shading {
            Some(shading) => crate::light_params(shading, scene.centre_in_world)?,
            None => crate::light_params(&tet_render::Shading::default(), scene.centre_in_world)?,
        };
        let lit = lights.enabled != 0;
        if lit && scene.grads.is_none() {
            return Err(GpuError::Input(
                "lighting and silhouettes need per-vertex gradients: GpuScene::with_gradients".into(),
            ));
        }
        if shader.is_bivariate() && scene.gmags.is_none() {
            return Err(GpuError::Input(format!(
                "{} needs per-vertex gradient magnitudes: GpuScene::with_gradient_magnitudes",
                shader.method_id()
            )));
        }
        if let GpuOrder::Given(order) = order {
            if order.len() > scene.num_tets() {
                return Err(GpuError::Input(format!(
                    "order of {} tets for a scene of {}",
                    order.len(),
                    scene.num_tets()
                )));
            }
            if let Some(&t) = order.iter().find(|&&t| t as usize >= scene.num_tets()) {
                return Err(GpuError::Input(format!("order refers to tet {t}; the scene has {}", scene.num_tets())));
            }
        }
        let dev = &ctx.device;
        let lim = dev.limits();
        let limit = lim.max_storage_buffer_binding_size;
        let (w, h) = (camera.width(), camera.height());
        if w > lim.max_texture_dimension_2d || h > lim.max_texture_dimension_2d {
            return Err(GpuError::TooLarge {
                what: "image side (pixels)",
                bytes: w.max(h) as u64,
                limit: lim.max_texture_dimension_2d as u64,
            });
        }
        let mut guard = self.ws.lock().unwrap_or_else(|e| e.into_inner());
        let ws = &mut *guard;
        let mut stats = GpuRenderStats { raster_path: raster, ..Default::default() };
        let pixels_bytes = w as u64 * h as u64 * 16;
        if raster == RasterPath::Compute && pixels_bytes > limit {
            stats.raster_path = RasterPath::Graphics;
        }
        if raster == RasterPath::Compute && shader.method() == METHOD_BIV_EXACT && ctx.limits_loop_iterations() {
            // A tile's composite loop and every fragment's integration would
            // share llvmpipe's 65 535 loop iterations (see
            // GpuContext::limits_loop_iterations): its pixels would come out
            // wrong past ~10⁵ tets; each graphics fragment gets its own count.
            stats.raster_path = RasterPath::Graphics;
        }
        if raster == RasterPath::Compute && lit && ctx.limits_loop_iterations() && ws.max_pairs > LIT_LOOP_LIMITED_PAIRS
        {
            // Likewise for lit fragments (a split segment shades up to 32
            // pieces): passes of LIT_LOOP_LIMITED_PAIRS pairs stay within
            // the limit, more need not; the graphics rasterizer gives each
            // fragment its own count.
            stats.raster_path = RasterPath::Graphics;
        }
        if ws.hdr.as_ref().is_none_or(|t| t.width() != w || t.height() != h) {
            ws.hdr = None;
            ws.hdr = Some(ctx.checked(|| {
                dev.create_texture(&wgpu::TextureDescriptor {
                    label: Some("hdr"),
                    size: wgpu::Extent3d { width: w, height: h, depth_or_array_layers: 1 },
                    mip_level_count: 1,
                    sample_count: 1,
                    dimension: wgpu::TextureDimension::D2,
                    format: HDR_FORMAT,
                    usage: wgpu::TextureUsages::RENDER_ATTACHMENT
                        | wgpu::TextureUsages::COPY_SRC
                        | wgpu::TextureUsages::TEXTURE_BINDING
                        | wgpu::TextureUsages::STORAGE_BINDING,
                    view_formats: &[],
                })
            })?);
            stats.buffers_grown += 1;
        }
        let hdr = ws.hdr.clone().expect("set above");
        let hdr_view = hdr.create_view(&Default::default());

        // The order.
        let n = match order {
            GpuOrder::Given(o) => {
                let t = Instant::now();
                if !o.is_empty() {
                    stats.buffers_grown += ws.order.ensure(ctx, o.len() as u64 * 4, lim.max_buffer_size)? as usize;
                    ctx.queue.write_buffer(ws.order.get(), 0, bytemuck::cast_slice(o));
                    ctx.queue.submit([]);
                    ctx.wait()?;
                }
                stats.upload_seconds = t.elapsed().as_secs_f64();
                o.len()
            }
            GpuOrder::GpuCentroid => {
                let t = Instant::now();
                if let Some(g) = self.sort_centroids(ctx, ws, scene, camera)? {
                    stats.buffers_grown += g;
                    stats.sorted_on_gpu = true;
                }
                stats.sort_seconds = t.elapsed().as_secs_f64();
                scene.num_tets()
            }
        };
        // (An empty given order uploads nothing; bind something.)
        stats.buffers_grown += ws.order.ensure(ctx, 16, lim.max_buffer_size)? as usize;
        let source_order = match order {
            GpuOrder::Given(_) => ws.order.get().clone(),
            GpuOrder::GpuCentroid => ws.depth_vals[ws.sorted.as_ref().map(|s| s.2).unwrap_or(0)].get().clone(),
        };
        // Culling: flag, scan and compact the order; the visible count comes back.
        let mut compacted: Option<wgpu::Buffer> = None;
        let n = match opts.cull {
            Some(cull) if n > 0 && !cull.culls_nothing() => {
                let t = Instant::now();
                let bytes = n as u64 * 4;
                stats.buffers_grown += ws.cull_flags.ensure(ctx, bytes, limit)? as usize;
                stats.buffers_grown += ws.cull_order.ensure(ctx, bytes, limit)? as usize;
                stats.buffers_grown += ws.sums.ensure(ctx, SortPipelines::sums_bytes(n as u32), limit)? as usize;
                stats.buffers_grown += ws.readback.ensure(ctx, 256, u64::MAX)? as usize;
                let blocks = (n as u32).div_ceil(SCAN_BLOCK).max(1);
                ctx.checked(|| -> Result<(), GpuError> {
                    let mut enc = dev.create_command_encoder(&Default::default());
                    let bufs = CullBuffers {
                        order_in: &source_order,
                        flags: ws.cull_flags.get(),
                        order_out: ws.cull_order.get(),
                        sums: ws.sums.get(),
                    };
                    self.cull.encode(ctx, &mut enc, &mut ws.params, &self.sort, scene, cull, n as u32, &bufs)?;
                    enc.copy_buffer_to_buffer(ws.sums.get(), blocks as u64 * 4, ws.readback.get(), 0, 4);
                    ws.params.flush(ctx);
                    ctx.queue.submit([enc.finish()]);
                    Ok(())
                })??;
                let visible =
                    u32::from_le_bytes(map_read_range(ctx, ws.readback.get(), 4)?[..4].try_into().expect("4 bytes"));
                let visible = (visible as usize).min(n);
                stats.tets_culled = n - visible;
                stats.cull_seconds = t.elapsed().as_secs_f64();
                compacted = Some(ws.cull_order.get().clone());
                visible
            }
            _ => n,
        };
        stats.tets_drawn = n;

        // Chunks: slot offsets into the order must meet the binding offset
        // alignment, so chunks are multiples of 256 slots (1 KiB).
        let per_slot = (std::mem::size_of::<TetShade>() as u64).max(std::mem::size_of::<TetGeom>() as u64);
        let cap = ((limit / per_slot) as usize / 256 * 256)
            .min(u32::MAX as usize / VERTS_PER_SLOT as usize / 256 * 256)
            .min(ws.max_chunk_slots);
        if cap == 0 {
            return Err(GpuError::TooLarge { what: "one chunk of per-tet data", bytes: per_slot * 256, limit });
        }
        let chunk = cap.min(n.max(1));
        stats.buffers_grown += ws.geoms.ensure(ctx, chunk as u64 * 64, limit)? as usize;
        stats.buffers_grown += ws.shades.ensure(ctx, chunk as u64 * 112, limit)? as usize;
        let bivariate = shader.is_bivariate();
        stats.buffers_grown += ws.gshades.ensure(ctx, if bivariate { chunk as u64 * 32 } else { 16 }, limit)? as usize;
        let normal_bytes = if lit { chunk as u64 * NORMAL_ROWS as u64 * 16 } else { 16 };
        stats.buffers_grown += ws.nshades.ensure(ctx, normal_bytes, limit)? as usize;
        ctx.queue.write_buffer(&ws.lights, 0, bytemuck::bytes_of(&lights));
        let none = crate::ShadowMaps::none();
        let shadows = match (opts.shadows, opts.shading.is_some_and(|s| s.wants_shadows())) {
            (Some(m), true) => m,
            (None, true) => {
                return Err(GpuError::Input("the shading wants shadows: FrameOptions::shadows (ShadowMaps)".into()))
            }
            (_, false) => &none,
        };
        // Uploaded once per shadow field, not per frame (a cube's knots
        // are tens of MB).
        if ws.shadows_uploaded != Some(shadows.id) {
            ws.shadows_uploaded = None;
            let (knot_bytes, index_bytes) = (shadows.knots.len() as u64 * 8, shadows.index.len() as u64 * 4);
            stats.buffers_grown += ws.shadow_knots.ensure(ctx, knot_bytes, limit)? as usize;
            stats.buffers_grown += ws.shadow_index.ensure(ctx, index_bytes, limit)? as usize;
            ctx.queue.write_buffer(&ws.shadow_maps, 0, bytemuck::cast_slice(&shadows.maps));
            ctx.queue.write_buffer(ws.shadow_knots.get(), 0, bytemuck::cast_slice(&shadows.knots));
            ctx.queue.write_buffer(ws.shadow_index.get(), 0, bytemuck::cast_slice(&shadows.index));
            ws.shadows_uploaded = Some(shadows.id);
        }
        let compute = stats.raster_path == RasterPath::Compute && n > 0;
        let (tiles_x, tiles_y) = (w.div_ceil(TILE_PX), h.div_ceil(TILE_PX));
        if compute {
            for (g, bytes) in [
                (&mut ws.accum, pixels_bytes),
                (&mut ws.ranges, tiles_x as u64 * tiles_y as u64 * 8),
                (&mut ws.counts, chunk as u64 * 4),
            ] {
                stats.buffers_grown += g.ensure(ctx, bytes, limit)? as usize;
            }
            stats.buffers_grown += ws.sums.ensure(ctx, SortPipelines::sums_bytes(chunk as u32), limit)? as usize;
            stats.buffers_grown += crate::gpusort::ensure_pairs(ctx, &mut ws.pair_keys, &mut ws.pair_vals, 16, limit)?;
            stats.buffers_grown += ws.hist.ensure(ctx, 16, limit)? as usize;
            stats.buffers_grown += ws.readback.ensure(ctx, 256, u64::MAX)? as usize;
        }
        let table_view = shader.table.create_view(&Default::default());
        let shade_pass =
            if stats.raster_path == RasterPath::Compute { ShadePass::Composite } else { ShadePass::Raster };
        let pipeline = self.shade_pipeline(ctx, shader.method(), shade_pass)?;
        let (table2d_view, alpha_view) = shader.views_2d();

        if n == 0 {
            // Nothing to draw: a cleared image.
            let mut enc = dev.create_command_encoder(&Default::default());
            enc.begin_render_pass(&wgpu::RenderPassDescriptor {
                label: Some("clear"),
                color_attachments: &[Some(wgpu::RenderPassColorAttachment {
                    view: &hdr_view,
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
            ctx.queue.submit([enc.finish()]);
        }

        let order_buf = compacted.unwrap_or(source_order);
        let mut s0 = 0;
        while s0 < n {
            let m = chunk.min(n - s0);
            let first = s0 == 0;
            stats.chunks += 1;
            let (gx, gy) = split_groups((m as u32).div_ceil(CLASSIFY_WG));
            let uniforms = frame_uniforms(camera, scene.centre_in_world, m as u32, shader, gx);

            let t = Instant::now();
            ctx.checked(|| -> Result<(), GpuError> {
                let fo = ws.params.push(&uniforms)?;
                let bg = bind_group(
                    dev,
                    "classify",
                    &self.classify_module.layout,
                    &[
                        wgpu::BindGroupEntry { binding: 0, resource: ws.params.binding(FRAME_SIZE) },
                        bind(1, &scene.positions),
                        bind(2, &scene.tet_buf),
                        bind(3, &scene.scalars),
                        wgpu::BindGroupEntry {
                            binding: 4,
                            resource: wgpu::BindingResource::Buffer(wgpu::BufferBinding {
                                buffer: &order_buf,
                                offset: s0 as u64 * 4,
                                size: std::num::NonZeroU64::new(m as u64 * 4),
                            }),
                        },
                        bind(5, ws.geoms.get()),
                        bind(6, ws.shades.get()),
                        bind(7, &shader.tf_nodes),
                        bind(17, scene.gmags.as_ref().unwrap_or(&scene.scalars)),
                        bind(18, ws.gshades.get()),
                        bind(19, &ws.lights),
                        bind(20, scene.grads.as_ref().unwrap_or(&scene.positions)),
                        bind(21, ws.nshades.get()),
                        bind(22, &ws.shadow_maps),
                        bind(23, ws.shadow_knots.get()),
                        bind(24, ws.shadow_index.get()),
                    ],
                );
                let mut enc = dev.create_command_encoder(&Default::default());
                dispatch(&mut enc, "classify", &self.classify, &bg, &[fo], (gx, gy));
                ws.params.flush(ctx);
                ctx.queue.submit([enc.finish()]);
                Ok(())
            })??;
            ctx.wait()?;
            stats.classify_seconds += t.elapsed().as_secs_f64();

            if compute {
                let env = BinEnv {
                    uniforms: &uniforms,
                    hdr_view: &hdr_view,
                    table_view: &table_view,
                    table2d_view: &table2d_view,
                    alpha_view: &alpha_view,
                    shader,
                    pipeline: &pipeline,
                    tiles: [tiles_x, tiles_y],
                    m: m as u32,
                    first,
                    pixels_bytes,
                    limit,
                };
                self.raster_compute(ctx, ws, &env, &mut stats)?;
            } else {
                let t = Instant::now();
                ctx.checked(|| -> Result<(), GpuError> {
                    let fo = ws.params.push(&uniforms)?;
                    let mut entries =
                        vec![wgpu::BindGroupEntry { binding: 0, resource: ws.params.binding(FRAME_SIZE) }];
                    entries.extend(bind_all(5, &[ws.geoms.get(), ws.shades.get(), &shader.tf_nodes]));
                    entries.extend([
                        bind_view(8, &table_view),
                        bind_view(14, &table2d_view),
                        bind_view(15, &alpha_view),
                    ]);
                    entries.extend([bind(16, &shader.shade_buf), bind(18, ws.gshades.get())]);
                    entries.extend([bind(19, &ws.lights), bind(21, ws.nshades.get())]);
                    entries.extend(shadow_bindings(ws));
                    let bg = bind_group(dev, "raster", &self.raster.layout, &entries);
                    let mut enc = dev.create_command_encoder(&Default::default());
                    {
                        let load =
                            if first { wgpu::LoadOp::Clear(wgpu::Color::TRANSPARENT) } else { wgpu::LoadOp::Load };
                        let mut pass = enc.begin_render_pass(&wgpu::RenderPassDescriptor {
                            label: Some("raster"),
                            color_attachments: &[Some(wgpu::RenderPassColorAttachment {
                                view: &hdr_view,
                                depth_slice: None,
                                resolve_target: None,
                                ops: wgpu::Operations { load, store: wgpu::StoreOp::Store },
                            })],
                            depth_stencil_attachment: None,
                            timestamp_writes: None,
                            occlusion_query_set: None,
                            multiview_mask: None,
                        });
                        if let ShadePipeline::Raster(p) = &pipeline {
                            pass.set_pipeline(p);
                        }
                        pass.set_bind_group(0, &bg, &[fo]);
                        pass.draw(0..m as u32 * VERTS_PER_SLOT, 0..1);
                    }
                    ws.params.flush(ctx);
                    ctx.queue.submit([enc.finish()]);
                    Ok(())
                })??;
                ctx.wait()?;
                stats.raster_seconds += t.elapsed().as_secs_f64();
            }
            s0 += m;
        }

        let t = Instant::now();
        let image = read_texture(ctx, &hdr)?;
        stats.readback_seconds = t.elapsed().as_secs_f64();
        stats.total_seconds = start.elapsed().as_secs_f64();
        Ok(GpuFrame { image, stats, hdr })
    }

    /// The compute rasterizer for one classified chunk: count tiles per
    /// slot, scan, read the pair total back, then fill, sort by tile and
    /// composite — in several passes over slot ranges when the pairs exceed
    /// one storage binding.
    fn raster_compute(
        &self,
        ctx: &GpuContext,
        ws: &mut Workspace,
        env: &BinEnv<'_>,
        stats: &mut GpuRenderStats,
    ) -> Result<(), GpuError> {
        let dev = &ctx.device;
        let m = env.m;
        let [tiles_x, tiles_y] = env.tiles;
        let n_tiles = tiles_x as u64 * tiles_y as u64;
        let bin_params = |lo: u32, hi: u32, base: u32, n_pairs: u32, items: u32| BinParams {
            tiles_x,
            tiles_y,
            n_slots: m,
            groups_x: split_groups(items.div_ceil(BIN_WG)).0,
            slot_lo: lo,
            slot_hi: hi,
            pair_base: base,
            n_pairs,
        };
        let groups = |items: u32| split_groups(items.div_ceil(BIN_WG));

        // Counts and their prefix sum; the total comes back to size the pairs.
        let t = Instant::now();
        let blocks = m.div_ceil(SCAN_BLOCK).max(1);
        ctx.checked(|| -> Result<(), GpuError> {
            let mut enc = dev.create_command_encoder(&Default::default());
            if env.first {
                enc.clear_buffer(ws.accum.get(), 0, Some(env.pixels_bytes));
            }
            let fo = ws.params.push(env.uniforms)?;
            let bo = ws.params.push(&bin_params(0, m, 0, 0, m))?;
            let bg = self.bin_group(ctx, ws, env, 0)?;
            dispatch(&mut enc, "bin_count", &self.bin.count, &bg, &[fo, bo], groups(m));
            self.sort.encode_scan(ctx, &mut enc, &mut ws.params, ws.counts.get(), m, ws.sums.get())?;
            enc.copy_buffer_to_buffer(ws.sums.get(), blocks as u64 * 4, ws.readback.get(), 0, 4);
            ws.params.flush(ctx);
            ctx.queue.submit([enc.finish()]);
            Ok(())
        })??;
        let total = u32::from_le_bytes(map_read_range(ctx, ws.readback.get(), 4)?[..4].try_into().expect("4 bytes"));
        stats.pairs += total as u64;

        // Slot ranges whose pairs fit one binding (usually one range).
        // On llvmpipe every loop of one invocation shares 65 535 iterations
        // (`GpuContext::limits_loop_iterations`): a pixel's composite loop
        // runs over its tile's whole list in a pass, so passes there hold at
        // most LOOP_LIMITED_PAIRS pairs (dense tiles of Blunt Fin at 128²
        // otherwise lost fragments: RMSE 4.8e-2 against the CPU).
        let loop_cap = if ctx.limits_loop_iterations() { LOOP_LIMITED_PAIRS } else { u32::MAX };
        let pair_cap = ((env.limit / 4).min(u32::MAX as u64) as u32).min(ws.max_pairs).min(loop_cap);
        let mut passes: Vec<(u32, u32, u32, u32)> = Vec::new();
        if total <= pair_cap {
            passes.push((0, m, 0, total));
        } else {
            stats.buffers_grown += ws.readback.ensure(ctx, m as u64 * 4, u64::MAX)? as usize;
            let mut enc = dev.create_command_encoder(&Default::default());
            enc.copy_buffer_to_buffer(ws.counts.get(), 0, ws.readback.get(), 0, m as u64 * 4);
            ctx.queue.submit([enc.finish()]);
            let bytes = map_read_range(ctx, ws.readback.get(), m as u64 * 4)?;
            let mut offsets: Vec<u32> = bytemuck::cast_slice(&bytes).to_vec();
            offsets.push(total);
            let mut lo = 0usize;
            while lo < m as usize {
                let base = offsets[lo];
                let hi = lo + offsets[lo + 1..].partition_point(|&o| o - base <= pair_cap);
                if hi == lo {
                    return Err(GpuError::TooLarge {
                        what: "tile pairs of one tet",
                        bytes: (offsets[lo + 1] - base) as u64 * 4,
                        limit: env.limit,
                    });
                }
                passes.push((lo as u32, hi as u32, base, offsets[hi] - base));
                lo = hi;
            }
        }
        stats.bin_seconds += t.elapsed().as_secs_f64();

        let bits = 64 - (n_tiles.max(2) - 1).leading_zeros();
        for (lo, hi, base, n_pairs) in passes {
            let t = Instant::now();
            let blocks = n_pairs.div_ceil(RADIX_BLOCK).max(1);
            stats.buffers_grown +=
                crate::gpusort::ensure_pairs(ctx, &mut ws.pair_keys, &mut ws.pair_vals, n_pairs as u64 * 4, env.limit)?;
            stats.buffers_grown += ws.hist.ensure(ctx, SortPipelines::hist_bytes(n_pairs), env.limit)? as usize;
            stats.buffers_grown += ws.sums.ensure(ctx, SortPipelines::sums_bytes(16 * blocks), env.limit)? as usize;
            let sorted = ctx.checked(|| -> Result<usize, GpuError> {
                let mut enc = dev.create_command_encoder(&Default::default());
                enc.clear_buffer(ws.ranges.get(), 0, Some(n_tiles * 8));
                let mut sorted = 0;
                if n_pairs > 0 {
                    let fo = ws.params.push(env.uniforms)?;
                    let bo = ws.params.push(&bin_params(lo, hi, base, n_pairs, hi - lo))?;
                    let bg = self.bin_group(ctx, ws, env, 0)?;
                    dispatch(&mut enc, "bin_fill", &self.bin.fill, &bg, &[fo, bo], groups(hi - lo));
                    let keys = [ws.pair_keys[0].get(), ws.pair_keys[1].get()];
                    let vals = [ws.pair_vals[0].get(), ws.pair_vals[1].get()];
                    sorted = self.sort.encode_radix(
                        ctx,
                        &mut enc,
                        &mut ws.params,
                        keys,
                        vals,
                        n_pairs,
                        bits,
                        ws.hist.get(),
                        ws.sums.get(),
                    )?;
                    let bo = ws.params.push(&bin_params(lo, hi, base, n_pairs, n_pairs))?;
                    let bg = self.bin_group(ctx, ws, env, sorted)?;
                    dispatch(&mut enc, "tile_ranges", &self.bin.ranges, &bg, &[fo, bo], groups(n_pairs));
                }
                ws.params.flush(ctx);
                ctx.queue.submit([enc.finish()]);
                Ok(sorted)
            })??;
            ctx.wait()?;
            stats.bin_seconds += t.elapsed().as_secs_f64();

            let t = Instant::now();
            ctx.checked(|| -> Result<(), GpuError> {
                let fo = ws.params.push(env.uniforms)?;
                let bo = ws.params.push(&bin_params(lo, hi, base, n_pairs, 0))?;
                let bg = self.bin_group(ctx, ws, env, sorted)?;
                let mut enc = dev.create_command_encoder(&Default::default());
                {
                    let mut pass = enc.begin_compute_pass(&Default::default());
                    if let ShadePipeline::Composite(p) = env.pipeline {
                        pass.set_pipeline(p);
                    }
                    pass.set_bind_group(0, &bg, &[fo, bo]);
                    pass.dispatch_workgroups(tiles_x, tiles_y, 1);
                }
                ws.params.flush(ctx);
                ctx.queue.submit([enc.finish()]);
                Ok(())
            })??;
            ctx.wait()?;
            stats.raster_seconds += t.elapsed().as_secs_f64();
        }
        Ok(())
    }

    /// The bin.wgsl bind group with pair buffers `pairs` (0 or 1).
    fn bin_group(
        &self,
        ctx: &GpuContext,
        ws: &Workspace,
        env: &BinEnv<'_>,
        pairs: usize,
    ) -> Result<wgpu::BindGroup, GpuError> {
        let mut entries = vec![
            wgpu::BindGroupEntry { binding: 0, resource: ws.params.binding(FRAME_SIZE) },
            wgpu::BindGroupEntry { binding: 1, resource: ws.params.binding(BIN_PARAMS_SIZE) },
        ];
        let (keys, vals) = (ws.pair_keys[pairs].get(), ws.pair_vals[pairs].get());
        entries
            .extend(bind_all(2, &[ws.geoms.get(), ws.counts.get(), keys, vals, ws.shades.get(), &env.shader.tf_nodes]));
        entries.push(bind_view(8, env.table_view));
        entries.extend(bind_all(9, &[ws.ranges.get(), ws.accum.get()]));
        entries.extend([bind_view(11, env.hdr_view), bind_view(14, env.table2d_view), bind_view(15, env.alpha_view)]);
        entries.extend([bind(16, &env.shader.shade_buf), bind(18, ws.gshades.get())]);
        entries.extend([bind(19, &ws.lights), bind(21, ws.nshades.get())]);
        entries.extend(shadow_bindings(ws));
        Ok(bind_group(&ctx.device, "bin", &self.bin.bound.layout, &entries))
    }
}

/// What the compute rasterizer needs of the frame and chunk.
struct BinEnv<'a> {
    uniforms: &'a FrameUniforms,
    hdr_view: &'a wgpu::TextureView,
    table_view: &'a wgpu::TextureView,
    table2d_view: &'a wgpu::TextureView,
    alpha_view: &'a wgpu::TextureView,
    shader: &'a GpuShader,
    pipeline: &'a ShadePipeline,
    tiles: [u32; 2],
    /// Slots in the chunk.
    m: u32,
    /// First chunk: clears the accumulated colour.
    first: bool,
    pixels_bytes: u64,
    limit: u64,
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
        groups_x,
        ..shader.frame_fields()
    }
}
