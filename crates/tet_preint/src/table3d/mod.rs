//! `table3d`: the 3D pre-integration table T(Sf, Sb, l) of premultiplied RGBA
//! with trilinear lookup (Röttger, Kraus & Ertl 2000; Röttger & Ertl 2002), or, where α bends within
//! a grid step, trilinear in optical depth ([`Reconstruction`]).
//!
//! Axes: Sf and Sb take `n_s` values over the domain's scalar range, equally
//! spaced or ([`ScalarAxis::TfNodes`]) piecewise equally spaced with a sample
//! on every TF control point, which removes the dominant interpolation
//! error (the TF's kinks), or ([`ScalarAxis::Data`]) denser where the
//! bundle's scalars are; l takes `n_l` values k·Δl, k = 0..n_l−1, up to
//! `len_max_world` (slice 0 is l = 0, all zeros). Only pairs in the band
//! |Sf − Sb| ≤ `max_ds` (plus a grid step so trilinear corners exist) are
//! stored: row a holds b ∈ [lo(a), hi(a)] (a ± w on a uniform axis), each
//! pair's n_l entries contiguous.
//!
//! # Builds ([`Build3d`])
//!
//! * `Adaptive` (what [`crate::BakeOptions`] bakes with): per (Sf, Sb)
//!   pair, density emission, the segment is cut at the TF's control points
//!   into pieces where ρ and κ are linear, and each piece into the fewest
//!   intervals whose estimated colour error stays below the tolerance. On
//!   an interval ln T is the chord plus a bend βx(1 − x) (exact, ρ linear),
//!   integrated to first order in β in closed form, so the error falls as
//!   (intervals)⁻⁴: a smooth TF needs a handful per pair where the slice
//!   recurrence takes two per grid step. All slices of an interval at once
//!   (vectorized over l). Independent emission: the slice recurrence.
//! * `SliceRecurrence` (`Build3d::default()`, tet_gpu's compute-shader
//!   bake): per (Sf, Sb) pair the segment is cut into n
//!   intervals (n = ⌈o·|b − a|⌉, o the oversampling factor per grid step;
//!   one interval on the diagonal, where it is exact). The optical depth from
//!   the entry to sample i is l·Dᵢ with Dᵢ = ∫₀^{uᵢ} ρ exact (trapezoids:
//!   ρ is linear between samples), so Tᵢ(l_k) = exp(−k·Δl·Dᵢ) = Tᵢ(l_{k−1})·Gᵢ:
//!   slice k comes from slice k−1's transmittances by one multiplication per
//!   sample, no exp. Colour, density emission, integrated by parts:
//!   C = κ₀ − κₙTₙ + Σᵢ Δκᵢ·∫ᵢT du, with ∫ᵢT = (Tᵢ − Tᵢ₊₁)/λᵢ (exact when ρ
//!   is constant on the interval, λᵢ its optical depth; a series below
//!   λ = 0.05). Independent emission: C = l·Σᵢ κ̄ᵢ·∫ᵢT. α = 1 − Tₙ. The inner
//!   loop runs over plain f32 arrays in 8 lanes without branches; pairs are
//!   distributed over threads with rayon.
//! * `Blend`: Röttger & Ertl's (2002) hardware pre-integration emulated: per slice, n
//!   steps blended back to front with each step's (colour, 1 − e^{−ρl/n})
//!   at the sample midpoint (Stein's constant-chromaticity step), the running
//!   sums rounded to the accumulation precision after every step (Table 1).
//! * `Incremental`: O(N³); slice k composites a front piece of length Δl
//!   (mean extinction from the prefix integral, mean colour of its ends) over
//!   slice k−1 looked up bilinearly at (Sm, Sb), as VTK's incremental table.
//! * `Exact`: every entry by the f64 [`crate::integrate_segment`] (the
//!   per-entry reference build).
//!
//! Every build but `Incremental` computes a pair from the TF over the
//! pair's own interval [Sf, Sb] only (the optical depth is integrated from
//! Sf), which lets [`Table3d::rebake`] recompute after a TF edit only the
//! pairs the edit reaches, bit for bit as a full bake.

