//! Points on surfaces (pbrt-v3 `core/interaction.h`): where a ray hit, with
//! the error bounds needed to leave the surface safely, the local
//! differential geometry, and the screen-space derivatives used to filter
//! textures.

use farm_common::geometry::{
    face_forward, offset_ray_origin, Ray, RayDifferential, Transform, Vec2, Vec3, SHADOW_EPSILON,
};

/// A point on a surface without differential geometry: what light sampling
/// and shadow rays need.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct Interaction {
    /// The point.
    pub p: Vec3,
    /// Conservative bound on the absolute error in `p`.
    pub p_error: Vec3,
    /// Geometric normal (unit, or zero for points not on a surface).
    pub n: Vec3,
    /// Time.
    pub time: f32,
}

impl Interaction {
    /// A ray leaving the point in direction `d`, from an origin offset past
    /// the point's error box.
    #[inline]
    pub fn spawn_ray(&self, d: Vec3) -> Ray {
        Ray::new(offset_ray_origin(self.p, self.p_error, self.n, d), d, self.time)
    }

    /// A shadow ray from this point to `p2`, stopping just short of it.
    #[inline]
    pub fn spawn_ray_to_point(&self, p2: Vec3) -> Ray {
        let o = offset_ray_origin(self.p, self.p_error, self.n, p2 - self.p);
        Ray { o, d: p2 - o, t_max: 1.0 - SHADOW_EPSILON, time: self.time }
    }

    /// A shadow ray between two surface points, both ends offset.
    #[inline]
    pub fn spawn_ray_to(&self, it: &Interaction) -> Ray {
        let pf = offset_ray_origin(self.p, self.p_error, self.n, it.p - self.p);
        let pt = offset_ray_origin(it.p, it.p_error, it.n, pf - it.p);
        Ray { o: pf, d: pt - pf, t_max: 1.0 - SHADOW_EPSILON, time: self.time }
    }
}

/// Shading frame, possibly perturbed by interpolated normals or bump maps.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct Shading {
    /// Shading normal (unit, on the same side as the geometric normal).
    pub n: Vec3,
    /// ∂p/∂u for shading.
    pub dpdu: Vec3,
    /// ∂p/∂v for shading.
    pub dpdv: Vec3,
    /// ∂n/∂u for shading.
    pub dndu: Vec3,
    /// ∂n/∂v for shading.
    pub dndv: Vec3,
}

impl Shading {
    /// Whether this frame is `si`'s true geometry, bit for bit.
    fn is_geometry_of(&self, si: &SurfaceInteraction) -> bool {
        let bits = |v: [Vec3; 5]| v.map(|x| x.to_array().map(f32::to_bits));
        bits([self.n, self.dpdu, self.dpdv, self.dndu, self.dndv])
            == bits([si.it.n, si.dpdu, si.dpdv, si.dndu, si.dndv])
    }
}

/// A ray–surface hit (pbrt-v3 `SurfaceInteraction`), in render space.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct SurfaceInteraction {
    /// Point, error bound, geometric normal and time.
    pub it: Interaction,
    /// Direction back along the incoming ray (unit).
    pub wo: Vec3,
    /// Surface parameterisation.
    pub uv: Vec2,
    /// ∂p/∂u.
    pub dpdu: Vec3,
    /// ∂p/∂v.
    pub dpdv: Vec3,
    /// ∂n/∂u.
    pub dndu: Vec3,
    /// ∂n/∂v.
    pub dndv: Vec3,
    /// Shading geometry.
    pub shading: Shading,
    /// ∂p/∂x on the film (zero without ray differentials).
    pub dpdx: Vec3,
    /// ∂p/∂y on the film.
    pub dpdy: Vec3,
    /// ∂u/∂x.
    pub dudx: f32,
    /// ∂v/∂x.
    pub dvdx: f32,
    /// ∂u/∂y.
    pub dudy: f32,
    /// ∂v/∂y.
    pub dvdy: f32,
    /// Index of the primitive hit (set by the acceleration structure).
    pub prim: u32,
}

impl SurfaceInteraction {
    /// A hit with shading geometry equal to the true geometry. The normal is
    /// `normalize(dpdu × dpdv)`, flipped when `flip_normal` (the shape's
    /// `ReverseOrientation` xor its transform's handedness swap).
    #[allow(clippy::too_many_arguments)]
    #[inline]
    pub fn new(
        p: Vec3,
        p_error: Vec3,
        uv: Vec2,
        wo: Vec3,
        dpdu: Vec3,
        dpdv: Vec3,
        dndu: Vec3,
        dndv: Vec3,
        time: f32,
        flip_normal: bool,
    ) -> Self {
        let mut n = dpdu.cross(dpdv).normalize();
        if flip_normal {
            n = -n;
        }
        SurfaceInteraction {
            it: Interaction { p, p_error, n, time },
            wo,
            uv,
            dpdu,
            dpdv,
            dndu,
            dndv,
            shading: Shading { n, dpdu, dpdv, dndu, dndv },
            ..Default::default()
        }
    }

