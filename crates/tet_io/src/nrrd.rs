//! NRRD volumes (`NRRD0001`–`NRRD0005`): 3D scalar grids, or 4D grids whose
//! first axis (at most 4 samples) holds the components of a vector field.
//!
//! Data may follow the header (attached) or live in detached files named by
//! `data file` (Kindlmann, "Definition of NRRD File Format", teem.sf.net):
//! one file; a numbered series, `data file: <format> <min> <max> <step>
//! [<subdim>]` with a printf `%d` conversion (`slice.%03d.raw 1 93 1 2`);
//! or `data file: LIST [<subdim>]` with one name a line to the end of the
//! header. Several files hold equal, consecutive parts of the samples (each
//! a slab of the slowest axes; `subdim` says how many of the fastest axes
//! one file spans) and each gets the line skip, byte skip and encoding.
//! Files are loaded through the caller's callback. Encodings: raw, gzip,
//! ascii. Not supported: bzip2 and hex encodings, `block` type, 2D images.

use std::io::Read;

use crate::cursor::{decode_to_f64, Endian, ScalarType, TextCursor};
use crate::raw::{checked_count, grid_points};
use crate::{FormatError, Location};
use tet_mesh::{Block, Field, SourceMesh};

#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum Encoding {
    Raw,
    Gzip,
    Ascii,
}

/// The header fields tetkit uses, with the line each came from.
#[derive(Debug, Default)]
struct Header {
    scalar_type: Option<ScalarType>,
    dimension: Option<usize>,
    sizes: Option<Vec<usize>>,
    endian: Option<Endian>,
    encoding: Option<Encoding>,
    directions: Option<Vec<Option<[f64; 3]>>>,
    spacings: Option<Vec<f64>>,
    origin: Option<[f64; 3]>,
    axis_mins: Option<Vec<f64>>,
    data_file: Option<String>,
    /// `data file: LIST [subdim]`: the names listed after it, and subdim.
    data_list: Option<(Vec<String>, Option<usize>)>,
    line_skip: usize,
    byte_skip: i64,
    content: Option<String>,
    /// Offset of the attached data (after the blank line), if there is one.
    data_start: Option<usize>,
    /// Line number of the first line after the header, for messages.
    end_line: usize,
}

