//! The reference renderer against closed forms: a single tet with a constant
//! transfer function, linear fields on split cubes (the segments of a linear
//! field compose to one segment), rays exactly through edges and vertices,
//! non-convex meshes that rays leave and re-enter, a camera inside, parallel
//! projection, slivers and jittered grids.

use glam::DVec3;
use proptest::prelude::*;
use tet_mesh::{
    build_adjacency, tetrahedralize, Adjacency, Block, ConvertOptions, Field, SourceMesh, SplitMode, TetMesh,
};
use tet_preint::{integrate_segment, ColorNode, Emission, OpacityNode, Rgba, TransferFunction};
use tet_render::{Camera, RayScratch, ReferenceOptions, ReferenceRenderer, ViewSpec};

fn tf_const(a: f64, rgb: [f64; 3]) -> TransferFunction {
    TransferFunction::new(
        vec![ColorNode { x: 0.0, rgb }],
        vec![OpacityNode { x: 0.0, a }],
        1.0,
        Emission::Density,
        false,
    )
    .unwrap()
}

/// Several nodes inside [lo, hi] so segments are split at breakpoints.
fn tf_ramp(lo: f64, hi: f64) -> TransferFunction {
    let x = |f: f64| lo + f * (hi - lo);
    TransferFunction::new(
        vec![
            ColorNode { x: x(0.0), rgb: [0.1, 0.3, 0.9] },
            ColorNode { x: x(0.4), rgb: [0.9, 0.9, 0.2] },
            ColorNode { x: x(1.0), rgb: [0.8, 0.1, 0.1] },
        ],
        vec![
            OpacityNode { x: x(0.0), a: 0.05 },
            OpacityNode { x: x(0.3), a: 0.9 },
            OpacityNode { x: x(0.7), a: 0.2 },
            OpacityNode { x: x(1.0), a: 1.5 },
        ],
        1.0,
        Emission::Density,
        false,
    )
    .unwrap()
}

/// A structured grid of `n` points per axis from `lo` with `spacing`, split
/// into tets, scalar `field(p)`; interior points moved by `jitter(index)`.
fn grid(
    n: [usize; 3],
    lo: [f64; 3],
    spacing: f64,
    split: SplitMode,
    field: impl Fn([f64; 3]) -> f64,
    jitter: impl Fn(usize) -> [f64; 3],
) -> TetMesh {
    let mut points = Vec::new();
    for k in 0..n[2] {
        for j in 0..n[1] {
            for i in 0..n[0] {
                let mut p = [lo[0] + i as f64 * spacing, lo[1] + j as f64 * spacing, lo[2] + k as f64 * spacing];
                let interior = i > 0 && j > 0 && k > 0 && i + 1 < n[0] && j + 1 < n[1] && k + 1 < n[2];
                if interior {
                    let d = jitter(points.len());
                    for a in 0..3 {
                        p[a] += d[a] * spacing;
                    }
                }
                points.push(p);
            }
        }
    }
    let scalar = points.iter().map(|&p| field(p)).collect();
    let source = SourceMesh {
        points,
        blocks: vec![Block::Structured { dims: n, first_point: 0 }],
        point_fields: vec![Field::new("s", 1, scalar)],
        ..Default::default()
    };
    let opts = ConvertOptions { split, ..Default::default() };
    tetrahedralize(&source, &opts, &mut |_| {}).unwrap().0
}

fn no_jitter(_: usize) -> [f64; 3] {
    [0.0; 3]
}

/// Keeps the tets whose centroid satisfies `keep` (the points stay).
fn carve(mesh: &TetMesh, keep: impl Fn(DVec3) -> bool) -> TetMesh {
    let mut out = mesh.clone();
    out.tets.to_mut().retain(|t| {
        let c = t.iter().map(|&v| DVec3::from(mesh.points[v as usize])).sum::<DVec3>() / 4.0;
        keep(c)
    });
    out
}

