//! Lights and volumetric shadows: the lit reference against the unlit one
//! and against closed forms, the shadow field against analytic
//! transmittance, both CPU renderers against the lit reference, and bad
//! input (a light inside the mesh, a light along the view direction, zero
//! gradients, transmittance underflow).

mod common;

use common::{grid_mesh, tf};
use std::sync::Arc;
use tet_mesh::{build_adjacency, Adjacency, TetMesh};
use tet_preint::{ExactShader, TransferFunction};
use tet_render::{
    diff, Camera, CpuRenderer, Image, Light, LightSet, LightSource, LitReference, RasterOptions, ReferenceOptions,
    ReferenceRenderer, Renderer, Scene, Shading, ShadowMode, ViewSpec,
};

struct Case {
    mesh: TetMesh,
    adj: Adjacency,
    grads: Vec<[f64; 3]>,
}

/// A jittered 6³-cell grid with a smooth scalar and its least-squares
/// gradients.
fn case(n: usize, s: impl Fn([f64; 3]) -> f64) -> Case {
    let (points, tets, scalar) = grid_mesh(n, 0.2, [0.0; 3], 7, s);
    let adj = build_adjacency(&points, &tets).unwrap();
    let scene = Scene::new(&points, tets.clone(), scalar.clone()).unwrap().ensure_gradients().unwrap();
    let grads = scene.gradients().unwrap().to_vec();
    let mesh = TetMesh { points, tets: tets.into(), scalar_name: "s".into(), scalar, point_fields: Vec::new() };
    Case { mesh, adj, grads }
}

fn blob(p: [f64; 3]) -> f64 {
    let d2 = (p[0] - 0.5).powi(2) + (p[1] - 0.45).powi(2) + (p[2] - 0.55).powi(2);
    (-d2 / 0.08).exp()
}

fn smooth_tf() -> TransferFunction {
    tf(r#"{"color": [[0, 0.2, 0.4, 1], [0.5, 1, 0.8, 0.3], [1, 1, 0.2, 0.1]],
           "opacity": [[0, 0.0], [0.3, 1.0], [0.7, 3.0], [1, 4.0]], "unit_distance": 1}"#)
}

fn view(size: u32) -> ViewSpec {
    let mut v = ViewSpec::looking_at([0.5, 0.5, 4.0], [0.5, 0.5, 0.5], [0.0, 1.0, 0.0], [size, size]);
    v.view_angle = 22.0;
    v
}

fn lights(list: &[LightSource]) -> LightSet {
    LightSet::new(list).unwrap()
}

fn sun() -> LightSource {
    LightSource::Directional { direction: [-0.6, -0.3, -0.75], intensity: 1.0 }
}

fn shading(sources: LightSet, shadows: bool) -> Shading {
    // The scenes span [0,1]³ with scalars in [0, 1].
    let gradient_floor = Shading::gradient_floor_for([0.0, 1.0], [0.0; 3], [1.0; 3]);
    Shading { light: Some(Light::default()), silhouette: None, sources, shadows, gradient_floor }
}

fn reference_lit(c: &Case, tf: &TransferFunction, v: &ViewSpec, sh: Shading, mode: ShadowMode) -> Image {
    let r = ReferenceRenderer::new(&c.mesh, &c.adj).unwrap();
    let lit = LitReference::new(sh, &c.grads, mode);
    r.render_lit(&Camera::new(v).unwrap(), tf, &lit, &|_, _| {}).unwrap().0
}

fn cpu(c: &Case, tf: &TransferFunction, v: &ViewSpec, sh: Shading, kind: CpuRenderer) -> Image {
    let scene = Scene::new(&c.mesh.points, c.mesh.tets.clone(), c.mesh.scalar.clone())
        .unwrap()
        .with_gradients(c.grads.clone())
        .unwrap();
    let field = sh.wants_shadows().then(|| Arc::new(scene.compute_shadows(tf, &sh.sources, &|_, _| {}).unwrap()));
    let mut r = Renderer::new(scene);
    r.set_renderer(kind);
    r.set_shadows(field).unwrap();
    r.set_view(v).unwrap();
    r.set_shader(Arc::new(ExactShader::new(tf.clone())));
    r.set_raster_options(RasterOptions { shading: sh, ..Default::default() });
    r.render(&|_, _| {}).unwrap().0
}

