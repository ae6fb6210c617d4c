// Lighting and silhouettes on the GPU: tet_render::shading's one model
// (Blinn–Phong, two-sided, several lights, the isotropic medium where the
// gradient has no direction, the fade below the gradient floor) and
// `light_segment` (the segment lit at its emission centroid, split into
// equal pieces where the terms vary), in f32. Prepended after common.wgsl
// to the classify module (pt-linear's thick point) and to the modules that
// shade fragments; each defines `shade_piece(fr, seg)`, the method's colour
// of a piece of a segment. Shadows: each shadow-casting light's deep
// shadow map (tet_render::shadow::DeepShadowMap), looked up where a piece
// is lit as `DeepShadowMap::depth_at` looks it up, in f32.

struct GpuLight {
    v: vec4<f32>,
    kind: u32,
    _pad0: u32,
    _pad1: u32,
    _pad2: u32,
}

struct LightParams {
    ambient: f32,
    diffuse: f32,
    specular: f32,
    shininess: f32,
    n_lights: u32,
    lit: u32,
    silhouette: u32,
    silhouette_exp: f32,
    gradient_floor: f32,
    split_tolerance: f32,
    max_pieces: u32,
    enabled: u32,
    resplit_tolerance: f32,
    max_subpieces: u32,
    subpiece_budget: u32,
    _pad: u32,
    lights: array<GpuLight, 8>,
}

const LIGHT_HEADLIGHT: u32 = 0u;
const LIGHT_DIRECTIONAL: u32 = 1u;
const LIGHT_POINT: u32 = 2u;
const NORMAL_ROWS: u32 = 6u;

@group(0) @binding(19) var<uniform> lighting: LightParams;

// gpu_types::GpuShadowMap: a map in the GPU's frame (positions relative to
// the mesh centre), light i's in slots SHADOW_SLOTS·i onwards; `has_map` 0
// in a light's first slot: no shadow from it; `cube` 1 there: its six
// slots are a cube of maps' faces (tet_render::shadow::cube_face order).
struct ShadowMap {
    e1: vec4<f32>,
    e2: vec4<f32>,
    d: vec4<f32>,
    origin: vec4<f32>,
    u0: f32,
    v0: f32,
    t0: f32,
    du: f32,
    dv: f32,
    bin_len: f32,
    nu: u32,
    nv: u32,
    knot_base: u32,
    index_base: u32,
    has_map: u32,
    cube: u32,
    fine_base: u32,
    finer_base: u32,
    finest_base: u32,
    _pad2: u32,
}

const SHADOW_BINS: u32 = 32u;
// Rays of at most this many knots are scanned from their first knot
// (tet_render::shadow::SHORT_RAY).
const SHADOW_SHORT_RAY: u32 = 8u;
// How much a lookup's four nearest rays must differ (their spread in
// optical depth times the light left) for it to turn bicubic
// (tet_render::shadow::CUBIC_ABOVE).
const SHADOW_CUBIC_ABOVE: f32 = 0.05;
const SHADOW_SLOTS: u32 = 6u;

@group(0) @binding(22) var<storage, read> shadow_maps: array<ShadowMap, 48>;
@group(0) @binding(23) var<storage, read> shadow_knots: array<vec2<f32>>;
@group(0) @binding(24) var<storage, read> shadow_index: array<u32>;

// A finer grid's position without a ray (tet_render::shadow::NO_RAY).
const SHADOW_NO_RAY: u32 = 0xFFFFFFFFu;
// Positions along a side of a finer grid's table tiles
// (tet_render::shadow::LEVEL_TILE).
const SHADOW_LEVEL_TILE: u32 = 8u;

// Ray r of map `m`'s optical depth at parameter t: linear between its
// knots, 0 before the first, the last's after it.
fn shadow_ray_depth(m: ShadowMap, r: u32, t: f32) -> f32 {
    let rec = m.index_base + r * (SHADOW_BINS + 1u);
    let b = u32(clamp(t / m.bin_len, 0.0, f32(SHADOW_BINS - 1u)));
    let start = shadow_index[rec];
    let end = shadow_index[rec + SHADOW_BINS];
    // A short ray is scanned whole, as the CPU scans it (same knot found).
    var n = start;
    if end - start > SHADOW_SHORT_RAY {
        n = shadow_index[rec + b];
    }
    loop {
        if n >= end || shadow_knots[m.knot_base + n].x > t {
            break;
        }
        n++;
    }
    if n == start {
        return 0.0;
    }
    if n == end {
        return shadow_knots[m.knot_base + end - 1u].y;
    }
    let a = shadow_knots[m.knot_base + n - 1u];
    let c = shadow_knots[m.knot_base + n];
    var w = 1.0;
    if c.x > a.x {
        w = (t - a.x) / (c.x - a.x);
    }
    return a.y + w * (c.y - a.y);
}

