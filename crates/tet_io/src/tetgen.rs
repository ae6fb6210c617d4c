//! TetGen `.node` + `.ele` reader.
//!
//! `.node`: `npoints dim nattributes nmarkers`, then `index x y z [attributes]
//! [marker]` per point. `.ele`: `ntets nodes_per_tet nattributes`, then
//! `index n1 .. n4 [.. n10] [attributes]`. `#` starts a comment anywhere;
//! blank lines are ignored. As in TetGen, the first point's index (0 or 1)
//! fixes the numbering the `.ele` node references use; indices must then
//! run consecutively. Ten-node tets (`-o2`) keep their nodes, put in VTK's
//! order and cut at them later, when their edge nodes sit where TetGen's
//! order says (else they are reduced to their corners, with a note).
//!
//! Point attributes become point fields `attribute_0`, `attribute_1`, …, the
//! boundary markers the point field `boundary_marker`; the first tetrahedron
//! attribute (TetGen's region attribute, `-A`) becomes the cell field
//! `region`, further ones `attribute_1`, …. Ten-node (`-o2`) tetrahedra keep
//! their four corners, which TetGen lists first. Errors in the `.ele` file are
//! marked with [`FormatError::companion`].

use std::path::{Path, PathBuf};

use tet_mesh::{Block, CellType, Cells, Field};

use crate::cursor::{clip, parse_f64, TextCursor};
use crate::{FormatError, Location, SourceMesh};

/// Given a `.node` or `.ele` path, or the basename without either extension
/// (`mesh.1`), returns the `.node` and `.ele` paths.
pub fn companion_paths(path: &Path) -> (PathBuf, PathBuf) {
    let base = match path.extension().and_then(|e| e.to_str()) {
        Some(e) if e.eq_ignore_ascii_case("node") || e.eq_ignore_ascii_case("ele") => path.with_extension(""),
        _ => path.to_path_buf(),
    };
    let mut node = base.clone().into_os_string();
    node.push(".node");
    let mut ele = base.into_os_string();
    ele.push(".ele");
    (node.into(), ele.into())
}

/// A ten-node tet's nodes in VTK's order (corners, then the midpoints of
/// edges 0-1, 1-2, 2-0, 0-3, 1-3, 2-3): for each, its place in TetGen's
/// `-o2` order, whose edge nodes lie on edges 2-3, 0-3, 0-1, 1-2, 1-3, 0-2
/// (read off TetGen 1.5's output, `tests/data/tetgen/twobox_o2.1.*`).
const TET10_AS_VTK: [usize; 10] = [0, 1, 2, 3, 6, 7, 9, 5, 8, 4];

/// Whether every ten-node tet's edge nodes (VTK order) sit at the middles
/// of their edges, to 1e-3 of the edge's length (TetGen prints coordinates
/// rounded): TetGen's `-o2` puts them there, so this tells its order was
/// read right (another edge's middle is a good part of an edge away).
fn edge_nodes_at_midpoints(mesh: &SourceMesh) -> bool {
    let edges = CellType::QuadraticTetra.straight_sided_parents();
    let Some(Block::Unstructured(cells)) = mesh.blocks.first() else { return true };
    (0..cells.len()).filter(|&c| cells.types[c] == CellType::QuadraticTetra).all(|c| {
        let n = cells.nodes(c);
        let p = |k: usize| mesh.points[n[k] as usize];
        edges.iter().enumerate().all(|(e, ab)| {
            let (pa, pb, m) = (p(ab[0]), p(ab[1]), p(4 + e));
            let len = (0..3).map(|x| (pa[x] - pb[x]).powi(2)).sum::<f64>().sqrt();
            (0..3).all(|x| (m[x] - 0.5 * (pa[x] + pb[x])).abs() <= 1e-3 * len)
        })
    })
}

/// Reads a TetGen mesh from the contents of its `.node` and `.ele` files.
pub fn read(node: &[u8], ele: &[u8]) -> Result<SourceMesh, FormatError> {
    let nodes = read_node(node)?;
    let (cells, cell_fields, quadratic) =
        read_ele(ele, nodes.first_index, nodes.points.len()).map_err(FormatError::companion)?;
    let mut mesh = SourceMesh {
        format: "TetGen .node/.ele".to_string(),
        points: nodes.points,
        point_fields: nodes.fields,
        blocks: vec![Block::Unstructured(cells)],
        cell_fields,
        ..Default::default()
    };
    if quadratic > 0 && !edge_nodes_at_midpoints(&mesh) {
        // Another TetGen's order, or moved nodes: cut at them the tets
        // would overlap, so only the corners are trusted.
        mesh.reduce_to_corners();
        mesh.notes.push(format!(
            "reduced {quadratic} ten-node tetrahedra to their corner nodes: their edge nodes are not at the middles of the edges TetGen's order puts them on"
        ));
    }
    if nodes.first_index == 0 {
        mesh.notes.push("TetGen numbering starts at 0".to_string());
    }
    mesh.check().map_err(|e| FormatError::new(Location::Whole, e))?;
    Ok(mesh)
}

