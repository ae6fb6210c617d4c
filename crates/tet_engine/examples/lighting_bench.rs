//! Lighting and shadows measured: the shadow field's cost against a
//! frame's, a camera move with the light fixed, and the errors of lit and
//! shadowed frames against the lit reference — the lighting's error (the
//! renderers against the reference that uses their shadow field) apart
//! from the shadow field's (that reference against exact shadow rays).
//!
//! `cargo run --release -p tet_engine --example lighting_bench -- B.tetb TF.json SIZE REF_SIZE [results.md]`
//!
//! TF.json is in scalar units, or normalized (then mapped onto the
//! bundle's scalar range); frames
//! are drawn at SIZE², with the default method (table3d) and the walker;
//! errors are measured at REF_SIZE² (the exact-shadow reference casts a
//! shadow ray at every quadrature node: keep it small). The light: one
//! directional light from the upper left front plus a dim headlight
//! (`TET_LIGHT=point`: a point light there instead, outside the box;
//! `TET_LIGHT=inside`: at the box's centre; `TET_LIGHT=beside`: 5% of the
//! box's diagonal outside it, that way). A
//! results file gets a markdown row appended, columns as in
//! [`HEADER`].

/// The columns of a results row (wall seconds, CPU/wall in brackets;
/// errors as RMSE / largest 8-bit difference, against the lit reference).
pub const HEADER: &str = "| bundle | frame / error size | unlit frame | lit frame (no shadows), camera moving | shadow field (CPU/wall of that frame), its memory | shadowed frame, camera moving, and the field's cost then | walker vs reference, unlit | headlight | lit + shadows vs the reference lit from the same field (lighting error) | that reference vs exact shadow rays (the field's error) | walker vs exact (both) | exact-shadow reference time |\n|---|---|---|---|---|---|---|---|---|---|---|---|";

use std::io::Write;
use std::time::Instant;

use tet_bundle::Bundle;
use tet_engine::{CpuFrameRenderer, FrameRenderer, FrameRequest, Look, ReferenceFrameRenderer};
use tet_preint::{Method, TransferFunction};
use tet_render::pipeline::process_cpu_seconds;
use tet_render::{diff, LightSet, LightSource, Lighting, ViewSpec};

