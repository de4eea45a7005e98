//! The scheduler against a recording outbox.

use super::*;
use farm_common::film::{FilmGeometry, FilmTile};
use farm_common::geometry::{Bounds2i, Point2i, Vec2};
use farm_common::ids::{TileAttempt, TileId};
use farm_common::image::RgbImage;
use farm_common::stats::RayStats;
use farm_common::Spectrum;
use std::collections::HashSet;
use std::time::{Duration, Instant};

#[derive(Default)]
pub(super) struct Recorder {
    pub(super) assigned: Vec<(WorkerId, Assignment)>,
    pub(super) cancelled: Vec<(WorkerId, JobId)>,
    pub(super) disconnected: Vec<WorkerId>,
    pub(super) updates: Vec<(JobId, JobUpdate)>,
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
    pub(super) fn take(&mut self) -> Vec<(WorkerId, Assignment)> {
        std::mem::take(&mut self.assigned)
    }
    pub(super) fn image(&self, job: JobId) -> Option<RgbImage> {
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

pub(super) fn geometry() -> FilmGeometry {
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

pub(crate) fn spec(priority: i32) -> JobSpec {
    JobSpec {
        name: "t".into(),
        priority,
        scene_hash: vec![1; 32],
        spp_override: 0,
        spp: 4,
        geometry: geometry(),
        owner: Owner::default(),
        detach: false,
        blobs: Vec::new(),
        shot: None,
        passes: None,
        parallel_tiles: false,
    }
}

/// What any worker would render for a tile: depends only on the tile.
pub(crate) fn render(g: &FilmGeometry, tile: TileId) -> FilmTile {
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
        s.tile_done(w, a.key(), render(&g, a.tile), RayStats::default(), out);
        queue.extend(out.take());
    }
}

pub(super) fn reference_image() -> RgbImage {
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
fn a_stalled_worker_costs_a_retry_not_the_image() {
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
                s.tile_done(w, a.key(), render(&g, a.tile), RayStats::default(), &mut out);
            } else {
                held_by_2 += 1;
            }
        }
    }
    assert_eq!(held_by_2, 2, "the stalled worker holds its two tiles");
    // Once no tile is left to hand out, the idle worker renders the stalled
    // one's tiles again (speculation): the image does not wait for the
    // stalled worker to be declared lost.
    assert!(out.image(job) == Some(reference.clone()), "image differs");
    s.tick(t0 + Duration::from_secs(10), &mut out);
    assert_eq!(out.disconnected, vec![WorkerId(2)]);
    // A late result from the lost worker changes nothing.
    let late = render(&g, TileId(0));
    let key = TileAttempt { job, tile: TileId(0), attempt: 0 };
    s.tile_done(WorkerId(2), key, late, RayStats::default(), &mut out);
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
    let unknown = TileAttempt { job: JobId(999), ..a.key() };
    s.tile_done(w, unknown, render(&g, a.tile), RayStats::default(), &mut out);
    // A tile of the wrong size is refused and retried.
    s.tile_done(w, a.key(), render(&g, TileId(a.tile.0 + 1)), RayStats::default(), &mut out);
    let (w, a) = out.take().remove(0);
    s.tile_done(w, a.key(), render(&g, a.tile), RayStats::default(), &mut out);
    s.tile_done(w, a.key(), render(&g, a.tile), RayStats::default(), &mut out);
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
                s.tile_failed(w, a.key(), format!("boom on {}", w.0), true, &mut out);
            } else {
                s.tile_done(w, a.key(), render(&g, a.tile), RayStats::default(), &mut out);
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
        s.tile_failed(w, a.key(), "flaky".into(), true, &mut out);
    }
    assert!(out.take().is_empty(), "no more tiles for the flaky worker");
    s.worker_joined(WorkerId(2), "good".into(), 1, 1, Instant::now(), &mut out);
    drain(&mut s, &mut out, |_| 0);
    assert!(out.image(job).is_some());
}

