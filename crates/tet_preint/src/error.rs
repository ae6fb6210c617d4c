//! Error of a method against `exact` over (Sf, Sb, l) triples.

use crate::domain::TableDomain;
use crate::exact::integrate_segment_with;
use crate::method::{Segment, SegmentShader};
use crate::tf::TransferFunction;
use rayon::prelude::*;

/// (RMS, max) absolute error of `shader` against the f64 exact integral
/// over every channel (R, G, B, A) of every triple `[Sf, Sb, l]`. The exact
/// side integrates the same f32 inputs, so only the method's error counts.
/// An empty list gives (0, 0).
pub fn table_error(shader: &dyn SegmentShader, tf: &TransferFunction, triples: &[[f32; 3]]) -> (f64, f64) {
    if triples.is_empty() {
        return (0.0, 0.0);
    }
    let (sum, max) = triples
        .par_chunks(4096)
        .map(|chunk| {
            let mut scratch = Vec::new();
            let (mut sum, mut max) = (0.0f64, 0.0f64);
            for t in chunk {
                let seg = Segment { s_front: t[0], s_back: t[1], len_world: t[2], ..Default::default() };
                let got = shader.shade(&seg);
                let want = integrate_segment_with(tf, t[0] as f64, t[1] as f64, (t[2] as f64).max(0.0), &mut scratch);
                for (g, w) in got.iter().zip(want.to_array()) {
                    let e = (*g as f64 - w).abs();
                    sum += e * e;
                    max = max.max(e);
                }
            }
            (sum, max)
        })
        .reduce(|| (0.0, 0.0), |a, b| (a.0 + b.0, a.1.max(b.1)));
    ((sum / (4 * triples.len()) as f64).sqrt(), max)
}

/// A fixed-seed LCG (Knuth's MMIX constants) drawing uniform f64 in
/// [0, 1) from the top 53 bits of its state: repeatable draws for error
/// measurements, tests and benchmarks without a rand crate.
pub fn lcg_unit(seed: u64) -> impl FnMut() -> f64 {
    let mut state = seed;
    move || {
        state = state.wrapping_mul(6364136223846793005).wrapping_add(1442695040888963407);
        (state >> 11) as f64 / (1u64 << 53) as f64
    }
}

/// `count` triples uniform over `domain`'s band (Sf uniform over the scalar
/// range, Sb within max_ds of it, l uniform over [0, l_max]) from a fixed
/// 64-bit `seed`, for repeatable error measurements.
pub fn uniform_triples(domain: &TableDomain, count: usize, seed: u64) -> Vec<[f32; 3]> {
    let mut next = lcg_unit(seed ^ 0x9e37_79b9_7f4a_7c15);
    (0..count)
        .map(|_| {
            let sf = domain.s_lo + next() * domain.scalar_span();
            let sb = (sf + (2.0 * next() - 1.0) * domain.max_ds).clamp(domain.s_lo, domain.s_hi);
            [sf as f32, sb as f32, (next() * domain.len_max_world) as f32]
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::ExactShader;

    #[test]
    fn exact_against_itself_is_tiny() {
        let tf = TransferFunction::from_json(
            r#"{"color": [[0, 1, 0, 0], [1, 0, 0, 1]], "opacity": [[0, 0.5], [1, 3]], "unit_distance": 1}"#,
        )
        .unwrap();
        let d = TableDomain::new(0.0, 1.0, 0.3, 2.0).unwrap();
        let tri = uniform_triples(&d, 500, 1);
        assert!(tri.iter().all(|t| (t[0] - t[1]).abs() <= 0.3 + 1e-6 && (0.0..=2.0).contains(&t[2])));
        let (rms, max) = table_error(&ExactShader::new(tf.clone()), &tf, &tri);
        assert!(max < 1e-6 && rms <= max, "{rms} {max}");
        assert_eq!(table_error(&ExactShader::new(tf.clone()), &tf, &[]), (0.0, 0.0));
    }
}
