//! Partial spheres (pbrt-v3 `shapes/sphere.cpp`):
//! `Shape "sphere" "float radius" 1 "float zmin" -1 "float zmax" 1 "float phimax" 360`.

use super::efloat::{nearest_hit, phi_of, quadratic_with_root, weingarten, EFloat, Placement};
use super::efloat3::EFloat3;
use crate::interaction::{Interaction, SurfaceInteraction};
use crate::sampling::uniform_sample_sphere;
use farm_common::geometry::{
    coordinate_system, gamma, offset_ray_origin, spherical_direction, Bounds3f, Ray, Vec2, Vec3,
};
use farm_common::math;
use farm_common::scene::Params;
use std::f32::consts::PI;

/// A sphere of `radius` around the object-space origin, clipped in z and φ.
#[derive(Clone, Debug)]
pub struct Sphere {
    /// Transforms and orientation.
    pub placement: Placement,
    /// Radius.
    pub radius: f32,
    /// Lower z clip.
    pub z_min: f32,
    /// Upper z clip.
    pub z_max: f32,
    /// θ at `z_min`.
    pub theta_min: f32,
    /// θ at `z_max`.
    pub theta_max: f32,
    /// Largest φ, in radians.
    pub phi_max: f32,
}

impl Sphere {
    /// A `Shape "sphere"` with pbrt-v3's parameters and defaults
    /// (`CreateSphereShape`).
    pub fn create(params: &Params, pl: Placement) -> Self {
        let f = |n: &str, d: f32| params.float(n, d);
        let radius = f("radius", 1.0);
        let (zmin, zmax) = (f("zmin", -radius), f("zmax", radius));
        Sphere::new(pl, radius, zmin, zmax, f("phimax", 360.0))
    }
}

/// Half of f64's machine epsilon: the relative error of one rounding.
const EPS64: f64 = f64::EPSILON * 0.5;

/// How far the double-precision roots `−proj ± half` of [`Sphere::roots`]
/// can be from values that the interval roots contain, for a ray whose
/// object-space origin has squared length `o2` and direction squared
/// length `a`, a sphere of radius `r`, and `root = √(4a·x)` as computed
/// (`x = r² − |v|²`, `v` the centre-to-line vector). To spare the
/// divisions, it returns that slack times a positive `scale`, and `scale`.
///
/// The interval path's coefficients contain the exact `a`, `b`, `c` of the
/// same `f32` ray, and its square root contains `root`. So one of its roots
/// contains `q/a = −b/2a ∓ root/2a`, and the other `c/q`, which differs
/// from `−b/2a ± root/2a` by `(root² − (b² − 4ac))/4aq`, with
/// `|q| ≥ max(root, |b|)/2`. That holds when the `f32` `b` that picks the
/// sign has the exact one's sign. Otherwise `|b|` is within a few
/// roundings of zero. Then `|q|` is still at least `a` times a rejected
/// root's distance from the range, which the first term covers.
///
/// Rounding analysis of the `f64` steps, with generous constants: `−proj`
/// is within `6ε·o/√a` of `−b/2a` (and `o/√a ≤ 1 + o²/a`); `root²` is
/// within `4a·27ε·(o² + r²)` of `b² − 4ac`; the roots' own roundings add a
/// few ε of `|proj| + half`. The bound doubles each. `2a·|proj|` stands
/// for `|b|`. Where `d·o` cancels so that they differ, the first term
/// exceeds the roots' size, and nothing is rejected. Where `root` and
/// `proj` are both zero, the scale is zero, and nothing is rejected
/// either.
#[inline]
fn scaled_root_slack(o2: f64, a: f64, r: f64, root: f64, proj: f64, half: f64) -> (f64, f64) {
    let e_x = 64.0 * EPS64 * (o2 + r * r);
    let d = root.max(2.0 * a * proj.abs());
    let scale = a * d;
    let slack = 16.0 * EPS64 * ((a + o2) * d + (proj.abs() + half) * scale) + 4.0 * e_x * a;
    (slack, scale)
}

