//! Layered (2.5D) tetrahedralization: one xy triangulation, prisms between
//! consecutive layers, each prism split by tetkit's conforming min-id rule.

use crate::error::DelaunayError;
use crate::predicates::orient;
use spade::{DelaunayTriangulation, HasPosition, Point2, Triangulation as _};
use tet_mesh::split::split_wedge;

/// A layered tetrahedralization.
#[derive(Debug, Clone)]
pub struct Layered {
    /// Positively oriented tets over the layers' points flattened in order:
    /// point `i` of layer `k` has id `k * columns + i`.
    pub tets: Vec<[u32; 4]>,
    /// Points per layer (the xy columns).
    pub columns: usize,
    /// Triangles of the xy Delaunay triangulation of layer 0.
    pub triangles: usize,
}

struct Column {
    pos: Point2<f64>,
    id: u32,
}

impl HasPosition for Column {
    type Scalar = f64;
    fn position(&self) -> Point2<f64> {
        self.pos
    }
}

/// Tetrahedralizes points on layers that share their xy columns: point `i`
/// of every layer belongs to column `i`, whose xy is taken from layer 0 and
/// whose z must rise strictly from each layer to the next. Layer 0's xy is
/// Delaunay-triangulated (spade); each triangle and pair of consecutive
/// layers makes a prism (a wedge), split into 3 tets so that neighbouring
/// prisms conform. Prisms with vertical sides and rising z are convex, so
/// every tet is positive; this is checked exactly all the same.
pub fn tetrahedralize_layers(layers: &[Vec<[f64; 3]>]) -> Result<Layered, DelaunayError> {
    if layers.len() < 2 {
        return Err(DelaunayError::TooFewLayers(layers.len()));
    }
    let n = layers[0].len();
    for (layer, l) in layers.iter().enumerate() {
        if l.len() != n {
            return Err(DelaunayError::LayerSizeMismatch { layer, expected: n, found: l.len() });
        }
    }
    let total = n.checked_mul(layers.len()).filter(|&t| t < u32::MAX as usize);
    let Some(_) = total else {
        return Err(DelaunayError::TooManyPoints { count: n.saturating_mul(layers.len()) });
    };
    for (k, l) in layers.iter().enumerate() {
        if let Some(i) = l.iter().position(|p| !p.iter().all(|c| c.is_finite())) {
            return Err(DelaunayError::NonFinite { index: k * n + i, coords: l[i] });
        }
    }
    for (k, pair) in layers.windows(2).enumerate() {
        for (column, (lo, hi)) in pair[0].iter().zip(&pair[1]).enumerate() {
            if hi[2] <= lo[2] {
                let (z_lower, z_upper) = (lo[2], hi[2]);
                return Err(DelaunayError::LayersNotAscending { layer: k + 1, column, z_lower, z_upper });
            }
        }
    }
    // Distinct columns: spade would silently merge duplicates.
    let mut by_xy: Vec<(u64, u64, usize)> =
        layers[0].iter().enumerate().map(|(i, p)| ((p[0] + 0.0).to_bits(), (p[1] + 0.0).to_bits(), i)).collect();
    by_xy.sort_unstable();
    for w in by_xy.windows(2) {
        if w[0].0 == w[1].0 && w[0].1 == w[1].1 {
            return Err(DelaunayError::DuplicateColumn { first: w[0].2, second: w[1].2 });
        }
    }
    let mut dt: DelaunayTriangulation<Column> = DelaunayTriangulation::new();
    for (i, p) in layers[0].iter().enumerate() {
        dt.insert(Column { pos: Point2::new(p[0], p[1]), id: i as u32 })
            .map_err(|e| DelaunayError::Planar { index: i, reason: format!("{e:?}") })?;
    }
    if dt.num_inner_faces() == 0 {
        return Err(DelaunayError::CollinearColumns { columns: n });
    }
    let mut triangles: Vec<[u32; 3]> = dt
        .inner_faces()
        .map(|f| {
            let [a, b, c] = f.vertices().map(|v| v.data().id);
            // Counter-clockwise seen from +z, as the wedge's bottom face
            // must be (spade's faces are; this guards the contract).
            let p = |i: u32| robust::Coord { x: layers[0][i as usize][0], y: layers[0][i as usize][1] };
            if robust::orient2d(p(a), p(b), p(c)) > 0.0 {
                [a, b, c]
            } else {
                [a, c, b]
            }
        })
        .collect();
    triangles.sort_unstable();
    let pt = |id: u32| &layers[id as usize / n][id as usize % n];
    let mut tets = Vec::with_capacity(triangles.len() * 3 * (layers.len() - 1));
    for k in 0..layers.len() - 1 {
        let (lo, hi) = ((k * n) as u32, ((k + 1) * n) as u32);
        for t in &triangles {
            let w = [lo + t[0], lo + t[1], lo + t[2], hi + t[0], hi + t[1], hi + t[2]];
            split_wedge(&w, &mut |tet| tets.push(tet));
        }
    }
    if let Some(bad) = tets.iter().find(|t| orient(pt(t[0]), pt(t[1]), pt(t[2]), pt(t[3])) <= 0.0) {
        // Unreachable for rising layers over a valid xy triangulation; kept
        // as an exact guard rather than a silent inverted tet.
        let index = bad[0] as usize;
        return Err(DelaunayError::Planar { index, reason: format!("prism tet {bad:?} is not positively oriented") });
    }
    Ok(Layered { tets, columns: n, triangles: triangles.len() })
}
