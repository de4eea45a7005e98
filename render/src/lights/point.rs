//! `LightSource "point"`: an isotropic point light (pbrt-v3 `lights/point.cpp`).

use super::LightSample;
use crate::interaction::Interaction;
use farm_common::geometry::Vec3;
use farm_common::Spectrum;

/// A point emitting intensity `i` in every direction.
#[derive(Clone, Debug)]
pub struct PointLight {
    /// Position in render space.
    pub p: Vec3,
    /// Radiant intensity (`I` × `scale`).
    pub i: Spectrum,
}

impl PointLight {
    /// Intensity over squared distance, toward the light.
    #[inline]
    pub fn sample_li(&self, r: &Interaction) -> Option<LightSample> {
        let d = self.p - r.p;
        let wi = d.normalize();
        let li = self.i / d.length_squared();
        Some(LightSample {
            li,
            wi,
            pdf: 1.0,
            p_light: Interaction { p: self.p, time: r.time, ..Default::default() },
        })
    }
}