// Where `x` lies on an axis of `n` rays from `x0` spaced `dx`, in ray
// spacings from the first, within [0, n - 1] (DeepShadowMap::depth_at's
// `coord`).
fn shadow_coord(x: f32, x0: f32, dx: f32, n: u32) -> f32 {
    var f = 0.0;
    if dx > 0.0 {
        f = clamp((x - x0) / dx, 0.0, f32(n - 1u));
    }
    return f;
}

// The cell of an axis of `n` rays that coordinate `f` falls in, and the
// weight of its far ray (the map's `cell`).
fn shadow_cell(f: f32, n: u32) -> vec2<f32> {
    let i = min(floor(f), f32(n - 2u));
    return vec2<f32>(i, f - i);
}

// A grid of a map's rays (the map's `Level`): the coarse one, or a finer
// one of rays halfway between, walked where the depths are rough (its
// table at `base` in the index buffer; SHADOW_NO_RAY for the coarse grid).
struct ShadowGrid {
    du: f32,
    dv: f32,
    nu: u32,
    nv: u32,
    base: u32,
}

// Ray (i, j) of grid `g`: its number in the map, SHADOW_NO_RAY where a
// finer grid has none.
fn shadow_ray_of(m: ShadowMap, g: ShadowGrid, i: u32, j: u32) -> u32 {
    if g.base != SHADOW_NO_RAY {
        return shadow_level_ray(g.base, g.nu, i, j);
    }
    return j * m.nu + i;
}

// Position (i, j) of a finer grid `nu` positions wide whose table starts
// at `base` (tet_render::shadow::LevelTable: per tile of SHADOW_LEVEL_TILE²
// positions, row after row, where its entries start in the table or
// SHADOW_NO_RAY; then the tiles' entries): its ray, SHADOW_NO_RAY where none.
fn shadow_level_ray(base: u32, nu: u32, i: u32, j: u32) -> u32 {
    let tiles_u = (nu + SHADOW_LEVEL_TILE - 1u) / SHADOW_LEVEL_TILE;
    let tile = shadow_index[base + (j / SHADOW_LEVEL_TILE) * tiles_u + i / SHADOW_LEVEL_TILE];
    if tile == SHADOW_NO_RAY {
        return SHADOW_NO_RAY;
    }
    return shadow_index[base + tile + (j % SHADOW_LEVEL_TILE) * SHADOW_LEVEL_TILE + i % SHADOW_LEVEL_TILE];
}

// Map `m`'s grid `k` times as dense as its coarse one, its table at `base`.
fn shadow_grid(m: ShadowMap, k: u32, base: u32) -> ShadowGrid {
    return ShadowGrid(m.du / f32(k), m.dv / f32(k), k * (m.nu - 1u) + 1u, k * (m.nv - 1u) + 1u, base);
}

// The cell of a finer grid (`k` times as dense, its table at `base`,
// SHADOW_NO_RAY: none) around the point at coarse coordinates (fu, fv),
// and whether its four rays were walked: its corner at the centre of its
// cell one grid up is walked exactly where all of that cell's rays are.
struct ShadowCell {
    g: ShadowGrid,
    cu: vec2<f32>,
    cv: vec2<f32>,
    walked: bool,
}

fn shadow_finer_cell(m: ShadowMap, k: u32, base: u32, fu: f32, fv: f32) -> ShadowCell {
    let g = shadow_grid(m, k, base);
    let cu = shadow_cell(f32(k) * fu, g.nu);
    let cv = shadow_cell(f32(k) * fv, g.nv);
    var walked = false;
    if base != SHADOW_NO_RAY {
        walked = shadow_level_ray(base, g.nu, u32(cu.x) | 1u, u32(cv.x) | 1u) != SHADOW_NO_RAY;
    }
    return ShadowCell(g, cu, cv, walked);
}

