//! From a view to a tet's pixels: bounding boxes, near-plane clipped
//! screen points, silhouette hulls and coverage (`Cover`, `cover_mask`,
//! row spans), and the per-tet setup itself (`TetSetup::new`,
//! `prepare_span`).

use super::*;

/// Per-lane results of [`TetSetup::eval_lanes`]: a lane with `len == 0`
/// has no fragment.
#[derive(Debug, Clone, Copy, Default)]
pub(crate) struct Lanes {
    pub s_front: [f32; LANES],
    pub s_back: [f32; LANES],
    pub g_front: [f32; LANES],
    pub g_back: [f32; LANES],
    pub len_world: [f32; LANES],
    /// ζ at the segment's midpoint and half the segment's ζ extent (lighting).
    pub zeta_mid: [f32; LANES],
    pub zeta_half: [f32; LANES],
}

/// What the setup needs besides the tet: optional per-vertex fields.
pub(crate) struct SetupInputs<'a> {
    pub scene: &'a Scene,
    pub view: &'a ViewGeometry,
    pub want_grad_mag: bool,
    pub want_normals: bool,
    /// Lighting: the world position (point lights) and the shadow field,
    /// interpolated like the normals.
    pub want_position: bool,
    pub shadows: Option<&'a std::sync::Arc<crate::ShadowField>>,
    /// The f64 thick-point data `pt-linear` shades once per tet.
    pub want_thick: bool,
    /// The f32 span data per-fragment methods evaluate (always built for clipped tets).
    pub want_span: bool,
}

/// Pixel bounding box `[x0, y0, x1, y1]` (inclusive, clipped to the image) of
/// the pixel centres a tet may cover, or `None` when it covers none.
pub(crate) fn tet_bbox(view: &ViewGeometry, tet: &[u32; 4]) -> Option<[i32; 4]> {
    let mut pts = [[0.0; 2]; 6];
    let mut keys = [0u64; 6];
    let n = screen_points(view, tet, &mut pts, &mut keys);
    bbox_of(&pts[..n], view.frame.width, view.frame.height)
}

pub(crate) fn bbox_of(pts: &[[f64; 2]], w: u32, h: u32) -> Option<[i32; 4]> {
    if pts.is_empty() {
        return None;
    }
    let (mut lo, mut hi) = ([f64::INFINITY; 2], [f64::NEG_INFINITY; 2]);
    for p in pts {
        for k in 0..2 {
            lo[k] = lo[k].min(p[k]);
            hi[k] = hi[k].max(p[k]);
        }
    }
    if !(lo[0].is_finite() && lo[1].is_finite() && hi[0].is_finite() && hi[1].is_finite()) {
        return None;
    }
    // Centre i + ½ inside [lo, hi] ⇔ i ∈ [ceil(lo − ½), floor(hi − ½)]
    // (ceil_i64/floor_i64: no libm call per tet; exact for these finite values).
    let c = |v: i64, max: u32| v.clamp(-1, i64::from(max)) as i32;
    let x0 = c(ceil_i64(lo[0] - 0.5), w);
    let y0 = c(ceil_i64(lo[1] - 0.5), h);
    let x1 = c(floor_i64(hi[0] - 0.5), w - 1);
    let y1 = c(floor_i64(hi[1] - 0.5), h - 1);
    let (x0, y0) = (x0.max(0), y0.max(0));
    if x0 > x1 || y0 > y1 || x1 < 0 || y1 < 0 {
        return None;
    }
    Some([x0, y0, x1, y1])
}

