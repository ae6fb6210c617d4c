//! The 2D-table methods on the GPU — `poly1/2/4` (Guthe et al. 2002), `partial`
//! (Moreland & Angel's Ψ) and `atlas2d` (Röttger & Ertl's (2002) cylindrical atlas) — and
//! the bivariate `biv-approx` and `biv-exact` (Song et al. 2009) as [`GpuShader`]s
//! built from tet_preint's baked methods, [`GpuShader::from_baked`] for any
//! method the GPU renders, and [`GpuShader::probe`]: the per-fragment
//! function at given (Sf, Sb, l) triples.
//!
//! Every lookup reads texels with `textureLoad` and interpolates in the
//! shader with the CPU's weights and clamps (fragment.wgsl), so GPU and CPU
//! agree to f32 rounding: no hardware filtering (8-bit weights). biv-exact
//! has no table: it integrates per fragment (biv_exact.wgsl).

use crate::gpu_types::{
    ShadeParams, METHOD_ATLAS2D, METHOD_BIV_APPROX, METHOD_BIV_EXACT, METHOD_PARTIAL, METHOD_POLY, METHOD_PT_LINEAR,
    METHOD_TABLE3D, NO_BAND, PROBE_WG,
};
use crate::render::{
    bind, bind_all, bind_group, bind_view, buffer, buffer_init, dispatch, placeholder_3d, storage_entry, texture_entry,
    uint_texture_entry, uniform_entry, upload_texture, GpuShader, TableGrid, READ_BACK,
};
use crate::{map_read, shader_source_fragment, GpuContext, GpuError, PROBE_WGSL};
use tet_preint::{
    Atlas2d, Baked, BivApprox, BivExact, Emission, Method, PartialShader, PolyTable, Segment, Shape, TransferFunction,
};

/// The methods [`GpuShader::from_baked`] accepts, in `Method::ALL`'s order.
pub const GPU_METHODS: [Method; 9] = [
    Method::PtLinear,
    Method::Table3d,
    Method::Atlas2d,
    Method::Poly1,
    Method::Poly2,
    Method::Poly4,
    Method::Partial,
    Method::BivExact,
    Method::BivApprox,
];

/// The 2D tables of a shader and their parameters, before upload of the TF rows.
pub(crate) struct Tables2d {
    pub table2d: wgpu::Texture,
    pub alpha: wgpu::Texture,
    pub params: ShadeParams,
    /// Rows appended to `tf_nodes` (partial's merged knots).
    pub extra_rows: Vec<[f32; 4]>,
}

impl Tables2d {
    /// 1×1 placeholders for the methods without 2D tables.
    pub fn placeholder(ctx: &GpuContext) -> Result<Tables2d, GpuError> {
        Ok(Tables2d {
            table2d: texture_2d_array(ctx, [1, 1, 1], &[[0.0; 4]])?,
            alpha: alpha_texture(ctx, &[0])?,
            params: bytemuck::Zeroable::zeroed(),
            extra_rows: Vec::new(),
        })
    }
}

/// An Rgba32Float 2D array texture of `size` = (width, height, layers),
/// texels layer by layer, row-major.
fn texture_2d_array(ctx: &GpuContext, size: [u32; 3], texels: &[[f32; 4]]) -> Result<wgpu::Texture, GpuError> {
    let lim = ctx.device.limits();
    if size[0].max(size[1]) > lim.max_texture_dimension_2d {
        return Err(GpuError::TooLarge {
            what: "2D table side (texels)",
            bytes: size[0].max(size[1]) as u64,
            limit: lim.max_texture_dimension_2d as u64,
        });
    }
    if size[2] > lim.max_texture_array_layers {
        return Err(GpuError::TooLarge {
            what: "2D table layers",
            bytes: size[2] as u64,
            limit: lim.max_texture_array_layers as u64,
        });
    }
    let (dim, format) = (wgpu::TextureDimension::D2, wgpu::TextureFormat::Rgba32Float);
    upload_texture(ctx, "table2d", dim, format, size, bytemuck::cast_slice(texels))
}

