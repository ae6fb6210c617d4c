//! The crate's only `unsafe` code: the AVX2 (+F16C) kernel of
//! [`Table3d`]'s batched lookup ([`SegmentShader::shade_batch`], and
//! `shade_span` through it), chosen at run time.
//!
//! What it computes is what the portable path (`Table3d::shade_batch`,
//! `Table3d::lookup`) computes, operation for operation, so the results are
//! **bit-identical**, not merely close: the index arithmetic (clamps, the
//! non-uniform axis's bucket map `x0 + (s − s0)·inv`, the cell split) and
//! the trilinear sum — per slice k ∈ {k0, k0 + 1}, `((p₀ + p₁) + p₂) + p₃`
//! with p_c = e_c,k·(w_c·g_k), g = (1 − fk, fk), then the two slices added —
//! are the same IEEE single-precision operations in the same order, done
//! eight lanes or one row of two entries at a time. No FMA is used: fusing the
//! multiply-adds would round differently (by ~1e-7) and break the contract
//! that every lookup path of a table — `shade`, `shade_span`, `shade_batch`,
//! the rasterizer's fast and per-tile paths — gives the same image bit for
//! bit (crates/tet_preint/results/lookup.md has what FMA would save).
//!
//! Per block of eight segments: the cells are located in 8 lanes (AVX2
//! gathers for the non-uniform axis's buckets, a second bucket step for
//! buckets that hold several knots, and the band's row offsets; a front
//! scalar equal to the previous segment's back one, as along a ray, reuses
//! its grid index), then each
//! segment loads its 4 (Sf, Sb) corners' two l-neighbours (one 32-byte row
//! each: 8 f32, or 8 f16 / unorm16 / unorm8 values decoded by F16C or
//! integer widening and the storage's factors) and interpolates.
//! Optical-depth tables ([`Reconstruction::OpticalDepth`]) take only the
//! cells from here ([`cells`]); their entries, depths, `exp` and colour
//! scale are the portable code's (`Table3d::gather`), so they too agree bit
//! for bit. (Finishing them per segment after this kernel's loads, through
//! a callback, measured slower than the portable path.)
//!
//! Selection: [`available`] checks the CPU once (`is_x86_feature_detected!`
//! for AVX2 and F16C, cached in a `OnceLock`) and honours the environment
//! variable `TET_PREINT_LOOKUP=portable`, which forces the portable path
//! process-wide (CI machines with AVX2 can run the whole suite on both
//! paths); `Table3d::set_lookup_kernel` forces it per table.
//!
//! [`Table3d`]: crate::Table3d
//! [`SegmentShader::shade_batch`]: crate::SegmentShader::shade_batch
//! [`Reconstruction::OpticalDepth`]: crate::Reconstruction::OpticalDepth
#![deny(unsafe_op_in_unsafe_fn)]

use crate::method::{Rgba32, SegmentBatch, BATCH};
use crate::precision::RawData;
use std::arch::x86_64::*;
use std::sync::OnceLock;

/// Environment variable that, set to `portable`, keeps every table on the
/// portable lookup.
pub const LOOKUP_ENV: &str = "TET_PREINT_LOOKUP";

/// Whether the kernel may run: the CPU has AVX2 and F16C, and
/// [`LOOKUP_ENV`] does not ask for the portable path. Decided once per
/// process.
pub fn available() -> bool {
    static AVAILABLE: OnceLock<bool> = OnceLock::new();
    *AVAILABLE.get_or_init(|| {
        let forced = std::env::var(LOOKUP_ENV).is_ok_and(|v| v.eq_ignore_ascii_case("portable"));
        !forced && is_x86_feature_detected!("avx2") && is_x86_feature_detected!("f16c")
    })
}

/// What the kernel reads of a table: its scalar axis, band and entries, as
/// `Table3d::band_coords_lanes` and `Table3d::cell_of` use them.
pub(crate) struct Lean<'a> {
    /// Uniform axis: `lo` = s_lo, `inv_ds` and the band's `reach` (grid
    /// steps). Otherwise `lo`, `hi`, `max_ds` and the buckets.
    pub uniform: bool,
    pub lo: f32,
    pub hi: f32,
    pub inv_ds: f32,
    pub reach: f32,
    pub max_ds: f32,
    /// Per bucket (s0, x0, 1/step, next knot) and its knot interval's
    /// index; buckets per scalar unit.
    pub bucket: &'a [[f32; 4]],
    pub bucket_j: &'a [i32],
    /// Per bucket, the next interval's (s0, x0, 1/step, last scalar).
    pub bucket2: &'a [[f32; 4]],
    pub bucket_inv: f32,
    /// Per knot interval: first and last scalar, first index, 1/step.
    pub seg_s0: &'a [f32],
    pub seg_s1: &'a [f32],
    pub seg_x0: &'a [f32],
    pub seg_inv: &'a [f32],
    pub n_s: usize,
    pub n_l: usize,
    pub inv_dl: f32,
    /// The band's `pair_off` as i32 (wrapping values stay wrapped).
    pub pair_off: &'a [i32],
    pub data: RawData<'a>,
    /// Optical-depth tables on f32 storage: each entry's optical depth
    /// (empty otherwise).
    pub depth: &'a [f32],
}

/// Cells of a batch (`Table3d::cell_of`'s values, lane by lane): lower
/// corner (a0, b0, k0), each in [0, n − 2], and fractions.
pub(crate) struct Cells {
    pub a0: [i32; BATCH],
    pub b0: [i32; BATCH],
    pub k0: [i32; BATCH],
    pub fa: [f32; BATCH],
    pub fb: [f32; BATCH],
    pub fk: [f32; BATCH],
}

impl Default for Cells {
    fn default() -> Self {
        Cells { a0: [0; BATCH], b0: [0; BATCH], k0: [0; BATCH], fa: [0.0; BATCH], fb: [0.0; BATCH], fk: [0.0; BATCH] }
    }
}

/// Storage kinds (the kernel's const parameter).
const F32: u8 = 0;
const F16: u8 = 1;
const U16: u8 = 2;
const U8: u8 = 3;

