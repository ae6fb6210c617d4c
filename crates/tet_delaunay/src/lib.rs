//! Tetrahedralizing scattered points: an exact, fast 3D Delaunay
//! tetrahedralization and a layered (2.5D) mode.
//!
//! - [`tetrahedralize_points`] — 3D Delaunay of a point cloud, returning a
//!   [`Delaunay`] (tets, duplicate-merge map, hull facts) or a
//!   [`DelaunayError`]. Options in [`DelaunayOptions`].
//! - [`tetrahedralize_layers`] — points on stacked layers (terrain strata,
//!   boreholes, atmospheric columns): triangulates layer 0 in xy and joins
//!   consecutive layers with prisms split into conforming tets, giving a
//!   [`Layered`].
//! - [`tetrahedralize_cloud`] — the same tets without the cell list, for a
//!   conversion that takes tets as they are.
//! - [`triangulate_cloud`] — a point cloud read from a file (a `SourceMesh`
//!   without cells) given tet cells by either mode ([`CloudMode`]), ready for
//!   the ordinary conversion.
//! - [`check_delaunay`] — the invariant checker tests and fuzzing use: a
//!   [`DelaunayViolation`] names the first broken invariant.
//! - [`SplitMix64`] — the small seeded generator the tests, benchmark and
//!   example use for reproducible random points.
//!
//! # Which mode
//! Use the 3D mode for genuinely scattered samples (particles, stars,
//! sensors, a lidar cloud treated as a volume): it fills the convex hull
//! with the Delaunay tets, whose empty circumspheres make them as round as
//! the samples allow, and MPVO visibility sorting is exact on it. If the
//! sampled object is not convex, set [`DelaunayOptions::max_circumradius`]
//! to peel off the large tets that bridge concavities (the result is then
//! non-convex). Use the layered mode when every sample belongs to one of a
//! few layers with the same xy columns (a terrain-following grid): 3D
//! Delaunay of such data makes flat, needle-like tets between layers and
//! mixes layers, while prisms keep each tet between two consecutive layers.
//!
//! # Exactness
//! Orientation and in-sphere decisions are exact (Shewchuk's adaptive
//! predicates from `robust`); ties between cospherical points (lattices,
//! coplanar layers, collinear runs) are broken by a symbolic perturbation
//! keyed on point ids, so any input with 4 non-coplanar distinct points
//! gives a valid Delaunay tetrahedralization without flat tets. The hull is
//! closed by an infinite vertex, so no hull tet is lost.
//!
//! ```
//! use tet_delaunay::{tetrahedralize_points, DelaunayOptions};
//! // The 8 corners of a cube (all cospherical) plus a duplicate corner.
//! let mut pts = Vec::new();
//! for k in 0..2 { for j in 0..2 { for i in 0..2 { pts.push([i as f64, j as f64, k as f64]); } } }
//! pts.push([1.0, 1.0, 1.0]);
//! let d = tetrahedralize_points(&pts, &DelaunayOptions::default()).unwrap();
//! assert_eq!(d.duplicates, 1);
//! assert_eq!(d.merged_into[8], 7);
//! assert_eq!(d.hull_facets, 12);
//! let volume: f64 = d.tets.iter().map(|t| tet_mesh::predicates::signed_tet_volume(
//!     &pts[t[0] as usize], &pts[t[1] as usize], &pts[t[2] as usize], &pts[t[3] as usize])).sum();
//! assert!((volume - 1.0).abs() < 1e-12);
//! ```
#![forbid(unsafe_code)]

mod check;
mod cloud;
mod error;
mod layers;
mod parallel;
mod predicates;
mod sort;
mod triangulation;

pub use check::{check_delaunay, DelaunayViolation};
pub use cloud::{tetrahedralize_cloud, triangulate_cloud, CloudMode, CloudReport};
pub use error::DelaunayError;
pub use layers::{tetrahedralize_layers, Layered};
pub use sort::SplitMix64;

use predicates::orient;
use triangulation::Triangulation;

