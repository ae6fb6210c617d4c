//! NetCDF files (the container of Exodus II meshes): the header and
//! whole-variable or one-record reads, for files already in memory.
//!
//! Classic-model files are parsed here; netCDF-4 files (HDF5 underneath:
//! the form SEACAS tools and `nccopy -k nc4` write, chunked and
//! compressed or not) are decoded by the pure-Rust `netcdf-reader` crate
//! and presented through the same [`NetCdf`] view (root group only, as
//! Exodus uses it).
//!
//! Format: Unidata, "NetCDF File Format Specification" (classic `CDF\x01`,
//! 64-bit offset `CDF\x02`, 64-bit data `CDF\x05`; big-endian throughout).
//! The header lists dimensions (one of length 0 is the record dimension),
//! global attributes and variables (name, dimension ids, attributes, type,
//! padded size `vsize`, and the offset `begin` of its data). A fixed-size
//! variable's values are contiguous at `begin`; a record variable's values
//! for record r start at `begin + r·recsize`, `recsize` being the sum of the
//! record variables' `vsize` (unpadded when there is only one).
//!
//! Every count and offset is checked against the file's length before use;
//! a malformed header is an error with its byte offset.

use crate::cursor::{ByteCursor, Endian};
use crate::{FormatError, Location};

const NC_DIMENSION: u32 = 0x0A;
const NC_VARIABLE: u32 = 0x0B;
const NC_ATTRIBUTE: u32 = 0x0C;

/// A netCDF external type.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum NcType {
    Byte,
    Char,
    Short,
    Int,
    Float,
    Double,
    UByte,
    UShort,
    UInt,
    Int64,
    UInt64,
}

impl NcType {
    fn from_code(code: u32) -> Option<NcType> {
        Some(match code {
            1 => NcType::Byte,
            2 => NcType::Char,
            3 => NcType::Short,
            4 => NcType::Int,
            5 => NcType::Float,
            6 => NcType::Double,
            7 => NcType::UByte,
            8 => NcType::UShort,
            9 => NcType::UInt,
            10 => NcType::Int64,
            11 => NcType::UInt64,
            _ => return None,
        })
    }

    pub fn size(self) -> usize {
        match self {
            NcType::Byte | NcType::Char | NcType::UByte => 1,
            NcType::Short | NcType::UShort => 2,
            NcType::Int | NcType::Float | NcType::UInt => 4,
            NcType::Double | NcType::Int64 | NcType::UInt64 => 8,
        }
    }
}

#[derive(Debug, Clone, PartialEq)]
pub struct Dimension {
    pub name: String,
    /// 0 for the record dimension (its length is [`NetCdf::num_records`]).
    pub len: usize,
}

/// An attribute: text for `NC_CHAR`, numbers otherwise.
#[derive(Debug, Clone, PartialEq)]
pub enum AttrValue {
    Text(String),
    Numbers(Vec<f64>),
}

#[derive(Debug, Clone, PartialEq)]
pub struct Variable {
    pub name: String,
    pub dims: Vec<usize>,
    pub attrs: Vec<(String, AttrValue)>,
    pub ty: NcType,
    vsize: u64,
    begin: u64,
    /// Byte offset of this variable's header entry (for errors).
    at: u64,
}

impl Variable {
    /// The text of attribute `name`, if it is text.
    pub fn text_attr(&self, name: &str) -> Option<&str> {
        self.attrs.iter().find(|(n, _)| n == name).and_then(|(_, v)| match v {
            AttrValue::Text(t) => Some(t.as_str()),
            AttrValue::Numbers(_) => None,
        })
    }
}

/// A parsed header over the file's bytes.
pub struct NetCdf<'a> {
    bytes: &'a [u8],
    /// A netCDF-4 file's decoder (`None` for classic files).
    nc4: Option<netcdf_reader::NcFile>,
    pub dims: Vec<Dimension>,
    pub attrs: Vec<(String, AttrValue)>,
    pub vars: Vec<Variable>,
    pub num_records: usize,
    record_dim: Option<usize>,
    record_size: u64,
}

