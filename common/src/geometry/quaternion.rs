//! Quaternions for interpolating rotations (pbrt-v3 `core/quaternion.h`).

use super::transform::Transform;
use crate::math;
use glam::{Mat4, Vec3};
use std::ops::{Add, Mul, Neg, Sub};

/// A quaternion `w + v·(i, j, k)`; unit quaternions represent rotations.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Quaternion {
    /// The vector part.
    pub v: Vec3,
    /// The scalar part.
    pub w: f32,
}

impl Default for Quaternion {
    fn default() -> Self {
        Quaternion { v: Vec3::ZERO, w: 1.0 }
    }
}

impl Add for Quaternion {
    type Output = Quaternion;
    fn add(self, o: Quaternion) -> Quaternion {
        Quaternion { v: self.v + o.v, w: self.w + o.w }
    }
}

impl Sub for Quaternion {
    type Output = Quaternion;
    fn sub(self, o: Quaternion) -> Quaternion {
        Quaternion { v: self.v - o.v, w: self.w - o.w }
    }
}

impl Neg for Quaternion {
    type Output = Quaternion;
    fn neg(self) -> Quaternion {
        Quaternion { v: -self.v, w: -self.w }
    }
}

impl Mul<f32> for Quaternion {
    type Output = Quaternion;
    fn mul(self, f: f32) -> Quaternion {
        Quaternion { v: self.v * f, w: self.w * f }
    }
}

impl Mul<Quaternion> for f32 {
    type Output = Quaternion;
    fn mul(self, q: Quaternion) -> Quaternion {
        q * self
    }
}

/// pbrt's row-major view of a matrix: `r[i][j]` is row `i`, column `j`.
#[inline]
pub(super) fn rows(m: &Mat4) -> [[f32; 4]; 4] {
    m.transpose().to_cols_array_2d()
}

/// The matrix with rows `r`.
#[inline]
pub(super) fn from_rows(r: &[[f32; 4]; 4]) -> Mat4 {
    Mat4::from_cols_array_2d(r).transpose()
}

impl Quaternion {
    /// The quaternion from its parts.
    pub const fn new(v: Vec3, w: f32) -> Self {
        Quaternion { v, w }
    }

    /// Four-dimensional dot product.
    #[inline]
    pub fn dot(&self, o: &Quaternion) -> f32 {
        self.v.dot(o.v) + self.w * o.w
    }

    /// The quaternion scaled to unit length.
    #[inline]
    pub fn normalize(&self) -> Quaternion {
        *self * (1.0 / self.dot(self).sqrt())
    }

    /// The rotation of the upper 3×3 part of `t`, which must be orthonormal
    /// (pbrt-v3 `Quaternion(const Transform &)`).
    pub fn from_transform(t: &Transform) -> Quaternion {
        let m = rows(&t.m);
        let trace = m[0][0] + m[1][1] + m[2][2];
        if trace > 0.0 {
            // The largest component is w.
            let mut s = (trace + 1.0).sqrt();
            let w = s / 2.0;
            s = 0.5 / s;
            let v = Vec3::new(
                (m[2][1] - m[1][2]) * s,
                (m[0][2] - m[2][0]) * s,
                (m[1][0] - m[0][1]) * s,
            );
            Quaternion { v, w }
        } else {
            // Start from the largest diagonal entry.
            const NXT: [usize; 3] = [1, 2, 0];
            let mut i = 0;
            if m[1][1] > m[0][0] {
                i = 1;
            }
            if m[2][2] > m[i][i] {
                i = 2;
            }
            let j = NXT[i];
            let k = NXT[j];
            let mut s = ((m[i][i] - (m[j][j] + m[k][k])) + 1.0).sqrt();
            let mut q = [0.0f32; 3];
            q[i] = s * 0.5;
            if s != 0.0 {
                s = 0.5 / s;
            }
            let w = (m[k][j] - m[j][k]) * s;
            q[j] = (m[j][i] + m[i][j]) * s;
            q[k] = (m[k][i] + m[i][k]) * s;
            Quaternion { v: Vec3::from(q), w }
        }
    }

    /// The rotation as a transform (pbrt-v3 `Quaternion::ToTransform`,
    /// including its transpose for the left-handed convention).
    pub fn to_transform(&self) -> Transform {
        let r = rotation_rows(self, self);
        let m = from_rows(&r);
        // The transpose of a rotation is its inverse.
        Transform { m: m.transpose(), inv: m }
    }
}

