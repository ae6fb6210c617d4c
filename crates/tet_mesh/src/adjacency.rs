//! Face adjacency of a tetrahedral mesh: what MPVO visibility sorting walks.
//!
//! Face `f` of a tet is the face opposite its vertex `f`. [`FACE_OUTWARD`]
//! lists each face's vertices in the order whose right-hand normal points out
//! of a positively oriented tet.

use crate::error::MeshError;
use crate::merge::FastMap;
use crate::predicates::{tet_orientation, TetOrientation};
use rayon::prelude::*;

/// Marks a face with no neighbour (on the boundary).
pub const NO_NEIGHBOR: u32 = u32::MAX;

/// Local vertex indices of face `f` (opposite vertex `f`), ordered so that
/// the right-hand normal points outward for a positive tet.
pub const FACE_OUTWARD: [[usize; 3]; 4] = [[1, 2, 3], [0, 3, 2], [0, 1, 3], [0, 2, 1]];

/// Neighbours across each face plus the boundary.
#[derive(Debug, Clone, PartialEq)]
pub struct Adjacency {
    /// `neighbors[t][f]` is the tet across face `f` of tet `t`, or [`NO_NEIGHBOR`].
    /// (Owned, or shared with a mapped bundle file.)
    pub neighbors: crate::SharedArray<[u32; 4]>,
    /// Boundary faces as `tet * 4 + face`, sorted.
    pub boundary_faces: Vec<u32>,
    /// Whether the boundary is one closed, locally convex surface, which
    /// makes the mesh's domain convex (and plain MPVO exact).
    pub convex: bool,
}

/// Builds face adjacency. A face shared by more than two tets is an error
/// naming them. Tets must be positively oriented for `convex` to be right.
pub fn build_adjacency(points: &[[f64; 3]], tets: &[[u32; 4]]) -> Result<Adjacency, MeshError> {
    let n_tets = tets.len();
    if n_tets > (u32::MAX / 4) as usize {
        return Err(MeshError::TooLarge { what: "tets", count: n_tets, limit: (u32::MAX / 4) as usize });
    }
    // Bucket every face by its smallest vertex (CSR), then match faces within
    // each bucket: buckets hold ~24 faces, so the matching is cache-local and
    // the whole build is linear.
    let n_points = points.len();
    let mut start = vec![0u32; n_points + 1];
    for t in tets {
        for f in 0..4 {
            let k = face_key(t, f);
            start[k.0 as usize + 1] += 1;
        }
    }
    for i in 0..n_points {
        start[i + 1] += start[i];
    }
    let mut fill = start.clone();
    let mut entries = vec![(0u32, 0u32, 0u32); n_tets * 4];
    for (ti, t) in tets.iter().enumerate() {
        for f in 0..4 {
            let (a, b, c) = face_key(t, f);
            let slot = &mut fill[a as usize];
            entries[*slot as usize] = (b, c, (ti * 4 + f) as u32);
            *slot += 1;
        }
    }
    drop(fill);

    // Split `entries` into per-chunk slices along bucket boundaries.
    let chunk_vertices = (n_points / (rayon::current_num_threads() * 8)).max(1024);
    let mut slices: Vec<(&mut [FaceEntry], usize)> = Vec::new();
    {
        let mut rest: &mut [FaceEntry] = &mut entries;
        let mut v = 0usize;
        while v < n_points {
            let v_end = (v + chunk_vertices).min(n_points);
            let len = (start[v_end] - start[v]) as usize;
            let (head, tail) = rest.split_at_mut(len);
            slices.push((head, v));
            rest = tail;
            v = v_end;
        }
    }
    let results: Vec<Result<Vec<(u32, u32)>, MeshError>> = slices
        .into_par_iter()
        .map(|(slice, v0)| {
            let mut pairs = Vec::with_capacity(slice.len() / 2);
            let mut offset = 0usize;
            let mut v = v0;
            while offset < slice.len() {
                let len = (start[v + 1] - start[v]) as usize;
                let bucket = &mut slice[offset..offset + len];
                bucket.sort_unstable();
                let mut i = 0;
                while i < bucket.len() {
                    let mut j = i + 1;
                    while j < bucket.len() && bucket[j].0 == bucket[i].0 && bucket[j].1 == bucket[i].1 {
                        j += 1;
                    }
                    match j - i {
                        1 => pairs.push((bucket[i].2, NO_NEIGHBOR)),
                        2 => pairs.push((bucket[i].2, bucket[i + 1].2)),
                        _ => {
                            return Err(MeshError::NonManifoldFace {
                                face: [v as u32, bucket[i].0, bucket[i].1],
                                tets: bucket[i..j].iter().map(|e| e.2 / 4).collect(),
                            })
                        }
                    }
                    i = j;
                }
                offset += len;
                v += 1;
            }
            Ok(pairs)
        })
        .collect();

    let mut neighbors = vec![[NO_NEIGHBOR; 4]; n_tets];
    let mut boundary_faces = Vec::new();
    for r in results {
        for (fa, fb) in r? {
            let (ta, la) = ((fa / 4) as usize, (fa % 4) as usize);
            if fb == NO_NEIGHBOR {
                boundary_faces.push(fa);
            } else {
                let (tb, lb) = ((fb / 4) as usize, (fb % 4) as usize);
                neighbors[ta][la] = tb as u32;
                neighbors[tb][lb] = ta as u32;
            }
        }
    }
    boundary_faces.sort_unstable();
    let convex = boundary_is_convex(points, tets, &boundary_faces);
    Ok(Adjacency { neighbors: neighbors.into(), boundary_faces, convex })
}

