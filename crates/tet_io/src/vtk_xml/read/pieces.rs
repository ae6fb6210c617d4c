//! A piece's points, fields and cells: unstructured pieces (cells and
//! polyhedra), structured, image and rectilinear pieces.

use super::*;

impl<'a> Ctx<'a> {
    /// The `Points` of a piece: `num_points` × 3 coordinates.
    pub(crate) fn points(&self, piece: usize, num_points: usize) -> Result<Vec<[f64; 3]>, FormatError> {
        let Some(points_el) = self.child(piece, "Points") else {
            if num_points == 0 {
                return Ok(Vec::new());
            }
            return Err(self.err_at(piece, format!("piece declares {num_points} points but has no <Points>")));
        };
        let array =
            self.child(points_el, "DataArray").ok_or_else(|| self.err_at(points_el, "<Points> has no DataArray"))?;
        let ncomp = self.num_components(array)?;
        if ncomp != 3 {
            return Err(self.err_at(array, format!("Points have {ncomp} components, expected 3")));
        }
        let n = num_points.checked_mul(3).ok_or_else(|| self.err_at(piece, "point count overflows"))?;
        let flat = self.array_f64(array, Some(n))?;
        Ok(flat.chunks_exact(3).map(|c| [c[0], c[1], c[2]]).collect())
    }

    /// The active scalar a piece's `<PointData>`/`<CellData>` declares
    /// (`Scalars="NAME"`), if any.
    pub(crate) fn active_scalar(&self, piece: usize, data: &str) -> Option<String> {
        let el = self.child(piece, data)?;
        self.attr(el, "Scalars").filter(|n| !n.is_empty()).map(str::to_string)
    }

    /// Numeric arrays of a `<PointData>`/`<CellData>` element as fields of
    /// `num_tuples` tuples; with `gather`, the tuples it lists, in its order
    /// (cells kept, a polyhedron's tuple once per tet).
    pub(crate) fn fields(
        &self,
        data_el: Option<usize>,
        num_tuples: usize,
        gather: Option<&[u32]>,
        stats: &mut Stats,
    ) -> Result<Vec<Field>, FormatError> {
        let Some(data_el) = data_el else {
            return Ok(Vec::new());
        };
        let mut fields = Vec::new();
        let arrays: Vec<usize> = self.children(data_el, "DataArray").collect();
        // The cells' orders are how to read the cells, not data.
        let degrees = self.attr(data_el, "HigherOrderDegrees");
        for (i, array) in arrays.into_iter().enumerate() {
            let name = match self.attr(array, "Name") {
                Some(n) if !n.is_empty() => n.to_string(),
                _ => format!("array{i}"),
            };
            if degrees == Some(name.as_str()) {
                continue;
            }
            if self.array_type(array)?.is_none() {
                if !stats.skipped_non_numeric.contains(&name) {
                    stats.skipped_non_numeric.push(name);
                }
                continue;
            }
            let ncomp = self.num_components(array)?;
            let n = num_tuples
                .checked_mul(ncomp)
                .ok_or_else(|| self.err_at(array, format!("array '{name}': size overflows")))?;
            let mut values = self.array_f64(array, Some(n))?;
            if let Some(gather) = gather {
                let mut out = Vec::with_capacity(gather.len() * ncomp);
                for &t in gather {
                    out.extend_from_slice(&values[t as usize * ncomp..(t as usize + 1) * ncomp]);
                }
                values = out;
            }
            fields.push(Field::new(name, ncomp, values));
        }
        Ok(fields)
    }

    // -- pieces ---------------------------------------------------------------

