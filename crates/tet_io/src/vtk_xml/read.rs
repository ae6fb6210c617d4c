//! Reading VTK XML datasets (serial files and parallel index files).

use std::cell::Cell;
use std::collections::BTreeMap;
use std::ops::Range;
use std::path::Path;

use base64::alphabet;
use base64::engine::general_purpose::{GeneralPurpose, GeneralPurposeConfig};
use base64::engine::DecodePaddingMode;
use base64::Engine as _;
use flate2::{Decompress, FlushDecompress, Status};
use quick_xml::events::{BytesStart, Event};
use tet_mesh::{Block, CellType, Cells, Field, PolyhedronSplitter, SourceMesh};

use crate::cursor::{decode_to_f64, parse_f64, ByteCursor, Endian, ScalarType};
use crate::{Format, FormatError, Location, ReadError};

/// Deflate cannot expand a block by more than about 1032:1; a header that
/// claims more is hostile (a zip bomb) or corrupt.
const MAX_DEFLATE_RATIO: usize = 1032;

/// Points of an ImageData or RectilinearGrid piece are not stored in the
/// file, so their count is bounded by nothing the file holds. Above this
/// many, the piece must carry a point or cell array of that size (which the
/// file does have to hold) before the points are materialized.
const MAX_UNBACKED_GRID_POINTS: usize = 1 << 20;

/// Base64 as VTK writes it: standard alphabet, padded, but a header and the
/// data after it may each carry their own padding, so decoding goes segment
/// by segment (see [`decode_base64`]).
const BASE64: GeneralPurpose = GeneralPurpose::new(
    &alphabet::STANDARD,
    GeneralPurposeConfig::new()
        .with_decode_allow_trailing_bits(true)
        .with_decode_padding_mode(DecodePaddingMode::Indifferent),
);

/// Reads one serial VTK XML file (`UnstructuredGrid`, `StructuredGrid`,
/// `ImageData` or `RectilinearGrid`) from memory.
///
/// Multiple `<Piece>`s are concatenated: points appended, connectivity
/// offset; points shared by two pieces stay duplicated (validation merges
/// them). All unstructured pieces go into one [`Block::Unstructured`]; each
/// structured piece becomes its own [`Block::Structured`].
///
/// Polyhedra (`VTK_POLYHEDRON`, id 42) with the `faces`/`faceoffsets` face
/// stream are split into tets around added centre points by
/// [`PolyhedronSplitter`] (each tet repeats the cell's data; the added
/// points average the point data), with a note. Cells without volume
/// (vertices, lines, polygons) and volume cells tetkit cannot reduce
/// (polyhedra without a face stream, Lagrange/Bézier cells, pentagonal and
/// hexagonal prisms) are skipped with a note counting them, and their
/// cell-data tuples dropped so cell fields stay aligned. Quadratic cells are reduced to their corners
/// (with a note). An unknown cell type id is an error. Point and cell arrays
/// become fields of their `NumberOfComponents`; `FieldData` and non-numeric
/// arrays are ignored.
pub fn read(bytes: &[u8]) -> Result<SourceMesh, FormatError> {
    let ctx = Ctx::new(bytes)?;
    let dataset_type = ctx.attr(0, "type").unwrap_or("").to_string();
    let kind = match dataset_type.as_str() {
        "UnstructuredGrid" => Kind::Unstructured,
        "StructuredGrid" => Kind::Structured,
        "ImageData" => Kind::Image,
        "RectilinearGrid" => Kind::Rectilinear,
        "PolyData" => {
            return Err(ctx.err_at(0, "VTK XML PolyData holds surfaces, not volume cells"));
        }
        t if t.starts_with('P') => {
            return Err(ctx.err_at(
                0,
                format!("this is a parallel VTK XML index ({t}); its pieces are separate files, read it from its path"),
            ));
        }
        "" => return Err(ctx.err_at(0, "VTKFile has no type attribute")),
        t => return Err(ctx.err_at(0, format!("unsupported VTK XML dataset type '{t}'"))),
    };
    let dataset = ctx
        .child(0, &dataset_type)
        .ok_or_else(|| ctx.err_at(0, format!("VTKFile of type {dataset_type} has no <{dataset_type}> element")))?;

    let mut stats = Stats::default();
    let mut mesh = SourceMesh::default();
    let mut num_pieces = 0usize;
    for piece in ctx.children(dataset, "Piece") {
        let part = match kind {
            Kind::Unstructured => ctx.unstructured_piece(piece, &mut stats)?,
            Kind::Structured | Kind::Image | Kind::Rectilinear => {
                ctx.structured_piece(kind, dataset, piece, &mut stats)?
            }
        };
        append_piece(&mut mesh, part, num_pieces == 0, &format!("piece {num_pieces}"))
            .map_err(|m| ctx.err_at(piece, m))?;
        num_pieces += 1;
    }
    if num_pieces == 0 {
        return Err(ctx.err_at(dataset, format!("<{dataset_type}> has no <Piece>")));
    }
    let mut notes = stats.notes();
    notes.append(&mut mesh.notes);
    mesh.notes = notes;
    mesh.format = format!("VTK XML {dataset_type}{}", ctx.layout_summary());
    if num_pieces > 1 {
        mesh.notes.push(format!("concatenated {num_pieces} pieces"));
    }
    mesh.check().map_err(|m| FormatError::new(Location::Whole, m))?;
    Ok(mesh)
}

/// Reads a parallel VTK XML index (`.pvtu`, and likewise `.pvts`, `.pvti`,
/// `.pvtr`): each `<Piece Source=...>` is read with [`read`] from a path
/// relative to the index file's directory, and the pieces are concatenated
/// as `read` concatenates in-file pieces. Points on piece borders stay
/// duplicated for the validation step to merge. Errors in a piece name the
/// piece's path.
pub fn read_pvtu(path: &Path) -> Result<SourceMesh, ReadError> {
    let malformed = |e: FormatError, p: &Path| ReadError::Malformed {
        format: Format::Pvtu,
        message: e.message,
        at: e.at,
        path: p.to_path_buf(),
    };
    let bytes = std::fs::read(path).map_err(|source| ReadError::Io { source, path: path.to_path_buf() })?;
    let ctx = Ctx::new(&bytes).map_err(|e| malformed(e, path))?;
    let ptype = ctx.attr(0, "type").unwrap_or("").to_string();
    if !matches!(ptype.as_str(), "PUnstructuredGrid" | "PStructuredGrid" | "PImageData" | "PRectilinearGrid") {
        let what = if ptype.is_empty() { "no type attribute".to_string() } else { format!("type '{ptype}'") };
        return Err(malformed(ctx.err_at(0, format!("not a parallel VTK XML index: VTKFile has {what}")), path));
    }
    let dataset =
        ctx.child(0, &ptype).ok_or_else(|| malformed(ctx.err_at(0, format!("no <{ptype}> element")), path))?;
    let dir = path.parent().unwrap_or_else(|| Path::new(""));

    let mut mesh = SourceMesh::default();
    let mut piece_format = String::new();
    let mut num_pieces = 0usize;
    for piece in ctx.children(dataset, "Piece") {
        let source = ctx
            .attr(piece, "Source")
            .ok_or_else(|| malformed(ctx.err_at(piece, "<Piece> has no Source attribute"), path))?;
        let piece_path = dir.join(source);
        let piece_bytes =
            std::fs::read(&piece_path).map_err(|source| ReadError::Io { source, path: piece_path.clone() })?;
        let mut part = read(&piece_bytes).map_err(|e| {
            let mut e = e;
            e.message = format!("piece {num_pieces} of {}: {}", path.display(), e.message);
            malformed(e, &piece_path)
        })?;
        if piece_format.is_empty() {
            piece_format = std::mem::take(&mut part.format);
        }
        let label = format!("piece {source}");
        for note in std::mem::take(&mut part.notes) {
            mesh.notes.push(format!("{label}: {note}"));
        }
        append_piece(&mut mesh, part, num_pieces == 0, &label)
            .map_err(|m| malformed(FormatError::new(Location::Whole, m), &piece_path))?;
        num_pieces += 1;
    }
    if num_pieces == 0 {
        return Err(malformed(ctx.err_at(dataset, format!("<{ptype}> has no <Piece>")), path));
    }
    mesh.format = format!("VTK XML {ptype}, {num_pieces} pieces; first: {piece_format}");
    mesh.check().map_err(|m| malformed(FormatError::new(Location::Whole, m), path))?;
    Ok(mesh)
}

