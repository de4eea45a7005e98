//! Low-discrepancy building blocks (pbrt-v3 `core/lowdiscrepancy.{h,cpp}`):
//! radical inverses in the first 1024 prime bases, their digit-permuted
//! variants, generator-matrix sampling with Gray codes, and the scrambled
//! (0,2)-sequence helpers used by the pixel samplers. Arithmetic follows
//! pbrt-v3 operation by operation (in `f32`), so the values are the same.

use farm_common::geometry::Vec2;
use farm_common::rng::{Rng, ONE_MINUS_EPSILON};
use std::ops::BitXor;

/// Number of primes with digit permutations (pbrt-v3 `PrimeTableSize`).
pub const PRIME_TABLE_SIZE: usize = 1000;

/// Number of bases [`radical_inverse`] supports (pbrt-v3's switch goes to 1023).
pub const RADICAL_INVERSE_BASES: usize = 1024;

/// The first 1024 primes (pbrt-v3 `Primes`, extended as its `RadicalInverse`).
pub static PRIMES: [u32; RADICAL_INVERSE_BASES] = first_primes();

/// `PRIME_SUMS[i]` is the sum of the primes before `PRIMES[i]` (pbrt-v3 `PrimeSums`).
pub static PRIME_SUMS: [u32; PRIME_TABLE_SIZE] = prime_sums();

const fn first_primes() -> [u32; RADICAL_INVERSE_BASES] {
    let mut out = [0u32; RADICAL_INVERSE_BASES];
    let (mut n, mut count) = (2u32, 0usize);
    while count < RADICAL_INVERSE_BASES {
        let mut d = 2u32;
        let mut prime = true;
        while d * d <= n {
            if n % d == 0 {
                prime = false;
                break;
            }
            d += 1;
        }
        if prime {
            out[count] = n;
            count += 1;
        }
        n += 1;
    }
    out
}

const fn prime_sums() -> [u32; PRIME_TABLE_SIZE] {
    let primes = first_primes();
    let mut out = [0u32; PRIME_TABLE_SIZE];
    let mut i = 1;
    while i < PRIME_TABLE_SIZE {
        out[i] = out[i - 1] + primes[i - 1];
        i += 1;
    }
    out
}

/// The radical inverse of `a` in base `PRIMES[base_index]` (pbrt-v3
/// `RadicalInverse`). Base 2 is computed by bit reversal in double
/// precision, exactly as pbrt-v3 does (and, like it, is not clamped).
pub fn radical_inverse(base_index: usize, a: u64) -> f32 {
    match base_index {
        0 => (a.reverse_bits() as f64 * f64::from_bits(0x3bf0_0000_0000_0000)) as f32,
        // Halton's second dimension: inlined with a constant base, the
        // compiler divides by multiplying (as pbrt-v3's switch over bases).
        1 => radical_inverse_base(3, a),
        _ => radical_inverse_base(PRIMES[base_index.min(RADICAL_INVERSE_BASES - 1)] as u64, a),
    }
}

/// [`radical_inverse`] in base `base` (not 2).
#[inline(always)]
fn radical_inverse_base(base: u64, a: u64) -> f32 {
    let inv_base = 1.0f32 / base as f32;
    let (mut a, mut reversed, mut inv_base_n) = (a, 0u64, 1.0f32);
    while a != 0 {
        let next = a / base;
        let digit = a - next * base;
        reversed = reversed.wrapping_mul(base).wrapping_add(digit);
        inv_base_n *= inv_base;
        a = next;
    }
    (reversed as f32 * inv_base_n).min(ONE_MINUS_EPSILON)
}

/// The radical inverse of `a` with each digit mapped through `perm`
/// (pbrt-v3 `ScrambledRadicalInverse`); `perm` has `PRIMES[base_index]` entries.
pub fn scrambled_radical_inverse(base_index: usize, a: u64, perm: &[u16]) -> f32 {
    let base = PRIMES[base_index.min(RADICAL_INVERSE_BASES - 1)] as u64;
    scrambled_in_base(base, a, perm)
}

/// [`scrambled_radical_inverse`] in base `base`.
#[inline(always)]
fn scrambled_in_base(base: u64, a: u64, perm: &[u16]) -> f32 {
    let perm = &perm[..base as usize];
    let inv_base = 1.0f32 / base as f32;
    let (mut a, mut reversed, mut inv_base_n) = (a, 0u64, 1.0f32);
    while a != 0 {
        let next = a / base;
        let digit = a - next * base;
        reversed = reversed.wrapping_mul(base).wrapping_add(perm[digit as usize] as u64);
        inv_base_n *= inv_base;
        a = next;
    }
    (inv_base_n * (reversed as f32 + scramble_tail(base, perm[0]))).min(ONE_MINUS_EPSILON)
}

