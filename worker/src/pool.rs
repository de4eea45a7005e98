//! A bridge from tokio to a dedicated rayon pool: CPU-bound work (scene
//! builds, tiles) runs on the pool's threads and the async side awaits the
//! result through a oneshot, so the tokio runtime never blocks (ballista's
//! `cpu_bound_executor.rs` idea, with rayon instead of a second runtime).

use crate::error::Error;
use farm_render::render::tiles_on_pool;
use std::panic::{catch_unwind, AssertUnwindSafe};
use std::sync::Arc;
use tokio::sync::{oneshot, Semaphore};

/// A dedicated rayon pool for CPU-bound work. Clones share the pool.
///
/// At most [`farm_render::render::tiles_on_pool`] closures are on the pool
/// at once (a tile's closure spreads its pixels over the pool: see there
/// why); the rest wait their turn on the async side, as the embedded
/// outbox's tiles do.
#[derive(Clone, Debug)]
pub struct CpuPool {
    pool: Arc<rayon::ThreadPool>,
    turns: Arc<Semaphore>,
}

impl CpuPool {
    /// A pool of `threads` threads named `farm-render-N` (0 = one per core).
    pub fn new(threads: usize) -> Result<Self, rayon::ThreadPoolBuildError> {
        let pool = rayon::ThreadPoolBuilder::new()
            .num_threads(threads)
            .thread_name(|i| format!("farm-render-{i}"))
            .build()?;
        let turns = Arc::new(Semaphore::new(tiles_on_pool(pool.current_num_threads())));
        Ok(CpuPool { pool: Arc::new(pool), turns })
    }

    /// Number of threads.
    pub fn threads(&self) -> usize {
        self.pool.current_num_threads()
    }

    /// Runs `f` on the pool, once it is its turn, and waits for its value
    /// without blocking the async runtime. A panic in `f` is caught and
    /// returned as an error. Dropping the returned future does not stop `f`
    /// once it has started.
    pub async fn run<F, R>(&self, f: F) -> Result<R, Error>
    where
        F: FnOnce() -> R + Send + 'static,
        R: Send + 'static,
    {
        let (tx, rx) = oneshot::channel();
        // The semaphore is never closed, so waiting for a turn cannot fail.
        let turn = self.turns.clone().acquire_owned().await.map_err(|_| Error::PoolDropped)?;
        self.pool.spawn(move || {
            let result = catch_unwind(AssertUnwindSafe(f))
                .map_err(|p| Error::Panicked(farm_common::panic_message(&*p)));
            drop(turn);
            // The receiver is gone when the waiting task was cancelled.
            let _ = tx.send(result);
        });
        rx.await.map_err(|_| Error::PoolDropped)?
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[tokio::test]
    async fn results_come_back_and_panics_become_errors() {
        let pool = CpuPool::new(2).unwrap();
        assert_eq!(pool.threads(), 2);
        let name = pool.run(|| std::thread::current().name().map(str::to_string)).await;
        assert!(name.unwrap().unwrap().starts_with("farm-render-"));
        let sum = pool.run(|| (1..=100u64).sum::<u64>()).await;
        assert_eq!(sum.unwrap(), 5050);
        let err = pool.run(|| -> u32 { panic!("boom {}", 7) }).await;
        assert!(matches!(err, Err(Error::Panicked(m)) if m == "boom 7"));
        let err = pool.run(|| -> u32 { panic!("static") }).await;
        assert!(matches!(err, Err(Error::Panicked(m)) if m == "static"));
        // The pool survives panics.
        let many: Vec<_> = (0..8u32).map(|i| pool.run(move || i * i)).collect();
        let mut got = Vec::new();
        for f in many {
            got.push(f.await.unwrap());
        }
        assert_eq!(got, vec![0, 1, 4, 9, 16, 25, 36, 49]);
    }

    /// Closures that spread their work over the pool, as tiles do: a
    /// thread waiting for the rest of one takes another from the pool's
    /// queue, so only twice its threads may be queued there at once.
    #[tokio::test]
    async fn closures_that_wait_on_the_pool_stay_few_on_it() {
        use rayon::prelude::*;
        use std::sync::atomic::{AtomicUsize, Ordering};
        let pool = CpuPool::new(2).unwrap();
        let (now, most) = (Arc::new(AtomicUsize::new(0)), Arc::new(AtomicUsize::new(0)));
        let runs: Vec<_> = (0..40)
            .map(|_| {
                let (pool, n, m) = (pool.clone(), now.clone(), most.clone());
                tokio::spawn(async move {
                    pool.run(move || {
                        m.fetch_max(n.fetch_add(1, Ordering::SeqCst) + 1, Ordering::SeqCst);
                        (0..8u64).into_par_iter().for_each(|i| {
                            let us = 100 + 400 * (i % 3);
                            std::thread::sleep(std::time::Duration::from_micros(us))
                        });
                        n.fetch_sub(1, Ordering::SeqCst);
                    })
                    .await
                })
            })
            .collect();
        for r in runs {
            r.await.unwrap().unwrap();
        }
        let most = most.load(Ordering::SeqCst);
        assert!((2..=4).contains(&most), "{most} closures were running at once on 2 threads");
    }
}
