//! Cells from OpenFOAM's face-based description.
//!
//! A cell is the set of faces that name it as owner (the face's right-hand
//! normal points out of the owner) or as neighbour (the normal points in;
//! the face is reversed to point out). Cells whose faces are exactly those of
//! a tetrahedron (4 triangles), pyramid (1 quad + 4 triangles), prism (2
//! triangles + 3 quads) or hexahedron (6 quads) with the matching edge
//! structure become that linear cell, its nodes in VTK order and orientation
//! (the base is an outward face reversed, so its normal points into the cell
//! as VTK's does; the opposite nodes follow the edges leaving the base).
//! Every other cell is a polyhedron, split into tets by
//! [`tet_mesh::PolyhedronSplitter`] around its centre.

use tet_mesh::{CellType, Cells, PolyhedronSplitter};

/// No neighbour (a boundary face).
pub(crate) const NONE: u32 = u32::MAX;

/// A polyMesh in memory.
#[derive(Debug, Clone, Default)]
pub(crate) struct PolyMesh {
    pub points: Vec<[f64; 3]>,
    /// Faces in CSR form: face `f` is `face_ids[face_start[f]..face_start[f + 1]]`.
    pub face_start: Vec<usize>,
    pub face_ids: Vec<u32>,
    /// Owner cell of every face.
    pub owner: Vec<u32>,
    /// Neighbour cell of every face, [`NONE`] on the boundary.
    pub neighbour: Vec<u32>,
}

impl PolyMesh {
    pub fn num_faces(&self) -> usize {
        self.face_start.len().saturating_sub(1)
    }

    pub fn face(&self, f: usize) -> &[u32] {
        &self.face_ids[self.face_start[f]..self.face_start[f + 1]]
    }
}

/// Why the faces do not make cells; the reader turns it into a located
/// error in the owner (or neighbour) file.
#[derive(Debug, Clone, PartialEq)]
pub(crate) struct CellError {
    pub message: String,
    /// A face of the offending cell and whether the cell is that face's
    /// neighbour (else its owner), to point at the file entry naming it.
    pub face: Option<(usize, bool)>,
}

/// The cells as tet_mesh takes them, and which OpenFOAM cell each came from.
pub(crate) struct Built {
    pub cells: Cells,
    /// Per output cell, the OpenFOAM cell (a polyhedron gives several tets).
    pub source_cell: Vec<u32>,
    pub splitter: PolyhedronSplitter,
    /// Counts of tets, pyramids, prisms, hexahedra and polyhedra.
    pub counts: [usize; 5],
}

/// Classifies one cell given its outward faces; `None` for a polyhedron.
fn classify(faces: &[&[u32]]) -> Option<(CellType, [u32; 8])> {
    let tris = faces.iter().filter(|f| f.len() == 3).count();
    let quads = faces.iter().filter(|f| f.len() == 4).count();
    let mut verts: Vec<u32> = faces.iter().flat_map(|f| f.iter().copied()).collect();
    verts.sort_unstable();
    verts.dedup();
    let rev = |f: &[u32]| -> Vec<u32> { std::iter::once(f[0]).chain(f[1..].iter().rev().copied()).collect() };
    let others = |base: &[u32]| -> Vec<u32> { verts.iter().copied().filter(|v| !base.contains(v)).collect() };
    let mut n = [0u32; 8];
    match (faces.len(), tris, quads, verts.len()) {
        (4, 4, 0, 4) => {
            let b = rev(faces[0]);
            let apex = others(&b);
            n[..3].copy_from_slice(&b);
            n[3] = apex[0];
            Some((CellType::Tetra, n))
        }
        (5, 4, 1, 5) => {
            let q = faces.iter().find(|f| f.len() == 4)?;
            let b = rev(q);
            let apex = others(&b);
            n[..4].copy_from_slice(&b);
            n[4] = apex[0];
            Some((CellType::Pyramid, n))
        }
        (5, 2, 3, 6) => {
            let t = faces.iter().find(|f| f.len() == 3)?;
            let b = rev(t);
            let top = extrude(&b, faces)?;
            n[..3].copy_from_slice(&b);
            n[3..6].copy_from_slice(&top);
            Some((CellType::Wedge, n)).filter(|_| sides_match(&n[..6], 3, faces))
        }
        (6, 0, 6, 8) => {
            let b = rev(faces[0]);
            let top = extrude(&b, faces)?;
            n[..4].copy_from_slice(&b);
            n[4..].copy_from_slice(&top);
            Some((CellType::Hexahedron, n)).filter(|_| sides_match(&n, 4, faces))
        }
        _ => None,
    }
}

