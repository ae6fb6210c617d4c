//! The mesh as a reader found it: mixed volume cells, structured blocks and
//! named fields, before tetrahedralization and validation.
//!
//! Every input reader in `tet_io` produces a [`SourceMesh`]; everything after
//! that (splitting, scalar selection, validation, adjacency) is format-blind.

use serde::{Deserialize, Serialize};

/// A linear volume cell type. Node orders follow VTK's (see `vtkCellType.h`):
/// a hexahedron is the bottom quad 0-1-2-3 then the top quad 4-5-6-7 with
/// 0-4, 1-5, 2-6, 3-7 edges; a voxel is a hexahedron with VTK's voxel order
/// (0,1,3,2,4,5,7,6 in hexahedron terms); a wedge is triangles 0-1-2 and
/// 3-4-5 with 0-3, 1-4, 2-5 edges; a pyramid is the base quad 0-1-2-3 and
/// apex 4. Orientation is not required: validation re-orients inverted tets.
///
/// Five quadratic cells keep all their nodes and are subdivided into
/// linear tets at them ([`crate::split`]): the 10-node tetrahedron (corners,
/// then the midpoints of edges 0-1, 1-2, 2-0, 0-3, 1-3, 2-3), the 20-node
/// hexahedron (corners, then the midpoints of edges 0-1, 1-2, 2-3, 3-0,
/// 4-5, 5-6, 6-7, 7-4, 0-4, 1-5, 2-6, 3-7), the 27-node one (the 20,
/// then the centres of the faces at x = 0, x = 1, y = 0, y = 1, z = 0,
/// z = 1 of the cell's parameter cube, then its centre), the 15-node wedge
/// (corners, then edges 0-1, 1-2, 2-0, 3-4, 4-5, 5-3, 0-3, 1-4, 2-5), the
/// 18-node one (the 15, then the centres of quads 0-1-4-3, 1-2-5-4,
/// 2-0-3-5), the 13-node pyramid (corners, then edges 0-1, 1-2, 2-3, 3-0,
/// 0-4, 1-4, 2-4, 3-4) and Gmsh's 14-node one (the 13, then the centre of
/// the base), in VTK's orders.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, Serialize, Deserialize)]
pub enum CellType {
    Tetra,
    Hexahedron,
    Voxel,
    Wedge,
    Pyramid,
    QuadraticTetra,
    QuadraticHexahedron,
    TriquadraticHexahedron,
    QuadraticWedge,
    QuadraticPyramid,
    BiquadraticWedge,
    QuadraticPyramidWithBaseCentre,
    /// VTK's Lagrange tetrahedron of order n ≥ 2 (id 71): (n + 1)(n + 2)(n +
    /// 3)/6 nodes in [`crate::lagrange`]'s order.
    LagrangeTetra(u8),
    /// VTK's Lagrange hexahedron of orders (p, q, r) along its parameter
    /// axes (id 72): (p + 1)(q + 1)(r + 1) nodes.
    LagrangeHexahedron([u8; 3]),
    /// VTK's Lagrange wedge of order n across and m along its axis (id 73):
    /// (n + 1)(n + 2)(m + 1)/2 nodes.
    LagrangeWedge(u8, u8),
    /// The 15-node tetrahedron (VTK's Lagrange tetrahedron of 15 nodes): the
    /// 10-node one's nodes, the centres of faces (0, 1, 2), (0, 1, 3),
    /// (1, 2, 3), (0, 2, 3), then the body centre.
    QuadraticTetraWithCentres,
    /// The 21-node wedge (VTK's Lagrange wedge of 21 nodes): the 15-node
    /// one's, the centres of triangles 0-1-2 and 3-4-5, of quads 0-1-4-3,
    /// 1-2-5-4, 2-0-3-5, then the body centre.
    QuadraticWedgeWithCentres,
    /// A pyramid of order n ≥ 2 in Gmsh's node order (VTK has no such
    /// cell): (n + 1)(n + 2)(2n + 3)/6 nodes — corners, edges, faces, body,
    /// recursively ([`crate::lagrange::gmsh_pyramid_lattice`]).
    LagrangePyramid(u8),
    /// VTK's 12-node wedge quadratic across and linear along its axis (id
    /// 31): corners, then the midpoints of edges 0-1, 1-2, 2-0, 3-4, 4-5, 5-3.
    QuadraticLinearWedge,
    /// VTK's 24-node hexahedron biquadratic on its side faces and quadratic
    /// along its axis (id 33): the 20-node one's nodes, then the centres of
    /// the faces at x = 0, x = 1, y = 0, y = 1 of its parameter cube.
    BiquadraticQuadraticHexahedron,
    /// VTK's 19-node pyramid (id 37): the 13-node one's nodes, the base's
    /// centre, the centres of triangles 0-1-4, 1-2-4, 2-3-4, 3-0-4, then the
    /// body centre.
    TriquadraticPyramid,
}

