//! The any-hit walks (shadow rays): [`Bvh::intersect_any`] and its forms
//! for a tree of one node and for AVX.

#[cfg(target_arch = "x86_64")]
use super::super::node::Avx;
use super::super::node::{BoxTest, SlabRay};
use super::{any_in_leaf, prefetch_node, Bvh, Inline, Stack, WIDE_STACK_SIZE};
use farm_common::geometry::Ray;

impl Bvh {
    /// Any hit: like [`Bvh::intersect`] but stops at the first primitive
    /// for which `f` returns `true` (shadow rays), in no particular order.
    #[inline(always)]
    pub fn intersect_any<F: FnMut(usize, &Ray) -> bool>(&self, ray: &Ray, mut f: F) -> bool {
        self.intersect_any_leaves(
            ray,
            #[inline(always)]
            |prims, r| any_in_leaf(prims, r, &mut f),
        )
    }

    /// [`Bvh::intersect_any`] a leaf at a time: `leaf(prims, ray)` says
    /// whether any of the primitives `prims` blocks `ray`.
    #[inline(always)]
    pub fn intersect_any_leaves<L: FnMut(std::ops::Range<usize>, &Ray) -> bool>(
        &self,
        ray: &Ray,
        f: L,
    ) -> bool {
        if self.nodes.is_empty() {
            return false;
        }
        if self.nodes.len() == 1 {
            return self.any_one_node(ray, f);
        }
        #[cfg(target_arch = "x86_64")]
        if self.avx {
            // SAFETY: `avx` is set only where `simd` found AVX.
            return unsafe { self.any_avx(ray, f) };
        }
        self.any(Inline::default(), ray, f)
    }

    /// [`Bvh::any`] on a tree of one node, whose children are all leaves:
    /// the leaves hit, in lane order as there, with no stack.
    #[inline(always)]
    pub(super) fn any_one_node<L: FnMut(std::ops::Range<usize>, &Ray) -> bool>(
        &self,
        ray: &Ray,
        mut leaf: L,
    ) -> bool {
        let node = &self.nodes[0];
        let (mut mask, _) = Inline::default().hit(node, &SlabRay::new(ray), ray.t_max);
        while mask != 0 {
            let l = mask.trailing_zeros() as usize;
            mask &= mask - 1;
            if leaf(node.prims(l), ray) {
                return true;
            }
        }
        false
    }

    /// [`Bvh::any`] compiled for AVX.
    #[cfg(target_arch = "x86_64")]
    #[target_feature(enable = "avx")]
    pub(super) unsafe fn any_avx<L: FnMut(std::ops::Range<usize>, &Ray) -> bool>(
        &self,
        ray: &Ray,
        f: L,
    ) -> bool {
        // SAFETY: the caller's contract: the CPU has AVX.
        self.any(unsafe { Avx::new_unchecked() }, ray, f)
    }

    /// [`Bvh::intersect_any`]'s walk with the box test `T`.
    #[inline(always)]
    pub(super) fn any<T: BoxTest, L: FnMut(std::ops::Range<usize>, &Ray) -> bool>(
        &self,
        test: T,
        ray: &Ray,
        mut leaf: L,
    ) -> bool {
        let r = SlabRay::new(ray);
        let mut stack: Stack<u32, WIDE_STACK_SIZE> = Stack::new();
        stack.push(0);
        while let Some(n) = stack.pop() {
            let node = &self.nodes[n as usize];
            let (mut mask, _) = test.hit(node, &r, ray.t_max);
            while mask != 0 {
                let l = mask.trailing_zeros() as usize;
                mask &= mask - 1;
                if node.count[l] == 0 {
                    prefetch_node(&self.nodes, node.child[l]);
                    stack.push(node.child[l]);
                    continue;
                }
                if leaf(node.prims(l), ray) {
                    return true;
                }
            }
        }
        false
    }
}
