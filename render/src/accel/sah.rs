//! The binned surface-area-heuristic build of the BVH (pbrt-v3
//! `BVHAccel::recursiveBuild` with `SplitMethod::SAH`), writing the
//! flattened depth-first node array directly.

use super::bvh::{LinearNode, STACK_SIZE};
use farm_common::geometry::Bounds3f;
use glam::Vec3A;

/// Number of SAH buckets (pbrt-v3 uses 12).
const N_BUCKETS: usize = 12;

/// Subtrees with more primitives than this are built in parallel.
const PARALLEL_THRESHOLD: usize = 64 * 1024;

/// A primitive during the build: its bounds and original index (28 bytes;
/// the centroid is recomputed, which is cheaper than moving it around).
#[derive(Clone, Copy, Debug)]
pub(super) struct PrimInfo {
    pub(super) bounds: Bounds3f,
    /// The original index, with [`COSTLY`] set for a primitive that keeps
    /// a box of its own.
    pub(super) index: u32,
}

/// The bit of [`PrimInfo::index`] that marks a primitive costly to test
/// (a sphere, a curve), which never shares a leaf: a flag inside the index
/// rather than a byte per primitive beside it, since the build's peak
/// memory is a large mesh's.
pub(super) const COSTLY: u32 = 1 << 31;

impl PrimInfo {
    /// The centroid's coordinate on `axis` (as `Bounds3f::centroid`).
    #[inline(always)]
    fn centroid(&self, axis: usize) -> f32 {
        0.5 * (self.bounds.min[axis] + self.bounds.max[axis])
    }
}

/// Bounds of a set of primitives and of their centroids, in SIMD vectors.
#[derive(Clone, Copy, Debug)]
pub(super) struct Extent {
    min: Vec3A,
    max: Vec3A,
    cmin: Vec3A,
    cmax: Vec3A,
}

impl Extent {
    const EMPTY: Extent = Extent {
        min: Vec3A::INFINITY,
        max: Vec3A::NEG_INFINITY,
        cmin: Vec3A::INFINITY,
        cmax: Vec3A::NEG_INFINITY,
    };

    /// The extent of `info`, by a scan.
    pub(super) fn of(info: &[PrimInfo]) -> Extent {
        info.iter().fold(Extent::EMPTY, |e, p| e.add(p))
    }

    #[inline(always)]
    fn add(&self, p: &PrimInfo) -> Extent {
        let (lo, hi) = (Vec3A::from(p.bounds.min), Vec3A::from(p.bounds.max));
        let c = 0.5 * (lo + hi);
        Extent {
            min: self.min.min(lo),
            max: self.max.max(hi),
            cmin: self.cmin.min(c),
            cmax: self.cmax.max(c),
        }
    }

    #[inline(always)]
    fn union(&self, o: &Extent) -> Extent {
        Extent {
            min: self.min.min(o.min),
            max: self.max.max(o.max),
            cmin: self.cmin.min(o.cmin),
            cmax: self.cmax.max(o.cmax),
        }
    }

    fn bounds(&self) -> Bounds3f {
        Bounds3f { min: self.min.into(), max: self.max.into() }
    }

    fn centroids(&self) -> Bounds3f {
        Bounds3f { min: self.cmin.into(), max: self.cmax.into() }
    }

    /// Surface area (zero when empty), as `Bounds3f::surface_area`.
    #[inline(always)]
    fn area(&self) -> f32 {
        let d = self.max - self.min;
        if d.cmplt(Vec3A::ZERO).any() {
            return 0.0;
        }
        2.0 * (d.x * d.y + d.x * d.z + d.y * d.z)
    }
}

/// What a build is asked for.
pub(super) struct Limits {
    /// pbrt-v3's `maxnodeprims`.
    pub(super) max_prims: usize,
}