/// Appends one piece (a mesh whose blocks index its own points from 0) to
/// `mesh`. Fields are matched by name and component count; a field that a
/// later piece lacks is dropped with a note, as are a later piece's extra
/// fields.
fn append_piece(mesh: &mut SourceMesh, piece: SourceMesh, first: bool, label: &str) -> Result<(), String> {
    let base = mesh.points.len();
    if !matches!(base.checked_add(piece.points.len()), Some(t) if t <= u32::MAX as usize) {
        return Err(format!("{label}: more than {} points in all", u32::MAX));
    }
    // Checked just above: every global index fits u32.
    let offset = base as u32;
    mesh.points.extend_from_slice(&piece.points);
    for block in piece.blocks {
        match block {
            Block::Unstructured(cells) => {
                if let Some(Block::Unstructured(acc)) = mesh.blocks.last_mut() {
                    let conn_base = acc.connectivity.len();
                    acc.types.extend_from_slice(&cells.types);
                    acc.offsets.extend(cells.offsets.iter().skip(1).map(|&o| o + conn_base));
                    acc.connectivity.extend(cells.connectivity.iter().map(|&p| p + offset));
                } else {
                    let mut cells = cells;
                    cells.connectivity.iter_mut().for_each(|p| *p += offset);
                    mesh.blocks.push(Block::Unstructured(cells));
                }
            }
            Block::Structured { dims, first_point } => {
                mesh.blocks.push(Block::Structured { dims, first_point: first_point + base });
            }
        }
    }
    if first {
        mesh.point_fields = piece.point_fields;
        mesh.cell_fields = piece.cell_fields;
        mesh.active_point_scalar = piece.active_point_scalar;
        mesh.active_cell_scalar = piece.active_cell_scalar;
    } else {
        merge_fields(&mut mesh.point_fields, piece.point_fields, "point", label, &mut mesh.notes);
        merge_fields(&mut mesh.cell_fields, piece.cell_fields, "cell", label, &mut mesh.notes);
    }
    mesh.notes.extend(piece.notes);
    Ok(())
}

fn merge_fields(acc: &mut Vec<Field>, mut more: Vec<Field>, kind: &str, label: &str, notes: &mut Vec<String>) {
    acc.retain_mut(|field| {
        match more.iter().position(|m| m.name == field.name && m.num_components == field.num_components) {
            Some(i) => {
                let m = more.swap_remove(i);
                field.values.extend_from_slice(&m.values);
                true
            }
            None => {
                notes.push(format!("{kind} field '{}' dropped: {label} lacks it", field.name));
                false
            }
        }
    });
    for m in more {
        notes.push(format!("{kind} field '{}' dropped: only {label} has it", m.name));
    }
}

#[derive(Clone, Copy, PartialEq, Eq)]
enum Kind {
    Unstructured,
    Structured,
    Image,
    Rectilinear,
}

/// What the reader skipped or changed, summed over all pieces.
#[derive(Default)]
struct Stats {
    reduced_higher_order: usize,
    skipped_without_volume: usize,
    /// Volume cells tetkit cannot reduce, by VTK type id.
    skipped_unreducible: BTreeMap<u32, usize>,
    skipped_non_numeric: Vec<String>,
    flat_structured_cells: usize,
    /// Polyhedra (id 42) split into tets, the tets and the centre points added.
    split_polyhedra: usize,
    polyhedron_tets: usize,
    polyhedron_points: usize,
}

impl Stats {
    fn notes(&self) -> Vec<String> {
        let mut notes = Vec::new();
        if self.reduced_higher_order > 0 {
            notes.push(format!("reduced {} higher-order cells to their corner nodes", self.reduced_higher_order));
        }
        if self.skipped_without_volume > 0 {
            notes.push(format!(
                "skipped {} cells without volume (vertices, lines, polygons) and their cell data",
                self.skipped_without_volume
            ));
        }
        for (id, n) in &self.skipped_unreducible {
            let what = match id {
                42 => "polyhedra (VTK_POLYHEDRON, id 42) with no 'faces'/'faceoffsets' arrays (VTK 9.4's polyhedron_* arrays are not read)".to_string(),
                15 => "pentagonal prisms (id 15)".to_string(),
                16 => "hexagonal prisms (id 16)".to_string(),
                id => format!("Lagrange/Bézier volume cells of VTK type id {id}"),
            };
            notes.push(format!("skipped {n} {what}, which tetkit cannot reduce, and their cell data"));
        }
        if self.split_polyhedra > 0 {
            notes.push(format!(
                "split {} polyhedra (VTK_POLYHEDRON) into {} tets around {} added cell- and face-centre points; each tet carries its cell's data",
                self.split_polyhedra, self.polyhedron_tets, self.polyhedron_points
            ));
        }
        if !self.skipped_non_numeric.is_empty() {
            notes.push(format!("skipped non-numeric arrays: {}", self.skipped_non_numeric.join(", ")));
        }
        if self.flat_structured_cells > 0 {
            notes.push(format!(
                "skipped {} cells of structured pieces with fewer than 2 points along some axis (no volume) and their cell data",
                self.flat_structured_cells
            ));
        }
        notes
    }
}

// ---------------------------------------------------------------------------
// XML tree

/// One element of the XML part of the file. `text` lists the byte ranges of
/// its character data (inline arrays keep their values there).
struct Element {
    name: String,
    attrs: Vec<(String, String)>,
    children: Vec<usize>,
    text: Vec<Range<usize>>,
    /// Byte offset of the `<` that opens the element.
    pos: usize,
    /// 1-based line of `pos`, counted once while parsing (error messages
    /// must not rescan a large file).
    line: usize,
}

fn line_at(bytes: &[u8], pos: usize) -> Location {
    let end = pos.min(bytes.len());
    Location::Line(bytes[..end].iter().filter(|&&b| b == b'\n').count() + 1)
}

fn find(haystack: &[u8], needle: &[u8], from: usize) -> Option<usize> {
    let hay = haystack.get(from..)?;
    let first = *needle.first()?;
    let mut i = 0;
    while let Some(p) = hay.get(i..)?.iter().position(|&b| b == first) {
        let at = i + p;
        if hay.get(at..at + needle.len()) == Some(needle) {
            return Some(from + at);
        }
        i = at + 1;
    }
    None
}

fn element_from(e: &BytesStart, pos: usize, bytes: &[u8]) -> Result<Element, FormatError> {
    let name = String::from_utf8_lossy(e.name().as_ref()).into_owned();
    let mut attrs = Vec::new();
    for a in e.attributes() {
        let a = a.map_err(|err| FormatError::new(line_at(bytes, pos), format!("bad attribute in <{name}>: {err}")))?;
        let key = String::from_utf8_lossy(a.key.as_ref()).into_owned();
        let value = match a.unescape_value() {
            Ok(v) => v.into_owned(),
            Err(_) => String::from_utf8_lossy(&a.value).into_owned(),
        };
        attrs.push((key, value));
    }
    Ok(Element { name, attrs, children: Vec::new(), text: Vec::new(), pos, line: 0 })
}

/// Parses `xml` (the file up to `<AppendedData`, which need not be closed
/// there) into a tree whose element 0 is the first top-level element.
fn parse_tree(xml: &[u8], bytes: &[u8]) -> Result<Vec<Element>, FormatError> {
    let mut reader = quick_xml::Reader::from_reader(xml);
    let mut els: Vec<Element> = Vec::new();
    let mut stack: Vec<usize> = Vec::new();
    let mut root_done = false;
    let (mut line, mut counted_to) = (1usize, 0usize);
    loop {
        let before = reader.buffer_position() as usize;
        let event = reader.read_event().map_err(|e| {
            FormatError::new(line_at(bytes, reader.error_position() as usize), format!("malformed XML: {e}"))
        })?;
        let after = reader.buffer_position() as usize;
        match event {
            Event::Start(ref e) | Event::Empty(ref e) => {
                let is_empty = matches!(event, Event::Empty(_));
                if stack.is_empty() && root_done {
                    // Content after the root element: ignore it.
                    if !is_empty {
                        break;
                    }
                    continue;
                }
                line += xml[counted_to..before].iter().filter(|&&b| b == b'\n').count();
                counted_to = before;
                let mut el = element_from(e, before, bytes)?;
                el.line = line;
                let idx = els.len();
                els.push(el);
                if let Some(&parent) = stack.last() {
                    els[parent].children.push(idx);
                }
                if is_empty {
                    if stack.is_empty() {
                        root_done = true;
                    }
                } else {
                    stack.push(idx);
                }
            }
            Event::End(_) => {
                stack.pop();
                if stack.is_empty() {
                    root_done = true;
                }
            }
            Event::Text(_) => {
                if let Some(&top) = stack.last() {
                    els[top].text.push(before..after);
                }
            }
            Event::Eof => break,
            _ => {}
        }
    }
    if els.is_empty() {
        return Err(FormatError::new(Location::Line(1), "no XML element found"));
    }
    if els[0].name != "VTKFile" {
        return Err(FormatError::new(
            line_at(bytes, els[0].pos),
            format!("root element is <{}>, expected <VTKFile>", els[0].name),
        ));
    }
    Ok(els)
}

// ---------------------------------------------------------------------------
// Encoding settings and the appended section

#[derive(Clone, Copy, PartialEq, Eq)]
enum Compressor {
    None,
    Zlib,
}

struct Appended<'a> {
    /// The bytes after the `_` marker (to the end of the file).
    data: &'a [u8],
    /// File offset of `data[0]`.
    base: usize,
    base64: bool,
    /// Sorted distinct `offset` attributes of appended arrays: in base64
    /// encoding an array ends where the next one starts.
    offsets: Vec<usize>,
}

