//! ASPRS LAS 1.0–1.4 lidar point clouds (point data formats 0–10), and LAZ
//! (LASzip-compressed LAS) through the pure-Rust `laz` crate.
//!
//! Coordinates are the stored integers times the header's scale plus its
//! offset. Point fields: `intensity`, `elevation` (= z, so it can be chosen
//! as the scalar), `classification`, `return_number`, and where the point
//! format has them `gps_time`, `red`, `green`, `blue` and `luminance`
//! (Rec. 709: 0.2126 R + 0.7152 G + 0.0722 B, on the stored 16-bit values).
//!
//! LAZ is recognised by bit 7 (or 6, older LASzip) of the point format byte
//! or by the `laszip encoded` VLR; its points are decompressed to the plain
//! LAS record layout and then decoded like LAS. A LAZ file that declares more
//! than [`MAX_LAZ_RATIO`] times its compressed size in points is refused
//! before anything is allocated, and a panic inside the LASzip decoder on
//! corrupt data is caught and reported as this file's error.

use std::io::Cursor;

use tet_mesh::{Field, SourceMesh};

use crate::cursor::ByteCursor;
use crate::{FormatError, Location};

/// Most decompressed bytes per compressed byte a LAZ file may declare. Real
/// lidar compresses 5–15×; a file claiming over a thousand is hostile (a
/// bomb) or corrupt.
pub const MAX_LAZ_RATIO: usize = 1024;

const LASZIP_USER_ID: &[u8] = b"laszip encoded";
const LASZIP_RECORD_ID: u16 = 22204;

/// Minimum record length of each point data format (0–10).
const MIN_RECORD_LEN: [usize; 11] = [20, 28, 26, 34, 57, 63, 30, 36, 38, 59, 67];

/// Where a point format keeps its optional attributes (byte offsets in a record).
struct Layout {
    /// Formats 6–10 use the 1.4 layout: 4-bit return number, full-byte
    /// classification at 16, GPS time at 22.
    extended: bool,
    gps: Option<usize>,
    rgb: Option<usize>,
}

fn layout(format: u8) -> Layout {
    let (gps, rgb) = match format {
        0 => (None, None),
        1 | 4 => (Some(20), None),
        2 => (None, Some(20)),
        3 | 5 => (Some(20), Some(28)),
        6 | 9 => (Some(22), None),
        _ => (Some(22), Some(30)), // 7, 8, 10
    };
    Layout { extended: format >= 6, gps, rgb }
}

fn le_u16(b: &[u8], at: usize) -> u16 {
    u16::from_le_bytes([b[at], b[at + 1]])
}

fn le_i32(b: &[u8], at: usize) -> i32 {
    i32::from_le_bytes(b[at..at + 4].try_into().expect("4 bytes"))
}

fn le_f64(b: &[u8], at: usize) -> f64 {
    f64::from_le_bytes(b[at..at + 8].try_into().expect("8 bytes"))
}

/// Header facts the point decoding needs.
struct Header {
    version: (u8, u8),
    header_size: usize,
    point_offset: usize,
    num_vlrs: u32,
    format_byte: u8,
    record_len: usize,
    count: u64,
    scale: [f64; 3],
    offset: [f64; 3],
}

