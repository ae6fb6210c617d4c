//! OpenFOAM reader: VTKData's cavity tutorial and binary two-cell case
//! (tests/data/openfoam/LICENSE.md), and cases this file writes itself
//! (binary with 32- and 64-bit labels, gzip, a hanging-node polyhedron,
//! a decomposed case, and one broken case per error the reader names).
//!
//! Expected cavity values were read by hand from the text files:
//! `cavity/0.5/p` entries 0, 210 and 399 are 5.88597e-06, 0.0156109 and
//! 4.84854; `1/p`: 4.73068e-06, 0.0156083, 4.84854; `1.5/p`: 3.75216e-06,
//! 0.0156063, 4.84853; `2.5/p` (the latest): 2.44788e-06, 0.0156039,
//! 4.84853. `U` entry 0 at 0.5 is (0.000253336 -0.000250529 0), at 1
//! (0.000253392 -0.000250481 0), at 1.5 (0.000253436 -0.000250437 0);
//! entry 210 at 1 is (-0.203856 -0.0156598 0); entry 399 at 0.5 is
//! (0.308819 -0.149468 0). Time 0 holds `uniform 0` and `uniform (0 0 0)`.

use std::io::Write;
use std::path::{Path, PathBuf};

use tet_io::{read_file, Format, Location, ReadError, ReadOptions};
use tet_mesh::predicates::signed_tet_volume;
use tet_mesh::{build_adjacency, tetrahedralize, Block, CellType, ConvertOptions, Finding, SourceMesh, FACE_OUTWARD};

const DIR: &str = concat!(env!("CARGO_MANIFEST_DIR"), "/../../tests/data/openfoam/");

fn cavity() -> PathBuf {
    Path::new(DIR).join("cavity")
}

fn read_at(path: &Path, time_step: Option<usize>) -> Result<SourceMesh, ReadError> {
    read_file(path, &ReadOptions { time_step, ..Default::default() })
}

fn field<'a>(m: &'a SourceMesh, name: &str) -> &'a tet_mesh::Field {
    m.cell_fields.iter().find(|f| f.name == name).unwrap_or_else(|| panic!("no field {name}: {:?}", m.cell_fields))
}

fn close(a: f64, b: f64) -> bool {
    (a - b).abs() <= 1e-12 * b.abs().max(1e-300)
}

/// Tetrahedralizes and returns (total volume, boundary area, convex), after
/// checking that no tet was re-oriented (cells come out positive) and that
/// the adjacency builds (no face shared by three tets).
fn tet_facts(m: &SourceMesh) -> (f64, f64, bool, tet_mesh::TetMesh) {
    let (t, report) = tetrahedralize(m, &ConvertOptions::default(), &mut |_| {}).unwrap();
    assert!(
        !report
            .findings
            .iter()
            .any(|f| matches!(f, Finding::ReorientedTets { .. } | Finding::DroppedZeroVolumeTets { .. })),
        "{:?}",
        report.findings
    );
    let p = |i: u32| &t.points[i as usize];
    let vol: f64 = t.tets.iter().map(|q| signed_tet_volume(p(q[0]), p(q[1]), p(q[2]), p(q[3]))).sum();
    let adj = build_adjacency(&t.points, &t.tets).unwrap();
    let area: f64 = adj
        .boundary_faces
        .iter()
        .map(|&bf| {
            let (ti, f) = (bf as usize / 4, bf as usize % 4);
            let q = t.tets[ti];
            let [a, b, c] = FACE_OUTWARD[f].map(|k| *p(q[k]));
            let u = [b[0] - a[0], b[1] - a[1], b[2] - a[2]];
            let v = [c[0] - a[0], c[1] - a[1], c[2] - a[2]];
            let n = [u[1] * v[2] - u[2] * v[1], u[2] * v[0] - u[0] * v[2], u[0] * v[1] - u[1] * v[0]];
            0.5 * (n[0] * n[0] + n[1] * n[1] + n[2] * n[2]).sqrt()
        })
        .sum();
    (vol, area, adj.convex, t)
}

