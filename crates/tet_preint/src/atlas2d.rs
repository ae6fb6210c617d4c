//! `atlas2d`: Röttger & Ertl's (2002) cylindrical mapping of the 3D table onto planes
//! through the front diagonal, tiled into one 2D image (Röttger & Ertl 2002,
//! eqs. 9–10).
//!
//! With Sf, Sb, l normalized to [0, 1] (by the domain's scalar range and
//! l_max) and sheared coordinates u = Sf − Sb, v = Sb, w = l, a plane is
//! selected by the piecewise-linear pseudo-angle α ∈ [0, 1] and
//! parametrized by the L∞ radius s = max(|u|, w) and t = Sb
//! ([`plane_to_table`], [`table_to_plane`]). Plane p of P sits at
//! α = p / (P − 1); each has `res × res` texels over (s, t) ∈ [0, 1]², and
//! plane p is the tile (p mod cols, p div cols) of an image `cols` tiles
//! wide. Texels are resampled from a [`Table3d`] by its trilinear lookup;
//! texels whose (Sf, Sb, l) falls outside the table's domain take the
//! clamped value (a linear tet never produces them). A lookup blends the two
//! planes nearest its α linearly, bilinear in (s, t) within each.

use crate::domain::{check_res, TableDomain, TableError, MAX_TABLE_ENTRIES};
use crate::method::{Method, Rgba32, Segment, SegmentShader};
use crate::precision::{Precision, Storage};
use crate::table3d::Table3d;
use rayon::prelude::*;
use serde::{Deserialize, Serialize};

/// Normalized (Sf, Sb, l) of the point at pseudo-angle `alpha`, radius `s`
/// and t = Sb on its plane (the appendix's f).
pub fn plane_to_table(alpha: f64, s: f64, t: f64) -> [f64; 3] {
    if alpha <= 0.25 {
        [t + s, t, 4.0 * alpha * s]
    } else if alpha <= 0.5 {
        [t + 4.0 * (0.5 - alpha) * s, t, s]
    } else if alpha <= 0.75 {
        [t - 4.0 * (alpha - 0.5) * s, t, s]
    } else {
        [t - s, t, 4.0 * (1.0 - alpha) * s]
    }
}

/// (α, s, t) of normalized (Sf, Sb, l): the inverse of [`plane_to_table`].
/// On the axis u = w = 0 the angle is undefined and 0 is returned.
pub fn table_to_plane(sf: f64, sb: f64, l: f64) -> [f64; 3] {
    let (u, w) = (sf - sb, l.max(0.0));
    let (alpha, s) = if u >= w {
        if u == 0.0 {
            (0.0, 0.0)
        } else {
            (w / (4.0 * u), u)
        }
    } else if u >= 0.0 {
        (0.5 - u / (4.0 * w), w)
    } else if -u <= w {
        (0.5 + (-u) / (4.0 * w), w)
    } else {
        (1.0 - w / (4.0 * (-u)), -u)
    };
    [alpha, s, sb]
}

/// Plane count and storage of an [`Atlas2d`].
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
pub struct Atlas2dParams {
    /// Number of planes P (≥ 2): 4N reconstructs an N³ table, N and N/2 are
    /// Röttger & Ertl's (2002) cheaper variants.
    pub planes: usize,
    /// Texels per plane side over (s, t).
    pub res: usize,
    pub precision: Precision,
}

impl Atlas2dParams {
    /// The choices of Röttger & Ertl, "A Two-Step Approach for Interactive
    /// Pre-Integrated Volume Rendering of Unstructured Grids", 2002, for an
    /// N-sample table: `factor` 4 (exact), 1 or ½
    /// (given as quarters: 16, 4, 2), `res` = N.
    pub fn for_table(table: &Table3d, planes_per_n_quarters: usize, precision: Precision) -> Atlas2dParams {
        let n = table.params().n_s;
        Atlas2dParams { planes: (n * planes_per_n_quarters / 4).max(2), res: n, precision }
    }
}

/// The tiled atlas; implements [`SegmentShader`].
#[derive(Debug, Clone)]
pub struct Atlas2d {
    domain: TableDomain,
    params: Atlas2dParams,
    cols: usize,
    rows: usize,
    data: Storage,
}

