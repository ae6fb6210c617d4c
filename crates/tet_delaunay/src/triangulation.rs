//! Incremental Bowyer–Watson on compact arrays with an infinite vertex.
//!
//! Every tet is four vertex ids and four neighbour ids (neighbour `i` lies
//! across the face opposite vertex `i`), packed in 32 bytes. The convex
//! hull is closed by ghost tets that have the infinite vertex [`INF`] in
//! place of a fourth point, so the structure is a triangulation of the whole
//! 3-sphere: every face has exactly two tets and points outside the hull are
//! located and inserted like any other (no bounding super-tetrahedron whose
//! removal would lose hull tets).
//!
//! Orientation contract: a finite tet is positive in tetkit's convention; a
//! ghost tet is positive when replacing [`INF`] by a point beyond its hull
//! facet gives a positive tet. Replacing a vertex of a conflict tet by the
//! new point keeps both true, so new tets need no orientation test.
//!
//! Vertex ids here are positions in insertion order (so that consecutive
//! insertions touch nearby memory); `orig` maps them back to input ids, which
//! key the symbolic perturbation so that ties do not depend on the order.
//!
//! Storage is atomic (`Relaxed` loads and stores, plain moves on x86) so
//! that one [`Inserter`] serves both the sequential path and the parallel
//! rounds of [`crate::parallel`], which share the tets without copying
//! them; the concurrency contract is documented there. Sequentially an
//! `Inserter` owns every vertex and never defers.

use crate::predicates::{in_sphere_tie, orient, StaticFilter};
use crate::sort::SplitMix64;
use std::sync::atomic::{AtomicU32, AtomicUsize, Ordering::Relaxed};

/// The infinite vertex.
pub(crate) const INF: u32 = u32::MAX;
/// Vertex slot 0 of a freed (or never used) tet.
pub(crate) const DEAD: u32 = u32::MAX - 1;
/// Vertex slot 0 of a tet in worker `w`'s current conflict zone is
/// `IN_CAVITY - w`. Vertex ids stay below `MAX_POINTS` (2^29), far below.
const IN_CAVITY: u32 = u32::MAX - 2;
/// Most workers of one parallel round (their cavity markers must not
/// collide with anything else).
pub(crate) const MAX_WORKERS: usize = 64;
const EMPTY: u64 = u64::MAX;
/// Unassigned entry of `Inserter::local`.
const NO_LOCAL: u8 = u8::MAX;
/// Largest cavity boundary (in vertices) linked through the dense matrix;
/// larger ones go through a hash table.
const DENSE_MAX: usize = 64;

/// For a new tet with the new point in slot `i`, the face opposite slot
/// `j ≠ i` holds the new point and the edge `(v[x], v[y])` with
/// `(x, y) = EDGE[i][j]`, directed so that the tet across that face holds
/// the same edge reversed. (The faces (1,2,3), (0,3,2), (0,1,3), (0,2,1)
/// are consistently oriented, ghosts included, and two tets sharing a
/// face see it in opposite orders; rotating the face so `i` comes first
/// leaves the edge.)
const EDGE: [[(usize, usize); 4]; 4] = [
    [(0, 0), (3, 2), (1, 3), (2, 1)],
    [(2, 3), (0, 0), (3, 0), (0, 2)],
    [(3, 1), (0, 3), (0, 0), (1, 0)],
    [(1, 2), (2, 0), (0, 1), (0, 0)],
];

/// A face of the cavity: the new tet built on it and the outside tet.
#[derive(Debug, Clone, Copy)]
struct Boundary {
    /// The new tet's vertices (the new point in `slot`).
    v: [u32; 4],
    outside: u32,
    slot: u8,
    /// The outside tet's neighbour slot that faces the cavity.
    back: u8,
    /// Local ids of `v` (all but `slot`) for the dense edge matrix.
    local: [u8; 4],
}

/// A tet's contents, read or to be written in one go.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(crate) struct Tet {
    pub(crate) v: [u32; 4],
    pub(crate) n: [u32; 4],
}

const DEAD_TET: Tet = Tet { v: [DEAD; 4], n: [u32::MAX; 4] };

/// A tet in shared memory. Aligned so that it never straddles two cache
/// lines: the flood fill touches dozens of scattered neighbours per
/// insertion.
#[derive(Debug)]
#[repr(C, align(32))]
pub(crate) struct AtomicTet {
    v: [AtomicU32; 4],
    n: [AtomicU32; 4],
}

impl AtomicTet {
    pub(crate) fn new(t: Tet) -> Self {
        AtomicTet { v: t.v.map(AtomicU32::new), n: t.n.map(AtomicU32::new) }
    }
    #[inline(always)]
    pub(crate) fn load(&self) -> Tet {
        Tet { v: [0, 1, 2, 3].map(|k| self.v[k].load(Relaxed)), n: [0, 1, 2, 3].map(|k| self.n[k].load(Relaxed)) }
    }
    #[inline(always)]
    pub(crate) fn store(&self, t: Tet) {
        for k in 0..4 {
            self.v[k].store(t.v[k], Relaxed);
            self.n[k].store(t.n[k], Relaxed);
        }
    }
    #[cfg(test)]
    pub(crate) fn v0(&self) -> u32 {
        self.v[0].load(Relaxed)
    }
    #[inline(always)]
    fn set_v0(&self, x: u32) {
        self.v[0].store(x, Relaxed)
    }
    #[inline(always)]
    fn set_n(&self, i: usize, x: u32) {
        self.n[i].store(x, Relaxed)
    }
}