/// The tet's projected points: its 4 vertices, or, when it crosses the near
/// plane, the vertices in front of it plus the points where its edges cross
/// it (at most 6). Keys identify points across tets (vertex id, or the
/// canonical edge) so shared silhouette edges are evaluated identically.
pub(crate) fn screen_points(
    view: &ViewGeometry,
    tet: &[u32; 4],
    pts: &mut [[f64; 2]; 6],
    keys: &mut [u64; 6],
) -> usize {
    let f = &view.frame;
    let z = tet.map(|v| view.cam[v as usize][2]);
    if f.parallel || z.iter().all(|&z| z >= f.near_depth) {
        for k in 0..4 {
            pts[k] = view.px[tet[k] as usize];
            keys[k] = vertex_key(tet[k]);
        }
        return 4;
    }
    let mut n = 0;
    for k in 0..4 {
        if z[k] >= f.near_depth {
            pts[n] = view.px[tet[k] as usize];
            keys[n] = vertex_key(tet[k]);
            n += 1;
        }
    }
    if n == 0 {
        return 0;
    }
    for i in 0..4 {
        for j in i + 1..4 {
            if (z[i] >= f.near_depth) != (z[j] >= f.near_depth) {
                let (a, b) = if tet[i] < tet[j] { (tet[i], tet[j]) } else { (tet[j], tet[i]) };
                let (xa, xb) = (view.cam[a as usize], view.cam[b as usize]);
                let t = (f.near_depth - xa[2]) / (xb[2] - xa[2]);
                let x = [xa[0] + t * (xb[0] - xa[0]), xa[1] + t * (xb[1] - xa[1]), f.near_depth];
                pts[n] = f.cam_to_px(x);
                keys[n] = ((a as u64) << 32) | b as u64;
                n += 1;
            }
        }
    }
    n
}

/// [`TetSetup::row_span`] over the silhouette edges `edges`.
#[inline]
pub(crate) fn row_span_of(edges: &[Edge], py: u32, x_lo: u32, x_hi: u32) -> Option<(u32, u32)> {
    let y = py as f64 + 0.5;
    let (mut lo, mut hi) = (x_lo as i64, x_hi as i64);
    for e in edges {
        if lo > hi {
            return None;
        }
        let at = |i: i64| e.inside(i as f64 + 0.5, y);
        let slope = e.slope;
        if slope == 0.0 {
            if !at(lo) {
                return None;
            }
            continue;
        }
        // The crossing's x, off by far less than a pixel: the exact tests
        // below usually just confirm the pixel next to it (a NaN or huge
        // crossing saturates, is clamped, and costs a longer walk).
        let run = e.x_per_y * (y - e.ay);
        let x_cross = e.ax + run - 0.5;
        // Fast path: pixel i's test decides i + ½ against the edge's
        // crossing, so when x_cross is farther from an integer than the
        // rounding of x_cross and of the test itself (each a few ulps of
        // `scale`; the margin is ~300× that), ⌈x_cross⌉ / ⌊x_cross⌋ is
        // exactly the boundary the tests below would settle on.
        let scale = e.ax.abs() + run.abs() + 1.0;
        if scale < 1e12 {
            let fl = floor_below_2_51(x_cross);
            let frac = x_cross - fl;
            if frac > 1e-12 * scale && frac < 1.0 - 1e-12 * scale {
                // frac > 0: ⌈x_cross⌉ = ⌊x_cross⌋ + 1.
                let f = fl as i64;
                if slope < 0.0 {
                    lo = lo.max((f + 1).min(hi + 1));
                } else {
                    hi = hi.min(f.max(lo - 1));
                }
                continue;
            }
        }
        if slope < 0.0 {
            // Inside for x ≥ boundary: the first inside pixel ≥ lo.
            let mut i = ceil_i64(x_cross).clamp(lo, hi + 1);
            if i <= hi && at(i) {
                while i > lo && at(i - 1) {
                    i -= 1;
                }
            } else {
                while i <= hi && !at(i) {
                    i += 1;
                }
            }
            lo = i;
        } else {
            // Inside for x ≤ boundary: the last inside pixel ≤ hi.
            let mut i = floor_i64(x_cross).clamp(lo - 1, hi);
            if i >= lo && at(i) {
                while i < hi && at(i + 1) {
                    i += 1;
                }
            } else {
                while i >= lo && !at(i) {
                    i -= 1;
                }
            }
            hi = i;
        }
    }
    (lo <= hi).then_some((lo as u32, hi as u32))
}

/// ⌊v⌋ for |v| < 2⁵¹, exactly, without a libm call or an integer round
/// trip: adding 1.5·2⁵² rounds v to an integer in the mantissa.
#[inline(always)]
pub(crate) fn floor_below_2_51(v: f64) -> f64 {
    const M: f64 = 6_755_399_441_055_744.0;
    let r = (v + M) - M;
    if r > v {
        r - 1.0
    } else {
        r
    }
}

