//! The native module of the `tetkit` Python package (`tetkit._tetkit`,
//! built by maturin from `python/pyproject.toml`): a thin client of
//! [`tet_engine`] with numpy arrays in and out.
//!
//! Main types: [`PyBundle`] (Python `tetkit.Bundle`: a validated mesh with
//! its scalar, face adjacency and time steps), the functions `load`, `read`,
//! `from_arrays`, `render`, `reference`, `tonemap`, `diff` and `encode_png`,
//! and the exceptions `TetkitError` (a `ValueError`: bad arguments or data)
//! and `TetkitIOError` (an `OSError`: a file that cannot be read or
//! written), whose messages are the command-line programs' (the same
//! [`tet_cli::describe`] of the same error chain).
//!
//! Every call that does real work releases the GIL. Images are H×W×4
//! float32 arrays of linear premultiplied RGBA, row 0 at the top, handed to
//! numpy without a copy. The Python layer (`python/tetkit/__init__.py`)
//! adds what is Python's own: notebook display, TF dicts, keyword defaults.
//!
//! No `#![forbid(unsafe_code)]`: PyO3's macros expand to `unsafe` FFI; this
//! crate's own code has none.
//!
//! ```
//! // The module's functions are Python-facing; in Rust the same engine
//! // calls draw the same frame (what `render` does underneath).
//! let bundle = tet_bundle::Bundle::read(std::path::Path::new(concat!(
//!     env!("CARGO_MANIFEST_DIR"), "/../../formats/samples/cube5.tetb")))?;
//! let view = tet_python::view_of(&bundle, None, 30.0, 20.0, 1.0, [16, 16])?;
//! assert_eq!(view.size, [16, 16]);
//! # Ok::<(), Box<dyn std::error::Error>>(())
//! ```

use std::path::PathBuf;

use numpy::ndarray::Array3;
use numpy::{IntoPyArray, PyArray3, PyReadonlyArray1, PyReadonlyArray2, PyReadonlyArray3};
use pyo3::create_exception;
use pyo3::exceptions::{PyOSError, PyValueError};
use pyo3::prelude::*;
use tet_bundle::Bundle;
use tet_cli::{ExitKind, KindExt};
use tet_engine::{
    resolve_tf, CpuFrameRenderer, FrameRenderer, FrameRequest, Look, ReferenceFrameRenderer, TfRequest, TfSource,
};
use tet_preint::{Colormap, Method, TransferFunction};
use tet_render::{CpuRenderer, Display, Image, Shading, ToneMap, ViewSpec};

create_exception!(
    _tetkit,
    TetkitError,
    PyValueError,
    "tetkit could not do what was asked with these arguments or this data (the message is tetview's or tetprep's)."
);
create_exception!(_tetkit, TetkitIOError, PyOSError, "A file tetkit needed could not be read or written.");

/// A Python exception for an error chain: its kind decides the class, the
/// CLI's description is the message.
fn py_err(e: anyhow::Error) -> PyErr {
    let msg = tet_cli::describe(&e);
    match ExitKind::of(&e) {
        ExitKind::Input | ExitKind::Output => TetkitIOError::new_err(msg),
        _ => TetkitError::new_err(msg),
    }
}

fn arg_err(name: &str, what: impl std::fmt::Display) -> PyErr {
    TetkitError::new_err(format!("{name}: {what}"))
}

/// A tetrahedral mesh with one scalar per point, its face adjacency and,
/// for a time series, the scalar of every step.
#[pyclass(name = "Bundle", module = "tetkit")]
pub struct PyBundle {
    pub bundle: Bundle,
}

impl PyBundle {
    /// The histograms `histogram` returns and `histogram_png` draws.
    fn histograms(
        &self,
        bins: (u32, u32),
        scalar_range: Option<(f64, f64)>,
        gradient_range: Option<(f64, f64)>,
    ) -> anyhow::Result<tet_analysis::Histograms> {
        let opts = tet_analysis::HistogramOptions {
            scalar_bins: bins.0,
            gradient_bins: bins.1,
            scalar_range,
            gradient_range,
            ..Default::default()
        };
        Ok(tet_analysis::Analyzer::from_mesh(&self.bundle.mesh)?.histograms(&opts)?)
    }
}