#[test]
fn constant_lighting_integrates_to_the_unlit_reference() {
    // ka = 1, no diffuse or specular: D ≡ 1, S ≡ 0, and the quadrature must
    // reproduce the closed-form integral.
    let c = case(4, blob);
    let t = smooth_tf();
    let v = view(12);
    let flat = Shading {
        light: Some(Light { ambient: 1.0, diffuse: 0.0, specular: 0.0, shininess: 1.0 }),
        ..Default::default()
    };
    let lit = reference_lit(&c, &t, &v, flat, ShadowMode::Exact);
    let r = ReferenceRenderer::new(&c.mesh, &c.adj).unwrap();
    let (plain, _) = r.render(&Camera::new(&v).unwrap(), &t, &ReferenceOptions::default(), &|_, _| {}).unwrap();
    let d = diff(&lit, &plain).unwrap();
    assert!(d.max_abs < 1e-6, "{d:?}");
    assert!(plain.pixels().iter().any(|p| p[3] > 0.1));
}

#[test]
fn headlight_reference_matches_both_cpu_renderers() {
    let c = case(5, blob);
    let t = smooth_tf();
    let v = view(24);
    let sh = shading(LightSet::default(), false);
    let reference = reference_lit(&c, &t, &v, sh, ShadowMode::Exact);
    // Lighting at emission centroids, split where it varies, against the integral.
    assert_cpu_renderers_near(&c, &t, &v, sh, &reference, 2e-2, 4e-3);
}

/// Both CPU renderers within `max_abs` and `rmse` of `reference`.
fn assert_cpu_renderers_near(
    c: &Case,
    t: &TransferFunction,
    v: &ViewSpec,
    sh: Shading,
    reference: &Image,
    max_abs: f64,
    rmse: f64,
) {
    for kind in [CpuRenderer::Walk, CpuRenderer::Pt] {
        let d = diff(&cpu(c, t, v, sh, kind), reference).unwrap();
        assert!(d.max_abs < max_abs && d.rmse < rmse, "{kind:?}: {d:?}");
    }
}

