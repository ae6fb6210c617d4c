//! The sections of both layouts: 4.1's entities, nodes and elements, 2.x's
//! nodes and elements (ASCII and binary), and the data sections.

use super::*;

/// The sections whose 4.1 layout is shared by ASCII and binary files.
#[derive(Debug, Clone, Copy)]
pub(crate) enum Section41 {
    Entities,
    Nodes,
    Elements,
}

impl Section41 {
    pub(crate) fn name(self) -> &'static str {
        match self {
            Section41::Entities => "Entities",
            Section41::Nodes => "Nodes",
            Section41::Elements => "Elements",
        }
    }
}

pub(crate) fn dispatch_41<V: Values>(v: &mut V, s: &mut State, which: Section41) -> Result<(), FormatError> {
    match which {
        Section41::Entities => read_entities_41(v, s),
        Section41::Nodes => read_nodes_41(v, s),
        Section41::Elements => read_elements_41(v, s),
    }
}

/// `$Entities` (4.1): only the physical tags of volumes are kept, to label
/// cells; points, curves and surfaces are read past.
pub(crate) fn read_entities_41<V: Values>(v: &mut V, s: &mut State) -> Result<(), FormatError> {
    let mut counts = [0u64; 4];
    for (dim, count) in counts.iter_mut().enumerate() {
        *count = v.size(
            ["the number of points", "the number of curves", "the number of surfaces", "the number of volumes"][dim],
        )?;
    }
    let mut volume_physical = HashMap::new();
    for (dim, &count) in counts.iter().enumerate() {
        for _ in 0..count {
            let tag = v.int("an entity tag")?;
            let box_values = if dim == 0 { 3 } else { 6 };
            for _ in 0..box_values {
                v.real("an entity's coordinates")?;
            }
            let num_physical = v.size("the number of physical tags")?;
            let mut first_physical = None;
            for _ in 0..num_physical {
                let p = v.int("a physical tag")?;
                first_physical.get_or_insert(p);
            }
            if dim > 0 {
                let num_bounding = v.size("the number of bounding entities")?;
                for _ in 0..num_bounding {
                    v.int("a bounding entity tag")?;
                }
            }
            if dim == 3 {
                volume_physical.insert(tag, first_physical.unwrap_or(0));
            }
        }
    }
    s.volume_physical = Some(volume_physical);
    Ok(())
}

/// `$Nodes` (4.1): entity blocks of tags then coordinates; parametric
/// blocks carry `dim` extra coordinates per node, which are dropped.
pub(crate) fn read_nodes_41<V: Values>(v: &mut V, s: &mut State) -> Result<(), FormatError> {
    let num_blocks = v.size("the number of node blocks")?;
    v.size("the number of nodes")?;
    v.size("the smallest node tag")?;
    v.size("the largest node tag")?;
    let mut coords = Vec::new();
    for _ in 0..num_blocks {
        let loc = v.location();
        let dim = v.int("the entity dimension of a node block")?;
        v.int("the entity tag of a node block")?;
        let parametric = v.int("the parametric flag of a node block")?;
        let count = v.size("the number of nodes in a block")?;
        if !(0..=3).contains(&dim) {
            return Err(FormatError::new(loc, format!("node block entity dimension must be 0 to 3, found {dim}")));
        }
        let per_node = match parametric {
            0 => 3,
            1 => 3 + dim as u64,
            p => return Err(FormatError::new(loc, format!("node block parametric flag must be 0 or 1, found {p}"))),
        };
        v.sizes(count, "node tags", &mut s.node_tags)?;
        let num_values = count
            .checked_mul(per_node)
            .ok_or_else(|| FormatError::new(loc, format!("node block of {count} nodes overflows")))?;
        coords.clear();
        v.reals(num_values, "node coordinates", &mut coords)?;
        let per_node = per_node as usize;
        s.points.extend(coords.chunks_exact(per_node).map(|c| [c[0], c[1], c[2]]));
    }
    Ok(())
}

