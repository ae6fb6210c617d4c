//! Command-line definition and dispatch.

use clap::{Args, Parser, Subcommand, ValueEnum};
use std::path::PathBuf;

/// Convert meshes, curvilinear grids, volumes and point clouds into validated tetrahedral
/// bundles (.tetb) for tetlut and tetview.
///
/// Exit codes: listed below (`tet_cli::ExitKind`, the same in every tetkit program).
#[derive(Debug, Parser)]
#[command(name = "tetprep", version, about, long_about = None, after_help = tet_cli::EXIT_CODES_HELP)]
pub struct Cli {
    #[command(subcommand)]
    pub command: Command,
}

#[derive(Debug, Subcommand)]
pub enum Command {
    /// Convert an input mesh, grid, volume or point cloud into a bundle.
    ///
    /// Formats (detected from content or extension; --format to force):
    /// legacy VTK (.vtk), VTK XML (.vtu .vts .vti .pvtu), PLOT3D grid (+ --q
    /// solution), Gmsh (.msh 2.2/4.1), TetGen (.node/.ele), SU2 (.su2, +
    /// --solution CSV), Exodus II (netCDF classic; --time-step), NRRD (.nrrd
    /// .nhdr), raw volumes (--format raw --dims --type --endian); point clouds:
    /// PLY, LAS/LAZ, OBJ vertex lists, glTF/GLB POINTS, CSV/XYZ tables
    /// (header line or --columns). Time series: a ParaView .pvd or .series
    /// listing one file a step, or --all-steps of an Exodus file or
    /// OpenFOAM case: the mesh once, the scalar of every step.
    ///
    /// Example: tetprep convert bluntfinxyz.bin --q bluntfinq.bin --scalar density -o bluntfin.tetb
    Convert(Box<ConvertArgs>),
    /// Cut a bundle into N pieces by a k-d tree for distributed rendering.
    ///
    /// Tets straddling a plane are clipped exactly at it (the scalar stays
    /// linear, so the pieces draw what the whole does); each piece is a
    /// validated bundle, with the time steps of a series. DIR gets the
    /// pieces and manifest.json (the tree, boxes, checksums and the whole
    /// mesh's scalar range), written atomically.
    ///
    /// Example: tetprep partition bluntfin.tetb --parts 8 -o bluntfin.parts
    Partition(Box<PartitionArgs>),
    /// Print a bundle's counts, bounds, scalar range, cell sizes and boundary
    /// facts; or a partition manifest's tree, boxes, counts and whether each
    /// piece file matches its checksum.
    Info {
        /// A bundle (.tetb), or a partition's manifest.json or directory.
        bundle: PathBuf,
        /// Machine-readable JSON instead of text.
        #[arg(long)]
        json: bool,
    },
    /// Write a bundle's tets and every per-vertex field to VTK XML (.vtu) for ParaView.
    Export {
        bundle: PathBuf,
        #[arg(short, long)]
        output: PathBuf,
    },
    /// Add gradients, histograms, per-cell ranges and frequency limits to a bundle.
    ///
    /// Ranges, segment facts and frequency limits are always computed; what the
    /// bundle already has is kept (and recomputed alongside).
    ///
    /// Example: tetprep analyze bluntfin.tetb --gradients --histogram
    Analyze {
        bundle: PathBuf,
        /// Output bundle (default: rewrite BUNDLE in place, atomically).
        #[arg(short, long)]
        output: Option<PathBuf>,
        #[command(flatten)]
        analysis: AnalysisArgs,
        /// Print the summary as JSON.
        #[arg(long)]
        json: bool,
    },
    /// Draw the volume-weighted 2D histogram (scalar × |∇s|) as a PNG, with
    /// the 1D histogram along the top; computed on the fly if not stored.
    ///
    /// Example: tetprep hist bluntfin.tetb -o hist.png --csv hist.csv
    Hist {
        bundle: PathBuf,
        /// Output PNG.
        #[arg(short, long)]
        output: PathBuf,
        /// Also write the bin volumes as CSV.
        #[arg(long)]
        csv: Option<PathBuf>,
        /// Logarithmic colour and bar scale (the default).
        #[arg(long, conflicts_with = "linear")]
        log: bool,
        /// Linear colour and bar scale.
        #[arg(long)]
        linear: bool,
        /// Recompute with these bins (SCALAR,GRADIENT) instead of the stored histogram.
        #[arg(long, value_parser = parse_bins)]
        bins: Option<[u32; 2]>,
        /// Scalar axis range LO,HI (recomputes).
        #[arg(long, value_parser = tet_cli::parse_range, allow_hyphen_values = true)]
        scalar_range: Option<(f64, f64)>,
        /// |∇s| axis range LO,HI (recomputes).
        #[arg(long, value_parser = tet_cli::parse_range, allow_hyphen_values = true)]
        gradient_range: Option<(f64, f64)>,
        /// Units of the scalar for the axis labels, e.g. "kg/m^3" (input files
        /// rarely carry units, so tetkit cannot know them).
        #[arg(long, value_name = "UNIT")]
        units: Option<String>,
        /// Length unit of the coordinates for the |∇s| label, e.g. "m".
        #[arg(long, value_name = "UNIT")]
        length_units: Option<String>,
    },
}