fn adjacency(mesh: &TetMesh) -> Adjacency {
    build_adjacency(&mesh.points, &mesh.tets).unwrap()
}

/// The parameter interval of the line o + t·u inside the box, if any.
fn clip_box(o: DVec3, u: DVec3, lo: DVec3, hi: DVec3) -> Option<(f64, f64)> {
    let (mut t0, mut t1) = (f64::NEG_INFINITY, f64::INFINITY);
    for a in 0..3 {
        if u[a] == 0.0 {
            if o[a] < lo[a] || o[a] > hi[a] {
                return None;
            }
        } else {
            let (x, y) = ((lo[a] - o[a]) / u[a], (hi[a] - o[a]) / u[a]);
            t0 = t0.max(x.min(y));
            t1 = t1.min(x.max(y));
        }
    }
    (t1 > t0).then_some((t0, t1))
}

/// Front-to-back composite of the analytic integrals over disjoint
/// intervals of a line through a linear field.
fn analytic(
    tf: &TransferFunction,
    field: &dyn Fn(DVec3) -> f64,
    o: DVec3,
    u: DVec3,
    mut pieces: Vec<(f64, f64)>,
) -> [f64; 4] {
    pieces.sort_by(|a, b| a.0.total_cmp(&b.0));
    let mut acc = Rgba::default();
    for (t0, t1) in pieces {
        if t1 > t0 {
            let c = integrate_segment(tf, field(o + u * t0), field(o + u * t1), t1 - t0);
            acc = acc.over(c);
        }
    }
    acc.to_array()
}

fn assert_close(got: [f64; 4], want: [f64; 4], tol: f64, what: &str) {
    for c in 0..4 {
        assert!((got[c] - want[c]).abs() <= tol, "{what}: channel {c}: got {got:?}, want {want:?}");
    }
}

/// Renders every pixel of `spec` with the reference and compares it with
/// `expected(origin, unit_dir, t_start)`.
fn check_view(
    r: &ReferenceRenderer,
    spec: &ViewSpec,
    tf: &TransferFunction,
    tol: f64,
    expected: &dyn Fn(DVec3, DVec3, f64) -> [f64; 4],
) -> usize {
    let cam = Camera::new(spec).unwrap();
    let (img, stats) = r.render(&cam, tf, &ReferenceOptions::default(), &|_, _| {}).unwrap();
    assert_eq!(stats.walk_failures, 0);
    assert_eq!(stats.rays, (spec.size[0] * spec.size[1]) as u64);
    let mut scratch = RayScratch::default();
    let mut hits = 0;
    for j in 0..cam.height() {
        for i in 0..cam.width() {
            let (x, y) = (i as f64 + 0.5, j as f64 + 0.5);
            let (o, d) = cam.ray(x, y);
            let t_start = if cam.is_parallel() { f64::NEG_INFINITY } else { cam.near_depth() / d.dot(cam.forward()) };
            let want = expected(o, d, t_start);
            let got = r.trace_pixel(&cam, x, y, tf, &ReferenceOptions::default(), &mut scratch).rgba;
            assert_close(got, want, tol, &format!("pixel ({i}, {j}) of {spec:?}"));
            let px = img.pixel(i, j);
            for c in 0..4 {
                assert_eq!(px[c], got[c] as f32, "image equals trace_pixel");
            }
            hits += (want[3] > 0.0) as usize;
        }
    }
    hits
}

fn views(lo: DVec3, hi: DVec3, size: u32) -> Vec<ViewSpec> {
    let base = ViewSpec::framing(lo.into(), hi.into(), [size, size]);
    let mut out = Vec::new();
    for (az, el) in [(0.0, 0.0), (33.0, 21.0), (-70.0, 48.0), (125.0, -37.0)] {
        for parallel in [false, true] {
            let mut v = base.orbit(az, el, 1.2);
            v.parallel = parallel;
            out.push(v);
        }
    }
    out
}

