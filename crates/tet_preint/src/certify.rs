//! Certify-and-refine for `table3d`: the bake measures its own error against
//! the exact integrator and refines until a target holds, for any transfer
//! function, or says it could not (issue 16).
//!
//! # What is measured
//!
//! Three deterministic segment sets (fixed seeds, [`CertifyOptions::seed`]):
//!
//! * `cells`: segments through the bundle's own cells (random rays through
//!   random cells, `tet_analysis::sample_cell_segments`): what renders.
//!   Only when the caller has the mesh ([`cell_triples`]); [`crate::make_shader`]
//!   has only the domain and measures the other two.
//! * `uniform`: uniform over the domain's band ([`crate::uniform_triples`]).
//! * `tf-nodes` ([`node_triples`]): segments whose ends lie near a TF
//!   control point at every scale from the whole band down to 1e-5 of it —
//!   straddling it, ending on it, or beside it — with lengths uniform and
//!   log-uniform. A uniform sample almost never lands there, yet that is
//!   where a table errs most: ρ̂(Sf, Sb) is not smooth at (node, node) (see
//!   [`crate::table3d::node_step_cap`]), and a narrow opacity peak is a
//!   node pair closer than any grid step.
//!
//! The error of a segment is the largest absolute difference of R, G, B or
//! A against [`crate::integrate_segment`] on the same f32 inputs.
//!
//! # How the table is refined ([`bake`])
//!
//! Start from the given [`Table3dParams`]; bake, measure. While the max over
//! every set is above [`CERTIFY_MARGIN`] × target:
//!
//! 1. If the table's lookup does not yet split at TF nodes, try splitting
//!    ([`CertifiedTable3d`]: a segment that crosses control points is cut
//!    there, each piece looked up, the pieces composited front to back, as
//!    the exact integrator does). Every piece then has both ends in one
//!    linear piece of the TF, where the table's entries are smooth, so the
//!    kink at (node, node) no longer enters. Kept when it lowers the max
//!    (no re-bake: same entries).
//! 2. Otherwise refine the axis the worst segments blame: re-measure the 64
//!    worst with Sf and Sb snapped to the grid's scalars (what is left is
//!    the l interpolation's error); if that explains at least half, n_l
//!    doubles, else n_s grows by √2 (either about doubles the memory).
//! 3. A step whose predicted table exceeds [`CertifyOptions::memory_budget`]
//!    is not baked; when neither axis fits (or [`crate::table3d::MAX_AXIS`]
//!    is reached) the bake stops with the best table found and a
//!    [`Certificate`] that says `certified: false` with its measured figure.
//!
//! The figure is a measurement on finitely many segments, not a bound: a
//! table is certified when the measured max is at most `target ×
//! CERTIFY_MARGIN`, so that an independent sample (another seed, more
//! segments) also stays below the target (the tests re-measure that way).

use crate::domain::{TableDomain, TableError};
use crate::error::uniform_triples;
use crate::exact::integrate_segment_with;
use crate::method::{self, Method, Rgba32, Segment, SegmentBatch, SegmentShader};
use crate::table3d::{Table3d, Table3dParams, MAX_AXIS};
use crate::tf::TransferFunction;
use rayon::prelude::*;
use serde::{Deserialize, Serialize};

/// Default target: max per-segment error (any channel) of a certified table.
pub const DEFAULT_MAX_ERROR: f64 = 1e-3;
/// Default memory a refined table may take (its entries and optical depths).
pub const DEFAULT_MEMORY_BUDGET: usize = 256 << 20;
/// Default segments per set.
pub const DEFAULT_SAMPLES: usize = 16_384;
/// Share of the target the measured max must stay under to be certified:
/// a max over 16k segments is a sample's max, and an independent sample
/// (the tests use another seed and more segments) may find a little more.
pub const CERTIFY_MARGIN: f64 = 0.75;
/// Worst segments kept per set for the refinement's diagnosis.
const WORST: usize = 64;
/// Refinement steps tried at most.
const MAX_STEPS: usize = 8;

/// What the bake certifies, in [`crate::BakeOptions::certify`].
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct CertifyOptions {
    /// Target max per-segment error; `None` bakes the given resolution as it
    /// is and measures nothing (what `tetlut bench`'s resolution sweeps do).
    pub max_error: Option<f64>,
    /// Largest table (bytes, as [`Table3d::memory_bytes`]) a refinement may bake.
    pub memory_budget: usize,
    /// Segments per measured set (≥ 1).
    pub samples: usize,
    /// Seed of the sets (the cells set is the caller's, see [`cell_triples`]).
    pub seed: u64,
}

impl Default for CertifyOptions {
    /// Target 1e-3, 256 MiB, 16 384 segments per set, seed 0xce47.
    fn default() -> Self {
        CertifyOptions {
            max_error: Some(DEFAULT_MAX_ERROR),
            memory_budget: DEFAULT_MEMORY_BUDGET,
            samples: DEFAULT_SAMPLES,
            seed: 0xce47,
        }
    }
}

impl CertifyOptions {
    /// Measures nothing: the given resolution as it is.
    pub fn off() -> Self {
        CertifyOptions { max_error: None, ..Default::default() }
    }
}

/// The measured error on one segment set.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct SetError {
    /// `cells`, `uniform` or `tf-nodes` (module docs).
    pub set: String,
    pub samples: usize,
    pub seed: u64,
    pub max: f64,
    pub rms: f64,
}

/// One table the refinement baked and measured.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Attempt {
    pub n_s: usize,
    pub n_l: usize,
    pub split_at_tf_nodes: bool,
    /// Intervals integrated exactly.
    pub exact_intervals: usize,
    pub max_error: f64,
    pub memory_bytes: u64,
}

