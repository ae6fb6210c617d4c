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

mod arrays;
mod pieces;

// The tests reach the decoders (the pieces' code is methods of `Ctx`).
#[cfg(test)]
use arrays::*;

/// Deflate cannot expand a block by more than about 1032:1; a header that
/// claims more is hostile (a zip bomb) or corrupt.
pub(crate) const MAX_DEFLATE_RATIO: usize = 1032;

/// Points of an ImageData or RectilinearGrid piece are not stored in the
/// file, so their count is bounded by nothing the file holds. Above this
/// many, the piece must carry a point or cell array of that size (which the
/// file does have to hold) before the points are materialized.
pub(crate) const MAX_UNBACKED_GRID_POINTS: usize = 1 << 20;

/// Base64 as VTK writes it: standard alphabet, padded, but a header and the
/// data after it may each carry their own padding, so decoding goes segment
/// by segment (see [`decode_base64`]).
pub(crate) const BASE64: GeneralPurpose = GeneralPurpose::new(
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
/// (polyhedra without a face stream, Lagrange/Bézier pyramids, pentagonal
/// and hexagonal prisms) are skipped with a note counting them, and their
/// cell-data tuples dropped so cell fields stay aligned. Quadratic cells
/// that [`CellType`] lists, and Lagrange tetrahedra, hexahedra and wedges
/// (their orders from the `HigherOrderDegrees` cell array the `<CellData>`
/// names, else from their node counts: [`CellType::from_vtk`]), keep their
/// nodes (cut at them) — every VTK quadratic volume cell is listed.
/// Bézier tetrahedra, hexahedra and wedges (ids 78–80; rational where
/// `<PointData>` names a `RationalWeights` array) are evaluated at their
/// lattice points, positions and every point array, and cut there as the
/// Lagrange cells of their orders ([`tet_mesh::bezier`]), with a note. An
/// unknown cell type id is an error. Point
/// and cell arrays
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
    if stats.reduced_higher_order > 0 {
        let also = mesh.reduce_to_corners();
        if also > 0 {
            notes.push(format!(
                "reduced {also} more quadratic cells to their corners as well, so that they conform with those"
            ));
        }
    }
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
pub(crate) fn append_piece(mesh: &mut SourceMesh, piece: SourceMesh, first: bool, label: &str) -> Result<(), String> {
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

pub(crate) fn merge_fields(
    acc: &mut Vec<Field>,
    mut more: Vec<Field>,
    kind: &str,
    label: &str,
    notes: &mut Vec<String>,
) {
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
pub(crate) enum Kind {
    Unstructured,
    Structured,
    Image,
    Rectilinear,
}

/// What the reader skipped or changed, summed over all pieces.
#[derive(Default)]
pub(crate) struct Stats {
    pub(crate) reduced_higher_order: usize,
    pub(crate) skipped_without_volume: usize,
    /// Volume cells tetkit cannot reduce, by VTK type id.
    pub(crate) skipped_unreducible: BTreeMap<u32, usize>,
    pub(crate) skipped_non_numeric: Vec<String>,
    pub(crate) flat_structured_cells: usize,
    /// Polyhedra (id 42) split into tets, the tets and the centre points added.
    pub(crate) split_polyhedra: usize,
    pub(crate) polyhedron_tets: usize,
    pub(crate) polyhedron_points: usize,
    /// Bézier cells evaluated at their lattice (summed over pieces), and
    /// whether any were rational.
    pub(crate) bezier: tet_mesh::BezierReport,
    pub(crate) rational_bezier: bool,
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
        if self.bezier.cells > 0 {
            notes.push(self.bezier.note(self.rational_bezier));
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
pub(crate) struct Element {
    pub(crate) name: String,
    pub(crate) attrs: Vec<(String, String)>,
    pub(crate) children: Vec<usize>,
    pub(crate) text: Vec<Range<usize>>,
    /// Byte offset of the `<` that opens the element.
    pub(crate) pos: usize,
    /// 1-based line of `pos`, counted once while parsing (error messages
    /// must not rescan a large file).
    pub(crate) line: usize,
}

pub(crate) fn line_at(bytes: &[u8], pos: usize) -> Location {
    let end = pos.min(bytes.len());
    Location::Line(bytes[..end].iter().filter(|&&b| b == b'\n').count() + 1)
}

pub(crate) fn find(haystack: &[u8], needle: &[u8], from: usize) -> Option<usize> {
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

pub(crate) fn element_from(e: &BytesStart, pos: usize, bytes: &[u8]) -> Result<Element, FormatError> {
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
pub(crate) fn parse_tree(xml: &[u8], bytes: &[u8]) -> Result<Vec<Element>, FormatError> {
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
pub(crate) enum Compressor {
    None,
    Zlib,
}

pub(crate) struct Appended<'a> {
    /// The bytes after the `_` marker (to the end of the file).
    pub(crate) data: &'a [u8],
    /// File offset of `data[0]`.
    pub(crate) base: usize,
    pub(crate) base64: bool,
    /// Sorted distinct `offset` attributes of appended arrays: in base64
    /// encoding an array ends where the next one starts.
    pub(crate) offsets: Vec<usize>,
}

// Bits of `Ctx::used`, for the format summary.
pub(crate) const USED_ASCII: u8 = 1;
pub(crate) const USED_BINARY: u8 = 2;
pub(crate) const USED_RAW: u8 = 4;
pub(crate) const USED_APPENDED_BASE64: u8 = 8;
pub(crate) const USED_ZLIB: u8 = 16;

pub(crate) struct Ctx<'a> {
    pub(crate) bytes: &'a [u8],
    pub(crate) els: Vec<Element>,
    pub(crate) endian: Endian,
    /// 4 (UInt32) or 8 (UInt64): size of block headers.
    pub(crate) header_size: usize,
    pub(crate) compressor: Result<Compressor, String>,
    pub(crate) appended: Option<Appended<'a>>,
    pub(crate) used: Cell<u8>,
}

/// Where an array's values live.
pub(crate) enum Payload<'x> {
    Ascii(&'x [Range<usize>]),
    Binary(&'x [u8], Location),
}

pub(crate) enum Unpacked<'b> {
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
    pub(crate) fn new(bytes: &'a [u8]) -> Result<Self, FormatError> {
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

    pub(crate) fn appended_section(bytes: &'a [u8], at: usize, els: &[Element]) -> Result<Appended<'a>, FormatError> {
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

    pub(crate) fn attr(&self, el: usize, key: &str) -> Option<&str> {
        self.els.get(el)?.attrs.iter().find(|(k, _)| k == key).map(|(_, v)| v.as_str())
    }

    pub(crate) fn name(&self, el: usize) -> &str {
        self.els.get(el).map_or("", |e| e.name.as_str())
    }

    pub(crate) fn err_at(&self, el: usize, message: impl Into<String>) -> FormatError {
        FormatError::new(Location::Line(self.els.get(el).map_or(1, |e| e.line)), message)
    }

    pub(crate) fn children<'s>(&'s self, el: usize, name: &'s str) -> impl Iterator<Item = usize> + 's {
        self.els
            .get(el)
            .map(|e| e.children.as_slice())
            .unwrap_or(&[])
            .iter()
            .copied()
            .filter(move |&c| self.name(c) == name)
    }

    pub(crate) fn child(&self, el: usize, name: &str) -> Option<usize> {
        self.children(el, name).next()
    }

    /// A DataArray child whose Name is `name`.
    pub(crate) fn named_array(&self, el: usize, name: &str) -> Option<usize> {
        self.children(el, "DataArray").find(|&c| self.attr(c, "Name") == Some(name))
    }

    pub(crate) fn layout_summary(&self) -> String {
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

    pub(crate) fn mark(&self, bit: u8) {
        self.used.set(self.used.get() | bit);
    }

    // -- counts and attributes ------------------------------------------------

    pub(crate) fn count_attr(&self, el: usize, key: &str) -> Result<usize, FormatError> {
        let v =
            self.attr(el, key).ok_or_else(|| self.err_at(el, format!("<{}> has no {key} attribute", self.name(el))))?;
        v.trim().parse::<usize>().map_err(|_| self.err_at(el, format!("{key}=\"{v}\" is not a count")))
    }

    pub(crate) fn floats_attr<const N: usize>(
        &self,
        el: usize,
        key: &str,
        default: [f64; N],
    ) -> Result<[f64; N], FormatError> {
        let Some(v) = self.attr(el, key) else {
            return Ok(default);
        };
        let vals: Vec<f64> = v.split_ascii_whitespace().filter_map(parse_f64).collect();
        vals.as_slice().try_into().map_err(|_| self.err_at(el, format!("{key}=\"{v}\" must be {N} numbers")))
    }

    /// Point counts along i, j, k of an `Extent` (or `WholeExtent`).
    pub(crate) fn extent_dims(&self, el: usize, key: &str) -> Result<[usize; 3], FormatError> {
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

    pub(crate) fn extent_min(&self, el: usize, key: &str) -> [f64; 3] {
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

    pub(crate) fn array_type(&self, el: usize) -> Result<Option<ScalarType>, FormatError> {
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

    pub(crate) fn num_components(&self, el: usize) -> Result<usize, FormatError> {
        match self.attr(el, "NumberOfComponents") {
            None => Ok(1),
            Some(v) => match v.trim().parse::<usize>() {
                Ok(n) if n >= 1 => Ok(n),
                _ => Err(self.err_at(el, format!("NumberOfComponents=\"{v}\" must be a positive count"))),
            },
        }
    }
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
    fn mixed_cells_skip_surfaces_keep_quadratic_tets_and_reduce_other_quadratics() {
        // tet, triangle (skipped), quadratic tet (kept whole, to be split at
        // its ten nodes).
        let text = tiny_vtu("10 5 24", "4 7 17", "0 1 2 3  0 1 2  0 1 2 3 4 5 6 7 8 9", "7 8 9");
        let m = read(text.as_bytes()).unwrap();
        assert_eq!(m.num_cells(), 2);
        let Block::Unstructured(cells) = &m.blocks[0] else { panic!() };
        assert_eq!(cells.types[1], CellType::QuadraticTetra);
        assert_eq!(cells.nodes(1), &[0, 1, 2, 3, 4, 5, 6, 7, 8, 9]);
        assert_eq!(m.cell_fields[0].values, vec![7.0, 9.0]);
        assert_eq!(m.point_fields.len(), 1, "String array skipped");
        assert!(!m.notes.iter().any(|n| n.contains("higher-order")), "{:?}", m.notes);
        assert!(m.notes.iter().any(|n| n.contains("skipped 1 cells without volume")), "{:?}", m.notes);
        assert!(m.format.contains("ascii"), "{}", m.format);
        // A 12-node wedge (VTK_QUADRATIC_LINEAR_WEDGE) is kept whole too.
        let text = tiny_vtu("24 5 31", "10 13 25", "0 1 2 3 4 5 6 7 8 9  0 1 2  0 1 2 3 4 5 6 7 8 9 0 1", "7 8 9");
        let m = read(text.as_bytes()).unwrap();
        let Block::Unstructured(cells) = &m.blocks[0] else { panic!() };
        assert_eq!(cells.types, vec![CellType::QuadraticTetra, CellType::QuadraticLinearWedge]);
        assert!(!m.notes.iter().any(|n| n.contains("higher-order")), "{:?}", m.notes);
        // A Bézier tetrahedron (id 78) is evaluated at its lattice: its
        // control points here sit on the lattice (the edge midpoints), so
        // the new points are where they are (Bernstein polynomials
        // reproduce linear maps), while the point scalar, whose control
        // values are not linear, is the Bézier value there: on edge 0-1,
        // s₀/4 + s₄/2 + s₁/4 = 2.25. The quadratic tet beside it, which
        // names the same points as its own nodes, stays whole and keeps
        // them: the Bézier tet gets six new points.
        let text = tiny_vtu("24 5 78", "10 13 23", "0 1 2 3 4 5 6 7 8 9  0 1 2  0 1 2 3 4 5 6 7 8 9", "7 8 9");
        let m = read(text.as_bytes()).unwrap();
        let Block::Unstructured(cells) = &m.blocks[0] else { panic!() };
        assert_eq!(cells.types, vec![CellType::QuadraticTetra, CellType::LagrangeTetra(2)]);
        assert_eq!(cells.nodes(1), &[0, 1, 2, 3, 10, 11, 12, 13, 14, 15]);
        assert_eq!(m.points.len(), 16);
        for i in 4..10 {
            assert!((0..3).all(|a| (m.points[i + 6][a] - m.points[i][a]).abs() < 1e-15), "node {i}");
        }
        assert!((m.point_fields[0].values[10] - 2.25).abs() < 1e-12, "{:?}", m.point_fields[0].values);
        assert!(!m.notes.iter().any(|n| n.contains("higher-order")), "{:?}", m.notes);
        assert!(
            m.notes.iter().any(|n| n.contains("evaluated 1 Bézier cells") && n.contains("6 points added")),
            "{:?}",
            m.notes
        );
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
