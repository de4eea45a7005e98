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
        let threshold = bound.wrapping_neg() % bound;
        loop {
            let r = self.uniform_u32();
            if r >= threshold {
                return r % bound;
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
    fn bounded_draws_stay_below_bound() {
        let mut r = Rng::default();
        let mut seen = [false; 7];
        for _ in 0..1000 {
            seen[r.uniform_u32_below(7) as usize] = true;
        }
        assert!(seen.iter().all(|&s| s));
    }
}
