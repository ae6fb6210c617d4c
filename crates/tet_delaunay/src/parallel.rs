//! Parallel Bowyer–Watson for large BRIO rounds: worker threads insert
//! contiguous runs of a Hilbert-sorted round concurrently into the shared
//! tets, without locks.
//!
//! Concurrency contract (all safe Rust: tets are atomics accessed
//! `Relaxed`; the workers' scope join orders everything between rounds):
//! - Space is partitioned by Hilbert key at the workers' run boundaries, and
//!   every vertex — inserted or not — belongs to the worker whose key range
//!   holds it. The infinite vertex belongs to all.
//! - A worker rewrites only tets whose vertices it all owns (its conflict
//!   zone), plus the back link of each tet just outside that zone. It walks
//!   only through tets it owns, and a walk or conflict zone that reaches a
//!   tet with a foreign vertex puts the point off, undoing its marks.
//! - Why that is race-free: a tet outside worker A's zone that A relinks
//!   shares a face — three vertices — with A's zone, so it has at most one
//!   vertex of any other worker B, and B can neither rewrite it (B must own
//!   all four) nor relink it (B needs three). The same counting shows that
//!   every tet A reads — the ones it owns, their neighbours, and the finite
//!   tet behind a ghost neighbour's hull facet — is changed by no other
//!   worker during the round, so A's reads are never torn. The one
//!   exception is the first tet of a worker that found no start tet of its
//!   own (`start_tet`): it may be mid-rewrite by another worker, so the
//!   ownership test (`owned_by`) rejects cavity markers, freed slots and
//!   torn mixes, and the walk defers.
//! - New tets go into the worker's freed slots or fresh slots taken from the
//!   spare array in private blocks. Deferred points (near the partition
//!   borders, or after a walk too long or slots run out) are inserted
//!   sequentially after the round.
//!
//! The symbolic perturbation keys on input ids, so the Delaunay
//! tetrahedralization is unique and the result does not depend on which
//! thread inserted what, or in which order.

use crate::sort::SplitMix64;
use crate::triangulation::{is_ghost, owned_by, Deferred, Inserter, Triangulation, DEAD, MAX_WORKERS};
use std::sync::atomic::AtomicUsize;

/// Fresh tet slots a worker takes from the spare array at a time.
pub(crate) const BLOCK: usize = 4096;
/// Pass 2 runs when pass 1 put off at least this many points per worker.
/// (Tests lower it so that both passes run on small sets.)
const PASS2_MIN: usize = if cfg!(test) { 16 } else { 2048 };

/// Counts of what a parallel round did, for tests and tuning.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub(crate) struct ParallelStats {
    /// Points inserted by workers (either pass).
    pub(crate) inserted: usize,
    /// Points pass 1 put off.
    pub(crate) deferred_pass1: usize,
    /// Points both passes put off, inserted sequentially.
    pub(crate) sequential: usize,
}

impl Triangulation {
    /// Inserts points `from..to` — one BRIO round, in Hilbert order, with
    /// `keys[v]` the Hilbert key of point `v` — with `threads` workers.
    ///
    /// Pass 1 gives each worker a contiguous run of the round and the part
    /// of space between its run's first key and the next run's. The points
    /// it defers lie near those borders; pass 2 re-partitions them by
    /// coordinate quantiles along their widest axis, which cuts across the
    /// old borders, and only what both passes deferred goes sequentially.
    pub(crate) fn insert_parallel(&mut self, from: u32, to: u32, keys: &[u64], threads: usize) -> ParallelStats {
        use rayon::prelude::*;
        let to = to.min(self.pts.len() as u32);
        let threads = threads.clamp(1, MAX_WORKERS);
        let todo = to.saturating_sub(from) as usize;
        if todo < 2 * threads || threads < 2 {
            self.insert_range(from, to);
            return ParallelStats { inserted: todo, ..ParallelStats::default() };
        }
        // Room for the round: ~6.7 tets per point plus every worker's
        // partly used block, so running out stays rare.
        self.grow_to(self.used + todo * 29 / 4 + 2 * threads * BLOCK);
        let chunk = todo.div_ceil(threads);
        let runs: Vec<Vec<u32>> = (0..threads)
            .map(|w| (from + (w * chunk).min(todo) as u32..from + ((w + 1) * chunk).min(todo) as u32).collect())
            .filter(|r: &Vec<u32>| !r.is_empty())
            .collect();
        let splits: Vec<u64> = runs[1..].iter().map(|r| keys[r[0] as usize]).collect();
        let owner: Vec<u8> = keys[..to as usize].par_iter().map(|k| splits.partition_point(|s| s <= k) as u8).collect();
        let deferred = self.parallel_pass(runs, &owner);
        let pass1 = deferred.len();

        let deferred = if deferred.len() >= PASS2_MIN * threads {
            let (lo, hi) = tet_mesh::stats::bounds(&deferred.iter().map(|&v| self.pts[v as usize]).collect::<Vec<_>>());
            let axis = (0..3).max_by(|&a, &b| (hi[a] - lo[a]).total_cmp(&(hi[b] - lo[b]))).unwrap_or(0);
            let mut coords: Vec<f64> = deferred.iter().map(|&v| self.pts[v as usize][axis]).collect();
            coords.sort_unstable_by(f64::total_cmp);
            let splits: Vec<f64> = (1..threads).map(|w| coords[w * coords.len() / threads]).collect();
            let pts = &self.pts[..to as usize];
            let owner: Vec<u8> = pts.par_iter().map(|p| splits.partition_point(|s| *s <= p[axis]) as u8).collect();
            let mut runs: Vec<Vec<u32>> = vec![Vec::new(); threads];
            for &v in &deferred {
                runs[owner[v as usize] as usize].push(v);
            }
            runs.retain(|r| !r.is_empty());
            self.parallel_pass(runs, &owner)
        } else {
            deferred
        };
        self.insert_points(&deferred);
        ParallelStats { inserted: todo - deferred.len(), deferred_pass1: pass1, sequential: deferred.len() }
    }

