//! The GPU renderer: projected tetrahedra on wgpu (Vulkan), headless, matched
//! against tet_render's CPU renderer. The only crate of the workspace that
//! uses wgpu.
//!
//! * [`GpuContext`]: adapter, device and queue ([`GpuContext::new_headless`];
//!   a clear [`GpuError::NoAdapter`] where none exists — Mesa's lavapipe,
//!   Debian package `mesa-vulkan-drivers`, is a software adapter).
//! * [`GpuScene`]: a mesh on the GPU — positions relative to the mesh
//!   centre in f32, tets, scalars.
//! * [`GpuShader`]: what colours a fragment, per method id ([`GPU_METHODS`];
//!   [`GpuShader::from_baked`] takes any of them from tet_preint's `Baked`):
//!   - `pt-linear`: transfer function nodes, the thick point shaded once;
//!   - `table3d`: the table as a 3D texture, trilinear lookup with
//!     `Table3d::lookup`'s normalisation;
//!   - `atlas2d`: Röttger & Ertl's (2002) tiled cylindrical atlas as one 2D texture,
//!     pseudo-angle and L∞ radius per fragment as `Atlas2d::lookup`;
//!   - `poly1/2/4`: ρ̂ and the colour polynomials' coefficients as a 2D
//!     array texture (full square or diagonal bands), the 16-bit α table as
//!     an R16Uint 1D texture, as `PolyTable::lookup` (tables from the CPU
//!     bake or [`bake_poly`]);
//!   - `partial`: the TF-independent Ψ table as a 2D texture, each segment
//!     split at the TF's control points per fragment, as `PartialShader`
//!     (both emission models; under independent emission Ψ and Ψ₁ above
//!     rate 8 by Gauss–Legendre quadrature, where the CPU takes the f64
//!     closed form);
//!   - `biv-approx`: 2D widgets over (s, |∇s|) and Song et al.'s (2009) F/B table,
//!     k sub-segments per fragment, as `BivApprox`, with per-vertex gradient
//!     magnitudes on the scene ([`GpuScene::with_gradient_magnitudes`]);
//!   - `biv-exact`: no table; the same TF rows as biv-approx, and per
//!     fragment `BivExact`'s scheme in f32 (shaders/biv_exact.wgsl): the
//!     segment cut at every breakpoint (found one at a time), each piece's
//!     optical depth in closed form (erfcx for Gaussians), its colour c·α
//!     where one widget carries it under density emission, else by 8-point
//!     Gauss–Legendre panels with the closed-form transmittance (also for
//!     the pieces the CPU takes from Song et al.'s (2009) emission-only tables); a
//!     budget of loop iterations per invocation bounds the work (past it:
//!     exact α, approximate colour). On llvmpipe it always runs the graphics
//!     rasterizer (that driver's shared loop-iteration limit).
//!
//!   Every lookup reads texels and interpolates with the CPU's weights and
//!   clamps, so the GPU agrees with the CPU shader to f32 rounding (biv-exact,
//!   which integrates instead: to ~1e-5, tests/gpu_methods.rs);
//!   [`GpuShader::probe`] evaluates the per-fragment function on given
//!   (Sf, Sb, l). Not on the GPU: `exact`.
//! * [`GpuCull`]: per-cell culling with tet_render's `TfCuller` semantics,
//!   computed on the GPU from the cells' scalar ranges and, with 2D widgets,
//!   |∇s| ranges (compared as ranks of the scene's distinct f64 values, so
//!   exactly the CPU's decision), and
//!   the visibility order compacted by a prefix sum so culled tets are
//!   neither classified nor rasterized ([`FrameOptions::cull`];
//!   `tets_culled` and [`GpuRenderStats::fraction_culled`] in the stats).
//! * [`GpuRenderer`]: the classify compute pass (Shirley–Tuchman
//!   classification, near-plane clipping, face planes), then one of two
//!   rasterizers ([`RasterPath`]) compositing front to back ("under") into
//!   Rgba32Float, and readback into a tet_render [`Image`]:
//!   - `Compute` (default): tets binned into 16×16-pixel tiles in
//!     visibility order (prefix sums and a stable GPU radix sort of
//!     (tile, tet) pairs), one workgroup per tile compositing per pixel
//!     with early termination;
//!   - `Graphics`: the hardware rasterizer with blending.
//!
//!   Both call the same per-fragment function (shaders/fragment.wgsl),
//!   specialised per method by a pipeline-overridable constant
//!   (`SHADE_METHOD`): each method's pipelines hold only its own code and
//!   are built at its first frame.
//!   Buffers persist across frames and grow only when needed; orders whose
//!   per-tet data exceeds one storage binding are drawn in chunks.
//!   [`GpuRenderer::tonemap`] fits and applies Reinhard's operator on the
//!   GPU (log-average luminance by a compute reduction) to 8-bit sRGB, as
//!   tet_render's `Display`.
//! * [`GpuOrder`]: the visibility order — given (tet_render's MPVO, the
//!   exact option, or the CPU [`centroid_order`]) or `GpuCentroid`, a GPU
//!   radix sort of centroid depths recomputed only when the camera moves.
//! * [`GpuTable3d`]: GPU pre-integration — table3d baked by a compute
//!   shader (the CPU's slice-recurrence integration per entry, same scalar
//!   axis) straight into the 3D texture [`GpuShader::table3d_baked`]
//!   samples; [`GpuAccumulation::F16`] rounds its running sums to f16 for
//!   the precision study. [`GpuShader::probe_table3d`] runs the
//!   per-fragment lookup on given (Sf, Sb, l) triples. [`bake_poly`]
//!   bakes the poly1/2/4 tables (ρ̂ and the colour polynomials) in a
//!   compute shader and reads them back into a `PolyTable`, which
//!   [`GpuShader::poly`] renders with.
//! * [`gpu_types`]: every CPU↔GPU struct, `Pod`, mirrored in the WGSL.
//!
//! ```
//! use tet_gpu::{centroid_order, GpuContext, GpuRenderer, GpuScene, GpuShader};
//! use tet_render::{Camera, ViewSpec};
//! let ctx = match GpuContext::new_headless() {
//!     Ok(ctx) => ctx,
//!     Err(e) => { eprintln!("skipped: {e}"); return Ok(()); }
//! };
//! let pts = [[0.0, 0.0, 0.0], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]];
//! let scene = GpuScene::new(&ctx, &pts, &[[0, 1, 2, 3]], &[0.5; 4])?;
//! let tf = tet_preint::TransferFunction::from_json(
//!     r#"{"color": [[0, 1, 1, 1]], "opacity": [[0, 2]], "unit_distance": 1}"#,
//! ).unwrap();
//! let shader = GpuShader::pt_linear(&ctx, &tf)?;
//! let camera = Camera::new(&ViewSpec::framing([0.0; 3], [1.0; 3], [64, 48])).unwrap();
//! let renderer = GpuRenderer::new(&ctx)?;
//! let order = centroid_order(&scene, &camera);
//! let frame = renderer.render(&ctx, &scene, &camera, &order, &shader)?;
//! // The tet covers part of the image; the centre pixel lies on its edge x + y = 1.
//! let covered = frame.image.pixels().iter().filter(|p| p[3] > 0.0).count();
//! assert!(covered > 100 && covered < 64 * 48);
//! # Ok::<(), tet_gpu::GpuError>(())
//! ```
#![forbid(unsafe_code)]

