//! Input files to a validated bundle — the one conversion `tetprep
//! convert` and the Python package's `tetkit.read` run.
//!
//! [`convert`] reads the input (any format `tet_io` reads; a time series
//! of `.pvd`/`.series` files or, with [`ConvertRequest::all_steps`], of an
//! Exodus file's or OpenFOAM case's steps), tetrahedralizes a point cloud
//! (`tet_delaunay`), splits and validates the cells (`tet_mesh`), builds
//! the face adjacency beside the mesh statistics, maps every later time
//! step's scalar onto the first step's mesh ([`tet_mesh::StepMapper`]) and
//! returns the [`Bundle`] with the time each stage took ([`Converted`]).
//! Stages are reported to a callback ([`Stage`]); nothing is printed.
//! Errors ([`ConvertError`]) say which stage and which input failed, with
//! the reader's or the mesh's error as their source.
//!
//! ```
//! use tet_convert::{convert, ConvertRequest};
//! let dir = tempfile::tempdir()?;
//! let path = dir.path().join("two.vtk");
//! // Two tets sharing a face, with a point scalar.
//! std::fs::write(&path, "# vtk DataFile Version 3.0\nt\nASCII\nDATASET UNSTRUCTURED_GRID\n\
//!     POINTS 5 double\n0 0 0 1 0 0 0 1 0 0 0 1 1 1 1\nCELLS 2 10\n4 0 1 2 3\n4 1 2 3 4\n\
//!     CELL_TYPES 2\n10 10\nPOINT_DATA 5\nSCALARS s double 1\nLOOKUP_TABLE default\n0 1 2 3 4\n")?;
//! let done = convert(&path, &ConvertRequest::default(), &mut |_| {})?;
//! assert_eq!(done.bundle.mesh.tets.len(), 2);
//! assert_eq!(done.bundle.adjacency.boundary_faces.len(), 6);
//! # Ok::<(), Box<dyn std::error::Error>>(())
//! ```
#![forbid(unsafe_code)]

pub mod partition;

use std::path::{Path, PathBuf};
use std::time::Instant;

use tet_bundle::{Bundle, BundleMeta, BundleStream, TimeSteps};
use tet_delaunay::{tetrahedralize_cloud, CloudMode, DelaunayOptions};
use tet_io::series::SeriesStep;
use tet_io::ReadOptions;
use tet_mesh::SourceMesh;
use tet_mesh::{build_adjacency, tetrahedralize_merged, ConvertOptions, GivenOrientation, NanPolicy, SplitMode, Step};

/// What to convert and how (the options of `tetprep convert`).
#[derive(Debug, Clone, Default)]
pub struct ConvertRequest {
    /// How to read the input (format, companions, time step).
    pub read: ReadOptions,
    /// Cells: the split, the scalar, non-finite values, merging, fields.
    pub convert: ConvertOptions,
    /// Point clouds: Delaunay of the hull or layered prisms.
    pub cloud_mode: CloudMode,
    /// Point clouds: drop hull-filling Delaunay cells with a larger
    /// circumradius.
    pub max_circumradius: Option<f64>,
    /// Every time step of an Exodus file or OpenFOAM case (a `.pvd` or
    /// `.series` input is always read as a time series).
    pub all_steps: bool,
    /// Where the bundle is going: its file is started before anything is
    /// read (a path that cannot be written fails at once) and the mesh is
    /// written there on a thread of its own while the adjacency and
    /// statistics are computed ([`Converted::stream`], which the caller
    /// finishes with the bundle). `None` leaves the writing to the caller.
    pub stream_to: Option<PathBuf>,
}

/// The stage starting now, for progress displays.
#[derive(Debug, Clone, PartialEq)]
pub enum Stage {
    Reading,
    TetrahedralizingPoints,
    /// A step of `tet_mesh::tetrahedralize` (merge, split, validate).
    Mesh(Step),
    Adjacency,
    /// Time step `index` of `count` (from 1), read and mapped.
    TimeStep {
        index: usize,
        count: usize,
        label: String,
    },
}

