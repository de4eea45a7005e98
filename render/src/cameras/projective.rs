//! What perspective and orthographic cameras share (pbrt-v3
//! `ProjectiveCamera`, `core/camera.h`): the raster-to-camera transform,
//! the thin lens and the shutter.

use crate::sampling::concentric_sample_disk;
use farm_common::geometry::{
    AnimatedTransform, Bounds2f, Mat4, Point2i, Ray, Transform, Vec2, Vec3,
};

/// A camera whose rays come from a projection of the film onto a screen window.
#[derive(Clone, Debug)]
pub struct ProjectiveCamera {
    /// Render-from-camera, possibly moving during the shutter interval.
    pub render_from_camera: AnimatedTransform,
    /// When the shutter opens.
    pub shutter_open: f32,
    /// When the shutter closes.
    pub shutter_close: f32,
    /// Raster (pixel) coordinates to camera space (pbrt-v3 `RasterToCamera`).
    pub camera_from_raster: Transform,
    /// Radius of the thin lens; 0 for a pinhole.
    pub lens_radius: f32,
    /// Distance to the plane in focus.
    pub focal_distance: f32,
}

/// pbrt-v3 `Scale`, with its exact inverse.
pub(super) fn scale(x: f32, y: f32, z: f32) -> Transform {
    Transform {
        m: Mat4::from_scale(Vec3::new(x, y, z)),
        inv: Mat4::from_scale(Vec3::new(1.0 / x, 1.0 / y, 1.0 / z)),
    }
}

/// pbrt-v3 `Translate`, with its exact inverse.
pub(super) fn translate(d: Vec3) -> Transform {
    Transform { m: Mat4::from_translation(d), inv: Mat4::from_translation(-d) }
}

impl ProjectiveCamera {
    /// A camera projecting with `screen_from_camera` and showing
    /// `screen_window` on a film of `full_resolution` pixels.
    #[allow(clippy::too_many_arguments)]
    pub fn new(
        render_from_camera: AnimatedTransform,
        screen_from_camera: &Transform,
        screen_window: &Bounds2f,
        shutter_open: f32,
        shutter_close: f32,
        lens_radius: f32,
        focal_distance: f32,
        full_resolution: Point2i,
    ) -> Self {
        let (lo, hi) = (screen_window.min, screen_window.max);
        let raster_from_screen = scale(full_resolution.x as f32, full_resolution.y as f32, 1.0)
            .compose(&scale(1.0 / (hi.x - lo.x), 1.0 / (lo.y - hi.y), 1.0))
            .compose(&translate(Vec3::new(-lo.x, -hi.y, 0.0)));
        let camera_from_raster =
            screen_from_camera.inverse().compose(&raster_from_screen.inverse());
        ProjectiveCamera {
            render_from_camera,
            shutter_open,
            shutter_close,
            camera_from_raster,
            lens_radius,
            focal_distance,
        }
    }

    /// The sample's time within the shutter interval.
    #[inline]
    pub(super) fn time(&self, u: f32) -> f32 {
        (1.0 - u) * self.shutter_open + u * self.shutter_close
    }

    /// The point on the lens for a lens sample.
    #[inline]
    pub(super) fn lens_point(&self, u: Vec2) -> Vec3 {
        let p = self.lens_radius * concentric_sample_disk(u);
        Vec3::new(p.x, p.y, 0.0)
    }

    /// Moves a camera-space ray's origin onto the lens and aims it through
    /// its point on the plane of focus.
    #[inline]
    pub(super) fn refocus(&self, ray: &mut Ray, u: Vec2) {
        let ft = self.focal_distance / ray.d.z;
        let p_focus = ray.at(ft);
        ray.o = self.lens_point(u);
        ray.d = (p_focus - ray.o).normalize();
    }
}
