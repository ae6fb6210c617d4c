//! Writing tetrahedral meshes as `.vtu` (appended raw binary).

use std::io::{self, BufWriter, Write};

use flate2::write::ZlibEncoder;
use flate2::Compression;
use tet_mesh::Field;

/// Options for [`write_vtu_with`].
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub struct WriteOptions {
    /// Compress every array with zlib (`vtkZLibDataCompressor`, 32 KiB
    /// blocks, fast level). Smaller files, but the whole compressed output
    /// is held in memory until the header (which lists offsets) is written.
    pub compress: bool,
}

/// Uncompressed block size VTK itself uses for zlib.
const ZLIB_BLOCK: usize = 32 * 1024;
/// Values converted to bytes per write.
const CHUNK_VALUES: usize = 8 * 1024;

/// Writes a tetrahedral mesh as a VTK XML UnstructuredGrid with appended raw
/// binary data: UInt64 headers, little endian, Float64 points, Int64
/// connectivity and offsets, UInt8 cell types (10) and every field as
/// Float64 with its component count. Data go out in large chunks through a
/// buffer; nothing is formatted per value.
///
/// Fails with `InvalidInput` when a point field does not have one tuple per
/// point or a cell field one per tet. Node indices are not checked.
pub fn write_vtu<W: Write>(
    out: W,
    points: &[[f64; 3]],
    tets: &[[u32; 4]],
    point_fields: &[Field],
    cell_fields: &[Field],
) -> io::Result<()> {
    write_vtu_with(out, points, tets, point_fields, cell_fields, WriteOptions::default())
}

