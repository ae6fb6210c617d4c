//! Splitting hexahedra, voxels, wedges and pyramids into tetrahedra so that
//! neighbouring cells agree on every shared face.
//!
//! The conforming rule: every quadrilateral face is cut along the diagonal
//! through its smallest (global, after duplicate merging) vertex id, and
//! each cell is coned from its own smallest vertex over the faces that do
//! not contain it. Two cells sharing a quad see the same four ids and so pick
//! the same diagonal, whatever their types or orientations; faces containing
//! the cone apex are cut through it, which is that face's smallest id too.
//! A hexahedron gives 6 tets, a wedge 3, a pyramid 2. Quadratic cells are
//! cut at all their nodes: a 10-node tetrahedron into 8 tets, a 20-node
//! hexahedron into 22, a 27-node one into its 8 sub-hexahedra (48), a
//! 15-node wedge into 14 or 15, an 18-node one into its 8 sub-wedges (24),
//! a 13-node pyramid into 13, Gmsh's 14-node one into 16. Lagrange cells of
//! any order, the centred quadratic cells and VTK's partly quadratic ones
//! (12-node wedge, 24-node hexahedron, 19-node pyramid) are split by
//! [`crate::lagrange`] into these linear cells at their nodes.
//!
//! Structured blocks may instead use the classic alternating 5-tet split:
//! cells of even and odd parity (i+j+k) use the two mirror-image 5-tet
//! decompositions, whose face diagonals match across every shared face of
//! one block. (Across the interface of two blocks the parities need not
//! agree; the min-id rule conforms everywhere.)

use crate::source::{Block, CellType};
use rayon::prelude::*;

/// How structured blocks are split; unstructured hexahedra always use the
/// conforming min-id rule (6 tets).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum SplitMode {
    /// Alternating 5-tet split for structured blocks.
    #[default]
    Five,
    /// Min-id 6-tet split everywhere.
    Six,
}

/// Tets and, for each tet, the index of the source cell it came from
/// (counted over all blocks in order, as cell fields are).
#[derive(Debug, Clone, Default)]
pub struct SplitCells {
    pub tets: Vec<[u32; 4]>,
    pub source_cell: Vec<u32>,
}

// Faces are listed outward (right-hand normal pointing out) for cells in
// VTK's orientation (a hexahedron's bottom quad turns counter-clockwise seen
// from its top; a wedge's first triangle likewise; a pyramid's base seen
// from its apex). Splitting a quad keeps its turning sense, so a cone from
// the apex over outward triangles gives positively oriented tets: only cells
// whose node order is mirrored need re-orientation later.
pub(crate) const HEX_FACES: [[usize; 4]; 6] =
    [[0, 3, 2, 1], [4, 5, 6, 7], [0, 1, 5, 4], [1, 2, 6, 5], [2, 3, 7, 6], [3, 0, 4, 7]];
const WEDGE_QUADS: [[usize; 4]; 3] = [[0, 1, 4, 3], [1, 2, 5, 4], [2, 0, 3, 5]];
const WEDGE_TRIS: [[usize; 3]; 2] = [[0, 2, 1], [3, 4, 5]];
/// The unit cube's corners in VTK hexahedron order: corner `c` of a cell
/// that [`structured_hex`] numbers sits at `(i, j, k) + UNIT_HEX[c]`.
pub const UNIT_HEX: [[f64; 3]; 8] =
    [[0., 0., 0.], [1., 0., 0.], [1., 1., 0.], [0., 1., 0.], [0., 0., 1.], [1., 0., 1.], [1., 1., 1.], [0., 1., 1.]];
/// VTK voxel node i sits at hexahedron node VOXEL_TO_HEX[i]'s place.
const VOXEL_AS_HEX: [usize; 8] = [0, 1, 3, 2, 4, 5, 7, 6];

/// Cuts quad (a, b, c, d) (cyclic order) along the diagonal through its
/// smallest id.
#[inline]
pub(crate) fn split_quad(q: [u32; 4]) -> [[u32; 3]; 2] {
    let [a, b, c, d] = q;
    if a.min(c) < b.min(d) {
        [[a, b, c], [a, c, d]]
    } else {
        [[a, b, d], [b, c, d]]
    }
}

#[inline]
fn argmin(ids: &[u32]) -> usize {
    let mut best = 0;
    for (i, &v) in ids.iter().enumerate() {
        if v < ids[best] {
            best = i;
        }
    }
    best
}

/// Splits one hexahedron (VTK order, global ids) by the min-id rule.
pub fn split_hexahedron(h: &[u32; 8], out: &mut impl FnMut([u32; 4])) {
    let apex = argmin(h);
    for f in HEX_FACES.iter().filter(|f| !f.contains(&apex)) {
        for t in split_quad([h[f[0]], h[f[1]], h[f[2]], h[f[3]]]) {
            out([h[apex], t[0], t[1], t[2]]);
        }
    }
}

/// Splits one wedge (VTK order, global ids) by the min-id rule.
pub fn split_wedge(w: &[u32; 6], out: &mut impl FnMut([u32; 4])) {
    let apex = argmin(w);
    for f in WEDGE_TRIS.iter().filter(|f| !f.contains(&apex)) {
        out([w[apex], w[f[0]], w[f[1]], w[f[2]]]);
    }
    for f in WEDGE_QUADS.iter().filter(|f| !f.contains(&apex)) {
        for t in split_quad([w[f[0]], w[f[1]], w[f[2]], w[f[3]]]) {
            out([w[apex], t[0], t[1], t[2]]);
        }
    }
}

/// Splits one pyramid (base quad 0-3, apex 4) along its base's min-id diagonal.
pub fn split_pyramid(p: &[u32; 5], out: &mut impl FnMut([u32; 4])) {
    for t in split_quad([p[0], p[3], p[2], p[1]]) {
        out([p[4], t[0], t[1], t[2]]);
    }
}