// Optical depth from light `l` to `pos_rel` (ShadowField::depth_at): its
// map, or the face of its cube that sees the point (the largest coordinate
// relative to the light, ties to the first axis, as cube_face). One call
// of shadow_depth, not one a branch: on llvmpipe every loop met counts
// against one shared iteration limit even where no lane takes it (see
// shadow_depth).
fn light_shadow_depth(l: u32, pos_rel: vec3<f32>) -> f32 {
    let first = l * SHADOW_SLOTS;
    var slot = first;
    if shadow_maps[first].cube != 0u {
        let q = pos_rel - shadow_maps[first].origin.xyz;
        let a = abs(q);
        if !(max(max(a.x, a.y), a.z) > 0.0) {
            return 0.0;
        }
        var face = 4u;
        var neg = q.z < 0.0;
        if a.x >= a.y && a.x >= a.z {
            face = 0u;
            neg = q.x < 0.0;
        } else if a.y >= a.z {
            face = 2u;
            neg = q.y < 0.0;
        }
        if neg {
            face += 1u;
        }
        slot = first + face;
    }
    return shadow_depth(slot, pos_rel);
}

// Where ray (ii, jj) of map `m` is read for a point at `axial` along the
// light: that depth for parallel rays, the distance at which a fan's ray
// crosses the point's plane.
fn shadow_ray_t(m: ShadowMap, g: ShadowGrid, fan: bool, axial: f32, ii: u32, jj: u32) -> f32 {
    if fan {
        let su = m.u0 + f32(ii) * g.du;
        let sv = m.v0 + f32(jj) * g.dv;
        return axial * sqrt(1.0 + su * su + sv * sv);
    }
    return axial;
}

// Catmull-Rom weights of the samples at -1, 0, 1, 2 for a point at t in
// [0, 1] (tet_render::shadow::catmull_rom).
fn catmull_rom(t: f32) -> vec4<f32> {
    let t2 = t * t;
    let t3 = t2 * t;
    return vec4<f32>(
        0.5 * (-t3 + 2.0 * t2 - t),
        0.5 * (3.0 * t3 - 5.0 * t2 + 2.0),
        0.5 * (-3.0 * t3 + 4.0 * t2 + t),
        0.5 * (t3 - t2),
    );
}

// The 4 x 4 rays around a lookup, r = 4 q + p for ray (i - 1 + p, j - 1 + q),
// in the order they are read: the nearest four (5, 6, 9, 10) first, then
// the other twelve as 4-bit entries (SHADOW_RING_LO, then SHADOW_RING_HI).
const SHADOW_RING_LO: u32 = 0xB8743210u;
const SHADOW_RING_HI: u32 = 0xFEDCu;

fn shadow_ray_of_read(k: u32) -> u32 {
    if k < 4u {
        return 5u + (k & 1u) + 4u * (k >> 1u);
    }
    let m = k - 4u;
    var word = SHADOW_RING_LO;
    if m >= 8u {
        word = SHADOW_RING_HI;
    }
    return (word >> (4u * (m & 7u))) & 15u;
}

