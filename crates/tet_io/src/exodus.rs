//! Exodus II meshes and results in netCDF classic form (`.exo`, `.ex2`,
//! `.e`, `.g`).
//!
//! The data model: Schoof & Yarberry, "EXODUS II: A Finite Element Data
//! Model" (Sandia report SAND92-2137, 1994), as the Exodus library (SEACAS)
//! writes it into netCDF ([`crate::netcdf`]): dimensions `num_dim`,
//! `num_nodes`, `num_el_blk`, `num_el_in_blk{i}`, `num_nod_per_el{i}` and the
//! record dimension `time_step`; coordinates in `coordx`/`coordy`/`coordz` or
//! one `coord` (num_dim × num_nodes); per element block `connect{i}` with
//! 1-based node numbers and its `elem_type` attribute; block ids in
//! `eb_prop1`; times in `time_whole`; nodal results named by `name_nod_var`
//! in `vals_nod_var{j}` (or one `vals_nod_var`, time × variable × node, in
//! older files); element results named by `name_elem_var` in
//! `vals_elem_var{j}eb{i}` where the truth table `elem_var_tab` says so.
//!
//! Tetrahedra, hexahedra, wedges and pyramids are read; TETRA10, TETRA15,
//! HEX20, HEX27, WEDGE15, WEDGE18, WEDGE21, PYRAMID13, PYRAMID14 and
//! PYRAMID19 keep their nodes, permuted into VTK's order and subdivided at
//! them (WEDGE21's and PYRAMID19's orders from SEACAS's Ioss element
//! topologies; the order is checked on every element's geometry where the
//! cell's straight-sided node places are known — all but PYRAMID19: a
//! block whose nodes fit VTK's order instead is read so, with a note; one
//! that fits neither is reduced to its corners); TET5, TETRA11, HEX9 and
//! WEDGE16, whose last node is a centre node inside the element, are read as
//! TETRA4, TETRA10, HEX8 and WEDGE15 (the centre's value is not used; every
//! face keeps its nodes, so neighbours conform), with a note; TETRA14,
//! WEDGE20 and PYRAMID18 (a node on every face, none inside) and TETRA8
//! (corners and face nodes only) are completed into TETRA15, WEDGE21 and
//! PYRAMID19 by points the reader adds — a body point at the mean of the
//! element's nodes, TETRA8's mid-edge points at their corners' mean, shared
//! by the elements on the edge — whose values are the same means of the
//! nodes' (exact for fields linear in space; every time step's alike), and
//! cut at all their nodes ([`Completion`]); other higher-order elements are
//! reduced to their corner nodes, which Exodus lists first (and then every
//! other quadratic element too, so that neighbours conform); blocks
//! of other types
//! (shells, beams, spheres, polyhedra) are skipped with a note. Nodal variables
//! become point fields and element variables cell fields (NaN in blocks the
//! truth table leaves out), all at one time step ([`ExodusOptions`]);
//! `block_id` is a cell field.
//!
//! Both containers are read: netCDF classic (CDF-1, 64-bit offset,
//! CDF-5) and netCDF-4 (HDF5; chunked, deflate-compressed or not), the
//! latter through `netcdf-reader` ([`crate::netcdf`]).

use tet_mesh::{Block, CellType, Cells, Field};

use crate::netcdf::{NetCdf, Variable};
use crate::{FormatError, Location, SourceMesh};

/// What to read of a results file.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub struct ExodusOptions {
    /// Time step (0-based) whose results become the fields; the first when
    /// unset.
    pub time_step: Option<usize>,
}

/// The cell an Exodus element type is read as, given its nodes per
/// element; `None` for types that are not volume cells tetkit reads.
/// TETRA10 and TETRA15, HEX20 and HEX27, WEDGE15, WEDGE18 and WEDGE21,
/// PYRAMID13, PYRAMID14 and PYRAMID19 keep their nodes (permuted into VTK's order by
/// [`node_orders`] and subdivided at them); TETRA8 and TETRA14, WEDGE20
/// and PYRAMID18 become TETRA15, WEDGE21 and PYRAMID19 by added points
/// ([`Completion`]); TET5, TETRA11, HEX9 and WEDGE16 are read without their
/// centre node ([`drops_centre_only`]); other higher-order elements are
/// reduced to their corners.
fn cell_type(elem_type: &str, nodes: usize) -> Option<CellType> {
    let t = elem_type.trim().to_ascii_uppercase();
    let family = ["TET", "HEX", "WEDGE", "PYRAMID"].into_iter().find(|f| t.starts_with(f))?;
    let linear = match family {
        "TET" => CellType::Tetra,
        "HEX" => CellType::Hexahedron,
        "WEDGE" => CellType::Wedge,
        _ => CellType::Pyramid,
    };
    let kept = [
        CellType::QuadraticTetra,
        CellType::QuadraticTetraWithCentres,
        CellType::QuadraticHexahedron,
        CellType::TriquadraticHexahedron,
        CellType::QuadraticWedge,
        CellType::BiquadraticWedge,
        CellType::QuadraticPyramid,
        CellType::QuadraticPyramidWithBaseCentre,
        CellType::QuadraticWedgeWithCentres,
        CellType::TriquadraticPyramid,
    ];
    match kept.into_iter().find(|q| q.linear() == linear && q.num_nodes() == nodes) {
        Some(q) => Some(q),
        // TETRA11: TETRA10 and a centre node; WEDGE16: WEDGE15 and one.
        None if linear == CellType::Tetra && nodes == 11 => Some(CellType::QuadraticTetra),
        None if linear == CellType::Wedge && nodes == 16 => Some(CellType::QuadraticWedge),
        // Face-centre nodes without a body node (TETRA14, WEDGE20,
        // PYRAMID18) or without mid-edge nodes either (TETRA8): completed
        // into the cell with all of them ([`Completion`]).
        None if linear == CellType::Tetra && (nodes == 8 || nodes == 14) => Some(CellType::QuadraticTetraWithCentres),
        None if linear == CellType::Wedge && nodes == 20 => Some(CellType::QuadraticWedgeWithCentres),
        None if linear == CellType::Pyramid && nodes == 18 => Some(CellType::TriquadraticPyramid),
        // Any other count (Ioss's cubic TETRA16/40, HEX16/32/64, WEDGE24/52,
        // …): its corners, which Exodus lists first.
        None => (nodes >= linear.num_nodes()).then_some(linear),
    }
}

/// The points an element of `nodes` nodes read as `cell_type` lacks, which
/// the reader adds so that it can be cut at all its nodes like the cell it
/// completes: TETRA14, WEDGE20 and PYRAMID18 (a node on every face, none
/// inside) lack the body node of TETRA15, WEDGE21 and PYRAMID19; TETRA8 (a
/// node on every face, none on the edges) lacks TETRA15's six mid-edge
/// nodes too. A mid-edge point is the mean of the edge's two corners, one
/// point shared by every element on the edge (so neighbours conform); a body
/// point is the mean of the element's nodes. Each added point's values are
/// the same mean of its nodes' values, which is exact for a field linear in
/// space and needs no other step data (a time step's fields are completed
/// the same way, [`Synthetic::extend`]).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum Completion {
    None,
    Body,
    EdgesAndBody,
}

fn completion(cell_type: CellType, nodes: usize) -> Completion {
    match (cell_type, nodes) {
        (CellType::QuadraticTetraWithCentres, 8) => Completion::EdgesAndBody,
        (CellType::QuadraticTetraWithCentres, 14)
        | (CellType::QuadraticWedgeWithCentres, 20)
        | (CellType::TriquadraticPyramid, 18) => Completion::Body,
        _ => Completion::None,
    }
}

/// The tetrahedron's edges in VTK's order (its nodes 4 to 9).
const TET_EDGES: [[usize; 2]; 6] = [[0, 1], [1, 2], [2, 0], [0, 3], [1, 3], [2, 3]];

/// The points added to complete elements ([`Completion`]): point
/// `num_nodes + k` is the mean of the file's nodes `sources[k]`, and each
/// completed element's added points, in its block's order (TETRA8: its six
/// edges in VTK's order, then the body; the others: the body).
#[derive(Debug, Clone, Default)]
struct Synthetic {
    num_nodes: usize,
    sources: Vec<Vec<u32>>,
    /// Per block (as `Layout::blocks`): the points added to each element
    /// (0, 1 or 7) and the elements' added point ids, element after element.
    of_block: Vec<(usize, Vec<u32>)>,
}

