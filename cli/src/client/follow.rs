//! Following a job on a coordinator to its image: the WatchJob stream,
//! reconnecting when the coordinator goes away and waiting when the
//! token has every watch slot taken.

use super::{connect, Remote, RemoteProgress};
use crate::display::LiveDisplay;
use crate::error::Error;
use farm_common::film::{PassEnd, PassStop};
use farm_common::stats::RayStats;
use farm_coordinator::estimate::{ErrorEstimate, Fireflies};
use farm_proto::connect::Client;
use farm_proto::convert::{decode_preview, ImageAssembler};
use farm_proto::v1::{self, job_event};
use std::time::Instant;

/// A finished job's image as the coordinator sent it.
#[derive(Clone, Debug)]
pub struct JobImage {
    /// The job's name as submitted (empty from an older coordinator).
    pub name: String,
    /// The image.
    pub image: farm_common::image::RgbImage,
    /// The render's estimate of its own error.
    pub error: Option<ErrorEstimate>,
    /// Samples per pixel.
    pub spp: u32,
    /// Seconds the farm rendered.
    pub render_seconds: f64,
    /// Rays traced.
    pub stats: RayStats,
    /// A render in passes: what each pass left.
    pub passes: Vec<PassEnd>,
    /// Why a render in passes stopped.
    pub stopped: Option<PassStop>,
}

/// Whether a failed call may succeed against the coordinator later: it
/// restarted, or the network between us failed. A refusal (no such job,
/// not yours, a bad token) is final.
fn transient(e: &Error) -> bool {
    use tonic::Code;
    match e {
        Error::Rpc(s) => matches!(s.code(), Code::Unavailable | Code::Unknown | Code::Cancelled),
        Error::Connect(farm_proto::connect::ConnectError::Failed { .. }) => true,
        _ => false,
    }
}

/// Follows `job` to its image, reconnecting with backoff whenever the
/// coordinator goes away (it restarts, or the network fails) for up to
/// `reconnect_for` without hearing from it. While the coordinator refuses
/// the watch because the token has every slot taken, it waits, for as
/// long as that lasts (the job renders meanwhile).
pub async fn follow(
    remote: &Remote,
    job: u64,
    client: Option<Client>,
    reconnect_for: std::time::Duration,
    progress: impl FnMut(&RemoteProgress),
) -> Result<JobImage, Error> {
    follow_live(remote, job, client, reconnect_for, progress, None).await
}

/// [`follow`], streaming the image to `display` as it renders and when
/// it is done.
pub async fn follow_live(
    remote: &Remote,
    job: u64,
    mut client: Option<Client>,
    reconnect_for: std::time::Duration,
    mut progress: impl FnMut(&RemoteProgress),
    mut display: Option<&mut LiveDisplay>,
) -> Result<JobImage, Error> {
    let mut backoff = std::time::Duration::from_millis(100);
    let mut last_heard = Instant::now();
    let mut waiting = false;
    loop {
        let attempt = async {
            let mut c = match client.take() {
                Some(c) => c,
                None => connect(remote).await?,
            };
            let r = watch_once(&mut c, job, &mut progress, &mut last_heard, display.as_deref_mut())
                .await;
            // Kept for the next watch when its slot was refused.
            Ok::<_, Error>((r, c))
        };
        let (result, c) = match attempt.await {
            Ok((r, c)) => (r, Some(c)),
            Err(e) => (Err(e), None),
        };
        match result {
            Ok(image) => {
                if let Some(d) = display.as_deref_mut() {
                    d.finish(&image.image, image.error.as_ref().map(|e| e.per_pixel.as_slice()));
                }
                return Ok(image);
            }
            Err(e) if no_watch_slot(&e) => {
                // The coordinator answered, and keeps the job for a client
                // that waits for a slot; the job renders meanwhile.
                if !waiting {
                    tracing::warn!(job, error = %e, "waiting for a watch slot");
                    waiting = true;
                }
                last_heard = Instant::now();
                client = c;
                tokio::time::sleep(WATCH_SLOT_WAIT).await;
            }
            Err(e) if transient(&e) && last_heard.elapsed() < reconnect_for => {
                tracing::warn!(job, error = %e, "lost the coordinator; reconnecting");
                waiting = false;
                tokio::time::sleep(backoff).await;
                backoff = (backoff * 2).min(std::time::Duration::from_secs(5));
            }
            Err(e) => return Err(e),
        }
    }
}

