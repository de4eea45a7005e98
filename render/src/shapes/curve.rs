//! Cubic Bézier curves (pbrt-v3 `shapes/curve.cpp`): `Shape "curve" "point P" [...]
//! "string type" "flat"|"cylinder"|"ribbon" "string basis" "bezier"|"bspline"
//! "integer degree" 3 "float width" 1 "normal N" [...] "integer splitdepth" 3`.
//! Each segment `[u_min, u_max]` of a curve is its own shape, intersected by
//! recursive subdivision in a ray-aligned frame.

use super::efloat::Placement;
use crate::interaction::SurfaceInteraction;
use farm_common::geometry::{coordinate_system, Bounds3f, Ray, Vec2, Vec3};
use farm_common::math;
use std::sync::Arc;

/// How the curve's surface is oriented.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum CurveType {
    /// Always faces the ray.
    Flat,
    /// Faces the ray, shaded as a cylinder.
    Cylinder,
    /// Oriented by normals interpolated between the end points.
    Ribbon,
}

/// Data shared by all segments of one curve (object space).
#[derive(Clone, Debug)]
pub struct CurveCommon {
    /// Curve type.
    pub kind: CurveType,
    /// Cubic Bézier control points.
    pub cp_obj: [Vec3; 4],
    /// Width at u = 0 and u = 1.
    pub width: [f32; 2],
    /// Ribbon normals at the ends (unit).
    pub n: [Vec3; 2],
    /// Angle between the ribbon normals.
    pub normal_angle: f32,
    /// 1 / sin(normal_angle).
    pub inv_sin_normal_angle: f32,
    /// Transforms and orientation.
    pub placement: Placement,
}

impl CurveCommon {
    /// Shared data; `norm` are the ribbon's end normals.
    pub fn new(
        placement: Placement,
        cp: [Vec3; 4],
        w0: f32,
        w1: f32,
        kind: CurveType,
        norm: Option<[Vec3; 2]>,
    ) -> Self {
        let (mut n, mut normal_angle, mut inv_sin_normal_angle) = ([Vec3::ZERO; 2], 0.0, 0.0);
        if let Some(nn) = norm {
            n = [nn[0].normalize(), nn[1].normalize()];
            normal_angle = math::acos(n[0].dot(n[1]).clamp(0.0, 1.0));
            inv_sin_normal_angle = 1.0 / math::sin(normal_angle);
        }
        CurveCommon {
            kind,
            cp_obj: cp,
            width: [w0, w1],
            n,
            normal_angle,
            inv_sin_normal_angle,
            placement,
        }
    }
}

/// One segment of a curve.
#[derive(Clone, Debug)]
pub struct Curve {
    /// The curve.
    pub common: Arc<CurveCommon>,
    /// Start of the segment's parameter range.
    pub u_min: f32,
    /// End of the segment's parameter range.
    pub u_max: f32,
}

#[inline]
pub(super) fn lerp3(t: f32, a: Vec3, b: Vec3) -> Vec3 {
    (1.0 - t) * a + t * b
}

#[inline]
pub(super) fn lerp(t: f32, a: f32, b: f32) -> f32 {
    (1.0 - t) * a + t * b
}

fn blossom_bezier(p: &[Vec3; 4], u0: f32, u1: f32, u2: f32) -> Vec3 {
    let a = [lerp3(u0, p[0], p[1]), lerp3(u0, p[1], p[2]), lerp3(u0, p[2], p[3])];
    let b = [lerp3(u1, a[0], a[1]), lerp3(u1, a[1], a[2])];
    lerp3(u2, b[0], b[1])
}

fn subdivide_bezier(cp: &[Vec3; 4]) -> [Vec3; 7] {
    [
        cp[0],
        (cp[0] + cp[1]) / 2.0,
        (cp[0] + 2.0 * cp[1] + cp[2]) / 4.0,
        (cp[0] + 3.0 * cp[1] + 3.0 * cp[2] + cp[3]) / 8.0,
        (cp[1] + 2.0 * cp[2] + cp[3]) / 4.0,
        (cp[2] + cp[3]) / 2.0,
        cp[3],
    ]
}

