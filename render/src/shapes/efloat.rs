//! Running error bounds for quadric intersection (pbrt-v3 `core/efloat.h`),
//! plus the object-space plumbing the quadrics and curves share.

use crate::interaction::SurfaceInteraction;
use farm_common::geometry::{
    next_float_down, next_float_up, Bounds3f, Ray, Transform, Vec3, MACHINE_EPSILON,
};
use farm_common::math;
use std::ops::{Add, Div, Mul, Neg, Sub};

/// A float with a conservative interval `[low, high]` around its true value.
#[derive(Clone, Copy, Debug, Default)]
pub struct EFloat {
    /// The computed value.
    pub v: f32,
    low: f32,
    high: f32,
}

impl EFloat {
    /// `v` with absolute error `err`, the interval rounded outwards.
    #[inline]
    pub fn new(v: f32, err: f32) -> Self {
        if err == 0.0 {
            EFloat { v, low: v, high: v }
        } else {
            EFloat { v, low: next_float_down(v - err), high: next_float_up(v + err) }
        }
    }
    /// A value and its interval as they are.
    #[inline(always)]
    pub(crate) fn from_parts(v: f32, low: f32, high: f32) -> Self {
        EFloat { v, low, high }
    }
    /// Upper end of the interval.
    #[inline]
    pub fn upper_bound(self) -> f32 {
        self.high
    }
    /// Lower end of the interval.
    #[inline]
    pub fn lower_bound(self) -> f32 {
        self.low
    }
    /// Width of the interval.
    #[inline]
    pub fn absolute_error(self) -> f32 {
        self.high - self.low
    }
}

impl From<f32> for EFloat {
    #[inline]
    fn from(v: f32) -> Self {
        EFloat { v, low: v, high: v }
    }
}

impl Add for EFloat {
    type Output = EFloat;
    #[inline]
    fn add(self, o: EFloat) -> EFloat {
        EFloat {
            v: self.v + o.v,
            low: next_float_down(self.low + o.low),
            high: next_float_up(self.high + o.high),
        }
    }
}

impl Sub for EFloat {
    type Output = EFloat;
    #[inline]
    fn sub(self, o: EFloat) -> EFloat {
        EFloat {
            v: self.v - o.v,
            low: next_float_down(self.low - o.high),
            high: next_float_up(self.high - o.low),
        }
    }
}

impl Mul for EFloat {
    type Output = EFloat;
    #[inline]
    fn mul(self, o: EFloat) -> EFloat {
        let p = [self.low * o.low, self.high * o.low, self.low * o.high, self.high * o.high];
        EFloat {
            v: self.v * o.v,
            low: next_float_down(p[0].min(p[1]).min(p[2].min(p[3]))),
            high: next_float_up(p[0].max(p[1]).max(p[2].max(p[3]))),
        }
    }
}

impl Div for EFloat {
    type Output = EFloat;
    #[inline]
    fn div(self, o: EFloat) -> EFloat {
        let v = self.v / o.v;
        if o.low < 0.0 && o.high > 0.0 {
            return EFloat { v, low: f32::NEG_INFINITY, high: f32::INFINITY };
        }
        // Division is correctly rounded, so it is monotone in each operand:
        // for a divisor of one sign, the signs say which two of the four
        // quotients are the extremes. The quadrics divide by intervals
        // that are positive or negative, never zero-straddling.
        if o.low > 0.0 && self.low.is_finite() && self.high.is_finite() {
            let (lo, hi) = if self.low >= 0.0 {
                (self.low / o.high, self.high / o.low)
            } else if self.high <= 0.0 {
                (self.low / o.low, self.high / o.high)
            } else {
                (self.low / o.low, self.high / o.low)
            };
            return EFloat { v, low: next_float_down(lo), high: next_float_up(hi) };
        }
        let d = [self.low / o.low, self.high / o.low, self.low / o.high, self.high / o.high];
        EFloat {
            v,
            low: next_float_down(d[0].min(d[1]).min(d[2].min(d[3]))),
            high: next_float_up(d[0].max(d[1]).max(d[2].max(d[3]))),
        }
    }
}

