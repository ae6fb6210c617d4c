//! VTK's arbitrary-order Lagrange volume cells — the tetrahedron (VTK id
//! 71), hexahedron (72) and wedge (73) — and the two centred quadratic
//! variants VTK reads as Lagrange cells (the 15-node tetrahedron and the
//! 21-node wedge): where their nodes lie on the cell's parameter lattice,
//! and their split into linear tets at every node.
//!
//! Node orders are VTK's (the `vtkHigherOrder*` cells): corners as the
//! linear cell; then the inner nodes of each edge, from its first corner
//! to its second; then each face's inner nodes; then the body's. Read off
//! VTK 9.7's own `GetParametricCoords` for orders 1–8 (tetrahedra), 1–7
//! (wedges) and hexahedra of equal and unequal orders; the tests compare
//! against that dump (`tests/data/vtk_lagrange_nodes.txt`).
//!
//! - Hexahedron of orders (p, q, r): edges 0-1, 1-2, 3-2, 0-3 of the bottom,
//!   the same four of the top, then 0-4, 1-5, 2-6, 3-7 (each counted along
//!   its parameter axis); faces x = 0, x = 1, y = 0, y = 1, z = 0, z = 1,
//!   each with its lower parameter axis fastest; the body x fastest, then y,
//!   then z.
//! - Tetrahedron of order n: edges 0-1, 1-2, 2-0, 0-3, 1-3, 2-3; faces
//!   (0, 1, 3), (1, 2, 3), (2, 0, 3), (0, 2, 1), each face's inner nodes a
//!   triangle of order n − 3 whose corners lie next to the face's corners
//!   taken in the orders (0, 1, 3), (2, 3, 1), (0, 3, 2), (0, 2, 1),
//!   numbered the same way recursively; the body a tetrahedron of order
//!   n − 4, recursively.
//! - Wedge of orders (n, n, m): edges 0-1, 1-2, 2-0, then 3-4, 4-5, 5-3,
//!   then 0-3, 1-4, 2-5; the bottom and top triangles' inner nodes row by
//!   row (x fastest); the quads 0-1-4-3, 1-2-5-4, 2-0-3-5, each along its
//!   triangle edge fastest, then up; the body a triangle's inner nodes row
//!   by row at each level, level slowest.
//!
//! Gmsh's complete tetrahedra, hexahedra, prisms and pyramids of any order
//! number their nodes by corners, edges, faces and body, recursively
//! (`gmsh_*_lattice`, checked against Gmsh 4.15's reference nodes); a
//! pyramid of order n ([`CellType::LagrangePyramid`], which VTK lacks)
//! keeps Gmsh's order.
//!
//! The split: a hexahedron into its p·q·r sub-hexahedra and a wedge into
//! n²·m sub-wedges (each cut by [`crate::split`]'s min-id rule, so their
//! quads conform with any neighbour's), a tetrahedron into n³'s worth of
//! corner tets, octahedra and inverted tets (the octahedra cut along their
//! diagonal through the smallest id; all their faces are lattice triangles,
//! so the choice stays inside the cell). Every sub-tet is oriented by its
//! integer parameter-lattice determinant, so a cell in VTK's orientation
//! gives positive tets. A pyramid of order n splits layer by layer into
//! upright pyramids on the cells of each layer, inverted ones under the
//! cells of the layers above the base, and a tet on every edge two cells
//! of a layer share (its base is cut as a hexahedron face is, its slanted
//! faces into the triangle lattice).

use crate::source::CellType;
use crate::split::{split_hexahedron, split_pyramid, split_wedge, UNIT_HEX};
use std::cell::RefCell;
use std::collections::HashMap;
use std::rc::Rc;

/// Highest order tetkit reads along any axis of a Lagrange cell (a
/// hexahedron of order 32 has 35,937 nodes).
pub const MAX_LAGRANGE_ORDER: u8 = 32;

/// Order n of a Lagrange tetrahedron with `count` nodes, (n + 1)(n + 2)(n +
/// 3)/6 = count.
pub fn lagrange_tetra_order(count: usize) -> Option<u8> {
    (1..=MAX_LAGRANGE_ORDER).find(|&n| {
        let n = n as usize;
        (n + 1) * (n + 2) * (n + 3) / 6 == count
    })
}

/// Order n of a Lagrange hexahedron of equal orders with `count` nodes,
/// (n + 1)³ = count.
pub fn lagrange_hexahedron_order(count: usize) -> Option<u8> {
    (1..=MAX_LAGRANGE_ORDER).find(|&n| (n as usize + 1).pow(3) == count)
}

/// Order n of a Lagrange wedge of equal orders with `count` nodes, (n +
/// 1)²(n + 2)/2 = count.
pub fn lagrange_wedge_order(count: usize) -> Option<u8> {
    (1..=MAX_LAGRANGE_ORDER).find(|&n| {
        let n = n as usize;
        (n + 1) * (n + 1) * (n + 2) / 2 == count
    })
}

