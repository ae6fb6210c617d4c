//! An exact k-d partition of a bundle into N pieces (`tetprep partition`),
//! one piece per rank of a distributed frame.
//!
//! **The tree.** The root box is the mesh's bounding box. A node of `n`
//! parts (n ≥ 2) is cut across the longest axis of its box at the
//! cost-weighted quantile `floor(n/2) / n` of its tets' centroids; the
//! side below the plane gets `floor(n/2)` parts, the side above the rest,
//! so any N ≥ 1 works, not only powers of two. The cost of a tet
//! ([`TetCost`]) is one, or its expected ray crossings (its surface area).
//!
//! **The exact clip.** A tet straddling a plane is cut by it. The point
//! where an edge crosses the plane gets its axis coordinate set to the
//! plane value exactly (an f64 equal to the node's plane), its other
//! coordinates and every per-vertex attribute (the scalar, the other
//! point fields, every time step's scalar and stored gradients) linearly
//! interpolated along the edge. The scalar is linear in a tet, so on the
//! plane's points it is what the unsplit tet had: drawing the pieces gives
//! the integral of the unsplit tet, and no piece reaches outside its box
//! (checked for every point). A vertex exactly on the plane needs no new
//! point. New points are keyed by their edge (the global ids of its two
//! endpoints, ordered), so two tets sharing a cut edge share its point.
//!
//! **Re-tetrahedralization.** A cut tet leaves a tet and a prism, two
//! prisms, or (with one vertex on the plane) a tet and a pyramid, or two
//! tets. Prisms and pyramids are split by the smallest-global-id rule of
//! Dompierre, Labbé, Vallet and Camarero ("How to subdivide pyramids,
//! prisms and hexahedra into tetrahedra", 1999; `tet_mesh::split`): each
//! quad's diagonal goes through its vertex of smallest global id. A quad
//! is shared by the two tets (or the two sides of the plane) that meet
//! there, with the same global ids, so both split it the same way: each
//! side's mesh is conforming and the cut faces on the two sides of a plane
//! coincide. (A deeper plane of one side may cut that side's face again:
//! the two sides then cover the same region of the plane, subdivided
//! differently, which rendering piece by piece does not mind.) Sub-tets of
//! zero volume (the exact orientation test, `piece_tet_orientation`) are dropped;
//! each kept one gets the vertex order that makes it positive.
//!
//! **Pieces** go through the conversion every bundle goes through
//! ([`crate::convert_source`]: validation, adjacency, statistics), with
//! merging limited to identical coordinates, and carry the source's other
//! point fields, time steps (with their stored gradients) and analysis
//! (its gradients cut, histograms over the source's axes, the piece's
//! ranges, facts and limits). [`write_partition`] writes one piece at a
//! time with the manifest (`formats/manifest.md`). Nothing is printed;
//! [`PartitionError`] names what failed.

use std::collections::HashMap;
use std::path::{Path, PathBuf};

use tet_bundle::manifest::{
    file_crc32, BoxBounds, KdNode, Manifest, PieceInfo, ScalarRange, SourceInfo, StepRange, MANIFEST_FILE,
    MANIFEST_FORMAT, MANIFEST_VERSION,
};
use tet_bundle::{Bundle, TimeSteps};
use tet_mesh::predicates::{tet_orientation, TetOrientation};
use tet_mesh::{Block, CellType, Cells, ConvertOptions, Field, SourceMesh};

use crate::{convert_source, ConvertError, ConvertRequest};

/// What a tet costs to draw, for the quantile that places each plane.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum TetCost {
    /// Every tet costs 1: pieces get about equal tet counts (what projected
    /// tetrahedra, whose work is per tet, spend).
    #[default]
    Uniform,
    /// A tet's expected ray crossings: its surface area. By Cauchy and
    /// Crofton's formula a uniformly random line meets a convex body with
    /// a probability proportional to its surface area, so over all views
    /// a ray walker's crossings of a tet, and its work there, follow the
    /// area: a graded mesh's small cells cost less than their count says.
    Crossings,
}

impl TetCost {
    /// The cost of the tet with corners `pos_in_world`.
    pub fn of(self, pos_in_world: &[[f64; 3]; 4]) -> f64 {
        match self {
            TetCost::Uniform => 1.0,
            TetCost::Crossings => {
                let p = pos_in_world;
                let area = |a: usize, b: usize, c: usize| {
                    let (u, v) = ([0, 1, 2].map(|k| p[b][k] - p[a][k]), [0, 1, 2].map(|k| p[c][k] - p[a][k]));
                    let n = [u[1] * v[2] - u[2] * v[1], u[2] * v[0] - u[0] * v[2], u[0] * v[1] - u[1] * v[0]];
                    0.5 * (n[0] * n[0] + n[1] * n[1] + n[2] * n[2]).sqrt()
                };
                let total = area(0, 1, 2) + area(0, 1, 3) + area(0, 2, 3) + area(1, 2, 3);
                if total.is_finite() {
                    total
                } else {
                    0.0
                }
            }
        }
    }

    /// The name the manifest and `tetprep partition --cost` use.
    pub fn id(self) -> &'static str {
        match self {
            TetCost::Uniform => "tets",
            TetCost::Crossings => "crossings",
        }
    }
}

/// How to partition.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct PartitionRequest {
    /// The number of pieces, N ≥ 1, at most the source's tet count.
    pub parts: usize,
    pub cost: TetCost,
}

/// Why a partition failed; a piece index where one is to blame, the path
/// last.
#[derive(Debug, thiserror::Error)]
pub enum PartitionError {
    #[error("the bundle's arrays do not fit together: {what}")]
    BadSource { what: String },
    #[error("--parts must be at least 1")]
    NoParts,
    #[error("{parts} parts for a mesh of {tets} tets: at most one part per tet")]
    TooManyParts { parts: usize, tets: usize },
    #[error("cutting the mesh makes {points} points, more than a mesh's u32 vertex ids address")]
    TooLarge { points: usize },
    #[error("piece {piece} would be empty: the mesh cannot be cut into {parts} parts along its centroids")]
    EmptyPiece { piece: usize, parts: usize },
    #[error("piece {piece}: point {point} at {pos_in_world:?} lies outside its box {bounds:?} (a bug)")]
    OutsideBox { piece: usize, point: usize, pos_in_world: [f64; 3], bounds: BoxBounds },
    #[error("piece {piece} does not convert to a bundle")]
    Piece {
        piece: usize,
        #[source]
        source: ConvertError,
    },
    #[error("piece {piece}: {what}")]
    PieceSteps { piece: usize, what: String },
    #[error("piece {piece} cannot be analysed as its source was")]
    Analysis {
        piece: usize,
        #[source]
        source: tet_analysis::AnalysisError,
    },
    #[error("{} exists and is not empty (use --force to replace it)", path.display())]
    OutputExists { path: PathBuf },
    #[error("cannot {action} {}", path.display())]
    Write {
        action: &'static str,
        #[source]
        source: std::io::Error,
        path: PathBuf,
    },
    #[error("piece {piece}")]
    Prepare {
        piece: usize,
        #[source]
        source: Box<dyn std::error::Error + Send + Sync>,
    },
    #[error("cannot write piece {piece}")]
    WritePiece {
        piece: usize,
        #[source]
        source: tet_bundle::BundleError,
    },
    #[error("cannot read the source bundle {}", path.display())]
    Source {
        #[source]
        source: std::io::Error,
        path: PathBuf,
    },
}