/// Reads an NRRD file. `load_detached` is called with the `data file` name
/// as written in the header (relative names are relative to the header's
/// directory; resolving them is the caller's job).
pub fn read(
    header_and_maybe_data: &[u8],
    load_detached: &mut dyn FnMut(&str) -> std::io::Result<Vec<u8>>,
) -> Result<SourceMesh, FormatError> {
    let bytes = header_and_maybe_data;
    let h = parse_header(bytes)?;
    let line = Location::Line(h.end_line);
    let missing = |what: &str| FormatError::new(line, format!("NRRD header lacks the required '{what}' field"));
    let scalar_type = h.scalar_type.ok_or_else(|| missing("type"))?;
    let dimension = h.dimension.ok_or_else(|| missing("dimension"))?;
    let sizes = h.sizes.clone().ok_or_else(|| missing("sizes"))?;
    let encoding = h.encoding.ok_or_else(|| missing("encoding"))?;
    if sizes.len() != dimension {
        return Err(FormatError::new(
            line,
            format!("'sizes' has {} entries but 'dimension' is {dimension}", sizes.len()),
        ));
    }
    // A leading axis of up to 4 samples in a 4D volume is the component axis.
    let (components, dims) = match sizes[..] {
        [i, j, k] => (1, [i, j, k]),
        [c, i, j, k] if (1..=4).contains(&c) => (c, [i, j, k]),
        [c, ..] if dimension == 4 => {
            return Err(FormatError::new(
                line,
                format!("4D NRRD with {c} samples on its first axis; only a leading vector axis of at most 4 components is supported"),
            ))
        }
        _ => {
            return Err(FormatError::new(
                line,
                format!("NRRD dimension {dimension} is not supported; tetkit reads 3D volumes (or 4D with a leading vector axis)"),
            ))
        }
    };
    if dims.contains(&0) || components == 0 {
        return Err(FormatError::new(line, format!("'sizes' {sizes:?} contains a zero")));
    }
    let count = checked_count(dims)
        .and_then(|n| n.checked_mul(components))
        .ok_or_else(|| FormatError::new(line, format!("'sizes' {sizes:?} overflow")))?;
    let data_bytes = count
        .checked_mul(scalar_type.size())
        .ok_or_else(|| FormatError::new(line, format!("'sizes' {sizes:?} overflow")))?;
    let endian = match h.endian {
        Some(e) => e,
        None if scalar_type.size() == 1 || encoding == Encoding::Ascii => Endian::Little,
        None => return Err(missing("endian")),
    };

    let mut notes = Vec::new();
    let values = match (data_files(&h, &sizes, count).map_err(|m| FormatError::new(line, m))?, h.data_start) {
        (Some(files), _) if files.len() == 1 => {
            let name = &files[0];
            let data = load_detached(name).map_err(|e| {
                FormatError::new(Location::Whole, format!("cannot read detached data file '{name}': {e}")).companion()
            })?;
            notes.push(format!("data read from detached file '{name}'"));
            decode_data(&data, 0, &h, encoding, scalar_type, endian, count, data_bytes, &mut notes)
                .map_err(FormatError::companion)?
        }
        (Some(files), _) => {
            // Equal parts, one a file, in order (data_files checked that
            // they divide the samples).
            let per_file = count / files.len();
            let mut values = Vec::with_capacity(count.min(1 << 28));
            for name in &files {
                let in_file =
                    |e: FormatError| FormatError::new(e.at, format!("data file '{name}': {}", e.message)).companion();
                let data = load_detached(name).map_err(|e| {
                    FormatError::new(Location::Whole, format!("cannot read detached data file '{name}': {e}"))
                        .companion()
                })?;
                let mut file_notes = Vec::new();
                let part = decode_data(
                    &data,
                    0,
                    &h,
                    encoding,
                    scalar_type,
                    endian,
                    per_file,
                    per_file * scalar_type.size(),
                    &mut file_notes,
                )
                .map_err(in_file)?;
                notes.extend(file_notes.into_iter().map(|n| format!("data file '{name}': {n}")));
                values.extend(part);
            }
            notes.push(format!(
                "data read from {} detached files ('{}' … '{}'), {per_file} samples each",
                files.len(),
                files[0],
                files[files.len() - 1]
            ));
            values
        }
        (None, Some(start)) => {
            decode_data(bytes, start, &h, encoding, scalar_type, endian, count, data_bytes, &mut notes)?
        }
        (None, None) => {
            return Err(FormatError::new(
                line,
                "NRRD header ends without a blank line and names no 'data file': there is no data",
            ))
        }
    };
    let companion = h.data_file.is_some();

    // Geometry: space directions beat spacings; space origin beats axis mins.
    let spatial = |v: &[f64]| -> Option<[f64; 3]> {
        let s = &v[v.len().checked_sub(3)?..];
        Some([s[0], s[1], s[2]])
    };
    let mut axes = [[1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]];
    if let Some(dirs) = &h.directions {
        if dirs.len() != dimension {
            return Err(FormatError::new(
                line,
                format!("'space directions' has {} entries but 'dimension' is {dimension}", dirs.len()),
            ));
        }
        for (axis, d) in dirs[dimension - 3..].iter().enumerate() {
            match d {
                Some(v) => axes[axis] = *v,
                None => {
                    return Err(FormatError::new(
                        line,
                        format!("'space directions' gives 'none' for spatial axis {axis}"),
                    ))
                }
            }
        }
    } else if let Some(sp) = h.spacings.as_deref() {
        if sp.len() != dimension {
            return Err(FormatError::new(
                line,
                format!("'spacings' has {} entries but 'dimension' is {dimension}", sp.len()),
            ));
        }
        if let Some(s) = spatial(sp) {
            for (axis, v) in s.iter().enumerate() {
                // NaN marks a non-spatial axis; keep unit spacing there.
                if v.is_finite() {
                    axes[axis][axis] = *v;
                }
            }
        }
    }
    let origin = match (&h.origin, h.axis_mins.as_deref().and_then(spatial)) {
        (Some(o), _) => *o,
        (None, Some(m)) if m.iter().all(|v| v.is_finite()) => m,
        _ => [0.0; 3],
    };

    let name = h.content.clone().filter(|c| !c.is_empty()).unwrap_or_else(|| "scalars".to_string());
    let mut mesh = SourceMesh {
        points: grid_points(dims, origin, axes),
        blocks: vec![Block::Structured { dims, first_point: 0 }],
        point_fields: vec![Field::new(name, components, values)],
        notes,
        format: format!(
            "NRRD ({}{})",
            match encoding {
                Encoding::Raw => "raw",
                Encoding::Gzip => "gzip",
                Encoding::Ascii => "ascii",
            },
            if companion { ", detached" } else { "" }
        ),
        ..Default::default()
    };
    if components > 1 {
        mesh.notes.push(format!("{components}-component samples from the leading axis"));
    }
    mesh.check().map_err(|e| FormatError::new(Location::Whole, e))?;
    Ok(mesh)
}

