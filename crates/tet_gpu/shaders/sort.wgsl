// Prefix sums and a stable LSD radix sort of (key, value) pairs, 4 bits a
// pass: the GPU sort of centroid depths (the fast approximate visibility
// order) and the binning of tets into screen tiles (bin.wgsl). Entry
// points, each dispatched with `SortParams` at a dynamic offset:
//
// * scan_blocks / scan_sums / scan_add: exclusive prefix sum of `data[0..n]`
//   in place, 1024 elements a workgroup, block sums in `sums`, the total in
//   `sums[n_blocks]`.
// * depth_keys: key = order-preserving bits of each tet's centroid depth,
//   value = tet index (tet_render's centroid order).
// * rs_hist / rs_scatter: one radix pass on the digit at `shift`: digit
//   counts per 256-element block into `hist` (digit-major, then scanned
//   with scan_*), then a stable scatter (rank within the block by a
//   workgroup prefix sum of packed one-hot counters).

struct SortParams {
    eye_rel: vec4<f32>,
    forward: vec4<f32>,
    n: u32,
    shift: u32,
    n_blocks: u32,
    groups_x: u32,
}

@group(0) @binding(0) var<uniform> sp: SortParams;

const WG: u32 = 256u;
const SCAN_PER: u32 = 4u;
const SCAN_BLOCK: u32 = 1024u;

fn block_id(wid: vec3<u32>) -> u32 {
    return wid.x + wid.y * sp.groups_x;
}

// ---- prefix sums --------------------------------------------------------

@group(0) @binding(1) var<storage, read_write> data: array<u32>;
@group(0) @binding(2) var<storage, read_write> sums: array<u32>;

var<workgroup> wsum: array<u32, 256>;

// Exclusive prefix of v over the workgroup (Hillis–Steele); wsum[255]
// holds the total afterwards.
fn wg_exclusive(lid: u32, v: u32) -> u32 {
    wsum[lid] = v;
    workgroupBarrier();
    for (var off = 1u; off < WG; off <<= 1u) {
        var t = 0u;
        if lid >= off {
            t = wsum[lid - off];
        }
        workgroupBarrier();
        wsum[lid] += t;
        workgroupBarrier();
    }
    return wsum[lid] - v;
}

@compute @workgroup_size(256)
fn scan_blocks(@builtin(workgroup_id) wid: vec3<u32>, @builtin(local_invocation_index) lid: u32) {
    let b = block_id(wid);
    let base = b * SCAN_BLOCK + lid * SCAN_PER;
    var v: array<u32, 4>;
    var t = 0u;
    for (var k = 0u; k < SCAN_PER; k++) {
        var x = 0u;
        if base + k < sp.n {
            x = data[base + k];
        }
        v[k] = t;
        t += x;
    }
    let ex = wg_exclusive(lid, t);
    for (var k = 0u; k < SCAN_PER; k++) {
        if base + k < sp.n {
            data[base + k] = ex + v[k];
        }
    }
    if lid == WG - 1u && b < sp.n_blocks {
        sums[b] = ex + t;
    }
}

// One workgroup: the block sums, 1024 at a time with a carry.
@compute @workgroup_size(256)
fn scan_sums(@builtin(local_invocation_index) lid: u32) {
    var carry = 0u;
    for (var start = 0u; start < sp.n_blocks; start += SCAN_BLOCK) {
        let base = start + lid * SCAN_PER;
        var v: array<u32, 4>;
        var t = 0u;
        for (var k = 0u; k < SCAN_PER; k++) {
            var x = 0u;
            if base + k < sp.n_blocks {
                x = sums[base + k];
            }
            v[k] = t;
            t += x;
        }
        let ex = wg_exclusive(lid, t);
        for (var k = 0u; k < SCAN_PER; k++) {
            if base + k < sp.n_blocks {
                sums[base + k] = carry + ex + v[k];
            }
        }
        carry += wsum[WG - 1u];
        workgroupBarrier();
    }
    if lid == 0u {
        sums[sp.n_blocks] = carry;
    }
}

