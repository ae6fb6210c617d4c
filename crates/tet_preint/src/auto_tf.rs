//! A transfer function built from the data when none is given: opacity on
//! the boundaries between materials, colour from a named [`Colormap`].
//!
//! The boundary measure follows Kindlmann and Durkin, "Semi-automatic
//! generation of transfer functions for direct volume rendering", 1998:
//! over the volume-weighted scalar × |∇s| histogram, g(v) is the mean
//! gradient magnitude of the volume with value v. At an ideal (blurred
//! step) boundary g(v) peaks at the boundary's centre value, and the
//! second derivative along the gradient, h = g·g′(v), changes sign there;
//! their position estimate p(v) = −σ²·h/g = −σ²·g′(v) (σ = g_max/(√e·h_max),
//! the boundary's blur) is 0 at the centre. Opacity is
//! ĝ(v)·b(p(v)) with ĝ = g/g_max and b a tent of half-width 2σ, then its
//! weakest tenth cut off, so the bulk of a material — large volume, small
//! gradient — stays clear.
//!
//! Scale: the opacity is multiplied so that a typical ray meets an optical
//! depth of [`AutoTfOptions::optical_depth`]: the mean chord of the mesh's
//! bounding box (Cauchy: 4·volume / surface for a convex body, here with
//! the tets' total volume) times the volume-weighted mean extinction. The
//! TF's `unit_distance` is that chord, so an opacity of 1 is an optical
//! depth of about 1 across the data.
//!
//! The histogram is the bundle's (`tetprep convert --histogram`) or is
//! computed now from the per-tet gradients of the mesh (always possible:
//! a linear tet's gradient is exact); where no gradient varies, the scalar
//! histogram alone decides (rare values opaque). [`AutoTf::source`] says
//! which, so a CLI can warn. A constant scalar is an error.
//!
//! # A constant scalar: the one policy
//!
//! Every program and the viewer treat a bundle whose scalar has one value
//! everywhere the same way, through the functions here:
//!
//! * the automatic TF cannot be built ([`auto_tf`] and [`choose_tf`] return
//!   [`TfError::AutoTf`], "the scalar is constant (v): … give --tf"; the
//!   CLIs exit 4, input data rejected, and so does the viewer);
//! * a given normalized TF is mapped onto [v − 0.5, v + 0.5]
//!   ([`normalized_tf_range`], [`tf_for_bundle`]), so the value sits at the
//!   TF's middle (not onto the table domain's tiny padded range);
//! * the programs warn with [`constant_scalar_warning`] (every TF then draws
//!   the mesh in one colour).
//!
//! ```
//! use tet_bundle::{Bundle, BundleMeta};
//! use tet_mesh::{build_adjacency, mesh_stats, TetMesh};
//! use tet_preint::{auto_tf, AutoTfOptions};
//! // One tet, scalar = x.
//! let points = vec![[0., 0., 0.], [1., 0., 0.], [0., 1., 0.], [0., 0., 1.]];
//! let tets = vec![[0, 1, 2, 3]];
//! let scalar: Vec<f64> = points.iter().map(|p| p[0]).collect();
//! let stats = mesh_stats(&points, &tets, &scalar);
//! let mesh = TetMesh { points, tets: tets.into(), scalar_name: "x".into(), scalar, point_fields: vec![] };
//! let adjacency = build_adjacency(&mesh.points, &mesh.tets)?;
//! let bundle = Bundle::new(mesh, adjacency, BundleMeta { stats, ..Default::default() });
//! let auto = auto_tf(&bundle, &AutoTfOptions::default())?;
//! assert!(auto.tf.opacity_nodes().iter().any(|o| o.a > 0.0));
//! # Ok::<(), Box<dyn std::error::Error>>(())
//! ```

use crate::colormap::Colormap;
use crate::tf::{ColorNode, Emission, OpacityNode, TransferFunction};
use crate::TfError;
use tet_analysis::{Analyzer, HistogramOptions, Histograms};
use tet_bundle::Bundle;

/// How [`auto_tf`] builds the TF.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct AutoTfOptions {
    pub colormap: Colormap,
    /// Target optical depth along a typical ray (mean chord × mean
    /// extinction): about 1 − e^{−τ} of a ray's light is absorbed.
    pub optical_depth: f64,
    /// At most this many opacity nodes (bins are max-pooled down to it, so
    /// narrow peaks survive).
    pub max_nodes: usize,
}