impl Synthetic {
    /// Reads the connectivity of the blocks that need completing (none in
    /// most files) and numbers their added points; the same for the mesh
    /// and for every time step, from the connectivity alone.
    fn of(f: &NetCdf<'_>, layout: &Layout, num_nodes: usize) -> Result<Synthetic, FormatError> {
        let mut out = Synthetic { num_nodes, ..Default::default() };
        let mut edge_point = std::collections::HashMap::new();
        for blk in &layout.blocks {
            let kind = completion(blk.cell_type, blk.nodes_per_elem);
            let per = match kind {
                Completion::None => 0,
                Completion::Body => 1,
                Completion::EdgesAndBody => TET_EDGES.len() + 1,
            };
            let mut ids = Vec::new();
            if kind != Completion::None {
                let connect = f.read(need(f, &format!("connect{}", blk.index + 1))?, None)?;
                let nodes = node_ids(&connect, blk, num_nodes, layout)?;
                for element in nodes.chunks_exact(blk.nodes_per_elem) {
                    if kind == Completion::EdgesAndBody {
                        for [a, b] in TET_EDGES {
                            let key = (element[a].min(element[b]), element[a].max(element[b]));
                            let next = (num_nodes + out.sources.len()) as u32;
                            let id = *edge_point.entry(key).or_insert(next);
                            if id == next {
                                out.sources.push(vec![key.0, key.1]);
                            }
                            ids.push(id);
                        }
                    }
                    ids.push((num_nodes + out.sources.len()) as u32);
                    out.sources.push(element.to_vec());
                }
            }
            out.of_block.push((per, ids));
        }
        Ok(out)
    }

    /// The added points of element `e` of block `b`.
    fn of_element(&self, b: usize, e: usize) -> &[u32] {
        let (per, ids) = &self.of_block[b];
        &ids[e * per..(e + 1) * per]
    }

    /// Appends the added points' values (each the mean of its sources') to
    /// a nodal variable (one value a file node).
    fn extend(&self, values: &mut Vec<f64>) {
        for src in &self.sources {
            let sum: f64 = src.iter().map(|&n| values[n as usize]).sum();
            values.push(sum / src.len() as f64);
        }
    }
}

/// A block's connectivity as 0-based node ids, each checked to name a node.
fn node_ids(connect: &[f64], blk: &BlockLayout, num_nodes: usize, layout: &Layout) -> Result<Vec<u32>, FormatError> {
    if let Some(e) = (0..blk.count * blk.nodes_per_elem)
        .find(|&k| !(connect.get(k).is_some_and(|&x| x >= 1.0 && x <= num_nodes as f64 && x.fract() == 0.0)))
    {
        return Err(whole(format!(
            "element {} of block {} names node {}; nodes are 1..={num_nodes}",
            e / blk.nodes_per_elem + 1,
            layout.block_id(blk.index),
            connect.get(e).copied().unwrap_or(f64::NAN)
        )));
    }
    Ok(connect[..blk.count * blk.nodes_per_elem].iter().map(|&x| x as u32 - 1).collect())
}

/// Whether an element of `nodes` nodes read as `cell_type` drops only a
/// centre node inside it (TET5, TETRA11, HEX9, WEDGE16: the last node), so its
/// faces keep every node and it conforms with its neighbours as read.
fn drops_centre_only(cell_type: CellType, nodes: usize) -> bool {
    nodes == cell_type.num_nodes() + 1
        && matches!(
            cell_type,
            CellType::Tetra | CellType::QuadraticTetra | CellType::Hexahedron | CellType::QuadraticWedge
        )
}

/// Node orders to try for a quadratic Exodus element of `nodes` nodes read
/// as `cell_type`, first match wins: entry i is the Exodus node (0-based) at
/// VTK's node i, where numbers from `nodes` on are the points the reader
/// adds ([`Completion`]: TETRA8's six edges in VTK's order, then the body).
/// First Exodus's own (the PATRAN convention of the Exodus II manual,
/// Schoof & Yarberry, "EXODUS II: A Finite Element Data Model", 1994, and
/// its SEACAS successor's element figures and Ioss element topologies: a
/// hexahedron's and wedge's mid-edge nodes bottom, vertical, top — VTK's go
/// bottom, top, vertical; HEX27's centre first, then faces −z, +z, −x, +x,
/// −y, +y; the tetrahedron's face nodes as Ioss's Tet8, Tet14 and Tet15 list
/// them (TETRA14/15: 10 on 0-2-1, 11 on 1-2-3, 12 on 0-3-2, 13 on 0-1-3;
/// TETRA8: 4 on 0-1-3, 5 on 1-2-3, 6 on 0-2-1, 7 on 0-3-2), and for TETRA15
/// two more seen in the documents — the sides' order (10 on 0-1-3 … 13 on
/// 0-2-1) and the manual's figure (10 the body, 11 on 0-1-2, 12 on 1-2-3, 13
/// on 0-2-3, 14 on 0-1-3)), then VTK's own (some writers, e.g. meshio,
/// store VTK's order under Exodus names). Face and body nodes sit at
/// distinct places, so at most one order fits a proper element. The reader
/// keeps the first that puts every element's nodes in their straight-sided
/// places ([`CellType::higher_order_nodes_in_place`]) and else reduces the
/// block to its corners.
fn node_orders(cell_type: CellType, nodes: usize) -> Vec<Vec<usize>> {
    const HEX20: [usize; 20] = [0, 1, 2, 3, 4, 5, 6, 7, 8, 9, 10, 11, 16, 17, 18, 19, 12, 13, 14, 15];
    const WEDGE15: [usize; 15] = [0, 1, 2, 3, 4, 5, 6, 7, 8, 12, 13, 14, 9, 10, 11];
    const TET10: [usize; 10] = [0, 1, 2, 3, 4, 5, 6, 7, 8, 9];
    let then = |head: &[usize], tail: &[usize]| -> Vec<usize> { head.iter().chain(tail).copied().collect() };
    let identity: Vec<usize> = (0..cell_type.num_nodes()).collect();
    // VTK's 15-node tetrahedron: faces 0-1-2, 0-1-3, 1-2-3, 0-2-3, then the body.
    let exodus: Vec<Vec<usize>> = match (cell_type, nodes) {
        (CellType::QuadraticHexahedron, _) => vec![HEX20.to_vec()],
        (CellType::TriquadraticHexahedron, _) => vec![then(&HEX20, &[23, 24, 25, 26, 21, 22, 20])],
        (CellType::QuadraticWedge, _) => vec![WEDGE15.to_vec()],
        (CellType::BiquadraticWedge, _) => vec![then(&WEDGE15, &[15, 16, 17])],
        // TETRA8: corners, faces; its edges (8..14) and body (14) added.
        (CellType::QuadraticTetraWithCentres, 8) => vec![
            then(&[0, 1, 2, 3, 8, 9, 10, 11, 12, 13], &[6, 4, 5, 7, 14]),
            then(&[0, 1, 2, 3, 8, 9, 10, 11, 12, 13], &[7, 4, 5, 6, 14]),
        ],
        // TETRA14 (the body, 14, added) and TETRA15.
        (CellType::QuadraticTetraWithCentres, _) => vec![
            then(&TET10, &[10, 13, 11, 12, 14]),
            then(&TET10, &[13, 10, 11, 12, 14]),
            then(&TET10, &[11, 14, 12, 13, 10]),
        ],
        // WEDGE20 (Ioss_Wedge20: triangles 15 on 0-2-1 and 16 on 3-4-5,
        // quads 17 on 1-2-5-4, 18 on 0-3-5-2, 19 on 0-1-4-3; the body, 20,
        // added) and WEDGE21 (Ioss_Wedge21: the same but the body 17 and
        // the quads 18, 19, 20).
        (CellType::QuadraticWedgeWithCentres, 20) => vec![then(&WEDGE15, &[15, 16, 19, 17, 18, 20])],
        (CellType::QuadraticWedgeWithCentres, _) => vec![then(&WEDGE15, &[15, 16, 20, 18, 19, 17])],
        // PYRAMID18 and PYRAMID19 (Ioss_Pyramid18/19): VTK's order already
        // — the 13 nodes, the base's centre, the triangles' 0-1-4 … 3-0-4,
        // the body (PYRAMID18's added).
        _ => vec![],
    };
    let mut orders: Vec<Vec<usize>> = exodus.into_iter().filter(|o| *o != identity).collect();
    orders.push(identity);
    orders
}

fn whole(m: impl Into<String>) -> FormatError {
    FormatError::new(Location::Whole, m)
}

fn need<'f>(f: &'f NetCdf<'_>, name: &str) -> Result<&'f Variable, FormatError> {
    f.var(name).ok_or_else(|| whole(format!("no variable '{name}' (is this an Exodus II file?)")))
}