fn parse_header(bytes: &[u8]) -> Result<Header, FormatError> {
    let mut c = ByteCursor::new(bytes);
    let h = c.take(227, "LAS header (227 bytes)")?;
    if &h[0..4] != b"LASF" {
        return Err(FormatError::new(Location::Byte(0), "not a LAS file: it does not start with 'LASF'"));
    }
    let version = (h[24], h[25]);
    if version.0 != 1 || version.1 > 4 {
        return Err(FormatError::new(
            Location::Byte(24),
            format!("LAS version {}.{} is not supported (1.0 to 1.4 are)", version.0, version.1),
        ));
    }
    let header_size = le_u16(h, 94) as usize;
    let point_offset = u32::from_le_bytes(h[96..100].try_into().expect("4 bytes")) as usize;
    let num_vlrs = u32::from_le_bytes(h[100..104].try_into().expect("4 bytes"));
    let format_byte = h[104];
    let record_len = le_u16(h, 105) as usize;
    let legacy_count = u32::from_le_bytes(h[107..111].try_into().expect("4 bytes"));
    if header_size < 227 || header_size > bytes.len() {
        return Err(FormatError::new(
            Location::Byte(94),
            format!("header size {header_size} is below 227 or past the end of the {}-byte file", bytes.len()),
        ));
    }
    if point_offset < header_size || point_offset > bytes.len() {
        return Err(FormatError::new(
            Location::Byte(96),
            format!(
                "offset to point data {point_offset} lies outside the file (header {header_size} bytes, file {} bytes)",
                bytes.len()
            ),
        ));
    }
    // LAS 1.4 keeps a 64-bit count at 247; the legacy 32-bit one is 0 for
    // formats 6–10 and for more than 2^32 - 1 points.
    let count = if version.1 >= 4 && header_size >= 375 {
        let wide = u64::from_le_bytes(bytes[247..255].try_into().expect("8 bytes"));
        if wide != 0 {
            wide
        } else {
            u64::from(legacy_count)
        }
    } else {
        u64::from(legacy_count)
    };
    let mut scale = [0.0; 3];
    let mut offset = [0.0; 3];
    for k in 0..3 {
        scale[k] = le_f64(h, 131 + 8 * k);
        offset[k] = le_f64(h, 155 + 8 * k);
        if !scale[k].is_finite() || scale[k] == 0.0 || !offset[k].is_finite() {
            return Err(FormatError::new(
                Location::Byte(131 + 8 * k as u64),
                format!(
                    "{} scale {} / offset {} must be finite and the scale non-zero",
                    ["x", "y", "z"][k],
                    scale[k],
                    offset[k]
                ),
            ));
        }
    }
    Ok(Header { version, header_size, point_offset, num_vlrs, format_byte, record_len, count, scale, offset })
}

/// The payload of the `laszip encoded` VLR, if the file has one.
fn find_laszip_vlr<'a>(bytes: &'a [u8], h: &Header) -> Result<Option<&'a [u8]>, FormatError> {
    let mut c = ByteCursor::with_base(&bytes[h.header_size..h.point_offset], h.header_size as u64);
    for v in 0..h.num_vlrs {
        let at = c.location();
        let head = c.take(54, &format!("header of VLR {v}"))?;
        let user_id = &head[2..18];
        let record_id = le_u16(head, 18);
        let len = le_u16(head, 20) as usize;
        let payload = c.take(len, &format!("VLR {v} payload")).map_err(|e| FormatError::new(at, e.message))?;
        let name_end = user_id.iter().position(|&b| b == 0).unwrap_or(16);
        if &user_id[..name_end] == LASZIP_USER_ID && record_id == LASZIP_RECORD_ID {
            return Ok(Some(payload));
        }
    }
    Ok(None)
}

/// Decompresses the LAZ point records to their LAS layout.
fn decompress(bytes: &[u8], h: &Header, vlr_payload: &[u8], count: usize) -> Result<Vec<u8>, FormatError> {
    let at = Location::Byte(h.point_offset as u64);
    let vlr = laz::LazVlr::from_buffer(vlr_payload)
        .map_err(|e| FormatError::new(Location::Whole, format!("bad laszip VLR: {e}")))?;
    if vlr.items_size() != h.record_len as u64 {
        return Err(FormatError::new(
            Location::Byte(105),
            format!("laszip VLR describes {}-byte points, the header {}-byte ones", vlr.items_size(), h.record_len),
        ));
    }
    let compressed = bytes.len() - h.point_offset;
    let plain = count.checked_mul(h.record_len).filter(|&n| n <= compressed.saturating_mul(MAX_LAZ_RATIO)).ok_or_else(
        || {
            FormatError::new(
                at,
                format!(
                    "{count} points of {} bytes cannot come from {compressed} compressed bytes (over {MAX_LAZ_RATIO}×)",
                    h.record_len
                ),
            )
        },
    )?;
    let mut out = vec![0u8; plain];
    // The `laz` decoder asserts and indexes on values read from the stream,
    // so corrupt data can panic inside it; that panic is this file's error.
    // (It still prints the panic message; with panic = "abort" it aborts.)
    let run = || -> Result<(), FormatError> {
        let mut src = Cursor::new(bytes);
        src.set_position(h.point_offset as u64);
        let mut dec = laz::LasZipDecompressor::new(src, vlr)
            .map_err(|e| FormatError::new(at, format!("cannot start LAZ decompression: {e}")))?;
        dec.decompress_many(&mut out)
            .map_err(|e| FormatError::new(at, format!("LAZ point data is corrupt or truncated: {e}")))
    };
    std::panic::catch_unwind(std::panic::AssertUnwindSafe(run))
        .unwrap_or_else(|_| Err(FormatError::new(at, "LAZ point data is corrupt: the LASzip decoder failed")))?;
    Ok(out)
}

