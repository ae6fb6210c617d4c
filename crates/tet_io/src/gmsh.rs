//! Gmsh `.msh` reader: format versions 2.x (2.2 layout) and 4.1, ASCII and
//! binary, either byte order.
//!
//! What is kept: all nodes (in file order), the volume elements reduced to
//! their corner nodes, `$NodeData` as point fields and `$ElementData` as cell
//! fields (of each name, the time step that comes last in the file; sections
//! of one step, as partitioned files write them, are merged), and the physical / elementary
//! entity tag of each volume element as the cell fields `gmsh:physical` and
//! `gmsh:geometrical` (the former only when the file has physical volumes).
//! Lower-dimensional elements are counted and dropped.
//! `$ElementNodeData`, `$PartitionedEntities`, `$Periodic`,
//! `$InterpolationScheme` and any unknown section are skipped with a note.
//!
//! Node order: Gmsh's first-order tetrahedron, hexahedron, prism and pyramid
//! have the same reference coordinates as VTK's tetra, hexahedron, wedge and
//! pyramid (a prism's triangle 0-1-2 lies under 3-4-5 in both), and every
//! higher-order element lists its corners first in that same order, so
//! reducing is keeping the leading nodes, with no permutation.
//!
//! Node and element tags may be sparse; they are mapped to indices through a
//! dense table only when the largest tag is within a small multiple of the
//! count (so memory stays bounded by the input size), else through a hash map.

use std::collections::HashMap;

use tet_mesh::{Block, CellType, Cells, Field};

use crate::cursor::{clip, ByteCursor, Endian, TextCursor};
use crate::{FormatError, Location, SourceMesh};

/// Field names for the per-cell entity tags.
pub const PHYSICAL_FIELD: &str = "gmsh:physical";
pub const GEOMETRICAL_FIELD: &str = "gmsh:geometrical";

/// Reads a whole `.msh` file held in memory.
pub fn read(bytes: &[u8]) -> Result<SourceMesh, FormatError> {
    let mut t = TextCursor::new(bytes);
    let first = t.token();
    match first {
        Some("$MeshFormat") => {}
        Some("$NOD") | Some("$NOE") => {
            return Err(FormatError::new(
                Location::Line(1),
                "Gmsh 1.0 files ($NOD) are not supported; re-save the mesh as MSH 2.2 or 4.1",
            ))
        }
        _ => {
            return Err(FormatError::new(
                Location::Line(1),
                "not a Gmsh mesh: the file does not start with $MeshFormat",
            ))
        }
    }
    let header = read_mesh_format(&mut t)?;
    let mut state = State::new(header);
    while let Some(section) = t.token() {
        let loc = t.location();
        match section {
            "$MeshFormat" => {
                // Gmsh accepts several files concatenated; the layout must not change midway.
                let again = read_mesh_format(&mut t)?;
                if again != state.header {
                    return Err(FormatError::new(loc, "a second $MeshFormat section changes the version or encoding"));
                }
            }
            "$PhysicalNames" => read_physical_names(&mut t, &mut state)?,
            "$Entities" if state.header.version == Version::V41 => state.section_41(&mut t, Section41::Entities)?,
            "$Nodes" => {
                if state.header.version == Version::V41 {
                    state.section_41(&mut t, Section41::Nodes)?;
                } else {
                    read_nodes_2(&mut t, &mut state)?;
                }
            }
            "$Elements" => {
                if state.header.version == Version::V41 {
                    state.section_41(&mut t, Section41::Elements)?;
                } else if state.header.binary.is_some() {
                    read_elements_2_binary(&mut t, &mut state)?;
                } else {
                    read_elements_2_ascii(&mut t, &mut state)?;
                }
            }
            "$NodeData" => read_data(&mut t, &mut state, DataKind::Node)?,
            "$ElementData" => read_data(&mut t, &mut state, DataKind::Element)?,
            "$ElementNodeData" => {
                let header = read_data_header(&mut t, "$ElementNodeData")?;
                skip_section(&mut t, "ElementNodeData", loc)?;
                state.notes.push(format!(
                    "skipped $ElementNodeData '{}' (values per element node are not supported)",
                    header.name
                ));
            }
            s if s.starts_with("$End") => {
                return Err(FormatError::new(loc, format!("{s} without a matching opening section")));
            }
            s if s.starts_with('$') && s.len() > 1 => {
                let name = &s[1..];
                skip_section(&mut t, name, loc)?;
                let s = s.to_string();
                if !state.skipped_sections.contains(&s) {
                    state.skipped_sections.push(s);
                }
            }
            other => {
                return Err(FormatError::new(
                    loc,
                    format!("expected a section header such as $Nodes, found '{}'", clip(other)),
                ))
            }
        }
    }
    state.finish()
}

#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum Version {
    /// 2.0, 2.1 and 2.2 share one layout.
    V2,
    V41,
}

#[derive(Debug, Clone, PartialEq)]
struct Header {
    version: Version,
    /// The version as the file spells it, for `SourceMesh::format`.
    version_text: String,
    /// Byte order and size of `size_t` (4.1) for binary files.
    binary: Option<(Endian, usize)>,
}

fn read_mesh_format(t: &mut TextCursor) -> Result<Header, FormatError> {
    let version_text = t.expect_token("the MSH version")?.to_string();
    let loc = t.location();
    let version = match version_text.as_str() {
        "2" | "2.0" | "2.1" | "2.2" => Version::V2,
        "4.1" => Version::V41,
        "4" | "4.0" => {
            return Err(FormatError::new(
                loc,
                "MSH 4.0 is not supported (its layout differs from 4.1); re-save the mesh as MSH 4.1 or 2.2",
            ))
        }
        v => {
            return Err(FormatError::new(loc, format!("unsupported MSH version '{}' (2.2 and 4.1 are read)", clip(v))))
        }
    };
    let file_type: i64 = t.parse("the file type (0 = ASCII, 1 = binary)")?;
    let data_size: i64 = t.parse("the data size")?;
    let binary = match file_type {
        0 => None,
        1 => {
            let size_bytes = match (version, data_size) {
                (Version::V2, 8) => 8,
                (Version::V41, 4) | (Version::V41, 8) => data_size as usize,
                _ => {
                    return Err(FormatError::new(
                        loc,
                        format!("unsupported data size {data_size} for binary MSH {version_text}"),
                    ))
                }
            };
            eat_line_end(t)?;
            let at = t.offset() as u64;
            let one = t.rest().get(..4).ok_or_else(|| {
                FormatError::new(Location::Byte(at), "truncated $MeshFormat: the byte-order integer is missing")
            })?;
            let one: [u8; 4] =
                one.try_into().map_err(|_| FormatError::new(Location::Byte(at), "truncated $MeshFormat"))?;
            let endian = if u32::from_le_bytes(one) == 1 {
                Endian::Little
            } else if u32::from_be_bytes(one) == 1 {
                Endian::Big
            } else {
                return Err(FormatError::new(
                    Location::Byte(at),
                    "binary $MeshFormat: the byte-order integer is not 1 in either byte order",
                ));
            };
            t.advance(4);
            Some((endian, size_bytes))
        }
        f => return Err(FormatError::new(loc, format!("file type must be 0 (ASCII) or 1 (binary), found {f}"))),
    };
    expect_end(t, "MeshFormat")?;
    Ok(Header { version, version_text, binary })
}

