use super::bounds::Bounds3f;
use super::float::gamma;
use super::ray::{Ray, RayDifferential};
use glam::{DMat4, Mat4, Vec3};

/// A 4×4 transform and its inverse (pbrt-v3 `Transform`). Points, vectors
/// and normals transform differently; each method says which it takes.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Transform {
    /// The matrix (glam is column-major: `m.col(3)` is the translation).
    pub m: Mat4,
    /// Its inverse.
    pub inv: Mat4,
}

impl Default for Transform {
    fn default() -> Self {
        Transform { m: Mat4::IDENTITY, inv: Mat4::IDENTITY }
    }
}

impl Transform {
    /// A transform from a matrix, inverting it. Singular matrices get a NaN
    /// inverse, as in pbrt-v3; callers that need the inverse check first.
    pub fn new(m: Mat4) -> Self {
        Transform { m, inv: m.inverse() }
    }
    /// A transform from a double-precision matrix, inverted in double.
    pub fn from_dmat4(m: DMat4) -> Self {
        Transform { m: m.as_mat4(), inv: m.inverse().as_mat4() }
    }
    /// The inverse transform.
    pub fn inverse(&self) -> Transform {
        Transform { m: self.inv, inv: self.m }
    }
    /// `self ∘ o`: apply `o` first.
    pub fn compose(&self, o: &Transform) -> Transform {
        Transform { m: self.m * o.m, inv: o.inv * self.inv }
    }
    /// Whether the transform is the identity.
    pub fn is_identity(&self) -> bool {
        self.m == Mat4::IDENTITY
    }
    /// Whether the transform flips handedness (negative determinant of the 3×3 part).
    pub fn swaps_handedness(&self) -> bool {
        glam::Mat3::from_mat4(self.m).determinant() < 0.0
    }

    /// A point, divided by w where w ≠ 1.
    #[inline]
    pub fn point(&self, p: Vec3) -> Vec3 {
        let r = self.m * p.extend(1.0);
        if r.w == 1.0 {
            r.truncate()
        } else {
            projected(r)
        }
    }

    /// [`Transform::point`] for a projective transform, whose w is almost
    /// never 1 (a perspective camera's raster to camera, a projection
    /// light's projection): the division inline.
    #[inline]
    pub fn point_projective(&self, p: Vec3) -> Vec3 {
        let r = self.m * p.extend(1.0);
        if r.w == 1.0 {
            r.truncate()
        } else {
            r.truncate() / r.w
        }
    }

    /// A point and a conservative bound on the rounding error of the result.
    #[inline]
    pub fn point_with_error(&self, p: Vec3) -> (Vec3, Vec3) {
        let abs_sum = abs_mat(&self.m) * p.abs().extend(1.0);
        (self.point(p), gamma(3) * abs_sum.truncate())
    }

    /// A point that already carries error `p_err`, and the bound on the error
    /// of the result (pbrt-v3's second `operator()` with `ptError`).
    #[inline]
    pub fn point_with_error_in(&self, p: Vec3, p_err: Vec3) -> (Vec3, Vec3) {
        let am = abs_mat(&self.m);
        let from_err = (am * p_err.extend(0.0)).truncate();
        let from_p = (am * p.abs().extend(1.0)).truncate();
        (self.point(p), (gamma(3) + 1.0) * from_err + gamma(3) * from_p)
    }

    /// A direction (no translation).
    #[inline]
    pub fn vector(&self, v: Vec3) -> Vec3 {
        (self.m * v.extend(0.0)).truncate()
    }

    /// A direction and a bound on its rounding error.
    #[inline]
    pub fn vector_with_error(&self, v: Vec3) -> (Vec3, Vec3) {
        let err = gamma(3) * (abs_mat(&self.m) * v.abs().extend(0.0)).truncate();
        (self.vector(v), err)
    }

    /// A surface normal: transformed by the inverse transpose.
    #[inline]
    pub fn normal(&self, n: Vec3) -> Vec3 {
        (self.inv.transpose() * n.extend(0.0)).truncate()
    }

    /// A ray, with its origin moved along the direction to the edge of the
    /// origin's error box so that it cannot start behind a surface, and
    /// `t_max` shortened to match (pbrt-v3 `Transform::operator()(Ray)`).
    #[inline]
    pub fn ray(&self, r: &Ray) -> Ray {
        let (mut o, o_err) = self.point_with_error(r.o);
        let d = self.vector(r.d);
        let len2 = d.length_squared();
        let mut t_max = r.t_max;
        if len2 > 0.0 {
            let dt = d.abs().dot(o_err) / len2;
            o += d * dt;
            t_max -= dt;
        }
        Ray { o, d, t_max, time: r.time }
    }

    /// A ray and its error bounds on origin and direction, without moving the
    /// origin (pbrt-v3's `operator()(Ray, Vector3f *oError, Vector3f *dError)`).
    #[inline]
    pub fn ray_with_error(&self, r: &Ray) -> (Ray, Vec3, Vec3) {
        let (mut o, o_err) = self.point_with_error(r.o);
        let (d, d_err) = self.vector_with_error(r.d);
        let len2 = d.length_squared();
        let mut t_max = r.t_max;
        if len2 > 0.0 {
            let dt = d.abs().dot(o_err) / len2;
            o += d * dt;
            t_max -= dt;
        }
        (Ray { o, d, t_max, time: r.time }, o_err, d_err)
    }

