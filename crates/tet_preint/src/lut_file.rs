//! The `.tetl` lookup-table file (spec: `formats/lut.md`) and the bake /
//! load entry points `tetlut` calls.
//!
//! Same container as the bundle: magic, version, a CRC-32'd section table,
//! 16-byte aligned payloads each with its own CRC-32, written atomically
//! (temporary file beside the target, fsync, rename). The `HEADER` section is
//! JSON naming the method, the TF it was baked from, the domain, the
//! method's parameters and one [`SectionInfo`] (dtype, dims, channels,
//! unorm scale) per data section, so new table kinds need no format change.

use crate::atlas2d::{Atlas2d, Atlas2dParams};
use crate::domain::{TableDomain, TableError};
use crate::method::{Method, SegmentShader};
use crate::partial::{PartialShader, PsiParams, PsiTable};
use crate::precision::{Precision, Storage};
use crate::table3d::{Table3d, Table3dParams};
use crate::tf::{Emission, TransferFunction};
use serde::{Deserialize, Serialize};
use std::io::Write;
use std::path::{Path, PathBuf};
use std::sync::Arc;

/// First 8 bytes of every `.tetl` file (PNG-style: high byte, CR LF, ^Z).
pub const LUT_MAGIC: [u8; 8] = *b"\x89TETL\r\n\x1a";
/// Format version written, and the newest read.
pub const LUT_FORMAT_VERSION: u32 = 1;
const HEADER_LEN: usize = 32;
const ENTRY_LEN: usize = 40;
const NAME_LEN: usize = 16;
const ALIGN: usize = 16;
const MAX_SECTIONS: u32 = 1 << 12;
/// The JSON header section's name.
pub const HEADER_SECTION: &str = "HEADER";

/// A `.tetl` file that cannot be read or written. Variants name the
/// section and byte offset where it applies; the path comes last.
#[derive(Debug, thiserror::Error)]
pub enum LutError {
    #[error("cannot {action} {}: {source}", path.display())]
    Io {
        action: &'static str,
        #[source]
        source: std::io::Error,
        path: PathBuf,
    },
    #[error("not a tetkit lookup table (no .tetl magic at byte 0): {}", path.display())]
    BadMagic { path: PathBuf },
    #[error("lookup-table format version {found} is newer than this tetkit reads (up to {supported}); upgrade tetkit: {}", path.display())]
    NewerVersion { found: u32, supported: u32, path: PathBuf },
    #[error("truncated at byte {offset}: {what}: {}", path.display())]
    Truncated { what: String, offset: u64, path: PathBuf },
    #[error("section '{section}' at byte {offset} is corrupt (checksum {found:08x}, expected {expected:08x}): {}", path.display())]
    BadChecksum { section: String, offset: u64, expected: u32, found: u32, path: PathBuf },
    #[error("lookup table is damaged: {what}: {}", path.display())]
    Damaged { what: String, path: PathBuf },
    #[error("lookup table has no section '{section}': {}", path.display())]
    MissingSection { section: String, path: PathBuf },
    #[error("section '{section}' at byte {offset}: {what}: {}", path.display())]
    BadSection { section: String, offset: u64, what: String, path: PathBuf },
    #[error("lookup table holds method '{found}', which {what}: {}", path.display())]
    Method { found: String, what: String, path: PathBuf },
    #[error("section name '{0}' is not 1–16 ASCII characters")]
    SectionName(String),
}

/// Element type of a data section.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum DType {
    F32,
    F16,
    Unorm16,
    Unorm8,
    F64,
    U32,
}

impl DType {
    pub fn bytes(self) -> usize {
        match self {
            DType::F32 | DType::U32 => 4,
            DType::F16 | DType::Unorm16 => 2,
            DType::Unorm8 => 1,
            DType::F64 => 8,
        }
    }
    /// The table storage precision, if this is one.
    pub fn precision(self) -> Option<Precision> {
        match self {
            DType::F32 => Some(Precision::F32),
            DType::F16 => Some(Precision::F16),
            DType::Unorm16 => Some(Precision::Unorm16),
            DType::Unorm8 => Some(Precision::Unorm8),
            _ => None,
        }
    }
}

