//! The mesh on the GPU (`GpuScene`: positions about the centre, tets,
//! scalars and their ranks, gradient magnitudes) and the CPU centroid order.

use super::*;

/// A mesh on the GPU. Positions are stored relative to the bounding-box
/// centre (as tet_render's `Scene`), in f32, so far-from-origin meshes keep
/// their sub-cell precision.
pub struct GpuScene {
    /// Unique per scene: keys the renderer's cached GPU order.
    pub(crate) id: u64,
    pub(crate) centre_in_world: DVec3,
    pub(crate) n_points: usize,
    /// Kept for the CPU centroid sort.
    pub(crate) pos_rel: Vec<[f32; 3]>,
    pub(crate) tets: Vec<[u32; 4]>,
    pub(crate) positions: wgpu::Buffer,
    pub(crate) tet_buf: wgpu::Buffer,
    pub(crate) scalars: wgpu::Buffer,
    /// The distinct vertex scalars, ascending (f64), and each vertex's index
    /// among them on the GPU: what culling compares ([`crate::GpuCull`]).
    pub(crate) distinct: Vec<f64>,
    pub(crate) ranks: wgpu::Buffer,
    /// Per-vertex gradient magnitudes (bivariate methods), f32.
    pub(crate) gmags: Option<wgpu::Buffer>,
    /// Their distinct values ascending and each vertex's rank among them
    /// (culling with 2D widgets).
    pub(crate) g_distinct: Option<Vec<f64>>,
    pub(crate) g_ranks: Option<wgpu::Buffer>,
    /// Per-vertex gradients (lighting): xyz in f32, w = 1 where the
    /// gradient is finite (else 0, xyz = 0: no direction).
    pub(crate) grads: Option<wgpu::Buffer>,
}

impl GpuScene {
    /// Uploads a mesh: `tets` positively oriented (as every bundle's are),
    /// one scalar per point. Indices out of range and non-finite values are
    /// errors, and so are tets or points beyond one storage binding (16
    /// bytes each: 8.4M on lavapipe's 128 MiB); per-tet render data is
    /// chunked and has no such limit.
    pub fn new(ctx: &GpuContext, points: &[[f64; 3]], tets: &[[u32; 4]], scalar: &[f64]) -> Result<GpuScene, GpuError> {
        if scalar.len() != points.len() {
            return Err(GpuError::Input(format!("{} scalars for {} points", scalar.len(), points.len())));
        }
        if points.is_empty() || tets.is_empty() {
            return Err(GpuError::Input(format!("{} points and {} tets: nothing to draw", points.len(), tets.len())));
        }
        if let Some(i) = points.iter().position(|p| !p.iter().all(|v| v.is_finite())) {
            return Err(GpuError::Input(format!("point {i} has a non-finite coordinate")));
        }
        if let Some(i) = scalar.iter().position(|s| !s.is_finite()) {
            return Err(GpuError::Input(format!("scalar of point {i} is not finite")));
        }
        if let Some((t, v)) = tets
            .iter()
            .enumerate()
            .find_map(|(t, tet)| tet.iter().find(|&&v| v as usize >= points.len()).map(|&v| (t, v)))
        {
            return Err(GpuError::Input(format!("tet {t} refers to point {v}; the mesh has {}", points.len())));
        }
        // Per-slot data is drawn in chunks; the scene itself is bound whole.
        let limit = ctx.device.limits().max_storage_buffer_binding_size;
        check_size("tets (16 bytes a tet)", tets.len() as u64 * 16, limit)?;
        check_size("point positions (16 bytes a point)", points.len() as u64 * 16, limit)?;
        if tets.len() as u64 * VERTS_PER_SLOT as u64 > u32::MAX as u64 {
            return Err(GpuError::Input(format!("{} tets: too many vertices for one draw", tets.len())));
        }
        let (mut lo, mut hi) = ([f64::INFINITY; 3], [f64::NEG_INFINITY; 3]);
        for p in points {
            for k in 0..3 {
                lo[k] = lo[k].min(p[k]);
                hi[k] = hi[k].max(p[k]);
            }
        }
        let centre = (DVec3::from(lo) + DVec3::from(hi)) * 0.5;
        let pos_rel: Vec<[f32; 3]> = points.iter().map(|p| (DVec3::from(*p) - centre).as_vec3().to_array()).collect();
        let pos4: Vec<[f32; 4]> = pos_rel.iter().map(|p| [p[0], p[1], p[2], 0.0]).collect();
        let s32: Vec<f32> = scalar.iter().map(|&s| s as f32).collect();
        let (distinct, ranks) = distinct_and_ranks(scalar);
        let init = |label: &str, contents: &[u8]| buffer_init(&ctx.device, label, contents, SCENE_USAGE);
        let (positions, tet_buf, scalars, ranks) = ctx.checked(|| {
            (
                init("positions", bytemuck::cast_slice(&pos4)),
                init("tets", bytemuck::cast_slice(tets)),
                init("scalars", bytemuck::cast_slice(&s32)),
                init("scalar ranks", bytemuck::cast_slice(&ranks)),
            )
        })?;
        Ok(GpuScene {
            id: next_scene_id(),
            centre_in_world: centre,
            n_points: points.len(),
            pos_rel,
            tets: tets.to_vec(),
            positions,
            tet_buf,
            scalars,
            distinct,
            ranks,
            gmags: None,
            g_distinct: None,
            g_ranks: None,
            grads: None,
        })
    }