    /// A ray with its differentials. Always inlined (a camera's, once a
    /// camera ray): out of line, the 96-byte differential ray went to it
    /// and came back through memory.
    #[inline(always)]
    pub fn ray_differential(&self, r: &RayDifferential) -> RayDifferential {
        RayDifferential {
            ray: self.ray(&r.ray),
            has_differentials: r.has_differentials,
            rx_o: self.point(r.rx_o),
            ry_o: self.point(r.ry_o),
            rx_d: self.vector(r.rx_d),
            ry_d: self.vector(r.ry_d),
        }
    }

    /// The box holding the transformed corners of `b`.
    pub fn bounds(&self, b: &Bounds3f) -> Bounds3f {
        let mut out = Bounds3f::default();
        for i in 0..8 {
            let c = Vec3::new(
                if i & 1 == 0 { b.min.x } else { b.max.x },
                if i & 2 == 0 { b.min.y } else { b.max.y },
                if i & 4 == 0 { b.min.z } else { b.max.z },
            );
            out = out.union_point(self.point(c));
        }
        out
    }
}

/// A homogeneous point divided by its w: out of line, so that the common
/// w = 1 takes a branch. Inlined, the division was computed on every call
/// and the result chosen after it, which put a division's latency on
/// every transformed point (a sphere's ray in object space, above all).
#[cold]
#[inline(never)]
fn projected(r: glam::Vec4) -> Vec3 {
    r.truncate() / r.w
}

#[inline(always)]
fn abs_mat(m: &Mat4) -> Mat4 {
    Mat4::from_cols(m.x_axis.abs(), m.y_axis.abs(), m.z_axis.abs(), m.w_axis.abs())
}

impl From<Mat4> for Transform {
    fn from(m: Mat4) -> Self {
        Transform::new(m)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn normals_stay_perpendicular_under_nonuniform_scale() {
        let t = Transform::new(Mat4::from_scale(Vec3::new(1.0, 4.0, 0.5)));
        let (a, b) = (Vec3::new(1.0, 1.0, 0.0), Vec3::new(0.0, 1.0, 1.0));
        let n = a.cross(b);
        assert!(t.normal(n).dot(t.vector(a)).abs() < 1e-5);
        assert!(t.normal(n).dot(t.vector(b)).abs() < 1e-5);
    }

    #[test]
    fn point_error_bound_covers_double_precision_result() {
        let m = Mat4::from_rotation_z(0.3) * Mat4::from_translation(Vec3::new(1e5, -3.0, 7.0));
        let t = Transform::new(m);
        let dm = m.as_dmat4();
        for p in [Vec3::new(1.0, 2.0, 3.0), Vec3::new(-1e4, 5e3, 0.1), Vec3::new(0.3, -0.7, 1e6)] {
            let (q, err) = t.point_with_error(p);
            let exact = dm.transform_point3(p.as_dvec3());
            for i in 0..3 {
                assert!((q[i] as f64 - exact[i]).abs() <= err[i] as f64 + 1e-12, "axis {i}");
            }
        }
    }

    /// Both forms of the point transform give the same bits, w = 1 or not,
    /// and a projective one divides by w.
    #[test]
    fn point_forms_agree_and_divide_by_w() {
        let affine = Transform::new(Mat4::from_rotation_y(0.4) * Mat4::from_translation(Vec3::X));
        // pbrt-v3's perspective divide: w = z.
        let (z, w) = (glam::Vec4::new(0.0, 0.0, 1.001, 1.0), glam::Vec4::new(0.0, 0.0, -0.01, 0.0));
        let projective = Transform::new(Mat4::from_cols(glam::Vec4::X, glam::Vec4::Y, z, w));
        let points =
            [Vec3::new(0.3, -2.0, 5.0), Vec3::new(1e4, 7.0, -3e3), Vec3::new(0.5, 0.5, 1.0)];
        for t in [affine, projective] {
            for p in points {
                let (a, b) = (t.point(p), t.point_projective(p));
                assert_eq!(a.to_array().map(f32::to_bits), b.to_array().map(f32::to_bits));
                let h = t.m * p.extend(1.0);
                assert_eq!(a, if h.w == 1.0 { h.truncate() } else { h.truncate() / h.w });
            }
        }
        let h = projective.m * points[0].extend(1.0);
        assert_ne!(h.w, 1.0);
    }

    #[test]
    fn compose_and_inverse_round_trip() {
        let a = Transform::new(Mat4::from_rotation_x(1.0) * Mat4::from_scale(Vec3::splat(2.0)));
        let b = Transform::new(Mat4::from_translation(Vec3::new(3.0, 4.0, 5.0)));
        let c = a.compose(&b);
        let p = Vec3::new(0.5, -2.0, 9.0);
        assert!((c.inverse().point(c.point(p)) - p).length() < 1e-4);
        assert!(!c.swaps_handedness());
        assert!(Transform::new(Mat4::from_scale(Vec3::new(-1.0, 1.0, 1.0))).swaps_handedness());
    }
}
