//! Size statistics of a tetrahedral mesh (what `tetprep info` prints).

use crate::predicates::{dist2, signed_tet_volume};
use rayon::prelude::*;
use serde::{Deserialize, Serialize};

/// Minimum, median and maximum of a per-cell quantity.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize, Default)]
pub struct Spread {
    pub min: f64,
    pub median: f64,
    pub max: f64,
}

impl Spread {
    fn of(mut v: Vec<f64>) -> Spread {
        if v.is_empty() {
            return Spread::default();
        }
        let mid = v.len() / 2;
        let (_, median, _) = v.select_nth_unstable_by(mid, f64::total_cmp);
        let median = *median;
        let min = v.par_iter().copied().reduce(|| f64::INFINITY, f64::min);
        let max = v.par_iter().copied().reduce(|| f64::NEG_INFINITY, f64::max);
        Spread { min, median, max }
    }
}

/// Geometry facts of a mesh.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize, Default)]
pub struct MeshStats {
    pub bounds_min: [f64; 3],
    pub bounds_max: [f64; 3],
    pub total_volume: f64,
    pub tet_volume: Spread,
    /// Over all six edges of every tet (shared edges counted per tet).
    pub edge_length: Spread,
    /// Largest distance between two vertices of one tet: its longest edge.
    pub max_cell_diameter: f64,
    pub scalar_min: f64,
    pub scalar_max: f64,
}

const EDGES: [(usize, usize); 6] = [(0, 1), (0, 2), (0, 3), (1, 2), (1, 3), (2, 3)];

/// Computes [`MeshStats`]; volumes and lengths in the mesh's units.
pub fn mesh_stats(points: &[[f64; 3]], tets: &[[u32; 4]], scalar: &[f64]) -> MeshStats {
    let mut lo = [f64::INFINITY; 3];
    let mut hi = [f64::NEG_INFINITY; 3];
    for p in points {
        for a in 0..3 {
            lo[a] = lo[a].min(p[a]);
            hi[a] = hi[a].max(p[a]);
        }
    }
    let volumes: Vec<f64> = tets
        .par_iter()
        .map(|t| {
            let p = |k: usize| &points[t[k] as usize];
            signed_tet_volume(p(0), p(1), p(2), p(3))
        })
        .collect();
    let edges: Vec<f64> = tets
        .par_iter()
        .flat_map_iter(|t| EDGES.iter().map(move |&(a, b)| dist2(&points[t[a] as usize], &points[t[b] as usize]).sqrt()))
        .collect();
    let total_volume = volumes.par_iter().sum();
    let edge_length = Spread::of(edges);
    MeshStats {
        bounds_min: lo,
        bounds_max: hi,
        total_volume,
        tet_volume: Spread::of(volumes),
        max_cell_diameter: edge_length.max,
        edge_length,
        scalar_min: scalar.iter().copied().fold(f64::INFINITY, f64::min),
        scalar_max: scalar.iter().copied().fold(f64::NEG_INFINITY, f64::max),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn unit_tet_stats() {
        let p = [[0., 0., 0.], [1., 0., 0.], [0., 1., 0.], [0., 0., 1.]];
        let s = mesh_stats(&p, &[[0, 1, 2, 3]], &[1.0, 2.0, 3.0, 4.0]);
        assert!((s.total_volume - 1.0 / 6.0).abs() < 1e-15);
        assert!((s.max_cell_diameter - 2f64.sqrt()).abs() < 1e-15);
        assert_eq!(s.edge_length.min, 1.0);
        assert_eq!((s.scalar_min, s.scalar_max), (1.0, 4.0));
    }
}
