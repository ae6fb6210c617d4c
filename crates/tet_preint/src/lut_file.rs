//! The `.tetl` lookup-table file (spec: `formats/lut.md`) and the bake /
//! load entry points `tetlut` calls.
//!
//! The bundle's container (`tet_container`): magic, version, a CRC-32'd
//! section table, 16-byte aligned payloads each with its own CRC-32, written
//! atomically (temporary file beside the target, fsync, rename). The `HEADER` section is
//! JSON naming the method, the TF it was baked from, the domain, the
//! method's parameters and one [`SectionInfo`] (dtype, dims, channels,
//! unorm scale) per data section, so new table kinds need no format change.

use crate::atlas2d::{Atlas2d, Atlas2dParams};
use crate::bivariate::{BivApprox, BivExact, FbTable};
use crate::certify::{Certificate, CertifiedTable3d, CertifyOptions};
use crate::domain::{TableDomain, TableError};
use crate::factory::{tf_for_domain, Baked, MAX_SUBSEGMENTS};
use crate::method::{ExactShader, Method, PtLinearShader, SegmentShader};
use crate::partial::{PartialShader, PsiParams, PsiTable};
use crate::poly::{AlphaTable, PolyTable};
use crate::precision::{Precision, Storage};
use crate::table3d::{ScalarAxis, Table3d, Table3dParams};
use crate::tf::TransferFunction;
use serde::{Deserialize, Serialize};
use std::io::Write;
use std::path::{Path, PathBuf};
use std::sync::Arc;
use tet_container::{ContainerError, ContainerFormat};

