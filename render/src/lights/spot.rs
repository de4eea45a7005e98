//! `LightSource "spot"`: a point light restricted to a cone with a smooth
//! falloff (pbrt-v3 `lights/spot.cpp`).

use super::LightSample;
use crate::interaction::Interaction;
use farm_common::geometry::{coordinate_system, Mat4, Transform, Vec3, Vec4};
use farm_common::math;
use farm_common::scene::Params;
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
    /// cos of `coneangle - conedeltaangle`.
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

impl SpotLight {
    /// A `LightSource "spot"` (pbrt-v3 `CreateSpotLight`).
    pub(super) fn create(p: &Params, render_from_light: &Transform) -> Self {
        let i = p.spectrum("I", Spectrum::ONE) * p.spectrum("scale", Spectrum::ONE);
        let cone = p.float("coneangle", 30.0);
        let delta = p.float("conedeltaangle", 5.0);
        let from = p.point3("from", Vec3::ZERO);
        let to = p.point3("to", Vec3::Z);
        let dir = (to - from).normalize();
        let (du, dv) = coordinate_system(dir);
        // Rows du, dv, dir: maps dir to +z.
        let dir_to_z = Mat4::from_cols(
            Vec4::new(du.x, dv.x, dir.x, 0.0),
            Vec4::new(du.y, dv.y, dir.y, 0.0),
            Vec4::new(du.z, dv.z, dir.z, 0.0),
            Vec4::W,
        );
        let light_m = render_from_light.m * Mat4::from_translation(from) * dir_to_z.transpose();
        let t = Transform::new(light_m);
        SpotLight {
            p: t.point(Vec3::ZERO),
            light_from_render: t.inverse(),
            i,
            cos_total_width: math::cos(cone.to_radians()),
            cos_falloff_start: math::cos((cone - delta).to_radians()),
        }
    }
}