#[inline]
pub(crate) fn is_ghost(v: &[u32; 4]) -> bool {
    v[0] == INF || v[1] == INF || v[2] == INF || v[3] == INF
}

/// Why an insertion was put off (parallel rounds only; a sequential
/// inserter only ever runs out of slots).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(crate) enum Deferred {
    /// The walk or the conflict zone reached a tet with a vertex another
    /// worker owns.
    Foreign,
    /// The walk exceeded its step limit.
    LongWalk,
    /// No free or fresh tet slot was left for the new tets.
    OutOfSlots,
}

pub(crate) struct Triangulation {
    /// Points in insertion order.
    pub(crate) pts: Vec<[f64; 3]>,
    /// Error bounds for the predicates' fast paths on `pts`.
    pub(crate) filter: StaticFilter,
    /// Input id of each point.
    pub(crate) orig: Vec<u32>,
    /// Tet slots, all initialised; `0..used` have been handed out (live or
    /// freed), the rest are fresh.
    pub(crate) tets: Vec<AtomicTet>,
    pub(crate) used: usize,
    /// Freed slots below `used`.
    pub(crate) free: Vec<u32>,
    /// A live finite tet near the last inserted point: where walks start.
    pub(crate) last: u32,
    /// Walks that hit the step limit and fell back to a full scan.
    pub(crate) walk_fallbacks: usize,
}

impl Triangulation {
    /// Starts from points 0..4 (a positive tet) and its four ghosts, with
    /// room for the tets a random set of that size needs (more are added
    /// when needed).
    pub(crate) fn new(pts: Vec<[f64; 3]>, orig: Vec<u32>) -> Self {
        debug_assert!(orient(&pts[0], &pts[1], &pts[2], &pts[3]) > 0.0);
        // ~6.7 finite tets per random point plus ghosts; a little more
        // avoids growing on typical inputs, and growth doubles otherwise.
        let capacity = pts.len().saturating_mul(29) / 4 + 16 * crate::parallel::BLOCK;
        let mut t = Triangulation {
            filter: StaticFilter::new(&pts),
            pts,
            orig,
            tets: Vec::new(),
            used: 5,
            free: Vec::new(),
            last: 0,
            walk_fallbacks: 0,
        };
        t.grow_to(capacity);
        // Ghost i replaces vertex i by INF and swaps two other vertices:
        // beyond face i is the other side from vertex i, so the odd
        // permutation restores the positive ghost orientation.
        let mut first = [DEAD_TET; 5];
        for (i, tet) in first.iter_mut().enumerate() {
            let mut v = [0, 1, 2, 3];
            if i > 0 {
                v[i - 1] = INF;
                v.swap(i % 4, (i + 1) % 4);
            }
            tet.v = v;
        }
        link_small(&mut first);
        for (k, tet) in first.into_iter().enumerate() {
            t.tets[k].store(tet);
        }
        t
    }

    /// Makes at least `len` slots exist, fresh ones dead. Large arrays are
    /// initialised on all threads: the first touch of each page is most of
    /// the cost.
    pub(crate) fn grow_to(&mut self, len: usize) {
        use rayon::prelude::*;
        if len <= self.tets.len() {
            return;
        }
        let add = len - self.tets.len();
        self.tets.reserve_exact(add);
        if add >= 1 << 16 {
            self.tets.par_extend((0..add).into_par_iter().map(|_| AtomicTet::new(DEAD_TET)));
        } else {
            self.tets.extend((0..add).map(|_| AtomicTet::new(DEAD_TET)));
        }
    }

    /// Number of points (all of which `insert_all` inserts).
    pub(crate) fn num_points(&self) -> usize {
        self.pts.len()
    }

    /// Inserts points 4.. in order.
    #[cfg(test)]
    pub(crate) fn insert_all(&mut self) {
        self.insert_range(4, self.pts.len() as u32);
    }

    /// Inserts points `ids` in order, on this thread.
    pub(crate) fn insert_points(&mut self, ids: &[u32]) {
        let mut k = 0;
        while k < ids.len() {
            let next = AtomicUsize::new(self.used);
            let free = std::mem::take(&mut self.free);
            let mut ins = Inserter::new(self, &next, None, 0, self.last, free, SplitMix64(0x5EED ^ k as u64));
            while k < ids.len() {
                match ins.insert(ids[k]) {
                    Ok(()) => k += 1,
                    Err(Deferred::OutOfSlots) => break,
                    Err(e) => unreachable!("a sequential insertion cannot be deferred ({e:?})"),
                }
            }
            let fresh = ins.unused_fresh();
            let (free, last, fallbacks) = (ins.free, ins.last, ins.walk_fallbacks);
            self.free = free;
            self.last = last;
            self.walk_fallbacks += fallbacks;
            // The inserter took all spare slots as one block.
            self.used = if fresh.is_empty() { next.into_inner().min(self.tets.len()) } else { fresh.start };
            if k < ids.len() {
                self.grow_to(self.tets.len() * 2);
            }
        }
    }

