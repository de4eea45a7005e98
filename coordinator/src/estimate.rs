//! A render's estimate of its own error, without a reference image.
//!
//! Every film pixel keeps its sums over all samples and over the second half
//! of its samples. The sampler says which half a sample is in
//! (`farm_common::film::Halves`); in a render in passes, a pass is the
//! second half of the render it completes. So the film holds two
//! half-images A (of a samples) and B (of b), and the full image
//! F = (a·A + b·B) / (a + b). How their difference relates to F's mean
//! squared error R depends on how the samples relate. If each half is as
//! good as a set of its size (R(n) for n samples), then
//!
//! E[(A − B)²] · ab / (a + b)² = g · R(a + b),
//! g = (1 + b/a)^(α−1) + (1 + a/b)^(α−1) − 1 when R(n) ∝ n^−α.
//!
//! (For a = b this says E[(F − A)²] = R(N/2) − R(N): the difference is the
//! error the second half took away, and g = 2^α − 1.)
//!
//! - **Independent halves** (`HalfImages::Independent`: pbrt-v3's `random`
//!   sampler, and the passes of a sampler with state, each its own set):
//!   α = 1 and g = 1, exactly.
//! - **The two halves of one sequence** (Halton, Sobol'): the rate lies
//!   between α = 1 (no better than independent samples) and α = 2 (a
//!   low-discrepancy set on a smooth integrand), so g lies between 1 and
//!   1 + a/b + b/a (3 for equal halves). The estimate divides by the
//!   geometric middle, √(1 + a/b + b/a), which puts it within √3 ≈ 1.7× of
//!   the truth for any rate in between.
//! - **Halves spread over one set's strata** (the pixel samplers rendered in
//!   one pass): a half is not a set of its size in the dimensions the
//!   sampler shuffles, so the difference runs higher; the estimate divides
//!   by √5 as it did before there were passes (measured 2–4× high at 64 spp).
//!
//! Dividing by F² + 0.01 gives the same relative MSE the reference
//! comparison uses (`metrics::rel_mse`), per pixel and channel. a and b are
//! taken from the halves' sums of filter weights.
//!
//! **The level a pixel's error is relative to.** The reference comparison
//! divides by the true value; the estimate has only the pixel's own F,
//! which the samples that make (A − B)² large also make large. Where a
//! pixel's few samples are mostly dim and now and then very bright (a
//! rough metal lit by a small sun, speckled at 64 spp), the pixels that
//! caught a bright sample have a large difference over a large F, and
//! those that caught none have none: the estimate saw a third of the true
//! error on such a scene (`scenes/estimate/motion.pbrt`, Halton at 64
//! spp). So each channel's error is taken relative to the smaller of F
//! and the mean F of the 3 × 3 pixels around it ([`levelled_errors`]):
//! in a smooth region that is F, at a speckle the level of its
//! neighbourhood. Next to a much darker region it is less than F: about
//! ⅔ of it on the bright side of a straight edge (its error counts 2.25×),
//! ⅓ on a bright line one pixel wide (9×); the dark side keeps its own.
//! On the shared scenes every claimed estimate stays within 2× with it.

use farm_common::film::{HalfImages, Pixel, TILE_SIZE};

pub mod fireflies;
pub use fireflies::{find as find_fireflies, suspects, Fireflies, Suspects};

/// Side of the blocks of [`ErrorEstimate::per_tile`].
const BLOCK: usize = TILE_SIZE as usize;
use farm_common::geometry::Bounds2i;

/// The denominator's offset in relMSE, as in `metrics::rel_mse`.
const EPSILON: f64 = 0.01;

/// One pixel's estimated relMSE (averaged over its channels) relative to
/// its own value, or `None` when a half has no samples there: what the
/// running estimate of a render under way shows ([`levelled_errors`] is
/// the finished render's).
pub fn pixel_error(p: &Pixel, scale: f32, halves: HalfImages) -> Option<f64> {
    pixel_error_against(p, scale, halves, Against::Value)
}

