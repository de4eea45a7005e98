//! The coordinator's single event loop: every change to the scheduler
//! happens here, one event at a time.

use super::live::{live_answer, send_live, Pace};
use super::outbox::{send_stored, GrpcOutbox, OffLoop};
use super::ServerConfig;
use crate::live::LiveCursor;
use crate::merge::Film;
use crate::metrics::{Metrics, StateLabel, JOB_STATES};
use crate::scheduler::{JobRow, JobSpec, JobUpdate, Outbox, Scheduler, Snapshot, WorkerRow};
use crate::scheduler::{JobView, WorkerView};
use crate::state::{unix_now, BlobStore, Command, Journal, SavedJob};
use farm_common::ids::{JobId, WorkerId};
use std::collections::{HashMap, HashSet};
use std::sync::Arc;
use std::time::{Duration, Instant};
use tokio::sync::{mpsc, oneshot};
use tonic::Status;

pub use super::from_worker::FromWorker;
pub use super::live::LiveAnswer;
pub(crate) use super::outbox::job_events;
pub use super::outbox::{LiveTx, WatchTx, WorkerTx};
pub use super::queues::{channel, EventRx, EventTx};

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
        /// The job (boxed: it is the largest event by far).
        spec: Box<JobSpec>,
        /// Its empty film, made before it reached the loop.
        film: Box<Film>,
        /// Where to send its id, or why it was refused.
        reply: oneshot::Sender<Result<JobId, crate::error::Error>>,
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
    /// A client asked to watch a job it may watch and was refused for
    /// having too many watches open: it is still there, waiting for a
    /// slot, so the job is not cancelled as unwatched meanwhile.
    WatchWaiting {
        /// The job.
        job: JobId,
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
        /// The tiles whose error map the page has drawn.
        merged: u32,
        /// Whether the page wants the job's facts too (its row, as the
        /// dashboard shows it), so that one look serves both.
        facts: bool,
        /// What there is to show, and the facts if asked for.
        reply: oneshot::Sender<(LiveAnswer, Option<crate::scheduler::JobView>)>,
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

/// Runs the scheduler until the channel closes or `Shutdown` arrives.
pub async fn run(mut rx: EventRx, config: ServerConfig, state: LoopState) {
    let mut sched = Scheduler::new(config.scheduler.clone());
    let (off_loop_tx, mut off_loop) = mpsc::unbounded_channel();
    let mut out = GrpcOutbox {
        journal: state.journal,
        metrics: state.metrics,
        off_loop: Some(off_loop_tx),
        ..Default::default()
    };
    let mut rays_at: (Instant, u64) = (Instant::now(), 0);
    sched.set_next_job(state.next_job);
    for job in state.jobs {
        sched.restore(job, &mut out);
    }
    let blobs = state.blobs;
    let keep = config.state.keep_finished;
    let mut last_purge: Option<Instant> = None;
    let mut unwatched: HashMap<JobId, Instant> = HashMap::new();
    // The running estimate each active job's row or page was last shown.
    let mut shown: HashMap<JobId, f64> = HashMap::new();
    // When the event being handled was taken.
    let mut busy_since: Option<Instant> = None;
    loop {
        if let Some(t) = busy_since.take() {
            out.metrics.loop_busy.inc_by(t.elapsed().as_secs_f64());
        }
        // A film back from off the loop goes first: its job waits for it.
        let ev = tokio::select! {
            biased;
            Some(done) = off_loop.recv() => Err(done),
            ev = rx.recv() => match ev {
                Some(ev) => Ok(ev),
                None => break,
            },
        };
        busy_since = Some(Instant::now());
        let ev = match ev {
            Ok(ev) => ev,
            Err(done) => {
                back_from_off_loop(&mut sched, done, &mut out);
                continue;
            }
        };
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
                        let (handed, merged) = (out.answered(&key), out.metrics.tiles_merged.get());
                        sched.tile_done(id, key, film_tile, stats, &mut out);
                        if !out.progressed.is_empty() {
                            send_live(&sched, &mut out, now, Pace::WithProgress);
                        }
                        // A tile's latency is its merged result's, not that
                        // of a speculative copy that lost.
                        if out.metrics.tiles_merged.get() > merged {
                            out.observe_latency(handed, now);
                        }
                    }
                    FromWorker::Failed { key, message, retryable } => {
                        let handed = out.answered(&key);
                        out.observe_latency(handed, now);
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
            Event::Submit { spec, film, reply } => {
                let id = match sched.check_shot(&spec) {
                    Ok(()) => Ok(sched.submit_with_film(*spec, *film, &mut out)),
                    Err(why) => {
                        // Its pages are unmapped off the loop, as they were mapped.
                        tokio::task::spawn_blocking(move || drop(film));
                        Err(crate::error::Error::BadShot(why))
                    }
                };
                let _ = reply.send(id);
            }
            Event::WatchWaiting { job, reply } => {
                // The grace period starts again at the next tick.
                unwatched.remove(&job);
                let _ = reply.send(sched.owner(job).is_some());
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
                            out.live.entry(job).or_default().push((live, LiveCursor::new(), now));
                        }
                    }
                    let _ = reply.send(true);
                }
                None => {
                    let _ = reply.send(false);
                }
            },
            Event::LiveTick => {
                send_live(&sched, &mut out, now, Pace::Tick);
                out.recent.expire(now);
            }
            Event::Views { reply } => {
                // Each running estimate is brought up to date over the
                // tiles merged since the last look, not recomputed.
                // A job whose film is lent off the loop keeps the last one.
                let active: HashSet<JobId> = sched.active_jobs().into_iter().map(|a| a.0).collect();
                shown.retain(|job, _| active.contains(job));
                for job in active {
                    shown_estimate(&mut sched, &mut shown, job);
                }
                let views = sched.views(now, |job| shown.get(&job).copied());
                let _ = reply.send(views);
            }
            Event::Live { job, from, merged, facts, reply } => {
                let at = (from, merged);
                let answer = live_answer(&mut sched, &mut out.recent, job, at, now);
                let facts = facts.then(|| {
                    // Up to date already: the answer brought it up to date.
                    let estimate = shown_estimate(&mut sched, &mut shown, job);
                    sched.view(job, now, |_| estimate)
                });
                let _ = reply.send((answer, facts.flatten()));
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
                // The counter follows the store's own count, which only grows.
                let received = blobs.received_bytes();
                m.blob_uploaded.inc_by(received.saturating_sub(m.blob_uploaded.get()));
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
                // A job whose film is being ended has all its tiles in: it
                // is delivered (and journalled) rather than failed or merged
                // again at the next start. A pass's estimate is not waited
                // for, nor taken if it comes: it would start the next pass.
                let until = tokio::time::Instant::now() + LENT_FILMS_WAIT;
                while sched.films_ending() {
                    match tokio::time::timeout_at(until, off_loop.recv()).await {
                        Ok(Some(OffLoop::Estimated(..))) => {}
                        Ok(Some(done)) => back_from_off_loop(&mut sched, done, &mut out),
                        _ => break,
                    }
                }
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

/// How long a shutdown waits for films being ended off the loop (a 2048² film's end takes about 0.2 s).
const LENT_FILMS_WAIT: Duration = Duration::from_secs(30);

/// The running estimate to show for `job`, brought up to date over the
/// tiles merged since the last look and noted in `shown`; while its film
/// is lent off the loop, the one last shown.
fn shown_estimate(
    sched: &mut Scheduler,
    shown: &mut HashMap<JobId, f64>,
    job: JobId,
) -> Option<f64> {
    match sched.film_mut(job).map(|film| film.running_estimate()) {
        Some(Some(e)) => shown.insert(job, e),
        Some(None) => shown.remove(&job),
        None => None,
    };
    shown.get(&job).copied()
}

/// Gives the scheduler a film back from off the loop, or its job's failure.
fn back_from_off_loop(sched: &mut Scheduler, done: OffLoop, out: &mut GrpcOutbox) {
    match done {
        OffLoop::Ended(job, ended) => sched.film_ended(job, ended, out),
        OffLoop::Estimated(job, film, estimate) => sched.pass_estimated(job, *film, estimate, out),
        OffLoop::Panicked(job, why) => {
            let reason = format!("internal error while ending the job's film: {why}");
            sched.abandon(job, reason, out);
        }
    }
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
