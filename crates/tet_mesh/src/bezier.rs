//! VTK's Bézier volume cells — the tetrahedron (VTK id 78), hexahedron (79)
//! and wedge (80), polynomial or rational — turned into the Lagrange cells
//! of the same orders by evaluating them at their parameter lattice.
//!
//! A Bézier cell's nodes are control points: only its corners lie on the
//! cell. VTK numbers them as it numbers a Lagrange cell's nodes (both are
//! `vtkHigherOrder*` cells), control point j standing at lattice point
//! ℓ_j, and interpolates positions and every point array with the
//! Bernstein basis of ℓ_j (rational: weighted by the `RationalWeights`
//! point array and divided by the weighted basis sum):
//!
//! - tetrahedron of order n: B_j(λ) = n!/(α₀!α₁!α₂!α₃!) Π λ_k^α_k with
//!   α = (n − a − b − c, a, b, c) for ℓ_j = (a, b, c) and λ = (1 − r − s − t,
//!   r, s, t);
//! - hexahedron of orders (p, q, r): B^p_a(r) B^q_b(s) B^r_c(t), B^n_i(x) =
//!   C(n, i) xⁱ(1 − x)ⁿ⁻ⁱ;
//! - wedge of orders (n, n, m): the triangle's n!/(α₀!α₁!α₂!) λ₀^α₀ r^a s^b
//!   times B^m_c(t).
//!
//! [`BezierEvaluator::to_lagrange`] evaluates a cell at each of its
//! lattice points ℓ_i / orders and moves each non-corner control point
//! there, with every point field's interpolated value; the cell is then the
//! Lagrange cell of its orders, cut at its nodes like any other. A control
//! point is evaluated once, by the first cell that names it, for every cell
//! that names it: the point on a shared face or edge depends only on that
//! face's or edge's control points, so neighbours conform. Corners stay (a
//! Bézier cell passes through them).
//!
//! The lattice-by-control-point basis matrix is built once per cell type
//! and order (up to [`MAX_CACHED_NODES`] nodes). Larger hexahedra are
//! evaluated by sum factorisation, axis by axis (O(N·(p + q + r)) for N
//! nodes); larger tetrahedra and wedges build their rows as they go (O(N²)
//! a cell: 43 M terms for a tetrahedron of order 32).

use crate::lagrange::{lagrange_hexahedron_lattice, lagrange_tetra_lattice, lagrange_wedge_lattice};
use crate::source::{CellType, Cells, Field};
use std::collections::HashMap;

/// Largest node count whose basis matrix is kept (1,024² values, 8 MiB).
pub const MAX_CACHED_NODES: usize = 1024;

/// What [`BezierEvaluator::to_lagrange`] did.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub struct BezierReport {
    /// Cells evaluated.
    pub cells: usize,
    /// Non-corner control points moved to the cells' values there.
    pub points_moved: usize,
    /// Points added where another cell names the control point as its own
    /// node (a file whose cells do not conform).
    pub points_added: usize,
}

impl BezierReport {
    /// The note a reader shows: what was evaluated and moved.
    pub fn note(&self, rational: bool) -> String {
        let added = match self.points_added {
            0 => String::new(),
            n => format!("; {n} points added where other cells name the control point as a node of theirs"),
        };
        format!(
            "evaluated {} {}Bézier cells at their lattice points ({} inner control points moved onto the cells{added}) and cut them there",
            self.cells,
            if rational { "rational " } else { "" },
            self.points_moved
        )
    }
}

/// Evaluates Bézier cells at their lattice points, keeping each cell
/// type's basis matrix.
#[derive(Debug, Default)]
pub struct BezierEvaluator {
    basis: HashMap<CellType, Basis>,
}

#[derive(Debug)]
struct Basis {
    /// Per node i: parameter point ℓ_i / orders.
    at: Vec<[f64; 3]>,
    /// Per control point j: its lattice point (the Bernstein exponents).
    lattice: Vec<[i32; 3]>,
    /// `matrix[i · n + j]` = B_j(ℓ_i / orders), when n ≤ MAX_CACHED_NODES.
    matrix: Option<Vec<f64>>,
}