/// Consumes the end of the current line exactly (spaces, optional CR, LF):
/// binary data starts right after it, so no further whitespace may be eaten.
fn eat_line_end(t: &mut TextCursor) -> Result<(), FormatError> {
    let rest = t.rest();
    let mut n = 0;
    while matches!(rest.get(n), Some(b' ') | Some(b'\t')) {
        n += 1;
    }
    if rest.get(n) == Some(&b'\r') {
        n += 1;
    }
    if rest.get(n) != Some(&b'\n') {
        return Err(FormatError::new(t.location(), "expected the end of the line before binary data"));
    }
    t.advance(n + 1);
    Ok(())
}

fn expect_end(t: &mut TextCursor, name: &str) -> Result<(), FormatError> {
    let at = t.offset();
    match t.token() {
        Some(tok) if tok.len() == name.len() + 4 && tok.starts_with("$End") && &tok[4..] == name => Ok(()),
        Some(tok) => Err(FormatError::new(
            t.location(),
            format!(
                "expected $End{name} (byte {at}), found '{}': the section holds more or other data than declared",
                clip(tok)
            ),
        )),
        None => Err(FormatError::new(t.location(), format!("unexpected end of file, expected $End{name}"))),
    }
}

/// Skips to just after `$End<name>`.
fn skip_section(t: &mut TextCursor, name: &str, opened_at: Location) -> Result<(), FormatError> {
    let pattern = format!("$End{name}");
    let rest = t.rest();
    match find(rest, pattern.as_bytes()) {
        Some(i) => {
            t.advance(i + pattern.len());
            Ok(())
        }
        None => Err(FormatError::new(opened_at, format!("section ${name} is not closed by {pattern}"))),
    }
}

fn find(hay: &[u8], needle: &[u8]) -> Option<usize> {
    if needle.is_empty() {
        return Some(0);
    }
    let first = needle[0];
    let mut from = 0;
    while let Some(p) = hay.get(from..)?.iter().position(|&b| b == first) {
        let i = from + p;
        if hay.get(i..i + needle.len()) == Some(needle) {
            return Some(i);
        }
        from = i + 1;
    }
    None
}

/// Scalar reads shared by the ASCII and binary forms of the 4.1 sections
/// (and of the 2.2 node list): Gmsh's `int`, `size_t` and `double`.
trait Values {
    fn int(&mut self, what: &str) -> Result<i64, FormatError>;
    fn size(&mut self, what: &str) -> Result<u64, FormatError>;
    fn real(&mut self, what: &str) -> Result<f64, FormatError>;
    /// Appends `n` size_t values.
    fn sizes(&mut self, n: u64, what: &str, out: &mut Vec<u64>) -> Result<(), FormatError>;
    /// Appends `n` doubles.
    fn reals(&mut self, n: u64, what: &str, out: &mut Vec<f64>) -> Result<(), FormatError>;
    fn location(&self) -> Location;
}

struct Ascii<'t, 'a> {
    t: &'t mut TextCursor<'a>,
}

impl Values for Ascii<'_, '_> {
    fn int(&mut self, what: &str) -> Result<i64, FormatError> {
        self.t.parse(what)
    }
    fn size(&mut self, what: &str) -> Result<u64, FormatError> {
        self.t.parse(what)
    }
    fn real(&mut self, what: &str) -> Result<f64, FormatError> {
        self.t.f64(what)
    }
    fn sizes(&mut self, n: u64, what: &str, out: &mut Vec<u64>) -> Result<(), FormatError> {
        for _ in 0..n {
            out.push(self.t.parse(what)?);
        }
        Ok(())
    }
    fn reals(&mut self, n: u64, what: &str, out: &mut Vec<f64>) -> Result<(), FormatError> {
        for _ in 0..n {
            out.push(self.t.f64(what)?);
        }
        Ok(())
    }
    /// The line of the next token (the cursor itself may still sit at the
    /// end of the previous line).
    fn location(&self) -> Location {
        let mut ahead = self.t.clone();
        ahead.token();
        ahead.location()
    }
}

struct Binary<'a> {
    c: ByteCursor<'a>,
    endian: Endian,
    size_bytes: usize,
}

impl Binary<'_> {
    fn to_count(&self, n: u64, what: &str) -> Result<usize, FormatError> {
        usize::try_from(n).map_err(|_| FormatError::new(self.c.location(), format!("{what}: count {n} is too large")))
    }
}

impl Values for Binary<'_> {
    fn int(&mut self, what: &str) -> Result<i64, FormatError> {
        self.c.i32(self.endian, what).map(i64::from)
    }
    fn size(&mut self, what: &str) -> Result<u64, FormatError> {
        if self.size_bytes == 4 {
            self.c.u32(self.endian, what).map(u64::from)
        } else {
            self.c.u64(self.endian, what)
        }
    }
    fn real(&mut self, what: &str) -> Result<f64, FormatError> {
        self.c.f64(self.endian, what)
    }
    fn sizes(&mut self, n: u64, what: &str, out: &mut Vec<u64>) -> Result<(), FormatError> {
        let n = self.to_count(n, what)?;
        let bytes = self.c.take_array(n, self.size_bytes, what)?;
        decode_sizes(bytes, self.size_bytes, self.endian, out);
        Ok(())
    }
    fn reals(&mut self, n: u64, what: &str, out: &mut Vec<f64>) -> Result<(), FormatError> {
        let n = self.to_count(n, what)?;
        let bytes = self.c.take_array(n, 8, what)?;
        out.reserve(n);
        out.extend(bytes.chunks_exact(8).map(|ch| f64::from_bits(word64(ch, self.endian))));
        Ok(())
    }
    fn location(&self) -> Location {
        self.c.location()
    }
}

fn word64(ch: &[u8], e: Endian) -> u64 {
    let mut a = [0u8; 8];
    a.copy_from_slice(&ch[..8]);
    match e {
        Endian::Little => u64::from_le_bytes(a),
        Endian::Big => u64::from_be_bytes(a),
    }
}

fn word32(ch: &[u8], e: Endian) -> u32 {
    let mut a = [0u8; 4];
    a.copy_from_slice(&ch[..4]);
    match e {
        Endian::Little => u32::from_le_bytes(a),
        Endian::Big => u32::from_be_bytes(a),
    }
}

fn decode_sizes(bytes: &[u8], size_bytes: usize, e: Endian, out: &mut Vec<u64>) {
    out.reserve(bytes.len() / size_bytes);
    if size_bytes == 4 {
        out.extend(bytes.chunks_exact(4).map(|ch| u64::from(word32(ch, e))));
    } else {
        out.extend(bytes.chunks_exact(8).map(|ch| word64(ch, e)));
    }
}

/// What an element type is to this reader.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum ElementKind {
    /// A volume element reducible to `CellType` by keeping its leading nodes.
    Volume(CellType, usize),
    /// A point, line or surface element with this many nodes.
    Lower(usize),
}

