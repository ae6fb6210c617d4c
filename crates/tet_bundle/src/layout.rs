//! The bundle's container (header, section table, 16-byte aligned payloads:
//! `tet_container`, specified in `formats/bundle.md`) and the little-endian
//! array encodings of its sections.

use crate::BundleError;
use std::borrow::Cow;
use std::io::{self, Write};
use std::path::Path;
use tet_container::{ContainerError, ContainerFormat};

/// First 8 bytes of every bundle. The high byte and CR/LF pair catch
/// text-mode transfers, as PNG's signature does.
pub const MAGIC: [u8; 8] = *b"\x89TETB\r\n\x1a";
/// Format version this build writes and the newest it reads.
pub const FORMAT_VERSION: u32 = 1;

/// The container format of bundles (see `tet_container`).
pub(crate) const FORMAT: ContainerFormat =
    ContainerFormat { magic: MAGIC, version: FORMAT_VERSION, max_sections: 1 << 16 };

pub use tet_container::SectionEntry;

/// Writes header, table and payloads. Payloads are borrowed (on
/// little-endian hosts straight from the mesh arrays), so a bundle is
/// streamed to disk without an in-memory copy of the file.
pub(crate) fn write_sections(out: &mut dyn Write, sections: &[(String, Cow<'_, [u8]>)]) -> io::Result<()> {
    let refs: Vec<(&str, &[u8])> = sections.iter().map(|(n, d)| (n.as_str(), d.as_ref())).collect();
    tet_container::write_sections(out, &FORMAT, &refs)
}

pub(crate) fn parse(bytes: &[u8], path: &Path) -> Result<Vec<SectionEntry>, BundleError> {
    let path = path.to_path_buf();
    tet_container::parse(bytes, &FORMAT).map(|(_, s)| s).map_err(|e| match e {
        ContainerError::BadMagic => BundleError::BadMagic { path },
        ContainerError::NewerVersion { found, supported } => BundleError::NewerVersion { found, supported, path },
        ContainerError::BadChecksum { section, expected, found, .. } => {
            BundleError::BadChecksum { section, expected, found, path }
        }
        e @ (ContainerError::Truncated { .. } | ContainerError::Damaged { .. }) => {
            BundleError::Damaged { what: e.to_string(), path }
        }
    })
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

/// Little-endian u32 records of four (a tet's vertices, its neighbours).
pub(crate) fn le_to_u32_quads(b: &[u8]) -> Result<Vec<[u32; 4]>, String> {
    Ok(le_to_u32s(b, 4)?.chunks_exact(4).map(|c| [c[0], c[1], c[2], c[3]]).collect())
}