/// The value of the permuted zero digits past the last digit of the index,
/// summed to infinity: `perm[0] / (base − 1)` in pbrt-v3's float operations.
#[inline(always)]
fn scramble_tail(base: u64, perm0: u16) -> f32 {
    let inv_base = 1.0f32 / base as f32;
    inv_base * perm0 as f32 / (1.0 - inv_base)
}

/// Dimensions below this have their base written out as a constant in
/// [`scrambled_radical_inverse_fast`]: Whitted's Halton and Sobol'-free
/// renders with up to about thirty lights stay within them.
pub const CONST_BASE_DIMS: usize = 64;

/// `$body` with `$base` bound to dimension `$dim`'s prime base, written out
/// as a literal for each dimension listed (`$other` otherwise). The body's
/// functions are inlined, so each arm divides by its constant base by
/// multiplying, as pbrt-v3's switch over bases does; the floating-point
/// operations are unchanged, so are the bits.
macro_rules! by_const_base {
    ($dim:expr, |$base:ident| $body:expr, $other:expr; $($d:literal => $b:literal),* $(,)?) => {
        match $dim {
            $($d => {
                let $base: u64 = $b;
                $body
            })*
            _ => $other,
        }
    };
}

/// [`scrambled_radical_inverse`] for dimensions from [`PAIR_DIMS`] on,
/// with a constant base below [`CONST_BASE_DIMS`] (the same bits).
#[inline]
pub fn scrambled_radical_inverse_fast(dim: usize, a: u64, perm: &[u16]) -> f32 {
    by_const_base!(dim, |b| scrambled_in_base(b, a, perm), scrambled_radical_inverse(dim, a, perm);
        18 => 67, 19 => 71, 20 => 73, 21 => 79, 22 => 83, 23 => 89, 24 => 97, 25 => 101,
        26 => 103, 27 => 107, 28 => 109, 29 => 113, 30 => 127, 31 => 131, 32 => 137,
        33 => 139, 34 => 149, 35 => 151, 36 => 157, 37 => 163, 38 => 167, 39 => 173,
        40 => 179, 41 => 181, 42 => 191, 43 => 193, 44 => 197, 45 => 199, 46 => 211,
        47 => 223, 48 => 227, 49 => 229, 50 => 233, 51 => 239, 52 => 241, 53 => 251,
        54 => 257, 55 => 263, 56 => 269, 57 => 271, 58 => 277, 59 => 281, 60 => 283,
        61 => 293, 62 => 307, 63 => 311,
    )
}

/// Dimensions below this (bases 2 … 61) get [`DigitPairs`] tables.
pub const PAIR_DIMS: usize = 18;

/// For each base `b` of the dimensions 2 … [`PAIR_DIMS`] − 1, the permuted
/// values of every two-digit group: `pair[d] = perm[d % b]·b + perm[d / b]`
/// for `d < b²`. The radical inverse then divides by `b²` once per two
/// digits instead of by `b` once per digit; the digits, their order and
/// the floating-point operations are unchanged, so the values are the same
/// bits (Halton spent a sixth of a render in this loop).
#[derive(Debug)]
pub struct DigitPairs {
    offsets: [usize; PAIR_DIMS],
    table: Vec<u32>,
    /// Each dimension's [`scramble_tail`], worked out once rather than
    /// divided out per sample.
    tails: [f32; PAIR_DIMS],
}

impl DigitPairs {
    /// The tables for the permutations `perms` (laid out as
    /// [`compute_radical_inverse_permutations`] returns them).
    pub fn new(perms: &[u16]) -> Self {
        let mut offsets = [0; PAIR_DIMS];
        let mut tails = [0.0; PAIR_DIMS];
        let mut table = Vec::new();
        for dim in 2..PAIR_DIMS {
            let b = PRIMES[dim] as usize;
            let perm = &perms[PRIME_SUMS[dim] as usize..][..b];
            offsets[dim] = table.len();
            tails[dim] = scramble_tail(b as u64, perm[0]);
            table.extend((0..b * b).map(|d| perm[d % b] as u32 * b as u32 + perm[d / b] as u32));
        }
        DigitPairs { offsets, table, tails }
    }

