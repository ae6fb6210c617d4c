//! glTF 2.0 (`.gltf` JSON and `.glb` binary) `POINTS` primitives as point
//! clouds, parsed and validated by the `gltf` crate.
//!
//! Every `POINTS` primitive of every mesh instanced in the default scene (or
//! the first scene, or every root node when there is no scene) contributes
//! its `POSITION`s, transformed by the node's world matrix. Point fields:
//! `COLOR_0` as `red`, `green`, `blue` (normalized integers mapped to 0–1,
//! alpha dropped) and every application-specific attribute (`_SCALAR`,
//! `_TEMPERATURE`, …) under its name as written, with as many components as
//! its accessor. A field that some POINTS primitive lacks is dropped with a
//! note, as are other standard attributes (normals, texture coordinates)
//! and primitives of other modes (triangles, lines).
//!
//! The accessor data is decoded here, not through the crate's iterators:
//! every byte range is checked against its view and buffer, so a file whose
//! accessors point past its data is an error, not a panic. Buffers come
//! from the GLB `BIN` chunk, from `data:` URIs (base64), or from the
//! caller's loader for external files.

use std::collections::BTreeMap;

use ::gltf::accessor::{DataType, Dimensions};
use ::gltf::mesh::{Mode, Semantic};
use base64::Engine;
use tet_mesh::{Field, SourceMesh};

use crate::cursor::clip;
use crate::{FormatError, Location};

fn whole(msg: impl Into<String>) -> FormatError {
    FormatError::new(Location::Whole, msg)
}

/// Column-major 4×4 matrix, as glTF stores them.
type Mat4 = [[f64; 4]; 4];

const IDENTITY: Mat4 = [[1.0, 0.0, 0.0, 0.0], [0.0, 1.0, 0.0, 0.0], [0.0, 0.0, 1.0, 0.0], [0.0, 0.0, 0.0, 1.0]];

fn mat_mul(a: &Mat4, b: &Mat4) -> Mat4 {
    let mut m = [[0.0; 4]; 4];
    for (c, col) in m.iter_mut().enumerate() {
        for (r, v) in col.iter_mut().enumerate() {
            *v = (0..4).map(|k| a[k][r] * b[c][k]).sum();
        }
    }
    m
}

fn transform_point(m: &Mat4, p: [f64; 3]) -> [f64; 3] {
    let mut out = [0.0; 3];
    for (r, o) in out.iter_mut().enumerate() {
        *o = m[0][r] * p[0] + m[1][r] * p[1] + m[2][r] * p[2] + m[3][r];
    }
    out
}

/// Loads the data of every buffer.
fn load_buffers(
    doc: &::gltf::Gltf,
    load_external: &mut dyn FnMut(&str) -> std::io::Result<Vec<u8>>,
) -> Result<Vec<Vec<u8>>, FormatError> {
    let mut out = Vec::new();
    for buffer in doc.document.buffers() {
        let i = buffer.index();
        let data = match buffer.source() {
            ::gltf::buffer::Source::Bin => {
                doc.blob.clone().ok_or_else(|| whole(format!("buffer {i} refers to a GLB BIN chunk the file lacks")))?
            }
            ::gltf::buffer::Source::Uri(uri) if uri.starts_with("data:") => {
                let (_, b64) =
                    uri.split_once(";base64,").ok_or_else(|| whole(format!("buffer {i}: data URI is not base64")))?;
                base64::engine::general_purpose::STANDARD
                    .decode(b64.trim())
                    .map_err(|e| whole(format!("buffer {i}: bad base64 in data URI: {e}")))?
            }
            ::gltf::buffer::Source::Uri(uri) => load_external(uri)
                .map_err(|e| whole(format!("buffer {i}: cannot read external file '{}': {e}", clip(uri))))?,
        };
        if data.len() < buffer.length() {
            return Err(whole(format!("buffer {i} declares {} bytes but has {}", buffer.length(), data.len())));
        }
        out.push(data);
    }
    Ok(out)
}

