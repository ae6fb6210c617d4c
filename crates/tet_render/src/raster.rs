//! Tile-parallel compositing of projected tets.
//!
//! The visibility order is split into chunks; each chunk bins its tets (by
//! pixel bounding box) into screen tiles, keeping the order. Each tile is
//! then rendered by one thread, walking the chunks' lists in order and
//! compositing front to back in f32 ("under": C += (1−α_acc)·c,
//! α_acc += (1−α_acc)·α), skipping pixels whose α has reached
//! [`RasterOptions::opaque_alpha`] and leaving the tile once all its pixels
//! have. A pixel's result depends only on the order, never on which thread
//! ran which tile: the image is bit-identical for any thread count.
//!
//! Per tet and tile, a setup is built in place (f64 silhouette and thick
//! point, f32 planes and fields relative to the tet); each row's covered
//! pixels come from the exact edge tests as one span, the span's segments are
//! evaluated 8 pixels at a time, and the tet's fragments go to the shader in
//! batches through [`SegmentShader::shade_span`] before compositing.

use crate::image::Image;
use crate::project::{
    prepare_span, tet_bbox, Cover, Fragment, Lanes, Prepared, SetupInputs, SpanEval, TetSetup, ViewGeometry, LANES,
    MASK_SIDE,
};
use crate::scene::Scene;
use crate::shading::Shading;
use rayon::prelude::*;
use std::sync::atomic::{AtomicU64, AtomicUsize, Ordering};
use tet_preint::{Rgba32, Segment, SegmentBatch, SegmentShader, BATCH};

/// Rasterizer settings.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct RasterOptions {
    /// Tile side in pixels. 16 (the default) keeps a tile's accumulators
    /// (4 KiB) and the table entries its tets share in the L1 cache; on the
    /// 1.2M-tet grid at 512² it measured ~10% faster than 32.
    pub tile: u32,
    /// A pixel at or above this accumulated α takes no more fragments
    /// (what it misses is at most 1 − opaque_alpha of the remaining colour).
    pub opaque_alpha: f32,
    pub shading: Shading,
    /// Per-fragment methods without lighting: set each tet up once (not
    /// once per tile it touches), in chunks of the order, and draw it from
    /// that record ([`crate::project::prepare_span`]). The images are
    /// bit-identical to the per-tile path's (`false`), which remains for
    /// tests and comparisons.
    pub fast_path: bool,
    /// Most bytes [`rasterize_cached`] keeps of a view's setup across
    /// frames (about 290 bytes a tet: 337 MiB for the 1.2M-tet grid):
    /// 512 MiB covers ~1.8M tets; larger meshes set up every frame. 0 keeps
    /// nothing.
    pub setup_cache_bytes: usize,
    /// The walker: rays a tile walks at once, one step each in turn (each
    /// walk is a chain of dependent loads, and independent chains let the
    /// core overlap their cache misses). `None`: [`crate::walk::WALK_LANES`]
    /// (8 rays cut the camera-moving frame by 8–18% on every bundle
    /// measured against one ray at a time, on a host where that had once
    /// been slower; `crates/tetview/results/walker.md`).
    /// The image is the same for any count (1 to 64).
    pub walk_interleave: Option<usize>,
    /// The walker: request the records of the tets a ray may step into
    /// next while the current step is computed (`walk::prefetch`). Meshes
    /// far larger than the caches gain most; the image is the same either way.
    pub walk_prefetch: bool,
    /// The walker: eight rays a step in the lanes of AVX2 vectors (x86-64
    /// CPUs that have it, detected at run time), `walk_interleave` then
    /// unused (adaptive sampling too: each level's rays in one list).
    /// Frames with lighting or a bivariate method take the scalar walk.
    /// The
    /// image is the same bit for bit either way; crossings and runs may
    /// differ slightly (a ray's opacity is noticed at its packet's next
    /// shading).
    pub walk_packets: bool,
    /// The walker: image-space adaptive sampling, an approximation for
    /// interaction (`None`, the default: every covered pixel walks its
    /// ray). `Some(tol)`: each tile walks the rays of a 4-pixel lattice
    /// first; a block whose pixels all meet the mesh through the same
    /// number of entries and whose walked corners differ by at most `tol`
    /// in every premultiplied channel is filled bilinearly, any other block
    /// is halved and its children's corners walked, level by level, down to
    /// single pixels. Silhouettes and
    /// re-entries are walked exactly (coverage comes from the rasterized
    /// entries), but a feature narrower than a block that none of its
    /// corners meets is missed: the error is not bounded, only measured
    /// (`crates/tetview/results/walker.md`).
    pub walk_adaptive: Option<f32>,
}

