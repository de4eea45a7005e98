//! The gRPC [`Outbox`]: what the scheduler sends goes down workers' Work
//! streams and watchers' WatchJob streams, what it asks to keep goes to
//! the journal, and what happens is counted for `/metrics`.

use super::live::RecentImages;
use crate::error::Error;
use crate::live::LiveCursor;
use crate::merge::Film;
use crate::metrics::Metrics;
use crate::scheduler::{Assignment, EndedFilm, JobUpdate, Outbox, Record};
use crate::state::{Command, Journal};
use farm_common::ids::{JobId, TileAttempt, WorkerId};
use farm_common::stats::RayStats;
use farm_proto::convert::{image_chunks, le_bytes, FireflyFacts, ImageFacts};
use farm_proto::v1::{self, coordinator_message, job_event};
use prost::Message;
use std::collections::HashMap;
use std::sync::Arc;
use std::time::Instant;
use tokio::sync::{mpsc, oneshot};
use tonic::Status;

/// Messages to a worker's Work stream.
pub type WorkerTx = mpsc::UnboundedSender<Result<v1::CoordinatorMessage, Status>>;
/// Messages to a WatchJob stream.
pub type WatchTx = mpsc::UnboundedSender<Result<v1::JobEvent, Status>>;
/// Live previews to a WatchJob stream: bounded, so a reader that falls
/// behind is sent less, not queued more.
pub type LiveTx = mpsc::Sender<Result<v1::JobEvent, Status>>;

#[derive(Default)]
pub(super) struct GrpcOutbox {
    pub(super) workers: HashMap<WorkerId, WorkerTx>,
    pub(super) watchers: HashMap<JobId, Vec<WatchTx>>,
    /// Watchers of the image as it renders, each with what it has seen
    /// and when it was last sent an update (or started watching).
    pub(super) live: HashMap<JobId, Vec<(LiveTx, LiveCursor, Instant)>>,
    /// Jobs with live watchers sent a progress event since previews were
    /// last looked at (see `live::Pace::WithProgress`).
    pub(super) progressed: Vec<JobId>,
    /// Where changes are made durable, with a state directory.
    pub(super) journal: Option<Journal>,
    /// What is counted for `/metrics`.
    pub(super) metrics: Arc<Metrics>,
    /// When each tile out was handed out (for the latency histogram).
    pub(super) handed: HashMap<TileAttempt, Instant>,
    /// Finished images kept a while for the dashboard pages open on them.
    pub(super) recent: RecentImages,
    /// Where films ended or estimated off the event loop go back to it;
    /// without it that is done on the loop.
    pub(super) off_loop: Option<OffLoopTx>,
}

/// A film's per-pixel work, done off the event loop.
pub(super) enum OffLoop {
    /// A job's film ended ([`Outbox::end_film`]).
    Ended(JobId, EndedFilm),
    /// A pass's film and its estimate ([`Outbox::estimate_pass`]).
    Estimated(JobId, Box<Film>, Option<f64>),
    /// The work panicked (a bug): the job fails with this message rather
    /// than wait for ever.
    Panicked(JobId, String),
}

/// Runs `work` for `job` on a blocking thread and sends what it gives back
/// to the loop, or [`OffLoop::Panicked`] if it panics. The loop may have
/// stopped meanwhile; a journalled job then resumes when the coordinator
/// starts, and ends again.
fn off_loop(tx: OffLoopTx, job: JobId, work: impl FnOnce() -> OffLoop + Send + 'static) {
    tokio::task::spawn_blocking(move || {
        let done = std::panic::catch_unwind(std::panic::AssertUnwindSafe(work));
        let _ = tx
            .send(done.unwrap_or_else(|p| OffLoop::Panicked(job, farm_common::panic_message(&*p))));
    });
}

/// Films done with off the event loop, on their way back to it.
pub(super) type OffLoopTx = mpsc::UnboundedSender<OffLoop>;

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
            let facts = ImageFacts {
                name: f.name.clone(),
                spp: f.spp,
                render_seconds: f.render_seconds,
                stats: f.stats,
                passes: f.passes.clone(),
                stopped: f.stopped,
                fireflies: f.error.as_ref().and_then(|e| e.fireflies.as_ref()).map(|f| {
                    FireflyFacts {
                        pixels: f.pixels as u32,
                        rel_mse: f.rel_mse,
                        brightest: f.brightest,
                    }
                }),
            };
            // The chunks' rows are slices of the finished job's own
            // buffers, which they keep alive.
            let rgb = le_bytes(f.clone(), |f| f.image.pixels.as_flattened());
            let error = f.error.as_ref().map(|e| {
                (le_bytes(f.clone(), |f| f.error.as_ref().map_or(&[], |e| &e.per_pixel)), e.rel_mse)
            });
            image_chunks((f.image.width, f.image.height), &rgb, error.as_ref(), &facts)
                .into_iter()
                .map(|img| v1::JobEvent { kind: Some(job_event::Kind::Image(img)) })
                .collect()
        }
        JobUpdate::Failed(m) => one(job_event::Kind::Failed(v1::JobFailed { message: m.clone() })),
    }
}

impl GrpcOutbox {
    /// A worker answered hand-out `key`: when it was handed out.
    pub(super) fn answered(&mut self, key: &TileAttempt) -> Option<Instant> {
        self.handed.remove(key)
    }

    /// Observes the latency of a hand-out made at `handed`.
    pub(super) fn observe_latency(&self, handed: Option<Instant>, now: Instant) {
        if let Some(t) = handed {
            self.metrics.tile_latency.observe(now.duration_since(t).as_secs_f64());
        }
    }
}

