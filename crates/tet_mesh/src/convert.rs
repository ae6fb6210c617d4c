//! From a [`SourceMesh`] to a validated [`TetMesh`]: scalar selection,
//! duplicate merging, cell splitting, orientation, dropping of degenerate
//! and non-finite cells, cell→point averaging and compaction. Every repair
//! becomes a [`Finding`] in the [`ConversionReport`].

use crate::error::MeshError;
use crate::merge::merge_duplicate_points;
use crate::predicates::{signed_tet_volume, tet_orientation, TetOrientation};
use crate::scalar::{select_scalar, ScalarLocation};
use crate::shared::SharedArray;
use crate::source::{Field, SourceMesh};
use crate::split::{split_blocks, SplitMode};
use rayon::prelude::*;
use std::fmt;
use std::sync::atomic::{AtomicBool, Ordering::Relaxed};

/// What to do with non-finite scalars or coordinates.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum NanPolicy {
    /// Fail, naming the first offending vertex or cell.
    #[default]
    Error,
    /// Drop every tet touching a non-finite value, and report how many.
    Drop,
}

/// Options for [`tetrahedralize`].
#[derive(Debug, Clone)]
pub struct ConvertOptions {
    pub split: SplitMode,
    /// Scalar selector (see [`crate::scalar`]); `None` picks the first field.
    pub scalar: Option<String>,
    pub nan: NanPolicy,
    /// Points closer than this fraction of the bounding-box diagonal (L∞)
    /// are merged. 0 merges only identical coordinates.
    pub merge_tolerance_rel: f64,
    /// Carry the source's point fields (other than the scalar) along, for
    /// export and later scalar choices.
    pub keep_point_fields: bool,
}

impl Default for ConvertOptions {
    fn default() -> Self {
        ConvertOptions {
            split: SplitMode::Five,
            scalar: None,
            nan: NanPolicy::Error,
            merge_tolerance_rel: 1e-10,
            keep_point_fields: true,
        }
    }
}

/// A validated tetrahedral mesh: every tet positively oriented and of
/// non-zero volume, every point used, every scalar finite.
#[derive(Debug, Clone, PartialEq)]
pub struct TetMesh {
    pub points: Vec<[f64; 3]>,
    /// Four point indices a tet (owned, or shared with a mapped bundle file).
    pub tets: SharedArray<[u32; 4]>,
    /// Name of the scalar (e.g. `density`, `Momentum:mag`, `x`, `zero`).
    pub scalar_name: String,
    /// One finite value per point.
    pub scalar: Vec<f64>,
    /// Other per-point fields carried from the source.
    pub point_fields: Vec<Field>,
}

/// One repair or fact found while converting; `Display` is the summary line.
#[derive(Debug, Clone, PartialEq)]
pub enum Finding {
    MergedDuplicatePoints {
        count: usize,
        tolerance: f64,
        with_different_scalar: usize,
    },
    DroppedBlankedCells {
        count: usize,
    },
    DroppedNonFinite {
        tets: usize,
        first_source_point: Option<usize>,
    },
    /// Tets re-oriented because their source cells list nodes in mirrored
    /// order (e.g. a left-handed structured grid).
    ReorientedTets {
        count: usize,
        cells: usize,
    },
    DroppedZeroVolumeTets {
        count: usize,
        first_source_cell: usize,
    },
    RemovedUnusedPoints {
        count: usize,
    },
    CellScalarAveragedToPoints {
        name: String,
    },
    NoScalarField,
    /// The chosen field has one value at every point: any TF shows the
    /// mesh as one colour.
    ConstantScalar {
        name: String,
        value: f64,
    },
    ReaderNote(String),
}

