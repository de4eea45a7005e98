//! pbrt-v3's PCG32 (`core/rng.h`), including its float conversion, so that
//! sample streams seeded the same way as pbrt-v3's are the same numbers.

const PCG32_DEFAULT_STATE: u64 = 0x853c_49e6_748f_ea9b;
const PCG32_DEFAULT_STREAM: u64 = 0xda3e_39cb_94b9_5bdb;
const PCG32_MULT: u64 = 0x5851_f42d_4c95_7f2d;

/// The largest f32 below one.
pub const ONE_MINUS_EPSILON: f32 = 1.0 - f32::EPSILON / 2.0;

/// A PCG32 generator: 64 bits of state, one of 2^63 streams.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct Rng {
    state: u64,
    inc: u64,
}

impl Default for Rng {
    fn default() -> Self {
        Rng { state: PCG32_DEFAULT_STATE, inc: PCG32_DEFAULT_STREAM }
    }
}

impl Rng {
    /// A generator on stream `seq` (pbrt-v3 `RNG(uint64_t)`).
    pub fn new(seq: u64) -> Self {
        let mut r = Rng { state: 0, inc: 0 };
        r.set_sequence(seq);
        r
    }

    /// Restart on stream `seq` (pbrt-v3 `SetSequence`).
    pub fn set_sequence(&mut self, seq: u64) {
        self.state = 0;
        self.inc = (seq << 1) | 1;
        self.uniform_u32();
        self.state = self.state.wrapping_add(PCG32_DEFAULT_STATE);
        self.uniform_u32();
    }

    /// The next 32 random bits.
    #[inline]
    pub fn uniform_u32(&mut self) -> u32 {
        let old = self.state;
        self.state = old.wrapping_mul(PCG32_MULT).wrapping_add(self.inc);
        let xorshifted = (((old >> 18) ^ old) >> 27) as u32;
        let rot = (old >> 59) as u32;
        xorshifted.rotate_right(rot)
    }

    /// A uniform integer in `[0, bound)` without modulo bias.
    pub fn uniform_u32_below(&mut self, bound: u32) -> u32 {
        if bound == 1 {
            // What the loop below comes to: one draw, accepted, and 0
            // (a shuffle's last step, and all of a shuffle of one).
            self.uniform_u32();
            return 0;
        }
        let threshold = rem(bound.wrapping_neg(), bound);
        loop {
            let r = self.uniform_u32();
            if r >= threshold {
                return rem(r, bound);
            }
        }
    }

    /// A uniform float in `[0, 1)`, converted exactly as pbrt-v3 does.
    #[inline]
    pub fn uniform_f32(&mut self) -> f32 {
        (self.uniform_u32() as f32 * f32::from_bits(0x2f80_0000)).min(ONE_MINUS_EPSILON)
    }

    /// Skip `delta` steps forward or back (pbrt-v3 `Advance`).
    pub fn advance(&mut self, delta: i64) {
        let (mut cur_mult, mut cur_plus) = (PCG32_MULT, self.inc);
        let (mut acc_mult, mut acc_plus) = (1u64, 0u64);
        let mut delta = delta as u64;
        while delta > 0 {
            if delta & 1 != 0 {
                acc_mult = acc_mult.wrapping_mul(cur_mult);
                acc_plus = acc_plus.wrapping_mul(cur_mult).wrapping_add(cur_plus);
            }
            cur_plus = cur_mult.wrapping_add(1).wrapping_mul(cur_plus);
            cur_mult = cur_mult.wrapping_mul(cur_mult);
            delta /= 2;
        }
        self.state = acc_mult.wrapping_mul(self.state).wrapping_add(acc_plus);
    }
}

/// The largest divisor [`rem`] takes by multiplication.
const FAST_REM_MAX: u32 = 1024;

/// ⌈2⁶⁴ / d⌉ for each divisor d up to [`FAST_REM_MAX`] (d = 1 wraps to 0).
static FAST_REM: [u64; FAST_REM_MAX as usize + 1] = {
    let mut m = [0u64; FAST_REM_MAX as usize + 1];
    let mut d = 1;
    while d <= FAST_REM_MAX as usize {
        m[d] = (u64::MAX / d as u64).wrapping_add(1);
        d += 1;
    }
    m
};

/// `a % d`, exactly, by a multiplication for the small divisors that
/// shuffles draw below (Lemire, Kaser and Kurz, "Faster remainder by direct
/// computation", 2019: exact for every 32-bit `a` and `d`), where a
/// division would cost a third of a shuffle. Panics when `d` is 0, as `%`.
#[inline(always)]
fn rem(a: u32, d: u32) -> u32 {
    if d.wrapping_sub(1) < FAST_REM_MAX {
        let low = FAST_REM[d as usize].wrapping_mul(u64::from(a));
        ((u128::from(low) * u128::from(d)) >> 64) as u32
    } else {
        a % d
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn floats_are_in_unit_interval_and_streams_differ() {
        let mut a = Rng::new(0);
        let mut b = Rng::new(1);
        let mut same = 0;
        for _ in 0..10_000 {
            let (x, y) = (a.uniform_f32(), b.uniform_f32());
            assert!((0.0..1.0).contains(&x));
            same += (x == y) as u32;
        }
        assert!(same < 10);
    }

    #[test]
    fn advance_matches_stepping() {
        let mut a = Rng::new(7);
        let mut b = a.clone();
        for _ in 0..1000 {
            a.uniform_u32();
        }
        b.advance(1000);
        assert_eq!(a, b);
        b.advance(-1000);
        let mut c = Rng::new(7);
        assert_eq!(b.uniform_u32(), c.uniform_u32());
    }

    #[test]
    fn remainders_by_multiplication_are_exact() {
        let mut r = Rng::new(3);
        for d in 1..=FAST_REM_MAX + 2 {
            let edges = [0, 1, d - 1, d, d.wrapping_neg(), u32::MAX, u32::MAX - 1, d * 1000 + 7];
            for a in edges.into_iter().chain((0..2000).map(|_| r.uniform_u32())) {
                assert_eq!(rem(a, d), a % d, "{a} % {d}");
            }
        }
        for d in [u32::MAX, 1 << 31, 65_537, 4_000_000_007] {
            assert_eq!(rem(u32::MAX, d), u32::MAX % d);
        }
    }

    #[test]
    fn bounded_draws_stay_below_bound() {
        let mut r = Rng::default();
        let mut seen = [false; 7];
        for _ in 0..1000 {
            seen[r.uniform_u32_below(7) as usize] = true;
        }
        assert!(seen.iter().all(|&s| s));
        // Below 1: one draw, as the general loop takes it.
        let mut one = Rng::new(9);
        let mut plain = one.clone();
        assert_eq!(one.uniform_u32_below(1), 0);
        plain.uniform_u32();
        assert_eq!(one, plain);
    }
}