#[test]
fn only_the_holder_of_a_hand_out_may_answer_it() {
    let reference = reference_image();
    let mut s = Scheduler::new(SchedulerConfig::default());
    let mut out = Recorder::default();
    let t0 = Instant::now();
    s.worker_joined(WorkerId(1), "honest".into(), 1, 1, t0, &mut out);
    s.worker_joined(WorkerId(2), "forger".into(), 1, 1, t0, &mut out);
    let job = s.submit(spec(0), &mut out);
    let g = geometry();
    let total = g.tile_count();
    let held: Vec<(WorkerId, Assignment)> = out.take();
    let (w1, a1) = held.iter().find(|(w, _)| *w == WorkerId(1)).cloned().unwrap();
    // Made-up pixels for every tile of the job, from a worker that holds
    // one other tile: none is merged, and none fails the job.
    let poison = |g: &FilmGeometry, t: TileId| {
        let mut f = render(g, t);
        for p in &mut f.pixels {
            p.contrib = [1e6; 3];
        }
        f
    };
    for t in 0..total {
        for attempt in 0..3 {
            let key = TileAttempt { job, tile: TileId(t), attempt };
            if key == a1.key() || held.iter().any(|(w, a)| *w == WorkerId(2) && a.key() == key) {
                continue;
            }
            s.tile_done(WorkerId(2), key, poison(&g, TileId(t)), RayStats::default(), &mut out);
            s.tile_failed(WorkerId(2), key, "forged".into(), false, &mut out);
        }
    }
    // The honest worker's tile, answered as an earlier attempt, is refused too.
    let stale = TileAttempt { attempt: a1.attempt + 1, ..a1.key() };
    s.tile_done(w1, stale, poison(&g, a1.tile), RayStats::default(), &mut out);
    assert_eq!(s.status().0[0].done, 0, "nothing merged from forged results");
    assert_eq!(s.job_state(job), Some(&JobState::Running));
    assert!(out.take().is_empty(), "no slot was freed by a forged answer");
    // Everyone answers what they hold honestly: the image is the reference.
    for (w, a) in held {
        s.tile_done(w, a.key(), render(&g, a.tile), RayStats::default(), &mut out);
    }
    drain(&mut s, &mut out, |_| 0);
    assert!(out.image(job) == Some(reference), "image differs");
}

#[test]
fn a_worker_cannot_hoard_a_job_by_asking_for_every_tile() {
    let config = SchedulerConfig { max_in_flight: 8, ..Default::default() };
    let mut s = Scheduler::new(config);
    let mut out = Recorder::default();
    // Sixteen threads: its tile per thread and two waiting are more than
    // the cap.
    s.worker_joined(WorkerId(1), "greedy".into(), 16, u32::MAX, Instant::now(), &mut out);
    s.worker_joined(WorkerId(2), "modest".into(), 1, 2, Instant::now(), &mut out);
    let _ = s.submit(spec(0), &mut out);
    let out_tiles = out.take();
    let greedy = out_tiles.iter().filter(|(w, _)| *w == WorkerId(1)).count();
    let modest = out_tiles.iter().filter(|(w, _)| *w == WorkerId(2)).count();
    assert!(geometry().tile_count() > 10);
    assert_eq!((greedy, modest), (8, 2));
    assert_eq!(s.status().1[0].in_flight, 8);
}

