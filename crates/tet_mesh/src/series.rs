//! Time series on one mesh: a later step's scalar mapped onto the mesh the
//! first step was converted to, the way the conversion mapped the first
//! step's, without converting again.
//!
//! A time series (ParaView `.pvd`, `.series`, Exodus time steps, OpenFOAM
//! time directories) repeats one mesh with new field values. The first step
//! is converted as any input ([`crate::tetrahedralize`]); its
//! [`ConversionReport`] says which source point each mesh point is and
//! which source cell each tet came from. [`StepMapper::scalar`] then checks
//! that a later step has the same mesh (same point and cell counts, the same
//! cells, every used point at the same coordinates bit for bit) and maps its
//! scalar with the same rule: a point field by the same point map, a cell
//! field by the same volume-weighted average in the same order, so a step
//! mapped here equals the step converted alone, bit for bit.

use crate::convert::{ConversionReport, TetMesh};
use crate::error::MeshError;
use crate::predicates::signed_tet_volume;
use crate::scalar::{select_scalar, ScalarLocation};
use crate::source::{Block, SourceMesh};

/// Maps later time steps' scalars onto a converted first step's mesh.
#[derive(Debug, Clone)]
pub struct StepMapper {
    /// The scalar's name as the first step's conversion chose it.
    scalar_name: String,
    location: ScalarLocation,
    source_points: usize,
    /// The first step's cells (a later step must have the same).
    blocks: Vec<Block>,
    point_source: Vec<u32>,
    tet_source_cell: Vec<u32>,
}

impl StepMapper {
    /// The mapper for `mesh`, converted from `first` with `report`.
    pub fn new(first: &SourceMesh, mesh: &TetMesh, report: &ConversionReport) -> Result<StepMapper, MeshError> {
        let location = report.scalar_location.unwrap_or(ScalarLocation::Constant);
        if report.point_source.len() != mesh.points.len() || report.tet_source_cell.len() != mesh.tets.len() {
            return Err(MeshError::BadSource(format!(
                "the conversion report maps {} points and {} tets; the mesh has {} and {}",
                report.point_source.len(),
                report.tet_source_cell.len(),
                mesh.points.len(),
                mesh.tets.len()
            )));
        }
        Ok(StepMapper {
            scalar_name: mesh.scalar_name.clone(),
            location,
            source_points: first.points.len(),
            blocks: first.blocks.clone(),
            point_source: report.point_source.clone(),
            tet_source_cell: report.tet_source_cell.clone(),
        })
    }

    /// The scalar's name (as a `--scalar` selector).
    pub fn scalar_name(&self) -> &str {
        &self.scalar_name
    }

    /// `step`'s scalar on `mesh` (the first step's converted mesh), or why
    /// `step` does not fit it.
    pub fn scalar(&self, step: &SourceMesh, mesh: &TetMesh) -> Result<Vec<f64>, MeshError> {
        let differs = |what: String| MeshError::StepMeshDiffers { what };
        if step.points.len() != self.source_points {
            return Err(differs(format!("{} points, the first step has {}", step.points.len(), self.source_points)));
        }
        if step.blocks != self.blocks {
            return Err(differs(format!(
                "its cells differ ({} cells, the first step has {})",
                step.num_cells(),
                self.blocks.iter().map(Block::num_cells).sum::<usize>()
            )));
        }
        if let Some((i, &src)) = self
            .point_source
            .iter()
            .enumerate()
            .find(|&(i, &src)| step.points[src as usize].map(f64::to_bits) != mesh.points[i].map(f64::to_bits))
        {
            return Err(differs(format!(
                "point {src} (source index) moved from {:?} to {:?} (moving meshes are not supported)",
                mesh.points[i], step.points[src as usize]
            )));
        }
        self.map(step, mesh)
    }