/// The adjacency a tetrahedralizer already knows (`neighbors[t][f]`: the
/// tet across the face opposite vertex `f`, or [`NO_NEIGHBOR`]), checked in
/// one parallel pass instead of rebuilt: every link in range, symmetric,
/// and joining two tets through the same three vertices. `None` when any
/// check fails (the caller then builds it with [`build_adjacency`]). Faces
/// marked as boundary are trusted to be unshared: the source must know it
/// (tet_delaunay's checker tests exactly that).
pub fn adjacency_from_neighbors(
    points: &[[f64; 3]],
    tets: &[[u32; 4]],
    neighbors: impl Into<crate::SharedArray<[u32; 4]>>,
) -> Option<Adjacency> {
    let neighbors = neighbors.into();
    let (boundary_faces, convex) = check_neighbors(points, tets, &neighbors)?;
    Some(Adjacency { neighbors, boundary_faces, convex })
}

/// [`adjacency_from_neighbors`]'s check of a borrowed relation (so that it
/// can be written out while it is checked): the boundary faces and whether
/// the boundary is convex, or `None` when a check fails.
pub fn check_neighbors(points: &[[f64; 3]], tets: &[[u32; 4]], neighbors: &[[u32; 4]]) -> Option<(Vec<u32>, bool)> {
    if neighbors.len() != tets.len() || tets.len() > (u32::MAX / 4) as usize {
        return None;
    }
    // Each pair of neighbours names the other, and shares the face: the
    // three vertices of t's face stand in u's other three slots (t's four
    // vertices distinct, so they fill those slots exactly). No sort, and
    // each pair is read from one side: a link t → u with t < u is checked
    // (u names t back through the same face), one with t > u is only
    // counted. The checked links name distinct back links (two faces of t
    // have different vertices; a slot of u names one tet), all among the
    // counted ones, so equal counts leave no counted link unchecked.
    let (consistent, up, down) = (0..tets.len())
        .into_par_iter()
        .map(|t| {
            let tv = &tets[t];
            let mut ok = (0..4).all(|i| (i + 1..4).all(|j| tv[i] != tv[j]));
            let (mut up, mut down) = (0u64, 0u64);
            for f in 0..4 {
                let u = neighbors[t][f];
                if u == NO_NEIGHBOR {
                    continue;
                }
                if (u as usize) < t {
                    down += 1;
                    continue;
                }
                up += 1;
                // Without branches on what u's records hold, so that their
                // reads (cache misses: neighbours lie anywhere in memory)
                // overlap. A u out of range reads tet 0 and fails.
                let in_range = (u as usize) < tets.len();
                let ui = if in_range { u as usize } else { 0 };
                let (back, uv) = (neighbors[ui], tets[ui]);
                let me = t as u32;
                let names_me = (0..4).fold(0u32, |m, g| m | ((back[g] == me) as u32) << g);
                let g = (names_me.trailing_zeros() & 3) as usize;
                let face = [tv[(f + 1) % 4], tv[(f + 2) % 4], tv[(f + 3) % 4]];
                let in_u = |x: u32| (uv[0] == x) | (uv[1] == x) | (uv[2] == x) | (uv[3] == x);
                // The face's vertices in u, and u's vertex across the face
                // (slot g) none of them: they fill u's other three slots
                // (a u with a repeated vertex fails its own distinctness).
                ok &= in_range
                    & (names_me != 0)
                    & (u as usize != t)
                    & in_u(face[0])
                    & in_u(face[1])
                    & in_u(face[2])
                    & (uv[g] != face[0])
                    & (uv[g] != face[1])
                    & (uv[g] != face[2]);
            }
            (ok, up, down)
        })
        .reduce(|| (true, 0, 0), |a, b| (a.0 && b.0, a.1 + b.1, a.2 + b.2));
    let consistent = consistent && up == down;
    if !consistent {
        return None;
    }
    let boundary_faces: Vec<u32> = neighbors
        .iter()
        .enumerate()
        .flat_map(|(t, n)| (0..4).filter(move |&f| n[f] == NO_NEIGHBOR).map(move |f| (t * 4 + f) as u32))
        .collect();
    let convex = boundary_is_convex(points, tets, &boundary_faces);
    Some((boundary_faces, convex))
}

