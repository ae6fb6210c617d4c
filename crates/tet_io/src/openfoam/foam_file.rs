//! One OpenFOAM data file: the `FoamFile` header and the lists and fields
//! after it, ASCII or binary.
//!
//! Syntax (User Guide §4.2): free-form tokens, `//` and `/* */` comments,
//! dictionaries `name { key value; … }`, lists `N ( … )` and the uniform
//! shorthand `N { value }`. In a `format binary` file everything is text
//! except the payload of a list of fixed-size items (labels, scalars,
//! vectors, and each face of a `faceList`): `N (` is followed at once by
//! N raw items in the byte order, label width and scalar width of the
//! header's `arch "LSB;label=32;scalar=64"` (these defaults when absent),
//! then `)`. Errors in text name the line; errors inside a binary payload
//! the byte offset (of the decompressed content for a `.gz` file).

use crate::cursor::{clip, decode_to_f64, parse_f64, Endian, ScalarType};
use crate::{FormatError, Location};

/// What the `FoamFile` header says.
#[derive(Debug, Clone, PartialEq)]
pub(crate) struct Header {
    pub binary: bool,
    pub endian: Endian,
    /// 4 or 8.
    pub label_bytes: usize,
    /// 4 or 8.
    pub scalar_bytes: usize,
    /// `class`, e.g. `vectorField`, `faceCompactList`, `volScalarField`
    /// (empty when the header has none).
    pub class: String,
}

impl Default for Header {
    fn default() -> Self {
        Header { binary: false, endian: Endian::Little, label_bytes: 4, scalar_bytes: 8, class: String::new() }
    }
}

#[derive(Debug, Clone, Copy, PartialEq)]
enum Tok<'a> {
    /// One of `( ) { } [ ] ;`.
    Punct(u8),
    /// A word or number; a quoted string without its quotes.
    Word(&'a str),
}

/// How a list opened: with a count or not, `(` or `{` (uniform).
struct ListOpen {
    count: Option<usize>,
    uniform: bool,
    /// Offset of the count (or of the bracket when there is no count).
    at: usize,
}

/// A tokenizer positioned after a file's header.
pub(crate) struct FoamFile<'a> {
    bytes: &'a [u8],
    pos: usize,
    pub header: Header,
}

fn is_punct(b: u8) -> bool {
    matches!(b, b'(' | b')' | b'{' | b'}' | b'[' | b']' | b';')
}

/// 1-based line of byte `offset`.
pub(crate) fn line_at(bytes: &[u8], offset: usize) -> usize {
    1 + bytes[..offset.min(bytes.len())].iter().filter(|&&b| b == b'\n').count()
}

impl<'a> FoamFile<'a> {
    /// Reads the header (a file without one is taken as ASCII with the
    /// default widths) and leaves the cursor after it.
    pub fn new(bytes: &'a [u8]) -> Result<Self, FormatError> {
        let mut f = FoamFile { bytes, pos: 0, header: Header::default() };
        let save = f.pos;
        match f.token()? {
            Some((Tok::Word("FoamFile"), _)) => f.read_header()?,
            _ => f.pos = save,
        }
        Ok(f)
    }

    fn text_loc(&self, offset: usize) -> Location {
        Location::Line(line_at(self.bytes, offset))
    }

    fn err(&self, offset: usize, msg: impl Into<String>) -> FormatError {
        FormatError::new(self.text_loc(offset), msg)
    }

    fn skip_trivia(&mut self) -> Result<(), FormatError> {
        loop {
            while self.bytes.get(self.pos).is_some_and(|b| b.is_ascii_whitespace()) {
                self.pos += 1;
            }
            let rest = &self.bytes[self.pos..];
            if rest.starts_with(b"//") {
                let end = rest.iter().position(|&b| b == b'\n').unwrap_or(rest.len());
                self.pos += end;
            } else if rest.starts_with(b"/*") {
                let end = rest[2..]
                    .windows(2)
                    .position(|w| w == b"*/")
                    .ok_or_else(|| self.err(self.pos, "a /* comment is never closed"))?;
                self.pos += 2 + end + 2;
            } else {
                return Ok(());
            }
        }
    }

