//! PLOT3D binary grid (XYZ) files with an optional Q solution file.
//!
//! Supported: 3D grids, single or multi-grid, single or double precision,
//! either byte order, with or without Fortran record markers, with or
//! without IBLANK, "whole" or "planes" layout. Every setting left `None` in
//! [`Plot3dOptions`] is auto-detected the way VTK's
//! `vtkMultiBlockPLOT3DReader` does it: each combination of settings is tried
//! and the one whose expected file size matches the actual size wins.
//! Not supported: ASCII PLOT3D, 2D grids, function files, OVERFLOW-style Q
//! files with extra variables.
//!
//! The Q file is read with the grid's byte order, record markers and
//! multi-grid setting; its precision is detected separately (some codes
//! write a double Q next to a single-precision grid). Derived fields follow
//! VTK's formulas (functions 110 pressure, 120 temperature, 112 Mach, 200
//! velocity), including its treatment of zero density (taken as 1).

use crate::cursor::{decode_to_f64, ByteCursor, Endian, ScalarType};
use crate::{FormatError, Location};
use tet_mesh::source::{Block, Field};
use tet_mesh::SourceMesh;

/// How to read a PLOT3D file; `None` means "detect from the file".
#[derive(Debug, Clone, PartialEq)]
pub struct Plot3dOptions {
    pub byte_order: Option<Endian>,
    /// Fortran unformatted files wrap every record in 4-byte length markers.
    pub record_markers: Option<bool>,
    /// The file starts with a grid count.
    pub multi_grid: Option<bool>,
    /// The grid file carries an int32 IBLANK value per point.
    pub iblank: Option<bool>,
    /// 8-byte floats instead of 4-byte floats.
    pub double_precision: Option<bool>,
    /// "Planes" layout: for each k, the x, y, z (and IBLANK) planes, each
    /// plane a separate record when record markers are present. Cannot be
    /// detected reliably, so it is an explicit choice.
    pub planes: bool,
    /// Ratio of specific heats used for the derived quantities.
    pub gamma: f64,
    /// Gas constant R for temperature T = p / (ρ R); 1.0 as in VTK.
    pub gas_constant: f64,
}

impl Default for Plot3dOptions {
    fn default() -> Self {
        Plot3dOptions {
            byte_order: None,
            record_markers: None,
            multi_grid: None,
            iblank: None,
            double_precision: None,
            planes: false,
            gamma: 1.4,
            gas_constant: 1.0,
        }
    }
}

/// One complete set of binary layout settings.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
struct Layout {
    endian: Endian,
    record_markers: bool,
    multi_grid: bool,
    iblank: bool,
    /// Bytes per float: 4 or 8.
    precision: usize,
    planes: bool,
}

impl Layout {
    fn describe(&self) -> String {
        format!(
            "{}, {}, {}, {}, {} precision{}",
            match self.endian {
                Endian::Big => "big-endian",
                Endian::Little => "little-endian",
            },
            if self.record_markers { "Fortran record markers" } else { "no record markers" },
            if self.multi_grid { "multi-grid" } else { "single grid" },
            if self.iblank { "IBLANK" } else { "no IBLANK" },
            if self.precision == 8 { "double" } else { "single" },
            if self.planes { ", planes layout" } else { "" },
        )
    }

    fn float_type(&self) -> ScalarType {
        if self.precision == 8 {
            ScalarType::F64
        } else {
            ScalarType::F32
        }
    }

    fn marker_bytes(&self) -> usize {
        if self.record_markers {
            8
        } else {
            0
        }
    }
}

/// The grid header as one layout reads it.
#[derive(Debug, Clone)]
struct GridHeader {
    dims: Vec<[usize; 3]>,
    /// Offset of the first grid's data (its leading record marker, if any).
    data_start: usize,
}