impl fmt::Display for Finding {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            Finding::MergedDuplicatePoints { count, tolerance, with_different_scalar } => {
                write!(f, "merged {count} duplicate points (tolerance {tolerance:.3e})")?;
                if *with_different_scalar > 0 {
                    write!(f, "; {with_different_scalar} of them had a different scalar (the first point's value was kept)")?;
                }
                Ok(())
            }
            Finding::DroppedBlankedCells { count } => write!(f, "dropped {count} cells touching IBLANK = 0 points"),
            Finding::DroppedNonFinite { tets, first_source_point } => {
                write!(f, "dropped {tets} tets touching non-finite values (--nan drop)")?;
                if let Some(p) = first_source_point {
                    write!(f, "; first such source point: {p}")?;
                }
                Ok(())
            }
            Finding::ReorientedTets { count, cells } => write!(
                f,
                "re-oriented {count} inverted tets from {cells} cells whose node order is mirrored (e.g. a left-handed grid)"
            ),
            Finding::DroppedZeroVolumeTets { count, first_source_cell } => {
                write!(f, "dropped {count} zero-volume tets (first from source cell {first_source_cell})")
            }
            Finding::RemovedUnusedPoints { count } => write!(f, "removed {count} unused points"),
            Finding::CellScalarAveragedToPoints { name } => {
                write!(f, "cell scalar '{name}' became point data by volume-weighted averaging")
            }
            Finding::NoScalarField => write!(f, "warning: the input has no field; the scalar is a constant 0 (use --scalar x|y|z for a coordinate)"),
            Finding::ConstantScalar { name, value } => write!(
                f,
                "warning: the scalar '{name}' is constant ({value}) over the mesh, so any transfer function draws it in one colour; choose another field with --scalar"
            ),
            Finding::ReaderNote(s) => f.write_str(s),
        }
    }
}

/// Counts and findings of one conversion.
#[derive(Debug, Clone, PartialEq, Default)]
pub struct ConversionReport {
    pub source_points: usize,
    pub source_cells: usize,
    /// Tets produced by splitting, before any were dropped.
    pub split_tets: usize,
    pub findings: Vec<Finding>,
    /// For each tet of the resulting mesh, the source cell it came from, so
    /// later errors (e.g. a face shared by three tets) can name input cells.
    pub tet_source_cell: Vec<u32>,
    /// For each point of the resulting mesh, the source point it is (a
    /// merged duplicate's representative), so later time steps' fields map
    /// the same way ([`crate::StepMapper`]).
    pub point_source: Vec<u32>,
    /// Where the chosen scalar lived in the source.
    pub scalar_location: Option<ScalarLocation>,
}

/// Steps reported to the progress callback.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Step {
    Merge,
    Split,
    Validate,
}

/// Converts and validates. `progress` is told when each step starts.
pub fn tetrahedralize(
    source: &SourceMesh,
    opts: &ConvertOptions,
    progress: &mut dyn FnMut(Step),
) -> Result<(TetMesh, ConversionReport), MeshError> {
    tetrahedralize_merged(source, opts, None, progress)
}

/// [`tetrahedralize`] for a source whose duplicate points an earlier step
/// already found with [`merge_duplicate_points`] at `opts`'s tolerance (a
/// point cloud's triangulation): `merged_into` is that result, used instead
/// of merging again. `None` merges as [`tetrahedralize`] does; a list of
/// the wrong length is an error.
pub fn tetrahedralize_merged(
    source: &SourceMesh,
    opts: &ConvertOptions,
    merged_into: Option<Vec<u32>>,
    progress: &mut dyn FnMut(Step),
) -> Result<(TetMesh, ConversionReport), MeshError> {
    tetrahedralize_with(source, opts, merged_into, None, progress)
}

/// What the caller of [`tetrahedralize_tets`] vouches for about its tets'
/// orientation.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum GivenOrientation {
    /// Unknown: each tet's orientation is decided exactly, flipped tets
    /// are reoriented and flat ones dropped, as for any split.
    Unchecked,
    /// Every tet is positively oriented by exact predicates on these very
    /// points (a Delaunay tetrahedralization's). The validation step then
    /// does no pass of its own: the caller confirms it in the statistics
    /// pass, [`crate::mesh_stats_confirming_orientation`], which it must run
    /// on the result. (With [`NanPolicy::Drop`] the tets are validated as
    /// `Unchecked` ones.)
    ExactlyPositive,
}

/// [`tetrahedralize_merged`] for tets an earlier step made over
/// `source.points` (a point cloud's triangulation): `tets` are taken as the
/// split of a source with one tet cell each, in their order (cell `i` is
/// tet `i`), without building that cell list and splitting it again;
/// `source`'s own cells are ignored. Then validated (see
/// [`GivenOrientation`]), given their scalar and compacted as any split. A
/// vertex id out of range is an error.
pub fn tetrahedralize_tets(
    source: &SourceMesh,
    opts: &ConvertOptions,
    merged_into: Option<Vec<u32>>,
    tets: Vec<[u32; 4]>,
    orientation: GivenOrientation,
    progress: &mut dyn FnMut(Step),
) -> Result<(TetMesh, ConversionReport), MeshError> {
    tetrahedralize_with(source, opts, merged_into, Some((tets, orientation)), progress)
}