    pub(crate) fn unstructured_piece(&self, piece: usize, stats: &mut Stats) -> Result<SourceMesh, FormatError> {
        let num_points = self.count_attr(piece, "NumberOfPoints")?;
        let num_cells = self.count_attr(piece, "NumberOfCells")?;
        if num_points > u32::MAX as usize {
            return Err(self.err_at(piece, format!("{num_points} points exceed the 32-bit index range")));
        }
        let points = self.points(piece, num_points)?;

        let mut cells = Cells::new();
        let mut gather: Option<Vec<u32>> = None;
        let mut splitter = PolyhedronSplitter::new(num_points);
        // Cells (indices into `cells`) holding Bézier control points.
        let mut bezier: Vec<usize> = Vec::new();
        if num_cells > 0 {
            let cells_el = self
                .child(piece, "Cells")
                .ok_or_else(|| self.err_at(piece, format!("piece declares {num_cells} cells but has no <Cells>")))?;
            let array = |name: &str| {
                self.named_array(cells_el, name)
                    .ok_or_else(|| self.err_at(cells_el, format!("<Cells> has no '{name}' DataArray")))
            };
            let (conn_el, offsets_el, types_el) = (array("connectivity")?, array("offsets")?, array("types")?);
            let types = self.array_i64(types_el, Some(num_cells))?;
            let mut offsets = self.array_i64(offsets_el, None)?;
            // VTK files list end offsets; some writers add the leading 0.
            if offsets.len() == num_cells + 1 && offsets.first() == Some(&0) {
                offsets.remove(0);
            }
            if offsets.len() != num_cells {
                return Err(
                    self.err_at(offsets_el, format!("'offsets' has {} entries for {num_cells} cells", offsets.len()))
                );
            }
            let connectivity = self.array_i64(conn_el, None)?;
            // Polyhedra (id 42) carry their faces in a separate stream.
            let poly = match (self.named_array(cells_el, "faces"), self.named_array(cells_el, "faceoffsets")) {
                (Some(f), Some(o)) if types.contains(&42) => Some(PolyFaces {
                    faces: self.array_i64(f, None)?,
                    offsets: self.array_i64(o, Some(num_cells))?,
                    at: f,
                }),
                _ => None,
            };
            let degrees = self.higher_order_degrees(piece, num_cells)?;
            let input = CellArrays {
                types: &types,
                offsets: &offsets,
                connectivity: &connectivity,
                poly: poly.as_ref(),
                degrees: degrees.as_deref(),
            };
            let mut source = Vec::with_capacity(num_cells);
            (cells, bezier) = self.build_cells(&input, num_points, piece, &mut source, &mut splitter, stats)?;
            if source.len() != num_cells || source.iter().enumerate().any(|(i, &c)| c as usize != i) {
                gather = Some(source);
            }
        }
        let point_fields = self.fields(self.child(piece, "PointData"), num_points, None, stats)?;
        let cell_fields = self.fields(self.child(piece, "CellData"), num_cells, gather.as_deref(), stats)?;
        let mut mesh = SourceMesh {
            points,
            blocks: vec![Block::Unstructured(cells)],
            point_fields,
            cell_fields,
            active_point_scalar: self.active_scalar(piece, "PointData"),
            active_cell_scalar: self.active_scalar(piece, "CellData"),
            ..Default::default()
        };
        stats.polyhedron_points += splitter.num_added_points();
        splitter.finish(&mut mesh).map_err(|m| self.err_at(piece, m))?;
        if !bezier.is_empty() {
            self.evaluate_bezier(piece, &mut mesh, &bezier, stats)?;
        }
        Ok(mesh)
    }

    /// Evaluates the piece's Bézier cells at their lattice points
    /// ([`tet_mesh::BezierEvaluator`]), rational where `<PointData>` names
    /// a `RationalWeights` array.
    fn evaluate_bezier(
        &self,
        piece: usize,
        mesh: &mut SourceMesh,
        bezier: &[usize],
        stats: &mut Stats,
    ) -> Result<(), FormatError> {
        let point_data = self.child(piece, "PointData");
        let weights = match point_data.and_then(|el| self.attr(el, "RationalWeights")).filter(|n| !n.is_empty()) {
            Some(name) => Some(
                mesh.point_fields
                    .iter()
                    .find(|f| f.name == name && f.num_components == 1)
                    .map(|f| f.values.clone())
                    .ok_or_else(|| {
                        self.err_at(
                            point_data.unwrap_or(piece),
                            format!("<PointData> names RationalWeights '{name}' but has no numeric one-component array of that name"),
                        )
                    })?,
            ),
            None => None,
        };
        let Some(Block::Unstructured(cells)) = mesh.blocks.first_mut() else {
            unreachable!("an unstructured piece holds one unstructured block")
        };
        let report = tet_mesh::BezierEvaluator::new()
            .to_lagrange(cells, bezier, &mut mesh.points, &mut mesh.point_fields, weights.as_deref())
            .map_err(|m| self.err_at(piece, format!("Bézier cells: {m}")))?;
        stats.bezier.cells += report.cells;
        stats.bezier.points_moved += report.points_moved;
        stats.bezier.points_added += report.points_added;
        stats.rational_bezier |= weights.is_some();
        Ok(())
    }

