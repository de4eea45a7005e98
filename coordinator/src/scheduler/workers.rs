//! Workers: joining, leaving, going silent, and the slots each has free.

use super::{Outbox, Scheduler};
use farm_common::ids::{JobId, WorkerId};
use std::collections::HashSet;
use std::time::Instant;
use tracing::{info, warn};

/// What bounds the tiles a worker holds ([`Scheduler::slots`]).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub(super) struct SlotRule {
    /// Every active job's tiles render on all of a worker's threads.
    pub(super) parallel: bool,
    /// A quarter of a worker's share of the tiles left to hand out.
    pub(super) share: u32,
    /// Fewer tiles are left than workers could hold two of.
    pub(super) ending: bool,
}

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
    /// How fast it renders a tile on all its threads.
    pub(super) pace: Pace,
}

/// How fast a worker renders tiles one after another on all its threads
/// (a job whose tiles render in parallel): what the end of a frame needs
/// to know whether a part of a late tile would come back sooner from this
/// worker than the whole tile from its holder.
#[derive(Clone, Copy, Debug, Default)]
pub(super) struct Pace {
    /// When its last whole tile came back.
    pub last_done: Option<Instant>,
    /// Seconds a tile, a moving average (none before its first tile).
    pub tile_seconds: Option<f64>,
}

impl Pace {
    /// A whole tile handed out at `handed` came back `now`: it rendered
    /// from then or from the tile before it, whichever was later.
    pub fn tile_done(&mut self, handed: Instant, now: Instant) {
        let start = self.last_done.map_or(handed, |l| l.max(handed));
        let d = now.saturating_duration_since(start).as_secs_f64();
        self.tile_seconds = Some(self.tile_seconds.map_or(d, |s| 0.75 * s + 0.25 * d));
        self.last_done = Some(now);
    }
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
            pace: Pace::default(),
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
                    || j.spares.get(&tile).is_some_and(|(wk, _)| *wk == id)
                    || j.holds_part(tile, id, None);
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

    /// Tiles `w` may hold now: what it asked for, or fewer once that would
    /// be more than a quarter of its share of the tiles left
    /// ([`Scheduler::refresh_slots`]).
    pub(super) fn slots(&self, w: &Worker) -> u32 {
        let rule = self.slot_rule;
        let cap = if rule.parallel {
            // Each tile on all its threads: one rendering, one waiting over
            // the round trip; near the end, one, so a tile waiting behind
            // another on a slow worker goes instead to whichever worker
            // frees up first.
            if rule.ending {
                1
            } else {
                rule.share.max(self.config.parallel_in_flight.max(1))
            }
        } else {
            // A tile per thread: one for each thread and two waiting.
            rule.share.max(w.threads.saturating_add(2))
        };
        w.max_in_flight.min(cap)
    }

    /// Keeps the slot rule true to the active jobs and the tiles they have
    /// left to hand out, and `ready` to it.
    pub(super) fn refresh_slots(&mut self) {
        let mut pending = 0usize;
        let mut parallel = true;
        for j in self.jobs.values().filter(|j| j.state.is_active()) {
            parallel &= j.spec.parallel_tiles;
            pending += j.pending.len();
        }
        let workers = self.workers.len().max(1);
        let held = self.config.parallel_in_flight.max(1) as usize;
        let rule = SlotRule {
            parallel,
            share: u32::try_from(pending / (workers * 4)).unwrap_or(u32::MAX),
            ending: pending < workers * held,
        };
        if rule != self.slot_rule {
            self.slot_rule = rule;
            let ids: Vec<WorkerId> = self.workers.keys().copied().collect();
            for id in ids {
                self.refresh_ready(id);
            }
        }
    }

    /// The workers with a free slot whose ids are above `after`, in order.
    pub(super) fn ready_after(&self, after: WorkerId) -> Vec<WorkerId> {
        use std::ops::Bound::{Excluded, Unbounded};
        self.ready.range((Excluded(after), Unbounded)).copied().collect()
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
