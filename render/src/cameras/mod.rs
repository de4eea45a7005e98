//! Cameras: `Camera "perspective"` and `Camera "orthographic"` (pbrt-v3
//! `cameras/perspective.cpp`, `cameras/orthographic.cpp`), which turn film
//! samples into rays in render space.

mod create;
mod orthographic;
mod perspective;
mod projective;

pub use create::create;
pub use orthographic::OrthographicCamera;
pub(crate) use perspective::perspective;
pub use perspective::PerspectiveCamera;
pub use projective::ProjectiveCamera;

use crate::sampling::CameraSample;
use farm_common::geometry::{Ray, RayDifferential};

/// A camera of any supported type.
#[derive(Clone, Debug)]
pub enum Camera {
    /// `Camera "perspective"`.
    Perspective(PerspectiveCamera),
    /// `Camera "orthographic"`.
    Orthographic(OrthographicCamera),
}

impl Camera {
    /// The ray for a film sample, in render space, and its weight.
    #[inline]
    pub fn generate_ray(&self, s: &CameraSample) -> (f32, Ray) {
        match self {
            Camera::Perspective(c) => c.generate_ray(s),
            Camera::Orthographic(c) => c.generate_ray(s),
        }
    }

    /// The ray with rays one pixel over in x and y, and its weight.
    #[inline]
    pub fn generate_ray_differential(&self, s: &CameraSample) -> (f32, RayDifferential) {
        match self {
            Camera::Perspective(c) => c.generate_ray_differential(s),
            Camera::Orthographic(c) => c.generate_ray_differential(s),
        }
    }

    /// Shutter open and close times.
    pub fn shutter(&self) -> (f32, f32) {
        let p = self.projective();
        (p.shutter_open, p.shutter_close)
    }

    /// The state shared by projective cameras.
    pub fn projective(&self) -> &ProjectiveCamera {
        match self {
            Camera::Perspective(c) => &c.base,
            Camera::Orthographic(c) => &c.base,
        }
    }
}
