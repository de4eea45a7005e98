//! pbrt-v3's watertight ray–triangle test ([`Triangle`]'s) on the three or
//! four triangles of a shared BVH leaf at once, in SSE, which every x86-64
//! CPU has. Each lane does the scalar test's operations in its order (no
//! fused multiply-adds; glam's `max_element` is `maxps`; compares are the
//! ordered ones, false for NaN as Rust's are), so a lane hits where the
//! scalar test hits, with the same bits in every value that is not a NaN
//! (whose payload Rust leaves unspecified). The leaves it declines
//! ([`test`] returns `None`) go to the scalar test, triangle by triangle:
//! a lane whose edge function is exactly zero (which the scalar test
//! redoes in double precision), a mesh with an alpha mask, a shape that is
//! not a triangle, and every leaf on other targets. So do leaves of one or
//! two triangles: there the scalar test, which stops at the edge functions
//! of a triangle missed, ran fewer instructions (killeroo-simple: 1.2% more
//! in all with four lanes for them, 1–4% more time; leaving them out cost
//! the kernel bench's walks about a fifth of their gain, below).
//!
//! On the kernel bench's dump (`FARM_DUMP_DIR`; its 100k-triangle torus
//! and 1M-triangle sphere, one thread, ns a ray, alternating runs), the
//! bare walk's closest hit went from 182/183 to 157/156 (torus, camera
//! rays), 371/361 to 339/333 (torus, shadow rays) and 174/185 to 167/168
//! (sphere, camera rays); the aggregate's any hit from 144/144 to 124/124
//! and 278/279 to 236/245 on the torus's. The sphere's incoherent rays,
//! which test about one triangle a ray, were level.
//!
//! [`Triangle`]: super::Triangle

use super::triangle::{AlphaMask, TriRay};
use super::Shape;
use crate::primitive::Primitive;
use farm_common::geometry::Ray;

/// Triangles tested at once.
pub const LANES: usize = 4;

/// The fewest triangles a leaf must hold for [`test`] to take it.
pub const FEWEST: usize = 3;

/// What [`test`] found in each lane, before the end of the ray's range is
/// checked against its `t_max` as it stands when the lane's turn comes
/// ([`Quad::within`]): the closest-hit walk shortens the ray after each
/// hit, lane by lane, as the scalar loop does.
#[derive(Clone, Copy, Debug, Default)]
pub struct Quad {
    /// The lanes whose triangle the ray hits within the `t_max` it was
    /// tested with (a shorter `t_max` only ever drops lanes).
    pub mask: u32,
    /// Each lane's hit distance.
    pub t: [f32; LANES],
    /// Its barycentrics.
    pub b: [[f32; LANES]; 3],
    t_scaled: [f32; LANES],
    det: [f32; LANES],
}

impl Quad {
    /// Whether lane `k`'s hit (in [`Quad::mask`]) lies within `t_max`: the
    /// scalar test's own check on its scaled distance.
    #[inline(always)]
    pub fn within(&self, k: usize, t_max: f32) -> bool {
        let (ts, det) = (self.t_scaled[k], self.det[k]);
        !(det < 0.0 && (ts >= 0.0 || ts < t_max * det))
            && !(det > 0.0 && (ts <= 0.0 || ts > t_max * det))
    }

    /// The closest-hit walk's loop over a leaf: lane by lane, a lane whose
    /// hit lies within `ray`'s `t_max` as it stands is a hit, is passed to
    /// `hit`, and shortens `ray` to it, as the scalar loop shortens it
    /// after each triangle. Returns whether any lane hit.
    #[inline(always)]
    pub fn accept(&self, ray: &mut Ray, mut hit: impl FnMut(usize)) -> bool {
        let mut any = false;
        let mut lanes = self.mask;
        while lanes != 0 {
            let k = lanes.trailing_zeros() as usize;
            lanes &= lanes - 1;
            if self.within(k, ray.t_max) {
                any = true;
                hit(k);
                if self.t[k] < ray.t_max {
                    ray.t_max = self.t[k];
                }
            }
        }
        any
    }

    /// Lane `k`'s barycentrics.
    #[inline(always)]
    pub fn barycentrics(&self, k: usize) -> [f32; 3] {
        [self.b[0][k], self.b[1][k], self.b[2][k]]
    }
}

