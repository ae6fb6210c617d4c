//! PLOT3D reader on the real Blunt Fin and combustor data sets, checked
//! against the values VTK 9.7's vtkMultiBlockPLOT3DReader produces for the
//! same files, plus the layout variants the real files lack (re-encoded at
//! test time from Blunt Fin sub-blocks).

mod common;

use common::Lcg;
use tet_io::cursor::Endian;
use tet_io::plot3d::{read, Plot3dOptions};
use tet_mesh::{Block, Field, SourceMesh};

const DIR: &str = concat!(env!("CARGO_MANIFEST_DIR"), "/../../tests/data/plot3d/");

fn load(name: &str) -> Vec<u8> {
    std::fs::read(format!("{DIR}{name}")).unwrap_or_else(|e| panic!("{name}: {e}"))
}

fn field<'a>(m: &'a SourceMesh, name: &str) -> &'a Field {
    m.point_fields.iter().find(|f| f.name == name).unwrap_or_else(|| panic!("no field {name}"))
}

/// Min and max ignoring NaN.
fn range(v: &[f64]) -> (f64, f64) {
    v.iter().filter(|x| !x.is_nan()).fold((f64::INFINITY, f64::NEG_INFINITY), |(lo, hi), &x| (lo.min(x), hi.max(x)))
}

fn close(a: f64, b: f64) -> bool {
    (a - b).abs() <= 1e-6 * b.abs().max(1e-6)
}

fn assert_close(what: &str, got: f64, vtk: f64) {
    assert!(close(got, vtk), "{what}: got {got}, VTK {vtk}");
}

fn bluntfin() -> SourceMesh {
    read(&load("bluntfinxyz.bin"), Some(&load("bluntfinq.bin")), &Plot3dOptions::default()).unwrap()
}

#[test]
fn bluntfin_matches_vtk() {
    let m = bluntfin();
    assert_eq!(m.points.len(), 40_960);
    assert_eq!(m.num_cells(), 37_479);
    assert_eq!(m.blocks, vec![Block::Structured { dims: [40, 32, 32], first_point: 0 }]);
    assert!(m.format.contains("big-endian") && m.format.contains("no record markers"), "{}", m.format);
    assert!(m.point_blanked.is_none());
    assert!(m.notes.iter().any(|n| n.contains("484 bytes after")), "{:?}", m.notes);
    assert!(m.notes.iter().any(|n| n.contains("fsmach 2.95") && n.contains("re 2100000")), "{:?}", m.notes);

    // Bounds and point 1000 as VTK reports them.
    let xs: Vec<f64> = m.points.iter().map(|p| p[0]).collect();
    let zs: Vec<f64> = m.points.iter().map(|p| p[2]).collect();
    assert_eq!(range(&xs), (-7.815747261047363, 14.362203598022461));
    assert_eq!(range(&zs), (0.0, 5.7242512702941895));
    assert_eq!(m.points[1000], [-2.161968469619751, 0.0, 0.0]);

    // Conserved fields are exact copies of the float32 file values.
    assert_eq!(range(&field(&m, "density").values), (0.1926f32 as f64, 4.9775f32 as f64));
    assert_eq!(range(&field(&m, "momentum").values), (-3.7339f32 as f64, 5.7903f32 as f64));
    assert_eq!(range(&field(&m, "stagnation_energy").values), (0.76895696f32 as f64, 25.161f32 as f64));
    assert_eq!(field(&m, "momentum").num_components, 3);

    // Derived fields: VTK computes in double and stores float32.
    let (plo, phi) = range(&field(&m, "pressure").values);
    assert_close("pressure min", plo, 0.2595479);
    assert_close("pressure max", phi, 10.01268);
    let (tlo, thi) = range(&field(&m, "temperature").values);
    assert_close("temperature min", tlo, 0.59870005);
    assert_close("temperature max", thi, 2.0713077);
    let (mlo, mhi) = range(&field(&m, "mach").values);
    assert_eq!(mlo, 0.0);
    assert_close("mach max", mhi, 3.3854456);
    let (vlo, vhi) = range(&field(&m, "velocity").values);
    assert_close("velocity min", vlo, -2.057061);
    assert_close("velocity max", vhi, 3.1229308);

    assert_close("density[1000]", field(&m, "density").values[1000], 0.563480019569397);
    assert_close("pressure[1000]", field(&m, "pressure").values[1000], 1.0908340215682983);
    assert_close("temperature[1000]", field(&m, "temperature").values[1000], 1.9358875751495361);
    assert_close("pressure[last]", field(&m, "pressure").values[40_959], 1.2562956809997559);
    assert_close("temperature[last]", field(&m, "temperature").values[40_959], 0.8548555374145508);
    assert_close("mach[last]", field(&m, "mach").values[40_959], 2.5583512783050537);
    let v = &field(&m, "velocity").values[3 * 40_959..];
    for (c, vtk) in [2.769665241241455, 0.402374804019928, 0.01681273803114891].into_iter().enumerate() {
        assert_close("velocity[last]", v[c], vtk);
    }
}