/// Reads a PLOT3D grid file and, when given, its Q solution file.
///
/// Errors located in the Q file are marked with [`FormatError::companion`].
pub fn read(xyz: &[u8], q: Option<&[u8]>, opts: &Plot3dOptions) -> Result<SourceMesh, FormatError> {
    let mut notes = Vec::new();
    let (layout, header, expected) = detect_grid_layout(xyz, opts)?;
    if expected < xyz.len() {
        notes.push(format!(
            "grid file has {} bytes after the expected {} bytes of data; ignored",
            xyz.len() - expected,
            expected
        ));
    }

    let total_points = header
        .dims
        .iter()
        .try_fold(0usize, |acc, d| acc.checked_add(d[0] * d[1] * d[2]))
        .ok_or_else(|| FormatError::new(Location::Whole, "total point count overflows"))?;
    let mut mesh = SourceMesh { format: format!("PLOT3D ({})", layout.describe()), ..Default::default() };
    // Bounded: detection checked that the file holds every grid's data.
    mesh.points.reserve(total_points);
    let mut blanked: Option<Vec<bool>> = if layout.iblank { Some(Vec::with_capacity(total_points)) } else { None };
    let mut unusual_iblank = 0usize;

    let mut cur = ByteCursor::new(xyz);
    cur.seek(header.data_start)?;
    let mut coords: [Vec<f64>; 3] = [Vec::new(), Vec::new(), Vec::new()];
    let mut iblank_values: Vec<f64> = Vec::new();
    for (g, dims) in header.dims.iter().enumerate() {
        let npts = dims[0] * dims[1] * dims[2];
        let plane = dims[0] * dims[1];
        for c in coords.iter_mut() {
            c.clear();
            c.reserve(npts);
        }
        iblank_values.clear();
        // Each record is either the whole grid or one k plane.
        let (records, per_record) = if layout.planes { (dims[2], plane) } else { (1, npts) };
        let record_len = per_record * (3 * layout.precision + if layout.iblank { 4 } else { 0 });
        for _ in 0..records {
            let what = format!("grid {g} coordinates");
            open_record(&mut cur, &layout, record_len, &what)?;
            for c in coords.iter_mut() {
                let raw = cur.take_array(per_record, layout.precision, &what)?;
                decode_to_f64(raw, layout.float_type(), layout.endian, c);
            }
            if layout.iblank {
                let raw = cur.take_array(per_record, 4, &format!("grid {g} IBLANK"))?;
                decode_to_f64(raw, ScalarType::I32, layout.endian, &mut iblank_values);
            }
            close_record(&mut cur, &layout, record_len, &what)?;
        }
        let first_point = mesh.points.len();
        mesh.points.extend(coords[0].iter().zip(&coords[1]).zip(&coords[2]).map(|((&x, &y), &z)| [x, y, z]));
        if let Some(bl) = blanked.as_mut() {
            unusual_iblank += iblank_values.iter().filter(|&&v| v != 0.0 && v != 1.0).count();
            bl.extend(iblank_values.iter().map(|&v| v == 0.0));
        }
        mesh.blocks.push(Block::Structured { dims: *dims, first_point });
    }
    if let Some(bl) = &blanked {
        let n = bl.iter().filter(|&&b| b).count();
        let mut note = format!("IBLANK: {n} of {} points blanked (IBLANK = 0)", bl.len());
        if unusual_iblank > 0 {
            note.push_str(&format!(
                "; {unusual_iblank} points carry other values (overset/fringe codes), kept as visible"
            ));
        }
        notes.push(note);
    }
    mesh.point_blanked = blanked;

    if let Some(qbytes) = q {
        read_q(qbytes, &layout, &header.dims, opts, &mut mesh, &mut notes).map_err(FormatError::companion)?;
    }
    if header.dims.len() > 1 {
        notes.insert(0, format!("{} grids, one structured block each", header.dims.len()));
    }
    mesh.notes = notes;
    mesh.check().map_err(|e| FormatError::new(Location::Whole, e))?;
    Ok(mesh)
}

/// Reads a leading record marker and checks it against the record length.
fn open_record(cur: &mut ByteCursor, layout: &Layout, len: usize, what: &str) -> Result<(), FormatError> {
    record_marker(cur, layout, len, &format!("before {what}"))
}

