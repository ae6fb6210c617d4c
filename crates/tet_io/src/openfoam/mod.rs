//! OpenFOAM cases: the `polyMesh` and the cell fields of one time.
//!
//! The mesh (OpenFOAM User Guide, §5.1 "Mesh description", the polyMesh
//! description; doc.cfd.direct/openfoam/user-guide-v12/mesh-description) is
//! face-based: `constant/polyMesh/points` (a `vectorField`), `faces` (a
//! `faceList` `N ( k(a b c …) … )`, or a `faceCompactList`: an offsets list
//! then a point-id list), `owner` (the cell on the side the face's
//! right-hand normal points away from, one per face) and `neighbour` (the
//! cell on the other side, for the internal faces, which come first; very
//! old cases list every face with -1 on the boundary), and `boundary` (the
//! patches, read only for the summary and ignored when absent). Files follow
//! the User Guide's §4.2 "Basic input/output file format" (a `FoamFile`
//! header dictionary, ASCII or binary per its `format` and `arch`; see the
//! `foam_file` parser); any of them may be gzip-compressed (`points.gz`).
//!
//! Cells are rebuilt from their faces (module `cells`): tetrahedra, pyramids,
//! prisms and hexahedra become those linear cells in VTK order; any other
//! cell is a polyhedron, split into tets around an added centre point by
//! [`tet_mesh::PolyhedronSplitter`] (face triangulations conform with the
//! neighbours'), each tet a cell carrying the polyhedron's values.
//!
//! Fields are the `volScalarField`s and `volVectorField`s of one time
//! directory (a directory whose name is a number, so `0.orig` is not one),
//! read as cell fields: `internalField uniform v` or `nonuniform
//! List<scalar|vector> N (…)`; other classes (`surfaceScalarField phi`, …)
//! are skipped with a note. The time is the latest by default;
//! [`FoamOptions::time_step`] (tetprep's `--time-step N`) is an index into
//! the times sorted by value, from 0. A note lists the times found.
//!
//! A decomposed case (`processor*/constant/polyMesh`, no top-level mesh) is
//! read processor by processor and merged: points through each processor's
//! `pointProcAddressing` when every processor has one, else by identical
//! coordinates, so the shared points are one point and the min-id face
//! splits of both sides agree; cell fields are concatenated in processor
//! order.
//!
//! Every problem is a [`ReadError::Malformed`] naming the file it is in and
//! the line (ASCII) or byte offset (binary payload; in a `.gz` file, of the
//! decompressed content), never a panic or a partial mesh.

mod cells;
mod foam_file;

use std::io::Read;
use std::path::{Path, PathBuf};

use tet_mesh::{Block, Field};

use self::cells::{PolyMesh, NONE};
use self::foam_file::FoamFile;
use crate::{Format, FormatError, Location, ReadError, SourceMesh};

/// Options for [`read_case`].
#[derive(Debug, Clone, Default)]
pub struct FoamOptions {
    /// Index (from 0) into the case's time directories sorted by time; the
    /// latest when unset.
    pub time_step: Option<usize>,
}

/// Whether `dir` is an OpenFOAM case directory: it has `constant/polyMesh`,
/// `system/controlDict` or `processor0`.
pub fn is_case_dir(dir: &Path) -> bool {
    dir.is_dir() && ["constant/polyMesh", "system/controlDict", "processor0"].iter().any(|p| dir.join(p).exists())
}

/// The case directory an input names: the directory itself, the directory
/// of a `*.foam` marker file, or the case around a `polyMesh` directory or a
/// file inside the case (the nearest ancestor that is a case directory).
pub fn case_dir(input: &Path) -> Option<PathBuf> {
    let start = if input.is_dir() { input.to_path_buf() } else { input.parent()?.to_path_buf() };
    let start = if start.as_os_str().is_empty() { PathBuf::from(".") } else { start };
    if input.is_file() && input.extension().is_some_and(|e| e.eq_ignore_ascii_case("foam")) {
        return Some(start);
    }
    start.ancestors().find(|d| is_case_dir(d)).map(Path::to_path_buf)
}

