//! Per-cell culling on the GPU with tet_render's [`TfCuller`] semantics (a
//! cell whose scalar range maps to zero opacity is not drawn), and stream
//! compaction of the visibility order (shaders/cull.wgsl): culled tets are
//! neither classified nor rasterized.
//!
//! [`GpuCull`] is built once per transfer function (a TF change) from the
//! culler's invisible intervals; every frame that uses it flags each slot of
//! the order, prefix-sums the flags and scatters the visible tets into a
//! compacted order, keeping their visibility order. The comparison runs on
//! the ranks of the scene's distinct vertex scalars ([`GpuScene`] uploads
//! them), so the decision is the CPU culler's f64 decision exactly.

use crate::gpu_types::{CullParams, CULL_WG};
use crate::render::{
    bind_all, bind_group, buffer_init, dispatch, shader_module, storage_entries, uniform_dyn_entry, BoundModule,
    GpuScene,
};
use crate::workspace::{split_groups, Params};
use crate::{shader_source_plain, GpuContext, GpuError, CULL_WGSL};
use tet_preint::TransferFunction;
use tet_render::TfCuller;

/// The invisible scalar intervals of one transfer function for one scene,
/// on the GPU: pass it in [`crate::FrameOptions::cull`].
pub struct GpuCull {
    pub(crate) scene_id: u64,
    pub(crate) intervals: wgpu::Buffer,
    pub(crate) n_intervals: u32,
    widgets: wgpu::Buffer,
    n_widgets: u32,
    use_g: bool,
    zero: Vec<[f64; 2]>,
}

impl GpuCull {
    /// The culling of `tf` (x in data units, as the renderer's) for `scene`:
    /// [`TfCuller::new`]'s invisible intervals, mapped onto the ranks of
    /// the scene's distinct scalars; with 2D widgets, the supports of the
    /// widgets that can show (opacity > 0, or colour > 0 under independent
    /// emission), mapped onto scalar and — where the scene has them
    /// ([`GpuScene::with_gradient_magnitudes`]) — |∇s| ranks, as
    /// `TransferFunction::cell_is_invisible` tests them (without gradient
    /// magnitudes any |∇s| ≥ 0 is possible, as on the CPU).
    pub fn new(ctx: &GpuContext, scene: &GpuScene, tf: &TransferFunction) -> Result<GpuCull, GpuError> {
        let zero = TfCuller::new(tf).zero_intervals().to_vec();
        let distinct = scene.distinct_scalars();
        // [lo, hi] → [first rank with value ≥ lo, first rank with value > hi).
        let to_ranks = |v: &[f64], lo: f64, hi: f64| {
            [v.partition_point(|&s| s < lo) as u32, v.partition_point(|&s| s <= hi) as u32]
        };
        let mut rows: Vec<[u32; 2]> =
            zero.iter().map(|&[lo, hi]| to_ranks(distinct, lo, hi)).filter(|r| r[0] < r[1]).collect();
        let independent = tf.emission() == tet_preint::Emission::Independent;
        let g_distinct = scene.distinct_gradient_magnitudes();
        let use_g = g_distinct.is_some();
        let mut rects: Vec<[u32; 4]> = tf
            .widgets()
            .iter()
            .filter(|w| w.opacity > 0.0 || (independent && w.color.iter().any(|&c| c > 0.0)))
            .filter_map(|w| {
                let [[s0, s1], [g0, g1]] = w.support;
                let s = to_ranks(distinct, s0, s1);
                match g_distinct {
                    Some(g) => {
                        let g = to_ranks(g, g0, g1);
                        Some([s[0], s[1], g[0], g[1]])
                    }
                    // |∇s| ∈ [0, ∞) meets [g0, g1] unless g1 < 0.
                    None => (g1 >= 0.0).then_some([s[0], s[1], 0, 0]),
                }
            })
            .collect();
        let n_widgets = rects.len() as u32;
        if rects.is_empty() {
            rects.push([0; 4]);
        }
        let n_intervals = rows.len() as u32;
        if rows.is_empty() {
            rows.push([0, 0]);
        }
        let init =
            |label: &str, contents: &[u8]| buffer_init(&ctx.device, label, contents, wgpu::BufferUsages::STORAGE);
        let (intervals, widgets) = ctx.checked(|| {
            (init("cull intervals", bytemuck::cast_slice(&rows)), init("cull widgets", bytemuck::cast_slice(&rects)))
        })?;
        Ok(GpuCull { scene_id: scene.id(), intervals, n_intervals, widgets, n_widgets, use_g, zero })
    }

