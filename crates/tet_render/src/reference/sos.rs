//! The one predicate the ray walk decides with: on which side a ray's line
//! passes an oriented edge, exact and never zero.
//!
//! For the line through `o` and `q` and the edge `a → b`,
//! `orient3d(o, q, a, b)` is (a positive multiple of) the Plücker side
//! product. It is zero when the line meets the edge's line (through an edge
//! or vertex, or coplanar). Zero is then broken by Simulation of Simplicity
//! (Edelsbrunner & Mücke 1990) applied to the line alone: the coordinates of
//! `o` and `q` are perturbed by ε^(2^k), k = 0..5 in the order o.x, o.y, o.z,
//! q.x, q.y, q.z, and the sign is that of the first non-vanishing
//! coefficient. Every decision therefore describes one and the same
//! (infinitesimally moved) line, which passes through no vertex or edge of
//! the mesh: it enters and leaves each tet exactly once, so the walk can
//! neither lose a tet nor visit one twice. Mesh points are not perturbed.

use robust::{orient2d, orient3d, Coord, Coord3D};

#[inline]
fn c3(p: &[f64; 3]) -> Coord3D<f64> {
    Coord3D { x: p[0], y: p[1], z: p[2] }
}

/// `(value, sign)`: `value` = orient3d(o, q, a, b) (its sign exact), `sign`
/// = ±1 after symbolic perturbation, or 0 only when `a == b`.
#[inline]
pub(crate) fn line_side(o: &[f64; 3], q: &[f64; 3], a: &[f64; 3], b: &[f64; 3]) -> (f64, i8) {
    let v = orient3d(c3(o), c3(q), c3(a), c3(b));
    if v > 0.0 {
        (v, 1)
    } else if v < 0.0 {
        (v, -1)
    } else {
        (0.0, perturbed_sign([o, q, a, b]))
    }
}

/// Sign of the 4×4 determinant with homogeneous rows (p, 1) for
/// rows = [o, q, a, b] (which equals orient3d(o, q, a, b)) under the
/// perturbation described in the module comment.
fn perturbed_sign(rows: [&[f64; 3]; 4]) -> i8 {
    // Perturbed entry k sits at row k / 3 (0 = o, 1 = q), column k % 3.
    // Terms are visited by increasing exponent Σ 2^k, i.e. by mask value.
    for mask in 1u32..64 {
        let mut ks = [0usize; 6];
        let mut n = 0;
        for k in 0..6 {
            if mask & (1 << k) != 0 {
                ks[n] = k;
                n += 1;
            }
        }
        let s = match ks[..n] {
            [k] => single(rows, k / 3, k % 3),
            [k1, k2] => {
                let (r1, c1, r2, c2) = (k1 / 3, k1 % 3, k2 / 3, k2 % 3);
                if r1 == r2 || c1 == c2 {
                    continue; // two entries of one row or column: no such term
                }
                pair(rows, c1, c2)
            }
            _ => continue, // three or more entries always share a row
        };
        if s != 0 {
            return s;
        }
    }
    0
}

fn sign(v: f64) -> i8 {
    if v > 0.0 {
        1
    } else if v < 0.0 {
        -1
    } else {
        0
    }
}

/// Coefficient of the single entry (row r, column c): the determinant with
/// row r replaced by the unit vector e_c, i.e. (−1)^(r+c) times the minor,
/// which (with the column of ones kept last) is an exact orient2d of the
/// other three rows projected onto the two remaining axes.
fn single(rows: [&[f64; 3]; 4], r: usize, c: usize) -> i8 {
    let (u, v) = match c {
        0 => (1, 2),
        1 => (0, 2),
        _ => (0, 1),
    };
    let mut pts = [Coord { x: 0.0, y: 0.0 }; 3];
    let mut n = 0;
    for (i, p) in rows.iter().enumerate() {
        if i != r {
            pts[n] = Coord { x: p[u], y: p[v] };
            n += 1;
        }
    }
    let minor = sign(orient2d(pts[0], pts[1], pts[2]));
    if (r + c).is_multiple_of(2) {
        minor
    } else {
        -minor
    }
}