/// ⌈v⌉ for |v| ≤ 1e15 (beyond: ±1e15; NaN → 0), without a libm call on
/// baseline x86-64.
#[inline(always)]
pub(crate) fn ceil_i64(v: f64) -> i64 {
    let v = v.clamp(-1e15, 1e15);
    let t = v as i64;
    if (t as f64) < v {
        t + 1
    } else {
        t
    }
}

/// ⌊v⌋, as [`ceil_i64`].
#[inline(always)]
pub(crate) fn floor_i64(v: f64) -> i64 {
    let v = v.clamp(-1e15, 1e15);
    let t = v as i64;
    if (t as f64) > v {
        t - 1
    } else {
        t
    }
}

#[inline]
pub(crate) fn vertex_key(v: u32) -> u64 {
    ((v as u64) << 32) | v as u64
}

/// Convex hull (positively oriented, exact orientation tests) of up to 6 points.
pub(crate) fn hull_of(pts: &[[f64; 2]], keys: &[u64], out: &mut [[f64; 2]; 6], out_keys: &mut [u64; 6]) -> usize {
    let mut idx: Vec<usize> = (0..pts.len()).collect();
    idx.sort_by(|&a, &b| pts[a][0].total_cmp(&pts[b][0]).then(pts[a][1].total_cmp(&pts[b][1])));
    let mut h: Vec<usize> = Vec::with_capacity(12);
    for pass in 0..2 {
        let start = h.len();
        let iter: Box<dyn Iterator<Item = &usize>> =
            if pass == 0 { Box::new(idx.iter()) } else { Box::new(idx.iter().rev()) };
        for &i in iter {
            while h.len() >= start + 2
                && orient2d(coord(pts[h[h.len() - 2]]), coord(pts[h[h.len() - 1]]), coord(pts[i])) <= 0.0
            {
                h.pop();
            }
            h.push(i);
        }
        h.pop();
    }
    let n = h.len().min(6);
    for (k, &i) in h.iter().take(n).enumerate() {
        out[k] = pts[i];
        out_keys[k] = keys[i];
    }
    n
}

impl TetSetup {
    /// Sets up tet `t`, or `None` when it can cover no pixel (fully behind
    /// the near plane, zero projected area, zero volume, off screen).
    #[cfg(test)]
    pub fn new(inp: &SetupInputs, t: usize) -> Option<TetSetup> {
        let mut s = TetSetup::default();
        s.build(inp, t).then_some(s)
    }