/// One piece: its bundle and box.
#[derive(Debug)]
pub struct Piece {
    pub bundle: Bundle,
    pub bounds: BoxBounds,
    /// Points made on cut edges (before the conversion's compaction).
    pub new_points: usize,
}

/// A partition in memory: the tree (node 0 the root, leaves naming
/// pieces in order) and the pieces.
#[derive(Debug)]
pub struct Partition {
    pub tree: Vec<KdNode>,
    pub pieces: Vec<Piece>,
}

/// The progress of a partition, for progress displays.
#[derive(Debug, Clone, PartialEq)]
pub enum PartitionStage {
    /// Cutting the mesh along the tree's planes.
    Cutting,
    /// Piece `index` of `count` (from 0) being converted.
    Converting { index: usize, count: usize },
    /// Piece `index` of `count` being written.
    Writing { index: usize, count: usize },
}

/// Which side of a plane a point lies on, exactly.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum Side {
    Below,
    On,
    Above,
}

/// Every vertex made so far: the source's points first (ids 0..n), then
/// the points made on cut edges; attributes interleaved, `stride` a point.
struct Vertices {
    pos_in_world: Vec<[f64; 3]>,
    attrs: Vec<f64>,
    stride: usize,
}

impl Vertices {
    fn attr(&self, v: u32) -> &[f64] {
        let v = v as usize;
        &self.attrs[v * self.stride..(v + 1) * self.stride]
    }

    /// The point where edge (a, b) crosses `plane` along `axis`: its axis
    /// coordinate is the plane value exactly, the rest linear along the
    /// edge from the smaller id, clamped to the edge's range so rounding
    /// never takes it out of the box both endpoints lie in (a field's
    /// non-finite values stay non-finite, unclamped).
    fn cut(&mut self, a: u32, b: u32, axis: usize, plane: f64) -> u32 {
        let (a, b) = if a < b { (a, b) } else { (b, a) };
        let (pa, pb) = (self.pos_in_world[a as usize], self.pos_in_world[b as usize]);
        let t = (plane - pa[axis]) / (pb[axis] - pa[axis]);
        let lerp = |x: f64, y: f64| {
            let (v, lo, hi) = (x + t * (y - x), x.min(y), x.max(y));
            // `clamp` wants ordered bounds: not so where both are NaN.
            if lo <= hi {
                v.clamp(lo, hi)
            } else {
                v
            }
        };
        let mut pos = [0.0; 3];
        for k in 0..3 {
            pos[k] = if k == axis { plane } else { lerp(pa[k], pb[k]) };
        }
        let id = self.pos_in_world.len() as u32;
        self.pos_in_world.push(pos);
        for c in 0..self.stride {
            let v = lerp(self.attrs[a as usize * self.stride + c], self.attrs[b as usize * self.stride + c]);
            self.attrs.push(v);
        }
        id
    }
}

/// The exact orientation of a piece's tet, under the domain's name: the
/// workspace's adaptive-precision predicate.
fn piece_tet_orientation(v: &Vertices, t: &[u32; 4]) -> TetOrientation {
    let p = |k: usize| &v.pos_in_world[t[k] as usize];
    tet_orientation(p(0), p(1), p(2), p(3))
}

/// Splits a tet set at `plane` along `axis` into the tets below and above
/// it (see the module documentation). `cuts` maps an edge to its point,
/// for this plane only.
fn clip(v: &mut Vertices, tets: &[[u32; 4]], axis: usize, plane: f64) -> (Vec<[u32; 4]>, Vec<[u32; 4]>) {
    let mut cuts: HashMap<(u32, u32), u32> = HashMap::new();
    let (mut below, mut above) = (Vec::new(), Vec::new());
    let side = |v: &Vertices, i: u32| {
        let x = v.pos_in_world[i as usize][axis];
        if x < plane {
            Side::Below
        } else if x > plane {
            Side::Above
        } else {
            Side::On
        }
    };
    for t in tets {
        let sides = t.map(|i| side(v, i));
        if !sides.contains(&Side::Above) {
            below.push(*t);
            continue;
        }
        if !sides.contains(&Side::Below) {
            above.push(*t);
            continue;
        }
        // The vertices on each side, in the tet's order (no allocation:
        // this runs for every cut tet).
        let group = |s: Side| {
            let mut ids = [0u32; 4];
            let mut len = 0;
            for k in (0..4).filter(|&k| sides[k] == s) {
                ids[len] = t[k];
                len += 1;
            }
            (ids, len)
        };
        let ((lo_ids, n_lo), (on_ids, n_on), (hi_ids, n_hi)) =
            (group(Side::Below), group(Side::On), group(Side::Above));
        let (lo, on, hi) = (&lo_ids[..n_lo], &on_ids[..n_on], &hi_ids[..n_hi]);
        let mut cut = |a: u32, b: u32| {
            let key = (a.min(b), a.max(b));
            *cuts.entry(key).or_insert_with(|| v.cut(key.0, key.1, axis, plane))
        };
        // Pieces as (polyhedron's ids, side) before re-tetrahedralization.
        let mut emit = |poly: Polyhedron, to_below: bool| {
            let out = if to_below { &mut below } else { &mut above };
            poly.tets(&mut |t| out.push(t));
        };
        match (lo.len(), on.len(), hi.len()) {
            (1, 0, 3) | (3, 0, 1) => {
                let (lone, three, lone_below) = if lo.len() == 1 { (lo[0], hi, true) } else { (hi[0], lo, false) };
                let p = [cut(lone, three[0]), cut(lone, three[1]), cut(lone, three[2])];
                emit(Polyhedron::Tet([lone, p[0], p[1], p[2]]), lone_below);
                emit(Polyhedron::Wedge([three[0], three[1], three[2], p[0], p[1], p[2]]), !lone_below);
            }
            (2, 0, 2) => {
                let (a, b, c, d) = (lo[0], lo[1], hi[0], hi[1]);
                let (ac, ad, bc, bd) = (cut(a, c), cut(a, d), cut(b, c), cut(b, d));
                emit(Polyhedron::Wedge([a, ac, ad, b, bc, bd]), true);
                emit(Polyhedron::Wedge([c, ac, bc, d, ad, bd]), false);
            }
            (1, 1, 2) | (2, 1, 1) => {
                let z = on[0];
                let (lone, two, lone_below) = if lo.len() == 1 { (lo[0], hi, true) } else { (hi[0], lo, false) };
                let (c, d) = (two[0], two[1]);
                let (pc, pd) = (cut(lone, c), cut(lone, d));
                emit(Polyhedron::Tet([lone, z, pc, pd]), lone_below);
                // The quad (c, d, pd, pc) lies on the face (lone, c, d).
                emit(Polyhedron::Pyramid([c, d, pd, pc, z]), !lone_below);
            }
            (1, 2, 1) => {
                let (a, c) = (lo[0], hi[0]);
                let p = cut(a, c);
                emit(Polyhedron::Tet([a, on[0], on[1], p]), true);
                emit(Polyhedron::Tet([c, on[0], on[1], p]), false);
            }
            // Both sides present leaves only the cases above.
            _ => {}
        }
    }
    // Orient exactly; drop what has no volume.
    let orient = |tets: Vec<[u32; 4]>, v: &Vertices| -> Vec<[u32; 4]> {
        tets.into_iter()
            .filter_map(|t| match piece_tet_orientation(v, &t) {
                TetOrientation::Positive => Some(t),
                TetOrientation::Negative => Some([t[1], t[0], t[2], t[3]]),
                TetOrientation::Flat => None,
            })
            .collect()
    };
    (orient(below, v), orient(above, v))
}

