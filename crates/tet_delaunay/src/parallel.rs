//! Parallel Bowyer–Watson for the last BRIO round: worker threads insert
//! contiguous runs of the Hilbert-sorted round concurrently into one shared
//! triangulation.
//!
//! Concurrency contract (all safe Rust: tets are atomics, accessed Relaxed,
//! and a per-tet lock byte taken with an Acquire CAS and released with a
//! Release store orders them):
//! - A worker reads a tet's contents for a decision only while it holds the
//!   tet's lock. Walks read unlocked (racy but well defined) and validate
//!   every id they follow; the tet a walk ends in is re-checked under lock.
//! - Locks are never waited for: a worker that finds a tet locked by another
//!   releases everything it holds and defers the point. Deferred points (and
//!   cavities too large for the dense linker, and walks that run too long)
//!   are inserted sequentially afterwards. Nothing is written before every
//!   tet a cavity touches is locked, so an abort leaves no trace.
//! - New tets go into the worker's own freed slots or slots bumped from a
//!   preallocated array; running out defers the point.
//!
//! The symbolic perturbation keys on input ids, so the Delaunay
//! tetrahedralization is unique and the result does not depend on which
//! thread inserted what, or in which order.

use crate::predicates::{in_sphere_tie, StaticFilter};
use crate::sort::SplitMix64;
use crate::triangulation::{is_ghost, Tet, Triangulation, DEAD, DENSE_MAX, EDGE, INF, NO_LOCAL};
use std::sync::atomic::{AtomicU32, AtomicU8, AtomicUsize, Ordering::*};

/// A tet in shared memory; same layout and meaning as [`Tet`].
#[repr(C, align(32))]
struct AtomicTet {
    v: [AtomicU32; 4],
    n: [AtomicU32; 4],
}

impl AtomicTet {
    fn new(t: Tet) -> Self {
        AtomicTet { v: t.v.map(AtomicU32::new), n: t.n.map(AtomicU32::new) }
    }
    #[inline(always)]
    fn load(&self) -> Tet {
        Tet { v: [0, 1, 2, 3].map(|k| self.v[k].load(Relaxed)), n: [0, 1, 2, 3].map(|k| self.n[k].load(Relaxed)) }
    }
    #[inline(always)]
    fn store(&self, t: Tet) {
        for k in 0..4 {
            self.v[k].store(t.v[k], Relaxed);
            self.n[k].store(t.n[k], Relaxed);
        }
    }
}

const FREE: u8 = 0;
/// Fresh tet slots a worker takes from the shared array at a time.
const SLOT_BLOCK: usize = 4096;

struct Shared<'a> {
    pts: &'a [[f64; 3]],
    filter: &'a StaticFilter,
    orig: &'a [u32],
    tets: Vec<AtomicTet>,
    locks: Vec<AtomicU8>,
    /// Slots in use at the front of `tets` (may run past its length when
    /// workers over-reserve at the end; those reservations are abandoned).
    len: AtomicUsize,
}

/// Why an insertion was put off to the sequential tail.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum Deferred {
    Contended,
    LongWalk,
    BigCavity,
    OutOfSlots,
}

struct Worker<'s, 'a> {
    sh: &'s Shared<'a>,
    /// Lock values: `touched` for a tet read or relinked by this insertion,
    /// `cavity` for one in its conflict zone.
    touched: u8,
    cavity: u8,
    last: u32,
    rng: SplitMix64,
    free: Vec<u32>,
    /// The worker's current block of fresh slots, `block_next..block_end`.
    block_next: usize,
    block_end: usize,
    locked: Vec<u32>,
    stack: Vec<u32>,
    conflict: Vec<u32>,
    boundary: Vec<(Tet, u32, u8, u8)>,
    local: Vec<u8>,
    local_verts: Vec<u32>,
    local_ids: Vec<[u8; 4]>,
    edge: Vec<u32>,
    deferred: Vec<u32>,
}

