//! Talking to a coordinator: `farm submit --coordinator`, `farm status`,
//! `farm cancel` and `farm health`.

use crate::embedded::RenderSummary;
use crate::error::Error;
use farm_common::film::FilmGeometry;
use farm_common::stats::RayStats;
use farm_coordinator::estimate::ErrorEstimate;
use farm_proto::auth::Token;
use farm_proto::connect::Client;
use farm_proto::convert::{blob_chunks, encode_scene, Blob, ImageAssembler};
use farm_proto::v1::{self, job_event};
use farm_proto::PROTOCOL_VERSION;
use farm_render::features::Features;
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
#[derive(Clone, Debug, Default)]
pub struct RemoteOptions {
    /// Output file (overrides the scene's).
    pub output: Option<PathBuf>,
    /// Samples per pixel override.
    pub spp: Option<u32>,
    /// Job priority (higher first).
    pub priority: i32,
    /// Upload files outside the scene's folder too.
    pub allow_assets_outside: bool,
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

/// Parses `scene` here, uploads it, renders it on the farm and returns the
/// image (not yet written).
pub async fn submit(
    remote: &Remote,
    scene: &Path,
    opts: &RemoteOptions,
    mut progress: impl FnMut(u64, &RemoteProgress),
) -> Result<RenderSummary, Error> {
    let start = Instant::now();
    let (desc, warnings) = farm_scene::parse_file(scene)?;
    let outside: Vec<String> =
        desc.assets.keys().filter(|k| farm_scene::is_outside(k)).cloned().collect();
    if !outside.is_empty() && !opts.allow_assets_outside {
        let folder = scene.parent().filter(|p| !p.as_os_str().is_empty()).unwrap_or(Path::new("."));
        return Err(Error::AssetsOutside { folder: folder.display().to_string(), paths: outside });
    }
    let (film, _) = FilmGeometry::from_description(&desc);
    let (manifest, assets) = encode_scene(&desc).map_err(|e| Error::Protocol(e.to_string()))?;
    let mut client = connect(remote).await?;
    for blob in assets.iter().chain(std::iter::once(&manifest)) {
        upload(&mut client, blob).await?;
    }
    let job = client
        .submit_job(v1::SubmitJobRequest {
            protocol_version: PROTOCOL_VERSION,
            scene_hash: manifest.hash.to_vec(),
            spp: opts.spp.unwrap_or(0),
            priority: opts.priority,
            name: scene.file_name().map(|n| n.to_string_lossy().into_owned()).unwrap_or_default(),
        })
        .await?
        .into_inner()
        .job_id;
    let startup_seconds = start.elapsed().as_secs_f64();
    let mut events = client.watch_job(v1::WatchJobRequest { job_id: job }).await?.into_inner();
    let mut assembler = ImageAssembler::default();
    while let Some(ev) = events.message().await? {
        match ev.kind {
            Some(job_event::Kind::Progress(p)) => progress(
                job,
                &RemoteProgress {
                    tiles_done: p.tiles_done,
                    tiles_total: p.tiles_total,
                    workers: p.workers_active,
                    stats: p.stats.as_ref().map(RayStats::from).unwrap_or_default(),
                },
            ),
            Some(job_event::Kind::Image(img)) => {
                let Some(done) = assembler.add(&img).map_err(|e| Error::Protocol(e.to_string()))?
                else {
                    continue;
                };
                let (w, h) = (done.image.width, done.image.height);
                let error = done.error.map(|(per_pixel, rel_mse)| ErrorEstimate {
                    width: w,
                    height: h,
                    per_pixel,
                    rel_mse,
                });
                return Ok(RenderSummary {
                    image: done.image,
                    error,
                    output: opts.output.clone().unwrap_or_else(|| PathBuf::from(&film.filename)),
                    stats: done.facts.stats,
                    spp: done.facts.spp,
                    startup_seconds,
                    render_seconds: done.facts.render_seconds,
                    features: Features::of(&desc),
                    scene_name: desc.name,
                    warnings,
                });
            }
            Some(job_event::Kind::Failed(f)) => return Err(Error::JobFailed(f.message)),
            None => {}
        }
    }
    Err(Error::Protocol("the job's event stream ended without an image".into()))
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
