//! The random sampler (pbrt-v3 `samplers/random.cpp`):
//!
//! ```text
//! Sampler "random" "integer pixelsamples" [4] "integer seed" [0]
//! ```
//!
//! Independent uniform values from one PCG32 stream per tile.

use super::pixel::SamplerCore;
use farm_common::geometry::{Point2i, Vec2};
use farm_common::rng::Rng;

/// The random sampler.
#[derive(Clone, Debug)]
pub struct RandomSampler {
    /// Pixel, sample index and arrays.
    pub core: SamplerCore,
    /// The generator (stream `seed`, reseeded by `clone_with_seed`).
    pub rng: Rng,
}

impl RandomSampler {
    /// A sampler taking `spp` samples, on stream `seed`.
    pub fn new(spp: i64, seed: u64) -> Self {
        RandomSampler { core: SamplerCore::new(spp), rng: Rng::new(seed) }
    }

    /// Fills the sample arrays and starts the pixel.
    pub fn start_pixel(&mut self, p: Point2i) {
        for arr in self.core.array_1d.iter_mut() {
            for v in arr.iter_mut() {
                *v = self.rng.uniform_f32();
            }
        }
        for arr in self.core.array_2d.iter_mut() {
            for v in arr.iter_mut() {
                let x = self.rng.uniform_f32();
                *v = Vec2::new(x, self.rng.uniform_f32());
            }
        }
        self.core.start_pixel(p);
    }

    /// A uniform value.
    #[inline]
    pub fn get_1d(&mut self) -> f32 {
        debug_assert!(self.core.current_pixel_sample_index < self.core.spp);
        self.rng.uniform_f32()
    }

    /// Two uniform values.
    #[inline]
    pub fn get_2d(&mut self) -> Vec2 {
        debug_assert!(self.core.current_pixel_sample_index < self.core.spp);
        let x = self.rng.uniform_f32();
        Vec2::new(x, self.rng.uniform_f32())
    }
}
