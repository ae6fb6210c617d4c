//! Under `mpirun -np N`: every rank draws a seeded image, the ranks agree
//! on the request, composite in a shuffled visibility order, and rank 0
//! checks the result against sequential front-to-back compositing of all
//! N images. Exit 0 when it matches (rank 0 prints the bytes each rank
//! sent), 1 when it does not, 3 when the agreement failed (every rank
//! prints the same message). `TET_SELFTEST_FAIL=R` makes rank R report a
//! failure; `TET_SELFTEST_DISAGREE=R` gives rank R another request;
//! `TET_SELFTEST_SIZE=WxH` sets the image size (default 67x41) and
//! `TET_SELFTEST_ROUNDS=K` composites K times (rank 0 prints each round's
//! seconds: the compositing benchmark of `docs/scaling.md`).

use tet_distributed::{agree, composite, seeded_image, sequential_over, Comm, MpiComm};
use tet_render::Image;

/// The selftest's seed for every rank's image.
const SEED: u64 = 0x2545_F491_4F6C_DD1D;

fn main() {
    let comm = MpiComm::init().expect("MPI initializes once");
    let (rank, size) = (comm.rank(), comm.size());
    let (w, h) = std::env::var("TET_SELFTEST_SIZE")
        .ok()
        .and_then(|s| s.split_once('x').and_then(|(a, b)| Some((a.parse().ok()?, b.parse().ok()?))))
        .unwrap_or((67u32, 41u32));
    let rounds = std::env::var("TET_SELFTEST_ROUNDS").ok().and_then(|v| v.parse::<usize>().ok()).unwrap_or(1).max(1);
    let env_rank = |name: &str| std::env::var(name).ok().and_then(|v| v.parse::<usize>().ok());
    let state = if env_rank("TET_SELFTEST_FAIL") == Some(rank) {
        Err(format!("simulated failure on rank {rank}"))
    } else if env_rank("TET_SELFTEST_DISAGREE") == Some(rank) {
        Ok(format!("size={w}x{h}\nview=another"))
    } else {
        Ok(format!("size={w}x{h}\nview=seeded"))
    };
    if let Err(e) = agree(&comm, state) {
        say_error(rank, &e);
        // Every rank has printed before any exits (mpirun ends the job at
        // the first error exit).
        let _ = comm.barrier();
        std::process::exit(3);
    }
    // A visibility order that is not the rank order: every other rank
    // first, then the rest backwards.
    let mut order: Vec<usize> = (0..size).step_by(2).collect();
    order.extend((0..size).filter(|r| r % 2 == 1).rev());
    let mine = seeded_image(rank, SEED, w, h);
    let mut result = None;
    for round in 0..rounds {
        let (image, stats) = composite(&comm, mine.clone(), &order).unwrap_or_else(|e| {
            say_error(rank, &e);
            std::process::exit(3)
        });
        if rounds > 1 {
            println!(
                "round {round} rank {rank}: {:.4} s, sent {} bytes, received {}",
                stats.seconds, stats.bytes_sent, stats.bytes_received
            );
        }
        result = Some((image, stats));
    }
    let (image, stats) = result.expect("one round at least");
    println!("rank {rank}: sent {} bytes in {} messages", stats.bytes_sent, stats.messages);
    if let Some(img) = image {
        let imgs: Vec<Image> = (0..size).map(|r| seeded_image(r, SEED, w, h)).collect();
        let want = sequential_over(&imgs, &order);
        let worst = img
            .pixels()
            .iter()
            .zip(&want)
            .map(|(g, e)| (0..4).map(|k| (g[k] - e[k]).abs()).fold(0.0f32, f32::max))
            .fold(0.0f32, f32::max);
        println!("rank 0: {size} ranks, order {order:?}, largest difference from sequential compositing {worst:e}");
        if worst > 1e-6 {
            std::process::exit(1);
        }
    }
}

/// One rank's error line in one write: ranks share mpirun's stderr, and
/// `eprintln!` writes a formatted line in pieces that another rank's line
/// could come between (seen in CI: "rank 2rank 2: error: …").
fn say_error(rank: usize, e: &dyn std::fmt::Display) {
    use std::io::Write;
    let line = format!("rank {rank}: error: {e}\n");
    let _ = std::io::stderr().lock().write_all(line.as_bytes());
}