/// Reads a count or dimension length: 4 bytes, or 8 in CDF-5.
fn non_neg(c: &mut ByteCursor<'_>, wide: bool, what: &str) -> Result<u64, FormatError> {
    if wide {
        c.u64(Endian::Big, what)
    } else {
        let v = c.i32(Endian::Big, what)?;
        u64::try_from(v).map_err(|_| FormatError::new(c.location(), format!("{what} is negative ({v})")))
    }
}

fn name(c: &mut ByteCursor<'_>, wide: bool) -> Result<String, FormatError> {
    let n = non_neg(c, wide, "name length")? as usize;
    let at = c.location();
    let raw = c.take(n, "name")?;
    c.take((4 - n % 4) % 4, "name padding")?;
    String::from_utf8(raw.to_vec()).map_err(|_| FormatError::new(at, "a name is not UTF-8"))
}

fn decode(raw: &[u8], ty: NcType, out: &mut Vec<f64>) {
    let n = raw.len() / ty.size();
    out.reserve(n);
    for k in 0..n {
        let b = &raw[k * ty.size()..(k + 1) * ty.size()];
        out.push(match ty {
            NcType::Byte => b[0] as i8 as f64,
            NcType::Char | NcType::UByte => b[0] as f64,
            NcType::Short => i16::from_be_bytes([b[0], b[1]]) as f64,
            NcType::UShort => u16::from_be_bytes([b[0], b[1]]) as f64,
            NcType::Int => i32::from_be_bytes(b.try_into().expect("4 bytes")) as f64,
            NcType::UInt => u32::from_be_bytes(b.try_into().expect("4 bytes")) as f64,
            NcType::Float => f32::from_be_bytes(b.try_into().expect("4 bytes")) as f64,
            NcType::Double => f64::from_be_bytes(b.try_into().expect("8 bytes")),
            NcType::Int64 => i64::from_be_bytes(b.try_into().expect("8 bytes")) as f64,
            NcType::UInt64 => u64::from_be_bytes(b.try_into().expect("8 bytes")) as f64,
        });
    }
}

fn attr_list(c: &mut ByteCursor<'_>, wide: bool) -> Result<Vec<(String, AttrValue)>, FormatError> {
    let tag = c.u32(Endian::Big, "attribute list tag")?;
    let n = non_neg(c, wide, "attribute count")? as usize;
    if tag == 0 && n == 0 {
        return Ok(Vec::new());
    }
    if tag != NC_ATTRIBUTE {
        return Err(FormatError::new(c.location(), format!("expected an attribute list (tag 12), found tag {tag}")));
    }
    let mut out = Vec::with_capacity(n.min(c.remaining() / 12));
    for _ in 0..n {
        let key = name(c, wide)?;
        let code = c.u32(Endian::Big, "attribute type")?;
        let ty = NcType::from_code(code)
            .ok_or_else(|| FormatError::new(c.location(), format!("attribute '{key}' has unknown type {code}")))?;
        let count = non_neg(c, wide, "attribute length")? as usize;
        let bytes = count
            .checked_mul(ty.size())
            .ok_or_else(|| FormatError::new(c.location(), format!("attribute '{key}' is too long")))?;
        let raw = c.take(bytes, "attribute values")?;
        c.take((4 - bytes % 4) % 4, "attribute padding")?;
        let value = if ty == NcType::Char {
            AttrValue::Text(String::from_utf8_lossy(raw).trim_end_matches('\0').to_string())
        } else {
            let mut v = Vec::new();
            decode(raw, ty, &mut v);
            AttrValue::Numbers(v)
        };
        out.push((key, value));
    }
    Ok(out)
}