/// Reads a trailing record marker and checks it against the record length.
fn close_record(cur: &mut ByteCursor, layout: &Layout, len: usize, what: &str) -> Result<(), FormatError> {
    record_marker(cur, layout, len, &format!("after {what}"))
}

/// Where the layout has record markers, reads one (`where_` says which:
/// "before grid count") and checks that it says `len` bytes.
fn record_marker(cur: &mut ByteCursor, layout: &Layout, len: usize, where_: &str) -> Result<(), FormatError> {
    if layout.record_markers {
        let at = cur.location();
        let m = cur.u32(layout.endian, &format!("record marker {where_}"))?;
        if m as usize != len {
            return Err(FormatError::new(at, format!("record marker {where_} says {m} bytes, expected {len}")));
        }
    }
    Ok(())
}

/// Reads the grid count (multi-grid) and the `ni nj nk` triples under one
/// layout. Only the header is looked at, so this is cheap to run for every
/// candidate layout.
fn parse_header(bytes: &[u8], layout: &Layout) -> Result<GridHeader, FormatError> {
    let mut cur = ByteCursor::new(bytes);
    let ngrids = if layout.multi_grid {
        open_record(&mut cur, layout, 4, "grid count")?;
        let at = cur.location();
        let n = cur.i32(layout.endian, "grid count")?;
        if n <= 0 {
            return Err(FormatError::new(at, format!("grid count {n} is not positive")));
        }
        close_record(&mut cur, layout, 4, "grid count")?;
        n as usize
    } else {
        1
    };
    let dims_len = ngrids.checked_mul(12).ok_or_else(|| FormatError::new(Location::Byte(0), "grid count overflows"))?;
    if layout.record_markers {
        let at = cur.location();
        let m = cur.u32(layout.endian, "record marker before grid dimensions")? as usize;
        if Some(m) == ngrids.checked_mul(8) {
            return Err(FormatError::new(at, "this is a 2D PLOT3D grid (ni nj per grid); only 3D grids are supported"));
        }
        if m != dims_len {
            return Err(FormatError::new(
                at,
                format!("record marker before grid dimensions says {m} bytes, expected {dims_len}"),
            ));
        }
    }
    let at = cur.location();
    let raw = cur.take_array(ngrids, 12, "grid dimensions")?;
    let mut dims = Vec::with_capacity(ngrids);
    for (g, triple) in raw.chunks_exact(12).enumerate() {
        let mut d = [0usize; 3];
        for (axis, v) in triple.chunks_exact(4).enumerate() {
            let arr: [u8; 4] = v.try_into().expect("4 bytes");
            let n = match layout.endian {
                Endian::Big => i32::from_be_bytes(arr),
                Endian::Little => i32::from_le_bytes(arr),
            };
            if n <= 0 {
                return Err(FormatError::new(
                    at,
                    format!("grid {g} dimension {axis} is {n}; dimensions must be positive"),
                ));
            }
            d[axis] = n as usize;
        }
        d[0].checked_mul(d[1])
            .and_then(|p| p.checked_mul(d[2]))
            .ok_or_else(|| FormatError::new(at, format!("grid {g} dimensions {d:?} overflow")))?;
        dims.push(d);
    }
    close_record(&mut cur, layout, dims_len, "grid dimensions")?;
    Ok(GridHeader { dims, data_start: cur.offset() as usize })
}

/// Bytes the grid data of `header` takes under `layout`, markers included.
fn grid_data_len(header: &GridHeader, layout: &Layout) -> Option<usize> {
    let per_point = 3 * layout.precision + if layout.iblank { 4 } else { 0 };
    header.dims.iter().try_fold(header.data_start, |acc, d| {
        let npts = d[0].checked_mul(d[1])?.checked_mul(d[2])?;
        let records = if layout.planes { d[2] } else { 1 };
        let data = npts.checked_mul(per_point)?;
        acc.checked_add(data)?.checked_add(records.checked_mul(layout.marker_bytes())?)
    })
}