/// The cell a reader keeps for a VTK Lagrange volume (ids 71, 72, 73) of
/// `count` nodes, or a Bézier one (78, 79, 80: the Lagrange cell of its
/// orders, which it becomes once [`crate::bezier::BezierEvaluator`] has
/// evaluated it at its lattice; its non-corner control points do not lie on
/// the cell, so a reader must do that before the cell is cut). `degrees` is the cell's
/// row of the file's `HigherOrderDegrees` array if it has one (VTK's
/// orders along each parameter axis); without it the order follows from
/// the node count, as in VTK. Returns `None` for other ids; `Some(Err)`
/// says why the count or degrees do not fit.
pub fn cell_type_of_vtk_higher_order(
    id: u32,
    count: usize,
    degrees: Option<[i64; 3]>,
) -> Option<Result<CellType, String>> {
    let linear = match id {
        71 | 78 => CellType::Tetra,
        72 | 79 => CellType::Hexahedron,
        73 | 80 => CellType::Wedge,
        _ => return None,
    };
    let orders = match degrees {
        Some(d) => match d.map(|o| u8::try_from(o).ok().filter(|o| (1..=MAX_LAGRANGE_ORDER).contains(o))) {
            [Some(a), Some(b), Some(c)] => Some([a, b, c]),
            _ => {
                return Some(Err(format!(
                    "HigherOrderDegrees {d:?} outside 1..={MAX_LAGRANGE_ORDER} for a cell of VTK type {id}"
                )))
            }
        },
        None => None,
    };
    let found = match (linear, orders) {
        (CellType::Tetra, _) if count == 15 && id < 78 => Some(CellType::QuadraticTetraWithCentres),
        (CellType::Wedge, _) if count == 21 && id < 78 => Some(CellType::QuadraticWedgeWithCentres),
        (CellType::Tetra, _) => lagrange_tetra_order(count).map(CellType::LagrangeTetra),
        (CellType::Hexahedron, Some(o)) => Some(CellType::LagrangeHexahedron(o)),
        (CellType::Hexahedron, None) => lagrange_hexahedron_order(count).map(|n| CellType::LagrangeHexahedron([n; 3])),
        (CellType::Wedge, Some([a, b, c])) if a == b => Some(CellType::LagrangeWedge(a, c)),
        (CellType::Wedge, Some(d)) => {
            return Some(Err(format!("Lagrange wedge with unequal triangle orders {d:?} (VTK requires equal)")))
        }
        (CellType::Wedge, None) => lagrange_wedge_order(count).map(|n| CellType::LagrangeWedge(n, n)),
        _ => unreachable!("linear is one of three types"),
    };
    Some(match found {
        Some(t) if t.num_nodes() == count => Ok(t.simplest()),
        Some(t) => Err(format!("{count} nodes, but its HigherOrderDegrees make it a {t:?} of {}", t.num_nodes())),
        None => {
            let kind = if id >= 78 { "Bézier" } else { "Lagrange" };
            let shape = match linear {
                CellType::Tetra => "tetrahedron: (n+1)(n+2)(n+3)/6",
                CellType::Hexahedron => "hexahedron: (n+1)³",
                _ => "wedge: (n+1)²(n+2)/2",
            };
            Err(format!("{count} nodes fit no order n of a {kind} {shape} nodes, n = 1..={MAX_LAGRANGE_ORDER}"))
        }
    })
}

impl CellType {
    /// An order-1 Lagrange cell as its linear cell, else itself.
    fn simplest(self) -> CellType {
        match self {
            CellType::LagrangeTetra(1) | CellType::LagrangeHexahedron([1, 1, 1]) | CellType::LagrangeWedge(1, 1) => {
                self.linear()
            }
            t => t,
        }
    }
}

/// Node index of lattice point (i, j, k) of a Lagrange hexahedron of
/// orders `o` (VTK's order, the module doc).
pub fn lagrange_hexahedron_node([i, j, k]: [usize; 3], o: [usize; 3]) -> usize {
    let on = |v: usize, n: usize| v == 0 || v == n;
    let (ib, jb, kb) = (on(i, o[0]), on(j, o[1]), on(k, o[2]));
    // Corner slot of (i, j) in the bottom or top quad: 0, 1, 2, 3 counter-clockwise.
    let quad_corner = |i: usize, j: usize| match (i > 0, j > 0) {
        (false, false) => 0,
        (true, false) => 1,
        (true, true) => 2,
        (false, true) => 3,
    };
    let (ei, ej, ek) = (o[0] - 1, o[1] - 1, o[2] - 1);
    match (ib as u8) + (jb as u8) + (kb as u8) {
        3 => quad_corner(i, j) + 4 * (k > 0) as usize,
        2 => {
            let top = if k > 0 { 2 * (ei + ej) } else { 0 };
            if !ib {
                8 + (i - 1) + if j > 0 { ei + ej } else { 0 } + top
            } else if !jb {
                8 + (j - 1) + if i > 0 { ei } else { 2 * ei + ej } + top
            } else {
                8 + 4 * (ei + ej) + (k - 1) + ek * quad_corner(i, j)
            }
        }
        1 => {
            let faces = 8 + 4 * (ei + ej + ek);
            if ib {
                faces + (j - 1) + ej * (k - 1) + if i > 0 { ej * ek } else { 0 }
            } else if jb {
                faces + 2 * ej * ek + (i - 1) + ei * (k - 1) + if j > 0 { ek * ei } else { 0 }
            } else {
                faces + 2 * (ej * ek + ek * ei) + (i - 1) + ei * (j - 1) + if k > 0 { ei * ej } else { 0 }
            }
        }
        _ => 8 + 4 * (ei + ej + ek) + 2 * (ej * ek + ek * ei + ei * ej) + (i - 1) + ei * ((j - 1) + ej * (k - 1)),
    }
}

type Lattice = [i32; 3];

fn add(a: Lattice, b: Lattice) -> Lattice {
    [a[0] + b[0], a[1] + b[1], a[2] + b[2]]
}

fn sub(a: Lattice, b: Lattice) -> Lattice {
    [a[0] - b[0], a[1] - b[1], a[2] - b[2]]
}

/// The point a `t`/`n` of the way from `a` to `b` (exact on the lattice).
fn along(a: Lattice, b: Lattice, t: i32, n: i32) -> Lattice {
    let d = sub(b, a);
    [a[0] + d[0] * t / n, a[1] + d[1] * t / n, a[2] + d[2] * t / n]
}

/// One lattice step in from corner `a` of an order-`n` simplex face or
/// body towards all its other corners (the next inner simplex's corner).
fn step_in(a: Lattice, others: &[Lattice], n: i32) -> Lattice {
    others.iter().fold(a, |p, &o| add(p, along([0; 3], sub(o, a), 1, n)))
}