    /// Next token and its offset; `None` at the end.
    fn token(&mut self) -> Result<Option<(Tok<'a>, usize)>, FormatError> {
        self.skip_trivia()?;
        let start = self.pos;
        let Some(&b) = self.bytes.get(start) else { return Ok(None) };
        if is_punct(b) {
            self.pos += 1;
            return Ok(Some((Tok::Punct(b), start)));
        }
        if b == b'"' {
            let rest = &self.bytes[start + 1..];
            let len = rest
                .iter()
                .position(|&c| c == b'"')
                .ok_or_else(|| self.err(start, "a quoted string is never closed"))?;
            self.pos = start + 1 + len + 1;
            let s = std::str::from_utf8(&rest[..len]).unwrap_or("\u{FFFD}");
            return Ok(Some((Tok::Word(s), start)));
        }
        while self.bytes.get(self.pos).is_some_and(|&c| !c.is_ascii_whitespace() && !is_punct(c) && c != b'"') {
            self.pos += 1;
        }
        let s = std::str::from_utf8(&self.bytes[start..self.pos]).unwrap_or("\u{FFFD}");
        Ok(Some((Tok::Word(s), start)))
    }

    fn expect_token(&mut self, what: &str) -> Result<(Tok<'a>, usize), FormatError> {
        let end = self.bytes.len();
        self.token()?.ok_or_else(|| self.err(end, format!("unexpected end of file, expected {what}")))
    }

    fn expect_punct(&mut self, p: u8, what: &str) -> Result<usize, FormatError> {
        match self.expect_token(what)? {
            (Tok::Punct(q), at) if q == p => Ok(at),
            (t, at) => Err(self.err(at, format!("expected '{}' {what}, found {}", p as char, show(t)))),
        }
    }

    fn read_header(&mut self) -> Result<(), FormatError> {
        self.expect_punct(b'{', "after FoamFile")?;
        loop {
            let (t, at) = self.expect_token("a FoamFile entry or '}'")?;
            let key = match t {
                Tok::Punct(b'}') => return Ok(()),
                Tok::Word(w) => w,
                Tok::Punct(_) => return Err(self.err(at, format!("unexpected {} in the FoamFile header", show(t)))),
            };
            let mut value: Option<(&str, usize)> = None;
            loop {
                match self.expect_token("';' ending a FoamFile entry")? {
                    (Tok::Punct(b';'), _) => break,
                    (Tok::Word(w), at) => {
                        value.get_or_insert((w, at));
                    }
                    (t, at) => return Err(self.err(at, format!("unexpected {} in FoamFile entry '{key}'", show(t)))),
                }
            }
            let (v, vat) = value.unwrap_or(("", at));
            match key {
                "format" => {
                    self.header.binary = match v {
                        "ascii" => false,
                        "binary" => true,
                        _ => return Err(self.err(vat, format!("format '{}': expected ascii or binary", clip(v)))),
                    }
                }
                "arch" => self.read_arch(v, vat)?,
                "class" => self.header.class = v.to_string(),
                _ => {}
            }
        }
    }

    /// `LSB;label=32;scalar=64` (any order; missing parts keep the defaults).
    fn read_arch(&mut self, v: &str, at: usize) -> Result<(), FormatError> {
        for part in v.split(';').map(str::trim).filter(|p| !p.is_empty()) {
            match part {
                "LSB" => self.header.endian = Endian::Little,
                "MSB" => self.header.endian = Endian::Big,
                "label=32" => self.header.label_bytes = 4,
                "label=64" => self.header.label_bytes = 8,
                "scalar=32" => self.header.scalar_bytes = 4,
                "scalar=64" => self.header.scalar_bytes = 8,
                _ => {
                    return Err(self.err(
                        at,
                        format!("arch part '{}': expected LSB or MSB, label=32|64, scalar=32|64", clip(part)),
                    ))
                }
            }
        }
        Ok(())
    }

