//! Gmsh `.msh` reader: format versions 2.x (2.2 layout) and 4.1, ASCII and
//! binary, either byte order.
//!
//! What is kept: all nodes (in file order), the volume elements — second
//! order (complete and incomplete) and complete tetrahedra, hexahedra,
//! prisms and pyramids of any higher order with all their nodes (permuted
//! into VTK's orders — VTK's Lagrange cells from the third order on; a
//! pyramid keeps Gmsh's order, VTK having none — and cut at them), other
//! higher-order elements (serendipity above second order) reduced to their
//! corner nodes, and then all of them, so that neighbours conform — `$NodeData` as point fields and `$ElementData` as cell
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
//! reducing is keeping the leading nodes, with no permutation. Its other
//! nodes follow by edges, faces and body, recursively
//! (`tet_mesh::lagrange::gmsh_tetra_lattice`, `gmsh_hexahedron_lattice`,
//! `gmsh_wedge_lattice`, `gmsh_pyramid_lattice`, checked against Gmsh's own
//! reference nodes: orders 1–10, 1–9, 1–6 and 1–9).
//!
//! Node and element tags may be sparse; they are mapped to indices through a
//! dense table only when the largest tag is within a small multiple of the
//! count (so memory stays bounded by the input size), else through a hash map.

use std::collections::HashMap;

use tet_mesh::{Block, CellType, Cells, Field};

use crate::cursor::{clip, ByteCursor, Endian, TextCursor};
use crate::{FormatError, Location, SourceMesh};

mod sections;
mod state;
mod values;

pub(crate) use sections::*;
pub(crate) use state::*;
pub(crate) use values::*;

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
pub(crate) enum Version {
    /// 2.0, 2.1 and 2.2 share one layout.
    V2,
    V41,
}

#[derive(Debug, Clone, PartialEq)]
pub(crate) struct Header {
    pub(crate) version: Version,
    /// The version as the file spells it, for `SourceMesh::format`.
    pub(crate) version_text: String,
    /// Byte order and size of `size_t` (4.1) for binary files.
    pub(crate) binary: Option<(Endian, usize)>,
}

pub(crate) fn read_mesh_format(t: &mut TextCursor) -> Result<Header, FormatError> {
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
pub(crate) fn eat_line_end(t: &mut TextCursor) -> Result<(), FormatError> {
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

pub(crate) fn expect_end(t: &mut TextCursor, name: &str) -> Result<(), FormatError> {
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
pub(crate) fn skip_section(t: &mut TextCursor, name: &str, opened_at: Location) -> Result<(), FormatError> {
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

pub(crate) fn find(hay: &[u8], needle: &[u8]) -> Option<usize> {
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
        for p in tet_mesh::split::UNIT_HEX.iter().chain([&[0.5, 0.5, 2.]]) {
            for c in p {
                real(&mut out, *c);
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