impl<'a> NetCdf<'a> {
    /// Parses the header of a classic, 64-bit offset or CDF-5 file, or of
    /// a netCDF-4 (HDF5) file.
    pub fn parse(bytes: &'a [u8]) -> Result<NetCdf<'a>, FormatError> {
        if bytes.starts_with(HDF5_MAGIC) {
            return NetCdf::parse_nc4(bytes);
        }
        let mut c = ByteCursor::new(bytes);
        let magic = c.take(4, "magic")?;
        if &magic[..3] != b"CDF" || !matches!(magic[3], 1 | 2 | 5) {
            return Err(FormatError::new(
                Location::Byte(0),
                "not a netCDF classic file (magic CDF\\x01, \\x02 or \\x05)",
            ));
        }
        let (wide, offset64) = (magic[3] == 5, magic[3] != 1);
        let numrecs_at = c.location();
        let numrecs =
            if wide { c.u64(Endian::Big, "record count")? } else { c.u32(Endian::Big, "record count")? as u64 };
        // STREAMING (all ones): the count is not written; derived below.
        let streaming = numrecs == u64::MAX || (!wide && numrecs == u32::MAX as u64);
        let tag = c.u32(Endian::Big, "dimension list tag")?;
        let ndims = non_neg(&mut c, wide, "dimension count")? as usize;
        if !(tag == NC_DIMENSION || (tag == 0 && ndims == 0)) {
            return Err(FormatError::new(c.location(), format!("expected a dimension list (tag 10), found tag {tag}")));
        }
        let mut dims = Vec::with_capacity(ndims.min(c.remaining() / 8));
        let mut record_dim = None;
        for i in 0..ndims {
            let n = name(&mut c, wide)?;
            let len = non_neg(&mut c, wide, "dimension length")? as usize;
            if len == 0 {
                if record_dim.is_some() {
                    return Err(FormatError::new(
                        c.location(),
                        format!("dimension '{n}' is a second record dimension"),
                    ));
                }
                record_dim = Some(i);
            }
            dims.push(Dimension { name: n, len });
        }
        let attrs = attr_list(&mut c, wide)?;
        let tag = c.u32(Endian::Big, "variable list tag")?;
        let nvars = non_neg(&mut c, wide, "variable count")? as usize;
        if !(tag == NC_VARIABLE || (tag == 0 && nvars == 0)) {
            return Err(FormatError::new(c.location(), format!("expected a variable list (tag 11), found tag {tag}")));
        }
        let mut vars = Vec::with_capacity(nvars.min(c.remaining() / 16));
        for _ in 0..nvars {
            let at = c.offset();
            let n = name(&mut c, wide)?;
            let rank = non_neg(&mut c, wide, "variable rank")? as usize;
            if rank > 64 {
                return Err(FormatError::new(Location::Byte(at), format!("variable '{n}' has rank {rank}")));
            }
            let mut vd = Vec::with_capacity(rank);
            for _ in 0..rank {
                let d = non_neg(&mut c, wide, "dimension id")? as usize;
                if d >= dims.len() {
                    return Err(FormatError::new(
                        Location::Byte(at),
                        format!("variable '{n}' names dimension {d} of {}", dims.len()),
                    ));
                }
                if Some(d) == record_dim && !vd.is_empty() {
                    return Err(FormatError::new(
                        Location::Byte(at),
                        format!("variable '{n}' has the record dimension other than first"),
                    ));
                }
                vd.push(d);
            }
            let vattrs = attr_list(&mut c, wide)?;
            let code = c.u32(Endian::Big, "variable type")?;
            let ty = NcType::from_code(code).ok_or_else(|| {
                FormatError::new(Location::Byte(at), format!("variable '{n}' has unknown type {code}"))
            })?;
            let vsize = if wide { c.u64(Endian::Big, "vsize")? } else { c.u32(Endian::Big, "vsize")? as u64 };
            let begin = if offset64 { c.u64(Endian::Big, "begin")? } else { c.u32(Endian::Big, "begin")? as u64 };
            vars.push(Variable { name: n, dims: vd, attrs: vattrs, ty, vsize, begin, at });
        }
        let mut f = NetCdf { bytes, nc4: None, dims, attrs, vars, num_records: 0, record_dim, record_size: 0 };
        // vsize may be written as 2³²−1 for huge variables: use the
        // computed size instead, padded to 4 bytes.
        let rec_vars: Vec<usize> = (0..f.vars.len()).filter(|&v| f.is_record(v)).collect();
        let padded = rec_vars.len() != 1;
        let mut record_size = 0u64;
        for &v in &rec_vars {
            let one = f.record_bytes(v).ok_or_else(|| {
                FormatError::new(Location::Byte(f.vars[v].at), format!("variable '{}' is too large", f.vars[v].name))
            })?;
            let one = if padded { one.div_ceil(4).checked_mul(4) } else { Some(one) };
            record_size = one.and_then(|o| record_size.checked_add(o)).ok_or_else(|| {
                FormatError::new(Location::Byte(f.vars[v].at), "the record variables' sizes overflow 64 bits")
            })?;
        }
        f.record_size = record_size;
        let data_start = rec_vars.iter().map(|&v| f.vars[v].begin).min().unwrap_or(bytes.len() as u64);
        // (+3: the last record's final padding may be left out.)
        let fits = match record_size {
            0 => 0,
            r => ((bytes.len() as u64).saturating_sub(data_start) + 3) / r,
        };
        if rec_vars.is_empty() {
            // No variable is stored by record: whatever count the header
            // declares, there are no records to read (a count of 2^27
            // here once had a reader loop over that many "time steps").
            f.num_records = 0;
        } else if streaming {
            f.num_records = fits as usize;
        } else if numrecs > fits {
            return Err(FormatError::new(
                numrecs_at,
                format!("the header declares {numrecs} records but the file holds {fits}"),
            ));
        } else {
            f.num_records = numrecs as usize;
        }
        Ok(f)
    }

    /// The netCDF-4 form: the root group's dimensions, attributes and
    /// variables (variables of types with no numeric or text reading —
    /// strings, compounds, enums — left out). The unlimited dimension is
    /// the record dimension; its length, which the HDF5 metadata gives as
    /// 0, is the records the smallest record variable holds.
    fn parse_nc4(bytes: &'a [u8]) -> Result<NetCdf<'a>, FormatError> {
        let file = nc4_call(|| netcdf_reader::NcFile::from_bytes(bytes))?;
        let dims: Vec<Dimension> = nc4_call(|| file.dimensions().map(<[_]>::to_vec))?
            .into_iter()
            .map(|d| Dimension { name: d.name, len: if d.is_unlimited { 0 } else { d.size as usize } })
            .collect();
        let record_dim = dims.iter().position(|d| d.len == 0);
        let attrs = nc4_call(|| file.global_attributes().map(<[_]>::to_vec))?.into_iter().map(nc4_attr).collect();
        let mut vars = Vec::new();
        for v in nc4_call(|| file.variables().map(<[_]>::to_vec))? {
            let Some(ty) = nc4_type(&v.dtype) else { continue };
            let vd = v
                .dimensions
                .iter()
                .map(|d| dims.iter().position(|x| x.name == d.name))
                .collect::<Option<Vec<usize>>>()
                .ok_or_else(|| whole(format!("variable '{}' names a dimension outside the root group", v.name)))?;
            if vd.iter().skip(1).any(|&d| Some(d) == record_dim) {
                return Err(whole(format!("variable '{}' has the record dimension other than first", v.name)));
            }
            let attrs = v.attributes.into_iter().map(nc4_attr).collect();
            vars.push(Variable { name: v.name, dims: vd, attrs, ty, vsize: 0, begin: 0, at: 0 });
        }
        let mut f = NetCdf { bytes, nc4: Some(file), dims, attrs, vars, num_records: 0, record_dim, record_size: 0 };
        let smallest = (0..f.vars.len())
            .filter(|&v| f.is_record(v))
            .min_by_key(|&v| f.vars[v].dims[1..].iter().map(|&d| f.dims[d].len).product::<usize>());
        if let Some(v) = smallest {
            let name = f.vars[v].name.clone();
            let file = f.nc4.as_ref().expect("set above");
            let data = nc4_call(|| file.read_variable_as_f64(&name))?;
            f.num_records = data.shape().first().copied().unwrap_or(0);
        }
        Ok(f)
    }

    fn is_record(&self, v: usize) -> bool {
        self.vars[v].dims.first().is_some_and(|&d| Some(d) == self.record_dim)
    }

    /// Bytes of one record (record variables) or of the whole variable.
    fn record_bytes(&self, v: usize) -> Option<u64> {
        let var = &self.vars[v];
        let skip = usize::from(self.is_record(v));
        var.dims[skip..].iter().try_fold(var.ty.size() as u64, |acc, &d| acc.checked_mul(self.dims[d].len as u64))
    }

    /// Whether the file is netCDF-4 (HDF5) rather than classic.
    pub fn is_netcdf4(&self) -> bool {
        self.nc4.is_some()
    }

    pub fn var(&self, name: &str) -> Option<&Variable> {
        self.vars.iter().find(|v| v.name == name)
    }

    pub fn dim_len(&self, name: &str) -> Option<usize> {
        self.dims.iter().position(|d| d.name == name).map(|i| self.dim(i))
    }

    /// A dimension's length (the record count for the record dimension).
    pub fn dim(&self, id: usize) -> usize {
        if Some(id) == self.record_dim {
            self.num_records
        } else {
            self.dims[id].len
        }
    }

    /// The variable's shape (the record dimension's length is the record count).
    pub fn shape(&self, var: &Variable) -> Vec<usize> {
        var.dims.iter().map(|&d| self.dim(d)).collect()
    }

    /// Every value of a fixed-size variable, or of record `record` of a
    /// record variable, as f64 in row-major order.
    pub fn read(&self, var: &Variable, record: Option<usize>) -> Result<Vec<f64>, FormatError> {
        let v = self.vars.iter().position(|x| std::ptr::eq(x, var)).expect("a variable of this file");
        if let Some(file) = &self.nc4 {
            return self.read_nc4(file, v, record);
        }
        let (start, end) = self.extent(v, record)?;
        let mut out = Vec::new();
        decode(&self.bytes[start as usize..end as usize], var.ty, &mut out);
        Ok(out)
    }

    /// Whether a fixed-size variable's data lies within the file (always
    /// true of a netCDF-4 file, whose compressed data says nothing of it
    /// until read): the error [`NetCdf::read`] would give, without reading.
    /// How a reader checks a variable whose shape it lays data out by
    /// before reading it.
    pub fn check_within_file(&self, var: &Variable) -> Result<(), FormatError> {
        let v = self.vars.iter().position(|x| std::ptr::eq(x, var)).expect("a variable of this file");
        if self.nc4.is_some() {
            return Ok(());
        }
        self.extent(v, if self.is_record(v) { Some(0) } else { None }).map(|_| ())
    }

    /// The byte range of variable `v`'s data (of record `record`), checked
    /// to lie within the file.
    fn extent(&self, v: usize, record: Option<usize>) -> Result<(u64, u64), FormatError> {
        let var = &self.vars[v];
        let err = |m: String| FormatError::new(Location::Byte(var.at), m);
        let bytes = self.record_bytes(v).ok_or_else(|| err(format!("variable '{}' is too large", var.name)))?;
        let start = match (self.is_record(v), record) {
            // (Checked: begin and the record size are the header's word.)
            (true, Some(r)) if r < self.num_records => (r as u64)
                .checked_mul(self.record_size)
                .and_then(|o| var.begin.checked_add(o))
                .ok_or_else(|| err(format!("record {r} of '{}' lies past 2^64 bytes", var.name)))?,
            (true, Some(r)) => {
                return Err(err(format!("record {r} of '{}': the file has {}", var.name, self.num_records)))
            }
            (true, None) => return Err(err(format!("'{}' is a record variable: name a record", var.name))),
            (false, _) => var.begin,
        };
        let end = start.checked_add(bytes).filter(|&e| e <= self.bytes.len() as u64).ok_or_else(|| {
            err(format!(
                "the data of '{}' ({bytes} bytes at {start}) runs past the end of the file ({} bytes)",
                var.name,
                self.bytes.len()
            ))
        })?;
        Ok((start, end))
    }

    /// [`NetCdf::read`] of a netCDF-4 file: the variable, or one record
    /// of it, decoded, its length checked against the shape.
    fn read_nc4(&self, file: &netcdf_reader::NcFile, v: usize, record: Option<usize>) -> Result<Vec<f64>, FormatError> {
        use netcdf_reader::{NcSliceInfo, NcSliceInfoElem};
        let var = &self.vars[v];
        let mut shape = self.shape(var);
        let data = match (self.is_record(v), record) {
            (true, Some(r)) if r < self.num_records => {
                let mut selections = vec![NcSliceInfoElem::Index(r as u64)];
                selections.extend(shape[1..].iter().map(|&n| NcSliceInfoElem::Slice {
                    start: 0,
                    end: n as u64,
                    step: 1,
                }));
                shape.remove(0);
                nc4_call(|| file.read_variable_slice_as_f64(&var.name, &NcSliceInfo { selections }))?
            }
            (true, Some(r)) => {
                return Err(whole(format!("record {r} of '{}': the file has {}", var.name, self.num_records)))
            }
            (true, None) => return Err(whole(format!("'{}' is a record variable: name a record", var.name))),
            (false, _) => nc4_call(|| file.read_variable_as_f64(&var.name))?,
        };
        let want: usize = shape.iter().product();
        if data.len() != want {
            return Err(whole(format!("'{}' holds {} values, its shape {shape:?} {want}", var.name, data.len())));
        }
        Ok(data.iter().copied().collect())
    }

    /// A 2-D char variable as its rows, trailing NULs and blanks removed.
    pub fn read_strings(&self, var: &Variable) -> Result<Vec<String>, FormatError> {
        let shape = self.shape(var);
        if var.ty != NcType::Char || shape.len() != 2 {
            return Err(FormatError::new(Location::Byte(var.at), format!("'{}' is not a list of names", var.name)));
        }
        if let Some(file) = &self.nc4 {
            let rows = nc4_call(|| file.read_variable_as_strings(&var.name))?;
            return Ok(rows.into_iter().map(|r| r.trim_end_matches('\0').trim().to_string()).collect());
        }
        let raw = self.read(var, None)?;
        Ok(raw
            .chunks(shape[1].max(1))
            .take(shape[0])
            .map(|row| {
                let b: Vec<u8> = row.iter().map(|&x| x as u8).take_while(|&x| x != 0).collect();
                String::from_utf8_lossy(&b).trim().to_string()
            })
            .collect())
    }
}

impl std::fmt::Debug for NetCdf<'_> {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("NetCdf")
            .field("netcdf4", &self.nc4.is_some())
            .field("dims", &self.dims)
            .field("vars", &self.vars)
            .field("num_records", &self.num_records)
            .finish()
    }
}

