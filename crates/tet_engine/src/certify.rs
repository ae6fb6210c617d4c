//! Certified table3d bakes beside the frames: a front end draws a plain
//! table at once and swaps in the certified one when its bake is done.

use std::sync::mpsc::{Receiver, TryRecvError};
use std::sync::Arc;
use std::time::Instant;

use tet_bundle::Bundle;
use tet_preint::{
    Baked, CertifiedTable3d, CertifyOptions, Method, Table3dParams, TableDomain, TableError, TransferFunction,
};

use crate::{count_table_bake, EngineError, Look};

/// A certified bake to run: the plain look's key, its TF and its table's
/// resolution (the start of the refinement).
struct Job {
    key: u64,
    tf: TransferFunction,
    params: Table3dParams,
}

/// The bake on its thread, and when it started.
struct Running {
    key: u64,
    tf: TransferFunction,
    started: Instant,
    rx: Receiver<Result<CertifiedTable3d, TableError>>,
}

/// Runs the certified bake ([`tet_preint::certify::bake`]: the bake
/// measures its own error and refines until it holds the target) of plain
/// table3d looks on a thread, one at a time. While a bake runs, only the
/// newest look asked for waits behind it (a TF being dragged asks for
/// every revision; the ones in between are never baked). The last result
/// is kept, as a look that draws the certified table, for the plain look's
/// [`Look::key`].
pub struct Certifier {
    domain: TableDomain,
    options: CertifyOptions,
    /// Segments through the bundle's cells, measured by every bake besides
    /// its own sets ([`tet_preint::certify::cell_triples`]).
    cells: Arc<Vec<[f32; 3]>>,
    running: Option<Running>,
    queued: Option<Job>,
    /// The plain look's key and its certified look (or why there is none).
    done: Option<(u64, Result<Look, EngineError>)>,
}

impl Certifier {
    /// Certified bakes over `domain` (the domain the plain looks are baked
    /// over) with `options`, measuring segments through `bundle`'s cells
    /// too. `options.max_error` must be set: a bake that measures nothing
    /// certifies nothing.
    pub fn new(bundle: &Bundle, domain: TableDomain, options: CertifyOptions) -> Result<Certifier, EngineError> {
        if options.max_error.is_none() {
            return Err(EngineError::Bake {
                method: Method::Table3d,
                source: TableError::Invalid("a certifier needs a target max error (CertifyOptions::max_error)".into()),
            });
        }
        let cells = tet_preint::certify::cell_triples(bundle, &domain, options.samples, options.seed);
        Ok(Certifier { domain, options, cells: Arc::new(cells), running: None, queued: None, done: None })
    }

    /// Asks for the certified table of `look`, a table3d look with baked
    /// tables (its TF, starting at its table's resolution): started now,
    /// or queued behind the running bake in place of any look queued
    /// before. Nothing to do when that look's bake runs or is done.
    pub fn certify(&mut self, look: &Look) -> Result<(), EngineError> {
        let key = look.key();
        if self.running.as_ref().is_some_and(|r| r.key == key) || self.done.as_ref().is_some_and(|d| d.0 == key) {
            return Ok(());
        }
        let params = match look.baked.as_deref() {
            Some(Baked::Table3d(t)) => *t.params(),
            _ => return Err(EngineError::NotCertifiable { method: look.method }),
        };
        let job = Job { key, tf: look.tf.clone(), params };
        if self.running.is_some() {
            self.queued = Some(job);
        } else {
            self.start(job);
        }
        Ok(())
    }

    fn start(&mut self, job: Job) {
        let (tx, rx) = std::sync::mpsc::channel();
        let (domain, options, cells) = (self.domain, self.options, self.cells.clone());
        let tf = job.tf.clone();
        count_table_bake();
        std::thread::spawn(move || {
            let res = tet_preint::tf_for_bake(Method::Table3d, &tf, &domain)
                .and_then(|tf| tet_preint::certify::bake(&tf, &domain, &job.params, &options, &cells));
            // The certifier may be gone (its front end closed): nothing to tell.
            let _ = tx.send(res);
        });
        self.running = Some(Running { key: job.key, tf: job.tf, started: Instant::now(), rx });
    }

    /// Takes the running bake's result if it is done and starts the queued
    /// one; returns the key of the plain look whose bake just finished.
    pub fn poll(&mut self) -> Option<u64> {
        let res = match self.running.as_ref()?.rx.try_recv() {
            Ok(res) => Some(res),
            Err(TryRecvError::Empty) => return None,
            Err(TryRecvError::Disconnected) => None,
        };
        Some(self.finish(res))
    }

    /// Blocks until no bake runs or waits; returns the key of the last one
    /// that finished, if any did.
    pub fn wait(&mut self) -> Option<u64> {
        let mut last = None;
        while let Some(running) = &self.running {
            let res = running.rx.recv().ok();
            last = Some(self.finish(res));
        }
        last
    }

    /// Records the running bake's result (`None`: its thread stopped without
    /// one) and starts the queued bake.
    fn finish(&mut self, res: Option<Result<CertifiedTable3d, TableError>>) -> u64 {
        let running = self.running.take().expect("finish is called for a running bake");
        let look = match res {
            Some(Ok(table)) => {
                let seconds = running.started.elapsed().as_secs_f64();
                let look = Look::new(running.tf, Method::Table3d, Some(Baked::Table3d(table)), None, seconds);
                Ok(look)
            }
            Some(Err(source)) => Err(EngineError::Bake { method: Method::Table3d, source }),
            None => Err(EngineError::CertifyStopped),
        };
        self.done = Some((running.key, look));
        if let Some(job) = self.queued.take() {
            if job.key != running.key {
                self.start(job);
            }
        }
        running.key
    }

    /// The certified look of the plain look with key `plain_key`, once its
    /// bake is done (`Err`: the bake failed; the plain look stays as good
    /// as it was).
    pub fn certified(&self, plain_key: u64) -> Option<Result<&Look, &EngineError>> {
        match &self.done {
            Some((k, res)) if *k == plain_key => Some(res.as_ref()),
            _ => None,
        }
    }

    /// Whether a bake runs (or waits to).
    pub fn is_busy(&self) -> bool {
        self.running.is_some()
    }
}