#[pymethods]
impl PyBundle {
    /// Points, N×3 float64 (a copy).
    #[getter]
    fn points<'py>(&self, py: Python<'py>) -> Bound<'py, numpy::PyArray2<f64>> {
        let p = &self.bundle.mesh.points;
        numpy::ndarray::Array2::from_shape_vec((p.len(), 3), p.as_flattened().to_vec()).expect("N×3").into_pyarray(py)
    }
    /// Tets, M×4 uint32 point indices, positively oriented (a copy).
    #[getter]
    fn tets<'py>(&self, py: Python<'py>) -> Bound<'py, numpy::PyArray2<u32>> {
        let t = &self.bundle.mesh.tets;
        numpy::ndarray::Array2::from_shape_vec((t.len(), 4), t.as_flattened().to_vec()).expect("M×4").into_pyarray(py)
    }
    /// The scalar per point, float64 (a copy).
    #[getter]
    fn scalar<'py>(&self, py: Python<'py>) -> Bound<'py, numpy::PyArray1<f64>> {
        self.bundle.mesh.scalar.clone().into_pyarray(py)
    }
    #[getter]
    fn scalar_name(&self) -> String {
        self.bundle.mesh.scalar_name.clone()
    }
    /// (min, max) a normalized TF spans: over every time step of a series.
    #[getter]
    fn scalar_range(&self) -> (f64, f64) {
        self.bundle.scalar_range()
    }
    /// ((xmin, ymin, zmin), (xmax, ymax, zmax)).
    #[getter]
    fn bounds(&self) -> ([f64; 3], [f64; 3]) {
        let s = &self.bundle.meta.stats;
        (s.bounds_min, s.bounds_max)
    }
    #[getter]
    fn num_points(&self) -> usize {
        self.bundle.mesh.points.len()
    }
    #[getter]
    fn num_tets(&self) -> usize {
        self.bundle.mesh.tets.len()
    }
    /// The times of a time series' steps, or None.
    #[getter]
    fn times(&self) -> Option<Vec<f64>> {
        self.bundle.steps.as_ref().map(|s| s.times().to_vec())
    }
    /// The conversion's findings (merged points, dropped cells, …).
    #[getter]
    fn findings(&self) -> Vec<String> {
        self.bundle.meta.findings.clone()
    }
    /// Volume-weighted histograms of the scalar and of (|∇s|, scalar), as
    /// `tetprep hist` computes them: a dict of numpy arrays — `scalar`
    /// (volume per scalar bin), `joint` (gradient bins × scalar bins),
    /// `scalar_edges`, `gradient_edges` — and the volumes `scalar_below`,
    /// `scalar_above`, `joint_outside`, `total_volume`.
    #[pyo3(signature = (bins=(256, 256), scalar_range=None, gradient_range=None))]
    fn histogram<'py>(
        &self,
        py: Python<'py>,
        bins: (u32, u32),
        scalar_range: Option<(f64, f64)>,
        gradient_range: Option<(f64, f64)>,
    ) -> PyResult<Bound<'py, pyo3::types::PyDict>> {
        let h = py.allow_threads(|| self.histograms(bins, scalar_range, gradient_range)).map_err(py_err)?;
        let edges = |a: &tet_analysis::histogram::Axis| (0..=a.bins as usize).map(|k| a.edge(k)).collect::<Vec<f64>>();
        let (ns, ng) = (h.scalar_axis.bins as usize, h.gradient_axis.bins as usize);
        let d = pyo3::types::PyDict::new(py);
        d.set_item("scalar_edges", edges(&h.scalar_axis).into_pyarray(py))?;
        d.set_item("gradient_edges", edges(&h.gradient_axis).into_pyarray(py))?;
        d.set_item("scalar", h.scalar.into_pyarray(py))?;
        let joint = numpy::ndarray::Array2::from_shape_vec((ng, ns), h.joint).expect("ng × ns");
        d.set_item("joint", joint.into_pyarray(py))?;
        d.set_item("scalar_below", h.scalar_below)?;
        d.set_item("scalar_above", h.scalar_above)?;
        d.set_item("joint_outside", h.joint_outside)?;
        d.set_item("total_volume", h.total_volume)?;
        Ok(d)
    }

    /// The histogram figure `tetprep hist` draws (the scalar × |∇s|
    /// histogram with the 1D one above, log colour scale unless `log` is
    /// false), as PNG bytes; also written to `path` when given. `units` and
    /// `length_units` label the axes; `bins`, `scalar_range` and
    /// `gradient_range` as for `histogram`.
    #[pyo3(signature = (path=None, bins=(256, 256), log=true, scalar_range=None, gradient_range=None, units=None,
        length_units=None))]
    #[allow(clippy::too_many_arguments)]
    fn histogram_png<'py>(
        &self,
        py: Python<'py>,
        path: Option<PathBuf>,
        bins: (u32, u32),
        log: bool,
        scalar_range: Option<(f64, f64)>,
        gradient_range: Option<(f64, f64)>,
        units: Option<String>,
        length_units: Option<String>,
    ) -> PyResult<Bound<'py, pyo3::types::PyBytes>> {
        let png = py
            .allow_threads(|| -> anyhow::Result<Vec<u8>> {
                let h = self.histograms(bins, scalar_range, gradient_range)?;
                let name = &self.bundle.mesh.scalar_name;
                let axis_units = tet_cli::hist_plot::AxisUnits { scalar: units, length: length_units };
                let title = format!("{name} × |∇{name}|");
                let png = tet_cli::hist_plot::histogram_figure(&h, name, &title, log, &axis_units).to_png()?;
                if let Some(p) = &path {
                    std::fs::write(p, &png)
                        .map_err(|e| anyhow::Error::new(e).context(format!("writing {}", p.display())))
                        .kind(ExitKind::Output)?;
                }
                Ok(png)
            })
            .map_err(py_err)?;
        Ok(pyo3::types::PyBytes::new(py, &png))
    }

    /// Per-point gradients of the scalar, N×3 (scalar units per world
    /// length): the stored ones, else computed now by `method` (`lsq`,
    /// least squares over the one-ring, or `tet-average`).
    #[pyo3(signature = (method="lsq"))]
    fn gradients<'py>(&self, py: Python<'py>, method: &str) -> PyResult<Bound<'py, numpy::PyArray2<f64>>> {
        let m = match method {
            "lsq" => tet_analysis::GradientMethod::LeastSquares,
            "tet-average" => tet_analysis::GradientMethod::TetAverage,
            other => return Err(arg_err("method", format!("'{other}': use lsq or tet-average"))),
        };
        let stored = self.bundle.analysis.as_ref().and_then(|a| a.gradients.as_ref()).filter(|g| g.method == m);
        let g: Vec<[f64; 3]> = match stored {
            Some(g) => g.per_point.clone(),
            None => py
                .allow_threads(|| -> anyhow::Result<Vec<[f64; 3]>> {
                    Ok(tet_analysis::Analyzer::from_mesh(&self.bundle.mesh)?.vertex_gradients(m).to_vec())
                })
                .map_err(py_err)?,
        };
        let n = g.len();
        Ok(numpy::ndarray::Array2::from_shape_vec((n, 3), g.into_flattened()).expect("N×3").into_pyarray(py))
    }

    /// The segment facts and frequency limits `tetprep info` prints: the
    /// largest scalar range of a cell, the longest cell diagonal, and the
    /// band frequencies whose peaks no cell (or 99% of cells) holds twice.
    fn limits<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, pyo3::types::PyDict>> {
        let a = py
            .allow_threads(|| -> anyhow::Result<tet_analysis::Analysis> {
                Ok(tet_analysis::Analyzer::from_mesh(&self.bundle.mesh)?.analyze(&Default::default())?)
            })
            .map_err(py_err)?;
        let d = pyo3::types::PyDict::new(py);
        d.set_item("max_cell_scalar_range", a.facts.max_cell_scalar_range)?;
        d.set_item("max_cell_diameter", a.facts.max_cell_diameter)?;
        d.set_item("frequency_limit", a.limits.frequency_limit)?;
        d.set_item("frequency_limit_99", a.limits.frequency_limit_99)?;
        Ok(d)
    }

    /// A copy at time `t` of a time series (linear between steps).
    fn at_time(&self, t: f64) -> PyResult<PyBundle> {
        let mut b = self.bundle.clone();
        b.set_time(t).map_err(|e| arg_err("time", e))?;
        Ok(PyBundle { bundle: b })
    }
    /// Writes the bundle (.tetb) atomically.
    fn save(&self, py: Python<'_>, path: PathBuf) -> PyResult<()> {
        py.allow_threads(|| self.bundle.write(&path)).map_err(|e| py_err(e.into()))
    }
    fn __repr__(&self) -> String {
        let b = &self.bundle;
        let (lo, hi) = b.scalar_range();
        let steps = b.steps.as_ref().map_or(String::new(), |s| format!(", {} time steps", s.len()));
        format!(
            "<tetkit.Bundle {} points, {} tets, scalar '{}' in [{lo}, {hi}]{steps}>",
            b.mesh.points.len(),
            b.mesh.tets.len(),
            b.mesh.scalar_name
        )
    }

    /// A notebook's summary of the bundle: an HTML table of its size,
    /// scalar, bounds, volume, time steps and the conversion's findings
    /// (`histogram_png` draws its histograms).
    fn _repr_html_(&self) -> String {
        let b = &self.bundle;
        let st = &b.meta.stats;
        let (lo, hi) = b.scalar_range();
        let esc = |t: &str| t.replace('&', "&amp;").replace('<', "&lt;").replace('>', "&gt;");
        let v3 = |v: [f64; 3]| format!("({:.6}, {:.6}, {:.6})", v[0], v[1], v[2]);
        let mut rows = vec![
            ("points", b.mesh.points.len().to_string()),
            ("tets", b.mesh.tets.len().to_string()),
            ("scalar", format!("{} in [{lo:.6}, {hi:.6}]", esc(&b.mesh.scalar_name))),
            ("bounds", format!("{} – {}", v3(st.bounds_min), v3(st.bounds_max))),
            ("volume", format!("{:.6}", st.total_volume)),
            ("gradients stored", b.analysis.as_ref().is_some_and(|a| a.gradients.is_some()).to_string()),
        ];
        if let Some(steps) = &b.steps {
            let t = steps.times();
            rows.push((
                "time steps",
                format!(
                    "{} from {} to {}",
                    t.len(),
                    t.first().copied().unwrap_or(0.0),
                    t.last().copied().unwrap_or(0.0)
                ),
            ));
        }
        for f in &b.meta.findings {
            rows.push(("finding", esc(f)));
        }
        let body: String =
            rows.iter().map(|(k, v)| format!("<tr><th style=\"text-align:left\">{k}</th><td>{v}</td></tr>")).collect();
        format!("<table><caption>tetkit.Bundle</caption>{body}</table>")
    }
}

