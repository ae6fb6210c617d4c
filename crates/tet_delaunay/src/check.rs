//! Invariant checker for a [`Delaunay`] result, for tests and fuzzing.
//!
//! Everything is decided with exact predicates, so a violation is a bug in
//! the tetrahedralization, never rounding.

use crate::predicates::{in_sphere_exact, orient};
use crate::Delaunay;
use std::collections::{HashMap, HashSet};
use thiserror::Error;

/// The first invariant a tetrahedralization breaks.
#[derive(Debug, Error, Clone, PartialEq)]
pub enum DelaunayViolation {
    #[error("tet {tet} indexes point {vertex}, but there are only {points} points")]
    VertexOutOfRange { tet: usize, vertex: u32, points: usize },
    #[error("tet {tet} {vertices:?} is not positively oriented (flat or inverted)")]
    NotPositive { tet: usize, vertices: [u32; 4] },
    #[error("face {face:?} belongs to {count} tets")]
    FaceOverused { face: [u32; 3], count: usize },
    #[error("face {face:?} is seen with the same orientation by both its tets")]
    FaceOrientation { face: [u32; 3] },
    #[error("Euler characteristic {euler} (V−E+F−T), but a ball has 1")]
    NotABall { euler: i64 },
    #[error("{found} boundary faces, but the result reports {reported} hull facets")]
    HullFacets { found: usize, reported: usize },
    #[error("point {point} (merged into {representative}) is in no tet")]
    PointUnused { point: usize, representative: u32 },
    #[error("point {point} is merged into {representative}, which has other coordinates")]
    BadMerge { point: usize, representative: u32 },
    #[error("point {point} lies beyond boundary face {face:?}: the tets do not fill the convex hull")]
    NotConvex { face: [u32; 3], point: usize },
    #[error("neighbours of tet {tet} across face {face}: {found}, but the faces say {expected} (u32::MAX: none)")]
    Neighbors { tet: usize, face: usize, found: u32, expected: u32 },
    #[error("{found} neighbour entries for {tets} tets")]
    NeighborCount { found: usize, tets: usize },
    #[error("point {point} lies strictly inside the circumsphere of tet {tet} {vertices:?}")]
    NotEmpty { tet: usize, vertices: [u32; 4], point: usize },
}

