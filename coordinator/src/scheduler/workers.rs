//! Workers: joining, leaving, going silent, and the slots each has free.

use super::{Outbox, Scheduler};
use farm_common::ids::{JobId, WorkerId};
use std::collections::HashSet;
use std::time::Instant;
use tracing::{info, warn};

pub(super) struct Worker {
    pub(super) name: String,
    pub(super) threads: u32,
    pub(super) max_in_flight: u32,
    pub(super) in_flight: HashSet<(JobId, u32)>,
    pub(super) last_seen: Instant,
    pub(super) tiles_done: u64,
    /// When it joined.
    pub(super) joined: Instant,
    /// Tiles it failed or sent back malformed.
    pub(super) failures: u64,
}

/// A worker row of `farm status`.
#[derive(Clone, Debug, PartialEq)]
pub struct WorkerRow {
    /// Id.
    pub id: WorkerId,
    /// Name.
    pub name: String,
    /// Render threads.
    pub threads: u32,
    /// Tiles held.
    pub in_flight: u32,
    /// Tiles returned.
    pub tiles_done: u64,
}

impl Scheduler {
    /// A worker opened its session, asking to hold `max_in_flight` tiles at
    /// once; it gets at most the configured cap, so no worker can hoard a
    /// job by asking for more.
    pub fn worker_joined(
        &mut self,
        id: WorkerId,
        name: String,
        threads: u32,
        max_in_flight: u32,
        now: Instant,
        out: &mut impl Outbox,
    ) {
        let max_in_flight = max_in_flight.clamp(1, self.config.max_in_flight.max(1));
        info!(worker = id.0, %name, threads, max_in_flight, "worker joined");
        let w = Worker {
            name,
            threads,
            max_in_flight,
            in_flight: HashSet::new(),
            last_seen: now,
            tiles_done: 0,
            joined: now,
            failures: 0,
        };
        self.workers.insert(id, w);
        self.ready.insert(id);
        self.fill(out);
    }

    /// A worker's session ended: its tiles go back to the queue.
    pub fn worker_left(&mut self, id: WorkerId, out: &mut impl Outbox) {
        let Some(w) = self.workers.remove(&id) else { return };
        self.ready.remove(&id);
        info!(worker = id.0, tiles = w.in_flight.len(), "worker left; its tiles are requeued");
        let mut lost: Vec<(JobId, u32)> = w.in_flight.into_iter().collect();
        lost.sort_unstable();
        for (job, tile) in lost.into_iter().rev() {
            if let Some(j) = self.jobs.get_mut(&job) {
                let held = j.in_flight.get(&tile).is_some_and(|(wk, _)| *wk == id)
                    || j.spares.get(&tile).is_some_and(|(wk, _)| *wk == id);
                if held && !j.drop_holder(tile, id) {
                    j.pending.push_front(tile);
                }
            }
        }
        self.fill(out);
    }

    /// Anything from a worker proves it alive.
    pub fn heard_from(&mut self, id: WorkerId, now: Instant) {
        if let Some(w) = self.workers.get_mut(&id) {
            w.last_seen = now;
        }
    }

    /// Declares workers silent for too long lost.
    pub fn tick(&mut self, now: Instant, out: &mut impl Outbox) {
        let timeout = self.config.worker_timeout;
        let lost: Vec<WorkerId> = self
            .workers
            .iter()
            .filter(|(_, w)| now.duration_since(w.last_seen) > timeout)
            .map(|(id, _)| *id)
            .collect();
        for id in lost {
            warn!(worker = id.0, "worker stopped answering; requeuing its tiles");
            out.disconnect(id);
            self.worker_left(id, out);
        }
    }

    pub(super) fn release(&mut self, worker: WorkerId, job: JobId, tile: u32) {
        if let Some(w) = self.workers.get_mut(&worker) {
            w.in_flight.remove(&(job, tile));
        }
        self.refresh_ready(worker);
    }

    /// Tiles `w` may hold now: what it asked for, or fewer while every
    /// active job's tiles render on all its threads
    /// ([`Scheduler::refresh_parallel_slots`]).
    pub(super) fn slots(&self, w: &Worker) -> u32 {
        match self.parallel_slots {
            Some(n) => w.max_in_flight.min(n),
            None => w.max_in_flight,
        }
    }

    /// Keeps `parallel_slots` true to the active jobs (and to the tiles
    /// they have left to hand out), and `ready` to it.
    pub(super) fn refresh_parallel_slots(&mut self) {
        let active = self.jobs.values().filter(|j| j.state.is_active());
        let mut pending = 0usize;
        let mut parallel = true;
        for j in active {
            parallel &= j.spec.parallel_tiles;
            pending += j.pending.len();
        }
        // A worker holds a quarter of its share of the tiles left, at
        // least `parallel_in_flight`; near the end, one: a tile waiting
        // behind another on a slow worker is better handed to whichever
        // worker frees up first.
        let held = self.config.parallel_in_flight.max(1);
        let workers = self.workers.len().max(1);
        let now = parallel.then(|| {
            if pending < workers * held as usize {
                1
            } else {
                u32::try_from(pending / (workers * 4)).unwrap_or(u32::MAX).max(held)
            }
        });
        if now != self.parallel_slots {
            self.parallel_slots = now;
            let ids: Vec<WorkerId> = self.workers.keys().copied().collect();
            for id in ids {
                self.refresh_ready(id);
            }
        }
    }

    /// Keeps `ready` equal to the set of workers with a free slot.
    pub(super) fn refresh_ready(&mut self, worker: WorkerId) {
        match self.workers.get(&worker) {
            Some(w) if (w.in_flight.len() as u32) < self.slots(w) => {
                self.ready.insert(worker);
            }
            _ => {
                self.ready.remove(&worker);
            }
        }
    }
}
