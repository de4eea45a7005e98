//! Triangle meshes (pbrt-v3 `shapes/triangle.cpp`): `Shape "trianglemesh"
//! "integer indices" [...] "point3 P" [...] "normal N" [...] "vector S" [...] "point2 uv" [...]`.
//! Vertices are stored in render space; intersection is the watertight
//! permute/shear algorithm with a double-precision fallback on edges.

use crate::interaction::{Interaction, Shading, SurfaceInteraction};
use crate::sampling::uniform_sample_triangle;
use crate::textures::{TexInput, TextureSet};
use farm_common::geometry::{coordinate_system, face_forward, gamma, Bounds3f, Ray, Vec2, Vec3};
use glam::Vec3Swizzles;
use std::sync::Arc;

/// An alpha mask on a mesh (`"float alpha"`, `"texture alpha"` and their `shadowalpha` twins).
#[derive(Clone, Debug, Default, PartialEq)]
pub enum AlphaMask {
    /// No mask.
    #[default]
    None,
    /// `"float alpha" 0`: every hit is cut away.
    Zero,
    /// A float texture: hits where it is 0 are cut away (pbrt-v3 evaluates
    /// it at the hit's point and uv, with no differentials).
    Texture(AlphaTexture),
}

/// The float texture of a textured alpha mask, among the scene's textures.
#[derive(Clone)]
pub struct AlphaTexture {
    /// The scene's textures.
    pub textures: Arc<TextureSet>,
    /// The mask's index among the float textures.
    pub id: u32,
}

impl PartialEq for AlphaTexture {
    fn eq(&self, other: &Self) -> bool {
        self.id == other.id && Arc::ptr_eq(&self.textures, &other.textures)
    }
}

impl std::fmt::Debug for AlphaTexture {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(f, "AlphaTexture({})", self.id)
    }
}

/// The shared data of a mesh, already in render space.
#[derive(Clone, Debug, Default)]
pub struct TriangleMesh {
    /// Vertex positions.
    pub p: Vec<Vec3>,
    /// Per-vertex shading normals (not normalised).
    pub n: Option<Vec<Vec3>>,
    /// Per-vertex tangents.
    pub s: Option<Vec<Vec3>>,
    /// Per-vertex (u, v).
    pub uv: Option<Vec<Vec2>>,
    /// `ReverseOrientation` was in effect.
    pub reverse_orientation: bool,
    /// The object-to-render transform flips handedness.
    pub transform_swaps_handedness: bool,
    /// Mask tested by `intersect`.
    pub alpha: AlphaMask,
    /// Extra mask tested by `intersect_p` (shadow rays).
    pub shadow_alpha: AlphaMask,
}

/// One triangle of a mesh, borrowed from the [`Shape::Triangle`] that
/// holds it (whose fields are inline so a shape stays 24 bytes).
///
/// [`Shape::Triangle`]: super::Shape::Triangle
#[derive(Clone, Copy, Debug)]
pub struct Triangle<'a> {
    /// The mesh.
    pub mesh: &'a TriangleMesh,
    /// Vertex indices into the mesh.
    pub v: [u32; 3],
}

/// What pbrt-v3's watertight test works out from the ray alone before it
/// looks at a triangle: the axis permutation that makes the direction's
/// largest component z, and the shear that maps the direction onto +z.
/// Made once per ray and used for every triangle the ray is tested
/// against; the values, and so the hits, are those pbrt-v3 computes per
/// test.
#[derive(Clone, Copy, Debug)]
pub struct TriRay {
    /// The axis that becomes z; `kz + 1` and `kz + 2` (mod 3) become x and y.
    kz: u8,
    /// `-d.x / d.z`, `-d.y / d.z` and `1 / d.z` of the permuted direction.
    s: [f32; 3],
}