/// What a `table3d` bake measured of itself: stored in the `.tetl` header
/// (`certificate`, format version 5) and printed by `tetlut bake/show`.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Certificate {
    /// The target asked for.
    pub target: f64,
    /// Whether `max_error` ≤ `target` × `margin` held within the memory budget.
    pub certified: bool,
    /// The largest per-segment error measured, over every set.
    pub max_error: f64,
    /// The share of the target a certified table's max stays under.
    pub margin: f64,
    /// Whether the lookup cuts segments at the TF's control points (a reader
    /// must do the same to get this figure; formats/lut.md).
    pub split_at_tf_nodes: bool,
    /// Intervals between the TF's control points inside the domain (0 is
    /// [s_lo, first node], the last [last node, s_hi]) whose segments the
    /// shader integrates exactly: every segment that meets one is exact.
    #[serde(default)]
    pub exact_intervals: Vec<usize>,
    /// How many intervals there are (control points inside the domain + 1).
    #[serde(default)]
    pub intervals: usize,
    /// Share of the measured segments integrated exactly (a cost figure:
    /// those take the exact integrator's time, not a lookup's).
    #[serde(default)]
    pub exact_share: f64,
    pub memory_budget: u64,
    pub memory_bytes: u64,
    pub sets: Vec<SetError>,
    /// Every configuration measured on the way, the last one kept.
    pub attempts: Vec<Attempt>,
    /// Why the target was not met, when it was not.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub limit: Option<String>,
}

impl Certificate {
    /// One line for people: "certified max 4.1e-4 ≤ 1e-3 (…)" or
    /// "NOT certified: max 1.8e-2 > 1e-3 …".
    pub fn summary(&self) -> String {
        let sets: Vec<String> =
            self.sets.iter().map(|s| format!("{} {:.2e} ({} seg.)", s.set, s.max, s.samples)).collect();
        let mut split = if self.split_at_tf_nodes { ", lookup split at TF nodes".to_string() } else { String::new() };
        if !self.exact_intervals.is_empty() {
            split += &format!(
                ", {} of {} TF intervals exact ({:.1}% of segments)",
                self.exact_intervals.len(),
                self.intervals,
                100.0 * self.exact_share
            );
        }
        if self.certified {
            format!("certified: max {:.2e} <= {:e} over {}{split}", self.max_error, self.target, sets.join(", "))
        } else {
            format!(
                "NOT certified: max {:.2e} > {:e} x {} within the {:.1} MiB budget ({}), over {}{split}",
                self.max_error,
                self.target,
                self.margin,
                self.memory_budget as f64 / (1u64 << 20) as f64,
                self.limit.as_deref().unwrap_or("target not met"),
                sets.join(", ")
            )
        }
    }
}

/// A `table3d` as baked: the table, how its lookup treats segments that
/// meet the TF's control points, and what the bake measured. Dereferences
/// to the [`Table3d`] (resolution, entries, reconstruction).
///
/// The control points inside the domain cut the scalar range into
/// intervals (on each, κ and ρ are linear). Two refinements may apply:
/// `split` cuts a segment at every control point it crosses, looks each
/// piece up and composites the pieces front to back; and a segment that
/// touches an interval marked `exact` is integrated exactly
/// ([`crate::integrate_segment`]) instead: where the table cannot follow
/// the TF (a ramp too steep for any grid step the budget allows, a step
/// narrower than an f32 ulp of the scalar), the method switches for
/// exactly the segments that need it.
#[derive(Debug, Clone)]
pub struct CertifiedTable3d {
    /// Boxed: a table's domain holds its quantiles (keeps `Baked` small).
    table: Box<Table3d>,
    /// The TF's control points inside the domain (f32, ascending).
    nodes: NodeIndex,
    /// Whether lookups cut segments at `nodes`.
    split: bool,
    /// Per interval (`nodes.len() + 1` of them; empty: none): integrate
    /// segments touching it exactly.
    exact_in: Vec<bool>,
    /// The TF in data units, when some interval is exact.
    /// (Boxed, as `certificate`: keeps `Baked` small.)
    exact: Option<Box<crate::method::ExactShader>>,
    certificate: Option<Box<Certificate>>,
}

impl std::ops::Deref for CertifiedTable3d {
    type Target = Table3d;
    fn deref(&self) -> &Table3d {
        &self.table
    }
}

impl CertifiedTable3d {
    /// A table with plain lookups and no certificate.
    pub fn plain(table: Table3d) -> Self {
        CertifiedTable3d {
            table: Box::new(table),
            nodes: NodeIndex::default(),
            split: false,
            exact_in: Vec::new(),
            exact: None,
            certificate: None,
        }
    }

    /// Reassembles a stored table. With a `tf` (data units), the
    /// certificate's `split_at_tf_nodes` and `exact_intervals` apply to its
    /// control points inside the table's domain; without one, or without a
    /// certificate, plain lookups. `None` when an exact interval's index is
    /// not below the interval count.
    pub fn from_parts(table: Table3d, tf: Option<&TransferFunction>, certificate: Option<Certificate>) -> Option<Self> {
        let mut t = CertifiedTable3d::plain(table);
        if let (Some(c), Some(tf)) = (&certificate, tf) {
            t.nodes = NodeIndex::new(split_nodes(tf, t.table.domain()));
            t.split = c.split_at_tf_nodes;
            if !c.exact_intervals.is_empty() {
                t.exact_in = vec![false; t.nodes.len() + 1];
                for &i in &c.exact_intervals {
                    *t.exact_in.get_mut(i)? = true;
                }
                t.exact = Some(Box::new(crate::method::ExactShader::new(tf.clone())));
            }
        }
        t.certificate = certificate.map(Box::new);
        Some(t)
    }

    pub fn table(&self) -> &Table3d {
        &self.table
    }
    pub fn into_table(self) -> Table3d {
        *self.table
    }
    pub fn certificate(&self) -> Option<&Certificate> {
        self.certificate.as_deref()
    }
    /// Whether the lookup cuts segments at TF control points.
    pub fn splits_at_tf_nodes(&self) -> bool {
        self.split && !self.nodes.is_empty()
    }
    /// Indices of the intervals between TF control points whose segments
    /// are integrated exactly.
    pub fn exact_intervals(&self) -> Vec<usize> {
        self.exact_in.iter().enumerate().filter(|(_, &e)| e).map(|(i, _)| i).collect()
    }

