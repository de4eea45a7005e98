//! The 8-wide node the BVH's traversal walks, and its box test: eight
//! children's boxes stored axis by axis, tested at once with pbrt-v3's
//! conservative slab test, in AVX where the CPU has it and as two SSE
//! halves where it does not. Every path does the same operations lane by
//! lane, so the tree, the traversal order and every hit are the same on
//! every host; only the speed differs.

use farm_common::geometry::{gamma, Ray, Vec3};
use std::sync::atomic::{AtomicU8, Ordering};

/// Children per node of the traversed tree.
pub(super) const WIDTH: usize = 8;

/// One node of the 8-wide tree the traversal walks: the boxes of up to eight
/// children, stored axis by axis so that one pass of slab arithmetic tests
/// all eight ([`Node::hit`]), and what each child is. Collapsed from the
/// binary SAH tree, which stays pbrt-v3's build.
#[derive(Clone, Copy, Debug, PartialEq)]
#[repr(C, align(64))]
pub(super) struct Node {
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

const _: () = assert!(std::mem::size_of::<Node>() == 256);

/// A ray prepared for box tests: origin, reciprocal direction and which
/// side of each slab it enters by.
pub(super) struct SlabRay {
    o: Vec3,
    inv: Vec3,
    /// Per axis, the row of [`Node::b`] holding the near sides, and the
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

/// Which instructions the box test runs on. The choice changes no bit of
/// any result: [`Node::hit`] gives the same mask and distances on each.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Simd {
    /// Plain Rust, lane by lane (any CPU).
    Portable,
    /// SSE, four lanes at a time: every x86-64 CPU.
    Sse,
    /// AVX, all eight lanes at once: x86-64 CPUs that have it.
    Avx,
}

/// The box test in use: 0 until first asked, then 1 + the [`Simd`] index.
static SIMD: AtomicU8 = AtomicU8::new(0);

const LEVELS: [Simd; 3] = [Simd::Portable, Simd::Sse, Simd::Avx];

/// The best box test this CPU runs.
pub fn detected_simd() -> Simd {
    #[cfg(target_arch = "x86_64")]
    {
        if std::arch::is_x86_feature_detected!("avx") {
            return Simd::Avx;
        }
        Simd::Sse
    }
    #[cfg(not(target_arch = "x86_64"))]
    Simd::Portable
}

/// The box test of the BVHs built from now on (those walked in a vector
/// test of their own: see [`super::Bvh::intersect`]): the CPU's best
/// unless [`force_simd`] chose another.
pub fn simd() -> Simd {
    let v = match SIMD.load(Ordering::Relaxed) {
        0 => {
            let s = 1 + detected_simd() as u8;
            // Another thread may have set it first (forced, or the same).
            match SIMD.compare_exchange(0, s, Ordering::Relaxed, Ordering::Relaxed) {
                Ok(_) => s,
                Err(v) => v,
            }
        }
        v => v,
    };
    LEVELS[usize::from(v - 1)]
}

/// Makes the BVHs built from now on in this process use `level` (the
/// CPU's best for `None`) where [`simd`] decides, so that tests can
/// compare each path's bits. Returns `false`, changing nothing, when this
/// CPU cannot run `level`.
pub fn force_simd(level: Option<Simd>) -> bool {
    let best = detected_simd();
    let level = level.unwrap_or(best);
    // x86-64 runs SSE or AVX; the portable test is the other targets' path.
    let runs = match level {
        Simd::Portable => best == Simd::Portable,
        Simd::Sse => best != Simd::Portable,
        Simd::Avx => best == Simd::Avx,
    };
    if runs {
        SIMD.store(1 + level as u8, Ordering::Relaxed);
    }
    runs
}

/// A box test: one of [`Node`]'s, chosen at compile time inside each
/// traversal loop. A value of the type is the right to run it.
pub(super) trait BoxTest: Copy {
    fn hit(self, node: &Node, r: &SlabRay, ray_t_max: f32) -> (u32, [f32; WIDTH]);
}

/// [`Node::hit_portable`].
#[cfg(not(target_arch = "x86_64"))]
#[derive(Clone, Copy, Default)]
pub(super) struct Portable;
/// [`Node::hit_sse`].
#[cfg(target_arch = "x86_64")]
#[derive(Clone, Copy, Default)]
pub(super) struct Sse;
/// [`Node::hit_avx`]; made only by [`Avx::new_unchecked`], so safe code
/// cannot run it on a CPU without AVX.
#[cfg(target_arch = "x86_64")]
#[derive(Clone, Copy)]
pub(super) struct Avx(());

#[cfg(target_arch = "x86_64")]
impl Avx {
    /// # Safety
    /// The CPU must have AVX.
    pub(super) unsafe fn new_unchecked() -> Self {
        Avx(())
    }
}

#[cfg(not(target_arch = "x86_64"))]
impl BoxTest for Portable {
    #[inline(always)]
    fn hit(self, node: &Node, r: &SlabRay, ray_t_max: f32) -> (u32, [f32; WIDTH]) {
        node.hit_portable(r, ray_t_max)
    }
}

#[cfg(target_arch = "x86_64")]
impl BoxTest for Sse {
    #[inline(always)]
    fn hit(self, node: &Node, r: &SlabRay, ray_t_max: f32) -> (u32, [f32; WIDTH]) {
        node.hit_sse(r, ray_t_max)
    }
}

#[cfg(target_arch = "x86_64")]
impl BoxTest for Avx {
    /// Inlined into [`super::bvh`]'s `#[target_feature]` walks.
    #[inline(always)]
    fn hit(self, node: &Node, r: &SlabRay, ray_t_max: f32) -> (u32, [f32; WIDTH]) {
        // SAFETY: an `Avx` exists only where the CPU has AVX.
        unsafe { node.hit_avx(r, ray_t_max) }
    }
}

/// `1 + 2γ₃`: far distances are rounded up by it so that no hit is lost.
#[inline(always)]
fn round_up() -> f32 {
    1.0 + 2.0 * gamma(3)
}

impl Node {
    /// The primitives of leaf child `l` (empty for an interior child).
    #[inline(always)]
    pub(super) fn prims(&self, l: usize) -> std::ops::Range<usize> {
        let start = self.child[l] as usize;
        start..start + usize::from(self.count[l])
    }

