//! The tetkit bundle (`.tetb`): one validated tetrahedral mesh with its
//! scalar, point fields, face adjacency and the facts later stages need.
//!
//! Main types: [`Bundle`] (what is stored), [`BundleMeta`] (the bincode
//! header section), [`TimeSteps`] (a time series' scalar per step on the
//! one mesh; [`Bundle::set_time`] interpolates between steps),
//! [`BundleError`], [`BundleStream`] (a bundle written while it is built:
//! the mesh first, the rest when known). [`Bundle::write`] writes atomically
//! (temporary file in the same directory, fsync, rename), so an interrupted
//! run never leaves a truncated file under the final name; [`Bundle::read`]
//! rejects a wrong magic, a newer format version, a bad section checksum or
//! inconsistent arrays with an error naming the section and the path.
//!
//! The byte layout is specified in `formats/bundle.md`.
//!
//! ```
//! use tet_bundle::{Bundle, BundleMeta};
//! use tet_mesh::{build_adjacency, TetMesh};
//! let mesh = TetMesh {
//!     points: vec![[0., 0., 0.], [1., 0., 0.], [0., 1., 0.], [0., 0., 1.]],
//!     tets: vec![[0, 1, 2, 3]].into(),
//!     scalar_name: "s".into(),
//!     scalar: vec![0.0, 1.0, 2.0, 3.0],
//!     point_fields: vec![],
//! };
//! let adjacency = build_adjacency(&mesh.points, &mesh.tets).unwrap();
//! let bundle = Bundle::new(mesh, adjacency, BundleMeta::default());
//! let dir = tempfile::tempdir().unwrap();
//! let path = dir.path().join("one.tetb");
//! bundle.write(&path).unwrap();
//! let back = Bundle::read(&path).unwrap();
//! assert_eq!(back.mesh, bundle.mesh);
//! assert!(back.adjacency.convex);
//! ```

#![forbid(unsafe_code)]

mod layout;
pub mod manifest;

use serde::{Deserialize, Serialize};
use std::borrow::Cow;
use std::path::{Path, PathBuf};
use tet_analysis::{Analysis, CellRanges, FrequencyLimits, GradientMethod, Histograms, SegmentFacts, VertexGradients};
use tet_mesh::{Adjacency, Field, MeshStats, SharedArray, TetMesh, NO_NEIGHBOR};

pub use layout::{SectionEntry, FORMAT_VERSION, MAGIC};
pub use manifest::{Manifest, ManifestError};

/// Failures reading or writing a bundle; the path comes last.
#[derive(Debug, thiserror::Error)]
pub enum BundleError {
    #[error("cannot {action} {}: {source}", path.display())]
    Io {
        action: &'static str,
        #[source]
        source: std::io::Error,
        path: PathBuf,
    },
    #[error("not a tetkit bundle (the file does not start with the .tetb magic): {}", path.display())]
    BadMagic { path: PathBuf },
    #[error("bundle format version {found} is newer than this tetkit reads (up to {supported}); upgrade tetkit: {}", path.display())]
    NewerVersion { found: u32, supported: u32, path: PathBuf },
    #[error("section '{section}' is corrupt (checksum {found:08x}, expected {expected:08x}): {}", path.display())]
    BadChecksum { section: String, expected: u32, found: u32, path: PathBuf },
    #[error("bundle is damaged: {what}: {}", path.display())]
    Damaged { what: String, path: PathBuf },
    #[error("bundle is missing required section '{section}': {}", path.display())]
    MissingSection { section: &'static str, path: PathBuf },
}

/// The sections of a mesh's own arrays: `POINTS`, `TETS`, `SCALAR`, then
/// one `FLDnnnnn` per point field.
fn mesh_sections(mesh: &TetMesh) -> Vec<(String, Cow<'_, [u8]>)> {
    let mut sections: Vec<(String, Cow<'_, [u8]>)> = vec![
        ("POINTS".into(), layout::le_bytes(mesh.points.as_flattened())),
        ("TETS".into(), layout::le_bytes(mesh.tets.as_flattened())),
        ("SCALAR".into(), layout::le_bytes(&mesh.scalar)),
    ];
    for (i, f) in mesh.point_fields.iter().enumerate() {
        sections.push((format!("FLD{i:05}"), layout::le_bytes(&f.values)));
    }
    sections
}

fn neighbor_section(neighbors: &[[u32; 4]]) -> (String, Cow<'_, [u8]>) {
    ("NEIGHBOR".into(), layout::le_bytes(neighbors.as_flattened()))
}

/// Table entries a [`BundleStream`] keeps room for: the mesh's sections,
/// adjacency, metadata, analysis and up to ~240 point fields or time
/// steps; a bundle with more is written afresh by `finish`.
const STREAM_TABLE_ROOM: usize = 256;

/// A bundle written while it is still being built: `tetprep convert`
/// writes the mesh's arrays (and a Delaunay tetrahedralization's
/// neighbours) while the adjacency is checked and the statistics are
/// computed, then [`BundleStream::finish`] adds the rest of the [`Bundle`]
/// and renames the file into place, as [`Bundle::write`] would. Dropped
/// unfinished (the conversion failed), nothing appears at the path.
///
/// What was written early must be what the finished bundle holds: `finish`
/// compares each such section's checksum with the bundle's and, where one
/// differs (the adjacency was rebuilt from the faces, say), writes the
/// whole bundle afresh instead; the result is the same either way.
#[derive(Debug)]
pub struct BundleStream {
    writer: tet_container::SectionWriter,
    path: PathBuf,
}

impl BundleStream {
    /// Starts the bundle that will replace `path`.
    pub fn create(path: &Path) -> Result<BundleStream, BundleError> {
        let writer = tet_container::SectionWriter::create(path, ".tetb-", &layout::FORMAT, STREAM_TABLE_ROOM)
            .map_err(|e| io_error(e, path))?;
        Ok(BundleStream { writer, path: path.to_path_buf() })
    }

