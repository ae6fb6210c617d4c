//! A `Table3d`'s lookups: a segment's cell, the gather of the 8 entries
//! around it and the reconstruction ([`Reconstruction`]); the
//! [`SegmentShader`] impl, and the choice of the AVX2 kernel (`simd_x86`).

use super::{LookupKernel, Reconstruction, Table3d, W};
use crate::method::{self, Method, Rgba32, Segment, SegmentBatch, SegmentShader};
use crate::simd::{no_nan, vmax, vmin};
use glam::Vec4;
use wide::{f32x8, CmpLt};

impl Table3d {
    /// The lookup ([`Reconstruction`]); inputs outside the domain (and NaN)
    /// are clamped.
    #[inline]
    pub fn lookup(&self, sf: f32, sb: f32, len_world: f32) -> Rgba32 {
        self.gather_cell(&self.cell_of(sf, sb, len_world))
    }

    /// The lookup in cell `c`, any storage.
    #[inline(always)]
    fn gather_cell(&self, c: &Cell) -> Rgba32 {
        match self.data.as_f32() {
            Some(d) => self.gather_f32(d, c),
            None => self.gather(
                |b| {
                    let (e0, e1) = (self.data.get4(b), self.data.get4(b + 4));
                    [e0[0], e0[1], e0[2], e0[3], e1[0], e1[1], e1[2], e1[3]]
                },
                c,
            ),
        }
    }

    /// The lower corner and fractions of a lookup's cell (no table access).
    #[inline(always)]
    fn cell_of(&self, sf: f32, sb: f32, len_world: f32) -> Cell {
        let (xa, xb) = self.band_coords(sf, sb);
        let xk = (len_world * self.inv_dl).max(0.0).min((self.params.n_l - 1) as f32);
        // x is in [0, n − 1] (clamped, never NaN): an i32 cast is exact and
        // far cheaper than a saturating cast to usize.
        let split = |x: f32, n: usize| {
            let i = (x as i32).min(n as i32 - 2);
            (i as usize, x - i as f32)
        };
        let (a0, fa) = split(xa, self.params.n_s);
        let (b0, fb) = split(xb, self.params.n_s);
        let (k0, fk) = split(xk, self.params.n_l);
        Cell { a0, b0, k0, fa, fb, fk }
    }

    /// [`Table3d::gather`] on f32 storage: the 4 (Sf, Sb) corners' two
    /// l-neighbours are 8 contiguous floats each.
    #[inline(always)]
    fn gather_f32(&self, d: &[f32], c: &Cell) -> Rgba32 {
        self.gather(|b| d[b..b + 8].try_into().expect("8 floats"), c)
    }

    /// Float offsets of entries (a0, b0, k0) and (a0 + 1, b0, k0); pair
    /// (a, b + 1) follows pair (a, b) in its row, so the other two corners
    /// are n_l entries further.
    #[inline(always)]
    fn cell_bases(&self, c: &Cell) -> (usize, usize) {
        let nl = self.params.n_l;
        let base0 = (self.band.pair_off[c.a0].wrapping_add(c.b0) * nl + c.k0) * 4;
        let base1 = (self.band.pair_off[c.a0 + 1].wrapping_add(c.b0) * nl + c.k0) * 4;
        (base0, base1)
    }

