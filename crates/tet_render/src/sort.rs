//! Visibility order of the tets, front to back.
//!
//! * [`SortMethod::Mpvo`] (Williams 1992): across every interior face the
//!   tet on the eye's side comes first. The face sides come from
//!   [`ViewGeometry::face_mask`] (exact orientation predicates for
//!   perspective; a canonical, antisymmetric sign for parallel). The
//!   resulting DAG is sorted by Kahn's algorithm in parallel layers (each
//!   layer sorted by tet id, so the order does not depend on the thread
//!   count). Exact for convex meshes without cycles — Delaunay meshes have
//!   none for any viewpoint.
//! * [`SortMethod::Mpvonc`]: for non-convex meshes two tets can occlude each
//!   other through empty space without sharing a face. As in Williams'
//!   MPVONC, ready tets (all face-neighbours in front already drawn) are not
//!   taken in arbitrary order but nearest first — a priority queue keyed by
//!   each tet's nearest vertex depth — so a tet behind a concavity waits for
//!   the nearer parts of the mesh. Residual limit: this is the heuristic,
//!   not an exact order (XMPVO or a BSP of the boundary would be); a tet can
//!   still be drawn before a non-neighbour in front of it when their depth
//!   intervals interleave across a concavity.
//! * [`SortMethod::Radix`]: centroid depth, LSD radix sort — fast,
//!   approximate (wrong where small and large tets interleave).
//!
//! Cycles (possible in MPVO graphs of non-Delaunay meshes, and near-
//! degenerate views) are broken by emitting the nearest remaining tet; the
//! number broken is reported.

use crate::project::{ViewGeometry, BACK, FRONT};
use crate::scene::Scene;
use rayon::prelude::*;
use serde::{Deserialize, Serialize};
use std::cmp::Reverse;
use std::collections::BinaryHeap;
use std::sync::atomic::{AtomicU8, Ordering};
use tet_mesh::NO_NEIGHBOR;

/// How to order the tets.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, Serialize, Deserialize, Default)]
#[serde(rename_all = "lowercase")]
pub enum SortMethod {
    Mpvo,
    Mpvonc,
    Radix,
    /// MPVO on convex meshes, MPVONC otherwise.
    #[default]
    Auto,
}

impl SortMethod {
    pub fn id(self) -> &'static str {
        match self {
            SortMethod::Mpvo => "mpvo",
            SortMethod::Mpvonc => "mpvonc",
            SortMethod::Radix => "radix",
            SortMethod::Auto => "auto",
        }
    }
    /// The method actually run for a scene.
    pub fn resolve(self, scene: &Scene) -> SortMethod {
        match self {
            SortMethod::Auto if scene.is_convex() => SortMethod::Mpvo,
            SortMethod::Auto => SortMethod::Mpvonc,
            m => m,
        }
    }
}

impl std::str::FromStr for SortMethod {
    type Err = String;
    fn from_str(s: &str) -> Result<Self, String> {
        match s {
            "mpvo" => Ok(SortMethod::Mpvo),
            "mpvonc" => Ok(SortMethod::Mpvonc),
            "radix" => Ok(SortMethod::Radix),
            "auto" => Ok(SortMethod::Auto),
            _ => Err(format!("unknown sort '{s}'; known: mpvo, mpvonc, radix, auto")),
        }
    }
}

/// A front-to-back order of the visible tets.
#[derive(Debug, Clone, PartialEq)]
pub struct VisibilityOrder {
    /// Tet ids, nearest first.
    pub tets: Vec<u32>,
    /// The method that produced it (never `Auto`).
    pub method: SortMethod,
    /// Tets emitted to break a cycle of the MPVO graph.
    pub cycles_broken: usize,
}

/// Orders the tets for which `visible` is true (all when `None`) front to
/// back. MPVO and MPVONC walk the whole graph — an invisible tet still
/// carries the ordering between its neighbours — but emit only visible
/// tets; the radix sort sorts only visible tets.
pub fn visibility_order(
    scene: &Scene,
    view: &ViewGeometry,
    method: SortMethod,
    visible: Option<&[bool]>,
) -> VisibilityOrder {
    let method = method.resolve(scene);
    let (tets, cycles_broken) = match method {
        SortMethod::Radix => (radix_order(scene, view, visible), 0),
        SortMethod::Mpvo => mpvo_layers(scene, view, visible),
        _ => mpvonc(scene, view, visible),
    };
    VisibilityOrder { tets, method, cycles_broken }
}

