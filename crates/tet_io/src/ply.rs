//! PLY (Stanford polygon format) point clouds: `ascii`,
//! `binary_little_endian` and `binary_big_endian`.
//!
//! The `vertex` element becomes the points: its `x`, `y`, `z` properties are
//! the coordinates and every other scalar property one point field of the
//! same name (`nx`, `ny`, `nz`, `red`, `lum`, … each stay separate fields).
//! List properties of the vertex element and every other element (faces,
//! edges, …) are skipped with a note: the result has no cells, it is a point
//! cloud for the Delaunay step. Elements before `vertex` are parsed only to
//! find where the vertex data starts; elements after it are not read.
//!
//! Declared counts are never trusted: binary records are taken through
//! [`ByteCursor::take_array`], and nothing is reserved beyond what the
//! remaining input can hold.

use tet_mesh::{Field, SourceMesh};

use crate::cursor::{clip, parse_f64, ByteCursor, Endian, ScalarType, TextCursor};
use crate::{FormatError, Location};

#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum Encoding {
    Ascii,
    Binary(Endian),
}

#[derive(Debug, Clone)]
enum PropKind {
    Scalar(ScalarType),
    List { count: ScalarType, item: ScalarType },
}

#[derive(Debug, Clone)]
struct Property {
    name: String,
    kind: PropKind,
}

#[derive(Debug, Clone)]
struct Element {
    name: String,
    count: u64,
    props: Vec<Property>,
    line: usize,
}

/// PLY's type names, old (`uchar`) and new (`uint8`) spellings.
fn ply_type(name: &str) -> Option<ScalarType> {
    Some(match name {
        "char" | "int8" => ScalarType::I8,
        "uchar" | "uint8" => ScalarType::U8,
        "short" | "int16" => ScalarType::I16,
        "ushort" | "uint16" => ScalarType::U16,
        "int" | "int32" => ScalarType::I32,
        "uint" | "uint32" => ScalarType::U32,
        "float" | "float32" => ScalarType::F32,
        "double" | "float64" => ScalarType::F64,
        _ => return None,
    })
}

struct Header {
    encoding: Encoding,
    elements: Vec<Element>,
    /// Byte offset of the first data byte.
    data_start: usize,
    /// Line number of the first data line (ASCII).
    data_line: usize,
}

fn parse_header(bytes: &[u8]) -> Result<Header, FormatError> {
    let mut t = TextCursor::new(bytes);
    match t.line_str() {
        Some("ply") => {}
        _ => return Err(FormatError::new(Location::Line(1), "not a PLY file: the first line must be 'ply'")),
    }
    let mut encoding = None;
    let mut elements: Vec<Element> = Vec::new();
    loop {
        let line_no = t.line();
        let Some(line) = t.line_str() else {
            return Err(FormatError::new(Location::Line(line_no), "unexpected end of file inside the PLY header"));
        };
        let err = |msg: String| FormatError::new(Location::Line(line_no), msg);
        let mut tok = line.split_ascii_whitespace();
        match tok.next() {
            None | Some("comment") | Some("obj_info") => {}
            Some("end_header") => break,
            Some("format") => {
                encoding = Some(match tok.next() {
                    Some("ascii") => Encoding::Ascii,
                    Some("binary_little_endian") => Encoding::Binary(Endian::Little),
                    Some("binary_big_endian") => Encoding::Binary(Endian::Big),
                    other => {
                        return Err(err(format!(
                            "unknown PLY format '{}'; expected ascii, binary_little_endian or binary_big_endian",
                            clip(other.unwrap_or(""))
                        )))
                    }
                });
            }
            Some("element") => {
                let name = tok.next().ok_or_else(|| err("element without a name".into()))?;
                let count_tok = tok.next().ok_or_else(|| err(format!("element '{}' without a count", clip(name))))?;
                let count = count_tok.parse::<u64>().map_err(|_| {
                    err(format!("element '{}': expected a record count, found '{}'", clip(name), clip(count_tok)))
                })?;
                elements.push(Element { name: name.to_string(), count, props: Vec::new(), line: line_no });
            }
            Some("property") => {
                let el = elements.last_mut().ok_or_else(|| err("property before any element".into()))?;
                let kind = match tok.next() {
                    Some("list") => {
                        let (c, i) = (tok.next().unwrap_or(""), tok.next().unwrap_or(""));
                        let count = ply_type(c).ok_or_else(|| err(format!("unknown list count type '{}'", clip(c))))?;
                        if matches!(count, ScalarType::F32 | ScalarType::F64) {
                            return Err(err(format!("list count type '{c}' is not an integer type")));
                        }
                        let item = ply_type(i).ok_or_else(|| err(format!("unknown list item type '{}'", clip(i))))?;
                        PropKind::List { count, item }
                    }
                    Some(ty) => PropKind::Scalar(
                        ply_type(ty).ok_or_else(|| err(format!("unknown property type '{}'", clip(ty))))?,
                    ),
                    None => return Err(err("property without a type".into())),
                };
                let name = tok.next().ok_or_else(|| err("property without a name".into()))?;
                if el.props.iter().any(|p| p.name == name) {
                    return Err(err(format!("element '{}' has property '{}' twice", clip(&el.name), clip(name))));
                }
                el.props.push(Property { name: name.to_string(), kind });
            }
            Some(other) => return Err(err(format!("unknown PLY header keyword '{}'", clip(other)))),
        }
    }
    let encoding = encoding.ok_or_else(|| FormatError::new(Location::Line(2), "PLY header has no 'format' line"))?;
    Ok(Header { encoding, elements, data_start: t.offset(), data_line: t.line() })
}