/// A face in its smallest vertex's bucket: the other two vertices (sorted)
/// and `tet * 4 + face`.
type FaceEntry = (u32, u32, u32);

#[inline]
fn face_key(t: &[u32; 4], f: usize) -> (u32, u32, u32) {
    let [i, j, k] = FACE_OUTWARD[f];
    let mut v = [t[i], t[j], t[k]];
    v.sort_unstable();
    (v[0], v[1], v[2])
}

/// Outward-ordered vertex ids of boundary face `tet * 4 + face`.
pub fn boundary_face_vertices(tets: &[[u32; 4]], packed: u32) -> [u32; 3] {
    let t = &tets[(packed / 4) as usize];
    let [i, j, k] = FACE_OUTWARD[(packed % 4) as usize];
    [t[i], t[j], t[k]]
}

/// A closed, connected surface that is locally convex at every edge bounds a
/// convex body. Each boundary edge must join exactly two boundary faces, and
/// the far vertex of one face must not lie strictly outside the other's
/// plane (exact predicate; coplanar is allowed, e.g. a box's flat sides).
fn boundary_is_convex(points: &[[f64; 3]], tets: &[[u32; 4]], boundary: &[u32]) -> bool {
    if boundary.is_empty() {
        return false;
    }
    let faces: Vec<[u32; 3]> = boundary.iter().map(|&b| boundary_face_vertices(tets, b)).collect();
    // Directed edge (a→b) of face i; its twin (b→a) belongs to the neighbour face.
    let mut edge_face: FastMap<(u32, u32), usize> = FastMap::default();
    edge_face.reserve(faces.len() * 3);
    for (i, f) in faces.iter().enumerate() {
        for e in 0..3 {
            if edge_face.insert((f[e], f[(e + 1) % 3]), i).is_some() {
                return false; // non-manifold boundary
            }
        }
    }
    let mut parent: Vec<usize> = (0..faces.len()).collect();
    fn find(p: &mut [usize], mut x: usize) -> usize {
        while p[x] != x {
            p[x] = p[p[x]];
            x = p[x];
        }
        x
    }
    for (i, f) in faces.iter().enumerate() {
        for e in 0..3 {
            let (a, b) = (f[e], f[(e + 1) % 3]);
            let Some(&j) = edge_face.get(&(b, a)) else { return false };
            let g = faces[j];
            let far = g.iter().copied().find(|&v| v != a && v != b).expect("triangle has a third vertex");
            let p = |v: u32| &points[v as usize];
            if tet_orientation(p(f[0]), p(f[1]), p(f[2]), p(far)) == TetOrientation::Positive {
                return false; // `far` is outside face i's plane: a reflex edge
            }
            let (ri, rj) = (find(&mut parent, i), find(&mut parent, j));
            parent[ri] = rj;
        }
    }
    let root = find(&mut parent, 0);
    (0..faces.len()).all(|i| find(&mut parent, i) == root)
}

#[cfg(test)]
mod from_neighbors_tests {
    use super::*;