impl Default for RasterOptions {
    fn default() -> Self {
        RasterOptions {
            tile: 16,
            opaque_alpha: 0.9999,
            shading: Shading::default(),
            fast_path: true,
            setup_cache_bytes: 512 << 20,
            walk_interleave: None,
            walk_prefetch: true,
            walk_packets: true,
            walk_adaptive: None,
        }
    }
}

/// Counters from one rasterization.
#[derive(Debug, Clone, Copy, Default, PartialEq, serde::Serialize)]
pub struct RasterStats {
    /// Fragments shaded and composited.
    pub fragments: u64,
    /// Tet setups: once per tet on the fast path (0 from a kept setup), once
    /// per tile a tet spans on the per-tile path and for clipped tets.
    pub setups: u64,
    /// Tiles left early because every pixel was opaque.
    pub tiles_terminated: usize,
    /// The fast path's per-tet setup was taken from the cache (none redone).
    pub reused_setup: bool,
    pub bin_seconds: f64,
    pub raster_seconds: f64,
}

/// Renders the tets of `order` (front to back) into a linear premultiplied
/// RGBA image. `progress(done, total)` is called as tiles finish, from
/// worker threads.
pub fn rasterize(
    scene: &Scene,
    view: &ViewGeometry,
    order: &[u32],
    shader: &dyn SegmentShader,
    opts: &RasterOptions,
    progress: &(dyn Fn(usize, usize) + Sync),
) -> (Image, RasterStats) {
    let frame = &view.frame;
    if fast_path_applies(view, shader, opts) {
        return rasterize_chunked(scene, view, order, None, shader, opts, None, false, progress);
    }
    let (w, h) = (frame.width, frame.height);
    let tile = opts.tile.clamp(4, 1024);
    let (tx, ty) = (w.div_ceil(tile) as usize, h.div_ceil(tile) as usize);
    let n_tiles = tx * ty;

    let t0 = std::time::Instant::now();
    let n_chunks = (rayon::current_num_threads() * 4).min(order.len() / 2048 + 1).max(1);
    let chunk_len = order.len().div_ceil(n_chunks).max(1);
    let bins: Vec<Vec<Vec<u32>>> = order
        .par_chunks(chunk_len)
        .map(|chunk| {
            let mut b: Vec<Vec<u32>> = vec![Vec::new(); n_tiles];
            for &t in chunk {
                if let Some([x0, y0, x1, y1]) = tet_bbox(view, &scene.tets()[t as usize]) {
                    let (t_x0, t_x1) = (x0 as u32 / tile, x1 as u32 / tile);
                    let (t_y0, t_y1) = (y0 as u32 / tile, y1 as u32 / tile);
                    for j in t_y0..=t_y1 {
                        for i in t_x0..=t_x1 {
                            b[j as usize * tx + i as usize].push(t);
                        }
                    }
                }
            }
            b
        })
        .collect();
    let bin_seconds = t0.elapsed().as_secs_f64();

    let t1 = std::time::Instant::now();
    let inputs = SetupInputs {
        scene,
        view,
        want_grad_mag: shader.method().is_bivariate(),
        want_normals: opts.shading.is_active(),
        want_position: opts.shading.needs_position()
            || (opts.shading.wants_shadows() && scene.shadows().is_some_and(|f| f.has_maps())),
        shadows: scene.shadows().filter(|_| opts.shading.wants_shadows()),
        want_thick: shader.method().shades_per_tet(),
        want_span: !shader.method().shades_per_tet(),
    };
    let pt_linear = shader.method().shades_per_tet();
    let fragments = AtomicU64::new(0);
    let setups = AtomicU64::new(0);
    let terminated = AtomicUsize::new(0);
    let done = AtomicUsize::new(0);
    let tiles: Vec<Vec<[f32; 4]>> = (0..n_tiles)
        .into_par_iter()
        .map(|ti| {
            let rect = {
                let (i, j) = ((ti % tx) as u32, (ti / tx) as u32);
                [i * tile, j * tile, ((i + 1) * tile).min(w) - 1, ((j + 1) * tile).min(h) - 1]
            };
            let mut ctx = TileCtx::new(rect);
            let all = ctx.acc.len();
            let mut setup = TetSetup::default();
            'tets: for chunk in &bins {
                for &t in &chunk[ti] {
                    if ctx.opaque == all {
                        terminated.fetch_add(1, Ordering::Relaxed);
                        break 'tets;
                    }
                    ctx.setups += 1;
                    if setup.build(&inputs, t as usize) {
                        draw_tet(&mut ctx, &setup, view, shader, opts, pt_linear);
                    }
                }
            }
            ctx.flush_frags(shader, opts.opaque_alpha);
            fragments.fetch_add(ctx.fragments, Ordering::Relaxed);
            setups.fetch_add(ctx.setups, Ordering::Relaxed);
            progress(done.fetch_add(1, Ordering::Relaxed) + 1, n_tiles);
            ctx.acc
        })
        .collect();

    let mut img = Image::new(w, h);
    let px = img.pixels_mut();
    for (ti, acc) in tiles.into_iter().enumerate() {
        let (i, j) = ((ti % tx) as u32, (ti / tx) as u32);
        let (x0, y0) = (i * tile, j * tile);
        let tw = ((i + 1) * tile).min(w) - x0;
        for (r, row) in acc.chunks_exact(tw as usize).enumerate() {
            let start = (y0 as usize + r) * w as usize + x0 as usize;
            px[start..start + tw as usize].copy_from_slice(row);
        }
    }
    let stats = RasterStats {
        fragments: fragments.into_inner(),
        setups: setups.into_inner(),
        tiles_terminated: terminated.into_inner(),
        reused_setup: false,
        bin_seconds,
        raster_seconds: t1.elapsed().as_secs_f64(),
    };
    (img, stats)
}

