// ---- biv-exact per fragment, in f32 ----------------------------------------
//
// biv-exact: Song et al., "Bivariate Transfer Functions on Unstructured
// Grids", 2009.
//
// Appended after fragment.wgsl (see `shader_source_fragment` in lib.rs): it
// reads the merged 1D knots (`knot_row`, `knot_eval`) and the widget rows
// (`widget_row`, `widget_contains`) that biv-approx uploads, and is called
// from `shade_segment` for METHOD_BIV_EXACT.
//
// As `tet_preint::BivExact::integrate`: along the segment s and g are linear
// in x ∈ [0, 1]; the segment is cut at the 1D TF's knots, every widget's
// support edges (in s and in g), every band's half-period crossings and each
// Gaussian's peak, so on a piece the 1D part is linear, a widget is either
// in or out of its support, and a band is monotone. Per piece the optical
// depth is in closed form (1D: trapezoid; box: ρ·Δx; triangle: trapezoid;
// sine: sinc form; Gaussian: erfcx form), so α is exact up to f32. Colour:
// density emission with one part carrying the piece → C = c·α (a widget) or
// 0 (nothing); every other piece (the 1D part alone, overlapping parts,
// independent emission) → C = ∫ E·T l dx by panelled 8-point Gauss–Legendre
// with T from the closed-form depths. The CPU takes the exact 1D integrator
// for a piece the 1D part carries and Song et al.'s (2009) Gaussian / band tables for
// independent-emission pieces one widget carries; the GPU integrates those by
// quadrature too (agreement ~1e-6, tests/gpu_methods.rs).
//
// Differences from the CPU, all bounded:
// * The pieces are found one at a time (the next breakpoint after x), so no
//   array and no sort.
// * A band with more than BIV_BAND_SPLIT_MAX half-period crossings on the
//   segment is not split at them (the CPU's limit is 65 536): its depth is
//   still exact (sine: the sinc form holds on any interval; triangle: its
//   antiderivative), its colour by the quadrature is then approximate
//   (exact for a band alone under density emission: c·α).
// * Gaussian pieces are also cut at peak ± BIV_GAUSS_ZONE/k (u = ±6, where
//   the shape is e^{-36} of its peak): inside, panels are at most 0.5/k
//   wide (as the CPU's), outside only the depth limits them. The exact
//   result does not change.
// * Work is bounded by a budget of BIV_MAX_WORK loop iterations per shader
//   invocation (`biv_work`: one segment for the probe and the graphics
//   raster, every segment a compute-raster pixel composites), counted
//   conservatively as the work is done (a pass over the widgets is
//   n_widgets + 1). Why so few: llvmpipe (lavapipe, the tests' adapter)
//   silently ends every loop of a shader invocation once 65 535 iterations
//   have run in all its loops together (gallivm's
//   LP_MAX_TGSI_LOOP_ITERATIONS), and the 8 lanes of its SIMD vector share
//   that count, so 8 × BIV_MAX_WORK must stay below it with room for the
//   rasterizer's own loop (a compute-raster tile's loop over its tets
//   would not leave that room at scale: on llvmpipe the renderer sends
//   biv-exact to the graphics rasterizer, GpuContext::limits_loop_iterations).
//   On a GPU the budget only caps a pixel's cost.
//   When the budget runs out, the piece at hand runs to x = 1 (depths stay
//   exact for the widgets, the 1D part is taken as linear between its
//   ends) and any colour not yet integrated is one span with frozen
//   coefficients (`biv_frozen`); later segments are one such piece each. A panel is
//   halved at most BIV_MAX_HALVINGS times (then the same frozen panel:
//   exact in the limit of an opaque start), and nothing is integrated past
//   optical depth BIV_DEPTH_CUTOFF (T < 2e-9: α rounds to 1 in f32, and what
//   lies behind is below f32's resolution of the colour in front).
//   The 8-point rules are written out (no loop) for the same reason.
// * Non-finite s or g, or l ≤ 0 or NaN, give 0; l is clamped to 1e30.


