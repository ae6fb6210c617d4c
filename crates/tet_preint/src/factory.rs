//! One entry point from a method id to a ready [`SegmentShader`]: what
//! renderers (tetview) and `tetlut` call to bake on the fly.
//!
//! [`make_shader`] bakes the tables `method` needs for `tf` over `domain`
//! with the resolutions of [`BakeOptions`]; [`Baked`] is the same result
//! before boxing (typed access for `tetlut show`, memory figures for the
//! benchmarks, and the `.tetl` conversion of [`crate::lut_file`]).
//!
//! Rules every method shares:
//!
//! * A normalized TF (x ∈ [0, 1]) is mapped onto the domain's scalar range
//!   first ([`tf_for_domain`]).
//! * The 1D methods (`exact`, `pt-linear`, `table3d`, `atlas2d`, `partial`,
//!   `poly*`) refuse a TF with 2D widgets instead of silently dropping them:
//!   the error names `biv-exact` / `biv-approx`.
//! * `biv-exact` tabulates nothing (Song et al.'s (2009) closed forms are evaluated per
//!   segment); `biv-approx` bakes the F/B table.
//!
//! Default resolutions ([`BakeOptions::default`]): table3d 128 × 128 × 256
//! f32 on the data-following scalar axis with every TF control point a
//! sample, built adaptively ([`crate::Table3dParams::data`]; the GPU's
//! on-device bake runs the slice recurrence on the same axis); atlas2d from
//! a table with N planes;
//! partial Ψ 1024² f32; poly1/2/4 at 512² f32; biv-approx F/B at 128² f32
//! with 4 sub-segments. Their bake times and errors on Blunt Fin, measured
//! by `tetlut bench`, are in `crates/tetlut/results/bluntfin.md`; partial's
//! Ψ is TF-independent (a TF edit rebakes nothing), and biv-approx's error
//! is set by k, not by the table side.
//!
//! table3d's resolution is the *starting* point: the default bake measures
//! its own max per-segment error and refines (split lookups at TF nodes,
//! exact integration on the TF intervals the table cannot follow, a finer
//! table within 256 MiB) until max ≤ 1e-3 holds, and records what it
//! measured ([`crate::certify`], `BakeOptions::certify`; off with
//! `CertifyOptions::off()`). Held-out TFs: crates/tetlut/results/certified.md.

use std::sync::Arc;

use crate::atlas2d::{Atlas2d, Atlas2dParams};
use crate::bivariate::{BivApprox, BivExact, FbTable};
use crate::certify::CertifiedTable3d;
use crate::domain::{check_res, TableDomain, TableError};
use crate::lut_file::BakeOptions;
use crate::method::{ExactShader, Method, PtLinearShader, Rgba32, Segment, SegmentBatch, SegmentShader};
use crate::partial::{PartialShader, PsiTable};
use crate::poly::{PolyParams, PolyTable};
use crate::precision::{Precision, Storage};
use crate::table3d::Table3d;
use crate::tf::{Emission, TransferFunction};

/// Largest F/B table side.
pub const MAX_FB_RES: usize = 4096;
/// Largest number of `biv-approx` sub-segments.
pub const MAX_SUBSEGMENTS: usize = 1024;

/// A baked method, typed.
#[derive(Debug, Clone)]
// One `Baked` is built per bake and then held (never moved in a hot loop):
// the variants' sizes do not matter.
#[allow(clippy::large_enum_variant)]
pub enum Baked {
    Exact(ExactShader),
    PtLinear(PtLinearShader),
    /// The table, its lookup (plain or split at TF nodes) and what the bake
    /// measured of it ([`crate::certify`]); dereferences to the [`Table3d`].
    Table3d(CertifiedTable3d),
    Atlas2d(Atlas2d),
    Partial(PartialShader),
    /// The table and the precision it was rounded to (and is stored in).
    Poly(PolyTable, Precision),
    BivExact(BivExact),
    /// The shader and the precision its F/B table was rounded to.
    BivApprox(BivApprox, Precision),
}