    /// The lookup at `c` from the 8 entries around it, `load8(b)` giving
    /// the entries at float offsets b and b + 4 (k0 and k0 + 1 of a corner).
    /// Every storage and lookup path reconstructs here, so they agree bit
    /// for bit; a corner of weight 0 may lie outside the band (its offset
    /// wraps within the data, as `pair_off` is built) and adds 0.
    #[inline(always)]
    fn gather(&self, load8: impl Fn(usize) -> [f32; 8], c: &Cell) -> Rgba32 {
        let Cell { fa, fb, fk, .. } = *c;
        let nl = self.params.n_l;
        let (base0, base1) = self.cell_bases(c);
        let bases = [base0, base0 + nl * 4, base1, base1 + nl * 4];
        // (Explicit, not `array::map`: that was not inlined on this hot path.)
        let e = [load8(bases[0]), load8(bases[1]), load8(bases[2]), load8(bases[3])];
        if self.recon == Reconstruction::Trilinear {
            // The 8 entries weighted: corner c's (Sf, Sb) weight w_c times
            // 1 − fk for its slice k0 and fk for k0 + 1, summed over the
            // corners in order for each slice, then the two slices (the
            // kernel's order: `simd_x86`).
            let (wa0, wa1, wb0, wb1) = (1.0 - fa, fa, 1.0 - fb, fb);
            let w = [wa0 * wb0, wa0 * wb1, wa1 * wb0, wa1 * wb1];
            let gk = 1.0 - fk;
            let slice = |h: usize, f: f32| {
                let v = |c: usize| Vec4::new(e[c][h], e[c][h + 1], e[c][h + 2], e[c][h + 3]) * (w[c] * f);
                ((v(0) + v(1)) + v(2)) + v(3)
            };
            return (slice(0, gk) + slice(4, fk)).to_array();
        }
        let depth = if self.depth.is_empty() {
            // Non-f32 storage: the depths of the decoded entries.
            let alpha = f32x8::from([e[0][3], e[0][7], e[1][3], e[1][7], e[2][3], e[2][7], e[3][3], e[3][7]]);
            let t = optical_depths(alpha).to_array();
            [[t[0], t[1]], [t[2], t[3]], [t[4], t[5]], [t[6], t[7]]]
        } else {
            let d = |b: usize| [self.depth[b / 4], self.depth[b / 4 + 1]];
            [d(bases[0]), d(bases[1]), d(bases[2]), d(bases[3])]
        };
        reconstruct(&e, &depth, fa, fb, fk)
    }

    /// Forces the portable lookup, or lets the AVX2 kernel run where it can
    /// ([`LookupKernel`]); kept across [`Table3d::rebake`].
    pub fn set_lookup_kernel(&mut self, kernel: LookupKernel) {
        self.kernel = kernel;
    }

    /// [`Table3d::set_lookup_kernel`] by value.
    pub fn with_lookup_kernel(mut self, kernel: LookupKernel) -> Self {
        self.kernel = kernel;
        self
    }

    /// The kernel batched lookups run on now: `"avx2"` or `"portable"`.
    pub fn lookup_kernel_in_use(&self) -> &'static str {
        #[cfg(target_arch = "x86_64")]
        if self.kernel == LookupKernel::Auto && crate::simd_x86::available() {
            return "avx2";
        }
        "portable"
    }

    /// The AVX2 kernel's batched lookup into `out`; `false` (nothing
    /// written) where it does not run.
    #[inline]
    pub(crate) fn shade_batch_lean(&self, segs: &SegmentBatch, out: &mut [Rgba32; method::BATCH]) -> bool {
        #[cfg(target_arch = "x86_64")]
        if self.kernel == LookupKernel::Auto {
            let axis = &*self.axis;
            let lean = crate::simd_x86::Lean {
                uniform: axis.uniform,
                lo: if axis.uniform { self.domain.s_lo as f32 } else { axis.lo },
                hi: axis.hi,
                inv_ds: self.inv_ds,
                reach: self.band.reach,
                max_ds: self.domain.max_ds as f32,
                bucket: &axis.bucket,
                bucket_inv: axis.bucket_inv,
                bucket_j: &axis.bucket_j,
                bucket2: &axis.bucket2,
                seg_s0: &axis.seg_s0,
                seg_s1: &axis.seg_s1,
                seg_x0: &axis.seg_x0,
                seg_inv: &axis.seg_inv,
                n_s: self.params.n_s,
                n_l: self.params.n_l,
                inv_dl: self.inv_dl,
                pair_off: &self.band.pair_off32,
                data: self.data.raw(),
                depth: &self.depth,
            };
            if self.recon == Reconstruction::Trilinear {
                return crate::simd_x86::shade_batch(&lean, segs, out);
            }
            // Optical depth on f32 storage (its depths kept): the kernel
            // reconstructs as `reconstruct` does, operation for operation.
            if !self.depth.is_empty() && crate::simd_x86::shade_batch_depth(&lean, segs, out) {
                return true;
            }
            // Optical depth: the kernel's cells, the portable gather.
            let mut c = crate::simd_x86::Cells::default();
            if !crate::simd_x86::cells(&lean, segs, &mut c) {
                return false;
            }
            for (i, o) in out.iter_mut().enumerate().take(segs.len.min(method::BATCH)) {
                // The kernel's corners are in [0, n − 2] (never negative).
                let cell = Cell {
                    a0: c.a0[i] as usize,
                    b0: c.b0[i] as usize,
                    k0: c.k0[i] as usize,
                    fa: c.fa[i],
                    fb: c.fb[i],
                    fk: c.fk[i],
                };
                *o = self.gather_cell(&cell);
            }
            return true;
        }
        let _ = (segs, out);
        false
    }
}