    /// [`scrambled_radical_inverse`] for a dimension `2 <= dim < PAIR_DIMS`.
    #[inline]
    pub fn scrambled_radical_inverse(&self, dim: usize, a: u64, perm: &[u16]) -> f32 {
        let (pairs, tail) = (&self.table[self.offsets[dim]..], self.tails[dim]);
        by_const_base!(dim, |b| pairs_in_base(b, a, pairs, perm, tail), pairs_in_base(PRIMES[dim] as u64, a, pairs, perm, tail);
            2 => 5, 3 => 7, 4 => 11, 5 => 13, 6 => 17, 7 => 19, 8 => 23, 9 => 29, 10 => 31,
            11 => 37, 12 => 41, 13 => 43, 14 => 47, 15 => 53, 16 => 59, 17 => 61,
        )
    }
}

/// [`DigitPairs::scrambled_radical_inverse`] in base `base`, whose pair
/// table is `pairs`.
#[inline(always)]
fn pairs_in_base(base: u64, a: u64, pairs: &[u32], perm: &[u16], tail: f32) -> f32 {
    let base2 = base * base;
    let (pairs, perm) = (&pairs[..base2 as usize], &perm[..base as usize]);
    let inv_base = 1.0f32 / base as f32;
    let (mut a, mut reversed, mut inv_base_n) = (a, 0u64, 1.0f32);
    while a >= base {
        let next = a / base2;
        let d = a - next * base2;
        reversed = reversed.wrapping_mul(base2).wrapping_add(pairs[d as usize] as u64);
        inv_base_n *= inv_base;
        inv_base_n *= inv_base;
        a = next;
    }
    if a != 0 {
        reversed = reversed.wrapping_mul(base).wrapping_add(perm[a as usize] as u64);
        inv_base_n *= inv_base;
    }
    (inv_base_n * (reversed as f32 + tail)).min(ONE_MINUS_EPSILON)
}

/// Random digit permutations for the first [`PRIME_TABLE_SIZE`] prime
/// bases, concatenated; base `i`'s starts at `PRIME_SUMS[i]` (pbrt-v3
/// `ComputeRadicalInversePermutations`).
pub fn compute_radical_inverse_permutations(rng: &mut Rng) -> Vec<u16> {
    radical_inverse_permutations_range(rng, 0, PRIME_TABLE_SIZE)
}

/// The permutations of the prime bases `first..end` only (`end` at most
/// [`PRIME_TABLE_SIZE`]), shuffled with `rng`, which is left where the next
/// base's shuffle starts. If `rng` is where shuffling bases `0..first`
/// leaves a default generator, these are the entries of
/// [`compute_radical_inverse_permutations`] from `PRIME_SUMS[first]` up to
/// base `end`'s.
pub fn radical_inverse_permutations_range(rng: &mut Rng, first: usize, end: usize) -> Vec<u16> {
    let end = end.min(PRIME_TABLE_SIZE);
    let bases = &PRIMES[first.min(end)..end];
    let total: usize = bases.iter().map(|&p| p as usize).sum();
    let mut perms = vec![0u16; total];
    let mut start = 0;
    for &p in bases {
        let p = p as usize;
        let chunk = &mut perms[start..start + p];
        for (j, v) in chunk.iter_mut().enumerate() {
            *v = j as u16;
        }
        shuffle(chunk, p, 1, rng);
        start += p;
    }
    perms
}

/// The index whose first `n_digits` base-`base` digits, reversed, are
/// `inverse` (pbrt-v3 `InverseRadicalInverse`).
pub fn inverse_radical_inverse(base: u64, mut inverse: u64, n_digits: u32) -> u64 {
    let mut index = 0u64;
    for _ in 0..n_digits {
        let digit = inverse % base;
        inverse /= base;
        index = index * base + digit;
    }
    index
}

/// The XOR of `columns[k]` over the set bits `k` of `a`: a generator
/// matrix times a vector over GF(2). It visits the set bits only, lowest
/// first; a test on every bit of a sample index is a branch the CPU
/// mispredicts about half the time. Panics if a set bit has no column.
#[inline(always)]
pub fn xor_columns<T: Copy + Default + BitXor<Output = T>>(columns: &[T], mut a: u64) -> T {
    let mut v = T::default();
    while a != 0 {
        v = v ^ columns[a.trailing_zeros() as usize];
        a &= a - 1;
    }
    v
}

/// The product of generator matrix `c` (columns) and the bits of `a` over GF(2).
#[inline]
pub fn multiply_generator(c: &[u32], a: u32) -> u32 {
    xor_columns(c, u64::from(a))
}

/// `2^-32` as pbrt-v3 writes it.
const INV_2_32: f32 = f32::from_bits(0x2f80_0000);

/// A sample from generator matrix `c`, XOR-scrambled (pbrt-v3 `SampleGeneratorMatrix`).
#[inline]
pub fn sample_generator_matrix(c: &[u32], a: u32, scramble: u32) -> f32 {
    (multiply_generator(c, a) ^ scramble) as f32 * INV_2_32
}