/// `tf` with x in data units: a normalized TF is mapped onto
/// [domain.s_lo, domain.s_hi]; others are returned as they are.
pub fn tf_for_domain(tf: &TransferFunction, domain: &TableDomain) -> Result<TransferFunction, TableError> {
    if tf.normalized() {
        tf.denormalize(domain.s_lo, domain.s_hi).map_err(|e| TableError::Invalid(format!("transfer function: {e}")))
    } else {
        Ok(tf.clone())
    }
}

/// `tf` as every bake of `method` over `domain` takes it: in data units
/// ([`tf_for_domain`]), checked against what the method can hold (2D
/// widgets only for the bivariate methods; table entries within f32). What
/// [`Baked::build`] runs first, for callers that update a table themselves
/// (e.g. [`Table3d::rebake`]).
pub fn tf_for_bake(
    method: Method,
    tf: &TransferFunction,
    domain: &TableDomain,
) -> Result<TransferFunction, TableError> {
    let tf = tf_for_domain(tf, domain)?;
    check_f32_colour(method, &tf, domain)?;
    if !method.is_bivariate() && !tf.widgets().is_empty() {
        return Err(TableError::Invalid(format!(
            "the transfer function has {} 2D widget(s), which method '{method}' cannot integrate (it reads \
             only the 1D part); use biv-exact (closed forms) or biv-approx (F/B table)",
            tf.widgets().len()
        )));
    }
    Ok(tf)
}

/// Bakes `method` for `tf` over `domain` and boxes it as a shader.
///
/// ```
/// use tet_preint::{make_shader, BakeOptions, Method, Segment, TableDomain, TransferFunction};
/// let tf = TransferFunction::from_json(
///     r#"{"color": [[0, 1, 0, 0], [1, 0, 0, 1]], "opacity": [[0, 0.5], [1, 3]], "unit_distance": 1}"#,
/// )?;
/// let domain = TableDomain::new(0.0, 1.0, 0.25, 2.0)?;
/// let mut opts = BakeOptions::default();
/// opts.poly_res = 64;
/// let shader = make_shader(Method::Poly2, &tf, &domain, &opts)?;
/// let px = shader.shade(&Segment { s_front: 0.4, s_back: 0.5, len_world: 1.0, ..Default::default() });
/// assert!(px[3] > 0.0 && px[3] < 1.0);
/// # Ok::<(), Box<dyn std::error::Error>>(())
/// ```
pub fn make_shader(
    method: Method,
    tf: &TransferFunction,
    domain: &TableDomain,
    opts: &BakeOptions,
) -> Result<Box<dyn SegmentShader>, TableError> {
    Ok(Baked::build(method, tf, domain, opts)?.into_shader())
}

/// Checks the storage precision a 2D method can hold.
fn check_2d_precision(method: Method, p: Precision) -> Result<(), TableError> {
    if method != Method::BivApprox && matches!(p, Precision::Unorm16 | Precision::Unorm8) {
        return Err(TableError::Invalid(format!(
            "{method} stores signed polynomial coefficients: precision {p} cannot hold them (use f32 or f16)"
        )));
    }
    Ok(())
}

/// Tables store f32. Under density emission a segment's colour is at most
/// the largest colour, which the TF bounds by f32::MAX. Under independent
/// emission it reaches colour × length. The integrating shaders (`exact`,
/// `pt-linear`, `biv-exact`) hold that at f32::MAX; a table would store
/// infinity, so the bake is refused, naming both factors.
fn check_f32_colour(method: Method, tf: &TransferFunction, domain: &TableDomain) -> Result<(), TableError> {
    if !method.is_tabulated() || tf.emission() != Emission::Independent {
        return Ok(());
    }
    let widgets: f64 = tf.widgets().iter().map(|w| w.color.iter().fold(0.0f64, |m, &c| m.max(c))).sum();
    let colour = tf.max_color().iter().fold(0.0f64, |m, &c| m.max(c)) + widgets;
    let reach = colour * domain.len_max_world;
    if reach > f32::MAX as f64 {
        return Err(TableError::Invalid(format!(
            "independent emission: colour up to {colour:e} over segments up to {:e} world units reaches {reach:e}, \
             beyond the largest f32 (3.4e38) that {method} tables store",
            domain.len_max_world
        )));
    }
    Ok(())
}