#[test]
fn shadow_field_equals_the_closed_form_transmittance() {
    // Constant extinction ρ = 2 in the unit cube, light straight down:
    // a vertex at height z sees exp(−2 (1 − z)).
    let (points, tets, scalar) = grid_mesh(4, 0.0, [0.0; 3], 3, |_| 0.5);
    let scene = Scene::new(&points, tets, scalar).unwrap();
    let t = tf(r#"{"color": [[0, 1, 1, 1]], "opacity": [[0, 2]], "unit_distance": 1}"#);
    let down = lights(&[LightSource::Directional { direction: [0.0, 0.0, -1.0], intensity: 1.0 }]);
    let f = scene.compute_shadows(&t, &down, &|_, _| {}).unwrap();
    assert_eq!(f.stats().walk_failures, 0);
    // A directional light's shadow is a deep shadow map, exact here (the
    // depth is linear along the light and constant across it) at vertices
    // and in between.
    let mut rng = common::Rng(11);
    let inner = (0..200).map(|_| [rng.range(0.0, 1.0), rng.range(0.0, 1.0), rng.range(0.0, 1.0)]);
    for p in points.iter().copied().chain(inner) {
        let got = f.depth_at(0, glam::DVec3::from(p));
        let want = 2.0 * (1.0 - p[2]);
        assert!((got - want).abs() < 1e-5, "at {p:?}: {got} vs {want}");
    }
    // A point light inside the mesh: a cube of maps around it, each ray
    // walked from the light (ρ = 2: a point at distance r sees 2r, exact
    // along each ray; between rays the interpolation's error).
    let inside = lights(&[LightSource::Point { position: [0.5, 0.5, 0.5], intensity: 1.0 }]);
    let f = scene.compute_shadows(&t, &inside, &|_, _| {}).unwrap();
    assert!(f.has_cube_lights() && f.has_maps());
    let mut rng = common::Rng(13);
    let inner = (0..300).map(|_| [rng.range(0.0, 1.0), rng.range(0.0, 1.0), rng.range(0.0, 1.0)]);
    for p in points.iter().copied().chain(inner) {
        let dist = ((p[0] - 0.5).powi(2) + (p[1] - 0.5).powi(2) + (p[2] - 0.5).powi(2)).sqrt();
        let got = f.depth_at(0, glam::DVec3::from(p));
        assert!((got - 2.0 * dist).abs() < 2e-4, "at {p:?}: {got} vs {}", 2.0 * dist);
    }
    assert_eq!(f.depth_at(0, glam::DVec3::splat(0.5)), 0.0, "the light's own point");
    // Huge extinction: transmittance underflows to 0, never NaN. The map
    // is lit at the top and dark from the first sample below it.
    let dense = tf(r#"{"color": [[0, 1, 1, 1]], "opacity": [[0, 1e300]], "unit_distance": 1}"#);
    let f = scene.compute_shadows(&dense, &down, &|_, _| {}).unwrap();
    for p in &points {
        let d = f.depth_at(0, glam::DVec3::from(*p));
        assert!(d.is_finite() && if p[2] == 1.0 { d == 0.0 } else { d >= tet_render::shadow::MAP_OPAQUE_DEPTH * 0.99 });
    }
    // A point light far above, outside the box: a deep map of rays fanning
    // out from it. With ρ = 2 a point p sees 2 × the length of the light's
    // ray inside the cube, entering through the top face. (Within a ray
    // spacing of the cube's outline seen from the light, the map mixes in
    // rays that miss the cube, as any map does: points are taken inside.)
    let above = lights(&[LightSource::Point { position: [0.5, 0.5, 50.0], intensity: 1.0 }]);
    let f = scene.compute_shadows(&t, &above, &|_, _| {}).unwrap();
    assert!(f.has_maps());
    let mut rng = common::Rng(12);
    let inner = (0..200).map(|_| [rng.range(0.02, 0.98), rng.range(0.02, 0.98), rng.range(0.0, 1.0)]);
    let away_from_outline = points.iter().copied().filter(|p| (0..2).all(|a| p[a] > 0.0 && p[a] < 1.0));
    for p in away_from_outline.chain(inner) {
        let got = f.depth_at(0, glam::DVec3::from(p));
        let dist = ((p[0] - 0.5).powi(2) + (p[1] - 0.5).powi(2) + (p[2] - 50.0).powi(2)).sqrt();
        let want = 2.0 * dist * (1.0 - p[2]) / (50.0 - p[2]);
        assert!((got - want).abs() < 1e-4, "at {p:?}: {got} vs {want}");
    }
    // Huge extinction there: lit at the top, as dark as the map records
    // below, never NaN.
    let f = scene.compute_shadows(&dense, &above, &|_, _| {}).unwrap();
    for p in points.iter().filter(|p| (0..2).all(|a| p[a] > 0.0 && p[a] < 1.0)) {
        let d = f.depth_at(0, glam::DVec3::from(*p));
        assert!(d.is_finite() && if p[2] == 1.0 { d == 0.0 } else { d >= tet_render::shadow::MAP_OPAQUE_DEPTH * 0.99 });
    }
    // A point light beside the box (some of the mesh not in front of it
    // along the way to the centre): a cube of maps too. Under huge
    // extinction the face towards the light is lit where the light looks
    // at it head-on, everything deeper is as dark as the map records, and
    // nothing is NaN. (Where the light grazes the face, within a ray
    // spacing the map mixes rays that have entered with rays that have
    // not, as any shadow map does at an outline.)
    let beside = lights(&[LightSource::Point { position: [0.5, 0.5, 1.05], intensity: 1.0 }]);
    let f = scene.compute_shadows(&dense, &beside, &|_, _| {}).unwrap();
    assert!(f.has_cube_lights());
    for p in &points {
        let d = f.depth_at(0, glam::DVec3::from(*p));
        assert!(d.is_finite() && (0.0..=tet_render::shadow::MAP_OPAQUE_DEPTH).contains(&d), "at {p:?}: {d}");
        if p[2] < 0.9 {
            assert!(d >= tet_render::shadow::MAP_OPAQUE_DEPTH * 0.99, "at {p:?}: {d}");
        }
    }
    for p in [[0.5, 0.5, 1.0], [0.52, 0.49, 1.0]] {
        assert_eq!(f.depth_at(0, glam::DVec3::from(p)), 0.0, "at {p:?}");
    }
}

#[test]
fn shadowed_renderers_match_the_reference_with_their_field_and_with_exact_rays() {
    let c = case(5, blob);
    let t = smooth_tf();
    let v = view(20);
    let sh = shading(lights(&[sun(), LightSource::Point { position: [1.5, 1.2, 1.4], intensity: 0.5 }]), true);
    let scene = Scene::new(&c.mesh.points, c.mesh.tets.clone(), c.mesh.scalar.clone()).unwrap();
    let field = scene.compute_shadows(&t, &sh.sources, &|_, _| {}).unwrap();
    let with_field = reference_lit(&c, &t, &v, sh, ShadowMode::Field(&field));
    let exact = reference_lit(&c, &t, &v, sh, ShadowMode::Exact);
    let unshadowed = reference_lit(&c, &t, &v, Shading { shadows: false, ..sh }, ShadowMode::Exact);
    // Shadows darken (never brighten), and the field is close to exact rays.
    let dark = diff(&exact, &unshadowed).unwrap();
    assert!(dark.max_abs > 0.02, "shadows change the picture: {dark:?}");
    for (a, b) in exact.pixels().iter().zip(unshadowed.pixels()) {
        assert!(a[0] <= b[0] + 1e-6 && a[3] == b[3], "{a:?} vs {b:?}");
    }
    let field_err = diff(&with_field, &exact).unwrap();
    // Linear interpolation of an exponential over 5 cells.
    assert!(field_err.max_abs < 3e-2 && field_err.rmse < 4e-3, "shadow field vs exact rays: {field_err:?}");
    assert_cpu_renderers_near(&c, &t, &v, sh, &with_field, 2e-2, 4e-3);
}

#[test]
fn degenerate_lights_and_gradients_give_finite_images() {
    let c = case(4, blob);
    let t = smooth_tf();
    let v = view(12);
    // A directional light shining along the view direction (from behind
    // the eye) and one shining at the eye; a point light inside the mesh
    // and one exactly at a vertex.
    let vertex = c.mesh.points[40];
    let sh = shading(
        lights(&[
            LightSource::Directional { direction: [0.0, 0.0, -1.0], intensity: 1.0 },
            LightSource::Directional { direction: [0.0, 0.0, 1.0], intensity: 1.0 },
            LightSource::Point { position: [0.5, 0.5, 0.5], intensity: 1.0 },
            LightSource::Point { position: vertex, intensity: 1.0 },
        ]),
        true,
    );
    let reference = reference_lit(&c, &t, &v, sh, ShadowMode::Exact);
    common::assert_finite(&reference);
    for kind in [CpuRenderer::Walk, CpuRenderer::Pt] {
        let img = cpu(&c, &t, &v, sh, kind);
        common::assert_finite(&img);
        assert!(diff(&img, &reference).unwrap().rmse < 1e-2, "{kind:?}");
    }
    // Zero gradients: the isotropic medium. Under the default headlight
    // that is the unlit picture; under the lights above, the renderers
    // still match the reference.
    let flat = Case { grads: vec![[0.0; 3]; c.grads.len()], ..case(4, blob) };
    let headlight = shading(LightSet::default(), false);
    let lit = reference_lit(&flat, &t, &v, headlight, ShadowMode::Exact);
    let r = ReferenceRenderer::new(&flat.mesh, &flat.adj).unwrap();
    let (plain, _) = r.render(&Camera::new(&v).unwrap(), &t, &ReferenceOptions::default(), &|_, _| {}).unwrap();
    assert!(diff(&lit, &plain).unwrap().max_abs < 1e-6);
    let img = cpu(&flat, &t, &v, headlight, CpuRenderer::Walk);
    assert!(diff(&img, &plain).unwrap().max_abs < 1e-3);
    let lit = reference_lit(&flat, &t, &v, sh, ShadowMode::Exact);
    common::assert_finite(&lit);
    let img = cpu(&flat, &t, &v, sh, CpuRenderer::Walk);
    assert!(diff(&img, &lit).unwrap().rmse < 1e-2);
    // Huge extinction: light gets no further than a skin far thinner than
    // a cell. The reference integrates that skin; the field's maps see
    // it to their knots' resolution. Both finite, opaque where the mesh is, and
    // no brighter than every light at full strength.
    let dense = tf(r#"{"color": [[0, 1, 1, 1]], "opacity": [[0, 1e30]], "unit_distance": 1}"#);
    let reference = reference_lit(&c, &dense, &v, sh, ShadowMode::Exact);
    let brightest = 0.3 + 4.0 * 0.7 + 4.0 * 0.2;
    for img in [reference.clone(), cpu(&c, &dense, &v, sh, CpuRenderer::Walk), cpu(&c, &dense, &v, sh, CpuRenderer::Pt)]
    {
        common::assert_finite(&img);
        for (p, r) in img.pixels().iter().zip(reference.pixels()) {
            assert!(p[3] == r[3] && p[..3].iter().all(|&x| (0.0..=brightest).contains(&x)), "{p:?} vs {r:?}");
        }
    }
}

#[test]
fn shadows_without_a_field_or_for_other_lights_are_refused() {
    let c = case(3, blob);
    let t = smooth_tf();
    let scene = Scene::new(&c.mesh.points, c.mesh.tets.clone(), c.mesh.scalar.clone())
        .unwrap()
        .with_gradients(c.grads.clone())
        .unwrap();
    let sh = shading(lights(&[sun()]), true);
    let mut r = Renderer::new(scene.clone());
    r.set_view(&view(8)).unwrap();
    r.set_shader(Arc::new(ExactShader::new(t.clone())));
    r.set_raster_options(RasterOptions { shading: sh, ..Default::default() });
    assert!(r.render(&|_, _| {}).unwrap_err().to_string().contains("shadow field"));
    let other =
        scene.compute_shadows(&t, &lights(&[LightSource::Point { position: [2.0; 3], intensity: 1.0 }]), &|_, _| {});
    r.set_shadows(Some(Arc::new(other.unwrap()))).unwrap();
    assert!(r.render(&|_, _| {}).unwrap_err().to_string().contains("other lights"));
    // A field of another mesh.
    let small = case(2, blob);
    let small_scene = Scene::new(&small.mesh.points, small.mesh.tets.clone(), small.mesh.scalar.clone()).unwrap();
    let f = small_scene.compute_shadows(&t, &sh.sources, &|_, _| {}).unwrap();
    assert!(r.set_shadows(Some(Arc::new(f))).is_err());
}

#[test]
fn a_thin_dense_sheet_shadows_what_lies_below_it_without_acne() {
    // A sheet one cell thick about z = 0.5 (scalar 1 there, 0 elsewhere,
    // linear between) in a faint medium, lit from above: its top is lit,
    // the medium below it is in its shadow, and the shadowed renderers
    // match exact shadow rays with no speckle on the sheet itself.
    let c = case(6, |p| (1.0 - (p[2] - 0.5).abs() * 6.0).max(0.0));
    let t = tf(
        r#"{"color": [[0, 0.3, 0.6, 1], [1, 1, 0.8, 0.4]], "opacity": [[0, 0.4], [0.7, 0.4], [1, 30]], "unit_distance": 1}"#,
    );
    let mut v = ViewSpec::looking_at([2.6, 1.2, 1.1], [0.5, 0.5, 0.5], [0.0, 0.0, 1.0], [28, 28]);
    v.view_angle = 30.0;
    let sh = shading(lights(&[LightSource::Directional { direction: [0.1, 0.2, -1.0], intensity: 1.0 }]), true);
    let exact = reference_lit(&c, &t, &v, sh, ShadowMode::Exact);
    let unshadowed = reference_lit(&c, &t, &v, Shading { shadows: false, ..sh }, ShadowMode::Exact);
    assert!(diff(&exact, &unshadowed).unwrap().max_abs > 0.05, "the sheet casts a shadow");
    assert_cpu_renderers_near(&c, &t, &v, sh, &exact, 8.0 / 255.0, 2e-3);
}

/// Fuzz finding (`fuzz/fuzz_targets/shadow.rs`): four narrow TF peaks of
/// extinction 10³ over the Delaunay tets of 9 lattice points, lit by a
/// directional light, made a map of 747 MB (the fuzzer's process 1.3 GB):
/// opaque layers oblique to the light are shadow edges at every depth, so
/// every finer grid was walked nearly everywhere, and each ray kept knots
/// down to transmittance 1e-20. Maps now end rays at `MAP_OPAQUE_DEPTH`
/// and keep finer grids within `LEVELS_BUDGET_BYTES`; the field stays
/// finite, lit where the light enters and dark behind the peaks.
#[test]
fn opaque_peaks_over_a_tiny_mesh_keep_the_map_within_its_budget() {
    use tet_delaunay::{tetrahedralize_points, DelaunayOptions};
    use tet_render::shadow::{LEVELS_BUDGET_BYTES, MAP_OPAQUE_DEPTH};
    let points: Vec<[f64; 3]> =
        [[0, 0, 0], [2, 0, 0], [0, 2, 0], [2, 2, 0], [0, 0, 2], [2, 0, 2], [0, 2, 0], [2, 2, 2], [3, 2, 1]]
            .iter()
            .map(|p| p.map(|x| x as f64))
            .collect();
    let scalar = vec![0.3, 1.0, 0.6, 0.2, 0.9, 0.5, 0.1, 0.8, 0.4];
    let d = tetrahedralize_points(&points, &DelaunayOptions::default()).unwrap();
    let scene = Scene::new(&points, d.tets, scalar).unwrap();
    let (floor, top) = (0.0627, 1000.0);
    let mut opacity = vec![[0.0, floor]];
    for at in [0.1252, 0.3752, 0.6252, 0.8752] {
        opacity.extend([[at - 0.0078, floor], [at, top], [at + 0.0078, floor]]);
    }
    opacity.push([1.0, floor]);
    let opacity: Vec<String> = opacity.iter().map(|[x, y]| format!("[{x}, {y}]")).collect();
    let t = tf(&format!(
        r#"{{"color": [[0, 1, 0.3, 0.1], [1, 0.3, 0.4, 1]], "opacity": [{}], "unit_distance": 1}}"#,
        opacity.join(", ")
    ));
    let light = lights(&[LightSource::Directional { direction: [-0.624, -0.498, -0.710], intensity: 1.0 }]);
    let f = scene.compute_shadows(&t, &light, &|_, _| {}).unwrap();
    // Measured: 747 MB with rays to e^−46 and no budget, 130 MB with the
    // budget alone, 72.8 MB with both (the third finer grid given up).
    assert!(f.memory_bytes() <= LEVELS_BUDGET_BYTES, "{} bytes", f.memory_bytes());
    let mut rng = common::Rng(3);
    let (mut lit, mut dark) = (0, 0);
    for _ in 0..2000 {
        let p = glam::DVec3::new(rng.range(0.0, 3.0), rng.range(0.0, 2.0), rng.range(0.0, 2.0));
        let depth = f.depth_at(0, p);
        assert!((0.0..=MAP_OPAQUE_DEPTH).contains(&depth), "at {p}: {depth}");
        lit += (depth < 1.0) as usize;
        dark += (depth >= MAP_OPAQUE_DEPTH * 0.99) as usize;
    }
    assert!(lit > 100 && dark > 100, "{lit} lit, {dark} dark of 2000");
}
