//! The coordinator's single event loop and the gRPC [`Outbox`].

use super::ServerConfig;
use crate::error::Error;
use crate::live::LiveCursor;
use crate::metrics::{Metrics, StateLabel, JOB_STATES};
use crate::scheduler::{
    Assignment, JobRow, JobSpec, JobUpdate, Outbox, Record, Scheduler, Snapshot, WorkerRow,
};
use crate::scheduler::{FinishedJob, JobView, WorkerView};
use crate::state::{unix_now, BlobStore, Command, Journal, SavedJob};
use farm_common::film::FilmTile;
use farm_common::ids::{JobId, TileAttempt, TileId, WorkerId};
use farm_common::image::ImagePiece;
use farm_common::stats::RayStats;
use farm_proto::convert::{encode_preview, image_chunks, ImageFacts};
use farm_proto::v1::{self, coordinator_message, job_event, tile_result, worker_message};
use prost::Message;
use std::collections::HashMap;
use std::sync::Arc;
use std::time::{Duration, Instant};
use tokio::sync::{mpsc, oneshot};
use tonic::Status;
use tracing::warn;

/// Messages to a worker's Work stream.
pub type WorkerTx = mpsc::UnboundedSender<Result<v1::CoordinatorMessage, Status>>;
/// Messages to a WatchJob stream.
pub type WatchTx = mpsc::UnboundedSender<Result<v1::JobEvent, Status>>;
/// Live previews to a WatchJob stream: bounded, so a reader that falls
/// behind is sent less, not queued more.
pub type LiveTx = mpsc::Sender<Result<v1::JobEvent, Status>>;

/// Pixels in one preview event (16 bytes each with the error map): about
/// 4 MiB, well under the message limit.
const PIXELS_PER_EVENT: usize = 1 << 18;

/// Everything the event loop reacts to.
pub enum Event {
    /// A worker opened its Work stream.
    WorkerJoined {
        /// Its id.
        id: WorkerId,
        /// Its name.
        name: String,
        /// Its render threads.
        threads: u32,
        /// Tiles it can hold.
        max_in_flight: u32,
        /// Its outgoing stream.
        tx: WorkerTx,
    },
    /// A message on a worker's stream, already decoded off the loop.
    FromWorker {
        /// The worker.
        id: WorkerId,
        /// What it said.
        msg: FromWorker,
    },
    /// A worker's stream ended.
    WorkerGone {
        /// The worker.
        id: WorkerId,
    },
    /// A client submitted a job.
    Submit {
        /// The job.
        spec: JobSpec,
        /// Where to send its id.
        reply: oneshot::Sender<JobId>,
    },
    /// A client watches a job.
    Watch {
        /// The job.
        job: JobId,
        /// Its event stream.
        tx: WatchTx,
        /// Where its previews go, if it asked for them.
        live: Option<LiveTx>,
        /// Whether the job exists.
        reply: oneshot::Sender<bool>,
    },
    /// `farm status`.
    Status {
        /// The listing.
        reply: oneshot::Sender<(Vec<JobRow>, Vec<WorkerRow>)>,
    },
    /// `farm cancel`.
    Cancel {
        /// The job.
        job: JobId,
        /// Whether it was cancelled.
        reply: oneshot::Sender<bool>,
    },
    /// Who submitted a job.
    Owner {
        /// The job.
        job: JobId,
        /// Its owner, if the job exists.
        reply: oneshot::Sender<Option<crate::scheduler::Owner>>,
    },
    /// The dashboard's listing.
    Views {
        /// Jobs and workers.
        reply: oneshot::Sender<(Vec<JobView>, Vec<WorkerView>)>,
    },
    /// A dashboard page's look at a job's image since `from` changes.
    Live {
        /// The job.
        job: JobId,
        /// The page's cursor.
        from: usize,
        /// What there is to show.
        reply: oneshot::Sender<LiveAnswer>,
    },
    /// The dashboard changes a job's priority.
    Priority {
        /// The job.
        job: JobId,
        /// The new priority.
        priority: i32,
        /// Whether the job was active.
        reply: oneshot::Sender<bool>,
    },
    /// Set the metrics' gauges from the scheduler (before a scrape).
    Gauges {
        /// Done.
        reply: oneshot::Sender<()>,
    },
    /// Time passes: find silent workers.
    Tick,
    /// Time to send live watchers what changed.
    LiveTick,
    /// Stop: fail unfinished jobs and close every stream.
    Shutdown,
}