fn malformed(path: &Path, e: FormatError) -> ReadError {
    ReadError::Malformed { format: Format::OpenFoam, message: e.message, at: e.at, path: path.to_path_buf() }
}

fn whole(path: &Path, message: impl Into<String>) -> ReadError {
    malformed(path, FormatError::new(Location::Whole, message))
}

/// Reads `path`, or `path.gz` decompressed when `path` does not exist;
/// `None` when neither does.
fn read_maybe_gz(path: &Path) -> Result<Option<(PathBuf, Vec<u8>)>, ReadError> {
    let io = |source, p: &Path| ReadError::Io { source, path: p.to_path_buf() };
    if path.is_file() {
        return std::fs::read(path).map(|b| Some((path.to_path_buf(), b))).map_err(|e| io(e, path));
    }
    let mut gz = path.as_os_str().to_owned();
    gz.push(".gz");
    let gz = PathBuf::from(gz);
    if !gz.is_file() {
        return Ok(None);
    }
    let raw = std::fs::read(&gz).map_err(|e| io(e, &gz))?;
    let mut out = Vec::new();
    flate2::read::GzDecoder::new(&raw[..])
        .read_to_end(&mut out)
        .map_err(|e| whole(&gz, format!("cannot decompress: {e}")))?;
    Ok(Some((gz, out)))
}

/// Which polyMesh file an error is in.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum Part {
    Points,
    Faces,
    Owner,
    Neighbour,
}

impl Part {
    fn name(self) -> &'static str {
        match self {
            Part::Points => "points",
            Part::Faces => "faces",
            Part::Owner => "owner",
            Part::Neighbour => "neighbour",
        }
    }
}

/// The four polyMesh files' bytes.
struct MeshBytes<'a> {
    points: &'a [u8],
    faces: &'a [u8],
    owner: &'a [u8],
    neighbour: &'a [u8],
}

/// Parses the four files into a [`PolyMesh`] and its cell count.
fn parse_poly_mesh(b: &MeshBytes<'_>) -> Result<(PolyMesh, usize, bool), (Part, FormatError)> {
    let mut pf = FoamFile::new(b.points).map_err(|e| (Part::Points, e))?;
    let binary = pf.header.binary;
    let (flat, _) = pf.tuples("the point list", 3, None).map_err(|e| (Part::Points, e))?;
    let points: Vec<[f64; 3]> = flat.chunks_exact(3).map(|c| [c[0], c[1], c[2]]).collect();
    if points.len() >= u32::MAX as usize {
        return Err((Part::Points, FormatError::new(Location::Whole, "more points than 32-bit indices reach")));
    }
    let mut ff = FoamFile::new(b.faces).map_err(|e| (Part::Faces, e))?;
    let (face_start, face_ids, _) = ff.faces(points.len()).map_err(|e| (Part::Faces, e))?;
    let nf = face_start.len() - 1;
    // A cell index is bounded by the face count (each cell needs 4 faces, a
    // face bounds 2 cells), which keeps the per-cell tables small.
    let cell = |v: i64, what: &str| -> Result<u32, String> {
        u32::try_from(v)
            .ok()
            .filter(|&c| (c as usize) < nf.max(1))
            .ok_or_else(|| format!("{what} names cell {v}, but {nf} faces bound at most {} cells", nf / 2))
    };
    let mut of = FoamFile::new(b.owner).map_err(|e| (Part::Owner, e))?;
    let mut owner: Vec<u32> = Vec::with_capacity(nf);
    let (n_owner, owner_at) = of
        .labels("the owner list", |v| {
            owner.push(cell(v, "the owner entry")?);
            Ok(())
        })
        .map_err(|e| (Part::Owner, e))?;
    if n_owner != nf {
        return Err((
            Part::Owner,
            FormatError::new(
                owner_at,
                format!("owner has {n_owner} entries but faces has {nf} faces (one owner per face)"),
            ),
        ));
    }
    let mut nb = FoamFile::new(b.neighbour).map_err(|e| (Part::Neighbour, e))?;
    let mut neighbour: Vec<u32> = Vec::with_capacity(nf);
    let (n_nb, nb_at) = nb
        .labels("the neighbour list", |v| {
            if neighbour.len() >= nf {
                return Err(format!("neighbour has more entries than the {nf} faces"));
            }
            neighbour.push(if v == -1 { NONE } else { cell(v, "the neighbour entry")? });
            Ok(())
        })
        .map_err(|e| (Part::Neighbour, e))?;
    debug_assert_eq!(n_nb, neighbour.len());
    let _ = nb_at;
    neighbour.resize(nf, NONE);
    let num_cells =
        owner.iter().chain(neighbour.iter().filter(|&&n| n != NONE)).map(|&c| c as usize + 1).max().unwrap_or(0);
    Ok((PolyMesh { points, face_start, face_ids, owner, neighbour }, num_cells, binary))
}