impl Outbox for GrpcOutbox {
    /// A complete film's estimate and image are worked out on a blocking
    /// thread: for a 2048² film that is about 0.16 s in which the loop goes
    /// on handing out and merging other jobs' tiles.
    fn end_film(&mut self, job: JobId, film: Film, spp: u32) -> Option<EndedFilm> {
        let Some(tx) = self.off_loop.clone() else { return Some(EndedFilm::of(film, spp)) };
        off_loop(tx, job, move || OffLoop::Ended(job, EndedFilm::of(film, spp)));
        None
    }

    /// The same for a pass's estimate, which reads every pixel as the
    /// job's end does.
    fn estimate_pass(
        &mut self,
        job: JobId,
        mut film: Film,
        spp: u32,
    ) -> Option<(Film, Option<f64>)> {
        let Some(tx) = self.off_loop.clone() else {
            let estimate = film.pass_estimate(spp);
            return Some((film, estimate));
        };
        off_loop(tx, job, move || {
            let estimate = film.pass_estimate(spp);
            OffLoop::Estimated(job, Box::new(film), estimate)
        });
        None
    }

    fn assign(&mut self, worker: WorkerId, a: Assignment) {
        self.metrics.tiles_dispatched.inc();
        if a.speculative {
            self.metrics.tiles_speculated.inc();
        } else if a.retry {
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
                samples: a.samples.map(|r| v1::SampleRange {
                    first_sample: r.first,
                    end_sample: r.end,
                    second_from: r.second_from,
                    own_halves: r.own_halves,
                }),
                part: a.part.map_or(0, |k| k + 1),
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
        if let JobUpdate::Finished(f) = &update {
            self.recent.finished(job, f, Instant::now());
        }
        if !final_update && self.live.contains_key(&job) && !self.progressed.contains(&job) {
            self.progressed.push(job);
        }
        if let Some(list) = self.watchers.get_mut(&job) {
            // A finished image's chunks share the finished job's buffers
            // (`job_events`), so a copy for each watcher copies only the
            // small fields; the last watcher is given the events themselves.
            let events = job_events(&update);
            if let Some(last) = list.pop() {
                list.retain(|tx| events.iter().all(|ev| tx.send(Ok(ev.clone())).is_ok()));
                if events.into_iter().all(|ev| last.send(Ok(ev)).is_ok()) {
                    list.push(last);
                }
            }
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

/// Streams a finished job's image from the journal to a watcher.
pub(super) fn send_stored(journal: &Journal, job: JobId, tx: WatchTx) {
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

#[cfg(test)]
mod tests {
    use super::*;
    use crate::scheduler::FinishedJob;
    use farm_common::image::RgbImage;

    /// Work off the loop that panics comes back as a failure of its job,
    /// with the panic's message; work that does not, as what it gave.
    #[tokio::test]
    async fn a_panic_off_the_loop_comes_back_as_its_jobs_failure() {
        let (tx, mut rx) = mpsc::unbounded_channel();
        off_loop(tx.clone(), JobId(3), || panic!("boom {}", 7));
        off_loop(tx, JobId(4), || OffLoop::Panicked(JobId(4), "fine".into()));
        let mut got = Vec::new();
        for _ in 0..2 {
            match rx.recv().await {
                Some(OffLoop::Panicked(j, why)) => got.push((j, why)),
                _ => panic!("not what was sent"),
            }
        }
        got.sort_by_key(|(j, _)| j.0);
        assert_eq!(got, [(JobId(3), "boom 7".to_string()), (JobId(4), "fine".to_string())]);
    }

    /// Every watcher still listening is sent every event, the last one
    /// the events themselves and the others copies; a closed one is
    /// dropped.
    #[test]
    fn every_open_watcher_is_sent_every_event() {
        let mut out = GrpcOutbox::default();
        let job = JobId(1);
        let (txs, mut rxs): (Vec<_>, Vec<_>) = (0..3).map(|_| mpsc::unbounded_channel()).unzip();
        out.watchers.insert(job, txs);
        rxs[1].close();
        let progress =
            JobUpdate::Progress { done: 1, total: 2, workers: 1, stats: RayStats::default() };
        out.notify(job, progress.clone());
        assert_eq!(out.watchers[&job].len(), 2, "the closed watcher is dropped");
        let (w, h) = (1024, 700);
        let finished = Arc::new(FinishedJob {
            name: "scene.pbrt".into(),
            image: RgbImage { width: w, height: h, pixels: vec![[0.25, 0.5, 1.0]; w * h] },
            error: None,
            spp: 1,
            render_seconds: 1.0,
            stats: RayStats::default(),
            passes: Vec::new(),
            stopped: None,
        });
        let update = JobUpdate::Finished(finished);
        let mut want = job_events(&progress);
        want.extend(job_events(&update));
        assert!(want.len() > 2, "the image should take several events");
        for e in &want[1..] {
            let Some(job_event::Kind::Image(img)) = &e.kind else { panic!("not an image") };
            assert_eq!(img.name, "scene.pbrt", "every chunk names the job");
        }
        out.notify(job, update);
        assert!(!out.watchers.contains_key(&job), "a finished job has no watchers left");
        for i in [0, 2] {
            let mut got = Vec::new();
            while let Ok(ev) = rxs[i].try_recv() {
                got.push(ev.expect("an event"));
            }
            assert_eq!(got, want, "watcher {i}");
        }
    }
}
