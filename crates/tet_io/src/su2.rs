//! SU2 native mesh reader (`.su2`, ASCII), with an optional point solution
//! from SU2's CSV output.
//!
//! The format (SU2 documentation, "Mesh File", su2code.github.io/docs_v7/Mesh-File):
//! `NDIME= 3`; `NELEM= n` followed by n lines `type node… [index]` with VTK
//! cell type ids and VTK node order (10 tetrahedron, 12 hexahedron, 13
//! prism, 14 pyramid; 3 line, 5 triangle and 9 quadrilateral are lower
//! dimensional); `NPOIN= n [ndomain]` followed by n lines `x y [z] [index]`;
//! `NMARK= m` with `MARKER_TAG=`/`MARKER_ELEMS=` boundary sections. A
//! multi-zone file starts with `NZONE= k` and opens each zone with
//! `IZONE= i`; node numbers are zone-local. `%` starts a comment; keywords
//! may come in any order and other sections (markers, periodic and FFD
//! definitions) are skipped, since only the volume cells and points are
//! needed. Node numbers start at 0.
//!
//! Errors name the line. Declared counts are never trusted for allocation:
//! a count larger than the lines left is an error at the keyword's line.
//!
//! A solution ([`attach_solution`]) is a CSV table as SU2 writes it
//! (`restart_flow.csv`, `flow.csv`: a header line `"PointID","x","y","z",
//! "Density",…`, one row per point): every column other than the
//! coordinates and `PointID` becomes a point field; rows are matched to
//! points by `PointID` when the column exists, else by order, and the
//! coordinates must agree with the mesh's.

use tet_mesh::{Block, CellType, Cells, Field};

use crate::cursor::{clip, parse_f64};
use crate::{FormatError, Location, SourceMesh};

/// Nodes per SU2/VTK element type, and the volume cell it is (None for
/// lines and faces).
fn element_kind(vtk: u32) -> Option<(usize, Option<CellType>)> {
    Some(match vtk {
        3 => (2, None),
        5 => (3, None),
        9 => (4, None),
        10 => (4, Some(CellType::Tetra)),
        12 => (8, Some(CellType::Hexahedron)),
        13 => (6, Some(CellType::Wedge)),
        14 => (5, Some(CellType::Pyramid)),
        _ => return None,
    })
}

/// Data lines with comments removed, with 1-based line numbers.
struct Lines<'a> {
    lines: std::iter::Enumerate<std::str::Lines<'a>>,
}

impl<'a> Lines<'a> {
    fn next_data(&mut self) -> Option<(usize, &'a str)> {
        for (i, line) in self.lines.by_ref() {
            let data = line.split('%').next().unwrap_or("").trim();
            if !data.is_empty() {
                return Some((i + 1, data));
            }
        }
        None
    }

    /// Item `k` (from 0) of the `n` that the section `key` (with its
    /// keyword line) announces ("elements", "points"): the next data line,
    /// or an error at the keyword line when the file ends first.
    fn next_item(
        &mut self,
        key: (&str, usize),
        n: usize,
        k: usize,
        what: &str,
    ) -> Result<(usize, &'a str), FormatError> {
        let (name, key_line) = key;
        self.next_data().ok_or_else(|| {
            FormatError::new(Location::Line(key_line), format!("{name}= {n} but the file ends after {k} {what}"))
        })
    }
}

/// `KEY= value…` → (KEY, rest), for a line that holds a keyword.
fn keyword(line: &str) -> Option<(&str, &str)> {
    let (key, rest) = line.split_once('=')?;
    let key = key.trim();
    (!key.is_empty() && key.bytes().all(|b| b.is_ascii_uppercase() || b.is_ascii_digit() || b == b'_'))
        .then_some((key, rest.trim()))
}

fn count(rest: &str, key: &str, line: usize, file_len: usize) -> Result<usize, FormatError> {
    let first = rest.split_ascii_whitespace().next().unwrap_or("");
    let n: usize = first.parse().map_err(|_| {
        FormatError::new(Location::Line(line), format!("{key}= needs a count, found '{}'", clip(first)))
    })?;
    // Each entry takes at least two bytes (a digit and a line end).
    if n > file_len / 2 + 1 {
        return Err(FormatError::new(
            Location::Line(line),
            format!("{key}= {n} is more entries than a file of {file_len} bytes can hold"),
        ));
    }
    Ok(n)
}

/// One zone's cells (zone-local node numbers) before its point offset is known.
#[derive(Default)]
struct Zone {
    first_point: usize,
    cells: Vec<(CellType, usize, [u32; 8])>,
    ndime: Option<usize>,
}