    /// `N (`, `N {`, or a bare `(` (ASCII lists may omit the count).
    fn open_list(&mut self, what: &str) -> Result<ListOpen, FormatError> {
        let (t, at) = self.expect_token(what)?;
        let count = match t {
            Tok::Punct(b'(') if !self.header.binary => return Ok(ListOpen { count: None, uniform: false, at }),
            Tok::Word(w) => Some(
                w.parse::<usize>()
                    .map_err(|_| self.err(at, format!("expected the length of {what}, found '{}'", clip(w))))?,
            ),
            t => return Err(self.err(at, format!("expected {what}, found {}", show(t)))),
        };
        let (open, oat) = self.expect_token(&format!("'(' opening {what}"))?;
        match open {
            Tok::Punct(b'(') => Ok(ListOpen { count, uniform: false, at }),
            Tok::Punct(b'{') => Ok(ListOpen { count, uniform: true, at }),
            t => Err(self.err(oat, format!("expected '(' opening {what}, found {}", show(t)))),
        }
    }

    /// Takes `n` raw items of `size` bytes right after an opening `(`.
    fn payload(&mut self, n: usize, size: usize, what: &str) -> Result<(&'a [u8], usize), FormatError> {
        let start = self.pos;
        let len = n.checked_mul(size).filter(|&l| l <= self.bytes.len() - start).ok_or_else(|| {
            FormatError::new(
                Location::Byte(start as u64),
                format!(
                    "truncated {what}: {n} binary items of {size} bytes need more than the {} bytes left",
                    self.bytes.len() - start
                ),
            )
        })?;
        self.pos += len;
        Ok((&self.bytes[start..start + len], start))
    }

    fn close(&mut self, p: u8, what: &str) -> Result<(), FormatError> {
        self.expect_punct(p, &format!("closing {what}")).map(|_| ())
    }

    fn label_of(&self, raw: &[u8]) -> i64 {
        match (self.header.label_bytes, self.header.endian) {
            (4, Endian::Little) => i32::from_le_bytes(raw.try_into().expect("4 bytes")) as i64,
            (4, Endian::Big) => i32::from_be_bytes(raw.try_into().expect("4 bytes")) as i64,
            (_, Endian::Little) => i64::from_le_bytes(raw.try_into().expect("8 bytes")),
            (_, Endian::Big) => i64::from_be_bytes(raw.try_into().expect("8 bytes")),
        }
    }

    fn ascii_label(&mut self, what: &str) -> Result<(i64, usize), FormatError> {
        match self.expect_token(what)? {
            (Tok::Word(w), at) => w
                .parse::<i64>()
                .map(|v| (v, at))
                .map_err(|_| self.err(at, format!("expected {what}, found '{}'", clip(w)))),
            (t, at) => Err(self.err(at, format!("expected {what}, found {}", show(t)))),
        }
    }

    fn ascii_scalar(&mut self, what: &str) -> Result<f64, FormatError> {
        match self.expect_token(what)? {
            (Tok::Word(w), at) => {
                parse_f64(w).ok_or_else(|| self.err(at, format!("expected {what}, found '{}'", clip(w))))
            }
            (t, at) => Err(self.err(at, format!("expected {what}, found {}", show(t)))),
        }
    }

    /// One ASCII tuple: a scalar, or `( x y z )` for 3 components.
    fn ascii_tuple(&mut self, ncomp: usize, what: &str, out: &mut Vec<f64>) -> Result<(), FormatError> {
        if ncomp == 1 {
            out.push(self.ascii_scalar(what)?);
            return Ok(());
        }
        self.expect_punct(b'(', &format!("opening a {what}"))?;
        for _ in 0..ncomp {
            out.push(self.ascii_scalar(&format!("a {what} component"))?);
        }
        self.close(b')', &format!("a {what} of {ncomp} components"))
    }