/// Reads a bundle written by `tetprep convert` (.tetb).
#[pyfunction]
fn load(py: Python<'_>, path: PathBuf) -> PyResult<PyBundle> {
    let bundle = py.allow_threads(|| Bundle::read(&path)).map_err(|e| py_err(e.into()))?;
    Ok(PyBundle { bundle })
}

/// Reads any mesh, grid, volume or point cloud file tetprep reads and
/// converts it as `tetprep convert` does with its defaults
/// ([`tet_convert::convert`]: cells split into tets, duplicates merged,
/// point clouds tetrahedralized by Delaunay, a `.pvd`/`.series` as a time
/// series).
#[pyfunction]
#[pyo3(signature = (path, scalar=None, q=None, all_steps=false))]
fn read(
    py: Python<'_>,
    path: PathBuf,
    scalar: Option<String>,
    q: Option<PathBuf>,
    all_steps: bool,
) -> PyResult<PyBundle> {
    let request = tet_convert::ConvertRequest {
        read: tet_io::ReadOptions { q_path: q, ..Default::default() },
        convert: tet_mesh::ConvertOptions { scalar, ..Default::default() },
        all_steps,
        ..Default::default()
    };
    let bundle =
        py.allow_threads(|| tet_convert::convert(&path, &request, &mut |_| {})).map_err(|e| py_err(e.into()))?.bundle;
    Ok(PyBundle { bundle })
}