// Bits of `Ctx::used`, for the format summary.
const USED_ASCII: u8 = 1;
const USED_BINARY: u8 = 2;
const USED_RAW: u8 = 4;
const USED_APPENDED_BASE64: u8 = 8;
const USED_ZLIB: u8 = 16;

struct Ctx<'a> {
    bytes: &'a [u8],
    els: Vec<Element>,
    endian: Endian,
    /// 4 (UInt32) or 8 (UInt64): size of block headers.
    header_size: usize,
    compressor: Result<Compressor, String>,
    appended: Option<Appended<'a>>,
    used: Cell<u8>,
}

/// Where an array's values live.
enum Payload<'x> {
    Ascii(&'x [Range<usize>]),
    Binary(&'x [u8], Location),
}

enum Unpacked<'b> {
    Stored(&'b [u8]),
    Inflated(Vec<u8>),
}

impl Unpacked<'_> {
    fn bytes(&self) -> &[u8] {
        match self {
            Unpacked::Stored(b) => b,
            Unpacked::Inflated(v) => v,
        }
    }
}

impl<'a> Ctx<'a> {
    fn new(bytes: &'a [u8]) -> Result<Self, FormatError> {
        let appended_at = find(bytes, b"<AppendedData", 0);
        let xml = &bytes[..appended_at.unwrap_or(bytes.len())];
        let els = parse_tree(xml, bytes)?;
        let root = &els[0];
        let get = |k: &str| root.attrs.iter().find(|(a, _)| a == k).map(|(_, v)| v.as_str());
        let endian = match get("byte_order") {
            None | Some("LittleEndian") => Endian::Little,
            Some("BigEndian") => Endian::Big,
            Some(o) => return Err(FormatError::new(line_at(bytes, root.pos), format!("unknown byte_order '{o}'"))),
        };
        let header_size = match get("header_type") {
            None | Some("UInt32") => 4,
            Some("UInt64") => 8,
            Some(h) => return Err(FormatError::new(line_at(bytes, root.pos), format!("unknown header_type '{h}'"))),
        };
        // An unsupported compressor only matters once a binary array is read
        // (VTK writes the attribute on ASCII files too).
        let compressor = match get("compressor") {
            None | Some("") => Ok(Compressor::None),
            Some("vtkZLibDataCompressor") => Ok(Compressor::Zlib),
            Some(c) => Err(format!(
                "unsupported compressor {c} (only vtkZLibDataCompressor is supported; re-save with zlib or no compression)"
            )),
        };
        let appended = match appended_at {
            None => None,
            Some(at) => Some(Self::appended_section(bytes, at, &els)?),
        };
        Ok(Ctx { bytes, els, endian, header_size, compressor, appended, used: Cell::new(0) })
    }