impl CellType {
    /// The linear cell of a quadratic one (its first nodes are the
    /// corners); a linear cell itself.
    pub fn linear(self) -> CellType {
        match self {
            CellType::QuadraticTetra | CellType::QuadraticTetraWithCentres | CellType::LagrangeTetra(_) => {
                CellType::Tetra
            }
            CellType::QuadraticHexahedron
            | CellType::TriquadraticHexahedron
            | CellType::LagrangeHexahedron(_)
            | CellType::BiquadraticQuadraticHexahedron => CellType::Hexahedron,
            CellType::QuadraticWedge
            | CellType::BiquadraticWedge
            | CellType::QuadraticWedgeWithCentres
            | CellType::LagrangeWedge(..)
            | CellType::QuadraticLinearWedge => CellType::Wedge,
            CellType::QuadraticPyramid
            | CellType::QuadraticPyramidWithBaseCentre
            | CellType::LagrangePyramid(_)
            | CellType::TriquadraticPyramid => CellType::Pyramid,
            linear => linear,
        }
    }

    /// For each node after the corners (in the cell's order), the corners
    /// whose mean is where it sits on a straight-sided cell: an edge's two,
    /// a face's three or four, or all (a body centre). Empty for linear and
    /// Lagrange cells (whose nodes follow from their parameter lattice) and
    /// for VTK's 12-node wedge, 24-node hexahedron and 19-node pyramid (no
    /// reader needs their check; the pyramid's body node is no corners'
    /// mean).
    pub fn straight_sided_parents(self) -> &'static [&'static [usize]] {
        const TRIQUADRATIC: [&[usize]; 19] = [
            &[0, 1],
            &[1, 2],
            &[2, 3],
            &[3, 0],
            &[4, 5],
            &[5, 6],
            &[6, 7],
            &[7, 4],
            &[0, 4],
            &[1, 5],
            &[2, 6],
            &[3, 7],
            &[0, 3, 7, 4],
            &[1, 2, 6, 5],
            &[0, 1, 5, 4],
            &[3, 2, 6, 7],
            &[0, 1, 2, 3],
            &[4, 5, 6, 7],
            &[0, 1, 2, 3, 4, 5, 6, 7],
        ];
        const TETRA15: [&[usize]; 11] = [
            &[0, 1],
            &[1, 2],
            &[2, 0],
            &[0, 3],
            &[1, 3],
            &[2, 3],
            &[0, 1, 2],
            &[0, 1, 3],
            &[1, 2, 3],
            &[0, 2, 3],
            &[0, 1, 2, 3],
        ];
        const WEDGE: [&[usize]; 12] = [
            &[0, 1],
            &[1, 2],
            &[2, 0],
            &[3, 4],
            &[4, 5],
            &[5, 3],
            &[0, 3],
            &[1, 4],
            &[2, 5],
            &[0, 1, 4, 3],
            &[1, 2, 5, 4],
            &[2, 0, 3, 5],
        ];
        const WEDGE21: [&[usize]; 15] = [
            &[0, 1],
            &[1, 2],
            &[2, 0],
            &[3, 4],
            &[4, 5],
            &[5, 3],
            &[0, 3],
            &[1, 4],
            &[2, 5],
            &[0, 1, 2],
            &[3, 4, 5],
            &[0, 1, 4, 3],
            &[1, 2, 5, 4],
            &[2, 0, 3, 5],
            &[0, 1, 2, 3, 4, 5],
        ];
        const PYRAMID: [&[usize]; 9] =
            [&[0, 1], &[1, 2], &[2, 3], &[3, 0], &[0, 4], &[1, 4], &[2, 4], &[3, 4], &[0, 1, 2, 3]];
        match self {
            CellType::QuadraticTetra => &TETRA15[..6],
            CellType::QuadraticTetraWithCentres => &TETRA15,
            CellType::QuadraticHexahedron => &TRIQUADRATIC[..12],
            CellType::TriquadraticHexahedron => &TRIQUADRATIC,
            CellType::QuadraticWedge => &WEDGE[..9],
            CellType::BiquadraticWedge => &WEDGE,
            CellType::QuadraticWedgeWithCentres => &WEDGE21,
            CellType::QuadraticPyramid => &PYRAMID[..8],
            CellType::QuadraticPyramidWithBaseCentre => &PYRAMID,
            _ => &[],
        }
    }

    /// Whether each of a quadratic cell's nodes after its corners lies
    /// nearer its own straight-sided place ([`CellType::straight_sided_parents`])
    /// than half the distance from that place to any other node's: a curved
    /// cell's bulge passes, a node order other than the one assumed (some
    /// node sitting at another's place) fails. How a reader checks that a
    /// file's node order is the one it assumed.
    pub fn higher_order_nodes_in_place(self, nodes: &[u32], points: &[[f64; 3]]) -> bool {
        let at = |n: usize| points[nodes[n] as usize];
        let corners = self.linear().num_nodes();
        let parents = self.straight_sided_parents();
        let place = |i: usize| -> [f64; 3] {
            if i < corners {
                return at(i);
            }
            let p = parents[i - corners];
            [0, 1, 2].map(|k| p.iter().map(|&c| at(c)[k]).sum::<f64>() / p.len() as f64)
        };
        let places: Vec<[f64; 3]> = (0..corners + parents.len()).map(place).collect();
        let d2 = |a: [f64; 3], b: [f64; 3]| (0..3).map(|k| (a[k] - b[k]).powi(2)).sum::<f64>();
        (corners..places.len()).all(|i| {
            let nearest_other =
                (0..places.len()).filter(|&j| j != i).map(|j| d2(places[i], places[j])).fold(f64::INFINITY, f64::min);
            // |x − P| < ½ min |P − Q|, squared.
            d2(at(i), places[i]) < nearest_other / 4.0
        })
    }

    /// Number of nodes the cell keeps: the linear cell's, or a quadratic
    /// cell's all.
    pub fn num_nodes(self) -> usize {
        match self {
            CellType::Tetra => 4,
            CellType::Hexahedron | CellType::Voxel => 8,
            CellType::Wedge => 6,
            CellType::Pyramid => 5,
            CellType::QuadraticTetra => 10,
            CellType::QuadraticHexahedron => 20,
            CellType::TriquadraticHexahedron => 27,
            CellType::QuadraticWedge => 15,
            CellType::QuadraticPyramid => 13,
            CellType::BiquadraticWedge => 18,
            CellType::QuadraticPyramidWithBaseCentre => 14,
            CellType::LagrangeTetra(n) => {
                let n = n as usize;
                (n + 1) * (n + 2) * (n + 3) / 6
            }
            CellType::LagrangeHexahedron(o) => o.iter().map(|&a| a as usize + 1).product(),
            CellType::LagrangeWedge(n, m) => {
                let (n, m) = (n as usize, m as usize);
                (n + 1) * (n + 2) / 2 * (m + 1)
            }
            CellType::QuadraticTetraWithCentres => 15,
            CellType::QuadraticWedgeWithCentres => 21,
            CellType::LagrangePyramid(n) => {
                let n = n as usize;
                (n + 1) * (n + 2) * (2 * n + 3) / 6
            }
            CellType::QuadraticLinearWedge => 12,
            CellType::BiquadraticQuadraticHexahedron => 24,
            CellType::TriquadraticPyramid => 19,
        }
    }

    /// Maps a VTK cell type id to the volume cell it is read as and the
    /// number of nodes the file stores for it. Every quadratic volume cell
    /// VTK has keeps its nodes (subdivided at them): the 10-node
    /// tetrahedron, the 20-, 24- and 27-node hexahedra, the 12-, 15- and
    /// 18-node wedges, the 13- and 19-node pyramids.
    ///
    /// Returns `None` for non-volume cells (vertices, lines, polygons) and
    /// for volume cell types that are no linear cell (polyhedra, which
    /// readers with a face stream split with
    /// [`crate::polyhedron::PolyhedronSplitter`]; Lagrange and Bézier cells,
    /// whose node count varies: [`CellType::from_vtk`]); readers skip the
    /// rest and say so in a note.
    pub fn from_vtk_id(id: u32) -> Option<(CellType, usize)> {
        Some(match id {
            10 => (CellType::Tetra, 4),
            11 => (CellType::Voxel, 8),
            12 => (CellType::Hexahedron, 8),
            13 => (CellType::Wedge, 6),
            14 => (CellType::Pyramid, 5),
            24 => (CellType::QuadraticTetra, 10),
            25 => (CellType::QuadraticHexahedron, 20),
            26 => (CellType::QuadraticWedge, 15),
            27 => (CellType::QuadraticPyramid, 13),
            32 => (CellType::BiquadraticWedge, 18),
            29 => (CellType::TriquadraticHexahedron, 27),
            31 => (CellType::QuadraticLinearWedge, 12),
            33 => (CellType::BiquadraticQuadraticHexahedron, 24),
            37 => (CellType::TriquadraticPyramid, 19),
            _ => return None,
        })
    }

    /// [`CellType::from_vtk_id`] extended to VTK's Lagrange volumes (ids 71,
    /// 72, 73, kept and cut at their nodes) and Bézier ones (78, 79, 80: the
    /// Lagrange cell of their orders, [`CellType::vtk_id_is_bezier`]), whose order follows from their node count
    /// `count` or their `HigherOrderDegrees` row ([`crate::lagrange`]).
    /// Returns the cell type and the node count the file stores for it
    /// (more than the type keeps when reduced); `Some(Err)` when `count` or
    /// the degrees fit no cell of the type; `None` for other ids.
    pub fn from_vtk(id: u32, count: usize, degrees: Option<[i64; 3]>) -> Option<Result<(CellType, usize), String>> {
        match CellType::from_vtk_id(id) {
            Some(fixed) => Some(Ok(fixed)),
            None => crate::lagrange::cell_type_of_vtk_higher_order(id, count, degrees).map(|r| r.map(|t| (t, count))),
        }
    }

    /// True for VTK's Bézier volume ids (tetrahedron 78, hexahedron 79,
    /// wedge 80): [`CellType::from_vtk`] gives them the Lagrange cell of
    /// their orders, whose nodes a reader must first evaluate
    /// ([`crate::bezier::BezierEvaluator`]).
    pub fn vtk_id_is_bezier(id: u32) -> bool {
        matches!(id, 78..=80)
    }

    /// True for VTK ids of cells that have no volume (vertex, line, polygon
    /// families); readers skip them silently except for a count in a note.
    pub fn vtk_id_is_surface_or_lower(id: u32) -> bool {
        // empty, vertex…polygon families, quadratic/biquadratic 1D-2D cells,
        // parametric curves/surfaces, higher-order, Lagrange and Bézier 1D-2D.
        matches!(id, 0..=9 | 21 | 22 | 23 | 28 | 30 | 34 | 35 | 36 | 51..=54 | 60..=63 | 68..=70 | 75..=77)
    }
}

