//! The container both tetkit file formats use (`formats/bundle.md`,
//! `formats/lut.md`): an 8-byte magic, a format version, a CRC-32'd
//! section table, and 16-byte aligned payloads each with its own CRC-32.
//!
//! Main items: [`ContainerFormat`] (a format's magic, version and section
//! limit), [`write_sections`] and [`parse`] (the byte layout),
//! [`SectionFile`] (a file read section by section, checksummed on the way,
//! or a section mapped into memory as a [`MappedSection`]),
//! [`SectionWriter`] (a file written a section at a time, table last),
//! [`write_atomic`] (temporary file beside the target, fsync, rename, so an
//! interrupted run never leaves a partial file under the final name),
//! [`SectionEntry`] and [`ContainerError`]. Errors carry the byte offsets
//! and section names; each format's crate adds the path and its own wording.
//!
//! ```
//! use tet_container::{parse, write_sections, ContainerFormat};
//! let fmt = ContainerFormat { magic: *b"\x89TEST\r\n\x1a", version: 1, max_sections: 16 };
//! let mut bytes = Vec::new();
//! write_sections(&mut bytes, &fmt, &[("A", b"hello"), ("B", &[1, 2, 3])]).unwrap();
//! let (version, sections) = parse(&bytes, &fmt).unwrap();
//! assert_eq!(version, 1);
//! assert_eq!(sections[1].name, "B");
//! assert_eq!(sections[1].data(&bytes), &[1, 2, 3]);
//! bytes[sections[0].offset as usize] ^= 1; // a flipped bit fails its checksum
//! assert!(parse(&bytes, &fmt).is_err());
//! ```

// `unsafe_code` is denied workspace-wide; only `mapped` (the mapping of a
// file, which the OS cannot make safe) allows it.

#[allow(unsafe_code)]
mod mapped;

pub use mapped::{MappedFile, MappedSection};

use std::io::{self, Write};
use std::path::Path;

/// Header bytes: magic, version, section count, table length, table CRC, reserved.
pub const HEADER_LEN: usize = 32;
/// Section table entry bytes: name, offset, length, CRC, reserved.
pub const ENTRY_LEN: usize = 40;
/// Longest section name (ASCII, zero-padded).
pub const NAME_LEN: usize = 16;
/// Payload alignment in bytes.
pub const ALIGN: usize = 16;

/// What distinguishes one format built on the container.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct ContainerFormat {
    /// First 8 bytes of every file.
    pub magic: [u8; 8],
    /// The version written, and the newest read.
    pub version: u32,
    /// More sections than this is a damaged table, not a real file.
    pub max_sections: u32,
}

/// One section table entry; the payload is `bytes[offset..offset + length]`.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct SectionEntry {
    pub name: String,
    pub offset: u64,
    pub length: u64,
    pub crc32: u32,
}

impl SectionEntry {
    /// The payload within the file bytes it was parsed from.
    pub fn data<'b>(&self, bytes: &'b [u8]) -> &'b [u8] {
        &bytes[self.offset as usize..(self.offset + self.length) as usize]
    }
}

/// Why bytes are not a valid container of a format. Offsets are in bytes
/// from the start of the file.
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
pub enum ContainerError {
    #[error("no magic at byte 0")]
    BadMagic,
    #[error("format version {found} is newer than this build reads (up to {supported})")]
    NewerVersion { found: u32, supported: u32 },
    #[error("truncated at byte {offset}: {what}")]
    Truncated { what: String, offset: u64 },
    #[error("{what}")]
    Damaged { what: String },
    #[error("section '{section}' at byte {offset} is corrupt (checksum {found:08x}, expected {expected:08x})")]
    BadChecksum { section: String, offset: u64, expected: u32, found: u32 },
}

/// Whether `name` can name a section: 1–16 ASCII bytes with no NUL.
pub fn valid_section_name(name: &str) -> bool {
    !name.is_empty() && name.len() <= NAME_LEN && name.is_ascii() && !name.contains('\0')
}