    /// Inserts points `from..to` in order, on this thread.
    pub(crate) fn insert_range(&mut self, from: u32, to: u32) {
        let ids: Vec<u32> = (from..to.min(self.pts.len() as u32)).collect();
        self.insert_points(&ids);
    }

    #[inline]
    fn p(&self, v: u32) -> &[f64; 3] {
        &self.pts[v as usize]
    }

    /// Removes finite tets reachable from the hull through faces between
    /// tets whose circumradius exceeds `max_r`; returns the removed flags.
    pub(crate) fn peel(&self, max_r: f64) -> (Vec<bool>, usize) {
        let tets: Vec<Tet> = self.tets[..self.used].iter().map(AtomicTet::load).collect();
        let mut removed = vec![false; tets.len()];
        let mut stack = Vec::new();
        let big = |t: usize| -> bool {
            let v = tets[t].v;
            circumradius(self.p(v[0]), self.p(v[1]), self.p(v[2]), self.p(v[3])) > max_r
        };
        for (t, tet) in tets.iter().enumerate() {
            if tet.v[0] != DEAD && is_ghost(&tet.v) {
                let g = tet.v.iter().position(|&x| x == INF).expect("ghost");
                let f = tets[t].n[g] as usize;
                if !removed[f] && big(f) {
                    removed[f] = true;
                    stack.push(f);
                }
            }
        }
        let mut count = stack.len();
        while let Some(t) = stack.pop() {
            for &nb in &tets[t].n {
                let nb = nb as usize;
                if !removed[nb] && !is_ghost(&tets[nb].v) && big(nb) {
                    removed[nb] = true;
                    count += 1;
                    stack.push(nb);
                }
            }
        }
        (removed, count)
    }

    /// Finite tets in input ids (skipping `removed` ones), their neighbours
    /// (`[t][f]`: the output tet across the face opposite vertex `f`, or
    /// `u32::MAX` where the hull, a ghost or a removed tet is), and the
    /// number of hull facets.
    pub(crate) fn finite_tets(&self, removed: Option<&[bool]>) -> (Vec<[u32; 4]>, Vec<[u32; 4]>, usize) {
        use rayon::prelude::*;
        // Two passes over fixed chunks: count, then fill each chunk's exact
        // share of the output, so the output is in slot order whatever the
        // thread count and is written (and paged in) once.
        const CHUNK: usize = 1 << 16;
        let keep = |s: usize, v: &[u32; 4]| v[0] != DEAD && !is_ghost(v) && !removed.is_some_and(|r| r[s]);
        let slots = &self.tets[..self.used];
        let counts: Vec<(usize, usize)> = slots
            .par_chunks(CHUNK)
            .enumerate()
            .map(|(c, chunk)| {
                let (mut kept, mut ghosts) = (0, 0);
                for (k, tet) in chunk.iter().enumerate() {
                    let v = tet.load().v;
                    kept += keep(c * CHUNK + k, &v) as usize;
                    ghosts += (v[0] != DEAD && is_ghost(&v)) as usize;
                }
                (kept, ghosts)
            })
            .collect();
        let total: usize = counts.iter().map(|c| c.0).sum();
        let mut out = vec![[0u32; 4]; total];
        // Output index of every slot (u32::MAX: not kept).
        let mut index = vec![u32::MAX; slots.len()];
        let mut parts = Vec::with_capacity(counts.len());
        let mut rest = &mut out[..];
        let mut base = 0usize;
        for &(kept, _) in &counts {
            let (part, tail) = rest.split_at_mut(kept);
            parts.push((part, base));
            rest = tail;
            base += kept;
        }
        parts.into_par_iter().zip(slots.par_chunks(CHUNK).zip(index.par_chunks_mut(CHUNK))).enumerate().for_each(
            |(c, ((part, base), (chunk, index)))| {
                let mut k = 0;
                for (j, tet) in chunk.iter().enumerate() {
                    let v = tet.load().v;
                    if keep(c * CHUNK + j, &v) {
                        part[k] = v.map(|x| self.orig[x as usize]);
                        index[j] = (base + k) as u32;
                        k += 1;
                    }
                }
            },
        );
        // Kept slots in output order, then their neighbours' output indices.
        let mut kept_slots = vec![0u32; total];
        for (s, &o) in index.iter().enumerate() {
            if o != u32::MAX {
                kept_slots[o as usize] = s as u32;
            }
        }
        let neighbors: Vec<[u32; 4]> = kept_slots
            .par_iter()
            .map(|&s| self.tets[s as usize].load().n.map(|m| index.get(m as usize).copied().unwrap_or(u32::MAX)))
            .collect();
        (out, neighbors, counts.iter().map(|c| c.1).sum())
    }
}

