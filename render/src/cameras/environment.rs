//! `Camera "environment"` (pbrt-v3 `cameras/environment.cpp`): every
//! direction around the camera, laid out on the film in latitude and
//! longitude, with the poles on the camera's y axis.

use super::projective::Common;
use crate::sampling::CameraSample;
use farm_common::geometry::{AnimatedTransform, Point2i, Ray, RayDifferential, Vec3};
use farm_common::math;
use std::f32::consts::PI;

/// A camera seeing the whole sphere of directions.
#[derive(Clone, Debug)]
pub struct EnvironmentCamera {
    /// Render-from-camera, possibly moving during the shutter interval.
    pub render_from_camera: AnimatedTransform,
    /// When the shutter opens.
    pub shutter_open: f32,
    /// When the shutter closes.
    pub shutter_close: f32,
    /// The film's full resolution, which spans 2π in x and π in y.
    resolution: (f32, f32),
}

impl EnvironmentCamera {
    /// A camera for a film of `full_resolution` pixels.
    pub fn new(
        render_from_camera: AnimatedTransform,
        shutter_open: f32,
        shutter_close: f32,
        full_resolution: Point2i,
    ) -> Self {
        EnvironmentCamera {
            render_from_camera,
            shutter_open,
            shutter_close,
            resolution: (full_resolution.x as f32, full_resolution.y as f32),
        }
    }

    /// The ray through a film sample (pbrt-v3 `GenerateRay`): row y is
    /// θ = π y / height from +y, column x is φ = 2π x / width from +x
    /// toward +z.
    #[inline]
    pub fn generate_ray(&self, s: &CameraSample) -> (f32, Ray) {
        let theta = PI * s.p_film.y / self.resolution.1;
        let phi = 2.0 * PI * s.p_film.x / self.resolution.0;
        let (sin_theta, cos_theta) = math::sin_cos(theta);
        let (sin_phi, cos_phi) = math::sin_cos(phi);
        let d = Vec3::new(sin_theta * cos_phi, cos_theta, sin_theta * sin_phi);
        let u = s.time;
        let time = (1.0 - u) * self.shutter_open + u * self.shutter_close;
        let ray = Ray::new(Vec3::ZERO, d, time);
        (1.0, self.render_from_camera.ray(&ray))
    }

    /// The ray with pbrt-v3's generic differentials (`Camera::
    /// GenerateRayDifferential`): rays a twentieth of a pixel over in x
    /// and y, scaled up to a whole pixel.
    #[inline]
    pub fn generate_ray_differential(&self, s: &CameraSample) -> (f32, RayDifferential) {
        let (w, ray) = self.generate_ray(s);
        let mut rd = RayDifferential::new(ray);
        let eps = 0.05f32;
        let mut shifted = *s;
        shifted.p_film.x += eps;
        let (_, rx) = self.generate_ray(&shifted);
        rd.rx_o = ray.o + (rx.o - ray.o) / eps;
        rd.rx_d = ray.d + (rx.d - ray.d) / eps;
        let mut shifted = *s;
        shifted.p_film.y += eps;
        let (_, ry) = self.generate_ray(&shifted);
        rd.ry_o = ray.o + (ry.o - ray.o) / eps;
        rd.ry_d = ray.d + (ry.d - ray.d) / eps;
        rd.has_differentials = true;
        (w, rd)
    }

    /// A `Camera "environment"` (pbrt-v3 `CreateEnvironmentCamera`): it
    /// reads the projective cameras' parameters and uses only the shutter.
    pub(super) fn create(rfc: AnimatedTransform, c: &Common, res: Point2i) -> Self {
        EnvironmentCamera::new(rfc, c.shutter_open, c.shutter_close, res)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use farm_common::geometry::{Transform, Vec2};

    fn sample(x: f32, y: f32) -> CameraSample {
        CameraSample { p_film: Vec2::new(x, y), p_lens: Vec2::splat(0.5), time: 0.5 }
    }

    /// The film's corners and centre: the top row looks up +y, the middle
    /// row round the horizon (+x at the left edge, -x at the centre, +z a
    /// quarter in), the bottom row down -y; differentials are a pixel's
    /// change of direction.
    #[test]
    fn the_film_is_a_latitude_longitude_map() {
        let c = EnvironmentCamera::new(
            AnimatedTransform::fixed(Transform::default()),
            0.0,
            1.0,
            Point2i::new(64, 32),
        );
        let dir = |x, y| c.generate_ray(&sample(x, y)).1.d;
        let near = |a: Vec3, b: Vec3| (a - b).length() < 1e-5;
        assert!(near(dir(10.0, 0.0), Vec3::Y));
        assert!(near(dir(10.0, 32.0), -Vec3::Y));
        assert!(near(dir(0.0, 16.0), Vec3::X));
        assert!(near(dir(16.0, 16.0), Vec3::Z));
        assert!(near(dir(32.0, 16.0), -Vec3::X));
        let (_, rd) = c.generate_ray_differential(&sample(16.0, 16.0));
        assert!(rd.has_differentials && rd.rx_o == Vec3::ZERO);
        // One pixel in x turns the horizon by 2π/64 toward -x.
        let step = 2.0 * PI / 64.0;
        assert!((rd.rx_d - rd.ray.d - Vec3::new(-step, 0.0, 0.0)).length() < 1e-3, "{}", rd.rx_d);
        assert!((rd.ry_d - rd.ray.d - Vec3::new(0.0, -PI / 32.0, 0.0)).length() < 1e-3);
        assert_eq!(c.generate_ray(&sample(1.0, 1.0)).1.time, 0.5);
    }
}
