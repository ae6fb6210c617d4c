//! CSV and XYZ point tables: one point per line.
//!
//! The separator is detected from the first data line: a comma, else a
//! semicolon, else a tab, else runs of whitespace. `#` starts a comment
//! (whole line or trailing); blank lines are skipped; a UTF-8 byte-order
//! mark and double quotes around values are dropped.
//!
//! Columns are named by a header line (a first data line with anything that
//! is not a number) or by the caller's column spec (`--columns x,y,z,value`,
//! which replaces a header if there is one; the names `_`, `-` or an empty
//! name skip a column). The coordinates are the columns named `x`, `y` and
//! `z` (any case); every other named column is one point field. A file with
//! neither header nor spec takes its first three columns as x, y, z and
//! names the rest `column_4`, `column_5`, … (with a note).
//!
//! Every row must have as many values as the first data row; errors name the
//! line and the column.

use tet_mesh::{Field, SourceMesh};

use crate::cursor::{clip, parse_f64, TextCursor};
use crate::{FormatError, Location};

#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum Separator {
    Comma,
    Semicolon,
    Tab,
    Whitespace,
}

impl Separator {
    fn detect(line: &str) -> Separator {
        if line.contains(',') {
            Separator::Comma
        } else if line.contains(';') {
            Separator::Semicolon
        } else if line.contains('\t') {
            Separator::Tab
        } else {
            Separator::Whitespace
        }
    }

    fn split<'a>(self, line: &'a str, out: &mut Vec<&'a str>) {
        out.clear();
        let unquote = |s: &'a str| {
            let s = s.trim();
            s.strip_prefix('"').and_then(|t| t.strip_suffix('"')).unwrap_or(s)
        };
        match self {
            Separator::Comma => out.extend(line.split(',').map(unquote)),
            Separator::Semicolon => out.extend(line.split(';').map(unquote)),
            Separator::Tab => out.extend(line.split('\t').map(unquote)),
            Separator::Whitespace => out.extend(line.split_ascii_whitespace().map(unquote)),
        }
    }

    fn describe(self) -> &'static str {
        match self {
            Separator::Comma => "CSV (comma-separated)",
            Separator::Semicolon => "CSV (semicolon-separated)",
            Separator::Tab => "CSV (tab-separated)",
            Separator::Whitespace => "CSV (whitespace-separated)",
        }
    }
}

/// Whether a column name means "do not read this column".
fn is_skip(name: &str) -> bool {
    matches!(name.trim(), "" | "_" | "-")
}

/// Quick content test used by format detection: true when the first data
/// line of `head` (text) has a header naming x, y and z, or at least three
/// numbers of which one is not an integer. ASCII PLOT3D files, which share
/// the `.xyz` extension, start with integer dimensions instead.
pub fn looks_like_point_table(head: &[u8]) -> bool {
    if head.iter().take(4096).any(|&b| b == 0) {
        return false;
    }
    let text = String::from_utf8_lossy(head);
    let Some(line) = text
        .lines()
        .map(|l| l.split('#').next().unwrap_or("").trim().trim_start_matches('\u{feff}'))
        .find(|l| !l.is_empty())
    else {
        return false;
    };
    let mut tok = Vec::new();
    Separator::detect(line).split(line, &mut tok);
    if tok.len() < 3 {
        return false;
    }
    if tok.iter().any(|t| parse_f64(t).is_none()) {
        let has = |c: &str| tok.iter().any(|t| t.eq_ignore_ascii_case(c));
        return has("x") && has("y") && has("z");
    }
    tok.iter().any(|t| t.parse::<i64>().is_err())
}

/// The next line holding data (comment and surrounding blanks removed).
fn next_data<'a>(t: &mut TextCursor<'a>) -> Option<(usize, &'a str)> {
    loop {
        let line_no = t.line();
        let line = t.line_str()?;
        let line = if line_no == 1 { line.trim_start_matches('\u{feff}') } else { line };
        let data = line.split('#').next().unwrap_or("").trim();
        if !data.is_empty() {
            return Some((line_no, data));
        }
    }
}

/// Rows past this many bytes are parsed in parallel chunks.
const PARALLEL_BYTES: usize = 1 << 20;

/// What a row's columns are: separator, count, names, and where each goes
/// (`sink`: 0–2 a coordinate, 3 + f field f, `None` skipped).
struct Table<'n> {
    sep: Separator,
    width: usize,
    names: &'n [String],
    sink: &'n [Option<usize>],
    fields: usize,
}

