//! Volume-weighted histograms: exact per-tet distribution, mass conservation,
//! configurable axes; cell ranges and frequency limits.
mod common;

use common::{capped_sliver, grid, Rng};
use proptest::prelude::*;
use tet_analysis::{volume_fraction_below, AnalysisOptions, Analyzer, GradientMethod, HistogramOptions, Scale};

/// F over a tet equals the mean of F over the 8 equal-volume tets of its
/// midpoint subdivision (s is linear, so sub-tet values are averages).
fn subdivided_fraction(s: [f64; 4], t: f64) -> f64 {
    let m = |a: usize, b: usize| 0.5 * (s[a] + s[b]);
    let subs = [
        [s[0], m(0, 1), m(0, 2), m(0, 3)],
        [m(0, 1), s[1], m(1, 2), m(1, 3)],
        [m(0, 2), m(1, 2), s[2], m(2, 3)],
        [m(0, 3), m(1, 3), m(2, 3), s[3]],
        [m(0, 1), m(0, 2), m(0, 3), m(1, 3)],
        [m(0, 1), m(0, 2), m(1, 2), m(1, 3)],
        [m(0, 2), m(0, 3), m(1, 3), m(2, 3)],
        [m(0, 2), m(1, 2), m(1, 3), m(2, 3)],
    ];
    subs.iter()
        .map(|sub| {
            let mut v = *sub;
            v.sort_by(f64::total_cmp);
            volume_fraction_below(&v, t)
        })
        .sum::<f64>()
        / 8.0
}

fn sorted(mut v: [f64; 4]) -> [f64; 4] {
    v.sort_by(f64::total_cmp);
    v
}

proptest! {
    #[test]
    fn fraction_is_self_consistent_under_subdivision(
        a in -10.0..10.0f64, b in -10.0..10.0f64, c in -10.0..10.0f64, d in -10.0..10.0f64,
        tie in 0usize..4, u in 0.0..1.0f64,
    ) {
        let mut v = [a, b, c, d];
        // Exercise coincident values (flat regions) too.
        if tie > 0 { v[tie] = v[tie - 1]; }
        let s = sorted(v);
        let t = s[0] - 1.0 + u * (s[3] - s[0] + 2.0);
        let f = volume_fraction_below(&s, t);
        prop_assert!((0.0..=1.0).contains(&f));
        let g = subdivided_fraction(s, t);
        prop_assert!((f - g).abs() < 1e-12, "F = {f}, subdivided {g}, s = {s:?}, t = {t}");
        // Monotone in t.
        prop_assert!(volume_fraction_below(&s, t + 1e-3) >= f - 1e-15);
    }
}

#[test]
fn fraction_matches_monte_carlo_sampling() {
    // Uniform points in the unit tet via sorted uniforms (barycentric).
    let s = [0.3, 1.0, 1.1, 4.0];
    let vals = [1.1, 0.3, 4.0, 1.0]; // vertex values in vertex order
    let mut rng = Rng(12345);
    let n = 400_000;
    let ts = [0.5, 1.05, 2.0, 3.5];
    let mut counts = [0usize; 4];
    for _ in 0..n {
        let mut u = [rng.next_f64(), rng.next_f64(), rng.next_f64()];
        u.sort_by(f64::total_cmp);
        let w = [u[0], u[1] - u[0], u[2] - u[1], 1.0 - u[2]];
        let x: f64 = (0..4).map(|k| w[k] * vals[k]).sum();
        for (i, &t) in ts.iter().enumerate() {
            if x <= t {
                counts[i] += 1;
            }
        }
    }
    for (i, &t) in ts.iter().enumerate() {
        let mc = counts[i] as f64 / n as f64;
        let f = volume_fraction_below(&s, t);
        assert!((mc - f).abs() < 4e-3, "t = {t}: exact {f}, sampled {mc}");
    }
}

#[test]
fn mass_equals_total_volume() {
    for m in [grid(9, 0.5, 0.0, |p| (5.0 * p[0]).sin() + p[1] * p[2]), capped_sliver(1e-9, |p| p[0] * p[1] + p[2])] {
        let total: f64 = tet_mesh::mesh_stats(&m.points, &m.tets, &m.scalar).total_volume;
        let an = Analyzer::from_mesh(&m).unwrap();
        for opts in [
            HistogramOptions::default(),
            HistogramOptions { scalar_bins: 7, gradient_bins: 3, ..Default::default() },
            // A range that cuts the data: the cut-off volume is reported.
            HistogramOptions { scalar_range: Some((0.0, 0.5)), gradient_range: Some((0.1, 2.0)), ..Default::default() },
            HistogramOptions {
                gradient_range: Some((1e-3, 10.0)),
                gradient_scale: Scale::Log,
                scalar_bins: 33,
                ..Default::default()
            },
        ] {
            let h = an.histograms(&opts).unwrap();
            let one_d: f64 = h.scalar.iter().sum::<f64>() + h.scalar_below + h.scalar_above;
            let joint: f64 = h.joint.iter().sum::<f64>() + h.joint_outside;
            assert!((h.total_volume - total).abs() <= 1e-13 * total, "{} vs {total}", h.total_volume);
            assert!((one_d - total).abs() <= 1e-13 * total, "1D mass {one_d} vs {total}");
            assert!((joint - total).abs() <= 1e-13 * total, "2D mass {joint} vs {total}");
            assert!(h.scalar.iter().chain(&h.joint).all(|&x| x >= 0.0));
            // The 1D histogram is the joint one's marginal where the |∇s| axis covers all tets.
            if h.joint_outside == 0.0 {
                for s in 0..h.scalar.len() {
                    let col: f64 = (0..h.gradient_axis.bins as usize).map(|g| h.joint[g * h.scalar.len() + s]).sum();
                    assert!((col - h.scalar[s]).abs() <= 1e-12 * total);
                }
            }
        }
    }
}