#[test]
fn the_cavity_reads_as_400_hexahedra_filling_its_box() {
    let case = cavity();
    for input in [case.clone(), case.join("case.foam"), case.join("constant/polyMesh")] {
        let m = read_at(&input, None).unwrap();
        assert_eq!(m.points.len(), 882, "{}", input.display());
        assert_eq!(m.num_cells(), 400);
        let Block::Unstructured(c) = &m.blocks[0] else { panic!("unstructured") };
        assert!(c.types.iter().all(|&t| t == CellType::Hexahedron));
        assert_eq!(m.format, "OpenFOAM (ascii)");
        // Scalars first (the default scalar is p), then vectors; phi skipped.
        let names: Vec<_> = m.cell_fields.iter().map(|f| (f.name.as_str(), f.num_components)).collect();
        assert_eq!(names, vec![("p", 1), ("U", 3)]);
        assert!(m.notes.iter().any(|n| n.contains("OpenFOAM times: 0, 0.5, 1, 1.5, 2, 2.5; fields from time 2.5")));
        assert!(m.notes.iter().any(|n| n.contains("phi (surfaceScalarField)")), "{:?}", m.notes);
    }
    let m = read_at(&case, None).unwrap();
    // Latest time (2.5) by default.
    let p = &field(&m, "p").values;
    assert!(close(p[0], 2.44788e-06) && close(p[210], 0.0156039) && close(p[399], 4.84853));
    assert_eq!(tet_mesh::Field::num_tuples(field(&m, "U")), 400);
    // The box is 0.1 × 0.1 × 0.01; a conforming mesh of it has the box's
    // surface as its boundary.
    let (vol, area, convex, t) = tet_facts(&m);
    assert!(close(vol, 1e-4), "{vol}");
    assert!((area - 2.0 * (0.01 + 0.001 + 0.001)).abs() < 1e-12 * area, "{area}");
    assert!(convex);
    assert_eq!(t.tets.len(), 2400);
}

#[test]
fn cavity_fields_at_each_time_step() {
    let case = cavity();
    // Index into 0, 0.5, 1, 1.5, 2, 2.5.
    let m = read_at(&case, Some(0)).unwrap();
    assert!(field(&m, "p").values.iter().all(|&v| v == 0.0));
    assert!(field(&m, "U").values.iter().all(|&v| v == 0.0));
    assert!(m.notes.iter().any(|n| n.contains("fields from time 0 (chosen")), "{:?}", m.notes);
    let cases: [(usize, [f64; 3], [f64; 3]); 3] = [
        (1, [5.88597e-06, 0.0156109, 4.84854], [0.000253336, -0.000250529, 0.0]),
        (2, [4.73068e-06, 0.0156083, 4.84854], [0.000253392, -0.000250481, 0.0]),
        (3, [3.75216e-06, 0.0156063, 4.84853], [0.000253436, -0.000250437, 0.0]),
    ];
    for (step, p_want, u0) in cases {
        let m = read_at(&case, Some(step)).unwrap();
        let p = &field(&m, "p").values;
        for (k, &i) in [0usize, 210, 399].iter().enumerate() {
            assert!(close(p[i], p_want[k]), "step {step} p[{i}] = {}", p[i]);
        }
        let u = &field(&m, "U").values;
        for c in 0..3 {
            assert!(close(u[c], u0[c]), "step {step} U[0] = {:?}", &u[..3]);
        }
        if step == 2 {
            assert!(close(u[630], -0.203856) && close(u[631], -0.0156598));
        }
        if step == 1 {
            assert!(close(u[3 * 399], 0.308819) && close(u[3 * 399 + 1], -0.149468));
        }
    }
    let e = read_at(&case, Some(6)).unwrap_err();
    let msg = e.to_string();
    assert!(msg.contains("time step 6 does not exist") && msg.contains("(0, 0.5, 1, 1.5, 2, 2.5)"), "{msg}");
    assert!(msg.contains(case.to_str().unwrap()), "{msg}");
}