/// The binary reflected Gray code of `v`.
#[inline]
pub fn gray_code(v: u32) -> u32 {
    (v >> 1) ^ v
}

/// `n` points of matrix `c` in Gray-code order (pbrt-v3 `GrayCodeSample`, 1D).
pub fn gray_code_sample_1d(c: &[u32], n: usize, scramble: u32, p: &mut [f32]) {
    let mut v = scramble;
    for (i, out) in p.iter_mut().enumerate().take(n) {
        *out = v as f32 * INV_2_32;
        v ^= c[(i as u32 + 1).trailing_zeros() as usize];
    }
}

/// `n` points of the matrix pair in Gray-code order (pbrt-v3 `GrayCodeSample`, 2D).
pub fn gray_code_sample_2d(c0: &[u32], c1: &[u32], n: usize, scramble: [u32; 2], p: &mut [Vec2]) {
    let mut v = scramble;
    for (i, out) in p.iter_mut().enumerate().take(n) {
        *out = Vec2::new(v[0] as f32 * INV_2_32, v[1] as f32 * INV_2_32);
        let tz = (i as u32 + 1).trailing_zeros() as usize;
        v[0] ^= c0[tz];
        v[1] ^= c1[tz];
    }
}

/// Shuffles `count` blocks of `n_dims` consecutive values (pbrt-v3 `Shuffle`).
pub fn shuffle<T>(samp: &mut [T], count: usize, n_dims: usize, rng: &mut Rng) {
    if n_dims == 1 {
        for i in 0..count {
            let other = i + rng.uniform_u32_below((count - i) as u32) as usize;
            samp.swap(i, other);
        }
        return;
    }
    for i in 0..count {
        let other = i + rng.uniform_u32_below((count - i) as u32) as usize;
        for j in 0..n_dims {
            samp.swap(n_dims * i + j, n_dims * other + j);
        }
    }
}

/// Shuffles each pixel sample's `n_per_sample` values among themselves,
/// then the pixel samples' blocks (pbrt-v3's two steps in `VanDerCorput`
/// and `Sobol2D`). A block of one value stays as it is, at the cost of one
/// draw.
fn shuffle_within_and_across<T>(
    samples: &mut [T],
    n_per_sample: usize,
    n_pixel_samples: usize,
    rng: &mut Rng,
) {
    if n_per_sample == 1 {
        for _ in 0..n_pixel_samples {
            rng.uniform_u32();
        }
    } else {
        for i in 0..n_pixel_samples {
            shuffle(&mut samples[i * n_per_sample..], n_per_sample, 1, rng);
        }
    }
    shuffle(samples, n_pixel_samples, n_per_sample, rng);
}

/// The van der Corput generator matrix (identity, bit-reversed).
pub const C_VAN_DER_CORPUT: [u32; 32] = {
    let mut c = [0u32; 32];
    let mut i = 0;
    while i < 32 {
        c[i] = 1 << (31 - i);
        i += 1;
    }
    c
};

/// The second Sobol' dimension's generator matrix.
pub const C_SOBOL_1: [u32; 32] = {
    let mut c = [0u32; 32];
    c[0] = 1 << 31;
    let mut i = 1;
    while i < 32 {
        c[i] = c[i - 1] ^ (c[i - 1] >> 1);
        i += 1;
    }
    c
};

/// Scrambled van der Corput samples for `n_pixel_samples` pixel samples of
/// `n_per_sample` values each, shuffled within and across pixel samples
/// (pbrt-v3 `VanDerCorput`).
pub fn van_der_corput(
    n_per_sample: usize,
    n_pixel_samples: usize,
    samples: &mut [f32],
    rng: &mut Rng,
) {
    let scramble = rng.uniform_u32();
    gray_code_sample_1d(&C_VAN_DER_CORPUT, n_per_sample * n_pixel_samples, scramble, samples);
    shuffle_within_and_across(samples, n_per_sample, n_pixel_samples, rng);
}

/// Scrambled (0,2)-sequence samples, shuffled like [`van_der_corput`]
/// (pbrt-v3 `Sobol2D`).
pub fn sobol_2d(n_per_sample: usize, n_pixel_samples: usize, samples: &mut [Vec2], rng: &mut Rng) {
    let scramble = [rng.uniform_u32(), rng.uniform_u32()];
    let n = n_per_sample * n_pixel_samples;
    gray_code_sample_2d(&C_VAN_DER_CORPUT, &C_SOBOL_1, n, scramble, samples);
    shuffle_within_and_across(samples, n_per_sample, n_pixel_samples, rng);
}

#[cfg(test)]
#[path = "lowdiscrepancy_tests.rs"]
mod tests;