/// Gmsh element type numbers (GmshDefines.h `MSH_*`) and their node counts.
/// Polygons and polyhedra (variable node counts) and the one-node
/// "sub-element" volume types are absent: they are reported as unknown.
fn element_kind(type_id: i64) -> Option<ElementKind> {
    use CellType::*;
    use ElementKind::{Lower, Volume};
    Some(match type_id {
        // Tetrahedra: complete orders 1..10, then incomplete (serendipity) ones.
        4 => Volume(Tetra, 4),
        11 => Volume(Tetra, 10),
        29 => Volume(Tetra, 20),
        30 => Volume(Tetra, 35),
        31 => Volume(Tetra, 56),
        32 => Volume(Tetra, 22),
        33 => Volume(Tetra, 28),
        71 => Volume(Tetra, 84),
        72 => Volume(Tetra, 120),
        73 => Volume(Tetra, 165),
        74 => Volume(Tetra, 220),
        75 => Volume(Tetra, 286),
        79 => Volume(Tetra, 34),
        80 => Volume(Tetra, 40),
        81 => Volume(Tetra, 46),
        82 => Volume(Tetra, 52),
        83 => Volume(Tetra, 58),
        // Hexahedra.
        5 => Volume(Hexahedron, 8),
        12 => Volume(Hexahedron, 27),
        17 => Volume(Hexahedron, 20),
        92 => Volume(Hexahedron, 64),
        93 => Volume(Hexahedron, 125),
        94 => Volume(Hexahedron, 216),
        95 => Volume(Hexahedron, 343),
        96 => Volume(Hexahedron, 512),
        97 => Volume(Hexahedron, 729),
        98 => Volume(Hexahedron, 1000),
        99 => Volume(Hexahedron, 32),
        100 => Volume(Hexahedron, 44),
        101 => Volume(Hexahedron, 56),
        102 => Volume(Hexahedron, 68),
        103 => Volume(Hexahedron, 80),
        104 => Volume(Hexahedron, 92),
        105 => Volume(Hexahedron, 104),
        // Prisms.
        6 => Volume(Wedge, 6),
        13 => Volume(Wedge, 18),
        18 => Volume(Wedge, 15),
        90 => Volume(Wedge, 40),
        91 => Volume(Wedge, 75),
        106 => Volume(Wedge, 126),
        107 => Volume(Wedge, 196),
        108 => Volume(Wedge, 288),
        109 => Volume(Wedge, 405),
        110 => Volume(Wedge, 550),
        111 => Volume(Wedge, 24),
        112 => Volume(Wedge, 33),
        113 => Volume(Wedge, 42),
        114 => Volume(Wedge, 51),
        115 => Volume(Wedge, 60),
        116 => Volume(Wedge, 69),
        117 => Volume(Wedge, 78),
        // Pyramids.
        7 => Volume(Pyramid, 5),
        14 => Volume(Pyramid, 14),
        19 => Volume(Pyramid, 13),
        118 => Volume(Pyramid, 30),
        119 => Volume(Pyramid, 55),
        120 => Volume(Pyramid, 91),
        121 => Volume(Pyramid, 140),
        122 => Volume(Pyramid, 204),
        123 => Volume(Pyramid, 285),
        124 => Volume(Pyramid, 385),
        125 => Volume(Pyramid, 21),
        126 => Volume(Pyramid, 29),
        127 => Volume(Pyramid, 37),
        128 => Volume(Pyramid, 45),
        129 => Volume(Pyramid, 53),
        130 => Volume(Pyramid, 61),
        131 => Volume(Pyramid, 69),
        // Points, lines, triangles, quadrangles of all orders.
        15 | 84 | 85 | 86 | 133 => Lower(1),
        1 | 67 | 68 | 70 | 134 => Lower(2),
        2 | 8 | 135 | 138 => Lower(3),
        3 | 26 | 140 => Lower(4),
        27 => Lower(5),
        9 | 28 => Lower(6),
        62 => Lower(7),
        16 | 63 => Lower(8),
        10 | 20 | 64 => Lower(9),
        21 | 65 => Lower(10),
        66 => Lower(11),
        22 | 39 => Lower(12),
        23 | 24 => Lower(15),
        36 | 40 => Lower(16),
        52 => Lower(18),
        41 => Lower(20),
        25 | 53 => Lower(21),
        54 | 57 => Lower(24),
        37 => Lower(25),
        55 => Lower(27),
        42 | 58 => Lower(28),
        56 => Lower(30),
        59 => Lower(32),
        38 | 43 | 60 => Lower(36),
        61 => Lower(40),
        44 => Lower(45),
        47 => Lower(49),
        45 => Lower(55),
        48 => Lower(64),
        46 => Lower(66),
        49 => Lower(81),
        50 => Lower(100),
        51 => Lower(121),
        _ => return None,
    })
}

fn element_nodes(kind: ElementKind) -> usize {
    match kind {
        ElementKind::Volume(_, n) | ElementKind::Lower(n) => n,
    }
}

#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum DataKind {
    Node,
    Element,
}

/// The `$NodeData`/`$ElementData` header (ASCII in both encodings).
struct DataHeader {
    name: String,
    time: f64,
    step: i64,
    components: usize,
    count: u64,
}

/// The latest time step seen of one named field.
struct DataField {
    kind: DataKind,
    name: String,
    time: f64,
    step: i64,
    /// Distinct time steps met for this name, in file order.
    steps_seen: usize,
    components: usize,
    tags: Vec<u64>,
    values: Vec<f64>,
    at: Location,
}

struct State {
    header: Header,
    node_tags: Vec<u64>,
    points: Vec<[f64; 3]>,
    cell_types: Vec<CellType>,
    /// Corner node tags of the kept cells, concatenated.
    cell_node_tags: Vec<u64>,
    cell_tags: Vec<u64>,
    cell_physical: Vec<f64>,
    cell_entity: Vec<f64>,
    lower_dim: usize,
    higher_order: usize,
    elements_sections: usize,
    /// Physical tag of each volume entity (4.1 `$Entities`).
    volume_physical: Option<HashMap<i64, i64>>,
    /// Whether the physical tag of the cells is known (2.2 tags or 4.1 entities).
    physical_known: bool,
    physical_volume_names: Vec<(i64, String)>,
    data: Vec<DataField>,
    skipped_sections: Vec<String>,
    notes: Vec<String>,
}

impl State {
    fn new(header: Header) -> Self {
        State {
            header,
            node_tags: Vec::new(),
            points: Vec::new(),
            cell_types: Vec::new(),
            cell_node_tags: Vec::new(),
            cell_tags: Vec::new(),
            cell_physical: Vec::new(),
            cell_entity: Vec::new(),
            lower_dim: 0,
            higher_order: 0,
            elements_sections: 0,
            volume_physical: None,
            physical_known: false,
            physical_volume_names: Vec::new(),
            data: Vec::new(),
            skipped_sections: Vec::new(),
            notes: Vec::new(),
        }
    }

    /// Runs the body of a 4.1 section that is ASCII or binary by the file's
    /// encoding, then checks its `$End` line. `t` is just after the header.
    fn section_41(&mut self, t: &mut TextCursor, which: Section41) -> Result<(), FormatError> {
        match self.header.binary {
            None => dispatch_41(&mut Ascii { t: &mut *t }, self, which)?,
            Some((endian, size_bytes)) => {
                eat_line_end(t)?;
                let base = t.offset() as u64;
                let mut v = Binary { c: ByteCursor::with_base(t.rest(), base), endian, size_bytes };
                dispatch_41(&mut v, self, which)?;
                let used = v.c.offset() - base;
                t.advance(used as usize);
            }
        }
        expect_end(t, which.name())
    }

    fn push_cell(&mut self, cell_type: CellType, nodes: &[u64], tag: u64, physical: f64, entity: f64) {
        let corners = cell_type.num_nodes();
        if nodes.len() > corners {
            self.higher_order += 1;
        }
        self.cell_types.push(cell_type);
        self.cell_node_tags.extend_from_slice(&nodes[..corners.min(nodes.len())]);
        self.cell_tags.push(tag);
        self.cell_physical.push(physical);
        self.cell_entity.push(entity);
    }

