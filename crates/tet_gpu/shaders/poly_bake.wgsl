// GPU bake of the poly1/2/4 tables (poly_bake.rs): one invocation per
// stored entry (row i, column col), tet_preint's `PolyTable::build` in f32:
// ρ̂ = ∫ρ/(Sb − Sf) (ρ(Sf) on the diagonal), the n slices l = k·l_max/n by
// `integrate_entry`'s per-piece closed forms with panelled 6-point
// Gauss–Legendre for G = ∫(1 − e^{−E}), Ĉ_k = C_k / w_k, and the
// polynomial coefficients C̃ = V⁻¹·Ĉ.

struct PolyBakeParams {
    degree: u32,
    res: u32,
    row_len: u32,
    // Band half-width, or 0xffffffff for the full square.
    band: u32,
    n_nodes: u32,
    independent: u32,
    _pad0: u32,
    _pad1: u32,
    l_max: f32,
    _pad2: f32,
    _pad3: f32,
    _pad4: f32,
}

@group(0) @binding(0) var<uniform> pp: PolyBakeParams;
// TF nodes (colour and opacity merged, ascending): 2q = (s, ρ, 0, 0), 2q + 1 = (κ, 0).
@group(0) @binding(1) var<storage, read> nodes: array<vec4<f32>>;
// (Vandermonde at t = i/n)⁻¹, row-major (n + 1)².
@group(0) @binding(2) var<storage, read> vinv: array<f32>;
@group(0) @binding(3) var<storage, read> grid: array<f32>;
@group(0) @binding(4) var<storage, read_write> out_rho: array<f32>;
@group(0) @binding(5) var<storage, read_write> out_coef: array<f32>;

const PANEL_DEPTH: f32 = 1.5;
const GL_X = array<f32, 6>(0.033765242898423975, 0.16939530676686776, 0.38069040695840156, 0.6193095930415985, 0.8306046932331322, 0.966234757101576);
const GL_W = array<f32, 6>(0.0856622461895852, 0.1803807865240693, 0.2339569672863455, 0.2339569672863455, 0.1803807865240693, 0.0856622461895852);

// 1 − e^{−x} without cancellation for small x ≥ 0.
fn one_minus_exp(x: f32) -> f32 {
    if x < 0.05 {
        return x * (1.0 - 0.5 * x * (1.0 - x / 3.0 * (1.0 - 0.25 * x * (1.0 - 0.2 * x))));
    }
    return 1.0 - exp(-x);
}

// (ρ, κ) at s: linear between the merged nodes, clamped outside.
fn profile(s: f32) -> vec4<f32> {
    let n = pp.n_nodes;
    var i = 0u;
    while i < n && nodes[2u * i].x <= s {
        i++;
    }
    if i == 0u {
        return vec4<f32>(nodes[0].y, nodes[1].xyz);
    }
    if i == n {
        return vec4<f32>(nodes[2u * n - 2u].y, nodes[2u * n - 1u].xyz);
    }
    let p = nodes[2u * i - 2u];
    let q = nodes[2u * i];
    let f = (s - p.x) / (q.x - p.x);
    let kp = nodes[2u * i - 1u].xyz;
    let kq = nodes[2u * i + 1u].xyz;
    return vec4<f32>(p.y + f * (q.y - p.y), kp + f * (kq - kp));
}