/// C(n, k) as f64 (exact to n = 56; orders stop at 32).
fn binomial(n: i32, k: i32) -> f64 {
    if k < 0 || k > n {
        return 0.0;
    }
    let k = k.min(n - k);
    let mut c: u128 = 1;
    for i in 0..k as u128 {
        c = c * (n as u128 - i) / (i + 1);
    }
    c as f64
}

impl Basis {
    fn new(cell_type: CellType) -> Option<Basis> {
        let (lattice, orders) = match cell_type {
            CellType::LagrangeTetra(n) => (lagrange_tetra_lattice(n), [n; 3]),
            CellType::LagrangeHexahedron(o) => (lagrange_hexahedron_lattice(o), o),
            CellType::LagrangeWedge(n, m) => (lagrange_wedge_lattice(n, m), [n, n, m]),
            _ => return None,
        };
        let at = lattice.iter().map(|l| std::array::from_fn(|a| l[a] as f64 / orders[a] as f64)).collect();
        let mut basis = Basis { at, lattice, matrix: None };
        let n = basis.lattice.len();
        if n <= MAX_CACHED_NODES {
            let mut m = vec![0.0; n * n];
            for i in 0..n {
                basis.row_into(cell_type, i, &mut m[i * n..(i + 1) * n]);
            }
            basis.matrix = Some(m);
        }
        Some(basis)
    }

    /// B_j(ℓ_i / orders) for every control point j. Each barycentric or
    /// 1 − x factor comes from node i's integer lattice point, so it is 0
    /// exactly where it should be (and a basis function vanishes exactly on
    /// the faces it vanishes on; `powi` gives 0⁰ = 1).
    fn row_into(&self, cell_type: CellType, i: usize, out: &mut [f64]) {
        let [r, s, t] = self.at[i];
        let li = self.lattice[i];
        // (k_i − …)/n: the complementary coordinate of node i.
        let rest = |n: i32, used: i32| (n - used) as f64 / n as f64;
        for (j, &[a, b, c]) in self.lattice.iter().enumerate() {
            out[j] = match cell_type {
                CellType::LagrangeTetra(n) => {
                    let n = n as i32;
                    let a0 = n - a - b - c;
                    let l0 = rest(n, li[0] + li[1] + li[2]);
                    binomial(n, a0)
                        * binomial(n - a0, a)
                        * binomial(n - a0 - a, b)
                        * l0.powi(a0)
                        * r.powi(a)
                        * s.powi(b)
                        * t.powi(c)
                }
                CellType::LagrangeHexahedron([p, q, o]) => {
                    let line = |n: u8, k: i32, x: f64, ki: i32| {
                        let n = n as i32;
                        binomial(n, k) * x.powi(k) * rest(n, ki).powi(n - k)
                    };
                    line(p, a, r, li[0]) * line(q, b, s, li[1]) * line(o, c, t, li[2])
                }
                CellType::LagrangeWedge(n, m) => {
                    let (n, m) = (n as i32, m as i32);
                    let a0 = n - a - b;
                    let l0 = rest(n, li[0] + li[1]);
                    let tri = binomial(n, a0) * binomial(n - a0, a) * l0.powi(a0) * r.powi(a) * s.powi(b);
                    tri * binomial(m, c) * t.powi(c) * rest(m, li[2]).powi(m - c)
                }
                _ => unreachable!("Basis::new takes the three Lagrange volumes only"),
            };
        }
    }
}

