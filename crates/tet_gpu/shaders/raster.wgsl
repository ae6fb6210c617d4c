// Raster pass: 12 vertices per draw slot (at most 4 triangles), pulled
// from the classify pass's TetGeom (no vertex buffer); the fragment shader
// turns the pixel into its ray segment from the slot's TetShade and shades
// it. Slots are drawn in visibility order, front to back, with the "under"
// blend (dst += (1 − dst.α)·src) that tet_render's rasterizer computes.

@group(0) @binding(0) var<uniform> fr: Frame;
@group(0) @binding(5) var<storage, read> geoms: array<TetGeom>;
@group(0) @binding(6) var<storage, read> shades: array<TetShade>;
// Table3d as an n_s × n_s × n_l cube: texel (k, b, a) = T(s_a, s_b, l_k).
@group(0) @binding(8) var table: texture_3d<f32>;

struct VOut {
    @builtin(position) pos: vec4<f32>,
    // 1 at the thick point, 0 on the silhouette (pt-linear), linear in screen space.
    @location(0) @interpolate(linear) tent: f32,
    @location(1) @interpolate(flat) slot: u32,
    @location(2) @interpolate(flat) mode: u32,
    @location(3) @interpolate(flat) thick_rgba: vec4<f32>,
}

@vertex
fn vs(@builtin(vertex_index) vi: u32) -> VOut {
    let slot = vi / VERTS_PER_SLOT;
    let corner = vi % VERTS_PER_SLOT;
    let tri = corner / 3u;
    let j = corner % 3u;
    let g = geoms[slot];
    var out: VOut;
    out.slot = slot;
    out.mode = g.mode;
    out.tent = 0.0;
    out.thick_rgba = vec4<f32>(g.hull[4], g.hull[5]);
    var p = vec2<f32>(0.0);
    var used = false;
    if g.mode == GEOM_THICK && tri < g.n_hull {
        used = true;
        if j == 0u {
            p = g.thick;
            out.tent = 1.0;
        } else if j == 1u {
            p = g.hull[tri];
        } else {
            p = g.hull[(tri + 1u) % g.n_hull];
        }
    } else if g.mode == GEOM_CLIPPED && tri + 2u < g.n_hull {
        used = true;
        if j == 0u {
            p = g.hull[0];
        } else {
            p = g.hull[tri + j];
        }
    }
    if used {
        out.pos = vec4<f32>(2.0 * p.x / fr.width - 1.0, 1.0 - 2.0 * p.y / fr.height, 0.5, 1.0);
    } else {
        // All three corners of an unused triangle coincide outside the view: no fragments.
        out.pos = vec4<f32>(-2.0, -2.0, 0.5, 1.0);
    }
    return out;
}

// Trilinear lookup with Table3d::lookup's normalisation: inputs clamped to
// the grid, Sb clamped to within the band's reach of Sf.
fn table_lookup(sf: f32, sb: f32, len: f32) -> vec4<f32> {
    let top = f32(fr.table_n_s - 1u);
    let xa = clamp((sf - fr.table_s_lo) * fr.table_inv_ds, 0.0, top);
    let xb0 = clamp((sb - fr.table_s_lo) * fr.table_inv_ds, 0.0, top);
    let xb = min(max(xb0, xa - fr.table_reach), xa + fr.table_reach);
    let xk = clamp(len * fr.table_inv_dl, 0.0, f32(fr.table_n_l - 1u));
    let a0 = min(u32(xa), fr.table_n_s - 2u);
    let b0 = min(u32(xb), fr.table_n_s - 2u);
    let k0 = min(u32(xk), fr.table_n_l - 2u);
    let fa = xa - f32(a0);
    let fb = xb - f32(b0);
    let fk = xk - f32(k0);
    var out = vec4<f32>(0.0);
    for (var da = 0u; da < 2u; da++) {
        let wa = select(1.0 - fa, fa, da == 1u);
        for (var db = 0u; db < 2u; db++) {
            let wb = select(1.0 - fb, fb, db == 1u);
            let w = wa * wb;
            if w == 0.0 {
                continue;
            }
            let e0 = textureLoad(table, vec3<i32>(i32(k0), i32(b0 + db), i32(a0 + da)), 0);
            let e1 = textureLoad(table, vec3<i32>(i32(k0 + 1u), i32(b0 + db), i32(a0 + da)), 0);
            out += w * (e0 + fk * (e1 - e0));
        }
    }
    return out;
}

@fragment
fn fs(v: VOut) -> @location(0) vec4<f32> {
    if fr.method == METHOD_PT_LINEAR && v.mode == GEOM_THICK {
        let lam = clamp(v.tent, 0.0, 1.0);
        if lam <= 0.0 {
            discard;
        }
        return v.thick_rgba * lam;
    }
    let seg = segment_at(fr, shades[v.slot], v.pos.x, v.pos.y);
    if !seg.ok {
        discard;
    }
    if fr.method == METHOD_TABLE3D {
        return table_lookup(seg.sf, seg.sb, seg.len);
    }
    return shade_pt_linear(fr, seg);
}