/// Nodes of an order-`p` triangle with corners `v` in VTK's recursive
/// order (corners, edges 0-1, 1-2, 2-0, then the inner triangle).
fn triangle_nodes(p: i32, v: [Lattice; 3], out: &mut Vec<Lattice>) {
    if p < 0 {
        return;
    }
    if p == 0 {
        out.push(v[0]);
        return;
    }
    out.extend(v);
    for (a, b) in [(0, 1), (1, 2), (2, 0)] {
        out.extend((1..p).map(|t| along(v[a], v[b], t, p)));
    }
    if p >= 3 {
        let inner = [0, 1, 2].map(|a| step_in(v[a], &[v[(a + 1) % 3], v[(a + 2) % 3]], p));
        triangle_nodes(p - 3, inner, out);
    }
}

/// A tetrahedron's edges and faces in the order a format numbers their
/// inner nodes (each edge from its first corner, each face's inner
/// triangle with its corners next to the face's in that order).
struct TetraOrder {
    edges: [(usize, usize); 6],
    faces: [[usize; 3]; 4],
}

const VTK_TETRA: TetraOrder = TetraOrder {
    edges: [(0, 1), (1, 2), (2, 0), (0, 3), (1, 3), (2, 3)],
    faces: [[0, 1, 3], [2, 3, 1], [0, 3, 2], [0, 2, 1]],
};

/// Gmsh's (its reference manual, "Node ordering"; checked against Gmsh
/// 4.15's `getElementProperties` for orders 1–10 in tests).
const GMSH_TETRA: TetraOrder = TetraOrder {
    edges: [(0, 1), (1, 2), (2, 0), (3, 0), (3, 2), (3, 1)],
    faces: [[0, 2, 1], [0, 1, 3], [0, 3, 2], [3, 1, 2]],
};

/// Nodes of an order-`n` tetrahedron with corners `v`: corners, edges,
/// faces, then the inner tetrahedron of order n − 4, recursively.
fn tetra_nodes(order: &TetraOrder, n: i32, v: [Lattice; 4], out: &mut Vec<Lattice>) {
    if n < 0 {
        return;
    }
    if n == 0 {
        out.push(v[0]);
        return;
    }
    out.extend(v);
    for (a, b) in order.edges {
        out.extend((1..n).map(|t| along(v[a], v[b], t, n)));
    }
    if n >= 3 {
        for f in order.faces {
            let inner = [0, 1, 2].map(|a| step_in(v[f[a]], &[v[f[(a + 1) % 3]], v[f[(a + 2) % 3]]], n));
            triangle_nodes(n - 3, inner, out);
        }
    }
    if n >= 4 {
        let inner = [0, 1, 2, 3].map(|a| {
            let others: Vec<Lattice> = (0..4).filter(|&b| b != a).map(|b| v[b]).collect();
            step_in(v[a], &others, n)
        });
        tetra_nodes(order, n - 4, inner, out);
    }
}

/// Nodes of an order-`p` quadrilateral with corners `v` (cyclic):
/// corners, edges 0-1, 1-2, 2-3, 3-0, then the inner quadrilateral of order
/// p − 2, recursively (Gmsh's order).
fn quad_nodes(p: i32, v: [Lattice; 4], out: &mut Vec<Lattice>) {
    if p < 0 {
        return;
    }
    if p == 0 {
        out.push(v[0]);
        return;
    }
    out.extend(v);
    for a in 0..4 {
        out.extend((1..p).map(|t| along(v[a], v[(a + 1) % 4], t, p)));
    }
    if p >= 2 {
        let inner = [0, 1, 2, 3].map(|a| step_in(v[a], &[v[(a + 1) % 4], v[(a + 3) % 4]], p));
        quad_nodes(p - 2, inner, out);
    }
}

/// Nodes of an order-`n` hexahedron with corners `v` (VTK's corner order)
/// in Gmsh's order: corners; edges 0-1, 0-3, 0-4, 1-2, 1-5, 2-3, 2-6,
/// 3-7, 4-5, 4-7, 5-6, 6-7; faces 0-3-2-1, 0-1-5-4, 0-4-7-3, 1-2-6-5,
/// 2-3-7-6, 4-5-6-7 (inner quadrilaterals, recursively); then the inner
/// hexahedron of order n − 2, recursively.
fn gmsh_hexahedron_nodes(n: i32, v: [Lattice; 8], out: &mut Vec<Lattice>) {
    const EDGES: [(usize, usize); 12] =
        [(0, 1), (0, 3), (0, 4), (1, 2), (1, 5), (2, 3), (2, 6), (3, 7), (4, 5), (4, 7), (5, 6), (6, 7)];
    const FACES: [[usize; 4]; 6] = [[0, 3, 2, 1], [0, 1, 5, 4], [0, 4, 7, 3], [1, 2, 6, 5], [2, 3, 7, 6], [4, 5, 6, 7]];
    const NEIGHBOURS: [[usize; 3]; 8] =
        [[1, 3, 4], [0, 2, 5], [1, 3, 6], [0, 2, 7], [0, 5, 7], [1, 4, 6], [2, 5, 7], [3, 4, 6]];
    if n < 0 {
        return;
    }
    if n == 0 {
        out.push(v[0]);
        return;
    }
    out.extend(v);
    for (a, b) in EDGES {
        out.extend((1..n).map(|t| along(v[a], v[b], t, n)));
    }
    if n >= 2 {
        for f in FACES {
            let inner = [0, 1, 2, 3].map(|a| step_in(v[f[a]], &[v[f[(a + 1) % 4]], v[f[(a + 3) % 4]]], n));
            quad_nodes(n - 2, inner, out);
        }
        let inner = [0, 1, 2, 3, 4, 5, 6, 7].map(|a| step_in(v[a], &NEIGHBOURS[a].map(|b| v[b]), n));
        gmsh_hexahedron_nodes(n - 2, inner, out);
    }
}

