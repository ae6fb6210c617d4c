//! The partition manifest (`manifest.json`, spec `formats/manifest.md`):
//! how a bundle was cut into pieces by a k-d tree, one piece per rank of a
//! distributed frame.
//!
//! [`Manifest`] holds the source bundle's name and checksum, the tree (per
//! inner node: the axis, the plane value and the two children; per leaf:
//! its piece), every piece's box, file, counts, byte size and CRC-32, and
//! the whole mesh's scalar range (and each time step's), so that every
//! rank normalizes its transfer function over the same range one process
//! would. [`Manifest::load`] checks the file (format tag, version, the
//! piece count against the tree, boxes nested as the tree says) and, with
//! `verify_pieces`, that each piece file exists with the recorded size and
//! checksum; errors ([`ManifestError`]) name the piece index and the path.
//! [`Manifest::front_to_back`] and [`Manifest::front_to_back_parallel`]
//! give the visibility order of the pieces from the tree.
//!
//! Pieces lie inside their boxes (the partition clips tets exactly at the
//! planes) and the boxes of the leaves tile the root box, so the order of
//! the boxes from the eye is the order of the pieces: a piece on the eye's
//! side of a plane can hide one on the other side, never the reverse.

use serde::{Deserialize, Serialize};
use std::io::Read;
use std::path::{Path, PathBuf};

/// The value of the manifest's `format` field: how a reader recognises a
/// manifest among JSON files.
pub const MANIFEST_FORMAT: &str = "tetkit-partition";
/// The manifest version this build writes and the newest it reads.
pub const MANIFEST_VERSION: u32 = 1;
/// The file name of the manifest inside a partition directory.
pub const MANIFEST_FILE: &str = "manifest.json";

/// An axis-aligned box in world units; `min[a] <= max[a]` on every axis.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct BoxBounds {
    pub min: [f64; 3],
    pub max: [f64; 3],
}

impl BoxBounds {
    /// Whether `pos_in_world` lies in the closed box.
    pub fn contains(&self, pos_in_world: &[f64; 3]) -> bool {
        (0..3).all(|a| self.min[a] <= pos_in_world[a] && pos_in_world[a] <= self.max[a])
    }

    /// The two halves of the box on either side of `plane` along `axis`:
    /// `(min side, max side)`; the plane value becomes their shared face
    /// exactly.
    pub fn split(&self, axis: usize, plane: f64) -> (BoxBounds, BoxBounds) {
        let (mut lo, mut hi) = (*self, *self);
        lo.max[axis] = plane;
        hi.min[axis] = plane;
        (lo, hi)
    }
}

/// One node of the k-d tree; node 0 is the root.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(tag = "kind", rename_all = "snake_case")]
pub enum KdNode {
    /// An inner node: its box is cut at `plane` along `axis` (0 = x, 1 = y,
    /// 2 = z); `children[0]` is the side below the plane, `children[1]` the
    /// side above (node indices).
    Split { bounds: BoxBounds, axis: u8, plane: f64, children: [usize; 2] },
    /// A leaf: piece `piece` of the manifest's list.
    Leaf { bounds: BoxBounds, piece: usize },
}

impl KdNode {
    pub fn bounds(&self) -> &BoxBounds {
        match self {
            KdNode::Split { bounds, .. } | KdNode::Leaf { bounds, .. } => bounds,
        }
    }
}

/// The bundle a partition was made from.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct SourceInfo {
    /// The file name (no directory) of the source bundle.
    pub file: String,
    /// CRC-32 (IEEE, as zlib) of the whole source file.
    pub crc32: u32,
    pub bytes: u64,
    pub points: u64,
    pub tets: u64,
    /// Total volume of the source's tets (world units cubed).
    pub total_volume: f64,
    /// How the source's cells were made (its `BundleMeta::split`:
    /// "delaunay" and "layered" for point clouds), so the default view of
    /// a distributed frame is framed as the source's (z up for point
    /// clouds). Empty in manifests written before it was recorded.
    #[serde(default)]
    pub split: String,
}