    /// Sets up tet `t` in place (a setup is large: the rasterizer reuses one
    /// per tile rather than moving a new one around for every tet); `false`
    /// when the tet can cover no pixel (fully behind the near plane, zero
    /// projected area, zero volume, off screen, or no exit face). Builds the
    /// f64 thick-point data (planes, fields; thick point and tent unless
    /// clipped) when `want_thick`, and the f32 span data when `want_span` or
    /// clipped.
    pub fn build(&mut self, inp: &SetupInputs, t: usize) -> bool {
        let scene = inp.scene;
        let view = inp.view;
        let frame = &view.frame;
        let tet = &scene.tets()[t];
        let mut pts = [[0.0; 2]; 6];
        let mut keys = [0u64; 6];
        let n = screen_points(view, tet, &mut pts, &mut keys);
        if n < 3 {
            return false;
        }
        let mut hull = [[0.0; 2]; 6];
        let mut hull_keys = [0u64; 6];
        let clipped = n != 4 || (!frame.parallel && tet.iter().any(|&v| view.cam[v as usize][2] < frame.near_depth));
        let (n_hull, thick) = if clipped {
            (hull_of(&pts[..n], &keys[..n], &mut hull, &mut hull_keys), None)
        } else {
            let p4 = [pts[0], pts[1], pts[2], pts[3]];
            let (class, ns) = silhouette_hull(&p4, &[keys[0], keys[1], keys[2], keys[3]], &mut hull, &mut hull_keys);
            (ns, class.thick_point(&p4))
        };
        if n_hull < 3 {
            return false;
        }
        let Some(bbox) = bbox_of(&hull[..n_hull], frame.width, frame.height) else { return false };

        // Linear fields from the camera-space vertices.
        let x = tet.map(|v| DVec3::from(view.cam[v as usize]));
        let (e1, e2, e3) = (x[1] - x[0], x[2] - x[0], x[3] - x[0]);
        let (c23, c31, c12) = (e2.cross(e3), e3.cross(e1), e1.cross(e2));
        let det = e1.dot(c23);
        if det == 0.0 || !det.is_finite() {
            return false;
        }
        // f64 planes and fields whenever asked (the thick point, and tests'
        // per-pixel oracle); the thick point itself only for unclipped tets.
        let thick_path = inp.want_thick;
        let span_path = inp.want_span || clipped;
        let grad_of = |f: &[f64; 4]| (c23 * (f[1] - f[0]) + c31 * (f[2] - f[0]) + c12 * (f[3] - f[0])) / det;
        let field_of = |f: &[f64; 4]| Field::new(frame, grad_of(f), f[0], x[0]);
        let sv = tet.map(|v| scene.scalar()[v as usize]);
        let range = |f: &[f64; 4]| {
            [f.iter().copied().fold(f64::INFINITY, f64::min), f.iter().copied().fold(f64::NEG_INFINITY, f64::max)]
        };
        let g_vals = match (inp.want_grad_mag, scene.gradient_magnitudes()) {
            (true, Some(gm)) => Some(tet.map(|v| gm[v as usize])),
            _ => None,
        };
        self.s = if thick_path { field_of(&sv) } else { Field::default() };
        self.s_range = range(&sv);
        self.g = g_vals.as_ref().filter(|_| thick_path).map(field_of);
        self.g_range = g_vals.as_ref().map_or([0.0, 0.0], range);
        self.normal = match (inp.want_normals, scene.gradients()) {
            (true, Some(gr)) => {
                let comp = |c: usize| field_of(&tet.map(|v| gr[v as usize][c]));
                Some([comp(0), comp(1), comp(2)])
            }
            _ => None,
        };
        self.position = None;
        if inp.want_normals {
            if inp.want_position {
                let pos = inp.scene.positions_rel();
                self.position = Some(std::array::from_fn(|c| field_of(&tet.map(|v| pos[v as usize][c]))));
                self.centre = inp.scene.centre_in_world();
            }
            self.shadow_maps = inp.shadows.filter(|f| f.has_maps()).cloned();
        }
        let mut len_max: f64 = 0.0;
        for i in 0..4 {
            for j in i + 1..4 {
                len_max = len_max.max((x[i] - x[j]).length_squared());
            }
        }
        self.len_max = len_max.sqrt();
        self.n_hull = n_hull;
        for k in 0..n_hull {
            let j = (k + 1) % n_hull;
            self.edges[k] = Edge::new(hull[k], hull_keys[k], hull[j], hull_keys[j]);
        }
        self.bbox = bbox;
        self.near_w = if clipped && !frame.parallel { Some(1.0 / frame.near_depth) } else { None };
        self.parallel = frame.parallel;
        self.clipped = clipped;
        self.thick = if thick_path { thick } else { None }; // None when clipped
        self.n_ramps = 0;
        self.n_front = 0;
        self.n_back = 0;
        self.span = SpanEval::new(frame, bbox);

        if thick_path {
            if let Some(t) = thick {
                for k in 0..n_hull {
                    let (u, v) = (hull[k], hull[(k + 1) % n_hull]);
                    let (dx, dy) = (v[0] - u[0], v[1] - u[1]);
                    let et = dx * (t[1] - u[1]) - dy * (t[0] - u[0]);
                    if et > 0.0 {
                        // (dx·(y − u_y) − dy·(x − u_x)) / et as an affine function.
                        self.tent_ramps[self.n_ramps] = [(dy * u[0] - dx * u[1]) / et, -dy / et, dx / et];
                        self.n_ramps += 1;
                    }
                }
            }
            self.span.rebase_ramps(&self.tent_ramps[..self.n_ramps], &mut self.span_ramps);
            if !self.set_f64_planes(frame, &x, view.face_mask[t]) {
                return false;
            }
        }
        if span_path {
            let near = if clipped && !frame.parallel { Some(frame.near_depth) } else { None };
            let ranges = (self.s_range, self.g_range, self.len_max);
            if !self.span.set_segments(frame, &x, &sv, g_vals.as_ref(), view.face_mask[t], near, ranges) {
                return false;
            }
        }
        true
    }