#[test]
fn a_linear_field_on_a_cube_fills_bins_evenly() {
    // s = x over the unit cube: every x-slab of width 1/n holds volume 1/n,
    // although no tet is aligned with the bins.
    let m = grid(5, 0.0, 0.0, |p| p[0]);
    let an = Analyzer::from_mesh(&m).unwrap();
    let h = an.histograms(&HistogramOptions { scalar_bins: 10, gradient_bins: 4, ..Default::default() }).unwrap();
    for (k, v) in h.scalar.iter().enumerate() {
        assert!((v - 0.1).abs() < 1e-14, "bin {k}: {v}");
    }
    // |∇s| = 1 in every tet: the joint histogram has one non-empty row.
    let rows: Vec<f64> = (0..4).map(|g| h.joint[g * 10..(g + 1) * 10].iter().sum()).collect();
    assert_eq!(rows.iter().filter(|&&r| r > 0.0).count(), 1, "{rows:?}");
}

#[test]
fn analysis_reuses_work_and_reports_limits() {
    let m = grid(9, 0.3, 0.0, |p| 3.0 * p[0] + p[1] * p[1]);
    let an = Analyzer::from_mesh(&m).unwrap();
    let opts = AnalysisOptions {
        gradients: Some(GradientMethod::LeastSquares),
        histogram: Some(HistogramOptions::default()),
        ..Default::default()
    };
    let a = an.analyze(&opts).unwrap();
    // The cached per-tet gradients are the ones the histogram used.
    let tg = an.tet_gradients() as *const _;
    assert_eq!(tg, an.tet_gradients() as *const _);
    let r = &a.ranges;
    assert_eq!(r.scalar.len(), m.tets.len());
    let gr = r.gradient_magnitude.as_ref().unwrap();
    for (t, tet) in m.tets.iter().enumerate() {
        let vals = tet.map(|v| m.scalar[v as usize]);
        assert_eq!(r.scalar[t][0], vals.iter().copied().fold(f64::INFINITY, f64::min));
        assert!(gr[t][0] <= gr[t][1]);
    }
    let f = &a.facts;
    assert!(f.cell_scalar_range.p50 <= f.cell_scalar_range.p99 && f.cell_scalar_range.p99 <= f.max_cell_scalar_range);
    let stats = tet_mesh::mesh_stats(&m.points, &m.tets, &m.scalar);
    assert_eq!(f.max_cell_diameter, stats.max_cell_diameter);
    let l = &a.limits;
    assert_eq!(l.frequency_limit, Some(1.0 / f.max_cell_scalar_range));
    assert!(l.frequency_limit_99.unwrap() >= l.frequency_limit.unwrap());
    let table = l.table.unwrap();
    assert!(table.samples_triangle > table.samples_sine && table.samples_sine > 1);
    assert!(l.gradient_frequency_limit.is_some());
}

#[test]
fn bad_input_is_an_error_not_a_panic() {
    let p = [[0.0; 3], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]];
    assert!(Analyzer::new(&p, &[[0, 1, 2, 9]], &[0.0; 4]).is_err());
    assert!(Analyzer::new(&p, &[[0, 1, 2, 3]], &[0.0; 3]).is_err());
    assert!(Analyzer::new(&p, &[[0, 1, 2, 3]], &[0.0, f64::NAN, 0.0, 0.0]).is_err());
    let an = Analyzer::new(&p, &[[0, 1, 2, 3]], &[0.0; 4]).unwrap();
    assert!(an.histograms(&HistogramOptions { scalar_bins: 0, ..Default::default() }).is_err());
    assert!(an.histograms(&HistogramOptions { scalar_range: Some((1.0, 0.0)), ..Default::default() }).is_err());
    // A constant field still gives a histogram (all volume in one bin) and no limit.
    let h = an.histograms(&HistogramOptions::default()).unwrap();
    assert_eq!(h.scalar.iter().filter(|&&v| v > 0.0).count(), 1);
    let a = an.analyze(&AnalysisOptions::default()).unwrap();
    assert_eq!(a.limits.frequency_limit, None);
}