    /// Range of `nodes` strictly between the segment's two scalars.
    #[inline]
    fn crossed(&self, sf: f32, sb: f32) -> std::ops::Range<usize> {
        let (lo, hi) = if sf <= sb { (sf, sb) } else { (sb, sf) };
        // NaN compares false both ways: an empty range, a plain lookup.
        let i = self.nodes.count_le(lo);
        let j = self.nodes.count_lt(hi);
        i..j.max(i)
    }

    /// Whether the segment touches an exact interval: the intervals it
    /// meets are i..=j for crossed nodes i..j.
    #[inline]
    fn needs_exact(&self, r: &std::ops::Range<usize>) -> bool {
        !self.exact_in.is_empty() && self.exact_in[r.start..=r.end].iter().any(|&e| e)
    }

    /// The pieces of the segment cut at the crossed control points, front
    /// to back, as (Sf, Sb, l): each piece's length is its share of the
    /// scalar change (the scalar is linear along the segment).
    #[inline]
    fn pieces(&self, seg: &Segment, nodes: std::ops::Range<usize>, mut piece: impl FnMut(f32, f32, f32)) {
        let (sf, sb, len) = (seg.s_front, seg.s_back, seg.len_world);
        let per_scalar = len / (sb - sf).abs();
        let mut prev = sf;
        let mut cut = |x: f32| {
            piece(prev, x, (x - prev).abs() * per_scalar);
            prev = x;
        };
        let xs = &self.nodes.xs[nodes];
        if sf < sb {
            xs.iter().for_each(|&x| cut(x));
        } else {
            xs.iter().rev().for_each(|&x| cut(x));
        }
        cut(sb);
    }

    /// The segment cut at the crossed control points, each piece looked up,
    /// the pieces composited front to back (premultiplied "over").
    fn shade_split(&self, seg: &Segment, nodes: std::ops::Range<usize>) -> Rgba32 {
        let mut acc = [0.0f32; 4];
        self.pieces(seg, nodes, |a, b, l| composite_under(&mut acc, self.table.lookup(a, b, l)));
        acc[3] = acc[3].min(1.0);
        acc
    }

    /// How one segment is shaded.
    #[inline]
    fn route(&self, seg: &Segment) -> Route {
        if self.nodes.is_empty() || !seg.len_world.is_finite() {
            return Route::Plain;
        }
        let r = self.crossed(seg.s_front, seg.s_back);
        if self.needs_exact(&r) {
            // (Without the exact shader, the plain lookup, as before any
            // interval was marked.)
            return if self.exact.is_some() { Route::Exact } else { Route::Plain };
        }
        if self.split && !r.is_empty() {
            Route::Split(r)
        } else {
            Route::Plain
        }
    }

    /// One segment that is not a plain lookup: `None` when it is.
    #[inline]
    fn shade_special(&self, seg: &Segment) -> Option<Rgba32> {
        match self.route(seg) {
            Route::Plain => None,
            Route::Exact => self.exact.as_ref().map(|e| e.shade(seg)),
            Route::Split(r) => Some(self.shade_split(seg, r)),
        }
    }

    /// Whether every segment is a plain table lookup.
    fn is_plain(&self) -> bool {
        self.nodes.is_empty() || (!self.split && self.exact_in.is_empty())
    }
}

impl SegmentShader for CertifiedTable3d {
    fn method(&self) -> Method {
        Method::Table3d
    }
    fn shade(&self, seg: &Segment) -> Rgba32 {
        self.shade_special(seg).unwrap_or_else(|| self.table.shade(seg))
    }
    fn shade_span(&self, segs: &[Segment], out: &mut [Rgba32]) {
        if self.is_plain() {
            return self.table.shade_span(segs, out);
        }
        for (seg, o) in segs.iter().zip(out.iter_mut()) {
            *o = self.shade(seg);
        }
    }
    /// Plain: the table's own batch lookup. Otherwise the segments that
    /// are plain lookups go through the batch lookup together, and so do
    /// the pieces of the segments cut at control points (gathered into
    /// batches of their own, each segment's pieces composited in order
    /// afterwards: the values of [`CertifiedTable3d::shade`], as every
    /// lookup path of the table gives the same entries bit for bit); the
    /// segments of exact intervals are integrated one by one.
    fn shade_batch(&self, segs: &SegmentBatch, out: &mut [Rgba32; method::BATCH]) {
        if self.is_plain() {
            return self.table.shade_batch(segs, out);
        }
        BATCH_SCRATCH.with(|cell| match cell.try_borrow_mut() {
            Ok(mut kept) => self.shade_batch_with(segs, out, kept.get_or_insert_with(Default::default)),
            // Called again from inside a call on this thread (a shader
            // built on this one): arrays of its own.
            Err(_) => self.shade_batch_with(segs, out, &mut Box::default()),
        });
    }
}

/// [`CertifiedTable3d`]'s `shade_batch` working arrays (~5 KiB), kept per
/// thread: zeroing them on every call cost more than the lookups of a short
/// batch (a lit segment's pieces, [`SegmentShader::shade_batch`] with a few
/// segments).
struct BatchScratch {
    plain: SegmentBatch,
    slot: [usize; method::BATCH],
    cut: CutBatch,
    tmp: [Rgba32; method::BATCH],
}

impl Default for BatchScratch {
    fn default() -> Self {
        BatchScratch {
            plain: SegmentBatch::default(),
            slot: [0; method::BATCH],
            cut: CutBatch::default(),
            tmp: [[0.0; 4]; method::BATCH],
        }
    }
}

thread_local! {
    static BATCH_SCRATCH: std::cell::RefCell<Option<Box<BatchScratch>>> = const { std::cell::RefCell::new(None) };
}