/// HDF5's signature, at the start of a netCDF-4 file.
pub(crate) const HDF5_MAGIC: &[u8] = b"\x89HDF\r\n\x1a\n";

fn whole(m: String) -> FormatError {
    FormatError::new(Location::Whole, m)
}

/// A call into the netCDF-4 decoder, its error (or a panic, should a
/// malformed file reach one in the decoder: bad input is an error here,
/// never a crash) as a [`FormatError`].
fn nc4_call<T>(f: impl FnOnce() -> netcdf_reader::Result<T>) -> Result<T, FormatError> {
    match std::panic::catch_unwind(std::panic::AssertUnwindSafe(f)) {
        Ok(Ok(v)) => Ok(v),
        Ok(Err(e)) => Err(whole(format!("netCDF-4 (HDF5): {e}"))),
        Err(_) => Err(whole("netCDF-4 (HDF5): the decoder failed on this file (malformed)".to_string())),
    }
}

fn nc4_type(t: &netcdf_reader::NcType) -> Option<NcType> {
    use netcdf_reader::NcType as T;
    Some(match t {
        T::Byte => NcType::Byte,
        T::Char => NcType::Char,
        T::Short => NcType::Short,
        T::Int => NcType::Int,
        T::Float => NcType::Float,
        T::Double => NcType::Double,
        T::UByte => NcType::UByte,
        T::UShort => NcType::UShort,
        T::UInt => NcType::UInt,
        T::Int64 => NcType::Int64,
        T::UInt64 => NcType::UInt64,
        _ => return None,
    })
}

