//! Per-vertex gradients: exact for linear fields, convergent on smooth
//! fields, finite and bounded at boundaries, next to slivers and far from
//! the origin.
mod common;

use common::{capped_sliver, grid, on_boundary};
use tet_analysis::{Analyzer, GradientMethod};

const METHODS: [GradientMethod; 2] = [GradientMethod::LeastSquares, GradientMethod::TetAverage];

fn dist(a: [f64; 3], b: [f64; 3]) -> f64 {
    ((a[0] - b[0]).powi(2) + (a[1] - b[1]).powi(2) + (a[2] - b[2]).powi(2)).sqrt()
}

#[test]
fn linear_fields_are_exact_even_far_from_the_origin() {
    let lin = |p: [f64; 3]| 3.0 - 2.0 * p[0] + 0.7 * p[1] + 5.0 * p[2];
    for offset in [0.0, 1e6] {
        // Jittered interior: no symmetry helps the fit.
        let m = grid(7, 0.6, offset, lin);
        let an = Analyzer::from_mesh(&m).unwrap();
        for method in METHODS {
            for (v, g) in an.vertex_gradients(method).iter().enumerate() {
                let e = dist(*g, [-2.0, 0.7, 5.0]);
                // With coordinates near 1e6 the differences carry ~1e-10 relative error.
                let tol = if offset == 0.0 { 1e-12 } else { 1e-7 };
                assert!(e < tol, "{method:?} offset {offset}: vertex {v} gradient {g:?} error {e:e}");
            }
        }
        for g in &an.tet_gradients().gradient {
            assert!(dist(*g, [-2.0, 0.7, 5.0]) < if offset == 0.0 { 1e-12 } else { 1e-7 });
        }
    }
}

fn field(p: [f64; 3]) -> f64 {
    (2.0 * p[0]).sin() * (3.0 * p[1]).cos() + p[2] * p[2] * p[0]
}

fn grad(p: [f64; 3]) -> [f64; 3] {
    [
        2.0 * (2.0 * p[0]).cos() * (3.0 * p[1]).cos() + p[2] * p[2],
        -3.0 * (2.0 * p[0]).sin() * (3.0 * p[1]).sin(),
        2.0 * p[2] * p[0],
    ]
}

/// (max error over all vertices, RMS over interior vertices, RMS over boundary vertices).
fn errors(n: usize, jitter: f64, method: GradientMethod) -> (f64, f64, f64) {
    let m = grid(n, jitter, 0.0, field);
    let an = Analyzer::from_mesh(&m).unwrap();
    let g = an.vertex_gradients(method);
    let (mut max, mut si, mut ni, mut sb, mut nb) = (0.0f64, 0.0, 0, 0.0, 0);
    for (v, p) in m.points.iter().enumerate() {
        let e = dist(g[v], grad(*p));
        max = max.max(e);
        if on_boundary(*p, 0.0) {
            sb += e * e;
            nb += 1;
        } else {
            si += e * e;
            ni += 1;
        }
    }
    (max, (si / ni as f64).sqrt(), (sb / nb as f64).sqrt())
}