impl<'s, 'a> Worker<'s, 'a> {
    #[inline(always)]
    fn p(&self, v: u32) -> &'a [f64; 3] {
        &self.sh.pts[v as usize]
    }

    /// A tet read without its lock is only followed if every id in it is
    /// plausible; anything else is a slot being rewritten by another worker.
    #[inline(always)]
    fn plausible(&self, t: &Tet) -> bool {
        let np = self.sh.pts.len() as u32;
        let nt = self.sh.tets.len() as u32;
        t.v.iter().all(|&x| x < np || x == INF) && t.n.iter().all(|&x| x < nt)
    }

    fn orient_replaced(&self, v: &[u32; 4], i: usize, q: &[f64; 3]) -> f64 {
        let mut p: [&[f64; 3]; 4] = [q; 4];
        for k in 0..4 {
            if k != i {
                p[k] = self.p(v[k]);
            }
        }
        self.sh.filter.orient(p[0], p[1], p[2], p[3])
    }

    fn in_sphere(&self, v: &[u32; 4], q: &[f64; 3], iq: u32) -> bool {
        let p = [self.p(v[0]), self.p(v[1]), self.p(v[2]), self.p(v[3])];
        let d = self.sh.filter.in_sphere(p[0], p[1], p[2], p[3], q);
        if d != 0.0 {
            return d > 0.0;
        }
        in_sphere_tie(p, v.map(|x| self.sh.orig[x as usize]), q, self.sh.orig[iq as usize])
    }

    /// Takes tet `t`'s lock as `state`, or upgrades it if this insertion
    /// already holds it. False when another worker holds it.
    #[inline(always)]
    fn lock(&mut self, t: u32, state: u8) -> bool {
        let l = &self.sh.locks[t as usize];
        match l.compare_exchange(FREE, state, Acquire, Relaxed) {
            Ok(_) => {
                self.locked.push(t);
                true
            }
            Err(s) if s == self.touched || s == self.cavity => {
                if state == self.cavity {
                    l.store(state, Relaxed);
                }
                true
            }
            Err(_) => false,
        }
    }

    fn unlock_all(&mut self) {
        for &t in &self.locked {
            self.sh.locks[t as usize].store(FREE, Release);
        }
        self.locked.clear();
    }

    /// Walk towards `q` from the last tet, reading without locks; returns a
    /// candidate that must be re-checked under lock.
    fn walk(&mut self, q: &[f64; 3]) -> Result<u32, Deferred> {
        let mut t = self.last;
        let mut prev = u32::MAX;
        let limit = 64 + 4 * (self.sh.tets.len() as u64).isqrt() as usize;
        'walk: for _ in 0..limit {
            let tet = self.sh.tets[t as usize].load();
            if tet.v[0] == DEAD || !self.plausible(&tet) {
                return Err(Deferred::Contended);
            }
            if is_ghost(&tet.v) {
                return Ok(t);
            }
            let r = (self.rng.next_u64() >> 62) as usize;
            for k in 0..4 {
                let i = (r + k) & 3;
                if tet.n[i] == prev {
                    continue;
                }
                if self.orient_replaced(&tet.v, i, q) < 0.0 {
                    prev = t;
                    t = tet.n[i];
                    continue 'walk;
                }
            }
            return Ok(t);
        }
        Err(Deferred::LongWalk)
    }

    /// Under lock: whether `t` is live and `q` lies in its closure (finite)
    /// or strictly beyond its hull facet (ghost) — either way in conflict.
    fn contains(&self, tet: &Tet, q: &[f64; 3]) -> bool {
        if tet.v[0] == DEAD {
            return false;
        }
        if let Some(g) = tet.v.iter().position(|&x| x == INF) {
            return self.orient_replaced(&tet.v, g, q) > 0.0;
        }
        (0..4).all(|i| self.orient_replaced(&tet.v, i, q) >= 0.0)
    }

    fn insert(&mut self, iq: u32) {
        let result = self.try_insert(iq);
        debug_assert!(self.locked.is_empty());
        if result.is_err() {
            self.deferred.push(iq);
        }
    }

    fn try_insert(&mut self, iq: u32) -> Result<(), Deferred> {
        let q = *self.p(iq);
        let t0 = self.walk(&q)?;
        let cavity = self.cavity;
        if !self.lock(t0, cavity) {
            return Err(Deferred::Contended);
        }
        let tet0 = self.sh.tets[t0 as usize].load();
        if !self.contains(&tet0, &q) {
            self.unlock_all();
            return Err(Deferred::Contended);
        }
        let r = self.flood(t0, &q, iq);
        if let Err(e) = r {
            self.unlock_all();
            return Err(e);
        }
        let r = self.rebuild(iq);
        self.unlock_all();
        r
    }

    /// Conflict zone from `t0` with every touched tet locked; fills
    /// `conflict` and `boundary` (new tet, outside tet, slot, back slot).
    fn flood(&mut self, t0: u32, q: &[f64; 3], iq: u32) -> Result<(), Deferred> {
        self.conflict.clear();
        self.stack.clear();
        self.boundary.clear();
        self.stack.push(t0);
        self.conflict.push(t0);
        while let Some(t) = self.stack.pop() {
            let Tet { v, n } = self.sh.tets[t as usize].load();
            for i in 0..4 {
                let nb = n[i];
                let touched = self.touched;
                if !self.lock(nb, touched) {
                    return Err(Deferred::Contended);
                }
                if self.sh.locks[nb as usize].load(Relaxed) == self.cavity {
                    continue;
                }
                let nt = self.sh.tets[nb as usize].load();
                if self.in_conflict(&nt, q, iq)? {
                    let cavity = self.cavity;
                    self.lock(nb, cavity);
                    self.conflict.push(nb);
                    self.stack.push(nb);
                    continue;
                }
                let back = (0..4).find(|&k| nt.n[k] == t).expect("adjacency is symmetric under lock");
                let mut nv = v;
                nv[i] = iq;
                self.boundary.push((Tet { v: nv, n: [u32::MAX; 4] }, nb, i as u8, back as u8));
            }
        }
        Ok(())
    }

    fn in_conflict(&mut self, tet: &Tet, q: &[f64; 3], iq: u32) -> Result<bool, Deferred> {
        let v = &tet.v;
        if let Some(g) = v.iter().position(|&x| x == INF) {
            let o = self.orient_replaced(v, g, q);
            if o != 0.0 {
                return Ok(o > 0.0);
            }
            let f = tet.n[g];
            let touched = self.touched;
            if !self.lock(f, touched) {
                return Err(Deferred::Contended);
            }
            if self.sh.locks[f as usize].load(Relaxed) == self.cavity {
                return Ok(true);
            }
            let fv = self.sh.tets[f as usize].load().v;
            return Ok(self.in_sphere(&fv, q, iq));
        }
        Ok(self.in_sphere(v, q, iq))
    }

    /// Slots for the new tets, locked: the conflict slots, then this
    /// worker's freed slots, then fresh ones from the shared array.
    fn reserve(&mut self) -> Result<(), Deferred> {
        let need = self.boundary.len().saturating_sub(self.conflict.len());
        let mut got = Vec::new();
        while got.len() < need {
            match self.free.pop() {
                Some(s) => got.push(s),
                None => break,
            }
        }
        while got.len() < need {
            if self.block_next == self.block_end {
                // Fresh slots come in private blocks: slots (and their lock
                // bytes) of different workers never share a cache line,
                // which one shared bump counter made them do.
                let start = self.sh.len.fetch_add(SLOT_BLOCK, Relaxed);
                let end = (start + SLOT_BLOCK).min(self.sh.tets.len());
                if start >= end {
                    self.free.extend(got);
                    return Err(Deferred::OutOfSlots);
                }
                (self.block_next, self.block_end) = (start, end);
            }
            got.push(self.block_next as u32);
            self.block_next += 1;
        }
        for (k, &s) in got.iter().enumerate() {
            let cavity = self.cavity;
            if !self.lock(s, cavity) {
                // A stale walk of another worker holds a slot this one owns;
                // give them all back and retry the point later.
                self.free.extend(got[k..].iter().copied());
                self.free.extend(got[..k].iter().copied());
                return Err(Deferred::Contended);
            }
        }
        self.conflict.extend(got);
        Ok(())
    }

    fn rebuild(&mut self, iq: u32) -> Result<(), Deferred> {
        if !self.name_locals() {
            return Err(Deferred::BigCavity);
        }
        self.reserve()?;
        // Point of no return: write the new tets and relink.
        let nb = self.boundary.len();
        for k in nb..self.conflict.len() {
            let s = self.conflict[k];
            self.sh.tets[s as usize].store(Tet { v: [DEAD; 4], n: [u32::MAX; 4] });
            self.free.push(s);
        }
        self.conflict.truncate(nb);
        let mut last = u32::MAX;
        for k in 0..nb {
            let (mut tet, outside, slot, back) = self.boundary[k];
            let s = self.conflict[k];
            tet.n[slot as usize] = outside;
            self.sh.tets[outside as usize].n[back as usize].store(s, Relaxed);
            if !is_ghost(&tet.v) {
                last = s;
            }
            self.sh.tets[s as usize].store(tet);
        }
        // Link the faces through the new point with the dense edge matrix.
        for k in 0..nb {
            let (tet, _, slot, _) = self.boundary[k];
            let i = slot as usize;
            let s = self.conflict[k];
            let l = self.local_ids[k];
            for (j, &(x, y)) in EDGE[i].iter().enumerate() {
                if j != i {
                    self.edge[l[x] as usize * DENSE_MAX + l[y] as usize] = s;
                }
            }
            debug_assert_eq!(tet.v[i], iq);
        }
        for k in 0..nb {
            let (_, _, slot, _) = self.boundary[k];
            let i = slot as usize;
            let s = self.conflict[k];
            let l = self.local_ids[k];
            let at = &self.sh.tets[s as usize];
            for (j, &(x, y)) in EDGE[i].iter().enumerate() {
                if j != i {
                    at.n[j].store(self.edge[l[y] as usize * DENSE_MAX + l[x] as usize], Relaxed);
                }
            }
        }
        debug_assert!(last != u32::MAX);
        self.last = last;
        Ok(())
    }

    /// Local ids of the cavity boundary's vertices for the dense linker;
    /// false when there are more than [`DENSE_MAX`].
    fn name_locals(&mut self) -> bool {
        let inf_slot = self.local.len() - 1;
        self.local_ids.clear();
        let mut count = 0usize;
        let mut fits = true;
        'faces: for &(tet, _, slot, _) in &self.boundary {
            let mut ids = [0u8; 4];
            for (x, &vx) in tet.v.iter().enumerate() {
                if x == slot as usize {
                    continue;
                }
                let at = if vx == INF { inf_slot } else { vx as usize };
                let mut l = self.local[at];
                if l == NO_LOCAL {
                    if count == DENSE_MAX {
                        fits = false;
                        break 'faces;
                    }
                    l = count as u8;
                    count += 1;
                    self.local[at] = l;
                    self.local_verts.push(at as u32);
                }
                ids[x] = l;
            }
            self.local_ids.push(ids);
        }
        for &at in &self.local_verts {
            self.local[at as usize] = NO_LOCAL;
        }
        self.local_verts.clear();
        fits
    }
}

