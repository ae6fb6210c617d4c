//! Every struct the CPU and the GPU share, `#[repr(C)]` and `Pod`, with the
//! WGSL declaration each one mirrors (in `shaders/common.wgsl` or
//! `shaders/tonemap.wgsl`). Layout rules: only 4-byte scalars and `[f32; 4]`
//! / `[u32; 4]` rows, every struct a multiple of 16 bytes, so WGSL's uniform
//! and storage layouts place each field at the same offset as Rust does
//! (checked by the layout tests at the bottom).

use bytemuck::{Pod, Zeroable};

/// `Frame` in common.wgsl: the camera in the scene's frame (positions
/// relative to the mesh centre), the pixel ↔ camera maps of
/// `tet_render::project::Frame`, and what the shaders need of the method.
#[repr(C)]
#[derive(Debug, Clone, Copy, PartialEq, Pod, Zeroable)]
pub struct FrameUniforms {
    /// Eye position relative to the mesh centre; w unused.
    pub eye_rel: [f32; 4],
    /// Unit screen right, up and view direction (world frame); w unused.
    pub right: [f32; 4],
    pub up: [f32; 4],
    pub forward: [f32; 4],
    /// x_cam = ax·x_px + bx, y_cam = ay·y_px + by (camera x/y at depth 1
    /// for perspective, world units for parallel).
    pub ax: f32,
    pub bx: f32,
    pub ay: f32,
    pub by: f32,
    pub width: f32,
    pub height: f32,
    /// Depth below which geometry is clipped (perspective only).
    pub near_depth: f32,
    /// 1 for parallel projection, 0 for perspective.
    pub parallel: u32,
    /// Tets in the order buffer (draw slots).
    pub n_slots: u32,
    /// `METHOD_*` in common.wgsl.
    pub method: u32,
    pub n_color_nodes: u32,
    pub n_opacity_nodes: u32,
    /// Table3d grid: lowest scalar, 1/Δs, 1/Δl, and the band's reach: in
    /// grid steps on a uniform axis, the domain's max_ds (scalar units) on a
    /// non-uniform one (`table_axis_segs` > 0), as `Table3d::lookup` clamps.
    pub table_s_lo: f32,
    pub table_inv_ds: f32,
    pub table_inv_dl: f32,
    pub table_reach: f32,
    pub table_n_s: u32,
    pub table_n_l: u32,
    /// Workgroups along x of the classify dispatch (2D for > 4M tets).
    pub groups_x: u32,
    /// Knot intervals of a non-uniform table3d scalar axis, stored after the
    /// TF nodes in the `tf_nodes` buffer as (s0, s1, x0, 1/step); 0 for a
    /// uniform axis (one scale, `table_s_lo` and `table_inv_ds`).
    pub table_axis_segs: u32,
    /// 1 where the table3d lookup interpolates optical depth
    /// (`tet_preint::Reconstruction::OpticalDepth`), 0 for trilinear RGBA.
    pub table_optical_depth: u32,
    pub _pad0: u32,
    pub _pad1: u32,
    pub _pad2: u32,
}

/// Per draw slot, written by the classify pass and read by the vertex
/// shader (`TetGeom` in common.wgsl): the silhouette in pixel coordinates
/// and how to triangulate it.
#[repr(C)]
#[derive(Debug, Clone, Copy, PartialEq, Pod, Zeroable)]
pub struct TetGeom {
    /// Hull points in polygon order, pixel coordinates. In `GEOM_THICK` mode
    /// only the first 4 are used and `hull[4..6]` carry the pt-linear RGBA of
    /// the thick point (premultiplied).
    pub hull: [[f32; 2]; 6],
    pub thick: [f32; 2],
    pub n_hull: u32,
    /// `GEOM_NONE` (draw nothing), `GEOM_THICK` (Shirley–Tuchman fan of
    /// `n_hull` triangles around the thick point) or `GEOM_CLIPPED` (fan of
    /// `n_hull − 2` triangles from `hull[0]`; the tet crosses the near plane).
    pub mode: u32,
}

/// Per draw slot, written by the classify pass and read by the fragment
/// shader (`TetShade` in common.wgsl): everything that turns a pixel into
/// its ray segment (Sf, Sb, l), as in `tet_render::project::TetSetup`.
#[repr(C)]
#[derive(Debug, Clone, Copy, PartialEq, Pod, Zeroable)]
pub struct TetShade {
    /// Face planes as affine functions of the pixel position (q0, qx, qy):
    /// 1/depth for perspective, depth for parallel; w = +1 front face,
    /// −1 back face, 0 unused (edge-on).
    pub planes: [[f32; 4]; 4],
    /// The scalar along the ray at depth z: (a0 + ax·x + ay·y) +
    /// z·(b0 + bx·x + by·y); `s_a.w` / `s_b.w` are the tet's smallest and
    /// largest vertex scalar (segments are clamped into them).
    pub s_a: [f32; 4],
    pub s_b: [f32; 4],
    /// (largest edge length, 1/near depth when the tet is clipped else 0, 0, 0).
    pub extra: [f32; 4],
}