/// What a dashboard page is shown of a job's image.
#[derive(Debug)]
pub enum LiveAnswer {
    /// Running: the pieces changed since the page's cursor, and its next cursor.
    Running {
        /// Image width.
        width: u32,
        /// Image height.
        height: u32,
        /// The cursor to pass next time.
        next: usize,
        /// What changed.
        pieces: Vec<ImagePiece>,
    },
    /// Done, with the image in memory.
    Done(std::sync::Arc<FinishedJob>),
    /// Done, with the image in the journal.
    Stored,
    /// Failed or cancelled: there is no image.
    Ended,
    /// No such job.
    NoJob,
}

#[derive(Default)]
struct GrpcOutbox {
    workers: HashMap<WorkerId, WorkerTx>,
    watchers: HashMap<JobId, Vec<WatchTx>>,
    /// Watchers of the image as it renders, each with what it has seen.
    live: HashMap<JobId, Vec<(LiveTx, LiveCursor)>>,
    /// Where changes are made durable, with a state directory.
    journal: Option<Journal>,
    /// What is counted for `/metrics`.
    metrics: Arc<Metrics>,
    /// When each tile out was handed out (for the latency histogram).
    handed: HashMap<TileAttempt, Instant>,
}

fn rpc_stats(s: &RayStats) -> Option<v1::RayStats> {
    Some(v1::RayStats::from(s))
}

/// The protocol form of a job update: one event, or for a finished image
/// one event per chunk of rows.
pub(crate) fn job_events(update: &JobUpdate) -> Vec<v1::JobEvent> {
    let one = |kind| vec![v1::JobEvent { kind: Some(kind) }];
    match update {
        JobUpdate::Progress { done, total, workers, stats } => {
            one(job_event::Kind::Progress(v1::JobProgress {
                tiles_done: *done,
                tiles_total: *total,
                workers_active: *workers,
                stats: rpc_stats(stats),
            }))
        }
        JobUpdate::Finished(f) => {
            let facts = ImageFacts { spp: f.spp, render_seconds: f.render_seconds, stats: f.stats };
            let error = f.error.as_ref().map(|e| (e.per_pixel.as_slice(), e.rel_mse));
            image_chunks(&f.image, error, &facts)
                .into_iter()
                .map(|img| v1::JobEvent { kind: Some(job_event::Kind::Image(img)) })
                .collect()
        }
        JobUpdate::Failed(m) => one(job_event::Kind::Failed(v1::JobFailed { message: m.clone() })),
    }
}

impl GrpcOutbox {
    /// A worker answered hand-out `key`: its latency is observed.
    fn answered(&mut self, key: &TileAttempt, now: Instant) {
        if let Some(t) = self.handed.remove(key) {
            self.metrics.tile_latency.observe(now.duration_since(t).as_secs_f64());
        }
    }
}

impl Outbox for GrpcOutbox {
    fn assign(&mut self, worker: WorkerId, a: Assignment) {
        self.metrics.tiles_dispatched.inc();
        if a.attempt > 0 {
            self.metrics.tiles_retried.inc();
        }
        self.handed.insert(a.key(), Instant::now());
        let msg = v1::CoordinatorMessage {
            kind: Some(coordinator_message::Kind::Assign(v1::TileAssignment {
                job_id: a.job.0,
                tile: a.tile.0,
                attempt: a.attempt,
                scene_hash: a.scene_hash,
                spp: a.spp,
            })),
        };
        if let Some(tx) = self.workers.get(&worker) {
            let _ = tx.send(Ok(msg));
        }
    }

    fn cancel(&mut self, worker: WorkerId, job: JobId) {
        let msg = v1::CoordinatorMessage {
            kind: Some(coordinator_message::Kind::Cancelled(v1::JobCancelled { job_id: job.0 })),
        };
        if let Some(tx) = self.workers.get(&worker) {
            let _ = tx.send(Ok(msg));
        }
    }

    fn disconnect(&mut self, worker: WorkerId) {
        if let Some(tx) = self.workers.remove(&worker) {
            let _ = tx.send(Err(Error::WorkerSilent.into()));
        }
    }

    fn notify(&mut self, job: JobId, update: JobUpdate) {
        let final_update = !matches!(update, JobUpdate::Progress { .. });
        if let Some(list) = self.watchers.get_mut(&job) {
            let events = job_events(&update);
            list.retain(|tx| events.iter().all(|ev| tx.send(Ok(ev.clone())).is_ok()));
        }
        if final_update {
            self.watchers.remove(&job);
            self.live.remove(&job);
            self.handed.retain(|k, _| k.job != job);
        }
    }