impl CertifiedTable3d {
    /// `shade_batch` on working arrays `sc` (whatever they held: every
    /// entry read is written first).
    fn shade_batch_with(&self, segs: &SegmentBatch, out: &mut [Rgba32; method::BATCH], sc: &mut BatchScratch) {
        let n = segs.len.min(method::BATCH);
        let BatchScratch { plain, slot, cut, tmp } = sc;
        plain.len = 0;
        (cut.pieces.len, cut.segs) = (0, 0);
        for i in 0..n {
            let seg = segs.get(i);
            match self.route(&seg) {
                Route::Plain => {
                    slot[plain.len] = i;
                    plain.push(seg);
                }
                Route::Exact => out[i] = self.exact.as_ref().map_or([0.0; 4], |e| e.shade(&seg)),
                Route::Split(r) if r.len() < method::BATCH => {
                    if cut.pieces.len + r.len() + 1 > method::BATCH {
                        cut.shade(&self.table, out, tmp);
                    }
                    cut.owners[cut.segs] = (i, cut.pieces.len);
                    cut.segs += 1;
                    // (Room for r.len() + 1 pieces was made just above.)
                    let pieces = &mut cut.pieces;
                    self.pieces(&seg, r, |a, b, l| {
                        let _room = pieces.push(Segment { s_front: a, s_back: b, len_world: l, ..Default::default() });
                    });
                }
                // More pieces than a batch holds: one by one.
                Route::Split(r) => out[i] = self.shade_split(&seg, r),
            }
        }
        cut.shade(&self.table, out, tmp);
        if plain.len > 0 {
            self.table.shade_batch(plain, tmp);
            for k in 0..plain.len {
                out[slot[k]] = tmp[k];
            }
        }
    }
}

/// How [`CertifiedTable3d`] shades a segment.
enum Route {
    /// One table lookup.
    Plain,
    /// Integrated exactly (it touches an exact interval).
    Exact,
    /// Cut at the control points it crosses (these), a lookup a piece.
    Split(std::ops::Range<usize>),
}

/// `acc` over … : the premultiplied colour `c` composited under `acc`.
#[inline]
fn composite_under(acc: &mut [f32; 4], c: Rgba32) {
    let t = 1.0 - acc[3];
    for k in 0..4 {
        acc[k] += t * c[k];
    }
}

/// The pieces of cut segments waiting for one batched lookup, and for
/// each of those segments its index in the caller's batch and its first
/// piece (its pieces run to the next segment's first).
struct CutBatch {
    pieces: SegmentBatch,
    owners: [(usize, usize); method::BATCH],
    segs: usize,
}

impl Default for CutBatch {
    fn default() -> Self {
        CutBatch { pieces: SegmentBatch::default(), owners: [(0, 0); method::BATCH], segs: 0 }
    }
}

impl CutBatch {
    /// Looks the pieces up and composites each segment's in order into
    /// `out` (as `CertifiedTable3d::shade_split`), then empties; `rgba`
    /// holds the pieces' colours (any contents on entry).
    fn shade(&mut self, table: &Table3d, out: &mut [Rgba32; method::BATCH], rgba: &mut [Rgba32; method::BATCH]) {
        if self.segs == 0 {
            return;
        }
        table.shade_batch(&self.pieces, rgba);
        for k in 0..self.segs {
            let (i, first) = self.owners[k];
            let end = if k + 1 < self.segs { self.owners[k + 1].1 } else { self.pieces.len };
            let mut acc = [0.0f32; 4];
            rgba[first..end].iter().for_each(|&c| composite_under(&mut acc, c));
            acc[3] = acc[3].min(1.0);
            out[i] = acc;
        }
        self.pieces.len = 0;
        self.segs = 0;
    }
}

/// Sorted control points with an O(1) start for counting those at or
/// below a scalar: every segment a certified table shades asks which
/// control points lie between its two scalars, and a binary search over a
/// few dozen of them per segment cost a tenth of a frame (the automatic
/// TF of Blunt Fin, 82 nodes). Buckets of a uniform partition of the
/// nodes' span hold how many nodes lie below their start; a count starts
/// there and scans to the exact answer both ways, so bucket rounding
/// never changes a result.
#[derive(Debug, Clone, Default)]
struct NodeIndex {
    xs: Vec<f32>,
    /// Per bucket: the nodes below its start (a guess the scans correct).
    below: Vec<u32>,
    lo: f32,
    /// Buckets per scalar unit (0 for a single node).
    inv: f32,
}

/// Buckets per node of a [`NodeIndex`].
const BUCKETS_PER_NODE: usize = 8;

impl NodeIndex {
    fn new(xs: Vec<f32>) -> NodeIndex {
        let (Some(&lo), Some(&hi)) = (xs.first(), xs.last()) else { return NodeIndex::default() };
        let nb = BUCKETS_PER_NODE * xs.len();
        let span = hi as f64 - lo as f64;
        let inv = if span > 0.0 { (nb as f64 / span) as f32 } else { 0.0 };
        let below = (0..nb)
            .map(|b| {
                let start = lo as f64 + b as f64 * span / nb as f64;
                xs.partition_point(|&x| (x as f64) < start) as u32
            })
            .collect();
        NodeIndex { xs, below, lo, inv }
    }

    fn len(&self) -> usize {
        self.xs.len()
    }

    fn is_empty(&self) -> bool {
        self.xs.is_empty()
    }

    /// Where a count for `x` starts (NaN and below the span: bucket 0; the
    /// casts saturate).
    #[inline]
    fn guess(&self, x: f32) -> usize {
        let b = (((x - self.lo) * self.inv) as usize).min(self.below.len().saturating_sub(1));
        self.below.get(b).map_or(0, |&c| c as usize)
    }

    /// How many nodes are ≤ x: `xs.partition_point(|&n| n <= x)` (0 for NaN).
    #[inline]
    fn count_le(&self, x: f32) -> usize {
        let mut i = self.guess(x);
        while i > 0 && self.xs[i - 1] > x {
            i -= 1;
        }
        while i < self.xs.len() && self.xs[i] <= x {
            i += 1;
        }
        i
    }

