//! What the renderer keeps of a bundle: vertex positions relative to the
//! mesh centre (so a mesh far from the origin — coordinates of 1e6 — keeps
//! its sub-cell precision through every later subtraction), scalars, face
//! adjacency, convexity and, when shading or bivariate methods need them,
//! per-vertex gradients and their magnitudes.

use crate::shadow::ShadowField;
use crate::RenderError;
use glam::DVec3;
use std::sync::Arc;
use tet_bundle::Bundle;
use tet_mesh::SharedArray;
use tet_mesh::{build_adjacency, NO_NEIGHBOR};

/// The renderer's copy of a mesh. Its geometry is fixed once built; views,
/// transfer functions and shaders change around it, and a time series
/// changes its scalar ([`Scene::set_scalar`]).
#[derive(Debug, Clone)]
pub struct Scene {
    centre_in_world: DVec3,
    pos_rel: Vec<[f64; 3]>,
    /// (Owned, or shared with a mapped bundle file: `tet_mesh::SharedArray`.)
    tets: SharedArray<[u32; 4]>,
    scalar: Vec<f64>,
    neighbors: SharedArray<[u32; 4]>,
    convex: bool,
    gradients: Option<Vec<[f64; 3]>>,
    grad_mag: Option<Vec<f64>>,
    bounds_min: [f64; 3],
    bounds_max: [f64; 3],
    scalar_range: [f64; 2],
    /// Each light's shadow (deep shadow maps), for shadows.
    shadows: Option<Arc<ShadowField>>,
}

impl Scene {
    /// Builds a scene from raw arrays, computing the face adjacency. Tets
    /// must be positively oriented (as every bundle's are) for front/back
    /// face decisions to be right.
    pub fn new(
        points: &[[f64; 3]],
        tets: impl Into<SharedArray<[u32; 4]>>,
        scalar: Vec<f64>,
    ) -> Result<Scene, RenderError> {
        let tets = tets.into();
        check_arrays(points, &tets, &scalar)?;
        let adj = build_adjacency(points, &tets).map_err(|e| RenderError::Scene(e.to_string()))?;
        Scene::assemble(points, tets, scalar, adj.neighbors, adj.convex)
    }

    /// Takes the mesh, adjacency and (if stored) gradients of a bundle.
    pub fn from_bundle(bundle: &Bundle) -> Result<Scene, RenderError> {
        let m = &bundle.mesh;
        Scene::from_parts(
            &m.points,
            m.tets.clone(),
            m.scalar.clone(),
            bundle.adjacency.neighbors.clone(),
            bundle.adjacency.convex,
            bundle.gradients().map(|g| g.per_point.clone()),
        )
    }

    /// [`Scene::from_bundle`] taking the bundle: its arrays are moved into
    /// the scene rather than copied, for a caller done with the bundle
    /// (a one-shot render of a mesh near the memory's size).
    pub fn from_bundle_owned(bundle: Bundle) -> Result<Scene, RenderError> {
        let (m, adjacency, gradients) = bundle.into_mesh();
        Scene::from_parts(
            &m.points,
            m.tets,
            m.scalar,
            adjacency.neighbors,
            adjacency.convex,
            gradients.map(|g| g.per_point),
        )
    }

    fn from_parts(
        points: &[[f64; 3]],
        tets: SharedArray<[u32; 4]>,
        scalar: Vec<f64>,
        neighbors: SharedArray<[u32; 4]>,
        convex: bool,
        gradients: Option<Vec<[f64; 3]>>,
    ) -> Result<Scene, RenderError> {
        check_arrays(points, &tets, &scalar)?;
        if neighbors.len() != tets.len() {
            return Err(RenderError::Scene(format!(
                "adjacency has {} entries for {} tets",
                neighbors.len(),
                tets.len()
            )));
        }
        let s = Scene::assemble(points, tets, scalar, neighbors, convex)?;
        match gradients {
            Some(g) => s.with_gradients(g),
            None => Ok(s),
        }
    }

    fn assemble(
        points: &[[f64; 3]],
        tets: SharedArray<[u32; 4]>,
        scalar: Vec<f64>,
        neighbors: SharedArray<[u32; 4]>,
        convex: bool,
    ) -> Result<Scene, RenderError> {
        let n = points.len();
        for (t, nb) in neighbors.iter().enumerate() {
            if let Some(&x) = nb.iter().find(|&&x| x != NO_NEIGHBOR && x as usize >= tets.len()) {
                return Err(RenderError::Scene(format!("tet {t}: neighbour {x} out of range ({} tets)", tets.len())));
            }
        }
        let (lo, hi) = tet_mesh::stats::bounds(points);
        let centre = if n == 0 { DVec3::ZERO } else { (DVec3::from(lo) + DVec3::from(hi)) * 0.5 };
        let pos_rel = points.iter().map(|p| (DVec3::from(*p) - centre).into()).collect();
        let scalar_range = scalar.iter().fold([f64::INFINITY, f64::NEG_INFINITY], |[a, b], &s| [a.min(s), b.max(s)]);
        Ok(Scene {
            centre_in_world: centre,
            pos_rel,
            tets,
            scalar,
            neighbors,
            convex,
            gradients: None,
            grad_mag: None,
            bounds_min: lo,
            bounds_max: hi,
            scalar_range,
            shadows: None,
        })
    }

    /// Attaches per-vertex gradients (scalar units per world length), used as
    /// normals for lighting and silhouettes and, as magnitudes, by bivariate
    /// methods.
    pub fn with_gradients(mut self, per_point: Vec<[f64; 3]>) -> Result<Scene, RenderError> {
        self.set_gradients(per_point)?;
        Ok(self)
    }