impl From<Precision> for DType {
    fn from(p: Precision) -> DType {
        match p {
            Precision::F32 => DType::F32,
            Precision::F16 => DType::F16,
            Precision::Unorm16 => DType::Unorm16,
            Precision::Unorm8 => DType::Unorm8,
        }
    }
}

/// How to read one data section: element type, shape (row-major, last
/// dimension fastest; the product is the element count) and, for unorm
/// types, each channel's range (the last dimension is the channel).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct SectionInfo {
    pub name: String,
    pub dtype: DType,
    pub dims: Vec<u64>,
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub scale: Vec<f32>,
}

impl SectionInfo {
    /// Element count, `None` on overflow.
    pub fn count(&self) -> Option<u64> {
        self.dims.iter().try_fold(1u64, |a, &d| a.checked_mul(d))
    }
}

/// The `HEADER` section.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct LutHeader {
    /// tetkit version that wrote the file.
    pub writer: String,
    /// Method id of DESIGN.md (`table3d`, `atlas2d`, `partial`, …).
    pub method: String,
    /// The transfer function baked, as `formats/tf.md` JSON.
    pub tf: serde_json::Value,
    /// The (Sf, Sb, l) domain, for methods that have one.
    pub domain: Option<TableDomain>,
    /// Method parameters (resolution, build, precision, …).
    pub params: serde_json::Value,
    pub sections: Vec<SectionInfo>,
}

/// A whole `.tetl` file in memory: header plus raw little-endian payloads
/// in the order of `header.sections`.
#[derive(Debug, Clone, PartialEq)]
pub struct LutFile {
    pub header: LutHeader,
    pub payloads: Vec<Vec<u8>>,
}

fn writer() -> String {
    format!("tetkit {}", env!("CARGO_PKG_VERSION"))
}

impl LutFile {
    /// An empty file for `method`.
    pub fn new(method: Method, tf: &TransferFunction, domain: Option<TableDomain>, params: serde_json::Value) -> Self {
        let tf = serde_json::from_str(&tf.to_json()).expect("a TF's JSON parses");
        LutFile {
            header: LutHeader { writer: writer(), method: method.id().into(), tf, domain, params, sections: vec![] },
            payloads: vec![],
        }
    }

    /// Appends a data section.
    pub fn push(&mut self, info: SectionInfo, payload: Vec<u8>) -> Result<(), LutError> {
        if info.name.is_empty() || info.name.len() > NAME_LEN || !info.name.is_ascii() || info.name == HEADER_SECTION {
            return Err(LutError::SectionName(info.name));
        }
        self.header.sections.push(info);
        self.payloads.push(payload);
        Ok(())
    }

    /// Appends a table [`Storage`] as a section of the given dims (whose
    /// last dimension must be the channel count).
    pub fn push_storage(&mut self, name: &str, dims: Vec<u64>, data: &Storage) -> Result<(), LutError> {
        let info = SectionInfo {
            name: name.into(),
            dtype: data.precision().into(),
            dims,
            scale: if matches!(data.precision(), Precision::Unorm16 | Precision::Unorm8) {
                data.scale().to_vec()
            } else {
                vec![]
            },
        };
        self.push(info, data.to_le_bytes())
    }

    /// The payload and description of section `name`.
    pub fn section(&self, name: &str) -> Option<(&SectionInfo, &[u8])> {
        self.header.sections.iter().zip(&self.payloads).find(|(i, _)| i.name == name).map(|(i, p)| (i, p.as_slice()))
    }

    /// The transfer function the file was baked from.
    pub fn transfer_function(&self) -> Result<TransferFunction, crate::TfError> {
        TransferFunction::from_json(&self.header.tf.to_string())
    }

    /// The file's bytes.
    pub fn to_bytes(&self) -> Vec<u8> {
        let mut out = Vec::new();
        self.write_to(&mut out).expect("writing to a Vec cannot fail");
        out
    }

