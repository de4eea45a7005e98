//! Interval arithmetic for bounding the motion of animated transforms
//! (pbrt-v3 `Interval` and `IntervalFindZeros` in `core/transform.cpp`).

use crate::math;
use std::f32::consts::PI;
use std::ops::{Add, Mul, Sub};

/// A closed range of reals `[low, high]`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Interval {
    /// Lower end.
    pub low: f32,
    /// Upper end.
    pub high: f32,
}

impl Interval {
    /// The range spanned by two values in any order.
    #[inline]
    pub fn new(v0: f32, v1: f32) -> Self {
        Interval { low: v0.min(v1), high: v0.max(v1) }
    }

    /// The single value `v`.
    #[inline]
    pub fn point(v: f32) -> Self {
        Interval { low: v, high: v }
    }

    /// Range of `sin` over the interval, which must lie in `[0, 2π]`.
    pub fn sin(self) -> Interval {
        debug_assert!(self.low >= 0.0 && self.high <= 2.0001 * PI);
        let (mut lo, mut hi) = (math::sin(self.low), math::sin(self.high));
        if lo > hi {
            std::mem::swap(&mut lo, &mut hi);
        }
        if self.low < PI / 2.0 && self.high > PI / 2.0 {
            hi = 1.0;
        }
        if self.low < 1.5 * PI && self.high > 1.5 * PI {
            lo = -1.0;
        }
        Interval::new(lo, hi)
    }

    /// Range of `cos` over the interval, which must lie in `[0, 2π]`.
    pub fn cos(self) -> Interval {
        debug_assert!(self.low >= 0.0 && self.high <= 2.0001 * PI);
        let (mut lo, mut hi) = (math::cos(self.low), math::cos(self.high));
        if lo > hi {
            std::mem::swap(&mut lo, &mut hi);
        }
        if self.low < PI && self.high > PI {
            lo = -1.0;
        }
        Interval::new(lo, hi)
    }
}

impl Add for Interval {
    type Output = Interval;
    #[inline]
    fn add(self, i: Interval) -> Interval {
        Interval::new(self.low + i.low, self.high + i.high)
    }
}

impl Sub for Interval {
    type Output = Interval;
    #[inline]
    fn sub(self, i: Interval) -> Interval {
        Interval::new(self.low - i.high, self.high - i.low)
    }
}

impl Mul for Interval {
    type Output = Interval;
    #[inline]
    fn mul(self, i: Interval) -> Interval {
        let (a, b, c, d) =
            (self.low * i.low, self.high * i.low, self.low * i.high, self.high * i.high);
        Interval::new(a.min(b).min(c.min(d)), a.max(b).max(c.max(d)))
    }
}

/// Zeros in `t` of `c1 + (c2 + c3·t)·cos(2θt) + (c4 + c5·t)·sin(2θt)` over
/// `t_interval`, found by bisecting `depth` times with interval bounds and
/// refining each surviving piece with four Newton steps; appends them to
/// `zeros` (pbrt-v3 `IntervalFindZeros`, which uses depth 8).
pub fn interval_find_zeros(
    c: [f32; 5],
    theta: f32,
    t_interval: Interval,
    zeros: &mut [f32; 8],
    zero_count: &mut usize,
    depth: u32,
) {
    let [c1, c2, c3, c4, c5] = c;
    let p = Interval::point;
    // The derivative's range over the interval; no zero if it excludes 0.
    let two_theta_t = p(2.0 * theta) * t_interval;
    let range = p(c1)
        + (p(c2) + p(c3) * t_interval) * two_theta_t.cos()
        + (p(c4) + p(c5) * t_interval) * two_theta_t.sin();
    if range.low > 0.0 || range.high < 0.0 || range.low == range.high {
        return;
    }
    if depth > 0 {
        let mid = (t_interval.low + t_interval.high) * 0.5;
        interval_find_zeros(
            c,
            theta,
            Interval::new(t_interval.low, mid),
            zeros,
            zero_count,
            depth - 1,
        );
        interval_find_zeros(
            c,
            theta,
            Interval::new(mid, t_interval.high),
            zeros,
            zero_count,
            depth - 1,
        );
    } else {
        let mut t = (t_interval.low + t_interval.high) * 0.5;
        for _ in 0..4 {
            let f = c1
                + (c2 + c3 * t) * math::cos(2.0 * theta * t)
                + (c4 + c5 * t) * math::sin(2.0 * theta * t);
            let f_prime = (c3 + 2.0 * (c4 + c5 * t) * theta) * math::cos(2.0 * t * theta)
                + (c5 - 2.0 * (c2 + c3 * t) * theta) * math::sin(2.0 * t * theta);
            if f == 0.0 || f_prime == 0.0 {
                break;
            }
            t -= f / f_prime;
        }
        // pbrt-v3 asserts there are at most eight; keep the first eight.
        if t >= t_interval.low - 1e-3 && t < t_interval.high + 1e-3 && *zero_count < zeros.len() {
            zeros[*zero_count] = t;
            *zero_count += 1;
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn products_and_trig_enclose_sampled_values() {
        let a = Interval::new(-1.0, 2.0);
        let b = Interval::new(0.5, -3.0);
        let m = a * b;
        assert_eq!((m.low, m.high), (-6.0, 3.0));
        let d = a - b;
        assert_eq!((d.low, d.high), (-1.5, 5.0));
        let s = Interval::new(1.0, 5.0).sin();
        assert_eq!((s.low, s.high), (-1.0, 1.0));
        let c = Interval::new(0.2, 1.0).cos();
        assert!(c.low == math::cos(1.0f32) && c.high == math::cos(0.2f32));
    }

    #[test]
    fn finds_the_zeros_of_a_known_function() {
        // f(t) = cos(2θt) with θ = π: zeros at t = 1/4 and 3/4.
        let mut zeros = [0.0; 8];
        let mut n = 0;
        interval_find_zeros(
            [0.0, 1.0, 0.0, 0.0, 0.0],
            PI,
            Interval::new(0.0, 1.0),
            &mut zeros,
            &mut n,
            8,
        );
        assert!(n >= 2, "{n}");
        for z in &zeros[..n] {
            assert!((z - 0.25).abs() < 1e-4 || (z - 0.75).abs() < 1e-4, "{z}");
        }
        // A function with no zero: 2 + sin.
        n = 0;
        interval_find_zeros(
            [2.0, 0.0, 0.0, 1.0, 0.0],
            1.0,
            Interval::new(0.0, 1.0),
            &mut zeros,
            &mut n,
            8,
        );
        assert_eq!(n, 0);
    }
}
