//! Point clouds as they come from files: a [`SourceMesh`] with points and
//! fields but no cells, turned into one with tet cells so the ordinary
//! conversion (validation, adjacency, bundle) takes over.

use crate::{tetrahedralize_layers, tetrahedralize_points, DelaunayError, DelaunayOptions};
use std::collections::HashMap;
use tet_mesh::convert::bbox_diagonal;
use tet_mesh::merge::merge_duplicate_points;
use tet_mesh::{Block, CellType, Cells, SourceMesh};

/// How a point cloud becomes tets.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum CloudMode {
    /// 3D Delaunay of the whole cloud (its convex hull, unless
    /// `max_circumradius` peels off hull-filling cells).
    #[default]
    Delaunay,
    /// Points on layers sharing xy columns: prisms between consecutive layers.
    Layered,
}

/// What [`triangulate_cloud`] did.
#[derive(Debug, Clone, PartialEq)]
pub struct CloudReport {
    pub mode: CloudMode,
    /// Distinct points tetrahedralized (after merging duplicates).
    pub distinct_points: usize,
    /// Non-finite points skipped (only with `skip_non_finite`).
    pub skipped_non_finite: usize,
    pub tets: usize,
    /// Delaunay: cells removed by `max_circumradius`.
    pub removed_cells: usize,
    /// Delaunay: the tets fill the convex hull (nothing removed), so MPVO
    /// visibility sorting is exact on them.
    pub fills_convex_hull: bool,
    /// Layered: layers and columns found.
    pub layers: usize,
    pub columns: usize,
    /// Delaunay: the triangulation's face adjacency, one entry per cell in
    /// the order of the new cell list (see [`crate::Delaunay::neighbors`]),
    /// for `tet_mesh::adjacency_from_neighbors` once the cells are tets.
    pub neighbors: Option<Vec<[u32; 4]>>,
    /// The duplicate merge the triangulation used (each point's
    /// representative), for `tet_mesh::tetrahedralize_merged`, so the
    /// conversion does not merge the points a second time.
    pub merged_into: Vec<u32>,
}

/// Replaces the (empty) cell list of a point-cloud `source` with tets over
/// its points. Duplicates within `merge_tolerance_rel` × the bounding-box
/// diagonal are left out of the triangulation exactly as
/// `tet_mesh::tetrahedralize` would merge them (the representatives of
/// `merge_duplicate_points`, same tolerance), so the later merge collapses
/// no tet. The Delaunay mode triangulates first, merging identical points
/// only, and merges within the tolerance first (then triangulates again)
/// only when an edge of the result is short enough for two points to be
/// that close (`near_pair_possible`): the usual cloud is merged once. Points with a
/// non-finite coordinate are an error naming the point, unless
/// `skip_non_finite`.
pub fn triangulate_cloud(
    source: &mut SourceMesh,
    mode: CloudMode,
    opts: &DelaunayOptions,
    merge_tolerance_rel: f64,
    skip_non_finite: bool,
) -> Result<CloudReport, DelaunayError> {
    let (tets, report) = tetrahedralize_cloud(source, mode, opts, merge_tolerance_rel, skip_non_finite)?;
    source.blocks = vec![Block::Unstructured(tet_cells(&tets))];
    // Cell fields of a point cloud would not match the new cells.
    source.cell_fields.clear();
    Ok(report)
}

/// One tetra cell a tet, built in parallel.
fn tet_cells(tets: &[[u32; 4]]) -> Cells {
    use rayon::prelude::*;
    Cells {
        types: vec![CellType::Tetra; tets.len()],
        offsets: (0..=tets.len()).into_par_iter().map(|i| 4 * i).collect(),
        connectivity: tets.par_iter().flat_map_iter(|t| t.iter().copied()).collect(),
    }
}