/// Shades `segs` into `out` as `Table3d::shade_batch` does with the
/// trilinear reconstruction and returns `true`; returns `false` without
/// writing when the kernel cannot run (no AVX2/F16C, or a table whose
/// offsets do not fit in i32 lanes).
pub(crate) fn shade_batch(t: &Lean<'_>, segs: &SegmentBatch, out: &mut [Rgba32; BATCH]) -> bool {
    run(t, segs, Out::Rgba(out))
}

/// Shades `segs` into `out` as `Table3d::shade_batch` does with the
/// optical-depth reconstruction on f32 storage (`Table3d::gather`'s
/// `reconstruct`) and returns `true`; `false` without writing where the
/// kernel cannot run (as [`shade_batch`], or depths that are not one per
/// entry).
pub(crate) fn shade_batch_depth(t: &Lean<'_>, segs: &SegmentBatch, out: &mut [Rgba32; BATCH]) -> bool {
    match t.data {
        RawData::F32(d) if t.depth.len() * 4 == d.len() => run(t, segs, Out::Depth(out)),
        _ => false,
    }
}

/// Locates the cells of `segs` into `cells` (lanes below `segs.len`) as
/// `Table3d::cell_of` does; `false` (nothing written) as [`shade_batch`].
pub(crate) fn cells(t: &Lean<'_>, segs: &SegmentBatch, cells: &mut Cells) -> bool {
    run(t, segs, Out::Cells(cells))
}