    /// Writes the mesh's arrays: points, tets, scalar and point fields.
    pub fn write_mesh(&mut self, mesh: &TetMesh) -> Result<(), BundleError> {
        for (name, data) in mesh_sections(mesh) {
            self.writer.section(&name, &data).map_err(|e| io_error(e, &self.path))?;
        }
        Ok(())
    }

    /// Writes the face adjacency's neighbour array (before it is checked:
    /// `finish` keeps it only if the bundle's is the same).
    pub fn write_neighbors(&mut self, neighbors: &[[u32; 4]]) -> Result<(), BundleError> {
        let (name, data) = neighbor_section(neighbors);
        self.writer.section(&name, &data).map_err(|e| io_error(e, &self.path))
    }

    /// Puts the sections written so far on disk (see
    /// [`tet_container::SectionWriter::sync_written`]).
    pub fn sync_written(&mut self) -> Result<(), BundleError> {
        self.writer.sync_written().map_err(|e| io_error(e, &self.path))
    }

    /// Adds `bundle`'s other sections, writes the table, syncs and renames
    /// the file into place. True when the early sections were kept; false
    /// when one differed from `bundle`'s and the bundle was written afresh.
    pub fn finish(mut self, bundle: &Bundle) -> Result<bool, BundleError> {
        let all = bundle.sections_out();
        let early = self.writer.sections();
        let kept = early.len() + self.writer.room() >= all.len()
            && early.iter().all(|e| {
                all.iter().any(|(name, data)| {
                    *name == e.name && data.len() as u64 == e.length && crc32fast::hash(data) == e.crc32
                })
            });
        if !kept {
            drop(self.writer);
            bundle.write(&self.path)?;
            return Ok(false);
        }
        let early: Vec<String> = early.iter().map(|e| e.name.clone()).collect();
        for (name, data) in all.iter().filter(|(name, _)| !early.contains(name)) {
            self.writer.section(name, data).map_err(|e| io_error(e, &self.path))?;
        }
        self.writer.finish(&self.path).map_err(|e| io_error(e, &self.path))?;
        Ok(true)
    }
}

fn io_error(e: tet_container::AtomicWriteError, path: &Path) -> BundleError {
    BundleError::Io { action: e.action, source: e.source, path: path.to_path_buf() }
}

/// Facts about the mesh and how it was made, stored in the `META` section.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize, Default)]
pub struct BundleMeta {
    /// tetkit version that wrote the bundle.
    pub writer: String,
    /// Input path and format as given to `tetprep convert`.
    pub source_path: String,
    pub source_format: String,
    pub source_points: u64,
    pub source_cells: u64,
    /// Tets produced by splitting, before degenerate ones were dropped.
    pub split_tets: u64,
    /// `"5"`, `"6"` or `"delaunay"`.
    pub split: String,
    /// True when the tets are a Delaunay tetrahedralization of their convex
    /// hull (MPVO is exact on them).
    pub delaunay: bool,
    /// The conversion report, one finding per line.
    pub findings: Vec<String>,
    pub stats: MeshStats,
}

/// Everything a bundle holds.
#[derive(Debug, Clone, PartialEq)]
pub struct Bundle {
    pub meta: BundleMeta,
    pub mesh: TetMesh,
    pub adjacency: Adjacency,
    /// Gradients, per-cell ranges, histograms and frequency limits, when
    /// `tetprep convert --gradients/--histogram` or `tetprep analyze` stored
    /// them (optional sections `ANALYSIS`, `CELLRANGE`, `CELLGRANGE`,
    /// `GRADIENT`; bundles without them read as `None`).
    pub analysis: Option<Analysis>,
    /// A time series' steps on this mesh (optional sections `TIMES`,
    /// `STEP00000`…); `mesh.scalar` is the first step's unless
    /// [`Bundle::set_time`] chose another time.
    pub steps: Option<TimeSteps>,
    /// The stored gradients at the time [`Bundle::set_time`] chose (from the
    /// steps' `GRAD` sections), while `analysis` is dropped.
    time_gradients: Option<VertexGradients>,
}

/// Most time steps a bundle holds (one section each, under the container's
/// 65,536 sections).
pub const MAX_STEPS: usize = 60_000;

/// Most time steps a bundle holds with per-step gradients (two sections a
/// step).
pub const MAX_STEPS_WITH_GRADIENTS: usize = 30_000;

/// The scalar of every time step of a series on one mesh.
#[derive(Debug, Clone, PartialEq)]
pub struct TimeSteps {
    times: Vec<f64>,
    scalars: Vec<Vec<f64>>,
    sources: Vec<String>,
    /// Per-vertex gradients of every step's scalar, by one method
    /// (`tetprep convert --gradients` of a series).
    gradients: Option<(GradientMethod, Vec<Vec<[f64; 3]>>)>,
    /// Over every step.
    scalar_min: f64,
    scalar_max: f64,
}

/// A time a bundle cannot be drawn at.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum TimeError {
    #[error("the bundle has no time steps (convert a .pvd, .series or --all-steps input to get them)")]
    NoSteps,
    #[error("time {time} is outside the bundle's steps, {first} to {last}")]
    OutOfRange { time: f64, first: f64, last: f64 },
}