/// Rounds f32 values through `precision` storage (what a file written in
/// that precision will read back as).
fn quantize(values: &[f32], channels: usize, precision: Precision) -> Vec<f32> {
    if precision == Precision::F32 {
        values.to_vec()
    } else {
        Storage::encode(values.to_vec(), channels, precision).to_f32()
    }
}

impl Baked {
    /// Bakes `method` (see the module docs for the rules).
    pub fn build(
        method: Method,
        tf: &TransferFunction,
        domain: &TableDomain,
        opts: &BakeOptions,
    ) -> Result<Baked, TableError> {
        Baked::build_with_cells(method, tf, domain, opts, &[])
    }

    /// [`Baked::build`], with segments through the bundle's cells
    /// (`[Sf, Sb, l]`, [`crate::certify::cell_triples`]) that `table3d`'s
    /// certification measures besides its own sets (ignored by the others).
    pub fn build_with_cells(
        method: Method,
        tf: &TransferFunction,
        domain: &TableDomain,
        opts: &BakeOptions,
        cells: &[[f32; 3]],
    ) -> Result<Baked, TableError> {
        let tf = tf_for_bake(method, tf, domain)?;
        Ok(match method {
            Method::Exact => Baked::Exact(ExactShader::new(tf)),
            Method::PtLinear => Baked::PtLinear(PtLinearShader::new(tf)),
            Method::Table3d => Baked::Table3d(crate::certify::bake(&tf, domain, &opts.table3d, &opts.certify, cells)?),
            Method::Atlas2d => {
                let t = Table3d::build(&tf, domain, &opts.table3d)?;
                let params = Atlas2dParams::for_table(&t, opts.atlas_planes_quarters, opts.table3d.precision);
                Baked::Atlas2d(Atlas2d::build(&t, &params)?)
            }
            Method::Partial => {
                let mut psi = opts.psi;
                psi.first_moment |= tf.emission() == Emission::Independent;
                let table = Arc::new(PsiTable::build(&psi)?);
                Baked::Partial(PartialShader::new(tf, table)?)
            }
            Method::Poly1 | Method::Poly2 | Method::Poly4 => {
                check_2d_precision(method, opts.precision_2d)?;
                check_res("poly res", opts.poly_res, 2, 16384)?;
                let degree = match method {
                    Method::Poly1 => 1,
                    Method::Poly2 => 2,
                    _ => 4,
                };
                let mut p = PolyParams::new(degree, opts.poly_res, domain.s_lo, domain.s_hi, domain.len_max_world);
                if !domain.is_full() {
                    p = p.with_max_ds(domain.max_ds.max(f64::MIN_POSITIVE));
                }
                let t = PolyTable::build(&tf, &p).map_err(|e| TableError::Invalid(format!("{method}: {e}")))?;
                Baked::Poly(quantize_poly(t, opts.precision_2d)?, opts.precision_2d)
            }
            Method::BivExact => Baked::BivExact(BivExact::new(tf)),
            Method::BivApprox => {
                check_res("biv-approx F/B res", opts.fb_res, 2, MAX_FB_RES)?;
                check_res("biv-approx sub-segments", opts.biv_subsegments, 1, MAX_SUBSEGMENTS)?;
                let fb = FbTable::build(tf.emission(), opts.fb_res).expect("res checked");
                let fb = quantize_fb(fb, opts.precision_2d)?;
                Baked::BivApprox(
                    BivApprox::new(tf, fb, opts.biv_subsegments).expect("checked k and emission"),
                    opts.precision_2d,
                )
            }
        })
    }

    /// The method baked.
    pub fn method(&self) -> Method {
        self.shader().method()
    }

    /// The baked object as a shader reference.
    pub fn shader(&self) -> &dyn SegmentShader {
        match self {
            Baked::Exact(s) => s,
            Baked::PtLinear(s) => s,
            Baked::Table3d(s) => s,
            Baked::Atlas2d(s) => s,
            Baked::Partial(s) => s,
            Baked::Poly(s, _) => s,
            Baked::BivExact(s) => s,
            Baked::BivApprox(s, _) => s,
        }
    }