/// The detached data files of `h` in order (`None`: the data are attached),
/// checked to split `count` samples into equal parts, each a slab of whole
/// `subdim`-dimensional pieces of the fastest axes.
fn data_files(h: &Header, sizes: &[usize], count: usize) -> Result<Option<Vec<String>>, String> {
    let (names, subdim) = match (&h.data_list, &h.data_file) {
        (Some((names, subdim)), _) => (names.clone(), *subdim),
        (None, None) => return Ok(None),
        (None, Some(value)) => {
            let tokens: Vec<&str> = value.split_whitespace().collect();
            match tokens[..] {
                [one] => return Ok(Some(vec![one.to_string()])),
                [format, min, max, step, ref rest @ ..] if rest.len() <= 1 => {
                    let int = |t: &str| t.parse::<i64>().map_err(|_| format!("'data file: {value}': '{t}' is not an integer"));
                    let (min, max, step) = (int(min)?, int(max)?, int(step)?);
                    let subdim = match rest {
                        [d] => Some(d.parse::<usize>().map_err(|_| format!("'data file: {value}': bad subdim '{d}'"))?),
                        _ => None,
                    };
                    if step == 0 || (max - min).signum() * step.signum() < 0 {
                        return Err(format!("'data file: {value}': step {step} never goes from {min} to {max}"));
                    }
                    let n = (max - min) / step + 1;
                    // Every file holds at least one sample: more files than
                    // samples is an error, not a long loop.
                    if n as u128 > count as u128 {
                        return Err(format!("'data file: {value}' names {n} files for {count} samples"));
                    }
                    let names = (0..n)
                        .map(|k| printf_int(format, min + k * step))
                        .collect::<Result<Vec<_>, _>>()
                        .map_err(|e| format!("'data file: {value}': {e}"))?;
                    (names, subdim)
                }
                _ => {
                    return Err(format!(
                        "'data file: {value}': expected one file name, '<format> <min> <max> <step> [<subdim>]' or 'LIST [<subdim>]'"
                    ))
                }
            }
        }
    };
    if names.is_empty() {
        return Err("'data file: LIST' is followed by no file names".to_string());
    }
    if !count.is_multiple_of(names.len()) {
        return Err(format!("{count} samples do not split into {} data files of equal size", names.len()));
    }
    if let Some(d) = subdim {
        // subdim below the dimension: each file is one d-dimensional piece;
        // equal to it: each file is a slab of whole slices of the slowest axis.
        let per_file: usize = sizes.iter().take(d).product();
        let fits = match d {
            _ if d == sizes.len() => sizes[d - 1].is_multiple_of(names.len()),
            _ => per_file * names.len() == count,
        };
        if d == 0 || d > sizes.len() || !fits {
            return Err(format!(
                "data file subdim {d}: {} files of the first {d} axes of sizes {sizes:?} do not make the volume",
                names.len()
            ));
        }
    }
    Ok(Some(names))
}