/// Where a time falls: steps `lo` and `hi` (equal at a step or with one
/// step) and the weight of `hi`, in [0, 1).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct TimeSample {
    pub lo: usize,
    pub hi: usize,
    pub weight_hi: f64,
}

impl TimeSteps {
    /// Steps at `times` (finite, strictly increasing, at least one) with a
    /// scalar per point each (finite) and where each came from.
    pub fn new(times: Vec<f64>, scalars: Vec<Vec<f64>>, sources: Vec<String>) -> Result<TimeSteps, String> {
        if times.is_empty() {
            return Err("a time series needs at least one step".into());
        }
        if times.len() > MAX_STEPS {
            return Err(format!("{} steps; a bundle holds at most {MAX_STEPS}", times.len()));
        }
        if scalars.len() != times.len() || sources.len() != times.len() {
            return Err(format!("{} times, {} scalars and {} sources", times.len(), scalars.len(), sources.len()));
        }
        if let Some(t) = times.iter().find(|t| !t.is_finite()) {
            return Err(format!("time {t} is not finite"));
        }
        if let Some(w) = times.windows(2).find(|w| w[0] >= w[1]) {
            return Err(format!("times must increase: {} then {}", w[0], w[1]));
        }
        let n = scalars[0].len();
        let (mut lo, mut hi) = (f64::INFINITY, f64::NEG_INFINITY);
        for (k, s) in scalars.iter().enumerate() {
            if s.len() != n {
                return Err(format!("step {k} has {} values, step 0 has {n}", s.len()));
            }
            for (i, &v) in s.iter().enumerate() {
                if !v.is_finite() {
                    return Err(format!("step {k} (time {}): value {v} at point {i}", times[k]));
                }
                lo = lo.min(v);
                hi = hi.max(v);
            }
        }
        Ok(TimeSteps { times, scalars, sources, gradients: None, scalar_min: lo, scalar_max: hi })
    }

