//! `Camera "perspective"` (pbrt-v3 `cameras/perspective.cpp`):
//!
//! ```text
//! Camera "perspective" "float fov" 45 "float lensradius" 0.1 "float focaldistance" 5
//! ```

use super::projective::{scale, Common, ProjectiveCamera};
use crate::sampling::CameraSample;
use farm_common::geometry::{
    AnimatedTransform, Bounds2f, Mat4, Point2i, Ray, RayDifferential, Transform, Vec3, Vec4,
};
use farm_common::math;
use farm_common::scene::Params;

/// A pinhole or thin-lens camera with perspective projection.
#[derive(Clone, Debug)]
pub struct PerspectiveCamera {
    /// Transforms, lens and shutter.
    pub base: ProjectiveCamera,
    /// Camera-space change of the film point per pixel in x.
    dx_camera: Vec3,
    /// Camera-space change of the film point per pixel in y.
    dy_camera: Vec3,
}

/// pbrt-v3 `Perspective(fov, n, f)`: projection onto z = 1 with the field
/// of view `fov` (degrees) mapped to [-1, 1] and depth from n to f.
pub fn perspective(fov: f32, n: f32, f: f32) -> Transform {
    let persp = Mat4::from_cols(
        Vec4::new(1.0, 0.0, 0.0, 0.0),
        Vec4::new(0.0, 1.0, 0.0, 0.0),
        Vec4::new(0.0, 0.0, f / (f - n), 1.0),
        Vec4::new(0.0, 0.0, -f * n / (f - n), 0.0),
    );
    let inv_tan_ang = 1.0 / math::tan(fov.to_radians() / 2.0);
    scale(inv_tan_ang, inv_tan_ang, 1.0).compose(&Transform::new(persp))
}

impl PerspectiveCamera {
    /// A camera with field of view `fov` (degrees, across the shorter side
    /// of the default screen window).
    #[allow(clippy::too_many_arguments)]
    pub fn new(
        render_from_camera: AnimatedTransform,
        screen_window: &Bounds2f,
        shutter_open: f32,
        shutter_close: f32,
        lens_radius: f32,
        focal_distance: f32,
        fov: f32,
        full_resolution: Point2i,
    ) -> Self {
        let base = ProjectiveCamera::new(
            render_from_camera,
            &perspective(fov, 1e-2, 1000.0),
            screen_window,
            shutter_open,
            shutter_close,
            lens_radius,
            focal_distance,
            full_resolution,
        );
        let t = &base.camera_from_raster;
        let origin = t.point(Vec3::ZERO);
        let dx_camera = t.point(Vec3::X) - origin;
        let dy_camera = t.point(Vec3::Y) - origin;
        PerspectiveCamera { base, dx_camera, dy_camera }
    }

    /// The ray through a film sample (pbrt-v3 `GenerateRay`).
    #[inline]
    pub fn generate_ray(&self, s: &CameraSample) -> (f32, Ray) {
        let b = &self.base;
        let p_camera =
            b.camera_from_raster.point_projective(Vec3::new(s.p_film.x, s.p_film.y, 0.0));
        let mut ray = Ray::new(Vec3::ZERO, p_camera.normalize(), 0.0);
        if b.lens_radius > 0.0 {
            b.refocus(&mut ray, s.p_lens);
        }
        ray.time = b.time(s.time);
        (1.0, b.render_from_camera.ray(&ray))
    }

    /// The ray and its one-pixel offsets (pbrt-v3 `GenerateRayDifferential`).
    #[inline]
    pub fn generate_ray_differential(&self, s: &CameraSample) -> (f32, RayDifferential) {
        let b = &self.base;
        let p_camera =
            b.camera_from_raster.point_projective(Vec3::new(s.p_film.x, s.p_film.y, 0.0));
        let mut ray = Ray::new(Vec3::ZERO, p_camera.normalize(), 0.0);
        if b.lens_radius > 0.0 {
            b.refocus(&mut ray, s.p_lens);
        }
        let mut rd = RayDifferential::new(ray);
        if b.lens_radius > 0.0 {
            // Offset rays leave the same lens point toward their own focus points.
            let p_lens = b.lens_point(s.p_lens);
            let through_focus = |d: Vec3| {
                let d = d.normalize();
                let p_focus = (b.focal_distance / d.z) * d;
                (p_focus - p_lens).normalize()
            };
            rd.rx_o = p_lens;
            rd.ry_o = p_lens;
            rd.rx_d = through_focus(p_camera + self.dx_camera);
            rd.ry_d = through_focus(p_camera + self.dy_camera);
        } else {
            rd.rx_o = rd.ray.o;
            rd.ry_o = rd.ray.o;
            rd.rx_d = (p_camera + self.dx_camera).normalize();
            rd.ry_d = (p_camera + self.dy_camera).normalize();
        }
        rd.ray.time = b.time(s.time);
        rd.has_differentials = true;
        (1.0, b.render_from_camera.ray_differential(&rd))
    }
}