#[derive(Debug, Clone, Copy, ValueEnum, PartialEq, Eq)]
pub enum GradientArg {
    /// Least squares over each vertex's one-ring.
    Lsq,
    /// Volume-weighted average of the per-tet gradients.
    TetAverage,
}

/// What `convert` and `analyze` compute beyond the mesh.
#[derive(Debug, Clone, Args)]
pub struct AnalysisArgs {
    /// Compute and store per-vertex gradients of the scalar.
    #[arg(long)]
    pub gradients: bool,
    /// How per-vertex gradients are computed.
    #[arg(long, value_enum, default_value = "lsq")]
    pub gradient_method: GradientArg,
    /// Compute and store the volume-weighted 1D and scalar × |∇s| histograms.
    #[arg(long)]
    pub histogram: bool,
    /// Histogram bins: SCALAR,GRADIENT.
    #[arg(long, value_parser = parse_bins, default_value = "256,256")]
    pub bins: [u32; 2],
    /// Histogram scalar range LO,HI (default: the scalar's range).
    #[arg(long, value_parser = tet_cli::parse_range, allow_hyphen_values = true)]
    pub scalar_range: Option<(f64, f64)>,
    /// Histogram |∇s| range LO,HI (default: 0 to the 99.9% volume quantile).
    #[arg(long, value_parser = tet_cli::parse_range, allow_hyphen_values = true)]
    pub gradient_range: Option<(f64, f64)>,
}

#[derive(Debug, Args)]
pub struct PartitionArgs {
    /// The bundle to cut.
    pub bundle: PathBuf,
    /// Number of pieces (any N ≥ 1, at most the number of tets).
    #[arg(long)]
    pub parts: usize,
    /// What the planes balance: tets (equal tet counts: projected
    /// tetrahedra's work) or crossings (tets weighted by their surface
    /// area, their expected ray crossings: the walker's work).
    #[arg(long, value_enum, default_value = "tets")]
    pub cost: CostArg,
    /// Output directory (created; its pieces and manifest.json appear together).
    #[arg(short, long)]
    pub output: PathBuf,
    /// Replace an existing non-empty output directory.
    #[arg(long)]
    pub force: bool,
    /// Print the manifest and timings as JSON.
    #[arg(long)]
    pub json: bool,
    /// No progress bars or summary (errors are still printed).
    #[arg(short, long)]
    pub quiet: bool,
    /// What each piece gets beyond its mesh, as `convert` computes it (the
    /// histogram's scalar axis defaults to the whole mesh's range, so the
    /// pieces' histograms add up to the whole's).
    #[command(flatten, next_help_heading = "Analysis of each piece")]
    pub analysis: AnalysisArgs,
}

#[derive(Debug, Clone, Copy, ValueEnum)]
pub enum CostArg {
    Tets,
    Crossings,
}