    /// The f64 face planes of [`TetSetup::fragment`]; `false` when none is an exit.
    pub(crate) fn set_f64_planes(&mut self, frame: &Frame, x: &[DVec3; 4], mask: u8) -> bool {
        for (f, fv) in FACE_OUTWARD.iter().enumerate() {
            let front = mask & (1 << f) != 0;
            let back = mask & (1 << (4 + f)) != 0;
            if !front && !back {
                continue;
            }
            let (a, b, c) = (x[fv[0]], x[fv[1]], x[fv[2]]);
            // The camera basis (right, up, forward) is left-handed, so the
            // outward normal's components are (c − a) × (b − a) there.
            let nrm = (c - a).cross(b - a);
            let k = nrm.dot(a);
            let q = if frame.parallel {
                // Depth where the ray (x_c, y_c, ·) meets n·X = k.
                let nz = nrm.z;
                let agrees = if front { nz < 0.0 } else { nz > 0.0 };
                if !agrees {
                    continue; // rounding disagrees with the exact side: edge-on, skip
                }
                [(k - nrm.x * frame.bx - nrm.y * frame.by) / nz, -nrm.x * frame.ax / nz, -nrm.y * frame.ay / nz]
            } else {
                // 1/depth where the ray z·(x_c, y_c, 1) meets n·X = k; the eye
                // (origin) is outside a front face: k < 0.
                let agrees = if front { k < 0.0 } else { k > 0.0 };
                if !agrees {
                    continue;
                }
                [(nrm.x * frame.bx + nrm.y * frame.by + nrm.z) / k, nrm.x * frame.ax / k, nrm.y * frame.ay / k]
            };
            if !q.iter().all(|v| v.is_finite()) {
                continue;
            }
            if front {
                self.planes_front[self.n_front] = q;
                self.n_front += 1;
            } else {
                self.planes_back[self.n_back] = q;
                self.n_back += 1;
            }
        }
        self.n_back > 0
    }

    /// The pixels of row `py` within `[x_lo, x_hi]` whose centres the
    /// silhouette covers, as an inclusive range, decided by the same edge
    /// functions and tie rule as [`TetSetup::covers`] (so exactly the pixels
    /// it accepts): each edge's test is monotone in x along a row, so its
    /// boundary is estimated from the edge's crossing and then settled with
    /// the exact test.
    pub fn row_span(&self, py: u32, x_lo: u32, x_hi: u32) -> Option<(u32, u32)> {
        row_span_of(&self.edges[..self.n_hull], py, x_lo, x_hi)
    }

    /// Segments for the `LANES` pixels `(px0 + l, py)`, l = 0..LANES, in f32
    /// (see [`SpanEval`]); lanes outside the tet get `len_world == 0`.
    /// Scalars are clamped into the tet's vertex range and lengths into
    /// [0, longest edge], so no lane is ever NaN.
    #[inline]
    pub fn eval_lanes(&self, px0: u32, py: u32, out: &mut Lanes) {
        self.span.eval_row(px0, py, out);
    }

    /// The `pt-linear` tent weights for the `LANES` pixels `(px0 + l, py)`
    /// (see [`TetSetup::tent`]), in f32.
    #[inline]
    pub fn tent_lanes(&self, px0: u32, py: u32, out: &mut [f32; LANES]) {
        let sp = &self.span;
        let i0 = (px0 as i32 - sp.ref_px[0]) as f32;
        let j = (py as i32 - sp.ref_px[1]) as f32;
        *out = [1.0; LANES];
        for r in &self.span_ramps[..self.n_ramps] {
            let rr = r.row(j);
            for (l, o) in out.iter_mut().enumerate() {
                let v = rr + r.dx * (i0 + l as f32);
                *o = if v < *o { v } else { *o };
            }
        }
        for o in out.iter_mut() {
            *o = if *o > 0.0 { o.min(1.0) } else { 0.0 };
        }
    }