// Optical depth to `pos_rel` through map slot `s` (DeepShadowMap::depth_at):
// bilinear across the four nearest rays, turning bicubic where they
// disagree (Catmull-Rom over the 4 x 4 nearest rays, the map's edge rays
// past it, held within the four nearest rays' range, blended in as their
// spread times the light left grows from SHADOW_CUBIC_ABOVE to twice
// that); each ray read where it crosses the point's depth along the light
// (a point light's fan: the point's plane across its axis).
//
// The rays are read in one loop, the twelve outer ones only where the
// lookup turns bicubic: on llvmpipe (lavapipe) every loop of an invocation
// shares 65 535 iterations, and a loop no lane takes still runs once, so
// a loop per ray would cost the compute rasterizer's composite pass (which
// inlines this for lit fragments) iterations on every unlit fragment too
// (compute_raster's long_tile_lists_composite_every_tet).
fn shadow_depth(s: u32, pos_rel: vec3<f32>) -> f32 {
    let m = shadow_maps[s];
    var u: f32;
    var v: f32;
    var axial: f32;
    let fan = m.origin.w != 0.0;
    if fan {
        let q = pos_rel - m.origin.xyz;
        let w = dot(q, m.d.xyz);
        if !(w > 0.0) {
            return 0.0;
        }
        u = dot(q, m.e1.xyz) / w;
        v = dot(q, m.e2.xyz) / w;
        axial = w;
    } else {
        u = dot(pos_rel, m.e1.xyz);
        v = dot(pos_rel, m.e2.xyz);
        axial = dot(pos_rel, m.d.xyz) - m.t0;
    }
    let fu = shadow_coord(u, m.u0, m.du, m.nu);
    let fv = shadow_coord(v, m.v0, m.dv, m.nv);
    var g = ShadowGrid(m.du, m.dv, m.nu, m.nv, SHADOW_NO_RAY);
    var cu = shadow_cell(fu, m.nu);
    var cv = shadow_cell(fv, m.nv);
    // Around rough cells the map has rays halfway between (its fine grid),
    // around the fine grid's rough cells rays halfway between those (the
    // finer grid), and so once more (the finest): read at the finest grid
    // whose four nearest rays exist. Every cell of a grid has the centre
    // of its cell one grid up for a corner, walked exactly where all of
    // that cell's rays are: one look a grid (as the CPU). Straight code,
    // no loop (see below).
    let fine = shadow_finer_cell(m, 2u, m.fine_base, fu, fv);
    if fine.walked {
        g = fine.g;
        cu = fine.cu;
        cv = fine.cv;
    }
    let finer = shadow_finer_cell(m, 4u, m.finer_base, fu, fv);
    if finer.walked {
        g = finer.g;
        cu = finer.cu;
        cv = finer.cv;
    }
    let finest = shadow_finer_cell(m, 8u, m.finest_base, fu, fv);
    if finest.walked {
        g = finest.g;
        cu = finest.cu;
        cv = finest.cv;
    }
    let i = u32(cu.x);
    let j = u32(cv.x);
    var depth: array<f32, 16>;
    var lo = 0.0;
    var hi = 0.0;
    var bilinear = 0.0;
    var cubic_share = 0.0;
    var reads = 4u;
    var missing = false;
    var k = 0u;
    loop {
        if k >= reads {
            break;
        }
        let r = shadow_ray_of_read(k);
        let ii = min(max(i + (r & 3u), 1u) - 1u, g.nu - 1u);
        let jj = min(max(j + (r >> 2u), 1u) - 1u, g.nv - 1u);
        let ray = shadow_ray_of(m, g, ii, jj);
        if ray == SHADOW_NO_RAY {
            // An outer ray the fine grid lacks (at the edge of its walked
            // part): bilinear, as the CPU.
            missing = true;
            break;
        }
        depth[r] = shadow_ray_depth(m, ray, shadow_ray_t(m, g, fan, axial, ii, jj));
        if k == 3u {
            let a = depth[5];
            let b = depth[9];
            let c = depth[6];
            let e = depth[10];
            lo = min(min(a, b), min(c, e));
            hi = max(max(a, b), max(c, e));
            let bottom = a + cu.y * (c - a);
            let top = b + cu.y * (e - b);
            bilinear = bottom + cv.y * (top - bottom);
            cubic_share = clamp(exp(-lo) * (hi - lo) / SHADOW_CUBIC_ABOVE - 1.0, 0.0, 1.0);
            if cubic_share > 0.0 {
                reads = 16u;
            }
        }
        k++;
    }
    if reads == 4u || missing {
        return bilinear;
    }
    let wu = catmull_rom(cu.y);
    let wv = catmull_rom(cv.y);
    // Row by row as the CPU sums them (no loop: see above).
    let row0 = wu.x * depth[0] + wu.y * depth[1] + wu.z * depth[2] + wu.w * depth[3];
    let row1 = wu.x * depth[4] + wu.y * depth[5] + wu.z * depth[6] + wu.w * depth[7];
    let row2 = wu.x * depth[8] + wu.y * depth[9] + wu.z * depth[10] + wu.w * depth[11];
    let row3 = wu.x * depth[12] + wu.y * depth[13] + wu.z * depth[14] + wu.w * depth[15];
    let sum = wv.x * row0 + wv.y * row1 + wv.z * row2 + wv.w * row3;
    return bilinear + cubic_share * (clamp(sum, lo, hi) - bilinear);
}