    /// Adds every step's per-vertex gradients (by `method`, one N×3 array a
    /// step, finite), so that a time's gradients are read, not computed.
    /// A series with gradients holds at most [`MAX_STEPS_WITH_GRADIENTS`].
    pub fn with_gradients(mut self, method: GradientMethod, per_step: Vec<Vec<[f64; 3]>>) -> Result<TimeSteps, String> {
        if self.times.len() > MAX_STEPS_WITH_GRADIENTS {
            return Err(format!(
                "{} steps; a bundle holds gradients for at most {MAX_STEPS_WITH_GRADIENTS}",
                self.times.len()
            ));
        }
        if per_step.len() != self.times.len() {
            return Err(format!("{} gradient arrays for {} steps", per_step.len(), self.times.len()));
        }
        let n = self.scalars[0].len();
        for (k, g) in per_step.iter().enumerate() {
            if g.len() != n {
                return Err(format!("step {k}: {} gradients for {n} points", g.len()));
            }
            if let Some(i) = g.iter().position(|v| !v.iter().all(|c| c.is_finite())) {
                return Err(format!("step {k} (time {}): gradient {:?} at point {i}", self.times[k], g[i]));
            }
        }
        self.gradients = Some((method, per_step));
        Ok(self)
    }

    /// The method of the stored per-step gradients, if any.
    pub fn gradient_method(&self) -> Option<GradientMethod> {
        self.gradients.as_ref().map(|g| g.0)
    }

    /// Step `k`'s stored gradients, if any.
    pub fn gradient(&self, k: usize) -> Option<&[[f64; 3]]> {
        self.gradients.as_ref().map(|g| g.1[k].as_slice())
    }

    /// The stored gradients at `time`, weighted as [`TimeSteps::scalar_at`]
    /// weights the scalar (`None` without stored gradients). Both gradient
    /// methods are linear in the scalar, so this is the gradient of the
    /// interpolated scalar up to rounding.
    pub fn gradient_at(&self, time: f64) -> Result<Option<Vec<[f64; 3]>>, TimeError> {
        let TimeSample { lo, hi, weight_hi: w } = self.sample(time)?;
        let Some((_, g)) = &self.gradients else { return Ok(None) };
        if lo == hi {
            return Ok(Some(g[lo].clone()));
        }
        Ok(Some(g[lo].iter().zip(&g[hi]).map(|(a, b)| std::array::from_fn(|c| (1.0 - w) * a[c] + w * b[c])).collect()))
    }

    pub fn len(&self) -> usize {
        self.times.len()
    }
    pub fn is_empty(&self) -> bool {
        self.times.is_empty()
    }
    pub fn times(&self) -> &[f64] {
        &self.times
    }
    /// Step `k`'s scalar per point.
    pub fn scalar(&self, k: usize) -> &[f64] {
        &self.scalars[k]
    }
    /// Where step `k` came from (a file, or a file and its step).
    pub fn source(&self, k: usize) -> &str {
        &self.sources[k]
    }
    /// The scalar's range over every step.
    pub fn scalar_range(&self) -> (f64, f64) {
        (self.scalar_min, self.scalar_max)
    }

    /// The steps around `time` and the later one's weight.
    pub fn sample(&self, time: f64) -> Result<TimeSample, TimeError> {
        let (first, last) = (self.times[0], self.times[self.times.len() - 1]);
        if !(time >= first && time <= last) {
            return Err(TimeError::OutOfRange { time, first, last });
        }
        // The last step at or before `time`.
        let lo = self.times.partition_point(|&t| t <= time) - 1;
        if self.times[lo] == time || lo + 1 == self.times.len() {
            return Ok(TimeSample { lo, hi: lo, weight_hi: 0.0 });
        }
        let w = (time - self.times[lo]) / (self.times[lo + 1] - self.times[lo]);
        Ok(TimeSample { lo, hi: lo + 1, weight_hi: w })
    }

    /// The scalar at `time`: a step's own values at its time, else linear
    /// between the two steps around it, `(1 − w)·a + w·b` per point.
    pub fn scalar_at(&self, time: f64) -> Result<Vec<f64>, TimeError> {
        let TimeSample { lo, hi, weight_hi: w } = self.sample(time)?;
        if lo == hi {
            return Ok(self.scalars[lo].clone());
        }
        Ok(self.scalars[lo].iter().zip(&self.scalars[hi]).map(|(&a, &b)| (1.0 - w) * a + w * b).collect())
    }
}

/// What the `ANALYSIS` section holds (the arrays have their own sections).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
struct AnalysisRecord {
    gradient_method: Option<GradientMethod>,
    facts: SegmentFacts,
    limits: FrequencyLimits,
    histograms: Option<Histograms>,
}