mod bake;
mod binning;
mod cull;
pub mod gpu_types;
mod gpusort;
mod lighting;
mod methods;
mod poly_bake;
mod render;
mod tonemap;
mod workspace;

pub use bake::{GpuAccumulation, GpuBakeStats, GpuTable3d};
pub use cull::GpuCull;
pub use lighting::{light_params, ShadowMaps};
pub use methods::GPU_METHODS;
pub use poly_bake::bake_poly;
pub use render::{
    centroid_order, FrameOptions, GpuFrame, GpuOrder, GpuRenderStats, GpuRenderer, GpuScene, GpuShader, RasterPath,
    LIT_LOOP_LIMITED_PAIRS,
};
pub use tonemap::ToneResult;

use tet_render::Image;

/// Why the GPU path failed; each variant says what to do about it.
#[derive(Debug, thiserror::Error)]
pub enum GpuError {
    #[error("no GPU adapter found (tried {backends}); install mesa-vulkan-drivers for a software adapter")]
    NoAdapter { backends: String },
    #[error("GPU adapter {adapter} lacks {feature}, which the renderer needs")]
    MissingFeature { adapter: String, feature: &'static str },
    #[error("GPU device request failed on {adapter}: {why}")]
    Device { adapter: String, why: String },
    #[error("{what} needs {bytes} bytes; this device allows {limit}")]
    TooLarge { what: &'static str, bytes: u64, limit: u64 },
    #[error("input: {0}")]
    Input(String),
    #[error("not on the GPU: {0}")]
    Unsupported(String),
    #[error("GPU validation: {0}")]
    Validation(String),
    #[error("reading back from the GPU: {0}")]
    Readback(String),
}

/// Adapter, device and queue.
pub struct GpuContext {
    pub device: wgpu::Device,
    pub queue: wgpu::Queue,
    info: wgpu::AdapterInfo,
}

impl GpuContext {
    /// The first adapter of the backends `WGPU_BACKEND` selects (default:
    /// every compiled backend, which is Vulkan only — the GL backend lacks
    /// f32 filtering and blending), high-performance preferred, with the
    /// adapter's own limits and `FLOAT32_BLENDABLE` (required: the HDR
    /// target is Rgba32Float).
    pub fn new_headless() -> Result<GpuContext, GpuError> {
        let desc = wgpu::InstanceDescriptor::new_without_display_handle_from_env();
        let backends = format!("{:?}", desc.backends);
        let instance = wgpu::Instance::new(desc);
        let adapter = pollster::block_on(instance.request_adapter(&wgpu::RequestAdapterOptions {
            power_preference: wgpu::PowerPreference::HighPerformance,
            ..Default::default()
        }))
        .map_err(|_| GpuError::NoAdapter { backends })?;
        let info = adapter.get_info();
        let name = format!("{} ({:?}, {:?})", info.name, info.backend, info.device_type);
        let needed = wgpu::Features::FLOAT32_BLENDABLE;
        if !adapter.features().contains(needed) {
            return Err(GpuError::MissingFeature { adapter: name, feature: "FLOAT32_BLENDABLE" });
        }
        let (device, queue) = pollster::block_on(adapter.request_device(&wgpu::DeviceDescriptor {
            label: Some("tet_gpu"),
            required_features: needed,
            required_limits: adapter.limits(),
            ..Default::default()
        }))
        .map_err(|e| GpuError::Device { adapter: name, why: e.to_string() })?;
        Ok(GpuContext { device, queue, info })
    }

    /// What the adapter is, e.g. "llvmpipe (LLVM 15.0.6, 256 bits) (Vulkan, Cpu)".
    pub fn describe(&self) -> String {
        format!(
            "{} ({:?}, {:?}, driver {} {})",
            self.info.name, self.info.backend, self.info.device_type, self.info.driver, self.info.driver_info
        )
    }

    /// Whether the adapter is llvmpipe (Mesa's lavapipe), whose compiled
    /// shaders end every loop once 65 535 iterations have run in all the
    /// loops of one invocation together (gallivm's
    /// LP_MAX_TGSI_LOOP_ITERATIONS): the compute rasterizer's per-pixel loop
    /// over a tile's tets would share that count with biv-exact's per-fragment
    /// integration, so biv-exact takes the graphics rasterizer there.
    pub(crate) fn limits_loop_iterations(&self) -> bool {
        self.info.driver.to_ascii_lowercase().contains("llvmpipe")
            || self.info.name.to_ascii_lowercase().contains("llvmpipe")
    }

    pub fn adapter_info(&self) -> &wgpu::AdapterInfo {
        &self.info
    }

    /// Whether the adapter is a software rasterizer (lavapipe, llvmpipe).
    pub fn is_software(&self) -> bool {
        self.info.device_type == wgpu::DeviceType::Cpu
    }

    /// Blocks until all submitted work has finished.
    pub(crate) fn wait(&self) -> Result<(), GpuError> {
        self.device.poll(wgpu::PollType::wait_indefinitely()).map(|_| ()).map_err(|e| GpuError::Readback(e.to_string()))
    }

    /// Runs `f` inside a validation error scope and turns a captured error
    /// into [`GpuError::Validation`] (wgpu would otherwise panic).
    pub(crate) fn checked<T>(&self, f: impl FnOnce() -> T) -> Result<T, GpuError> {
        let scope = self.device.push_error_scope(wgpu::ErrorFilter::Validation);
        let out = f();
        match pollster::block_on(scope.pop()) {
            Some(e) => Err(GpuError::Validation(e.to_string())),
            None => Ok(out),
        }
    }
}

/// Whether a missing GPU adapter must fail a test instead of skipping it:
/// `TETKIT_REQUIRE_GPU=1` (`make test-gpu`, and `make ci` where a Vulkan
/// driver is installed). Any other value, or none, lets tests skip with a
/// printed reason. The one reading of the variable, for every crate's tests.
pub fn gpu_required() -> bool {
    std::env::var("TETKIT_REQUIRE_GPU").is_ok_and(|v| v == "1")
}

/// The WGSL of every module as the GPU receives it (shared declarations
/// prepended), by name: what the naga test validates.
pub fn shader_sources() -> Vec<(&'static str, String)> {
    vec![
        ("classify", shader_source(CLASSIFY_WGSL)),
        ("raster", shader_source_fragment(RASTER_WGSL)),
        ("bin", shader_source_fragment(BIN_WGSL)),
        ("sort", shader_source_plain(SORT_WGSL)),
        ("tonemap", shader_source_plain(TONEMAP_WGSL)),
        ("bake", shader_source_plain(BAKE_WGSL)),
        ("probe", shader_source_fragment(PROBE_WGSL)),
        ("poly_bake", shader_source_plain(POLY_BAKE_WGSL)),
        ("cull", shader_source_plain(CULL_WGSL)),
    ]
}

const COMMON_WGSL: &str = include_str!("../shaders/common.wgsl");
const FRAGMENT_WGSL: &str = include_str!("../shaders/fragment.wgsl");
const LIGHTING_WGSL: &str = include_str!("../shaders/lighting.wgsl");
const BIV_EXACT_WGSL: &str = include_str!("../shaders/biv_exact.wgsl");
const CLASSIFY_WGSL: &str = include_str!("../shaders/classify.wgsl");
const RASTER_WGSL: &str = include_str!("../shaders/raster.wgsl");
const BIN_WGSL: &str = include_str!("../shaders/bin.wgsl");
const SORT_WGSL: &str = include_str!("../shaders/sort.wgsl");
const TONEMAP_WGSL: &str = include_str!("../shaders/tonemap.wgsl");
const BAKE_WGSL: &str = include_str!("../shaders/bake.wgsl");
const PROBE_WGSL: &str = include_str!("../shaders/probe.wgsl");
const POLY_BAKE_WGSL: &str = include_str!("../shaders/poly_bake.wgsl");
const CULL_WGSL: &str = include_str!("../shaders/cull.wgsl");

/// common.wgsl + lighting.wgsl + `body` (classify).
fn shader_source(body: &str) -> String {
    format!("{COMMON_WGSL}\n{LIGHTING_WGSL}\n{body}")
}

/// common.wgsl + lighting.wgsl + fragment.wgsl + biv_exact.wgsl + `body`: the modules that
/// shade fragments (graphics raster, compute raster, probe), so all run the
/// same maths.
fn shader_source_fragment(body: &str) -> String {
    format!("{COMMON_WGSL}\n{LIGHTING_WGSL}\n{FRAGMENT_WGSL}\n{BIV_EXACT_WGSL}\n{body}")
}

/// A module on its own (sort, tonemap, bake).
fn shader_source_plain(body: &str) -> String {
    body.to_string()
}

/// Reads an Rgba32Float texture back into an [`Image`].
pub(crate) fn read_texture(ctx: &GpuContext, tex: &wgpu::Texture) -> Result<Image, GpuError> {
    let pixels = render::read_rgba32f(ctx, tex, "readback")?;
    Image::from_pixels(tex.width(), tex.height(), pixels).map_err(|e| GpuError::Readback(e.to_string()))
}

/// Maps a MAP_READ buffer after the queue's work and copies it out.
pub(crate) fn map_read(ctx: &GpuContext, buf: &wgpu::Buffer) -> Result<Vec<u8>, GpuError> {
    map_read_range(ctx, buf, buf.size())
}

/// As [`map_read`], the first `bytes` only.
pub(crate) fn map_read_range(ctx: &GpuContext, buf: &wgpu::Buffer, bytes: u64) -> Result<Vec<u8>, GpuError> {
    let slice = buf.slice(..bytes);
    let (tx, rx) = std::sync::mpsc::channel();
    slice.map_async(wgpu::MapMode::Read, move |r| {
        let _ = tx.send(r);
    });
    ctx.wait()?;
    rx.recv().map_err(|e| GpuError::Readback(e.to_string()))?.map_err(|e| GpuError::Readback(e.to_string()))?;
    let out = slice.get_mapped_range().map_err(|e| GpuError::Readback(e.to_string()))?.to_vec();
    buf.unmap();
    Ok(out)
}