// The lighting terms at one point (tet_render's LitPoint): emitted colour
// times `diffuse`, plus white `specular` times extinction; `silhouette`
// scales everything.
struct LitPoint {
    diffuse: f32,
    specular: f32,
    silhouette: f32,
}

// x^p for x in [0, 1] (0^0 = 1, as powi and powf give).
fn pow_unit(x: f32, p: f32) -> f32 {
    if p == 0.0 {
        return 1.0;
    }
    if !(x > 0.0) {
        return 0.0;
    }
    return pow(x, p);
}

// Shading::lit_point for gradient `g` (world frame; `has_dir` false where a
// vertex gradient was not finite: no direction) at `pos_rel` (relative to
// the mesh centre), seen along unit `view_dir` (eye towards the sample).
fn lit_point(g: vec3<f32>, has_dir_in: bool, pos_rel: vec3<f32>, view_dir: vec3<f32>) -> LitPoint {
    var out = LitPoint(1.0, 0.0, 1.0);
    // |g| scaled by its largest component: no overflow or underflow in f32.
    let m = max(max(abs(g.x), abs(g.y)), abs(g.z));
    let has_dir = has_dir_in && m > 0.0 && m <= 3.4e38;
    var n = vec3<f32>(0.0);
    var len = 0.0;
    if has_dir {
        let gs = g / m;
        let ls = length(gs);
        n = gs / ls;
        len = m * ls;
    }
    var weight = 0.0;
    if has_dir {
        weight = 1.0;
        if len < lighting.gradient_floor {
            weight = len / lighting.gradient_floor;
        }
    }
    if lighting.lit != 0u {
        let to_eye = -view_dir;
        var d_iso = lighting.ambient;
        var d = lighting.ambient;
        var s = 0.0;
        for (var i = 0u; i < lighting.n_lights; i++) {
            let l = lighting.lights[i];
            var to_light = -view_dir;
            if l.kind == LIGHT_DIRECTIONAL {
                to_light = -l.v.xyz;
            } else if l.kind == LIGHT_POINT {
                let dv = l.v.xyz - pos_rel;
                let dm = max(max(abs(dv.x), abs(dv.y)), abs(dv.z));
                if !(dm > 0.0) {
                    // A point light at the sample: no direction, nothing added.
                    continue;
                }
                to_light = normalize(dv / dm);
            }
            var w = l.v.w;
            if shadow_maps[i * SHADOW_SLOTS].has_map != 0u {
                // ShadowField depths stop at MAP_OPAQUE_DEPTH: exp stays finite.
                w *= exp(-max(light_shadow_depth(i, pos_rel), 0.0));
            }
            if w == 0.0 {
                continue;
            }
            d_iso += w * lighting.diffuse;
            if weight == 0.0 {
                continue;
            }
            d += w * lighting.diffuse * min(abs(dot(n, to_light)), 1.0);
            let h = to_light + to_eye;
            let h_len = length(h);
            // A light behind the sample (l̂ = −v̂): no half vector, no
            // highlight. The CPU's threshold is 1e-9 in f64; f32 rounding
            // leaves |h| ~1e-7 there, so 1e-5.
            if h_len > 1.0e-5 {
                s += w * lighting.specular * pow_unit(min(abs(dot(n, h)) / h_len, 1.0), lighting.shininess);
            }
        }
        out.diffuse = d_iso + weight * (d - d_iso);
        out.specular = weight * s;
    }
    if weight == 0.0 {
        return out;
    }
    if lighting.silhouette != 0u {
        let n_dot_v = min(abs(dot(n, view_dir)), 1.0);
        out.silhouette = 1.0 + weight * (pow_unit(max(1.0 - n_dot_v, 0.0), lighting.silhouette_exp) - 1.0);
    }
    return out;
}

// LitPoint::apply: premultiplied `c` lit by constant terms.
fn lit_apply(p: LitPoint, c: vec4<f32>) -> vec4<f32> {
    return vec4<f32>((c.xyz * p.diffuse + vec3<f32>(p.specular * c.w)) * p.silhouette, c.w * p.silhouette);
}