/// Non-blank lines with comments removed, with their 1-based line numbers.
struct Lines<'a> {
    t: TextCursor<'a>,
}

impl<'a> Lines<'a> {
    fn new(bytes: &'a [u8]) -> Self {
        Lines { t: TextCursor::new(bytes) }
    }

    /// The next line holding data, or `None` at the end of the file.
    fn next_data(&mut self) -> Option<(usize, &'a str)> {
        loop {
            let line_no = self.t.line();
            let line = self.t.line_str()?;
            let data = line.split('#').next().unwrap_or("");
            if !data.trim().is_empty() {
                return Some((line_no, data));
            }
        }
    }

    /// The next data line, or an error saying what was missing (`what` is
    /// only called on failure, so the hot path builds no message).
    fn expect(&mut self, what: impl FnOnce() -> String) -> Result<(usize, &'a str), FormatError> {
        let at = self.t.line();
        self.next_data()
            .ok_or_else(|| FormatError::new(Location::Line(at), format!("unexpected end of file, expected {}", what())))
    }
}

fn parse_int(tok: Option<&str>, what: &str, line: usize) -> Result<i64, FormatError> {
    let tok = tok.ok_or_else(|| FormatError::new(Location::Line(line), format!("missing {what}")))?;
    tok.parse::<i64>()
        .map_err(|_| FormatError::new(Location::Line(line), format!("expected {what}, found '{}'", clip(tok))))
}

fn parse_real(tok: Option<&str>, what: &str, line: usize) -> Result<f64, FormatError> {
    let tok = tok.ok_or_else(|| FormatError::new(Location::Line(line), format!("missing {what}")))?;
    parse_f64(tok)
        .ok_or_else(|| FormatError::new(Location::Line(line), format!("expected {what}, found '{}'", clip(tok))))
}

/// A header count: absent means `default`; present must lie in `range`.
fn header_count(
    tok: Option<&str>,
    what: &str,
    line: usize,
    default: i64,
    range: std::ops::RangeInclusive<i64>,
) -> Result<usize, FormatError> {
    let v = match tok {
        None => default,
        Some(_) => parse_int(tok, what, line)?,
    };
    if !range.contains(&v) {
        return Err(FormatError::new(
            Location::Line(line),
            format!("{what} must be {} to {}, found {v}", range.start(), range.end()),
        ));
    }
    Ok(v as usize)
}

/// Checks that the record index on `line` continues the numbering.
fn check_index(index: i64, expected: i64, what: &str, line: usize) -> Result<(), FormatError> {
    if index != expected {
        return Err(FormatError::new(
            Location::Line(line),
            format!("{what} index {index} breaks the numbering: expected {expected}"),
        ));
    }
    Ok(())
}

/// Splits row-major `values` (`rows × width`) into one single-component
/// field per column.
fn column_fields(values: &[f64], width: usize, name: impl Fn(usize) -> String) -> Vec<Field> {
    (0..width).map(|k| Field::new(name(k), 1, values.iter().skip(k).step_by(width).copied().collect())).collect()
}

struct NodeFile {
    points: Vec<[f64; 3]>,
    fields: Vec<Field>,
    first_index: i64,
}