/// Nodes of an order-`n` wedge in Gmsh's order (corners as VTK's): corners;
/// edges 0-1, 0-2, 0-3, 1-2, 1-4, 2-5, 3-4, 3-5, 4-5; the triangles 0-2-1 and
/// 3-4-5 (inner triangles, recursively), the quadrilaterals 0-1-4-3,
/// 0-3-5-2, 1-2-5-4 (inner quadrilaterals, recursively); then the body: each
/// node of the inner triangle (recursively) with its vertical line's nodes
/// as Gmsh orders a line's (its ends, then the rest upwards).
fn gmsh_wedge_nodes(n: i32, out: &mut Vec<Lattice>) {
    const EDGES: [(usize, usize); 9] = [(0, 1), (0, 2), (0, 3), (1, 2), (1, 4), (2, 5), (3, 4), (3, 5), (4, 5)];
    const QUADS: [[usize; 4]; 3] = [[0, 1, 4, 3], [0, 3, 5, 2], [1, 2, 5, 4]];
    let v: [Lattice; 6] = [[0, 0, 0], [n, 0, 0], [0, n, 0], [0, 0, n], [n, 0, n], [0, n, n]];
    out.extend(v);
    for (a, b) in EDGES {
        out.extend((1..n).map(|t| along(v[a], v[b], t, n)));
    }
    if n >= 3 {
        for f in [[0, 2, 1], [3, 4, 5]] {
            let inner = [0, 1, 2].map(|a| step_in(v[f[a]], &[v[f[(a + 1) % 3]], v[f[(a + 2) % 3]]], n));
            triangle_nodes(n - 3, inner, out);
        }
    }
    if n >= 2 {
        for f in QUADS {
            let inner = [0, 1, 2, 3].map(|a| step_in(v[f[a]], &[v[f[(a + 1) % 4]], v[f[(a + 3) % 4]]], n));
            quad_nodes(n - 2, inner, out);
        }
    }
    if n >= 3 {
        let mut inner = Vec::new();
        triangle_nodes(n - 3, [[1, 1, 0], [n - 2, 1, 0], [1, n - 2, 0]], &mut inner);
        let levels: Vec<i32> = [1, n - 1].into_iter().chain(2..n - 1).collect();
        for p in inner {
            out.extend(levels.iter().map(|&z| [p[0], p[1], z]));
        }
    }
}

/// Lattice points of Gmsh's complete wedge (prism) of order n (types 6,
/// 13, 90, 91, 106–110), in its node order.
pub fn gmsh_wedge_lattice(n: u8) -> Vec<[i32; 3]> {
    let mut out = Vec::new();
    gmsh_wedge_nodes(n as i32, &mut out);
    out
}

/// Nodes of an order-`n` pyramid in Gmsh's order, on the pyramid's sheared
/// lattice (point (i, j, k): layer k of (n − k + 1)² points; (i, j, k + 1)
/// lies over the centre of cell (i, j) of layer k): corners (base 0-1-2-3,
/// apex 4); edges 0-1, 0-3, 0-4, 1-2, 1-4, 2-3, 2-4, 3-4; the triangles
/// 0-1-4, 3-0-4, 1-2-4, 2-3-4 (inner triangles, recursively) and the base
/// 0-3-2-1 (inner quadrilateral, recursively); then the inner pyramid of
/// order n − 3 one layer up, recursively.
fn gmsh_pyramid_nodes(n: i32, v: [Lattice; 5], out: &mut Vec<Lattice>) {
    const EDGES: [(usize, usize); 8] = [(0, 1), (0, 3), (0, 4), (1, 2), (1, 4), (2, 3), (2, 4), (3, 4)];
    if n < 0 {
        return;
    }
    if n == 0 {
        out.push(v[0]);
        return;
    }
    out.extend(v);
    for (a, b) in EDGES {
        out.extend((1..n).map(|t| along(v[a], v[b], t, n)));
    }
    if n >= 3 {
        for f in [[0, 1, 4], [3, 0, 4], [1, 2, 4], [2, 3, 4]] {
            let inner = [0, 1, 2].map(|a| step_in(v[f[a]], &[v[f[(a + 1) % 3]], v[f[(a + 2) % 3]]], n));
            triangle_nodes(n - 3, inner, out);
        }
    }
    if n >= 2 {
        let f = [0, 3, 2, 1];
        let inner = [0, 1, 2, 3].map(|a| step_in(v[f[a]], &[v[f[(a + 1) % 4]], v[f[(a + 3) % 4]]], n));
        quad_nodes(n - 2, inner, out);
    }
    if n >= 3 {
        let inner = [
            add(v[0], [1, 1, 1]),
            add(v[1], [-2, 1, 1]),
            add(v[2], [-2, -2, 1]),
            add(v[3], [1, -2, 1]),
            add(v[4], [1, 1, -2]),
        ];
        gmsh_pyramid_nodes(n - 3, inner, out);
    }
}

/// Lattice points (on the sheared lattice of `gmsh_pyramid_nodes`: real
/// parameter point ((2i + k)/n − 1, (2j + k)/n − 1, k/n) of Gmsh's
/// pyramid) of Gmsh's complete pyramid of order n (types 7, 14, 118–124),
/// in its node order — [`CellType::LagrangePyramid`]'s.
pub fn gmsh_pyramid_lattice(n: u8) -> Vec<[i32; 3]> {
    let n = n as i32;
    let mut out = Vec::new();
    gmsh_pyramid_nodes(n, [[0, 0, 0], [n, 0, 0], [n, n, 0], [0, n, 0], [0, 0, n]], &mut out);
    out
}

