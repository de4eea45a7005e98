//! The farm's renderer: builds a scene from a `SceneDescription` and renders
//! 16×16 film tiles with pbrt-v3's Whitted integrator.
#![warn(missing_docs)]

/// Acceleration structures.
pub mod accel;
/// Reflection models.
pub mod bxdf;
/// Cameras.
pub mod cameras;
/// Errors building a renderer.
pub mod error;
/// Reconstruction filters.
pub mod filters;
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
/// Primitives, aggregates and instances.
pub mod primitive;
/// Rendering tiles.
pub mod render;
/// Sample generators.
pub mod sampler;
/// Warping samples to distributions.
pub mod sampling;
/// The renderable scene.
pub mod scene;
/// Geometric shapes.
pub mod shapes;
/// Textures.
pub mod textures;

pub use render::{RenderOptions, Renderer};
