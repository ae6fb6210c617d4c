//! VTK's Lagrange cells: node orders against VTK's own (a dump from VTK
//! 9.7.2, `tests/data/vtk_lagrange_nodes.py`), and the split at their nodes
//! into positive tets that fill each cell and conform across shared faces.
use std::collections::HashMap;
use tet_mesh::lagrange::{
    gmsh_hexahedron_lattice, gmsh_pyramid_lattice, gmsh_tetra_lattice, gmsh_wedge_lattice, lagrange_hexahedron_lattice,
    lagrange_hexahedron_node, lagrange_tetra_lattice, lagrange_wedge_lattice, lattice_permutation,
};
use tet_mesh::predicates::signed_tet_volume;
use tet_mesh::split::split_cell;
use tet_mesh::{build_adjacency, CellType, SplitMix64};

#[test]
fn node_orders_match_vtk() {
    let text = include_str!("data/vtk_lagrange_nodes.txt");
    let mut checked = 0;
    for line in text.lines().filter(|l| !l.starts_with('#')) {
        let (head, points) = line.split_once(':').expect("type orders: points");
        let head: Vec<u8> = head.split_whitespace().map(|w| w.parse().unwrap()).collect();
        let vtk: Vec<[i32; 3]> = points
            .split_whitespace()
            .map(|p| {
                let v: Vec<i32> = p.split(',').map(|c| c.parse().unwrap()).collect();
                [v[0], v[1], v[2]]
            })
            .collect();
        let ours = match head[0] {
            71 => lagrange_tetra_lattice(head[1]),
            73 => lagrange_wedge_lattice(head[1], head[3]),
            72 => {
                let o = [head[1], head[2], head[3]].map(usize::from);
                let mut at = vec![[-1; 3]; vtk.len()];
                for k in 0..=o[2] {
                    for j in 0..=o[1] {
                        for i in 0..=o[0] {
                            at[lagrange_hexahedron_node([i, j, k], o)] = [i, j, k].map(|v| v as i32);
                        }
                    }
                }
                at
            }
            t => panic!("type {t}"),
        };
        assert_eq!(ours, vtk, "VTK type {} orders {:?}", head[0], &head[1..]);
        checked += 1;
    }
    assert_eq!(checked, 27);
}

/// Gmsh's complete tetrahedra, hexahedra and prisms: node orders against
/// Gmsh's own (a dump from Gmsh 4.15.2, `tests/data/gmsh_nodes.py`), and each a
/// permutation of VTK's Lagrange cell of its order.
#[test]
fn gmsh_node_orders_match_gmsh() {
    let text = include_str!("data/gmsh_nodes.txt");
    let mut checked = 0;
    for line in text.lines() {
        let mut words = line.split_whitespace();
        let (family, _type_id, order) = (words.next().unwrap(), words.next().unwrap(), words.next().unwrap());
        let order: u8 = order.parse().unwrap();
        let gmsh: Vec<[i32; 3]> = words
            .map(|p| {
                let v: Vec<i32> = p.split(',').map(|c| c.parse().unwrap()).collect();
                [v[0], v[1], v[2]]
            })
            .collect();
        let (ours, vtk) = match family {
            "tet" => (gmsh_tetra_lattice(order), lagrange_tetra_lattice(order)),
            "hex" => (gmsh_hexahedron_lattice(order), lagrange_hexahedron_lattice([order; 3])),
            "prism" => (gmsh_wedge_lattice(order), lagrange_wedge_lattice(order, order)),
            // (tetkit's pyramid keeps Gmsh's order.)
            "pyramid" => (gmsh_pyramid_lattice(order), gmsh_pyramid_lattice(order)),
            f => panic!("{f}"),
        };
        assert_eq!(ours, gmsh, "{family} of order {order}");
        assert!(lattice_permutation(&ours, &vtk).is_some(), "{family} of order {order}");
        checked += 1;
    }
    assert_eq!(checked, 34);
}

/// Lattice cells on integer points (denominator 840 = lcm(1..=8)), ids
/// shuffled and shared by every cell placed (cells sharing a face share
/// its nodes' ids), positions through a fixed skew of positive determinant.
struct Placer {
    ids: HashMap<[i64; 3], u32>,
    order: Vec<u32>,
}

const D: i64 = 840;