fn tetrahedralize_with(
    source: &SourceMesh,
    opts: &ConvertOptions,
    merged_into: Option<Vec<u32>>,
    given: Option<(Vec<[u32; 4]>, GivenOrientation)>,
    progress: &mut dyn FnMut(Step),
) -> Result<(TetMesh, ConversionReport), MeshError> {
    source.check().map_err(MeshError::BadSource)?;
    let source_cells = given.as_ref().map_or(source.num_cells(), |g| g.0.len());
    let vouched =
        given.as_ref().is_some_and(|g| g.1 == GivenOrientation::ExactlyPositive) && opts.nan == NanPolicy::Error;
    if source_cells == 0 {
        return Err(MeshError::NoCells { points: source.points.len() });
    }
    if source.points.len() >= u32::MAX as usize {
        return Err(MeshError::TooLarge { what: "points", count: source.points.len(), limit: u32::MAX as usize - 1 });
    }
    let mut report = ConversionReport { source_points: source.points.len(), source_cells, ..Default::default() };
    report.findings.extend(source.notes.iter().cloned().map(Finding::ReaderNote));
    let scalar = select_scalar(source, opts.scalar.as_deref())?;
    if scalar.location == ScalarLocation::Constant {
        report.findings.push(Finding::NoScalarField);
    }

    let bad_point = |i: usize| {
        let p = &source.points[i];
        !p.iter().all(|c| c.is_finite()) || (scalar.location == ScalarLocation::Point && !scalar.values[i].is_finite())
    };

    // 1. Merge duplicates (tolerance relative to the bounding-box diagonal).
    progress(Step::Merge);
    let diag = bbox_diagonal(&source.points);
    let tolerance = opts.merge_tolerance_rel * diag;
    let rep = match merged_into {
        Some(rep) if rep.len() == source.points.len() && rep.iter().all(|&r| rep.get(r as usize) == Some(&r)) => rep,
        Some(rep) => {
            return Err(MeshError::BadSource(format!(
                "{} merge targets for {} points (or a target out of range or not its own representative)",
                rep.len(),
                source.points.len()
            )))
        }
        None => merge_duplicate_points(&source.points, tolerance),
    };
    let merged = rep.iter().enumerate().filter(|&(i, &r)| r as usize != i).count();
    if merged > 0 {
        let with_different_scalar = if scalar.location == ScalarLocation::Point {
            rep.iter().enumerate().filter(|&(i, &r)| scalar.values[i] != scalar.values[r as usize]).count()
        } else {
            0
        };
        report.findings.push(Finding::MergedDuplicatePoints { count: merged, tolerance, with_different_scalar });
    }

    // 2. Split cells on merged ids (so the min-id rule conforms across
    //    duplicates) and drop IBLANKed cells.
    progress(Step::Split);
    let (split, blanked) = match given {
        None => split_blocks(&source.blocks, opts.split, &rep, source.point_blanked.as_deref()),
        Some((tets, _)) => {
            let n_points = source.points.len();
            if let Some(t) = tets.par_iter().position_any(|t| t.iter().any(|&v| v as usize >= n_points)) {
                return Err(MeshError::BadSource(format!(
                    "tet {t} names vertex {} of {n_points} points",
                    tets[t].iter().copied().max().unwrap_or(0)
                )));
            }
            // Merged copies are renamed to their representative, as the
            // split does (a triangulation uses representatives already).
            let tets = if rep.iter().enumerate().all(|(i, &r)| r as usize == i) {
                tets
            } else {
                tets.par_iter().map(|t| t.map(|v| rep[v as usize])).collect()
            };
            let source_cell = (0..tets.len() as u32).into_par_iter().collect();
            let blanked = 0;
            (crate::split::SplitCells { tets, source_cell }, blanked)
        }
    };
    report.split_tets = split.tets.len();

    // Non-finite input is an error (naming the source index) unless
    // dropping; only values some tet uses count, so a NaN on a point that
    // no cell touches is harmless.
    if opts.nan == NanPolicy::Error {
        let any_bad = (0..source.points.len()).any(bad_point)
            || (scalar.location == ScalarLocation::Cell && scalar.values.iter().any(|v| !v.is_finite()));
        if any_bad {
            let mut used = vec![false; source.points.len()];
            for t in &split.tets {
                for &v in t {
                    used[v as usize] = true;
                }
            }
            if let Some(i) =
                (0..source.points.len()).find(|&i| used[i] && !source.points[i].iter().all(|c| c.is_finite()))
            {
                return Err(MeshError::NonFinitePoint { point: i, coords: source.points[i] });
            }
            if scalar.location == ScalarLocation::Point {
                if let Some(i) = (0..source.points.len()).find(|&i| used[i] && !scalar.values[i].is_finite()) {
                    return Err(MeshError::NonFiniteScalar {
                        name: scalar.name.clone(),
                        vertex: i,
                        value: scalar.values[i],
                    });
                }
            }
            if scalar.location == ScalarLocation::Cell {
                if let Some(&c) = split.source_cell.iter().find(|&&c| !scalar.values[c as usize].is_finite()) {
                    let c = c as usize;
                    return Err(MeshError::NonFiniteCellScalar {
                        name: scalar.name.clone(),
                        cell: c,
                        value: scalar.values[c],
                    });
                }
            }
        }
    }
    if blanked > 0 {
        report.findings.push(Finding::DroppedBlankedCells { count: blanked });
    }

    // 3. Orient exactly, drop flat tets and (with --nan drop) non-finite ones.
    progress(Step::Validate);
    let cell_bad = |c: u32| scalar.location == ScalarLocation::Cell && !scalar.values[c as usize].is_finite();
    #[derive(Clone, Copy, PartialEq)]
    enum Verdict {
        Keep,
        Flipped,
        Flat,
        NonFinite,
    }
    // Tets vouched for are confirmed by the caller's statistics pass.
    let verdicts: Vec<Verdict> = if vouched {
        Vec::new()
    } else {
        split
            .tets
            .par_iter()
            .zip(split.source_cell.par_iter())
            .map(|(t, &c)| {
                if opts.nan == NanPolicy::Drop && (t.iter().any(|&v| bad_point(v as usize)) || cell_bad(c)) {
                    return Verdict::NonFinite;
                }
                let p = |k: usize| &source.points[t[k] as usize];
                match tet_orientation(p(0), p(1), p(2), p(3)) {
                    TetOrientation::Positive => Verdict::Keep,
                    TetOrientation::Negative => Verdict::Flipped,
                    TetOrientation::Flat => Verdict::Flat,
                }
            })
            .collect()
    };
    let (mut flipped, mut flat, mut nonfinite) = (0usize, 0usize, 0usize);
    let (mut flipped_cells, mut last_flipped_cell) = (0usize, u32::MAX);
    let mut first_flat_cell = None;
    let split_tets = split.tets.len();
    // Every tet kept as it is (the usual case): the split's lists are the
    // result, not copied.
    let all_kept = vouched || verdicts.par_iter().all(|v| *v == Verdict::Keep);
    let (mut tets, mut tet_cell, kept_lists) = if all_kept {
        (split.tets, split.source_cell, None)
    } else {
        (Vec::with_capacity(split_tets), Vec::with_capacity(split_tets), Some((split.tets, split.source_cell)))
    };
    for ((t, &c), v) in kept_lists.iter().flat_map(|(t, c)| t.iter().zip(c.iter())).zip(&verdicts) {
        match v {
            Verdict::Keep => tets.push(*t),
            Verdict::Flipped => {
                flipped += 1;
                if c != last_flipped_cell {
                    flipped_cells += 1;
                    last_flipped_cell = c;
                }
                tets.push([t[1], t[0], t[2], t[3]]);
            }
            Verdict::Flat => {
                flat += 1;
                first_flat_cell.get_or_insert(c as usize);
                continue;
            }
            Verdict::NonFinite => {
                nonfinite += 1;
                continue;
            }
        }
        tet_cell.push(c);
    }
    drop(verdicts);
    drop(kept_lists);
    if nonfinite > 0 {
        let first_source_point = (0..source.points.len()).find(|&i| bad_point(i));
        report.findings.push(Finding::DroppedNonFinite { tets: nonfinite, first_source_point });
    }
    if flipped > 0 {
        report.findings.push(Finding::ReorientedTets { count: flipped, cells: flipped_cells });
    }
    if flat > 0 {
        report
            .findings
            .push(Finding::DroppedZeroVolumeTets { count: flat, first_source_cell: first_flat_cell.unwrap_or(0) });
    }
    if tets.is_empty() {
        return Err(MeshError::Empty {
            reason: format!("{split_tets} tets from splitting: {flat} flat, {nonfinite} non-finite"),
        });
    }

    // 4. Per-point scalar: point data as is; cell data by volume-weighted
    //    averaging over the kept tets (the tets of a cell sum to its volume).
    let n_src = source.points.len();
    let point_scalar: Vec<f64> = match scalar.location {
        ScalarLocation::Point => scalar.values.clone(),
        ScalarLocation::Constant => vec![0.0; n_src],
        ScalarLocation::Cell => {
            let mut sum = vec![0.0f64; n_src];
            let mut weight = vec![0.0f64; n_src];
            for (t, &c) in tets.iter().zip(&tet_cell) {
                let p = |k: usize| &source.points[t[k] as usize];
                let vol = signed_tet_volume(p(0), p(1), p(2), p(3)).abs();
                let val = scalar.values[c as usize];
                for &v in t {
                    sum[v as usize] += vol * val;
                    weight[v as usize] += vol;
                }
            }
            report.findings.push(Finding::CellScalarAveragedToPoints { name: scalar.name.clone() });
            sum.iter().zip(&weight).map(|(s, w)| if *w > 0.0 { s / w } else { 0.0 }).collect()
        }
    };

    // 5. Compact: keep only used points, in source order. The marks are
    //    set from all threads (the same value, so the order of the stores
    //    does not matter); where every point is used (a Delaunay cloud
    //    without copies) the numbering is the identity and the tets stay.
    let used: Vec<AtomicBool> = (0..n_src).map(|_| AtomicBool::new(false)).collect();
    tets.par_iter().with_min_len(1 << 14).for_each(|t| {
        for &v in t {
            used[v as usize].store(true, Relaxed);
        }
    });
    let mut new_index = vec![u32::MAX; n_src];
    let mut kept: Vec<usize> = Vec::new();
    for (i, slot) in new_index.iter_mut().enumerate() {
        if used[i].load(Relaxed) {
            *slot = kept.len() as u32;
            kept.push(i);
        }
    }
    drop(used);
    let unused = n_src - kept.len() - merged;
    if unused > 0 {
        report.findings.push(Finding::RemovedUnusedPoints { count: unused });
    }
    if kept.len() < n_src {
        tets.par_iter_mut().for_each(|t| {
            for v in t.iter_mut() {
                *v = new_index[*v as usize];
            }
        });
    }
    let points: Vec<[f64; 3]> = kept.iter().map(|&i| source.points[i]).collect();
    let scalar_values: Vec<f64> = kept.iter().map(|&i| point_scalar[i]).collect();
    let point_fields = if opts.keep_point_fields {
        source
            .point_fields
            .iter()
            .map(|f| {
                let nc = f.num_components;
                let mut values = Vec::with_capacity(kept.len() * nc);
                for &i in &kept {
                    values.extend_from_slice(&f.values[i * nc..(i + 1) * nc]);
                }
                Field { name: f.name.clone(), num_components: nc, values }
            })
            .collect()
    } else {
        Vec::new()
    };
    if scalar.location != ScalarLocation::Constant {
        if let Some(&value) = scalar_values.first().filter(|v| scalar_values.iter().all(|w| w == *v)) {
            report.findings.push(Finding::ConstantScalar { name: scalar.name.clone(), value });
        }
    }
    report.tet_source_cell = tet_cell;
    report.point_source = kept.iter().map(|&i| i as u32).collect();
    report.scalar_location = Some(scalar.location);
    Ok((TetMesh { points, tets: tets.into(), scalar_name: scalar.name, scalar: scalar_values, point_fields }, report))
}