// tet_render::shading::emission_centroid in f32: 1/τ − (1 − α)/α with
// τ = −ln(1 − α); by its series ½ − α/12 − α²/24 − 19α³/720 below α = 0.05
// (the closed form cancels there in f32; the series' error < 2e-7).
fn emission_centroid(alpha: f32) -> f32 {
    if !(alpha > 1.0e-4) {
        return 0.5;
    }
    if alpha >= 1.0 {
        return 0.0;
    }
    if alpha < 0.05 {
        return 0.5 - alpha * (1.0 / 12.0 + alpha * (1.0 / 24.0 + alpha * (19.0 / 720.0)));
    }
    let tau = -log(1.0 - alpha);
    return clamp(1.0 / tau - (1.0 - alpha) / alpha, 0.0, 0.5);
}

// A segment's lighting inputs at its two ends (the gradient and position
// are linear in depth along the ray, as tet_render's TetSetup fields).
struct LitEnds {
    nf: vec3<f32>,
    nb: vec3<f32>,
    pf: vec3<f32>,
    pb: vec3<f32>,
    view_dir: vec3<f32>,
    has_dir: bool,
}

// The terms at fraction w of the segment (0 front, 1 back).
fn lit_at(e: LitEnds, w: f32) -> LitPoint {
    return lit_point(e.nf + w * (e.nb - e.nf), e.has_dir, e.pf + w * (e.pb - e.pf), e.view_dir);
}

// Unit direction of the ray through pixel (x, y) (Frame::view_dir).
fn ray_dir(fr: Frame, x: f32, y: f32) -> vec3<f32> {
    if fr.parallel != 0u {
        return fr.forward.xyz;
    }
    let cx = fr.ax * x + fr.bx;
    let cy = fr.ay * y + fr.by;
    return normalize(fr.forward.xyz + fr.right.xyz * cx + fr.up.xyz * cy);
}

// Position relative to the mesh centre at depth z on the ray through (x, y).
fn ray_pos(fr: Frame, x: f32, y: f32, z: f32) -> vec3<f32> {
    let cx = fr.ax * x + fr.bx;
    let cy = fr.ay * y + fr.by;
    if fr.parallel != 0u {
        return fr.eye_rel.xyz + fr.right.xyz * cx + fr.up.xyz * cy + fr.forward.xyz * z;
    }
    return fr.eye_rel.xyz + (fr.forward.xyz + fr.right.xyz * cx + fr.up.xyz * cy) * z;
}

// The lighting inputs of segment `seg` through pixel (x, y) from a slot's
// gradient fields `rows` (per component c, rows 2c and 2c + 1 as TetShade's
// s_a and s_b; rows[0].w: 1 where every vertex gradient is finite).
fn lit_ends(fr: Frame, rows: array<vec4<f32>, 6>, seg: Seg, x: f32, y: f32) -> LitEnds {
    var e: LitEnds;
    let xy1 = vec3<f32>(1.0, x, y);
    let base_a = vec3<f32>(dot(rows[0].xyz, xy1), dot(rows[2].xyz, xy1), dot(rows[4].xyz, xy1));
    let base_b = vec3<f32>(dot(rows[1].xyz, xy1), dot(rows[3].xyz, xy1), dot(rows[5].xyz, xy1));
    e.nf = base_a + seg.zf * base_b;
    e.nb = base_a + seg.zb * base_b;
    e.has_dir = rows[0].w > 0.5;
    e.pf = ray_pos(fr, x, y, seg.zf);
    e.pb = ray_pos(fr, x, y, seg.zb);
    e.view_dir = ray_dir(fr, x, y);
    return e;
}

