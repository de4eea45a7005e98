//! A bounding volume hierarchy over primitive bounds, built with the binned
//! surface area heuristic after pbrt-v3's `BVHAccel` (`accelerators/bvh.cpp`,
//! split method `"sah"`):
//!
//! ```text
//! Accelerator "bvh" "integer maxnodeprims" 4
//! ```
//!
//! The binary tree pbrt-v3 builds is then collapsed into 8-wide nodes, whose
//! eight child boxes one vectorised slab test checks at once (AVX where the
//! CPU has it, two SSE halves where not; the same tree and bits on every
//! host, see `node.rs`). Closest-hit
//! traversal visits the children hit nearest first and drops any whose
//! entry lies beyond the closest hit found so far; shadow rays stop at the
//! first blocker. On a 100k-triangle mesh (`cargo bench -p farm-render
//! --bench kernels -- bvh::`) 4-wide nodes made camera rays 2.4× and shadow
//! rays 3.4× faster than the binary tree, and 8-wide ones in AVX another
//! 12–19% (any hit 1.13–1.26 → 1.01–1.02 ms, closest hit 0.86–0.89 →
//! 0.75–0.77 ms).

#[cfg(target_arch = "x86_64")]
use super::node::Avx;
use super::node::{simd, BoxTest, Node, Simd, SlabRay, WIDTH};

/// The box test of the walks compiled into their callers: SSE on x86-64
/// (AVX is a walk of its own, see [`Bvh::intersect_leaves`]).
#[cfg(target_arch = "x86_64")]
type Inline = super::node::Sse;
#[cfg(not(target_arch = "x86_64"))]
type Inline = super::node::Portable;
use super::collapse::{collapse, stack_need};
use super::sah::{build_node, Extent, Limits, PrimInfo, COSTLY};
use farm_common::geometry::{Bounds3f, Ray, Vec3};
use std::mem::MaybeUninit;

/// pbrt-v3's default `maxnodeprims`.
pub const DEFAULT_MAX_PRIMS_IN_NODE: usize = 4;

/// Depth of the traversal stack; the build keeps every leaf shallower.
pub(super) const STACK_SIZE: usize = 64;

/// One node of the flattened tree (pbrt-v3 `LinearBVHNode`, 32 bytes). An
/// interior node's first child follows it; `offset` is its second child.
/// A leaf's primitives are `offset..offset + n_prims` in the build order.
#[derive(Clone, Copy, Debug, PartialEq)]
#[repr(C, align(32))]
pub(super) struct LinearNode {
    /// `[min, max]`.
    pub(super) b: [[f32; 3]; 2],
    pub(super) offset: u32,
    pub(super) n_prims: u16,
}

const _: () = assert!(std::mem::size_of::<LinearNode>() == 32);

impl LinearNode {
    pub(super) fn new(bounds: &Bounds3f, offset: u32, n_prims: u16) -> Self {
        LinearNode { b: [bounds.min.to_array(), bounds.max.to_array()], offset, n_prims }
    }

    pub(super) fn bounds(&self) -> Bounds3f {
        Bounds3f { min: Vec3::from(self.b[0]), max: Vec3::from(self.b[1]) }
    }

    pub(super) fn is_leaf(&self) -> bool {
        self.n_prims > 0
    }
}

/// Depth of the traversal stack that holds for any tree: a node pops one
/// entry and pushes at most [`WIDTH`], and the wide tree is no deeper than
/// the binary one.
const WIDE_STACK_SIZE: usize = (WIDTH - 1) * STACK_SIZE + 1;

/// Depth of the closest-hit walk's stack for the trees that need no more
/// by [`stack_need`]'s bound: nearly all (every shared scene's tree needs
/// under 70). Its 16-byte entries then take 2 KB of the caller's frame;
/// the 7 KB that any tree may need made the compiler probe two stack
/// pages on every call.
const SHALLOW_STACK_SIZE: usize = 2 * STACK_SIZE + 1;