/// Reads a LAS or LAZ file into a point cloud with per-point fields.
pub fn read(bytes: &[u8]) -> Result<SourceMesh, FormatError> {
    let h = parse_header(bytes)?;
    let format = h.format_byte & 0x3f;
    let vlr = find_laszip_vlr(bytes, &h)?;
    let compressed = h.format_byte & 0xc0 != 0 || vlr.is_some();
    if format > 10 {
        return Err(FormatError::new(Location::Byte(104), format!("point data format {format} is not 0 to 10")));
    }
    let min_len = MIN_RECORD_LEN[format as usize];
    if h.record_len < min_len {
        return Err(FormatError::new(
            Location::Byte(105),
            format!("point record length {} is below the {min_len} bytes of point format {format}", h.record_len),
        ));
    }
    if h.count > u64::from(u32::MAX) {
        return Err(FormatError::new(Location::Byte(107), format!("{} points are more than tetkit indexes", h.count)));
    }
    let count = h.count as usize;

    let decompressed;
    let records: &[u8] = if compressed {
        let payload = vlr.ok_or_else(|| {
            FormatError::new(Location::Byte(104), "point format marks the file as LAZ but there is no laszip VLR")
        })?;
        decompressed = decompress(bytes, &h, payload, count)?;
        &decompressed
    } else {
        let mut c = ByteCursor::with_base(&bytes[h.point_offset..], h.point_offset as u64);
        c.take_array(count, h.record_len, &format!("point records ({count} × {} bytes)", h.record_len))?
    };

    let lay = layout(format);
    let mut points = Vec::with_capacity(count);
    let mut intensity = Vec::with_capacity(count);
    let mut elevation = Vec::with_capacity(count);
    let mut classification = Vec::with_capacity(count);
    let mut return_number = Vec::with_capacity(count);
    let mut gps_time = Vec::with_capacity(if lay.gps.is_some() { count } else { 0 });
    let n_rgb = if lay.rgb.is_some() { count } else { 0 };
    let (mut red, mut green, mut blue, mut luminance) =
        (Vec::with_capacity(n_rgb), Vec::with_capacity(n_rgb), Vec::with_capacity(n_rgb), Vec::with_capacity(n_rgb));
    for r in records.chunks_exact(h.record_len) {
        let mut p = [0.0; 3];
        for (k, v) in p.iter_mut().enumerate() {
            *v = f64::from(le_i32(r, 4 * k)) * h.scale[k] + h.offset[k];
        }
        points.push(p);
        elevation.push(p[2]);
        intensity.push(f64::from(le_u16(r, 12)));
        if lay.extended {
            return_number.push(f64::from(r[14] & 0x0f));
            classification.push(f64::from(r[16]));
        } else {
            return_number.push(f64::from(r[14] & 0x07));
            classification.push(f64::from(r[15] & 0x1f));
        }
        if let Some(g) = lay.gps {
            gps_time.push(le_f64(r, g));
        }
        if let Some(c) = lay.rgb {
            let (rv, gv, bv) = (f64::from(le_u16(r, c)), f64::from(le_u16(r, c + 2)), f64::from(le_u16(r, c + 4)));
            red.push(rv);
            green.push(gv);
            blue.push(bv);
            luminance.push(0.2126 * rv + 0.7152 * gv + 0.0722 * bv);
        }
    }

    let mut point_fields = vec![
        Field::new("intensity", 1, intensity),
        Field::new("elevation", 1, elevation),
        Field::new("classification", 1, classification),
        Field::new("return_number", 1, return_number),
    ];
    if lay.gps.is_some() {
        point_fields.push(Field::new("gps_time", 1, gps_time));
    }
    if lay.rgb.is_some() {
        point_fields.push(Field::new("red", 1, red));
        point_fields.push(Field::new("green", 1, green));
        point_fields.push(Field::new("blue", 1, blue));
        point_fields.push(Field::new("luminance", 1, luminance));
    }
    let mut notes = Vec::new();
    if h.record_len > min_len {
        notes.push(format!("{} extra bytes per point record not read", h.record_len - min_len));
    }
    let name = if compressed { "LAZ" } else { "LAS" };
    let mesh = SourceMesh {
        points,
        point_fields,
        notes,
        format: format!("{name} {}.{} (point format {format})", h.version.0, h.version.1),
        ..Default::default()
    };
    mesh.check().map_err(|e| FormatError::new(Location::Whole, e))?;
    Ok(mesh)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A LAS 1.2 header for `count` points of `format` with scale 0.01.
    fn header(format: u8, record_len: u16, count: u32) -> Vec<u8> {
        let mut h = vec![0u8; 227];
        h[0..4].copy_from_slice(b"LASF");
        h[24] = 1;
        h[25] = 2;
        h[94..96].copy_from_slice(&227u16.to_le_bytes());
        h[96..100].copy_from_slice(&227u32.to_le_bytes());
        h[104] = format;
        h[105..107].copy_from_slice(&record_len.to_le_bytes());
        h[107..111].copy_from_slice(&count.to_le_bytes());
        for k in 0..3 {
            h[131 + 8 * k..139 + 8 * k].copy_from_slice(&0.01f64.to_le_bytes());
            h[155 + 8 * k..163 + 8 * k].copy_from_slice(&(100.0 * k as f64).to_le_bytes());
        }
        h
    }

    #[test]
    fn format_0_scale_offset_and_fields() {
        let mut f = header(0, 20, 2);
        for (xyz, i, cls) in [([100i32, 200, 300], 7u16, 2u8), ([-100, 0, 5], 9, 0x21)] {
            for v in xyz {
                f.extend_from_slice(&v.to_le_bytes());
            }
            f.extend_from_slice(&i.to_le_bytes());
            f.push(0b0001_0010); // return 2 of 2
            f.push(cls);
            f.extend_from_slice(&[0, 0, 0, 0]);
        }
        let m = read(&f).unwrap();
        assert_eq!(m.points, vec![[1.0, 102.0, 203.0], [-1.0, 100.0, 200.05]]);
        let get = |n: &str| m.point_fields.iter().find(|f| f.name == n).unwrap().values.clone();
        assert_eq!(get("intensity"), vec![7.0, 9.0]);
        assert_eq!(get("classification"), vec![2.0, 1.0]); // high bits are flags
        assert_eq!(get("return_number"), vec![2.0, 2.0]);
        assert_eq!(get("elevation"), vec![203.0, 200.05]);
        assert_eq!(m.point_fields.len(), 4);
        assert_eq!(m.format, "LAS 1.2 (point format 0)");
    }

    #[test]
    fn hostile_headers_are_errors() {
        let mut huge = header(3, 34, u32::MAX);
        huge.extend_from_slice(&[0; 34]);
        assert!(read(&huge).unwrap_err().message.contains("truncated"));
        let mut short_rec = header(3, 20, 1);
        short_rec.extend_from_slice(&[0; 20]);
        assert!(read(&short_rec).unwrap_err().message.contains("below"));
        let mut bad_fmt = header(11, 40, 1);
        bad_fmt.extend_from_slice(&[0; 40]);
        assert!(read(&bad_fmt).is_err());
        let mut laz_no_vlr = header(0x83, 34, 1);
        laz_no_vlr.extend_from_slice(&[0; 34]);
        assert!(read(&laz_no_vlr).unwrap_err().message.contains("laszip VLR"));
        let mut vlrs = header(0, 20, 0);
        vlrs[100..104].copy_from_slice(&1000u32.to_le_bytes());
        assert!(read(&vlrs).is_err());
        let mut zero_scale = header(0, 20, 0);
        zero_scale[131..139].copy_from_slice(&0.0f64.to_le_bytes());
        assert!(read(&zero_scale).is_err());
    }
}
