//! Times a table's batched lookup (`SegmentShader::shade_batch`, one
//! thread) on a recorded frame's segment stream, batch for batch as the
//! renderer made them, and prints a hash of the results' bits (two builds
//! of the kernel must print the same hash: the lookup paths are
//! bit-identical).
//!
//! Record the stream with `tet_render`'s `frame_profile` example:
//! `TET_RECORD_SEGS=segs.bin RAYON_NUM_THREADS=1 frame_profile B.tetb L.tetl 1`, then
//! `cargo run --release -p tet_preint --example lookup_replay -- L.tetl segs.bin [rounds]`.
//! `TET_PREINT_LOOKUP=portable` times the portable path.
use std::time::Instant;
use tet_preint::{load_shader, LutFile, SegmentBatch, BATCH};

fn main() {
    let args: Vec<String> = std::env::args().collect();
    if args.len() < 3 {
        eprintln!("usage: lookup_replay L.tetl segs.bin [rounds]");
        std::process::exit(2);
    }
    let lut_path = std::path::Path::new(&args[1]);
    let lut = LutFile::read(lut_path).expect("lut reads");
    let shader = load_shader(&lut, lut_path).expect("shader");
    let bytes = std::fs::read(&args[2]).expect("segment file reads");
    let rounds: usize = args.get(3).map_or(5, |s| s.parse().expect("rounds"));
    // Batches as (start, len) into one array of (Sf, Sb, l).
    let (mut segs, mut batches) = (Vec::<[f32; 3]>::new(), Vec::<(usize, usize)>::new());
    let f = |b: &[u8]| f32::from_le_bytes(b.try_into().expect("4 bytes"));
    let mut at = 0;
    while at + 4 <= bytes.len() {
        let n = u32::from_le_bytes(bytes[at..at + 4].try_into().expect("4 bytes")) as usize;
        at += 4;
        assert!(n <= BATCH && at + 12 * n <= bytes.len(), "segment file is truncated or not a recording");
        batches.push((segs.len(), n));
        for k in 0..n {
            let r = &bytes[at + 12 * k..at + 12 * k + 12];
            segs.push([f(&r[0..4]), f(&r[4..8]), f(&r[8..12])]);
        }
        at += 12 * n;
    }
    if std::env::var("REPLAY_HOT").is_ok() {
        // Every lookup the same segment: the compute floor, no misses.
        // (`REPLAY_HOT=chain`: Sf = Sb, so each front is the previous back.)
        let mut s0 = segs[segs.len() / 2];
        if std::env::var("REPLAY_HOT").is_ok_and(|v| v == "chain") {
            s0[1] = s0[0];
        }
        segs.iter_mut().for_each(|s| *s = s0);
    }
    println!("{} segments in {} batches; lookup {}", segs.len(), batches.len(), shader.method());
    let mut batch = SegmentBatch::default();
    let mut out = [[0.0f32; 4]; BATCH];
    let mut best = f64::INFINITY;
    for round in 0..rounds {
        let mut hash = 0xcbf2_9ce4_8422_2325u64;
        let t0 = Instant::now();
        for &(start, n) in &batches {
            for (k, s) in segs[start..start + n].iter().enumerate() {
                (batch.s_front[k], batch.s_back[k], batch.len_world[k]) = (s[0], s[1], s[2]);
            }
            batch.len = n;
            shader.shade_batch(&batch, &mut out);
            // A cheap fold of the first and last results' bits (the loop's
            // cost stays the lookup's); the full check is the tests'.
            for v in [out[0], out[n.max(1) - 1]] {
                for c in v {
                    hash = (hash ^ u64::from(c.to_bits())).wrapping_mul(0x100_0000_01b3);
                }
            }
        }
        let dt = t0.elapsed().as_secs_f64();
        best = best.min(dt);
        println!("round {round}: {:.2} ns/segment, hash {hash:016x}", dt * 1e9 / segs.len() as f64);
    }
    println!("best {:.2} ns/segment", best * 1e9 / segs.len() as f64);
}