/// Cells, fields and notes of a parsed mesh: the SourceMesh less its fields'
/// expansion. `fields` hold one tuple per OpenFOAM cell.
fn assemble(
    m: PolyMesh,
    num_cells: usize,
    fields: Vec<Field>,
    bytes: &MeshBytes<'_>,
) -> Result<SourceMesh, (Part, FormatError)> {
    let built = cells::build(&m, num_cells).map_err(|e| {
        let (part, at) = match e.face {
            Some((f, true)) => (Part::Neighbour, FoamFile::label_location(bytes.neighbour, f)),
            Some((f, false)) => (Part::Owner, FoamFile::label_location(bytes.owner, f)),
            None => (Part::Owner, Location::Whole),
        };
        (part, FormatError::new(at, e.message))
    })?;
    let mut mesh = SourceMesh { points: m.points, ..Default::default() };
    let [tets, pyramids, prisms, hexes, polys] = built.counts;
    let kinds: Vec<String> =
        [(hexes, "hexahedra"), (prisms, "prisms"), (pyramids, "pyramids"), (tets, "tetrahedra"), (polys, "polyhedra")]
            .iter()
            .filter(|(n, _)| *n > 0)
            .map(|(n, what)| format!("{n} {what}"))
            .collect();
    mesh.notes.push(format!("{num_cells} OpenFOAM cells: {}", kinds.join(", ")));
    if polys > 0 {
        mesh.notes.push(format!(
            "split {polys} polyhedral cells into {} tets around {polys} added cell centres and {} face centres (faces of 5+ points); each tet carries its cell's values",
            built.cells.len() - (num_cells - polys),
            built.splitter.num_face_centres()
        ));
    }
    mesh.cell_fields.extend(fields.into_iter().map(|f| per_output_cell(f, &built.source_cell)));
    built.splitter.finish(&mut mesh).map_err(|e| (Part::Points, FormatError::new(Location::Whole, e)))?;
    mesh.blocks.push(Block::Unstructured(built.cells));
    mesh.check().map_err(|e| (Part::Owner, FormatError::new(Location::Whole, e)))?;
    Ok(mesh)
}

/// Reads a polyMesh from its four files' bytes (no fields): the in-memory
/// entry point tests and the fuzz target use. Errors start with the file's
/// name (`owner: …`).
pub fn read_poly_mesh(points: &[u8], faces: &[u8], owner: &[u8], neighbour: &[u8]) -> Result<SourceMesh, FormatError> {
    let bytes = MeshBytes { points, faces, owner, neighbour };
    let named = |(part, e): (Part, FormatError)| FormatError::new(e.at, format!("{}: {}", part.name(), e.message));
    let (m, n, binary) = parse_poly_mesh(&bytes).map_err(named)?;
    let mut mesh = assemble(m, n, Vec::new(), &bytes).map_err(named)?;
    mesh.format = format!("OpenFOAM polyMesh ({})", if binary { "binary" } else { "ascii" });
    Ok(mesh)
}

/// The time directories of the case `input` is in (of processor0 for a
/// decomposed case), sorted: (time, directory name). Step k of
/// [`FoamOptions::time_step`] is the k-th.
pub fn case_times(input: &Path) -> Result<Vec<(f64, String)>, ReadError> {
    let case = case_dir(input).ok_or_else(|| {
        whole(
            input,
            "not inside an OpenFOAM case (no directory with constant/polyMesh, system/controlDict or processor0)",
        )
    })?;
    let has_top = ["points", "points.gz"].iter().any(|p| case.join("constant/polyMesh").join(p).is_file());
    let dir = if has_top { Some(case.clone()) } else { processor_dirs(&case).into_iter().next() };
    time_dirs(&dir.unwrap_or(case))
}