fn choices<T: Copy>(fixed: Option<T>, all: &[T]) -> Vec<T> {
    match fixed {
        Some(v) => vec![v],
        None => all.to_vec(),
    }
}

/// Tries every layout the options leave open and picks the one whose
/// expected size equals the file size. When none matches exactly, a layout
/// that leaves trailing bytes is accepted, preferring verified record
/// markers, then the fewest trailing bytes. Returns the layout, its header
/// and the expected size.
fn detect_grid_layout(bytes: &[u8], opts: &Plot3dOptions) -> Result<(Layout, GridHeader, usize), FormatError> {
    let mut exact = Vec::new();
    let mut shorter = Vec::new();
    let mut tried = Vec::new();
    let mut saw_2d = false;
    for endian in choices(opts.byte_order, &[Endian::Big, Endian::Little]) {
        for record_markers in choices(opts.record_markers, &[false, true]) {
            for multi_grid in choices(opts.multi_grid, &[false, true]) {
                for iblank in choices(opts.iblank, &[false, true]) {
                    for double in choices(opts.double_precision, &[false, true]) {
                        let layout = Layout {
                            endian,
                            record_markers,
                            multi_grid,
                            iblank,
                            precision: if double { 8 } else { 4 },
                            planes: opts.planes,
                        };
                        let header = match parse_header(bytes, &layout) {
                            Ok(h) => h,
                            Err(e) => {
                                saw_2d |= e.message.contains("2D PLOT3D");
                                tried.push(format!("[{}] header rejected: {}", layout.describe(), e.message));
                                continue;
                            }
                        };
                        let Some(expected) = grid_data_len(&header, &layout) else {
                            tried.push(format!("[{}] sizes overflow", layout.describe()));
                            continue;
                        };
                        // With markers, the first data record's marker must
                        // agree too; this rejects most wrong guesses early.
                        if layout.record_markers && !first_record_marker_ok(bytes, &header, &layout) {
                            tried.push(format!("[{}] first data record marker disagrees", layout.describe()));
                            continue;
                        }
                        tried.push(format!(
                            "[{}] dims {} → expects {expected} bytes",
                            layout.describe(),
                            dims_summary(&header.dims)
                        ));
                        if expected == bytes.len() {
                            exact.push((layout, header, expected));
                        } else if expected < bytes.len() {
                            shorter.push((layout, header, expected));
                        }
                    }
                }
            }
        }
    }
    let listing = || tried.join("; ");
    match exact.len() {
        1 => return Ok(exact.pop().expect("one")),
        0 => {}
        _ => {
            let names: Vec<String> =
                exact.iter().map(|(l, h, _)| format!("[{}] dims {}", l.describe(), dims_summary(&h.dims))).collect();
            return Err(FormatError::new(
                Location::Whole,
                format!(
                    "ambiguous PLOT3D grid layout: {} layouts match the file size {} exactly: {}; set the options explicitly",
                    exact.len(),
                    bytes.len(),
                    names.join("; ")
                ),
            ));
        }
    }
    if !shorter.is_empty() {
        shorter.sort_by_key(|(l, _, e)| (!l.record_markers, bytes.len() - e));
        let best_key = (!shorter[0].0.record_markers, bytes.len() - shorter[0].2);
        let ties = shorter.iter().filter(|(l, _, e)| (!l.record_markers, bytes.len() - e) == best_key).count();
        if ties == 1 {
            return Ok(shorter.swap_remove(0));
        }
    }
    saw_2d |= looks_like_2d_c_file(bytes);
    let hint = if saw_2d { " (the file looks like a 2D PLOT3D grid, which is not supported)" } else { "" };
    Err(FormatError::new(
        Location::Whole,
        format!("no PLOT3D layout matches the grid file size of {} bytes{hint}; tried: {}", bytes.len(), listing()),
    ))
}