/// Order n of a pyramid with `count` nodes, (n + 1)(n + 2)(2n + 3)/6 = count.
pub fn lagrange_pyramid_order(count: usize) -> Option<u8> {
    (1..=MAX_LAGRANGE_ORDER).find(|&n| {
        let n = n as usize;
        (n + 1) * (n + 2) * (2 * n + 3) / 6 == count
    })
}

fn tetra_corners(n: i32) -> [Lattice; 4] {
    [[0, 0, 0], [n, 0, 0], [0, n, 0], [0, 0, n]]
}

/// Lattice points of a Lagrange tetrahedron of order n, in node order.
pub fn lagrange_tetra_lattice(n: u8) -> Vec<[i32; 3]> {
    let mut out = Vec::new();
    tetra_nodes(&VTK_TETRA, n as i32, tetra_corners(n as i32), &mut out);
    out
}

/// Lattice points of Gmsh's complete tetrahedron of order n (types 4, 11,
/// 29, 30, 31, 71–75), in its node order.
pub fn gmsh_tetra_lattice(n: u8) -> Vec<[i32; 3]> {
    let mut out = Vec::new();
    tetra_nodes(&GMSH_TETRA, n as i32, tetra_corners(n as i32), &mut out);
    out
}

/// Lattice points of Gmsh's complete hexahedron of order n (types 5, 12,
/// 92–98), in its node order.
pub fn gmsh_hexahedron_lattice(n: u8) -> Vec<[i32; 3]> {
    let n = n as i32;
    let corners = UNIT_HEX.map(|c| c.map(|x| x as i32 * n));
    let mut out = Vec::new();
    gmsh_hexahedron_nodes(n, corners, &mut out);
    out
}

/// Lattice points of a Lagrange hexahedron of orders `o`, in node order.
pub fn lagrange_hexahedron_lattice(o: [u8; 3]) -> Vec<[i32; 3]> {
    let ou = o.map(usize::from);
    let mut at = vec![[0; 3]; ou.iter().map(|a| a + 1).product()];
    for k in 0..=ou[2] {
        for j in 0..=ou[1] {
            for i in 0..=ou[0] {
                at[lagrange_hexahedron_node([i, j, k], ou)] = [i as i32, j as i32, k as i32];
            }
        }
    }
    at
}

/// For each node of `to` (lattice points in some order), the index of the
/// same point in `from`: how to read a cell stored in `from`'s order in
/// `to`'s. `None` if the two are not the same points.
pub fn lattice_permutation(from: &[[i32; 3]], to: &[[i32; 3]]) -> Option<Vec<usize>> {
    let at: HashMap<[i32; 3], usize> = from.iter().enumerate().map(|(i, &p)| (p, i)).collect();
    if at.len() != from.len() || from.len() != to.len() {
        return None;
    }
    to.iter().map(|p| at.get(p).copied()).collect()
}

/// Lattice points of a Lagrange wedge of orders (n, n, m), in node order.
pub fn lagrange_wedge_lattice(n: u8, m: u8) -> Vec<[i32; 3]> {
    let (n, m) = (n as i32, m as i32);
    let tri = [[0, 0], [n, 0], [0, n]];
    let at = |xy: [i32; 2], z: i32| [xy[0], xy[1], z];
    let edge = |a: usize, b: usize, t: i32| {
        [tri[a][0] + (tri[b][0] - tri[a][0]) * t / n, tri[a][1] + (tri[b][1] - tri[a][1]) * t / n]
    };
    let inner: Vec<[i32; 2]> = (1..n).flat_map(|y| (1..n - y).map(move |x| [x, y])).collect();
    let mut out: Vec<Lattice> = Vec::new();
    for z in [0, m] {
        out.extend(tri.iter().map(|&c| at(c, z)));
    }
    for z in [0, m] {
        for (a, b) in [(0, 1), (1, 2), (2, 0)] {
            out.extend((1..n).map(|t| at(edge(a, b, t), z)));
        }
    }
    for c in tri {
        out.extend((1..m).map(|z| at(c, z)));
    }
    for z in [0, m] {
        out.extend(inner.iter().map(|&p| at(p, z)));
    }
    for (a, b) in [(0, 1), (1, 2), (2, 0)] {
        for z in 1..m {
            out.extend((1..n).map(|t| at(edge(a, b, t), z)));
        }
    }
    for z in 1..m {
        out.extend(inner.iter().map(|&p| at(p, z)));
    }
    out
}

/// Parameter points (times 12) of the 15-node tetrahedron:
/// corners, edge midpoints as the 10-node one, the centres of faces (0, 1,
/// 2), (0, 1, 3), (1, 2, 3), (0, 2, 3), the body centre.
pub const TETRA15_AT: [[i32; 3]; 15] = [
    [0, 0, 0],
    [12, 0, 0],
    [0, 12, 0],
    [0, 0, 12],
    [6, 0, 0],
    [6, 6, 0],
    [0, 6, 0],
    [0, 0, 6],
    [6, 0, 6],
    [0, 6, 6],
    [4, 4, 0],
    [4, 0, 4],
    [4, 4, 4],
    [0, 4, 4],
    [3, 3, 3],
];

/// Parameter points (times 6) of the 21-node wedge: the 15-node one's, the
/// bottom and top triangles' centres, the centres of quads 0-1-4-3,
/// 1-2-5-4, 2-0-3-5, the body centre.
pub const WEDGE21_AT: [[i32; 3]; 21] = [
    [0, 0, 0],
    [6, 0, 0],
    [0, 6, 0],
    [0, 0, 6],
    [6, 0, 6],
    [0, 6, 6],
    [3, 0, 0],
    [3, 3, 0],
    [0, 3, 0],
    [3, 0, 6],
    [3, 3, 6],
    [0, 3, 6],
    [0, 0, 3],
    [6, 0, 3],
    [0, 6, 3],
    [2, 2, 0],
    [2, 2, 6],
    [3, 0, 3],
    [3, 3, 3],
    [0, 3, 3],
    [2, 2, 3],
];

