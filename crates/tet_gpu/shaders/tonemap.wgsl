// HDR display: composite over the background, fit Reinhard's global
// operator (log-average luminance by a two-level reduction) and map to
// 8-bit sRGB — tet_render::image's `to_rgba8` on the GPU. Three entry
// points: `reduce` (per-workgroup Σ ln(δ + L) and max L), `fit` (one
// workgroup combines the partials) and `map` (per pixel).

struct ToneParams {
    background: vec4<f32>,
    width: u32,
    height: u32,
    n_partials: u32,
    reinhard: u32,
    key: f32,
    exposure: f32,
    groups_x: u32,
    _pad: u32,
}

struct ToneFit {
    scale: f32,
    white_sq: f32,
    log_average: f32,
    _pad: f32,
}

@group(0) @binding(0) var<uniform> tp: ToneParams;
@group(0) @binding(1) var hdr: texture_2d<f32>;
// (Σ ln(δ + L), max L) per reduce workgroup.
@group(0) @binding(2) var<storage, read_write> partials: array<vec2<f32>>;
@group(0) @binding(3) var<storage, read_write> tone_fit: ToneFit;
// RGBA8 packed little-endian (R in the low byte), row 0 at the top.
@group(0) @binding(4) var<storage, read_write> out_rgba8: array<u32>;

const WG: u32 = 256u;
// Pixels per reduce invocation.
const PER_THREAD: u32 = 4u;
// Reinhard et al. 2002's δ, as tet_render's Reinhard::fit.
const DELTA: f32 = 1.0e-4;

var<workgroup> w_sum: array<f32, 256>;
var<workgroup> w_max: array<f32, 256>;

fn composited(i: u32) -> vec3<f32> {
    let p = textureLoad(hdr, vec2<i32>(i32(i % tp.width), i32(i / tp.width)), 0);
    let t = 1.0 - clamp(p.a, 0.0, 1.0);
    return p.rgb + t * tp.background.rgb;
}

fn luminance(c: vec3<f32>) -> f32 {
    return 0.2126 * c.r + 0.7152 * c.g + 0.0722 * c.b;
}

fn tree(lid: u32) {
    for (var stride = WG / 2u; stride > 0u; stride = stride / 2u) {
        workgroupBarrier();
        if lid < stride {
            w_sum[lid] = w_sum[lid] + w_sum[lid + stride];
            w_max[lid] = max(w_max[lid], w_max[lid + stride]);
        }
    }
    workgroupBarrier();
}

@compute @workgroup_size(256)
fn reduce(@builtin(workgroup_id) wid: vec3<u32>, @builtin(local_invocation_index) lid: u32) {
    let group = wid.x + wid.y * tp.groups_x;
    let n = tp.width * tp.height;
    var sum = 0.0;
    var mx = 0.0;
    if group < tp.n_partials {
        for (var r = 0u; r < PER_THREAD; r++) {
            let i = (group * PER_THREAD + r) * WG + lid;
            if i < n {
                let l = max(luminance(composited(i)), 0.0);
                sum += log(DELTA + l);
                mx = max(mx, l);
            }
        }
    }
    w_sum[lid] = sum;
    w_max[lid] = mx;
    tree(lid);
    if lid == 0u && group < tp.n_partials {
        partials[group] = vec2<f32>(w_sum[0], w_max[0]);
    }
}

@compute @workgroup_size(256)
fn fit(@builtin(local_invocation_index) lid: u32) {
    var sum = 0.0;
    var mx = 0.0;
    for (var i = lid; i < tp.n_partials; i += WG) {
        sum += partials[i].x;
        mx = max(mx, partials[i].y);
    }
    w_sum[lid] = sum;
    w_max[lid] = mx;
    tree(lid);
    if lid == 0u {
        let n = f32(max(tp.width * tp.height, 1u));
        let log_average = exp(w_sum[0] / n);
        let scale = tp.key * tp.exposure / log_average;
        let max_lm = w_max[0] * scale;
        var f: ToneFit;
        f.scale = scale;
        f.white_sq = max(max_lm * max_lm, 1.17549435e-38);
        f.log_average = log_average;
        tone_fit = f;
    }
}

fn linear_to_srgb(v: f32) -> f32 {
    let c = clamp(v, 0.0, 1.0);
    if c <= 0.0031308 {
        return 12.92 * c;
    }
    return 1.055 * pow(c, 1.0 / 2.4) - 0.055;
}

fn to_u8(v: f32) -> u32 {
    return u32(clamp(v, 0.0, 1.0) * 255.0 + 0.5);
}

@compute @workgroup_size(256)
fn map(@builtin(global_invocation_id) gid: vec3<u32>) {
    let i = gid.x + gid.y * tp.groups_x * WG;
    if i >= tp.width * tp.height {
        return;
    }
    let c = composited(i);
    var rgb: vec3<f32>;
    if tp.reinhard != 0u {
        let l = max(luminance(c), 0.0);
        if l <= 0.0 {
            rgb = vec3<f32>(0.0);
        } else {
            let f = tone_fit;
            let lm = l * f.scale;
            let ld = lm * (1.0 + lm / f.white_sq) / (1.0 + lm);
            let k = ld / l;
            let m = clamp(c * k, vec3<f32>(0.0), vec3<f32>(1.0));
            rgb = vec3<f32>(linear_to_srgb(m.r), linear_to_srgb(m.g), linear_to_srgb(m.b));
        }
    } else {
        rgb = c;
    }
    out_rgba8[i] = to_u8(rgb.r) | (to_u8(rgb.g) << 8u) | (to_u8(rgb.b) << 16u) | (255u << 24u);
}