/// `format` (one printf integer conversion: `%d`, `%i`, `%u`, with an
/// optional `0` flag and width; `%%` is a percent sign) applied to `v`.
fn printf_int(format: &str, v: i64) -> Result<String, String> {
    let mut out = String::new();
    let mut chars = format.chars().peekable();
    let mut used = false;
    while let Some(c) = chars.next() {
        if c != '%' {
            out.push(c);
            continue;
        }
        if chars.peek() == Some(&'%') {
            chars.next();
            out.push('%');
            continue;
        }
        let zero = chars.peek() == Some(&'0');
        if zero {
            chars.next();
        }
        let mut width = 0usize;
        while let Some(d) = chars.peek().and_then(|c| c.to_digit(10)) {
            width = width.saturating_mul(10).saturating_add(d as usize);
            chars.next();
        }
        if width > 32 {
            return Err(format!("field width {width} in '{format}' is too wide"));
        }
        match chars.next() {
            Some('d' | 'i' | 'u') if !used => {
                used = true;
                let digits = v.unsigned_abs().to_string();
                let sign = if v < 0 { "-" } else { "" };
                let pad = width.saturating_sub(digits.len() + sign.len());
                if zero {
                    out += &format!("{sign}{}{digits}", "0".repeat(pad));
                } else {
                    out += &format!("{}{sign}{digits}", " ".repeat(pad));
                }
            }
            _ => return Err(format!("'{format}' needs exactly one %d conversion")),
        }
    }
    if used {
        Ok(out)
    } else {
        Err(format!("'{format}' has no %d conversion for the file number"))
    }
}