const BIV_MAX_WORK: u32 = 6000u;
const BIV_BAND_SPLIT_MAX: f32 = 256.0;
const BIV_MAX_HALVINGS: u32 = 40u;
// Largest optical depth of one quadrature panel: 8-point Gauss–Legendre on
// e^{−τ} over 4 e-folds errs by ~1e-13 (the CPU's 0.5 aims at f64).
const BIV_PANEL_DEPTH: f32 = 4.0;
const BIV_DEPTH_CUTOFF: f32 = 20.0;
const BIV_GAUSS_ZONE: f32 = 6.0;
// A Gaussian whose A = |d(s, g)/dx|²/σ² exceeds this is narrower along the
// segment than 1e-18 of it: its depth is taken as 0 (f32 would overflow).
const BIV_GAUSS_A_MAX: f32 = 1.0e36;
const BIV_PI: f32 = 3.14159265358979324;
const BIV_SQRT_PI_2: f32 = 0.886226925452758014; // √π / 2

// Loop iterations spent by this invocation (see BIV_MAX_WORK).
var<private> biv_work: u32 = 0u;

// The segment: s and g at x = 0 and their changes over it, and its world
// length (clamped to 1e30).
struct BivSeg {
    sf: f32,
    sb: f32,
    gf: f32,
    gb: f32,
    ds: f32,
    dg: f32,
    len_world: f32,
}

// One piece [x0, x1]: the 1D part's (κ, ρ) at both ends (linear between:
// the piece does not cross a knot) and (s, g) at its middle, where every
// widget's support membership is decided for the whole piece (the CPU's
// rule: the support is constant on a piece).
struct BivPiece {
    x0: f32,
    x1: f32,
    e0: vec4<f32>,
    e1: vec4<f32>,
    sm: f32,
    gm: f32,
}

fn biv_s(b: BivSeg, x: f32) -> f32 {
    return select(b.sf + x * b.ds, b.sb, x >= 1.0);
}
fn biv_g(b: BivSeg, x: f32) -> f32 {
    return select(b.gf + x * b.dg, b.gb, x >= 1.0);
}

// sin(πy) for finite y: y = n + r with |r| ≤ ½ (exact in f32), the odd
// Taylor polynomial of sin(πr) to degree 13 (error < 1e-9 before rounding),
// sign from n's parity. Not the built-in sin: Vulkan only promises 2^-11
// absolute there, and the phases of the bands need better.
fn biv_sin_pi(y: f32) -> f32 {
    let n = round(y);
    let z = BIV_PI * (y - n);
    let z2 = z * z;
    let p = z * (1.0 + z2 * (-1.0 / 6.0 + z2 * (1.0 / 120.0 + z2 * (-1.0 / 5040.0 + z2 * (1.0 / 362880.0
        + z2 * (-1.0 / 39916800.0 + z2 * (1.0 / 6227020800.0)))))));
    let odd = n - 2.0 * floor(0.5 * n) != 0.0;
    return select(p, -p, odd);
}

// cos(πy) for finite y, as biv_sin_pi (even polynomial to degree 14).
fn biv_cos_pi(y: f32) -> f32 {
    let n = round(y);
    let z = BIV_PI * (y - n);
    let z2 = z * z;
    let p = 1.0 + z2 * (-0.5 + z2 * (1.0 / 24.0 + z2 * (-1.0 / 720.0 + z2 * (1.0 / 40320.0
        + z2 * (-1.0 / 3628800.0 + z2 * (1.0 / 479001600.0 + z2 * (-1.0 / 87178291200.0)))))));
    let odd = n - 2.0 * floor(0.5 * n) != 0.0;
    return select(p, -p, odd);
}

// sin(πy)/(πy), 1 at y = 0 (the series where |y| < ½: no division).
fn biv_sinc_pi(y: f32) -> f32 {
    if abs(y) < 0.5 {
        let z2 = BIV_PI * BIV_PI * y * y;
        return 1.0 + z2 * (-1.0 / 6.0 + z2 * (1.0 / 120.0 + z2 * (-1.0 / 5040.0 + z2 * (1.0 / 362880.0
            + z2 * (-1.0 / 39916800.0 + z2 * (1.0 / 6227020800.0))))));
    }
    return biv_sin_pi(y) / (BIV_PI * y);
}