impl Placer {
    fn new(seed: u64) -> Placer {
        let mut rng = SplitMix64(seed);
        let mut order: Vec<u32> = (0..20_000).collect();
        for i in (1..order.len()).rev() {
            order.swap(i, (rng.next_u64() % (i as u64 + 1)) as usize);
        }
        Placer { ids: HashMap::new(), order }
    }

    fn id(&mut self, at: [i64; 3]) -> u32 {
        let next = self.order[self.ids.len()];
        *self.ids.entry(at).or_insert(next)
    }

    fn points(&self) -> Vec<[f64; 3]> {
        let mut p = vec![[f64::NAN; 3]; self.order.len()];
        for (&[x, y, z], &id) in &self.ids {
            let (x, y, z) = (x as f64 / D as f64, y as f64 / D as f64, z as f64 / D as f64);
            p[id as usize] = [2.0 * x + 0.3 * y - 0.2 * z, 0.1 * x + 1.5 * y + 0.4 * z, 0.2 * x - 0.1 * y + 1.2 * z];
        }
        p
    }

    /// Nodes of a cell whose parameter lattice point (a, b, c) of orders
    /// `o` lies at c0 + a/o0 (c1 - c0) + b/o1 (c2 - c0) + c/o2 (c3 - c0)
    /// (corner offsets in units of D).
    fn place(&mut self, lattice: &[[i32; 3]], o: [i64; 3], c: [[i64; 3]; 4]) -> Vec<u32> {
        lattice
            .iter()
            .map(|l| {
                let at = [0, 1, 2].map(|k| {
                    D * c[0][k] + (1..4).map(|e| D * l[e - 1] as i64 * (c[e][k] - c[0][k]) / o[e - 1]).sum::<i64>()
                });
                self.id(at)
            })
            .collect()
    }

    /// A pyramid of order n on base corner `o`, base side 2, apex 1 above
    /// the base's centre (its sheared lattice point (i, j, k) at o + (2i +
    /// k, 2j + k, k)/n).
    fn pyramid(&mut self, n: u8, o: [i64; 3]) -> (CellType, Vec<u32>) {
        let c = [o, [o[0] + 2, o[1], o[2]], [o[0], o[1] + 2, o[2]], [o[0] + 1, o[1] + 1, o[2] + 1]];
        (CellType::LagrangePyramid(n), self.place(&gmsh_pyramid_lattice(n), [n as i64; 3], c))
    }

    fn tetra(&mut self, n: u8, c: [[i64; 3]; 4]) -> (CellType, Vec<u32>) {
        (CellType::LagrangeTetra(n), self.place(&lagrange_tetra_lattice(n), [n as i64; 3], c))
    }

    /// A wedge on corners 0, 1, 2 of its bottom and 3 above corner 0.
    fn wedge(&mut self, n: u8, m: u8, c: [[i64; 3]; 4]) -> (CellType, Vec<u32>) {
        (CellType::LagrangeWedge(n, m), self.place(&lagrange_wedge_lattice(n, m), [n as i64, n as i64, m as i64], c))
    }

    /// An axis-aligned hexahedron of unit side (in D) at `origin`.
    fn hexahedron(&mut self, o: [u8; 3], origin: [i64; 3]) -> (CellType, Vec<u32>) {
        let lattice = lagrange_hexahedron_lattice(o);
        let c = [
            origin,
            [origin[0] + 1, origin[1], origin[2]],
            [origin[0], origin[1] + 1, origin[2]],
            [origin[0], origin[1], origin[2] + 1],
        ];
        (CellType::LagrangeHexahedron(o), self.place(&lattice, o.map(i64::from), c))
    }

    /// The 15-node tetrahedron and the 21-node wedge at their parameter
    /// points (`at` in 1/den units of the cell's corner frame `c`).
    fn centred(&mut self, ty: CellType, at: &[[i32; 3]], den: i64, c: [[i64; 3]; 4]) -> (CellType, Vec<u32>) {
        (ty, self.place(at, [den; 3], c))
    }
}

use tet_mesh::lagrange::{TETRA15_AT as TETRA15, WEDGE21_AT as WEDGE21};

const UNIT: [[i64; 3]; 4] = [[0, 0, 0], [1, 0, 0], [0, 1, 0], [0, 0, 1]];

fn shifted(c: [[i64; 3]; 4], by: [i64; 3]) -> [[i64; 3]; 4] {
    c.map(|p| [p[0] + by[0], p[1] + by[1], p[2] + by[2]])
}