/// True when the file is exactly a single-grid 2D PLOT3D file without
/// record markers (`ni nj`, then x and y, maybe IBLANK), to say so in the
/// error instead of only listing the 3D layouts that failed.
fn looks_like_2d_c_file(bytes: &[u8]) -> bool {
    let (Some(a), Some(b)) = (bytes.get(0..4), bytes.get(4..8)) else {
        return false;
    };
    [Endian::Big, Endian::Little].into_iter().any(|e| {
        let int = |s: &[u8]| {
            let arr: [u8; 4] = s.try_into().expect("4 bytes");
            match e {
                Endian::Big => i32::from_be_bytes(arr),
                Endian::Little => i32::from_le_bytes(arr),
            }
        };
        let (ni, nj) = (int(a), int(b));
        if ni <= 0 || nj <= 0 {
            return false;
        }
        let npts = ni as u64 * nj as u64;
        [8u64, 12, 16, 20]
            .iter()
            .any(|per_point| npts.checked_mul(*per_point).and_then(|d| d.checked_add(8)) == Some(bytes.len() as u64))
    })
}

fn first_record_marker_ok(bytes: &[u8], header: &GridHeader, layout: &Layout) -> bool {
    let Some(d) = header.dims.first() else {
        return false;
    };
    let per_record = if layout.planes { d[0] * d[1] } else { d[0] * d[1] * d[2] };
    let len = per_record * (3 * layout.precision + if layout.iblank { 4 } else { 0 });
    let mut cur = ByteCursor::new(bytes);
    cur.seek(header.data_start).is_ok() && open_record(&mut cur, layout, len, "grid").is_ok()
}

fn dims_summary(dims: &[[usize; 3]]) -> String {
    let shown: Vec<String> = dims.iter().take(4).map(|d| format!("{}×{}×{}", d[0], d[1], d[2])).collect();
    if dims.len() > 4 {
        format!("{} … ({} grids)", shown.join(", "), dims.len())
    } else {
        shown.join(", ")
    }
}