/// The numeric subdirectories of `dir`, sorted by value: (value, name).
fn time_dirs(dir: &Path) -> Result<Vec<(f64, String)>, ReadError> {
    let rd = std::fs::read_dir(dir).map_err(|source| ReadError::Io { source, path: dir.to_path_buf() })?;
    let mut times: Vec<(f64, String)> = rd
        .filter_map(Result::ok)
        .filter(|e| e.path().is_dir())
        .filter_map(|e| {
            let name = e.file_name().to_str()?.to_string();
            let v: f64 = name.parse().ok().filter(|v: &f64| v.is_finite())?;
            Some((v, name))
        })
        .collect();
    times.sort_by(|a, b| a.0.total_cmp(&b.0));
    Ok(times)
}

/// `processorN` subdirectories holding a mesh, by N.
fn processor_dirs(case: &Path) -> Vec<PathBuf> {
    let Ok(rd) = std::fs::read_dir(case) else { return Vec::new() };
    let mut v: Vec<(usize, PathBuf)> = rd
        .filter_map(Result::ok)
        .filter_map(|e| {
            let n: usize = e.file_name().to_str()?.strip_prefix("processor")?.parse().ok()?;
            let p = e.path();
            p.join("constant/polyMesh").is_dir().then_some((n, p))
        })
        .collect();
    v.sort();
    v.into_iter().map(|(_, p)| p).collect()
}

/// One domain (the case, or one processor) read from disk.
struct Domain {
    mesh: PolyMesh,
    num_cells: usize,
    binary: bool,
    /// Files kept for locating errors found after parsing.
    files: [(PathBuf, Vec<u8>); 4],
    point_addressing: Option<Vec<u32>>,
}

fn read_domain(dir: &Path, want_addressing: bool) -> Result<Domain, ReadError> {
    let pm = dir.join("constant/polyMesh");
    let mut files: Vec<(PathBuf, Vec<u8>)> = Vec::with_capacity(4);
    for part in [Part::Points, Part::Faces, Part::Owner, Part::Neighbour] {
        let p = pm.join(part.name());
        match read_maybe_gz(&p)? {
            Some(f) => files.push(f),
            None => {
                let hint = if part == Part::Points && pm.join("blockMeshDict").exists() {
                    " (constant/polyMesh has a blockMeshDict: run blockMesh to make the mesh)"
                } else {
                    ""
                };
                return Err(whole(&pm, format!("the polyMesh has no '{}' file{hint}", part.name())));
            }
        }
    }
    let files: [(PathBuf, Vec<u8>); 4] = files.try_into().expect("four files");
    let bytes = MeshBytes { points: &files[0].1, faces: &files[1].1, owner: &files[2].1, neighbour: &files[3].1 };
    let at_part = |part: Part| &files[part as usize].0;
    let (mesh, num_cells, binary) = parse_poly_mesh(&bytes).map_err(|(part, e)| malformed(at_part(part), e))?;
    let point_addressing = if want_addressing {
        match read_maybe_gz(&pm.join("pointProcAddressing"))? {
            Some((p, b)) => {
                let mut f = FoamFile::new(&b).map_err(|e| malformed(&p, e))?;
                let limit = u32::MAX as i64 - 1;
                let mut v = Vec::with_capacity(mesh.points.len());
                let (n, at) = f
                    .labels("pointProcAddressing", |x| {
                        if !(0..limit).contains(&x) {
                            return Err(format!("point address {x} is not a point index"));
                        }
                        v.push(x as u32);
                        Ok(())
                    })
                    .map_err(|e| malformed(&p, e))?;
                if n != mesh.points.len() {
                    return Err(malformed(
                        &p,
                        FormatError::new(at, format!("{n} entries for the processor's {} points", mesh.points.len())),
                    ));
                }
                Some(v)
            }
            None => None,
        }
    } else {
        None
    };
    Ok(Domain { mesh, num_cells, binary, files, point_addressing })
}

