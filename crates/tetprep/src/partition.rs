//! `tetprep partition`: a bundle cut into N pieces by a k-d tree
//! (`tet_convert::partition`), with the manifest; and the manifest part of
//! `tetprep info`.

use crate::cli::PartitionArgs;
use crate::convert::Progress;
use serde_json::{json, Value};
use std::fmt::Write as _;
use std::path::{Path, PathBuf};
use std::time::Instant;
use tet_bundle::manifest::{KdNode, Manifest, MANIFEST_FILE};
use tet_bundle::Bundle;
use tet_cli::{ExitKind, KindExt};
use tet_convert::partition::{write_partition, PartitionRequest, PartitionStage, TetCost};

pub fn run(args: PartitionArgs) -> anyhow::Result<()> {
    let progress = Progress::new(args.quiet || args.json);
    let t_all = Instant::now();
    progress.step("reading the bundle");
    let source = Bundle::read(&args.bundle)?;
    let t_read = t_all.elapsed().as_secs_f64();
    let analysis = crate::analysis::requested(&args.analysis).map(|mut opts| {
        // One scalar axis for every piece: the whole mesh's range.
        if let Some(h) = &mut opts.histogram {
            h.scalar_range = h.scalar_range.or(Some(source.scalar_range()));
        }
        opts
    });
    let cost = match args.cost {
        crate::cli::CostArg::Tets => TetCost::Uniform,
        crate::cli::CostArg::Crossings => TetCost::Crossings,
    };
    let req = PartitionRequest { parts: args.parts, cost };
    let t = Instant::now();
    let (manifest, new_points) = write_partition(
        &source,
        &args.bundle,
        &args.output,
        &req,
        args.force,
        &mut |_, bundle| {
            let Some(opts) = &analysis else { return Ok(bundle) };
            let result = crate::analysis::analyze(&bundle, opts).map(|a| bundle.with_analysis(a)).and_then(|b| {
                // Stored per-step gradients were cut with the steps; only
                // a series without them gets them computed, as convert does.
                match opts.gradients {
                    Some(m) if b.steps.as_ref().is_some_and(|s| s.gradient_method().is_none()) => {
                        crate::analysis::with_step_gradients(b, m)
                    }
                    _ => Ok(b),
                }
            });
            result.map_err(|e| tet_cli::describe(&e).into())
        },
        &mut |stage| match stage {
            PartitionStage::Cutting => progress.step("cutting along the k-d planes"),
            PartitionStage::Converting { index, count } => {
                progress.set(format!("validating piece {} of {count}", index + 1))
            }
            PartitionStage::Writing { index, count } => progress.set(format!("writing piece {} of {count}", index + 1)),
        },
    )?;
    let t_partition = t.elapsed().as_secs_f64();
    progress.finish();
    let total = t_all.elapsed().as_secs_f64();
    let manifest_path = args.output.join(MANIFEST_FILE);
    if args.json {
        let mut v = manifest_json(&manifest, None);
        v["manifest"] = json!(manifest_path.display().to_string());
        v["new_points"] = json!(new_points);
        v["timings_s"] = json!({ "read": t_read, "partition_and_write": t_partition, "total": total });
        println!("{}", serde_json::to_string_pretty(&v)?);
    } else if !args.quiet {
        println!("wrote {} ({} pieces)", manifest_path.display(), manifest.parts);
        print!("{}", manifest_text(&manifest, None));
        println!("time        {total:.3} s (read {t_read:.3}, partition and write {t_partition:.3})");
    }
    Ok(())
}

/// Whether `path` is a partition manifest, or a directory holding one;
/// the manifest's path if so.
pub fn manifest_path(path: &Path) -> Option<PathBuf> {
    use std::io::Read;
    let file = if path.is_dir() { path.join(MANIFEST_FILE) } else { path.to_path_buf() };
    // A bundle (or anything else) is told apart by its first bytes, so a
    // large file is not read whole.
    let mut head = Vec::with_capacity(256);
    std::fs::File::open(&file).ok()?.take(256).read_to_end(&mut head).ok()?;
    if head.iter().find(|b| !b.is_ascii_whitespace()) != Some(&b'{') {
        return None;
    }
    let bytes = std::fs::read(&file).ok()?;
    Manifest::recognise(&bytes).then_some(file)
}