/// Tets per chunk of the order in [`rasterize_chunked`]: their records
/// (~250 bytes each) stay in the last-level cache between setup and raster.
const CHUNK: usize = 16 * 1024;

/// One tet of a chunk, set up once for every tile it touches.
// Records live side by side in a per-part Vec (one write, reads from every
// tile it touches); boxing the large variant would add an allocation per tet.
#[allow(clippy::large_enum_variant)]
enum Rec {
    /// Planes and fields, and the covered pixels.
    Span { span: SpanEval, bbox: [i32; 4], cover: Cover },
    /// Crosses the near plane: set up per tile by [`TetSetup::build`].
    Clipped(u32),
}

/// The fast path's per-tet setup of the visible tets of one view, order and
/// cull mask, kept by [`crate::Renderer`] across frames while none of them
/// changes: a new transfer function that culls the same cells, a new
/// shader or method re-renders from it without setting a tet up again.
pub struct PreparedFrame {
    /// Per chunk of the order, its parts.
    chunks: Vec<Vec<Part>>,
    tile: u32,
    want_grad_mag: bool,
    /// Tets the order had (the records are for exactly that order).
    order_len: usize,
    bytes: usize,
}

impl std::fmt::Debug for PreparedFrame {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("PreparedFrame").field("chunks", &self.chunks.len()).field("bytes", &self.bytes).finish()
    }
}

impl PreparedFrame {
    /// Bytes held (records, row spans, tile lists).
    pub fn memory_bytes(&self) -> usize {
        self.bytes
    }
}

/// A contiguous part of a chunk, set up by one worker: records in order,
/// row spans, and per tile the records that touch it (in order).
struct Part {
    recs: Vec<Rec>,
    rows: Vec<[u16; 2]>,
    bins: Vec<Vec<u32>>,
}

impl Part {
    fn new(n_tiles: usize) -> Part {
        Part { recs: Vec::new(), rows: Vec::new(), bins: vec![Vec::new(); n_tiles] }
    }

    /// Sets up `tets` (those `visible` when given) and bins them into
    /// `tile`-pixel tiles (`tx` per row).
    fn prepare(&mut self, inputs: &SetupInputs, tets: &[u32], visible: Option<&[bool]>, tile: u32, tx: usize) {
        self.recs.clear();
        self.rows.clear();
        for b in &mut self.bins {
            b.clear();
        }
        let mut span = SpanEval::default();
        for &t in tets {
            if visible.is_some_and(|v| !v[t as usize]) {
                continue;
            }
            let (rec, bbox) = match prepare_span(inputs, t as usize, &mut span, &mut self.rows) {
                Prepared::Nothing => continue,
                Prepared::Span { bbox, cover } => (Rec::Span { span, bbox, cover }, Some(bbox)),
                Prepared::Clipped => (Rec::Clipped(t), tet_bbox(inputs.view, &inputs.scene.tets()[t as usize])),
            };
            let Some([x0, y0, x1, y1]) = bbox else { continue };
            let r = self.recs.len() as u32;
            self.recs.push(rec);
            for j in y0 as u32 / tile..=y1 as u32 / tile {
                for i in x0 as u32 / tile..=x1 as u32 / tile {
                    self.bins[j as usize * tx + i as usize].push(r);
                }
            }
        }
    }

    /// Gives back the spare capacity of a part that is kept.
    fn shrink_to_fit(&mut self) {
        self.recs.shrink_to_fit();
        self.rows.shrink_to_fit();
        for b in &mut self.bins {
            b.shrink_to_fit();
        }
    }

    fn memory_bytes(&self) -> usize {
        self.recs.capacity() * std::mem::size_of::<Rec>()
            + self.rows.capacity() * 4
            + self.bins.iter().map(|b| b.capacity() * 4 + std::mem::size_of::<Vec<u32>>()).sum::<usize>()
    }
}