/// Splits one 10-node tetrahedron (VTK order: corners, then the midpoints
/// of edges 0-1, 1-2, 2-0, 0-3, 1-3, 2-3) at its nodes into 8 tets: one at
/// each corner and four around a diagonal of the octahedron the corners
/// leave. Each face becomes its four triangles, which the neighbour across
/// it cuts alike; the diagonal (inside the cell) is the one through the
/// smallest mid-edge id.
pub fn split_quadratic_tetra(n: &[u32; 10], out: &mut impl FnMut([u32; 4])) {
    const CORNERS: [[usize; 4]; 4] = [[0, 4, 6, 7], [4, 1, 5, 8], [6, 5, 2, 9], [7, 8, 9, 3]];
    // Each diagonal (opposite mid-edges) and the cycle of the other four
    // around it, turning so that the tets are positive.
    const DIAGONALS: [([usize; 2], [usize; 4]); 3] =
        [([4, 9], [5, 6, 7, 8]), ([6, 8], [4, 5, 9, 7]), ([7, 5], [4, 6, 9, 8])];
    for c in CORNERS {
        out(c.map(|k| n[k]));
    }
    let (diagonal, cycle) = DIAGONALS.iter().min_by_key(|(d, _)| n[d[0]].min(n[d[1]])).expect("three diagonals");
    for i in 0..4 {
        out([n[diagonal[0]], n[diagonal[1]], n[cycle[i]], n[cycle[(i + 1) % 4]]]);
    }
}

/// Splits one 20-node hexahedron (VTK order: corners, then the midpoints
/// of edges 0-1, 1-2, 2-3, 3-0, 4-5, 5-6, 6-7, 7-4, 0-4, 1-5, 2-6, 3-7) at
/// its nodes, without adding any: a tet at each corner (the corner and its
/// three edges' midpoints), and the cuboctahedron of the twelve midpoints
/// left between them coned from its smallest id over its faces: 22 tets.
/// Each hexahedron face becomes four corner triangles and the square of its
/// edges' midpoints cut by the min-id rule, as the neighbour across it cuts
/// it (the apex, smallest of all twelve, is the smallest of any square it
/// lies on, so those squares are cut through it and left out of the cone).
pub fn split_quadratic_hexahedron(n: &[u32; 20], out: &mut impl FnMut([u32; 4])) {
    const CORNERS: [[usize; 4]; 8] = [
        [0, 8, 11, 16],
        [1, 9, 8, 17],
        [2, 10, 9, 18],
        [3, 11, 10, 19],
        [4, 15, 12, 16],
        [5, 12, 13, 17],
        [6, 13, 14, 18],
        [7, 14, 15, 19],
    ];
    // The cuboctahedron's faces, turning outward: the squares on the
    // hexahedron's faces (in [`HEX_FACES`] order), the triangles cut off
    // at its corners.
    const FACES: [&[usize]; 14] = [
        &[11, 10, 9, 8],
        &[12, 13, 14, 15],
        &[8, 17, 12, 16],
        &[9, 18, 13, 17],
        &[10, 19, 14, 18],
        &[11, 16, 15, 19],
        &[11, 8, 16],
        &[8, 9, 17],
        &[9, 10, 18],
        &[10, 11, 19],
        &[12, 15, 16],
        &[13, 12, 17],
        &[14, 13, 18],
        &[15, 14, 19],
    ];
    for c in CORNERS {
        out(c.map(|k| n[k]));
    }
    cone_from_smallest(n, 8..20, &FACES, out);
}

/// Cones a convex polyhedron of a cell's nodes from its smallest id among
/// `vertices`: `faces` are node slots (triangles, or squares cut by the
/// min-id rule) turning so that a cone from inside is positive. The apex
/// is the smallest id of every square it lies on, so those are cut through
/// it, and every face through it is left out.
fn cone_from_smallest(n: &[u32], vertices: std::ops::Range<usize>, faces: &[&[usize]], out: &mut impl FnMut([u32; 4])) {
    let apex = vertices.start + argmin(&n[vertices]);
    for f in faces.iter().filter(|f| !f.contains(&apex)) {
        match **f {
            [a, b, c] => out([n[apex], n[a], n[b], n[c]]),
            [a, b, c, d] => {
                for t in split_quad([n[a], n[b], n[c], n[d]]) {
                    out([n[apex], t[0], t[1], t[2]]);
                }
            }
            _ => unreachable!("faces are triangles or squares"),
        }
    }
}

/// Splits one 15-node wedge (VTK order: corners, then the midpoints of
/// edges 0-1, 1-2, 2-0, 3-4, 4-5, 5-3, 0-3, 1-4, 2-5) at its nodes: a tet
/// at each corner and the convex polyhedron of the nine midpoints coned
/// from its smallest id (14 or 15 tets). Its faces are cut as the
/// 10-node tetrahedron's and the 20-node hexahedron's are, so it conforms
/// with either across a shared face.
pub fn split_quadratic_wedge(n: &[u32; 15], out: &mut impl FnMut([u32; 4])) {
    const CORNERS: [[usize; 4]; 6] =
        [[0, 6, 8, 12], [1, 7, 6, 13], [2, 8, 7, 14], [3, 11, 9, 12], [4, 9, 10, 13], [5, 10, 11, 14]];
    const FACES: [&[usize]; 11] = [
        &[8, 6, 12],
        &[6, 7, 13],
        &[7, 8, 14],
        &[9, 11, 12],
        &[10, 9, 13],
        &[11, 10, 14],
        &[7, 6, 8],
        &[9, 10, 11],
        &[6, 13, 9, 12],
        &[7, 14, 10, 13],
        &[8, 12, 11, 14],
    ];
    for c in CORNERS {
        out(c.map(|k| n[k]));
    }
    cone_from_smallest(n, 6..15, &FACES, out);
}

/// Splits one 13-node pyramid (VTK order: base 0-3, apex 4, then the
/// midpoints of edges 0-1, 1-2, 2-3, 3-0, 0-4, 1-4, 2-4, 3-4) at its
/// nodes: a tet at each base corner, the small pyramid on the apex over
/// the square of the slanted edges' midpoints (two tets), and the convex
/// polyhedron of the eight midpoints between coned from its smallest id.
pub fn split_quadratic_pyramid(n: &[u32; 13], out: &mut impl FnMut([u32; 4])) {
    const CORNERS: [[usize; 4]; 4] = [[0, 5, 8, 9], [1, 6, 5, 10], [2, 7, 6, 11], [3, 8, 7, 12]];
    const FACES: [&[usize]; 10] = [
        &[8, 5, 9],
        &[5, 6, 10],
        &[6, 7, 11],
        &[7, 8, 12],
        &[5, 10, 9],
        &[6, 11, 10],
        &[7, 12, 11],
        &[8, 9, 12],
        &[8, 7, 6, 5],
        &[9, 10, 11, 12],
    ];
    for c in CORNERS {
        out(c.map(|k| n[k]));
    }
    // The apex's pyramid, over the square the polyhedron shares with it
    // (both cut it by the min-id rule).
    for t in split_quad([n[12], n[11], n[10], n[9]]) {
        out([n[4], t[0], t[1], t[2]]);
    }
    cone_from_smallest(n, 5..13, &FACES, out);
}