/// Links the faces of a few tets by brute-force vertex-set matching.
fn link_small(tets: &mut [Tet]) {
    let face = |v: [u32; 4], i: usize| {
        let mut f: Vec<u32> = (0..4).filter(|&k| k != i).map(|k| v[k]).collect();
        f.sort_unstable();
        f
    };
    for s in 0..tets.len() {
        for i in 0..4 {
            let f = face(tets[s].v, i);
            for o in (0..tets.len()).filter(|&o| o != s) {
                if (0..4).any(|j| face(tets[o].v, j) == f) {
                    tets[s].n[i] = o as u32;
                }
            }
        }
    }
}

/// Inserts points into a triangulation's shared tets: one per thread in a
/// parallel round, or one on the caller's thread. Holds the scratch
/// buffers every insertion reuses.
pub(crate) struct Inserter<'a> {
    pts: &'a [[f64; 3]],
    filter: &'a StaticFilter,
    orig: &'a [u32],
    tets: &'a [AtomicTet],
    /// Owner of each vertex in a parallel round (`None`: this inserter owns
    /// every vertex).
    owner: Option<&'a [u8]>,
    me: u8,
    /// `IN_CAVITY - me`.
    marker: u32,
    /// Shared bump counter of fresh slots.
    next: &'a AtomicUsize,
    /// Fresh slots taken from `next` and not used yet.
    block_next: usize,
    block_end: usize,
    /// Fresh slots taken from `next` at a time (all of them sequentially).
    block: usize,
    pub(crate) last: u32,
    pub(crate) free: Vec<u32>,
    rng: SplitMix64,
    pub(crate) walk_fallbacks: usize,
    stack: Vec<(u32, Tet)>,
    conflict: Vec<u32>,
    /// The original first vertex of each conflict tet (replaced by the
    /// marker), restored when the insertion is put off.
    saved_v0: Vec<u32>,
    boundary: Vec<Boundary>,
    /// Per vertex (the infinite one last): its local id in the current
    /// cavity boundary, or [`NO_LOCAL`]; `local_verts` lists those set.
    local: Vec<u8>,
    local_verts: Vec<u32>,
    /// `DENSE_MAX`² new-tet slots keyed by directed edge of local ids.
    edge: Vec<u32>,
    /// Open-addressing table matching the faces through the new point by
    /// their edge opposite it; `used` lists the slots to clear afterwards.
    table: Vec<(u64, u32)>,
    table_used: Vec<u32>,
}

/// Whether every finite vertex of `v` belongs to worker `me` under
/// `owner`, `v` has at most one infinite slot, and no slot holds a
/// non-vertex (`DEAD`, a cavity marker): the ownership test of
/// [`Inserter::owns`], safe on torn reads.
#[inline(always)]
pub(crate) fn owned_by(owner: &[u8], me: u8, v: &[u32; 4]) -> bool {
    let mut infinite = 0;
    for &x in v {
        if x == INF {
            infinite += 1;
        } else if owner.get(x as usize) != Some(&me) {
            return false;
        }
    }
    infinite <= 1
}

impl<'a> Inserter<'a> {
    /// An inserter on `tri`'s tets starting its walks at `last` (a live
    /// finite tet), allocating from `free` and then fresh slots from
    /// `next`. With `owner`, it only touches tets whose finite vertices
    /// `me` owns and defers other points.
    pub(crate) fn new(
        tri: &'a Triangulation,
        next: &'a AtomicUsize,
        owner: Option<&'a [u8]>,
        me: u8,
        last: u32,
        free: Vec<u32>,
        rng: SplitMix64,
    ) -> Self {
        debug_assert!((me as usize) < MAX_WORKERS);
        Inserter {
            pts: &tri.pts,
            filter: &tri.filter,
            orig: &tri.orig,
            tets: &tri.tets,
            block: if owner.is_some() { crate::parallel::BLOCK } else { usize::MAX },
            owner,
            me,
            marker: IN_CAVITY - me as u32,
            next,
            block_next: 0,
            block_end: 0,
            last,
            free,
            rng,
            walk_fallbacks: 0,
            stack: Vec::new(),
            conflict: Vec::new(),
            saved_v0: Vec::new(),
            boundary: Vec::new(),
            local: vec![NO_LOCAL; tri.pts.len() + 1],
            local_verts: Vec::new(),
            edge: vec![0; DENSE_MAX * DENSE_MAX],
            table: Vec::new(),
            table_used: Vec::new(),
        }
    }

    /// Fresh slots taken but not used, for the caller to put on the free
    /// list after a round.
    pub(crate) fn unused_fresh(&self) -> std::ops::Range<usize> {
        self.block_next..self.block_end
    }