/// VTKData's binary case written by OpenFOAM 4 (faceCompactList, no arch).
#[test]
fn the_binary_two_cell_case() {
    let m = read_at(&Path::new(DIR).join("64BitFloats/case.foam"), None).unwrap();
    assert_eq!(m.format, "OpenFOAM (binary)");
    assert_eq!((m.points.len(), m.num_cells()), (12, 2));
    assert_eq!(field(&m, "p").values, vec![1.0, 2.0]);
    assert_eq!(field(&m, "U").values, vec![1.0, 0.0, 0.0, 2.0, 0.0, 0.0]);
    let (vol, area, convex, _) = tet_facts(&m);
    // Two 1 × 2 × 2 hexahedra side by side in [-1, 1]³.
    assert!(close(vol, 8.0) && close(area, 24.0) && convex, "{vol} {area}");
}

// ---------------------------------------------------------------------------
// Cases written here.

/// A polyMesh: faces with owner (and neighbour for the internal ones, which
/// come first).
#[derive(Clone)]
struct Poly {
    points: Vec<[f64; 3]>,
    faces: Vec<Vec<u32>>,
    owner: Vec<i64>,
    neighbour: Vec<i64>,
}

/// Builds the polyMesh of cells given by their outward faces: a face two
/// cells share is internal, owned by the lower cell with its orientation.
fn poly(points: Vec<[f64; 3]>, cells: &[Vec<Vec<u32>>]) -> Poly {
    let key = |f: &[u32]| {
        let mut k = f.to_vec();
        k.sort_unstable();
        k
    };
    /// A face: its sorted ids, owner, ids as the owner sees them, neighbour.
    struct Seen {
        key: Vec<u32>,
        owner: usize,
        face: Vec<u32>,
        neighbour: Option<usize>,
    }
    let mut seen: Vec<Seen> = Vec::new();
    for (c, faces) in cells.iter().enumerate() {
        for f in faces {
            match seen.iter_mut().find(|s| s.key == key(f)) {
                Some(s) => s.neighbour = Some(c),
                None => seen.push(Seen { key: key(f), owner: c, face: f.clone(), neighbour: None }),
            }
        }
    }
    let (mut internal, boundary): (Vec<_>, Vec<_>) = seen.into_iter().partition(|s| s.neighbour.is_some());
    internal.sort_by_key(|s| (s.owner, s.neighbour));
    let mut p = Poly { points, faces: vec![], owner: vec![], neighbour: vec![] };
    for s in internal.iter().chain(&boundary) {
        p.faces.push(s.face.clone());
        p.owner.push(s.owner as i64);
        if let Some(n) = s.neighbour {
            p.neighbour.push(n as i64);
        }
    }
    p
}

/// VTK-order hexahedron nodes → its outward faces.
fn hex_faces(h: [u32; 8]) -> Vec<Vec<u32>> {
    const F: [[usize; 4]; 6] = [[0, 3, 2, 1], [4, 5, 6, 7], [0, 1, 5, 4], [1, 2, 6, 5], [2, 3, 7, 6], [3, 0, 4, 7]];
    F.iter().map(|f| f.iter().map(|&i| h[i]).collect()).collect()
}

/// A unit cube (cell 0, a 7-face polyhedron: its x = 1 face is split in two
/// quads by the edge midpoints 8, 9, which also make its z = 0 and z = 1
/// faces pentagons) against two half-height hexahedra on x ∈ [1, 2]: the
/// classic hanging-node refinement. Volume 2, box [0,2]×[0,1]×[0,1].
fn hanging_node() -> Poly {
    let mut points = tet_mesh::split::UNIT_HEX.to_vec();
    points.extend([
        [1., 0.5, 0.],
        [1., 0.5, 1.],
        [2., 0., 0.],
        [2., 0.5, 0.],
        [2., 1., 0.],
        [2., 0., 1.],
        [2., 0.5, 1.],
        [2., 1., 1.],
    ]);
    let big = vec![
        vec![0, 4, 7, 3],
        vec![0, 1, 5, 4],
        vec![3, 7, 6, 2],
        vec![0, 3, 2, 8, 1],
        vec![4, 5, 9, 6, 7],
        vec![1, 8, 9, 5],
        vec![8, 2, 6, 9],
    ];
    poly(points, &[big, hex_faces([1, 10, 11, 8, 5, 13, 14, 9]), hex_faces([8, 11, 12, 2, 9, 14, 15, 6])])
}