/// What the kernel writes.
enum Out<'a> {
    Rgba(&'a mut [Rgba32; BATCH]),
    /// The optical-depth reconstruction (f32 storage).
    Depth(&'a mut [Rgba32; BATCH]),
    Cells(&'a mut Cells),
}

fn run(t: &Lean<'_>, segs: &SegmentBatch, out: Out<'_>) -> bool {
    if !available() {
        return false;
    }
    let (len, ptr): (usize, *const u8) = match t.data {
        RawData::F32(d) => (d.len(), d.as_ptr().cast()),
        RawData::F16(d) | RawData::Unorm16(d, _) => (d.len(), d.as_ptr().cast()),
        RawData::Unorm8(d, _) => (d.len(), d.as_ptr()),
    };
    let factors = match t.data {
        RawData::Unorm16(_, f) | RawData::Unorm8(_, f) => f,
        _ => [1.0; 4],
    };
    // The bounds every unsafe read below relies on (checked here, once per
    // call, not trusted from the table's construction): offsets and the
    // lane arithmetic fit in i32, the two l-rows of a corner pair fit in
    // the data, the band has a row offset per scalar index, the buckets
    // exist.
    let nl4 = t.n_l * 4;
    let fits = len <= i32::MAX as usize
        && t.n_s >= 2
        && t.n_l >= 2
        && t.n_s <= 1 << 20
        && t.n_l <= 1 << 20
        && len >= nl4 + 8
        && t.pair_off.len() >= t.n_s
        && (t.uniform || {
            let nseg = t.seg_s0.len();
            !t.bucket.is_empty()
                && t.bucket.len() <= 1 << 24
                && t.bucket_j.len() == t.bucket.len()
                && t.bucket2.len() == t.bucket.len()
                && (1..=1 << 24).contains(&nseg)
                && [t.seg_s1.len(), t.seg_x0.len(), t.seg_inv.len()] == [nseg; 3]
        });
    if !fits {
        return false;
    }
    let g = Geometry { nl4, max_base: (len - nl4 - 8) as i32, ptr, factors };
    let kind = match t.data {
        RawData::F32(_) => F32,
        RawData::F16(_) => F16,
        RawData::Unorm16(..) => U16,
        RawData::Unorm8(..) => U8,
    };
    // SAFETY: `available()` checked that the CPU has AVX2 and F16C, the
    // kernel's target features; `g` describes `t.data` (pointer, length
    // bound `max_base` checked just above), which outlives the call.
    // (`Out::Depth` only comes with f32 storage and one depth an entry,
    // checked by `shade_batch_depth`: the rows' bound bounds the depths.)
    unsafe {
        match (kind, out) {
            (_, Out::Cells(c)) => kernel::<F32, true, false>(t, &g, segs, None, Some(c)),
            (_, Out::Depth(o)) => kernel::<F32, false, true>(t, &g, segs, Some(o), None),
            (F32, Out::Rgba(o)) => kernel::<F32, false, false>(t, &g, segs, Some(o), None),
            (F16, Out::Rgba(o)) => kernel::<F16, false, false>(t, &g, segs, Some(o), None),
            (U16, Out::Rgba(o)) => kernel::<U16, false, false>(t, &g, segs, Some(o), None),
            (_, Out::Rgba(o)) => kernel::<U8, false, false>(t, &g, segs, Some(o), None),
        }
    }
    true
}

/// The entries' address and the largest float offset a lookup's first
/// corner row may start at (`len − n_l·4 − 8`: its second row, n_l entries
/// on, then ends inside the data).
struct Geometry {
    nl4: usize,
    max_base: i32,
    ptr: *const u8,
    factors: [f32; 4],
}

/// Eight consecutive stored values from value offset `off`, decoded to f32
/// as `Storage::get` decodes them (f16 → f32 and u16/u8 → f32 are exact;
/// unorm values are then multiplied by the same f32 factor).
///
/// # Safety
/// AVX2 and F16C must be available, and values `off..off + 8` must lie in
/// the storage `g.ptr` points to, of kind `S`.
#[target_feature(enable = "avx2,f16c")]
#[inline]
unsafe fn row<const S: u8>(g: &Geometry, off: usize) -> __m256 {
    // SAFETY (every arm): the caller guarantees values off..off + 8 are in
    // the data, and each arm reads exactly 8 values of its width there;
    // unaligned loads.
    match S {
        F32 => unsafe { _mm256_loadu_ps(g.ptr.cast::<f32>().add(off)) },
        F16 => unsafe { _mm256_cvtph_ps(_mm_loadu_si128(g.ptr.cast::<u16>().add(off).cast())) },
        U16 => {
            let v = unsafe { _mm_loadu_si128(g.ptr.cast::<u16>().add(off).cast()) };
            let f = _mm256_cvtepi32_ps(_mm256_cvtepu16_epi32(v));
            _mm256_mul_ps(f, factors8(g))
        }
        _ => {
            let v = unsafe { _mm_loadl_epi64(g.ptr.add(off).cast()) };
            let f = _mm256_cvtepi32_ps(_mm256_cvtepu8_epi32(v));
            _mm256_mul_ps(f, factors8(g))
        }
    }
}

/// The unorm factors of an entry's channels, for two entries.
#[target_feature(enable = "avx2")]
#[inline]
fn factors8(g: &Geometry) -> __m256 {
    let [r, gr, b, a] = g.factors;
    _mm256_setr_ps(r, gr, b, a, r, gr, b, a)
}

/// `v` with NaN lanes replaced by `fill` (`simd::no_nan`).
#[target_feature(enable = "avx2")]
#[inline]
fn no_nan(v: __m256, fill: __m256) -> __m256 {
    _mm256_blendv_ps(fill, v, _mm256_cmp_ps::<_CMP_EQ_OQ>(v, v))
}

/// min(max(v, lo), hi) with `maxps`/`minps` in the portable path's operand
/// order (`simd::vmax`, `simd::vmin`).
#[target_feature(enable = "avx2")]
#[inline]
fn clamp(v: __m256, lo: __m256, hi: __m256) -> __m256 {
    _mm256_min_ps(_mm256_max_ps(v, lo), hi)
}

/// Integer lanes clamped to [lo, hi].
#[target_feature(enable = "avx2")]
#[inline]
fn clamp_i(v: __m256i, lo: i32, hi: i32) -> __m256i {
    _mm256_min_epi32(_mm256_max_epi32(v, _mm256_set1_epi32(lo)), _mm256_set1_epi32(hi))
}

/// One block of the optical-depth reconstruction (`Table3d::gather`'s
/// `reconstruct`, operation for operation): per lane the trilinear colour
/// `lin` (each corner's l-lerp e₀ + (e₁ − e₀)·fk weighted, summed
/// ((p₀ + p₁) + p₂) + p₃, two corners a vector), the optical depth τ the
/// same way from the entries' depths, α = 1 − e^−max(τ, 0) and the colour
/// scaled by α / lin.α. `base`: the kernel's row offsets of the block's
/// corner pairs.
///
/// # Safety
/// AVX2 and F16C must be available; `g` must describe `t.data` (f32) as
/// for [`kernel`], `t.depth` must hold one value per entry, and `base`
/// (lanes below `m`) must be the kernel's (clamped to `g.max_base`).
#[target_feature(enable = "avx2,f16c")]
unsafe fn depth_block<const S: u8>(
    t: &Lean<'_>,
    g: &Geometry,
    (blk, m): (usize, usize),
    base: &[[i32; 8]; 2],
    frac: [__m256; 3],
    out: &mut [Rgba32; BATCH],
) {
    let (mut w, mut fk) = ([[0.0f32; 8]; 4], [0.0f32; 8]);
    let one = _mm256_set1_ps(1.0);
    let [fa, fb, fkv] = frac;
    let (wa0, wb0) = (_mm256_sub_ps(one, fa), _mm256_sub_ps(one, fb));
    // SAFETY: 8-lane stores into local arrays of 8 values.
    unsafe {
        _mm256_storeu_ps(w[0].as_mut_ptr(), _mm256_mul_ps(wa0, wb0));
        _mm256_storeu_ps(w[1].as_mut_ptr(), _mm256_mul_ps(wa0, fb));
        _mm256_storeu_ps(w[2].as_mut_ptr(), _mm256_mul_ps(fa, wb0));
        _mm256_storeu_ps(w[3].as_mut_ptr(), _mm256_mul_ps(fa, fb));
        _mm256_storeu_ps(fk.as_mut_ptr(), fkv);
    }
    for l in 0..m {
        let (o0, o1) = (base[0][l] as usize, base[1][l] as usize);
        let bases = [o0, o0 + g.nl4, o1, o1 + g.nl4];
        // SAFETY: each row reads values bases[c]..bases[c] + 8, within the
        // data (the clamp to max_base); AVX2/F16C as required.
        let v = unsafe { [row::<S>(g, bases[0]), row::<S>(g, bases[1]), row::<S>(g, bases[2]), row::<S>(g, bases[3])] };
        let fkl = fk[l];
        let fk8 = _mm256_set1_ps(fkl);
        let lerp = |x: __m256, y: __m256| {
            let e0 = _mm256_permute2f128_ps::<0x20>(x, y);
            let e1 = _mm256_permute2f128_ps::<0x31>(x, y);
            _mm256_add_ps(e0, _mm256_mul_ps(_mm256_sub_ps(e1, e0), fk8))
        };
        let wl = [w[0][l], w[1][l], w[2][l], w[3][l]];
        let w01 = _mm256_set_m128(_mm_set1_ps(wl[1]), _mm_set1_ps(wl[0]));
        let w23 = _mm256_set_m128(_mm_set1_ps(wl[3]), _mm_set1_ps(wl[2]));
        let p01 = _mm256_mul_ps(lerp(v[0], v[1]), w01);
        let p23 = _mm256_mul_ps(lerp(v[2], v[3]), w23);
        let lin = _mm_add_ps(_mm256_castps256_ps128(p01), _mm256_extractf128_ps::<1>(p01));
        let lin = _mm_add_ps(lin, _mm256_castps256_ps128(p23));
        let lin = _mm_add_ps(lin, _mm256_extractf128_ps::<1>(p23));
        let mut lin4 = [0.0f32; 4];
        // SAFETY: a 4-float store into a local [f32; 4].
        unsafe { _mm_storeu_ps(lin4.as_mut_ptr(), lin) };
        // The depths of the same 8 entries: entry b/4 and b/4 + 1 of each row.
        let d = |b: usize| {
            // SAFETY: b/4 + 1 < data.len()/4 = depth.len() (the row bound).
            unsafe { (*t.depth.get_unchecked(b / 4), *t.depth.get_unchecked(b / 4 + 1)) }
        };
        let lerp_d = |(d0, d1): (f32, f32)| d0 + (d1 - d0) * fkl;
        let tau = lerp_d(d(bases[0])) * wl[0]
            + lerp_d(d(bases[1])) * wl[1]
            + lerp_d(d(bases[2])) * wl[2]
            + lerp_d(d(bases[3])) * wl[3];
        let a = crate::table3d::alpha_of_depth(tau.max(0.0));
        let scale = if lin4[3] > 0.0 { a / lin4[3] } else { 1.0 };
        out[blk + l] = [lin4[0] * scale, lin4[1] * scale, lin4[2] * scale, a];
    }
}

/// The 8 × 8 transpose: lane l of vector j becomes lane j of vector l.
#[target_feature(enable = "avx2")]
#[inline]
fn transpose8(v: [__m256; 8]) -> [__m256; 8] {
    let t: [__m256; 8] = std::array::from_fn(|k| {
        let (a, b) = (v[2 * (k / 2)], v[2 * (k / 2) + 1]);
        if k % 2 == 0 {
            _mm256_unpacklo_ps(a, b)
        } else {
            _mm256_unpackhi_ps(a, b)
        }
    });
    // (t0 = v0v1 lo, t1 = v0v1 hi, t2 = v2v3 lo, t3 = v2v3 hi, …)
    let u: [__m256; 8] = [
        _mm256_shuffle_ps::<0x44>(t[0], t[2]),
        _mm256_shuffle_ps::<0xee>(t[0], t[2]),
        _mm256_shuffle_ps::<0x44>(t[1], t[3]),
        _mm256_shuffle_ps::<0xee>(t[1], t[3]),
        _mm256_shuffle_ps::<0x44>(t[4], t[6]),
        _mm256_shuffle_ps::<0xee>(t[4], t[6]),
        _mm256_shuffle_ps::<0x44>(t[5], t[7]),
        _mm256_shuffle_ps::<0xee>(t[5], t[7]),
    ];
    [
        _mm256_permute2f128_ps::<0x20>(u[0], u[4]),
        _mm256_permute2f128_ps::<0x20>(u[1], u[5]),
        _mm256_permute2f128_ps::<0x20>(u[2], u[6]),
        _mm256_permute2f128_ps::<0x20>(u[3], u[7]),
        _mm256_permute2f128_ps::<0x31>(u[0], u[4]),
        _mm256_permute2f128_ps::<0x31>(u[1], u[5]),
        _mm256_permute2f128_ps::<0x31>(u[2], u[6]),
        _mm256_permute2f128_ps::<0x31>(u[3], u[7]),
    ]
}

/// The batched lookup (see [`shade_batch`]): with `CELLS`, the cells into
/// `cells` only; otherwise the trilinear lookups into `out`.
///
/// # Safety
/// AVX2 and F16C must be available; `g` must describe `t.data` (pointer
/// and `max_base = len − n_l·4 − 8 ≥ 0`), `t.pair_off` must hold at least
/// `t.n_s ≥ 2` values, and a non-uniform axis at least one bucket, a
/// `bucket_j` per bucket and nseg ≥ 1 values in each `seg_*` array.
#[target_feature(enable = "avx2,f16c")]
unsafe fn kernel<const S: u8, const CELLS: bool, const DEPTH: bool>(
    t: &Lean<'_>,
    g: &Geometry,
    segs: &SegmentBatch,
    mut out: Option<&mut [Rgba32; BATCH]>,
    mut cells: Option<&mut Cells>,
) {
    let n = segs.len.min(BATCH);
    // `Axis::x_of_lanes` (and `Axis::x_of` for every lane): fractional grid
    // indices of eight scalars already clamped to [lo, hi]. (A closure, so
    // that it inlines here.)
    let x_of_lanes = |s: __m256, valid: i32| -> __m256 {
        let nb = t.bucket.len() as i32 - 1;
        let last = t.seg_s0.len() as i32 - 1;
        let lo = _mm256_set1_ps(t.lo);
        let scaled =
            _mm256_min_ps(_mm256_mul_ps(_mm256_sub_ps(s, lo), _mm256_set1_ps(t.bucket_inv)), _mm256_set1_ps(nb as f32));
        // The portable path truncates the same clamped value; the integer
        // clamp only matters for values it would index out of range with
        // (a NaN or −∞ product truncates to i32::MIN), never trusted here.
        let b = clamp_i(_mm256_cvttps_epi32(scaled), 0, nb);
        let mut bi = [0i32; 8];
        // SAFETY: 8-lane store into a local [i32; 8].
        unsafe { _mm256_storeu_si256(bi.as_mut_ptr().cast(), b) };
        // Each lane's 16-byte bucket row, transposed into four 8-lane
        // vectors (cheaper than four 8-lane gathers of one field each).
        let rows = |rows: &[[f32; 4]]| {
            // SAFETY: every bi[l] is in [0, nb] (clamped above) and `rows`
            // has nb + 1 rows (`t.bucket`, or `t.bucket2` of the same
            // length, checked by `run`): 4-float loads inside row bi[l].
            let r = |l: usize| unsafe { _mm_loadu_ps(rows.as_ptr().add(bi[l] as usize).cast()) };
            let (t0, t1) = (_mm256_set_m128(r(4), r(0)), _mm256_set_m128(r(5), r(1)));
            let (t2, t3) = (_mm256_set_m128(r(6), r(2)), _mm256_set_m128(r(7), r(3)));
            let (u0, u1) = (_mm256_castps_pd(_mm256_unpacklo_ps(t0, t1)), _mm256_castps_pd(_mm256_unpackhi_ps(t0, t1)));
            let (u2, u3) = (_mm256_castps_pd(_mm256_unpacklo_ps(t2, t3)), _mm256_castps_pd(_mm256_unpackhi_ps(t2, t3)));
            (
                _mm256_castpd_ps(_mm256_unpacklo_pd(u0, u2)),
                _mm256_castpd_ps(_mm256_unpackhi_pd(u0, u2)),
                _mm256_castpd_ps(_mm256_unpacklo_pd(u1, u3)),
                _mm256_castpd_ps(_mm256_unpackhi_pd(u1, u3)),
            )
        };
        let (s0, x0, inv, next) = rows(t.bucket);
        let x = _mm256_add_ps(x0, _mm256_mul_ps(_mm256_sub_ps(s, s0), inv));
        let slow = _mm256_cmp_ps::<_CMP_GT_OQ>(s, next);
        if _mm256_movemask_ps(slow) & valid == 0 {
            return clamp(x, _mm256_setzero_ps(), _mm256_set1_ps((t.n_s - 1) as f32));
        }
        // Past the bucket's next knot (a bucket holding several knots: a
        // fifth of the lookups on Blunt Fin's data axis), `Axis::x_of` takes
        // the first interval j < nseg − 1 with s ≤ seg_s1[j], or the last
        // (`partition_point`). Every interval up to the bucket's ends below
        // s, so that is the bucket's next interval where s ≤ its last
        // scalar (`bucket2`), and otherwise the first found by stepping on
        // from there while s > seg_s1[j]; the line of interval j is then
        // the same arithmetic.
        let (s0, x0, inv, end) = rows(t.bucket2);
        let x2 = _mm256_add_ps(x0, _mm256_mul_ps(_mm256_sub_ps(s, s0), inv));
        let x = _mm256_blendv_ps(x, x2, slow);
        let slow2 = _mm256_and_ps(slow, _mm256_cmp_ps::<_CMP_GT_OQ>(s, end));
        let x = if _mm256_movemask_ps(slow2) & valid == 0 {
            x
        } else {
            // SAFETY: b is in [0, nb] as above, an index of `t.bucket_j`.
            let jb = unsafe { _mm256_i32gather_epi32::<4>(t.bucket_j.as_ptr(), b) };
            let mut j = clamp_i(_mm256_add_epi32(jb, _mm256_set1_epi32(2)), 0, last);
            let limit = _mm256_set1_epi32(last);
            loop {
                // SAFETY: every lane of j is in [0, last], an index of the
                // seg arrays (nseg = last + 1 values each, checked by `run`).
                let s1 = unsafe { _mm256_i32gather_ps::<4>(t.seg_s1.as_ptr(), j) };
                let below_last = _mm256_cmpgt_epi32(limit, j);
                let step = _mm256_and_si256(_mm256_castps_si256(_mm256_cmp_ps::<_CMP_GT_OQ>(s, s1)), below_last);
                if _mm256_movemask_ps(_mm256_castsi256_ps(step)) == 0 {
                    break;
                }
                // step lanes are all ones (−1): j − (−1) = j + 1 ≤ last.
                j = _mm256_sub_epi32(j, step);
            }
            // SAFETY: j in [0, last] as in the loop.
            let (s0j, x0j, invj) = unsafe {
                (
                    _mm256_i32gather_ps::<4>(t.seg_s0.as_ptr(), j),
                    _mm256_i32gather_ps::<4>(t.seg_x0.as_ptr(), j),
                    _mm256_i32gather_ps::<4>(t.seg_inv.as_ptr(), j),
                )
            };
            let xj = _mm256_add_ps(x0j, _mm256_mul_ps(_mm256_sub_ps(s, s0j), invj));
            _mm256_blendv_ps(x, xj, slow2)
        };
        clamp(x, _mm256_setzero_ps(), _mm256_set1_ps((t.n_s - 1) as f32))
    };
    let zero = _mm256_setzero_ps();
    let top = _mm256_set1_ps((t.n_s - 1) as f32);
    let (top_s, top_l) = (_mm256_set1_ps((t.n_s - 2) as f32), _mm256_set1_ps((t.n_l - 2) as f32));
    let (inv_dl, xk_max) = (_mm256_set1_ps(t.inv_dl), _mm256_set1_ps((t.n_l - 1) as f32));
    let (lo, hi) = (_mm256_set1_ps(t.lo), _mm256_set1_ps(t.hi));
    let nl = _mm256_set1_epi32(t.n_l as i32);
    let po = t.pair_off.as_ptr();
    let one = _mm256_set1_ps(1.0);
    let mut base = [[0i32; 8]; 2];
    // Corner c's two weights, each spread over 4 lanes.
    let pair_idx: [__m256i; 4] = std::array::from_fn(|c| {
        let (a, b) = (2 * c as i32, 2 * c as i32 + 1);
        _mm256_setr_epi32(a, a, a, a, b, b, b, b)
    });
    // The previous block's last clamped back scalar and its grid index
    // (non-uniform axis): a ray's segments follow each other, so segment
    // i's front scalar is usually segment i − 1's back one, bit for bit,
    // and its grid index is already known (`x_of_lanes` is a function of
    // each lane's scalar alone): a block whose every front scalar is its
    // predecessor's back one maps only the back scalars. NaN at first:
    // its bits are no clamped scalar's.
    let (mut prev_sb, mut prev_xb) = (_mm256_set1_ps(f32::NAN), _mm256_setzero_ps());
    // Lane i takes lane i − 1; lane 0 the previous block's lane 7.
    let shift = _mm256_setr_epi32(7, 0, 1, 2, 3, 4, 5, 6);
    for blk in (0..n).step_by(8) {
        let m = (n - blk).min(8);
        let valid = (1i32 << m) - 1;
        // SAFETY: blk ≤ 56 (n ≤ BATCH = 64, blk a multiple of 8 below n),
        // so floats blk..blk + 8 lie in each [f32; BATCH] array.
        let (sf, sb, len) = unsafe {
            (
                _mm256_loadu_ps(segs.s_front.as_ptr().add(blk)),
                _mm256_loadu_ps(segs.s_back.as_ptr().add(blk)),
                _mm256_loadu_ps(segs.len_world.as_ptr().add(blk)),
            )
        };
        // `Table3d::band_coords_lanes`.
        let (xa, xb) = if t.uniform {
            let inv = _mm256_set1_ps(t.inv_ds);
            let reach = _mm256_set1_ps(t.reach);
            let (sf, sb) = (no_nan(sf, lo), no_nan(sb, lo));
            let xa = clamp(_mm256_mul_ps(_mm256_sub_ps(sf, lo), inv), zero, top);
            let b = clamp(_mm256_mul_ps(_mm256_sub_ps(sb, lo), inv), zero, top);
            (xa, clamp(b, _mm256_sub_ps(xa, reach), _mm256_add_ps(xa, reach)))
        } else {
            let ds = _mm256_set1_ps(t.max_ds);
            let sf = clamp(no_nan(sf, lo), lo, hi);
            let b = clamp(no_nan(sb, lo), lo, hi);
            let sb = clamp(b, _mm256_sub_ps(sf, ds), _mm256_add_ps(sf, ds));
            let xb = x_of_lanes(sb, valid);
            // Each lane's predecessor's clamped back scalar and grid index
            // (lane 0's from the previous block).
            let pred = |v: __m256, carry: __m256| {
                _mm256_blend_ps::<1>(_mm256_permutevar8x32_ps(v, shift), _mm256_permutevar8x32_ps(carry, shift))
            };
            let (sb_pred, xb_pred) = (pred(sb, prev_sb), pred(xb, prev_xb));
            // The previous block's lane at the same place: a batch of
            // eight rays stepped together (the packet walk) holds each
            // ray's previous segment there.
            let (sb_above, xb_above) = (prev_sb, prev_xb);
            (prev_sb, prev_xb) = (sb, xb);
            // Bit for bit (an integer compare: −0 is not +0), on the
            // clamped values `x_of_lanes` would read.
            let bits = |a: __m256, b: __m256| {
                let m = _mm256_cmpeq_epi32(_mm256_castps_si256(a), _mm256_castps_si256(b));
                (m, _mm256_movemask_ps(_mm256_castsi256_ps(m)) & valid)
            };
            let (_, same) = bits(sf, sb_pred);
            let (above_mask, above) = bits(sf, sb_above);
            let xa = if same == valid {
                xb_pred
            } else if above == valid {
                xb_above
            } else if same | above == valid {
                _mm256_blendv_ps(xb_pred, xb_above, _mm256_castsi256_ps(above_mask))
            } else {
                x_of_lanes(sf, valid)
            };
            (xa, xb)
        };
        let xk = clamp(_mm256_mul_ps(no_nan(len, zero), inv_dl), zero, xk_max);
        // Cell corner min(⌊x⌋, n − 2) and fraction, as `Table3d::cell_of`;
        // the integer clamps keep indices in range whatever the floats were.
        let a0 = clamp_i(_mm256_cvttps_epi32(_mm256_min_ps(xa, top_s)), 0, t.n_s as i32 - 2);
        let b0 = clamp_i(_mm256_cvttps_epi32(_mm256_min_ps(xb, top_s)), 0, t.n_s as i32 - 2);
        let k0 = clamp_i(_mm256_cvttps_epi32(_mm256_min_ps(xk, top_l)), 0, t.n_l as i32 - 2);
        let fa = _mm256_sub_ps(xa, _mm256_cvtepi32_ps(a0));
        let fb = _mm256_sub_ps(xb, _mm256_cvtepi32_ps(b0));
        let fk = _mm256_sub_ps(xk, _mm256_cvtepi32_ps(k0));
        if CELLS {
            if let Some(c) = cells.as_deref_mut() {
                // SAFETY: blk + 8 ≤ BATCH: 8-lane stores inside each [_; BATCH] array.
                unsafe {
                    _mm256_storeu_si256(c.a0.as_mut_ptr().add(blk).cast(), a0);
                    _mm256_storeu_si256(c.b0.as_mut_ptr().add(blk).cast(), b0);
                    _mm256_storeu_si256(c.k0.as_mut_ptr().add(blk).cast(), k0);
                    _mm256_storeu_ps(c.fa.as_mut_ptr().add(blk), fa);
                    _mm256_storeu_ps(c.fb.as_mut_ptr().add(blk), fb);
                    _mm256_storeu_ps(c.fk.as_mut_ptr().add(blk), fk);
                }
            }
            continue;
        }
        let Some(out) = out.as_deref_mut() else { return };
        // SAFETY: a0 ∈ [0, n_s − 2], so a0 and a0 + 1 index `t.pair_off`
        // (at least n_s values).
        let (p0, p1) = unsafe { (_mm256_i32gather_epi32::<4>(po, a0), _mm256_i32gather_epi32::<4>(po.add(1), a0)) };
        // `Table3d::cell_bases` in wrapping i32 (the band's offsets wrap as
        // its usize ones do), then clamped to where both l-rows of the
        // corner pair fit: a no-op for every valid table, and the reads'
        // bound whatever the table held.
        let off = |p: __m256i| {
            let e = _mm256_add_epi32(_mm256_mullo_epi32(_mm256_add_epi32(p, b0), nl), k0);
            clamp_i(_mm256_slli_epi32::<2>(e), 0, g.max_base)
        };
        // SAFETY: 8-lane stores into local arrays of 8 values.
        unsafe {
            _mm256_storeu_si256(base[0].as_mut_ptr().cast(), off(p0));
            _mm256_storeu_si256(base[1].as_mut_ptr().cast(), off(p1));
        }
        if DEPTH {
            // SAFETY: as the trilinear path below (the same rows, and the
            // depths of their entries: one an entry, checked by `run`'s
            // caller).
            unsafe { depth_block::<S>(t, g, (blk, m), &base, [fa, fb, fk], out) };
            continue;
        }
        // The 8 weights of each lane's entries, as `Table3d::gather`: corner
        // c's w_c times 1 − fk (slice k0) and fk (slice k0 + 1), then
        // transposed so that lane l's eight are one vector,
        // (w₀·gk, w₀·fk, w₁·gk, w₁·fk, …).
        let (wa0, wb0) = (_mm256_sub_ps(one, fa), _mm256_sub_ps(one, fb));
        let gk = _mm256_sub_ps(one, fk);
        let wc = [_mm256_mul_ps(wa0, wb0), _mm256_mul_ps(wa0, fb), _mm256_mul_ps(fa, wb0), _mm256_mul_ps(fa, fb)];
        let wts = transpose8([
            _mm256_mul_ps(wc[0], gk),
            _mm256_mul_ps(wc[0], fk),
            _mm256_mul_ps(wc[1], gk),
            _mm256_mul_ps(wc[1], fk),
            _mm256_mul_ps(wc[2], gk),
            _mm256_mul_ps(wc[2], fk),
            _mm256_mul_ps(wc[3], gk),
            _mm256_mul_ps(wc[3], fk),
        ]);
        for (l, &wl) in wts.iter().enumerate().take(m) {
            // base ∈ [0, max_base] (clamped), so base + n_l·4 + 8 ≤ len.
            let (o0, o1) = (base[0][l] as usize, base[1][l] as usize);
            let bases = [o0, o0 + g.nl4, o1, o1 + g.nl4];
            // SAFETY: each row reads values bases[c]..bases[c] + 8, all
            // within the data by the bound above; AVX2/F16C as required.
            let v =
                unsafe { [row::<S>(g, bases[0]), row::<S>(g, bases[1]), row::<S>(g, bases[2]), row::<S>(g, bases[3])] };
            // Corner c's row [k0 | k0 + 1] times [w_c·gk ×4 | w_c·fk ×4],
            // summed over the corners in the portable order, then the two
            // slices.
            let p = |c: usize| _mm256_mul_ps(v[c], _mm256_permutevar8x32_ps(wl, pair_idx[c]));
            let s = _mm256_add_ps(_mm256_add_ps(_mm256_add_ps(p(0), p(1)), p(2)), p(3));
            let s = _mm_add_ps(_mm256_castps256_ps128(s), _mm256_extractf128_ps::<1>(s));
            // SAFETY: 4-float store into out[blk + l], an [f32; 4] (blk + l < n ≤ BATCH, bounds-checked).
            unsafe { _mm_storeu_ps(out[blk + l].as_mut_ptr(), s) };
        }
    }
}

#[cfg(test)]
mod tests {
    //! The kernel against the portable path: equal values (the contract is
    //! bit-identity, which implies the trait's 1e-6), on every storage, both
    //! reconstructions, the uniform and a non-uniform scalar axis, batches of
    //! every length with in- and out-of-domain scalars, NaN, ±∞, zero and
    //! negative lengths.
    use crate::table3d::{Build3d, LookupKernel, ScalarAxis, Table3d, Table3dParams};
    use crate::*;
    use proptest::prelude::*;

    /// Thin: the table stays trilinear. Dense: it takes the optical depth.
    const THIN: &str = r#"{"color": [[0, 0.2, 0.4, 1], [0.35, 1, 1, 0.2], [1, 1, 0, 0]],
        "opacity": [[0, 0.002], [0.3, 0.001], [0.6, 0.004], [1, 0.01]], "unit_distance": 1}"#;
    const DENSE: &str = r#"{"color": [[0, 0.2, 0.4, 1], [0.35, 1, 1, 0.2], [1, 1, 0, 0]],
        "opacity": [[0, 0.2], [0.3, 0.1], [0.6, 40], [1, 5]], "unit_distance": 0.5}"#;

    fn tables() -> Vec<Table3d> {
        let scalars: Vec<f64> = (0..=1000).map(|i| (i as f64 / 1000.0).powi(3)).collect();
        let mut d = TableDomain::new(0.0, 1.0, 0.4, 2.0).unwrap();
        d.s_quantiles = ScalarQuantiles::of(&scalars);
        let mut v = Vec::new();
        for (json, recon) in [(THIN, Reconstruction::Trilinear), (DENSE, Reconstruction::OpticalDepth)] {
            let tf = TransferFunction::from_json(json).unwrap();
            for precision in Precision::ALL {
                for s_axis in [ScalarAxis::Uniform, ScalarAxis::Data] {
                    let build = Build3d::SliceRecurrence { oversampling: 1.0 };
                    let p = Table3dParams { n_s: 24, n_l: 12, build, precision, s_axis };
                    let t = Table3d::build(&tf, &d, &p).unwrap();
                    assert_eq!(t.reconstruction(), recon, "{json}");
                    v.push(t);
                }
            }
            // Knots crowded into the first bucket (4 of them in 1/160 of the
            // range): lookups step past the bucket's next two intervals.
            let knots = [(0.0, 0), (0.001, 1), (0.002, 2), (0.003, 3), (0.0045, 5), (0.2, 9), (1.0, 39)];
            let p = Table3dParams { n_s: 40, n_l: 12, s_axis: ScalarAxis::TfNodes, ..Default::default() };
            v.push(Table3d::build_with_knots(&tf, &d, &p, &knots).unwrap());
        }
        v
    }

    fn odd(v: u8) -> Option<f32> {
        match v % 12 {
            0 => Some(f32::NAN),
            1 => Some(f32::INFINITY),
            2 => Some(f32::NEG_INFINITY),
            3 => Some(-5.0),
            4 => Some(7.0),
            5 => Some(0.0),
            6 => Some(-0.0),
            7 => Some(-1e-3),
            8 => Some(3e38),
            _ => None,
        }
    }

    fn batch(raw: &[(f32, f32, f32, u8)]) -> SegmentBatch {
        let mut b = SegmentBatch::default();
        for &(s_front, s_back, len_world, tag) in raw.iter().take(BATCH) {
            let mut seg = Segment { s_front, s_back, len_world, ..Default::default() };
            match tag % 4 {
                0 => seg.s_front = odd(tag / 4).unwrap_or(s_front),
                1 => seg.s_back = odd(tag / 4).unwrap_or(s_back),
                2 => seg.len_world = odd(tag / 4).unwrap_or(len_world),
                _ => {}
            }
            b.push(seg);
        }
        b
    }

    fn check(t: &Table3d, b: &SegmentBatch) -> Result<(), TestCaseError> {
        let portable = t.clone().with_lookup_kernel(LookupKernel::Portable);
        prop_assert_eq!(portable.lookup_kernel_in_use(), "portable");
        let (mut fast, mut slow) = ([[-1.0f32; 4]; BATCH], [[-1.0f32; 4]; BATCH]);
        // The kernel itself, not a silent fallback, wherever it is available.
        prop_assert_eq!(t.shade_batch_lean(b, &mut fast), super::available());
        t.shade_batch(b, &mut fast);
        portable.shade_batch(b, &mut slow);
        let segs: Vec<Segment> = (0..b.len).map(|i| b.get(i)).collect();
        let mut span = vec![[-1.0f32; 4]; b.len];
        t.shade_span(&segs, &mut span);
        for i in 0..b.len {
            let what = (t.params().precision, t.reconstruction(), t.is_uniform_axis(), b.get(i));
            // Bit-identical (a zero's sign aside), hence within 1e-6.
            prop_assert!(fast[i] == slow[i], "{what:?}: avx2 {:?} vs portable {:?}", fast[i], slow[i]);
            prop_assert!(span[i] == slow[i], "{what:?}: span {:?} vs portable {:?}", span[i], slow[i]);
            prop_assert!(fast[i] == t.shade(&b.get(i)), "{what:?}: avx2 vs shade");
            prop_assert!(fast[i].iter().all(|v| v.is_finite()), "{what:?}: {:?}", fast[i]);
        }
        prop_assert!(fast[b.len..].iter().all(|o| *o == [-1.0; 4]), "lanes past len were written");
        Ok(())
    }

    #[test]
    fn the_kernel_runs_where_the_cpu_has_it() {
        let t = &tables()[0];
        let cpu = is_x86_feature_detected!("avx2") && is_x86_feature_detected!("f16c");
        let forced = std::env::var(super::LOOKUP_ENV).is_ok_and(|v| v.eq_ignore_ascii_case("portable"));
        let want = if cpu && !forced { "avx2" } else { "portable" };
        assert_eq!(t.lookup_kernel_in_use(), want);
        if want == "portable" {
            eprintln!(
                "note: no AVX2/F16C (or {} set): the kernel tests compare the portable path with itself",
                super::LOOKUP_ENV
            );
        }
    }

    proptest! {
        #![proptest_config(ProptestConfig { cases: 96, rng_seed: proptest::test_runner::RngSeed::Fixed(0x51d), ..ProptestConfig::default() })]

        #[test]
        fn kernel_equals_the_portable_path(
            raw in prop::collection::vec((-0.3f32..1.3, -0.3f32..1.3, -0.5f32..2.6, any::<u8>()), 0..=BATCH),
        ) {
            let b = batch(&raw);
            for t in TABLES.with(|t| t.clone()) {
                check(&t, &b)?;
            }
        }
    }

    proptest! {
        #![proptest_config(ProptestConfig { cases: 64, rng_seed: proptest::test_runner::RngSeed::Fixed(0xc4a1), ..ProptestConfig::default() })]

        /// A ray's segments: each front scalar the previous back one (the
        /// kernel then reuses its grid index), with breaks (a new run) and
        /// odd values anywhere in the chain.
        #[test]
        fn chained_segments_equal_the_portable_path(
            raw in prop::collection::vec((-0.3f32..1.3, -0.5f32..2.6, any::<u8>(), 0u8..8), 1..=BATCH),
        ) {
            let mut b = SegmentBatch::default();
            let mut prev = 0.4f32;
            for &(s, len_world, tag, brk) in &raw {
                let s_front = if brk == 0 { s * 0.5 } else { prev };
                let mut seg = Segment { s_front, s_back: s, len_world, ..Default::default() };
                match tag % 6 {
                    0 => seg.s_back = odd(tag / 6).unwrap_or(s),
                    1 => seg.s_front = odd(tag / 6).unwrap_or(s_front),
                    _ => {}
                }
                prev = seg.s_back;
                b.push(seg);
            }
            for t in TABLES.with(|t| t.clone()) {
                check(&t, &b)?;
            }
        }

        /// Eight rays' segments interleaved (the packet walk's batches):
        /// each front scalar the back one eight segments earlier, with
        /// breaks and odd values anywhere, and some lanes chained to their
        /// predecessor in the batch instead.
        #[test]
        fn interleaved_chains_equal_the_portable_path(
            raw in prop::collection::vec((-0.3f32..1.3, -0.5f32..2.6, any::<u8>(), 0u8..8), 1..=BATCH),
        ) {
            let mut b = SegmentBatch::default();
            let mut back = [0.4f32; 8];
            for (i, &(s, len_world, tag, brk)) in raw.iter().enumerate() {
                let s_front = match brk {
                    0 => s * 0.5,
                    1 if i > 0 => b.s_back[i - 1],
                    _ => back[i % 8],
                };
                let mut seg = Segment { s_front, s_back: s, len_world, ..Default::default() };
                match tag % 6 {
                    0 => seg.s_back = odd(tag / 6).unwrap_or(s),
                    1 => seg.s_front = odd(tag / 6).unwrap_or(s_front),
                    _ => {}
                }
                back[i % 8] = seg.s_back;
                b.push(seg);
            }
            for t in TABLES.with(|t| t.clone()) {
                check(&t, &b)?;
            }
        }
    }

    thread_local! {
        static TABLES: Vec<Table3d> = tables();
    }

    /// Scalars in every interval of the axis and on every grid scalar (the
    /// data axis's buckets that hold several knots step past the first).
    #[test]
    fn every_axis_interval() {
        for t in tables() {
            let n_s = t.params().n_s;
            let mut segs = Vec::new();
            for a in 0..n_s - 1 {
                let (x0, x1) = (t.scalar_at(a), t.scalar_at(a + 1));
                for f in [0.0, 1e-7, 0.1, 0.25, 0.5, 0.75, 0.9, 0.999_999, 1.0] {
                    let s = (x0 + f * (x1 - x0)) as f32;
                    let near = t.scalar_at((a + 2).min(n_s - 1)) as f32;
                    segs.push(Segment { s_front: s, s_back: near, len_world: 0.7, ..Default::default() });
                    segs.push(Segment { s_front: near, s_back: s, len_world: 1.3, ..Default::default() });
                }
            }
            for c in segs.chunks(BATCH) {
                check(&t, &SegmentBatch::from_segments(c)).unwrap();
            }
        }
    }

    #[test]
    fn every_batch_length_and_stale_lanes() {
        let raw: Vec<_> =
            (0..BATCH).map(|i| (i as f32 / 50.0, 1.0 - i as f32 / 70.0, i as f32 / 25.0, (i * 7) as u8)).collect();
        for t in tables() {
            for len in 0..=BATCH {
                let mut b = batch(&raw);
                b.len = len;
                check(&t, &b).unwrap();
            }
        }
    }
}