impl Atlas2d {
    /// Resamples `table` onto `params.planes` planes.
    pub fn build(table: &Table3d, params: &Atlas2dParams) -> Result<Atlas2d, TableError> {
        check_res("atlas2d planes", params.planes, 2, 1 << 16)?;
        check_res("atlas2d res", params.res, 2, 1 << 14)?;
        let (cols, rows) = tiling(params.planes);
        let (width, height) = (cols * params.res, rows * params.res);
        let entries = (width * height) as u64;
        if entries > MAX_TABLE_ENTRIES {
            return Err(TableError::TooLarge { entries, max: MAX_TABLE_ENTRIES });
        }
        let d = *table.domain();
        let res = params.res;
        let top = (res - 1) as f64;
        let mut image = vec![0.0f32; width * height * 4];
        // One image row of tiles per parallel task.
        image.par_chunks_mut(width * res * 4).enumerate().for_each(|(tile_row, band)| {
            for tile_col in 0..cols {
                let p = tile_row * cols + tile_col;
                if p >= params.planes {
                    break;
                }
                let alpha = p as f64 / (params.planes - 1) as f64;
                for y in 0..res {
                    for x in 0..res {
                        let [sf, sb, l] = plane_to_table(alpha, x as f64 / top, y as f64 / top);
                        let v = table.lookup(
                            (d.s_lo + sf * d.scalar_span()) as f32,
                            (d.s_lo + sb * d.scalar_span()) as f32,
                            (l * d.len_max_world) as f32,
                        );
                        let o = (y * width + tile_col * res + x) * 4;
                        band[o..o + 4].copy_from_slice(&v);
                    }
                }
            }
        });
        let data = Storage::encode(image, 4, params.precision);
        Ok(Atlas2d { domain: d, params: *params, cols, rows, data })
    }

    /// Reassembles an atlas from stored parts; `None` when `data` is not the
    /// tiled image of `params`.
    pub fn from_parts(domain: TableDomain, params: Atlas2dParams, data: Storage) -> Option<Atlas2d> {
        if params.planes < 2 || params.res < 2 || params.planes > 1 << 16 || params.res > 1 << 14 {
            return None;
        }
        let (cols, rows) = tiling(params.planes);
        if data.channels() != 4
            || data.precision() != params.precision
            || data.len() != cols * rows * params.res * params.res * 4
        {
            return None;
        }
        Some(Atlas2d { domain, params, cols, rows, data })
    }

    pub fn domain(&self) -> &TableDomain {
        &self.domain
    }
    pub fn params(&self) -> &Atlas2dParams {
        &self.params
    }
    pub fn storage(&self) -> &Storage {
        &self.data
    }
    /// Image size in texels (width, height).
    pub fn image_size(&self) -> (usize, usize) {
        (self.cols * self.params.res, self.rows * self.params.res)
    }
    /// Bytes of the stored image.
    pub fn memory_bytes(&self) -> usize {
        self.data.memory_bytes()
    }
    /// The image as RGBA texels, row-major (what `tetlut show` draws).
    pub fn image(&self) -> Vec<Rgba32> {
        (0..self.data.len() / 4).map(|i| self.data.get4(i * 4)).collect()
    }

    #[inline]
    fn texel(&self, plane: usize, x: usize, y: usize) -> [f32; 4] {
        let res = self.params.res;
        let (tc, tr) = (plane % self.cols, plane / self.cols);
        let width = self.cols * res;
        self.data.get4(((tr * res + y) * width + tc * res + x) * 4)
    }

    fn bilinear(&self, plane: usize, s: f32, t: f32) -> [f32; 4] {
        let top = (self.params.res - 1) as f32;
        let (xs, yt) = ((s * top).clamp(0.0, top), (t * top).clamp(0.0, top));
        let x0 = (xs as usize).min(self.params.res - 2);
        let y0 = (yt as usize).min(self.params.res - 2);
        let (fx, fy) = (xs - x0 as f32, yt - y0 as f32);
        let mut out = [0.0f32; 4];
        for (dy, wy) in [(0, 1.0 - fy), (1, fy)] {
            for (dx, wx) in [(0, 1.0 - fx), (1, fx)] {
                let e = self.texel(plane, x0 + dx, y0 + dy);
                for c in 0..4 {
                    out[c] += wx * wy * e[c];
                }
            }
        }
        out
    }

