//! The event loop's side of watching a render as it goes: previews for
//! live `WatchJob` streams each tick, and a dashboard page's look at a job.

use super::outbox::GrpcOutbox;
use super::{LIVE_AT_MOST_EVERY, LIVE_BATCH_PIXELS, LIVE_EVERY};
use crate::live::shift;
use crate::scheduler::{FinishedJob, JobUpdate, Scheduler, Snapshot};
use farm_common::film::FilmGeometry;
use farm_common::geometry::Bounds2i;
use farm_common::ids::JobId;
use farm_proto::convert::push_piece;
use farm_proto::v1::{self, job_event};
use std::collections::{HashMap, VecDeque};
use std::sync::Arc;
use std::time::{Duration, Instant};
use tokio::sync::mpsc;

/// Pixels in one preview event (16 bytes each): about 4 MiB, well under
/// the message limit.
const PIXELS_PER_EVENT: usize = 1 << 18;

/// What a dashboard page is shown of a job's image.
#[derive(Debug)]
pub enum LiveAnswer {
    /// Running: the page's answer ([`crate::web::live`]'s format), with
    /// the pieces changed since its cursor.
    Running(Vec<u8>),
    /// Done, with the image in memory, and the film's layout when a page
    /// was looking as it ended (so it can be sent only what it lacks).
    Done(Arc<FinishedJob>, Option<FilmGeometry>),
    /// Done, with the image in the journal.
    Stored,
    /// Failed or cancelled: there is no image.
    Ended,
    /// No such job.
    NoJob,
}

/// How long after a page last looked at a running job its finished image
/// is kept in memory for it: twice the longest a page waits between looks
/// (five seconds, `nextLook` in `dashboard.js`), so that a page still
/// open, whose look takes time of its own, is not answered from the
/// journal (a read of the whole image on the journal's thread).
const PAGE_LOOKS_EVERY: Duration = Duration::from_secs(10);
/// How long a finished image is kept for the pages that were open.
const KEEP_FOR: Duration = Duration::from_secs(30);
/// At most this many bytes of finished images are kept.
const KEEP_BYTES: usize = 128 << 20;

/// Finished images kept in memory for a short while for the dashboard
/// pages that were open when their job ended: each such page asks once for
/// the finished image, and would otherwise have it read back from the
/// journal. Only jobs a page looked at lately are kept, for seconds, and
/// within a byte budget.
#[derive(Default)]
pub(super) struct RecentImages {
    /// When a page last looked at each running job, and its film's layout.
    looked: HashMap<JobId, (Instant, FilmGeometry)>,
    kept: VecDeque<(JobId, Instant, Arc<FinishedJob>, FilmGeometry)>,
}

fn size(f: &FinishedJob) -> usize {
    f.image.pixels.len() * 12 + f.error.as_ref().map_or(0, |e| e.per_pixel.len() * 4)
}

impl RecentImages {
    /// A page looked at running `job`.
    pub(super) fn looked(&mut self, job: JobId, geometry: &FilmGeometry, now: Instant) {
        self.looked.entry(job).and_modify(|l| l.0 = now).or_insert_with(|| (now, geometry.clone()));
    }

    /// `job` finished: keep its image if a page looked at it lately.
    pub(super) fn finished(&mut self, job: JobId, f: &Arc<FinishedJob>, now: Instant) {
        let Some((at, geometry)) = self.looked.remove(&job) else { return };
        if now.duration_since(at) > PAGE_LOOKS_EVERY || size(f) > KEEP_BYTES {
            return;
        }
        self.kept.push_back((job, now, f.clone(), geometry));
        while self.kept.iter().map(|(_, _, f, _)| size(f)).sum::<usize>() > KEEP_BYTES {
            self.kept.pop_front();
        }
    }

    /// A kept image of `job`, and its film's layout.
    fn get(&self, job: JobId) -> Option<(Arc<FinishedJob>, FilmGeometry)> {
        self.kept.iter().find(|k| k.0 == job).map(|(_, _, f, g)| (f.clone(), g.clone()))
    }

    /// Forgets what is past its time, and pages of jobs that ended otherwise.
    pub(super) fn expire(&mut self, now: Instant) {
        self.kept.retain(|(_, at, _, _)| now.duration_since(*at) <= KEEP_FOR);
        self.looked.retain(|_, (at, _)| now.duration_since(*at) <= PAGE_LOOKS_EVERY);
    }
}