mod axis;
mod band;
mod build;
mod lookup;
// The AVX2 kernel's optical-depth lookups take the same 1 − e^−τ.
pub(crate) use lookup::alpha_of_depth;
mod rebake;

use crate::domain::{check_res, TableDomain, TableError, MAX_TABLE_ENTRIES};
use crate::method::Rgba32;
use crate::precision::{Accumulation, Precision, Storage};
use crate::tf::TransferFunction;
use axis::Axis;
use band::Band;
use build::{bake_pairs, build_incremental, rows_mut, Grid};
use lookup::optical_depths;
use rayon::prelude::*;
use serde::{Deserialize, Serialize};
use wide::f32x8;

pub use axis::{
    node_step_cap, tf_nodes_in, DATA_AXIS_DENSITY_POWER, DATA_AXIS_NODE_BUDGET, DATA_AXIS_NODE_STEP,
    DATA_AXIS_UNIFORM_SHARE,
};
pub use build::ExtinctionPrefix;
pub use rebake::{FullRebake, RebakeStats};

/// How the table is computed.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(tag = "kind", rename_all = "kebab-case")]
pub enum Build3d {
    /// Transmittance recurrence over l with `oversampling` intervals per
    /// scalar grid step (module docs).
    SliceRecurrence { oversampling: f32 },
    /// Density emission: per (Sf, Sb) pair the fewest pieces whose
    /// estimated colour error is at most `tolerance` (absolute, per
    /// entry), each integrated with the bend of ln T to first order, and
    /// every slice l at once (module docs). Independent emission: the slice
    /// recurrence with oversampling 2.
    Adaptive { tolerance: f32 },
    /// The frame-buffer integration of Röttger & Ertl, "A Two-Step Approach
    /// for Interactive Pre-Integrated Volume Rendering of Unstructured
    /// Grids", 2002: `steps` samples per segment, sums
    /// rounded to `accumulation` after each step.
    Blend { steps: u32, accumulation: Accumulation },
    /// Composite a short front piece over the previous slice (O(N³)).
    Incremental,
    /// f64 exact integration per entry.
    Exact,
}

impl Default for Build3d {
    fn default() -> Self {
        Build3d::SliceRecurrence { oversampling: 2.0 }
    }
}

/// [`Build3d::Adaptive`]'s tolerance in [`Table3dParams::data`] (so in
/// `BakeOptions`): estimated colour error per entry. On Blunt Fin with
/// `tf_normalized.json` the entries' max error against the per-entry exact
/// build is 1.1e-5 (slice recurrence, o = 2: 1.5e-5) at about 1/7 of the
/// slice recurrence's bake time (crates/tetlut/results/bluntfin.md).
pub const ADAPTIVE_TOLERANCE: f32 = 1e-5;

/// Where the `n_s` samples of the Sf and Sb axes lie.
///
/// The table's error is dominated by the TF's control points: ρ and κ have
/// a kink there, so α and C have one along Sf = node and Sb = node (and a
/// sharp bend near the diagonal), which a uniform grid straddles with an
/// error of order |Δslope|·Δs·l. `TfNodes` puts a grid sample on every
/// control point inside the scalar range (the steps between two control
/// points are uniform, their count proportional to the gap, at least one),
/// so trilinear interpolation never straddles a kink; on the Blunt Fin
/// uniform set this lowers the max error of 128 × 128 × 256 from 2.4e-3 to
/// below 1e-3 (crates/tetlut/results/bluntfin.md).
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "kebab-case")]
pub enum ScalarAxis {
    /// Equal steps over [s_lo, s_hi] (format version 1's only axis).
    #[default]
    Uniform,
    /// Piecewise uniform with a sample on every TF control point; falls back
    /// to uniform steps when the TF has more control points in range than
    /// the axis has steps.
    TfNodes,
    /// Samples with a density that is half uniform over the scalar range,
    /// half ∝ √(the data's scalar density) (from the domain's
    /// [`ScalarQuantiles`]; all uniform when it has none), refined near
    /// every TF control point (steps there half the uniform step, growing
    /// as √distance: [`node_step_cap`]), and a sample on every control
    /// point. A table's error grows with l·|dρ/ds|·Δs where the segments
    /// are, so a bundle whose scalars crowd into a sliver of the range (the
    /// stars' luminosities: half below 3e-4 of it, all inside the first
    /// step of a uniform 128-sample axis) needs its samples there; and
    /// across a control point the error is first order in the step there,
    /// wherever the samples are, so those steps must be small too.
    ///
    /// [`ScalarQuantiles`]: crate::domain::ScalarQuantiles
    Data,
}