/// Transmittance floor of the reconstruction (optical depth 69). An f32 α
/// resolves depths up to 16.6 only (1 − α ≥ 2⁻²⁴ below 1); an entry with
/// α = 1 is usually far deeper, and counting it as 69 makes a lookup between
/// it and a depth-τ entry at weight w give 1 − e^{−(1−w)τ−69w}: opaque
/// within 1e-3 from w = 0.1, as the true depths would. (Counting it as 16.6
/// instead leaves 2.4e-4 of transmittance half way between two opaque
/// slices; neither choice moves the four bundles' errors.)
const MIN_TRANSMITTANCE: f32 = 1e-30;

/// Below this α (and optical depth) the reconstruction uses series: 1 − α
/// in f32 drops α's low bits (all of them below 6e-8), which would zero a
/// faint entry's depth and, through the colour scale, its colour.
const SERIES_BELOW: f32 = 1.0 / 64.0;

/// −ln(max(1 − α, [`MIN_TRANSMITTANCE`])) lane by lane: the optical depth
/// of an entry, as the lookup interpolates it; α + α²/2 + α³/3 + α⁴/4
/// below [`SERIES_BELOW`] (relative error < 2e-9).
#[inline(always)]
pub(super) fn optical_depths(alpha: f32x8) -> f32x8 {
    let log = -vmax(f32x8::ONE - alpha, f32x8::splat(MIN_TRANSMITTANCE)).ln();
    let (half, third, quarter) = (f32x8::splat(0.5), f32x8::splat(1.0 / 3.0), f32x8::splat(0.25));
    let series = alpha * (f32x8::ONE + alpha * (half + alpha * (third + alpha * quarter)));
    alpha.cmp_lt(f32x8::splat(SERIES_BELOW)).blend(series, log)
}

/// 1 − e^{−τ} for τ ≥ 0, by its series below [`SERIES_BELOW`] (relative
/// error < 2e-9), so a faint lookup keeps its α to f32 precision.
#[inline(always)]
pub(crate) fn alpha_of_depth(tau: f32) -> f32 {
    if tau < SERIES_BELOW {
        tau * (1.0 - tau * (0.5 - tau * (1.0 / 6.0 - tau * (1.0 / 24.0))))
    } else {
        1.0 - (-tau).exp()
    }
}