    /// Lookup of a segment; inputs outside the domain (and NaN) are clamped.
    // max/min rather than clamp: they map NaN to the low edge, clamp keeps it.
    #[allow(clippy::manual_clamp)]
    pub fn lookup(&self, sf: f32, sb: f32, len_world: f32) -> Rgba32 {
        let d = &self.domain;
        let norm = |s: f32| (((s as f64 - d.s_lo) / d.scalar_span()).max(0.0).min(1.0)) as f32;
        let (sf, sb) = (norm(sf), norm(sb));
        let l = ((len_world as f64 / d.len_max_world).max(0.0).min(1.0)) as f32;
        let [alpha, s, t] = table_to_plane(sf as f64, sb as f64, l as f64);
        let x = (alpha as f32 * (self.params.planes - 1) as f32).clamp(0.0, (self.params.planes - 1) as f32);
        let p0 = (x as usize).min(self.params.planes - 2);
        let f = x - p0 as f32;
        let (s, t) = (s as f32, t as f32);
        let a = self.bilinear(p0, s, t);
        let b = self.bilinear(p0 + 1, s, t);
        std::array::from_fn(|c| a[c] + f * (b[c] - a[c]))
    }
}

/// Tiles per row and rows of tiles for `planes` planes (near-square).
fn tiling(planes: usize) -> (usize, usize) {
    let cols = (planes as f64).sqrt().ceil() as usize;
    (cols, planes.div_ceil(cols))
}

impl SegmentShader for Atlas2d {
    fn method(&self) -> Method {
        Method::Atlas2d
    }
    fn shade(&self, seg: &Segment) -> Rgba32 {
        self.lookup(seg.s_front, seg.s_back, seg.len_world)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::table3d::{Build3d, Table3dParams};
    use crate::TransferFunction;
    use proptest::prelude::*;

    proptest! {
        #![proptest_config(ProptestConfig { cases: 2000, rng_seed: proptest::test_runner::RngSeed::Fixed(7), ..ProptestConfig::default() })]
        #[test]
        fn mapping_round_trips(sf in 0.0f64..1.0, sb in 0.0f64..1.0, l in 0.0f64..1.0) {
            let [alpha, s, t] = table_to_plane(sf, sb, l);
            prop_assert!((0.0..=1.0).contains(&alpha) && (0.0..=1.0).contains(&s));
            let back = plane_to_table(alpha, s, t);
            for (x, y) in back.iter().zip([sf, sb, l]) {
                prop_assert!((x - y).abs() < 1e-12, "{:?} vs {:?}", back, (sf, sb, l));
            }
        }
    }

    #[test]
    fn axis_and_diagonal() {
        assert_eq!(table_to_plane(0.3, 0.3, 0.0), [0.0, 0.0, 0.3]);
        assert_eq!(plane_to_table(0.7, 0.0, 0.4), [0.4, 0.4, 0.0]);
        // Pure l (u = 0) is the middle plane.
        assert_eq!(table_to_plane(0.5, 0.5, 0.2)[0], 0.5);
    }

    #[test]
    fn more_planes_approach_the_table() {
        let tf = TransferFunction::from_json(
            r#"{"color": [[0, 0.2, 0.4, 0.6], [1, 0.8, 0.3, 0.1]],
                "opacity": [[0, 0.1], [0.3, 0.6], [0.7, 0.2], [1, 0.9]], "unit_distance": 1}"#,
        )
        .unwrap();
        let d = TableDomain::full(0.0, 1.0, 2.0).unwrap();
        let t =
            Table3d::build(&tf, &d, &Table3dParams { n_s: 16, n_l: 16, build: Build3d::Exact, ..Default::default() })
                .unwrap();
        let err = |quarters: usize| {
            let a = Atlas2d::build(&t, &Atlas2dParams::for_table(&t, quarters, Precision::F32)).unwrap();
            let mut worst = 0.0f32;
            let mut state = 12345u64;
            let mut next = || {
                state = state.wrapping_mul(6364136223846793005).wrapping_add(1442695040888963407);
                (state >> 40) as f32 / (1u64 << 24) as f32
            };
            for _ in 0..3000 {
                let (sf, sb, l) = (next(), next(), 2.0 * next());
                let (x, y) = (a.lookup(sf, sb, l), t.lookup(sf, sb, l));
                for c in 0..4 {
                    worst = worst.max((x[c] - y[c]).abs());
                }
                assert!(x.iter().all(|v| v.is_finite()));
            }
            worst
        };
        let (e4, e1, eh) = (err(16), err(4), err(2));
        assert!(e4 < e1 && e1 < eh, "4N {e4}, N {e1}, N/2 {eh}");
        assert!(e4 < 0.03, "4N planes differ from the table by {e4}");
    }
}
