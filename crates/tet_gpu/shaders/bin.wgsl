// Compute rasterizer: bins the classified slots of a chunk into 16×16
// pixel tiles, then one workgroup per tile composites its tets front to
// back, per pixel, with early termination — the same coverage polygons,
// tent and per-fragment maths (fragment.wgsl) as the graphics path.
//
// 1. bin_count: tiles each slot's silhouette box overlaps → counts[slot].
// 2. (sort.wgsl) exclusive prefix sum of counts → each slot's first pair.
// 3. bin_fill: pairs (tile, slot), in slot order, for slots
//    [slot_lo, slot_hi) at pair index counts[slot] − pair_base.
// 4. (sort.wgsl) stable radix sort of the pairs by tile: each tile's slots
//    stay in visibility order.
// 5. tile_ranges: each tile's [first, end) in the sorted pairs.
// 6. composite: per tile, the pixels' running colour (`accum`, carried
//    across chunks) "under" each covering slot's fragment; the result is
//    stored into the HDR texture.

struct BinParams {
    tiles_x: u32,
    tiles_y: u32,
    n_slots: u32,
    groups_x: u32,
    slot_lo: u32,
    slot_hi: u32,
    pair_base: u32,
    n_pairs: u32,
}

@group(0) @binding(0) var<uniform> fr: Frame;
@group(0) @binding(1) var<uniform> bp: BinParams;
@group(0) @binding(2) var<storage, read> geoms: array<TetGeom>;
@group(0) @binding(3) var<storage, read_write> counts: array<u32>;
@group(0) @binding(4) var<storage, read_write> keys: array<u32>;
@group(0) @binding(5) var<storage, read_write> vals: array<u32>;
// 6: shades, 7: tf_nodes, 8: table (fragment.wgsl, common.wgsl).
@group(0) @binding(9) var<storage, read_write> ranges: array<vec2<u32>>;
@group(0) @binding(10) var<storage, read_write> accum: array<vec4<f32>>;
@group(0) @binding(11) var out_tex: texture_storage_2d<rgba32float, write>;

const TILE: u32 = 16u;
const BIN_WG: u32 = 64u;
// As tet_render's RasterOptions::opaque_alpha: a pixel stops compositing
// once its opacity reaches this.
const OPAQUE_ALPHA: f32 = 0.9999;
// Entries loaded into workgroup memory at a time (and composited between
// workgroup-wide termination checks).
const BATCH: u32 = 128u;

// Inclusive tile rectangle (x0, y0, x1, y1) whose pixel centres the
// slot's silhouette box can cover; x0 > x1 when none.
fn tile_rect(g: TetGeom) -> vec4<u32> {
    var lo = vec2<f32>(3.0e38);
    var hi = vec2<f32>(-3.0e38);
    for (var i = 0u; i < g.n_hull; i++) {
        lo = min(lo, g.hull[i]);
        hi = max(hi, g.hull[i]);
    }
    // Pixel centres x + 0.5 in [lo, hi], clamped to the image.
    let p0 = max(ceil(lo - vec2<f32>(0.5)), vec2<f32>(0.0));
    let p1 = min(floor(hi - vec2<f32>(0.5)), vec2<f32>(fr.width - 1.0, fr.height - 1.0));
    if g.mode == GEOM_NONE || !(p0.x <= p1.x) || !(p0.y <= p1.y) {
        return vec4<u32>(1u, 0u, 0u, 0u);
    }
    let t0 = vec2<u32>(p0) / TILE;
    let t1 = vec2<u32>(p1) / TILE;
    return vec4<u32>(t0, t1);
}

fn slot_index(gid: vec3<u32>) -> u32 {
    return gid.x + gid.y * bp.groups_x * BIN_WG;
}

@compute @workgroup_size(64)
fn bin_count(@builtin(global_invocation_id) gid: vec3<u32>) {
    let slot = slot_index(gid);
    if slot >= bp.n_slots {
        return;
    }
    let r = tile_rect(geoms[slot]);
    var n = 0u;
    if r.x <= r.z {
        n = (r.z - r.x + 1u) * (r.w - r.y + 1u);
    }
    counts[slot] = n;
}

@compute @workgroup_size(64)
fn bin_fill(@builtin(global_invocation_id) gid: vec3<u32>) {
    let slot = bp.slot_lo + slot_index(gid);
    if slot >= bp.slot_hi {
        return;
    }
    let r = tile_rect(geoms[slot]);
    if r.x > r.z {
        return;
    }
    var o = counts[slot] - bp.pair_base;
    for (var ty = r.y; ty <= r.w; ty++) {
        for (var tx = r.x; tx <= r.z; tx++) {
            keys[o] = ty * bp.tiles_x + tx;
            vals[o] = slot;
            o++;
        }
    }
}

@compute @workgroup_size(64)
fn tile_ranges(@builtin(global_invocation_id) gid: vec3<u32>) {
    let i = slot_index(gid);
    if i >= bp.n_pairs {
        return;
    }
    let k = keys[i];
    if i == 0u || keys[i - 1u] != k {
        ranges[k].x = i;
    }
    if i + 1u == bp.n_pairs || keys[i + 1u] != k {
        ranges[k].y = i + 1u;
    }
}

fn orient2(a: vec2<f32>, b: vec2<f32>, c: vec2<f32>) -> f32 {
    return (b.x - a.x) * (c.y - a.y) - (b.y - a.y) * (c.x - a.x);
}

// orient2(a, b, p) evaluated with the endpoints in a canonical order, so
// an edge shared by two polygons gives exactly opposite values in both.
fn edge_fn(a: vec2<f32>, b: vec2<f32>, p: vec2<f32>) -> f32 {
    if a.x > b.x || (a.x == b.x && a.y > b.y) {
        return -orient2(b, a, p);
    }
    return orient2(a, b, p);
}

