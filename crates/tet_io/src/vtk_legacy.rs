//! Legacy VTK (`.vtk`) reader: file versions 1.0 to 5.1, ASCII and BINARY.
//!
//! Reads UNSTRUCTURED_GRID (classic `CELLS n size` layout and the 5.x
//! `OFFSETS`/`CONNECTIVITY` layout), STRUCTURED_GRID, STRUCTURED_POINTS and
//! RECTILINEAR_GRID, with their POINT_DATA and CELL_DATA attributes.
//!
//! The layout rules follow VTK's own `vtkDataReader`, which is the only
//! specification the format has:
//! - Keywords and headers are whitespace-separated text, case-insensitive.
//! - A binary block starts after the newline that ends its header line and
//!   is big-endian; a newline usually follows it before the next keyword.
//! - In binary, `vtkIdType` arrays are 4-byte ints (VTK writes them as `int`)
//!   and `long` is 8 bytes (VTK on LP64 platforms); a `long` block that only
//!   fits as 4-byte values (written on Windows) is read as such, with a note.
//! - Array names escape spaces and other bytes as `%XX`.
//! - `METADATA` (component names, information keys) may follow any array and
//!   runs to the next empty line; it is skipped.

use crate::cursor::{clip, decode_to_f64, parse_f64, ByteCursor, Endian, ScalarType, TextCursor};
use crate::{FormatError, Location};
use tet_mesh::{Block, CellType, Cells, Field, SourceMesh};

/// Reads a legacy VTK file held in memory.
///
/// Volume cells are kept in VTK node order; quadratic cells that
/// `CellType` lists and Lagrange tetrahedra, hexahedra and wedges (their
/// orders from their node counts) keep their nodes (cut at them), Bézier
/// ones are evaluated at their lattice points (polynomial: legacy files
/// carry no rational weights) and cut there ([`tet_mesh::bezier`]), and surface, line and vertex cells are skipped (with their CELL_DATA tuples), each counted in
/// a note. Files without volume
/// cells (POLYDATA, 2D grids, surface-only unstructured grids) are errors.
pub fn read(bytes: &[u8]) -> Result<SourceMesh, FormatError> {
    let mut parser = Parser::start(bytes)?;
    parser.run()?;
    parser.finish()
}

/// Element type of an array as declared in the file.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum ElemType {
    /// Packed bits in binary (most significant bit first), 0/1 in ASCII.
    Bit,
    Num(ScalarType),
    /// C `long`/`unsigned long`, whose binary size depends on the writer's
    /// platform.
    Long {
        signed: bool,
    },
    /// `string`/`utf8_string` arrays; not numeric, skipped.
    Str,
    /// `variant` arrays, which VTK writes as text even in binary files.
    Variant,
}

/// Maps a type name as VTK writes it to the element type, matching the way
/// `vtkDataReader::ReadArray` does (lower-cased, mostly by prefix).
fn elem_type(name: &str) -> Option<ElemType> {
    use ScalarType::*;
    let lower = name.to_ascii_lowercase();
    let s = lower.as_str();
    // Exact spellings of the fixed-width type names (VTK 9 writes the 64-bit
    // ones; the others are accepted for files written by other tools).
    let exact = match s {
        "char" | "signed_char" | "vtktypeint8" => Some(ElemType::Num(I8)),
        "vtktypeuint8" => Some(ElemType::Num(U8)),
        "vtktypeint16" => Some(ElemType::Num(I16)),
        "vtktypeuint16" => Some(ElemType::Num(U16)),
        "vtktypeint32" => Some(ElemType::Num(I32)),
        "vtktypeuint32" => Some(ElemType::Num(U32)),
        "vtktypeint64" => Some(ElemType::Num(I64)),
        "vtktypeuint64" => Some(ElemType::Num(U64)),
        "vtktypefloat32" => Some(ElemType::Num(F32)),
        "vtktypefloat64" => Some(ElemType::Num(F64)),
        _ => None,
    };
    if exact.is_some() {
        return exact;
    }
    let prefixed = [
        ("bit", ElemType::Bit),
        ("unsigned_char", ElemType::Num(U8)),
        ("unsigned_short", ElemType::Num(U16)),
        ("unsigned_int", ElemType::Num(U32)),
        ("unsigned_long", ElemType::Long { signed: false }),
        ("short", ElemType::Num(I16)),
        // VTK writes vtkIdType arrays as 4-byte ints.
        ("vtkidtype", ElemType::Num(I32)),
        ("int", ElemType::Num(I32)),
        ("long", ElemType::Long { signed: true }),
        ("float", ElemType::Num(F32)),
        ("double", ElemType::Num(F64)),
        ("string", ElemType::Str),
        ("utf8_string", ElemType::Str),
        ("variant", ElemType::Variant),
    ];
    prefixed.iter().find(|(p, _)| s.starts_with(p)).map(|&(_, t)| t)
}

/// Decodes VTK's `%XX` escapes in array names (VTK writes spaces as `%20`).
fn decode_name(raw: &str) -> String {
    let b = raw.as_bytes();
    let mut out = Vec::with_capacity(b.len());
    let mut i = 0;
    while i < b.len() {
        if b[i] == b'%' && i + 2 < b.len() {
            let hex = |c: u8| (c as char).to_digit(16);
            if let (Some(h), Some(l)) = (hex(b[i + 1]), hex(b[i + 2])) {
                out.push((h * 16 + l) as u8);
                i += 3;
                continue;
            }
        }
        out.push(b[i]);
        i += 1;
    }
    String::from_utf8_lossy(&out).into_owned()
}

#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum Dataset {
    Unstructured,
    StructuredGrid,
    StructuredPoints,
    Rectilinear,
}

impl Dataset {
    fn name(self) -> &'static str {
        match self {
            Dataset::Unstructured => "UNSTRUCTURED_GRID",
            Dataset::StructuredGrid => "STRUCTURED_GRID",
            Dataset::StructuredPoints => "STRUCTURED_POINTS",
            Dataset::Rectilinear => "RECTILINEAR_GRID",
        }
    }
}

/// Which attribute section the keywords currently belong to.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum Section {
    /// Geometry and topology, before any POINT_DATA or CELL_DATA.
    Dataset,
    Point(usize),
    Cell(usize),
}

/// Cells as the file lists them: cell `c` has nodes
/// `connectivity[offsets[c]..offsets[c + 1]]`, any VTK type.
#[derive(Debug, Default)]
struct RawCells {
    offsets: Vec<usize>,
    connectivity: Vec<u32>,
}

impl RawCells {
    fn len(&self) -> usize {
        self.offsets.len().saturating_sub(1)
    }
}

struct Parser<'a> {
    bytes: &'a [u8],
    t: TextCursor<'a>,
    binary: bool,
    dataset: Dataset,
    section: Section,
    points: Option<Vec<[f64; 3]>>,
    dims: Option<[usize; 3]>,
    origin: [f64; 3],
    spacing: [f64; 3],
    coords: [Option<Vec<f64>>; 3],
    raw_cells: Option<RawCells>,
    cell_types: Option<Vec<u32>>,
    blanking: Option<Vec<bool>>,
    point_fields: Vec<Field>,
    cell_fields: Vec<Field>,
    /// The first SCALARS of POINT_DATA / CELL_DATA: VTK's active scalars.
    active_point_scalar: Option<String>,
    active_cell_scalar: Option<String>,
    /// Declared POINT_DATA / CELL_DATA counts, checked once geometry is known.
    point_data_count: Option<usize>,
    cell_data_count: Option<usize>,
    notes: Vec<String>,
}