impl SourceInfo {
    /// Whether the source was tetrahedralized from a point cloud.
    pub fn from_point_cloud(&self) -> bool {
        matches!(self.split.as_str(), "delaunay" | "layered")
    }
}

/// A scalar's range over the whole mesh.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct ScalarRange {
    pub min: f64,
    pub max: f64,
}

/// A time step's time and its scalar range over the whole mesh.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct StepRange {
    pub time: f64,
    pub min: f64,
    pub max: f64,
}

/// One piece: a bundle file in the manifest's directory.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct PieceInfo {
    /// File name relative to the manifest's directory.
    pub file: String,
    /// The leaf's box; every point of the piece lies in it.
    pub bounds: BoxBounds,
    pub tets: u64,
    pub points: u64,
    /// Total volume of the piece's tets.
    pub volume: f64,
    /// Size of the piece file in bytes.
    pub bytes: u64,
    /// CRC-32 (IEEE, as zlib) of the whole piece file.
    pub crc32: u32,
}

/// A partition manifest (see the module documentation).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Manifest {
    /// Always [`MANIFEST_FORMAT`].
    pub format: String,
    /// [`MANIFEST_VERSION`] when written.
    pub version: u32,
    /// tetkit version that wrote it.
    pub writer: String,
    pub source: SourceInfo,
    /// The number of pieces asked for (= `pieces.len()`).
    pub parts: usize,
    /// The scalar's name and its range over the whole mesh (for a time
    /// series: over every step, as [`crate::Bundle::scalar_range`]).
    pub scalar_name: String,
    pub scalar_range: ScalarRange,
    /// Each time step's range over the whole mesh; empty without steps.
    pub steps: Vec<StepRange>,
    /// The k-d tree, node 0 the root; the root box is the source's bounding box.
    pub tree: Vec<KdNode>,
    /// The pieces in leaf order (left before right, depth first).
    pub pieces: Vec<PieceInfo>,
    /// What the planes balance: "tets" (counts) or "crossings" (each tet
    /// weighted by its surface area, its expected ray crossings). Absent in
    /// older files: "tets".
    #[serde(default = "default_cost")]
    pub cost: String,
}

fn default_cost() -> String {
    "tets".into()
}

/// Why a manifest or one of its pieces is not usable; the path comes last.
#[derive(Debug, thiserror::Error)]
pub enum ManifestError {
    #[error("cannot read {}: {source}", path.display())]
    Io {
        #[source]
        source: std::io::Error,
        path: PathBuf,
    },
    #[error("not a tetkit partition manifest ({what}): {}", path.display())]
    NotManifest { what: String, path: PathBuf },
    #[error("manifest version {found} is newer than this tetkit reads (up to {supported}); upgrade tetkit: {}", path.display())]
    NewerVersion { found: u32, supported: u32, path: PathBuf },
    #[error("manifest is inconsistent: {what}: {}", path.display())]
    Inconsistent { what: String, path: PathBuf },
    #[error("piece {piece}: {what}: {}", path.display())]
    BadPiece { piece: usize, what: String, path: PathBuf },
    #[error("piece {piece}")]
    PieceBundle {
        piece: usize,
        #[source]
        source: crate::BundleError,
    },
    #[error("piece {piece} is missing or unreadable ({source}): {}", path.display())]
    MissingPiece {
        piece: usize,
        #[source]
        source: std::io::Error,
        path: PathBuf,
    },
    #[error("piece {piece} is {found} bytes, the manifest says {expected}: {}", path.display())]
    PieceSize { piece: usize, expected: u64, found: u64, path: PathBuf },
    #[error("piece {piece} is corrupt (CRC-32 {found:08x}, the manifest says {expected:08x}): {}", path.display())]
    PieceChecksum { piece: usize, expected: u32, found: u32, path: PathBuf },
}

