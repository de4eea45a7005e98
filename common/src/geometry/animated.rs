//! Transforms that move during the shutter interval (pbrt-v3
//! `AnimatedTransform`, `core/transform.{h,cpp}`): each keyframe is split
//! into translation, rotation and scale, which are interpolated separately,
//! and boxes are bounded over the whole motion by finding where each
//! coordinate of a moving point has zero derivative.

use super::bounds::Bounds3f;
use super::interval::{interval_find_zeros, Interval};
use super::quaternion::{from_rows, rotation_rows, rows, slerp, Quaternion};
use super::ray::{Ray, RayDifferential};
use super::transform::Transform;
use crate::math;
use glam::{Mat3, Mat4, Vec3};

/// A transform interpolated between two keyframes at two times. Outside
/// `[start_time, end_time]` it holds the nearer keyframe. When both
/// keyframes are equal every method uses the start transform directly.
#[derive(Clone, Debug, PartialEq)]
pub struct AnimatedTransform {
    start: Transform,
    end: Transform,
    start_time: f32,
    end_time: f32,
    motion: Option<Box<Motion>>,
}

/// The decomposed keyframes and the motion-derivative coefficients; only
/// present when the keyframes differ.
#[derive(Clone, Debug, PartialEq)]
struct Motion {
    t: [Vec3; 2],
    r: [Quaternion; 2],
    s: [Mat4; 2],
    has_rotation: bool,
    /// Angle between the keyframe rotations (half the rotation angle).
    theta: f32,
    /// ∂p/∂t = c1 + (c2 + c3·t)·cos(2θt) + (c4 + c5·t)·sin(2θt) with
    /// c1 = `dt + c[0]·p` and c2..c5 = `c[k]·p`, for t in [0, 1].
    dt: Vec3,
    c: [Mat3; 5],
}

/// Splits `m` into translation, rotation and the remaining scale/shear
/// `S` such that `m = T·R·S` (pbrt-v3 `AnimatedTransform::Decompose`).
fn decompose(m: &Mat4) -> (Vec3, Quaternion, Mat4) {
    let mut r = rows(m);
    let t = Vec3::new(r[0][3], r[1][3], r[2][3]);
    // The upper 3×3 part alone.
    for row in r.iter_mut().take(3) {
        row[3] = 0.0;
    }
    r[3] = [0.0, 0.0, 0.0, 1.0];
    let mm = from_rows(&r);
    // Polar decomposition by averaging with the inverse transpose.
    let mut rot = mm;
    let mut count = 0;
    loop {
        let rit = rot.transpose().inverse();
        let next = (rot + rit) * 0.5;
        let (a, b) = (rows(&rot), rows(&next));
        let mut norm = 0.0f32;
        for i in 0..3 {
            let n =
                (a[i][0] - b[i][0]).abs() + (a[i][1] - b[i][1]).abs() + (a[i][2] - b[i][2]).abs();
            norm = norm.max(n);
        }
        rot = next;
        count += 1;
        if count >= 100 || norm <= 0.0001 {
            break;
        }
    }
    let q = Quaternion::from_transform(&Transform { m: rot, inv: rot.transpose() });
    let s = rot.inverse() * mm;
    (t, q, s)
}

/// The 3×3 transform matrix of pbrt-v3's `ToTransform` for the form `B(a, b)`.
fn rot3(a: &Quaternion, b: &Quaternion) -> Mat3 {
    // `ToTransform` transposes the rows, so the rows become columns.
    Mat3::from_mat4(Mat4::from_cols_array_2d(&rotation_rows(a, b)))
}

