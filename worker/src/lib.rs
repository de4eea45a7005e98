//! The farm's renderer: builds a scene from a `SceneDescription` and renders
//! 16×16 film tiles with pbrt-v3's Whitted integrator.
#![warn(missing_docs)]

/// Acceleration structures.
pub mod accel;
/// Content-addressed blobs fetched from the coordinator.
pub mod blobs;
/// Reflection models.
pub mod bxdf;
/// Cameras.
pub mod cameras;
/// Worker settings.
pub mod config;
/// Errors building a renderer.
pub mod error;
/// What a scene uses, and so what a render can skip.
pub mod features;
/// Reconstruction filters.
pub mod filters;
/// The grpc.health.v1 service for probes.
pub mod health;
/// Image decoding and MIP maps.
pub mod image;
/// The Whitted integrator.
pub mod integrator;
/// Surface hits and points.
pub mod interaction;
/// Light sources.
pub mod lights;
/// Materials.
pub mod materials;
/// The tokio-to-rayon bridge for CPU-bound work.
pub mod pool;
/// Primitives, aggregates and instances.
pub mod primitive;
/// Rendering tiles.
pub mod render;
/// Built renderers cached by scene and spp.
pub mod renderers;
/// Sample generators.
pub mod sampler;
/// Warping samples to distributions.
pub mod sampling;
/// The renderable scene.
pub mod scene;
/// The session with the coordinator.
pub mod service;
/// Geometric shapes.
pub mod shapes;
/// Test helpers: a tiny scene and a fake coordinator.
#[cfg(test)]
pub(crate) mod testing;
/// Textures.
pub mod textures;
/// One tile assignment, rendered.
pub mod tiles;

pub use config::WorkerConfig;
pub use render::{RenderOptions, Renderer};
pub use service::{run, WorkerError, WorkerSummary};
