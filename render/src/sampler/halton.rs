//! The Halton sampler (pbrt-v3 `samplers/halton.cpp`):
//!
//! ```text
//! Sampler "halton" "integer pixelsamples" [16] "bool samplepixelcenter" [false]
//! ```
//!
//! The first two dimensions of the Halton sequence, scaled by `2^j` and
//! `3^k` to cover the sample bounds (up to 128×128 pixels), enumerate the
//! pixels; each pixel's samples are every `2^j·3^k`-th point. Higher
//! dimensions use digit-permuted radical inverses with pbrt-v3's
//! permutation tables (a default-seeded PCG32).

use super::lowdiscrepancy::{
    inverse_radical_inverse, radical_inverse, radical_inverse_permutations_range,
    scrambled_radical_inverse_fast, DigitPairs, PAIR_DIMS, PRIME_SUMS, PRIME_TABLE_SIZE,
};
use super::pixel::{GlobalSampler, GlobalSequence};
use farm_common::geometry::{Bounds2i, Point2i, Vec2};
use farm_common::rng::Rng;
use std::sync::OnceLock;

/// Largest pixel resolution enumerated by the first two dimensions.
const MAX_RESOLUTION: i32 = 128;

/// Dimensions whose permutations are made when the first Halton sampler
/// is: the first part of the table ([`PART_STARTS`]).
const EAGER_DIMS: usize = 64;

/// Where each part of pbrt-v3's permutation table starts, and where the
/// table ends: the first part is made with the first Halton sampler, each
/// of the others (and any before it not yet made) on the first use of one
/// of its bases. pbrt-v3 makes the table for all 1000 bases: 3.7 M
/// entries, 7.4 MB. Whitted draws 5 dimensions for the camera, then, at
/// every hit of its ray tree in turn, 2 for each light and, above the last
/// depth, 4 for the specular lobes. A scene of a few lights and no glass
/// stays within the first part (18 kB); glass branches the tree, so
/// `scenes/example.pbrt` (three lights, depth 5) can draw up to about 250
/// dimensions, within the first three parts (0.4 MB).
const PART_STARTS: [usize; 6] = [0, EAGER_DIMS, 128, 256, 512, PRIME_TABLE_SIZE];

/// One part of the table: the permutations of the bases
/// `PART_STARTS[k]..PART_STARTS[k + 1]`, and the generator as their last
/// shuffle left it, which the next part continues from.
struct Part {
    perms: Vec<u16>,
    rng: Rng,
}

/// Part `k` of pbrt-v3's permutations, made (with the parts before it) on
/// first use. The shuffles draw from one generator in base order, so a
/// part's values are those of the whole table.
fn part(k: usize) -> &'static Part {
    static PARTS: [OnceLock<Part>; PART_STARTS.len() - 1] =
        [const { OnceLock::new() }; PART_STARTS.len() - 1];
    PARTS[k].get_or_init(|| {
        let mut rng = if k == 0 { Rng::default() } else { part(k - 1).rng.clone() };
        let perms =
            radical_inverse_permutations_range(&mut rng, PART_STARTS[k], PART_STARTS[k + 1]);
        Part { perms, rng }
    })
}

/// The part holding dimension `dim` (below [`PRIME_TABLE_SIZE`]).
#[inline]
fn part_of(dim: usize) -> usize {
    debug_assert!(dim < PRIME_TABLE_SIZE);
    PART_STARTS[1..].partition_point(|&start| start <= dim)
}

/// pbrt-v3's permutations of the first [`EAGER_DIMS`] bases.
fn permutations() -> &'static [u16] {
    &part(0).perms
}

/// Two-digit tables of the low dimensions' permutations, once per process.
fn digit_pairs() -> &'static DigitPairs {
    static PAIRS: OnceLock<DigitPairs> = OnceLock::new();
    PAIRS.get_or_init(|| DigitPairs::new(permutations()))
}

