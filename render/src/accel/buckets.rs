//! The SAH's buckets (pbrt-v3 `BVHAccel::recursiveBuild`): which bucket
//! a primitive's centroid falls in, the buckets' counts and extents, and
//! the boundary between them that costs least.

use super::sah::{Extent, PrimInfo};

/// Number of SAH buckets (pbrt-v3 uses 12).
pub(super) const N_BUCKETS: usize = 12;

/// Which SAH bucket a primitive's centroid falls in along one axis.
#[derive(Clone, Copy, Debug)]
pub(super) struct Axis {
    pub(super) dim: usize,
    lo: f32,
    scale: f32,
}

impl Axis {
    /// Twelve equal buckets over the centroids' extent along `dim`.
    pub(super) fn of(ext: &Extent, dim: usize) -> Axis {
        let lo = ext.cmin[dim];
        Axis { dim, lo, scale: N_BUCKETS as f32 / (ext.cmax[dim] - lo) }
    }

    /// An axis whose buckets nobody reads: it puts every primitive in
    /// some bucket, without a branch.
    pub(super) const UNUSED: Axis = Axis { dim: 0, lo: 0.0, scale: 0.0 };

    #[inline(always)]
    pub(super) fn bucket(&self, p: &PrimInfo) -> usize {
        ((p.centroid(self.dim) - self.lo) * self.scale).min((N_BUCKETS - 1) as f32) as usize
    }
}

/// The primitive count and extent of each bucket along an axis.
#[derive(Clone, Copy, Debug)]
pub(super) struct Bins {
    counts: [u32; N_BUCKETS],
    ext: [Extent; N_BUCKETS],
}

impl Bins {
    pub(super) const EMPTY: Bins = Bins { counts: [0; N_BUCKETS], ext: [Extent::EMPTY; N_BUCKETS] };

    #[inline(always)]
    pub(super) fn add(&mut self, b: usize, p: &PrimInfo) {
        self.counts[b] += 1;
        self.ext[b] = self.ext[b].add(p);
    }

    /// Adds the primitives of `info` to their buckets along `axis`.
    pub(super) fn scan(&mut self, info: &[PrimInfo], axis: &Axis) {
        for p in info {
            self.add(axis.bucket(p), p);
        }
    }
}

/// The cheapest bucket boundary by the SAH (pbrt-v3's cost
/// `1 + (n₀A₀ + n₁A₁)/A`): its cost and, if any, the last bucket left of
/// it with the count and extent left of it and the extent right of it.
#[derive(Clone, Copy, Debug)]
pub(super) struct Choice {
    pub(super) cost: f32,
    pub(super) split: Option<(usize, usize, Extent, Extent)>,
}

impl Choice {
    const NONE: Choice = Choice { cost: f32::INFINITY, split: None };

    /// Considers the boundary after bucket `b`, with `n0` primitives of
    /// extent `l` left of it and `n1` of extent `r` right of it. A strictly
    /// lower cost replaces the choice, so the first of equal costs stays.
    #[inline(always)]
    fn consider(&mut self, b: usize, n0: u32, l: &Extent, n1: u32, r: &Extent, total_area: f32) {
        let below = n0 as f32 * l.area();
        let above = n1 as f32 * r.area();
        let cost = 1.0 + (below + above) / total_area;
        if cost < self.cost {
            *self = Choice { cost, split: Some((b, n0 as usize, *l, *r)) };
        }
    }
}

/// pbrt-v3's choice among the boundaries of all twelve buckets `bins`.
#[inline(always)]
pub(super) fn choose(bins: &Bins, total_area: f32) -> Choice {
    sweep(&bins.counts, &bins.ext, N_BUCKETS, |i| i, total_area)
}

/// The cheapest boundary between consecutive buckets of the first `m` of
/// `counts` and `ext`, in order: the `j`-th is the one after bucket
/// `which(j)`. The costs of every boundary come from one sweep from the
/// right and one from the left.
#[inline(always)]
fn sweep<const M: usize>(
    counts: &[u32; M],
    ext: &[Extent; M],
    m: usize,
    which: impl Fn(usize) -> usize,
    total_area: f32,
) -> Choice {
    let mut right = [Extent::EMPTY; M];
    let mut right_count = [0u32; M];
    let (mut acc, mut acc_n) = (Extent::EMPTY, 0);
    for j in (1..m).rev() {
        acc = acc.union(&ext[j]);
        acc_n += counts[j];
        right[j] = acc;
        right_count[j] = acc_n;
    }
    let (mut acc, mut acc_n) = (Extent::EMPTY, 0);
    let mut choice = Choice::NONE;
    for j in 0..m - 1 {
        acc = acc.union(&ext[j]);
        acc_n += counts[j];
        choice.consider(which(j), acc_n, &acc, right_count[j + 1], &right[j + 1], total_area);
    }
    choice
}

/// The most primitives [`choose_few`] takes.
pub(super) const FEW: usize = 8;

/// [`choose`] for at most [`FEW`] primitives, found over the buckets they
/// fill rather than all twelve (most of a build's nodes are this small,
/// and the twelve cost them more than their primitives do). The same
/// choice, bit for bit: every boundary between two filled buckets costs
/// what the first does, which is the one pbrt-v3 keeps, and an empty
/// bucket's extent leaves a union as it was. That holds without NaN; a
/// NaN or infinite bound gives `None`, for [`choose`] to decide, and so
/// does a first or last bucket left empty, where the sweep over all
/// twelve would also weigh a boundary with nothing on one side (finite
/// bounds do that only when the centroids' spread overflows or is
/// subnormal).
#[inline(always)]
pub(super) fn choose_few(info: &[PrimInfo], axis: &Axis, total_area: f32) -> Option<Choice> {
    let n = info.len();
    debug_assert!(n <= FEW);
    let mut bucket = [0u8; FEW];
    let mut filled = 0u32;
    for (k, p) in info.iter().enumerate() {
        if !(p.bounds.min.is_finite() && p.bounds.max.is_finite()) {
            return None;
        }
        let b = axis.bucket(p);
        bucket[k] = b as u8;
        filled |= 1 << b;
    }
    if filled & 1 == 0 || filled & (1 << (N_BUCKETS - 1)) == 0 {
        return None;
    }
    // The filled buckets in order, each with its count and its extent
    // added up in the primitives' order, as a scan adds them.
    let mut which = [0usize; FEW];
    let mut counts = [0u32; FEW];
    let mut be = [Extent::EMPTY; FEW];
    let mut m = 0;
    while filled != 0 {
        let b = filled.trailing_zeros() as usize;
        filled &= filled - 1;
        which[m] = b;
        for (k, p) in info.iter().enumerate() {
            if bucket[k] as usize == b {
                counts[m] += 1;
                be[m] = be[m].add(p);
            }
        }
        m += 1;
    }
    Some(sweep(&counts, &be, m, |j| which[j], total_area))
}
