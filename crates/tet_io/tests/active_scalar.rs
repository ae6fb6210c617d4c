//! The file's declared active scalar is the default scalar. Regression: a
//! VTU declaring `<PointData Scalars="Density">` with `IBlank` first got
//! `IBlank` as its scalar.
use tet_io::{read_bytes, Format};
use tet_mesh::scalar::{select_scalar, ScalarLocation};

fn vtu(point_attrs: &str, cell_attrs: &str) -> String {
    format!(
        r#"<?xml version="1.0"?>
<VTKFile type="UnstructuredGrid" version="1.0" byte_order="LittleEndian">
<UnstructuredGrid><Piece NumberOfPoints="4" NumberOfCells="1">
<PointData{point_attrs}><DataArray type="Int32" Name="IBlank" format="ascii">1 1 1 1</DataArray>
<DataArray type="Float32" Name="Density" format="ascii">0.5 1 1.5 2</DataArray></PointData>
<CellData{cell_attrs}><DataArray type="Int32" Name="Zone" format="ascii">7</DataArray>
<DataArray type="Float32" Name="Vorticity" format="ascii">3</DataArray></CellData>
<Points><DataArray type="Float64" NumberOfComponents="3" format="ascii">0 0 0 1 0 0 0 1 0 0 0 1</DataArray></Points>
<Cells><DataArray type="Int64" Name="connectivity" format="ascii">0 1 2 3</DataArray>
<DataArray type="Int64" Name="offsets" format="ascii">4</DataArray>
<DataArray type="UInt8" Name="types" format="ascii">10</DataArray></Cells>
</Piece></UnstructuredGrid></VTKFile>"#
    )
}

fn default_scalar(bytes: &[u8], format: Format) -> (String, ScalarLocation) {
    let mesh = read_bytes(bytes, format).unwrap();
    let s = select_scalar(&mesh, None).unwrap();
    (s.name, s.location)
}

#[test]
fn vtu_point_data_scalars_attribute_is_the_default() {
    let text = vtu(r#" Scalars="Density""#, "");
    let mesh = read_bytes(text.as_bytes(), Format::VtkXml).unwrap();
    assert_eq!(mesh.active_point_scalar.as_deref(), Some("Density"));
    assert_eq!(default_scalar(text.as_bytes(), Format::VtkXml), ("Density".into(), ScalarLocation::Point));
}

#[test]
fn vtu_cell_data_scalars_attribute_beats_the_first_point_array() {
    let text = vtu("", r#" Scalars="Vorticity""#);
    assert_eq!(default_scalar(text.as_bytes(), Format::VtkXml), ("Vorticity".into(), ScalarLocation::Cell));
    // Nothing declared: the first point array, as before.
    let text = vtu("", "");
    assert_eq!(default_scalar(text.as_bytes(), Format::VtkXml), ("IBlank".into(), ScalarLocation::Point));
}

#[test]
fn legacy_first_scalars_is_the_default_over_field_arrays() {
    let text = b"# vtk DataFile Version 3.0\nt\nASCII\nDATASET UNSTRUCTURED_GRID\n\
POINTS 4 float\n0 0 0 1 0 0 0 1 0 0 0 1\nCELLS 1 5\n4 0 1 2 3\nCELL_TYPES 1\n10\n\
POINT_DATA 4\nFIELD extra 1\nIBlank 1 4 int\n1 1 1 1\n\
SCALARS Pressure float 1\nLOOKUP_TABLE default\n1 2 3 4\n\
SCALARS Temperature float 1\nLOOKUP_TABLE default\n5 6 7 8\n";
    let mesh = read_bytes(text, Format::VtkLegacy).unwrap();
    assert_eq!(mesh.point_fields[0].name, "IBlank");
    assert_eq!(mesh.active_point_scalar.as_deref(), Some("Pressure"));
    assert_eq!(default_scalar(text, Format::VtkLegacy), ("Pressure".into(), ScalarLocation::Point));
}