impl Neg for EFloat {
    type Output = EFloat;
    #[inline]
    fn neg(self) -> EFloat {
        EFloat { v: -self.v, low: -self.high, high: -self.low }
    }
}

impl Mul<EFloat> for f32 {
    type Output = EFloat;
    #[inline]
    fn mul(self, o: EFloat) -> EFloat {
        EFloat::from(self) * o
    }
}

impl Sub<f32> for EFloat {
    type Output = EFloat;
    #[inline]
    fn sub(self, o: f32) -> EFloat {
        self - EFloat::from(o)
    }
}

/// Roots `t0 <= t1` of `a t² + b t + c` with error bounds (pbrt-v3 `Quadratic`).
#[inline]
pub fn quadratic(a: EFloat, b: EFloat, c: EFloat) -> Option<(EFloat, EFloat)> {
    quadratic_with_discriminant(a, b, c, discriminant(a.v, b.v, c.v))
}

/// pbrt-v3's `b² − 4ac`, in double precision from the coefficients' values.
#[inline(always)]
fn discriminant(a: f32, b: f32, c: f32) -> f64 {
    b as f64 * b as f64 - 4.0 * a as f64 * c as f64
}

/// The arithmetic a quadric's coefficients are written in, so that one
/// generic function computes them as plain values (`f32`) or with bounds
/// ([`EFloat`]). An `EFloat`'s value is each operation's plain result, so
/// both give the same values, bit for bit.
pub(crate) trait Arith:
    Copy + Add<Output = Self> + Sub<Output = Self> + Mul<Output = Self> + Div<Output = Self> + From<f32>
{
}

impl<T> Arith for T where
    T: Copy + Add<Output = T> + Sub<Output = T> + Mul<Output = T> + Div<Output = T> + From<f32>
{
}

/// Whether pbrt-v3's quadric test ([`quadratic`], then [`nearest_hit`])
/// misses, judged on the coefficients' values alone: the discriminant is
/// negative (or NaN), or `eval` clips both roots away. Both decide on
/// nothing else: the discriminant is computed from the values, and only
/// the roots' values are ever evaluated, whatever their bounds say. So a
/// ray this rejects needs no interval arithmetic. In all-shapes, 83% of the
/// hyperboloid's tests end here: a third miss its quadric, and half meet it
/// only where it is clipped away.
#[inline]
pub(crate) fn misses<H>(a: f32, b: f32, c: f32, eval: impl Fn(f32) -> Option<H>) -> bool {
    let discrim = discriminant(a, b, c);
    #[allow(clippy::neg_cmp_op_on_partial_ord)]
    if !(discrim >= 0.0) {
        return true;
    }
    let (t0, t1) = roots(a, b, c, discrim.sqrt() as f32, b < 0.0);
    eval(t0).is_none() && eval(t1).is_none()
}

/// pbrt-v3's two roots `q/a` and `c/q` (unordered) given the square root
/// of the discriminant, as values or with bounds: [`misses`] and
/// [`quadratic_with_root`] compute the same values through it.
#[inline(always)]
fn roots<T: Arith>(a: T, b: T, c: T, root: T, b_negative: bool) -> (T, T) {
    let q = T::from(-0.5) * if b_negative { b - root } else { b + root };
    (q / a, c / q)
}

/// A quadric whose coefficients are written once for values and bounds.
pub(crate) trait Coefficients {
    /// pbrt-v3's `a`, `b`, `c` for the object-space ray `o + t d`.
    fn coefficients<T: Arith>(&self, o: [T; 3], d: [T; 3]) -> (T, T, T);
}

/// A quadric's hit with bounds: the object-space origin and direction,
/// the hit's `t`, and what the shape's clip test made of it.
pub(crate) type BoundedHit<H> = ([EFloat; 3], [EFloat; 3], EFloat, H);