#[derive(Debug, Clone, Copy, ValueEnum)]
pub enum SplitArg {
    #[value(name = "5")]
    Five,
    #[value(name = "6")]
    Six,
}

#[derive(Debug, Clone, Copy, ValueEnum)]
pub enum ModeArg {
    Delaunay,
    Layered,
}

#[derive(Debug, Clone, Copy, ValueEnum)]
pub enum NanArg {
    Error,
    Drop,
}

#[derive(Debug, Clone, Copy, ValueEnum)]
pub enum EndianArg {
    Little,
    Big,
}

#[derive(Debug, Args)]
pub struct ConvertArgs {
    /// Input file (for TetGen either the .node or the .ele).
    pub input: PathBuf,
    /// Output bundle.
    #[arg(short, long)]
    pub output: PathBuf,
    /// Input format: vtk, vtk-xml, pvtu, plot3d, gmsh, tetgen, raw, nrrd,
    /// ply, las (also LAZ), obj, gltf (also GLB), csv.
    #[arg(long, value_parser = parse_format)]
    pub format: Option<tet_io::Format>,
    /// Scalar to keep: a field name (a vector gives its magnitude), NAME:x|y|z|N
    /// for a component, NAME:mag, or x|y|z for a coordinate. Default: the first
    /// point field, else the first cell field. A wrong name lists what the file has.
    #[arg(long)]
    pub scalar: Option<String>,
    /// Structured grids: alternating 5-tet split or conforming 6-tet split.
    /// Unstructured hexahedra always use the conforming 6-tet split.
    #[arg(long, value_enum, default_value = "5")]
    pub split: SplitArg,
    /// Non-finite scalars or coordinates: fail (naming the first), or drop the tets touching them.
    #[arg(long, value_enum, default_value = "error")]
    pub nan: NanArg,
    /// Merge points closer than this fraction of the bounding-box diagonal.
    #[arg(long, default_value_t = 1e-10)]
    pub merge_tolerance: f64,
    /// Do not carry the input's other point fields into the bundle.
    #[arg(long)]
    pub scalar_only: bool,
    /// Point clouds (inputs without cells): 3D Delaunay of the convex hull, or
    /// layered prisms for points on layers sharing xy columns (terrain,
    /// boreholes, atmospheric columns).
    #[arg(long, value_enum, default_value = "delaunay")]
    pub mode: ModeArg,
    /// Point clouds, Delaunay mode: peel hull-filling tets whose circumradius
    /// exceeds R (world units), for scans of non-convex objects.
    #[arg(long, value_name = "R")]
    pub max_circumradius: Option<f64>,
    /// Print the summary as JSON.
    #[arg(long)]
    pub json: bool,
    #[command(flatten, next_help_heading = "Analysis")]
    pub analysis: AnalysisArgs,
    /// No progress bars or summary (errors are still printed).
    #[arg(short, long)]
    pub quiet: bool,

    /// CSV/XYZ point tables: column names in order, e.g. x,y,z,value (`_`
    /// skips a column). Replaces the file's header line.
    #[arg(long, value_delimiter = ',', help_heading = "Point tables")]
    pub columns: Option<Vec<String>>,

    /// SU2 meshes: the solution as SU2 writes it in CSV (restart_flow.csv,
    /// flow.csv; a header line, one row per mesh point, matched by PointID).
    #[arg(long, help_heading = "SU2")]
    pub solution: Option<PathBuf>,

    /// Results files: the time step, from 0, whose fields are read. Exodus
    /// II: nodal and element variables (default: the first). OpenFOAM: the
    /// N-th time directory in time order (default: the latest).
    #[arg(long, help_heading = "Results (Exodus II, OpenFOAM)", conflicts_with = "all_steps")]
    pub time_step: Option<usize>,

    /// Results files: every time step into one bundle (the mesh once, the
    /// scalar of each step with its time; `tetview render --time T`).
    /// Exodus II: each step of `time_whole`; OpenFOAM: each time directory.
    /// A ParaView .pvd or .series input is always read as a time series.
    #[arg(long, help_heading = "Results (Exodus II, OpenFOAM)")]
    pub all_steps: bool,

