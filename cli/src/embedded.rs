//! `farm submit` without a coordinator address: the coordinator's own
//! [`Scheduler`], run in this process with one in-process worker that
//! renders on a rayon pool. Tiles reach the worker and results come back
//! over channels (no serialization, no sockets), so an embedded render gets
//! the farm's retries, failure messages and ordered merge: there is one job
//! engine, whichever way a scene is rendered.

use crate::display::Display;
use crate::error::Error;
use farm_common::film::{
    checked_layout, FilmGeometry, FilmTile, Limits, PassEnd, PassPlan, PassStop, SampleRange,
    SamplerKind,
};
use farm_common::ids::{JobId, TileAttempt, TileId, WorkerId};
use farm_common::image::{self, ImageMetadata, RgbImage};
use farm_common::scene::{SceneDescription, Warning};
use farm_common::stats::RayStats;
use farm_coordinator::estimate::ErrorEstimate;
use farm_coordinator::live::LiveCursor;
use farm_coordinator::merge::Film;
use farm_coordinator::scheduler::{
    Assignment, FinishedJob, JobSpec, JobUpdate, Outbox, Scheduler, SchedulerConfig,
};
use farm_proto::default_in_flight;
use farm_render::features::Features;
use farm_render::{RenderOptions, Renderer};
use std::collections::VecDeque;
use std::panic::{catch_unwind, AssertUnwindSafe};
use std::path::{Path, PathBuf};
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::mpsc;
use std::sync::Arc;
use std::time::Instant;

/// Choices for one render.
#[derive(Clone, Debug, Default)]
pub struct SubmitOptions {
    /// Output file (overrides the scene's `Film "string filename"`).
    pub output: Option<PathBuf>,
    /// Samples per pixel (overrides the sampler's `pixelsamples`).
    pub spp: Option<u32>,
    /// Render threads (0 = one per core).
    pub threads: usize,
    /// Compute ray differentials and every camera-sample dimension even
    /// where the scene does not use them (a benchmark's baseline).
    pub all_paths: bool,
    /// The largest film and sample counts to render.
    pub limits: Limits,
    /// What the command line changes in the scene (`--cropwindow`, `--quick`).
    pub overrides: farm_scene::Overrides,
    /// A display server (tev) to stream the image to, `HOST:PORT`.
    pub display_server: Option<String>,
    /// Render in passes and stop after the first whose estimated relMSE is
    /// at most this (`--target-error`).
    pub target_error: Option<f64>,
    /// Render in passes and stop after the first that ends this many
    /// seconds or more after the render started (`--time-limit`).
    pub time_limit: Option<f64>,
    /// Render in passes that end at these samples per pixel, increasing,
    /// the last at most the render's (`farm converge`); empty: the passes
    /// of `target_error` and `time_limit`, if any.
    pub pass_totals: Vec<u32>,
}

/// Progress of a running render.
#[derive(Clone, Copy, Debug, Default)]
pub struct Progress {
    /// Tiles received.
    pub tiles_done: u32,
    /// Tiles in the job.
    pub tiles_total: u32,
    /// Rays traced so far.
    pub stats: RayStats,
}

/// What a finished render produced.
#[derive(Clone, Debug)]
pub struct RenderSummary {
    /// The image.
    pub image: RgbImage,
    /// The render's estimate of its own error (`None` at one sample per pixel).
    pub error: Option<ErrorEstimate>,
    /// Where it goes.
    pub output: PathBuf,
    /// Rays traced.
    pub stats: RayStats,
    /// Samples per pixel used.
    pub spp: u32,
    /// Seconds to parse, load and build the scene.
    pub startup_seconds: f64,
    /// Seconds spent rendering tiles.
    pub render_seconds: f64,
    /// What the scene uses and so what the render skipped.
    pub features: Features,
    /// The scene's name.
    pub scene_name: String,
    /// What was ignored in the scene.
    pub warnings: Vec<Warning>,
    /// A render in passes: what each pass left.
    pub passes: Vec<PassEnd>,
    /// Why a render in passes stopped.
    pub stopped: Option<PassStop>,
    /// The scene's sampler, when known (not to `farm watch`).
    pub sampler: Option<SamplerKind>,
}

/// The one worker of an embedded render.
const LOCAL_WORKER: WorkerId = WorkerId(1);

/// A tile rendered (or failed) by the in-process worker.
struct LocalResult {
    key: TileAttempt,
    outcome: Result<(FilmTile, RayStats), String>,
}

