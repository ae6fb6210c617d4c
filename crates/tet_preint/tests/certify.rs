//! Issue 16: table3d's certify-and-refine bake on held-out transfer
//! functions (tests/data/heldout: a dozen narrow opacity peaks, an 8-node
//! sharp TF, near-discontinuous steps, plateaus; and a near-constant scalar
//! field), over the Blunt Fin bundle's (Sf, Sb, l) domain. Each
//! certificate is re-measured independently: other seeds, more segments.
use std::path::Path;
use tet_preint::certify::{self, CertifiedTable3d, CertifyOptions};
use tet_preint::{
    tf_for_domain, BakeOptions, Baked, LutFile, Method, Segment, SegmentShader, Table3dParams, TableDomain,
    TransferFunction,
};

const HELDOUT: [&str; 4] = ["tf_peaks12", "tf_sharp8", "tf_steps", "tf_plateaus"];

fn heldout(name: &str) -> TransferFunction {
    let p = Path::new(env!("CARGO_MANIFEST_DIR")).join(format!("tests/data/heldout/{name}.json"));
    TransferFunction::from_json(&std::fs::read_to_string(p).unwrap()).unwrap()
}

/// Blunt Fin's density domain (crates/tetlut/results/bluntfin.md).
fn bluntfin() -> TableDomain {
    TableDomain::new(0.1926, 4.9775, 2.0032, 3.6486).unwrap()
}

/// A near-constant field: a scalar range of 1e-2 around 100 (f32 steps of
/// 7.6e-6 there: the steps TF's ramps are narrower than one).
fn near_constant() -> TableDomain {
    TableDomain::new(100.0, 100.01, 0.01, 3.6486).unwrap()
}

/// A smaller start than the default (the refinement is what is tested).
fn start() -> Table3dParams {
    Table3dParams { n_s: 64, n_l: 128, ..BakeOptions::default().table3d }
}

fn check(name: &str, domain: &TableDomain) {
    let tf = tf_for_domain(&heldout(name), domain).unwrap();
    let opts = CertifyOptions { samples: 8192, ..Default::default() };
    let t = certify::bake(&tf, domain, &start(), &opts, &[]).unwrap();
    let c = t.certificate().expect("a certificate");
    assert!(c.certified, "{name}: {}", c.summary());
    assert!(c.max_error <= 1e-3 * certify::CERTIFY_MARGIN, "{name}: {}", c.summary());
    assert!(c.sets.iter().any(|s| s.set == "tf-nodes" && s.samples >= 8192), "{name}: {:?}", c.sets);
    // Independently: another seed, five times the segments per set.
    let again = certify::remeasure(&t, &tf, domain, 40_000, 0x5eed_0016, &[]);
    for s in &again {
        assert!(s.max <= 1e-3, "{name}: re-measured {} max {:e} ({})", s.set, s.max, c.summary());
    }
}

#[test]
fn heldout_tfs_are_certified_and_hold_on_fresh_segments() {
    for name in HELDOUT {
        check(name, &bluntfin());
    }
}

#[test]
fn near_constant_field_is_certified_and_holds() {
    for name in ["tf_sharp8", "tf_steps"] {
        check(name, &near_constant());
    }
}

/// The default options (what make_shader bakes) on the sample TF: no
/// refinement needed, the plain 128 × 128 × 256 table, certified.
#[test]
fn sample_tf_needs_no_refinement() {
    let tfn = TransferFunction::from_json(include_str!("../../../formats/samples/tf_normalized.json")).unwrap();
    let d = bluntfin();
    let b = Baked::build(Method::Table3d, &tfn, &d, &BakeOptions::default()).unwrap();
    let Baked::Table3d(t) = &b else { panic!("table3d") };
    let c = t.certificate().unwrap();
    assert!(c.certified && !c.split_at_tf_nodes && c.exact_intervals.is_empty(), "{}", c.summary());
    assert_eq!((t.params().n_s, t.params().n_l), (128, 256));
}