impl Limits {
    /// Whether the primitives of `info` may share one leaf rather than each
    /// sit behind its own box: at most `max_prims` of them, all cheap.
    fn one_leaf(&self, info: &[PrimInfo]) -> bool {
        info.len() <= self.max_prims && info.iter().all(|p| p.index & COSTLY == 0)
    }
}

/// Appends the subtree over `info` (primitives `base..base + info.len()`
/// of the final order, with extent `ext`) to `nodes`, depth first, and
/// reorders `info`.
pub(super) fn build_node(
    info: &mut [PrimInfo],
    base: u32,
    depth: u32,
    limits: &Limits,
    ext: Extent,
    nodes: &mut Vec<LinearNode>,
) {
    let max_prims = limits.max_prims;
    let n = info.len();
    let bounds = ext.bounds();
    let leaf = |nodes: &mut Vec<LinearNode>| nodes.push(LinearNode::new(&bounds, base, n as u16));
    if n == 1 {
        return leaf(nodes);
    }
    let cb = ext.centroids();
    let dim = cb.maximum_extent();
    // No spread of centroids (or NaN): SAH buckets cannot separate them.
    let degenerate = cb.max[dim].partial_cmp(&cb.min[dim]) != Some(std::cmp::Ordering::Greater);
    if degenerate && n <= max_prims {
        return leaf(nodes);
    }
    // Levels left for halving by count must keep every leaf within the stack.
    let halvings = usize::BITS - (n - 1).leading_zeros();
    let (mid, left_ext, right_ext) =
        if degenerate || n <= 2 || depth + halvings >= STACK_SIZE as u32 - 2 {
            let mid = equal_counts(info, dim);
            (mid, Extent::of(&info[..mid]), Extent::of(&info[mid..]))
        } else {
            match sah_split(info, &ext, dim, max_prims) {
                Some(split) => split,
                None => return leaf(nodes),
            }
        };
    // Interior node: first child follows, second child's index patched in.
    let me = nodes.len();
    nodes.push(LinearNode::new(&bounds, 0, 0));
    let (left, right) = info.split_at_mut(mid);
    let right_base = base + mid as u32;
    if n > PARALLEL_THRESHOLD && rayon::current_num_threads() > 1 {
        // The first child goes straight into `nodes`, the second into a
        // vector of its own that is then moved over: only the second
        // child's nodes are ever held twice.
        let mut rn = Vec::new();
        rayon::join(
            || build_node(left, base, depth + 1, limits, left_ext, nodes),
            || build_node(right, right_base, depth + 1, limits, right_ext, &mut rn),
        );
        nodes[me].offset = nodes.len() as u32;
        append_shifted(nodes, &rn);
    } else {
        build_node(left, base, depth + 1, limits, left_ext, nodes);
        nodes[me].offset = nodes.len() as u32;
        build_node(right, right_base, depth + 1, limits, right_ext, nodes);
    }
    // A subtree of at most `max_prims` cheap primitives (the SAH mostly
    // splits down to one a leaf) becomes one leaf: its primitives are now
    // in the order pbrt-v3's splits put them, and the 8-wide tree tests
    // them together rather than boxing each. For a mesh, a quarter of the
    // nodes and half the build's memory. Costly shapes (spheres, curves)
    // keep their own boxes, which cull most of their tests.
    if limits.one_leaf(info) {
        nodes.truncate(me);
        leaf(nodes);
    }
}

/// Appends a subtree built on its own, moving its child links.
fn append_shifted(nodes: &mut Vec<LinearNode>, sub: &[LinearNode]) {
    let shift = nodes.len() as u32;
    nodes.extend(sub.iter().map(|n| {
        let mut n = *n;
        if n.n_prims == 0 {
            n.offset += shift;
        }
        n
    }));
}

/// Splits at the median centroid along `dim`; returns the split point.
fn equal_counts(info: &mut [PrimInfo], dim: usize) -> usize {
    let mid = info.len() / 2;
    info.select_nth_unstable_by(mid, |a, b| a.centroid(dim).total_cmp(&b.centroid(dim)));
    mid
}

