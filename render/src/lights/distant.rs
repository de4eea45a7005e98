//! `LightSource "distant"`: parallel light from one direction (pbrt-v3
//! `lights/distant.cpp`).

use super::LightSample;
use crate::interaction::Interaction;
use farm_common::geometry::{Transform, Vec3};
use farm_common::scene::Params;
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

impl DistantLight {
    /// A `LightSource "distant"` (pbrt-v3 `CreateDistantLight`); its world
    /// radius is set once the scene's bounds are known.
    pub(super) fn create(p: &Params, render_from_light: &Transform) -> Self {
        let l = p.spectrum("L", Spectrum::ONE) * p.spectrum("scale", Spectrum::ONE);
        let from = p.point3("from", Vec3::ZERO);
        let to = p.point3("to", Vec3::Z);
        let w_light = render_from_light.vector(from - to).normalize();
        DistantLight { l, w_light, world_radius: 0.0 }
    }
}