/// Whether [`rasterize`] takes the fast path for these options and shader
/// (per-fragment methods without lighting, images up to 32768 wide).
pub fn fast_path_applies(view: &ViewGeometry, shader: &dyn SegmentShader, opts: &RasterOptions) -> bool {
    opts.fast_path && !opts.shading.is_active() && !shader.method().shades_per_tet() && view.frame.width <= 1 << 15
}

/// [`rasterize`] with a cache of the fast path's setup: `order` is the
/// visibility order and `visible` the cull mask, if the order holds culled
/// tets (they are neither set up nor drawn). When `cache` holds the setup of this view,
/// order and mask (the caller clears it when one changes) nothing is set up
/// again; when it is empty, `keep` is set and the setup fits in
/// [`RasterOptions::setup_cache_bytes`], it is filled. Where the fast path
/// does not apply, this is [`rasterize`] of the visible tets.
#[allow(clippy::too_many_arguments)]
pub fn rasterize_cached(
    scene: &Scene,
    view: &ViewGeometry,
    order: &[u32],
    visible: Option<&[bool]>,
    shader: &dyn SegmentShader,
    opts: &RasterOptions,
    cache: &mut Option<PreparedFrame>,
    keep: bool,
    progress: &(dyn Fn(usize, usize) + Sync),
) -> (Image, RasterStats) {
    if !fast_path_applies(view, shader, opts) {
        return match visible {
            Some(v) => {
                let filtered: Vec<u32> = order.iter().copied().filter(|&t| v[t as usize]).collect();
                rasterize(scene, view, &filtered, shader, opts, progress)
            }
            None => rasterize(scene, view, order, shader, opts, progress),
        };
    }
    rasterize_chunked(scene, view, order, visible, shader, opts, Some(cache), keep, progress)
}