/// Depth of a tet's centroid (camera z).
fn centroid_depth(view: &ViewGeometry, t: &[u32; 4]) -> f64 {
    0.25 * t.iter().map(|&v| view.cam[v as usize][2]).sum::<f64>()
}

/// Order-preserving map of an f64 onto u64.
#[inline]
fn f64_key(x: f64) -> u64 {
    let b = x.to_bits();
    if b >> 63 == 1 {
        !b
    } else {
        b | (1 << 63)
    }
}

#[inline]
fn f32_key(x: f32) -> u32 {
    let b = x.to_bits();
    if b >> 31 == 1 {
        !b
    } else {
        b | (1 << 31)
    }
}

/// Centroid-depth order by LSD radix sort on f32 keys (3 passes of 11 bits).
fn radix_order(scene: &Scene, view: &ViewGeometry, visible: Option<&[bool]>) -> Vec<u32> {
    let mut items: Vec<(u32, u32)> = scene
        .tets()
        .par_iter()
        .enumerate()
        .filter(|(t, _)| visible.is_none_or(|v| v[*t]))
        .map(|(t, tet)| (f32_key(centroid_depth(view, tet) as f32), t as u32))
        .collect();
    let mut tmp = vec![(0u32, 0u32); items.len()];
    for pass in 0..3 {
        let shift = pass * 11;
        let mut count = [0usize; 2049];
        for &(k, _) in &items {
            count[((k >> shift) & 0x7ff) as usize + 1] += 1;
        }
        for i in 0..2048 {
            count[i + 1] += count[i];
        }
        for &it in &items {
            let b = ((it.0 >> shift) & 0x7ff) as usize;
            tmp[count[b]] = it;
            count[b] += 1;
        }
        std::mem::swap(&mut items, &mut tmp);
    }
    items.into_iter().map(|(_, t)| t).collect()
}

/// Number of face-neighbours in front of each tet, and the mask of faces
/// with a neighbour behind.
#[inline]
fn in_front_count(view: &ViewGeometry, nb: &[u32; 4], t: usize) -> (u8, u8) {
    let m = view.face_mask[t];
    let (mut front, mut behind) = (0u8, 0u8);
    for (f, &n) in nb.iter().enumerate() {
        if n == NO_NEIGHBOR {
            continue;
        }
        if m & FRONT & (1 << f) != 0 {
            front += 1;
        } else if m & BACK & (1 << (4 + f)) != 0 {
            behind |= 1 << f;
        }
    }
    (front, behind)
}

/// An in-degree no decrement can bring back to 1: marks forced (cycle-breaking) tets.
const FORCED: u8 = 128;

/// Nearest-first scan for cycle breaking, built on first need.
struct CycleBreaker {
    by_depth: Option<Vec<u32>>,
    next: usize,
}

impl CycleBreaker {
    fn new() -> Self {
        CycleBreaker { by_depth: None, next: 0 }
    }
    /// The nearest tet still waiting (0 < in-degree < FORCED − 4).
    fn pick(&mut self, scene: &Scene, view: &ViewGeometry, indeg: &[AtomicU8]) -> Option<u32> {
        let list = self.by_depth.get_or_insert_with(|| {
            let mut v: Vec<(u64, u32)> = scene
                .tets()
                .par_iter()
                .enumerate()
                .map(|(t, tet)| (f64_key(centroid_depth(view, tet)), t as u32))
                .collect();
            v.par_sort_unstable();
            v.into_iter().map(|(_, t)| t).collect()
        });
        while self.next < list.len() {
            let t = list[self.next];
            self.next += 1;
            let d = indeg[t as usize].load(Ordering::Relaxed);
            if d > 0 && d < FORCED - 4 {
                indeg[t as usize].store(FORCED, Ordering::Relaxed);
                return Some(t);
            }
        }
        None
    }
}