// erfcx(z) = e^{z²} erfc(z) for z ≥ 0: Numerical Recipes' erfc Chebyshev
// fit (relative error < 1.2e-7 for every z ≥ 0) without its e^{−z²}
// factor, so no overflow and no underflow for large z (erfcx → 1/(z√π)).
fn biv_erfcx(z: f32) -> f32 {
    let t = 1.0 / (1.0 + 0.5 * z);
    let p = -1.26551223 + t * (1.00002368 + t * (0.37409196 + t * (0.09678418 + t * (-0.18628806
        + t * (0.27886807 + t * (-1.13520398 + t * (1.48851587 + t * (-0.82215223 + t * 0.17087277))))))));
    return t * exp(p);
}

// Triangle bands m(v) = 1 − 2|v − round v| and an antiderivative in v:
// with w = v + ½ = p + r (p integer, r ∈ [0, 1)), F = p/2 + (r² for
// r < ½, −r² + 2r − ½ beyond): each period adds ½.
fn biv_tri(v: f32) -> f32 {
    return 1.0 - 2.0 * abs(v - round(v));
}
fn biv_tri_antiderivative(v: f32) -> f32 {
    let w = v + 0.5;
    let p = floor(w);
    let r = w - p;
    let g = select(r * (2.0 - r) - 0.5, r * r, r < 0.5);
    return 0.5 * p + g;
}

// e^{−|c + d t|²/2}: the Gaussian's shape at a Gauss–Legendre node t.
fn biv_gauss_at(c: vec2<f32>, d: vec2<f32>, t: f32) -> f32 {
    let v = c + d * t;
    return exp(-0.5 * dot(v, v));
}

// ∫_{xa}^{xb} e^{−q(x)} dx of the Gaussian with parameters p = (s_c, g_c,
// σ_s, σ_g) along the segment, support ignored: tet_preint's
// `gaussian_depth` in f32. q = ½((a_s + b_s x)² + (a_g + b_g x)²) =
// q_min + u², u = k(x + B/A), k = √(A/2). Where k·Δx < 1 (the erf
// difference would cancel in f32; e^{−u²} over less than one unit of u is
// smooth) 8-point Gauss–Legendre on e^{−q}, else the erfcx form without
// cancellation; q at the ends from the squares directly and q_min by the
// Lagrange identity ½(a_s b_g − a_g b_s)²/A (no C₀ − B²/A cancellation).
fn biv_gauss_integral(b: BivSeg, p: vec4<f32>, xa: f32, xb: f32) -> f32 {
    let dx = xb - xa;
    if !(dx > 0.0) {
        return 0.0;
    }
    let a_s = (b.sf - p.x) / p.z;
    let b_s = b.ds / p.z;
    let a_g = (b.gf - p.y) / p.w;
    let b_g = b.dg / p.w;
    let a2 = b_s * b_s + b_g * b_g;
    if !(a2 <= BIV_GAUSS_A_MAX) {
        return 0.0;
    }
    let k = sqrt(0.5 * a2);
    if k * dx < 1.0 {
        // In t = (x − mid)/(Δx/2): a_s + b_s x = c_s + d_s t (same for g).
        let mid = xa + 0.5 * dx;
        let c = vec2<f32>(a_s + b_s * mid, a_g + b_g * mid);
        let d = vec2<f32>(b_s, b_g) * (0.5 * dx);
        let sum = GL8_W[0] * (biv_gauss_at(c, d, GL8_X[0]) + biv_gauss_at(c, d, -GL8_X[0]))
            + GL8_W[1] * (biv_gauss_at(c, d, GL8_X[1]) + biv_gauss_at(c, d, -GL8_X[1]))
            + GL8_W[2] * (biv_gauss_at(c, d, GL8_X[2]) + biv_gauss_at(c, d, -GL8_X[2]))
            + GL8_W[3] * (biv_gauss_at(c, d, GL8_X[3]) + biv_gauss_at(c, d, -GL8_X[3]));
        return sum * 0.5 * dx;
    }
    let shift = (a_s * b_s + a_g * b_g) / a2;
    let u0 = k * (xa + shift);
    let u1 = k * (xb + shift);
    let s0 = a_s + b_s * xa;
    let g0 = a_g + b_g * xa;
    let s1 = a_s + b_s * xb;
    let g1 = a_g + b_g * xb;
    let e0 = exp(-0.5 * (s0 * s0 + g0 * g0));
    let e1 = exp(-0.5 * (s1 * s1 + g1 * g1));
    var bracket: f32;
    if u0 >= 0.0 {
        bracket = biv_erfcx(u0) * e0 - biv_erfcx(u1) * e1;
    } else if u1 <= 0.0 {
        bracket = biv_erfcx(-u1) * e1 - biv_erfcx(-u0) * e0;
    } else {
        let cross = a_s * b_g - a_g * b_s;
        let qmin = 0.5 * cross * cross / a2;
        bracket = 2.0 * exp(-qmin) - biv_erfcx(u1) * e1 - biv_erfcx(-u0) * e0;
    }
    return max(BIV_SQRT_PI_2 / k * bracket, 0.0);
}