    /// Is the next token a `)`? (Consumes it when it is.)
    fn at_close(&mut self) -> Result<bool, FormatError> {
        let save = self.pos;
        match self.token()? {
            Some((Tok::Punct(b')'), _)) => Ok(true),
            _ => {
                self.pos = save;
                Ok(false)
            }
        }
    }

    /// A list of labels; `each(value)` validates and stores one, its error
    /// becoming a [`FormatError`] at that label. Returns the length and
    /// where the list starts.
    pub fn labels(
        &mut self,
        what: &str,
        mut each: impl FnMut(i64) -> Result<(), String>,
    ) -> Result<(usize, Location), FormatError> {
        let open = self.open_list(what)?;
        let at = self.text_loc(open.at);
        if open.uniform {
            return Err(self.err(open.at, format!("{what} is a uniform list (N{{…}}); expected one entry per item")));
        }
        match open.count {
            Some(n) if self.header.binary => {
                let size = self.header.label_bytes;
                let (raw, start) = self.payload(n, size, what)?;
                for (i, ch) in raw.chunks_exact(size).enumerate() {
                    each(self.label_of(ch))
                        .map_err(|m| FormatError::new(Location::Byte((start + i * size) as u64), m))?;
                }
                self.close(b')', what)?;
                Ok((n, at))
            }
            count => {
                let mut n = 0usize;
                loop {
                    if count.is_some_and(|c| n == c) || count.is_none() && self.at_close()? {
                        break;
                    }
                    let (v, vat) = self.ascii_label(&format!("entry {n} of {what}"))?;
                    each(v).map_err(|m| self.err(vat, m))?;
                    n += 1;
                }
                if count.is_some() {
                    self.close(b')', what)?;
                }
                Ok((n, at))
            }
        }
    }

    /// A list of `ncomp`-component tuples (scalars or vectors), flattened.
    /// `expected`, when known, is the tuple count the list must have (a
    /// uniform `N{v}` list is accepted only then, so no declared count is
    /// trusted for allocation).
    pub fn tuples(
        &mut self,
        what: &str,
        ncomp: usize,
        expected: Option<usize>,
    ) -> Result<(Vec<f64>, Location), FormatError> {
        let open = self.open_list(what)?;
        let at = self.text_loc(open.at);
        if let (Some(n), Some(e)) = (open.count, expected) {
            if n != e {
                return Err(self.err(open.at, format!("{what} has {n} values, expected {e} (one per cell)")));
            }
        }
        if open.uniform {
            let n = match (open.count, expected) {
                (Some(n), Some(_)) => n,
                _ => return Err(self.err(open.at, format!("{what} is a uniform list (N{{…}}), not expected here"))),
            };
            let mut one = Vec::with_capacity(ncomp);
            self.ascii_tuple(ncomp, what, &mut one)?;
            self.close(b'}', what)?;
            let mut out = Vec::with_capacity(n * ncomp);
            for _ in 0..n {
                out.extend_from_slice(&one);
            }
            return Ok((out, at));
        }
        match open.count {
            Some(n) if self.header.binary => {
                let size = self.header.scalar_bytes;
                let (raw, _) = self.payload(n, size * ncomp, what)?;
                let ty = if size == 4 { ScalarType::F32 } else { ScalarType::F64 };
                let mut out = Vec::new();
                decode_to_f64(raw, ty, self.header.endian, &mut out);
                self.close(b')', what)?;
                Ok((out, at))
            }
            count => {
                // Each ASCII value takes at least 2 bytes: cap the reservation.
                let cap = count.unwrap_or(0).min(self.bytes.len() / 2) * ncomp;
                let mut out = Vec::with_capacity(cap);
                let mut n = 0usize;
                loop {
                    if count.is_some_and(|c| n == c) || count.is_none() && self.at_close()? {
                        break;
                    }
                    self.ascii_tuple(ncomp, what, &mut out)?;
                    n += 1;
                }
                if count.is_some() {
                    self.close(b')', what)?;
                }
                if let Some(e) = expected.filter(|&e| e != n) {
                    return Err(FormatError::new(at, format!("{what} has {n} values, expected {e} (one per cell)")));
                }
                Ok((out, at))
            }
        }
    }