/// CRC-32 (IEEE, as zlib) and length of a file, read in 1 MiB blocks.
pub fn file_crc32(path: &Path) -> std::io::Result<(u32, u64)> {
    let mut file = std::fs::File::open(path)?;
    let mut hasher = crc32fast::Hasher::new();
    let mut buf = vec![0u8; 1 << 20];
    let mut len = 0u64;
    loop {
        let n = file.read(&mut buf)?;
        if n == 0 {
            break;
        }
        hasher.update(&buf[..n]);
        len += n as u64;
    }
    Ok((hasher.finalize(), len))
}

impl Manifest {
    /// Whether `bytes` look like a manifest: JSON whose `format` field is
    /// [`MANIFEST_FORMAT`] (what `tetprep info` tests before parsing).
    pub fn recognise(bytes: &[u8]) -> bool {
        #[derive(Deserialize)]
        struct Tag {
            format: Option<String>,
        }
        let head = bytes.iter().find(|b| !b.is_ascii_whitespace());
        head == Some(&b'{')
            && serde_json::from_slice::<Tag>(bytes).is_ok_and(|t| t.format.as_deref() == Some(MANIFEST_FORMAT))
    }

    /// The manifest as pretty-printed JSON (what is written to disk).
    pub fn to_json(&self) -> String {
        serde_json::to_string_pretty(self).expect("a manifest always serializes")
    }

    /// Reads and checks the manifest at `path` ([`Manifest::check`]); with
    /// `verify_pieces`, also each piece file's size and checksum
    /// ([`Manifest::verify_pieces`]).
    pub fn load(path: &Path, verify_pieces: bool) -> Result<Manifest, ManifestError> {
        let bytes = std::fs::read(path).map_err(|source| ManifestError::Io { source, path: path.to_path_buf() })?;
        let m = Manifest::from_json(&bytes, path)?;
        if verify_pieces {
            m.verify_pieces(path.parent().unwrap_or(Path::new(".")))?;
        }
        Ok(m)
    }

    /// Parses and checks manifest bytes; `path` is only used in errors.
    pub fn from_json(bytes: &[u8], path: &Path) -> Result<Manifest, ManifestError> {
        let not = |what: String| ManifestError::NotManifest { what, path: path.to_path_buf() };
        let value: serde_json::Value = serde_json::from_slice(bytes).map_err(|e| not(format!("not JSON: {e}")))?;
        if value.get("format").and_then(|f| f.as_str()) != Some(MANIFEST_FORMAT) {
            return Err(not(format!("no \"format\": \"{MANIFEST_FORMAT}\" field")));
        }
        let version = value.get("version").and_then(|v| v.as_u64()).ok_or_else(|| not("no version".into()))?;
        if version > MANIFEST_VERSION as u64 {
            return Err(ManifestError::NewerVersion {
                found: version.min(u32::MAX as u64) as u32,
                supported: MANIFEST_VERSION,
                path: path.to_path_buf(),
            });
        }
        let m: Manifest = serde_json::from_value(value).map_err(|e| ManifestError::Inconsistent {
            what: format!("fields do not decode ({e})"),
            path: path.to_path_buf(),
        })?;
        m.check(path)?;
        Ok(m)
    }