/// Decodes an accessor to `count × components` f64 values, checking every
/// byte range first.
fn accessor_values(
    acc: &::gltf::Accessor,
    buffers: &[Vec<u8>],
    input_len: usize,
) -> Result<(Vec<f64>, usize), FormatError> {
    let i = acc.index();
    let dims = match acc.dimensions() {
        Dimensions::Scalar => 1,
        Dimensions::Vec2 => 2,
        Dimensions::Vec3 => 3,
        Dimensions::Vec4 => 4,
        other => return Err(whole(format!("accessor {i} has type {other:?}; only SCALAR and VEC2–4 are read"))),
    };
    if acc.sparse().is_some() {
        return Err(whole(format!("accessor {i} is sparse; sparse accessors are not supported")));
    }
    let ty = acc.data_type();
    let size = ty.size();
    let elem = dims * size;
    let count = acc.count();
    let Some(view) = acc.view() else {
        // No view: zeros. Bound the count by the input so a tiny file cannot
        // ask for gigabytes.
        if count > input_len {
            return Err(whole(format!("accessor {i} has no data but claims {count} elements")));
        }
        return Ok((vec![0.0; count * dims], dims));
    };
    let buf = &buffers[view.buffer().index()];
    let stride = view.stride().unwrap_or(elem);
    let bad = || {
        whole(format!(
            "accessor {i} ({count} × {elem} bytes, stride {stride}) does not fit in buffer view {} ({} bytes at {})",
            view.index(),
            view.length(),
            view.offset()
        ))
    };
    if stride < elem {
        return Err(bad());
    }
    let view_end = view.offset().checked_add(view.length()).filter(|&e| e <= buf.len()).ok_or_else(bad)?;
    let start = view.offset().checked_add(acc.offset()).ok_or_else(bad)?;
    if count > 0 {
        let last = (count - 1).checked_mul(stride).and_then(|n| n.checked_add(start)).and_then(|n| n.checked_add(elem));
        if last.is_none_or(|end| end > view_end) {
            return Err(bad());
        }
    }
    let mut out = Vec::with_capacity(count * dims);
    for e in 0..count {
        let base = start + e * stride;
        for c in 0..dims {
            let b = &buf[base + c * size..base + (c + 1) * size];
            let v = match ty {
                DataType::I8 => f64::from(b[0] as i8),
                DataType::U8 => f64::from(b[0]),
                DataType::I16 => f64::from(i16::from_le_bytes([b[0], b[1]])),
                DataType::U16 => f64::from(u16::from_le_bytes([b[0], b[1]])),
                DataType::U32 => f64::from(u32::from_le_bytes([b[0], b[1], b[2], b[3]])),
                DataType::F32 => f64::from(f32::from_le_bytes([b[0], b[1], b[2], b[3]])),
            };
            let v = if acc.normalized() {
                match ty {
                    DataType::I8 => (v / 127.0).max(-1.0),
                    DataType::U8 => v / 255.0,
                    DataType::I16 => (v / 32767.0).max(-1.0),
                    DataType::U16 => v / 65535.0,
                    DataType::U32 => v / f64::from(u32::MAX),
                    DataType::F32 => v,
                }
            } else {
                v
            };
            out.push(v);
        }
    }
    Ok((out, dims))
}

/// One instanced POINTS primitive: its world positions and named fields.
struct Part {
    points: Vec<[f64; 3]>,
    fields: BTreeMap<String, (usize, Vec<f64>)>,
}

struct Walk<'b> {
    buffers: &'b [Vec<u8>],
    input_len: usize,
    parts: Vec<Part>,
    visited: Vec<bool>,
    skipped: BTreeMap<String, usize>,
}

