//! Three [`EFloat`]s at once, one an axis: the sphere's coefficients are
//! three dot products of intervals, whose nine products (four bound
//! products, a minimum and a maximum each) were most of its interval
//! arithmetic. Stored lane by lane, a product of two triples is one pass
//! of SSE arithmetic on x86-64.
//!
//! Each lane computes what [`EFloat`]'s own operation does, in the same
//! order: the same values and the same bounds, bit for bit. The one
//! exception is a NaN bound (from a NaN value, or an infinite bound times
//! zero: a coordinate or its square past `f32::MAX`): it is NaN both ways,
//! but its payload may differ, which no comparison sees, since the steps
//! to the next float keep NaN as NaN.

use super::efloat::EFloat;
use farm_common::geometry::Vec3;

/// Three [`EFloat`]s, lane by lane (the fourth lane is padding). Aligned
/// so that no vector of lanes straddles a cache line: a store split across
/// two lines cannot be forwarded to the loads of single lanes that
/// follow it. Unaligned, two or three runs in four of the sphere bench
/// were 13–42% slower, depending on where the stack began.
#[derive(Clone, Copy, Debug)]
#[repr(C, align(16))]
pub(crate) struct EFloat3 {
    v: [f32; 4],
    low: [f32; 4],
    high: [f32; 4],
}

impl EFloat3 {
    /// `v` with absolute errors `err`, as [`EFloat::new`] makes each.
    #[inline(always)]
    pub(crate) fn new(v: Vec3, err: Vec3) -> Self {
        let (v, err) = (v.extend(0.0).to_array(), err.extend(0.0).to_array());
        imp::new(v, err)
    }

    /// Lane-by-lane products, as [`EFloat`]'s `*`.
    #[inline(always)]
    pub(crate) fn mul(self, o: EFloat3) -> EFloat3 {
        imp::mul(&self, &o)
    }

    /// `x + y + z`, added in that order.
    #[inline(always)]
    pub(crate) fn sum(self) -> EFloat {
        self.lane(0) + self.lane(1) + self.lane(2)
    }

    /// `x + y` (the z lane left out, as the cylinder's coefficients do).
    #[inline(always)]
    pub(crate) fn sum_xy(self) -> EFloat {
        self.lane(0) + self.lane(1)
    }

    /// One lane.
    #[inline(always)]
    fn lane(&self, l: usize) -> EFloat {
        EFloat::from_parts(self.v[l], self.low[l], self.high[l])
    }
}

/// The operations lane by lane: [`EFloat`]'s own, one lane at a time.
#[cfg_attr(target_arch = "x86_64", allow(dead_code))]
mod portable {
    use super::{EFloat, EFloat3};

    fn from_lanes(lanes: [EFloat; 4]) -> EFloat3 {
        EFloat3 {
            v: lanes.map(|e| e.v),
            low: lanes.map(EFloat::lower_bound),
            high: lanes.map(EFloat::upper_bound),
        }
    }

    #[inline(always)]
    pub(super) fn new(v: [f32; 4], err: [f32; 4]) -> EFloat3 {
        from_lanes(std::array::from_fn(|l| EFloat::new(v[l], err[l])))
    }

    #[inline(always)]
    pub(super) fn mul(a: &EFloat3, b: &EFloat3) -> EFloat3 {
        from_lanes(std::array::from_fn(|l| a.lane(l) * b.lane(l)))
    }
}

/// The same in SSE, which every x86-64 CPU has. `f32::min` and `max`
/// return the other operand where one is NaN, which `minps` and `maxps` do
/// only for the first; the masks below make up the difference. Where both
/// operands are zeros of different signs either may come out, as from
/// `f32::min`; the step to the next float treats both zeros alike.
#[cfg(target_arch = "x86_64")]
mod imp {
    use super::EFloat3;
    use std::arch::x86_64::*;

    // SAFETY (every function): SSE and SSE2 are part of every x86-64
    // target, so these intrinsics only compute; loads and stores are of
    // `[f32; 4]` arrays, unaligned.

    #[inline(always)]
    unsafe fn load(a: &[f32; 4]) -> __m128 {
        _mm_loadu_ps(a.as_ptr())
    }

    #[inline(always)]
    unsafe fn store(v: __m128) -> [f32; 4] {
        let mut out = [0.0; 4];
        _mm_storeu_ps(out.as_mut_ptr(), v);
        out
    }

    /// `mask ? a : b`, lane by lane.
    #[inline(always)]
    unsafe fn select(mask: __m128, a: __m128, b: __m128) -> __m128 {
        _mm_or_ps(_mm_and_ps(mask, a), _mm_andnot_ps(mask, b))
    }

    /// `f32::min`: the other operand where one is NaN.
    #[inline(always)]
    unsafe fn min(a: __m128, b: __m128) -> __m128 {
        select(_mm_cmpunord_ps(b, b), a, _mm_min_ps(a, b))
    }

    /// `f32::max`: the other operand where one is NaN.
    #[inline(always)]
    unsafe fn max(a: __m128, b: __m128) -> __m128 {
        select(_mm_cmpunord_ps(b, b), a, _mm_max_ps(a, b))
    }

    /// `next_float_up` lane by lane: +∞ and NaN stay, −0 steps as +0 does.
    #[inline(always)]
    unsafe fn next_up(v: __m128) -> __m128 {
        let bits = _mm_castps_si128(_mm_add_ps(v, _mm_setzero_ps()));
        // +1 for a positive value, −1 for a negative one.
        let sign2 = _mm_slli_epi32::<1>(_mm_srli_epi32::<31>(bits));
        let step = _mm_sub_epi32(_mm_set1_epi32(1), sign2);
        let up = _mm_castsi128_ps(_mm_add_epi32(bits, step));
        select(_mm_cmpnlt_ps(v, _mm_set1_ps(f32::INFINITY)), v, up)
    }