    /// pbrt-v3's slab test with precomputed reciprocal direction and signs,
    /// on all eight children: far distances are rounded up by 1 + 2γ₃ so
    /// that no hit is lost. An axis whose slab test is undefined (a ray in
    /// the plane of a face, 0·∞) does not constrain the ray: that keeps
    /// such grazing rays, where pbrt-v3 keeps or drops them by axis.
    /// Returns a bit mask of the children hit and each child's entry
    /// distance.
    #[inline(always)]
    #[cfg_attr(target_arch = "x86_64", allow(dead_code))]
    pub(super) fn hit_portable(&self, r: &SlabRay, ray_t_max: f32) -> (u32, [f32; WIDTH]) {
        let up = round_up();
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

    /// [`Node::hit_portable`] in SSE, which every x86-64 CPU has, four
    /// lanes at a time: the same operations lane by lane, so the same bits.
    #[cfg(target_arch = "x86_64")]
    #[inline(always)]
    pub(super) fn hit_sse(&self, r: &SlabRay, ray_t_max: f32) -> (u32, [f32; WIDTH]) {
        use std::arch::x86_64::*;
        let (o, inv) = (r.o.to_array(), r.inv.to_array());
        let mut out = [0.0f32; WIDTH];
        let mut mask = 0;
        // SAFETY: SSE and SSE2 are part of every x86-64 target; the loads
        // and stores are of four floats inside the node's rows and `out`.
        unsafe {
            let up = _mm_set1_ps(round_up());
            for half in 0..WIDTH / 4 {
                // A node of few children (a small tree's only one) is
                // often no wider than four.
                if 4 * half >= usize::from(self.n) {
                    break;
                }
                let row = |i: usize| _mm_loadu_ps(self.b[i].as_ptr().add(4 * half));
                let mut t_near = _mm_set1_ps(f32::NEG_INFINITY);
                let mut t_far = _mm_set1_ps(f32::INFINITY);
                for axis in 0..3 {
                    let (o, inv) = (_mm_set1_ps(o[axis]), _mm_set1_ps(inv[axis]));
                    let tn = _mm_mul_ps(_mm_sub_ps(row(r.near[axis]), o), inv);
                    let tf = _mm_mul_ps(_mm_sub_ps(row(r.far[axis]), o), inv);
                    // maxps(a, b) is a > b ? a : b, so a NaN distance leaves
                    // the bound alone, as in the portable test; minps likewise.
                    t_near = _mm_max_ps(tn, t_near);
                    t_far = _mm_min_ps(tf, t_far);
                }
                let far = _mm_mul_ps(t_far, up);
                let hit = _mm_and_ps(
                    _mm_and_ps(
                        _mm_cmple_ps(t_near, far),
                        _mm_cmplt_ps(t_near, _mm_set1_ps(ray_t_max)),
                    ),
                    _mm_cmpgt_ps(far, _mm_setzero_ps()),
                );
                mask |= (_mm_movemask_ps(hit) as u32) << (4 * half);
                _mm_storeu_ps(out.as_mut_ptr().add(4 * half), t_near);
            }
        }
        (mask & ((1 << self.n) - 1), out)
    }

    /// [`Node::hit_portable`] in AVX, all eight lanes at once: the same
    /// operations lane by lane, so the same bits (the compares are the
    /// ordered, quiet ones, false for NaN like SSE's).
    ///
    /// `#[inline]`: without it the AVX walks called it, once a node
    /// (the walks have AVX too, so it can be inlined into them); inlined,
    /// the Embree comparison's walks took 4–13% less time.
    ///
    /// # Safety
    /// The CPU must have AVX.
    #[cfg(target_arch = "x86_64")]
    #[target_feature(enable = "avx")]
    #[inline]
    pub(super) unsafe fn hit_avx(&self, r: &SlabRay, ray_t_max: f32) -> (u32, [f32; WIDTH]) {
        use std::arch::x86_64::*;
        let (o, inv) = (r.o.to_array(), r.inv.to_array());
        let mut out = [0.0f32; WIDTH];
        // SAFETY: the loads and stores are of the node's rows and `out`,
        // eight floats each.
        unsafe {
            let row = |i: usize| _mm256_loadu_ps(self.b[i].as_ptr());
            let mut t_near = _mm256_set1_ps(f32::NEG_INFINITY);
            let mut t_far = _mm256_set1_ps(f32::INFINITY);
            for axis in 0..3 {
                let (o, inv) = (_mm256_set1_ps(o[axis]), _mm256_set1_ps(inv[axis]));
                let tn = _mm256_mul_ps(_mm256_sub_ps(row(r.near[axis]), o), inv);
                let tf = _mm256_mul_ps(_mm256_sub_ps(row(r.far[axis]), o), inv);
                t_near = _mm256_max_ps(tn, t_near);
                t_far = _mm256_min_ps(tf, t_far);
            }
            let far = _mm256_mul_ps(t_far, _mm256_set1_ps(round_up()));
            let hit = _mm256_and_ps(
                _mm256_and_ps(
                    _mm256_cmp_ps::<_CMP_LE_OQ>(t_near, far),
                    _mm256_cmp_ps::<_CMP_LT_OQ>(t_near, _mm256_set1_ps(ray_t_max)),
                ),
                _mm256_cmp_ps::<_CMP_GT_OQ>(far, _mm256_setzero_ps()),
            );
            let mask = _mm256_movemask_ps(hit) as u32;
            _mm256_storeu_ps(out.as_mut_ptr(), t_near);
            (mask & ((1 << self.n) - 1), out)
        }
    }
}