fn split_all(cells: &[(CellType, Vec<u32>)]) -> Vec<[u32; 4]> {
    let mut tets = vec![];
    for (ty, nodes) in cells {
        assert_eq!(nodes.len(), ty.num_nodes(), "{ty:?}");
        split_cell(*ty, nodes, &mut |t| {
            assert!(t.iter().all(|v| nodes.contains(v)), "{ty:?}: {t:?} is not on the cell's nodes");
            tets.push(t)
        });
    }
    tets
}

fn vol(p: &[[f64; 3]], t: &[u32; 4]) -> f64 {
    signed_tet_volume(&p[t[0] as usize], &p[t[1] as usize], &p[t[2] as usize], &p[t[3] as usize])
}

/// The skew's determinant: a unit cube's volume after it.
fn skew_det() -> f64 {
    2.0 * (1.5 * 1.2 + 0.04) - 0.3 * (0.12 - 0.08) - 0.2 * (-0.01 - 0.3)
}

#[test]
fn lagrange_cells_split_at_every_node_into_positive_tets_filling_them() {
    for seed in 0..6 {
        let mut l = Placer::new(seed);
        let mut cases = vec![];
        for n in 1..=6u8 {
            let n3 = n as usize * n as usize * n as usize;
            cases.push((l.tetra(n, shifted(UNIT, [0, 0, 0])), n3, 1.0 / 6.0));
        }
        for o in [[2, 2, 2], [3, 1, 2], [1, 4, 2], [4, 4, 4]] {
            let cells = o.iter().map(|&a| a as usize).product::<usize>();
            cases.push((l.hexahedron(o, [3, 0, 0]), 6 * cells, 1.0));
        }
        for (n, m) in [(2, 2), (3, 1), (2, 4), (5, 3)] {
            let cells = n as usize * n as usize * m as usize;
            cases.push((l.wedge(n, m, shifted(UNIT, [6, 0, 0])), 3 * cells, 0.5));
        }
        for n in 2..=5u8 {
            let n = n as usize;
            let pyramids = n * (n + 1) * (2 * n + 1) / 6 + (n - 1) * n * (2 * n - 1) / 6;
            cases.push((l.pyramid(n as u8, [15, 0, 0]), 2 * pyramids + 2 * (n - 1) * n * (n + 1) / 3, 4.0 / 3.0));
        }
        cases.push((
            l.centred(CellType::QuadraticTetraWithCentres, &TETRA15, 12, shifted(UNIT, [9, 0, 0])),
            24,
            1.0 / 6.0,
        ));
        cases.push((l.centred(CellType::QuadraticWedgeWithCentres, &WEDGE21, 6, shifted(UNIT, [12, 0, 0])), 36, 0.5));
        let p = l.points();
        for ((ty, nodes), count, volume) in cases {
            let tets = split_all(&[(ty, nodes.clone())]);
            // Tets are n³ in a tetrahedron's lattice only counting the octahedra as 4.
            let count = if let CellType::LagrangeTetra(n) = ty {
                let n = n as usize;
                let octahedra = (n - 1) * n * (n + 1) / 6;
                n * (n + 1) * (n + 2) / 6 + 4 * octahedra + n.saturating_sub(2) * (n - 1) * n / 6
            } else {
                count
            };
            assert_eq!(tets.len(), count, "{ty:?}");
            let mut sum = 0.0;
            for t in &tets {
                let v = vol(&p, t);
                assert!(v > 0.0, "{ty:?} seed {seed}: tet {t:?} has volume {v}");
                sum += v;
            }
            assert!((sum - volume * skew_det()).abs() < 1e-9, "{ty:?} seed {seed}: {sum}");
            assert!(nodes.iter().all(|n| tets.iter().any(|t| t.contains(n))), "{ty:?}: a node unused");
        }
    }
}

