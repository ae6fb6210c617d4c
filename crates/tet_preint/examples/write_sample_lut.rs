//! Regenerates `formats/samples/mild8.tetl` (a table3d of 8 × 8 × 4 in f16
//! for `crates/tet_preint/tests/data/vtk/tf_mild.json` over s ∈ [0, 1],
//! |Sf − Sb| ≤ 0.5, l ≤ 2, scalar samples on the TF's control points, so
//! format version 2 with a `SAXIS` section; `mild8_v1.tetl` is the same
//! table with a uniform axis as format version 1 wrote it, kept unchanged) and `formats/samples/mild_poly2.tetl` (poly2 at
//! 16² in f16, same TF and domain). Run only when the format version changes:
//! `cargo run -p tet_preint --example write_sample_lut`
use tet_preint::table3d::{Build3d, ScalarAxis, Table3dParams};
use tet_preint::{bake, BakeOptions, Method, Precision, TableDomain, TransferFunction};

fn main() {
    let root = concat!(env!("CARGO_MANIFEST_DIR"), "/../..");
    let tf = TransferFunction::from_json(include_str!("../tests/data/vtk/tf_mild.json")).expect("sample TF");
    let domain = TableDomain::new(0.0, 1.0, 0.5, 2.0).expect("domain");
    let opts = BakeOptions {
        table3d: Table3dParams {
            n_s: 8,
            n_l: 4,
            build: Build3d::Exact,
            precision: Precision::F16,
            s_axis: ScalarAxis::TfNodes,
        },
        ..Default::default()
    };
    let lut = bake(Method::Table3d, &tf, &domain, &opts).expect("bake");
    let path = std::path::Path::new(root).join("formats/samples/mild8.tetl");
    lut.write(&path).expect("write");
    println!("wrote {}", path.display());
    // poly2 at 16² in f16 over the same domain.
    let opts = BakeOptions { poly_res: 16, precision_2d: Precision::F16, ..Default::default() };
    let lut = bake(Method::Poly2, &tf, &domain, &opts).expect("bake");
    let path = std::path::Path::new(root).join("formats/samples/mild_poly2.tetl");
    lut.write(&path).expect("write");
    println!("wrote {}", path.display());
}