impl CellType {
    /// True for VTK volume cells tetkit cannot reduce to a linear cell:
    /// pentagonal and hexagonal prisms, convex point sets, polyhedra,
    /// parametric regions, the variable-order higher-order volumes and the
    /// Lagrange and Bézier pyramids (which VTK itself does not construct).
    /// Readers skip them with a counted note.
    pub fn vtk_id_is_unreducible_volume(id: u32) -> bool {
        matches!(id, 15 | 16 | 41 | 42 | 55 | 56 | 64..=67 | 74 | 81)
    }
}

/// Unstructured cells in compressed-row form: cell `c` has type `types[c]`
/// and nodes `connectivity[offsets[c]..offsets[c + 1]]`, exactly
/// `types[c].num_nodes()` of them (readers drop the higher-order nodes of
/// cells they reduce to their corners).
#[derive(Debug, Clone, Default, PartialEq)]
pub struct Cells {
    pub types: Vec<CellType>,
    pub offsets: Vec<usize>,
    pub connectivity: Vec<u32>,
}

impl Cells {
    /// An empty cell list ready for [`Cells::push`].
    pub fn new() -> Self {
        Cells { types: Vec::new(), offsets: vec![0], connectivity: Vec::new() }
    }

    /// Appends one cell. `nodes` must hold at least `cell_type.num_nodes()`
    /// entries; only that many leading entries are kept.
    pub fn push(&mut self, cell_type: CellType, nodes: &[u32]) {
        let n = cell_type.num_nodes();
        self.types.push(cell_type);
        self.connectivity.extend_from_slice(&nodes[..n]);
        self.offsets.push(self.connectivity.len());
    }

