//! Geometric shapes (pbrt-v3 `core/shape.h` and `shapes/*`): ray
//! intersection with conservative error bounds, area sampling and the
//! solid-angle densities area lights need. Everything returned is in render space.

mod cone;
mod create;
mod curve;
mod curve_segments;
mod cylinder;
mod disk;
mod efloat;
mod efloat3;
mod heightfield;
mod hyperboloid;
mod loopsubdiv;
mod mesh;
mod nurbs;
mod paraboloid;
#[cfg(test)]
mod quadric_tests;
mod sphere;
mod triangle;
pub mod triangle4;

pub use cone::Cone;
pub use create::{create, create_in};
pub use curve::{Curve, CurveCommon, CurveType};
pub use cylinder::Cylinder;
pub use disk::Disk;
pub use efloat::{quadratic, EFloat, Placement};
pub use hyperboloid::Hyperboloid;
pub use loopsubdiv::loop_subdivide;
pub use paraboloid::Paraboloid;
pub use sphere::Sphere;
pub use triangle::{AlphaMask, AlphaTexture, TriRay, Triangle, TriangleMesh};

use crate::interaction::{Interaction, SurfaceInteraction};

use farm_common::geometry::{Bounds3f, Ray, Vec2, Vec3};
use std::sync::Arc;

/// A shape of any kind; dispatch is a `match`, with no allocation per ray.
#[derive(Clone, Debug)]
pub enum Shape {
    /// `sphere`
    Sphere(Box<Sphere>),
    /// `cylinder`
    Cylinder(Box<Cylinder>),
    /// `disk`
    Disk(Box<Disk>),
    /// `cone`
    Cone(Box<Cone>),
    /// `paraboloid`
    Paraboloid(Box<Paraboloid>),
    /// `hyperboloid`
    Hyperboloid(Box<Hyperboloid>),
    /// One triangle of a `trianglemesh`, `loopsubdiv` or `heightfield`;
    /// [`Shape::triangle`] borrows it as a [`Triangle`]. Its fields are
    /// inline, not a struct, so the tag fits beside the indices: a shape
    /// is 24 bytes, not 32, and a primitive 32.
    Triangle {
        /// The mesh.
        mesh: Arc<TriangleMesh>,
        /// Vertex indices into the mesh.
        v: [u32; 3],
    },
    /// One segment of a `curve`.
    Curve(Curve),
}

macro_rules! dispatch {
    ($self:ident, $s:ident => $e:expr) => {
        match $self {
            Shape::Sphere($s) => $e,
            Shape::Cylinder($s) => $e,
            Shape::Disk($s) => $e,
            Shape::Cone($s) => $e,
            Shape::Paraboloid($s) => $e,
            Shape::Hyperboloid($s) => $e,
            Shape::Triangle { mesh, v } => {
                let $s = &Triangle { mesh, v: *v };
                $e
            }
            Shape::Curve($s) => $e,
        }
    };
}