#[test]
fn smooth_field_errors_converge_under_refinement() {
    // Spacings 1/8, 1/16, 1/32. Printed rates: `cargo test -p tet_analysis
    // --test gradients -- --nocapture`.
    for jitter in [0.0, 0.4] {
        for method in METHODS {
            let e: Vec<(f64, f64, f64)> = [9, 17, 33].iter().map(|&n| errors(n, jitter, method)).collect();
            let rate = |a: f64, b: f64| (a / b).log2();
            let r_max: Vec<f64> = e.windows(2).map(|w| rate(w[0].0, w[1].0)).collect();
            let r_int: Vec<f64> = e.windows(2).map(|w| rate(w[0].1, w[1].1)).collect();
            let r_bnd: Vec<f64> = e.windows(2).map(|w| rate(w[0].2, w[1].2)).collect();
            println!(
                "{:<11} jitter {jitter}: max err {:.2e} {:.2e} {:.2e} (rates {:.2} {:.2}); interior RMS {:.2e} {:.2e} {:.2e} (rates {:.2} {:.2}); boundary RMS rates {:.2} {:.2}",
                method.name(), e[0].0, e[1].0, e[2].0, r_max[0], r_max[1], e[0].1, e[1].1, e[2].1, r_int[0], r_int[1], r_bnd[0], r_bnd[1]
            );
            // First order everywhere (one-sided fits at the boundary).
            for r in r_max.iter().chain(&r_bnd) {
                assert!(*r > 0.85, "{method:?} jitter {jitter}: rate {r} (errors {e:?})");
            }
            // Second order inside an unjittered grid (each one-ring is
            // symmetric enough that the O(h) terms cancel), first order on
            // jittered ones.
            let expected = if jitter == 0.0 { 1.8 } else { 0.85 };
            for r in &r_int {
                assert!(*r > expected, "{method:?} jitter {jitter}: interior rate {r} (errors {e:?})");
            }
        }
    }
}

#[test]
fn slivers_give_finite_bounded_vertex_gradients() {
    let f = |p: [f64; 3]| p[0] * p[0] + 2.0 * p[1] * p[1] + p[2] * p[2] + 3.0 * p[0] * p[1];
    let df = |p: [f64; 3]| [2.0 * p[0] + 3.0 * p[1], 4.0 * p[1] + 3.0 * p[0], 2.0 * p[2]];
    for eps in [1e-2, 1e-5, 1e-9, 1e-13] {
        let m = capped_sliver(eps, f);
        tet_mesh::check_tet_mesh(&m).unwrap();
        let an = Analyzer::from_mesh(&m).unwrap();
        // The sliver's own gradient is that of its linear interpolant, whose
        // normal component grows like 1/eps for a curved field: honest but
        // useless for shading; vertex gradients must not inherit it.
        let sliver_g = an.tet_gradients().magnitude(0);
        assert!(sliver_g.is_finite());
        for method in METHODS {
            for (v, g) in an.vertex_gradients(method).iter().enumerate() {
                let e = dist(*g, df(m.points[v]));
                // The field's second derivatives are ≤ 4 over cells of size 1:
                // first-order methods err by a few units, never by 1/eps.
                assert!(g.iter().all(|c| c.is_finite()) && e < 8.0, "{method:?} eps {eps}: vertex {v} {g:?} error {e}");
            }
        }
        // Linear fields stay exact next to the sliver.
        let m = capped_sliver(eps, |p| 1.0 + p[0] - 2.0 * p[1] + 4.0 * p[2]);
        let an = Analyzer::from_mesh(&m).unwrap();
        for method in METHODS {
            for g in an.vertex_gradients(method) {
                assert!(dist(*g, [1.0, -2.0, 4.0]) < 1e-6, "{method:?} eps {eps}: {g:?}");
            }
        }
    }
}

#[test]
fn boundary_vertices_and_offsets_do_not_degrade_the_fit() {
    let a = grid(9, 0.3, 0.0, field);
    let b = grid(9, 0.3, 1e6, field);
    for method in METHODS {
        let ga = Analyzer::from_mesh(&a).unwrap().vertex_gradients(method).to_vec();
        let gb = Analyzer::from_mesh(&b).unwrap().vertex_gradients(method).to_vec();
        for v in 0..ga.len() {
            assert!(ga[v].iter().all(|c| c.is_finite()));
            // Corner and edge vertices have one-sided rings; still first order.
            // Spacing h = 1/8; |second derivatives| ≤ ~13: errors stay O(h).
            assert!(dist(ga[v], grad(a.points[v])) < 8.0 / 8.0, "{method:?} vertex {v}: {:?}", ga[v]);
            // Coordinates near 1e6 keep ~1e-10 of the relative precision.
            assert!(dist(ga[v], gb[v]) < 1e-6, "{method:?} vertex {v}: {:?} vs {:?}", ga[v], gb[v]);
        }
    }
}