/// Resolution, build and storage of a [`Table3d`].
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct Table3dParams {
    /// Samples along Sf and along Sb (≥ 2).
    pub n_s: usize,
    /// Samples along l, including l = 0 (≥ 2).
    pub n_l: usize,
    pub build: Build3d,
    pub precision: Precision,
    /// Placement of the scalar samples; absent in format-1 files (uniform).
    #[serde(default)]
    pub s_axis: ScalarAxis,
}

impl Default for Table3dParams {
    /// 128 × 128 × 256, slice recurrence with oversampling 2, f32, uniform
    /// scalar axis (format version 1's layout; `BakeOptions`, what tetlut,
    /// the CPU renderer and tetview bake with, defaults to
    /// [`Table3dParams::data`]).
    fn default() -> Self {
        Table3dParams {
            n_s: 128,
            n_l: 256,
            build: Build3d::default(),
            precision: Precision::F32,
            s_axis: ScalarAxis::Uniform,
        }
    }
}

impl Table3dParams {
    /// The defaults with a sample on every TF control point: the accurate
    /// choice on the CPU.
    pub fn tf_nodes() -> Self {
        Table3dParams { s_axis: ScalarAxis::TfNodes, ..Default::default() }
    }

    /// The defaults with samples following the data and on every TF control
    /// point ([`ScalarAxis::Data`]), built adaptively
    /// ([`Build3d::Adaptive`] at [`ADAPTIVE_TOLERANCE`]): what
    /// [`crate::BakeOptions`] bakes with. tet_gpu's compute-shader bake
    /// runs the slice recurrence: give it `build: Build3d::default()` (the
    /// same axis; entries agree to ~1e-5).
    pub fn data() -> Self {
        Table3dParams {
            s_axis: ScalarAxis::Data,
            build: Build3d::Adaptive { tolerance: ADAPTIVE_TOLERANCE },
            ..Default::default()
        }
    }
}

/// Largest `n_s` or `n_l`.
pub const MAX_AXIS: usize = 8192;

/// A baked 3D table; implements [`SegmentShader`] by lookup ([`Reconstruction`]).
///
/// [`SegmentShader`]: crate::method::SegmentShader
#[derive(Debug, Clone)]
pub struct Table3d {
    domain: TableDomain,
    params: Table3dParams,
    band: Band,
    /// Boxed: keeps `Table3d` (and `Baked`) small.
    axis: Box<Axis>,
    data: Storage,
    /// How lookups interpolate ([`Reconstruction`]), chosen from `pair_gap`.
    recon: Reconstruction,
    /// Per pair, the largest gap between the two reconstructions'
    /// half-way α along l and towards the next pair of its row.
    pair_gap: Vec<f32>,
    /// With [`Reconstruction::OpticalDepth`] on f32 storage, the optical
    /// depth ([`optical_depths`]) of every entry, in entry order: what the
    /// lookup interpolates, computed once per bake, load or re-bake instead
    /// of 8 logarithms per lookup. Empty otherwise.
    depth: Vec<f32>,
    /// 1 / grid step along s (uniform axis) and along l.
    inv_ds: f32,
    inv_dl: f32,
    /// Which code runs the batched lookups ([`LookupKernel`]).
    kernel: LookupKernel,
}