/// Parameter points (times 24; the base at height 0, the apex at 24) of
/// VTK's 19-node pyramid: corners, the 13-node one's edge midpoints, the
/// base's centre, the triangles' centres, the body centre (from VTK's own
/// parametric coordinates).
pub const TRIQUADRATIC_PYRAMID_AT: [[i32; 3]; 19] = [
    [0, 0, 0],
    [24, 0, 0],
    [24, 24, 0],
    [0, 24, 0],
    [12, 12, 24],
    [12, 0, 0],
    [24, 12, 0],
    [12, 24, 0],
    [0, 12, 0],
    [6, 6, 12],
    [18, 6, 12],
    [18, 18, 12],
    [6, 18, 12],
    [12, 12, 0],
    [12, 4, 8],
    [20, 12, 8],
    [12, 20, 8],
    [4, 12, 8],
    [12, 12, 6],
];

fn det(t: [Lattice; 4]) -> i64 {
    let [a, b, c] = [sub(t[1], t[0]), sub(t[2], t[0]), sub(t[3], t[0])].map(|v| v.map(i64::from));
    a[0] * (b[1] * c[2] - b[2] * c[1]) - a[1] * (b[0] * c[2] - b[2] * c[0]) + a[2] * (b[0] * c[1] - b[1] * c[0])
}

/// `local` (node slots) reordered so that their lattice tet is positive.
fn oriented(mut local: [u16; 4], at: impl Fn(u16) -> Lattice) -> [u16; 4] {
    if det(local.map(&at)) < 0 {
        local.swap(2, 3);
    }
    local
}

/// A cell's split in node slots, computed once per cell type and order.
#[derive(Debug, Default)]
struct LatticeSplit {
    /// Tets as they are (already positive).
    tets: Vec<[u16; 4]>,
    /// Octahedra: slots of p + x, p + y, p + z, p + x + y, p + x + z,
    /// p + y + z; cut by `octahedron_cuts`.
    octahedra: Vec<[u16; 6]>,
    /// [`octahedron_tets`], once.
    octahedron_cuts: [([usize; 2], [[usize; 4]; 4]); 3],
    /// Sub-hexahedra in VTK order, cut by the min-id rule.
    hexahedra: Vec<[u16; 8]>,
    /// Sub-wedges in VTK order, cut by the min-id rule.
    wedges: Vec<[u16; 6]>,
    /// Sub-pyramids in VTK order (base turning counter-clockwise seen from
    /// the apex), cut by the min-id rule.
    pyramids: Vec<[u16; 5]>,
    /// Rings of (corner, mid-edge, …) slots around a face centre, coned
    /// from the body centre: `(ring, face centre)`; the 15- and 21-node cells.
    fans: Vec<(Vec<u16>, u16)>,
    /// 3 × 3 face grids (rows of slots) of the 21-node wedge's quads, cut
    /// into four quads by the min-id rule and coned from the body centre.
    grids: Vec<[[u16; 3]; 3]>,
    /// The body centre of a fan or grid cell.
    centre: u16,
    /// The lattice point of each slot, to orient fans and grids.
    at: Vec<Lattice>,
}

/// Octahedron slot pairs on a diagonal, and for each diagonal its four
/// tets (slots into the octahedron), oriented for the octahedron of the
/// lattice at p = 0 (translation keeps orientation).
fn octahedron_tets() -> [([usize; 2], [[usize; 4]; 4]); 3] {
    const AT: [Lattice; 6] = [[1, 0, 0], [0, 1, 0], [0, 0, 1], [1, 1, 0], [1, 0, 1], [0, 1, 1]];
    const OPPOSITE: [usize; 6] = [5, 4, 3, 2, 1, 0];
    [0usize, 1, 2].map(|d0| {
        let d1 = OPPOSITE[d0];
        let rest: Vec<usize> = (0..6).filter(|&s| s != d0 && s != d1).collect();
        let a = rest[0];
        let b = *rest.iter().find(|&&s| s != a && s != OPPOSITE[a]).expect("a neighbour of a");
        let ring = [a, b, OPPOSITE[a], OPPOSITE[b]];
        let tets = [0, 1, 2, 3].map(|i| {
            let t = [d0, d1, ring[i], ring[(i + 1) % 4]];
            let o = oriented(t.map(|s| s as u16), |s| AT[s as usize]);
            o.map(|s| s as usize)
        });
        ([d0, d1], tets)
    })
}

