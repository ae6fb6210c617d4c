//! What the reader tests share: a fixed-seed generator for the damage the
//! robustness tests do, gzip-compressed test files, and checks of the
//! counts VTK reports.
#![allow(dead_code)] // not every test binary uses all of it

use std::io::Read;
use std::path::Path;
use tet_mesh::{Block, SourceMesh};

/// A fixed-seed LCG (Knuth's MMIX constants): the robustness tests need no
/// rand crate, and their damage is the same on every run.
pub struct Lcg(pub u64);

impl Lcg {
    /// The next 31 bits.
    pub fn next(&mut self) -> u64 {
        self.0 = self.0.wrapping_mul(6364136223846793005).wrapping_add(1442695040888963407);
        self.0 >> 33
    }

    /// [`Lcg::next`] reduced below `n` (0 for `n` = 0).
    pub fn below(&mut self, n: usize) -> usize {
        (self.next() % n.max(1) as u64) as usize
    }
}

/// The decompressed bytes of the gzip file at `path`.
pub fn gunzip(path: &Path) -> Vec<u8> {
    let gz = std::fs::read(path).unwrap();
    let mut out = Vec::new();
    flate2::read::GzDecoder::new(&gz[..]).read_to_end(&mut out).unwrap();
    out
}

/// The point and cell counts VTK reports.
pub fn assert_counts(m: &SourceMesh, points: usize, cells: usize) {
    assert_eq!(m.points.len(), points);
    assert_eq!(m.num_cells(), cells);
}

/// One structured block of `dims` points, with the counts VTK reports.
pub fn assert_structured(m: &SourceMesh, dims: [usize; 3], points: usize, cells: usize) {
    assert_eq!(m.blocks, vec![Block::Structured { dims, first_point: 0 }]);
    assert_counts(m, points, cells);
}

/// The tets and total volume of `m` as tetprep converts it, checked: no
/// tet re-oriented or dropped as flat (a cell cut at its nodes in the
/// wrong order shows so), and the tets conform (face adjacency builds).
pub fn converted(m: &SourceMesh) -> (usize, f64) {
    let (mesh, report) = tet_mesh::tetrahedralize(m, &Default::default(), &mut |_| {}).unwrap();
    assert!(
        !report.findings.iter().any(|f| matches!(
            f,
            tet_mesh::Finding::ReorientedTets { .. } | tet_mesh::Finding::DroppedZeroVolumeTets { .. }
        )),
        "{:?}",
        report.findings
    );
    tet_mesh::build_adjacency(&mesh.points, &mesh.tets).expect("conforming");
    (mesh.tets.len(), tet_mesh::mesh_stats(&mesh.points, &mesh.tets, &mesh.scalar).total_volume)
}