/// Poly's α table as an R16Uint 1D texture: the 16-bit samples themselves.
fn alpha_texture(ctx: &GpuContext, data: &[u16]) -> Result<wgpu::Texture, GpuError> {
    let max = ctx.device.limits().max_texture_dimension_1d;
    if data.len() as u64 > max as u64 {
        return Err(GpuError::TooLarge { what: "α table entries", bytes: data.len() as u64, limit: max as u64 });
    }
    let (dim, format) = (wgpu::TextureDimension::D1, wgpu::TextureFormat::R16Uint);
    upload_texture(ctx, "alpha table", dim, format, [data.len() as u32, 1, 1], bytemuck::cast_slice(data))
}

impl GpuShader {
    /// `poly1`, `poly2`, `poly4` (Guthe et al. 2002): ρ̂ and the chromaticity
    /// polynomials' coefficients C̃ᵣ as an Rgba32Float 2D array texture in
    /// the table's own storage (a full square or diagonal bands; layer r
    /// holds C̃ᵣ, layer 0 also ρ̂), the 16-bit α table as an R16Uint 1D
    /// texture, looked up per fragment as `PolyTable::lookup` (bilinear in
    /// (Sf, Sb), α(l·ρ̂), C = w·Σ C̃ᵣ (l/l_max)ʳ, clamped). The table may come
    /// from the CPU bake or from [`crate::bake_poly`].
    pub fn poly(ctx: &GpuContext, table: &PolyTable) -> Result<GpuShader, GpuError> {
        let (n, res, row_len) = (table.degree(), table.res(), table.row_len());
        let stride = 3 * (n + 1);
        let (rho, coef) = (table.rho(), table.coef());
        let cells = res * row_len;
        if res > u32::MAX as usize / 16 {
            return Err(GpuError::TooLarge { what: "poly resolution", bytes: res as u64, limit: u32::MAX as u64 / 16 });
        }
        let mut texels = vec![[0.0f32; 4]; cells * (n + 1)];
        for (r, layer) in texels.chunks_mut(cells).enumerate() {
            for (e, t) in layer.iter_mut().enumerate() {
                let c = &coef[e * stride + r * 3..e * stride + r * 3 + 3];
                *t = [c[0], c[1], c[2], if r == 0 { rho[e] } else { 0.0 }];
            }
        }
        let table2d = texture_2d_array(ctx, [row_len as u32, res as u32, (n + 1) as u32], &texels)?;
        let alpha_tab = table.alpha_table();
        let alpha = alpha_texture(ctx, alpha_tab.data())?;
        let [s_lo, s_hi] = table.s_range();
        let mc = table.max_color();
        let params = ShadeParams {
            s_lo,
            // The same f32 expressions as PolyTable's derived fields.
            s_scale: (res - 1) as f32 / (s_hi - s_lo),
            inv_l_max: 1.0 / table.l_max(),
            alpha_inv_step: (alpha_tab.data().len() - 1) as f32 / alpha_tab.x_max(),
            max_color: [mc[0], mc[1], mc[2], 0.0],
            res: res as u32,
            band: table.band().map_or(NO_BAND, |b| b as u32),
            degree: n as u32,
            independent: (table.emission() == Emission::Independent) as u32,
            alpha_len: alpha_tab.data().len() as u32,
            ..bytemuck::Zeroable::zeroed()
        };
        let id = match n {
            1 => Method::Poly1,
            2 => Method::Poly2,
            _ => Method::Poly4,
        };
        let tables = Tables2d { table2d, alpha, params, extra_rows: Vec::new() };
        GpuShader::assemble(ctx, METHOD_POLY, id, None, placeholder_3d(ctx)?, TableGrid::none(), tables)
    }