/// [`triangulate_cloud`] without the cell list: the tets over
/// `source.points` (source ids) and the report, for a conversion that takes
/// them as they are (`tet_mesh::tetrahedralize_tets`). In either mode every
/// tet is positively oriented by exact predicates on `source.points`
/// (`tet_mesh::GivenOrientation::ExactlyPositive`). `source` is not
/// changed.
pub fn tetrahedralize_cloud(
    source: &SourceMesh,
    mode: CloudMode,
    opts: &DelaunayOptions,
    merge_tolerance_rel: f64,
    skip_non_finite: bool,
) -> Result<(Vec<[u32; 4]>, CloudReport), DelaunayError> {
    if source.points.is_empty() {
        return Err(DelaunayError::NoPoints);
    }
    let finite = |p: &[f64; 3]| p.iter().all(|c| c.is_finite());
    let mut skipped = 0;
    if let Some(i) = source.points.iter().position(|p| !finite(p)) {
        if !skip_non_finite {
            return Err(DelaunayError::NonFinite { index: i, coords: source.points[i] });
        }
        skipped = source.points.iter().filter(|p| !finite(p)).count();
    }
    let tolerance = merge_tolerance_rel * bbox_diagonal(&source.points);
    let mut report = CloudReport {
        mode,
        distinct_points: 0,
        skipped_non_finite: skipped,
        tets: 0,
        removed_cells: 0,
        fills_convex_hull: false,
        layers: 0,
        columns: 0,
        neighbors: None,
        merged_into: Vec::new(),
    };
    // Delaunay of the whole cloud first, merging only identical points
    // (the triangulation's own merge), when that is provably the same as
    // merging within the tolerance first: see `near_pair_possible`.
    let first_try = match mode {
        CloudMode::Delaunay if opts.max_circumradius.is_none() => {
            let finite_ids: Option<Vec<u32>> = (skipped > 0)
                .then(|| (0..source.points.len() as u32).filter(|&i| finite(&source.points[i as usize])).collect());
            let owned: Vec<[f64; 3]>;
            let pts: &[[f64; 3]] = match &finite_ids {
                None => &source.points,
                Some(ids) => {
                    owned = ids.iter().map(|&i| source.points[i as usize]).collect();
                    &owned
                }
            };
            let d = tetrahedralize_points(pts, opts).map_err(|e| match (e, &finite_ids) {
                (DelaunayError::NonFinite { index, coords }, Some(ids)) => {
                    DelaunayError::NonFinite { index: ids[index] as usize, coords }
                }
                (other, _) => other,
            })?;
            if near_pair_possible(pts, &d.tets, tolerance) {
                None
            } else {
                Some((d, finite_ids))
            }
        }
        _ => None,
    };
    let (tets, rep): (Vec<[u32; 4]>, Vec<u32>) = match first_try {
        Some((d, finite_ids)) => {
            report.distinct_points = d.merged_into.len() - d.duplicates;
            report.removed_cells = d.removed_cells;
            report.fills_convex_hull = d.fills_convex_hull();
            report.neighbors = Some(d.neighbors);
            match finite_ids {
                None => (d.tets, d.merged_into),
                Some(ids) => {
                    let mut rep: Vec<u32> = (0..source.points.len() as u32).collect();
                    for (k, &i) in ids.iter().enumerate() {
                        rep[i as usize] = ids[d.merged_into[k] as usize];
                    }
                    (d.tets.iter().map(|t| t.map(|v| ids[v as usize])).collect(), rep)
                }
            }
        }
        None => {
            let rep = merge_duplicate_points(&source.points, tolerance);
            // Distinct finite points, by source index.
            let distinct: Vec<u32> = (0..source.points.len() as u32)
                .filter(|&i| rep[i as usize] == i && finite(&source.points[i as usize]))
                .collect();
            report.distinct_points = distinct.len();
            let tets = match mode {
                CloudMode::Delaunay => {
                    let pts: Vec<[f64; 3]> = distinct.iter().map(|&i| source.points[i as usize]).collect();
                    let d = tetrahedralize_points(&pts, opts).map_err(|e| match e {
                        DelaunayError::NonFinite { index, coords } => {
                            DelaunayError::NonFinite { index: distinct[index] as usize, coords }
                        }
                        other => other,
                    })?;
                    report.removed_cells = d.removed_cells;
                    report.fills_convex_hull = d.fills_convex_hull();
                    report.neighbors = Some(d.neighbors);
                    d.tets.iter().map(|t| t.map(|v| distinct[v as usize])).collect()
                }
                CloudMode::Layered => {
                    let (layers, ids) = layers_from_columns(&source.points, &distinct)?;
                    report.layers = layers.len();
                    report.columns = layers[0].len();
                    let l = tetrahedralize_layers(&layers)?;
                    l.tets.iter().map(|t| t.map(|v| ids[v as usize])).collect()
                }
            };
            (tets, rep)
        }
    };
    report.tets = tets.len();
    report.merged_into = rep;
    Ok((tets, report))
}

