//! A bridge from tokio to a dedicated rayon pool: CPU-bound work (scene
//! builds, tiles) runs on the pool's threads and the async side awaits the
//! result through a oneshot, so the tokio runtime never blocks (ballista's
//! `cpu_bound_executor.rs` idea, with rayon instead of a second runtime).

use crate::error::Error;
use std::panic::{catch_unwind, AssertUnwindSafe};
use std::sync::Arc;
use tokio::sync::oneshot;

/// A dedicated rayon pool for CPU-bound work. Clones share the pool.
#[derive(Clone, Debug)]
pub struct CpuPool {
    pool: Arc<rayon::ThreadPool>,
}

impl CpuPool {
    /// A pool of `threads` threads named `farm-render-N` (0 = one per core).
    pub fn new(threads: usize) -> Result<Self, rayon::ThreadPoolBuildError> {
        let pool = rayon::ThreadPoolBuilder::new()
            .num_threads(threads)
            .thread_name(|i| format!("farm-render-{i}"))
            .build()?;
        Ok(CpuPool { pool: Arc::new(pool) })
    }

    /// Number of threads.
    pub fn threads(&self) -> usize {
        self.pool.current_num_threads()
    }

    /// Runs `f` on the pool and waits for its value without blocking the
    /// async runtime. A panic in `f` is caught and returned as an error.
    /// Dropping the returned future does not stop `f` once it has started.
    pub async fn run<F, R>(&self, f: F) -> Result<R, Error>
    where
        F: FnOnce() -> R + Send + 'static,
        R: Send + 'static,
    {
        let (tx, rx) = oneshot::channel();
        self.pool.spawn(move || {
            let result = catch_unwind(AssertUnwindSafe(f))
                .map_err(|p| Error::Panicked(farm_common::panic_message(&*p)));
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
}