#[test]
fn impossible_sums_are_a_retryable_failure_of_the_worker_that_sent_them() {
    let reference = reference_image();
    let mut s = Scheduler::new(SchedulerConfig::default());
    let mut out = Recorder::default();
    s.worker_joined(WorkerId(1), "a".into(), 1, 1, Instant::now(), &mut out);
    let job = s.submit(spec(0), &mut out);
    let g = geometry();
    let (w, a) = out.take().remove(0);
    let mut bad = render(&g, a.tile);
    bad.pixels[3].contrib[1] = f32::NAN;
    s.tile_done(w, a.key(), bad, RayStats::default(), &mut out);
    // The worker is handed another tile (it failed that one), which it
    // poisons too; then it renders honestly.
    let (w2, a2) = out.take().remove(0);
    assert_eq!(s.job_state(job), Some(&JobState::Running));
    let mut bad = render(&g, a2.tile);
    bad.pixels[0].weight = -1.0;
    s.tile_done(w2, a2.key(), bad, RayStats::default(), &mut out);
    drain(&mut s, &mut out, |_| 0);
    assert!(out.image(job) == Some(reference), "image differs");
}

/// A recorder whose changes also go to a journal, as the server's do.
pub(super) struct Durable {
    pub(super) rec: Recorder,
    pub(super) journal: crate::state::Journal,
}

impl Outbox for Durable {
    fn assign(&mut self, worker: WorkerId, a: Assignment) {
        self.rec.assign(worker, a)
    }
    fn cancel(&mut self, worker: WorkerId, job: JobId) {
        self.rec.cancel(worker, job)
    }
    fn disconnect(&mut self, worker: WorkerId) {
        self.rec.disconnect(worker)
    }
    fn notify(&mut self, job: JobId, update: JobUpdate) {
        self.rec.notify(job, update)
    }
    fn record(&mut self, change: Record<'_>) {
        self.journal.record(change)
    }
    fn durable(&self) -> bool {
        true
    }
}