    /// How many nodes are < x: `xs.partition_point(|&n| n < x)` (0 for NaN).
    #[inline]
    fn count_lt(&self, x: f32) -> usize {
        let mut i = self.guess(x);
        while i > 0 && self.xs[i - 1] >= x {
            i -= 1;
        }
        while i < self.xs.len() && self.xs[i] < x {
            i += 1;
        }
        i
    }
}

/// The TF's colour and opacity control points strictly inside the domain's
/// scalar range, as f32, ascending, without duplicates.
pub fn split_nodes(tf: &TransferFunction, domain: &TableDomain) -> Vec<f32> {
    let mut v: Vec<f32> = tf
        .color_nodes()
        .iter()
        .map(|c| c.x)
        .chain(tf.opacity_nodes().iter().map(|o| o.x))
        .filter(|&x| x > domain.s_lo && x < domain.s_hi)
        .map(|x| x as f32)
        .collect();
    v.sort_unstable_by(f32::total_cmp);
    v.dedup();
    v
}

/// The deterministic generator of [`crate::uniform_triples`] (LCG, top 53 bits).
fn unit_rng(seed: u64) -> impl FnMut() -> f64 {
    crate::lcg_unit(seed ^ 0x9e37_79b9_7f4a_7c15)
}

/// About `count` segments near the TF's control points inside the domain
/// (module docs), from `seed`; empty when the TF has none inside. Every
/// triple lies in the band: Sf, Sb in range, |Sf − Sb| ≤ max_ds, l ≤ l_max.
pub fn node_triples(tf: &TransferFunction, domain: &TableDomain, count: usize, seed: u64) -> Vec<[f32; 3]> {
    let nodes: Vec<f64> = split_nodes(tf, domain).iter().map(|&x| f64::from(x)).collect();
    if nodes.is_empty() || count == 0 {
        return Vec::new();
    }
    let mut next = unit_rng(seed);
    let reach = domain.max_ds.min(domain.scalar_span());
    let per = count.div_ceil(nodes.len());
    let mut out = Vec::with_capacity(per * nodes.len());
    for &x0 in &nodes {
        for _ in 0..per {
            // Offsets from the whole band down to 1e-5 of it, log-uniform.
            let r = reach * 10f64.powf(-5.0 * next());
            let kind = next();
            let (mut f, mut b) = if kind < 0.5 {
                (x0 - r * next(), x0 + r * next())
            } else if kind < 0.75 {
                (x0, x0 + if next() < 0.5 { -r } else { r })
            } else {
                let sgn = if next() < 0.5 { -1.0 } else { 1.0 };
                (x0 + sgn * r * next(), x0 + sgn * r * next())
            };
            if next() < 0.5 {
                std::mem::swap(&mut f, &mut b);
            }
            let f = f.clamp(domain.s_lo, domain.s_hi);
            let b = b.clamp(domain.s_lo, domain.s_hi).clamp(f - domain.max_ds, f + domain.max_ds);
            let l = if next() < 0.5 {
                domain.len_max_world * next()
            } else {
                domain.len_max_world * 10f64.powf(-4.0 * next())
            };
            out.push([f as f32, b as f32, l as f32]);
        }
    }
    out
}

/// `count` segments through `bundle`'s cells (random rays through random
/// cells, the bundle's own segment distribution) from `seed`, clamped into
/// `domain`'s band as the lookup clamps them.
pub fn cell_triples(bundle: &tet_bundle::Bundle, domain: &TableDomain, count: usize, seed: u64) -> Vec<[f32; 3]> {
    let m = &bundle.mesh;
    tet_analysis::sample_cell_segments(&m.points, &m.tets, &m.scalar, None, count, seed)
        .into_iter()
        .map(|s| {
            let f = s.s_front.clamp(domain.s_lo, domain.s_hi);
            let b = s.s_back.clamp(domain.s_lo, domain.s_hi).clamp(f - domain.max_ds, f + domain.max_ds);
            [f as f32, b as f32, s.len_world.clamp(0.0, domain.len_max_world) as f32]
        })
        .collect()
}

/// The per-segment error measure: the largest |channel − exact|.
fn segment_error(shader: &dyn SegmentShader, tf: &TransferFunction, t: &[f32; 3], scratch: &mut Vec<f64>) -> f64 {
    let seg = Segment { s_front: t[0], s_back: t[1], len_world: t[2], ..Default::default() };
    let got = shader.shade(&seg);
    let want = integrate_segment_with(tf, f64::from(t[0]), f64::from(t[1]), f64::from(t[2]).max(0.0), scratch);
    got.iter().zip(want.to_array()).map(|(g, w)| (f64::from(*g) - w).abs()).fold(0.0, f64::max)
}

/// (max, RMS over the per-segment errors, the [`WORST`] worst) of `shader` on `triples`.
fn measure(
    shader: &dyn SegmentShader,
    tf: &TransferFunction,
    triples: &[[f32; 3]],
) -> (f64, f64, Vec<([f32; 3], f64)>) {
    if triples.is_empty() {
        return (0.0, 0.0, Vec::new());
    }
    let keep = |mut v: Vec<([f32; 3], f64)>| {
        v.sort_unstable_by(|a, b| b.1.total_cmp(&a.1));
        v.truncate(WORST);
        v
    };
    let (sum, worst) = triples
        .par_chunks(1024)
        .map(|chunk| {
            let mut scratch = Vec::new();
            let mut sum = 0.0;
            let mut v = Vec::with_capacity(chunk.len());
            for t in chunk {
                let e = segment_error(shader, tf, t, &mut scratch);
                // NaN (never expected) counts as the worst possible.
                let e = if e.is_nan() { f64::INFINITY } else { e };
                sum += e * e;
                v.push((*t, e));
            }
            (sum, keep(v))
        })
        .reduce(
            || (0.0, Vec::new()),
            |a, b| {
                let mut w = a.1;
                w.extend(b.1);
                (a.0 + b.0, keep(w))
            },
        );
    (worst.first().map_or(0.0, |w| w.1), (sum / triples.len() as f64).sqrt(), worst)
}

/// A named, seeded segment set.
struct Set {
    name: &'static str,
    seed: u64,
    triples: Vec<[f32; 3]>,
}

