//! Test meshes, an exact visibility order (MPVO over face adjacency, for
//! convex meshes) and a CPU reference that shades exact ray segments.
#![allow(dead_code)]

use glam::DVec3;
use std::sync::Arc;
use tet_gpu::{GpuContext, GpuRenderer, GpuScene, GpuShader};
use tet_mesh::split::{structured_grid_tets, structured_points};
use tet_mesh::SplitMode;
use tet_preint::{ScalarAxis, Segment, SegmentShader, Table3d, Table3dParams, TableDomain, TransferFunction};
use tet_render::{diff, Camera, DiffStats, Image};

/// The GPU, or `None` with a printed reason; with `TETKIT_REQUIRE_GPU=1` a
/// missing adapter fails the test instead (`make test-gpu`).
pub fn gpu() -> Option<GpuContext> {
    match GpuContext::new_headless() {
        Ok(ctx) => {
            eprintln!("GPU adapter: {}", ctx.describe());
            Some(ctx)
        }
        Err(e) => {
            if tet_gpu::gpu_required() {
                panic!("TETKIT_REQUIRE_GPU=1 but: {e}");
            }
            eprintln!("skipped: {e}");
            None
        }
    }
}

/// The GPU ([`gpu`]) with `mesh` uploaded and a renderer: what the image
/// tests start from; `None` where [`gpu`] skips.
pub fn gpu_with_scene(mesh: &Mesh) -> Option<(GpuContext, GpuScene, GpuRenderer)> {
    let ctx = gpu()?;
    let scene = mesh.gpu_scene(&ctx);
    let renderer = GpuRenderer::new(&ctx).unwrap();
    Some((ctx, scene, renderer))
}

/// tet_render's renderer of `scene` on its projected-tetrahedra path: the
/// GPU draws projected tetrahedra, so that path is its reference.
pub fn cpu_pt_renderer(scene: tet_render::Scene) -> tet_render::Renderer {
    let mut cpu = tet_render::Renderer::new(scene);
    cpu.set_renderer(tet_render::CpuRenderer::Pt);
    cpu
}

/// The CPU image of `cpu`'s current view and shader, and the visibility
/// order it drew in (for the GPU to draw in the same order).
pub fn cpu_image_and_order(cpu: &mut tet_render::Renderer) -> (Image, Vec<u32>) {
    let (image, _) = cpu.render(&|_, _| {}).unwrap();
    let order = cpu.order().unwrap().tets.clone();
    (image, order)
}

/// The GPU image of `scene` drawn with `shaders.0` in the order in which
/// the CPU PT renderer `cpu` (at its current view) draws with `shaders.1`,
/// that CPU image, and the order.
pub fn gpu_and_cpu_pt_images(
    ctx: &GpuContext,
    renderer: &GpuRenderer,
    scene: &GpuScene,
    cam: &Camera,
    cpu: &mut tet_render::Renderer,
    shaders: (&GpuShader, &Arc<dyn SegmentShader>),
) -> (Image, Image, Vec<u32>) {
    cpu.set_shader(shaders.1.clone());
    let (want, order) = cpu_image_and_order(cpu);
    let got = renderer.render(ctx, scene, cam, &order, shaders.0).unwrap().image;
    (got, want, order)
}

/// Positional argument `i` of an example's `args`, parsed, or `default`
/// where it is absent.
pub fn arg_or<T: std::str::FromStr>(args: &[String], i: usize, default: T) -> Result<T, T::Err> {
    Ok(args.get(i).map(|s| s.parse()).transpose()?.unwrap_or(default))
}

/// An example's first three arguments, CELLS SIZE FRAMES (grid cells a
/// side, image size, frames of at least `min_frames`), each defaulting to
/// `defaults`'.
pub fn cells_size_frames(
    args: &[String],
    defaults: (usize, u32, usize),
    min_frames: usize,
) -> Result<(usize, u32, usize), Box<dyn std::error::Error>> {
    let cells = arg_or(args, 1, defaults.0)?;
    let size = arg_or(args, 2, defaults.1)?;
    let frames = arg_or(args, 3, defaults.2)?.max(min_frames);
    Ok((cells, size, frames))
}

/// The transfer function the image tests render with.
pub fn tf() -> TransferFunction {
    TransferFunction::from_json(
        r#"{"color": [[0, 0.1, 0.2, 1], [0.5, 1, 0.8, 0.1], [1, 1, 0.1, 0.1]],
            "opacity": [[0, 0.5], [0.4, 4], [0.6, 1], [1, 8]], "unit_distance": 1}"#,
    )
    .unwrap()
}

/// A 64 × 64 table of [`tf`] over `mesh`'s cells, on scalar axis `s_axis`.
pub fn table_on_axis(mesh: &Mesh, s_axis: ScalarAxis) -> Table3d {
    let (max_ds, len) = mesh.cell_limits();
    let domain = TableDomain::new(0.0, 1.0, max_ds, len).unwrap();
    let t = Table3d::build(&tf(), &domain, &Table3dParams { n_s: 64, n_l: 64, s_axis, ..Default::default() }).unwrap();
    assert_eq!(t.is_uniform_axis(), s_axis == ScalarAxis::Uniform);
    t
}

