//! The farm's renderer: builds a scene from a `SceneDescription` and renders
//! 16×16 film tiles with pbrt-v3's Whitted integrator.
#![warn(missing_docs)]

/// Surface hits and points.
pub mod interaction;
/// Warping samples to distributions.
pub mod sampling;