/// The scheduler's way out to the in-process worker: each assignment
/// becomes a task on the render pool, in the order assigned, once fewer
/// than [`farm_render::render::tiles_on_pool`] tiles are on it (not all at
/// once: see there why).
struct LocalOutbox<R> {
    render: Arc<R>,
    pool: Arc<rayon::ThreadPool>,
    results: mpsc::Sender<LocalResult>,
    /// Set when the (one) job is cancelled or failed: its queued tiles are
    /// dropped unrendered.
    cancelled: Arc<AtomicBool>,
    /// Assigned tiles not yet on the pool, in order.
    queued: VecDeque<Assignment>,
    /// Tiles on the pool whose result has not been taken yet, and how many
    /// may be ([`LocalOutbox::pump`]).
    on_pool: usize,
    pool_limit: usize,
    updates: Vec<JobUpdate>,
}

impl<R> LocalOutbox<R>
where
    R: Fn(TileId, Option<SampleRange>) -> (FilmTile, RayStats) + Send + Sync + 'static,
{
    /// Tiles assigned whose result has not been taken yet.
    fn outstanding(&self) -> usize {
        self.queued.len() + self.on_pool
    }

    /// Puts queued tiles on the pool while fewer than `pool_limit` are there.
    fn pump(&mut self) {
        while self.on_pool < self.pool_limit {
            let Some(a) = self.queued.pop_front() else { break };
            self.on_pool += 1;
            self.spawn(a);
        }
    }

    /// A task on the pool that renders `a` and sends back the result.
    fn spawn(&self, a: Assignment) {
        let (render, results, cancelled) =
            (self.render.clone(), self.results.clone(), self.cancelled.clone());
        self.pool.spawn_fifo(move || {
            let outcome = if cancelled.load(Ordering::Relaxed) {
                Err("the job was cancelled".to_string())
            } else if a.part.is_some() {
                // The scheduler splits a tile only for workers other than
                // its holder, and an embedded render has one worker.
                Err("a part of a tile handed to the only worker".to_string())
            } else {
                catch_unwind(AssertUnwindSafe(|| render(a.tile, a.samples))).map_err(|p| {
                    format!("render thread panicked: {}", farm_common::panic_message(&*p))
                })
            };
            // A closed channel means the render was abandoned.
            let _ = results.send(LocalResult { key: a.key(), outcome });
        });
    }
}

impl<R> Outbox for LocalOutbox<R>
where
    R: Fn(TileId, Option<SampleRange>) -> (FilmTile, RayStats) + Send + Sync + 'static,
{
    fn assign(&mut self, _worker: WorkerId, a: Assignment) {
        self.queued.push_back(a);
        self.pump();
    }

    fn cancel(&mut self, _worker: WorkerId, _job: JobId) {
        self.cancelled.store(true, Ordering::Relaxed);
    }

    fn disconnect(&mut self, _worker: WorkerId) {}

    fn notify(&mut self, _job: JobId, update: JobUpdate) {
        self.updates.push(update);
    }
}

/// One job for [`run_job`]: its film, samples per pixel (the cap of a
/// render in passes), name and passes.
#[derive(Clone, Debug)]
pub struct LocalJob {
    /// The film layout.
    pub geometry: FilmGeometry,
    /// Samples per pixel.
    pub spp: u32,
    /// A name for logs.
    pub name: String,
    /// Its passes, when it renders in passes.
    pub passes: Option<PassPlan>,
}

/// Runs one job through the scheduler on `threads` render threads (0 = one
/// per core): `render` renders a tile of the job's film at its samples per
/// pixel, or the samples of one pass (a [`Renderer`]'s `render_tile` or
/// `render_tile_samples` in a real render). `progress` is called as tiles
/// merge.
pub fn run_job<R>(
    render: R,
    job: LocalJob,
    threads: usize,
    display: Option<&mut Display>,
    progress: impl FnMut(&Progress),
) -> Result<Arc<FinishedJob>, Error>
where
    R: Fn(TileId, Option<SampleRange>) -> (FilmTile, RayStats) + Send + Sync + 'static,
{
    run_job_with(render, job, threads, display, progress, |_, _, _| {})
}