/// For each base node, the one node an edge of the cell joins it to outside
/// the base; `None` unless every base node has exactly one.
fn extrude(base: &[u32], faces: &[&[u32]]) -> Option<Vec<u32>> {
    let mut top = Vec::with_capacity(base.len());
    for &v in base {
        let mut partner: Option<u32> = None;
        for f in faces {
            for (i, &a) in f.iter().enumerate() {
                let b = f[(i + 1) % f.len()];
                let other = if a == v {
                    b
                } else if b == v {
                    a
                } else {
                    continue;
                };
                if base.contains(&other) {
                    continue;
                }
                match partner {
                    None => partner = Some(other),
                    Some(p) if p == other => {}
                    Some(_) => return None,
                }
            }
        }
        top.push(partner?);
    }
    Some(top)
}

/// Whether the cell's faces are exactly the base, the top and the `k` side
/// quads of the extrusion `nodes` = base ++ top (each compared as a set).
fn sides_match(nodes: &[u32], k: usize, faces: &[&[u32]]) -> bool {
    let key = |ids: &[u32]| {
        let mut v = ids.to_vec();
        v.sort_unstable();
        v
    };
    let mut want: Vec<Vec<u32>> = vec![key(&nodes[..k]), key(&nodes[k..2 * k])];
    for i in 0..k {
        let j = (i + 1) % k;
        want.push(key(&[nodes[i], nodes[j], nodes[k + j], nodes[k + i]]));
    }
    let mut have: Vec<Vec<u32>> = faces.iter().map(|f| key(f)).collect();
    want.sort();
    have.sort();
    want == have
}

/// Whether every edge of the cell is used by exactly two of its faces
/// (OpenFOAM's topological closedness); the first bad edge otherwise.
fn open_edge(faces: &[&[u32]]) -> Option<(u32, u32, usize)> {
    let mut edges: Vec<(u32, u32)> = Vec::new();
    for f in faces {
        for (i, &a) in f.iter().enumerate() {
            let b = f[(i + 1) % f.len()];
            edges.push((a.min(b), a.max(b)));
        }
    }
    edges.sort_unstable();
    let mut i = 0;
    while i < edges.len() {
        let mut j = i;
        while j < edges.len() && edges[j] == edges[i] {
            j += 1;
        }
        if j - i != 2 {
            return Some((edges[i].0, edges[i].1, j - i));
        }
        i = j;
    }
    None
}

/// Builds the cells. `num_cells` must exceed every owner and neighbour
/// entry (the caller derives and bounds it).
pub(crate) fn build(m: &PolyMesh, num_cells: usize) -> Result<Built, CellError> {
    let nf = m.num_faces();
    // Cell → faces (CSR), each entry face·2 + (1 when the cell is the neighbour).
    let mut start = vec![0usize; num_cells + 1];
    for f in 0..nf {
        start[m.owner[f] as usize + 1] += 1;
        if m.neighbour[f] != NONE {
            start[m.neighbour[f] as usize + 1] += 1;
        }
    }
    for c in 0..num_cells {
        start[c + 1] += start[c];
    }
    let mut fill = start.clone();
    let mut entries = vec![0usize; start[num_cells]];
    for f in 0..nf {
        let o = m.owner[f] as usize;
        entries[fill[o]] = 2 * f;
        fill[o] += 1;
        if m.neighbour[f] != NONE {
            let n = m.neighbour[f] as usize;
            entries[fill[n]] = 2 * f + 1;
            fill[n] += 1;
        }
    }
    drop(fill);

    let mut out = Built {
        cells: Cells::new(),
        source_cell: Vec::with_capacity(num_cells),
        splitter: PolyhedronSplitter::new(m.points.len()),
        counts: [0; 5],
    };
    let mut buf: Vec<u32> = Vec::new();
    let mut bounds: Vec<(usize, usize)> = Vec::new();
    for c in 0..num_cells {
        let mine = &entries[start[c]..start[c + 1]];
        let first = mine.first().map(|&e| (e / 2, e % 2 == 1));
        if mine.len() < 4 {
            let message = if mine.is_empty() {
                format!("cell {c} is bounded by no face: owner and neighbour must number cells from 0 without gaps")
            } else {
                let list: Vec<String> = mine.iter().map(|e| (e / 2).to_string()).collect();
                format!("cell {c} has {} faces ({}); a cell needs at least 4", mine.len(), list.join(", "))
            };
            return Err(CellError { message, face: first });
        }
        buf.clear();
        bounds.clear();
        for &e in mine {
            let face = m.face(e / 2);
            let s = buf.len();
            if e % 2 == 0 {
                buf.extend_from_slice(face);
            } else {
                buf.push(face[0]);
                buf.extend(face[1..].iter().rev());
            }
            bounds.push((s, buf.len()));
        }
        let faces: Vec<&[u32]> = bounds.iter().map(|&(s, e)| &buf[s..e]).collect();
        let src = c as u32;
        match classify(&faces) {
            Some((ty, nodes)) => {
                out.cells.push(ty, &nodes);
                out.source_cell.push(src);
                out.counts[match ty {
                    CellType::Tetra => 0,
                    CellType::Pyramid => 1,
                    CellType::Wedge => 2,
                    _ => 3,
                }] += 1;
            }
            None => {
                if let Some((a, b, k)) = open_edge(&faces) {
                    return Err(CellError {
                        message: format!(
                            "cell {c} is not closed: its edge {a}-{b} is on {k} of its faces (every edge must be on exactly 2)"
                        ),
                        face: first,
                    });
                }
                let (cells, source) = (&mut out.cells, &mut out.source_cell);
                out.splitter
                    .split(faces.iter().copied(), &mut |t| {
                        cells.push(CellType::Tetra, &t);
                        source.push(src);
                    })
                    .map_err(|message| CellError { message: format!("cell {c}: {message}"), face: first })?;
                out.counts[4] += 1;
            }
        }
    }
    Ok(out)
}

