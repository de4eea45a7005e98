//! Partial cones (pbrt-v3 `shapes/cone.cpp`):
//! `Shape "cone" "float radius" 1 "float height" 1 "float phimax" 360`.

use super::efloat::{
    phi_of, quadric_hit, ray_point_error, weingarten, Arith, Coefficients, ObjectHit, Placement,
};
use crate::interaction::SurfaceInteraction;
use farm_common::geometry::{Bounds3f, Ray, Vec2, Vec3};
use farm_common::scene::Params;

/// A cone with its base of `radius` at z = 0 and apex at z = `height`.
#[derive(Clone, Debug)]
pub struct Cone {
    /// Transforms and orientation.
    pub placement: Placement,
    /// Base radius.
    pub radius: f32,
    /// Apex height.
    pub height: f32,
    /// Largest φ, in radians.
    pub phi_max: f32,
}

impl Cone {
    /// A `Shape "cone"` (pbrt-v3 `CreateConeShape`).
    pub fn create(params: &Params, pl: Placement) -> Self {
        let f = |n: &str, d: f32| params.float(n, d);
        let (radius, height) = (f("radius", 1.0), f("height", 1.0));
        Cone::new(pl, height, radius, f("phimax", 360.0))
    }
}

impl Cone {
    /// pbrt-v3's constructor (φ in degrees).
    pub fn new(placement: Placement, height: f32, radius: f32, phi_max_deg: f32) -> Self {
        Cone { placement, radius, height, phi_max: phi_max_deg.clamp(0.0, 360.0).to_radians() }
    }

    /// Render-space bounds.
    pub fn bounds(&self) -> Bounds3f {
        let r = self.radius;
        self.placement.bounds(&Bounds3f::new(Vec3::new(-r, -r, 0.0), Vec3::new(r, r, self.height)))
    }

    /// The hit in object space, with rays rejected on values first
    /// ([`quadric_hit`]) or not (the tests' reference).
    #[inline(always)]
    pub(super) fn hit(&self, r: &Ray, values_first: bool) -> Option<ObjectHit<(Vec3, f32)>> {
        let (ray, oe, de) = self.placement.object_ray(r);
        let eval = |t: f32| {
            let p = ray.at(t);
            // Clipped in z before φ's arc tangent is paid for.
            if p.z < 0.0 || p.z > self.height {
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
        let v = p.z / self.height;
        let dpdu = Vec3::new(-self.phi_max * p.y, self.phi_max * p.x, 0.0);
        let dpdv = Vec3::new(-p.x / (1.0 - v), -p.y / (1.0 - v), self.height);
        let d2pduu = -self.phi_max * self.phi_max * Vec3::new(p.x, p.y, 0.0);
        let d2pduv = self.phi_max / (1.0 - v) * Vec3::new(p.y, -p.x, 0.0);
        let (dndu, dndv) = weingarten(dpdu, dpdv, d2pduu, d2pduv, Vec3::ZERO);
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
        self.radius * (self.height * self.height + self.radius * self.radius).sqrt() * self.phi_max
            / 2.0
    }
}

impl Coefficients for Cone {
    #[inline(always)]
    fn coefficients<T: Arith>(&self, o: [T; 3], d: [T; 3]) -> (T, T, T) {
        let mut k = T::from(self.radius) / T::from(self.height);
        k = k * k;
        let h = T::from(self.height);
        let a = d[0] * d[0] + d[1] * d[1] - k * d[2] * d[2];
        let b = T::from(2.0) * (d[0] * o[0] + d[1] * o[1] - k * d[2] * (o[2] - h));
        let c = o[0] * o[0] + o[1] * o[1] - k * (o[2] - h) * (o[2] - h);
        (a, b, c)
    }
}
