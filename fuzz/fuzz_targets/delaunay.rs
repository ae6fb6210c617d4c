//! Delaunay on small point sets built from the input bytes: coordinates
//! on a coarse grid (massive cospherical, coplanar and collinear ties and
//! duplicates) or arbitrary f64 bit patterns. Every result must pass the
//! library's brute-force invariant checker; errors must be the documented
//! ones (degenerate input, non-finite or too large coordinates).
#![no_main]
mod common;

use libfuzzer_sys::fuzz_target;
use tet_delaunay::{check_delaunay, tetrahedralize_points, DelaunayError, DelaunayOptions};

fuzz_target!(|data: &[u8]| {
    let Some((&mode, rest)) = data.split_first() else { return };
    let pts = common::points(mode, rest, 64, 32);
    let opts = DelaunayOptions { max_circumradius: (mode & 2 != 0).then_some(1.5) };
    match tetrahedralize_points(&pts, &opts) {
        Ok(d) => check_delaunay(&pts, &d, true).expect("Delaunay invariants"),
        Err(
            DelaunayError::Degenerate { .. }
            | DelaunayError::NonFinite { .. }
            | DelaunayError::CoordinateTooLarge { .. },
        ) => {}
        Err(e) => panic!("unexpected error: {e}"),
    }
});