/// [`write_vtu`] with options (zlib compression).
pub fn write_vtu_with<W: Write>(
    out: W,
    points: &[[f64; 3]],
    tets: &[[u32; 4]],
    point_fields: &[Field],
    cell_fields: &[Field],
    options: WriteOptions,
) -> io::Result<()> {
    for (fields, n, kind) in [(point_fields, points.len(), "point"), (cell_fields, tets.len(), "cell")] {
        for f in fields {
            if f.num_components == 0 || Some(f.values.len()) != n.checked_mul(f.num_components) {
                return Err(io::Error::new(
                    io::ErrorKind::InvalidInput,
                    format!(
                        "{kind} field '{}' has {} values, expected {n} × {} components",
                        f.name,
                        f.values.len(),
                        f.num_components
                    ),
                ));
            }
        }
    }

    // Arrays in the order they appear in the header and the appended data.
    let mut arrays: Vec<Array<'_>> = Vec::new();
    arrays.extend(point_fields.iter().map(|f| Array::Values(&f.values)));
    arrays.extend(cell_fields.iter().map(|f| Array::Values(&f.values)));
    arrays.push(Array::Points(points));
    arrays.push(Array::Connectivity(tets));
    arrays.push(Array::Offsets(tets.len()));
    arrays.push(Array::Types(tets.len()));

    let compressed: Option<Vec<Vec<u8>>> =
        if options.compress { Some(arrays.iter().map(compress_array).collect::<io::Result<_>>()?) } else { None };
    let mut offsets = Vec::with_capacity(arrays.len());
    let mut offset = 0u64;
    for (i, a) in arrays.iter().enumerate() {
        offsets.push(offset);
        offset += match &compressed {
            Some(c) => c[i].len() as u64,
            None => 8 + a.byte_len() as u64,
        };
    }

    let mut out = BufWriter::with_capacity(1 << 16, out);
    let compressor = if options.compress { r#" compressor="vtkZLibDataCompressor""# } else { "" };
    writeln!(out, r#"<?xml version="1.0"?>"#)?;
    writeln!(
        out,
        r#"<VTKFile type="UnstructuredGrid" version="1.0" byte_order="LittleEndian" header_type="UInt64"{compressor}>"#
    )?;
    writeln!(out, "  <UnstructuredGrid>")?;
    writeln!(out, r#"    <Piece NumberOfPoints="{}" NumberOfCells="{}">"#, points.len(), tets.len())?;
    let mut next = offsets.iter();
    let mut array_tag = |out: &mut BufWriter<W>, ty: &str, name: &str, ncomp: usize| -> io::Result<()> {
        let off = next.next().copied().unwrap_or(0);
        let comps = if ncomp == 1 { String::new() } else { format!(r#" NumberOfComponents="{ncomp}""#) };
        writeln!(
            out,
            r#"        <DataArray type="{ty}" Name="{}"{comps} format="appended" offset="{off}"/>"#,
            xml_escape(name)
        )
    };
    writeln!(out, "      <PointData>")?;
    for f in point_fields {
        array_tag(&mut out, "Float64", &f.name, f.num_components)?;
    }
    writeln!(out, "      </PointData>")?;
    writeln!(out, "      <CellData>")?;
    for f in cell_fields {
        array_tag(&mut out, "Float64", &f.name, f.num_components)?;
    }
    writeln!(out, "      </CellData>")?;
    writeln!(out, "      <Points>")?;
    array_tag(&mut out, "Float64", "Points", 3)?;
    writeln!(out, "      </Points>")?;
    writeln!(out, "      <Cells>")?;
    array_tag(&mut out, "Int64", "connectivity", 1)?;
    array_tag(&mut out, "Int64", "offsets", 1)?;
    array_tag(&mut out, "UInt8", "types", 1)?;
    writeln!(out, "      </Cells>")?;
    writeln!(out, "    </Piece>")?;
    writeln!(out, "  </UnstructuredGrid>")?;
    write!(out, "  <AppendedData encoding=\"raw\">\n   _")?;
    match compressed {
        Some(blocks) => {
            for b in &blocks {
                out.write_all(b)?;
            }
        }
        None => {
            for a in &arrays {
                out.write_all(&(a.byte_len() as u64).to_le_bytes())?;
                a.for_each_chunk(&mut |bytes| out.write_all(bytes))?;
            }
        }
    }
    write!(out, "\n  </AppendedData>\n</VTKFile>\n")?;
    out.flush()
}

enum Array<'a> {
    Values(&'a [f64]),
    Points(&'a [[f64; 3]]),
    Connectivity(&'a [[u32; 4]]),
    /// Int64 end offsets 4, 8, ... of this many tets.
    Offsets(usize),
    /// This many UInt8 `VTK_TETRA` (10).
    Types(usize),
}

impl Array<'_> {
    fn byte_len(&self) -> usize {
        match self {
            Array::Values(v) => v.len() * 8,
            Array::Points(p) => p.len() * 24,
            Array::Connectivity(t) => t.len() * 32,
            Array::Offsets(n) => n * 8,
            Array::Types(n) => *n,
        }
    }

    /// Feeds the little-endian bytes to `sink` in chunks of a few tens of KiB.
    fn for_each_chunk(&self, sink: &mut dyn FnMut(&[u8]) -> io::Result<()>) -> io::Result<()> {
        let mut buf: Vec<u8> = Vec::with_capacity(CHUNK_VALUES * 32);
        match self {
            Array::Values(v) => {
                for chunk in v.chunks(CHUNK_VALUES) {
                    buf.clear();
                    chunk.iter().for_each(|x| buf.extend_from_slice(&x.to_le_bytes()));
                    sink(&buf)?;
                }
            }
            Array::Points(p) => {
                for chunk in p.chunks(CHUNK_VALUES) {
                    buf.clear();
                    chunk.iter().flatten().for_each(|x| buf.extend_from_slice(&x.to_le_bytes()));
                    sink(&buf)?;
                }
            }
            Array::Connectivity(t) => {
                for chunk in t.chunks(CHUNK_VALUES) {
                    buf.clear();
                    chunk.iter().flatten().for_each(|&x| buf.extend_from_slice(&i64::from(x).to_le_bytes()));
                    sink(&buf)?;
                }
            }
            Array::Offsets(n) => {
                let mut c = 0usize;
                while c < *n {
                    let end = (c + CHUNK_VALUES).min(*n);
                    buf.clear();
                    (c..end).for_each(|i| buf.extend_from_slice(&(4 * (i as i64 + 1)).to_le_bytes()));
                    sink(&buf)?;
                    c = end;
                }
            }
            Array::Types(n) => {
                let tens = [10u8; CHUNK_VALUES];
                let mut left = *n;
                while left > 0 {
                    let k = left.min(CHUNK_VALUES);
                    sink(&tens[..k])?;
                    left -= k;
                }
            }
        }
        Ok(())
    }
}

/// One array in VTK's zlib layout: UInt64 header `[nblocks, blocksize,
/// lastblocksize, compsize_1..n]` followed by the compressed blocks.
fn compress_array(array: &Array<'_>) -> io::Result<Vec<u8>> {
    let total = array.byte_len();
    let mut blocks: Vec<Vec<u8>> = Vec::with_capacity(total.div_ceil(ZLIB_BLOCK));
    let mut pending: Vec<u8> = Vec::with_capacity(ZLIB_BLOCK);
    let compress = |bytes: &[u8]| -> io::Result<Vec<u8>> {
        let mut enc = ZlibEncoder::new(Vec::with_capacity(bytes.len() / 2 + 64), Compression::fast());
        enc.write_all(bytes)?;
        enc.finish()
    };
    array.for_each_chunk(&mut |mut bytes| {
        while !bytes.is_empty() {
            let take = (ZLIB_BLOCK - pending.len()).min(bytes.len());
            pending.extend_from_slice(&bytes[..take]);
            bytes = &bytes[take..];
            if pending.len() == ZLIB_BLOCK {
                blocks.push(compress(&pending)?);
                pending.clear();
            }
        }
        Ok(())
    })?;
    let last = if pending.is_empty() { ZLIB_BLOCK } else { pending.len() };
    if !pending.is_empty() {
        blocks.push(compress(&pending)?);
    }
    let header_words = 3 + blocks.len();
    let mut out = Vec::with_capacity(header_words * 8 + blocks.iter().map(Vec::len).sum::<usize>());
    for w in [blocks.len(), ZLIB_BLOCK, if blocks.is_empty() { 0 } else { last }] {
        out.extend_from_slice(&(w as u64).to_le_bytes());
    }
    for b in &blocks {
        out.extend_from_slice(&(b.len() as u64).to_le_bytes());
    }
    for b in &blocks {
        out.extend_from_slice(b);
    }
    Ok(out)
}

fn xml_escape(s: &str) -> String {
    let mut out = String::with_capacity(s.len());
    for ch in s.chars() {
        match ch {
            '&' => out.push_str("&amp;"),
            '<' => out.push_str("&lt;"),
            '>' => out.push_str("&gt;"),
            '"' => out.push_str("&quot;"),
            c => out.push(c),
        }
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;
    use tet_mesh::{Block, CellType};

    type Sample = (Vec<[f64; 3]>, Vec<[u32; 4]>, Vec<Field>, Vec<Field>);

    fn sample() -> Sample {
        let points = vec![[0.0, 0.0, 0.0], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0], [1.0, 1.0, 1.0]];
        let tets = vec![[0, 1, 2, 3], [1, 2, 3, 4]];
        let pf = vec![Field::new("T<&\"x\">", 1, vec![0.5, 1.5, -2.0, 3.25, 1e300])];
        let cf = vec![Field::new("v", 3, vec![1.0, 2.0, 3.0, 4.0, 5.0, 6.0])];
        (points, tets, pf, cf)
    }

    fn check_roundtrip(bytes: &[u8]) {
        let (points, tets, pf, cf) = sample();
        let m = crate::vtk_xml::read(bytes).unwrap();
        assert_eq!(m.points, points);
        let Block::Unstructured(cells) = &m.blocks[0] else { panic!() };
        assert!(cells.types.iter().all(|&t| t == CellType::Tetra));
        assert_eq!(cells.connectivity, tets.iter().flatten().copied().collect::<Vec<_>>());
        assert_eq!(m.point_fields, pf);
        assert_eq!(m.cell_fields, cf);
    }

    #[test]
    fn roundtrip_raw_and_zlib() {
        let (points, tets, pf, cf) = sample();
        let mut raw = Vec::new();
        write_vtu(&mut raw, &points, &tets, &pf, &cf).unwrap();
        check_roundtrip(&raw);
        let mut z = Vec::new();
        write_vtu_with(&mut z, &points, &tets, &pf, &cf, WriteOptions { compress: true }).unwrap();
        check_roundtrip(&z);
    }

    #[test]
    fn wrong_field_length_is_invalid_input() {
        let (points, tets, _, cf) = sample();
        let bad = vec![Field::new("short", 1, vec![1.0])];
        let e = write_vtu(Vec::new(), &points, &tets, &bad, &cf).unwrap_err();
        assert_eq!(e.kind(), io::ErrorKind::InvalidInput);
    }
}