fn nc4_attr(a: netcdf_reader::NcAttribute) -> (String, AttrValue) {
    use netcdf_reader::NcAttrValue as V;
    fn nums<T: Copy + Into<f64>>(v: &[T]) -> AttrValue {
        AttrValue::Numbers(v.iter().map(|&x| x.into()).collect())
    }
    let value = match &a.value {
        V::Chars(t) => AttrValue::Text(t.trim_end_matches('\0').to_string()),
        V::Strings(t) => AttrValue::Text(t.join("\n")),
        V::Bytes(v) => nums(v),
        V::UBytes(v) => nums(v),
        V::Shorts(v) => nums(v),
        V::UShorts(v) => nums(v),
        V::Ints(v) => nums(v),
        V::UInts(v) => nums(v),
        V::Floats(v) => nums(v),
        V::Doubles(v) => nums(v),
        V::Int64s(v) => AttrValue::Numbers(v.iter().map(|&x| x as f64).collect()),
        V::UInt64s(v) => AttrValue::Numbers(v.iter().map(|&x| x as f64).collect()),
    };
    (a.name, value)
}

#[cfg(test)]
pub(crate) mod tests {
    use super::*;

    /// One variable for [`Writer`]: name, dimension ids, netCDF type code,
    /// text attributes, values.
    pub(crate) type WriterVar = (String, Vec<usize>, u32, Vec<(String, String)>, Vec<f64>);

