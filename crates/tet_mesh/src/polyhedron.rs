//! Polyhedral cells (OpenFOAM's arbitrary cells, VTK's `VTK_POLYHEDRON`,
//! id 42) as tets around added centre points, conforming with each other and
//! with the cells [`crate::split`] splits.
//!
//! A polyhedron is given as its faces, each a cycle of global point ids. It
//! becomes a cone from a new **cell-centre** point (the average of its
//! distinct points) over a triangulation of every face:
//!
//! - a triangle is kept;
//! - a quadrilateral is cut along the diagonal through its smallest id — the
//!   rule [`crate::split`] applies to every quad face of hexahedra, wedges
//!   and pyramids, so a quad shared with such a cell is cut the same way
//!   from both sides;
//! - a face of five or more points is fanned from a new **face-centre** point
//!   (the average of its points), one per distinct face (keyed by its sorted
//!   ids), so the two polyhedra sharing it use the same point and the same
//!   triangles. A fan from a centre point stays valid for non-planar faces
//!   and for faces with collinear runs (hanging nodes on an edge), where a
//!   fan from a corner would make zero-area triangles; ParaView's
//!   `decomposePolyhedra` does the same.
//!
//! The cell's tets are positive when its faces are given outward (right-hand
//! normals pointing out of the cell) and the cell is star-shaped from its
//! centre; faces given inward make negative tets, which conversion
//! re-orients. Ids must be the ones the min-id rule sees: conversion merges
//! duplicate points before splitting, so callers whose points may hold
//! duplicates should merge them first, or a quad shared with a hexahedron
//! through a duplicate may be cut along the other diagonal.
//!
//! The added points are not in the mesh until [`PolyhedronSplitter::finish`]
//! appends them to a [`SourceMesh`], with every point field's value the
//! average of the point's parents (the cell's or the face's points); cell
//! fields are the reader's business: each tet becomes a cell that carries
//! the polyhedron's values.

use crate::merge::FastMap;
use crate::source::SourceMesh;
use crate::split::split_quad;

/// Splits polyhedra into tets, accumulating the centre points it adds.
#[derive(Debug, Clone, Default)]
pub struct PolyhedronSplitter {
    /// Points in the mesh before any were added: added point `k` gets id
    /// `base + k`.
    base: usize,
    /// Parents of each added point (it lies at their average), flattened:
    /// added point `k` has `parents[parent_start[k]..parent_start[k + 1]]`.
    parents: Vec<u32>,
    parent_start: Vec<usize>,
    /// Sorted ids of a face of ≥ 5 points → its face-centre point id.
    face_centres: FastMap<Vec<u32>, u32>,
    /// Polyhedra split so far.
    cells: usize,
}

impl PolyhedronSplitter {
    /// A splitter for a mesh that has `num_points` points now.
    pub fn new(num_points: usize) -> Self {
        PolyhedronSplitter { base: num_points, parent_start: vec![0], ..Default::default() }
    }

    /// Number of points added so far (cell and face centres).
    pub fn num_added_points(&self) -> usize {
        self.parent_start.len() - 1
    }

    /// Number of polyhedra split so far.
    pub fn num_cells(&self) -> usize {
        self.cells
    }

    /// Number of face-centre points added so far.
    pub fn num_face_centres(&self) -> usize {
        self.face_centres.len()
    }

    fn add_point(&mut self, parents: impl IntoIterator<Item = u32>) -> Result<u32, String> {
        let id = self.base + self.num_added_points();
        let id = u32::try_from(id)
            .ok()
            .filter(|&i| i < u32::MAX)
            .ok_or_else(|| format!("added centre points take the point count past {}", u32::MAX - 1))?;
        self.parents.extend(parents);
        self.parent_start.push(self.parents.len());
        Ok(id)
    }