    fn write_to<W: Write>(&self, out: &mut W) -> std::io::Result<()> {
        let header = serde_json::to_vec_pretty(&self.header).expect("header serializes");
        let mut sections: Vec<(&str, &[u8])> = vec![(HEADER_SECTION, &header)];
        for (info, p) in self.header.sections.iter().zip(&self.payloads) {
            sections.push((&info.name, p));
        }
        let table_len = sections.len() * ENTRY_LEN;
        let mut offset = align(HEADER_LEN + table_len);
        let mut table = Vec::with_capacity(table_len);
        let mut offsets = Vec::with_capacity(sections.len());
        for (name, data) in &sections {
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
        let mut head = Vec::with_capacity(HEADER_LEN);
        head.extend_from_slice(&LUT_MAGIC);
        head.extend_from_slice(&LUT_FORMAT_VERSION.to_le_bytes());
        head.extend_from_slice(&(sections.len() as u32).to_le_bytes());
        head.extend_from_slice(&(table_len as u64).to_le_bytes());
        head.extend_from_slice(&crc32fast::hash(&table).to_le_bytes());
        head.extend_from_slice(&0u32.to_le_bytes());
        out.write_all(&head)?;
        out.write_all(&table)?;
        let mut pos = HEADER_LEN + table_len;
        for ((_, data), off) in sections.iter().zip(offsets) {
            out.write_all(&[0u8; ALIGN][..off - pos])?;
            out.write_all(data)?;
            pos = off + data.len();
        }
        // Nothing after the last payload: any truncation cuts into one.
        Ok(())
    }

    /// Writes atomically: temporary file beside `path`, fsync, rename.
    pub fn write(&self, path: &Path) -> Result<(), LutError> {
        let io = |action: &'static str| move |source| LutError::Io { action, source, path: path.to_path_buf() };
        let dir = match path.parent() {
            Some(d) if !d.as_os_str().is_empty() => d,
            _ => Path::new("."),
        };
        let mut builder = tempfile::Builder::new();
        builder.prefix(".tetl-").suffix(".tmp");
        #[cfg(unix)]
        {
            use std::os::unix::fs::PermissionsExt;
            builder.permissions(std::fs::Permissions::from_mode(0o644));
        }
        let mut tmp = builder.tempfile_in(dir).map_err(io("create a temporary file beside"))?;
        {
            let mut w = std::io::BufWriter::with_capacity(1 << 20, tmp.as_file_mut());
            self.write_to(&mut w).map_err(io("write"))?;
            w.flush().map_err(io("write"))?;
        }
        tmp.as_file().sync_all().map_err(io("sync"))?;
        tmp.persist(path).map_err(|e| LutError::Io {
            action: "rename into place",
            source: e.error,
            path: path.to_path_buf(),
        })?;
        Ok(())
    }

    /// Reads and verifies a file.
    pub fn read(path: &Path) -> Result<LutFile, LutError> {
        let bytes =
            std::fs::read(path).map_err(|source| LutError::Io { action: "read", source, path: path.to_path_buf() })?;
        LutFile::from_bytes(&bytes, path)
    }

    /// Parses and verifies file bytes; `path` only names the file in errors.
    /// Sections not listed in the header are ignored (newer writers may add
    /// them); listed ones must be present with the byte count their dtype and
    /// dims imply.
    pub fn from_bytes(bytes: &[u8], path: &Path) -> Result<LutFile, LutError> {
        let p = || path.to_path_buf();
        if bytes.len() < LUT_MAGIC.len() || bytes[..8] != LUT_MAGIC {
            return Err(LutError::BadMagic { path: p() });
        }
        if bytes.len() < HEADER_LEN {
            return Err(LutError::Truncated {
                what: format!("header needs {HEADER_LEN} bytes"),
                offset: bytes.len() as u64,
                path: p(),
            });
        }
        let u32_at = |o: usize| u32::from_le_bytes(bytes[o..o + 4].try_into().expect("4 bytes"));
        let u64_at = |o: usize| u64::from_le_bytes(bytes[o..o + 8].try_into().expect("8 bytes"));
        let version = u32_at(8);
        if version > LUT_FORMAT_VERSION {
            return Err(LutError::NewerVersion { found: version, supported: LUT_FORMAT_VERSION, path: p() });
        }
        if version == 0 {
            return Err(LutError::Damaged { what: "format version 0".into(), path: p() });
        }
        let (count, table_len) = (u32_at(12), u64_at(16));
        if count > MAX_SECTIONS || table_len != count as u64 * ENTRY_LEN as u64 {
            return Err(LutError::Damaged {
                what: format!("section table of {count} entries / {table_len} bytes is inconsistent"),
                path: p(),
            });
        }
        let table_end = HEADER_LEN + table_len as usize;
        if bytes.len() < table_end {
            return Err(LutError::Truncated {
                what: format!("the section table ends at byte {table_end}"),
                offset: bytes.len() as u64,
                path: p(),
            });
        }
        let table = &bytes[HEADER_LEN..table_end];
        let (expected, found) = (u32_at(24), crc32fast::hash(table));
        if expected != found {
            return Err(LutError::BadChecksum {
                section: "section table".into(),
                offset: HEADER_LEN as u64,
                expected,
                found,
                path: p(),
            });
        }
        let mut entries: Vec<(String, u64, &[u8])> = Vec::with_capacity(count as usize);
        for e in table.chunks_exact(ENTRY_LEN) {
            let end = e[..NAME_LEN].iter().position(|&b| b == 0).unwrap_or(NAME_LEN);
            let name = String::from_utf8_lossy(&e[..end]).into_owned();
            let offset = u64::from_le_bytes(e[16..24].try_into().expect("8 bytes"));
            let length = u64::from_le_bytes(e[24..32].try_into().expect("8 bytes"));
            let crc = u32::from_le_bytes(e[32..36].try_into().expect("4 bytes"));
            if offset.checked_add(length).is_none_or(|end| end > bytes.len() as u64) {
                return Err(LutError::Truncated {
                    what: format!("section '{name}' spans bytes {offset}..+{length}"),
                    offset: bytes.len() as u64,
                    path: p(),
                });
            }
            let data = &bytes[offset as usize..(offset + length) as usize];
            let found = crc32fast::hash(data);
            if found != crc {
                return Err(LutError::BadChecksum { section: name, offset, expected: crc, found, path: p() });
            }
            entries.push((name, offset, data));
        }
        let (_, hoff, hbytes) = entries
            .iter()
            .find(|e| e.0 == HEADER_SECTION)
            .ok_or_else(|| LutError::MissingSection { section: HEADER_SECTION.into(), path: p() })?;
        let header: LutHeader = serde_json::from_slice(hbytes).map_err(|e| LutError::BadSection {
            section: HEADER_SECTION.into(),
            offset: *hoff,
            what: format!("JSON does not decode ({e})"),
            path: p(),
        })?;
        let mut payloads = Vec::with_capacity(header.sections.len());
        for info in &header.sections {
            let (_, off, data) = entries
                .iter()
                .find(|e| e.0 == info.name)
                .ok_or_else(|| LutError::MissingSection { section: info.name.clone(), path: p() })?;
            let want = info.count().and_then(|c| c.checked_mul(info.dtype.bytes() as u64));
            if want != Some(data.len() as u64) {
                return Err(LutError::BadSection {
                    section: info.name.clone(),
                    offset: *off,
                    what: format!("{} bytes, but {:?} × {:?} needs {want:?}", data.len(), info.dims, info.dtype),
                    path: p(),
                });
            }
            payloads.push(data.to_vec());
        }
        Ok(LutFile { header, payloads })
    }

    /// Decodes section `name` as table [`Storage`] (channels = last dim).
    pub fn storage(&self, name: &str, path: &Path) -> Result<Storage, LutError> {
        let (info, bytes) =
            self.section(name).ok_or_else(|| LutError::MissingSection { section: name.into(), path: path.into() })?;
        let bad = |what: String| LutError::BadSection { section: name.into(), offset: 0, what, path: path.into() };
        let precision =
            info.dtype.precision().ok_or_else(|| bad(format!("dtype {:?} is not a table precision", info.dtype)))?;
        let channels = *info.dims.last().ok_or_else(|| bad("no dims".into()))? as usize;
        let count = info.count().ok_or_else(|| bad("dims overflow".into()))? as usize;
        let scale = if info.scale.is_empty() { vec![1.0; channels] } else { info.scale.clone() };
        Storage::from_le_bytes(bytes, count, channels, precision, scale)
            .ok_or_else(|| bad(format!("does not decode as {count} {precision} values in {channels} channels")))
    }
}

fn align(n: usize) -> usize {
    n.div_ceil(ALIGN) * ALIGN
}

/// What `tetlut bake` asks for; unused fields are ignored by a method.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct BakeOptions {
    /// `table3d` and `atlas2d` (which resamples a table3d).
    pub table3d: Table3dParams,
    /// `atlas2d`: planes in quarters of n_s (16 = 4N, 4 = N, 2 = N/2).
    pub atlas_planes_quarters: usize,
    /// `partial`: Ψ table.
    pub psi: PsiParams,
}