/// Applies line skip and byte skip, decodes the encoding and converts the
/// samples to f64. `base` is the offset of the data in `source`.
#[allow(clippy::too_many_arguments)]
fn decode_data(
    source: &[u8],
    base: usize,
    h: &Header,
    encoding: Encoding,
    ty: ScalarType,
    endian: Endian,
    count: usize,
    data_bytes: usize,
    notes: &mut Vec<String>,
) -> Result<Vec<f64>, FormatError> {
    let mut start = base.min(source.len());
    // Line skip counts lines of the file itself, before any decompression.
    for _ in 0..h.line_skip {
        match source[start..].iter().position(|&b| b == b'\n') {
            Some(p) => start += p + 1,
            None => {
                return Err(FormatError::new(
                    Location::Byte(source.len() as u64),
                    format!("'line skip: {}' runs past the end of the data", h.line_skip),
                ))
            }
        }
    }
    let mut values = Vec::new();
    match encoding {
        Encoding::Raw => {
            let data_at = if h.byte_skip == -1 {
                // -1: the data are the last bytes of the file.
                source.len().checked_sub(data_bytes).filter(|&s| s >= start).ok_or_else(|| {
                    FormatError::new(
                        Location::Byte(start as u64),
                        format!(
                            "'byte skip: -1' but the file holds only {} data bytes, {data_bytes} needed",
                            source.len() - start
                        ),
                    )
                })?
            } else if h.byte_skip < 0 {
                return Err(FormatError::new(
                    Location::Whole,
                    format!("'byte skip: {}' is invalid (only -1 may be negative)", h.byte_skip),
                ));
            } else {
                start
                    .checked_add(h.byte_skip as usize)
                    .ok_or_else(|| FormatError::new(Location::Whole, "'byte skip' overflows"))?
            };
            let available = source.len().saturating_sub(data_at);
            if available < data_bytes {
                return Err(FormatError::new(
                    Location::Byte(data_at as u64),
                    format!(
                        "raw NRRD data truncated: {count} samples × {} bytes = {data_bytes} bytes expected, {available} present",
                        ty.size()
                    ),
                ));
            }
            if available > data_bytes {
                notes.push(format!("{} bytes after the data ignored", available - data_bytes));
            }
            decode_to_f64(&source[data_at..data_at + data_bytes], ty, endian, &mut values);
        }
        Encoding::Gzip => {
            if h.byte_skip < 0 {
                return Err(FormatError::new(Location::Whole, "'byte skip: -1' is only meaningful with raw encoding"));
            }
            // Byte skip applies to the decompressed stream. The output is
            // bounded to what the header promises (plus one byte to notice
            // excess), so a small bomb cannot inflate without limit.
            let skip = h.byte_skip as u64;
            let want = (data_bytes as u64).saturating_add(skip);
            let mut decoder = flate2::read::MultiGzDecoder::new(&source[start..]).take(want.saturating_add(1));
            let mut out = Vec::with_capacity(data_bytes.min(source.len().saturating_mul(64)).min(1 << 28));
            decoder.read_to_end(&mut out).map_err(|e| {
                FormatError::new(Location::Byte(start as u64), format!("gzip data cannot be decompressed: {e}"))
            })?;
            if (out.len() as u64) < want {
                return Err(FormatError::new(
                    Location::Byte(start as u64),
                    format!(
                        "gzip data decompress to {} bytes; {data_bytes} bytes of samples{} expected",
                        out.len(),
                        if skip > 0 { format!(" after skipping {skip}") } else { String::new() }
                    ),
                ));
            }
            if out.len() as u64 > want {
                notes.push("gzip stream holds more bytes than the samples; the rest is ignored".to_string());
            }
            let s = skip as usize;
            decode_to_f64(&out[s..s + data_bytes], ty, endian, &mut values);
        }
        Encoding::Ascii => {
            // Each value needs at least one digit and a separator, which
            // bounds the reservation by the input size.
            values.reserve(count.min(source.len().saturating_sub(start) / 2 + 1));
            let mut text = TextCursor::new(&source[start..]);
            while values.len() < count {
                match text.token() {
                    Some(tok) => match crate::cursor::parse_f64(tok.trim_end_matches(',')) {
                        Some(v) => values.push(v),
                        None => {
                            return Err(FormatError::new(
                                Location::Byte((start + text.offset()) as u64),
                                format!(
                                    "ascii NRRD data: '{}' is not a number",
                                    tok.chars().take(40).collect::<String>()
                                ),
                            ))
                        }
                    },
                    None => {
                        return Err(FormatError::new(
                            Location::Byte(source.len() as u64),
                            format!("ascii NRRD data ends after {} of {count} values", values.len()),
                        ))
                    }
                }
            }
            if text.token().is_some() {
                notes.push("values after the expected count ignored".to_string());
            }
        }
    }
    Ok(values)
}