/// The Halton sampler.
pub type HaltonSampler = GlobalSampler<Halton>;

/// The Halton sequence mapped onto the sample bounds.
#[derive(Clone, Debug)]
pub struct Halton {
    perms: &'static [u16],
    pairs: &'static DigitPairs,
    base_scales: [i64; 2],
    base_exponents: [u32; 2],
    sample_stride: i64,
    mult_inverse: [i64; 2],
    pixel_for_offset: Point2i,
    offset_for_current_pixel: i64,
    sample_at_pixel_center: bool,
}

fn extended_gcd(a: u64, b: u64) -> (i64, i64) {
    if b == 0 {
        return (1, 0);
    }
    let d = (a / b) as i64;
    let (xp, yp) = extended_gcd(b, a % b);
    (yp, xp - d * yp)
}

fn multiplicative_inverse(a: i64, n: i64) -> i64 {
    let (x, _) = extended_gcd(a as u64, n as u64);
    x.rem_euclid(n)
}

impl Halton {
    /// The sequence for images whose samples cover `sample_bounds`.
    pub fn new(sample_bounds: Bounds2i, sample_at_pixel_center: bool) -> Self {
        let res =
            [sample_bounds.max.x - sample_bounds.min.x, sample_bounds.max.y - sample_bounds.min.y];
        let mut base_scales = [1i64; 2];
        let mut base_exponents = [0u32; 2];
        for i in 0..2 {
            let base = if i == 0 { 2 } else { 3 };
            let (mut scale, mut exp) = (1i64, 0u32);
            while scale < res[i].min(MAX_RESOLUTION) as i64 {
                scale *= base;
                exp += 1;
            }
            base_scales[i] = scale;
            base_exponents[i] = exp;
        }
        Halton {
            perms: permutations(),
            pairs: digit_pairs(),
            base_scales,
            base_exponents,
            sample_stride: base_scales[0] * base_scales[1],
            mult_inverse: [
                multiplicative_inverse(base_scales[1], base_scales[0]),
                multiplicative_inverse(base_scales[0], base_scales[1]),
            ],
            pixel_for_offset: Point2i::new(i32::MAX, i32::MAX),
            offset_for_current_pixel: 0,
            sample_at_pixel_center,
        }
    }

    /// The permutation of base `PRIMES[dim]` (and the rest of its part of
    /// the table).
    fn permutation_for_dimension(&self, dim: usize) -> &[u16] {
        if dim < EAGER_DIMS {
            return &self.perms[PRIME_SUMS[dim] as usize..];
        }
        let k = part_of(dim);
        let start = PRIME_SUMS[PART_STARTS[k]];
        &part(k).perms[(PRIME_SUMS[dim] - start) as usize..]
    }
}

impl GlobalSequence for Halton {
    fn index_for_sample(&mut self, pixel: Point2i, sample_num: i64) -> i64 {
        if pixel != self.pixel_for_offset {
            self.offset_for_current_pixel = 0;
            if self.sample_stride > 1 {
                let pm = [pixel.x.rem_euclid(MAX_RESOLUTION), pixel.y.rem_euclid(MAX_RESOLUTION)];
                let mut offset = 0u64;
                for (i, (base, pmi)) in [(2, pm[0]), (3, pm[1])].into_iter().enumerate() {
                    let dim_offset =
                        inverse_radical_inverse(base, pmi as u64, self.base_exponents[i]);
                    offset = offset.wrapping_add(
                        dim_offset
                            .wrapping_mul((self.sample_stride / self.base_scales[i]) as u64)
                            .wrapping_mul(self.mult_inverse[i] as u64),
                    );
                }
                self.offset_for_current_pixel = offset as i64 % self.sample_stride;
            }
            self.pixel_for_offset = pixel;
        }
        self.offset_for_current_pixel + sample_num * self.sample_stride
    }