    /// Boxes the shader.
    pub fn into_shader(self) -> Box<dyn SegmentShader> {
        match self {
            Baked::Exact(s) => Box::new(s),
            Baked::PtLinear(s) => Box::new(s),
            Baked::Table3d(s) => Box::new(s),
            Baked::Atlas2d(s) => Box::new(s),
            Baked::Partial(s) => Box::new(s),
            Baked::Poly(s, _) => Box::new(s),
            Baked::BivExact(s) => Box::new(s),
            Baked::BivApprox(s, _) => Box::new(s),
        }
    }
}

/// A baked method draws as its shader: one `Arc<Baked>` serves the CPU
/// renderers (as `Arc<dyn SegmentShader>`) and the GPU (which uploads the
/// typed tables), so a look's tables are held once. Each call forwards to
/// the variant's own implementation, so the values are its values.
impl SegmentShader for Baked {
    fn method(&self) -> Method {
        self.shader().method()
    }

    fn shade(&self, seg: &Segment) -> Rgba32 {
        self.shader().shade(seg)
    }

    fn shade_span(&self, segs: &[Segment], out: &mut [Rgba32]) {
        self.shader().shade_span(segs, out)
    }

    fn shade_batch(&self, segs: &SegmentBatch, out: &mut [Rgba32; crate::method::BATCH]) {
        self.shader().shade_batch(segs, out)
    }
}

impl Baked {
    /// Bytes of tabulated data as stored in a `.tetl` (0 for methods
    /// without tables).
    pub fn memory_bytes(&self) -> usize {
        match self {
            Baked::Table3d(t) => t.memory_bytes(),
            Baked::Atlas2d(t) => t.memory_bytes(),
            Baked::Partial(s) => s.psi().memory_bytes(),
            Baked::Poly(t, p) => (t.rho().len() + t.coef().len()) * p.bytes() + 2 * t.alpha_table().data().len(),
            Baked::BivApprox(s, p) => (s.table().f().len() + s.table().b().len()) * p.bytes(),
            // The erf and band tables of Song et al., "Bivariate Transfer
            // Functions on Unstructured Grids", 2009 (none unless the emission
            // is independent and the TF has the matching widgets).
            Baked::BivExact(s) => s.tables().memory_bytes(),
            Baked::Exact(_) | Baked::PtLinear(_) => 0,
        }
    }

    /// Bytes the same tables would take over the full (Sf, Sb) square (equal
    /// to [`Baked::memory_bytes`] for tables that do not depend on the band).
    pub fn full_memory_bytes(&self) -> usize {
        match self {
            Baked::Table3d(t) => t.full_memory_bytes(),
            Baked::Poly(t, p) => {
                let n = t.res() * t.res() * (1 + 3 * (t.degree() + 1));
                n * p.bytes() + 2 * t.alpha_table().data().len()
            }
            _ => self.memory_bytes(),
        }
    }
}

/// The table with ρ̂ and the coefficients rounded through `precision`.
fn quantize_poly(t: PolyTable, precision: Precision) -> Result<PolyTable, TableError> {
    if precision == Precision::F32 {
        return Ok(t);
    }
    let stride = 3 * (t.degree() + 1);
    let rho = quantize(t.rho(), 1, precision);
    let coef = quantize(t.coef(), stride, precision);
    t.with_values(rho, coef, t.alpha_table().clone())
        .map_err(|e| TableError::Invalid(format!("{precision} rounding: {e}")))
}