#[cfg(test)]
mod tests {
    use super::*;
    use tet_mesh::predicates::signed_tet_volume;

    /// Unit cube: points in VTK hexahedron order; faces outward.
    fn cube_faces() -> Vec<Vec<u32>> {
        vec![vec![0, 3, 2, 1], vec![4, 5, 6, 7], vec![0, 1, 5, 4], vec![1, 2, 6, 5], vec![2, 3, 7, 6], vec![3, 0, 4, 7]]
    }

    fn cube_points() -> Vec<[f64; 3]> {
        tet_mesh::split::UNIT_HEX.to_vec()
    }

    fn vol(p: &[[f64; 3]], n: &[u32]) -> f64 {
        signed_tet_volume(&p[n[0] as usize], &p[n[1] as usize], &p[n[2] as usize], &p[n[3] as usize])
    }

    #[test]
    fn a_cube_in_any_face_order_is_a_positive_hexahedron() {
        let p = cube_points();
        let faces = cube_faces();
        for rot in 0..6 {
            let mut f = faces.clone();
            f.rotate_left(rot);
            let refs: Vec<&[u32]> = f.iter().map(Vec::as_slice).collect();
            let (ty, n) = classify(&refs).unwrap();
            assert_eq!(ty, CellType::Hexahedron);
            // Corner tets at node 0 and node 6 are positive in VTK order.
            assert!(vol(&p, &[n[0], n[1], n[3], n[4]]) > 0.0, "{n:?}");
            assert!(vol(&p, &[n[6], n[5], n[7], n[2]]) > 0.0, "{n:?}");
        }
    }

    #[test]
    fn tet_pyramid_and_wedge_are_positive() {
        let p = vec![[0., 0., 0.], [1., 0., 0.], [0., 1., 0.], [0., 0., 1.]];
        let f: [&[u32]; 4] = [&[0, 2, 1], &[0, 1, 3], &[1, 2, 3], &[2, 0, 3]];
        let (ty, n) = classify(&f).unwrap();
        assert_eq!(ty, CellType::Tetra);
        assert!(vol(&p, &n[..4]) > 0.0);
        let f: [&[u32]; 5] = [&[0, 1, 4], &[0, 3, 2, 1], &[1, 2, 4], &[2, 3, 4], &[3, 0, 4]];
        assert_eq!(classify(&f).unwrap(), (CellType::Pyramid, [0, 1, 2, 3, 4, 0, 0, 0]));
        let f: [&[u32]; 5] = [&[0, 1, 4, 3], &[0, 2, 1], &[3, 4, 5], &[1, 2, 5, 4], &[2, 0, 3, 5]];
        assert_eq!(classify(&f).unwrap(), (CellType::Wedge, [0, 1, 2, 3, 4, 5, 0, 0]));
    }

    #[test]
    fn an_open_cell_is_refused() {
        let mut f = cube_faces();
        f[5] = vec![3, 0, 4, 8];
        let refs: Vec<&[u32]> = f.iter().map(Vec::as_slice).collect();
        assert!(classify(&refs).is_none());
        assert!(open_edge(&refs).is_some());
    }
}