    /// Two dimensions with digit-pair tables in one call: the common case
    /// of a light's or a BSDF's sample, without a second call's set-up.
    #[inline]
    fn sample_2d(&self, pixel: Point2i, index: i64, dim: usize) -> Vec2 {
        if (2..PAIR_DIMS - 1).contains(&dim) {
            let a = index as u64;
            let (p0, p1) =
                (self.permutation_for_dimension(dim), self.permutation_for_dimension(dim + 1));
            return Vec2::new(
                self.pairs.scrambled_radical_inverse(dim, a, p0),
                self.pairs.scrambled_radical_inverse(dim + 1, a, p1),
            );
        }
        Vec2::new(
            self.sample_dimension(pixel, index, dim),
            self.sample_dimension(pixel, index, dim + 1),
        )
    }

    fn sample_dimension(&self, _pixel: Point2i, index: i64, dim: usize) -> f32 {
        if self.sample_at_pixel_center && dim < 2 {
            return 0.5;
        }
        match dim {
            0 => radical_inverse(0, (index >> self.base_exponents[0]) as u64),
            1 => radical_inverse(1, (index / self.base_scales[1]) as u64),
            _ if dim < PAIR_DIMS => self.pairs.scrambled_radical_inverse(
                dim,
                index as u64,
                self.permutation_for_dimension(dim),
            ),
            _ => {
                // pbrt-v3 aborts past its 1000 permuted bases; wrap instead
                // (reached only by ray trees of glass several levels deep
                // under dozens of lights).
                let dim =
                    if dim < PRIME_TABLE_SIZE { dim } else { 2 + dim % (PRIME_TABLE_SIZE - 2) };
                let perm = self.permutation_for_dimension(dim);
                scrambled_radical_inverse_fast(dim, index as u64, perm)
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::super::lowdiscrepancy::{
        compute_radical_inverse_permutations, scrambled_radical_inverse, PRIMES,
    };
    use super::*;

    fn bounds(w: i32, h: i32) -> Bounds2i {
        Bounds2i::new(Point2i::new(0, 0), Point2i::new(w, h))
    }

    /// A pair of dimensions in one call is the two dimensions, for pairs
    /// in the digit-pair tables, across their end, and past it.
    #[test]
    fn pairs_of_dimensions_are_the_dimensions() {
        let h = Halton::new(bounds(64, 64), false);
        let mut rng = Rng::new(5);
        for dim in 0..PAIR_DIMS + 4 {
            for _ in 0..200 {
                let index = i64::from(rng.uniform_u32() >> (rng.uniform_u32() % 32));
                let p = Point2i::new(3, 9);
                let pair = h.sample_2d(p, index, dim);
                let one =
                    (h.sample_dimension(p, index, dim), h.sample_dimension(p, index, dim + 1));
                assert_eq!(
                    (pair.x.to_bits(), pair.y.to_bits()),
                    (one.0.to_bits(), one.1.to_bits())
                );
            }
        }
    }

    /// Dimensions on both sides of the eager prefix read pbrt-v3's table.
    #[test]
    fn dimensions_past_the_eager_prefix_use_the_full_table() {
        let h = Halton::new(bounds(64, 64), false);
        let full = compute_radical_inverse_permutations(&mut Rng::default());
        for dim in [2, 17, 18, EAGER_DIMS - 1, EAGER_DIMS, 127, 128, 500, 511, 512, 999] {
            for index in [1i64, 12_345, 987_654_321] {
                let want =
                    scrambled_radical_inverse(dim, index as u64, &full[PRIME_SUMS[dim] as usize..]);
                let got = h.sample_dimension(Point2i::new(0, 0), index, dim);
                assert_eq!(got.to_bits(), want.to_bits(), "dim {dim}, index {index}");
            }
        }
    }

    /// Every base's permutation, whichever part of the table holds it, is
    /// pbrt-v3's; the parts meet where `PART_STARTS` says.
    #[test]
    fn each_part_of_the_table_holds_pbrts_permutations() {
        let h = Halton::new(bounds(64, 64), false);
        let full = compute_radical_inverse_permutations(&mut Rng::default());
        for dim in 0..PRIME_TABLE_SIZE {
            let p = PRIMES[dim] as usize;
            let want = &full[PRIME_SUMS[dim] as usize..][..p];
            assert_eq!(&h.permutation_for_dimension(dim)[..p], want, "dim {dim}");
        }
        for (k, w) in PART_STARTS.windows(2).enumerate() {
            assert_eq!((part_of(w[0]), part_of(w[1] - 1)), (k, k));
            let size = (PRIME_SUMS.get(w[1]).copied().unwrap_or(full.len() as u32)
                - PRIME_SUMS[w[0]]) as usize;
            assert_eq!(part(k).perms.len(), size, "part {k}");
        }
    }

    /// The first entries of some bases' permutations as C++ pbrt-v3 makes
    /// them: `ComputeRadicalInversePermutations` with a default `RNG`,
    /// printed by a small program linked with the pbrt-v3 library built as
    /// `../shared/reference/BUILD-PBRT-V3.md` says. Bases on both sides of
    /// every part's edge.
    #[test]
    fn the_parts_hold_pbrt_v3s_own_values() {
        let pbrt: [(usize, [u16; 8]); 10] = [
            (17, [56, 4, 6, 5, 36, 23, 35, 17]),
            (63, [177, 295, 108, 8, 193, 179, 286, 120]),
            (64, [236, 43, 18, 290, 180, 164, 15, 235]),
            (127, [569, 18, 5, 124, 611, 672, 598, 416]),
            (128, [622, 205, 721, 252, 288, 485, 661, 439]),
            (255, [1215, 1612, 422, 873, 902, 662, 1398, 472]),
            (256, [1417, 676, 459, 1507, 1050, 1185, 1163, 814]),
            (511, [2763, 3460, 2035, 595, 2584, 3469, 737, 143]),
            (512, [2503, 1645, 3180, 1564, 1097, 1899, 2501, 2607]),
            (999, [3238, 4543, 7597, 5332, 4638, 877, 5077, 5885]),
        ];
        let h = Halton::new(bounds(64, 64), false);
        for (dim, want) in pbrt {
            assert_eq!(h.permutation_for_dimension(dim)[..8], want, "dim {dim}");
        }
        assert_eq!(h.permutation_for_dimension(0)[..2], [1, 0]);
    }

    #[test]
    fn scales_and_inverses_match_pbrt() {
        let h = Halton::new(bounds(100, 50), false);
        assert_eq!(h.base_scales, [128, 81]);
        assert_eq!(h.base_exponents, [7, 4]);
        assert_eq!(h.sample_stride, 128 * 81);
        assert_eq!((h.mult_inverse[0] * 81) % 128, 1);
        assert_eq!((h.mult_inverse[1] * 128) % 81, 1);
    }

    #[test]
    fn first_samples_of_pixel_zero_are_radical_inverses() {
        let mut s = HaltonSampler::new(16, Halton::new(bounds(64, 64), false));
        s.start_pixel(Point2i::new(0, 0));
        // Pixel (0,0) is visited by indices that are multiples of the stride.
        let stride = 64 * 81;
        for i in 0..16i64 {
            let index = i * stride;
            let p = s.get_2d();
            assert_eq!(p.x, radical_inverse(0, (index >> 6) as u64));
            assert_eq!(p.y, radical_inverse(1, (index / 81) as u64));
            // Unscaled: the full radical inverse times the scale is the pixel plus p.
            let full_x = radical_inverse(0, index as u64) as f64 * 64.0;
            assert!((full_x - p.x as f64).abs() < 1e-5, "{full_x} {}", p.x);
            let t = s.get_1d();
            assert_eq!(t, scrambled_radical_inverse(2, index as u64, &permutations()[5..]));
            s.start_next_sample();
        }
    }
}