/// A pixel's sums of filter weights, all and each half's, or `None` when
/// a half has no samples there.
pub(crate) fn half_weights(p: &Pixel) -> Option<(f64, f64, f64)> {
    let w = f64::from(p.weight);
    let w_b = f64::from(p.second_weight);
    let w_a = w - w_b;
    (w != 0.0 && w_a != 0.0 && w_b != 0.0).then_some((w, w_a, w_b))
}

/// A pixel's error as [`levelled_errors`] gives it, or `None` where it is
/// not counted (NaN).
pub(crate) fn counted_error(e: f64) -> Option<f64> {
    (!e.is_nan()).then_some(e)
}

/// The sum and count of the pixels' errors that are counted, in order.
#[cfg(test)]
pub(crate) fn sum_counted(errors: &[f64]) -> (f64, usize) {
    errors.iter().filter_map(|&e| counted_error(e)).fold((0.0, 0), |(s, k), e| (s + e, k + 1))
}

/// A pixel's value per channel (times `1 / w`, where
/// [`pixel_error_against`] divides by `w`: the level need not match it
/// bit for bit), or
/// `None` when a half has no samples there.
#[inline(always)]
fn sampled_value(p: &Pixel, scale: f32) -> Option<[f64; 3]> {
    let (w, _, _) = half_weights(p)?;
    let per = 1.0 / w;
    Some(p.contrib.map(|c| (f64::from(c) * per).max(0.0) * f64::from(scale)))
}

/// `1 / n` for the number of pixels a 3 × 3 neighbourhood holds (1 to 9),
/// so that a level is a product rather than a division.
const PER_COUNT: [f64; 10] = {
    let mut per = [0.0; 10];
    let mut n = 1;
    while n < per.len() {
        per[n] = 1.0 / n as f64;
        n += 1;
    }
    per
};

/// The level of channel `c` of a pixel of `value` whose neighbourhood's
/// sums (values, then the count of pixels summed) are `sum`: the smaller
/// of its value and their mean.
#[inline(always)]
pub(crate) fn level(value: &[f64; 4], sum: &[f64; 4], c: usize) -> f64 {
    value[c].min(sum[c] * PER_COUNT[sum[3] as usize])
}

/// What a pixel's per-channel squared error terms are multiplied by to
/// give its relMSE: the weight `times` that turns E[(A − B)²] into
/// g · R, over 3 (the channels' mean) and g (see the module
/// documentation); worked out once a pixel, with two divisions at most.
#[inline(always)]
fn factor(w: f64, w_a: f64, w_b: f64, halves: HalfImages) -> f64 {
    match halves {
        HalfImages::Independent => w_a * w_b / (3.0 * (w * w)),
        HalfImages::Sequence => {
            // 1 + a/b + b/a over one denominator.
            let ab = w_a * w_b;
            let g = ((w_a * w_a + w_b * w_b + ab) / ab).abs().sqrt();
            ab / (3.0 * (w * w) * g)
        }
        HalfImages::Spread => 0.25 / (3.0 * 5f64.sqrt()),
    }
}