/// Which code runs a [`Table3d`]'s batched lookups
/// ([`SegmentShader::shade_batch`] and [`SegmentShader::shade_span`]; the
/// single lookup [`Table3d::lookup`] is always portable). Both give the same
/// values bit for bit (module `simd_x86`), so the choice is speed only.
///
/// [`SegmentShader::shade_batch`]: crate::method::SegmentShader::shade_batch
/// [`SegmentShader::shade_span`]: crate::method::SegmentShader::shade_span
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub enum LookupKernel {
    /// The AVX2 kernel where the CPU has AVX2 and F16C (checked once per
    /// process) and the environment variable `TET_PREINT_LOOKUP` is not
    /// `portable`; the portable code otherwise (and on other architectures).
    #[default]
    Auto,
    /// Always the portable code (tests compare the two paths with it).
    Portable,
}

impl Table3d {
    /// Bakes the table for `tf` (x in data units: denormalize a normalized TF
    /// first) over `domain`.
    pub fn build(tf: &TransferFunction, domain: &TableDomain, params: &Table3dParams) -> Result<Table3d, TableError> {
        check_res("table3d n_s", params.n_s, 2, MAX_AXIS)?;
        check_res("table3d n_l", params.n_l, 2, MAX_AXIS)?;
        let axis = Axis::for_params(tf, domain, params)?;
        Table3d::build_on_axis(tf, domain, params, axis)
    }

    /// Bakes the table on a given scalar axis, (scalar, grid index) knots as
    /// [`Table3d::s_knots`] returns them (e.g. an earlier table's, so that a
    /// TF edit that moved a node keeps the old samples; or knots placed by
    /// the caller). `params.s_axis` must not be `Uniform` (the knots say
    /// where the samples are); invalid knots are an error.
    pub fn build_with_knots(
        tf: &TransferFunction,
        domain: &TableDomain,
        params: &Table3dParams,
        knots: &[(f64, usize)],
    ) -> Result<Table3d, TableError> {
        check_res("table3d n_s", params.n_s, 2, MAX_AXIS)?;
        check_res("table3d n_l", params.n_l, 2, MAX_AXIS)?;
        if params.s_axis == ScalarAxis::Uniform {
            return Err(TableError::Invalid("knots given for a uniform scalar axis".into()));
        }
        let axis = Axis::from_knots(domain, params.n_s, knots).ok_or_else(|| {
            TableError::Invalid(format!(
                "{} scalar axis knots: need (s_lo, 0) … (s_hi, n_s − 1), both strictly increasing",
                knots.len()
            ))
        })?;
        Table3d::build_on_axis(tf, domain, params, axis)
    }

    fn build_on_axis(
        tf: &TransferFunction,
        domain: &TableDomain,
        params: &Table3dParams,
        axis: Axis,
    ) -> Result<Table3d, TableError> {
        let band = Band::for_axis(params.n_s, domain, &axis);
        let entries = band.pairs as u64 * params.n_l as u64;
        if entries > MAX_TABLE_ENTRIES {
            return Err(TableError::TooLarge { entries, max: MAX_TABLE_ENTRIES });
        }
        match params.build {
            Build3d::SliceRecurrence { oversampling } if !(0.01..=1024.0).contains(&oversampling) => {
                return Err(TableError::Invalid(format!("oversampling {oversampling} must be in [0.01, 1024]")));
            }
            Build3d::Adaptive { tolerance } if !(1e-8..=1e-2).contains(&tolerance) => {
                return Err(TableError::Invalid(format!("tolerance {tolerance} must be in [1e-8, 1e-2]")));
            }
            Build3d::Blend { steps, .. } => check_res("blend steps", steps as usize, 1, 1 << 16)?,
            _ => {}
        }
        let grid = Grid::new(domain, params, &axis);
        let values = match params.build {
            Build3d::Incremental => build_incremental(tf, &grid, &band, &axis, domain),
            build => {
                let mut values = vec![0.0f32; band.pairs * grid.n_l * 4];
                bake_pairs(tf, &grid, &band, build, &mut values, &|_, _| true);
                values
            }
        };
        let data = Storage::encode(values, 4, params.precision);
        Ok(Table3d::assemble(domain, params, axis, data).expect("built storage matches its layout"))
    }

