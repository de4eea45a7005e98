//! The farm's coordinator: parses pbrt-v3 scenes into scene descriptions,
//! splits the film into 16×16 tile jobs, hands them to workers, merges the
//! results in tile order and writes the image. The `farm` binary lives here.
#![warn(missing_docs)]

/// `farm bench`: shared scenes against pbrt-v3's time and memory.
pub mod bench;
/// The `farm` command line.
pub mod cli;
/// Talking to a coordinator.
pub mod client;
/// `farm converge`: error against time over increasing sample counts.
pub mod converge;
/// How tiles reach workers.
pub mod dispatch;
/// Scene errors.
pub mod error;
/// A render's estimate of its own error from its two half-images.
pub mod estimate;
/// Running one job.
pub mod job;
/// Ordered merging of film tiles.
pub mod merge;
/// Image error metrics.
pub mod metrics;
/// Image files.
pub mod output;
/// PLY mesh reader.
pub mod ply;
/// The pbrt-v3 scene parser.
pub mod scene;
/// The farm scheduler.
pub mod scheduler;
/// The coordinator gRPC server.
pub mod server;
/// Rendering a scene file end to end in this process.
pub mod submit;