/// What a field file holds.
enum FieldFile {
    Values(Field),
    /// A class that is not a volScalarField/volVectorField.
    OtherClass(String),
    /// An `internalField` in a form this reader does not evaluate.
    Unreadable,
}

fn read_field(path: &Path, bytes: &[u8], name: &str, num_cells: usize) -> Result<FieldFile, ReadError> {
    let mut f = FoamFile::new(bytes).map_err(|e| malformed(path, e))?;
    let ncomp = match f.header.class.as_str() {
        "volScalarField" => 1,
        "volVectorField" => 3,
        other => return Ok(FieldFile::OtherClass(other.to_string())),
    };
    Ok(match f.internal_field(ncomp, num_cells).map_err(|e| malformed(path, e))? {
        Some(values) => FieldFile::Values(Field::new(name, ncomp, values)),
        None => FieldFile::Unreadable,
    })
}

/// Field names in a time directory (`.gz` stripped), sorted.
fn field_names(dir: &Path) -> Result<Vec<String>, ReadError> {
    let rd = std::fs::read_dir(dir).map_err(|source| ReadError::Io { source, path: dir.to_path_buf() })?;
    let mut names: Vec<String> = rd
        .filter_map(Result::ok)
        .filter(|e| e.path().is_file())
        .filter_map(|e| e.file_name().to_str().map(|n| n.strip_suffix(".gz").unwrap_or(n).to_string()))
        .filter(|n| !n.starts_with('.') && !n.ends_with('~'))
        .collect();
    names.sort();
    names.dedup();
    Ok(names)
}

/// Reads the fields named `names` from `dir` for a domain of `num_cells`
/// cells; `None` entries were skipped (recorded in `skipped`).
fn read_fields(
    dir: &Path,
    names: &[String],
    num_cells: usize,
    skipped: &mut Vec<String>,
) -> Result<Vec<Option<Field>>, ReadError> {
    let mut out = Vec::with_capacity(names.len());
    for name in names {
        let Some((p, bytes)) = read_maybe_gz(&dir.join(name))? else {
            return Err(whole(dir, format!("the field '{name}' is missing from this time directory")));
        };
        out.push(match read_field(&p, &bytes, name, num_cells)? {
            FieldFile::Values(f) => Some(f),
            FieldFile::OtherClass(c) => {
                if !c.is_empty() {
                    skipped.push(format!("{name} ({c})"));
                }
                None
            }
            FieldFile::Unreadable => {
                skipped.push(format!("{name} (internalField not uniform/nonuniform)"));
                None
            }
        });
    }
    Ok(out)
}

/// OpenFOAM cell field `f` carried to the output cells: output cell `i`
/// takes the values of OpenFOAM cell `source_cell[i]` (a decomposed
/// polyhedron's tets each carry their cell's values).
fn per_output_cell(f: Field, source_cell: &[u32]) -> Field {
    let k = f.num_components;
    let mut values = Vec::with_capacity(source_cell.len() * k);
    for &c in source_cell {
        values.extend_from_slice(&f.values[c as usize * k..(c as usize + 1) * k]);
    }
    Field::new(f.name, k, values)
}