impl Sphere {
    /// pbrt-v3's constructor: z clips ordered and clamped to the radius, φ in degrees.
    pub fn new(
        placement: Placement,
        radius: f32,
        z_min: f32,
        z_max: f32,
        phi_max_deg: f32,
    ) -> Self {
        let (lo, hi) = (z_min.min(z_max), z_min.max(z_max));
        Sphere {
            placement,
            radius,
            // pbrt-v3's Clamp: a negative radius reverses the bounds.
            z_min: math::clamp(lo, -radius, radius),
            z_max: math::clamp(hi, -radius, radius),
            theta_min: math::acos((lo / radius).clamp(-1.0, 1.0)),
            theta_max: math::acos((hi / radius).clamp(-1.0, 1.0)),
            phi_max: phi_max_deg.clamp(0.0, 360.0).to_radians(),
        }
    }

    /// Render-space bounds.
    pub fn bounds(&self) -> Bounds3f {
        let r = self.radius;
        self.placement
            .bounds(&Bounds3f::new(Vec3::new(-r, -r, self.z_min), Vec3::new(r, r, self.z_max)))
    }

    /// Whether the z and φ clips can cut anything away. A full sphere needs
    /// neither the hit point nor its φ to accept a root.
    #[inline]
    fn is_clipped(&self) -> bool {
        self.z_min > -self.radius || self.z_max < self.radius || self.phi_max < 2.0 * PI
    }

    /// The object-space ray and the roots `t0 <= t1` of the ray–sphere quadratic,
    /// with pbrt-v3's error bounds.
    #[inline]
    fn roots(&self, r: &Ray) -> Option<(Ray, EFloat, EFloat)> {
        let (ray, oe, de) = self.placement.object_ray(r);
        // b² − 4ac cancels catastrophically for rays from far away; pbrt-v4
        // writes it as 4a(r² − |v|²), v the centre-to-closest-point vector.
        // Its value is computed in double precision from the ray, accurate
        // both far away and for short chords. Most rays miss: they are
        // rejected here, before any interval arithmetic.
        let (od, dd) = (ray.o.as_dvec3(), ray.d.as_dvec3());
        let a64 = dd.length_squared();
        let proj = dd.dot(od) / a64;
        let len2 = (od - dd * proj).length_squared();
        let r64 = self.radius as f64;
        // A clear miss needs no square root.
        if len2 > r64 * r64 * (1.0 + 1e-9) {
            return None;
        }
        let len64 = len2.sqrt();
        let discrim = 4.0 * a64 * (r64 + len64) * (r64 - len64);
        if discrim.is_nan() || discrim < 0.0 {
            return None;
        }
        // The roots in double precision. The interval roots below contain
        // values within a slack of these (`scaled_root_slack`), so when
        // these lie outside the ray's range by more, so do those: a shadow
        // ray that stops short of a spherical light, and a ray leaving the
        // sphere it was spawned on, are rejected here. The slack is worked
        // out only for roots outside the range at all.
        let root = discrim.sqrt();
        let half = root / (2.0 * a64);
        let (near, far) = (-proj - half, -proj + half);
        let t_max = ray.t_max as f64;
        if near > t_max || far < 0.0 {
            let (slack, scale) = scaled_root_slack(od.length_squared(), a64, r64, root, proj, half);
            if (near - t_max * (1.0 + 4.0 * EPS64)) * scale > slack || far * scale < -slack {
                return None;
            }
        }
        let (o, d) = (EFloat3::new(ray.o, oe), EFloat3::new(ray.d, de));
        let (a, b, c) = self.coefficients(o, d);
        let (t0, t1) = quadratic_with_root(a, b, c, root);
        Some((ray, t0, t1))
    }