/// The sets a bake measures: `cells` (when given), `uniform`, `tf-nodes`.
fn sets(tf: &TransferFunction, domain: &TableDomain, opts: &CertifyOptions, cells: &[[f32; 3]]) -> Vec<Set> {
    let n = opts.samples.max(1);
    let mut out = Vec::new();
    if !cells.is_empty() {
        // Every k-th: an even subsample of the caller's (already random) set.
        let step = cells.len().div_ceil(n);
        out.push(Set { name: "cells", seed: 0, triples: cells.iter().step_by(step).copied().collect() });
    }
    out.push(Set { name: "uniform", seed: opts.seed, triples: uniform_triples(domain, n, opts.seed) });
    let nodes = node_triples(tf, domain, n, opts.seed ^ 0x6e6f_6465);
    if !nodes.is_empty() {
        out.push(Set { name: "tf-nodes", seed: opts.seed ^ 0x6e6f_6465, triples: nodes });
    }
    out
}

/// Measures `shader` on every set: the per-set figures and all sets' worst.
fn measure_sets(shader: &dyn SegmentShader, tf: &TransferFunction, sets: &[Set]) -> (Vec<SetError>, Vec<[f32; 3]>) {
    let mut errors = Vec::new();
    let mut worst = Vec::new();
    for s in sets {
        let (max, rms, w) = measure(shader, tf, &s.triples);
        errors.push(SetError { set: s.name.into(), samples: s.triples.len(), seed: s.seed, max, rms });
        worst.extend(w);
    }
    worst.sort_unstable_by(|a, b| b.1.total_cmp(&a.1));
    worst.truncate(WORST);
    (errors, worst.into_iter().map(|w| w.0).collect())
}

fn max_of(errors: &[SetError]) -> f64 {
    errors.iter().map(|e| e.max).fold(0.0, f64::max)
}

/// Re-measures `shader` on fresh segments: `uniform` and `tf-nodes` from
/// another `seed` (and the caller's cells, when given), `samples` each.
/// What the tests use to check a certificate independently.
pub fn remeasure(
    shader: &dyn SegmentShader,
    tf: &TransferFunction,
    domain: &TableDomain,
    samples: usize,
    seed: u64,
    cells: &[[f32; 3]],
) -> Vec<SetError> {
    let opts = CertifyOptions { samples, seed, ..Default::default() };
    measure_sets(shader, tf, &sets(tf, domain, &opts, cells)).0
}

/// How much of the worst segments' error the l interpolation explains:
/// the error with Sf and Sb snapped to the nearest grid scalar (only l is
/// interpolated then) over the error as measured, the largest ratio of
/// the two maxima.
fn l_share(shader: &dyn SegmentShader, table: &Table3d, tf: &TransferFunction, worst: &[[f32; 3]]) -> f64 {
    let n = table.params().n_s;
    let grid: Vec<f64> = (0..n).map(|a| table.scalar_at(a)).collect();
    let snap = |s: f32| {
        let s = f64::from(s);
        let i = grid.partition_point(|&g| g < s).min(n - 1);
        let j = i.saturating_sub(1);
        (if (grid[i] - s).abs() < (s - grid[j]).abs() { grid[i] } else { grid[j] }) as f32
    };
    let mut scratch = Vec::new();
    let (mut total, mut along_l) = (0.0f64, 0.0f64);
    for t in worst {
        total = total.max(segment_error(shader, tf, t, &mut scratch));
        let mut s = [snap(t[0]), snap(t[1]), t[2]];
        // Keep the snapped pair in the band (the lookup would clamp it).
        let ds = table.domain().max_ds as f32;
        s[1] = s[1].clamp(s[0] - ds, s[0] + ds);
        along_l = along_l.max(segment_error(shader, tf, &s, &mut scratch));
    }
    if total > 0.0 {
        along_l / total
    } else {
        0.0
    }
}

/// Steepness of each interval between the TF's control points `nodes`
/// (intervals 0..=nodes.len(), the outer ones to the domain's ends): how
/// fast extinction, and colour weighted by extinction, change per scalar
/// unit. Which interval of a long failing segment to integrate exactly.
fn steepness(tf: &TransferFunction, domain: &TableDomain, nodes: &[f32]) -> Vec<f64> {
    let mut xs = vec![domain.s_lo];
    xs.extend(nodes.iter().map(|&x| f64::from(x)));
    xs.push(domain.s_hi);
    xs.windows(2)
        .map(|w| {
            let (a, b) = (w[0], w[1]);
            let (ra, rb) = (tf.extinction(a), tf.extinction(b));
            let (ca, cb) = (tf.color(a), tf.color(b));
            let dc = (0..3).map(|k| (ca[k] - cb[k]).abs()).fold(0.0, f64::max);
            ((ra - rb).abs() + dc * ra.max(rb)) / (b - a).max(f64::MIN_POSITIVE)
        })
        .collect()
}

/// Segments of `sets` on which `shader` errs by more than `goal` (at most
/// 1 << 16 of them, in set order).
fn failing(shader: &dyn SegmentShader, tf: &TransferFunction, sets: &[Set], goal: f64) -> Vec<[f32; 3]> {
    let mut out = Vec::new();
    for s in sets {
        out.par_extend(s.triples.par_chunks(1024).flat_map_iter(|chunk| {
            let mut scratch = Vec::new();
            chunk
                .iter()
                .filter(|t| {
                    let e = segment_error(shader, tf, t, &mut scratch);
                    e.is_nan() || e > goal
                })
                .copied()
                .collect::<Vec<_>>()
        }));
        if out.len() >= 1 << 16 {
            out.truncate(1 << 16);
            break;
        }
    }
    out
}

