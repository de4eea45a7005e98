//! `farm submit` without a coordinator address: an embedded coordinator and
//! an in-process worker, joined by the same dispatcher seam the gRPC farm
//! uses.

use crate::dispatch::LocalDispatcher;
use crate::error::SceneError;
use crate::estimate::ErrorEstimate;
use crate::job::{self, JobError, Progress};
use crate::output::{self, ImageError, ImageMetadata, RgbImage};
use farm_common::scene::Warning;
use farm_worker::error::BuildError;
use farm_worker::features::Features;
use farm_worker::integrator::RayStats;
use farm_worker::{RenderOptions, Renderer};
use std::path::{Path, PathBuf};
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
}

/// Why a render failed.
#[derive(Debug, thiserror::Error)]
pub enum SubmitError {
    /// The scene file is malformed.
    #[error(transparent)]
    Scene(#[from] SceneError),
    /// The scene could not be built.
    #[error("{0}")]
    Build(#[from] BuildError),
    /// Rendering stopped early.
    #[error(transparent)]
    Job(#[from] JobError),
    /// The image could not be written.
    #[error(transparent)]
    Image(#[from] ImageError),
    /// The thread pool could not start.
    #[error("cannot start render threads: {0}")]
    Threads(#[from] rayon::ThreadPoolBuildError),
}

/// Parses, builds and renders `scene` in this process, calling `progress`
/// after every tile. Nothing is written.
pub fn render(
    scene: &Path,
    opts: &SubmitOptions,
    progress: impl FnMut(&Progress),
) -> Result<RenderSummary, SubmitError> {
    let start = Instant::now();
    let (desc, mut warnings) = crate::scene::parse_file(scene)?;
    let (renderer, build_warnings) =
        Renderer::new(&desc, &RenderOptions { spp: opts.spp, all_paths: opts.all_paths })?;
    warnings.extend(build_warnings);
    let startup_seconds = start.elapsed().as_secs_f64();
    let output = opts.output.clone().unwrap_or_else(|| PathBuf::from(&renderer.film.filename));
    let spp = renderer.samples_per_pixel();
    let features = renderer.features.clone();
    let geometry = renderer.film.clone();
    let dispatcher = LocalDispatcher::new(Arc::new(renderer), opts.threads)?;
    let t = Instant::now();
    let (film, stats) = job::run(geometry, &dispatcher, progress)?;
    Ok(RenderSummary {
        image: film.image(),
        error: film.error_estimate(),
        output,
        stats,
        spp,
        startup_seconds,
        render_seconds: t.elapsed().as_secs_f64(),
        features,
        scene_name: desc.name,
        warnings,
    })
}

/// Writes a finished render to its output path.
pub fn write(summary: &RenderSummary) -> Result<(), SubmitError> {
    let meta = ImageMetadata {
        scene: summary.scene_name.clone(),
        spp: summary.spp,
        render_seconds: summary.render_seconds as f32,
        rel_mse_estimate: summary.error.as_ref().map(|e| e.rel_mse as f32),
    };
    output::write_image(&summary.output, &summary.image, &meta)?;
    Ok(())
}

/// Writes the per-pixel error estimate as a grey image (the same value in
/// R, G and B) to `path`.
pub fn write_error_map(
    path: &Path,
    summary: &RenderSummary,
    error: &ErrorEstimate,
) -> Result<(), SubmitError> {
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
    output::write_image(path, &image, &meta)?;
    Ok(())
}