/// Parses the header lines up to the blank line (or end of input for a
/// detached header).
fn parse_header(bytes: &[u8]) -> Result<Header, FormatError> {
    let mut text = TextCursor::new(bytes);
    let magic = text.line_str().unwrap_or("");
    let version = magic.strip_prefix("NRRD000").and_then(|v| v.trim_end().parse::<u8>().ok());
    if !matches!(version, Some(1..=5)) {
        return Err(FormatError::new(
            Location::Line(1),
            format!(
                "not an NRRD file: magic is '{}', expected NRRD0001 to NRRD0005",
                magic.chars().take(16).collect::<String>()
            ),
        ));
    }
    let mut h = Header::default();
    loop {
        let lineno = text.line();
        let Some(line) = text.line_str() else {
            h.end_line = lineno;
            break;
        };
        if line.trim().is_empty() {
            h.data_start = Some(text.offset());
            h.end_line = lineno;
            break;
        }
        if line.starts_with('#') {
            continue;
        }
        let at = Location::Line(lineno);
        let err = |msg: String| FormatError::new(at, msg);
        // Key/value pairs ("key:=value") carry no geometry: skip them.
        if let Some(kv) = line.find(":=") {
            if !matches!(line.find(": "), Some(field) if field < kv) {
                continue;
            }
        }
        let Some((key, value)) = line.split_once(": ") else {
            return Err(err(format!(
                "NRRD header line is not 'field: value': '{}'",
                line.chars().take(60).collect::<String>()
            )));
        };
        let value = value.trim();
        match key.trim().to_ascii_lowercase().as_str() {
            "type" => {
                h.scalar_type = Some(nrrd_type(value).ok_or_else(|| err(format!("unsupported NRRD type '{value}'")))?)
            }
            "dimension" => h.dimension = Some(value.parse().map_err(|_| err(format!("bad dimension '{value}'")))?),
            "sizes" => {
                let s: Result<Vec<usize>, _> = value.split_whitespace().map(str::parse).collect();
                h.sizes = Some(s.map_err(|_| err(format!("bad sizes '{value}' (need non-negative integers)")))?);
            }
            "endian" => {
                h.endian = Some(match value.to_ascii_lowercase().as_str() {
                    "little" => Endian::Little,
                    "big" => Endian::Big,
                    _ => return Err(err(format!("bad endian '{value}'"))),
                })
            }
            "encoding" => {
                h.encoding = Some(match value.to_ascii_lowercase().as_str() {
                    "raw" => Encoding::Raw,
                    "gzip" | "gz" => Encoding::Gzip,
                    "ascii" | "text" | "txt" => Encoding::Ascii,
                    other => {
                        return Err(err(format!("NRRD encoding '{other}' is not supported (raw, gzip, ascii are)")))
                    }
                })
            }
            "space directions" => h.directions = Some(parse_vectors(value).map_err(err)?),
            "spacings" => h.spacings = Some(parse_numbers(value).map_err(err)?),
            "axis mins" | "axismins" => h.axis_mins = Some(parse_numbers(value).map_err(err)?),
            "space origin" => {
                h.origin = match parse_vectors(value).map_err(err)?[..] {
                    [Some(o)] => Some(o),
                    _ => return Err(err(format!("bad space origin '{value}' (need one 3-vector)"))),
                }
            }
            "space dimension" if value != "3" => {
                return Err(err(format!("space dimension {value} is not supported (only 3)")));
            }
            "data file" | "datafile" => {
                let mut tokens = value.split_whitespace();
                if tokens.next() == Some("LIST") {
                    let subdim = match tokens.next() {
                        Some(d) => Some(d.parse().map_err(|_| err(format!("bad subdim '{d}' after LIST")))?),
                        None => None,
                    };
                    // The rest of the header file names the data files.
                    let mut names = Vec::new();
                    while let Some(l) = text.line_str() {
                        if !l.trim().is_empty() {
                            names.push(l.trim().to_string());
                        }
                    }
                    h.data_file = Some(value.to_string());
                    h.data_list = Some((names, subdim));
                    h.end_line = text.line();
                    break;
                }
                h.data_file = Some(value.to_string());
            }
            "line skip" | "lineskip" => {
                h.line_skip = value.parse().map_err(|_| err(format!("bad line skip '{value}'")))?
            }
            "byte skip" | "byteskip" => {
                h.byte_skip = value.parse().map_err(|_| err(format!("bad byte skip '{value}'")))?
            }
            "content" => h.content = Some(value.to_string()),
            // Informational fields that do not change how samples are read.
            _ => {}
        }
    }
    Ok(h)
}

fn nrrd_type(s: &str) -> Option<ScalarType> {
    Some(match s.to_ascii_lowercase().as_str() {
        "signed char" | "int8" | "int8_t" => ScalarType::I8,
        "uchar" | "unsigned char" | "uint8" | "uint8_t" => ScalarType::U8,
        "short" | "short int" | "signed short" | "signed short int" | "int16" | "int16_t" => ScalarType::I16,
        "ushort" | "unsigned short" | "unsigned short int" | "uint16" | "uint16_t" => ScalarType::U16,
        "int" | "signed int" | "int32" | "int32_t" => ScalarType::I32,
        "uint" | "unsigned int" | "uint32" | "uint32_t" => ScalarType::U32,
        "longlong"
        | "long long"
        | "long long int"
        | "signed long long"
        | "signed long long int"
        | "int64"
        | "int64_t" => ScalarType::I64,
        "ulonglong" | "unsigned long long" | "unsigned long long int" | "uint64" | "uint64_t" => ScalarType::U64,
        "float" => ScalarType::F32,
        "double" => ScalarType::F64,
        _ => return None,
    })
}

