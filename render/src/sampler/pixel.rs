//! The bookkeeping shared by all samplers (pbrt-v3 `core/sampler.cpp`):
//! the current pixel and sample index with requested sample arrays
//! ([`SamplerCore`]), per-pixel precomputed dimensions
//! ([`PixelSampler`]) and global sequences indexed per pixel
//! ([`GlobalSampler`]).

use farm_common::geometry::{Point2i, Vec2};
use farm_common::rng::Rng;

/// pbrt-v3 `Sampler`'s state: pixel, sample index and sample arrays.
#[derive(Clone, Debug)]
pub struct SamplerCore {
    /// Samples taken in each pixel.
    pub spp: i64,
    /// The pixel being sampled.
    pub current_pixel: Point2i,
    /// Index of the current sample within the pixel.
    pub current_pixel_sample_index: i64,
    /// Length of each requested 1D array.
    pub array_1d_sizes: Vec<usize>,
    /// Length of each requested 2D array.
    pub array_2d_sizes: Vec<usize>,
    /// Each 1D array's values for all samples of the pixel.
    pub array_1d: Vec<Vec<f32>>,
    /// Each 2D array's values for all samples of the pixel.
    pub array_2d: Vec<Vec<Vec2>>,
    array_1d_offset: usize,
    array_2d_offset: usize,
}

impl SamplerCore {
    /// A sampler state taking `spp` samples per pixel.
    pub fn new(spp: i64) -> Self {
        SamplerCore {
            spp,
            current_pixel: Point2i::default(),
            current_pixel_sample_index: 0,
            array_1d_sizes: Vec::new(),
            array_2d_sizes: Vec::new(),
            array_1d: Vec::new(),
            array_2d: Vec::new(),
            array_1d_offset: 0,
            array_2d_offset: 0,
        }
    }

    /// Starts the first sample of pixel `p`.
    pub fn start_pixel(&mut self, p: Point2i) {
        self.current_pixel = p;
        self.current_pixel_sample_index = 0;
        self.array_1d_offset = 0;
        self.array_2d_offset = 0;
    }

    /// Moves to the next sample; false once the pixel's samples are used up.
    pub fn start_next_sample(&mut self) -> bool {
        self.array_1d_offset = 0;
        self.array_2d_offset = 0;
        self.current_pixel_sample_index += 1;
        self.current_pixel_sample_index < self.spp
    }

    /// Jumps to sample `n` of the pixel; false if it is past the last.
    pub fn set_sample_number(&mut self, n: i64) -> bool {
        self.array_1d_offset = 0;
        self.array_2d_offset = 0;
        self.current_pixel_sample_index = n;
        n < self.spp
    }

    /// Asks for an array of `n` 1D values in every sample.
    pub fn request_1d_array(&mut self, n: usize) {
        self.array_1d_sizes.push(n);
        self.array_1d.push(vec![0.0; n * self.spp as usize]);
    }

    /// Asks for an array of `n` 2D values in every sample.
    pub fn request_2d_array(&mut self, n: usize) {
        self.array_2d_sizes.push(n);
        self.array_2d.push(vec![Vec2::ZERO; n * self.spp as usize]);
    }

    /// The next requested 1D array of the current sample, if any is left.
    pub fn get_1d_array(&mut self, n: usize) -> Option<&[f32]> {
        let i = self.array_1d_offset;
        if i == self.array_1d.len() {
            return None;
        }
        debug_assert_eq!(n, self.array_1d_sizes[i]);
        self.array_1d_offset += 1;
        let start = self.current_pixel_sample_index as usize * n;
        Some(&self.array_1d[i][start..start + n])
    }

    /// The next requested 2D array of the current sample, if any is left.
    pub fn get_2d_array(&mut self, n: usize) -> Option<&[Vec2]> {
        let i = self.array_2d_offset;
        if i == self.array_2d.len() {
            return None;
        }
        debug_assert_eq!(n, self.array_2d_sizes[i]);
        self.array_2d_offset += 1;
        let start = self.current_pixel_sample_index as usize * n;
        Some(&self.array_2d[i][start..start + n])
    }
}

