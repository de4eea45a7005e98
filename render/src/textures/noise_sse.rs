//! The eight corners of Perlin noise's lattice cell in two SSE vectors
//! (`super::noise`): the same operations as `super::noise_scalar`, lane by
//! lane, so the same bits.

use super::{lerp, weight};
use std::arch::x86_64::*;

/// `mask ? a : b`, lane by lane.
#[inline(always)]
fn select(mask: __m128i, a: __m128, b: __m128) -> __m128 {
    // SAFETY: SSE and SSE2 are part of every x86-64 target, and these
    // intrinsics only compute on registers (no memory is read or written).
    unsafe {
        let m = _mm_castsi128_ps(mask);
        _mm_or_ps(_mm_and_ps(m, a), _mm_andnot_ps(m, b))
    }
}

/// `grad` of four corners with gradient indices `h` at offsets `dx` (one
/// for all four), `dy` and `dz` (one a corner).
#[inline(always)]
fn grads(h: [i32; 4], dx: f32, dy: __m128, dz: __m128) -> __m128 {
    // SAFETY: as in `select`: SSE2 register arithmetic only.
    unsafe {
        let h = _mm_setr_epi32(h[0], h[1], h[2], h[3]);
        // h == 12 || h == 13
        let mid = _mm_cmpeq_epi32(_mm_and_si128(h, _mm_set1_epi32(14)), _mm_set1_epi32(12));
        let u_is_x = _mm_or_si128(_mm_cmplt_epi32(h, _mm_set1_epi32(8)), mid);
        let v_is_y = _mm_or_si128(_mm_cmplt_epi32(h, _mm_set1_epi32(4)), mid);
        let u = select(u_is_x, _mm_set1_ps(dx), dy);
        let v = select(v_is_y, dy, dz);
        // Bit 0 of h negates u, bit 1 negates v: the sign bit flipped, as
        // `-` flips it.
        let neg_u = _mm_castsi128_ps(_mm_slli_epi32::<31>(h));
        let neg_v = _mm_castsi128_ps(_mm_slli_epi32::<31>(_mm_srli_epi32::<1>(h)));
        _mm_add_ps(_mm_xor_ps(u, neg_u), _mm_xor_ps(v, neg_v))
    }
}

/// Noise at offsets `d` into the cell whose corners' gradient indices are
/// `h` (`super::hashes`).
#[inline(always)]
pub(super) fn blend(d: [f32; 3], h: [[i32; 4]; 2]) -> f32 {
    let [dx, dy, dz] = d;
    // SAFETY: as in `select`: SSE2 register arithmetic only.
    unsafe {
        let dy4 = _mm_setr_ps(dy, dy - 1.0, dy, dy - 1.0);
        let dz4 = _mm_setr_ps(dz, dz, dz - 1.0, dz - 1.0);
        // [w000, w010, w001, w011] and [w100, w110, w101, w111].
        let near = grads(h[0], dx, dy4, dz4);
        let far = grads(h[1], dx - 1.0, dy4, dz4);
        let (wx, wy, wz) = (weight(dx), weight(dy), weight(dz));
        // lerp(wx, near, far): [x00, x10, x01, x11].
        let x =
            _mm_add_ps(_mm_mul_ps(_mm_set1_ps(1.0 - wx), near), _mm_mul_ps(_mm_set1_ps(wx), far));
        // lerp(wy, [x00, x01], [x10, x11]): [y0, y1].
        let (lo, hi) = (_mm_shuffle_ps::<0x88>(x, x), _mm_shuffle_ps::<0xdd>(x, x));
        let y = _mm_add_ps(_mm_mul_ps(_mm_set1_ps(1.0 - wy), lo), _mm_mul_ps(_mm_set1_ps(wy), hi));
        let y0 = _mm_cvtss_f32(y);
        let y1 = _mm_cvtss_f32(_mm_shuffle_ps::<0x55>(y, y));
        lerp(wz, y0, y1)
    }
}