    /// `next_float_down` lane by lane: −∞ and NaN stay, +0 steps as −0 does.
    #[inline(always)]
    unsafe fn next_down(v: __m128) -> __m128 {
        let sign = _mm_set1_ps(-0.0);
        let neg = _mm_xor_ps(_mm_add_ps(_mm_xor_ps(v, sign), _mm_setzero_ps()), sign);
        let bits = _mm_castps_si128(neg);
        // −1 for a positive value, +1 for a negative one.
        let sign2 = _mm_slli_epi32::<1>(_mm_srli_epi32::<31>(bits));
        let step = _mm_sub_epi32(sign2, _mm_set1_epi32(1));
        let down = _mm_castsi128_ps(_mm_add_epi32(bits, step));
        select(_mm_cmpngt_ps(v, _mm_set1_ps(f32::NEG_INFINITY)), v, down)
    }

    #[inline(always)]
    pub(super) fn new(v: [f32; 4], err: [f32; 4]) -> EFloat3 {
        // SAFETY: see above.
        unsafe {
            let (vv, e) = (load(&v), load(&err));
            let exact = _mm_cmpeq_ps(e, _mm_setzero_ps());
            let low = select(exact, vv, next_down(_mm_sub_ps(vv, e)));
            let high = select(exact, vv, next_up(_mm_add_ps(vv, e)));
            EFloat3 { v, low: store(low), high: store(high) }
        }
    }

    #[inline(always)]
    pub(super) fn mul(a: &EFloat3, b: &EFloat3) -> EFloat3 {
        // SAFETY: see above.
        unsafe {
            let (al, ah, bl, bh) = (load(&a.low), load(&a.high), load(&b.low), load(&b.high));
            let p =
                [_mm_mul_ps(al, bl), _mm_mul_ps(ah, bl), _mm_mul_ps(al, bh), _mm_mul_ps(ah, bh)];
            let low = next_down(min(min(p[0], p[1]), min(p[2], p[3])));
            let high = next_up(max(max(p[0], p[1]), max(p[2], p[3])));
            EFloat3 {
                v: store(_mm_mul_ps(load(&a.v), load(&b.v))),
                low: store(low),
                high: store(high),
            }
        }
    }
}

#[cfg(not(target_arch = "x86_64"))]
use portable as imp;

#[cfg(test)]
mod tests {
    use super::*;
    use farm_common::rng::Rng;

    /// Bits of an [`EFloat`], with every NaN alike.
    fn bits(x: EFloat) -> [u32; 3] {
        [x.v, x.lower_bound(), x.upper_bound()]
            .map(|f| if f.is_nan() { u32::MAX } else { f.to_bits() })
    }

    fn value(rng: &mut Rng) -> f32 {
        // NaNs of the largest payloads, which a bare bit step wraps round.
        const ODD: [f32; 12] = [
            f32::from_bits(0x7fff_ffff),
            f32::from_bits(0xffff_ffff),
            0.0,
            -0.0,
            1e-45,
            -3e-39,
            f32::INFINITY,
            f32::NEG_INFINITY,
            f32::NAN,
            1e38,
            -3e38,
            f32::MAX,
        ];
        match rng.uniform_u32() % 8 {
            0 => ODD[rng.uniform_u32_below(ODD.len() as u32) as usize],
            _ => (rng.uniform_f32() - 0.5) * 10f32.powi((rng.uniform_u32() % 13) as i32 - 6),
        }
    }

    fn vector(rng: &mut Rng) -> Vec3 {
        Vec3::new(value(rng), value(rng), value(rng))
    }

    /// Products and sums of triples give what [`EFloat`]'s own operations
    /// give one at a time, bit for bit (NaN bounds as NaN), over values of
    /// every scale and the awkward ones: signed zeros, subnormals,
    /// infinities, NaN, values that overflow, and zero error bounds. Both
    /// the SSE path (on x86-64) and the portable one are checked.
    #[test]
    fn three_lanes_match_one_at_a_time() {
        let rng = &mut Rng::new(11);
        for i in 0..100_000 {
            let (va, vb) = (vector(rng), vector(rng));
            let (ea, eb) = (vector(rng).abs(), vector(rng).abs());
            // Exact zero errors often, as an untransformed ray has, and
            // negative zeros now and then.
            let ea = match i % 7 {
                0 | 3 => Vec3::ZERO,
                5 => Vec3::new(-0.0, 0.0, -0.0),
                _ => ea,
            };
            let one = |v: Vec3, e: Vec3, l: usize| EFloat::new(v[l], e[l]);
            let scalar: Vec<EFloat> = (0..3).map(|l| one(va, ea, l) * one(vb, eb, l)).collect();
            let (pa, pb) = (va.extend(0.0).to_array(), vb.extend(0.0).to_array());
            let (qa, qb) = (ea.extend(0.0).to_array(), eb.extend(0.0).to_array());
            let both = [
                EFloat3::new(va, ea).mul(EFloat3::new(vb, eb)),
                portable::mul(&portable::new(pa, qa), &portable::new(pb, qb)),
            ];
            for lanes in both {
                for (l, s) in scalar.iter().enumerate() {
                    assert_eq!(bits(lanes.lane(l)), bits(*s), "case {i}, lane {l}");
                }
                assert_eq!(bits(lanes.sum()), bits(scalar[0] + scalar[1] + scalar[2]), "case {i}");
                assert_eq!(bits(lanes.sum_xy()), bits(scalar[0] + scalar[1]), "case {i}");
            }
        }
    }
}
