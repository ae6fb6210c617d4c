//! A bounding-volume hierarchy over a mesh's boundary triangles, for finding
//! where a line enters the mesh. Built once per mesh and reused for every
//! view and every ray.
//!
//! The hierarchy only prunes: its box tests are conservative (boxes grown by
//! a small margin relative to the mesh size), and the exact decision whether
//! the line crosses a triangle is left to the caller's predicate, so that the
//! same exact, symbolically perturbed test decides entries into the mesh and
//! moves between tets.

use glam::DVec3;
use tet_mesh::FACE_OUTWARD;

/// Leaves hold at most this many triangles.
const LEAF_SIZE: usize = 4;

/// One boundary triangle: the packed face id `tet * 4 + face` and its vertex
/// ids in outward order (right-hand normal out of the mesh).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct BoundaryTriangle {
    pub packed_face: u32,
    pub vertices: [u32; 3],
}

#[derive(Debug, Clone, Copy)]
struct Node {
    lo: DVec3,
    hi: DVec3,
    /// Leaf: first triangle and count (`count > 0`). Inner: `first` is the
    /// left child's index, the right child follows the left subtree
    /// (`count == 0`, right index in `right`).
    first: u32,
    count: u32,
    right: u32,
}

/// The hierarchy: triangles reordered so that every leaf's are contiguous.
#[derive(Debug, Clone)]
pub struct BoundaryBvh {
    nodes: Vec<Node>,
    triangles: Vec<BoundaryTriangle>,
}

impl BoundaryBvh {
    /// Builds over `boundary_faces` (packed `tet * 4 + face`, as in
    /// `Adjacency::boundary_faces`). The caller has checked that every id is
    /// in range and every point is finite.
    pub fn build(points: &[[f64; 3]], tets: &[[u32; 4]], boundary_faces: &[u32]) -> BoundaryBvh {
        let mut triangles: Vec<BoundaryTriangle> = boundary_faces
            .iter()
            .map(|&packed| {
                let t = &tets[(packed / 4) as usize];
                let [i, j, k] = FACE_OUTWARD[(packed % 4) as usize];
                BoundaryTriangle { packed_face: packed, vertices: [t[i], t[j], t[k]] }
            })
            .collect();
        let p = |v: u32| DVec3::from(points[v as usize]);
        let bounds: Vec<(DVec3, DVec3)> = triangles
            .iter()
            .map(|tri| {
                let [a, b, c] = tri.vertices.map(p);
                (a.min(b).min(c), a.max(b).max(c))
            })
            .collect();
        // Margin: a few ulps of the mesh's extent, so that rounding in the
        // slab test never prunes a triangle the line touches.
        let (mut lo, mut hi) = (DVec3::splat(f64::INFINITY), DVec3::splat(f64::NEG_INFINITY));
        for &(a, b) in &bounds {
            lo = lo.min(a);
            hi = hi.max(b);
        }
        let extent =
            if triangles.is_empty() { 0.0 } else { (hi - lo).max_element().max(lo.abs().max(hi.abs()).max_element()) };
        let margin = DVec3::splat(extent * 1e-12);
        let mut order: Vec<usize> = (0..triangles.len()).collect();
        let mut nodes = Vec::with_capacity(2 * triangles.len() / LEAF_SIZE + 1);
        if !triangles.is_empty() {
            build_node(&bounds, &mut order, 0, margin, &mut nodes);
        }
        triangles = order.iter().map(|&i| triangles[i]).collect();
        BoundaryBvh { nodes, triangles }
    }

    pub fn triangles(&self) -> &[BoundaryTriangle] {
        &self.triangles
    }

    /// Calls `visit` with every triangle whose (grown) box the whole line
    /// `origin + t·dir` (t over all reals) passes through.
    pub fn for_each_near_line(&self, origin: DVec3, dir: DVec3, mut visit: impl FnMut(&BoundaryTriangle)) {
        if self.nodes.is_empty() {
            return;
        }
        let inv = dir.recip();
        let mut stack = [0u32; 64];
        let mut top = 1usize;
        while top > 0 {
            top -= 1;
            let node = &self.nodes[stack[top] as usize];
            if !line_hits_box(origin, dir, inv, node.lo, node.hi) {
                continue;
            }
            if node.count > 0 {
                let start = node.first as usize;
                for tri in &self.triangles[start..start + node.count as usize] {
                    visit(tri);
                }
            } else {
                // Depth is at most ~2 log2(n / LEAF_SIZE) for median splits.
                stack[top] = node.right;
                stack[top + 1] = node.first;
                top += 2;
            }
        }
    }
}