impl Default for AutoTfOptions {
    fn default() -> Self {
        AutoTfOptions { colormap: Colormap::default(), optical_depth: 1.5, max_nodes: 64 }
    }
}

/// Where the boundary measure came from.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum BoundarySource {
    /// The bundle's scalar × |∇s| histogram.
    BundleHistogram,
    /// Computed now from the mesh's per-tet gradients (the bundle has no
    /// histogram section).
    ComputedHistogram,
    /// No gradient varies: opacity from the scalar histogram alone.
    ScalarHistogramOnly,
}

impl BoundarySource {
    /// A sentence for a CLI's note, or `None` when nothing needs saying.
    pub fn note(self) -> Option<&'static str> {
        match self {
            BoundarySource::BundleHistogram => None,
            BoundarySource::ComputedHistogram => Some(
                "the bundle has no histogram section: the automatic transfer function's scalar × |∇s| histogram was computed from the mesh now (tetprep convert --histogram stores it)",
            ),
            BoundarySource::ScalarHistogramOnly => Some(
                "the gradient magnitude does not vary with the scalar: the automatic transfer function uses the scalar histogram alone (rare values opaque)",
            ),
        }
    }
}

/// A TF built by [`auto_tf`] and how.
#[derive(Debug, Clone, PartialEq)]
pub struct AutoTf {
    pub tf: TransferFunction,
    pub source: BoundarySource,
    /// The mean chord (world units) the opacity is scaled to; the TF's unit_distance.
    pub mean_chord: f64,
    /// The scalar range the colour map spans (where the opacity is visible).
    pub color_range: (f64, f64),
}

/// Scalar bins of a histogram computed here.
const BINS: u32 = 128;
/// Opacity below this fraction of the largest is cut (bulk material).
const CUT: f64 = 0.1;

/// The data-aware TF of `bundle` (see the module docs).
pub fn auto_tf(bundle: &Bundle, opts: &AutoTfOptions) -> Result<AutoTf, TfError> {
    let stats = &bundle.meta.stats;
    let mesh = &bundle.mesh;
    let range = finite_range(&mesh.scalar)?;
    let stored = bundle.analysis.as_ref().and_then(|a| a.histograms.clone()).filter(|h| h.check().is_ok());
    let (hist, source) = match stored {
        Some(h) => (h, BoundarySource::BundleHistogram),
        None => {
            let an = Analyzer::new(&mesh.points, &mesh.tets, &mesh.scalar)
                .map_err(|e| TfError::AutoTf(format!("cannot analyse the mesh: {e}")))?;
            let ho = HistogramOptions { scalar_bins: BINS, gradient_bins: 64, ..Default::default() };
            let h = an.histograms(&ho).map_err(|e| TfError::AutoTf(format!("histogram: {e}")))?;
            (h, BoundarySource::ComputedHistogram)
        }
    };
    let bounds = (stats.bounds_min, stats.bounds_max);
    from_summary(&hist, source, range, bounds, stats.total_volume, opts)
}

/// The automatic TF of a mesh known by its summary instead of as a bundle:
/// its scalar × |∇s| histograms (a partition's pieces' histograms summed —
/// cut over the source's axes, they add up to the source's), the scalar's
/// finite range, the bounding box and the total volume: what [`auto_tf`]
/// reads from a bundle with a stored histogram, so the same mesh gives the
/// same TF (to the rounding of the sums).
pub fn auto_tf_from_histograms(
    hist: &Histograms,
    scalar_range: (f64, f64),
    bounds: ([f64; 3], [f64; 3]),
    total_volume: f64,
    opts: &AutoTfOptions,
) -> Result<AutoTf, TfError> {
    hist.check().map_err(|e| TfError::AutoTf(format!("histogram: {e}")))?;
    let (lo, hi) = scalar_range;
    if !(lo.is_finite() && hi.is_finite()) {
        return Err(TfError::AutoTf("the scalar has no finite values".into()));
    }
    if lo >= hi {
        return Err(constant(lo));
    }
    from_summary(hist, BoundarySource::BundleHistogram, scalar_range, bounds, total_volume, opts)
}

/// The smallest and largest value of `scalar`; an error for a scalar
/// with no finite value or one value.
fn finite_range(scalar: &[f64]) -> Result<(f64, f64), TfError> {
    let (smin, smax) = scalar.iter().fold((f64::INFINITY, f64::NEG_INFINITY), |(a, b), &v| (a.min(v), b.max(v)));
    if !(smin.is_finite() && smax.is_finite()) {
        return Err(TfError::AutoTf("the scalar has no finite values".into()));
    }
    if smin >= smax {
        return Err(constant(smin));
    }
    Ok((smin, smax))
}