/// A bundle from arrays: points N×3 float64, tets M×4 integer indices (any
/// orientation; flat tets are dropped), one scalar per point (length N) or
/// per tet (length M, averaged onto the points by volume).
#[pyfunction]
fn from_arrays(
    py: Python<'_>,
    points: PyReadonlyArray2<'_, f64>,
    tets: PyReadonlyArray2<'_, i64>,
    scalars: PyReadonlyArray1<'_, f64>,
) -> PyResult<PyBundle> {
    let (p, t, s) = (points.as_array(), tets.as_array(), scalars.as_array());
    if p.ncols() != 3 {
        return Err(arg_err("points", format!("shape {:?}: need N×3", p.shape())));
    }
    if t.ncols() != 4 {
        return Err(arg_err("tets", format!("shape {:?}: need M×4", t.shape())));
    }
    let (n, m) = (p.nrows(), t.nrows());
    if let Some((i, _)) = p.outer_iter().enumerate().find(|(_, r)| !r.iter().all(|v| v.is_finite())) {
        return Err(arg_err("points", format!("point {i} has a non-finite coordinate")));
    }
    if let Some((i, v)) = t.iter().enumerate().find(|(_, &v)| v < 0 || v as usize >= n) {
        return Err(arg_err("tets", format!("tet {} refers to point {v}; there are {n} points", i / 4)));
    }
    let location = if s.len() == n {
        "point"
    } else if s.len() == m {
        "cell"
    } else {
        return Err(arg_err("scalars", format!("length {}: need one a point ({n}) or one a tet ({m})", s.len())));
    };
    if let Some((i, v)) = s.iter().enumerate().find(|(_, v)| !v.is_finite()) {
        return Err(arg_err("scalars", format!("value {i} is {v}")));
    }
    let points: Vec<[f64; 3]> = p.outer_iter().map(|r| [r[0], r[1], r[2]]).collect();
    let conn: Vec<u32> = t.iter().map(|&v| v as u32).collect();
    let values: Vec<f64> = s.iter().copied().collect();
    let field = tet_mesh::Field::new("scalar", 1, values);
    let mut cells = tet_mesh::Cells::new();
    for t in conn.chunks_exact(4) {
        cells.push(tet_mesh::CellType::Tetra, t);
    }
    let source = tet_mesh::SourceMesh {
        format: "numpy arrays".into(),
        points,
        blocks: vec![tet_mesh::Block::Unstructured(cells)],
        point_fields: if location == "point" { vec![field.clone()] } else { vec![] },
        cell_fields: if location == "cell" { vec![field] } else { vec![] },
        ..Default::default()
    };
    bundle_of(py, source, Some("scalar".into()))
}

/// `source` converted as `tetprep convert` converts a file
/// ([`tet_convert::convert_source`]), `scalar` chosen by `--scalar`'s
/// rules; the GIL released.
fn bundle_of(py: Python<'_>, source: tet_mesh::SourceMesh, scalar: Option<String>) -> PyResult<PyBundle> {
    let label = source.format.clone();
    let request = tet_convert::ConvertRequest {
        convert: tet_mesh::ConvertOptions { scalar, ..Default::default() },
        ..Default::default()
    };
    let bundle = py
        .allow_threads(|| tet_convert::convert_source(source, &label, &request, &mut |_| {}))
        .map_err(|e| py_err(e.into()))?
        .bundle;
    Ok(PyBundle { bundle })
}

/// One named field: values per point or per cell, `components` each
/// (a 1D array is one component).
type FieldArg<'py> = (String, numpy::PyReadonlyArrayDyn<'py, f64>);

fn fields_of(
    kind: &str,
    fields: Vec<FieldArg<'_>>,
    count: usize,
    keep: Option<&[u32]>,
) -> PyResult<Vec<tet_mesh::Field>> {
    let mut out = Vec::with_capacity(fields.len());
    for (name, a) in fields {
        let v = a.as_array();
        let (rows, comps) = match v.shape() {
            [n] => (*n, 1),
            [n, c] => (*n, *c),
            s => return Err(arg_err(&format!("{kind} field '{name}'"), format!("shape {s:?}: need one row a {kind}"))),
        };
        if rows != count || comps == 0 {
            return Err(arg_err(
                &format!("{kind} field '{name}'"),
                format!("{rows}×{comps} values for {count} {kind}s"),
            ));
        }
        let flat: Vec<f64> = v.iter().copied().collect();
        let values = match keep {
            Some(k) => {
                k.iter().flat_map(|&c| flat[c as usize * comps..(c as usize + 1) * comps].iter().copied()).collect()
            }
            None => flat,
        };
        out.push(tet_mesh::Field::new(name, comps, values));
    }
    Ok(out)
}