/// First 8 bytes of every `.tetl` file (PNG-style: high byte, CR LF, ^Z).
pub const LUT_MAGIC: [u8; 8] = *b"\x89TETL\r\n\x1a";
/// Format version written, and the newest read. Version 2 added the
/// non-uniform scalar axis of `table3d` (`params.s_axis`, section `SAXIS`);
/// version-1 files read as before (their tables have a uniform axis).
/// Version 3 added the `"data"` scalar axis (knots in `SAXIS` as for
/// `"tf-nodes"`); versions 1 and 2 read as before. Version 4 added the
/// `"adaptive"` table3d build kind (`params.build`; the sections mean the
/// same); versions 1–3 read as before. Version 5 added the header's
/// `certificate` (what a `table3d` bake measured of itself, and whether its
/// lookup splits segments at TF nodes); versions 1–4 read as before
/// (no certificate, plain lookups).
pub const LUT_FORMAT_VERSION: u32 = 5;
/// The container format of `.tetl` files (see `tet_container`).
const FORMAT: ContainerFormat =
    ContainerFormat { magic: LUT_MAGIC, version: LUT_FORMAT_VERSION, max_sections: 1 << 12 };
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
    /// Method id (`table3d`, `atlas2d`, `partial`, …; `tet_preint::Method`).
    pub method: String,
    /// The transfer function baked, as `formats/tf.md` JSON.
    pub tf: serde_json::Value,
    /// The (Sf, Sb, l) domain, for methods that have one.
    pub domain: Option<TableDomain>,
    /// Method parameters (resolution, build, precision, …).
    pub params: serde_json::Value,
    pub sections: Vec<SectionInfo>,
    /// `table3d` (version 5): the bake's measured error against `exact`
    /// ([`Certificate`]); absent when the bake measured nothing and in
    /// files before version 5.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub certificate: Option<Certificate>,
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
        // The header holds what the file stores: a domain's quantiles are
        // not written (the axis knots they shaped are).
        let domain = domain.map(|d| TableDomain { s_quantiles: None, ..d });
        LutFile {
            header: LutHeader {
                writer: writer(),
                method: method.id().into(),
                tf,
                domain,
                params,
                sections: vec![],
                certificate: None,
            },
            payloads: vec![],
        }
    }

    /// Appends a data section.
    pub fn push(&mut self, info: SectionInfo, payload: Vec<u8>) -> Result<(), LutError> {
        if !tet_container::valid_section_name(&info.name) || info.name == HEADER_SECTION {
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

    fn write_to(&self, out: &mut dyn Write) -> std::io::Result<()> {
        let header = serde_json::to_vec_pretty(&self.header).expect("header serializes");
        let mut sections: Vec<(&str, &[u8])> = vec![(HEADER_SECTION, &header)];
        for (info, p) in self.header.sections.iter().zip(&self.payloads) {
            sections.push((&info.name, p));
        }
        tet_container::write_sections(out, &FORMAT, &sections)
    }

    /// Writes atomically: temporary file beside `path`, fsync, rename.
    pub fn write(&self, path: &Path) -> Result<(), LutError> {
        tet_container::write_atomic(path, ".tetl-", |w| self.write_to(w)).map_err(|e| LutError::Io {
            action: e.action,
            source: e.source,
            path: path.to_path_buf(),
        })
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
        let (_, table) = tet_container::parse(bytes, &FORMAT).map_err(|e| match e {
            ContainerError::BadMagic => LutError::BadMagic { path: p() },
            ContainerError::NewerVersion { found, supported } => LutError::NewerVersion { found, supported, path: p() },
            ContainerError::Truncated { what, offset } => LutError::Truncated { what, offset, path: p() },
            ContainerError::Damaged { what } => LutError::Damaged { what, path: p() },
            ContainerError::BadChecksum { section, offset, expected, found } => {
                LutError::BadChecksum { section, offset, expected, found, path: p() }
            }
        })?;
        let entries: Vec<(String, u64, &[u8])> =
            table.into_iter().map(|e| (e.data(bytes), e)).map(|(d, e)| (e.name, e.offset, d)).collect();
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

/// What `tetlut bake` and [`crate::make_shader`] ask for; each method reads
/// only its own fields.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct BakeOptions {
    /// `table3d` and `atlas2d` (which resamples a table3d).
    pub table3d: Table3dParams,
    /// `atlas2d`: planes in quarters of n_s (16 = 4N, 4 = N, 2 = N/2).
    pub atlas_planes_quarters: usize,
    /// `partial`: Ψ table.
    pub psi: PsiParams,
    /// `poly1`/`poly2`/`poly4`: table side N (N × N over the scalar range).
    pub poly_res: usize,
    /// `biv-approx`: F/B table side.
    pub fb_res: usize,
    /// `biv-approx`: equal sub-segments per segment (Song et al.'s (2009) k).
    pub biv_subsegments: usize,
    /// Storage of the poly tables (f32 or f16: their coefficients are
    /// signed) and of the F/B table (any precision).
    pub precision_2d: Precision,
    /// `table3d`: the error target the bake measures itself against and
    /// refines `table3d` (as the starting resolution) to meet, within a
    /// memory budget ([`crate::certify`]); `CertifyOptions::off()` bakes
    /// `table3d` as given.
    pub certify: CertifyOptions,
}

impl Default for BakeOptions {
    /// table3d 128 × 128 × 256 f32 (adaptive build, samples following the
    /// data's scalars, refined at and placed on every TF control point:
    /// [`Table3dParams::data`]); atlas2d N
    /// planes; Ψ 1024² f32; poly 512² f32; F/B 128² f32 with 4 sub-segments;
    /// table3d certified to max error 1e-3 within 256 MiB.
    fn default() -> Self {
        BakeOptions {
            table3d: Table3dParams::data(),
            atlas_planes_quarters: 4,
            psi: PsiParams::default(),
            poly_res: 512,
            fb_res: 128,
            biv_subsegments: 4,
            precision_2d: Precision::F32,
            certify: CertifyOptions::default(),
        }
    }
}

/// Section names used by this module's methods.
pub const TABLE3D_SECTION: &str = "T3D";
/// `table3d` with a non-uniform scalar axis: its knots.
pub const TABLE3D_AXIS_SECTION: &str = "SAXIS";
pub const ATLAS_SECTION: &str = "ATLAS";
pub const PSI_SECTION: &str = "PSI";
pub const POLY_RHO_SECTION: &str = "RHO";
pub const POLY_COEF_SECTION: &str = "COEF";
pub const POLY_ALPHA_SECTION: &str = "ALPHA";
pub const FB_SECTION: &str = "FB";

/// Bakes `method` for `tf` over `domain` into a `.tetl` in memory (through
/// [`Baked::build`]: a normalized TF is mapped onto the domain's scalar
/// range, and the header stores the TF in data units). `exact`, `pt-linear`
/// and `biv-exact` tabulate nothing: their file holds the TF only.
pub fn bake(
    method: Method,
    tf: &TransferFunction,
    domain: &TableDomain,
    opts: &BakeOptions,
) -> Result<LutFile, TableError> {
    let tf = tf_for_domain(tf, domain)?;
    Ok(Baked::build(method, &tf, domain, opts)?.to_lut(&tf, domain))
}

/// A shader for a baked file of any method.
pub fn load_shader(lut: &LutFile, path: &Path) -> Result<Box<dyn SegmentShader>, LutError> {
    Ok(Baked::from_lut(lut, path)?.into_shader())
}

/// `params` of the methods that tabulate nothing.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
struct UntabulatedParams {
    /// Always false: the shader evaluates the TF per segment.
    tabulated: bool,
}

/// `params` of `poly1`/`poly2`/`poly4` files.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct PolyFileParams {
    pub degree: usize,
    pub res: usize,
    /// Band half-width in samples, `null` for the full square.
    pub band: Option<usize>,
    pub s_lo: f32,
    pub s_hi: f32,
    pub l_max: f32,
    /// Largest κ per channel (the colour clamp).
    pub max_color: [f32; 3],
    /// Range of the 16-bit α table.
    pub alpha_x_max: f32,
    pub precision: Precision,
}

/// `params` of `biv-approx` files.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct FbFileParams {
    pub res: usize,
    pub subsegments: usize,
    pub precision: Precision,
}

