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
    // Table3d's reconstruction (tet_preint `Reconstruction`): trilinear
    // RGBA, or the optical depth −ln(1 − α) trilinear and the colour
    // trilinear scaled by α over the trilinear α.
    var lin = vec4<f32>(0.0);
    var tau_sum = 0.0;
    let depth = fr.table_optical_depth != 0u;
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
            lin += w * (e0 + fk * (e1 - e0));
            if !depth {
                continue;
            }
            tau_sum += w * ((1.0 - fk) * table_depth(e0.w) + fk * table_depth(e1.w));
        }
    }
    if !depth {
        return lin;
    }
    let tau = max(tau_sum, 0.0);
    var a = 1.0 - exp(-tau);
    if tau < TABLE_SERIES_BELOW {
        a = tau * (1.0 - tau * (0.5 - tau * (1.0 / 6.0 - tau * (1.0 / 24.0))));
    }
    let scale = select(1.0, a / lin.w, lin.w > 0.0);
    return vec4<f32>(lin.xyz * scale, a);
}

// tet_preint's MIN_TRANSMITTANCE: α = 1 entries count as optical depth 69.
const TABLE_MIN_TRANSMITTANCE: f32 = 1e-30;
// tet_preint's SERIES_BELOW: faint entries' depths and α by their series.
const TABLE_SERIES_BELOW: f32 = 0.015625;

// An entry's optical depth −ln(max(1 − α, MIN)) (tet_preint `optical_depths`).
fn table_depth(alpha: f32) -> f32 {
    if alpha < TABLE_SERIES_BELOW {
        return alpha * (1.0 + alpha * (0.5 + alpha * (1.0 / 3.0 + alpha * 0.25)));
    }
    return -log(max(1.0 - alpha, TABLE_MIN_TRANSMITTANCE));
}

// ---- The 2D-table methods (poly1/2/4, partial, atlas2d) -------------------

struct ShadeParams {
    s_lo: f32,
    s_scale: f32,
    inv_l_max: f32,
    alpha_inv_step: f32,
    max_color: vec4<f32>,
    res: u32,
    band: u32,
    degree: u32,
    independent: u32,
    alpha_len: u32,
    planes: u32,
    cols: u32,
    knots: u32,
    n_knots: u32,
    widgets: u32,
    n_widgets: u32,
    subsegments: u32,
}

// The method's 2D tables: poly — layer r holds C̃ᵣ (rgb) of entry (i, j) at
// texel (column, i), layer 0 also ρ̂ (a); partial — Ψ, Ψ₁ (r, g) at
// (γ_front, γ_back); atlas2d — the tiled planes (layer 0).
@group(0) @binding(14) var table2d: texture_2d_array<f32>;
// Poly's α(x) = 1 − e^{−x} at 16 bits (65535 = 1).
@group(0) @binding(15) var alpha_tab: texture_1d<u32>;
@group(0) @binding(16) var<uniform> shp: ShadeParams;

const NO_BAND: u32 = 0xffffffffu;

// 1 − e^{−x} for x ≥ 0 without cancellation for small x (series below
// 0.05, relative error < 1e-10 there).
fn one_minus_exp(x: f32) -> f32 {
    if x < 0.05 {
        return x * (1.0 - 0.5 * x * (1.0 - x / 3.0 * (1.0 - 0.25 * x * (1.0 - 0.2 * x))));
    }
    return 1.0 - exp(-x);
}

// AlphaTable::alpha: linear between the 16-bit samples, the last beyond.
fn poly_alpha(x: f32) -> f32 {
    let u = max(x * shp.alpha_inv_step, 0.0);
    let last = shp.alpha_len - 1u;
    if u >= f32(last) {
        return f32(textureLoad(alpha_tab, i32(last), 0).x) * (1.0 / 65535.0);
    }
    let k = u32(u);
    let f = u - f32(k);
    let a = f32(textureLoad(alpha_tab, i32(k), 0).x);
    let b = f32(textureLoad(alpha_tab, i32(k + 1u), 0).x);
    return (a + f * (b - a)) * (1.0 / 65535.0);
}

