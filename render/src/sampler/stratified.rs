//! The stratified sampler (pbrt-v3 `samplers/stratified.cpp`):
//!
//! ```text
//! Sampler "stratified" "integer xsamples" [4] "integer ysamples" [4]
//!     "bool jitter" [true] "integer dimensions" [4]
//! ```
//!
//! Jittered strata per pixel, shuffled across dimensions; 2D arrays are
//! Latin hypercubes. `pixelsamples` is not a parameter of this sampler.

use super::lowdiscrepancy::shuffle;
use super::pixel::PixelSampler;
use farm_common::geometry::{Point2i, Vec2};
use farm_common::rng::{Rng, ONE_MINUS_EPSILON};

/// One jittered (or centred) value per stratum of `[0,1)` (pbrt-v3 `StratifiedSample1D`).
pub fn stratified_sample_1d(samp: &mut [f32], rng: &mut Rng, jitter: bool) {
    let inv = 1.0 / samp.len() as f32;
    for (i, s) in samp.iter_mut().enumerate() {
        let delta = if jitter { rng.uniform_f32() } else { 0.5 };
        *s = ((i as f32 + delta) * inv).min(ONE_MINUS_EPSILON);
    }
}

/// One jittered value per cell of an `nx`×`ny` grid, row by row (pbrt-v3 `StratifiedSample2D`).
pub fn stratified_sample_2d(samp: &mut [Vec2], nx: usize, ny: usize, rng: &mut Rng, jitter: bool) {
    let (dx, dy) = (1.0 / nx as f32, 1.0 / ny as f32);
    let mut k = 0;
    for y in 0..ny {
        for x in 0..nx {
            let jx = if jitter { rng.uniform_f32() } else { 0.5 };
            let jy = if jitter { rng.uniform_f32() } else { 0.5 };
            samp[k] = Vec2::new(
                ((x as f32 + jx) * dx).min(ONE_MINUS_EPSILON),
                ((y as f32 + jy) * dy).min(ONE_MINUS_EPSILON),
            );
            k += 1;
        }
    }
}

/// `samples.len()` points of a 2D Latin hypercube (pbrt-v3 `LatinHypercube` with `nDim` 2).
pub fn latin_hypercube_2d(samples: &mut [Vec2], rng: &mut Rng) {
    let n = samples.len();
    let inv = 1.0 / n as f32;
    for (i, s) in samples.iter_mut().enumerate() {
        for j in 0..2 {
            s[j] = ((i as f32 + rng.uniform_f32()) * inv).min(ONE_MINUS_EPSILON);
        }
    }
    for dim in [0usize, 1] {
        for j in 0..n {
            let other = j + rng.uniform_u32_below((n - j) as u32) as usize;
            let tmp = samples[j][dim];
            samples[j][dim] = samples[other][dim];
            samples[other][dim] = tmp;
        }
    }
}

/// The stratified sampler.
#[derive(Clone, Debug)]
pub struct StratifiedSampler {
    /// The per-pixel sample storage and generator.
    pub px: PixelSampler,
    x_samples: usize,
    y_samples: usize,
    pub(super) jitter: bool,
}

impl StratifiedSampler {
    /// Strata across and down a pixel.
    pub fn strata(&self) -> (usize, usize) {
        (self.x_samples, self.y_samples)
    }

    /// A sampler with `x_samples`×`y_samples` strata and `n_dims`
    /// precomputed 1D and 2D dimensions.
    pub fn new(x_samples: usize, y_samples: usize, jitter: bool, n_dims: usize) -> Self {
        let px = PixelSampler::new((x_samples * y_samples) as i64, n_dims);
        StratifiedSampler { px, x_samples, y_samples, jitter }
    }

    /// Generates the pixel's samples and starts its first one.
    pub fn start_pixel(&mut self, p: Point2i) {
        let (nx, ny, jitter) = (self.x_samples, self.y_samples, self.jitter);
        let px = &mut self.px;
        for s in px.samples_1d.iter_mut() {
            stratified_sample_1d(s, &mut px.rng, jitter);
            shuffle(s, nx * ny, 1, &mut px.rng);
        }
        for s in px.samples_2d.iter_mut() {
            stratified_sample_2d(s, nx, ny, &mut px.rng, jitter);
            shuffle(s, nx * ny, 1, &mut px.rng);
        }
        for (arr, &n) in px.core.array_1d.iter_mut().zip(&px.core.array_1d_sizes) {
            for chunk in arr.chunks_exact_mut(n.max(1)) {
                stratified_sample_1d(chunk, &mut px.rng, jitter);
                shuffle(chunk, n, 1, &mut px.rng);
            }
        }
        for (arr, &n) in px.core.array_2d.iter_mut().zip(&px.core.array_2d_sizes) {
            for chunk in arr.chunks_exact_mut(n.max(1)) {
                latin_hypercube_2d(chunk, &mut px.rng);
            }
        }
        px.start_pixel(p);
    }
}