/// Tone-mapping parameters (`ToneParams` in tonemap.wgsl).
#[repr(C)]
#[derive(Debug, Clone, Copy, PartialEq, Pod, Zeroable)]
pub struct ToneParams {
    /// Linear RGB under the volume; w unused.
    pub background: [f32; 4],
    pub width: u32,
    pub height: u32,
    /// Workgroups of the reduction pass (partials to combine).
    pub n_partials: u32,
    /// 0: `ToneMap::None` (clamped linear), 1: Reinhard.
    pub reinhard: u32,
    pub key: f32,
    pub exposure: f32,
    pub groups_x: u32,
    pub _pad: u32,
}

/// The fitted operator (`ToneFit` in tonemap.wgsl), as `tet_render::image::Reinhard`.
#[repr(C)]
#[derive(Debug, Clone, Copy, PartialEq, Pod, Zeroable)]
pub struct ToneFit {
    pub scale: f32,
    pub white_sq: f32,
    pub log_average: f32,
    pub _pad: f32,
}

/// Parameters of one dispatch of sort.wgsl (`SortParams` there): prefix
/// sums, radix passes and the centroid-depth keys.
#[repr(C)]
#[derive(Debug, Clone, Copy, PartialEq, Pod, Zeroable)]
pub struct SortParams {
    /// Eye relative to the mesh centre and the unit view direction (depth
    /// keys only); w unused.
    pub eye_rel: [f32; 4],
    pub forward: [f32; 4],
    /// Elements to scan or sort.
    pub n: u32,
    /// Bit offset of the radix digit.
    pub shift: u32,
    /// Blocks of the pass (scan: block sums; radix: histogram columns).
    pub n_blocks: u32,
    /// Workgroups along x of a 2D dispatch.
    pub groups_x: u32,
}

/// Parameters of one dispatch of bin.wgsl (`BinParams` there).
#[repr(C)]
#[derive(Debug, Clone, Copy, PartialEq, Pod, Zeroable)]
pub struct BinParams {
    pub tiles_x: u32,
    pub tiles_y: u32,
    /// Slots of the chunk.
    pub n_slots: u32,
    pub groups_x: u32,
    /// Slots whose pairs this pass writes, and the pair index of `slot_lo`'s
    /// first pair (pairs of a chunk too many for one pass go in several).
    pub slot_lo: u32,
    pub slot_hi: u32,
    pub pair_base: u32,
    pub n_pairs: u32,
}

/// Parameters of the table3d bake (`BakeParams` in bake.wgsl).
#[repr(C)]
#[derive(Debug, Clone, Copy, PartialEq, Pod, Zeroable)]
pub struct BakeParams {
    pub n_s: u32,
    pub n_l: u32,
    /// TF rows in the `tf` buffer: colour nodes, then opacity nodes.
    pub n_color: u32,
    pub n_opacity: u32,
    /// Distinct TF node positions in the `breaks` buffer.
    pub n_breaks: u32,
    /// Widest row of the band (the dispatch's y extent).
    pub row_width: u32,
    /// 1 for independent emission, 0 for density emission.
    pub independent: u32,
    /// 1: round the running sums to f16 after every piece (precision study).
    pub f16: u32,
    /// Δl and the longest length (world units).
    pub dl: f32,
    pub len_max: f32,
    /// Pieces per scalar grid step along a segment.
    pub oversampling: f32,
    /// Largest l_max·|Δρ|·Δu of one piece before it is split.
    pub bend: f32,
}

/// Parameters of the poly1/2/4 bake (`PolyBakeParams` in poly_bake.wgsl).
#[repr(C)]
#[derive(Debug, Clone, Copy, PartialEq, Pod, Zeroable)]
pub struct PolyBakeParams {
    /// Polynomial degree n (1, 2 or 4).
    pub degree: u32,
    /// Table resolution N and entries per stored row (N, or 2·band + 1).
    pub res: u32,
    pub row_len: u32,
    /// Band half-width, `u32::MAX` for the full square.
    pub band: u32,
    /// Merged TF nodes in the `nodes` buffer.
    pub n_nodes: u32,
    /// 1 for independent emission, 0 for density emission.
    pub independent: u32,
    pub _pad0: u32,
    pub _pad1: u32,
    /// Longest segment (world units).
    pub l_max: f32,
    pub _pad2: f32,
    pub _pad3: f32,
    pub _pad4: f32,
}

