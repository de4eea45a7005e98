//! Cameras: `Camera "perspective"`, `"orthographic"` and `"environment"`
//! (pbrt-v3 `cameras/perspective.cpp`, `orthographic.cpp`,
//! `environment.cpp`), which turn film samples into rays in render space.

mod create;
mod environment;
mod orthographic;
mod perspective;
mod projective;
mod realistic;

pub use create::create;
pub use environment::EnvironmentCamera;
pub use orthographic::OrthographicCamera;
pub(crate) use perspective::perspective;
pub use perspective::PerspectiveCamera;
pub use projective::ProjectiveCamera;
pub use realistic::{read_lens_file, LensElement, PupilBounds, RealisticCamera};

use crate::sampling::CameraSample;
use farm_common::geometry::{Ray, RayDifferential};

/// A camera of any supported type.
#[derive(Clone, Debug)]
pub enum Camera {
    /// `Camera "perspective"`.
    Perspective(PerspectiveCamera),
    /// `Camera "orthographic"`.
    Orthographic(OrthographicCamera),
    /// `Camera "environment"`.
    Environment(EnvironmentCamera),
    /// `Camera "realistic"`.
    Realistic(Box<RealisticCamera>),
}

impl Camera {
    /// The ray for a film sample, in render space, and its weight.
    #[inline]
    pub fn generate_ray(&self, s: &CameraSample) -> (f32, Ray) {
        match self {
            Camera::Perspective(c) => c.generate_ray(s),
            Camera::Orthographic(c) => c.generate_ray(s),
            Camera::Environment(c) => c.generate_ray(s),
            Camera::Realistic(c) => c.generate_ray(s),
        }
    }

    /// The ray with rays one pixel over in x and y, and its weight.
    #[inline]
    pub fn generate_ray_differential(&self, s: &CameraSample) -> (f32, RayDifferential) {
        match self {
            Camera::Perspective(c) => c.generate_ray_differential(s),
            Camera::Orthographic(c) => c.generate_ray_differential(s),
            Camera::Environment(c) => c.generate_ray_differential(s),
            Camera::Realistic(c) => c.generate_ray_differential(s),
        }
    }

    /// Shutter open and close times.
    pub fn shutter(&self) -> (f32, f32) {
        match self {
            Camera::Environment(c) => (c.shutter_open, c.shutter_close),
            Camera::Realistic(c) => (c.shutter_open, c.shutter_close),
            _ => self.projective().map_or((0.0, 1.0), |p| (p.shutter_open, p.shutter_close)),
        }
    }

    /// The radius of the camera's lens; 0 for a pinhole.
    pub fn lens_radius(&self) -> f32 {
        self.projective().map_or(0.0, |p| p.lens_radius)
    }

    /// Whether the camera reads the sample's lens point.
    pub fn uses_lens(&self) -> bool {
        matches!(self, Camera::Realistic(_)) || self.lens_radius() > 0.0
    }

    /// The state shared by projective cameras, for those that are.
    pub fn projective(&self) -> Option<&ProjectiveCamera> {
        match self {
            Camera::Perspective(c) => Some(&c.base),
            Camera::Orthographic(c) => Some(&c.base),
            Camera::Environment(_) | Camera::Realistic(_) => None,
        }
    }
}
