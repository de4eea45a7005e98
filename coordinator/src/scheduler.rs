//! The farm's scheduler: jobs, their tile queues, the workers and what each
//! holds. It owns all of that state, is driven by one event at a time from
//! a single loop, and never touches a socket: it reaches workers and
//! watchers through an [`Outbox`], which tests replace with a recorder.
//!
//! Tiles merge into each job's film strictly in tile order (see
//! [`crate::merge`]), so neither the number of workers, their speed, the
//! order of results nor retries change a bit of the image.

use crate::estimate::ErrorEstimate;
use crate::merge::{Accepted, Film};
use farm_common::film::{FilmGeometry, FilmTile};
use farm_common::ids::{JobId, TileId, WorkerId};
use farm_common::image::RgbImage;
use farm_common::stats::RayStats;
use std::collections::{BTreeMap, BTreeSet, HashMap, HashSet, VecDeque};
use std::time::{Duration, Instant};
use tracing::{debug, info, warn};

/// Knobs of the scheduler.
#[derive(Clone, Debug)]
pub struct SchedulerConfig {
    /// A worker silent for this long is lost; its tiles go back to the queue.
    pub worker_timeout: Duration,
    /// A tile that fails on this many different workers fails its job.
    pub max_tile_failures: usize,
    /// A worker that fails this many tiles of a job gets no more of them.
    pub max_worker_failures: u32,
}

impl Default for SchedulerConfig {
    fn default() -> Self {
        SchedulerConfig {
            worker_timeout: Duration::from_secs(6),
            max_tile_failures: 3,
            max_worker_failures: 3,
        }
    }
}

/// One tile handed to a worker.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct Assignment {
    /// The job.
    pub job: JobId,
    /// The tile.
    pub tile: TileId,
    /// Earlier hand-outs of this tile.
    pub attempt: u32,
    /// Hash of the job's scene manifest.
    pub scene_hash: Vec<u8>,
    /// Samples per pixel override (0 = the scene's).
    pub spp: u32,
}

/// What watchers of a job hear.
#[derive(Clone, Debug, PartialEq)]
pub enum JobUpdate {
    /// More tiles are in.
    Progress {
        /// Tiles merged or waiting to merge.
        done: u32,
        /// All tiles.
        total: u32,
        /// Workers holding tiles of the job.
        workers: u32,
        /// Rays so far.
        stats: RayStats,
    },
    /// The image is complete.
    Finished(std::sync::Arc<FinishedJob>),
    /// The job failed or was cancelled.
    Failed(String),
}

/// A completed job's image and facts.
#[derive(Clone, Debug, PartialEq)]
pub struct FinishedJob {
    /// The image.
    pub image: RgbImage,
    /// Samples per pixel.
    pub spp: u32,
    /// Seconds from the first assignment to the last tile.
    pub render_seconds: f64,
    /// Rays traced.
    pub stats: RayStats,
    /// The render's estimate of its own error.
    pub error: Option<ErrorEstimate>,
}

/// The scheduler's way out: messages to workers and to a job's watchers.
pub trait Outbox {
    /// Send a tile to a worker.
    fn assign(&mut self, worker: WorkerId, a: Assignment);
    /// Tell a worker to drop a job's tiles.
    fn cancel(&mut self, worker: WorkerId, job: JobId);
    /// Drop the connection to a worker declared lost.
    fn disconnect(&mut self, worker: WorkerId);
    /// Tell a job's watchers something happened.
    fn notify(&mut self, job: JobId, update: JobUpdate);
}

/// Where a job is in its life.
#[derive(Clone, Debug, PartialEq, Eq)]
pub enum JobState {
    /// No tile handed out yet.
    Queued,
    /// Tiles are out.
    Running,
    /// Image complete.
    Done,
    /// Failed, with the reason.
    Failed(String),
    /// Cancelled by a client.
    Cancelled,
}

impl JobState {
    /// Lower-case name for listings.
    pub fn name(&self) -> &'static str {
        match self {
            JobState::Queued => "queued",
            JobState::Running => "running",
            JobState::Done => "done",
            JobState::Failed(_) => "failed",
            JobState::Cancelled => "cancelled",
        }
    }
    fn is_active(&self) -> bool {
        matches!(self, JobState::Queued | JobState::Running)
    }
}

