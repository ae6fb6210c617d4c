//! Choosing the scalar to render from a source mesh's fields.
//!
//! Selector grammar (what `--scalar` takes): `NAME` (a vector field gives its
//! magnitude), `NAME:mag`, `NAME:x|y|z` or `NAME:0|1|2…` (one component), or
//! `x|y|z` for a coordinate when no field has that name. Names match exactly
//! first, then case-insensitively if that is unambiguous.

use crate::error::MeshError;
use crate::source::{Field, SourceMesh};

/// Where the chosen values live.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum ScalarLocation {
    Point,
    Cell,
    /// No field at all: a constant zero (the summary warns).
    Constant,
}

/// The chosen scalar, before tetrahedralization.
#[derive(Debug, Clone, PartialEq)]
pub struct SelectedScalar {
    /// Display name, e.g. `Momentum:mag` or `density`.
    pub name: String,
    pub location: ScalarLocation,
    /// One value per source point or per source cell (empty for Constant).
    pub values: Vec<f64>,
}

enum Component {
    Magnitude,
    Index(usize),
}

fn parse_component(s: &str) -> Option<Component> {
    match s.to_ascii_lowercase().as_str() {
        "mag" | "magnitude" => Some(Component::Magnitude),
        "x" => Some(Component::Index(0)),
        "y" => Some(Component::Index(1)),
        "z" => Some(Component::Index(2)),
        n => n.parse().ok().map(Component::Index),
    }
}

fn extract(field: &Field, comp: &Component) -> Option<Vec<f64>> {
    let nc = field.num_components;
    match *comp {
        Component::Magnitude if nc == 1 => Some(field.values.clone()),
        Component::Magnitude => {
            Some(field.values.chunks_exact(nc).map(|t| t.iter().map(|v| v * v).sum::<f64>().sqrt()).collect())
        }
        Component::Index(i) if i < nc => Some(field.values.iter().skip(i).step_by(nc).copied().collect()),
        Component::Index(_) => None,
    }
}

fn describe(mesh: &SourceMesh) -> String {
    let mut items = Vec::new();
    for (fields, loc) in [(&mesh.point_fields, "point"), (&mesh.cell_fields, "cell")] {
        for f in fields {
            if f.num_components == 1 {
                items.push(format!("{} ({loc})", f.name));
            } else {
                items.push(format!("{} ({loc}, {} components: NAME, NAME:mag, NAME:0..)", f.name, f.num_components));
            }
        }
    }
    items.push("x, y, z (coordinates)".into());
    items.join("; ")
}

fn find<'a>(fields: &'a [Field], name: &str) -> Option<&'a Field> {
    fields.iter().find(|f| f.name == name).or_else(|| {
        let mut it = fields.iter().filter(|f| f.name.eq_ignore_ascii_case(name));
        match (it.next(), it.next()) {
            (Some(f), None) => Some(f),
            _ => None,
        }
    })
}