    /// Reassembles a table from stored parts (e.g. a `.tetl` file): the
    /// scalar axis's knots (scalar, grid index) are required for
    /// [`ScalarAxis::TfNodes`] and ignored for `Uniform`. `None` when the
    /// knots are invalid or `data` does not hold the band's entries in RGBA.
    pub fn from_parts(
        domain: TableDomain,
        params: Table3dParams,
        s_knots: Option<&[(f64, usize)]>,
        data: Storage,
    ) -> Option<Table3d> {
        if params.n_s < 2 || params.n_l < 2 || params.n_s > MAX_AXIS || params.n_l > MAX_AXIS {
            return None;
        }
        let axis = match params.s_axis {
            ScalarAxis::Uniform => Axis::uniform(&domain, params.n_s),
            ScalarAxis::TfNodes | ScalarAxis::Data => Axis::from_knots(&domain, params.n_s, s_knots?)?,
        };
        Table3d::assemble(&domain, &params, axis, data)
    }

    fn assemble(domain: &TableDomain, params: &Table3dParams, axis: Axis, data: Storage) -> Option<Table3d> {
        let (domain, params) = (*domain, *params);
        let band = Band::for_axis(params.n_s, &domain, &axis);
        if data.channels() != 4 || data.len() != band.pairs * params.n_l * 4 || data.precision() != params.precision {
            return None;
        }
        let inv_ds = ((params.n_s - 1) as f64 / domain.scalar_span()) as f32;
        let inv_dl = ((params.n_l - 1) as f64 / domain.len_max_world) as f32;
        let mut t = Table3d {
            domain,
            params,
            band,
            axis: Box::new(axis),
            data,
            recon: Reconstruction::Trilinear,
            pair_gap: Vec::new(),
            depth: Vec::new(),
            inv_ds,
            inv_dl,
            kernel: LookupKernel::Auto,
        };
        t.update_reconstruction(|_, _| true);
        Some(t)
    }

    pub fn domain(&self) -> &TableDomain {
        &self.domain
    }
    pub fn params(&self) -> &Table3dParams {
        &self.params
    }
    pub fn storage(&self) -> &Storage {
        &self.data
    }
    /// Bytes the table holds: the band's entries as stored, plus (f32
    /// storage) the per-entry optical depths the lookup reads.
    pub fn memory_bytes(&self) -> usize {
        self.data.memory_bytes() + self.depth.len() * 4
    }
    /// Bytes the full n_s × n_s × n_l cube would take in the same precision
    /// (with its optical depths where this table keeps them, as
    /// [`Table3d::memory_bytes`]).
    pub fn full_memory_bytes(&self) -> usize {
        let entries = self.params.n_s * self.params.n_s * self.params.n_l;
        let depth = if self.depth.is_empty() { 0 } else { entries * 4 };
        entries * 4 * self.params.precision.bytes() + depth
    }

    /// How lookups interpolate (chosen at every bake, load and re-bake).
    pub fn reconstruction(&self) -> Reconstruction {
        self.recon
    }

    /// The largest gap between the trilinear and the optical-depth
    /// reconstructions' α half way between neighbouring entries (along l,
    /// and along Sb, which covers Sf by the table's symmetry in α): above
    /// [`RECONSTRUCTION_GAP`], lookups take the optical depth.
    pub fn reconstruction_gap(&self) -> f32 {
        self.pair_gap.iter().fold(0.0, |m, &g| m.max(g))
    }

