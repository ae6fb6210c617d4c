//! Raw bricks of voxels: a header-less (or fixed-size-header) array of
//! scalars whose shape, type and byte order come from the caller.
//!
//! The voxels become the points of one structured block (i fastest), and
//! their values one point field.

use crate::cursor::{decode_to_f64, ByteCursor, Endian, ScalarType};
use crate::{FormatError, Location};
use tet_mesh::{Block, Field, SourceMesh};

/// Everything a raw file does not say about itself.
#[derive(Debug, Clone, PartialEq)]
pub struct RawSpec {
    /// Samples along i, j, k (i fastest in the file).
    pub dims: [usize; 3],
    pub scalar_type: ScalarType,
    pub endian: Endian,
    pub spacing: [f64; 3],
    pub origin: [f64; 3],
    /// Bytes to skip before the first sample.
    pub header_bytes: usize,
    /// Name of the produced point field.
    pub name: String,
}

/// Reads a raw volume. A file shorter than `header_bytes` plus the samples
/// is an error stating expected and actual sizes; extra bytes after the
/// samples are ignored with a note.
pub fn read(bytes: &[u8], spec: &RawSpec) -> Result<SourceMesh, FormatError> {
    let count = checked_count(spec.dims)
        .ok_or_else(|| FormatError::new(Location::Whole, format!("dimensions {:?} overflow", spec.dims)))?;
    if count == 0 {
        return Err(FormatError::new(
            Location::Whole,
            format!("dimensions {:?} are empty; every dimension must be at least 1", spec.dims),
        ));
    }
    let expected = count
        .checked_mul(spec.scalar_type.size())
        .and_then(|n| n.checked_add(spec.header_bytes))
        .ok_or_else(|| FormatError::new(Location::Whole, "expected file size overflows"))?;
    if bytes.len() < expected {
        return Err(FormatError::new(
            Location::Byte(bytes.len() as u64),
            format!(
                "raw file too short: {} header bytes + {count} samples × {} bytes = {expected} bytes expected, file has {}",
                spec.header_bytes,
                spec.scalar_type.size(),
                bytes.len()
            ),
        ));
    }
    let mut cur = ByteCursor::new(bytes);
    cur.seek(spec.header_bytes)?;
    let data = cur.take_array(count, spec.scalar_type.size(), "voxel data")?;
    let mut values = Vec::new();
    decode_to_f64(data, spec.scalar_type, spec.endian, &mut values);

    let axes = [[spec.spacing[0], 0.0, 0.0], [0.0, spec.spacing[1], 0.0], [0.0, 0.0, spec.spacing[2]]];
    let mut mesh = SourceMesh {
        points: grid_points(spec.dims, spec.origin, axes),
        blocks: vec![Block::Structured { dims: spec.dims, first_point: 0 }],
        point_fields: vec![Field::new(spec.name.clone(), 1, values)],
        format: "raw volume".to_string(),
        ..Default::default()
    };
    if bytes.len() > expected {
        mesh.notes
            .push(format!("raw file has {} bytes after the expected {expected}; ignored", bytes.len() - expected));
    }
    mesh.check().map_err(|e| FormatError::new(Location::Whole, e))?;
    Ok(mesh)
}

/// Accepts the usual spellings of sample types: `u8`/`uint8`/`uchar`,
/// `i16`/`int16`/`short`, `f32`/`float32`/`float`, `f64`/`double`, ….
pub fn parse_scalar_type(s: &str) -> Option<ScalarType> {
    Some(match s.trim().to_ascii_lowercase().as_str() {
        "i8" | "int8" | "char" | "schar" | "signed char" | "int8_t" => ScalarType::I8,
        "u8" | "uint8" | "uchar" | "unsigned char" | "byte" | "uint8_t" => ScalarType::U8,
        "i16" | "int16" | "short" | "int16_t" => ScalarType::I16,
        "u16" | "uint16" | "ushort" | "unsigned short" | "uint16_t" => ScalarType::U16,
        "i32" | "int32" | "int" | "int32_t" => ScalarType::I32,
        "u32" | "uint32" | "uint" | "unsigned int" | "uint32_t" => ScalarType::U32,
        "i64" | "int64" | "long long" | "longlong" | "int64_t" => ScalarType::I64,
        "u64" | "uint64" | "ulonglong" | "unsigned long long" | "uint64_t" => ScalarType::U64,
        "f32" | "float32" | "float" | "single" => ScalarType::F32,
        "f64" | "float64" | "double" => ScalarType::F64,
        _ => return None,
    })
}

/// Product of the dimensions, `None` on overflow.
pub(crate) fn checked_count(dims: [usize; 3]) -> Option<usize> {
    dims[0].checked_mul(dims[1])?.checked_mul(dims[2])
}

/// Points of a regular lattice, i fastest: `origin + i·axes[0] + j·axes[1] +
/// k·axes[2]`. The caller has already checked that the data backing the
/// lattice is present, which bounds the allocation by the input size.
pub(crate) fn grid_points(dims: [usize; 3], origin: [f64; 3], axes: [[f64; 3]; 3]) -> Vec<[f64; 3]> {
    let mut points = Vec::with_capacity(checked_count(dims).unwrap_or(0));
    for k in 0..dims[2] {
        let kf = k as f64;
        for j in 0..dims[1] {
            let jf = j as f64;
            let row: [f64; 3] = std::array::from_fn(|c| origin[c] + jf * axes[1][c] + kf * axes[2][c]);
            points.extend((0..dims[0]).map(|i| {
                let f = i as f64;
                [row[0] + f * axes[0][0], row[1] + f * axes[0][1], row[2] + f * axes[0][2]]
            }));
        }
    }
    points
}

#[cfg(test)]
mod tests {
    use super::*;

    fn spec(dims: [usize; 3], ty: ScalarType) -> RawSpec {
        RawSpec {
            dims,
            scalar_type: ty,
            endian: Endian::Big,
            spacing: [1.0, 2.0, 3.0],
            origin: [10.0, 0.0, 0.0],
            header_bytes: 2,
            name: "v".into(),
        }
    }

    #[test]
    fn reads_big_endian_u16_with_header() {
        let mut b = vec![0xff, 0xff];
        for v in 0u16..8 {
            b.extend(v.to_be_bytes());
        }
        let m = read(&b, &spec([2, 2, 2], ScalarType::U16)).unwrap();
        assert_eq!(m.point_fields[0].values, (0..8).map(f64::from).collect::<Vec<_>>());
        assert_eq!(m.points[7], [11.0, 2.0, 3.0]);
        assert_eq!(m.num_cells(), 1);
    }

    #[test]
    fn short_file_says_expected_and_actual() {
        let e = read(&[0u8; 10], &spec([2, 2, 2], ScalarType::U16)).unwrap_err();
        assert!(e.message.contains("18 bytes expected, file has 10"), "{}", e.message);
        let e = read(&[0u8; 10], &spec([usize::MAX, 2, 2], ScalarType::U16)).unwrap_err();
        assert!(e.message.contains("overflow"), "{}", e.message);
        assert!(read(&[0u8; 10], &spec([0, 2, 2], ScalarType::U8)).is_err());
    }

    #[test]
    fn scalar_type_spellings() {
        assert_eq!(parse_scalar_type("uint8"), Some(ScalarType::U8));
        assert_eq!(parse_scalar_type("Float"), Some(ScalarType::F32));
        assert_eq!(parse_scalar_type("double"), Some(ScalarType::F64));
        assert_eq!(parse_scalar_type("i64"), Some(ScalarType::I64));
        assert_eq!(parse_scalar_type("int7"), None);
    }
}