fn header_error(what: String, path: &Path) -> LutError {
    LutError::BadSection { section: HEADER_SECTION.into(), offset: 0, what, path: path.into() }
}

impl Baked {
    /// The baked method as a `.tetl`; `tf` (data units) is stored in the
    /// header, `domain` too where the method has none of its own.
    pub fn to_lut(&self, tf: &TransferFunction, domain: &TableDomain) -> LutFile {
        let untabulated = || serde_json::to_value(UntabulatedParams { tabulated: false }).expect("serializes");
        match self {
            Baked::Table3d(t) => t.to_lut(tf),
            Baked::Atlas2d(t) => t.to_lut(tf),
            Baked::Partial(s) => s.psi().to_lut(tf, domain),
            Baked::Poly(t, precision) => t.to_lut(tf, domain, *precision),
            Baked::BivApprox(s, precision) => fb_to_lut(s, tf, domain, *precision),
            Baked::Exact(_) | Baked::PtLinear(_) | Baked::BivExact(_) => {
                LutFile::new(self.method(), tf, Some(*domain), untabulated())
            }
        }
    }

    /// Rebuilds the baked method from a file, checking every section against
    /// the header's params.
    pub fn from_lut(lut: &LutFile, path: &Path) -> Result<Baked, LutError> {
        let method: Method = lut.header.method.parse().map_err(|_| LutError::Method {
            found: lut.header.method.clone(),
            what: "is not a known method id".into(),
            path: path.into(),
        })?;
        let tf = || lut.transfer_function().map_err(|e| header_error(format!("tf: {e}"), path));
        let no_widgets = |tf: TransferFunction| {
            if tf.widgets().is_empty() || method.is_bivariate() {
                Ok(tf)
            } else {
                Err(header_error(format!("method {method} cannot hold a TF with 2D widgets"), path))
            }
        };
        Ok(match method {
            Method::Table3d => Baked::Table3d(CertifiedTable3d::from_lut(lut, path)?),
            Method::Atlas2d => Baked::Atlas2d(Atlas2d::from_lut(lut, path)?),
            Method::Partial => {
                let tf = no_widgets(tf()?)?;
                let psi = Arc::new(PsiTable::from_lut(lut, path)?);
                Baked::Partial(
                    PartialShader::new(tf, psi)
                        .map_err(|e| LutError::Damaged { what: e.to_string(), path: path.into() })?,
                )
            }
            Method::Poly1 | Method::Poly2 | Method::Poly4 => {
                let t = PolyTable::from_lut(lut, path)?;
                let p: PolyFileParams = params_of(lut, method, path)?;
                Baked::Poly(t, p.precision)
            }
            Method::BivApprox => {
                let p: FbFileParams = params_of(lut, method, path)?;
                Baked::BivApprox(fb_from_lut(lut, &tf()?, path)?, p.precision)
            }
            Method::Exact | Method::PtLinear | Method::BivExact => {
                let _: UntabulatedParams = params_of(lut, method, path)?;
                let tf = no_widgets(tf()?)?;
                match method {
                    Method::Exact => Baked::Exact(ExactShader::new(tf)),
                    Method::PtLinear => Baked::PtLinear(PtLinearShader::new(tf)),
                    _ => Baked::BivExact(BivExact::new(tf)),
                }
            }
        })
    }
}

