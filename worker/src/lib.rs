//! The worker process: registers with a coordinator, keeps one `Work`
//! stream open, fetches each job's scene and assets once (content
//! addressed), builds a renderer per scene and renders the tiles it is
//! assigned on a dedicated rayon pool, sending each film tile back as it is
//! done. The rendering itself is `farm-render`'s.
#![warn(missing_docs)]

/// One tile assignment, rendered.
pub mod assignment;
/// Content-addressed blobs fetched from the coordinator.
pub mod blob_cache;
/// Worker settings.
pub mod config;
/// The worker's errors.
pub mod error;
/// The grpc.health.v1 service for probes.
pub mod health;
/// Prometheus `/metrics` of a worker.
pub mod metrics;
/// The tokio-to-rayon bridge for CPU-bound work.
pub mod pool;
/// Built renderers cached by scene and spp.
pub mod renderer_cache;
/// The session with the coordinator.
pub mod session;
/// Test helpers: a tiny scene and a fake coordinator.
#[cfg(test)]
pub(crate) mod testing;

pub use config::WorkerConfig;
pub use error::{Error, Result};
pub use session::{run, WorkerSummary};