#[test]
fn single_tet_constant_tf_matches_closed_form() {
    let mesh = TetMesh {
        points: vec![[0.0, 0.0, 0.0], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]],
        tets: vec![[0, 1, 2, 3]].into(),
        scalar: vec![0.0; 4],
        scalar_name: "s".into(),
        point_fields: Vec::new(),
    };
    let adj = adjacency(&mesh);
    let r = ReferenceRenderer::new(&mesh, &adj).unwrap();
    let rgb = [0.9, 0.5, 0.2];
    let tf = tf_const(2.5, rgb);
    // Chord through the tet by clipping against its four half-spaces
    // (x, y, z ≥ 0 and x + y + z ≤ 1): an independent computation.
    let chord = |o: DVec3, u: DVec3| {
        let (mut t0, mut t1) = (f64::NEG_INFINITY, f64::INFINITY);
        for (n, c) in [(DVec3::X, 0.0), (DVec3::Y, 0.0), (DVec3::Z, 0.0), (-DVec3::ONE, -1.0)] {
            // n·(o + t u) ≥ c
            let (a, b) = (n.dot(u), n.dot(o) - c);
            if a == 0.0 {
                if b < 0.0 {
                    return 0.0;
                }
            } else if a > 0.0 {
                t0 = t0.max(-b / a);
            } else {
                t1 = t1.min(-b / a);
            }
        }
        (t1 - t0).max(0.0)
    };
    let mut hits = 0;
    for spec in views(DVec3::ZERO, DVec3::ONE, 24) {
        hits += check_view(&r, &spec, &tf, 1e-12, &|o, u, _| {
            let a = 1.0 - (-2.5 * chord(o, u)).exp();
            [rgb[0] * a, rgb[1] * a, rgb[2] * a, a]
        });
    }
    assert!(hits > 500, "{hits}");
}

#[test]
fn linear_field_on_split_cubes_composes_to_one_segment() {
    let field = |p: [f64; 3]| 0.3 * p[0] - 0.2 * p[1] + 0.5 * p[2];
    let fv = move |p: DVec3| field(p.into());
    let tf = tf_ramp(-0.6, 1.6);
    for split in [SplitMode::Five, SplitMode::Six] {
        let mesh = grid([5, 4, 6], [0.0; 3], 0.5, split, field, no_jitter);
        let adj = adjacency(&mesh);
        assert!(adj.convex);
        let r = ReferenceRenderer::new(&mesh, &adj).unwrap();
        let (lo, hi) = (DVec3::ZERO, DVec3::new(2.0, 1.5, 2.5));
        let mut hits = 0;
        for spec in views(lo, hi, 20) {
            hits += check_view(&r, &spec, &tf, 1e-10, &|o, u, ts| {
                let pieces = clip_box(o, u, lo, hi).map(|(a, b)| vec![(a.max(ts), b)]).unwrap_or_default();
                analytic(&tf, &fv, o, u, pieces)
            });
        }
        assert!(hits > 1000, "{hits}");
    }
}

