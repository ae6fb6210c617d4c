//! A light-space deep shadow map for a directional light (after Lokovic &
//! Veach, "Deep Shadow Maps", SIGGRAPH 2000): a grid of rays travelling
//! with the light across the mesh's bounding box, each walked exactly
//! through the mesh, recording the optical depth from the light at every
//! tet crossing and every TF node it meets (between two of those the
//! depth is a smooth quadratic, so a narrow opaque layer of the TF is a
//! sharp step, not a ramp over a depth sample). A point's depth is
//! interpolated linearly along each of the four nearest rays and
//! bilinearly between them, so its resolution across the light is the
//! grid's, not the mesh's: a shadow edge inside a large cell stays sharp
//! to a ray spacing. A point light outside the mesh's bounding box gets the
//! same map with rays fanning out from it ([`DeepShadowMap::build_point`]).

use glam::DVec3;
use rayon::prelude::*;
use tet_preint::TransferFunction;

use super::ShadowScratch;
use crate::reference::{Line, LineSegment, ReferenceRenderer, ReferenceStats};

/// Rays across the longer side of the light's view of the bounding box.
pub const MAP_RAYS: usize = 256;

/// Optical depth at which a map's ray stops: a point past it reads
/// transmittance e^−16 ≈ 1.1e-7 instead of less, which moves no pixel by
/// more than 1.1e-7 of the light's intensity (3e-5/255 of a unit light).
/// The exact shadow rays stop at [`super::OPAQUE_DEPTH`] (e^−46); a map's
/// rays stopping there too stored nearly three times the knots on rays
/// into an opaque layer (knots every [`KNOT_DEPTH`] of depth): the fuzz
/// finding pinned in tests/lighting.rs (7 tets, TF peaks of extinction
/// 10³) took 130 MB with rays to e^−46, 72.8 MB to e^−16 (both within
/// [`LEVELS_BUDGET_BYTES`]).
pub const MAP_OPAQUE_DEPTH: f64 = 16.0;

/// Optical depth from a directional light over a grid of its rays.
#[derive(Debug, Clone)]
pub struct DeepShadowMap {
    /// Unit vectors across the rays and along them (the light's travel).
    e1: DVec3,
    e2: DVec3,
    d: DVec3,
    /// Coordinates of the first ray's centre and first depth sample, and
    /// the spacing of rays and samples (in the frame of the mesh the map
    /// was walked in).
    u0: f64,
    v0: f64,
    t0: f64,
    du: f64,
    dv: f64,
    nu: usize,
    nv: usize,
    /// Every ray's knots, ray after ray: (parameter along the ray from
    /// depth `t0`, optical depth there), at every tet crossing and every
    /// TF node the ray meets, increasing.
    knots: Vec<[f32; 2]>,
    /// Per ray r (= j·nu + i): its knots' range in `knots` and, for a ray
    /// of more than [`SHORT_RAY`] knots, where its bins start in `bins`
    /// (unused otherwise). 12 bytes a ray, so that the records of a 256²
    /// map (0.8 MB) stay in a core's cache while a frame looks it up; the
    /// knots are what a lookup then waits for.
    rays: Vec<RayRecord>,
    /// A long ray's `BINS − 1` inner bins: entry b − 1 is its first knot at
    /// or past parameter b·`bin_len` (0 < b < BINS), where a lookup in bin
    /// b scans on from. A short ray is scanned from its first knot.
    bins: Vec<u32>,
    /// The finer grids, level L = 1..=[`MAX_LEVELS`] at `levels[L − 1]`
    /// (rays 2^L times as dense: (2^L·(nu − 1) + 1) × (2^L·(nv − 1) + 1)
    /// positions): each position's record in `rays`, [`NO_RAY`] where no
    /// ray was walked. A level is walked only around the cells of the
    /// level above whose depths are rough, and holds the level above's
    /// rays (at its even positions) only within two positions of a ray it
    /// added, where lookups and the next level read it; absent: no cell
    /// was rough.
    levels: Vec<LevelTable>,
    bin_len: f32,
    /// A point light's map: rays fan out from this point (the light), the
    /// grid is over slopes across `d` and a sample's parameter is its
    /// distance from the light. `None`: parallel rays along `d`.
    origin: Option<DVec3>,
}

/// The box of `points`.
fn bounds_of(points: &[[f64; 3]]) -> (DVec3, DVec3) {
    let (lo, hi) = tet_mesh::stats::bounds(points);
    (DVec3::from(lo), DVec3::from(hi))
}

/// Index bins along each ray.
const BINS: usize = 32;

/// A position of a finer grid without a ray.
pub const NO_RAY: u32 = u32::MAX;

/// Positions along a side of a [`LevelTable`]'s tiles.
pub const LEVEL_TILE: usize = 8;

/// A finer grid's ray numbers by position, kept only in the tiles of
/// [`LEVEL_TILE`] × [`LEVEL_TILE`] positions where a ray was walked (a
/// finer grid is walked around shadow edges only: the third's 2041² full
/// table alone would be 17 MB). One flat vector, read as is by the GPU
/// ([`MapLayout::levels`]): first one word per tile, row after row of
/// ⌈nu / LEVEL_TILE⌉ tiles — where the tile's entries start in this
/// vector, [`NO_RAY`] where it has no ray; then the tiles' entries, row
/// after row within a tile, each a ray number or `NO_RAY`.
#[derive(Debug, Clone)]
struct LevelTable {
    tiles_u: usize,
    words: Vec<u32>,
}

impl LevelTable {
    /// The table of a grid `nu` positions wide whose rays by position
    /// (row after row) are `dense`.
    fn from_dense(nu: usize, dense: &[u32]) -> LevelTable {
        let (tiles_u, tiles_v) = (nu.div_ceil(LEVEL_TILE), (dense.len() / nu).div_ceil(LEVEL_TILE));
        let mut words = vec![NO_RAY; tiles_u * tiles_v];
        for tj in 0..tiles_v {
            for ti in 0..tiles_u {
                let at = |i: usize, j: usize| {
                    let (i, j) = (ti * LEVEL_TILE + i, tj * LEVEL_TILE + j);
                    if i < nu && j * nu < dense.len() {
                        dense[j * nu + i]
                    } else {
                        NO_RAY
                    }
                };
                let tile: [u32; LEVEL_TILE * LEVEL_TILE] = std::array::from_fn(|k| at(k % LEVEL_TILE, k / LEVEL_TILE));
                if tile.iter().any(|&r| r != NO_RAY) {
                    words[tj * tiles_u + ti] = words.len() as u32;
                    words.extend_from_slice(&tile);
                }
            }
        }
        LevelTable { tiles_u, words }
    }

    /// The ray at position (i, j), [`NO_RAY`] where none was walked.
    fn get(&self, i: usize, j: usize) -> u32 {
        let tile = self.words[(j / LEVEL_TILE) * self.tiles_u + i / LEVEL_TILE];
        if tile == NO_RAY {
            return NO_RAY;
        }
        self.words[tile as usize + (j % LEVEL_TILE) * LEVEL_TILE + i % LEVEL_TILE]
    }
}

/// How rough a cell's depths must be (a third difference across four rays
/// through it times the light left, at some even depth: see
/// `DeepShadowMap::rough_cells`) for the rays halfway between to be
/// walked. Chosen by measurement (crates/tet_engine/results/lighting.md):
/// at 0.06 the refinement walked a third of ironProt's map for the sample
/// TF, whose shadows were already within 0.1/255, and the field cost more
/// than a lit frame there; at 0.25 the held-out TFs' errors on Blunt Fin
/// are as low and ironProt's field stays under a lit frame.
pub const REFINE_ABOVE: f64 = 0.25;

/// The same for a cell of a finer grid to get the next grid's rays
/// ([`MAX_LEVELS`]). Chosen by measurement (crates/tet_engine/results/
/// lighting.md): at `REFINE_ABOVE` itself the second grid gained little
/// more on the held-out TFs than at twice it and put ironProt's field
/// over a lit frame; at twice it ironProt gets no second grid. The third
/// grid needs it as low (at 1, 2 or 4 the point light's sliver above
/// stays 2.1/255).
pub const REFINE_FINER_ABOVE: f64 = 0.5;

/// Even depths along the rays at which [`DeepShadowMap::rough_cells`]
/// compares them.
const REFINE_SAMPLES: usize = 64;

/// Finer grids at most ([`DeepShadowMap`]'s `levels`): rays up to 8× as
/// dense as the coarse grid's around shadow edges. The third level is
/// what follows a point light's shadow of a narrow TF peak's sliver on
/// Blunt Fin (crates/tet_engine/results/lighting.md); the memory it takes
/// is its rays', its table kept by tiles ([`LEVEL_TILE`]).
pub const MAX_LEVELS: usize = 3;

/// The most memory a map grows to by its finer grids: a finer grid that
/// would take the map past this is not kept; the coarse grid is always
/// walked. A safety net: an opaque layer oblique to the light is a shadow
/// edge at every depth, so each finer grid is walked nearly everywhere
/// (the fuzzed input behind the test in tests/lighting.rs walked 761k
/// rays into 419 MB, rays ending at [`MAP_OPAQUE_DEPTH`]). 128 MiB,
/// wgpu's default storage-buffer limit: the largest measured map of real
/// data takes 68 MB with its three grids (crates/tet_engine/results/
/// lighting.md: Blunt Fin, held-out peaks12), the tests' two bands of
/// extinction 400 take 116 MB.
pub const LEVELS_BUDGET_BYTES: usize = 128 << 20;