    /// One parallel pass: worker `w` inserts `runs[w]` (in order) touching
    /// only tets whose finite vertices `owner` gives to `w`. Returns the
    /// points put off, in insertion order.
    fn parallel_pass(&mut self, runs: Vec<Vec<u32>>, owner: &[u8]) -> Vec<u32> {
        let starts: Vec<u32> = {
            let next = AtomicUsize::new(self.used);
            let mut probe = Inserter::new(self, &next, None, 0, self.last, Vec::new(), SplitMix64(7));
            runs.iter().enumerate().map(|(w, run)| self.start_tet(&mut probe, run, owner, w as u8)).collect()
        };
        let next = AtomicUsize::new(self.used);
        let mut free = std::mem::take(&mut self.free);
        let share = free.len().div_ceil(runs.len()).max(1);
        let mut frees: Vec<Vec<u32>> = Vec::new();
        while !free.is_empty() {
            let rest = free.split_off(free.len().saturating_sub(share));
            frees.push(rest);
        }
        frees.resize_with(runs.len(), Vec::new);
        let tri = &*self;
        let next_ref = &next;
        type WorkerResult = (Vec<u32>, Vec<u32>, std::ops::Range<usize>, u32, usize);
        let results: Vec<WorkerResult> = std::thread::scope(|scope| {
            let handles: Vec<_> = runs
                .iter()
                .zip(starts.iter())
                .zip(frees)
                .enumerate()
                .map(|(w, ((run, &start), my_free))| {
                    scope.spawn(move || {
                        let rng = SplitMix64(0x5EED ^ (w as u64 + 1));
                        let mut ins = Inserter::new(tri, next_ref, Some(owner), w as u8, start, my_free, rng);
                        let mut deferred = Vec::new();
                        let mut inserted = 0;
                        for &v in run {
                            match ins.insert(v) {
                                Ok(()) => inserted += 1,
                                Err(Deferred::Foreign | Deferred::LongWalk | Deferred::OutOfSlots) => deferred.push(v),
                            }
                        }
                        let fresh = ins.unused_fresh();
                        (deferred, std::mem::take(&mut ins.free), fresh, ins.last, inserted)
                    })
                })
                .collect();
            handles.into_iter().map(|h| h.join().unwrap_or_else(|e| std::panic::resume_unwind(e))).collect()
        });

        // Slots taken but not used: the topmost blocks lower `used`, the
        // others go on the free list.
        let mut end = next.into_inner().min(self.tets.len());
        let mut fresh: Vec<std::ops::Range<usize>> = results.iter().map(|r| r.2.clone()).collect();
        fresh.sort_by_key(|r| std::cmp::Reverse(r.end));
        for r in fresh {
            if r.is_empty() {
                continue;
            }
            if r.end >= end {
                end = end.min(r.start);
            } else {
                self.free.extend(r.start as u32..r.end as u32);
            }
        }
        self.used = end;
        let live_finite = |t: &Triangulation, s: u32| {
            (s as usize) < t.used && {
                let v = t.tets[s as usize].load().v;
                v[0] != DEAD && !is_ghost(&v)
            }
        };
        let mut deferred = Vec::new();
        for (d, f, _, last, inserted) in results {
            deferred.extend(d);
            self.free.extend(f);
            if inserted > 0 && live_finite(self, last) {
                self.last = last;
            }
        }
        if !live_finite(self, self.last) {
            self.last =
                (0..self.used as u32).find(|&t| live_finite(self, t)).expect("a triangulation has a finite tet");
        }
        deferred.sort_unstable();
        deferred
    }