/// What a dashboard page is shown of `job`, at cursor `from` into the
/// film's changes with `merged` tiles' error map drawn.
pub(super) fn live_answer(
    sched: &mut Scheduler,
    recent: &mut RecentImages,
    job: JobId,
    (from, merged): (usize, u32),
    now: Instant,
) -> LiveAnswer {
    if let Some(film) = sched.film_mut(job) {
        recent.looked(job, film.geometry(), now);
        // The error map is the running estimate's, brought up to date.
        film.running_estimate();
        return LiveAnswer::Running(crate::web::live::running(
            film,
            from,
            merged,
            crate::web::live::ANSWER_PIXELS,
        ));
    }
    if let Some(g) = sched.film_lent(job) {
        // Nothing new until the film is back: look again.
        return LiveAnswer::Running(crate::web::live::unchanged(g, from, merged));
    }
    match sched.snapshot(job) {
        None => LiveAnswer::NoJob,
        Some(Snapshot::Stored) => match recent.get(job) {
            Some((f, g)) => LiveAnswer::Done(f, Some(g)),
            None => LiveAnswer::Stored,
        },
        Some(Snapshot::Update(JobUpdate::Finished(f))) => {
            LiveAnswer::Done(f, recent.get(job).map(|(_, g)| g))
        }
        Some(Snapshot::Update(_)) => LiveAnswer::Ended,
    }
}

/// When [`send_live`] is called.
#[derive(Clone, Copy, PartialEq, Eq, Debug)]
pub(super) enum Pace {
    /// Right after the jobs in `GrpcOutbox::progressed` were sent a
    /// progress event: a preview sent now goes down the same stream in the
    /// same write, so its reader wakes once for both.
    WithProgress,
    /// The tick (every [`LIVE_EVERY`]), for what waits when no progress comes.
    Tick,
}

/// Sends each live watcher the pieces that changed since it last took
/// some, if it has room for them: one event at a time at most, so a reader
/// that falls behind is sent larger catch-ups, never a queue. Beside a
/// progress event, at most once every [`LIVE_EVERY`] and once
/// [`LIVE_BATCH_PIXELS`] wait or [`LIVE_AT_MOST_EVERY`] has passed; at a
/// tick, only what has waited [`LIVE_AT_MOST_EVERY`].
pub(super) fn send_live(sched: &Scheduler, out: &mut GrpcOutbox, now: Instant, pace: Pace) {
    let progressed = std::mem::take(&mut out.progressed);
    out.live.retain(|job, list| {
        // A film lent out comes back: its watchers wait for it.
        let Some(film) = sched.film(*job) else { return sched.film_lent(*job).is_some() };
        if pace == Pace::WithProgress && !progressed.contains(job) {
            return true;
        }
        let b = film.geometry().cropped_pixel_bounds;
        list.retain_mut(|(tx, cursor, sent)| {
            if tx.is_closed() {
                return false;
            }
            if tx.capacity() == 0 {
                return true;
            }
            // A small film's batch is a quarter of it.
            let batch = LIVE_BATCH_PIXELS.min(b.area() / 4).max(1);
            let since = now.duration_since(*sent);
            let due = match pace {
                Pace::WithProgress => {
                    since >= LIVE_EVERY
                        && (cursor.waiting(film) >= batch || since >= LIVE_AT_MOST_EVERY)
                }
                Pace::Tick => since >= LIVE_AT_MOST_EVERY,
            };
            if !due {
                return true;
            }
            // tev is shown the error map of the finished image only.
            let regions = cursor.take(film, PIXELS_PER_EVENT);
            if regions.is_empty() {
                return true;
            }
            let (width, height) = (b.width() as u32, b.height() as u32);
            let pixels: usize = regions.iter().map(Bounds2i::area).sum();
            let mut preview = v1::JobPreview {
                width,
                height,
                scale: film.geometry().scale,
                bounds: Vec::with_capacity(regions.len() * 4),
                sums: Vec::with_capacity(pixels * 16),
            };
            for r in regions {
                push_piece(&mut preview, r, |out| {
                    film.write_region_sums(shift(r, b.min.x, b.min.y), out)
                });
            }
            let ev = v1::JobEvent { kind: Some(job_event::Kind::Preview(preview)) };
            *sent = now;
            !matches!(tx.try_send(Ok(ev)), Err(mpsc::error::TrySendError::Closed(_)))
        });
        !list.is_empty()
    });
}

#[cfg(test)]
mod tests {
    use super::*;
    use farm_common::image::RgbImage;

    fn finished(pixels: usize) -> Arc<FinishedJob> {
        Arc::new(FinishedJob {
            name: String::new(),
            image: RgbImage { width: pixels, height: 1, pixels: vec![[0.5; 3]; pixels] },
            error: None,
            spp: 1,
            render_seconds: 1.0,
            stats: Default::default(),
            passes: Vec::new(),
            stopped: None,
        })
    }