    /// The hit point.
    #[inline]
    pub fn p(&self) -> Vec3 {
        self.it.p
    }

    /// The geometric normal.
    #[inline]
    pub fn n(&self) -> Vec3 {
        self.it.n
    }

    /// Replaces the shading frame (pbrt-v3 `SetShadingGeometry`). When
    /// `orientation_is_authoritative`, the geometric normal is flipped to the
    /// shading normal's side; otherwise the shading normal follows the
    /// geometric one.
    pub fn set_shading_geometry(
        &mut self,
        dpdus: Vec3,
        dpdvs: Vec3,
        dndus: Vec3,
        dndvs: Vec3,
        orientation_is_authoritative: bool,
    ) {
        let mut sn = dpdus.cross(dpdvs).normalize();
        if orientation_is_authoritative {
            self.it.n = face_forward(self.it.n, sn);
        } else {
            sn = face_forward(sn, self.it.n);
        }
        self.shading = Shading { n: sn, dpdu: dpdus, dpdv: dpdvs, dndu: dndus, dndv: dndvs };
    }

    /// The hit moved by `t` (pbrt-v3 `Transform::operator()(SurfaceInteraction)`).
    pub fn transform(&self, t: &Transform) -> SurfaceInteraction {
        let mut out = self.moved_geometry(t);
        let n = t.normal(self.shading.n).normalize();
        out.shading = Shading {
            n: face_forward(n, out.it.n),
            dpdu: t.vector(self.shading.dpdu),
            dpdv: t.vector(self.shading.dpdv),
            dndu: t.normal(self.shading.dndu),
            dndv: t.normal(self.shading.dndv),
        };
        out
    }

    /// [`SurfaceInteraction::transform`] of a hit whose shading geometry is
    /// still its true geometry, as [`SurfaceInteraction::new`] makes it (a
    /// quadric's or a curve's, in object space): the shading vectors come
    /// out as the true ones do, bit for bit, so they are copied rather than
    /// transformed again (`face_forward` of a normal against itself keeps
    /// it).
    #[inline]
    pub fn transform_fresh(&self, t: &Transform) -> SurfaceInteraction {
        debug_assert!(self.shading.is_geometry_of(self), "shading moved off the true geometry");
        self.moved_geometry(t)
    }

    /// The hit moved by `t`, with the moved true frame as its shading frame.
    #[inline(always)]
    fn moved_geometry(&self, t: &Transform) -> SurfaceInteraction {
        let (p, p_error) = t.point_with_error_in(self.it.p, self.it.p_error);
        let n = t.normal(self.it.n).normalize();
        let (dpdu, dpdv) = (t.vector(self.dpdu), t.vector(self.dpdv));
        let (dndu, dndv) = (t.normal(self.dndu), t.normal(self.dndv));
        SurfaceInteraction {
            it: Interaction { p, p_error, n, time: self.it.time },
            wo: t.vector(self.wo).normalize(),
            uv: self.uv,
            dpdu,
            dpdv,
            dndu,
            dndv,
            shading: Shading { n, dpdu, dpdv, dndu, dndv },
            dpdx: t.vector(self.dpdx),
            dpdy: t.vector(self.dpdy),
            dudx: self.dudx,
            dvdx: self.dvdx,
            dudy: self.dudy,
            dvdy: self.dvdy,
            prim: self.prim,
        }
    }

