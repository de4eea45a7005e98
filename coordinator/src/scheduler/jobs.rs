//! Jobs through the scheduler: their life from submission to image,
//! failure or cancellation, and what each tile result does to them.

use super::job::{Job, JobSpec, JobState, Owner, Snapshot};
use super::{EndedFilm, FinishedJob, JobUpdate, Outbox, Record, Scheduler};
use crate::merge::{Accepted, Film};
use farm_common::film::FilmTile;
use farm_common::ids::{JobId, TileAttempt, TileId, WorkerId};
use farm_common::stats::RayStats;
use std::collections::HashSet;
use std::sync::Arc;
use std::time::Duration;
use tracing::{debug, info, warn};

/// Longest quiet spell between progress updates of a running job.
pub(super) const PROGRESS_EVERY: Duration = Duration::from_millis(100);

impl Scheduler {
    /// Queues a job and hands out tiles.
    pub fn submit(&mut self, spec: JobSpec, out: &mut impl Outbox) -> JobId {
        let film = Film::new(spec.geometry.clone());
        self.submit_with_film(spec, film, out)
    }

    /// [`Scheduler::submit`] with the job's empty film made by the caller
    /// (the server makes it off its event loop: mapping a 2048² film's
    /// 128 MB took the loop 30 ms). A film of another geometry is replaced.
    pub fn submit_with_film(
        &mut self,
        mut spec: JobSpec,
        film: Film,
        out: &mut impl Outbox,
    ) -> JobId {
        let id = JobId(self.next_job);
        self.next_job += 1;
        // A shot's first frame names the shot after itself.
        if let Some(s) = spec.shot.as_mut().filter(|s| s.shot.0 == 0) {
            s.shot = id;
        }
        let total = spec.geometry.tile_count();
        info!(job = id.0, name = %spec.name, tiles = total, priority = spec.priority, "job queued");
        let mut job = Job::new(id, spec, JobState::Queued, self.now());
        job.film = Some(if *film.geometry() == job.spec.geometry {
            film
        } else {
            Film::new(job.spec.geometry.clone())
        });
        job.pending = (0..total).collect();
        out.record(Record::Submitted { job: id, spec: &job.spec });
        self.jobs.insert(id, job);
        if total == 0 {
            self.finish(id, out);
        }
        self.fill(out);
        id
    }

    /// Refuses a frame that names a shot (other than a new one) that is
    /// not a shot of the same client's. A shot is known while any of its
    /// frames' jobs is (until `--keep-finished` forgets the last), so a
    /// shot longer than that still takes its next frames.
    pub fn check_shot(&self, spec: &JobSpec) -> Result<(), String> {
        let Some(s) = spec.shot.filter(|s| s.shot.0 != 0) else { return Ok(()) };
        let known = self.jobs.values().any(|j| {
            j.spec.owner.id == spec.owner.id && j.spec.shot.is_some_and(|f| f.shot == s.shot)
        });
        if known {
            Ok(())
        } else {
            Err(format!("there is no shot {} of yours on this coordinator", s.shot.0))
        }
    }

    /// Whether `worker` holds hand-out `key`: only the holder's answer to a
    /// tile counts, so a result for a tile never assigned, assigned to
    /// another worker, or an earlier attempt of it changes nothing.
    fn holds(&self, worker: WorkerId, key: TileAttempt) -> bool {
        self.jobs.get(&key.job).is_some_and(|j| {
            let h = Some(&(worker, key.attempt));
            // A job whose film is lent out holds nothing.
            j.state.is_active()
                && j.film.is_some()
                && (j.in_flight.get(&key.tile.0) == h
                    || j.spares.get(&key.tile.0) == h
                    || j.holds_part(key.tile.0, worker, Some(key.attempt)))
        })
    }

    /// A worker answered a hand-out another finished first: its slot is
    /// free now.
    fn answered_superseded(&mut self, worker: WorkerId, key: TileAttempt, out: &mut impl Outbox) {
        let moot = (worker, key.tile.0, key.attempt);
        if self.jobs.get_mut(&key.job).is_some_and(|j| j.superseded.remove(&moot)) {
            self.release(worker, key.job, key.tile.0);
            self.fill(out);
        }
    }

