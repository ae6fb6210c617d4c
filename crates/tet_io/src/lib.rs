//! Input readers for meshes, grids and volumes, and VTK XML export.
//!
//! Every reader turns a file into a [`tet_mesh::SourceMesh`]; point-cloud
//! readers ([`ply`], [`las`] with LAZ, [`obj`], [`gltf`], [`csv`]) return
//! points and point fields with no cells, for Delaunay. [`read_file`]
//! detects the format from the content or the extension (or takes
//! [`ReadOptions::format`]) and wraps any failure in a [`ReadError`] that
//! names the format, the place (line or byte offset) and the path.
//!
//! Readers work on bytes already in memory and never trust a declared count:
//! allocations are bounded by the input's size, so truncated or hostile files
//! produce errors, not panics (the fuzz targets in `fuzz/` hold them to it).
//!
//! ```
//! use tet_io::{read_bytes, Format};
//! let text = b"# vtk DataFile Version 3.0\ntet\nASCII\nDATASET UNSTRUCTURED_GRID\n\
//! POINTS 4 float\n0 0 0 1 0 0 0 1 0 0 0 1\nCELLS 1 5\n4 0 1 2 3\nCELL_TYPES 1\n10\n";
//! let mesh = read_bytes(text, Format::VtkLegacy).unwrap();
//! assert_eq!(mesh.points.len(), 4);
//! assert_eq!(mesh.num_cells(), 1);
//! ```

#![forbid(unsafe_code)]

pub mod csv;
pub mod cursor;
pub mod exodus;
pub mod gltf;
pub mod gmsh;
pub mod las;
pub mod netcdf;
pub mod nrrd;
pub mod obj;
pub mod openfoam;
pub mod plot3d;
pub mod ply;
pub mod raw;
pub mod series;
pub mod su2;
pub mod tetgen;
pub mod vtk_legacy;
pub mod vtk_xml;

use std::fmt;
use std::path::{Path, PathBuf};

pub use tet_mesh::SourceMesh;

/// Where in a file something went wrong.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Location {
    /// 1-based line of a text file.
    Line(usize),
    /// Byte offset from the start of the file.
    Byte(u64),
    /// The problem is with the file as a whole (e.g. counts that disagree).
    Whole,
}

impl fmt::Display for Location {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            Location::Line(l) => write!(f, "line {l}"),
            Location::Byte(b) => write!(f, "byte {b}"),
            Location::Whole => write!(f, "file"),
        }
    }
}

/// A reader's failure before the path is known: what and where.
#[derive(Debug, Clone, PartialEq)]
pub struct FormatError {
    pub at: Location,
    pub message: String,
    /// The location refers to the companion file (PLOT3D Q file, TetGen
    /// .ele, NRRD detached data) rather than the main one.
    pub in_companion: bool,
}

impl FormatError {
    pub fn new(at: Location, message: impl Into<String>) -> Self {
        FormatError { at, message: message.into(), in_companion: false }
    }

    /// Marks the error as belonging to the companion file.
    pub fn companion(mut self) -> Self {
        self.in_companion = true;
        self
    }
}

impl fmt::Display for FormatError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "{} at {}", self.message, self.at)
    }
}

/// Everything that can go wrong reading an input; the path comes last.
#[derive(Debug, thiserror::Error)]
pub enum ReadError {
    #[error("cannot read {}: {source}", path.display())]
    Io {
        #[source]
        source: std::io::Error,
        path: PathBuf,
    },
    #[error("{format}: {message} ({})", place(at, path))]
    Malformed { format: Format, message: String, at: Location, path: PathBuf },
    /// A time-series index (`.pvd`, `.series`) that cannot be used.
    #[error("time series: {message} ({})", place(at, path))]
    BadSeries { message: String, at: Location, path: PathBuf },
    #[error("cannot tell the format of {}: {hint}; pass --format", path.display())]
    UnknownFormat { hint: String, path: PathBuf },
    #[error("{format} input needs {what} ({})", path.display())]
    MissingOption { format: Format, what: String, path: PathBuf },
    /// A format recognised (by extension or magic bytes) that no `--format`
    /// reads yet.
    #[error("this is {kind}, which tetkit does not read yet (no --format value reads it); \
             convert it to VTK XML (.vtu) first, e.g. with ParaView (File > Save Data) or meshio: {}", path.display())]
    Unsupported { kind: Unsupported, path: PathBuf },
}

/// Formats `tetprep` recognises but cannot read yet, so it can say what a
/// file is instead of asking for a `--format` that does not exist.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Unsupported {
    /// CGNS (`.cgns`, HDF5 or ADF).
    Cgns,
    /// A NetCDF file of no known mesh convention.
    NetCdf,
    /// An HDF5 file of no known mesh convention.
    Hdf5,
}

