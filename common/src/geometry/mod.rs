//! Geometry on glam's `Vec3`/`Vec2` (points, vectors and normals share the
//! type; the `Transform` methods say which is meant), with pbrt-v3's
//! floating-point error analysis (`core/geometry.h`, `core/transform.h`).

mod animated;
mod bounds;
mod float;
mod interval;
mod quaternion;
mod ray;
mod transform;

pub use animated::AnimatedTransform;
pub use bounds::{Bounds2f, Bounds2i, Bounds3f, Point2i};
pub use float::{
    coordinate_system, face_forward, gamma, next_float_down, next_float_up, offset_ray_origin,
    spherical_direction, MACHINE_EPSILON, SHADOW_EPSILON,
};
pub use glam::{DMat4, DVec3, Mat4, Vec2, Vec3, Vec4};
pub use interval::Interval;
pub use quaternion::{slerp, Quaternion};
pub use ray::{Ray, RayDifferential};
pub use transform::Transform;