/// `$Elements` (4.1): entity blocks of one element type each.
pub(crate) fn read_elements_41<V: Values>(v: &mut V, s: &mut State) -> Result<(), FormatError> {
    s.elements_sections += 1;
    s.physical_known |= s.volume_physical.is_some();
    let num_blocks = v.size("the number of element blocks")?;
    v.size("the number of elements")?;
    v.size("the smallest element tag")?;
    v.size("the largest element tag")?;
    let mut buf = Vec::new();
    for _ in 0..num_blocks {
        let loc = v.location();
        let dim = v.int("the entity dimension of an element block")?;
        let entity = v.int("the entity tag of an element block")?;
        let type_id = v.int("the element type of a block")?;
        let count = v.size("the number of elements in a block")?;
        let Some(kind) = element_kind(type_id) else {
            let first = if count > 0 { v.size("an element tag").ok() } else { None };
            let which = match first {
                Some(tag) => format!("element {tag}"),
                None => "an element block".to_string(),
            };
            return Err(FormatError::new(
                loc,
                format!("{which} (entity dimension {dim}, tag {entity}) has unknown or unsupported Gmsh element type {type_id}"),
            ));
        };
        let per_element = element_nodes(kind) + 1;
        let num_values = count
            .checked_mul(per_element as u64)
            .ok_or_else(|| FormatError::new(loc, format!("element block of {count} elements overflows")))?;
        buf.clear();
        v.sizes(num_values, "element tags and nodes", &mut buf)?;
        match kind {
            ElementKind::Lower(_) => s.lower_dim += buf.len() / per_element,
            ElementKind::Volume(cell_type, _) => {
                let physical = s.volume_physical.as_ref().map_or(0, |m| m.get(&entity).copied().unwrap_or(0));
                for element in buf.chunks_exact(per_element) {
                    s.push_cell(cell_type, &element[1..], element[0], physical as f64, entity as f64);
                }
            }
        }
    }
    Ok(())
}

pub(crate) fn nonnegative(value: i64, what: &str, loc: Location) -> Result<u64, FormatError> {
    u64::try_from(value).map_err(|_| FormatError::new(loc, format!("{what} must not be negative, found {value}")))
}

/// `$Nodes` (2.x): a count, then `tag x y z` per node (binary: int + 3 doubles).
pub(crate) fn read_nodes_2(t: &mut TextCursor, s: &mut State) -> Result<(), FormatError> {
    let count: u64 = t.parse("the number of nodes")?;
    match s.header.binary {
        None => {
            for _ in 0..count {
                let tag: i64 = t.parse("a node tag")?;
                let loc = t.location();
                s.node_tags.push(nonnegative(tag, "a node tag", loc)?);
                let x = t.f64("a node's x coordinate")?;
                let y = t.f64("a node's y coordinate")?;
                let z = t.f64("a node's z coordinate")?;
                s.points.push([x, y, z]);
            }
        }
        Some((endian, _)) => {
            eat_line_end(t)?;
            let base = t.offset() as u64;
            let mut c = ByteCursor::with_base(t.rest(), base);
            let count = usize::try_from(count)
                .map_err(|_| FormatError::new(c.location(), format!("node count {count} is too large")))?;
            let bytes = c.take_array(count, 4 + 3 * 8, "node list")?;
            s.node_tags.reserve(count);
            s.points.reserve(count);
            for (i, node) in bytes.chunks_exact(28).enumerate() {
                let tag = word32(node, endian) as i32;
                let loc = Location::Byte(base + (i * 28) as u64);
                s.node_tags.push(nonnegative(i64::from(tag), "a node tag", loc)?);
                let coord = |k: usize| f64::from_bits(word64(&node[4 + 8 * k..], endian));
                s.points.push([coord(0), coord(1), coord(2)]);
            }
            t.advance((c.offset() - base) as usize);
        }
    }
    expect_end(t, "Nodes")
}

pub(crate) fn unknown_type_error(loc: Location, element: u64, type_id: i64) -> FormatError {
    FormatError::new(loc, format!("element {element} has unknown or unsupported Gmsh element type {type_id}"))
}