    /// The five tets of a cube: the hand-off agrees with the build, and a
    /// link that is not symmetric, or joins tets that share no face, or a
    /// tet whose vertices were swapped after the links were made, is refused.
    #[test]
    fn agrees_with_the_build_and_refuses_bad_links() {
        let points = crate::split::UNIT_HEX;
        let mut tets = vec![[0, 1, 3, 4], [1, 2, 3, 6], [1, 6, 4, 5], [3, 4, 6, 7], [1, 3, 4, 6]];
        for t in &mut tets {
            let p = |i: u32| &points[i as usize];
            if tet_orientation(p(t[0]), p(t[1]), p(t[2]), p(t[3])) != TetOrientation::Positive {
                t.swap(2, 3);
            }
        }
        let built = build_adjacency(&points, &tets).unwrap();
        let handed = adjacency_from_neighbors(&points, &tets, built.neighbors.clone()).unwrap();
        assert_eq!(handed, built);
        let mut one_way = built.neighbors.clone();
        let (t, f) =
            (0..5).flat_map(|t| (0..4).map(move |f| (t, f))).find(|&(t, f)| one_way[t][f] != NO_NEIGHBOR).unwrap();
        one_way[t][f] = NO_NEIGHBOR;
        assert!(adjacency_from_neighbors(&points, &tets, one_way).is_none());
        let mut wrong_face = built.neighbors.clone();
        wrong_face[4].rotate_left(1);
        assert!(adjacency_from_neighbors(&points, &tets, wrong_face).is_none());
        let mut swapped = tets.clone();
        swapped[4].swap(2, 3);
        assert!(adjacency_from_neighbors(&points, &swapped, built.neighbors.clone()).is_none());
        // A tet naming one vertex twice shares no face with anything.
        let mut repeated = tets.clone();
        repeated[0][2] = repeated[0][1];
        assert!(adjacency_from_neighbors(&points, &repeated, built.neighbors.clone()).is_none());
        let mut out_of_range = built.neighbors;
        out_of_range[0][0] = 99;
        assert!(adjacency_from_neighbors(&points, &tets, out_of_range).is_none());
    }

    /// Links checked from one side (the smaller tet) and counted from the
    /// other: no corruption slips through. Random rewiring of a 5-split
    /// grid — a link to another tet, two slots swapped, a symmetric pair
    /// joined through faces they do not share, a link dropped — is refused
    /// unless every link left is a true one (a face dropped on both sides
    /// reads as boundary, which the source is trusted on).
    #[test]
    fn one_sided_check_refuses_every_corruption() {
        let n = [5usize; 3];
        let points = crate::split::structured_points(n, |p| p.map(|x| x as f64));
        let tets = crate::split::structured_grid_tets(n.map(|k| k - 1), crate::SplitMode::Five);
        let built = build_adjacency(&points, &tets).unwrap();
        let m = tets.len() as u64;
        let mut rng = crate::SplitMix64(5);
        let mut pick = |k: u64| (rng.next_u64() % k) as usize;
        for round in 0..3000 {
            let mut nb = built.neighbors.clone();
            let (t1, f1, t2, f2) = (pick(m), pick(4), pick(m), pick(4));
            match round % 4 {
                0 => nb[t1][f1] = t2 as u32,
                1 => {
                    let a = nb[t1][f1];
                    nb[t1][f1] = nb[t2][f2];
                    nb[t2][f2] = a;
                }
                2 => {
                    nb[t1][f1] = t2 as u32;
                    nb[t2][f2] = t1 as u32;
                }
                _ => nb[t1][f1] = NO_NEIGHBOR,
            }
            let truthful =
                nb.iter().zip(&built.neighbors).all(|(a, b)| (0..4).all(|f| a[f] == NO_NEIGHBOR || a[f] == b[f]));
            let both_sides = (0..tets.len())
                .all(|t| (0..4).all(|f| nb[t][f] == NO_NEIGHBOR || nb[nb[t][f] as usize].contains(&(t as u32))));
            let got = adjacency_from_neighbors(&points, &tets, nb.clone());
            assert_eq!(got.is_some(), truthful && both_sides, "round {round}: {t1}.{f1} / {t2}.{f2}");
        }
    }
}