/// Integer lattice lines: along axes, face and space diagonals, through
/// vertices and along or across edges of both splits.
#[test]
fn rays_through_edges_and_vertices_are_neither_lost_nor_doubled() {
    let field = |p: [f64; 3]| 0.25 * p[0] + 0.5 * p[1] - 0.125 * p[2];
    let fv = move |p: DVec3| field(p.into());
    let rho = 0.7;
    let tf_c = tf_const(rho, [0.2, 0.6, 1.0]);
    let tf_r = tf_ramp(-0.4, 2.3);
    let dirs = [
        [0, 0, 1],
        [1, 0, 0],
        [0, 1, 0],
        [1, 1, 0],
        [1, 0, 1],
        [0, 1, 1],
        [1, 1, 1],
        [1, -1, 1],
        [-1, 1, 1],
        [1, 2, 0],
        [2, 1, 1],
        [1, 2, 3],
        [3, -1, 2],
    ];
    let (lo, hi) = (DVec3::ZERO, DVec3::splat(3.0));
    for split in [SplitMode::Five, SplitMode::Six] {
        let mesh = grid([4, 4, 4], [0.0; 3], 1.0, split, field, no_jitter);
        let adj = adjacency(&mesh);
        let r = ReferenceRenderer::new(&mesh, &adj).unwrap();
        let mut scratch = RayScratch::default();
        let mut checked = 0;
        for d in dirs {
            let d = DVec3::new(d[0] as f64, d[1] as f64, d[2] as f64);
            // Lines through every lattice point and half-lattice point of a
            // slab, started far outside.
            for a in -2..=8 {
                for b in -2..=8 {
                    for c in [0, 3] {
                        let through = DVec3::new(a as f64 * 0.5, b as f64 * 0.5, c as f64 * 0.5);
                        let o = through - d * 10.0;
                        let u = d.normalize();
                        let Some((t0, t1)) = clip_box(o, u, lo, hi) else { continue };
                        // A line lying in a boundary face's plane grazes the
                        // surface: inside or outside is a matter of
                        // perturbation, both answers are right.
                        let grazing = (0..3).any(|k| d[k] == 0.0 && (o[k] == lo[k] || o[k] == hi[k]));
                        // The whole line through o and o + d under `tf`.
                        let mut trace = |tf: &TransferFunction| {
                            r.trace_line(o, o + d, f64::NEG_INFINITY, tf, &ReferenceOptions::default(), &mut scratch)
                        };
                        let res = trace(&tf_c);
                        assert_eq!(res.stats.walk_failures, 0, "{o} {d}");
                        let want = 1.0 - (-rho * (t1 - t0)).exp();
                        if grazing {
                            assert!(
                                res.rgba[3] == 0.0 || (res.rgba[3] - want).abs() < 1e-12,
                                "{o} {d}: {:?}",
                                res.rgba
                            );
                            continue;
                        }
                        assert!((res.rgba[3] - want).abs() < 1e-12, "{split:?} {o} {d}: α {} want {want}", res.rgba[3]);
                        let got = trace(&tf_r);
                        let want = analytic(&tf_r, &fv, o, u, vec![(t0, t1)]);
                        assert_close(got.rgba, want, 1e-10, &format!("{split:?} line {o} + t {d}"));
                        checked += 1;
                    }
                }
            }
        }
        assert!(checked > 300, "{checked}");
    }
}

/// Parallel projection whose pixel centres fall exactly on the vertex
/// columns of a grid with spacing 2: every ray runs along a z edge.
#[test]
fn parallel_rays_along_grid_edges() {
    let field = |p: [f64; 3]| p[0] - 0.5 * p[1] + 0.25 * p[2];
    let fv = move |p: DVec3| field(p.into());
    let tf = tf_ramp(-6.0, 6.0);
    for split in [SplitMode::Five, SplitMode::Six] {
        let mesh = grid([4, 4, 4], [-3.0; 3], 2.0, split, field, no_jitter);
        let adj = adjacency(&mesh);
        let r = ReferenceRenderer::new(&mesh, &adj).unwrap();
        let spec = ViewSpec {
            parallel: true,
            parallel_scale: 4.0,
            ..ViewSpec::looking_at([0.0, 0.0, 20.0], [0.0; 3], [0.0, 1.0, 0.0], [4, 4])
        };
        let cam = Camera::new(&spec).unwrap();
        let (img, stats) = r.render(&cam, &tf, &ReferenceOptions::default(), &|_, _| {}).unwrap();
        assert_eq!(stats.walk_failures, 0);
        for (i, j) in [(1, 1), (1, 2), (2, 1), (2, 2)] {
            let (o, d) = cam.ray(i as f64 + 0.5, j as f64 + 0.5);
            assert!(o.x.fract() == 0.0 && o.y.fract() == 0.0 && (o.x as i64).rem_euclid(2) == 1, "{o}");
            let want = analytic(&tf, &fv, o, d, vec![clip_box(o, d, DVec3::splat(-3.0), DVec3::splat(3.0)).unwrap()]);
            let px = img.pixel(i, j);
            assert_close(px.map(f64::from), want, 1e-6, &format!("pixel {i},{j}"));
        }
    }
}