/// Neighbouring Lagrange cells cut their shared faces alike: every interior
/// face is matched, and only the outer surface's triangles are on the
/// boundary (a quad face of orders a × b gives 2ab, a triangle of order n
/// gives n², a centred triangle 6, a centred quad 8).
#[test]
fn lagrange_cells_conform_across_shared_faces() {
    for seed in 0..12 {
        let mut l = Placer::new(1000 + seed);
        // Two hexahedra of orders (2, 3, 1) side by side along x; their
        // outer faces: 2 x-faces of 3·1, 4 y-faces of 2·1, 4 z-faces of 2·3.
        let hexes = vec![l.hexahedron([2, 3, 1], [0, 0, 0]), l.hexahedron([2, 3, 1], [1, 0, 0])];
        let hex_boundary = 2 * 2 * 3 + 4 * 2 * 2 + 4 * 2 * 2 * 3;
        // Two order-3 tets sharing a face: 6 outer triangles of 9.
        let a = [[10, 0, 0], [11, 0, 0], [10, 1, 0], [10, 0, 1]];
        let b = [[11, 0, 0], [10, 0, 1], [10, 1, 0], [11, 1, 1]];
        let tets = vec![l.tetra(3, a), l.tetra(3, b)];
        // An order-(3, 2) wedge on top of an order-3 tet's face (triangle
        // on triangle), and an order-(3, 3, 2) hexahedron against the wedge's
        // first quad: tet 3 faces of 9, wedge top 9 and 2 quads of 3·2,
        // hexahedron 5 faces: two of 3·3 (z), three of 3·2 (x, x, y).
        let base = [[20, 0, 0], [21, 0, 0], [20, 1, 0], [20, 0, -1]];
        let mixed = vec![
            l.tetra(3, [base[0], base[2], base[1], base[3]]),
            l.wedge(3, 2, [[20, 0, 0], [21, 0, 0], [20, 1, 0], [20, 0, 1]]),
            l.hexahedron([3, 3, 2], [20, -1, 0]),
        ];
        let mixed_boundary = 3 * 9 + 9 + 2 * (2 * 3 * 2) + 2 * (2 * 3 * 3) + 3 * (2 * 3 * 2);
        // Two 15-node tets on a face (6 outer faces of 6 triangles); two
        // 21-node wedges one on the other (2 triangles of 6, 6 quads of 8).
        let t15 = vec![
            l.centred(
                CellType::QuadraticTetraWithCentres,
                &TETRA15,
                12,
                [[30, 0, 0], [31, 0, 0], [30, 1, 0], [30, 0, 1]],
            ),
            l.centred(
                CellType::QuadraticTetraWithCentres,
                &TETRA15,
                12,
                [[31, 0, 0], [30, 0, 1], [30, 1, 0], [31, 1, 1]],
            ),
        ];
        let w21 = vec![
            l.centred(CellType::QuadraticWedgeWithCentres, &WEDGE21, 6, shifted(UNIT, [40, 0, 0])),
            l.centred(CellType::QuadraticWedgeWithCentres, &WEDGE21, 6, shifted(UNIT, [40, 0, 1])),
        ];
        // An order-3 pyramid on an order-(3, 3, 2) hexahedron of side 2 (base
        // on its top), an order-3 tet on the pyramid's face 0-1-4: the
        // hexahedron's five other faces (18 + 4 · 12), the pyramid's three
        // and the tet's three (9 each).
        let hex = {
            let o = [50, 0, 0];
            let c = [o, [52, 0, 0], [50, 2, 0], [50, 0, 2]];
            (CellType::LagrangeHexahedron([3, 3, 2]), l.place(&lagrange_hexahedron_lattice([3, 3, 2]), [3, 3, 2], c))
        };
        let pyramid_stack =
            vec![hex, l.pyramid(3, [50, 0, 2]), l.tetra(3, [[50, 0, 2], [52, 0, 2], [51, -1, 2], [51, 1, 3]])];
        let p = l.points();
        for (cells, boundary) in [
            (hexes, hex_boundary),
            (tets, 6 * 9),
            (mixed, mixed_boundary),
            (t15, 6 * 6),
            (w21, 2 * 6 + 6 * 8),
            (pyramid_stack, 18 + 4 * 12 + 3 * 9 + 3 * 9),
        ] {
            let tets = split_all(&cells);
            for t in &tets {
                let v = vol(&p, t);
                assert!(v != 0.0, "{:?}: flat tet", cells[0].0);
            }
            // Inverted cells (none here but the mirrored tet of `mixed`) are
            // re-oriented by validation; the adjacency needs positive tets.
            let tets: Vec<[u32; 4]> = tets
                .into_iter()
                .map(|t| {
                    let v = vol(&p, &t);
                    if v < 0.0 {
                        [t[0], t[1], t[3], t[2]]
                    } else {
                        t
                    }
                })
                .collect();
            let adjacency = build_adjacency(&p, &tets).expect("conforming");
            assert_eq!(adjacency.boundary_faces.len(), boundary, "{:?} seed {seed}", cells[0].0);
        }
    }
}