// Layer `layer` of poly entry (i, j): PolyTable's storage, a full square or
// diagonal bands (column j − i + b, clamped into the band).
fn poly_texel(i: u32, j: u32, layer: u32) -> vec4<f32> {
    var col = j;
    if shp.band != NO_BAND {
        let b = shp.band;
        col = min(select(0u, j + b - i, j + b >= i), 2u * b);
    }
    return textureLoad(table2d, vec2<i32>(i32(col), i32(i)), i32(layer), 0);
}

// PolyTable::lookup: bilinear ρ̂ and C̃ᵣ, α from the 16-bit table,
// C = w·Σ C̃ᵣ tʳ (t = l/l_max ≤ 1), clamped to [0, bound·max κ].
fn poly_lookup(sf: f32, sb: f32, len: f32) -> vec4<f32> {
    let l = min(max(len, 0.0), 1.0e30);
    if l == 0.0 {
        return vec4<f32>(0.0);
    }
    let top = f32(shp.res - 1u);
    let u = min(max((sf - shp.s_lo) * shp.s_scale, 0.0), top);
    let v = min(max((sb - shp.s_lo) * shp.s_scale, 0.0), top);
    let i0 = min(u32(u), shp.res - 2u);
    let j0 = min(u32(v), shp.res - 2u);
    let fu = u - f32(i0);
    let fv = v - f32(j0);
    let w = array<f32, 4>((1.0 - fu) * (1.0 - fv), fu * (1.0 - fv), (1.0 - fu) * fv, fu * fv);
    let ii = array<u32, 4>(i0, i0 + 1u, i0, i0 + 1u);
    let jj = array<u32, 4>(j0, j0, j0 + 1u, j0 + 1u);
    var rho_hat = 0.0;
    var chat = vec3<f32>(0.0);
    for (var k = 0u; k < 4u; k++) {
        let e = poly_texel(ii[k], jj[k], 0u);
        rho_hat += w[k] * e.w;
        chat += w[k] * e.xyz;
    }
    let x = l * rho_hat;
    let alpha = poly_alpha(x);
    let t = min(l * shp.inv_l_max, 1.0);
    var tp = t;
    for (var r = 1u; r <= shp.degree; r++) {
        var v = vec3<f32>(0.0);
        for (var k = 0u; k < 4u; k++) {
            v += w[k] * poly_texel(ii[k], jj[k], r).xyz;
        }
        chat += tp * v;
        tp *= t;
    }
    var weight = alpha;
    var bound = alpha;
    if shp.independent != 0u {
        if x > 1.0e-4 {
            weight = one_minus_exp(x) / rho_hat;
        } else {
            weight = l * (1.0 - 0.5 * x);
        }
        bound = l;
    }
    return vec4<f32>(min(max(weight * chat, vec3<f32>(0.0)), bound * shp.max_color.xyz), alpha);
}

// Texel (x, y) of atlas plane `plane`: tile (plane mod cols, plane div cols).
fn atlas_texel(plane: u32, x: u32, y: u32) -> vec4<f32> {
    let tc = plane % shp.cols;
    let tr = plane / shp.cols;
    return textureLoad(table2d, vec2<i32>(i32(tc * shp.res + x), i32(tr * shp.res + y)), 0, 0);
}