// tet_render::shading::light_segment: `c`, the method's colour of `seg`,
// lit at its emission centroid where the terms vary little over it, else
// split into up to `max_pieces` equal pieces (their number
// ⌈√(variation·weight/tolerance)⌉), each shaded by `shade_piece` and lit at
// its own emission centroid, composited front to back; a piece across
// which the terms at the neighbouring pieces' points change by more than
// `resplit_tolerance` over its colour is split again
// (tet_render::shading::resplit_pieces).
fn light_segment(fr: Frame, seg: Seg, c: vec4<f32>, e: LitEnds) -> vec4<f32> {
    let weight = max(max(max(c.x, c.y), max(c.z, c.w)), 0.0);
    if !(weight > 0.0) {
        return c;
    }
    let mid = lit_at(e, emission_centroid(c.w));
    let tol = lighting.split_tolerance;
    if weight * 4.0 < tol {
        return lit_apply(mid, c);
    }
    let front = lit_at(e, 0.0);
    let back = lit_at(e, 1.0);
    let variation = abs(front.diffuse - mid.diffuse) + abs(mid.diffuse - back.diffuse)
        + abs(front.specular - mid.specular) + abs(mid.specular - back.specular)
        + abs(front.silhouette - mid.silhouette) + abs(mid.silhouette - back.silhouette);
    let want = ceil(sqrt(variation * weight / tol));
    var pieces = 1u;
    if want > 1.0 {
        pieces = u32(min(want, f32(lighting.max_pieces)));
    }
    if pieces <= 1u {
        return lit_apply(mid, c);
    }
    // The pieces are evaluated one ahead of the one composited (whether
    // piece j is split again depends on piece j + 1's terms), and a piece
    // split again has its subpieces evaluated in the rounds after. Every
    // round evaluates at most one piece or subpiece (a shade and a lit_at)
    // from one call site: llvmpipe shares one loop-iteration budget among
    // every loop of an invocation and runs an untaken loop once, so each
    // inlined copy of the shadow lookup's loop would cost every fragment.
    var out = vec4<f32>(0.0);
    let step = 1.0 / f32(pieces);
    var prev_l = front;
    var cur_l = front;
    var cur_c = vec4<f32>(0.0);
    var next_l = back;
    var next_c = vec4<f32>(0.0);
    var evaluated = 0u;
    var j = 0u;
    var k = 0u;
    var q = 0u;
    var total = 0u;
    var sub = vec4<f32>(0.0);
    loop {
        let ahead = k == 0u;
        if !ahead || evaluated < min(j + 2u, pieces) {
            var w0 = f32(evaluated) * step;
            var w1 = f32(evaluated + 1u) * step;
            var len = seg.len * step;
            if !ahead {
                w0 = (f32(j) + f32(q) / f32(k)) * step;
                w1 = (f32(j) + f32(q + 1u) / f32(k)) * step;
                len = seg.len * (w1 - w0);
            }
            var piece = seg;
            piece.sf = seg.sf + w0 * (seg.sb - seg.sf);
            piece.sb = seg.sf + w1 * (seg.sb - seg.sf);
            piece.gf = seg.gf + w0 * (seg.gb - seg.gf);
            piece.gb = seg.gf + w1 * (seg.gb - seg.gf);
            piece.len = len;
            let rgba = shade_piece(fr, piece);
            let l = lit_at(e, w0 + (w1 - w0) * emission_centroid(rgba.w));
            if !ahead {
                sub += (1.0 - sub.w) * lit_apply(l, rgba);
                q += 1u;
                if q < k {
                    continue;
                }
                out += (1.0 - out.w) * sub;
                k = 0u;
            } else {
                if evaluated == j {
                    cur_l = l;
                    cur_c = rgba;
                } else {
                    next_l = l;
                    next_c = rgba;
                }
                evaluated += 1u;
                if evaluated < min(j + 2u, pieces) {
                    continue;
                }
            }
        }
        if ahead {
            if j + 1u == pieces {
                next_l = back;
            }
            // Piece j: split again, or lit at its one point.
            let colour = max(max(max(cur_c.x, cur_c.y), max(cur_c.z, cur_c.w)), 0.0);
            let change = 0.5 * (lit_jump(prev_l, cur_l) + lit_jump(cur_l, next_l)) * colour;
            let want_sub = clamp(ceil(sqrt(change / tol)), 2.0, f32(lighting.max_subpieces));
            let kk = min(u32(want_sub), lighting.subpiece_budget - total);
            if change > lighting.resplit_tolerance && kk >= 2u {
                k = kk;
                q = 0u;
                total += kk;
                sub = vec4<f32>(0.0);
                continue;
            }
            out += (1.0 - out.w) * lit_apply(cur_l, cur_c);
        }
        // Piece j done.
        prev_l = cur_l;
        cur_l = next_l;
        cur_c = next_c;
        j += 1u;
        if j >= pieces {
            break;
        }
    }
    return out;
}

// tet_render::shading's jump: how much the terms differ between two points.
fn lit_jump(a: LitPoint, b: LitPoint) -> f32 {
    return abs(a.diffuse - b.diffuse) + abs(a.specular - b.specular) + abs(a.silhouette - b.silhouette);
}