/// A lookup from the 8 entries around it: `e[c]` holds corner c's entries
/// at slices k0 and k0 + 1 (RGBA, RGBA) and `depth[c]` their
/// [`optical_depths`], corners in the order (a0, b0), (a0, b0 + 1),
/// (a0 + 1, b0), (a0 + 1, b0 + 1); `fa`, `fb`, `fk` are the fractions
/// along Sf, Sb and l.
///
/// The optical depth −ln(1 − α) is interpolated trilinearly, not α: for
/// one (Sf, Sb) it is linear in l (l times the mean extinction), and across
/// (Sf, Sb) it stays smooth where α saturates, so l adds no error to α and
/// long segments through dense cells lose most of theirs (the stars'
/// Delaunay mesh: cell-segment max error 1.3e-2 → 4.4e-4, 128×128×256).
/// The colour is the trilinear colour scaled by α over the trilinear α: it
/// keeps the trilinear chromaticity, is exact in l where the colour is
/// constant (C = κ·α with density emission, C = κ·α/ρ with independent
/// emission), and keeps C ≤ α·max κ. Every lookup path reconstructs here
/// from the same depths, so they agree bit for bit.
#[inline(always)]
fn reconstruct(e: &[[f32; 8]; 4], depth: &[[f32; 2]; 4], fa: f32, fb: f32, fk: f32) -> Rgba32 {
    let (wa0, wa1, wb0, wb1) = (1.0 - fa, fa, 1.0 - fb, fb);
    let w = [wa0 * wb0, wa0 * wb1, wa1 * wb0, wa1 * wb1];
    let lerp_l = |c: &[f32; 8]| -> Vec4 {
        let (e0, e1) = (Vec4::new(c[0], c[1], c[2], c[3]), Vec4::new(c[4], c[5], c[6], c[7]));
        e0 + (e1 - e0) * fk
    };
    let lin = lerp_l(&e[0]) * w[0] + lerp_l(&e[1]) * w[1] + lerp_l(&e[2]) * w[2] + lerp_l(&e[3]) * w[3];
    let lerp_d = |d: &[f32; 2]| d[0] + (d[1] - d[0]) * fk;
    let tau = lerp_d(&depth[0]) * w[0] + lerp_d(&depth[1]) * w[1] + lerp_d(&depth[2]) * w[2] + lerp_d(&depth[3]) * w[3];
    let a = alpha_of_depth(tau.max(0.0));
    // lin.w = 0 only where every weighted α is 0, and then a = 0 too: the
    // colour stays (independent emission glows without absorbing).
    let scale = if lin.w > 0.0 { a / lin.w } else { 1.0 };
    [lin.x * scale, lin.y * scale, lin.z * scale, a]
}

/// A lookup's lower grid corner and fractional position in its cell.
#[derive(Debug, Clone, Copy, Default)]
struct Cell {
    a0: usize,
    b0: usize,
    k0: usize,
    fa: f32,
    fb: f32,
    fk: f32,
}

/// Segments whose cells [`SegmentShader::shade_span`] locates before
/// reading any entry.
const SPAN_BLOCK: usize = 64;

