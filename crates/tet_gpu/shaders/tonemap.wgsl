// HDR display: composite over the background, fit Reinhard's global
// operator (log-average luminance of the covered pixels, α > COVERED_ALPHA,
// by a two-level reduction) and map to 8-bit sRGB with colour kept —
// tet_render::image's `to_rgba8` on the GPU. Three entry points: `reduce`
// (per workgroup: Σ ln(δ + L), max L and the count over covered pixels,
// and Σ, max over all), `fit` (one workgroup combines the partials; all
// pixels when none is covered) and `map` (per pixel).

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
// Per reduce workgroup g: [2g] = (Σ ln(δ + L), max L, count) over covered
// pixels, [2g + 1] = (Σ ln(δ + L), max L, count) over all.
@group(0) @binding(2) var<storage, read_write> partials: array<vec4<f32>>;
@group(0) @binding(3) var<storage, read_write> tone_fit: ToneFit;
// RGBA8 packed little-endian (R in the low byte), row 0 at the top.
@group(0) @binding(4) var<storage, read_write> out_rgba8: array<u32>;

const WG: u32 = 256u;
// Pixels per reduce invocation.
const PER_THREAD: u32 = 4u;
// Reinhard et al. 2002's δ, as tet_render's Reinhard::fit.
const DELTA: f32 = 1.0e-4;
// tet_render::image::COVERED_ALPHA and DESATURATION.
const COVERED_ALPHA: f32 = 0.02;
const DESATURATION: f32 = 0.25;

var<workgroup> w_sum: array<f32, 256>;
var<workgroup> w_max: array<f32, 256>;
var<workgroup> w_cnt: array<f32, 256>;
var<workgroup> w_sum_all: array<f32, 256>;
var<workgroup> w_max_all: array<f32, 256>;

fn texel(i: u32) -> vec4<f32> {
    return textureLoad(hdr, vec2<i32>(i32(i % tp.width), i32(i / tp.width)), 0);
}

fn composited(i: u32) -> vec3<f32> {
    let p = texel(i);
    let t = 1.0 - clamp(p.a, 0.0, 1.0);
    return p.rgb + t * tp.background.rgb;
}

fn luminance(c: vec3<f32>) -> f32 {
    return 0.2126 * c.r + 0.7152 * c.g + 0.0722 * c.b;
}

// Stores this invocation's partial sums and maxima (covered pixels, then
// all pixels) and reduces the workgroup's into index 0 of w_*; every
// invocation of the workgroup calls it (it holds barriers).
fn workgroup_reduce(lid: u32, sum: f32, mx: f32, cnt: f32, sum_all: f32, mx_all: f32) {
    w_sum[lid] = sum;
    w_max[lid] = mx;
    w_cnt[lid] = cnt;
    w_sum_all[lid] = sum_all;
    w_max_all[lid] = mx_all;
    for (var stride = WG / 2u; stride > 0u; stride = stride / 2u) {
        workgroupBarrier();
        if lid < stride {
            w_sum[lid] = w_sum[lid] + w_sum[lid + stride];
            w_max[lid] = max(w_max[lid], w_max[lid + stride]);
            w_cnt[lid] = w_cnt[lid] + w_cnt[lid + stride];
            w_sum_all[lid] = w_sum_all[lid] + w_sum_all[lid + stride];
            w_max_all[lid] = max(w_max_all[lid], w_max_all[lid + stride]);
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
    var cnt = 0.0;
    var sum_all = 0.0;
    var mx_all = 0.0;
    if group < tp.n_partials {
        for (var r = 0u; r < PER_THREAD; r++) {
            let i = (group * PER_THREAD + r) * WG + lid;
            if i < n {
                let l = max(luminance(composited(i)), 0.0);
                let lg = log(DELTA + l);
                sum_all += lg;
                mx_all = max(mx_all, l);
                if texel(i).a > COVERED_ALPHA {
                    sum += lg;
                    mx = max(mx, l);
                    cnt += 1.0;
                }
            }
        }
    }
    workgroup_reduce(lid, sum, mx, cnt, sum_all, mx_all);
    if lid == 0u && group < tp.n_partials {
        partials[2u * group] = vec4<f32>(w_sum[0], w_max[0], w_cnt[0], 0.0);
        partials[2u * group + 1u] = vec4<f32>(w_sum_all[0], w_max_all[0], 0.0, 0.0);
    }
}

@compute @workgroup_size(256)
fn fit(@builtin(local_invocation_index) lid: u32) {
    var sum = 0.0;
    var mx = 0.0;
    var cnt = 0.0;
    var sum_all = 0.0;
    var mx_all = 0.0;
    for (var i = lid; i < tp.n_partials; i += WG) {
        let c = partials[2u * i];
        let a = partials[2u * i + 1u];
        sum += c.x;
        mx = max(mx, c.y);
        cnt += c.z;
        sum_all += a.x;
        mx_all = max(mx_all, a.y);
    }
    workgroup_reduce(lid, sum, mx, cnt, sum_all, mx_all);
    if lid == 0u {
        var s = w_sum[0];
        var m = w_max[0];
        var n = w_cnt[0];
        if n < 0.5 {
            s = w_sum_all[0];
            m = w_max_all[0];
            n = f32(max(tp.width * tp.height, 1u));
        }
        let log_average = exp(s / n);
        let scale = tp.key * tp.exposure / log_average;
        // The white point at exposure 1, as Reinhard::fit_where.
        let max_lm = m * tp.key / log_average;
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
            let ld = min(lm * (1.0 + lm / f.white_sq) / (1.0 + lm), 1.0);
            let k = ld / l;
            var m = max(c, vec3<f32>(0.0)) * k;
            // Out of gamut, hue kept: tet_render::image::fit_gamut (a mix
            // of desaturation towards the grey of the same luminance and
            // darkening at full saturation).
            let top = max(m.r, max(m.g, m.b));
            if top > 1.0 {
                let t = clamp((1.0 - ld) / (top - ld), 0.0, 1.0);
                let desaturated = vec3<f32>(ld) + t * (m - vec3<f32>(ld));
                let darkened = m / top;
                m = clamp(darkened + DESATURATION * (desaturated - darkened), vec3<f32>(0.0), vec3<f32>(1.0));
            }
            rgb = vec3<f32>(linear_to_srgb(m.r), linear_to_srgb(m.g), linear_to_srgb(m.b));
        }
    } else {
        rgb = c;
    }
    out_rgba8[i] = to_u8(rgb.r) | (to_u8(rgb.g) << 8u) | (to_u8(rgb.b) << 16u) | (255u << 24u);
}