fn read_node(bytes: &[u8]) -> Result<NodeFile, FormatError> {
    let mut lines = Lines::new(bytes);
    let (line, header) = lines.expect(|| "the .node header (npoints dim nattributes nmarkers)".into())?;
    let mut tok = header.split_ascii_whitespace();
    let count = parse_int(tok.next(), "the number of points", line)?;
    if count == 0 {
        return Err(FormatError::new(
            Location::Line(line),
            "the .node file declares 0 points (TetGen then takes them from a .poly file, which is not read here)",
        ));
    }
    let count = u64::try_from(count)
        .map_err(|_| FormatError::new(Location::Line(line), format!("negative number of points {count}")))?;
    if count > u64::from(u32::MAX) {
        return Err(FormatError::new(Location::Line(line), format!("{count} points are more than tetkit indexes")));
    }
    let dim = header_count(tok.next(), "the dimension", line, 3, 3..=3)?;
    let num_attributes = header_count(tok.next(), "the number of point attributes", line, 0, 0..=i64::from(u16::MAX))?;
    let markers = header_count(tok.next(), "the boundary marker flag", line, 0, 0..=1)? == 1;
    let _ = dim;

    let mut points = Vec::new();
    let mut attributes = Vec::new();
    let mut boundary = Vec::new();
    let mut first_index = 0;
    for i in 0..count {
        let (line, data) = lines.expect(|| format!("point {} of {count}", i + 1))?;
        let mut tok = data.split_ascii_whitespace();
        let index = parse_int(tok.next(), "a point index", line)?;
        if i == 0 {
            if index != 0 && index != 1 {
                return Err(FormatError::new(
                    Location::Line(line),
                    format!("the first point index must be 0 or 1, found {index}"),
                ));
            }
            first_index = index;
        } else {
            check_index(index, first_index + i as i64, "point", line)?;
        }
        let x = parse_real(tok.next(), "the x coordinate", line)?;
        let y = parse_real(tok.next(), "the y coordinate", line)?;
        let z = parse_real(tok.next(), "the z coordinate", line)?;
        points.push([x, y, z]);
        for _ in 0..num_attributes {
            attributes.push(parse_real(tok.next(), "a point attribute", line)?);
        }
        if markers {
            boundary.push(parse_int(tok.next(), "a boundary marker", line)? as f64);
        }
    }
    let mut fields = column_fields(&attributes, num_attributes, |k| format!("attribute_{k}"));
    if markers {
        fields.push(Field::new("boundary_marker", 1, boundary));
    }
    Ok(NodeFile { points, fields, first_index })
}

/// Reads the `.ele` file; node references are `first_index`-based.
fn read_ele(bytes: &[u8], first_index: i64, num_points: usize) -> Result<(Cells, Vec<Field>, usize), FormatError> {
    let mut lines = Lines::new(bytes);
    let (line, header) = lines.expect(|| "the .ele header (ntets nodes_per_tet nattributes)".into())?;
    let mut tok = header.split_ascii_whitespace();
    let count = parse_int(tok.next(), "the number of tetrahedra", line)?;
    let count = u64::try_from(count)
        .map_err(|_| FormatError::new(Location::Line(line), format!("negative number of tetrahedra {count}")))?;
    let per_tet = header_count(tok.next(), "the number of nodes per tetrahedron", line, 4, 4..=10)?;
    if per_tet != 4 && per_tet != 10 {
        return Err(FormatError::new(
            Location::Line(line),
            format!("nodes per tetrahedron must be 4 or 10, found {per_tet}"),
        ));
    }
    let num_attributes =
        header_count(tok.next(), "the number of tetrahedron attributes", line, 0, 0..=i64::from(u16::MAX))?;

    let mut cells = Cells::new();
    let mut attributes = Vec::new();
    let mut first_tet = 0;
    let mut nodes = [0u32; 10];
    for i in 0..count {
        let (line, data) = lines.expect(|| format!("tetrahedron {} of {count}", i + 1))?;
        let mut tok = data.split_ascii_whitespace();
        let index = parse_int(tok.next(), "a tetrahedron index", line)?;
        if i == 0 {
            first_tet = index;
        } else {
            check_index(index, first_tet.saturating_add(i as i64), "tetrahedron", line)?;
        }
        for k in 0..per_tet {
            let n = parse_int(tok.next(), "a node index", line)?;
            let local = n.checked_sub(first_index).filter(|&v| v >= 0 && (v as u64) < num_points as u64);
            let Some(local) = local else {
                return Err(FormatError::new(
                    Location::Line(line),
                    format!(
                        "tetrahedron {index} refers to node {n}, outside {first_index}..{}",
                        first_index + num_points as i64 - 1
                    ),
                ));
            };
            if let Some(slot) = nodes.get_mut(k) {
                *slot = local as u32;
            }
        }
        if per_tet == 10 {
            cells.push(CellType::QuadraticTetra, &TET10_AS_VTK.map(|k| nodes[k]));
        } else {
            cells.push(CellType::Tetra, &nodes[..4]);
        }
        for _ in 0..num_attributes {
            attributes.push(parse_real(tok.next(), "a tetrahedron attribute", line)?);
        }
    }
    let fields = column_fields(&attributes, num_attributes, |k| {
        if k == 0 {
            "region".to_string()
        } else {
            format!("attribute_{k}")
        }
    });
    let quadratic = if per_tet == 10 { cells.len() } else { 0 };
    Ok((cells, fields, quadratic))
}

#[cfg(test)]
mod tests {
    use super::*;