/// Tests `ray` (prepared as `tr`) against the triangles `prims` (three or
/// [`LANES`]), as the scalar test does each: for a shadow ray
/// (`shadow`), as `intersect_p` does. `None` where the scalar test must
/// decide (see the module's doc).
#[inline(always)]
pub fn test(prims: &[Primitive], ray: &Ray, tr: &TriRay, shadow: bool) -> Option<Quad> {
    #[cfg(target_arch = "x86_64")]
    {
        if prims.len() < FEWEST || prims.len() > LANES {
            return None;
        }
        #[cfg(test)]
        if tests::SCALAR_ONLY.get() {
            return None;
        }
        // Vertex coordinates, [vertex · 3 + axis][lane]; lanes past the
        // leaf's repeat its first triangle and are masked off at the end.
        // (Gathered through memory: building each row in registers was
        // 10–20% slower on the kernel bench.)
        let mut c = [[0.0f32; LANES]; 9];
        // The mesh whose masks were looked at last: a leaf's triangles are
        // mostly of one mesh.
        let mut checked: *const super::TriangleMesh = std::ptr::null();
        for (k, p) in prims.iter().enumerate() {
            let Shape::Triangle { mesh, v } = &p.shape else { return None };
            if !std::ptr::eq(checked, &**mesh) {
                let masked = |a: &AlphaMask| !matches!(a, AlphaMask::None);
                if masked(&mesh.alpha) || (shadow && masked(&mesh.shadow_alpha)) {
                    return None;
                }
                checked = &**mesh;
            }
            for (j, &i) in v.iter().enumerate() {
                let q = mesh.p[i as usize];
                c[3 * j][k] = q.x;
                c[3 * j + 1][k] = q.y;
                c[3 * j + 2][k] = q.z;
            }
        }
        for row in &mut c {
            for k in prims.len()..LANES {
                row[k] = row[0];
            }
        }
        // SAFETY: SSE and SSE2 are part of every x86-64 target.
        unsafe { sse::test(&c, prims.len(), ray, tr) }
    }
    #[cfg(not(target_arch = "x86_64"))]
    {
        let _ = (prims, ray, tr, shadow);
        None
    }
}

#[cfg(target_arch = "x86_64")]
mod sse {
    use super::{Quad, LANES};
    use crate::shapes::triangle::TriRay;
    use farm_common::geometry::{gamma, Ray};
    use std::arch::x86_64::*;

    /// |x|, as `f32::abs`: the sign bit cleared.
    #[inline(always)]
    unsafe fn abs(x: __m128) -> __m128 {
        _mm_and_ps(x, _mm_castsi128_ps(_mm_set1_epi32(0x7fff_ffff)))
    }

    /// glam's `Vec3::new(a, b, c).max_element()`: `max(a, max(b, c))` with
    /// `max(x, y) = if x > y { x } else { y }`, which is `maxps(x, y)`.
    #[inline(always)]
    unsafe fn max3(a: __m128, b: __m128, c: __m128) -> __m128 {
        _mm_max_ps(a, _mm_max_ps(b, c))
    }

