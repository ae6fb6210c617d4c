//! What a read has gathered (State): nodes, elements, physical names and
//! tag maps, and the $NodeData/$ElementData fields.

use super::*;
use tet_mesh::lagrange;

#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(crate) enum DataKind {
    Node,
    Element,
}

/// The `$NodeData`/`$ElementData` header (ASCII in both encodings).
pub(crate) struct DataHeader {
    pub(crate) name: String,
    pub(crate) time: f64,
    pub(crate) step: i64,
    pub(crate) components: usize,
    pub(crate) count: u64,
}

/// The latest time step seen of one named field.
pub(crate) struct DataField {
    pub(crate) kind: DataKind,
    pub(crate) name: String,
    pub(crate) time: f64,
    pub(crate) step: i64,
    /// Distinct time steps met for this name, in file order.
    pub(crate) steps_seen: usize,
    pub(crate) components: usize,
    pub(crate) tags: Vec<u64>,
    pub(crate) values: Vec<f64>,
    pub(crate) at: Location,
}

pub(crate) struct State {
    pub(crate) header: Header,
    pub(crate) node_tags: Vec<u64>,
    pub(crate) points: Vec<[f64; 3]>,
    pub(crate) cell_types: Vec<CellType>,
    /// Corner node tags of the kept cells, concatenated.
    pub(crate) cell_node_tags: Vec<u64>,
    pub(crate) cell_tags: Vec<u64>,
    pub(crate) cell_physical: Vec<f64>,
    pub(crate) cell_entity: Vec<f64>,
    pub(crate) lower_dim: usize,
    pub(crate) higher_order: usize,
    pub(crate) elements_sections: usize,
    /// Physical tag of each volume entity (4.1 `$Entities`).
    pub(crate) volume_physical: Option<HashMap<i64, i64>>,
    /// Whether the physical tag of the cells is known (2.2 tags or 4.1 entities).
    pub(crate) physical_known: bool,
    pub(crate) physical_volume_names: Vec<(i64, String)>,
    pub(crate) data: Vec<DataField>,
    pub(crate) skipped_sections: Vec<String>,
    pub(crate) notes: Vec<String>,
    /// For complete elements of order 3 and above read as VTK's Lagrange
    /// cells: per cell type, the Gmsh node at each VTK node.
    lagrange_orders: HashMap<CellType, Vec<usize>>,
}

impl State {
    pub(crate) fn new(header: Header) -> Self {
        State {
            header,
            node_tags: Vec::new(),
            points: Vec::new(),
            cell_types: Vec::new(),
            cell_node_tags: Vec::new(),
            cell_tags: Vec::new(),
            cell_physical: Vec::new(),
            cell_entity: Vec::new(),
            lower_dim: 0,
            higher_order: 0,
            elements_sections: 0,
            volume_physical: None,
            physical_known: false,
            physical_volume_names: Vec::new(),
            data: Vec::new(),
            skipped_sections: Vec::new(),
            notes: Vec::new(),
            lagrange_orders: HashMap::new(),
        }
    }

    /// Runs the body of a 4.1 section that is ASCII or binary by the file's
    /// encoding, then checks its `$End` line. `t` is just after the header.
    pub(crate) fn section_41(&mut self, t: &mut TextCursor, which: Section41) -> Result<(), FormatError> {
        match self.header.binary {
            None => dispatch_41(&mut Ascii { t: &mut *t }, self, which)?,
            Some((endian, size_bytes)) => {
                eat_line_end(t)?;
                let base = t.offset() as u64;
                let mut v = Binary { c: ByteCursor::with_base(t.rest(), base), endian, size_bytes };
                dispatch_41(&mut v, self, which)?;
                let used = v.c.offset() - base;
                t.advance(used as usize);
            }
        }
        expect_end(t, which.name())
    }