/// A clipped part of a tet, in global ids.
enum Polyhedron {
    Tet([u32; 4]),
    /// VTK wedge order: triangles (0, 1, 2) and (3, 4, 5), edges 0-3, 1-4, 2-5.
    Wedge([u32; 6]),
    /// Base quad (0, 1, 2, 3) in cyclic order, apex 4.
    Pyramid([u32; 5]),
}

impl Polyhedron {
    /// Its tets by the smallest-global-id rule (orientation not yet fixed).
    fn tets(&self, out: &mut impl FnMut([u32; 4])) {
        match self {
            Polyhedron::Tet(t) => out(*t),
            Polyhedron::Wedge(w) => tet_mesh::split::split_wedge(w, out),
            Polyhedron::Pyramid(p) => tet_mesh::split::split_pyramid(p, out),
        }
    }
}

/// Leaves under construction: each leaf's tets (global ids) and box.
struct Builder {
    v: Vertices,
    tree: Vec<KdNode>,
    leaves: Vec<(Vec<[u32; 4]>, BoxBounds)>,
    cost: TetCost,
    parts: usize,
}

impl Builder {
    /// Builds the subtree of `parts` parts over `tets` in `bounds`; returns
    /// its node index.
    fn node(&mut self, tets: Vec<[u32; 4]>, bounds: BoxBounds, parts: usize) -> Result<usize, PartitionError> {
        let index = self.tree.len();
        if tets.is_empty() {
            return Err(PartitionError::EmptyPiece { piece: self.leaves.len(), parts: self.parts });
        }
        if parts == 1 {
            self.tree.push(KdNode::Leaf { bounds, piece: self.leaves.len() });
            self.leaves.push((tets, bounds));
            return Ok(index);
        }
        let extent = |a: usize| bounds.max[a] - bounds.min[a];
        let axis = (0..3).fold(0, |best, a| if extent(a) > extent(best) { a } else { best });
        let left_parts = parts / 2;
        let plane = self.quantile(&tets, axis, left_parts as f64 / parts as f64);
        // A placeholder, filled once the children's indices are known.
        self.tree.push(KdNode::Leaf { bounds, piece: usize::MAX });
        let (below, above) = clip(&mut self.v, &tets, axis, plane);
        // Vertex ids are u32, as in every mesh: more points than that
        // would have wrapped, and nothing made with them is used.
        if self.v.pos_in_world.len() >= u32::MAX as usize {
            return Err(PartitionError::TooLarge { points: self.v.pos_in_world.len() });
        }
        drop(tets);
        let (lo_box, hi_box) = bounds.split(axis, plane);
        let left = self.node(below, lo_box, left_parts)?;
        let right = self.node(above, hi_box, parts - left_parts)?;
        self.tree[index] = KdNode::Split { bounds, axis: axis as u8, plane, children: [left, right] };
        Ok(index)
    }

    /// The centroid coordinate along `axis` below which a fraction `q` of
    /// the tets' cost lies (the first centroid, in order, at which the
    /// cost before it reaches q of the total; never the smallest one, so
    /// something lies below the plane).
    fn quantile(&self, tets: &[[u32; 4]], axis: usize, q: f64) -> f64 {
        let mut keyed: Vec<(f64, f64)> = tets
            .iter()
            .map(|t| {
                let pos = t.map(|i| self.v.pos_in_world[i as usize]);
                let centroid = pos.iter().map(|p| p[axis]).sum::<f64>() / 4.0;
                (centroid, self.cost.of(&pos))
            })
            .collect();
        keyed.sort_by(|a, b| a.0.total_cmp(&b.0));
        let total: f64 = keyed.iter().map(|k| k.1).sum();
        let target = q * total;
        let mut before = 0.0;
        let mut pick = keyed.len() - 1;
        for (i, k) in keyed.iter().enumerate() {
            if before >= target && i > 0 {
                pick = i;
                break;
            }
            before += k.1;
        }
        keyed[pick.max(1).min(keyed.len() - 1)].0
    }
}

/// Hidden field names that carry time steps through the conversion.
const STEP_FIELD: &str = "\u{1}partition-step";
const GRAD_FIELD: &str = "\u{1}partition-grad";
const ANALYSIS_GRAD_FIELD: &str = "\u{1}partition-analysis-grad";

/// Cuts `source` into `req.parts` pieces (see the module documentation);
/// `label` names the source in the pieces' metadata and in errors.
pub fn partition(
    source: &Bundle,
    label: &str,
    req: &PartitionRequest,
    progress: &mut dyn FnMut(PartitionStage),
) -> Result<Partition, PartitionError> {
    let Cut { v, tree, leaves } = cut(source, req, progress)?;
    let count = leaves.len();
    let mut pieces = Vec::with_capacity(count);
    for (k, (tets, bounds)) in leaves.into_iter().enumerate() {
        progress(PartitionStage::Converting { index: k, count });
        pieces.push(piece(source, label, &v, k, count, tets, bounds)?);
    }
    Ok(Partition { tree, pieces })
}

/// The array sizes the cut indexes by (a bundle read from a file has
/// them; one built in memory may not).
fn check_arrays(source: &Bundle) -> Result<(), PartitionError> {
    let mesh = &source.mesh;
    let np = mesh.points.len();
    let bad = |what: String| Err(PartitionError::BadSource { what });
    if mesh.scalar.len() != np {
        return bad(format!("{} scalars for {np} points", mesh.scalar.len()));
    }
    if let Some(t) = mesh.tets.iter().position(|t| t.iter().any(|&v| v as usize >= np)) {
        return bad(format!("tet {t} names a point beyond the {np} points"));
    }
    if let Some(f) = mesh.point_fields.iter().find(|f| f.values.len() != np * f.num_components) {
        return bad(format!("field '{}' has {} values for {np} points × {}", f.name, f.values.len(), f.num_components));
    }
    if source.gradients_of_analysis().is_some_and(|g| g.len() != np) {
        return bad(format!("the analysis's gradients are not one per point ({np})"));
    }
    if let Some(st) = &source.steps {
        if (0..st.len()).any(|k| st.scalar(k).len() != np || st.gradient(k).is_some_and(|g| g.len() != np)) {
            return bad(format!("a time step's values are not one per point ({np})"));
        }
    }
    Ok(())
}

/// The tree and each leaf's tets over every vertex made.
struct Cut {
    v: Vertices,
    tree: Vec<KdNode>,
    leaves: Vec<(Vec<[u32; 4]>, BoxBounds)>,
}

/// The point fields other than the scalar, in the source's order: the
/// attributes after the scalar.
fn other_fields(mesh: &tet_mesh::TetMesh) -> Vec<&Field> {
    mesh.point_fields.iter().filter(|f| f.name != mesh.scalar_name).collect()
}