// ∫_{xa}^{xb} m_w dx of widget w's shape along the segment (its support is
// decided per piece by the caller): box Δx; sine the sinc form (exact on any
// interval); triangle the trapezoid where no half-period crossing lies
// inside (then m is linear), else its antiderivative; Gaussian above.
fn biv_shape_integral(b: BivSeg, w: u32, xa: f32, xb: f32) -> f32 {
    let dx = xb - xa;
    if !(dx > 0.0) {
        return 0.0;
    }
    let kind = u32(widget_row(w, 3u).x);
    let p = widget_row(w, 0u);
    if kind == WIDGET_BOX {
        return dx;
    }
    if kind == WIDGET_GAUSSIAN {
        return biv_gauss_integral(b, p, xa, xb);
    }
    // Bands: v = f·s − φ, linear in x.
    let v0 = biv_band_v0(w, b.sf);
    let dv = p.x * b.ds;
    let va = v0 + dv * xa;
    let vb = v0 + dv * xb;
    if kind == WIDGET_SINE {
        // ∫ (1 + cos 2πv)/2 dx = Δx/2·(1 + cos(π(v_a + v_b))·sinc(π(v_b − v_a))).
        return 0.5 * dx * (1.0 + biv_cos_pi(va + vb) * biv_sinc_pi(dv * dx));
    }
    let lo = min(va, vb);
    let hi = max(va, vb);
    if floor(2.0 * lo) + 1.0 >= 2.0 * hi {
        return 0.5 * dx * (biv_tri(va) + biv_tri(vb));
    }
    return max((biv_tri_antiderivative(vb) - biv_tri_antiderivative(va)) / dv, 0.0);
}

// m_w at x along the segment (support ignored): Widget::shape_unclipped,
// the bands' phase v = v₀ + Δv·x from biv_band_v0.
fn biv_shape_at(b: BivSeg, w: u32, x: f32) -> f32 {
    let kind = u32(widget_row(w, 3u).x);
    let p = widget_row(w, 0u);
    if kind == WIDGET_GAUSSIAN {
        let ts = (biv_s(b, x) - p.x) / p.z;
        let tg = (biv_g(b, x) - p.y) / p.w;
        return exp(-0.5 * (ts * ts + tg * tg));
    }
    if kind == WIDGET_TRIANGLE || kind == WIDGET_SINE {
        let v = biv_band_v0(w, b.sf) + p.x * b.ds * x;
        if kind == WIDGET_TRIANGLE {
            return biv_tri(v);
        }
        return 0.5 * (1.0 + biv_cos_pi(2.0 * (v - round(v))));
    }
    return 1.0;
}