fn main() -> anyhow::Result<()> {
    let args: Vec<String> = std::env::args().collect();
    if args.len() < 5 {
        anyhow::bail!("usage: lighting_bench B.tetb TF.json SIZE REF_SIZE [results.md]");
    }
    let bundle = Bundle::read(std::path::Path::new(&args[1]))?;
    let (size, ref_size): (u32, u32) = (args[3].parse()?, args[4].parse()?);
    let s = [bundle.meta.stats.scalar_min, bundle.meta.stats.scalar_max];
    let tf = TransferFunction::from_json(&std::fs::read_to_string(&args[2])?)?;
    let tf = if tf.normalized() { tf.denormalize(s[0], s[1])? } else { tf };
    // `TET_LIGHT=point`: a point light where the directional one comes
    // from, half a bounding-box diagonal outside the box (its deep shadow
    // map fans out from it).
    let place = std::env::var("TET_LIGHT").unwrap_or_default();
    let key = if ["point", "inside", "beside"].contains(&place.as_str()) {
        let (lo, hi) = (bundle.meta.stats.bounds_min, bundle.meta.stats.bounds_max);
        let diag = (0..3).map(|a| (hi[a] - lo[a]).powi(2)).sum::<f64>().sqrt();
        let dir = [0.6f64, -0.5, -0.62];
        let norm = dir.iter().map(|c| c * c).sum::<f64>().sqrt();
        let position: [f64; 3] = match place.as_str() {
            "inside" => std::array::from_fn(|a| 0.5 * (lo[a] + hi[a])),
            // From the box's centre along −dir to its surface, then 5% of
            // the diagonal further.
            "beside" => {
                let u: [f64; 3] = std::array::from_fn(|a| -dir[a] / norm);
                let to_face = (0..3)
                    .filter(|&a| u[a] != 0.0)
                    .map(|a| 0.5 * (hi[a] - lo[a]) / u[a].abs())
                    .fold(f64::INFINITY, f64::min);
                std::array::from_fn(|a| 0.5 * (lo[a] + hi[a]) + u[a] * (to_face + 0.05 * diag))
            }
            _ => std::array::from_fn(|a| 0.5 * (lo[a] + hi[a]) - dir[a] / norm * diag),
        };
        eprintln!("point light at {position:?}");
        LightSource::Point { position, intensity: 0.9 }
    } else {
        LightSource::Directional { direction: [0.6, -0.5, -0.62], intensity: 0.9 }
    };
    let lights = LightSet::new(&[key, LightSource::Headlight { intensity: 0.3 }])?;
    let lighting = Lighting { lights, shadows: true, ..Default::default() };
    let (lo, hi) = (bundle.meta.stats.bounds_min, bundle.meta.stats.bounds_max);
    let z_up = tet_render::camera::bundle_is_z_up(&bundle.meta);
    let view_at = |px: u32, azimuth: f64| -> anyhow::Result<ViewSpec> {
        Ok(ViewSpec::default_for(lo, hi, [px, px], z_up, None)?.orbit(azimuth, 20.0, 1.0))
    };
    let look = Look::bake(&bundle, Method::Table3d, tf.clone())?;
    let mut cpu = CpuFrameRenderer::new(&bundle)?;
    let lit = lighting.shading(None);
    let unlit = tet_render::Shading::default();
    let nothing = |_: usize, _: usize| {};

    // Frames at SIZE²: unlit, then lit + shadows (the field computed in the
    // first lit frame), then camera moves with the light fixed.
    let mut row = Vec::new();
    let frame = |shading, az: f64, cpu: &mut CpuFrameRenderer| -> anyhow::Result<(f64, f64, f64)> {
        let req = FrameRequest { shading, ..FrameRequest::new(view_at(size, az)?) };
        let (t, c) = (Instant::now(), process_cpu_seconds());
        cpu.render(&look, &req, &nothing)?;
        Ok((t.elapsed().as_secs_f64(), process_cpu_seconds() - c, cpu.shadow_seconds))
    };
    frame(unlit, 30.0, &mut cpu)?; // warm: walker links, cull mask, gradients
    let (unlit_s, unlit_cpu, _) = frame(unlit, 32.0, &mut cpu)?;
    let (first_s, first_cpu, field_s) = frame(lit, 34.0, &mut cpu)?;
    let field_bytes = cpu.renderer().scene().shadows().map_or(0, |f| f.memory_bytes());
    let (move_s, move_cpu, move_field) = frame(lit, 36.0, &mut cpu)?;
    let (move2_s, _, _) = frame(lit, 38.0, &mut cpu)?;
    let no_shadows = tet_render::Shading { shadows: false, ..lit };
    let (lit_s, lit_cpu, _) = frame(no_shadows, 40.0, &mut cpu)?;
    let (lit2_s, _, _) = frame(no_shadows, 42.0, &mut cpu)?;
    row.push(format!("{:.3} s ({:.2})", unlit_s, unlit_cpu / unlit_s));
    row.push(format!("{:.3}–{:.3} s ({:.2})", lit_s.min(lit2_s), lit_s.max(lit2_s), lit_cpu / lit_s));
    row.push(format!("{:.3} s ({:.2}), {:.1} MB", field_s, first_cpu / first_s, field_bytes as f64 / 1e6));
    row.push(format!(
        "{:.3}–{:.3} s ({:.2}), field {:.3} s",
        move_s.min(move2_s),
        move_s.max(move2_s),
        move_cpu / move_s,
        move_field
    ));

    // Errors at REF_SIZE².
    let view = view_at(ref_size, 34.0)?;
    let req = FrameRequest { shading: lit, ..FrameRequest::new(view.clone()) };
    let walker = cpu.render(&look, &req, &nothing)?.image;
    let mut reference = ReferenceFrameRenderer::new(&bundle)?;
    let t = Instant::now();
    let exact = reference.render(&Look::exact(tf.clone()), &req, &nothing)?.image;
    let exact_s = t.elapsed().as_secs_f64();
    reference.use_shadow_field(&tf, &lights)?;
    let with_field = reference.render(&Look::exact(tf.clone()), &req, &nothing)?.image;
    let headlight = FrameRequest { shading: Lighting::default().shading(None), ..FrameRequest::new(view.clone()) };
    let walker_head = cpu.render(&look, &headlight, &nothing)?.image;
    let ref_head = reference.render(&Look::exact(tf.clone()), &headlight, &nothing)?.image;
    let unlit_req = FrameRequest::new(view);
    let walker_plain = cpu.render(&look, &unlit_req, &nothing)?.image;
    let ref_plain = reference.render(&Look::exact(tf.clone()), &unlit_req, &nothing)?.image;
    let fmt = |d: tet_render::DiffStats| format!("{:.2e} / {:.1}", d.rmse, d.max_abs * 255.0);
    row.push(fmt(diff(&walker_plain, &ref_plain)?));
    row.push(fmt(diff(&walker_head, &ref_head)?));
    row.push(fmt(diff(&walker, &with_field)?));
    row.push(fmt(diff(&with_field, &exact)?));
    row.push(fmt(diff(&walker, &exact)?));
    row.push(format!("{exact_s:.1} s"));
    let name = std::path::Path::new(&args[1]).file_name().map(|n| n.to_string_lossy().into_owned()).unwrap_or_default();
    let light = if place.is_empty() { String::new() } else { format!(", point light ({place})") };
    let line =
        format!("| {name} ({} tets{light}) | {size}² / {ref_size}² | {} |", bundle.mesh.tets.len(), row.join(" | "));
    println!("{line}");
    if let Some(p) = args.get(5) {
        let fresh = !std::path::Path::new(p).exists();
        let mut f = std::fs::OpenOptions::new().create(true).append(true).open(p)?;
        if fresh {
            writeln!(f, "{HEADER}")?;
        }
        writeln!(f, "{line}")?;
    }
    Ok(())
}
