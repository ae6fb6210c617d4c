// GPU pre-integration of table3d (bake.rs): one invocation per entry
// (Sf = grid[a], Sb = grid[b], l = k·Δl), written straight into the 3D
// texture the renderer samples (texel (k, b, a), as fragment.wgsl reads it).
//
// The integration is tet_preint's slice-recurrence build (table3d.rs,
// `recurrence_pair`) per entry: the segment u ∈ [0, 1] is cut at
// ⌈o·|b − a|⌉ equal steps and at every TF node in between (so κ and ρ are
// linear on each piece), a piece over which ρ changes enough to bend ln T
// (l_max·|Δρ|·Δu > bend), or whose estimated colour error (SPLIT_ERROR,
// weighted by the transmittance at l_max in front of it) is too large, is
// split evenly (at most 64 ways), and on each piece T falls exponentially:
//   density emission:     C = κ_f − κ_b·T_end + Σ Δκᵢ·q̄ᵢ      (by parts)
//   independent emission: C = l·Σ Δuᵢ·(κᵢ·q̄ᵢ + Δκᵢ·m̄ᵢ)
// with q̄ = ∫₀¹ T dx and m̄ = ∫₀¹ x·T dx over the piece (series below
// λ = 0.05 and 0.3, as the CPU), α = 1 − T_end. Two differences from the
// CPU, both at rounding level: the optical depth of a piece is its exact
// trapezoid λ = l·Δu·(ρ₀ + ρ₁)/2 (ρ is linear on it) instead of a
// difference of f64 prefix integrals, and T is carried by T·e^{−λ} along
// the segment instead of by slices (one thread per entry has no state
// across slices).
//
// `f16 = 1` is the precision study's f16 accumulation: the running
// transmittance and colour sums are rounded to f16 after every piece
// (`round_f16`: bit arithmetic, so no SHADER_F16 feature is needed).

struct BakeParams {
    n_s: u32,
    n_l: u32,
    n_color: u32,
    n_opacity: u32,
    n_breaks: u32,
    row_width: u32,
    independent: u32,
    f16: u32,
    dl: f32,
    len_max: f32,
    oversampling: f32,
    bend: f32,
}

@group(0) @binding(0) var<uniform> bp: BakeParams;
// Colour nodes (x, r, g, b), then opacity nodes (x, ρ, 0, 0).
@group(0) @binding(1) var<storage, read> tf: array<vec4<f32>>;
// Scalar of every grid index.
@group(0) @binding(2) var<storage, read> grid: array<f32>;
// Per row a: the stored b range [lo, hi].
@group(0) @binding(3) var<storage, read> rows: array<vec2<u32>>;
// Every TF node's x, ascending, without repeats.
@group(0) @binding(4) var<storage, read> breaks: array<f32>;
@group(0) @binding(5) var out_table: texture_storage_3d<rgba32float, write>;

const LAM_SMALL: f32 = 0.05;
const LAM_SMALL_1: f32 = 0.3;
const T_FLUSH: f32 = 1.0e-30;
const MAX_SPLIT: f32 = 64.0;
// tet_preint's SPLIT_ERROR (table3d.rs): largest estimated colour error per
// unit u of the chord rule on a piece, times r² for r pieces.
const SPLIT_ERROR: f32 = 1.0e-4;

// max over x ∈ [0, 1] of x·e^{−x·τ} (tet_preint's attenuation_linear).
fn attenuation_linear(tau: f32) -> f32 {
    if tau <= 1.0 {
        return exp(-tau);
    }
    return exp(-1.0) / tau;
}

// max over x ∈ [0, 1] of x²·e^{−x·τ} (tet_preint's attenuation).
fn attenuation(tau: f32) -> f32 {
    if tau <= 2.0 {
        return exp(-tau);
    }
    return 4.0 * exp(-2.0) / (tau * tau);
}
const BAKE_WG: u32 = 64u;