/// Marks for exact integration the intervals the `failing` segments need:
/// per segment the steepest interval it meets (the next round re-measures
/// and marks more if needed, so a few steep intervals do not drag their
/// gentle neighbours onto the slow path). Returns how many intervals
/// were newly marked.
fn mark_exact(t: &mut CertifiedTable3d, steep: &[f64], failing: &[[f32; 3]]) -> usize {
    if t.exact_in.is_empty() {
        t.exact_in = vec![false; t.nodes.len() + 1];
    }
    let mut marked = 0;
    for f in failing {
        let r = t.crossed(f[0], f[1]);
        if t.needs_exact(&r) {
            continue;
        }
        let k = (r.start..=r.end).max_by(|&a, &b| steep[a].total_cmp(&steep[b])).expect("non-empty");
        t.exact_in[k] = true;
        marked += 1;
    }
    marked
}

/// Share of `sets`' segments that `t` integrates exactly.
fn exact_share(t: &CertifiedTable3d, sets: &[Set]) -> f64 {
    let (mut n, mut e) = (0usize, 0usize);
    for s in sets {
        n += s.triples.len();
        e += s.triples.iter().filter(|x| t.needs_exact(&t.crossed(x[0], x[1]))).count();
    }
    if n == 0 {
        0.0
    } else {
        e as f64 / n as f64
    }
}

/// Bakes a `table3d` for `tf` (data units) over `domain`, starting at
/// `params` and refined until its measured error meets `opts.max_error` or
/// the memory budget is spent (module docs). `cells`: segments through the
/// bundle's cells (may be empty). With `opts.max_error = None`, the table
/// at `params` with plain lookups and no certificate.
pub fn bake(
    tf: &TransferFunction,
    domain: &TableDomain,
    params: &Table3dParams,
    opts: &CertifyOptions,
    cells: &[[f32; 3]],
) -> Result<CertifiedTable3d, TableError> {
    let Some(target) = opts.max_error else {
        return Ok(CertifiedTable3d::plain(Table3d::build(tf, domain, params)?));
    };
    if !(target.is_finite() && target > 0.0) {
        return Err(TableError::Invalid(format!("certify target max error {target}: must be positive and finite")));
    }
    let sets = sets(tf, domain, opts, cells);
    let nodes = split_nodes(tf, domain);
    let steep = steepness(tf, domain, &nodes);
    let goal = target * CERTIFY_MARGIN;
    let mut params = *params;
    let mut attempts: Vec<Attempt> = Vec::new();
    let mut table = CertifiedTable3d {
        nodes: NodeIndex::new(nodes.clone()),
        ..CertifiedTable3d::plain(Table3d::build(tf, domain, &params)?)
    };
    let over_budget = table.memory_bytes() > opts.memory_budget;
    let record = |t: &CertifiedTable3d, errors: &[SetError], attempts: &mut Vec<Attempt>| {
        attempts.push(Attempt {
            n_s: t.params().n_s,
            n_l: t.params().n_l,
            split_at_tf_nodes: t.splits_at_tf_nodes(),
            exact_intervals: t.exact_intervals().len(),
            max_error: max_of(errors),
            memory_bytes: t.memory_bytes() as u64,
        });
    };
    let (mut errors, mut worst) = measure_sets(&table, tf, &sets);
    record(&table, &errors, &mut attempts);
    let (mut grown, mut tried_split) = (0, false);
    while max_of(&errors) > goal && !over_budget {
        // 1. The same entries, looked up piece by piece between the TF's nodes.
        if !tried_split && !nodes.is_empty() {
            tried_split = true;
            let cut = CertifiedTable3d { split: true, ..table.clone() };
            let (e2, w2) = measure_sets(&cut, tf, &sets);
            record(&cut, &e2, &mut attempts);
            if max_of(&e2) < max_of(&errors) {
                (table, errors, worst) = (cut, e2, w2);
            }
            continue;
        }
        // 2. Exact integration for the segments of the intervals the table
        //    cannot follow (no re-bake; a few rounds, each re-measured).
        if !nodes.is_empty() || table.exact_in.is_empty() {
            let fail = failing(&table, tf, &sets, goal);
            let mut t = table.clone();
            if nodes.is_empty() {
                // One interval, the whole range: the table is no help at all.
                t.exact_in = vec![true];
            } else if mark_exact(&mut t, &steep, &fail) == 0 {
                // Nothing new to switch: the failing segments are exact
                // already (a target below f32 rounding) — fall through.
                t.exact_in.clear();
            }
            if !t.exact_in.is_empty() {
                t.exact = Some(Box::new(crate::method::ExactShader::new(tf.clone())));
                let (e2, w2) = measure_sets(&t, tf, &sets);
                record(&t, &e2, &mut attempts);
                (table, errors, worst) = (t, e2, w2);
                if t_all_exact(&table) {
                    break;
                }
                continue;
            }
        }
        // 3. A finer table, on the axis the worst segments blame.
        if grown >= MAX_STEPS {
            break;
        }
        let mem = table.memory_bytes();
        let share = l_share(&table, &table, tf, &worst);
        let grow_s = ((params.n_s as f64 * std::f64::consts::SQRT_2).round() as usize).min(MAX_AXIS);
        let grow_l = (params.n_l * 2).min(MAX_AXIS);
        // Stored pairs grow about as n_s² (the band's width is in steps).
        let predict = |n_s: usize, n_l: usize| {
            mem as f64 * (n_s as f64 / params.n_s as f64).powi(2) * (n_l as f64 / params.n_l as f64)
        };
        let fits = |n_s: usize, n_l: usize| {
            (n_s, n_l) != (params.n_s, params.n_l) && predict(n_s, n_l) <= opts.memory_budget as f64
        };
        let (first, second) = if share >= 0.5 {
            ((params.n_s, grow_l), (grow_s, params.n_l))
        } else {
            ((grow_s, params.n_l), (params.n_s, grow_l))
        };
        let next = if fits(first.0, first.1) {
            first
        } else if fits(second.0, second.1) {
            second
        } else {
            break;
        };
        (params.n_s, params.n_l) = next;
        grown += 1;
        let t = CertifiedTable3d { table: Box::new(Table3d::build(tf, domain, &params)?), ..table.clone() };
        let (e2, w2) = measure_sets(&t, tf, &sets);
        record(&t, &e2, &mut attempts);
        (table, errors, worst) = (t, e2, w2);
    }
    let max = max_of(&errors);
    let certified = max <= goal && !over_budget;
    let limit = if over_budget {
        Some(format!(
            "the starting table takes {} bytes, more than the memory budget of {}",
            table.memory_bytes(),
            opts.memory_budget
        ))
    } else if !certified {
        Some("no refinement within the memory budget brings the error to the target".into())
    } else {
        None
    };
    table.certificate = Some(Box::new(Certificate {
        target,
        certified,
        max_error: max,
        margin: CERTIFY_MARGIN,
        split_at_tf_nodes: table.splits_at_tf_nodes(),
        exact_intervals: table.exact_intervals(),
        intervals: nodes.len() + 1,
        exact_share: exact_share(&table, &sets),
        memory_budget: opts.memory_budget as u64,
        memory_bytes: table.memory_bytes() as u64,
        sets: errors,
        attempts,
        limit,
    }));
    Ok(table)
}