/// Builds the tree and clips the tets (the cutting half of [`partition`]).
fn cut(
    source: &Bundle,
    req: &PartitionRequest,
    progress: &mut dyn FnMut(PartitionStage),
) -> Result<Cut, PartitionError> {
    let mesh = &source.mesh;
    if req.parts == 0 {
        return Err(PartitionError::NoParts);
    }
    if req.parts > mesh.tets.len() {
        return Err(PartitionError::TooManyParts { parts: req.parts, tets: mesh.tets.len() });
    }
    check_arrays(source)?;
    progress(PartitionStage::Cutting);
    // Attributes a point: the scalar, the other point fields' components,
    // each step's scalar, each step's gradient.
    let other_fields = other_fields(mesh);
    let steps = source.steps.as_ref();
    let n_steps = steps.map_or(0, TimeSteps::len);
    let step_grads = steps.is_some_and(|s| s.gradient_method().is_some());
    let analysis_grads = source.gradients_of_analysis();
    let stride = 1
        + other_fields.iter().map(|f| f.num_components).sum::<usize>()
        + n_steps * (1 + 3 * step_grads as usize)
        + 3 * analysis_grads.is_some() as usize;
    let np = mesh.points.len();
    let mut attrs = Vec::with_capacity(np * stride);
    for i in 0..np {
        attrs.push(mesh.scalar[i]);
        for f in &other_fields {
            attrs.extend_from_slice(&f.values[i * f.num_components..(i + 1) * f.num_components]);
        }
        if let Some(st) = steps {
            for k in 0..n_steps {
                attrs.push(st.scalar(k)[i]);
                if let Some(g) = st.gradient(k) {
                    attrs.extend_from_slice(&g[i]);
                }
            }
        }
        if let Some(g) = analysis_grads {
            attrs.extend_from_slice(&g[i]);
        }
    }
    let (lo, hi) = tet_mesh::stats::bounds(&mesh.points);
    let root = BoxBounds { min: lo, max: hi };
    let mut b = Builder {
        v: Vertices { pos_in_world: mesh.points.clone(), attrs, stride },
        tree: Vec::new(),
        leaves: Vec::new(),
        cost: req.cost,
        parts: req.parts,
    };
    b.node(mesh.tets.to_vec(), root, req.parts)?;
    let Builder { v, tree, leaves, .. } = b;
    Ok(Cut { v, tree, leaves })
}

/// One leaf's tets to a converted bundle with its steps.
#[allow(clippy::too_many_arguments)]
fn piece(
    source: &Bundle,
    label: &str,
    v: &Vertices,
    k: usize,
    count: usize,
    tets: Vec<[u32; 4]>,
    bounds: BoxBounds,
) -> Result<Piece, PartitionError> {
    let mesh = &source.mesh;
    let other_fields = other_fields(mesh);
    let np_source = mesh.points.len();
    // Local ids in global order.
    let mut used: Vec<u32> = tets.iter().flatten().copied().collect();
    used.sort_unstable();
    used.dedup();
    let local: HashMap<u32, u32> = used.iter().enumerate().map(|(i, &g)| (g, i as u32)).collect();
    let points: Vec<[f64; 3]> = used.iter().map(|&g| v.pos_in_world[g as usize]).collect();
    if let Some(i) = points.iter().position(|p| !bounds.contains(p)) {
        return Err(PartitionError::OutsideBox { piece: k, point: i, pos_in_world: points[i], bounds });
    }
    let new_points = used.iter().filter(|&&g| g as usize >= np_source).count();
    let column = |c: usize, n: usize| -> Vec<f64> {
        let mut out = Vec::with_capacity(used.len() * n);
        for &g in &used {
            out.extend_from_slice(&v.attr(g)[c..c + n]);
        }
        out
    };
    // The source's fields in its order (the scalar among them where it
    // has it), else the scalar first, taken out again after conversion.
    let scalar_is_field = mesh.point_fields.iter().any(|f| f.name == mesh.scalar_name);
    let mut fields = Vec::with_capacity(mesh.point_fields.len() + 1);
    if !scalar_is_field {
        fields.push(Field::new(mesh.scalar_name.clone(), 1, column(0, 1)));
    }
    let mut c = 1;
    let mut others = other_fields.iter();
    for f in &mesh.point_fields {
        if f.name == mesh.scalar_name {
            fields.push(Field::new(f.name.clone(), 1, column(0, 1)));
        } else if let Some(o) = others.next() {
            fields.push(Field::new(o.name.clone(), o.num_components, column(c, o.num_components)));
            c += o.num_components;
        }
    }
    let steps = source.steps.as_ref();
    let n_steps = steps.map_or(0, TimeSteps::len);
    for s in 0..n_steps {
        fields.push(Field::new(format!("{STEP_FIELD}{s}"), 1, column(c, 1)));
        c += 1;
        if steps.is_some_and(|st| st.gradient_method().is_some()) {
            fields.push(Field::new(format!("{GRAD_FIELD}{s}"), 3, column(c, 3)));
            c += 3;
        }
    }
    if source.gradients_of_analysis().is_some() {
        fields.push(Field::new(ANALYSIS_GRAD_FIELD, 3, column(c, 3)));
    }
    let mut cells = Cells::new();
    for t in &tets {
        cells.push(CellType::Tetra, &t.map(|g| local[&g]));
    }
    let n_tets = tets.len();
    drop(tets);
    let src = SourceMesh {
        points,
        blocks: vec![Block::Unstructured(cells)],
        point_fields: fields,
        format: "tetkit bundle piece".into(),
        ..Default::default()
    };
    let req = ConvertRequest {
        convert: ConvertOptions {
            scalar: Some(mesh.scalar_name.clone()),
            // The cut points are exact: only identical coordinates merge.
            merge_tolerance_rel: 0.0,
            keep_point_fields: true,
            ..Default::default()
        },
        ..Default::default()
    };
    let piece_label = format!("{label} piece {k}");
    let converted = convert_source(src, &piece_label, &req, &mut |_| {})
        .map_err(|source| PartitionError::Piece { piece: k, source })?;
    let mut bundle = converted.bundle;
    // Take the hidden step fields back out as the piece's steps.
    let all_fields = std::mem::take(&mut bundle.mesh.point_fields);
    let (hidden, kept): (Vec<Field>, Vec<Field>) = all_fields
        .into_iter()
        .filter(|f| scalar_is_field || f.name != mesh.scalar_name)
        .partition(|f| f.name.starts_with('\u{1}'));
    bundle.mesh.point_fields = kept;
    let mut hidden: HashMap<String, Vec<f64>> = hidden.into_iter().map(|f| (f.name, f.values)).collect();
    let mut take = |name: String| hidden.remove(&name).unwrap_or_default();
    let triples = |v: Vec<f64>| -> Vec<[f64; 3]> { v.chunks_exact(3).map(|c| [c[0], c[1], c[2]]).collect() };
    if let Some(st) = steps {
        let scalars = (0..n_steps).map(|s| take(format!("{STEP_FIELD}{s}"))).collect();
        let sources = (0..n_steps).map(|s| st.source(s).to_string()).collect();
        let mut piece_steps = TimeSteps::new(st.times().to_vec(), scalars, sources)
            .map_err(|what| PartitionError::PieceSteps { piece: k, what })?;
        if let Some(method) = st.gradient_method() {
            let grads = (0..n_steps).map(|s| triples(take(format!("{GRAD_FIELD}{s}")))).collect();
            piece_steps = piece_steps
                .with_gradients(method, grads)
                .map_err(|what| PartitionError::PieceSteps { piece: k, what })?;
        }
        bundle = bundle.with_steps(piece_steps).map_err(|what| PartitionError::PieceSteps { piece: k, what })?;
    }
    if let Some(a) = &source.analysis {
        let grads = a.gradients.as_ref().map(|g| tet_analysis::VertexGradients {
            method: g.method,
            per_point: triples(take(ANALYSIS_GRAD_FIELD.to_string())),
        });
        let analysis =
            piece_analysis(&bundle, a, grads).map_err(|source| PartitionError::Analysis { piece: k, source })?;
        bundle = bundle.with_analysis(analysis);
    }
    let meta = &mut bundle.meta;
    meta.source_path = label.to_string();
    meta.source_format = format!("tetkit bundle, piece {k} of {count}");
    meta.source_points = source.mesh.points.len() as u64;
    meta.source_cells = source.mesh.tets.len() as u64;
    meta.split = source.meta.split.clone();
    meta.split_tets = n_tets as u64;
    meta.delaunay = false;
    meta.findings.insert(
        0,
        format!(
            "piece {k} of {count} of {label}: box [{:?} – {:?}], {new_points} points made on cut edges",
            bounds.min, bounds.max
        ),
    );
    Ok(Piece { bundle, bounds, new_points })
}