    #[inline(always)]
    fn p(&self, v: u32) -> &'a [f64; 3] {
        &self.pts[v as usize]
    }

    #[inline(always)]
    fn tet(&self, t: u32) -> Tet {
        self.tets[t as usize].load()
    }

    /// Whether this inserter may rewrite a tet with these vertices.
    ///
    /// In a parallel round `v` may be a torn read of a tet another worker
    /// is rewriting (only ever the first tet of a walk, when the worker
    /// could not start on a tet of its own): its slots then hold that
    /// worker's vertices, `INF`, `DEAD` or a cavity marker, mixed across
    /// versions. Such a read is never ours: markers and `DEAD` are not
    /// vertices, and a mix with three of our vertices cannot occur, so a
    /// tet with more than one infinite slot is rejected as well.
    #[inline(always)]
    fn owns(&self, v: &[u32; 4]) -> bool {
        match self.owner {
            None => true,
            Some(o) => owned_by(o, self.me, v),
        }
    }

    /// Orientation of tet `v` with vertex `i` replaced by `q` (for a ghost,
    /// `i` must be the infinite vertex's slot, or the walk must not ask).
    #[inline]
    fn orient_replaced(&self, v: &[u32; 4], i: usize, q: &[f64; 3]) -> f64 {
        let mut p: [&[f64; 3]; 4] = [q; 4];
        for k in 0..4 {
            if k != i {
                p[k] = self.p(v[k]);
            }
        }
        self.filter.orient(p[0], p[1], p[2], p[3])
    }

    /// Finds a tet in conflict with `q`: a finite tet whose closure
    /// contains it, or a ghost whose hull facet it sees from outside.
    pub(crate) fn locate(&mut self, q: &[f64; 3]) -> Result<u32, Deferred> {
        let mut t = self.last;
        let mut prev = u32::MAX;
        // Stochastic remembering walk: a random first face avoids cycles,
        // and the face we came through is never re-tested.
        let len = self.tets.len();
        let limit = 64 + 4 * (len as u64).isqrt() as usize + len / 16;
        'walk: for _ in 0..limit {
            let Tet { v, n } = self.tet(t);
            if !self.owns(&v) {
                return Err(Deferred::Foreign);
            }
            if is_ghost(&v) {
                return Ok(t);
            }
            let r = (self.rng.next_u64() >> 62) as usize;
            for k in 0..4 {
                let i = (r + k) & 3;
                if n[i] == prev {
                    continue;
                }
                if self.orient_replaced(&v, i, q) < 0.0 {
                    prev = t;
                    t = n[i];
                    continue 'walk;
                }
            }
            return Ok(t);
        }
        if self.owner.is_some() {
            return Err(Deferred::LongWalk);
        }
        self.walk_fallbacks += 1;
        Ok(self.locate_by_scan(q))
    }

    /// Safety net when a sequential walk runs too long: test every live tet.
    fn locate_by_scan(&self, q: &[f64; 3]) -> u32 {
        for (t, tet) in self.tets.iter().enumerate() {
            let v = tet.load().v;
            if v[0] == DEAD {
                continue;
            }
            if let Some(g) = v.iter().position(|&x| x == INF) {
                if self.orient_replaced(&v, g, q) > 0.0 {
                    return t as u32;
                }
            } else if (0..4).all(|i| self.orient_replaced(&v, i, q) >= 0.0) {
                return t as u32;
            }
        }
        unreachable!("the tets and ghosts cover all of space")
    }

    /// Perturbed in-sphere test of finite tet `v` against point `iq`.
    #[inline(always)]
    fn in_sphere(&self, v: &[u32; 4], q: &[f64; 3], iq: u32) -> bool {
        let p = [self.p(v[0]), self.p(v[1]), self.p(v[2]), self.p(v[3])];
        let d = self.filter.in_sphere(p[0], p[1], p[2], p[3], q);
        if d != 0.0 {
            return d > 0.0;
        }
        in_sphere_tie(p, v.map(|x| self.orig[x as usize]), q, self.orig[iq as usize])
    }

    /// Conflict test of tet `tet` with point `q` (id `iq`).
    #[inline]
    fn in_conflict(&self, tet: &Tet, q: &[f64; 3], iq: u32) -> bool {
        let v = &tet.v;
        if let Some(g) = v.iter().position(|&x| x == INF) {
            let o = self.orient_replaced(v, g, q);
            if o != 0.0 {
                return o > 0.0;
            }
            // On the hull facet's plane: in conflict exactly when the finite
            // tet across that facet is (in-circle of the facet, with the
            // same perturbation), as geogram does.
            let f = self.tet(tet.n[g]);
            return f.v[0] == self.marker || self.in_sphere(&f.v, q, iq);
        }
        self.in_sphere(v, q, iq)
    }

    /// Puts tet `t` (contents `tet`) into the conflict zone.
    #[inline(always)]
    fn mark(&mut self, t: u32, tet: Tet) {
        self.tets[t as usize].set_v0(self.marker);
        self.conflict.push(t);
        self.saved_v0.push(tet.v[0]);
        self.stack.push((t, tet));
    }

    /// Undoes the marks of an insertion that is put off.
    fn unmark(&mut self) {
        for (&t, &v0) in self.conflict.iter().zip(&self.saved_v0) {
            self.tets[t as usize].set_v0(v0);
        }
    }

    /// A free or fresh slot, or `None` when none is left.
    #[inline]
    fn alloc(&mut self) -> Option<u32> {
        if let Some(s) = self.free.pop() {
            return Some(s);
        }
        if self.block_next == self.block_end {
            // Parallel workers take private blocks, so that slots of
            // different workers rarely share a cache line.
            let len = self.tets.len();
            let start = self.next.fetch_add(self.block.min(len), Relaxed);
            let end = start.saturating_add(self.block).min(len);
            if start >= end {
                // Keep the shared counter from creeping past the end.
                self.next.fetch_min(len, Relaxed);
                return None;
            }
            (self.block_next, self.block_end) = (start, end);
        }
        let s = self.block_next as u32;
        self.block_next += 1;
        Some(s)
    }

    /// Inserts point `iq` (distinct from every inserted point), or puts it
    /// off leaving the triangulation unchanged.
    pub(crate) fn insert(&mut self, iq: u32) -> Result<(), Deferred> {
        let q = self.pts[iq as usize];
        let t0 = self.locate(&q)?;
        // Conflict zone by flood fill from t0 (which contains q, so is in
        // conflict without a test). A conflict tet is flagged by this
        // inserter's marker in its first vertex slot, its contents kept on
        // the stack, so one cache line per neighbour tells whether it is
        // already in the zone; the flag goes when the slot is rebuilt or
        // freed. Non-conflict tets are not flagged: one facing several
        // conflict tets is tested again (cheap, it is in cache).
        //
        // Each face from a conflict tet to a non-conflict one is a boundary
        // face: its new tet is the conflict tet with the vertex opposite
        // the face replaced by q. The outside neighbour's slot pointing back
        // is found now, before any conflict slot is reused (a neighbour may
        // face two conflict tets).
        self.conflict.clear();
        self.saved_v0.clear();
        self.stack.clear();
        self.boundary.clear();
        let tet0 = self.tet(t0);
        self.mark(t0, tet0);
        while let Some((t, Tet { v, n })) = self.stack.pop() {
            for i in 0..4 {
                let nb = n[i];
                let nt = self.tet(nb);
                if nt.v[0] == self.marker {
                    continue;
                }
                if self.in_conflict(&nt, &q, iq) {
                    if !self.owns(&nt.v) {
                        self.unmark();
                        return Err(Deferred::Foreign);
                    }
                    self.mark(nb, nt);
                    continue;
                }
                let back = (0..4).find(|&k| nt.n[k] == t).expect("adjacency is symmetric");
                let mut nv = v;
                nv[i] = iq;
                self.boundary.push(Boundary { v: nv, outside: nb, slot: i as u8, back: back as u8, local: [0; 4] });
            }
        }

        // New tets take the conflict slots first, then free or fresh ones.
        let nc = self.conflict.len();
        for k in nc..self.boundary.len() {
            match self.alloc() {
                Some(s) => self.conflict.push(s),
                None => {
                    self.free.extend_from_slice(&self.conflict[nc..k]);
                    self.conflict.truncate(nc);
                    self.unmark();
                    return Err(Deferred::OutOfSlots);
                }
            }
        }
        // Point of no return.
        for k in self.boundary.len()..nc {
            let s = self.conflict[k];
            self.tets[s as usize].store(DEAD_TET);
            self.free.push(s);
        }
        let mut last = u32::MAX;
        for k in 0..self.boundary.len() {
            let b = self.boundary[k];
            let s = self.conflict[k];
            let mut n = [u32::MAX; 4];
            n[b.slot as usize] = b.outside;
            self.tets[s as usize].store(Tet { v: b.v, n });
            self.tets[b.outside as usize].set_n(b.back as usize, s);
            if !is_ghost(&b.v) {
                last = s;
            }
        }
        debug_assert!(last != u32::MAX);
        self.last = last;
        if !self.link_new_dense(iq) {
            self.link_new_hashed();
        }
        Ok(())
    }

    /// Links the new tets (slots `conflict[k]` for boundary face `k`)
    /// across their faces through the new point `iq`, when the cavity
    /// boundary has at most [`DENSE_MAX`] vertices: each gets a small local
    /// id, and the directed boundary edges go in a dense matrix. Returns
    /// false (changing nothing) for larger cavities.
    fn link_new_dense(&mut self, iq: u32) -> bool {
        debug_assert!(self.boundary.iter().all(|b| b.v[b.slot as usize] == iq));
        let Inserter { boundary, local, local_verts, edge, conflict, tets, .. } = self;
        let inf_slot = local.len() - 1;
        // Each directed edge (x, y) of a new tet's face through q has its
        // reverse (y, x) in exactly one other new tet: the one across it.
        // Pass 1 names the vertices and records the directed edges.
        let mut count = 0usize;
        let mut fits = true;
        'faces: for (b, &s) in boundary.iter_mut().zip(conflict.iter()) {
            let i = b.slot as usize;
            for x in 0..4 {
                if x == i {
                    continue;
                }
                let vx = b.v[x];
                let slot = if vx == INF { inf_slot } else { vx as usize };
                let mut l = local[slot];
                if l == NO_LOCAL {
                    if count == DENSE_MAX {
                        fits = false;
                        break 'faces;
                    }
                    l = count as u8;
                    count += 1;
                    local[slot] = l;
                    local_verts.push(slot as u32);
                }
                b.local[x] = l;
            }
            for (j, &(x, y)) in EDGE[i].iter().enumerate() {
                if j != i {
                    edge[b.local[x] as usize * DENSE_MAX + b.local[y] as usize] = s;
                }
            }
        }
        for &slot in local_verts.iter() {
            local[slot as usize] = NO_LOCAL;
        }
        local_verts.clear();
        if !fits {
            return false;
        }
        for (b, &s) in boundary.iter().zip(conflict.iter()) {
            let i = b.slot as usize;
            let tet = &tets[s as usize];
            for (j, &(x, y)) in EDGE[i].iter().enumerate() {
                if j != i {
                    tet.set_n(j, edge[b.local[y] as usize * DENSE_MAX + b.local[x] as usize]);
                }
            }
        }
        true
    }

    /// [`Self::link_new_dense`] for cavities of any size, through an
    /// open-addressing table keyed by the undirected edge.
    fn link_new_hashed(&mut self) {
        let needed = (6 * self.boundary.len()).next_power_of_two().max(256);
        if self.table.len() < needed {
            self.table = vec![(EMPTY, 0); needed];
        }
        let mask = self.table.len() - 1;
        for k in 0..self.boundary.len() {
            let b = self.boundary[k];
            let s = self.conflict[k];
            let i = b.slot as usize;
            for (j, &(x, y)) in EDGE[i].iter().enumerate() {
                if j == i {
                    continue;
                }
                let (e0, e1) = (b.v[x], b.v[y]);
                let key = ((e0.min(e1) as u64) << 32) | e0.max(e1) as u64;
                let mut h = (key.wrapping_mul(0x9E37_79B9_7F4A_7C15) >> 40) as usize & mask;
                loop {
                    let (k3, val) = self.table[h];
                    if k3 == EMPTY {
                        self.table[h] = (key, s * 4 + j as u32);
                        self.table_used.push(h as u32);
                        break;
                    }
                    if k3 == key {
                        self.tets[s as usize].set_n(j, val / 4);
                        self.tets[(val / 4) as usize].set_n((val % 4) as usize, s);
                        break;
                    }
                    h = (h + 1) & mask;
                }
            }
        }
        for &h in &self.table_used {
            self.table[h as usize].0 = EMPTY;
        }
        self.table_used.clear();
    }
}

