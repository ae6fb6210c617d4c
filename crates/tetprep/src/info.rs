//! `tetprep info` and `tetprep export`.

use anyhow::Context;
use serde_json::{json, Value};
use std::fmt::Write as _;
use std::path::Path;
use tet_bundle::{Bundle, FORMAT_VERSION};
use tet_cli::{ExitKind, KindExt};
use tet_mesh::Field;

pub fn run(path: &Path, as_json: bool) -> anyhow::Result<()> {
    if let Some(manifest) = crate::partition::manifest_path(path) {
        return crate::partition::info(&manifest, as_json);
    }
    let bundle = Bundle::read(path)?;
    if as_json {
        let mut v = summary_json(&bundle);
        v["bundle"] = json!(path.display().to_string());
        println!("{}", serde_json::to_string_pretty(&v)?);
    } else {
        println!("bundle      {} (format v{FORMAT_VERSION}, written by {})", path.display(), bundle.meta.writer);
        print!("{}", summary_text(&bundle));
    }
    Ok(())
}

pub fn export(path: &Path, output: &Path) -> anyhow::Result<()> {
    let bundle = Bundle::read(path)?;
    let mesh = &bundle.mesh;
    let mut fields = vec![Field::new(mesh.scalar_name.clone(), 1, mesh.scalar.clone())];
    fields.extend(mesh.point_fields.iter().filter(|f| f.name != mesh.scalar_name).cloned());
    if let Some(g) = bundle.analysis.as_ref().and_then(|a| a.gradients.as_ref()) {
        let name = format!("{}_gradient", mesh.scalar_name);
        fields.push(Field::new(name.clone(), 3, g.per_point.as_flattened().to_vec()));
        let mag = g.per_point.iter().map(|v| (v[0] * v[0] + v[1] * v[1] + v[2] * v[2]).sqrt()).collect();
        fields.push(Field::new(format!("{name}_magnitude"), 1, mag));
    }
    let file = std::fs::File::create(output)
        .with_context(|| format!("cannot create {}", output.display()))
        .kind(ExitKind::Output)?;
    tet_io::vtk_xml::write_vtu(std::io::BufWriter::new(file), &mesh.points, &mesh.tets, &fields, &[])
        .with_context(|| format!("writing {} failed", output.display()))
        .kind(ExitKind::Output)?;
    println!(
        "wrote {} ({} points, {} tets, {} point fields)",
        output.display(),
        mesh.points.len(),
        mesh.tets.len(),
        fields.len()
    );
    Ok(())
}

/// The JSON summary shared by `info --json` and `convert --json`.
pub fn summary_json(b: &Bundle) -> Value {
    let mut v = summary_json_mesh(b);
    if let (Value::Object(m), Value::Object(a)) = (&mut v, crate::analysis::info_json(b)) {
        m.extend(a);
    }
    v
}

fn summary_json_mesh(b: &Bundle) -> Value {
    let s = &b.meta.stats;
    json!({
        "format_version": FORMAT_VERSION,
        "points": b.mesh.points.len(),
        "tets": b.mesh.tets.len(),
        "total_volume": s.total_volume,
        "min_tet_volume": s.tet_volume.min,
        "tet_volume": { "min": s.tet_volume.min, "median": s.tet_volume.median, "max": s.tet_volume.max },
        "edge_length": { "min": s.edge_length.min, "median": s.edge_length.median, "max": s.edge_length.max },
        "max_cell_diameter": s.max_cell_diameter,
        "bounds": { "min": s.bounds_min, "max": s.bounds_max },
        "scalar": { "name": b.mesh.scalar_name, "min": s.scalar_min, "max": s.scalar_max },
        "point_fields": b.mesh.point_fields.iter().map(|f| json!({"name": f.name, "components": f.num_components})).collect::<Vec<_>>(),
        "boundary_faces": b.adjacency.boundary_faces.len(),
        "convex": b.adjacency.convex,
        "delaunay": b.meta.delaunay,
        "split": b.meta.split,
        "split_tets": b.meta.split_tets,
        "source": { "path": b.meta.source_path, "format": b.meta.source_format, "points": b.meta.source_points, "cells": b.meta.source_cells },
        "findings": b.meta.findings,
        "time_steps": b.steps.as_ref().map(|st| {
            let (lo, hi) = st.scalar_range();
            json!({
                "count": st.len(),
                "scalar_range": [lo, hi],
                "gradients": st.gradient_method().map(|m| m.name()),
                "steps": (0..st.len()).map(|k| {
                    let (mn, mx) = min_max(st.scalar(k));
                    json!({"time": st.times()[k], "source": st.source(k), "scalar_min": mn, "scalar_max": mx})
                }).collect::<Vec<_>>(),
            })
        }),
    })
}