/// The time of each step (`time_whole`; empty when the file has no steps).
pub fn times(bytes: &[u8]) -> Result<Vec<f64>, FormatError> {
    times_of(&NetCdf::parse(bytes)?)
}

fn times_of(f: &NetCdf<'_>) -> Result<Vec<f64>, FormatError> {
    let steps = f.num_records;
    match f.var("time_whole") {
        Some(t) if steps > 0 => (0..steps).map(|r| f.read(t, Some(r)).map(|v| v[0])).collect(),
        _ => Ok(Vec::new()),
    }
}

/// A volume block that is read: its index (0-based, `connect{index+1}`),
/// cell type, nodes per element, and where its cells start among all.
struct BlockLayout {
    index: usize,
    cell_type: CellType,
    nodes_per_elem: usize,
    first: usize,
    count: usize,
}

/// Which blocks become cells, from the variables' shapes and attributes
/// alone (the connectivity is not read): what the mesh and every time
/// step's element variables are laid out by.
struct Layout {
    blocks: Vec<BlockLayout>,
    block_ids: Vec<f64>,
    num_cells: usize,
    skipped: Vec<String>,
}

impl Layout {
    fn of(f: &NetCdf<'_>) -> Result<Layout, FormatError> {
        let num_blocks = f.dim_len("num_el_blk").unwrap_or(0);
        // Without `eb_prop1` a block's id is its number ([`Layout::block_id`]):
        // nothing is allocated from the header's count.
        let block_ids = match f.var("eb_prop1") {
            Some(v) => f.read(v, None)?,
            None => Vec::new(),
        };
        // The blocks that have connectivity, from the variables' names (a
        // null block has none): the header's block count alone never
        // drives a loop.
        let mut with_connect: Vec<usize> = f
            .vars
            .iter()
            .filter_map(|v| v.name.strip_prefix("connect")?.parse::<usize>().ok())
            .filter(|&i| (1..=num_blocks).contains(&i))
            .map(|i| i - 1)
            .collect();
        with_connect.sort_unstable();
        with_connect.dedup();
        let mut layout = Layout { blocks: Vec::new(), block_ids, num_cells: 0, skipped: Vec::new() };
        for b in with_connect {
            let name = format!("connect{}", b + 1);
            let Some(connect) = f.var(&name) else {
                continue;
            };
            let shape = f.shape(connect);
            let elem_type = connect.text_attr("elem_type").unwrap_or("").to_string();
            let [n_elems, per] = shape[..] else {
                return Err(whole(format!("'{name}' has shape {shape:?}, expected 2-D")));
            };
            // The cells' count lays out every step's element fields: the
            // connectivity must be there (the header's shape alone never
            // sizes an allocation).
            f.check_within_file(connect)?;
            let Some(ct) = cell_type(&elem_type, per) else {
                let plural = if n_elems == 1 { "" } else { "s" };
                layout.skipped.push(format!("block {} ({elem_type}, {n_elems} element{plural})", layout.block_id(b)));
                continue;
            };
            layout.blocks.push(BlockLayout {
                index: b,
                cell_type: ct,
                nodes_per_elem: per,
                first: layout.num_cells,
                count: n_elems,
            });
            layout.num_cells += n_elems;
        }
        Ok(layout)
    }

    fn block_id(&self, b: usize) -> f64 {
        self.block_ids.get(b).copied().unwrap_or((b + 1) as f64)
    }
}

/// The fields of one time step: nodal variables as point fields, `block_id`
/// and the element variables as cell fields, and notes.
#[derive(Debug, Clone, Default)]
pub struct StepFields {
    pub point_fields: Vec<Field>,
    pub cell_fields: Vec<Field>,
    pub notes: Vec<String>,
}

/// The fields of time step `step` (0-based) of an Exodus II file held in
/// memory, as [`read`] gives them for that step, without reading the
/// coordinates or the connectivity: a time series maps each later step onto
/// the mesh read once.
pub fn read_step_fields(bytes: &[u8], step: usize) -> Result<StepFields, FormatError> {
    let f = NetCdf::parse(bytes)?;
    let steps = f.num_records;
    if step >= steps.max(1) {
        return Err(whole(format!("time step {step} asked for; the file has {steps} (0..{})", steps.max(1) - 1)));
    }
    let num_nodes = f.dim_len("num_nodes").unwrap_or(0);
    let layout = Layout::of(&f)?;
    let synthetic = Synthetic::of(&f, &layout, num_nodes)?;
    step_fields(&f, &layout, &synthetic, step)
}

/// The fields of `step`, laid out by `layout`, nodal ones completed at the
/// points `synthetic` adds (see [`StepFields`]).
fn step_fields(f: &NetCdf<'_>, layout: &Layout, synthetic: &Synthetic, step: usize) -> Result<StepFields, FormatError> {
    let num_nodes = synthetic.num_nodes;
    let num_cells = layout.num_cells;
    let mut out = StepFields::default();
    out.cell_fields.push(Field::new(
        "block_id",
        1,
        layout.blocks.iter().flat_map(|b| std::iter::repeat_n(layout.block_id(b.index), b.count)).collect(),
    ));
    if f.num_records == 0 {
        return Ok(out);
    }
    let names = match f.var("name_nod_var") {
        Some(v) => f.read_strings(v)?,
        None => Vec::new(),
    };
    // The older combined array (variable × node at each step), read once.
    let combined = match f.var("vals_nod_var") {
        Some(v) => Some(f.read(v, Some(step))?),
        None => None,
    };
    for (j, n) in names.iter().enumerate() {
        let values = if let Some(v) = f.var(&format!("vals_nod_var{}", j + 1)) {
            f.read(v, Some(step))?
        } else if let Some(all) = &combined {
            all.get(j * num_nodes..(j + 1) * num_nodes).map(<[f64]>::to_vec).unwrap_or_default()
        } else {
            return Err(whole(format!("nodal variable '{n}' has no values")));
        };
        if values.len() != num_nodes {
            return Err(whole(format!("nodal variable '{n}' has {} values for {num_nodes} nodes", values.len())));
        }
        let mut values = values;
        synthetic.extend(&mut values);
        out.point_fields.push(Field::new(field_name(n, j), 1, values));
    }
    let enames = match f.var("name_elem_var") {
        Some(v) => f.read_strings(v)?,
        None => Vec::new(),
    };
    let truth = match f.var("elem_var_tab") {
        Some(v) => Some(f.read(v, None)?),
        None => None,
    };
    let mut partial = Vec::new();
    for (j, n) in enames.iter().enumerate() {
        let mut values = vec![f64::NAN; num_cells];
        let mut complete = true;
        for blk in &layout.blocks {
            let (b, first, count) = (blk.index, blk.first, blk.count);
            let on = truth.as_ref().is_none_or(|t| t.get(b * enames.len() + j).is_some_and(|&x| x != 0.0));
            let var = f.var(&format!("vals_elem_var{}eb{}", j + 1, b + 1));
            match (on, var) {
                (true, Some(v)) => {
                    let vals = f.read(v, Some(step))?;
                    if vals.len() != count {
                        return Err(whole(format!(
                            "element variable '{n}' has {} values in block {} of {count} elements",
                            vals.len(),
                            b + 1
                        )));
                    }
                    values[first..first + count].copy_from_slice(&vals);
                }
                _ => complete = false,
            }
        }
        if !complete {
            partial.push(n.clone());
        }
        out.cell_fields.push(Field::new(field_name(n, j), 1, values));
    }
    if !partial.is_empty() {
        out.notes.push(format!("element variables missing in some blocks (NaN there): {}", partial.join(", ")));
    }
    Ok(out)
}