    pub(crate) fn push_cell(&mut self, cell_type: CellType, nodes: &[u64], tag: u64, physical: f64, entity: f64) {
        // Second-order cells keep their nodes, in VTK's order (see
        // `CellType`): for each VTK node, the Gmsh node at its place
        // (Gmsh's orders from its manual, "Node ordering": a 10-node tet's
        // edges 0-1, 1-2, 2-0, 3-0, 2-3, 3-1; a 20-node hexahedron's 0-1, 0-3, 0-4, 1-2, 1-5, 2-3, 2-6, 3-7,
        // 4-5, 4-7, 5-6, 6-7; a 15-node prism's 0-1, 0-2, 0-3, 1-2, 1-4,
        // 2-5, 3-4, 3-5, 4-5; a 13-node pyramid's 0-1, 0-3, 0-4, 1-2, 1-4,
        // 2-3, 2-4, 3-4).
        const TET10: [usize; 10] = [0, 1, 2, 3, 4, 5, 6, 7, 9, 8];
        const HEX20: [usize; 20] = [0, 1, 2, 3, 4, 5, 6, 7, 8, 11, 13, 9, 16, 18, 19, 17, 10, 12, 14, 15];
        const PRISM15: [usize; 15] = [0, 1, 2, 3, 4, 5, 6, 9, 7, 12, 14, 13, 8, 10, 11];
        const PYRAMID13: [usize; 13] = [0, 1, 2, 3, 4, 5, 8, 10, 6, 7, 9, 11, 12];
        // Complete second order adds face and body centres: a 27-node
        // hexahedron's faces z = 0, y = 0, x = 0, x = 1, y = 1, z = 1 of its
        // parameter cube, then its centre; an 18-node prism's quads
        // 0-1-4-3, 2-0-3-5, 1-2-5-4; a 14-node pyramid's base. (Checked on
        // a Gmsh mesh: each sits at the centroid of its face's corners.)
        const HEX27: [usize; 27] =
            [0, 1, 2, 3, 4, 5, 6, 7, 8, 11, 13, 9, 16, 18, 19, 17, 10, 12, 14, 15, 22, 23, 21, 24, 20, 25, 26];
        const PRISM18: [usize; 18] = [0, 1, 2, 3, 4, 5, 6, 9, 7, 12, 14, 13, 8, 10, 11, 15, 17, 16];
        const PYRAMID14: [usize; 14] = [0, 1, 2, 3, 4, 5, 8, 10, 6, 7, 9, 11, 12, 13];
        // Complete tetrahedra, hexahedra, prisms and pyramids of order 3 and above (Gmsh's
        // corners, edges, faces, body, recursively: tet_mesh::lagrange's
        // `gmsh_*_lattice`) are VTK's Lagrange cells of their order.
        let lagrange = match (cell_type, nodes.len()) {
            (CellType::Tetra, n) if n > 10 => lagrange::lagrange_tetra_order(n).map(CellType::LagrangeTetra),
            (CellType::Hexahedron, n) if n > 27 => {
                lagrange::lagrange_hexahedron_order(n).map(|o| CellType::LagrangeHexahedron([o; 3]))
            }
            (CellType::Wedge, n) if n > 18 => lagrange::lagrange_wedge_order(n).map(|o| CellType::LagrangeWedge(o, o)),
            (CellType::Pyramid, n) if n > 14 => lagrange::lagrange_pyramid_order(n).map(CellType::LagrangePyramid),
            _ => None,
        };
        if let Some(ty) = lagrange {
            let order = self.lagrange_orders.entry(ty).or_insert_with(|| {
                let (gmsh, vtk) = match ty {
                    CellType::LagrangeTetra(n) => {
                        (lagrange::gmsh_tetra_lattice(n), lagrange::lagrange_tetra_lattice(n))
                    }
                    CellType::LagrangeHexahedron(o) => {
                        (lagrange::gmsh_hexahedron_lattice(o[0]), lagrange::lagrange_hexahedron_lattice(o))
                    }
                    CellType::LagrangeWedge(n, m) => {
                        (lagrange::gmsh_wedge_lattice(n), lagrange::lagrange_wedge_lattice(n, m))
                    }
                    // (Gmsh's own order.)
                    CellType::LagrangePyramid(n) => {
                        (lagrange::gmsh_pyramid_lattice(n), lagrange::gmsh_pyramid_lattice(n))
                    }
                    _ => unreachable!("a Lagrange tetrahedron, hexahedron, wedge or pyramid"),
                };
                lagrange::lattice_permutation(&gmsh, &vtk).expect("the same lattice points")
            });
            // (Taken out while the cell is pushed, put back after.)
            let order = std::mem::take(order);
            self.push_kept(ty, order.iter().map(|&k| nodes[k]), tag, physical, entity);
            self.lagrange_orders.insert(ty, order);
            return;
        }
        let kept: Option<(CellType, &[usize])> = match (cell_type, nodes.len()) {
            (CellType::Tetra, 10) => Some((CellType::QuadraticTetra, &TET10)),
            (CellType::Hexahedron, 20) => Some((CellType::QuadraticHexahedron, &HEX20)),
            (CellType::Hexahedron, 27) => Some((CellType::TriquadraticHexahedron, &HEX27)),
            (CellType::Wedge, 15) => Some((CellType::QuadraticWedge, &PRISM15)),
            (CellType::Wedge, 18) => Some((CellType::BiquadraticWedge, &PRISM18)),
            (CellType::Pyramid, 13) => Some((CellType::QuadraticPyramid, &PYRAMID13)),
            (CellType::Pyramid, 14) => Some((CellType::QuadraticPyramidWithBaseCentre, &PYRAMID14)),
            _ => None,
        };
        if let Some((ty, order)) = kept {
            self.push_kept(ty, order.iter().map(|&k| nodes[k]), tag, physical, entity);
            return;
        }
        let corners = cell_type.num_nodes();
        if nodes.len() > corners {
            self.higher_order += 1;
        }
        self.push_kept(cell_type, nodes[..corners.min(nodes.len())].iter().copied(), tag, physical, entity);
    }