impl PerspectiveCamera {
    /// A `Camera "perspective"` (pbrt-v3 `CreatePerspectiveCamera`): the
    /// projective camera's parameters `c`, and `fov` or `halffov` from `p`.
    pub(super) fn create(p: &Params, rfc: AnimatedTransform, c: &Common, res: Point2i) -> Self {
        let mut fov = p.float("fov", 90.0);
        let half_fov = p.float("halffov", -1.0);
        if half_fov > 0.0 {
            // Structure Synth exports half of the full field of view.
            fov = 2.0 * half_fov;
        }
        let (open, close) = (c.shutter_open, c.shutter_close);
        let (lens, focus) = (c.lens_radius, c.focal_distance);
        PerspectiveCamera::new(rfc, &c.screen, open, close, lens, focus, fov, res)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use farm_common::geometry::Vec2;
    use farm_common::rng::Rng;

    fn window(aspect: f32) -> Bounds2f {
        if aspect > 1.0 {
            Bounds2f { min: Vec2::new(-aspect, -1.0), max: Vec2::new(aspect, 1.0) }
        } else {
            Bounds2f { min: Vec2::new(-1.0, -1.0 / aspect), max: Vec2::new(1.0, 1.0 / aspect) }
        }
    }

    fn camera(xf: AnimatedTransform, lens: f32, fov: f32, res: Point2i) -> PerspectiveCamera {
        let w = window(res.x as f32 / res.y as f32);
        PerspectiveCamera::new(xf, &w, 0.0, 1.0, lens, 3.0, fov, res)
    }

    fn sample(x: f32, y: f32) -> CameraSample {
        CameraSample { p_film: Vec2::new(x, y), p_lens: Vec2::splat(0.5), time: 0.0 }
    }

    fn placed() -> Transform {
        Transform::new(
            Mat4::from_translation(Vec3::new(1.0, 2.0, 3.0)) * Mat4::from_rotation_y(0.7),
        )
    }

    #[test]
    fn film_centre_looks_along_the_forward_axis() {
        let t = placed();
        let c = camera(AnimatedTransform::fixed(t), 0.0, 60.0, Point2i::new(64, 48));
        let (w, r) = c.generate_ray(&sample(32.0, 24.0));
        assert_eq!(w, 1.0);
        assert!((r.d - t.vector(Vec3::Z)).length() < 1e-6, "{:?}", r.d);
        assert!((r.o - t.point(Vec3::ZERO)).length() < 1e-5);
    }

    #[test]
    fn fov_spans_the_shorter_side() {
        let id = AnimatedTransform::fixed(Transform::default());
        let c = camera(id.clone(), 0.0, 90.0, Point2i::new(32, 32));
        let (_, r) = c.generate_ray(&sample(0.0, 0.0));
        // Raster y runs down, camera y up: the top-left corner is at (-1, 1, 1).
        assert!((math::atan2(r.d.x, r.d.z).to_degrees() + 45.0).abs() < 1e-4, "{:?}", r.d);
        assert!((math::atan2(r.d.y, r.d.z).to_degrees() - 45.0).abs() < 1e-4, "{:?}", r.d);
        let c = camera(id, 0.0, 60.0, Point2i::new(64, 32));
        let t = math::tan(30.0f32.to_radians());
        let (_, r) = c.generate_ray(&sample(0.0, 16.0));
        assert!((r.d.x / r.d.z + 2.0 * t).abs() < 1e-5 && r.d.y.abs() < 1e-6);
        let (_, r) = c.generate_ray(&sample(32.0, 32.0));
        assert!((r.d.y / r.d.z + t).abs() < 1e-5 && r.d.x.abs() < 1e-6);
    }

    #[test]
    fn lens_rays_meet_on_the_plane_of_focus() {
        let c =
            camera(AnimatedTransform::fixed(Transform::default()), 0.2, 50.0, Point2i::new(40, 30));
        let mut rng = Rng::new(2);
        let s0 = sample(7.3, 21.9);
        let (_, r0) = c.generate_ray(&s0);
        let focus = r0.at(3.0 / r0.d.z);
        for _ in 0..50 {
            let s = CameraSample { p_lens: Vec2::new(rng.uniform_f32(), rng.uniform_f32()), ..s0 };
            let (_, r) = c.generate_ray(&s);
            // The origin is on the lens, up to the transform's error offset.
            assert!(r.o.z.abs() < 1e-6 && r.o.truncate().length() <= 0.2 + 1e-6);
            assert!((r.at(3.0 / r.d.z) - focus).length() < 1e-4);
        }
    }

    #[test]
    fn differentials_are_the_neighbouring_pixels_rays() {
        let mut rng = Rng::new(4);
        let moving =
            AnimatedTransform::new(placed(), 0.0, Transform::new(Mat4::from_rotation_x(0.5)), 1.0);
        for (xf, lens) in [
            (AnimatedTransform::fixed(placed()), 0.0),
            (AnimatedTransform::fixed(placed()), 0.25),
            (moving.clone(), 0.0),
            (moving, 0.25),
        ] {
            let c = camera(xf, lens, 45.0, Point2i::new(50, 40));
            for _ in 0..200 {
                let mut u = || rng.uniform_f32();
                let s = CameraSample {
                    p_film: Vec2::new(50.0 * u(), 40.0 * u()),
                    p_lens: Vec2::new(u(), u()),
                    time: u(),
                };
                let (_, rd) = c.generate_ray_differential(&s);
                let (_, r) = c.generate_ray(&s);
                assert!(rd.has_differentials && rd.ray == r);
                let (_, rx) = c.generate_ray(&CameraSample { p_film: s.p_film + Vec2::X, ..s });
                let (_, ry) = c.generate_ray(&CameraSample { p_film: s.p_film + Vec2::Y, ..s });
                assert!((rd.rx_o - rx.o).length() < 1e-4 && (rd.rx_d - rx.d).length() < 1e-4);
                assert!((rd.ry_o - ry.o).length() < 1e-4 && (rd.ry_d - ry.d).length() < 1e-4);
            }
        }
    }
}