/// Raw little-endian bytes of f32 values in `precision` (f32 or f16).
fn push_f32s(
    f: &mut LutFile,
    name: &str,
    dims: Vec<u64>,
    values: &[f32],
    precision: Precision,
) -> Result<(), LutError> {
    let channels = *dims.last().expect("dims") as usize;
    f.push_storage(name, dims, &Storage::encode(values.to_vec(), channels, precision))
}

fn fb_to_lut(s: &BivApprox, tf: &TransferFunction, domain: &TableDomain, precision: Precision) -> LutFile {
    let t = s.table();
    let params = FbFileParams { res: t.res(), subsegments: s.subsegments(), precision };
    let mut f = LutFile::new(Method::BivApprox, tf, Some(*domain), serde_json::to_value(params).expect("serializes"));
    let fb: Vec<f32> = t.f().iter().zip(t.b()).flat_map(|(a, b)| [*a, *b]).collect();
    let r = t.res() as u64;
    push_f32s(&mut f, FB_SECTION, vec![r, r, 2], &fb, precision).expect("valid name");
    f
}

fn fb_from_lut(lut: &LutFile, tf: &TransferFunction, path: &Path) -> Result<BivApprox, LutError> {
    let p: FbFileParams = params_of(lut, Method::BivApprox, path)?;
    let data = lut.storage(FB_SECTION, path)?;
    let r = p.res;
    if data.channels() != 2 || data.precision() != p.precision || Some(data.len()) != r.checked_mul(2 * r) {
        return Err(layout_error(FB_SECTION, path));
    }
    let v = data.to_f32();
    let (f, b): (Vec<f32>, Vec<f32>) = v.chunks_exact(2).map(|c| (c[0], c[1])).unzip();
    let table = FbTable::from_parts(tf.emission(), r, f, b).ok_or_else(|| layout_error(FB_SECTION, path))?;
    BivApprox::new(tf.clone(), table, p.subsegments).ok_or_else(|| {
        header_error(format!("biv-approx sub-segments {} not in 1..={MAX_SUBSEGMENTS}", p.subsegments), path)
    })
}

