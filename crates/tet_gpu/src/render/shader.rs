//! What colours fragments on the GPU (`GpuShader`): pt-linear's TF nodes,
//! table3d's texture and scalar axis, and the table-texture helpers the
//! 2D-table methods share.

use super::*;

/// What colours fragments: a method with its data on the GPU.
pub struct GpuShader {
    pub(crate) method: u32,
    /// The method id (`METHOD_POLY` serves poly1, poly2 and poly4).
    pub(crate) id: Method,
    pub(crate) tf_nodes: wgpu::Buffer,
    pub(crate) n_color: u32,
    pub(crate) n_opacity: u32,
    pub(crate) table: wgpu::Texture,
    pub(crate) table_params: [f32; 4],
    pub(crate) table_dims: [u32; 2],
    /// Knot intervals of a non-uniform scalar axis (after the TF nodes in
    /// `tf_nodes`); 0 for a uniform axis.
    pub(crate) axis_segs: u32,
    /// Table3d's lookup interpolates optical depth
    /// (`Reconstruction::OpticalDepth`) rather than RGBA.
    pub(crate) optical_depth: bool,
    /// The 2D-table methods' tables (1×1 placeholders for the others):
    /// an Rgba32Float 2D array texture and poly's 16-bit α table.
    pub(crate) table2d: wgpu::Texture,
    pub(crate) alpha: wgpu::Texture,
    /// `ShadeParams` as a uniform buffer.
    pub(crate) shade_buf: wgpu::Buffer,
}

/// How a table3d's grid reaches the shaders: `FrameUniforms`' table fields
/// and, for a non-uniform scalar axis, the knot intervals.
pub(crate) struct TableGrid {
    pub params: [f32; 4],
    pub dims: [u32; 2],
    pub axis: Vec<[f32; 4]>,
    /// The lookup interpolates optical depth (`Reconstruction::OpticalDepth`).
    pub optical_depth: bool,
}

impl TableGrid {
    /// The grid of a shader without a table3d (fields no lookup reads).
    pub fn none() -> TableGrid {
        TableGrid { params: [0.0, 1.0, 1.0, 0.0], dims: [2, 2], axis: vec![], optical_depth: false }
    }

    /// The same f64 → f32 steps as `Table3d::from_parts`, `Band::new` and
    /// the axis's knot intervals, so the grid coordinates agree with the
    /// CPU lookup (bit for bit on a uniform axis; on a non-uniform one up to
    /// f32 rounding where a scalar sits on a knot, the map being continuous).
    pub fn new(domain: &TableDomain, n_s: usize, n_l: usize, knots: &[(f64, usize)], uniform: bool) -> TableGrid {
        let d = domain;
        let span = d.scalar_span();
        let step = span / (n_s - 1) as f64;
        let inv_ds = ((n_s - 1) as f64 / span) as f32;
        let inv_dl = ((n_l - 1) as f64 / d.len_max_world) as f32;
        if uniform {
            let reach = (d.max_ds / step).min((n_s - 1) as f64) as f32;
            return TableGrid {
                params: [d.s_lo as f32, inv_ds, inv_dl, reach],
                dims: [n_s as u32, n_l as u32],
                axis: vec![],
                optical_depth: false,
            };
        }
        let axis = knots
            .windows(2)
            .map(|w| {
                let ((s0, i0), (s1, i1)) = (w[0], w[1]);
                [s0 as f32, s1 as f32, i0 as f32, ((i1 - i0) as f64 / (s1 - s0)) as f32]
            })
            .collect();
        TableGrid {
            params: [d.s_lo as f32, inv_ds, inv_dl, d.max_ds as f32],
            dims: [n_s as u32, n_l as u32],
            axis,
            optical_depth: false,
        }
    }
}

impl GpuShader {
    /// `pt-linear`: the thick point's segment shaded once per tet with the
    /// transfer function (κ mean, α = 1 − e^{−l·ρ̄}), interpolated towards
    /// the silhouette. Clipped tets are shaded per fragment.
    pub fn pt_linear(ctx: &GpuContext, tf: &TransferFunction) -> Result<GpuShader, GpuError> {
        GpuShader::with_table(ctx, METHOD_PT_LINEAR, Some(tf), placeholder_3d(ctx)?, TableGrid::none())
    }

    /// `table3d`: the band of the table expanded into a full
    /// n_l × n_s × n_s Rgba32Float 3D texture (zeros outside the band, which
    /// a lookup never reaches) and looked up trilinearly per fragment with
    /// `Table3d::lookup`'s clamping (8 texel loads; no hardware filtering,
    /// whose 8-bit weights would differ from the CPU). Either scalar axis:
    /// a non-uniform one ([`tet_preint::ScalarAxis::TfNodes`]) maps scalars
    /// to grid indices through its knot intervals as the CPU does.
    pub fn table3d(ctx: &GpuContext, table: &Table3d) -> Result<GpuShader, GpuError> {
        let p = table.params();
        let (n_s, n_l) = (p.n_s, p.n_l);
        check_table_dims(ctx, n_s, n_l)?;
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
        let mut grid = TableGrid::new(table.domain(), n_s, n_l, &table.s_knots(), table.is_uniform_axis());
        grid.optical_depth = table.reconstruction() == Reconstruction::OpticalDepth;
        GpuShader::with_table(ctx, METHOD_TABLE3D, None, tex, grid)
    }

