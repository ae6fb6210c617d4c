//! Byte layout: header, section table, 16-byte aligned section payloads.
//! See `formats/bundle.md` for the specification this implements.

use crate::BundleError;
use std::borrow::Cow;
use std::io::{self, Write};
use std::path::Path;

/// First 8 bytes of every bundle. The high byte and CR/LF pair catch
/// text-mode transfers, as PNG's signature does.
pub const MAGIC: [u8; 8] = *b"\x89TETB\r\n\x1a";
/// Format version this build writes and the newest it reads.
pub const FORMAT_VERSION: u32 = 1;

const HEADER_LEN: usize = 32;
const ENTRY_LEN: usize = 40;
const NAME_LEN: usize = 16;
const ALIGN: usize = 16;
/// More sections than this is a damaged table, not a real bundle.
const MAX_SECTIONS: u32 = 1 << 16;

/// One section table entry.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct SectionEntry {
    pub name: String,
    pub offset: u64,
    pub length: u64,
    pub crc32: u32,
}

/// Writes header, table and payloads. Payloads are borrowed (on
/// little-endian hosts straight from the mesh arrays), so a bundle is
/// streamed to disk without an in-memory copy of the file.
pub(crate) fn write_sections<W: Write>(out: &mut W, sections: &[(String, Cow<'_, [u8]>)]) -> io::Result<()> {
    let table_len = sections.len() * ENTRY_LEN;
    let mut offset = align(HEADER_LEN + table_len);
    let mut table = Vec::with_capacity(table_len);
    let mut offsets = Vec::with_capacity(sections.len());
    for (name, data) in sections {
        let mut n = [0u8; NAME_LEN];
        n[..name.len()].copy_from_slice(name.as_bytes());
        table.extend_from_slice(&n);
        table.extend_from_slice(&(offset as u64).to_le_bytes());
        table.extend_from_slice(&(data.len() as u64).to_le_bytes());
        table.extend_from_slice(&crc32fast::hash(data).to_le_bytes());
        table.extend_from_slice(&0u32.to_le_bytes());
        offsets.push(offset);
        offset = align(offset + data.len());
    }
    let mut header = Vec::with_capacity(HEADER_LEN);
    header.extend_from_slice(&MAGIC);
    header.extend_from_slice(&FORMAT_VERSION.to_le_bytes());
    header.extend_from_slice(&(sections.len() as u32).to_le_bytes());
    header.extend_from_slice(&(table_len as u64).to_le_bytes());
    header.extend_from_slice(&crc32fast::hash(&table).to_le_bytes());
    header.extend_from_slice(&0u32.to_le_bytes());
    debug_assert_eq!(header.len(), HEADER_LEN);
    out.write_all(&header)?;
    out.write_all(&table)?;
    let mut pos = HEADER_LEN + table_len;
    for ((_, data), off) in sections.iter().zip(offsets) {
        out.write_all(&[0u8; ALIGN][..off - pos])?;
        out.write_all(data)?;
        pos = off + data.len();
    }
    // No padding after the last section: any truncation cuts into a section
    // and so fails its bounds check or checksum.
    Ok(())
}

fn align(n: usize) -> usize {
    n.div_ceil(ALIGN) * ALIGN
}

pub(crate) fn parse(bytes: &[u8], path: &Path) -> Result<Vec<SectionEntry>, BundleError> {
    let damaged = |what: String| BundleError::Damaged { what, path: path.to_path_buf() };
    if bytes.len() < MAGIC.len() || bytes[..8] != MAGIC {
        return Err(BundleError::BadMagic { path: path.to_path_buf() });
    }
    if bytes.len() < HEADER_LEN {
        return Err(damaged(format!("header truncated ({} of {HEADER_LEN} bytes)", bytes.len())));
    }
    let u32_at = |o: usize| u32::from_le_bytes(bytes[o..o + 4].try_into().expect("4 bytes"));
    let u64_at = |o: usize| u64::from_le_bytes(bytes[o..o + 8].try_into().expect("8 bytes"));
    let version = u32_at(8);
    if version > FORMAT_VERSION {
        return Err(BundleError::NewerVersion { found: version, supported: FORMAT_VERSION, path: path.to_path_buf() });
    }
    if version == 0 {
        return Err(damaged("format version 0".into()));
    }
    let count = u32_at(12);
    let table_len = u64_at(16);
    if count > MAX_SECTIONS || table_len != count as u64 * ENTRY_LEN as u64 {
        return Err(damaged(format!("section table of {count} entries / {table_len} bytes is inconsistent")));
    }
    let table_end = HEADER_LEN + table_len as usize;
    if bytes.len() < table_end {
        return Err(damaged(format!(
            "truncated: the section table ends at byte {table_end}, the file has {}",
            bytes.len()
        )));
    }
    let table = &bytes[HEADER_LEN..table_end];
    let (expected, found) = (u32_at(24), crc32fast::hash(table));
    if expected != found {
        return Err(BundleError::BadChecksum {
            section: "section table".into(),
            expected,
            found,
            path: path.to_path_buf(),
        });
    }
    let mut entries = Vec::with_capacity(count as usize);
    for e in table.chunks_exact(ENTRY_LEN) {
        let name_bytes = &e[..NAME_LEN];
        let end = name_bytes.iter().position(|&b| b == 0).unwrap_or(NAME_LEN);
        let name = String::from_utf8_lossy(&name_bytes[..end]).into_owned();
        let offset = u64::from_le_bytes(e[16..24].try_into().expect("8 bytes"));
        let length = u64::from_le_bytes(e[24..32].try_into().expect("8 bytes"));
        let crc32 = u32::from_le_bytes(e[32..36].try_into().expect("4 bytes"));
        let fits = offset.checked_add(length).is_some_and(|end| end <= bytes.len() as u64);
        if !fits {
            return Err(damaged(format!(
                "section '{name}' (bytes {offset}..+{length}) runs past the end of the file ({} bytes): truncated?",
                bytes.len()
            )));
        }
        let data = &bytes[offset as usize..(offset + length) as usize];
        let found = crc32fast::hash(data);
        if found != crc32 {
            return Err(BundleError::BadChecksum { section: name, expected: crc32, found, path: path.to_path_buf() });
        }
        entries.push(SectionEntry { name, offset, length, crc32 });
    }
    Ok(entries)
}

/// Little-endian bytes of a POD slice: borrowed on little-endian hosts.
pub(crate) fn le_bytes<T: bytemuck::Pod + ToLeBytes>(v: &[T]) -> Cow<'_, [u8]> {
    if cfg!(target_endian = "little") {
        Cow::Borrowed(bytemuck::cast_slice(v))
    } else {
        Cow::Owned(v.iter().flat_map(|x| x.to_le_vec()).collect())
    }
}

pub(crate) trait ToLeBytes {
    fn to_le_vec(&self) -> Vec<u8>;
}

impl ToLeBytes for f64 {
    fn to_le_vec(&self) -> Vec<u8> {
        self.to_le_bytes().to_vec()
    }
}

impl ToLeBytes for u32 {
    fn to_le_vec(&self) -> Vec<u8> {
        self.to_le_bytes().to_vec()
    }
}

/// Decodes little-endian f64s; the count must be a multiple of `group`.
pub(crate) fn le_to_f64s(b: &[u8], group: usize) -> Result<Vec<f64>, String> {
    if !b.len().is_multiple_of(8 * group) {
        return Err(format!("{} bytes is not a whole number of {group}×f64 records", b.len()));
    }
    Ok(b.chunks_exact(8).map(|c| f64::from_le_bytes(c.try_into().expect("8 bytes"))).collect())
}

pub(crate) fn le_to_u32s(b: &[u8], group: usize) -> Result<Vec<u32>, String> {
    if !b.len().is_multiple_of(4 * group) {
        return Err(format!("{} bytes is not a whole number of {group}×u32 records", b.len()));
    }
    Ok(b.chunks_exact(4).map(|c| u32::from_le_bytes(c.try_into().expect("4 bytes"))).collect())
}