/// Trees of fewer nodes are walked inline in SSE, not in AVX: the call
/// into the AVX walk cost 2–4% on scenes of a few shapes (cornell-box,
/// veach-mis, instances), whose trees have 3–8 nodes.
const AVX_FROM_NODES: usize = 64;

/// Bytes of capacity from which a built tree keeps its unused capacity
/// rather than being copied to fit (see [`Bvh::collapsed`]): twice the
/// largest size below which glibc's malloc may serve a block from its heap
/// (32 MiB), so such a block is always a fresh mapping of its own.
const KEEP_CAPACITY_FROM: usize = 64 << 20;

/// `items` in the order `order` gives (entry `i` is the index of the item
/// that goes to place `i`; a permutation), moved into a new vector. The
/// reads are independent of each other, so the memory system serves many
/// at once; following the permutation's cycles in place instead waits for
/// one cache miss after another (a quarter of a 4M-triangle build).
fn gather<T>(items: Vec<T>, order: &[u32]) -> Vec<T> {
    debug_assert_eq!(items.len(), order.len());
    // `Option<T>` is `T`'s size for a type with a niche (a primitive), and
    // then this reuses the items' own buffer.
    let mut slots: Vec<Option<T>> = items.into_iter().map(Some).collect();
    order.iter().map(|&i| slots[i as usize].take().expect("the order is a permutation")).collect()
}

/// pbrt-v3's binary SAH tree over `info`, whose entries it puts in the
/// tree's primitive order.
fn build_binary(info: &mut [PrimInfo], max_prims_in_node: usize) -> Vec<LinearNode> {
    // A binary tree with leaves of one primitive or more has at most
    // 2n - 1 nodes; the capacity not used is never touched, so it costs
    // address space, not memory.
    let mut nodes = Vec::with_capacity((2 * info.len()).saturating_sub(1));
    if !info.is_empty() {
        let limits = Limits { max_prims: max_prims_in_node.clamp(1, 255) };
        let ext = Extent::of(info);
        build_node(info, 0, 0, &limits, ext, None, &mut nodes);
    }
    nodes
}

/// Tests a leaf's primitives `prims` for the closest hit, shortening
/// `ray` to each hit; returns whether any was hit.
#[inline(always)]
pub fn closest_in_leaf<F: FnMut(usize, &Ray) -> Option<f32>>(
    prims: std::ops::Range<usize>,
    ray: &mut Ray,
    mut f: F,
) -> bool {
    let mut hit = false;
    for i in prims {
        if let Some(t) = f(i, ray) {
            hit = true;
            if t < ray.t_max {
                ray.t_max = t;
            }
        }
    }
    hit
}

#[cfg(test)]
thread_local! {
    /// The most entries a stack of this thread has held (tests only).
    static STACK_PEAK: std::cell::Cell<usize> = const { std::cell::Cell::new(0) };
}

/// Whether any of a leaf's primitives `prims` blocks `ray`. A plain loop:
/// `any` went through an iterator adaptor that was not inlined, a call
/// for every leaf.
#[inline(always)]
pub fn any_in_leaf<F: FnMut(usize, &Ray) -> bool>(
    prims: std::ops::Range<usize>,
    ray: &Ray,
    mut f: F,
) -> bool {
    for i in prims {
        if f(i, ray) {
            return true;
        }
    }
    false
}

/// A fixed-size traversal stack that is not initialised on each ray.
struct Stack<T: Copy, const N: usize> {
    items: [MaybeUninit<T>; N],
    len: usize,
}

impl<T: Copy, const N: usize> Stack<T, N> {
    #[inline(always)]
    fn new() -> Self {
        Stack { items: [const { MaybeUninit::uninit() }; N], len: 0 }
    }

    #[inline(always)]
    fn push(&mut self, v: T) {
        // Indexed, so a stack too small for its tree panics.
        self.items[self.len] = MaybeUninit::new(v);
        self.len += 1;
        #[cfg(test)]
        STACK_PEAK.with(|p| p.set(p.get().max(self.len)));
    }

    #[inline(always)]
    fn pop(&mut self) -> Option<T> {
        if self.len == 0 {
            return None;
        }
        self.len -= 1;
        // SAFETY: every slot below `len` was written by `push`.
        Some(unsafe { self.items[self.len].assume_init() })
    }
}