/// A [`BoundedHit`] with the object-space ray it was found on, as the
/// shapes' `hit` returns it.
pub(crate) type ObjectHit<H> = (Ray, [EFloat; 3], [EFloat; 3], EFloat, H);

/// pbrt-v3's quadric test of `ray` (object space, its origin's and
/// direction's errors `oe` and `de`): rejected on values first when
/// `values_first` ([`misses`]; the tests compare both ways), then
/// [`quadratic`] and [`nearest_hit`] with bounds. Returns the origin and
/// direction with bounds, the hit's `t` and what `eval` made of it.
#[inline(always)]
pub(crate) fn quadric_hit<H>(
    q: &impl Coefficients,
    ray: &Ray,
    (oe, de): (Vec3, Vec3),
    values_first: bool,
    eval: impl Fn(f32) -> Option<H>,
) -> Option<BoundedHit<H>> {
    if values_first {
        let (a, b, c) = q.coefficients(ray.o.to_array(), ray.d.to_array());
        if misses(a, b, c, &eval) {
            return None;
        }
    }
    let (o, d) = efloat_coords(ray, oe, de);
    let (a, b, c) = q.coefficients(o, d);
    let (t0, t1) = quadratic(a, b, c)?;
    let (t, h) = nearest_hit(t0, t1, ray.t_max, eval)?;
    Some((o, d, t, h))
}

/// Roots `t0 <= t1` of `a t² + b t + c` given the discriminant `b² − 4ac`,
/// which the caller may compute in a better-conditioned form (pbrt-v4's
/// sphere), with pbrt-v3's error bound on its square root. A negative
/// discriminant means no roots, and so does a NaN one (a ray with a NaN in
/// it): pbrt-v3 goes on to NaN roots, whose bounds fail every comparison
/// in [`nearest_hit`], so that a cylinder, cone, paraboloid or hyperboloid
/// reported a hit at `t` = NaN.
#[inline]
pub fn quadratic_with_discriminant(
    a: EFloat,
    b: EFloat,
    c: EFloat,
    discrim: f64,
) -> Option<(EFloat, EFloat)> {
    #[allow(clippy::neg_cmp_op_on_partial_ord)]
    if !(discrim >= 0.0) {
        return None;
    }
    Some(quadratic_with_root(a, b, c, discrim.sqrt()))
}

/// The roots given the square root of a non-negative discriminant.
#[inline]
pub fn quadratic_with_root(a: EFloat, b: EFloat, c: EFloat, root: f64) -> (EFloat, EFloat) {
    let float_root = EFloat::new(root as f32, (MACHINE_EPSILON as f64 * root) as f32);
    let (mut t0, mut t1) = roots(a, b, c, float_root, b.v < 0.0);
    if t0.v > t1.v {
        std::mem::swap(&mut t0, &mut t1);
    }
    (t0, t1)
}

/// Picks the nearest valid root the way every pbrt-v3 quadric does: `eval`
/// maps a `t` to the refined hit and its φ, or `None` when clipped away.
#[inline]
pub(crate) fn nearest_hit<H>(
    t0: EFloat,
    t1: EFloat,
    t_max: f32,
    eval: impl Fn(f32) -> Option<H>,
) -> Option<(EFloat, H)> {
    if t0.upper_bound() > t_max || t1.lower_bound() <= 0.0 {
        return None;
    }
    let mut t = t0;
    if t.lower_bound() <= 0.0 {
        t = t1;
        if t.upper_bound() > t_max {
            return None;
        }
    }
    if let Some(h) = eval(t.v) {
        return Some((t, h));
    }
    if t.v == t1.v || t1.upper_bound() > t_max {
        return None;
    }
    eval(t1.v).map(|h| (t1, h))
}

/// φ in [0, 2π) from `atan2(y, x)`.
#[inline]
pub(crate) fn phi_of(y: f32, x: f32) -> f32 {
    let phi = math::atan2(y, x);
    if phi < 0.0 {
        phi + 2.0 * std::f32::consts::PI
    } else {
        phi
    }
}