/// [`rasterize`]'s fast path: the order in chunks; each chunk's tets set up
/// once ([`prepare_span`]) and binned by parallel parts, then its tiles
/// composited in parallel into accumulators that persist across chunks.
/// Same fragments, values and per-pixel order as the per-tile path. With a
/// `cache`, the setup of the whole order is kept in (or taken from) it.
#[allow(clippy::too_many_arguments)]
fn rasterize_chunked(
    scene: &Scene,
    view: &ViewGeometry,
    order: &[u32],
    visible: Option<&[bool]>,
    shader: &dyn SegmentShader,
    opts: &RasterOptions,
    mut cache: Option<&mut Option<PreparedFrame>>,
    keep: bool,
    progress: &(dyn Fn(usize, usize) + Sync),
) -> (Image, RasterStats) {
    let frame = &view.frame;
    let (w, h) = (frame.width, frame.height);
    let tile = opts.tile.clamp(4, 1024);
    let (tx, ty) = (w.div_ceil(tile) as usize, h.div_ceil(tile) as usize);
    let n_tiles = tx * ty;
    let inputs = SetupInputs {
        scene,
        view,
        want_grad_mag: shader.method().is_bivariate(),
        want_normals: false,
        want_position: false,
        shadows: None,
        want_thick: false,
        want_span: true,
    };
    let mut tiles: Vec<TileCtx> = (0..n_tiles)
        .map(|ti| {
            let (i, j) = ((ti % tx) as u32, (ti / tx) as u32);
            TileCtx::new([i * tile, j * tile, ((i + 1) * tile).min(w) - 1, ((j + 1) * tile).min(h) - 1])
        })
        .collect();
    let n_parts = rayon::current_num_threads() * 2;
    let prepare_chunk = |chunk: &[u32], parts: &mut Vec<Part>, visible: Option<&[bool]>| {
        parts.resize_with(n_parts, || Part::new(n_tiles));
        let part_len = chunk.len().div_ceil(n_parts).max(1);
        parts.par_iter_mut().enumerate().for_each(|(k, part)| {
            let lo = (k * part_len).min(chunk.len());
            let hi = ((k + 1) * part_len).min(chunk.len());
            part.prepare(&inputs, &chunk[lo..hi], visible, tile, tx);
        });
    };
    let (mut bin_seconds, mut raster_seconds, mut prepared) = (0.0, 0.0, 0u64);
    let n_chunks = order.len().div_ceil(CHUNK);
    // A kept setup is for this view and order (the caller's contract); it is
    // valid for these records if built with the same tile size and fields.
    let want_grad_mag = inputs.want_grad_mag;
    let reuse = cache
        .as_deref()
        .and_then(Option::as_ref)
        .is_some_and(|pf| pf.tile == tile && pf.want_grad_mag == want_grad_mag && pf.order_len == order.len());
    // Without a kept setup for this frame, fill the cache as the chunks are
    // drawn (each chunk's setup still feeds its raster while in cache), if
    // it fits in the memory budget (records of visible tets).
    let fill = match cache.as_deref_mut() {
        Some(slot) if !reuse => {
            *slot = None;
            keep && {
                let drawn = visible.map_or(order.len(), |v| order.iter().filter(|&&t| v[t as usize]).count());
                drawn.saturating_mul(std::mem::size_of::<Rec>() + 16) <= opts.setup_cache_bytes
            }
        }
        _ => false,
    };
    let mut filled: Vec<Vec<Part>> = Vec::new();
    let kept = cache.as_deref().and_then(Option::as_ref);
    let mut scratch: Vec<Part> = Vec::new();
    for (c, chunk) in order.chunks(CHUNK).enumerate() {
        let t0 = std::time::Instant::now();
        let parts: &[Part] = match kept {
            Some(pf) => &pf.chunks[c],
            None => {
                prepare_chunk(chunk, &mut scratch, visible);
                prepared += scratch.iter().map(|p| p.recs.len() as u64).sum::<u64>();
                &scratch
            }
        };
        let t1 = std::time::Instant::now();
        bin_seconds += (t1 - t0).as_secs_f64();
        tiles.par_iter_mut().enumerate().for_each(|(ti, ctx)| {
            if ctx.done {
                return;
            }
            let all = ctx.acc.len();
            let mut setup: Option<Box<TetSetup>> = None;
            for part in parts {
                for &r in &part.bins[ti] {
                    if ctx.opaque == all {
                        ctx.done = true;
                        return;
                    }
                    match &part.recs[r as usize] {
                        Rec::Span { span, bbox, cover } => {
                            draw_span(ctx, span, *bbox, *cover, &part.rows, shader, opts.opaque_alpha)
                        }
                        Rec::Clipped(t) => {
                            ctx.setups += 1;
                            let s = setup.get_or_insert_with(Default::default);
                            if s.build(&inputs, *t as usize) {
                                draw_tet(ctx, s, view, shader, opts, false);
                            }
                        }
                    }
                }
            }
        });
        raster_seconds += t1.elapsed().as_secs_f64();
        if fill {
            let mut parts = std::mem::take(&mut scratch);
            parts.iter_mut().for_each(Part::shrink_to_fit);
            filled.push(parts);
        }
        progress(c + 1, n_chunks);
    }
    if let Some(slot) = cache.filter(|_| fill) {
        let bytes = filled.iter().flatten().map(Part::memory_bytes).sum();
        *slot = Some(PreparedFrame { chunks: filled, tile, want_grad_mag, order_len: order.len(), bytes });
    }

    tiles.par_iter_mut().for_each(|ctx| ctx.flush_frags(shader, opts.opaque_alpha));
    let mut img = Image::new(w, h);
    let px = img.pixels_mut();
    let (mut fragments, mut setups, mut terminated) = (0, prepared, 0);
    for ctx in &tiles {
        let [x0, y0, x1, _] = ctx.rect;
        let tw = (x1 - x0 + 1) as usize;
        for (r, row) in ctx.acc.chunks_exact(tw).enumerate() {
            let start = (y0 as usize + r) * w as usize + x0 as usize;
            px[start..start + tw].copy_from_slice(row);
        }
        fragments += ctx.fragments;
        setups += ctx.setups;
        terminated += ctx.done as usize;
    }
    let stats = RasterStats {
        fragments,
        setups,
        tiles_terminated: terminated,
        reused_setup: reuse,
        bin_seconds,
        raster_seconds,
    };
    (img, stats)
}