/// A grid of the map's rays: the coarse one (`depth` 0) or a finer one.
struct Level {
    du: f64,
    dv: f64,
    nu: usize,
    nv: usize,
    depth: usize,
}

/// The cell of a grid of `n` rays that continuous coordinate `f` ∈ [0, n − 1]
/// falls in, and the weight of its far side.
fn cell(f: f64, n: usize) -> (usize, f64) {
    let i = (f as usize).min(n - 2);
    (i, f - i as f64)
}

/// Rays of at most this many knots have no bins: a lookup scans them from
/// their first knot (one or two cache lines), which finds the same knot as
/// a scan from a bin (knots increase along a ray).
pub const SHORT_RAY: usize = 8;

/// A ray's knots, `knots[start..end]`, and its bins at `bins[bins_at..]`
/// (a ray of more than [`SHORT_RAY`] knots).
#[derive(Debug, Clone, Copy)]
struct RayRecord {
    start: u32,
    end: u32,
    bins_at: u32,
}

/// How much a lookup's four nearest rays must differ for it to start
/// interpolating bicubically ([`DeepShadowMap::depth_at`]; fully from twice
/// that): their optical depths' spread times the transmittance of the
/// least deep (what an error in depth there costs in light). Below, the
/// bilinear value is that close to each of them; deep in a shadow, where
/// no light is left to get wrong, it stays bilinear. On Blunt Fin the
/// bicubic lookup halved the held-out TFs' largest shadow errors (the
/// finer knots did most of the 5–10× lower RMSE with the sample and dense
/// TFs; crates/tet_engine/results/lighting.md).
pub const CUBIC_ABOVE: f64 = 0.05;

/// Catmull–Rom weights of the four samples at −1, 0, 1, 2 for a point at
/// `t` ∈ [0, 1] between samples 0 and 1 (they sum to 1; a linear function
/// is reproduced exactly).
pub fn catmull_rom(t: f64) -> [f64; 4] {
    let (t2, t3) = (t * t, t * t * t);
    [0.5 * (-t3 + 2.0 * t2 - t), 0.5 * (3.0 * t3 - 5.0 * t2 + 2.0), 0.5 * (-3.0 * t3 + 4.0 * t2 + t), 0.5 * (t3 - t2)]
}

/// Rays along each side of a cube map's face (90° of view: ~0.53° apart).
/// 170 keeps the held-out TFs' shadow maxima within 2/255 with the light
/// inside Blunt Fin (128: 2.8/255 on a dozen narrow peaks) and the cube
/// within one 512² frame on 0.2–1.2M-tet meshes
/// (crates/tet_engine/results/lighting.md).
pub const CUBE_RAYS: usize = 170;

/// The faces of a point light's cube of maps: (axis d, e1, e2), face f
/// seeing the points whose largest coordinate relative to the light is
/// along d ([`cube_face`]).
pub(crate) const CUBE_AXES: [(DVec3, DVec3, DVec3); 6] = [
    (DVec3::X, DVec3::Y, DVec3::Z),
    (DVec3::NEG_X, DVec3::Y, DVec3::Z),
    (DVec3::Y, DVec3::Z, DVec3::X),
    (DVec3::NEG_Y, DVec3::Z, DVec3::X),
    (DVec3::Z, DVec3::X, DVec3::Y),
    (DVec3::NEG_Z, DVec3::X, DVec3::Y),
];

/// The face of a cube of maps that sees `q` (a point relative to the
/// light): its largest coordinate's axis and sign (ties to the first
/// axis): 0 +x, 1 −x, 2 +y, 3 −y, 4 +z, 5 −z.
pub fn cube_face(q: DVec3) -> usize {
    let a = q.abs();
    let axis = if a.x >= a.y && a.x >= a.z {
        0
    } else if a.y >= a.z {
        1
    } else {
        2
    };
    2 * axis + usize::from(q[axis] < 0.0)
}

/// A [`DeepShadowMap`] as its lookup reads it: unit vectors across the
/// rays (`e1`, `e2`) and along them (`d`); a point light's position
/// (`origin`: rays fan out from it over slopes, samples by distance) or
/// `None` (parallel rays, samples by depth along `d` from `t0`); the first
/// ray's coordinates and the spacing (`u0`, `v0`, `du`, `dv`) of `nu` ×
/// `nv` rays; each ray's knots (parameter, optical depth), ray after ray,
/// and per ray `bins + 1` indices into them (its first knot, its first knot
/// at or past each bin of length `bin_len`, its end). Positions are in the
/// frame the map was walked in ([`crate::ShadowField::frame_origin_in_world`]).
#[derive(Debug, Clone)]
pub struct MapLayout<'a> {
    pub e1: DVec3,
    pub e2: DVec3,
    pub d: DVec3,
    pub origin: Option<DVec3>,
    pub u0: f64,
    pub v0: f64,
    pub t0: f64,
    pub du: f64,
    pub dv: f64,
    pub nu: usize,
    pub nv: usize,
    pub bin_len: f32,
    pub bins: usize,
    /// [`SHORT_RAY`].
    pub short_ray: usize,
    pub knots: &'a [[f32; 2]],
    /// Per ray, `bins + 1` indices into `knots`: entry 0 its first knot,
    /// entry b (0 < b < bins) its first knot at or past parameter
    /// b·`bin_len`, entry `bins` the end of its knots. A lookup scans a ray
    /// of at most [`SHORT_RAY`] knots from its first knot, any other from
    /// its point's bin.
    pub index: Vec<u32>,
    /// The finer grids, at most [`MAX_LEVELS`]: level L (`levels[L − 1]`)
    /// of (2^L·(nu − 1) + 1) × (2^L·(nv − 1) + 1) positions, walked around
    /// the level above's rough cells, the level above's rays at even
    /// positions near those it added: each position's ray (its record at
    /// `index[r·(bins + 1)..]`), [`NO_RAY`] where none, by tiles of `tile`
    /// × `tile` positions: first a word per tile, ⌈positions a row / tile⌉
    /// tiles a row, row after row — where the tile's entries start in this
    /// table, or `NO_RAY` (no ray in it); then the kept tiles' entries, row
    /// after row within each. No levels: the map has no finer rays.
    pub levels: Vec<&'a [u32]>,
    /// [`LEVEL_TILE`].
    pub tile: usize,
}

impl DeepShadowMap {
    /// Walks `MAP_RAYS` × (as many as the aspect gives) rays of a light
    /// travelling along unit `d` through `reference`'s mesh (points in the
    /// frame the map is looked up in).
    pub(crate) fn build(
        reference: &ReferenceRenderer,
        d: DVec3,
        tf: &TransferFunction,
        stats: &mut ReferenceStats,
    ) -> DeepShadowMap {
        let e1 = d.any_orthonormal_vector();
        let e2 = d.cross(e1);
        let (mut lo, mut hi) = (DVec3::splat(f64::INFINITY), DVec3::splat(f64::NEG_INFINITY));
        for p in reference.points() {
            let p = DVec3::from(*p);
            let q = DVec3::new(p.dot(e1), p.dot(e2), p.dot(d));
            lo = lo.min(q);
            hi = hi.max(q);
        }
        let ext = (hi - lo).max(DVec3::splat(1e-300));
        let longest = ext.x.max(ext.y);
        let (nu, nv) = if ext.x >= ext.y {
            (MAP_RAYS, ((MAP_RAYS as f64 * ext.y / longest).ceil() as usize).clamp(2, MAP_RAYS))
        } else {
            (((MAP_RAYS as f64 * ext.x / longest).ceil() as usize).clamp(2, MAP_RAYS), MAP_RAYS)
        };
        // Ray centres span the box edge to edge, drawn in by 1e-7 of it:
        // a ray along the rim would run along boundary faces of a box-like
        // mesh, where the exact walk (rightly) finds no inside; a point on
        // the rim takes the value just inside. Samples from the first
        // depth to the last.
        let inset = ext.x.max(ext.y) * 1e-7;
        let (du, dv) = ((ext.x - 2.0 * inset) / (nu - 1) as f64, (ext.y - 2.0 * inset) / (nv - 1) as f64);
        let (u0, v0, t0) = (lo.x + inset, lo.y + inset, lo.z);
        // The ray through map coordinates (u, v).
        let ray = |u: f64, v: f64| (e1 * u + e2 * v + d * t0, d, f64::NEG_INFINITY);
        let rows = walk_grid(reference, [nu, nv], tf, None, |i, j| ray(u0 + i as f64 * du, v0 + j as f64 * dv));
        let bin_len = (ext.z / BINS as f64).max(1e-300) as f32;
        let mut map = Self::from_walks([e1, e2, d], None, [u0, v0, t0], [du, dv], [nu, nv], rows, bin_len, stats);
        map.refine_levels(reference, tf, stats, ray);
        map
    }