impl fmt::Display for Unsupported {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(match self {
            Unsupported::Cgns => "a CGNS file",
            Unsupported::NetCdf => "a NetCDF file",
            Unsupported::Hdf5 => "an HDF5 file",
        })
    }
}

/// NetCDF classic / 64-bit offset / 64-bit data magic.
fn is_netcdf(head: &[u8]) -> bool {
    head.len() >= 4 && head.starts_with(b"CDF") && matches!(head[3], 1 | 2 | 5)
}

use netcdf::HDF5_MAGIC;

/// What an input is when it is a format no reader handles: by the magic
/// bytes first (so a NetCDF `.g` is not taken for a PLOT3D grid), then the
/// extension; `head` is the file's first bytes (empty for a directory).
pub fn detect_unsupported(path: &Path, head: &[u8]) -> Option<Unsupported> {
    if path.is_dir() {
        return None;
    }
    let ext = lower_ext(path);
    let exodus_ext = matches!(ext.as_str(), "exo" | "ex2" | "exii" | "e" | "g" | "gen");
    let hdf5 = head.starts_with(HDF5_MAGIC);
    if (is_netcdf(head) || hdf5) && (exodus_ext || looks_like_exodus(head)) {
        // Read by [`Format::Exodus`] (classic netCDF or netCDF-4).
        return None;
    }
    if is_netcdf(head) || hdf5 {
        return Some(match ext.as_str() {
            "cgns" => Unsupported::Cgns,
            _ if hdf5 => Unsupported::Hdf5,
            _ => Unsupported::NetCdf,
        });
    }
    match ext.as_str() {
        "cgns" | "adf" => return Some(Unsupported::Cgns),
        "nc" | "cdf" => return Some(Unsupported::NetCdf),
        "h5" | "hdf5" | "hdf" => return Some(Unsupported::Hdf5),
        _ => {}
    }
    head.starts_with(b"ADF Database Version").then_some(Unsupported::Cgns)
}

/// A netCDF header naming Exodus II's dimensions.
fn looks_like_exodus(head: &[u8]) -> bool {
    let has = |n: &[u8]| head.windows(n.len()).any(|w| w == n);
    has(b"num_el_blk") && has(b"num_nodes")
}

/// "at byte 12 of x.vtk", "at line 3 of x.msh", or "in x.bin" for whole-file problems.
fn place(at: &Location, path: &Path) -> String {
    match at {
        Location::Whole => format!("in {}", path.display()),
        _ => format!("at {at} of {}", path.display()),
    }
}

/// Input formats `tetprep convert` understands.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum Format {
    /// Legacy `.vtk`, ASCII or BINARY.
    VtkLegacy,
    /// VTK XML `.vtu`, `.vts`, `.vti`.
    VtkXml,
    /// VTK XML parallel unstructured `.pvtu` (pieces read from disk).
    Pvtu,
    /// PLOT3D grid (`.xyz`/`.x`/`.g`/`.bin`) with an optional Q solution.
    Plot3d,
    /// Gmsh `.msh` 2.2 or 4.1, ASCII or binary.
    Gmsh,
    /// TetGen `.node` + `.ele`.
    TetGen,
    /// Raw brick of voxels (dims, type, endianness from options).
    Raw,
    /// NRRD header (attached or detached data; raw or gzip encoding).
    Nrrd,
    /// PLY point cloud (ascii or binary): the vertex element.
    Ply,
    /// LAS 1.0–1.4 lidar, uncompressed or LAZ.
    Las,
    /// Wavefront OBJ vertex list.
    Obj,
    /// glTF / GLB `POINTS` primitives.
    Gltf,
    /// CSV / XYZ point table (header line or [`ReadOptions::columns`]).
    Csv,
    /// SU2 native mesh (`.su2`, ASCII), with an optional CSV solution
    /// ([`ReadOptions::solution`]).
    Su2,
    /// Exodus II in netCDF classic form, results at
    /// [`ReadOptions::time_step`].
    Exodus,
    /// An OpenFOAM case (directory, `*.foam` file or polyMesh directory),
    /// polyhedra included, cell fields at [`ReadOptions::time_step`].
    OpenFoam,
}