impl Shape {
    /// The triangle, if this is one.
    #[inline(always)]
    pub fn triangle(&self) -> Option<Triangle<'_>> {
        match self {
            Shape::Triangle { mesh, v } => Some(Triangle { mesh, v: *v }),
            _ => None,
        }
    }

    /// Bounds in render space.
    pub fn bounds(&self) -> Bounds3f {
        dispatch!(self, s => s.bounds())
    }

    /// The nearest hit with `t < ray.t_max`: its `t` and the interaction
    /// (render space, `wo = -ray.d` normalised, `prim` left 0).
    #[inline]
    pub fn intersect(&self, ray: &Ray) -> Option<(f32, SurfaceInteraction)> {
        dispatch!(self, s => s.intersect(ray))
    }

    /// [`Shape::intersect`] with the interaction written to `si`; `si` is
    /// left alone on a miss.
    #[inline(always)]
    pub fn intersect_into(&self, ray: &Ray, si: &mut SurfaceInteraction) -> Option<f32> {
        if let Shape::Sphere(s) = self {
            return s.intersect_into(ray, si);
        }
        let (t, hit) = self.intersect(ray)?;
        *si = hit;
        Some(t)
    }

    /// Like [`Shape::intersect`] but ignoring alpha masks (pbrt-v3 `Pdf`'s lookup).
    #[inline]
    pub fn intersect_no_alpha(&self, ray: &Ray) -> Option<(f32, SurfaceInteraction)> {
        match self {
            Shape::Triangle { mesh, v } => Triangle { mesh, v: *v }.intersect_with(ray, false),
            _ => dispatch!(self, s => s.intersect(ray)),
        }
    }

    /// Whether anything is hit with `t < ray.t_max`.
    #[inline]
    pub fn intersect_p(&self, ray: &Ray) -> bool {
        dispatch!(self, s => s.intersect_p(ray))
    }

    /// [`Shape::intersect_p`] with `ray` prepared for triangles as `tr`.
    #[inline(always)]
    pub fn intersect_p_prepared(&self, ray: &Ray, tr: &TriRay) -> bool {
        match self {
            Shape::Triangle { mesh, v } => Triangle { mesh, v: *v }.intersect_p_prepared(ray, tr),
            _ => dispatch!(self, s => s.intersect_p(ray)),
        }
    }

    /// Surface area (for quadrics and curves, in object space as in pbrt-v3).
    pub fn area(&self) -> f32 {
        dispatch!(self, s => s.area())
    }

    /// A point on the surface with its normal and error bound, and the
    /// density with respect to area. pbrt-v3 cannot sample cones,
    /// paraboloids, hyperboloids or curves; those return density 0.
    #[inline(always)]
    pub fn sample_area(&self, u: Vec2) -> (Interaction, f32) {
        match self {
            Shape::Sphere(s) => s.sample_area(u),
            Shape::Cylinder(s) => s.sample_area(u),
            Shape::Disk(s) => s.sample_area(u),
            Shape::Triangle { mesh, v } => Triangle { mesh, v: *v }.sample_area(u),
            _ => (Interaction::default(), 0.0),
        }
    }

    /// A point sampled for lighting `reference`, with its density with
    /// respect to solid angle at `reference`; `None` when that density is 0 or infinite.
    #[inline(always)]
    pub fn sample_from(&self, reference: &Interaction, u: Vec2) -> Option<(Interaction, f32)> {
        match self {
            Shape::Sphere(s) => s.sample_from(reference, u),
            _ => {
                let (it, pdf) = self.sample_area(u);
                area_to_solid_angle(reference, it, pdf)
            }
        }
    }

    /// [`Shape::sample_from`] for an area light that keeps its shape's
    /// `inv_area` (1 / [`Shape::area`], the density [`Shape::sample_area`]
    /// gives) and, for a triangle, its [`Triangle::geometric_normal`]: a
    /// triangle's point is sampled without working out its area or its
    /// plane again (two cross products, two square roots and two divisions
    /// a sample).
    #[inline(always)]
    pub fn sample_from_light(
        &self,
        reference: &Interaction,
        u: Vec2,
        inv_area: f32,
        geometric_normal: Vec3,
    ) -> Option<(Interaction, f32)> {
        match self {
            Shape::Triangle { mesh, v } => {
                let it = Triangle { mesh, v: *v }.sample_point_facing(u, geometric_normal);
                area_to_solid_angle(reference, it, inv_area)
            }
            _ => self.sample_from(reference, u),
        }
    }

    /// What [`Shape::sample_from_light`] takes as `geometric_normal`: a
    /// triangle's [`Triangle::geometric_normal`], zero for other shapes.
    pub fn light_normal(&self) -> Vec3 {
        match self {
            Shape::Triangle { mesh, v } => Triangle { mesh, v: *v }.geometric_normal(),
            _ => Vec3::ZERO,
        }
    }

    /// Solid-angle density at `reference` of sampling direction `wi`.
    pub fn pdf_from(&self, reference: &Interaction, wi: Vec3) -> f32 {
        match self {
            Shape::Sphere(s) => s.pdf_from(self, reference, wi),
            _ => generic_pdf(self, reference, wi),
        }
    }
}

/// Converts an area-density sample to solid angle at `reference` (pbrt-v3 `Shape::Sample(ref, u)`).
#[inline(always)]
fn area_to_solid_angle(
    reference: &Interaction,
    mut it: Interaction,
    pdf: f32,
) -> Option<(Interaction, f32)> {
    it.time = reference.time;
    let wi = it.p - reference.p;
    if pdf == 0.0 || wi.length_squared() == 0.0 {
        return None;
    }
    let wi = wi.normalize();
    let pdf = pdf * reference.p.distance_squared(it.p) / it.n.dot(-wi).abs();
    (pdf.is_finite() && pdf > 0.0).then_some((it, pdf))
}

/// pbrt-v3 `Shape::Pdf`: trace `wi` and convert 1/area to solid angle.
fn generic_pdf(shape: &Shape, reference: &Interaction, wi: Vec3) -> f32 {
    let ray = reference.spawn_ray(wi);
    let Some((_, isect)) = shape.intersect_no_alpha(&ray) else {
        return 0.0;
    };
    let pdf = reference.p.distance_squared(isect.it.p) / (isect.it.n.dot(-wi).abs() * shape.area());
    if pdf.is_infinite() {
        0.0
    } else {
        pdf
    }
}