#[derive(Clone, Copy, PartialEq)]
enum Enc {
    Ascii,
    Binary { label64: bool },
}

fn foam(class: &str, enc: Enc, body: &[u8]) -> Vec<u8> {
    let (format, arch) = match enc {
        Enc::Ascii => ("ascii", String::new()),
        Enc::Binary { label64 } => {
            ("binary", format!("    arch \"LSB;label={};scalar=64\";\n", if label64 { 64 } else { 32 }))
        }
    };
    let mut v = format!(
        "/*--- written by tests/openfoam.rs ---*/\nFoamFile\n{{\n    version 2.0;\n    format {format};\n{arch}    class {class};\n    object x;\n}}\n// * * //\n\n"
    )
    .into_bytes();
    v.extend_from_slice(body);
    v.extend_from_slice(b"\n\n// *** //\n");
    v
}

fn label_list(v: &[i64], enc: Enc) -> Vec<u8> {
    match enc {
        Enc::Ascii => {
            let items: Vec<String> = v.iter().map(|x| x.to_string()).collect();
            format!("{}\n(\n{}\n)", v.len(), items.join("\n")).into_bytes()
        }
        Enc::Binary { label64 } => {
            let mut b = format!("{}\n(", v.len()).into_bytes();
            for &x in v {
                if label64 {
                    b.extend_from_slice(&x.to_le_bytes());
                } else {
                    b.extend_from_slice(&(x as i32).to_le_bytes());
                }
            }
            b.push(b')');
            b
        }
    }
}

fn scalar_list(v: &[f64], ncomp: usize, enc: Enc) -> Vec<u8> {
    let n = v.len() / ncomp;
    match enc {
        Enc::Ascii => {
            let items: Vec<String> = v
                .chunks(ncomp)
                .map(|t| {
                    let s: Vec<String> = t.iter().map(|x| format!("{x:?}")).collect();
                    if ncomp == 1 {
                        s[0].clone()
                    } else {
                        format!("({})", s.join(" "))
                    }
                })
                .collect();
            format!("{n}\n(\n{}\n)", items.join("\n")).into_bytes()
        }
        Enc::Binary { .. } => {
            let mut b = format!("{n}\n(").into_bytes();
            for x in v {
                b.extend_from_slice(&x.to_le_bytes());
            }
            b.push(b')');
            b
        }
    }
}

/// The polyMesh files' bytes: points, faces, owner, neighbour. ASCII faces
/// are a faceList, binary ones a faceCompactList.
fn mesh_files(p: &Poly, enc: Enc) -> [(String, Vec<u8>); 4] {
    let flat: Vec<f64> = p.points.iter().flatten().copied().collect();
    let faces = match enc {
        Enc::Ascii => {
            let items: Vec<String> = p
                .faces
                .iter()
                .map(|f| format!("{}({})", f.len(), f.iter().map(u32::to_string).collect::<Vec<_>>().join(" ")))
                .collect();
            foam("faceList", enc, format!("{}\n(\n{}\n)", p.faces.len(), items.join("\n")).as_bytes())
        }
        Enc::Binary { .. } => {
            let mut offsets = vec![0i64];
            let mut ids = vec![];
            for f in &p.faces {
                ids.extend(f.iter().map(|&i| i as i64));
                offsets.push(ids.len() as i64);
            }
            let mut body = label_list(&offsets, enc);
            body.push(b'\n');
            body.extend(label_list(&ids, enc));
            foam("faceCompactList", enc, &body)
        }
    };
    [
        ("points".into(), foam("vectorField", enc, &scalar_list(&flat, 3, enc))),
        ("faces".into(), faces),
        ("owner".into(), foam("labelList", enc, &label_list(&p.owner, enc))),
        ("neighbour".into(), foam("labelList", enc, &label_list(&p.neighbour, enc))),
    ]
}

fn write(path: &Path, bytes: &[u8], gz: bool) {
    std::fs::create_dir_all(path.parent().unwrap()).unwrap();
    if gz {
        let mut name = path.as_os_str().to_owned();
        name.push(".gz");
        let mut e = flate2::write::GzEncoder::new(std::fs::File::create(name).unwrap(), flate2::Compression::fast());
        e.write_all(bytes).unwrap();
        e.finish().unwrap();
    } else {
        std::fs::write(path, bytes).unwrap();
    }
}