    /// While a job's film is ended off the loop, its live watchers and
    /// pages wait for it; once it is done they are let go.
    #[tokio::test]
    async fn watchers_wait_for_a_film_lent_off_the_loop() {
        use crate::live::LiveCursor;
        use crate::scheduler::tests::{render, spec};
        use crate::scheduler::{JobSpec, SchedulerConfig};
        use crate::server::outbox::OffLoop;
        use farm_common::geometry::{Bounds2i, Point2i, Vec2};
        use farm_common::ids::{TileAttempt, WorkerId};
        let b = Bounds2i::new(Point2i::new(0, 0), Point2i::new(40, 20));
        let g = FilmGeometry::new(b.max, b, Vec2::splat(0.5), 1.0, f32::INFINITY, "x".into(), 35.0);
        let spec = JobSpec { spp: 2, geometry: g.clone(), ..spec(0) };
        let (off_tx, mut off_rx) = mpsc::unbounded_channel();
        let mut out = GrpcOutbox { off_loop: Some(off_tx), ..Default::default() };
        let (worker_tx, mut to_worker) = mpsc::unbounded_channel();
        out.workers.insert(WorkerId(1), worker_tx);
        let mut sched = Scheduler::new(SchedulerConfig::default());
        let now = Instant::now();
        sched.worker_joined(WorkerId(1), "w".into(), 1, 64, now, &mut out);
        let job = sched.submit(spec, &mut out);
        let (live_tx, _live_rx) = mpsc::channel(4);
        out.live.entry(job).or_default().push((live_tx, LiveCursor::new(), now));
        while let Ok(Ok(msg)) = to_worker.try_recv() {
            let Some(v1::coordinator_message::Kind::Assign(a)) = msg.kind else { continue };
            let tile = farm_common::ids::TileId(a.tile);
            let key = TileAttempt { job, tile, attempt: a.attempt };
            sched.tile_done(WorkerId(1), key, render(&g, tile), Default::default(), &mut out);
        }
        assert!(sched.film_lent(job).is_some(), "every tile is in: the film is being ended");
        send_live(&sched, &mut out, now, Pace::Tick);
        assert!(out.live.contains_key(&job), "its live watchers wait");
        let mut recent = RecentImages::default();
        let answer = live_answer(&mut sched, &mut recent, job, (0, 0), now);
        assert!(matches!(answer, LiveAnswer::Running(_)), "a page is told to look again");
        let row = sched.view(job, now, |_| Some(0.25)).expect("the job");
        assert_eq!(row.rel_mse, Some(0.25), "its row keeps the estimate it showed");
        let Some(OffLoop::Ended(j, ended)) = off_rx.recv().await else { panic!("no film back") };
        sched.film_ended(j, ended, &mut out);
        send_live(&sched, &mut out, now, Pace::Tick);
        assert!(!out.live.contains_key(&job), "the job is done: no more previews");
        let answer = live_answer(&mut sched, &mut recent, job, (0, 0), now);
        assert!(matches!(answer, LiveAnswer::Done(..)));
    }

    #[test]
    fn finished_images_are_kept_briefly_for_pages_that_were_looking() {
        let t0 = Instant::now();
        let (at, b) = (farm_common::geometry::Point2i::new(4, 1), Default::default());
        let r2 = farm_common::geometry::Vec2::splat(0.5);
        let g = FilmGeometry::new(at, b, r2, 1.0, f32::INFINITY, "x.exr".into(), 35.0);
        let mut r = RecentImages::default();
        // Nobody looked at job 1; a page looked at job 2 just before it ended.
        r.finished(JobId(1), &finished(4), t0);
        r.looked(JobId(2), &g, t0);
        r.finished(JobId(2), &finished(4), t0 + Duration::from_secs(1));
        assert!(r.get(JobId(1)).is_none(), "no page was open");
        assert!(r.get(JobId(2)).is_some());
        // A page that stopped looking long before the end.
        r.looked(JobId(3), &g, t0);
        r.finished(JobId(3), &finished(4), t0 + PAGE_LOOKS_EVERY + Duration::from_secs(1));
        assert!(r.get(JobId(3)).is_none());
        // Kept for a while only.
        r.expire(t0 + KEEP_FOR);
        assert!(r.get(JobId(2)).is_some());
        r.expire(t0 + KEEP_FOR + Duration::from_secs(2));
        assert!(r.get(JobId(2)).is_none());
        // Within the byte budget: the oldest go first, and a huge image is not kept.
        let big = KEEP_BYTES / 12 / 2;
        for j in 4..7 {
            r.looked(JobId(j), &g, t0);
            r.finished(JobId(j), &finished(big), t0);
        }
        assert!(
            r.get(JobId(4)).is_none() && r.get(JobId(5)).is_some() && r.get(JobId(6)).is_some()
        );
        r.looked(JobId(7), &g, t0);
        r.finished(JobId(7), &finished(KEEP_BYTES / 12 + 1), t0);
        assert!(r.get(JobId(7)).is_none());
    }
}