/// `$Elements` (2.x, ASCII): `tag type ntags tag... node...` per element;
/// the first tag is the physical entity, the second the elementary one.
pub(crate) fn read_elements_2_ascii(t: &mut TextCursor, s: &mut State) -> Result<(), FormatError> {
    s.elements_sections += 1;
    let count: u64 = t.parse("the number of elements")?;
    let mut nodes = Vec::new();
    for _ in 0..count {
        let tag: u64 = t.parse("an element tag")?;
        let loc = t.location();
        let type_id: i64 = t.parse("an element type")?;
        let num_tags: u64 = t.parse("the number of element tags")?;
        let kind = element_kind(type_id).ok_or_else(|| unknown_type_error(loc, tag, type_id))?;
        let (mut physical, mut entity) = (0i64, 0i64);
        for i in 0..num_tags {
            let value: i64 = t.parse("an element tag value")?;
            match i {
                0 => physical = value,
                1 => entity = value,
                _ => {}
            }
        }
        nodes.clear();
        for _ in 0..element_nodes(kind) {
            nodes.push(t.parse::<u64>("an element node tag")?);
        }
        match kind {
            ElementKind::Lower(_) => s.lower_dim += 1,
            ElementKind::Volume(cell_type, _) => {
                s.physical_known |= num_tags >= 1;
                s.push_cell(cell_type, &nodes, tag, physical as f64, entity as f64);
            }
        }
    }
    expect_end(t, "Elements")
}

/// `$Elements` (2.x, binary): blocks headed by (type, count, ntags), each
/// element being `tag, ntags tags, nodes` as 4-byte ints.
pub(crate) fn read_elements_2_binary(t: &mut TextCursor, s: &mut State) -> Result<(), FormatError> {
    s.elements_sections += 1;
    let Some((endian, _)) = s.header.binary else {
        return read_elements_2_ascii(t, s);
    };
    let count: u64 = t.parse("the number of elements")?;
    eat_line_end(t)?;
    let base = t.offset() as u64;
    let mut c = ByteCursor::with_base(t.rest(), base);
    let mut done = 0u64;
    let mut nodes = Vec::new();
    while done < count {
        let loc = c.location();
        let type_id = c.i32(endian, "an element block's type")?;
        let in_block = c.i32(endian, "an element block's element count")?;
        let num_tags = c.i32(endian, "an element block's number of tags")?;
        if in_block <= 0 || num_tags < 0 {
            return Err(FormatError::new(
                loc,
                format!("element block header has {in_block} elements and {num_tags} tags; both must be positive"),
            ));
        }
        let in_block = in_block as u64;
        if in_block > count - done {
            return Err(FormatError::new(
                loc,
                format!("element block of {in_block} elements overruns the {count} elements declared"),
            ));
        }
        let Some(kind) = element_kind(i64::from(type_id)) else {
            let first = c.clone().i32(endian, "an element tag").unwrap_or(0);
            return Err(unknown_type_error(loc, first as u64, i64::from(type_id)));
        };
        let num_tags = num_tags as usize;
        let per_element = 1 + num_tags + element_nodes(kind);
        let record = per_element
            .checked_mul(4)
            .ok_or_else(|| FormatError::new(loc, format!("element block with {num_tags} tags overflows")))?;
        let bytes = c.take_array(in_block as usize, record, "element block")?;
        match kind {
            ElementKind::Lower(_) => s.lower_dim += in_block as usize,
            ElementKind::Volume(cell_type, _) => {
                s.physical_known |= num_tags >= 1;
                for element in bytes.chunks_exact(record) {
                    let int = |k: usize| word32(&element[4 * k..], endian) as i32;
                    let physical = if num_tags >= 1 { int(1) } else { 0 };
                    let entity = if num_tags >= 2 { int(2) } else { 0 };
                    nodes.clear();
                    for k in 1 + num_tags..per_element {
                        // Negative node numbers are not tags; map them to an unused value so
                        // resolution reports the element.
                        nodes.push(u64::try_from(int(k)).unwrap_or(u64::MAX));
                    }
                    s.push_cell(cell_type, &nodes, int(0) as u32 as u64, f64::from(physical), f64::from(entity));
                }
            }
        }
        done += in_block;
    }
    t.advance((c.offset() - base) as usize);
    expect_end(t, "Elements")
}