/// Each pixel's estimated relMSE over a `width` × `height` film whose
/// pixels (row-major) are `pixel(i)`: per channel, relative to the smaller
/// of its value and the mean value of the 3 × 3 pixels around it (itself
/// included; pixels without samples in both halves left out), as the
/// module documentation says, or to its value alone for the pixels of
/// `own` (fireflies, which would set their neighbourhood's level
/// themselves; ascending). NaN where a half has no samples, a pixel's
/// error being finite otherwise (a film's sums are): 8 bytes a pixel,
/// where `Option<f64>` takes 16.
///
/// Neighbouring pixels are worked out [`LANES`] at a time, each
/// operation across them at once ([`levelled_lanes`]): the same
/// operations in the same order on each pixel as one at a time, so the
/// same bits, with the divisions (six or seven a pixel, and one for its
/// value) paired into the vector unit's.
pub fn levelled_errors(
    (width, height): (usize, usize),
    pixel: impl Fn(usize) -> Pixel,
    scale: f32,
    halves: HalfImages,
    own: &[usize],
) -> Vec<f64> {
    // A row's values with a count of 1 (zeros where a half has no
    // samples), and their sums over 3 pixels across; the 3 × 3 sums add
    // three rows of those, so only three rows are held at a time.
    let add = |a: &mut [f64; 4], b: &[f64; 4]| (0..4).for_each(|c| a[c] += b[c]);
    let row = |y: usize| -> (Vec<[f64; 4]>, Vec<[f64; 4]>) {
        let values: Vec<[f64; 4]> = (y * width..(y + 1) * width)
            .map(|i| sampled_value(&pixel(i), scale).map_or([0.0; 4], |v| [v[0], v[1], v[2], 1.0]))
            .collect();
        let mut across = values.clone();
        for (x, a) in across.iter_mut().enumerate() {
            if x > 0 {
                add(a, &values[x - 1]);
            }
            if x + 1 < width {
                add(a, &values[x + 1]);
            }
        }
        (values, across)
    };
    // Its pages mapped in one call, then written in order.
    let mut errors = crate::pages::mapped(0.0, width * height);
    debug_assert!(own.windows(2).all(|w| w[0] <= w[1]), "fireflies in ascending order");
    let mut own = own.iter().copied().peekable();
    let (mut above, mut here) = (None, (height > 0).then(|| row(0)));
    for y in 0..height {
        let below = (y + 1 < height).then(|| row(y + 1));
        let (values, across) = here.as_ref().expect("a row is held for each y");
        // The sums over the pixel's neighbourhood, or `None` where its
        // error is not levelled.
        let mut around = |x: usize| -> Option<[f64; 4]> {
            let i = y * width + x;
            while own.next_if(|&j| j < i).is_some() {}
            if values[x][3] == 0.0 || own.next_if_eq(&i).is_some() {
                return None;
            }
            let mut sum = across[x];
            for (_, other) in above.iter().chain(below.iter()) {
                add(&mut sum, &other[x]);
            }
            Some(sum)
        };
        // One pixel's error, as [`levelled_lanes`] works out several.
        let alone = |x: usize, around: Option<[f64; 4]>| {
            let p = pixel(y * width + x);
            let e = match around {
                Some(sum) => {
                    let level = std::array::from_fn(|c| level(&values[x], &sum, c));
                    pixel_error_against(&p, scale, halves, Against::Level(level))
                }
                None if values[x][3] == 0.0 => None,
                None => pixel_error(&p, scale, halves),
            };
            e.unwrap_or(f64::NAN)
        };
        let mut x = 0;
        while x < width {
            let row_at = y * width + x;
            if x + LANES <= width {
                // Filled in loops: through `array::from_fn` the closures
                // were called out of line in the coordinator's build.
                let mut sums = [None; LANES];
                for (k, s) in sums.iter_mut().enumerate() {
                    *s = around(x + k);
                }
                if sums.iter().all(Option::is_some) {
                    let mut pixels = [Pixel::default(); LANES];
                    for (k, p) in pixels.iter_mut().enumerate() {
                        *p = pixel(row_at + k);
                    }
                    let value = std::array::from_fn(|k| values[x + k]);
                    let sums = sums.map(|s| s.unwrap_or_default());
                    let e = levelled_lanes(&pixels, scale, halves, &value, &sums);
                    errors[row_at..row_at + LANES].copy_from_slice(&e);
                } else {
                    for (k, sum) in sums.into_iter().enumerate() {
                        errors[row_at + k] = alone(x + k, sum);
                    }
                }
                x += LANES;
            } else {
                errors[row_at] = alone(x, around(x));
                x += 1;
            }
        }
        above = here;
        here = below;
    }
    errors
}