@compute @workgroup_size(256)
fn scan_add(@builtin(workgroup_id) wid: vec3<u32>, @builtin(local_invocation_index) lid: u32) {
    let b = block_id(wid);
    if b >= sp.n_blocks {
        return;
    }
    let add = sums[b];
    for (var k = 0u; k < SCAN_PER; k++) {
        let i = b * SCAN_BLOCK + k * WG + lid;
        if i < sp.n {
            data[i] += add;
        }
    }
}

// ---- radix sort ---------------------------------------------------------

@group(0) @binding(3) var<storage, read> keys_in: array<u32>;
@group(0) @binding(4) var<storage, read> vals_in: array<u32>;
@group(0) @binding(5) var<storage, read_write> keys_out: array<u32>;
@group(0) @binding(6) var<storage, read_write> vals_out: array<u32>;
@group(0) @binding(7) var<storage, read_write> hist: array<u32>;
@group(0) @binding(8) var<storage, read> positions: array<vec4<f32>>;
@group(0) @binding(9) var<storage, read> tets: array<vec4<u32>>;

// Order-preserving map of an f32 onto u32 (tet_render's f32_key).
fn f32_key(x: f32) -> u32 {
    let b = bitcast<u32>(x);
    if (b >> 31u) == 1u {
        return ~b;
    }
    return b | 0x80000000u;
}

@compute @workgroup_size(256)
fn depth_keys(@builtin(global_invocation_id) gid: vec3<u32>) {
    let i = gid.x + gid.y * sp.groups_x * WG;
    if i >= sp.n {
        return;
    }
    let t = tets[i];
    let c = positions[t.x].xyz + positions[t.y].xyz + positions[t.z].xyz + positions[t.w].xyz;
    keys_out[i] = f32_key(dot(c * 0.25 - sp.eye_rel.xyz, sp.forward.xyz));
    vals_out[i] = i;
}

var<workgroup> digit_count: array<atomic<u32>, 16>;

@compute @workgroup_size(256)
fn rs_hist(@builtin(workgroup_id) wid: vec3<u32>, @builtin(local_invocation_index) lid: u32) {
    let b = block_id(wid);
    if lid < 16u {
        atomicStore(&digit_count[lid], 0u);
    }
    workgroupBarrier();
    let i = b * WG + lid;
    if i < sp.n {
        atomicAdd(&digit_count[(keys_in[i] >> sp.shift) & 15u], 1u);
    }
    workgroupBarrier();
    if lid < 16u && b < sp.n_blocks {
        hist[lid * sp.n_blocks + b] = atomicLoad(&digit_count[lid]);
    }
}

// 16 counters of 16 bits, digit d in word d / 2, half d % 2.
var<workgroup> packed_lo: array<vec4<u32>, 256>;
var<workgroup> packed_hi: array<vec4<u32>, 256>;

@compute @workgroup_size(256)
fn rs_scatter(@builtin(workgroup_id) wid: vec3<u32>, @builtin(local_invocation_index) lid: u32) {
    let b = block_id(wid);
    let i = b * WG + lid;
    let valid = i < sp.n;
    var key = 0u;
    var d = 0u;
    var lo = vec4<u32>(0u);
    var hi = vec4<u32>(0u);
    if valid {
        key = keys_in[i];
        d = (key >> sp.shift) & 15u;
        let one = 1u << (16u * (d & 1u));
        let w = (d >> 1u) & 3u;
        if d < 8u {
            lo[w] = one;
        } else {
            hi[w] = one;
        }
    }
    packed_lo[lid] = lo;
    packed_hi[lid] = hi;
    workgroupBarrier();
    for (var off = 1u; off < WG; off <<= 1u) {
        var tl = vec4<u32>(0u);
        var th = vec4<u32>(0u);
        if lid >= off {
            tl = packed_lo[lid - off];
            th = packed_hi[lid - off];
        }
        workgroupBarrier();
        packed_lo[lid] += tl;
        packed_hi[lid] += th;
        workgroupBarrier();
    }
    if valid {
        let w = (d >> 1u) & 3u;
        var word: u32;
        if d < 8u {
            word = packed_lo[lid][w];
        } else {
            word = packed_hi[lid][w];
        }
        let rank = ((word >> (16u * (d & 1u))) & 0xffffu) - 1u;
        let dst = hist[d * sp.n_blocks + b] + rank;
        keys_out[dst] = key;
        vals_out[dst] = vals_in[i];
    }
}