impl Walk<'_> {
    fn node(&mut self, node: ::gltf::Node, parent: &Mat4) -> Result<(), FormatError> {
        // glTF nodes form trees: a node reached twice is a cycle or a
        // shared child, both invalid (and a way to blow up the traversal).
        let seen = self.visited.get_mut(node.index()).ok_or_else(|| whole("node index out of range"))?;
        if *seen {
            return Err(whole(format!("node {} is reached twice: the node hierarchy is not a tree", node.index())));
        }
        *seen = true;
        let local = node.transform().matrix().map(|c| c.map(f64::from));
        let world = mat_mul(parent, &local);
        if let Some(mesh) = node.mesh() {
            for prim in mesh.primitives() {
                if prim.mode() != Mode::Points {
                    *self.skipped.entry(format!("{:?} primitives", prim.mode())).or_default() += 1;
                    continue;
                }
                self.primitive(&prim, &world)?;
            }
        }
        for child in node.children() {
            self.node(child, &world)?;
        }
        Ok(())
    }

    fn primitive(&mut self, prim: &::gltf::Primitive, world: &Mat4) -> Result<(), FormatError> {
        let pos = prim.get(&Semantic::Positions).ok_or_else(|| whole("a POINTS primitive has no POSITION"))?;
        let (xyz, dims) = accessor_values(&pos, self.buffers, self.input_len)?;
        if dims != 3 {
            return Err(whole(format!("POSITION accessor {} is not VEC3", pos.index())));
        }
        let points: Vec<[f64; 3]> = xyz.chunks_exact(3).map(|p| transform_point(world, [p[0], p[1], p[2]])).collect();
        let mut fields = BTreeMap::new();
        for (semantic, acc) in prim.attributes() {
            match semantic {
                Semantic::Positions => {}
                Semantic::Colors(0) => {
                    let (v, dims) = accessor_values(&acc, self.buffers, self.input_len)?;
                    if acc.count() != points.len() || dims < 3 {
                        return Err(whole(format!("COLOR_0 accessor {} does not match POSITION", acc.index())));
                    }
                    for (k, name) in ["red", "green", "blue"].iter().enumerate() {
                        fields.insert(name.to_string(), (1, v.iter().skip(k).step_by(dims).copied().collect()));
                    }
                }
                Semantic::Extras(name) => {
                    let (v, dims) = accessor_values(&acc, self.buffers, self.input_len)?;
                    if acc.count() != points.len() {
                        return Err(whole(format!(
                            "attribute _{name} has {} elements for {} positions",
                            acc.count(),
                            points.len()
                        )));
                    }
                    fields.insert(format!("_{name}"), (dims, v));
                }
                other => *self.skipped.entry(format!("{} attributes", other.to_string())).or_default() += 1,
            }
        }
        self.parts.push(Part { points, fields });
        Ok(())
    }
}