    /// One kept cell: its type, node tags (in VTK's order) and tags.
    fn push_kept(&mut self, ty: CellType, node_tags: impl Iterator<Item = u64>, tag: u64, physical: f64, entity: f64) {
        self.cell_types.push(ty);
        self.cell_node_tags.extend(node_tags);
        self.cell_tags.push(tag);
        self.cell_physical.push(physical);
        self.cell_entity.push(entity);
    }

    pub(crate) fn finish(self) -> Result<SourceMesh, FormatError> {
        let State {
            header,
            node_tags,
            points,
            cell_types,
            cell_node_tags,
            cell_tags,
            cell_physical,
            cell_entity,
            lower_dim,
            higher_order,
            elements_sections,
            physical_known,
            physical_volume_names,
            data,
            skipped_sections,
            mut notes,
            ..
        } = self;
        if points.is_empty() && node_tags.is_empty() {
            return Err(FormatError::new(Location::Whole, "the file has no nodes ($Nodes section missing or empty)"));
        }
        if elements_sections == 0 {
            return Err(FormatError::new(Location::Whole, "the file has no $Elements section"));
        }
        if cell_types.is_empty() {
            return Err(FormatError::new(
                Location::Whole,
                format!("the file has no volume elements ({lower_dim} point, line or surface elements only)"),
            ));
        }
        if u32::try_from(points.len()).is_err() {
            return Err(FormatError::new(Location::Whole, "more than 2^32 - 1 nodes"));
        }
        let node_map = TagMap::build(&node_tags)
            .map_err(|t| FormatError::new(Location::Whole, format!("node tag {t} appears twice in $Nodes")))?;

        let mut cells = Cells::new();
        cells.types.reserve(cell_types.len());
        cells.offsets.reserve(cell_types.len());
        cells.connectivity.reserve(cell_node_tags.len());
        let mut resolved: Vec<u32> = Vec::with_capacity(32);
        let mut at = 0usize;
        for (c, &ty) in cell_types.iter().enumerate() {
            let n = ty.num_nodes();
            let tags = cell_node_tags.get(at..at + n).ok_or_else(|| {
                FormatError::new(Location::Whole, "internal: element node list shorter than its type")
            })?;
            resolved.clear();
            for &tag in tags {
                resolved.push(node_map.get(tag).ok_or_else(|| {
                    FormatError::new(
                        Location::Whole,
                        format!(
                            "element {} refers to node tag {tag}, which is not in $Nodes",
                            cell_tags.get(c).copied().unwrap_or(0)
                        ),
                    )
                })?);
            }
            cells.push(ty, &resolved);
            at += n;
        }
        // Cut cells beside reduced ones would not conform: then they are
        // reduced too (and counted with them).
        let higher_order = higher_order + if higher_order > 0 { cells.reduce_to_corners() } else { 0 };

        let mut mesh = SourceMesh {
            format: format!(
                "Gmsh {} ({})",
                header.version_text,
                if header.binary.is_some() { "binary" } else { "ASCII" }
            ),
            ..Default::default()
        };
        // All zeros means the file defines no physical volumes: leave the field out.
        if physical_known && cell_physical.iter().any(|&p| p != 0.0) {
            mesh.cell_fields.push(Field::new(PHYSICAL_FIELD, 1, cell_physical));
        }
        mesh.cell_fields.push(Field::new(GEOMETRICAL_FIELD, 1, cell_entity));

        let num_points = points.len();
        let num_cells = cells.len();
        let mut cell_map: Option<TagMap> = None;
        for f in data {
            let comps = f.components;
            let (count, map) = match f.kind {
                DataKind::Node => (num_points, &node_map),
                DataKind::Element => {
                    if cell_map.is_none() {
                        cell_map = Some(TagMap::build(&cell_tags).map_err(|t| {
                            FormatError::new(Location::Whole, format!("element tag {t} is used by two volume elements"))
                        })?);
                    }
                    match &cell_map {
                        Some(m) => (num_cells, m),
                        None => continue,
                    }
                }
            };
            let len = count.checked_mul(comps).ok_or_else(|| FormatError::new(f.at, "field size overflows"))?;
            let mut values = vec![f64::NAN; len];
            let mut covered = vec![false; count];
            let mut outside = 0usize;
            for (i, &tag) in f.tags.iter().enumerate() {
                let Some(idx) = map.get(tag) else {
                    if f.kind == DataKind::Node {
                        return Err(FormatError::new(
                            f.at,
                            format!("$NodeData '{}' refers to node tag {tag}, which is not in $Nodes", f.name),
                        ));
                    }
                    outside += 1;
                    continue;
                };
                let idx = idx as usize;
                let src = f.values.get(i * comps..(i + 1) * comps);
                let dst = values.get_mut(idx * comps..(idx + 1) * comps);
                if let (Some(src), Some(dst)) = (src, dst) {
                    dst.copy_from_slice(src);
                }
                if let Some(c) = covered.get_mut(idx) {
                    *c = true;
                }
            }
            let n_covered = covered.iter().filter(|&&c| c).count();
            let what = if f.kind == DataKind::Node { "point" } else { "cell" };
            if f.steps_seen > 1 {
                notes.push(format!(
                    "{what} field '{}': kept the last of {} time steps (step {}, time {})",
                    f.name, f.steps_seen, f.step, f.time
                ));
            }
            if outside > 0 {
                notes.push(format!("{what} field '{}': ignored {outside} values on non-volume elements", f.name));
            }
            if n_covered == 0 {
                notes.push(format!("{what} field '{}' dropped: it has no values on the volume {what}s", f.name));
                continue;
            }
            if n_covered < count {
                notes.push(format!(
                    "{what} field '{}' covers {n_covered} of {count} {what}s; the others are NaN",
                    f.name
                ));
            }
            let field = Field::new(f.name, comps, values);
            match f.kind {
                DataKind::Node => mesh.point_fields.push(field),
                DataKind::Element => mesh.cell_fields.push(field),
            }
        }

        if lower_dim > 0 {
            notes.insert(0, format!("skipped {lower_dim} lower-dimensional elements (points, lines, surfaces)"));
        }
        if higher_order > 0 {
            notes.insert(0, format!("reduced {higher_order} higher-order elements to their corner nodes"));
        }
        if !physical_volume_names.is_empty() {
            let list: Vec<String> =
                physical_volume_names.iter().map(|(tag, name)| format!("{tag} \"{name}\"")).collect();
            notes.push(format!("physical volumes ({PHYSICAL_FIELD}): {}", list.join(", ")));
        }
        if !skipped_sections.is_empty() {
            notes.push(format!("skipped sections: {}", skipped_sections.join(", ")));
        }
        mesh.points = points;
        mesh.blocks.push(Block::Unstructured(cells));
        mesh.notes = notes;
        mesh.check().map_err(|e| FormatError::new(Location::Whole, e))?;
        Ok(mesh)
    }
}

