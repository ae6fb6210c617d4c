//! The agreement before a distributed frame and binary-swap compositing in
//! visibility order.

use crate::{Comm, DistributedError};
use std::time::Instant;
use tet_render::Image;

const TAG_AGREE: i32 = 1;
const TAG_VERDICT: i32 = 2;
const TAG_REDUCE: i32 = 4;
const TAG_REDUCED: i32 = 5;
const TAG_FOLD: i32 = 3;
/// Binary-swap stage s uses `TAG_SWAP + s`.
const TAG_SWAP: i32 = 16;
const TAG_GATHER: i32 = 64;

/// Premultiplied `front` over `back`.
pub fn over(front: [f32; 4], back: [f32; 4]) -> [f32; 4] {
    let t = 1.0 - front[3];
    [front[0] + t * back[0], front[1] + t * back[1], front[2] + t * back[2], front[3] + t * back[3]]
}

/// Every rank calls this with its state: `Ok(fingerprint)` (the request it
/// will draw, one `key=value` a line: view, TF, method, image size,
/// manifest) or `Err(message)` (what it met reading its pieces). All ranks
/// return the same result: the lowest failing rank's error, else the first
/// rank whose fingerprint differs from rank 0's (naming the first line that
/// differs), else `Ok`.
pub fn agree<C: Comm + ?Sized>(comm: &C, mine: Result<String, String>) -> Result<(), DistributedError> {
    let encode = |state: &Result<String, String>| -> Vec<u8> {
        let (flag, text) = match state {
            Ok(f) => (0u8, f.as_str()),
            Err(m) => (1u8, m.as_str()),
        };
        let mut v = vec![flag];
        v.extend_from_slice(text.as_bytes());
        v
    };
    let rank = comm.rank();
    let verdict: Vec<u8> = if rank == 0 {
        let mut states = vec![mine];
        for from in 1..comm.size() {
            let m = comm.recv(from, TAG_AGREE, comm.timeout())?;
            let text = String::from_utf8_lossy(m.get(1..).unwrap_or_default()).into_owned();
            states.push(if m.first() == Some(&0) { Ok(text) } else { Err(text) });
        }
        let failed = states.iter().enumerate().find_map(|(r, s)| s.as_ref().err().map(|m| (r, m.clone())));
        let verdict = match failed {
            Some((r, message)) => Err((1u8, r, message)),
            None => {
                let root: Vec<&str> = states[0].as_ref().map(|f| f.lines().collect()).unwrap_or_default();
                states
                    .iter()
                    .enumerate()
                    .skip(1)
                    .find_map(|(r, s)| {
                        let theirs: Vec<&str> = s.as_ref().map(|f| f.lines().collect()).unwrap_or_default();
                        (theirs != root).then(|| {
                            let k = (0..root.len().max(theirs.len()))
                                .find(|&k| root.get(k) != theirs.get(k))
                                .expect("the line lists differ somewhere");
                            let what = format!(
                                "'{}' against '{}'",
                                theirs.get(k).copied().unwrap_or("(nothing)"),
                                root.get(k).copied().unwrap_or("(nothing)")
                            );
                            Err((2u8, r, what))
                        })
                    })
                    .unwrap_or(Ok(()))
            }
        };
        let mut v = Vec::new();
        if let Err((kind, r, text)) = &verdict {
            v.push(*kind);
            v.extend_from_slice(&(*r as u64).to_le_bytes());
            v.extend_from_slice(text.as_bytes());
        } else {
            v.push(0);
        }
        for to in 1..comm.size() {
            comm.send(to, TAG_VERDICT, &v)?;
        }
        v
    } else {
        comm.send(0, TAG_AGREE, &encode(&mine))?;
        comm.recv(0, TAG_VERDICT, comm.timeout())?
    };
    match verdict.first() {
        Some(0) => Ok(()),
        Some(&kind) if verdict.len() >= 9 => {
            let r = u64::from_le_bytes(verdict[1..9].try_into().expect("8 bytes")) as usize;
            let text = String::from_utf8_lossy(&verdict[9..]).into_owned();
            Err(if kind == 1 {
                DistributedError::RankFailed { rank: r, message: text }
            } else {
                DistributedError::Disagree { rank: r, what: text }
            })
        }
        _ => Err(DistributedError::Malformed { rank, from: 0, tag: TAG_VERDICT, what: "a verdict of no kind".into() }),
    }
}

