//! Communicators: what compositing needs of one, in-process threads, and
//! (feature `mpi`) MPI.

use crate::{DistributedError, RECEIVE_TIMEOUT};
use std::cell::RefCell;
use std::sync::mpsc::{channel, Receiver, RecvTimeoutError, Sender};
use std::time::{Duration, Instant};

/// Ranks exchanging tagged byte messages. A send may block until the
/// receiver takes the message (MPI's rendezvous for large messages), so
/// two ranks that exchange must not both send first; a receive gives up
/// after `timeout`.
pub trait Comm {
    fn rank(&self) -> usize;
    fn size(&self) -> usize;
    fn send(&self, to: usize, tag: i32, data: &[u8]) -> Result<(), DistributedError>;
    fn recv(&self, from: usize, tag: i32, timeout: Duration) -> Result<Vec<u8>, DistributedError>;
    /// How long [`crate::agree`] and [`crate::composite`] wait for a message.
    fn timeout(&self) -> Duration {
        RECEIVE_TIMEOUT
    }

    /// Waits until every rank has called it (at most [`Comm::timeout`] for
    /// each message). Ranks that stop on an agreed error call it after
    /// printing, so that `mpirun`, which ends the job when the first rank
    /// exits with an error, cannot cut another rank's message off.
    fn barrier(&self) -> Result<(), DistributedError> {
        const TAG_BARRIER: i32 = 0x7ff0;
        if self.rank() == 0 {
            for from in 1..self.size() {
                self.recv(from, TAG_BARRIER, self.timeout())?;
            }
            for to in 1..self.size() {
                self.send(to, TAG_BARRIER, &[])?;
            }
        } else {
            self.send(0, TAG_BARRIER, &[])?;
            self.recv(0, TAG_BARRIER, self.timeout())?;
        }
        Ok(())
    }
}

type Message = (usize, i32, Vec<u8>);

/// Ranks as threads of one process, linked by channels: the algorithms'
/// tests, and distributed rendering on one machine without MPI.
pub struct ThreadComm {
    rank: usize,
    to: Vec<Sender<Message>>,
    inbox: Receiver<Message>,
    /// Messages that arrived before they were asked for.
    pending: RefCell<Vec<Message>>,
    timeout: Duration,
}

impl ThreadComm {
    /// Runs `f` on `size` ranks, each a thread with its communicator, and
    /// returns their results in rank order.
    pub fn run<T: Send>(size: usize, f: impl Fn(&ThreadComm) -> T + Sync) -> Vec<T> {
        ThreadComm::run_with_timeout(size, RECEIVE_TIMEOUT, f)
    }

    /// [`ThreadComm::run`] with another wait for messages than
    /// [`RECEIVE_TIMEOUT`] (tests of ranks that stop early).
    pub fn run_with_timeout<T: Send>(size: usize, timeout: Duration, f: impl Fn(&ThreadComm) -> T + Sync) -> Vec<T> {
        let (senders, inboxes): (Vec<_>, Vec<_>) = (0..size).map(|_| channel::<Message>()).unzip();
        std::thread::scope(|s| {
            let handles: Vec<_> = inboxes
                .into_iter()
                .enumerate()
                .map(|(rank, inbox)| {
                    let comm =
                        ThreadComm { rank, to: senders.clone(), inbox, pending: RefCell::new(Vec::new()), timeout };
                    let f = &f;
                    s.spawn(move || f(&comm))
                })
                .collect();
            handles.into_iter().map(|h| h.join().expect("a rank's thread panicked")).collect()
        })
    }
}

impl Comm for ThreadComm {
    fn rank(&self) -> usize {
        self.rank
    }

    fn size(&self) -> usize {
        self.to.len()
    }

    fn send(&self, to: usize, tag: i32, data: &[u8]) -> Result<(), DistributedError> {
        let peer = self.to.get(to).ok_or_else(|| DistributedError::Transport {
            rank: self.rank,
            what: format!("no rank {to} among {}", self.to.len()),
        })?;
        peer.send((self.rank, tag, data.to_vec()))
            .map_err(|_| DistributedError::Transport { rank: self.rank, what: format!("rank {to} has stopped") })
    }

    fn timeout(&self) -> Duration {
        self.timeout
    }

    fn recv(&self, from: usize, tag: i32, timeout: Duration) -> Result<Vec<u8>, DistributedError> {
        let mut pending = self.pending.borrow_mut();
        if let Some(i) = pending.iter().position(|m| m.0 == from && m.1 == tag) {
            return Ok(pending.remove(i).2);
        }
        let deadline = Instant::now() + timeout;
        loop {
            let left = deadline.saturating_duration_since(Instant::now());
            match self.inbox.recv_timeout(left) {
                Ok(m) if m.0 == from && m.1 == tag => return Ok(m.2),
                Ok(m) => pending.push(m),
                Err(RecvTimeoutError::Timeout) => {
                    return Err(DistributedError::Timeout { rank: self.rank, from, tag, waited: timeout })
                }
                Err(RecvTimeoutError::Disconnected) => {
                    return Err(DistributedError::Transport { rank: self.rank, what: "every peer has stopped".into() })
                }
            }
        }
    }
}

#[cfg(feature = "mpi")]
pub(crate) mod mpi_comm {
    use super::Comm;
    use crate::DistributedError;
    use mpi::point_to_point::{Destination, Source};
    use mpi::topology::{Communicator, SimpleCommunicator};
    use std::time::{Duration, Instant};

    /// The ranks of `mpirun` (MPI_COMM_WORLD through rsmpi). MPI is
    /// initialized by [`MpiComm::init`] and finalized when it drops.
    pub struct MpiComm {
        world: SimpleCommunicator,
        _universe: mpi::environment::Universe,
    }

    impl MpiComm {
        /// Initializes MPI (once a process); `None` if it already was.
        pub fn init() -> Option<MpiComm> {
            let universe = mpi::initialize()?;
            Some(MpiComm { world: universe.world(), _universe: universe })
        }
    }

    impl Comm for MpiComm {
        fn rank(&self) -> usize {
            self.world.rank() as usize
        }

        fn size(&self) -> usize {
            self.world.size() as usize
        }

        fn send(&self, to: usize, tag: i32, data: &[u8]) -> Result<(), DistributedError> {
            if to >= self.size() {
                return Err(DistributedError::Transport {
                    rank: self.rank(),
                    what: format!("no rank {to} among {}", self.size()),
                });
            }
            self.world.process_at_rank(to as i32).send_with_tag(data, tag);
            Ok(())
        }

        fn recv(&self, from: usize, tag: i32, timeout: Duration) -> Result<Vec<u8>, DistributedError> {
            let peer = self.world.process_at_rank(from as i32);
            // Probe until the message is there, so that a rank that died or
            // never sends is a bounded wait, not a hang.
            let deadline = Instant::now() + timeout;
            let mut nap = Duration::from_micros(50);
            while peer.immediate_probe_with_tag(tag).is_none() {
                if Instant::now() >= deadline {
                    return Err(DistributedError::Timeout { rank: self.rank(), from, tag, waited: timeout });
                }
                std::thread::sleep(nap);
                nap = (nap * 2).min(Duration::from_millis(5));
            }
            let (data, _) = peer.receive_vec_with_tag::<u8>(tag);
            Ok(data)
        }
    }
}