#[test]
fn non_convex_meshes_are_left_and_re_entered() {
    let field = |p: [f64; 3]| 0.2 * p[0] + 0.3 * p[1] - 0.1 * p[2];
    let fv = move |p: DVec3| field(p.into());
    let tf = tf_ramp(-0.5, 2.5);
    // A U: the 4×4×2 box minus the notch 1 < x < 3, y > 2.
    let full = grid([5, 5, 3], [0.0; 3], 1.0, SplitMode::Five, field, no_jitter);
    let u_mesh = carve(&full, |c| !(c.x > 1.0 && c.x < 3.0 && c.y > 2.0));
    let boxes_u = [
        (DVec3::ZERO, DVec3::new(4.0, 2.0, 2.0)),
        (DVec3::new(0.0, 2.0, 0.0), DVec3::new(1.0, 4.0, 2.0)),
        (DVec3::new(3.0, 2.0, 0.0), DVec3::new(4.0, 4.0, 2.0)),
    ];
    // Two separate boxes: the 4×4×2 grid minus the slab 1 < x < 3.
    let two = carve(&full, |c| !(c.x > 1.0 && c.x < 3.0));
    let boxes_two = [(DVec3::ZERO, DVec3::new(1.0, 4.0, 2.0)), (DVec3::new(3.0, 0.0, 0.0), DVec3::new(4.0, 4.0, 2.0))];
    for (mesh, boxes) in [(&u_mesh, &boxes_u[..]), (&two, &boxes_two[..])] {
        let adj = adjacency(mesh);
        assert!(!adj.convex);
        let r = ReferenceRenderer::new(mesh, &adj).unwrap();
        let expected = |o: DVec3, u: DVec3, ts: f64| {
            let pieces =
                boxes.iter().filter_map(|&(lo, hi)| clip_box(o, u, lo, hi)).map(|(a, b)| (a.max(ts), b)).collect();
            analytic(&tf, &fv, o, u, pieces)
        };
        let mut hits = 0;
        for spec in views(DVec3::ZERO, DVec3::new(4.0, 4.0, 2.0), 20) {
            hits += check_view(&r, &spec, &tf, 1e-10, &expected);
        }
        assert!(hits > 1000);
        // Along x through the gap: out, in again.
        let mut scratch = RayScratch::default();
        let o = DVec3::new(-1.0, 3.3, 0.7);
        let res = r.trace_line(o, o + DVec3::X, f64::NEG_INFINITY, &tf, &ReferenceOptions::default(), &mut scratch);
        assert_eq!(res.stats.entries, 2);
        assert_close(res.rgba, expected(o, DVec3::X, f64::NEG_INFINITY), 1e-12, "through the gap");
    }
}

#[test]
fn camera_inside_the_mesh_starts_at_the_near_plane() {
    let field = |p: [f64; 3]| 0.3 * p[0] + 0.1 * p[1] + 0.4 * p[2];
    let fv = move |p: DVec3| field(p.into());
    let tf = tf_ramp(0.0, 2.4);
    let mesh = grid([5, 5, 5], [0.0; 3], 0.75, SplitMode::Five, field, no_jitter);
    let adj = adjacency(&mesh);
    let r = ReferenceRenderer::new(&mesh, &adj).unwrap();
    let (lo, hi) = (DVec3::ZERO, DVec3::splat(3.0));
    for (pos, focal) in
        [([1.1, 1.3, 1.7], [2.0, 1.0, 0.5]), ([2.9, 0.2, 0.4], [0.0, 3.0, 3.0]), ([1.5; 3], [1.5, 0.0, 1.4])]
    {
        let spec = ViewSpec { view_angle: 70.0, ..ViewSpec::looking_at(pos, focal, [0.0, 0.0, 1.0], [24, 18]) };
        let hits = check_view(&r, &spec, &tf, 1e-10, &|o, u, ts| {
            let pieces = clip_box(o, u, lo, hi).map(|(a, b)| vec![(a.max(ts), b)]).unwrap_or_default();
            analytic(&tf, &fv, o, u, pieces)
        });
        assert_eq!(hits, 24 * 18, "every ray starts inside");
    }
}