/// A piece's analysis like its source's: the source's per-vertex gradients
/// cut with the mesh (`grads`), the per-cell ranges, segment facts and
/// frequency limits of the piece, and, where the source has histograms,
/// the piece's over the source's axes (so the pieces' bins add up to the
/// source's).
fn piece_analysis(
    piece: &Bundle,
    source: &tet_analysis::Analysis,
    grads: Option<tet_analysis::VertexGradients>,
) -> Result<tet_analysis::Analysis, tet_analysis::AnalysisError> {
    let mesh = &piece.mesh;
    let an = tet_analysis::Analyzer::from_mesh(mesh)?;
    let histograms = match &source.histograms {
        None => None,
        Some(h) => Some(an.histograms(&h.same_axes())?),
    };
    let ranges = tet_analysis::cell_ranges(&mesh.tets, &mesh.scalar, grads.as_ref().map(|g| g.per_point.as_slice()));
    let facts = tet_analysis::segment_facts(&mesh.points, &mesh.tets, &ranges);
    let limits = tet_analysis::frequency_limits(&facts, tet_analysis::DEFAULT_TABLE_TOLERANCE);
    Ok(tet_analysis::Analysis { gradients: grads, ranges, facts, limits, histograms })
}

/// The file name of piece `k`.
pub fn piece_file_name(k: usize) -> String {
    format!("piece_{k:04}.tetb")
}

/// The manifest of a partition of `source` (described by `source_info`)
/// with `tree` and `pieces`.
fn manifest_of(source: &Bundle, source_info: SourceInfo, tree: Vec<KdNode>, pieces: Vec<PieceInfo>) -> Manifest {
    let (min, max) = source.scalar_range();
    let steps = source.steps.as_ref().map_or_else(Vec::new, |st| {
        (0..st.len())
            .map(|k| {
                let (lo, hi) =
                    st.scalar(k).iter().fold((f64::INFINITY, f64::NEG_INFINITY), |(a, b), &x| (a.min(x), b.max(x)));
                StepRange { time: st.times()[k], min: lo, max: hi }
            })
            .collect()
    });
    Manifest {
        format: MANIFEST_FORMAT.into(),
        version: MANIFEST_VERSION,
        writer: format!("tetkit {}", env!("CARGO_PKG_VERSION")),
        source: source_info,
        parts: pieces.len(),
        scalar_name: source.mesh.scalar_name.clone(),
        scalar_range: ScalarRange { min, max },
        steps,
        tree,
        pieces,
        cost: TetCost::Uniform.id().into(),
    }
}

/// Whether `dir` exists and holds anything.
fn non_empty_dir(dir: &Path) -> bool {
    match std::fs::read_dir(dir) {
        Ok(mut entries) => entries.next().is_some(),
        // A file of that name counts as "something there".
        Err(_) => dir.exists(),
    }
}

/// Partitions `source` (read from `source_path`) and writes the pieces and
/// `manifest.json` into `out_dir`, atomically: everything goes into a
/// temporary directory beside `out_dir`, which is renamed into place at the
/// end (an existing non-empty `out_dir` is refused unless `force`, then
/// replaced). Each piece is converted, given to `prepare` (the binary adds
/// the analysis `tetprep convert` would), written and dropped before the
/// next, so only one piece's bundle is in memory at a time. Returns the
/// manifest and the number of points made on cut edges per piece.
pub fn write_partition(
    source: &Bundle,
    source_path: &Path,
    out_dir: &Path,
    req: &PartitionRequest,
    force: bool,
    prepare: &mut dyn FnMut(usize, Bundle) -> Result<Bundle, Box<dyn std::error::Error + Send + Sync>>,
    progress: &mut dyn FnMut(PartitionStage),
) -> Result<(Manifest, Vec<usize>), PartitionError> {
    if non_empty_dir(out_dir) && !force {
        return Err(PartitionError::OutputExists { path: out_dir.to_path_buf() });
    }
    let source_file =
        source_path.file_name().map_or_else(|| source_path.display().to_string(), |n| n.to_string_lossy().into_owned());
    let (crc32, bytes) =
        file_crc32(source_path).map_err(|e| PartitionError::Source { source: e, path: source_path.to_path_buf() })?;
    let Cut { v, tree, leaves } = cut(source, req, progress)?;
    // The temporary directory beside the output, removed on any failure.
    let parent = match out_dir.parent() {
        Some(p) if !p.as_os_str().is_empty() => p.to_path_buf(),
        _ => PathBuf::from("."),
    };
    let tmp = tempfile::Builder::new().prefix(".tetprep-partition-").tempdir_in(&parent).map_err(|source| {
        PartitionError::Write { action: "create a temporary directory in", source, path: parent.clone() }
    })?;
    let count = leaves.len();
    let mut infos = Vec::with_capacity(count);
    let mut new_points = Vec::with_capacity(count);
    for (k, (tets, bounds)) in leaves.into_iter().enumerate() {
        progress(PartitionStage::Converting { index: k, count });
        let p = piece(source, &source_file, &v, k, count, tets, bounds)?;
        let bundle = prepare(k, p.bundle).map_err(|source| PartitionError::Prepare { piece: k, source })?;
        progress(PartitionStage::Writing { index: k, count });
        let file = piece_file_name(k);
        let path = tmp.path().join(&file);
        bundle.write(&path).map_err(|source| PartitionError::WritePiece { piece: k, source })?;
        let (crc32, bytes) =
            file_crc32(&path).map_err(|source| PartitionError::Write { action: "read back", source, path })?;
        infos.push(PieceInfo {
            file,
            bounds,
            tets: bundle.mesh.tets.len() as u64,
            points: bundle.mesh.points.len() as u64,
            volume: bundle.meta.stats.total_volume,
            bytes,
            crc32,
        });
        new_points.push(p.new_points);
    }
    drop(v);
    let info = SourceInfo {
        file: source_file,
        crc32,
        bytes,
        points: source.mesh.points.len() as u64,
        tets: source.mesh.tets.len() as u64,
        total_volume: source.meta.stats.total_volume,
        split: source.meta.split.clone(),
    };
    let mut manifest = manifest_of(source, info, tree, infos);
    manifest.cost = req.cost.id().into();
    let manifest_path = tmp.path().join(MANIFEST_FILE);
    std::fs::write(&manifest_path, manifest.to_json()).map_err(|source| PartitionError::Write {
        action: "write",
        source,
        path: manifest_path,
    })?;
    // Into place: an existing directory (allowed by --force) is moved
    // aside first and removed after the rename.
    let old = if out_dir.exists() {
        let aside = parent.join(format!(
            ".tetprep-partition-old-{}",
            tmp.path().file_name().map_or_else(String::new, |n| n.to_string_lossy().into_owned())
        ));
        std::fs::rename(out_dir, &aside).map_err(|source| PartitionError::Write {
            action: "move aside",
            source,
            path: out_dir.to_path_buf(),
        })?;
        Some(aside)
    } else {
        None
    };
    let tmp_path = tmp.keep();
    if let Err(source) = std::fs::rename(&tmp_path, out_dir) {
        // Put the old directory back; the new one is discarded.
        if let Some(aside) = &old {
            let _ = std::fs::rename(aside, out_dir);
        }
        let _ = std::fs::remove_dir_all(&tmp_path);
        return Err(PartitionError::Write { action: "rename into place", source, path: out_dir.to_path_buf() });
    }
    if let Some(aside) = old {
        if aside.is_dir() {
            let _ = std::fs::remove_dir_all(&aside);
        } else {
            let _ = std::fs::remove_file(&aside);
        }
    }
    Ok((manifest, new_points))
}