/// Every keyword that can start a line after a data block.
const KEYWORDS: &[&str] = &[
    "POINTS",
    "CELLS",
    "CELL_TYPES",
    "OFFSETS",
    "CONNECTIVITY",
    "DIMENSIONS",
    "ORIGIN",
    "SPACING",
    "ASPECT_RATIO",
    "X_COORDINATES",
    "Y_COORDINATES",
    "Z_COORDINATES",
    "BLANKING",
    "POINT_DATA",
    "CELL_DATA",
    "SCALARS",
    "VECTORS",
    "NORMALS",
    "TENSORS",
    "TENSORS6",
    "TEXTURE_COORDINATES",
    "COLOR_SCALARS",
    "LOOKUP_TABLE",
    "FIELD",
    "GLOBAL_IDS",
    "PEDIGREE_IDS",
    "EDGE_FLAGS",
    "METADATA",
    "NULL_ARRAY",
];

/// A structured points or rectilinear grid has no point data in the file, so
/// its point count is bounded by this many per input byte (a `bit` array
/// holds 8 values per byte) plus a small allowance, to keep a hostile
/// `DIMENSIONS` line from allocating without limit.
const IMPLICIT_POINTS_PER_BYTE: usize = 8;
const IMPLICIT_POINTS_ALLOWANCE: usize = 1 << 20;

impl<'a> Parser<'a> {
    /// Reads the header: version line, title line, ASCII/BINARY, DATASET.
    fn start(bytes: &'a [u8]) -> Result<Self, FormatError> {
        let mut t = TextCursor::new(bytes);
        let first = t.line_str().ok_or_else(|| FormatError::new(Location::Line(1), "empty file"))?;
        const PREFIX: &str = "# vtk datafile version";
        let head = first.trim_start();
        let ok_prefix = head.len() >= PREFIX.len()
            && head.is_char_boundary(PREFIX.len())
            && head[..PREFIX.len()].eq_ignore_ascii_case(PREFIX);
        if !ok_prefix {
            return Err(FormatError::new(
                Location::Line(1),
                format!(
                    "not a legacy VTK file: the first line should start with '# vtk DataFile Version', found '{}'",
                    clip(first)
                ),
            ));
        }
        let mut notes = Vec::new();
        let version = head[PREFIX.len()..].trim();
        let parsed = version.split_once('.').and_then(|(maj, min)| {
            let minor: String = min.chars().take_while(|c| c.is_ascii_digit()).collect();
            Some((maj.trim().parse::<u32>().ok()?, minor.parse::<u32>().ok()?))
        });
        match parsed {
            Some((major, minor)) if (major, minor) > (5, 1) => notes.push(format!(
                "file version {major}.{minor} is newer than 5.1, the newest this reader knows; read as 5.1"
            )),
            Some(_) => {}
            None => notes.push(format!("cannot parse the file version '{}'", clip(version))),
        }
        // The title line is free text (possibly empty).
        if t.line_str().is_none() {
            return Err(FormatError::new(t.location(), "unexpected end of file after the version line"));
        }
        let mode_line = t.line();
        let mode = t
            .token()
            .ok_or_else(|| FormatError::new(t.location(), "unexpected end of file, expected ASCII or BINARY"))?;
        let binary = if mode.to_ascii_lowercase().starts_with("ascii") {
            false
        } else if mode.to_ascii_lowercase().starts_with("binary") {
            true
        } else {
            return Err(FormatError::new(
                Location::Line(mode_line),
                format!("expected ASCII or BINARY on the third line, found '{}'", clip(mode)),
            ));
        };
        let mut parser = Parser {
            bytes,
            t,
            binary,
            dataset: Dataset::Unstructured,
            section: Section::Dataset,
            points: None,
            dims: None,
            origin: [0.0; 3],
            spacing: [1.0; 3],
            coords: [None, None, None],
            raw_cells: None,
            cell_types: None,
            blanking: None,
            point_fields: Vec::new(),
            cell_fields: Vec::new(),
            active_point_scalar: None,
            active_cell_scalar: None,
            point_data_count: None,
            cell_data_count: None,
            notes,
        };
        let kw = parser.token("DATASET")?;
        if !kw.eq_ignore_ascii_case("DATASET") {
            let msg = if kw.eq_ignore_ascii_case("POINT_DATA") || kw.eq_ignore_ascii_case("CELL_DATA") {
                format!("the file has {} but no DATASET: there is no geometry to read", kw.to_ascii_uppercase())
            } else {
                format!("expected DATASET, found '{}'", clip(kw))
            };
            return Err(parser.err(msg));
        }
        let kind = parser.token("dataset type")?;
        parser.dataset = match kind.to_ascii_uppercase().as_str() {
            "UNSTRUCTURED_GRID" => Dataset::Unstructured,
            "STRUCTURED_GRID" => Dataset::StructuredGrid,
            "STRUCTURED_POINTS" => Dataset::StructuredPoints,
            "RECTILINEAR_GRID" => Dataset::Rectilinear,
            "POLYDATA" => {
                return Err(parser.err(
                    "no volume cells: this file holds POLYDATA (vertices, lines, polygons and \
                     triangle strips), which has no volume to render",
                ))
            }
            other => {
                return Err(parser.err(format!(
                    "unsupported dataset type '{}' (expected UNSTRUCTURED_GRID, STRUCTURED_GRID, \
                     STRUCTURED_POINTS or RECTILINEAR_GRID)",
                    clip(other)
                )))
            }
        };
        Ok(parser)
    }

    /// Where the cursor is: a line for ASCII files, a byte offset for binary
    /// ones (line numbers mean little after binary blocks).
    fn here(&self) -> Location {
        if self.binary {
            Location::Byte(self.t.offset() as u64)
        } else {
            self.t.location()
        }
    }

    fn err(&self, message: impl Into<String>) -> FormatError {
        FormatError::new(self.here(), message)
    }