/// Checks `d` as the tetrahedralization of `points`: indices in range,
/// every tet positive, every face in one or two tets with opposite
/// orientations, and — when the tets fill the convex hull — a ball whose
/// boundary faces number `d.hull_facets` and which uses every distinct
/// point; duplicates map to identical points; `d.neighbors` names, across
/// each face, the other tet of that face (or none). With `brute_force`, also that
/// the boundary is convex (no point beyond any boundary face) and that no
/// point lies strictly inside any tet's circumsphere (cospherical points
/// are allowed), in O((tets + faces) × points): for small sets.
pub fn check_delaunay(points: &[[f64; 3]], d: &Delaunay, brute_force: bool) -> Result<(), DelaunayViolation> {
    let n = points.len();
    let p = |i: u32| &points[i as usize];
    for (t, v) in d.tets.iter().enumerate() {
        if let Some(&x) = v.iter().find(|&&x| x as usize >= n) {
            return Err(DelaunayViolation::VertexOutOfRange { tet: t, vertex: x, points: n });
        }
        if orient(p(v[0]), p(v[1]), p(v[2]), p(v[3])) <= 0.0 {
            return Err(DelaunayViolation::NotPositive { tet: t, vertices: *v });
        }
    }
    // Outward faces of each positive tet, keyed by their sorted vertices.
    let mut faces: HashMap<[u32; 3], Vec<[u32; 3]>> = HashMap::new();
    // The tets of each face, for the neighbour check.
    let mut face_tets: HashMap<[u32; 3], Vec<u32>> = HashMap::new();
    let mut edges = HashSet::new();
    let mut verts = HashSet::new();
    for (ti, t) in d.tets.iter().enumerate() {
        for f in [[t[1], t[2], t[3]], [t[0], t[3], t[2]], [t[0], t[1], t[3]], [t[0], t[2], t[1]]] {
            let mut k = f;
            k.sort_unstable();
            faces.entry(k).or_default().push(f);
            face_tets.entry(k).or_default().push(ti as u32);
        }
        for i in 0..4 {
            verts.insert(t[i]);
            for j in i + 1..4 {
                edges.insert((t[i].min(t[j]), t[i].max(t[j])));
            }
        }
    }
    let rot = |f: [u32; 3]| {
        let m = (0..3).min_by_key(|&i| f[i]).unwrap_or(0);
        [f[m], f[(m + 1) % 3], f[(m + 2) % 3]]
    };
    let mut boundary = Vec::new();
    for (k, fs) in &faces {
        match fs.len() {
            1 => boundary.push(fs[0]),
            2 => {
                let (a, b) = (rot(fs[0]), rot(fs[1]));
                if (a[1], a[2]) != (b[2], b[1]) {
                    return Err(DelaunayViolation::FaceOrientation { face: *k });
                }
            }
            count => return Err(DelaunayViolation::FaceOverused { face: *k, count }),
        }
    }
    if d.neighbors.len() != d.tets.len() {
        return Err(DelaunayViolation::NeighborCount { found: d.neighbors.len(), tets: d.tets.len() });
    }
    for (ti, t) in d.tets.iter().enumerate() {
        for f in 0..4 {
            let mut k: Vec<u32> = (0..4).filter(|&i| i != f).map(|i| t[i]).collect();
            k.sort_unstable();
            let expected =
                face_tets[&[k[0], k[1], k[2]]].iter().copied().find(|&o| o as usize != ti).unwrap_or(u32::MAX);
            if d.neighbors[ti][f] != expected {
                return Err(DelaunayViolation::Neighbors { tet: ti, face: f, found: d.neighbors[ti][f], expected });
            }
        }
    }
    for (i, &r) in d.merged_into.iter().enumerate() {
        // `!=` on f64: ±0 compare equal, as in the merge.
        if r as usize >= n || points[i] != points[r as usize] {
            return Err(DelaunayViolation::BadMerge { point: i, representative: r });
        }
    }
    if d.fills_convex_hull() && !d.tets.is_empty() {
        let euler = verts.len() as i64 - edges.len() as i64 + faces.len() as i64 - d.tets.len() as i64;
        if euler != 1 {
            return Err(DelaunayViolation::NotABall { euler });
        }
        if boundary.len() != d.hull_facets {
            return Err(DelaunayViolation::HullFacets { found: boundary.len(), reported: d.hull_facets });
        }
        for (i, &r) in d.merged_into.iter().enumerate() {
            if !verts.contains(&r) {
                return Err(DelaunayViolation::PointUnused { point: i, representative: r });
            }
        }
    }
    if brute_force && d.fills_convex_hull() {
        // Boundary faces are outward: a point beyond one is outside the
        // tets but inside the hull.
        for f in &boundary {
            if let Some(q) = points.iter().position(|q| orient(p(f[0]), p(f[1]), p(f[2]), q) > 0.0) {
                return Err(DelaunayViolation::NotConvex { face: *f, point: q });
            }
        }
    }
    if brute_force {
        for (t, v) in d.tets.iter().enumerate() {
            for (q, pq) in points.iter().enumerate() {
                if v.contains(&(q as u32)) || d.merged_into.get(q).is_some_and(|&r| v.contains(&r)) {
                    continue;
                }
                if in_sphere_exact(p(v[0]), p(v[1]), p(v[2]), p(v[3]), pq) > 0.0 {
                    return Err(DelaunayViolation::NotEmpty { tet: t, vertices: *v, point: q });
                }
            }
        }
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::{tetrahedralize_points, DelaunayOptions};

    #[test]
    fn accepts_a_delaunay_result_and_names_broken_invariants() {
        let mut pts = tet_mesh::split::structured_points([3; 3], |p| p.map(|x| x as f64));
        pts.push([2.0, 2.0, 2.0]);
        let d = tetrahedralize_points(&pts, &DelaunayOptions::default()).unwrap();
        assert_eq!(check_delaunay(&pts, &d, true), Ok(()));

        let mut flipped = d.clone();
        flipped.tets[3].swap(0, 1);
        assert!(matches!(check_delaunay(&pts, &flipped, false), Err(DelaunayViolation::NotPositive { tet: 3, .. })));

        // Dropping any one tet leaves a hole or a dent.
        for t in 0..d.tets.len() {
            let mut missing = d.clone();
            missing.tets.remove(t);
            assert!(check_delaunay(&pts, &missing, true).is_err(), "without tet {t}");
        }

        // A convex bipyramid split through its equator: structurally a
        // fine ball, but the flat bottom apex lies inside the top tet's
        // circumsphere (Delaunay would split it around the axis d–e).
        let pts = [[0.0, 0.0, 0.0], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.3, 0.3, 1.0], [0.3, 0.3, -0.05]];
        let bipyramid = Delaunay {
            tets: vec![[0, 1, 2, 3], [1, 0, 2, 4]],
            neighbors: vec![[u32::MAX, u32::MAX, u32::MAX, 1], [u32::MAX, u32::MAX, u32::MAX, 0]],
            merged_into: (0..5).collect(),
            duplicates: 0,
            hull_facets: 6,
            removed_cells: 0,
            walk_fallbacks: 0,
            parallel_deferred: 0,
        };
        assert_eq!(check_delaunay(&pts, &bipyramid, false), Ok(()));
        assert!(matches!(
            check_delaunay(&pts, &bipyramid, true),
            Err(DelaunayViolation::NotEmpty { tet: 0, point: 4, .. })
        ));
    }
}
