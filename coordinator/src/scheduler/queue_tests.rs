//! Which job a free slot goes to (priority, then submission), what the
//! dashboard's views and the gauges say of jobs and workers, and shots.

use super::tests::{geometry, render, spec, Recorder};
use super::*;
use farm_common::stats::RayStats;
use std::time::{Duration, Instant};

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

#[test]
fn a_raised_priority_takes_the_next_free_slot_and_views_tell_the_truth() {
    let mut s = Scheduler::new(SchedulerConfig::default());
    let mut out = Recorder::default();
    let t0 = Instant::now();
    s.worker_joined(WorkerId(1), "w".into(), 1, 1, t0, &mut out);
    let first = s.submit(spec(0), &mut out);
    let second = s.submit(spec(0), &mut out);
    let (w, a) = out.take().pop().unwrap();
    assert_eq!(a.job, first);
    assert!(s.set_priority(second, 5, &mut out));
    assert!(out.take().is_empty(), "the slot is still held");
    s.tile_done(w, a.key(), render(&geometry(), a.tile), RayStats::default(), &mut out);
    let next = out.take();
    assert_eq!(next[0].1.job, second, "the raised job goes first");
    let (jobs, workers) = s.views(t0 + Duration::from_secs(2), |_| Some(0.5));
    let v = |id: JobId| jobs.iter().find(|j| j.id == id.0).unwrap().clone();
    assert_eq!((v(first).tiles_done, v(first).state, v(first).rel_mse), (1, "running", Some(0.5)));
    assert_eq!(v(second).priority, 5);
    assert_eq!(v(second).workers, 1);
    assert!(v(first).eta_seconds.unwrap() > 0.0);
    assert_eq!(workers[0].tiles_done, 1);
    assert_eq!(workers[0].tiles_per_second, 0.5);
    let g = s.gauges();
    assert_eq!(g.jobs.get("running"), Some(&2));
    assert_eq!(g.queue_depth as u32, 2 * geometry().tile_count() - 2);
    // An ended job's priority cannot change.
    assert!(s.cancel(first, &mut out));
    assert!(!s.set_priority(first, 9, &mut out));
}

#[test]
fn a_worker_failing_a_job_too_often_shows_as_blocklisted() {
    let mut s = Scheduler::new(SchedulerConfig { max_tile_failures: 10, ..Default::default() });
    let mut out = Recorder::default();
    let t0 = Instant::now();
    s.worker_joined(WorkerId(1), "flaky".into(), 1, 1, t0, &mut out);
    let job = s.submit(spec(0), &mut out);
    for _ in 0..3 {
        let (w, a) = out.take().pop().expect("a tile");
        s.tile_failed(w, a.key(), "boom".into(), true, &mut out);
    }
    let (_, workers) = s.views(t0, |_| None);
    assert_eq!(workers[0].failures, 3);
    assert_eq!(workers[0].blocklisted, vec![job.0]);
}

/// A shot's first frame names the shot after its job; later frames may
/// join it only if it is a shot and its owner's.
#[test]
fn frames_join_only_their_owners_shots() {
    use super::ShotFrame;
    let mut s = Scheduler::new(SchedulerConfig::default());
    let mut out = Recorder::default();
    let frame = |shot: u64, frame: u32, owner: &str| {
        let shot = Some(ShotFrame { shot: JobId(shot), frame, frames: 3 });
        let owner = Owner { id: owner.into(), name: owner.into() };
        JobSpec { shot, owner, ..spec(0) }
    };
    let plain = s.submit(JobSpec { owner: frame(0, 1, "ann").owner, ..spec(0) }, &mut out);
    let first = s.submit(frame(0, 1, "ann"), &mut out);
    let (rows, _) = s.status();
    let row = rows.iter().find(|r| r.id == first).unwrap();
    assert_eq!(row.shot, Some(ShotFrame { shot: first, frame: 1, frames: 3 }));
    assert!(s.check_shot(&frame(first.0, 2, "ann")).is_ok());
    assert!(s.check_shot(&frame(0, 1, "bob")).is_ok(), "anyone may start a shot");
    let refused = [frame(first.0, 2, "bob"), frame(plain.0, 2, "ann"), frame(99, 2, "ann")];
    for f in refused {
        let e = s.check_shot(&f).unwrap_err();
        assert!(e.contains("no shot"), "{e}");
    }
}

/// A job submitted with a film made by the caller renders as one
/// submitted without; a film of another geometry is not used.
#[test]
fn a_job_keeps_a_film_made_for_it_and_replaces_one_that_is_not() {
    use crate::merge::Film;
    use farm_common::geometry::{Bounds2i, Point2i};
    let reference = super::tests::reference_image();
    let mut other = geometry();
    other.cropped_pixel_bounds = Bounds2i::new(Point2i::new(0, 0), Point2i::new(20, 10));
    for film in [Film::new(geometry()), Film::new(other)] {
        let mut s = Scheduler::new(SchedulerConfig::default());
        let mut out = Recorder::default();
        s.worker_joined(WorkerId(1), "a".into(), 1, 1, Instant::now(), &mut out);
        let job = s.submit_with_film(spec(0), film, &mut out);
        let g = geometry();
        while let Some((w, a)) = out.take().pop() {
            s.tile_done(w, a.key(), render(&g, a.tile), RayStats::default(), &mut out);
        }
        assert_eq!(out.image(job).expect("finished"), reference);
    }
}