/// [`run_job`], calling `on_pass` with each pass's end, the film as it
/// stands then and the rays traced so far, for every pass of a job in
/// passes but its last (whose image and estimate are the finished job's).
pub fn run_job_with<R>(
    render: R,
    job: LocalJob,
    threads: usize,
    mut display: Option<&mut Display>,
    mut progress: impl FnMut(&Progress),
    mut on_pass: impl FnMut(&PassEnd, &mut Film, &RayStats),
) -> Result<Arc<FinishedJob>, Error>
where
    R: Fn(TileId, Option<SampleRange>) -> (FilmTile, RayStats) + Send + Sync + 'static,
{
    let pool = rayon::ThreadPoolBuilder::new()
        .num_threads(threads)
        .thread_name(|i| format!("farm-render-{i}"))
        .build()?;
    let threads = pool.current_num_threads();
    let spec = JobSpec {
        name: job.name,
        priority: 0,
        scene_hash: Vec::new(),
        spp_override: 0,
        spp: job.spp,
        geometry: job.geometry,
        owner: Default::default(),
        detach: false,
        blobs: Vec::new(),
        shot: None,
        passes: job.passes,
        // The one worker here holds its usual slots: nothing waits on a
        // slower worker's share, and its tiles spread over the pool anyway.
        parallel_tiles: false,
    };
    let (results, inbox) = mpsc::channel();
    let mut out = LocalOutbox {
        render: Arc::new(render),
        pool: Arc::new(pool),
        results,
        cancelled: Arc::default(),
        queued: VecDeque::new(),
        on_pool: 0,
        pool_limit: farm_render::render::tiles_on_pool(threads),
        updates: Vec::new(),
    };
    let mut sched = Scheduler::new(SchedulerConfig::default());
    let now = Instant::now();
    let slots = default_in_flight(threads);
    sched.worker_joined(LOCAL_WORKER, "this process".into(), threads as u32, slots, now, &mut out);
    let job = sched.submit(spec, &mut out);
    let mut last_failure = String::new();
    let mut live = LiveCursor::new();
    let mut passes_seen = 0;
    loop {
        for update in out.updates.drain(..) {
            match update {
                JobUpdate::Progress { done, total, stats, .. } => {
                    progress(&Progress { tiles_done: done, tiles_total: total, stats })
                }
                JobUpdate::Finished(f) => {
                    if let Some(d) = display.as_deref_mut() {
                        d.finish(&f.image, f.error.as_ref().map(|e| e.per_pixel.as_slice()));
                    }
                    return Ok(f);
                }
                JobUpdate::Failed(m) => return Err(Error::JobFailed(m)),
            }
        }
        if let (Some(d), Some(film)) = (display.as_deref_mut(), sched.film(job)) {
            if d.due() {
                d.pieces(&live.take_pieces(film, usize::MAX));
            }
        }
        if out.outstanding() == 0 {
            // Nothing is rendering and the scheduler hands this worker no
            // more: every remaining tile failed here too often. No other
            // worker will come, so the job cannot finish.
            sched.abandon(
                job,
                format!("no worker may render its remaining tiles ({last_failure})"),
                &mut out,
            );
            continue;
        }
        let Ok(r) = inbox.recv() else {
            return Err(Error::JobFailed("the render threads stopped".into()));
        };
        out.on_pool -= 1;
        out.pump();
        sched.heard_from(LOCAL_WORKER, Instant::now());
        match r.outcome {
            Ok((film_tile, stats)) => {
                sched.tile_done(LOCAL_WORKER, r.key, film_tile, stats, &mut out);
                let ends = sched.pass_ends(job);
                if ends.len() > passes_seen {
                    passes_seen = ends.len();
                    let end = ends[ends.len() - 1];
                    let stats = sched.stats(job).unwrap_or_default();
                    if let Some(film) = sched.film_mut(job) {
                        on_pass(&end, film, &stats);
                    }
                }
            }
            Err(message) => {
                last_failure = format!("tile {}: {message}", r.key.tile.0);
                sched.tile_failed(LOCAL_WORKER, r.key, message, true, &mut out)
            }
        }
    }
}

/// Parses, builds and renders `scene` in this process, calling `progress`
/// as tiles merge. Nothing is written.
pub fn render(
    scene: &Path,
    opts: &SubmitOptions,
    progress: impl FnMut(&Progress),
) -> Result<RenderSummary, Error> {
    let start = Instant::now();
    let (desc, warnings) = farm_scene::parse_file(scene)?;
    render_parsed(desc, warnings, start, opts, progress)
}

/// Builds and renders a parsed scene (parsing began at `start`), as
/// [`render`] does.
pub fn render_parsed(
    desc: SceneDescription,
    warnings: Vec<Warning>,
    start: Instant,
    opts: &SubmitOptions,
    progress: impl FnMut(&Progress),
) -> Result<RenderSummary, Error> {
    render_parsed_with(desc, warnings, start, opts, progress, |_, _, _| {})
}

/// Gives the pages of the heap's free blocks back to the system: what
/// parsing and building freed (the scene's text, its parameter lists, a
/// mesh's arrays as parsed) sits between blocks still in use, where
/// glibc's own trimming, which only cuts the heap's top, cannot reach it.
/// On teapot-area-light (2,292 meshes) that is about 1 MB of a 15 MB peak.
fn return_freed_heap() {
    #[cfg(all(target_os = "linux", target_env = "gnu"))]
    // SAFETY: malloc_trim only releases free memory; it takes the
    // allocator's own locks and touches no block in use.
    unsafe {
        libc::malloc_trim(0);
    }
}

