// Classify pass: one invocation per draw slot (visibility-order position).
// Transforms the slot's tet into the camera frame, classifies its
// projection (Shirley–Tuchman: 3 or 4 triangles around the thick point),
// clips tets crossing the near plane to the convex hull of what is in
// front, and writes the per-slot silhouette (TetGeom, for the vertex
// shader) and the face planes and scalar field (TetShade, for the fragment
// shader) — the GPU form of tet_render's TetSetup::new.

@group(0) @binding(0) var<uniform> fr: Frame;
@group(0) @binding(1) var<storage, read> positions: array<vec4<f32>>;
@group(0) @binding(2) var<storage, read> tets: array<vec4<u32>>;
@group(0) @binding(3) var<storage, read> scalars: array<f32>;
@group(0) @binding(4) var<storage, read> order: array<u32>;
@group(0) @binding(5) var<storage, read_write> geoms: array<TetGeom>;
@group(0) @binding(6) var<storage, read_write> shades: array<TetShade>;
// Bivariate methods: per-vertex gradient magnitudes in, per-slot linear
// field out (two rows a slot, as TetShade's s_a, s_b).
@group(0) @binding(17) var<storage, read> gmags: array<f32>;
@group(0) @binding(18) var<storage, read_write> gshades: array<vec4<f32>>;
// Lighting (lighting.wgsl's `lighting.enabled`): per-vertex gradients in
// (xyz; w = 1 where finite, else 0 and xyz = 0), per slot the gradient's
// components as linear fields out (NORMAL_ROWS rows a slot).
@group(0) @binding(20) var<storage, read> vgrads: array<vec4<f32>>;
@group(0) @binding(21) var<storage, read_write> nshades: array<vec4<f32>>;

// pt-linear's thick point is the only segment this module shades.
fn shade_piece(f: Frame, seg: Seg) -> vec4<f32> {
    return shade_pt_linear(f, seg);
}

// tet_mesh::FACE_OUTWARD: face f is opposite vertex f, outward for a
// positively oriented tet.
const FACE_A = array<u32, 4>(1u, 0u, 0u, 0u);
const FACE_B = array<u32, 4>(2u, 3u, 1u, 2u);
const FACE_C = array<u32, 4>(3u, 2u, 3u, 1u);

fn to_cam(d: vec3<f32>) -> vec3<f32> {
    return vec3<f32>(dot(d, fr.right.xyz), dot(d, fr.up.xyz), dot(d, fr.forward.xyz));
}

fn cam_to_px(x: vec3<f32>) -> vec2<f32> {
    var c = x.xy;
    if fr.parallel == 0u {
        c = x.xy / x.z;
    }
    return vec2<f32>((c.x - fr.bx) / fr.ax, (c.y - fr.by) / fr.ay);
}

fn orient(a: vec2<f32>, b: vec2<f32>, c: vec2<f32>) -> f32 {
    return (b.x - a.x) * (c.y - a.y) - (b.y - a.y) * (c.x - a.x);
}

fn finite(v: f32) -> bool {
    return v == v && abs(v) <= 3.4e38;
}

/// A linear field with values `v` at the tet's vertices as the two rows a
/// fragment evaluates it from (xyz; w left 0): affine in the pixel position
/// for a parallel view, over depth for a perspective one. `x0` is vertex
/// 0 in camera space, `c23`, `c31`, `c12` and `det` the cofactors and
/// determinant of the tet's camera-space edges. The scalar, the gradient
/// magnitude and each gradient component all go through here.
fn linear_field_rows(v: vec4<f32>, x0: vec3<f32>, c23: vec3<f32>, c31: vec3<f32>, c12: vec3<f32>, det: f32) -> array<vec4<f32>, 2> {
    let g = (c23 * (v[1] - v[0]) + c31 * (v[2] - v[0]) + c12 * (v[3] - v[0])) / det;
    let g0 = v[0] - dot(g, x0);
    if fr.parallel != 0u {
        return array<vec4<f32>, 2>(
            vec4<f32>(g0 + g.x * fr.bx + g.y * fr.by, g.x * fr.ax, g.y * fr.ay, 0.0),
            vec4<f32>(g.z, 0.0, 0.0, 0.0),
        );
    }
    return array<vec4<f32>, 2>(
        vec4<f32>(g0, 0.0, 0.0, 0.0),
        vec4<f32>(g.x * fr.bx + g.y * fr.by + g.z, g.x * fr.ax, g.y * fr.ay, 0.0),
    );
}