    fn token(&mut self, what: &str) -> Result<&'a str, FormatError> {
        match self.t.token() {
            Some(tok) => Ok(tok),
            None => Err(self.err(format!("unexpected end of file, expected {what}"))),
        }
    }

    /// Value `i` of `count` in an ASCII data block.
    fn data_token(&mut self, i: usize, count: usize, what: &str) -> Result<&'a str, FormatError> {
        match self.t.token() {
            Some(tok) => Ok(tok),
            None => Err(self.err(format!("unexpected end of file in {what}: found {i} of {count} values"))),
        }
    }

    /// A non-negative count as written in a header.
    fn count(&mut self, what: &str) -> Result<usize, FormatError> {
        let tok = self.token(what)?;
        match tok.parse::<i64>() {
            Ok(v) if v < 0 => Err(self.err(format!("{what} is negative ({v})"))),
            Ok(v) => usize::try_from(v).map_err(|_| self.err(format!("{what} {v} is too large"))),
            Err(_) => Err(self.err(format!("expected {what}, found '{}'", clip(tok)))),
        }
    }

    fn real(&mut self, what: &str) -> Result<f64, FormatError> {
        let tok = self.token(what)?;
        parse_f64(tok).ok_or_else(|| self.err(format!("expected {what}, found '{}'", clip(tok))))
    }

    /// The next keyword, skipping METADATA blocks; `None` at the end.
    fn keyword(&mut self) -> Result<Option<&'a str>, FormatError> {
        loop {
            let Some(tok) = self.t.token() else {
                return Ok(None);
            };
            if tok.eq_ignore_ascii_case("METADATA") {
                // Component names and information keys, one per line, up to
                // an empty line (or the end of the file).
                self.t.line_str();
                while let Some(line) = self.t.line_str() {
                    if line.trim().is_empty() {
                        break;
                    }
                }
                continue;
            }
            return Ok(Some(tok));
        }
    }

    /// True when the current line holds another token before its newline.
    fn more_on_line(&self) -> bool {
        let rest = self.t.rest();
        let end = rest.iter().position(|&b| b == b'\n').unwrap_or(rest.len());
        rest[..end].iter().any(|b| !b.is_ascii_whitespace())
    }

    /// True when the next token (possibly on a later line) is `word`.
    fn next_token_is(&self, word: &str) -> bool {
        let mut peek = self.t.clone();
        peek.token().is_some_and(|tok| tok.eq_ignore_ascii_case(word))
    }

    /// Consumes the rest of the header line, newline included; binary data
    /// starts right after it (VTK's `getline` before every binary read).
    fn begin_binary(&mut self, what: &str) -> Result<(), FormatError> {
        let rest = self.t.rest();
        match rest.iter().position(|&b| b == b'\n') {
            Some(nl) => {
                self.t.advance(nl + 1);
                Ok(())
            }
            None => Err(self.err(format!("truncated {what}: the file ends before its binary data"))),
        }
    }

    /// Takes `count` binary items of `size` bytes after the header line.
    fn binary_block(&mut self, count: usize, size: usize, what: &str) -> Result<&'a [u8], FormatError> {
        if count == 0 {
            return Ok(&[]);
        }
        self.begin_binary(what)?;
        let mut cursor = ByteCursor::with_base(self.t.rest(), self.t.offset() as u64);
        let raw = cursor.take_array(count, size, what)?;
        self.t.advance(raw.len());
        Ok(raw)
    }

    /// True when the cursor sits where a binary block should end: at the end
    /// of the file, or at a newline followed by a line that starts with a
    /// keyword or is a FIELD array header (`name nComp nTuples type`).
    fn at_section_boundary(&self) -> bool {
        let rest = self.t.rest();
        let start = rest.iter().position(|b| !b.is_ascii_whitespace()).unwrap_or(rest.len());
        if start == rest.len() {
            return true;
        }
        if !rest[..start].contains(&b'\n') {
            return false;
        }
        let line = &rest[start..];
        let line = &line[..line.iter().position(|&b| b == b'\n').unwrap_or(line.len())];
        let Ok(line) = std::str::from_utf8(line) else {
            return false;
        };
        let words: Vec<&str> = line.split_ascii_whitespace().take(5).collect();
        let Some(first) = words.first() else {
            return false;
        };
        let upper = first.to_ascii_uppercase();
        KEYWORDS.contains(&upper.as_str())
            || (words.len() == 4
                && words[1].parse::<u64>().is_ok()
                && words[2].parse::<u64>().is_ok()
                && elem_type(words[3]).is_some())
    }

    /// Reads `count` values declared as `type_name`, as f64. Returns `None`
    /// (having skipped the data) for string arrays.
    fn read_values(&mut self, type_name: &str, count: usize, what: &str) -> Result<Option<Vec<f64>>, FormatError> {
        let ty =
            elem_type(type_name).ok_or_else(|| self.err(format!("{what}: unknown data type '{}'", clip(type_name))))?;
        match ty {
            ElemType::Str => {
                self.skip_strings(count, what)?;
                Ok(None)
            }
            ElemType::Variant => Err(self.err(format!("{what}: variant arrays are not supported"))),
            _ if !self.binary => self.ascii_values(ty, count, what).map(Some),
            ElemType::Bit => {
                let nbytes = count.div_ceil(8);
                let raw = self.binary_block(nbytes, 1, what)?;
                let bit = |i: usize| raw.get(i / 8).map_or(0.0, |&b| f64::from((b >> (7 - i % 8)) & 1));
                Ok(Some((0..count).map(bit).collect()))
            }
            ElemType::Num(scalar) => {
                let raw = self.binary_block(count, scalar.size(), what)?;
                let mut out = Vec::new();
                decode_to_f64(raw, scalar, Endian::Big, &mut out);
                Ok(Some(out))
            }
            ElemType::Long { signed } => self.binary_long(signed, count, what).map(Some),
        }
    }

    fn ascii_values(&mut self, ty: ElemType, count: usize, what: &str) -> Result<Vec<f64>, FormatError> {
        // Each value takes at least two bytes (digit and separator), so the
        // input bounds the allocation whatever the declared count.
        let mut out = Vec::with_capacity(count.min(self.t.rest().len() / 2 + 1));
        for i in 0..count {
            let tok = self.data_token(i, count, what)?;
            let v =
                parse_f64(tok).ok_or_else(|| self.err(format!("{what}: expected a number, found '{}'", clip(tok))))?;
            out.push(if ty == ElemType::Bit { f64::from(u8::from(v != 0.0)) } else { v });
        }
        Ok(out)
    }

    /// Binary `long`: 8 bytes as VTK writes it on LP64 platforms; if only 4
    /// bytes per value leave the cursor at a keyword (or the end), the file
    /// came from a platform with a 4-byte `long` (Windows).
    fn binary_long(&mut self, signed: bool, count: usize, what: &str) -> Result<Vec<f64>, FormatError> {
        let (wide, narrow) =
            if signed { (ScalarType::I64, ScalarType::I32) } else { (ScalarType::U64, ScalarType::U32) };
        let saved = self.t.clone();
        let as_wide = self.binary_block(count, 8, what);
        if as_wide.is_err() || !self.at_section_boundary() {
            let after_wide = std::mem::replace(&mut self.t, saved);
            if let Ok(raw) = self.binary_block(count, 4, what) {
                if self.at_section_boundary() {
                    self.notes.push(format!("{what}: binary 'long' values read as 4-byte integers"));
                    let mut out = Vec::new();
                    decode_to_f64(raw, narrow, Endian::Big, &mut out);
                    return Ok(out);
                }
            }
            self.t = after_wide;
        }
        let raw = as_wide?;
        let mut out = Vec::new();
        decode_to_f64(raw, wide, Endian::Big, &mut out);
        Ok(out)
    }

    /// Skips `count` strings: one line each in ASCII, length-prefixed in
    /// binary (VTK's 1/2/4/8-byte headers tagged by the top two bits).
    fn skip_strings(&mut self, count: usize, what: &str) -> Result<(), FormatError> {
        if count == 0 {
            return Ok(());
        }
        if !self.binary {
            self.t.line_str();
            for _ in 0..count {
                if self.t.line_str().is_none() {
                    return Err(self.err(format!("truncated {what}: the file ends inside a string array")));
                }
            }
            return Ok(());
        }
        self.begin_binary(what)?;
        let mut cursor = ByteCursor::with_base(self.t.rest(), self.t.offset() as u64);
        for _ in 0..count {
            let first = cursor.take(1, what)?[0];
            let len = match first >> 6 {
                3 => u64::from(first & 0x3f),
                2 => u64::from(u16::from_be_bytes([first, cursor.take(1, what)?[0]]) & 0x3fff),
                1 => {
                    let tail = cursor.take(3, what)?;
                    u64::from(u32::from_be_bytes([first, tail[0], tail[1], tail[2]]) & 0x3fff_ffff)
                }
                _ => {
                    let tail = cursor.take(7, what)?;
                    let mut b = [first; 8];
                    b[1..].copy_from_slice(tail);
                    u64::from_be_bytes(b)
                }
            };
            let len = usize::try_from(len).unwrap_or(usize::MAX);
            cursor.take(len, what)?;
        }
        let used = self.t.rest().len() - cursor.remaining();
        self.t.advance(used);
        Ok(())
    }

    /// Streams `count` integers declared as `type_name` into `sink`, which
    /// may refuse a value with a message (located at that value).
    fn read_ints(
        &mut self,
        type_name: &str,
        count: usize,
        what: &str,
        mut sink: impl FnMut(i64) -> Result<(), String>,
    ) -> Result<(), FormatError> {
        let ty =
            elem_type(type_name).ok_or_else(|| self.err(format!("{what}: unknown data type '{}'", clip(type_name))))?;
        let scalar = match ty {
            ElemType::Num(s) if !matches!(s, ScalarType::F32 | ScalarType::F64) => s,
            ElemType::Long { signed: true } => ScalarType::I64,
            ElemType::Long { signed: false } => ScalarType::U64,
            _ => return Err(self.err(format!("{what} must have an integer type, not '{}'", clip(type_name)))),
        };
        if !self.binary {
            for i in 0..count {
                let tok = self.data_token(i, count, what)?;
                let v = tok
                    .parse::<i64>()
                    .map_err(|_| self.err(format!("{what}: expected an integer, found '{}'", clip(tok))))?;
                sink(v).map_err(|m| self.err(format!("{what}: {m}")))?;
            }
            return Ok(());
        }
        let size = scalar.size();
        if count > 0 {
            self.begin_binary(what)?;
        }
        let start = self.t.offset();
        let mut cursor = ByteCursor::with_base(self.t.rest(), start as u64);
        let raw = cursor.take_array(count, size, what)?;
        for (i, ch) in raw.chunks_exact(size).enumerate() {
            let v = match scalar {
                ScalarType::I8 => i64::from(ch[0] as i8),
                ScalarType::U8 => i64::from(ch[0]),
                ScalarType::I16 => i64::from(i16::from_be_bytes([ch[0], ch[1]])),
                ScalarType::U16 => i64::from(u16::from_be_bytes([ch[0], ch[1]])),
                ScalarType::I32 => i64::from(i32::from_be_bytes([ch[0], ch[1], ch[2], ch[3]])),
                ScalarType::U32 => i64::from(u32::from_be_bytes([ch[0], ch[1], ch[2], ch[3]])),
                _ => {
                    let b: [u8; 8] = ch.try_into().unwrap_or([0; 8]);
                    if scalar == ScalarType::U64 {
                        i64::try_from(u64::from_be_bytes(b)).unwrap_or(i64::MAX)
                    } else {
                        i64::from_be_bytes(b)
                    }
                }
            };
            sink(v).map_err(|m| FormatError::new(Location::Byte((start + i * size) as u64), format!("{what}: {m}")))?;
        }
        self.t.advance(raw.len());
        Ok(())
    }

    fn run(&mut self) -> Result<(), FormatError> {
        while let Some(kw) = self.keyword()? {
            let upper = kw.to_ascii_uppercase();
            match (self.section, upper.as_str()) {
                (_, "POINT_DATA") => {
                    let n = self.count("POINT_DATA count")?;
                    self.point_data_count = Some(n);
                    self.section = Section::Point(n);
                }
                (_, "CELL_DATA") => {
                    let n = self.count("CELL_DATA count")?;
                    self.cell_data_count = Some(n);
                    self.section = Section::Cell(n);
                }
                (Section::Dataset, "FIELD") => self.read_field(None)?,
                (Section::Dataset, _) => self.read_geometry(&upper)?,
                (Section::Point(n), _) => self.read_attribute(&upper, n, true)?,
                (Section::Cell(n), _) => self.read_attribute(&upper, n, false)?,
            }
        }
        Ok(())
    }

    fn unexpected(&self, kw: &str) -> FormatError {
        self.err(format!("unexpected keyword '{}' in a {} dataset", clip(kw), self.dataset.name()))
    }

    fn read_geometry(&mut self, kw: &str) -> Result<(), FormatError> {
        let ds = self.dataset;
        match kw {
            "POINTS" if matches!(ds, Dataset::Unstructured | Dataset::StructuredGrid) => {
                let n = self.count("point count")?;
                let ty = self.token("point data type")?;
                let count = n.checked_mul(3).ok_or_else(|| self.err(format!("point count {n} is too large")))?;
                let flat = self
                    .read_values(ty, count, "POINTS")?
                    .ok_or_else(|| self.err("POINTS cannot be a string array"))?;
                self.points = Some(flat.chunks_exact(3).map(|c| [c[0], c[1], c[2]]).collect());
            }
            "CELLS" if ds == Dataset::Unstructured => self.read_cells()?,
            "CELL_TYPES" if ds == Dataset::Unstructured => {
                let n = self.count("cell type count")?;
                let mut types = Vec::with_capacity(n.min(self.t.rest().len() / 2 + 1));
                self.read_ints("int", n, "CELL_TYPES", |v| {
                    let id = u32::try_from(v).map_err(|_| format!("cell {} has invalid VTK type {v}", types.len()))?;
                    types.push(id);
                    Ok(())
                })?;
                self.cell_types = Some(types);
            }
            "DIMENSIONS" if ds != Dataset::Unstructured => {
                let mut dims = [0usize; 3];
                for d in &mut dims {
                    *d = self.count("DIMENSIONS")?;
                    if *d == 0 {
                        return Err(self.err("DIMENSIONS must be at least 1 along each axis"));
                    }
                }
                dims.iter()
                    .try_fold(1usize, |acc, &d| acc.checked_mul(d))
                    .ok_or_else(|| self.err(format!("DIMENSIONS {dims:?} overflow the point count")))?;
                self.dims = Some(dims);
            }
            "ORIGIN" if ds == Dataset::StructuredPoints => {
                for i in 0..3 {
                    self.origin[i] = self.real("ORIGIN")?;
                }
            }
            "SPACING" | "ASPECT_RATIO" if ds == Dataset::StructuredPoints => {
                for i in 0..3 {
                    self.spacing[i] = self.real(kw)?;
                }
            }
            "X_COORDINATES" | "Y_COORDINATES" | "Z_COORDINATES" if ds == Dataset::Rectilinear => {
                let axis = usize::from(kw.as_bytes()[0] - b'X');
                let n = self.count(&format!("{kw} count"))?;
                let ty = self.token("coordinate data type")?;
                let values =
                    self.read_values(ty, n, kw)?.ok_or_else(|| self.err(format!("{kw} cannot be a string array")))?;
                self.coords[axis] = Some(values);
            }
            "BLANKING" if ds == Dataset::StructuredGrid => {
                let n = self.count("BLANKING count")?;
                let ty = self.token("BLANKING data type")?;
                let values = self
                    .read_values(ty, n, "BLANKING")?
                    .ok_or_else(|| self.err("BLANKING cannot be a string array"))?;
                // VTK: a zero marks a hidden (blanked) point.
                self.blanking = Some(values.iter().map(|&v| v == 0.0).collect());
            }
            _ => return Err(self.unexpected(kw)),
        }
        Ok(())
    }

    /// `CELLS` in either layout: classic `CELLS n size` followed by `size`
    /// ints (a node count, then the nodes, per cell), or the 5.x `CELLS
    /// nOffsets nConn` followed by OFFSETS and CONNECTIVITY arrays.
    fn read_cells(&mut self) -> Result<(), FormatError> {
        let first = self.count("cell count")?;
        let second = self.count("cell list size")?;
        let rest_len = self.t.rest().len();
        let mut raw = RawCells::default();
        if self.next_token_is("OFFSETS") {
            self.token("OFFSETS")?;
            let ty = self.token("OFFSETS data type")?;
            raw.offsets.reserve(first.min(rest_len / 2 + 1));
            let offsets = &mut raw.offsets;
            self.read_ints(ty, first, "OFFSETS", |v| {
                let prev = offsets.last().copied();
                let off = usize::try_from(v).map_err(|_| format!("offset {} is negative ({v})", offsets.len()))?;
                match prev {
                    None if off != 0 => return Err(format!("the first offset must be 0, found {off}")),
                    Some(p) if off < p => {
                        return Err(format!("offset {} ({off}) is below the previous one ({p})", offsets.len()))
                    }
                    _ if off > second => {
                        return Err(format!("offset {} ({off}) exceeds the connectivity size {second}", offsets.len()))
                    }
                    _ => {}
                }
                offsets.push(off);
                Ok(())
            })?;
            if raw.offsets.last().is_some_and(|&last| last != second) {
                return Err(self.err(format!(
                    "the last offset ({}) does not match the connectivity size {second}",
                    raw.offsets.last().copied().unwrap_or(0)
                )));
            }
            if !self.next_token_is("CONNECTIVITY") {
                return Err(self.err("expected CONNECTIVITY after the OFFSETS array"));
            }
            self.token("CONNECTIVITY")?;
            let ty = self.token("CONNECTIVITY data type")?;
            raw.connectivity.reserve(second.min(self.t.rest().len() / 2 + 1));
            let conn = &mut raw.connectivity;
            self.read_ints(ty, second, "CONNECTIVITY", |v| {
                let id =
                    u32::try_from(v).map_err(|_| format!("entry {} is not a valid point index ({v})", conn.len()))?;
                conn.push(id);
                Ok(())
            })?;
            if raw.offsets.is_empty() {
                raw.offsets.push(0);
            }
        } else {
            let (ncells, size) = (first, second);
            raw.offsets.reserve(ncells.min(rest_len / 2 + 1) + 1);
            raw.offsets.push(0);
            raw.connectivity.reserve(size.min(rest_len / 2 + 1));
            // Remaining nodes of the cell being read; `None` between cells.
            let mut pending: Option<usize> = None;
            let mut consumed = 0usize;
            let (offsets, conn) = (&mut raw.offsets, &mut raw.connectivity);
            self.read_ints("int", size, "CELLS", |v| {
                consumed += 1;
                match pending {
                    None => {
                        if offsets.len() > ncells {
                            return Err(format!("the list holds more than the declared {ncells} cells"));
                        }
                        let n = usize::try_from(v).ok().filter(|&n| n <= size - consumed).ok_or_else(|| {
                            format!("cell {} declares {v} nodes, more than the list has left", offsets.len() - 1)
                        })?;
                        if n == 0 {
                            offsets.push(conn.len());
                        } else {
                            pending = Some(n);
                        }
                    }
                    Some(left) => {
                        let id = u32::try_from(v)
                            .map_err(|_| format!("cell {} refers to invalid point index {v}", offsets.len() - 1))?;
                        conn.push(id);
                        if left == 1 {
                            offsets.push(conn.len());
                            pending = None;
                        } else {
                            pending = Some(left - 1);
                        }
                    }
                }
                Ok(())
            })?;
            if raw.len() != ncells {
                return Err(self
                    .err(format!("CELLS declares {ncells} cells but its list of {size} values holds {}", raw.len())));
            }
        }
        self.raw_cells = Some(raw);
        Ok(())
    }

    /// Reads one attribute of a POINT_DATA (`is_point`) or CELL_DATA section
    /// of `n` tuples.
    fn read_attribute(&mut self, kw: &str, n: usize, is_point: bool) -> Result<(), FormatError> {
        let (name, ty, comps, what) = match kw {
            "SCALARS" => {
                let name = self.token("SCALARS name")?;
                let ty = self.token("SCALARS data type")?;
                let mut comps = 1;
                if self.more_on_line() {
                    comps = self.count("SCALARS component count")?;
                    if comps == 0 {
                        return Err(self.err("SCALARS component count must be at least 1"));
                    }
                }
                if self.next_token_is("LOOKUP_TABLE") {
                    self.token("LOOKUP_TABLE")?;
                    self.token("lookup table name")?;
                }
                (name, ty, comps, "SCALARS")
            }
            "VECTORS" | "NORMALS" | "TENSORS" | "TENSORS6" | "GLOBAL_IDS" | "PEDIGREE_IDS" | "EDGE_FLAGS" => {
                let name = self.token(&format!("{kw} name"))?;
                let ty = self.token(&format!("{kw} data type"))?;
                let comps = match kw {
                    "VECTORS" | "NORMALS" => 3,
                    "TENSORS" => 9,
                    "TENSORS6" => 6,
                    _ => 1,
                };
                (name, ty, comps, kw)
            }
            "TEXTURE_COORDINATES" => {
                let name = self.token("TEXTURE_COORDINATES name")?;
                let comps = self.count("TEXTURE_COORDINATES dimension")?;
                if !(1..=3).contains(&comps) {
                    return Err(self.err(format!("TEXTURE_COORDINATES dimension must be 1, 2 or 3, found {comps}")));
                }
                let ty = self.token("TEXTURE_COORDINATES data type")?;
                (name, ty, comps, kw)
            }
            "COLOR_SCALARS" => {
                let name = self.token("COLOR_SCALARS name")?;
                let comps = self.count("COLOR_SCALARS component count")?;
                if comps == 0 {
                    return Err(self.err("COLOR_SCALARS component count must be at least 1"));
                }
                // Bytes in binary files; floats in [0, 1] in ASCII files,
                // which VTK turns into bytes as 255·v + 0.5, truncated.
                let ty = if self.binary { "unsigned_char" } else { "float" };
                (name, ty, comps, kw)
            }
            "LOOKUP_TABLE" => {
                self.token("LOOKUP_TABLE name")?;
                let size = self.count("LOOKUP_TABLE size")?;
                let count = size.checked_mul(4).ok_or_else(|| self.err("LOOKUP_TABLE size is too large"))?;
                let ty = if self.binary { "unsigned_char" } else { "float" };
                self.read_values(ty, count, "LOOKUP_TABLE")?;
                return Ok(());
            }
            "FIELD" => return self.read_field(Some((n, is_point))),
            _ => {
                let section = if is_point { "POINT_DATA" } else { "CELL_DATA" };
                return Err(self.err(format!("unknown keyword '{}' in {section}", clip(kw))));
            }
        };
        let name = decode_name(name);
        let count = n
            .checked_mul(comps)
            .ok_or_else(|| self.err(format!("{what} '{name}': {n} tuples × {comps} components overflow")))?;
        let label = format!("{what} '{name}'");
        let Some(mut values) = self.read_values(ty, count, &label)? else {
            self.notes.push(format!("skipped string array {label}"));
            return Ok(());
        };
        if kw == "COLOR_SCALARS" && !self.binary {
            for v in &mut values {
                *v = (255.0 * *v + 0.5).clamp(0.0, 255.0).trunc();
            }
        }
        if kw == "SCALARS" {
            let active = if is_point { &mut self.active_point_scalar } else { &mut self.active_cell_scalar };
            active.get_or_insert_with(|| name.clone());
        }
        self.push_field(Field::new(name, comps, values), is_point);
        Ok(())
    }

    fn push_field(&mut self, field: Field, is_point: bool) {
        if is_point {
            self.point_fields.push(field);
        } else {
            self.cell_fields.push(field);
        }
    }

    /// `FIELD name nArrays` then per array `name nComp nTuples type` and its
    /// data (or `NULL_ARRAY`). `attach` is the section's tuple count and
    /// kind; `None` for dataset-level field data, which is read and dropped.
    fn read_field(&mut self, attach: Option<(usize, bool)>) -> Result<(), FormatError> {
        self.token("FIELD name")?;
        let arrays = self.count("FIELD array count")?;
        for _ in 0..arrays {
            let raw_name = self.token("field array name")?;
            if raw_name == "NULL_ARRAY" {
                continue;
            }
            let name = decode_name(raw_name);
            let comps = self.count(&format!("component count of field array '{name}'"))?;
            let tuples = self.count(&format!("tuple count of field array '{name}'"))?;
            let ty = self.token(&format!("data type of field array '{name}'"))?;
            let count = comps.checked_mul(tuples).ok_or_else(|| {
                self.err(format!("field array '{name}': {tuples} tuples × {comps} components overflow"))
            })?;
            let label = format!("field array '{name}'");
            let values = self.read_values(ty, count, &label)?;
            let Some((n, is_point)) = attach else {
                continue;
            };
            match values {
                None => self.notes.push(format!("skipped string {label}")),
                Some(_) if comps == 0 || tuples != n => {
                    let kind = if is_point { "points" } else { "cells" };
                    self.notes.push(format!("skipped {label}: {tuples} tuples × {comps} components for {n} {kind}"));
                }
                Some(values) => self.push_field(Field::new(name, comps, values), is_point),
            }
        }
        Ok(())
    }

    fn finish(mut self) -> Result<SourceMesh, FormatError> {
        let mut mesh = SourceMesh {
            format: if self.binary { "legacy VTK (BINARY)" } else { "legacy VTK (ASCII)" }.to_string(),
            active_point_scalar: self.active_point_scalar.take(),
            active_cell_scalar: self.active_cell_scalar.take(),
            ..Default::default()
        };
        let whole = |m: String| FormatError::new(Location::Whole, m);
        let ds = self.dataset.name();
        let mut kept: Option<Vec<bool>> = None;
        let mut bezier: Vec<usize> = Vec::new();
        let declared_cells = match self.dataset {
            Dataset::Unstructured => {
                let points = self.points.take().ok_or_else(|| whole("the UNSTRUCTURED_GRID has no POINTS".into()))?;
                let raw = self
                    .raw_cells
                    .take()
                    .ok_or_else(|| whole("no volume cells: the UNSTRUCTURED_GRID has no CELLS section".into()))?;
                let types = self.cell_types.take().ok_or_else(|| whole("CELLS without CELL_TYPES".into()))?;
                if types.len() != raw.len() {
                    return Err(whole(format!("CELL_TYPES lists {} cells but CELLS lists {}", types.len(), raw.len())));
                }
                let (cells, mask) = assemble_cells(&raw, &types, points.len(), &mut bezier, &mut self.notes)?;
                mesh.points = points;
                mesh.blocks.push(Block::Unstructured(cells));
                kept = mask;
                raw.len()
            }
            _ => {
                let dims = self.dims.ok_or_else(|| whole(format!("the {ds} has no DIMENSIONS")))?;
                let npoints = dims[0] * dims[1] * dims[2];
                if dims.iter().any(|&d| d < 2) {
                    return Err(whole(format!(
                        "no volume cells: the {ds} has DIMENSIONS {} {} {}, a grid of fewer than 3 dimensions",
                        dims[0], dims[1], dims[2]
                    )));
                }
                mesh.points = match self.dataset {
                    Dataset::StructuredGrid => {
                        let points =
                            self.points.take().ok_or_else(|| whole("the STRUCTURED_GRID has no POINTS".into()))?;
                        if points.len() != npoints {
                            return Err(whole(format!(
                                "the STRUCTURED_GRID has {} points but DIMENSIONS {} {} {} need {npoints}",
                                points.len(),
                                dims[0],
                                dims[1],
                                dims[2]
                            )));
                        }
                        points
                    }
                    _ => {
                        let limit = self
                            .bytes
                            .len()
                            .saturating_mul(IMPLICIT_POINTS_PER_BYTE)
                            .saturating_add(IMPLICIT_POINTS_ALLOWANCE);
                        if npoints > limit {
                            return Err(whole(format!(
                                "DIMENSIONS {} {} {} declare {npoints} points, more than a file of {} bytes can describe",
                                dims[0],
                                dims[1],
                                dims[2],
                                self.bytes.len()
                            )));
                        }
                        if self.dataset == Dataset::StructuredPoints {
                            uniform_points(dims, self.origin, self.spacing)
                        } else {
                            let mut axes: [&[f64]; 3] = [&[], &[], &[]];
                            for (axis, name) in ["X", "Y", "Z"].iter().enumerate() {
                                let c = self.coords[axis]
                                    .as_deref()
                                    .ok_or_else(|| whole(format!("the RECTILINEAR_GRID has no {name}_COORDINATES")))?;
                                if c.len() != dims[axis] {
                                    return Err(whole(format!(
                                        "{name}_COORDINATES has {} values but DIMENSIONS says {}",
                                        c.len(),
                                        dims[axis]
                                    )));
                                }
                                axes[axis] = c;
                            }
                            rectilinear_points(axes)
                        }
                    }
                };
                mesh.blocks.push(Block::Structured { dims, first_point: 0 });
                (dims[0] - 1) * (dims[1] - 1) * (dims[2] - 1)
            }
        };
        if let Some(n) = self.point_data_count {
            if n != mesh.points.len() {
                return Err(whole(format!(
                    "POINT_DATA declares {n} values but the dataset has {} points",
                    mesh.points.len()
                )));
            }
        }
        if let Some(n) = self.cell_data_count {
            if n != declared_cells {
                return Err(whole(format!("CELL_DATA declares {n} values but the dataset has {declared_cells} cells")));
            }
        }
        if let Some(mask) = &kept {
            for f in &mut self.cell_fields {
                let nc = f.num_components;
                let mut values = Vec::with_capacity(f.values.len());
                for (tuple, &keep) in f.values.chunks_exact(nc).zip(mask) {
                    if keep {
                        values.extend_from_slice(tuple);
                    }
                }
                f.values = values;
            }
        }
        if let Some(blank) = self.blanking.take() {
            if blank.len() != mesh.points.len() {
                return Err(whole(format!("BLANKING has {} values for {} points", blank.len(), mesh.points.len())));
            }
            mesh.point_blanked = Some(blank);
        }
        mesh.point_fields = self.point_fields;
        mesh.cell_fields = self.cell_fields;
        if !bezier.is_empty() {
            // Legacy files carry no RationalWeights: polynomial cells.
            let Some(Block::Unstructured(cells)) = mesh.blocks.first_mut() else {
                unreachable!("an unstructured grid holds one unstructured block")
            };
            let r = tet_mesh::BezierEvaluator::new()
                .to_lagrange(cells, &bezier, &mut mesh.points, &mut mesh.point_fields, None)
                .map_err(|m| whole(format!("Bézier cells: {m}")))?;
            self.notes.push(r.note(false));
        }
        mesh.notes = self.notes;
        mesh.check().map_err(whole)?;
        Ok(mesh)
    }
}