// Twice the signed area of the polygon hull[0..n] (0 when degenerate or
// not finite: nothing covered).
fn poly_area(g: TetGeom) -> f32 {
    let n = g.n_hull;
    var area = 0.0;
    for (var i = 0u; i < n; i++) {
        let a = g.hull[i];
        let b = g.hull[(i + 1u) % n];
        area += a.x * b.y - b.x * a.y;
    }
    if !(abs(area) < 3.0e38) {
        return 0.0;
    }
    return area;
}

// Whether pixel centre p lies in the convex polygon hull[0..n] whose area
// has sign `sgn`: inside every edge, and on an edge only where the edge
// (interior on its left) points down or, horizontal, left — a tie rule
// under which exactly one of two polygons sharing an edge owns the points
// on it.
fn covers(g: TetGeom, sgn: f32, p: vec2<f32>) -> bool {
    let n = g.n_hull;
    for (var i = 0u; i < n; i++) {
        let a = g.hull[i];
        let b = g.hull[(i + 1u) % n];
        let e = edge_fn(a, b, p) * sgn;
        if e < 0.0 {
            return false;
        }
        if e == 0.0 {
            let d = (b - a) * sgn;
            if !(d.y > 0.0 || (d.y == 0.0 && d.x < 0.0)) {
                return false;
            }
        }
    }
    return true;
}

// pt-linear's tent at p: 1 at the thick point, 0 on the silhouette, linear
// on each fan triangle — the pyramid over a convex base is the smallest of
// its face planes.
fn tent_at(g: TetGeom, p: vec2<f32>) -> f32 {
    var t = 1.0;
    for (var i = 0u; i < g.n_hull; i++) {
        let a = g.hull[i];
        let b = g.hull[(i + 1u) % g.n_hull];
        let den = orient2(g.thick, a, b);
        if den != 0.0 {
            t = min(t, orient2(p, a, b) / den);
        }
    }
    return t;
}

var<workgroup> w_range: vec2<u32>;
var<workgroup> w_done: atomic<u32>;
var<workgroup> w_done_plain: u32;
// One batch of the tile's list, loaded cooperatively: slot, silhouette,
// pixel-centre box and area sign (0: covers nothing).
var<workgroup> b_slot: array<u32, BATCH>;
var<workgroup> b_geom: array<TetGeom, BATCH>;
var<workgroup> b_box: array<vec4<f32>, BATCH>;
var<workgroup> b_sgn: array<f32, BATCH>;

@compute @workgroup_size(16, 16)
fn composite(
    @builtin(workgroup_id) wid: vec3<u32>,
    @builtin(local_invocation_id) lid3: vec3<u32>,
    @builtin(local_invocation_index) lid: u32,
) {
    let tile = wid.x + wid.y * bp.tiles_x;
    let px = wid.x * TILE + lid3.x;
    let py = wid.y * TILE + lid3.y;
    let inside = f32(px) < fr.width && f32(py) < fr.height;
    let pix = py * u32(fr.width) + px;
    var acc = vec4<f32>(0.0);
    if inside {
        acc = accum[pix];
    }
    var alive = inside && acc.a < OPAQUE_ALPHA;
    if lid == 0u {
        w_range = ranges[tile];
        atomicStore(&w_done, 0u);
    }
    workgroupBarrier();
    if !alive {
        atomicAdd(&w_done, 1u);
    }
    let r = workgroupUniformLoad(&w_range);
    let p = vec2<f32>(f32(px) + 0.5, f32(py) + 0.5);
    for (var start = r.x; start < r.y; start += BATCH) {
        let count = min(BATCH, r.y - start);
        if lid < count {
            let slot = vals[start + lid];
            let g = geoms[slot];
            var lo = vec2<f32>(3.0e38);
            var hi = vec2<f32>(-3.0e38);
            for (var i = 0u; i < g.n_hull; i++) {
                lo = min(lo, g.hull[i]);
                hi = max(hi, g.hull[i]);
            }
            let area = poly_area(g);
            b_slot[lid] = slot;
            b_geom[lid] = g;
            b_box[lid] = vec4<f32>(lo, hi);
            b_sgn[lid] = select(select(-1.0, 1.0, area > 0.0), 0.0, area == 0.0 || g.mode == GEOM_NONE);
        }
        workgroupBarrier();
        if alive {
            for (var k = 0u; k < count; k++) {
                let bx = b_box[k];
                let sgn = b_sgn[k];
                if sgn == 0.0 || p.x < bx.x || p.x > bx.z || p.y < bx.y || p.y > bx.w {
                    continue;
                }
                let g = b_geom[k];
                if !covers(g, sgn, p) {
                    continue;
                }
                var tent = 0.0;
                if g.mode == GEOM_THICK && SHADE_METHOD == METHOD_PT_LINEAR {
                    tent = tent_at(g, p);
                }
                let f = fragment_color(fr, g.mode, vec4<f32>(g.hull[4], g.hull[5]), tent, b_slot[k], p.x, p.y);
                if f.ok {
                    acc += (1.0 - acc.a) * f.rgba;
                }
            }
            if acc.a >= OPAQUE_ALPHA {
                alive = false;
                atomicAdd(&w_done, 1u);
            }
        }
        workgroupBarrier();
        if lid == 0u {
            w_done_plain = atomicLoad(&w_done);
        }
        if workgroupUniformLoad(&w_done_plain) == TILE * TILE {
            break;
        }
    }
    if inside {
        accum[pix] = acc;
        textureStore(out_tex, vec2<i32>(i32(px), i32(py)), acc);
    }
}
