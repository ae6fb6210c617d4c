//! Sort-last compositing across ranks, and the agreement that comes first.
//!
//! A distributed frame is drawn by every rank over its own pieces of the
//! mesh (premultiplied linear RGBA over the whole screen) and composited
//! front to back in the visibility order of the pieces — a k-d tree's
//! order from the eye — so the result is the single-process image up to
//! f32 rounding: "over" is associative, and each rank's image already
//! holds its pieces' part of every ray.
//!
//! * [`Comm`]: what the algorithms need of a communicator (rank, size,
//!   tagged byte messages, receives with a deadline). [`ThreadComm`] runs
//!   ranks as threads of one process (tests, and one machine without MPI);
//!   with the `mpi` feature, [`MpiComm`] runs them over MPI (rsmpi).
//! * [`agree`]: every rank reports its state (a fingerprint of its request,
//!   or the error it met reading its pieces); all ranks return the same
//!   verdict, so bad input stops every rank with one message and no rank
//!   waits for an image that never comes.
//! * [`reduce`]: every rank's bytes (or error) combined on rank 0 and the
//!   result handed to all, failures included (the automatic TF of a
//!   partition sums the pieces' histograms through it).
//! * [`composite`]: binary swap (Ma, Painter, Hansen and Krogh, "Parallel
//!   Volume Rendering Using Binary-Swap Compositing", IEEE CG&A 1994) over
//!   ranks in visibility order, non-powers of two folded first; rank 0 ends
//!   with the image ([`CompositeStats`]: bytes and seconds).
//!
//! ```
//! use tet_distributed::{composite, over, Comm, ThreadComm};
//! use tet_render::Image;
//!
//! // Three ranks, each with a flat image; visibility order 2, 0, 1.
//! let colour = |r: usize| [0.1 * (r + 1) as f32, 0.0, 0.2, 0.25 * (r + 1) as f32];
//! let images = ThreadComm::run(3, |comm| {
//!     let mine = Image::from_pixels(4, 2, vec![colour(comm.rank()); 8]).unwrap();
//!     composite(comm, mine, &[2, 0, 1]).unwrap().0
//! });
//! let root = images[0].as_ref().unwrap();
//! let want = over(over(colour(2), colour(0)), colour(1));
//! assert!(root.pixels().iter().all(|p| (0..4).all(|k| (p[k] - want[k]).abs() < 1e-6)));
//! assert!(images[1].is_none() && images[2].is_none());
//! ```
#![forbid(unsafe_code)]

mod comm;
mod composite;

#[cfg(feature = "mpi")]
pub use comm::mpi_comm::MpiComm;
pub use comm::{Comm, ThreadComm};
pub use composite::{agree, composite, over, reduce, seeded_image, sequential_over, CompositeStats};

use std::time::Duration;

/// How long a rank waits for a message before it gives up (a rank that
/// died or never got there): no distributed run hangs.
pub const RECEIVE_TIMEOUT: Duration = Duration::from_secs(120);

/// What can go wrong between ranks.
#[derive(Debug, thiserror::Error)]
pub enum DistributedError {
    /// A rank failed before compositing (its message, as every rank reports it).
    #[error("rank {rank}: {message}")]
    RankFailed { rank: usize, message: String },
    /// Ranks were given different requests (view, TF, method, manifest).
    #[error("ranks disagree on the request: rank {rank} differs from rank 0 ({what})")]
    Disagree { rank: usize, what: String },
    /// The order does not name every rank once.
    #[error("visibility order {order:?} is not a permutation of the {size} ranks")]
    BadOrder { order: Vec<usize>, size: usize },
    /// Images of different sizes.
    #[error("rank {rank} drew {got:?} pixels, rank 0 {want:?}")]
    SizeMismatch { rank: usize, got: [u32; 2], want: [u32; 2] },
    /// No message came in time.
    #[error("rank {rank}: no message from rank {from} (tag {tag}) within {waited:?}")]
    Timeout { rank: usize, from: usize, tag: i32, waited: Duration },
    /// A message of the wrong length or shape.
    #[error("rank {rank}: malformed message from rank {from} (tag {tag}): {what}")]
    Malformed { rank: usize, from: usize, tag: i32, what: String },
    /// The communicator failed (a peer gone, MPI's own error).
    #[error("rank {rank}: {what}")]
    Transport { rank: usize, what: String },
}