/// What the 2D-table methods need besides the `Frame` (`ShadeParams` in
/// fragment.wgsl), one uniform per [`crate::GpuShader`]; fields a method
/// does not use are 0.
#[repr(C)]
#[derive(Debug, Clone, Copy, PartialEq, Pod, Zeroable)]
pub struct ShadeParams {
    /// Lowest scalar of the table's range (poly, atlas2d).
    pub s_lo: f32,
    /// Scalar → table axis: (res − 1)/(s_hi − s_lo) grid steps (poly),
    /// 1/(s_hi − s_lo) (atlas2d's normalisation).
    pub s_scale: f32,
    /// 1/l_max (poly's t = l/l_max, atlas2d's normalised l).
    pub inv_l_max: f32,
    /// Entries of the α table per unit optical depth (poly).
    pub alpha_inv_step: f32,
    /// Largest κ per channel (poly's clamp); w unused.
    pub max_color: [f32; 4],
    /// Table side: poly N, partial's Ψ side, atlas2d's plane side.
    pub res: u32,
    /// Poly band half-width, [`NO_BAND`] for the full square.
    pub band: u32,
    /// Poly degree n.
    pub degree: u32,
    /// 1 for independent emission, 0 for density emission.
    pub independent: u32,
    /// Entries of the 16-bit α table (poly).
    pub alpha_len: u32,
    /// Atlas2d: planes P and tiles per image row.
    pub planes: u32,
    pub cols: u32,
    /// Partial and biv-approx: the TF's merged control points in `tf_nodes`
    /// from row `knots`, two rows each ((x, κ), (ρ, 0, 0, 0)), `n_knots` of them.
    pub knots: u32,
    pub n_knots: u32,
    /// Biv-approx: the 2D widgets in `tf_nodes` from row `widgets`, four
    /// rows each (see fragment.wgsl), and the sub-segments per segment (k).
    pub widgets: u32,
    pub n_widgets: u32,
    pub subsegments: u32,
}

/// [`ShadeParams::band`] of a poly table stored as the full square.
pub const NO_BAND: u32 = u32::MAX;

/// One light of [`LightParams`] (`GpuLight` in lighting.wgsl).
#[repr(C)]
#[derive(Debug, Clone, Copy, PartialEq, Pod, Zeroable)]
pub struct GpuLight {
    /// xyz: a directional light's unit direction of travel (world frame),
    /// a point light's position relative to the mesh centre (the GPU's
    /// positions), unused for the headlight; w: the intensity.
    pub v: [f32; 4],
    /// `LIGHT_*`.
    pub kind: u32,
    pub _pad0: u32,
    pub _pad1: u32,
    pub _pad2: u32,
}

/// `tet_render::Shading` on the GPU (`LightParams` in lighting.wgsl): the
/// material, the lights, silhouettes, the gradient floor and
/// `light_segment`'s split rule. Shadows: [`GpuShadowMap`].
#[repr(C)]
#[derive(Debug, Clone, Copy, PartialEq, Pod, Zeroable)]
pub struct LightParams {
    pub ambient: f32,
    pub diffuse: f32,
    pub specular: f32,
    pub shininess: f32,
    /// Lights in `lights`.
    pub n_lights: u32,
    /// 1 with lighting (a material), 0 without.
    pub lit: u32,
    /// 1 with silhouettes (exponent `silhouette_exp`), 0 without.
    pub silhouette: u32,
    pub silhouette_exp: f32,
    /// `Shading::gradient_floor` (0: no fade).
    pub gradient_floor: f32,
    /// `tet_render::LIT_SPLIT_TOLERANCE` and `LIT_MAX_PIECES`.
    pub split_tolerance: f32,
    pub max_pieces: u32,
    /// 1 when any shading is on (lighting or silhouettes): fragments are
    /// lit; 0: they are not, and nothing else here is read.
    pub enabled: u32,
    /// `tet_render::LIT_RESPLIT_TOLERANCE`, `LIT_MAX_SUBPIECES` and the
    /// most subpieces of one segment (`tet_preint::BATCH`, the CPU's second
    /// batch).
    pub resplit_tolerance: f32,
    pub max_subpieces: u32,
    pub subpiece_budget: u32,
    pub _pad: u32,
    pub lights: [GpuLight; MAX_GPU_LIGHTS],
}