// Atlas2d::bilinear over (s, t) ∈ [0, 1]² within one plane.
fn atlas_bilinear(plane: u32, s: f32, t: f32) -> vec4<f32> {
    let top = f32(shp.res - 1u);
    let xs = clamp(s * top, 0.0, top);
    let yt = clamp(t * top, 0.0, top);
    let x0 = min(u32(xs), shp.res - 2u);
    let y0 = min(u32(yt), shp.res - 2u);
    let fx = xs - f32(x0);
    let fy = yt - f32(y0);
    var out = vec4<f32>(0.0);
    for (var dy = 0u; dy < 2u; dy++) {
        let wy = select(1.0 - fy, fy, dy == 1u);
        for (var dx = 0u; dx < 2u; dx++) {
            let wx = select(1.0 - fx, fx, dx == 1u);
            out += (wx * wy) * atlas_texel(plane, x0 + dx, y0 + dy);
        }
    }
    return out;
}

// Atlas2d::lookup: (Sf, Sb, l) normalised to [0, 1], then the pseudo-angle α
// of Röttger & Ertl, "A Two-Step Approach for Interactive Pre-Integrated
// Volume Rendering of Unstructured Grids", 2002, and L∞ radius s (tet_preint::atlas2d::table_to_plane), the
// two planes nearest α blended linearly, bilinear in (s, t = Sb) in each.
fn atlas_lookup(sf: f32, sb: f32, len: f32) -> vec4<f32> {
    let nf = clamp((sf - shp.s_lo) * shp.s_scale, 0.0, 1.0);
    let nb = clamp((sb - shp.s_lo) * shp.s_scale, 0.0, 1.0);
    let w = clamp(len * shp.inv_l_max, 0.0, 1.0);
    let u = nf - nb;
    var alpha = 0.0;
    var s = 0.0;
    if u >= w {
        if u != 0.0 {
            alpha = w / (4.0 * u);
            s = u;
        }
    } else if u >= 0.0 {
        alpha = 0.5 - u / (4.0 * w);
        s = w;
    } else if -u <= w {
        alpha = 0.5 + (-u) / (4.0 * w);
        s = w;
    } else {
        alpha = 1.0 - w / (4.0 * (-u));
        s = -u;
    }
    let pm = f32(shp.planes - 1u);
    let x = clamp(alpha * pm, 0.0, pm);
    let p0 = min(u32(x), shp.planes - 2u);
    let f = x - f32(p0);
    let a = atlas_bilinear(p0, s, nb);
    let b = atlas_bilinear(p0 + 1u, s, nb);
    return a + f * (b - a);
}

// Partial: the TF's merged control points, two rows each after the TF
// nodes: (x, κ) and (ρ, 0, 0, 0).
fn knot_row(q: u32) -> vec4<f32> {
    return tf_nodes[shp.knots + 2u * q];
}
fn knot_rho(q: u32) -> f32 {
    return tf_nodes[shp.knots + 2u * q + 1u].x;
}

// Knots with x < s (x ≤ s when `or_equal`): a binary search.
fn knots_below(s: f32, or_equal: bool) -> u32 {
    var lo = 0u;
    var hi = shp.n_knots;
    while lo < hi {
        let mid = (lo + hi) / 2u;
        let x = knot_row(mid).x;
        if x < s || (or_equal && x == s) {
            lo = mid + 1u;
        } else {
            hi = mid;
        }
    }
    return lo;
}

// κ(s) (xyz) and ρ(s) (w), linear between the merged knots, clamped outside.
fn knot_eval(s: f32) -> vec4<f32> {
    let n = shp.n_knots;
    let i = knots_below(s, true);
    if i == 0u {
        return vec4<f32>(knot_row(0u).yzw, knot_rho(0u));
    }
    if i == n {
        return vec4<f32>(knot_row(n - 1u).yzw, knot_rho(n - 1u));
    }
    let a = knot_row(i - 1u);
    let b = knot_row(i);
    let t = (s - a.x) / (b.x - a.x);
    let ra = knot_rho(i - 1u);
    return vec4<f32>(a.yzw + t * (b.yzw - a.yzw), ra + t * (knot_rho(i) - ra));
}