/// Diagonal of the bounding box of the finite points (0 if there are none):
/// the length merge tolerances are relative to.
pub fn bbox_diagonal(points: &[[f64; 3]]) -> f64 {
    let (lo, hi) = crate::stats::bounds(points);
    let d2: f64 = (0..3).map(|a| (hi[a] - lo[a]).powi(2)).sum();
    if d2.is_finite() {
        d2.sqrt()
    } else {
        0.0
    }
}

/// Invariant checker for tests and fuzzing: indices in range, every tet
/// exactly positive, every point used, scalars finite.
pub fn check_tet_mesh(m: &TetMesh) -> Result<(), String> {
    if m.scalar.len() != m.points.len() {
        return Err(format!("{} scalars for {} points", m.scalar.len(), m.points.len()));
    }
    let mut used = vec![false; m.points.len()];
    for (i, t) in m.tets.iter().enumerate() {
        if t.iter().any(|&v| v as usize >= m.points.len()) {
            return Err(format!("tet {i} refers to a missing point"));
        }
        let p = |k: usize| &m.points[t[k] as usize];
        if tet_orientation(p(0), p(1), p(2), p(3)) != TetOrientation::Positive {
            return Err(format!("tet {i} is not positively oriented"));
        }
        for &v in t {
            used[v as usize] = true;
        }
    }
    if let Some(i) = used.iter().position(|u| !u) {
        return Err(format!("point {i} is unused"));
    }
    if let Some(i) = m.scalar.iter().position(|s| !s.is_finite()) {
        return Err(format!("scalar at point {i} is not finite"));
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::source::{Block, Field};

    /// Two unit cubes side by side, the shared face's four points listed
    /// twice (as two separately written blocks would): a merge handed over
    /// gives what merging here gives; a wrong one is refused.
    #[test]
    fn a_handed_merge_equals_merging_here() {
        let mut points = vec![];
        for x0 in [0.0, 1.0] {
            for k in 0..2 {
                for j in 0..2 {
                    for i in 0..2 {
                        points.push([x0 + i as f64, j as f64, k as f64]);
                    }
                }
            }
        }
        let s: Vec<f64> = points.iter().map(|p| p[0] + 2.0 * p[1] - p[2]).collect();
        let src = SourceMesh {
            points,
            blocks: vec![
                Block::Structured { dims: [2, 2, 2], first_point: 0 },
                Block::Structured { dims: [2, 2, 2], first_point: 8 },
            ],
            point_fields: vec![Field::new("s", 1, s)],
            ..Default::default()
        };
        let opts = ConvertOptions::default();
        let here = tetrahedralize(&src, &opts, &mut |_| {}).unwrap();
        let rep = merge_duplicate_points(&src.points, opts.merge_tolerance_rel * bbox_diagonal(&src.points));
        assert_eq!(rep.iter().enumerate().filter(|&(i, &r)| r as usize != i).count(), 4);
        let handed = tetrahedralize_merged(&src, &opts, Some(rep.clone()), &mut |_| {}).unwrap();
        assert_eq!(handed.0, here.0);
        assert_eq!(handed.1.findings, here.1.findings);
        let mut short = rep.clone();
        short.pop();
        assert!(matches!(tetrahedralize_merged(&src, &opts, Some(short), &mut |_| {}), Err(MeshError::BadSource(_))));
        let mut chained = rep;
        chained[0] = 8; // point 8 is itself merged into 1: not a representative
        assert!(matches!(tetrahedralize_merged(&src, &opts, Some(chained), &mut |_| {}), Err(MeshError::BadSource(_))));
    }

    /// Tets vouched for as exactly positive skip the validation pass (a
    /// flipped one passes through, for the caller's statistics pass to
    /// find); unchecked ones, or vouched ones with `--nan drop`, are
    /// reoriented as any split's.
    #[test]
    fn vouched_tets_are_left_to_the_statistics_pass() {
        let points = vec![[0.0, 0.0, 0.0], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0], [1.0, 1.0, 1.0]];
        let s: Vec<f64> = points.iter().map(|p| p[0] + p[1]).collect();
        let src = SourceMesh { points, point_fields: vec![Field::new("s", 1, s)], ..Default::default() };
        // Tet 1 is negatively oriented.
        let tets = vec![[0, 1, 2, 3], [2, 1, 3, 4]];
        let run = |orientation, nan| {
            let opts = ConvertOptions { nan, ..Default::default() };
            tetrahedralize_tets(&src, &opts, None, tets.clone(), orientation, &mut |_| {}).unwrap()
        };
        let (vouched, report) = run(GivenOrientation::ExactlyPositive, NanPolicy::Error);
        assert_eq!(vouched.tets, tets);
        assert!(report.findings.iter().all(|f| !matches!(f, Finding::ReorientedTets { .. })));
        assert_eq!(
            crate::mesh_stats_confirming_orientation(&vouched.points, &vouched.tets, &vouched.scalar),
            Err(MeshError::NotPositive { tet: 1, orientation: "negatively oriented" })
        );
        for (orientation, nan) in
            [(GivenOrientation::Unchecked, NanPolicy::Error), (GivenOrientation::ExactlyPositive, NanPolicy::Drop)]
        {
            let (checked, report) = run(orientation, nan);
            assert_eq!(checked.tets, vec![[0, 1, 2, 3], [1, 2, 3, 4]]);
            assert!(report.findings.iter().any(|f| matches!(f, Finding::ReorientedTets { count: 1, .. })));
        }
    }
}