/// Splits one 18-node wedge (VTK order: the 15-node one's nodes, then the
/// centres of quads 0-1-4-3, 1-2-5-4, 2-0-3-5) into its 8 sub-wedges (each
/// triangle cut into four, at the bottom, middle and top levels), each by
/// the min-id rule: its faces are cut as the 10-node tetrahedron's and the
/// 27-node hexahedron's are.
pub fn split_biquadratic_wedge(n: &[u32; 18], out: &mut impl FnMut([u32; 4])) {
    // Per level: the triangle's corners, then its edges' midpoints (0-1,
    // 1-2, 2-0); the four sub-triangles in those six slots.
    const LEVELS: [[usize; 6]; 3] = [[0, 1, 2, 6, 7, 8], [12, 13, 14, 15, 16, 17], [3, 4, 5, 9, 10, 11]];
    const SUB: [[usize; 3]; 4] = [[0, 3, 5], [3, 1, 4], [5, 4, 2], [3, 4, 5]];
    for level in 0..2 {
        let (lo, hi) = (LEVELS[level], LEVELS[level + 1]);
        for t in SUB {
            let w = [n[lo[t[0]]], n[lo[t[1]]], n[lo[t[2]]], n[hi[t[0]]], n[hi[t[1]]], n[hi[t[2]]]];
            split_wedge(&w, out);
        }
    }
}

/// Splits one 14-node pyramid (Gmsh's: the 13-node one's nodes in VTK's
/// order, then the centre of the base) at its nodes: at each base corner
/// the pyramid on its quarter of the base under its slanted edge's
/// midpoint, the apex's pyramid over the slanted edges' midpoints, and
/// what is left between coned from the base centre (16 tets). The base is
/// cut into the four quads a 27-node hexahedron's face is.
pub fn split_quadratic_pyramid_with_base_centre(n: &[u32; 14], out: &mut impl FnMut([u32; 4])) {
    // Pyramids as [`split_pyramid`] takes them: base quad, then apex.
    const PYRAMIDS: [[usize; 5]; 5] =
        [[0, 5, 13, 8, 9], [5, 1, 6, 13, 10], [13, 6, 2, 7, 11], [8, 13, 7, 3, 12], [9, 10, 11, 12, 4]];
    // The slanted faces' middle triangles, turning outward.
    const TRIANGLES: [[usize; 3]; 4] = [[5, 10, 9], [6, 11, 10], [7, 12, 11], [8, 9, 12]];
    for p in PYRAMIDS {
        split_pyramid(&p.map(|k| n[k]), out);
    }
    for t in split_quad([n[9], n[10], n[11], n[12]]) {
        out([n[13], t[0], t[1], t[2]]);
    }
    for t in TRIANGLES {
        out([n[13], n[t[0]], n[t[1]], n[t[2]]]);
    }
}

/// Node of a 27-node hexahedron (VTK order) at lattice point `[k][j][i]`
/// of its 3 × 3 × 3 nodes (i along edge 0-1, j along 0-3, k along 0-4).
const TRIQUADRATIC_LATTICE: [[[usize; 3]; 3]; 3] = [
    [[0, 8, 1], [11, 24, 9], [3, 10, 2]],
    [[16, 22, 17], [20, 26, 21], [19, 23, 18]],
    [[4, 12, 5], [15, 25, 13], [7, 14, 6]],
];

/// Splits one 27-node hexahedron (VTK order: the 20-node one's nodes, then
/// the centres of the faces at x = 0, x = 1, y = 0, y = 1, z = 0, z = 1 of
/// its parameter cube, then its centre) into its 8 sub-hexahedra, each by
/// the min-id rule (48 tets), conforming with the neighbour across every
/// face as any hexahedra do.
pub fn split_triquadratic_hexahedron(n: &[u32; 27], out: &mut impl FnMut([u32; 4])) {
    for c in 0..8 {
        let (a, b, z) = (c & 1, (c >> 1) & 1, c >> 2);
        let h = UNIT_HEX.map(|u| n[TRIQUADRATIC_LATTICE[z + u[2] as usize][b + u[1] as usize][a + u[0] as usize]]);
        split_hexahedron(&h, out);
    }
}

/// Splits one structured hexahedron (VTK order) with the alternating 5-tet
/// pattern; `odd` is the parity of i+j+k.
pub fn split_hexahedron_five(h: &[u32; 8], odd: bool, out: &mut impl FnMut([u32; 4])) {
    // Central tet first, then the four corner tets; all positive for a cell
    // in VTK orientation.
    const EVEN: [[usize; 4]; 5] = [[1, 3, 4, 6], [0, 1, 3, 4], [1, 2, 3, 6], [5, 1, 4, 6], [3, 7, 4, 6]];
    const ODD: [[usize; 4]; 5] = [[2, 0, 5, 7], [0, 1, 2, 5], [3, 0, 2, 7], [0, 4, 5, 7], [6, 2, 5, 7]];
    for t in if odd { &ODD } else { &EVEN } {
        out([h[t[0]], h[t[1]], h[t[2]], h[t[3]]]);
    }
}