@compute @workgroup_size(64)
fn poly_bake(@builtin(global_invocation_id) gid: vec3<u32>) {
    let col = gid.x;
    let i = gid.y;
    if col >= pp.row_len || i >= pp.res {
        return;
    }
    var j = col;
    if pp.band != 0xffffffffu {
        j = min(u32(max(i32(i + col) - i32(pp.band), 0)), pp.res - 1u);
    }
    let n = pp.degree;
    let sf = grid[i];
    let sb = grid[j];
    let pf = profile(sf);
    let pb = profile(sb);
    var chat: array<vec3<f32>, 5>;
    var rho_hat: f32;
    if i == j {
        rho_hat = max(pf.x, 0.0);
        for (var k = 0u; k <= n; k++) {
            chat[k] = pf.yzw;
        }
    } else {
        let independent = pp.independent != 0u;
        let width = abs(sb - sf);
        let per_scalar = pp.l_max / width;
        let inv_n = 1.0 / f32(n);
        var int_rho = 0.0;
        var int_krho = vec3<f32>(0.0);
        var int_k = vec3<f32>(0.0);
        var color: array<vec3<f32>, 4>;
        var trans = array<f32, 4>(1.0, 1.0, 1.0, 1.0);
        var depth_total = 0.0;
        var saturated = false;
        // Knots: Sf, the nodes strictly between in the segment's order, Sb.
        let up = sb > sf;
        var q: i32;
        if up {
            q = 0;
            while q < i32(pp.n_nodes) && nodes[2 * q].x <= sf {
                q++;
            }
        } else {
            q = i32(pp.n_nodes) - 1;
            while q >= 0 && nodes[2 * q].x >= sf {
                q--;
            }
        }
        var s0 = sf;
        var r0 = pf.x;
        var k0 = pf.yzw;
        var done = false;
        loop {
            if done {
                break;
            }
            var s1 = sb;
            var r1 = pb.x;
            var k1 = pb.yzw;
            let inside = q >= 0 && q < i32(pp.n_nodes) && nodes[2 * q].x > min(sf, sb) && nodes[2 * q].x < max(sf, sb);
            if inside {
                s1 = nodes[2 * q].x;
                r1 = nodes[2 * q].y;
                k1 = nodes[2 * q + 1].xyz;
                q += select(-1, 1, up);
            } else {
                done = true;
            }
            let ds = abs(s1 - s0);
            int_rho += 0.5 * ds * (r0 + r1);
            int_k += 0.5 * ds * (k0 + k1);
            int_krho += ds / 6.0 * (k0 * r0 + 4.0 * (0.5 * (k0 + k1)) * (0.5 * (r0 + r1)) + k1 * r1);
            if !saturated {
                let d = ds * per_scalar;
                let a = r0 * d;
                let a_end = r1 * d;
                let b = a_end - a;
                let depth = 0.5 * (a + a_end);
                depth_total += depth;
                if depth == 0.0 {
                    if independent {
                        for (var k = 1u; k <= n; k++) {
                            let dk = d * f32(k) * inv_n;
                            color[k - 1u] += trans[k - 1u] * dk * 0.5 * (k0 + k1);
                        }
                    }
                } else {
                    var g = array<f32, 4>(0.0, 0.0, 0.0, 0.0);
                    var p0 = array<f32, 4>(0.0, 0.0, 0.0, 0.0);
                    var p1 = array<f32, 4>(0.0, 0.0, 0.0, 0.0);
                    let panels = u32(clamp(ceil(max(a, a_end) / PANEL_DEPTH), 1.0, 1.0e9));
                    let h = 1.0 / f32(panels);
                    for (var p = 0u; p < panels; p++) {
                        let x0 = f32(p) * h;
                        if (a * x0 + 0.5 * b * x0 * x0) * inv_n > 40.0 {
                            for (var k = 1u; k <= n; k++) {
                                g[k - 1u] += 1.0 - x0;
                            }
                            break;
                        }
                        for (var gi = 0u; gi < 6u; gi++) {
                            let x = x0 + h * GL_X[gi];
                            let wn = GL_W[gi];
                            let e = (a + 0.5 * b * x) * x * inv_n;
                            let m = one_minus_exp(e);
                            let e1 = 1.0 - m;
                            var pw = 1.0;
                            var geo = 0.0;
                            for (var k = 1u; k <= n; k++) {
                                geo += pw;
                                pw *= e1;
                                g[k - 1u] += wn * h * m * geo;
                                p0[k - 1u] += wn * h * pw;
                                p1[k - 1u] += wn * h * x * pw;
                            }
                        }
                    }
                    for (var k = 1u; k <= n; k++) {
                        let frac = f32(k) * inv_n;
                        let alpha_piece = one_minus_exp(depth * frac);
                        let t = trans[k - 1u];
                        if independent {
                            let dk = d * frac;
                            color[k - 1u] += t * dk * (k0 * p0[k - 1u] + (k1 - k0) * p1[k - 1u]);
                        } else {
                            let gk = g[k - 1u];
                            color[k - 1u] += t * (k0 * gk + k1 * (alpha_piece - gk));
                        }
                        trans[k - 1u] = t * (1.0 - alpha_piece);
                    }
                }
                saturated = trans[0] < 1.0e-30;
            }
            s0 = s1;
            r0 = r1;
            k0 = k1;
        }
        rho_hat = max(int_rho / width, 0.0);
        if !independent && int_rho > 0.0 {
            chat[0] = int_krho / int_rho;
        } else {
            chat[0] = int_k / width;
        }
        for (var k = 1u; k <= n; k++) {
            let l = pp.l_max * f32(k) * inv_n;
            var w: f32;
            if independent {
                let x = l * rho_hat;
                if x > 1.0e-8 {
                    w = one_minus_exp(x) / rho_hat;
                } else {
                    w = l * (1.0 - 0.5 * x);
                }
            } else {
                w = one_minus_exp(depth_total * f32(k) * inv_n);
            }
            if w > 1.0e-9 * min(l, 1.0) && w > 1.0e-12 {
                chat[k] = color[k - 1u] / w;
            } else {
                chat[k] = chat[0];
            }
        }
    }
    let e = i * pp.row_len + col;
    out_rho[e] = rho_hat;
    let stride = 3u * (n + 1u);
    for (var r = 0u; r <= n; r++) {
        var v = vec3<f32>(0.0);
        for (var qq = 0u; qq <= n; qq++) {
            v += vinv[r * (n + 1u) + qq] * chat[qq];
        }
        out_coef[e * stride + r * 3u] = v.x;
        out_coef[e * stride + r * 3u + 1u] = v.y;
        out_coef[e * stride + r * 3u + 2u] = v.z;
    }
}