/// Circumradius in plain floating point (a measurement for filtering, not
/// a decision the structure depends on); infinite for a flat tet.
pub(crate) fn circumradius(a: &[f64; 3], b: &[f64; 3], c: &[f64; 3], d: &[f64; 3]) -> f64 {
    let s = |p: &[f64; 3]| [p[0] - a[0], p[1] - a[1], p[2] - a[2]];
    let (u, v, w) = (s(b), s(c), s(d));
    let cr =
        |x: [f64; 3], y: [f64; 3]| [x[1] * y[2] - x[2] * y[1], x[2] * y[0] - x[0] * y[2], x[0] * y[1] - x[1] * y[0]];
    let dot = |x: [f64; 3], y: [f64; 3]| x[0] * y[0] + x[1] * y[1] + x[2] * y[2];
    let (vw, wu, uv) = (cr(v, w), cr(w, u), cr(u, v));
    let det = dot(u, vw);
    if det == 0.0 {
        return f64::INFINITY;
    }
    let (lu, lv, lw) = (dot(u, u), dot(v, v), dot(w, w));
    let c = [0, 1, 2].map(|k| (lu * vw[k] + lv * wu[k] + lw * uv[k]) / (2.0 * det));
    dot(c, c).sqrt()
}

#[cfg(test)]
pub(crate) mod tests {
    use super::*;
    use crate::predicates::in_sphere_sos;
    use crate::sort::SplitMix64;