/// Point and derivative of a cubic Bézier.
fn eval_bezier(cp: &[Vec3; 4], u: f32) -> (Vec3, Vec3) {
    let cp1 = [lerp3(u, cp[0], cp[1]), lerp3(u, cp[1], cp[2]), lerp3(u, cp[2], cp[3])];
    let cp2 = [lerp3(u, cp1[0], cp1[1]), lerp3(u, cp1[1], cp1[2])];
    let deriv = if (cp2[1] - cp2[0]).length_squared() > 0.0 {
        3.0 * (cp2[1] - cp2[0])
    } else {
        cp[3] - cp[0]
    };
    (lerp3(u, cp2[0], cp2[1]), deriv)
}

/// The ray's frame: origin at the ray origin, z along the ray (pbrt-v3 `LookAt`).
struct RayFrame {
    o: Vec3,
    right: Vec3,
    up: Vec3,
    dir: Vec3,
}

impl RayFrame {
    fn point(&self, p: Vec3) -> Vec3 {
        let q = p - self.o;
        Vec3::new(self.right.dot(q), self.up.dot(q), self.dir.dot(q))
    }
    fn vector_to_ray(&self, v: Vec3) -> Vec3 {
        Vec3::new(self.right.dot(v), self.up.dot(v), self.dir.dot(v))
    }
    fn vector_to_object(&self, v: Vec3) -> Vec3 {
        v.x * self.right + v.y * self.up + v.z * self.dir
    }
}

/// pbrt-v3 `Rotate(theta_degrees, axis)` applied to `v`.
fn rotate(theta_deg: f32, axis: Vec3, v: Vec3) -> Vec3 {
    let a = axis.normalize();
    let (s, c) = math::sin_cos(theta_deg.to_radians());
    let r0 = Vec3::new(
        a.x * a.x + (1.0 - a.x * a.x) * c,
        a.x * a.y * (1.0 - c) - a.z * s,
        a.x * a.z * (1.0 - c) + a.y * s,
    );
    let r1 = Vec3::new(
        a.x * a.y * (1.0 - c) + a.z * s,
        a.y * a.y + (1.0 - a.y * a.y) * c,
        a.y * a.z * (1.0 - c) - a.x * s,
    );
    let r2 = Vec3::new(
        a.x * a.z * (1.0 - c) - a.y * s,
        a.y * a.z * (1.0 - c) + a.x * s,
        a.z * a.z + (1.0 - a.z * a.z) * c,
    );
    Vec3::new(r0.dot(v), r1.dot(v), r2.dot(v))
}

/// Whether the ray's box around z misses the control points' box grown by half the width.
#[inline]
fn misses(cp: &[Vec3], half_width: f64, z_max: f64) -> bool {
    let lo = cp[0].min(cp[1]).min(cp[2].min(cp[3]));
    let hi = cp[0].max(cp[1]).max(cp[2].max(cp[3]));
    (hi.y as f64 + half_width) < 0.0
        || (lo.y as f64 - half_width) > 0.0
        || (hi.x as f64 + half_width) < 0.0
        || (lo.x as f64 - half_width) > 0.0
        || (hi.z as f64 + half_width) < 0.0
        || (lo.z as f64 - half_width) > z_max
}

impl Curve {
    fn segment_cps(&self) -> [Vec3; 4] {
        let cp = &self.common.cp_obj;
        let (a, b) = (self.u_min, self.u_max);
        [
            blossom_bezier(cp, a, a, a),
            blossom_bezier(cp, a, a, b),
            blossom_bezier(cp, a, b, b),
            blossom_bezier(cp, b, b, b),
        ]
    }

    fn width_at(&self, u: f32) -> f32 {
        lerp(u, self.common.width[0], self.common.width[1])
    }