/// A bundle from cells as VTK lists them (PyVista's `celltypes`,
/// `offset`, `cell_connectivity`; meshio's blocks flattened) or from a
/// structured grid's points (`dims`: x fastest), with named point and cell
/// fields; converted as `tetprep convert` converts a file (cells split into
/// tets, `scalar` chosen by the same rules). Cells without volume are
/// skipped and counted in the findings; a volume cell tetkit cannot reduce
/// is an error naming it. Bézier cells (VTK ids 78–80) are evaluated at
/// their lattice points (rational with a one-component point field named
/// `RationalWeights`, VTK's name for it) and cut there.
#[pyfunction]
#[pyo3(signature = (points, cell_types, offsets, connectivity, point_fields, cell_fields, scalar=None, dims=None, format="arrays"))]
#[allow(clippy::too_many_arguments)]
fn from_cells(
    py: Python<'_>,
    points: PyReadonlyArray2<'_, f64>,
    cell_types: PyReadonlyArray1<'_, i64>,
    offsets: PyReadonlyArray1<'_, i64>,
    connectivity: PyReadonlyArray1<'_, i64>,
    point_fields: Vec<FieldArg<'_>>,
    cell_fields: Vec<FieldArg<'_>>,
    scalar: Option<String>,
    dims: Option<(usize, usize, usize)>,
    format: &str,
) -> PyResult<PyBundle> {
    let p = points.as_array();
    if p.ncols() != 3 {
        return Err(arg_err("points", format!("shape {:?}: need N×3", p.shape())));
    }
    let n = p.nrows();
    if let Some((i, _)) = p.outer_iter().enumerate().find(|(_, r)| !r.iter().all(|v| v.is_finite())) {
        return Err(arg_err("points", format!("point {i} has a non-finite coordinate")));
    }
    let (types, offs, conn) = (cell_types.as_array(), offsets.as_array(), connectivity.as_array());
    let mut notes = Vec::new();
    // Cells holding Bézier control points (indices into the cells kept).
    let mut bezier: Vec<usize> = Vec::new();
    let (mut blocks, kept): (Vec<tet_mesh::Block>, Option<Vec<u32>>) = match dims {
        Some((nx, ny, nz)) => {
            if nx.checked_mul(ny).and_then(|v| v.checked_mul(nz)) != Some(n) {
                return Err(arg_err("dims", format!("{nx}×{ny}×{nz} for {n} points")));
            }
            (vec![tet_mesh::Block::Structured { dims: [nx, ny, nz], first_point: 0 }], None)
        }
        None => {
            let k = types.len();
            if offs.len() != k + 1 {
                return Err(arg_err(
                    "offsets",
                    format!("{} offsets for {k} cells: need one more than cells", offs.len()),
                ));
            }
            let mut cells = tet_mesh::Cells::new();
            let (mut kept, mut flat) = (Vec::new(), 0usize);
            let mut nodes: Vec<u32> = Vec::with_capacity(32);
            let mut reduced = 0usize;
            for c in 0..k {
                let (a, b) = (offs[c], offs[c + 1]);
                if a < 0 || b < a || b as usize > conn.len() {
                    return Err(arg_err(
                        "offsets",
                        format!("cell {c}: {a}..{b} is outside the {} connectivity entries", conn.len()),
                    ));
                }
                let id = u32::try_from(types[c]).unwrap_or(u32::MAX);
                let found = tet_mesh::CellType::from_vtk(id, (b - a) as usize, None)
                    .transpose()
                    .map_err(|m| arg_err("cell_types", format!("cell {c} (VTK type {id}): {m}")))?;
                match found {
                    Some((ty, stored)) => {
                        if (b - a) as usize != stored {
                            return Err(arg_err("connectivity", format!("cell {c} (VTK type {id}) lists {} points, needs {stored}", b - a)));
                        }
                        nodes.clear();
                        for &v in conn.slice(numpy::ndarray::s![a as usize..b as usize]).iter().take(ty.num_nodes()) {
                            nodes.push(u32::try_from(v).ok().filter(|&q| (q as usize) < n).ok_or_else(|| {
                                arg_err("connectivity", format!("cell {c} refers to point {v}; there are {n} points"))
                            })?);
                        }
                        reduced += usize::from(stored > ty.num_nodes());
                        if tet_mesh::CellType::vtk_id_is_bezier(id) && ty != ty.linear() {
                            bezier.push(cells.len());
                        }
                        cells.push(ty, &nodes);
                        kept.push(c as u32);
                    }
                    None if tet_mesh::CellType::vtk_id_is_surface_or_lower(id) => flat += 1,
                    None => {
                        return Err(arg_err(
                            "cell_types",
                            format!("cell {c} has VTK type {id}, which tetkit does not split (tetrahedra, hexahedra, voxels, wedges, pyramids, their quadratic forms and Lagrange and Bézier tetrahedra, hexahedra and wedges are read)"),
                        ))
                    }
                }
            }
            if flat > 0 {
                notes.push(format!("skipped {flat} cells without volume (vertices, lines, polygons)"));
            }
            if reduced > 0 {
                // As the file readers do: cells cut at their nodes would not
                // conform with a neighbour reduced to its corners.
                notes.push(format!("reduced {reduced} higher-order cells to their corner nodes"));
                let also = cells.reduce_to_corners();
                if also > 0 {
                    notes.push(format!("reduced {also} more higher-order cells to their corners as well, so that they conform with those"));
                }
            }
            if kept.is_empty() {
                // Not a point cloud to tetrahedralize: the cells had no volume.
                return Err(arg_err("cell_types", format!("no volume cells among the {k} cells")));
            }
            let all = kept.len() == k;
            (vec![tet_mesh::Block::Unstructured(cells)], (!all).then_some(kept))
        }
    };
    let num_cells: usize = blocks.iter().map(tet_mesh::Block::num_cells).sum();
    let mut point_fields = fields_of("point", point_fields, n, None)?;
    let cell_fields = match (&kept, dims) {
        (_, Some(_)) => fields_of("cell", cell_fields, num_cells, None)?,
        (Some(k), None) => fields_of("cell", cell_fields, types.len(), Some(k))?,
        (None, None) => fields_of("cell", cell_fields, num_cells, None)?,
    };
    let mut points: Vec<[f64; 3]> = p.outer_iter().map(|r| [r[0], r[1], r[2]]).collect();
    if let Some(tet_mesh::Block::Unstructured(cells)) = blocks.first_mut().filter(|_| !bezier.is_empty()) {
        // VTK writes the weights of rational cells as a point array it
        // flags; arrays handed over carry no flag, so the name VTK gives
        // it by default marks them.
        let weights = point_fields.iter().find(|f| f.name == "RationalWeights" && f.num_components == 1);
        let weights = weights.map(|f| f.values.clone());
        let r = tet_mesh::BezierEvaluator::new()
            .to_lagrange(cells, &bezier, &mut points, &mut point_fields, weights.as_deref())
            .map_err(|m| arg_err("connectivity", format!("Bézier cells: {m}")))?;
        notes.push(r.note(weights.is_some()));
    }
    let source = tet_mesh::SourceMesh {
        format: format.to_string(),
        points,
        blocks,
        point_fields,
        cell_fields,
        notes,
        ..Default::default()
    };
    bundle_of(py, source, scalar)
}

/// The view of `tetview render`: a VTK-fields view JSON, or the default
/// framing of the bundle's bounds orbited by azimuth/elevation/zoom.
/// The shading a Python call asks for: the view JSON's "lighting", a
/// light direction, the headlight, shadows (`tet_render::Lighting::choose`,
/// as `tetview`).
fn shading_of(
    view_json: Option<&str>,
    light: bool,
    light_dir: Option<(f64, f64, f64)>,
    shadows: bool,
) -> Result<Shading, tet_render::RenderError> {
    let from_view = match view_json {
        Some(text) => tet_render::Lighting::from_view_json(text)?,
        None => None,
    };
    let lighting = tet_render::Lighting::choose(from_view, light, light_dir.map(|(x, y, z)| [x, y, z]), shadows)?;
    Ok(lighting.map(|l| l.shading(None)).unwrap_or_default())
}