    pub(crate) fn with_table(
        ctx: &GpuContext,
        method: u32,
        tf: Option<&TransferFunction>,
        table: wgpu::Texture,
        grid: TableGrid,
    ) -> Result<GpuShader, GpuError> {
        let id = if method == METHOD_TABLE3D { Method::Table3d } else { Method::PtLinear };
        let tables = Tables2d::placeholder(ctx)?;
        GpuShader::assemble(ctx, method, id, tf, table, grid, tables)
    }

    /// A shader from its parts: `tables.extra_rows` go after the TF nodes
    /// and the table3d axis in `tf_nodes` (their first row's index is set in
    /// `tables.params.knots` and added to `tables.params.widgets`).
    pub(crate) fn assemble(
        ctx: &GpuContext,
        method: u32,
        id: Method,
        tf: Option<&TransferFunction>,
        table: wgpu::Texture,
        grid: TableGrid,
        mut tables: Tables2d,
    ) -> Result<GpuShader, GpuError> {
        let mut nodes: Vec<[f32; 4]> = Vec::new();
        let (mut n_color, mut n_opacity) = (0, 0);
        if let Some(tf) = tf {
            nodes.extend(tf_node_rows(tf));
            n_color = tf.color_nodes().len() as u32;
            n_opacity = tf.opacity_nodes().len() as u32;
        }
        nodes.extend(&grid.axis);
        if !tables.extra_rows.is_empty() {
            // The extra rows start with the merged knots; the widgets'
            // offset is given relative to them.
            tables.params.knots = nodes.len() as u32;
            tables.params.widgets += nodes.len() as u32;
            nodes.extend(&tables.extra_rows);
        }
        if nodes.is_empty() {
            nodes.push([0.0; 4]);
        }
        let limit = ctx.device.limits().max_storage_buffer_binding_size;
        check_size("transfer function rows (16 bytes each)", nodes.len() as u64 * 16, limit)?;
        let dev = &ctx.device;
        let params = bytemuck::bytes_of(&tables.params);
        let shade_buf = ctx.checked(|| buffer_init(dev, "shade params", params, wgpu::BufferUsages::UNIFORM))?;
        let rows = bytemuck::cast_slice(&nodes);
        let tf_nodes = ctx.checked(|| buffer_init(dev, "tf nodes", rows, wgpu::BufferUsages::STORAGE))?;
        Ok(GpuShader {
            method,
            id,
            tf_nodes,
            n_color,
            n_opacity,
            table,
            table_params: grid.params,
            table_dims: grid.dims,
            axis_segs: grid.axis.len() as u32,
            optical_depth: grid.optical_depth,
            table2d: tables.table2d,
            alpha: tables.alpha,
            shade_buf,
        })
    }

    /// The method id (`pt-linear`, `table3d`, `poly2`, …).
    pub fn method_id(&self) -> &'static str {
        self.id.id()
    }

    /// The method.
    pub fn method_kind(&self) -> Method {
        self.id
    }

    pub(crate) fn method(&self) -> u32 {
        self.method
    }

    /// The frame uniforms this shader sets (method, TF rows, table3d grid
    /// and lookup); the camera's fields are zero.
    pub(crate) fn frame_fields(&self) -> FrameUniforms {
        FrameUniforms {
            method: self.method,
            n_color_nodes: self.n_color,
            n_opacity_nodes: self.n_opacity,
            table_s_lo: self.table_params[0],
            table_inv_ds: self.table_params[1],
            table_inv_dl: self.table_params[2],
            table_reach: self.table_params[3],
            table_n_s: self.table_dims[0],
            table_n_l: self.table_dims[1],
            table_axis_segs: self.axis_segs,
            table_optical_depth: self.optical_depth as u32,
            ..bytemuck::Zeroable::zeroed()
        }
    }
}

/// The TF as the shaders read it: colour nodes (x, r, g, b), then opacity
/// nodes (x, ρ, 0, 0) with ρ = a / unit_distance.
pub(crate) fn tf_node_rows(tf: &TransferFunction) -> Vec<[f32; 4]> {
    let u = tf.unit_distance();
    tf.color_nodes()
        .iter()
        .map(|c| [c.x as f32, c.rgb[0] as f32, c.rgb[1] as f32, c.rgb[2] as f32])
        .chain(tf.opacity_nodes().iter().map(|o| [o.x as f32, (o.a / u) as f32, 0.0, 0.0]))
        .collect()
}

/// A table's axes within the device's 3D texture limit and the cube within 2 GiB.
pub(crate) fn check_table_dims(ctx: &GpuContext, n_s: usize, n_l: usize) -> Result<(), GpuError> {
    let max3d = ctx.device.limits().max_texture_dimension_3d as usize;
    if n_s > max3d || n_l > max3d {
        return Err(GpuError::TooLarge {
            what: "table3d axis (texels)",
            bytes: n_s.max(n_l) as u64,
            limit: max3d as u64,
        });
    }
    check_size("table3d as a full cube", (n_s * n_s * n_l * 16) as u64, 1 << 31)
}

/// A 1×1×1 table3d texture for shaders that read none.
pub(crate) fn placeholder_3d(ctx: &GpuContext) -> Result<wgpu::Texture, GpuError> {
    table_texture(ctx, [1, 1, 1], &[[0.0; 4]])
}

pub(crate) fn table_texture(ctx: &GpuContext, size: [u32; 3], texels: &[[f32; 4]]) -> Result<wgpu::Texture, GpuError> {
    let (dim, format) = (wgpu::TextureDimension::D3, wgpu::TextureFormat::Rgba32Float);
    upload_texture(ctx, "table3d", dim, format, size, bytemuck::cast_slice(texels))
}