    /// The transfer function's invisible intervals (data units, ±∞ at the
    /// clamped ends), as [`TfCuller::zero_intervals`].
    pub fn zero_intervals(&self) -> &[[f64; 2]] {
        &self.zero
    }

    /// Whether no cell of the scene can be culled (no vertex scalar falls in
    /// an invisible interval): compaction is then skipped.
    pub fn culls_nothing(&self) -> bool {
        self.n_intervals == 0
    }
}

pub(crate) struct CullPipelines {
    bound: BoundModule,
    flags: wgpu::ComputePipeline,
    scatter: wgpu::ComputePipeline,
}

const CULL_PARAMS_SIZE: u64 = std::mem::size_of::<CullParams>() as u64;

/// The buffers one compaction reads and writes.
pub(crate) struct CullBuffers<'a> {
    pub order_in: &'a wgpu::Buffer,
    pub flags: &'a wgpu::Buffer,
    pub order_out: &'a wgpu::Buffer,
    pub sums: &'a wgpu::Buffer,
}

impl CullPipelines {
    pub(crate) fn new(ctx: &GpuContext) -> CullPipelines {
        let dev = &ctx.device;
        let cs = wgpu::ShaderStages::COMPUTE;
        let module = shader_module(dev, "cull.wgsl", shader_source_plain(CULL_WGSL));
        let mut entries = vec![uniform_dyn_entry(0, cs)];
        // Tets, ranks, intervals and the order in are read; flags and the
        // order out written; |∇s| ranks and widgets read.
        entries.extend(storage_entries(1, cs, &[true, true, true, true, false, false, true, true]));
        let bound = BoundModule::new(dev, "cull", &entries, module);
        CullPipelines {
            flags: bound.compute(dev, "cull_flags", &[]),
            scatter: bound.compute(dev, "cull_scatter", &[]),
            bound,
        }
    }

    /// Encodes flags, their prefix sum and the scatter of `n` slots; the
    /// visible count lands in `sums[⌈n / 1024⌉]` (the scan's total).
    #[allow(clippy::too_many_arguments)]
    pub(crate) fn encode(
        &self,
        ctx: &GpuContext,
        enc: &mut wgpu::CommandEncoder,
        prm: &mut Params,
        sort: &crate::gpusort::SortPipelines,
        scene: &GpuScene,
        cull: &GpuCull,
        n: u32,
        bufs: &CullBuffers<'_>,
    ) -> Result<(), GpuError> {
        let (gx, gy) = split_groups(n.div_ceil(CULL_WG));
        let o = prm.push(&CullParams {
            n,
            n_intervals: cull.n_intervals,
            groups_x: gx,
            n_widgets: cull.n_widgets,
            use_g: cull.use_g as u32,
            _pad0: 0,
            _pad1: 0,
            _pad2: 0,
        })?;
        let mut entries = vec![wgpu::BindGroupEntry { binding: 0, resource: prm.binding(CULL_PARAMS_SIZE) }];
        entries.extend(bind_all(
            1,
            &[scene.tet_buf(), scene.ranks(), &cull.intervals, bufs.order_in, bufs.flags, bufs.order_out],
        ));
        entries.extend(bind_all(7, &[scene.g_ranks(), &cull.widgets]));
        let bg = bind_group(&ctx.device, "cull", &self.bound.layout, &entries);
        dispatch(enc, "cull_flags", &self.flags, &bg, &[o], (gx, gy));
        sort.encode_scan(ctx, enc, prm, bufs.flags, n, bufs.sums)?;
        dispatch(enc, "cull_scatter", &self.scatter, &bg, &[o], (gx, gy));
        Ok(())
    }
}