#[test]
fn combustor_matches_vtk() {
    let m = read(&load("combxyz.bin"), Some(&load("combq.bin")), &Plot3dOptions::default()).unwrap();
    assert_eq!(m.blocks, vec![Block::Structured { dims: [57, 33, 25], first_point: 0 }]);
    assert_eq!(m.points.len(), 47_025);
    assert_eq!(m.num_cells(), 43_008);
    let ys: Vec<f64> = m.points.iter().map(|p| p[1]).collect();
    assert_eq!(range(&ys), (-5.662140846252441, 5.662140846252441));
    assert_eq!(range(&field(&m, "density").values), (0.1978131f32 as f64, 0.71041924f32 as f64));
    assert_eq!(range(&field(&m, "stagnation_energy").values), (0.0, 0.0));
    // Energy is all zero, so pressure is non-positive and Mach is NaN
    // wherever the flow moves: VTK gives the same.
    let (plo, phi) = range(&field(&m, "pressure").values);
    assert_close("pressure min", plo, -118486.36);
    assert_eq!(phi, 0.0);
    assert!(m.notes.iter().any(|n| n.contains("negative pressure")), "{:?}", m.notes);
    assert!(field(&m, "mach").values.iter().any(|v| v.is_nan()));
    assert!(!m.notes.iter().any(|n| n.contains("bytes after")), "{:?}", m.notes);
}

/// One grid in memory: what the encoder writes and the reader must return.
#[derive(Clone)]
struct Grid {
    dims: [usize; 3],
    xyz: [Vec<f64>; 3],
    iblank: Vec<i32>,
    q: [Vec<f64>; 5],
    conditions: [f64; 4],
}

/// Cuts a sub-block out of the Blunt Fin mesh (values stay float32-exact).
fn sub_block(m: &SourceMesh, lo: [usize; 3], dims: [usize; 3]) -> Grid {
    let mut g = Grid {
        dims,
        xyz: Default::default(),
        iblank: Vec::new(),
        q: Default::default(),
        conditions: [2.95f32 as f64, 0.0, 2.1e6, 1.3911f32 as f64],
    };
    let (rho, mom, e) = (field(m, "density"), field(m, "momentum"), field(m, "stagnation_energy"));
    for k in 0..dims[2] {
        for j in 0..dims[1] {
            for i in 0..dims[0] {
                let p = (lo[0] + i) + 40 * ((lo[1] + j) + 32 * (lo[2] + k));
                for c in 0..3 {
                    g.xyz[c].push(m.points[p][c]);
                    g.q[1 + c].push(mom.values[3 * p + c]);
                }
                g.q[0].push(rho.values[p]);
                g.q[4].push(e.values[p]);
                // Blank a sprinkling of points; 2 and -1 are overset codes.
                g.iblank.push(match p % 7 {
                    0 => 0,
                    3 => 2,
                    5 => -1,
                    _ => 1,
                });
            }
        }
    }
    g
}

#[derive(Clone, Copy, Debug)]
struct Enc {
    little: bool,
    markers: bool,
    multi: bool,
    iblank: bool,
    double: bool,
    planes: bool,
}

struct Writer {
    enc: Enc,
    out: Vec<u8>,
}