/// A volScalarField with one value per cell.
fn scalar_field(values: &[f64], enc: Enc) -> Vec<u8> {
    let mut body = b"dimensions [0 2 -2 0 0 0 0];\n\ninternalField nonuniform List<scalar> ".to_vec();
    body.extend(scalar_list(values, 1, enc));
    body.extend_from_slice(b";\n\nboundaryField\n{\n    walls { type zeroGradient; }\n}\n");
    foam("volScalarField", enc, &body)
}

/// Writes `p` as a case in `dir` (with `system/controlDict` and a `0/p`
/// field when `p_values` is given).
fn write_case(dir: &Path, p: &Poly, enc: Enc, gz: bool, p_values: Option<&[f64]>) {
    for (name, bytes) in mesh_files(p, enc) {
        write(&dir.join("constant/polyMesh").join(name), &bytes, gz);
    }
    write(&dir.join("system/controlDict"), &foam("dictionary", Enc::Ascii, b"application icoFoam;"), false);
    if let Some(v) = p_values {
        write(&dir.join("0/p"), &scalar_field(v, enc), gz);
    }
}

#[test]
fn binary_32_and_64_bit_labels_and_gzip_read_like_ascii() {
    let d = tempfile::tempdir().unwrap();
    let p = hanging_node();
    let values = [10.0, 20.0, 30.0];
    let variants = [
        ("ascii", Enc::Ascii, false),
        ("bin32", Enc::Binary { label64: false }, false),
        ("bin64", Enc::Binary { label64: true }, false),
        ("gz", Enc::Ascii, true),
        ("bin64gz", Enc::Binary { label64: true }, true),
    ];
    let mut first: Option<SourceMesh> = None;
    for (name, enc, gz) in variants {
        let case = d.path().join(name);
        write_case(&case, &p, enc, gz, Some(&values));
        let m = read_at(&case, None).unwrap_or_else(|e| panic!("{name}: {e}"));
        assert_eq!(m.num_cells(), 2 + 20, "{name}");
        assert_eq!(m.format.contains("binary"), enc != Enc::Ascii, "{name}: {}", m.format);
        match &first {
            None => first = Some(m),
            Some(f) => {
                assert_eq!(f.points, m.points, "{name}");
                assert_eq!(f.blocks, m.blocks, "{name}");
                assert_eq!(f.cell_fields, m.cell_fields, "{name}");
            }
        }
    }
}

#[test]
fn a_hanging_node_polyhedron_becomes_conforming_tets_of_its_volume() {
    let d = tempfile::tempdir().unwrap();
    let case = d.path().join("refined");
    write_case(&case, &hanging_node(), Enc::Ascii, false, Some(&[10.0, 20.0, 30.0]));
    let m = read_at(&case, None).unwrap();
    let Block::Unstructured(c) = &m.blocks[0] else { panic!("unstructured") };
    // Cell 0 (the polyhedron) → 3 quads · 2 + 2 pentagons · 5 + 2 quads · 2
    // = 20 tets; then the two hexahedra.
    assert_eq!(c.types.iter().filter(|&&t| t == CellType::Tetra).count(), 20);
    assert_eq!(c.types.iter().filter(|&&t| t == CellType::Hexahedron).count(), 2);
    // 16 points + the cell centre + two pentagon centres.
    assert_eq!(m.points.len(), 19);
    assert!(m.notes.iter().any(|n| n.contains("split 1 polyhedral cells into 20 tets")), "{:?}", m.notes);
    let pv = &field(&m, "p").values;
    assert_eq!(pv.len(), 22);
    assert!(pv[..20].iter().all(|&v| v == 10.0) && pv[20..] == [20.0, 30.0]);
    // The centre is the average of the cell's 10 points.
    let centre = m.points[16];
    assert!(close(centre[0], 0.6) && close(centre[1], 0.5) && close(centre[2], 0.5), "{centre:?}");
    // Every tet of the polyhedron is positive: its faces were outward.
    let tets: Vec<&[u32]> = (0..20).map(|i| c.nodes(i)).collect();
    let vol: f64 = tets
        .iter()
        .map(|t| {
            let p = |k: usize| &m.points[t[k] as usize];
            let v = signed_tet_volume(p(0), p(1), p(2), p(3));
            assert!(v > 0.0, "{t:?}: {v}");
            v
        })
        .sum();
    assert!(close(vol, 1.0), "{vol}");
    // Conforming: the whole mesh's boundary is the box's surface (an open
    // internal face would add its area twice) and is convex.
    let (vol, area, convex, t) = tet_facts(&m);
    assert!(close(vol, 2.0) && close(area, 10.0) && convex, "{vol} {area} {convex}");
    // The cell centre's point value is the polyhedron's (only its tets touch it).
    let k = t.points.iter().position(|q| *q == centre).unwrap();
    assert!(close(t.scalar[k], 10.0), "{}", t.scalar[k]);
}

