//! Bounds-checked cursors over a file's bytes, shared by every reader.
//!
//! Readers never index a slice directly and never allocate from a declared
//! count without first checking that the remaining input can hold it: that is
//! what keeps garbage input from panicking or exhausting memory.

use crate::{FormatError, Location};

/// Byte order of binary data.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Endian {
    Little,
    Big,
}

/// A forward cursor over binary data that tracks its byte offset.
#[derive(Debug, Clone)]
pub struct ByteCursor<'a> {
    bytes: &'a [u8],
    pos: usize,
    /// Offset of `bytes[0]` in the file, so errors report file offsets.
    base: u64,
}

impl<'a> ByteCursor<'a> {
    pub fn new(bytes: &'a [u8]) -> Self {
        ByteCursor { bytes, pos: 0, base: 0 }
    }

    /// A cursor over a sub-slice that starts at `base` bytes into the file.
    pub fn with_base(bytes: &'a [u8], base: u64) -> Self {
        ByteCursor { bytes, pos: 0, base }
    }

    /// File offset of the next byte.
    pub fn offset(&self) -> u64 {
        self.base + self.pos as u64
    }

    pub fn location(&self) -> Location {
        Location::Byte(self.offset())
    }

    pub fn remaining(&self) -> usize {
        self.bytes.len() - self.pos
    }

    pub fn is_empty(&self) -> bool {
        self.remaining() == 0
    }

    pub fn seek(&mut self, pos: usize) -> Result<(), FormatError> {
        if pos > self.bytes.len() {
            return Err(FormatError::new(
                Location::Byte(self.base + pos as u64),
                format!("offset is past the end of the data ({} bytes)", self.bytes.len()),
            ));
        }
        self.pos = pos;
        Ok(())
    }

    /// Takes `n` bytes or fails with a "truncated" error naming `what`.
    pub fn take(&mut self, n: usize, what: &str) -> Result<&'a [u8], FormatError> {
        if n > self.remaining() {
            return Err(FormatError::new(
                self.location(),
                format!("truncated {what}: needs {n} bytes, only {} remain", self.remaining()),
            ));
        }
        let s = &self.bytes[self.pos..self.pos + n];
        self.pos += n;
        Ok(s)
    }

    /// Takes `count` items of `item_size` bytes, checking the product for
    /// overflow and against the remaining input before anything is allocated.
    pub fn take_array(&mut self, count: usize, item_size: usize, what: &str) -> Result<&'a [u8], FormatError> {
        let n = count.checked_mul(item_size).ok_or_else(|| {
            FormatError::new(self.location(), format!("{what}: declared size {count} × {item_size} overflows"))
        })?;
        self.take(n, what)
    }

    pub fn u32(&mut self, e: Endian, what: &str) -> Result<u32, FormatError> {
        let b: [u8; 4] = self.take(4, what)?.try_into().expect("4 bytes");
        Ok(match e {
            Endian::Little => u32::from_le_bytes(b),
            Endian::Big => u32::from_be_bytes(b),
        })
    }

    pub fn i32(&mut self, e: Endian, what: &str) -> Result<i32, FormatError> {
        self.u32(e, what).map(|v| v as i32)
    }

    pub fn u64(&mut self, e: Endian, what: &str) -> Result<u64, FormatError> {
        let b: [u8; 8] = self.take(8, what)?.try_into().expect("8 bytes");
        Ok(match e {
            Endian::Little => u64::from_le_bytes(b),
            Endian::Big => u64::from_be_bytes(b),
        })
    }

    pub fn f32(&mut self, e: Endian, what: &str) -> Result<f32, FormatError> {
        self.u32(e, what).map(f32::from_bits)
    }

    pub fn f64(&mut self, e: Endian, what: &str) -> Result<f64, FormatError> {
        self.u64(e, what).map(f64::from_bits)
    }
}

/// Scalar element types found in binary payloads.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum ScalarType {
    I8,
    U8,
    I16,
    U16,
    I32,
    U32,
    I64,
    U64,
    F32,
    F64,
}