/// The cell fields of time directory `tname` of every domain (the case, or
/// each processor in order), concatenated in the domains' cell order:
/// scalars before vectors, each by name; fields of other classes skipped
/// with a note.
fn read_time_fields(
    domain_dirs: &[PathBuf],
    domain_cells: &[usize],
    tname: &str,
    notes: &mut Vec<String>,
) -> Result<Vec<Field>, ReadError> {
    let first = domain_dirs[0].join(tname);
    let names = field_names(&first)?;
    let mut skipped = Vec::new();
    let mut per_domain: Vec<Vec<Option<Field>>> = Vec::new();
    for (k, (dir, &cells)) in domain_dirs.iter().zip(domain_cells).enumerate() {
        let tdir = dir.join(tname);
        if !tdir.is_dir() {
            return Err(whole(&tdir, format!("the time directory {tname} is missing from this processor")));
        }
        let mut sk = Vec::new();
        per_domain.push(read_fields(&tdir, &names, cells, &mut sk)?);
        if k == 0 {
            skipped = sk;
        }
    }
    if !skipped.is_empty() {
        notes.push(format!("skipped fields that are not volScalarField/volVectorField: {}", skipped.join(", ")));
    }
    // Scalars before vectors (the first field is the default scalar), each by name.
    let mut order: Vec<usize> =
        (0..names.len()).filter(|&i| per_domain.first().is_some_and(|d| d[i].is_some())).collect();
    order.sort_by_key(|&i| (per_domain[0][i].as_ref().map_or(0, |f| f.num_components), i));
    let mut fields: Vec<Field> = Vec::new();
    for &i in &order {
        let first = per_domain[0][i].as_ref().expect("kept");
        let mut values = Vec::new();
        for (dom, dir) in per_domain.iter().zip(domain_dirs) {
            match &dom[i] {
                Some(f) if f.num_components == first.num_components => values.extend_from_slice(&f.values),
                _ => {
                    return Err(whole(
                        &dir.join(tname).join(&names[i]),
                        format!("the field '{}' is not the same kind of field as in the first processor", names[i]),
                    ))
                }
            }
        }
        fields.push(Field::new(first.name.clone(), first.num_components, values));
    }
    Ok(fields)
}

/// The time steps of an OpenFOAM case, for a time series: the mesh is read
/// and its cells built once, here; each step then reads only its time
/// directory's fields and lays them out on those cells, as [`read_case`]
/// does for the time it reads.
pub struct CaseSteps {
    domain_dirs: Vec<PathBuf>,
    domain_cells: Vec<usize>,
    /// The OpenFOAM cell each output cell comes from (in the domains' cell
    /// order).
    source_cell: Vec<u32>,
    times: Vec<(f64, String)>,
}

impl CaseSteps {
    /// Reads the mesh of the case `input` is in (as [`read_case`] finds it).
    pub fn open(input: &Path) -> Result<CaseSteps, ReadError> {
        let case = case_dir(input).ok_or_else(|| whole(input, "not inside an OpenFOAM case"))?;
        let has_top = ["points", "points.gz"].iter().any(|p| case.join("constant/polyMesh").join(p).is_file());
        let domain_dirs: Vec<PathBuf> = if has_top { vec![case.clone()] } else { processor_dirs(&case) };
        if domain_dirs.is_empty() {
            return Err(whole(&case, "this OpenFOAM case has no mesh"));
        }
        let times = time_dirs(&domain_dirs[0])?;
        let decomposed = domain_dirs.len() > 1 || !has_top;
        let mut domains = Vec::with_capacity(domain_dirs.len());
        for d in &domain_dirs {
            domains.push(read_domain(d, decomposed)?);
        }
        let domain_cells: Vec<usize> = domains.iter().map(|d| d.num_cells).collect();
        let built = if domains.len() == 1 && !decomposed {
            let d = domains.pop().expect("one domain");
            cells::build(&d.mesh, d.num_cells)
        } else {
            let (m, n) = merge_domains(&mut domains, &mut Vec::new());
            cells::build(&m, n)
        }
        .map_err(|e| whole(&case, e.message))?;
        Ok(CaseSteps { domain_dirs, domain_cells, source_cell: built.source_cell, times })
    }

    /// The case's times (value, directory name), sorted: step k is the k-th.
    pub fn times(&self) -> &[(f64, String)] {
        &self.times
    }

    /// Step `step`'s cell fields on the mesh's cells, with no points and
    /// no cells (the mesh is [`read_case`]'s for any of the case's times).
    pub fn fields(&self, step: usize) -> Result<SourceMesh, ReadError> {
        let (_, tname) = self.times.get(step).ok_or_else(|| {
            whole(&self.domain_dirs[0], format!("time step {step} does not exist: the case has {}", self.times.len()))
        })?;
        let mut notes = Vec::new();
        let fields = read_time_fields(&self.domain_dirs, &self.domain_cells, tname, &mut notes)?;
        let mut mesh = SourceMesh { format: "OpenFOAM".into(), notes, ..Default::default() };
        mesh.cell_fields.extend(fields.into_iter().map(|f| per_output_cell(f, &self.source_cell)));
        Ok(mesh)
    }
}