// PsiTable::lookup: bilinear (Ψ, Ψ₁) over γ = x/(1 + x) per axis.
fn psi_lookup(a: f32, c: f32) -> vec2<f32> {
    let top = f32(shp.res - 1u);
    let ga = max(a, 0.0);
    let gc = max(c, 0.0);
    var x = top;
    var y = top;
    if ga < 1.0e30 {
        x = min(ga / (1.0 + ga) * top, top);
    }
    if gc < 1.0e30 {
        y = min(gc / (1.0 + gc) * top, top);
    }
    let i0 = min(u32(x), shp.res - 2u);
    let j0 = min(u32(y), shp.res - 2u);
    let fx = x - f32(i0);
    let fy = y - f32(j0);
    let e00 = textureLoad(table2d, vec2<i32>(i32(i0), i32(j0)), 0, 0).xy;
    let e10 = textureLoad(table2d, vec2<i32>(i32(i0 + 1u), i32(j0)), 0, 0).xy;
    let e01 = textureLoad(table2d, vec2<i32>(i32(i0), i32(j0 + 1u)), 0, 0).xy;
    let e11 = textureLoad(table2d, vec2<i32>(i32(i0 + 1u), i32(j0 + 1u)), 0, 0).xy;
    let r0 = e00 + fx * (e10 - e00);
    let r1 = e01 + fx * (e11 - e01);
    return r0 + fy * (r1 - r0);
}

// tet_preint's INDEPENDENT_DIRECT_RATE: above it independent emission does
// not read the table (its cells near γ = 1 are too coarse for Ψ ~ 1/rate).
const PARTIAL_DIRECT_RATE: f32 = 8.0;

// 8-point Gauss–Legendre nodes (positive half) and weights on [−1, 1].
const GL8_X = array<f32, 4>(0.18343464249564980, 0.52553240991632899, 0.79666647741362674, 0.96028985649753623);
const GL8_W = array<f32, 4>(0.36268378337836198, 0.31370664587788729, 0.22238103445337447, 0.10122853629037626);

// (Ψ, Ψ₁) = ∫₀¹ (1, x)·e^{−φ(x)} dx, φ = a x + (c − a) x²/2, a, c ≥ 0,
// max(a, c) > PARTIAL_DIRECT_RATE: φ increases on [0, 1], so only
// [0, x_end] with φ(x_end) = 40 counts (the rest weighs < e^{−40} of the
// start); 8 panels of 8-point Gauss–Legendre there (≤ 5 e-folds a panel
// where φ is near-linear: relative error ~1e-11 in exact arithmetic, f32
// rounding dominates). The CPU takes the f64 closed form (erfcx/Dawson).
fn psi_quadrature(a: f32, c: f32) -> vec2<f32> {
    let b = c - a;
    let depth = 40.0;
    // φ(x) = depth: x = 2·depth / (a + √(a² + 2 b depth)) (no cancellation);
    // no root (concave φ never reaching it) or beyond 1: the whole piece.
    var x_end = 1.0;
    let disc = a * a + 2.0 * b * depth;
    if disc > 0.0 && 0.5 * (a + c) > depth {
        x_end = min(1.0, 2.0 * depth / (a + sqrt(disc)));
    }
    let panels = 8u;
    let h = x_end / f32(panels);
    var psi = vec2<f32>(0.0);
    for (var p = 0u; p < panels; p++) {
        let mid = (f32(p) + 0.5) * h;
        for (var i = 0u; i < 4u; i++) {
            for (var sgn = 0u; sgn < 2u; sgn++) {
                let x = mid + select(-1.0, 1.0, sgn == 1u) * GL8_X[i] * 0.5 * h;
                let f = exp(-(a * x + 0.5 * b * x * x)) * GL8_W[i] * 0.5 * h;
                psi += vec2<f32>(f, f * x);
            }
        }
    }
    return psi;
}

