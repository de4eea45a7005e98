//! Transcendental functions from the pure-Rust `libm` crate, never the
//! platform's C maths library: glibc's `sinf`, `expf`, `powf`… have
//! changed between versions (and differ again on musl or macOS), so a farm
//! mixing hosts would render tiles that differ in their last bits. These
//! give the same bits on every host. `sqrt` is exact by IEEE 754 and stays
//! with `std`. So are `floor` and `ceil`, but on baseline x86-64 (no
//! SSE4.1 `roundss`) `std` calls the C library's `floorf` out of line for
//! them; [`floor`] and [`ceil`] here are the same exact functions inline.
//!
//! Each function takes `f32` or `f64` ([`Real`]), so a call site reads as
//! the method it replaces: `x.sin()` becomes `math::sin(x)`,
//! `y.atan2(x)` becomes `math::atan2(y, x)`, `x.powf(e)` becomes
//! `math::powf(x, e)`. `clippy.toml` refuses the `std` methods.

/// A float type with `libm`'s functions.
pub trait Real: Copy + private::Sealed {
    #[doc(hidden)]
    fn lm1(self, f: Fn1) -> Self;
    #[doc(hidden)]
    fn lm2(self, other: Self, f: Fn2) -> Self;
    #[doc(hidden)]
    fn lm_sin_cos(self) -> (Self, Self);
    #[doc(hidden)]
    fn round_down(self) -> Self;
    #[doc(hidden)]
    fn round_up(self) -> Self;
}

mod private {
    pub trait Sealed {}
    impl Sealed for f32 {}
    impl Sealed for f64 {}
}

#[doc(hidden)]
#[derive(Clone, Copy)]
pub enum Fn1 {
    Sin,
    Cos,
    Tan,
    Asin,
    Acos,
    Atan,
    Exp,
    Ln,
    Log2,
    Log10,
    Sinh,
    Tanh,
}

#[doc(hidden)]
#[derive(Clone, Copy)]
pub enum Fn2 {
    Atan2,
    Pow,
}

macro_rules! real {
    ($t:ty, $sin:ident, $cos:ident, $tan:ident, $asin:ident, $acos:ident, $atan:ident,
     $exp:ident, $ln:ident, $log2:ident, $log10:ident, $sinh:ident, $tanh:ident,
     $atan2:ident, $pow:ident, $sincos:ident, $int:ty) => {
        impl Real for $t {
            #[inline(always)]
            fn round_down(self) -> Self {
                // From 2^(mantissa bits) up every float is an integer; so
                // are the infinities, and NaN stays NaN.
                if self.is_nan() || self.abs() >= (1u64 << (<$t>::MANTISSA_DIGITS - 1)) as $t {
                    return self;
                }
                // Truncation is exact below that; a negative non-integer
                // truncates up, one too far. The sign of zero follows `self`.
                let t = self as $int as $t;
                let r = if t > self { t - 1.0 } else { t };
                r.copysign(self)
            }
            #[inline(always)]
            fn round_up(self) -> Self {
                if self.is_nan() || self.abs() >= (1u64 << (<$t>::MANTISSA_DIGITS - 1)) as $t {
                    return self;
                }
                let t = self as $int as $t;
                let r = if t < self { t + 1.0 } else { t };
                r.copysign(self)
            }
            #[inline]
            fn lm1(self, f: Fn1) -> Self {
                match f {
                    Fn1::Sin => libm::$sin(self),
                    Fn1::Cos => libm::$cos(self),
                    Fn1::Tan => libm::$tan(self),
                    Fn1::Asin => libm::$asin(self),
                    Fn1::Acos => libm::$acos(self),
                    Fn1::Atan => libm::$atan(self),
                    Fn1::Exp => libm::$exp(self),
                    Fn1::Ln => libm::$ln(self),
                    Fn1::Log2 => libm::$log2(self),
                    Fn1::Log10 => libm::$log10(self),
                    Fn1::Sinh => libm::$sinh(self),
                    Fn1::Tanh => libm::$tanh(self),
                }
            }
            #[inline]
            fn lm2(self, other: Self, f: Fn2) -> Self {
                match f {
                    Fn2::Atan2 => libm::$atan2(self, other),
                    Fn2::Pow => libm::$pow(self, other),
                }
            }
            #[inline]
            fn lm_sin_cos(self) -> (Self, Self) {
                libm::$sincos(self)
            }
        }
    };
}