/// BRIO rounds at least this large are inserted in parallel.
const PARALLEL_ROUND_MIN: usize = 50_000;

/// The most points [`tetrahedralize_points`] accepts (2^29): their tets
/// must stay indexable by u32.
pub const MAX_POINTS: usize = 1 << 29;

/// The largest coordinate magnitude [`tetrahedralize_points`] accepts
/// (2^190 ≈ 1.6e57): the in-sphere determinant is a degree-5 polynomial in
/// coordinate differences, and its exact evaluation must not overflow.
pub const MAX_COORDINATE: f64 = 1.5692754338466702e57;

/// Options for [`tetrahedralize_points`].
#[derive(Debug, Clone, Default)]
pub struct DelaunayOptions {
    /// Peel off hull-filling tets: starting from the convex hull, tets with
    /// a circumradius above this (in the points' units) are removed, and so
    /// are their neighbours above it, until only tets at most this large
    /// face the outside. Large tets enclosed by small ones stay. `None`
    /// keeps the whole convex hull.
    pub max_circumradius: Option<f64>,
}

/// A 3D Delaunay tetrahedralization.
#[derive(Debug, Clone)]
pub struct Delaunay {
    /// Positively oriented tets (det[p1−p0, p2−p0, p3−p0] > 0) indexing the
    /// input points. Only representatives of duplicate groups appear.
    pub tets: Vec<[u32; 4]>,
    /// `neighbors[t][f]`: the tet across the face of `tets[t]` opposite its
    /// vertex `f`, or `u32::MAX` on the boundary — the face adjacency the
    /// insertion maintained, in `tet_mesh::Adjacency`'s convention, so a
    /// caller need not rebuild it.
    pub neighbors: Vec<[u32; 4]>,
    /// For each input point, the point it was merged into: the first point
    /// with bit-identical coordinates (±0 equal), or itself.
    pub merged_into: Vec<u32>,
    /// Input points merged into an earlier identical point.
    pub duplicates: usize,
    /// Triangles on the convex hull of the points.
    pub hull_facets: usize,
    /// Tets removed by [`DelaunayOptions::max_circumradius`]; when nonzero
    /// the tets no longer fill the convex hull.
    pub removed_cells: usize,
    /// Point locations that fell back to a scan of all tets (a safety net;
    /// expected 0).
    pub walk_fallbacks: usize,
    /// Points of the parallel rounds that workers put off in both passes
    /// (their walk or conflict zone reached another worker's part of space,
    /// or rarely a walk ran long) and the round's sequential tail inserted;
    /// 0 when the input was too small to insert in parallel.
    pub parallel_deferred: usize,
}

impl Delaunay {
    /// True when the tets fill the convex hull of the points.
    pub fn fills_convex_hull(&self) -> bool {
        self.removed_cells == 0
    }
}