    /// A point light's map (after the same paper's perspective maps): rays
    /// from `light` through a grid over the mesh's view from it, each
    /// walked from the light, its knots at distances from it. `None` when
    /// some point of the mesh is not in front of the light along the
    /// direction to the mesh's centre (a light inside or beside the
    /// bounding box): such a light gets a cube of maps
    /// ([`DeepShadowMap::build_cube`]).
    pub(crate) fn build_point(
        reference: &ReferenceRenderer,
        light: DVec3,
        tf: &TransferFunction,
        stats: &mut ReferenceStats,
    ) -> Option<DeepShadowMap> {
        let pts = reference.points();
        let (lo, hi) = bounds_of(pts);
        let d = ((lo + hi) * 0.5 - light).try_normalize()?;
        let e1 = d.any_orthonormal_vector();
        let e2 = d.cross(e1);
        // Every point well in front (slopes at most 4, i.e. within ~76° of
        // the axis), else the fan would need more than one map.
        let (mut slo, mut shi, mut far) = ([f64::INFINITY; 2], [f64::NEG_INFINITY; 2], 0.0f64);
        for p in pts {
            let q = DVec3::from(*p) - light;
            let w = q.dot(d);
            // False for NaN too (a non-finite point or light): no map.
            let in_front = w > 0.25 * q.length();
            if !in_front {
                return None;
            }
            let (u, v) = (q.dot(e1) / w, q.dot(e2) / w);
            (slo[0], shi[0], slo[1], shi[1]) = (slo[0].min(u), shi[0].max(u), slo[1].min(v), shi[1].max(v));
            far = far.max(q.length());
        }
        let ext = [(shi[0] - slo[0]).max(1e-300), (shi[1] - slo[1]).max(1e-300)];
        let longest = ext[0].max(ext[1]);
        let count = |e: f64| ((MAP_RAYS as f64 * e / longest).ceil() as usize).clamp(2, MAP_RAYS);
        let (nu, nv) = (count(ext[0]), count(ext[1]));
        let inset = longest * 1e-7;
        let (du, dv) = ((ext[0] - 2.0 * inset) / (nu - 1) as f64, (ext[1] - 2.0 * inset) / (nv - 1) as f64);
        let (u0, v0) = (slo[0] + inset, slo[1] + inset);
        // The ray of slopes (u, v).
        let ray = |u: f64, v: f64| (light, (d + e1 * u + e2 * v).normalize(), f64::NEG_INFINITY);
        let rays = walk_grid(reference, [nu, nv], tf, None, |i, j| ray(u0 + i as f64 * du, v0 + j as f64 * dv));
        let bin_len = (far / BINS as f64).max(1e-300) as f32;
        let mut map =
            Self::from_walks([e1, e2, d], Some(light), [u0, v0, 0.0], [du, dv], [nu, nv], rays, bin_len, stats);
        map.refine_levels(reference, tf, stats, ray);
        Some(map)
    }

    /// A point light's cube of maps (after the same paper's perspective
    /// maps, one for each face of a cube around the light): for a light
    /// inside the mesh or beside its box, where no single fan covers the
    /// mesh. Face f looks along [`CUBE_AXES`]`[f]`; its rays leave the light
    /// over slopes in [−1, 1]² across that axis, each walked from the light
    /// outwards (parameter = distance from the light). `None` for a light
    /// that is not finite.
    pub(crate) fn build_cube(
        reference: &ReferenceRenderer,
        light: DVec3,
        tf: &TransferFunction,
        stats: &mut ReferenceStats,
    ) -> Option<Box<[DeepShadowMap; 6]>> {
        if !light.is_finite() {
            return None;
        }
        // A light strictly inside a tet: every ray starts there and walks
        // only what lies ahead (no boundary search, nothing behind the
        // light). A light inside the mesh's box on a face, edge or vertex
        // (a grid node; a cell's centre, on the diagonal a 6-split shares)
        // starts its rays a hair away, strictly inside a tet: at most 1e-9
        // of the box's diagonal, far below a ray spacing. Otherwise (outside
        // the mesh) each ray's whole line is walked from its boundary
        // entries.
        let from_inside = reference.tet_strictly_containing(light).map(|(t, s)| (light, t, s)).or_else(|| {
            let (lo, hi) = bounds_of(reference.points());
            let in_box = (light.cmpge(lo) & light.cmple(hi)).all();
            let diag = (hi - lo).length();
            // Fixed, irrational-looking directions: no mesh is aligned with them.
            let dirs = [DVec3::new(0.5773, 0.4471, 0.6833), DVec3::new(-0.6168, 0.3125, 0.7219)];
            let nudges = [1e-12, 1e-11, 1e-10, 1e-9].into_iter().flat_map(|k| dirs.map(|d| d.normalize() * k * diag));
            in_box
                .then(|| {
                    nudges.into_iter().find_map(|off| {
                        reference.tet_strictly_containing(light + off).map(|(t, s)| (light + off, t, s))
                    })
                })
                .flatten()
        });
        Some(Self::build_cube_from(reference, light, tf, stats, from_inside))
    }

    /// [`DeepShadowMap::build_cube`] for a finite light, its rays walked
    /// from `from_inside` (a point strictly inside a tet: the light or one
    /// a hair from it, the tet and the scalar there) or, without it, along
    /// their whole lines.
    fn build_cube_from(
        reference: &ReferenceRenderer,
        light: DVec3,
        tf: &TransferFunction,
        stats: &mut ReferenceStats,
        from_inside: Option<(DVec3, usize, f64)>,
    ) -> Box<[DeepShadowMap; 6]> {
        let start = from_inside.map_or(light, |(p, _, _)| p);
        let from_inside = from_inside.map(|(_, t, s)| (t, s));
        let far = reference.points().iter().map(|p| (DVec3::from(*p) - light).length()).fold(0.0f64, f64::max);
        let bin_len = (far / BINS as f64).max(1e-300) as f32;
        let n = CUBE_RAYS;
        let step = 2.0 / (n - 1) as f64;
        let faces = CUBE_AXES.map(|(d, e1, e2)| {
            // From the light on (t ≥ 0): the mesh behind it is another face's.
            let rays = walk_grid(reference, [n, n], tf, from_inside, |i, j| {
                let (u, v) = (-1.0 + i as f64 * step, -1.0 + j as f64 * step);
                (start, (d + e1 * u + e2 * v).normalize(), 0.0)
            });
            Self::from_walks([e1, e2, d], Some(light), [-1.0, -1.0, 0.0], [step, step], [n, n], rays, bin_len, stats)
        });
        Box::new(faces)
    }

    /// A map of axes `[e1, e2, d]` (a fan's from `origin`) over the grid of
    /// `[nu, nv]` rays from (u0, v0) spaced (du, dv), depths from t0, its
    /// rays' walks `rows` in ray order; no fine rays yet.
    #[allow(clippy::too_many_arguments)]
    fn from_walks(
        [e1, e2, d]: [DVec3; 3],
        origin: Option<DVec3>,
        [u0, v0, t0]: [f64; 3],
        [du, dv]: [f64; 2],
        [nu, nv]: [usize; 2],
        rows: RayRows,
        bin_len: f32,
        stats: &mut ReferenceStats,
    ) -> DeepShadowMap {
        let (knots, rays, bins) = index_rays(rows, bin_len, stats);
        DeepShadowMap { e1, e2, d, u0, v0, t0, du, dv, nu, nv, knots, rays, bins, levels: Vec::new(), bin_len, origin }
    }

    /// The optical depth from the light to `p` (in the map's frame).
    pub fn depth_at(&self, p: DVec3) -> f64 {
        let coord = |x: f64, x0: f64, dx: f64, n: usize| {
            if dx > 0.0 {
                ((x - x0) / dx).clamp(0.0, (n - 1) as f64)
            } else {
                0.0
            }
        };
        // Parallel rays: every ray is read at the point's depth along `d`.
        // A point light's fan: each ray at the point where it crosses the
        // point's plane across `d` (depth w along the axis, so a face the
        // light looks straight at is met by all four rays at once), i.e. at
        // distance w·√(1 + u² + v²) along a ray of slopes (u, v).
        let (u, v, axial) = match self.origin {
            None => (p.dot(self.e1), p.dot(self.e2), p.dot(self.d) - self.t0),
            Some(o) => {
                let q = p - o;
                let w = q.dot(self.d);
                if w <= 0.0 {
                    // Behind the light: nothing between (not in the mesh).
                    return 0.0;
                }
                (q.dot(self.e1) / w, q.dot(self.e2) / w, w)
            }
        };
        let (fu, fv) = (coord(u, self.u0, self.du, self.nu), coord(v, self.v0, self.dv, self.nv));
        // Around cells whose rays disagree the map has rays halfway between
        // (a finer grid, and around its rough cells a finer one still):
        // read at the finest level whose four nearest rays exist.
        for depth in (1..=self.levels.len()).rev() {
            let level = self.level(depth);
            let scale = (1usize << depth) as f64;
            let (i, wu) = cell(scale * fu, level.nu);
            let (j, wv) = cell(scale * fv, level.nv);
            // Every cell of a level has the centre of its cell one level
            // up for a corner, and that centre is walked exactly where
            // that whole cell is: one look says whether all four are there.
            if self.levels[depth - 1].get(i | 1, j | 1) != NO_RAY {
                if let Some(d) = self.interpolate(&level, i, j, wu, wv, axial) {
                    return d;
                }
            }
        }
        let (i, wu) = cell(fu, self.nu);
        let (j, wv) = cell(fv, self.nv);
        self.interpolate(&self.level(0), i, j, wu, wv, axial).unwrap_or(0.0)
    }

    /// The grid of rays at `depth`: the coarse one (0), or one 2^depth
    /// times as dense (its rays where walked).
    fn level(&self, depth: usize) -> Level {
        let k = 1usize << depth;
        Level {
            du: self.du / k as f64,
            dv: self.dv / k as f64,
            nu: k * (self.nu - 1) + 1,
            nv: k * (self.nv - 1) + 1,
            depth,
        }
    }

    /// Ray (i, j) of `level`'s record, `None` where a finer grid has none.
    fn record(&self, level: &Level, i: usize, j: usize) -> Option<RayRecord> {
        if level.depth > 0 {
            let r = self.levels[level.depth - 1].get(i, j);
            (r != NO_RAY).then(|| self.rays[r as usize])
        } else {
            Some(self.rays[j * self.nu + i])
        }
    }