/// Groups points into xy columns (exact x and y), sorts each by z, and
/// returns the layers (layer k = the k-th lowest point of every column, in
/// column order of first appearance) with the source index of each
/// flattened point `k * columns + c`.
/// Layers of points, and the source index of each flattened point.
/// Whether two distinct points of a triangulated cloud may lie within
/// `tolerance` of each other on every axis (the test of
/// `merge_duplicate_points`). Such a pair is at most √3·tolerance apart,
/// and a point's nearest other point is joined to it by an edge of every
/// Delaunay tetrahedralization (the ball on that segment as diameter holds
/// no other point, not even on its boundary). So when no edge of `tets` is
/// that short, merging within the tolerance first would have merged only
/// identical points — what [`tetrahedralize_points`] did itself. The
/// margin covers the rounding of the squared lengths; a false alarm only
/// costs the merge-first path.
fn near_pair_possible(pts: &[[f64; 3]], tets: &[[u32; 4]], tolerance: f64) -> bool {
    use rayon::prelude::*;
    // Not positive or not finite: `merge_duplicate_points` merges only
    // identical points.
    if !(tolerance > 0.0 && tolerance.is_finite()) {
        return false;
    }
    let reach2 = 3.0 * tolerance * tolerance * (1.0 + 1e-6);
    const EDGES: [(usize, usize); 6] = [(0, 1), (0, 2), (0, 3), (1, 2), (1, 3), (2, 3)];
    tets.par_iter().with_min_len(1 << 14).any(|t| {
        EDGES.iter().any(|&(a, b)| {
            let (p, q) = (&pts[t[a] as usize], &pts[t[b] as usize]);
            let d2 = (p[0] - q[0]).powi(2) + (p[1] - q[1]).powi(2) + (p[2] - q[2]).powi(2);
            d2 <= reach2
        })
    })
}

type LayersWithIds = (Vec<Vec<[f64; 3]>>, Vec<u32>);

fn layers_from_columns(points: &[[f64; 3]], distinct: &[u32]) -> Result<LayersWithIds, DelaunayError> {
    let mut column_of: HashMap<[u64; 2], usize> = HashMap::new();
    let mut columns: Vec<Vec<u32>> = Vec::new();
    for &i in distinct {
        let p = points[i as usize];
        let key = [(p[0] + 0.0).to_bits(), (p[1] + 0.0).to_bits()];
        let c = *column_of.entry(key).or_insert_with(|| {
            columns.push(Vec::new());
            columns.len() - 1
        });
        columns[c].push(i);
    }
    let min = columns.iter().map(Vec::len).min().unwrap_or(0);
    let max = columns.iter().map(Vec::len).max().unwrap_or(0);
    if min != max {
        return Err(DelaunayError::UnevenColumns { columns: columns.len(), min, max });
    }
    if max < 2 {
        return Err(DelaunayError::TooFewLayers(max));
    }
    for col in &mut columns {
        col.sort_by(|&a, &b| points[a as usize][2].total_cmp(&points[b as usize][2]));
    }
    let layers: Vec<Vec<[f64; 3]>> =
        (0..max).map(|k| columns.iter().map(|col| points[col[k] as usize]).collect()).collect();
    let ids: Vec<u32> = (0..max).flat_map(|k| columns.iter().map(move |col| col[k])).collect();
    Ok((layers, ids))
}

