//! The maximized-minimum-distance sampler (pbrt-v3 `samplers/maxmin.cpp`):
//!
//! ```text
//! Sampler "maxmindist" "integer pixelsamples" [4] "integer dimensions" [4]
//! ```
//!
//! The pixel's 2D film samples come from Grünschloss–Keller (0,m,2)-net
//! generator matrices with maximized minimum distance; other dimensions
//! use scrambled (0,2)-sequences like the `02sequence` sampler.

use super::lowdiscrepancy::{sample_generator_matrix, shuffle, sobol_2d, van_der_corput};
use super::pixel::PixelSampler;
use farm_common::geometry::{Point2i, Vec2};

const fn matrix(prefix: &[u32]) -> [u32; 32] {
    let mut c = [0u32; 32];
    let mut i = 0;
    while i < prefix.len() {
        c[i] = prefix[i];
        i += 1;
    }
    c
}

/// pbrt-v3 `CMaxMinDist`: generator matrix for `2^i` samples at index `i`
/// (columns bit-reversed; entry 1 is pbrt-v3's, whose only nonzero column
/// is never used).
pub static C_MAX_MIN_DIST: [[u32; 32]; 17] = [
    [0; 32],
    {
        let mut c = [0u32; 32];
        c[31] = 0x8000_0000;
        c
    },
    matrix(&[0xc0000000, 0x80000000]),
    matrix(&[0xa0000000, 0x40000000, 0x80000000]),
    matrix(&[0xc0000000, 0x50000000, 0x20000000, 0x30000000]),
    matrix(&[0x88000000, 0x58000000, 0x20000000, 0x40000000, 0x80000000]),
    matrix(&[0xe0000000, 0x60000000, 0x28000000, 0x10000000, 0x18000000, 0x04000000]),
    matrix(&[0x82000000, 0x44000000, 0x2c000000, 0x10000000, 0x20000000, 0x40000000, 0x80000000]),
    matrix(&[
        0x80000000, 0x70000000, 0x30000000, 0x14000000, 0x08000000, 0x0c000000, 0x02000000,
        0x01000000,
    ]),
    matrix(&[
        0xc0000000, 0x41000000, 0x22000000, 0x16000000, 0x08000000, 0x10000000, 0x20000000,
        0x40800000, 0x80000000,
    ]),
    matrix(&[
        0x80000000, 0x40000000, 0x20000000, 0x18000000, 0x08000000, 0x1c000000, 0x1e000000,
        0x03000000, 0x00800000, 0x00400000,
    ]),
    matrix(&[
        0x80000000, 0x60400000, 0x20800000, 0x11000000, 0x0b000000, 0x04000000, 0x08000000,
        0x10000000, 0x20000000, 0x40000000, 0x00200000,
    ]),
    matrix(&[
        0x80000000, 0x40000000, 0x20000000, 0x1c000000, 0x0c000000, 0x05000000, 0x02000000,
        0x03000000, 0x00800000, 0x00400000, 0x00200000, 0x00100000,
    ]),
    matrix(&[
        0x80000000, 0x40000000, 0x30200000, 0x10400000, 0x08800000, 0x05800000, 0x02000000,
        0x04000000, 0x08000000, 0x10000000, 0x20000000, 0x00100000, 0x00080000,
    ]),
    matrix(&[
        0x80000000, 0x40000000, 0x20000000, 0x10000000, 0x0e000000, 0x06000000, 0x02800000,
        0x01000000, 0x01800000, 0x00400000, 0x00200000, 0x00100000, 0x00080000, 0x00040000,
    ]),
    matrix(&[
        0x80000000, 0x40000000, 0x20000000, 0x18100000, 0x08200000, 0x04400000, 0x02c00000,
        0x01000000, 0x02000000, 0x04000000, 0x08000000, 0x10000000, 0x00080000, 0x00040000,
        0x00020000,
    ]),
    matrix(&[
        0x80000000, 0x40000000, 0x20000000, 0x10000000, 0x08000000, 0x07000000, 0x03000000,
        0x01400000, 0x00800000, 0x00c00000, 0x00200000, 0x00100000, 0x00080000, 0x00040000,
        0x00020000, 0x00010000,
    ]),
];

