//! Looks that change with a front end's edits: a table3d re-baked in place
//! for an edited TF is the fresh bake; the certifier bakes the newest look
//! asked for and hands back its certified table; a renderer keeps the cull
//! mask while the TF stays.

use tet_bundle::Bundle;
use tet_engine::{Certifier, CpuFrameRenderer, EngineError, FrameRenderer, FrameRequest, FrameStats, Look};
use tet_preint::{BakeOptions, Baked, CertifyOptions, Method, Table3dParams, TableDomain, TransferFunction};
use tet_render::{Image, ViewSpec};

fn cube5() -> Bundle {
    let path = concat!(env!("CARGO_MANIFEST_DIR"), "/../../formats/samples/cube5.tetb");
    Bundle::read(std::path::Path::new(path)).unwrap()
}

/// [`cube5`] and its table domain.
fn cube5_with_domain() -> (Bundle, TableDomain) {
    let bundle = cube5();
    let domain = TableDomain::from_bundle(&bundle).unwrap();
    (bundle, domain)
}

/// A TF in the bundle's data units: a colour ramp, opacity nodes at
/// every quarter of the range, the one at the first quarter `alpha` (an
/// edit of it reaches the pairs that meet the range's first half).
fn tf(bundle: &Bundle, alpha: f64) -> TransferFunction {
    let (lo, hi) = bundle.scalar_range();
    let at = |f: f64| lo + f * (hi - lo);
    let (q1, mid, q3) = (at(0.25), at(0.5), at(0.75));
    TransferFunction::from_json(&format!(
        r#"{{"color": [[{lo}, 1, 0.2, 0], [{hi}, 0.1, 0.4, 1]],
            "opacity": [[{lo}, 0.2], [{q1}, {alpha}], [{mid}, 0.5], [{q3}, 1.5], [{hi}, 0.5]], "unit_distance": 1}}"#
    ))
    .unwrap()
}

/// Plain table3d at n_s = 16 (certification off).
fn plain_options() -> BakeOptions {
    let defaults = BakeOptions::default();
    BakeOptions {
        table3d: Table3dParams { n_s: 16, n_l: 32, ..defaults.table3d },
        certify: CertifyOptions::off(),
        ..defaults
    }
}

/// `method` baked with [`plain_options`] for [`tf`]`(bundle, alpha)`.
fn plain_look(bundle: &Bundle, domain: &TableDomain, method: Method, alpha: f64) -> Look {
    Look::bake_with(domain, method, tf(bundle, alpha), &plain_options(), &[]).unwrap()
}

fn table_bits(look: &Look) -> Vec<u32> {
    let Some(Baked::Table3d(t)) = look.baked.as_deref() else { panic!("a table3d look") };
    t.storage().to_f32().into_iter().map(f32::to_bits).collect()
}

fn bits(img: &Image) -> Vec<[u32; 4]> {
    img.pixels().iter().map(|p| p.map(f32::to_bits)).collect()
}

/// A value edit re-bakes only some pairs and gives the fresh bake's table,
/// bit for bit, under a new key; the look before it is consumed.
#[test]
fn a_table3d_rebaked_for_an_edit_is_the_fresh_bake() {
    let (bundle, domain) = cube5_with_domain();
    let opts = plain_options();
    let first = plain_look(&bundle, &domain, Method::Table3d, 1.0);
    let first_key = first.key();
    assert!(first.rebake.is_none());
    let edited = first.rebake(&domain, tf(&bundle, 3.0), &opts).unwrap();
    let stats = edited.rebake.expect("re-baked in place");
    assert!(stats.full.is_none() && stats.pairs_rebaked < stats.pairs, "{stats:?}");
    assert_ne!(edited.key(), first_key);
    assert_eq!(edited.tf, tf(&bundle, 3.0));
    let fresh = plain_look(&bundle, &domain, Method::Table3d, 3.0);
    assert!(table_bits(&edited) == table_bits(&fresh));

    // Still holding the tables elsewhere (a clone) re-bakes a copy: the
    // clone keeps the old table.
    let before = table_bits(&edited);
    let held = edited.clone();
    let again = edited.rebake(&domain, tf(&bundle, 0.5), &opts).unwrap();
    assert!(table_bits(&held) == before);
    let fresh = plain_look(&bundle, &domain, Method::Table3d, 0.5);
    assert!(table_bits(&again) == table_bits(&fresh));
}

/// Other looks are baked afresh; a TF the method cannot take is refused
/// as a fresh bake refuses it.
#[test]
fn other_looks_rebake_afresh_and_bad_tfs_are_refused() {
    let (bundle, domain) = cube5_with_domain();
    let opts = plain_options();
    let linear = plain_look(&bundle, &domain, Method::PtLinear, 1.0);
    let linear = linear.rebake(&domain, tf(&bundle, 2.0), &opts).unwrap();
    assert!(linear.rebake.is_none() && linear.method == Method::PtLinear);
    assert_eq!(linear.tf, tf(&bundle, 2.0));

    // A new resolution: a fresh table at that resolution.
    let table = plain_look(&bundle, &domain, Method::Table3d, 1.0);
    let mut finer = plain_options();
    finer.table3d.n_s = 24;
    let table = table.rebake(&domain, tf(&bundle, 2.0), &finer).unwrap();
    assert!(table.rebake.is_none());
    let Some(Baked::Table3d(t)) = table.baked.as_deref() else { panic!("a table3d look") };
    assert_eq!(t.params().n_s, 24);

    let (lo, hi) = bundle.scalar_range();
    let widget = TransferFunction::from_json(&format!(
        r#"{{"color": [[{lo}, 1, 1, 1], [{hi}, 1, 1, 1]], "opacity": [[{lo}, 0], [{hi}, 1]], "unit_distance": 1,
            "widgets": [{{"type": "box", "center": [{lo}, 0], "width": [1, 1], "color": [1, 0, 0], "opacity": 1}}]}}"#
    ))
    .unwrap();
    let table = Look::bake_with(&domain, Method::Table3d, tf(&bundle, 1.0), &finer, &[]).unwrap();
    let err = table.rebake(&domain, widget, &finer).unwrap_err();
    assert!(matches!(err, EngineError::Bake { method: Method::Table3d, .. }), "{err}");
}