// A band's phase v = f·s − φ at scalar s, less an integer (every band
// formula here is periodic in v with period 1): the f32 product f·s would
// lose the phase once f·|s| ≳ 1e3 (ulp(3e5) = 0.03 at f = 1e6), so f is
// split on the CPU into f_hi (12 significant bits) + f_lo and s here into
// s_hi (its top 12 bits, by masking) + s_lo: f_hi·s_hi is exact and reduced
// mod 1 exactly, the rest is ~2^-12 of f·s. Phase error ~1e-7·(1 +
// f·|s|·2^-12) instead of 6e-8·f·|s|. Row 3 of a band: (kind, f_hi, f_lo,
// φ mod 1).
fn biv_band_v0(w: u32, s: f32) -> f32 {
    let r = widget_row(w, 3u);
    let s_hi = bitcast<f32>(bitcast<u32>(s) & 0xfffff000u);
    let s_lo = s - s_hi;
    let t = r.y * s_hi;
    if !(abs(t) < 1.0e30) {
        let p = widget_row(w, 0u);
        return p.x * s - p.y;
    }
    let v = (t - floor(t)) + (r.y * s_lo + r.z * s) - r.w;
    return v - floor(v);
}

// The 1D part's (κ, ρ) at x inside the piece: linear between its ends.
fn biv_one_d(pc: BivPiece, x: f32) -> vec4<f32> {
    let span = pc.x1 - pc.x0;
    if !(span > 0.0) {
        return pc.e0;
    }
    let t = clamp((x - pc.x0) / span, 0.0, 1.0);
    return pc.e0 + t * (pc.e1 - pc.e0);
}

// ∫_{xa}^{xb} ρ dx inside the piece, per unit world length (× l is the
// optical depth): the 1D part's trapezoid plus every widget whose support
// holds the piece (tet_preint's `piece_depth`).
fn biv_depth(b: BivSeg, pc: BivPiece, xa: f32, xb: f32) -> f32 {
    let dx = xb - xa;
    if !(dx > 0.0) {
        return 0.0;
    }
    var d = 0.5 * (biv_one_d(pc, xa).w + biv_one_d(pc, xb).w) * dx;
    for (var w = 0u; w < shp.n_widgets; w++) {
        let rho = widget_row(w, 1u).w;
        if rho > 0.0 && widget_contains(w, pc.sm, pc.gm) {
            d += rho * biv_shape_integral(b, w, xa, xb);
        }
    }
    return d;
}

// One quadrature node x of a panel starting at a: E(x) (xyz) and
// ∫_a^x ρ dx per unit length (w), in one pass over the widgets.
fn biv_node(b: BivSeg, pc: BivPiece, a: f32, x: f32) -> vec4<f32> {
    let one = biv_one_d(pc, x);
    let independent = shp.independent != 0u;
    var em = select(one.xyz * one.w, one.xyz, independent);
    var d = 0.5 * (biv_one_d(pc, a).w + one.w) * (x - a);
    for (var w = 0u; w < shp.n_widgets; w++) {
        if !widget_contains(w, pc.sm, pc.gm) {
            continue;
        }
        let c = widget_row(w, 1u);
        if independent {
            em += c.xyz;
        }
        if c.w > 0.0 {
            d += c.w * biv_shape_integral(b, w, a, x);
            if !independent {
                em += c.xyz * (c.w * biv_shape_at(b, w, x));
            }
        }
    }
    return vec4<f32>(em, d);
}

// A Gauss–Legendre term: weight × E(x) × e^{−l·∫_a^x ρ}.
fn biv_node_term(b: BivSeg, pc: BivPiece, a: f32, x: f32, weight: f32) -> vec3<f32> {
    let n = biv_node(b, pc, a, x);
    return (weight * exp(-b.len_world * n.w)) * n.xyz;
}