    /// The ray–sphere quadratic `a t² + b t + c` with error bounds: pbrt-v3's
    /// `d·d`, `2 d·o` and `o·o − r²`, with the three axes' products of each
    /// made at once.
    #[inline]
    fn coefficients(&self, o: EFloat3, d: EFloat3) -> (EFloat, EFloat, EFloat) {
        let a = d.mul(d).sum();
        let b = 2.0 * d.mul(o).sum();
        let rad = EFloat::from(self.radius);
        let c = o.mul(o).sum() - rad * rad;
        (a, b, c)
    }

    fn hit(&self, r: &Ray) -> Option<(Ray, EFloat, (Vec3, f32))> {
        let (ray, t0, t1) = self.roots(r)?;
        let radius = self.radius;
        let clipped = self.is_clipped();
        let eval = |t: f32| {
            // Reproject the hit onto the sphere.
            let mut p = ray.at(t);
            p *= radius / p.length();
            if p.x == 0.0 && p.y == 0.0 {
                p.x = 1e-5 * radius;
            }
            let phi = phi_of(p.y, p.x);
            let cut = clipped
                && ((self.z_min > -radius && p.z < self.z_min)
                    || (self.z_max < radius && p.z > self.z_max)
                    || phi > self.phi_max);
            (!cut).then_some((p, phi))
        };
        let (t, h) = nearest_hit(t0, t1, ray.t_max, eval)?;
        Some((ray, t, h))
    }

    /// Nearest hit, in render space.
    pub fn intersect(&self, r: &Ray) -> Option<(f32, SurfaceInteraction)> {
        let mut si = SurfaceInteraction::default();
        let t = self.intersect_into(r, &mut si)?;
        Some((t, si))
    }

    /// [`Sphere::intersect`] with the interaction written to `out`, which
    /// a miss leaves alone: the render-space interaction is built in place
    /// rather than returned by value and copied.
    pub fn intersect_into(&self, r: &Ray, out: &mut SurfaceInteraction) -> Option<f32> {
        let (ray, t, (p, phi)) = self.hit(r)?;
        let u = phi / self.phi_max;
        let theta = math::acos((p.z / self.radius).clamp(-1.0, 1.0));
        let dtheta = self.theta_max - self.theta_min;
        let v = (theta - self.theta_min) / dtheta;
        let inv_z_radius = 1.0 / (p.x * p.x + p.y * p.y).sqrt();
        let (cos_phi, sin_phi) = (p.x * inv_z_radius, p.y * inv_z_radius);
        let dpdu = Vec3::new(-self.phi_max * p.y, self.phi_max * p.x, 0.0);
        let dpdv =
            dtheta * Vec3::new(p.z * cos_phi, p.z * sin_phi, -self.radius * math::sin(theta));
        let d2pduu = -self.phi_max * self.phi_max * Vec3::new(p.x, p.y, 0.0);
        let d2pduv = dtheta * p.z * self.phi_max * Vec3::new(-sin_phi, cos_phi, 0.0);
        let d2pdvv = -dtheta * dtheta * p;
        let (dndu, dndv) = weingarten(dpdu, dpdv, d2pduu, d2pduv, d2pdvv);
        let p_error = gamma(5) * p.abs();
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
        *out = self.placement.render_hit(&si);
        Some(t.v)
    }

    /// Whether the ray hits.
    pub fn intersect_p(&self, r: &Ray) -> bool {
        if self.is_clipped() {
            return self.hit(r).is_some();
        }
        let Some((ray, t0, t1)) = self.roots(r) else {
            return false;
        };
        nearest_hit(t0, t1, ray.t_max, |_| Some(())).is_some()
    }

    /// Surface area (object space).
    pub fn area(&self) -> f32 {
        self.phi_max * self.radius * (self.z_max - self.z_min)
    }

    /// A uniform point on the whole sphere and its area density.
    pub fn sample_area(&self, u: Vec2) -> (Interaction, f32) {
        let mut p_obj = self.radius * uniform_sample_sphere(u);
        let pl = &self.placement;
        let mut n = pl.render_from_object.normal(p_obj).normalize();
        if pl.reverse_orientation {
            n = -n;
        }
        p_obj *= self.radius / p_obj.length();
        let (p, p_error) = pl.render_from_object.point_with_error_in(p_obj, gamma(5) * p_obj.abs());
        (Interaction { p, p_error, n, time: 0.0 }, 1.0 / self.area())
    }