    /// Whether pixel centre (x, y) is covered (edge functions, tie rule);
    /// the per-pixel definition [`TetSetup::row_span`] must agree with.
    #[cfg(test)]
    pub fn covers(&self, x: f64, y: f64) -> bool {
        self.edges[..self.n_hull].iter().all(|e| e.inside(x, y))
    }

    /// The segment along the ray through pixel position (x, y); `None` where
    /// the ray misses the tet or the segment has no length.
    #[inline]
    pub fn fragment(&self, frame: &Frame, x: f64, y: f64) -> Option<Fragment> {
        let ev = |q: &[f64; 3]| q[0] + q[1] * x + q[2] * y;
        let (z_f, z_b) = if self.parallel {
            let mut zf = f64::NEG_INFINITY;
            for q in &self.planes_front[..self.n_front] {
                zf = zf.max(ev(q));
            }
            let mut zb = f64::INFINITY;
            for q in &self.planes_back[..self.n_back] {
                zb = zb.min(ev(q));
            }
            (zf, zb)
        } else {
            // Entry: the smallest positive 1/depth over front planes (and the
            // near plane); exit: the largest over back planes.
            let mut wf = self.near_w.unwrap_or(f64::INFINITY);
            for q in &self.planes_front[..self.n_front] {
                let w = ev(q);
                if w > 0.0 && w < wf {
                    wf = w;
                }
            }
            let mut wb = 0.0f64;
            for q in &self.planes_back[..self.n_back] {
                wb = wb.max(ev(q));
            }
            // (f64::max drops NaNs, so wb is a number.)
            if wb <= 0.0 || wf == f64::INFINITY {
                return None;
            }
            (1.0 / wf, 1.0 / wb)
        };
        if !z_f.is_finite() || !z_b.is_finite() || z_b <= z_f {
            return None;
        }
        let len = ((z_b - z_f) * frame.len_per_depth(x, y)).min(self.len_max);
        let clamp = |v: f64, r: [f64; 2]| if v.is_nan() { r[0] } else { v.clamp(r[0], r[1]) };
        let (g_front, g_back) = match &self.g {
            Some(g) => (clamp(g.at(x, y, z_f), self.g_range), clamp(g.at(x, y, z_b), self.g_range)),
            None => (0.0, 0.0),
        };
        Some(Fragment {
            s_front: clamp(self.s.at(x, y, z_f), self.s_range),
            s_back: clamp(self.s.at(x, y, z_b), self.s_range),
            g_front,
            g_back,
            len_world: len,
            z_front: z_f,
            z_back: z_b,
        })
    }

    /// The interpolated per-vertex gradient (world frame) at depth z on the
    /// ray through (x, y), when normals were requested.
    #[inline]
    pub fn normal_at(&self, x: f64, y: f64, z: f64) -> Option<DVec3> {
        self.normal.as_ref().map(|n| DVec3::new(n[0].at(x, y, z), n[1].at(x, y, z), n[2].at(x, y, z)))
    }

    /// World position (when asked for) and each light's shadow
    /// transmittance (1 without a field) at depth `z` of the ray through
    /// (x, y).
    pub fn lit_at(&self, x: f64, y: f64, z: f64) -> (DVec3, [f64; crate::MAX_LIGHTS]) {
        let pos = match &self.position {
            Some(f) => DVec3::new(f[0].at(x, y, z), f[1].at(x, y, z), f[2].at(x, y, z)) + self.centre,
            None => DVec3::ZERO,
        };
        let mut shadow = [1.0; crate::MAX_LIGHTS];
        if let Some(m) = &self.shadow_maps {
            for (i, t) in shadow.iter_mut().enumerate().take(m.num_lights()) {
                *t = (-m.depth_at(i, pos).max(0.0)).exp();
            }
        }
        (pos, shadow)
    }