/// `tetprep info` of a manifest: the tree, boxes, counts and each piece
/// file's checksum status (a mismatch is reported, not an error).
pub fn info(path: &Path, as_json: bool) -> anyhow::Result<()> {
    let manifest = Manifest::load(path, false).kind(ExitKind::Input)?;
    let dir = path.parent().unwrap_or(Path::new("."));
    let status: Vec<Result<(), String>> =
        (0..manifest.pieces.len()).map(|k| manifest.verify_piece(dir, k).map_err(|e| e.to_string())).collect();
    if as_json {
        let mut v = manifest_json(&manifest, Some(&status));
        v["manifest"] = json!(path.display().to_string());
        println!("{}", serde_json::to_string_pretty(&v)?);
    } else {
        println!("manifest    {} (partition v{}, written by {})", path.display(), manifest.version, manifest.writer);
        print!("{}", manifest_text(&manifest, Some(&status)));
    }
    Ok(())
}

/// The manifest as JSON, with each piece's checksum status where checked.
fn manifest_json(m: &Manifest, status: Option<&[Result<(), String>]>) -> Value {
    let mut v = serde_json::to_value(m).unwrap_or(Value::Null);
    if let Some(status) = status {
        v["pieces_ok"] = json!(status.iter().all(Result::is_ok));
        if let Some(pieces) = v["pieces"].as_array_mut() {
            for (p, s) in pieces.iter_mut().zip(status) {
                p["status"] = match s {
                    Ok(()) => json!("ok"),
                    Err(e) => json!(e),
                };
            }
        }
    }
    v
}

fn fmt_box(b: &tet_bundle::manifest::BoxBounds) -> String {
    format!("[{:.6}, {:.6}, {:.6}] – [{:.6}, {:.6}, {:.6}]", b.min[0], b.min[1], b.min[2], b.max[0], b.max[1], b.max[2])
}

/// The text summary: source, ranges, the tree indented by depth, pieces.
fn manifest_text(m: &Manifest, status: Option<&[Result<(), String>]>) -> String {
    let mut o = String::new();
    let s = &m.source;
    let _ = writeln!(
        o,
        "source      {} ({} points, {} tets, volume {:.9e}, {} bytes, CRC-32 {:08x})",
        s.file, s.points, s.tets, s.total_volume, s.bytes, s.crc32
    );
    let _ = writeln!(o, "parts       {}", m.parts);
    let _ = writeln!(
        o,
        "scalar      {}  [{:.6e}, {:.6e}] over the whole mesh{}",
        m.scalar_name,
        m.scalar_range.min,
        m.scalar_range.max,
        if m.steps.is_empty() { String::new() } else { format!(" and all {} time steps", m.steps.len()) }
    );
    let _ = writeln!(o, "tree:");
    let mut stack = vec![(0usize, 0usize)];
    while let Some((n, depth)) = stack.pop() {
        let indent = "  ".repeat(depth + 1);
        match m.tree.get(n) {
            Some(KdNode::Split { bounds, axis, plane, children }) => {
                let name = ["x", "y", "z"].get(*axis as usize).copied().unwrap_or("?");
                let _ = writeln!(o, "{indent}{name} = {plane:.9e}  box {}", fmt_box(bounds));
                stack.push((children[1], depth + 1));
                stack.push((children[0], depth + 1));
            }
            Some(KdNode::Leaf { bounds, piece }) => {
                let _ = writeln!(o, "{indent}piece {piece}  box {}", fmt_box(bounds));
            }
            None => {}
        }
    }
    let _ = writeln!(o, "pieces:");
    let (mut tets, mut volume) = (0u64, 0.0);
    for (k, p) in m.pieces.iter().enumerate() {
        tets += p.tets;
        volume += p.volume;
        let state = match status.and_then(|s| s.get(k)) {
            None => String::new(),
            Some(Ok(())) => "  checksum ok".into(),
            Some(Err(e)) => format!("  BAD: {e}"),
        };
        let _ = writeln!(
            o,
            "  {k:>4}  {}  {} tets, {} points, volume {:.6e}, {} bytes, CRC-32 {:08x}{state}",
            p.file, p.tets, p.points, p.volume, p.bytes, p.crc32
        );
    }
    let _ = writeln!(o, "total       {tets} tets in the pieces ({} in the source); volume {volume:.9e}", m.source.tets);
    o
}