    pub fn len(&self) -> usize {
        self.types.len()
    }

    /// Reduces every quadratic cell to its linear corners (its first
    /// nodes); returns how many were. Readers call it when the same mesh
    /// also holds higher-order cells they could only reduce: a cell cut at
    /// its mid-edge nodes beside one that ignores them would not conform
    /// across their shared face.
    pub fn reduce_to_corners(&mut self) -> usize {
        if self.types.iter().all(|&t| t.linear() == t) {
            return 0;
        }
        let mut out = Cells::new();
        let mut reduced = 0;
        for c in 0..self.len() {
            let t = self.types[c];
            reduced += (t.linear() != t) as usize;
            out.push(t.linear(), self.nodes(c));
        }
        *self = out;
        reduced
    }

    pub fn is_empty(&self) -> bool {
        self.types.is_empty()
    }

    /// Nodes of cell `c`.
    pub fn nodes(&self, c: usize) -> &[u32] {
        &self.connectivity[self.offsets[c]..self.offsets[c + 1]]
    }
}

/// A group of cells sharing one topology description.
#[derive(Debug, Clone, PartialEq)]
pub enum Block {
    /// Explicit cells referring to global point indices.
    Unstructured(Cells),
    /// A structured (curvilinear, rectilinear or uniform) block of
    /// `dims[0] × dims[1] × dims[2]` points stored i-fastest starting at
    /// global point index `first_point`. Its hexahedral cells are ordered
    /// i-fastest too; cell (i,j,k) has nodes (i,j,k), (i+1,j,k), (i+1,j+1,k),
    /// (i,j+1,k) and the same at k+1 (VTK hexahedron order).
    Structured { dims: [usize; 3], first_point: usize },
}