/// Writes header, table and payloads (borrowed, so a large file streams to
/// disk without an in-memory copy). Section names must satisfy
/// [`valid_section_name`]; a longer one is an `InvalidInput` error.
pub fn write_sections<W: Write + ?Sized>(
    out: &mut W,
    fmt: &ContainerFormat,
    sections: &[(&str, &[u8])],
) -> io::Result<()> {
    if let Some((bad, _)) = sections.iter().find(|(n, _)| !valid_section_name(n)) {
        return Err(io::Error::new(
            io::ErrorKind::InvalidInput,
            format!("section name '{bad}' is not 1–16 ASCII bytes"),
        ));
    }
    let table_len = sections.len() * ENTRY_LEN;
    let mut offset = align(HEADER_LEN + table_len);
    let mut table = Vec::with_capacity(table_len);
    let mut offsets = Vec::with_capacity(sections.len());
    for (name, data) in sections {
        push_entry(&mut table, name, offset as u64, data.len() as u64, crc32fast::hash(data));
        offsets.push(offset);
        offset = align(offset + data.len());
    }
    out.write_all(&header_bytes(fmt, sections.len(), &table))?;
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

/// Appends a section's table entry (a valid name).
fn push_entry(table: &mut Vec<u8>, name: &str, offset: u64, length: u64, crc32: u32) {
    let mut n = [0u8; NAME_LEN];
    n[..name.len()].copy_from_slice(name.as_bytes());
    table.extend_from_slice(&n);
    table.extend_from_slice(&offset.to_le_bytes());
    table.extend_from_slice(&length.to_le_bytes());
    table.extend_from_slice(&crc32.to_le_bytes());
    table.extend_from_slice(&0u32.to_le_bytes());
}

/// The header of a file of `count` sections listed in `table`.
fn header_bytes(fmt: &ContainerFormat, count: usize, table: &[u8]) -> Vec<u8> {
    let mut header = Vec::with_capacity(HEADER_LEN);
    header.extend_from_slice(&fmt.magic);
    header.extend_from_slice(&fmt.version.to_le_bytes());
    header.extend_from_slice(&(count as u32).to_le_bytes());
    header.extend_from_slice(&(table.len() as u64).to_le_bytes());
    header.extend_from_slice(&crc32fast::hash(table).to_le_bytes());
    header.extend_from_slice(&0u32.to_le_bytes());
    debug_assert_eq!(header.len(), HEADER_LEN);
    header
}

fn align(n: usize) -> usize {
    n.div_ceil(ALIGN) * ALIGN
}

/// Verifies the header, the table's and every section's checksum and
/// bounds; returns the file's version and its sections in table order.
pub fn parse(bytes: &[u8], fmt: &ContainerFormat) -> Result<(u32, Vec<SectionEntry>), ContainerError> {
    let head = parse_header(&bytes[..bytes.len().min(HEADER_LEN)], bytes.len() as u64, fmt)?;
    let table_end = HEADER_LEN + head.table_len as usize;
    if bytes.len() < table_end {
        return Err(ContainerError::Truncated {
            what: format!("the section table ends at byte {table_end}"),
            offset: bytes.len() as u64,
        });
    }
    let entries = parse_table(&bytes[HEADER_LEN..table_end], &head, bytes.len() as u64)?;
    for e in &entries {
        check_crc(e, crc32fast::hash(e.data(bytes)))?;
    }
    Ok((head.version, entries))
}

/// What the 32-byte header says.
struct Header {
    version: u32,
    table_len: u64,
    table_crc32: u32,
}

/// Checks the header (`head`: the file's first bytes, up to
/// [`HEADER_LEN`]) of a file of `file_len` bytes.
fn parse_header(head: &[u8], file_len: u64, fmt: &ContainerFormat) -> Result<Header, ContainerError> {
    if head.len() < fmt.magic.len() || head[..8] != fmt.magic {
        return Err(ContainerError::BadMagic);
    }
    if head.len() < HEADER_LEN {
        return Err(ContainerError::Truncated {
            what: format!("the header needs {HEADER_LEN} bytes"),
            offset: head.len() as u64,
        });
    }
    let u32_at = |o: usize| u32::from_le_bytes(head[o..o + 4].try_into().expect("4 bytes"));
    let u64_at = |o: usize| u64::from_le_bytes(head[o..o + 8].try_into().expect("8 bytes"));
    let version = u32_at(8);
    if version > fmt.version {
        return Err(ContainerError::NewerVersion { found: version, supported: fmt.version });
    }
    if version == 0 {
        return Err(ContainerError::Damaged { what: "format version 0".into() });
    }
    let (count, table_len) = (u32_at(12), u64_at(16));
    if count > fmt.max_sections || table_len != count as u64 * ENTRY_LEN as u64 {
        return Err(ContainerError::Damaged {
            what: format!("section table of {count} entries / {table_len} bytes is inconsistent"),
        });
    }
    if file_len < HEADER_LEN as u64 + table_len {
        return Err(ContainerError::Truncated {
            what: format!("the section table ends at byte {}", HEADER_LEN as u64 + table_len),
            offset: file_len,
        });
    }
    Ok(Header { version, table_len, table_crc32: u32_at(24) })
}

/// Checks the table's checksum and that every section lies within a file
/// of `file_len` bytes (the sections' own checksums are the caller's).
fn parse_table(table: &[u8], head: &Header, file_len: u64) -> Result<Vec<SectionEntry>, ContainerError> {
    let found = crc32fast::hash(table);
    if head.table_crc32 != found {
        return Err(ContainerError::BadChecksum {
            section: "section table".into(),
            offset: HEADER_LEN as u64,
            expected: head.table_crc32,
            found,
        });
    }
    let mut entries = Vec::with_capacity(table.len() / ENTRY_LEN);
    for e in table.chunks_exact(ENTRY_LEN) {
        let end = e[..NAME_LEN].iter().position(|&b| b == 0).unwrap_or(NAME_LEN);
        let name = String::from_utf8_lossy(&e[..end]).into_owned();
        let offset = u64::from_le_bytes(e[16..24].try_into().expect("8 bytes"));
        let length = u64::from_le_bytes(e[24..32].try_into().expect("8 bytes"));
        let crc32 = u32::from_le_bytes(e[32..36].try_into().expect("4 bytes"));
        if offset.checked_add(length).is_none_or(|end| end > file_len) {
            return Err(ContainerError::Truncated {
                what: format!("section '{name}' spans bytes {offset}..+{length}"),
                offset: file_len,
            });
        }
        entries.push(SectionEntry { name, offset, length, crc32 });
    }
    Ok(entries)
}

fn check_crc(e: &SectionEntry, found: u32) -> Result<(), ContainerError> {
    if found != e.crc32 {
        return Err(ContainerError::BadChecksum {
            section: e.name.clone(),
            offset: e.offset,
            expected: e.crc32,
            found,
        });
    }
    Ok(())
}

/// A container file read section by section, each straight into the
/// caller's array and checked against its checksum on the way: a file is
/// never held in memory whole, so reading one costs the memory of what is
/// decoded from it (a 4 GB bundle does not need 8 GB to load).
/// [`SectionFile::verify_unread`] checks what was not read, so a flipped
/// bit anywhere is found as [`parse`] finds it.
#[derive(Debug)]
pub struct SectionFile {
    file: std::fs::File,
    version: u32,
    sections: Vec<SectionEntry>,
    read: Vec<bool>,
    /// The file mapped, once a section was asked for mapped.
    mapped: Option<std::sync::Arc<MappedFile>>,
}

/// Why a [`SectionFile`] could not be read: the file system's error, or
/// what is wrong with the bytes.
#[derive(Debug, thiserror::Error)]
pub enum SectionFileError {
    #[error("cannot read: {0}")]
    Io(#[from] io::Error),
    #[error(transparent)]
    Format(#[from] ContainerError),
}

/// Bytes read (and checksummed) at a time: small enough to stay in cache
/// between the read and the checksum.
const READ_CHUNK: usize = 1 << 20;

impl SectionFile {
    /// Opens `path` and checks its header and section table (not yet the
    /// sections' checksums).
    pub fn open(path: &Path, fmt: &ContainerFormat) -> Result<SectionFile, SectionFileError> {
        use std::io::Read;
        let mut file = std::fs::File::open(path)?;
        let file_len = file.metadata()?.len();
        let mut head = Vec::with_capacity(HEADER_LEN);
        (&mut file).take(HEADER_LEN as u64).read_to_end(&mut head)?;
        let header = parse_header(&head, file_len, fmt)?;
        let mut table = vec![0u8; header.table_len as usize];
        file.read_exact(&mut table)?;
        let sections = parse_table(&table, &header, file_len)?;
        let read = vec![false; sections.len()];
        Ok(SectionFile { file, version: header.version, sections, read, mapped: None })
    }

    /// The file's format version.
    pub fn version(&self) -> u32 {
        self.version
    }

    /// The sections, in table order.
    pub fn sections(&self) -> &[SectionEntry] {
        &self.sections
    }

    /// The index of the first section named `name`.
    pub fn find(&self, name: &str) -> Option<usize> {
        self.sections.iter().position(|e| e.name == name)
    }

    /// Reads section `index` into `dst` (exactly its length) and checks
    /// its checksum.
    pub fn read_into(&mut self, index: usize, dst: &mut [u8]) -> Result<(), SectionFileError> {
        let e = &self.sections[index];
        if dst.len() as u64 != e.length {
            return Err(io::Error::new(
                io::ErrorKind::InvalidInput,
                format!("section '{}' has {} bytes, not {}", e.name, e.length, dst.len()),
            )
            .into());
        }
        let found = self.stream(index, dst)?;
        check_crc(&self.sections[index], found)?;
        self.read[index] = true;
        Ok(())
    }

    /// Section `index` mapped into memory as `T`s (checksummed on the
    /// mapped bytes, which reads each page once; the operating system may
    /// drop them again and read them back when used): no copy in this
    /// process's own memory. `None` where the section cannot be viewed as
    /// `T`s in place (a big-endian host, or a length not a whole number of
    /// them, or a file the system cannot map): read it instead.
    pub fn map_section<T: bytemuck::Pod>(
        &mut self,
        index: usize,
    ) -> Result<Option<MappedSection<T>>, SectionFileError> {
        let e = &self.sections[index];
        let file = match &self.mapped {
            Some(m) => std::sync::Arc::clone(m),
            None => match MappedFile::map(&self.file) {
                Ok(m) => {
                    self.mapped = Some(std::sync::Arc::clone(&m));
                    m
                }
                // (Some file systems and special files cannot be mapped.)
                Err(_) => return Ok(None),
            },
        };
        let Some(section) = MappedSection::<T>::new(std::sync::Arc::clone(&file), e.offset, e.length) else {
            if file.bytes().len() < (e.offset + e.length) as usize {
                return Err(SectionFileError::Format(ContainerError::Truncated {
                    what: format!("section '{}' spans bytes {}..+{}", e.name, e.offset, e.length),
                    offset: file.bytes().len() as u64,
                }));
            }
            return Ok(None);
        };
        let bytes = &file.bytes()[e.offset as usize..(e.offset + e.length) as usize];
        check_crc(e, crc32fast::hash(bytes))?;
        self.read[index] = true;
        Ok(Some(section))
    }

    /// Reads section `index` into a new byte vector (small records).
    pub fn read_vec(&mut self, index: usize) -> Result<Vec<u8>, SectionFileError> {
        let mut v = vec![0u8; self.sections[index].length as usize];
        self.read_into(index, &mut v)?;
        Ok(v)
    }

    /// Checks the checksum of every section not read yet, a chunk at a
    /// time (no memory kept).
    pub fn verify_unread(&mut self) -> Result<(), SectionFileError> {
        let mut buf = vec![0u8; READ_CHUNK];
        for i in 0..self.sections.len() {
            if !self.read[i] {
                let found = self.stream(i, &mut buf)?;
                check_crc(&self.sections[i], found)?;
                self.read[i] = true;
            }
        }
        Ok(())
    }

    /// Reads section `index` chunk by chunk and returns the checksum of
    /// what was read: into `dst` when it is the section's length, else
    /// through `dst` as a reused buffer of at least [`READ_CHUNK`] bytes.
    fn stream(&mut self, index: usize, dst: &mut [u8]) -> Result<u32, SectionFileError> {
        use std::io::{Read, Seek, SeekFrom};
        let e = &self.sections[index];
        self.file.seek(SeekFrom::Start(e.offset))?;
        let whole = dst.len() as u64 == e.length;
        let mut hasher = crc32fast::Hasher::new();
        let mut done = 0u64;
        while done < e.length {
            let n = (e.length - done).min(READ_CHUNK as u64) as usize;
            let chunk = if whole { &mut dst[done as usize..done as usize + n] } else { &mut dst[..n] };
            self.file.read_exact(chunk).map_err(|err| {
                if err.kind() == io::ErrorKind::UnexpectedEof {
                    SectionFileError::Format(ContainerError::Truncated {
                        what: format!("section '{}' spans bytes {}..+{}", e.name, e.offset, e.length),
                        offset: e.offset + done,
                    })
                } else {
                    err.into()
                }
            })?;
            hasher.update(chunk);
            done += n as u64;
        }
        Ok(hasher.finalize())
    }
}

/// A failed [`write_atomic`]: the step and the I/O error (the caller adds the path).
#[derive(Debug, thiserror::Error)]
#[error("cannot {action}: {source}")]
pub struct AtomicWriteError {
    /// "create a temporary file beside", "write", "sync", "rename into
    /// place", or, for a device or FIFO ([`persist_temp`]), "read back" or
    /// "open".
    pub action: &'static str,
    #[source]
    pub source: io::Error,
}

/// The [`AtomicWriteError`] of step `action`, for `map_err`.
fn step(action: &'static str) -> impl Fn(io::Error) -> AtomicWriteError {
    move |source| AtomicWriteError { action, source }
}

/// Writes `path` atomically: `write` fills a temporary file (named
/// `{tmp_prefix}XXXX.tmp`) in the same directory through a 1 MiB buffer,
/// which is synced and renamed over `path`. On error the temporary file is
/// removed and `path` is untouched. Every tetkit program writes its outputs
/// through here, so they all get one mode: `File::create`'s (0666 less the
/// umask on Unix, 0644 under the usual umask 022).
pub fn write_atomic(
    path: &Path,
    tmp_prefix: &str,
    write: impl FnOnce(&mut dyn Write) -> io::Result<()>,
) -> Result<(), AtomicWriteError> {
    let mut tmp = temp_beside(path, tmp_prefix)?;
    {
        let mut w = io::BufWriter::with_capacity(1 << 20, tmp.as_file_mut());
        write(&mut w).map_err(step("write"))?;
        w.flush().map_err(step("write"))?;
    }
    tmp.as_file().sync_all().map_err(step("sync"))?;
    persist_temp(tmp.into_temp_path(), path)
}

/// Puts a finished temporary file at `path`: renamed over it, or, where
/// `path` names something other than a regular file or a directory (after
/// symlinks: a device such as /dev/null or a terminal, a FIFO, a socket),
/// its bytes written into that and the temporary file removed. Renaming
/// over /dev/null replaced the device with an ordinary file (tetkit runs as
/// root on its CI machines): whatever programs threw away there afterwards
/// was read back by the next one reading it — cargo's probe of rustc failed
/// on a gcc message so (2026-12-06).
pub fn persist_temp(tmp: tempfile::TempPath, path: &Path) -> Result<(), AtomicWriteError> {
    let special = std::fs::metadata(path).is_ok_and(|m| !m.file_type().is_file() && !m.file_type().is_dir());
    if !special {
        tmp.persist(path).map_err(|e| AtomicWriteError { action: "rename into place", source: e.error })?;
        return Ok(());
    }
    let mut from = std::fs::File::open(&tmp).map_err(step("read back"))?;
    let mut to = std::fs::OpenOptions::new().write(true).open(path).map_err(step("open"))?;
    io::copy(&mut from, &mut to).map_err(step("write"))?;
    to.flush().map_err(step("write"))
}

/// A temporary file (`{tmp_prefix}XXXX.tmp`) in `path`'s directory, with
/// the mode an ordinary output file gets.
fn temp_beside(path: &Path, tmp_prefix: &str) -> Result<tempfile::NamedTempFile, AtomicWriteError> {
    let dir = match path.parent() {
        Some(d) if !d.as_os_str().is_empty() => d,
        _ => Path::new("."),
    };
    let mut builder = tempfile::Builder::new();
    builder.prefix(tmp_prefix).suffix(".tmp");
    // Temporary files are private (0600); the result is an ordinary output
    // file, readable like any other the user creates: open(2) with 0666
    // applies the umask, as File::create does.
    #[cfg(unix)]
    {
        use std::os::unix::fs::PermissionsExt;
        builder.permissions(std::fs::Permissions::from_mode(0o666));
    }
    builder.tempfile_in(dir).map_err(|source| AtomicWriteError { action: "create a temporary file beside", source })
}

/// A container written a section at a time, for files whose first
/// sections are final before the rest is computed (a conversion writes its
/// mesh while the adjacency is still being checked): into a temporary file
/// beside the destination, each section checksummed as it goes, the header
/// and table written last, synced and renamed into place by
/// [`SectionWriter::finish`], as [`write_atomic`] does. Dropped unfinished,
/// the temporary file is removed and nothing appears at the destination.
///
/// On Linux, the whole pages of a section of 1 MiB or more are written with
/// `O_DIRECT` (where the file system takes it: not tmpfs) from a
/// page-aligned buffer, its head and tail through the page cache: a
/// conversion's mesh then reaches the disk without the page cache's copy
/// and the writeback the sync would force while the statistics are still
/// being computed on the same cores. The file's bytes are the same either
/// way (a test).
///
/// Room for `capacity` table entries is kept before the first section; a
/// shorter table leaves zeros between it and the first section, which a
/// last entry, [`PADDING_SECTION`], covers with its checksum (so a flipped
/// bit there is found like any other; readers skip it by name).
#[derive(Debug)]
pub struct SectionWriter {
    fmt: ContainerFormat,
    file: io::BufWriter<std::fs::File>,
    /// The same file opened for direct I/O (Linux, where the file system
    /// takes it): the whole pages of large sections go to the disk from an
    /// aligned buffer, without the page cache's copy and its writeback at
    /// the sync (on two cores that writeback competed with the conversion's
    /// statistics). `None` elsewhere, or after a direct write failed.
    direct: Option<direct::Direct>,
    tmp: tempfile::TempPath,
    capacity: usize,
    /// Where the first section starts (after room for `capacity` entries and
    /// the padding's).
    start: u64,
    pos: u64,
    entries: Vec<SectionEntry>,
}

/// The section a [`SectionWriter`] adds over the unused room of its table:
/// zeros, checksummed.
pub const PADDING_SECTION: &str = "PADDING";

impl SectionWriter {
    /// Starts a file that will replace `path`, with room for `capacity`
    /// sections (at most `fmt.max_sections`).
    pub fn create(
        path: &Path,
        tmp_prefix: &str,
        fmt: &ContainerFormat,
        capacity: usize,
    ) -> Result<SectionWriter, AtomicWriteError> {
        // One entry of the room is the padding's.
        let capacity = capacity.min(fmt.max_sections.saturating_sub(1) as usize);
        let (file, tmp) = temp_beside(path, tmp_prefix)?.into_parts();
        let direct = direct::Direct::open(&tmp);
        let start = align(HEADER_LEN + (capacity + 1) * ENTRY_LEN) as u64;
        let mut file = io::BufWriter::with_capacity(1 << 20, file);
        // The header and table's room, filled in by `finish`.
        file.write_all(&vec![0u8; start as usize]).map_err(|source| AtomicWriteError { action: "write", source })?;
        Ok(SectionWriter { fmt: *fmt, file, direct, tmp, capacity, start, pos: start, entries: Vec::new() })
    }

    /// Appends a section (16-byte aligned). A name [`valid_section_name`]
    /// refuses, or a section past the capacity, is an `InvalidInput` error.
    pub fn section(&mut self, name: &str, data: &[u8]) -> Result<(), AtomicWriteError> {
        let invalid = |what: String| AtomicWriteError {
            action: "write",
            source: io::Error::new(io::ErrorKind::InvalidInput, what),
        };
        if !valid_section_name(name) {
            return Err(invalid(format!("section name '{name}' is not 1–16 ASCII bytes")));
        }
        if self.entries.len() == self.capacity {
            return Err(invalid(format!("section '{name}' is past the {} the table has room for", self.capacity)));
        }
        let offset = align(self.pos as usize) as u64;
        // The whole pages [first, end) of a large section go straight to
        // the disk, the head before them and the tail after them through
        // the page cache (disjoint pages: the kernel keeps the two kinds of
        // write apart); a section without such pages is all head.
        let pages = self.direct.as_ref().and_then(|d| d.pages_of(offset, data.len()));
        let (head, tail) =
            pages.map_or((data.len(), data.len()), |(first, end)| ((first - offset) as usize, (end - offset) as usize));
        let mut write = |w: &mut io::BufWriter<std::fs::File>| -> io::Result<()> {
            w.write_all(&[0u8; ALIGN][..(offset - self.pos) as usize])?;
            w.write_all(&data[..head])?;
            if let Some((first, end)) = pages {
                let direct = self.direct.as_mut().expect("pages come from it");
                if direct.write(first, &data[head..tail]).is_ok() {
                    use std::io::Seek;
                    w.seek(io::SeekFrom::Start(end))?;
                } else {
                    // The file system took the open but not the write:
                    // these pages and every later section buffered.
                    self.direct = None;
                    w.write_all(&data[head..tail])?;
                }
            }
            w.write_all(&data[tail..])
        };
        write(&mut self.file).map_err(|source| AtomicWriteError { action: "write", source })?;
        self.entries.push(SectionEntry {
            name: name.to_string(),
            offset,
            length: data.len() as u64,
            crc32: crc32fast::hash(data),
        });
        self.pos = offset + data.len() as u64;
        Ok(())
    }

    /// Flushes what was written so far and asks the system to put it on
    /// disk now, so that [`SectionWriter::finish`]'s sync finds little left
    /// to wait for (a conversion calls this on its writer thread while the
    /// rest of the bundle is still being computed).
    pub fn sync_written(&mut self) -> Result<(), AtomicWriteError> {
        self.file.flush().map_err(|source| AtomicWriteError { action: "write", source })?;
        self.file.get_ref().sync_data().map_err(|source| AtomicWriteError { action: "sync", source })
    }

    /// The sections written so far, in order.
    pub fn sections(&self) -> &[SectionEntry] {
        &self.entries
    }

    /// Room left in the table.
    pub fn room(&self) -> usize {
        self.capacity - self.entries.len()
    }

    /// Writes the header and table (sections listed in the order written),
    /// syncs the file and renames it over `path`.
    pub fn finish(mut self, path: &Path) -> Result<(), AtomicWriteError> {
        use std::io::Seek;
        // The table's unused room, past the padding's own entry, as one
        // more section of zeros.
        let pad_at = align(HEADER_LEN + (self.entries.len() + 1) * ENTRY_LEN) as u64;
        if pad_at < self.start {
            let zeros = vec![0u8; (self.start - pad_at) as usize];
            self.entries.push(SectionEntry {
                name: PADDING_SECTION.into(),
                offset: pad_at,
                length: zeros.len() as u64,
                crc32: crc32fast::hash(&zeros),
            });
        }
        let mut table = Vec::with_capacity(self.entries.len() * ENTRY_LEN);
        for e in &self.entries {
            push_entry(&mut table, &e.name, e.offset, e.length, e.crc32);
        }
        let header = header_bytes(&self.fmt, self.entries.len(), &table);
        let mut file =
            self.file.into_inner().map_err(|e| AtomicWriteError { action: "write", source: e.into_error() })?;
        file.seek(io::SeekFrom::Start(0)).map_err(step("write"))?;
        file.write_all(&header).map_err(step("write"))?;
        file.write_all(&table).map_err(step("write"))?;
        file.sync_all().map_err(step("sync"))?;
        drop(file);
        persist_temp(self.tmp, path)
    }
}

/// Direct I/O for [`SectionWriter`]'s large sections (Linux): the file
/// opened again with `O_DIRECT`, whole 4 KiB pages written at page offsets
/// from a page-aligned buffer. Elsewhere a stub that never opens.
mod direct {
    use std::path::Path;

    /// Sections with less than this in whole pages go through the page cache.
    const MIN_DIRECT: u64 = 1 << 20;
    /// Page size and alignment of every direct write (a multiple of any
    /// device's logical block size).
    const PAGE: u64 = 4096;
    /// Bytes copied into the aligned buffer a write.
    const CHUNK: usize = 4 << 20;

    #[derive(Debug)]
    pub(super) struct Direct {
        #[cfg(target_os = "linux")]
        file: std::fs::File,
        #[cfg(target_os = "linux")]
        buffer: Vec<u8>,
    }

    impl Direct {
        /// The file at `path` opened for direct writes, where the system and
        /// its file system take `O_DIRECT` (not tmpfs, say).
        #[cfg(target_os = "linux")]
        pub(super) fn open(path: &Path) -> Option<Direct> {
            use std::os::unix::fs::OpenOptionsExt;
            let file = std::fs::OpenOptions::new().write(true).custom_flags(libc::O_DIRECT).open(path).ok()?;
            Some(Direct { file, buffer: Vec::new() })
        }

        #[cfg(not(target_os = "linux"))]
        pub(super) fn open(_: &Path) -> Option<Direct> {
            None
        }

        /// The whole pages [first, end) of `len` bytes at `offset`, when
        /// there are enough of them to write directly.
        pub(super) fn pages_of(&self, offset: u64, len: usize) -> Option<(u64, u64)> {
            let first = offset.div_ceil(PAGE) * PAGE;
            let end = (offset + len as u64) / PAGE * PAGE;
            (end >= first + MIN_DIRECT).then_some((first, end))
        }

        /// Writes `data` (whole pages) at `pos` (a page offset).
        #[cfg(target_os = "linux")]
        pub(super) fn write(&mut self, pos: u64, data: &[u8]) -> std::io::Result<()> {
            use std::os::unix::fs::FileExt;
            debug_assert!(pos.is_multiple_of(PAGE) && (data.len() as u64).is_multiple_of(PAGE));
            if self.buffer.is_empty() {
                self.buffer = vec![0u8; CHUNK + PAGE as usize];
            }
            let at = self.buffer.as_ptr().align_offset(PAGE as usize);
            let aligned = &mut self.buffer[at..at + CHUNK];
            for (k, chunk) in data.chunks(CHUNK).enumerate() {
                aligned[..chunk.len()].copy_from_slice(chunk);
                self.file.write_all_at(&aligned[..chunk.len()], pos + (k * CHUNK) as u64)?;
            }
            Ok(())
        }

        #[cfg(not(target_os = "linux"))]
        pub(super) fn write(&mut self, _: u64, _: &[u8]) -> std::io::Result<()> {
            Err(std::io::ErrorKind::Unsupported.into())
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    const FMT: ContainerFormat = ContainerFormat { magic: *b"\x89TEST\r\n\x1a", version: 3, max_sections: 8 };

    fn sample() -> Vec<u8> {
        let mut out = Vec::new();
        write_sections(&mut out, &FMT, &[("ONE", &[7; 5]), ("TWO", &[]), ("THREE", &[1, 2, 3, 4, 5, 6, 7, 8, 9])])
            .unwrap();
        out
    }

    /// Large sections written with direct I/O (where the file system takes
    /// it) give the file the page cache alone gives, byte for byte, at
    /// unaligned offsets and with ragged heads and tails.
    #[test]
    fn large_sections_direct_or_buffered_give_the_same_file() {
        let dir = tempfile::tempdir().unwrap();
        let big: Vec<u8> = (0..(3 << 20) + 4093).map(|i: u32| (i.wrapping_mul(2_654_435_761) >> 13) as u8).collect();
        let other: Vec<u8> = big.iter().rev().map(|b| b ^ 0x5a).collect();
        let write = |name: &str, direct: bool| {
            let path = dir.path().join(name);
            let mut w = SectionWriter::create(&path, ".t-", &FMT, 5).unwrap();
            let used = w.direct.is_some();
            if !direct {
                w.direct = None;
            }
            w.section("SMALL", &[3; 37]).unwrap();
            w.section("BIG", &big).unwrap();
            w.sync_written().unwrap();
            w.section("ODD", &[9; 5]).unwrap();
            w.section("OTHER", &other[..(5 << 20) / 3]).unwrap();
            w.finish(&path).unwrap();
            (std::fs::read(&path).unwrap(), used)
        };
        let (buffered, _) = write("buffered.bin", false);
        let (direct, opened) = write("direct.bin", true);
        // (Where the temporary directory's file system refuses O_DIRECT,
        // both files are written through the page cache.)
        eprintln!("direct I/O opened: {opened}");
        assert!(buffered == direct, "the files differ");
        let (_, s) = parse(&direct, &FMT).unwrap();
        let big_entry = s.iter().find(|e| e.name == "BIG").unwrap();
        assert_eq!(&direct[big_entry.offset as usize..][..big.len()], &big[..]);
    }

    /// A file written a section at a time parses (bytes and file reader)
    /// to the same sections as one written at once, with a table shorter
    /// than its room; nothing is at the destination until `finish`, and a
    /// writer dropped unfinished leaves nothing behind.
    #[test]
    fn a_file_written_a_section_at_a_time_reads_back() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("out.bin");
        let mut w = SectionWriter::create(&path, ".t-", &FMT, 5).unwrap();
        let parts: [(&str, &[u8]); 3] = [("ONE", &[7; 5]), ("TWO", &[]), ("THREE", &[1, 2, 3, 4, 5, 6, 7, 8, 9])];
        for (name, data) in parts {
            w.section(name, data).unwrap();
        }
        assert_eq!(w.room(), 2);
        assert!(w.section("", b"x").is_err(), "an empty name");
        assert!(!path.exists(), "nothing at the destination before finish");
        w.finish(&path).unwrap();
        let bytes = std::fs::read(&path).unwrap();
        let (version, s) = parse(&bytes, &FMT).unwrap();
        assert_eq!(version, 3);
        assert_eq!(s.iter().map(|e| e.name.as_str()).collect::<Vec<_>>(), ["ONE", "TWO", "THREE", PADDING_SECTION]);
        // Every byte past the header is in the table or a section, up to
        // alignment: a flip in the unused room is found.
        let covered: u64 = s.iter().map(|e| e.length).sum::<u64>() + 4 * ENTRY_LEN as u64 + HEADER_LEN as u64;
        assert!(bytes.len() as u64 - covered < 4 * ALIGN as u64, "{} of {}", covered, bytes.len());
        let mut flipped = bytes.clone();
        flipped[s[3].offset as usize + 5] ^= 1;
        assert!(parse(&flipped, &FMT).is_err());
        for ((_, data), e) in parts.iter().zip(&s) {
            assert_eq!(e.data(&bytes), *data);
            assert!((e.offset as usize).is_multiple_of(ALIGN));
        }
        let mut f = SectionFile::open(&path, &FMT).unwrap();
        let three = f.find("THREE").unwrap();
        assert_eq!(f.read_vec(three).unwrap(), parts[2].1);
        f.verify_unread().unwrap();
        assert_eq!(std::fs::read_dir(dir.path()).unwrap().count(), 1, "no temporary file left");

        // Full: the sixth section is refused; dropped unfinished, no file.
        let other = dir.path().join("other.bin");
        let mut w = SectionWriter::create(&other, ".t-", &FMT, 1).unwrap();
        w.section("A", b"a").unwrap();
        assert_eq!(w.section("B", b"b").unwrap_err().source.kind(), io::ErrorKind::InvalidInput);
        drop(w);
        assert!(!other.exists());
        assert_eq!(std::fs::read_dir(dir.path()).unwrap().count(), 1, "the unfinished file is removed");
    }

    #[test]
    fn round_trip_keeps_names_order_and_alignment() {
        let bytes = sample();
        let (version, s) = parse(&bytes, &FMT).unwrap();
        assert_eq!(version, 3);
        assert_eq!(s.iter().map(|e| e.name.as_str()).collect::<Vec<_>>(), ["ONE", "TWO", "THREE"]);
        assert!(s.iter().all(|e| (e.offset as usize).is_multiple_of(ALIGN)));
        assert_eq!(s[2].data(&bytes), &[1, 2, 3, 4, 5, 6, 7, 8, 9]);
        assert_eq!(bytes.len() as u64, s[2].offset + s[2].length, "no padding after the last section");
    }

    #[test]
    fn every_truncation_and_every_flipped_bit_is_an_error() {
        let bytes = sample();
        for len in 0..bytes.len() {
            assert!(parse(&bytes[..len], &FMT).is_err(), "truncated to {len}");
        }
        // Padding and the header's reserved word (bytes 28..32) are covered
        // by no checksum; every other byte is.
        let (_, s) = parse(&bytes, &FMT).unwrap();
        let covered = |i: usize| {
            i < HEADER_LEN + s.len() * ENTRY_LEN
                || s.iter().any(|e| (e.offset..e.offset + e.length).contains(&(i as u64)))
        };
        for i in (0..bytes.len()).filter(|&i| covered(i) && !(28..32).contains(&i)) {
            let mut b = bytes.clone();
            b[i] ^= 0x10;
            assert!(parse(&b, &FMT).is_err(), "bit flip at byte {i} went unnoticed");
        }
    }

    /// A file read section by section finds what `parse` finds in its
    /// bytes: the same sections and payloads, and every truncation and
    /// covered bit flip, either while reading a section or in
    /// `verify_unread`.
    #[test]
    fn a_section_file_agrees_with_parse() {
        let bytes = sample();
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("s.bin");
        let read_all = |b: &[u8]| -> Result<Vec<Vec<u8>>, SectionFileError> {
            std::fs::write(&path, b).unwrap();
            let mut f = SectionFile::open(&path, &FMT)?;
            let first = f.find("THREE").map(|i| f.read_vec(i)).transpose()?;
            f.verify_unread()?;
            Ok(first.into_iter().collect())
        };
        assert_eq!(read_all(&bytes).unwrap(), vec![vec![1, 2, 3, 4, 5, 6, 7, 8, 9]]);
        std::fs::write(&path, &bytes).unwrap();
        let f = SectionFile::open(&path, &FMT).unwrap();
        assert_eq!((f.version(), f.sections()), (3, parse(&bytes, &FMT).unwrap().1.as_slice()));
        for len in 0..bytes.len() {
            assert!(read_all(&bytes[..len]).is_err(), "truncated to {len}");
        }
        for i in 0..bytes.len() {
            let mut b = bytes.clone();
            b[i] ^= 0x10;
            assert_eq!(read_all(&b).is_err(), parse(&b, &FMT).is_err(), "bit flip at byte {i}");
        }
        assert!(matches!(SectionFile::open(&dir.path().join("absent"), &FMT), Err(SectionFileError::Io(_))));
    }

    #[test]
    fn versions_and_names_are_checked() {
        let mut bytes = sample();
        bytes[8..12].copy_from_slice(&4u32.to_le_bytes());
        assert_eq!(parse(&bytes, &FMT).unwrap_err(), ContainerError::NewerVersion { found: 4, supported: 3 });
        bytes[8..12].copy_from_slice(&2u32.to_le_bytes());
        assert_eq!(parse(&bytes, &FMT).unwrap().0, 2, "older versions read");
        assert_eq!(
            parse(b"not a container at all........................", &FMT).unwrap_err(),
            ContainerError::BadMagic
        );
        let mut out = Vec::new();
        assert!(write_sections(&mut out, &FMT, &[("SEVENTEEN_CHARS__", &[])]).is_err());
        assert!(write_sections(&mut out, &FMT, &[("", &[])]).is_err());
    }

    #[cfg(unix)]
    #[test]
    fn atomic_writes_get_the_mode_file_create_gives() {
        use std::os::unix::fs::PermissionsExt;
        let dir = tempfile::tempdir().unwrap();
        let plain = dir.path().join("plain");
        std::fs::File::create(&plain).unwrap();
        let out = dir.path().join("out");
        write_atomic(&out, ".t-", |w| w.write_all(b"x")).unwrap();
        let mode = |p: &Path| std::fs::metadata(p).unwrap().permissions().mode() & 0o777;
        assert_eq!(mode(&out), mode(&plain));
    }

    /// Output to /dev/null (or any device or FIFO) is written into it, not
    /// renamed over it: the device stays a device (a regression: renaming
    /// made it an ordinary file, as root).
    #[cfg(unix)]
    #[test]
    fn atomic_writes_to_a_device_write_into_it() {
        use std::os::unix::fs::FileTypeExt;
        let null = Path::new("/dev/null");
        if !std::fs::metadata(null).is_ok_and(|m| m.file_type().is_char_device()) {
            eprintln!("note: /dev/null is not a device here; nothing to check");
            return;
        }
        write_atomic(null, ".t-", |w| w.write_all(b"thrown away")).unwrap();
        let mut sections = SectionWriter::create(null, ".t-", &FMT, 4).unwrap();
        sections.section("DATA", &[1u8, 2, 3]).unwrap();
        sections.finish(null).unwrap();
        assert!(std::fs::metadata(null).unwrap().file_type().is_char_device(), "/dev/null replaced");
        assert_eq!(std::fs::read(null).unwrap(), b"", "/dev/null keeps nothing");
    }

    #[test]
    fn atomic_write_replaces_the_file_or_leaves_it() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("f.bin");
        std::fs::write(&path, b"old").unwrap();
        let err = write_atomic(&path, ".t-", |w: &mut dyn Write| {
            w.write_all(b"partial")?;
            Err(io::Error::other("disk full"))
        })
        .unwrap_err();
        assert_eq!(err.action, "write");
        assert_eq!(std::fs::read(&path).unwrap(), b"old");
        write_atomic(&path, ".t-", |w| w.write_all(b"new")).unwrap();
        assert_eq!(std::fs::read(&path).unwrap(), b"new");
        assert_eq!(std::fs::read_dir(dir.path()).unwrap().count(), 1, "no temporary file left");
    }
}
