//! Partial paraboloids (pbrt-v3 `shapes/paraboloid.cpp`):
//! `Shape "paraboloid" "float radius" 1 "float zmin" 0 "float zmax" 1 "float phimax" 360`.

use super::efloat::{
    phi_of, quadric_hit, ray_point_error, weingarten, Arith, Coefficients, ObjectHit, Placement,
};
use crate::interaction::SurfaceInteraction;
use farm_common::geometry::{Bounds3f, Ray, Vec2, Vec3};
use farm_common::math;
use farm_common::scene::Params;

/// The paraboloid `z = zmax (x² + y²) / radius²`, clipped in z and φ.
#[derive(Clone, Debug)]
pub struct Paraboloid {
    /// Transforms and orientation.
    pub placement: Placement,
    /// Radius at `z_max`.
    pub radius: f32,
    /// Lower z clip.
    pub z_min: f32,
    /// Upper z clip.
    pub z_max: f32,
    /// Largest φ, in radians.
    pub phi_max: f32,
}

impl Paraboloid {
    /// A `Shape "paraboloid"` (pbrt-v3 `CreateParaboloidShape`).
    pub fn create(params: &Params, pl: Placement) -> Self {
        let f = |n: &str, d: f32| params.float(n, d);
        let (radius, zmin, zmax) = (f("radius", 1.0), f("zmin", 0.0), f("zmax", 1.0));
        Paraboloid::new(pl, radius, zmin, zmax, f("phimax", 360.0))
    }
}

impl Paraboloid {
    /// pbrt-v3's constructor (φ in degrees).
    pub fn new(placement: Placement, radius: f32, z0: f32, z1: f32, phi_max_deg: f32) -> Self {
        Paraboloid {
            placement,
            radius,
            z_min: z0.min(z1),
            z_max: z0.max(z1),
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
    /// ([`quadric_hit`]) or not (the tests' reference).
    #[inline(always)]
    pub(super) fn hit(&self, r: &Ray, values_first: bool) -> Option<ObjectHit<(Vec3, f32)>> {
        let (ray, oe, de) = self.placement.object_ray(r);
        let eval = |t: f32| {
            let p = ray.at(t);
            // Clipped in z before φ's arc tangent is paid for.
            if p.z < self.z_min || p.z > self.z_max {
                return None;
            }
            let phi = phi_of(p.y, p.x);
            let clipped = phi > self.phi_max;
            (!clipped).then_some((p, phi))
        };
        let (o, d, t, hp) = quadric_hit(self, &ray, (oe, de), values_first, eval)?;
        Some((ray, o, d, t, hp))
    }

    /// Nearest hit, in render space.
    pub fn intersect(&self, r: &Ray) -> Option<(f32, SurfaceInteraction)> {
        let (ray, o, d, t, (p, phi)) = self.hit(r, true)?;
        let u = phi / self.phi_max;
        let dz = self.z_max - self.z_min;
        let v = (p.z - self.z_min) / dz;
        let dpdu = Vec3::new(-self.phi_max * p.y, self.phi_max * p.x, 0.0);
        let dpdv = dz * Vec3::new(p.x / (2.0 * p.z), p.y / (2.0 * p.z), 1.0);
        let d2pduu = -self.phi_max * self.phi_max * Vec3::new(p.x, p.y, 0.0);
        let d2pduv = dz * self.phi_max * Vec3::new(-p.y / (2.0 * p.z), p.x / (2.0 * p.z), 0.0);
        let d2pdvv = -dz * dz * Vec3::new(p.x / (4.0 * p.z * p.z), p.y / (4.0 * p.z * p.z), 0.0);
        let (dndu, dndv) = weingarten(dpdu, dpdv, d2pduu, d2pduv, d2pdvv);
        let p_error = ray_point_error(&o, &d, t);
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
        let radius2 = self.radius * self.radius;
        let k = 4.0 * self.z_max / radius2;
        (radius2 * radius2 * self.phi_max / (12.0 * self.z_max * self.z_max))
            * (math::powf(k * self.z_max + 1.0, 1.5) - math::powf(k * self.z_min + 1.0, 1.5))
    }
}

impl Coefficients for Paraboloid {
    #[inline(always)]
    fn coefficients<T: Arith>(&self, o: [T; 3], d: [T; 3]) -> (T, T, T) {
        let rad = T::from(self.radius);
        let k = T::from(self.z_max) / (rad * rad);
        let a = k * (d[0] * d[0] + d[1] * d[1]);
        let b = T::from(2.0) * k * (d[0] * o[0] + d[1] * o[1]) - d[2];
        let c = k * (o[0] * o[0] + o[1] * o[1]) - o[2];
        (a, b, c)
    }
}
