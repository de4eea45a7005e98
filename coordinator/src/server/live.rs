//! The event loop's side of watching a render as it goes: previews for
//! live `WatchJob` streams each tick, and a dashboard page's look at a job.

use super::outbox::GrpcOutbox;
use crate::live::shift;
use crate::scheduler::{FinishedJob, JobUpdate, Scheduler, Snapshot};
use farm_common::ids::JobId;
use farm_proto::convert::preview_region;
use farm_proto::v1::{self, job_event};
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
    /// Done, with the image in memory.
    Done(std::sync::Arc<FinishedJob>),
    /// Done, with the image in the journal.
    Stored,
    /// Failed or cancelled: there is no image.
    Ended,
    /// No such job.
    NoJob,
}

/// What a dashboard page at cursor `from` is shown of `job`.
pub(super) fn live_answer(sched: &mut Scheduler, job: JobId, from: usize) -> LiveAnswer {
    if let Some(film) = sched.film_mut(job) {
        // The error map is the running estimate's, brought up to date.
        film.running_estimate();
        return LiveAnswer::Running(crate::web::live::running(film, from));
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
pub(super) fn send_live(sched: &Scheduler, out: &mut GrpcOutbox) {
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
            let regions = cursor.take(film, PIXELS_PER_EVENT);
            if regions.is_empty() {
                return true;
            }
            let regions = regions
                .into_iter()
                .map(|r| preview_region(r, film.region_sums(shift(r, b.min.x, b.min.y))))
                .collect();
            let (width, height) = (b.width() as u32, b.height() as u32);
            let preview = v1::JobPreview { width, height, scale: film.geometry().scale, regions };
            let ev = v1::JobEvent { kind: Some(job_event::Kind::Preview(preview)) };
            !matches!(tx.try_send(Ok(ev)), Err(mpsc::error::TrySendError::Closed(_)))
        });
        !list.is_empty()
    });
}