    /// Estimates the screen-space derivatives of p, u and v from the ray's
    /// differentials (pbrt-v3 `ComputeDifferentials`).
    pub fn compute_differentials(&mut self, ray: &RayDifferential) {
        let n = self.it.n;
        let p = self.it.p;
        let fail = |s: &mut Self| {
            s.dudx = 0.0;
            s.dvdx = 0.0;
            s.dudy = 0.0;
            s.dvdy = 0.0;
            s.dpdx = Vec3::ZERO;
            s.dpdy = Vec3::ZERO;
        };
        if !ray.has_differentials {
            return fail(self);
        }
        // Intersect the offset rays with the tangent plane.
        let d = n.dot(p);
        let tx = -(n.dot(ray.rx_o) - d) / n.dot(ray.rx_d);
        let ty = -(n.dot(ray.ry_o) - d) / n.dot(ray.ry_d);
        if !tx.is_finite() || !ty.is_finite() {
            return fail(self);
        }
        let px = ray.rx_o + tx * ray.rx_d;
        let py = ray.ry_o + ty * ray.ry_d;
        self.dpdx = px - p;
        self.dpdy = py - p;
        // Solve the least-squares system for (du, dv) in the two best-conditioned axes.
        let dim = if n.x.abs() > n.y.abs() && n.x.abs() > n.z.abs() {
            [1, 2]
        } else if n.y.abs() > n.z.abs() {
            [0, 2]
        } else {
            [0, 1]
        };
        let a = [[self.dpdu[dim[0]], self.dpdv[dim[0]]], [self.dpdu[dim[1]], self.dpdv[dim[1]]]];
        let bx = [px[dim[0]] - p[dim[0]], px[dim[1]] - p[dim[1]]];
        let by = [py[dim[0]] - p[dim[0]], py[dim[1]] - p[dim[1]]];
        match (solve_2x2(a, bx), solve_2x2(a, by)) {
            (Some((dudx, dvdx)), Some((dudy, dvdy))) => {
                self.dudx = dudx;
                self.dvdx = dvdx;
                self.dudy = dudy;
                self.dvdy = dvdy;
            }
            (x, y) => {
                let (dudx, dvdx) = x.unwrap_or((0.0, 0.0));
                let (dudy, dvdy) = y.unwrap_or((0.0, 0.0));
                self.dudx = dudx;
                self.dvdx = dvdx;
                self.dudy = dudy;
                self.dvdy = dvdy;
            }
        }
    }

    /// A ray leaving the hit in direction `d`.
    #[inline]
    pub fn spawn_ray(&self, d: Vec3) -> Ray {
        self.it.spawn_ray(d)
    }
}

/// Solves a 2×2 linear system (pbrt-v3 `SolveLinearSystem2x2`).
fn solve_2x2(a: [[f32; 2]; 2], b: [f32; 2]) -> Option<(f32, f32)> {
    let det = a[0][0] * a[1][1] - a[0][1] * a[1][0];
    if det.abs() < 1e-10 {
        return None;
    }
    let x0 = (a[1][1] * b[0] - a[0][1] * b[1]) / det;
    let x1 = (a[0][0] * b[1] - a[1][0] * b[0]) / det;
    if x0.is_nan() || x1.is_nan() {
        return None;
    }
    Some((x0, x1))
}

#[cfg(test)]
mod tests {
    use super::*;
    use farm_common::geometry::Mat4;
    use farm_common::rng::Rng;

    fn float(rng: &mut Rng, scale: f32) -> f32 {
        (rng.uniform_f32() - 0.5) * scale
    }

    fn vector(rng: &mut Rng, scale: f32) -> Vec3 {
        Vec3::new(float(rng, scale), float(rng, scale), float(rng, scale))
    }

    /// `transform_fresh` is `transform` for a hit as `new` makes it, bit for
    /// bit: over random frames (zero and signed-zero derivatives among
    /// them, flipped normals) and transforms that rotate, shear, scale
    /// unevenly, mirror and move far away.
    #[test]
    fn a_fresh_hit_moves_as_transform_moves_it() {
        let rng = &mut Rng::new(7);
        let zeroish = |v: Vec3, k: usize| match k % 5 {
            0 => Vec3::ZERO,
            1 => Vec3::new(-0.0, 0.0, -0.0),
            _ => v,
        };
        for i in 0..2000 {
            let si = SurfaceInteraction::new(
                vector(rng, 20.0),
                vector(rng, 1e-5).abs(),
                Vec2::new(float(rng, 1.0), float(rng, 1.0)),
                vector(rng, 2.0),
                vector(rng, 3.0),
                vector(rng, 3.0),
                zeroish(vector(rng, 1.0), i),
                zeroish(vector(rng, 1.0), i / 5),
                0.25,
                i % 2 == 0,
            );
            let mut m = Mat4::from_cols_array(&std::array::from_fn(|_| float(rng, 4.0)));
            let far = if i % 3 == 0 { 1e6 } else { 10.0 };
            m.w_axis = vector(rng, far).extend(1.0);
            (m.x_axis.w, m.y_axis.w, m.z_axis.w) = (0.0, 0.0, 0.0);
            let t = Transform::new(m);
            assert_eq!(
                format!("{:?}", si.transform_fresh(&t)),
                format!("{:?}", si.transform(&t)),
                "case {i}"
            );
        }
    }
}