    fn finish(self) -> Result<SourceMesh, FormatError> {
        let State {
            header,
            node_tags,
            points,
            cell_types,
            cell_node_tags,
            cell_tags,
            cell_physical,
            cell_entity,
            lower_dim,
            higher_order,
            elements_sections,
            physical_known,
            physical_volume_names,
            data,
            skipped_sections,
            mut notes,
            ..
        } = self;
        if points.is_empty() && node_tags.is_empty() {
            return Err(FormatError::new(Location::Whole, "the file has no nodes ($Nodes section missing or empty)"));
        }
        if elements_sections == 0 {
            return Err(FormatError::new(Location::Whole, "the file has no $Elements section"));
        }
        if cell_types.is_empty() {
            return Err(FormatError::new(
                Location::Whole,
                format!("the file has no volume elements ({lower_dim} point, line or surface elements only)"),
            ));
        }
        if u32::try_from(points.len()).is_err() {
            return Err(FormatError::new(Location::Whole, "more than 2^32 - 1 nodes"));
        }
        let node_map = TagMap::build(&node_tags)
            .map_err(|t| FormatError::new(Location::Whole, format!("node tag {t} appears twice in $Nodes")))?;

        let mut cells = Cells::new();
        cells.types.reserve(cell_types.len());
        cells.offsets.reserve(cell_types.len());
        cells.connectivity.reserve(cell_node_tags.len());
        let mut resolved = [0u32; 8];
        let mut at = 0usize;
        for (c, &ty) in cell_types.iter().enumerate() {
            let n = ty.num_nodes();
            let tags = cell_node_tags.get(at..at + n).ok_or_else(|| {
                FormatError::new(Location::Whole, "internal: element node list shorter than its type")
            })?;
            for (slot, &tag) in resolved.iter_mut().zip(tags) {
                *slot = node_map.get(tag).ok_or_else(|| {
                    FormatError::new(
                        Location::Whole,
                        format!(
                            "element {} refers to node tag {tag}, which is not in $Nodes",
                            cell_tags.get(c).copied().unwrap_or(0)
                        ),
                    )
                })?;
            }
            cells.push(ty, &resolved[..n]);
            at += n;
        }

        let mut mesh = SourceMesh {
            format: format!(
                "Gmsh {} ({})",
                header.version_text,
                if header.binary.is_some() { "binary" } else { "ASCII" }
            ),
            ..Default::default()
        };
        // All zeros means the file defines no physical volumes: leave the field out.
        if physical_known && cell_physical.iter().any(|&p| p != 0.0) {
            mesh.cell_fields.push(Field::new(PHYSICAL_FIELD, 1, cell_physical));
        }
        mesh.cell_fields.push(Field::new(GEOMETRICAL_FIELD, 1, cell_entity));

        let num_points = points.len();
        let num_cells = cells.len();
        let mut cell_map: Option<TagMap> = None;
        for f in data {
            let comps = f.components;
            let (count, map) = match f.kind {
                DataKind::Node => (num_points, &node_map),
                DataKind::Element => {
                    if cell_map.is_none() {
                        cell_map = Some(TagMap::build(&cell_tags).map_err(|t| {
                            FormatError::new(Location::Whole, format!("element tag {t} is used by two volume elements"))
                        })?);
                    }
                    match &cell_map {
                        Some(m) => (num_cells, m),
                        None => continue,
                    }
                }
            };
            let len = count.checked_mul(comps).ok_or_else(|| FormatError::new(f.at, "field size overflows"))?;
            let mut values = vec![f64::NAN; len];
            let mut covered = vec![false; count];
            let mut outside = 0usize;
            for (i, &tag) in f.tags.iter().enumerate() {
                let Some(idx) = map.get(tag) else {
                    if f.kind == DataKind::Node {
                        return Err(FormatError::new(
                            f.at,
                            format!("$NodeData '{}' refers to node tag {tag}, which is not in $Nodes", f.name),
                        ));
                    }
                    outside += 1;
                    continue;
                };
                let idx = idx as usize;
                let src = f.values.get(i * comps..(i + 1) * comps);
                let dst = values.get_mut(idx * comps..(idx + 1) * comps);
                if let (Some(src), Some(dst)) = (src, dst) {
                    dst.copy_from_slice(src);
                }
                if let Some(c) = covered.get_mut(idx) {
                    *c = true;
                }
            }
            let n_covered = covered.iter().filter(|&&c| c).count();
            let what = if f.kind == DataKind::Node { "point" } else { "cell" };
            if f.steps_seen > 1 {
                notes.push(format!(
                    "{what} field '{}': kept the last of {} time steps (step {}, time {})",
                    f.name, f.steps_seen, f.step, f.time
                ));
            }
            if outside > 0 {
                notes.push(format!("{what} field '{}': ignored {outside} values on non-volume elements", f.name));
            }
            if n_covered == 0 {
                notes.push(format!("{what} field '{}' dropped: it has no values on the volume {what}s", f.name));
                continue;
            }
            if n_covered < count {
                notes.push(format!(
                    "{what} field '{}' covers {n_covered} of {count} {what}s; the others are NaN",
                    f.name
                ));
            }
            let field = Field::new(f.name, comps, values);
            match f.kind {
                DataKind::Node => mesh.point_fields.push(field),
                DataKind::Element => mesh.cell_fields.push(field),
            }
        }

        if lower_dim > 0 {
            notes.insert(0, format!("skipped {lower_dim} lower-dimensional elements (points, lines, surfaces)"));
        }
        if higher_order > 0 {
            notes.insert(0, format!("reduced {higher_order} higher-order elements to their corner nodes"));
        }
        if !physical_volume_names.is_empty() {
            let list: Vec<String> =
                physical_volume_names.iter().map(|(tag, name)| format!("{tag} \"{name}\"")).collect();
            notes.push(format!("physical volumes ({PHYSICAL_FIELD}): {}", list.join(", ")));
        }
        if !skipped_sections.is_empty() {
            notes.push(format!("skipped sections: {}", skipped_sections.join(", ")));
        }
        mesh.points = points;
        mesh.blocks.push(Block::Unstructured(cells));
        mesh.notes = notes;
        mesh.check().map_err(|e| FormatError::new(Location::Whole, e))?;
        Ok(mesh)
    }
}

/// Maps sparse tags to dense indices with memory bounded by the tag count.
enum TagMap {
    Dense(Vec<u32>),
    Sparse(HashMap<u64, u32>),
}

impl TagMap {
    /// Fails with the first duplicated tag.
    fn build(tags: &[u64]) -> Result<TagMap, u64> {
        let max = tags.iter().copied().max().unwrap_or(0);
        let dense_limit = (tags.len() as u64).saturating_mul(2).saturating_add(1024);
        if max <= dense_limit {
            let mut table = vec![u32::MAX; max as usize + 1];
            for (i, &tag) in tags.iter().enumerate() {
                match table.get_mut(tag as usize) {
                    Some(slot) if *slot == u32::MAX => *slot = i as u32,
                    _ => return Err(tag),
                }
            }
            Ok(TagMap::Dense(table))
        } else {
            let mut map = HashMap::with_capacity(tags.len());
            for (i, &tag) in tags.iter().enumerate() {
                if map.insert(tag, i as u32).is_some() {
                    return Err(tag);
                }
            }
            Ok(TagMap::Sparse(map))
        }
    }

    fn get(&self, tag: u64) -> Option<u32> {
        match self {
            TagMap::Dense(table) => {
                usize::try_from(tag).ok().and_then(|i| table.get(i)).copied().filter(|&v| v != u32::MAX)
            }
            TagMap::Sparse(map) => map.get(&tag).copied(),
        }
    }
}