// PartialShader::integrate in f32: the segment split at the TF's control
// points, each linear piece from the Ψ table (density emission:
// C = κ_f (1 − Ψ) + κ_b (Ψ − ζ); independent emission:
// C = d [κ_f Ψ + (κ_b − κ_f) Ψ₁], Ψ and Ψ₁ by quadrature above rate 8;
// ζ = e^{−(a + c)/2}), composited front to back.
fn partial_shade(sf: f32, sb: f32, len: f32) -> vec4<f32> {
    if !(len > 0.0) {
        return vec4<f32>(0.0);
    }
    let l = min(len, 1.0e30);
    let same = sf == sb;
    var per_scalar = 0.0;
    var first = 0u;
    var n_mid = 0u;
    if !same {
        let lo = min(sf, sb);
        let hi = max(sf, sb);
        per_scalar = l / (hi - lo);
        first = knots_below(lo, true);
        let end = knots_below(hi, false);
        n_mid = select(0u, end - first, end > first);
    }
    var x0 = sf;
    var e0 = knot_eval(sf);
    var color = vec3<f32>(0.0);
    var trans = 1.0;
    var depth = 0.0;
    for (var k = 0u; k <= n_mid; k++) {
        var x1 = sb;
        var e1: vec4<f32>;
        if k < n_mid {
            var q = first + k;
            if sb < sf {
                q = first + n_mid - 1u - k;
            }
            let row = knot_row(q);
            x1 = row.x;
            e1 = vec4<f32>(row.yzw, knot_rho(q));
        } else {
            e1 = knot_eval(sb);
        }
        var d = l;
        if !same {
            d = abs(x1 - x0) * per_scalar;
        }
        let a = d * e0.w;
        let c = d * e1.w;
        let piece_depth = 0.5 * (a + c);
        let zeta = exp(-piece_depth);
        var ck: vec3<f32>;
        if shp.independent == 0u {
            let p = psi_lookup(a, c);
            ck = e0.xyz * (1.0 - p.x) + e1.xyz * (p.x - zeta);
        } else {
            var p: vec2<f32>;
            if max(a, c) > PARTIAL_DIRECT_RATE {
                p = psi_quadrature(a, c);
            } else {
                p = psi_lookup(a, c);
            }
            ck = d * (e0.xyz * p.x + (e1.xyz - e0.xyz) * p.y);
        }
        color += trans * max(ck, vec3<f32>(0.0));
        trans *= zeta;
        depth += piece_depth;
        x0 = x1;
        e0 = e1;
    }
    return vec4<f32>(color, one_minus_exp(depth));
}

// The method these pipelines shade (`METHOD_*`, equal to `Frame.method`):
// a pipeline-overridable constant, so each method's pipelines are compiled
// with its own code only (the renderer builds one set per method).
override SHADE_METHOD: u32 = 1u;

// ---- biv-approx: 2D widgets, the F/B table ---------------------------------
// Song et al., "Bivariate Transfer Functions on Unstructured Grids", 2009, §5.

// Widget w's rows after the TF rows: (shape parameters), (colour, ρ_w =
// opacity / unit distance), (support s0, s1, g0, g1), (kind, bands: f_hi,
// f_lo, φ mod 1 — read by biv_exact.wgsl's `biv_band_v0`).
const WIDGET_BOX: u32 = 0u;
const WIDGET_GAUSSIAN: u32 = 1u;
const WIDGET_TRIANGLE: u32 = 2u;
const WIDGET_SINE: u32 = 3u;

fn widget_row(w: u32, r: u32) -> vec4<f32> {
    return tf_nodes[shp.widgets + 4u * w + r];
}

fn widget_contains(w: u32, s: f32, g: f32) -> bool {
    let sup = widget_row(w, 2u);
    return s >= sup.x && s <= sup.y && g >= sup.z && g <= sup.w;
}

