//! `LightSource "goniometric"`: a point light whose intensity varies with
//! direction as a lat-long image gives it (pbrt-v3 `lights/goniometric.h`),
//! the way goniophotometric diagrams of real luminaires are measured.

use super::infinite::{spherical_phi, spherical_theta};
use super::LightSample;
use crate::image::MipMap;
use crate::interaction::Interaction;
use farm_common::geometry::{Transform, Vec2, Vec3};
use farm_common::Spectrum;
use std::f32::consts::PI;

/// A point light with an intensity map over the sphere of directions.
#[derive(Clone, Debug)]
pub struct GoniometricLight {
    /// Position in render space.
    pub p: Vec3,
    /// Light-from-render.
    pub light_from_render: Transform,
    /// Intensity (`I` × `scale`).
    pub i: Spectrum,
    /// The `mapname` image; `None` scales by one everywhere.
    pub map: Option<MipMap<Spectrum>>,
}

impl GoniometricLight {
    /// pbrt-v3 `GonioPhotometricLight::Scale`: the map's value toward render
    /// direction `w`. The map's poles lie on the light's y axis, so y and z
    /// swap before the spherical angles are taken.
    #[inline]
    pub fn scale(&self, w: Vec3) -> Spectrum {
        let Some(map) = &self.map else { return Spectrum::ONE };
        let mut wp = self.light_from_render.vector(w).normalize();
        std::mem::swap(&mut wp.y, &mut wp.z);
        let st = Vec2::new(spherical_phi(wp) * (0.5 / PI), spherical_theta(wp) * (1.0 / PI));
        map.lookup(st, 0.0)
    }

    /// Intensity toward `r`, over squared distance.
    #[inline]
    pub fn sample_li(&self, r: &Interaction) -> Option<LightSample> {
        let wi = (self.p - r.p).normalize();
        super::point_sample(self.p, self.i * self.scale(-wi), r)
    }

    /// A `LightSource "goniometric"` (pbrt-v3 `CreateGoniometricLight`):
    /// unlike `point`, it has no `from`; the transform places it.
    pub(super) fn create(
        p: &farm_common::scene::Params,
        render_from_light: &Transform,
        map: Option<MipMap<Spectrum>>,
    ) -> Self {
        let i = p.spectrum("I", Spectrum::ONE) * p.spectrum("scale", Spectrum::ONE);
        GoniometricLight {
            p: render_from_light.point(Vec3::ZERO),
            light_from_render: render_from_light.inverse(),
            i,
            map,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::image::WrapMode;
    use farm_common::math;

    /// A 4×2 map whose texels are their index: pbrt-v3's lookup puts
    /// s = φ/2π, t = θ/π with θ measured from the light's +y axis.
    #[test]
    fn the_map_is_indexed_by_angles_about_the_light_y_axis() {
        let texels: Vec<Spectrum> = (0..8).map(|i| Spectrum::splat(i as f32)).collect();
        let map = MipMap::new(4, 2, texels, false, 8.0, WrapMode::Repeat);
        let light = GoniometricLight {
            p: Vec3::ZERO,
            light_from_render: Transform::default(),
            i: Spectrum::ONE,
            map: Some(map.clone()),
        };
        for (w, st) in [
            // +y is θ = 0 (t = 0); -y is θ = π.
            (Vec3::Y, Vec2::new(0.0, 0.0)),
            (-Vec3::Y, Vec2::new(0.0, 1.0)),
            // +x: θ = π/2, φ = 0. +z (after the swap, light y): φ = π/2.
            (Vec3::X, Vec2::new(0.0, 0.5)),
            (Vec3::Z, Vec2::new(0.25, 0.5)),
            (-Vec3::X, Vec2::new(0.5, 0.5)),
            (Vec3::new(1.0, 1.0, -1.0), {
                let theta = math::acos(1.0f32 / 3f32.sqrt());
                Vec2::new(0.875, theta / PI)
            }),
        ] {
            let got = light.scale(w);
            let want = map.lookup(st, 0.0);
            assert!((got.r - want.r).abs() < 1e-4, "{w}: {} vs {} at {st}", got.r, want.r);
        }
        let none = GoniometricLight { map: None, ..light };
        assert_eq!(none.scale(Vec3::X), Spectrum::ONE);
    }
}