    /// Splits one polyhedron given by its faces (cycles of global ids, each
    /// of at least 3 points; outward for positive tets), calling `out` with
    /// each tet `[centre, a, b, c]`. Errors (no panic) for a face with fewer
    /// than 3 points or a point count past `u32`.
    pub fn split<'f>(
        &mut self,
        faces: impl IntoIterator<Item = &'f [u32]> + Clone,
        out: &mut impl FnMut([u32; 4]),
    ) -> Result<(), String> {
        let mut distinct: Vec<u32> = faces.clone().into_iter().flatten().copied().collect();
        distinct.sort_unstable();
        distinct.dedup();
        let centre = self.add_point(distinct)?;
        self.cells += 1;
        for (k, face) in faces.into_iter().enumerate() {
            match *face {
                [a, b, c] => out([centre, a, b, c]),
                [a, b, c, d] => {
                    for t in split_quad([a, b, c, d]) {
                        out([centre, t[0], t[1], t[2]]);
                    }
                }
                _ if face.len() >= 5 => {
                    let mut key = face.to_vec();
                    key.sort_unstable();
                    let fc = match self.face_centres.get(&key) {
                        Some(&id) => id,
                        None => {
                            let id = self.add_point(face.iter().copied())?;
                            self.face_centres.insert(key, id);
                            id
                        }
                    };
                    for (i, &a) in face.iter().enumerate() {
                        out([centre, fc, a, face[(i + 1) % face.len()]]);
                    }
                }
                _ => return Err(format!("face {k} of a polyhedron has {} points; a face needs 3", face.len())),
            }
        }
        Ok(())
    }

    /// Appends the added points to `mesh` (each at the average of its
    /// parents) and extends every point field (the parents' average) and the
    /// blanking mask (blanked when any parent is). The mesh must be the one
    /// the splitter was created for: its point count is checked.
    pub fn finish(self, mesh: &mut SourceMesh) -> Result<(), String> {
        if mesh.points.len() != self.base {
            return Err(format!(
                "the splitter was made for {} points but the mesh has {}",
                self.base,
                mesh.points.len()
            ));
        }
        if let Some(&bad) = self.parents.iter().find(|&&p| p as usize >= self.base) {
            return Err(format!("a polyhedron refers to point {bad}, but there are {} points", self.base));
        }
        let added = self.num_added_points();
        mesh.points.reserve(added);
        for k in 0..added {
            let ps = &self.parents[self.parent_start[k]..self.parent_start[k + 1]];
            let mut s = [0.0f64; 3];
            for &p in ps {
                let q = mesh.points[p as usize];
                for a in 0..3 {
                    s[a] += q[a];
                }
            }
            let n = ps.len().max(1) as f64;
            mesh.points.push(s.map(|v| v / n));
        }
        for f in &mut mesh.point_fields {
            let nc = f.num_components;
            if f.values.len() != self.base * nc {
                return Err(format!("point field '{}' has {} values for {} points", f.name, f.values.len(), self.base));
            }
            f.values.reserve(added * nc);
            for k in 0..added {
                let ps = &self.parents[self.parent_start[k]..self.parent_start[k + 1]];
                let n = ps.len().max(1) as f64;
                for c in 0..nc {
                    let s: f64 = ps.iter().map(|&p| f.values[p as usize * nc + c]).sum();
                    f.values.push(s / n);
                }
            }
        }
        if let Some(bl) = &mut mesh.point_blanked {
            for k in 0..added {
                let ps = &self.parents[self.parent_start[k]..self.parent_start[k + 1]];
                let b = ps.iter().any(|&p| bl.get(p as usize).copied().unwrap_or(false));
                bl.push(b);
            }
        }
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::predicates::signed_tet_volume;
    use crate::source::Field;
    use crate::split::{HEX_FACES, UNIT_HEX};

    /// Unit cube corners 0..8 (VTK hexahedron order), its six faces outward.
    fn cube() -> (Vec<[f64; 3]>, Vec<Vec<u32>>) {
        let f = HEX_FACES.iter().map(|f| f.iter().map(|&v| v as u32).collect()).collect();
        (UNIT_HEX.to_vec(), f)
    }

    #[test]
    fn a_cube_as_polyhedron_fills_its_volume_with_positive_tets() {
        let (p, f) = cube();
        let mut mesh = SourceMesh {
            points: p,
            point_fields: vec![Field::new("s", 1, (0..8).map(f64::from).collect())],
            ..Default::default()
        };
        let mut s = PolyhedronSplitter::new(8);
        let mut tets = vec![];
        s.split(f.iter().map(Vec::as_slice), &mut |t| tets.push(t)).unwrap();
        assert_eq!(tets.len(), 12);
        s.finish(&mut mesh).unwrap();
        assert_eq!(mesh.points[8], [0.5, 0.5, 0.5]);
        assert_eq!(mesh.point_fields[0].values[8], 3.5);
        let p = &mesh.points;
        let vol: f64 = tets
            .iter()
            .map(|t| {
                let v = signed_tet_volume(&p[t[0] as usize], &p[t[1] as usize], &p[t[2] as usize], &p[t[3] as usize]);
                assert!(v > 0.0, "{t:?}");
                v
            })
            .sum();
        assert!((vol - 1.0).abs() < 1e-12);
    }

    #[test]
    fn pentagons_share_one_face_centre_and_bad_faces_are_errors() {
        let mut s = PolyhedronSplitter::new(10);
        let pent: &[u32] = &[0, 1, 2, 3, 4];
        let rev: &[u32] = &[4, 3, 2, 1, 0];
        let mut a = vec![];
        s.split([pent, &[0, 1, 5][..]], &mut |t| a.push(t)).unwrap();
        let mut b = vec![];
        s.split([rev, &[0, 1, 6][..]], &mut |t| b.push(t)).unwrap();
        // Two cell centres and one shared face centre.
        assert_eq!(s.num_added_points(), 3);
        assert_eq!(s.num_face_centres(), 1);
        assert_eq!(a[0][1], 11);
        assert_eq!(b[0][1], 11);
        assert!(s.split([&[0, 1][..]], &mut |_| {}).unwrap_err().contains("2 points"));
    }
}