/// Turns the file's cells into volume cells. Returns the cells and, when
/// any were skipped, a keep-mask over the file's cells (for CELL_DATA).
fn assemble_cells(
    raw: &RawCells,
    types: &[u32],
    npoints: usize,
    bezier: &mut Vec<usize>,
    notes: &mut Vec<String>,
) -> Result<(Cells, Option<Vec<bool>>), FormatError> {
    let whole = |m: String| FormatError::new(Location::Whole, m);
    let mut cells = Cells::new();
    cells.types.reserve(types.len());
    cells.connectivity.reserve(raw.connectivity.len());
    let mut mask = Vec::with_capacity(types.len());
    let (mut reduced, mut lower, mut unsupported) = (0usize, 0usize, 0usize);
    let mut lower_ids = Vec::new();
    let mut unsupported_ids = Vec::new();
    for (c, &id) in types.iter().enumerate() {
        let nodes = raw
            .offsets
            .get(c)
            .zip(raw.offsets.get(c + 1))
            .and_then(|(&lo, &hi)| raw.connectivity.get(lo..hi))
            .ok_or_else(|| whole(format!("cell {c} has a bad node range")))?;
        // (Legacy files carry no HigherOrderDegrees: a Lagrange cell's
        // orders follow from its node count, as in VTK.)
        let found = CellType::from_vtk(id, nodes.len(), None)
            .transpose()
            .map_err(|m| whole(format!("cell {c} (VTK type {id}): {m}")))?;
        if let Some((cell_type, stored)) = found {
            let need = cell_type.num_nodes();
            if nodes.len() < need {
                return Err(whole(format!(
                    "cell {c} (VTK type {id}, {cell_type:?}) lists {} nodes, needs {need}",
                    nodes.len()
                )));
            }
            if let Some(&p) = nodes[..need].iter().find(|&&p| p as usize >= npoints) {
                return Err(whole(format!("cell {c} refers to point {p}, but the file has {npoints} points")));
            }
            if stored > need {
                reduced += 1;
            }
            if CellType::vtk_id_is_bezier(id) && cell_type != cell_type.linear() {
                bezier.push(cells.len());
            }
            cells.push(cell_type, nodes);
            mask.push(true);
        } else if CellType::vtk_id_is_surface_or_lower(id) {
            lower += 1;
            if !lower_ids.contains(&id) {
                lower_ids.push(id);
            }
            mask.push(false);
        } else if CellType::vtk_id_is_unreducible_volume(id) {
            unsupported += 1;
            if !unsupported_ids.contains(&id) {
                unsupported_ids.push(id);
            }
            mask.push(false);
        } else {
            return Err(whole(format!("cell {c} has unknown VTK cell type {id}")));
        }
    }
    if reduced > 0 {
        notes.push(format!("reduced {reduced} quadratic or higher-order cells to their corner nodes"));
        let also = cells.reduce_to_corners();
        if also > 0 {
            notes.push(format!(
                "reduced {also} more quadratic cells to their corners as well, so that they conform with those"
            ));
        }
    }
    if lower > 0 {
        lower_ids.sort_unstable();
        notes.push(format!("skipped {lower} surface, line or vertex cells (VTK types {lower_ids:?})"));
    }
    if unsupported > 0 {
        unsupported_ids.sort_unstable();
        notes.push(format!(
            "skipped {unsupported} volume cells of types this reader cannot reduce (VTK types {unsupported_ids:?})"
        ));
    }
    if cells.is_empty() {
        return Err(whole(format!(
            "no volume cells: all {} cells of the UNSTRUCTURED_GRID are surface, line or vertex cells (or unsupported)",
            types.len()
        )));
    }
    let mask = if mask.iter().all(|&k| k) { None } else { Some(mask) };
    Ok((cells, mask))
}

