//! Hyperboloids of one sheet swept from a line segment (pbrt-v3
//! `shapes/hyperboloid.cpp`): `Shape "hyperboloid" "point p1" [0 0 0] "point p2" [1 1 1] "float phimax" 360`.

use super::efloat::{
    phi_of, quadric_hit, ray_point_error, weingarten, Arith, Coefficients, ObjectHit, Placement,
};
use crate::interaction::SurfaceInteraction;
use farm_common::geometry::{Bounds3f, Ray, Vec2, Vec3};
use farm_common::math;
use farm_common::scene::{Params, Warning};

/// The surface swept by rotating segment `p1`–`p2` about z.
#[derive(Clone, Debug)]
pub struct Hyperboloid {
    /// Transforms and orientation.
    pub placement: Placement,
    /// First end of the segment.
    pub p1: Vec3,
    /// Second end of the segment.
    pub p2: Vec3,
    /// Lower z.
    pub z_min: f32,
    /// Upper z.
    pub z_max: f32,
    /// Largest φ, in radians.
    pub phi_max: f32,
    /// Largest radius.
    pub r_max: f32,
    /// Implicit coefficient of x² + y².
    pub ah: f32,
    /// Implicit coefficient of z².
    pub ch: f32,
}

impl Hyperboloid {
    /// A `Shape "hyperboloid"` (pbrt-v3 `CreateHyperboloidShape`); a
    /// degenerate one is a warning and no shape.
    pub fn create(params: &Params, pl: Placement, warnings: &mut Vec<Warning>) -> Option<Self> {
        let p1 = params.point3("p1", Vec3::ZERO);
        let p2 = params.point3("p2", Vec3::ONE);
        let h = Hyperboloid::new(pl, p1, p2, params.float("phimax", 360.0));
        if h.is_none() {
            warnings.push(Warning {
                loc: None,
                message: "Degenerate hyperboloid: cannot compute its implicit form. Ignoring."
                    .into(),
            });
        }
        h
    }
}

impl Hyperboloid {
    /// pbrt-v3's constructor (φ in degrees). `None` when the implicit
    /// coefficients cannot be found (a degenerate segment, on which pbrt-v3 loops forever).
    pub fn new(placement: Placement, point1: Vec3, point2: Vec3, phi_max_deg: f32) -> Option<Self> {
        let (mut p1, mut p2) = (point1, point2);
        let radius1 = (p1.x * p1.x + p1.y * p1.y).sqrt();
        let radius2 = (p2.x * p2.x + p2.y * p2.y).sqrt();
        let (z_min, z_max) = (p1.z.min(p2.z), p1.z.max(p2.z));
        if p2.z == 0.0 {
            std::mem::swap(&mut p1, &mut p2);
        }
        let mut pp = p1;
        let (mut ah, mut ch) = (f32::NAN, f32::NAN);
        for _ in 0..64 {
            pp += 2.0 * (p2 - p1);
            let xy1 = pp.x * pp.x + pp.y * pp.y;
            let xy2 = p2.x * p2.x + p2.y * p2.y;
            ah = (1.0 / xy1 - (pp.z * pp.z) / (xy1 * p2.z * p2.z))
                / (1.0 - (xy2 * pp.z * pp.z) / (xy1 * p2.z * p2.z));
            ch = (ah * xy2 - 1.0) / (p2.z * p2.z);
            if ah.is_finite() {
                break;
            }
        }
        if !ah.is_finite() || !ch.is_finite() {
            return None;
        }
        Some(Hyperboloid {
            placement,
            p1,
            p2,
            z_min,
            z_max,
            phi_max: phi_max_deg.clamp(0.0, 360.0).to_radians(),
            r_max: radius1.max(radius2),
            ah,
            ch,
        })
    }

    /// Render-space bounds.
    pub fn bounds(&self) -> Bounds3f {
        let r = self.r_max;
        self.placement
            .bounds(&Bounds3f::new(Vec3::new(-r, -r, self.z_min), Vec3::new(r, r, self.z_max)))
    }