/// Reads the Q file for the grids already read into `mesh` and appends the
/// conserved and derived fields. Errors are about the Q file (the caller
/// marks them as companion errors).
fn read_q(
    bytes: &[u8],
    grid_layout: &Layout,
    dims: &[[usize; 3]],
    opts: &Plot3dOptions,
    mesh: &mut SourceMesh,
    notes: &mut Vec<String>,
) -> Result<(), FormatError> {
    // The Q header has the grid header's shape; IBLANK never appears in Q.
    let base = Layout { iblank: false, ..*grid_layout };
    let header = parse_header(bytes, &base)
        .map_err(|e| FormatError::new(e.at, format!("Q file header under the grid's layout: {}", e.message)))?;
    if header.dims != dims {
        return Err(FormatError::new(
            Location::Byte(0),
            format!(
                "Q file grid dimensions {} do not match the grid file's {}",
                dims_summary(&header.dims),
                dims_summary(dims)
            ),
        ));
    }
    let q_len = |layout: &Layout| -> Option<usize> {
        dims.iter().try_fold(header.data_start, |acc, d| {
            let npts = d[0] * d[1] * d[2];
            let records = if layout.planes { d[2] } else { 1 };
            let data = npts.checked_mul(5 * layout.precision)?.checked_add(4 * layout.precision)?;
            acc.checked_add(data)?.checked_add((records + 1) * layout.marker_bytes())
        })
    };
    let other = Layout { precision: if base.precision == 4 { 8 } else { 4 }, ..base };
    let (layout, expected) = match (q_len(&base), q_len(&other)) {
        (Some(e), _) if e == bytes.len() => (base, e),
        (_, Some(e)) if e == bytes.len() => {
            notes.push(format!(
                "Q file is {} precision, unlike the grid",
                if other.precision == 8 { "double" } else { "single" }
            ));
            (other, e)
        }
        (Some(e), _) if e < bytes.len() => (base, e),
        (e, _) => {
            return Err(FormatError::new(
                Location::Whole,
                format!(
                    "Q file has {} bytes, but the grids need {} bytes of solution data ({})",
                    bytes.len(),
                    e.map_or("an overflowing number of".to_string(), |v| v.to_string()),
                    base.describe()
                ),
            ))
        }
    };
    if expected < bytes.len() {
        notes.push(format!(
            "Q file has {} bytes after the expected {expected} bytes of data; ignored",
            bytes.len() - expected
        ));
    }

    let total = mesh.points.len();
    let mut density = Vec::with_capacity(total);
    let mut momentum = Vec::with_capacity(3 * total);
    let mut energy = Vec::with_capacity(total);
    let mut cur = ByteCursor::new(bytes);
    cur.seek(header.data_start)?;
    let mut vars: [Vec<f64>; 5] = Default::default();
    let mut conditions = Vec::new();
    for (g, d) in dims.iter().enumerate() {
        let npts = d[0] * d[1] * d[2];
        let what = format!("grid {g} flow conditions");
        open_record(&mut cur, &layout, 4 * layout.precision, &what)?;
        let mut cond = Vec::with_capacity(4);
        decode_to_f64(cur.take_array(4, layout.precision, &what)?, layout.float_type(), layout.endian, &mut cond);
        close_record(&mut cur, &layout, 4 * layout.precision, &what)?;
        conditions.push(cond);

        for v in vars.iter_mut() {
            v.clear();
            v.reserve(npts);
        }
        let (records, per_record) = if layout.planes { (d[2], d[0] * d[1]) } else { (1, npts) };
        let record_len = per_record * 5 * layout.precision;
        let what = format!("grid {g} solution");
        for _ in 0..records {
            open_record(&mut cur, &layout, record_len, &what)?;
            for v in vars.iter_mut() {
                let raw = cur.take_array(per_record, layout.precision, &what)?;
                decode_to_f64(raw, layout.float_type(), layout.endian, v);
            }
            close_record(&mut cur, &layout, record_len, &what)?;
        }
        density.extend_from_slice(&vars[0]);
        energy.extend_from_slice(&vars[4]);
        momentum.extend(vars[1].iter().zip(&vars[2]).zip(&vars[3]).flat_map(|((&x, &y), &z)| [x, y, z]));
    }
    for (g, c) in conditions.iter().enumerate() {
        if let [fsmach, alpha, re, time] = c[..] {
            let grid = if dims.len() > 1 { format!(" (grid {g})") } else { String::new() };
            notes.push(format!("Q flow conditions{grid}: fsmach {fsmach}, alpha {alpha}, re {re}, time {time}"));
        }
    }
    let derived = derive_flow_fields(&density, &momentum, &energy, opts.gamma, opts.gas_constant);
    if derived.zero_density > 0 {
        notes.push(format!(
            "{} points have zero density; derived fields there use density 1 (as VTK does)",
            derived.zero_density
        ));
    }
    if derived.negative_pressure > 0 {
        notes.push(format!(
            "{} points have negative pressure (stagnation energy below kinetic energy); Mach is NaN there",
            derived.negative_pressure
        ));
    }
    mesh.point_fields.push(Field::new("density", 1, density));
    mesh.point_fields.push(Field::new("momentum", 3, momentum));
    mesh.point_fields.push(Field::new("stagnation_energy", 1, energy));
    mesh.point_fields.push(Field::new("pressure", 1, derived.pressure));
    mesh.point_fields.push(Field::new("temperature", 1, derived.temperature));
    mesh.point_fields.push(Field::new("mach", 1, derived.mach));
    mesh.point_fields.push(Field::new("velocity", 3, derived.velocity));
    Ok(())
}

/// Quantities derived from the conserved variables, per point.
#[derive(Debug, Default)]
struct DerivedFields {
    pressure: Vec<f64>,
    temperature: Vec<f64>,
    mach: Vec<f64>,
    velocity: Vec<f64>,
    zero_density: usize,
    negative_pressure: usize,
}