impl Motion {
    fn new(start: &Transform, end: &Transform) -> Motion {
        let (t0, r0, s0) = decompose(&start.m);
        let (t1, mut r1, s1) = decompose(&end.m);
        // Take the shorter arc.
        if r0.dot(&r1) < 0.0 {
            r1 = -r1;
        }
        let cos_theta = r0.dot(&r1);
        let theta = math::acos(cos_theta.clamp(-1.0, 1.0));
        // pbrt-v3 bounds the motion by the two end boxes when the rotations
        // are within 0.9995 of each other (about 3.6°), but even a small turn
        // carries points along an arc that bulges out of those boxes (by
        // 2e-4 of the box's size in our tests). Any turn gets the rotational
        // bounds here; a turn too small to give a direction perpendicular to
        // the first key is below the bounds' padding.
        let qperp = (r1 - r0 * cos_theta).normalize();
        let has_rotation = theta > 0.0 && qperp.v.is_finite() && qperp.w.is_finite();
        let mut c = [Mat3::ZERO; 5];
        if has_rotation {
            // R(t) = A + B·cos(2θt) + C·sin(2θt) for the slerp q0·cos θt + q⊥·sin θt,
            // S(t) = S0 + t·ΔS, p(t) = T(t) + R(t)·S(t)·p; differentiate.
            let (m0, mp) = (rot3(&r0, &r0), rot3(&qperp, &qperp));
            let a = (m0 + mp) * 0.5;
            let b = (m0 - mp) * 0.5;
            let cc = rot3(&r0, &qperp);
            let s0m = Mat3::from_mat4(s0);
            let ds = Mat3::from_mat4(s1) - s0m;
            let two_theta = 2.0 * theta;
            c[0] = a * ds;
            c[1] = b * ds + (cc * s0m) * two_theta;
            c[2] = (cc * ds) * two_theta;
            c[3] = cc * ds - (b * s0m) * two_theta;
            c[4] = (b * ds) * -two_theta;
        }
        Motion { t: [t0, t1], r: [r0, r1], s: [s0, s1], has_rotation, theta, dt: t1 - t0, c }
    }

    /// The five derivative coefficients of coordinate `axis` for point `p`.
    fn coefficients(&self, p: Vec3, axis: usize) -> [f32; 5] {
        let mut out = [0.0; 5];
        for (o, m) in out.iter_mut().zip(&self.c) {
            *o = (*m * p)[axis];
        }
        out[0] += self.dt[axis];
        out
    }
}

/// pbrt-v3 `Transform::HasScale`: some axis changes length by over 0.1%.
fn has_scale(t: &Transform) -> bool {
    let not_one = |x: f32| !(0.999..=1.001).contains(&x);
    not_one(t.vector(Vec3::X).length_squared())
        || not_one(t.vector(Vec3::Y).length_squared())
        || not_one(t.vector(Vec3::Z).length_squared())
}

impl AnimatedTransform {
    /// The transform moving from `start` at `start_time` to `end` at `end_time`.
    pub fn new(start: Transform, start_time: f32, end: Transform, end_time: f32) -> Self {
        let motion = (start != end).then(|| Box::new(Motion::new(&start, &end)));
        AnimatedTransform { start, end, start_time, end_time, motion }
    }

    /// A transform that does not move.
    pub fn fixed(t: Transform) -> Self {
        AnimatedTransform { start: t, end: t, start_time: 0.0, end_time: 1.0, motion: None }
    }

    /// Whether the keyframes differ (pbrt-v3 `actuallyAnimated`).
    #[inline]
    pub fn is_animated(&self) -> bool {
        self.motion.is_some()
    }

    /// Whether the keyframe rotations differ, so that the motion bounds
    /// follow the arc (pbrt-v3's `hasRotation` ignores turns under about 3.6°).
    pub fn has_rotation(&self) -> bool {
        self.motion.as_ref().is_some_and(|m| m.has_rotation)
    }

    /// Whether either keyframe scales (pbrt-v3 `AnimatedTransform::HasScale`).
    pub fn has_scale(&self) -> bool {
        has_scale(&self.start) || has_scale(&self.end)
    }

    /// The transform at `start_time`.
    pub fn start(&self) -> &Transform {
        &self.start
    }

    /// The transform at `end_time`.
    pub fn end(&self) -> &Transform {
        &self.end
    }

    /// The keyframe times.
    pub fn times(&self) -> (f32, f32) {
        (self.start_time, self.end_time)
    }