/// Every rank's contribution (bytes, or the error it met making them) to
/// rank 0, which combines them in rank order with `combine`; every rank
/// returns the same result: the lowest failing rank's error
/// ([`DistributedError::RankFailed`]), `combine`'s error (as rank 0's), or
/// the combined bytes. What a rank sums over the others before drawing
/// (a partition's histograms for the automatic TF) goes through here, so
/// one rank's failure stops all of them instead of leaving them waiting.
pub fn reduce<C: Comm + ?Sized>(
    comm: &C,
    mine: Result<Vec<u8>, String>,
    combine: impl FnOnce(Vec<Vec<u8>>) -> Result<Vec<u8>, String>,
) -> Result<Vec<u8>, DistributedError> {
    let encode = |flag: u8, rank: usize, body: &[u8]| {
        let mut v = Vec::with_capacity(body.len() + 9);
        v.push(flag);
        v.extend_from_slice(&(rank as u64).to_le_bytes());
        v.extend_from_slice(body);
        v
    };
    let rank = comm.rank();
    let result = if rank == 0 {
        let mut parts = vec![mine];
        for from in 1..comm.size() {
            let m = comm.recv(from, TAG_REDUCE, comm.timeout())?;
            let body = m.get(1..).unwrap_or_default().to_vec();
            parts.push(if m.first() == Some(&0) { Ok(body) } else { Err(String::from_utf8_lossy(&body).into_owned()) });
        }
        let failed = parts.iter().enumerate().find_map(|(r, p)| p.as_ref().err().map(|m| (r, m.clone())));
        let out = match failed {
            Some((r, message)) => encode(1, r, message.as_bytes()),
            None => match combine(parts.into_iter().map(|p| p.expect("no rank failed")).collect()) {
                Ok(bytes) => encode(0, 0, &bytes),
                Err(message) => encode(1, 0, message.as_bytes()),
            },
        };
        for to in 1..comm.size() {
            comm.send(to, TAG_REDUCED, &out)?;
        }
        out
    } else {
        let m = match &mine {
            Ok(bytes) => {
                let mut v = vec![0u8];
                v.extend_from_slice(bytes);
                v
            }
            Err(message) => {
                let mut v = vec![1u8];
                v.extend_from_slice(message.as_bytes());
                v
            }
        };
        comm.send(0, TAG_REDUCE, &m)?;
        comm.recv(0, TAG_REDUCED, comm.timeout())?
    };
    if result.len() < 9 {
        return Err(DistributedError::Malformed {
            rank,
            from: 0,
            tag: TAG_REDUCED,
            what: "a result of no kind".into(),
        });
    }
    let r = u64::from_le_bytes(result[1..9].try_into().expect("8 bytes")) as usize;
    match result[0] {
        0 => Ok(result[9..].to_vec()),
        _ => Err(DistributedError::RankFailed { rank: r, message: String::from_utf8_lossy(&result[9..]).into_owned() }),
    }
}

/// What compositing cost this rank.
#[derive(Debug, Clone, Copy, Default, PartialEq)]
pub struct CompositeStats {
    pub bytes_sent: u64,
    pub bytes_received: u64,
    pub messages: u64,
    pub seconds: f64,
}

/// A region's message: its length, the offset and pixels of its span from
/// the first to the last pixel that is not empty (all four channels 0; a
/// piece's image is empty off its screen footprint, and transparent pixels
/// change nothing under "over"), little-endian.
fn encode_span(px: &[[f32; 4]]) -> Vec<u8> {
    let filled = |p: &&[f32; 4]| p.iter().any(|&c| c != 0.0);
    let first = px.iter().position(|p| filled(&p)).unwrap_or(px.len());
    let last = px.iter().rposition(|p| filled(&p)).map_or(first, |l| l + 1);
    let mut v = Vec::with_capacity(16 + (last - first) * 16);
    v.extend_from_slice(&(px.len() as u64).to_le_bytes());
    v.extend_from_slice(&(first as u64).to_le_bytes());
    if cfg!(target_endian = "little") {
        // The pixels' bytes as they are in memory: one copy.
        v.extend_from_slice(bytemuck::cast_slice(&px[first..last]));
    } else {
        for p in &px[first..last] {
            for c in p {
                v.extend_from_slice(&c.to_le_bytes());
            }
        }
    }
    v
}