#[cfg(test)]
mod tests {
    use super::*;
    use tet_mesh::Field;

    fn cloud(points: Vec<[f64; 3]>) -> SourceMesh {
        let n = points.len();
        SourceMesh {
            points,
            point_fields: vec![Field::new("v", 1, (0..n).map(|i| i as f64).collect())],
            ..Default::default()
        }
    }

    #[test]
    fn duplicates_are_left_out_and_tets_refer_to_source_ids() {
        let mut pts = tet_mesh::split::structured_points([3; 3], |p| p.map(|x| x as f64));
        pts.push([2.0, 2.0, 2.0]); // duplicate of point 26
        let mut src = cloud(pts);
        let r = triangulate_cloud(&mut src, CloudMode::Delaunay, &DelaunayOptions::default(), 1e-10, false).unwrap();
        assert_eq!(r.distinct_points, 27);
        assert!(r.fills_convex_hull);
        let Block::Unstructured(cells) = &src.blocks[0] else { panic!() };
        assert_eq!(cells.len(), r.tets);
        assert!(cells.connectivity.iter().all(|&v| v != 27), "the duplicate is never used");
        // The ordinary conversion accepts it with nothing flat or flipped.
        let (m, rep) = tet_mesh::tetrahedralize(&src, &Default::default(), &mut |_| {}).unwrap();
        assert_eq!(m.tets.len(), r.tets);
        assert_eq!(m.points.len(), 27);
        assert!(rep.findings.iter().any(|f| matches!(f, tet_mesh::Finding::MergedDuplicatePoints { count: 1, .. })));
        assert!(!rep.findings.iter().any(|f| matches!(
            f,
            tet_mesh::Finding::ReorientedTets { .. } | tet_mesh::Finding::DroppedZeroVolumeTets { .. }
        )));
    }

    #[test]
    fn layered_columns_are_found_in_any_order() {
        // 3×3 columns, 3 layers, listed column by column and top-down.
        let mut pts = Vec::new();
        for j in 0..3 {
            for i in 0..3 {
                for k in (0..3).rev() {
                    pts.push([i as f64, j as f64 * 1.5, k as f64 + 0.1 * (i + j) as f64]);
                }
            }
        }
        let mut src = cloud(pts);
        let r = triangulate_cloud(&mut src, CloudMode::Layered, &DelaunayOptions::default(), 0.0, false).unwrap();
        assert_eq!((r.layers, r.columns), (3, 9));
        let (m, _) = tet_mesh::tetrahedralize(&src, &Default::default(), &mut |_| {}).unwrap();
        let vol: f64 = m
            .tets
            .iter()
            .map(|t| {
                tet_mesh::predicates::signed_tet_volume(
                    &m.points[t[0] as usize],
                    &m.points[t[1] as usize],
                    &m.points[t[2] as usize],
                    &m.points[t[3] as usize],
                )
            })
            .sum();
        assert!((vol - 2.0 * 3.0 * 2.0).abs() < 1e-9, "{vol}");
    }

    #[test]
    fn uneven_columns_and_non_finite_points_are_errors() {
        let mut src = cloud(vec![[0., 0., 0.], [0., 0., 1.], [1., 0., 0.], [1., 0., 1.], [0., 1., 0.]]);
        let e = triangulate_cloud(&mut src, CloudMode::Layered, &DelaunayOptions::default(), 0.0, false).unwrap_err();
        assert_eq!(e, DelaunayError::UnevenColumns { columns: 3, min: 1, max: 2 });
        let mut src = cloud(vec![[0., 0., 0.], [1., 0., 0.], [0., 1., 0.], [0., 0., 1.], [f64::NAN, 0., 0.]]);
        let e = triangulate_cloud(&mut src, CloudMode::Delaunay, &DelaunayOptions::default(), 0.0, false).unwrap_err();
        assert!(matches!(e, DelaunayError::NonFinite { index: 4, .. }));
        let r = triangulate_cloud(&mut src, CloudMode::Delaunay, &DelaunayOptions::default(), 0.0, true).unwrap();
        assert_eq!((r.skipped_non_finite, r.tets), (1, 1));
    }

