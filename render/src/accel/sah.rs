//! The binned surface-area-heuristic build of the BVH (pbrt-v3
//! `BVHAccel::recursiveBuild` with `SplitMethod::SAH`), writing the
//! flattened depth-first node array directly.

use super::buckets::{choose, choose_few, Axis, Bins, Choice, FEW};
use super::bvh::{LinearNode, STACK_SIZE};
use farm_common::geometry::Bounds3f;
use glam::Vec3A;

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
    pub(super) fn centroid(&self, axis: usize) -> f32 {
        0.5 * (self.bounds.min[axis] + self.bounds.max[axis])
    }
}

/// Bounds of a set of primitives and of their centroids, in SIMD vectors.
#[derive(Clone, Copy, Debug)]
pub(super) struct Extent {
    min: Vec3A,
    max: Vec3A,
    pub(super) cmin: Vec3A,
    pub(super) cmax: Vec3A,
}

impl Extent {
    pub(super) const EMPTY: Extent = Extent {
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
    pub(super) fn add(&self, p: &PrimInfo) -> Extent {
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
    pub(super) fn union(&self, o: &Extent) -> Extent {
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
    pub(super) fn area(&self) -> f32 {
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

/// How a node over some primitives is split, decided from their count,
/// extent and depth alone (so a parent can tell before its children are
/// built).
#[derive(Clone, Copy, Debug)]
enum Plan {
    Leaf,
    /// At the median centroid along this axis.
    Median(usize),
    /// At the cheapest bucket boundary along this axis.
    Sah(Axis),
}

impl Plan {
    fn of(n: usize, ext: &Extent, depth: u32, max_prims: usize) -> Plan {
        if n == 1 {
            return Plan::Leaf;
        }
        let cb = ext.centroids();
        let dim = cb.maximum_extent();
        // No spread of centroids (or NaN): SAH buckets cannot separate them.
        let degenerate = cb.max[dim].partial_cmp(&cb.min[dim]) != Some(std::cmp::Ordering::Greater);
        if degenerate && n <= max_prims {
            return Plan::Leaf;
        }
        // Levels left for halving by count must keep every leaf within the stack.
        let halvings = usize::BITS - (n - 1).leading_zeros();
        if degenerate || n <= 2 || depth + halvings >= STACK_SIZE as u32 - 2 {
            Plan::Median(dim)
        } else {
            Plan::Sah(Axis::of(ext, dim))
        }
    }

    /// The axis to bucket along, if buckets are wanted.
    fn axis(&self) -> Option<Axis> {
        match self {
            Plan::Sah(axis) => Some(*axis),
            _ => None,
        }
    }
}

/// Appends the subtree over `info` (primitives `base..base + info.len()`
/// of the final order, with extent `ext`) to `nodes`, depth first, and
/// reorders `info`. `bins`, when given, are `info`'s buckets along the
/// axis its plan splits, binned by the parent's partition.
pub(super) fn build_node(
    info: &mut [PrimInfo],
    base: u32,
    depth: u32,
    limits: &Limits,
    ext: Extent,
    bins: Option<&Bins>,
    nodes: &mut Vec<LinearNode>,
) {
    let max_prims = limits.max_prims;
    let n = info.len();
    let bounds = ext.bounds();
    let leaf = |nodes: &mut Vec<LinearNode>| nodes.push(LinearNode::new(&bounds, base, n as u16));
    let (mid, left_ext, right_ext, binned) = match Plan::of(n, &ext, depth, max_prims) {
        Plan::Leaf => return leaf(nodes),
        Plan::Median(dim) => {
            let mid = equal_counts(info, dim);
            (mid, Extent::of(&info[..mid]), Extent::of(&info[mid..]), None)
        }
        Plan::Sah(axis) => {
            let total_area = ext.area();
            let few = n <= FEW && !plain();
            let choice = match bins {
                Some(bins) if !plain() => {
                    #[cfg(test)]
                    {
                        let mut scanned = Bins::EMPTY;
                        scanned.scan(info, &axis);
                        // As printed: -0 and +0 differ, NaNs do not.
                        assert_eq!(format!("{bins:?}"), format!("{scanned:?}"), "binned ≠ scanned");
                    }
                    choose(bins, total_area)
                }
                _ => match few.then(|| choose_few(info, &axis, total_area)).flatten() {
                    Some(choice) => choice,
                    None => {
                        let mut scanned = Bins::EMPTY;
                        scanned.scan(info, &axis);
                        choose(&scanned, total_area)
                    }
                },
            };
            match sah_split(info, &axis, choice, depth, max_prims) {
                Some(split) => split,
                None => return leaf(nodes),
            }
        }
    };
    let side = |i: usize| binned.as_ref().filter(|b| b.wanted[i]).map(|b| &b.bins[i]);
    let (left_bins, right_bins) = (side(0), side(1));
    // Interior node: first child follows, second child's index patched in.
    let me = nodes.len();
    nodes.push(LinearNode::new(&bounds, 0, 0));
    let (left, right) = info.split_at_mut(mid);
    let right_base = base + mid as u32;
    let d = depth + 1;
    if n > PARALLEL_THRESHOLD && rayon::current_num_threads() > 1 {
        // The first child goes straight into `nodes`, the second into a
        // vector of its own that is then moved over: only the second
        // child's nodes are ever held twice.
        let mut rn = Vec::new();
        rayon::join(
            || build_node(left, base, d, limits, left_ext, left_bins, nodes),
            || build_node(right, right_base, d, limits, right_ext, right_bins, &mut rn),
        );
        nodes[me].offset = nodes.len() as u32;
        append_shifted(nodes, &rn);
    } else {
        build_node(left, base, d, limits, left_ext, left_bins, nodes);
        nodes[me].offset = nodes.len() as u32;
        build_node(right, right_base, d, limits, right_ext, right_bins, nodes);
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

/// The buckets a partition binned for the two sides it split, of which
/// the sides whose plans split by the SAH want theirs.
pub(super) struct Binned {
    bins: [Bins; 2],
    wanted: [bool; 2],
}

/// The fewest primitives of a node whose partition bins its sides'
/// buckets. Timed by level on a 4M-triangle mesh, binning saved 15–25%
/// from 2¹⁸ primitives (out of L2) and cost about 10% at 2¹⁵–2¹⁶; as the
/// threshold, 2¹² to 2¹⁷ gave the same start-up within noise, and 2¹⁴
/// lets the build tests (100k primitives) exercise it.
const BINNED_FROM: usize = 1 << 14;

#[cfg(test)]
thread_local! {
    /// Test-only: every node scans all twelve of its buckets, rather than
    /// taking those its parent's partition binned or looking at only
    /// those its few primitives fill, so that a test can compare builds.
    pub(super) static PLAIN: std::cell::Cell<bool> = const { std::cell::Cell::new(false) };
}

#[inline(always)]
fn plain() -> bool {
    #[cfg(test)]
    return PLAIN.with(|s| s.get());
    #[cfg(not(test))]
    false
}

/// Splits `info` at `choice`, partitioning it around the boundary. Returns
/// the split point, the extents of both sides and, for a large node, the
/// buckets its sides will want, binned on the way; or `None` when a leaf is
/// cheaper and allowed (pbrt-v3 compares the cost with a leaf's `n`).
fn sah_split(
    info: &mut [PrimInfo],
    axis: &Axis,
    choice: Choice,
    depth: u32,
    max_prims: usize,
) -> Option<(usize, Extent, Extent, Option<Box<Binned>>)> {
    let (min_cost, split) = (choice.cost, choice.split);
    let n = info.len();
    if n <= max_prims && min_cost >= n as f32 {
        return None;
    }
    let mid = match split {
        Some((b, count, l, r)) if count > 0 && count < n => {
            // Each side's buckets along the axis its own plan will split
            // are binned as the partition passes its primitives, which
            // spares the children a pass over them.
            let d = depth + 1;
            let axes = if n >= BINNED_FROM {
                [Plan::of(count, &l, d, max_prims), Plan::of(n - count, &r, d, max_prims)]
                    .map(|plan| plan.axis())
            } else {
                [None, None]
            };
            let keep = |p: &PrimInfo| axis.bucket(p) <= b;
            let (mid, bins) = if axes.iter().any(Option::is_some) {
                let mut binned =
                    Box::new(Binned { bins: [Bins::EMPTY; 2], wanted: axes.map(|a| a.is_some()) });
                let axes = axes.map(|a| a.unwrap_or(Axis::UNUSED));
                let (mid, unordered) = partition_binned(info, keep, &axes, &mut binned.bins);
                binned.wanted[1] &= !unordered;
                (mid, Some(binned))
            } else {
                (partition(info, keep), None)
            };
            debug_assert_eq!(mid, count);
            return Some((mid, l, r, bins));
        }
        // Only reachable with NaN bounds: split at the median.
        _ => equal_counts(info, axis.dim),
    };
    Some((mid, Extent::of(&info[..mid]), Extent::of(&info[mid..]), None))
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

/// [`partition`], which also bins each element into `bins[0]` along
/// `axes[0]` if it satisfies `pred`, else into `bins[1]` along `axes[1]`.
/// The order it leaves is [`partition`]'s, and each element is binned
/// once: it is read at `v[i]` before any swap moves it behind `i`.
///
/// The elements that satisfy `pred` keep their order, so their buckets
/// are those a scan of them finds, bit for bit. The others are shuffled,
/// and their buckets, added up in the order they were read, are a scan's
/// only when no element's bounds make the order matter
/// ([`order_matters`]); whether one did is returned with the count.
fn partition_binned(
    v: &mut [PrimInfo],
    pred: impl Fn(&PrimInfo) -> bool,
    axes: &[Axis; 2],
    bins: &mut [Bins; 2],
) -> (usize, bool) {
    let mut j = 0;
    let mut unordered = false;
    for i in 0..v.len() {
        ahead(v, i);
        ahead(v, j);
        let p = v[i];
        let keep = pred(&p);
        let side = (!keep) as usize;
        bins[side].add(axes[side].bucket(&p), &p);
        unordered |= !keep && order_matters(&p);
        swap_fields(v, i, j);
        j += keep as usize;
    }
    (j, unordered)
}

/// Whether a minimum or maximum folded over bounds that include `p`'s
/// may depend on the order they are added in: the SSE instructions return
/// their second operand on a tie, so a -0 against a +0 keeps either, and
/// on NaN (which an infinite pair of bounds makes of a centroid).
#[inline(always)]
fn order_matters(p: &PrimInfo) -> bool {
    let (lo, hi) = (Vec3A::from(p.bounds.min), Vec3A::from(p.bounds.max));
    let negative_zero = |v: Vec3A| v.cmpeq(Vec3A::ZERO).bitmask() & v.is_negative_bitmask() != 0;
    !(lo.is_finite() && hi.is_finite()) || negative_zero(lo) || negative_zero(hi)
}

/// Asks for the element 32 places after `i` (about 900 bytes ahead) to be
/// fetched. A large node's partition reads two streams, at `i` and at the
/// trailing `j`, from main memory; fetching both ahead took 50–80 ms off a
/// 4M-triangle mesh's build on one core.
#[inline(always)]
fn ahead(v: &[PrimInfo], i: usize) {
    if let Some(p) = v.get(i + 32) {
        farm_common::prefetch(std::slice::from_ref(p));
    }
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

#[cfg(test)]
mod tests {
    use super::*;
    use crate::accel::buckets::{Axis, Bins};

    /// The buckets `partition_binned` adds up are a scan's of where it
    /// put the elements, bit for bit (as printed: -0 is not +0, and a NaN
    /// kept or not differs), or it says that the moved side's may not be.
    #[test]
    fn shuffled_buckets_are_a_scans_or_flagged() {
        let inf = f32::INFINITY;
        let cases: [([f32; 3], [f32; 3], bool); 4] = [
            ([1.0, 2.0, 3.0], [1.5, 2.5, 3.5], false),
            ([1.0, f32::NAN, 3.0], [1.5, 2.5, 3.5], true),
            ([1.0, -0.0, 3.0], [1.5, 2.5, 3.5], true),
            ([-inf, 2.0, 3.0], [inf, 2.5, 3.5], true),
        ];
        for (min, max, flagged) in cases {
            let odd = PrimInfo { bounds: Bounds3f { min: min.into(), max: max.into() }, index: 1 };
            let plain = |index, y: f32| PrimInfo {
                bounds: Bounds3f { min: [1.0, y, 3.0].into(), max: [1.2, 2.5, 3.5].into() },
                index,
            };
            // Kept: the even indices. The odd ones are moved about.
            let mut v = [plain(0, 0.0), odd, plain(3, 0.0), plain(2, 1.0), plain(5, 0.0)];
            let mut bins = [Bins::EMPTY; 2];
            let axes = [Axis::UNUSED; 2];
            let (mid, unordered) = partition_binned(&mut v, |p| p.index % 2 == 0, &axes, &mut bins);
            assert_eq!(mid, 2);
            assert_eq!(unordered, flagged, "{min:?}");
            let mut scanned = [Bins::EMPTY; 2];
            scanned[0].scan(&v[..mid], &axes[0]);
            scanned[1].scan(&v[mid..], &axes[1]);
            assert_eq!(format!("{:?}", bins[0]), format!("{:?}", scanned[0]));
            let same = format!("{:?}", bins[1]) == format!("{:?}", scanned[1]);
            assert!(same || unordered, "{min:?}: moved side's buckets differ unflagged");
        }
    }
}