/// Pixels [`levelled_errors`] works out at once.
const LANES: usize = 2;

/// `f` of each lane.
#[inline(always)]
fn each(f: impl Fn(usize) -> f64) -> [f64; LANES] {
    std::array::from_fn(f)
}

/// [`pixel_error_against`] of [`Against::Level`] for `LANES` pixels that
/// have samples in both halves, each levelled by its `value` and the
/// `sum` over its neighbourhood as [`levelled_errors`] has them: each line
/// the same operation on every pixel, in the order the one-pixel
/// functions do them.
#[inline(always)]
fn levelled_lanes(
    p: &[Pixel; LANES],
    scale: f32,
    halves: HalfImages,
    value: &[[f64; 4]; LANES],
    sum: &[[f64; 4]; LANES],
) -> [f64; LANES] {
    type L = [f64; LANES];
    let level: [L; 3] = std::array::from_fn(|c| each(|k| level(&value[k], &sum[k], c)));
    let scale = f64::from(scale);
    let w: L = each(|k| f64::from(p[k].weight));
    let w_b: L = each(|k| f64::from(p[k].second_weight));
    let w_a: L = each(|k| w[k] - w_b[k]);
    let to_a: L = each(|k| scale / w_a[k]);
    let to_b: L = each(|k| scale / w_b[k]);
    let factor: L = each(|k| factor(w[k], w_a[k], w_b[k], halves));
    let mut e: L = [0.0; LANES];
    // Indexed rather than iterated: `level.iter()` here kept the loop from
    // being unrolled into vector divisions (104 → 158 ms for a 2048² film).
    #[allow(clippy::needless_range_loop)]
    for c in 0..3 {
        let level = level[c];
        let all: L = each(|k| f64::from(p[k].contrib[c]));
        let second: L = each(|k| f64::from(p[k].second_contrib[c]));
        let a: L = each(|k| (all[k] - second[k]) * to_a[k]);
        let b: L = each(|k| second[k] * to_b[k]);
        let d: L = each(|k| a[k] - b[k]);
        let term: L = each(|k| d[k] * d[k] / (level[k] * level[k] + EPSILON));
        e = each(|k| e[k] + term[k]);
    }
    each(|k| e[k] * factor[k])
}

/// What a pixel's squared error is relative to.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Against {
    /// Its value, as the reference comparison has it.
    Value,
    /// Its darker half: for a firefly, nearer its true value.
    DarkerHalf,
    /// A level per channel: the smaller of the pixel's value and its
    /// neighbourhood's mean ([`levelled_errors`]), or for a pixel on the
    /// edge of a small light, the mean of a run of pixels along the edge.
    Level([f64; 3]),
}

/// [`pixel_error`], relative to the pixel's value, its darker half or a
/// level.
pub fn pixel_error_against(
    p: &Pixel,
    scale: f32,
    halves: HalfImages,
    against: Against,
) -> Option<f64> {
    let scale = f64::from(scale);
    let (w, w_a, w_b) = half_weights(p)?;
    // E[(A − B)²] times `factor` is R, averaged over the channels (see the
    // module documentation).
    let (to_a, to_b) = (scale / w_a, scale / w_b);
    let mut e = 0.0;
    for c in 0..3 {
        let all = f64::from(p.contrib[c]);
        let second = f64::from(p.second_contrib[c]);
        let a = (all - second) * to_a;
        let b = second * to_b;
        let d = a - b;
        let level = match against {
            // The image clamps negative values (from negative filter
            // lobes) to 0.
            Against::Value => (all / w).max(0.0) * scale,
            Against::DarkerHalf => a.min(b).max(0.0),
            Against::Level(l) => l[c],
        };
        e += d * d / (level * level + EPSILON);
    }
    Some(e * factor(w, w_a, w_b, halves))
}