    /// Checks the structure: the piece count against `parts` and the
    /// tree's leaves, every piece reached by exactly one leaf, every node
    /// reached once from the root, children's boxes exactly the parent's
    /// box split at its plane, each leaf's box the piece's, and piece file
    /// names that stay inside the manifest's directory.
    pub fn check(&self, path: &Path) -> Result<(), ManifestError> {
        let bad = |what: String| ManifestError::Inconsistent { what, path: path.to_path_buf() };
        if self.parts == 0 {
            return Err(bad("0 parts".into()));
        }
        if self.pieces.len() != self.parts {
            return Err(bad(format!("{} parts but {} pieces listed", self.parts, self.pieces.len())));
        }
        if self.tree.is_empty() {
            return Err(bad("the tree has no nodes".into()));
        }
        if Some(self.tree.len()) != self.parts.checked_mul(2).map(|n| n - 1) {
            return Err(bad(format!(
                "{} tree nodes for {} parts (a k-d tree has 2N − 1)",
                self.tree.len(),
                self.parts
            )));
        }
        if !matches!(
            self.scalar_range.min.partial_cmp(&self.scalar_range.max),
            Some(std::cmp::Ordering::Less | std::cmp::Ordering::Equal)
        ) {
            return Err(bad(format!("scalar range {} to {}", self.scalar_range.min, self.scalar_range.max)));
        }
        let mut node_seen = vec![false; self.tree.len()];
        let mut piece_leaf = vec![None; self.pieces.len()];
        // Depth-first from the root, with each node's expected box.
        let mut stack = vec![(0usize, *self.tree[0].bounds())];
        while let Some((n, expected)) = stack.pop() {
            let node = &self.tree[n];
            if std::mem::replace(&mut node_seen[n], true) {
                return Err(bad(format!("tree node {n} is reached twice")));
            }
            if node.bounds() != &expected {
                return Err(bad(format!("tree node {n}'s box is not its parent's box split at the parent's plane")));
            }
            match node {
                KdNode::Split { bounds, axis, plane, children } => {
                    let axis = *axis as usize;
                    if axis > 2 {
                        return Err(bad(format!("tree node {n} splits axis {axis}")));
                    }
                    if !(bounds.min[axis]..=bounds.max[axis]).contains(plane) {
                        return Err(bad(format!("tree node {n}'s plane {plane} is outside its box")));
                    }
                    if let Some(c) = children.iter().find(|&&c| c >= self.tree.len()) {
                        return Err(bad(format!("tree node {n} has child {c} beyond the {} nodes", self.tree.len())));
                    }
                    let (lo, hi) = bounds.split(axis, *plane);
                    stack.push((children[1], hi));
                    stack.push((children[0], lo));
                }
                KdNode::Leaf { bounds, piece } => {
                    let Some(info) = self.pieces.get(*piece) else {
                        return Err(bad(format!("leaf {n} names piece {piece} of {}", self.pieces.len())));
                    };
                    if let Some(other) = piece_leaf[*piece].replace(n) {
                        return Err(bad(format!("piece {piece} is named by leaves {other} and {n}")));
                    }
                    if &info.bounds != bounds {
                        return Err(ManifestError::BadPiece {
                            piece: *piece,
                            what: format!("its box differs from its leaf's (node {n})"),
                            path: path.to_path_buf(),
                        });
                    }
                }
            }
        }
        if let Some(n) = node_seen.iter().position(|s| !s) {
            return Err(bad(format!("tree node {n} is not reached from the root")));
        }
        if let Some(k) = piece_leaf.iter().position(Option::is_none) {
            return Err(ManifestError::BadPiece {
                piece: k,
                what: "no leaf of the tree names it".into(),
                path: path.to_path_buf(),
            });
        }
        for (k, p) in self.pieces.iter().enumerate() {
            let name = Path::new(&p.file);
            let plain = name.components().count() == 1
                && matches!(name.components().next(), Some(std::path::Component::Normal(_)));
            if !plain {
                return Err(ManifestError::BadPiece {
                    piece: k,
                    what: "its file name is not a plain name inside the manifest's directory".into(),
                    path: path.to_path_buf(),
                });
            }
        }
        Ok(())
    }

    /// Where piece `k`'s file is, for a manifest in `dir` (`dir` itself
    /// for a piece that does not exist).
    pub fn piece_path(&self, dir: &Path, k: usize) -> PathBuf {
        self.pieces.get(k).map_or_else(|| dir.to_path_buf(), |p| dir.join(&p.file))
    }

    /// Checks that every piece file in `dir` exists with the recorded size
    /// and CRC-32; the first failure names the piece and its path.
    pub fn verify_pieces(&self, dir: &Path) -> Result<(), ManifestError> {
        (0..self.pieces.len()).try_for_each(|k| self.verify_piece(dir, k))
    }

