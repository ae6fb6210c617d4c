//! A DataArray's values: its payload (ASCII, inline binary, appended raw
//! or base64, zlib blocks) unpacked and decoded to f64 or i64.

use super::*;

impl<'a> Ctx<'a> {
    /// Runs `f` on the array's values, decoded from base64 and inflated as
    /// needed. `expected_bytes`, when known, is checked against a compressed
    /// header before anything is inflated.
    pub(crate) fn with_payload<R>(
        &self,
        el: usize,
        expected_bytes: Option<usize>,
        f: impl FnOnce(Payload<'_>) -> Result<R, FormatError>,
    ) -> Result<R, FormatError> {
        let format = self.attr(el, "format").unwrap_or("ascii");
        let what = format!("DataArray '{}'", self.attr(el, "Name").unwrap_or(""));
        match format {
            "ascii" => {
                self.mark(USED_ASCII);
                f(Payload::Ascii(&self.els[el].text))
            }
            "binary" => {
                self.mark(USED_BINARY);
                let compressor = self.compressor.clone().map_err(|m| self.err_at(el, m))?;
                let loc = self.err_at(el, "").at;
                let text: Vec<u8> = self.els[el]
                    .text
                    .iter()
                    .flat_map(|r| self.bytes.get(r.clone()).unwrap_or(&[]).iter().copied())
                    .filter(|b| !b.is_ascii_whitespace())
                    .collect();
                // Offsets inside decoded base64 are not file offsets: report
                // the element's line instead.
                self.with_base64_payload(&text, loc, compressor, expected_bytes, &what, f)
            }
            "appended" => {
                let app = self
                    .appended
                    .as_ref()
                    .ok_or_else(|| self.err_at(el, format!("{what} is appended but the file has no <AppendedData>")))?;
                let compressor = self.compressor.clone().map_err(|m| self.err_at(el, m))?;
                let offset_text = self.attr(el, "offset").unwrap_or("");
                let offset: usize = offset_text
                    .trim()
                    .parse()
                    .map_err(|_| self.err_at(el, format!("{what}: offset=\"{offset_text}\" is not a byte offset")))?;
                let loc = Location::Byte(app.base as u64 + offset as u64);
                if offset > app.data.len() {
                    return Err(FormatError::new(
                        loc,
                        format!(
                            "{what}: offset {offset} is past the end of the appended data ({} bytes)",
                            app.data.len()
                        ),
                    ));
                }
                if app.base64 {
                    self.mark(USED_APPENDED_BASE64);
                    let end = app.offsets.iter().copied().find(|&o| o > offset).unwrap_or(app.data.len());
                    let end = end.min(app.data.len());
                    let chunk = &app.data[offset..end];
                    let text: Vec<u8> = chunk.iter().copied().filter(|b| !b.is_ascii_whitespace()).collect();
                    self.with_base64_payload(&text, loc, compressor, expected_bytes, &what, f)
                } else {
                    self.mark(USED_RAW);
                    let mut cur = ByteCursor::with_base(&app.data[offset..], loc_offset(loc));
                    let unpacked = self.unpack(&mut cur, compressor, expected_bytes, &what)?;
                    f(Payload::Binary(unpacked.bytes(), loc))
                }
            }
            other => Err(self.err_at(el, format!("{what}: unknown format '{other}'"))),
        }
    }

    pub(crate) fn header_word(&self, cur: &mut ByteCursor<'_>, what: &str) -> Result<u64, FormatError> {
        if self.header_size == 8 {
            cur.u64(self.endian, what)
        } else {
            cur.u32(self.endian, what).map(u64::from)
        }
    }

    /// Runs `f` on base64 `text` (white space removed) decoded and
    /// unpacked; every error is reported at `loc`, since offsets inside
    /// decoded base64 are not file offsets.
    fn with_base64_payload<R>(
        &self,
        text: &[u8],
        loc: Location,
        compressor: Compressor,
        expected_bytes: Option<usize>,
        what: &str,
        f: impl FnOnce(Payload<'_>) -> Result<R, FormatError>,
    ) -> Result<R, FormatError> {
        let decoded = decode_base64(text).map_err(|m| FormatError::new(loc, format!("{what}: {m}")))?;
        let mut cur = ByteCursor::new(&decoded);
        let unpacked =
            self.unpack(&mut cur, compressor, expected_bytes, what).map_err(|e| FormatError::new(loc, e.message))?;
        f(Payload::Binary(unpacked.bytes(), loc))
    }

    /// Reads one array block: `[nbytes]` then the bytes, or the zlib layout
    /// `[nblocks, blocksize, lastblocksize, compsize_1..n]` then the blocks.
    pub(crate) fn unpack<'b>(
        &self,
        cur: &mut ByteCursor<'b>,
        compressor: Compressor,
        expected_bytes: Option<usize>,
        what: &str,
    ) -> Result<Unpacked<'b>, FormatError> {
        let at = cur.location();
        let to_usize = |v: u64, cur: &ByteCursor<'_>| {
            usize::try_from(v).map_err(|_| FormatError::new(cur.location(), format!("{what}: size {v} is too large")))
        };
        if compressor == Compressor::None {
            let n = self.header_word(cur, &format!("{what} size header"))?;
            let n = to_usize(n, cur)?;
            return Ok(Unpacked::Stored(cur.take(n, what)?));
        }
        self.mark(USED_ZLIB);
        let num_blocks = to_usize(self.header_word(cur, &format!("{what} zlib header"))?, cur)?;
        let block_size = to_usize(self.header_word(cur, &format!("{what} zlib header"))?, cur)?;
        let last_size = to_usize(self.header_word(cur, &format!("{what} zlib header"))?, cur)?;
        let sizes = cur.take_array(num_blocks, self.header_size, &format!("{what} zlib block sizes"))?;
        let last_size = if last_size == 0 { block_size } else { last_size };
        let total = match num_blocks {
            0 => Some(0),
            n => (n - 1).checked_mul(block_size).and_then(|t| t.checked_add(last_size)),
        }
        .ok_or_else(|| FormatError::new(at, format!("{what}: zlib header declares an impossible size")))?;
        if let Some(expected) = expected_bytes {
            if total != expected {
                return Err(FormatError::new(
                    at,
                    format!("{what}: zlib header declares {total} bytes, the array needs {expected}"),
                ));
            }
        }
        let mut size_cur = ByteCursor::new(sizes);
        let mut out: Vec<u8> = Vec::new();
        let mut inflater = Decompress::new(true);
        for b in 0..num_blocks {
            let comp = to_usize(self.header_word(&mut size_cur, "zlib block size")?, cur)?;
            let plain = if b + 1 == num_blocks { last_size } else { block_size };
            let block_at = cur.location();
            let input = cur.take(comp, &format!("{what} zlib block {b}"))?;
            if plain > comp.saturating_mul(MAX_DEFLATE_RATIO).saturating_add(1024) {
                return Err(FormatError::new(
                    block_at,
                    format!("{what}: zlib block {b} claims {plain} bytes from {comp} compressed bytes (beyond zlib's ratio)"),
                ));
            }
            out.reserve_exact(plain);
            inflater.reset(true);
            let before = out.len();
            let status = inflater.decompress_vec(input, &mut out, FlushDecompress::Finish);
            let produced = out.len() - before;
            match status {
                Ok(Status::StreamEnd) if produced == plain => {}
                Ok(Status::StreamEnd) => {
                    return Err(FormatError::new(
                        block_at,
                        format!("{what}: zlib block {b} inflates to {produced} bytes, header says {plain}"),
                    ))
                }
                Ok(_) => {
                    return Err(FormatError::new(
                        block_at,
                        format!(
                        "{what}: zlib block {b} is truncated or inflates past the {plain} bytes its header declares"
                    ),
                    ))
                }
                Err(e) => return Err(FormatError::new(block_at, format!("{what}: zlib block {b} is corrupt: {e}"))),
            }
        }
        Ok(Unpacked::Inflated(out))
    }

    /// The array's values as f64; exactly `expected` of them when given.
    pub(crate) fn array_f64(&self, el: usize, expected: Option<usize>) -> Result<Vec<f64>, FormatError> {
        let ty = self.array_type(el)?.ok_or_else(|| self.err_at(el, "expected a numeric DataArray"))?;
        let expected_bytes = expected.and_then(|n| n.checked_mul(ty.size()));
        let what = format!("DataArray '{}'", self.attr(el, "Name").unwrap_or(""));
        let values = self.with_payload(el, expected_bytes, |payload| match payload {
            Payload::Ascii(ranges) => self.ascii_values(ranges, expected, &what, parse_f64),
            Payload::Binary(bytes, loc) => {
                check_byte_count(bytes.len(), ty, expected, loc, &what)?;
                let mut out = Vec::new();
                decode_to_f64(bytes, ty, self.endian, &mut out);
                Ok(out)
            }
        })?;
        Ok(values)
    }

    /// The array's values as i64 (integer arrays only).
    pub(crate) fn array_i64(&self, el: usize, expected: Option<usize>) -> Result<Vec<i64>, FormatError> {
        let ty = self.array_type(el)?.ok_or_else(|| self.err_at(el, "expected an integer DataArray"))?;
        let what = format!("DataArray '{}'", self.attr(el, "Name").unwrap_or(""));
        if matches!(ty, ScalarType::F32 | ScalarType::F64) {
            return Err(self.err_at(el, format!("{what} must hold integers, not floating point")));
        }
        let expected_bytes = expected.and_then(|n| n.checked_mul(ty.size()));
        self.with_payload(el, expected_bytes, |payload| match payload {
            Payload::Ascii(ranges) => self.ascii_values(ranges, expected, &what, parse_i64),
            Payload::Binary(bytes, loc) => {
                check_byte_count(bytes.len(), ty, expected, loc, &what)?;
                decode_to_i64(bytes, ty, self.endian).map_err(|m| FormatError::new(loc, format!("{what}: {m}")))
            }
        })
    }

    pub(crate) fn ascii_values<T>(
        &self,
        ranges: &[Range<usize>],
        expected: Option<usize>,
        what: &str,
        parse: impl Fn(&str) -> Option<T>,
    ) -> Result<Vec<T>, FormatError> {
        let text_len: usize = ranges.iter().map(|r| r.len()).sum();
        // Every value takes at least two bytes (a digit and a separator).
        let mut out = Vec::with_capacity(expected.unwrap_or(0).min(text_len / 2 + 1));
        let base = self.bytes.as_ptr() as usize;
        for r in ranges {
            let Some(text) = self.bytes.get(r.clone()) else {
                continue;
            };
            for tok in text.split(|b| b.is_ascii_whitespace()).filter(|t| !t.is_empty()) {
                let pos = tok.as_ptr() as usize - base;
                let value = std::str::from_utf8(tok).ok().and_then(&parse).ok_or_else(|| {
                    let shown = String::from_utf8_lossy(&tok[..tok.len().min(40)]).into_owned();
                    FormatError::new(line_at(self.bytes, pos), format!("{what}: '{shown}' is not a valid value"))
                })?;
                if expected.is_some_and(|n| out.len() >= n) {
                    return Err(FormatError::new(
                        line_at(self.bytes, pos),
                        format!("{what}: more than the {} values expected", out.len()),
                    ));
                }
                out.push(value);
            }
        }
        if let Some(n) = expected {
            if out.len() != n {
                let pos = ranges.first().map_or(0, |r| r.start);
                return Err(FormatError::new(
                    line_at(self.bytes, pos),
                    format!("{what}: {} values, expected {n}", out.len()),
                ));
            }
        }
        Ok(out)
    }
}