#[test]
fn slivers_give_finite_exact_results() {
    // A tet fanned from an interior point 1e-13 from one face: that fan tet
    // is a sliver; a linear field on the fan equals the field on the tet.
    let big = [[0.0, 0.0, 0.0], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]];
    let inner = [0.3, 0.3, 1e-13];
    let mut points = big.to_vec();
    points.push(inner);
    let field = |p: &[f64; 3]| 1.0 + p[0] - 2.0 * p[1] + 3.0 * p[2];
    let scalar = points.iter().map(field).collect();
    // Replace vertex f of the big tet by the inner point: positive, since
    // the inner point is on the same side of face f as vertex f.
    let tets = (0..4)
        .map(|f| {
            let mut t = [0u32, 1, 2, 3];
            t[f] = 4;
            t
        })
        .collect();
    let mesh = TetMesh { points, tets, scalar, scalar_name: "s".into(), point_fields: Vec::new() };
    let adj = adjacency(&mesh);
    assert_eq!(adj.boundary_faces.len(), 4);
    let r = ReferenceRenderer::new(&mesh, &adj).unwrap();
    let tf = tf_ramp(-1.0, 4.0);
    let tet_chord = |o: DVec3, u: DVec3| {
        let (mut t0, mut t1) = (f64::NEG_INFINITY, f64::INFINITY);
        for (n, c) in [(DVec3::X, 0.0), (DVec3::Y, 0.0), (DVec3::Z, 0.0), (-DVec3::ONE, -1.0)] {
            let (a, b) = (n.dot(u), n.dot(o) - c);
            if a > 0.0 {
                t0 = t0.max(-b / a);
            } else if a < 0.0 {
                t1 = t1.min(-b / a);
            } else if b < 0.0 {
                return None;
            }
        }
        (t1 > t0).then_some((t0, t1))
    };
    let fv = move |p: DVec3| field(&p.into());
    for spec in views(DVec3::ZERO, DVec3::ONE, 16) {
        check_view(&r, &spec, &tf, 1e-9, &|o, u, ts| {
            let pieces = tet_chord(o, u).map(|(a, b)| vec![(a.max(ts), b)]).unwrap_or_default();
            analytic(&tf, &fv, o, u, pieces)
        });
    }
}

#[test]
fn early_termination_changes_nothing_visible_and_can_be_disabled() {
    let field = |p: [f64; 3]| p[0] + p[1];
    let mesh = grid([6, 6, 6], [0.0; 3], 1.0, SplitMode::Six, field, no_jitter);
    let adj = adjacency(&mesh);
    let r = ReferenceRenderer::new(&mesh, &adj).unwrap();
    let tf = tf_const(40.0, [1.0, 0.5, 0.25]);
    let cam = Camera::new(&ViewSpec::framing([0.0; 3], [5.0; 3], [16, 16]).orbit(20.0, 30.0, 1.5)).unwrap();
    let on = ReferenceOptions::default();
    let off = ReferenceOptions { early_termination: false, ..on };
    let (a, sa) = r.render(&cam, &tf, &on, &|_, _| {}).unwrap();
    let (b, sb) = r.render(&cam, &tf, &off, &|_, _| {}).unwrap();
    assert!(sa.terminated_early > 100 && sb.terminated_early == 0);
    assert!(sa.segments < sb.segments);
    assert!(tet_render::diff(&a, &b).unwrap().max_abs <= 1e-8);
    // Deterministic: the same render twice is bitwise equal.
    let (a2, sa2) = r.render(&cam, &tf, &on, &|_, _| {}).unwrap();
    assert_eq!(a, a2);
    assert_eq!(sa, sa2);
}