/// How long a client refused a watch slot waits before it asks again:
/// well inside the coordinator's grace for a job's client
/// (`--client-grace`, default 120 s), which each refusal starts again; a
/// grace not much longer than this can still cancel a waiting client's job.
const WATCH_SLOT_WAIT: std::time::Duration = std::time::Duration::from_millis(500);

/// Whether `e` is the coordinator refusing to open a watch because the
/// token already has as many open as it may (`MAX_WATCHES_PER_TOKEN`):
/// another of its clients will close one, so this one waits rather than
/// fail, as when more frames or scenes are submitted at once than that.
fn no_watch_slot(e: &Error) -> bool {
    matches!(e, Error::NoWatchSlot(_))
}

/// One WatchJob stream, to the image, a failure, or a broken stream.
async fn watch_once(
    client: &mut Client,
    job: u64,
    progress: &mut impl FnMut(&RemoteProgress),
    last_heard: &mut Instant,
    mut display: Option<&mut LiveDisplay>,
) -> Result<JobImage, Error> {
    let live = display.is_some();
    let mut events = match client.watch_job(v1::WatchJobRequest { job_id: job, live }).await {
        Ok(events) => events.into_inner(),
        // Only the opening of the stream is refused for its slot.
        Err(s) if s.code() == tonic::Code::ResourceExhausted => return Err(Error::NoWatchSlot(s)),
        Err(s) => return Err(s.into()),
    };
    let mut assembler = ImageAssembler::default();
    while let Some(ev) = events.message().await? {
        *last_heard = Instant::now();
        match ev.kind {
            Some(job_event::Kind::Progress(p)) => progress(&RemoteProgress {
                tiles_done: p.tiles_done,
                tiles_total: p.tiles_total,
                workers: p.workers_active,
                stats: p.stats.as_ref().map(RayStats::from).unwrap_or_default(),
            }),
            Some(job_event::Kind::Image(img)) => {
                let Some(done) = assembler.add(&img).map_err(|e| Error::Protocol(e.to_string()))?
                else {
                    continue;
                };
                let (w, h) = (done.image.width, done.image.height);
                let fireflies = done.facts.fireflies.map(|f| Fireflies {
                    pixels: f.pixels as usize,
                    rel_mse: f.rel_mse,
                    brightest: f.brightest,
                });
                let error = done.error.map(|(per_pixel, rel_mse)| ErrorEstimate {
                    fireflies,
                    width: w,
                    height: h,
                    per_pixel,
                    rel_mse,
                });
                return Ok(JobImage {
                    name: done.facts.name,
                    image: done.image,
                    error,
                    spp: done.facts.spp,
                    render_seconds: done.facts.render_seconds,
                    stats: done.facts.stats,
                    passes: done.facts.passes,
                    stopped: done.facts.stopped,
                });
            }
            Some(job_event::Kind::Failed(f)) => return Err(Error::JobFailed(f.message)),
            Some(job_event::Kind::Preview(p)) => {
                let Some(d) = display.as_deref_mut() else { continue };
                // A preview is display only: one that does not fit is
                // dropped, and the render goes on.
                match decode_preview(&p, p.width, p.height) {
                    Ok(pieces) => d.pieces(p.width, p.height, &pieces),
                    Err(e) => tracing::warn!(job, error = %e, "preview ignored"),
                }
            }
            None => {}
        }
    }
    // The coordinator went away between events (a shutdown, a restart).
    Err(Error::Rpc(tonic::Status::unavailable("the job's event stream ended without an image")))
}
