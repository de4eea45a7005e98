//! Annuli in a z plane (pbrt-v3 `shapes/disk.cpp`):
//! `Shape "disk" "float height" 0 "float radius" 1 "float innerradius" 0 "float phimax" 360`.

use super::efloat::{phi_of, Placement};
use crate::interaction::{Interaction, SurfaceInteraction};
use crate::sampling::concentric_sample_disk;
use farm_common::geometry::{Bounds3f, Ray, Vec2, Vec3};
use farm_common::scene::Params;

/// A disk (or annulus) at `z = height`, facing +z.
#[derive(Clone, Debug)]
pub struct Disk {
    /// Transforms and orientation.
    pub placement: Placement,
    /// The plane's z.
    pub height: f32,
    /// Outer radius.
    pub radius: f32,
    /// Inner radius.
    pub inner_radius: f32,
    /// Largest φ, in radians.
    pub phi_max: f32,
}

impl Disk {
    /// A `Shape "disk"` (pbrt-v3 `CreateDiskShape`).
    pub fn create(params: &Params, pl: Placement) -> Self {
        let f = |n: &str, d: f32| params.float(n, d);
        let (height, radius, inner) = (f("height", 0.0), f("radius", 1.0), f("innerradius", 0.0));
        Disk::new(pl, height, radius, inner, f("phimax", 360.0))
    }
}

impl Disk {
    /// pbrt-v3's constructor (φ in degrees).
    pub fn new(
        placement: Placement,
        height: f32,
        radius: f32,
        inner_radius: f32,
        phi_max_deg: f32,
    ) -> Self {
        Disk {
            placement,
            height,
            radius,
            inner_radius,
            phi_max: phi_max_deg.clamp(0.0, 360.0).to_radians(),
        }
    }

    /// Render-space bounds.
    pub fn bounds(&self) -> Bounds3f {
        let r = self.radius;
        self.placement
            .bounds(&Bounds3f::new(Vec3::new(-r, -r, self.height), Vec3::new(r, r, self.height)))
    }

    fn hit(&self, r: &Ray) -> Option<(Ray, f32, Vec3, f32, f32)> {
        let (ray, _, _) = self.placement.object_ray(r);
        if ray.d.z == 0.0 {
            return None;
        }
        let t = (self.height - ray.o.z) / ray.d.z;
        if t <= 0.0 || t >= ray.t_max {
            return None;
        }
        let p = ray.at(t);
        let dist2 = p.x * p.x + p.y * p.y;
        if dist2 > self.radius * self.radius || dist2 < self.inner_radius * self.inner_radius {
            return None;
        }
        let phi = phi_of(p.y, p.x);
        if phi > self.phi_max {
            return None;
        }
        Some((ray, t, p, phi, dist2))
    }

    /// Nearest hit, in render space.
    pub fn intersect(&self, r: &Ray) -> Option<(f32, SurfaceInteraction)> {
        let (ray, t, mut p, phi, dist2) = self.hit(r)?;
        let u = phi / self.phi_max;
        let r_hit = dist2.sqrt();
        let v = 1.0 - (r_hit - self.inner_radius) / (self.radius - self.inner_radius);
        let dpdu = Vec3::new(-self.phi_max * p.y, self.phi_max * p.x, 0.0);
        let dpdv = Vec3::new(p.x, p.y, 0.0) * (self.inner_radius - self.radius) / r_hit;
        p.z = self.height;
        let si = SurfaceInteraction::new(
            p,
            Vec3::ZERO,
            Vec2::new(u, v),
            -ray.d,
            dpdu,
            dpdv,
            Vec3::ZERO,
            Vec3::ZERO,
            r.time,
            self.placement.flip(),
        );
        Some((t, self.placement.render_hit(&si)))
    }

    /// Whether the ray hits.
    pub fn intersect_p(&self, r: &Ray) -> bool {
        self.hit(r).is_some()
    }

    /// Surface area (object space).
    pub fn area(&self) -> f32 {
        self.phi_max * 0.5 * (self.radius * self.radius - self.inner_radius * self.inner_radius)
    }

    /// A point on the full disk (pbrt-v3 ignores the inner radius and φ here) and its area density.
    pub fn sample_area(&self, u: Vec2) -> (Interaction, f32) {
        let pd = concentric_sample_disk(u);
        let p_obj = Vec3::new(pd.x * self.radius, pd.y * self.radius, self.height);
        let pl = &self.placement;
        let mut n = pl.render_from_object.normal(Vec3::Z).normalize();
        if pl.reverse_orientation {
            n = -n;
        }
        let (p, p_error) = pl.render_from_object.point_with_error_in(p_obj, Vec3::ZERO);
        (Interaction { p, p_error, n, time: 0.0 }, 1.0 / self.area())
    }
}
