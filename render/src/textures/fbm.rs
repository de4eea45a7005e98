//! Solid noise textures: `"fbm"`, `"wrinkled"` and `"windy"` (pbrt-v3
//! `FBmTexture`, `WrinkledTexture`, `WindyTexture`).

use super::mapping::Mapping3D;
use super::noise::{fbm, turbulence};
use crate::interaction::SurfaceInteraction;

/// Fractional Brownian motion.
#[derive(Clone, Debug, PartialEq)]
pub struct Fbm {
    /// The 3D mapping.
    pub mapping: Mapping3D,
    /// `"float roughness"` (default 0.5).
    pub omega: f32,
    /// `"integer octaves"` (default 8).
    pub octaves: i32,
}

impl Fbm {
    /// The value at `si`.
    pub fn evaluate(&self, si: &SurfaceInteraction) -> f32 {
        let (p, dx, dy) = self.mapping.map(si);
        fbm(p, dx, dy, self.omega, self.octaves)
    }
}

/// Turbulence.
#[derive(Clone, Debug, PartialEq)]
pub struct Wrinkled {
    /// The 3D mapping.
    pub mapping: Mapping3D,
    /// `"float roughness"` (default 0.5).
    pub omega: f32,
    /// `"integer octaves"` (default 8).
    pub octaves: i32,
}

impl Wrinkled {
    /// The value at `si`.
    pub fn evaluate(&self, si: &SurfaceInteraction) -> f32 {
        let (p, dx, dy) = self.mapping.map(si);
        turbulence(p, dx, dy, self.omega, self.octaves)
    }
}

/// Wind-blown waves.
#[derive(Clone, Debug, PartialEq)]
pub struct Windy {
    /// The 3D mapping.
    pub mapping: Mapping3D,
}

impl Windy {
    /// The value at `si`.
    pub fn evaluate(&self, si: &SurfaceInteraction) -> f32 {
        let (p, dx, dy) = self.mapping.map(si);
        let wind = fbm(0.1 * p, 0.1 * dx, 0.1 * dy, 0.5, 3);
        let wave = fbm(p, dx, dy, 0.5, 6);
        wind.abs() * wave
    }
}