/// Σ_j B_j(ℓ_i / o) v_j for every node i of a Bézier hexahedron of orders
/// `o` (`lattice[j]`: node j's lattice point), by sum factorisation: the
/// values on the (o₀+1)(o₁+1)(o₂+1) lattice, transformed along x, then y,
/// then z by the 1-D Bernstein matrix of that axis.
fn hexahedron_sums(o: [u8; 3], lattice: &[[i32; 3]], v: &[f64]) -> Vec<f64> {
    let o = o.map(|x| x as usize);
    let dims = o.map(|x| x + 1);
    let at = |l: [usize; 3]| l[0] + dims[0] * (l[1] + dims[1] * l[2]);
    let mut grid = vec![0.0; dims.iter().product()];
    for (j, l) in lattice.iter().enumerate() {
        grid[at(l.map(|x| x as usize))] = v[j];
    }
    for axis in 0..3 {
        let n = o[axis] as i32;
        // bern[k · dims + m]: B^n_m(k / n).
        let bern: Vec<f64> = (0..=n)
            .flat_map(|k| {
                (0..=n).map(move |m| {
                    let x = k as f64 / n as f64;
                    binomial(n, m) * x.powi(m) * ((n - k) as f64 / n as f64).powi(n - m)
                })
            })
            .collect();
        grid = (0..grid.len())
            .map(|idx| {
                let mut l = [idx % dims[0], idx / dims[0] % dims[1], idx / (dims[0] * dims[1])];
                let k = l[axis];
                let mut acc = 0.0;
                for m in 0..dims[axis] {
                    l[axis] = m;
                    acc += bern[k * dims[axis] + m] * grid[at(l)];
                }
                acc
            })
            .collect();
    }
    lattice.iter().map(|l| grid[at(l.map(|x| x as usize))]).collect()
}

impl BezierEvaluator {
    pub fn new() -> Self {
        Self::default()
    }