/// Reads the POINTS primitives of a glTF or GLB file. `load_external` is
/// called with the URI of each buffer that is neither in the GLB nor a
/// `data:` URI (relative to the file's directory; resolving it is the
/// caller's job).
pub fn read(
    bytes: &[u8],
    load_external: &mut dyn FnMut(&str) -> std::io::Result<Vec<u8>>,
) -> Result<SourceMesh, FormatError> {
    let doc = ::gltf::Gltf::from_slice(bytes).map_err(|e| whole(format!("not a valid glTF file: {e}")))?;
    let buffers = load_buffers(&doc, load_external)?;
    let d = &doc.document;
    let mut walk = Walk {
        buffers: &buffers,
        input_len: bytes.len() + buffers.iter().map(Vec::len).sum::<usize>(),
        parts: Vec::new(),
        visited: vec![false; d.nodes().len()],
        skipped: BTreeMap::new(),
    };
    match d.default_scene().or_else(|| d.scenes().next()) {
        Some(scene) => {
            for node in scene.nodes() {
                walk.node(node, &IDENTITY)?;
            }
        }
        None => {
            // No scene: every node that is no other node's child is a root.
            let mut is_child = vec![false; d.nodes().len()];
            for n in d.nodes() {
                for c in n.children() {
                    is_child[c.index()] = true;
                }
            }
            for n in d.nodes().filter(|n| !is_child[n.index()]) {
                walk.node(n, &IDENTITY)?;
            }
        }
    }
    let Walk { parts, skipped, .. } = walk;
    if parts.is_empty() {
        return Err(whole("the glTF scene has no POINTS primitive (triangle and line meshes are not point clouds)"));
    }
    let mut notes: Vec<String> = skipped.iter().map(|(what, n)| format!("skipped {n} {what}")).collect();
    // Keep the fields every part has, with the same component count.
    let first = &parts[0].fields;
    let mut keep = Vec::new();
    for (name, (dims, _)) in first {
        if parts.iter().all(|p| p.fields.get(name).is_some_and(|f| f.0 == *dims)) {
            keep.push((name.clone(), *dims));
        }
    }
    let all_names: std::collections::BTreeSet<&String> = parts.iter().flat_map(|p| p.fields.keys()).collect();
    for name in all_names {
        if !keep.iter().any(|(k, _)| k == name) {
            notes.push(format!("dropped the attribute '{name}': not every POINTS primitive has it"));
        }
    }
    let total: usize = parts.iter().map(|p| p.points.len()).sum();
    if total > u32::MAX as usize {
        return Err(whole(format!("{total} points are more than tetkit indexes")));
    }
    let mut points = Vec::with_capacity(total);
    let mut point_fields: Vec<Field> = keep.iter().map(|(n, d)| Field::new(n.clone(), *d, Vec::new())).collect();
    for mut part in parts {
        points.extend_from_slice(&part.points);
        for f in &mut point_fields {
            let (_, v) = part.fields.remove(&f.name).expect("kept fields are in every part");
            f.values.extend(v);
        }
    }
    let format = if doc.blob.is_some() || bytes.starts_with(b"glTF") { "glTF (binary .glb)" } else { "glTF (JSON)" };
    let mesh = SourceMesh { points, point_fields, notes, format: format.to_string(), ..Default::default() };
    mesh.check().map_err(|e| FormatError::new(Location::Whole, e))?;
    Ok(mesh)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn no_files(_: &str) -> std::io::Result<Vec<u8>> {
        Err(std::io::Error::new(std::io::ErrorKind::NotFound, "no files in this test"))
    }

    #[test]
    fn embedded_buffer_with_translation_and_scalar() {
        // Two points (0,0,0) and (1,2,3) as f32, then two f32 scalars 5 and 7.
        let mut bin = Vec::new();
        for v in [0.0f32, 0.0, 0.0, 1.0, 2.0, 3.0, 5.0, 7.0] {
            bin.extend_from_slice(&v.to_le_bytes());
        }
        let b64 = base64::engine::general_purpose::STANDARD.encode(&bin);
        let json = format!(
            r#"{{"asset":{{"version":"2.0"}},"scene":0,"scenes":[{{"nodes":[0]}}],
            "nodes":[{{"mesh":0,"translation":[10,0,0]}}],
            "meshes":[{{"primitives":[{{"mode":0,"attributes":{{"POSITION":0,"_SCALAR":1}}}}]}}],
            "buffers":[{{"byteLength":32,"uri":"data:application/octet-stream;base64,{b64}"}}],
            "bufferViews":[{{"buffer":0,"byteOffset":0,"byteLength":24}},{{"buffer":0,"byteOffset":24,"byteLength":8}}],
            "accessors":[{{"bufferView":0,"componentType":5126,"count":2,"type":"VEC3","min":[0,0,0],"max":[1,2,3]}},
                         {{"bufferView":1,"componentType":5126,"count":2,"type":"SCALAR"}}]}}"#
        );
        let m = read(json.as_bytes(), &mut no_files).unwrap();
        assert_eq!(m.points, vec![[10.0, 0.0, 0.0], [11.0, 2.0, 3.0]]);
        assert_eq!(m.point_fields[0].name, "_SCALAR");
        assert_eq!(m.point_fields[0].values, vec![5.0, 7.0]);
        assert_eq!(m.format, "glTF (JSON)");

        // An accessor that runs past its view is an error.
        let bad = json.replace(r#""count":2,"type":"SCALAR""#, r#""count":3,"type":"SCALAR""#);
        assert!(read(bad.as_bytes(), &mut no_files).unwrap_err().message.contains("does not fit"));
    }
}