fn build_split(cell_type: CellType) -> LatticeSplit {
    let mut s = LatticeSplit::default();
    match cell_type {
        CellType::LagrangeHexahedron(o) => {
            let o = o.map(usize::from);
            for c in 0..o[2] {
                for b in 0..o[1] {
                    for a in 0..o[0] {
                        s.hexahedra.push(UNIT_HEX.map(|u| {
                            let ijk = [a + u[0] as usize, b + u[1] as usize, c + u[2] as usize];
                            lagrange_hexahedron_node(ijk, o) as u16
                        }));
                    }
                }
            }
        }
        CellType::LagrangeWedge(n, m) => {
            let (n, m) = (n as i32, m as i32);
            let lattice = lagrange_wedge_lattice(n as u8, m as u8);
            let slot = slots_of(&lattice, [n, n, m]);
            let mut triangles = Vec::new();
            for y in 0..n {
                for x in 0..n - y {
                    triangles.push([[x, y], [x + 1, y], [x, y + 1]]);
                    if x + y <= n - 2 {
                        triangles.push([[x + 1, y], [x + 1, y + 1], [x, y + 1]]);
                    }
                }
            }
            for z in 0..m {
                for t in &triangles {
                    let w = [0, 1, 2, 3, 4, 5].map(|i| {
                        let p = t[i % 3];
                        slot([p[0], p[1], z + (i / 3) as i32])
                    });
                    s.wedges.push(w);
                }
            }
        }
        CellType::LagrangeTetra(n) => {
            let n = n as i32;
            let lattice = lagrange_tetra_lattice(n as u8);
            let slot = slots_of(&lattice, [n; 3]);
            let at = |s: u16| lattice[s as usize];
            for k in 0..n {
                for j in 0..n - k {
                    for i in 0..n - k - j {
                        let p = [i, j, k];
                        let corner = [p, add(p, [1, 0, 0]), add(p, [0, 1, 0]), add(p, [0, 0, 1])];
                        s.tets.push(oriented(corner.map(&slot), at));
                        if i + j + k <= n - 2 {
                            s.octahedron_cuts = octahedron_tets();
                            let oct = [[1, 0, 0], [0, 1, 0], [0, 0, 1], [1, 1, 0], [1, 0, 1], [0, 1, 1]];
                            s.octahedra.push(oct.map(|d| slot(add(p, d))));
                        }
                        if i + j + k <= n - 3 {
                            let inverted = [[1, 1, 0], [1, 0, 1], [0, 1, 1], [1, 1, 1]];
                            s.tets.push(oriented(inverted.map(|d| slot(add(p, d))), at));
                        }
                    }
                }
            }
        }
        CellType::LagrangePyramid(n) => {
            // Layer by layer: upright pyramids on every cell of layer k (apex
            // above its centre), inverted ones under every cell of layer
            // k ≥ 1 (apex below), and a tet on every edge of a layer that
            // two cells share, between their apexes. Its slanted faces come
            // out as the triangle lattice, its base as the square one.
            let n = n as i32;
            let lattice = gmsh_pyramid_lattice(n as u8);
            let slot = slots_of(&lattice, [n; 3]);
            let at = |s: u16| lattice[s as usize];
            for k in 0..n {
                let m = n - k;
                for j in 0..m {
                    for i in 0..m {
                        let base = [[i, j, k], [i + 1, j, k], [i + 1, j + 1, k], [i, j + 1, k]];
                        let [a, b, c, d] = base.map(&slot);
                        s.pyramids.push([a, b, c, d, slot([i, j, k + 1])]);
                        if k > 0 {
                            s.pyramids.push([a, d, c, b, slot([i + 1, j + 1, k - 1])]);
                        }
                    }
                }
                // Edges shared by two cells of layer k: along i between rows
                // j − 1 and j, along j between columns i − 1 and i.
                for j in 1..m {
                    for i in 0..m {
                        let t = [[i, j, k], [i + 1, j, k], [i, j - 1, k + 1], [i, j, k + 1]];
                        s.tets.push(oriented(t.map(&slot), at));
                        let t = [[j, i, k], [j, i + 1, k], [j - 1, i, k + 1], [j, i, k + 1]];
                        s.tets.push(oriented(t.map(&slot), at));
                    }
                }
            }
        }
        CellType::QuadraticTetraWithCentres => {
            s.at = TETRA15_AT.to_vec();
            s.centre = 14;
            // Each face: its corners and mid-edges in turn, and its centre.
            s.fans = vec![
                (vec![0, 4, 1, 5, 2, 6], 10),
                (vec![0, 4, 1, 8, 3, 7], 11),
                (vec![1, 5, 2, 9, 3, 8], 12),
                (vec![0, 6, 2, 9, 3, 7], 13),
            ];
        }
        CellType::QuadraticWedgeWithCentres => {
            s.at = WEDGE21_AT.to_vec();
            s.centre = 20;
            s.fans = vec![(vec![0, 6, 1, 7, 2, 8], 15), (vec![3, 9, 4, 10, 5, 11], 16)];
            s.grids = vec![
                [[0, 6, 1], [12, 17, 13], [3, 9, 4]],
                [[1, 7, 2], [13, 18, 14], [4, 10, 5]],
                [[2, 8, 0], [14, 19, 12], [5, 11, 3]],
            ];
        }
        CellType::QuadraticLinearWedge => {
            // Each triangle cut into four at its edges' midpoints, the
            // bottom's over the top's.
            s.wedges = vec![[0, 6, 8, 3, 9, 11], [6, 1, 7, 9, 4, 10], [8, 7, 2, 11, 10, 5], [6, 7, 8, 9, 10, 11]];
        }
        CellType::BiquadraticQuadraticHexahedron => {
            // Two layers, below and above the ring of the vertical edges'
            // midpoints (16-19) and side faces' centres (20-23): in each, a
            // wedge at every corner under the corner triangle of the
            // serendipity square, and a hexahedron under its square of
            // edge midpoints (the bottom and top faces cut as the 20-node
            // hexahedron's, the sides as the 27-node one's).
            s.wedges = vec![
                [0, 8, 11, 16, 22, 20],
                [1, 9, 8, 17, 21, 22],
                [2, 10, 9, 18, 23, 21],
                [3, 11, 10, 19, 20, 23],
                [16, 22, 20, 4, 12, 15],
                [17, 21, 22, 5, 13, 12],
                [18, 23, 21, 6, 14, 13],
                [19, 20, 23, 7, 15, 14],
            ];
            s.hexahedra = vec![[8, 9, 10, 11, 22, 21, 23, 20], [22, 21, 23, 20, 12, 13, 14, 15]];
        }
        CellType::TriquadraticPyramid => {
            // Each triangle as a fan around its centre (as the 15-node
            // tetrahedron's faces), the base as four quadrilaterals (as the
            // 27-node hexahedron's faces), all coned from the body centre.
            s.at = TRIQUADRATIC_PYRAMID_AT.to_vec();
            s.centre = 18;
            s.fans = vec![
                (vec![0, 5, 1, 10, 4, 9], 14),
                (vec![1, 6, 2, 11, 4, 10], 15),
                (vec![2, 7, 3, 12, 4, 11], 16),
                (vec![3, 8, 0, 9, 4, 12], 17),
            ];
            s.grids = vec![[[0, 5, 1], [8, 13, 6], [3, 7, 2]]];
        }
        t => unreachable!("{t:?} is no lattice cell"),
    }
    s
}