impl TriRay {
    /// The permutation and shear of `ray`'s direction.
    #[inline(always)]
    pub fn new(ray: &Ray) -> Self {
        let ad = ray.d.abs();
        let kz: u8 = if ad.x > ad.y {
            if ad.x > ad.z {
                0
            } else {
                2
            }
        } else if ad.y > ad.z {
            1
        } else {
            2
        };
        let d = TriRay { kz, s: [0.0; 3] }.permute(ray.d);
        TriRay { kz, s: [-d.x / d.z, -d.y / d.z, 1.0 / d.z] }
    }

    /// The axis that becomes z and the shear (`-d.x / d.z`, `-d.y / d.z`,
    /// `1 / d.z` of the permuted direction), for the four-lane test.
    #[inline(always)]
    pub(super) fn parts(&self) -> (usize, [f32; 3]) {
        (usize::from(self.kz), self.s)
    }

    /// `v` with the axes (kz + 1, kz + 2, kz) mod 3 as (x, y, z). The same
    /// for every triangle a ray meets, so the branch is predicted.
    #[inline(always)]
    fn permute(&self, v: Vec3) -> Vec3 {
        match self.kz {
            0 => v.yzx(),
            1 => v.zxy(),
            _ => v,
        }
    }
}

/// The result of the watertight test: barycentrics and t.
struct RawHit {
    b: [f32; 3],
    t: f32,
}