/// Whether every interval is integrated exactly (nothing left to switch).
fn t_all_exact(t: &CertifiedTable3d) -> bool {
    !t.exact_in.is_empty() && t.exact_in.iter().all(|&e| e)
}

/// The `k` (at most 64) worst of `triples` for `shader`, worst first, with
/// their errors: for diagnosis (`crates/tet_preint/examples/certify_heldout.rs`).
pub fn worst_segments(
    shader: &dyn SegmentShader,
    tf: &TransferFunction,
    triples: &[[f32; 3]],
    k: usize,
) -> Vec<([f32; 3], f64)> {
    let mut w = measure(shader, tf, triples).2;
    w.truncate(k);
    w
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A batch shaded while this thread's kept arrays are in use (a shader
    /// built on this one, calling it from inside its own call) gets arrays
    /// of its own and the same colours; calls after reuse the kept ones
    /// whatever an earlier, longer batch left in them.
    #[test]
    fn batches_agree_with_shade_whoever_holds_the_scratch() {
        let d = TableDomain::new(0.0, 1.0, 0.5, 2.0).unwrap();
        let tf = TransferFunction::from_json(
            r#"{"color": [[0, 1, 0, 0], [1, 0, 0, 1]], "opacity": [[0, 0.1], [0.3, 4], [0.31, 0.1], [0.7, 2], [1, 0.2]], "unit_distance": 1}"#,
        )
        .unwrap();
        let params = Table3dParams { n_s: 32, n_l: 32, ..Table3dParams::data() };
        let certificate = Certificate {
            target: 1e-3,
            certified: false,
            max_error: 1.0,
            margin: 0.9,
            split_at_tf_nodes: true,
            exact_intervals: vec![1],
            intervals: 4,
            exact_share: 0.0,
            memory_budget: 0,
            memory_bytes: 0,
            sets: Vec::new(),
            attempts: Vec::new(),
            limit: None,
        };
        let t = CertifiedTable3d::from_parts(Table3d::build(&tf, &d, &params).unwrap(), Some(&tf), Some(certificate))
            .unwrap();
        assert!(!t.is_plain());
        let segs: Vec<Segment> = (0..100)
            .map(|k| {
                let a = (k * 37 % 100) as f32 / 100.0;
                let b = (a + [0.02, -0.2, 0.45][k % 3]).clamp(0.0, 1.0);
                Segment { s_front: a, s_back: b, len_world: 0.1 + (k % 5) as f32 * 0.3, ..Default::default() }
            })
            .collect();
        let check = |chunk: &[Segment]| {
            let mut out = [[0.0f32; 4]; method::BATCH];
            t.shade_batch(&SegmentBatch::from_segments(chunk), &mut out);
            for (i, s) in chunk.iter().enumerate() {
                assert_eq!(out[i], t.shade(s), "{s:?}");
            }
        };
        // A full batch, then shorter ones on the arrays it left.
        for len in [64, 36, 3, 1] {
            check(&segs[100 - len..]);
        }
        BATCH_SCRATCH.with(|cell| {
            let _held = cell.borrow_mut();
            check(&segs[..64]);
            check(&segs[10..20]);
        });
    }
    use super::NodeIndex;
    use proptest::prelude::*;

    /// Sorted, distinct f32 nodes from raw draws (clustered when `tight`).
    fn nodes(raw: &[f32], tight: bool) -> Vec<f32> {
        let mut v: Vec<f32> = raw.iter().map(|&x| if tight { 0.5 + x * 1e-6 } else { x }).collect();
        v.sort_unstable_by(f32::total_cmp);
        v.dedup();
        v
    }

    proptest! {
        #![proptest_config(ProptestConfig { cases: 256, rng_seed: proptest::test_runner::RngSeed::Fixed(0x0de5), ..ProptestConfig::default() })]

        /// The bucketed counts are the binary searches' counts for any
        /// query: on nodes, an ulp beside them, outside the span, ±∞, NaN.
        #[test]
        fn node_counts_equal_binary_search(
            raw in prop::collection::vec(-2.0f32..3.0, 0..100),
            tight in any::<bool>(),
            queries in prop::collection::vec(-3.0f32..4.0, 1..40),
            pick in prop::collection::vec(any::<u16>(), 1..40),
        ) {
            let xs = nodes(&raw, tight);
            let index = NodeIndex::new(xs.clone());
            let mut qs = queries.clone();
            qs.extend([f32::NAN, f32::INFINITY, f32::NEG_INFINITY, 0.5, -0.0, 0.0]);
            for &p in &pick {
                if let Some(&x) = xs.get(p as usize % xs.len().max(1)) {
                    qs.extend([x, x.next_up(), x.next_down()]);
                }
            }
            for &q in &qs {
                prop_assert_eq!(index.count_le(q), xs.partition_point(|&x| x <= q), "≤ {} in {:?}", q, xs);
                prop_assert_eq!(index.count_lt(q), xs.partition_point(|&x| x < q), "< {} in {:?}", q, xs);
            }
        }
    }
}