fn read_physical_names(t: &mut TextCursor, state: &mut State) -> Result<(), FormatError> {
    let count: u64 = t.parse("the number of physical names")?;
    for _ in 0..count {
        let dim: i64 = t.parse("a physical name's dimension")?;
        let tag: i64 = t.parse("a physical name's tag")?;
        let loc = t.location();
        let rest = t.line_str().ok_or_else(|| FormatError::new(loc, "unexpected end of file in $PhysicalNames"))?;
        if dim == 3 {
            state.physical_volume_names.push((tag, rest.trim().trim_matches('"').to_string()));
        }
    }
    expect_end(t, "PhysicalNames")
}

/// The sections whose 4.1 layout is shared by ASCII and binary files.
#[derive(Debug, Clone, Copy)]
enum Section41 {
    Entities,
    Nodes,
    Elements,
}

impl Section41 {
    fn name(self) -> &'static str {
        match self {
            Section41::Entities => "Entities",
            Section41::Nodes => "Nodes",
            Section41::Elements => "Elements",
        }
    }
}

fn dispatch_41<V: Values>(v: &mut V, s: &mut State, which: Section41) -> Result<(), FormatError> {
    match which {
        Section41::Entities => read_entities_41(v, s),
        Section41::Nodes => read_nodes_41(v, s),
        Section41::Elements => read_elements_41(v, s),
    }
}

/// `$Entities` (4.1): only the physical tags of volumes are kept, to label
/// cells; points, curves and surfaces are read past.
fn read_entities_41<V: Values>(v: &mut V, s: &mut State) -> Result<(), FormatError> {
    let mut counts = [0u64; 4];
    for (dim, count) in counts.iter_mut().enumerate() {
        *count = v.size(
            ["the number of points", "the number of curves", "the number of surfaces", "the number of volumes"][dim],
        )?;
    }
    let mut volume_physical = HashMap::new();
    for (dim, &count) in counts.iter().enumerate() {
        for _ in 0..count {
            let tag = v.int("an entity tag")?;
            let box_values = if dim == 0 { 3 } else { 6 };
            for _ in 0..box_values {
                v.real("an entity's coordinates")?;
            }
            let num_physical = v.size("the number of physical tags")?;
            let mut first_physical = None;
            for _ in 0..num_physical {
                let p = v.int("a physical tag")?;
                first_physical.get_or_insert(p);
            }
            if dim > 0 {
                let num_bounding = v.size("the number of bounding entities")?;
                for _ in 0..num_bounding {
                    v.int("a bounding entity tag")?;
                }
            }
            if dim == 3 {
                volume_physical.insert(tag, first_physical.unwrap_or(0));
            }
        }
    }
    s.volume_physical = Some(volume_physical);
    Ok(())
}

/// `$Nodes` (4.1): entity blocks of tags then coordinates; parametric
/// blocks carry `dim` extra coordinates per node, which are dropped.
fn read_nodes_41<V: Values>(v: &mut V, s: &mut State) -> Result<(), FormatError> {
    let num_blocks = v.size("the number of node blocks")?;
    v.size("the number of nodes")?;
    v.size("the smallest node tag")?;
    v.size("the largest node tag")?;
    let mut coords = Vec::new();
    for _ in 0..num_blocks {
        let loc = v.location();
        let dim = v.int("the entity dimension of a node block")?;
        v.int("the entity tag of a node block")?;
        let parametric = v.int("the parametric flag of a node block")?;
        let count = v.size("the number of nodes in a block")?;
        if !(0..=3).contains(&dim) {
            return Err(FormatError::new(loc, format!("node block entity dimension must be 0 to 3, found {dim}")));
        }
        let per_node = match parametric {
            0 => 3,
            1 => 3 + dim as u64,
            p => return Err(FormatError::new(loc, format!("node block parametric flag must be 0 or 1, found {p}"))),
        };
        v.sizes(count, "node tags", &mut s.node_tags)?;
        let num_values = count
            .checked_mul(per_node)
            .ok_or_else(|| FormatError::new(loc, format!("node block of {count} nodes overflows")))?;
        coords.clear();
        v.reals(num_values, "node coordinates", &mut coords)?;
        let per_node = per_node as usize;
        s.points.extend(coords.chunks_exact(per_node).map(|c| [c[0], c[1], c[2]]));
    }
    Ok(())
}

/// `$Elements` (4.1): entity blocks of one element type each.
fn read_elements_41<V: Values>(v: &mut V, s: &mut State) -> Result<(), FormatError> {
    s.elements_sections += 1;
    s.physical_known |= s.volume_physical.is_some();
    let num_blocks = v.size("the number of element blocks")?;
    v.size("the number of elements")?;
    v.size("the smallest element tag")?;
    v.size("the largest element tag")?;
    let mut buf = Vec::new();
    for _ in 0..num_blocks {
        let loc = v.location();
        let dim = v.int("the entity dimension of an element block")?;
        let entity = v.int("the entity tag of an element block")?;
        let type_id = v.int("the element type of a block")?;
        let count = v.size("the number of elements in a block")?;
        let Some(kind) = element_kind(type_id) else {
            let first = if count > 0 { v.size("an element tag").ok() } else { None };
            let which = match first {
                Some(tag) => format!("element {tag}"),
                None => "an element block".to_string(),
            };
            return Err(FormatError::new(
                loc,
                format!("{which} (entity dimension {dim}, tag {entity}) has unknown or unsupported Gmsh element type {type_id}"),
            ));
        };
        let per_element = element_nodes(kind) + 1;
        let num_values = count
            .checked_mul(per_element as u64)
            .ok_or_else(|| FormatError::new(loc, format!("element block of {count} elements overflows")))?;
        buf.clear();
        v.sizes(num_values, "element tags and nodes", &mut buf)?;
        match kind {
            ElementKind::Lower(_) => s.lower_dim += buf.len() / per_element,
            ElementKind::Volume(cell_type, _) => {
                let physical = s.volume_physical.as_ref().map_or(0, |m| m.get(&entity).copied().unwrap_or(0));
                for element in buf.chunks_exact(per_element) {
                    s.push_cell(cell_type, &element[1..], element[0], physical as f64, entity as f64);
                }
            }
        }
    }
    Ok(())
}

fn nonnegative(value: i64, what: &str, loc: Location) -> Result<u64, FormatError> {
    u64::try_from(value).map_err(|_| FormatError::new(loc, format!("{what} must not be negative, found {value}")))
}

/// `$Nodes` (2.x): a count, then `tag x y z` per node (binary: int + 3 doubles).
fn read_nodes_2(t: &mut TextCursor, s: &mut State) -> Result<(), FormatError> {
    let count: u64 = t.parse("the number of nodes")?;
    match s.header.binary {
        None => {
            for _ in 0..count {
                let tag: i64 = t.parse("a node tag")?;
                let loc = t.location();
                s.node_tags.push(nonnegative(tag, "a node tag", loc)?);
                let x = t.f64("a node's x coordinate")?;
                let y = t.f64("a node's y coordinate")?;
                let z = t.f64("a node's z coordinate")?;
                s.points.push([x, y, z]);
            }
        }
        Some((endian, _)) => {
            eat_line_end(t)?;
            let base = t.offset() as u64;
            let mut c = ByteCursor::with_base(t.rest(), base);
            let count = usize::try_from(count)
                .map_err(|_| FormatError::new(c.location(), format!("node count {count} is too large")))?;
            let bytes = c.take_array(count, 4 + 3 * 8, "node list")?;
            s.node_tags.reserve(count);
            s.points.reserve(count);
            for (i, node) in bytes.chunks_exact(28).enumerate() {
                let tag = word32(node, endian) as i32;
                let loc = Location::Byte(base + (i * 28) as u64);
                s.node_tags.push(nonnegative(i64::from(tag), "a node tag", loc)?);
                let coord = |k: usize| f64::from_bits(word64(&node[4 + 8 * k..], endian));
                s.points.push([coord(0), coord(1), coord(2)]);
            }
            t.advance((c.offset() - base) as usize);
        }
    }
    expect_end(t, "Nodes")
}