/// The F/B table rounded through `precision`.
fn quantize_fb(t: FbTable, precision: Precision) -> Result<FbTable, TableError> {
    if precision == Precision::F32 {
        return Ok(t);
    }
    let (f, b) = (quantize(t.f(), 1, precision), quantize(t.b(), 1, precision));
    FbTable::from_parts(t.emission(), t.res(), f, b)
        .ok_or_else(|| TableError::Invalid(format!("F/B table does not survive {precision} rounding")))
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::method::Segment;

    fn tf(json: &str) -> TransferFunction {
        TransferFunction::from_json(json).unwrap()
    }

    /// biv-exact's memory counts Song et al.'s (2009) erf table (one Gaussian widget,
    /// independent emission).
    #[test]
    fn biv_exact_memory_counts_its_tables() {
        let t = tf(include_str!("../../tetlut/results/tf_gauss_independent.json"));
        let d = TableDomain::new(0.0, 2.0, 2.0, 3.0).unwrap();
        let b = Baked::build(Method::BivExact, &t, &d, &BakeOptions::default()).unwrap();
        let Baked::BivExact(s) = &b else { panic!("biv-exact") };
        let erf = s.gauss_table().expect("a Gaussian widget under independent emission").memory_bytes();
        assert!(erf > 0);
        assert_eq!(b.memory_bytes(), erf);
        assert_eq!(b.full_memory_bytes(), erf);
    }

    const TF: &str = r#"{"color": [[0, 1, 0, 0], [1, 0, 0, 1]], "opacity": [[0, 0.5], [1, 3]], "unit_distance": 1}"#;
    const TF_W: &str = r#"{"color": [[0, 1, 0, 0], [1, 0, 0, 1]], "opacity": [[0, 0.5], [1, 3]], "unit_distance": 1,
        "widgets": [{"type": "box", "center": [0.5, 1], "width": [0.2, 1], "color": [1, 1, 1], "opacity": 2}]}"#;

    fn small() -> BakeOptions {
        let mut o = BakeOptions::default();
        o.table3d.n_s = 16;
        o.table3d.n_l = 8;
        o.psi.res = 32;
        o.poly_res = 16;
        o.fb_res = 16;
        o
    }

    #[test]
    fn every_method_bakes_and_shades_close_to_exact() {
        let tf = tf(TF);
        let d = TableDomain::new(0.0, 1.0, 0.3, 1.0).unwrap();
        let exact = ExactShader::new(tf.clone());
        let seg = Segment { s_front: 0.4, s_back: 0.6, len_world: 0.5, ..Default::default() };
        let want = exact.shade(&seg);
        for m in Method::ALL {
            let sh = make_shader(m, &tf, &d, &small()).unwrap();
            assert_eq!(sh.method(), m);
            let got = sh.shade(&seg);
            for c in 0..4 {
                assert!((got[c] - want[c]).abs() < 0.05, "{m}: {got:?} vs {want:?}");
            }
        }
    }

    #[test]
    fn one_d_methods_refuse_widgets_and_name_biv() {
        let tf = tf(TF_W);
        let d = TableDomain::new(0.0, 1.0, 0.3, 1.0).unwrap();
        for m in Method::ALL.into_iter().filter(|m| !m.is_bivariate()) {
            let e = make_shader(m, &tf, &d, &small()).err().expect("refused").to_string();
            assert!(e.contains("biv-exact") && e.contains(m.id()), "{m}: {e}");
        }
        for m in [Method::BivExact, Method::BivApprox] {
            assert!(make_shader(m, &tf, &d, &small()).is_ok());
        }
    }

    #[test]
    fn normalized_tf_maps_onto_the_domain() {
        let norm = tf(r#"{"normalized": true, "color": [[0, 1, 0, 0], [1, 0, 0, 1]], "opacity": [[0, 0.5], [1, 3]],
            "unit_distance": 1}"#);
        let d = TableDomain::new(10.0, 20.0, 10.0, 1.0).unwrap();
        let a = make_shader(Method::Exact, &norm, &d, &small()).unwrap();
        let b = ExactShader::new(norm.denormalize(10.0, 20.0).unwrap());
        let seg = Segment { s_front: 12.0, s_back: 18.0, len_world: 0.7, ..Default::default() };
        assert_eq!(a.shade(&seg), b.shade(&seg));
    }

    #[test]
    fn bad_options_are_errors() {
        let tf = tf(TF);
        let d = TableDomain::new(0.0, 1.0, 0.3, 1.0).unwrap();
        let mut o = small();
        o.precision_2d = Precision::Unorm8;
        assert!(make_shader(Method::Poly2, &tf, &d, &o).err().unwrap().to_string().contains("unorm8"));
        assert!(make_shader(Method::BivApprox, &tf, &d, &o).is_ok());
        let mut o = small();
        o.fb_res = 1;
        assert!(make_shader(Method::BivApprox, &tf, &d, &o).is_err());
        let mut o = small();
        o.biv_subsegments = 0;
        assert!(make_shader(Method::BivApprox, &tf, &d, &o).is_err());
        let mut o = small();
        o.poly_res = 1;
        assert!(make_shader(Method::Poly1, &tf, &d, &o).is_err());
    }
}