/// Reads an SU2 mesh from the file's bytes.
pub fn read(bytes: &[u8]) -> Result<SourceMesh, FormatError> {
    let text = std::str::from_utf8(bytes).map_err(|e| {
        FormatError::new(Location::Byte(e.valid_up_to() as u64), "SU2 meshes are ASCII text; found non-UTF-8 bytes")
    })?;
    let mut lines = Lines { lines: text.lines().enumerate() };
    let mut points: Vec<[f64; 3]> = Vec::new();
    let mut zones: Vec<Zone> = vec![Zone::default()];
    let mut lower = 0usize;
    let (mut seen_elem, mut seen_poin) = (false, false);
    let mut nzone: Option<usize> = None;
    while let Some((line_no, line)) = lines.next_data() {
        let Some((key, rest)) = keyword(line) else {
            // Data of a section this reader skips (markers, FFD boxes, …).
            continue;
        };
        match key {
            "NZONE" => nzone = Some(count(rest, key, line_no, bytes.len())?),
            "IZONE" => {
                // A new zone; the first IZONE opens the zone already started.
                let zone = zones.last().expect("one zone");
                if !zone.cells.is_empty() || zone.ndime.is_some() || points.len() > zone.first_point {
                    zones.push(Zone { first_point: points.len(), ..Zone::default() });
                }
            }
            "NDIME" => {
                let d = count(rest, key, line_no, bytes.len())?;
                if d == 2 {
                    return Err(FormatError::new(
                        Location::Line(line_no),
                        "a 2D SU2 mesh (NDIME= 2) has no volume cells; tetkit renders 3D meshes",
                    ));
                }
                if d != 3 {
                    return Err(FormatError::new(Location::Line(line_no), format!("NDIME= {d}: expected 3")));
                }
                zones.last_mut().expect("one zone").ndime = Some(d);
            }
            "NELEM" => {
                let n = count(rest, key, line_no, bytes.len())?;
                seen_elem = true;
                let zone = zones.last_mut().expect("one zone");
                zone.cells.reserve(n.min(bytes.len() / 16));
                for k in 0..n {
                    let (ln, data) = lines.next_item(("NELEM", line_no), n, k, "elements")?;
                    let mut tok = data.split_ascii_whitespace();
                    let ty_tok = tok.next().unwrap_or("");
                    let ty: u32 = ty_tok.parse().map_err(|_| {
                        FormatError::new(Location::Line(ln), format!("element type '{}' is not a number", clip(ty_tok)))
                    })?;
                    let (nodes, cell) = element_kind(ty).ok_or_else(|| {
                        FormatError::new(
                            Location::Line(ln),
                            format!("element type {ty} is not an SU2 type (3, 5, 9, 10, 12, 13, 14)"),
                        )
                    })?;
                    let mut ids = [0u32; 8];
                    for (j, id) in ids.iter_mut().take(nodes).enumerate() {
                        let t = tok.next().ok_or_else(|| {
                            FormatError::new(
                                Location::Line(ln),
                                format!("element of type {ty} needs {nodes} nodes, found {j}"),
                            )
                        })?;
                        *id = t.parse().map_err(|_| {
                            FormatError::new(Location::Line(ln), format!("node number '{}' is not valid", clip(t)))
                        })?;
                    }
                    match cell {
                        Some(c) => zone.cells.push((c, ln, ids)),
                        None => lower += 1,
                    }
                }
            }
            "NPOIN" => {
                let n = count(rest, key, line_no, bytes.len())?;
                seen_poin = true;
                points.reserve(n.min(bytes.len() / 8));
                for k in 0..n {
                    let (ln, data) = lines.next_item(("NPOIN", line_no), n, k, "points")?;
                    let mut p = [0.0f64; 3];
                    let mut tok = data.split_ascii_whitespace();
                    for (c, v) in p.iter_mut().enumerate() {
                        let t = tok.next().ok_or_else(|| {
                            FormatError::new(Location::Line(ln), format!("point needs 3 coordinates, found {c}"))
                        })?;
                        *v = parse_f64(t).ok_or_else(|| {
                            FormatError::new(Location::Line(ln), format!("coordinate '{}' is not a number", clip(t)))
                        })?;
                    }
                    points.push(p);
                }
            }
            _ => {}
        }
    }
    if !seen_elem || !seen_poin {
        return Err(FormatError::new(
            Location::Whole,
            format!("not an SU2 mesh: no {} section", if seen_elem { "NPOIN=" } else { "NELEM=" }),
        ));
    }
    let mut cells = Cells::new();
    let nzones = zones.len();
    for (z, zone) in zones.iter().enumerate() {
        let end = zones.get(z + 1).map_or(points.len(), |n| n.first_point);
        let zone_points = end - zone.first_point;
        for &(c, ln, ids) in &zone.cells {
            let n = c.num_nodes();
            if let Some(&bad) = ids[..n].iter().find(|&&i| i as usize >= zone_points) {
                return Err(FormatError::new(
                    Location::Line(ln),
                    format!("node {bad} is past the zone's {zone_points} points (SU2 numbers nodes from 0)"),
                ));
            }
            let global: Vec<u32> = ids[..n].iter().map(|&i| i + zone.first_point as u32).collect();
            cells.push(c, &global);
        }
    }
    let mut mesh = SourceMesh {
        format: "SU2".to_string(),
        points,
        blocks: vec![Block::Unstructured(cells)],
        ..Default::default()
    };
    if lower > 0 {
        mesh.notes.push(format!("skipped {lower} line and face elements among the volume elements"));
    }
    if nzones > 1 || nzone.is_some_and(|k| k > 1) {
        mesh.notes.push(format!("merged {nzones} zones (node numbers offset per zone)"));
    }
    mesh.check().map_err(|e| FormatError::new(Location::Whole, e))?;
    Ok(mesh)
}