    /// Builds the triangulation of `pts` (distinct, full-dimensional) in
    /// the library's insertion order.
    fn build(pts: &[[f64; 3]]) -> Triangulation {
        let order = crate::sort::brio_order(pts, (0..pts.len() as u32).collect(), 1);
        let order = crate::initial_tet(pts, order).unwrap();
        let mut t = Triangulation::new(order.iter().map(|&i| pts[i as usize]).collect(), order);
        t.insert_all();
        t
    }

    /// Internal invariants: neighbour links symmetric through the shared
    /// face (ghosts included), every finite tet positive, no slot both live
    /// and free, and (with `empty_sphere`) no point in conflict with any
    /// finite tet under the perturbed predicate, which is what makes ties
    /// between cospherical points consistent.
    pub(crate) fn check(t: &Triangulation, empty_sphere: bool) {
        let tets: Vec<Tet> = t.tets[..t.used].iter().map(AtomicTet::load).collect();
        assert!(t.tets[t.used..].iter().all(|x| x.v0() == DEAD), "a slot past `used` is live");
        let live = |s: usize| tets[s].v[0] != DEAD;
        assert!(t.free.iter().all(|&f| !live(f as usize)), "a free slot is live");
        for s in (0..tets.len()).filter(|&s| live(s)) {
            let v = tets[s].v;
            for i in 0..4 {
                let nb = tets[s].n[i] as usize;
                assert!(live(nb), "tet {s} links to a dead slot");
                let back = tets[nb].n.iter().position(|&x| x as usize == s).expect("symmetric link");
                let mut f: Vec<u32> = (0..4).filter(|&k| k != i).map(|k| v[k]).collect();
                let mut g: Vec<u32> = (0..4).filter(|&k| k != back).map(|k| tets[nb].v[k]).collect();
                f.sort_unstable();
                g.sort_unstable();
                assert_eq!(f, g, "tets {s} and {nb} do not share the face they link through");
            }
            if !is_ghost(&v) {
                let p = v.map(|x| &t.pts[x as usize]);
                assert!(orient(p[0], p[1], p[2], p[3]) > 0.0);
                if empty_sphere {
                    for (q, pq) in t.pts.iter().enumerate() {
                        if !v.contains(&(q as u32)) {
                            let ids = v.map(|x| t.orig[x as usize]);
                            let iq = t.orig[q];
                            assert!(!in_sphere_sos(p, ids, pq, iq), "point {q} in conflict with tet {v:?}");
                        }
                    }
                }
            }
        }
    }

