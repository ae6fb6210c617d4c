// Shared declarations: prepended to classify.wgsl and raster.wgsl (see
// `shader_source` in lib.rs). Structs mirror src/gpu_types.rs field by field.

struct Frame {
    eye_rel: vec4<f32>,
    right: vec4<f32>,
    up: vec4<f32>,
    forward: vec4<f32>,
    ax: f32,
    bx: f32,
    ay: f32,
    by: f32,
    width: f32,
    height: f32,
    near_depth: f32,
    parallel: u32,
    n_slots: u32,
    method: u32,
    n_color_nodes: u32,
    n_opacity_nodes: u32,
    table_s_lo: f32,
    table_inv_ds: f32,
    table_inv_dl: f32,
    table_reach: f32,
    table_n_s: u32,
    table_n_l: u32,
    groups_x: u32,
    table_axis_segs: u32,
    table_optical_depth: u32,
    _pad0: u32,
    _pad1: u32,
    _pad2: u32,
}

struct TetGeom {
    hull: array<vec2<f32>, 6>,
    thick: vec2<f32>,
    n_hull: u32,
    mode: u32,
}

struct TetShade {
    planes: array<vec4<f32>, 4>,
    s_a: vec4<f32>,
    s_b: vec4<f32>,
    extra: vec4<f32>,
}

const METHOD_PT_LINEAR: u32 = 0u;
const METHOD_TABLE3D: u32 = 1u;
const METHOD_POLY: u32 = 2u;
const METHOD_PARTIAL: u32 = 3u;
const METHOD_ATLAS2D: u32 = 4u;
const METHOD_BIV_APPROX: u32 = 5u;
const METHOD_BIV_EXACT: u32 = 6u;
const GEOM_NONE: u32 = 0u;
const GEOM_THICK: u32 = 1u;
const GEOM_CLIPPED: u32 = 2u;
const VERTS_PER_SLOT: u32 = 12u;

// One ray segment through a tet; ok = false where the ray misses it. zf, zb:
// the entry and exit depth values (as `segment_at` finds them); gf, gb: the
// gradient magnitudes there (bivariate methods; set by `fragment_color`).
struct Seg {
    sf: f32,
    sb: f32,
    len: f32,
    ok: bool,
    zf: f32,
    zb: f32,
    gf: f32,
    gb: f32,
}

// World length per unit of depth along the ray through pixel (x, y).
fn len_per_depth(fr: Frame, x: f32, y: f32) -> f32 {
    if fr.parallel != 0u {
        return 1.0;
    }
    let cx = fr.ax * x + fr.bx;
    let cy = fr.ay * y + fr.by;
    return sqrt(1.0 + cx * cx + cy * cy);
}

// The segment along the ray through pixel position (x, y), as
// tet_render's TetSetup::fragment: entry on the farthest front plane, exit
// on the nearest back plane, scalars from the linear field there, clamped
// to the tet's vertex range; the length is capped by the longest edge.
fn segment_at(fr: Frame, sh: TetShade, x: f32, y: f32) -> Seg {
    var out: Seg;
    out.ok = false;
    var zf: f32;
    var zb: f32;
    if fr.parallel != 0u {
        zf = -3.0e38;
        zb = 3.0e38;
        for (var i = 0u; i < 4u; i++) {
            let q = sh.planes[i];
            let v = q.x + q.y * x + q.z * y;
            if q.w > 0.5 {
                zf = max(zf, v);
            } else if q.w < -0.5 {
                zb = min(zb, v);
            }
        }
        if zb >= 3.0e38 || zf <= -3.0e38 {
            return out;
        }
    } else {
        // 1/depth: entry is the smallest positive value over front planes
        // (and the near plane), exit the largest over back planes.
        var wf = 3.0e38;
        if sh.extra.y > 0.0 {
            wf = sh.extra.y;
        }
        var wb = 0.0;
        for (var i = 0u; i < 4u; i++) {
            let q = sh.planes[i];
            let w = q.x + q.y * x + q.z * y;
            if q.w > 0.5 {
                if w > 0.0 && w < wf {
                    wf = w;
                }
            } else if q.w < -0.5 {
                wb = max(wb, w);
            }
        }
        if !(wb > 0.0) || wf >= 3.0e38 {
            return out;
        }
        zf = 1.0 / wf;
        zb = 1.0 / wb;
    }
    if !(zb > zf) {
        return out;
    }
    let base_a = sh.s_a.x + sh.s_a.y * x + sh.s_a.z * y;
    let base_b = sh.s_b.x + sh.s_b.y * x + sh.s_b.z * y;
    out.zf = zf;
    out.zb = zb;
    out.sf = clamp(base_a + zf * base_b, sh.s_a.w, sh.s_b.w);
    out.sb = clamp(base_a + zb * base_b, sh.s_a.w, sh.s_b.w);
    out.len = min((zb - zf) * len_per_depth(fr, x, y), sh.extra.x);
    out.ok = true;
    return out;
}

// Transfer function nodes: colour nodes (x, r, g, b) first, then opacity
// nodes (x, ρ, 0, 0) with ρ = a / unit_distance.
@group(0) @binding(7) var<storage, read> tf_nodes: array<vec4<f32>>;

// κ(s), clamped outside the nodes (TransferFunction::color).
fn tf_color(fr: Frame, s: f32) -> vec3<f32> {
    let n = fr.n_color_nodes;
    var i = 0u;
    while i < n && tf_nodes[i].x <= s {
        i++;
    }
    if i == 0u {
        return tf_nodes[0].yzw;
    }
    if i == n {
        return tf_nodes[n - 1u].yzw;
    }
    let a = tf_nodes[i - 1u];
    let b = tf_nodes[i];
    let t = (s - a.x) / (b.x - a.x);
    return a.yzw + t * (b.yzw - a.yzw);
}

// ρ(s), clamped outside the nodes (TransferFunction::extinction).
fn tf_extinction(fr: Frame, s: f32) -> f32 {
    let o = fr.n_color_nodes;
    let n = fr.n_opacity_nodes;
    var i = 0u;
    while i < n && tf_nodes[o + i].x <= s {
        i++;
    }
    if i == 0u {
        return tf_nodes[o].y;
    }
    if i == n {
        return tf_nodes[o + n - 1u].y;
    }
    let p = tf_nodes[o + i - 1u];
    let q = tf_nodes[o + i];
    return p.y + (s - p.x) / (q.x - p.x) * (q.y - p.y);
}

// pt-linear (PtLinearShader): mean colour of κ(Sf), κ(Sb) and
// α = 1 − exp(−l·(ρ(Sf) + ρ(Sb))/2), premultiplied.
fn shade_pt_linear(fr: Frame, seg: Seg) -> vec4<f32> {
    let cf = tf_color(fr, seg.sf);
    let cb = tf_color(fr, seg.sb);
    let tau = max(seg.len, 0.0) * 0.5 * (tf_extinction(fr, seg.sf) + tf_extinction(fr, seg.sb));
    // 1 − e^{−τ} without cancellation for small τ.
    var alpha: f32;
    if tau < 1.0e-3 {
        alpha = tau * (1.0 - tau * (0.5 - tau / 6.0));
    } else {
        alpha = 1.0 - exp(-tau);
    }
    return vec4<f32>(0.5 * (cf + cb) * alpha, alpha);
}