// κ(s), clamped outside the nodes.
fn bake_color(s: f32) -> vec3<f32> {
    let n = bp.n_color;
    var i = 0u;
    while i < n && tf[i].x <= s {
        i++;
    }
    if i == 0u {
        return tf[0].yzw;
    }
    if i == n {
        return tf[n - 1u].yzw;
    }
    let p = tf[i - 1u];
    let q = tf[i];
    return p.yzw + (s - p.x) / (q.x - p.x) * (q.yzw - p.yzw);
}

// ρ(s), clamped outside the nodes.
fn bake_rho(s: f32) -> f32 {
    let o = bp.n_color;
    let n = bp.n_opacity;
    var i = 0u;
    while i < n && tf[o + i].x <= s {
        i++;
    }
    if i == 0u {
        return tf[o].y;
    }
    if i == n {
        return tf[o + n - 1u].y;
    }
    let p = tf[o + i - 1u];
    let q = tf[o + i];
    return p.y + (s - p.x) / (q.x - p.x) * (q.y - p.y);
}

// x rounded to the nearest f16 value (ties to even, f16 subnormals kept,
// overflow to ±∞), returned as f32. Bit arithmetic rather than
// pack2x16float, which naga accepts only with a float16 capability.
fn round_f16(x: f32) -> f32 {
    let sign = bitcast<u32>(x) & 0x80000000u;
    let a = abs(x);
    if a >= 65520.0 {
        return bitcast<f32>(sign | 0x7f800000u);
    }
    if a < 6.103515625e-5 {
        // Subnormal f16: multiples of 2⁻²⁴ (the scaling is exact).
        return bitcast<f32>(sign | bitcast<u32>(round(a * 16777216.0) / 16777216.0));
    }
    let b = bitcast<u32>(a);
    let r = (b + 0x0fffu + ((b >> 13u) & 1u)) & 0xffffe000u;
    return bitcast<f32>(sign | r);
}

// The accumulation precision: f32, or f16 (the precision study).
fn acc_round(x: f32) -> f32 {
    if bp.f16 != 0u {
        return round_f16(x);
    }
    return x;
}

fn acc_round3(v: vec3<f32>) -> vec3<f32> {
    return vec3<f32>(acc_round(v.x), acc_round(v.y), acc_round(v.z));
}

// u of TF node p inside the open scalar range (lo, hi) of the segment, 2
// (past the end) otherwise.
fn break_u(p: i32, sf: f32, sb: f32) -> f32 {
    if p < 0 || p >= i32(bp.n_breaks) {
        return 2.0;
    }
    let x = breaks[p];
    if x > min(sf, sb) && x < max(sf, sb) {
        return (x - sf) / (sb - sf);
    }
    return 2.0;
}