/// Prints how far a GPU image is from the CPU one (and how many pixels the
/// CPU one covers, which must be some).
pub fn report(what: &str, gpu: &Image, cpu: &Image) -> DiffStats {
    let d = diff(gpu, cpu).unwrap();
    let covered = cpu.pixels().iter().filter(|p| p[3] > 0.0).count();
    eprintln!(
        "{what}: mean |Δ| = {:.3e} ({:.3}/255), max |Δ| = {:.3e} ({:.3}/255) at {:?}, rmse {:.3e}; {} covered pixels",
        d.mean_abs,
        d.mean_abs * 255.0,
        d.max_abs,
        d.max_abs * 255.0,
        d.max_at,
        d.rmse,
        covered
    );
    assert!(covered > 0, "{what}: the reference image is empty");
    d
}

/// [`report`]s and asserts that two images agree within the image tests'
/// tolerance: mean |Δ| ≤ 0.5/255 and max |Δ| ≤ 2/255.
pub fn assert_close_images(what: &str, got: &Image, want: &Image) -> DiffStats {
    let d = report(what, got, want);
    assert!(d.mean_abs <= 0.5 / 255.0 && d.max_abs <= 2.0 / 255.0, "{what}: {d:?}");
    d
}

pub struct Mesh {
    pub points: Vec<[f64; 3]>,
    pub tets: Vec<[u32; 4]>,
    pub scalar: Vec<f64>,
}

/// One positively oriented tet.
pub fn single_tet() -> Mesh {
    Mesh {
        points: vec![[0.0, 0.0, 0.0], [1.0, 0.1, 0.0], [0.2, 1.0, 0.1], [0.1, 0.3, 0.9]],
        tets: vec![[0, 1, 2, 3]],
        scalar: vec![0.1, 0.9, 0.5, 0.3],
    }
}

/// n³ cells over [0, 1]³, each split into 5 tets (tet_mesh's alternating
/// pattern), with a smooth scalar in [0, 1].
pub fn grid(n: usize) -> Mesh {
    grid_cells([n; 3])
}

/// As [`grid`] with `n[0] × n[1] × n[2]` cells over [0, 1]³.
#[allow(dead_code)] // not every test binary uses it
pub fn grid_cells(n: [usize; 3]) -> Mesh {
    let points = structured_points(n.map(|c| c + 1), |[i, j, k]| {
        [i as f64 / n[0] as f64, j as f64 / n[1] as f64, k as f64 / n[2] as f64]
    });
    let scalar = points
        .iter()
        .map(|p| {
            let r2 = (p[0] - 0.5).powi(2) + (p[1] - 0.5).powi(2) + (p[2] - 0.5).powi(2);
            (0.5 + 0.45 * (6.0 * r2).cos() * (3.0 * p[0] + 1.0).sin()).clamp(0.0, 1.0)
        })
        .collect();
    Mesh { points, tets: structured_grid_tets(n, SplitMode::Five), scalar }
}

impl Mesh {
    /// This mesh on the GPU (without gradient magnitudes).
    pub fn gpu_scene(&self, ctx: &GpuContext) -> GpuScene {
        GpuScene::new(ctx, &self.points, &self.tets, &self.scalar).unwrap()
    }

    /// This mesh as a tet_render scene.
    pub fn cpu_scene(&self) -> tet_render::Scene {
        tet_render::Scene::new(&self.points, self.tets.clone(), self.scalar.clone()).unwrap()
    }

    pub fn bounds(&self) -> ([f64; 3], [f64; 3]) {
        tet_mesh::stats::bounds(&self.points)
    }

    /// (largest per-tet scalar range, largest edge length).
    pub fn cell_limits(&self) -> (f64, f64) {
        let mut ds: f64 = 0.0;
        let mut len: f64 = 0.0;
        for t in &self.tets {
            let s = t.map(|v| self.scalar[v as usize]);
            let (mn, mx) = s.iter().fold((f64::INFINITY, f64::NEG_INFINITY), |(a, b), &x| (a.min(x), b.max(x)));
            ds = ds.max(mx - mn);
            for i in 0..4 {
                for j in i + 1..4 {
                    let d = DVec3::from(self.points[t[i] as usize]) - DVec3::from(self.points[t[j] as usize]);
                    len = len.max(d.length());
                }
            }
        }
        (ds, len)
    }

    fn p(&self, v: u32) -> DVec3 {
        DVec3::from(self.points[v as usize])
    }