    /// pbrt-v3's cone sampling of the visible cap (uniform area sampling from inside).
    #[inline(always)]
    pub fn sample_from(&self, reference: &Interaction, u: Vec2) -> Option<(Interaction, f32)> {
        let pl = &self.placement;
        let p_center = pl.render_from_object.point(Vec3::ZERO);
        let p_origin =
            offset_ray_origin(reference.p, reference.p_error, reference.n, p_center - reference.p);
        if p_origin.distance_squared(p_center) <= self.radius * self.radius {
            let (it, pdf) = self.sample_area(u);
            return super::area_to_solid_angle(reference, it, pdf);
        }
        // Sample uniformly inside the subtended cone.
        let dc = reference.p.distance(p_center);
        let inv_dc = 1.0 / dc;
        let wc = (p_center - reference.p) * inv_dc;
        let (wc_x, wc_y) = coordinate_system(wc);
        let sin_theta_max = self.radius * inv_dc;
        let sin_theta_max2 = sin_theta_max * sin_theta_max;
        let inv_sin_theta_max = 1.0 / sin_theta_max;
        let cos_theta_max = (1.0 - sin_theta_max2).max(0.0).sqrt();
        let mut cos_theta = (cos_theta_max - 1.0) * u.x + 1.0;
        let mut sin_theta2 = 1.0 - cos_theta * cos_theta;
        if sin_theta_max2 < 0.00068523 {
            // Taylor expansion for small angles.
            sin_theta2 = sin_theta_max2 * u.x;
            cos_theta = (1.0 - sin_theta2).sqrt();
        }
        let cos_alpha = sin_theta2 * inv_sin_theta_max
            + cos_theta
                * (1.0 - sin_theta2 * inv_sin_theta_max * inv_sin_theta_max).max(0.0).sqrt();
        let sin_alpha = (1.0 - cos_alpha * cos_alpha).max(0.0).sqrt();
        let phi = u.y * 2.0 * PI;
        let n_world = spherical_direction(sin_alpha, cos_alpha, phi, -wc_x, -wc_y, -wc);
        let p = p_center + self.radius * n_world;
        let n = if pl.reverse_orientation { -n_world } else { n_world };
        let pdf = 1.0 / (2.0 * PI * (1.0 - cos_theta_max));
        let it = Interaction { p, p_error: gamma(5) * p.abs(), n, time: reference.time };
        (pdf > 0.0 && pdf.is_finite()).then_some((it, pdf))
    }