/// Maps sparse tags to dense indices with memory bounded by the tag count.
pub(crate) enum TagMap {
    Dense(Vec<u32>),
    Sparse(HashMap<u64, u32>),
}

impl TagMap {
    /// Fails with the first duplicated tag.
    pub(crate) fn build(tags: &[u64]) -> Result<TagMap, u64> {
        let max = tags.iter().copied().max().unwrap_or(0);
        let dense_limit = (tags.len() as u64).saturating_mul(2).saturating_add(1024);
        if max <= dense_limit {
            let mut table = vec![u32::MAX; max as usize + 1];
            for (i, &tag) in tags.iter().enumerate() {
                match table.get_mut(tag as usize) {
                    Some(slot) if *slot == u32::MAX => *slot = i as u32,
                    _ => return Err(tag),
                }
            }
            Ok(TagMap::Dense(table))
        } else {
            let mut map = HashMap::with_capacity(tags.len());
            for (i, &tag) in tags.iter().enumerate() {
                if map.insert(tag, i as u32).is_some() {
                    return Err(tag);
                }
            }
            Ok(TagMap::Sparse(map))
        }
    }

    pub(crate) fn get(&self, tag: u64) -> Option<u32> {
        match self {
            TagMap::Dense(table) => {
                usize::try_from(tag).ok().and_then(|i| table.get(i)).copied().filter(|&v| v != u32::MAX)
            }
            TagMap::Sparse(map) => map.get(&tag).copied(),
        }
    }
}

pub(crate) fn read_physical_names(t: &mut TextCursor, state: &mut State) -> Result<(), FormatError> {
    let count: u64 = t.parse("the number of physical names")?;
    for _ in 0..count {
        let dim: i64 = t.parse("a physical name's dimension")?;
        let tag: i64 = t.parse("a physical name's tag")?;
        let loc = t.location();
        let rest = t.line_str().ok_or_else(|| FormatError::new(loc, "unexpected end of file in $PhysicalNames"))?;
        if dim == 3 {
            state.physical_volume_names.push((tag, rest.trim().trim_matches('"').to_string()));
        }
    }
    expect_end(t, "PhysicalNames")
}
