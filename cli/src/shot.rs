//! A shot on a farm (`farm submit FILES... --coordinator`): its frames are
//! submitted as jobs a few ahead of the ones rendering, so the farm's
//! queue always holds the next frame's tiles and no worker idles between
//! frames, while the coordinator holds only a few frames' films. Each
//! asset is uploaded once however many frames name it (the blobs are
//! content-addressed), and each frame is written as soon as its image
//! arrives. A frame that fails fails alone.

use crate::client::{
    connect, follow, prepare_scene, upload_new, JobImage, Remote, RemoteOptions, RemoteProgress,
};
use crate::embedded::RenderSummary;
use crate::error::Error;
use crate::frames::{FrameOutput, FrameScene};
use farm_common::film::{FilmGeometry, SamplerKind};
use farm_common::scene::Warning;
use farm_proto::connect::Client;
use farm_proto::v1;
use farm_render::features::Features;
use std::collections::HashSet;
use std::path::{Path, PathBuf};
use tokio::sync::mpsc;
use tokio::task::JoinSet;

/// At most this many of a shot's frames are submitted and unfinished at
/// once (the coordinator allows a client 16 watches).
pub const MAX_IN_FLIGHT: usize = 8;

/// What became of one frame.
pub enum FrameEnd {
    /// Its image, to be written.
    Done(Box<RenderSummary>, FrameOutput),
    /// It failed, alone.
    Failed(FrameOutput, Error),
}

/// Which shot the frames belong to.
#[derive(Clone, Copy, Debug)]
pub struct ShotPlace {
    /// An existing shot to add them to (`--retry-failed`); `None` starts
    /// a new one with the first frame.
    pub shot: Option<u64>,
    /// How many frames the shot has (the files given).
    pub frames: u32,
}

/// What the shot cost.
#[derive(Clone, Copy, Debug, Default)]
pub struct ShotTotals {
    /// The shot's id (0 if no frame was submitted).
    pub shot: u64,
    /// Frames submitted.
    pub frames: usize,
    /// Bytes uploaded, each blob once.
    pub uploaded_bytes: u64,
    /// Blobs that more than one frame named, uploaded once.
    pub blobs_reused: usize,
}

/// A frame on the farm: what is kept of its scene while it renders.
struct Pending {
    out: FrameOutput,
    job: u64,
    film_filename: String,
    features: Features,
    sampler: SamplerKind,
    scene_name: String,
    warnings: Vec<Warning>,
    startup_seconds: f64,
}

/// Submits each frame `frames` yields, at most `in_flight` unfinished at
/// once, and hands each frame's end to `on_end` as it comes, with
/// `progress` told of the frames' tiles as they merge. A scene that does
/// not parse ends the shot (the frames already on the farm are still
/// followed to their end); anything else fails only its frame.
pub async fn submit_shot(
    remote: &Remote,
    mut frames: impl Iterator<Item = Result<FrameScene, Error>>,
    opts: &RemoteOptions,
    place: ShotPlace,
    in_flight: usize,
    mut progress: impl FnMut(u32, &RemoteProgress),
    mut on_end: impl FnMut(FrameEnd),
) -> Result<ShotTotals, Error> {
    let mut client = connect(remote).await?;
    let mut totals = ShotTotals { shot: place.shot.unwrap_or(0), ..Default::default() };
    let frames_declared = place.frames.max(1);
    let mut sent: HashSet<[u8; 32]> = HashSet::new();
    let mut running: JoinSet<(Pending, Result<JobImage, Error>)> = JoinSet::new();
    let (tx, mut rx) = mpsc::unbounded_channel::<(u32, RemoteProgress)>();
    let mut stopped: Option<Error> = None;
    loop {
        while stopped.is_none() && running.len() < in_flight.clamp(1, MAX_IN_FLIGHT) {
            let frame = match frames.next() {
                None => break,
                Some(Err(e)) => {
                    stopped = Some(e);
                    break;
                }
                Some(Ok(f)) => f,
            };
            totals.frames += 1;
            let out = frame.out.clone();
            // The files given, or the scenes met so far if more (a file
            // with several WorldEnds).
            let frames = frames_declared.max(totals.frames as u32);
            let shot = v1::ShotFrame { shot: totals.shot, frame: out.frame, frames };
            match submit_frame(&mut client, frame, opts, shot, &mut sent, &mut totals).await {
                Ok(p) => {
                    if totals.shot == 0 {
                        totals.shot = p.job;
                    }
                    let (remote, tx) = (remote.clone(), tx.clone());
                    let reconnect_for = opts.reconnect_for;
                    running.spawn(async move {
                        let n = p.out.frame;
                        let image = follow(&remote, p.job, None, reconnect_for, |r| {
                            let _ = tx.send((n, *r));
                        })
                        .await;
                        (p, image)
                    });
                }
                Err(e) => on_end(FrameEnd::Failed(out, e)),
            }
        }
        if running.is_empty() {
            break;
        }
        tokio::select! {
            Some((n, p)) = rx.recv() => progress(n, &p),
            Some(joined) = running.join_next() => {
                let (p, image) = joined.map_err(|e| Error::Protocol(format!("a frame's task: {e}")))?;
                on_end(match image {
                    Ok(image) => summary(p, image),
                    Err(e) => FrameEnd::Failed(p.out, e),
                });
            }
        }
    }
    match stopped {
        Some(e) => Err(e),
        None => Ok(totals),
    }
}