real!(
    f32, sinf, cosf, tanf, asinf, acosf, atanf, expf, logf, log2f, log10f, sinhf, tanhf, atan2f,
    powf, sincosf, i32
);
real!(
    f64, sin, cos, tan, asin, acos, atan, exp, log, log2, log10, sinh, tanh, atan2, pow, sincos,
    i64
);

macro_rules! one {
    ($($(#[$doc:meta])* $name:ident => $f:ident;)*) => {
        $(
            $(#[$doc])*
            #[inline]
            pub fn $name<T: Real>(x: T) -> T {
                x.lm1(Fn1::$f)
            }
        )*
    };
}

one! {
    /// Sine (radians).
    sin => Sin;
    /// Cosine (radians).
    cos => Cos;
    /// Tangent (radians).
    tan => Tan;
    /// Arcsine.
    asin => Asin;
    /// Arccosine.
    acos => Acos;
    /// Arctangent.
    atan => Atan;
    /// eˣ.
    exp => Exp;
    /// Natural logarithm.
    ln => Ln;
    /// Base-2 logarithm.
    log2 => Log2;
    /// Base-10 logarithm.
    log10 => Log10;
    /// Hyperbolic sine.
    sinh => Sinh;
    /// Hyperbolic tangent.
    tanh => Tanh;
}

/// The angle of (x, y), as `y.atan2(x)`.
#[inline]
pub fn atan2<T: Real>(y: T, x: T) -> T {
    y.lm2(x, Fn2::Atan2)
}

/// `x` to the power `e`.
#[inline]
pub fn powf<T: Real>(x: T, e: T) -> T {
    x.lm2(e, Fn2::Pow)
}

/// (sin x, cos x).
#[inline]
pub fn sin_cos<T: Real>(x: T) -> (T, T) {
    x.lm_sin_cos()
}

/// The largest integer not above `x`, as `x.floor()` (the same value,
/// without a call into the C library).
#[inline(always)]
pub fn floor<T: Real>(x: T) -> T {
    x.round_down()
}

/// The smallest integer not below `x`, as `x.ceil()`.
#[inline(always)]
pub fn ceil<T: Real>(x: T) -> T {
    x.round_up()
}

/// pbrt-v3's `Clamp`: `low` below it, `high` above it, else `val`.
/// Unlike `f32::clamp` it never panics: bounds from a scene may be
/// reversed (`high < low` gives `low` below `low` and `high` from there)
/// or NaN (then ignored).
#[inline]
pub fn clamp(val: f32, low: f32, high: f32) -> f32 {
    if val < low {
        low
    } else if val > high {
        high
    } else {
        val
    }
}

/// `floor(x) as i64`, saturating (NaN is 0), without the round trip
/// through a float.
#[inline(always)]
pub fn floor_i64(x: f64) -> i64 {
    let t = x as i64;
    t.saturating_sub(i64::from((t as f64) > x))
}

/// `ceil(x) as i64`, saturating (NaN is 0), without the round trip
/// through a float.
#[inline(always)]
pub fn ceil_i64(x: f64) -> i64 {
    let t = x as i64;
    t.saturating_add(i64::from((t as f64) < x))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn integer_floor_and_ceil_are_floor_and_ceil_converted() {
        let mut values = vec![0.0, -0.0, 0.5, -0.5, 1.0, -1.0, 2.5, -2.5, 1e15 + 0.5, -1e15 - 0.5];
        values.extend([2f64.powi(52), 2f64.powi(53) + 2.0, 2f64.powi(63), -(2f64.powi(63)), 1e300]);
        values.extend([f64::INFINITY, f64::NEG_INFINITY, f64::NAN, f64::MIN_POSITIVE, -1e-300]);
        let mut rng = crate::rng::Rng::new(9);
        values.extend((0..1000).map(|_| (rng.uniform_f32() as f64 - 0.5) * 1e6));
        for x in values {
            assert_eq!(floor_i64(x), floor(x) as i64, "{x}");
            assert_eq!(ceil_i64(x), ceil(x) as i64, "{x}");
        }
    }

    #[test]
    #[allow(clippy::disallowed_methods)]
    fn floor_and_ceil_are_std_s_to_the_bit() {
        let mut xs: Vec<f32> = vec![
            0.0,
            -0.0,
            0.5,
            -0.5,
            1.0,
            -1.0,
            1.5,
            -1.5,
            2.5,
            -2.5,
            0.999_999_94,
            -0.999_999_94,
            8388607.5,
            -8388607.5,
            8388608.0,
            -8388608.0,
            16777217.0,
            1e30,
            -1e30,
            1e-40,
            -1e-40,
            f32::MAX,
            f32::MIN,
            f32::MIN_POSITIVE,
            f32::INFINITY,
            f32::NEG_INFINITY,
            f32::NAN,
        ];
        let mut r = crate::rng::Rng::new(3);
        xs.extend((0..100_000).map(|_| f32::from_bits(r.uniform_u32())));
        xs.extend((0..100_000).map(|_| (r.uniform_f32() - 0.5) * 1000.0));
        for x in xs {
            assert_eq!(floor(x).to_bits(), x.floor().to_bits(), "floor {x:e}");
            assert_eq!(ceil(x).to_bits(), x.ceil().to_bits(), "ceil {x:e}");
            let d = x as f64 * 1.000_000_1;
            assert_eq!(floor(d).to_bits(), d.floor().to_bits(), "floor {d:e}");
            assert_eq!(ceil(d).to_bits(), d.ceil().to_bits(), "ceil {d:e}");
        }
        for d in [4503599627370495.5f64, -4503599627370495.5, 4503599627370496.0, -0.0, 0.25] {
            assert_eq!(floor(d).to_bits(), d.floor().to_bits(), "floor {d:e}");
            assert_eq!(ceil(d).to_bits(), d.ceil().to_bits(), "ceil {d:e}");
        }
    }

    #[test]
    fn these_are_libm_s_bits() {
        for x in [0.5f32, 1e-3, 3.0, 100.0, -2.5] {
            assert_eq!(sin(x).to_bits(), libm::sinf(x).to_bits());
            assert_eq!(exp(x).to_bits(), libm::expf(x).to_bits());
            assert_eq!(powf(x.abs(), 2.4).to_bits(), libm::powf(x.abs(), 2.4).to_bits());
            assert_eq!(atan2(x, 0.7).to_bits(), libm::atan2f(x, 0.7).to_bits());
            let (s, c) = sin_cos(x);
            assert_eq!(
                (s.to_bits(), c.to_bits()),
                (libm::sinf(x).to_bits(), libm::cosf(x).to_bits())
            );
        }
        assert_eq!(sin(0.5f64).to_bits(), libm::sin(0.5).to_bits());
    }

    /// `sin_cos` (libm's `sincosf`) gives `sinf`'s and `cosf`'s bits, so
    /// code may take both at once where pbrt-v3 calls the two. Checked over
    /// every 7th float once (0 differences in 613 million); here every
    /// 4099th.
    #[test]
    fn sin_cos_is_sin_and_cos() {
        let same = |a: f32, b: f32| a.to_bits() == b.to_bits() || a.is_nan() && b.is_nan();
        for bits in (0..=u32::MAX).step_by(4099) {
            let x = f32::from_bits(bits);
            let (s, c) = sin_cos(x);
            assert!(same(s, libm::sinf(x)) && same(c, libm::cosf(x)), "{x:e}");
        }
    }

    #[test]
    fn they_agree_with_the_platform_within_an_ulp_or_two() {
        #[allow(clippy::disallowed_methods)]
        fn platform(x: f32) -> [f32; 8] {
            [
                x.sin(),
                x.cos(),
                x.tan(),
                x.exp(),
                x.abs().ln(),
                x.abs().powf(1.7),
                x.atan2(0.3),
                x.atan(),
            ]
        }
        let ours = |x: f32| {
            [
                sin(x),
                cos(x),
                tan(x),
                exp(x),
                ln(x.abs()),
                powf(x.abs(), 1.7),
                atan2(x, 0.3),
                atan(x),
            ]
        };
        for i in 1..200 {
            let x = (i as f32 - 100.0) * 0.071;
            for (a, b) in ours(x).iter().zip(platform(x)) {
                let ulps = (a.to_bits() as i64 - b.to_bits() as i64).abs();
                assert!(ulps <= 2, "{x}: {a} against {b}");
            }
        }
    }
}