/// The symmetric bilinear form `B(a, b)` behind pbrt-v3's `ToTransform`
/// matrix before its transpose, written so that `B(q, q)` is exactly that
/// matrix for a unit `q`. With `a ≠ b` it gives the cross term of the
/// rotation matrix of `a·cos + b·sin`, which the motion bounds need; the
/// constant `1` of the diagonal is then `a·b`.
pub(super) fn rotation_rows(a: &Quaternion, b: &Quaternion) -> [[f32; 4]; 4] {
    if a == b {
        // pbrt-v3's expressions exactly, for bit-identical interpolation.
        let (x, y, z, w) = (a.v.x, a.v.y, a.v.z, a.w);
        let (xx, yy, zz) = (x * x, y * y, z * z);
        let (xy, xz, yz) = (x * y, x * z, y * z);
        let (wx, wy, wz) = (x * w, y * w, z * w);
        return [
            [1.0 - 2.0 * (yy + zz), 2.0 * (xy + wz), 2.0 * (xz - wy), 0.0],
            [2.0 * (xy - wz), 1.0 - 2.0 * (xx + zz), 2.0 * (yz + wx), 0.0],
            [2.0 * (xz + wy), 2.0 * (yz - wx), 1.0 - 2.0 * (xx + yy), 0.0],
            [0.0, 0.0, 0.0, 1.0],
        ];
    }
    // Polarised products: p(u, v) = (a.u b.v + a.v b.u) / 2.
    let av = [a.v.x, a.v.y, a.v.z, a.w];
    let bv = [b.v.x, b.v.y, b.v.z, b.w];
    let p = |u: usize, v: usize| 0.5 * (av[u] * bv[v] + av[v] * bv[u]);
    let (x, y, z, w) = (0, 1, 2, 3);
    let one = a.dot(b);
    [
        [
            one - 2.0 * (p(y, y) + p(z, z)),
            2.0 * (p(x, y) + p(w, z)),
            2.0 * (p(x, z) - p(w, y)),
            0.0,
        ],
        [
            2.0 * (p(x, y) - p(w, z)),
            one - 2.0 * (p(x, x) + p(z, z)),
            2.0 * (p(y, z) + p(w, x)),
            0.0,
        ],
        [
            2.0 * (p(x, z) + p(w, y)),
            2.0 * (p(y, z) - p(w, x)),
            one - 2.0 * (p(x, x) + p(y, y)),
            0.0,
        ],
        [0.0, 0.0, 0.0, 0.0],
    ]
}

/// Spherical linear interpolation from `q1` (t = 0) to `q2` (t = 1) along
/// the shorter arc, falling back to a normalised linear blend when the two
/// are nearly parallel (pbrt-v3 `Slerp`; the sign flip that picks the
/// shorter arc is done by pbrt-v3's `AnimatedTransform`, and here as well).
pub fn slerp(t: f32, q1: &Quaternion, q2: &Quaternion) -> Quaternion {
    let mut q2 = *q2;
    let mut cos_theta = q1.dot(&q2);
    if cos_theta < 0.0 {
        q2 = -q2;
        cos_theta = -cos_theta;
    }
    if cos_theta > 0.9995 {
        ((1.0 - t) * *q1 + t * q2).normalize()
    } else {
        let theta = math::acos(cos_theta.clamp(-1.0, 1.0));
        let thetap = theta * t;
        let qperp = (q2 - *q1 * cos_theta).normalize();
        *q1 * math::cos(thetap) + qperp * math::sin(thetap)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::rng::Rng;

    fn random_unit(rng: &mut Rng) -> Quaternion {
        let mut u = || 2.0 * rng.uniform_f32() - 1.0;
        Quaternion::new(Vec3::new(u(), u(), u()), u()).normalize()
    }

    #[test]
    fn transform_round_trip_preserves_the_rotation() {
        let mut rng = Rng::new(7);
        for _ in 0..1000 {
            let q = random_unit(&mut rng);
            let t = q.to_transform();
            let back = Quaternion::from_transform(&t);
            // q and -q are the same rotation.
            assert!((back.dot(&q).abs() - 1.0).abs() < 1e-5, "{q:?} {back:?}");
            let p = Vec3::new(0.3, -1.2, 2.0);
            assert!((t.inverse().point(t.point(p)) - p).length() < 1e-5);
        }
    }

    #[test]
    fn to_transform_matches_a_rotation_about_z() {
        // pbrt-v3: Quaternion(Rotate(θ, z)) has v = (0, 0, sin θ/2).
        let theta = 0.7f32;
        let t = Transform::new(Mat4::from_rotation_z(theta));
        let q = Quaternion::from_transform(&t);
        assert!(
            (q.v.z - math::sin(theta / 2.0)).abs() < 1e-6
                && (q.w - math::cos(theta / 2.0)).abs() < 1e-6
        );
        let back = q.to_transform();
        assert!(
            (back.point(Vec3::X) - Vec3::new(math::cos(theta), math::sin(theta), 0.0)).length()
                < 1e-6
        );
    }

    #[test]
    fn slerp_of_identical_quaternions_returns_it() {
        let mut rng = Rng::new(3);
        for _ in 0..200 {
            let q = random_unit(&mut rng);
            for t in [0.0, 0.25, 0.5, 1.0] {
                let s = slerp(t, &q, &q);
                assert!((s.v - q.v).length() < 1e-6 && (s.w - q.w).abs() < 1e-6);
                // The opposite sign is the same rotation: the short arc is no motion.
                let s = slerp(t, &q, &-q);
                assert!((s.v - q.v).length() < 1e-6 && (s.w - q.w).abs() < 1e-6);
            }
        }
    }

    #[test]
    fn slerp_moves_at_constant_angular_speed() {
        let a = Quaternion::from_transform(&Transform::new(Mat4::IDENTITY));
        let b = Quaternion::from_transform(&Transform::new(Mat4::from_rotation_y(2.0)));
        for t in [0.1f32, 0.5, 0.9] {
            let s = slerp(t, &a, &b).to_transform();
            let expect = Mat4::from_rotation_y(2.0 * t);
            assert!(s.m.abs_diff_eq(expect, 1e-5), "{t}");
        }
    }

    #[test]
    fn bilinear_form_is_the_rotation_matrix_on_the_diagonal() {
        let mut rng = Rng::new(11);
        for _ in 0..100 {
            let q = random_unit(&mut rng);
            let q2 = Quaternion::new(q.v, next(q.w));
            let exact = from_rows(&rotation_rows(&q, &q));
            let mut polar = from_rows(&rotation_rows(&q, &q2));
            polar.w_axis.w = 1.0;
            assert!(exact.abs_diff_eq(polar, 1e-5));
        }
    }

    fn next(w: f32) -> f32 {
        crate::geometry::next_float_up(w)
    }
}