/// [`render_parsed`], calling `on_pass` as [`run_job_with`] does.
pub fn render_parsed_with(
    mut desc: SceneDescription,
    mut warnings: Vec<Warning>,
    start: Instant,
    opts: &SubmitOptions,
    progress: impl FnMut(&Progress),
    on_pass: impl FnMut(&PassEnd, &mut Film, &RayStats),
) -> Result<RenderSummary, Error> {
    opts.overrides.apply(&mut desc, &mut warnings);
    // Refuse an oversize film before anything is allocated for it.
    checked_layout(&desc, opts.spp, &opts.limits)?;
    // The renderer takes the description: what it does not keep (a mesh's
    // arrays as parsed) is freed as it builds.
    let name = std::mem::take(&mut desc.name);
    let (renderer, build_warnings) =
        Renderer::new(desc, &RenderOptions { spp: opts.spp, all_paths: opts.all_paths })?;
    warnings.extend(build_warnings);
    return_freed_heap();
    let startup_seconds = start.elapsed().as_secs_f64();
    let output = opts.output.clone().unwrap_or_else(|| PathBuf::from(&renderer.film.filename));
    let features = renderer.features.clone();
    let t = Instant::now();
    let (geometry, spp) = (renderer.film.clone(), renderer.samples_per_pixel());
    let kind = renderer.sampler.kind();
    let mut passes = PassPlan::for_job(kind, spp, opts.target_error, opts.time_limit);
    if !opts.pass_totals.is_empty() {
        let plan = PassPlan::new(spp, None, None);
        passes = Some(PassPlan { totals: opts.pass_totals.clone(), ..plan }.for_sampler(kind));
    }
    if let Some(p) = &passes {
        p.check().map_err(Error::Usage)?;
        if p.totals.last().is_some_and(|&n| n > spp) {
            return Err(Error::Usage(format!("passes {:?} go past {spp} spp", p.totals)));
        }
    }
    let mut display = opts.display_server.as_deref().and_then(|address| {
        let b = geometry.cropped_pixel_bounds;
        Display::connect(address, &name, b.width(), b.height())
            .map_err(|e| {
                warnings
                    .push(Warning { loc: None, message: format!("{e}; not streaming the image") })
            })
            .ok()
    });
    // On the pool's threads: a stateless sampler's tile spreads its pixels
    // over them, so the last tiles of a frame do not leave threads idle.
    let render =
        move |tile, samples: Option<SampleRange>| renderer.render_tile_parallel(tile, samples);
    let job = LocalJob { geometry, spp, name: name.clone(), passes };
    let finished = run_job_with(render, job, opts.threads, display.as_mut(), progress, on_pass)?;
    let render_seconds = t.elapsed().as_secs_f64();
    let finished = Arc::try_unwrap(finished).unwrap_or_else(|f| (*f).clone());
    Ok(RenderSummary {
        image: finished.image,
        error: finished.error,
        output,
        stats: finished.stats,
        spp: finished.spp,
        startup_seconds,
        render_seconds,
        features,
        scene_name: name,
        warnings,
        passes: finished.passes,
        stopped: finished.stopped,
        sampler: Some(kind),
    })
}

/// Writes a finished render to its output path.
pub fn write(summary: &RenderSummary) -> Result<(), Error> {
    let meta = ImageMetadata {
        scene: summary.scene_name.clone(),
        spp: summary.spp,
        render_seconds: summary.render_seconds as f32,
        rel_mse_estimate: summary.error.as_ref().map(|e| e.rel_mse as f32),
    };
    image::write_image(&summary.output, &summary.image, &meta)?;
    Ok(())
}

/// Writes the per-pixel error estimate as a grey image (the same value in
/// R, G and B) to `path`.
pub fn write_error_map(
    path: &Path,
    summary: &RenderSummary,
    error: &ErrorEstimate,
) -> Result<(), Error> {
    let image = RgbImage {
        width: error.width,
        height: error.height,
        pixels: error.per_pixel.iter().map(|&v| [v; 3]).collect(),
    };
    let meta = ImageMetadata {
        scene: format!("{} (estimated relMSE per pixel)", summary.scene_name),
        spp: summary.spp,
        render_seconds: summary.render_seconds as f32,
        rel_mse_estimate: Some(error.rel_mse as f32),
    };
    image::write_image(path, &image, &meta)?;
    Ok(())
}

#[cfg(test)]
#[path = "embedded_tests.rs"]
mod tests;