/// ∂n/∂u and ∂n/∂v by the Weingarten equations.
#[inline]
pub(crate) fn weingarten(
    dpdu: Vec3,
    dpdv: Vec3,
    d2pduu: Vec3,
    d2pduv: Vec3,
    d2pdvv: Vec3,
) -> (Vec3, Vec3) {
    let (e1, f1, g1) = (dpdu.dot(dpdu), dpdu.dot(dpdv), dpdv.dot(dpdv));
    let n = dpdu.cross(dpdv).normalize();
    let (e, f, g) = (n.dot(d2pduu), n.dot(d2pduv), n.dot(d2pdvv));
    let inv = 1.0 / (e1 * g1 - f1 * f1);
    let dndu = (f * f1 - e * g1) * inv * dpdu + (e * f1 - f * e1) * inv * dpdv;
    let dndv = (g * f1 - f * g1) * inv * dpdu + (f * f1 - g * e1) * inv * dpdv;
    (dndu, dndv)
}

/// Placement of an object-space shape: its transforms and orientation flags.
#[derive(Clone, Copy, Debug)]
pub struct Placement {
    /// Object to render space.
    pub render_from_object: Transform,
    /// Render to object space.
    pub object_from_render: Transform,
    /// `ReverseOrientation` was in effect.
    pub reverse_orientation: bool,
    /// The transform flips handedness.
    pub transform_swaps_handedness: bool,
}

impl Placement {
    /// The placement for `render_from_object`.
    pub fn new(render_from_object: &Transform, reverse_orientation: bool) -> Self {
        Placement {
            render_from_object: *render_from_object,
            object_from_render: render_from_object.inverse(),
            reverse_orientation,
            transform_swaps_handedness: render_from_object.swaps_handedness(),
        }
    }

    /// Whether normals are flipped.
    #[inline]
    pub fn flip(&self) -> bool {
        self.reverse_orientation ^ self.transform_swaps_handedness
    }

    /// The ray in object space with origin and direction error bounds; like
    /// pbrt-v3 the origin moves to the edge of its error box but `t_max` is kept.
    #[inline]
    pub(crate) fn object_ray(&self, r: &Ray) -> (Ray, Vec3, Vec3) {
        let (mut ray, o_err, d_err) = self.object_from_render.ray_with_error(r);
        ray.t_max = r.t_max;
        (ray, o_err, d_err)
    }

    /// Render-space bounds of an object-space box.
    #[inline]
    pub(crate) fn bounds(&self, b: &Bounds3f) -> Bounds3f {
        self.render_from_object.bounds(b)
    }

    /// A hit built in object space (by [`SurfaceInteraction::new`], its
    /// shading geometry untouched), moved to render space.
    #[inline]
    pub(crate) fn render_hit(&self, si: &SurfaceInteraction) -> SurfaceInteraction {
        si.transform_fresh(&self.render_from_object)
    }
}

/// An object-space ray's origin and direction as [`EFloat`]s, given
/// their error bounds (from [`Placement::object_ray`]).
#[inline]
pub(crate) fn efloat_coords(ray: &Ray, oe: Vec3, de: Vec3) -> ([EFloat; 3], [EFloat; 3]) {
    let o = [EFloat::new(ray.o.x, oe.x), EFloat::new(ray.o.y, oe.y), EFloat::new(ray.o.z, oe.z)];
    let d = [EFloat::new(ray.d.x, de.x), EFloat::new(ray.d.y, de.y), EFloat::new(ray.d.z, de.z)];
    (o, d)
}