    /// The scene with per-vertex gradient magnitudes |∇s| (what the
    /// bivariate methods interpolate along a segment; tet_render's
    /// `Scene::gradient_magnitudes`). One finite value ≥ 0 per point.
    pub fn with_gradient_magnitudes(mut self, ctx: &GpuContext, g: &[f64]) -> Result<GpuScene, GpuError> {
        if g.len() != self.n_points {
            return Err(GpuError::Input(format!("{} gradient magnitudes for {} points", g.len(), self.n_points)));
        }
        if let Some(i) = g.iter().position(|v| !(v.is_finite() && *v >= 0.0)) {
            return Err(GpuError::Input(format!("gradient magnitude of point {i} is {}: need finite ≥ 0", g[i])));
        }
        let g32: Vec<f32> = g.iter().map(|&v| v as f32).collect();
        let (distinct, ranks) = distinct_and_ranks(g);
        let init = |label: &str, contents: &[u8]| buffer_init(&ctx.device, label, contents, SCENE_USAGE);
        let (gmags, g_ranks) = ctx.checked(|| {
            (
                init("gradient magnitudes", bytemuck::cast_slice(&g32)),
                init("gradient ranks", bytemuck::cast_slice(&ranks)),
            )
        })?;
        self.gmags = Some(gmags);
        self.g_ranks = Some(g_ranks);
        self.g_distinct = Some(distinct);
        Ok(self)
    }

    /// The scene with per-vertex gradients ∇s in the world frame (what
    /// lighting and silhouettes interpolate as the normal; tet_render's
    /// `Scene::gradients`), one a point. A non-finite gradient is kept as
    /// one with no direction: a tet with one is lit as the isotropic medium,
    /// as on the CPU (where its interpolated normal is not finite).
    pub fn with_gradients(mut self, ctx: &GpuContext, g: &[[f64; 3]]) -> Result<GpuScene, GpuError> {
        if g.len() != self.n_points {
            return Err(GpuError::Input(format!("{} gradients for {} points", g.len(), self.n_points)));
        }
        let g4: Vec<[f32; 4]> = g
            .par_iter()
            .map(|v| {
                let f = v.map(|c| c as f32);
                if f.iter().all(|c| c.is_finite()) {
                    [f[0], f[1], f[2], 1.0]
                } else {
                    [0.0; 4]
                }
            })
            .collect();
        let grads = ctx.checked(|| buffer_init(&ctx.device, "gradients", bytemuck::cast_slice(&g4), SCENE_USAGE))?;
        self.grads = Some(grads);
        Ok(self)
    }

    /// Whether the scene carries per-vertex gradients.
    pub fn has_gradients(&self) -> bool {
        self.grads.is_some()
    }