/// Draws one prepared tet into the tile: its covered pixels in the tile,
/// gathered across rows and evaluated `LANES` at a time (small tets cover
/// a few pixels per row), then queued for shading (what [`draw_tet`] does
/// for an unlit per-fragment method, from the record).
fn draw_span(
    ctx: &mut TileCtx,
    sp: &SpanEval,
    bbox: [i32; 4],
    cover: Cover,
    rows: &[[u16; 2]],
    shader: &dyn SegmentShader,
    opaque_alpha: f32,
) {
    let [rx0, ry0, rx1, ry1] = ctx.rect;
    let (ref_x, ref_y) = (sp.ref_px[0], sp.ref_px[1]);
    let mut q = PixelQueue::default();
    match cover {
        Cover::Mask(mut m) => {
            // Keep the bits inside the tile (rows and columns of the bbox).
            let s = MASK_SIDE as u32;
            let (bx, by) = (bbox[0] as u32, bbox[1] as u32);
            let i_lo = rx0.saturating_sub(bx).min(s);
            let i_hi = (rx1 + 1).saturating_sub(bx).min(s);
            let j_lo = ry0.saturating_sub(by).min(s);
            let j_hi = (ry1 + 1).saturating_sub(by).min(s);
            if i_lo >= i_hi || j_lo >= j_hi {
                return;
            }
            let cols = ((1u64 << (i_hi - i_lo)) - 1) << i_lo;
            let mut keep = 0u64;
            for j in j_lo..j_hi {
                keep |= cols << (s * j);
            }
            m &= keep;
            while m != 0 {
                let b = m.trailing_zeros();
                m &= m - 1;
                let (px, py) = (bx + b % s, by + b / s);
                let pix = (py - ry0) as usize * ctx.stride + (px - rx0) as usize;
                q.push((px as i32 - ref_x) as f32, (py as i32 - ref_y) as f32, pix as u32);
                if q.n == LANES {
                    q.flush(ctx, sp, shader, opaque_alpha);
                }
            }
        }
        Cover::Rows(first) => {
            let y0 = (bbox[1] as u32).max(ry0);
            let y1 = (bbox[3] as u32).min(ry1);
            for py in y0..=y1 {
                let [a, b] = rows[first as usize + (py - bbox[1] as u32) as usize];
                let (xa, xb) = ((a as u32).max(rx0), (b as u32).min(rx1));
                if xa > xb || a > b {
                    continue;
                }
                let row = (py - ry0) as usize * ctx.stride;
                let j = (py as i32 - ref_y) as f32;
                for px in xa..=xb {
                    q.push((px as i32 - ref_x) as f32, j, (row + (px - rx0) as usize) as u32);
                    if q.n == LANES {
                        q.flush(ctx, sp, shader, opaque_alpha);
                    }
                }
            }
        }
    }
    if q.n > 0 {
        q.flush(ctx, sp, shader, opaque_alpha);
    }
}

/// Up to `LANES` pixels of one tet waiting for [`SpanEval::eval_pixels`]:
/// offsets from its reference pixel and index in the tile.
#[derive(Default)]
struct PixelQueue {
    i: [f32; LANES],
    j: [f32; LANES],
    pix: [u32; LANES],
    n: usize,
}

impl PixelQueue {
    #[inline(always)]
    fn push(&mut self, i: f32, j: f32, pix: u32) {
        self.i[self.n] = i;
        self.j[self.n] = j;
        self.pix[self.n] = pix;
        self.n += 1;
    }

    fn flush(&mut self, ctx: &mut TileCtx, sp: &SpanEval, shader: &dyn SegmentShader, opaque_alpha: f32) {
        let mut lanes = Lanes::default();
        sp.eval_pixels(&self.i, &self.j, &mut lanes);
        ctx.push_pixels(&lanes, &self.pix, self.n, shader, opaque_alpha);
        self.n = 0;
    }
}

/// Unlit fragments waiting for one [`SegmentShader::shade_batch`] call,
/// across tets in drawing order, with their pixel (index into the tile).
struct FragBatch {
    segs: SegmentBatch,
    pixel: [u32; BATCH],
    rgba: [Rgba32; BATCH],
}

struct TileCtx {
    rect: [u32; 4],
    stride: usize,
    acc: Vec<[f32; 4]>,
    opaque: usize,
    fragments: u64,
    setups: u64,
    batch: Batch,
    frags: Box<FragBatch>,
    /// The pieces of a split lit segment ([`crate::shading::light_segment`]).
    lit_pieces: Box<crate::shading::LitPieces>,
    /// Every pixel reached `opaque_alpha`: later chunks skip the tile.
    done: bool,
}

impl TileCtx {
    /// An empty tile over the inclusive pixel rectangle `[x0, y0, x1, y1]`.
    fn new(rect: [u32; 4]) -> TileCtx {
        TileCtx {
            rect,
            stride: (rect[2] - rect[0] + 1) as usize,
            acc: vec![[0.0f32; 4]; ((rect[2] - rect[0] + 1) * (rect[3] - rect[1] + 1)) as usize],
            opaque: 0,
            fragments: 0,
            setups: 0,
            batch: Batch::new(),
            frags: Box::new(FragBatch { segs: SegmentBatch::default(), pixel: [0; BATCH], rgba: [[0.0; 4]; BATCH] }),
            lit_pieces: Box::default(),
            done: false,
        }
    }

    /// Queues the first `n` lanes (pixels `pix[l]` of the tile) that have a
    /// segment and whose pixel is not yet opaque; shades and composites when
    /// the batch is full.
    #[inline]
    fn push_pixels(
        &mut self,
        lanes: &Lanes,
        pix: &[u32; LANES],
        n: usize,
        shader: &dyn SegmentShader,
        opaque_alpha: f32,
    ) {
        for (l, &p) in pix.iter().enumerate().take(n) {
            if lanes.len_world[l] <= 0.0 || self.acc[p as usize][3] >= opaque_alpha {
                continue;
            }
            let f = &mut *self.frags;
            let k = f.segs.len;
            f.segs.s_front[k] = lanes.s_front[l];
            f.segs.s_back[k] = lanes.s_back[l];
            f.segs.grad_front[k] = lanes.g_front[l];
            f.segs.grad_back[k] = lanes.g_back[l];
            f.segs.len_world[k] = lanes.len_world[l];
            f.pixel[k] = p;
            f.segs.len = k + 1;
            if k + 1 == BATCH {
                self.flush_frags(shader, opaque_alpha);
            }
        }
    }

