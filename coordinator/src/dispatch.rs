//! How tiles reach workers. The scheduler only sees this seam: the embedded
//! mode renders in this process on a rayon pool; the gRPC farm will send
//! tiles to remote workers through the same trait.

use farm_common::film::FilmTile;
use farm_common::ids::TileId;
use farm_worker::integrator::RayStats;
use farm_worker::Renderer;
use std::sync::atomic::{AtomicUsize, Ordering};
use std::sync::mpsc::Sender;
use std::sync::Arc;

/// A rendered tile, or why it could not be rendered.
#[derive(Debug)]
pub struct TileResult {
    /// Which tile.
    pub tile: TileId,
    /// Its film tile.
    pub film_tile: FilmTile,
    /// Rays traced for it.
    pub stats: RayStats,
}

/// Something that renders tiles and reports each result on a channel, in
/// any order.
pub trait TileDispatcher: Send + Sync {
    /// Starts rendering `tiles`; returns at once. Each result is sent on
    /// `results`; the channel closes when every tile has been sent.
    fn dispatch(&self, tiles: Vec<TileId>, results: Sender<TileResult>);
}

/// Renders tiles in this process on a dedicated rayon pool.
pub struct LocalDispatcher {
    renderer: Arc<Renderer>,
    pool: Arc<rayon::ThreadPool>,
}

impl LocalDispatcher {
    /// A dispatcher with `threads` render threads (0 = one per core).
    pub fn new(
        renderer: Arc<Renderer>,
        threads: usize,
    ) -> Result<Self, rayon::ThreadPoolBuildError> {
        let pool = rayon::ThreadPoolBuilder::new()
            .num_threads(threads)
            .thread_name(|i| format!("farm-render-{i}"))
            .build()?;
        Ok(LocalDispatcher { renderer, pool: Arc::new(pool) })
    }

    /// Number of render threads.
    pub fn threads(&self) -> usize {
        self.pool.current_num_threads()
    }
}

impl TileDispatcher for LocalDispatcher {
    fn dispatch(&self, tiles: Vec<TileId>, results: Sender<TileResult>) {
        let renderer = self.renderer.clone();
        let pool = self.pool.clone();
        // Every render thread takes the next tile in order, so tiles finish
        // in about the order the film merges them: few wait for a
        // predecessor (holding their memory), and merging keeps pace with
        // rendering instead of piling up behind the first half of the image.
        std::thread::spawn(move || {
            let next = AtomicUsize::new(0);
            pool.broadcast(|_| {
                let tx = results.clone();
                while let Some(&tile) = tiles.get(next.fetch_add(1, Ordering::Relaxed)) {
                    let (film_tile, stats) = renderer.render_tile(tile);
                    // A closed channel means the job was abandoned.
                    if tx.send(TileResult { tile, film_tile, stats }).is_err() {
                        break;
                    }
                }
            });
        });
    }
}