/// A converted bundle and where the time went.
#[derive(Debug)]
pub struct Converted {
    pub bundle: Bundle,
    /// Seconds per stage, in order (`read`, `tetrahedralize_points`,
    /// `select_scalar`, `merge`, `split`, `validate`, `adjacency_stats`,
    /// `time_steps`).
    pub timings: Vec<(&'static str, f64)>,
    /// With [`ConvertRequest::stream_to`]: the bundle's file, its mesh
    /// written; `BundleStream::finish(&bundle)` completes it.
    pub stream: Option<BundleStream>,
}

/// Why a conversion failed; the path names the input, the source is the
/// reader's, the triangulation's or the mesh's own error.
#[derive(Debug, thiserror::Error)]
pub enum ConvertError {
    #[error("reading the input failed")]
    Read(#[source] tet_io::ReadError),
    #[error("reading the time steps of {} failed", path.display())]
    Steps {
        path: PathBuf,
        #[source]
        source: tet_io::ReadError,
    },
    #[error("reading time step {index} ({label}) failed")]
    ReadStep {
        index: usize,
        label: String,
        #[source]
        source: tet_io::ReadError,
    },
    #[error("tetrahedralizing the points of {} failed", path.display())]
    Cloud {
        path: PathBuf,
        #[source]
        source: tet_delaunay::DelaunayError,
    },
    /// Point-cloud options for an input with cells.
    #[error("--mode layered and --max-circumradius apply to point clouds; {} has cells", path.display())]
    CloudOptions { path: PathBuf },
    #[error("{} is a time series of point clouds; a series must share one mesh (convert one step at a time)", path.display())]
    CloudSeries { path: PathBuf },
    #[error("converting {} failed", path.display())]
    Mesh {
        path: PathBuf,
        #[source]
        source: tet_mesh::MeshError,
    },
    /// The tets are not a valid mesh; `cells` names the input cells of the
    /// tets involved where the error names tets.
    #[error("the tets do not form a valid mesh{cells}")]
    Invalid {
        cells: String,
        #[source]
        source: tet_mesh::MeshError,
    },
    #[error("writing the bundle failed")]
    Write(#[source] tet_bundle::BundleError),
    #[error("time step {index} ({label}) failed")]
    Step {
        index: usize,
        label: String,
        #[source]
        source: tet_mesh::MeshError,
    },
    #[error("the time steps of {}: {what}", path.display())]
    BadSteps { path: PathBuf, what: String },
}

/// Converts `input` as `req` says; `progress` hears each stage as it starts.
pub fn convert(input: &Path, req: &ConvertRequest, progress: &mut dyn FnMut(Stage)) -> Result<Converted, ConvertError> {
    // The output's file first: a path that cannot be written fails now,
    // not after the conversion.
    let stream = start_stream(req)?;
    progress(Stage::Reading);
    let t = Instant::now();
    // A time series: the first step is converted as any input, the others
    // are mapped onto its mesh.
    let series = tet_io::series::series_steps(input, &req.read, req.all_steps)
        .map_err(|source| ConvertError::Steps { path: input.into(), source })?;
    let source = match &series {
        Some(steps) => {
            let first = &steps[0];
            tet_io::read_file(&first.path, &ReadOptions { time_step: first.time_step, ..req.read.clone() })
                .map_err(|source| ConvertError::ReadStep { index: 0, label: first.label.clone(), source })?
        }
        None => tet_io::read_file(input, &req.read).map_err(ConvertError::Read)?,
    };
    let timings = vec![("read", t.elapsed().as_secs_f64())];
    build(source, series.as_deref(), input, req, stream, timings, progress)
}

/// The bundle's file at [`ConvertRequest::stream_to`], started.
fn start_stream(req: &ConvertRequest) -> Result<Option<BundleStream>, ConvertError> {
    req.stream_to.as_deref().map(BundleStream::create).transpose().map_err(ConvertError::Write)
}

/// Converts a mesh already in memory (arrays handed over by the Python
/// package, a reader's output) as [`convert`] converts a file's: point
/// clouds tetrahedralized, cells split and validated, adjacency and
/// statistics. `label` names it in errors and in the bundle's source path.
pub fn convert_source(
    source: SourceMesh,
    label: &str,
    req: &ConvertRequest,
    progress: &mut dyn FnMut(Stage),
) -> Result<Converted, ConvertError> {
    let stream = start_stream(req)?;
    build(source, None, Path::new(label), req, stream, Vec::new(), progress)
}

/// Everything after reading: the source (a series' first step, with the
/// list of steps) to the bundle.
fn build(
    mut source: SourceMesh,
    series: Option<&[SeriesStep]>,
    input: &Path,
    req: &ConvertRequest,
    stream: Option<BundleStream>,
    mut timings: Vec<(&'static str, f64)>,
    progress: &mut dyn FnMut(Stage),
) -> Result<Converted, ConvertError> {
    // A point cloud (points, no cells) is tetrahedralized first; from then
    // on it is a mesh like any other.
    // Its tets go to the conversion as they are: no cell list to build and
    // split again.
    let (mut cloud, cloud_tets) = if source.num_cells() == 0 && !source.points.is_empty() {
        progress(Stage::TetrahedralizingPoints);
        let t = Instant::now();
        let dopts = DelaunayOptions { max_circumradius: req.max_circumradius };
        let drop_nan = req.convert.nan == NanPolicy::Drop;
        let (tets, r) =
            tetrahedralize_cloud(&source, req.cloud_mode, &dopts, req.convert.merge_tolerance_rel, drop_nan)
                .map_err(|source| ConvertError::Cloud { path: input.into(), source })?;
        // Cell fields of a point cloud would not match the new cells.
        source.cell_fields.clear();
        timings.push(("tetrahedralize_points", t.elapsed().as_secs_f64()));
        (Some(r), Some(tets))
    } else {
        if req.max_circumradius.is_some() || req.cloud_mode == CloudMode::Layered {
            return Err(ConvertError::CloudOptions { path: input.into() });
        }
        (None, None)
    };
    if cloud.is_some() && series.is_some() {
        return Err(ConvertError::CloudSeries { path: input.into() });
    }

    let mut step_start = (Instant::now(), "select_scalar");
    let mut step_times: Vec<(&'static str, f64)> = Vec::new();
    // A cloud's points were merged before its triangulation: not again.
    let merged_into = cloud.as_mut().map(|c| std::mem::take(&mut c.merged_into));
    let mut on_step = |s| {
        let key = match s {
            Step::Merge => "merge",
            Step::Split => "split",
            Step::Validate => "validate",
        };
        step_times.push((step_start.1, step_start.0.elapsed().as_secs_f64()));
        step_start = (Instant::now(), key);
        progress(Stage::Mesh(s))
    };
    let converted = match cloud_tets {
        // Exact predicates made them (`tetrahedralize_cloud`): confirmed in
        // the statistics pass below, not in a validation pass of their own.
        Some(tets) => tet_mesh::tetrahedralize_tets(
            &source,
            &req.convert,
            merged_into,
            tets,
            GivenOrientation::ExactlyPositive,
            &mut on_step,
        ),
        None => tetrahedralize_merged(&source, &req.convert, merged_into, &mut on_step),
    };
    let (mesh, report) = converted.map_err(|source| ConvertError::Mesh { path: input.into(), source })?;
    step_times.push((step_start.1, step_start.0.elapsed().as_secs_f64()));
    timings.extend(step_times);

    progress(Stage::Adjacency);
    let t = Instant::now();
    // A Delaunay cloud hands over the adjacency its insertion kept, checked
    // in one pass, when the conversion kept its tets as they were (same
    // order, same vertex order); otherwise it is built from the faces.
    let handed = cloud.as_mut().and_then(|c| c.neighbors.take()).filter(|n| {
        n.len() == mesh.tets.len() && report.tet_source_cell.iter().enumerate().all(|(i, &c)| c as usize == i)
    });
    let mut adjacency_source = "built from the faces";
    // The mesh is final: with `stream_to` its arrays (and the neighbours
    // handed over) go to the file on a thread of their own while the
    // adjacency is checked or built and the statistics are computed beside
    // it (its face bucketing is serial).
    let (adjacency, stats, stream) = std::thread::scope(|scope| {
        let writer = stream.map(|mut s| {
            let (mesh, handed) = (&mesh, handed.as_deref());
            scope.spawn(move || {
                s.write_mesh(mesh)?;
                if let Some(n) = handed {
                    s.write_neighbors(n)?;
                }
                // The disk's share of the work done here too, beside the
                // computation, rather than in the final sync.
                s.sync_written()?;
                Ok::<_, tet_bundle::BundleError>(s)
            })
        });
        let (adjacency, stats) = rayon::join(
            || match handed.as_deref().and_then(|n| tet_mesh::check_neighbors(&mesh.points, &mesh.tets, n)) {
                Some(parts) => Ok(Ok(parts)),
                None => build_adjacency(&mesh.points, &mesh.tets).map(Err),
            },
            || {
                if cloud.is_some() {
                    tet_mesh::mesh_stats_confirming_orientation(&mesh.points, &mesh.tets, &mesh.scalar)
                } else {
                    Ok(tet_mesh::mesh_stats(&mesh.points, &mesh.tets, &mesh.scalar))
                }
            },
        );
        let stream = writer.map(|h| h.join().unwrap_or_else(|e| std::panic::resume_unwind(e)));
        (adjacency, stats, stream)
    });
    let adjacency = match (adjacency, handed) {
        (Ok(Ok((boundary_faces, convex))), Some(neighbors)) => {
            adjacency_source = "handed over by the Delaunay tetrahedralization";
            Ok(tet_mesh::Adjacency { neighbors: neighbors.into(), boundary_faces, convex })
        }
        (Ok(Err(built)), _) => Ok(built),
        // (Checked parts come from handed-over neighbours: not reached.)
        (Ok(Ok(_)), None) => build_adjacency(&mesh.points, &mesh.tets),
        (Err(e), _) => Err(e),
    };
    let adjacency = adjacency.map_err(|e| {
        let cells = match &e {
            tet_mesh::MeshError::NonManifoldFace { tets, .. } => {
                let cells: Vec<String> = tets.iter().map(|&t| report.tet_source_cell[t as usize].to_string()).collect();
                format!(" (they come from input cells {})", cells.join(", "))
            }
            _ => String::new(),
        };
        ConvertError::Invalid { cells, source: e }
    })?;
    let stats = stats.map_err(|source| ConvertError::Invalid { cells: String::new(), source })?;
    // (A mesh error first: the file being written is dropped with it.)
    let stream = stream.transpose().map_err(ConvertError::Write)?;
    timings.push(("adjacency_stats", t.elapsed().as_secs_f64()));

    // The other steps' scalars, mapped onto this mesh.
    let steps =
        match series {
            Some(list) => {
                let t = Instant::now();
                let mapper = tet_mesh::StepMapper::new(&source, &mesh, &report)
                    .map_err(|source| ConvertError::Mesh { path: input.into(), source })?;
                let mut scalars = vec![mesh.scalar.clone()];
                // An Exodus file's or OpenFOAM case's steps read only their
                // fields, the mesh once; other steps are files of their own.
                let later = tet_io::series::StepFields::open(list, &req.read)
                    .map_err(|source| ConvertError::ReadStep { index: 0, label: list[0].label.clone(), source })?;
                for (k, step) in list.iter().enumerate().skip(1) {
                    progress(Stage::TimeStep { index: k + 1, count: list.len(), label: step.label.clone() });
                    let read_error = |source| ConvertError::ReadStep { index: k, label: step.label.clone(), source };
                    let mapped = match &later {
                        Some(e) => mapper.scalar_of_fields(&e.fields(step).map_err(read_error)?, &mesh),
                        None => {
                            let s = tet_io::read_file(
                                &step.path,
                                &ReadOptions { time_step: step.time_step, ..req.read.clone() },
                            )
                            .map_err(read_error)?;
                            mapper.scalar(&s, &mesh)
                        }
                    };
                    scalars.push(mapped.map_err(|source| ConvertError::Step {
                        index: k,
                        label: step.label.clone(),
                        source,
                    })?);
                }
                let times = list.iter().map(|s| s.time).collect();
                let labels = list.iter().map(|s| s.label.clone()).collect();
                let steps = TimeSteps::new(times, scalars, labels)
                    .map_err(|what| ConvertError::BadSteps { path: input.into(), what })?;
                timings.push(("time_steps", t.elapsed().as_secs_f64()));
                Some(steps)
            }
            None => None,
        };

    let mut findings: Vec<String> = Vec::new();
    if let Some(st) = &steps {
        let (lo, hi) = st.scalar_range();
        findings.push(format!(
            "time series: {} steps, times {} to {}; scalar '{}' over all steps {lo} to {hi}",
            st.len(),
            st.times()[0],
            st.times()[st.len() - 1],
            mesh.scalar_name
        ));
    }
    let split = if let Some(c) = &cloud {
        match c.mode {
            CloudMode::Delaunay => {
                findings.push(format!(
                    "Delaunay tetrahedralization of {} distinct points: {} tets{}; face adjacency {adjacency_source}",
                    c.distinct_points,
                    c.tets,
                    if c.fills_convex_hull { ", filling the convex hull" } else { "" }
                ));
                if c.removed_cells > 0 {
                    findings.push(format!(
                        "removed {} hull-filling cells with circumradius above {}; the domain is no longer the convex hull",
                        c.removed_cells,
                        req.max_circumradius.unwrap_or(f64::NAN)
                    ));
                }
                "delaunay"
            }
            CloudMode::Layered => {
                findings.push(format!("layered: {} layers × {} columns: {} tets", c.layers, c.columns, c.tets));
                "layered"
            }
        }
    } else if source.blocks.iter().any(|b| matches!(b, tet_mesh::Block::Structured { .. })) {
        match req.convert.split {
            SplitMode::Five => "5",
            SplitMode::Six => "6",
        }
    } else {
        "6"
    };
    let meta = BundleMeta {
        source_path: input.display().to_string(),
        source_format: source.format.clone(),
        source_points: report.source_points as u64,
        source_cells: report.source_cells as u64,
        split_tets: report.split_tets as u64,
        split: split.into(),
        delaunay: cloud.as_ref().is_some_and(|c| c.fills_convex_hull),
        findings: findings.into_iter().chain(report.findings.iter().map(|f| f.to_string())).collect(),
        ..Default::default()
    };
    drop(source);
    let mut bundle = Bundle::with_stats(mesh, adjacency, meta, stats);
    if let Some(st) = steps {
        bundle = bundle.with_steps(st).map_err(|what| ConvertError::BadSteps { path: input.into(), what })?;
    }
    Ok(Converted { bundle, timings, stream })
}