impl Format {
    /// Name as accepted by `--format`.
    pub fn name(self) -> &'static str {
        match self {
            Format::VtkLegacy => "vtk",
            Format::VtkXml => "vtk-xml",
            Format::Pvtu => "pvtu",
            Format::Plot3d => "plot3d",
            Format::Gmsh => "gmsh",
            Format::TetGen => "tetgen",
            Format::Raw => "raw",
            Format::Nrrd => "nrrd",
            Format::Ply => "ply",
            Format::Las => "las",
            Format::Obj => "obj",
            Format::Gltf => "gltf",
            Format::Csv => "csv",
            Format::Su2 => "su2",
            Format::Exodus => "exodus",
            Format::OpenFoam => "openfoam",
        }
    }

    pub const ALL: [Format; 16] = [
        Format::VtkLegacy,
        Format::VtkXml,
        Format::Pvtu,
        Format::Plot3d,
        Format::Gmsh,
        Format::TetGen,
        Format::Raw,
        Format::Nrrd,
        Format::Ply,
        Format::Las,
        Format::Obj,
        Format::Gltf,
        Format::Csv,
        Format::Su2,
        Format::Exodus,
        Format::OpenFoam,
    ];

    /// Parses a `--format` name; `laz`, `glb` and `xyz-points` are accepted
    /// as aliases of `las`, `gltf` and `csv`.
    pub fn from_name(name: &str) -> Option<Format> {
        match name.to_ascii_lowercase().as_str() {
            "laz" => return Some(Format::Las),
            "glb" => return Some(Format::Gltf),
            "xyz-points" | "tsv" => return Some(Format::Csv),
            _ => {}
        }
        Format::ALL.into_iter().find(|f| f.name().eq_ignore_ascii_case(name))
    }

    /// True for formats that hold scattered points and no cells.
    pub fn is_point_cloud(self) -> bool {
        matches!(self, Format::Ply | Format::Las | Format::Obj | Format::Gltf | Format::Csv)
    }
}

impl fmt::Display for Format {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(match self {
            Format::VtkLegacy => "legacy VTK",
            Format::VtkXml => "VTK XML",
            Format::Pvtu => "VTK XML (parallel)",
            Format::Plot3d => "PLOT3D",
            Format::Gmsh => "Gmsh",
            Format::TetGen => "TetGen",
            Format::Raw => "raw volume",
            Format::Nrrd => "NRRD",
            Format::Ply => "PLY",
            Format::Las => "LAS/LAZ",
            Format::Obj => "OBJ",
            Format::Gltf => "glTF",
            Format::Csv => "CSV",
            Format::Su2 => "SU2",
            Format::Exodus => "Exodus II",
            Format::OpenFoam => "OpenFOAM",
        })
    }
}

/// Options for [`read_file`] beyond the path.
#[derive(Debug, Clone, Default)]
pub struct ReadOptions {
    /// Force a format instead of detecting it.
    pub format: Option<Format>,
    /// PLOT3D Q (solution) file.
    pub q_path: Option<PathBuf>,
    pub plot3d: plot3d::Plot3dOptions,
    /// Layout of a raw volume (required for [`Format::Raw`]).
    pub raw: Option<raw::RawSpec>,
    /// SU2 solution: a CSV table with a row per mesh point (SU2's
    /// `restart_flow.csv` or `flow.csv`).
    pub solution: Option<PathBuf>,
    /// Results files: the time step (0-based) whose fields are read. Exodus
    /// II: the first when unset. OpenFOAM: an index into the case's time
    /// directories sorted by time, the latest when unset.
    pub time_step: Option<usize>,
    /// Column names of a CSV/XYZ point table, in order (`x`, `y`, `z` and
    /// field names; `_` skips a column). Replaces the file's header line.
    pub columns: Option<Vec<String>>,
}

/// Reads a single in-memory file of a format that needs no companion file or
/// options (legacy VTK, VTK XML, Gmsh, NRRD with attached data, the point
/// clouds; glTF only with embedded buffers, CSV with a header line). Used by
/// tests and fuzz targets.
pub fn read_bytes(bytes: &[u8], format: Format) -> Result<SourceMesh, FormatError> {
    match format {
        Format::VtkLegacy => vtk_legacy::read(bytes),
        Format::VtkXml => vtk_xml::read(bytes),
        Format::Gmsh => gmsh::read(bytes),
        Format::Nrrd => nrrd::read(bytes, &mut |name: &str| {
            Err(std::io::Error::new(std::io::ErrorKind::NotFound, format!("detached data file '{name}' not available")))
        }),
        Format::Plot3d => plot3d::read(bytes, None, &plot3d::Plot3dOptions::default()),
        Format::Ply => ply::read(bytes),
        Format::Las => las::read(bytes),
        Format::Obj => obj::read(bytes),
        Format::Csv => csv::read(bytes, None),
        Format::Su2 => su2::read(bytes),
        Format::Exodus => exodus::read(bytes, &exodus::ExodusOptions::default()),
        Format::Gltf => gltf::read(bytes, &mut |uri: &str| {
            Err(std::io::Error::new(std::io::ErrorKind::NotFound, format!("external buffer '{uri}' not available")))
        }),
        Format::Pvtu | Format::TetGen | Format::Raw | Format::OpenFoam => Err(FormatError::new(
            Location::Whole,
            format!("{format} input needs companion files, a directory or options; use read_file"),
        )),
    }
}