impl ScalarType {
    pub fn size(self) -> usize {
        match self {
            ScalarType::I8 | ScalarType::U8 => 1,
            ScalarType::I16 | ScalarType::U16 => 2,
            ScalarType::I32 | ScalarType::U32 | ScalarType::F32 => 4,
            ScalarType::I64 | ScalarType::U64 | ScalarType::F64 => 8,
        }
    }
}

/// Decodes `bytes` (a whole number of `ty` elements) to f64, appending to `out`.
pub fn decode_to_f64(bytes: &[u8], ty: ScalarType, e: Endian, out: &mut Vec<f64>) {
    let sz = ty.size();
    out.reserve(bytes.len() / sz);
    macro_rules! conv {
        ($t:ty, $n:expr) => {
            for ch in bytes.chunks_exact($n) {
                let arr: [u8; $n] = ch.try_into().expect("chunk size");
                let v = match e {
                    Endian::Little => <$t>::from_le_bytes(arr),
                    Endian::Big => <$t>::from_be_bytes(arr),
                };
                out.push(v as f64);
            }
        };
    }
    match ty {
        ScalarType::I8 => out.extend(bytes.iter().map(|&b| b as i8 as f64)),
        ScalarType::U8 => out.extend(bytes.iter().map(|&b| b as f64)),
        ScalarType::I16 => conv!(i16, 2),
        ScalarType::U16 => conv!(u16, 2),
        ScalarType::I32 => conv!(i32, 4),
        ScalarType::U32 => conv!(u32, 4),
        ScalarType::I64 => conv!(i64, 8),
        ScalarType::U64 => conv!(u64, 8),
        ScalarType::F32 => conv!(f32, 4),
        ScalarType::F64 => conv!(f64, 8),
    }
}

/// A whitespace tokenizer over ASCII text that tracks line numbers (1-based).
#[derive(Debug, Clone)]
pub struct TextCursor<'a> {
    bytes: &'a [u8],
    pos: usize,
    line: usize,
}

impl<'a> TextCursor<'a> {
    pub fn new(bytes: &'a [u8]) -> Self {
        TextCursor { bytes, pos: 0, line: 1 }
    }

    /// A cursor over text that is line `line` onwards of a larger file.
    pub fn starting_at_line(bytes: &'a [u8], line: usize) -> Self {
        TextCursor { bytes, pos: 0, line }
    }

    pub fn line(&self) -> usize {
        self.line
    }

    pub fn location(&self) -> Location {
        Location::Line(self.line)
    }

    /// Byte offset of the next unread byte.
    pub fn offset(&self) -> usize {
        self.pos
    }