impl PolyTable {
    /// The table as a `.tetl` of method poly{degree} (sections `RHO`: dims
    /// [res, row_len, 1]; `COEF`: [res, row_len, 3(n+1)]; `ALPHA`: [len, 1]
    /// unorm16 with scale 1), ρ̂ and the coefficients stored in `precision`
    /// (f32 or f16; [`Baked::build`] rounds the in-memory table the same
    /// way so that baking and loading give the same shader).
    pub fn to_lut(&self, tf: &TransferFunction, domain: &TableDomain, precision: Precision) -> LutFile {
        let [s_lo, s_hi] = self.s_range();
        let params = PolyFileParams {
            degree: self.degree(),
            res: self.res(),
            band: self.band(),
            s_lo,
            s_hi,
            l_max: self.l_max(),
            max_color: self.max_color(),
            alpha_x_max: self.alpha_table().x_max(),
            precision,
        };
        let mut f = LutFile::new(self.method(), tf, Some(*domain), serde_json::to_value(params).expect("serializes"));
        let (res, row) = (self.res() as u64, self.row_len() as u64);
        let stride = 3 * (self.degree() as u64 + 1);
        push_f32s(&mut f, POLY_RHO_SECTION, vec![res, row, 1], self.rho(), precision).expect("valid name");
        push_f32s(&mut f, POLY_COEF_SECTION, vec![res, row, stride], self.coef(), precision).expect("valid name");
        let alpha = self.alpha_table().data();
        let info = SectionInfo {
            name: POLY_ALPHA_SECTION.into(),
            dtype: DType::Unorm16,
            dims: vec![alpha.len() as u64, 1],
            scale: vec![1.0],
        };
        f.push(info, alpha.iter().flat_map(|v| v.to_le_bytes()).collect()).expect("valid name");
        f
    }

    pub fn from_lut(lut: &LutFile, path: &Path) -> Result<PolyTable, LutError> {
        let method: Method = lut.header.method.parse().map_err(|_| LutError::Method {
            found: lut.header.method.clone(),
            what: "is not a known method id".into(),
            path: path.into(),
        })?;
        if !matches!(method, Method::Poly1 | Method::Poly2 | Method::Poly4) {
            return Err(LutError::Method {
                found: method.id().into(),
                what: "is not poly1/2/4".into(),
                path: path.into(),
            });
        }
        let p: PolyFileParams = params_of(lut, method, path)?;
        let want_degree = match method {
            Method::Poly1 => 1,
            Method::Poly2 => 2,
            _ => 4,
        };
        if p.degree != want_degree {
            return Err(header_error(format!("params.degree {} does not match method {method}", p.degree), path));
        }
        let tf = lut.transfer_function().map_err(|e| header_error(format!("tf: {e}"), path))?;
        let rho = lut.storage(POLY_RHO_SECTION, path)?;
        let coef = lut.storage(POLY_COEF_SECTION, path)?;
        if rho.precision() != p.precision || coef.precision() != p.precision {
            return Err(layout_error(POLY_COEF_SECTION, path));
        }
        let (info, bytes) = lut
            .section(POLY_ALPHA_SECTION)
            .ok_or_else(|| LutError::MissingSection { section: POLY_ALPHA_SECTION.into(), path: path.into() })?;
        if info.dtype != DType::Unorm16 || info.scale.iter().any(|s| *s != 1.0) {
            return Err(layout_error(POLY_ALPHA_SECTION, path));
        }
        let alpha: Vec<u16> = bytes.chunks_exact(2).map(|c| u16::from_le_bytes([c[0], c[1]])).collect();
        let alpha = AlphaTable::from_parts(p.alpha_x_max, alpha).map_err(|e| LutError::BadSection {
            section: POLY_ALPHA_SECTION.into(),
            offset: 0,
            what: e.to_string(),
            path: path.into(),
        })?;
        PolyTable::from_parts(
            p.degree,
            p.res,
            p.band,
            [p.s_lo, p.s_hi],
            p.l_max,
            tf.emission(),
            p.max_color,
            rho.to_f32(),
            coef.to_f32(),
            alpha,
        )
        .map_err(|e| LutError::BadSection {
            section: POLY_COEF_SECTION.into(),
            offset: 0,
            what: e.to_string(),
            path: path.into(),
        })
    }
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

/// The `SAXIS` section: f64 [K, 2] of (scalar, grid index) knots.
fn axis_knots(lut: &LutFile, n_s: usize, path: &Path) -> Result<Vec<(f64, usize)>, LutError> {
    let bad = |what: String| LutError::BadSection {
        section: TABLE3D_AXIS_SECTION.into(),
        offset: 0,
        what,
        path: path.into(),
    };
    let (info, bytes) = lut
        .section(TABLE3D_AXIS_SECTION)
        .ok_or_else(|| bad("missing: params.s_axis is tf-nodes but the file has no knots".into()))?;
    if info.dtype != DType::F64 || info.dims.len() != 2 || info.dims[1] != 2 || bytes.len() % 16 != 0 {
        return Err(bad(format!("expected f64 [K, 2], found {:?} {:?}", info.dtype, info.dims)));
    }
    let v: Vec<f64> = bytes.chunks_exact(8).map(|c| f64::from_le_bytes(c.try_into().expect("8 bytes"))).collect();
    v.chunks_exact(2)
        .map(|k| {
            let i = k[1];
            if i.fract() == 0.0 && (0.0..n_s as f64).contains(&i) {
                Ok((k[0], i as usize))
            } else {
                Err(bad(format!("knot index {i} is not a grid index below {n_s}")))
            }
        })
        .collect()
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
        if self.params().s_axis != ScalarAxis::Uniform {
            let knots = self.s_knots();
            let bytes: Vec<u8> = knots.iter().flat_map(|&(s, i)| [s, i as f64]).flat_map(f64::to_le_bytes).collect();
            let info = SectionInfo {
                name: TABLE3D_AXIS_SECTION.into(),
                dtype: DType::F64,
                dims: vec![knots.len() as u64, 2],
                scale: vec![],
            };
            f.push(info, bytes).expect("valid name");
        }
        f
    }