/// Parsed rows: points and each field's values.
struct Rows {
    points: Vec<[f64; 3]>,
    values: Vec<Vec<f64>>,
}

impl Rows {
    fn new(fields: usize) -> Rows {
        Rows { points: Vec::new(), values: vec![Vec::new(); fields] }
    }
}

impl Table<'_> {
    /// Parses data line `line` (number `line_no`) into `rows`.
    fn row<'a>(
        &self,
        line_no: usize,
        line: &'a str,
        rows: &mut Rows,
        cells: &mut Vec<&'a str>,
    ) -> Result<(), FormatError> {
        let at = Location::Line(line_no);
        self.sep.split(line, cells);
        if cells.len() != self.width {
            return Err(FormatError::new(at, format!("expected {} values, found {}", self.width, cells.len())));
        }
        let mut p = [0.0; 3];
        for (c, s) in cells.iter().enumerate() {
            let Some(dest) = self.sink[c] else { continue };
            let v = parse_f64(s).ok_or_else(|| {
                FormatError::new(
                    at,
                    format!("column '{}': expected a number, found '{}'", clip(&self.names[c]), clip(s)),
                )
            })?;
            if dest < 3 {
                p[dest] = v;
            } else {
                rows.values[dest - 3].push(v);
            }
        }
        rows.points.push(p);
        Ok(())
    }

    /// The rows of `text` (its first line numbered `first_line`) in about
    /// `chunks` pieces split at line ends, parsed in parallel, in order.
    fn rows_in_chunks(&self, text: &[u8], first_line: usize, chunks: usize) -> Vec<Result<Rows, FormatError>> {
        use rayon::prelude::*;
        let mut starts = vec![0];
        for k in 1..chunks.max(1) {
            let at = (text.len() * k / chunks).max(*starts.last().expect("one start"));
            match text[at..].iter().position(|&b| b == b'\n') {
                Some(nl) if at + nl + 1 < text.len() => starts.push(at + nl + 1),
                _ => break,
            }
        }
        starts.dedup();
        starts.push(text.len());
        let pieces: Vec<&[u8]> = starts.windows(2).map(|w| &text[w[0]..w[1]]).collect();
        let newlines: Vec<usize> = pieces.par_iter().map(|p| p.iter().filter(|&&b| b == b'\n').count()).collect();
        let firsts: Vec<usize> = newlines
            .iter()
            .scan(first_line, |line, n| {
                let first = *line;
                *line += n;
                Some(first)
            })
            .collect();
        pieces
            .par_iter()
            .zip(firsts)
            .map(|(piece, line)| {
                let mut t = TextCursor::starting_at_line(piece, line);
                let (mut rows, mut cells) = (Rows::new(self.fields), Vec::new());
                while let Some((line_no, line)) = next_data(&mut t) {
                    self.row(line_no, line, &mut rows, &mut cells)?;
                }
                Ok(rows)
            })
            .collect()
    }
}