fn uniform_points(dims: [usize; 3], origin: [f64; 3], spacing: [f64; 3]) -> Vec<[f64; 3]> {
    let axis = |a: usize| -> Vec<f64> { (0..dims[a]).map(|i| origin[a] + i as f64 * spacing[a]).collect() };
    let (x, y, z) = (axis(0), axis(1), axis(2));
    rectilinear_points([&x, &y, &z])
}

/// Points of a grid with the given axis coordinates, i fastest.
fn rectilinear_points(axes: [&[f64]; 3]) -> Vec<[f64; 3]> {
    let mut points = Vec::with_capacity(axes[0].len() * axes[1].len() * axes[2].len());
    for &z in axes[2] {
        for &y in axes[1] {
            for &x in axes[0] {
                points.push([x, y, z]);
            }
        }
    }
    points
}

#[cfg(test)]
mod tests {
    use super::*;

    fn ascii(body: &str) -> Vec<u8> {
        format!("# vtk DataFile Version 3.0\ntest\nASCII\n{body}").into_bytes()
    }

    const TET: &str = "DATASET UNSTRUCTURED_GRID\nPOINTS 4 float\n0 0 0 1 0 0 0 1 0 0 0 1\n";

    #[test]
    fn decodes_percent_escapes() {
        assert_eq!(decode_name("cell%20id"), "cell id");
        assert_eq!(decode_name("a%2"), "a%2");
        assert_eq!(decode_name("100%zz"), "100%zz");
        assert_eq!(decode_name("%41%42"), "AB");
    }