    /// Ray `rec`'s optical depth at parameter t: linear between its knots,
    /// 0 before the first, the last's after it.
    fn read_ray(&self, rec: RayRecord, t: f32) -> f64 {
        let (start, end) = (rec.start as usize, rec.end as usize);
        // The ray's knots from its bin on.
        let k = &self.knots[start..end];
        let mut n = 0;
        if k.len() > SHORT_RAY {
            let b = ((t / self.bin_len).max(0.0) as usize).min(BINS - 1);
            if b > 0 {
                n = self.bins[rec.bins_at as usize + b - 1] as usize - start;
            }
        }
        depth_past(k, &mut n, t) as f64
    }

    /// Where ray (i, j) of `level` is read for a point at `axial` along
    /// the light: that depth for parallel rays, the distance at which a
    /// fan's ray crosses the point's plane.
    fn ray_t(&self, level: &Level, i: usize, j: usize, axial: f64) -> f32 {
        match self.origin {
            None => axial as f32,
            Some(_) => {
                let (su, sv) = (self.u0 + i as f64 * level.du, self.v0 + j as f64 * level.dv);
                (axial * (1.0 + su * su + sv * sv).sqrt()) as f32
            }
        }
    }

    /// The depth at cell (i, j) of `level`, weights (wu, wv) towards ray
    /// (i + 1, j + 1); `None` where a fine cell lacks one of its rays.
    fn interpolate(&self, level: &Level, i: usize, j: usize, wu: f64, wv: f64, axial: f64) -> Option<f64> {
        let at = |i: usize, j: usize| -> Option<f64> {
            Some(self.read_ray(self.record(level, i, j)?, self.ray_t(level, i, j, axial)))
        };
        let (a, b, c, e) = (at(i, j)?, at(i, j + 1)?, at(i + 1, j)?, at(i + 1, j + 1)?);
        let (lo, hi) = (a.min(b).min(c).min(e), a.max(b).max(c).max(e));
        let bilinear = {
            let bottom = a + wu * (c - a);
            let top = b + wu * (e - b);
            bottom + wv * (top - bottom)
        };
        // Where the four rays disagree the depth varies steeply across the
        // light (an opaque layer crossed obliquely, a shadow's edge):
        // Catmull–Rom over the 4 × 4 nearest rays (rays past the map's edge
        // read as the edge's), held within the four nearest rays' range so
        // that a step does not overshoot; blended in from bilinear as their
        // spread (weighted by the light left, see CUBIC_ABOVE) goes from
        // CUBIC_ABOVE to twice that, so the field stays continuous. On the
        // fine grid a cell without all sixteen (at the edge of the walked
        // part) stays bilinear.
        let cubic_share = ((-lo).exp() * (hi - lo) / CUBIC_ABOVE - 1.0).clamp(0.0, 1.0);
        if cubic_share == 0.0 {
            return Some(bilinear);
        }
        let (cu, cv) = (catmull_rom(wu), catmull_rom(wv));
        let ii = |k: usize| (i + k).saturating_sub(1).min(level.nu - 1);
        let jj = |k: usize| (j + k).saturating_sub(1).min(level.nv - 1);
        let mut sum = 0.0;
        for (q, wq) in cv.iter().enumerate() {
            let mut row = 0.0;
            for (p, wp) in cu.iter().enumerate() {
                // The four nearest rays are read already.
                let depth = match (p, q) {
                    (1, 1) => a,
                    (2, 1) => c,
                    (1, 2) => b,
                    (2, 2) => e,
                    _ => match at(ii(p), jj(q)) {
                        Some(d) => d,
                        None => return Some(bilinear),
                    },
                };
                row += wp * depth;
            }
            sum += wq * row;
        }
        Some(bilinear + cubic_share * (sum.clamp(lo, hi) - bilinear))
    }

    /// Every walked ray of `level` (of a finer level: near the rays it
    /// added) sampled at [`REFINE_SAMPLES`] even axial depths from 0 to the
    /// map's last bin's end: per position, where its samples start in the
    /// second vector (in units of REFINE_SAMPLES), [`NO_RAY`] where no ray
    /// was walked or sampled.
    fn sample_level(&self, level: &Level) -> (Vec<u32>, Vec<f32>) {
        let step = BINS as f64 * self.bin_len as f64 / REFINE_SAMPLES as f64;
        // On a finer level only the rays within two positions of one it
        // added (an odd position) can be part of a cell's sixteen; the
        // rest of its even positions (the level above's rays) are skipped.
        let (nu, nv) = (level.nu, level.nv);
        let mut near_new = vec![level.depth == 0; nu * nv];
        if level.depth > 0 {
            for j in 0..nv {
                for i in (0..nu).filter(|&i| (i | j) & 1 == 1 && self.record(level, i, j).is_some()) {
                    for jj in j.saturating_sub(2)..(j + 3).min(nv) {
                        near_new[jj * nu + i.saturating_sub(2)..jj * nu + (i + 3).min(nu)].fill(true);
                    }
                }
            }
        }
        let rows: Vec<(Vec<bool>, Vec<f32>)> = (0..level.nv)
            .into_par_iter()
            .map(|j| {
                let (mut has, mut out) = (Vec::with_capacity(level.nu), Vec::new());
                for i in 0..level.nu {
                    let rec = if near_new[j * nu + i] { self.record(level, i, j) } else { None };
                    let Some(rec) = rec else {
                        has.push(false);
                        continue;
                    };
                    has.push(true);
                    let k = &self.knots[rec.start as usize..rec.end as usize];
                    let scale = self.ray_t(level, i, j, 1.0) as f64;
                    let mut n = 0;
                    for s in 0..REFINE_SAMPLES {
                        out.push(depth_past(k, &mut n, (s as f64 * step * scale) as f32));
                    }
                }
                (has, out)
            })
            .collect();
        let (mut at, mut samples) = (Vec::with_capacity(level.nu * level.nv), Vec::new());
        for (has, out) in rows {
            let mut next = (samples.len() / REFINE_SAMPLES) as u32;
            for h in has {
                at.push(if h { next } else { NO_RAY });
                next += h as u32;
            }
            samples.extend(out);
        }
        (at, samples)
    }

    /// The cells of row `j` of `level` whose depths the bicubic lookup
    /// would not follow: at some of [`REFINE_SAMPLES`] even depths, a third
    /// difference across four rays through the cell (along either axis,
    /// the map's edge rays repeated past it: zero for a quadratic, which
    /// Catmull–Rom interpolates exactly; 2·D for a step of D between the
    /// cell's rays) times the light its least deep ray leaves exceeds
    /// [`REFINE_ABOVE`] ([`REFINE_FINER_ABOVE`] on the fine grid). A cell
    /// of a finer level lacking one of those rays
    /// (at the edge of its walked part) is not rough. `sampled`: the
    /// level's [`DeepShadowMap::sample_level`].
    fn rough_cells(&self, level: &Level, j: usize, (at, samples): &(Vec<u32>, Vec<f32>)) -> Vec<bool> {
        let (nu, nv) = (level.nu as isize, level.nv as isize);
        let ray = |i: isize, j: isize| -> Option<&[f32]> {
            let k = at[(j.clamp(0, nv - 1) * nu + i.clamp(0, nu - 1)) as usize];
            (k != NO_RAY).then(|| &samples[k as usize * REFINE_SAMPLES..][..REFINE_SAMPLES])
        };
        let third = |a: f32, b: f32, c: f32, d: f32| (a as f64 - 3.0 * b as f64 + 3.0 * c as f64 - d as f64).abs();
        let above = if level.depth == 0 { REFINE_ABOVE } else { REFINE_FINER_ABOVE };
        let j = j as isize;
        (0..nu - 1)
            .map(|i| {
                // Most cells of a finer level were not walked: one look.
                if ray(i, j).is_none() {
                    return false;
                }
                // Rows j and j + 1 across i − 1..=i + 2, columns i and i + 1
                // across j − 1..=j + 2.
                let line = |f: &dyn Fn(isize) -> (isize, isize)| -> Option<[&[f32]; 4]> {
                    let at = |k: isize| ray(f(k).0, f(k).1);
                    Some([at(-1)?, at(0)?, at(1)?, at(2)?])
                };
                let lines = [
                    line(&|k| (i + k, j)),
                    line(&|k| (i + k, j + 1)),
                    line(&|k| (i, j + k)),
                    line(&|k| (i + 1, j + k)),
                ];
                let [Some(r0), Some(r1), Some(c0), Some(c1)] = lines else { return false };
                let lines = [r0, r1, c0, c1];
                (0..REFINE_SAMPLES).any(|s| {
                    // The cell's corners: the rows' inner rays.
                    let lo = [r0[1][s], r0[2][s], r1[1][s], r1[2][s]].into_iter().fold(f32::INFINITY, f32::min) as f64;
                    let rough = lines.iter().map(|l| third(l[0][s], l[1][s], l[2][s], l[3][s])).fold(0.0f64, f64::max);
                    (-lo).exp() * rough > above
                })
            })
            .collect()
    }