fn lower_ext(path: &Path) -> String {
    path.extension().and_then(|e| e.to_str()).unwrap_or("").to_ascii_lowercase()
}

/// Detects the format from the first bytes, then the extension.
pub fn detect_format(path: &Path, head: &[u8], opts: &ReadOptions) -> Option<Format> {
    if path.is_dir() {
        // A case directory, or one inside a case (its constant/polyMesh).
        return openfoam::case_dir(path).is_some().then_some(Format::OpenFoam);
    }
    let ext = lower_ext(path);
    if matches!(ext.as_str(), "pvtu" | "pvts" | "pvti") {
        return Some(Format::Pvtu);
    }
    let text = String::from_utf8_lossy(&head[..head.len().min(4096)]);
    if text.starts_with("# vtk DataFile") {
        return Some(Format::VtkLegacy);
    }
    if text.contains("<VTKFile") {
        return Some(if text.contains("type=\"PUnstructuredGrid\"") { Format::Pvtu } else { Format::VtkXml });
    }
    if text.trim_start().starts_with("$MeshFormat") {
        return Some(Format::Gmsh);
    }
    if text.starts_with("NRRD000") {
        return Some(Format::Nrrd);
    }
    if head.starts_with(b"ply\n") || head.starts_with(b"ply\r\n") {
        return Some(Format::Ply);
    }
    if head.starts_with(b"LASF") {
        return Some(Format::Las);
    }
    if (is_netcdf(head) || head.starts_with(HDF5_MAGIC))
        && (looks_like_exodus(head) || matches!(ext.as_str(), "exo" | "ex2" | "exii" | "e" | "g" | "gen"))
    {
        return Some(Format::Exodus);
    }
    if text.lines().take(64).any(|l| l.trim_start().starts_with("NDIME=")) {
        return Some(Format::Su2);
    }
    if ext == "foam" || text.contains("FoamFile") {
        return Some(Format::OpenFoam);
    }
    if head.starts_with(b"glTF") || (text.trim_start().starts_with('{') && text.contains("\"asset\"")) {
        return Some(Format::Gltf);
    }
    match ext.as_str() {
        "ply" => return Some(Format::Ply),
        "las" | "laz" => return Some(Format::Las),
        "obj" => return Some(Format::Obj),
        "gltf" | "glb" => return Some(Format::Gltf),
        "csv" | "tsv" | "txt" | "pts" => return Some(Format::Csv),
        // `.xyz` is both PLOT3D's grid extension and the plain point-table
        // one: a column spec or a table-like first line decides.
        "xyz" if opts.columns.is_some() || csv::looks_like_point_table(head) => return Some(Format::Csv),
        _ => {}
    }
    match ext.as_str() {
        "vtk" => Some(Format::VtkLegacy),
        "vtu" | "vts" | "vti" | "vtr" => Some(Format::VtkXml),
        "msh" => Some(Format::Gmsh),
        "su2" => Some(Format::Su2),
        "exo" | "ex2" | "exii" => Some(Format::Exodus),
        "node" | "ele" => Some(Format::TetGen),
        "nrrd" | "nhdr" => Some(Format::Nrrd),
        "raw" if opts.raw.is_some() => Some(Format::Raw),
        _ if opts.raw.is_some() => Some(Format::Raw),
        "xyz" | "x" | "g" | "p3d" | "grd" | "bin" | "q" | "fmt" => Some(Format::Plot3d),
        _ if opts.q_path.is_some() => Some(Format::Plot3d),
        _ if opts.columns.is_some() => Some(Format::Csv),
        _ => None,
    }
}

fn read_all(path: &Path) -> Result<Vec<u8>, ReadError> {
    std::fs::read(path).map_err(|source| ReadError::Io { source, path: path.to_path_buf() })
}

/// A reader of a file's bytes that loads the companion files named inside
/// it through the callback (by the name as written).
type CompanionReader = fn(&[u8], &mut dyn FnMut(&str) -> std::io::Result<Vec<u8>>) -> Result<SourceMesh, FormatError>;