    /// The bytes not consumed yet.
    pub fn rest(&self) -> &'a [u8] {
        &self.bytes[self.pos..]
    }

    /// Skips `n` bytes (clamped to the end), counting newlines in them.
    pub fn advance(&mut self, n: usize) {
        let end = (self.pos + n).min(self.bytes.len());
        self.line += self.bytes[self.pos..end].iter().filter(|&&b| b == b'\n').count();
        self.pos = end;
    }

    fn skip_ws(&mut self) {
        while let Some(&b) = self.bytes.get(self.pos) {
            if b == b'\n' {
                self.line += 1;
            } else if !b.is_ascii_whitespace() {
                break;
            }
            self.pos += 1;
        }
    }

    /// Next whitespace-separated token, or `None` at the end of input.
    pub fn token(&mut self) -> Option<&'a str> {
        self.skip_ws();
        let start = self.pos;
        while let Some(&b) = self.bytes.get(self.pos) {
            if b.is_ascii_whitespace() {
                break;
            }
            self.pos += 1;
        }
        if start == self.pos {
            return None;
        }
        // Non-UTF-8 garbage becomes an empty-looking token that fails to parse.
        Some(std::str::from_utf8(&self.bytes[start..self.pos]).unwrap_or("\u{FFFD}"))
    }

    /// Next token or an error naming what was expected.
    pub fn expect_token(&mut self, what: &str) -> Result<&'a str, FormatError> {
        let loc = self.location();
        self.token().ok_or_else(|| FormatError::new(loc, format!("unexpected end of file, expected {what}")))
    }

    pub fn parse<T: std::str::FromStr>(&mut self, what: &str) -> Result<T, FormatError> {
        let tok = self.expect_token(what)?;
        tok.parse::<T>()
            .map_err(|_| FormatError::new(self.location(), format!("expected {what}, found '{}'", clip(tok))))
    }

    pub fn f64(&mut self, what: &str) -> Result<f64, FormatError> {
        let tok = self.expect_token(what)?;
        parse_f64(tok)
            .ok_or_else(|| FormatError::new(self.location(), format!("expected {what}, found '{}'", clip(tok))))
    }

    /// The rest of the current line (without the newline), consuming it.
    pub fn line_str(&mut self) -> Option<&'a str> {
        if self.pos >= self.bytes.len() {
            return None;
        }
        let start = self.pos;
        while let Some(&b) = self.bytes.get(self.pos) {
            self.pos += 1;
            if b == b'\n' {
                self.line += 1;
                let end = if self.pos >= 2 && self.bytes[self.pos - 2] == b'\r' { self.pos - 2 } else { self.pos - 1 };
                return Some(std::str::from_utf8(&self.bytes[start..end]).unwrap_or("\u{FFFD}"));
            }
        }
        Some(std::str::from_utf8(&self.bytes[start..]).unwrap_or("\u{FFFD}"))
    }
}

/// Parses a float as scientific codes write it, including Fortran's `1.0D+03`
/// and the `nan`/`inf` spellings (those are rejected later, by validation,
/// with the vertex named).
pub fn parse_f64(tok: &str) -> Option<f64> {
    if let Ok(v) = tok.parse::<f64>() {
        return Some(v);
    }
    if tok.bytes().any(|b| b == b'd' || b == b'D') {
        return tok.replace(['d', 'D'], "e").parse().ok();
    }
    match tok.to_ascii_lowercase().as_str() {
        "nan" | "-nan" | "+nan" | "-nan(ind)" | "nan(ind)" => Some(f64::NAN),
        "-1.#ind" | "1.#qnan" | "-1.#qnan" => Some(f64::NAN),
        "1.#inf" | "infinity" => Some(f64::INFINITY),
        "-1.#inf" | "-infinity" => Some(f64::NEG_INFINITY),
        _ => None,
    }
}

/// Shortens text quoted in an error message.
pub(crate) fn clip(s: &str) -> String {
    if s.chars().count() > 40 {
        let t: String = s.chars().take(40).collect();
        format!("{t}…")
    } else {
        s.to_string()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn take_array_rejects_absurd_counts_without_allocating() {
        let data = [0u8; 16];
        let mut c = ByteCursor::new(&data);
        assert!(c.take_array(usize::MAX / 2, 8, "points").is_err());
        assert!(c.take_array(5, 4, "points").is_err());
        assert_eq!(c.take_array(4, 4, "points").unwrap().len(), 16);
    }

    #[test]
    fn text_cursor_tracks_lines() {
        let mut t = TextCursor::new(b"a b\n  c\r\n1.5D+02\n");
        assert_eq!(t.token(), Some("a"));
        assert_eq!(t.token(), Some("b"));
        assert_eq!(t.token(), Some("c"));
        assert_eq!(t.line(), 2);
        assert_eq!(t.f64("x").unwrap(), 150.0);
        assert_eq!(t.token(), None);
    }

    #[test]
    fn decode_big_endian_f32() {
        let mut out = Vec::new();
        decode_to_f64(&1.5f32.to_be_bytes(), ScalarType::F32, Endian::Big, &mut out);
        assert_eq!(out, vec![1.5]);
    }
}
