use serde::{Deserialize, Serialize};

/// Index of a 16×16 tile in the film's tile grid, row-major over the sample
/// bounds (pbrt-v3: `tile.y * nTiles.x + tile.x`).
#[derive(Clone, Copy, Debug, PartialEq, Eq, PartialOrd, Ord, Hash, Serialize, Deserialize)]
pub struct TileId(pub u32);

/// A render job submitted to the coordinator.
#[derive(Clone, Copy, Debug, PartialEq, Eq, PartialOrd, Ord, Hash, Serialize, Deserialize)]
pub struct JobId(pub u64);

/// A worker registered with the coordinator.
#[derive(Clone, Copy, Debug, PartialEq, Eq, PartialOrd, Ord, Hash, Serialize, Deserialize)]
pub struct WorkerId(pub u64);

/// One hand-out of a tile to a worker: a result answers exactly one, and
/// only the worker holding it may answer.
#[derive(Clone, Copy, Debug, PartialEq, Eq, PartialOrd, Ord, Hash, Serialize, Deserialize)]
pub struct TileAttempt {
    /// The job.
    pub job: JobId,
    /// The tile.
    pub tile: TileId,
    /// Earlier hand-outs of this tile (0 the first time).
    pub attempt: u32,
}