fn unknown_type_error(loc: Location, element: u64, type_id: i64) -> FormatError {
    FormatError::new(loc, format!("element {element} has unknown or unsupported Gmsh element type {type_id}"))
}

/// `$Elements` (2.x, ASCII): `tag type ntags tag... node...` per element;
/// the first tag is the physical entity, the second the elementary one.
fn read_elements_2_ascii(t: &mut TextCursor, s: &mut State) -> Result<(), FormatError> {
    s.elements_sections += 1;
    let count: u64 = t.parse("the number of elements")?;
    let mut nodes = Vec::new();
    for _ in 0..count {
        let tag: u64 = t.parse("an element tag")?;
        let loc = t.location();
        let type_id: i64 = t.parse("an element type")?;
        let num_tags: u64 = t.parse("the number of element tags")?;
        let kind = element_kind(type_id).ok_or_else(|| unknown_type_error(loc, tag, type_id))?;
        let (mut physical, mut entity) = (0i64, 0i64);
        for i in 0..num_tags {
            let value: i64 = t.parse("an element tag value")?;
            match i {
                0 => physical = value,
                1 => entity = value,
                _ => {}
            }
        }
        nodes.clear();
        for _ in 0..element_nodes(kind) {
            nodes.push(t.parse::<u64>("an element node tag")?);
        }
        match kind {
            ElementKind::Lower(_) => s.lower_dim += 1,
            ElementKind::Volume(cell_type, _) => {
                s.physical_known |= num_tags >= 1;
                s.push_cell(cell_type, &nodes, tag, physical as f64, entity as f64);
            }
        }
    }
    expect_end(t, "Elements")
}

/// `$Elements` (2.x, binary): blocks headed by (type, count, ntags), each
/// element being `tag, ntags tags, nodes` as 4-byte ints.
fn read_elements_2_binary(t: &mut TextCursor, s: &mut State) -> Result<(), FormatError> {
    s.elements_sections += 1;
    let Some((endian, _)) = s.header.binary else {
        return read_elements_2_ascii(t, s);
    };
    let count: u64 = t.parse("the number of elements")?;
    eat_line_end(t)?;
    let base = t.offset() as u64;
    let mut c = ByteCursor::with_base(t.rest(), base);
    let mut done = 0u64;
    let mut nodes = Vec::new();
    while done < count {
        let loc = c.location();
        let type_id = c.i32(endian, "an element block's type")?;
        let in_block = c.i32(endian, "an element block's element count")?;
        let num_tags = c.i32(endian, "an element block's number of tags")?;
        if in_block <= 0 || num_tags < 0 {
            return Err(FormatError::new(
                loc,
                format!("element block header has {in_block} elements and {num_tags} tags; both must be positive"),
            ));
        }
        let in_block = in_block as u64;
        if in_block > count - done {
            return Err(FormatError::new(
                loc,
                format!("element block of {in_block} elements overruns the {count} elements declared"),
            ));
        }
        let Some(kind) = element_kind(i64::from(type_id)) else {
            let first = c.clone().i32(endian, "an element tag").unwrap_or(0);
            return Err(unknown_type_error(loc, first as u64, i64::from(type_id)));
        };
        let num_tags = num_tags as usize;
        let per_element = 1 + num_tags + element_nodes(kind);
        let record = per_element
            .checked_mul(4)
            .ok_or_else(|| FormatError::new(loc, format!("element block with {num_tags} tags overflows")))?;
        let bytes = c.take_array(in_block as usize, record, "element block")?;
        match kind {
            ElementKind::Lower(_) => s.lower_dim += in_block as usize,
            ElementKind::Volume(cell_type, _) => {
                s.physical_known |= num_tags >= 1;
                for element in bytes.chunks_exact(record) {
                    let int = |k: usize| word32(&element[4 * k..], endian) as i32;
                    let physical = if num_tags >= 1 { int(1) } else { 0 };
                    let entity = if num_tags >= 2 { int(2) } else { 0 };
                    nodes.clear();
                    for k in 1 + num_tags..per_element {
                        // Negative node numbers are not tags; map them to an unused value so
                        // resolution reports the element.
                        nodes.push(u64::try_from(int(k)).unwrap_or(u64::MAX));
                    }
                    s.push_cell(cell_type, &nodes, int(0) as u32 as u64, f64::from(physical), f64::from(entity));
                }
            }
        }
        done += in_block;
    }
    t.advance((c.offset() - base) as usize);
    expect_end(t, "Elements")
}

fn read_data_header(t: &mut TextCursor, section: &str) -> Result<DataHeader, FormatError> {
    let num_strings: u64 = t.parse("the number of string tags")?;
    let _ = t.line_str();
    let mut name = None;
    for _ in 0..num_strings {
        let loc = t.location();
        let line = t
            .line_str()
            .ok_or_else(|| FormatError::new(loc, format!("unexpected end of file in the {section} string tags")))?;
        name.get_or_insert_with(|| line.trim().trim_matches('"').to_string());
    }
    let num_reals: u64 = t.parse("the number of real tags")?;
    let mut time = 0.0;
    for i in 0..num_reals {
        let r = t.f64("a real tag")?;
        if i == 0 {
            time = r;
        }
    }
    let num_ints: u64 = t.parse("the number of integer tags")?;
    let loc = t.location();
    if num_ints < 3 {
        return Err(FormatError::new(
            loc,
            format!("{section} needs at least 3 integer tags (time step, components, count), found {num_ints}"),
        ));
    }
    let mut ints = [0i64; 3];
    for i in 0..num_ints {
        let v: i64 = t.parse("an integer tag")?;
        if let Some(slot) = ints.get_mut(i as usize) {
            *slot = v;
        }
    }
    let [step, components, count] = ints;
    if !(1..=64).contains(&components) {
        return Err(FormatError::new(loc, format!("{section}: {components} components per value (1 to 64 are read)")));
    }
    let count = nonnegative(count, "the number of values", loc)?;
    Ok(DataHeader {
        name: name.unwrap_or_else(|| "data".to_string()),
        time,
        step,
        components: components as usize,
        count,
    })
}

