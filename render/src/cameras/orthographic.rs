//! `Camera "orthographic"` (pbrt-v3 `cameras/orthographic.cpp`):
//!
//! ```text
//! Camera "orthographic" "float screenwindow" [-2 2 -1.5 1.5]
//! ```

use super::projective::{scale, translate, Common, ProjectiveCamera};
use crate::sampling::CameraSample;
use farm_common::geometry::{
    AnimatedTransform, Bounds2f, Point2i, Ray, RayDifferential, Transform, Vec3,
};

/// A camera with parallel rays along +z, optionally through a thin lens.
#[derive(Clone, Debug)]
pub struct OrthographicCamera {
    /// Transforms, lens and shutter.
    pub base: ProjectiveCamera,
    /// Camera-space change of the ray origin per pixel in x.
    dx_camera: Vec3,
    /// Camera-space change of the ray origin per pixel in y.
    dy_camera: Vec3,
}

/// pbrt-v3 `Orthographic(zNear, zFar)`: depth from zNear to zFar mapped to [0, 1].
pub fn orthographic(z_near: f32, z_far: f32) -> Transform {
    scale(1.0, 1.0, 1.0 / (z_far - z_near)).compose(&translate(Vec3::new(0.0, 0.0, -z_near)))
}

impl OrthographicCamera {
    /// A camera showing `screen_window` (camera-space units) on the film.
    pub fn new(
        render_from_camera: AnimatedTransform,
        screen_window: &Bounds2f,
        shutter_open: f32,
        shutter_close: f32,
        lens_radius: f32,
        focal_distance: f32,
        full_resolution: Point2i,
    ) -> Self {
        let base = ProjectiveCamera::new(
            render_from_camera,
            &orthographic(0.0, 1.0),
            screen_window,
            shutter_open,
            shutter_close,
            lens_radius,
            focal_distance,
            full_resolution,
        );
        let dx_camera = base.camera_from_raster.vector(Vec3::X);
        let dy_camera = base.camera_from_raster.vector(Vec3::Y);
        OrthographicCamera { base, dx_camera, dy_camera }
    }

    /// The ray through a film sample (pbrt-v3 `GenerateRay`).
    #[inline]
    pub fn generate_ray(&self, s: &CameraSample) -> (f32, Ray) {
        let b = &self.base;
        let p_camera = b.camera_from_raster.point(Vec3::new(s.p_film.x, s.p_film.y, 0.0));
        let mut ray = Ray::new(p_camera, Vec3::Z, 0.0);
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
        let p_camera = b.camera_from_raster.point(Vec3::new(s.p_film.x, s.p_film.y, 0.0));
        let mut ray = Ray::new(p_camera, Vec3::Z, 0.0);
        if b.lens_radius > 0.0 {
            b.refocus(&mut ray, s.p_lens);
        }
        let mut rd = RayDifferential::new(ray);
        if b.lens_radius > 0.0 {
            // As pbrt-v3: the focus distance along the refocused main ray.
            let p_lens = b.lens_point(s.p_lens);
            let ft = b.focal_distance / rd.ray.d.z;
            let p_focus = p_camera + self.dx_camera + ft * Vec3::Z;
            rd.rx_o = p_lens;
            rd.rx_d = (p_focus - p_lens).normalize();
            let p_focus = p_camera + self.dy_camera + ft * Vec3::Z;
            rd.ry_o = p_lens;
            rd.ry_d = (p_focus - p_lens).normalize();
        } else {
            rd.rx_o = rd.ray.o + self.dx_camera;
            rd.ry_o = rd.ray.o + self.dy_camera;
            rd.rx_d = rd.ray.d;
            rd.ry_d = rd.ray.d;
        }
        rd.ray.time = b.time(s.time);
        rd.has_differentials = true;
        (1.0, b.render_from_camera.ray_differential(&rd))
    }
}