    /// Walks the rays of grid level `depth` (twice as dense as the level
    /// above) around every cell of the level above whose depths are rough
    /// ([`DeepShadowMap::rough_cells`]) and the cells next to those (so
    /// that a bicubic lookup there finds its sixteen), `ray(u, v)` giving
    /// the ray through map coordinates (u, v) as `walk_grid` takes it.
    /// False: nothing was rough, no level added.
    fn refine(
        &mut self,
        depth: usize,
        reference: &ReferenceRenderer,
        tf: &TransferFunction,
        stats: &mut ReferenceStats,
        ray: &(impl Fn(f64, f64) -> (DVec3, DVec3, f64) + Sync),
    ) -> bool {
        debug_assert_eq!(self.levels.len() + 1, depth);
        let parent = self.level(depth - 1);
        let (cu, cv) = (parent.nu - 1, parent.nv - 1);
        let flagged: Vec<bool> = {
            let sampled = self.sample_level(&parent);
            (0..cv).into_par_iter().flat_map_iter(|j| self.rough_cells(&parent, j, &sampled)).collect()
        };
        let child = self.level(depth);
        let (fu, fv) = (child.nu, child.nv);
        let walked = |i: usize, j: usize| self.record(&parent, i, j).is_some();
        let mut wanted = vec![false; fu * fv];
        for j in 0..cv {
            for i in 0..cu {
                let near = (j.saturating_sub(1)..(j + 2).min(cv))
                    .any(|jj| (i.saturating_sub(1)..(i + 2).min(cu)).any(|ii| flagged[jj * cu + ii]));
                // Only cells of the level above that it has whole.
                if near && walked(i, j) && walked(i + 1, j) && walked(i, j + 1) && walked(i + 1, j + 1) {
                    for jj in 2 * j..=2 * j + 2 {
                        for ii in 2 * i..=2 * i + 2 {
                            wanted[jj * fu + ii] = true;
                        }
                    }
                }
            }
        }
        drop(flagged);
        let new: Vec<(usize, usize)> = (0..fu * fv)
            .filter(|&k| wanted[k] && (k % fu % 2 == 1 || k / fu % 2 == 1))
            .map(|k| (k % fu, k / fu))
            .collect();
        if new.is_empty() {
            return false;
        }
        // A level that would take the map over its budget is not kept: not
        // walked where its rays at the map's mean cost a ray would, given
        // up after the walk where they cost more (rays at shadow edges
        // hold more knots than the mean; the walks stay counted in `stats`).
        let bytes = self.memory_bytes() as f64;
        if bytes + bytes / self.rays.len().max(1) as f64 * new.len() as f64 > LEVELS_BUDGET_BYTES as f64 {
            return false;
        }
        let (hu, hv) = (child.du, child.dv);
        let (u0, v0) = (self.u0, self.v0);
        let rows = walk_list(reference, &new, tf, None, |i, j| ray(u0 + i as f64 * hu, v0 + j as f64 * hv));
        let before = (self.knots.len(), self.rays.len(), self.bins.len());
        append_rays(&mut self.knots, &mut self.rays, &mut self.bins, rows, self.bin_len, stats);
        if self.memory_bytes() > LEVELS_BUDGET_BYTES {
            self.knots.truncate(before.0);
            self.rays.truncate(before.1);
            self.bins.truncate(before.2);
            return false;
        }
        let first_new = before.1 as u32;
        let mut table = vec![NO_RAY; fu * fv];
        for j in 0..parent.nv {
            for i in 0..parent.nu {
                table[2 * j * fu + 2 * i] = match depth {
                    1 => (j * parent.nu + i) as u32,
                    _ => self.levels[depth - 2].get(i, j),
                };
            }
        }
        // A lookup, a roughness test or the next level reads this level
        // only within two positions of a ray it added (the cells those
        // rays are corners of, and their sixteen): the level above's rays
        // are kept there only, so that the table's tiles are kept only
        // around the shadow edges.
        let mut near_new = vec![false; fu * fv];
        for (k, &(i, j)) in new.iter().enumerate() {
            table[j * fu + i] = first_new + k as u32;
            for jj in j.saturating_sub(2)..(j + 3).min(fv) {
                near_new[jj * fu + i.saturating_sub(2)..jj * fu + (i + 3).min(fu)].fill(true);
            }
        }
        for (r, near) in table.iter_mut().zip(near_new) {
            if !near {
                *r = NO_RAY;
            }
        }
        self.levels.push(LevelTable::from_dense(fu, &table));
        true
    }

    /// The finer levels, each where the one above is rough
    /// ([`DeepShadowMap::refine`]), up to [`MAX_LEVELS`].
    fn refine_levels(
        &mut self,
        reference: &ReferenceRenderer,
        tf: &TransferFunction,
        stats: &mut ReferenceStats,
        ray: impl Fn(f64, f64) -> (DVec3, DVec3, f64) + Sync,
    ) {
        for depth in 1..=MAX_LEVELS {
            if !self.refine(depth, reference, tf, stats, &ray) {
                break;
            }
        }
    }

    pub fn memory_bytes(&self) -> usize {
        self.knots.len() * 8
            + self.rays.len() * std::mem::size_of::<RayRecord>()
            + (self.bins.len() + self.levels.iter().map(|l| l.words.len()).sum::<usize>()) * 4
    }

    /// A point light's map: the light (its rays fan out from it).
    pub(crate) fn origin(&self) -> Option<DVec3> {
        self.origin
    }

    /// The map's arrays and frame as [`DeepShadowMap::depth_at`] reads
    /// them, for another reader of the same lookup (the GPU's
    /// `lighting.wgsl`, bilinear and bicubic alike).
    pub fn layout(&self) -> MapLayout<'_> {
        MapLayout {
            e1: self.e1,
            e2: self.e2,
            d: self.d,
            origin: self.origin,
            u0: self.u0,
            v0: self.v0,
            t0: self.t0,
            du: self.du,
            dv: self.dv,
            nu: self.nu,
            nv: self.nv,
            bin_len: self.bin_len,
            bins: BINS,
            short_ray: SHORT_RAY,
            levels: self.levels.iter().map(|l| l.words.as_slice()).collect(),
            tile: LEVEL_TILE,
            knots: &self.knots,
            index: self.full_index(),
        }
    }

    /// Every ray's `BINS + 1` entries of [`MapLayout::index`]: a long ray's
    /// kept bins, a short ray's scanned for here (as [`append_rays`] does).
    fn full_index(&self) -> Vec<u32> {
        let mut index = Vec::with_capacity(self.rays.len() * (BINS + 1));
        for r in &self.rays {
            index.push(r.start);
            if (r.end - r.start) as usize > SHORT_RAY {
                index.extend_from_slice(&self.bins[r.bins_at as usize..][..BINS - 1]);
            } else {
                let mut n = r.start as usize;
                for b in 1..BINS {
                    n = first_at_or_past(&self.knots, n, r.end as usize, b as f32 * self.bin_len) as usize;
                    index.push(n as u32);
                }
            }
            index.push(r.end);
        }
        index
    }

    /// Rays across and along.
    pub fn resolution(&self) -> [usize; 2] {
        [self.nu, self.nv]
    }
}

/// The rays' knots in one array, rows of (knot counts, knots, stats) in
/// ray order, each ray's record and the long rays' bins
/// ([`DeepShadowMap`]'s `rays` and `bins`).
fn index_rays(rows: RayRows, bin_len: f32, stats: &mut ReferenceStats) -> (Vec<[f32; 2]>, Vec<RayRecord>, Vec<u32>) {
    let (mut knots, mut records, mut bins) = (Vec::new(), Vec::new(), Vec::new());
    append_rays(&mut knots, &mut records, &mut bins, rows, bin_len, stats);
    (knots, records, bins)
}

/// Appends the rays of `rows` (as [`index_rays`] takes them) to a map's
/// knots, records and bins.
fn append_rays(
    knots: &mut Vec<[f32; 2]>,
    records: &mut Vec<RayRecord>,
    bins: &mut Vec<u32>,
    rows: RayRows,
    bin_len: f32,
    stats: &mut ReferenceStats,
) {
    for (counts, row, st) in rows {
        let mut start = knots.len() as u32;
        knots.extend(row);
        stats.add(&st);
        for c in counts {
            let end = start + c;
            records.push(RayRecord { start, end, bins_at: bins.len() as u32 });
            if c as usize > SHORT_RAY {
                let mut n = start as usize;
                for b in 1..BINS {
                    n = first_at_or_past(knots, n, end as usize, b as f32 * bin_len) as usize;
                    bins.push(n as u32);
                }
            }
            start = end;
        }
    }
}

/// A ray's optical depth at parameter `t` from its knots `k`, scanning on
/// from knot `*n` (left at the first knot past `t`, so that increasing
/// parameters scan on): linear between knots, 0 before the first, the
/// last's after it.
fn depth_past(k: &[[f32; 2]], n: &mut usize, t: f32) -> f32 {
    while *n < k.len() && k[*n][0] <= t {
        *n += 1;
    }
    match (*n, k.len()) {
        (0, _) => 0.0,
        (n, len) if n == len => k[len - 1][1],
        (n, _) => {
            let ([ta, da], [tb, db]) = (k[n - 1], k[n]);
            let w = if tb > ta { (t - ta) / (tb - ta) } else { 1.0 };
            da + w * (db - da)
        }
    }
}

/// The first of `knots[from..end]` at or past parameter `t` (`end` if
/// none).
fn first_at_or_past(knots: &[[f32; 2]], from: usize, end: usize, t: f32) -> u32 {
    let mut n = from;
    while n < end && knots[n][0] < t {
        n += 1;
    }
    n as u32
}

/// Walks the ray from `start` along `d`, appending its knots: (parameter,
/// optical depth) where it enters the mesh, at every TF node and tet
/// crossing after, up to the last crossing or [`MAP_OPAQUE_DEPTH`].
/// Per row of a grid of rays: each ray's knot count, the row's knots, and
/// its walks' counts.
type RayRows = Vec<(Vec<u32>, Vec<[f32; 2]>, ReferenceStats)>;