    /// Solid-angle density of [`Sphere::sample_from`].
    pub fn pdf_from(&self, shape: &super::Shape, reference: &Interaction, wi: Vec3) -> f32 {
        let p_center = self.placement.render_from_object.point(Vec3::ZERO);
        let p_origin =
            offset_ray_origin(reference.p, reference.p_error, reference.n, p_center - reference.p);
        if p_origin.distance_squared(p_center) <= self.radius * self.radius {
            return super::generic_pdf(shape, reference, wi);
        }
        let sin_theta_max2 = self.radius * self.radius / reference.p.distance_squared(p_center);
        let cos_theta_max = (1.0 - sin_theta_max2).max(0.0).sqrt();
        1.0 / (2.0 * PI * (1.0 - cos_theta_max))
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use farm_common::geometry::{DVec3, Mat4, Transform};
    use farm_common::rng::Rng;

    /// The interval path alone, without the double-precision early outs:
    /// whether it accepts a root in the ray's range.
    fn interval_only(s: &Sphere, r: &Ray) -> bool {
        let (ray, oe, de) = s.placement.object_ray(r);
        let (a, b, c) = s.coefficients(EFloat3::new(ray.o, oe), EFloat3::new(ray.d, de));
        let (od, dd) = (ray.o.as_dvec3(), ray.d.as_dvec3());
        let len = (od - dd * (dd.dot(od) / dd.length_squared())).length();
        let r64 = s.radius as f64;
        let discrim = 4.0 * dd.length_squared() * (r64 + len) * (r64 - len);
        let Some((t0, t1)) = super::super::efloat::quadratic_with_discriminant(a, b, c, discrim)
        else {
            return false;
        };
        nearest_hit(t0, t1, ray.t_max, |_| Some(())).is_some()
    }

    /// The early outs never change the answer: shadow rays to points
    /// sampled on the sphere (which stop just short of it), rays from inside,
    /// rays that end just past or just before the surface, grazing rays, and
    /// rays spawned from a hit on the sphere, out of it or into it (which
    /// the tight `scaled_root_slack` rejects before the interval path); for
    /// spheres near and far from the origin, scaled and rotated.
    #[test]
    fn early_outs_agree_with_the_interval_path() {
        let mut rng = Rng::new(5);
        let placements = [
            (Mat4::from_translation(Vec3::new(3.0, -2.0, 7.0)), 1.5),
            (
                Mat4::from_translation(Vec3::new(-40.0, 9.0, 300.0))
                    * Mat4::from_rotation_y(0.7)
                    * Mat4::from_scale(Vec3::new(0.5, 2.0, 3.0)),
                1.0,
            ),
            (Mat4::from_translation(Vec3::new(2e4, 1e3, -5e4)), 200.0),
            (Mat4::from_scale(Vec3::splat(1e-3)), 0.01),
        ];
        for (m, radius) in placements {
            let t = Transform::new(m);
            let s = Sphere::new(Placement::new(&t, false), radius, -radius, radius, 360.0);
            let centre = t.point(Vec3::ZERO);
            let size = s.bounds().diagonal().length();
            let mut u2 = || Vec2::new(rng.uniform_f32(), rng.uniform_f32());
            let (mut hits, mut misses, mut spawned) = (0, 0, 0);
            for i in 0..24_000 {
                let from = centre + uniform_sample_sphere(u2()) * size * (0.3 + 2.0 * u2().x);
                let reference =
                    Interaction { p: from, p_error: Vec3::splat(1e-6), n: Vec3::Z, time: 0.0 };
                let ray = match i % 6 {
                    // A shadow ray to a point the light sampled.
                    0 => match s.sample_from(&reference, u2()) {
                        Some((it, _)) => reference.spawn_ray_to(&it),
                        None => continue,
                    },
                    // A segment ending near the surface, either side, up to
                    // a few of its rounding errors away.
                    1 => {
                        let target = s.sample_area(u2()).0.p;
                        let mut r = Ray::new(from, target - from, 0.0);
                        r.t_max = 1.0 + (u2().x - 0.5) * math::powf(10f32, -3.0 - 4.0 * u2().x);
                        r
                    }
                    // From a point on the surface, not moved off it: one
                    // root within rounding of zero.
                    5 => Ray::new(s.sample_area(u2()).0.p, uniform_sample_sphere(u2()), 0.0),
                    // A grazing ray: aimed at a point just off the silhouette.
                    2 => {
                        let w = (centre - from).normalize();
                        let (a, _) = coordinate_system(w);
                        let edge = s.bounds().diagonal().abs().min_element() * 0.5;
                        let target = centre + a * edge * (1.0 + (u2().x - 0.5) * 1e-5);
                        Ray::new(from, target - from, 0.0)
                    }
                    // Spawned from a hit, leaving the sphere or entering it.
                    _ => {
                        let Some((_, si)) =
                            s.intersect(&Ray::new(from, s.sample_area(u2()).0.p - from, 0.0))
                        else {
                            continue;
                        };
                        spawned += 1;
                        let n = si.it.n;
                        let w = uniform_sample_sphere(u2());
                        let out = if w.dot(n) >= 0.0 { w } else { -w };
                        si.spawn_ray(if i % 6 == 3 { out } else { -out })
                    }
                };
                let want = interval_only(&s, &ray);
                assert_eq!(s.intersect_p(&ray), want, "ray {i}: {ray:?}");
                assert_eq!(s.intersect(&ray).is_some(), want, "ray {i}");
                if want {
                    hits += 1;
                } else {
                    misses += 1;
                }
            }
            assert!(hits > 1000 && misses > 1000 && spawned > 4000, "{hits} {misses} {spawned}");
        }
    }

    /// Hits agree with a double-precision solution far from the origin and for huge radii.
    #[test]
    fn far_and_huge_spheres_match_f64() {
        let mut rng = Rng::new(11);
        for (center, radius) in [
            (Vec3::new(1e4, -3e4, 2e4), 10.0f32),
            (Vec3::new(0.0, 0.0, 0.0), 1e5),
            (Vec3::new(5e5, 0.0, 0.0), 2e3),
        ] {
            let t = Transform::new(Mat4::from_translation(center));
            let s = Sphere::new(Placement::new(&t, false), radius, -radius, radius, 360.0);
            let (mut hits, mut checked) = (0, 0);
            for _ in 0..4000 {
                let w = uniform_sample_sphere(Vec2::new(rng.uniform_f32(), rng.uniform_f32()));
                let o = center + w * radius * (1.5 + 3.0 * rng.uniform_f32());
                let aim = center
                    + radius
                        * 1.2
                        * uniform_sample_sphere(Vec2::new(rng.uniform_f32(), rng.uniform_f32()));
                let ray = Ray::new(o, aim - o, 0.0);
                // Double-precision reference.
                let (od, dd, cd) = (o.as_dvec3(), ray.d.as_dvec3(), center.as_dvec3());
                let oc: DVec3 = od - cd;
                let a = dd.dot(dd);
                let b = 2.0 * dd.dot(oc);
                let c = oc.dot(oc) - (radius as f64) * (radius as f64);
                let disc = b * b - 4.0 * a * c;
                let got = s.intersect(&ray);
                if disc < -1e-3 * b * b {
                    assert!(got.is_none());
                    continue;
                }
                if disc < 1e-3 * b * b {
                    continue; // grazing: either answer is fine
                }
                let t0 = (-b - disc.sqrt()) / (2.0 * a);
                let (th, si) = got.expect("missed a clear hit");
                checked += 1;
                // The object-space ray origin is moved up to its rounding error
                // along d (as in pbrt-v3), so t is compared in distance units.
                let slack = 1e-6 * (o.abs().max_element() + center.abs().max_element()) as f64
                    + 1e-5 * radius as f64;
                assert!((th as f64 - t0).abs() * dd.length() < slack, "t {th} vs {t0}");
                let pd = od + dd * t0;
                let perr = si.it.p_error.as_dvec3();
                assert!((si.p().as_dvec3() - pd)
                    .abs()
                    .cmple(perr * 4.0 + DVec3::splat(slack))
                    .all());
                // The refined point lies on the sphere to within its error bound.
                let dist = (si.p().as_dvec3() - cd).length() - radius as f64;
                assert!(dist.abs() <= 2.0 * perr.length() + 1e-6 * cd.length(), "{dist}");
                assert!(s.intersect_p(&ray));
                hits += 1;
            }
            assert!(hits > 500 && checked == hits, "{hits}");
        }
    }

    /// A negative radius reverses pbrt-v3's clamp of the z clips: its
    /// `Clamp` gives the low bound below it and the high one above, where
    /// `f32::clamp` panicked.
    #[test]
    fn a_negative_radius_clamps_as_pbrt_does() {
        let t = Transform::new(Mat4::IDENTITY);
        let s = Sphere::new(Placement::new(&t, false), -1.0, 1.0, 0.5, 360.0);
        assert_eq!((s.z_min, s.z_max), (1.0, -1.0));
        let s = Sphere::new(Placement::new(&t, false), f32::NAN, -1.0, 1.0, 360.0);
        assert_eq!((s.z_min, s.z_max), (-1.0, 1.0));
    }
}
