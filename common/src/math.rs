//! Transcendental functions from the pure-Rust `libm` crate, never the
//! platform's C maths library: glibc's `sinf`, `expf`, `powf`… have
//! changed between versions (and differ again on musl or macOS), so a farm
//! mixing hosts would render tiles that differ in their last bits. These
//! give the same bits on every host. `sqrt` and the rounding functions are
//! exact by IEEE 754 and stay with `std`.
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
     $atan2:ident, $pow:ident, $sincos:ident) => {
        impl Real for $t {
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
    powf, sincosf
);
real!(f64, sin, cos, tan, asin, acos, atan, exp, log, log2, log10, sinh, tanh, atan2, pow, sincos);

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

#[cfg(test)]
mod tests {
    use super::*;

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