/// Adds the point fields of an SU2 CSV solution (`csv`, the file's bytes)
/// to `mesh`. Errors are in the solution file's terms ([`FormatError::companion`]).
pub fn attach_solution(mesh: &mut SourceMesh, csv: &[u8]) -> Result<(), FormatError> {
    let table = crate::csv::read(csv, None).map_err(FormatError::companion)?;
    let err = |m: String| FormatError::new(Location::Whole, m).companion();
    let n = mesh.points.len();
    if table.points.len() != n {
        return Err(err(format!("the solution has {} rows, the mesh {n} points", table.points.len())));
    }
    // Row r holds point order[r]: by PointID where the column exists.
    let id_column =
        table.point_fields.iter().position(|f| f.name.eq_ignore_ascii_case("PointID") && f.num_components == 1);
    let ids = id_column.map(|k| &table.point_fields[k]);
    let order: Vec<usize> = match ids {
        Some(f) => {
            let mut seen = vec![false; n];
            let mut order = Vec::with_capacity(n);
            for (r, &v) in f.values.iter().enumerate() {
                let i = v as usize;
                if v.fract() != 0.0 || v < 0.0 || i >= n || std::mem::replace(&mut seen[i], true) {
                    return Err(err(format!("row {} has PointID {v}: not a new point of the mesh's {n}", r + 1)));
                }
                order.push(i);
            }
            order
        }
        None => (0..n).collect(),
    };
    // The coordinates must be the mesh's (SU2 writes them with ~15 digits;
    // a 2D solution has z = 0 in the table).
    let extent = mesh.points.iter().fold(0.0f64, |m, p| m.max(p[0].abs()).max(p[1].abs()).max(p[2].abs()));
    let tol = 1e-6 * extent.max(1e-300);
    for (r, &i) in order.iter().enumerate() {
        let (a, b) = (table.points[r], mesh.points[i]);
        if (0..3).any(|c| (a[c] - b[c]).abs() > tol) {
            return Err(err(format!(
                "row {} is at ({}, {}, {}) but mesh point {i} at ({}, {}, {}): the solution is for another mesh",
                r + 1,
                a[0],
                a[1],
                a[2],
                b[0],
                b[1],
                b[2]
            )));
        }
    }
    for (c, f) in table.point_fields.into_iter().enumerate() {
        if Some(c) == id_column {
            continue;
        }
        let k = f.num_components;
        let mut values = vec![0.0; n * k];
        for (r, &i) in order.iter().enumerate() {
            values[i * k..(i + 1) * k].copy_from_slice(&f.values[r * k..(r + 1) * k]);
        }
        mesh.point_fields.push(Field::new(f.name, k, values));
    }
    mesh.notes.push("point fields from the SU2 CSV solution".to_string());
    mesh.check().map_err(|e| FormatError::new(Location::Whole, e))?;
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    /// One of each volume type around a shared set of points, with a marker
    /// section, comments and an FFD block that must be skipped.
    const MIXED: &str = "% a comment\nNDIME= 3\nNELEM= 5\n\
        10 0 1 2 4 0\n\
        12 0 1 2 3 4 5 6 7 1\n\
        13 0 1 2 4 5 6\n\
        14 0 1 2 3 4\n\
        5 0 1 2\n\
        NPOIN= 8\n\
        0 0 0 0\n1 0 0 1\n1 1 0 2\n0 1 0 3\n0 0 1 4\n1 0 1 5\n1 1 1 6\n0 1 1 7\n\
        NMARK= 1\nMARKER_TAG= wall\nMARKER_ELEMS= 1\n5 0 1 2\n\
        FFD_NBOX= 1\nFFD_CORNER_POINTS= 1\n0.5 0.5 0.5\n";

    #[test]
    fn reads_every_volume_type_and_skips_the_rest() {
        let m = read(MIXED.as_bytes()).unwrap();
        assert_eq!(m.points.len(), 8);
        let Block::Unstructured(c) = &m.blocks[0] else { panic!("unstructured") };
        assert_eq!(c.types, vec![CellType::Tetra, CellType::Hexahedron, CellType::Wedge, CellType::Pyramid]);
        assert_eq!(&c.connectivity[..4], &[0, 1, 2, 4]);
        assert!(m.notes.iter().any(|n| n.contains("skipped 1 line and face")), "{:?}", m.notes);
    }

    #[test]
    fn points_before_elements_and_keywords_without_spaces() {
        let text = "NDIME=3\nNPOIN=4 4\n0 0 0\n1 0 0\n0 1 0\n0 0 1\nNELEM=1\n10 0 1 2 3\n";
        let m = read(text.as_bytes()).unwrap();
        assert_eq!(m.num_cells(), 1);
    }

    #[test]
    fn zones_offset_their_node_numbers() {
        let zone = "NDIME= 3\nNELEM= 1\n10 0 1 2 3\nNPOIN= 4\n0 0 0\n1 0 0\n0 1 0\n0 0 1\n";
        let text = format!("NZONE= 2\nIZONE= 1\n{zone}IZONE= 2\n{zone}");
        let m = read(text.as_bytes()).unwrap();
        assert_eq!(m.points.len(), 8);
        let Block::Unstructured(c) = &m.blocks[0] else { panic!("unstructured") };
        assert_eq!(c.connectivity, vec![0, 1, 2, 3, 4, 5, 6, 7]);
    }

    #[test]
    fn bad_input_is_an_error_with_its_line() {
        let cases: &[(&str, &str)] = &[
            ("NDIME= 2\nNELEM= 0\nNPOIN= 0\n", "2D SU2 mesh"),
            ("NDIME= 3\nNELEM= 2\n10 0 1 2 3\n", "ends after 1 elements"),
            ("NDIME= 3\nNELEM= 1\n10 0 1 2\nNPOIN= 0\n", "needs 4 nodes, found 3"),
            ("NDIME= 3\nNELEM= 1\n11 0 1 2 3 4 5 6 7\nNPOIN= 0\n", "element type 11"),
            ("NDIME= 3\nNELEM= 1\n10 0 1 2 9\nNPOIN= 4\n0 0 0\n1 0 0\n0 1 0\n0 0 1\n", "node 9 is past"),
            ("NDIME= 3\nNELEM= 1\n10 0 1 2 3\nNPOIN= 4\n0 0 0\n1 0 x\n0 1 0\n0 0 1\n", "'x' is not a number"),
            ("NDIME= 3\nNELEM= 99999999\n", "more entries than"),
            ("NDIME= 3\nNPOIN= 0\n", "no NELEM= section"),
        ];
        for (text, want) in cases {
            let e = read(text.as_bytes()).unwrap_err();
            assert!(e.message.contains(want), "{text:?}: {e}");
        }
        let e = read(b"NDIME= 3\nNELEM= 1\n10 0 1 2\n").unwrap_err();
        assert_eq!(e.at, Location::Line(3));
    }

    #[test]
    fn solution_columns_become_point_fields_by_point_id() {
        let mut m = read(MIXED.as_bytes()).unwrap();
        // Rows in reverse order, matched by PointID.
        let mut csv = String::from("\"PointID\",\"x\",\"y\",\"z\",\"Density\"\n");
        for i in (0..8).rev() {
            let p = m.points[i];
            csv += &format!("{i},{},{},{},{}\n", p[0], p[1], p[2], 10 + i);
        }
        attach_solution(&mut m, csv.as_bytes()).unwrap();
        let d = m.point_fields.iter().find(|f| f.name == "Density").unwrap();
        assert_eq!(d.values, (10..18).map(f64::from).collect::<Vec<_>>());
        assert!(!m.point_fields.iter().any(|f| f.name == "PointID"));
    }

    #[test]
    fn a_solution_for_another_mesh_is_refused() {
        let mut m = read(MIXED.as_bytes()).unwrap();
        let csv = "x,y,z,p\n".to_string() + &"9,9,9,1\n".repeat(8);
        let e = attach_solution(&mut m, csv.as_bytes()).unwrap_err();
        assert!(e.message.contains("another mesh") && e.in_companion, "{e}");
        let e = attach_solution(&mut m, b"x,y,z,p\n0,0,0,1\n").unwrap_err();
        assert!(e.message.contains("1 rows, the mesh 8 points"), "{e}");
    }
}
