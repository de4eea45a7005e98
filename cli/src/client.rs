//! Talking to a coordinator: `farm submit --coordinator`, `farm status`,
//! `farm cancel` and `farm health`.

use crate::display::LiveDisplay;
use crate::embedded::RenderSummary;
use crate::error::Error;
use farm_common::film::{FilmGeometry, PassEnd, PassStop, SamplerKind};
use farm_common::scene::{SceneDescription, Warning};
use farm_common::stats::RayStats;
use farm_coordinator::estimate::{ErrorEstimate, Fireflies};
use farm_proto::auth::Token;
use farm_proto::connect::Client;
use farm_proto::convert::{blob_chunks, decode_preview, encode_scene, Blob, ImageAssembler};
use farm_proto::v1::{self, job_event};
use farm_proto::PROTOCOL_VERSION;
use farm_render::features::Features;
use std::collections::HashSet;
use std::path::{Path, PathBuf};
use std::time::Instant;

/// A coordinator and the token to present to it.
#[derive(Clone, Debug, Default)]
pub struct Remote {
    /// Its URL: `https://HOST:PORT`, or `http://` for an insecure one.
    pub url: String,
    /// The token (required with https://).
    pub token: Option<Token>,
}

impl Remote {
    /// A coordinator reached without a token (an insecure one, on loopback).
    pub fn insecure(url: &str) -> Remote {
        Remote { url: url.to_string(), token: None }
    }
}

/// Connects to a coordinator.
pub async fn connect(remote: &Remote) -> Result<Client, Error> {
    Ok(farm_proto::connect::connect(&remote.url, remote.token.as_ref()).await?)
}

/// Uploads one blob in chunks.
pub async fn upload(client: &mut Client, blob: &Blob) -> Result<(), Error> {
    let parts = blob_chunks(&blob.hash, &blob.data);
    client.upload_blob(tokio_stream::iter(parts)).await?;
    Ok(())
}

/// Options of a remote render.
#[derive(Clone, Debug)]
pub struct RemoteOptions {
    /// Output file (overrides the scene's).
    pub output: Option<PathBuf>,
    /// Samples per pixel override.
    pub spp: Option<u32>,
    /// Job priority (higher first).
    pub priority: i32,
    /// Upload files outside the scene's folder too.
    pub allow_assets_outside: bool,
    /// Keep the job running with no client watching it.
    pub detach: bool,
    /// How long to keep reconnecting to a coordinator that went away.
    pub reconnect_for: std::time::Duration,
    /// What the command line changes in the scene (`--cropwindow`, `--quick`).
    pub overrides: farm_scene::Overrides,
    /// A display server (tev) to stream the image to as it renders.
    pub display_server: Option<String>,
    /// Print nothing but errors (a display server that cannot be reached).
    pub quiet: bool,
    /// Render in passes and stop at this estimated relMSE (`--target-error`).
    pub target_error: Option<f64>,
    /// Render in passes and stop after the pass that ends past this many
    /// seconds (`--time-limit`).
    pub time_limit: Option<f64>,
}

impl Default for RemoteOptions {
    fn default() -> Self {
        RemoteOptions {
            output: None,
            spp: None,
            priority: 0,
            allow_assets_outside: false,
            detach: false,
            reconnect_for: std::time::Duration::from_secs(600),
            overrides: farm_scene::Overrides::default(),
            display_server: None,
            quiet: false,
            target_error: None,
            time_limit: None,
        }
    }
}

/// Progress of a remote job.
#[derive(Clone, Copy, Debug, Default)]
pub struct RemoteProgress {
    /// Tiles in.
    pub tiles_done: u32,
    /// All tiles.
    pub tiles_total: u32,
    /// Workers holding tiles.
    pub workers: u32,
    /// Rays so far.
    pub stats: RayStats,
}

/// A job submitted, not yet finished.
pub struct Submitted {
    /// Its id.
    pub job: u64,
    /// The connection it was submitted on.
    pub client: Client,
    /// The scene as parsed here.
    pub desc: farm_common::scene::SceneDescription,
    /// The parser's warnings.
    pub warnings: Vec<farm_common::scene::Warning>,
    /// Seconds from the start to the job's id.
    pub startup_seconds: f64,
}

/// Parses `scene` here, uploads it and submits the job.
pub async fn start(
    remote: &Remote,
    scene: &Path,
    opts: &RemoteOptions,
) -> Result<Submitted, Error> {
    let start = Instant::now();
    let (desc, warnings) = farm_scene::parse_file(scene)?;
    start_parsed(remote, scene, desc, warnings, start, opts).await
}

/// Uploads a scene parsed from `scene` (its first file) and submits the
/// job, as [`start`] does.
pub async fn start_parsed(
    remote: &Remote,
    scene: &Path,
    mut desc: SceneDescription,
    mut warnings: Vec<Warning>,
    start: Instant,
    opts: &RemoteOptions,
) -> Result<Submitted, Error> {
    let (manifest, assets) = prepare_scene(&mut desc, &mut warnings, scene, opts)?;
    let mut client = connect(remote).await?;
    upload_new(&mut client, &manifest, &assets, &mut HashSet::new()).await?;
    let request = submit_request(&manifest, crate::shot::file_name(scene), opts, None);
    let job = client
        .submit_job(v1::SubmitJobRequest { detach: opts.detach, ..request })
        .await?
        .into_inner()
        .job_id;
    Ok(Submitted { job, client, desc, warnings, startup_seconds: start.elapsed().as_secs_f64() })
}

