//! A worker's messages, decoded and checked off the event loop.

use farm_common::film::FilmTile;
use farm_common::ids::{JobId, TileAttempt, TileId, WorkerId};
use farm_common::stats::RayStats;
use farm_proto::v1::{tile_result, worker_message};
use tracing::warn;

/// What a worker said, decoded and checked by its stream's own task so the
/// scheduler's loop only does scheduling.
#[derive(Debug)]
pub enum FromWorker {
    /// A rendered tile.
    Tile {
        /// The hand-out it answers.
        key: TileAttempt,
        /// Its sums.
        film_tile: FilmTile,
        /// Its rays.
        stats: RayStats,
    },
    /// A tile that could not be rendered (or whose result was malformed).
    Failed {
        /// The hand-out it answers.
        key: TileAttempt,
        /// Why.
        message: String,
        /// Whether another worker may succeed.
        retryable: bool,
    },
    /// A heartbeat (or a message with nothing in it).
    Alive,
}

impl FromWorker {
    /// Decodes a worker's message; malformed results become retryable failures.
    pub fn decode(id: WorkerId, kind: Option<worker_message::Kind>) -> FromWorker {
        let Some(worker_message::Kind::Result(r)) = kind else { return FromWorker::Alive };
        let key = TileAttempt { job: JobId(r.job_id), tile: TileId(r.tile), attempt: r.attempt };
        let (job, tile) = (key.job, key.tile);
        let stats = r.stats.as_ref().map(RayStats::from).unwrap_or_default();
        let failed = |message: String| FromWorker::Failed { key, message, retryable: true };
        match r.outcome {
            Some(tile_result::Outcome::FilmTile(ft)) => match FilmTile::try_from(&ft) {
                Ok(film_tile) => FromWorker::Tile { key, film_tile, stats },
                Err(e) => {
                    warn!(worker = id.0, job = job.0, tile = tile.0, error = %e, "malformed film tile refused");
                    failed(format!("malformed film tile: {e}"))
                }
            },
            Some(tile_result::Outcome::Failure(f)) => {
                FromWorker::Failed { key, message: f.message, retryable: f.retryable }
            }
            None => {
                warn!(
                    worker = id.0,
                    job = job.0,
                    tile = tile.0,
                    "tile result without an outcome refused"
                );
                failed("empty tile result".into())
            }
        }
    }
}
