//! Talking to a coordinator: `farm submit --coordinator`, `farm status`,
//! `farm cancel` and `farm health`.

use crate::embedded::RenderSummary;
use farm_common::film::FilmGeometry;
use farm_common::image::RgbImage;
use farm_common::stats::RayStats;
use farm_coordinator::estimate::ErrorEstimate;
use farm_proto::convert::{blob_chunks, encode_scene, Blob};
use farm_proto::v1::{self, coordinator_client::CoordinatorClient, job_event};
use farm_proto::{MAX_MESSAGE_SIZE, PROTOCOL_VERSION};
use farm_render::features::Features;
use std::path::{Path, PathBuf};
use std::time::Instant;
use tonic::transport::Channel;

/// Why talking to the coordinator failed.
#[derive(Debug, thiserror::Error)]
pub enum ClientError {
    /// The scene file is malformed.
    #[error(transparent)]
    Scene(#[from] farm_scene::SceneError),
    /// The address is not a valid URL or nothing answers there.
    #[error("cannot reach the coordinator at {url}: {source}")]
    Connect {
        /// The address.
        url: String,
        /// What failed.
        source: tonic::transport::Error,
    },
    /// The coordinator refused or failed a call.
    #[error("the coordinator says: {}", .0.message())]
    Rpc(#[from] tonic::Status),
    /// The job failed on the farm.
    #[error("the job failed: {0}")]
    JobFailed(String),
    /// The coordinator's answer made no sense.
    #[error("bad answer from the coordinator: {0}")]
    Protocol(String),
}

/// Connects to a coordinator.
pub async fn connect(url: &str) -> Result<CoordinatorClient<Channel>, ClientError> {
    let endpoint = Channel::from_shared(url.to_string())
        .map_err(|_| ClientError::Protocol(format!("{url} is not a valid URL")))?;
    let channel = endpoint
        .connect()
        .await
        .map_err(|source| ClientError::Connect { url: url.to_string(), source })?;
    Ok(CoordinatorClient::new(channel)
        .max_decoding_message_size(MAX_MESSAGE_SIZE)
        .max_encoding_message_size(MAX_MESSAGE_SIZE))
}

/// Uploads one blob in chunks.
pub async fn upload(
    client: &mut CoordinatorClient<Channel>,
    blob: &Blob,
) -> Result<(), ClientError> {
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
    url: &str,
    scene: &Path,
    opts: &RemoteOptions,
    mut progress: impl FnMut(u64, &RemoteProgress),
) -> Result<RenderSummary, ClientError> {
    let start = Instant::now();
    let (desc, warnings) = farm_scene::parse_file(scene)?;
    let (film, _) = FilmGeometry::from_description(&desc);
    let (manifest, assets) =
        encode_scene(&desc).map_err(|e| ClientError::Protocol(e.to_string()))?;
    let mut client = connect(url).await?;
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
                let Some((image, error)) = assembler.add(&img)? else { continue };
                return Ok(RenderSummary {
                    image,
                    error,
                    output: opts.output.clone().unwrap_or_else(|| PathBuf::from(&film.filename)),
                    stats: img.stats.as_ref().map(RayStats::from).unwrap_or_default(),
                    spp: img.spp,
                    startup_seconds,
                    render_seconds: img.render_seconds,
                    features: Features::of(&desc),
                    scene_name: desc.name,
                    warnings,
                });
            }
            Some(job_event::Kind::Failed(f)) => return Err(ClientError::JobFailed(f.message)),
            None => {}
        }
    }
    Err(ClientError::Protocol("the job's event stream ended without an image".into()))
}

/// Collects an image (and its error map) sent as chunks of rows.
#[derive(Default)]
struct ImageAssembler {
    image: Option<RgbImage>,
    error_map: Vec<f32>,
    rows: usize,
}

/// Little-endian f32s from bytes whose length is a multiple of 4.
fn f32s(bytes: &[u8]) -> impl Iterator<Item = f32> + '_ {
    bytes.chunks_exact(4).map(|b| f32::from_le_bytes([b[0], b[1], b[2], b[3]]))
}

impl ImageAssembler {
    /// Adds a chunk; returns the image and the error estimate once every row is in.
    fn add(
        &mut self,
        img: &v1::JobImage,
    ) -> Result<Option<(RgbImage, Option<ErrorEstimate>)>, ClientError> {
        let (w, h) = (img.width as usize, img.height as usize);
        let image = self.image.get_or_insert_with(|| RgbImage {
            width: w,
            height: h,
            pixels: vec![[0.0; 3]; w * h],
        });
        let row_bytes = w * 12;
        let rows = img.rgb.len().checked_div(row_bytes).unwrap_or(h);
        if image.width != w
            || image.height != h
            || img.first_row as usize != self.rows
            || (row_bytes > 0 && !img.rgb.len().is_multiple_of(row_bytes))
            || (img.estimated_rel_mse.is_some() && img.error_map.len() != rows * w * 4)
        {
            return Err(ClientError::Protocol(format!(
                "image chunk at row {} ({} bytes) does not fit a {w}×{h} image",
                img.first_row,
                img.rgb.len()
            )));
        }
        if self.rows + rows > h {
            return Err(ClientError::Protocol("more image rows than the image has".into()));
        }
        let dst = &mut image.pixels[self.rows * w..(self.rows + rows) * w];
        for (px, bytes) in dst.iter_mut().zip(img.rgb.chunks_exact(12)) {
            let mut c = f32s(bytes);
            *px = [0; 3].map(|_| c.next().unwrap_or(0.0));
        }
        self.error_map.extend(f32s(&img.error_map));
        self.rows += rows;
        if self.rows < h {
            return Ok(None);
        }
        let Some(image) = self.image.take() else { return Ok(None) };
        let error = img.estimated_rel_mse.map(|rel_mse| ErrorEstimate {
            width: w,
            height: h,
            per_pixel: std::mem::take(&mut self.error_map),
            rel_mse,
        });
        Ok(Some((image, error)))
    }
}

/// Jobs and workers.
pub async fn status(url: &str) -> Result<v1::GetStatusResponse, ClientError> {
    Ok(connect(url).await?.get_status(v1::GetStatusRequest {}).await?.into_inner())
}

/// Cancels a job; whether it was still running.
pub async fn cancel(url: &str, job: u64) -> Result<bool, ClientError> {
    Ok(connect(url)
        .await?
        .cancel_job(v1::CancelJobRequest { job_id: job })
        .await?
        .into_inner()
        .cancelled)
}

/// Whether the gRPC health service at `url` reports SERVING.
pub async fn healthy(url: &str) -> Result<bool, ClientError> {
    let channel = Channel::from_shared(url.to_string())
        .map_err(|_| ClientError::Protocol(format!("{url} is not a valid URL")))?
        .connect()
        .await
        .map_err(|source| ClientError::Connect { url: url.to_string(), source })?;
    let mut client = tonic_health::pb::health_client::HealthClient::new(channel);
    let r = client
        .check(tonic_health::pb::HealthCheckRequest { service: String::new() })
        .await?
        .into_inner();
    Ok(r.status == tonic_health::pb::health_check_response::ServingStatus::Serving as i32)
}