    /// `partial` (Moreland & Angel 2004): the TF-independent Ψ table as an
    /// Rgba32Float 2D texture over (γ_front, γ_back) and the TF's merged
    /// control points (κ, ρ at each); per fragment the segment is split at
    /// the control points between Sf and Sb and each piece composited from
    /// one bilinear Ψ lookup, as `PartialShader::integrate` (in f32 where the
    /// CPU accumulates in f64). Independent emission reads Ψ₁ from the
    /// table's second channel and, above rate 8 (where the CPU takes the f64
    /// closed form), integrates Ψ and Ψ₁ by Gauss–Legendre quadrature over
    /// the part of the piece in front of optical depth 40.
    pub fn partial(ctx: &GpuContext, shader: &PartialShader) -> Result<GpuShader, GpuError> {
        let tf = shader.transfer_function();
        let psi = shader.psi();
        let res = psi.params().res;
        let ch = psi.storage().channels();
        let values = psi.storage().to_f32();
        let texels: Vec<[f32; 4]> = (0..res * res)
            .map(|e| [values[e * ch], if ch == 2 { values[e * ch + 1] } else { 0.0 }, 0.0, 0.0])
            .collect();
        let table2d = texture_2d_array(ctx, [res as u32, res as u32, 1], &texels)?;
        let knots = merged_knots(tf);
        let params = ShadeParams {
            res: res as u32,
            n_knots: (knots.len() / 2) as u32,
            independent: (tf.emission() == Emission::Independent) as u32,
            ..bytemuck::Zeroable::zeroed()
        };
        let tables = Tables2d { table2d, alpha: alpha_texture(ctx, &[0])?, params, extra_rows: knots };
        GpuShader::assemble(ctx, METHOD_PARTIAL, Method::Partial, None, placeholder_3d(ctx)?, TableGrid::none(), tables)
    }

    /// `atlas2d` (Röttger & Ertl 2002): the tiled cylindrical atlas as one Rgba32Float
    /// 2D texture (plane p at tile (p mod cols, p div cols), as
    /// `Atlas2d::image`), looked up per fragment as `Atlas2d::lookup`:
    /// (Sf, Sb, l) normalised by the domain, Röttger & Ertl's (2002) pseudo-angle α and
    /// L∞ radius s, the two nearest planes blended, bilinear in (s, Sb).
    pub fn atlas2d(ctx: &GpuContext, atlas: &Atlas2d) -> Result<GpuShader, GpuError> {
        let (w, h) = atlas.image_size();
        let p = atlas.params();
        let table2d = texture_2d_array(ctx, [w as u32, h as u32, 1], &atlas.image())?;
        let d = atlas.domain();
        let params = ShadeParams {
            s_lo: d.s_lo as f32,
            s_scale: (1.0 / d.scalar_span()) as f32,
            inv_l_max: (1.0 / d.len_max_world) as f32,
            res: p.res as u32,
            planes: p.planes as u32,
            cols: (w / p.res) as u32,
            ..bytemuck::Zeroable::zeroed()
        };
        let tables = Tables2d { table2d, alpha: alpha_texture(ctx, &[0])?, params, extra_rows: Vec::new() };
        GpuShader::assemble(ctx, METHOD_ATLAS2D, Method::Atlas2d, None, placeholder_3d(ctx)?, TableGrid::none(), tables)
    }

    /// `biv-approx` (Song et al. 2009 §5): the F/B table as an Rgba32Float 2D
    /// texture over (α_f, α_b), the 1D TF as merged control points and the
    /// 2D widgets (box, Gaussian, triangle and sine bands with their
    /// supports) as rows; per fragment the segment's scalar and gradient
    /// magnitude (interpolated from per-vertex values:
    /// [`crate::GpuScene::with_gradient_magnitudes`]) are sampled at the ends
    /// of k equal sub-segments, each looked up in F/B and composited, as
    /// `BivApprox::integrate` (in f32 where the CPU accumulates in f64).
    pub fn biv_approx(ctx: &GpuContext, shader: &BivApprox) -> Result<GpuShader, GpuError> {
        let tf = shader.transfer_function();
        let fb = shader.table();
        let res = fb.res();
        let texels: Vec<[f32; 4]> = fb.f().iter().zip(fb.b()).map(|(&f, &b)| [f, b, 0.0, 0.0]).collect();
        let table2d = texture_2d_array(ctx, [res as u32, res as u32, 1], &texels)?;
        let mut rows = merged_knots(tf);
        let n_knots = (rows.len() / 2) as u32;
        // Relative to the first extra row here; `assemble` adds the offset.
        let widgets = rows.len() as u32;
        rows.extend(widget_rows(tf));
        let params = ShadeParams {
            res: res as u32,
            independent: (tf.emission() == Emission::Independent) as u32,
            n_knots,
            widgets,
            n_widgets: tf.widgets().len() as u32,
            subsegments: shader.subsegments() as u32,
            ..bytemuck::Zeroable::zeroed()
        };
        let tables = Tables2d { table2d, alpha: alpha_texture(ctx, &[0])?, params, extra_rows: rows };
        GpuShader::assemble(
            ctx,
            METHOD_BIV_APPROX,
            Method::BivApprox,
            None,
            placeholder_3d(ctx)?,
            TableGrid::none(),
            tables,
        )
    }

