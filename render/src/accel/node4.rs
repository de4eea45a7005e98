//! The 4-wide node the BVH's traversal walks, and its box test: four
//! children's boxes stored axis by axis, tested at once with pbrt-v3's
//! conservative slab test.

use farm_common::geometry::{gamma, Ray, Vec3};

/// Children per node of the traversed tree.
pub(super) const WIDTH: usize = 4;

/// One node of the 4-wide tree the traversal walks: the boxes of up to four
/// children, stored axis by axis so that one pass of slab arithmetic tests
/// all four (in SSE on x86-64, [`Node4::hit`]), and what each child
/// is. Collapsed from the binary SAH tree, which stays pbrt-v3's build.
#[derive(Clone, Copy, Debug, PartialEq)]
#[repr(C, align(64))]
pub(super) struct Node4 {
    /// The children's minimum corners in rows 0 … 2 (`[axis][child]`), their
    /// maximum ones in rows 3 … 5, so that row `3·dir_is_neg + axis` is an
    /// axis's near sides ([`SlabRay::near`]).
    pub(super) b: [[f32; WIDTH]; 6],
    /// An interior child's node index, or a leaf child's first primitive.
    pub(super) child: [u32; WIDTH],
    /// A leaf child's primitive count; 0 for an interior child.
    pub(super) count: [u8; WIDTH],
    /// Children in use; the rest of the lanes are never reported hit.
    pub(super) n: u8,
}

const _: () = assert!(std::mem::size_of::<Node4>() == 128);

/// A ray prepared for box tests: origin, reciprocal direction and which
/// side of each slab it enters by.
pub(super) struct SlabRay {
    o: Vec3,
    inv: Vec3,
    /// Per axis, the row of [`Node4::b`] holding the near sides, and the
    /// far ones: worked out once per ray, not per node.
    near: [usize; 3],
    far: [usize; 3],
}

impl SlabRay {
    #[inline(always)]
    pub(super) fn new(ray: &Ray) -> Self {
        let inv = Vec3::new(1.0 / ray.d.x, 1.0 / ray.d.y, 1.0 / ray.d.z);
        let neg = [(inv.x < 0.0) as usize, (inv.y < 0.0) as usize, (inv.z < 0.0) as usize];
        let near = [3 * neg[0], 1 + 3 * neg[1], 2 + 3 * neg[2]];
        let far = [3 - 3 * neg[0], 4 - 3 * neg[1], 5 - 3 * neg[2]];
        SlabRay { o: ray.o, inv, near, far }
    }
}

impl Node4 {
    /// pbrt-v3's slab test with precomputed reciprocal direction and signs,
    /// on all four children: far distances are rounded up by 1 + 2γ₃ so that
    /// no hit is lost. An axis whose slab test is undefined (a ray in the
    /// plane of a face, 0·∞) does not constrain the ray: that keeps such
    /// grazing rays, where pbrt-v3 keeps or drops them by axis. Returns a
    /// bit mask of the children hit and each child's entry distance.
    #[cfg_attr(not(target_arch = "x86_64"), inline(always))]
    #[cfg_attr(target_arch = "x86_64", allow(dead_code))]
    pub(super) fn hit_portable(&self, r: &SlabRay, ray_t_max: f32) -> (u32, [f32; WIDTH]) {
        let up = 1.0 + 2.0 * gamma(3);
        let (o, inv) = (r.o.to_array(), r.inv.to_array());
        let mut t_near = [f32::NEG_INFINITY; WIDTH];
        let mut t_far = [f32::INFINITY; WIDTH];
        for axis in 0..3 {
            let near = &self.b[r.near[axis]];
            let far = &self.b[r.far[axis]];
            for l in 0..WIDTH {
                let tn = (near[l] - o[axis]) * inv[axis];
                let tf = (far[l] - o[axis]) * inv[axis];
                // Written so that a NaN distance leaves the bound alone.
                t_near[l] = if tn > t_near[l] { tn } else { t_near[l] };
                t_far[l] = if tf < t_far[l] { tf } else { t_far[l] };
            }
        }
        let mut mask = 0;
        for l in 0..WIDTH {
            let far = t_far[l] * up;
            let hit = t_near[l] <= far && t_near[l] < ray_t_max && far > 0.0;
            mask |= (hit as u32) << l;
        }
        (mask & ((1 << self.n) - 1), t_near)
    }

    /// [`Node4::hit_portable`] in SSE, which every x86-64 CPU has: the same
    /// operations lane by lane, so the same bits, but the hit mask made by
    /// three vector compares and a movemask, where the compiler built it
    /// lane by lane (about 30 instructions a node).
    #[cfg(target_arch = "x86_64")]
    #[inline(always)]
    pub(super) fn hit(&self, r: &SlabRay, ray_t_max: f32) -> (u32, [f32; WIDTH]) {
        use std::arch::x86_64::*;
        // SAFETY: SSE and SSE2 are part of every x86-64 target, so these
        // intrinsics only compute; the loads are of arrays by value.
        unsafe {
            let up = _mm_set1_ps(1.0 + 2.0 * gamma(3));
            let (o, inv) = (r.o.to_array(), r.inv.to_array());
            let row = |i: usize| {
                let b = &self.b[i];
                _mm_set_ps(b[3], b[2], b[1], b[0])
            };
            let mut t_near = _mm_set1_ps(f32::NEG_INFINITY);
            let mut t_far = _mm_set1_ps(f32::INFINITY);
            for axis in 0..3 {
                let (o, inv) = (_mm_set1_ps(o[axis]), _mm_set1_ps(inv[axis]));
                let tn = _mm_mul_ps(_mm_sub_ps(row(r.near[axis]), o), inv);
                let tf = _mm_mul_ps(_mm_sub_ps(row(r.far[axis]), o), inv);
                // maxps(a, b) is a > b ? a : b, so a NaN distance leaves the
                // bound alone, as in the portable test; minps likewise.
                t_near = _mm_max_ps(tn, t_near);
                t_far = _mm_min_ps(tf, t_far);
            }
            let far = _mm_mul_ps(t_far, up);
            let hit = _mm_and_ps(
                _mm_and_ps(_mm_cmple_ps(t_near, far), _mm_cmplt_ps(t_near, _mm_set1_ps(ray_t_max))),
                _mm_cmpgt_ps(far, _mm_setzero_ps()),
            );
            let mask = _mm_movemask_ps(hit) as u32;
            let mut out = [0.0f32; WIDTH];
            for (l, v) in out.iter_mut().enumerate() {
                *v = match l {
                    0 => _mm_cvtss_f32(t_near),
                    1 => _mm_cvtss_f32(_mm_shuffle_ps::<0b01>(t_near, t_near)),
                    2 => _mm_cvtss_f32(_mm_shuffle_ps::<0b10>(t_near, t_near)),
                    _ => _mm_cvtss_f32(_mm_shuffle_ps::<0b11>(t_near, t_near)),
                };
            }
            (mask & ((1 << self.n) - 1), out)
        }
    }

    /// [`Node4::hit_portable`] where there is no SSE version.
    #[cfg(not(target_arch = "x86_64"))]
    #[inline(always)]
    pub(super) fn hit(&self, r: &SlabRay, ray_t_max: f32) -> (u32, [f32; WIDTH]) {
        self.hit_portable(r, ray_t_max)
    }
}