fn emit_none(slot: u32) {
    var g: TetGeom;
    g.mode = GEOM_NONE;
    g.n_hull = 0u;
    geoms[slot] = g;
}

@compute @workgroup_size(64)
fn classify(@builtin(global_invocation_id) gid: vec3<u32>) {
    let slot = gid.x + gid.y * fr.groups_x * 64u;
    if slot >= fr.n_slots {
        return;
    }
    let tv = tets[order[slot]];
    let ids = array<u32, 4>(tv.x, tv.y, tv.z, tv.w);
    var p: array<vec3<f32>, 4>;
    var x: array<vec3<f32>, 4>;
    var s: array<f32, 4>;
    var clipped = false;
    for (var k = 0u; k < 4u; k++) {
        p[k] = positions[ids[k]].xyz;
        x[k] = to_cam(p[k] - fr.eye_rel.xyz);
        s[k] = scalars[ids[k]];
        if fr.parallel == 0u && x[k].z < fr.near_depth {
            clipped = true;
        }
    }

    var g: TetGeom;
    g.mode = GEOM_NONE;
    if !clipped {
        var px: array<vec2<f32>, 4>;
        for (var k = 0u; k < 4u; k++) {
            px[k] = cam_to_px(x[k]);
        }
        var pos: array<u32, 4>;
        var neg: array<u32, 4>;
        var np = 0u;
        var nn = 0u;
        for (var f = 0u; f < 4u; f++) {
            let a = orient(px[FACE_A[f]], px[FACE_B[f]], px[FACE_C[f]]);
            if a > 0.0 {
                pos[np] = f;
                np++;
            } else if a < 0.0 {
                neg[nn] = f;
                nn++;
            }
        }
        if np == 0u || nn == 0u {
            emit_none(slot);
            return;
        }
        if np == 1u || nn == 1u {
            var thick = neg[0];
            if np == 1u {
                thick = pos[0];
            }
            var n = 0u;
            for (var v = 0u; v < 4u; v++) {
                if v != thick {
                    g.hull[n] = px[v];
                    n++;
                }
            }
            g.n_hull = 3u;
            g.thick = px[thick];
        } else {
            // The diagonals: the edge shared by the two positive faces
            // (vertices neg[0], neg[1]) and the one shared by the negative faces.
            let d00 = neg[0];
            let d01 = neg[1];
            let d10 = pos[0];
            let d11 = pos[1];
            let o1 = orient(px[d10], px[d11], px[d00]);
            let o2 = orient(px[d10], px[d11], px[d01]);
            let t = clamp(o1 / (o1 - o2), 0.0, 1.0);
            g.hull[0] = px[d00];
            g.hull[1] = px[d10];
            g.hull[2] = px[d01];
            g.hull[3] = px[d11];
            g.n_hull = 4u;
            g.thick = px[d00] + t * (px[d01] - px[d00]);
        }
        g.mode = GEOM_THICK;
    } else {
        // What lies in front of the near plane: the vertices there and the
        // points where edges cross it (at most 6), then their convex hull.
        var pts: array<vec2<f32>, 6>;
        var n = 0u;
        for (var k = 0u; k < 4u; k++) {
            if x[k].z >= fr.near_depth {
                pts[n] = cam_to_px(x[k]);
                n++;
            }
        }
        if n == 0u {
            emit_none(slot);
            return;
        }
        for (var i = 0u; i < 4u; i++) {
            for (var j = i + 1u; j < 4u; j++) {
                if (x[i].z >= fr.near_depth) != (x[j].z >= fr.near_depth) {
                    // Canonical direction (smaller vertex id first) so shared
                    // edges give identical points in both tets.
                    var a = x[i];
                    var b = x[j];
                    if ids[j] < ids[i] {
                        a = x[j];
                        b = x[i];
                    }
                    let t = (fr.near_depth - a.z) / (b.z - a.z);
                    pts[n] = cam_to_px(vec3<f32>(a.x + t * (b.x - a.x), a.y + t * (b.y - a.y), fr.near_depth));
                    n++;
                }
            }
        }
        // Andrew's monotone chain over at most 6 points.
        var idx: array<u32, 6>;
        for (var i = 0u; i < n; i++) {
            idx[i] = i;
        }
        for (var i = 1u; i < n; i++) {
            let cur = idx[i];
            var j = i;
            while j > 0u {
                let q = pts[idx[j - 1u]];
                let c = pts[cur];
                if q.x > c.x || (q.x == c.x && q.y > c.y) {
                    idx[j] = idx[j - 1u];
                    j--;
                } else {
                    break;
                }
            }
            idx[j] = cur;
        }
        var h: array<u32, 13>;
        var k = 0u;
        for (var i = 0u; i < n; i++) {
            while k >= 2u && orient(pts[h[k - 2u]], pts[h[k - 1u]], pts[idx[i]]) <= 0.0 {
                k--;
            }
            h[k] = idx[i];
            k++;
        }
        let lower = k + 1u;
        for (var ii = 0u; ii + 1u < n; ii++) {
            let i = n - 2u - ii;
            while k >= lower && orient(pts[h[k - 2u]], pts[h[k - 1u]], pts[idx[i]]) <= 0.0 {
                k--;
            }
            h[k] = idx[i];
            k++;
        }
        let nh = min(k - 1u, 6u);
        if k < 1u || nh < 3u {
            emit_none(slot);
            return;
        }
        for (var i = 0u; i < nh; i++) {
            g.hull[i] = pts[h[i]];
        }
        g.n_hull = nh;
        g.mode = GEOM_CLIPPED;
    }

    // The scalar as a linear field of camera-space position. Edges come
    // from differences of mesh-relative positions (rotated), not of
    // camera-space points, so no depth-sized cancellation.
    let e1 = to_cam(p[1] - p[0]);
    let e2 = to_cam(p[2] - p[0]);
    let e3 = to_cam(p[3] - p[0]);
    let c23 = cross(e2, e3);
    let c31 = cross(e3, e1);
    let c12 = cross(e1, e2);
    let det = dot(e1, c23);
    if det == 0.0 || !finite(det) {
        emit_none(slot);
        return;
    }
    var sh: TetShade;
    let srows = linear_field_rows(vec4<f32>(s[0], s[1], s[2], s[3]), x[0], c23, c31, c12, det);
    sh.s_a = srows[0];
    sh.s_b = srows[1];
    sh.s_a.w = min(min(s[0], s[1]), min(s[2], s[3]));
    sh.s_b.w = max(max(s[0], s[1]), max(s[2], s[3]));
    if fr.method == METHOD_BIV_APPROX || fr.method == METHOD_BIV_EXACT {
        // The gradient magnitude as the same kind of linear field.
        var gv: array<f32, 4>;
        for (var k = 0u; k < 4u; k++) {
            gv[k] = gmags[ids[k]];
        }
        let grows = linear_field_rows(vec4<f32>(gv[0], gv[1], gv[2], gv[3]), x[0], c23, c31, c12, det);
        var ga = grows[0];
        var gb = grows[1];
        ga.w = min(min(gv[0], gv[1]), min(gv[2], gv[3]));
        gb.w = max(max(gv[0], gv[1]), max(gv[2], gv[3]));
        gshades[2u * slot] = ga;
        gshades[2u * slot + 1u] = gb;
    }
    // Lighting: each gradient component as the same kind of linear field
    // (tet_render's TetSetup normal fields); row 0's w says whether every
    // vertex gradient is finite (else the tet has no direction).
    var nrows: array<vec4<f32>, 6>;
    if lighting.enabled != 0u {
        var vg: array<vec4<f32>, 4>;
        var finite_all = 1.0;
        for (var k = 0u; k < 4u; k++) {
            vg[k] = vgrads[ids[k]];
            if vg[k].w < 0.5 {
                finite_all = 0.0;
            }
        }
        for (var c = 0u; c < 3u; c++) {
            let rows = linear_field_rows(vec4<f32>(vg[0][c], vg[1][c], vg[2][c], vg[3][c]), x[0], c23, c31, c12, det);
            nrows[2u * c] = rows[0];
            nrows[2u * c + 1u] = rows[1];
        }
        nrows[0].w = finite_all;
        for (var r = 0u; r < NORMAL_ROWS; r++) {
            nshades[NORMAL_ROWS * slot + r] = nrows[r];
        }
    }
    var len_sq = 0.0;
    for (var i = 0u; i < 4u; i++) {
        for (var j = i + 1u; j < 4u; j++) {
            let d = p[j] - p[i];
            len_sq = max(len_sq, dot(d, d));
        }
    }
    sh.extra = vec4<f32>(sqrt(len_sq), 0.0, 0.0, 0.0);
    if g.mode == GEOM_CLIPPED {
        sh.extra.y = 1.0 / fr.near_depth;
    }

    // Face planes as affine functions of the pixel position.
    var n_back = 0u;
    for (var f = 0u; f < 4u; f++) {
        let ia = FACE_A[f];
        let ib = FACE_B[f];
        let ic = FACE_C[f];
        // The camera basis is left-handed, so the outward normal's camera
        // components are (c − a) × (b − a).
        let nrm = cross(to_cam(p[ic] - p[ia]), to_cam(p[ib] - p[ia]));
        let kk = dot(nrm, x[ia]);
        var q = vec4<f32>(0.0);
        if fr.parallel != 0u {
            let nz = nrm.z;
            if nz != 0.0 {
                q = vec4<f32>((kk - nrm.x * fr.bx - nrm.y * fr.by) / nz, -nrm.x * fr.ax / nz, -nrm.y * fr.ay / nz, 0.0);
                // Front face: outward normal against the view direction.
                q.w = select(-1.0, 1.0, nz < 0.0);
            }
        } else if kk != 0.0 {
            q = vec4<f32>((nrm.x * fr.bx + nrm.y * fr.by + nrm.z) / kk, nrm.x * fr.ax / kk, nrm.y * fr.ay / kk, 0.0);
            // The eye (origin) is outside a front face: k < 0.
            q.w = select(-1.0, 1.0, kk < 0.0);
        }
        if !(finite(q.x) && finite(q.y) && finite(q.z)) {
            q = vec4<f32>(0.0);
        }
        if q.w < -0.5 {
            n_back++;
        }
        sh.planes[f] = q;
    }
    if n_back == 0u {
        emit_none(slot);
        return;
    }

    // pt-linear shades the thick point once; the rasterizer interpolates
    // it towards the silhouette. hull[4..6] carry the RGBA.
    if fr.method == METHOD_PT_LINEAR && g.mode == GEOM_THICK {
        let seg = segment_at(fr, sh, g.thick.x, g.thick.y);
        if !seg.ok {
            emit_none(slot);
            return;
        }
        var rgba = shade_pt_linear(fr, seg);
        if lighting.enabled != 0u {
            // Lit at the thick point (tet_render's raster `shade`).
            rgba = light_segment(fr, seg, rgba, lit_ends(fr, nrows, seg, g.thick.x, g.thick.y));
        }
        g.hull[4] = rgba.xy;
        g.hull[5] = rgba.zw;
    }
    geoms[slot] = g;
    shades[slot] = sh;
}