/// Asks for node `i`'s cache lines ahead of its visit (a hint only).
#[inline(always)]
fn prefetch_node(nodes: &[Node], i: u32) {
    farm_common::prefetch(nodes.get(i as usize..=i as usize).unwrap_or_default());
}

/// The hierarchy. It stores only nodes; the caller keeps the primitives in
/// the order [`Bvh::build`] returns and tests them in the closures given to
/// [`Bvh::intersect`] and [`Bvh::intersect_any`] (a primitive at a time)
/// or [`Bvh::intersect_leaves`] and [`Bvh::intersect_any_leaves`] (a leaf
/// at a time).
#[derive(Clone, Debug, Default)]
pub struct Bvh {
    nodes: Vec<Node>,
    bounds: Bounds3f,
    /// The tree may need more than [`SHALLOW_STACK_SIZE`] stack entries.
    deep: bool,
    /// Walk in AVX ([`Bvh::intersect_leaves`] says when): decided at the build,
    /// from [`simd`], so that a ray pays one test for it.
    #[cfg_attr(not(target_arch = "x86_64"), allow(dead_code))]
    avx: bool,
}

impl Bvh {
    /// Builds a BVH over `items` and returns them in the BVH's order, so the
    /// index the intersection closures receive indexes the returned vector.
    /// Items for which `cheap` holds (triangles) may share a leaf of up to
    /// `max_prims_in_node`; the others keep a box each where pbrt-v3's SAH
    /// gives them one. Once the tree is built, its order is kept (4 bytes
    /// an item), the build's [`PrimInfo`]s freed and the binary tree
    /// collapsed into the 8-wide one and freed, and only then are the items
    /// gathered into their new order: the second copy of the items is
    /// never held beside the build records, so the build's peak stays the
    /// SAH's (items, records and binary nodes).
    pub fn build_over<T>(
        items: Vec<T>,
        bounds: impl Fn(&T) -> Bounds3f,
        cheap: impl Fn(&T) -> bool,
        max_prims_in_node: usize,
    ) -> (Bvh, Vec<T>) {
        assert!(items.len() < COSTLY as usize, "more than 2^31 primitives in one BVH");
        let mut info: Vec<PrimInfo> = items
            .iter()
            .enumerate()
            .map(|(i, t)| {
                let costly = if cheap(t) { 0 } else { COSTLY };
                PrimInfo { bounds: bounds(t), index: i as u32 | costly }
            })
            .collect();
        let nodes = build_binary(&mut info, max_prims_in_node);
        let order: Vec<u32> = info.iter().map(|p| p.index & !COSTLY).collect();
        drop(info);
        let bvh = Bvh::collapsed(nodes);
        (bvh, gather(items, &order))
    }

    /// Builds the hierarchy over `prim_bounds` with at most
    /// `max_prims_in_node` (capped at 255, as in pbrt-v3) primitives per leaf
    /// where the SAH allows, and subtrees of at most that many primitives as
    /// one leaf. Returns the hierarchy and the primitive order: entry `i` is
    /// the index into `prim_bounds` of the `i`-th primitive, which is what
    /// the intersection closures receive. The result depends only on the
    /// input, not on thread scheduling.
    pub fn build(prim_bounds: &[Bounds3f], max_prims_in_node: usize) -> (Bvh, Vec<u32>) {
        let mut info: Vec<PrimInfo> = prim_bounds
            .iter()
            .enumerate()
            .map(|(i, b)| PrimInfo { bounds: *b, index: i as u32 })
            .collect();
        assert!(prim_bounds.len() < COSTLY as usize, "more than 2^31 primitives in one BVH");
        let nodes = build_binary(&mut info, max_prims_in_node);
        let order = info.iter().map(|p| p.index).collect();
        drop(info);
        (Bvh::collapsed(nodes), order)
    }