    #[test]
    fn maps_type_names_like_vtk() {
        use ScalarType::*;
        assert_eq!(elem_type("float"), Some(ElemType::Num(F32)));
        assert_eq!(elem_type("DOUBLE"), Some(ElemType::Num(F64)));
        assert_eq!(elem_type("vtkIdType"), Some(ElemType::Num(I32)));
        assert_eq!(elem_type("vtktypeint64"), Some(ElemType::Num(I64)));
        assert_eq!(elem_type("vtktypeuint64"), Some(ElemType::Num(U64)));
        assert_eq!(elem_type("unsigned_long"), Some(ElemType::Long { signed: false }));
        assert_eq!(elem_type("long"), Some(ElemType::Long { signed: true }));
        assert_eq!(elem_type("unsigned_char"), Some(ElemType::Num(U8)));
        assert_eq!(elem_type("char"), Some(ElemType::Num(I8)));
        assert_eq!(elem_type("bit"), Some(ElemType::Bit));
        assert_eq!(elem_type("utf8_string"), Some(ElemType::Str));
        assert_eq!(elem_type("complex"), None);
    }

    #[test]
    fn classic_cells_with_scalars_and_lookup_table() {
        let text = format!(
            "{TET}CELLS 1 5\n4 0 1 2 3\nCELL_TYPES 1\n10\nCELL_DATA 1\nSCALARS id int 1\n\
             LOOKUP_TABLE default\n7\nPOINT_DATA 4\nSCALARS s double\n1 2 3 4\n\
             LOOKUP_TABLE my_table 2\n0 0 0 1 1 1 1 1\n"
        );
        let m = read(&ascii(&text)).unwrap();
        assert_eq!(m.points.len(), 4);
        assert_eq!(m.num_cells(), 1);
        assert_eq!(m.cell_fields[0].values, vec![7.0]);
        assert_eq!(m.point_fields[0].values, vec![1.0, 2.0, 3.0, 4.0]);
        assert_eq!(m.format, "legacy VTK (ASCII)");
    }