/// Delaunay tetrahedralization of `points`.
///
/// Identical points are merged first (see [`Delaunay::merged_into`]).
/// Errors: a non-finite coordinate or one beyond [`MAX_COORDINATE`]
/// (naming the first such point), more
/// than [`MAX_POINTS`] points, fewer than 4 distinct non-coplanar points, or a
/// non-positive `max_circumradius`.
pub fn tetrahedralize_points(points: &[[f64; 3]], opts: &DelaunayOptions) -> Result<Delaunay, DelaunayError> {
    if let Some(r) = opts.max_circumradius {
        if r.is_nan() || r <= 0.0 {
            return Err(DelaunayError::BadCircumradius(r));
        }
    }
    // Tets are indexed by u32 and number ~6.7 per point (plus ghosts), so
    // the point count is capped well below 2^32 / 7.
    if points.len() > MAX_POINTS {
        return Err(DelaunayError::TooManyPoints { count: points.len() });
    }
    if let Some(index) = points.iter().position(|p| !p.iter().all(|c| c.is_finite())) {
        return Err(DelaunayError::NonFinite { index, coords: points[index] });
    }
    if let Some(index) = points.iter().position(|p| p.iter().any(|c| c.abs() > MAX_COORDINATE)) {
        return Err(DelaunayError::CoordinateTooLarge { index, coords: points[index], limit: MAX_COORDINATE });
    }
    // Copies of a point share its Hilbert key: one parallel sort by key
    // finds them.
    let keys = sort::hilbert_keys(points);
    let merged_into = sort::exact_duplicates(points, &keys);
    let unique: Vec<u32> = merged_into.iter().enumerate().filter(|&(i, &r)| r as usize == i).map(|(_, &r)| r).collect();
    let duplicates = points.len() - unique.len();
    let (order, round_ends) = sort::brio_order_keyed(&keys, unique, 0x7E7D_E1A0);
    let order = initial_tet(points, order)?;
    // Hilbert keys in insertion order partition the parallel rounds.
    let keys: Vec<u64> = order.iter().map(|&o| keys[o as usize]).collect();
    let mut tri = Triangulation::new(order.iter().map(|&i| points[i as usize]).collect(), order);
    debug_assert!(tri.num_points() == points.len() - duplicates);
    // Large BRIO rounds go to worker threads; small ones are not worth the
    // hand-off. rayon's pool size, so RAYON_NUM_THREADS governs every
    // parallel stage alike.
    let threads = rayon::current_num_threads().min(8);
    let mut parallel_deferred = 0;
    let mut start = 4u32;
    for &end in &round_ends {
        let end = end as u32;
        if end <= start {
            continue;
        }
        if threads > 1 && (end - start) as usize >= PARALLEL_ROUND_MIN {
            parallel_deferred += tri.insert_parallel(start, end, &keys, threads).sequential;
        } else {
            tri.insert_range(start, end);
        }
        start = end;
    }
    drop(keys);
    let (removed, removed_cells) = match opts.max_circumradius {
        Some(r) => {
            let (flags, n) = tri.peel(r);
            (Some(flags), n)
        }
        None => (None, 0),
    };
    let (tets, neighbors, hull_facets) = tri.finite_tets(removed.as_deref());
    Ok(Delaunay {
        tets,
        neighbors,
        merged_into,
        duplicates,
        hull_facets,
        removed_cells,
        walk_fallbacks: tri.walk_fallbacks,
        parallel_deferred,
    })
}

/// Moves 4 non-coplanar points found early in `order` to its front,
/// positively oriented, keeping the rest in order.
pub(crate) fn initial_tet(points: &[[f64; 3]], order: Vec<u32>) -> Result<Vec<u32>, DelaunayError> {
    let p = |i: u32| &points[i as usize];
    let degenerate = |dimension| Err(DelaunayError::Degenerate { distinct: order.len(), dimension });
    if order.len() < 2 {
        return degenerate(0);
    }
    let (a, b) = (order[0], order[1]);
    let collinear = |c: u32| {
        use robust::{orient2d, Coord};
        let (pa, pb, pc) = (p(a), p(b), p(c));
        [(0, 1), (1, 2), (2, 0)].iter().all(|&(x, y)| {
            orient2d(Coord { x: pa[x], y: pa[y] }, Coord { x: pb[x], y: pb[y] }, Coord { x: pc[x], y: pc[y] }) == 0.0
        })
    };
    let Some(ci) = (2..order.len()).find(|&k| !collinear(order[k])) else {
        return degenerate(1);
    };
    let c = order[ci];
    let Some(di) = (2..order.len()).find(|&k| k != ci && orient(p(a), p(b), p(c), p(order[k])) != 0.0) else {
        return degenerate(2);
    };
    let d = order[di];
    let first = if orient(p(a), p(b), p(c), p(d)) > 0.0 { [a, b, c, d] } else { [b, a, c, d] };
    let mut out = Vec::with_capacity(order.len());
    out.extend_from_slice(&first);
    out.extend(order.iter().enumerate().filter(|&(k, _)| k > 1 && k != ci && k != di).map(|(_, &v)| v));
    Ok(out)
}