impl Triangle<'_> {
    #[inline(always)]
    fn points(&self) -> (Vec3, Vec3, Vec3) {
        let p = &self.mesh.p;
        (p[self.v[0] as usize], p[self.v[1] as usize], p[self.v[2] as usize])
    }

    /// Render-space bounds.
    pub fn bounds(&self) -> Bounds3f {
        let (p0, p1, p2) = self.points();
        Bounds3f::new(p0, p1).union_point(p2)
    }

    /// The watertight ray–triangle test, with the ray's permutation and
    /// shear already worked out (`tr`, made from `ray` or a ray with the
    /// same direction).
    #[inline(always)]
    fn raw_hit_prepared(&self, ray: &Ray, tr: &TriRay) -> Option<RawHit> {
        let (p0, p1, p2) = self.points();
        let (mut p0t, mut p1t, mut p2t) =
            (tr.permute(p0 - ray.o), tr.permute(p1 - ray.o), tr.permute(p2 - ray.o));
        // Shear so the ray runs along +z.
        let [sx, sy, sz] = tr.s;
        p0t.x += sx * p0t.z;
        p0t.y += sy * p0t.z;
        p1t.x += sx * p1t.z;
        p1t.y += sy * p1t.z;
        p2t.x += sx * p2t.z;
        p2t.y += sy * p2t.z;
        // Edge functions, redone in double precision when any is exactly zero.
        let mut e0 = p1t.x * p2t.y - p1t.y * p2t.x;
        let mut e1 = p2t.x * p0t.y - p2t.y * p0t.x;
        let mut e2 = p0t.x * p1t.y - p0t.y * p1t.x;
        if e0 == 0.0 || e1 == 0.0 || e2 == 0.0 {
            let (a, b, c) = (p0t.as_dvec3(), p1t.as_dvec3(), p2t.as_dvec3());
            e0 = (c.y * b.x - c.x * b.y) as f32;
            e1 = (a.y * c.x - a.x * c.y) as f32;
            e2 = (b.y * a.x - b.x * a.y) as f32;
        }
        if (e0 < 0.0 || e1 < 0.0 || e2 < 0.0) && (e0 > 0.0 || e1 > 0.0 || e2 > 0.0) {
            return None;
        }
        let det = e0 + e1 + e2;
        if det == 0.0 {
            return None;
        }
        // Scaled hit distance against the ray's range.
        p0t.z *= sz;
        p1t.z *= sz;
        p2t.z *= sz;
        let t_scaled = e0 * p0t.z + e1 * p1t.z + e2 * p2t.z;
        if det < 0.0 && (t_scaled >= 0.0 || t_scaled < ray.t_max * det) {
            return None;
        }
        if det > 0.0 && (t_scaled <= 0.0 || t_scaled > ray.t_max * det) {
            return None;
        }
        let inv_det = 1.0 / det;
        let b = [e0 * inv_det, e1 * inv_det, e2 * inv_det];
        let t = t_scaled * inv_det;
        // Make sure t is conservatively greater than zero.
        let max_zt = Vec3::new(p0t.z, p1t.z, p2t.z).abs().max_element();
        let delta_z = gamma(3) * max_zt;
        let max_xt = Vec3::new(p0t.x, p1t.x, p2t.x).abs().max_element();
        let max_yt = Vec3::new(p0t.y, p1t.y, p2t.y).abs().max_element();
        let delta_x = gamma(5) * (max_xt + max_zt);
        let delta_y = gamma(5) * (max_yt + max_zt);
        let delta_e = 2.0 * (gamma(2) * max_xt * max_yt + delta_y * max_xt + delta_x * max_yt);
        let max_e = Vec3::new(e0, e1, e2).abs().max_element();
        let delta_t =
            3.0 * (gamma(3) * max_e * max_zt + delta_e * max_zt + delta_z * max_e) * inv_det.abs();
        if t <= delta_t {
            return None;
        }
        Some(RawHit { b, t })
    }

    fn uvs(&self) -> [Vec2; 3] {
        match &self.mesh.uv {
            Some(uv) => [uv[self.v[0] as usize], uv[self.v[1] as usize], uv[self.v[2] as usize]],
            None => [Vec2::new(0.0, 0.0), Vec2::new(1.0, 0.0), Vec2::new(1.0, 1.0)],
        }
    }

    /// Nearest hit; `test_alpha` applies the constant-zero alpha mask.
    pub fn intersect_with(&self, ray: &Ray, test_alpha: bool) -> Option<(f32, SurfaceInteraction)> {
        let (t, b) = self.hit_barycentrics(ray, test_alpha)?;
        Some((t, self.interaction(ray, b)))
    }

    /// The hit's `t` and barycentrics, without its interaction: the BVH
    /// finds several hits on the way to the closest and builds the
    /// interaction of that one only ([`Triangle::interaction`]).
    #[inline]
    pub fn hit_barycentrics(&self, ray: &Ray, test_alpha: bool) -> Option<(f32, [f32; 3])> {
        self.hit_barycentrics_prepared(ray, &TriRay::new(ray), test_alpha)
    }

    /// [`Triangle::hit_barycentrics`] with `ray` prepared as `tr`.
    #[inline(always)]
    pub fn hit_barycentrics_prepared(
        &self,
        ray: &Ray,
        tr: &TriRay,
        test_alpha: bool,
    ) -> Option<(f32, [f32; 3])> {
        let h = self.raw_hit_prepared(ray, tr)?;
        if test_alpha && self.cuts(&self.mesh.alpha, ray, h.b) {
            return None;
        }
        Some((h.t, h.b))
    }

    /// Whether `mask` cuts away the hit at barycentrics `b` (pbrt-v3
    /// `Triangle::Intersect`'s alpha test).
    #[inline]
    fn cuts(&self, mask: &AlphaMask, ray: &Ray, b: [f32; 3]) -> bool {
        match mask {
            AlphaMask::None => false,
            AlphaMask::Zero => true,
            AlphaMask::Texture(t) => {
                let si = self.interaction(ray, b);
                t.textures.eval(&TexInput::<f32>::Texture(t.id), &si) == 0.0
            }
        }
    }

    /// The surface interaction at barycentrics `b` of a hit by `ray`.
    pub fn interaction(self, ray: &Ray, b: [f32; 3]) -> SurfaceInteraction {
        let mut si = SurfaceInteraction::default();
        self.interaction_into(ray, b, &mut si);
        si
    }

    /// [`Triangle::interaction`] written to `si`, the caller's, so that the
    /// closest hit's interaction is built where it is used rather than
    /// copied out through each layer of the intersection. Always inlined:
    /// with the whole binary optimised as one module, LLVM did not inline
    /// it into [`Aggregate::intersect`](crate::primitive::Aggregate::intersect),
    /// which cost cornell-box 2–3%.
    #[inline(always)]
    pub fn interaction_into(self, ray: &Ray, b: [f32; 3], si: &mut SurfaceInteraction) {
        let mesh = self.mesh;
        let (p0, p1, p2) = self.points();
        let [b0, b1, b2] = b;
        let uv = self.uvs();
        // Partial derivatives, or any frame around the normal for degenerate uvs.
        let (duv02, duv12) = (uv[0] - uv[2], uv[1] - uv[2]);
        let (dp02, dp12) = (p0 - p2, p1 - p2);
        let determinant = duv02.x * duv12.y - duv02.y * duv12.x;
        let degenerate_uv = determinant.abs() < 1e-8;
        let (mut dpdu, mut dpdv) = (Vec3::ZERO, Vec3::ZERO);
        if !degenerate_uv {
            let invdet = 1.0 / determinant;
            dpdu = (duv12.y * dp02 - duv02.y * dp12) * invdet;
            dpdv = (-duv12.x * dp02 + duv02.x * dp12) * invdet;
        }
        if degenerate_uv || dpdu.cross(dpdv).length_squared() == 0.0 {
            (dpdu, dpdv) = coordinate_system((p2 - p0).cross(p1 - p0).normalize());
        }
        let abs_sum = (b0 * p0).abs() + (b1 * p1).abs() + (b2 * p2).abs();
        let p_error = gamma(7) * abs_sum;
        let p_hit = b0 * p0 + b1 * p1 + b2 * p2;
        let uv_hit = b0 * uv[0] + b1 * uv[1] + b2 * uv[2];
        let flip = mesh.reverse_orientation ^ mesh.transform_swaps_handedness;
        *si = SurfaceInteraction::new(
            p_hit,
            p_error,
            uv_hit,
            -ray.d.normalize(),
            dpdu,
            dpdv,
            Vec3::ZERO,
            Vec3::ZERO,
            ray.time,
            false,
        );
        let ng = dp02.cross(dp12).normalize();
        si.it.n = ng;
        si.shading.n = ng;
        if mesh.n.is_some() || mesh.s.is_some() {
            self.shading_geometry(si, b, &uv, flip);
        }
        if mesh.n.is_some() {
            si.it.n = face_forward(si.it.n, si.shading.n);
        } else if flip {
            si.it.n = -si.it.n;
            si.shading.n = si.it.n;
        }
    }

    /// Interpolated normals and tangents (pbrt-v3's `SetShadingGeometry`
    /// with authoritative orientation, including its orientation flip).
    fn shading_geometry(
        &self,
        si: &mut SurfaceInteraction,
        b: [f32; 3],
        uv: &[Vec2; 3],
        flip: bool,
    ) {
        let mesh = self.mesh;
        let [i0, i1, i2] = self.v.map(|i| i as usize);
        let ns = match &mesh.n {
            Some(n) => {
                let ns = b[0] * n[i0] + b[1] * n[i1] + b[2] * n[i2];
                if ns.length_squared() > 0.0 {
                    ns.normalize()
                } else {
                    si.it.n
                }
            }
            None => si.it.n,
        };
        let mut ss = match &mesh.s {
            Some(s) => {
                let ss = b[0] * s[i0] + b[1] * s[i1] + b[2] * s[i2];
                if ss.length_squared() > 0.0 {
                    ss.normalize()
                } else {
                    si.dpdu.normalize()
                }
            }
            None => si.dpdu.normalize(),
        };
        let mut ts = ss.cross(ns);
        if ts.length_squared() > 0.0 {
            ts = ts.normalize();
            ss = ts.cross(ns);
        } else {
            (ss, ts) = coordinate_system(ns);
        }
        let (mut dndu, mut dndv) = (Vec3::ZERO, Vec3::ZERO);
        if let Some(n) = &mesh.n {
            let (duv02, duv12) = (uv[0] - uv[2], uv[1] - uv[2]);
            let (dn1, dn2) = (n[i0] - n[i2], n[i1] - n[i2]);
            let determinant = duv02.x * duv12.y - duv02.y * duv12.x;
            if determinant.abs() >= 1e-8 {
                let inv = 1.0 / determinant;
                dndu = (duv12.y * dn1 - duv02.y * dn2) * inv;
                dndv = (-duv12.x * dn1 + duv02.x * dn2) * inv;
            }
        }
        let mut sn = ss.cross(ts).normalize();
        if flip {
            sn = -sn;
        }
        si.it.n = face_forward(si.it.n, sn);
        si.shading = Shading { n: sn, dpdu: ss, dpdv: ts, dndu, dndv };
    }

    /// Nearest hit, with the constant-zero alpha mask applied.
    pub fn intersect(&self, ray: &Ray) -> Option<(f32, SurfaceInteraction)> {
        self.intersect_with(ray, true)
    }

    /// Whether the ray hits (shadow rays: both alpha masks apply).
    pub fn intersect_p(&self, ray: &Ray) -> bool {
        self.intersect_p_prepared(ray, &TriRay::new(ray))
    }

    /// [`Triangle::intersect_p`] with `ray` prepared as `tr`.
    #[inline(always)]
    pub fn intersect_p_prepared(&self, ray: &Ray, tr: &TriRay) -> bool {
        let Some(h) = self.raw_hit_prepared(ray, tr) else { return false };
        let m = self.mesh;
        !(self.cuts(&m.alpha, ray, h.b) || self.cuts(&m.shadow_alpha, ray, h.b))
    }

    /// Area.
    pub fn area(&self) -> f32 {
        let (p0, p1, p2) = self.points();
        0.5 * (p1 - p0).cross(p2 - p0).length()
    }

    /// A uniform point and its area density.
    #[inline(always)]
    pub fn sample_area(&self, u: Vec2) -> (Interaction, f32) {
        (self.sample_point(u), 1.0 / self.area())
    }

    /// A uniform point, with its normal and error bound (pbrt-v3
    /// `Triangle::Sample`): the geometric normal, turned to the side of the
    /// interpolated shading normal where the mesh has normals and else
    /// oriented as [`Triangle::intersect`] orients it.
    #[inline(always)]
    pub fn sample_point(&self, u: Vec2) -> Interaction {
        self.sample_point_facing(u, self.geometric_normal())
    }

    /// The unit normal of the triangle's plane, `(p1 − p0) × (p2 − p0)`
    /// normalized, before any flip.
    #[inline(always)]
    pub fn geometric_normal(&self) -> Vec3 {
        let (p0, p1, p2) = self.points();
        (p1 - p0).cross(p2 - p0).normalize()
    }

    /// [`Triangle::sample_point`] given the [`Triangle::geometric_normal`]
    /// (which an area light works out once).
    #[inline(always)]
    pub fn sample_point_facing(&self, u: Vec2, geometric_normal: Vec3) -> Interaction {
        let b = uniform_sample_triangle(u);
        let (p0, p1, p2) = self.points();
        let b2 = 1.0 - b.x - b.y;
        let p = b.x * p0 + b.y * p1 + b2 * p2;
        let mut n = geometric_normal;
        match &self.mesh.n {
            Some(ns) => {
                let [i0, i1, i2] = self.v.map(|i| i as usize);
                n = face_forward(n, b.x * ns[i0] + b.y * ns[i1] + b2 * ns[i2]);
            }
            None if self.mesh.reverse_orientation ^ self.mesh.transform_swaps_handedness => n = -n,
            None => {}
        }
        let abs_sum = (b.x * p0).abs() + (b.y * p1).abs() + (b2 * p2).abs();
        Interaction { p, p_error: gamma(6) * abs_sum, n, time: 0.0 }
    }
}

#[cfg(test)]
#[path = "triangle_tests.rs"]
mod tests;