/// Invariant checker for tests and fuzzing: neighbours are symmetric, share
/// exactly the face's three vertices, and boundary faces are exactly the
/// faces without a neighbour.
pub fn check_adjacency(tets: &[[u32; 4]], adj: &Adjacency) -> Result<(), String> {
    let mut boundary = Vec::new();
    for (t, nb) in adj.neighbors.iter().enumerate() {
        for (f, &n) in nb.iter().enumerate() {
            if n == NO_NEIGHBOR {
                boundary.push((t * 4 + f) as u32);
                continue;
            }
            let back = adj.neighbors[n as usize].iter().filter(|&&x| x == t as u32).count();
            if back == 0 {
                return Err(format!("tet {t} face {f} → tet {n}, but not back"));
            }
            let k = face_key(&tets[t], f);
            let shared = (0..4).any(|g| face_key(&tets[n as usize], g) == k);
            if !shared {
                return Err(format!("tet {t} face {f} and tet {n} do not share that face"));
            }
        }
    }
    if boundary != adj.boundary_faces {
        return Err("boundary face list does not match the faces without neighbours".into());
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::split::{split_hexahedron, UNIT_HEX};

    fn cube_mesh(offset: f64) -> (Vec<[f64; 3]>, Vec<[u32; 4]>) {
        let p: Vec<[f64; 3]> = UNIT_HEX.iter().map(|q| [q[0] + offset, q[1] + offset, q[2] + offset]).collect();
        let mut tets = vec![];
        split_hexahedron(&[0, 1, 2, 3, 4, 5, 6, 7], &mut |t| tets.push(t));
        // Orient positively.
        for t in &mut tets {
            if tet_orientation(&p[t[0] as usize], &p[t[1] as usize], &p[t[2] as usize], &p[t[3] as usize])
                == TetOrientation::Negative
            {
                t.swap(0, 1);
            }
        }
        (p, tets)
    }

    #[test]
    fn cube_is_convex_with_twelve_boundary_faces() {
        let (p, tets) = cube_mesh(1e6);
        let adj = build_adjacency(&p, &tets).unwrap();
        assert_eq!(adj.boundary_faces.len(), 12);
        assert!(adj.convex);
        check_adjacency(&tets, &adj).unwrap();
    }

    #[test]
    fn l_shape_is_not_convex() {
        // Two cubes sharing an edge only through a third: an L of three cubes.
        let mut pts = vec![];
        let mut tets = vec![];
        let cubes = [[0., 0., 0.], [1., 0., 0.], [0., 1., 0.]];
        let mut id = std::collections::HashMap::new();
        for c in cubes {
            let mut h = [0u32; 8];
            for (k, q) in UNIT_HEX.iter().enumerate() {
                let pos = [c[0] + q[0], c[1] + q[1], c[2] + q[2]];
                let key = pos.map(|x| (x * 2.0) as i64);
                h[k] = *id.entry(key).or_insert_with(|| {
                    pts.push(pos);
                    (pts.len() - 1) as u32
                });
            }
            split_hexahedron(&h, &mut |t| tets.push(t));
        }
        for t in &mut tets {
            if tet_orientation(&pts[t[0] as usize], &pts[t[1] as usize], &pts[t[2] as usize], &pts[t[3] as usize])
                == TetOrientation::Negative
            {
                t.swap(0, 1);
            }
        }
        let adj = build_adjacency(&pts, &tets).unwrap();
        check_adjacency(&tets, &adj).unwrap();
        assert!(!adj.convex);
        // 3 cubes × 12 boundary triangles, less both sides of the 2 shared squares.
        assert_eq!(adj.boundary_faces.len(), 3 * 12 - 2 * 2 * 2);
    }

    #[test]
    fn face_shared_by_three_tets_is_an_error_naming_them() {
        let p = vec![[0., 0., 0.], [1., 0., 0.], [0., 1., 0.], [0., 0., 1.], [0., 0., -1.], [0.2, 0.2, 2.0]];
        let tets = vec![[0, 1, 2, 3], [0, 2, 1, 4], [0, 1, 2, 5]];
        match build_adjacency(&p, &tets) {
            Err(MeshError::NonManifoldFace { tets, .. }) => assert_eq!(tets, vec![0, 1, 2]),
            other => panic!("expected a non-manifold error, got {other:?}"),
        }
    }
}