    /// The 8-wide hierarchy of the binary tree `nodes`, which it frees
    /// before returning.
    fn collapsed(nodes: Vec<LinearNode>) -> Bvh {
        let bounds = nodes.first().map_or(Bounds3f::default(), LinearNode::bounds);
        let mut wide = collapse(&nodes);
        drop(nodes);
        // Nodes are over-aligned, so the allocator cannot shrink them in
        // place: shrinking copies the tree into fresh pages (60–90 ms of a
        // 4M-triangle mesh's 2 s start-up). A large tree's capacity is a
        // mapping of its own whose unused tail was never touched and holds
        // no memory (it is address space, and commit charge where the
        // kernel does not overcommit); a small one's may sit among reused
        // heap pages.
        if wide.capacity() * std::mem::size_of::<Node>() < KEEP_CAPACITY_FROM {
            wide.shrink_to_fit();
        }
        let deep = !wide.is_empty() && stack_need(&wide, 0) > SHALLOW_STACK_SIZE;
        let avx = simd() == Simd::Avx && wide.len() >= AVX_FROM_NODES;
        Bvh { nodes: wide, bounds, deep, avx }
    }

    /// Bounds of everything (empty for an empty hierarchy).
    pub fn bounds(&self) -> Bounds3f {
        self.bounds
    }

    /// Number of (8-wide) nodes.
    pub fn node_count(&self) -> usize {
        self.nodes.len()
    }

    /// Closest hit: visits nodes front to back and calls `f(i, ray)` for
    /// each primitive `i` (in build order) whose leaf the ray reaches; `f`
    /// returns `Some(t)` when the primitive is hit at `t < ray.t_max`, after
    /// which the ray passed on is shortened to `t`. Returns whether
    /// anything was hit; the caller's closure keeps the hit itself.
    #[inline]
    pub fn intersect<F: FnMut(usize, &Ray) -> Option<f32>>(&self, ray: &Ray, mut f: F) -> bool {
        self.intersect_leaves(
            ray,
            #[inline(always)]
            |prims, r| closest_in_leaf(prims, r, &mut f),
        )
    }

    /// [`Bvh::intersect`] a leaf at a time: `leaf(prims, ray)` tests the
    /// primitives `prims` (in build order) as [`Bvh::intersect`] tests them
    /// one by one, shortening `ray` to each hit, and returns whether any
    /// was hit. For tests that take a leaf's primitives together.
    #[inline]
    pub fn intersect_leaves<L: FnMut(std::ops::Range<usize>, &mut Ray) -> bool>(
        &self,
        ray: &Ray,
        f: L,
    ) -> bool {
        if self.nodes.is_empty() {
            return false;
        }
        // A tree of one node without a stack; a deep tree, which few are,
        // in SSE with a stack that any tree fits; a tree of at least
        // `AVX_FROM_NODES` in AVX where the CPU has it; the rest inline.
        // Every path gives the same bits.
        if self.nodes.len() == 1 {
            return self.closest_one_node(ray, f);
        }
        if self.deep {
            return self.closest_deep(ray, f);
        }
        #[cfg(target_arch = "x86_64")]
        if self.avx {
            // SAFETY: `avx` is set only where `simd` found AVX.
            return unsafe { self.closest_avx(ray, f) };
        }
        self.closest::<_, SHALLOW_STACK_SIZE, _>(Inline::default(), ray, f)
    }

    /// [`Bvh::closest`] on a tree of one node, whose children are all
    /// leaves (a scene of a few shapes): the leaves hit, nearest first, with
    /// no stack. The order is [`Bvh::closest`]'s, ties included (the higher
    /// lane first), so the hits are the same.
    #[inline(always)]
    fn closest_one_node<L: FnMut(std::ops::Range<usize>, &mut Ray) -> bool>(
        &self,
        ray: &Ray,
        mut leaf: L,
    ) -> bool {
        let node = &self.nodes[0];
        let mut shortened = *ray;
        let mut hit = false;
        let (mut mask, t) = Inline::default().hit(node, &SlabRay::new(ray), ray.t_max);
        while mask != 0 {
            let (mut l, mut rest) = (mask.trailing_zeros() as usize, mask & (mask - 1));
            while rest != 0 {
                let m = rest.trailing_zeros() as usize;
                rest &= rest - 1;
                if t[m] <= t[l] {
                    l = m;
                }
            }
            mask &= !(1 << l);
            // Every leaf left is at least this far.
            if t[l] >= shortened.t_max {
                break;
            }
            hit |= leaf(node.prims(l), &mut shortened);
        }
        hit
    }