/// pbrt-v3 `PixelSampler`: a fixed number of dimensions is generated for
/// all of a pixel's samples at once; further dimensions are uniform random.
#[derive(Clone, Debug)]
pub struct PixelSampler {
    /// Pixel, sample index and arrays.
    pub core: SamplerCore,
    /// `samples_1d[dim][sample]`, filled by the sampler at each pixel.
    pub samples_1d: Vec<Vec<f32>>,
    /// `samples_2d[dim][sample]`, filled by the sampler at each pixel.
    pub samples_2d: Vec<Vec<Vec2>>,
    current_1d: usize,
    current_2d: usize,
    /// The generator; default-constructed, reseeded by `clone_with_seed`.
    pub rng: Rng,
}

impl PixelSampler {
    /// Storage for `n_dims` 1D and 2D dimensions of `spp` samples.
    pub fn new(spp: i64, n_dims: usize) -> Self {
        PixelSampler {
            core: SamplerCore::new(spp),
            samples_1d: vec![vec![0.0; spp as usize]; n_dims],
            samples_2d: vec![vec![Vec2::ZERO; spp as usize]; n_dims],
            current_1d: 0,
            current_2d: 0,
            rng: Rng::default(),
        }
    }

    /// Starts pixel `p` once its samples have been filled in.
    pub fn start_pixel(&mut self, p: Point2i) {
        self.current_1d = 0;
        self.current_2d = 0;
        self.core.start_pixel(p);
    }

    /// Moves to the next sample of the pixel.
    pub fn start_next_sample(&mut self) -> bool {
        self.current_1d = 0;
        self.current_2d = 0;
        self.core.start_next_sample()
    }

    /// Jumps to sample `n` of the pixel.
    pub fn set_sample_number(&mut self, n: i64) -> bool {
        self.current_1d = 0;
        self.current_2d = 0;
        self.core.set_sample_number(n)
    }

    /// The next 1D value of the current sample.
    #[inline]
    pub fn get_1d(&mut self) -> f32 {
        debug_assert!(self.core.current_pixel_sample_index < self.core.spp);
        if self.current_1d < self.samples_1d.len() {
            let v = self.samples_1d[self.current_1d][self.core.current_pixel_sample_index as usize];
            self.current_1d += 1;
            v
        } else {
            self.rng.uniform_f32()
        }
    }

    /// The next 2D value of the current sample.
    #[inline]
    pub fn get_2d(&mut self) -> Vec2 {
        debug_assert!(self.core.current_pixel_sample_index < self.core.spp);
        if self.current_2d < self.samples_2d.len() {
            let v = self.samples_2d[self.current_2d][self.core.current_pixel_sample_index as usize];
            self.current_2d += 1;
            v
        } else {
            // pbrt-v3 returns `Point2f(rng.UniformFloat(), rng.UniformFloat())`,
            // whose arguments C++ may evaluate in either order. g++, which
            // builds pbrt-v3 here (../shared/reference/BUILD-PBRT-V3.md),
            // evaluates them right to left: y is drawn first.
            let y = self.rng.uniform_f32();
            Vec2::new(self.rng.uniform_f32(), y)
        }
    }
}

/// A sequence sampled by pixel through a global index (pbrt-v3
/// `GlobalSampler`'s pure virtual methods).
pub trait GlobalSequence: Clone {
    /// The global index of the pixel's `sample_num`-th sample.
    fn index_for_sample(&mut self, pixel: Point2i, sample_num: i64) -> i64;
    /// Dimension `dim` of global sample `index`; dimensions 0 and 1 are
    /// returned as offsets within `pixel`.
    fn sample_dimension(&self, pixel: Point2i, index: i64, dim: usize) -> f32;
    /// Dimensions `dim` and `dim + 1` of global sample `index`.
    #[inline]
    fn sample_2d(&self, pixel: Point2i, index: i64, dim: usize) -> Vec2 {
        Vec2::new(
            self.sample_dimension(pixel, index, dim),
            self.sample_dimension(pixel, index, dim + 1),
        )
    }
}

/// First dimension used for sample arrays (pbrt-v3 `arrayStartDim`).
pub const ARRAY_START_DIM: usize = 5;

/// pbrt-v3 `GlobalSampler`: every value comes from one global sequence.
#[derive(Clone, Debug)]
pub struct GlobalSampler<S> {
    /// Pixel, sample index and arrays.
    pub core: SamplerCore,
    /// The sequence.
    pub seq: S,
    dimension: usize,
    interval_sample_index: i64,
    array_end_dim: usize,
}