impl OrthographicCamera {
    /// A `Camera "orthographic"` (pbrt-v3 `CreateOrthographicCamera`): it
    /// reads only the parameters every projective camera does.
    pub(super) fn create(rfc: AnimatedTransform, c: &Common, res: Point2i) -> Self {
        let (open, close) = (c.shutter_open, c.shutter_close);
        OrthographicCamera::new(rfc, &c.screen, open, close, c.lens_radius, c.focal_distance, res)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use farm_common::geometry::{Mat4, Vec2};
    use farm_common::rng::Rng;

    fn camera(xf: AnimatedTransform, lens: f32) -> OrthographicCamera {
        let w = Bounds2f { min: Vec2::new(-2.0, -1.0), max: Vec2::new(2.0, 1.0) };
        OrthographicCamera::new(xf, &w, 0.0, 1.0, lens, 4.0, Point2i::new(64, 32))
    }

    fn sample(x: f32, y: f32) -> CameraSample {
        CameraSample { p_film: Vec2::new(x, y), p_lens: Vec2::splat(0.5), time: 0.0 }
    }

    #[test]
    fn screen_window_maps_to_the_film() {
        let t = Transform::new(
            Mat4::from_translation(Vec3::new(0.0, 0.0, -5.0)) * Mat4::from_rotation_z(0.3),
        );
        let c = camera(AnimatedTransform::fixed(t), 0.0);
        let (_, r) = c.generate_ray(&sample(32.0, 16.0));
        assert!(
            (r.o - t.point(Vec3::ZERO)).length() < 1e-5
                && (r.d - t.vector(Vec3::Z)).length() < 1e-6
        );
        let c = camera(AnimatedTransform::fixed(Transform::default()), 0.0);
        let (_, r) = c.generate_ray(&sample(0.0, 0.0));
        assert!((r.o - Vec3::new(-2.0, 1.0, 0.0)).length() < 1e-6, "{:?}", r.o);
        let (_, r) = c.generate_ray(&sample(64.0, 32.0));
        assert!((r.o - Vec3::new(2.0, -1.0, 0.0)).length() < 1e-6, "{:?}", r.o);
    }

    #[test]
    fn differentials_are_the_neighbouring_pixels_rays() {
        let mut rng = Rng::new(8);
        let t = Transform::new(Mat4::from_translation(Vec3::ONE) * Mat4::from_rotation_x(0.4));
        let c = camera(AnimatedTransform::fixed(t), 0.0);
        for _ in 0..200 {
            let mut u = || rng.uniform_f32();
            let s = CameraSample {
                p_film: Vec2::new(64.0 * u(), 32.0 * u()),
                p_lens: Vec2::new(u(), u()),
                time: u(),
            };
            let (_, rd) = c.generate_ray_differential(&s);
            let (_, rx) = c.generate_ray(&CameraSample { p_film: s.p_film + Vec2::X, ..s });
            let (_, ry) = c.generate_ray(&CameraSample { p_film: s.p_film + Vec2::Y, ..s });
            assert!((rd.rx_o - rx.o).length() < 1e-5 && (rd.rx_d - rx.d).length() < 1e-6);
            assert!((rd.ry_o - ry.o).length() < 1e-5 && (rd.ry_d - ry.d).length() < 1e-6);
        }
    }

    #[test]
    fn lens_differentials_focus_as_pbrt_v3_does() {
        // pbrt-v3 aims the offset rays at depth focaldistance / d.z of the
        // refocused main ray, not at the plane of focus; kept for fidelity.
        let c = camera(AnimatedTransform::fixed(Transform::default()), 0.3);
        let s =
            CameraSample { p_film: Vec2::new(5.0, 7.0), p_lens: Vec2::new(0.9, 0.2), time: 0.0 };
        let (_, rd) = c.generate_ray_differential(&s);
        let p_camera = c.base.camera_from_raster.point(Vec3::new(5.0, 7.0, 0.0));
        let lens = c.base.lens_point(s.p_lens);
        let main_d = (p_camera + 4.0 * Vec3::Z - lens).normalize();
        let focus = p_camera + c.dx_camera + (4.0 / main_d.z) * Vec3::Z;
        assert!((rd.rx_o - lens).length() < 1e-6);
        assert!((rd.rx_d - (focus - lens).normalize()).length() < 1e-6);
        assert!((rd.ray.d - main_d).length() < 1e-6);
    }
}
