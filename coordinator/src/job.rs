//! One render job on the coordinator: hand every tile to a dispatcher,
//! merge results in tile order as they arrive, and report progress.

use crate::dispatch::{TileDispatcher, TileResult};
use crate::merge::{Accepted, Film};
use farm_common::film::FilmGeometry;
use farm_common::ids::TileId;
use farm_worker::integrator::RayStats;
use std::sync::mpsc;
use tracing::warn;

/// Progress of a running job.
#[derive(Clone, Copy, Debug, Default)]
pub struct Progress {
    /// Tiles received.
    pub tiles_done: u32,
    /// Tiles in the job.
    pub tiles_total: u32,
    /// Rays traced so far.
    pub stats: RayStats,
}

/// Why a job did not finish.
#[derive(Debug, thiserror::Error)]
pub enum JobError {
    /// The dispatcher stopped sending results before every tile came back.
    #[error("the workers stopped after {done} of {total} tiles")]
    Incomplete {
        /// Tiles received.
        done: u32,
        /// Tiles in the job.
        total: u32,
    },
}

/// Renders every tile of `geometry` through `dispatcher`; calls `progress`
/// after each tile. Returns the assembled film and the total ray counts.
pub fn run(
    geometry: FilmGeometry,
    dispatcher: &dyn TileDispatcher,
    mut progress: impl FnMut(&Progress),
) -> Result<(Film, RayStats), JobError> {
    let total = geometry.tile_count();
    let mut film = Film::new(geometry);
    let (tx, rx) = mpsc::channel::<TileResult>();
    dispatcher.dispatch((0..total).map(TileId).collect(), tx);
    let mut p = Progress { tiles_total: total, ..Default::default() };
    for r in rx {
        match film.accept(r.tile, r.film_tile) {
            Ok(Accepted::New) => {
                p.tiles_done += 1;
                p.stats.add(&r.stats);
                progress(&p);
            }
            Ok(Accepted::Duplicate) => warn!(tile = r.tile.0, "duplicate tile result ignored"),
            Err(e) => warn!(tile = r.tile.0, error = %e, "tile result refused"),
        }
        if film.is_complete() {
            break;
        }
    }
    if !film.is_complete() {
        return Err(JobError::Incomplete { done: p.tiles_done, total });
    }
    Ok((film, p.stats))
}