    /// The tent weight of the thick point at pixel (x, y): 1 at the thick
    /// point, 0 on the silhouette, linear on each of the Shirley–Tuchman
    /// triangles (on a convex silhouette the tent is the minimum of the
    /// per-edge ramps, so no triangle lookup is needed). The f64 definition
    /// [`TetSetup::tent_lanes`] evaluates in f32.
    #[cfg(test)]
    pub fn tent(&self, x: f64, y: f64) -> f64 {
        if self.thick.is_none() {
            return 0.0;
        }
        let mut lam = 1.0f64;
        for r in &self.tent_ramps[..self.n_ramps] {
            lam = lam.min(r[0] + r[1] * x + r[2] * y);
        }
        lam.clamp(0.0, 1.0)
    }
}

/// Which pixels of its bounding box a prepared tet covers.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(crate) enum Cover {
    /// Bounding box at most [`MASK_SIDE`] pixels wide and high: bit
    /// `8·j + i` is pixel (bbox x0 + i, bbox y0 + j).
    Mask(u64),
    /// Larger: one inclusive pixel range per row of the bounding box, from
    /// this index on in the rows list (`[1, 0]` for an empty row).
    Rows(u32),
}

/// Side of the bounding boxes whose coverage is a [`Cover::Mask`].
pub(crate) const MASK_SIDE: i32 = 8;

/// The silhouette of an unclipped tet's projected vertices `p4` (keys
/// `keys4`) in `hull`/`hull_keys`, positively oriented (interior on the left
/// of each directed edge): its Shirley–Tuchman class and vertex count (0
/// when degenerate).
pub(crate) fn silhouette_hull(
    p4: &[[f64; 2]; 4],
    keys4: &[u64; 4],
    hull: &mut [[f64; 2]; 6],
    hull_keys: &mut [u64; 6],
) -> (ProjClass, usize) {
    let class = classify_projection(p4);
    let (sil, ns) = class.silhouette();
    for k in 0..ns {
        hull[k] = p4[sil[k]];
        hull_keys[k] = keys4[sil[k]];
    }
    let area: f64 = (0..ns)
        .map(|k| {
            let (u, v) = (hull[k], hull[(k + 1) % ns]);
            u[0] * v[1] - u[1] * v[0]
        })
        .sum();
    if area < 0.0 {
        hull[..ns].reverse();
        hull_keys[..ns].reverse();
    }
    (class, ns)
}

/// What [`prepare_span`] made of a tet.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(crate) enum Prepared {
    /// Covers no pixel (what [`TetSetup::build`] returns `false` for).
    Nothing,
    /// Crosses the near plane: only [`TetSetup::build`] clips.
    Clipped,
    /// `span` holds the tet's planes and fields; `cover` its pixels.
    Span { bbox: [i32; 4], cover: Cover },
}