/// An estimate of a render's relMSE from its two half-images.
#[derive(Clone, Debug, PartialEq)]
pub struct ErrorEstimate {
    /// The render's fireflies and edge pixels, when counting them makes
    /// the estimate only a lower bound.
    pub fireflies: Option<Fireflies>,
    /// Image width in pixels.
    pub width: usize,
    /// Image height in pixels.
    pub height: usize,
    /// Per pixel (row-major), the estimate averaged over the three channels;
    /// 0 where a half had no samples.
    pub per_pixel: Vec<f32>,
    /// The estimated relMSE of the whole image: the mean of `per_pixel`
    /// over the pixels both halves reached.
    pub rel_mse: f64,
}

impl ErrorEstimate {
    /// The estimate from a film's sums (row-major over `bounds`, the image's
    /// pixels) scaled as the image is by `scale`: each pixel's
    /// [`levelled_errors`], with no pixel held at its own value (a film's
    /// estimate holds its fireflies at theirs); `None` when no pixel has
    /// samples in both halves (one sample per pixel).
    pub fn from_pixels(
        bounds: Bounds2i,
        pixels: &[Pixel],
        scale: f32,
        halves: HalfImages,
    ) -> Option<Self> {
        let size = (bounds.width().max(0) as usize, bounds.height().max(0) as usize);
        let errors = levelled_errors(size, |i| pixels[i], scale, halves, &[]);
        Self::from_values(bounds, &errors)
    }

    /// The estimate from each pixel's error (NaN: not counted), row-major
    /// over `bounds` (summed in that order).
    pub fn from_values(bounds: Bounds2i, values: &[f64]) -> Option<Self> {
        Self::with_totals(bounds, values).map(|(e, _)| e)
    }

    /// [`ErrorEstimate::from_values`] and the sum and count of the errors
    /// counted, from the same pass.
    pub(crate) fn with_totals(bounds: Bounds2i, values: &[f64]) -> Option<(Self, (f64, usize))> {
        let (width, height) = (bounds.width().max(0) as usize, bounds.height().max(0) as usize);
        let mut per_pixel = crate::pages::mapped(0.0f32, values.len());
        let (mut sum, mut counted) = (0.0f64, 0usize);
        for (p, &v) in per_pixel.iter_mut().zip(values) {
            if let Some(e) = counted_error(v) {
                *p = e as f32;
                sum += e;
                counted += 1;
            }
        }
        (counted > 0).then(|| {
            let rel_mse = sum / counted as f64;
            (ErrorEstimate { fireflies: None, width, height, per_pixel, rel_mse }, (sum, counted))
        })
    }

    /// The estimate, counting the fireflies' and edge pixels' error as
    /// [`Fireflies::rel_mse`] does when they matter: the value to decide by.
    pub fn upper(&self) -> f64 {
        self.fireflies.as_ref().map_or(self.rel_mse, |f| f.rel_mse.max(self.rel_mse))
    }

    /// The estimate averaged over each 16 × 16 block of the image, row-major
    /// over the blocks (the film's tile grid when the film is not cropped).
    pub fn per_tile(&self) -> (usize, usize, Vec<f32>) {
        let (tw, th) = (self.width.div_ceil(BLOCK), self.height.div_ceil(BLOCK));
        let mut out = Vec::with_capacity(tw * th);
        for ty in 0..th {
            for tx in 0..tw {
                let (x0, y0) = (tx * BLOCK, ty * BLOCK);
                let (x1, y1) = ((x0 + BLOCK).min(self.width), (y0 + BLOCK).min(self.height));
                let mut s = 0.0f64;
                for y in y0..y1 {
                    s += self.per_pixel[y * self.width + x0..y * self.width + x1]
                        .iter()
                        .map(|&v| f64::from(v))
                        .sum::<f64>();
                }
                out.push((s / ((x1 - x0) * (y1 - y0)) as f64) as f32);
            }
        }
        (tw, th, out)
    }
}

#[cfg(test)]
mod tests;
