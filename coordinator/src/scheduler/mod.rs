//! The farm's scheduler: jobs, their tile queues, the workers and what each
//! holds. It owns all of that state, is driven by one event at a time from
//! a single loop, and never touches a socket: it reaches workers and
//! watchers through an [`Outbox`], which tests replace with a recorder.
//!
//! Tiles merge into each job's film strictly in tile order (see
//! [`crate::merge`]), so neither the number of workers, their speed, the
//! order of results nor retries change a bit of the image.

#[cfg(test)]
mod ending_tests;
mod fill;
mod job;
mod jobs;
mod outbox;
#[cfg(test)]
mod part_tests;
#[cfg(test)]
mod pass_tests;
mod passes;
#[cfg(test)]
mod progress_tests;
#[cfg(test)]
mod queue_tests;
mod restore;
#[cfg(test)]
pub(crate) mod tests;
mod views;
mod workers;

pub use job::{JobRow, JobSpec, JobState, Owner, ShotFrame, Snapshot};
pub use outbox::{Assignment, EndedFilm, FinishedJob, JobUpdate, Outbox, Record};
pub use views::{Gauges, JobView, WorkerView};
pub use workers::WorkerRow;

use farm_common::ids::{JobId, WorkerId};
use std::collections::{BTreeMap, BTreeSet};
use std::time::Duration;

/// Knobs of the scheduler.
#[derive(Clone, Debug)]
pub struct SchedulerConfig {
    /// A worker silent for this long is lost; its tiles go back to the queue.
    pub worker_timeout: Duration,
    /// A tile that fails on this many different workers fails its job.
    pub max_tile_failures: usize,
    /// A worker that fails this many tiles of a job gets no more of them.
    pub max_worker_failures: u32,
    /// The most tiles one worker may hold at once, whatever it asks for.
    pub max_in_flight: u32,
    /// A worker holds at most what it asked for and at most a quarter of
    /// its share of the tiles left to hand out, but no fewer than its
    /// threads + 2 (a tile per thread and two waiting over the round
    /// trip), or, while every active job's tiles render on all of a
    /// worker's threads ([`JobSpec::parallel_tiles`]), no fewer than this
    /// many: one rendering and one waiting; and then one once fewer tiles
    /// are left than workers could hold this many of. Holding what it asks
    /// for (4 × threads + 2) would hand a large farm a frame's tiles up
    /// front and leave the slow workers' share to hold up its end (see
    /// [`crate::sim`]).
    pub parallel_in_flight: u32,
}

impl Default for SchedulerConfig {
    fn default() -> Self {
        SchedulerConfig {
            worker_timeout: Duration::from_secs(6),
            max_tile_failures: 3,
            max_worker_failures: 3,
            max_in_flight: 256,
            parallel_in_flight: 2,
        }
    }
}

/// The scheduler's state.
pub struct Scheduler {
    config: SchedulerConfig,
    jobs: BTreeMap<JobId, job::Job>,
    workers: BTreeMap<WorkerId, workers::Worker>,
    /// Workers with a free slot: the only ones `fill` looks at, so the cost
    /// of a result does not grow with the size of the farm.
    ready: BTreeSet<WorkerId>,
    /// What bounds the tiles a worker holds now (`Scheduler::slots`).
    slot_rule: workers::SlotRule,
    next_job: u64,
    /// The time, when a simulation drives the scheduler (`None`: the
    /// clock's).
    virtual_now: Option<std::time::Instant>,
}

impl Scheduler {
    /// No jobs, no workers.
    pub fn new(config: SchedulerConfig) -> Self {
        Scheduler {
            config,
            jobs: BTreeMap::new(),
            workers: BTreeMap::new(),
            ready: BTreeSet::new(),
            slot_rule: workers::SlotRule::default(),
            next_job: 1,
            virtual_now: None,
        }
    }

    /// From now on the time is `now`, as set here, not the clock's: a
    /// simulation ([`crate::sim`]) runs the scheduler in virtual time.
    pub fn set_virtual_time(&mut self, now: std::time::Instant) {
        self.virtual_now = Some(now);
    }

    /// The time: the clock's, or the simulation's.
    pub(crate) fn now(&self) -> std::time::Instant {
        self.virtual_now.unwrap_or_else(std::time::Instant::now)
    }

    /// The film layout of an active job whose film is lent out, being
    /// estimated or ended off the event loop ([`Outbox::estimate_pass`],
    /// [`Outbox::end_film`]): it has no film for now, but is not over.
    pub fn film_lent(&self, job: JobId) -> Option<&farm_common::film::FilmGeometry> {
        let j = self.jobs.get(&job)?;
        let lent = j.state.is_active() && j.film_lent();
        lent.then_some(&j.spec.geometry)
    }

    /// Whether any active job's film is being ended off the loop
    /// ([`Outbox::end_film`]).
    pub fn films_ending(&self) -> bool {
        self.jobs.values().any(|j| j.state.is_active() && j.ending.is_some())
    }

    /// The film of an active job, as it stands (for live previews).
    pub fn film(&self, job: JobId) -> Option<&crate::merge::Film> {
        self.jobs.get(&job)?.film.as_ref()
    }

    /// What each pass of a job in passes has left so far (empty for a job
    /// without passes, or not known).
    pub fn pass_ends(&self, job: JobId) -> &[farm_common::film::PassEnd] {
        self.jobs.get(&job).map_or(&[], |j| j.pass_ends.as_slice())
    }

    /// The rays a job has traced so far.
    pub fn stats(&self, job: JobId) -> Option<farm_common::stats::RayStats> {
        self.jobs.get(&job).map(|j| j.stats)
    }

    /// The film of an active job, to bring its running estimate up to date.
    pub fn film_mut(&mut self, job: JobId) -> Option<&mut crate::merge::Film> {
        self.jobs.get_mut(&job)?.film.as_mut()
    }

    /// Jobs and workers for `farm status`: the dashboard's rows, cut down.
    pub fn status(&self) -> (Vec<JobRow>, Vec<WorkerRow>) {
        let (jobs, workers) = self.views(self.now(), |_| None);
        let jobs = jobs
            .into_iter()
            .map(|j| JobRow {
                id: JobId(j.id),
                name: j.name,
                state: j.state,
                done: j.tiles_done,
                total: j.tiles_total,
                priority: j.priority,
                owner: Owner { id: j.owner_id, name: j.owner },
                attempts: j.attempts,
                retries: j.retries,
                speculated: j.speculated,
                shot: self.jobs.get(&JobId(j.id)).and_then(|job| job.spec.shot),
            })
            .collect();
        let workers = workers
            .into_iter()
            .map(|w| WorkerRow {
                id: WorkerId(w.id),
                name: w.name,
                threads: w.threads,
                in_flight: w.in_flight,
                tiles_done: w.tiles_done,
            })
            .collect();
        (jobs, workers)
    }
}