    /// Ray ∩ tet t as (t_in, t_out, s_in, s_out), exact in f64.
    fn segment(&self, t: usize, o: DVec3, d: DVec3) -> Option<(f64, f64, f64, f64)> {
        let tet = self.tets[t];
        let (mut t_in, mut t_out) = (f64::NEG_INFINITY, f64::INFINITY);
        for fv in tet_mesh::FACE_OUTWARD {
            let (a, b, c) = (self.p(tet[fv[0]]), self.p(tet[fv[1]]), self.p(tet[fv[2]]));
            let n = (b - a).cross(c - a);
            let denom = n.dot(d);
            let num = n.dot(a - o);
            if denom < 0.0 {
                t_in = t_in.max(num / denom);
            } else if denom > 0.0 {
                t_out = t_out.min(num / denom);
            } else if num < 0.0 {
                return None;
            }
        }
        // A camera inside the mesh sees only what is in front of the eye.
        let t_in = t_in.max(0.0);
        if t_out.partial_cmp(&t_in) != Some(std::cmp::Ordering::Greater) {
            return None;
        }
        let s_at = |x: DVec3| self.scalar_at(t, x);
        Some((t_in, t_out, s_at(o + d * t_in), s_at(o + d * t_out)))
    }

    fn scalar_at(&self, t: usize, x: DVec3) -> f64 {
        let tet = self.tets[t];
        let p = tet.map(|v| self.p(v));
        let s = tet.map(|v| self.scalar[v as usize]);
        let (e1, e2, e3) = (p[1] - p[0], p[2] - p[0], p[3] - p[0]);
        let det = e1.dot(e2.cross(e3));
        let r = x - p[0];
        let b1 = r.dot(e2.cross(e3)) / det;
        let b2 = e1.dot(r.cross(e3)) / det;
        let b3 = e1.dot(e2.cross(r)) / det;
        s[0] + b1 * (s[1] - s[0]) + b2 * (s[2] - s[0]) + b3 * (s[3] - s[0])
    }

    /// CPU reference: per pixel centre, the exact segments of the ray
    /// through every tet, sorted by entry and composited front to back in
    /// f32 with `shader` (what tet_render's rasterizer does per fragment).
    pub fn reference(&self, camera: &Camera, shader: &dyn SegmentShader) -> Image {
        let (w, h) = (camera.width(), camera.height());
        let mut px = vec![[0.0f32; 4]; (w * h) as usize];
        for y in 0..h {
            for x in 0..w {
                let (o, d) = camera.ray(x as f64 + 0.5, y as f64 + 0.5);
                let mut segs: Vec<(f64, f64, f64, f64)> =
                    (0..self.tets.len()).filter_map(|t| self.segment(t, o, d)).collect();
                segs.sort_by(|a, b| a.0.total_cmp(&b.0));
                let acc = &mut px[(y * w + x) as usize];
                for (t0, t1, s0, s1) in segs {
                    let c = shader.shade(&Segment {
                        s_front: s0 as f32,
                        s_back: s1 as f32,
                        len_world: (t1 - t0) as f32,
                        ..Default::default()
                    });
                    let tr = 1.0 - acc[3];
                    for ch in 0..4 {
                        acc[ch] += tr * c[ch];
                    }
                }
            }
        }
        Image::from_pixels(w, h, px).unwrap()
    }

    /// MPVO over face adjacency: exact front-to-back order for a convex
    /// mesh (a tet comes after every neighbour across its front faces).
    pub fn mpvo_order(&self, camera: &Camera) -> Vec<u32> {
        let adj = tet_mesh::build_adjacency(&self.points, &self.tets).unwrap();
        let eye = camera.eye_in_world();
        let n = self.tets.len();
        let mut indeg = vec![0u32; n];
        let mut side = vec![[0i8; 4]; n];
        for (t, tet) in self.tets.iter().enumerate() {
            for (f, fv) in tet_mesh::FACE_OUTWARD.iter().enumerate() {
                let (a, b, c) = (self.p(tet[fv[0]]), self.p(tet[fv[1]]), self.p(tet[fv[2]]));
                // Parallel projection: the eye is at infinity against the view direction.
                let to_eye = if camera.is_parallel() { -camera.forward() } else { eye - a };
                let v = (b - a).cross(c - a).dot(to_eye);
                side[t][f] = if v > 0.0 {
                    1
                } else if v < 0.0 {
                    -1
                } else {
                    0
                };
                if v > 0.0 && adj.neighbors[t][f] != tet_mesh::NO_NEIGHBOR {
                    indeg[t] += 1;
                }
            }
        }
        let mut queue: std::collections::VecDeque<u32> = (0..n as u32).filter(|&t| indeg[t as usize] == 0).collect();
        let mut order = Vec::with_capacity(n);
        while let Some(t) = queue.pop_front() {
            order.push(t);
            for (&nb, &sd) in adj.neighbors[t as usize].iter().zip(&side[t as usize]) {
                if sd < 0 && nb != tet_mesh::NO_NEIGHBOR {
                    indeg[nb as usize] -= 1;
                    if indeg[nb as usize] == 0 {
                        queue.push_back(nb);
                    }
                }
            }
        }
        assert_eq!(order.len(), n, "visibility cycle in a test mesh");
        order
    }
}