    /// The faces of a `faceList` (`N ( k(a b c …) … )`) or a
    /// `faceCompactList` (an offsets list then a point-id list), as CSR
    /// `(start, ids)`. Every id is checked against `num_points` and every
    /// face must have at least 3 points; the error names the face.
    pub fn faces(&mut self, num_points: usize) -> Result<(Vec<usize>, Vec<u32>, Location), FormatError> {
        let point = |v: i64, f: usize| -> Result<u32, String> {
            u32::try_from(v).ok().filter(|&p| (p as usize) < num_points).ok_or_else(|| {
                format!("face {f} names point {v}, but the mesh has {num_points} points (numbered from 0)")
            })
        };
        if self.header.class == "faceCompactList" {
            let mut start: Vec<usize> = Vec::new();
            let (_, at) = self.labels("the face offsets", |v| {
                let prev = start.last().copied();
                let ok = usize::try_from(v).ok().filter(|&o| match prev {
                    None => o == 0,
                    Some(p) => o >= p + 3,
                });
                let Some(o) = ok else {
                    return Err(match prev {
                        None => format!("the face offsets must start at 0, found {v}"),
                        Some(p) => format!(
                            "face {} has {} points (offsets {p} to {v}); a face needs 3",
                            start.len() - 1,
                            v - p as i64
                        ),
                    });
                };
                start.push(o);
                Ok(())
            })?;
            if start.is_empty() {
                start.push(0);
            }
            let nfaces = start.len() - 1;
            let mut ids: Vec<u32> = Vec::with_capacity(start[nfaces].min(self.bytes.len()));
            let mut face = 0usize;
            let (n, ids_at) = self.labels("the face point ids", |v| {
                while face < nfaces && start[face + 1] <= ids.len() {
                    face += 1;
                }
                ids.push(point(v, face)?);
                Ok(())
            })?;
            if n != start[nfaces] {
                return Err(FormatError::new(
                    ids_at,
                    format!("the face offsets end at {} but there are {n} point ids", start[nfaces]),
                ));
            }
            return Ok((start, ids, at));
        }
        let open = self.open_list("the face list")?;
        let at = self.text_loc(open.at);
        if open.uniform {
            return Err(self.err(open.at, "the face list is a uniform list (N{…}); expected one entry per face"));
        }
        let mut start = vec![0usize];
        let mut ids: Vec<u32> = Vec::new();
        loop {
            let f = start.len() - 1;
            if open.count.is_some_and(|c| f == c) || open.count.is_none() && self.at_close()? {
                break;
            }
            let what = format!("face {f}");
            let inner = self.open_list(&what)?;
            let k = match inner.count {
                Some(k) if !inner.uniform => k,
                _ => return Err(self.err(inner.at, format!("{what}: expected k(a b c …) with its point count k"))),
            };
            if k < 3 {
                return Err(self.err(inner.at, format!("{what} has {k} points; a face needs 3")));
            }
            if self.header.binary {
                let size = self.header.label_bytes;
                let (raw, pstart) = self.payload(k, size, &what)?;
                for (i, ch) in raw.chunks_exact(size).enumerate() {
                    ids.push(
                        point(self.label_of(ch), f)
                            .map_err(|m| FormatError::new(Location::Byte((pstart + i * size) as u64), m))?,
                    );
                }
            } else {
                for _ in 0..k {
                    let (v, vat) = self.ascii_label(&format!("a point id of {what}"))?;
                    ids.push(point(v, f).map_err(|m| self.err(vat, m))?);
                }
            }
            self.close(b')', &what)?;
            start.push(ids.len());
        }
        if open.count.is_some() {
            self.close(b')', "the face list")?;
        }
        Ok((start, ids, at))
    }