fn constant(v: f64) -> TfError {
    TfError::AutoTf(format!(
        "the scalar is constant ({v}): there is nothing for an automatic transfer function to separate; give --tf"
    ))
}

fn from_summary(
    hist: &Histograms,
    mut source: BoundarySource,
    (smin, smax): (f64, f64),
    (bounds_min, bounds_max): ([f64; 3], [f64; 3]),
    total_volume: f64,
    opts: &AutoTfOptions,
) -> Result<AutoTf, TfError> {
    let centres = bin_centres(hist);
    let opacity = match boundary_opacity(hist) {
        Some(o) => o,
        None => {
            source = BoundarySource::ScalarHistogramOnly;
            rarity_opacity(&hist.scalar)
        }
    };
    let mean_chord = mean_chord(bounds_min, bounds_max, hist.total_volume.max(total_volume));
    let volume: f64 = hist.scalar.iter().sum();
    let weighted: f64 = hist.scalar.iter().zip(&opacity).map(|(v, o)| v * o).sum();
    if weighted.is_nan() || weighted <= 0.0 || volume <= 0.0 {
        return Err(TfError::AutoTf("no scalar bin holds volume (degenerate mesh)".into()));
    }
    // κ = a / u with u = mean chord: τ ≈ chord · Σ v κ / V = Σ v a / V.
    let k = opts.optical_depth * volume / weighted;
    let (xs, a) = pool(&centres, &opacity, opts.max_nodes.max(2));
    let mut nodes: Vec<OpacityNode> = xs.iter().zip(&a).map(|(&x, &o)| OpacityNode { x, a: k * o }).collect();
    // The ends of the data, so the TF is defined (and clamps) over all of it.
    if nodes.first().is_some_and(|n| n.x > smin) {
        nodes.insert(0, OpacityNode { x: smin, a: nodes[0].a });
    }
    if nodes.last().is_some_and(|n| n.x < smax) {
        nodes.push(OpacityNode { x: smax, a: nodes[nodes.len() - 1].a });
    }
    let color_range = visible_range(&centres, &opacity).unwrap_or((smin, smax));
    let color: Vec<ColorNode> = opts.colormap.nodes(color_range.0, color_range.1);
    let tf = TransferFunction::new(color, nodes, mean_chord, Emission::Density, false)?;
    Ok(AutoTf { tf, source, mean_chord, color_range })
}

fn bin_centres(h: &Histograms) -> Vec<f64> {
    let a = &h.scalar_axis;
    (0..a.bins as usize).map(|k| 0.5 * (a.edge(k) + a.edge(k + 1))).collect()
}

/// Mean chord of the box [lo, hi] holding `volume` of material: 4V/S with S
/// the box's surface (Cauchy's formula), at least a thousandth of the diagonal.
fn mean_chord(lo: [f64; 3], hi: [f64; 3], volume: f64) -> f64 {
    let d = [0, 1, 2].map(|i| (hi[i] - lo[i]).max(0.0));
    let diag = (d[0] * d[0] + d[1] * d[1] + d[2] * d[2]).sqrt();
    let surface = 2.0 * (d[0] * d[1] + d[1] * d[2] + d[2] * d[0]);
    let chord = if surface > 0.0 { 4.0 * volume / surface } else { diag };
    let chord = chord.max(1e-3 * diag);
    if chord > 0.0 && chord.is_finite() {
        chord
    } else {
        1.0
    }
}

/// Gaussian smoothing (σ in bins) of `v`, weighting each bin by `w`.
fn smooth(v: &[f64], w: &[f64], sigma: f64) -> Vec<f64> {
    let r = (3.0 * sigma).ceil() as isize;
    (0..v.len() as isize)
        .map(|i| {
            let (mut num, mut den) = (0.0, 0.0);
            for j in (i - r).max(0)..=(i + r).min(v.len() as isize - 1) {
                let k = (-((j - i) as f64).powi(2) / (2.0 * sigma * sigma)).exp() * w[j as usize];
                num += k * v[j as usize];
                den += k;
            }
            if den > 0.0 {
                num / den
            } else {
                0.0
            }
        })
        .collect()
}