// ∫_{xa}^{xb} E·T l dx (T from 1 at xa) with the coefficients frozen,
// used where a panel cannot be resolved (the halving or work budget is
// spent), in one pass over the widgets. Density emission: C = κ̄·(1 − e^{−D})
// with κ̄ the depth-weighted mean colour of the parts (exact when one part
// carries the span or the colours agree; never above the largest colour).
// Independent emission: E at the middle, ρ uniform: C = E·Δx·(1 − e^{−D})/r
// with r = ∫ρ dx, D = l·r (exact for constant E and ρ; → E/ρ behind an
// opaque start).
fn biv_frozen(b: BivSeg, pc: BivPiece, xa: f32, xb: f32) -> vec3<f32> {
    let dx = xb - xa;
    if !(dx > 0.0) {
        return vec3<f32>(0.0);
    }
    let one = biv_one_d(pc, xa + 0.5 * dx);
    let r_one = 0.5 * (biv_one_d(pc, xa).w + biv_one_d(pc, xb).w) * dx;
    var r = r_one;
    var weighted = one.xyz * r_one;
    var em = one.xyz;
    for (var w = 0u; w < shp.n_widgets; w++) {
        if !widget_contains(w, pc.sm, pc.gm) {
            continue;
        }
        let c = widget_row(w, 1u);
        em += c.xyz;
        if c.w > 0.0 {
            let rw = c.w * biv_shape_integral(b, w, xa, xb);
            r += rw;
            weighted += c.xyz * rw;
        }
    }
    let d = b.len_world * r;
    if shp.independent == 0u {
        if !(r > 0.0) {
            return vec3<f32>(0.0);
        }
        return weighted * (one_minus_exp(d) / r);
    }
    if d > 1.0e-6 {
        return em * (dx * one_minus_exp(d) / r);
    }
    return em * (dx * b.len_world * (1.0 - 0.5 * d));
}

// C = ∫ E·T l dx over the piece by 8-point Gauss–Legendre panels, T from
// the closed-form depths (tet_preint's `quadrature_color`): each panel is
// halved until its depth is ≤ BIV_PANEL_DEPTH, is at most h_max wide, and
// the next starts at twice its width; stops once the depth from the piece's
// start passes `depth_left` (the segment's remaining depth), and freezes the
// rest of the piece once the work budget (`biv_work`, see the top) runs
// short.
fn biv_quadrature(b: BivSeg, pc: BivPiece, h_max: f32, depth_left: f32) -> vec3<f32> {
    let cost_w = shp.n_widgets + 1u;
    var out = vec3<f32>(0.0);
    var before = 0.0;
    var a = pc.x0;
    var h = h_max;
    loop {
        if !(a < pc.x1) || before > depth_left {
            break;
        }
        // A panel costs at most its loop pass, the first depth, the halvings
        // and the 8 nodes (or a frozen panel's pass).
        if biv_work + (BIV_MAX_HALVINGS + 10u) * cost_w + 1u > BIV_MAX_WORK {
            out += exp(-before) * biv_frozen(b, pc, a, pc.x1);
            biv_work += cost_w;
            break;
        }
        biv_work += cost_w + 1u;
        h = min(h, pc.x1 - a);
        var r = biv_depth(b, pc, a, a + h);
        var halvings = 0u;
        while b.len_world * r > BIV_PANEL_DEPTH && halvings < BIV_MAX_HALVINGS {
            h *= 0.5;
            r = biv_depth(b, pc, a, a + h);
            halvings++;
        }
        biv_work += halvings * (cost_w + 1u);
        let pd = b.len_world * r;
        let t_before = exp(-before);
        if pd > BIV_PANEL_DEPTH {
            out += t_before * biv_frozen(b, pc, a, a + h);
            biv_work += cost_w;
        } else {
            let mid = a + 0.5 * h;
            let hh = 0.5 * h;
            let sum = biv_node_term(b, pc, a, mid - GL8_X[0] * hh, GL8_W[0])
                + biv_node_term(b, pc, a, mid + GL8_X[0] * hh, GL8_W[0])
                + biv_node_term(b, pc, a, mid - GL8_X[1] * hh, GL8_W[1])
                + biv_node_term(b, pc, a, mid + GL8_X[1] * hh, GL8_W[1])
                + biv_node_term(b, pc, a, mid - GL8_X[2] * hh, GL8_W[2])
                + biv_node_term(b, pc, a, mid + GL8_X[2] * hh, GL8_W[2])
                + biv_node_term(b, pc, a, mid - GL8_X[3] * hh, GL8_W[3])
                + biv_node_term(b, pc, a, mid + GL8_X[3] * hh, GL8_W[3]);
            out += (hh * b.len_world * t_before) * sum;
            biv_work += 8u * cost_w;
        }
        before += pd;
        let end = select(a + h, pc.x1, h >= pc.x1 - a);
        if !(end > a) {
            break; // h below x's f32 spacing: nothing left to resolve
        }
        a = end;
        h = min(2.0 * h, h_max);
    }
    return out;
}