    fn record(&mut self, change: Record<'_>) {
        if let Record::Merged { stats, .. } = &change {
            self.metrics.tiles_merged.inc();
            self.metrics.add_rays(stats);
        }
        if let Some(journal) = &self.journal {
            journal.record(change);
        }
    }

    fn durable(&self) -> bool {
        self.journal.is_some()
    }
}

/// Unreferenced blobs are kept this long after their last upload, so a
/// client has time to submit the job that needs them.
const BLOB_GRACE: Duration = Duration::from_secs(3600);
/// How often finished jobs and unreferenced blobs are looked for.
const PURGE_EVERY: Duration = Duration::from_secs(60);

/// What the event loop needs besides its events.
pub struct LoopState {
    /// The journal, with a state directory.
    pub journal: Option<Journal>,
    /// The blob store (for purges).
    pub blobs: BlobStore,
    /// Jobs to resume.
    pub jobs: Vec<SavedJob>,
    /// The next job's id.
    pub next_job: u64,
    /// What is counted for `/metrics`.
    pub metrics: Arc<Metrics>,
}

/// Streams a finished job's image from the journal to a watcher.
fn send_stored(journal: &Journal, job: JobId, tx: WatchTx) {
    let (reply, rx) = oneshot::channel();
    journal.send(Command::ReadImage { job: job.0, reply });
    tokio::spawn(async move {
        let events = rx.await.unwrap_or_default();
        if events.is_empty() {
            let _ = tx.send(Err(Status::data_loss(format!("the image of job {} is lost", job.0))));
        }
        for bytes in events {
            match v1::JobEvent::decode(bytes.as_slice()) {
                Ok(ev) => {
                    if tx.send(Ok(ev)).is_err() {
                        return;
                    }
                }
                Err(e) => {
                    let _ = tx.send(Err(Status::data_loss(format!("job {}: {e}", job.0))));
                    return;
                }
            }
        }
    });
}