    /// Render-space bounds.
    pub fn bounds(&self) -> Bounds3f {
        let cp = self.segment_cps();
        let b = Bounds3f::new(cp[0], cp[1]).union(&Bounds3f::new(cp[2], cp[3]));
        let w = self.width_at(self.u_min).max(self.width_at(self.u_max));
        self.common.placement.bounds(&b.expand(w * 0.5))
    }

    /// Nearest hit (or any hit when `want_isect` is false), in render space.
    pub fn intersect_impl(&self, r: &Ray, want_isect: bool) -> Option<(f32, SurfaceInteraction)> {
        let pl = &self.common.placement;
        let (ray, _, _) = pl.object_ray(r);
        let cp_obj = self.segment_cps();
        // Orient the ray frame so the curve lies roughly along x.
        let mut dx = ray.d.cross(cp_obj[3] - cp_obj[0]);
        if dx.length_squared() == 0.0 {
            dx = coordinate_system(ray.d).0;
        }
        let dir = ray.d.normalize();
        let up_n = dx.normalize();
        let right0 = up_n.cross(dir);
        if right0.length() == 0.0 {
            return None;
        }
        let right = right0.normalize();
        let frame = RayFrame { o: ray.o, right, up: dir.cross(right), dir };
        let cp = cp_obj.map(|p| frame.point(p));
        let max_width = self.width_at(self.u_min).max(self.width_at(self.u_max));
        let ray_length = ray.d.length();
        let z_max = ray_length * ray.t_max;
        if misses(&cp, 0.5 * max_width as f64, z_max as f64) {
            return None;
        }
        // Refinement depth from the curve's flatness.
        let mut l0 = 0.0f32;
        for i in 0..2 {
            let d = (cp[i] - 2.0 * cp[i + 1] + cp[i + 2]).abs();
            l0 = l0.max(d.x.max(d.y).max(d.z));
        }
        let eps = self.common.width[0].max(self.common.width[1]) * 0.05;
        let log2 = |v: f32| -> i32 {
            if v.is_nan() || v < 1.0 {
                return 0;
            }
            let bits = v.to_bits();
            (bits >> 23) as i32 - 127 + if bits & (1 << 22) != 0 { 1 } else { 0 }
        };
        let r0 = log2(std::f32::consts::SQRT_2 * 6.0 * l0 / (8.0 * eps)) / 2;
        let max_depth = r0.clamp(0, 10);
        let mut hit = None;
        let found = self
            .recursive(&ray, &frame, &cp, self.u_min, self.u_max, max_depth, want_isect, &mut hit);
        if !found {
            return None;
        }
        match hit {
            Some((t, si)) => Some((t, pl.render_hit(&si))),
            None => Some((0.0, SurfaceInteraction::default())),
        }
    }

