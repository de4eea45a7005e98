//! `LightSource "point"`: an isotropic point light (pbrt-v3 `lights/point.cpp`).

use super::LightSample;
use crate::interaction::Interaction;
use farm_common::geometry::{Transform, Vec3};
use farm_common::scene::Params;
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

impl PointLight {
    /// A `LightSource "point"` (pbrt-v3 `CreatePointLight`).
    pub(super) fn create(p: &Params, render_from_light: &Transform) -> Self {
        let i = p.spectrum("I", Spectrum::ONE) * p.spectrum("scale", Spectrum::ONE);
        // pbrt-v3 applies `from` after the light's transform.
        let from = p.point3("from", Vec3::ZERO);
        PointLight { p: render_from_light.point(Vec3::ZERO) + from, i }
    }
}