pub fn view_of(
    bundle: &Bundle,
    view_json: Option<&str>,
    azimuth: f64,
    elevation: f64,
    zoom: f64,
    size: [u32; 2],
) -> Result<ViewSpec, tet_render::RenderError> {
    if size[0] == 0 || size[1] == 0 || size[0] > 16384 || size[1] > 16384 {
        return Err(tet_render::RenderError::View(format!("size {}x{}: need 1 to 16384 a side", size[0], size[1])));
    }
    match view_json {
        Some(text) => {
            let mut v = ViewSpec::from_json(text)?;
            v.size = size;
            Ok(v)
        }
        None => {
            let s = &bundle.meta.stats;
            let z_up = tet_render::camera::bundle_is_z_up(&bundle.meta);
            Ok(ViewSpec::default_for(s.bounds_min, s.bounds_max, size, z_up, None)?.orbit(azimuth, elevation, zoom))
        }
    }
}

/// The TF of a request: JSON text (tf.md schema), a file, or the automatic
/// TF with an optional colour map.
fn tf_of(
    bundle: &Bundle,
    tf_json: Option<&str>,
    tf_path: Option<PathBuf>,
    colormap: Option<&str>,
) -> anyhow::Result<TransferFunction> {
    let source = match (tf_json, tf_path) {
        (Some(text), _) => TfSource::Given(TransferFunction::from_json(text)?),
        (None, Some(p)) => TfSource::File(p),
        (None, None) => TfSource::Auto,
    };
    let colormap = colormap.map(|c| c.parse::<Colormap>()).transpose()?;
    Ok(resolve_tf(bundle, &TfRequest { source, colormap, ..TfRequest::default() })?.tf)
}

fn image_to_py(py: Python<'_>, image: Image) -> Bound<'_, PyArray3<f32>> {
    let (w, h) = (image.width() as usize, image.height() as usize);
    // The pixels' buffer becomes the array's: no copy.
    let flat: Vec<f32> = image.into_pixels().into_flattened();
    Array3::from_shape_vec((h, w, 4), flat).expect("H×W×4").into_pyarray(py)
}

fn image_from_py(name: &str, a: &PyReadonlyArray3<'_, f32>) -> PyResult<Image> {
    let v = a.as_array();
    let shape = v.shape();
    if shape[2] != 4 {
        return Err(arg_err(name, format!("shape {shape:?}: need H×W×4 float32 RGBA")));
    }
    let px: Vec<[f32; 4]> =
        v.outer_iter().flat_map(|row| row.outer_iter().map(|p| [p[0], p[1], p[2], p[3]]).collect::<Vec<_>>()).collect();
    Image::from_pixels(shape[1] as u32, shape[0] as u32, px).map_err(|e| arg_err(name, e))
}

/// Pre-integration tables of a TF and a method baked over a bundle's
/// domain (`tetlut bake --bundle`): render with them (`render(table=...)`)
/// and save them as a `.tetl`.
#[pyclass(name = "Table", module = "tetkit")]
pub struct PyTable {
    look: Look,
    lut: tet_preint::LutFile,
}

#[pymethods]
impl PyTable {
    #[getter]
    fn method(&self) -> &'static str {
        self.look.method.id()
    }
    /// Seconds the bake took.
    #[getter]
    fn bake_seconds(&self) -> f64 {
        self.look.shader_seconds
    }
    /// Bytes of tabulated data (as stored in the file).
    #[getter]
    fn memory_bytes(&self) -> usize {
        self.look.baked.as_ref().map_or(0, |b| b.memory_bytes())
    }
    /// table3d: what the bake measured of itself — `certified`,
    /// `max_error` (largest per-segment error over its sample sets) and
    /// `target`; None for other methods.
    #[getter]
    fn certificate<'py>(&self, py: Python<'py>) -> PyResult<Option<Bound<'py, pyo3::types::PyDict>>> {
        let Some(tet_preint::Baked::Table3d(t)) = self.look.baked.as_deref() else { return Ok(None) };
        let Some(c) = t.certificate() else { return Ok(None) };
        let d = pyo3::types::PyDict::new(py);
        d.set_item("certified", c.certified)?;
        d.set_item("max_error", c.max_error)?;
        d.set_item("target", c.target)?;
        Ok(Some(d))
    }
    /// Writes the tables as a `.tetl` (what `tetview render --lut` reads).
    fn save(&self, py: Python<'_>, path: PathBuf) -> PyResult<()> {
        py.allow_threads(|| self.lut.write(&path)).map_err(|e| py_err(e.into()))
    }
    fn __repr__(&self) -> String {
        format!("<tetkit.Table {} ({} bytes)>", self.look.method.id(), self.memory_bytes())
    }
}

/// Bakes `method`'s tables for the TF over the bundle's domain, as
/// `tetview render` bakes them before drawing.
#[pyfunction]
#[pyo3(signature = (bundle, tf_json=None, tf_path=None, colormap=None, method="table3d"))]
fn bake(
    py: Python<'_>,
    bundle: &PyBundle,
    tf_json: Option<&str>,
    tf_path: Option<PathBuf>,
    colormap: Option<&str>,
    method: &str,
) -> PyResult<PyTable> {
    let b = &bundle.bundle;
    let (look, lut) = py
        .allow_threads(|| -> anyhow::Result<(Look, tet_preint::LutFile)> {
            let tf = tf_of(b, tf_json, tf_path.clone(), colormap)?;
            let look = Look::bake(b, method.parse::<Method>()?, tf)?;
            let domain = tet_preint::TableDomain::from_bundle(b)?;
            let tf_data = tet_preint::tf_for_domain(&look.tf, &domain)?;
            let lut = look.baked.as_ref().expect("Look::bake bakes").to_lut(&tf_data, &domain);
            Ok((look, lut))
        })
        .map_err(py_err)?;
    Ok(PyTable { look, lut })
}