/// The hanging-node mesh decomposed: processor0 holds the polyhedron,
/// processor1 the two hexahedra, each numbering its points its own way
/// (reversed), so merging decides whether the shared faces conform.
#[test]
fn a_decomposed_case_merges_its_processors() {
    let global = hanging_node();
    let cells_of = [vec![0usize], vec![1, 2]];
    for with_addressing in [true, false] {
        let d = tempfile::tempdir().unwrap();
        let case = d.path().join("decomposed");
        write(&case.join("system/controlDict"), &foam("dictionary", Enc::Ascii, b"application icoFoam;"), false);
        for (proc, cells) in cells_of.iter().enumerate() {
            // The processor's cells as faces of global ids, then renumbered.
            let mut cell_faces: Vec<Vec<Vec<u32>>> = vec![vec![]; cells.len()];
            for (f, face) in global.faces.iter().enumerate() {
                let o = global.owner[f] as usize;
                let n = global.neighbour.get(f).map(|&n| n as usize);
                if let Some(k) = cells.iter().position(|&c| c == o) {
                    cell_faces[k].push(face.clone());
                }
                if let Some(k) = n.and_then(|n| cells.iter().position(|&c| c == n)) {
                    let mut r = face.clone();
                    r[1..].reverse();
                    cell_faces[k].push(r);
                }
            }
            let mut used: Vec<u32> = cell_faces.iter().flatten().flatten().copied().collect();
            used.sort_unstable();
            used.dedup();
            used.reverse();
            let local = |g: u32| used.iter().position(|&u| u == g).unwrap() as u32;
            let local_cells: Vec<Vec<Vec<u32>>> =
                cell_faces.iter().map(|c| c.iter().map(|f| f.iter().map(|&g| local(g)).collect()).collect()).collect();
            let pts = used.iter().map(|&g| global.points[g as usize]).collect();
            let lp = poly(pts, &local_cells);
            let dir = case.join(format!("processor{proc}"));
            let enc = if proc == 0 { Enc::Ascii } else { Enc::Binary { label64: false } };
            write_case(&dir, &lp, enc, false, Some(&cells.iter().map(|&c| 10.0 * (c + 1) as f64).collect::<Vec<_>>()));
            std::fs::remove_dir_all(dir.join("system")).unwrap();
            if with_addressing {
                let addr: Vec<i64> = used.iter().map(|&g| g as i64).collect();
                write(
                    &dir.join("constant/polyMesh/pointProcAddressing"),
                    &foam("labelList", enc, &label_list(&addr, enc)),
                    false,
                );
            }
        }
        let m = read_at(&case, None).unwrap();
        assert_eq!(m.format, "OpenFOAM (decomposed, 2 processors, binary)");
        let how = if with_addressing { "pointProcAddressing" } else { "identical coordinates" };
        assert!(
            m.notes.iter().any(|n| n.contains("merged 2 processors: 22 processor points became 16") && n.contains(how)),
            "{:?}",
            m.notes
        );
        assert_eq!(m.num_cells(), 22);
        assert_eq!(field(&m, "p").values[19..], [10.0, 20.0, 30.0]);
        let (vol, area, convex, _) = tet_facts(&m);
        assert!(close(vol, 2.0) && close(area, 10.0) && convex, "{with_addressing}: {vol} {area}");

        // A time step's fields alone, on the cells built once, are the
        // whole read's (the polyhedron's tets carry its value).
        let steps = tet_io::openfoam::CaseSteps::open(&case).unwrap();
        assert_eq!(steps.times().len(), 1);
        assert_eq!(steps.fields(0).unwrap().cell_fields, m.cell_fields);
        assert!(steps.fields(1).unwrap_err().to_string().contains("time step 1 does not exist"));

        // A processor without the time directory is an error naming it.
        std::fs::remove_dir_all(case.join("processor1/0")).unwrap();
        let e = steps.fields(0).unwrap_err().to_string();
        assert!(e.contains("time directory 0 is missing") && e.contains("processor1"), "{e}");
        let e = read_at(&case, None).unwrap_err();
        let msg = e.to_string();
        assert!(msg.contains("time directory 0 is missing") && msg.contains("processor1"), "{msg}");
    }
}