/// Reads an Exodus II file held in memory.
pub fn read(bytes: &[u8], opts: &ExodusOptions) -> Result<SourceMesh, FormatError> {
    let f = NetCdf::parse(bytes)?;
    let num_dim = f.dim_len("num_dim").ok_or_else(|| whole("no dimension 'num_dim': not an Exodus II file"))?;
    if num_dim != 3 {
        return Err(whole(format!("a {num_dim}D Exodus mesh has no volume cells; tetkit renders 3D meshes")));
    }
    let num_nodes = f.dim_len("num_nodes").unwrap_or(0);
    // Coordinates: three arrays, or one num_dim × num_nodes array. The
    // points are allocated only once the coordinates were read (which checks
    // them against the file's size), never from the header's count alone.
    let mut points: Vec<[f64; 3]>;
    if let Some(coord) = f.var("coord") {
        if f.shape(coord) != [3, num_nodes] {
            return Err(whole(format!("'coord' has shape {:?}, expected [3, {num_nodes}]", f.shape(coord))));
        }
        let v = f.read(coord, None)?;
        points = (0..num_nodes).map(|k| [v[k], v[num_nodes + k], v[2 * num_nodes + k]]).collect();
    } else {
        points = Vec::new();
        for (c, name) in ["coordx", "coordy", "coordz"].iter().enumerate() {
            let v = f.read(need(&f, name)?, None)?;
            if v.len() != num_nodes {
                return Err(whole(format!("'{name}' has {} values for {num_nodes} nodes", v.len())));
            }
            if c == 0 {
                points = vec![[0.0f64; 3]; num_nodes];
            }
            for (p, x) in points.iter_mut().zip(v) {
                p[c] = x;
            }
        }
    }
    let layout = Layout::of(&f)?;
    let synthetic = Synthetic::of(&f, &layout, num_nodes)?;
    let added: Vec<[f64; 3]> = synthetic
        .sources
        .iter()
        .map(|src| [0, 1, 2].map(|k| src.iter().map(|&n| points[n as usize][k]).sum::<f64>() / src.len() as f64))
        .collect();
    points.extend(added);
    let mut cells = Cells::new();
    let (mut reduced, mut centres, mut completed, mut order_notes) = (0usize, 0usize, 0usize, Vec::new());
    for (b, blk) in layout.blocks.iter().enumerate() {
        let connect = f.read(need(&f, &format!("connect{}", blk.index + 1))?, None)?;
        // Every node number checked once, before any order is tried.
        let ids = node_ids(&connect, blk, num_nodes, &layout)?;
        let id = layout.block_id(blk.index);
        let per = blk.nodes_per_elem;
        // Element e's nodes in `order` (indices past the file's nodes are
        // the element's added points), into a buffer reused for all.
        let mut buf = Vec::with_capacity(blk.cell_type.num_nodes());
        let element = |buf: &mut Vec<u32>, e: usize, order: &[usize]| {
            buf.clear();
            buf.extend(
                order.iter().map(|&k| if k < per { ids[e * per + k] } else { synthetic.of_element(b, e)[k - per] }),
            );
        };
        // (A linear cell's only order is the identity.)
        let orders = node_orders(blk.cell_type, per);
        let quadratic = !blk.cell_type.straight_sided_parents().is_empty();
        let chosen = if quadratic {
            orders.iter().position(|order| {
                (0..blk.count).all(|e| {
                    element(&mut buf, e, order);
                    blk.cell_type.higher_order_nodes_in_place(&buf, &points)
                })
            })
        } else {
            Some(0)
        };
        match chosen {
            Some(k) => {
                if k > 0 {
                    order_notes.push(format!(
                        "block {id}'s {} nodes are in VTK's order, not Exodus's (as some writers store them): read so",
                        blk.cell_type.num_nodes()
                    ));
                }
                for e in 0..blk.count {
                    element(&mut buf, e, &orders[k]);
                    cells.push(blk.cell_type, &buf);
                }
            }
            None => {
                order_notes.push(format!(
                    "block {id}'s {}-node elements have nodes away from where Exodus's (or VTK's) order puts them: reduced to their corners",
                    blk.cell_type.num_nodes()
                ));
                let corners: Vec<usize> = (0..blk.cell_type.linear().num_nodes()).collect();
                for e in 0..blk.count {
                    element(&mut buf, e, &corners);
                    cells.push(blk.cell_type.linear(), &buf);
                }
                reduced += blk.count;
            }
        }
        if drops_centre_only(blk.cell_type, blk.nodes_per_elem) {
            centres += blk.count;
        } else if completion(blk.cell_type, per) != Completion::None && chosen.is_some() {
            completed += blk.count;
        } else if blk.nodes_per_elem > blk.cell_type.num_nodes() {
            reduced += blk.count;
        }
    }
    // Elements cut at their nodes beside reduced ones would not conform with them.
    let also = if reduced > 0 { cells.reduce_to_corners() } else { 0 };
    let format = if f.is_netcdf4() { "Exodus II (netCDF-4/HDF5)" } else { "Exodus II" };
    let mut mesh = SourceMesh { format: format.to_string(), points, ..Default::default() };
    let steps = f.num_records;
    let step = opts.time_step.unwrap_or(0);
    if opts.time_step.is_some() && step >= steps.max(1) {
        return Err(whole(format!("time step {step} asked for; the file has {steps} (0..{})", steps.max(1) - 1)));
    }
    let fields = step_fields(&f, &layout, &synthetic, step)?;
    mesh.point_fields = fields.point_fields;
    mesh.cell_fields = fields.cell_fields;
    mesh.notes = fields.notes;
    if steps > 0 {
        let times = times_of(&f)?;
        let t = times.get(step).copied().unwrap_or(f64::NAN);
        mesh.notes.push(match times.as_slice() {
            [first, .., last] => format!(
                "{steps} time steps (t = {first} … {last}); fields of step {step} (t = {t}); --time-step N picks another"
            ),
            _ => format!("1 time step (t = {t})"),
        });
    }
    mesh.notes.extend(order_notes);
    if completed > 0 {
        mesh.notes.push(format!(
            "completed {completed} elements with face nodes but no body node (TETRA8, TETRA14, WEDGE20, PYRAMID18) \
             by {} added points (a body point at the mean of each element's nodes; TETRA8's mid-edge points at \
             their corners' mean; values the same means) and cut them at all their nodes",
            synthetic.sources.len()
        ));
    }
    if centres > 0 {
        mesh.notes.push(format!(
            "read {centres} elements without their centre node (TET5, TETRA11, HEX9, WEDGE16: the node inside the element; its faces keep all theirs)"
        ));
    }
    if reduced > 0 {
        mesh.notes.push(format!("reduced {reduced} higher-order elements to their corner nodes"));
    }
    if also > 0 {
        mesh.notes.push(format!(
            "reduced {also} quadratic elements to their corners as well, so that they conform with those"
        ));
    }
    if !layout.skipped.is_empty() {
        mesh.notes.push(format!("skipped element blocks that are not volume cells: {}", layout.skipped.join(", ")));
    }
    mesh.blocks.push(Block::Unstructured(cells));
    mesh.check().map_err(whole)?;
    Ok(mesh)
}