    /// A live tet owned by worker `me` near the start of its run, found by
    /// sequential walks before the workers start, for its first walk.
    /// When none of the sampled points lies in such a tet (small runs, or
    /// runs along a partition border), the first live finite tet `me` owns
    /// anywhere; failing that, the global start. A worker starting on a tet
    /// it does not own reads that tet while others may rewrite it — the
    /// torn read is rejected by `owned_by` — and defers its points to the
    /// sequential tail: correct, only slower.
    fn start_tet(&self, probe: &mut Inserter, run: &[u32], owner: &[u8], me: u8) -> u32 {
        let mine = |t: u32| {
            let v = self.tets[t as usize].load().v;
            v[0] != DEAD && !is_ghost(&v) && owned_by(owner, me, &v)
        };
        let step = (run.len() / 16).max(1);
        for &v in run.iter().step_by(step).take(16) {
            // A sequential probe never defers; its walk reads only.
            if let Ok(t) = probe.locate(&self.pts[v as usize]) {
                if mine(t) {
                    return t;
                }
            }
        }
        (0..self.used as u32).find(|&t| mine(t)).unwrap_or(self.last)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::triangulation::tests::check;

    /// Finite tets as sorted vertex sets in input ids, sorted.
    fn canonical(t: &Triangulation) -> Vec<[u32; 4]> {
        let (mut tets, _, _) = t.finite_tets(None);
        for v in &mut tets {
            v.sort_unstable();
        }
        tets.sort_unstable();
        tets
    }

    /// The library's pipeline with every round of at least `min_round`
    /// points inserted by `threads` workers.
    fn build(pts: &[[f64; 3]], threads: usize, min_round: usize) -> (Triangulation, ParallelStats) {
        let keys = crate::sort::hilbert_keys(pts);
        let (order, ends) = crate::sort::brio_order_keyed(&keys, (0..pts.len() as u32).collect(), 3);
        let order = crate::initial_tet(pts, order).unwrap();
        let keys: Vec<u64> = order.iter().map(|&o| keys[o as usize]).collect();
        let mut t = Triangulation::new(order.iter().map(|&i| pts[i as usize]).collect(), order);
        let mut stats = ParallelStats::default();
        let mut start = 4;
        for &end in &ends {
            let end = end as u32;
            if end <= start {
                continue;
            }
            if (end - start) as usize >= min_round {
                let s = t.insert_parallel(start, end, &keys, threads);
                stats.inserted += s.inserted;
                stats.deferred_pass1 += s.deferred_pass1;
                stats.sequential += s.sequential;
            } else {
                t.insert_range(start, end);
            }
            start = end;
        }
        (t, stats)
    }

    #[test]
    fn parallel_insertion_gives_the_sequential_triangulation() {
        let mut rng = SplitMix64(99);
        let random: Vec<[f64; 3]> = (0..40_000).map(|_| [rng.next_f64(), rng.next_f64(), rng.next_f64()]).collect();
        // A cospherical lattice: every tie goes to the symbolic perturbation.
        let lattice: Vec<[f64; 3]> =
            (0..24 * 24 * 24).map(|i| [(i % 24) as f64, ((i / 24) % 24) as f64, (i / 576) as f64]).collect();
        // Two thin slabs: walks and zones cross the partition borders often.
        let slabs: Vec<[f64; 3]> =
            (0..20_000).map(|i| [rng.next_f64(), rng.next_f64(), (i % 2) as f64 + 1e-3 * rng.next_f64()]).collect();
        for pts in [&random, &lattice, &slabs] {
            let (seq, _) = build(pts, 1, usize::MAX);
            check(&seq, false);
            let want = canonical(&seq);
            for threads in [2, 3, 5] {
                let (par, stats) = build(pts, threads, 1000);
                assert!(stats.inserted > 0 && stats.deferred_pass1 > 0 && stats.inserted < pts.len(), "{stats:?}");
                assert!(stats.sequential < stats.deferred_pass1, "{stats:?}");
                check(&par, false);
                assert_eq!(canonical(&par), want, "{threads} threads");
            }
        }
    }
}