// ---------------------------------------------------------------------------
// Bad input: each error names the file and a line or byte.

fn malformed(e: ReadError) -> (String, Location, PathBuf) {
    match e {
        ReadError::Malformed { format: Format::OpenFoam, message, at, path } => (message, at, path),
        other => panic!("expected a malformed OpenFOAM file, got {other:?}"),
    }
}

fn broken(name: &str, p: &Poly, enc: Enc, values: Option<&[f64]>) -> (tempfile::TempDir, PathBuf) {
    let d = tempfile::tempdir().unwrap();
    let case = d.path().join(name);
    write_case(&case, p, enc, false, values);
    (d, case)
}

#[test]
fn bad_meshes_are_errors_naming_file_and_place() {
    let good = hanging_node();

    // A face naming a point past the list.
    let mut p = good.clone();
    p.faces[3][1] = 99;
    for enc in [Enc::Ascii, Enc::Binary { label64: true }] {
        let (_d, case) = broken("missing_point", &p, enc, None);
        let (msg, at, path) = malformed(read_at(&case, None).unwrap_err());
        assert!(msg.contains("face 3 names point 99, but the mesh has 16 points"), "{msg}");
        assert!(path.ends_with("constant/polyMesh/faces"), "{}", path.display());
        match enc {
            // Header 9 lines, blank, count, '(' then one face a line.
            Enc::Ascii => assert_eq!(at, Location::Line(16)),
            _ => assert!(matches!(at, Location::Byte(_)), "{at:?}"),
        }
    }

    // owner shorter than faces.
    let mut p = good.clone();
    p.owner.pop();
    let (_d, case) = broken("short_owner", &p, Enc::Ascii, None);
    let (msg, at, path) = malformed(read_at(&case, None).unwrap_err());
    assert!(msg.contains("owner has 15 entries but faces has 16 faces"), "{msg}");
    assert!(path.ends_with("owner") && matches!(at, Location::Line(_)), "{} {at:?}", path.display());

    // neighbour longer than faces.
    let mut p = good.clone();
    p.neighbour = vec![0; 17];
    let (_d, case) = broken("long_neighbour", &p, Enc::Binary { label64: false }, None);
    let (msg, at, path) = malformed(read_at(&case, None).unwrap_err());
    assert!(msg.contains("more entries than the 16 faces"), "{msg}");
    assert!(path.ends_with("neighbour") && matches!(at, Location::Byte(_)), "{} {at:?}", path.display());

    // A cell with 3 faces: a fourth cell owning three boundary faces.
    let mut p = good.clone();
    for f in [vec![0, 1, 4], vec![1, 5, 4], vec![0, 4, 5]] {
        p.faces.push(f);
        p.owner.push(3);
    }
    let (_d, case) = broken("three_faces", &p, Enc::Ascii, None);
    let (msg, at, path) = malformed(read_at(&case, None).unwrap_err());
    assert!(msg.contains("cell 3 has 3 faces (16, 17, 18); a cell needs at least 4"), "{msg}");
    assert!(path.ends_with("owner"), "{}", path.display());
    // owner entry 16: header 9 lines, blank, count, '(' then one a line.
    assert_eq!(at, Location::Line(29));

    // An owner naming a cell no face count can hold.
    let mut p = good.clone();
    p.owner[5] = 1_000_000;
    let (_d, case) = broken("huge_cell", &p, Enc::Ascii, None);
    let (msg, _, path) = malformed(read_at(&case, None).unwrap_err());
    assert!(msg.contains("names cell 1000000") && path.ends_with("owner"), "{msg}");

    // A polyhedron that is not closed.
    let mut p = good.clone();
    let k = p.faces.iter().position(|f| f.len() == 5).unwrap();
    p.faces[k].remove(3);
    let (_d, case) = broken("open_cell", &p, Enc::Ascii, None);
    let (msg, _, path) = malformed(read_at(&case, None).unwrap_err());
    assert!(msg.contains("cell 0 is not closed"), "{msg}");
    assert!(path.ends_with("owner"), "{}", path.display());

    // Truncated binary points.
    let (_d, case) = broken("truncated", &good, Enc::Binary { label64: false }, None);
    let pts = case.join("constant/polyMesh/points");
    let bytes = std::fs::read(&pts).unwrap();
    std::fs::write(&pts, &bytes[..bytes.len() - 100]).unwrap();
    let (msg, at, path) = malformed(read_at(&case, None).unwrap_err());
    assert!(msg.contains("truncated") && path == pts && matches!(at, Location::Byte(_)), "{msg} {at:?}");

    // A mesh directory without owner.
    let (_d, case) = broken("no_owner", &good, Enc::Ascii, None);
    std::fs::remove_file(case.join("constant/polyMesh/owner")).unwrap();
    let (msg, _, path) = malformed(read_at(&case, None).unwrap_err());
    assert!(msg.contains("no 'owner' file") && path.ends_with("constant/polyMesh"), "{msg}");
}