// `best` lowered to c where x < c < best.
fn biv_take(best: f32, x: f32, c: f32) -> f32 {
    return select(best, c, c > x && c < best);
}

// The next breakpoint after x (≤ 1), `xk` being the next 1D knot's (2 if
// none): every widget's support edges in s and in g, each band's next
// half-period crossing (bands with at most BIV_BAND_SPLIT_MAX crossings on
// the segment), each Gaussian's peak and peak ± BIV_GAUSS_ZONE/k. Computed
// from x each time (no per-widget state): the crossing of level j/2 is at
// (j/2 − v₀)/Δv, the first level past v(x) in the direction of travel.
fn biv_next_break(b: BivSeg, x: f32, xk: f32) -> f32 {
    var best = min(xk, 1.0);
    for (var w = 0u; w < shp.n_widgets; w++) {
        let sup = widget_row(w, 2u);
        if b.ds != 0.0 {
            best = biv_take(best, x, (sup.x - b.sf) / b.ds);
            best = biv_take(best, x, (sup.y - b.sf) / b.ds);
        }
        if b.dg != 0.0 {
            best = biv_take(best, x, (sup.z - b.gf) / b.dg);
            best = biv_take(best, x, (sup.w - b.gf) / b.dg);
        }
        let kind = u32(widget_row(w, 3u).x);
        let p = widget_row(w, 0u);
        if (kind == WIDGET_TRIANGLE || kind == WIDGET_SINE) && b.ds != 0.0 {
            let v0 = biv_band_v0(w, b.sf);
            let dv = p.x * b.ds;
            let v1 = v0 + dv;
            let crossings = floor(2.0 * max(v0, v1)) - ceil(2.0 * min(v0, v1)) + 1.0;
            if crossings > 0.0 && crossings <= BIV_BAND_SPLIT_MAX {
                let vx = v0 + dv * x;
                var j: f32;
                var step: f32;
                if dv > 0.0 {
                    j = floor(2.0 * vx) + 1.0;
                    step = 1.0;
                } else {
                    j = ceil(2.0 * vx) - 1.0;
                    step = -1.0;
                }
                var c = (0.5 * j - v0) / dv;
                if c <= x {
                    c = (0.5 * (j + step) - v0) / dv;
                }
                best = biv_take(best, x, c);
            }
        }
        if kind == WIDGET_GAUSSIAN {
            let a_s = (b.sf - p.x) / p.z;
            let b_s = b.ds / p.z;
            let a_g = (b.gf - p.y) / p.w;
            let b_g = b.dg / p.w;
            let a2 = b_s * b_s + b_g * b_g;
            if a2 > 0.0 && a2 <= BIV_GAUSS_A_MAX {
                let peak = -(a_s * b_s + a_g * b_g) / a2;
                let reach = BIV_GAUSS_ZONE / sqrt(0.5 * a2);
                best = biv_take(best, x, peak - reach);
                best = biv_take(best, x, peak);
                best = biv_take(best, x, peak + reach);
            }
        }
    }
    return best;
}

fn biv_finite(v: f32) -> bool {
    return v == v && abs(v) <= 3.40282347e38;
}