/// Kindlmann–Durkin opacity per scalar bin in [0, 1]; `None` when g(v) is
/// flat (no boundary to find).
fn boundary_opacity(h: &Histograms) -> Option<Vec<f64>> {
    let (ns, ng) = (h.scalar_axis.bins as usize, h.gradient_axis.bins as usize);
    let ga = &h.gradient_axis;
    let gc: Vec<f64> = (0..ng).map(|k| 0.5 * (ga.edge(k) + ga.edge(k + 1))).collect();
    let (mut vol, mut gsum) = (vec![0.0; ns], vec![0.0; ns]);
    for (row, &g) in h.joint.chunks_exact(ns).zip(&gc) {
        for (s, &m) in row.iter().enumerate() {
            vol[s] += m;
            gsum[s] += m * g;
        }
    }
    let total: f64 = vol.iter().sum();
    // Bins with almost no volume say nothing about g: weight 0 in smoothing.
    let present: Vec<f64> = vol.iter().map(|&v| if v > 1e-9 * total { 1.0 } else { 0.0 }).collect();
    let mean: Vec<f64> = vol.iter().zip(&gsum).map(|(&v, &s)| if v > 0.0 { s / v } else { 0.0 }).collect();
    let g = smooth(&mean, &present, 1.5);
    let g_max = g.iter().copied().fold(0.0, f64::max);
    let g_min = g.iter().zip(&present).filter(|(_, &p)| p > 0.0).map(|(&x, _)| x).fold(f64::INFINITY, f64::min);
    // NaN-safe: a flat or empty g fails the comparison.
    if g_max.is_nan() || g_max <= 0.0 || g_max <= 1.05 * g_min {
        return None;
    }
    // g′(v) by central differences in scalar units; h = g·g′.
    let c = bin_centres(h);
    let dg: Vec<f64> = (0..ns)
        .map(|i| {
            let (a, b) = (i.saturating_sub(1), (i + 1).min(ns - 1));
            if c[b] > c[a] {
                (g[b] - g[a]) / (c[b] - c[a])
            } else {
                0.0
            }
        })
        .collect();
    let h_max = g.iter().zip(&dg).map(|(g, d)| (g * d).abs()).fold(0.0, f64::max);
    let b: Vec<f64> = if h_max > 0.0 {
        let sigma = g_max / (std::f64::consts::E.sqrt() * h_max);
        dg.iter().map(|d| (1.0 - (sigma * sigma * d).abs() / (2.0 * sigma)).max(0.0)).collect()
    } else {
        vec![1.0; ns]
    };
    let raw: Vec<f64> = (0..ns).map(|i| present[i] * g[i] / g_max * b[i]).collect();
    Some(cut(raw))
}

/// Opacity where values are rare: 1 − v/v_max of the smoothed scalar
/// histogram (the fallback without a gradient measure).
fn rarity_opacity(vol: &[f64]) -> Vec<f64> {
    let present: Vec<f64> = vol.iter().map(|&v| if v > 0.0 { 1.0 } else { 0.0 }).collect();
    let v = smooth(vol, &vec![1.0; vol.len()], 1.5);
    let v_max = v.iter().copied().fold(0.0, f64::max);
    if v_max.is_nan() || v_max <= 0.0 {
        return vec![1.0; vol.len()];
    }
    let raw: Vec<f64> = v.iter().zip(&present).map(|(x, p)| p * (1.0 - x / v_max)).collect();
    let out = cut(raw);
    if out.iter().all(|&o| o == 0.0) {
        present
    } else {
        out
    }
}

/// Normalizes to a largest value of 1 and cuts the weakest [`CUT`].
fn cut(raw: Vec<f64>) -> Vec<f64> {
    let m = raw.iter().copied().fold(0.0, f64::max);
    if m.is_nan() || m <= 0.0 {
        return raw;
    }
    raw.into_iter().map(|o| ((o / m - CUT) / (1.0 - CUT)).max(0.0)).collect()
}

/// Max-pools bins into at most `n` nodes (x at each group's strongest bin).
fn pool(xs: &[f64], o: &[f64], n: usize) -> (Vec<f64>, Vec<f64>) {
    let group = xs.len().div_ceil(n).max(1);
    let (mut px, mut po) = (Vec::new(), Vec::new());
    for (cx, co) in xs.chunks(group).zip(o.chunks(group)) {
        let (i, &m) = co.iter().enumerate().fold((0, &co[0]), |best, (i, v)| if *v > *best.1 { (i, v) } else { best });
        // An all-zero group keeps its centre so clear stretches stay clear.
        let x = if m > 0.0 { cx[i] } else { cx[cx.len() / 2] };
        if px.last().is_none_or(|&l| x > l) {
            px.push(x);
            po.push(m);
        }
    }
    (px, po)
}