// Widget::shape_unclipped: m(s, g) ∈ [0, 1].
fn widget_shape(w: u32, s: f32, g: f32) -> f32 {
    let p = widget_row(w, 0u);
    let kind = u32(widget_row(w, 3u).x);
    if kind == WIDGET_GAUSSIAN {
        let ds = (s - p.x) / p.z;
        let dg = (g - p.y) / p.w;
        return exp(-0.5 * (ds * ds + dg * dg));
    }
    if kind == WIDGET_TRIANGLE || kind == WIDGET_SINE {
        let x = p.x * s - p.y;
        // Rust's round: half away from zero.
        let r = sign(x) * floor(abs(x) + 0.5);
        if kind == WIDGET_TRIANGLE {
            return 1.0 - 2.0 * abs(x - r);
        }
        return 0.5 * (1.0 + cos(6.283185307179586 * (x - r)));
    }
    return 1.0;
}

// The TF at (s, g): colour κ(s, g) (xyz) and extinction ρ(s, g) (w), as
// TransferFunction::color2 and extinction2 (the 1D part from the merged
// knots plus every widget; summed extinctions).
fn tf2_eval(s: f32, g: f32) -> vec4<f32> {
    let one = knot_eval(s);
    var rho = one.w;
    var em = one.xyz;
    if shp.independent == 0u {
        em = one.xyz * one.w;
    }
    for (var w = 0u; w < shp.n_widgets; w++) {
        if !widget_contains(w, s, g) {
            continue;
        }
        let c = widget_row(w, 1u);
        let rw = c.w * widget_shape(w, s, g);
        rho += rw;
        if shp.independent == 0u {
            em += c.xyz * rw;
        } else {
            em += c.xyz;
        }
    }
    if shp.independent == 0u {
        if rho > 0.0 {
            em = em / rho;
        } else {
            em = one.xyz;
        }
    }
    return vec4<f32>(em, rho);
}

// FbTable::lookup: (F, B) at (α_f, α_b), bilinear, clamped to [0, 1]²
// (texel (j, i) holds entry (α_f index i, α_b index j)).
fn fb_lookup(alpha_f: f32, alpha_b: f32) -> vec2<f32> {
    let top = f32(shp.res - 1u);
    let u = min(max(alpha_f * top, 0.0), top);
    let v = min(max(alpha_b * top, 0.0), top);
    let i = min(u32(u), shp.res - 2u);
    let j = min(u32(v), shp.res - 2u);
    let fu = u - f32(i);
    let fv = v - f32(j);
    let t00 = textureLoad(table2d, vec2<i32>(i32(j), i32(i)), 0, 0).xy;
    let t01 = textureLoad(table2d, vec2<i32>(i32(j + 1u), i32(i)), 0, 0).xy;
    let t10 = textureLoad(table2d, vec2<i32>(i32(j), i32(i + 1u)), 0, 0).xy;
    let t11 = textureLoad(table2d, vec2<i32>(i32(j + 1u), i32(i + 1u)), 0, 0).xy;
    return (1.0 - fu) * ((1.0 - fv) * t00 + fv * t01) + fu * ((1.0 - fv) * t10 + fv * t11);
}

// BivApprox::integrate: k equal sub-segments; κ and ρ at their ends
// (s and g linear along the segment), each looked up in the F/B table and
// composited front to back.
fn biv_approx(seg: Seg) -> vec4<f32> {
    if !(seg.len > 0.0) {
        return vec4<f32>(0.0);
    }
    let k = shp.subsegments;
    let d = min(seg.len, 1.0e30) / f32(k);
    var e0 = tf2_eval(seg.sf, seg.gf);
    var acc = vec3<f32>(0.0);
    var trans = 1.0;
    for (var j = 1u; j <= k; j++) {
        let x = f32(j) / f32(k);
        let e1 = tf2_eval(seg.sf + x * (seg.sb - seg.sf), seg.gf + x * (seg.gb - seg.gf));
        let a0 = e0.w * d;
        let a1 = e1.w * d;
        let fb = fb_lookup(one_minus_exp(a0), one_minus_exp(a1));
        let depth = 0.5 * (a0 + a1);
        let alpha = one_minus_exp(depth);
        var scale = 1.0;
        if shp.independent != 0u {
            if depth > 1.0e-8 {
                scale = alpha * d / depth;
            } else {
                scale = d * (1.0 - 0.5 * depth);
            }
        }
        acc += trans * scale * (e0.xyz * fb.x + e1.xyz * fb.y);
        trans *= 1.0 - alpha;
        e0 = e1;
    }
    return vec4<f32>(acc, 1.0 - trans);
}