/// Splits a single cell of any type (nodes in VTK order, already mapped to
/// global merged ids) with the min-id rule.
pub fn split_cell(cell_type: CellType, nodes: &[u32], out: &mut impl FnMut([u32; 4])) {
    match cell_type {
        CellType::Tetra => out([nodes[0], nodes[1], nodes[2], nodes[3]]),
        CellType::Hexahedron => {
            let h: [u32; 8] = nodes[..8].try_into().expect("8 nodes");
            split_hexahedron(&h, out)
        }
        CellType::Voxel => {
            let mut h = [0u32; 8];
            for (i, &hi) in VOXEL_AS_HEX.iter().enumerate() {
                h[hi] = nodes[i];
            }
            split_hexahedron(&h, out)
        }
        CellType::Wedge => split_wedge(&nodes[..6].try_into().expect("6 nodes"), out),
        CellType::Pyramid => split_pyramid(&nodes[..5].try_into().expect("5 nodes"), out),
        CellType::QuadraticTetra => split_quadratic_tetra(&nodes[..10].try_into().expect("10 nodes"), out),
        CellType::QuadraticHexahedron => split_quadratic_hexahedron(&nodes[..20].try_into().expect("20 nodes"), out),
        CellType::TriquadraticHexahedron => {
            split_triquadratic_hexahedron(&nodes[..27].try_into().expect("27 nodes"), out)
        }
        CellType::QuadraticWedge => split_quadratic_wedge(&nodes[..15].try_into().expect("15 nodes"), out),
        CellType::QuadraticPyramid => split_quadratic_pyramid(&nodes[..13].try_into().expect("13 nodes"), out),
        CellType::BiquadraticWedge => split_biquadratic_wedge(&nodes[..18].try_into().expect("18 nodes"), out),
        CellType::QuadraticPyramidWithBaseCentre => {
            split_quadratic_pyramid_with_base_centre(&nodes[..14].try_into().expect("14 nodes"), out)
        }
        CellType::LagrangeTetra(_)
        | CellType::LagrangeHexahedron(_)
        | CellType::LagrangeWedge(..)
        | CellType::LagrangePyramid(_)
        | CellType::QuadraticLinearWedge
        | CellType::BiquadraticQuadraticHexahedron
        | CellType::TriquadraticPyramid
        | CellType::QuadraticTetraWithCentres
        | CellType::QuadraticWedgeWithCentres => crate::lagrange::split_lagrange(cell_type, nodes, out),
    }
}

/// Node ids (VTK hexahedron order, corners as [`UNIT_HEX`]) of cell
/// (i, j, k) of a structured block of `dims` points per axis whose points
/// are numbered i fastest, then j, then k, from `first_point`.
#[inline]
pub fn structured_hex(dims: [usize; 3], first_point: usize, i: usize, j: usize, k: usize) -> [usize; 8] {
    let id = |i: usize, j: usize, k: usize| first_point + i + dims[0] * (j + dims[1] * k);
    [
        id(i, j, k),
        id(i + 1, j, k),
        id(i + 1, j + 1, k),
        id(i, j + 1, k),
        id(i, j, k + 1),
        id(i + 1, j, k + 1),
        id(i + 1, j + 1, k + 1),
        id(i, j + 1, k + 1),
    ]
}

/// The points of a structured block of `dims` points per axis in the
/// block's numbering (i fastest, then j, then k): `at([i, j, k])` for each.
pub fn structured_points(dims: [usize; 3], mut at: impl FnMut([usize; 3]) -> [f64; 3]) -> Vec<[f64; 3]> {
    let mut points = Vec::with_capacity(dims[0] * dims[1] * dims[2]);
    for k in 0..dims[2] {
        for j in 0..dims[1] {
            for i in 0..dims[0] {
                points.push(at([i, j, k]));
            }
        }
    }
    points
}

/// The tets of a structured grid of `cells[0] × cells[1] × cells[2]` cells
/// whose `(cells[0] + 1) × (cells[1] + 1) × (cells[2] + 1)` points are
/// numbered i fastest from 0, split as `mode` splits a
/// [`Block::Structured`], cell by cell in the same order: what
/// [`split_blocks`] gives for that one block with every point its own id.
/// The point count must fit in `u32`, as every mesh's ids.
pub fn structured_grid_tets(cells: [usize; 3], mode: SplitMode) -> Vec<[u32; 4]> {
    let dims = cells.map(|c| c + 1);
    let ids: Vec<u32> = (0..(dims[0] * dims[1] * dims[2]) as u32).collect();
    split_blocks(&[Block::Structured { dims, first_point: 0 }], mode, &ids, None).0.tets
}