/// Decodes one scalar of type `ty` from the front of `b` (which holds at
/// least `ty.size()` bytes).
fn scalar_at(b: &[u8], ty: ScalarType, e: Endian) -> f64 {
    macro_rules! get {
        ($t:ty, $n:expr) => {{
            let arr: [u8; $n] = b[..$n].try_into().expect("size checked by caller");
            (match e {
                Endian::Little => <$t>::from_le_bytes(arr),
                Endian::Big => <$t>::from_be_bytes(arr),
            }) as f64
        }};
    }
    match ty {
        ScalarType::I8 => b[0] as i8 as f64,
        ScalarType::U8 => b[0] as f64,
        ScalarType::I16 => get!(i16, 2),
        ScalarType::U16 => get!(u16, 2),
        ScalarType::I32 => get!(i32, 4),
        ScalarType::U32 => get!(u32, 4),
        ScalarType::I64 => get!(i64, 8),
        ScalarType::U64 => get!(u64, 8),
        ScalarType::F32 => get!(f32, 4),
        ScalarType::F64 => get!(f64, 8),
    }
}

/// A list length read from the file as a usable count.
fn list_len(v: f64, at: Location, prop: &str) -> Result<usize, FormatError> {
    if v < 0.0 || v.fract() != 0.0 || v > u32::MAX as f64 {
        return Err(FormatError::new(at, format!("list property '{}' has an invalid length {v}", clip(prop))));
    }
    Ok(v as usize)
}

/// Smallest number of bytes a binary record of `el` can take.
fn min_record_size(el: &Element) -> usize {
    el.props
        .iter()
        .map(|p| match p.kind {
            PropKind::Scalar(t) => t.size(),
            PropKind::List { count, .. } => count.size(),
        })
        .sum()
}

/// Where each vertex property goes: a coordinate, a field column, or nowhere.
#[derive(Clone, Copy)]
enum Sink {
    Coord(usize),
    Field(usize),
    Skip,
}