    /// A minimal classic file writer for tests: fixed variables of f64 or
    /// i32 and record variables of f64.
    pub(crate) struct Writer {
        pub dims: Vec<(String, usize)>,
        pub vars: Vec<WriterVar>,
        pub num_records: usize,
    }

    fn put_name(out: &mut Vec<u8>, n: &str) {
        out.extend((n.len() as u32).to_be_bytes());
        out.extend(n.as_bytes());
        out.resize(out.len().div_ceil(4) * 4, 0);
    }

    impl Writer {
        /// Writes CDF-1 (`offset64` false) or CDF-2. Record variables'
        /// values are record-major (all of record 0, then record 1, …).
        pub fn write(&self, offset64: bool) -> Vec<u8> {
            let size = |code: u32| {
                if code == 6 {
                    8
                } else if code == 2 {
                    1
                } else {
                    4
                }
            };
            let rec = |dims: &Vec<usize>| dims.first().is_some_and(|&d| self.dims[d].1 == 0);
            let vsize = |dims: &Vec<usize>, code: u32| {
                let skip = usize::from(rec(dims));
                let n: usize = dims[skip..].iter().map(|&d| self.dims[d].1).product();
                (n * size(code)).div_ceil(4) * 4
            };
            // Header with placeholder begins, then fix them.
            let header = |begins: &[u64]| {
                let mut h = Vec::new();
                h.extend(b"CDF");
                h.push(if offset64 { 2 } else { 1 });
                h.extend((self.num_records as u32).to_be_bytes());
                h.extend(NC_DIMENSION.to_be_bytes());
                h.extend((self.dims.len() as u32).to_be_bytes());
                for (n, l) in &self.dims {
                    put_name(&mut h, n);
                    h.extend((*l as u32).to_be_bytes());
                }
                h.extend([0u8; 8]);
                h.extend(NC_VARIABLE.to_be_bytes());
                h.extend((self.vars.len() as u32).to_be_bytes());
                for (k, (n, dims, code, attrs, _)) in self.vars.iter().enumerate() {
                    put_name(&mut h, n);
                    h.extend((dims.len() as u32).to_be_bytes());
                    for d in dims {
                        h.extend((*d as u32).to_be_bytes());
                    }
                    if attrs.is_empty() {
                        h.extend([0u8; 8]);
                    } else {
                        h.extend(NC_ATTRIBUTE.to_be_bytes());
                        h.extend((attrs.len() as u32).to_be_bytes());
                        for (an, av) in attrs {
                            put_name(&mut h, an);
                            h.extend(2u32.to_be_bytes());
                            put_name(&mut h, av);
                        }
                    }
                    h.extend(code.to_be_bytes());
                    h.extend((vsize(dims, *code) as u32).to_be_bytes());
                    if offset64 {
                        h.extend(begins[k].to_be_bytes());
                    } else {
                        h.extend((begins[k] as u32).to_be_bytes());
                    }
                }
                h
            };
            let hlen = header(&vec![0; self.vars.len()]).len() as u64;
            let mut begins = vec![0u64; self.vars.len()];
            let mut at = hlen;
            for (k, (_, dims, code, _, _)) in self.vars.iter().enumerate() {
                if !rec(dims) {
                    begins[k] = at;
                    at += vsize(dims, *code) as u64;
                }
            }
            let recsize: u64 = self.vars.iter().filter(|v| rec(&v.1)).map(|(_, d, c, _, _)| vsize(d, *c) as u64).sum();
            for (k, (_, dims, code, _, _)) in self.vars.iter().enumerate() {
                if rec(dims) {
                    begins[k] = at;
                    at += vsize(dims, *code) as u64;
                }
            }
            let mut out = header(&begins);
            out.resize((at + recsize * self.num_records.saturating_sub(1) as u64) as usize, 0);
            for (k, (_, dims, code, _, vals)) in self.vars.iter().enumerate() {
                let per = if rec(dims) { vals.len() / self.num_records.max(1) } else { vals.len() };
                for (i, v) in vals.iter().enumerate() {
                    let (r, j) = (i / per.max(1), i % per.max(1));
                    let base = if rec(dims) { begins[k] + r as u64 * recsize } else { begins[k] } as usize;
                    let o = base + j * size(*code);
                    match code {
                        6 => out[o..o + 8].copy_from_slice(&v.to_be_bytes()),
                        5 => out[o..o + 4].copy_from_slice(&(*v as f32).to_be_bytes()),
                        2 => out[o] = *v as u8,
                        _ => out[o..o + 4].copy_from_slice(&(*v as i32).to_be_bytes()),
                    }
                }
            }
            out
        }
    }