    #[allow(clippy::too_many_arguments)]
    fn recursive(
        &self,
        ray: &Ray,
        frame: &RayFrame,
        cp: &[Vec3; 4],
        u0: f32,
        u1: f32,
        depth: i32,
        want_isect: bool,
        out: &mut Option<(f32, SurfaceInteraction)>,
    ) -> bool {
        let ray_length = ray.d.length();
        let z_max = ray_length * ray.t_max;
        if depth > 0 {
            let split = subdivide_bezier(cp);
            let u = [u0, (u0 + u1) / 2.0, u1];
            let mut hit = false;
            for seg in 0..2 {
                let cps =
                    [split[3 * seg], split[3 * seg + 1], split[3 * seg + 2], split[3 * seg + 3]];
                let max_width = self.width_at(u[seg]).max(self.width_at(u[seg + 1]));
                if misses(&cps, 0.5 * max_width as f64, z_max as f64) {
                    continue;
                }
                hit |= self.recursive(
                    ray,
                    frame,
                    &cps,
                    u[seg],
                    u[seg + 1],
                    depth - 1,
                    want_isect,
                    out,
                );
                if hit && !want_isect {
                    return true;
                }
            }
            return hit;
        }
        // Reject hits beyond the tangent perpendiculars at the segment's ends.
        let edge = (cp[1].y - cp[0].y) * -cp[0].y + cp[0].x * (cp[0].x - cp[1].x);
        if edge < 0.0 {
            return false;
        }
        let edge = (cp[2].y - cp[3].y) * -cp[3].y + cp[3].x * (cp[3].x - cp[2].x);
        if edge < 0.0 {
            return false;
        }
        // Closest point on the chord to the ray.
        let seg_dir = Vec2::new(cp[3].x - cp[0].x, cp[3].y - cp[0].y);
        let denom = seg_dir.length_squared();
        if denom == 0.0 {
            return false;
        }
        let w = (-Vec2::new(cp[0].x, cp[0].y)).dot(seg_dir) / denom;
        // pbrt-v3 `Clamp`, which never panics (`f32::clamp` would on u0 > u1).
        let u = math::clamp(lerp(w, u0, u1), u0, u1);
        let mut hit_width = self.width_at(u);
        let c = &*self.common;
        let mut n_hit = Vec3::ZERO;
        if c.kind == CurveType::Ribbon {
            n_hit = if c.normal_angle == 0.0 {
                c.n[0]
            } else {
                let sin0 = math::sin((1.0 - u) * c.normal_angle) * c.inv_sin_normal_angle;
                let sin1 = math::sin(u * c.normal_angle) * c.inv_sin_normal_angle;
                sin0 * c.n[0] + sin1 * c.n[1]
            };
            hit_width *= n_hit.dot(ray.d).abs() / ray_length;
        }
        let (pc, dpcdw) = eval_bezier(cp, w.clamp(0.0, 1.0));
        let pt_curve_dist2 = pc.x * pc.x + pc.y * pc.y;
        if pt_curve_dist2 as f64 > (hit_width * hit_width) as f64 * 0.25 {
            return false;
        }
        if pc.z < 0.0 || pc.z > z_max {
            return false;
        }
        let pt_curve_dist = pt_curve_dist2.sqrt();
        let edge_func = dpcdw.x * -pc.y + pc.x * dpcdw.y;
        let v = if edge_func > 0.0 {
            0.5 + pt_curve_dist / hit_width
        } else {
            0.5 - pt_curve_dist / hit_width
        };
        if want_isect {
            let t_hit = pc.z / ray_length;
            let p_error = Vec3::splat(2.0 * hit_width);
            let (_, dpdu) = eval_bezier(&c.cp_obj, u);
            let dpdv = if c.kind == CurveType::Ribbon {
                n_hit.cross(dpdu).normalize() * hit_width
            } else {
                let dpdu_plane = frame.vector_to_ray(dpdu);
                let mut dpdv_plane =
                    Vec3::new(-dpdu_plane.y, dpdu_plane.x, 0.0).normalize() * hit_width;
                if c.kind == CurveType::Cylinder {
                    let theta = lerp(v, -90.0, 90.0);
                    dpdv_plane = rotate(-theta, dpdu_plane, dpdv_plane);
                }
                frame.vector_to_object(dpdv_plane)
            };
            let si = SurfaceInteraction::new(
                ray.at(t_hit),
                p_error,
                Vec2::new(u, v),
                -ray.d,
                dpdu,
                dpdv,
                Vec3::ZERO,
                Vec3::ZERO,
                ray.time,
                c.placement.flip(),
            );
            // Like pbrt-v3, a later segment's hit replaces an earlier one.
            *out = Some((t_hit, si));
        }
        true
    }

    /// Nearest hit, in render space.
    pub fn intersect(&self, r: &Ray) -> Option<(f32, SurfaceInteraction)> {
        self.intersect_impl(r, true)
    }

    /// Whether the ray hits.
    pub fn intersect_p(&self, r: &Ray) -> bool {
        self.intersect_impl(r, false).is_some()
    }

    /// Approximate area: control-polygon length times average width.
    pub fn area(&self) -> f32 {
        let cp = self.segment_cps();
        let avg = (self.width_at(self.u_min) + self.width_at(self.u_max)) * 0.5;
        let len: f32 = (0..3).map(|i| cp[i].distance(cp[i + 1])).sum();
        len * avg
    }
}
