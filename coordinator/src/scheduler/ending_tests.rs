//! A complete film ended, or a pass's film estimated, outside the
//! scheduler ([`Outbox::end_film`], [`Outbox::estimate_pass`] returning
//! `None`, as the server's outbox does): other jobs go on meanwhile, the
//! image and the passes are those of a film ended at once, and a job
//! cancelled in between stays cancelled.

use super::tests::{geometry, reference_image, render, spec, Recorder};
use super::*;
use crate::merge::Film;
use farm_common::ids::{TileAttempt, TileId};
use farm_common::stats::RayStats;
use std::time::Instant;

/// A recorder that keeps each complete film to be ended later.
#[derive(Default)]
struct Later {
    rec: Recorder,
    films: Vec<(JobId, Film, u32)>,
    passes: Vec<(JobId, Film, u32)>,
    ended: Vec<JobId>,
}

impl Outbox for Later {
    fn assign(&mut self, worker: WorkerId, a: Assignment) {
        self.rec.assign(worker, a);
    }
    fn cancel(&mut self, worker: WorkerId, job: JobId) {
        self.rec.cancel(worker, job);
    }
    fn disconnect(&mut self, worker: WorkerId) {
        self.rec.disconnect(worker);
    }
    fn notify(&mut self, job: JobId, update: JobUpdate) {
        self.rec.notify(job, update);
    }
    fn record(&mut self, change: Record<'_>) {
        if let Record::Ended { job, .. } = change {
            self.ended.push(job);
        }
    }
    fn end_film(&mut self, job: JobId, film: Film, spp: u32) -> Option<EndedFilm> {
        self.films.push((job, film, spp));
        None
    }
    fn estimate_pass(&mut self, job: JobId, film: Film, spp: u32) -> Option<(Film, Option<f64>)> {
        self.passes.push((job, film, spp));
        None
    }
}

/// Answers every hand-out of `job` until none is left.
fn render_all(s: &mut Scheduler, out: &mut Later, job: JobId) {
    let g = geometry();
    loop {
        let mine: Vec<_> = out.rec.take().into_iter().filter(|(_, a)| a.job == job).collect();
        if mine.is_empty() {
            return;
        }
        for (w, a) in mine {
            s.tile_done(w, a.key(), render(&g, a.tile), RayStats::default(), out);
        }
    }
}

/// A scheduler with one worker, whose outbox ends films later.
fn one_worker() -> (Scheduler, Later) {
    let mut s = Scheduler::new(SchedulerConfig::default());
    let mut out = Later::default();
    s.worker_joined(WorkerId(1), "a".into(), 1, 4, Instant::now(), &mut out);
    (s, out)
}

fn state(s: &Scheduler, job: JobId) -> &'static str {
    s.jobs[&job].state.name()
}

#[test]
fn a_film_ended_later_lets_other_jobs_go_on_and_gives_the_same_image() {
    let reference = reference_image();
    let (mut s, mut out) = one_worker();
    let first = s.submit(spec(1), &mut out);
    let second = s.submit(spec(0), &mut out);
    // The first job's tiles all in: its film waits to be ended, and the
    // job is still running, not yet reported done to anyone.
    let g = geometry();
    let mut held = Vec::new();
    while out.films.is_empty() {
        held.extend(out.rec.take());
        let i = held.iter().position(|(_, a)| a.job == first).expect("a tile of it is out");
        let (w, a) = held.remove(i);
        s.tile_done(w, a.key(), render(&g, a.tile), RayStats::default(), &mut out);
    }
    out.rec.assigned.extend(held);
    assert_eq!(state(&s, first), "running");
    assert!(out.rec.image(first).is_none() && out.ended.is_empty());
    assert_eq!(s.film_lent(first), Some(&geometry()), "its pages wait for it");
    assert!(s.film_lent(second).is_none(), "a job with its film has none lent");
    // Meanwhile the second job's tiles are handed out and merged.
    render_all(&mut s, &mut out, second);
    assert_eq!(out.films.len(), 2, "the second film is complete too");
    assert_eq!(state(&s, first), "running");
    // A late copy of a tile of the first job is ignored, not merged.
    let late = TileAttempt { job: first, tile: TileId(0), attempt: 0 };
    s.tile_done(WorkerId(1), late, render(&g, TileId(0)), RayStats::default(), &mut out);
    // Ended, in either order: each job done with the image of a film
    // ended at once.
    for (job, film, spp) in std::mem::take(&mut out.films).into_iter().rev() {
        s.film_ended(job, EndedFilm::of(film, spp), &mut out);
        assert_eq!(state(&s, job), "done");
        assert!(s.film_lent(job).is_none());
        assert_eq!(out.rec.image(job).expect("finished"), reference);
    }
    assert_eq!(out.ended, [second, first], "each end is journalled once");
}