#[tokio::test]
async fn a_journalled_job_resumes_to_the_same_bits() {
    let reference = reference_image();
    let dir = std::env::temp_dir().join(format!("farm-journal-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let db = dir.join("farm.db");
    let _ = std::fs::remove_file(&db);
    let g = geometry();
    let total = g.tile_count();
    // A coordinator gets a third of the tiles in, with more in flight, and dies.
    let merged = {
        let (journal, restored) = crate::state::Journal::open(Some(&db)).unwrap();
        assert!(restored.jobs.is_empty());
        let mut s = Scheduler::new(SchedulerConfig::default());
        let mut out = Durable { rec: Recorder::default(), journal: journal.clone() };
        s.worker_joined(WorkerId(1), "a".into(), 1, 4, Instant::now(), &mut out);
        let job = s.submit(spec(0), &mut out);
        let mut merged = 0;
        // Answer out of order: the last of each batch first.
        while merged < total / 3 {
            let mut batch = out.rec.take();
            batch.reverse();
            let (w, a) = batch.remove(0);
            s.tile_done(w, a.key(), render(&g, a.tile), RayStats::default(), &mut out);
            out.rec.assigned.extend(batch);
            merged += 1;
        }
        assert_eq!(s.job_state(job), Some(&JobState::Running));
        journal.flush().await;
        merged
    };
    // The next coordinator resumes the job with those tiles and renders
    // only the others; the image is the uninterrupted render's, bit for bit.
    let (journal, restored) = crate::state::Journal::open(Some(&db)).unwrap();
    assert_eq!(restored.next_job, 2);
    let saved = restored.jobs.into_iter().next().expect("the job was journalled");
    assert_eq!(saved.tiles.len(), merged as usize);
    assert!(saved.ending.is_none());
    let attempts_before: u32 = saved.attempts.iter().map(|(_, n)| n).sum();
    assert!(attempts_before > merged, "tiles in flight were journalled as handed out");
    let mut s = Scheduler::new(SchedulerConfig::default());
    let mut out = Durable { rec: Recorder::default(), journal: journal.clone() };
    s.restore(saved, &mut out);
    s.set_next_job(restored.next_job);
    s.worker_joined(WorkerId(7), "b".into(), 1, 3, Instant::now(), &mut out);
    let mut handed = 0;
    let mut queue = out.rec.take();
    while let Some((w, a)) = queue.pop() {
        handed += 1;
        s.tile_done(w, a.key(), render(&g, a.tile), RayStats::default(), &mut out);
        queue.extend(out.rec.take());
    }
    assert_eq!(handed, total - merged, "only the missing tiles render again");
    let image = out.rec.image(JobId(1)).expect("finished after the restart");
    let bits = |i: &RgbImage| i.pixels.iter().flat_map(|p| p.map(f32::to_bits)).collect::<Vec<_>>();
    assert_eq!(bits(&image), bits(&reference));
    assert_eq!(s.snapshot(JobId(1)), Some(Snapshot::Stored), "the image is read from the journal");
    let (row, _) = s.status();
    assert_eq!(
        row[0].retries,
        attempts_before - merged,
        "each tile in flight at the end was retried"
    );
    // A new job gets a new id; the finished one's image is in the journal.
    assert_eq!(s.submit(spec(0), &mut out), JobId(2));
    let (reply, rx) = tokio::sync::oneshot::channel();
    journal.send(crate::state::Command::ReadImage { job: 1, reply });
    assert!(!rx.await.unwrap().is_empty());
    // Past its retention it is forgotten.
    assert!(s.expire(crate::state::unix_now(), Duration::from_secs(3600)).is_empty());
    assert_eq!(
        s.expire(crate::state::unix_now() + 3600, Duration::from_secs(3600)),
        vec![JobId(1)]
    );
    std::fs::remove_dir_all(dir).ok();
}

/// A 200×200 film: 169 tiles.
fn big() -> FilmGeometry {
    let res = Point2i::new(200, 200);
    let crop = Bounds2i::new(Point2i::new(0, 0), res);
    FilmGeometry::new(res, crop, Vec2::splat(2.0), 1.0, f32::INFINITY, "x.exr".into(), 35.0)
}

#[test]
fn workers_hold_few_tiles_of_a_job_whose_tiles_render_on_all_threads() {
    let now = Instant::now();
    let parallel = || JobSpec { geometry: big(), parallel_tiles: true, ..spec(0) };
    // Twenty workers asking for ten: 169 tiles are a little over eight a
    // worker, so each holds two (one rendering, one waiting).
    let mut s = Scheduler::new(SchedulerConfig::default());
    let mut out = Recorder::default();
    for w in 1..=20 {
        s.worker_joined(WorkerId(w), format!("w{w}"), 4, 10, now, &mut out);
    }
    let held = |s: &Scheduler, w: u64| s.workers[&WorkerId(w)].in_flight.len();
    s.submit(parallel(), &mut out);
    assert!((1..=20).all(|w| held(&s, w) == 2), "{:?}", (1..=20).map(|w| held(&s, w)));
    // A job whose tiles render one per thread gives each a tile for each of
    // its threads and two waiting.
    s.submit(spec(0), &mut out);
    assert!((1..=20).all(|w| held(&s, w) == 6), "{:?}", (1..=20).map(|w| held(&s, w)));

    // One worker asking for ten holds ten while a quarter of the tiles left
    // is more, then fewer: the last tile goes out to it holding none.
    let mut s = Scheduler::new(SchedulerConfig::default());
    let mut out = Recorder::default();
    s.worker_joined(WorkerId(1), "w".into(), 4, 10, now, &mut out);
    let job = s.submit(parallel(), &mut out);
    assert_eq!(held(&s, 1), 10);
    let mut queue = out.take();
    let mut most_at_the_end = 0;
    while !queue.is_empty() {
        let (w, a) = queue.remove(0);
        s.tile_done(w, a.key(), render(&big(), a.tile), RayStats::default(), &mut out);
        queue.extend(out.take());
        if s.jobs[&job].pending.is_empty() {
            most_at_the_end = most_at_the_end.max(held(&s, 1));
        }
    }
    assert_eq!(s.job_state(job), Some(&JobState::Done));
    assert_eq!(most_at_the_end, 1);
}
