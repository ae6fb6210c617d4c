#![no_main]
//! Transfer-function JSON: whatever `TransferFunction::from_json` accepts
//! must denormalize without panicking and integrate any segment exactly
//! (and approximately, pt-linear) to finite RGBA with α in [0, 1]; and
//! whatever table (small resolutions) bakes from it must shade likewise.
use libfuzzer_sys::fuzz_target;
use tet_preint::{
    make_shader, BakeOptions, ExactShader, Method, PtLinearShader, Segment, SegmentShader, TableDomain,
    TransferFunction,
};

fuzz_target!(|data: &[u8]| {
    let Ok(text) = std::str::from_utf8(data) else { return };
    let Ok(mut tf) = TransferFunction::from_json(text) else { return };
    if tf.normalized() {
        let Ok(d) = tf.denormalize(-2.0, 3.0) else { return };
        tf = d;
    }
    let mut shaders: Vec<Box<dyn SegmentShader>> =
        vec![Box::new(ExactShader::new(tf.clone())), Box::new(PtLinearShader::new(tf.clone()))];
    // Small tables, so each input bakes in a few milliseconds.
    let mut opts = BakeOptions::default();
    (opts.table3d.n_s, opts.table3d.n_l, opts.poly_res, opts.psi.res) = (8, 16, 16, 32);
    let domain = TableDomain::new(-2.0, 3.0, 5.0, 200.0).expect("domain");
    for m in [Method::Table3d, Method::Poly2, Method::Partial] {
        if let Ok(s) = make_shader(m, &tf, &domain, &opts) {
            shaders.push(s);
        }
    }
    let segs = [(0.0f32, 1.0f32, 1.0f32), (-5.0, 7.0, 100.0), (0.5, 0.5, 1e6), (2.0, -2.0, 1e-6), (f32::NAN, 1.0, 1.0)];
    for s in &shaders {
        for &(sf, sb, l) in &segs {
            let c = s.shade(&Segment { s_front: sf, s_back: sb, grad_front: 0.5, grad_back: 1.5, len_world: l });
            assert!(c.iter().all(|v| v.is_finite()), "{sf} {sb} {l}: {c:?}");
            assert!((0.0..=1.0).contains(&c[3]), "{sf} {sb} {l}: {c:?}");
        }
    }
});