#[test]
fn bad_input_is_an_error() {
    let mesh = grid([2, 2, 2], [0.0; 3], 1.0, SplitMode::Five, |p| p[0], no_jitter);
    let adj = adjacency(&mesh);
    let mut short = adj.clone();
    short.neighbors.to_mut().pop();
    assert!(ReferenceRenderer::new(&mesh, &short).unwrap_err().to_string().contains("adjacency"));
    let mut nan = mesh.clone();
    nan.points[3][1] = f64::NAN;
    assert!(ReferenceRenderer::new(&nan, &adj).unwrap_err().to_string().contains("point 3"));
    let r = ReferenceRenderer::new(&mesh, &adj).unwrap();
    let normalized = TransferFunction::from_json(
        r#"{"normalized": true, "color": [[0,1,1,1]], "opacity": [[0,1]], "unit_distance": 1}"#,
    )
    .unwrap();
    let cam = Camera::new(&ViewSpec::framing([0.0; 3], [1.0; 3], [4, 4])).unwrap();
    assert!(r.render(&cam, &normalized, &ReferenceOptions::default(), &|_, _| {}).is_err());
}

proptest! {
    #![proptest_config(ProptestConfig { cases: 48, ..ProptestConfig::default() })]
    /// Jittered interior points keep the box and a linear field stays
    /// linear on any tets: random lines must match the analytic integral.
    #[test]
    fn jittered_grids_match_the_analytic_line_integral(
        seed in 0u64..1000,
        ox in -1.0f64..4.0, oy in -1.0f64..4.0,
        dx in -1.0f64..1.0, dy in -1.0f64..1.0, dz in 0.2f64..1.0,
        six in any::<bool>(),
    ) {
        let jitter = move |i: usize| {
            let mut s = seed.wrapping_mul(0x9E3779B97F4A7C15) ^ (i as u64).wrapping_mul(0xBF58476D1CE4E5B9);
            let mut next = || { s ^= s >> 31; s = s.wrapping_mul(0x94D049BB133111EB); s ^= s >> 29; (s >> 11) as f64 / (1u64 << 53) as f64 - 0.5 };
            [0.25 * next(), 0.25 * next(), 0.25 * next()]
        };
        let field = |p: [f64; 3]| 0.4 * p[0] - 0.3 * p[1] + 0.2 * p[2];
        let fv = move |p: DVec3| field(p.into());
        let split = if six { SplitMode::Six } else { SplitMode::Five };
        let mesh = grid([5, 5, 5], [0.0; 3], 0.75, split, field, jitter);
        let adj = adjacency(&mesh);
        let r = ReferenceRenderer::new(&mesh, &adj).unwrap();
        let tf = tf_ramp(-1.0, 2.0);
        let o = DVec3::new(ox, oy, -2.0);
        let d = DVec3::new(dx, dy, dz);
        let mut scratch = RayScratch::default();
        let res = r.trace_line(o, o + d, f64::NEG_INFINITY, &tf, &ReferenceOptions::default(), &mut scratch);
        prop_assert_eq!(res.stats.walk_failures, 0);
        let u = (o + d - o).normalize();
        let pieces = clip_box(o, u, DVec3::ZERO, DVec3::splat(3.0)).map(|p| vec![p]).unwrap_or_default();
        let want = analytic(&tf, &fv, o, u, pieces);
        for c in 0..4 {
            prop_assert!((res.rgba[c] - want[c]).abs() < 1e-10, "{:?} vs {:?}", res.rgba, want);
        }
    }
}
