//! The farm's job engine: the scheduler state machine that splits each job's
//! film into 16×16 tiles, hands them to workers, retries what is lost or
//! fails, and merges results strictly in tile order; the single event loop
//! and the gRPC service that feed it; the content-addressed blob store; and
//! the render's estimate of its own error. It never builds or renders a
//! scene: the film layout comes from `farm-common`.
#![warn(missing_docs)]

/// The coordinator's errors and their gRPC status codes.
pub mod error;
/// A render's estimate of its own error from its two half-images.
pub mod estimate;
/// The film as it renders, in changed pieces, for live watchers.
pub mod live;
/// Ordered merging of film tiles.
pub mod merge;
/// Prometheus metrics.
pub mod metrics;
/// Large buffers mapped before they are written.
mod pages;
/// The farm scheduler.
pub mod scheduler;
/// TLS, tokens and roles.
pub mod security;
/// The coordinator gRPC server.
pub mod server;
/// A simulated farm: the scheduler in virtual time with virtual workers.
pub mod sim;
/// The journal and blob store in the state directory.
pub mod state;
/// The web dashboard and `/metrics`, on the gRPC port.
pub mod web;

pub use error::{Error, Result};
