//! The farm's renderer: a scene description and a tile id in, a film tile
//! out. It builds the scene (shapes, BVH, camera, sampler, filter,
//! materials, textures, lights) from a `SceneDescription` once, then renders
//! any 16×16 tile with pbrt-v3's Whitted integrator. It knows nothing of
//! networks, processes or schedulers: no tokio, tonic or protocol types.
#![warn(missing_docs)]

/// Acceleration structures.
pub mod accel;
/// Reflection models.
pub mod bxdf;
/// Cameras.
pub mod cameras;
/// Errors building a renderer.
pub mod error;
/// What a scene uses, and so what a render can skip.
pub mod features;
/// Reconstruction filters.
pub mod filters;
/// Image textures' MIP maps.
pub mod image;
/// The Whitted integrator.
pub mod integrator;
/// Surface hits and points.
pub mod interaction;
/// Spline and Fourier interpolation.
pub mod interpolation;
/// Light sources.
pub mod lights;
/// Materials.
pub mod materials;
/// Primitives, aggregates and instances.
pub mod primitive;
/// Rendering tiles.
pub mod render;
/// Sample generators.
pub mod sampler;
/// Warping samples to distributions.
pub mod sampling;
/// Geometric shapes.
pub mod shapes;
/// Textures.
pub mod textures;
/// The built scene: primitives in their BVH, materials, textures, lights.
pub mod world;

pub use error::BuildError;
pub use render::{RenderOptions, Renderer};
