//! How element data is read: ASCII words or binary records (Values),
//! and Gmsh's element types and their node counts.

use super::*;

/// Scalar reads shared by the ASCII and binary forms of the 4.1 sections
/// (and of the 2.2 node list): Gmsh's `int`, `size_t` and `double`.
pub(crate) trait Values {
    fn int(&mut self, what: &str) -> Result<i64, FormatError>;
    fn size(&mut self, what: &str) -> Result<u64, FormatError>;
    fn real(&mut self, what: &str) -> Result<f64, FormatError>;
    /// Appends `n` size_t values.
    fn sizes(&mut self, n: u64, what: &str, out: &mut Vec<u64>) -> Result<(), FormatError>;
    /// Appends `n` doubles.
    fn reals(&mut self, n: u64, what: &str, out: &mut Vec<f64>) -> Result<(), FormatError>;
    fn location(&self) -> Location;
}

pub(crate) struct Ascii<'t, 'a> {
    pub(crate) t: &'t mut TextCursor<'a>,
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

pub(crate) struct Binary<'a> {
    pub(crate) c: ByteCursor<'a>,
    pub(crate) endian: Endian,
    pub(crate) size_bytes: usize,
}

impl Binary<'_> {
    pub(crate) fn to_count(&self, n: u64, what: &str) -> Result<usize, FormatError> {
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

pub(crate) fn word64(ch: &[u8], e: Endian) -> u64 {
    let mut a = [0u8; 8];
    a.copy_from_slice(&ch[..8]);
    match e {
        Endian::Little => u64::from_le_bytes(a),
        Endian::Big => u64::from_be_bytes(a),
    }
}

pub(crate) fn word32(ch: &[u8], e: Endian) -> u32 {
    let mut a = [0u8; 4];
    a.copy_from_slice(&ch[..4]);
    match e {
        Endian::Little => u32::from_le_bytes(a),
        Endian::Big => u32::from_be_bytes(a),
    }
}

pub(crate) fn decode_sizes(bytes: &[u8], size_bytes: usize, e: Endian, out: &mut Vec<u64>) {
    out.reserve(bytes.len() / size_bytes);
    if size_bytes == 4 {
        out.extend(bytes.chunks_exact(4).map(|ch| u64::from(word32(ch, e))));
    } else {
        out.extend(bytes.chunks_exact(8).map(|ch| word64(ch, e)));
    }
}

/// What an element type is to this reader.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(crate) enum ElementKind {
    /// A volume element reducible to `CellType` by keeping its leading nodes.
    Volume(CellType, usize),
    /// A point, line or surface element with this many nodes.
    Lower(usize),
}

/// Gmsh element type numbers (GmshDefines.h `MSH_*`) and their node counts.
/// Polygons and polyhedra (variable node counts) and the one-node
/// "sub-element" volume types are absent: they are reported as unknown.
pub(crate) fn element_kind(type_id: i64) -> Option<ElementKind> {
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

pub(crate) fn element_nodes(kind: ElementKind) -> usize {
    match kind {
        ElementKind::Volume(_, n) | ElementKind::Lower(n) => n,
    }
}