    /// The piece's `HigherOrderDegrees` cell array (VTK names it in its
    /// `<CellData>` element's attribute of that name), three orders a cell.
    fn higher_order_degrees(&self, piece: usize, num_cells: usize) -> Result<Option<Vec<i64>>, FormatError> {
        let Some(cell_data) = self.child(piece, "CellData") else {
            return Ok(None);
        };
        let Some(name) = self.attr(cell_data, "HigherOrderDegrees").filter(|n| !n.is_empty()) else {
            return Ok(None);
        };
        let array = self.named_array(cell_data, name).ok_or_else(|| {
            self.err_at(cell_data, format!("<CellData> names HigherOrderDegrees '{name}' but has no such DataArray"))
        })?;
        if self.num_components(array)? != 3 {
            return Err(self.err_at(array, format!("HigherOrderDegrees '{name}' must have 3 components")));
        }
        let n = num_cells.checked_mul(3).ok_or_else(|| self.err_at(array, "HigherOrderDegrees: size overflows"))?;
        Ok(Some(self.array_i64(array, Some(n))?))
    }

    /// The piece's cells; `source` receives, per cell kept, the index of
    /// the file's cell it came from (a polyhedron gives several tets). Also
    /// returns the cells (indices into the cells kept) that hold Bézier
    /// control points.
    pub(crate) fn build_cells(
        &self,
        input: &CellArrays<'_>,
        num_points: usize,
        piece: usize,
        source: &mut Vec<u32>,
        splitter: &mut PolyhedronSplitter,
        stats: &mut Stats,
    ) -> Result<(Cells, Vec<usize>), FormatError> {
        let mut bezier = Vec::new();
        let CellArrays { types, offsets, connectivity, poly, degrees } = *input;
        let num_cells = types.len();
        // End of the previous polyhedron's face stream.
        let mut poly_start = 0usize;
        let mut cells = Cells {
            types: Vec::with_capacity(num_cells),
            offsets: Vec::with_capacity(num_cells + 1),
            connectivity: Vec::with_capacity(connectivity.len()),
        };
        cells.offsets.push(0);
        let mut start = 0usize;
        let mut nodes: Vec<u32> = Vec::with_capacity(32);
        for (c, (&id, &end)) in types.iter().zip(offsets).enumerate() {
            let end =
                usize::try_from(end).ok().filter(|&e| e >= start && e <= connectivity.len()).ok_or_else(|| {
                    self.err_at(
                        piece,
                        format!(
                            "cell {c}: offset {end} is outside {start}..={} of the connectivity",
                            connectivity.len()
                        ),
                    )
                })?;
            let cell_nodes = &connectivity[start..end];
            start = end;
            let id = u32::try_from(id)
                .map_err(|_| self.err_at(piece, format!("cell {c} has invalid VTK cell type id {id}")))?;
            let degrees = degrees.map(|d| [d[3 * c], d[3 * c + 1], d[3 * c + 2]]);
            let found = CellType::from_vtk(id, cell_nodes.len(), degrees)
                .transpose()
                .map_err(|m| self.err_at(piece, format!("cell {c} (VTK type {id}): {m}")))?;
            let keep = match found {
                Some((cell_type, stored)) => {
                    if cell_nodes.len() != stored {
                        return Err(self.err_at(
                            piece,
                            format!("cell {c} (VTK type {id}) has {} nodes, expected {stored}", cell_nodes.len()),
                        ));
                    }
                    let n = cell_type.num_nodes();
                    nodes.clear();
                    for &p in &cell_nodes[..n] {
                        nodes.push(u32::try_from(p).ok().filter(|&q| (q as usize) < num_points).ok_or_else(|| {
                            self.err_at(
                                piece,
                                format!("cell {c} refers to point {p}, but the piece has {num_points} points"),
                            )
                        })?);
                    }
                    if stored > n {
                        stats.reduced_higher_order += 1;
                    }
                    if CellType::vtk_id_is_bezier(id) && cell_type != cell_type.linear() {
                        bezier.push(cells.len());
                    }
                    cells.push(cell_type, &nodes);
                    true
                }
                None if id == 42 && poly.is_some() => {
                    let pf = poly.expect("checked");
                    let end = usize::try_from(pf.offsets[c])
                        .ok()
                        .filter(|&e| e >= poly_start && e <= pf.faces.len())
                        .ok_or_else(|| {
                        self.err_at(
                            pf.at,
                            format!(
                                "cell {c}: faceoffsets entry {} is outside {poly_start}..={} of 'faces'",
                                pf.offsets[c],
                                pf.faces.len()
                            ),
                        )
                    })?;
                    let faces = polyhedron_faces(&pf.faces[poly_start..end], num_points)
                        .map_err(|m| self.err_at(pf.at, format!("polyhedron cell {c}: {m}")))?;
                    poly_start = end;
                    let first_cell = cells.len();
                    splitter
                        .split(faces.iter().map(Vec::as_slice), &mut |t| cells.push(CellType::Tetra, &t))
                        .map_err(|m| self.err_at(pf.at, format!("polyhedron cell {c}: {m}")))?;
                    stats.split_polyhedra += 1;
                    stats.polyhedron_tets += cells.len() - first_cell;
                    source.extend(std::iter::repeat_n(c as u32, cells.len() - first_cell));
                    false
                }
                None if CellType::vtk_id_is_surface_or_lower(id) => {
                    stats.skipped_without_volume += 1;
                    false
                }
                None if CellType::vtk_id_is_unreducible_volume(id) => {
                    *stats.skipped_unreducible.entry(id).or_insert(0) += 1;
                    false
                }
                None => {
                    return Err(self.err_at(piece, format!("cell {c} has unknown VTK cell type id {id}")));
                }
            };
            if keep {
                source.push(c as u32);
            }
        }
        Ok((cells, bezier))
    }

