//! Wavefront OBJ vertex lists as point clouds.
//!
//! Every `v x y z` line is a point, in file order; `v x y z w` divides by
//! `w`, and the common `v x y z r g b` extension gives the point fields
//! `red`, `green`, `blue` (then every vertex must have them). Faces, lines
//! and point elements (`f`, `l`, `p`) are ignored with a counted note, as are
//! normals, texture coordinates, groups and materials.
//!
//! This is a small reader of its own rather than `tobj`: `tobj` exports only
//! the vertices that faces reference, so a point-cloud OBJ (vertices and no
//! faces) comes out of it empty.

use tet_mesh::{Field, SourceMesh};

use crate::cursor::{clip, parse_f64, TextCursor};
use crate::{FormatError, Location};

/// Reads the vertices of an OBJ file.
pub fn read(bytes: &[u8]) -> Result<SourceMesh, FormatError> {
    let mut t = TextCursor::new(bytes);
    let mut points = Vec::new();
    let mut rgb: [Vec<f64>; 3] = [Vec::new(), Vec::new(), Vec::new()];
    let mut first_colour_line = None;
    let mut elements = 0usize;
    loop {
        let line_no = t.line();
        let Some(line) = t.line_str() else { break };
        let data = line.split('#').next().unwrap_or("");
        let mut tok = data.split_ascii_whitespace();
        match tok.next() {
            Some("v") => {}
            Some("f" | "l" | "p") => {
                elements += 1;
                continue;
            }
            _ => continue,
        }
        let at = Location::Line(line_no);
        let mut vals = [0.0; 7];
        let mut n = 0;
        for s in tok {
            if n == 7 {
                return Err(FormatError::new(at, "a vertex has more than 7 numbers (x y z [w] or x y z r g b)"));
            }
            vals[n] = parse_f64(s)
                .ok_or_else(|| FormatError::new(at, format!("expected a number in the vertex, found '{}'", clip(s))))?;
            n += 1;
        }
        let mut p = [vals[0], vals[1], vals[2]];
        let colour = match n {
            3 => false,
            4 => {
                if vals[3] == 0.0 {
                    return Err(FormatError::new(at, "vertex weight w is 0"));
                }
                p.iter_mut().for_each(|c| *c /= vals[3]);
                false
            }
            6 => true,
            _ => {
                return Err(FormatError::new(
                    at,
                    format!("a vertex needs x y z, x y z w or x y z r g b; this one has {n} numbers"),
                ))
            }
        };
        let had_colours = first_colour_line.is_some();
        if colour && !had_colours && !points.is_empty() {
            return Err(FormatError::new(at, "vertex has a colour but earlier vertices have none"));
        }
        if !colour && had_colours {
            return Err(FormatError::new(at, "vertex has no colour but earlier vertices have one"));
        }
        if colour {
            first_colour_line.get_or_insert(line_no);
            for k in 0..3 {
                rgb[k].push(vals[3 + k]);
            }
        }
        points.push(p);
    }
    if points.is_empty() {
        return Err(FormatError::new(Location::Whole, "the OBJ file has no 'v' lines, so there are no points"));
    }
    let mut notes = Vec::new();
    if elements > 0 {
        notes.push(format!("ignored {elements} faces, lines and point elements: a point cloud keeps only vertices"));
    }
    let point_fields = if first_colour_line.is_some() {
        let [r, g, b] = rgb;
        vec![Field::new("red", 1, r), Field::new("green", 1, g), Field::new("blue", 1, b)]
    } else {
        Vec::new()
    };
    let mesh = SourceMesh { points, point_fields, notes, format: "OBJ".to_string(), ..Default::default() };
    mesh.check().map_err(|e| FormatError::new(Location::Whole, e))?;
    Ok(mesh)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn vertices_colours_and_ignored_faces() {
        let m = read(b"# points\no cloud\nv 0 0 0 1 0 0\nv 2 4 6 0 0.5 1 # comment\nvn 0 0 1\nf 1 2 1\n").unwrap();
        assert_eq!(m.points, vec![[0.0; 3], [2.0, 4.0, 6.0]]);
        assert_eq!(m.point_fields.iter().map(|f| f.name.as_str()).collect::<Vec<_>>(), ["red", "green", "blue"]);
        assert_eq!(m.point_fields[1].values, vec![0.0, 0.5]);
        assert!(m.notes[0].contains("ignored 1 faces"), "{:?}", m.notes);
    }

    #[test]
    fn weights_and_errors_name_the_line() {
        let m = read(b"v 2 4 6 2\n").unwrap();
        assert_eq!(m.points, vec![[1.0, 2.0, 3.0]]);
        assert_eq!(read(b"v 0 0 0\nv 1 1\n").unwrap_err().at, Location::Line(2));
        assert_eq!(read(b"v 0 0 0\nv 1 1 x\n").unwrap_err().at, Location::Line(2));
        assert_eq!(read(b"v 0 0 0\nv 1 1 1 1 1 1\n").unwrap_err().at, Location::Line(2));
        assert!(read(b"f 1 2 3\n").is_err());
    }
}
