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
/// `tet_mesh::tetrahedralize` will merge them (same function, same
/// tolerance), so the later merge collapses no tet. Points with a
/// non-finite coordinate are an error naming the point, unless
/// `skip_non_finite`.
pub fn triangulate_cloud(
    source: &mut SourceMesh,
    mode: CloudMode,
    opts: &DelaunayOptions,
    merge_tolerance_rel: f64,
    skip_non_finite: bool,
) -> Result<CloudReport, DelaunayError> {
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
    let rep = merge_duplicate_points(&source.points, tolerance);
    // Distinct finite points, by source index.
    let distinct: Vec<u32> = (0..source.points.len() as u32)
        .filter(|&i| rep[i as usize] == i && finite(&source.points[i as usize]))
        .collect();
    let mut report = CloudReport {
        mode,
        distinct_points: distinct.len(),
        skipped_non_finite: skipped,
        tets: 0,
        removed_cells: 0,
        fills_convex_hull: false,
        layers: 0,
        columns: 0,
        neighbors: None,
        merged_into: Vec::new(),
    };
    let tets: Vec<[u32; 4]> = match mode {
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
            let tets = d.tets.iter().map(|t| t.map(|v| distinct[v as usize])).collect();
            report.neighbors = Some(d.neighbors);
            tets
        }
        CloudMode::Layered => {
            let (layers, ids) = layers_from_columns(&source.points, &distinct)?;
            report.layers = layers.len();
            report.columns = layers[0].len();
            let l = tetrahedralize_layers(&layers)?;
            l.tets.iter().map(|t| t.map(|v| ids[v as usize])).collect()
        }
    };
    report.tets = tets.len();
    let mut cells = Cells::new();
    cells.types.reserve(tets.len());
    cells.offsets.reserve(tets.len());
    cells.connectivity.reserve(tets.len() * 4);
    for t in &tets {
        cells.push(CellType::Tetra, t);
    }
    source.blocks = vec![Block::Unstructured(cells)];
    // Cell fields of a point cloud would not match the new cells.
    source.cell_fields.clear();
    report.merged_into = rep;
    Ok(report)
}

/// Groups points into xy columns (exact x and y), sorts each by z, and
/// returns the layers (layer k = the k-th lowest point of every column, in
/// column order of first appearance) with the source index of each
/// flattened point `k * columns + c`.
/// Layers of points, and the source index of each flattened point.
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
}