/// Runs the scheduler until the channel closes or `Shutdown` arrives.
pub async fn run(mut rx: mpsc::UnboundedReceiver<Event>, config: ServerConfig, state: LoopState) {
    let mut sched = Scheduler::new(config.scheduler.clone());
    let mut out =
        GrpcOutbox { journal: state.journal, metrics: state.metrics, ..Default::default() };
    let mut rays_at: (Instant, u64) = (Instant::now(), 0);
    sched.set_next_job(state.next_job);
    for job in state.jobs {
        sched.restore(job, &mut out);
    }
    let blobs = state.blobs;
    let keep = config.state.keep_finished;
    let mut last_purge: Option<Instant> = None;
    let mut unwatched: HashMap<JobId, Instant> = HashMap::new();
    while let Some(ev) = rx.recv().await {
        let now = Instant::now();
        match ev {
            Event::WorkerJoined { id, name, threads, max_in_flight, tx } => {
                out.workers.insert(id, tx);
                sched.worker_joined(id, name, threads, max_in_flight, now, &mut out);
            }
            Event::FromWorker { id, msg } => {
                sched.heard_from(id, now);
                match msg {
                    FromWorker::Tile { key, film_tile, stats } => {
                        out.answered(&key, now);
                        sched.tile_done(id, key, film_tile, stats, &mut out)
                    }
                    FromWorker::Failed { key, message, retryable } => {
                        out.answered(&key, now);
                        out.metrics.tiles_failed.inc();
                        sched.tile_failed(id, key, message, retryable, &mut out)
                    }
                    FromWorker::Alive => {}
                }
            }
            Event::WorkerGone { id } => {
                out.workers.remove(&id);
                sched.worker_left(id, &mut out);
            }
            Event::Submit { spec, reply } => {
                let id = sched.submit(spec, &mut out);
                let _ = reply.send(id);
            }
            Event::Watch { job, tx, live, reply } => match sched.snapshot(job) {
                Some(Snapshot::Stored) => {
                    match &out.journal {
                        Some(j) => send_stored(j, job, tx),
                        None => {
                            let _ = tx.send(Err(Status::data_loss("the image is not kept")));
                        }
                    }
                    let _ = reply.send(true);
                }
                Some(Snapshot::Update(update)) => {
                    let last = !matches!(update, JobUpdate::Progress { .. });
                    for ev in job_events(&update) {
                        let _ = tx.send(Ok(ev));
                    }
                    if !last {
                        out.watchers.entry(job).or_default().push(tx);
                        if let Some(live) = live {
                            out.live.entry(job).or_default().push((live, LiveCursor::new()));
                        }
                    }
                    let _ = reply.send(true);
                }
                None => {
                    let _ = reply.send(false);
                }
            },
            Event::LiveTick => send_live(&sched, &mut out),
            Event::Views { reply } => {
                // Each running estimate is brought up to date over the
                // tiles merged since the last look, not recomputed.
                let mut estimates = HashMap::new();
                for (job, _) in sched.active_jobs() {
                    if let Some(film) = sched.film_mut(job) {
                        estimates.insert(job, film.running_estimate());
                    }
                }
                let views = sched.views(now, |job, _| estimates.get(&job).copied().flatten());
                let _ = reply.send(views);
            }
            Event::Live { job, from, reply } => {
                let _ = reply.send(live_answer(&mut sched, job, from));
            }
            Event::Priority { job, priority, reply } => {
                let _ = reply.send(sched.set_priority(job, priority, &mut out));
            }
            Event::Gauges { reply } => {
                let g = sched.gauges();
                let m = &out.metrics;
                for s in JOB_STATES {
                    let n = g.jobs.get(s).copied().unwrap_or(0);
                    m.jobs.get_or_create(&StateLabel { state: s.into() }).set(n);
                }
                m.queue_depth.set(g.queue_depth);
                m.workers.set(g.workers);
                m.blob_bytes.set(blobs.total_bytes() as i64);
                let _ = reply.send(());
            }
            Event::Status { reply } => {
                let _ = reply.send(sched.status());
            }
            Event::Cancel { job, reply } => {
                let _ = reply.send(sched.cancel(job, &mut out));
            }
            Event::Owner { job, reply } => {
                let _ = reply.send(sched.owner(job).cloned());
            }
            Event::Tick => {
                let total = out.metrics.total_rays();
                let secs = now.duration_since(rays_at.0).as_secs_f64();
                if secs > 0.0 {
                    out.metrics.rays_per_second.set((total - rays_at.1) as f64 / secs);
                }
                rays_at = (now, total);
                sched.tick(now, &mut out);
                cancel_unwatched(&mut sched, &mut out, &mut unwatched, now, config.client_grace);
                if last_purge.is_none_or(|t| now.duration_since(t) >= PURGE_EVERY) {
                    last_purge = Some(now);
                    purge(&mut sched, &out, &blobs, keep);
                }
            }
            Event::Shutdown => {
                sched.shutdown(&mut out);
                if out.durable() {
                    // Watchers reconnect and find their job again.
                    let msg =
                        "the coordinator is shutting down; its jobs resume when it starts again";
                    for tx in out.watchers.values().flatten() {
                        let _ = tx.send(Err(Status::unavailable(msg)));
                    }
                }
                out.watchers.clear();
                out.workers.clear();
                if let Some(j) = &out.journal {
                    j.flush().await;
                }
                break;
            }
        }
    }
}

/// What a dashboard page at cursor `from` is shown of `job`.
fn live_answer(sched: &mut Scheduler, job: JobId, from: usize) -> LiveAnswer {
    if let Some(film) = sched.film_mut(job) {
        // The error map is the running estimate's, brought up to date.
        film.running_estimate();
        let b = film.geometry().cropped_pixel_bounds;
        let mut cursor = LiveCursor::at(from);
        let pieces = cursor.take(film, usize::MAX, true);
        return LiveAnswer::Running {
            width: b.width() as u32,
            height: b.height() as u32,
            next: cursor.position(),
            pieces,
        };
    }
    match sched.snapshot(job) {
        None => LiveAnswer::NoJob,
        Some(Snapshot::Stored) => LiveAnswer::Stored,
        Some(Snapshot::Update(JobUpdate::Finished(f))) => LiveAnswer::Done(f),
        Some(Snapshot::Update(_)) => LiveAnswer::Ended,
    }
}