    #[test]
    fn lattice_and_random_sets_satisfy_the_perturbed_empty_sphere_property() {
        let pts = tet_mesh::split::structured_points([5; 3], |p| p.map(|x| x as f64));
        check(&build(&pts), true);
        let mut rng = SplitMix64(5);
        let pts: Vec<[f64; 3]> = (0..300).map(|_| [rng.next_f64(), rng.next_f64(), rng.next_f64()]).collect();
        check(&build(&pts), true);
        // Two coplanar layers of a 4×4 grid, half a spacing apart.
        let pts: Vec<[f64; 3]> =
            (0..32).map(|i| [(i % 4) as f64, ((i / 4) % 4) as f64, (i / 16) as f64 * 0.5]).collect();
        check(&build(&pts), true);
    }

    #[test]
    fn running_out_of_slots_grows_the_array_and_retries() {
        // Points on two skew lines have a quadratic-size Delaunay
        // tetrahedralization ((n/2 − 1)² tets), far beyond the initial
        // capacity estimate.
        let pts: Vec<[f64; 3]> =
            (0..600).map(|i| if i % 2 == 0 { [i as f64, 0.0, 0.0] } else { [0.0, i as f64, 1.0] }).collect();
        let order = crate::sort::brio_order(&pts, (0..pts.len() as u32).collect(), 1);
        let order = crate::initial_tet(&pts, order).unwrap();
        let mut t = Triangulation::new(order.iter().map(|&i| pts[i as usize]).collect(), order);
        let before = t.tets.len();
        t.insert_all();
        check(&t, true);
        let (tets, _, _) = t.finite_tets(None);
        assert_eq!(tets.len(), 299 * 299);
        assert!(tets.len() > before, "{} tets fit in the initial {before} slots", tets.len());
    }
    /// Regression (CI stop 10): a worker that could not start on a tet of
    /// its own walked from a foreign tet while another worker had it in its
    /// cavity, read the cavity marker as a vertex id and indexed out of
    /// bounds. Such reads must defer the point, never panic.
    #[test]
    fn a_walk_from_a_foreign_tet_in_another_cavity_defers() {
        let mut rng = SplitMix64(3);
        let pts: Vec<[f64; 3]> = (0..200).map(|_| [rng.next_f64(), rng.next_f64(), rng.next_f64()]).collect();
        let order = crate::sort::brio_order(&pts, (0..pts.len() as u32).collect(), 1);
        let order = crate::initial_tet(&pts, order).unwrap();
        let mut t = Triangulation::new(order.iter().map(|&i| pts[i as usize]).collect(), order);
        t.insert_range(4, 150);
        let start = (0..t.used as u32).find(|&s| !is_ghost(&t.tets[s as usize].load().v)).unwrap();
        let owner = vec![0u8; 150];
        let next = AtomicUsize::new(t.used);
        let original = t.tets[start as usize].load();
        // What worker 1 can observe of worker 0's tets mid-round: a cavity
        // marker, a freed slot, and a torn mix of two ghosts.
        let torn_reads = [
            Tet { v: [IN_CAVITY, original.v[1], original.v[2], original.v[3]], n: original.n },
            Tet { v: [DEAD, original.v[1], original.v[2], original.v[3]], n: original.n },
            Tet { v: [INF, INF, original.v[2], original.v[3]], n: original.n },
        ];
        for seen in torn_reads {
            t.tets[start as usize].store(seen);
            let mut ins = Inserter::new(&t, &next, Some(&owner), 1, start, Vec::new(), SplitMix64(1));
            assert_eq!(ins.insert(160), Err(Deferred::Foreign));
            // None of them is a tet even worker 0 could own.
            assert!(!owned_by(&owner, 0, &seen.v));
        }
        // Nothing was changed: the rest inserts into a valid triangulation.
        t.tets[start as usize].store(original);
        t.insert_range(150, 200);
        check(&t, true);
    }
}
