//! One tile assignment, from scene lookup to the `TileResult` to send.

use crate::pool::CpuPool;
use crate::renderer_cache::RendererCache;
use farm_common::film::{SampleRange, TILE_PARTS};
use farm_common::ids::TileId;
use farm_proto::connect::Client;
use farm_proto::convert::Hash;
use farm_proto::v1::{self, tile_result::Outcome, TileAssignment, TileFailure, TileResult};
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::Arc;

/// What became of one assignment.
#[derive(Debug)]
pub struct TileOutcome {
    /// The tile's job.
    pub job_id: u64,
    /// The job's cancellation flag the tile was started with.
    pub cancelled: Arc<AtomicBool>,
    /// The result to send; `None` when the tile was dropped unrendered.
    pub result: Option<TileResult>,
    /// Whether the result holds a rendered film tile.
    pub rendered: bool,
    /// Seconds from the assignment's arrival to this outcome.
    pub seconds: f64,
}

/// Gets the assignment's renderer (building it if needed), then renders the
/// tile on `pool` unless `cancelled` is set by the time a thread is free.
/// Build errors and panics become `TileFailure`s.
pub async fn render_tile(
    renderers: RendererCache,
    client: Client,
    pool: CpuPool,
    a: TileAssignment,
    cancelled: Arc<AtomicBool>,
) -> TileOutcome {
    let (job_id, tile, attempt) = (a.job_id, a.tile, a.attempt);
    let arrived = std::time::Instant::now();
    let outcome = |outcome: Option<Outcome>, stats: Option<v1::RayStats>| TileOutcome {
        seconds: arrived.elapsed().as_secs_f64(),
        job_id,
        cancelled: cancelled.clone(),
        rendered: matches!(outcome, Some(Outcome::FilmTile(_))),
        result: outcome.map(|o| TileResult { job_id, tile, attempt, outcome: Some(o), stats }),
    };
    let failure = |message: String, retryable: bool| {
        tracing::warn!(job_id, tile, attempt, %message, retryable, "tile failed");
        outcome(Some(Outcome::Failure(TileFailure { message, retryable })), None)
    };

    let Ok(hash) = Hash::try_from(a.scene_hash.as_slice()) else {
        return failure(format!("scene hash has {} bytes, not 32", a.scene_hash.len()), false);
    };
    let renderer = match renderers.get(&client, hash, a.spp).await {
        Ok(r) => r,
        Err(e) => return failure(e.to_string(), e.retryable()),
    };
    if tile >= renderer.film.tile_count() {
        let message =
            format!("tile {tile} is outside the film's {} tiles", renderer.film.tile_count());
        return failure(message, false);
    }

    let samples = a.samples.map(|r| SampleRange {
        first: r.first_sample,
        end: r.end_sample,
        second_from: r.second_from,
        own_halves: r.own_halves,
    });
    if let Some(Err(why)) = samples.map(|r| r.check(renderer.samples_per_pixel())) {
        return failure(why, false);
    }
    // A part of the tile, for a sampler whose pixels can be drawn apart.
    let part = a.part.checked_sub(1);
    if part.is_some_and(|k| k >= TILE_PARTS || !renderer.tiles_parallel()) {
        let why = format!(
            "part {} of a tile: there are {TILE_PARTS}, of a stateless sampler's tiles only",
            a.part - 1
        );
        // Retryable: the tile's holder renders it whole all the same, so
        // the job need not fail for a part this worker cannot render.
        return failure(why, true);
    }

    let flag = cancelled.clone();
    let rendered = pool
        .run(move || {
            // Tiles of cancelled jobs (or of a closing session) are skipped.
            if flag.load(Ordering::Relaxed) {
                return None;
            }
            let started = std::time::Instant::now();
            // A stateless sampler's tile spreads its pixels over the pool.
            let (film_tile, stats) = match part {
                Some(k) => renderer.render_part(TileId(tile), samples, k)?,
                None => renderer.render_tile_parallel(TileId(tile), samples),
            };
            Some((v1::FilmTile::from(&film_tile), v1::RayStats::from(&stats), started.elapsed()))
        })
        .await;
    match rendered {
        Ok(Some((film_tile, stats, elapsed))) => {
            tracing::debug!(
                job_id,
                tile,
                attempt,
                ms = elapsed.as_secs_f64() * 1e3,
                "tile rendered"
            );
            outcome(Some(Outcome::FilmTile(film_tile)), Some(stats))
        }
        Ok(None) => outcome(None, None),
        Err(e) => failure(e.to_string(), true),
    }
}