/// Splits at the median centroid along the widest centroid axis. Median
/// splits keep the depth logarithmic whatever the geometry, which the fixed
/// traversal stack relies on.
fn build_node(bounds: &[(DVec3, DVec3)], order: &mut [usize], offset: usize, margin: DVec3, nodes: &mut Vec<Node>) {
    let (mut lo, mut hi) = (DVec3::splat(f64::INFINITY), DVec3::splat(f64::NEG_INFINITY));
    let (mut clo, mut chi) = (lo, hi);
    for &i in order.iter() {
        let (a, b) = bounds[i];
        lo = lo.min(a);
        hi = hi.max(b);
        let c = (a + b) * 0.5;
        clo = clo.min(c);
        chi = chi.max(c);
    }
    let index = nodes.len();
    nodes.push(Node { lo: lo - margin, hi: hi + margin, first: offset as u32, count: order.len() as u32, right: 0 });
    if order.len() <= LEAF_SIZE {
        return;
    }
    let span = chi - clo;
    let axis = if span.x >= span.y && span.x >= span.z {
        0
    } else if span.y >= span.z {
        1
    } else {
        2
    };
    let mid = order.len() / 2;
    let key = |i: &usize| {
        let (a, b) = bounds[*i];
        (a[axis] + b[axis]) * 0.5
    };
    order.select_nth_unstable_by(mid, |x, y| key(x).total_cmp(&key(y)).then(x.cmp(y)));
    let (left, right) = order.split_at_mut(mid);
    let left_index = nodes.len() as u32;
    build_node(bounds, left, offset, margin, nodes);
    let right_index = nodes.len() as u32;
    build_node(bounds, right, offset + mid, margin, nodes);
    nodes[index].count = 0;
    nodes[index].first = left_index;
    nodes[index].right = right_index;
}

/// Slab test for an infinite line. A zero direction component gives ±∞ in
/// `inv`; that axis then only checks the origin lies within the slab.
#[inline]
fn line_hits_box(origin: DVec3, dir: DVec3, inv: DVec3, lo: DVec3, hi: DVec3) -> bool {
    let (mut t0, mut t1) = (f64::NEG_INFINITY, f64::INFINITY);
    for a in 0..3 {
        if dir[a] == 0.0 {
            if origin[a] < lo[a] || origin[a] > hi[a] {
                return false;
            }
            continue;
        }
        let (mut ta, mut tb) = ((lo[a] - origin[a]) * inv[a], (hi[a] - origin[a]) * inv[a]);
        if ta > tb {
            std::mem::swap(&mut ta, &mut tb);
        }
        t0 = t0.max(ta);
        t1 = t1.min(tb);
    }
    // Relative slack: t0 and t1 come from different axes' roundings.
    t0 <= t1 + 1e-9 * t1.abs().max(t0.abs())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn finds_every_triangle_a_line_can_touch() {
        // A strip of 100 unit tets along x; boundary is every face.
        let mut points = Vec::new();
        let mut tets = Vec::new();
        for i in 0..100u32 {
            let x = i as f64;
            let b = points.len() as u32;
            points.extend_from_slice(&[[x, 0.0, 0.0], [x + 1.0, 0.0, 0.0], [x, 1.0, 0.0], [x, 0.0, 1.0]]);
            tets.push([b, b + 1, b + 2, b + 3]);
        }
        let faces: Vec<u32> = (0..400).collect();
        let bvh = BoundaryBvh::build(&points, &tets, &faces);
        assert_eq!(bvh.triangles().len(), 400);
        // A line along x through every tet's corner edge region sees all.
        let mut seen = 0;
        bvh.for_each_near_line(DVec3::new(-5.0, 0.0, 0.0), DVec3::X, |_| seen += 1);
        assert_eq!(seen, 400);
        // A line along z at x = 50.5 sees only tet 50's faces (and maybe
        // neighbours' shared-plane boxes), never far ones.
        let mut ids = Vec::new();
        bvh.for_each_near_line(DVec3::new(50.25, 0.25, -3.0), DVec3::Z, |t| ids.push(t.packed_face / 4));
        assert!(ids.contains(&50));
        assert!(ids.iter().all(|&t| (49..=51).contains(&t)), "{ids:?}");
    }
}
