//! Tests of the low-discrepancy building blocks (`lowdiscrepancy.rs`).

use super::*;

#[test]
fn two_digit_steps_give_the_same_bits() {
    let perms = compute_radical_inverse_permutations(&mut Rng::default());
    let pairs = DigitPairs::new(&perms);
    let mut rng = Rng::new(11);
    for dim in 2..PAIR_DIMS {
        let perm = &perms[PRIME_SUMS[dim] as usize..];
        let b = PRIMES[dim] as u64;
        let edges = [0, 1, b - 1, b, b + 1, b * b - 1, b * b, b * b * b, u32::MAX as u64];
        let random = (0..2000).map(|_| rng.uniform_u32() as u64 >> (rng.uniform_u32() % 32));
        for a in edges.into_iter().chain(random).chain([1 << 40, u64::MAX >> 1]) {
            let want = reference(dim, a, Some(perm));
            assert_eq!(scrambled_radical_inverse(dim, a, perm).to_bits(), want.to_bits());
            let got = pairs.scrambled_radical_inverse(dim, a, perm);
            assert_eq!(got.to_bits(), want.to_bits(), "dim {dim}, a {a}");
        }
    }
}

/// pbrt-v3's `ScrambledRadicalInverse`, written out with the base
/// read from the table at run time; `perm: None` for the plain inverse.
fn reference(dim: usize, mut a: u64, perm: Option<&[u16]>) -> f32 {
    let base = PRIMES[dim] as u64;
    let p = |d: u64| perm.map_or(d, |p| p[d as usize] as u64);
    let inv_base = 1.0f32 / base as f32;
    let (mut reversed, mut inv_base_n) = (0u64, 1.0f32);
    while a != 0 {
        let next = a / base;
        reversed = reversed.wrapping_mul(base).wrapping_add(p(a - next * base));
        inv_base_n *= inv_base;
        a = next;
    }
    let v = match perm {
        Some(perm) => inv_base_n * (reversed as f32 + inv_base * perm[0] as f32 / (1.0 - inv_base)),
        None => reversed as f32 * inv_base_n,
    };
    v.min(ONE_MINUS_EPSILON)
}

#[test]
fn constant_bases_give_the_same_bits() {
    let perms = compute_radical_inverse_permutations(&mut Rng::default());
    let mut rng = Rng::new(5);
    for dim in 1..CONST_BASE_DIMS + 8 {
        let perm = &perms[PRIME_SUMS[dim] as usize..];
        let b = PRIMES[dim] as u64;
        let edges = [0, 1, b - 1, b, b + 1, b * b - 1, b * b, b * b * b, u32::MAX as u64];
        let random = (0..500).map(|_| rng.uniform_u32() as u64 >> (rng.uniform_u32() % 32));
        for a in edges.into_iter().chain(random).chain([1 << 40, (1 << 62) + 12345]) {
            if dim == 1 {
                let (got, want) = (radical_inverse(1, a), reference(1, a, None));
                assert_eq!(got.to_bits(), want.to_bits(), "base 3, a {a}");
            } else if dim >= PAIR_DIMS {
                let got = scrambled_radical_inverse_fast(dim, a, perm);
                let want = reference(dim, a, Some(perm));
                assert_eq!(got.to_bits(), want.to_bits(), "dim {dim}, a {a}");
            }
        }
    }
}

#[test]
fn prime_tables_match_pbrt() {
    assert_eq!(&PRIMES[..6], &[2, 3, 5, 7, 11, 13]);
    assert_eq!(PRIMES[999], 7919);
    assert_eq!(PRIMES[1023], 8161);
    assert_eq!(&PRIME_SUMS[..6], &[0, 2, 5, 10, 17, 28]);
    assert_eq!(PRIME_SUMS[999], 3_674_994);
}

#[test]
fn radical_inverse_matches_definition() {
    assert_eq!(radical_inverse(0, 1), 0.5);
    assert_eq!(radical_inverse(0, 6), 0.375);
    assert_eq!(radical_inverse(1, 1), 1.0f32 / 3.0);
    // 7 = 21 in base 3 -> 0.12 = 1/3 + 2/9 = 5/9, computed as pbrt-v3 does.
    let expected = 5.0f32 * (1.0 / 3.0f32 * (1.0 / 3.0f32));
    assert_eq!(radical_inverse(1, 7), expected);
    for i in 0..1000u64 {
        let v = radical_inverse(2, i);
        let mut reference = 0.0f64;
        let (mut a, mut f) = (i, 1.0f64);
        while a != 0 {
            f /= 5.0;
            reference += (a % 5) as f64 * f;
            a /= 5;
        }
        assert!((v as f64 - reference).abs() < 1e-6, "{i}: {v} vs {reference}");
    }
}

#[test]
fn identity_permutation_scramble_equals_plain_radical_inverse() {
    let perm: Vec<u16> = (0..7).collect();
    for i in 0..500u64 {
        assert_eq!(scrambled_radical_inverse(3, i, &perm), radical_inverse(3, i));
    }
}

#[test]
fn permutation_prefixes_match_the_full_table() {
    let full = compute_radical_inverse_permutations(&mut Rng::default());
    for bases in [1, 2, 18, 64] {
        let prefix = radical_inverse_permutations_range(&mut Rng::default(), 0, bases);
        let end = PRIMES[..bases].iter().map(|&p| p as usize).sum::<usize>();
        assert_eq!(prefix, full[..end], "{bases} bases");
    }
}

#[test]
fn permutations_are_permutations() {
    let perms = compute_radical_inverse_permutations(&mut Rng::default());
    assert_eq!(perms.len(), 3_674_994 + 7919);
    for &i in &[0usize, 1, 17, 999] {
        let p = PRIMES[i] as usize;
        let s = PRIME_SUMS[i] as usize;
        let mut seen = vec![false; p];
        for &d in &perms[s..s + p] {
            seen[d as usize] = true;
        }
        assert!(seen.iter().all(|&x| x));
    }
}

#[test]
fn inverse_radical_inverse_round_trips() {
    for i in 0..243u64 {
        let digits = radical_inverse(1, i) * 243.0;
        let back = inverse_radical_inverse(3, digits.round() as u64, 5);
        assert_eq!(back, i);
    }
}

#[test]
fn gray_code_samples_cover_strata() {
    let mut p = [0.0f32; 16];
    gray_code_sample_1d(&C_VAN_DER_CORPUT, 16, 0, &mut p);
    let mut strata: Vec<u32> = p.iter().map(|v| (v * 16.0) as u32).collect();
    strata.sort_unstable();
    assert_eq!(strata, (0..16).collect::<Vec<_>>());
    assert_eq!(gray_code(5), 7);
    assert_eq!(multiply_generator(&C_SOBOL_1, 3), C_SOBOL_1[0] ^ C_SOBOL_1[1]);
}

#[test]
fn a_generator_matrix_times_every_bit() {
    let mut rng = Rng::new(3);
    for a in (0..200).map(|_| rng.uniform_u32()).chain([0, 1, u32::MAX, 1 << 31]) {
        let want = (0..32).filter(|k| a >> k & 1 != 0).fold(0, |v, k| v ^ C_SOBOL_1[k]);
        assert_eq!(multiply_generator(&C_SOBOL_1, a), want, "{a:#x}");
    }
}
