//! The bundle's container (header, section table, 16-byte aligned payloads:
//! `tet_container`, specified in `formats/bundle.md`) and the little-endian
//! array encodings of its sections.

use crate::BundleError;
use std::borrow::Cow;
use std::io::{self, Write};
use std::path::Path;
use tet_container::{ContainerError, ContainerFormat, SectionFile, SectionFileError};

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
    tet_container::parse(bytes, &FORMAT).map(|(_, s)| s).map_err(|e| container_error(e, path))
}

fn container_error(e: ContainerError, path: &Path) -> BundleError {
    let path = path.to_path_buf();
    match e {
        ContainerError::BadMagic => BundleError::BadMagic { path },
        ContainerError::NewerVersion { found, supported } => BundleError::NewerVersion { found, supported, path },
        ContainerError::BadChecksum { section, expected, found, .. } => {
            BundleError::BadChecksum { section, expected, found, path }
        }
        e @ (ContainerError::Truncated { .. } | ContainerError::Damaged { .. }) => {
            BundleError::Damaged { what: e.to_string(), path }
        }
    }
}

fn file_error(e: SectionFileError, path: &Path) -> BundleError {
    match e {
        SectionFileError::Io(source) => BundleError::Io { action: "read", source, path: path.to_path_buf() },
        SectionFileError::Format(e) => container_error(e, path),
    }
}

/// Where a bundle's sections are decoded from: bytes whose checksums
/// [`parse`] has checked, or a file read section by section straight into
/// the decoded arrays (no copy of the whole file in memory).
pub(crate) enum Sections<'a> {
    Bytes { bytes: &'a [u8], table: Vec<SectionEntry> },
    File(SectionFile),
}

/// The scalar a section's records are made of, as stored (little-endian).
pub(crate) trait LeScalar: bytemuck::Pod {
    const NAME: &'static str;
    fn from_le_in_place(v: &mut [Self]);
}

/// f64 records are fixed up through their bits.
impl LeScalar for u64 {
    const NAME: &'static str = "f64";
    fn from_le_in_place(v: &mut [u64]) {
        v.iter_mut().for_each(|x| *x = u64::from_le(*x));
    }
}

impl LeScalar for u32 {
    const NAME: &'static str = "u32";
    fn from_le_in_place(v: &mut [u32]) {
        v.iter_mut().for_each(|x| *x = u32::from_le(*x));
    }
}

impl<'a> Sections<'a> {
    /// Opens a bundle file: header and table checked, sections not read.
    pub(crate) fn open(path: &Path) -> Result<Sections<'a>, BundleError> {
        SectionFile::open(path, &FORMAT).map(Sections::File).map_err(|e| file_error(e, path))
    }

    fn index(&self, name: &str) -> Option<usize> {
        match self {
            Sections::Bytes { table, .. } => table.iter().position(|e| e.name == name),
            Sections::File(f) => f.find(name),
        }
    }

    /// A small record section's bytes.
    pub(crate) fn bytes(&mut self, name: &str, path: &Path) -> Result<Option<Cow<'a, [u8]>>, BundleError> {
        let Some(i) = self.index(name) else { return Ok(None) };
        match self {
            Sections::Bytes { bytes, table } => Ok(Some(Cow::Borrowed(table[i].data(bytes)))),
            Sections::File(f) => f.read_vec(i).map(|v| Some(Cow::Owned(v))).map_err(|e| file_error(e, path)),
        }
    }

    /// An array section as records `T` made of scalars `S` (u32, or u64
    /// for f64 bits), read straight into the returned vector.
    pub(crate) fn records<T: bytemuck::Pod, S: LeScalar>(
        &mut self,
        name: &str,
        path: &Path,
    ) -> Result<Option<Vec<T>>, BundleError> {
        let Some(i) = self.index(name) else { return Ok(None) };
        let length = match self {
            Sections::Bytes { table, .. } => table[i].length,
            Sections::File(f) => f.sections()[i].length,
        } as usize;
        let size = std::mem::size_of::<T>();
        if !length.is_multiple_of(size) {
            return Err(BundleError::Damaged {
                what: format!(
                    "{name}: {length} bytes is not a whole number of {}×{} records",
                    size / std::mem::size_of::<S>(),
                    S::NAME
                ),
                path: path.to_path_buf(),
            });
        }
        let mut v: Vec<T> = vec![T::zeroed(); length / size];
        let dst: &mut [u8] = bytemuck::cast_slice_mut(&mut v);
        match self {
            Sections::Bytes { bytes, table } => dst.copy_from_slice(table[i].data(bytes)),
            Sections::File(f) => f.read_into(i, dst).map_err(|e| file_error(e, path))?,
        }
        if cfg!(target_endian = "big") {
            S::from_le_in_place(bytemuck::cast_slice_mut(&mut v));
        }
        Ok(Some(v))
    }

    /// [`Sections::records`] for a large array: a file's section mapped
    /// into memory in place where the host's byte order allows (no copy;
    /// pages read in as used and droppable again), else read.
    pub(crate) fn records_shared<T: bytemuck::Pod + Send + Sync, S: LeScalar>(
        &mut self,
        name: &str,
        path: &Path,
    ) -> Result<Option<tet_mesh::SharedArray<T>>, BundleError> {
        let Some(i) = self.index(name) else { return Ok(None) };
        // (A length that is not whole records is not mapped: `records`
        // then names it.)
        if let Sections::File(f) = self {
            if let Some(m) = f.map_section::<T>(i).map_err(|e| file_error(e, path))? {
                return Ok(Some(tet_mesh::SharedArray::Shared(std::sync::Arc::new(m))));
            }
        }
        Ok(self.records::<T, S>(name, path)?.map(tet_mesh::SharedArray::Owned))
    }

    /// Checks the checksums of the sections not decoded (a file's; bytes
    /// were checked whole by [`parse`]).
    pub(crate) fn verify_unread(&mut self, path: &Path) -> Result<(), BundleError> {
        match self {
            Sections::Bytes { .. } => Ok(()),
            Sections::File(f) => f.verify_unread().map_err(|e| file_error(e, path)),
        }
    }
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