/// Field descriptors stored in `META`'s companion `FIELDS` section.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
struct FieldInfo {
    name: String,
    num_components: u32,
}

/// What `META` holds on disk: the meta plus what is needed to decode arrays.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
struct MetaRecord {
    meta: BundleMeta,
    scalar_name: String,
    convex: bool,
    fields: Vec<FieldInfo>,
}

impl Bundle {
    /// A bundle from a validated mesh; `meta.stats` is recomputed here so it
    /// always describes the stored mesh.
    pub fn new(mesh: TetMesh, adjacency: Adjacency, meta: BundleMeta) -> Bundle {
        let stats = tet_mesh::mesh_stats(&mesh.points, &mesh.tets, &mesh.scalar);
        Bundle::with_stats(mesh, adjacency, meta, stats)
    }

    /// Like [`Bundle::new`] with statistics computed by the caller (e.g.
    /// concurrently with the adjacency); `stats` must be
    /// `tet_mesh::mesh_stats` of this mesh.
    pub fn with_stats(mesh: TetMesh, adjacency: Adjacency, mut meta: BundleMeta, stats: MeshStats) -> Bundle {
        meta.stats = stats;
        if meta.writer.is_empty() {
            meta.writer = format!("tetkit {}", env!("CARGO_PKG_VERSION"));
        }
        Bundle { meta, mesh, adjacency, analysis: None, steps: None, time_gradients: None }
    }