    /// Recomputes the gaps of the pairs whose entries `which` selects (and
    /// of their row predecessors, whose Sb-neighbour they are), chooses the
    /// reconstruction, and brings the optical depths up to date. Rows in
    /// parallel. After the band changed, `which` must select every pair.
    fn update_reconstruction(&mut self, which: impl Fn(usize, usize) -> bool + Sync) {
        let n_l = self.params.n_l;
        let pairs = self.band.pairs;
        self.pair_gap.resize(pairs, 0.0);
        let (band, data) = (&self.band, &self.data);
        // α of pair p's entries.
        let alpha_of = |p: usize, out: &mut Vec<f32>| {
            out.clear();
            match data.as_f32() {
                Some(d) => out.extend(d[p * n_l * 4..(p + 1) * n_l * 4].chunks_exact(4).map(|e| e[3])),
                None => out.extend((0..n_l).map(|k| data.get4((p * n_l + k) * 4)[3])),
            }
        };
        // √T = √(1 − α): half way between two entries the trilinear α is
        // 1 − (T₀ + T₁)/2 and the optical-depth α is 1 − √(T₀T₁), a gap of
        // (√T₀ − √T₁)²/2 (no logarithm needed).
        let root_t_of = |p: usize, scratch: &mut Vec<f32>, out: &mut Vec<f32>| {
            alpha_of(p, scratch);
            out.clear();
            out.extend(scratch.iter().map(|&a| (1.0 - a).max(0.0).sqrt()));
        };
        // Lane-wise maxima (no NaN: √ of a clamped value), reduced at the end.
        let max_gap = |x: &[f32], y: &[f32]| {
            let mut m = [0.0f32; W];
            for (xc, yc) in x.chunks(W).zip(y.chunks(W)) {
                for i in 0..xc.len() {
                    let g = 0.5 * (xc[i] - yc[i]) * (xc[i] - yc[i]);
                    m[i] = if g > m[i] { g } else { m[i] };
                }
            }
            m.into_iter().fold(0.0f32, f32::max)
        };
        rows_mut(&mut self.pair_gap, band, 1).into_par_iter().for_each(|(a, gaps)| {
            let row = band.row(a);
            let (mut cur, mut next, mut scratch) = (Vec::new(), Vec::new(), Vec::new());
            let mut have_next = false;
            for b in row.clone().rev() {
                let p = band.pair(a, b);
                let has_next = b + 1 < row.end;
                if !(which(a, b) || (has_next && which(a, b + 1))) {
                    have_next = false;
                    continue;
                }
                // `next` gets the previous iteration's pair, (a, b + 1).
                std::mem::swap(&mut cur, &mut next);
                root_t_of(p, &mut scratch, &mut cur);
                let mut g = max_gap(&cur[..n_l - 1], &cur[1..]);
                if has_next {
                    if !have_next {
                        root_t_of(p + 1, &mut scratch, &mut next);
                    }
                    g = g.max(max_gap(&cur, &next));
                }
                gaps[b - row.start] = g;
                have_next = true;
            }
        });
        let recon = if self.reconstruction_gap() > RECONSTRUCTION_GAP {
            Reconstruction::OpticalDepth
        } else {
            Reconstruction::Trilinear
        };
        self.recon = recon;
        if recon == Reconstruction::Trilinear || self.data.as_f32().is_none() {
            self.depth = Vec::new();
            return;
        }
        let refill = self.depth.len() != pairs * n_l;
        if refill {
            self.depth = vec![0.0; pairs * n_l];
        }
        let band = &self.band;
        rows_mut(&mut self.depth, band, n_l).into_par_iter().for_each(|(a, depth)| {
            let row = band.row(a);
            let mut alpha = Vec::with_capacity(n_l);
            for b in row.clone() {
                if !(refill || which(a, b)) {
                    continue;
                }
                alpha_of(band.pair(a, b), &mut alpha);
                let out = &mut depth[(b - row.start) * n_l..(b - row.start + 1) * n_l];
                for (c, o) in alpha.chunks(W).zip(out.chunks_mut(W)) {
                    let mut x = [0.0f32; W];
                    x[..c.len()].copy_from_slice(c);
                    o.copy_from_slice(&optical_depths(f32x8::from(x)).to_array()[..c.len()]);
                }
            }
        });
    }
    /// Stored half-width of the band in grid steps (n_s − 1 when full; the
    /// widest row's for a non-uniform axis).
    pub fn band_half_width(&self) -> usize {
        self.band.w
    }