    /// `biv-exact` (Song et al. 2009, tet_preint's `BivExact`): no table; the 1D TF
    /// as merged control points and the 2D widgets as rows (as
    /// `biv_approx`), and per fragment the segment (s and |∇s| linear, the
    /// latter from [`crate::GpuScene::with_gradient_magnitudes`]) cut at
    /// every breakpoint, each piece's optical depth in closed form and its
    /// colour in closed form or by Gauss–Legendre panels
    /// (shaders/biv_exact.wgsl, which states its f32 limits and work caps).
    /// The emission-only tables of Song et al., "Bivariate Transfer Functions
    /// on Unstructured Grids", 2009, are not used: those pieces go to the
    /// quadrature too.
    pub fn biv_exact(ctx: &GpuContext, shader: &BivExact) -> Result<GpuShader, GpuError> {
        let tf = shader.transfer_function();
        let mut rows = merged_knots(tf);
        let n_knots = (rows.len() / 2) as u32;
        // Relative to the first extra row here; `assemble` adds the offset.
        let widgets = rows.len() as u32;
        rows.extend(widget_rows(tf));
        let params = ShadeParams {
            independent: (tf.emission() == Emission::Independent) as u32,
            n_knots,
            widgets,
            n_widgets: tf.widgets().len() as u32,
            ..bytemuck::Zeroable::zeroed()
        };
        let tables = Tables2d { params, extra_rows: rows, ..Tables2d::placeholder(ctx)? };
        GpuShader::assemble(
            ctx,
            METHOD_BIV_EXACT,
            Method::BivExact,
            None,
            placeholder_3d(ctx)?,
            TableGrid::none(),
            tables,
        )
    }

    /// The GPU form of a baked method ([`GPU_METHODS`]); the other
    /// (`exact`) is [`GpuError::Unsupported`].
    pub fn from_baked(ctx: &GpuContext, baked: &Baked) -> Result<GpuShader, GpuError> {
        match baked {
            Baked::PtLinear(s) => GpuShader::pt_linear(ctx, s.transfer_function()),
            Baked::Table3d(t) => GpuShader::table3d(ctx, t),
            Baked::Atlas2d(a) => GpuShader::atlas2d(ctx, a),
            Baked::Poly(t, _) => GpuShader::poly(ctx, t),
            Baked::Partial(s) => GpuShader::partial(ctx, s),
            Baked::BivApprox(s, _) => GpuShader::biv_approx(ctx, s),
            Baked::BivExact(s) => GpuShader::biv_exact(ctx, s),
            other => Err(GpuError::Unsupported(format!(
                "method {} (GPU methods: {})",
                other.method(),
                GPU_METHODS.iter().map(|m| m.id()).collect::<Vec<_>>().join(", ")
            ))),
        }
    }

    /// Views of the 2D tables as the fragment shaders bind them.
    pub(crate) fn views_2d(&self) -> (wgpu::TextureView, wgpu::TextureView) {
        let t2 = self.table2d.create_view(&wgpu::TextureViewDescriptor {
            dimension: Some(wgpu::TextureViewDimension::D2Array),
            ..Default::default()
        });
        let a = self.alpha.create_view(&wgpu::TextureViewDescriptor {
            dimension: Some(wgpu::TextureViewDimension::D1),
            ..Default::default()
        });
        (t2, a)
    }