    /// The scalar of a later step of the same file or case as the first
    /// (an Exodus file's time steps, an OpenFOAM case's times), given as
    /// its fields alone (`step` has no points and no cells): its mesh is
    /// the first step's by the file's own structure, so it is not compared
    /// again. A scalar selected by
    /// coordinate (`x`, `y`, `z`) is the first step's.
    pub fn scalar_of_fields(&self, step: &SourceMesh, mesh: &TetMesh) -> Result<Vec<f64>, MeshError> {
        let axis = match self.scalar_name.to_ascii_lowercase().as_str() {
            "x" => Some(0),
            "y" => Some(1),
            "z" => Some(2),
            _ => None,
        };
        if let Some(a) = axis {
            // No field of that name: the scalar is the coordinate, which
            // the step (without points) does not repeat.
            if select_scalar(step, Some(&self.scalar_name)).is_ok_and(|s| s.values.is_empty() && self.source_points > 0)
            {
                return Ok(mesh.points.iter().map(|p| p[a]).collect());
            }
        }
        self.map(step, mesh)
    }

    /// `step`'s scalar by the first step's rule (after the mesh checks).
    fn map(&self, step: &SourceMesh, mesh: &TetMesh) -> Result<Vec<f64>, MeshError> {
        let differs = |what: String| MeshError::StepMeshDiffers { what };
        if self.location == ScalarLocation::Constant {
            return Ok(vec![0.0; mesh.points.len()]);
        }
        let selected = select_scalar(step, Some(&self.scalar_name))?;
        let expected = match self.location {
            ScalarLocation::Point => self.source_points,
            _ => self.blocks.iter().map(Block::num_cells).sum::<usize>(),
        };
        if selected.values.len() != expected {
            return Err(differs(format!(
                "scalar '{}' has {} values, the first step's mesh has {expected} {}",
                self.scalar_name,
                selected.values.len(),
                if self.location == ScalarLocation::Point { "points" } else { "cells" }
            )));
        }
        if selected.location != self.location {
            return Err(differs(format!(
                "scalar '{}' is a {} field here and a {} field in the first step",
                self.scalar_name,
                location_name(selected.location),
                location_name(self.location)
            )));
        }
        let values = &selected.values;
        match self.location {
            ScalarLocation::Point => {
                let mut out = Vec::with_capacity(self.point_source.len());
                for &src in &self.point_source {
                    let v = values[src as usize];
                    if !v.is_finite() {
                        return Err(MeshError::NonFiniteInStep {
                            name: self.scalar_name.clone(),
                            place: format!("vertex {src} (source point index)"),
                            value: v,
                        });
                    }
                    out.push(v);
                }
                Ok(out)
            }
            ScalarLocation::Cell => {
                // The conversion's average: per point, the kept tets'
                // volumes times their cells' values over the volumes, summed
                // in tet order (the mesh keeps the conversion's tet order).
                if let Some(&c) = self.tet_source_cell.iter().find(|&&c| !values[c as usize].is_finite()) {
                    return Err(MeshError::NonFiniteInStep {
                        name: self.scalar_name.clone(),
                        place: format!("cell {c} (source cell index)"),
                        value: values[c as usize],
                    });
                }
                let n = mesh.points.len();
                let (mut sum, mut weight) = (vec![0.0f64; n], vec![0.0f64; n]);
                for (t, &c) in mesh.tets.iter().zip(&self.tet_source_cell) {
                    let p = |k: usize| &mesh.points[t[k] as usize];
                    let vol = signed_tet_volume(p(0), p(1), p(2), p(3)).abs();
                    let val = values[c as usize];
                    for &v in t {
                        sum[v as usize] += vol * val;
                        weight[v as usize] += vol;
                    }
                }
                Ok(sum.iter().zip(&weight).map(|(s, w)| if *w > 0.0 { s / w } else { 0.0 }).collect())
            }
            ScalarLocation::Constant => unreachable!("returned above"),
        }
    }
}