#[test]
fn impossible_target_in_a_tiny_budget_is_not_certified_and_says_so() {
    let d = bluntfin();
    let tf = tf_for_domain(&heldout("tf_peaks12"), &d).unwrap();
    // 1e-9 is below the f32 rounding of the results: nothing reaches it.
    let opts = CertifyOptions { max_error: Some(1e-9), memory_budget: 4 << 20, samples: 2048, ..Default::default() };
    let p = Table3dParams { n_s: 32, n_l: 64, ..BakeOptions::default().table3d };
    let t = certify::bake(&tf, &d, &p, &opts, &[]).unwrap();
    let c = t.certificate().unwrap();
    assert!(!c.certified, "{}", c.summary());
    assert!(c.max_error > 1e-9 && c.max_error.is_finite(), "{}", c.summary());
    assert!(c.limit.is_some() && c.summary().contains("NOT certified"), "{}", c.summary());
    assert!(t.memory_bytes() <= 4 << 20);
    // A starting table over the budget is baked (it was asked for) but never certified.
    let opts = CertifyOptions { memory_budget: 1 << 10, samples: 2048, ..Default::default() };
    let c = certify::bake(&tf, &d, &p, &opts, &[]).unwrap().certificate().unwrap().clone();
    assert!(!c.certified && c.limit.as_deref().unwrap().contains("budget"), "{}", c.summary());
}

#[test]
fn bad_targets_are_errors() {
    let d = bluntfin();
    let tf = tf_for_domain(&heldout("tf_sharp8"), &d).unwrap();
    for e in [0.0, -1.0, f64::NAN, f64::INFINITY] {
        let opts = CertifyOptions { max_error: Some(e), ..Default::default() };
        let err = certify::bake(&tf, &d, &start(), &opts, &[]).expect_err("refused").to_string();
        assert!(err.contains("max error"), "{err}");
    }
}

/// The certificate, the split lookup and the exact intervals survive the
/// `.tetl`: same figure, same pixels.
#[test]
fn tetl_round_trips_the_certificate_and_the_lookup() {
    let d = bluntfin();
    let tfn = heldout("tf_peaks12");
    let mut opts = BakeOptions { table3d: start(), ..Default::default() };
    opts.certify.samples = 4096;
    let tf = tf_for_domain(&tfn, &d).unwrap();
    let lut = tet_preint::bake(Method::Table3d, &tfn, &d, &opts).unwrap();
    let c = lut.header.certificate.clone().expect("stored");
    assert!(c.certified && (c.split_at_tf_nodes || !c.exact_intervals.is_empty()), "{}", c.summary());
    let path = Path::new("mem.tetl");
    let back = LutFile::from_bytes(&lut.to_bytes(), path).unwrap();
    // JSON keeps every field; floats to within their last digit.
    let same = |a: &tet_preint::Certificate, b: &tet_preint::Certificate| {
        assert_eq!((a.target, a.certified, a.split_at_tf_nodes), (b.target, b.certified, b.split_at_tf_nodes));
        assert_eq!(
            (&a.exact_intervals, a.intervals, a.attempts.len()),
            (&b.exact_intervals, b.intervals, b.attempts.len())
        );
        assert!((a.max_error - b.max_error).abs() <= 1e-15 * a.max_error.abs(), "{} {}", a.max_error, b.max_error);
        assert_eq!(a.sets.len(), b.sets.len());
    };
    same(back.header.certificate.as_ref().expect("read back"), &c);
    let Baked::Table3d(t) = Baked::from_lut(&back, path).unwrap() else { panic!("table3d") };
    same(t.certificate().expect("kept"), &c);
    assert_eq!(t.splits_at_tf_nodes(), c.split_at_tf_nodes);
    assert_eq!(t.exact_intervals(), c.exact_intervals);
    let direct = certify::bake(&tf, &d, &start(), &opts.certify, &[]).unwrap();
    for tr in tet_preint::uniform_triples(&d, 2000, 9).into_iter().chain(certify::node_triples(&tf, &d, 2000, 9)) {
        let s = Segment { s_front: tr[0], s_back: tr[1], len_world: tr[2], ..Default::default() };
        assert_eq!(t.shade(&s), direct.shade(&s), "{tr:?}");
    }
    // A version-4 style header (no certificate) reads as a plain table.
    let mut old = back.clone();
    old.header.certificate = None;
    let Baked::Table3d(p) = Baked::from_lut(&old, path).unwrap() else { panic!("table3d") };
    assert!(p.certificate().is_none() && !p.splits_at_tf_nodes() && p.exact_intervals().is_empty());
    // An exact interval the TF does not have is an error naming the field.
    let mut bad = back;
    bad.header.certificate.as_mut().unwrap().exact_intervals = vec![10_000];
    let e = Baked::from_lut(&bad, path).expect_err("refused").to_string();
    assert!(e.contains("exact_intervals"), "{e}");
}