    /// [`Bvh::closest`] for a deep tree, not inlined: its stack would
    /// take the caller's frame past the size that makes it probe pages.
    #[inline(never)]
    fn closest_deep<L: FnMut(std::ops::Range<usize>, &mut Ray) -> bool>(
        &self,
        ray: &Ray,
        f: L,
    ) -> bool {
        self.closest::<_, WIDE_STACK_SIZE, _>(Inline::default(), ray, f)
    }

    /// [`Bvh::closest`] compiled for AVX, for a tree that is not deep.
    #[cfg(target_arch = "x86_64")]
    #[target_feature(enable = "avx")]
    unsafe fn closest_avx<L: FnMut(std::ops::Range<usize>, &mut Ray) -> bool>(
        &self,
        ray: &Ray,
        f: L,
    ) -> bool {
        // SAFETY: the caller's contract: the CPU has AVX.
        self.closest::<_, SHALLOW_STACK_SIZE, _>(unsafe { Avx::new_unchecked() }, ray, f)
    }

    /// [`Bvh::intersect`]'s walk with the box test `T` and a stack of `N`
    /// entries, which the tree must not need more of.
    #[inline(always)]
    fn closest<T: BoxTest, const N: usize, L: FnMut(std::ops::Range<usize>, &mut Ray) -> bool>(
        &self,
        test: T,
        ray: &Ray,
        mut leaf: L,
    ) -> bool {
        let r = SlabRay::new(ray);
        let mut shortened = *ray;
        let mut hit = false;
        // Entries: child and leaf primitive count (0 for a node) in one
        // word, and the entry distance: written and read in the same
        // widths, so a pop soon after a push is served by the store.
        let mut stack: Stack<(u64, f32), N> = Stack::new();
        // The nearest child hit is visited next without going through the stack.
        let mut next = Some((0u64, f32::NEG_INFINITY));
        while let Some((entry, t_near)) = next.take().or_else(|| stack.pop()) {
            // A hit found since this entry was pushed may have passed it.
            if t_near >= shortened.t_max {
                continue;
            }
            let (child, count) = (entry as u32, (entry >> 32) as u32);
            if count > 0 {
                hit |= leaf(child as usize..(child + count) as usize, &mut shortened);
                continue;
            }
            let node = &self.nodes[child as usize];
            let (mut mask, t) = test.hit(node, &r, shortened.t_max);
            // The children hit, farthest first, so that the nearest is
            // popped next: an insertion sort whose entries and distances
            // are kept apart, so each is moved in the width it was written.
            let mut entries = [0u64; WIDTH];
            let mut dists = [0f32; WIDTH];
            let mut k = 0;
            while mask != 0 {
                let l = mask.trailing_zeros() as usize;
                mask &= mask - 1;
                if node.count[l] == 0 {
                    prefetch_node(&self.nodes, node.child[l]);
                }
                let (e, d) = (u64::from(node.child[l]) | u64::from(node.count[l]) << 32, t[l]);
                let mut j = k;
                while j > 0 && dists[j - 1] < d {
                    entries[j] = entries[j - 1];
                    dists[j] = dists[j - 1];
                    j -= 1;
                }
                entries[j] = e;
                dists[j] = d;
                k += 1;
            }
            if k > 0 {
                for i in 0..k - 1 {
                    stack.push((entries[i], dists[i]));
                }
                next = Some((entries[k - 1], dists[k - 1]));
            }
        }
        hit
    }
}

#[path = "any.rs"]
mod any;

#[cfg(test)]
#[path = "bvh_tests.rs"]
mod tests;

#[cfg(test)]
#[path = "walk_tests.rs"]
mod walk_tests;