/// The walks of a `[nu, nv]` grid of rays in ray order (r = j·nu + i);
/// `ray(i, j)` gives ray (i, j)'s start, unit direction and the parameter
/// its walk starts at.
fn walk_grid(
    reference: &ReferenceRenderer,
    [nu, nv]: [usize; 2],
    tf: &TransferFunction,
    from_inside: Option<(usize, f64)>,
    ray: impl Fn(usize, usize) -> (DVec3, DVec3, f64) + Sync,
) -> RayRows {
    let at: Vec<(usize, usize)> = (0..nv).flat_map(|j| (0..nu).map(move |i| (i, j))).collect();
    walk_list(reference, &at, tf, from_inside, ray)
}

/// The walks of the rays at grid positions `at`, in that order (chunks in
/// parallel: the result does not depend on the thread count); `ray(i, j)`
/// as for [`walk_grid`].
fn walk_list(
    reference: &ReferenceRenderer,
    at: &[(usize, usize)],
    tf: &TransferFunction,
    from_inside: Option<(usize, f64)>,
    ray: impl Fn(usize, usize) -> (DVec3, DVec3, f64) + Sync,
) -> RayRows {
    at.par_chunks(64)
        .map_init(ShadowScratch::default, |scratch, chunk| {
            let mut st = ReferenceStats::default();
            let (mut counts, mut knots) = (Vec::with_capacity(chunk.len()), Vec::new());
            for &(i, j) in chunk {
                let before = knots.len();
                walk_ray(reference, ray(i, j), from_inside, tf, scratch, &mut st, &mut knots);
                counts.push((knots.len() - before) as u32);
            }
            (counts, knots, st)
        })
        .collect()
}

#[allow(clippy::too_many_arguments)]
fn walk_ray(
    reference: &ReferenceRenderer,
    (start, d, t_start): (DVec3, DVec3, f64),
    from_inside: Option<(usize, f64)>,
    tf: &TransferFunction,
    scratch: &mut ShadowScratch,
    stats: &mut ReferenceStats,
    knots: &mut Vec<[f32; 2]>,
) {
    let Some(line) = Line::through(start, start + d) else { return };
    let mut acc = 0.0f64;
    let ShadowScratch { entries, extinction, .. } = scratch;
    let first = knots.len();
    let push = |t: f64, depth: f64, knots: &mut Vec<[f32; 2]>| {
        let knot = [t as f32, depth.min(MAP_OPAQUE_DEPTH) as f32];
        match knots[first..].last() {
            // Keep t increasing; a repeated t keeps the deeper value.
            Some(last) if last[0] >= knot[0] => {
                let l = knots.len() - 1;
                knots[l][1] = knots[l][1].max(knot[1]);
            }
            _ => knots.push(knot),
        }
    };
    stats.rays += 1;
    let mut visit = |seg: &LineSegment| {
        let (s0, s1, len) = (seg.s_front(), seg.back.s, seg.len());
        // Where the segment starts (an entry, or the last back again).
        push(seg.t_front, acc, knots);
        // The TF's opacity nodes split the segment into pieces of linear
        // extinction, over which the depth is quadratic (closed form: no
        // search or integration per knot): each piece gets knots every
        // [`KNOT_DEPTH`] of optical depth (at most [`KNOT_MAX`]), so linear
        // interpolation between knots stays within ~1e-3 of the depth
        // (inside a narrow opaque peak the transmittance falls from 1 to 0
        // over one segment: knots every quarter of depth, at most 16, left
        // up to 3/255 of shadow error there on the held-out TFs).
        tf.extinction_knots(s0, s1, extinction);
        // Knots are stored as f32: ones closer than a few of its steps at
        // this parameter would merge, and a merge keeps the deeper depth at
        // the earlier place (a face the light enters would read as the
        // opaque inside just past it).
        let min_knot_gap = 4.0 * f32::EPSILON as f64 * seg.t_front.abs().max(seg.back.t.abs());
        let mut prev = 0.0;
        for w in extinction.windows(2) {
            let ([fa, ra], [fb, rb]) = (w[0], w[1]);
            let width = (fb - fa) * len;
            let mut end = prev + 0.5 * (ra + rb) * width;
            // Where the ray reaches MAP_OPAQUE_DEPTH inside this piece, its
            // knots end there (fraction `u_end` of the piece): none are
            // spent on depths no lookup can tell apart.
            let mut u_end = 1.0;
            if acc + end >= MAP_OPAQUE_DEPTH {
                // Not closer to the piece's start than f32 tells apart
                // (a merged knot would darken the face the light enters).
                let u_min = (min_knot_gap / width).min(1.0);
                u_end = fraction_at_depth(ra, rb, width, MAP_OPAQUE_DEPTH - acc - prev).max(u_min);
                end = MAP_OPAQUE_DEPTH - acc;
            }
            let pieces =
                ((end - prev) / KNOT_DEPTH).ceil().min((width * u_end / min_knot_gap).floor()).clamp(1.0, KNOT_MAX)
                    as usize;
            for q in 1..=pieces {
                let u = u_end * q as f64 / pieces as f64;
                let part = if q == pieces { end } else { prev + width * u * (ra + 0.5 * (rb - ra) * u) };
                push(seg.t_front + (fa + (fb - fa) * u) * len, acc + part, knots);
            }
            prev = end;
            if u_end < 1.0 {
                break;
            }
        }
        acc += prev;
        acc >= MAP_OPAQUE_DEPTH
    };
    match from_inside {
        // The ray starts in this tet (at t = 0): only the tets ahead.
        Some(inside) => reference.walk_line_from_inside(&line, inside, entries, stats, &mut visit),
        None => reference.walk_line(&line, t_start, entries, stats, &mut visit),
    }
    simplify(knots, first, KNOT_TOLERANCE);
}

/// The fraction u in [0, 1] of a piece of extinction linear from `ra` to
/// `rb` (per unit length, both ≥ 0) over `width` at which its optical
/// depth, width·u·(ra + (rb − ra)·u/2), reaches `depth` (≥ 0; 1 where the
/// whole piece holds less). The root in the form without cancellation.
fn fraction_at_depth(ra: f64, rb: f64, width: f64, depth: f64) -> f64 {
    // In units of the larger extinction, so that ra² cannot overflow.
    let m = ra.max(rb);
    if !(m > 0.0 && width > 0.0) {
        return 1.0;
    }
    let (a, b, t) = (ra / m, rb / m, depth.max(0.0) / width / m);
    let denom = a + (a * a + 2.0 * (b - a) * t).max(0.0).sqrt();
    if denom.is_nan() || denom <= 0.0 {
        return 1.0;
    }
    (2.0 * t / denom).clamp(0.0, 1.0)
}

/// Optical depth error allowed when dropping knots (transmittance off by
/// at most 0.1%).
const KNOT_TOLERANCE: f32 = 1e-3;

/// Optical depth between the knots a ray's piece of linear extinction gets
/// ([`walk_ray`]), and the most knots such a piece gets.
const KNOT_DEPTH: f64 = 0.05;
const KNOT_MAX: f64 = 1024.0;

/// Drops the knots of `knots[first..]` that linear interpolation between
/// the kept ones reproduces within `tol` (the swing-door rule: from the
/// last kept knot, the slopes that pass within `tol` of every knot since
/// form a narrowing interval; a knot is kept where it would empty). Most
/// crossings of faint cells go, the bends at opaque layers stay.
fn simplify(knots: &mut Vec<[f32; 2]>, first: usize, tol: f32) {
    if knots.len() - first < 3 {
        return;
    }
    let mut out = first + 1; // knots[first] is kept
    let mut anchor = knots[first];
    let (mut lo, mut hi) = (f32::NEG_INFINITY, f32::INFINITY);
    let mut i = first + 1;
    while i < knots.len() {
        let p = knots[i];
        let dt = p[0] - anchor[0];
        if dt <= 0.0 {
            i += 1;
            continue;
        }
        let (a, b) = ((p[1] - tol - anchor[1]) / dt, (p[1] + tol - anchor[1]) / dt);
        let (nlo, nhi) = (lo.max(a), hi.min(b));
        if nlo > nhi {
            // p cannot join: the previous knot is kept, and the door
            // reopens from it.
            anchor = knots[i - 1];
            knots[out] = anchor;
            out += 1;
            (lo, hi) = (f32::NEG_INFINITY, f32::INFINITY);
            continue;
        }
        (lo, hi) = (nlo, nhi);
        i += 1;
    }
    let last = knots[knots.len() - 1];
    if knots[out - 1] != last {
        knots[out] = last;
        out += 1;
    }
    knots.truncate(out);
}

#[cfg(test)]
mod tests {
    use super::*;
    use tet_mesh::{build_adjacency, tetrahedralize, ConvertOptions, SourceMesh, TetMesh};

    /// A 6³-cell grid over [0, 1]³, 5-split, without the tets whose centre
    /// lies in a slab across the middle (a non-convex mesh: rays leave into
    /// the gap and come back), scalar varying along all three axes.
    fn slotted_grid() -> TetMesh {
        let n = 6;
        let mut points = Vec::new();
        for k in 0..=n {
            for j in 0..=n {
                for i in 0..=n {
                    points.push([i as f64 / n as f64, j as f64 / n as f64, k as f64 / n as f64]);
                }
            }
        }
        let values = points.iter().map(|p| p[0] + 0.6 * p[1] * p[1] + 0.3 * p[2]).collect();
        let src = SourceMesh::structured([n + 1; 3], points, "s", values);
        let opts = ConvertOptions { scalar: Some("s".into()), ..Default::default() };
        let (mut mesh, _) = tetrahedralize(&src, &opts, &mut |_| {}).unwrap();
        let points = &mesh.points;
        mesh.tets
            .to_mut()
            .retain(|t| !(0.5..0.67).contains(&(t.iter().map(|&v| points[v as usize][0]).sum::<f64>() / 4.0)));
        mesh
    }