#[cfg(test)]
mod tests {
    use super::*;
    use tet_mesh::predicates::signed_tet_volume;
    use tet_mesh::split::{structured_grid_tets, structured_points};
    use tet_mesh::{build_adjacency, check_adjacency, check_tet_mesh, SplitMix64, SplitMode, TetMesh, FACE_OUTWARD};

    /// A `cells` grid over the unit cube (boundary points on the cube's
    /// faces; interior points jittered by up to `jitter` of a cell) with a
    /// random per-vertex scalar, as a bundle; positive tets.
    pub(crate) fn grid_bundle(cells: [usize; 3], jitter: f64, seed: u64) -> Bundle {
        let mut rng = SplitMix64(seed);
        let dims = cells.map(|c| c + 1);
        let points = structured_points(dims, |ijk| {
            std::array::from_fn(|a| {
                let interior = ijk[a] > 0 && ijk[a] < cells[a];
                let wobble = if interior { jitter * (rng.next_f64() - 0.5) } else { 0.0 };
                (ijk[a] as f64 + wobble) / cells[a] as f64
            })
        });
        let mut tets = structured_grid_tets(cells, SplitMode::Five);
        for t in &mut tets {
            let p = |k: usize| &points[t[k] as usize];
            if tet_orientation(p(0), p(1), p(2), p(3)) == TetOrientation::Negative {
                t.swap(0, 1);
            }
        }
        let scalar = (0..points.len()).map(|_| rng.next_f64() * 10.0 - 3.0).collect();
        let mesh = TetMesh { points, tets: tets.into(), scalar_name: "s".into(), scalar, point_fields: vec![] };
        let adjacency = build_adjacency(&mesh.points, &mesh.tets).unwrap();
        Bundle::new(mesh, adjacency, Default::default())
    }

    fn volume(points: &[[f64; 3]], tets: &[[u32; 4]]) -> f64 {
        tets.iter()
            .map(|t| {
                let p = |k: usize| &points[t[k] as usize];
                signed_tet_volume(p(0), p(1), p(2), p(3))
            })
            .sum()
    }

    /// Barycentric coordinates of `x` in the tet, if inside (with a small
    /// tolerance for points on faces).
    fn inside(points: &[[f64; 3]], t: &[u32; 4], x: &[f64; 3]) -> Option<[f64; 4]> {
        let p = |k: usize| &points[t[k] as usize];
        let whole = signed_tet_volume(p(0), p(1), p(2), p(3));
        let mut w = [0.0; 4];
        for k in 0..4 {
            let mut q = [*p(0), *p(1), *p(2), *p(3)];
            q[k] = *x;
            w[k] = signed_tet_volume(&q[0], &q[1], &q[2], &q[3]) / whole;
        }
        w.iter().all(|&b| b > -1e-9).then_some(w)
    }

    /// Every piece: inside its box, valid and conforming (boundary faces
    /// only on its box's faces: the source's boundary is the unit cube),
    /// scalar at every point the source's linear interpolation.
    fn check_pieces(source: &Bundle, part: &Partition, parts: usize) {
        assert_eq!(part.pieces.len(), parts);
        assert_eq!(part.tree.len(), 2 * parts - 1);
        let src = &source.mesh;
        let mut total = 0.0;
        let (lo, hi) = source.scalar_range();
        for (k, p) in part.pieces.iter().enumerate() {
            let m = &p.bundle.mesh;
            check_tet_mesh(m).unwrap_or_else(|e| panic!("piece {k}: {e}"));
            check_adjacency(&m.tets, &p.bundle.adjacency).unwrap();
            assert!(m.points.iter().all(|x| p.bounds.contains(x)), "piece {k} leaves its box");
            for &f in &p.bundle.adjacency.boundary_faces {
                let (t, face) = ((f / 4) as usize, (f % 4) as usize);
                let verts = FACE_OUTWARD[face].map(|c| m.points[m.tets[t][c] as usize]);
                let on_box_face = (0..3).any(|a| {
                    verts.iter().all(|v| v[a] == p.bounds.min[a]) || verts.iter().all(|v| v[a] == p.bounds.max[a])
                });
                assert!(on_box_face, "piece {k}: boundary face {verts:?} inside the box (not conforming)");
            }
            total += volume(&m.points, &m.tets);
            for (x, &s) in m.points.iter().zip(&m.scalar) {
                let (t, w) = src.tets.iter().find_map(|t| inside(&src.points, t, x).map(|w| (t, w))).expect("in a tet");
                let want: f64 = (0..4).map(|c| w[c] * src.scalar[t[c] as usize]).sum();
                assert!((s - want).abs() <= 1e-12 * (hi - lo).max(want.abs()), "piece {k}: {s} vs {want} at {x:?}");
                assert!(lo <= s && s <= hi);
            }
        }
        let want = source.meta.stats.total_volume;
        assert!((total - want).abs() <= 1e-12 * want, "volume {total} vs {want}");
    }

    /// On a Delaunay mesh of points crowded towards x = 0, longest in x (cells small in
    /// every direction there), pieces of equal tet counts have very unequal
    /// surface (expected crossings); the crossings cost balances the surface
    /// instead, the volume kept.
    #[test]
    fn the_crossings_cost_balances_surface_not_count() {
        let mut rng = SplitMix64(11);
        let points: Vec<[f64; 3]> =
            (0..3000).map(|_| [2.0 * rng.next_f64().powi(3), rng.next_f64(), rng.next_f64()]).collect();
        let d = tet_delaunay::tetrahedralize_points(&points, &Default::default()).unwrap();
        let scalar = points.iter().map(|p| p[0] + 2.0 * p[1] - p[2]).collect();
        let mesh = TetMesh { points, tets: d.tets.into(), scalar_name: "s".into(), scalar, point_fields: vec![] };
        let adjacency = build_adjacency(&mesh.points, &mesh.tets).unwrap();
        let source = Bundle::new(mesh, adjacency, Default::default());
        let surface = |b: &Bundle| -> f64 {
            b.mesh.tets.iter().map(|t| TetCost::Crossings.of(&t.map(|v| b.mesh.points[v as usize]))).sum()
        };
        let spread = |cost: TetCost| -> (f64, f64) {
            let part = partition(&source, "g", &PartitionRequest { parts: 2, cost }, &mut |_| {}).unwrap();
            let v: f64 = part.pieces.iter().map(|p| volume(&p.bundle.mesh.points, &p.bundle.mesh.tets)).sum();
            let whole = volume(&source.mesh.points, &source.mesh.tets);
            assert!((v - whole).abs() <= 1e-12 * whole, "{v} {whole}");
            let (a, b) = (surface(&part.pieces[0].bundle), surface(&part.pieces[1].bundle));
            let (ta, tb) = (part.pieces[0].bundle.mesh.tets.len() as f64, part.pieces[1].bundle.mesh.tets.len() as f64);
            ((a - b).abs() / (a + b), (ta - tb).abs() / (ta + tb))
        };
        let (surf_uniform, count_uniform) = spread(TetCost::Uniform);
        let (surf_crossings, count_crossings) = spread(TetCost::Crossings);
        eprintln!("tets: surface spread {surf_uniform:.3}, count spread {count_uniform:.3}; crossings: {surf_crossings:.3}, {count_crossings:.3}");
        assert!(count_uniform < 0.05 && surf_uniform > 0.2, "{count_uniform} {surf_uniform}");
        assert!(surf_crossings < 0.05 && count_crossings > 0.2, "{count_crossings} {surf_crossings}");
    }