/// A job as submitted.
#[derive(Clone, Debug)]
pub struct JobSpec {
    /// A name for listings.
    pub name: String,
    /// Higher first; ties in submission order.
    pub priority: i32,
    /// Hash of the scene manifest.
    pub scene_hash: Vec<u8>,
    /// Samples per pixel override (0 = the scene's).
    pub spp_override: u32,
    /// Samples per pixel actually used.
    pub spp: u32,
    /// The film layout.
    pub geometry: FilmGeometry,
}

struct Job {
    id: JobId,
    spec: JobSpec,
    state: JobState,
    film: Option<Film>,
    pending: VecDeque<u32>,
    in_flight: HashMap<u32, (WorkerId, u32)>,
    attempts: HashMap<u32, u32>,
    failures: HashMap<u32, Vec<(WorkerId, String)>>,
    worker_failures: HashMap<WorkerId, u32>,
    stats: RayStats,
    started: Option<Instant>,
    done_tiles: u32,
    last_progress: Instant,
    finished: Option<std::sync::Arc<FinishedJob>>,
}

/// Longest quiet spell between progress updates of a running job.
const PROGRESS_EVERY: Duration = Duration::from_millis(100);

struct Worker {
    name: String,
    threads: u32,
    max_in_flight: u32,
    in_flight: HashSet<(JobId, u32)>,
    last_seen: Instant,
    tiles_done: u64,
}

/// A row of `farm status`.
#[derive(Clone, Debug, PartialEq)]
pub struct JobRow {
    /// Id.
    pub id: JobId,
    /// Name.
    pub name: String,
    /// State name.
    pub state: &'static str,
    /// Tiles in.
    pub done: u32,
    /// All tiles.
    pub total: u32,
    /// Priority.
    pub priority: i32,
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

/// The scheduler's state.
pub struct Scheduler {
    config: SchedulerConfig,
    jobs: BTreeMap<JobId, Job>,
    workers: BTreeMap<WorkerId, Worker>,
    /// Workers with a free slot: the only ones `fill` looks at, so the cost
    /// of a result does not grow with the size of the farm.
    ready: BTreeSet<WorkerId>,
    next_job: u64,
}

impl Scheduler {
    /// No jobs, no workers.
    pub fn new(config: SchedulerConfig) -> Self {
        Scheduler {
            config,
            jobs: BTreeMap::new(),
            workers: BTreeMap::new(),
            ready: BTreeSet::new(),
            next_job: 1,
        }
    }

    /// Queues a job and hands out tiles.
    pub fn submit(&mut self, spec: JobSpec, out: &mut impl Outbox) -> JobId {
        let id = JobId(self.next_job);
        self.next_job += 1;
        let total = spec.geometry.tile_count();
        info!(job = id.0, name = %spec.name, tiles = total, priority = spec.priority, "job queued");
        let job = Job {
            id,
            film: Some(Film::new(spec.geometry.clone())),
            spec,
            state: JobState::Queued,
            pending: (0..total).collect(),
            in_flight: HashMap::new(),
            attempts: HashMap::new(),
            failures: HashMap::new(),
            worker_failures: HashMap::new(),
            stats: RayStats::default(),
            started: None,
            done_tiles: 0,
            last_progress: Instant::now(),
            finished: None,
        };
        self.jobs.insert(id, job);
        if total == 0 {
            self.finish(id, out);
        }
        self.fill(out);
        id
    }