/// The span (offset, pixels) of a message for a region of `n` pixels.
fn decode_span(
    b: &[u8],
    n: usize,
    rank: usize,
    from: usize,
    tag: i32,
) -> Result<(usize, Vec<[f32; 4]>), DistributedError> {
    let bad = |what: String| DistributedError::Malformed { rank, from, tag, what };
    if b.len() < 16 || !(b.len() - 16).is_multiple_of(16) {
        return Err(bad(format!("{} bytes is not a region message", b.len())));
    }
    let word = |k: usize| u64::from_le_bytes(b[8 * k..8 * k + 8].try_into().expect("8 bytes")) as usize;
    let (len, offset, count) = (word(0), word(1), (b.len() - 16) / 16);
    if len != n || offset.checked_add(count).is_none_or(|end| end > n) {
        return Err(bad(format!(
            "a region of {len} pixels with {count} from {offset}, for {n} pixels (an image of another size?)"
        )));
    }
    let px = if cfg!(target_endian = "little") {
        // One copy into aligned pixels (a message's bytes need not be aligned).
        let mut px = vec![[0.0f32; 4]; count];
        bytemuck::cast_slice_mut::<[f32; 4], u8>(&mut px).copy_from_slice(&b[16..]);
        px
    } else {
        b[16..]
            .chunks_exact(16)
            .map(|p| std::array::from_fn(|k| f32::from_le_bytes(p[4 * k..4 * k + 4].try_into().expect("4 bytes"))))
            .collect()
    };
    Ok((offset, px))
}

/// Composites every rank's image (premultiplied linear RGBA, the same size
/// on every rank) front to back in `order` (ranks, front first, the same
/// on every rank). Rank 0 returns the image, the others `None`.
///
/// Binary swap: the first `P − 2^⌊log₂P⌋` adjacent pairs of the order fold
/// into one (the back sends its image to the front), then each of the
/// remaining 2^k ranks, in order, swaps halves of its region with its
/// partner at each of k stages, keeping one half composited front over
/// back; rank 0 gathers the 2^k final regions. Every message carries only
/// the span of its region between the first and the last pixel that is not
/// empty, so a rank sends at most about two images' worth of pixels, and
/// little more than its pieces' screen footprint.
pub fn composite<C: Comm + ?Sized>(
    comm: &C,
    mine: Image,
    order: &[usize],
) -> Result<(Option<Image>, CompositeStats), DistributedError> {
    let start = Instant::now();
    let (rank, size) = (comm.rank(), comm.size());
    let mut seen = vec![false; size];
    if order.len() != size || order.iter().any(|&r| r >= size || std::mem::replace(&mut seen[r], true)) {
        return Err(DistributedError::BadOrder { order: order.to_vec(), size });
    }
    let (w, h) = (mine.width(), mine.height());
    let n = mine.pixels().len();
    let mut px = mine.pixels().to_vec();
    let mut st = CompositeStats::default();
    let send = |to: usize, tag: i32, data: &[[f32; 4]], st: &mut CompositeStats| {
        let b = encode_span(data);
        st.bytes_sent += b.len() as u64;
        st.messages += 1;
        comm.send(to, tag, &b)
    };
    let recv = |from: usize, tag: i32, count: usize, st: &mut CompositeStats| {
        let b = comm.recv(from, tag, comm.timeout())?;
        st.bytes_received += b.len() as u64;
        decode_span(&b, count, rank, from, tag)
    };

    let pos = order.iter().position(|&r| r == rank).expect("a permutation holds every rank");
    let k = 1usize << (usize::BITS - 1 - size.leading_zeros());
    let extra = size - k;
    // Fold: position 2i + 1 (behind) sends to 2i (in front), i < extra.
    let vpos = if pos < 2 * extra {
        if pos % 2 == 1 {
            send(order[pos - 1], TAG_FOLD, &px, &mut st)?;
            None
        } else {
            let (at, back) = recv(order[pos + 1], TAG_FOLD, n, &mut st)?;
            for (p, b) in px[at..].iter_mut().zip(&back) {
                *p = over(*p, *b);
            }
            Some(pos / 2)
        }
    } else {
        Some(pos - extra)
    };
    // The rank at each virtual position (each a run of the order).
    let vrank = |v: usize| if v < extra { order[2 * v] } else { order[v + extra] };
    let stages = k.trailing_zeros();
    // Region of virtual rank v after all stages.
    let region = |v: usize| {
        let (mut lo, mut hi) = (0usize, n);
        for s in 0..stages {
            let mid = lo + (hi - lo) / 2;
            if (v >> s) & 1 == 0 {
                hi = mid;
            } else {
                lo = mid;
            }
        }
        (lo, hi)
    };
    if let Some(v) = vpos {
        let (mut lo, mut hi) = (0usize, n);
        for s in 0..stages {
            let partner = vrank(v ^ (1 << s));
            let mid = lo + (hi - lo) / 2;
            let front = (v >> s) & 1 == 0;
            let (keep, give) = if front { ((lo, mid), (mid, hi)) } else { ((mid, hi), (lo, mid)) };
            let tag = TAG_SWAP + s as i32;
            // The front sends first, the back receives first: blocking
            // sends of large messages cannot deadlock.
            let theirs = if front {
                send(partner, tag, &px[give.0..give.1], &mut st)?;
                recv(partner, tag, keep.1 - keep.0, &mut st)?
            } else {
                let t = recv(partner, tag, keep.1 - keep.0, &mut st)?;
                send(partner, tag, &px[give.0..give.1], &mut st)?;
                t
            };
            // Off their span their pixels are empty: ours stay as they are.
            let (at, theirs) = theirs;
            for (p, t) in px[keep.0 + at..keep.1].iter_mut().zip(&theirs) {
                *p = if front { over(*p, *t) } else { over(*t, *p) };
            }
            (lo, hi) = keep;
        }
        if rank != 0 {
            send(0, TAG_GATHER, &px[lo..hi], &mut st)?;
        }
    }
    if rank != 0 {
        st.seconds = start.elapsed().as_secs_f64();
        return Ok((None, st));
    }
    let mut out = vec![[0.0f32; 4]; n];
    for v in 0..k {
        let (lo, hi) = region(v);
        let from = vrank(v);
        if from == 0 {
            out[lo..hi].copy_from_slice(&px[lo..hi]);
        } else {
            let (at, span) = recv(from, TAG_GATHER, hi - lo, &mut st)?;
            out[lo + at..lo + at + span.len()].copy_from_slice(&span);
        }
    }
    st.seconds = start.elapsed().as_secs_f64();
    let image = Image::from_pixels(w, h, out).map_err(|e| DistributedError::Malformed {
        rank,
        from: rank,
        tag: TAG_GATHER,
        what: e.to_string(),
    })?;
    Ok((Some(image), st))
}