    #[test]
    fn pieces_keep_volume_scalar_and_conformity_for_several_counts() {
        let source = grid_bundle([4, 3, 3], 0.6, 7);
        for parts in [1, 2, 3, 4, 7] {
            let req = PartitionRequest { parts, cost: TetCost::Uniform };
            let part = partition(&source, "grid.tetb", &req, &mut |_| {}).unwrap();
            check_pieces(&source, &part, parts);
            if parts > 1 {
                assert!(part.pieces.iter().any(|p| p.new_points > 0), "N = {parts} cut no edge");
            }
            if parts >= 4 {
                // Some tet is cut by two planes: a point lies on both.
                let planes: Vec<(usize, f64)> = part
                    .tree
                    .iter()
                    .filter_map(|n| match n {
                        KdNode::Split { axis, plane, .. } => Some((*axis as usize, *plane)),
                        KdNode::Leaf { .. } => None,
                    })
                    .collect();
                let on_two = part.pieces.iter().flat_map(|p| &p.bundle.mesh.points).any(|x| {
                    planes
                        .iter()
                        .filter(|(a, v)| x[*a] == *v)
                        .map(|(a, _)| *a)
                        .collect::<std::collections::BTreeSet<_>>()
                        .len()
                        >= 2
                });
                assert!(on_two, "N = {parts}: no tet was cut by two planes");
            }
        }
    }

    /// A split whose two children are leaves: the triangles of both
    /// pieces on the plane are the same, compared by coordinates.
    #[test]
    fn cut_faces_on_both_sides_coincide() {
        let source = grid_bundle([3, 3, 4], 0.5, 11);
        for parts in [2, 4, 7] {
            let part =
                partition(&source, "g", &PartitionRequest { parts, cost: TetCost::Uniform }, &mut |_| {}).unwrap();
            let mut checked = 0;
            for node in &part.tree {
                let KdNode::Split { axis, plane, children, .. } = node else { continue };
                let leaf = |n: usize| match part.tree[n] {
                    KdNode::Leaf { piece, .. } => Some(piece),
                    _ => None,
                };
                let (Some(a), Some(b)) = (leaf(children[0]), leaf(children[1])) else { continue };
                let on_plane = |k: usize| {
                    let b = &part.pieces[k].bundle;
                    let mut faces: Vec<[[u64; 3]; 3]> = b
                        .adjacency
                        .boundary_faces
                        .iter()
                        .filter_map(|&f| {
                            let (t, face) = ((f / 4) as usize, (f % 4) as usize);
                            let verts = FACE_OUTWARD[face].map(|c| b.mesh.points[b.mesh.tets[t][c] as usize]);
                            verts.iter().all(|v| v[*axis as usize] == *plane).then(|| {
                                let mut key = verts.map(|v| v.map(f64::to_bits));
                                key.sort();
                                key
                            })
                        })
                        .collect();
                    faces.sort();
                    faces
                };
                let (fa, fb) = (on_plane(a), on_plane(b));
                assert!(!fa.is_empty());
                assert_eq!(fa, fb, "N = {parts}: the cut faces of pieces {a} and {b} differ");
                checked += 1;
            }
            assert!(checked >= 1);
        }
    }

    /// A plane through a grid plane's vertices makes no new point.
    #[test]
    fn a_plane_through_vertices_makes_no_points() {
        let source = grid_bundle([4, 2, 2], 0.0, 3);
        let m = &source.mesh;
        let mut v = Vertices { pos_in_world: m.points.clone(), attrs: m.scalar.clone(), stride: 1 };
        let (below, above) = clip(&mut v, &m.tets, 0, 0.5);
        assert_eq!(v.pos_in_world.len(), m.points.len());
        assert_eq!(below.len() + above.len(), m.tets.len());
        assert_eq!(below.len(), above.len());
    }

    /// Single tets in every configuration against a plane (a vertex alone,
    /// two and two, one or two vertices on the plane): the parts keep the
    /// volume and stay on their sides.
    #[test]
    fn every_clip_case_keeps_the_volume() {
        let mut rng = SplitMix64(5);
        for trial in 0..400 {
            // Coordinates on a coarse lattice so vertices often lie on the plane.
            let mut points: Vec<[f64; 3]> = (0..4)
                .map(|_| std::array::from_fn(|_| (rng.next_f64() * 4.0).floor() - 2.0 + 0.5 * rng.next_f64().round()))
                .collect();
            let o = tet_orientation(&points[0], &points[1], &points[2], &points[3]);
            if o == TetOrientation::Flat {
                continue;
            }
            if o == TetOrientation::Negative {
                points.swap(0, 1);
            }
            let axis = trial % 3;
            let plane = [-1.0, -0.5, 0.0, 0.5, 1.0][trial % 5];
            let tets = [[0u32, 1, 2, 3]];
            let want = volume(&points, &tets);
            let mut v = Vertices { pos_in_world: points.clone(), attrs: vec![0.0; 4], stride: 1 };
            let (below, above) = clip(&mut v, &tets, axis, plane);
            let got = volume(&v.pos_in_world, &below) + volume(&v.pos_in_world, &above);
            assert!((got - want).abs() <= 1e-12 * want, "trial {trial}: {got} vs {want}");
            for t in &below {
                assert!(t.iter().all(|&i| v.pos_in_world[i as usize][axis] <= plane));
                assert_eq!(piece_tet_orientation(&v, t), TetOrientation::Positive);
            }
            for t in &above {
                assert!(t.iter().all(|&i| v.pos_in_world[i as usize][axis] >= plane));
                assert_eq!(piece_tet_orientation(&v, t), TetOrientation::Positive);
            }
        }
    }