/// A scene parsed from `scene` (its first file) made ready to send: the
/// command line's overrides applied, its assets checked against the
/// folder they may come from, and encoded as a manifest and blobs.
pub fn prepare_scene(
    desc: &mut SceneDescription,
    warnings: &mut Vec<Warning>,
    scene: &Path,
    opts: &RemoteOptions,
) -> Result<(Blob, Vec<Blob>), Error> {
    opts.overrides.apply(desc, warnings);
    check_outside(desc, scene, opts.allow_assets_outside)?;
    encode_scene(desc).map_err(|e| Error::Protocol(e.to_string()))
}

/// What [`upload_new`] sent.
#[derive(Clone, Copy, Debug, Default)]
pub struct Uploaded {
    /// Bytes uploaded.
    pub bytes: u64,
    /// Blobs skipped, already sent.
    pub reused: usize,
}

/// Uploads a scene's blobs and then its manifest, skipping those whose
/// hash is in `sent`. A blob joins `sent` only once it is uploaded, so
/// after a failed upload the next scene that needs it tries again.
pub async fn upload_new(
    client: &mut Client,
    manifest: &Blob,
    assets: &[Blob],
    sent: &mut HashSet<[u8; 32]>,
) -> Result<Uploaded, Error> {
    let mut done = Uploaded::default();
    for blob in assets.iter().chain(std::iter::once(manifest)) {
        if sent.contains(&blob.hash) {
            done.reused += 1;
            continue;
        }
        upload(client, blob).await?;
        sent.insert(blob.hash);
        done.bytes += blob.data.len() as u64;
    }
    Ok(done)
}

/// The request that submits the scene whose manifest is `manifest` as a
/// job called `name` (not detached), a frame of `shot` if given.
pub fn submit_request(
    manifest: &Blob,
    name: String,
    opts: &RemoteOptions,
    shot: Option<v1::ShotFrame>,
) -> v1::SubmitJobRequest {
    v1::SubmitJobRequest {
        protocol_version: PROTOCOL_VERSION,
        scene_hash: manifest.hash.to_vec(),
        spp: opts.spp.unwrap_or(0),
        priority: opts.priority,
        name,
        detach: false,
        shot,
        target_error: opts.target_error,
        time_limit: opts.time_limit,
    }
}

/// Refuses a scene read from `scene` that names files outside its folder,
/// unless they may be sent.
pub fn check_outside(desc: &SceneDescription, scene: &Path, allowed: bool) -> Result<(), Error> {
    let outside: Vec<String> =
        desc.assets.keys().filter(|k| farm_scene::is_outside(k)).cloned().collect();
    if !outside.is_empty() && !allowed {
        let folder = scene.parent().filter(|p| !p.as_os_str().is_empty()).unwrap_or(Path::new("."));
        return Err(Error::AssetsOutside { folder: folder.display().to_string(), paths: outside });
    }
    Ok(())
}

/// Parses `scene` here, uploads it, renders it on the farm and returns the
/// image (not yet written).
pub async fn submit(
    remote: &Remote,
    scene: &Path,
    opts: &RemoteOptions,
    progress: impl FnMut(u64, &RemoteProgress),
) -> Result<RenderSummary, Error> {
    let start = Instant::now();
    let (desc, warnings) = farm_scene::parse_file(scene)?;
    submit_parsed(remote, scene, desc, warnings, start, opts, progress).await
}

/// Submits a parsed scene and follows it to its image, as [`submit`] does.
pub async fn submit_parsed(
    remote: &Remote,
    scene: &Path,
    desc: SceneDescription,
    warnings: Vec<Warning>,
    start: Instant,
    opts: &RemoteOptions,
    mut progress: impl FnMut(u64, &RemoteProgress),
) -> Result<RenderSummary, Error> {
    let Submitted { job, client, desc, warnings, startup_seconds } =
        start_parsed(remote, scene, desc, warnings, start, opts).await?;
    let (film, _) = FilmGeometry::from_description(&desc);
    let mut display =
        opts.display_server.as_deref().map(|a| LiveDisplay::new(a, &desc.name, opts.quiet));
    let done = follow_live(
        remote,
        job,
        Some(client),
        opts.reconnect_for,
        |p| progress(job, p),
        display.as_mut(),
    )
    .await?;
    Ok(RenderSummary {
        image: done.image,
        error: done.error,
        output: opts.output.clone().unwrap_or_else(|| PathBuf::from(&film.filename)),
        stats: done.stats,
        spp: done.spp,
        startup_seconds,
        render_seconds: done.render_seconds,
        features: Features::of(&desc),
        scene_name: desc.name,
        warnings,
        passes: done.passes,
        stopped: done.stopped,
        sampler: Some(SamplerKind::of(&desc.sampler.name)),
    })
}

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

/// Jobs and workers.
pub async fn status(remote: &Remote) -> Result<v1::GetStatusResponse, Error> {
    Ok(connect(remote).await?.get_status(v1::GetStatusRequest {}).await?.into_inner())
}

/// Cancels a job; whether it was still running.
pub async fn cancel(remote: &Remote, job: u64) -> Result<bool, Error> {
    Ok(connect(remote)
        .await?
        .cancel_job(v1::CancelJobRequest { job_id: job })
        .await?
        .into_inner()
        .cancelled)
}

/// Whether the gRPC health service at `url` reports SERVING.
pub async fn healthy(remote: &Remote) -> Result<bool, Error> {
    let (channel, _) = farm_proto::connect::channel(&remote.url, remote.token.as_ref()).await?;
    let mut client = tonic_health::pb::health_client::HealthClient::new(channel);
    let r = client
        .check(tonic_health::pb::HealthCheckRequest { service: String::new() })
        .await?
        .into_inner();
    Ok(r.status == tonic_health::pb::health_check_response::ServingStatus::Serving as i32)
}