/// The per-fragment (span) setup of one unclipped tet, once per tet rather
/// than once per tile it touches: the same silhouette, bounding box, edge
/// tests and [`SpanEval`] as [`TetSetup::build`] with `want_span`, so the
/// rasterizer's fast path draws the same fragments with the same values.
/// The row spans over the whole bounding box are computed here, where the
/// edges are at hand ([`row_span_of`] on a sub-range of a row gives that
/// sub-range of the full span).
pub(crate) fn prepare_span(inp: &SetupInputs, t: usize, span: &mut SpanEval, rows: &mut Vec<[u16; 2]>) -> Prepared {
    let scene = inp.scene;
    let view = inp.view;
    let frame = &view.frame;
    let tet = &scene.tets()[t];
    if !frame.parallel && tet.iter().any(|&v| view.cam[v as usize][2] < frame.near_depth) {
        return Prepared::Clipped;
    }
    let p4 = tet.map(|v| view.px[v as usize]);
    let mut hull = [[0.0; 2]; 6];
    let mut hull_keys = [0u64; 6];
    let (_, ns) = silhouette_hull(&p4, &tet.map(vertex_key), &mut hull, &mut hull_keys);
    if ns < 3 {
        return Prepared::Nothing;
    }
    let Some(bbox) = bbox_of(&hull[..ns], frame.width, frame.height) else { return Prepared::Nothing };
    let x = tet.map(|v| DVec3::from(view.cam[v as usize]));
    let (e1, e2, e3) = (x[1] - x[0], x[2] - x[0], x[3] - x[0]);
    let det = e1.dot(e2.cross(e3));
    if det == 0.0 || !det.is_finite() {
        return Prepared::Nothing;
    }
    let sv = tet.map(|v| scene.scalar()[v as usize]);
    let range = |f: &[f64; 4]| {
        [f.iter().copied().fold(f64::INFINITY, f64::min), f.iter().copied().fold(f64::NEG_INFINITY, f64::max)]
    };
    let g_vals = match (inp.want_grad_mag, scene.gradient_magnitudes()) {
        (true, Some(gm)) => Some(tet.map(|v| gm[v as usize])),
        _ => None,
    };
    let g_range = g_vals.as_ref().map_or([0.0, 0.0], range);
    let mut len_max: f64 = 0.0;
    for i in 0..4 {
        for j in i + 1..4 {
            len_max = len_max.max((x[i] - x[j]).length_squared());
        }
    }
    *span = SpanEval::new(frame, bbox);
    let ranges = (range(&sv), g_range, len_max.sqrt());
    if !span.set_segments(frame, &x, &sv, g_vals.as_ref(), view.face_mask[t], None, ranges) {
        return Prepared::Nothing;
    }
    let mut edges = [Edge::default(); 4];
    for k in 0..ns {
        let j = (k + 1) % ns;
        edges[k] = Edge::new(hull[k], hull_keys[k], hull[j], hull_keys[j]);
    }
    let (w, h) = (bbox[2] - bbox[0] + 1, bbox[3] - bbox[1] + 1);
    if w <= MASK_SIDE && h <= MASK_SIDE {
        return Prepared::Span { bbox, cover: Cover::Mask(cover_mask(&edges[..ns], bbox)) };
    }
    let first = rows.len() as u32;
    for py in bbox[1]..=bbox[3] {
        let r = row_span_of(&edges[..ns], py as u32, bbox[0] as u32, bbox[2] as u32);
        rows.push(r.map_or([1, 0], |(a, b)| [a as u16, b as u16]));
    }
    Prepared::Span { bbox, cover: Cover::Rows(first) }
}

/// The pixel centres of a bounding box at most [`MASK_SIDE`] square that
/// every edge accepts, as a [`Cover::Mask`]: [`Edge::inside`] for each,
/// with its row term `dx·(y − ay)` and column term `dy·(x − ax)` computed
/// once per row and column (the same operations, so the same decisions),
/// eight columns at a time.
pub(crate) fn cover_mask(edges: &[Edge], bbox: [i32; 4]) -> u64 {
    const S: usize = MASK_SIDE as usize;
    let (w, h) = ((bbox[2] - bbox[0] + 1) as usize, (bbox[3] - bbox[1] + 1) as usize);
    let cols: u64 = (1u64 << w) - 1;
    let mut mask = 0u64;
    for j in 0..h {
        mask |= cols << (S * j);
    }
    let x = |i: usize| (bbox[0] + i as i32) as f64 + 0.5;
    let (x_lo, x_hi) = (f64x4::from([x(0), x(1), x(2), x(3)]), f64x4::from([x(4), x(5), x(6), x(7)]));
    let zero = f64x4::ZERO;
    for e in edges {
        let (ax, dy, sign) = (f64x4::splat(e.ax), f64x4::splat(e.dy), f64x4::splat(e.sign));
        let (c_lo, c_hi) = (dy * (x_lo - ax), dy * (x_hi - ax));
        let tie = if e.tie { f64x4::splat(f64::from_bits(u64::MAX)) } else { zero };
        let mut m = 0u64;
        for j in 0..h {
            let row = f64x4::splat(e.dx * ((bbox[1] + j as i32) as f64 + 0.5 - e.ay));
            let bits = |c: f64x4| {
                let v = sign * (row - c);
                (v.cmp_gt(zero) | (v.cmp_eq(zero) & tie)).move_mask() as u64
            };
            m |= (bits(c_lo) | bits(c_hi) << 4) << (S * j);
        }
        mask &= m;
    }
    mask
}