impl Writer {
    fn int(&self, buf: &mut Vec<u8>, v: i32) {
        buf.extend(if self.enc.little { v.to_le_bytes() } else { v.to_be_bytes() });
    }
    fn float(&self, buf: &mut Vec<u8>, v: f64) {
        match (self.enc.double, self.enc.little) {
            (true, true) => buf.extend(v.to_le_bytes()),
            (true, false) => buf.extend(v.to_be_bytes()),
            (false, true) => buf.extend((v as f32).to_le_bytes()),
            (false, false) => buf.extend((v as f32).to_be_bytes()),
        }
    }
    fn record(&mut self, payload: Vec<u8>) {
        let mut marker = Vec::new();
        if self.enc.markers {
            self.int(&mut marker, payload.len() as i32);
            self.out.extend(&marker);
        }
        self.out.extend(payload);
        self.out.extend(marker);
    }
    fn header(&mut self, grids: &[Grid]) {
        if self.enc.multi {
            let mut p = Vec::new();
            self.int(&mut p, grids.len() as i32);
            self.record(p);
        }
        let mut p = Vec::new();
        for g in grids {
            for d in g.dims {
                self.int(&mut p, d as i32);
            }
        }
        self.record(p);
    }
}

/// The point ranges of a grid of `dims` (`points` in all) written as one
/// record each: every k-plane in the planes layout, else all the points.
fn record_spans(dims: [usize; 3], points: usize, planes: bool) -> Vec<std::ops::Range<usize>> {
    let plane = dims[0] * dims[1];
    if planes {
        (0..dims[2]).map(|k| k * plane..(k + 1) * plane).collect()
    } else {
        std::iter::once(0..points).collect()
    }
}

/// Writes the grid file and the Q file of `grids` in layout `enc`.
fn encode(grids: &[Grid], enc: Enc) -> (Vec<u8>, Vec<u8>) {
    let mut w = Writer { enc, out: Vec::new() };
    w.header(grids);
    for g in grids {
        for span in record_spans(g.dims, g.xyz[0].len(), enc.planes) {
            let mut p = Vec::new();
            for c in &g.xyz {
                c[span.clone()].iter().for_each(|&v| w.float(&mut p, v));
            }
            if enc.iblank {
                g.iblank[span.clone()].iter().for_each(|&v| w.int(&mut p, v));
            }
            w.record(p);
        }
    }
    let xyz = std::mem::take(&mut w.out);
    w.header(grids);
    for g in grids {
        let mut p = Vec::new();
        g.conditions.iter().for_each(|&v| w.float(&mut p, v));
        w.record(p);
        for span in record_spans(g.dims, g.q[0].len(), enc.planes) {
            let mut p = Vec::new();
            for var in &g.q {
                var[span.clone()].iter().for_each(|&v| w.float(&mut p, v));
            }
            w.record(p);
        }
    }
    (xyz, w.out)
}

fn check_variant(grids: &[Grid], enc: Enc, reference: Option<&SourceMesh>) -> SourceMesh {
    let (xyz, q) = encode(grids, enc);
    let opts = Plot3dOptions { planes: enc.planes, ..Default::default() };
    let m = read(&xyz, Some(&q), &opts).unwrap_or_else(|e| panic!("{enc:?}: {e}"));
    let what = format!("{enc:?} read as {}", m.format);
    assert_eq!(m.format.contains("little-endian"), enc.little, "{what}");
    assert_eq!(m.format.contains("Fortran record markers"), enc.markers, "{what}");
    assert_eq!(m.format.contains("multi-grid"), enc.multi, "{what}");
    assert_eq!(m.format.contains("double"), enc.double, "{what}");
    assert_eq!(m.format.contains(", IBLANK"), enc.iblank, "{what}");
    let mut first = 0;
    for (b, g) in grids.iter().enumerate() {
        assert_eq!(m.blocks[b], Block::Structured { dims: g.dims, first_point: first }, "{what}");
        let n = g.xyz[0].len();
        for p in 0..n {
            assert_eq!(m.points[first + p], [g.xyz[0][p], g.xyz[1][p], g.xyz[2][p]], "{what}");
            assert_eq!(field(&m, "density").values[first + p], g.q[0][p], "{what}");
            assert_eq!(field(&m, "stagnation_energy").values[first + p], g.q[4][p], "{what}");
            for c in 0..3 {
                assert_eq!(field(&m, "momentum").values[3 * (first + p) + c], g.q[1 + c][p], "{what}");
            }
            if enc.iblank {
                assert_eq!(m.point_blanked.as_ref().unwrap()[first + p], g.iblank[p] == 0, "{what}");
            }
        }
        first += n;
    }
    assert_eq!(m.point_blanked.is_some(), enc.iblank, "{what}");
    // Derived fields depend only on the conserved ones, so every variant of
    // the same grids must agree exactly.
    if let Some(r) = reference {
        assert_eq!(m.points, r.points, "{what}");
        for name in ["density", "momentum", "stagnation_energy", "pressure", "temperature", "velocity"] {
            assert_eq!(field(&m, name).values, field(r, name).values, "{what}: {name}");
        }
    }
    m
}