/// Reads a PLY file's vertices and their scalar properties.
pub fn read(bytes: &[u8]) -> Result<SourceMesh, FormatError> {
    let header = parse_header(bytes)?;
    let vi = header.elements.iter().position(|e| e.name == "vertex").ok_or_else(|| {
        FormatError::new(Location::Whole, "PLY header declares no 'vertex' element, so there are no points")
    })?;
    let vertex = &header.elements[vi];
    let at_header = Location::Line(vertex.line);
    if vertex.count > u64::from(u32::MAX) {
        return Err(FormatError::new(at_header, format!("{} vertices are more than tetkit indexes", vertex.count)));
    }
    let count = vertex.count as usize;

    let mut sinks = Vec::with_capacity(vertex.props.len());
    let mut field_names = Vec::new();
    let mut notes = Vec::new();
    let mut coord_found = [false; 3];
    for p in &vertex.props {
        let sink = match (&p.kind, p.name.as_str()) {
            (PropKind::Scalar(_), "x") => Sink::Coord(0),
            (PropKind::Scalar(_), "y") => Sink::Coord(1),
            (PropKind::Scalar(_), "z") => Sink::Coord(2),
            (PropKind::Scalar(_), name) => {
                field_names.push(name.to_string());
                Sink::Field(field_names.len() - 1)
            }
            (PropKind::List { .. }, name) => {
                notes.push(format!("skipped the list property '{name}' of the vertex element"));
                Sink::Skip
            }
        };
        if let Sink::Coord(k) = sink {
            coord_found[k] = true;
        }
        sinks.push(sink);
    }
    for (k, found) in coord_found.iter().enumerate() {
        if !found {
            return Err(FormatError::new(
                at_header,
                format!("the vertex element has no scalar property '{}'", ["x", "y", "z"][k]),
            ));
        }
    }
    for el in header.elements.iter().filter(|e| e.name != "vertex") {
        notes.push(format!(
            "skipped the element '{}' ({} records): a point cloud keeps only vertices",
            el.name, el.count
        ));
    }

    // Allocations grow with what the input actually holds: every record
    // takes at least one byte, binary or ASCII.
    let data_len = bytes.len() - header.data_start;
    let cap = count.min(data_len);
    let mut points: Vec<[f64; 3]> = Vec::with_capacity(cap);
    let mut columns: Vec<Vec<f64>> = field_names.iter().map(|_| Vec::with_capacity(cap)).collect();
    let mut p = [0.0; 3];
    let store = |sink: Sink, v: f64, p: &mut [f64; 3], columns: &mut Vec<Vec<f64>>| match sink {
        Sink::Coord(k) => p[k] = v,
        Sink::Field(f) => columns[f].push(v),
        Sink::Skip => {}
    };

    let format = match header.encoding {
        Encoding::Ascii => {
            let mut t = TextCursor::new(&bytes[header.data_start..]);
            // TextCursor counts from line 1; shift to file lines.
            let line0 = header.data_line - 1;
            let loc = |t: &TextCursor| Location::Line(t.line() + line0);
            let value = |t: &mut TextCursor, what: &str, el: &str, r: u64| -> Result<f64, FormatError> {
                let at = loc(t);
                let tok = t.token().ok_or_else(|| {
                    FormatError::new(at, format!("unexpected end of file in {el} {r}, expected {what}"))
                })?;
                parse_f64(tok).ok_or_else(|| {
                    FormatError::new(loc(t), format!("{el} {r}: expected {what}, found '{}'", clip(tok)))
                })
            };
            for el in &header.elements[..=vi] {
                let is_vertex = el.name == "vertex";
                if el.props.is_empty() {
                    continue; // no tokens to read, however many records
                }
                for r in 0..el.count {
                    for (pi, prop) in el.props.iter().enumerate() {
                        match prop.kind {
                            PropKind::Scalar(_) => {
                                let v = value(&mut t, &format!("property '{}'", prop.name), &el.name, r)?;
                                if is_vertex {
                                    store(sinks[pi], v, &mut p, &mut columns);
                                }
                            }
                            PropKind::List { .. } => {
                                let at = loc(&t);
                                let n = value(&mut t, &format!("the length of list '{}'", prop.name), &el.name, r)?;
                                for _ in 0..list_len(n, at, &prop.name)? {
                                    value(&mut t, &format!("an item of list '{}'", prop.name), &el.name, r)?;
                                }
                            }
                        }
                    }
                    if is_vertex {
                        points.push(p);
                    }
                }
            }
            "PLY (ascii)"
        }
        Encoding::Binary(e) => {
            let mut c = ByteCursor::with_base(&bytes[header.data_start..], header.data_start as u64);
            for el in &header.elements[..=vi] {
                let is_vertex = el.name == "vertex";
                let fixed = el.props.iter().all(|p| matches!(p.kind, PropKind::Scalar(_)));
                let what = format!("'{}' data ({} records)", el.name, el.count);
                if fixed {
                    let size = min_record_size(el);
                    let n = usize::try_from(el.count).unwrap_or(usize::MAX);
                    let data = c.take_array(n, size, &what)?;
                    if !is_vertex || size == 0 {
                        continue;
                    }
                    // Property offsets within a record.
                    let mut offsets = Vec::with_capacity(el.props.len());
                    let mut off = 0;
                    for prop in &el.props {
                        offsets.push(off);
                        if let PropKind::Scalar(t) = prop.kind {
                            off += t.size();
                        }
                    }
                    for rec in data.chunks_exact(size) {
                        for (pi, prop) in el.props.iter().enumerate() {
                            if let PropKind::Scalar(ty) = prop.kind {
                                store(sinks[pi], scalar_at(&rec[offsets[pi]..], ty, e), &mut p, &mut columns);
                            }
                        }
                        points.push(p);
                    }
                } else {
                    // Records of varying size: walk them one property at a time.
                    for _ in 0..el.count {
                        for (pi, prop) in el.props.iter().enumerate() {
                            match prop.kind {
                                PropKind::Scalar(ty) => {
                                    let v = scalar_at(c.take(ty.size(), &what)?, ty, e);
                                    if is_vertex {
                                        store(sinks[pi], v, &mut p, &mut columns);
                                    }
                                }
                                PropKind::List { count, item } => {
                                    let at = c.location();
                                    let n =
                                        list_len(scalar_at(c.take(count.size(), &what)?, count, e), at, &prop.name)?;
                                    c.take_array(n, item.size(), &what)?;
                                }
                            }
                        }
                        if is_vertex {
                            points.push(p);
                        }
                    }
                }
            }
            match e {
                Endian::Little => "PLY (binary little-endian)",
                Endian::Big => "PLY (binary big-endian)",
            }
        }
    };

    let point_fields = field_names.into_iter().zip(columns).map(|(name, values)| Field::new(name, 1, values)).collect();
    let mesh = SourceMesh { points, point_fields, notes, format: format.to_string(), ..Default::default() };
    mesh.check().map_err(|e| FormatError::new(Location::Whole, e))?;
    Ok(mesh)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn ascii_with_faces_and_a_list_property() {
        let text = b"ply\nformat ascii 1.0\ncomment made by hand\nelement vertex 3\nproperty float x\n\
property float y\nproperty float z\nproperty list uchar int tags\nproperty uchar red\n\
element face 1\nproperty list uchar int vertex_indices\nend_header\n\
0 0 0 2 7 8 255\n1 0 0 0 128\n0 1 0.5 1 9 0\n3 0 1 2\n";
        let m = read(text).unwrap();
        assert_eq!(m.points, vec![[0.0, 0.0, 0.0], [1.0, 0.0, 0.0], [0.0, 1.0, 0.5]]);
        assert_eq!(m.point_fields.len(), 1);
        assert_eq!(m.point_fields[0].name, "red");
        assert_eq!(m.point_fields[0].values, vec![255.0, 128.0, 0.0]);
        assert!(m.blocks.is_empty());
        assert_eq!(m.notes.len(), 2, "{:?}", m.notes);
        assert_eq!(m.format, "PLY (ascii)");
    }

    #[test]
    fn big_endian_after_another_element() {
        let mut f = b"ply\nformat binary_big_endian 1.0\nelement camera 1\nproperty list uchar short k\n\
element vertex 2\nproperty double x\nproperty double y\nproperty double z\nproperty short s\nend_header\n"
            .to_vec();
        f.extend_from_slice(&[2, 0, 1, 0, 2]);
        for (xyz, s) in [([1.0f64, 2.0, 3.0], -5i16), ([4.0, 5.0, 6.0], 7)] {
            for v in xyz {
                f.extend_from_slice(&v.to_be_bytes());
            }
            f.extend_from_slice(&s.to_be_bytes());
        }
        let m = read(&f).unwrap();
        assert_eq!(m.points, vec![[1.0, 2.0, 3.0], [4.0, 5.0, 6.0]]);
        assert_eq!(m.point_fields[0].values, vec![-5.0, 7.0]);
        assert_eq!(m.format, "PLY (binary big-endian)");
    }

    #[test]
    fn hostile_headers_are_errors() {
        let cases: [&[u8]; 7] = [
            b"ply\nformat binary_little_endian 1.0\nelement vertex 18446744073709551615\nproperty float x\nproperty float y\nproperty float z\nend_header\n",
            b"ply\nformat binary_little_endian 1.0\nelement vertex 4000000000\nproperty float x\nproperty float y\nproperty float z\nend_header\n",
            b"ply\nformat ascii 1.0\nelement vertex 1\nproperty quad x\nend_header\n",
            b"ply\nformat ascii 1.0\nelement vertex 1\nproperty list float int x\nend_header\n",
            b"ply\nformat ascii 1.0\nelement vertex 1\nproperty float x\nproperty float y\nend_header\n0 0\n",
            b"ply\nformat ebcdic 1.0\n",
            b"ply\nformat binary_little_endian 1.0\nelement face 99999999999\nproperty list uint uint v\nelement vertex 1\nproperty float x\nproperty float y\nproperty float z\nend_header\n\xff\xff\xff\xff",
        ];
        for c in cases {
            let e = read(c).unwrap_err();
            assert!(!e.message.is_empty());
        }
    }
}