fn mpvo_layers(scene: &Scene, view: &ViewGeometry, visible: Option<&[bool]>) -> (Vec<u32>, usize) {
    let nbs = scene.neighbors();
    let counts: Vec<(u8, u8)> = nbs.par_iter().enumerate().map(|(t, nb)| in_front_count(view, nb, t)).collect();
    let indeg: Vec<AtomicU8> = counts.iter().map(|c| AtomicU8::new(c.0)).collect();
    let mut layer: Vec<u32> = counts.par_iter().enumerate().filter(|(_, c)| c.0 == 0).map(|(t, _)| t as u32).collect();
    let n = scene.num_tets();
    let mut order = Vec::with_capacity(visible.map_or(n, |v| v.iter().filter(|&&x| x).count()));
    let mut emitted = 0usize;
    let mut breaker = CycleBreaker::new();
    let mut cycles = 0;
    while emitted < n {
        if layer.is_empty() {
            match breaker.pick(scene, view, &indeg) {
                Some(t) => {
                    cycles += 1;
                    layer.push(t);
                }
                None => break,
            }
        }
        emitted += layer.len();
        order.extend(layer.iter().copied().filter(|&t| visible.is_none_or(|v| v[t as usize])));
        let release = |t: &u32, out: &mut Vec<u32>| {
            let behind = counts[*t as usize].1;
            for (f, &nb) in nbs[*t as usize].iter().enumerate() {
                if behind & (1 << f) != 0 && indeg[nb as usize].fetch_sub(1, Ordering::AcqRel) == 1 {
                    out.push(nb);
                }
            }
        };
        let mut next: Vec<u32> = if layer.len() > 4096 {
            layer
                .par_chunks(1024)
                .map(|chunk| {
                    let mut out = Vec::new();
                    chunk.iter().for_each(|t| release(t, &mut out));
                    out
                })
                .flatten()
                .collect()
        } else {
            let mut out = Vec::new();
            layer.iter().for_each(|t| release(t, &mut out));
            out
        };
        if next.len() > 4096 {
            next.par_sort_unstable();
        } else {
            next.sort_unstable();
        }
        layer = next;
    }
    (order, cycles)
}

fn mpvonc(scene: &Scene, view: &ViewGeometry, visible: Option<&[bool]>) -> (Vec<u32>, usize) {
    let nbs = scene.neighbors();
    let counts: Vec<(u8, u8)> = nbs.par_iter().enumerate().map(|(t, nb)| in_front_count(view, nb, t)).collect();
    let indeg: Vec<AtomicU8> = counts.iter().map(|c| AtomicU8::new(c.0)).collect();
    // Every tet's key up front, in parallel: the loop below is sequential.
    let near: Vec<u64> = scene
        .tets()
        .par_iter()
        .map(|tet| f64_key(tet.iter().map(|&v| view.cam[v as usize][2]).fold(f64::INFINITY, f64::min)))
        .collect();
    let near_key = |t: u32| near[t as usize];
    let mut heap: BinaryHeap<Reverse<(u64, u32)>> = counts
        .iter()
        .enumerate()
        .filter(|(_, c)| c.0 == 0)
        .map(|(t, _)| Reverse((near_key(t as u32), t as u32)))
        .collect();
    let n = scene.num_tets();
    let mut order = Vec::with_capacity(n);
    let mut emitted = 0;
    let mut breaker = CycleBreaker::new();
    let mut cycles = 0;
    while emitted < n {
        let t = match heap.pop() {
            Some(Reverse((_, t))) => t,
            None => match breaker.pick(scene, view, &indeg) {
                Some(t) => {
                    cycles += 1;
                    t
                }
                None => break,
            },
        };
        emitted += 1;
        if visible.is_none_or(|v| v[t as usize]) {
            order.push(t);
        }
        let behind = counts[t as usize].1;
        for (f, &nb) in nbs[t as usize].iter().enumerate() {
            if behind & (1 << f) != 0 && indeg[nb as usize].fetch_sub(1, Ordering::Relaxed) == 1 {
                heap.push(Reverse((near_key(nb), nb)));
            }
        }
    }
    (order, cycles)
}