    /// Checks that piece `k`'s file in `dir` exists with the recorded size
    /// and CRC-32.
    pub fn verify_piece(&self, dir: &Path, k: usize) -> Result<(), ManifestError> {
        let Some(p) = self.pieces.get(k) else {
            return Err(ManifestError::BadPiece {
                piece: k,
                what: format!("there are {} pieces", self.pieces.len()),
                path: dir.to_path_buf(),
            });
        };
        let path = self.piece_path(dir, k);
        let meta = std::fs::metadata(&path).map_err(|source| ManifestError::MissingPiece {
            piece: k,
            source,
            path: path.clone(),
        })?;
        if meta.len() != p.bytes {
            return Err(ManifestError::PieceSize { piece: k, expected: p.bytes, found: meta.len(), path });
        }
        let (crc, _) =
            file_crc32(&path).map_err(|source| ManifestError::MissingPiece { piece: k, source, path: path.clone() })?;
        if crc != p.crc32 {
            return Err(ManifestError::PieceChecksum { piece: k, expected: p.crc32, found: crc, path });
        }
        Ok(())
    }

    /// Reads piece `k` of a manifest in `dir` (a rank's share): the file's
    /// size and CRC-32 are checked first ([`Manifest::verify_piece`]), then
    /// the bundle is read and its counts compared with the manifest's.
    pub fn load_piece(&self, dir: &Path, k: usize) -> Result<crate::Bundle, ManifestError> {
        self.verify_piece(dir, k)?;
        let path = self.piece_path(dir, k);
        let bundle = crate::Bundle::read(&path).map_err(|source| ManifestError::PieceBundle { piece: k, source })?;
        let p = &self.pieces[k];
        let (tets, points) = (bundle.mesh.tets.len() as u64, bundle.mesh.points.len() as u64);
        if (tets, points) != (p.tets, p.points) {
            return Err(ManifestError::BadPiece {
                piece: k,
                what: format!("{tets} tets and {points} points, the manifest says {} and {}", p.tets, p.points),
                path,
            });
        }
        Ok(bundle)
    }

    /// The pieces in front-to-back order for an eye at `eye_in_world`
    /// (a perspective view): at every inner node the child on the eye's
    /// side of the plane comes first (an eye on the plane: either order is
    /// exact, the lower side is taken).
    pub fn front_to_back(&self, eye_in_world: [f64; 3]) -> Vec<usize> {
        self.order_by(|axis, plane| eye_in_world[axis] <= plane)
    }

    /// The pieces in front-to-back order for a parallel projection looking
    /// along `view_dir_in_world` (from the eye into the scene): at every
    /// inner node the lower side comes first where the view direction
    /// points up the axis.
    pub fn front_to_back_parallel(&self, view_dir_in_world: [f64; 3]) -> Vec<usize> {
        self.order_by(|axis, _| view_dir_in_world[axis] >= 0.0)
    }