    /// Shades the queued fragments and composites them in order. A pixel
    /// may be queued more than once (several tets'); the queueing test saw
    /// the pixel before the batch, so opacity is tested again here: the
    /// same fragments reach `under`, in the same order, as when each is
    /// composited at once.
    fn flush_frags(&mut self, shader: &dyn SegmentShader, opaque_alpha: f32) {
        let f = &mut *self.frags;
        let n = f.segs.len;
        if n == 0 {
            return;
        }
        shader.shade_batch(&f.segs, &mut f.rgba);
        for k in 0..n {
            let acc = &mut self.acc[f.pixel[k] as usize];
            if acc[3] < opaque_alpha {
                under(acc, f.rgba[k], opaque_alpha, &mut self.opaque);
                self.fragments += 1;
            }
        }
        f.segs.len = 0;
    }
}

/// Fragments of one tet waiting to be shaded in one
/// [`SegmentShader::shade_span`] call and composited.
struct Batch {
    segs: [Segment; LIT_BATCH],
    /// Index into the tile's `acc`.
    pixel: [u32; LIT_BATCH],
    /// Pixel position and ζ at the segment midpoint (lighting only).
    at: [[u32; 2]; LIT_BATCH],
    zeta_mid: [f32; LIT_BATCH],
    zeta_half: [f32; LIT_BATCH],
    rgba: [Rgba32; LIT_BATCH],
    n: usize,
}

const LIT_BATCH: usize = 64;

impl Batch {
    fn new() -> Batch {
        Batch {
            segs: [Segment::default(); LIT_BATCH],
            pixel: [0; LIT_BATCH],
            at: [[0; 2]; LIT_BATCH],
            zeta_mid: [0.0; LIT_BATCH],
            zeta_half: [0.0; LIT_BATCH],
            rgba: [[0.0; 4]; LIT_BATCH],
            n: 0,
        }
    }
}

/// Composites premultiplied `c` under pixel `acc` ("under": front to back).
#[inline(always)]
fn under(acc: &mut [f32; 4], c: Rgba32, opaque_alpha: f32, opaque: &mut usize) {
    let t = 1.0 - acc[3];
    acc[0] += t * c[0];
    acc[1] += t * c[1];
    acc[2] += t * c[2];
    acc[3] += t * c[3];
    if acc[3] >= opaque_alpha {
        *opaque += 1;
    }
}

/// Shades and composites the batched fragments (one tet's, so no pixel
/// appears twice), with lighting/silhouettes at each segment's midpoint.
fn flush(ctx: &mut TileCtx, s: &TetSetup, view: &ViewGeometry, shader: &dyn SegmentShader, opts: &RasterOptions) {
    let (b, pieces) = (&mut ctx.batch, &mut *ctx.lit_pieces);
    let n = b.n;
    if n == 0 {
        return;
    }
    shader.shade_span(&b.segs[..n], &mut b.rgba[..n]);
    if opts.shading.is_active() {
        for k in 0..n {
            let (x, y) = (b.at[k][0] as f64 + 0.5, b.at[k][1] as f64 + 0.5);
            let (z_mid, z_half) = (s.span.z0 + b.zeta_mid[k] as f64, b.zeta_half[k] as f64);
            let lit_at = |w: f32| lit_point(s, view, opts, x, y, z_mid + (2.0 * w as f64 - 1.0) * z_half);
            let shade_pieces = |p: &SegmentBatch, out: &mut [Rgba32; BATCH]| shader.shade_batch(p, out);
            b.rgba[k] = crate::shading::light_segment(&b.segs[k], b.rgba[k], None, lit_at, shade_pieces, pieces).0;
        }
    }
    for k in 0..n {
        under(&mut ctx.acc[b.pixel[k] as usize], b.rgba[k], opts.opaque_alpha, &mut ctx.opaque);
    }
    ctx.fragments += n as u64;
    b.n = 0;
}

fn segment(f: &Fragment) -> Segment {
    Segment {
        s_front: f.s_front as f32,
        s_back: f.s_back as f32,
        grad_front: f.g_front as f32,
        grad_back: f.g_back as f32,
        len_world: f.len_world as f32,
    }
}