impl Block {
    /// Number of volume cells in the block (a structured block with any
    /// dimension below 2 has none).
    pub fn num_cells(&self) -> usize {
        match self {
            Block::Unstructured(cells) => cells.len(),
            Block::Structured { dims, .. } => dims.iter().map(|&d| d.saturating_sub(1)).product(),
        }
    }
}

/// A named field with `num_components` values per tuple, stored
/// tuple-major (`values[t * num_components + c]`).
#[derive(Debug, Clone, PartialEq)]
pub struct Field {
    pub name: String,
    pub num_components: usize,
    pub values: Vec<f64>,
}

impl Field {
    pub fn new(name: impl Into<String>, num_components: usize, values: Vec<f64>) -> Self {
        Field { name: name.into(), num_components, values }
    }

    pub fn num_tuples(&self) -> usize {
        self.values.len().checked_div(self.num_components).unwrap_or(0)
    }
}

/// What a reader produced. Invariants a reader must uphold (checked by
/// [`SourceMesh::check`]): every cell node and structured block lies inside
/// `points`; point fields have one tuple per point; cell fields have one
/// tuple per cell over all blocks in order; `point_blanked`, when present,
/// has one entry per point.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct SourceMesh {
    pub points: Vec<[f64; 3]>,
    pub blocks: Vec<Block>,
    pub point_fields: Vec<Field>,
    pub cell_fields: Vec<Field>,
    /// PLOT3D IBLANK: `true` marks a blanked point (IBLANK = 0); cells
    /// touching a blanked point are dropped.
    pub point_blanked: Option<Vec<bool>>,
    /// Human-readable facts the reader wants the summary to show, e.g.
    /// "reduced 120 quadratic tetrahedra to their corner nodes".
    pub notes: Vec<String>,
    /// Short name of the format read, e.g. "legacy VTK (binary)".
    pub format: String,
    /// The field the file declares as its active scalar, where it declares
    /// one (VTK XML's `Scalars="NAME"` on `<PointData>`/`<CellData>`, legacy
    /// VTK's first `SCALARS` of `POINT_DATA`/`CELL_DATA`): the default
    /// scalar, point data's before cell data's.
    pub active_point_scalar: Option<String>,
    pub active_cell_scalar: Option<String>,
}