/// One deep shadow map on the GPU (`ShadowMap` in lighting.wgsl), light i's
/// in slots [`SHADOW_SLOTS`]·i onwards:
/// `tet_render::shadow::MapLayout` in the GPU's frame (positions relative to
/// the mesh centre), its knots and ray index at offsets into the buffers
/// every light's maps share. `has_map` 0: the light casts no shadow here.
#[repr(C)]
#[derive(Debug, Clone, Copy, PartialEq, Pod, Zeroable)]
pub struct GpuShadowMap {
    /// Unit vectors across the rays and along them (w unused).
    pub e1: [f32; 4],
    pub e2: [f32; 4],
    pub d: [f32; 4],
    /// xyz: a point light's position (its rays fan out); w: 1 for a point
    /// light's map, 0 for parallel rays.
    pub origin: [f32; 4],
    pub u0: f32,
    pub v0: f32,
    pub t0: f32,
    pub du: f32,
    pub dv: f32,
    pub bin_len: f32,
    pub nu: u32,
    pub nv: u32,
    /// Where this map's knots and index records start in their buffers.
    pub knot_base: u32,
    pub index_base: u32,
    pub has_map: u32,
    /// In a light's first slot: 1 when the light's shadow is a cube of
    /// six maps, its faces in this slot and the next five
    /// (`tet_render::shadow::cube_face` order).
    pub cube: u32,
    /// Where this map's fine grid's table starts in the index buffer
    /// (`tet_render::shadow::MapLayout::levels`' first: a ray number a
    /// position, by tiles of [`SHADOW_LEVEL_TILE`]², `NO_RAY` where none),
    /// or `NO_RAY`: no fine rays.
    pub fine_base: u32,
    /// The same for the second finer grid (`MapLayout::levels[1]`), or
    /// `NO_RAY`.
    pub finer_base: u32,
    /// The same for the third (`MapLayout::levels[2]`), or `NO_RAY`.
    pub finest_base: u32,
    pub _pad2: u32,
}

/// Map slots a light has in the shadow-map buffer: one for a map, six
/// for a cube of maps (`SHADOW_SLOTS` in lighting.wgsl).
pub const SHADOW_SLOTS: usize = 6;

/// Index bins along each shadow-map ray (`SHADOW_BINS` in lighting.wgsl;
/// `tet_render::shadow::MapLayout::bins`).
pub const SHADOW_BINS: usize = 32;

/// Positions along a side of a finer grid's table tiles
/// (`SHADOW_LEVEL_TILE` in lighting.wgsl;
/// `tet_render::shadow::LEVEL_TILE`).
pub const SHADOW_LEVEL_TILE: usize = 8;

/// Finer grids a shadow map may have on the GPU (`GpuShadowMap`'s
/// `fine_base`, `finer_base`, `finest_base`).
pub const SHADOW_LEVELS: usize = 3;

/// Shadow-map rays of at most this many knots are scanned from their first
/// knot, not from a bin (`SHADOW_SHORT_RAY` in lighting.wgsl;
/// `tet_render::shadow::SHORT_RAY`).
pub const SHADOW_SHORT_RAY: usize = 8;

/// Lights a [`LightParams`] holds (`tet_render::MAX_LIGHTS`).
pub const MAX_GPU_LIGHTS: usize = 8;
pub const LIGHT_HEADLIGHT: u32 = 0;
pub const LIGHT_DIRECTIONAL: u32 = 1;
pub const LIGHT_POINT: u32 = 2;

/// Rows of the per-slot gradient fields (lighting): per component of the
/// interpolated gradient two rows like `TetShade`'s `s_a`, `s_b`.
pub const NORMAL_ROWS: u32 = 6;

/// Parameters of the culling compaction (`CullParams` in cull.wgsl).
#[repr(C)]
#[derive(Debug, Clone, Copy, PartialEq, Pod, Zeroable)]
pub struct CullParams {
    /// Slots of the order to compact.
    pub n: u32,
    /// Invisible scalar-rank intervals in the `intervals` buffer.
    pub n_intervals: u32,
    /// Workgroups along x of the 2D dispatch.
    pub groups_x: u32,
    /// 2D widgets that can make a cell visible, as rank rectangles in the
    /// `widgets` buffer.
    pub n_widgets: u32,
    /// 1 when the rectangles' |∇s| sides are compared (the scene has
    /// gradient magnitudes), 0 when any |∇s| is possible.
    pub use_g: u32,
    pub _pad0: u32,
    pub _pad1: u32,
    pub _pad2: u32,
}

/// Workgroup size of the culling passes (`CULL_WG` in cull.wgsl).
pub const CULL_WG: u32 = 64;