/// Uploads what of one frame the coordinator has not been sent in this
/// shot, and submits it.
async fn submit_frame(
    client: &mut Client,
    frame: FrameScene,
    opts: &RemoteOptions,
    shot: v1::ShotFrame,
    sent: &mut HashSet<[u8; 32]>,
    totals: &mut ShotTotals,
) -> Result<Pending, Error> {
    let start = frame.start();
    let FrameScene { out, file, mut desc, mut warnings, .. } = frame;
    let (manifest, assets) = prepare_scene(&mut desc, &mut warnings, &file, opts)?;
    let up = upload_new(client, &manifest, &assets, sent).await?;
    totals.blobs_reused += up.reused;
    totals.uploaded_bytes += up.bytes;
    let request = crate::client::submit_request(&manifest, file_name(&file), opts, Some(shot));
    let job = client.submit_job(request).await?.into_inner().job_id;
    let (film, _) = FilmGeometry::from_description(&desc);
    Ok(Pending {
        out,
        job,
        film_filename: film.filename,
        features: Features::of(&desc),
        sampler: SamplerKind::of(&desc.sampler.name),
        scene_name: desc.name,
        warnings,
        startup_seconds: start.elapsed().as_secs_f64(),
    })
}

/// A file's name, for a job's.
pub fn file_name(file: &Path) -> String {
    file.file_name().map(|n| n.to_string_lossy().into_owned()).unwrap_or_default()
}

/// A frame's image and what is known of its scene, as a render's summary.
fn summary(p: Pending, image: JobImage) -> FrameEnd {
    let output = p.out.image.clone().unwrap_or_else(|| PathBuf::from(&p.film_filename));
    let summary = RenderSummary {
        image: image.image,
        error: image.error,
        output,
        stats: image.stats,
        spp: image.spp,
        startup_seconds: p.startup_seconds,
        render_seconds: image.render_seconds,
        features: p.features,
        scene_name: p.scene_name,
        warnings: p.warnings,
        passes: image.passes,
        stopped: image.stopped,
        sampler: Some(p.sampler),
    };
    FrameEnd::Done(Box::new(summary), p.out)
}

/// A shot as a status listing shows it: each frame counted once, by its
/// latest job (a frame rendered again after a failure counts as the new
/// job stands).
#[derive(Clone, Debug, Default, PartialEq, Eq)]
pub struct ShotView {
    /// The shot's id (its first frame's job).
    pub shot: u64,
    /// Its first frame's job's name.
    pub name: String,
    /// Who submitted it.
    pub owner: String,
    /// How many frames its client was given.
    pub frames: u32,
    /// Frames whose latest job is done.
    pub done: Vec<u32>,
    /// Frames whose latest job is queued or running.
    pub rendering: Vec<u32>,
    /// Frames whose latest job failed or was cancelled.
    pub failed: Vec<u32>,
}

/// The shots among `jobs`, by id.
pub fn shots(jobs: &[v1::JobStatus]) -> Vec<ShotView> {
    use std::collections::BTreeMap;
    let mut latest: BTreeMap<u64, BTreeMap<u32, &v1::JobStatus>> = BTreeMap::new();
    for j in jobs {
        let Some(s) = &j.shot else { continue };
        let frames = latest.entry(s.shot).or_default();
        let slot = frames.entry(s.frame).or_insert(j);
        if j.job_id > slot.job_id {
            *slot = j;
        }
    }
    latest
        .into_iter()
        .map(|(shot, frames)| {
            let mut v = ShotView { shot, ..Default::default() };
            for (frame, j) in frames {
                if j.job_id == shot || v.name.is_empty() {
                    v.name.clone_from(&j.name);
                    v.owner.clone_from(&j.owner);
                }
                v.frames = v.frames.max(j.shot.as_ref().map_or(0, |s| s.frames));
                match j.state.as_str() {
                    "done" => v.done.push(frame),
                    "queued" | "running" => v.rendering.push(frame),
                    _ => v.failed.push(frame),
                }
            }
            v
        })
        .collect()
}

/// Shot `shot` as the coordinator lists it (for `--retry-failed`).
pub async fn existing_shot(remote: &Remote, shot: u64) -> Result<ShotView, Error> {
    let s = crate::client::status(remote).await?;
    shots(&s.jobs).into_iter().find(|v| v.shot == shot).ok_or_else(|| {
        Error::Usage(format!(
            "the coordinator knows no shot {shot} of yours (a shot is forgotten with its jobs, after the coordinator's --keep-finished)"
        ))
    })
}
