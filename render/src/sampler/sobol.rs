//! The Sobol' sampler (pbrt-v3 `samplers/sobol.cpp`):
//!
//! ```text
//! Sampler "sobol" "integer pixelsamples" [16]
//! ```
//!
//! A global sampler: the first two Sobol' dimensions, scaled to the
//! power-of-two square covering the sample bounds, pick the pixel; the
//! sample index of a pixel's n-th sample is found by inverting those two
//! generator matrices (pbrt-v3 `SobolIntervalToIndex`).
//!
//! Only the first [`NUM_SOBOL_DIMENSIONS`] of pbrt-v3's 1024 generator
//! matrices are stored (`sobolmatrices.rs`). Beyond them (pbrt-v3 would
//! use its further matrices, and aborts past 1024) dimension `d` reuses
//! stored dimension `2 + (d - 2) % (NUM_SOBOL_DIMENSIONS - 2)`, XOR-scrambled
//! by a fixed hash of `d`: deterministic and still stratified per
//! dimension, but not pbrt-v3's values.

use super::lowdiscrepancy::xor_columns;
use super::pixel::{GlobalSampler, GlobalSequence};
use super::sobolmatrices::{NUM_SOBOL_DIMENSIONS, SOBOL_MATRICES_32, SOBOL_MATRIX_SIZE};
use farm_common::geometry::{Bounds2i, Point2i};
use farm_common::rng::ONE_MINUS_EPSILON;

/// The Sobol' sampler.
pub type SobolSampler = GlobalSampler<Sobol>;

/// Columns of the second Sobol' dimension at 52 bits (pbrt-v3 `SobolMatrices64`).
fn sobol_1_columns_52() -> [u64; SOBOL_MATRIX_SIZE] {
    let mut c = [0u64; SOBOL_MATRIX_SIZE];
    c[0] = 1 << 51;
    for i in 1..SOBOL_MATRIX_SIZE {
        c[i] = c[i - 1] ^ (c[i - 1] >> 1);
    }
    c
}

/// Forward and inverse pixel matrices of one resolution.
pub type VdcMatrices = ([u64; SOBOL_MATRIX_SIZE], [u64; SOBOL_MATRIX_SIZE]);

/// pbrt-v3's `VdCSobolMatrices[m-1]` and `VdCSobolMatricesInv[m-1]`:
/// how index bits `2m + c` move the pixel `(x << m) | y`, and which low
/// `2m` index bits give pixel bit `c`.
pub fn vdc_sobol_matrices(m: u32) -> VdcMatrices {
    let m = m as usize;
    let c1 = sobol_1_columns_52();
    let mut fwd = [0u64; SOBOL_MATRIX_SIZE];
    for c in 0..SOBOL_MATRIX_SIZE.saturating_sub(2 * m) {
        fwd[c] = c1[2 * m + c] >> (52 - m);
    }
    // Pixel bits produced by each of the low 2m index bits, paired with the
    // index bits combined; column-reduce until each pixel bit stands alone.
    let mut cols: Vec<(u64, u64)> = (0..2 * m)
        .map(|j| {
            let x = if j < m { 1u64 << (m - 1 - j) } else { 0 };
            ((x << m) | (c1[j] >> (52 - m)), 1u64 << j)
        })
        .collect();
    let mut inv = [0u64; SOBOL_MATRIX_SIZE];
    for bit in 0..2 * m {
        if let Some(k) = (bit..2 * m).find(|&k| cols[k].0 >> bit & 1 != 0) {
            cols.swap(bit, k);
            let pivot = cols[bit];
            for (j, col) in cols.iter_mut().enumerate() {
                if j != bit && col.0 >> bit & 1 != 0 {
                    col.0 ^= pivot.0;
                    col.1 ^= pivot.1;
                }
            }
        }
    }
    for (bit, col) in cols.iter().enumerate() {
        inv[bit] = col.1;
    }
    (fwd, inv)
}