fn parse_numbers(value: &str) -> Result<Vec<f64>, String> {
    value
        .split_whitespace()
        .map(|t| crate::cursor::parse_f64(t).ok_or_else(|| format!("'{t}' is not a number")))
        .collect()
}

/// Parses `(x,y,z) none (x,y,z)` lists; `none` gives `None`.
fn parse_vectors(value: &str) -> Result<Vec<Option<[f64; 3]>>, String> {
    let mut out = Vec::new();
    let mut rest = value.trim();
    while !rest.is_empty() {
        if let Some(r) = rest.strip_prefix("none") {
            out.push(None);
            rest = r.trim_start();
            continue;
        }
        let inner = rest
            .strip_prefix('(')
            .and_then(|r| r.split_once(')'))
            .ok_or_else(|| format!("expected '(x,y,z)' or 'none' in '{value}'"))?;
        let nums: Vec<f64> = inner
            .0
            .split(',')
            .map(|t| crate::cursor::parse_f64(t.trim()).ok_or_else(|| format!("'{}' is not a number", t.trim())))
            .collect::<Result<_, _>>()?;
        let v: [f64; 3] = nums
            .try_into()
            .map_err(|n: Vec<f64>| format!("vector with {} components; only 3D space is supported", n.len()))?;
        out.push(Some(v));
        rest = inner.1.trim_start();
    }
    Ok(out)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn no_file(_: &str) -> std::io::Result<Vec<u8>> {
        Err(std::io::Error::new(std::io::ErrorKind::NotFound, "none"))
    }

    #[test]
    fn vectors_and_none() {
        let v = parse_vectors("none (1,0,0) (0, 2.5,0)  (0,0,-1)").unwrap();
        assert_eq!(v, vec![None, Some([1.0, 0.0, 0.0]), Some([0.0, 2.5, 0.0]), Some([0.0, 0.0, -1.0])]);
        assert!(parse_vectors("(1,0)").is_err());
        assert!(parse_vectors("(1,0,0").is_err());
    }

    #[test]
    fn attached_raw_with_directions() {
        let mut b = b"NRRD0004\n# c\ntype: uint16\ndimension: 3\nsizes: 2 1 1\nendian: big\nencoding: raw\nspace directions: (2,0,0) (0,1,0) (0,0,1)\nspace origin: (1,1,1)\nfoo:=bar\n\n".to_vec();
        b.extend([0, 7, 1, 0]);
        let m = read(&b, &mut no_file).unwrap();
        assert_eq!(m.point_fields[0].values, vec![7.0, 256.0]);
        assert_eq!(m.points[1], [3.0, 1.0, 1.0]);
    }

    #[test]
    fn header_errors_name_the_line() {
        let e = read(b"NRRD0004\ntype: quux\n\n", &mut no_file).unwrap_err();
        assert_eq!(e.at, Location::Line(2));
        let e = read(b"NRRD0009\n", &mut no_file).unwrap_err();
        assert!(e.message.contains("magic"));
        let e = read(b"NRRD0004\ntype: float\ndimension: 3\nsizes: 99999999 99999999 99999999\nencoding: raw\nendian: little\n\n", &mut no_file).unwrap_err();
        assert!(e.message.contains("truncated") || e.message.contains("overflow"), "{}", e.message);
        let e = read(
            b"NRRD0004\ntype: float\ndimension: 3\nsizes: 1 1 1\nencoding: raw\nendian: little\ndata file: x.raw\n",
            &mut no_file,
        )
        .unwrap_err();
        assert!(e.in_companion);
    }
}