// BivExact::integrate in f32 (see the top of this file): premultiplied
// (C, α) of one segment.
fn biv_exact(seg: Seg) -> vec4<f32> {
    let ok = biv_finite(seg.sf) && biv_finite(seg.sb) && biv_finite(seg.gf) && biv_finite(seg.gb);
    if !ok || !(seg.len > 0.0) {
        return vec4<f32>(0.0);
    }
    var b: BivSeg;
    b.sf = seg.sf;
    b.sb = seg.sb;
    b.gf = seg.gf;
    b.gb = seg.gb;
    b.ds = seg.sb - seg.sf;
    b.dg = seg.gb - seg.gf;
    b.len_world = min(seg.len, 1.0e30);
    let independent = shp.independent != 0u;
    // The 1D knots strictly between sf and sb, in the direction of travel:
    // a cursor `kc` (ends at `kend`), advanced past each piece's start.
    var kc = 0i;
    var kend = 0i;
    var kstep = 0i;
    if b.ds > 0.0 {
        kc = i32(knots_below(b.sf, true));
        kend = i32(knots_below(b.sb, false));
        kstep = 1i;
    } else if b.ds < 0.0 {
        kc = i32(knots_below(b.sf, false)) - 1i;
        kend = i32(knots_below(b.sb, true)) - 1i;
        kstep = -1i;
    }
    var x = 0.0;
    var e0 = knot_eval(b.sf);
    var color = vec3<f32>(0.0);
    var depth = 0.0;
    // The work budget (see the top): a piece costs three passes over the
    // widgets (next breakpoint, depth, what carries it), knot_eval's binary
    // search and its own loop; the knot cursor 1 a step.
    let cost_w = shp.n_widgets + 1u;
    let cost_piece = 3u * cost_w + firstLeadingBit(shp.n_knots | 1u) + 3u;
    // A piece is at least 3 passes: the budget ends the loop long before this
    // bound (after it, a piece is the last).
    for (var piece = 0u; piece < BIV_MAX_WORK; piece++) {
        if !(x < 1.0) {
            break;
        }
        biv_work += cost_piece;
        // No budget for another piece after this one (and a frozen colour for
        // each): this one runs to the end.
        let last_piece = biv_work + 2u * (cost_piece + 2u * cost_w) > BIV_MAX_WORK;
        var xk = 2.0;
        while kstep != 0i && kc != kend {
            biv_work += 1u;
            let c = (knot_row(u32(kc)).x - b.sf) / b.ds;
            if c > x {
                xk = c;
                break;
            }
            kc += kstep;
        }
        var x1 = 1.0;
        if !last_piece {
            x1 = biv_next_break(b, x, xk);
        }
        let e1 = knot_eval(biv_s(b, x1));
        let xm = 0.5 * (x + x1);
        let pc = BivPiece(x, x1, e0, e1, biv_s(b, xm), biv_g(b, xm));
        let d = b.len_world * biv_depth(b, pc, x, x1);
        let alpha = one_minus_exp(d);
        // What carries the piece; the Gaussians' bump zones narrow the panels.
        let one_d = e0.w > 0.0 || e1.w > 0.0;
        var n_opaque = 0u;
        var last = 0u;
        var h_max = x1 - x;
        for (var w = 0u; w < shp.n_widgets; w++) {
            let rho = widget_row(w, 1u).w;
            if !(rho > 0.0) || !widget_contains(w, pc.sm, pc.gm) {
                continue;
            }
            n_opaque++;
            last = w;
            if u32(widget_row(w, 3u).x) == WIDGET_GAUSSIAN {
                let p = widget_row(w, 0u);
                let b_s = b.ds / p.z;
                let b_g = b.dg / p.w;
                let a2 = b_s * b_s + b_g * b_g;
                if a2 > 0.0 && a2 <= BIV_GAUSS_A_MAX {
                    let a_s = (b.sf - p.x) / p.z;
                    let a_g = (b.gf - p.y) / p.w;
                    let k = sqrt(0.5 * a2);
                    let peak = -(a_s * b_s + a_g * b_g) / a2;
                    if abs(k * (xm - peak)) < BIV_GAUSS_ZONE {
                        h_max = min(h_max, 0.5 / k);
                    }
                }
            }
        }
        var pcol = vec3<f32>(0.0);
        if !independent && !one_d && n_opaque == 1u {
            pcol = widget_row(last, 1u).xyz * alpha;
        } else if (independent || one_d || n_opaque > 0u) && last_piece {
            pcol = biv_frozen(b, pc, x, x1);
            biv_work += cost_w;
        } else if independent || one_d || n_opaque > 0u {
            pcol = biv_quadrature(b, pc, h_max, BIV_DEPTH_CUTOFF - depth);
        }
        color += exp(-depth) * pcol;
        depth += d;
        x = x1;
        e0 = e1;
        if depth > BIV_DEPTH_CUTOFF {
            break;
        }
    }
    let out = vec4<f32>(color, one_minus_exp(depth));
    let fine = biv_finite(out.x) && biv_finite(out.y) && biv_finite(out.z) && biv_finite(out.w);
    return select(vec4<f32>(0.0), out, fine);
}