    pub(crate) fn structured_piece(
        &self,
        kind: Kind,
        dataset: usize,
        piece: usize,
        stats: &mut Stats,
    ) -> Result<SourceMesh, FormatError> {
        let dims = self.extent_dims(piece, "Extent")?;
        let too_many =
            || self.err_at(piece, format!("structured piece {dims:?} has more points than 32-bit indices reach"));
        let num_points = dims
            .iter()
            .try_fold(1usize, |a, &d| a.checked_mul(d))
            .filter(|&n| n <= u32::MAX as usize)
            .ok_or_else(too_many)?;
        // VTK's cell count (which cell data follows) counts lower-dimensional
        // cells of flat pieces; tetkit keeps only volume cells.
        let vtk_cells = if dims.contains(&0) { 0 } else { dims.iter().map(|&d| (d - 1).max(1)).product() };
        let volume_cells: usize = dims.iter().map(|&d| d.saturating_sub(1)).product();
        // A flat piece keeps none of its (lower-dimensional) cells' tuples.
        let kept = if volume_cells == vtk_cells {
            None
        } else {
            stats.flat_structured_cells += vtk_cells;
            Some(&[][..])
        };
        let point_fields = self.fields(self.child(piece, "PointData"), num_points, None, stats)?;
        let cell_fields = self.fields(self.child(piece, "CellData"), vtk_cells, kept, stats)?;

        let points = match kind {
            Kind::Structured => self.points(piece, num_points)?,
            Kind::Image | Kind::Rectilinear => {
                let backed = !point_fields.is_empty() || (!cell_fields.is_empty() && volume_cells >= num_points / 8);
                if num_points > MAX_UNBACKED_GRID_POINTS && !backed {
                    return Err(self.err_at(
                        piece,
                        format!("piece of {num_points} grid points carries no point or cell data of that size"),
                    ));
                }
                if kind == Kind::Image {
                    self.image_points(dataset, piece, dims)?
                } else {
                    self.rectilinear_points(piece, dims)?
                }
            }
            Kind::Unstructured => {
                unreachable!("unstructured pieces are read by unstructured_piece")
            }
        };
        Ok(SourceMesh {
            points,
            blocks: vec![Block::Structured { dims, first_point: 0 }],
            point_fields,
            cell_fields,
            active_point_scalar: self.active_scalar(piece, "PointData"),
            active_cell_scalar: self.active_scalar(piece, "CellData"),
            ..Default::default()
        })
    }