    fn appended_section(bytes: &'a [u8], at: usize, els: &[Element]) -> Result<Appended<'a>, FormatError> {
        let loc = line_at(bytes, at);
        let gt = find(bytes, b">", at).ok_or_else(|| FormatError::new(loc, "unterminated <AppendedData> tag"))?;
        let tag = &bytes[at..=gt];
        let mut reader = quick_xml::Reader::from_reader(tag);
        let encoding = match reader.read_event() {
            Ok(Event::Start(e)) | Ok(Event::Empty(e)) => {
                element_from(&e, at, bytes)?.attrs.into_iter().find(|(k, _)| k == "encoding").map(|(_, v)| v)
            }
            _ => return Err(FormatError::new(loc, "malformed <AppendedData> tag")),
        };
        let base64 = match encoding.as_deref() {
            Some("raw") => false,
            Some("base64") => true,
            Some(e) => return Err(FormatError::new(loc, format!("unknown AppendedData encoding '{e}'"))),
            None => return Err(FormatError::new(loc, "<AppendedData> has no encoding attribute")),
        };
        let rest = &bytes[gt + 1..];
        let skip = rest.iter().position(|b| !b.is_ascii_whitespace()).unwrap_or(rest.len());
        if rest.get(skip) != Some(&b'_') {
            return Err(FormatError::new(
                Location::Byte((gt + 1 + skip) as u64),
                "AppendedData does not start with the '_' marker",
            ));
        }
        let base = gt + 1 + skip + 1;
        let mut data = &bytes[base..];
        if base64 {
            // Base64 text ends at the closing tag.
            if let Some(end) = data.iter().position(|&b| b == b'<') {
                data = &data[..end];
            }
        }
        let mut offsets: Vec<usize> = els
            .iter()
            .filter_map(|e| e.attrs.iter().find(|(k, _)| k == "offset"))
            .filter_map(|(_, v)| v.trim().parse::<usize>().ok())
            .collect();
        offsets.sort_unstable();
        offsets.dedup();
        Ok(Appended { data, base, base64, offsets })
    }

    fn attr(&self, el: usize, key: &str) -> Option<&str> {
        self.els.get(el)?.attrs.iter().find(|(k, _)| k == key).map(|(_, v)| v.as_str())
    }

    fn name(&self, el: usize) -> &str {
        self.els.get(el).map_or("", |e| e.name.as_str())
    }

    fn err_at(&self, el: usize, message: impl Into<String>) -> FormatError {
        FormatError::new(Location::Line(self.els.get(el).map_or(1, |e| e.line)), message)
    }

    fn children<'s>(&'s self, el: usize, name: &'s str) -> impl Iterator<Item = usize> + 's {
        self.els
            .get(el)
            .map(|e| e.children.as_slice())
            .unwrap_or(&[])
            .iter()
            .copied()
            .filter(move |&c| self.name(c) == name)
    }

    fn child(&self, el: usize, name: &str) -> Option<usize> {
        self.children(el, name).next()
    }

    /// A DataArray child whose Name is `name`.
    fn named_array(&self, el: usize, name: &str) -> Option<usize> {
        self.children(el, "DataArray").find(|&c| self.attr(c, "Name") == Some(name))
    }

    fn layout_summary(&self) -> String {
        let used = self.used.get();
        let mut parts = Vec::new();
        for (bit, name) in [
            (USED_ASCII, "ascii"),
            (USED_BINARY, "inline binary"),
            (USED_RAW, "appended"),
            (USED_APPENDED_BASE64, "appended base64"),
            (USED_ZLIB, "zlib"),
        ] {
            if used & bit != 0 {
                parts.push(name);
            }
        }
        if parts.is_empty() {
            String::new()
        } else {
            format!(" ({})", parts.join(", "))
        }
    }

    fn mark(&self, bit: u8) {
        self.used.set(self.used.get() | bit);
    }

    // -- counts and attributes ------------------------------------------------

    fn count_attr(&self, el: usize, key: &str) -> Result<usize, FormatError> {
        let v =
            self.attr(el, key).ok_or_else(|| self.err_at(el, format!("<{}> has no {key} attribute", self.name(el))))?;
        v.trim().parse::<usize>().map_err(|_| self.err_at(el, format!("{key}=\"{v}\" is not a count")))
    }

    fn floats_attr<const N: usize>(&self, el: usize, key: &str, default: [f64; N]) -> Result<[f64; N], FormatError> {
        let Some(v) = self.attr(el, key) else {
            return Ok(default);
        };
        let vals: Vec<f64> = v.split_ascii_whitespace().filter_map(parse_f64).collect();
        vals.as_slice().try_into().map_err(|_| self.err_at(el, format!("{key}=\"{v}\" must be {N} numbers")))
    }

    /// Point counts along i, j, k of an `Extent` (or `WholeExtent`).
    fn extent_dims(&self, el: usize, key: &str) -> Result<[usize; 3], FormatError> {
        let v =
            self.attr(el, key).ok_or_else(|| self.err_at(el, format!("<{}> has no {key} attribute", self.name(el))))?;
        let bad = || self.err_at(el, format!("{key}=\"{v}\" must be 6 integers with max >= min - 1"));
        let e: Vec<i64> =
            v.split_ascii_whitespace().map(|t| t.parse::<i64>()).collect::<Result<_, _>>().map_err(|_| bad())?;
        if e.len() != 6 {
            return Err(bad());
        }
        let mut dims = [0usize; 3];
        for a in 0..3 {
            let n = e[2 * a + 1].checked_sub(e[2 * a]).and_then(|d| d.checked_add(1)).ok_or_else(bad)?;
            dims[a] = usize::try_from(n).map_err(|_| bad())?;
        }
        Ok(dims)
    }

    fn extent_min(&self, el: usize, key: &str) -> [f64; 3] {
        let mut min = [0.0; 3];
        if let Some(v) = self.attr(el, key) {
            let e: Vec<i64> = v.split_ascii_whitespace().filter_map(|t| t.parse().ok()).collect();
            if e.len() == 6 {
                min = [e[0] as f64, e[2] as f64, e[4] as f64];
            }
        }
        min
    }

    // -- DataArray decoding ---------------------------------------------------

    fn array_type(&self, el: usize) -> Result<Option<ScalarType>, FormatError> {
        let t = self.attr(el, "type").ok_or_else(|| self.err_at(el, "DataArray has no type attribute"))?;
        Ok(Some(match t {
            "Int8" | "Char" => ScalarType::I8,
            "UInt8" | "UnsignedChar" => ScalarType::U8,
            "Int16" | "Short" => ScalarType::I16,
            "UInt16" | "UnsignedShort" => ScalarType::U16,
            "Int32" | "Int" => ScalarType::I32,
            "UInt32" | "UnsignedInt" => ScalarType::U32,
            "Int64" | "Long" | "LongLong" | "IdType" => ScalarType::I64,
            "UInt64" | "UnsignedLong" | "UnsignedLongLong" => ScalarType::U64,
            "Float32" | "Float" => ScalarType::F32,
            "Float64" | "Double" => ScalarType::F64,
            "String" | "Bit" => return Ok(None),
            other => return Err(self.err_at(el, format!("unknown DataArray type '{other}'"))),
        }))
    }

    fn num_components(&self, el: usize) -> Result<usize, FormatError> {
        match self.attr(el, "NumberOfComponents") {
            None => Ok(1),
            Some(v) => match v.trim().parse::<usize>() {
                Ok(n) if n >= 1 => Ok(n),
                _ => Err(self.err_at(el, format!("NumberOfComponents=\"{v}\" must be a positive count"))),
            },
        }
    }

    /// Runs `f` on the array's values, decoded from base64 and inflated as
    /// needed. `expected_bytes`, when known, is checked against a compressed
    /// header before anything is inflated.
    fn with_payload<R>(
        &self,
        el: usize,
        expected_bytes: Option<usize>,
        f: impl FnOnce(Payload<'_>) -> Result<R, FormatError>,
    ) -> Result<R, FormatError> {
        let format = self.attr(el, "format").unwrap_or("ascii");
        let what = format!("DataArray '{}'", self.attr(el, "Name").unwrap_or(""));
        match format {
            "ascii" => {
                self.mark(USED_ASCII);
                f(Payload::Ascii(&self.els[el].text))
            }
            "binary" => {
                self.mark(USED_BINARY);
                let compressor = self.compressor.clone().map_err(|m| self.err_at(el, m))?;
                let loc = self.err_at(el, "").at;
                let text: Vec<u8> = self.els[el]
                    .text
                    .iter()
                    .flat_map(|r| self.bytes.get(r.clone()).unwrap_or(&[]).iter().copied())
                    .filter(|b| !b.is_ascii_whitespace())
                    .collect();
                let decoded = decode_base64(&text).map_err(|m| FormatError::new(loc, format!("{what}: {m}")))?;
                // Offsets inside decoded base64 are not file offsets: report
                // the element's line instead.
                let mut cur = ByteCursor::new(&decoded);
                let unpacked = self
                    .unpack(&mut cur, compressor, expected_bytes, &what)
                    .map_err(|e| FormatError::new(loc, e.message))?;
                f(Payload::Binary(unpacked.bytes(), loc))
            }
            "appended" => {
                let app = self
                    .appended
                    .as_ref()
                    .ok_or_else(|| self.err_at(el, format!("{what} is appended but the file has no <AppendedData>")))?;
                let compressor = self.compressor.clone().map_err(|m| self.err_at(el, m))?;
                let offset_text = self.attr(el, "offset").unwrap_or("");
                let offset: usize = offset_text
                    .trim()
                    .parse()
                    .map_err(|_| self.err_at(el, format!("{what}: offset=\"{offset_text}\" is not a byte offset")))?;
                let loc = Location::Byte(app.base as u64 + offset as u64);
                if offset > app.data.len() {
                    return Err(FormatError::new(
                        loc,
                        format!(
                            "{what}: offset {offset} is past the end of the appended data ({} bytes)",
                            app.data.len()
                        ),
                    ));
                }
                if app.base64 {
                    self.mark(USED_APPENDED_BASE64);
                    let end = app.offsets.iter().copied().find(|&o| o > offset).unwrap_or(app.data.len());
                    let end = end.min(app.data.len());
                    let chunk = &app.data[offset..end];
                    let text: Vec<u8> = chunk.iter().copied().filter(|b| !b.is_ascii_whitespace()).collect();
                    let decoded = decode_base64(&text).map_err(|m| FormatError::new(loc, format!("{what}: {m}")))?;
                    let mut cur = ByteCursor::new(&decoded);
                    let unpacked = self
                        .unpack(&mut cur, compressor, expected_bytes, &what)
                        .map_err(|e| FormatError::new(loc, e.message))?;
                    f(Payload::Binary(unpacked.bytes(), loc))
                } else {
                    self.mark(USED_RAW);
                    let mut cur = ByteCursor::with_base(&app.data[offset..], loc_offset(loc));
                    let unpacked = self.unpack(&mut cur, compressor, expected_bytes, &what)?;
                    f(Payload::Binary(unpacked.bytes(), loc))
                }
            }
            other => Err(self.err_at(el, format!("{what}: unknown format '{other}'"))),
        }
    }

    fn header_word(&self, cur: &mut ByteCursor<'_>, what: &str) -> Result<u64, FormatError> {
        if self.header_size == 8 {
            cur.u64(self.endian, what)
        } else {
            cur.u32(self.endian, what).map(u64::from)
        }
    }

    /// Reads one array block: `[nbytes]` then the bytes, or the zlib layout
    /// `[nblocks, blocksize, lastblocksize, compsize_1..n]` then the blocks.
    fn unpack<'b>(
        &self,
        cur: &mut ByteCursor<'b>,
        compressor: Compressor,
        expected_bytes: Option<usize>,
        what: &str,
    ) -> Result<Unpacked<'b>, FormatError> {
        let at = cur.location();
        let to_usize = |v: u64, cur: &ByteCursor<'_>| {
            usize::try_from(v).map_err(|_| FormatError::new(cur.location(), format!("{what}: size {v} is too large")))
        };
        if compressor == Compressor::None {
            let n = self.header_word(cur, &format!("{what} size header"))?;
            let n = to_usize(n, cur)?;
            return Ok(Unpacked::Stored(cur.take(n, what)?));
        }
        self.mark(USED_ZLIB);
        let num_blocks = to_usize(self.header_word(cur, &format!("{what} zlib header"))?, cur)?;
        let block_size = to_usize(self.header_word(cur, &format!("{what} zlib header"))?, cur)?;
        let last_size = to_usize(self.header_word(cur, &format!("{what} zlib header"))?, cur)?;
        let sizes = cur.take_array(num_blocks, self.header_size, &format!("{what} zlib block sizes"))?;
        let last_size = if last_size == 0 { block_size } else { last_size };
        let total = match num_blocks {
            0 => Some(0),
            n => (n - 1).checked_mul(block_size).and_then(|t| t.checked_add(last_size)),
        }
        .ok_or_else(|| FormatError::new(at, format!("{what}: zlib header declares an impossible size")))?;
        if let Some(expected) = expected_bytes {
            if total != expected {
                return Err(FormatError::new(
                    at,
                    format!("{what}: zlib header declares {total} bytes, the array needs {expected}"),
                ));
            }
        }
        let mut size_cur = ByteCursor::new(sizes);
        let mut out: Vec<u8> = Vec::new();
        let mut inflater = Decompress::new(true);
        for b in 0..num_blocks {
            let comp = to_usize(self.header_word(&mut size_cur, "zlib block size")?, cur)?;
            let plain = if b + 1 == num_blocks { last_size } else { block_size };
            let block_at = cur.location();
            let input = cur.take(comp, &format!("{what} zlib block {b}"))?;
            if plain > comp.saturating_mul(MAX_DEFLATE_RATIO).saturating_add(1024) {
                return Err(FormatError::new(
                    block_at,
                    format!("{what}: zlib block {b} claims {plain} bytes from {comp} compressed bytes (beyond zlib's ratio)"),
                ));
            }
            out.reserve_exact(plain);
            inflater.reset(true);
            let before = out.len();
            let status = inflater.decompress_vec(input, &mut out, FlushDecompress::Finish);
            let produced = out.len() - before;
            match status {
                Ok(Status::StreamEnd) if produced == plain => {}
                Ok(Status::StreamEnd) => {
                    return Err(FormatError::new(
                        block_at,
                        format!("{what}: zlib block {b} inflates to {produced} bytes, header says {plain}"),
                    ))
                }
                Ok(_) => {
                    return Err(FormatError::new(
                        block_at,
                        format!(
                        "{what}: zlib block {b} is truncated or inflates past the {plain} bytes its header declares"
                    ),
                    ))
                }
                Err(e) => return Err(FormatError::new(block_at, format!("{what}: zlib block {b} is corrupt: {e}"))),
            }
        }
        Ok(Unpacked::Inflated(out))
    }

    /// The array's values as f64; exactly `expected` of them when given.
    fn array_f64(&self, el: usize, expected: Option<usize>) -> Result<Vec<f64>, FormatError> {
        let ty = self.array_type(el)?.ok_or_else(|| self.err_at(el, "expected a numeric DataArray"))?;
        let expected_bytes = expected.and_then(|n| n.checked_mul(ty.size()));
        let what = format!("DataArray '{}'", self.attr(el, "Name").unwrap_or(""));
        let values = self.with_payload(el, expected_bytes, |payload| match payload {
            Payload::Ascii(ranges) => self.ascii_values(ranges, expected, &what, parse_f64),
            Payload::Binary(bytes, loc) => {
                check_byte_count(bytes.len(), ty, expected, loc, &what)?;
                let mut out = Vec::new();
                decode_to_f64(bytes, ty, self.endian, &mut out);
                Ok(out)
            }
        })?;
        Ok(values)
    }

    /// The array's values as i64 (integer arrays only).
    fn array_i64(&self, el: usize, expected: Option<usize>) -> Result<Vec<i64>, FormatError> {
        let ty = self.array_type(el)?.ok_or_else(|| self.err_at(el, "expected an integer DataArray"))?;
        let what = format!("DataArray '{}'", self.attr(el, "Name").unwrap_or(""));
        if matches!(ty, ScalarType::F32 | ScalarType::F64) {
            return Err(self.err_at(el, format!("{what} must hold integers, not floating point")));
        }
        let expected_bytes = expected.and_then(|n| n.checked_mul(ty.size()));
        self.with_payload(el, expected_bytes, |payload| match payload {
            Payload::Ascii(ranges) => self.ascii_values(ranges, expected, &what, parse_i64),
            Payload::Binary(bytes, loc) => {
                check_byte_count(bytes.len(), ty, expected, loc, &what)?;
                decode_to_i64(bytes, ty, self.endian).map_err(|m| FormatError::new(loc, format!("{what}: {m}")))
            }
        })
    }

    fn ascii_values<T>(
        &self,
        ranges: &[Range<usize>],
        expected: Option<usize>,
        what: &str,
        parse: impl Fn(&str) -> Option<T>,
    ) -> Result<Vec<T>, FormatError> {
        let text_len: usize = ranges.iter().map(|r| r.len()).sum();
        // Every value takes at least two bytes (a digit and a separator).
        let mut out = Vec::with_capacity(expected.unwrap_or(0).min(text_len / 2 + 1));
        let base = self.bytes.as_ptr() as usize;
        for r in ranges {
            let Some(text) = self.bytes.get(r.clone()) else {
                continue;
            };
            for tok in text.split(|b| b.is_ascii_whitespace()).filter(|t| !t.is_empty()) {
                let pos = tok.as_ptr() as usize - base;
                let value = std::str::from_utf8(tok).ok().and_then(&parse).ok_or_else(|| {
                    let shown = String::from_utf8_lossy(&tok[..tok.len().min(40)]).into_owned();
                    FormatError::new(line_at(self.bytes, pos), format!("{what}: '{shown}' is not a valid value"))
                })?;
                if expected.is_some_and(|n| out.len() >= n) {
                    return Err(FormatError::new(
                        line_at(self.bytes, pos),
                        format!("{what}: more than the {} values expected", out.len()),
                    ));
                }
                out.push(value);
            }
        }
        if let Some(n) = expected {
            if out.len() != n {
                let pos = ranges.first().map_or(0, |r| r.start);
                return Err(FormatError::new(
                    line_at(self.bytes, pos),
                    format!("{what}: {} values, expected {n}", out.len()),
                ));
            }
        }
        Ok(out)
    }

    /// The `Points` of a piece: `num_points` × 3 coordinates.
    fn points(&self, piece: usize, num_points: usize) -> Result<Vec<[f64; 3]>, FormatError> {
        let Some(points_el) = self.child(piece, "Points") else {
            if num_points == 0 {
                return Ok(Vec::new());
            }
            return Err(self.err_at(piece, format!("piece declares {num_points} points but has no <Points>")));
        };
        let array =
            self.child(points_el, "DataArray").ok_or_else(|| self.err_at(points_el, "<Points> has no DataArray"))?;
        let ncomp = self.num_components(array)?;
        if ncomp != 3 {
            return Err(self.err_at(array, format!("Points have {ncomp} components, expected 3")));
        }
        let n = num_points.checked_mul(3).ok_or_else(|| self.err_at(piece, "point count overflows"))?;
        let flat = self.array_f64(array, Some(n))?;
        Ok(flat.chunks_exact(3).map(|c| [c[0], c[1], c[2]]).collect())
    }

    /// The active scalar a piece's `<PointData>`/`<CellData>` declares
    /// (`Scalars="NAME"`), if any.
    fn active_scalar(&self, piece: usize, data: &str) -> Option<String> {
        let el = self.child(piece, data)?;
        self.attr(el, "Scalars").filter(|n| !n.is_empty()).map(str::to_string)
    }

    /// Numeric arrays of a `<PointData>`/`<CellData>` element as fields of
    /// `num_tuples` tuples; with `gather`, the tuples it lists, in its order
    /// (cells kept, a polyhedron's tuple once per tet).
    fn fields(
        &self,
        data_el: Option<usize>,
        num_tuples: usize,
        gather: Option<&[u32]>,
        stats: &mut Stats,
    ) -> Result<Vec<Field>, FormatError> {
        let Some(data_el) = data_el else {
            return Ok(Vec::new());
        };
        let mut fields = Vec::new();
        let arrays: Vec<usize> = self.children(data_el, "DataArray").collect();
        for (i, array) in arrays.into_iter().enumerate() {
            let name = match self.attr(array, "Name") {
                Some(n) if !n.is_empty() => n.to_string(),
                _ => format!("array{i}"),
            };
            if self.array_type(array)?.is_none() {
                if !stats.skipped_non_numeric.contains(&name) {
                    stats.skipped_non_numeric.push(name);
                }
                continue;
            }
            let ncomp = self.num_components(array)?;
            let n = num_tuples
                .checked_mul(ncomp)
                .ok_or_else(|| self.err_at(array, format!("array '{name}': size overflows")))?;
            let mut values = self.array_f64(array, Some(n))?;
            if let Some(gather) = gather {
                let mut out = Vec::with_capacity(gather.len() * ncomp);
                for &t in gather {
                    out.extend_from_slice(&values[t as usize * ncomp..(t as usize + 1) * ncomp]);
                }
                values = out;
            }
            fields.push(Field::new(name, ncomp, values));
        }
        Ok(fields)
    }

    // -- pieces ---------------------------------------------------------------

    fn unstructured_piece(&self, piece: usize, stats: &mut Stats) -> Result<SourceMesh, FormatError> {
        let num_points = self.count_attr(piece, "NumberOfPoints")?;
        let num_cells = self.count_attr(piece, "NumberOfCells")?;
        if num_points > u32::MAX as usize {
            return Err(self.err_at(piece, format!("{num_points} points exceed the 32-bit index range")));
        }
        let points = self.points(piece, num_points)?;

        let mut cells = Cells::new();
        let mut gather: Option<Vec<u32>> = None;
        let mut splitter = PolyhedronSplitter::new(num_points);
        if num_cells > 0 {
            let cells_el = self
                .child(piece, "Cells")
                .ok_or_else(|| self.err_at(piece, format!("piece declares {num_cells} cells but has no <Cells>")))?;
            let array = |name: &str| {
                self.named_array(cells_el, name)
                    .ok_or_else(|| self.err_at(cells_el, format!("<Cells> has no '{name}' DataArray")))
            };
            let (conn_el, offsets_el, types_el) = (array("connectivity")?, array("offsets")?, array("types")?);
            let types = self.array_i64(types_el, Some(num_cells))?;
            let mut offsets = self.array_i64(offsets_el, None)?;
            // VTK files list end offsets; some writers add the leading 0.
            if offsets.len() == num_cells + 1 && offsets.first() == Some(&0) {
                offsets.remove(0);
            }
            if offsets.len() != num_cells {
                return Err(
                    self.err_at(offsets_el, format!("'offsets' has {} entries for {num_cells} cells", offsets.len()))
                );
            }
            let connectivity = self.array_i64(conn_el, None)?;
            // Polyhedra (id 42) carry their faces in a separate stream.
            let poly = match (self.named_array(cells_el, "faces"), self.named_array(cells_el, "faceoffsets")) {
                (Some(f), Some(o)) if types.contains(&42) => Some(PolyFaces {
                    faces: self.array_i64(f, None)?,
                    offsets: self.array_i64(o, Some(num_cells))?,
                    at: f,
                }),
                _ => None,
            };
            let input =
                CellArrays { types: &types, offsets: &offsets, connectivity: &connectivity, poly: poly.as_ref() };
            let mut source = Vec::with_capacity(num_cells);
            cells = self.build_cells(&input, num_points, piece, &mut source, &mut splitter, stats)?;
            if source.len() != num_cells || source.iter().enumerate().any(|(i, &c)| c as usize != i) {
                gather = Some(source);
            }
        }
        let point_fields = self.fields(self.child(piece, "PointData"), num_points, None, stats)?;
        let cell_fields = self.fields(self.child(piece, "CellData"), num_cells, gather.as_deref(), stats)?;
        let mut mesh = SourceMesh {
            points,
            blocks: vec![Block::Unstructured(cells)],
            point_fields,
            cell_fields,
            active_point_scalar: self.active_scalar(piece, "PointData"),
            active_cell_scalar: self.active_scalar(piece, "CellData"),
            ..Default::default()
        };
        stats.polyhedron_points += splitter.num_added_points();
        splitter.finish(&mut mesh).map_err(|m| self.err_at(piece, m))?;
        Ok(mesh)
    }

    /// The piece's cells; `source` receives, per cell kept, the index of
    /// the file's cell it came from (a polyhedron gives several tets).
    fn build_cells(
        &self,
        input: &CellArrays<'_>,
        num_points: usize,
        piece: usize,
        source: &mut Vec<u32>,
        splitter: &mut PolyhedronSplitter,
        stats: &mut Stats,
    ) -> Result<Cells, FormatError> {
        let CellArrays { types, offsets, connectivity, poly } = *input;
        let num_cells = types.len();
        // End of the previous polyhedron's face stream.
        let mut poly_start = 0usize;
        let mut cells = Cells {
            types: Vec::with_capacity(num_cells),
            offsets: Vec::with_capacity(num_cells + 1),
            connectivity: Vec::with_capacity(connectivity.len()),
        };
        cells.offsets.push(0);
        let mut start = 0usize;
        let mut nodes = [0u32; 32];
        for (c, (&id, &end)) in types.iter().zip(offsets).enumerate() {
            let end =
                usize::try_from(end).ok().filter(|&e| e >= start && e <= connectivity.len()).ok_or_else(|| {
                    self.err_at(
                        piece,
                        format!(
                            "cell {c}: offset {end} is outside {start}..={} of the connectivity",
                            connectivity.len()
                        ),
                    )
                })?;
            let cell_nodes = &connectivity[start..end];
            start = end;
            let id = u32::try_from(id)
                .map_err(|_| self.err_at(piece, format!("cell {c} has invalid VTK cell type id {id}")))?;
            let keep = match CellType::from_vtk_id(id) {
                Some((cell_type, stored)) => {
                    if cell_nodes.len() != stored {
                        return Err(self.err_at(
                            piece,
                            format!("cell {c} (VTK type {id}) has {} nodes, expected {stored}", cell_nodes.len()),
                        ));
                    }
                    let n = cell_type.num_nodes();
                    for (slot, &p) in nodes.iter_mut().zip(&cell_nodes[..n]) {
                        *slot = u32::try_from(p).ok().filter(|&q| (q as usize) < num_points).ok_or_else(|| {
                            self.err_at(
                                piece,
                                format!("cell {c} refers to point {p}, but the piece has {num_points} points"),
                            )
                        })?;
                    }
                    if stored > n {
                        stats.reduced_higher_order += 1;
                    }
                    cells.push(cell_type, &nodes[..n]);
                    true
                }
                None if id == 42 && poly.is_some() => {
                    let pf = poly.expect("checked");
                    let end = usize::try_from(pf.offsets[c])
                        .ok()
                        .filter(|&e| e >= poly_start && e <= pf.faces.len())
                        .ok_or_else(|| {
                        self.err_at(
                            pf.at,
                            format!(
                                "cell {c}: faceoffsets entry {} is outside {poly_start}..={} of 'faces'",
                                pf.offsets[c],
                                pf.faces.len()
                            ),
                        )
                    })?;
                    let faces = polyhedron_faces(&pf.faces[poly_start..end], num_points)
                        .map_err(|m| self.err_at(pf.at, format!("polyhedron cell {c}: {m}")))?;
                    poly_start = end;
                    let first_cell = cells.len();
                    splitter
                        .split(faces.iter().map(Vec::as_slice), &mut |t| cells.push(CellType::Tetra, &t))
                        .map_err(|m| self.err_at(pf.at, format!("polyhedron cell {c}: {m}")))?;
                    stats.split_polyhedra += 1;
                    stats.polyhedron_tets += cells.len() - first_cell;
                    source.extend(std::iter::repeat_n(c as u32, cells.len() - first_cell));
                    false
                }
                None if CellType::vtk_id_is_surface_or_lower(id) => {
                    stats.skipped_without_volume += 1;
                    false
                }
                None if CellType::vtk_id_is_unreducible_volume(id) => {
                    *stats.skipped_unreducible.entry(id).or_insert(0) += 1;
                    false
                }
                None => {
                    return Err(self.err_at(piece, format!("cell {c} has unknown VTK cell type id {id}")));
                }
            };
            if keep {
                source.push(c as u32);
            }
        }
        Ok(cells)
    }

    fn structured_piece(
        &self,
        kind: Kind,
        dataset: usize,
        piece: usize,
        stats: &mut Stats,
    ) -> Result<SourceMesh, FormatError> {
        let dims = self.extent_dims(piece, "Extent")?;
        let too_many =
            || self.err_at(piece, format!("structured piece {dims:?} has more points than 32-bit indices reach"));
        let num_points = dims
            .iter()
            .try_fold(1usize, |a, &d| a.checked_mul(d))
            .filter(|&n| n <= u32::MAX as usize)
            .ok_or_else(too_many)?;
        // VTK's cell count (which cell data follows) counts lower-dimensional
        // cells of flat pieces; tetkit keeps only volume cells.
        let vtk_cells = if dims.contains(&0) { 0 } else { dims.iter().map(|&d| (d - 1).max(1)).product() };
        let volume_cells: usize = dims.iter().map(|&d| d.saturating_sub(1)).product();
        // A flat piece keeps none of its (lower-dimensional) cells' tuples.
        let kept = if volume_cells == vtk_cells {
            None
        } else {
            stats.flat_structured_cells += vtk_cells;
            Some(&[][..])
        };
        let point_fields = self.fields(self.child(piece, "PointData"), num_points, None, stats)?;
        let cell_fields = self.fields(self.child(piece, "CellData"), vtk_cells, kept, stats)?;

        let points = match kind {
            Kind::Structured => self.points(piece, num_points)?,
            Kind::Image | Kind::Rectilinear => {
                let backed = !point_fields.is_empty() || (!cell_fields.is_empty() && volume_cells >= num_points / 8);
                if num_points > MAX_UNBACKED_GRID_POINTS && !backed {
                    return Err(self.err_at(
                        piece,
                        format!("piece of {num_points} grid points carries no point or cell data of that size"),
                    ));
                }
                if kind == Kind::Image {
                    self.image_points(dataset, piece, dims)?
                } else {
                    self.rectilinear_points(piece, dims)?
                }
            }
            Kind::Unstructured => {
                unreachable!("unstructured pieces are read by unstructured_piece")
            }
        };
        Ok(SourceMesh {
            points,
            blocks: vec![Block::Structured { dims, first_point: 0 }],
            point_fields,
            cell_fields,
            active_point_scalar: self.active_scalar(piece, "PointData"),
            active_cell_scalar: self.active_scalar(piece, "CellData"),
            ..Default::default()
        })
    }

    /// ImageData points, i fastest: `Origin + Direction · (Spacing ∘ ijk)`
    /// with ijk the absolute structured index (Extent minimum included), as
    /// `vtkImageData::TransformIndexToPhysicalPoint` computes them.
    fn image_points(&self, dataset: usize, piece: usize, dims: [usize; 3]) -> Result<Vec<[f64; 3]>, FormatError> {
        let origin = self.floats_attr(dataset, "Origin", [0.0; 3])?;
        let spacing = self.floats_attr(dataset, "Spacing", [1.0; 3])?;
        let d = self.floats_attr(dataset, "Direction", [1.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 1.0])?;
        let min = self.extent_min(piece, "Extent");
        let mut points = Vec::with_capacity(dims[0] * dims[1] * dims[2]);
        for k in 0..dims[2] {
            let z = (min[2] + k as f64) * spacing[2];
            for j in 0..dims[1] {
                let y = (min[1] + j as f64) * spacing[1];
                for i in 0..dims[0] {
                    let x = (min[0] + i as f64) * spacing[0];
                    points.push([
                        origin[0] + d[0] * x + d[1] * y + d[2] * z,
                        origin[1] + d[3] * x + d[4] * y + d[5] * z,
                        origin[2] + d[6] * x + d[7] * y + d[8] * z,
                    ]);
                }
            }
        }
        Ok(points)
    }

    /// RectilinearGrid points from the three `<Coordinates>` arrays, i fastest.
    fn rectilinear_points(&self, piece: usize, dims: [usize; 3]) -> Result<Vec<[f64; 3]>, FormatError> {
        let coords_el = self
            .child(piece, "Coordinates")
            .ok_or_else(|| self.err_at(piece, "RectilinearGrid piece has no <Coordinates>"))?;
        let arrays: Vec<usize> = self.children(coords_el, "DataArray").collect();
        if arrays.len() != 3 {
            return Err(self.err_at(coords_el, format!("<Coordinates> has {} DataArrays, expected 3", arrays.len())));
        }
        let x = self.array_f64(arrays[0], Some(dims[0]))?;
        let y = self.array_f64(arrays[1], Some(dims[1]))?;
        let z = self.array_f64(arrays[2], Some(dims[2]))?;
        let mut points = Vec::with_capacity(dims[0] * dims[1] * dims[2]);
        for &zk in &z {
            for &yj in &y {
                points.extend(x.iter().map(|&xi| [xi, yj, zk]));
            }
        }
        Ok(points)
    }
}