/// Coefficient of the entries (row 0, column c1) and (row 1, column c2),
/// c1 ≠ c2: rows 0 and 1 replaced by e_c1 and e_c2. Expanding along both
/// leaves det[[a_w, 1], [b_w, 1]] = a_w − b_w for the third axis w.
fn pair(rows: [&[f64; 3]; 4], c1: usize, c2: usize) -> i8 {
    let w = 3 - c1 - c2;
    // Row 0 at column c1: sign (−1)^(0+c1). In the 3×3 minor row 1 becomes
    // row 0 and column c2 shifts left when it lay right of c1.
    let c2_reduced = if c2 > c1 { c2 - 1 } else { c2 };
    let parity = (c1 + c2_reduced) % 2;
    let s = sign(rows[2][w] - rows[3][w]);
    if parity == 0 {
        s
    } else {
        -s
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The determinant of a 4×4 matrix by cofactors, in exact integer
    /// arithmetic (inputs are small integers).
    fn det4(m: [[i128; 4]; 4]) -> i128 {
        fn det3(m: [[i128; 3]; 3]) -> i128 {
            m[0][0] * (m[1][1] * m[2][2] - m[1][2] * m[2][1]) - m[0][1] * (m[1][0] * m[2][2] - m[1][2] * m[2][0])
                + m[0][2] * (m[1][0] * m[2][1] - m[1][1] * m[2][0])
        }
        let mut d = 0;
        for c in 0..4 {
            let mut sub = [[0i128; 3]; 3];
            for r in 1..4 {
                let mut cc = 0;
                for (k, v) in m[r].iter().enumerate() {
                    if k != c {
                        sub[r - 1][cc] = *v;
                        cc += 1;
                    }
                }
            }
            let s = if c % 2 == 0 { 1 } else { -1 };
            d += s * m[0][c] * det3(sub);
        }
        d
    }

    /// Sign of det with o, q perturbed by ε^(2^k) for a concrete ε = 1/N:
    /// scaling everything by N^63 keeps it integral. N = 2^… would overflow
    /// i128, so use the polynomial in ε directly: evaluate coefficients by
    /// replacing rows with unit vectors and take the first non-zero in
    /// exponent order — independently of the minors used above.
    fn brute(rows: [[i64; 3]; 4]) -> i8 {
        let hom = |p: [i64; 3]| [p[0] as i128, p[1] as i128, p[2] as i128, 1];
        let base = [hom(rows[0]), hom(rows[1]), hom(rows[2]), hom(rows[3])];
        let d0 = det4(base);
        if d0 != 0 {
            return d0.signum() as i8;
        }
        for mask in 1u32..64 {
            let ks: Vec<usize> = (0..6).filter(|k| mask & (1 << k) != 0).collect();
            let mut m = base;
            let mut rows_used = [false; 2];
            let mut ok = true;
            for &k in &ks {
                let (r, c) = (k / 3, k % 3);
                if rows_used[r] {
                    ok = false;
                }
                rows_used[r] = true;
                m[r] = [0; 4];
                m[r][c] = 1;
            }
            if !ok {
                continue;
            }
            let d = det4(m);
            if d != 0 {
                return d.signum() as i8;
            }
        }
        0
    }

    #[test]
    fn perturbed_sign_matches_cofactor_expansion_on_degenerate_lattice_inputs() {
        // Exhaustive-ish over small lattice configurations, most of them
        // degenerate (coplanar, collinear, shared points).
        let vals = [-1i64, 0, 1];
        let mut checked = 0;
        let mut state = 12345u64;
        let mut next = || {
            state = state.wrapping_mul(6364136223846793005).wrapping_add(1442695040888963407);
            vals[((state >> 33) % 3) as usize]
        };
        for _ in 0..20000 {
            let rows: [[i64; 3]; 4] = std::array::from_fn(|_| [next(), next(), next()]);
            if rows[2] == rows[3] || rows[0] == rows[1] {
                continue;
            }
            let f = |p: [i64; 3]| [p[0] as f64, p[1] as f64, p[2] as f64];
            let (o, q, a, b) = (f(rows[0]), f(rows[1]), f(rows[2]), f(rows[3]));
            let (_, s) = line_side(&o, &q, &a, &b);
            assert_eq!(s, brute(rows), "{rows:?}");
            assert_ne!(s, 0);
            // Antisymmetric in the edge's direction.
            assert_eq!(line_side(&o, &q, &b, &a).1, -s);
            checked += 1;
        }
        assert!(checked > 10000);
    }
}