/// The maximized-minimum-distance sampler.
#[derive(Clone, Debug)]
pub struct MaxMinDistSampler {
    /// The per-pixel sample storage and generator.
    pub px: PixelSampler,
    c_pixel: &'static [u32; 32],
}

impl MaxMinDistSampler {
    /// A sampler taking `spp` samples (a power of two up to 2^16) with
    /// `n_dims` precomputed 1D and 2D dimensions.
    pub fn new(spp: i64, n_dims: usize) -> Self {
        Self::asked(spp, spp, n_dims)
    }

    /// A sampler taking `spp` samples where the scene asked for `asked`
    /// (before pbrt-v3's rounding up to a power of two). pbrt-v3's
    /// constructor picks the film's generator matrix by the count it was
    /// given, not the rounded one (its `Log2Int(samplesPerPixel)` names
    /// the argument), so 6 samples take 8 points of the matrix made for 4.
    /// farm does the same, so such a scene renders pbrt-v3's image.
    pub fn asked(spp: i64, asked: i64, n_dims: usize) -> Self {
        let index = (asked.max(1) as u64).ilog2() as usize;
        MaxMinDistSampler {
            px: PixelSampler::new(spp, n_dims),
            c_pixel: &C_MAX_MIN_DIST[index.min(C_MAX_MIN_DIST.len() - 1)],
        }
    }

    /// Generates the pixel's samples and starts its first one.
    pub fn start_pixel(&mut self, p: Point2i) {
        let px = &mut self.px;
        let spp = px.core.spp as usize;
        let inv_spp = 1.0 / spp as f32;
        if let Some(film) = px.samples_2d.first_mut() {
            for (i, s) in film.iter_mut().enumerate() {
                *s = Vec2::new(
                    i as f32 * inv_spp,
                    sample_generator_matrix(self.c_pixel, i as u32, 0),
                );
            }
            shuffle(film, spp, 1, &mut px.rng);
        }
        for s in px.samples_1d.iter_mut() {
            van_der_corput(1, spp, s, &mut px.rng);
        }
        for s in px.samples_2d.iter_mut().skip(1) {
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

    /// Six samples asked for render eight, from the matrix for four: the
    /// film samples' second coordinates are the four-point matrix's values
    /// at indices 0..8, and differ from the eight-point matrix's.
    #[test]
    fn a_count_rounded_up_keeps_the_matrix_of_the_count_asked() {
        let y_values = |s: &mut MaxMinDistSampler| {
            s.start_pixel(Point2i::new(3, 5));
            let mut ys: Vec<u32> = (0..8)
                .map(|i| {
                    s.px.set_sample_number(i);
                    s.px.get_2d().y.to_bits()
                })
                .collect();
            ys.sort_unstable();
            ys
        };
        let want: Vec<u32> = {
            let mut v: Vec<u32> = (0..8)
                .map(|i| sample_generator_matrix(&C_MAX_MIN_DIST[2], i, 0).to_bits())
                .collect();
            v.sort_unstable();
            v
        };
        assert_eq!(y_values(&mut MaxMinDistSampler::asked(8, 6, 2)), want);
        assert_ne!(y_values(&mut MaxMinDistSampler::new(8, 2)), want);
        assert_eq!(y_values(&mut MaxMinDistSampler::asked(8, 5, 2)), want);
    }

    #[test]
    fn film_samples_are_stratified_in_both_axes() {
        for log2 in 2..=8u32 {
            let n = 1usize << log2;
            let mut s = MaxMinDistSampler::new(n as i64, 2);
            s.start_pixel(Point2i::new(0, 0));
            let mut xs = vec![false; n];
            let mut ys = vec![false; n];
            for i in 0..n {
                s.px.set_sample_number(i as i64);
                let p = s.px.get_2d();
                xs[(p.x * n as f32) as usize] = true;
                ys[(p.y * n as f32) as usize] = true;
            }
            assert!(xs.iter().all(|&b| b) && ys.iter().all(|&b| b), "spp {n}");
        }
    }
}