impl<S: GlobalSequence> GlobalSampler<S> {
    /// A sampler over `seq` taking `spp` samples per pixel.
    pub fn new(spp: i64, seq: S) -> Self {
        GlobalSampler {
            core: SamplerCore::new(spp),
            seq,
            dimension: 0,
            interval_sample_index: 0,
            array_end_dim: ARRAY_START_DIM,
        }
    }

    /// Starts pixel `p` and fills in its sample arrays.
    pub fn start_pixel(&mut self, p: Point2i) {
        self.core.start_pixel(p);
        self.dimension = 0;
        self.interval_sample_index = self.seq.index_for_sample(p, 0);
        let core = &mut self.core;
        self.array_end_dim = ARRAY_START_DIM + core.array_1d.len() + 2 * core.array_2d.len();
        for (i, arr) in core.array_1d.iter_mut().enumerate() {
            for (j, v) in arr.iter_mut().enumerate() {
                let index = self.seq.index_for_sample(p, j as i64);
                *v = self.seq.sample_dimension(p, index, ARRAY_START_DIM + i);
            }
        }
        let mut dim = ARRAY_START_DIM + core.array_1d.len();
        for arr in core.array_2d.iter_mut() {
            for (j, v) in arr.iter_mut().enumerate() {
                let index = self.seq.index_for_sample(p, j as i64);
                v.x = self.seq.sample_dimension(p, index, dim);
                v.y = self.seq.sample_dimension(p, index, dim + 1);
            }
            dim += 2;
        }
    }

    /// Moves to the next sample of the pixel.
    pub fn start_next_sample(&mut self) -> bool {
        self.dimension = 0;
        let next = self.core.current_pixel_sample_index + 1;
        self.interval_sample_index = self.seq.index_for_sample(self.core.current_pixel, next);
        self.core.start_next_sample()
    }

    /// Jumps to sample `n` of the pixel.
    pub fn set_sample_number(&mut self, n: i64) -> bool {
        self.dimension = 0;
        self.interval_sample_index = self.seq.index_for_sample(self.core.current_pixel, n);
        self.core.set_sample_number(n)
    }

    /// The next 1D value, skipping the dimensions used by arrays.
    #[inline]
    pub fn get_1d(&mut self) -> f32 {
        let d = self.next_dimensions(1);
        self.seq.sample_dimension(self.core.current_pixel, self.interval_sample_index, d)
    }

    /// The next 2D value, skipping the dimensions used by arrays.
    #[inline]
    pub fn get_2d(&mut self) -> Vec2 {
        let d = self.next_dimensions(2);
        self.seq.sample_2d(self.core.current_pixel, self.interval_sample_index, d)
    }

    /// Passes over the next 1D value without computing it: later values
    /// are the ones [`GlobalSampler::get_1d`] would have left.
    #[inline]
    pub fn skip_1d(&mut self) {
        self.next_dimensions(1);
    }

    /// Passes over the next 2D value without computing it.
    #[inline]
    pub fn skip_2d(&mut self) {
        self.next_dimensions(2);
    }

    /// Takes the next `n` (1 or 2) dimensions, jumping past the arrays'
    /// dimensions if they would overlap them; returns the first.
    #[inline]
    fn next_dimensions(&mut self, n: usize) -> usize {
        if self.dimension + n > ARRAY_START_DIM && self.dimension < self.array_end_dim {
            self.dimension = self.array_end_dim;
        }
        self.dimension += n;
        self.dimension - n
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Past its precomputed dimensions, a 2D value is the next two random
    /// numbers with y drawn first (g++'s order for pbrt-v3's
    /// `Point2f(rng.UniformFloat(), rng.UniformFloat())`); a 1D value is
    /// the next one.
    #[test]
    fn past_the_precomputed_dimensions_y_is_drawn_first() {
        let mut s = PixelSampler::new(4, 1);
        s.rng.set_sequence(17);
        let mut rng = s.rng.clone();
        s.start_pixel(Point2i::new(2, 3));
        let _ = (s.get_1d(), s.get_2d());
        let (a, b, c) = (rng.uniform_f32(), rng.uniform_f32(), rng.uniform_f32());
        assert_eq!(s.get_2d(), Vec2::new(b, a));
        assert_eq!(s.get_1d(), c);
    }
}