    fn sample() -> Writer {
        Writer {
            dims: vec![("time".into(), 0), ("n".into(), 3), ("len".into(), 4)],
            vars: vec![
                ("a".into(), vec![1], 6, vec![("units".into(), "m".into())], vec![1.0, 2.0, 3.0]),
                ("ids".into(), vec![1], 4, vec![], vec![7.0, 8.0, 9.0]),
                ("names".into(), vec![1, 2], 2, vec![], "ab\0\0cd\0\0ef\0\0".bytes().map(f64::from).collect()),
                ("t".into(), vec![0], 6, vec![], vec![0.5, 1.5]),
                ("v".into(), vec![0, 1], 5, vec![], vec![1.0, 2.0, 3.0, 4.0, 5.0, 6.0]),
            ],
            num_records: 2,
        }
    }

    #[test]
    fn reads_fixed_and_record_variables_in_both_offset_sizes() {
        for offset64 in [false, true] {
            let bytes = sample().write(offset64);
            let f = NetCdf::parse(&bytes).unwrap();
            assert_eq!(f.num_records, 2);
            assert_eq!(f.read(f.var("a").unwrap(), None).unwrap(), vec![1.0, 2.0, 3.0]);
            assert_eq!(f.var("a").unwrap().text_attr("units"), Some("m"));
            assert_eq!(f.read(f.var("ids").unwrap(), None).unwrap(), vec![7.0, 8.0, 9.0]);
            assert_eq!(f.read_strings(f.var("names").unwrap()).unwrap(), vec!["ab", "cd", "ef"]);
            assert_eq!(f.read(f.var("t").unwrap(), Some(1)).unwrap(), vec![1.5]);
            assert_eq!(f.read(f.var("v").unwrap(), Some(1)).unwrap(), vec![4.0, 5.0, 6.0]);
            assert!(f.read(f.var("v").unwrap(), Some(2)).is_err());
        }
    }

    #[test]
    fn truncated_and_corrupt_headers_are_errors() {
        let bytes = sample().write(false);
        for cut in 0..bytes.len() {
            if let Ok(f) = NetCdf::parse(&bytes[..cut]) {
                for v in &f.vars {
                    let r = if f.shape(v).first() == Some(&f.num_records) && v.dims[0] == 0 { Some(0) } else { None };
                    let _ = f.read(v, r);
                }
            }
        }
        let mut bad = bytes.clone();
        bad[3] = 3;
        assert!(NetCdf::parse(&bad).unwrap_err().message.contains("not a netCDF"));
    }
}