/// Merges decomposed domains into one mesh: global point ids through
/// `pointProcAddressing` when every domain has it, else by identical
/// coordinates; faces, owners and neighbours offset per domain.
fn merge_domains(domains: &mut [Domain], notes: &mut Vec<String>) -> (PolyMesh, usize) {
    let total_points: usize = domains.iter().map(|d| d.mesh.points.len()).sum();
    let mut maps: Vec<Vec<u32>> = Vec::with_capacity(domains.len());
    let mut points: Vec<[f64; 3]> = Vec::new();
    let addressed = domains.iter().all(|d| d.point_addressing.is_some());
    let mut by_address = false;
    if addressed {
        let n = domains
            .iter()
            .flat_map(|d| d.point_addressing.iter().flatten())
            .map(|&g| g as usize + 1)
            .max()
            .unwrap_or(0);
        if n <= total_points {
            let mut pos: Vec<Option<[f64; 3]>> = vec![None; n];
            for d in domains.iter() {
                for (l, &g) in d.point_addressing.iter().flatten().enumerate() {
                    pos[g as usize].get_or_insert(d.mesh.points[l]);
                }
            }
            if pos.iter().all(Option::is_some) {
                points = pos.into_iter().map(|p| p.expect("checked")).collect();
                maps = domains.iter_mut().map(|d| d.point_addressing.take().expect("checked")).collect();
                by_address = true;
            }
        }
    }
    if !by_address {
        let all: Vec<[f64; 3]> = domains.iter().flat_map(|d| d.mesh.points.iter().copied()).collect();
        let rep = tet_mesh::merge::merge_duplicate_points(&all, 0.0);
        let mut new_id = vec![u32::MAX; all.len()];
        for (i, &r) in rep.iter().enumerate() {
            if r as usize == i {
                new_id[i] = points.len() as u32;
                points.push(all[i]);
            }
        }
        let mut base = 0usize;
        for d in domains.iter() {
            let n = d.mesh.points.len();
            maps.push((base..base + n).map(|i| new_id[rep[i] as usize]).collect());
            base += n;
        }
    }
    notes.push(format!(
        "merged {} processors: {total_points} processor points became {} ({})",
        domains.len(),
        points.len(),
        if by_address { "pointProcAddressing" } else { "identical coordinates" }
    ));
    let mut m = PolyMesh { points, face_start: vec![0], ..Default::default() };
    let mut cell_base = 0u32;
    for (d, map) in domains.iter().zip(&maps) {
        for f in 0..d.mesh.num_faces() {
            m.face_ids.extend(d.mesh.face(f).iter().map(|&p| map[p as usize]));
            m.face_start.push(m.face_ids.len());
        }
        m.owner.extend(d.mesh.owner.iter().map(|&c| c + cell_base));
        m.neighbour.extend(d.mesh.neighbour.iter().map(|&c| if c == NONE { NONE } else { c + cell_base }));
        cell_base += d.num_cells as u32;
    }
    (m, cell_base as usize)
}

