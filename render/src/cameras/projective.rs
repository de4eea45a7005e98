//! What perspective and orthographic cameras share (pbrt-v3
//! `ProjectiveCamera`, `core/camera.h`): the raster-to-camera transform,
//! the thin lens and the shutter.

use crate::sampling::concentric_sample_disk;
use farm_common::film::FilmGeometry;
use farm_common::geometry::{
    AnimatedTransform, Bounds2f, Mat4, Point2i, Ray, Transform, Vec2, Vec3,
};
use farm_common::scene::{Entity, Params, Warning};

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

/// Parameters both projective cameras read.
pub(super) struct Common {
    pub(super) shutter_open: f32,
    pub(super) shutter_close: f32,
    pub(super) lens_radius: f32,
    pub(super) focal_distance: f32,
    pub(super) screen: Bounds2f,
}

/// The shutter interval every camera reads (`shutteropen`, `shutterclose`),
/// swapped with pbrt-v3's warning when given backwards.
pub(super) fn shutter(p: &Params, entity: &Entity, warnings: &mut Vec<Warning>) -> (f32, f32) {
    let mut shutter_open = p.float("shutteropen", 0.0);
    let mut shutter_close = p.float("shutterclose", 1.0);
    if shutter_close < shutter_open {
        warnings.push(Warning::at(
            &entity.loc,
            format!("Shutter close time [{shutter_close:.6}] < shutter open [{shutter_open:.6}].  Swapping them."),
        ));
        std::mem::swap(&mut shutter_open, &mut shutter_close);
    }
    (shutter_open, shutter_close)
}

/// Reads the parameters every projective camera takes (pbrt-v3's
/// shutter, lens and screen-window set-up in `Create*Camera`).
pub(super) fn common(
    p: &Params,
    entity: &Entity,
    film: &FilmGeometry,
    focal_default: f32,
    warnings: &mut Vec<Warning>,
) -> Common {
    let (shutter_open, shutter_close) = shutter(p, entity, warnings);
    let lens_radius = p.float("lensradius", 0.0);
    let focal_distance = p.float("focaldistance", focal_default);
    let res = film.full_resolution;
    let frame = p.float("frameaspectratio", res.x as f32 / res.y as f32);
    let mut screen = if frame > 1.0 {
        Bounds2f { min: Vec2::new(-frame, -1.0), max: Vec2::new(frame, 1.0) }
    } else {
        Bounds2f { min: Vec2::new(-1.0, -1.0 / frame), max: Vec2::new(1.0, 1.0 / frame) }
    };
    if let Some(sw) = p.floats("screenwindow") {
        if let [x0, x1, y0, y1] = *sw {
            screen = Bounds2f { min: Vec2::new(x0, y0), max: Vec2::new(x1, y1) };
        } else {
            warnings.push(Warning::at(&entity.loc, "\"screenwindow\" should have four values"));
        }
    }
    Common { shutter_open, shutter_close, lens_radius, focal_distance, screen }
}