impl SegmentShader for Table3d {
    fn method(&self) -> Method {
        Method::Table3d
    }
    fn shade(&self, seg: &Segment) -> Rgba32 {
        self.lookup(seg.s_front, seg.s_back, seg.len_world)
    }
    /// Eight segments at a time: the cells are located with the same values
    /// as [`Table3d::cell_of`] by lane-wise arithmetic that vectorizes (only
    /// the non-uniform axis's bucket reads and the entries are per lane).
    /// Where the CPU has AVX2 and F16C ([`LookupKernel::Auto`]), the
    /// `simd_x86` kernel does it instead, on every storage, with the same
    /// values bit for bit (for optical-depth tables it locates the cells
    /// and the gather below finishes).
    fn shade_batch(&self, segs: &SegmentBatch, out: &mut [Rgba32; method::BATCH]) {
        if self.shade_batch_lean(segs, out) {
            return;
        }
        let n = segs.len.min(method::BATCH);
        let Some(d) = self.data.as_f32() else {
            for (i, o) in out.iter_mut().enumerate().take(n) {
                *o = self.lookup(segs.s_front[i], segs.s_back[i], segs.len_world[i]);
            }
            return;
        };
        // Two passes: locate every cell (lane-wise arithmetic), then gather
        // (a short loop of independent reads whose cache misses overlap).
        let mut cells = [Cell::default(); method::BATCH];
        let (top_s, top_l) = (f32x8::splat((self.params.n_s - 2) as f32), f32x8::splat((self.params.n_l - 2) as f32));
        let (inv_dl, xk_max) = (f32x8::splat(self.inv_dl), f32x8::splat((self.params.n_l - 1) as f32));
        for blk in (0..n).step_by(W) {
            let m = (n - blk).min(W);
            let lanes = |a: &[f32; method::BATCH]| -> f32x8 {
                let v: [f32; W] = a[blk..blk + W].try_into().expect("BATCH is a multiple of W");
                f32x8::from(v)
            };
            let (xa, xb) = self.band_coords_lanes(lanes(&segs.s_front), lanes(&segs.s_back), m);
            let len = no_nan(lanes(&segs.len_world), f32x8::ZERO);
            let xk = vmin(vmax(len * inv_dl, f32x8::ZERO), xk_max);
            // Cell corner min(⌊x⌋, n − 2) (x ≥ 0: truncation of the clamped value) and fraction.
            let (a0, b0, k0) =
                (vmin(xa, top_s).fast_trunc_int(), vmin(xb, top_s).fast_trunc_int(), vmin(xk, top_l).fast_trunc_int());
            let fa = (xa - f32x8::from_i32x8(a0)).to_array();
            let fb = (xb - f32x8::from_i32x8(b0)).to_array();
            let fk = (xk - f32x8::from_i32x8(k0)).to_array();
            let (a0, b0, k0) = (a0.to_array(), b0.to_array(), k0.to_array());
            for l in 0..m {
                cells[blk + l] = Cell {
                    a0: a0[l] as usize,
                    b0: b0[l] as usize,
                    k0: k0[l] as usize,
                    fa: fa[l],
                    fb: fb[l],
                    fk: fk[l],
                };
            }
        }
        for (c, o) in cells[..n].iter().zip(out.iter_mut()) {
            *o = self.gather_f32(d, c);
        }
    }

    fn shade_span(&self, segs: &[Segment], out: &mut [Rgba32]) {
        let mut done = 0;
        if self.lookup_kernel_in_use() == "avx2" {
            // Through the batched kernel, BATCH segments at a time (the same
            // values: every path is bit-identical to `lookup`).
            let mut batch = SegmentBatch::default();
            let mut rgba = [[0.0f32; 4]; method::BATCH];
            for (sb, ob) in segs.chunks(method::BATCH).zip(out.chunks_mut(method::BATCH)) {
                for (i, seg) in sb.iter().enumerate() {
                    (batch.s_front[i], batch.s_back[i], batch.len_world[i]) = (seg.s_front, seg.s_back, seg.len_world);
                }
                batch.len = sb.len();
                if !self.shade_batch_lean(&batch, &mut rgba) {
                    break;
                }
                let k = ob.len().min(sb.len());
                ob[..k].copy_from_slice(&rgba[..k]);
                done += k;
            }
        }
        let (segs, out) = (&segs[done.min(segs.len())..], &mut out[done..]);
        match self.data.as_f32() {
            Some(d) => {
                // Two passes per block: locating a cell is arithmetic (and,
                // on a non-uniform axis, a bucket lookup and a rare search);
                // the entries are cache misses. Kept apart, the second loop
                // is short enough that the CPU overlaps many segments'
                // misses, whatever the axis (one loop: 91 ns per segment on
                // the TF-node axis against 42 on the uniform, on Blunt Fin).
                let mut cells = [Cell::default(); SPAN_BLOCK];
                for (sb, ob) in segs.chunks(SPAN_BLOCK).zip(out.chunks_mut(SPAN_BLOCK)) {
                    for (seg, c) in sb.iter().zip(cells.iter_mut()) {
                        *c = self.cell_of(seg.s_front, seg.s_back, seg.len_world);
                    }
                    for (c, o) in cells.iter().zip(ob.iter_mut()) {
                        *o = self.gather_f32(d, c);
                    }
                }
            }
            None => {
                for (seg, o) in segs.iter().zip(out.iter_mut()) {
                    *o = self.lookup(seg.s_front, seg.s_back, seg.len_world);
                }
            }
        }
    }
}
