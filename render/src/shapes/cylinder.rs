//! Partial cylinders around z (pbrt-v3 `shapes/cylinder.cpp`):
//! `Shape "cylinder" "float radius" 1 "float zmin" -1 "float zmax" 1 "float phimax" 360`.

use super::efloat::{misses, nearest_hit, phi_of, quadratic, weingarten, EFloat, Placement};
use super::efloat3::EFloat3;
use crate::interaction::{Interaction, SurfaceInteraction};
use farm_common::geometry::{gamma, Bounds3f, Ray, Vec2, Vec3};
use farm_common::math;
use farm_common::scene::Params;

/// A cylinder of `radius` between `z_min` and `z_max`, open at both ends.
#[derive(Clone, Debug)]
pub struct Cylinder {
    /// Transforms and orientation.
    pub placement: Placement,
    /// Radius.
    pub radius: f32,
    /// Bottom.
    pub z_min: f32,
    /// Top.
    pub z_max: f32,
    /// Largest φ, in radians.
    pub phi_max: f32,
}

impl Cylinder {
    /// A `Shape "cylinder"` (pbrt-v3 `CreateCylinderShape`).
    pub fn create(params: &Params, pl: Placement) -> Self {
        let f = |n: &str, d: f32| params.float(n, d);
        let (radius, zmin, zmax) = (f("radius", 1.0), f("zmin", -1.0), f("zmax", 1.0));
        Cylinder::new(pl, radius, zmin, zmax, f("phimax", 360.0))
    }
}

impl Cylinder {
    /// pbrt-v3's constructor (φ in degrees).
    pub fn new(
        placement: Placement,
        radius: f32,
        z_min: f32,
        z_max: f32,
        phi_max_deg: f32,
    ) -> Self {
        Cylinder {
            placement,
            radius,
            z_min: z_min.min(z_max),
            z_max: z_min.max(z_max),
            phi_max: phi_max_deg.clamp(0.0, 360.0).to_radians(),
        }
    }

    /// Render-space bounds.
    pub fn bounds(&self) -> Bounds3f {
        let r = self.radius;
        self.placement
            .bounds(&Bounds3f::new(Vec3::new(-r, -r, self.z_min), Vec3::new(r, r, self.z_max)))
    }

    /// The hit in object space, with rays rejected on values first
    /// ([`misses`]) or not (the tests' reference).
    #[inline(always)]
    pub(super) fn hit(&self, r: &Ray, values_first: bool) -> Option<(Ray, EFloat, (Vec3, f32))> {
        let (ray, oe, de) = self.placement.object_ray(r);
        let eval = |t: f32| {
            let mut p = ray.at(t);
            // Clipped in z before the refinement and φ's arc tangent are
            // paid for (refining moves only x and y).
            if p.z < self.z_min || p.z > self.z_max {
                return None;
            }
            let hit_rad = (p.x * p.x + p.y * p.y).sqrt();
            p.x *= self.radius / hit_rad;
            p.y *= self.radius / hit_rad;
            let phi = phi_of(p.y, p.x);
            let clipped = phi > self.phi_max;
            (!clipped).then_some((p, phi))
        };
        if values_first {
            // The values of the bounded coefficients below, in their order.
            let (o, d) = (ray.o, ray.d);
            let a = d.x * d.x + d.y * d.y;
            let b = 2.0 * (d.x * o.x + d.y * o.y);
            let c = (o.x * o.x + o.y * o.y) - self.radius * self.radius;
            if misses(a, b, c, eval) {
                return None;
            }
        }
        let (o, d) = (EFloat3::new(ray.o, oe), EFloat3::new(ray.d, de));
        let a = d.mul(d).sum_xy();
        let b = 2.0 * d.mul(o).sum_xy();
        let c = o.mul(o).sum_xy() - self.radius * self.radius;
        let (t0, t1) = quadratic(a, b, c)?;
        let (t, h) = nearest_hit(t0, t1, ray.t_max, eval)?;
        Some((ray, t, h))
    }

    /// Nearest hit, in render space.
    pub fn intersect(&self, r: &Ray) -> Option<(f32, SurfaceInteraction)> {
        let (ray, t, (p, phi)) = self.hit(r, true)?;
        let u = phi / self.phi_max;
        let v = (p.z - self.z_min) / (self.z_max - self.z_min);
        let dpdu = Vec3::new(-self.phi_max * p.y, self.phi_max * p.x, 0.0);
        let dpdv = Vec3::new(0.0, 0.0, self.z_max - self.z_min);
        let d2pduu = -self.phi_max * self.phi_max * Vec3::new(p.x, p.y, 0.0);
        let (dndu, dndv) = weingarten(dpdu, dpdv, d2pduu, Vec3::ZERO, Vec3::ZERO);
        let p_error = gamma(3) * Vec3::new(p.x, p.y, 0.0).abs();
        let si = SurfaceInteraction::new(
            p,
            p_error,
            Vec2::new(u, v),
            -ray.d,
            dpdu,
            dpdv,
            dndu,
            dndv,
            r.time,
            self.placement.flip(),
        );
        Some((t.v, self.placement.render_hit(&si)))
    }

    /// Whether the ray hits.
    pub fn intersect_p(&self, r: &Ray) -> bool {
        self.hit(r, true).is_some()
    }

    /// Surface area (object space).
    pub fn area(&self) -> f32 {
        (self.z_max - self.z_min) * self.radius * self.phi_max
    }

    /// A uniform point and its area density.
    pub fn sample_area(&self, u: Vec2) -> (Interaction, f32) {
        let z = (1.0 - u.x) * self.z_min + u.x * self.z_max;
        let phi = u.y * self.phi_max;
        let (sin_phi, cos_phi) = math::sin_cos(phi);
        let mut p_obj = Vec3::new(self.radius * cos_phi, self.radius * sin_phi, z);
        let pl = &self.placement;
        let mut n = pl.render_from_object.normal(Vec3::new(p_obj.x, p_obj.y, 0.0)).normalize();
        if pl.reverse_orientation {
            n = -n;
        }
        let hit_rad = (p_obj.x * p_obj.x + p_obj.y * p_obj.y).sqrt();
        p_obj.x *= self.radius / hit_rad;
        p_obj.y *= self.radius / hit_rad;
        let err = gamma(3) * Vec3::new(p_obj.x, p_obj.y, 0.0).abs();
        let (p, p_error) = pl.render_from_object.point_with_error_in(p_obj, err);
        (Interaction { p, p_error, n, time: 0.0 }, 1.0 / self.area())
    }
}