    /// The slotted grid's exact walker (the mesh leaked: a test's).
    fn slotted_reference() -> ReferenceRenderer<'static> {
        let mesh: &'static TetMesh = Box::leak(Box::new(slotted_grid()));
        let adjacency = Box::leak(Box::new(build_adjacency(&mesh.points, &mesh.tets).unwrap()));
        ReferenceRenderer::new(mesh, adjacency).unwrap()
    }

    /// A white TF over the slotted grid's scalars (0 to 2) with these
    /// opacity nodes (JSON pairs).
    fn white_tf(opacity: &str) -> TransferFunction {
        TransferFunction::from_json(&format!(
            r#"{{"color": [[0, 1, 1, 1], [2, 1, 1, 1]], "opacity": {opacity}, "unit_distance": 1}}"#
        ))
        .unwrap()
    }

    /// A faint medium with a narrow opaque band (extinction 40 over 0.03
    /// of the scalar): a layer whose shadow has sharp edges.
    fn band_tf() -> TransferFunction {
        white_tf("[[0, 0.1], [0.8, 0.1], [0.83, 40], [0.86, 0.1], [2, 0.3]]")
    }

    /// The tests' directional light: oblique to every axis of the grid.
    fn key_light() -> DVec3 {
        DVec3::new(0.6, -0.5, -0.62).normalize()
    }

    #[test]
    fn catmull_rom_weights_sum_to_one_and_keep_lines() {
        for k in 0..=20 {
            let t = k as f64 / 20.0;
            let w = catmull_rom(t);
            assert!((w.iter().sum::<f64>() - 1.0).abs() < 1e-15, "{t}");
            let line: f64 = w.iter().enumerate().map(|(i, w)| w * (i as f64 - 1.0)).sum();
            assert!((line - t).abs() < 1e-15, "{t}: {line}");
        }
        assert_eq!(catmull_rom(0.0), [0.0, 1.0, 0.0, 0.0]);
    }

    /// A directional light's map against exact shadow rays at points all
    /// over a grid whose TF has a narrow opaque band (the layer crossed
    /// obliquely, its shadow's edges): the transmittances agree closely,
    /// and a lookup never leaves the range of depths the rays around it
    /// hold (no overshoot at the band's steps).
    #[test]
    fn a_directional_map_follows_exact_shadow_rays_through_a_narrow_band() {
        let reference = slotted_reference();
        let tf = band_tf();
        let d = key_light();
        let mut stats = ReferenceStats::default();
        let map = DeepShadowMap::build(&reference, d, &tf, &mut stats);
        assert_eq!(stats.walk_failures, 0);
        // The band's shadow edges refine the map.
        assert!(!map.levels.is_empty());
        assert_levels_nest(&map);
        let light = crate::LightSource::Directional { direction: d.into(), intensity: 1.0 };
        let (mean, worst) = errors_against_exact_rays(&reference, &map, &light, &tf);
        // Bilinear between the rays (the knots as now): mean 1.8e-3, worst
        // 0.17; bicubic where they disagree: 4.7e-4, 0.048; with the fine
        // rays around rough cells: 3.0e-4, 0.017.
        assert!(mean < 4e-4 && worst < 0.03, "mean {mean:.2e}, worst {worst:.3}");
    }

    /// A level's table by tiles reads as the full table it was made from,
    /// at every position of grids whose sides are and are not whole tiles,
    /// and keeps only the tiles that have a ray.
    #[test]
    fn a_level_table_reads_as_its_full_table() {
        let mut rng = tet_mesh::XorShift64(11);
        for (nu, nv) in [(17, 9), (16, 16), (3, 41), (1, 1)] {
            let mut dense = vec![NO_RAY; nu * nv];
            // A few clusters of rays, as refinement around edges leaves.
            for _ in 0..3 {
                let (ci, cj) = ((rng.range(0.0, nu as f64)) as usize, (rng.range(0.0, nv as f64)) as usize);
                for j in cj.saturating_sub(2)..(cj + 3).min(nv) {
                    for i in ci.saturating_sub(2)..(ci + 3).min(nu) {
                        dense[j * nu + i] = (j * nu + i) as u32 * 7;
                    }
                }
            }
            let table = LevelTable::from_dense(nu, &dense);
            for j in 0..nv {
                for i in 0..nu {
                    assert_eq!(table.get(i, j), dense[j * nu + i], "({i}, {j}) of {nu} × {nv}");
                }
            }
            let directory = nu.div_ceil(LEVEL_TILE) * nv.div_ceil(LEVEL_TILE);
            let with_rays = (0..directory)
                .filter(|&t| {
                    let (ti, tj) = (t % nu.div_ceil(LEVEL_TILE), t / nu.div_ceil(LEVEL_TILE));
                    (0..nv).any(|j| {
                        (0..nu).any(|i| i / LEVEL_TILE == ti && j / LEVEL_TILE == tj && dense[j * nu + i] != NO_RAY)
                    })
                })
                .count();
            assert_eq!(table.words.len(), directory + with_rays * LEVEL_TILE * LEVEL_TILE);
        }
        // No ray at all: the directory alone.
        assert_eq!(LevelTable::from_dense(20, &[NO_RAY; 60]).words, vec![NO_RAY; 3]);
    }

    /// Each level of a map keeps the rays of the level above at its even
    /// positions where it was walked, and adds its own only around edges.
    fn assert_levels_nest(map: &DeepShadowMap) {
        let mut above: Vec<u32> = (0..(map.nu * map.nv) as u32).collect();
        for depth in 1..=map.levels.len() {
            let (up, level) = (map.level(depth - 1), map.level(depth));
            let tiles = &map.levels[depth - 1];
            let table: Vec<u32> = (0..level.nu * level.nv).map(|k| tiles.get(k % level.nu, k / level.nu)).collect();
            let directory = tiles.tiles_u * level.nv.div_ceil(LEVEL_TILE);
            let kept = tiles.words[..directory].iter().filter(|&&w| w != NO_RAY).count();
            assert!(kept < directory, "level {depth} keeps only the tiles walked");
            assert_eq!(tiles.words.len(), directory + kept * LEVEL_TILE * LEVEL_TILE);
            assert!(table.contains(&NO_RAY), "level {depth} refined around the edges only");
            let known: std::collections::HashSet<u32> = above.iter().copied().collect();
            let added = table.iter().filter(|&&r| r != NO_RAY && !known.contains(&r)).count();
            assert!(added > 0, "level {depth} adds rays");
            for j in 0..up.nv {
                for i in 0..up.nu {
                    let r = above[j * up.nu + i];
                    // Where the level was walked, the ray above is there.
                    let here = table[2 * j * level.nu + 2 * i];
                    assert!(here == r || here == NO_RAY, "level {depth} at ({i}, {j})");
                }
            }
            above = table.clone();
        }
    }

    /// The mean and largest transmittance error of `map` against exact
    /// shadow rays at random points of the slotted grid.
    fn errors_against_exact_rays(
        reference: &ReferenceRenderer,
        map: &DeepShadowMap,
        light: &crate::LightSource,
        tf: &TransferFunction,
    ) -> (f64, f64) {
        let mut scratch = crate::shadow::ShadowScratch::default();
        let mut stats = ReferenceStats::default();
        let mut rng = tet_mesh::XorShift64(5);
        let (mut worst, mut sum, mut n) = (0.0f64, 0.0, 0);
        for _ in 0..3000 {
            let p = DVec3::new(rng.range(0.02, 0.98), rng.range(0.02, 0.98), rng.range(0.02, 0.98));
            if (0.5..0.67).contains(&p.x) {
                continue; // in the slot: no tet there
            }
            let exact = reference.depth_to_light(p, light, tf, &mut scratch, &mut stats);
            let err = ((-map.depth_at(p)).exp() - (-exact).exp()).abs();
            worst = worst.max(err);
            sum += err;
            n += 1;
        }
        (sum / n as f64, worst)
    }

    /// The fraction where a piece of linear extinction reaches a depth is
    /// the root of its quadratic depth, for rising, falling, constant and
    /// huge extinctions (no overflow at 1e300), and 1 where the piece
    /// holds less.
    #[test]
    fn the_fraction_at_a_depth_inverts_a_pieces_depth() {
        let depth_at = |ra: f64, rb: f64, w: f64, u: f64| w * u * (ra + 0.5 * (rb - ra) * u);
        for (ra, rb, w) in
            [(0.0, 1000.0, 0.01), (1000.0, 0.0, 0.01), (3.0, 3.0, 2.0), (1e-3, 7.0, 5.0), (1e300, 1e300, 0.5)]
        {
            for frac in [1e-9, 0.01, 0.3, 0.99] {
                let target = frac * depth_at(ra, rb, w, 1.0);
                let u = fraction_at_depth(ra, rb, w, target);
                let got = depth_at(ra, rb, w, u);
                assert!((got - target).abs() <= 1e-12 * target, "{ra} {rb} {w}: u {u}, {got} vs {target}");
            }
            assert_eq!(fraction_at_depth(ra, rb, w, 2.0 * depth_at(ra, rb, w, 1.0)), 1.0);
        }
        assert_eq!(fraction_at_depth(0.0, 0.0, 1.0, 5.0), 1.0);
    }

    /// An opaque layer oblique to the light (extinction 10³ over 1% of the
    /// scalar, a fuzz finding's TF): its rays end their knots at
    /// [`MAP_OPAQUE_DEPTH`], the finer grids stop at the memory budget, and
    /// the map still follows exact shadow rays away from the layer's
    /// shadow edge.
    #[test]
    fn an_opaque_layer_keeps_the_map_within_its_budget() {
        let reference = slotted_reference();
        let tf = white_tf("[[0, 0.1], [0.99, 0.1], [1.0, 1000], [1.01, 0.1], [2, 0.1]]");
        let map = DeepShadowMap::build(&reference, key_light(), &tf, &mut ReferenceStats::default());
        let cut = MAP_OPAQUE_DEPTH as f32;
        assert!(map.knots.iter().all(|k| k[1] <= cut));
        // Each ray that reaches the cut ends there: no two knots of a ray
        // at the cut, and rays do reach it.
        let mut reaching = 0;
        for r in &map.rays {
            let knots = &map.knots[r.start as usize..r.end as usize];
            let at_cut = knots.iter().filter(|k| k[1] == cut).count();
            assert!(at_cut <= 1, "a ray with {at_cut} knots at the cut");
            reaching += at_cut;
        }
        assert!(reaching > map.rays.len() / 10, "{reaching} of {} rays reach the cut", map.rays.len());
        let bytes = map.memory_bytes();
        assert!(bytes <= LEVELS_BUDGET_BYTES, "{bytes} bytes");
        assert!(!map.levels.is_empty(), "the budget leaves room for a finer grid");
        let light = crate::LightSource::Directional { direction: key_light().into(), intensity: 1.0 };
        let (mean, worst) = errors_against_exact_rays(&reference, &map, &light, &tf);
        // Measured: 43.6 MB with two finer grids (the third would have
        // passed the budget and was given up), mean 1.86e-4, worst 0.24
        // (at the layer's shadow edge, within a ray spacing).
        assert!(mean < 4e-4 && worst < 0.5, "mean {mean:.2e}, worst {worst:.3}");
    }

    /// Two narrower, denser bands: shadow edges the fine grid still leaves
    /// rough get the finer grids, and the map follows exact shadow rays
    /// closer with each level.
    #[test]
    fn the_finer_grids_follow_narrower_bands_closer() {
        let reference = slotted_reference();
        let tf = white_tf(
            "[[0, 0.1], [0.8, 0.1], [0.81, 400], [0.82, 0.1], [1.2, 0.1], [1.21, 400], [1.22, 0.1], [2, 0.3]]",
        );
        let d = key_light();
        let map = DeepShadowMap::build(&reference, d, &tf, &mut ReferenceStats::default());
        assert_eq!(map.levels.len(), MAX_LEVELS);
        assert_levels_nest(&map);
        let light = crate::LightSource::Directional { direction: d.into(), intensity: 1.0 };
        let errors = |levels: usize| {
            let mut map = map.clone();
            map.levels.truncate(levels);
            errors_against_exact_rays(&reference, &map, &light, &tf)
        };
        let [(mean3, worst3), (mean2, worst2), (mean1, worst1)] = [3, 2, 1].map(errors);
        // Measured: three levels mean 1.19e-4, worst 0.019; two 1.81e-4,
        // 0.043; the fine grid alone 6.0e-4, 0.31.
        let got = format!("three levels: mean {mean3:.2e}, worst {worst3:.3}; two: {mean2:.2e}, {worst2:.3}; one: {mean1:.2e}, {worst1:.3}");
        assert!(mean3 < 1.5e-4 && worst3 < 0.03, "{got}");
        assert!(1.3 * mean3 < mean2 && 1.5 * worst3 < worst2, "{got}");
        assert!(2.0 * mean2 < mean1 && 2.0 * worst2 < worst1, "{got}");
    }

    /// A faint TF (no steep shadow anywhere) walks no fine rays: the
    /// refinement costs nothing where the coarse map is followed.
    #[test]
    fn a_faint_medium_refines_nothing() {
        let tf = white_tf("[[0, 0.1], [2, 0.1]]");
        let map = DeepShadowMap::build(&slotted_reference(), key_light(), &tf, &mut Default::default());
        assert!(map.levels.is_empty(), "{} levels", map.levels.len());
    }

    /// The compact ray records and the full index the GPU gets agree: a
    /// ray's bins start at its first knot at or past each bin's parameter,
    /// long rays' bins are the ones kept, and a scan from a bin finds the
    /// knot a scan of the whole ray finds (short and long rays alike).
    #[test]
    fn ray_records_and_the_full_index_find_the_same_knots() {
        let map = DeepShadowMap::build(&slotted_reference(), key_light(), &band_tf(), &mut Default::default());
        let layout = map.layout();
        assert_eq!(layout.index.len(), map.rays.len() * (BINS + 1));
        let first_past = |from: usize, end: usize, t: f32| (from..end).find(|&n| map.knots[n][0] > t).unwrap_or(end);
        let (mut short, mut long) = (0, 0);
        let mut rng = tet_mesh::XorShift64(9);
        for (r, rec) in map.rays.iter().enumerate() {
            let (start, end) = (rec.start as usize, rec.end as usize);
            let index = &layout.index[r * (BINS + 1)..][..BINS + 1];
            assert_eq!((index[0] as usize, index[BINS] as usize), (start, end), "ray {r}");
            for (b, &at) in index.iter().enumerate().take(BINS).skip(1) {
                let (at, t) = (at as usize, b as f32 * map.bin_len);
                assert!(map.knots[start..at].iter().all(|k| k[0] < t) && (at == end || map.knots[at][0] >= t));
                if end - start > SHORT_RAY {
                    assert_eq!(map.bins[rec.bins_at as usize + b - 1] as usize, at, "ray {r} bin {b}");
                }
            }
            if end - start > SHORT_RAY {
                long += 1;
            } else if end > start {
                short += 1;
            }
            for _ in 0..8 {
                let t = rng.range(0.0, (BINS as f64 + 1.0) * map.bin_len as f64) as f32;
                let b = ((t / map.bin_len).max(0.0) as usize).min(BINS - 1);
                let from = if end - start > SHORT_RAY { index[b] as usize } else { start };
                assert_eq!(first_past(from, end, t), first_past(start, end, t), "ray {r} at {t}");
            }
        }
        assert!(short > 0 && long > 0, "{short} short and {long} long rays");
    }

    /// A cube walked from the light's tet records the same depths as one
    /// walked along whole lines from their boundary entries, on a mesh the
    /// rays leave and re-enter; the light's tet is found, a light on a
    /// vertex or outside the mesh has none.
    #[test]
    fn a_cube_walked_from_the_light_equals_one_walked_along_whole_lines() {
        let mesh = slotted_grid();
        let adjacency = build_adjacency(&mesh.points, &mesh.tets).unwrap();
        assert!(!adjacency.convex);
        let reference = ReferenceRenderer::new(&mesh, &adjacency).unwrap();
        let tf = white_tf("[[0, 0.2], [0.7, 3], [0.8, 0.1], [2, 1.5]]");
        let light = DVec3::new(0.23, 0.31, 0.27);
        let (tet, s) = reference.tet_strictly_containing(light).expect("the light's tet");
        assert!((s - (0.23 + 0.6 * 0.31 * 0.31 + 0.3 * 0.27)).abs() < 0.05, "{s}");
        assert_eq!(reference.tet_strictly_containing(DVec3::splat(0.5)), None, "a grid vertex");
        assert_eq!(reference.tet_strictly_containing(DVec3::new(0.55, 0.5, 0.5)), None, "in the slot");
        assert_eq!(reference.tet_strictly_containing(DVec3::splat(2.0)), None, "outside");
        let (mut a, mut b) = (ReferenceStats::default(), ReferenceStats::default());
        let inside = DeepShadowMap::build_cube_from(&reference, light, &tf, &mut a, Some((light, tet, s)));
        let whole = DeepShadowMap::build_cube_from(&reference, light, &tf, &mut b, None);
        assert_eq!((a.walk_failures, b.walk_failures), (0, 0));
        let mut rng = tet_mesh::XorShift64(29);
        let mut deep = 0;
        for _ in 0..3000 {
            let p = DVec3::new(rng.range(0.0, 1.0), rng.range(0.0, 1.0), rng.range(0.0, 1.0));
            let f = cube_face(p - light);
            let (x, y) = (inside[f].depth_at(p), whole[f].depth_at(p));
            assert!((x - y).abs() <= 1e-5 * y.max(1.0), "at {p}: {x} vs {y}");
            deep += usize::from(y > 1.0 && p.x > 0.67);
        }
        assert!(deep > 100, "rays across the slot carry depth: {deep}");

        // A light on a grid vertex (in no tet strictly): its rays start a
        // hair away inside a tet, and read as the whole lines do.
        let vertex = DVec3::splat(2.0 / 6.0);
        assert_eq!(reference.tet_strictly_containing(vertex), None);
        let (mut c, mut d) = (ReferenceStats::default(), ReferenceStats::default());
        let nudged = DeepShadowMap::build_cube(&reference, vertex, &tf, &mut c).unwrap();
        let whole = DeepShadowMap::build_cube_from(&reference, vertex, &tf, &mut d, None);
        // (Entries: only the re-entries across the slot, not every ray's.)
        assert!(c.entries < d.entries / 3, "walked from inside: {} entries against {}", c.entries, d.entries);
        assert_eq!((c.walk_failures, d.walk_failures), (0, 0));
        for _ in 0..3000 {
            let p = DVec3::new(rng.range(0.0, 1.0), rng.range(0.0, 1.0), rng.range(0.0, 1.0));
            let f = cube_face(p - vertex);
            let (x, y) = (nudged[f].depth_at(p), whole[f].depth_at(p));
            assert!((x - y).abs() <= 1e-5 * y.max(1.0), "at {p}: {x} vs {y}");
        }
    }
}
