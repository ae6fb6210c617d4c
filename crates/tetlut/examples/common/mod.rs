//! What the table3d examples share: their first two arguments.

use tet_bundle::Bundle;
use tet_preint::{TableDomain, TransferFunction};

/// The bundle (`args[1]`) and TF file (`args[2]`) every example takes: the
/// bundle, its table domain and the TF mapped onto that domain (as `tetlut
/// bake` maps it). Panics with what failed, as examples may.
pub fn bundle_domain_tf(args: &[String]) -> (Bundle, TableDomain, TransferFunction) {
    let bundle = Bundle::read(std::path::Path::new(&args[1])).expect("bundle");
    let tf = TransferFunction::from_json(&std::fs::read_to_string(&args[2]).expect("tf")).expect("tf json");
    let domain = TableDomain::from_bundle(&bundle).expect("domain");
    let tf = tet_preint::tf_for_domain(&tf, &domain).expect("tf for domain");
    (bundle, domain, tf)
}