fn bake_entry(a: u32, b: u32, k: u32) -> vec4<f32> {
    let sf = grid[a];
    let sb = grid[b];
    let l = f32(k) * bp.dl;
    let independent = bp.independent != 0u;
    let m = max(u32(ceil(bp.oversampling * f32(max(a, b) - min(a, b)))), 1u);
    // TF nodes in the order the segment meets them.
    var first = 0;
    while first < i32(bp.n_breaks) && breaks[first] < sf {
        first++;
    }
    var p: i32;
    var step: i32;
    if sb > sf {
        p = first;
        while p < i32(bp.n_breaks) && breaks[p] <= sf {
            p++;
        }
        step = 1;
    } else {
        p = first - 1;
        step = -1;
    }
    var ub = break_u(p, sf, sb);
    let bend_scale = bp.len_max / bp.bend;

    var u0 = 0.0;
    var rho0 = bake_rho(sf);
    var kap0 = bake_color(sf);
    var t = 1.0;
    var acc = vec3<f32>(0.0);
    // Optical depth at l_max in front of the piece (the split rule's).
    var depth0 = 0.0;
    var i = 1u;
    // Pieces: at most m uniform steps plus one per TF node.
    let guard = m + bp.n_breaks + 2u;
    for (var piece = 0u; piece < guard; piece++) {
        if u0 >= 1.0 || t == 0.0 {
            break;
        }
        let uu = select(f32(i) / f32(m), 1.0, i >= m);
        var u1: f32;
        if ub < uu - 1.0e-6 {
            u1 = ub;
            p += step;
            ub = break_u(p, sf, sb);
        } else {
            u1 = uu;
            i++;
            if ub <= uu + 1.0e-6 {
                p += step;
                ub = break_u(p, sf, sb);
            }
        }
        let s1 = select(sf + (sb - sf) * u1, sb, u1 >= 1.0);
        let rho1 = bake_rho(s1);
        let kap1 = bake_color(s1);
        let du = u1 - u0;
        let l_drho = bp.len_max * abs(rho1 - rho0);
        var err_r2: f32;
        if independent {
            let kmax = max(kap0, kap1);
            err_r2 = max(kmax.x, max(kmax.y, kmax.z)) * bp.len_max * l_drho * du / 12.0 * attenuation(depth0);
        } else {
            let dk = abs(kap1 - kap0);
            err_r2 = max(dk.x, max(dk.y, dk.z)) * l_drho / 12.0 * attenuation_linear(depth0);
        }
        let r_bend = ceil(bend_scale * abs(rho1 - rho0) * du);
        let r = u32(clamp(max(r_bend, ceil(sqrt(err_r2 / SPLIT_ERROR))), 1.0, MAX_SPLIT));
        depth0 += bp.len_max * du * 0.5 * (rho0 + rho1);
        let inv_r = 1.0 / f32(r);
        var pr = rho0;
        var pk = kap0;
        var pu = u0;
        for (var j = 1u; j <= r; j++) {
            let f = f32(j) * inv_r;
            let last = j == r;
            let nr = select(rho0 + (rho1 - rho0) * f, rho1, last);
            let nk = select(kap0 + (kap1 - kap0) * f, kap1, last);
            let nu = select(u0 + du * f, u1, last);
            let w = nu - pu;
            let lam = l * 0.5 * (pr + nr) * w;
            var tn = acc_round(t * exp(-lam));
            if tn < T_FLUSH {
                tn = 0.0;
            }
            var q: f32;
            if lam < LAM_SMALL {
                q = t * (1.0 - lam * (0.5 - lam * (1.0 / 6.0 - lam * (1.0 / 24.0))));
            } else {
                q = (t - tn) / lam;
            }
            let dk = nk - pk;
            if independent {
                var m1: f32;
                if lam < LAM_SMALL_1 {
                    m1 = t * (0.5 - lam * (1.0 / 3.0 - lam * (1.0 / 8.0 - lam * (1.0 / 30.0 - lam * (1.0 / 144.0 - lam * (1.0 / 840.0))))));
                } else {
                    m1 = (q - tn) / lam;
                }
                acc = acc_round3(acc + w * (pk * q + dk * m1));
            } else {
                acc = acc_round3(acc + dk * q);
            }
            t = tn;
            pr = nr;
            pk = nk;
            pu = nu;
            if t == 0.0 {
                break;
            }
        }
        u0 = u1;
        rho0 = rho1;
        kap0 = kap1;
    }
    var c: vec3<f32>;
    if independent {
        c = l * acc;
    } else {
        c = bake_color(sf) - bake_color(sb) * t + acc;
    }
    return vec4<f32>(max(c, vec3<f32>(0.0)), clamp(1.0 - t, 0.0, 1.0));
}

// x: slice k, y: b − lo(a) within row a, z: row a.
@compute @workgroup_size(BAKE_WG)
fn bake(@builtin(global_invocation_id) gid: vec3<u32>) {
    let k = gid.x;
    let a = gid.z;
    if k >= bp.n_l || a >= bp.n_s {
        return;
    }
    let row = rows[a];
    let b = row.x + gid.y;
    if b > row.y {
        return;
    }
    var e = vec4<f32>(0.0);
    if k > 0u {
        e = bake_entry(a, b, k);
    }
    textureStore(out_table, vec3<i32>(i32(k), i32(b), i32(a)), e);
}