    /// The hit in object space, with rays rejected on values first
    /// ([`quadric_hit`]) or not (the tests' reference).
    #[inline(always)]
    pub(super) fn hit(&self, r: &Ray, values_first: bool) -> Option<ObjectHit<(Vec3, f32, f32)>> {
        let (ray, oe, de) = self.placement.object_ray(r);
        let (p1, p2) = (self.p1, self.p2);
        let eval = |t: f32| {
            let p = ray.at(t);
            // Clipped in z before φ's arc tangent is paid for.
            if p.z < self.z_min || p.z > self.z_max {
                return None;
            }
            let v = (p.z - p1.z) / (p2.z - p1.z);
            let pr = (1.0 - v) * p1 + v * p2;
            let phi = phi_of(pr.x * p.y - p.x * pr.y, p.x * pr.x + p.y * pr.y);
            let clipped = phi > self.phi_max;
            (!clipped).then_some((p, phi, v))
        };
        let (o, d, t, hp) = quadric_hit(self, &ray, (oe, de), values_first, eval)?;
        Some((ray, o, d, t, hp))
    }

    /// Nearest hit, in render space.
    pub fn intersect(&self, r: &Ray) -> Option<(f32, SurfaceInteraction)> {
        let (ray, o, d, t, (p, phi, v)) = self.hit(r, true)?;
        let u = phi / self.phi_max;
        let (p1, p2) = (self.p1, self.p2);
        let (sin_phi, cos_phi) = math::sin_cos(phi);
        let dpdu = Vec3::new(-self.phi_max * p.y, self.phi_max * p.x, 0.0);
        let dpdv = Vec3::new(
            (p2.x - p1.x) * cos_phi - (p2.y - p1.y) * sin_phi,
            (p2.x - p1.x) * sin_phi + (p2.y - p1.y) * cos_phi,
            p2.z - p1.z,
        );
        let d2pduu = -self.phi_max * self.phi_max * Vec3::new(p.x, p.y, 0.0);
        let d2pduv = self.phi_max * Vec3::new(-dpdv.y, dpdv.x, 0.0);
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

    /// Surface area (pbrt-v3's closed form, object space).
    pub fn area(&self) -> f32 {
        let (p1, p2) = (self.p1, self.p2);
        let sqr = |a: f32| a * a;
        let quad = |a: f32| sqr(a) * sqr(a);
        self.phi_max / 6.0
            * (2.0 * quad(p1.x) - 2.0 * p1.x * p1.x * p1.x * p2.x
                + 2.0 * quad(p2.x)
                + 2.0
                    * (p1.y * p1.y + p1.y * p2.y + p2.y * p2.y)
                    * (sqr(p1.y - p2.y) + sqr(p1.z - p2.z))
                + p2.x
                    * p2.x
                    * (5.0 * p1.y * p1.y + 2.0 * p1.y * p2.y - 4.0 * p2.y * p2.y
                        + 2.0 * sqr(p1.z - p2.z))
                + p1.x
                    * p1.x
                    * (-4.0 * p1.y * p1.y
                        + 2.0 * p1.y * p2.y
                        + 5.0 * p2.y * p2.y
                        + 2.0 * sqr(p1.z - p2.z))
                - 2.0
                    * p1.x
                    * p2.x
                    * (p2.x * p2.x - p1.y * p1.y + 5.0 * p1.y * p2.y - p2.y * p2.y - p1.z * p1.z
                        + 2.0 * p1.z * p2.z
                        - p2.z * p2.z))
    }
}

impl Coefficients for Hyperboloid {
    #[inline(always)]
    fn coefficients<T: Arith>(&self, o: [T; 3], d: [T; 3]) -> (T, T, T) {
        let (ah, ch) = (T::from(self.ah), T::from(self.ch));
        let a = ah * d[0] * d[0] + ah * d[1] * d[1] - ch * d[2] * d[2];
        let b = T::from(2.0) * (ah * d[0] * o[0] + ah * d[1] * o[1] - ch * d[2] * o[2]);
        let c = ah * o[0] * o[0] + ah * o[1] * o[1] - ch * o[2] * o[2] - T::from(1.0);
        (a, b, c)
    }
}