    /// The sections in file order, payloads borrowed where possible.
    fn sections_out(&self) -> Vec<(String, Cow<'_, [u8]>)> {
        let record = MetaRecord {
            meta: self.meta.clone(),
            scalar_name: self.mesh.scalar_name.clone(),
            convex: self.adjacency.convex,
            fields: self
                .mesh
                .point_fields
                .iter()
                .map(|f| FieldInfo { name: f.name.clone(), num_components: f.num_components as u32 })
                .collect(),
        };
        let meta_bytes =
            bincode::serde::encode_to_vec(&record, bincode::config::standard()).expect("meta always encodes");
        let mut sections: Vec<(String, Cow<'_, [u8]>)> = vec![("META".into(), Cow::Owned(meta_bytes))];
        let mut mesh = mesh_sections(&self.mesh);
        let fields = mesh.split_off(3);
        sections.extend(mesh);
        sections.push(neighbor_section(&self.adjacency.neighbors));
        sections.push(("BOUNDARY".into(), layout::le_bytes(&self.adjacency.boundary_faces)));
        sections.extend(fields);
        if let Some(a) = &self.analysis {
            let record = AnalysisRecord {
                gradient_method: a.gradients.as_ref().map(|g| g.method),
                facts: a.facts,
                limits: a.limits,
                histograms: a.histograms.clone(),
            };
            let bytes =
                bincode::serde::encode_to_vec(&record, bincode::config::standard()).expect("analysis always encodes");
            sections.push(("ANALYSIS".into(), Cow::Owned(bytes)));
            sections.push(("CELLRANGE".into(), layout::le_bytes(a.ranges.scalar.as_flattened())));
            if let Some(g) = &a.ranges.gradient_magnitude {
                sections.push(("CELLGRANGE".into(), layout::le_bytes(g.as_flattened())));
            }
            if let Some(g) = &a.gradients {
                sections.push(("GRADIENT".into(), layout::le_bytes(g.per_point.as_flattened())));
            }
        }
        if let Some(st) = &self.steps {
            let record = TimesRecord { times: st.times.clone(), sources: st.sources.clone() };
            let bytes =
                bincode::serde::encode_to_vec(&record, bincode::config::standard()).expect("times always encode");
            sections.push(("TIMES".into(), Cow::Owned(bytes)));
            for (k, s) in st.scalars.iter().enumerate() {
                sections.push((format!("STEP{k:05}"), layout::le_bytes(s)));
            }
            if let Some((method, per_step)) = &st.gradients {
                let bytes =
                    bincode::serde::encode_to_vec(StepGradientsRecord { method: *method }, bincode::config::standard())
                        .expect("a method always encodes");
                sections.push(("STEPGRAD".into(), Cow::Owned(bytes)));
                for (k, g) in per_step.iter().enumerate() {
                    sections.push((format!("GRAD{k:05}"), layout::le_bytes(g.as_flattened())));
                }
            }
        }
        sections
    }

    /// Serializes to bytes (the exact file content).
    pub fn to_bytes(&self) -> Vec<u8> {
        let mut out = Vec::new();
        layout::write_sections(&mut out, &self.sections_out()).expect("writing to a Vec cannot fail");
        out
    }

    /// Writes atomically: a temporary file beside `path` is written, synced
    /// and renamed over `path`.
    pub fn write(&self, path: &Path) -> Result<(), BundleError> {
        let sections = self.sections_out();
        tet_container::write_atomic(path, ".tetb-", |w| layout::write_sections(w, &sections))
            .map_err(|e| io_error(e, path))
    }

    /// Reads and verifies a bundle file, section by section straight into
    /// its arrays: loading needs the memory of the bundle, not of the
    /// bundle and the file besides.
    pub fn read(path: &Path) -> Result<Bundle, BundleError> {
        let mut sections = layout::Sections::open(path)?;
        let bundle = Bundle::decode(&mut sections, path)?;
        sections.verify_unread(path)?;
        Ok(bundle)
    }

    /// Parses and verifies bundle bytes; `path` is only used in errors.
    pub fn from_bytes(bytes: &[u8], path: &Path) -> Result<Bundle, BundleError> {
        let table = layout::parse(bytes, path)?;
        Bundle::decode(&mut layout::Sections::Bytes { bytes, table }, path)
    }

    fn decode(src: &mut layout::Sections<'_>, path: &Path) -> Result<Bundle, BundleError> {
        let damaged = |what: String| BundleError::Damaged { what, path: path.to_path_buf() };
        let missing = |section: &'static str| BundleError::MissingSection { section, path: path.to_path_buf() };
        let meta = src.bytes("META", path)?.ok_or_else(|| missing("META"))?;
        let (record, _): (MetaRecord, usize) =
            bincode::serde::decode_from_slice(&meta, bincode::config::standard().with_limit::<{ 1 << 26 }>())
                .map_err(|e| damaged(format!("META section does not decode ({e})")))?;
        let points: Vec<[f64; 3]> = src.records::<_, u64>("POINTS", path)?.ok_or_else(|| missing("POINTS"))?;
        // The two largest arrays (32 bytes a tet of the file's ~40) are
        // mapped, not read, from a file on a little-endian host.
        let tets: SharedArray<[u32; 4]> = src.records_shared::<_, u32>("TETS", path)?.ok_or_else(|| missing("TETS"))?;
        let scalar: Vec<f64> = src.records::<_, u64>("SCALAR", path)?.ok_or_else(|| missing("SCALAR"))?;
        let neighbors: SharedArray<[u32; 4]> =
            src.records_shared::<_, u32>("NEIGHBOR", path)?.ok_or_else(|| missing("NEIGHBOR"))?;
        let boundary_faces: Vec<u32> = src.records::<_, u32>("BOUNDARY", path)?.ok_or_else(|| missing("BOUNDARY"))?;

        let np = points.len();
        if let Some(i) = tets.iter().position(|t| t.iter().any(|&v| v as usize >= np)) {
            return Err(damaged(format!("tet {i} refers to a point beyond the {np} points")));
        }
        if scalar.len() != np {
            return Err(damaged(format!("{} scalars for {np} points", scalar.len())));
        }
        if neighbors.len() != tets.len() {
            return Err(damaged(format!("{} neighbour entries for {} tets", neighbors.len(), tets.len())));
        }
        if let Some(i) = neighbors.iter().position(|n| n.iter().any(|&t| t != NO_NEIGHBOR && t as usize >= tets.len()))
        {
            return Err(damaged(format!("tet {i} has a neighbour beyond the {} tets", tets.len())));
        }
        if let Some(b) = boundary_faces.iter().find(|&&b| (b / 4) as usize >= tets.len()) {
            return Err(damaged(format!("boundary face {b} refers to a missing tet")));
        }
        let mut point_fields = Vec::with_capacity(record.fields.len());
        for (i, info) in record.fields.iter().enumerate() {
            let tag = format!("FLD{i:05}");
            let values: Vec<f64> = src
                .records::<_, u64>(&tag, path)?
                .ok_or_else(|| damaged(format!("field '{}' has no section {tag}", info.name)))?;
            let nc = info.num_components as usize;
            if nc == 0 || values.len() != np * nc {
                return Err(damaged(format!(
                    "field '{}' has {} values for {np} points × {nc}",
                    info.name,
                    values.len()
                )));
            }
            point_fields.push(Field { name: info.name.clone(), num_components: nc, values });
        }
        let analysis = match src.bytes("ANALYSIS", path)? {
            None => None,
            Some(sec) => Some(read_analysis(&sec, src, path, np, tets.len())?),
        };
        let steps = match src.bytes("TIMES", path)? {
            None => None,
            Some(sec) => Some(read_steps(&sec, src, path, np)?),
        };
        Ok(Bundle {
            meta: record.meta,
            mesh: TetMesh { points, tets, scalar_name: record.scalar_name, scalar, point_fields },
            adjacency: Adjacency { neighbors, boundary_faces, convex: record.convex },
            analysis,
            steps,
            time_gradients: None,
        })
    }

    /// Adds a time series' steps (replacing any earlier ones); the mesh's
    /// scalar stays as it is (conventionally the first step's).
    pub fn with_steps(mut self, steps: TimeSteps) -> Result<Bundle, String> {
        if steps.scalars[0].len() != self.mesh.points.len() {
            return Err(format!("{} values a step for {} points", steps.scalars[0].len(), self.mesh.points.len()));
        }
        self.steps = Some(steps);
        // Gradients of a time chosen on the steps replaced no longer hold.
        self.time_gradients = None;
        Ok(self)
    }

    /// The scalar's range a transfer function is normalized over: over every
    /// time step for a series (so a normalized TF means the same colours at
    /// every time), else the statistics' range of the one scalar.
    pub fn scalar_range(&self) -> (f64, f64) {
        match &self.steps {
            Some(st) => st.scalar_range(),
            None => (self.meta.stats.scalar_min, self.meta.stats.scalar_max),
        }
    }

    /// Makes the mesh's scalar the one at `time` ([`TimeSteps::scalar_at`])
    /// and the statistics' scalar range the whole series' (so a normalized
    /// TF means the same colours at every time). The analysis describes one
    /// step's scalar, so it is dropped (what needs it is computed again);
    /// the steps stay, and their stored gradients at `time`, if any, become
    /// [`Bundle::gradients`].
    pub fn set_time(&mut self, time: f64) -> Result<(), TimeError> {
        let steps = self.steps.as_ref().ok_or(TimeError::NoSteps)?;
        self.mesh.scalar = steps.scalar_at(time)?;
        (self.meta.stats.scalar_min, self.meta.stats.scalar_max) = steps.scalar_range();
        self.time_gradients = match (steps.gradient_method(), steps.gradient_at(time)?) {
            (Some(method), Some(per_point)) => Some(VertexGradients { method, per_point }),
            _ => None,
        };
        self.analysis = None;
        Ok(())
    }

    /// The per-vertex gradients of the mesh's current scalar, where stored:
    /// the analysis's, or after [`Bundle::set_time`] the steps' at that time.
    pub fn gradients(&self) -> Option<&VertexGradients> {
        self.analysis.as_ref().and_then(|a| a.gradients.as_ref()).or(self.time_gradients.as_ref())
    }

    /// Takes the bundle apart for a consumer that keeps only the mesh: its
    /// mesh, adjacency and the gradients [`Bundle::gradients`] gives, moved
    /// out, not copied (a 10⁸-tet renderer then holds its arrays once).
    pub fn into_mesh(self) -> (TetMesh, Adjacency, Option<VertexGradients>) {
        let gradients = self.analysis.and_then(|a| a.gradients).or(self.time_gradients);
        (self.mesh, self.adjacency, gradients)
    }

    /// The analysis's stored per-vertex gradients (the `GRADIENT` section),
    /// if any — unlike [`Bundle::gradients`], never a time's.
    pub fn gradients_of_analysis(&self) -> Option<&[[f64; 3]]> {
        self.analysis.as_ref().and_then(|a| a.gradients.as_ref()).map(|g| g.per_point.as_slice())
    }

    /// Sets the analysis part (replacing any earlier one).
    pub fn with_analysis(mut self, analysis: Analysis) -> Bundle {
        self.analysis = Some(analysis);
        self
    }

    /// Lists the sections of a bundle file without decoding them (for `info`).
    pub fn sections(bytes: &[u8], path: &Path) -> Result<Vec<SectionEntry>, BundleError> {
        layout::parse(bytes, path)
    }
}

/// What the `TIMES` section holds (the scalars have their own sections).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
struct TimesRecord {
    times: Vec<f64>,
    sources: Vec<String>,
}

/// Decodes the optional time-series sections; errors say what is
/// inconsistent.
fn read_steps(sec: &[u8], src: &mut layout::Sections<'_>, path: &Path, np: usize) -> Result<TimeSteps, BundleError> {
    let damaged = |what: String| BundleError::Damaged { what, path: path.to_path_buf() };
    let (record, _): (TimesRecord, usize) =
        bincode::serde::decode_from_slice(sec, bincode::config::standard().with_limit::<{ 1 << 26 }>())
            .map_err(|e| damaged(format!("TIMES section does not decode ({e})")))?;
    let mut scalars = Vec::with_capacity(record.times.len().min(1 << 16));
    for k in 0..record.times.len() {
        let tag = format!("STEP{k:05}");
        let values: Vec<f64> = src
            .records::<_, u64>(&tag, path)?
            .ok_or_else(|| damaged(format!("TIMES lists {} steps but {tag} is missing", record.times.len())))?;
        if values.len() != np {
            return Err(damaged(format!("{tag} has {} values for {np} points", values.len())));
        }
        scalars.push(values);
    }
    let steps = TimeSteps::new(record.times, scalars, record.sources).map_err(|e| damaged(format!("TIMES: {e}")))?;
    let Some(sec) = src.bytes("STEPGRAD", path)? else { return Ok(steps) };
    let (record, _): (StepGradientsRecord, usize) =
        bincode::serde::decode_from_slice(&sec, bincode::config::standard().with_limit::<{ 1 << 10 }>())
            .map_err(|e| damaged(format!("STEPGRAD section does not decode ({e})")))?;
    let mut per_step = Vec::with_capacity(steps.len().min(1 << 16));
    for k in 0..steps.len() {
        let tag = format!("GRAD{k:05}");
        let values: Vec<[f64; 3]> = src
            .records::<_, u64>(&tag, path)?
            .ok_or_else(|| damaged(format!("STEPGRAD is present but {tag} is missing")))?;
        if values.len() != np {
            return Err(damaged(format!("{tag} has {} values for {np} points × 3", 3 * values.len())));
        }
        per_step.push(values);
    }
    steps.with_gradients(record.method, per_step).map_err(|e| damaged(format!("STEPGRAD: {e}")))
}

/// What the `STEPGRAD` section holds (the arrays are `GRAD00000`…).
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
struct StepGradientsRecord {
    method: GradientMethod,
}

/// Decodes the optional analysis sections; errors say what is inconsistent.
fn read_analysis(
    record_bytes: &[u8],
    src: &mut layout::Sections<'_>,
    path: &Path,
    np: usize,
    nt: usize,
) -> Result<Analysis, BundleError> {
    let damaged = |what: String| BundleError::Damaged { what, path: path.to_path_buf() };
    let (record, _): (AnalysisRecord, usize) =
        bincode::serde::decode_from_slice(record_bytes, bincode::config::standard().with_limit::<{ 1 << 28 }>())
            .map_err(|e| damaged(format!("ANALYSIS section does not decode ({e})")))?;
    if let Some(h) = &record.histograms {
        h.check().map_err(|e| damaged(format!("ANALYSIS: {e}")))?;
    }
    let mut pairs = |name: &str, required: bool| -> Result<Option<Vec<[f64; 2]>>, BundleError> {
        let Some(v) = src.records::<[f64; 2], u64>(name, path)? else {
            return if required { Err(damaged(format!("ANALYSIS present without {name}"))) } else { Ok(None) };
        };
        if v.len() != nt {
            return Err(damaged(format!("{name} has {} values for {nt} tets × 2", 2 * v.len())));
        }
        Ok(Some(v))
    };
    let scalar = pairs("CELLRANGE", true)?.unwrap_or_default();
    let gradient_magnitude = pairs("CELLGRANGE", false)?;
    let gradients = match record.gradient_method {
        None => None,
        Some(method) => {
            let v: Vec<[f64; 3]> = src
                .records::<_, u64>("GRADIENT", path)?
                .ok_or_else(|| damaged("ANALYSIS names a gradient method but GRADIENT is missing".into()))?;
            if v.len() != np {
                return Err(damaged(format!("GRADIENT has {} values for {np} points × 3", 3 * v.len())));
            }
            Some(VertexGradients { method, per_point: v })
        }
    };
    Ok(Analysis {
        gradients,
        ranges: CellRanges { scalar, gradient_magnitude },
        facts: record.facts,
        limits: record.limits,
        histograms: record.histograms,
    })
}