    #[test]
    fn time_steps_and_fields_are_cut_too() {
        let mut source = grid_bundle([3, 3, 3], 0.5, 13);
        let n = source.mesh.points.len();
        let s0 = source.mesh.scalar.clone();
        let s1: Vec<f64> = source.mesh.points.iter().map(|p| p[0] * 3.0 - p[2]).collect();
        let g: Vec<Vec<[f64; 3]>> = vec![vec![[1.0, 2.0, 3.0]; n], vec![[3.0, 0.0, -1.0]; n]];
        let steps = TimeSteps::new(vec![0.0, 2.0], vec![s0, s1], vec!["a".into(), "b".into()])
            .unwrap()
            .with_gradients(tet_analysis_method(), g)
            .unwrap();
        source.mesh.point_fields.push(Field::new("v", 3, source.mesh.points.as_flattened().to_vec()));
        source = source.with_steps(steps).unwrap();
        let part =
            partition(&source, "g", &PartitionRequest { parts: 3, cost: TetCost::Uniform }, &mut |_| {}).unwrap();
        for p in &part.pieces {
            let st = p.bundle.steps.as_ref().expect("steps kept");
            assert_eq!(st.times(), &[0.0, 2.0]);
            assert_eq!(st.scalar(0), p.bundle.mesh.scalar.as_slice());
            for (i, x) in p.bundle.mesh.points.iter().enumerate() {
                // Step 1 is linear in the coordinates; the field v is the position.
                assert!((st.scalar(1)[i] - (x[0] * 3.0 - x[2])).abs() < 1e-12);
                assert_eq!(st.gradient(1).unwrap()[i], [3.0, 0.0, -1.0]);
                let f = &p.bundle.mesh.point_fields[0];
                assert_eq!(f.name, "v");
                assert!((0..3).all(|c| (f.values[3 * i + c] - x[c]).abs() < 1e-12));
            }
        }
    }

    /// A source with gradients and histograms: the pieces carry the
    /// gradients cut with the mesh, and histograms over the source's axes
    /// whose bins add up to the source's.
    #[test]
    fn the_analysis_is_cut_too() {
        use tet_analysis::{AnalysisOptions, Analyzer, GradientMethod, HistogramOptions};
        let grid = grid_bundle([3, 3, 3], 0.5, 19);
        let mut mesh = grid.mesh.clone();
        mesh.scalar = mesh.points.iter().map(|p| p[0] + 2.0 * p[1] + 3.0 * p[2]).collect();
        let opts = AnalysisOptions {
            gradients: Some(GradientMethod::LeastSquares),
            histogram: Some(HistogramOptions { scalar_bins: 16, gradient_bins: 8, ..Default::default() }),
            ..Default::default()
        };
        let analysis = Analyzer::from_mesh(&mesh).unwrap().analyze(&opts).unwrap();
        let source = Bundle::new(mesh, grid.adjacency.clone(), Default::default()).with_analysis(analysis);
        let part =
            partition(&source, "g", &PartitionRequest { parts: 4, cost: TetCost::Uniform }, &mut |_| {}).unwrap();
        let whole = source.analysis.as_ref().unwrap().histograms.as_ref().unwrap();
        let mut bins = vec![0.0; whole.scalar.len()];
        for p in &part.pieces {
            let a = p.bundle.analysis.as_ref().expect("the piece is analysed");
            let g = a.gradients.as_ref().expect("gradients cut");
            assert_eq!(g.per_point.len(), p.bundle.mesh.points.len());
            for v in &g.per_point {
                assert!((0..3).all(|c| (v[c] - [1.0, 2.0, 3.0][c]).abs() < 1e-9), "{v:?}");
            }
            let h = a.histograms.as_ref().unwrap();
            assert_eq!((h.scalar_axis, h.gradient_axis), (whole.scalar_axis, whole.gradient_axis));
            for (b, v) in bins.iter_mut().zip(&h.scalar) {
                *b += v;
            }
        }
        let total = source.meta.stats.total_volume;
        for (b, w) in bins.iter().zip(&whole.scalar) {
            assert!((b - w).abs() <= 1e-12 * total, "{b} vs {w}");
        }
    }

    /// A point field of NaN and infinities (fields other than the scalar
    /// are not checked for finiteness) is cut without a panic.
    #[test]
    fn non_finite_fields_are_carried() {
        let mut source = grid_bundle([2, 2, 2], 0.3, 23);
        let n = source.mesh.points.len();
        let values = (0..n).map(|i| [f64::NAN, f64::INFINITY, -1.0][i % 3]).collect();
        source.mesh.point_fields.push(Field::new("odd", 1, values));
        let part =
            partition(&source, "g", &PartitionRequest { parts: 3, cost: TetCost::Uniform }, &mut |_| {}).unwrap();
        assert!(part.pieces.iter().all(|p| p.bundle.mesh.point_fields[0].name == "odd"));
    }

    fn tet_analysis_method() -> tet_analysis::GradientMethod {
        tet_analysis::GradientMethod::LeastSquares
    }

    #[test]
    fn bad_part_counts_are_errors() {
        let source = grid_bundle([1, 1, 1], 0.0, 1);
        let req = |parts| PartitionRequest { parts, cost: TetCost::Uniform };
        assert!(matches!(partition(&source, "g", &req(0), &mut |_| {}), Err(PartitionError::NoParts)));
        assert!(matches!(
            partition(&source, "g", &req(6), &mut |_| {}),
            Err(PartitionError::TooManyParts { parts: 6, tets: 5 })
        ));
        assert!(partition(&source, "g", &req(5), &mut |_| {}).is_ok());
        let mut short = source;
        short.mesh.point_fields.push(Field::new("f", 2, vec![0.0; 3]));
        assert!(matches!(partition(&short, "g", &req(2), &mut |_| {}), Err(PartitionError::BadSource { .. })));
    }

    #[test]
    fn written_partitions_load_and_verify() {
        let source = grid_bundle([3, 2, 2], 0.4, 17);
        let dir = tempfile::tempdir().unwrap();
        let src_path = dir.path().join("g.tetb");
        source.write(&src_path).unwrap();
        let out = dir.path().join("parts");
        let req = PartitionRequest { parts: 3, cost: TetCost::Uniform };
        let (m, _) = write_partition(&source, &src_path, &out, &req, false, &mut |_, b| Ok(b), &mut |_| {}).unwrap();
        let back = Manifest::load(&out.join(MANIFEST_FILE), true).unwrap();
        assert_eq!(back, m);
        assert_eq!(back.front_to_back([-5.0, 0.5, 0.5]).len(), 3);
        // An existing directory is refused without force, replaced with it.
        assert!(matches!(
            write_partition(&source, &src_path, &out, &req, false, &mut |_, b| Ok(b), &mut |_| {}),
            Err(PartitionError::OutputExists { .. })
        ));
        write_partition(&source, &src_path, &out, &req, true, &mut |_, b| Ok(b), &mut |_| {}).unwrap();
        Manifest::load(&out.join(MANIFEST_FILE), true).unwrap();
        let leftovers: Vec<_> = std::fs::read_dir(dir.path()).unwrap().map(|e| e.unwrap().file_name()).collect();
        assert_eq!(leftovers.len(), 2, "{leftovers:?}");
        // A flipped byte in a piece: the checksum names the piece.
        let p1 = out.join(piece_file_name(1));
        let mut bytes = std::fs::read(&p1).unwrap();
        let last = bytes.len() - 1;
        bytes[last] ^= 0x40;
        std::fs::write(&p1, &bytes).unwrap();
        let e = Manifest::load(&out.join(MANIFEST_FILE), true).unwrap_err();
        assert!(matches!(e, tet_bundle::ManifestError::PieceChecksum { piece: 1, .. }), "{e}");
        assert!(e.to_string().contains("piece 1") && e.to_string().contains("piece_0001.tetb"));
        std::fs::remove_file(out.join(piece_file_name(2))).unwrap();
        std::fs::remove_file(&p1).unwrap();
        let e = Manifest::load(&out.join(MANIFEST_FILE), true).unwrap_err();
        assert!(matches!(e, tet_bundle::ManifestError::MissingPiece { piece: 1, .. }), "{e}");
    }
}