impl Default for BakeOptions {
    fn default() -> Self {
        BakeOptions { table3d: Table3dParams::default(), atlas_planes_quarters: 4, psi: PsiParams::default() }
    }
}

/// Section names used by this module's methods.
pub const TABLE3D_SECTION: &str = "T3D";
pub const ATLAS_SECTION: &str = "ATLAS";
pub const PSI_SECTION: &str = "PSI";

/// Bakes `method` for `tf` over `domain` into a `.tetl` in memory.
/// Methods this module does not build (poly*, biv-*, exact, pt-linear) are
/// an error.
pub fn bake(
    method: Method,
    tf: &TransferFunction,
    domain: &TableDomain,
    opts: &BakeOptions,
) -> Result<LutFile, TableError> {
    match method {
        Method::Table3d => Ok(Table3d::build(tf, domain, &opts.table3d)?.to_lut(tf)),
        Method::Atlas2d => {
            let t = Table3d::build(tf, domain, &opts.table3d)?;
            let params = Atlas2dParams::for_table(&t, opts.atlas_planes_quarters, opts.table3d.precision);
            Ok(Atlas2d::build(&t, &params)?.to_lut(tf))
        }
        Method::Partial => {
            let mut psi = opts.psi;
            psi.first_moment |= tf.emission() == Emission::Independent;
            Ok(PsiTable::build(&psi)?.to_lut(tf, domain))
        }
        m => Err(TableError::Invalid(format!("method '{m}' is not baked by tet_preint's table module"))),
    }
}