    /// The keyframe that applies at `time` if no interpolation is needed.
    #[inline]
    fn key(&self, time: f32) -> Option<&Transform> {
        if self.motion.is_none() || time <= self.start_time {
            Some(&self.start)
        } else if time >= self.end_time {
            Some(&self.end)
        } else {
            None
        }
    }

    /// The transform at `time`, clamped to the keyframe range
    /// (pbrt-v3 `AnimatedTransform::Interpolate`).
    pub fn interpolate(&self, time: f32) -> Transform {
        if let Some(t) = self.key(time) {
            return *t;
        }
        let Some(m) = self.motion.as_deref() else {
            return self.start;
        };
        let dt = (time - self.start_time) / (self.end_time - self.start_time);
        let trans = (1.0 - dt) * m.t[0] + dt * m.t[1];
        let rotate = slerp(dt, &m.r[0], &m.r[1]);
        let (a, b) = (m.s[0].to_cols_array(), m.s[1].to_cols_array());
        let mut s = [0.0f32; 16];
        for i in 0..16 {
            s[i] = (1.0 - dt) * a[i] + dt * b[i];
        }
        let translate =
            Transform { m: Mat4::from_translation(trans), inv: Mat4::from_translation(-trans) };
        translate
            .compose(&rotate.to_transform())
            .compose(&Transform::new(Mat4::from_cols_array(&s)))
    }

    /// A ray transformed at its own time. Always inlined (a camera's, once
    /// a camera ray): out of line, the ray came through memory and its
    /// direction was loaded wider than the camera had stored it.
    #[inline(always)]
    pub fn ray(&self, r: &Ray) -> Ray {
        match self.key(r.time) {
            Some(t) => t.ray(r),
            None => self.interpolate(r.time).ray(r),
        }
    }

    /// A ray and its differentials transformed at the ray's time. Always
    /// inlined, as [`Transform::ray_differential`] is.
    #[inline(always)]
    pub fn ray_differential(&self, r: &RayDifferential) -> RayDifferential {
        match self.key(r.ray.time) {
            Some(t) => t.ray_differential(r),
            None => self.interpolate(r.ray.time).ray_differential(r),
        }
    }

    /// A point transformed at `time`.
    #[inline]
    pub fn point(&self, time: f32, p: Vec3) -> Vec3 {
        match self.key(time) {
            Some(t) => t.point(p),
            None => self.interpolate(time).point(p),
        }
    }

    /// A vector transformed at `time`.
    #[inline]
    pub fn vector(&self, time: f32, v: Vec3) -> Vec3 {
        match self.key(time) {
            Some(t) => t.vector(v),
            None => self.interpolate(time).vector(v),
        }
    }

    /// A box holding `b` transformed at every time of the motion
    /// (pbrt-v3 `AnimatedTransform::MotionBounds`).
    pub fn motion_bounds(&self, b: &Bounds3f) -> Bounds3f {
        if self.motion.is_none() {
            return self.start.bounds(b);
        }
        let out = self.motion_bounds_unpadded(b);
        // Positions computed at other times round differently: pad by a
        // few ulps so every sampled position is inside.
        let pad = out.min.abs().max(out.max.abs()) * super::float::gamma(3);
        Bounds3f { min: out.min - pad, max: out.max + pad }
    }

    fn motion_bounds_unpadded(&self, b: &Bounds3f) -> Bounds3f {
        let Some(m) = self.motion.as_deref() else {
            return self.start.bounds(b);
        };
        if !m.has_rotation {
            return self.start.bounds(b).union(&self.end.bounds(b));
        }
        let mut out = Bounds3f::default();
        for i in 0..8 {
            let c = Vec3::new(
                if i & 1 == 0 { b.min.x } else { b.max.x },
                if i & 2 == 0 { b.min.y } else { b.max.y },
                if i & 4 == 0 { b.min.z } else { b.max.z },
            );
            out = out.union(&self.bound_point_motion(c));
        }
        out
    }

