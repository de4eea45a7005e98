//! `LightSource "projection"`: a point light that projects an image through
//! a perspective frustum, like a slide projector (pbrt-v3
//! `lights/projection.cpp`).

use super::LightSample;
use crate::cameras::perspective;
use crate::image::MipMap;
use crate::interaction::Interaction;
use farm_common::geometry::{Transform, Vec2, Vec3};
use farm_common::Spectrum;

/// pbrt-v3's near plane for the projection.
const HITHER: f32 = 1e-3;
/// pbrt-v3's far plane for the projection.
const YON: f32 = 1e30;

/// A projector at the light's origin, looking down its +z axis.
#[derive(Clone, Debug)]
pub struct ProjectionLight {
    /// Position in render space.
    pub p: Vec3,
    /// Light-from-render.
    pub light_from_render: Transform,
    /// Intensity (`I` × `scale`).
    pub i: Spectrum,
    /// The projected image; `None` projects white.
    pub map: Option<MipMap<Spectrum>>,
    /// Screen-from-light: pbrt-v3's `Perspective(fov, 1e-3, 1e30)`.
    pub projection: Transform,
    /// The screen window: the shorter image side spans [-1, 1].
    pub screen_min: Vec2,
    /// Its upper corner.
    pub screen_max: Vec2,
    /// cos of the angle from the axis to the window's corner.
    pub cos_total_width: f32,
}

impl ProjectionLight {
    /// A projector for an image of `width × height` (1 × 1 without one)
    /// with a field of view `fov` degrees across the image's shorter side.
    pub fn new(
        render_from_light: &Transform,
        i: Spectrum,
        map: Option<(usize, usize, MipMap<Spectrum>)>,
        fov: f32,
    ) -> Self {
        let aspect = map.as_ref().map_or(1.0, |(w, h, _)| *w as f32 / *h as f32);
        let (screen_min, screen_max) = if aspect > 1.0 {
            (Vec2::new(-aspect, -1.0), Vec2::new(aspect, 1.0))
        } else {
            (Vec2::new(-1.0, -1.0 / aspect), Vec2::new(1.0, 1.0 / aspect))
        };
        let projection = perspective(fov, HITHER, YON);
        let corner = projection.inverse().point(Vec3::new(screen_max.x, screen_max.y, 0.0));
        ProjectionLight {
            p: render_from_light.point(Vec3::ZERO),
            light_from_render: render_from_light.inverse(),
            i,
            map: map.map(|(_, _, m)| m),
            projection,
            screen_min,
            screen_max,
            cos_total_width: corner.normalize().z,
        }
    }

    /// pbrt-v3 `ProjectionLight::Projection`: the image's value toward
    /// render direction `w`, black outside the frustum.
    #[inline]
    pub fn projection(&self, w: Vec3) -> Spectrum {
        let wl = self.light_from_render.vector(w);
        if wl.z < HITHER {
            return Spectrum::ZERO;
        }
        let p = self.projection.point_projective(wl);
        let (lo, hi) = (self.screen_min, self.screen_max);
        if !(p.x >= lo.x && p.x <= hi.x && p.y >= lo.y && p.y <= hi.y) {
            return Spectrum::ZERO;
        }
        let Some(map) = &self.map else { return Spectrum::ONE };
        let st = (Vec2::new(p.x, p.y) - lo) / (hi - lo);
        map.lookup(st, 0.0)
    }

    /// Intensity toward `r`, over squared distance.
    #[inline]
    pub fn sample_li(&self, r: &Interaction) -> Option<LightSample> {
        let wi = (self.p - r.p).normalize();
        super::point_sample(self.p, self.i * self.projection(-wi), r)
    }

    /// A `LightSource "projection"` (pbrt-v3 `CreateProjectionLight`).
    pub(super) fn create(
        p: &farm_common::scene::Params,
        render_from_light: &Transform,
        map: Option<(usize, usize, MipMap<Spectrum>)>,
    ) -> Self {
        let i = p.spectrum("I", Spectrum::ONE) * p.spectrum("scale", Spectrum::ONE);
        let fov = p.float("fov", 45.0);
        ProjectionLight::new(render_from_light, i, map, fov)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::image::WrapMode;

    /// The frustum of a 2:1 image at 90°: the shorter side spans ±45°, the
    /// longer ±atan 2; directions beyond, or behind, get nothing, and the
    /// image's corner texels land at the frustum's corners.
    #[test]
    fn the_image_fills_the_frustum_and_nothing_else() {
        let texels: Vec<Spectrum> = (0..8).map(|i| Spectrum::splat(i as f32 + 1.0)).collect();
        let map = MipMap::new(4, 2, texels, false, 8.0, WrapMode::Repeat);
        let l = ProjectionLight::new(&Transform::default(), Spectrum::ONE, Some((4, 2, map)), 90.0);
        assert_eq!((l.screen_min, l.screen_max), (Vec2::new(-2.0, -1.0), Vec2::new(2.0, 1.0)));
        // cos of the angle to (2, 1, 1).
        assert!((l.cos_total_width - 1.0 / 6f32.sqrt()).abs() < 1e-5);
        assert_eq!(l.projection(Vec3::new(0.0, 0.0, -1.0)), Spectrum::ZERO);
        assert_eq!(l.projection(Vec3::new(0.0, 1.01, 1.0)), Spectrum::ZERO);
        assert_eq!(l.projection(Vec3::new(2.02, 0.0, 1.0)), Spectrum::ZERO);
        assert!(l.projection(Vec3::new(1.98, 0.0, 1.0)).r > 0.0);
        // Screen (-1.5, -0.5) is the centre of texel (0, 0); (1.5, 0.5) of texel (3, 1).
        let first = l.projection(Vec3::new(-1.5, -0.5, 1.0)).r;
        let last = l.projection(Vec3::new(1.5, 0.5, 1.0)).r;
        assert!((first - 1.0).abs() < 1e-4 && (last - 8.0).abs() < 1e-4, "{first} {last}");
        let white = ProjectionLight::new(&Transform::default(), Spectrum::ONE, None, 30.0);
        assert_eq!(white.projection(Vec3::Z), Spectrum::ONE);
        assert_eq!(white.projection(Vec3::new(1.0, 0.0, 1.0)), Spectrum::ZERO);
    }
}