/// Sends each live watcher the pieces that changed since it last took
/// some, if it has room for them: one event a tick at most, so a reader
/// that falls behind is sent larger catch-ups, never a queue.
fn send_live(sched: &Scheduler, out: &mut GrpcOutbox) {
    out.live.retain(|job, list| {
        let Some(film) = sched.film(*job) else { return false };
        let b = film.geometry().cropped_pixel_bounds;
        list.retain_mut(|(tx, cursor)| {
            if tx.is_closed() {
                return false;
            }
            if tx.capacity() == 0 {
                return true;
            }
            // tev is shown the error map of the finished image only.
            let pieces = cursor.take(film, PIXELS_PER_EVENT, false);
            if pieces.is_empty() {
                return true;
            }
            let preview = encode_preview(b.width() as u32, b.height() as u32, &pieces);
            let ev = v1::JobEvent { kind: Some(job_event::Kind::Preview(preview)) };
            !matches!(tx.try_send(Ok(ev)), Err(mpsc::error::TrySendError::Closed(_)))
        });
        !list.is_empty()
    });
}

/// Cancels each job whose client went away: not detached, and with no
/// watcher for `grace` (counted from the coordinator's start for jobs it
/// resumed, so their clients have time to reconnect).
fn cancel_unwatched(
    sched: &mut Scheduler,
    out: &mut GrpcOutbox,
    since: &mut HashMap<JobId, Instant>,
    now: Instant,
    grace: Duration,
) {
    let active = sched.active_jobs();
    since.retain(|j, _| active.iter().any(|(a, _)| a == j));
    for (job, detach) in active {
        if detach {
            continue;
        }
        let watched = out.watchers.get_mut(&job).is_some_and(|list| {
            list.retain(|tx| !tx.is_closed());
            !list.is_empty()
        });
        if watched {
            since.remove(&job);
            continue;
        }
        let from = *since.entry(job).or_insert(now);
        if now.duration_since(from) >= grace {
            let why = format!(
                "cancelled: no client has watched the job for {} s (submit with --detach to keep a job running without its client)",
                grace.as_secs()
            );
            sched.cancel_because(job, why, out);
            since.remove(&job);
        }
    }
}

/// Forgets jobs past their retention and, with a journal, deletes their
/// rows and the blobs no job needs any more.
fn purge(sched: &mut Scheduler, out: &GrpcOutbox, blobs: &BlobStore, keep: Duration) {
    let now = unix_now();
    let jobs: Vec<u64> = sched.expire(now, keep).into_iter().map(|j| j.0).collect();
    let Some(journal) = &out.journal else { return };
    let (reply, rx) = oneshot::channel();
    let before = now - BLOB_GRACE.as_secs() as i64;
    journal.send(Command::Purge { jobs, unreferenced_before: before, reply });
    let blobs = blobs.clone();
    tokio::spawn(async move {
        if let Ok(hashes) = rx.await {
            blobs.remove(&hashes);
        }
    });
}

/// What a worker said, decoded and checked by its stream's own task so the
/// scheduler's loop only does scheduling.
#[derive(Debug)]
pub enum FromWorker {
    /// A rendered tile.
    Tile {
        /// The hand-out it answers.
        key: TileAttempt,
        /// Its sums.
        film_tile: FilmTile,
        /// Its rays.
        stats: RayStats,
    },
    /// A tile that could not be rendered (or whose result was malformed).
    Failed {
        /// The hand-out it answers.
        key: TileAttempt,
        /// Why.
        message: String,
        /// Whether another worker may succeed.
        retryable: bool,
    },
    /// A heartbeat (or a message with nothing in it).
    Alive,
}

impl FromWorker {
    /// Decodes a worker's message; malformed results become retryable failures.
    pub fn decode(id: WorkerId, kind: Option<worker_message::Kind>) -> FromWorker {
        let Some(worker_message::Kind::Result(r)) = kind else { return FromWorker::Alive };
        let key = TileAttempt { job: JobId(r.job_id), tile: TileId(r.tile), attempt: r.attempt };
        let (job, tile) = (key.job, key.tile);
        let stats = r.stats.as_ref().map(RayStats::from).unwrap_or_default();
        let failed = |message: String| FromWorker::Failed { key, message, retryable: true };
        match r.outcome {
            Some(tile_result::Outcome::FilmTile(ft)) => match FilmTile::try_from(&ft) {
                Ok(film_tile) => FromWorker::Tile { key, film_tile, stats },
                Err(e) => {
                    warn!(worker = id.0, job = job.0, tile = tile.0, error = %e, "malformed film tile refused");
                    failed(format!("malformed film tile: {e}"))
                }
            },
            Some(tile_result::Outcome::Failure(f)) => {
                FromWorker::Failed { key, message: f.message, retryable: f.retryable }
            }
            None => {
                warn!(
                    worker = id.0,
                    job = job.0,
                    tile = tile.0,
                    "tile result without an outcome refused"
                );
                failed("empty tile result".into())
            }
        }
    }
}