    /// The `internalField` of a `vol*Field`: `uniform v` repeated over the
    /// `num_cells` cells, or `nonuniform List<scalar|vector> N (…)` whose N
    /// must be `num_cells`. `None` when the entry is missing or is not one of
    /// those forms (a macro, a `#codeStream`): the caller notes it.
    pub fn internal_field(&mut self, ncomp: usize, num_cells: usize) -> Result<Option<Vec<f64>>, FormatError> {
        let mut depth = 0usize;
        loop {
            let Some((t, _)) = self.token()? else { return Ok(None) };
            match t {
                Tok::Punct(b'{' | b'(' | b'[') => depth += 1,
                Tok::Punct(b'}' | b')' | b']') => depth = depth.saturating_sub(1),
                Tok::Word("internalField") if depth == 0 => break,
                _ => {}
            }
        }
        let (kind, kat) = self.expect_token("uniform or nonuniform after internalField")?;
        match kind {
            Tok::Word("uniform") => {
                let mut one = Vec::with_capacity(ncomp);
                self.ascii_tuple(ncomp, "internalField value", &mut one)?;
                let mut out = Vec::with_capacity(num_cells * ncomp);
                for _ in 0..num_cells {
                    out.extend_from_slice(&one);
                }
                Ok(Some(out))
            }
            Tok::Word("nonuniform") => {
                let (ty, tat) = self.expect_token("List<scalar> or List<vector>")?;
                let want = if ncomp == 1 { "List<scalar>" } else { "List<vector>" };
                if ty != Tok::Word(want) {
                    return Err(self.err(tat, format!("internalField is {}, expected {want}", show(ty))));
                }
                Ok(Some(self.tuples("internalField", ncomp, Some(num_cells))?.0))
            }
            _ => {
                let _ = kat;
                Ok(None)
            }
        }
    }

    /// The patches of a `boundary` file, `N ( name { … nFaces n; … } … )`,
    /// as (name, face count); `None` when the file does not have that shape
    /// (the boundary is informative only, so the caller ignores it then).
    pub fn patches(&mut self) -> Option<Vec<(String, usize)>> {
        let open = self.open_list("the patch list").ok()?;
        if open.uniform {
            return None;
        }
        let mut out = Vec::new();
        loop {
            let name = match self.token().ok()?? {
                (Tok::Punct(b')'), _) => return Some(out),
                (Tok::Word(w), _) => w.to_string(),
                _ => return None,
            };
            self.expect_punct(b'{', "").ok()?;
            let (mut depth, mut faces, mut prev) = (1usize, 0usize, "");
            while depth > 0 {
                match self.token().ok()?? {
                    (Tok::Punct(b'{'), _) => depth += 1,
                    (Tok::Punct(b'}'), _) => depth -= 1,
                    (Tok::Word(w), _) => {
                        if prev == "nFaces" && depth == 1 {
                            faces = w.parse().ok()?;
                        }
                        prev = w;
                        continue;
                    }
                    _ => {}
                }
                prev = "";
            }
            out.push((name, faces));
        }
    }

    /// The location of entry `index` of the first list after the header (a
    /// labelList such as `owner`): for errors found after parsing.
    pub fn label_location(bytes: &'a [u8], index: usize) -> Location {
        let Ok(mut f) = FoamFile::new(bytes) else { return Location::Whole };
        let Ok(open) = f.open_list("labels") else { return Location::Whole };
        if f.header.binary && open.count.is_some() {
            return Location::Byte((f.pos + index * f.header.label_bytes) as u64);
        }
        for _ in 0..index {
            if !matches!(f.token(), Ok(Some(_))) {
                return Location::Whole;
            }
        }
        match f.token() {
            Ok(Some((_, at))) => f.text_loc(at),
            _ => Location::Whole,
        }
    }
}