fn min_max(v: &[f64]) -> (f64, f64) {
    v.iter().fold((f64::INFINITY, f64::NEG_INFINITY), |(a, b), &x| (a.min(x), b.max(x)))
}

pub fn summary_text(b: &Bundle) -> String {
    let s = &b.meta.stats;
    let mut o = String::new();
    let m = &b.meta;
    let _ = writeln!(
        o,
        "source      {} ({}): {} points, {} cells",
        m.source_path, m.source_format, m.source_points, m.source_cells
    );
    let _ = writeln!(o, "split       {} → {} tets before validation", m.split, m.split_tets);
    let _ = writeln!(o, "points      {}", b.mesh.points.len());
    let _ = writeln!(o, "tets        {}", b.mesh.tets.len());
    let _ = writeln!(o, "scalar      {}  [{:.6e}, {:.6e}]", b.mesh.scalar_name, s.scalar_min, s.scalar_max);
    if !b.mesh.point_fields.is_empty() {
        let names: Vec<_> = b
            .mesh
            .point_fields
            .iter()
            .map(|f| if f.num_components == 1 { f.name.clone() } else { format!("{}[{}]", f.name, f.num_components) })
            .collect();
        let _ = writeln!(o, "fields      {}", names.join(", "));
    }
    let _ = writeln!(
        o,
        "bounds      [{:.6}, {:.6}, {:.6}] – [{:.6}, {:.6}, {:.6}]",
        s.bounds_min[0], s.bounds_min[1], s.bounds_min[2], s.bounds_max[0], s.bounds_max[1], s.bounds_max[2]
    );
    let _ = writeln!(
        o,
        "volume      total {:.9e}; per tet min {:.3e} / median {:.3e} / max {:.3e}",
        s.total_volume, s.tet_volume.min, s.tet_volume.median, s.tet_volume.max
    );
    let _ = writeln!(
        o,
        "edge length min {:.3e} / median {:.3e} / max {:.3e}; max cell diameter {:.6e}",
        s.edge_length.min, s.edge_length.median, s.edge_length.max, s.max_cell_diameter
    );
    let _ = writeln!(
        o,
        "boundary    {} faces; domain {}{}",
        b.adjacency.boundary_faces.len(),
        if b.adjacency.convex { "convex" } else { "not convex" },
        if m.delaunay { " (Delaunay)" } else { "" }
    );
    if let Some(st) = &b.steps {
        let (lo, hi) = st.scalar_range();
        let _ = writeln!(
            o,
            "time steps  {}, t = {} to {}; scalar over all steps [{lo:.6e}, {hi:.6e}] (the scalar above is step 0's){}",
            st.len(),
            st.times()[0],
            st.times()[st.len() - 1],
            match st.gradient_method() {
                Some(m) => format!("; gradients stored for every step ({})", m.name()),
                None => String::new(),
            }
        );
        // Every step of a short series; the ends of a long one.
        let shown: Vec<usize> =
            if st.len() <= 12 { (0..st.len()).collect() } else { (0..5).chain(st.len() - 5..st.len()).collect() };
        for (i, &k) in shown.iter().enumerate() {
            if i > 0 && k != shown[i - 1] + 1 {
                let _ = writeln!(o, "  …         {} more", k - shown[i - 1] - 1);
            }
            let (mn, mx) = min_max(st.scalar(k));
            let _ = writeln!(o, "  {k:>4}  t = {:<12} [{mn:.6e}, {mx:.6e}]  {}", st.times()[k], st.source(k));
        }
    }
    o.push_str(&crate::analysis::info_text(b));
    if !m.findings.is_empty() {
        let _ = writeln!(o, "findings:");
        for f in &m.findings {
            let _ = writeln!(o, "  - {f}");
        }
    }
    o
}