/// Slot of each lattice point of a cell whose lattice spans `dims`.
fn slots_of(lattice: &[Lattice], dims: [i32; 3]) -> impl Fn(Lattice) -> u16 {
    let size = dims.map(|d| d as usize + 1);
    let mut dense = vec![u16::MAX; size[0] * size[1] * size[2]];
    let index = move |p: Lattice| p[0] as usize + size[0] * (p[1] as usize + size[1] * p[2] as usize);
    for (slot, &p) in lattice.iter().enumerate() {
        dense[index(p)] = slot as u16;
    }
    move |p| dense[index(p)]
}

thread_local! {
    static SPLITS: RefCell<HashMap<CellType, Rc<LatticeSplit>>> = RefCell::new(HashMap::new());
}

/// Splits a Lagrange or centred quadratic cell (nodes in VTK's order,
/// global ids) at its nodes; see the module doc.
pub fn split_lagrange(cell_type: CellType, nodes: &[u32], out: &mut impl FnMut([u32; 4])) {
    let split = SPLITS.with(|m| {
        let mut m = m.borrow_mut();
        // A file may mix many orders; keep the cache small.
        if m.len() >= 64 && !m.contains_key(&cell_type) {
            m.clear();
        }
        m.entry(cell_type).or_insert_with(|| Rc::new(build_split(cell_type))).clone()
    });
    let id = |s: u16| nodes[s as usize];
    for t in &split.tets {
        out(t.map(id));
    }
    if !split.octahedra.is_empty() {
        for o in &split.octahedra {
            let (_, tets) = split
                .octahedron_cuts
                .iter()
                .min_by_key(|(d, _)| id(o[d[0]]).min(id(o[d[1]])))
                .expect("three diagonals");
            for t in tets {
                out(t.map(|s| id(o[s])));
            }
        }
    }
    for h in &split.hexahedra {
        split_hexahedron(&h.map(id), out);
    }
    for w in &split.wedges {
        split_wedge(&w.map(id), out);
    }
    for p in &split.pyramids {
        split_pyramid(&p.map(id), out);
    }
    let at = |s: u16| split.at[s as usize];
    for (ring, face_centre) in &split.fans {
        for i in 0..ring.len() {
            let t = oriented([split.centre, *face_centre, ring[i], ring[(i + 1) % ring.len()]], at);
            out(t.map(id));
        }
    }
    for g in &split.grids {
        for r in 0..2 {
            for c in 0..2 {
                let [a, b, c, d] = [g[r][c], g[r][c + 1], g[r + 1][c + 1], g[r + 1][c]];
                // Cut along the diagonal through the smallest global id, as
                // the neighbour across the face cuts it (`split_quad`).
                let tris =
                    if id(a).min(id(c)) < id(b).min(id(d)) { [[a, b, c], [a, c, d]] } else { [[a, b, d], [b, c, d]] };
                for [p, q, r] in tris {
                    out(oriented([split.centre, p, q, r], at).map(id));
                }
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn hexahedron_nodes_are_a_permutation_of_the_lattice() {
        for o in [[1, 1, 1], [2, 2, 2], [3, 3, 3], [2, 3, 1], [3, 1, 2], [1, 4, 2], [5, 2, 3]] {
            let n = (o[0] + 1) * (o[1] + 1) * (o[2] + 1);
            let mut seen = vec![false; n];
            for k in 0..=o[2] {
                for j in 0..=o[1] {
                    for i in 0..=o[0] {
                        let s = lagrange_hexahedron_node([i, j, k], o);
                        assert!(s < n && !seen[s], "{o:?} ({i},{j},{k}) -> {s}");
                        seen[s] = true;
                    }
                }
            }
        }
    }

    #[test]
    fn orders_follow_node_counts() {
        assert_eq!(lagrange_tetra_order(10), Some(2));
        assert_eq!(lagrange_tetra_order(20), Some(3));
        assert_eq!(lagrange_tetra_order(11), None);
        assert_eq!(lagrange_hexahedron_order(64), Some(3));
        assert_eq!(lagrange_wedge_order(18), Some(2));
        assert_eq!(lagrange_wedge_order(40), Some(3));
        let t = |id, n, d| cell_type_of_vtk_higher_order(id, n, d);
        assert_eq!(t(71, 4, None), Some(Ok(CellType::Tetra)));
        assert_eq!(t(71, 15, None), Some(Ok(CellType::QuadraticTetraWithCentres)));
        assert_eq!(t(72, 24, Some([2, 3, 1])), Some(Ok(CellType::LagrangeHexahedron([2, 3, 1]))));
        assert_eq!(t(79, 27, None), Some(Ok(CellType::LagrangeHexahedron([2, 2, 2]))));
        assert!(matches!(t(78, 8, None), Some(Err(_))));
        // A Bézier cell of 15 or 21 nodes fits no order (the centred
        // quadratic variants are Lagrange cells only).
        assert!(matches!(t(78, 15, None), Some(Err(_))));
        assert!(matches!(t(80, 21, None), Some(Err(_))));
        assert_eq!(t(78, 4, None), Some(Ok(CellType::Tetra)));
        assert!(matches!(t(72, 25, Some([2, 3, 1])), Some(Err(_))));
        assert!(matches!(t(73, 19, None), Some(Err(_))));
        assert!(matches!(t(72, 8, Some([0, 1, 1])), Some(Err(_))));
        assert_eq!(t(74, 5, None), None);
    }
}