/// Picks the scalar: by `selector` if given, else the file's declared active
/// point scalar, else its active cell scalar, else the first point field,
/// else the first cell field, else a constant zero.
pub fn select_scalar(mesh: &SourceMesh, selector: Option<&str>) -> Result<SelectedScalar, MeshError> {
    let Some(sel) = selector else {
        fn active<'a>(fields: &'a [Field], name: &Option<String>) -> Option<&'a Field> {
            name.as_deref().and_then(|n| fields.iter().find(|f| f.name == n))
        }
        let pick = active(&mesh.point_fields, &mesh.active_point_scalar)
            .map(|f| (f, ScalarLocation::Point))
            .or_else(|| active(&mesh.cell_fields, &mesh.active_cell_scalar).map(|f| (f, ScalarLocation::Cell)))
            .or_else(|| mesh.point_fields.first().map(|f| (f, ScalarLocation::Point)))
            .or_else(|| mesh.cell_fields.first().map(|f| (f, ScalarLocation::Cell)));
        return Ok(match pick {
            Some((f, location)) => SelectedScalar {
                name: if f.num_components == 1 { f.name.clone() } else { format!("{}:mag", f.name) },
                location,
                values: extract(f, &Component::Magnitude).expect("magnitude always exists"),
            },
            None => SelectedScalar { name: "zero".into(), location: ScalarLocation::Constant, values: vec![] },
        });
    };
    let unknown = || MeshError::UnknownScalar { name: sel.to_string(), available: describe(mesh) };
    // Whole name first (names may contain ':'), then NAME:COMPONENT.
    let candidates: Vec<(&str, Component)> = {
        let mut v = vec![(sel, Component::Magnitude)];
        if let Some((base, comp)) = sel.rsplit_once(':') {
            if let Some(c) = parse_component(comp) {
                v.push((base, c));
            }
        }
        v
    };
    for (name, comp) in &candidates {
        for (fields, location) in
            [(&mesh.point_fields, ScalarLocation::Point), (&mesh.cell_fields, ScalarLocation::Cell)]
        {
            if let Some(f) = find(fields, name) {
                let values = extract(f, comp).ok_or_else(unknown)?;
                let display = match comp {
                    Component::Magnitude if f.num_components > 1 => format!("{}:mag", f.name),
                    Component::Magnitude => f.name.clone(),
                    Component::Index(i) => format!("{}:{i}", f.name),
                };
                return Ok(SelectedScalar { name: display, location, values });
            }
        }
    }
    let axis = match sel.to_ascii_lowercase().as_str() {
        "x" => 0,
        "y" => 1,
        "z" => 2,
        _ => return Err(unknown()),
    };
    Ok(SelectedScalar {
        name: sel.to_ascii_lowercase(),
        location: ScalarLocation::Point,
        values: mesh.points.iter().map(|p| p[axis]).collect(),
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    fn mesh() -> SourceMesh {
        SourceMesh {
            points: vec![[1.0, 2.0, 3.0], [4.0, 5.0, 6.0]],
            point_fields: vec![
                Field::new("Momentum", 3, vec![3.0, 4.0, 0.0, 0.0, 0.0, 1.0]),
                Field::new("Density", 1, vec![0.5, 0.7]),
            ],
            ..Default::default()
        }
    }

    #[test]
    fn default_is_first_point_field_magnitude() {
        let s = select_scalar(&mesh(), None).unwrap();
        assert_eq!(s.name, "Momentum:mag");
        assert_eq!(s.values, vec![5.0, 1.0]);
    }

    #[test]
    fn default_is_the_declared_active_scalar() {
        let mut m = mesh();
        m.cell_fields = vec![Field::new("Id", 1, vec![])];
        m.active_point_scalar = Some("Density".into());
        m.active_cell_scalar = Some("Id".into());
        let s = select_scalar(&m, None).unwrap();
        assert_eq!((s.name.as_str(), s.location), ("Density", ScalarLocation::Point));
        // Only cell data declares one: it beats the first point field.
        m.active_point_scalar = None;
        assert_eq!(select_scalar(&m, None).unwrap().location, ScalarLocation::Cell);
        // A declared name that is not there (a string array, say) falls back.
        m.active_cell_scalar = Some("Label".into());
        assert_eq!(select_scalar(&m, None).unwrap().name, "Momentum:mag");
    }

    #[test]
    fn components_names_and_coordinates() {
        let m = mesh();
        assert_eq!(select_scalar(&m, Some("Momentum:y")).unwrap().values, vec![4.0, 0.0]);
        assert_eq!(select_scalar(&m, Some("density")).unwrap().values, vec![0.5, 0.7]);
        assert_eq!(select_scalar(&m, Some("z")).unwrap().values, vec![3.0, 6.0]);
    }

    #[test]
    fn unknown_name_lists_what_exists() {
        let e = select_scalar(&mesh(), Some("Pressure")).unwrap_err().to_string();
        assert!(e.contains("Density (point)") && e.contains("Momentum (point, 3 components"), "{e}");
    }
}