pub(crate) fn loc_offset(loc: Location) -> u64 {
    match loc {
        Location::Byte(b) => b,
        _ => 0,
    }
}

pub(crate) fn check_byte_count(
    len: usize,
    ty: ScalarType,
    expected: Option<usize>,
    loc: Location,
    what: &str,
) -> Result<(), FormatError> {
    if len / ty.size() * ty.size() != len {
        return Err(FormatError::new(
            loc,
            format!("{what}: {len} bytes is not a whole number of {}-byte values", ty.size()),
        ));
    }
    if let Some(n) = expected {
        if len / ty.size() != n {
            return Err(FormatError::new(loc, format!("{what}: holds {} values, expected {n}", len / ty.size())));
        }
    }
    Ok(())
}

pub(crate) fn parse_i64(tok: &str) -> Option<i64> {
    tok.parse::<i64>().ok().or_else(|| {
        let v = parse_f64(tok)?;
        (v.fract() == 0.0 && v.abs() < 9.0e15).then_some(v as i64)
    })
}

/// Decodes integer elements to i64 (UInt64 values beyond i64 are an error).
pub(crate) fn decode_to_i64(bytes: &[u8], ty: ScalarType, e: Endian) -> Result<Vec<i64>, String> {
    macro_rules! conv {
        ($t:ty, $n:expr) => {
            bytes.chunks_exact($n).map(|ch| {
                let arr: [u8; $n] = ch.try_into().expect("chunk size");
                match e {
                    Endian::Little => <$t>::from_le_bytes(arr),
                    Endian::Big => <$t>::from_be_bytes(arr),
                }
            })
        };
    }
    Ok(match ty {
        ScalarType::I8 => bytes.iter().map(|&b| b as i8 as i64).collect(),
        ScalarType::U8 => bytes.iter().map(|&b| b as i64).collect(),
        ScalarType::I16 => conv!(i16, 2).map(i64::from).collect(),
        ScalarType::U16 => conv!(u16, 2).map(i64::from).collect(),
        ScalarType::I32 => conv!(i32, 4).map(i64::from).collect(),
        ScalarType::U32 => conv!(u32, 4).map(i64::from).collect(),
        ScalarType::I64 => conv!(i64, 8).collect(),
        ScalarType::U64 => conv!(u64, 8)
            .map(|v| i64::try_from(v).map_err(|_| format!("value {v} is out of range")))
            .collect::<Result<_, _>>()?,
        ScalarType::F32 | ScalarType::F64 => return Err("expected integers, found floating point".into()),
    })
}

/// Decodes VTK's base64: possibly several padded streams back to back (a
/// block header encoded separately from its data), which decode to the
/// concatenation of their bytes. `text` must hold no whitespace.
pub(crate) fn decode_base64(text: &[u8]) -> Result<Vec<u8>, String> {
    let mut out = Vec::with_capacity(text.len() / 4 * 3 + 3);
    let mut start = 0;
    while start < text.len() {
        let rest = &text[start..];
        let end = match rest.iter().position(|&c| c == b'=') {
            Some(p) => start + p + rest[p..].iter().take_while(|&&c| c == b'=').count(),
            None => text.len(),
        };
        BASE64
            .decode_vec(&text[start..end], &mut out)
            .map_err(|e| format!("invalid base64 at character {start}: {e}"))?;
        start = end;
    }
    Ok(out)
}