    /// ImageData points, i fastest: `Origin + Direction · (Spacing ∘ ijk)`
    /// with ijk the absolute structured index (Extent minimum included), as
    /// `vtkImageData::TransformIndexToPhysicalPoint` computes them.
    pub(crate) fn image_points(
        &self,
        dataset: usize,
        piece: usize,
        dims: [usize; 3],
    ) -> Result<Vec<[f64; 3]>, FormatError> {
        let origin = self.floats_attr(dataset, "Origin", [0.0; 3])?;
        let spacing = self.floats_attr(dataset, "Spacing", [1.0; 3])?;
        let d = self.floats_attr(dataset, "Direction", [1.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 1.0])?;
        let min = self.extent_min(piece, "Extent");
        let mut points = Vec::with_capacity(dims[0] * dims[1] * dims[2]);
        for k in 0..dims[2] {
            let z = (min[2] + k as f64) * spacing[2];
            for j in 0..dims[1] {
                let y = (min[1] + j as f64) * spacing[1];
                for i in 0..dims[0] {
                    let x = (min[0] + i as f64) * spacing[0];
                    points.push([
                        origin[0] + d[0] * x + d[1] * y + d[2] * z,
                        origin[1] + d[3] * x + d[4] * y + d[5] * z,
                        origin[2] + d[6] * x + d[7] * y + d[8] * z,
                    ]);
                }
            }
        }
        Ok(points)
    }

    /// RectilinearGrid points from the three `<Coordinates>` arrays, i fastest.
    pub(crate) fn rectilinear_points(&self, piece: usize, dims: [usize; 3]) -> Result<Vec<[f64; 3]>, FormatError> {
        let coords_el = self
            .child(piece, "Coordinates")
            .ok_or_else(|| self.err_at(piece, "RectilinearGrid piece has no <Coordinates>"))?;
        let arrays: Vec<usize> = self.children(coords_el, "DataArray").collect();
        if arrays.len() != 3 {
            return Err(self.err_at(coords_el, format!("<Coordinates> has {} DataArrays, expected 3", arrays.len())));
        }
        let x = self.array_f64(arrays[0], Some(dims[0]))?;
        let y = self.array_f64(arrays[1], Some(dims[1]))?;
        let z = self.array_f64(arrays[2], Some(dims[2]))?;
        let mut points = Vec::with_capacity(dims[0] * dims[1] * dims[2]);
        for &zk in &z {
            for &yj in &y {
                points.extend(x.iter().map(|&xi| [xi, yj, zk]));
            }
        }
        Ok(points)
    }
}

/// A piece's `<Cells>` arrays.
#[derive(Clone, Copy)]
pub(crate) struct CellArrays<'a> {
    pub(crate) types: &'a [i64],
    pub(crate) offsets: &'a [i64],
    pub(crate) connectivity: &'a [i64],
    pub(crate) poly: Option<&'a PolyFaces>,
    /// The `HigherOrderDegrees` cell array (three orders a cell) if any.
    pub(crate) degrees: Option<&'a [i64]>,
}

/// The polyhedron face stream: `faces` holds, per polyhedron, its face
/// count then each face as a point count and point ids; `faceoffsets[c]`
/// is the end of cell c's stream (-1 for other cells).
pub(crate) struct PolyFaces {
    pub(crate) faces: Vec<i64>,
    pub(crate) offsets: Vec<i64>,
    /// The `faces` DataArray element, for errors.
    pub(crate) at: usize,
}

/// One polyhedron's faces from its stream `[nfaces, n0, ids…, n1, ids…]`.
pub(crate) fn polyhedron_faces(stream: &[i64], num_points: usize) -> Result<Vec<Vec<u32>>, String> {
    let (&nf, mut rest) = stream.split_first().ok_or("its face stream is empty")?;
    let nf = usize::try_from(nf)
        .ok()
        .filter(|&n| n >= 4 && n <= rest.len())
        .ok_or_else(|| format!("face count {nf} is not between 4 and the {} entries of its stream", rest.len()))?;
    let mut faces = Vec::with_capacity(nf);
    for f in 0..nf {
        let (&k, tail) = rest.split_first().ok_or_else(|| format!("its stream ends before face {f}"))?;
        let k = usize::try_from(k)
            .ok()
            .filter(|&k| k >= 3 && k <= tail.len())
            .ok_or_else(|| format!("face {f} has point count {k}; needs 3 to the {} entries left", tail.len()))?;
        let ids = tail[..k]
            .iter()
            .map(|&p| u32::try_from(p).ok().filter(|&q| (q as usize) < num_points))
            .collect::<Option<Vec<u32>>>()
            .ok_or_else(|| format!("face {f} refers to a point outside the piece's {num_points}"))?;
        faces.push(ids);
        rest = &tail[k..];
    }
    if !rest.is_empty() {
        return Err(format!("{} entries are left after its {nf} faces", rest.len()));
    }
    Ok(faces)
}