#[test]
fn layout_variants_agree() {
    let full = bluntfin();
    let a = sub_block(&full, [3, 2, 1], [7, 5, 4]);
    let b = sub_block(&full, [20, 10, 20], [4, 6, 3]);
    let base = Enc { little: false, markers: false, multi: false, iblank: false, double: false, planes: false };
    let one = [a.clone()];
    let reference = check_variant(&one, base, None);
    // The big-endian C single-grid encoding of a sub-block reproduces the
    // original file's values.
    assert_eq!(reference.points[0], full.points[3 + 40 * (2 + 32)]);

    for little in [false, true] {
        for markers in [false, true] {
            for iblank in [false, true] {
                for double in [false, true] {
                    for planes in [false, true] {
                        let enc = Enc { little, markers, multi: false, iblank, double, planes };
                        check_variant(&one, enc, Some(&reference));
                    }
                }
            }
        }
    }
    let two = [a, b];
    let multi_ref = check_variant(&two, Enc { multi: true, ..base }, None);
    assert_eq!(multi_ref.blocks.len(), 2);
    assert_eq!(multi_ref.points.len(), 7 * 5 * 4 + 4 * 6 * 3);
    assert!(multi_ref.notes.iter().any(|n| n.contains("2 grids")), "{:?}", multi_ref.notes);
    for little in [false, true] {
        for markers in [false, true] {
            for iblank in [false, true] {
                for double in [false, true] {
                    let enc = Enc { little, markers, multi: true, iblank, double, planes: false };
                    let m = check_variant(&two, enc, Some(&multi_ref));
                    if iblank {
                        assert!(m.notes.iter().any(|n| n.contains("overset")), "{:?}", m.notes);
                    }
                }
            }
        }
    }
    check_variant(&two, Enc { multi: true, markers: true, planes: true, ..base }, Some(&multi_ref));
}

#[test]
fn explicit_options_are_honoured() {
    let full = bluntfin();
    let g = [sub_block(&full, [0, 0, 0], [5, 4, 3])];
    let enc = Enc { little: true, markers: true, multi: true, iblank: true, double: true, planes: false };
    let (xyz, q) = encode(&g, enc);
    let exact = Plot3dOptions {
        byte_order: Some(Endian::Little),
        record_markers: Some(true),
        multi_grid: Some(true),
        iblank: Some(true),
        double_precision: Some(true),
        ..Default::default()
    };
    assert!(read(&xyz, Some(&q), &exact).is_ok());
    let wrong = Plot3dOptions { byte_order: Some(Endian::Big), ..exact.clone() };
    let e = read(&xyz, Some(&q), &wrong).unwrap_err();
    assert!(e.message.contains("tried"), "{}", e.message);
    let wrong = Plot3dOptions { double_precision: Some(false), ..exact };
    assert!(read(&xyz, Some(&q), &wrong).is_err());
}

#[test]
fn q_file_errors_are_companion_errors() {
    let xyz = load("bluntfinxyz.bin");
    let q = load("bluntfinq.bin");
    let e = read(&xyz, Some(&q[..q.len() / 2]), &Plot3dOptions::default()).unwrap_err();
    assert!(e.in_companion, "{e}");
    assert!(e.message.contains("Q file has"), "{}", e.message);
    let comb_q = load("combq.bin");
    let e = read(&xyz, Some(&comb_q), &Plot3dOptions::default()).unwrap_err();
    assert!(e.in_companion && e.message.contains("do not match"), "{e}");
    let e = read(&xyz, Some(b"\0\0"), &Plot3dOptions::default()).unwrap_err();
    assert!(e.in_companion, "{e}");
    // The grid alone reads fine without fields.
    let m = read(&xyz, None, &Plot3dOptions::default()).unwrap();
    assert!(m.point_fields.is_empty());
}