/// Dimension `dim` of Sobol' point `a` (pbrt-v3 `SobolSampleFloat`), with
/// the documented fallback past the stored dimensions.
#[inline]
pub fn sobol_sample(mut a: i64, dim: usize) -> f32 {
    let (dim, mut v) = if dim < NUM_SOBOL_DIMENSIONS {
        (dim, 0u32)
    } else {
        let mut h = (dim as u64).wrapping_mul(0x9e37_79b9_7f4a_7c15);
        h ^= h >> 29;
        (2 + (dim - 2) % (NUM_SOBOL_DIMENSIONS - 2), (h >> 32) as u32)
    };
    let mut i = dim * SOBOL_MATRIX_SIZE;
    if (a as u64) < 1 << SOBOL_MATRIX_SIZE {
        v ^= xor_columns(&SOBOL_MATRICES_32[i..i + SOBOL_MATRIX_SIZE], a as u64);
    } else {
        // Indices of 2^52 and up (and negative ones) run on into the next
        // dimensions' columns, as in pbrt-v3's loop, and stop at the
        // table's end, where pbrt-v3 would read past it.
        while a != 0 && i < SOBOL_MATRICES_32.len() {
            if a & 1 != 0 {
                v ^= SOBOL_MATRICES_32[i];
            }
            a >>= 1;
            i += 1;
        }
    }
    v as f32 * f32::from_bits(0x2f80_0000)
}

/// The Sobol' sequence over the sample bounds.
#[derive(Clone, Debug)]
pub struct Sobol {
    sample_bounds: Bounds2i,
    resolution: i32,
    log2_resolution: u32,
    /// pbrt-v3's `VdCSobolMatrices` and `VdCSobolMatricesInv` for this resolution.
    vdc: Box<VdcMatrices>,
}

impl Sobol {
    /// The sequence for images whose samples cover `sample_bounds`.
    pub fn new(sample_bounds: Bounds2i) -> Self {
        let diag = sample_bounds.width().max(sample_bounds.height()).max(1);
        let resolution = (diag as u32).next_power_of_two().min(1 << 26) as i32;
        let log2_resolution = resolution.trailing_zeros();
        let vdc = Box::new(vdc_sobol_matrices(log2_resolution));
        Sobol { sample_bounds, resolution, log2_resolution, vdc }
    }

    /// pbrt-v3 `SobolIntervalToIndex`.
    fn interval_to_index(&self, frame: u64, p: Point2i) -> u64 {
        let m = self.log2_resolution;
        if m == 0 {
            return 0;
        }
        // Bits from 52 up are dropped, as this function's bit loops did
        // (pbrt-v3's read past the 52 columns).
        const COLUMNS: u64 = (1 << SOBOL_MATRIX_SIZE) - 1;
        let index = frame << (2 * m);
        let delta = xor_columns(&self.vdc.0, frame & COLUMNS);
        let b = (((p.x as u32 as u64) << m) | p.y as u32 as u64) ^ delta;
        index ^ xor_columns(&self.vdc.1, b & COLUMNS)
    }
}

impl GlobalSequence for Sobol {
    fn index_for_sample(&mut self, pixel: Point2i, sample_num: i64) -> i64 {
        let p =
            Point2i::new(pixel.x - self.sample_bounds.min.x, pixel.y - self.sample_bounds.min.y);
        self.interval_to_index(sample_num as u64, p) as i64
    }