/// Chooses the cheapest bucket boundary by the SAH (pbrt-v3's cost
/// `1 + (n₀A₀ + n₁A₁)/A` against a leaf's `n`) and partitions `info` around
/// it; returns the split point and the extents of both sides, or `None`
/// when a leaf is cheaper and allowed.
fn sah_split(
    info: &mut [PrimInfo],
    ext: &Extent,
    dim: usize,
    max_prims: usize,
) -> Option<(usize, Extent, Extent)> {
    let lo = ext.cmin[dim];
    let scale = N_BUCKETS as f32 / (ext.cmax[dim] - lo);
    let last = (N_BUCKETS - 1) as f32;
    let bucket = |p: &PrimInfo| ((p.centroid(dim) - lo) * scale).min(last) as usize;
    let mut counts = [0usize; N_BUCKETS];
    let mut be = [Extent::EMPTY; N_BUCKETS];
    for p in info.iter() {
        let b = bucket(p);
        counts[b] += 1;
        be[b] = be[b].add(p);
    }
    // Sweep from the right to get the cost of every boundary in O(buckets).
    let mut right = [Extent::EMPTY; N_BUCKETS];
    let mut right_count = [0usize; N_BUCKETS];
    let (mut acc, mut acc_n) = (Extent::EMPTY, 0);
    for i in (1..N_BUCKETS).rev() {
        acc = acc.union(&be[i]);
        acc_n += counts[i];
        right[i] = acc;
        right_count[i] = acc_n;
    }
    let total_area = ext.area();
    let (mut acc, mut acc_n) = (Extent::EMPTY, 0);
    let (mut min_cost, mut split) = (f32::INFINITY, None);
    for i in 0..N_BUCKETS - 1 {
        acc = acc.union(&be[i]);
        acc_n += counts[i];
        let below = acc_n as f32 * acc.area();
        let above = right_count[i + 1] as f32 * right[i + 1].area();
        let cost = 1.0 + (below + above) / total_area;
        if cost < min_cost {
            min_cost = cost;
            split = Some((i, acc_n, acc, right[i + 1]));
        }
    }
    let n = info.len();
    if n <= max_prims && min_cost >= n as f32 {
        return None;
    }
    let mid = match split {
        Some((b, count, l, r)) if count > 0 && count < n => {
            let mid = partition(info, |p| bucket(p) <= b);
            debug_assert_eq!(mid, count);
            return Some((mid, l, r));
        }
        // Only reachable with NaN bounds: split at the median.
        _ => equal_counts(info, dim),
    };
    Some((mid, Extent::of(&info[..mid]), Extent::of(&info[mid..])))
}

/// Moves the elements satisfying `pred` to the front; returns their count.
/// Branch-free (every element is swapped), since the predicate is a coin
/// toss to the branch predictor.
fn partition(v: &mut [PrimInfo], pred: impl Fn(&PrimInfo) -> bool) -> usize {
    let mut j = 0;
    for i in 0..v.len() {
        let keep = pred(&v[i]);
        swap_fields(v, i, j);
        j += keep as usize;
    }
    j
}

/// `v.swap(i, j)`, field by field. A 28-byte element is
/// otherwise copied as two overlapping 16-byte moves, and the next
/// iteration's load of an element just stored that way cannot be forwarded
/// from the store (it spans two of them) and waits for it to retire: a
/// third of the SAH build's time on a large mesh.
#[inline(always)]
fn swap_fields(v: &mut [PrimInfo], i: usize, j: usize) {
    let (a, b) = (v[i], v[j]);
    let p = &mut v[j];
    p.bounds.min = a.bounds.min;
    p.bounds.max = a.bounds.max;
    p.index = a.index;
    let p = &mut v[i];
    p.bounds.min = b.bounds.min;
    p.bounds.max = b.bounds.max;
    p.index = b.index;
}