    /// [`Scene::with_gradients`] in place (a time step's stored gradients
    /// after [`Scene::set_scalar`]).
    pub fn set_gradients(&mut self, per_point: Vec<[f64; 3]>) -> Result<(), RenderError> {
        if per_point.len() != self.pos_rel.len() {
            return Err(RenderError::Scene(format!("{} gradients for {} points", per_point.len(), self.pos_rel.len())));
        }
        if let Some(i) = per_point.iter().position(|g| !g.iter().all(|v| v.is_finite())) {
            return Err(RenderError::Scene(format!("gradient of point {i} is not finite")));
        }
        self.grad_mag = Some(per_point.iter().map(|g| DVec3::from(*g).length()).collect());
        self.gradients = Some(per_point);
        Ok(())
    }

    /// Replaces the scalar (a time series' next step: the geometry stays).
    /// Gradients describe the old scalar, so they are dropped (true when
    /// there were some); [`Scene::ensure_gradients`] computes new ones.
    pub fn set_scalar(&mut self, scalar: Vec<f64>) -> Result<bool, RenderError> {
        if scalar.len() != self.pos_rel.len() {
            return Err(RenderError::Scene(format!("{} scalars for {} points", scalar.len(), self.pos_rel.len())));
        }
        if let Some(i) = scalar.iter().position(|s| !s.is_finite()) {
            return Err(RenderError::Scene(format!("scalar of point {i} is not finite")));
        }
        self.scalar_range = scalar.iter().fold([f64::INFINITY, f64::NEG_INFINITY], |[a, b], &s| [a.min(s), b.max(s)]);
        self.scalar = scalar;
        self.grad_mag = None;
        self.shadows = None;
        Ok(self.gradients.take().is_some())
    }

    /// Attaches (or with `None` drops) the shadow field renderers light
    /// with; it must have one transmittance per point.
    pub fn set_shadows(&mut self, field: Option<Arc<ShadowField>>) -> Result<(), RenderError> {
        if let Some(f) = &field {
            if f.key().num_points != self.pos_rel.len() {
                return Err(RenderError::Scene(format!(
                    "shadow field of {} points for {} points",
                    f.key().num_points,
                    self.pos_rel.len()
                )));
            }
        }
        self.shadows = field;
        Ok(())
    }

    pub fn shadows(&self) -> Option<&Arc<ShadowField>> {
        self.shadows.as_ref()
    }

    /// Computes least-squares per-vertex gradients when none are attached.
    pub fn ensure_gradients(self) -> Result<Scene, RenderError> {
        if self.gradients.is_some() {
            return Ok(self);
        }
        let points: Vec<[f64; 3]> = self.pos_rel.clone();
        let an = tet_analysis::Analyzer::new(&points, &self.tets, &self.scalar)
            .map_err(|e| RenderError::Scene(e.to_string()))?;
        let g = an.vertex_gradients(tet_analysis::GradientMethod::LeastSquares).to_vec();
        self.with_gradients(g)
    }

    /// World position of the point positions are stored relative to.
    pub fn centre_in_world(&self) -> DVec3 {
        self.centre_in_world
    }
    /// Vertex positions relative to [`Scene::centre_in_world`].
    pub fn positions_rel(&self) -> &[[f64; 3]] {
        &self.pos_rel
    }
    pub fn tets(&self) -> &[[u32; 4]] {
        &self.tets
    }
    pub fn scalar(&self) -> &[f64] {
        &self.scalar
    }
    pub fn neighbors(&self) -> &[[u32; 4]] {
        &self.neighbors
    }
    pub fn is_convex(&self) -> bool {
        self.convex
    }
    pub fn gradients(&self) -> Option<&[[f64; 3]]> {
        self.gradients.as_deref()
    }
    pub fn gradient_magnitudes(&self) -> Option<&[f64]> {
        self.grad_mag.as_deref()
    }
    /// World bounding box of the points.
    pub fn bounds(&self) -> ([f64; 3], [f64; 3]) {
        (self.bounds_min, self.bounds_max)
    }
    /// Smallest and largest vertex scalar.
    pub fn scalar_range(&self) -> [f64; 2] {
        self.scalar_range
    }
    pub fn num_tets(&self) -> usize {
        self.tets.len()
    }
    pub fn num_points(&self) -> usize {
        self.pos_rel.len()
    }
}

fn check_arrays(points: &[[f64; 3]], tets: &[[u32; 4]], scalar: &[f64]) -> Result<(), RenderError> {
    if scalar.len() != points.len() {
        return Err(RenderError::Scene(format!("{} scalars for {} points", scalar.len(), points.len())));
    }
    if tets.len() > (u32::MAX / 4) as usize {
        return Err(RenderError::Scene(format!("{} tets: more than 2^30 are not supported", tets.len())));
    }
    if let Some(i) = points.iter().position(|p| !p.iter().all(|v| v.is_finite())) {
        return Err(RenderError::Scene(format!("point {i} has a non-finite coordinate")));
    }
    if let Some(i) = scalar.iter().position(|s| !s.is_finite()) {
        return Err(RenderError::Scene(format!("scalar of point {i} is not finite")));
    }
    for (t, tet) in tets.iter().enumerate() {
        if let Some(&v) = tet.iter().find(|&&v| v as usize >= points.len()) {
            return Err(RenderError::Scene(format!("tet {t} refers to point {v}; the mesh has {}", points.len())));
        }
    }
    Ok(())
}