/// A rank's test image: a pseudo-random premultiplied colour per pixel
/// (α in [0, 1], colour ≤ α, a fifth of the pixels empty) from `rank` and
/// `seed` (the tests' and `tet-distributed-selftest`'s).
pub fn seeded_image(rank: usize, seed: u64, w: u32, h: u32) -> Image {
    let mut x = seed ^ (rank as u64 + 1).wrapping_mul(0x9E37_79B9_7F4A_7C15);
    let mut next = || {
        x ^= x << 13;
        x ^= x >> 7;
        x ^= x << 17;
        (x >> 40) as f32 / (1u64 << 24) as f32
    };
    let px = (0..w * h)
        .map(|_| {
            let a = if next() < 0.2 { 0.0 } else { next() };
            [a * next(), a * next(), a * next(), a]
        })
        .collect();
    Image::from_pixels(w, h, px).expect("w × h pixels")
}

/// `images[order[0]]` over `images[order[1]]` over …, pixel by pixel, in
/// one process: what [`composite`] must equal.
pub fn sequential_over(images: &[Image], order: &[usize]) -> Vec<[f32; 4]> {
    let n = images.first().map_or(0, |i| i.pixels().len());
    (0..n).map(|p| order.iter().fold([0.0; 4], |acc, &r| over(acc, images[r].pixels()[p]))).collect()
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::ThreadComm;
    use proptest::prelude::*;

    fn image_of(rank: usize, seed: u64, w: u32, h: u32) -> Image {
        seeded_image(rank, seed, w, h)
    }

    fn sequential(order: &[usize], seed: u64, w: u32, h: u32) -> Vec<[f32; 4]> {
        let imgs: Vec<Image> = (0..order.len()).map(|r| image_of(r, seed, w, h)).collect();
        sequential_over(&imgs, order)
    }

    proptest! {
        #![proptest_config(ProptestConfig::with_cases(24))]
        /// Any rank count, any visibility order, any image size: rank 0's
        /// image is the sequential front-to-back composite within f32
        /// rounding; no other rank has one.
        #[test]
        fn binary_swap_equals_sequential_over(
            size in 1usize..7,
            perm_seed in any::<u64>(),
            seed in any::<u64>(),
            w in 1u32..9,
            h in 1u32..6,
        ) {
            let mut order: Vec<usize> = (0..size).collect();
            let mut x = perm_seed | 1;
            for i in (1..size).rev() {
                x ^= x << 13; x ^= x >> 7; x ^= x << 17;
                order.swap(i, (x % (i as u64 + 1)) as usize);
            }
            let out = ThreadComm::run(size, |c| composite(c, image_of(c.rank(), seed, w, h), &order).unwrap());
            let want = sequential(&order, seed, w, h);
            let got = out[0].0.as_ref().unwrap();
            for (g, e) in got.pixels().iter().zip(&want) {
                for k in 0..4 {
                    prop_assert!((g[k] - e[k]).abs() <= 1e-6, "{:?} vs {:?}", g, e);
                }
            }
            prop_assert!(out[1..].iter().all(|(img, _)| img.is_none()));
            // No rank sends more than two images' worth of pixels (each
            // message adds a 16-byte header).
            let image_bytes = (w * h) as u64 * 16;
            prop_assert!(out.iter().all(|(_, s)| s.bytes_sent - 16 * s.messages <= 2 * image_bytes));
        }
    }

    /// Images empty off a band of rows (a piece's footprint): the same
    /// result, and messages carry the bands, not the whole regions.
    #[test]
    fn sparse_images_send_their_footprint() {
        let (w, h) = (32u32, 48u32);
        let band = |rank: usize, img: Image| {
            let rows = (rank * 8..rank * 8 + 6).collect::<Vec<_>>();
            let px = img
                .pixels()
                .iter()
                .enumerate()
                .map(|(p, &v)| if rows.contains(&(p / w as usize)) { v } else { [0.0; 4] })
                .collect();
            Image::from_pixels(w, h, px).unwrap()
        };
        let order = [3, 1, 0, 2, 4];
        let out = ThreadComm::run(5, |c| composite(c, band(c.rank(), image_of(c.rank(), 9, w, h)), &order).unwrap());
        let imgs: Vec<Image> = (0..5).map(|r| band(r, image_of(r, 9, w, h))).collect();
        let want = sequential_over(&imgs, &order);
        for (g, e) in out[0].0.as_ref().unwrap().pixels().iter().zip(&want) {
            assert!((0..4).all(|k| (g[k] - e[k]).abs() <= 1e-6), "{g:?} vs {e:?}");
        }
        // Dense, five ranks send 4.75 images in all (a fold, two swap
        // stages, three gathers); bands of a sixth of the rows, far less.
        let full = (w * h) as u64 * 16;
        let sent: u64 = out.iter().map(|(_, s)| s.bytes_sent).sum();
        assert!(sent < 2 * full, "{sent} bytes sent in all for images of {full}");
    }

    #[test]
    fn bad_orders_are_refused_on_every_rank() {
        for order in [vec![0, 1], vec![0, 0, 1], vec![0, 1, 3], vec![2, 1, 0, 1]] {
            let out = ThreadComm::run(3, |c| composite(c, image_of(c.rank(), 1, 2, 2), &order).map(|_| ()));
            assert!(out.iter().all(|r| matches!(r, Err(DistributedError::BadOrder { .. }))), "{order:?}");
        }
    }

    /// Every rank returns the same verdict: the lowest failing rank's
    /// message, else the first differing rank and line, else Ok.
    #[test]
    fn agreement_gives_every_rank_one_verdict() {
        let ok = |_: usize| Ok::<String, String>("view=a\ntf=b\nsize=4x4".into());
        assert!(ThreadComm::run(4, |c| agree(c, ok(c.rank()))).iter().all(|r| r.is_ok()));
        let out = ThreadComm::run(4, |c| {
            agree(c, if c.rank() >= 2 { Err(format!("piece {} is missing", c.rank())) } else { ok(c.rank()) })
        });
        for r in &out {
            let e = r.as_ref().unwrap_err();
            assert!(matches!(e, DistributedError::RankFailed { rank: 2, .. }), "{e}");
            assert_eq!(e.to_string(), "rank 2: piece 2 is missing");
        }
        let out = ThreadComm::run(3, |c| {
            agree(c, Ok(if c.rank() == 1 { "view=a\ntf=c\nsize=4x4".into() } else { "view=a\ntf=b\nsize=4x4".into() }))
        });
        for r in &out {
            let e = r.as_ref().unwrap_err();
            assert!(matches!(e, DistributedError::Disagree { rank: 1, .. }), "{e}");
            assert!(e.to_string().contains("'tf=c' against 'tf=b'"), "{e}");
        }
        assert!(agree(&OneRank, ok(0)).is_ok());
        assert!(matches!(agree(&OneRank, Err("no piece".into())), Err(DistributedError::RankFailed { rank: 0, .. })));
    }

    /// A communicator of one rank (for the single-rank case above).
    struct OneRank;
    impl Comm for OneRank {
        fn rank(&self) -> usize {
            0
        }
        fn size(&self) -> usize {
            1
        }
        fn send(&self, _: usize, _: i32, _: &[u8]) -> Result<(), DistributedError> {
            unreachable!("one rank sends nothing")
        }
        fn recv(&self, _: usize, _: i32, _: std::time::Duration) -> Result<Vec<u8>, DistributedError> {
            unreachable!("one rank receives nothing")
        }
    }

    /// The barrier holds every rank until all have reached it.
    #[test]
    fn reduce_combines_in_rank_order_and_shares_failures() {
        // A sum of each rank's number, in rank order, on every rank.
        let got = ThreadComm::run(4, |comm| {
            let mine = Ok(vec![comm.rank() as u8 + 1]);
            reduce(comm, mine, |parts| {
                assert_eq!(parts, vec![vec![1], vec![2], vec![3], vec![4]]);
                Ok(vec![parts.iter().map(|p| p[0]).sum()])
            })
            .unwrap()
        });
        assert!(got.iter().all(|g| g == &[10u8]), "{got:?}");
        // Rank 2 fails: every rank gets its message, combine never runs.
        let got = ThreadComm::run(3, |comm| {
            let mine = if comm.rank() == 2 { Err("no histogram in piece 2".to_string()) } else { Ok(vec![1]) };
            reduce(comm, mine, |_| unreachable!("a rank failed")).unwrap_err().to_string()
        });
        assert!(got.iter().all(|e| e == "rank 2: no histogram in piece 2"), "{got:?}");
        // combine refuses: rank 0's error everywhere.
        let got = ThreadComm::run(2, |comm| {
            reduce(comm, Ok(vec![comm.rank() as u8]), |_| Err("axes differ".into())).unwrap_err().to_string()
        });
        assert!(got.iter().all(|e| e == "rank 0: axes differ"), "{got:?}");
    }

    #[test]
    fn barrier_waits_for_every_rank() {
        let reached = std::sync::atomic::AtomicUsize::new(0);
        let seen = ThreadComm::run(4, |c| {
            std::thread::sleep(std::time::Duration::from_millis(10 * c.rank() as u64));
            reached.fetch_add(1, std::sync::atomic::Ordering::SeqCst);
            c.barrier().unwrap();
            reached.load(std::sync::atomic::Ordering::SeqCst)
        });
        assert_eq!(seen, [4, 4, 4, 4]);
    }

    /// A rank whose message never comes: the waiting rank gives up with
    /// the peer and tag named (the test shortens the wait).
    #[test]
    fn a_missing_message_is_a_bounded_wait() {
        let out = ThreadComm::run(2, |c| {
            if c.rank() == 0 {
                c.recv(1, 5, std::time::Duration::from_millis(50)).map(|_| ())
            } else {
                Ok(())
            }
        });
        let e = out[0].as_ref().unwrap_err();
        assert!(matches!(e, DistributedError::Timeout { rank: 0, from: 1, tag: 5, .. }), "{e}");
    }

    /// Images of different sizes: the receiving rank says whose and why,
    /// and its partner, left waiting, gives up after the wait.
    #[test]
    fn images_of_another_size_are_malformed() {
        let out = ThreadComm::run_with_timeout(2, std::time::Duration::from_millis(200), |c| {
            let (w, h) = if c.rank() == 0 { (4, 4) } else { (4, 3) };
            composite(c, image_of(c.rank(), 3, w, h), &[0, 1]).map(|_| ())
        });
        assert!(matches!(out[1], Err(DistributedError::Malformed { rank: 1, from: 0, .. })), "{out:?}");
        assert!(matches!(out[0], Err(DistributedError::Timeout { rank: 0, from: 1, .. })), "{out:?}");
    }
}