/// VTK's formulas: v = m/ρ, p = (γ−1)(E − ½ρ|v|²), T = p/(ρR),
/// Mach = |v| / sqrt(γp/ρ). Zero density is replaced by 1 like VTK does, so
/// a zero never divides; negative pressure gives a NaN Mach number, which
/// validation reports later.
fn derive_flow_fields(density: &[f64], momentum: &[f64], energy: &[f64], gamma: f64, r: f64) -> DerivedFields {
    let n = density.len();
    let mut out = DerivedFields {
        pressure: Vec::with_capacity(n),
        temperature: Vec::with_capacity(n),
        mach: Vec::with_capacity(n),
        velocity: Vec::with_capacity(3 * n),
        ..Default::default()
    };
    for ((&rho_in, m), &e) in density.iter().zip(momentum.chunks_exact(3)).zip(energy) {
        let rho = if rho_in == 0.0 {
            out.zero_density += 1;
            1.0
        } else {
            rho_in
        };
        let inv = 1.0 / rho;
        let (u, v, w) = (m[0] * inv, m[1] * inv, m[2] * inv);
        let v2 = u * u + v * v + w * w;
        let p = (gamma - 1.0) * (e - 0.5 * rho * v2);
        if p < 0.0 {
            out.negative_pressure += 1;
        }
        let a2 = gamma * p * inv;
        out.pressure.push(p);
        out.temperature.push(p * inv / r);
        out.mach.push((v2 / a2).sqrt());
        out.velocity.extend_from_slice(&[u, v, w]);
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    fn be_ints(v: &[i32]) -> Vec<u8> {
        v.iter().flat_map(|x| x.to_be_bytes()).collect()
    }

    #[test]
    fn header_with_markers_detects_2d() {
        let mut b = be_ints(&[8, 3, 4, 8]);
        b.extend(vec![0u8; 3 * 4 * 2 * 4 + 8]);
        let layout = Layout {
            endian: Endian::Big,
            record_markers: true,
            multi_grid: false,
            iblank: false,
            precision: 4,
            planes: false,
        };
        let e = parse_header(&b, &layout).unwrap_err();
        assert!(e.message.contains("2D"), "{}", e.message);
        let e = read(&b, None, &Plot3dOptions::default()).unwrap_err();
        assert!(e.message.contains("2D"), "{}", e.message);
    }

    #[test]
    fn tiny_grid_all_settings_detected() {
        // 2×2×2 little-endian, markers, multi-grid (1 grid), IBLANK, double.
        let mut b = Vec::new();
        let le = |v: i32| v.to_le_bytes();
        for v in [4, 1, 4, 12, 2, 2, 2, 12] {
            b.extend(le(v));
        }
        let rec = 8 * (3 * 8 + 4);
        b.extend(le(rec));
        for c in 0..3 {
            for p in 0..8 {
                b.extend(f64::from((p >> c) & 1).to_le_bytes());
            }
        }
        for p in 0..8 {
            b.extend(le(if p == 7 { 0 } else { 1 }));
        }
        b.extend(le(rec));
        let m = read(&b, None, &Plot3dOptions::default()).unwrap();
        assert!(m.format.contains("little-endian"), "{}", m.format);
        assert!(m.format.contains("double"), "{}", m.format);
        assert_eq!(m.points.len(), 8);
        assert_eq!(m.points[7], [1.0, 1.0, 1.0]);
        assert_eq!(m.point_blanked.as_ref().unwrap().iter().filter(|&&b| b).count(), 1);
    }

    #[test]
    fn derived_fields_follow_vtk() {
        let d = derive_flow_fields(&[2.0, 0.0], &[2.0, 0.0, 0.0, 1.0, 0.0, 0.0], &[5.0, -1.0], 1.4, 1.0);
        // v = 1, p = 0.4 (5 − 1) = 1.6, T = 0.8, a² = 1.4·1.6/2 = 1.12.
        assert!((d.pressure[0] - 1.6).abs() < 1e-12);
        assert!((d.temperature[0] - 0.8).abs() < 1e-12);
        assert!((d.mach[0] - (1.0f64 / 1.12).sqrt()).abs() < 1e-12);
        assert_eq!(d.zero_density, 1);
        assert_eq!(d.negative_pressure, 1);
        assert!(d.mach[1].is_nan());
    }
}