    #[command(flatten, next_help_heading = "PLOT3D")]
    pub plot3d: Plot3dArgs,
    #[command(flatten, next_help_heading = "Raw volumes")]
    pub raw: RawArgs,
}

#[derive(Debug, Args)]
pub struct Plot3dArgs {
    /// PLOT3D Q (solution) file.
    #[arg(long)]
    pub q: Option<PathBuf>,
    /// Byte order (default: detected).
    #[arg(long, value_enum)]
    pub plot3d_endian: Option<EndianArg>,
    /// Planes layout instead of whole (cannot be detected).
    #[arg(long)]
    pub plot3d_planes: bool,
    /// Ratio of specific heats for derived fields.
    #[arg(long, default_value_t = 1.4)]
    pub gamma: f64,
}

#[derive(Debug, Args)]
pub struct RawArgs {
    /// Raw volume size in voxels: NX,NY,NZ.
    #[arg(long, value_parser = tet_cli::parse_counts3)]
    pub dims: Option<[usize; 3]>,
    /// Raw voxel type: i8 u8 i16 u16 i32 u32 i64 u64 f32 f64.
    #[arg(long = "type")]
    pub voxel_type: Option<String>,
    /// Raw byte order.
    #[arg(long, value_enum)]
    pub endian: Option<EndianArg>,
    /// Raw voxel spacing: SX,SY,SZ.
    #[arg(long, value_parser = tet_cli::parse_xyz, default_value = "1,1,1", allow_hyphen_values = true)]
    pub spacing: [f64; 3],
    /// Raw volume origin: OX,OY,OZ.
    #[arg(long, value_parser = tet_cli::parse_xyz, default_value = "0,0,0", allow_hyphen_values = true)]
    pub origin: [f64; 3],
    /// Bytes to skip at the start of a raw file.
    #[arg(long, default_value_t = 0)]
    pub header_bytes: usize,
}

fn parse_format(s: &str) -> Result<tet_io::Format, String> {
    tet_io::Format::from_name(s).ok_or_else(|| {
        let names: Vec<_> = tet_io::Format::ALL.iter().map(|f| f.name()).collect();
        format!("unknown format '{s}'; known: {}", names.join(", "))
    })
}

fn parse_bins(s: &str) -> Result<[u32; 2], String> {
    let v: Vec<u32> =
        s.split(',').map(|t| t.trim().parse::<u32>()).collect::<Result<_, _>>().map_err(|e| e.to_string())?;
    let b: [u32; 2] = v.try_into().map_err(|_| format!("expected SCALAR,GRADIENT bin counts, got '{s}'"))?;
    if b.iter().any(|&n| n == 0 || n > tet_analysis::histogram::MAX_BINS) {
        return Err(format!("bin counts must be 1..={}", tet_analysis::histogram::MAX_BINS));
    }
    Ok(b)
}

pub fn run(cli: Cli) -> anyhow::Result<()> {
    match cli.command {
        Command::Convert(args) => crate::convert::run(*args),
        Command::Partition(args) => crate::partition::run(*args),
        Command::Info { bundle, json } => crate::info::run(&bundle, json),
        Command::Export { bundle, output } => crate::info::export(&bundle, &output),
        Command::Analyze { bundle, output, analysis, json } => {
            crate::analysis::run_analyze(&bundle, output.as_deref(), &analysis, json)
        }
        Command::Hist {
            bundle,
            output,
            csv,
            log: _,
            linear,
            bins,
            scalar_range,
            gradient_range,
            units,
            length_units,
        } => {
            let req = crate::plot::HistRequest {
                log: !linear,
                bins,
                scalar_range,
                gradient_range,
                units: crate::plot::AxisUnits { scalar: units, length: length_units },
            };
            crate::plot::run_hist(&bundle, &output, csv.as_deref(), &req)
        }
    }
}