/// Renders on the CPU as `tetview render` does (same TF policy, bake,
/// renderer and view), returning H×W×4 float32 linear premultiplied RGBA.
#[pyfunction]
#[pyo3(signature = (bundle, tf_json=None, tf_path=None, colormap=None, method="table3d", lut=None, view_json=None,
    azimuth=0.0, elevation=0.0, zoom=1.0, size=(512, 512), renderer="walk", light=false, cull=true, table=None,
    progress=None, light_dir=None, shadows=false, adaptive=None))]
#[allow(clippy::too_many_arguments)]
fn render<'py>(
    py: Python<'py>,
    bundle: &PyBundle,
    tf_json: Option<&str>,
    tf_path: Option<PathBuf>,
    colormap: Option<&str>,
    method: &str,
    lut: Option<PathBuf>,
    view_json: Option<&str>,
    azimuth: f64,
    elevation: f64,
    zoom: f64,
    size: (u32, u32),
    renderer: &str,
    light: bool,
    cull: bool,
    table: Option<PyRef<'py, PyTable>>,
    progress: Option<Py<PyAny>>,
    light_dir: Option<(f64, f64, f64)>,
    shadows: bool,
    adaptive: Option<f32>,
) -> PyResult<(Bound<'py, PyArray3<f32>>, Bound<'py, pyo3::types::PyDict>)> {
    let b = &bundle.bundle;
    let progress = progress_of(progress);
    let table_look = table.map(|t| t.look.clone());
    let (image, stats, engine_seconds) = py
        .allow_threads(|| -> anyhow::Result<(Image, tet_engine::FrameStats, f64)> {
            let start = std::time::Instant::now();
            // The look and the renderer are dropped inside the timed block:
            // freeing tables and the walker's mesh is the engine's time.
            let frame = {
                let look = match (&table_look, &lut) {
                    (Some(l), _) => l.clone(),
                    (None, Some(p)) => Look::from_lut(p)?,
                    (None, None) => {
                        Look::bake(b, method.parse::<Method>()?, tf_of(b, tf_json, tf_path.clone(), colormap)?)?
                    }
                };
                let view = view_of(b, view_json, azimuth, elevation, zoom, [size.0, size.1])?;
                // "gpu": projected tetrahedra on the GPU (the engine's
                // GpuFrameRenderer, as `tetview render --gpu`).
                let gpu = renderer == "gpu";
                let cpu: CpuRenderer = if gpu {
                    CpuRenderer::Pt
                } else {
                    renderer
                        .parse()
                        .map_err(|e: String| anyhow::Error::msg(format!("renderer: {e} (or gpu on the GPU)")))?
                };
                if let Some(tol) = adaptive {
                    tet_engine::check_adaptive(tol, cpu).map_err(|e| anyhow::Error::new(e).context("adaptive"))?;
                }
                let request = FrameRequest {
                    adaptive,
                    shading: shading_of(view_json, light, light_dir, shadows)?,
                    cpu,
                    cull,
                    ..FrameRequest::new(view)
                };
                if gpu {
                    let scene = tet_render::Scene::from_bundle(b)?;
                    let mut r = tet_engine::GpuFrameRenderer::new(b, scene, Default::default())?;
                    r.render(&look, &request, &progress)?
                } else {
                    let mut r = CpuFrameRenderer::new(b)?;
                    r.render(&look, &request, &progress)?
                }
            };
            Ok((frame.image, frame.stats, start.elapsed().as_secs_f64()))
        })
        .map_err(py_err)?;
    let d = pyo3::types::PyDict::new(py);
    d.set_item("engine_seconds", engine_seconds)?;
    match stats {
        tet_engine::FrameStats::Cpu(stats) => {
            d.set_item("frame_seconds", stats.total_seconds)?;
            d.set_item("renderer", stats.renderer.clone())?;
            d.set_item("tets_drawn", stats.tets_drawn)?;
            d.set_item("tets_culled", stats.tets_culled)?;
            d.set_item("crossings", stats.crossings)?;
            d.set_item("fragments", stats.fragments)?;
            d.set_item("rays_walked", stats.walk_rays)?;
            d.set_item("rays_interpolated", stats.walk_rays_interpolated)?;
        }
        tet_engine::FrameStats::Gpu(g) => {
            d.set_item("frame_seconds", g.render.total_seconds)?;
            d.set_item("renderer", "gpu")?;
            d.set_item("device", g.device.clone())?;
            d.set_item("tets_drawn", g.render.tets_drawn)?;
            d.set_item("tets_culled", g.render.tets_culled)?;
        }
        tet_engine::FrameStats::Reference { .. } => unreachable!("render draws with the CPU or the GPU renderer"),
    }
    Ok((image_to_py(py, image), d))
}

/// The engine's progress callback for a Python callable `f(done, total)`:
/// called with the GIL from the worker threads at most about a hundred
/// times a frame and once at the end, in increasing `done` (a count a
/// worker arrives with after a later one was delivered is dropped, so the
/// last call is always `(total, total)`); an exception in it is reported
/// as unraisable (`sys.unraisablehook`) and does not stop the render.
fn progress_of(f: Option<Py<PyAny>>) -> impl Fn(usize, usize) + Sync {
    // The lock orders the calls: two workers taking the GIL one after the
    // other could otherwise deliver 16 then 12. It is always taken before
    // the GIL, and the calling thread has released the GIL for the render.
    let delivered = std::sync::Mutex::new(0usize);
    move |done, total| {
        let Some(f) = &f else { return };
        let step = (total / 100).max(1);
        let mut last = delivered.lock().unwrap_or_else(std::sync::PoisonError::into_inner);
        if done <= *last || (done != total && done < *last + step) {
            return;
        }
        *last = done;
        Python::with_gil(|py| {
            if let Err(e) = f.call1(py, (done, total)) {
                e.write_unraisable(py, None);
            }
        });
    }
}