    /// Random points with exact copies, near copies (within the merge
    /// tolerance on every axis, not identical) and non-finite points.
    fn noisy_cloud(seed: u64, near: bool) -> Vec<[f64; 3]> {
        let mut rng = crate::SplitMix64(seed);
        let mut pts: Vec<[f64; 3]> = (0..400).map(|_| [rng.next_f64(), rng.next_f64(), rng.next_f64()]).collect();
        for k in 0..40 {
            let p = pts[k * 7];
            pts.push(p); // an exact copy, later in the list
            if near && k % 4 == 0 {
                // Within 1e-10 × the diagonal on every axis.
                pts.push([p[0] + 3e-11, p[1] - 2e-11, p[2] + 1e-11]);
            }
        }
        pts.insert(17, [f64::NAN, 0.5, 0.5]);
        pts.push([0.5, f64::INFINITY, 0.5]);
        pts
    }

    /// The conversion's view of a cloud: each point's representative and
    /// the tets in source ids.
    fn triangulated(pts: Vec<[f64; 3]>, opts: &DelaunayOptions) -> (CloudReport, Vec<[u32; 4]>) {
        let mut src = cloud(pts);
        let r = triangulate_cloud(&mut src, CloudMode::Delaunay, opts, 1e-10, true).unwrap();
        let Block::Unstructured(cells) = &src.blocks[0] else { panic!() };
        let tets = (0..cells.len()).map(|c| <[u32; 4]>::try_from(cells.nodes(c)).unwrap()).collect();
        (r, tets)
    }

    /// Triangulating first and merging only identical points (the fast
    /// path) gives what merging within the tolerance first gives whenever
    /// no two points are that close; near copies take the merge-first path.
    #[test]
    fn merge_within_tolerance_is_kept_with_or_without_near_copies() {
        for near in [false, true] {
            let pts = noisy_cloud(7, near);
            let n = pts.len();
            let diag = bbox_diagonal(&pts);
            let expected = merge_duplicate_points(&pts, 1e-10 * diag);
            let (r, tets) = triangulated(pts.clone(), &DelaunayOptions::default());
            assert_eq!(r.merged_into, expected, "near copies: {near}");
            let finite = pts.iter().filter(|p| p.iter().all(|c| c.is_finite())).count();
            let merged = expected.iter().enumerate().filter(|&(i, &m)| m as usize != i).count();
            assert_eq!((r.skipped_non_finite, r.distinct_points), (2, finite - merged));
            // Only finite representatives are used, each tet positive.
            assert!(tets.iter().flatten().all(|&v| (v as usize) < n && expected[v as usize] == v));
            assert!(tets.iter().flatten().all(|&v| pts[v as usize].iter().all(|c| c.is_finite())));
            let p = |v: u32| &pts[v as usize];
            assert!(tets.iter().all(|t| crate::predicates::orient(p(t[0]), p(t[1]), p(t[2]), p(t[3])) > 0.0));
            // The hull is filled: the tets' volume is the convex hull's,
            // the same whichever path ran (compare with peeling off
            // nothing, which always merges first).
            let (r2, tets2) = triangulated(pts.clone(), &DelaunayOptions { max_circumradius: Some(1e9) });
            assert_eq!((r2.merged_into, r2.distinct_points), (r.merged_into.clone(), r.distinct_points));
            let vol = |ts: &[[u32; 4]]| -> f64 {
                ts.iter().map(|t| tet_mesh::predicates::signed_tet_volume(p(t[0]), p(t[1]), p(t[2]), p(t[3]))).sum()
            };
            assert!((vol(&tets) - vol(&tets2)).abs() < 1e-12, "near copies: {near}");
            assert_eq!(tets.len(), tets2.len());
        }
    }
}
