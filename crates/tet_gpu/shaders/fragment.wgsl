// Per-fragment shading shared by the graphics raster (raster.wgsl) and the
// compute rasterizer (bin.wgsl): prepended to both after common.wgsl (see
// `shader_source` in lib.rs), so both paths run the same maths.

// Table3d as an n_s × n_s × n_l cube: texel (k, b, a) = T(s_a, s_b, l_k).
@group(0) @binding(8) var table: texture_3d<f32>;

// Fractional grid index of scalar s (already clamped to the axis) on a
// non-uniform table3d axis: the line of its knot interval, the intervals
// stored after the TF nodes as (s0, s1, x0, 1/step), as Table3d's axis maps
// it (the first interval whose end is not below s).
fn table_axis_x(fr: Frame, s: f32, top: f32) -> f32 {
    let o = fr.n_color_nodes + fr.n_opacity_nodes;
    let n = fr.table_axis_segs;
    // Binary search (interval ends increase): a data-driven axis has one
    // interval per grid step, so a linear scan would cost O(n_s).
    var j = 0u;
    var hi = n - 1u;
    while j < hi {
        let mid = (j + hi) / 2u;
        if tf_nodes[o + mid].y < s {
            j = mid + 1u;
        } else {
            hi = mid;
        }
    }
    let g = tf_nodes[o + j];
    return clamp(g.z + (s - g.x) * g.w, 0.0, top);
}

// Trilinear lookup with Table3d::lookup's normalisation: inputs clamped to
// the grid, Sb clamped to within the band's reach of Sf (in grid steps on a
// uniform axis, in scalar units, before the index map, on a non-uniform one).
fn table_lookup(fr: Frame, sf: f32, sb: f32, len: f32) -> vec4<f32> {
    let top = f32(fr.table_n_s - 1u);
    var xa: f32;
    var xb: f32;
    if fr.table_axis_segs == 0u {
        xa = clamp((sf - fr.table_s_lo) * fr.table_inv_ds, 0.0, top);
        let xb0 = clamp((sb - fr.table_s_lo) * fr.table_inv_ds, 0.0, top);
        xb = min(max(xb0, xa - fr.table_reach), xa + fr.table_reach);
    } else {
        let o = fr.n_color_nodes + fr.n_opacity_nodes;
        let lo = tf_nodes[o].x;
        let hi = tf_nodes[o + fr.table_axis_segs - 1u].y;
        let ds = fr.table_reach;
        let sfc = min(max(sf, lo), hi);
        let sbc = min(max(min(max(sb, lo), hi), sfc - ds), sfc + ds);
        xa = table_axis_x(fr, sfc, top);
        xb = table_axis_x(fr, sbc, top);
    }
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

// The per-slot shading data (bound by the raster and bin modules).
@group(0) @binding(6) var<storage, read> shades: array<TetShade>;

struct Frag {
    rgba: vec4<f32>,
    ok: bool,
}

// What one covered pixel (x, y: its centre in pixel coordinates) of slot
// `slot` contributes, premultiplied: the graphics path's fragment shader
// and the compute rasterizer both call this, so they agree bit for bit
// given the same coverage and tent. `tent` is 1 at the thick point and 0
// on the silhouette (pt-linear's interpolation of the thick point's RGBA).
fn fragment_color(fr: Frame, mode: u32, thick_rgba: vec4<f32>, tent: f32, slot: u32, x: f32, y: f32) -> Frag {
    var out: Frag;
    out.ok = false;
    if fr.method == METHOD_PT_LINEAR && mode == GEOM_THICK {
        let lam = clamp(tent, 0.0, 1.0);
        if lam <= 0.0 {
            return out;
        }
        out.rgba = thick_rgba * lam;
        out.ok = true;
        return out;
    }
    let seg = segment_at(fr, shades[slot], x, y);
    if !seg.ok {
        return out;
    }
    out.ok = true;
    if fr.method == METHOD_TABLE3D {
        out.rgba = table_lookup(fr, seg.sf, seg.sb, seg.len);
    } else {
        out.rgba = shade_pt_linear(fr, seg);
    }
    return out;
}