#[test]
fn unsupported_and_hostile_headers() {
    let opts = Plot3dOptions::default();
    let be = |v: &[i32]| -> Vec<u8> { v.iter().flat_map(|x| x.to_be_bytes()).collect() };
    // A 2D grid (ni nj, x and y only) of 3×4 points.
    let mut two_d = be(&[3, 4]);
    two_d.extend(vec![0u8; 3 * 4 * 2 * 4]);
    let e = read(&two_d, None, &opts).unwrap_err();
    assert!(e.message.contains("no PLOT3D layout") && e.message.contains("2D"), "{}", e.message);
    let mut two_d_fortran = be(&[8, 3, 4, 8, 96]);
    two_d_fortran.extend(vec![0u8; 96]);
    two_d_fortran.extend(be(&[96]));
    let e = read(&two_d_fortran, None, &opts).unwrap_err();
    assert!(e.message.contains("2D"), "{}", e.message);

    for header in [
        be(&[i32::MAX, i32::MAX, i32::MAX]),
        be(&[-40, 32, 32]),
        be(&[0, 0, 0]),
        be(&[i32::MAX]),
        be(&[4, i32::MAX, 4, 12]),
        be(&[4, -3, 4]),
        be(&[12, 40, 32, 32, 12, i32::MAX]),
        be(&[1, 1]),
        Vec::new(),
        b"40 32 32\n1.0 2.0".to_vec(),
    ] {
        let mut bytes = header.clone();
        bytes.extend(vec![0u8; 64]);
        for b in [&header, &bytes] {
            let e = read(b, None, &opts).unwrap_err();
            assert!(!e.message.is_empty());
            let _ = read(b, Some(b), &opts);
        }
    }
}

#[test]
fn corrupted_real_files_never_panic() {
    let mut rng = Lcg(0x9e3779b97f4a7c15);
    let opts = Plot3dOptions::default();
    for (xyz_name, q_name) in [("bluntfinxyz.bin", "bluntfinq.bin"), ("combxyz.bin", "combq.bin")] {
        let xyz = load(xyz_name);
        let q = load(q_name);
        for _ in 0..200 {
            let cut = rng.below(xyz.len());
            let _ = read(&xyz[..cut], Some(&q), &opts);
            let cut = rng.below(q.len());
            let _ = read(&xyz, Some(&q[..cut]), &opts);
        }
        for _ in 0..200 {
            // Flips in the header area are the interesting ones; mix both.
            let mut bad = xyz.clone();
            let at = if rng.below(2) == 0 { rng.below(64) } else { rng.below(bad.len()) };
            bad[at] ^= 1 << rng.below(8);
            let _ = read(&bad, Some(&q), &opts);
            let mut bad_q = q.clone();
            let at = if rng.below(2) == 0 { rng.below(64) } else { rng.below(bad_q.len()) };
            bad_q[at] ^= 0xff;
            let _ = read(&xyz, Some(&bad_q), &opts);
        }
    }
    // Fortran-marker, multi-grid, planes encodings corrupted the same way.
    let full = bluntfin();
    let grids = [sub_block(&full, [0, 0, 0], [6, 5, 4]), sub_block(&full, [10, 10, 10], [3, 3, 3])];
    for planes in [false, true] {
        let enc = Enc { little: true, markers: true, multi: true, iblank: true, double: false, planes };
        let (xyz, q) = encode(&grids, enc);
        let opts = Plot3dOptions { planes, ..Default::default() };
        for _ in 0..200 {
            let _ = read(&xyz[..rng.below(xyz.len())], Some(&q), &opts);
            let mut bad = xyz.clone();
            let at = rng.below(bad.len());
            bad[at] ^= 0x80;
            let _ = read(&bad, Some(&q), &opts);
            let mut bad_q = q.clone();
            let at = rng.below(bad_q.len());
            bad_q[at] ^= 0x40;
            let _ = read(&xyz, Some(&bad_q), &opts);
        }
    }
}