/// A variable's name, or `variable_J` when the file leaves it blank.
fn field_name(name: &str, j: usize) -> String {
    if name.is_empty() {
        format!("variable_{}", j + 1)
    } else {
        name.to_string()
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::netcdf::tests::Writer;

    /// Two tets (one TETRA block) and a HEX8 block over 12 nodes, with two
    /// time steps of a nodal and an element variable.
    fn file() -> Writer {
        let names = |list: &[&str]| -> Vec<f64> {
            list.iter().flat_map(|n| format!("{n:\0<8}").into_bytes().into_iter().map(f64::from)).collect()
        };
        let coord: Vec<f64> = (0..12)
            .map(|i| (i % 2) as f64)
            .chain((0..12).map(|i| (i / 2 % 2) as f64))
            .chain((0..12).map(|i| (i / 4) as f64))
            .collect();
        Writer {
            dims: vec![
                ("time_step".into(), 0),
                ("num_dim".into(), 3),
                ("num_nodes".into(), 12),
                ("num_el_blk".into(), 2),
                ("num_el_in_blk1".into(), 1),
                ("num_nod_per_el1".into(), 4),
                ("num_el_in_blk2".into(), 1),
                ("num_nod_per_el2".into(), 8),
                ("num_nod_var".into(), 1),
                ("num_elem_var".into(), 1),
                ("len_name".into(), 8),
            ],
            vars: vec![
                ("coord".into(), vec![1, 2], 6, vec![], coord),
                ("eb_prop1".into(), vec![3], 4, vec![], vec![10.0, 20.0]),
                (
                    "connect1".into(),
                    vec![4, 5],
                    4,
                    vec![("elem_type".into(), "TETRA".into())],
                    vec![1.0, 2.0, 3.0, 5.0],
                ),
                (
                    "connect2".into(),
                    vec![6, 7],
                    4,
                    vec![("elem_type".into(), "HEX8".into())],
                    vec![5.0, 6.0, 8.0, 7.0, 9.0, 10.0, 12.0, 11.0],
                ),
                ("name_nod_var".into(), vec![8, 10], 2, vec![], names(&["Temp"])),
                ("name_elem_var".into(), vec![9, 10], 2, vec![], names(&["Stress"])),
                ("elem_var_tab".into(), vec![3, 9], 4, vec![], vec![0.0, 1.0]),
                ("time_whole".into(), vec![0], 6, vec![], vec![0.0, 2.5]),
                ("vals_nod_var1".into(), vec![0, 2], 6, vec![], (0..24).map(f64::from).collect()),
                ("vals_elem_var1eb2".into(), vec![0, 6], 6, vec![], vec![100.0, 200.0]),
            ],
            num_records: 2,
        }
    }

    /// Regression (fuzzing): the header's node and block counts drove an
    /// allocation and a loop before any data was read, so a 100-byte file
    /// declaring 2³¹ nodes or blocks could abort or spin. Now both are an
    /// error at the first read past the end, at once.
    #[test]
    fn huge_declared_counts_are_errors_not_allocations() {
        for (dim, value) in [("num_nodes", (1u32 << 31) - 1), ("num_el_blk", (1 << 31) - 1)] {
            // The header now declares more than the data written: the
            // dimension's length follows its name, padded to 4 bytes.
            let mut bytes = file().write(true);
            let at = bytes.windows(dim.len()).position(|w| w == dim.as_bytes()).unwrap() + dim.len().div_ceil(4) * 4;
            bytes[at..at + 4].copy_from_slice(&value.to_be_bytes());
            let t = std::time::Instant::now();
            let r = read(&bytes, &ExodusOptions::default());
            assert!(r.is_err() || dim == "num_el_blk", "{dim}");
            assert!(t.elapsed().as_secs_f64() < 5.0, "{dim}: {:?}", t.elapsed());
        }
    }

    #[test]
    fn blocks_fields_and_time_steps() {
        for offset64 in [false, true] {
            let bytes = file().write(offset64);
            let m = read(&bytes, &ExodusOptions::default()).unwrap();
            assert_eq!(m.points.len(), 12);
            assert_eq!(m.points[11], [1.0, 1.0, 2.0]);
            let Block::Unstructured(c) = &m.blocks[0] else { panic!("unstructured") };
            assert_eq!(c.types, vec![CellType::Tetra, CellType::Hexahedron]);
            assert_eq!(c.nodes(0), &[0, 1, 2, 4]);
            let temp = m.point_fields.iter().find(|f| f.name == "Temp").unwrap();
            assert_eq!(temp.values, (0..12).map(f64::from).collect::<Vec<_>>());
            let stress = m.cell_fields.iter().find(|f| f.name == "Stress").unwrap();
            assert!(stress.values[0].is_nan() && stress.values[1] == 100.0);
            let ids = m.cell_fields.iter().find(|f| f.name == "block_id").unwrap();
            assert_eq!(ids.values, vec![10.0, 20.0]);
            assert!(m.notes.iter().any(|n| n.contains("2 time steps (t = 0 … 2.5)")), "{:?}", m.notes);
            let m1 = read(&bytes, &ExodusOptions { time_step: Some(1) }).unwrap();
            let temp = m1.point_fields.iter().find(|f| f.name == "Temp").unwrap();
            assert_eq!(temp.values[0], 12.0);
            assert_eq!(m1.cell_fields.iter().find(|f| f.name == "Stress").unwrap().values[1], 200.0);
            let e = read(&bytes, &ExodusOptions { time_step: Some(2) }).unwrap_err();
            assert!(e.message.contains("the file has 2"), "{e}");
        }
    }

    #[test]
    fn bad_node_numbers_and_truncation_are_errors() {
        let mut w = file();
        w.vars[2].4[3] = 13.0;
        let e = read(&w.write(false), &ExodusOptions::default()).unwrap_err();
        assert!(e.message.contains("names node 13"), "{e}");
        let bytes = file().write(false);
        for cut in (0..bytes.len()).step_by(7) {
            let _ = read(&bytes[..cut], &ExodusOptions::default());
        }
    }

    /// A step's fields alone are what the whole read gives for that step;
    /// a step beyond the file and truncated bytes are errors.
    /// Regression (fuzz finding): a 2.3 kB file declaring 150,994,958
    /// records but no record variable was read as that many time steps,
    /// each read once (14 s, 1.2 GB); it has none.
    #[test]
    fn declared_records_without_record_variables_are_no_steps() {
        let file = include_bytes!("../../../tests/data/exodus/fuzz_records_without_record_vars.exo");
        let bytes = &file[1..];
        assert_eq!(NetCdf::parse(bytes).unwrap().num_records, 0);
        let m = read(bytes, &ExodusOptions::default()).unwrap();
        assert!(!m.notes.iter().any(|n| n.contains("time steps")), "{:?}", m.notes);
        assert!(read(bytes, &ExodusOptions { time_step: Some(1) }).is_err());
    }

    /// Regression (fuzz finding, 2026-12-06): a 2.3 kB 64-bit-offset file
    /// whose record variable starts near 2^64 made the offset of its second
    /// record overflow (a panic with overflow checks, a wrapped offset
    /// without); it is an error naming the record now.
    #[test]
    fn a_record_offset_past_2_64_is_an_error() {
        let file = include_bytes!("../../../tests/data/exodus/fuzz_record_offset_overflow.exo");
        let (step, bytes) = file.split_first().unwrap();
        for time_step in [usize::from(step & 3), 0, 1, 2, 3] {
            let _ = read(bytes, &ExodusOptions { time_step: Some(time_step) });
        }
    }

    /// Regression (fuzz finding, 2026-12-06): an 8.7 kB file whose block
    /// declares 1,634,874,114 HEX20 elements (a connectivity far past the
    /// file's end) made a step's fields read alone (`read_step_fields`, as a
    /// time series reads its later steps) lay out a `block_id` value per
    /// declared cell, 13 GB, before any data was read; both reads now
    /// refuse the block's connectivity at once.
    #[test]
    fn a_block_declared_past_the_file_end_allocates_nothing() {
        let file = include_bytes!("../../../tests/data/exodus/fuzz_face_nodes_oom.exo");
        let bytes = &file[1..];
        let e = read_step_fields(bytes, 0).unwrap_err();
        assert!(e.message.contains("'connect3'") && e.message.contains("runs past the end of the file"), "{e}");
        let e = read(bytes, &ExodusOptions::default()).unwrap_err();
        assert!(e.message.contains("runs past the end of the file"), "{e}");
    }

    /// Regression (fuzz finding): a 2.7 kB file declaring 2^30 element
    /// blocks without `eb_prop1` made the reader list an id for each (8 GB,
    /// 8 s) before finding it had no values; the ids are now numbered as
    /// asked, and the file is refused at once.
    #[test]
    fn a_huge_block_count_allocates_nothing() {
        let bytes = include_bytes!("../../../tests/data/exodus/fuzz_block_count_2e9.exo");
        let f = NetCdf::parse(bytes).unwrap();
        assert!(f.dim_len("num_el_blk").unwrap() > 1 << 29);
        let layout = Layout::of(&f).unwrap();
        assert!(layout.block_ids.is_empty());
        assert_eq!(layout.block_id(7), 8.0);
        let e = read(bytes, &ExodusOptions { time_step: Some(1) }).unwrap_err();
        assert!(e.message.contains("has no values"), "{e}");
    }

    #[test]
    fn step_fields_equal_the_whole_read() {
        for offset64 in [false, true] {
            let bytes = file().write(offset64);
            for step in 0..2 {
                let m = read(&bytes, &ExodusOptions { time_step: Some(step) }).unwrap();
                let f = read_step_fields(&bytes, step).unwrap();
                // Bit for bit (NaN where a block lacks an element variable).
                let bits = |fs: &[Field]| -> Vec<(String, Vec<u64>)> {
                    fs.iter().map(|f| (f.name.clone(), f.values.iter().map(|v| v.to_bits()).collect())).collect()
                };
                assert_eq!(bits(&f.point_fields), bits(&m.point_fields), "step {step}");
                assert_eq!(bits(&f.cell_fields), bits(&m.cell_fields), "step {step}");
            }
            let e = read_step_fields(&bytes, 2).unwrap_err();
            assert!(e.message.contains("time step 2 asked for; the file has 2"), "{e}");
            for cut in (0..bytes.len()).step_by(5) {
                let _ = read_step_fields(&bytes[..cut], 1);
            }
        }
    }

    /// A file of one element block per entry, each element given by its
    /// node positions in the file's order; nodes at equal positions are one
    /// node (so neighbours share their face's nodes).
    fn blocks_file(blocks: &[(&str, Vec<Vec<[f64; 3]>>)]) -> Writer {
        let mut nodes: Vec<[f64; 3]> = Vec::new();
        let mut node_of = std::collections::HashMap::new();
        let mut dims = vec![("time_step".to_string(), 0), ("num_dim".into(), 3)];
        let mut vars = Vec::new();
        let mut connects = Vec::new();
        for (elem_type, elems) in blocks {
            let ids: Vec<f64> = elems
                .iter()
                .flatten()
                .map(|p| {
                    let key = p.map(f64::to_bits);
                    *node_of.entry(key).or_insert_with(|| {
                        nodes.push(*p);
                        nodes.len() as f64
                    })
                })
                .collect();
            connects.push((elem_type.to_string(), elems.len(), elems[0].len(), ids));
        }
        dims.push(("num_nodes".into(), nodes.len()));
        dims.push(("num_el_blk".into(), blocks.len()));
        for (b, (_, count, per, _)) in connects.iter().enumerate() {
            dims.push((format!("num_el_in_blk{}", b + 1), *count));
            dims.push((format!("num_nod_per_el{}", b + 1), *per));
        }
        let coord: Vec<f64> = (0..3).flat_map(|k| nodes.iter().map(move |p| p[k])).collect();
        vars.push(("coord".into(), vec![1, 2], 6, vec![], coord));
        for (b, (elem_type, _, _, ids)) in connects.into_iter().enumerate() {
            let (d_el, d_per) = (4 + 2 * b, 5 + 2 * b);
            vars.push((format!("connect{}", b + 1), vec![d_el, d_per], 4, vec![("elem_type".into(), elem_type)], ids));
        }
        Writer { dims, vars, num_records: 0 }
    }

    /// The tets and total volume of `m` as tetprep converts it, checked: no
    /// tet re-oriented or dropped as flat (a cell cut at its nodes in the
    /// wrong order shows so), and the tets conform (face adjacency builds).
    /// (The crate's integration tests have the same helper, which a unit
    /// test cannot reach.)
    fn converted(m: &SourceMesh, label: &str) -> (usize, f64) {
        let (mesh, report) = tet_mesh::tetrahedralize(m, &Default::default(), &mut |_| {}).unwrap();
        assert!(
            !report.findings.iter().any(|f| matches!(
                f,
                tet_mesh::Finding::ReorientedTets { .. } | tet_mesh::Finding::DroppedZeroVolumeTets { .. }
            )),
            "{label}: {:?}",
            report.findings
        );
        tet_mesh::build_adjacency(&mesh.points, &mesh.tets).expect("conforming");
        (mesh.tets.len(), tet_mesh::mesh_stats(&mesh.points, &mesh.tets, &mesh.scalar).total_volume)
    }

    /// TET5, TETRA11 and HEX9 (a centre node last) are read as TETRA4,
    /// TETRA10 (cut at its ten nodes) and HEX8, with a note, and nothing
    /// else is reduced: their faces keep every node.
    #[test]
    fn centre_node_variants_drop_only_their_centre() {
        let tet = [[0., 0., 0.], [1., 0., 0.], [0., 1., 0.], [0., 0., 1.]];
        let mid = |a: usize, b: usize| std::array::from_fn::<f64, 3, _>(|k| (tet[a][k] + tet[b][k]) / 2.0);
        let mut tet11: Vec<[f64; 3]> = tet.to_vec();
        tet11.extend([mid(0, 1), mid(1, 2), mid(0, 2), mid(0, 3), mid(1, 3), mid(2, 3), [0.25; 3]]);
        let shift = |e: &[[f64; 3]], dx: f64| e.iter().map(|p| [p[0] + dx, p[1], p[2]]).collect::<Vec<_>>();
        let mut tet5 = tet.to_vec();
        tet5.push([0.25; 3]);
        let mut hex = tet_mesh::split::UNIT_HEX.to_vec();
        hex.push([0.5; 3]);
        let file = blocks_file(&[
            ("TETRA11", vec![shift(&tet11, 0.0)]),
            ("TET5", vec![shift(&tet5, 3.0)]),
            ("HEX9", vec![shift(&hex, 6.0)]),
        ]);
        let m = read(&file.write(false), &ExodusOptions::default()).unwrap();
        let Block::Unstructured(c) = &m.blocks[0] else { panic!("unstructured") };
        assert_eq!(c.types, vec![CellType::QuadraticTetra, CellType::Tetra, CellType::Hexahedron]);
        assert!(m.notes.iter().any(|n| n.contains("read 3 elements without their centre node")), "{:?}", m.notes);
        assert!(!m.notes.iter().any(|n| n.contains("reduced")), "{:?}", m.notes);
        let (mesh, _) = tet_mesh::tetrahedralize(&m, &Default::default(), &mut |_| {}).unwrap();
        assert_eq!(mesh.tets.len(), 8 + 1 + 6);
        let v = tet_mesh::mesh_stats(&mesh.points, &mesh.tets, &mesh.scalar).total_volume;
        assert!((v - (2.0 / 6.0 + 1.0)).abs() < 1e-12, "{v}");
    }

    /// TETRA8, TETRA14, WEDGE20 and PYRAMID18 (face nodes, no body node;
    /// TETRA8 no mid-edge nodes either) in Ioss's node order, and TETRA15 in
    /// Ioss's, on a skewed lattice, two elements a block sharing a face:
    /// each is completed into the cell with all its nodes (a body point, and
    /// TETRA8's mid-edge points shared by both elements), cut at them into
    /// positive conforming tets of the exact volume, and a field linear in
    /// space is exact at every added point, in the mesh read and in each
    /// time step's fields read alone.
    #[test]
    fn face_node_elements_are_completed_and_cut_at_all_nodes() {
        let skew = |p: [f64; 3]| {
            [p[0] + 0.3 * p[1] - 0.1 * p[2], 0.2 * p[0] + p[1] + 0.25 * p[2], -0.1 * p[0] + 0.15 * p[1] + 1.1 * p[2]]
        };
        let det = 1.0 * (1.1 - 0.0375) - 0.3 * (0.22 + 0.025) - 0.1 * (0.03 + 0.1);
        let mean = |c: &[[f64; 3]], ps: &[usize]| {
            [0, 1, 2].map(|k| ps.iter().map(|&i| c[i][k]).sum::<f64>() / ps.len() as f64)
        };
        let element = |c: &[[f64; 3]], extra: &[&[usize]]| -> Vec<[f64; 3]> {
            let mut v = c.to_vec();
            v.extend(extra.iter().map(|ps| mean(c, ps)));
            v
        };
        let tet_edges: [&[usize]; 6] = [&[0, 1], &[1, 2], &[2, 0], &[0, 3], &[1, 3], &[2, 3]];
        // Two tets sharing face 1-2-3 (the second mirrored through it).
        let tets = [
            [[0., 0., 0.], [1., 0., 0.], [0., 1., 0.], [0., 0., 1.]],
            [[1., 1., 1.], [1., 0., 0.], [0., 0., 1.], [0., 1., 0.]],
        ];
        // Ioss_Tet14/15 faces: 10 on 0-2-1, 11 on 1-2-3, 12 on 0-3-2, 13 on 0-1-3.
        let tet_faces: [&[usize]; 4] = [&[0, 2, 1], &[1, 2, 3], &[0, 3, 2], &[0, 1, 3]];
        let tet14 = |c: &[[f64; 3]]| element(c, &[&tet_edges[..], &tet_faces[..]].concat());
        let tet15 = |c: &[[f64; 3]]| element(c, &[&tet_edges[..], &tet_faces[..], &[&[0, 1, 2, 3]]].concat());
        // Ioss_Tet8: 4 on 0-1-3, 5 on 1-2-3, 6 on 0-2-1, 7 on 0-3-2.
        let tet8 = |c: &[[f64; 3]]| element(c, &[&[0, 1, 3], &[1, 2, 3], &[0, 2, 1], &[0, 3, 2]]);
        let wedge =
            |z: f64| [[0., 0., z], [1., 0., z], [0., 1., z], [0., 0., z + 1.], [1., 0., z + 1.], [0., 1., z + 1.]];
        // Ioss_Wedge20: edges bottom, vertical, top; triangles 0-2-1,
        // 3-4-5; quads 1-2-5-4, 0-3-5-2, 0-1-4-3.
        let wedge20 = |z: f64| {
            let e: [&[usize]; 9] = [&[0, 1], &[1, 2], &[2, 0], &[0, 3], &[1, 4], &[2, 5], &[3, 4], &[4, 5], &[5, 3]];
            let f: [&[usize]; 5] = [&[0, 2, 1], &[3, 4, 5], &[1, 2, 5, 4], &[0, 3, 5, 2], &[0, 1, 4, 3]];
            element(&wedge(z), &[&e[..], &f[..]].concat())
        };
        // Ioss_Pyramid18: edges, the base's centre, triangles 0-1-4 … 3-0-4.
        let pyramid18 = |x: f64| {
            let c = [[x, 0., 0.], [x + 1., 0., 0.], [x + 1., 1., 0.], [x, 1., 0.], [x + 0.5, 0.5, 1.]];
            let e: [&[usize]; 8] = [&[0, 1], &[1, 2], &[2, 3], &[3, 0], &[0, 4], &[1, 4], &[2, 4], &[3, 4]];
            let f: [&[usize]; 5] = [&[0, 1, 2, 3], &[0, 1, 4], &[1, 2, 4], &[2, 3, 4], &[3, 0, 4]];
            element(&c, &[&e[..], &f[..]].concat())
        };
        let skewed = |v: Vec<[f64; 3]>| v.into_iter().map(skew).collect::<Vec<_>>();
        let tet_volume = 1.0 / 6.0 + 1.0 / 3.0;
        // (block, VTK's cell type, volume of its two elements, points added)
        type Case<'a> = (&'a str, Vec<Vec<[f64; 3]>>, CellType, f64, usize);
        let cases: Vec<Case> = vec![
            (
                "TETRA8",
                tets.iter().map(|c| skewed(tet8(c))).collect(),
                CellType::QuadraticTetraWithCentres,
                tet_volume,
                9 + 2,
            ),
            (
                "TETRA14",
                tets.iter().map(|c| skewed(tet14(c))).collect(),
                CellType::QuadraticTetraWithCentres,
                tet_volume,
                2,
            ),
            (
                "TETRA15",
                tets.iter().map(|c| skewed(tet15(c))).collect(),
                CellType::QuadraticTetraWithCentres,
                tet_volume,
                0,
            ),
            ("WEDGE20", vec![skewed(wedge20(0.)), skewed(wedge20(1.))], CellType::QuadraticWedgeWithCentres, 1.0, 2),
            (
                "PYRAMID18",
                vec![skewed(pyramid18(0.)), skewed(pyramid18(1.))],
                CellType::TriquadraticPyramid,
                2.0 / 3.0,
                2,
            ),
        ];
        let linear = |p: [f64; 3]| 2.0 * p[0] - 3.0 * p[1] + 0.5 * p[2] + 7.0;
        for (name, elems, ty, volume, added) in cases {
            let mut w = blocks_file(&[(name, elems)]);
            // Two time steps of a nodal field: the linear one, then twice it.
            let num_nodes = w.dims.iter().find(|d| d.0 == "num_nodes").unwrap().1;
            let coord = w.vars[0].4.clone();
            let at = |i: usize| linear([coord[i], coord[num_nodes + i], coord[2 * num_nodes + i]]);
            let values: Vec<f64> = (0..num_nodes).map(at).chain((0..num_nodes).map(|i| 2.0 * at(i))).collect();
            w.dims.push(("num_nod_var".into(), 1));
            w.dims.push(("len_name".into(), 8));
            let (d_var, d_name) = (w.dims.len() - 2, w.dims.len() - 1);
            let label: Vec<f64> = b"T\0\0\0\0\0\0\0".iter().map(|&b| f64::from(b)).collect();
            w.vars.push(("name_nod_var".into(), vec![d_var, d_name], 2, vec![], label));
            w.vars.push(("time_whole".into(), vec![0], 6, vec![], vec![0.0, 1.0]));
            w.vars.push(("vals_nod_var1".into(), vec![0, 2], 6, vec![], values));
            w.num_records = 2;
            let bytes = w.write(false);
            let m = read(&bytes, &ExodusOptions::default()).unwrap();
            let Block::Unstructured(c) = &m.blocks[0] else { panic!("unstructured") };
            assert_eq!(c.types, vec![ty; 2], "{name}");
            assert_eq!(m.points.len(), num_nodes + added, "{name}");
            assert_eq!(
                m.notes.iter().any(|n| n.contains("completed 2 elements") && n.contains(&format!("by {added} added"))),
                added > 0,
                "{name}: {:?}",
                m.notes
            );
            assert!(!m.notes.iter().any(|n| n.contains("reduced")), "{name}: {:?}", m.notes);
            let t = &m.point_fields[0];
            for (i, p) in m.points.iter().enumerate() {
                assert!((t.values[i] - linear(*p)).abs() < 1e-12, "{name}: point {i}");
            }
            for step in 0..2 {
                let f = read_step_fields(&bytes, step).unwrap();
                let ms = read(&bytes, &ExodusOptions { time_step: Some(step) }).unwrap();
                assert_eq!(f.point_fields[0].values, ms.point_fields[0].values, "{name} step {step}");
                assert_eq!(f.point_fields[0].values.len(), num_nodes + added, "{name} step {step}");
            }
            let (tets, v) = converted(&m, name);
            assert!((v - volume * det).abs() < 1e-12, "{name}: volume {v}");
            assert!(tets >= 2 * 12, "{name}: {tets} tets");
        }
    }

    /// Element types with node counts tetkit has no split for (Ioss's cubic
    /// TETRA16: two nodes on each edge) are read by their corners, with a
    /// note — regression: a TETRA16 or HEX32 block was skipped as "not
    /// volume cells", its volume lost. Too few nodes for the shape is still
    /// not a volume cell.
    #[test]
    fn unknown_node_counts_are_read_by_their_corners() {
        let c = [[0., 0., 0.], [1., 0., 0.], [0., 1., 0.], [0., 0., 1.]];
        let mut tet16: Vec<[f64; 3]> = c.to_vec();
        for [a, b] in TET_EDGES {
            for t in [1.0 / 3.0, 2.0 / 3.0] {
                tet16.push([0, 1, 2].map(|k| c[a][k] + t * (c[b][k] - c[a][k])));
            }
        }
        let m = read(&blocks_file(&[("TETRA16", vec![tet16])]).write(false), &ExodusOptions::default()).unwrap();
        let Block::Unstructured(cells) = &m.blocks[0] else { panic!("unstructured") };
        assert_eq!(cells.types, vec![CellType::Tetra]);
        assert!(m.notes.iter().any(|n| n.contains("reduced 1 higher-order elements")), "{:?}", m.notes);
        let (tets, v) = converted(&m, "TETRA16");
        assert_eq!(tets, 1);
        assert!((v - 1.0 / 6.0).abs() < 1e-12, "{v}");
        assert_eq!(cell_type("TETRA", 3), None);
        assert_eq!(cell_type("HEX32", 32), Some(CellType::Hexahedron));
    }

    /// WEDGE16 (WEDGE15 and a body node, Ioss_Wedge16) is read as WEDGE15
    /// without its centre, cut at its 15 nodes.
    #[test]
    fn wedge16_drops_only_its_centre() {
        let c = [[0., 0., 0.], [1., 0., 0.], [0., 1., 0.], [0., 0., 1.], [1., 0., 1.], [0., 1., 1.]];
        let e = [[0, 1], [1, 2], [2, 0], [0, 3], [1, 4], [2, 5], [3, 4], [4, 5], [5, 3]];
        let mut w16: Vec<[f64; 3]> = c.to_vec();
        w16.extend(e.iter().map(|&[a, b]| [0, 1, 2].map(|k| (c[a][k] + c[b][k]) / 2.0)));
        w16.push([1.0 / 3.0, 1.0 / 3.0, 0.5]);
        let m = read(&blocks_file(&[("WEDGE16", vec![w16])]).write(false), &ExodusOptions::default()).unwrap();
        let Block::Unstructured(cells) = &m.blocks[0] else { panic!("unstructured") };
        assert_eq!(cells.types, vec![CellType::QuadraticWedge]);
        assert!(m.notes.iter().any(|n| n.contains("read 1 elements without their centre node")), "{:?}", m.notes);
        let (mesh, _) = tet_mesh::tetrahedralize(&m, &Default::default(), &mut |_| {}).unwrap();
        let v = tet_mesh::mesh_stats(&mesh.points, &mesh.tets, &mesh.scalar).total_volume;
        assert!((v - 0.5).abs() < 1e-12, "{v}");
    }

    /// PYRAMID19 (SEACAS's Ioss_Pyramid19: the 13 nodes, the base's centre,
    /// triangles 0-1-4 … 3-0-4, the body) is VTK's 19-node pyramid as it
    /// stands, cut at all its nodes into conforming tets of the volume.
    #[test]
    fn pyramid19_is_cut_at_its_nodes() {
        let pyramid19 = |x: f64| {
            let c = [[x, 0., 0.], [x + 1., 0., 0.], [x + 1., 1., 0.], [x, 1., 0.], [x + 0.5, 0.5, 1.]];
            let mid = |ps: &[usize]| [0, 1, 2].map(|k| ps.iter().map(|&i| c[i][k]).sum::<f64>() / ps.len() as f64);
            let mut v = c.to_vec();
            for p in [[0, 1], [1, 2], [2, 3], [3, 0], [0, 4], [1, 4], [2, 4], [3, 4]] {
                v.push(mid(&p));
            }
            v.push(mid(&[0, 1, 2, 3]));
            for t in [[0, 1, 4], [1, 2, 4], [2, 3, 4], [3, 0, 4]] {
                v.push(mid(&t));
            }
            v.push([x + 0.5, 0.5, 0.25]);
            v
        };
        let file = blocks_file(&[("PYRAMID19", vec![pyramid19(0.0), pyramid19(1.0)])]);
        let m = read(&file.write(false), &ExodusOptions::default()).unwrap();
        let Block::Unstructured(c) = &m.blocks[0] else { panic!("unstructured") };
        assert_eq!(c.types, vec![CellType::TriquadraticPyramid; 2]);
        assert!(m.notes.is_empty(), "{:?}", m.notes);
        let (tets, v) = converted(&m, "PYRAMID19");
        assert!((v - 2.0 / 3.0).abs() < 1e-12, "{v}");
        assert!(tets >= 2 * 13, "{tets} tets");
    }

    /// Exodus's quadratic elements, written in Exodus's node order (the
    /// manual's figures: written out here independently of the reader's
    /// tables; HEX27 as its lattice: centre 21, faces 22 −z, 23 +z, 24 −x,
    /// 25 +x, 26 −y, 27 +y, 1-based), on a skewed lattice: each block of two
    /// elements sharing a face reads as VTK's quadratic cell and converts
    /// into positive conforming tets of the exact volume. The same written
    /// in VTK's order (as meshio does) is read so, with a note; nodes in
    /// neither order are reduced to corners, with a note.
    #[test]
    fn quadratic_elements_in_exodus_order_are_cut_at_their_nodes() {
        let skew = |p: [f64; 3]| {
            [p[0] + 0.3 * p[1] - 0.1 * p[2], 0.2 * p[0] + p[1] + 0.25 * p[2], -0.1 * p[0] + 0.15 * p[1] + 1.1 * p[2]]
        };
        let det = 1.0 * (1.1 - 0.0375) - 0.3 * (0.22 + 0.025) - 0.1 * (0.03 + 0.1);
        let mid = |ps: &[[f64; 3]]| [0, 1, 2].map(|k| ps.iter().map(|p| p[k]).sum::<f64>() / ps.len() as f64);
        let hex_corners = |o: [f64; 3]| tet_mesh::split::UNIT_HEX.map(|c| [o[0] + c[0], o[1] + c[1], o[2] + c[2]]);
        let with_edges = |c: &[[f64; 3]], edges: &[(usize, usize)], extra: &[&[usize]]| -> Vec<[f64; 3]> {
            let mut v = c.to_vec();
            v.extend(edges.iter().map(|&(a, b)| mid(&[c[a], c[b]])));
            v.extend(extra.iter().map(|f| mid(&f.iter().map(|&i| c[i]).collect::<Vec<_>>())));
            v
        };
        // Exodus: bottom edges, vertical edges, top edges.
        let hex_edges =
            [(0, 1), (1, 2), (2, 3), (3, 0), (0, 4), (1, 5), (2, 6), (3, 7), (4, 5), (5, 6), (6, 7), (7, 4)];
        let hex20 = |o| with_edges(&hex_corners(o), &hex_edges, &[]);
        let hex27 = |o| {
            let all: &[usize] = &[0, 1, 2, 3, 4, 5, 6, 7];
            let faces: [&[usize]; 6] =
                [&[0, 1, 2, 3], &[4, 5, 6, 7], &[0, 3, 7, 4], &[1, 2, 6, 5], &[0, 1, 5, 4], &[3, 2, 6, 7]];
            let mut extra = vec![all];
            extra.extend(faces);
            with_edges(&hex_corners(o), &hex_edges, &extra)
        };
        let wedge_corners =
            |z: f64| [[0., 0., z], [1., 0., z], [0., 1., z], [0., 0., z + 1.], [1., 0., z + 1.], [0., 1., z + 1.]];
        let wedge_edges = [(0, 1), (1, 2), (2, 0), (0, 3), (1, 4), (2, 5), (3, 4), (4, 5), (5, 3)];
        let wedge15 = |z| with_edges(&wedge_corners(z), &wedge_edges, &[]);
        let wedge18 = |z| with_edges(&wedge_corners(z), &wedge_edges, &[&[0, 1, 4, 3], &[1, 2, 5, 4], &[2, 0, 3, 5]]);
        // WEDGE21 as SEACAS's Ioss_Wedge21 lists its faces: triangle
        // centres, the body, then quads 1-2-5-4, 0-3-5-2, 0-1-4-3.
        let wedge21 = |z| {
            let faces: [&[usize]; 6] =
                [&[0, 1, 2], &[3, 4, 5], &[0, 1, 2, 3, 4, 5], &[1, 2, 5, 4], &[0, 3, 5, 2], &[0, 1, 4, 3]];
            with_edges(&wedge_corners(z), &wedge_edges, &faces)
        };
        let pyramid = |x: f64, centre: bool| {
            let c = [[x, 0., 0.], [x + 1., 0., 0.], [x + 1., 1., 0.], [x, 1., 0.], [x, 0., 1.]];
            let e = [(0, 1), (1, 2), (2, 3), (3, 0), (0, 4), (1, 4), (2, 4), (3, 4)];
            with_edges(&c, &e, if centre { &[&[0, 1, 2, 3]] } else { &[] })
        };
        let shift =
            |v: Vec<[f64; 3]>, dx: f64| v.into_iter().map(|p| skew([p[0] + dx, p[1], p[2]])).collect::<Vec<_>>();
        // (block, VTK's cell type, volume of its two elements)
        let cases = vec![
            (
                ("HEX20", vec![shift(hex20([0., 0., 0.]), 0.), shift(hex20([0., 0., 1.]), 0.)]),
                CellType::QuadraticHexahedron,
                2.0,
            ),
            (
                ("HEX27", vec![shift(hex27([0., 0., 0.]), 3.), shift(hex27([0., 0., 1.]), 3.)]),
                CellType::TriquadraticHexahedron,
                2.0,
            ),
            (("WEDGE15", vec![shift(wedge15(0.), 6.), shift(wedge15(1.), 6.)]), CellType::QuadraticWedge, 1.0),
            (("WEDGE", vec![shift(wedge18(0.), 9.), shift(wedge18(1.), 9.)]), CellType::BiquadraticWedge, 1.0),
            (
                ("WEDGE21", vec![shift(wedge21(0.), 18.), shift(wedge21(1.), 18.)]),
                CellType::QuadraticWedgeWithCentres,
                1.0,
            ),
            (
                ("PYRAMID13", vec![shift(pyramid(0., false), 12.), shift(pyramid(2., false), 12.)]),
                CellType::QuadraticPyramid,
                2.0 / 3.0,
            ),
            (
                ("PYRAMID", vec![shift(pyramid(0., true), 15.), shift(pyramid(2., true), 15.)]),
                CellType::QuadraticPyramidWithBaseCentre,
                2.0 / 3.0,
            ),
        ];
        for ((name, elems), ty, volume) in cases {
            let order = node_orders(ty, ty.num_nodes());
            let in_vtk_order: Vec<Vec<[f64; 3]>> =
                elems.iter().map(|e| order[0].iter().map(|&k| e[k]).collect()).collect();
            let mut scrambled = elems.clone();
            for e in &mut scrambled {
                let n = e.len();
                e.swap(n - 1, n - 3);
            }
            for (variant, elems, note) in [
                ("exodus", elems, None),
                ("vtk", in_vtk_order, (order.len() > 1).then_some("VTK's order")),
                ("scrambled", scrambled, Some("reduced to their corners")),
            ] {
                let m = read(&blocks_file(&[(name, elems)]).write(false), &ExodusOptions::default()).unwrap();
                let Block::Unstructured(c) = &m.blocks[0] else { panic!("unstructured") };
                let reduced = variant == "scrambled";
                assert_eq!(c.types, vec![if reduced { ty.linear() } else { ty }; 2], "{name} {variant}");
                match note {
                    Some(n) => assert!(m.notes.iter().any(|x| x.contains(n)), "{name} {variant}: {:?}", m.notes),
                    None => assert!(m.notes.is_empty(), "{name} {variant}: {:?}", m.notes),
                }
                let (tets, v) = converted(&m, &format!("{name} {variant}"));
                assert!((v - volume * det).abs() < 1e-12, "{name} {variant}: volume {v}");
                // Cut at their nodes: 13 to 48 tets an element; by corners 2 to 6.
                assert_eq!(tets >= 26, !reduced, "{name} {variant}: {tets} tets");
            }
        }
    }
}