    /// A worker opened its session.
    pub fn worker_joined(
        &mut self,
        id: WorkerId,
        name: String,
        threads: u32,
        max_in_flight: u32,
        now: Instant,
        out: &mut impl Outbox,
    ) {
        info!(worker = id.0, %name, threads, max_in_flight, "worker joined");
        let w = Worker {
            name,
            threads,
            max_in_flight: max_in_flight.max(1),
            in_flight: HashSet::new(),
            last_seen: now,
            tiles_done: 0,
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
                if j.in_flight.get(&tile).is_some_and(|(wk, _)| *wk == id) {
                    j.in_flight.remove(&tile);
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

    /// A rendered tile. Results for unknown jobs, tiles already in, or bad
    /// tiles are refused with a logged reason.
    pub fn tile_done(
        &mut self,
        worker: WorkerId,
        job: JobId,
        tile: TileId,
        film_tile: FilmTile,
        stats: RayStats,
        out: &mut impl Outbox,
    ) {
        self.release(worker, job, tile.0);
        let Some(j) = self.jobs.get_mut(&job) else {
            warn!(worker = worker.0, job = job.0, "result for an unknown job ignored");
            return;
        };
        let Some(film) = j.film.as_mut().filter(|_| j.state.is_active()) else {
            debug!(job = job.0, tile = tile.0, "result for a finished job ignored");
            return;
        };
        match film.accept(tile, film_tile) {
            Ok(Accepted::New) => {
                // A tile is pending, in flight or in: only a late result for a
                // requeued tile can still be in the queue.
                if j.in_flight.remove(&tile.0).is_none() {
                    j.pending.retain(|&t| t != tile.0);
                }
                j.stats.add(&stats);
                j.done_tiles += 1;
                if let Some(w) = self.workers.get_mut(&worker) {
                    w.tiles_done += 1;
                }
                // Progress goes out every 0.5% of the tiles or 100 ms, not per tile.
                let total = j.spec.geometry.tile_count();
                let now = Instant::now();
                let step = (total / 200).max(1);
                if j.done_tiles == total
                    || j.done_tiles % step == 0
                    || now.duration_since(j.last_progress) >= PROGRESS_EVERY
                {
                    j.last_progress = now;
                    let workers: HashSet<WorkerId> =
                        j.in_flight.values().map(|(w, _)| *w).collect();
                    let update = JobUpdate::Progress {
                        done: j.done_tiles,
                        total,
                        workers: workers.len() as u32,
                        stats: j.stats,
                    };
                    out.notify(job, update);
                }
                if film.is_complete() {
                    self.finish(job, out);
                }
            }
            Ok(Accepted::Duplicate) => {
                debug!(job = job.0, tile = tile.0, "duplicate tile result ignored")
            }
            Err(e) => {
                warn!(worker = worker.0, job = job.0, tile = tile.0, error = %e, "tile result refused");
                self.record_failure(
                    worker,
                    job,
                    tile.0,
                    format!("bad tile from worker: {e}"),
                    true,
                    out,
                );
            }
        }
        self.fill(out);
    }

    /// A tile a worker could not render.
    pub fn tile_failed(
        &mut self,
        worker: WorkerId,
        job: JobId,
        tile: TileId,
        message: String,
        retryable: bool,
        out: &mut impl Outbox,
    ) {
        self.release(worker, job, tile.0);
        if self.jobs.get(&job).is_some_and(|j| {
            j.state.is_active() && j.in_flight.get(&tile.0).is_some_and(|(w, _)| *w == worker)
        }) {
            self.record_failure(worker, job, tile.0, message, retryable, out);
        } else {
            debug!(worker = worker.0, job = job.0, tile = tile.0, "stale failure ignored");
        }
        self.fill(out);
    }

    /// Cancels a job; returns whether it was still active.
    pub fn cancel(&mut self, job: JobId, out: &mut impl Outbox) -> bool {
        let Some(j) = self.jobs.get_mut(&job) else { return false };
        if !j.state.is_active() {
            return false;
        }
        j.state = JobState::Cancelled;
        j.film = None;
        j.pending.clear();
        let holders: HashSet<WorkerId> = j.in_flight.drain().map(|(_, (w, _))| w).collect();
        for w in holders {
            out.cancel(w, job);
            if let Some(wk) = self.workers.get_mut(&w) {
                wk.in_flight.retain(|(jb, _)| *jb != job);
            }
            self.refresh_ready(w);
        }
        info!(job = job.0, "job cancelled");
        out.notify(job, JobUpdate::Failed("the job was cancelled".into()));
        self.fill(out);
        true
    }

    /// Fails an active job that cannot finish (an embedded render whose
    /// only worker may take none of its remaining tiles); returns whether
    /// it was active.
    pub fn abandon(&mut self, job: JobId, reason: String, out: &mut impl Outbox) -> bool {
        if !self.jobs.get(&job).is_some_and(|j| j.state.is_active()) {
            return false;
        }
        self.fail(job, reason, out);
        true
    }

    /// Fails every active job (coordinator shutting down).
    pub fn shutdown(&mut self, out: &mut impl Outbox) {
        for (id, j) in &mut self.jobs {
            if j.state.is_active() {
                j.state = JobState::Failed("the coordinator is shutting down".into());
                out.notify(*id, JobUpdate::Failed("the coordinator is shutting down".into()));
            }
        }
    }

    /// The current update for a new watcher of `job`, if the job exists.
    pub fn snapshot(&self, job: JobId) -> Option<JobUpdate> {
        let j = self.jobs.get(&job)?;
        Some(match &j.state {
            JobState::Done => JobUpdate::Finished(j.finished.clone()?),
            JobState::Failed(m) => JobUpdate::Failed(m.clone()),
            JobState::Cancelled => JobUpdate::Failed("the job was cancelled".into()),
            _ => JobUpdate::Progress {
                done: j.done_tiles,
                total: j.spec.geometry.tile_count(),
                workers: 0,
                stats: j.stats,
            },
        })
    }

    /// Jobs and workers for `farm status`.
    pub fn status(&self) -> (Vec<JobRow>, Vec<WorkerRow>) {
        let jobs = self
            .jobs
            .values()
            .map(|j| JobRow {
                id: j.id,
                name: j.spec.name.clone(),
                state: j.state.name(),
                done: j.done_tiles,
                total: j.spec.geometry.tile_count(),
                priority: j.spec.priority,
            })
            .collect();
        let workers = self
            .workers
            .iter()
            .map(|(id, w)| WorkerRow {
                id: *id,
                name: w.name.clone(),
                threads: w.threads,
                in_flight: w.in_flight.len() as u32,
                tiles_done: w.tiles_done,
            })
            .collect();
        (jobs, workers)
    }

    /// The state of a job.
    pub fn job_state(&self, job: JobId) -> Option<&JobState> {
        self.jobs.get(&job).map(|j| &j.state)
    }

    fn release(&mut self, worker: WorkerId, job: JobId, tile: u32) {
        if let Some(w) = self.workers.get_mut(&worker) {
            w.in_flight.remove(&(job, tile));
        }
        self.refresh_ready(worker);
    }

    /// Keeps `ready` equal to the set of workers with a free slot.
    fn refresh_ready(&mut self, worker: WorkerId) {
        match self.workers.get(&worker) {
            Some(w) if (w.in_flight.len() as u32) < w.max_in_flight => {
                self.ready.insert(worker);
            }
            _ => {
                self.ready.remove(&worker);
            }
        }
    }

    fn record_failure(
        &mut self,
        worker: WorkerId,
        job: JobId,
        tile: u32,
        message: String,
        retryable: bool,
        out: &mut impl Outbox,
    ) {
        let max_tile = self.config.max_tile_failures;
        let Some(j) = self.jobs.get_mut(&job) else { return };
        j.in_flight.remove(&tile);
        let name = self
            .workers
            .get(&worker)
            .map(|w| w.name.clone())
            .unwrap_or_else(|| format!("worker {}", worker.0));
        warn!(worker = worker.0, job = job.0, tile, %message, retryable, "tile failed");
        let fails = j.failures.entry(tile).or_default();
        fails.push((worker, format!("{name}: {message}")));
        *j.worker_failures.entry(worker).or_default() += 1;
        let distinct: HashSet<WorkerId> = fails.iter().map(|(w, _)| *w).collect();
        if !retryable || distinct.len() >= max_tile {
            let msgs: Vec<String> = fails.iter().map(|(_, m)| m.clone()).collect();
            let reason = format!("tile {tile} failed: {}", msgs.join("; "));
            self.fail(job, reason, out);
        } else {
            j.pending.push_front(tile);
        }
    }

    fn fail(&mut self, job: JobId, reason: String, out: &mut impl Outbox) {
        let Some(j) = self.jobs.get_mut(&job) else { return };
        warn!(job = job.0, %reason, "job failed");
        j.state = JobState::Failed(reason.clone());
        j.film = None;
        j.pending.clear();
        let holders: HashSet<WorkerId> = j.in_flight.drain().map(|(_, (w, _))| w).collect();
        for w in holders {
            out.cancel(w, job);
            if let Some(wk) = self.workers.get_mut(&w) {
                wk.in_flight.retain(|(jb, _)| *jb != job);
            }
            self.refresh_ready(w);
        }
        out.notify(job, JobUpdate::Failed(reason));
    }

    fn finish(&mut self, job: JobId, out: &mut impl Outbox) {
        let Some(j) = self.jobs.get_mut(&job) else { return };
        let Some(film) = j.film.take() else { return };
        let render_seconds = j.started.map(|s| s.elapsed().as_secs_f64()).unwrap_or(0.0);
        let finished = std::sync::Arc::new(FinishedJob {
            image: film.image(),
            error: film.error_estimate(),
            spp: j.spec.spp,
            render_seconds,
            stats: j.stats,
        });
        j.state = JobState::Done;
        j.finished = Some(finished.clone());
        info!(job = job.0, seconds = render_seconds, "job done");
        out.notify(job, JobUpdate::Finished(finished));
    }

    /// Hands out tiles: round-robin over workers with free slots, each
    /// taking the next tile of the first job (by priority, then submission)
    /// it may work on.
    fn fill(&mut self, out: &mut impl Outbox) {
        if self.ready.is_empty() {
            return;
        }
        let mut order: Vec<JobId> =
            self.jobs.values().filter(|j| j.state.is_active()).map(|j| j.id).collect();
        order.sort_by_key(|id| (-self.jobs[id].spec.priority, *id));
        if order.is_empty() {
            return;
        }
        let max_worker = self.config.max_worker_failures;
        loop {
            let mut assigned = false;
            let ids: Vec<WorkerId> = self.ready.iter().copied().collect();
            for wid in ids {
                let Some(w) = self.workers.get(&wid) else { continue };
                if w.in_flight.len() as u32 >= w.max_in_flight {
                    continue;
                }
                for jid in &order {
                    let j = self.jobs.get_mut(jid).expect("active job");
                    if j.worker_failures.get(&wid).copied().unwrap_or(0) >= max_worker {
                        continue;
                    }
                    // Prefer a tile this worker has not failed before.
                    let failed_here = |t: &u32| {
                        j.failures.get(t).is_some_and(|f| f.iter().any(|(fw, _)| *fw == wid))
                    };
                    let Some(pos) = j
                        .pending
                        .iter()
                        .position(|t| !failed_here(t))
                        .or((!j.pending.is_empty()).then_some(0))
                    else {
                        continue;
                    };
                    let tile = j.pending.remove(pos).expect("position in range");
                    let attempt = {
                        let a = j.attempts.entry(tile).or_insert(0);
                        *a += 1;
                        *a - 1
                    };
                    j.in_flight.insert(tile, (wid, attempt));
                    if j.state == JobState::Queued {
                        j.state = JobState::Running;
                        j.started = Some(Instant::now());
                    }
                    let a = Assignment {
                        job: *jid,
                        tile: TileId(tile),
                        attempt,
                        scene_hash: j.spec.scene_hash.clone(),
                        spp: j.spec.spp_override,
                    };
                    self.workers.get_mut(&wid).expect("worker").in_flight.insert((*jid, tile));
                    self.refresh_ready(wid);
                    out.assign(wid, a);
                    assigned = true;
                    break;
                }
            }
            if !assigned {
                break;
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use farm_common::geometry::{Bounds2i, Point2i, Vec2};
    use farm_common::Spectrum;

    #[derive(Default)]
    struct Recorder {
        assigned: Vec<(WorkerId, Assignment)>,
        cancelled: Vec<(WorkerId, JobId)>,
        disconnected: Vec<WorkerId>,
        updates: Vec<(JobId, JobUpdate)>,
    }

    impl Outbox for Recorder {
        fn assign(&mut self, worker: WorkerId, a: Assignment) {
            self.assigned.push((worker, a));
        }
        fn cancel(&mut self, worker: WorkerId, job: JobId) {
            self.cancelled.push((worker, job));
        }
        fn disconnect(&mut self, worker: WorkerId) {
            self.disconnected.push(worker);
        }
        fn notify(&mut self, job: JobId, update: JobUpdate) {
            self.updates.push((job, update));
        }
    }

    impl Recorder {
        fn take(&mut self) -> Vec<(WorkerId, Assignment)> {
            std::mem::take(&mut self.assigned)
        }
        fn image(&self, job: JobId) -> Option<RgbImage> {
            self.updates.iter().find_map(|(j, u)| match u {
                JobUpdate::Finished(f) if *j == job => Some(f.image.clone()),
                _ => None,
            })
        }
        fn failure(&self, job: JobId) -> Option<String> {
            self.updates.iter().find_map(|(j, u)| match u {
                JobUpdate::Failed(m) if *j == job => Some(m.clone()),
                _ => None,
            })
        }
    }

    fn geometry() -> FilmGeometry {
        let b = Bounds2i::new(Point2i::new(0, 0), Point2i::new(50, 35));
        FilmGeometry::new(
            Point2i::new(50, 35),
            b,
            Vec2::splat(2.0),
            1.0,
            f32::INFINITY,
            "x.exr".into(),
            35.0,
        )
    }

    fn spec(priority: i32) -> JobSpec {
        JobSpec {
            name: "t".into(),
            priority,
            scene_hash: vec![1; 32],
            spp_override: 0,
            spp: 4,
            geometry: geometry(),
        }
    }

    /// What any worker would render for a tile: depends only on the tile.
    fn render(g: &FilmGeometry, tile: TileId) -> FilmTile {
        let mut t = FilmTile::new(g.tile_pixel_bounds(tile));
        for p in t.pixel_bounds.iter() {
            let v = ((p.x * 31 + p.y * 17 + tile.0 as i32 * 7) % 97) as f32 / 97.0 + 0.013;
            t.add(p, Spectrum::new(v, v * v, 1.0 / (1.0 + v)), 0.25 + v, p.y % 2 == 0);
        }
        t
    }

    /// Completes every assignment, answering in the order `pick` chooses.
    fn drain(s: &mut Scheduler, out: &mut Recorder, mut pick: impl FnMut(usize) -> usize) {
        let g = geometry();
        let mut queue = out.take();
        while !queue.is_empty() {
            let (w, a) = queue.remove(pick(queue.len()) % queue.len());
            s.tile_done(w, a.job, a.tile, render(&g, a.tile), RayStats::default(), out);
            queue.extend(out.take());
        }
    }

    fn reference_image() -> RgbImage {
        let mut s = Scheduler::new(SchedulerConfig::default());
        let mut out = Recorder::default();
        s.worker_joined(WorkerId(1), "a".into(), 1, 1, Instant::now(), &mut out);
        let job = s.submit(spec(0), &mut out);
        drain(&mut s, &mut out, |_| 0);
        out.image(job).expect("finished")
    }

    #[test]
    fn many_workers_in_any_order_give_the_same_bits() {
        let reference = reference_image();
        let mut s = Scheduler::new(SchedulerConfig::default());
        let mut out = Recorder::default();
        let now = Instant::now();
        for w in 1..=4 {
            s.worker_joined(WorkerId(w), format!("w{w}"), 2, 3, now, &mut out);
        }
        let job = s.submit(spec(0), &mut out);
        let first: HashSet<WorkerId> = out.assigned.iter().map(|(w, _)| *w).collect();
        assert_eq!(first.len(), 4, "work is spread over all workers");
        let mut rng = farm_common::rng::Rng::new(5);
        drain(&mut s, &mut out, |n| rng.uniform_u32_below(n as u32) as usize);
        assert!(out.image(job) == Some(reference.clone()), "image differs");
        assert_eq!(s.job_state(job), Some(&JobState::Done));
    }

    #[test]
    fn a_lost_worker_costs_a_retry_not_the_image() {
        let reference = reference_image();
        let mut s = Scheduler::new(SchedulerConfig::default());
        let mut out = Recorder::default();
        let t0 = Instant::now();
        s.worker_joined(WorkerId(1), "good".into(), 1, 2, t0, &mut out);
        s.worker_joined(WorkerId(2), "stalls".into(), 1, 2, t0, &mut out);
        let job = s.submit(spec(0), &mut out);
        let g = geometry();
        // Worker 2 never answers; worker 1 keeps working and stays alive.
        let mut held_by_2 = 0;
        for _ in 0..10_000 {
            let batch = out.take();
            if batch.is_empty() {
                break;
            }
            for (w, a) in batch {
                if w == WorkerId(1) {
                    s.heard_from(WorkerId(1), t0 + Duration::from_secs(10));
                    s.tile_done(
                        w,
                        a.job,
                        a.tile,
                        render(&g, a.tile),
                        RayStats::default(),
                        &mut out,
                    );
                } else {
                    held_by_2 += 1;
                }
            }
        }
        assert_eq!(held_by_2, 2, "the stalled worker holds its two tiles");
        assert!(out.image(job).is_none());
        s.tick(t0 + Duration::from_secs(10), &mut out);
        assert_eq!(out.disconnected, vec![WorkerId(2)]);
        drain(&mut s, &mut out, |_| 0);
        assert!(out.image(job) == Some(reference.clone()), "image differs");
        // A late result from the lost worker changes nothing.
        let late = render(&g, TileId(0));
        s.tile_done(WorkerId(2), job, TileId(0), late, RayStats::default(), &mut out);
        assert_eq!(s.job_state(job), Some(&JobState::Done));
    }

    #[test]
    fn duplicates_unknown_jobs_and_bad_tiles_are_ignored() {
        let reference = reference_image();
        let mut s = Scheduler::new(SchedulerConfig::default());
        let mut out = Recorder::default();
        s.worker_joined(WorkerId(1), "a".into(), 1, 1, Instant::now(), &mut out);
        let job = s.submit(spec(0), &mut out);
        let g = geometry();
        let (w, a) = out.take().remove(0);
        s.tile_done(w, JobId(999), a.tile, render(&g, a.tile), RayStats::default(), &mut out);
        // A tile of the wrong size is refused and retried.
        s.tile_done(
            w,
            a.job,
            a.tile,
            render(&g, TileId(a.tile.0 + 1)),
            RayStats::default(),
            &mut out,
        );
        let (w, a) = out.take().remove(0);
        s.tile_done(w, a.job, a.tile, render(&g, a.tile), RayStats::default(), &mut out);
        s.tile_done(w, a.job, a.tile, render(&g, a.tile), RayStats::default(), &mut out);
        drain(&mut s, &mut out, |_| 0);
        assert!(out.image(job) == Some(reference.clone()), "image differs");
    }

    #[test]
    fn a_tile_failing_on_three_workers_fails_the_job_with_their_messages() {
        let mut s = Scheduler::new(SchedulerConfig::default());
        let mut out = Recorder::default();
        for w in 1..=3 {
            s.worker_joined(WorkerId(w), format!("w{w}"), 1, 1, Instant::now(), &mut out);
        }
        let job = s.submit(spec(0), &mut out);
        let g = geometry();
        for _ in 0..20 {
            for (w, a) in out.take() {
                if a.tile == TileId(5) {
                    s.tile_failed(w, a.job, a.tile, format!("boom on {}", w.0), true, &mut out);
                } else {
                    s.tile_done(
                        w,
                        a.job,
                        a.tile,
                        render(&g, a.tile),
                        RayStats::default(),
                        &mut out,
                    );
                }
            }
        }
        let msg = out.failure(job).expect("job failed");
        for w in 1..=3 {
            assert!(msg.contains(&format!("boom on {w}")), "{msg}");
        }
        assert!(matches!(s.job_state(job), Some(JobState::Failed(_))));
    }

    #[test]
    fn a_worker_failing_repeatedly_gets_no_more_of_that_job() {
        let mut s = Scheduler::new(SchedulerConfig::default());
        let mut out = Recorder::default();
        s.worker_joined(WorkerId(1), "flaky".into(), 1, 1, Instant::now(), &mut out);
        let job = s.submit(spec(0), &mut out);
        for _ in 0..3 {
            let (w, a) = out.take().remove(0);
            s.tile_failed(w, a.job, a.tile, "flaky".into(), true, &mut out);
        }
        assert!(out.take().is_empty(), "no more tiles for the flaky worker");
        s.worker_joined(WorkerId(2), "good".into(), 1, 1, Instant::now(), &mut out);
        drain(&mut s, &mut out, |_| 0);
        assert!(out.image(job).is_some());
    }

    #[test]
    fn higher_priority_runs_first_then_submission_order() {
        let mut s = Scheduler::new(SchedulerConfig::default());
        let mut out = Recorder::default();
        let low = s.submit(spec(0), &mut out);
        let high = s.submit(spec(5), &mut out);
        s.worker_joined(WorkerId(1), "a".into(), 1, 1, Instant::now(), &mut out);
        assert_eq!(out.take()[0].1.job, high);
        assert!(s.cancel(high, &mut out));
        assert_eq!(out.cancelled, vec![(WorkerId(1), high)]);
        assert_eq!(out.take()[0].1.job, low);
    }
}