pub(crate) fn read_data_header(t: &mut TextCursor, section: &str) -> Result<DataHeader, FormatError> {
    let num_strings: u64 = t.parse("the number of string tags")?;
    let _ = t.line_str();
    let mut name = None;
    for _ in 0..num_strings {
        let loc = t.location();
        let line = t
            .line_str()
            .ok_or_else(|| FormatError::new(loc, format!("unexpected end of file in the {section} string tags")))?;
        name.get_or_insert_with(|| line.trim().trim_matches('"').to_string());
    }
    let num_reals: u64 = t.parse("the number of real tags")?;
    let mut time = 0.0;
    for i in 0..num_reals {
        let r = t.f64("a real tag")?;
        if i == 0 {
            time = r;
        }
    }
    let num_ints: u64 = t.parse("the number of integer tags")?;
    let loc = t.location();
    if num_ints < 3 {
        return Err(FormatError::new(
            loc,
            format!("{section} needs at least 3 integer tags (time step, components, count), found {num_ints}"),
        ));
    }
    let mut ints = [0i64; 3];
    for i in 0..num_ints {
        let v: i64 = t.parse("an integer tag")?;
        if let Some(slot) = ints.get_mut(i as usize) {
            *slot = v;
        }
    }
    let [step, components, count] = ints;
    if !(1..=64).contains(&components) {
        return Err(FormatError::new(loc, format!("{section}: {components} components per value (1 to 64 are read)")));
    }
    let count = nonnegative(count, "the number of values", loc)?;
    Ok(DataHeader {
        name: name.unwrap_or_else(|| "data".to_string()),
        time,
        step,
        components: components as usize,
        count,
    })
}

/// `$NodeData` / `$ElementData`: values by tag, merged per name: sections of
/// the same time step (partitions) add up, a new time step replaces the old.
pub(crate) fn read_data(t: &mut TextCursor, s: &mut State, kind: DataKind) -> Result<(), FormatError> {
    let section = if kind == DataKind::Node { "NodeData" } else { "ElementData" };
    let at = t.location();
    let h = read_data_header(t, section)?;
    let comps = h.components;
    let mut tags = Vec::new();
    let mut values = Vec::new();
    match s.header.binary {
        None => {
            for _ in 0..h.count {
                tags.push(t.parse::<u64>("a data tag")?);
                for _ in 0..comps {
                    values.push(t.f64("a data value")?);
                }
            }
        }
        Some((endian, _)) => {
            eat_line_end(t)?;
            let base = t.offset() as u64;
            let mut c = ByteCursor::with_base(t.rest(), base);
            let count = usize::try_from(h.count)
                .map_err(|_| FormatError::new(c.location(), format!("{section}: count {} is too large", h.count)))?;
            let record = 4 + 8 * comps;
            let bytes = c.take_array(count, record, section)?;
            tags.reserve(count);
            values.reserve(count * comps);
            for (i, rec) in bytes.chunks_exact(record).enumerate() {
                let tag = word32(rec, endian) as i32;
                let loc = Location::Byte(base + (i * record) as u64);
                tags.push(nonnegative(i64::from(tag), "a data tag", loc)?);
                values.extend(rec[4..].chunks_exact(8).map(|v| f64::from_bits(word64(v, endian))));
            }
            t.advance((c.offset() - base) as usize);
        }
    }
    expect_end(t, section)?;

    match s.data.iter_mut().find(|f| f.kind == kind && f.name == h.name) {
        Some(f) if f.step == h.step => {
            if f.components != comps {
                return Err(FormatError::new(
                    at,
                    format!("{section} '{}' changes from {} to {comps} components", h.name, f.components),
                ));
            }
            f.tags.extend_from_slice(&tags);
            f.values.extend_from_slice(&values);
        }
        Some(f) => {
            f.steps_seen += 1;
            f.step = h.step;
            f.time = h.time;
            f.components = comps;
            f.tags = tags;
            f.values = values;
            f.at = at;
        }
        None => s.data.push(DataField {
            kind,
            name: h.name,
            time: h.time,
            step: h.step,
            steps_seen: 1,
            components: comps,
            tags,
            values,
            at,
        }),
    }
    Ok(())
}