/// The batch and span paths return what `shade` returns, split and exact
/// segments mixed with plain ones.
#[test]
fn batch_and_span_agree_with_shade() {
    let d = bluntfin();
    let tf = tf_for_domain(&heldout("tf_steps"), &d).unwrap();
    let opts = CertifyOptions { samples: 4096, ..Default::default() };
    let t: CertifiedTable3d = certify::bake(&tf, &d, &start(), &opts, &[]).unwrap();
    let mut tr = certify::node_triples(&tf, &d, 500, 3);
    tr.extend(tet_preint::uniform_triples(&d, 500, 4));
    let segs: Vec<Segment> =
        tr.iter().map(|t| Segment { s_front: t[0], s_back: t[1], len_world: t[2], ..Default::default() }).collect();
    let mut span = vec![[0.0f32; 4]; segs.len()];
    t.shade_span(&segs, &mut span);
    for (chunk, want) in segs.chunks(tet_preint::BATCH).zip(span.chunks(tet_preint::BATCH)) {
        let mut out = [[0.0f32; 4]; tet_preint::BATCH];
        t.shade_batch(&tet_preint::SegmentBatch::from_segments(chunk), &mut out);
        for (i, s) in chunk.iter().enumerate() {
            assert_eq!(out[i], t.shade(s));
            assert_eq!(want[i], t.shade(s));
        }
    }
}

/// Cut segments shaded in a batch (their pieces looked up together, in
/// batches of their own) give what `shade` gives, bit for bit: a TF of 100
/// control points, so that a segment across the range has more pieces than
/// a batch holds (shaded one by one) and short ones fill several piece
/// batches; an exact interval among them.
#[test]
fn cut_segments_in_a_batch_agree_with_shade() {
    let d = bluntfin();
    let opacity: Vec<String> =
        (0..=100).map(|k| format!("[{}, {}]", k as f64 / 100.0, if k % 2 == 0 { 0.05 } else { 0.6 })).collect();
    let json = format!(
        r#"{{"color": [[0, 0.2, 0.4, 1], [1, 1, 0.5, 0]], "opacity": [{}], "unit_distance": 1}}"#,
        opacity.join(", ")
    );
    let tf = tf_for_domain(&TransferFunction::from_json(&json).unwrap(), &d).unwrap();
    let table = tet_preint::Table3d::build(&tf, &d, &start()).unwrap();
    let nodes = certify::split_nodes(&tf, &d).len();
    assert!(nodes > tet_preint::BATCH, "{nodes} control points inside the domain");
    let certificate = certify::Certificate {
        target: 1e-3,
        certified: false,
        max_error: 1.0,
        margin: 0.9,
        split_at_tf_nodes: true,
        exact_intervals: vec![7, 40],
        intervals: nodes + 1,
        exact_share: 0.0,
        memory_budget: 0,
        memory_bytes: 0,
        sets: Vec::new(),
        attempts: Vec::new(),
        limit: None,
    };
    let t = CertifiedTable3d::from_parts(table, Some(&tf), Some(certificate)).unwrap();
    assert!(t.splits_at_tf_nodes());
    let (lo, span) = (d.s_lo as f32, d.scalar_span() as f32);
    // Short segments crossing 0–3 nodes, a few across the whole range, and
    // ones inside an exact interval, in an order that mixes them.
    let mut segs = Vec::new();
    for k in 0..400 {
        let a = lo + span * ((k * 37 % 400) as f32 / 400.0);
        let w = span * [0.004, 0.013, 0.031, 0.9][k % 4] * if k % 3 == 0 { -1.0 } else { 1.0 };
        let b = (a + w).clamp(lo, lo + span);
        segs.push(Segment { s_front: a, s_back: b, len_world: 0.05 + (k % 7) as f32 * 0.3, ..Default::default() });
    }
    let mut cut = 0;
    for chunk in segs.chunks(tet_preint::BATCH) {
        let mut out = [[0.0f32; 4]; tet_preint::BATCH];
        t.shade_batch(&tet_preint::SegmentBatch::from_segments(chunk), &mut out);
        for (i, s) in chunk.iter().enumerate() {
            assert_eq!(out[i], t.shade(s), "{s:?}");
            cut += usize::from(s.s_front != s.s_back);
        }
    }
    assert!(cut > 300);
}