/// The scalar span where opacity is at least 5% of its largest.
fn visible_range(xs: &[f64], o: &[f64]) -> Option<(f64, f64)> {
    let m = o.iter().copied().fold(0.0, f64::max);
    let vis: Vec<f64> = xs.iter().zip(o).filter(|(_, &v)| v >= 0.05 * m && v > 0.0).map(|(&x, _)| x).collect();
    match (vis.first(), vis.last()) {
        (Some(&a), Some(&b)) if b > a => Some((a, b)),
        _ => None,
    }
}

/// The TF a CLI renders with, from what it was given: `given` (read from
/// `--tf`, normalized or not) or, without one, [`auto_tf`] of `bundle`
/// (then required);
/// then `colormap` (replacing a given TF's colours over its nodes' span)
/// and `opacity_scale` (multiplying every extinction) applied. A normalized
/// TF stays normalized (the caller maps it onto its range).
pub fn choose_tf(
    given: Option<TransferFunction>,
    bundle: Option<&Bundle>,
    colormap: Option<Colormap>,
    opacity_scale: f64,
) -> Result<(TransferFunction, Option<AutoTf>), TfError> {
    let (tf, auto) = match given {
        Some(tf) => {
            let tf = match colormap {
                Some(map) => {
                    let (lo, hi) = node_span(&tf);
                    tf.with_colormap(map, lo, hi)?
                }
                None => tf,
            };
            (tf, None)
        }
        None => {
            let opts = AutoTfOptions { colormap: colormap.unwrap_or_default(), ..Default::default() };
            let bundle = bundle
                .ok_or_else(|| TfError::AutoTf("no transfer function given and no bundle to build one from".into()))?;
            let a = auto_tf(bundle, &opts)?;
            (a.tf.clone(), Some(a))
        }
    };
    let tf = if opacity_scale == 1.0 { tf } else { tf.with_opacity_scale(opacity_scale)? };
    Ok((tf, auto))
}

/// The scalar range a normalized TF's [0, 1] is mapped onto for data over
/// [lo, hi] (a bundle's scalar range): [lo, hi] itself, or for a constant
/// scalar (hi ≤ lo) [lo − 0.5, lo + 0.5]. See the module docs' constant
/// scalar policy; the caller checks that lo and hi are finite.
pub fn normalized_tf_range(lo: f64, hi: f64) -> (f64, f64) {
    if hi > lo {
        (lo, hi)
    } else {
        (lo - 0.5, lo + 0.5)
    }
}

/// `tf` in `bundle`'s scalar units: a normalized TF mapped onto
/// [`normalized_tf_range`] of the bundle's scalar range (its
/// `meta.stats`), any other TF as it is. What `tetlut` and `tetview` do
/// with a normalized TF and a bundle (the viewer's `TfModel` the same).
pub fn tf_for_bundle(tf: &TransferFunction, bundle: &Bundle) -> Result<TransferFunction, TfError> {
    if !tf.normalized() {
        return Ok(tf.clone());
    }
    let (lo, hi) = bundle.scalar_range();
    let (lo, hi) = normalized_tf_range(lo, hi);
    tf.denormalize(lo, hi)
}

/// The warning every program prints for a bundle whose scalar is constant
/// (`None` otherwise): every transfer function then draws the mesh in one
/// colour.
pub fn constant_scalar_warning(bundle: &Bundle) -> Option<String> {
    let (lo, hi) = bundle.scalar_range();
    (lo == hi).then(|| {
        format!(
            "the scalar '{}' is constant ({lo}) over the mesh{}, so the image has one colour; \
             convert the input again with another --scalar",
            bundle.mesh.scalar_name,
            if bundle.steps.is_some() { " at every time step" } else { "" }
        )
    })
}

/// The x span of a TF's colour and opacity nodes (a single point widened by 1).
pub fn node_span(tf: &TransferFunction) -> (f64, f64) {
    let xs = tf.color_nodes().iter().map(|c| c.x).chain(tf.opacity_nodes().iter().map(|o| o.x));
    let (lo, hi) = xs.fold((f64::INFINITY, f64::NEG_INFINITY), |(a, b), x| (a.min(x), b.max(x)));
    normalized_tf_range(lo, hi)
}

#[cfg(test)]
mod tests {
    use super::*;
    use tet_bundle::BundleMeta;
    use tet_mesh::{build_adjacency, mesh_stats, tetrahedralize, ConvertOptions, SourceMesh};