/// Counts of what the parallel phase did, for tests and tuning.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub(crate) struct ParallelStats {
    pub(crate) inserted: usize,
    pub(crate) deferred: usize,
}

impl Triangulation {
    /// Inserts points `from..` with `threads` workers on contiguous runs,
    /// then the deferred ones sequentially.
    pub(crate) fn insert_parallel(&mut self, from: u32, threads: usize) -> ParallelStats {
        let n = self.pts.len() as u32;
        let threads = threads.clamp(1, 64);
        if from >= n || threads < 2 {
            for v in from..n {
                self.insert(v);
            }
            return ParallelStats::default();
        }
        let todo = (n - from) as usize;
        // ~6.7 finite tets per point plus ghosts; over-reserving by 8 per
        // point keeps OutOfSlots deferrals rare.
        let cap = self.tets.len() + 8 * todo + 2 * threads * SLOT_BLOCK;
        let used = self.tets.len();
        let mut shared_tets: Vec<AtomicTet> = Vec::with_capacity(cap);
        shared_tets.extend(self.tets.drain(..).map(AtomicTet::new));
        shared_tets.resize_with(cap, || AtomicTet::new(Tet { v: [DEAD; 4], n: [u32::MAX; 4] }));
        self.tets = Vec::new();
        let locks: Vec<AtomicU8> = (0..cap).map(|_| AtomicU8::new(FREE)).collect();
        let shared = Shared {
            pts: &self.pts,
            filter: &self.filter,
            orig: &self.orig,
            tets: shared_tets,
            locks,
            len: AtomicUsize::new(used),
        };
        let mut free = std::mem::take(&mut self.free);
        let last0 = self.last;
        let n_local = self.pts.len() + 1;
        let chunk = todo.div_ceil(threads);
        let results: Vec<(Vec<u32>, Vec<u32>, u32)> = std::thread::scope(|scope| {
            let handles: Vec<_> = (0..threads)
                .map(|w| {
                    let lo = from as usize + w * chunk;
                    let hi = (lo + chunk).min(n as usize);
                    // Each worker starts with a share of the free slots.
                    let my_free = if w == 0 { std::mem::take(&mut free) } else { Vec::new() };
                    let sh = &shared;
                    scope.spawn(move || {
                        let mut wk = Worker {
                            sh,
                            touched: (2 * w + 1) as u8,
                            cavity: (2 * w + 2) as u8,
                            last: last0,
                            rng: SplitMix64(0x5EED ^ (w as u64 + 1)),
                            free: my_free,
                            block_next: 0,
                            block_end: 0,
                            locked: Vec::new(),
                            stack: Vec::new(),
                            conflict: Vec::new(),
                            boundary: Vec::new(),
                            local: vec![NO_LOCAL; n_local],
                            local_verts: Vec::new(),
                            local_ids: Vec::new(),
                            edge: vec![0; DENSE_MAX * DENSE_MAX],
                            deferred: Vec::new(),
                        };
                        for v in lo as u32..hi as u32 {
                            wk.insert(v);
                        }
                        (wk.deferred, wk.free, wk.last)
                    })
                })
                .collect();
            handles.into_iter().map(|h| h.join().unwrap_or_else(|e| std::panic::resume_unwind(e))).collect()
        });
        let len = shared.len.load(Relaxed).min(cap);
        let Shared { tets: shared_tets, .. } = shared;
        self.tets = shared_tets.into_iter().take(len).map(|t| t.load()).collect();
        let mut deferred = Vec::new();
        let live_finite =
            |tets: &[Tet], t: u32| tets.get(t as usize).is_some_and(|t| t.v[0] != DEAD && !is_ghost(&t.v));
        let mut last = None;
        for (d, _, l) in results {
            deferred.extend(d);
            if live_finite(&self.tets, l) {
                last = Some(l);
            }
        }
        // Walks must start in a live finite tet; the one the round started
        // from may have been rebuilt by a worker.
        self.last = last.filter(|&l| live_finite(&self.tets, l)).unwrap_or_else(|| {
            (0..self.tets.len() as u32).find(|&t| live_finite(&self.tets, t)).expect("a triangulation has a finite tet")
        });
        // Abandoned reservations and freed slots are DEAD; reuse them all.
        self.free.clear();
        self.free.extend((0..self.tets.len() as u32).filter(|&t| self.tets[t as usize].v[0] == DEAD));
        deferred.sort_unstable();
        for &v in &deferred {
            self.insert(v);
        }
        ParallelStats { inserted: todo - deferred.len(), deferred: deferred.len() }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Finite tets as sorted vertex sets in input ids, sorted.
    fn canonical(t: &Triangulation) -> Vec<[u32; 4]> {
        let (mut tets, _) = t.finite_tets(None);
        for v in &mut tets {
            v.sort_unstable();
        }
        tets.sort_unstable();
        tets
    }

    fn build(pts: &[[f64; 3]], threads: usize) -> (Triangulation, ParallelStats) {
        let order = crate::sort::brio_order(pts, (0..pts.len() as u32).collect(), 3);
        let order = crate::initial_tet(pts, order).unwrap();
        let mut t = Triangulation::new(order.iter().map(|&i| pts[i as usize]).collect(), order);
        let from = (pts.len() / 8) as u32;
        t.insert_range(4, from);
        let stats = t.insert_parallel(from, threads);
        (t, stats)
    }

    #[test]
    fn parallel_insertion_gives_the_sequential_triangulation() {
        let mut rng = SplitMix64(99);
        let random: Vec<[f64; 3]> = (0..40_000).map(|_| [rng.next_f64(), rng.next_f64(), rng.next_f64()]).collect();
        // A cospherical lattice: every tie goes to the symbolic perturbation.
        let lattice: Vec<[f64; 3]> =
            (0..24 * 24 * 24).map(|i| [(i % 24) as f64, ((i / 24) % 24) as f64, (i / 576) as f64]).collect();
        for pts in [&random, &lattice] {
            let (seq, _) = build(pts, 1);
            let want = canonical(&seq);
            for threads in [2, 3, 5] {
                let (par, stats) = build(pts, threads);
                assert_eq!(stats.inserted + stats.deferred, pts.len() - pts.len() / 8);
                assert_eq!(canonical(&par), want, "{threads} threads");
                // Links stay symmetric and no slot is both live and free.
                for (s, tet) in par.tets.iter().enumerate() {
                    if tet.v[0] == DEAD {
                        continue;
                    }
                    for &nb in &tet.n {
                        assert!(par.tets[nb as usize].n.contains(&(s as u32)), "tet {s} -> {nb} not symmetric");
                    }
                }
                assert!(par.free.iter().all(|&f| par.tets[f as usize].v[0] == DEAD));
            }
        }
    }
}
