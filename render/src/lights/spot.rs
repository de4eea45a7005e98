//! `LightSource "spot"`: a point light restricted to a cone with a smooth
//! falloff (pbrt-v3 `lights/spot.cpp`).

use super::LightSample;
use crate::interaction::Interaction;
use farm_common::geometry::{Transform, Vec3};
use farm_common::Spectrum;

/// A spotlight.
#[derive(Clone, Debug)]
pub struct SpotLight {
    /// Position in render space.
    pub p: Vec3,
    /// Light-from-render (the cone points along +z in light space).
    pub light_from_render: Transform,
    /// Intensity (`I` × `scale`).
    pub i: Spectrum,
    /// cos of `coneangle`.
    pub cos_total_width: f32,
    /// cos of `coneangle - conedelta`.
    pub cos_falloff_start: f32,
}

impl SpotLight {
    /// pbrt-v3's quartic falloff between the two cone angles.
    #[inline]
    pub fn falloff(&self, w: Vec3) -> f32 {
        let wl = self.light_from_render.vector(w).normalize();
        let cos_theta = wl.z;
        if cos_theta < self.cos_total_width {
            return 0.0;
        }
        if cos_theta >= self.cos_falloff_start {
            return 1.0;
        }
        let delta =
            (cos_theta - self.cos_total_width) / (self.cos_falloff_start - self.cos_total_width);
        (delta * delta) * (delta * delta)
    }

    /// Intensity times falloff over squared distance.
    #[inline]
    pub fn sample_li(&self, r: &Interaction) -> Option<LightSample> {
        let d = self.p - r.p;
        let wi = d.normalize();
        let li = self.i * self.falloff(-wi) / d.length_squared();
        Some(LightSample {
            li,
            wi,
            pdf: 1.0,
            p_light: Interaction { p: self.p, time: r.time, ..Default::default() },
        })
    }
}
