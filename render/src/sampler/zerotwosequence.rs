//! The (0,2)-sequence sampler (pbrt-v3 `samplers/zerotwosequence.cpp`):
//!
//! ```text
//! Sampler "02sequence" "integer pixelsamples" [16] "integer dimensions" [4]
//! ```
//!
//! (also named `"lowdiscrepancy"`). Each pixel gets freshly scrambled van
//! der Corput (1D) and Sobol' (2D) points, shuffled across dimensions.
//! Sample counts are powers of two.

use super::lowdiscrepancy::{sobol_2d, van_der_corput};
use super::pixel::PixelSampler;
use farm_common::geometry::Point2i;

/// The (0,2)-sequence sampler.
#[derive(Clone, Debug)]
pub struct ZeroTwoSequenceSampler {
    /// The per-pixel sample storage and generator.
    pub px: PixelSampler,
}

impl ZeroTwoSequenceSampler {
    /// A sampler taking `spp` samples (a power of two) with `n_dims`
    /// precomputed 1D and 2D dimensions.
    pub fn new(spp: i64, n_dims: usize) -> Self {
        ZeroTwoSequenceSampler { px: PixelSampler::new(spp, n_dims) }
    }

    /// Generates the pixel's samples and starts its first one.
    pub fn start_pixel(&mut self, p: Point2i) {
        let px = &mut self.px;
        let spp = px.core.spp as usize;
        for s in px.samples_1d.iter_mut() {
            van_der_corput(1, spp, s, &mut px.rng);
        }
        for s in px.samples_2d.iter_mut() {
            sobol_2d(1, spp, s, &mut px.rng);
        }
        for (s, &n) in px.core.array_1d.iter_mut().zip(&px.core.array_1d_sizes) {
            van_der_corput(n, spp, s, &mut px.rng);
        }
        for (s, &n) in px.core.array_2d.iter_mut().zip(&px.core.array_2d_sizes) {
            sobol_2d(n, spp, s, &mut px.rng);
        }
        px.start_pixel(p);
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn sixteen_samples_fill_every_elementary_interval() {
        let mut s = ZeroTwoSequenceSampler::new(16, 4);
        s.px.rng.set_sequence(42);
        s.start_pixel(Point2i::new(3, 7));
        let pts: Vec<_> = (0..16)
            .map(|i| {
                s.px.set_sample_number(i);
                s.px.get_2d()
            })
            .collect();
        // Elementary intervals of volume 1/16: (2^a) x (2^(4-a)) grids.
        for a in 0..=4u32 {
            let (nx, ny) = ((1u32 << a) as f32, (1u32 << (4 - a)) as f32);
            let mut seen = [false; 16];
            for p in &pts {
                let cell = (p.x * nx) as u32 * (1 << (4 - a)) + (p.y * ny) as u32;
                assert!(!seen[cell as usize], "interval {a} hit twice");
                seen[cell as usize] = true;
            }
        }
        let mut t: Vec<u32> = (0..16)
            .map(|i| {
                s.px.set_sample_number(i);
                (s.px.get_1d() * 16.0) as u32
            })
            .collect();
        t.sort_unstable();
        assert_eq!(t, (0..16).collect::<Vec<_>>());
    }
}