    const NODE: &str = "# a tetrahedron and its apex twin\n4 3 1 1\n\n1 0 0 0 0.5 7 # corner\n2 1 0 0 1.5 0\n\
        # interleaved comment\n3 0 1 0 2.5 0\n4 0 0 1 3.5 1\n";
    const ELE: &str = "1 4 1\n1 1 2 3 4 -5\n# Generated by tetgen\n";

    #[test]
    fn reads_attributes_markers_and_regions() {
        let m = read(NODE.as_bytes(), ELE.as_bytes()).unwrap();
        assert_eq!(m.points.len(), 4);
        assert_eq!(m.points[3], [0.0, 0.0, 1.0]);
        assert_eq!(m.point_fields[0].name, "attribute_0");
        assert_eq!(m.point_fields[0].values, vec![0.5, 1.5, 2.5, 3.5]);
        assert_eq!(m.point_fields[1].name, "boundary_marker");
        assert_eq!(m.point_fields[1].values, vec![7.0, 0.0, 0.0, 1.0]);
        assert_eq!(m.cell_fields[0].name, "region");
        assert_eq!(m.cell_fields[0].values, vec![-5.0]);
        match &m.blocks[0] {
            Block::Unstructured(c) => assert_eq!(c.nodes(0), &[0, 1, 2, 3]),
            _ => panic!(),
        }
    }

    /// A ten-node tet whose edge nodes are not at its edges' middles is
    /// reduced to its corners, with a note.
    #[test]
    fn zero_based_and_ten_node() {
        let node = "4 3 0 0\n0 0 0 0\n1 1 0 0\n2 0 1 0\n3 0 0 1\n";
        let ele = "1 10 2\n0 3 2 1 0 0 1 2 3 0 1 9 8\n";
        let m = read(node.as_bytes(), ele.as_bytes()).unwrap();
        match &m.blocks[0] {
            Block::Unstructured(c) => assert_eq!(c.nodes(0), &[3, 2, 1, 0]),
            _ => panic!(),
        }
        assert_eq!(m.cell_fields[1].name, "attribute_1");
        assert_eq!(m.cell_fields[1].values, vec![8.0]);
        assert!(m.notes.iter().any(|n| n.contains("ten-node")));
    }

    #[test]
    fn errors_name_the_line_and_file() {
        let gap = NODE.replace("3 0 1 0", "5 0 1 0");
        let e = read(gap.as_bytes(), ELE.as_bytes()).unwrap_err();
        assert_eq!(e.at, Location::Line(7));
        assert!(e.message.contains("index 5") && !e.in_companion, "{e}");

        let e = read(NODE.as_bytes(), b"1 4 1\n1 1 2 3 5 0\n").unwrap_err();
        assert!(e.in_companion && e.message.contains("node 5"), "{e}");
        assert_eq!(e.at, Location::Line(2));

        let e = read(NODE.as_bytes(), b"2 4 0\n1 1 2 3 4\n").unwrap_err();
        assert!(e.in_companion && e.message.contains("end of file"), "{e}");
    }

    #[test]
    fn hostile_headers_fail_cleanly() {
        let ele = ELE.as_bytes();
        for node in [
            "",
            "0 3 0 0\n",
            "-4 3 0 0\n",
            "99999999999999999999 3 0 0\n",
            "4 2 0 0\n",
            "4 3 65535 0\n1 0 0 0\n",
            "4 3 -1 0\n",
            "4 3 0 7\n",
            "4000000000 3 0 0\n1 0 0 0\n",
            "1 3 0 0\n2 0 0 0\n",
            "1 3 0 0\n1 x 0 0\n",
        ] {
            assert!(read(node.as_bytes(), ele).is_err(), "accepted {node:?}");
        }
        for ele in ["", "1 5 0\n1 1 2 3 4 5\n", "18446744073709551615 4 0\n", "1 4 0\n1 1 2 3 -4\n", "1 4 0\n1 1 2 3\n"]
        {
            let e = read(NODE.as_bytes(), ele.as_bytes()).unwrap_err();
            assert!(e.in_companion, "{ele:?}: {e}");
        }
    }

    #[test]
    fn companion_paths_from_either_file_or_basename() {
        let want = (PathBuf::from("dir/mesh.1.node"), PathBuf::from("dir/mesh.1.ele"));
        assert_eq!(companion_paths(Path::new("dir/mesh.1.node")), want);
        assert_eq!(companion_paths(Path::new("dir/mesh.1.ele")), want);
        assert_eq!(companion_paths(Path::new("dir/mesh.1")), want);
    }
}