/// Runs `read` on `bytes`, the contents of `path`, with companion names
/// resolved against `path`'s directory: its result, and the last companion
/// it loaded (an error marked as in a companion names that file).
fn read_with_companions(
    path: &Path,
    bytes: &[u8],
    read: CompanionReader,
) -> (Result<SourceMesh, FormatError>, Option<PathBuf>) {
    let dir = path.parent().map(Path::to_path_buf).unwrap_or_default();
    let mut companion: Option<PathBuf> = None;
    let result = read(bytes, &mut |name: &str| {
        let p = dir.join(name);
        companion = Some(p.clone());
        std::fs::read(p)
    });
    (result, companion)
}

/// Reads any supported input file (with its companions) into a [`SourceMesh`].
pub fn read_file(path: &Path, opts: &ReadOptions) -> Result<SourceMesh, ReadError> {
    let format = match opts.format {
        Some(f) => f,
        None => {
            if lower_ext(path) == "ele" {
                Format::TetGen
            } else if path.is_dir() {
                detect_format(path, &[], opts).ok_or_else(|| ReadError::UnknownFormat {
                    hint: "a directory is read only as an OpenFOAM case (constant/polyMesh, system/controlDict or processor0 in it or above it)".into(),
                    path: path.to_path_buf(),
                })?
            } else {
                let unsupported = |kind| ReadError::Unsupported { kind, path: path.to_path_buf() };
                let bytes = read_all(path)?;
                let head = &bytes[..bytes.len().min(4096)];
                if let Some(kind) = detect_unsupported(path, head) {
                    return Err(unsupported(kind));
                }
                detect_format(path, head, opts).ok_or_else(|| ReadError::UnknownFormat {
                    hint: "the content matches no known header and the extension is not recognised".into(),
                    path: path.to_path_buf(),
                })?
            }
        }
    };
    let malformed = |e: FormatError, main: &Path, companion: Option<&Path>| ReadError::Malformed {
        format,
        message: e.message,
        at: e.at,
        path: if e.in_companion { companion.unwrap_or(main).to_path_buf() } else { main.to_path_buf() },
    };
    match format {
        Format::Pvtu => vtk_xml::read_pvtu(path),
        Format::TetGen => {
            let (node, ele) = tetgen::companion_paths(path);
            let node_bytes = read_all(&node)?;
            let ele_bytes = read_all(&ele)?;
            tetgen::read(&node_bytes, &ele_bytes).map_err(|e| malformed(e, &node, Some(&ele)))
        }
        Format::Plot3d => {
            let xyz = read_all(path)?;
            let q = match &opts.q_path {
                Some(q) => Some(read_all(q)?),
                None => None,
            };
            plot3d::read(&xyz, q.as_deref(), &opts.plot3d).map_err(|e| malformed(e, path, opts.q_path.as_deref()))
        }
        Format::Raw => {
            let spec = opts.raw.as_ref().ok_or_else(|| ReadError::MissingOption {
                format,
                what: "--dims, --type and --endian".into(),
                path: path.to_path_buf(),
            })?;
            let bytes = read_all(path)?;
            raw::read(&bytes, spec).map_err(|e| malformed(e, path, None))
        }
        Format::Nrrd | Format::Gltf => {
            let bytes = read_all(path)?;
            // NRRD's detached data file, glTF's external buffers.
            let read: CompanionReader = if format == Format::Nrrd { nrrd::read } else { gltf::read };
            let (result, companion) = read_with_companions(path, &bytes, read);
            result.map_err(|e| malformed(e, path, companion.as_deref()))
        }
        Format::Csv => {
            let bytes = read_all(path)?;
            csv::read(&bytes, opts.columns.as_deref()).map_err(|e| malformed(e, path, None))
        }
        Format::Exodus => {
            let bytes = read_all(path)?;
            exodus::read(&bytes, &exodus::ExodusOptions { time_step: opts.time_step })
                .map_err(|e| malformed(e, path, None))
        }
        Format::OpenFoam => openfoam::read_case(path, &openfoam::FoamOptions { time_step: opts.time_step }),
        Format::Su2 => {
            let bytes = read_all(path)?;
            let mut mesh = su2::read(&bytes).map_err(|e| malformed(e, path, None))?;
            if let Some(sol) = &opts.solution {
                let csv = read_all(sol)?;
                su2::attach_solution(&mut mesh, &csv).map_err(|e| malformed(e, path, Some(sol)))?;
            }
            Ok(mesh)
        }
        Format::VtkLegacy | Format::VtkXml | Format::Gmsh | Format::Ply | Format::Las | Format::Obj => {
            let bytes = read_all(path)?;
            read_bytes(&bytes, format).map_err(|e| malformed(e, path, None))
        }
    }
}