    /// The renderer's per-fragment shading (fragment.wgsl's `shade_segment`,
    /// the function every rendered fragment calls) at each (Sf, Sb, l), read
    /// back: what a fragment with that segment gets (pt-linear: the
    /// per-fragment form clipped tets use). At most 4 194 240 triples a call.
    pub fn probe(&self, ctx: &GpuContext, triples: &[[f32; 3]]) -> Result<Vec<[f32; 4]>, GpuError> {
        let segs: Vec<Segment> = triples
            .iter()
            .map(|t| Segment { s_front: t[0], s_back: t[1], len_world: t[2], ..Default::default() })
            .collect();
        self.probe_segments(ctx, &segs)
    }

    /// [`GpuShader::probe`] on whole segments: the gradient magnitudes at
    /// entry and exit too (the bivariate methods read them).
    pub fn probe_segments(&self, ctx: &GpuContext, segs: &[Segment]) -> Result<Vec<[f32; 4]>, GpuError> {
        let max = 65535 * PROBE_WG as usize;
        if segs.len() > max {
            return Err(GpuError::Input(format!("probe: {} segments, at most {max} a call", segs.len())));
        }
        if segs.is_empty() {
            return Ok(Vec::new());
        }
        let fr = self.frame_fields();
        let input: Vec<[f32; 4]> = segs
            .iter()
            .flat_map(|s| [[s.s_front, s.s_back, s.len_world, 0.0], [s.grad_front, s.grad_back, 0.0, 0.0]])
            .collect();
        let bytes = (segs.len() * 16) as u64;
        let dev = &ctx.device;
        let readback = ctx.checked(|| {
            let cs = wgpu::ShaderStages::COMPUTE;
            let constants = [("SHADE_METHOD", self.method() as f64)];
            let (layout, pipeline) = crate::render::compute_pipeline_with(
                dev,
                "probe",
                &[
                    uniform_entry(0, cs),
                    storage_entry(7, cs, true),
                    texture_entry(8, cs, wgpu::TextureViewDimension::D3),
                    storage_entry(12, cs, true),
                    storage_entry(13, cs, false),
                    texture_entry(14, cs, wgpu::TextureViewDimension::D2Array),
                    uint_texture_entry(15, cs, wgpu::TextureViewDimension::D1),
                    uniform_entry(16, cs),
                    storage_entry(18, cs, true),
                ],
                shader_source_fragment(PROBE_WGSL),
                "probe",
                &constants,
            );
            let uni = buffer_init(dev, "probe frame", bytemuck::bytes_of(&fr), wgpu::BufferUsages::UNIFORM);
            let inp = buffer_init(dev, "probe in", bytemuck::cast_slice(&input), wgpu::BufferUsages::STORAGE);
            let gshades = buffer(dev, "probe gshades", 32, wgpu::BufferUsages::STORAGE);
            let out = buffer(dev, "probe out", bytes, wgpu::BufferUsages::STORAGE | wgpu::BufferUsages::COPY_SRC);
            let readback = buffer(dev, "probe read-back", bytes, READ_BACK);
            let view = self.table.create_view(&Default::default());
            let (t2, a) = self.views_2d();
            let mut entries = vec![bind(0, &uni), bind(7, &self.tf_nodes), bind_view(8, &view)];
            entries.extend(bind_all(12, &[&inp, &out]));
            entries.extend([bind_view(14, &t2), bind_view(15, &a), bind(16, &self.shade_buf)]);
            // No slots: the probe's segments carry their gradient magnitudes.
            entries.push(bind(18, &gshades));
            let group = bind_group(dev, "probe", &layout, &entries);
            let mut enc = dev.create_command_encoder(&Default::default());
            dispatch(&mut enc, "probe", &pipeline, &group, &[], ((segs.len() as u32).div_ceil(PROBE_WG), 1));
            enc.copy_buffer_to_buffer(&out, 0, &readback, 0, bytes);
            ctx.queue.submit([enc.finish()]);
            readback
        })?;
        let raw = map_read(ctx, &readback)?;
        Ok(bytemuck::pod_collect_to_vec::<u8, [f32; 4]>(&raw))
    }