impl SourceMesh {
    /// [`Cells::reduce_to_corners`] over every unstructured block; returns
    /// how many cells were reduced.
    pub fn reduce_to_corners(&mut self) -> usize {
        self.blocks
            .iter_mut()
            .map(|b| match b {
                Block::Unstructured(cells) => cells.reduce_to_corners(),
                _ => 0,
            })
            .sum()
    }

    /// One structured block of `dims` points (`points` in VTK order, i
    /// fastest) with one point field, the scalar `name`: what a structured
    /// grid with one value per point becomes.
    pub fn structured(dims: [usize; 3], points: Vec<[f64; 3]>, name: &str, values: Vec<f64>) -> SourceMesh {
        SourceMesh {
            points,
            blocks: vec![Block::Structured { dims, first_point: 0 }],
            point_fields: vec![Field::new(name, 1, values)],
            ..Default::default()
        }
    }

    /// Total number of volume cells over all blocks.
    pub fn num_cells(&self) -> usize {
        self.blocks.iter().map(Block::num_cells).sum()
    }

    /// Checks the invariants listed on the type; readers call this before
    /// returning so a malformed file becomes an error, not a later panic.
    pub fn check(&self) -> Result<(), String> {
        let n = self.points.len();
        for (b, block) in self.blocks.iter().enumerate() {
            match block {
                Block::Unstructured(cells) => {
                    if cells.offsets.len() != cells.types.len() + 1 {
                        return Err(format!("block {b}: offsets do not match cell count"));
                    }
                    for c in 0..cells.len() {
                        let (lo, hi) = (cells.offsets[c], cells.offsets[c + 1]);
                        if lo > hi || hi > cells.connectivity.len() || hi - lo != cells.types[c].num_nodes() {
                            return Err(format!("block {b}: cell {c} has a bad node range"));
                        }
                    }
                    if let Some((i, &p)) = cells.connectivity.iter().enumerate().find(|(_, &p)| p as usize >= n) {
                        return Err(format!(
                            "block {b}: connectivity entry {i} refers to point {p}, but there are {n} points"
                        ));
                    }
                }
                Block::Structured { dims, first_point } => {
                    let count = dims.iter().try_fold(1usize, |acc, &d| acc.checked_mul(d));
                    match count.and_then(|c| c.checked_add(*first_point)) {
                        Some(end) if end <= n => {}
                        _ => {
                            return Err(format!(
                                "block {b}: structured dims {dims:?} at point {first_point} exceed the {n} points"
                            ))
                        }
                    }
                }
            }
        }
        for f in &self.point_fields {
            check_field_length(f, "point", n)?;
        }
        let nc = self.num_cells();
        for f in &self.cell_fields {
            check_field_length(f, "cell", nc)?;
        }
        if let Some(bl) = &self.point_blanked {
            if bl.len() != n {
                return Err(format!("IBLANK has {} entries for {} points", bl.len(), n));
            }
        }
        Ok(())
    }
}