    /// Leaves in the order a depth-first walk visits them when
    /// `lower_first(axis, plane)` says which child to visit first.
    fn order_by(&self, lower_first: impl Fn(usize, f64) -> bool) -> Vec<usize> {
        let mut out = Vec::with_capacity(self.pieces.len());
        let mut stack = vec![0usize];
        // A checked manifest reaches each node once; the bound guards an
        // unchecked one against cycles.
        let mut budget = self.tree.len();
        while let Some(n) = stack.pop() {
            if budget == 0 {
                break;
            }
            budget -= 1;
            match self.tree.get(n) {
                Some(KdNode::Leaf { piece, .. }) => out.push(*piece),
                Some(KdNode::Split { axis, plane, children, .. }) => {
                    let (first, second) = if lower_first(*axis as usize, *plane) {
                        (children[0], children[1])
                    } else {
                        (children[1], children[0])
                    };
                    stack.push(second);
                    stack.push(first);
                }
                None => {}
            }
        }
        out
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn unit() -> BoxBounds {
        BoxBounds { min: [0.0; 3], max: [1.0; 3] }
    }

    /// Three pieces: x at 0.5, then the upper half's y at 0.25.
    fn three() -> Manifest {
        let root = unit();
        let (l, r) = root.split(0, 0.5);
        let (rl, rr) = r.split(1, 0.25);
        let piece = |k: usize, bounds: BoxBounds| PieceInfo {
            file: format!("piece_{k:04}.tetb"),
            bounds,
            tets: 1,
            points: 4,
            volume: 0.1,
            bytes: 0,
            crc32: 0,
        };
        Manifest {
            format: MANIFEST_FORMAT.into(),
            version: MANIFEST_VERSION,
            writer: "test".into(),
            source: SourceInfo {
                file: "s.tetb".into(),
                crc32: 0,
                bytes: 0,
                points: 0,
                tets: 0,
                total_volume: 1.0,
                split: String::new(),
            },
            parts: 3,
            scalar_name: "s".into(),
            scalar_range: ScalarRange { min: 0.0, max: 1.0 },
            steps: vec![],
            tree: vec![
                KdNode::Split { bounds: root, axis: 0, plane: 0.5, children: [1, 2] },
                KdNode::Leaf { bounds: l, piece: 0 },
                KdNode::Split { bounds: r, axis: 1, plane: 0.25, children: [3, 4] },
                KdNode::Leaf { bounds: rl, piece: 1 },
                KdNode::Leaf { bounds: rr, piece: 2 },
            ],
            pieces: vec![piece(0, l), piece(1, rl), piece(2, rr)],
            cost: "tets".into(),
        }
    }

    #[test]
    fn round_trips_and_is_recognised() {
        let m = three();
        let json = m.to_json();
        assert!(Manifest::recognise(json.as_bytes()));
        assert!(!Manifest::recognise(b"{\"format\": \"other\"}"));
        assert!(!Manifest::recognise(b"\x89TETB\r\n\x1a"));
        let back = Manifest::from_json(json.as_bytes(), Path::new("m.json")).unwrap();
        assert_eq!(back, m);
    }

    #[test]
    fn visibility_order_follows_the_planes() {
        let m = three();
        assert_eq!(m.front_to_back([-1.0, 0.5, 0.5]), [0, 2, 1]);
        assert_eq!(m.front_to_back([-1.0, 0.1, 0.5]), [0, 1, 2]);
        assert_eq!(m.front_to_back([2.0, 0.9, 0.5]), [2, 1, 0]);
        assert_eq!(m.front_to_back([2.0, -0.5, 0.5]), [1, 2, 0]);
        assert_eq!(m.front_to_back_parallel([-1.0, 1.0, 0.0]), [1, 2, 0]);
        assert_eq!(m.front_to_back_parallel([1.0, -1.0, 0.0]), [0, 2, 1]);
    }

    #[test]
    fn inconsistent_manifests_are_refused() {
        let p = Path::new("m.json");
        let mut m = three();
        m.parts = 4;
        assert!(matches!(Manifest::from_json(m.to_json().as_bytes(), p), Err(ManifestError::Inconsistent { .. })));
        let mut m = three();
        m.pieces[2].bounds.max[1] = 0.9;
        assert!(matches!(
            Manifest::from_json(m.to_json().as_bytes(), p),
            Err(ManifestError::BadPiece { piece: 2, .. })
        ));
        let mut m = three();
        if let KdNode::Split { plane, .. } = &mut m.tree[2] {
            *plane = 0.3;
        }
        assert!(matches!(Manifest::from_json(m.to_json().as_bytes(), p), Err(ManifestError::Inconsistent { .. })));
        let mut m = three();
        m.pieces[1].file = "../escape.tetb".into();
        assert!(matches!(
            Manifest::from_json(m.to_json().as_bytes(), p),
            Err(ManifestError::BadPiece { piece: 1, .. })
        ));
        let mut m = three();
        m.version = MANIFEST_VERSION + 1;
        assert!(matches!(Manifest::from_json(m.to_json().as_bytes(), p), Err(ManifestError::NewerVersion { .. })));
        assert!(matches!(Manifest::from_json(b"[1, 2]", p), Err(ManifestError::NotManifest { .. })));
    }
}
