// Raster pass: 12 vertices per draw slot (at most 4 triangles), pulled
// from the classify pass's TetGeom (no vertex buffer); the fragment shader
// turns the pixel into its ray segment from the slot's TetShade and shades
// it. Slots are drawn in visibility order, front to back, with the "under"
// blend (dst += (1 − dst.α)·src) that tet_render's rasterizer computes.

@group(0) @binding(0) var<uniform> fr: Frame;
@group(0) @binding(5) var<storage, read> geoms: array<TetGeom>;


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

@fragment
fn fs(v: VOut) -> @location(0) vec4<f32> {
    let f = fragment_color(fr, v.mode, v.thick_rgba, v.tent, v.slot, v.pos.x, v.pos.y);
    if !f.ok {
        discard;
    }
    return f.rgba;
}