/// Absolute error of `o + t d` per axis (used by cone, paraboloid, hyperboloid).
#[inline]
pub(crate) fn ray_point_error(o: &[EFloat; 3], d: &[EFloat; 3], t: EFloat) -> Vec3 {
    Vec3::new(
        (o[0] + t * d[0]).absolute_error(),
        (o[1] + t * d[1]).absolute_error(),
        (o[2] + t * d[2]).absolute_error(),
    )
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn intervals_contain_double_results() {
        let a = EFloat::new(0.1, 1e-7);
        let b = EFloat::new(3.3, 0.0);
        let exact = 0.1f64 * 3.3f64 - 3.3 / 0.1;
        let r = a * b - b / a;
        assert!(r.lower_bound() as f64 <= exact && exact <= r.upper_bound() as f64);
    }

    /// The two-quotient division gives the same bounds, bit for bit, as
    /// pbrt-v3's four quotients, for every sign pattern of the dividend.
    #[test]
    fn division_matches_four_quotients() {
        let mut rng = farm_common::rng::Rng::new(7);
        let mut x = || (rng.uniform_f32() - 0.5) * 10f32.powi((rng.uniform_u32() % 9) as i32 - 4);
        for i in 0..20_000 {
            let num = EFloat::new(x(), x().abs() * (i % 3) as f32);
            let dv = x().abs() + 1e-3;
            let den = EFloat::new(dv, dv * 0.5 * (i % 2) as f32);
            for den in [den, -den] {
                let q = num / den;
                let d = [
                    num.low / den.low,
                    num.high / den.low,
                    num.low / den.high,
                    num.high / den.high,
                ];
                let low = next_float_down(d[0].min(d[1]).min(d[2].min(d[3])));
                let high = next_float_up(d[0].max(d[1]).max(d[2].max(d[3])));
                assert_eq!((q.low.to_bits(), q.high.to_bits()), (low.to_bits(), high.to_bits()));
            }
        }
    }

    /// A ray with a NaN in it misses every quadric that solves `quadratic`
    /// (and the sphere), where its NaN roots' bounds would fail every
    /// comparison of `nearest_hit` and be taken.
    #[test]
    fn a_nan_ray_misses_the_quadrics() {
        use crate::shapes::{Cone, Cylinder, Hyperboloid, Paraboloid, Shape, Sphere};
        use farm_common::geometry::Transform;
        let pl = || Placement::new(&Transform::default(), false);
        let shapes = [
            Shape::Sphere(Box::new(Sphere::new(pl(), 1.0, -1.0, 1.0, 360.0))),
            Shape::Cylinder(Box::new(Cylinder::new(pl(), 1.0, -1.0, 1.0, 360.0))),
            Shape::Cone(Box::new(Cone::new(pl(), 1.0, 1.0, 360.0))),
            Shape::Paraboloid(Box::new(Paraboloid::new(pl(), 1.0, 0.0, 1.0, 360.0))),
            Shape::Hyperboloid(Box::new(
                Hyperboloid::new(pl(), Vec3::new(1.0, 0.0, -1.0), Vec3::new(0.5, 0.5, 1.0), 360.0)
                    .expect("a hyperboloid"),
            )),
        ];
        let rays = [
            Ray::new(Vec3::new(-5.0, 0.1, 0.2), Vec3::new(1.0, f32::NAN, 0.0), 0.0),
            Ray::new(Vec3::new(f32::NAN, 0.1, 0.2), Vec3::X, 0.0),
        ];
        for (k, shape) in shapes.iter().enumerate() {
            // The same shapes do take the ray without its NaN.
            let clean = Ray::new(Vec3::new(-5.0, 0.1, 0.2), Vec3::X, 0.0);
            assert!(shape.intersect(&clean).is_some(), "shape {k} is hit at all");
            for r in &rays {
                assert!(shape.intersect(r).is_none(), "shape {k}, {r:?}");
                assert!(!shape.intersect_p(r), "shape {k}, {r:?}");
            }
        }
    }

    #[test]
    fn quadratic_roots_bracket_true_roots() {
        // (t - 2)(t - 1e4) = t² - 10002 t + 20000
        let (t0, t1) =
            quadratic(1.0.into(), (-10002.0).into(), 20000.0.into()).expect("real roots");
        assert!(t0.lower_bound() <= 2.0 && 2.0 <= t0.upper_bound());
        assert!(t1.lower_bound() <= 1e4 && 1e4 <= t1.upper_bound());
        assert!(quadratic(1.0.into(), 0.0.into(), 1.0.into()).is_none());
    }
}
