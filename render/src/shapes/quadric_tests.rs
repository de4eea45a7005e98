//! The quadrics' rejection on values ([`super::efloat::misses`]) changes no
//! hit: with it and without it, every ray gets the same answer, bit for
//! bit, on quadrics of every kind, placed, scaled and clipped at random.

use super::efloat::{EFloat, Placement};
use super::{Cone, Cylinder, Hyperboloid, Paraboloid};
use farm_common::geometry::{Mat4, Ray, Transform, Vec3};
use farm_common::rng::Rng;
use glam::Quat;

/// What a hit is compared by: `t`'s value and bounds, and the point.
fn key(t: EFloat, p: Vec3) -> [u32; 6] {
    [t.v, t.lower_bound(), t.upper_bound(), p.x, p.y, p.z].map(f32::to_bits)
}

/// A placement at a random scale (10⁻⁴ to 10⁶), rotation and offset.
fn placement(rng: &mut Rng) -> (Placement, f32) {
    let scale = farm_common::math::powf(10.0, rng.uniform_f32() * 10.0 - 4.0);
    let axis = Vec3::new(rng.uniform_f32() - 0.5, rng.uniform_f32() - 0.5, rng.uniform_f32() + 0.1);
    let rot = Quat::from_axis_angle(axis.normalize(), rng.uniform_f32() * 6.0);
    let offset = scale * 3.0 * Vec3::new(rng.uniform_f32(), rng.uniform_f32(), rng.uniform_f32());
    let m = Mat4::from_scale_rotation_translation(Vec3::splat(scale), rot, offset);
    (Placement::new(&Transform::new(m), rng.uniform_u32().is_multiple_of(2)), scale)
}

/// A ray near the shape, one of five kinds, a fifth each: leaving a point
/// in its box; from 10⁵ sizes away (where the quadratic cancels); along a
/// tangent of the unit circle about its axis (grazing the cylinder, close
/// to grazing the others); aimed at its box from nearby; and the same,
/// stopping short.
fn ray(rng: &mut Rng, pl: &Placement, scale: f32) -> Ray {
    let mut u = || rng.uniform_f32() * 2.0 - 1.0;
    let xf = &pl.render_from_object;
    let target = xf.point(Vec3::new(u() * 1.5, u() * 1.5, u() * 1.5));
    let k = u();
    if k < -0.6 {
        return Ray::new(target, Vec3::new(u(), u(), u()), 0.0);
    }
    if k < -0.2 {
        let from = target + scale * 1e5 * Vec3::new(u(), u(), u());
        return Ray::new(from, target - from, 0.0);
    }
    if k < 0.2 {
        let (theta, z) = (u() * 3.2, u());
        let (s, c) = farm_common::math::sin_cos(theta);
        let (p, d) = (Vec3::new(c, s, z), Vec3::new(-s, c, u() * 0.01));
        return Ray::new(xf.point(p - 3.0 * d), xf.vector(d), 0.0);
    }
    let from = target + scale * 6.0 * Vec3::new(u(), u(), u());
    let mut r = Ray::new(from, target - from, 0.0);
    if k > 0.6 {
        r.t_max = (k - 0.6) * 3.0;
    }
    r
}

/// One quadric's placement and its size in render space, φ and z range.
struct Params {
    pl: Placement,
    scale: f32,
    phi: f32,
    z: [f32; 2],
}

/// Compares `hit` with and without the rejection on values, over rays
/// at 64 random quadrics of one kind.
fn check(name: &str, hit: impl Fn(&Params, &Ray, bool) -> Option<[u32; 6]>) {
    let mut rng = Rng::new(3);
    let shapes: Vec<Params> = (0..64)
        .map(|_| {
            let (pl, scale) = placement(&mut rng);
            let phi = if rng.uniform_u32().is_multiple_of(2) {
                360.0
            } else {
                30.0 + 300.0 * rng.uniform_f32()
            };
            let z = [rng.uniform_f32() - 0.8, rng.uniform_f32() + 0.1];
            Params { pl, scale, phi, z }
        })
        .collect();
    let (mut hits, n) = (0, 40_000);
    for i in 0..n {
        let s = &shapes[i % shapes.len()];
        let r = ray(&mut rng, &s.pl, s.scale);
        let bounded = hit(s, &r, false);
        assert_eq!(hit(s, &r, true), bounded, "{name}: ray {r:?}");
        hits += usize::from(bounded.is_some());
    }
    // The rays must reach both answers, or the comparison proves little.
    assert!(hits > n / 20 && hits < n * 19 / 20, "{name}: {hits} hits of {n}");
}

#[test]
fn rejecting_on_values_changes_no_quadric_hit() {
    check("cylinder", |s, r, f| {
        let q = Cylinder::new(s.pl, 1.0, s.z[0], s.z[1], s.phi);
        q.hit(r, f).map(|(_, t, (p, _))| key(t, p))
    });
    check("cone", |s, r, f| {
        let q = Cone::new(s.pl, 1.0 + s.z[1], 1.0, s.phi);
        q.hit(r, f).map(|(_, _, _, t, (p, _))| key(t, p))
    });
    check("paraboloid", |s, r, f| {
        let q = Paraboloid::new(s.pl, 1.0, s.z[0].max(0.0), s.z[1], s.phi);
        q.hit(r, f).map(|(_, _, _, t, (p, _))| key(t, p))
    });
    check("hyperboloid", |s, r, f| {
        let (p1, p2) = (Vec3::new(1.0, s.z[0], -1.0), Vec3::new(0.5 + s.z[1], 0.3, 1.0));
        let q = Hyperboloid::new(s.pl, p1, p2, s.phi).expect("a hyperboloid");
        q.hit(r, f).map(|(_, _, _, t, (p, _, _))| key(t, p))
    });
}