/// Checks that field `f` has at least one component and one tuple per
/// element: `count` of them, `kind` ("point", "cell") naming them.
fn check_field_length(f: &Field, kind: &str, count: usize) -> Result<(), String> {
    if f.num_components == 0 || f.values.len() != count * f.num_components {
        return Err(format!(
            "{kind} field '{}' has {} values, expected {count} {kind}s × {} components",
            f.name,
            f.values.len(),
            f.num_components
        ));
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn check_catches_out_of_range_node() {
        let mut cells = Cells::new();
        cells.push(CellType::Tetra, &[0, 1, 2, 7]);
        let m =
            SourceMesh { points: vec![[0.0; 3]; 4], blocks: vec![Block::Unstructured(cells)], ..Default::default() };
        let e = m.check().unwrap_err();
        assert!(e.contains("point 7"), "{e}");
    }

    #[test]
    fn quadratic_cells_keep_their_nodes() {
        assert_eq!(CellType::from_vtk_id(24), Some((CellType::QuadraticTetra, 10)));
        assert_eq!(CellType::from_vtk_id(25), Some((CellType::QuadraticHexahedron, 20)));
        assert_eq!(CellType::from_vtk_id(29), Some((CellType::TriquadraticHexahedron, 27)));
        for (id, stored) in [(24, 10), (25, 20), (29, 27), (26, 15), (27, 13), (32, 18), (31, 12), (33, 24), (37, 19)] {
            assert_eq!(CellType::from_vtk_id(id).map(|(t, _)| t.num_nodes()), Some(stored));
        }
        assert_eq!(CellType::from_vtk_id(26), Some((CellType::QuadraticWedge, 15)));
        assert_eq!(CellType::from_vtk_id(31), Some((CellType::QuadraticLinearWedge, 12)));
        // Bézier cells become the Lagrange cells of their orders (their
        // control points evaluated by the reader).
        assert_eq!(CellType::from_vtk(79, 27, None), Some(Ok((CellType::LagrangeHexahedron([2, 2, 2]), 27))));
        assert!(CellType::vtk_id_is_bezier(79) && !CellType::vtk_id_is_bezier(72));
        assert_eq!(CellType::from_vtk_id(5), None);
        assert!(CellType::vtk_id_is_surface_or_lower(5));
    }

    #[test]
    fn structured_block_cell_count() {
        let b = Block::Structured { dims: [40, 32, 32], first_point: 0 };
        assert_eq!(b.num_cells(), 37_479);
        let flat = Block::Structured { dims: [4, 4, 1], first_point: 0 };
        assert_eq!(flat.num_cells(), 0);
    }
}