    /// Turns the Bézier cells `bezier` of `cells` (indices; each stored as
    /// the Lagrange cell type of its orders, nodes = control point ids into
    /// `points`) into Lagrange cells: each non-corner control point takes
    /// the cell's value there — its position and every field of
    /// `point_fields` (one tuple a point) interpolated the same way. A
    /// control point no other cell names (as a node, or as a Bézier cell's
    /// corner) is moved there in place; one that another cell does name
    /// keeps its place for that cell and the Bézier cells get a new point,
    /// appended. `weights`: the `RationalWeights` point array (one per
    /// point), else the cells are polynomial. Every value is computed from
    /// the control points as they were.
    ///
    /// Errors (cell index first): a cell type that is not a Lagrange
    /// tetrahedron, hexahedron or wedge, a node out of range, a weight
    /// that is not finite and positive, a value that evaluates to a
    /// non-finite number. Nothing is changed on error.
    pub fn to_lagrange(
        &mut self,
        cells: &mut Cells,
        bezier: &[usize],
        points: &mut Vec<[f64; 3]>,
        point_fields: &mut [Field],
        weights: Option<&[f64]>,
    ) -> Result<BezierReport, String> {
        let num_points = points.len();
        if let Some(w) = weights {
            if w.len() != num_points {
                return Err(format!("RationalWeights has {} values for {num_points} points", w.len()));
            }
        }
        for f in point_fields.iter() {
            if f.num_components == 0 || f.values.len() != num_points * f.num_components {
                return Err(format!("point field '{}' does not hold one tuple a point", f.name));
            }
        }
        // Points some cell needs where they are: every node of a cell that
        // is not Bézier, every corner of one that is.
        let mut is_bezier = vec![false; cells.len()];
        for &c in bezier {
            *is_bezier.get_mut(c).ok_or_else(|| format!("Bézier cell {c} is not in the piece"))? = true;
        }
        let mut pinned = vec![false; num_points];
        for (c, &t) in cells.types.iter().enumerate() {
            let nodes = &cells.connectivity[cells.offsets[c]..cells.offsets[c + 1]];
            let keep = if is_bezier[c] { t.linear().num_nodes().min(nodes.len()) } else { nodes.len() };
            for &p in &nodes[..keep] {
                if let Some(slot) = pinned.get_mut(p as usize) {
                    *slot = true;
                }
            }
        }
        // Each non-corner control point's value, once (the first cell that
        // names it evaluates it): position, then the fields' tuples.
        let mut evaluated: std::collections::HashSet<u32> = std::collections::HashSet::new();
        let mut order: Vec<u32> = Vec::new();
        let mut new_points: Vec<[f64; 3]> = Vec::new();
        let mut new_values: Vec<Vec<f64>> = vec![Vec::new(); point_fields.len()];
        let mut row = Vec::new();
        for &c in bezier {
            let cell_type = cells.types[c];
            let basis = match self.basis.entry(cell_type) {
                std::collections::hash_map::Entry::Occupied(e) => e.into_mut(),
                std::collections::hash_map::Entry::Vacant(e) => e.insert(Basis::new(cell_type).ok_or_else(|| {
                    format!("cell {c}: {cell_type:?} is not a Bézier tetrahedron, hexahedron or wedge")
                })?),
            };
            let basis = &*basis;
            let nodes = &cells.connectivity[cells.offsets[c]..cells.offsets[c + 1]];
            let n = basis.lattice.len();
            if nodes.len() != n {
                return Err(format!("cell {c}: {} control points, its orders need {n}", nodes.len()));
            }
            if let Some(&p) = nodes.iter().find(|&&p| p as usize >= num_points) {
                return Err(format!("cell {c} refers to point {p}, but the piece has {num_points} points"));
            }
            let w_of = |j: usize| weights.map_or(1.0, |w| w[nodes[j] as usize]);
            if let Some(j) = (0..n).find(|&j| !(w_of(j).is_finite() && w_of(j) > 0.0)) {
                return Err(format!(
                    "cell {c}: control point {} has rational weight {}; weights must be finite and positive",
                    nodes[j],
                    w_of(j)
                ));
            }
            // What every node value is a weighted sum of, control point by
            // control point: the weight, the weighted coordinates, each
            // weighted field component (rational weights folded in; the sums
            // are divided by the first channel's).
            let mut channels = vec![(0..n).map(w_of).collect::<Vec<f64>>()];
            channels.extend((0..3).map(|a| (0..n).map(|j| w_of(j) * points[nodes[j] as usize][a]).collect()));
            for f in point_fields.iter() {
                let k = f.num_components;
                for comp in 0..k {
                    channels.push((0..n).map(|j| w_of(j) * f.values[nodes[j] as usize * k + comp]).collect());
                }
            }
            // A hexahedron too large for a cached matrix: every node's sums
            // at once, axis by axis (O(N·(p + q + r)), not N²).
            let tensor = match (cell_type, &basis.matrix) {
                (CellType::LagrangeHexahedron(o), None) => {
                    Some(channels.iter().map(|ch| hexahedron_sums(o, &basis.lattice, ch)).collect::<Vec<_>>())
                }
                _ => None,
            };
            let mut sums = vec![0.0; channels.len()];
            for (i, &p) in nodes.iter().enumerate().skip(cell_type.linear().num_nodes()) {
                if !evaluated.insert(p) {
                    continue;
                }
                match &tensor {
                    Some(t) => sums.iter_mut().zip(t).for_each(|(s, ch)| *s = ch[i]),
                    None => {
                        let b: &[f64] = match &basis.matrix {
                            Some(m) => &m[i * n..(i + 1) * n],
                            None => {
                                row.resize(n, 0.0);
                                basis.row_into(cell_type, i, &mut row);
                                &row
                            }
                        };
                        for (s, ch) in sums.iter_mut().zip(&channels) {
                            *s = b.iter().zip(ch).map(|(b, v)| b * v).sum();
                        }
                    }
                }
                let sum = sums[0];
                if !(sum.is_finite() && sum > 0.0) {
                    return Err(format!("cell {c}: its basis sums to {sum} at node {i}"));
                }
                let x = [sums[1] / sum, sums[2] / sum, sums[3] / sum];
                if !x.iter().all(|v| v.is_finite()) {
                    return Err(format!("cell {c}: node {i} evaluates to {x:?}"));
                }
                let mut ch = sums[4..].iter();
                for (f, out) in point_fields.iter().zip(&mut new_values) {
                    out.extend(ch.by_ref().take(f.num_components).map(|v| v / sum));
                }
                order.push(p);
                new_points.push(x);
            }
        }
        let appended = order.iter().filter(|&&p| pinned[p as usize]).count();
        if num_points + appended >= u32::MAX as usize {
            return Err(format!("{appended} points added to {num_points} are more than 32-bit indices reach"));
        }
        // Where each evaluated value goes: in place, or a new point.
        let mut id_of: HashMap<u32, u32> = HashMap::with_capacity(order.len());
        for (v, &p) in order.iter().enumerate() {
            let id = if pinned[p as usize] {
                points.push(new_points[v]);
                for (f, vals) in point_fields.iter_mut().zip(&new_values) {
                    let k = f.num_components;
                    f.values.extend_from_slice(&vals[v * k..(v + 1) * k]);
                }
                (points.len() - 1) as u32
            } else {
                points[p as usize] = new_points[v];
                for (f, vals) in point_fields.iter_mut().zip(&new_values) {
                    let k = f.num_components;
                    f.values[p as usize * k..(p as usize + 1) * k].copy_from_slice(&vals[v * k..(v + 1) * k]);
                }
                p
            };
            id_of.insert(p, id);
        }
        for &c in bezier {
            let corners = cells.types[c].linear().num_nodes();
            for p in &mut cells.connectivity[cells.offsets[c] + corners..cells.offsets[c + 1]] {
                *p = id_of[p];
            }
        }
        Ok(BezierReport { cells: bezier.len(), points_moved: order.len() - appended, points_added: appended })
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn ids(n: usize) -> Vec<u32> {
        (0..n as u32).collect()
    }

    /// Every basis is a partition of unity at every lattice point, and the
    /// corner rows are unit rows (a Bézier cell passes through its
    /// corners).
    #[test]
    fn bases_sum_to_one_and_interpolate_corners() {
        for t in [
            CellType::LagrangeTetra(1),
            CellType::LagrangeTetra(4),
            CellType::LagrangeHexahedron([2, 2, 2]),
            CellType::LagrangeHexahedron([1, 2, 3]),
            CellType::LagrangeWedge(3, 3),
            CellType::LagrangeWedge(2, 1),
        ] {
            let b = Basis::new(t).unwrap();
            let n = b.lattice.len();
            let m = b.matrix.as_ref().unwrap();
            for i in 0..n {
                let s: f64 = m[i * n..(i + 1) * n].iter().sum();
                assert!((s - 1.0).abs() < 1e-14, "{t:?} node {i}: {s}");
            }
            for i in 0..t.linear().num_nodes() {
                for j in 0..n {
                    assert_eq!(m[i * n + j], if i == j { 1.0 } else { 0.0 }, "{t:?} corner {i}, {j}");
                }
            }
        }
    }

    /// A Bézier cell whose control points sit on its own lattice (the
    /// identity map) evaluates to the same points: Bernstein polynomials
    /// reproduce linear functions with control values on the lattice.
    #[test]
    fn a_control_net_on_the_lattice_is_the_identity() {
        for t in [CellType::LagrangeTetra(3), CellType::LagrangeHexahedron([1, 2, 3]), CellType::LagrangeWedge(2, 2)] {
            let b = Basis::new(t).unwrap();
            let mut points: Vec<[f64; 3]> = b.at.clone();
            let mut cells = Cells::new();
            cells.push(t, &ids(points.len()));
            let mut fields = vec![Field::new("x+2y", 1, points.iter().map(|p| p[0] + 2.0 * p[1]).collect())];
            let r = BezierEvaluator::new().to_lagrange(&mut cells, &[0], &mut points, &mut fields, None).unwrap();
            let corners = t.linear().num_nodes();
            assert_eq!(r, BezierReport { cells: 1, points_moved: b.at.len() - corners, points_added: 0 });
            let conn = &cells.connectivity;
            for (i, &p) in conn.iter().enumerate() {
                let (x, want) = (points[p as usize], b.at[i]);
                assert!((0..3).all(|a| (x[a] - want[a]).abs() < 1e-14), "{t:?} node {i}: {x:?} vs {want:?}");
                let v = fields[0].values[p as usize];
                assert!((v - (want[0] + 2.0 * want[1])).abs() < 1e-14);
            }
        }
    }

    /// Two quadratic Bézier tets sharing a face, with a warped control net
    /// and a rational weight on the shared face: each evaluated value is
    /// the one the cell alone gives (moving a control point in place never
    /// feeds another cell's evaluation), the face's three edge points are
    /// one for both cells, and no point is added.
    #[test]
    fn neighbours_share_their_face_points_and_see_the_control_net_as_it_was() {
        let t = CellType::LagrangeTetra(2);
        let at = Basis::new(t).unwrap().at;
        let warp = |p: [f64; 3], k: f64| [p[0] + 0.2 * p[1] * p[2], p[1] + 0.1 * k * p[0] * p[0], p[2] + 0.15 * p[0]];
        // Cell 0 on the lattice; cell 1 its mirror through the face z = 0
        // (nodes 0, 1, 2 and the edge nodes 4, 5, 6 of that face shared).
        let mut points: Vec<[f64; 3]> = at.iter().map(|&p| warp(p, 1.0)).collect();
        let mirror: Vec<u32> = (0..10)
            .map(|i| match i {
                0 | 1 | 2 | 4 | 5 | 6 => i,
                _ => {
                    points.push(warp([at[i as usize][0], at[i as usize][1], -at[i as usize][2]], -1.0));
                    (points.len() - 1) as u32
                }
            })
            .collect();
        let mut cells = Cells::new();
        cells.push(t, &ids(10));
        let mirrored: Vec<u32> = [0, 2, 1, 3, 6, 5, 4, 7, 9, 8].iter().map(|&i: &usize| mirror[i]).collect();
        cells.push(t, &mirrored);
        let weights: Vec<f64> = (0..points.len()).map(|p| if p == 5 { 0.7 } else { 1.0 + 0.05 * p as f64 }).collect();
        let scalar: Vec<f64> = points.iter().map(|p| (3.0 * p[0]).sin() + p[2]).collect();
        let alone = |c: usize| {
            let mut cs = Cells::new();
            cs.push(t, cells.nodes(c));
            let (mut pts, mut f) = (points.clone(), vec![Field::new("s", 1, scalar.clone())]);
            let w = weights.clone();
            BezierEvaluator::new().to_lagrange(&mut cs, &[0], &mut pts, &mut f, Some(&w)).unwrap();
            cs.nodes(0).iter().map(|&p| (pts[p as usize], f[0].values[p as usize])).collect::<Vec<_>>()
        };
        let (want0, want1) = (alone(0), alone(1));
        let mut fields = vec![Field::new("s", 1, scalar.clone())];
        let n_before = points.len();
        let r =
            BezierEvaluator::new().to_lagrange(&mut cells, &[0, 1], &mut points, &mut fields, Some(&weights)).unwrap();
        assert_eq!(r, BezierReport { cells: 2, points_moved: 6 + 3, points_added: 0 });
        assert_eq!(points.len(), n_before);
        for (c, want) in [(0, want0), (1, want1)] {
            for (i, &p) in cells.nodes(c).iter().enumerate() {
                let (x, v) = (points[p as usize], fields[0].values[p as usize]);
                let (wx, wv) = want[i];
                assert!((0..3).all(|a| (x[a] - wx[a]).abs() < 1e-15) && (v - wv).abs() < 1e-15, "cell {c} node {i}");
            }
        }
        assert_eq!(cells.nodes(1)[4..7], [6, 5, 4]);
    }

    /// A hexahedron of more nodes than a cached matrix holds is evaluated
    /// by sum factorisation: the same values (to rounding) as the matrix
    /// path gives, rational weights and a two-component field included.
    #[test]
    fn large_hexahedra_are_summed_axis_by_axis_to_the_same_values() {
        let t = CellType::LagrangeHexahedron([11, 12, 9]);
        let b = Basis::new(t).unwrap();
        assert!(b.matrix.is_none() && b.at.len() > MAX_CACHED_NODES);
        let n = b.at.len();
        let warp = |p: [f64; 3]| [p[0] + 0.1 * (3.0 * p[1]).sin(), p[1] + 0.2 * p[0] * p[2], p[2] - 0.1 * p[0] * p[1]];
        let points: Vec<[f64; 3]> = b.at.iter().map(|&p| warp(p)).collect();
        let weights: Vec<f64> = (0..n).map(|j| 1.0 + 0.3 * ((j * 7919) % 13) as f64 / 13.0).collect();
        let field: Vec<f64> = points.iter().flat_map(|p| [(4.0 * p[0]).cos(), p[1] * p[2]]).collect();
        let mut cells = Cells::new();
        cells.push(t, &ids(n));
        let (mut pts, mut fields) = (points.clone(), vec![Field::new("v", 2, field.clone())]);
        BezierEvaluator::new().to_lagrange(&mut cells, &[0], &mut pts, &mut fields, Some(&weights)).unwrap();
        let mut row = vec![0.0; n];
        for i in (8..n).step_by(37) {
            b.row_into(t, i, &mut row);
            let wsum: f64 = (0..n).map(|j| row[j] * weights[j]).sum();
            let want = |f: &dyn Fn(usize) -> f64| (0..n).map(|j| row[j] * weights[j] * f(j)).sum::<f64>() / wsum;
            for a in 0..3 {
                let w = want(&|j| points[j][a]);
                assert!((pts[i][a] - w).abs() < 1e-12, "node {i} axis {a}: {} vs {w}", pts[i][a]);
            }
            for comp in 0..2 {
                let w = want(&|j| field[2 * j + comp]);
                assert!((fields[0].values[2 * i + comp] - w).abs() < 1e-12, "node {i} field {comp}");
            }
        }
    }

    #[test]
    fn bad_weights_and_nodes_are_errors_that_change_nothing() {
        let t = CellType::LagrangeTetra(2);
        let b = Basis::new(t).unwrap();
        let mut points = b.at.clone();
        let mut cells = Cells::new();
        cells.push(t, &ids(10));
        let mut fields = vec![Field::new("s", 1, vec![0.0; 10])];
        let mut ev = BezierEvaluator::new();
        for (w, msg) in [(0.0, "weight 0"), (-1.0, "weight -1"), (f64::NAN, "weight NaN")] {
            let mut weights = vec![1.0; 10];
            weights[7] = w;
            let e = ev.to_lagrange(&mut cells, &[0], &mut points, &mut fields, Some(&weights)).unwrap_err();
            assert!(e.contains(msg), "{e}");
        }
        let e = ev.to_lagrange(&mut cells, &[0], &mut points, &mut fields, Some(&[1.0; 3])).unwrap_err();
        assert!(e.contains("3 values for 10 points"), "{e}");
        let mut short = points[..9].to_vec();
        let e = ev.to_lagrange(&mut cells, &[0], &mut short, &mut fields, None).unwrap_err();
        assert!(e.contains("point field"), "{e}");
        let mut no_fields: Vec<Field> = Vec::new();
        let e = ev.to_lagrange(&mut cells, &[0], &mut short, &mut no_fields, None).unwrap_err();
        assert!(e.contains("refers to point 9"), "{e}");
        let mut lin = Cells::new();
        lin.push(CellType::Pyramid, &[0, 1, 2, 3, 4]);
        assert!(ev.to_lagrange(&mut lin, &[0], &mut points, &mut no_fields, None).unwrap_err().contains("Pyramid"));
        assert_eq!((points.len(), cells.connectivity, fields[0].values.len()), (10, ids(10), 10));
    }
}
