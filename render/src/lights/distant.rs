//! `LightSource "distant"`: parallel light from one direction (pbrt-v3
//! `lights/distant.cpp`).

use super::LightSample;
use crate::interaction::Interaction;
use farm_common::geometry::Vec3;
use farm_common::Spectrum;

/// A directional light.
#[derive(Clone, Debug)]
pub struct DistantLight {
    /// Radiance (`L` × `scale`).
    pub l: Spectrum,
    /// Unit direction toward the light, in render space.
    pub w_light: Vec3,
    /// Radius of the scene's bounding sphere (set by preprocessing).
    pub world_radius: f32,
}

impl DistantLight {
    /// `L` from `w_light`; the shadow ray ends outside the scene.
    #[inline]
    pub fn sample_li(&self, r: &Interaction) -> Option<LightSample> {
        let p_outside = r.p + self.w_light * (2.0 * self.world_radius);
        Some(LightSample {
            li: self.l,
            wi: self.w_light,
            pdf: 1.0,
            p_light: Interaction { p: p_outside, time: r.time, ..Default::default() },
        })
    }
}