/// The exact ray-cast reference of the same view and TF (`tetview
/// reference`), H×W×4 float32.
#[pyfunction]
#[pyo3(signature = (bundle, tf_json=None, tf_path=None, colormap=None, view_json=None, azimuth=0.0, elevation=0.0,
    zoom=1.0, size=(512, 512), progress=None, light=false, light_dir=None, shadows=false))]
#[allow(clippy::too_many_arguments)]
fn reference<'py>(
    py: Python<'py>,
    bundle: &PyBundle,
    tf_json: Option<&str>,
    tf_path: Option<PathBuf>,
    colormap: Option<&str>,
    view_json: Option<&str>,
    azimuth: f64,
    elevation: f64,
    zoom: f64,
    size: (u32, u32),
    progress: Option<Py<PyAny>>,
    light: bool,
    light_dir: Option<(f64, f64, f64)>,
    shadows: bool,
) -> PyResult<Bound<'py, PyArray3<f32>>> {
    let b = &bundle.bundle;
    let progress = progress_of(progress);
    let image = py
        .allow_threads(|| -> anyhow::Result<Image> {
            let tf = tf_of(b, tf_json, tf_path.clone(), colormap)?;
            let view = view_of(b, view_json, azimuth, elevation, zoom, [size.0, size.1])?;
            let shading = shading_of(view_json, light, light_dir, shadows)?;
            let mut r = ReferenceFrameRenderer::new(b)?;
            Ok(r.render(&Look::exact(tf), &FrameRequest { shading, ..FrameRequest::new(view) }, &progress)?.image)
        })
        .map_err(py_err)?;
    Ok(image_to_py(py, image))
}

fn display(exposure: f32, background: (f32, f32, f32), reinhard: bool) -> PyResult<Display> {
    if !(exposure.is_finite() && exposure > 0.0) {
        return Err(arg_err("exposure", format!("{exposure}: need a positive number")));
    }
    let tonemap = if reinhard { ToneMap::Reinhard { key: 0.18, exposure } } else { ToneMap::None };
    Ok(Display { background: [background.0, background.1, background.2], tonemap })
}

/// 8-bit sRGB RGBA (H×W×4 uint8) of a linear image, tone mapped as
/// `tetview render` writes its PNG.
#[pyfunction]
#[pyo3(signature = (image, exposure=1.0, background=(0.0, 0.0, 0.0), reinhard=true))]
fn tonemap<'py>(
    py: Python<'py>,
    image: PyReadonlyArray3<'py, f32>,
    exposure: f32,
    background: (f32, f32, f32),
    reinhard: bool,
) -> PyResult<Bound<'py, PyArray3<u8>>> {
    let img = image_from_py("image", &image)?;
    let d = display(exposure, background, reinhard)?;
    let (w, h) = (img.width() as usize, img.height() as usize);
    let rgba = py.allow_threads(|| img.to_rgba8(&d));
    Ok(Array3::from_shape_vec((h, w, 4), rgba).expect("H×W×4").into_pyarray(py))
}

/// PNG bytes of an 8-bit RGBA array (H×W×4 uint8).
#[pyfunction]
fn encode_png(py: Python<'_>, rgba: numpy::PyReadonlyArray3<'_, u8>) -> PyResult<Vec<u8>> {
    let v = rgba.as_array();
    let shape = v.shape().to_vec();
    if shape[2] != 4 {
        return Err(arg_err("rgba", format!("shape {shape:?}: need H×W×4 uint8")));
    }
    let bytes: Vec<u8> = v.iter().copied().collect();
    py.allow_threads(|| tet_render::image::encode_png_rgba8(shape[1] as u32, shape[0] as u32, &bytes))
        .map_err(|e| arg_err("rgba", e))
}

/// Differences of two images of one size (linear premultiplied RGBA):
/// (rmse, max_abs, mean_abs, max 8-bit difference after tone mapping each).
#[pyfunction]
fn diff(py: Python<'_>, a: PyReadonlyArray3<'_, f32>, b: PyReadonlyArray3<'_, f32>) -> PyResult<(f64, f64, f64, u8)> {
    let (a, b) = (image_from_py("a", &a)?, image_from_py("b", &b)?);
    py.allow_threads(|| {
        let s = tet_render::image::diff(&a, &b)?;
        let d = Display::default();
        Ok::<_, tet_render::RenderError>((
            s.rmse,
            s.max_abs,
            s.mean_abs,
            tet_render::image::diff_rgba8(&a.to_rgba8(&d), &b.to_rgba8(&d)),
        ))
    })
    .map_err(|e| arg_err("a, b", e))
}

/// The methods `render` takes.
#[pyfunction]
fn methods() -> Vec<&'static str> {
    Method::ALL.iter().map(|m| m.id()).collect()
}

#[pymodule]
#[pyo3(name = "_tetkit")]
fn tetkit_native(m: &Bound<'_, PyModule>) -> PyResult<()> {
    m.add_class::<PyBundle>()?;
    m.add_class::<PyTable>()?;
    for f in [
        wrap_pyfunction!(load, m)?,
        wrap_pyfunction!(read, m)?,
        wrap_pyfunction!(from_arrays, m)?,
        wrap_pyfunction!(from_cells, m)?,
        wrap_pyfunction!(render, m)?,
        wrap_pyfunction!(reference, m)?,
        wrap_pyfunction!(bake, m)?,
        wrap_pyfunction!(tonemap, m)?,
        wrap_pyfunction!(encode_png, m)?,
        wrap_pyfunction!(diff, m)?,
        wrap_pyfunction!(methods, m)?,
    ] {
        m.add_function(f)?;
    }
    m.add("TetkitError", m.py().get_type::<TetkitError>())?;
    m.add("TetkitIOError", m.py().get_type::<TetkitIOError>())?;
    m.add("__version__", env!("CARGO_PKG_VERSION"))?;
    Ok(())
}