    fn sample_dimension(&self, pixel: Point2i, index: i64, dim: usize) -> f32 {
        let mut s = sobol_sample(index, dim);
        if dim < 2 {
            let (min, cur) = if dim == 0 {
                (self.sample_bounds.min.x, pixel.x)
            } else {
                (self.sample_bounds.min.y, pixel.y)
            };
            s = s * self.resolution as f32 + min as f32;
            s = (s - cur as f32).clamp(0.0, ONE_MINUS_EPSILON);
        }
        s
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use farm_common::math;

    #[test]
    fn vdc_matrices_match_pbrt_tables() {
        let (f, i) = vdc_sobol_matrices(1);
        assert_eq!(&i[..2], &[0x2, 0x3]);
        assert_eq!(f[0], 1);
        let (_, i) = vdc_sobol_matrices(4);
        assert_eq!(&i[..8], &[0xf0, 0x50, 0x30, 0x10, 0x88, 0x44, 0x22, 0x11]);
        let (f, _) = vdc_sobol_matrices(9);
        assert_eq!(&f[..4], &[0x140, 0x1e0, 0x110, 0x198]);
        let (f, _) = vdc_sobol_matrices(16);
        assert_eq!(&f[..4], &[0x8000, 0xc000, 0xa000, 0xf000]);
        let (f, i) = vdc_sobol_matrices(25);
        assert_eq!(&f[..3], &[0x1400140, 0x1e001e0, 0]);
        assert_eq!(&i[..3], &[0x2020202000000, 0x3fc03fc000000, 0x3560356000000]);
        let (_, i) = vdc_sobol_matrices(26);
        assert_eq!(i[0], 0xc0c0c0c000000);
        assert_eq!(i[51], 0x100000001);
    }

    #[test]
    fn interval_index_lands_in_its_pixel() {
        let b = Bounds2i::new(Point2i::new(-3, 2), Point2i::new(20, 11));
        let mut s = Sobol::new(b);
        assert_eq!(s.resolution, 32);
        for p in b.iter() {
            for n in 0..8 {
                let idx = s.index_for_sample(p, n);
                let x = sobol_sample(idx, 0) * 32.0 + b.min.x as f32;
                let y = sobol_sample(idx, 1) * 32.0 + b.min.y as f32;
                assert_eq!((math::floor(x) as i32, math::floor(y) as i32), (p.x, p.y), "{p:?} {n}");
            }
        }
    }

    /// pbrt-v3's `SobolSample` loop, a test of every bit of the index.
    fn sample_bit_by_bit(mut a: i64, dim: usize) -> u32 {
        let (mut v, mut i) = (0u32, dim * SOBOL_MATRIX_SIZE);
        while a != 0 && i < SOBOL_MATRICES_32.len() {
            if a & 1 != 0 {
                v ^= SOBOL_MATRICES_32[i];
            }
            a >>= 1;
            i += 1;
        }
        v
    }

    #[test]
    fn set_bits_give_the_bit_by_bit_values() {
        let mut rng = farm_common::rng::Rng::new(7);
        let mut indices = vec![0i64, 1, (1 << 52) - 1, 1 << 52, i64::MAX, -1, i64::MIN];
        for bits in [8, 24, 40, 52, 53, 63] {
            for _ in 0..50 {
                let a = (u64::from(rng.uniform_u32()) << 32 | u64::from(rng.uniform_u32()))
                    >> (64 - bits);
                indices.push(a as i64);
            }
        }
        for &a in &indices {
            for dim in [0, 1, 2, 17, NUM_SOBOL_DIMENSIONS - 2, NUM_SOBOL_DIMENSIONS - 1] {
                let want = sample_bit_by_bit(a, dim) as f32 * f32::from_bits(0x2f80_0000);
                assert_eq!(sobol_sample(a, dim).to_bits(), want.to_bits(), "{a:#x} {dim}");
            }
        }
        // The index of a pixel's sample, against the same loops written out.
        let s = Sobol::new(Bounds2i::new(Point2i::new(0, 0), Point2i::new(700, 300)));
        for (k, &a) in indices.iter().enumerate() {
            let (frame, p) = (a as u64, Point2i::new(k as i32 % 700, k as i32 % 300));
            let m = s.log2_resolution;
            let (mut delta, mut f) = (0u64, frame);
            for c in 0..SOBOL_MATRIX_SIZE {
                delta ^= if f & 1 != 0 { s.vdc.0[c] } else { 0 };
                f >>= 1;
            }
            let (mut index, mut b) = (frame << (2 * m), ((p.x as u64) << m | p.y as u64) ^ delta);
            for c in 0..SOBOL_MATRIX_SIZE {
                index ^= if b & 1 != 0 { s.vdc.1[c] } else { 0 };
                b >>= 1;
            }
            assert_eq!(s.interval_to_index(frame, p), index, "{frame:#x}");
        }
    }
}