/// A piece's `<Cells>` arrays.
#[derive(Clone, Copy)]
struct CellArrays<'a> {
    types: &'a [i64],
    offsets: &'a [i64],
    connectivity: &'a [i64],
    poly: Option<&'a PolyFaces>,
}

/// The polyhedron face stream: `faces` holds, per polyhedron, its face
/// count then each face as a point count and point ids; `faceoffsets[c]`
/// is the end of cell c's stream (-1 for other cells).
struct PolyFaces {
    faces: Vec<i64>,
    offsets: Vec<i64>,
    /// The `faces` DataArray element, for errors.
    at: usize,
}

/// One polyhedron's faces from its stream `[nfaces, n0, ids…, n1, ids…]`.
fn polyhedron_faces(stream: &[i64], num_points: usize) -> Result<Vec<Vec<u32>>, String> {
    let (&nf, mut rest) = stream.split_first().ok_or("its face stream is empty")?;
    let nf = usize::try_from(nf)
        .ok()
        .filter(|&n| n >= 4 && n <= rest.len())
        .ok_or_else(|| format!("face count {nf} is not between 4 and the {} entries of its stream", rest.len()))?;
    let mut faces = Vec::with_capacity(nf);
    for f in 0..nf {
        let (&k, tail) = rest.split_first().ok_or_else(|| format!("its stream ends before face {f}"))?;
        let k = usize::try_from(k)
            .ok()
            .filter(|&k| k >= 3 && k <= tail.len())
            .ok_or_else(|| format!("face {f} has point count {k}; needs 3 to the {} entries left", tail.len()))?;
        let ids = tail[..k]
            .iter()
            .map(|&p| u32::try_from(p).ok().filter(|&q| (q as usize) < num_points))
            .collect::<Option<Vec<u32>>>()
            .ok_or_else(|| format!("face {f} refers to a point outside the piece's {num_points}"))?;
        faces.push(ids);
        rest = &tail[k..];
    }
    if !rest.is_empty() {
        return Err(format!("{} entries are left after its {nf} faces", rest.len()));
    }
    Ok(faces)
}

