// Per-cell culling on the GPU (tet_render's TfCuller semantics) and stream
// compaction of the visibility order:
//
// 1. cull_flags: flags[i] = 1 when the tet in slot i of `order_in` is
//    visible, else 0.
// 2. (sort.wgsl) exclusive prefix sum of the flags → each visible slot's
//    position in the compacted order; the total is the visible count.
// 3. cull_scatter: order_out[flags[i]] = order_in[i] for visible slots, so
//    the compacted order keeps the visibility order.
//
// A cell is invisible when its scalar range [min, max] lies in one of the
// transfer function's closed invisible intervals. The comparison is made on
// ranks: every distinct vertex scalar (f64 on the CPU) is replaced by its
// index in the sorted distinct scalars, and each interval [lo, hi] by the
// half-open rank range [first rank ≥ lo, first rank > hi), so the GPU's
// decision equals the CPU's f64 one exactly (no f32 rounding at interval ends).
// With 2D widgets (TfCuller's bivariate test) a cell in an invisible
// interval stays visible when its (scalar, |∇s|) rank box meets the support
// rectangle of a widget that can show, mapped onto ranks the same way (the
// |∇s| sides only when the scene has gradient magnitudes).

struct CullParams {
    n: u32,
    n_intervals: u32,
    groups_x: u32,
    n_widgets: u32,
    use_g: u32,
    _pad0: u32,
    _pad1: u32,
    _pad2: u32,
}

@group(0) @binding(0) var<uniform> cp: CullParams;
@group(0) @binding(1) var<storage, read> tets: array<vec4<u32>>;
@group(0) @binding(2) var<storage, read> ranks: array<u32>;
@group(0) @binding(3) var<storage, read> intervals: array<vec2<u32>>;
@group(0) @binding(4) var<storage, read> order_in: array<u32>;
@group(0) @binding(5) var<storage, read_write> flags: array<u32>;
@group(0) @binding(6) var<storage, read_write> order_out: array<u32>;
@group(0) @binding(7) var<storage, read> g_ranks: array<u32>;
// Per widget: [first s rank ≥ s0, first s rank > s1, same for g).
@group(0) @binding(8) var<storage, read> widgets: array<vec4<u32>>;

const CULL_WG: u32 = 64u;

fn slot_of(gid: vec3<u32>) -> u32 {
    return gid.x + gid.y * cp.groups_x * CULL_WG;
}

// Whether tet t contributes: its rank range meets no invisible interval
// wholly (intervals are sorted and disjoint; a binary search finds the
// first whose end lies above the range's maximum).
fn visible(t: u32) -> bool {
    let v = tets[t];
    let r = vec4<u32>(ranks[v.x], ranks[v.y], ranks[v.z], ranks[v.w]);
    let lo = min(min(r.x, r.y), min(r.z, r.w));
    let hi = max(max(r.x, r.y), max(r.z, r.w));
    var a = 0u;
    var b = cp.n_intervals;
    while a < b {
        let mid = (a + b) / 2u;
        if intervals[mid].y <= hi {
            a = mid + 1u;
        } else {
            b = mid;
        }
    }
    if !(a < cp.n_intervals && intervals[a].x <= lo) {
        return true;
    }
    if cp.n_widgets == 0u {
        return false;
    }
    var glo = 0u;
    var ghi = 0u;
    if cp.use_g != 0u {
        let q = vec4<u32>(g_ranks[v.x], g_ranks[v.y], g_ranks[v.z], g_ranks[v.w]);
        glo = min(min(q.x, q.y), min(q.z, q.w));
        ghi = max(max(q.x, q.y), max(q.z, q.w));
    }
    for (var w = 0u; w < cp.n_widgets; w++) {
        let r = widgets[w];
        if hi >= r.x && lo < r.y && (cp.use_g == 0u || (ghi >= r.z && glo < r.w)) {
            return true;
        }
    }
    return false;
}

@compute @workgroup_size(64)
fn cull_flags(@builtin(global_invocation_id) gid: vec3<u32>) {
    let i = slot_of(gid);
    if i >= cp.n {
        return;
    }
    flags[i] = select(0u, 1u, visible(order_in[i]));
}

@compute @workgroup_size(64)
fn cull_scatter(@builtin(global_invocation_id) gid: vec3<u32>) {
    let i = slot_of(gid);
    if i >= cp.n {
        return;
    }
    let t = order_in[i];
    if visible(t) {
        order_out[flags[i]] = t;
    }
}