    /// [`GpuShader::probe`] for `table3d` shaders only (an input error for
    /// the others): the table lookup every fragment runs.
    pub fn probe_table3d(&self, ctx: &GpuContext, triples: &[[f32; 3]]) -> Result<Vec<[f32; 4]>, GpuError> {
        if self.method() != METHOD_TABLE3D {
            return Err(GpuError::Input(format!("probe_table3d: the shader is {}, not table3d", self.method_id())));
        }
        self.probe(ctx, triples)
    }

    /// Whether the shader is pt-linear (shaded once per tet at the thick point).
    pub fn is_pt_linear(&self) -> bool {
        self.method() == METHOD_PT_LINEAR
    }

    /// Whether the shader reads |∇s| (biv-approx, biv-exact): the scene
    /// needs per-vertex gradient magnitudes and classify writes their field.
    pub(crate) fn is_bivariate(&self) -> bool {
        matches!(self.method(), METHOD_BIV_APPROX | METHOD_BIV_EXACT)
    }
}

/// The TF's colour and opacity node positions merged (sorted, distinct),
/// two rows each: (x, κ(x)) and (ρ(x), 0, 0, 0) — between consecutive
/// knots κ and ρ are linear, so the shader interpolates them exactly.
fn merged_knots(tf: &TransferFunction) -> Vec<[f32; 4]> {
    let mut xs: Vec<f64> = tf.color_nodes().iter().map(|c| c.x).chain(tf.opacity_nodes().iter().map(|o| o.x)).collect();
    xs.sort_by(f64::total_cmp);
    xs.dedup();
    xs.iter()
        .flat_map(|&x| {
            let k = tf.color(x);
            [[x as f32, k[0] as f32, k[1] as f32, k[2] as f32], [tf.extinction(x) as f32, 0.0, 0.0, 0.0]]
        })
        .collect()
}

/// The TF's 2D widgets as four rows each (fragment.wgsl's `widget_row`):
/// shape parameters, (colour, opacity / unit distance), the support
/// (±f32::MAX where unbounded) and the kind — for bands also the frequency
/// split as f_hi (12 significant bits) + f_lo and the phase mod 1, with
/// which biv_exact.wgsl keeps f·s − φ exact to ~1e-7 at high f·|s|.
fn widget_rows(tf: &TransferFunction) -> Vec<[f32; 4]> {
    let u = tf.unit_distance();
    let f = |x: f64| x.clamp(-f32::MAX as f64, f32::MAX as f64) as f32;
    tf.widgets()
        .iter()
        .flat_map(|w| {
            let (kind, p) = match w.shape {
                Shape::Box { center, width } => (0.0, [center[0], center[1], width[0], width[1]]),
                Shape::Gaussian { center, sigma } => (1.0, [center[0], center[1], sigma[0], sigma[1]]),
                Shape::Triangle { frequency, phase } => (2.0, [frequency, phase, 0.0, 0.0]),
                Shape::Sine { frequency, phase } => (3.0, [frequency, phase, 0.0, 0.0]),
            };
            let band = match w.shape {
                Shape::Triangle { frequency, phase } | Shape::Sine { frequency, phase } => {
                    let f_hi = f32::from_bits(f(frequency).to_bits() & 0xffff_f000);
                    [f_hi, (frequency - f64::from(f_hi)) as f32, (phase - phase.floor()) as f32]
                }
                _ => [0.0; 3],
            };
            let [[s0, s1], [g0, g1]] = w.support;
            [
                p.map(f),
                [f(w.color[0]), f(w.color[1]), f(w.color[2]), f(w.opacity / u)],
                [f(s0), f(s1), f(g0), f(g1)],
                [kind, band[0], band[1], band[2]],
            ]
        })
        .collect()
}