// Per slot, the gradient magnitude as a linear field (classify.wgsl, the
// bivariate methods only): two rows like TetShade's s_a, s_b (w: the tet's
// smallest and largest vertex value).
@group(0) @binding(18) var<storage, read> gshades: array<vec4<f32>>;

// (C, α) of one segment with the pipeline's method (pt-linear per fragment:
// clipped tets and the probe).
fn shade_segment(fr: Frame, seg: Seg) -> vec4<f32> {
    switch SHADE_METHOD {
        case METHOD_TABLE3D: {
            return table_lookup(fr, seg.sf, seg.sb, seg.len);
        }
        case METHOD_POLY: {
            return poly_lookup(seg.sf, seg.sb, seg.len);
        }
        case METHOD_PARTIAL: {
            return partial_shade(seg.sf, seg.sb, seg.len);
        }
        case METHOD_ATLAS2D: {
            return atlas_lookup(seg.sf, seg.sb, seg.len);
        }
        case METHOD_BIV_APPROX: {
            return biv_approx(seg);
        }
        case METHOD_BIV_EXACT: {
            return biv_exact(seg);
        }
        default: {
            return shade_pt_linear(fr, seg);
        }
    }
}

// The per-slot shading data (bound by the raster and bin modules).
@group(0) @binding(6) var<storage, read> shades: array<TetShade>;
// Lighting: per slot the gradient's linear fields (classify.wgsl).
@group(0) @binding(21) var<storage, read> nshades: array<vec4<f32>>;

// A piece of a lit segment (lighting.wgsl's light_segment): the method's colour.
fn shade_piece(fr: Frame, seg: Seg) -> vec4<f32> {
    return shade_segment(fr, seg);
}

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
    if SHADE_METHOD == METHOD_PT_LINEAR && mode == GEOM_THICK {
        let lam = clamp(tent, 0.0, 1.0);
        if lam <= 0.0 {
            return out;
        }
        out.rgba = thick_rgba * lam;
        out.ok = true;
        return out;
    }
    var seg = segment_at(fr, shades[slot], x, y);
    if !seg.ok {
        return out;
    }
    if SHADE_METHOD == METHOD_BIV_APPROX || SHADE_METHOD == METHOD_BIV_EXACT {
        // The gradient magnitude's field at the entry and exit depths,
        // clamped to the tet's vertex range (TetSetup::fragment).
        let ga = gshades[2u * slot];
        let gb = gshades[2u * slot + 1u];
        let base_a = ga.x + ga.y * x + ga.z * y;
        let base_b = gb.x + gb.y * x + gb.z * y;
        seg.gf = clamp(base_a + seg.zf * base_b, ga.w, gb.w);
        seg.gb = clamp(base_a + seg.zb * base_b, ga.w, gb.w);
    }
    out.ok = true;
    out.rgba = shade_segment(fr, seg);
    if lighting.enabled != 0u {
        let o = NORMAL_ROWS * slot;
        let rows = array<vec4<f32>, 6>(nshades[o], nshades[o + 1u], nshades[o + 2u], nshades[o + 3u], nshades[o + 4u], nshades[o + 5u]);
        out.rgba = light_segment(fr, seg, out.rgba, lit_ends(fr, rows, seg, x, y));
    }
    return out;
}