    /// An n³ grid of the unit cube, split into tets as tetprep splits it, scalar `f`.
    fn grid(n: usize, f: impl Fn([f64; 3]) -> f64) -> Bundle {
        let mut points = Vec::new();
        for k in 0..=n {
            for j in 0..=n {
                for i in 0..=n {
                    points.push([i as f64 / n as f64, j as f64 / n as f64, k as f64 / n as f64]);
                }
            }
        }
        let values = points.iter().map(|&p| f(p)).collect();
        let src = SourceMesh::structured([n + 1; 3], points, "s", values);
        let opts = ConvertOptions { scalar: Some("s".into()), ..Default::default() };
        let (mesh, _) = tetrahedralize(&src, &opts, &mut |_| {}).unwrap();
        let stats = mesh_stats(&mesh.points, &mesh.tets, &mesh.scalar);
        let adjacency = build_adjacency(&mesh.points, &mesh.tets).unwrap();
        Bundle::new(mesh, adjacency, BundleMeta { stats, ..Default::default() })
    }

    /// A sphere of value 1 in a background of 0 with a smooth (tanh) rim:
    /// the boundary's middle values get the opacity, the two materials none.
    #[test]
    fn opacity_sits_on_the_boundary_not_the_materials() {
        let b = grid(16, |p| {
            let r = ((p[0] - 0.5).powi(2) + (p[1] - 0.5).powi(2) + (p[2] - 0.5).powi(2)).sqrt();
            0.5 * (1.0 - ((r - 0.3) / 0.05).tanh())
        });
        let a = auto_tf(&b, &AutoTfOptions::default()).unwrap();
        assert_eq!(a.source, BoundarySource::ComputedHistogram);
        let tf = &a.tf;
        let (lo, mid, hi) = (tf.extinction(0.01), tf.extinction(0.5), tf.extinction(0.99));
        eprintln!("extinction at 0.01 {lo:.3}, 0.5 {mid:.3}, 0.99 {hi:.3}; chord {}", a.mean_chord);
        assert!(mid > 0.0 && mid > 5.0 * lo && mid > 5.0 * hi, "{lo} {mid} {hi}");
        assert!(tf.opacity_nodes().len() <= 66);
        // The unit cube's mean chord, 4V/S = 4/6.
        assert!((a.mean_chord - 4.0 / 6.0).abs() < 1e-9, "{}", a.mean_chord);
        assert!(tf.opacity_nodes().iter().all(|o| o.a.is_finite()));
    }

    #[test]
    fn constant_scalar_is_a_clear_error_and_linear_falls_back() {
        let e = auto_tf(&grid(3, |_| 2.0), &AutoTfOptions::default()).unwrap_err().to_string();
        assert!(e.contains("constant") && e.contains("--tf"), "{e}");
        // A linear field: |∇s| is the same everywhere, so no boundary; the
        // scalar histogram decides, and the TF is finite and visible.
        let a = auto_tf(&grid(4, |p| p[0] + p[1]), &AutoTfOptions::default()).unwrap();
        assert_eq!(a.source, BoundarySource::ScalarHistogramOnly);
        assert!(a.tf.opacity_nodes().iter().all(|o| o.a.is_finite()) && a.tf.opacity_nodes().iter().any(|o| o.a > 0.0));
    }

    #[test]
    fn choose_tf_recolours_and_scales_a_given_tf() {
        let b = grid(3, |p| p[0]);
        let given = TransferFunction::from_json(
            r#"{"normalized": true, "color": [[0, 1, 0, 0], [1, 0, 0, 1]], "opacity": [[0, 0.5], [1, 3]], "unit_distance": 1}"#,
        )
        .unwrap();
        let (tf, auto) = choose_tf(Some(given.clone()), Some(&b), Some(Colormap::Magma), 2.0).unwrap();
        assert!(auto.is_none() && tf.normalized());
        assert_eq!(tf.color(0.0), Colormap::Magma.sample(0.0));
        assert_eq!(tf.opacity_nodes()[1].a, 6.0);
        let (same, _) = choose_tf(Some(given.clone()), Some(&b), None, 1.0).unwrap();
        assert_eq!(same, given);
        let (auto_tf, info) = choose_tf(None, Some(&b), Some(Colormap::Turbo), 1.0).unwrap();
        assert!(info.is_some() && !auto_tf.normalized());
        assert!(choose_tf(None, None, None, 1.0).is_err());
        // The TF written by --save-tf reads back as the same TF.
        assert_eq!(TransferFunction::from_json(&auto_tf.to_json()).unwrap(), auto_tf);
    }
}