    #[test]
    fn offsets_connectivity_layout() {
        let text = format!(
            "{TET}CELLS 2 4\nOFFSETS vtktypeint64\n0 4\nCONNECTIVITY vtktypeint64\n3 2 1 0\nCELL_TYPES 1\n10\n"
        );
        let m = read(&ascii(&text)).unwrap();
        match &m.blocks[0] {
            Block::Unstructured(c) => assert_eq!(c.nodes(0), &[3, 2, 1, 0]),
            b => panic!("{b:?}"),
        }
    }

    #[test]
    fn skipped_cells_drop_their_cell_data() {
        let text = "DATASET UNSTRUCTURED_GRID\nPOINTS 5 float\n0 0 0 1 0 0 0 1 0 0 0 1 1 1 1\n\
                    CELLS 3 13\n3 0 1 2\n4 0 1 2 3\n3 1 2 4\nCELL_TYPES 3\n5 10 5\n\
                    CELL_DATA 3\nVECTORS v float\n1 1 1 2 2 2 3 3 3\n";
        let m = read(&ascii(text)).unwrap();
        assert_eq!(m.num_cells(), 1);
        assert_eq!(m.cell_fields[0].values, vec![2.0, 2.0, 2.0]);
        assert!(m.notes.iter().any(|n| n.contains("skipped 2 surface")), "{:?}", m.notes);
    }