    /// Logs why an answer from `worker` to `key` was ignored.
    fn ignored(&self, worker: WorkerId, key: TileAttempt, what: &str) {
        let (job, tile, attempt) = (key.job.0, key.tile.0, key.attempt);
        match self.jobs.get(&key.job) {
            // A job ended while the answer was on its way; a worker declared
            // lost may still have had a few messages in flight.
            Some(j) if !j.state.is_active() || j.film_lent() => {
                debug!(job, tile, "{what} for a finished job or pass ignored")
            }
            _ if !self.workers.contains_key(&worker) => {
                debug!(worker = worker.0, job, tile, "{what} from a lost worker ignored")
            }
            Some(j) if j.film.as_ref().is_some_and(|f| f.has(key.tile)) => {
                debug!(worker = worker.0, job, tile, "{what} for a tile merged from another worker")
            }
            None => warn!(worker = worker.0, job, tile, "{what} for an unknown job refused"),
            Some(_) => warn!(
                worker = worker.0,
                job, tile, attempt, "{what} for a tile this worker does not hold refused"
            ),
        }
    }

    /// A rendered tile. Only the worker holding that hand-out may answer
    /// it; a tile of the wrong size or with impossible sums is a retryable
    /// failure of that worker.
    pub fn tile_done(
        &mut self,
        worker: WorkerId,
        key: TileAttempt,
        film_tile: FilmTile,
        stats: RayStats,
        out: &mut impl Outbox,
    ) {
        if !self.holds(worker, key) {
            self.ignored(worker, key, "tile result");
            self.answered_superseded(worker, key, out);
            return;
        }
        let (job, tile) = (key.job, key.tile);
        self.release(worker, job, tile.0);
        let now = self.now();
        let j = self.jobs.get_mut(&job).expect("held tiles belong to known jobs");
        let part = j
            .parts
            .get(&tile.0)
            .and_then(|p| p.held.iter().position(|h| *h == Some((worker, key.attempt))));
        // A whole tile from its holder times the worker's pace.
        let from_holder = j.in_flight.get(&tile.0) == Some(&(worker, key.attempt));
        if j.spec.parallel_tiles && from_holder {
            let handed = j.handed_at.get(&tile.0).copied();
            if let (Some(handed), Some(w)) = (handed, self.workers.get_mut(&worker)) {
                w.pace.tile_done(handed, now);
            }
        }
        let film = j.film.as_mut().expect("active jobs have a film");
        match film.check(tile, &film_tile) {
            Ok(Accepted::New) => {
                let whole = match part {
                    Some(k) => j.part_done(tile.0, k, film_tile, stats),
                    None => Some((film_tile, stats)),
                };
                if let Some((film_tile, stats)) = whole {
                    self.merge_new(worker, job, tile, film_tile, stats, out);
                }
            }
            Ok(Accepted::Duplicate) => {
                // A held tile is never in the film; keep the books straight anyway.
                j.drop_holders(tile.0);
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

    /// Merges a tile result the film found new (a whole tile, or its parts
    /// added up), from `worker`: journals it, counts it, tells watchers,
    /// frees the tile's other hand-outs and ends the pass when it was the
    /// last.
    fn merge_new(
        &mut self,
        worker: WorkerId,
        job: JobId,
        tile: TileId,
        film_tile: FilmTile,
        stats: RayStats,
        out: &mut impl Outbox,
    ) {
        let now = self.now();
        let j = self.jobs.get_mut(&job).expect("held tiles belong to known jobs");
        let film = j.film.as_mut().expect("active jobs have a film");
        let key = TileId(j.pass.saturating_mul(j.spec.geometry.tile_count()) + tile.0);
        let film_tile = Arc::new(film_tile);
        out.record(Record::Merged { job, tile: key, film_tile: &film_tile, stats: &stats });
        film.insert(tile, film_tile);
        let complete = film.is_complete();
        let others = j.drop_holders(tile.0);
        j.stats.add(&stats);
        j.done_tiles += 1;
        if let Some(w) = self.workers.get_mut(&worker) {
            w.tiles_done += 1;
        }
        // Progress goes out every 0.5% of the tiles or 100 ms, not per tile.
        let total = j.spec.geometry.tile_count();
        let step = (total / 200).max(1);
        if j.done_tiles == total
            || j.done_tiles.is_multiple_of(step)
            || now.duration_since(j.last_progress) >= PROGRESS_EVERY
        {
            j.last_progress = now;
            let workers = match j.holders_counted {
                Some((n, at))
                    if j.done_tiles < total && now.duration_since(at) < PROGRESS_EVERY =>
                {
                    n
                }
                _ => {
                    let n = j.holder_count();
                    j.holders_counted = Some((n, now));
                    n
                }
            };
            let update = JobUpdate::Progress { done: j.done_tiles, total, workers, stats: j.stats };
            out.notify(job, update);
        }
        // The tile's other hand-outs are no longer needed, but their
        // workers are still rendering them: their slots stay taken until
        // they answer (the answer is ignored), or free now at the end of
        // the pass.
        let others = others.into_iter().filter(|(w, _)| *w != worker);
        if !complete {
            j.superseded.extend(others.map(|(w, a)| (w, tile.0, a)));
            return;
        }
        let old: Vec<_> = j.superseded.drain().map(|(w, t, _)| (w, t)).collect();
        let now_moot = others.map(|(w, _)| (w, tile.0));
        for (w, t) in old.into_iter().chain(now_moot).collect::<Vec<_>>() {
            self.release(w, job, t);
        }
        self.end_pass(job, out);
    }

    /// A tile a worker could not render; only the holder of that hand-out
    /// may say so.
    pub fn tile_failed(
        &mut self,
        worker: WorkerId,
        key: TileAttempt,
        message: String,
        retryable: bool,
        out: &mut impl Outbox,
    ) {
        if !self.holds(worker, key) {
            self.ignored(worker, key, "tile failure");
            self.answered_superseded(worker, key, out);
            return;
        }
        self.release(worker, key.job, key.tile.0);
        self.record_failure(worker, key.job, key.tile.0, message, retryable, out);
        self.fill(out);
    }

    /// Cancels a job; returns whether it was still active.
    pub fn cancel(&mut self, job: JobId, out: &mut impl Outbox) -> bool {
        self.cancel_because(job, "the job was cancelled".into(), out)
    }

    /// Cancels a job, telling its watchers why; returns whether it was
    /// still active.
    pub fn cancel_because(&mut self, job: JobId, why: String, out: &mut impl Outbox) -> bool {
        let Some(j) = self.jobs.get_mut(&job) else { return false };
        if !j.state.is_active() {
            return false;
        }
        self.stop(job, JobState::Cancelled, out);
        info!(job = job.0, %why, "job cancelled");
        out.notify(job, JobUpdate::Failed(why));
        self.fill(out);
        true
    }

    /// The queued and running jobs, each with whether it was detached.
    pub fn active_jobs(&self) -> Vec<(JobId, bool)> {
        self.jobs.values().filter(|j| j.state.is_active()).map(|j| (j.id, j.spec.detach)).collect()
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

    /// The coordinator is shutting down. With a journal, active jobs stay
    /// as they are, to resume when it starts again; without, they fail.
    pub fn shutdown(&mut self, out: &mut impl Outbox) {
        if out.durable() {
            let active = self.jobs.values().filter(|j| j.state.is_active()).count();
            info!(jobs = active, "active jobs will resume when the coordinator starts again");
            return;
        }
        for (id, j) in &mut self.jobs {
            if j.state.is_active() {
                j.state = JobState::Failed("the coordinator is shutting down".into());
                out.notify(*id, JobUpdate::Failed("the coordinator is shutting down".into()));
            }
        }
    }

    /// What a new watcher of `job` is told first, if the job exists.
    pub fn snapshot(&self, job: JobId) -> Option<Snapshot> {
        let j = self.jobs.get(&job)?;
        let update = match &j.state {
            JobState::Done => match &j.finished {
                Some(f) => JobUpdate::Finished(f.clone()),
                None => return Some(Snapshot::Stored),
            },
            JobState::Failed(m) => JobUpdate::Failed(m.clone()),
            JobState::Cancelled => JobUpdate::Failed("the job was cancelled".into()),
            _ => JobUpdate::Progress {
                done: j.done_tiles,
                total: j.spec.geometry.tile_count(),
                workers: 0,
                stats: j.stats,
            },
        };
        Some(Snapshot::Update(update))
    }

    /// Who submitted a job, if it exists.
    pub fn owner(&self, job: JobId) -> Option<&Owner> {
        self.jobs.get(&job).map(|j| &j.spec.owner)
    }

    /// The state of a job.
    pub fn job_state(&self, job: JobId) -> Option<&JobState> {
        self.jobs.get(&job).map(|j| &j.state)
    }

    pub(super) fn record_failure(
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
        // Another hand-out of the tile may still be rendering it.
        let still_held = j.drop_holder(tile, worker);
        let name = self
            .workers
            .get(&worker)
            .map(|w| w.name.clone())
            .unwrap_or_else(|| format!("worker {}", worker.0));
        warn!(worker = worker.0, job = job.0, tile, %message, retryable, "tile failed");
        let fails = j.failures.entry(tile).or_default();
        fails.push((worker, format!("{name}: {message}")));
        *j.worker_failures.entry(worker).or_default() += 1;
        if let Some(w) = self.workers.get_mut(&worker) {
            w.failures += 1;
        }
        let distinct: HashSet<WorkerId> = fails.iter().map(|(w, _)| *w).collect();
        if !retryable || distinct.len() >= max_tile {
            let msgs: Vec<String> = fails.iter().map(|(_, m)| m.clone()).collect();
            let reason = format!("tile {tile} failed: {}", msgs.join("; "));
            self.fail(job, reason, out);
        } else if !still_held {
            j.pending.push_front(tile);
        }
    }

    pub(super) fn fail(&mut self, job: JobId, reason: String, out: &mut impl Outbox) {
        if !self.jobs.contains_key(&job) {
            return;
        }
        warn!(job = job.0, %reason, "job failed");
        self.stop(job, JobState::Failed(reason.clone()), out);
        out.notify(job, JobUpdate::Failed(reason));
    }

    /// Ends an active job in `state`: its film and queue are dropped and
    /// the workers holding its tiles are told to drop them.
    fn stop(&mut self, job: JobId, state: JobState, out: &mut impl Outbox) {
        let Some(j) = self.jobs.get_mut(&job) else { return };
        j.state = state;
        j.ended_at = Some(crate::state::unix_now());
        out.record(Record::Ended { job, state: &j.state, image: None });
        j.film = None;
        j.ending = None;
        j.estimating = None;
        j.pending.clear();
        j.out_order.clear();
        let spares = j.spares.drain().map(|(_, (w, _))| w);
        let parts: Vec<WorkerId> =
            j.parts.drain().flat_map(|(_, p)| p.held).flatten().map(|(w, _)| w).collect();
        let holders: HashSet<WorkerId> =
            j.in_flight.drain().map(|(_, (w, _))| w).chain(spares).chain(parts).collect();
        for w in holders {
            out.cancel(w, job);
            if let Some(wk) = self.workers.get_mut(&w) {
                wk.in_flight.retain(|(jb, _)| *jb != job);
            }
            self.refresh_ready(w);
        }
    }

    /// Ends a job whose film is complete: its image and estimate are worked
    /// out by the outbox ([`Outbox::end_film`]), at once or later; the job
    /// stays running until [`Scheduler::film_ended`] has them.
    pub(super) fn finish(&mut self, job: JobId, out: &mut impl Outbox) {
        let now = self.now();
        let Some(j) = self.jobs.get_mut(&job) else { return };
        let Some(film) = j.lend_film() else { return };
        let render_seconds = j.started.map(|s| now.duration_since(s).as_secs_f64()).unwrap_or(0.0);
        let spp = j.pass_ends.last().map_or(j.spec.spp, |p| p.spp);
        j.ending = Some((spp, render_seconds));
        if let Some(ended) = out.end_film(job, film, spp) {
            self.film_ended(job, ended, out);
        }
    }

    /// The image and estimate of `job`'s film, which [`Outbox::end_film`]
    /// worked out: the job is done. Ignored if the job was cancelled (or
    /// forgotten) meanwhile.
    pub fn film_ended(&mut self, job: JobId, ended: EndedFilm, out: &mut impl Outbox) {
        let Some(j) = self.jobs.get_mut(&job) else { return };
        let Some((spp, render_seconds)) = j.ending.take() else { return };
        if !j.state.is_active() {
            return;
        }
        let finished = std::sync::Arc::new(FinishedJob {
            name: j.spec.name.clone(),
            image: ended.image,
            error: ended.error,
            spp,
            render_seconds,
            stats: j.stats,
            passes: j.pass_ends.clone(),
            stopped: j.stopped,
        });
        j.state = JobState::Done;
        j.rel_mse = finished.error.as_ref().map(|e| e.rel_mse);
        j.ended_at = Some(crate::state::unix_now());
        out.record(Record::Ended { job, state: &j.state, image: Some(&finished) });
        // With a journal the image is read back from it: memory does not
        // grow with the jobs kept for their retention period.
        j.finished = (!out.durable()).then(|| finished.clone());
        info!(job = job.0, seconds = render_seconds, "job done");
        out.notify(job, JobUpdate::Finished(finished));
    }
}