    /// A box holding the path of point `p` over the motion
    /// (pbrt-v3 `AnimatedTransform::BoundPointMotion`).
    pub fn bound_point_motion(&self, p: Vec3) -> Bounds3f {
        let Some(m) = self.motion.as_deref() else {
            return Bounds3f::from_point(self.start.point(p));
        };
        let mut bounds = Bounds3f::new(self.start.point(p), self.end.point(p));
        for axis in 0..3 {
            let mut zeros = [0.0f32; 8];
            let mut n = 0;
            let c = m.coefficients(p, axis);
            interval_find_zeros(c, m.theta, Interval::new(0.0, 1.0), &mut zeros, &mut n, 8);
            for &z in &zeros[..n] {
                let time = (1.0 - z) * self.start_time + z * self.end_time;
                bounds = bounds.union_point(self.point(time, p));
            }
        }
        bounds
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::rng::Rng;

    fn rand_in(rng: &mut Rng, lo: f32, hi: f32) -> f32 {
        lo + (hi - lo) * rng.uniform_f32()
    }

    fn rand_axis(rng: &mut Rng) -> Vec3 {
        loop {
            let v = Vec3::new(
                rand_in(rng, -1.0, 1.0),
                rand_in(rng, -1.0, 1.0),
                rand_in(rng, -1.0, 1.0),
            );
            if v.length() > 0.1 && v.length() <= 1.0 {
                return v.normalize();
            }
        }
    }

    fn keyframe(rng: &mut Rng, rot: Mat4, scale: Vec3) -> Transform {
        let t =
            Vec3::new(rand_in(rng, -5.0, 5.0), rand_in(rng, -5.0, 5.0), rand_in(rng, -5.0, 5.0));
        Transform::new(Mat4::from_translation(t) * rot * Mat4::from_scale(scale))
    }

    /// Keyframe pairs of several kinds: `kind` picks the relation of the rotations.
    fn random_pair(rng: &mut Rng, kind: u32) -> AnimatedTransform {
        let r0 = Mat4::from_axis_angle(rand_axis(rng), rand_in(rng, 0.0, std::f32::consts::TAU));
        let axis = rand_axis(rng);
        let r1 = match kind {
            0 => Mat4::from_axis_angle(rand_axis(rng), rand_in(rng, 0.0, std::f32::consts::TAU)),
            1 => r0 * Mat4::from_axis_angle(axis, std::f32::consts::PI),
            2 => r0 * Mat4::from_axis_angle(axis, rand_in(rng, 1e-4, 0.08)),
            3 => r0 * Mat4::from_axis_angle(axis, std::f32::consts::TAU - rand_in(rng, 1e-4, 0.08)),
            _ => r0,
        };
        let mut scale =
            || Vec3::new(rand_in(rng, 0.3, 3.0), rand_in(rng, 0.3, 3.0), rand_in(rng, 0.3, 3.0));
        let (s0, s1) = (scale(), scale());
        let s1 = if kind == 5 { s0 } else { s1 };
        let start = keyframe(rng, r0, s0);
        let end = keyframe(rng, r1, s1);
        let t0 = rand_in(rng, -1.0, 1.0);
        AnimatedTransform::new(start, t0, end, t0 + rand_in(rng, 0.1, 2.0))
    }

    #[test]
    fn interpolation_at_the_key_times_returns_the_keys() {
        let mut rng = Rng::new(1);
        for i in 0..300 {
            let a = random_pair(&mut rng, i % 6);
            let (t0, t1) = a.times();
            assert_eq!(a.interpolate(t0), *a.start());
            assert_eq!(a.interpolate(t1), *a.end());
            assert_eq!(a.interpolate(t0 - 5.0), *a.start());
            assert_eq!(a.interpolate(t1 + 5.0), *a.end());
            // Just inside the range the decomposition reproduces the keys closely.
            let near = a.interpolate(t0 + 1e-6 * (t1 - t0));
            assert!(near.m.abs_diff_eq(a.start().m, 2e-3), "{i}: {:?} {:?}", near.m, a.start().m);
            let near = a.interpolate(t1 - 1e-6 * (t1 - t0));
            assert!(near.m.abs_diff_eq(a.end().m, 2e-3), "{i}");
        }
    }

    #[test]
    fn static_transforms_take_the_fast_path() {
        let t = Transform::new(Mat4::from_rotation_x(0.4) * Mat4::from_translation(Vec3::ONE));
        let a = AnimatedTransform::new(t, 0.0, t, 1.0);
        assert!(!a.is_animated() && !a.has_rotation());
        let b = Bounds3f::new(Vec3::splat(-1.0), Vec3::splat(2.0));
        assert_eq!(a.motion_bounds(&b), t.bounds(&b));
        let r = Ray::new(Vec3::ZERO, Vec3::Z, 0.5);
        assert_eq!(a.ray(&r), t.ray(&r));
        assert_eq!(a.interpolate(0.3), t);
    }

    #[test]
    fn half_way_through_a_rotation_is_half_the_angle() {
        let a = AnimatedTransform::new(
            Transform::new(Mat4::IDENTITY),
            0.0,
            Transform::new(
                Mat4::from_translation(Vec3::new(2.0, 0.0, 0.0)) * Mat4::from_rotation_z(1.2),
            ),
            2.0,
        );
        assert!(a.has_rotation());
        let m = a.interpolate(1.0);
        let expect = Mat4::from_translation(Vec3::new(1.0, 0.0, 0.0)) * Mat4::from_rotation_z(0.6);
        assert!(m.m.abs_diff_eq(expect, 1e-5), "{:?}", m.m);
    }

    #[test]
    fn half_turn_bounds_are_the_half_circle() {
        let a = AnimatedTransform::new(
            Transform::new(Mat4::IDENTITY),
            0.0,
            Transform::new(Mat4::from_rotation_z(std::f32::consts::PI)),
            1.0,
        );
        let b = a.bound_point_motion(Vec3::X);
        assert!((b.min.x + 1.0).abs() < 1e-5 && (b.max.x - 1.0).abs() < 1e-5, "{b:?}");
        // The path passes through (0, ±1, 0) on one side only.
        let extent = b.max.y - b.min.y;
        assert!((extent - 1.0).abs() < 1e-4, "{b:?}");
    }

    #[test]
    fn motion_bounds_contain_the_moving_box() {
        let mut rng = Rng::new(42);
        for i in 0..240 {
            let kind = i % 6;
            let a = random_pair(&mut rng, kind);
            let lo = Vec3::new(
                rand_in(&mut rng, -2.0, 2.0),
                rand_in(&mut rng, -2.0, 2.0),
                rand_in(&mut rng, -2.0, 2.0),
            );
            let hi = lo
                + Vec3::new(
                    rand_in(&mut rng, 0.0, 2.0),
                    rand_in(&mut rng, 0.0, 2.0),
                    rand_in(&mut rng, 0.0, 2.0),
                );
            let b = Bounds3f::new(lo, hi);
            let mb = a.motion_bounds(&b);
            // pbrt-v3 bounds nearly-parallel rotations by the keyframe boxes
            // alone, which misses the arc's small bulge (≤ 5e-4 of the radius).
            let rel = if a.has_rotation() { 1e-4 } else { 1e-3 };
            let scale = 1.0 + mb.min.abs().max(mb.max.abs()).max_element();
            let grown = mb.expand(rel * scale);
            let (t0, t1) = a.times();
            for k in 0..1000 {
                let time = t0 + (t1 - t0) * k as f32 / 999.0;
                let t = a.interpolate(time);
                for c in 0..8 {
                    let p = Vec3::new(
                        if c & 1 == 0 { lo.x } else { hi.x },
                        if c & 2 == 0 { lo.y } else { hi.y },
                        if c & 4 == 0 { lo.z } else { hi.z },
                    );
                    let q = t.point(p);
                    assert!(
                        grown.inside(q),
                        "pair {i} kind {kind} time {time}: {q:?} outside {mb:?}"
                    );
                }
            }
        }
    }
}