/// `$NodeData` / `$ElementData`: values by tag, merged per name: sections of
/// the same time step (partitions) add up, a new time step replaces the old.
fn read_data(t: &mut TextCursor, s: &mut State, kind: DataKind) -> Result<(), FormatError> {
    let section = if kind == DataKind::Node { "NodeData" } else { "ElementData" };
    let at = t.location();
    let h = read_data_header(t, section)?;
    let comps = h.components;
    let mut tags = Vec::new();
    let mut values = Vec::new();
    match s.header.binary {
        None => {
            for _ in 0..h.count {
                tags.push(t.parse::<u64>("a data tag")?);
                for _ in 0..comps {
                    values.push(t.f64("a data value")?);
                }
            }
        }
        Some((endian, _)) => {
            eat_line_end(t)?;
            let base = t.offset() as u64;
            let mut c = ByteCursor::with_base(t.rest(), base);
            let count = usize::try_from(h.count)
                .map_err(|_| FormatError::new(c.location(), format!("{section}: count {} is too large", h.count)))?;
            let record = 4 + 8 * comps;
            let bytes = c.take_array(count, record, section)?;
            tags.reserve(count);
            values.reserve(count * comps);
            for (i, rec) in bytes.chunks_exact(record).enumerate() {
                let tag = word32(rec, endian) as i32;
                let loc = Location::Byte(base + (i * record) as u64);
                tags.push(nonnegative(i64::from(tag), "a data tag", loc)?);
                values.extend(rec[4..].chunks_exact(8).map(|v| f64::from_bits(word64(v, endian))));
            }
            t.advance((c.offset() - base) as usize);
        }
    }
    expect_end(t, section)?;

    match s.data.iter_mut().find(|f| f.kind == kind && f.name == h.name) {
        Some(f) if f.step == h.step => {
            if f.components != comps {
                return Err(FormatError::new(
                    at,
                    format!("{section} '{}' changes from {} to {comps} components", h.name, f.components),
                ));
            }
            f.tags.extend_from_slice(&tags);
            f.values.extend_from_slice(&values);
        }
        Some(f) => {
            f.steps_seen += 1;
            f.step = h.step;
            f.time = h.time;
            f.components = comps;
            f.tags = tags;
            f.values = values;
            f.at = at;
        }
        None => s.data.push(DataField {
            kind,
            name: h.name,
            time: h.time,
            step: h.step,
            steps_seen: 1,
            components: comps,
            tags,
            values,
            at,
        }),
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    fn cells(m: &SourceMesh) -> &Cells {
        match &m.blocks[0] {
            Block::Unstructured(c) => c,
            Block::Structured { .. } => panic!("structured block"),
        }
    }

    const TET_22: &str = "$MeshFormat\n2.2 0 8\n$EndMeshFormat\n$Nodes\n5\n\
        1000000000000000 0 0 0\n7 1 0 0\n3 0 1 0\n9 0 0 1\n12 5 5 5\n$EndNodes\n\
        $Elements\n3\n1 15 2 0 1 12\n20 2 2 5 6 1000000000000000 7 3\n\
        21 4 2 7 8 1000000000000000 7 3 9\n$EndElements\n";

    #[test]
    fn sparse_huge_tags_use_a_hash_map() {
        let m = read(TET_22.as_bytes()).unwrap();
        assert_eq!(m.points.len(), 5);
        assert_eq!(cells(&m).nodes(0), &[0, 1, 2, 3]);
        assert_eq!(m.format, "Gmsh 2.2 (ASCII)");
        let physical = m.cell_fields.iter().find(|f| f.name == PHYSICAL_FIELD).unwrap();
        assert_eq!(physical.values, vec![7.0]);
        assert!(m.notes.iter().any(|n| n.contains("skipped 2 lower-dimensional")), "{:?}", m.notes);
    }

    #[test]
    fn tag_map_dense_and_sparse() {
        let dense = TagMap::build(&[3, 1, 2]).unwrap();
        assert!(matches!(dense, TagMap::Dense(_)));
        assert_eq!(dense.get(1), Some(1));
        assert_eq!(dense.get(0), None);
        assert_eq!(dense.get(u64::MAX), None);
        let sparse = TagMap::build(&[u64::MAX, 5]).unwrap();
        assert!(matches!(sparse, TagMap::Sparse(_)));
        assert_eq!(sparse.get(u64::MAX), Some(0));
        assert_eq!(TagMap::build(&[4, 9, 4]).err(), Some(4));
    }

    #[test]
    fn unknown_element_type_names_element_and_type() {
        let text = TET_22.replace("21 4 2", "21 999 2");
        let e = read(text.as_bytes()).unwrap_err();
        assert!(e.message.contains("element 21") && e.message.contains("999"), "{e}");
        assert_eq!(e.at, Location::Line(16));
    }

    #[test]
    fn missing_node_is_an_error() {
        let text = TET_22.replace("7 3 9\n", "7 3 10\n");
        let e = read(text.as_bytes()).unwrap_err();
        assert!(e.message.contains("node tag 10"), "{e}");
    }

    #[test]
    fn surface_only_mesh_is_an_error() {
        let text = TET_22.replace("21 4 2 7 8 1000000000000000 7 3 9\n", "21 2 2 7 8 7 3 9\n");
        let e = read(text.as_bytes()).unwrap_err();
        assert!(e.message.contains("no volume elements"), "{e}");
    }

    const HEX_41: &str = "$MeshFormat\n4.1 0 8\n$EndMeshFormat\n\
        $Entities\n0 0 0 1\n4 0 0 0 1 1 1 1 42 0\n$EndEntities\n\
        $Nodes\n2 9 10 90\n2 1 1 4\n10\n20\n30\n40\n0 0 0 0 0\n1 0 0 1 0\n1 1 0 1 1\n0 1 0 0 1\n\
        3 4 0 5\n50\n60\n70\n80\n90\n0 0 1\n1 0 1\n1 1 1\n0 1 1\n0.5 0.5 2\n$EndNodes\n\
        $Elements\n2 2 1 2\n3 4 5 1\n1 10 20 30 40 50 60 70 80\n3 4 7 1\n2 50 60 70 80 90\n$EndElements\n\
        $NodeData\n1\n\"T\"\n1\n0.5\n3\n0\n1\n2\n10 1.5\n90 9.5\n$EndNodeData\n\
        $NodeData\n1\n\"T\"\n1\n1.0\n3\n1\n1\n2\n10 2.5\n90 3.5\n$EndNodeData\n\
        $NodeData\n1\n\"T\"\n1\n1.0\n4\n1\n1\n1\n1\n20 7\n$EndNodeData\n\
        $ElementData\n1\n\"q\"\n1\n0\n3\n0\n1\n2\n2 0.25\n77 3\n$EndElementData\n\
        $ElementNodeData\n1\n\"skipme\"\n1\n0\n3\n0\n1\n1\n1 8 1 2 3 4 5 6 7 8\n$EndElementNodeData\n";

    #[test]
    fn ascii_41_blocks_parametric_nodes_and_data() {
        let m = read(HEX_41.as_bytes()).unwrap();
        assert_eq!(m.format, "Gmsh 4.1 (ASCII)");
        assert_eq!(m.points.len(), 9);
        assert_eq!(m.points[2], [1.0, 1.0, 0.0]);
        let c = cells(&m);
        assert_eq!(c.types, vec![CellType::Hexahedron, CellType::Pyramid]);
        assert_eq!(c.nodes(0), &[0, 1, 2, 3, 4, 5, 6, 7]);
        assert_eq!(c.nodes(1), &[4, 5, 6, 7, 8]);
        let physical = m.cell_fields.iter().find(|f| f.name == PHYSICAL_FIELD).unwrap();
        assert_eq!(physical.values, vec![42.0, 42.0]);
        // Step 1 replaced step 0; its two partitions (sections) were merged.
        let t = &m.point_fields[0];
        assert_eq!(t.name, "T");
        assert_eq!(t.values[0], 2.5);
        assert_eq!(t.values[1], 7.0);
        assert_eq!(t.values[8], 3.5);
        assert!(t.values[3].is_nan());
        let q = m.cell_fields.iter().find(|f| f.name == "q").unwrap();
        assert!(q.values[0].is_nan());
        assert_eq!(q.values[1], 0.25);
        let notes = m.notes.join("\n");
        assert!(notes.contains("kept the last of 2 time steps"), "{notes}");
        assert!(notes.contains("ignored 1 values on non-volume elements"), "{notes}");
        assert!(notes.contains("skipped $ElementNodeData 'skipme'"), "{notes}");
    }

    /// Writes a binary 4.1 file of the same hexahedron + pyramid mesh.
    fn binary_41(endian: Endian, size_bytes: usize) -> Vec<u8> {
        let mut out = format!("$MeshFormat\n4.1 1 {size_bytes}\n").into_bytes();
        let int = |out: &mut Vec<u8>, v: i32| match endian {
            Endian::Little => out.extend_from_slice(&v.to_le_bytes()),
            Endian::Big => out.extend_from_slice(&v.to_be_bytes()),
        };
        let size = |out: &mut Vec<u8>, v: u64| match (endian, size_bytes) {
            (Endian::Little, 4) => out.extend_from_slice(&(v as u32).to_le_bytes()),
            (Endian::Big, 4) => out.extend_from_slice(&(v as u32).to_be_bytes()),
            (Endian::Little, _) => out.extend_from_slice(&v.to_le_bytes()),
            (Endian::Big, _) => out.extend_from_slice(&v.to_be_bytes()),
        };
        let real = |out: &mut Vec<u8>, v: f64| match endian {
            Endian::Little => out.extend_from_slice(&v.to_le_bytes()),
            Endian::Big => out.extend_from_slice(&v.to_be_bytes()),
        };
        int(&mut out, 1);
        out.extend_from_slice(b"\n$EndMeshFormat\n$Nodes\n");
        for v in [1, 9, 1, 9] {
            size(&mut out, v);
        }
        int(&mut out, 3);
        int(&mut out, 1);
        int(&mut out, 0);
        size(&mut out, 9);
        for tag in 1..=9 {
            size(&mut out, tag);
        }
        let xyz = [
            [0., 0., 0.],
            [1., 0., 0.],
            [1., 1., 0.],
            [0., 1., 0.],
            [0., 0., 1.],
            [1., 0., 1.],
            [1., 1., 1.],
            [0., 1., 1.],
            [0.5, 0.5, 2.],
        ];
        for p in xyz {
            for c in p {
                real(&mut out, c);
            }
        }
        out.extend_from_slice(b"\n$EndNodes\n$Elements\n");
        for v in [2, 2, 1, 2] {
            size(&mut out, v);
        }
        for (ty, tag, nodes) in [(5, 1u64, &[1u64, 2, 3, 4, 5, 6, 7, 8][..]), (7, 2, &[5, 6, 7, 8, 9][..])] {
            int(&mut out, 3);
            int(&mut out, 1);
            int(&mut out, ty);
            size(&mut out, 1);
            size(&mut out, tag);
            for &n in nodes {
                size(&mut out, n);
            }
        }
        out.extend_from_slice(b"\n$EndElements\n$ElementData\n1\n\"q\"\n1\n0\n3\n0\n1\n2\n");
        for (tag, v) in [(1, 0.5), (2, 0.75)] {
            int(&mut out, tag);
            real(&mut out, v);
        }
        out.extend_from_slice(b"\n$EndElementData\n");
        out
    }

    #[test]
    fn binary_41_both_byte_orders_and_size_t_widths() {
        for endian in [Endian::Little, Endian::Big] {
            for size_bytes in [4, 8] {
                let bytes = binary_41(endian, size_bytes);
                let m = read(&bytes).unwrap_or_else(|e| panic!("{endian:?} {size_bytes}: {e}"));
                assert_eq!(m.format, "Gmsh 4.1 (binary)");
                assert_eq!(m.points[8], [0.5, 0.5, 2.0]);
                assert_eq!(cells(&m).nodes(1), &[4, 5, 6, 7, 8]);
                let q = m.cell_fields.iter().find(|f| f.name == "q").unwrap();
                assert_eq!(q.values, vec![0.5, 0.75]);
            }
        }
    }

    #[test]
    fn binary_big_endian_22() {
        let mut out = b"$MeshFormat\n2.2 1 8\n".to_vec();
        out.extend_from_slice(&1i32.to_be_bytes());
        out.extend_from_slice(b"\n$EndMeshFormat\n$Nodes\n4\n");
        for (tag, p) in [(1, [0., 0., 0.]), (2, [1., 0., 0.]), (3, [0., 1., 0.]), (4, [0., 0., 1.])] {
            out.extend_from_slice(&i32::to_be_bytes(tag));
            for c in p {
                out.extend_from_slice(&f64::to_be_bytes(c));
            }
        }
        out.extend_from_slice(b"\n$EndNodes\n$Elements\n2\n");
        // A triangle block, then a tetrahedron block; 2 tags each.
        for v in [2, 1, 2, 10, 5, 9, 1, 2, 3, 4, 1, 2, 11, 6, 3, 1, 2, 3, 4] {
            out.extend_from_slice(&i32::to_be_bytes(v));
        }
        out.extend_from_slice(b"\n$EndElements\n");
        let m = read(&out).unwrap();
        assert_eq!(m.format, "Gmsh 2.2 (binary)");
        assert_eq!(cells(&m).nodes(0), &[0, 1, 2, 3]);
        let geo = m.cell_fields.iter().find(|f| f.name == GEOMETRICAL_FIELD).unwrap();
        assert_eq!(geo.values, vec![3.0]);
        // A block claiming more elements than the section is rejected.
        let mut bad = out.clone();
        let at = find(&bad, b"$Elements\n2\n").unwrap() + 12 + 4;
        bad[at..at + 4].copy_from_slice(&7i32.to_be_bytes());
        let e = read(&bad).unwrap_err();
        assert!(e.message.contains("overruns"), "{e}");
        assert!(matches!(e.at, Location::Byte(_)));
    }

    #[test]
    fn hostile_headers_fail_cleanly() {
        let cases: &[&[u8]] = &[
            b"",
            b"$MeshFormat\n",
            b"$MeshFormat\n4.0 0 8\n$EndMeshFormat\n",
            b"$MeshFormat\n2.2 0 8\n$EndMeshFormat\n$Nodes\n18446744073709551615\n1 0 0 0\n$EndNodes\n",
            b"$MeshFormat\n2.2 0 8\n$EndMeshFormat\n$Nodes\n-3\n$EndNodes\n",
            b"$MeshFormat\n2.2 1 8\n\x01\x00\x00\x00\n$EndMeshFormat\n$Nodes\n99999999999999\n",
            b"$MeshFormat\n4.1 1 8\n\x01\x00\x00\x00\n$EndMeshFormat\n$Nodes\n\xff\xff\xff\xff\xff\xff\xff\xff",
            b"$MeshFormat\n4.1 0 8\n$EndMeshFormat\n$Nodes\n1 3 1 3\n0 1 0 18446744073709551615\n$EndNodes\n",
            b"$MeshFormat\n4.1 0 8\n$EndMeshFormat\n$Nodes\n1 1 1 1\n3 1 7 1\n1\n0 0 0\n$EndNodes\n",
            b"$MeshFormat\n2.2 0 8\n$EndMeshFormat\n$Nodes\n1\n1 0 0 0\n$EndNodes\n$NodeData\n1\n\"x\"\n0\n3\n0\n4000000000\n1\n",
            b"$MeshFormat\n2.2 0 8\n$EndMeshFormat\n$Nodes\n1\n1 zero 0 0\n$EndNodes\n",
            b"$MeshFormat\n2.2 0 8\n$EndMeshFormat\n$Comments\nnever closed\n",
            b"$MeshFormat\n2.2 3 8\n$EndMeshFormat\n",
            b"$NOD\n1\n1 0 0 0\n$ENDNOD\n",
        ];
        for case in cases {
            assert!(read(case).is_err(), "accepted: {:?}", String::from_utf8_lossy(case));
        }
    }
}
