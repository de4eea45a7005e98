//! Talking to a coordinator: `farm submit --coordinator`, `farm status`,
//! `farm cancel` and `farm health`.

use crate::display::LiveDisplay;
use crate::embedded::RenderSummary;
use crate::error::Error;
use farm_common::film::{FilmGeometry, SamplerKind};
use farm_common::scene::{SceneDescription, Warning};
use farm_common::stats::RayStats;
use farm_proto::auth::Token;
use farm_proto::connect::Client;
use farm_proto::convert::{blob_chunks, encode_scene, Blob};
use farm_proto::v1;
use farm_proto::PROTOCOL_VERSION;
use farm_render::features::Features;
use std::collections::HashSet;
use std::path::{Path, PathBuf};
use std::time::Instant;

mod follow;
pub use follow::{follow, follow_live, JobImage};

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