fn loc_offset(loc: Location) -> u64 {
    match loc {
        Location::Byte(b) => b,
        _ => 0,
    }
}

fn check_byte_count(
    len: usize,
    ty: ScalarType,
    expected: Option<usize>,
    loc: Location,
    what: &str,
) -> Result<(), FormatError> {
    if len / ty.size() * ty.size() != len {
        return Err(FormatError::new(
            loc,
            format!("{what}: {len} bytes is not a whole number of {}-byte values", ty.size()),
        ));
    }
    if let Some(n) = expected {
        if len / ty.size() != n {
            return Err(FormatError::new(loc, format!("{what}: holds {} values, expected {n}", len / ty.size())));
        }
    }
    Ok(())
}

fn parse_i64(tok: &str) -> Option<i64> {
    tok.parse::<i64>().ok().or_else(|| {
        let v = parse_f64(tok)?;
        (v.fract() == 0.0 && v.abs() < 9.0e15).then_some(v as i64)
    })
}

/// Decodes integer elements to i64 (UInt64 values beyond i64 are an error).
fn decode_to_i64(bytes: &[u8], ty: ScalarType, e: Endian) -> Result<Vec<i64>, String> {
    macro_rules! conv {
        ($t:ty, $n:expr) => {
            bytes.chunks_exact($n).map(|ch| {
                let arr: [u8; $n] = ch.try_into().expect("chunk size");
                match e {
                    Endian::Little => <$t>::from_le_bytes(arr),
                    Endian::Big => <$t>::from_be_bytes(arr),
                }
            })
        };
    }
    Ok(match ty {
        ScalarType::I8 => bytes.iter().map(|&b| b as i8 as i64).collect(),
        ScalarType::U8 => bytes.iter().map(|&b| b as i64).collect(),
        ScalarType::I16 => conv!(i16, 2).map(i64::from).collect(),
        ScalarType::U16 => conv!(u16, 2).map(i64::from).collect(),
        ScalarType::I32 => conv!(i32, 4).map(i64::from).collect(),
        ScalarType::U32 => conv!(u32, 4).map(i64::from).collect(),
        ScalarType::I64 => conv!(i64, 8).collect(),
        ScalarType::U64 => conv!(u64, 8)
            .map(|v| i64::try_from(v).map_err(|_| format!("value {v} is out of range")))
            .collect::<Result<_, _>>()?,
        ScalarType::F32 | ScalarType::F64 => return Err("expected integers, found floating point".into()),
    })
}