/// Reads an OpenFOAM case (see the module documentation) given as its
/// directory, a `*.foam` file in it, its `constant/polyMesh` directory or a
/// file inside it.
pub fn read_case(input: &Path, opts: &FoamOptions) -> Result<SourceMesh, ReadError> {
    let case = case_dir(input).ok_or_else(|| {
        whole(
            input,
            "not inside an OpenFOAM case (no directory with constant/polyMesh, system/controlDict or processor0)",
        )
    })?;
    let top = case.join("constant/polyMesh");
    let has_top = ["points", "points.gz"].iter().any(|p| top.join(p).is_file());
    let procs = if has_top { Vec::new() } else { processor_dirs(&case) };
    if !has_top && procs.is_empty() {
        let hint = if top.join("blockMeshDict").exists() { " (it has a blockMeshDict: run blockMesh)" } else { "" };
        return Err(whole(
            &case,
            format!("this OpenFOAM case has no mesh: neither constant/polyMesh/points nor processor*/constant/polyMesh exists{hint}"),
        ));
    }
    let domain_dirs: Vec<PathBuf> = if has_top { vec![case.clone()] } else { procs };
    let mut notes = Vec::new();

    // The time: from the case, or for a decomposed case from processor0.
    let times = time_dirs(&domain_dirs[0])?;
    let list = times.iter().map(|t| t.1.as_str()).collect::<Vec<_>>().join(", ");
    let chosen = match opts.time_step {
        Some(i) => Some(times.get(i).ok_or_else(|| {
            whole(
                &domain_dirs[0],
                format!(
                    "time step {i} does not exist: the case has {} time directories ({}), numbered from 0",
                    times.len(),
                    if list.is_empty() { "none" } else { &list }
                ),
            )
        })?),
        None => times.last(),
    };
    match chosen {
        Some((_, name)) => notes.push(format!(
            "OpenFOAM times: {list}; fields from time {name} ({}; --time-step N picks the N-th from 0)",
            if opts.time_step.is_some() { "chosen" } else { "the latest" }
        )),
        None => notes.push("no time directories: the mesh has no fields".to_string()),
    }

    let decomposed = domain_dirs.len() > 1 || !has_top;
    let mut domains = Vec::with_capacity(domain_dirs.len());
    for d in &domain_dirs {
        domains.push(read_domain(d, decomposed)?);
    }
    let domain_cells: Vec<usize> = domains.iter().map(|d| d.num_cells).collect();
    let fields = match chosen {
        Some((_, tname)) => {
            if domain_dirs[0].join(tname).join("polyMesh").is_dir() {
                notes.push(format!("time {tname} has its own polyMesh (a moving mesh); constant/polyMesh is read"));
            }
            read_time_fields(&domain_dirs, &domain_cells, tname, &mut notes)?
        }
        None => Vec::new(),
    };
    let binary = domains.iter().any(|d| d.binary);
    let mut mesh = if domains.len() == 1 && !decomposed {
        let Domain { mesh, num_cells, files, .. } = domains.pop().expect("one domain");
        let bytes = MeshBytes { points: &files[0].1, faces: &files[1].1, owner: &files[2].1, neighbour: &files[3].1 };
        assemble(mesh, num_cells, fields, &bytes).map_err(|(part, e)| malformed(&files[part as usize].0, e))?
    } else {
        // A processor's mesh that cannot make cells is blamed by its own
        // files: on failure of the merged build (only then: the cells are
        // built once on the way that works), each processor is built alone
        // to find the one at fault.
        let blame = |domains: &[Domain]| -> Option<ReadError> {
            domains.iter().find_map(|d| {
                let e = cells::build(&d.mesh, d.num_cells).err()?;
                let (part, at) = match e.face {
                    Some((f, true)) => (Part::Neighbour, FoamFile::label_location(&d.files[3].1, f)),
                    Some((f, false)) => (Part::Owner, FoamFile::label_location(&d.files[2].1, f)),
                    None => (Part::Owner, Location::Whole),
                };
                Some(malformed(&d.files[part as usize].0, FormatError::new(at, e.message)))
            })
        };
        let (m, n) = merge_domains(&mut domains, &mut notes);
        let empty = MeshBytes { points: &[], faces: &[], owner: &[], neighbour: &[] };
        match assemble(m, n, fields, &empty) {
            Ok(mesh) => mesh,
            Err((_, e)) => return Err(blame(&domains).unwrap_or_else(|| whole(&case, e.message))),
        }
    };
    if let Some(patches) = read_maybe_gz(&domain_dirs[0].join("constant/polyMesh/boundary"))
        .ok()
        .flatten()
        .and_then(|(_, b)| FoamFile::new(&b).ok()?.patches())
    {
        if !patches.is_empty() && has_top {
            let list: Vec<String> = patches.iter().map(|(n, f)| format!("{n} ({f} faces)")).collect();
            notes.push(format!("patches: {}", list.join(", ")));
        }
    }
    notes.append(&mut mesh.notes);
    mesh.notes = notes;
    mesh.format = match (decomposed, binary) {
        (false, b) => format!("OpenFOAM ({})", if b { "binary" } else { "ascii" }),
        (true, b) => {
            format!("OpenFOAM (decomposed, {} processors, {})", domain_dirs.len(), if b { "binary" } else { "ascii" })
        }
    };
    Ok(mesh)
}