/// Workgroup size of the bake along l (`BAKE_WG` in bake.wgsl).
pub const BAKE_WG: u32 = 64;
/// Workgroup size of the table probe (probe.wgsl).
pub const PROBE_WG: u32 = 64;

/// Side of a compute-raster tile in pixels (`TILE` in bin.wgsl; the
/// composite workgroup is TILE × TILE).
pub const TILE_PX: u32 = 16;
/// Workgroup size of bin_count / bin_fill / tile_ranges (`BIN_WG`).
pub const BIN_WG: u32 = 64;
/// Elements a scan workgroup handles (`SCAN_BLOCK` in sort.wgsl).
pub const SCAN_BLOCK: u32 = 1024;
/// Elements a radix workgroup handles, and the digit width.
pub const RADIX_BLOCK: u32 = 256;
pub const RADIX_BITS: u32 = 4;
/// Stride of the per-dispatch uniform arena (dynamic offsets).
pub const PARAM_STRIDE: u64 = 256;

/// Classify workgroup size (`@workgroup_size` in classify.wgsl).
pub const CLASSIFY_WG: u32 = 64;
/// Tone-mapping workgroup size (tonemap.wgsl).
pub const TONE_WG: u32 = 256;
/// Vertices drawn per slot: at most 4 triangles (class 2, or a clipped hull of 6).
pub const VERTS_PER_SLOT: u32 = 12;

pub const METHOD_PT_LINEAR: u32 = 0;
pub const METHOD_TABLE3D: u32 = 1;
pub const METHOD_POLY: u32 = 2;
pub const METHOD_PARTIAL: u32 = 3;
pub const METHOD_ATLAS2D: u32 = 4;
pub const METHOD_BIV_APPROX: u32 = 5;
pub const METHOD_BIV_EXACT: u32 = 6;

pub const GEOM_NONE: u32 = 0;
pub const GEOM_THICK: u32 = 1;
pub const GEOM_CLIPPED: u32 = 2;

#[cfg(test)]
mod tests {
    use super::*;
    use std::mem::{align_of, size_of};

    /// Sizes a multiple of 16 and 4-byte alignment; the field offsets are
    /// checked against naga's layout of the WGSL structs in tests/shaders.rs.
    #[test]
    fn sizes_are_multiples_of_16() {
        assert_eq!(size_of::<FrameUniforms>(), 160);
        assert_eq!(size_of::<TetGeom>(), 64);
        assert_eq!(size_of::<TetShade>(), 112);
        assert_eq!(size_of::<ToneParams>(), 48);
        assert_eq!(size_of::<ToneFit>(), 16);
        assert_eq!(size_of::<SortParams>(), 48);
        assert_eq!(size_of::<BinParams>(), 32);
        assert_eq!(size_of::<BakeParams>(), 48);
        assert_eq!(size_of::<PolyBakeParams>(), 48);
        assert_eq!(size_of::<ShadeParams>(), 80);
        assert_eq!(size_of::<CullParams>(), 32);
        assert_eq!(size_of::<GpuLight>(), 32);
        assert_eq!(size_of::<LightParams>(), 320);
        assert_eq!(size_of::<GpuShadowMap>(), 128);
        assert_eq!(MAX_GPU_LIGHTS, tet_render::MAX_LIGHTS);
        assert_eq!(SHADOW_LEVELS, tet_render::shadow::MAX_LEVELS);
        assert_eq!(SHADOW_LEVEL_TILE, tet_render::shadow::LEVEL_TILE);
        for (s, a) in [
            (size_of::<FrameUniforms>(), align_of::<FrameUniforms>()),
            (size_of::<TetGeom>(), align_of::<TetGeom>()),
            (size_of::<TetShade>(), align_of::<TetShade>()),
            (size_of::<ToneParams>(), align_of::<ToneParams>()),
            (size_of::<ToneFit>(), align_of::<ToneFit>()),
            (size_of::<SortParams>(), align_of::<SortParams>()),
            (size_of::<BinParams>(), align_of::<BinParams>()),
            (size_of::<BakeParams>(), align_of::<BakeParams>()),
            (size_of::<PolyBakeParams>(), align_of::<PolyBakeParams>()),
            (size_of::<ShadeParams>(), align_of::<ShadeParams>()),
            (size_of::<CullParams>(), align_of::<CullParams>()),
            (size_of::<GpuLight>(), align_of::<GpuLight>()),
            (size_of::<LightParams>(), align_of::<LightParams>()),
            (size_of::<GpuShadowMap>(), align_of::<GpuShadowMap>()),
        ] {
            assert_eq!(s % 16, 0);
            assert_eq!(a, 4);
        }
    }
}