/// Shades one fragment (the `pt-linear` thick point), with lighting/silhouettes at the segment's midpoint.
fn shade(
    s: &TetSetup,
    view: &ViewGeometry,
    shader: &dyn SegmentShader,
    opts: &RasterOptions,
    f: &Fragment,
    (x, y): (f64, f64),
    pieces: &mut crate::shading::LitPieces,
) -> [f32; 4] {
    let rgba = shader.shade(&segment(f));
    if !opts.shading.is_active() {
        return rgba;
    }
    let lit_at = |w: f32| lit_point(s, view, opts, x, y, f.z_front + w as f64 * (f.z_back - f.z_front));
    let shade_pieces = |p: &SegmentBatch, out: &mut [Rgba32; BATCH]| shader.shade_batch(p, out);
    crate::shading::light_segment(&segment(f), rgba, None, lit_at, shade_pieces, pieces).0
}

/// The lighting terms at depth `z` of pixel (x, y): the normal, position
/// and shadows interpolated there (unshaded without normals).
fn lit_point(s: &TetSetup, view: &ViewGeometry, opts: &RasterOptions, x: f64, y: f64, z: f64) -> crate::LitPoint {
    match s.normal_at(x, y, z) {
        Some(n) => {
            let (pos, shadow) = s.lit_at(x, y, z);
            opts.shading.lit_point(n, pos, view.frame.view_dir(x, y), |i| shadow[i])
        }
        None => crate::LitPoint::NONE,
    }
}

/// Draws one tet into the tile: row spans of covered pixel centres (exact
/// edge tests), segments evaluated `LANES` pixels at a time, fragments
/// batched per tet for the shader.
fn draw_tet(
    ctx: &mut TileCtx,
    s: &TetSetup,
    view: &ViewGeometry,
    shader: &dyn SegmentShader,
    opts: &RasterOptions,
    pt_linear: bool,
) {
    let x0 = (s.bbox[0] as u32).max(ctx.rect[0]);
    let y0 = (s.bbox[1] as u32).max(ctx.rect[1]);
    let x1 = (s.bbox[2] as u32).min(ctx.rect[2]);
    let y1 = (s.bbox[3] as u32).min(ctx.rect[3]);
    if x0 > x1 || y0 > y1 {
        return;
    }
    // pt-linear: shade the thick point once, interpolate towards the silhouette.
    let thick_rgba = if pt_linear && !s.clipped {
        let Some(t) = s.thick else { return };
        match s.fragment(&view.frame, t[0], t[1]) {
            Some(f) => Some(shade(s, view, shader, opts, &f, (t[0], t[1]), &mut ctx.lit_pieces)),
            None => return,
        }
    } else {
        None
    };
    let opaque_alpha = opts.opaque_alpha;
    // Lighting needs the tet's setup per fragment: those go through the
    // batch, flushed per tet.
    let lit = opts.shading.is_active();
    let mut lanes = Lanes::default();
    let mut tent = [0.0f32; LANES];
    for py in y0..=y1 {
        let Some((xa, xb)) = s.row_span(py, x0, x1) else { continue };
        let row = (py - ctx.rect[1]) as usize * ctx.stride;
        let mut px0 = xa;
        while px0 <= xb {
            let n = ((xb - px0 + 1) as usize).min(LANES);
            let base = row + (px0 - ctx.rect[0]) as usize;
            if let Some(rgba) = thick_rgba {
                s.tent_lanes(px0, py, &mut tent);
                for (l, &lam) in tent[..n].iter().enumerate() {
                    let acc = &mut ctx.acc[base + l];
                    if lam <= 0.0 || acc[3] >= opaque_alpha {
                        continue;
                    }
                    under(acc, rgba.map(|v| v * lam), opaque_alpha, &mut ctx.opaque);
                    ctx.fragments += 1;
                }
            } else {
                s.eval_lanes(px0, py, &mut lanes);
                if !lit {
                    let pix = std::array::from_fn(|l| (base + l) as u32);
                    ctx.push_pixels(&lanes, &pix, n, shader, opaque_alpha);
                    px0 += LANES as u32;
                    continue;
                }
                for l in 0..n {
                    if lanes.len_world[l] <= 0.0 || ctx.acc[base + l][3] >= opaque_alpha {
                        continue;
                    }
                    let b = &mut ctx.batch;
                    b.segs[b.n] = Segment {
                        s_front: lanes.s_front[l],
                        s_back: lanes.s_back[l],
                        grad_front: lanes.g_front[l],
                        grad_back: lanes.g_back[l],
                        len_world: lanes.len_world[l],
                    };
                    b.pixel[b.n] = (base + l) as u32;
                    b.at[b.n] = [px0 + l as u32, py];
                    b.zeta_mid[b.n] = lanes.zeta_mid[l];
                    b.zeta_half[b.n] = lanes.zeta_half[l];
                    b.n += 1;
                    if b.n == LIT_BATCH {
                        flush(ctx, s, view, shader, opts);
                    }
                }
            }
            px0 += LANES as u32;
        }
    }
    flush(ctx, s, view, shader, opts);
}