    /// Replaces the scalar (a time series' step; one finite value per
    /// point), written into the existing buffers. Gradients and their
    /// magnitudes describe the old scalar and are dropped; the scene gets a new id, so
    /// a [`crate::GpuCull`] of the old scalar is refused rather than used.
    pub fn set_scalar(&mut self, ctx: &GpuContext, scalar: &[f64]) -> Result<(), GpuError> {
        if scalar.len() != self.n_points {
            return Err(GpuError::Input(format!("{} scalars for {} points", scalar.len(), self.n_points)));
        }
        if let Some(i) = scalar.iter().position(|s| !s.is_finite()) {
            return Err(GpuError::Input(format!("scalar of point {i} is not finite")));
        }
        let s32: Vec<f32> = scalar.iter().map(|&s| s as f32).collect();
        let (distinct, ranks) = distinct_and_ranks(scalar);
        ctx.checked(|| {
            ctx.queue.write_buffer(&self.scalars, 0, bytemuck::cast_slice(&s32));
            ctx.queue.write_buffer(&self.ranks, 0, bytemuck::cast_slice(&ranks));
        })?;
        self.distinct = distinct;
        (self.gmags, self.g_ranks, self.g_distinct, self.grads) = (None, None, None, None);
        self.id = next_scene_id();
        Ok(())
    }

    /// Whether the scene carries gradient magnitudes.
    pub fn has_gradient_magnitudes(&self) -> bool {
        self.gmags.is_some()
    }

    pub(crate) fn id(&self) -> u64 {
        self.id
    }
    pub(crate) fn tet_buf(&self) -> &wgpu::Buffer {
        &self.tet_buf
    }
    pub(crate) fn ranks(&self) -> &wgpu::Buffer {
        &self.ranks
    }
    pub(crate) fn distinct_scalars(&self) -> &[f64] {
        &self.distinct
    }
    pub(crate) fn distinct_gradient_magnitudes(&self) -> Option<&[f64]> {
        self.g_distinct.as_deref()
    }
    /// The gradient-magnitude ranks (the scalar ranks where the scene has none: unread then).
    pub(crate) fn g_ranks(&self) -> &wgpu::Buffer {
        self.g_ranks.as_ref().unwrap_or(&self.ranks)
    }

    pub fn centre_in_world(&self) -> DVec3 {
        self.centre_in_world
    }
    pub fn num_tets(&self) -> usize {
        self.tets.len()
    }
    pub fn num_points(&self) -> usize {
        self.n_points
    }
}

/// The distinct values ascending, and each value's index among them.
/// A new scene id (a scene's, or a scene's after its scalar changed).
fn next_scene_id() -> u64 {
    static NEXT_ID: std::sync::atomic::AtomicU64 = std::sync::atomic::AtomicU64::new(1);
    NEXT_ID.fetch_add(1, std::sync::atomic::Ordering::Relaxed)
}

fn distinct_and_ranks(values: &[f64]) -> (Vec<f64>, Vec<u32>) {
    let mut distinct = values.to_vec();
    distinct.par_sort_unstable_by(f64::total_cmp);
    distinct.dedup();
    let ranks = values.par_iter().map(|s| distinct.partition_point(|d| d < s) as u32).collect();
    (distinct, ranks)
}

/// Usage of the scene's buffers.
const SCENE_USAGE: wgpu::BufferUsages = wgpu::BufferUsages::STORAGE.union(wgpu::BufferUsages::COPY_DST);

pub(crate) fn check_size(what: &'static str, bytes: u64, limit: u64) -> Result<(), GpuError> {
    if bytes > limit {
        return Err(GpuError::TooLarge { what, bytes, limit });
    }
    Ok(())
}

/// Tets sorted front to back by the depth of their centroids (the fast
/// approximate order; exact for none but simple meshes, as tet_render's
/// radix sort). Computed on the CPU with rayon in this increment.
pub fn centroid_order(scene: &GpuScene, camera: &Camera) -> Vec<u32> {
    let eye = (camera.eye_in_world() - scene.centre_in_world).as_vec3();
    let fwd = camera.forward().as_vec3();
    let mut keyed: Vec<(f32, u32)> = scene
        .tets
        .par_iter()
        .enumerate()
        .map(|(i, t)| {
            let mut c = glam::Vec3::ZERO;
            for &v in t {
                c += glam::Vec3::from(scene.pos_rel[v as usize]);
            }
            ((c * 0.25 - eye).dot(fwd), i as u32)
        })
        .collect();
    keyed.par_sort_unstable_by(|a, b| a.0.total_cmp(&b.0).then(a.1.cmp(&b.1)));
    keyed.into_iter().map(|(_, i)| i).collect()
}