/// Reads a point table; `columns` names the columns in order (see the
/// module documentation).
pub fn read(bytes: &[u8], columns: Option<&[String]>) -> Result<SourceMesh, FormatError> {
    let mut t = TextCursor::new(bytes);
    let (first_line, first) =
        next_data(&mut t).ok_or_else(|| FormatError::new(Location::Whole, "the point table has no data lines"))?;
    let sep = Separator::detect(first);
    let mut tok = Vec::new();
    sep.split(first, &mut tok);
    let width = tok.len();
    let header = tok.iter().any(|s| parse_f64(s).is_none());
    let mut notes = Vec::new();

    let names: Vec<String> = match (columns, header) {
        (Some(spec), _) => {
            if header {
                notes.push(format!("header line {first_line} replaced by --columns"));
            }
            if spec.len() > width {
                return Err(FormatError::new(
                    Location::Line(first_line),
                    format!("--columns names {} columns but the line has {width}", spec.len()),
                ));
            }
            if spec.len() < width {
                notes.push(format!("columns {} to {width} are not named by --columns; ignored", spec.len() + 1));
            }
            let mut n: Vec<String> = spec.iter().map(|s| s.trim().to_string()).collect();
            n.resize(width, String::new());
            n
        }
        (None, true) => tok.iter().map(|s| s.to_string()).collect(),
        (None, false) => {
            if width < 3 {
                return Err(FormatError::new(
                    Location::Line(first_line),
                    format!("a point needs x, y and z but the line has {width} values; pass --columns"),
                ));
            }
            if width > 3 {
                notes.push(format!("no header: columns taken as x, y, z, column_4 … column_{width}"));
            }
            (0..width)
                .map(|k| if k < 3 { ["x", "y", "z"][k].to_string() } else { format!("column_{}", k + 1) })
                .collect()
        }
    };

    let mut coord = [None; 3];
    let mut field_names: Vec<&str> = Vec::new();
    // Per column: Some(0..3) a coordinate, Some(3 + f) field f, None skipped.
    let mut sink: Vec<Option<usize>> = Vec::with_capacity(width);
    for (c, name) in names.iter().enumerate() {
        if is_skip(name) {
            sink.push(None);
            continue;
        }
        if names[..c].iter().any(|n| !is_skip(n) && n.eq_ignore_ascii_case(name)) {
            return Err(FormatError::new(
                Location::Line(first_line),
                format!("column name '{}' appears twice", clip(name)),
            ));
        }
        match ["x", "y", "z"].iter().position(|a| a.eq_ignore_ascii_case(name)) {
            Some(k) => {
                coord[k] = Some(c);
                sink.push(Some(k));
            }
            None => {
                field_names.push(name);
                sink.push(Some(3 + field_names.len() - 1));
            }
        }
    }
    if let Some(k) = coord.iter().position(Option::is_none) {
        let listed: Vec<&str> = names.iter().filter(|n| !is_skip(n)).map(String::as_str).collect();
        return Err(FormatError::new(
            Location::Line(first_line),
            format!(
                "no column named '{}' (columns: {}); name them with --columns",
                ["x", "y", "z"][k],
                clip(&listed.join(", "))
            ),
        ));
    }

    let table = Table { sep, width, names: &names, sink: &sink, fields: field_names.len() };
    let mut rows = Rows::new(field_names.len());
    if !header {
        table.row(first_line, first, &mut rows, &mut tok)?;
    }
    // The rest in chunks of whole lines, parsed in parallel; each chunk
    // stops at its first error and the earliest chunk's is reported, so the
    // error (and every value) is the serial parse's.
    let rest = t.rest();
    let chunks = if rest.len() < PARALLEL_BYTES { 1 } else { rayon::current_num_threads() * 4 };
    for part in table.rows_in_chunks(rest, t.line(), chunks) {
        let part = part?;
        rows.points.extend(part.points);
        for (v, p) in rows.values.iter_mut().zip(part.values) {
            v.extend(p);
        }
    }
    let Rows { points, values } = rows;
    if points.is_empty() {
        return Err(FormatError::new(Location::Line(first_line), "the point table has a header but no rows"));
    }
    if points.len() > u32::MAX as usize {
        return Err(FormatError::new(Location::Whole, format!("{} points are more than tetkit indexes", points.len())));
    }
    let point_fields = field_names.iter().zip(values).map(|(n, v)| Field::new(*n, 1, v)).collect();
    let mesh = SourceMesh { points, point_fields, notes, format: sep.describe().to_string(), ..Default::default() };
    mesh.check().map_err(|e| FormatError::new(Location::Whole, e))?;
    Ok(mesh)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn header_any_case_and_separators() {
        for (text, fmt) in [
            (&b"# comment\nX,Value,y,Z\n1,10,2,3\n4,20,5,6 # trailing\n"[..], "CSV (comma-separated)"),
            (b"\xef\xbb\xbfx;Value;y;z\n1;10;2;3\n\n4;20;5;6\n", "CSV (semicolon-separated)"),
            (b"x\tValue\ty\tz\n1\t10\t2\t3\n4\t20\t5\t6\n", "CSV (tab-separated)"),
            (b"\"x\"  \"Value\" y z\n1 10 2 3\n  4   20 5 6\n", "CSV (whitespace-separated)"),
        ] {
            let m = read(text, None).unwrap_or_else(|e| panic!("{fmt}: {e}"));
            assert_eq!(m.points, vec![[1.0, 2.0, 3.0], [4.0, 5.0, 6.0]], "{fmt}");
            assert_eq!(m.point_fields[0].name, "Value");
            assert_eq!(m.point_fields[0].values, vec![10.0, 20.0]);
            assert_eq!(m.format, fmt);
        }
    }

    #[test]
    fn column_spec_replaces_header_and_skips() {
        let spec: Vec<String> = ["value", "_", "x", "y", "z"].iter().map(|s| s.to_string()).collect();
        let m = read(b"a b c d e\n7 0 1 2 3\n", Some(&spec)).unwrap();
        assert_eq!(m.points, vec![[1.0, 2.0, 3.0]]);
        assert_eq!(m.point_fields.len(), 1);
        assert_eq!(m.point_fields[0].values, vec![7.0]);
        let m = read(b"1 2 3 4\n", None).unwrap();
        assert_eq!(m.point_fields[0].name, "column_4");
    }

    #[test]
    fn errors_name_the_line() {
        assert_eq!(read(b"x,y,z\n1,2,3\n1,2\n", None).unwrap_err().at, Location::Line(3));
        let e = read(b"x,y,z\n1,2,3\n\n1,2,oops\n", None).unwrap_err();
        assert_eq!(e.at, Location::Line(4));
        assert!(e.message.contains("'z'"), "{e}");
        assert!(read(b"a,b,c\n1,2,3\n", None).unwrap_err().message.contains("no column named 'x'"));
        assert!(read(b"1 2\n", None).is_err());
        assert!(read(b"x,y,z\n", None).is_err());
    }

    #[test]
    fn detection_heuristic() {
        assert!(looks_like_point_table(b"x y z value\n"));
        assert!(looks_like_point_table(b"# c\n0.5 1 2\n"));
        assert!(!looks_like_point_table(b"40 32 32\n0.5 0.25\n"));
        assert!(!looks_like_point_table(b"1\n40 32 32\n"));
    }

    /// A table past the parallel threshold (with comments, blank and CRLF
    /// lines) parses to the same points and fields as its rows one chunk
    /// at a time, and a bad row deep inside is reported at its own line
    /// whatever the chunking (the first of two).
    #[test]
    fn chunked_rows_equal_the_serial_parse() {
        let mut text = String::from("x,v,y,z\n");
        for i in 0..60_000 {
            let row = format!("{},{},{},{}", i as f64 * 0.5, i % 7, -(i as f64), i as f64 * 1e-3);
            text.push_str(&match i % 1000 {
                3 => format!("{row}\r\n"),
                5 => format!("\n# a comment\n{row}\n"),
                _ => format!("{row}\n"),
            });
        }
        assert!(text.len() > PARALLEL_BYTES);
        let m = read(text.as_bytes(), None).unwrap();
        assert_eq!(m.points.len(), 60_000);
        assert_eq!(m.points[59_999], [29_999.5, -59_999.0, 59.999]);
        assert_eq!(m.point_fields[0].values[13], 6.0);
        let (names, sink) = (["x", "v", "y", "z"].map(String::from), [Some(0), Some(3), Some(1), Some(2)]);
        let table = Table { sep: Separator::Comma, width: 4, names: &names, sink: &sink, fields: 1 };
        let body = &text.as_bytes()["x,v,y,z\n".len()..];
        for chunks in [1, 3, 7, 64] {
            let parts: Vec<Rows> = table.rows_in_chunks(body, 2, chunks).into_iter().map(Result::unwrap).collect();
            let points: Vec<[f64; 3]> = parts.iter().flat_map(|p| p.points.iter().copied()).collect();
            let values: Vec<f64> = parts.iter().flat_map(|p| p.values[0].iter().copied()).collect();
            assert_eq!((points, values), (m.points.clone(), m.point_fields[0].values.clone()), "{chunks} chunks");
        }
        let bad = text.replacen("\n10000,1,", "\n10000,six,", 1).replacen("\n20000,2,", "\n20000,,2,", 1);
        let line = bad.lines().position(|l| l.contains("six")).unwrap() + 1;
        assert_eq!(read(bad.as_bytes(), None).unwrap_err().at, Location::Line(line));
        for chunks in [1, 5, 64] {
            let first_error = table
                .rows_in_chunks(&bad.as_bytes()["x,v,y,z\n".len()..], 2, chunks)
                .into_iter()
                .find_map(Result::err)
                .unwrap();
            assert_eq!(first_error.at, Location::Line(line), "{chunks} chunks");
        }
    }
}