    /// [`super::test`]'s arithmetic on gathered vertices `c` of `n` lanes.
    #[inline(always)]
    pub(super) unsafe fn test(
        c: &[[f32; LANES]; 9],
        n: usize,
        ray: &Ray,
        tr: &TriRay,
    ) -> Option<Quad> {
        let (kz, s) = tr.parts();
        // The permutation: axes (kz + 1, kz + 2, kz) become (x, y, z).
        let (ax, ay, az) = ((kz + 1) % 3, (kz + 2) % 3, kz);
        let o = ray.o.to_array();
        // Vertex j's coordinate on `axis`, less the ray's origin there.
        let rel = |j: usize, axis: usize| {
            _mm_sub_ps(_mm_loadu_ps(c[3 * j + axis].as_ptr()), _mm_set1_ps(o[axis]))
        };
        let (sx, sy, sz) = (_mm_set1_ps(s[0]), _mm_set1_ps(s[1]), _mm_set1_ps(s[2]));
        let mut x = [_mm_setzero_ps(); 3];
        let mut y = [_mm_setzero_ps(); 3];
        let mut z = [_mm_setzero_ps(); 3];
        for j in 0..3 {
            let (px, py, pz) = (rel(j, ax), rel(j, ay), rel(j, az));
            // The shear: p.x += sx · p.z, p.y += sy · p.z.
            x[j] = _mm_add_ps(px, _mm_mul_ps(sx, pz));
            y[j] = _mm_add_ps(py, _mm_mul_ps(sy, pz));
            z[j] = pz;
        }
        let edge = |a: usize, b: usize| _mm_sub_ps(_mm_mul_ps(x[a], y[b]), _mm_mul_ps(y[a], x[b]));
        let (e0, e1, e2) = (edge(1, 2), edge(2, 0), edge(0, 1));
        let zero = _mm_setzero_ps();
        let lanes = (1u32 << n) - 1;
        // An edge function of exactly zero is redone in double precision
        // by the scalar test: the whole leaf goes there.
        let any_zero = _mm_or_ps(
            _mm_or_ps(_mm_cmpeq_ps(e0, zero), _mm_cmpeq_ps(e1, zero)),
            _mm_cmpeq_ps(e2, zero),
        );
        if _mm_movemask_ps(any_zero) as u32 & lanes != 0 {
            return None;
        }
        let or3 = |a, b, c| _mm_or_ps(_mm_or_ps(a, b), c);
        let some_neg = or3(_mm_cmplt_ps(e0, zero), _mm_cmplt_ps(e1, zero), _mm_cmplt_ps(e2, zero));
        let some_pos = or3(_mm_cmpgt_ps(e0, zero), _mm_cmpgt_ps(e1, zero), _mm_cmpgt_ps(e2, zero));
        let mut reject = _mm_and_ps(some_neg, some_pos);
        // Most leaves a ray reaches it misses, outside an edge of every
        // triangle: done, as the scalar test is done there.
        if !(_mm_movemask_ps(reject) as u32) & lanes == 0 {
            return Some(Quad::default());
        }
        let det = _mm_add_ps(_mm_add_ps(e0, e1), e2);
        reject = _mm_or_ps(reject, _mm_cmpeq_ps(det, zero));
        let (z0, z1, z2) = (_mm_mul_ps(z[0], sz), _mm_mul_ps(z[1], sz), _mm_mul_ps(z[2], sz));
        let t_scaled =
            _mm_add_ps(_mm_add_ps(_mm_mul_ps(e0, z0), _mm_mul_ps(e1, z1)), _mm_mul_ps(e2, z2));
        let range = _mm_mul_ps(_mm_set1_ps(ray.t_max), det);
        let behind_neg = _mm_and_ps(
            _mm_cmplt_ps(det, zero),
            _mm_or_ps(_mm_cmpge_ps(t_scaled, zero), _mm_cmplt_ps(t_scaled, range)),
        );
        let behind_pos = _mm_and_ps(
            _mm_cmpgt_ps(det, zero),
            _mm_or_ps(_mm_cmple_ps(t_scaled, zero), _mm_cmpgt_ps(t_scaled, range)),
        );
        reject = or3(reject, behind_neg, behind_pos);
        let inv_det = _mm_div_ps(_mm_set1_ps(1.0), det);
        let b = [_mm_mul_ps(e0, inv_det), _mm_mul_ps(e1, inv_det), _mm_mul_ps(e2, inv_det)];
        let t = _mm_mul_ps(t_scaled, inv_det);
        // t conservatively greater than zero, as the scalar test bounds it.
        let g = |n: i32| _mm_set1_ps(gamma(n));
        let max_zt = max3(abs(z0), abs(z1), abs(z2));
        let delta_z = _mm_mul_ps(g(3), max_zt);
        let max_xt = max3(abs(x[0]), abs(x[1]), abs(x[2]));
        let max_yt = max3(abs(y[0]), abs(y[1]), abs(y[2]));
        let delta_x = _mm_mul_ps(g(5), _mm_add_ps(max_xt, max_zt));
        let delta_y = _mm_mul_ps(g(5), _mm_add_ps(max_yt, max_zt));
        let delta_e = _mm_mul_ps(
            _mm_set1_ps(2.0),
            _mm_add_ps(
                _mm_add_ps(
                    _mm_mul_ps(_mm_mul_ps(g(2), max_xt), max_yt),
                    _mm_mul_ps(delta_y, max_xt),
                ),
                _mm_mul_ps(delta_x, max_yt),
            ),
        );
        let max_e = max3(abs(e0), abs(e1), abs(e2));
        let delta_t = _mm_mul_ps(
            _mm_mul_ps(
                _mm_set1_ps(3.0),
                _mm_add_ps(
                    _mm_add_ps(
                        _mm_mul_ps(_mm_mul_ps(g(3), max_e), max_zt),
                        _mm_mul_ps(delta_e, max_zt),
                    ),
                    _mm_mul_ps(delta_z, max_e),
                ),
            ),
            abs(inv_det),
        );
        reject = _mm_or_ps(reject, _mm_cmple_ps(t, delta_t));
        let mut q = Quad { mask: !(_mm_movemask_ps(reject) as u32) & lanes, ..Quad::default() };
        _mm_storeu_ps(q.t.as_mut_ptr(), t);
        _mm_storeu_ps(q.t_scaled.as_mut_ptr(), t_scaled);
        _mm_storeu_ps(q.det.as_mut_ptr(), det);
        for (out, v) in q.b.iter_mut().zip(b) {
            _mm_storeu_ps(out.as_mut_ptr(), v);
        }
        Some(q)
    }
}

#[cfg(test)]
#[path = "triangle4_tests.rs"]
mod tests;