    pub fn from_lut(lut: &LutFile, path: &Path) -> Result<Table3d, LutError> {
        let params: Table3dParams = params_of(lut, Method::Table3d, path)?;
        let domain = domain_of(lut, path)?;
        let data = lut.storage(TABLE3D_SECTION, path)?;
        let knots = match params.s_axis {
            ScalarAxis::Uniform => None,
            ScalarAxis::TfNodes | ScalarAxis::Data => Some(axis_knots(lut, params.n_s, path)?),
        };
        Table3d::from_parts(domain, params, knots.as_deref(), data).ok_or_else(|| {
            let what = if knots.is_some() { "size, precision or scalar-axis knots" } else { "size or precision" };
            LutError::BadSection {
                section: TABLE3D_SECTION.into(),
                offset: 0,
                what: format!("{what} do not match the header's params"),
                path: path.into(),
            }
        })
    }
}

impl CertifiedTable3d {
    /// The table as a `.tetl` ([`Table3d::to_lut`]) with its certificate.
    pub fn to_lut(&self, tf: &TransferFunction) -> LutFile {
        let mut f = self.table().to_lut(tf);
        f.header.certificate = self.certificate().cloned();
        f
    }

    /// A stored table and its certificate; a certificate that says the
    /// lookup splits at TF nodes splits at the header's TF's.
    pub fn from_lut(lut: &LutFile, path: &Path) -> Result<CertifiedTable3d, LutError> {
        let table = Table3d::from_lut(lut, path)?;
        let cert = lut.header.certificate.clone();
        // Only a splitting lookup needs the TF (its control points).
        let tf = match &cert {
            Some(c) if c.split_at_tf_nodes => {
                Some(lut.transfer_function().map_err(|e| header_error(format!("tf: {e}"), path))?)
            }
            _ => None,
        };
        CertifiedTable3d::from_parts(table, tf.as_ref(), cert).ok_or_else(|| {
            header_error("certificate.exact_intervals names an interval the TF does not have".into(), path)
        })
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
