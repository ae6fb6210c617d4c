//! A container file's sections mapped into memory: [`MappedFile`] and
//! [`MappedSection`], the one place in tetkit that maps files. A mapped
//! section's pages are read in by the operating system as they are first
//! touched and, being clean file pages, can be dropped again under memory
//! pressure and read back later — so an array larger than the memory left
//! can be held (a 10⁸-tet bundle's connectivity and adjacency are 3.3 GB).
//! [`crate::SectionFile::read_into`] is the portable twin: the same bytes
//! read into an owned buffer (tests compare the two).

use std::io;
use std::sync::Arc;

/// A whole file mapped read-only.
#[derive(Debug)]
pub struct MappedFile {
    map: memmap2::Mmap,
}

impl MappedFile {
    /// Maps `file` (opened for reading) whole.
    pub fn map(file: &std::fs::File) -> io::Result<Arc<MappedFile>> {
        // SAFETY: a mapping is only sound while nothing else changes or
        // truncates the file: a write would change the bytes under this
        // process's immutable slices, a truncation would fault on access.
        // tetkit never writes a container in place — every file is written
        // to a temporary beside it and renamed over the old name
        // (`write_atomic`, `SectionWriter`), which leaves a mapped inode as
        // it was — and the section table and each section's checksum are
        // checked on the mapped bytes before any is used. Another program
        // rewriting a bundle in place while tetkit maps it is outside what
        // tetkit can guard against (as for any reader of a mapped file).
        let map = unsafe { memmap2::Mmap::map(file)? };
        Ok(Arc::new(MappedFile { map }))
    }

    /// The mapped bytes.
    pub fn bytes(&self) -> &[u8] {
        &self.map
    }
}

/// One section of a [`MappedFile`] viewed as a slice of `T` (which must be
/// the file's byte order: little-endian hosts only, see
/// [`MappedSection::new`]). Keeps the mapping alive.
pub struct MappedSection<T> {
    file: Arc<MappedFile>,
    offset: usize,
    len: usize,
    _of: std::marker::PhantomData<fn() -> T>,
}

impl<T: bytemuck::Pod> MappedSection<T> {
    /// The bytes `offset..offset + length` of `file` as `T`s; `None` where
    /// they are out of range, not a whole number of `T`s or not aligned for
    /// `T` (a container's sections are 16-byte aligned and a mapping is
    /// page-aligned, so a valid file's are), or where the host is
    /// big-endian (the stored bytes are little-endian; read them instead).
    pub fn new(file: Arc<MappedFile>, offset: u64, length: u64) -> Option<MappedSection<T>> {
        if cfg!(target_endian = "big") {
            return None;
        }
        let (offset, length) = (usize::try_from(offset).ok()?, usize::try_from(length).ok()?);
        let bytes = file.bytes().get(offset..offset.checked_add(length)?)?;
        let len = bytemuck::try_cast_slice::<u8, T>(bytes).ok()?.len();
        Some(MappedSection { file, offset, len, _of: std::marker::PhantomData })
    }
}

impl<T: bytemuck::Pod> AsRef<[T]> for MappedSection<T> {
    fn as_ref(&self) -> &[T] {
        let size = std::mem::size_of::<T>();
        bytemuck::cast_slice(&self.file.bytes()[self.offset..self.offset + self.len * size])
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_mapped_section_views_the_files_bytes() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("f");
        let words: Vec<u32> = (0..1000).collect();
        let mut bytes = vec![0u8; 16];
        bytes.extend(words.iter().flat_map(|w| w.to_le_bytes()));
        std::fs::write(&path, &bytes).unwrap();
        let file = MappedFile::map(&std::fs::File::open(&path).unwrap()).unwrap();
        let s = MappedSection::<u32>::new(Arc::clone(&file), 16, 4000).unwrap();
        assert_eq!(s.as_ref(), &words[..]);
        let pairs = MappedSection::<[u32; 2]>::new(Arc::clone(&file), 16, 4000).unwrap();
        assert_eq!(pairs.as_ref()[1], [2, 3]);
        // Out of range, a partial record, a misaligned start: none.
        assert!(MappedSection::<u32>::new(Arc::clone(&file), 16, 4004).is_none());
        assert!(MappedSection::<[u32; 3]>::new(Arc::clone(&file), 16, 4000).is_none());
        assert!(MappedSection::<u32>::new(file, 17, 8).is_none());
    }
}