/// Splits every block into tets.
///
/// `point_id` maps a source point index to the id the tets should use (the
/// duplicate-merged id); the min-id rule is evaluated on those ids so that
/// cells meeting only through merged duplicates still conform. Cells with a
/// node where `skip_point` is true (PLOT3D IBLANK = 0) are left out; the
/// number of such cells is returned beside the tets.
pub fn split_blocks(
    blocks: &[Block],
    mode: SplitMode,
    point_id: &[u32],
    skip_point: Option<&[bool]>,
) -> (SplitCells, usize) {
    let mut out = SplitCells::default();
    let mut skipped = 0usize;
    let mut cell_base = 0usize;
    let skipped_cell = |nodes: &[usize]| skip_point.is_some_and(|s| nodes.iter().any(|&n| s[n]));
    for block in blocks {
        match block {
            Block::Unstructured(cells) => {
                // Chunks of cells split in parallel, concatenated in order:
                // the same tets in the same order as one pass.
                let split_range = |range: std::ops::Range<usize>| {
                    let mut tets = Vec::with_capacity(range.len());
                    let mut src = Vec::with_capacity(range.len());
                    let mut skipped = 0usize;
                    let mut buf: Vec<u32> = Vec::with_capacity(32);
                    for c in range {
                        let nodes = cells.nodes(c);
                        if let Some(s) = skip_point {
                            if nodes.iter().any(|&n| s[n as usize]) {
                                skipped += 1;
                                continue;
                            }
                        }
                        buf.clear();
                        buf.extend(nodes.iter().map(|&n| point_id[n as usize]));
                        let cell = (cell_base + c) as u32;
                        split_cell(cells.types[c], &buf, &mut |t| {
                            tets.push(t);
                            src.push(cell);
                        });
                    }
                    (tets, src, skipped)
                };
                const CHUNK: usize = 1 << 16;
                let n = cells.len();
                if n <= CHUNK {
                    let (t, s, sk) = split_range(0..n);
                    out.tets.extend_from_slice(&t);
                    out.source_cell.extend_from_slice(&s);
                    skipped += sk;
                } else {
                    let parts: Vec<(Vec<[u32; 4]>, Vec<u32>, usize)> = (0..n.div_ceil(CHUNK))
                        .into_par_iter()
                        .map(|k| split_range(k * CHUNK..((k + 1) * CHUNK).min(n)))
                        .collect();
                    let total: usize = parts.iter().map(|p| p.0.len()).sum();
                    out.tets.reserve(total);
                    out.source_cell.reserve(total);
                    for (t, s, sk) in parts {
                        out.tets.extend_from_slice(&t);
                        out.source_cell.extend_from_slice(&s);
                        skipped += sk;
                    }
                }
            }
            &Block::Structured { dims, first_point } => {
                let [ni, nj, nk] = [dims[0].saturating_sub(1), dims[1].saturating_sub(1), dims[2].saturating_sub(1)];
                let per_cell = match mode {
                    SplitMode::Five => 5,
                    SplitMode::Six => 6,
                };
                // One k-layer of cells per parallel task: layers are independent.
                let layers: Vec<(Vec<[u32; 4]>, Vec<u32>, usize)> = (0..nk)
                    .into_par_iter()
                    .map(|k| {
                        let mut tets = Vec::with_capacity(ni * nj * per_cell);
                        let mut src = Vec::with_capacity(ni * nj * per_cell);
                        let mut skipped = 0usize;
                        for j in 0..nj {
                            for i in 0..ni {
                                let nodes = structured_hex(dims, first_point, i, j, k);
                                if skipped_cell(&nodes) {
                                    skipped += 1;
                                    continue;
                                }
                                let h = nodes.map(|n| point_id[n]);
                                let cell = (cell_base + i + ni * (j + nj * k)) as u32;
                                let mut push = |t| {
                                    tets.push(t);
                                    src.push(cell);
                                };
                                match mode {
                                    SplitMode::Five => split_hexahedron_five(&h, (i + j + k) % 2 == 1, &mut push),
                                    SplitMode::Six => split_hexahedron(&h, &mut push),
                                }
                            }
                        }
                        (tets, src, skipped)
                    })
                    .collect();
                for (t, s, sk) in layers {
                    out.tets.extend_from_slice(&t);
                    out.source_cell.extend_from_slice(&s);
                    skipped += sk;
                }
            }
        }
        cell_base += block.num_cells();
    }
    (out, skipped)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::predicates::signed_tet_volume;

    /// Sum of signed volumes, asserting each tet is positive: cells in VTK
    /// orientation must split into positive tets.
    fn total_abs_volume(p: &[[f64; 3]], tets: &[[u32; 4]]) -> f64 {
        tets.iter()
            .map(|t| {
                let v = signed_tet_volume(&p[t[0] as usize], &p[t[1] as usize], &p[t[2] as usize], &p[t[3] as usize]);
                assert!(v > 0.0, "tet {t:?} has volume {v}");
                v
            })
            .sum()
    }

    /// Points indexed by id: corner c of `corners` at index `ids[c]`.
    fn placed_at_ids(corners: &[[f64; 3]], ids: &[u32]) -> Vec<[f64; 3]> {
        let mut pts = vec![[0.0; 3]; corners.len()];
        for (corner, &id) in corners.iter().zip(ids) {
            pts[id as usize] = *corner;
        }
        pts
    }

    #[test]
    fn every_hex_labelling_gives_six_tets_filling_the_cube() {
        let p = UNIT_HEX;
        // All 8 choices of which corner holds the smallest id, plus shuffled ids.
        let perms: [[u32; 8]; 4] =
            [[0, 1, 2, 3, 4, 5, 6, 7], [7, 6, 5, 4, 3, 2, 1, 0], [3, 0, 6, 1, 7, 2, 5, 4], [5, 7, 0, 2, 6, 1, 4, 3]];
        for ids in perms {
            let pts = placed_at_ids(&p, &ids);
            let mut tets = vec![];
            split_hexahedron(&ids, &mut |t| tets.push(t));
            assert_eq!(tets.len(), 6);
            assert!((total_abs_volume(&pts, &tets) - 1.0).abs() < 1e-12, "{ids:?}");
        }
    }

    #[test]
    fn five_split_fills_the_cube_for_both_parities() {
        let p = UNIT_HEX;
        let ids = [0, 1, 2, 3, 4, 5, 6, 7];
        for odd in [false, true] {
            let mut tets = vec![];
            split_hexahedron_five(&ids, odd, &mut |t| tets.push(t));
            assert_eq!(tets.len(), 5);
            assert!((total_abs_volume(&p, &tets) - 1.0).abs() < 1e-12);
        }
    }

    #[test]
    fn structured_hex_places_corners_as_unit_hex() {
        let dims = [3, 4, 5];
        let (i, j, k) = (1, 2, 3);
        let nodes = structured_hex(dims, 7, i, j, k);
        for (c, n) in UNIT_HEX.iter().zip(nodes) {
            let at = [i + c[0] as usize, j + c[1] as usize, k + c[2] as usize];
            assert_eq!(n, 7 + at[0] + dims[0] * (at[1] + dims[1] * at[2]));
        }
    }

    #[test]
    fn structured_grid_tets_fill_the_grid_in_cell_order() {
        let cells = [3, 2, 2];
        let m = cells.map(|c| c + 1);
        let points = structured_points(m, |p| p.map(|x| x as f64));
        assert_eq!(points[1 + m[0] * (2 + m[1] * 2)], [1.0, 2.0, 2.0]);
        for (mode, per_cell) in [(SplitMode::Five, 5), (SplitMode::Six, 6)] {
            let tets = structured_grid_tets(cells, mode);
            assert_eq!(tets.len(), per_cell * 12, "{mode:?}");
            assert!((total_abs_volume(&points, &tets) - 12.0).abs() < 1e-12, "{mode:?}");
            // The first cell's tets come first, from its own corners.
            let first = structured_hex(m, 0, 0, 0, 0).map(|n| n as u32);
            assert!(tets[..per_cell].iter().flatten().all(|v| first.contains(v)), "{mode:?}");
        }
    }

    #[test]
    fn wedge_and_pyramid_fill_their_volume() {
        let p = [[0., 0., 0.], [1., 0., 0.], [0., 1., 0.], [0., 0., 1.], [1., 0., 1.], [0., 1., 1.]];
        for ids in [[0u32, 1, 2, 3, 4, 5], [5, 4, 3, 2, 1, 0], [2, 4, 0, 5, 1, 3]] {
            let pts = placed_at_ids(&p, &ids);
            let mut tets = vec![];
            split_wedge(&ids, &mut |t| tets.push(t));
            assert_eq!(tets.len(), 3);
            assert!((total_abs_volume(&pts, &tets) - 0.5).abs() < 1e-12);
        }
        let p = vec![[0., 0., 0.], [1., 0., 0.], [1., 1., 0.], [0., 1., 0.], [0.5, 0.5, 1.]];
        let mut tets = vec![];
        split_pyramid(&[0, 1, 2, 3, 4], &mut |t| tets.push(t));
        assert_eq!(tets.len(), 2);
        assert!((total_abs_volume(&p, &tets) - 1.0 / 3.0).abs() < 1e-12);
    }

    #[test]
    fn voxel_is_reordered_before_splitting() {
        // Voxel order: x fastest, then y, then z.
        let p = vec![
            [0., 0., 0.],
            [1., 0., 0.],
            [0., 1., 0.],
            [1., 1., 0.],
            [0., 0., 1.],
            [1., 0., 1.],
            [0., 1., 1.],
            [1., 1., 1.],
        ];
        let mut tets = vec![];
        split_cell(CellType::Voxel, &[0, 1, 2, 3, 4, 5, 6, 7], &mut |t| tets.push(t));
        assert_eq!(tets.len(), 6);
        assert!((total_abs_volume(&p, &tets) - 1.0).abs() < 1e-12);
    }

    /// Quadratic cells on the half-integer lattice: node positions in
    /// doubled integer coordinates, ids from a shuffled map shared by all
    /// cells (so cells sharing a face share its nodes' ids).
    struct Lattice {
        ids: std::collections::HashMap<[i32; 3], u32>,
        order: Vec<u32>,
    }

    impl Lattice {
        fn new(seed: u64) -> Lattice {
            let mut rng = crate::SplitMix64(seed);
            let mut order: Vec<u32> = (0..1000).collect();
            for i in (1..order.len()).rev() {
                order.swap(i, (rng.next_u64() % (i as u64 + 1)) as usize);
            }
            Lattice { ids: Default::default(), order }
        }

        fn id(&mut self, at: [i32; 3]) -> u32 {
            let next = self.order[self.ids.len()];
            *self.ids.entry(at).or_insert(next)
        }

        /// Positions of every id handed out, skewed by a fixed affine map
        /// of positive determinant.
        fn points(&self) -> Vec<[f64; 3]> {
            let mut p = vec![[f64::NAN; 3]; 1000];
            for (&[x, y, z], &id) in &self.ids {
                let (x, y, z) = (x as f64 / 2.0, y as f64 / 2.0, z as f64 / 2.0);
                p[id as usize] =
                    [2.0 * x + 0.3 * y - 0.2 * z, 0.1 * x + 1.5 * y + 0.4 * z, 0.2 * x - 0.1 * y + 1.2 * z];
            }
            p
        }

        /// A hexahedron's nodes from its lower corner (doubled coordinates,
        /// side 2): the 20 of VTK's quadratic order, or all 27.
        fn hex(&mut self, o: [i32; 3], nodes: usize) -> Vec<u32> {
            let c = UNIT_HEX.map(|u| [o[0] + 2 * u[0] as i32, o[1] + 2 * u[1] as i32, o[2] + 2 * u[2] as i32]);
            let mid = |a: usize, b: usize| [0, 1, 2].map(|k| (c[a][k] + c[b][k]) / 2);
            let mut at: Vec<[i32; 3]> = c.to_vec();
            for (a, b) in
                [(0, 1), (1, 2), (2, 3), (3, 0), (4, 5), (5, 6), (6, 7), (7, 4), (0, 4), (1, 5), (2, 6), (3, 7)]
            {
                at.push(mid(a, b));
            }
            if nodes == 27 {
                for d in [[0, 1, 1], [2, 1, 1], [1, 0, 1], [1, 2, 1], [1, 1, 0], [1, 1, 2], [1, 1, 1]] {
                    at.push([o[0] + d[0], o[1] + d[1], o[2] + d[2]]);
                }
            }
            at.into_iter().map(|a| self.id(a)).collect()
        }

        /// A cell's corners (doubled coordinates), its edges' midpoints,
        /// then the centres of the given quads.
        fn cell(&mut self, c: &[[i32; 3]], edges: &[(usize, usize)], quads: &[[usize; 4]]) -> Vec<u32> {
            let mut at = c.to_vec();
            for &(a, b) in edges {
                at.push([0, 1, 2].map(|k| (c[a][k] + c[b][k]) / 2));
            }
            for q in quads {
                at.push([0, 1, 2].map(|k| q.iter().map(|&v| c[v][k]).sum::<i32>() / 4));
            }
            at.into_iter().map(|a| self.id(a)).collect()
        }

        fn tet10(&mut self, c: [[i32; 3]; 4]) -> Vec<u32> {
            self.cell(&c, &[(0, 1), (1, 2), (2, 0), (0, 3), (1, 3), (2, 3)], &[])
        }

        /// A wedge's 15 nodes, or with `centres` its 18.
        fn wedge(&mut self, c: [[i32; 3]; 6], centres: bool) -> Vec<u32> {
            let quads: &[[usize; 4]] = if centres { &[[0, 1, 4, 3], [1, 2, 5, 4], [2, 0, 3, 5]] } else { &[] };
            self.cell(&c, &[(0, 1), (1, 2), (2, 0), (3, 4), (4, 5), (5, 3), (0, 3), (1, 4), (2, 5)], quads)
        }

        /// A pyramid's 13 nodes, or with `centre` its 14.
        fn pyramid(&mut self, c: [[i32; 3]; 5], centre: bool) -> Vec<u32> {
            let quads: &[[usize; 4]] = if centre { &[[0, 1, 2, 3]] } else { &[] };
            self.cell(&c, &[(0, 1), (1, 2), (2, 3), (3, 0), (0, 4), (1, 4), (2, 4), (3, 4)], quads)
        }
    }

    fn split_all(cells: &[(CellType, Vec<u32>)]) -> Vec<[u32; 4]> {
        let mut tets = vec![];
        for (ty, nodes) in cells {
            split_cell(*ty, nodes, &mut |t| {
                assert!(t.iter().all(|v| nodes.contains(v)), "{ty:?}: {t:?} is not on the cell's nodes");
                tets.push(t)
            });
        }
        tets
    }

    /// Each quadratic cell, under many labellings, splits at its nodes into
    /// positive tets filling it, every node used.
    #[test]
    fn quadratic_cells_split_at_their_nodes_into_positive_tets_filling_them() {
        let det = 2.0 * (1.5 * 1.2 + 0.04) - 0.3 * (0.12 - 0.08) - 0.2 * (-0.01 - 0.3);
        for seed in 0..40 {
            let mut l = Lattice::new(seed);
            let cases = [
                (CellType::QuadraticTetra, l.tet10([[0, 0, 0], [2, 0, 0], [0, 2, 0], [0, 0, 2]]), 8..=8, det / 6.0),
                (CellType::QuadraticHexahedron, l.hex([4, 0, 0], 20), 22..=22, det),
                (CellType::TriquadraticHexahedron, l.hex([8, 0, 0], 27), 48..=48, det),
                (
                    CellType::QuadraticWedge,
                    l.wedge([[12, 0, 0], [14, 0, 0], [12, 2, 0], [12, 0, 2], [14, 0, 2], [12, 2, 2]], false),
                    14..=15,
                    det / 2.0,
                ),
                (
                    CellType::QuadraticPyramid,
                    l.pyramid([[16, 0, 0], [18, 0, 0], [18, 2, 0], [16, 2, 0], [16, 0, 2]], false),
                    13..=13,
                    det / 3.0,
                ),
                (
                    CellType::BiquadraticWedge,
                    l.wedge([[20, 0, 0], [22, 0, 0], [20, 2, 0], [20, 0, 2], [22, 0, 2], [20, 2, 2]], true),
                    24..=24,
                    det / 2.0,
                ),
                (
                    CellType::QuadraticPyramidWithBaseCentre,
                    l.pyramid([[24, 0, 0], [26, 0, 0], [26, 2, 0], [24, 2, 0], [24, 0, 2]], true),
                    16..=16,
                    det / 3.0,
                ),
            ];
            let p = l.points();
            for (ty, nodes, count, volume) in cases {
                assert_eq!(nodes.len(), ty.num_nodes());
                let tets = split_all(&[(ty, nodes.clone())]);
                assert!(count.contains(&tets.len()), "{ty:?}: {} tets", tets.len());
                assert!((total_abs_volume(&p, &tets) - volume).abs() < 1e-12, "{ty:?} seed {seed}");
                assert!(nodes.iter().all(|n| tets.iter().any(|t| t.contains(n))), "{ty:?}: a node unused");
            }
        }
    }

    fn assert_all_positive(p: &[[f64; 3]], tets: &[[u32; 4]], what: &str) {
        for t in tets {
            let [a, b, c, d] = t.map(|v| &p[v as usize]);
            assert!(crate::predicates::signed_tet_volume(a, b, c, d) > 0.0, "{what}: {t:?}");
        }
    }

    /// VTK's 12-node wedge, 24-node hexahedron and 19-node pyramid split at
    /// their nodes into positive tets filling them, under many labellings;
    /// stacked and side by side with 27-node hexahedra they conform.
    #[test]
    fn partly_quadratic_cells_split_filling_and_conforming() {
        const HEX_EDGES: [(usize, usize); 12] =
            [(0, 1), (1, 2), (2, 3), (3, 0), (4, 5), (5, 6), (6, 7), (7, 4), (0, 4), (1, 5), (2, 6), (3, 7)];
        const SIDES: [[usize; 4]; 4] = [[0, 3, 7, 4], [1, 2, 6, 5], [0, 1, 5, 4], [3, 2, 6, 7]];
        let det = 2.0 * (1.5 * 1.2 + 0.04) - 0.3 * (0.12 - 0.08) - 0.2 * (-0.01 - 0.3);
        let corners =
            |o: [i32; 3]| UNIT_HEX.map(|u| [o[0] + 2 * u[0] as i32, o[1] + 2 * u[1] as i32, o[2] + 2 * u[2] as i32]);
        for seed in 0..30 {
            let mut l = Lattice::new(500 + seed);
            let wedge = [[0, 0, 0], [2, 0, 0], [0, 2, 0], [0, 0, 2], [2, 0, 2], [0, 2, 2]];
            let w12 = l.cell(&wedge, &[(0, 1), (1, 2), (2, 0), (3, 4), (4, 5), (5, 3)], &[]);
            let h24 = l.cell(&corners([4, 0, 0]), &HEX_EDGES, &SIDES);
            let p = l.points();
            for (ty, nodes, count, volume) in [
                (CellType::QuadraticLinearWedge, w12, 12, det / 2.0),
                (CellType::BiquadraticQuadraticHexahedron, h24, 36, det),
            ] {
                assert_eq!(nodes.len(), ty.num_nodes());
                let tets = split_all(&[(ty, nodes.clone())]);
                assert_eq!(tets.len(), count, "{ty:?}");
                assert!((total_abs_volume(&p, &tets) - volume).abs() < 1e-12, "{ty:?} seed {seed}");
                assert_all_positive(&p, &tets, &format!("{ty:?} seed {seed}"));
            }
            // Two 24-node hexahedra stacked (an 8-node face between them),
            // a 27-node one beside the lower (a 9-node face): outer faces
            // 2 · 6 (bottom and top) + 7 · 8 (24-node sides) + 5 · 8 (the 27-node
            // one's).
            let cells = vec![
                (CellType::BiquadraticQuadraticHexahedron, l.cell(&corners([10, 0, 0]), &HEX_EDGES, &SIDES)),
                (CellType::BiquadraticQuadraticHexahedron, l.cell(&corners([10, 0, 2]), &HEX_EDGES, &SIDES)),
                (CellType::TriquadraticHexahedron, l.hex([12, 0, 0], 27)),
            ];
            // Two 12-node wedges side by side (a 6-node quad between them).
            let wedges = vec![
                (
                    CellType::QuadraticLinearWedge,
                    l.cell(
                        &[[20, 0, 0], [22, 0, 0], [20, 2, 0], [20, 0, 2], [22, 0, 2], [20, 2, 2]],
                        &[(0, 1), (1, 2), (2, 0), (3, 4), (4, 5), (5, 3)],
                        &[],
                    ),
                ),
                (
                    CellType::QuadraticLinearWedge,
                    l.cell(
                        &[[22, 0, 0], [22, 2, 0], [20, 2, 0], [22, 0, 2], [22, 2, 2], [20, 2, 2]],
                        &[(0, 1), (1, 2), (2, 0), (3, 4), (4, 5), (5, 3)],
                        &[],
                    ),
                ),
            ];
            let p = l.points();
            for (cells, boundary) in [(cells, 2 * 6 + 7 * 8 + 5 * 8), (wedges, 4 * 4 + 4 * 4)] {
                let tets = split_all(&cells);
                let adjacency = crate::build_adjacency(&p, &tets).expect("conforming");
                assert_eq!(adjacency.boundary_faces.len(), boundary, "{:?} seed {seed}", cells[0].0);
            }
        }
        // The 19-node pyramid at VTK's parameter points (base 1 × 1, height
        // 1), skewed, relabelled: 32 positive tets of volume 1/3.
        let at = crate::lagrange::TRIQUADRATIC_PYRAMID_AT;
        let skew = |q: [i32; 3]| {
            let [x, y, z] = q.map(|c| c as f64 / 24.0);
            [2.0 * x + 0.3 * y - 0.2 * z, 0.1 * x + 1.5 * y + 0.4 * z, 0.2 * x - 0.1 * y + 1.2 * z]
        };
        for seed in 0..30u64 {
            let mut ids: Vec<u32> = (0..19).collect();
            let mut rng = crate::SplitMix64(seed);
            for i in (1..19).rev() {
                ids.swap(i, (rng.next_u64() % (i as u64 + 1)) as usize);
            }
            let mut p = vec![[0.0; 3]; 19];
            for (k, &id) in ids.iter().enumerate() {
                p[id as usize] = skew(at[k]);
            }
            let tets = split_all(&[(CellType::TriquadraticPyramid, ids.clone())]);
            assert_eq!(tets.len(), 32);
            assert!((total_abs_volume(&p, &tets) - det / 3.0).abs() < 1e-12, "seed {seed}");
            assert_all_positive(&p, &tets, &format!("seed {seed}"));
        }
    }

    /// The straight-sided places of every quadratic cell's nodes are where
    /// VTK's orders put them; two nodes swapped are out of place.
    #[test]
    fn quadratic_nodes_are_in_their_straight_sided_places() {
        let mut l = Lattice::new(7);
        let cells = [
            (CellType::QuadraticTetra, l.tet10([[0, 0, 0], [2, 0, 0], [0, 2, 0], [0, 0, 2]])),
            (CellType::QuadraticHexahedron, l.hex([4, 0, 0], 20)),
            (CellType::TriquadraticHexahedron, l.hex([8, 0, 0], 27)),
            (
                CellType::QuadraticWedge,
                l.wedge([[12, 0, 0], [14, 0, 0], [12, 2, 0], [12, 0, 2], [14, 0, 2], [12, 2, 2]], false),
            ),
            (
                CellType::BiquadraticWedge,
                l.wedge([[20, 0, 0], [22, 0, 0], [20, 2, 0], [20, 0, 2], [22, 0, 2], [20, 2, 2]], true),
            ),
            (
                CellType::QuadraticPyramid,
                l.pyramid([[16, 0, 0], [18, 0, 0], [18, 2, 0], [16, 2, 0], [16, 0, 2]], false),
            ),
            (
                CellType::QuadraticPyramidWithBaseCentre,
                l.pyramid([[24, 0, 0], [26, 0, 0], [26, 2, 0], [24, 2, 0], [24, 0, 2]], true),
            ),
        ];
        let p = l.points();
        for (ty, nodes) in cells {
            assert_eq!(ty.straight_sided_parents().len() + ty.linear().num_nodes(), ty.num_nodes(), "{ty:?}");
            assert!(ty.higher_order_nodes_in_place(&nodes, &p), "{ty:?}");
            let corners = ty.linear().num_nodes();
            for a in corners..nodes.len() {
                for b in a + 1..nodes.len() {
                    let mut swapped = nodes.clone();
                    swapped.swap(a, b);
                    assert!(!ty.higher_order_nodes_in_place(&swapped, &p), "{ty:?}: nodes {a} and {b} swapped");
                }
            }
        }
    }

    /// Neighbouring quadratic cells cut their shared faces alike: the
    /// adjacency finds every interior face matched, and only the outer
    /// surface's triangles on the boundary.
    #[test]
    fn quadratic_cells_conform_across_shared_faces() {
        for seed in 0..20 {
            let mut l = Lattice::new(100 + seed);
            // Two 20-node hexahedra along x, two along y; two 27-node ones
            // along z; two 10-node tets on one face.
            let hex20: Vec<_> = [[0, 0, 0], [2, 0, 0], [0, 2, 0]]
                .into_iter()
                .map(|o| (CellType::QuadraticHexahedron, l.hex(o, 20)))
                .collect();
            let hex27: Vec<_> = [[10, 0, 0], [10, 0, 2]]
                .into_iter()
                .map(|o| (CellType::TriquadraticHexahedron, l.hex(o, 27)))
                .collect();
            let tet10 = vec![
                (CellType::QuadraticTetra, l.tet10([[20, 0, 0], [22, 0, 0], [20, 2, 0], [20, 0, 2]])),
                (CellType::QuadraticTetra, l.tet10([[22, 0, 0], [20, 2, 0], [20, 0, 2], [22, 2, 2]])),
            ];
            // A 15-node wedge on a 20-node hexahedron's x = 1 face (through
            // the wedge's quad 2-0-3-5), a 13-node pyramid on its top.
            let mixed = vec![
                (CellType::QuadraticHexahedron, l.hex([30, 0, 0], 20)),
                (
                    CellType::QuadraticWedge,
                    l.wedge([[32, 0, 0], [34, 0, 0], [32, 2, 0], [32, 0, 2], [34, 0, 2], [32, 2, 2]], false),
                ),
                (
                    CellType::QuadraticPyramid,
                    l.pyramid([[30, 0, 2], [32, 0, 2], [32, 2, 2], [30, 2, 2], [30, 0, 4]], false),
                ),
            ];
            // The same with an 18-node wedge and a 14-node pyramid on a
            // 27-node hexahedron.
            let mixed27 = vec![
                (CellType::TriquadraticHexahedron, l.hex([40, 0, 0], 27)),
                (
                    CellType::BiquadraticWedge,
                    l.wedge([[42, 0, 0], [44, 0, 0], [42, 2, 0], [42, 0, 2], [44, 0, 2], [42, 2, 2]], true),
                ),
                (
                    CellType::QuadraticPyramidWithBaseCentre,
                    l.pyramid([[40, 0, 2], [42, 0, 2], [42, 2, 2], [40, 2, 2], [40, 0, 4]], true),
                ),
            ];
            let p = l.points();
            // (cells, outer faces × triangles a face: 6 a quadratic quad,
            // 8 a biquadratic one, 4 a quadratic triangle)
            for (cells, boundary) in [
                (hex20, 14 * 6),
                (hex27, 10 * 8),
                (tet10, 6 * 4),
                (mixed, 4 * 6 + (2 * 4 + 2 * 6) + 4 * 4),
                (mixed27, 4 * 8 + (2 * 4 + 2 * 8) + 4 * 4),
            ] {
                let tets = split_all(&cells);
                let adjacency = crate::build_adjacency(&p, &tets).expect("conforming");
                assert_eq!(adjacency.boundary_faces.len(), boundary, "{:?} seed {seed}", cells[0].0);
            }
        }
    }
}