#[test]
fn a_job_cancelled_while_its_film_is_ended_stays_cancelled() {
    let (mut s, mut out) = one_worker();
    let job = s.submit(spec(0), &mut out);
    render_all(&mut s, &mut out, job);
    let (_, film, spp) = out.films.pop().expect("the film is complete");
    assert!(s.cancel(job, &mut out), "a job being ended is still active");
    s.film_ended(job, EndedFilm::of(film, spp), &mut out);
    assert_eq!(state(&s, job), "cancelled");
    assert!(out.rec.image(job).is_none(), "no image after the cancellation");
    assert_eq!(out.ended, [job], "the cancellation is its only end");
}

#[test]
fn a_pass_estimated_later_starts_the_next_pass_as_one_estimated_at_once() {
    use super::pass_tests::{finished, in_passes, render, run, three};
    let plan = three(None, None);
    let mut s = Scheduler::new(SchedulerConfig::default());
    let mut now = Recorder::default();
    s.worker_joined(WorkerId(1), "a".into(), 1, 4, Instant::now(), &mut now);
    let job = s.submit(in_passes(&plan), &mut now);
    run(&mut s, &mut now);
    let reference = finished(&now, job);

    let (mut s, mut out) = one_worker();
    let job = s.submit(in_passes(&plan), &mut out);
    let g = geometry();
    let mut estimated = 0;
    loop {
        let mut queue = out.rec.take();
        while let Some((w, a)) = queue.pop() {
            s.tile_done(w, a.key(), render(&g, a.tile), RayStats::default(), &mut out);
            queue.extend(out.rec.take());
        }
        let Some((j, mut film, spp)) = out.passes.pop() else { break };
        // While the estimate is worked out, the job has nothing out and
        // hands out nothing.
        assert_eq!(state(&s, job), "running");
        assert!(s.film_lent(job).is_some());
        s.fill(&mut out);
        assert!(out.rec.assigned.is_empty());
        let estimate = film.pass_estimate(spp);
        s.pass_estimated(j, film, estimate, &mut out);
        estimated += 1;
    }
    assert_eq!(estimated, 3, "one estimate a pass");
    let (j, film, spp) = out.films.pop().expect("the last pass ends the job");
    s.film_ended(j, EndedFilm::of(film, spp), &mut out);
    let f = finished(&out.rec, job);
    let noted =
        |f: &FinishedJob| -> Vec<_> { f.passes.iter().map(|p| (p.spp, p.estimate)).collect() };
    assert_eq!(noted(&f), noted(&reference), "the same passes, the same estimates");
    assert_eq!(f.image, reference.image);
    assert!(f.passes.iter().all(|p| p.estimate.is_some()), "{:?}", f.passes);
}

#[test]
fn a_job_cancelled_while_its_pass_is_estimated_starts_no_other_pass() {
    use super::pass_tests::{in_passes, three};
    let (mut s, mut out) = one_worker();
    let job = s.submit(in_passes(&three(None, None)), &mut out);
    render_all(&mut s, &mut out, job);
    let (_, mut film, spp) = out.passes.pop().expect("the first pass is complete");
    assert!(s.cancel(job, &mut out));
    let estimate = film.pass_estimate(spp);
    s.pass_estimated(job, film, estimate, &mut out);
    assert_eq!(state(&s, job), "cancelled");
    assert!(s.film_lent(job).is_none(), "a cancelled job's pages are told it ended");
    assert!(out.rec.take().is_empty(), "no tile of a next pass is handed out");
    assert!(s.pass_ends(job).is_empty());
}

/// A job whose film is lent out hands out nothing and takes no result,
/// even with a tile left queued or held (as a tile put back after its
/// holder failed, whose parts came back first, could be).
#[test]
fn a_lent_film_hands_out_nothing_and_takes_no_result() {
    let (mut s, mut out) = one_worker();
    let job = s.submit(spec(0), &mut out);
    render_all(&mut s, &mut out, job);
    assert!(s.film_lent(job).is_some());
    let j = s.jobs.get_mut(&job).unwrap();
    assert!(j.pending.is_empty() && j.out_order.is_empty());
    j.pending.push_back(0);
    j.in_flight.insert(1, (WorkerId(2), 7));
    s.worker_joined(WorkerId(2), "b".into(), 1, 4, Instant::now(), &mut out);
    assert!(out.rec.take().is_empty(), "no tile of a lent film is handed out");
    let key = TileAttempt { job, tile: TileId(1), attempt: 7 };
    s.tile_done(WorkerId(2), key, render(&geometry(), TileId(1)), RayStats::default(), &mut out);
    s.tile_failed(WorkerId(2), key, "no".into(), false, &mut out);
    assert_eq!(state(&s, job), "running", "neither a result nor a failure touches it");
    let (_, film, spp) = out.films.pop().unwrap();
    s.film_ended(job, EndedFilm::of(film, spp), &mut out);
    assert_eq!(out.rec.image(job).expect("finished"), reference_image());
}