/// Three looks asked for while the first bakes: the first and the newest
/// are baked, the one in between never is; the newest's certified look
/// draws a certified table of its TF.
#[test]
fn the_certifier_bakes_the_newest_look() {
    let (bundle, domain) = cube5_with_domain();
    let opts = plain_options();
    let looks: Vec<Look> = [1.0, 2.0, 3.0]
        .into_iter()
        .map(|a| Look::bake_with(&domain, Method::Table3d, tf(&bundle, a), &opts, &[]).unwrap())
        .collect();
    let mut certifier = Certifier::new(&bundle, domain, CertifyOptions::default()).unwrap();
    assert!(!certifier.is_busy() && certifier.poll().is_none());
    for look in &looks {
        certifier.certify(look).unwrap();
        assert!(certifier.is_busy());
    }
    assert_eq!(certifier.wait(), Some(looks[2].key()));
    assert!(!certifier.is_busy());
    assert!(certifier.certified(looks[0].key()).is_none() && certifier.certified(looks[1].key()).is_none());
    let certified = certifier.certified(looks[2].key()).expect("done").expect("baked").clone();
    assert_eq!(certified.tf, looks[2].tf);
    assert_ne!(certified.key(), looks[2].key());
    let Some(Baked::Table3d(t)) = certified.baked.as_deref() else { panic!("a table3d look") };
    let c = t.certificate().expect("measured");
    assert!(c.certified && c.max_error <= c.target, "{c:?}");
    // Done: asking again bakes nothing.
    certifier.certify(&looks[2]).unwrap();
    assert!(!certifier.is_busy());

    // The certified table draws (on the CPU renderer) what a look built from
    // it draws: it is an ordinary look.
    let mut r = CpuFrameRenderer::new(&bundle).unwrap();
    let (lo, hi) = r.renderer().scene().bounds();
    let view = ViewSpec::framing(lo, hi, [24, 24]);
    let frame = r.render(&certified, &FrameRequest::new(view), &|_, _| {}).unwrap();
    assert!(frame.image.pixels().iter().any(|p| p[3] > 0.0));
}

#[test]
fn the_certifier_refuses_what_it_cannot_certify() {
    let (bundle, domain) = cube5_with_domain();
    let Err(e) = Certifier::new(&bundle, domain, CertifyOptions::off()) else { panic!("a certifier needs a target") };
    assert!(e.to_string().contains("target"), "{e}");
    let mut certifier = Certifier::new(&bundle, domain, CertifyOptions::default()).unwrap();
    let linear = Look::bake_with(&domain, Method::PtLinear, tf(&bundle, 1.0), &plain_options(), &[]).unwrap();
    let err = certifier.certify(&linear).unwrap_err();
    assert!(matches!(err, EngineError::NotCertifiable { method: Method::PtLinear }), "{err}");
    let by_gpu = Look::baked_by_renderer(&bundle, tf(&bundle, 1.0), Method::Table3d).unwrap();
    assert!(matches!(certifier.certify(&by_gpu), Err(EngineError::NotCertifiable { .. })));
    assert!(!certifier.is_busy());
}

/// A new look of the same TF (another method or resolution, the certified
/// table) keeps the cull mask; a new TF recomputes it; the images are a
/// fresh renderer's.
#[test]
fn the_cull_mask_stays_while_the_tf_does() {
    let (bundle, domain) = cube5_with_domain();
    let opts = plain_options();
    let mut r = CpuFrameRenderer::new(&bundle).unwrap();
    let (lo, hi) = r.renderer().scene().bounds();
    let req = FrameRequest::new(ViewSpec::framing(lo, hi, [32, 24]).orbit(25.0, 15.0, 1.0));
    let mut step = |look: &Look| {
        let frame = r.render(look, &req, &|_, _| {}).unwrap();
        let cold = CpuFrameRenderer::new(&bundle).unwrap().render(look, &req, &|_, _| {}).unwrap();
        assert!(bits(&frame.image) == bits(&cold.image), "{}", look.method);
        let FrameStats::Cpu(st) = frame.stats else { panic!("CPU statistics") };
        st.recomputed_cull
    };
    let table = plain_look(&bundle, &domain, Method::Table3d, 1.0);
    assert!(step(&table));
    let linear = plain_look(&bundle, &domain, Method::PtLinear, 1.0);
    assert!(!step(&linear));
    assert!(!step(&table));
    let edited = table.rebake(&domain, tf(&bundle, 0.0), &opts).unwrap();
    assert!(step(&edited));
}