/// A shader for a baked file of method table3d, atlas2d or partial.
pub fn load_shader(lut: &LutFile, path: &Path) -> Result<Box<dyn SegmentShader>, LutError> {
    let method: Method = lut.header.method.parse().map_err(|_| LutError::Method {
        found: lut.header.method.clone(),
        what: "is not a known method id".into(),
        path: path.into(),
    })?;
    Ok(match method {
        Method::Table3d => Box::new(Table3d::from_lut(lut, path)?),
        Method::Atlas2d => Box::new(Atlas2d::from_lut(lut, path)?),
        Method::Partial => {
            let tf = lut.transfer_function().map_err(|e| LutError::BadSection {
                section: HEADER_SECTION.into(),
                offset: 0,
                what: format!("tf: {e}"),
                path: path.into(),
            })?;
            let psi = Arc::new(PsiTable::from_lut(lut, path)?);
            Box::new(
                PartialShader::new(tf, psi)
                    .map_err(|e| LutError::Damaged { what: e.to_string(), path: path.into() })?,
            )
        }
        m => {
            return Err(LutError::Method {
                found: m.id().into(),
                what: "has no table loader here".into(),
                path: path.into(),
            })
        }
    })
}

fn params_of<T: for<'de> Deserialize<'de>>(lut: &LutFile, method: Method, path: &Path) -> Result<T, LutError> {
    if lut.header.method != method.id() {
        return Err(LutError::Method {
            found: lut.header.method.clone(),
            what: format!("is not {method}"),
            path: path.into(),
        });
    }
    serde_json::from_value(lut.header.params.clone()).map_err(|e| LutError::BadSection {
        section: HEADER_SECTION.into(),
        offset: 0,
        what: format!("params for {method} do not decode ({e})"),
        path: path.into(),
    })
}