fn show(t: Tok<'_>) -> String {
    match t {
        Tok::Punct(p) => format!("'{}'", p as char),
        Tok::Word(w) => format!("'{}'", clip(w)),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn file(header: &str, body: &[u8]) -> Vec<u8> {
        let mut v = format!("/* banner */\nFoamFile\n{{\n    version 2.0;\n{header}}}\n// * * //\n").into_bytes();
        v.extend_from_slice(body);
        v
    }

    #[test]
    fn header_and_ascii_lists() {
        let b = file("    format ascii;\n    class vectorField;\n", b"3\n(\n(0 0 0)\n(1 0 0)\n(0 1e-3 0)\n)\n");
        let mut f = FoamFile::new(&b).unwrap();
        assert_eq!(f.header.class, "vectorField");
        let (v, _) = f.tuples("points", 3, None).unwrap();
        assert_eq!(v, vec![0., 0., 0., 1., 0., 0., 0., 1e-3, 0.]);
    }

    #[test]
    fn arch_and_binary_labels() {
        let mut body = b"2\n(".to_vec();
        body.extend_from_slice(&7i64.to_be_bytes());
        body.extend_from_slice(&9i64.to_be_bytes());
        body.extend_from_slice(b")\n");
        let b = file("    format binary;\n    arch \"MSB;label=64;scalar=32\";\n", &body);
        let mut f = FoamFile::new(&b).unwrap();
        assert_eq!((f.header.endian, f.header.label_bytes, f.header.scalar_bytes), (Endian::Big, 8, 4));
        let mut got = vec![];
        f.labels("owner", |v| {
            got.push(v);
            Ok(())
        })
        .unwrap();
        assert_eq!(got, vec![7, 9]);
    }

    #[test]
    fn faces_both_forms_and_errors() {
        let b = file("    format ascii;\n    class faceList;\n", b"2(4(0 1 2 3) 3(1 2 4))");
        let (s, ids, _) = FoamFile::new(&b).unwrap().faces(5).unwrap();
        assert_eq!((s, ids), (vec![0, 4, 7], vec![0, 1, 2, 3, 1, 2, 4]));
        let b = file("    format ascii;\n    class faceCompactList;\n", b"3(0 4 7)\n7(0 1 2 3 1 2 4)");
        let (s, ids, _) = FoamFile::new(&b).unwrap().faces(5).unwrap();
        assert_eq!((s, ids), (vec![0, 4, 7], vec![0, 1, 2, 3, 1, 2, 4]));
        let b = file("    format ascii;\n    class faceList;\n", b"2(4(0 1 2 3)\n3(1 2 9))");
        let e = FoamFile::new(&b).unwrap().faces(5).unwrap_err();
        assert!(e.message.contains("face 1 names point 9"), "{e}");
        assert_eq!(e.at, Location::Line(10));
    }

    #[test]
    fn fields_uniform_nonuniform_and_counts() {
        let b = file("    class volVectorField;\n", b"dimensions [0 1 -1 0 0 0 0];\ninternalField uniform (1 2 3);\n");
        let v = FoamFile::new(&b).unwrap().internal_field(3, 2).unwrap().unwrap();
        assert_eq!(v, vec![1., 2., 3., 1., 2., 3.]);
        let b = file("", b"internalField nonuniform List<scalar> 3(1 2 3);\n");
        let e = FoamFile::new(&b).unwrap().internal_field(1, 4).unwrap_err();
        assert!(e.message.contains("3 values, expected 4"), "{e}");
        let b = file("", b"internalField nonuniform List<scalar> 4{2.5};\n");
        assert_eq!(FoamFile::new(&b).unwrap().internal_field(1, 4).unwrap().unwrap(), vec![2.5; 4]);
        let b = file("", b"internalField #codeStream { };\n");
        assert_eq!(FoamFile::new(&b).unwrap().internal_field(1, 4).unwrap(), None);
    }

    #[test]
    fn truncated_binary_payload_names_its_byte() {
        let b = file("    format binary;\n", b"1000(\x01\x02");
        let e = FoamFile::new(&b).unwrap().labels("owner", |_| Ok(())).unwrap_err();
        assert!(matches!(e.at, Location::Byte(_)) && e.message.contains("truncated"), "{e}");
    }
}