/// Decodes VTK's base64: possibly several padded streams back to back (a
/// block header encoded separately from its data), which decode to the
/// concatenation of their bytes. `text` must hold no whitespace.
fn decode_base64(text: &[u8]) -> Result<Vec<u8>, String> {
    let mut out = Vec::with_capacity(text.len() / 4 * 3 + 3);
    let mut start = 0;
    while start < text.len() {
        let rest = &text[start..];
        let end = match rest.iter().position(|&c| c == b'=') {
            Some(p) => start + p + rest[p..].iter().take_while(|&&c| c == b'=').count(),
            None => text.len(),
        };
        BASE64
            .decode_vec(&text[start..end], &mut out)
            .map_err(|e| format!("invalid base64 at character {start}: {e}"))?;
        start = end;
    }
    Ok(out)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn b64(bytes: &[u8]) -> String {
        base64::engine::general_purpose::STANDARD.encode(bytes)
    }

    #[test]
    fn base64_with_separately_padded_header_decodes_to_concatenation() {
        let header = 5u32.to_le_bytes();
        let data = b"hello";
        let text = format!("{}{}", b64(&header), b64(data));
        assert!(text.contains("=="));
        let mut expected = header.to_vec();
        expected.extend_from_slice(data);
        assert_eq!(decode_base64(text.as_bytes()).unwrap(), expected);
        assert!(decode_base64(b"A===B").is_err());
    }

    fn tiny_vtu(types: &str, offsets: &str, conn: &str, celldata: &str) -> String {
        format!(
            r#"<?xml version="1.0"?>
<VTKFile type="UnstructuredGrid" version="1.0" byte_order="LittleEndian" header_type="UInt64">
<UnstructuredGrid><Piece NumberOfPoints="10" NumberOfCells="3">
<PointData><DataArray type="Float32" Name="s" format="ascii">0 1 2 3 4 5 6 7 8 9</DataArray>
<DataArray type="String" Name="label" format="ascii">65 0</DataArray></PointData>
<CellData><DataArray type="Int32" Name="id" format="ascii">{celldata}</DataArray></CellData>
<Points><DataArray type="Float64" NumberOfComponents="3" format="ascii">
0 0 0 1 0 0 0 1 0 0 0 1 .5 0 0 .5 .5 0 0 .5 0 0 0 .5 .5 0 .5 0 .5 .5</DataArray></Points>
<Cells><DataArray type="Int64" Name="connectivity" format="ascii">{conn}</DataArray>
<DataArray type="Int64" Name="offsets" format="ascii">{offsets}</DataArray>
<DataArray type="UInt8" Name="types" format="ascii">{types}</DataArray></Cells>
</Piece></UnstructuredGrid></VTKFile>"#
        )
    }

    #[test]
    fn mixed_cells_skip_surfaces_and_reduce_quadratics() {
        // tet, triangle (skipped), quadratic tet (reduced).
        let text = tiny_vtu("10 5 24", "4 7 17", "0 1 2 3  0 1 2  0 1 2 3 4 5 6 7 8 9", "7 8 9");
        let m = read(text.as_bytes()).unwrap();
        assert_eq!(m.num_cells(), 2);
        let Block::Unstructured(cells) = &m.blocks[0] else { panic!() };
        assert_eq!(cells.nodes(1), &[0, 1, 2, 3]);
        assert_eq!(m.cell_fields[0].values, vec![7.0, 9.0]);
        assert_eq!(m.point_fields.len(), 1, "String array skipped");
        assert!(m.notes.iter().any(|n| n.contains("1 higher-order")), "{:?}", m.notes);
        assert!(m.notes.iter().any(|n| n.contains("skipped 1 cells without volume")), "{:?}", m.notes);
        assert!(m.format.contains("ascii"), "{}", m.format);
    }

    #[test]
    fn offsets_with_leading_zero_and_polyhedron_skipped() {
        let text = tiny_vtu("10 42 10", "0 4 8 12", "0 1 2 3 4 5 6 7 1 2 3 4", "1 2 3");
        let m = read(text.as_bytes()).unwrap();
        assert_eq!(m.num_cells(), 2);
        assert_eq!(m.cell_fields[0].values, vec![1.0, 3.0]);
        assert!(m.notes.iter().any(|n| n.contains("polyhedra")), "{:?}", m.notes);
    }

    /// Two unit cubes along x: cell 0 a VTK_POLYHEDRON (its faces in the
    /// `faces`/`faceoffsets` stream), cell 1 a hexahedron sharing its x = 1
    /// face. The polyhedron becomes 12 positive tets around its centre
    /// (cell data repeated, point data averaged) that conform with the hex.
    #[test]
    fn polyhedra_are_split_into_tets_from_their_face_stream() {
        let faces = "6 4 0 3 2 1 4 4 5 6 7 4 0 1 5 4 4 1 2 6 5 4 2 3 7 6 4 3 0 4 7";
        let text = format!(
            r#"<?xml version="1.0"?>
<VTKFile type="UnstructuredGrid" version="1.0" byte_order="LittleEndian">
<UnstructuredGrid><Piece NumberOfPoints="12" NumberOfCells="2">
<PointData><DataArray type="Float64" Name="s" format="ascii">0 1 2 3 4 5 6 7 8 9 10 11</DataArray></PointData>
<CellData><DataArray type="Int32" Name="id" format="ascii">7 9</DataArray></CellData>
<Points><DataArray type="Float64" NumberOfComponents="3" format="ascii">
0 0 0 1 0 0 1 1 0 0 1 0 0 0 1 1 0 1 1 1 1 0 1 1 2 0 0 2 1 0 2 0 1 2 1 1</DataArray></Points>
<Cells><DataArray type="Int64" Name="connectivity" format="ascii">0 1 2 3 4 5 6 7 1 8 9 2 5 10 11 6</DataArray>
<DataArray type="Int64" Name="offsets" format="ascii">8 16</DataArray>
<DataArray type="UInt8" Name="types" format="ascii">42 12</DataArray>
<DataArray type="Int64" Name="faces" format="ascii">{faces}</DataArray>
<DataArray type="Int64" Name="faceoffsets" format="ascii">31 -1</DataArray></Cells>
</Piece></UnstructuredGrid></VTKFile>"#
        );
        let m = read(text.as_bytes()).unwrap();
        let Block::Unstructured(c) = &m.blocks[0] else { panic!("unstructured") };
        assert_eq!(c.len(), 13);
        assert_eq!(m.cell_fields[0].values, [vec![7.0; 12], vec![9.0]].concat());
        assert_eq!(m.points.len(), 13);
        assert_eq!(m.points[12], [0.5, 0.5, 0.5]);
        assert_eq!(m.point_fields[0].values[12], 3.5);
        assert!(m.notes.iter().any(|n| n.contains("split 1 polyhedra")), "{:?}", m.notes);
        let (t, report) = tet_mesh::tetrahedralize(&m, &Default::default(), &mut |_| {}).unwrap();
        assert!(!report.findings.iter().any(|f| matches!(f, tet_mesh::Finding::ReorientedTets { .. })));
        let adj = tet_mesh::build_adjacency(&t.points, &t.tets).unwrap();
        // 12 + 6 tets; the boundary of the 2 × 1 × 1 box: 10 unit squares.
        assert_eq!((t.tets.len(), adj.boundary_faces.len(), adj.convex), (18, 20, true));
        // A broken stream is an error naming the cell.
        let bad = text.replace(faces, "6 4 0 3 2 1 4 4 5 6 7 4 0 1 5 4 4 1 2 6 5 4 2 3 7 6 4 3 0 4 70");
        let e = read(bad.as_bytes()).unwrap_err();
        assert!(e.message.contains("polyhedron cell 0: face 5 refers to a point outside"), "{e}");
    }

    #[test]
    fn unknown_cell_type_names_cell_and_id() {
        let text = tiny_vtu("10 10 99", "4 8 12", "0 1 2 3 4 5 6 7 1 2 3 4", "1 2 3");
        let e = read(text.as_bytes()).unwrap_err();
        assert!(e.message.contains("cell 2") && e.message.contains("99"), "{e}");
    }

    #[test]
    fn bad_point_reference_and_short_offsets_are_errors() {
        let text = tiny_vtu("10 10 10", "4 8 12", "0 1 2 3 4 5 6 7 1 2 3 10", "1 2 3");
        let e = read(text.as_bytes()).unwrap_err();
        assert!(e.message.contains("point 10"), "{e}");
        let text = tiny_vtu("10 10 10", "4 8 13", "0 1 2 3 4 5 6 7 1 2 3 4", "1 2 3");
        assert!(read(text.as_bytes()).is_err());
        let text = tiny_vtu("10 10 10", "4 8 12", "0 1 2 3 4 5 6 7 1 2 3 4", "1 2");
        let e = read(text.as_bytes()).unwrap_err();
        assert!(e.message.contains("expected 3"), "{e}");
        assert!(matches!(e.at, Location::Line(_)));
    }

    fn zlib_header(words: &[u64]) -> Vec<u8> {
        words.iter().flat_map(|w| (*w as u32).to_le_bytes()).collect()
    }

    fn appended_file(payload: &[u8], ty: &str, n: usize, compressed: bool) -> Vec<u8> {
        let comp = if compressed { r#" compressor="vtkZLibDataCompressor""# } else { "" };
        let mut f = format!(
            r#"<VTKFile type="ImageData" byte_order="LittleEndian"{comp}>
<ImageData WholeExtent="0 {m} 0 0 0 0" Origin="0 0 0" Spacing="1 1 1"><Piece Extent="0 {m} 0 0 0 0">
<PointData><DataArray type="{ty}" Name="v" format="appended" offset="0"/></PointData>
</Piece></ImageData><AppendedData encoding="raw">_"#,
            m = n - 1
        )
        .into_bytes();
        f.extend_from_slice(payload);
        f.extend_from_slice(b"</AppendedData></VTKFile>");
        f
    }

    #[test]
    fn zlib_bomb_header_is_refused_before_inflating() {
        use std::io::Write;
        let mut enc = flate2::write::ZlibEncoder::new(Vec::new(), flate2::Compression::best());
        enc.write_all(&[0u8; 4000]).unwrap();
        let block = enc.finish().unwrap();
        // Honest: 1 block of 4000 bytes → 4000 UInt8 values.
        let mut payload = zlib_header(&[1, 4000, 4000, block.len() as u64]);
        payload.extend_from_slice(&block);
        let m = read(&appended_file(&payload, "UInt8", 4000, true)).unwrap();
        assert_eq!(m.point_fields[0].values.len(), 4000);
        assert!(m.format.contains("zlib"), "{}", m.format);
        // Header lies small: the stream would inflate past it.
        let mut payload = zlib_header(&[1, 2000, 2000, block.len() as u64]);
        payload.extend_from_slice(&block);
        let e = read(&appended_file(&payload, "UInt8", 2000, true)).unwrap_err();
        assert!(e.message.contains("past"), "{e}");
        // Header claims an absurd size from a few compressed bytes.
        let mut payload = zlib_header(&[1, 4_000_000_000, 4_000_000_000, block.len() as u64]);
        payload.extend_from_slice(&block);
        let e = read(&appended_file(&payload, "UInt8", 4000, true)).unwrap_err();
        assert!(e.message.contains("needs 4000"), "{e}");
    }

    #[test]
    fn unsupported_compressor_is_named() {
        let text = appended_file(&[0; 16], "UInt8", 4, false);
        let text = String::from_utf8_lossy(&text)
            .replace(r#"byte_order="LittleEndian""#, r#"byte_order="LittleEndian" compressor="vtkLZMADataCompressor""#);
        let e = read(text.as_bytes()).unwrap_err();
        assert!(e.message.contains("unsupported compressor vtkLZMADataCompressor"), "{e}");
    }

    #[test]
    fn raw_appended_values_and_huge_declared_sizes() {
        let mut payload = 8u32.to_le_bytes().to_vec();
        payload.extend_from_slice(&[1, 0, 2, 0, 3, 0, 4, 0]);
        let m = read(&appended_file(&payload, "Int16", 4, false)).unwrap();
        assert_eq!(m.point_fields[0].values, vec![1.0, 2.0, 3.0, 4.0]);
        assert_eq!(m.points[3], [3.0, 0.0, 0.0]);
        let mut payload = u32::MAX.to_le_bytes().to_vec();
        payload.extend_from_slice(&[1, 0, 2, 0, 3, 0, 4, 0]);
        let e = read(&appended_file(&payload, "Int16", 4, false)).unwrap_err();
        assert!(e.message.contains("truncated"), "{e}");
        assert!(matches!(e.at, Location::Byte(_)));
    }

    #[test]
    fn huge_image_extent_without_data_is_refused() {
        let text = br#"<VTKFile type="ImageData"><ImageData WholeExtent="0 99999 0 99999 0 99999">
<Piece Extent="0 99999 0 99999 0 99999"></Piece></ImageData></VTKFile>"#;
        assert!(read(text).is_err());
        let text = br#"<VTKFile type="ImageData"><ImageData WholeExtent="0 1 0 1 0 1">
<Piece Extent="0 1 0 1 0 -5"></Piece></ImageData></VTKFile>"#;
        assert!(read(text).is_err());
    }
}