fn location_name(l: ScalarLocation) -> &'static str {
    match l {
        ScalarLocation::Point => "point",
        ScalarLocation::Cell => "cell",
        ScalarLocation::Constant => "constant",
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::source::Field;
    use crate::{tetrahedralize, ConvertOptions};

    /// Two hex blocks sharing a face (duplicated points, merged), a point
    /// field and a cell field whose values change with `t`, and an unused
    /// point.
    fn step(t: f64) -> SourceMesh {
        let mut points = vec![];
        for x0 in [0.0, 1.0] {
            for k in 0..3 {
                for j in 0..2 {
                    for i in 0..2 {
                        points.push([x0 + i as f64, j as f64 * 0.7, k as f64 * 0.5]);
                    }
                }
            }
        }
        points.push([9.0, 9.0, 9.0]);
        let s: Vec<f64> = points.iter().map(|p| (p[0] * 1.3 + t).sin() + p[1] * p[2] * t).collect();
        let c: Vec<f64> = (0..4).map(|i| i as f64 * t - 0.5).collect();
        SourceMesh {
            points,
            blocks: vec![
                Block::Structured { dims: [2, 2, 3], first_point: 0 },
                Block::Structured { dims: [2, 2, 3], first_point: 12 },
            ],
            point_fields: vec![Field::new("s", 1, s), Field::new("v", 3, vec![t; 75])],
            cell_fields: vec![Field::new("c", 1, c)],
            ..Default::default()
        }
    }

    /// Mapping a later step equals converting it alone, bit for bit, for a
    /// point field, a vector's magnitude and a cell field.
    #[test]
    fn a_mapped_step_equals_the_step_converted_alone() {
        for scalar in ["s", "v", "c"] {
            let opts = ConvertOptions { scalar: Some(scalar.into()), ..Default::default() };
            let first = step(0.25);
            let (mesh, report) = tetrahedralize(&first, &opts, &mut |_| {}).unwrap();
            let mapper = StepMapper::new(&first, &mesh, &report).unwrap();
            for t in [0.25, 1.5, 3.0] {
                let later = step(t);
                let alone = tetrahedralize(&later, &opts, &mut |_| {}).unwrap().0;
                let mapped = mapper.scalar(&later, &mesh).unwrap();
                assert_eq!(alone.points, mesh.points);
                assert_eq!(
                    mapped.iter().map(|v| v.to_bits()).collect::<Vec<_>>(),
                    alone.scalar.iter().map(|v| v.to_bits()).collect::<Vec<_>>(),
                    "{scalar} at t = {t}"
                );
            }
        }
    }

    /// A step on another mesh, with a non-finite value, or missing the
    /// field is an error naming what differs, never a wrong scalar.
    #[test]
    fn a_step_that_does_not_fit_is_refused() {
        let opts = ConvertOptions { scalar: Some("s".into()), ..Default::default() };
        let first = step(0.0);
        let (mesh, report) = tetrahedralize(&first, &opts, &mut |_| {}).unwrap();
        let mapper = StepMapper::new(&first, &mesh, &report).unwrap();

        let mut moved = step(1.0);
        moved.points[3][2] += 1e-9;
        let e = mapper.scalar(&moved, &mesh).unwrap_err();
        assert!(matches!(e, MeshError::StepMeshDiffers { .. }) && e.to_string().contains("point 3"), "{e}");

        // The unused point may move: no tet sees it.
        let mut unused = step(1.0);
        unused.points[24] = [1.0, 2.0, 3.0];
        assert!(mapper.scalar(&unused, &mesh).is_ok());

        let mut fewer = step(1.0);
        fewer.points.pop();
        assert!(mapper.scalar(&fewer, &mesh).unwrap_err().to_string().contains("24 points"));

        let mut recut = step(1.0);
        recut.blocks.pop();
        assert!(mapper.scalar(&recut, &mesh).unwrap_err().to_string().contains("cells differ"));

        let mut nan = step(1.0);
        nan.point_fields[0].values[5] = f64::NAN;
        let e = mapper.scalar(&nan, &mesh).unwrap_err();
        assert!(matches!(e, MeshError::NonFiniteInStep { .. }) && e.to_string().contains("vertex 5"), "{e}");

        let mut renamed = step(1.0);
        renamed.point_fields[0].name = "t".into();
        assert!(matches!(mapper.scalar(&renamed, &mesh), Err(MeshError::UnknownScalar { .. })));
    }
}