    #[test]
    fn unknown_cell_type_names_cell_and_id() {
        let text = format!("{TET}CELLS 1 5\n4 0 1 2 3\nCELL_TYPES 1\n99\n");
        let e = read(&ascii(&text)).unwrap_err();
        assert!(e.message.contains("cell 0") && e.message.contains("99"), "{e}");
    }

    #[test]
    fn polydata_is_refused_clearly() {
        let e = read(&ascii("DATASET POLYDATA\nPOINTS 0 float\n")).unwrap_err();
        assert!(e.message.starts_with("no volume cells: this file holds POLYDATA"), "{e}");
    }

    #[test]
    fn flat_structured_grid_has_no_volume() {
        let e = read(&ascii("DATASET STRUCTURED_POINTS\nDIMENSIONS 4 4 1\n")).unwrap_err();
        assert!(e.message.starts_with("no volume cells"), "{e}");
    }

    #[test]
    fn metadata_and_field_data_are_handled() {
        let text = format!(
            "FIELD FieldData 1\nTime 1 1 double\n0.5\n{TET}CELLS 1 5\n4 0 1 2 3\nCELL_TYPES 1\n10\n\
             POINT_DATA 4\nVECTORS vel float\n0 0 0 1 1 1 2 2 2 3 3 3\nMETADATA\nCOMPONENT_NAMES\nvx\nvy\nvz\n\n\
             FIELD FieldData 3\nNULL_ARRAY\nmy%20p 1 4 int\n1 2 3 4\nwrong 1 3 int\n1 2 3\n"
        );
        let text = text.replacen("DATASET UNSTRUCTURED_GRID\n", "", 1);
        let text = format!("DATASET UNSTRUCTURED_GRID\n{text}");
        let m = read(&ascii(&text)).unwrap();
        assert_eq!(m.point_fields.len(), 2);
        assert_eq!(m.point_fields[1].name, "my p");
        assert!(m.notes.iter().any(|n| n.contains("'wrong'")));
    }

    /// A binary file built by hand: big-endian data, a `long` array of 4-byte
    /// values (Windows), bits, colour bytes and a string array.
    #[test]
    fn binary_arrays() {
        let mut f = b"# vtk DataFile Version 4.2\nt\nBINARY\nDATASET UNSTRUCTURED_GRID\nPOINTS 4 double\n".to_vec();
        for v in [0.0f64, 0., 0., 1., 0., 0., 0., 1., 0., 0., 0., 1.] {
            f.extend(v.to_be_bytes());
        }
        f.extend(b"\nCELLS 1 5\n");
        for v in [4i32, 0, 1, 2, 3] {
            f.extend(v.to_be_bytes());
        }
        f.extend(b"\nCELL_TYPES 1\n");
        f.extend(10i32.to_be_bytes());
        f.extend(b"\nPOINT_DATA 4\nFIELD f 3\nl 1 4 long\n");
        for v in [-1i32, 2, 3, 4] {
            f.extend(v.to_be_bytes());
        }
        f.extend(b"\nb 1 4 bit\n");
        f.push(0b1010_0000);
        f.extend(b"\nnames 1 4 string\n");
        for s in ["a", "bb", "", "dddd"] {
            f.push(0xc0 | s.len() as u8);
            f.extend(s.as_bytes());
        }
        f.extend(b"\nCOLOR_SCALARS c 1\n");
        f.extend([0u8, 10, 200, 255]);
        f.push(b'\n');
        let m = read(&f).unwrap();
        assert_eq!(m.format, "legacy VTK (BINARY)");
        assert_eq!(m.point_fields[0].values, vec![-1.0, 2.0, 3.0, 4.0]);
        assert_eq!(m.point_fields[1].values, vec![1.0, 0.0, 1.0, 0.0]);
        assert_eq!(m.point_fields[2].values, vec![0.0, 10.0, 200.0, 255.0]);
        assert!(m.notes.iter().any(|n| n.contains("4-byte")), "{:?}", m.notes);
    }

    #[test]
    fn hostile_counts_are_errors() {
        for body in [
            "DATASET UNSTRUCTURED_GRID\nPOINTS 99999999999999 float\n0 0 0\n",
            "DATASET UNSTRUCTURED_GRID\nPOINTS -4 float\n",
            "DATASET UNSTRUCTURED_GRID\nPOINTS 1 complex\n0 0 0\n",
            "DATASET STRUCTURED_POINTS\nDIMENSIONS 100000 100000 100000\n",
            "DATASET STRUCTURED_POINTS\nDIMENSIONS 4611686018427387904 4 4\n",
            "DATASET RECTILINEAR_GRID\nDIMENSIONS 2 2 2\nX_COORDINATES 2 float\n0 1\n",
        ] {
            assert!(read(&ascii(body)).is_err(), "{body}");
        }
    }
}