    /// The scalar axis as (scalar, grid index) knots with uniform steps
    /// between them: two knots for a uniform axis.
    pub fn s_knots(&self) -> Vec<(f64, usize)> {
        self.axis.knots()
    }

    /// The knots [`Table3d::s_knots`] would return for a table built from
    /// these inputs, without building it: for bakes outside this crate
    /// (tet_gpu's compute-shader bake) that must use the same axis.
    pub fn axis_knots(
        tf: &TransferFunction,
        domain: &TableDomain,
        params: &Table3dParams,
    ) -> Result<Vec<(f64, usize)>, TableError> {
        Ok(Axis::for_params(tf, domain, params)?.knots())
    }

    /// Whether the scalar axis has equal steps (a consumer may then map
    /// scalars to indices by one scale; tet_gpu's shader reads either axis).
    pub fn is_uniform_axis(&self) -> bool {
        self.axis.uniform
    }

    /// Grid value: scalar of index `a`.
    pub fn scalar_at(&self, a: usize) -> f64 {
        self.axis.grid[a]
    }
    /// Grid value: length of slice `k`.
    pub fn len_at(&self, k: usize) -> f64 {
        k as f64 * self.domain.len_max_world / (self.params.n_l - 1) as f64
    }

    /// The stored entry at grid indices, `None` outside the band.
    pub fn entry(&self, a: usize, b: usize, k: usize) -> Option<Rgba32> {
        if a >= self.params.n_s || b >= self.params.n_s || k >= self.params.n_l || !self.band.row(a).contains(&b) {
            return None;
        }
        Some(self.data.get4((self.band.pair(a, b) * self.params.n_l + k) * 4))
    }

    /// Slice k as an n_s × n_s RGBA image (row Sb, column Sf), zero outside
    /// the band: what `tetlut show` draws.
    pub fn slice_image(&self, k: usize) -> Vec<Rgba32> {
        let n = self.params.n_s;
        let mut out = vec![[0.0; 4]; n * n];
        for b in 0..n {
            for a in 0..n {
                if let Some(e) = self.entry(a, b, k.min(self.params.n_l - 1)) {
                    out[b * n + a] = e;
                }
            }
        }
        out
    }
}

/// How [`Table3d`] interpolates between its entries.
///
/// Trilinear interpolation of premultiplied RGBA is what Röttger & Ertl 2002 does and
/// is exact enough while α changes little from entry to entry. Where a
/// grid step holds much optical depth (long cells through dense regions:
/// the stars' Delaunay mesh has l up to 562 world units, Δl = 2.2), α bends
/// within a step and trilinear α misses by up to 1e-2; interpolating the
/// optical depth instead is exact along l and far closer along s. A table
/// takes [`Reconstruction::OpticalDepth`] when the two differ by more than
/// [`RECONSTRUCTION_GAP`] half way between some pair of neighbouring
/// entries ([`Table3d::reconstruction_gap`]), and the cheaper trilinear
/// lookup otherwise (it reads no optical depths: the four CFD and volume
/// bundles' tables stay trilinear, bit for bit as before).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Reconstruction {
    /// Premultiplied RGBA trilinear.
    Trilinear,
    /// Optical depth −ln(1 − α) trilinear, colour trilinear scaled by α
    /// over the trilinear α (`reconstruct`, module `lookup`).
    OpticalDepth,
}

impl Reconstruction {
    /// The name `tetlut` prints (`trilinear`, `optical-depth`).
    pub fn id(self) -> &'static str {
        match self {
            Reconstruction::Trilinear => "trilinear",
            Reconstruction::OpticalDepth => "optical-depth",
        }
    }
}

/// Largest half-way gap between the reconstructions for which a table
/// stays [`Reconstruction::Trilinear`]: a tenth of the 1e-3 accuracy target.
pub const RECONSTRUCTION_GAP: f32 = 1e-4;

/// Lanes of [`SegmentShader::shade_batch`]'s lane-wise arithmetic.
///
/// [`SegmentShader::shade_batch`]: crate::method::SegmentShader::shade_batch
const W: usize = 8;

#[cfg(test)]
mod tests;
