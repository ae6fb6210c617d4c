//! VTK XML datasets: a reader for `.vtu`, `.vts`, `.vti`, `.vtr` and the
//! parallel `.pvtu`/`.pvts`/`.pvti`/`.pvtr` index files, and a fast `.vtu`
//! writer for tetrahedral meshes.
//!
//! The reader handles every data layout VTK's own writers produce: `ascii`,
//! inline `binary` (base64) and `appended` arrays (raw or base64 encoding),
//! UInt32 and UInt64 block headers, either byte order, and
//! `vtkZLibDataCompressor` compression. LZ4 and LZMA compressed files are
//! rejected with an "unsupported compressor" error. Zlib blocks are never
//! inflated past the size their header declares, and a header that claims
//! more than zlib's maximum ratio (about 1032:1) is refused before anything
//! is allocated.
//!
//! The appended section (`<AppendedData encoding="raw">_...`) is binary and
//! not XML; the reader cuts the file at `<AppendedData` and gives only the
//! part before it to the XML parser.

mod read;
mod write;

pub use read::{read, read_pvtu};
pub use write::{write_vtu, write_vtu_with, WriteOptions};