#[test]
fn bad_fields_and_times_are_errors_naming_the_file() {
    let good = hanging_node();
    // Two values for three cells.
    let (_d, case) = broken("short_field", &good, Enc::Ascii, Some(&[1.0, 2.0]));
    let (msg, at, path) = malformed(read_at(&case, None).unwrap_err());
    assert!(msg.contains("internalField has 2 values, expected 3"), "{msg}");
    assert!(path.ends_with("0/p"), "{}", path.display());
    assert_eq!(at, Location::Line(13));
    // The same in binary: the count is text, so still a line.
    let (_d, case) = broken("short_field_bin", &good, Enc::Binary { label64: false }, Some(&[1.0, 2.0]));
    let (msg, _, path) = malformed(read_at(&case, None).unwrap_err());
    assert!(msg.contains("2 values, expected 3") && path.ends_with("0/p"), "{msg}");
    // A time step past the last.
    let (_d, case) = broken("times", &good, Enc::Ascii, Some(&[1.0, 2.0, 3.0]));
    let (msg, _, path) = malformed(read_at(&case, Some(1)).unwrap_err());
    assert!(msg.contains("time step 1 does not exist: the case has 1 time directories (0)"), "{msg}");
    assert_eq!(path, case);
    // 0.orig is not a time; a case without times reads with no fields.
    std::fs::rename(case.join("0"), case.join("0.orig")).unwrap();
    let m = read_at(&case, None).unwrap();
    assert!(m.cell_fields.is_empty());
    assert!(m.notes.iter().any(|n| n.contains("no time directories")), "{:?}", m.notes);
}

/// The in-memory entry point (what the fuzz target drives) names the file
/// in its messages.
#[test]
fn read_poly_mesh_in_memory() {
    let p = hanging_node();
    let files = mesh_files(&p, Enc::Binary { label64: false });
    let m = tet_io::openfoam::read_poly_mesh(&files[0].1, &files[1].1, &files[2].1, &files[3].1).unwrap();
    assert_eq!(m.num_cells(), 22);
    let e = tet_io::openfoam::read_poly_mesh(&files[0].1, &files[1].1, &files[3].1, &files[3].1).unwrap_err();
    assert!(e.message.starts_with("owner: owner has 3 entries"), "{e}");
}