fn domain_of(lut: &LutFile, path: &Path) -> Result<TableDomain, LutError> {
    let d = lut.header.domain.ok_or_else(|| LutError::BadSection {
        section: HEADER_SECTION.into(),
        offset: 0,
        what: "no domain".into(),
        path: path.into(),
    })?;
    TableDomain::new(d.s_lo, d.s_hi, d.max_ds, d.len_max_world).map_err(|e| LutError::BadSection {
        section: HEADER_SECTION.into(),
        offset: 0,
        what: e.to_string(),
        path: path.into(),
    })
}

fn layout_error(section: &str, path: &Path) -> LutError {
    LutError::BadSection {
        section: section.into(),
        offset: 0,
        what: "size or precision does not match the header's params".into(),
        path: path.into(),
    }
}

impl Table3d {
    /// The table as a `.tetl` (section `T3D`: dims [pairs, n_l, 4]).
    pub fn to_lut(&self, tf: &TransferFunction) -> LutFile {
        let params = serde_json::to_value(self.params()).expect("params serialize");
        let mut f = LutFile::new(Method::Table3d, tf, Some(*self.domain()), params);
        let n_l = self.params().n_l as u64;
        let pairs = self.storage().len() as u64 / (4 * n_l);
        f.push_storage(TABLE3D_SECTION, vec![pairs, n_l, 4], self.storage()).expect("valid name");
        f
    }

    pub fn from_lut(lut: &LutFile, path: &Path) -> Result<Table3d, LutError> {
        let params: Table3dParams = params_of(lut, Method::Table3d, path)?;
        let domain = domain_of(lut, path)?;
        let data = lut.storage(TABLE3D_SECTION, path)?;
        Table3d::from_parts(domain, params, data).ok_or_else(|| layout_error(TABLE3D_SECTION, path))
    }
}

impl Atlas2d {
    /// The atlas as a `.tetl` (section `ATLAS`: dims [height, width, 4]).
    pub fn to_lut(&self, tf: &TransferFunction) -> LutFile {
        let params = serde_json::to_value(self.params()).expect("params serialize");
        let mut f = LutFile::new(Method::Atlas2d, tf, Some(*self.domain()), params);
        let (w, h) = self.image_size();
        f.push_storage(ATLAS_SECTION, vec![h as u64, w as u64, 4], self.storage()).expect("valid name");
        f
    }

    pub fn from_lut(lut: &LutFile, path: &Path) -> Result<Atlas2d, LutError> {
        let params: Atlas2dParams = params_of(lut, Method::Atlas2d, path)?;
        let domain = domain_of(lut, path)?;
        let data = lut.storage(ATLAS_SECTION, path)?;
        Atlas2d::from_parts(domain, params, data).ok_or_else(|| layout_error(ATLAS_SECTION, path))
    }
}

impl PsiTable {
    /// The Ψ table as a `.tetl` of method `partial` for `tf` (section `PSI`:
    /// dims [res, res, 1 or 2]); the domain is informative only.
    pub fn to_lut(&self, tf: &TransferFunction, domain: &TableDomain) -> LutFile {
        let params = serde_json::to_value(self.params()).expect("params serialize");
        let mut f = LutFile::new(Method::Partial, tf, Some(*domain), params);
        let (r, ch) = (self.params().res as u64, self.storage().channels() as u64);
        f.push_storage(PSI_SECTION, vec![r, r, ch], self.storage()).expect("valid name");
        f
    }

    pub fn from_lut(lut: &LutFile, path: &Path) -> Result<PsiTable, LutError> {
        let params: PsiParams = params_of(lut, Method::Partial, path)?;
        let data = lut.storage(PSI_SECTION, path)?;
        PsiTable::from_parts(params, data).ok_or_else(|| layout_error(PSI_SECTION, path))
    }
}
