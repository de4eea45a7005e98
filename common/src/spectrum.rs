//! RGB spectra (pbrt-v3 built with `RGBSpectrum`, as the reference images
//! were). Sampled and blackbody spectra are converted to RGB once, when the
//! scene is parsed, through the CIE matching functions (see `cie`).

use crate::math;
use serde::{Deserialize, Serialize};
use std::ops::{Add, AddAssign, Div, Index, Mul, MulAssign, Sub};

/// A linear RGB triple.
#[derive(Clone, Copy, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct Spectrum {
    /// Red.
    pub r: f32,
    /// Green.
    pub g: f32,
    /// Blue.
    pub b: f32,
}

impl Spectrum {
    /// Black.
    pub const ZERO: Spectrum = Spectrum { r: 0.0, g: 0.0, b: 0.0 };
    /// White (1, 1, 1).
    pub const ONE: Spectrum = Spectrum { r: 1.0, g: 1.0, b: 1.0 };

    /// The triple (r, g, b).
    #[inline]
    pub const fn new(r: f32, g: f32, b: f32) -> Self {
        Spectrum { r, g, b }
    }
    /// All three channels equal to `v`.
    #[inline]
    pub const fn splat(v: f32) -> Self {
        Spectrum { r: v, g: v, b: v }
    }
    /// From an array.
    #[inline]
    pub const fn from_array(a: [f32; 3]) -> Self {
        Spectrum { r: a[0], g: a[1], b: a[2] }
    }
    /// As an array.
    #[inline]
    pub const fn to_array(self) -> [f32; 3] {
        [self.r, self.g, self.b]
    }
    /// Whether every channel is zero.
    #[inline]
    pub fn is_black(&self) -> bool {
        self.r == 0.0 && self.g == 0.0 && self.b == 0.0
    }
    /// Whether any channel is NaN.
    #[inline]
    pub fn has_nan(&self) -> bool {
        self.r.is_nan() || self.g.is_nan() || self.b.is_nan()
    }
    /// Whether every channel is finite.
    #[inline]
    pub fn is_finite(&self) -> bool {
        self.r.is_finite() && self.g.is_finite() && self.b.is_finite()
    }
    /// Luminance with pbrt-v3's weights (`RGBSpectrum::y`).
    #[inline]
    pub fn y(&self) -> f32 {
        0.212671 * self.r + 0.715160 * self.g + 0.072169 * self.b
    }
    /// Largest channel.
    #[inline]
    pub fn max_component(&self) -> f32 {
        self.r.max(self.g).max(self.b)
    }
    /// Channel-wise map.
    #[inline]
    pub fn map(self, f: impl Fn(f32) -> f32) -> Spectrum {
        Spectrum::new(f(self.r), f(self.g), f(self.b))
    }
    /// Channel-wise square root.
    #[inline]
    pub fn sqrt(self) -> Spectrum {
        self.map(f32::sqrt)
    }
    /// Channel-wise `exp`.
    #[inline]
    pub fn exp(self) -> Spectrum {
        self.map(math::exp)
    }
    /// Clamp every channel to `[lo, hi]`.
    #[inline]
    pub fn clamp(self, lo: f32, hi: f32) -> Spectrum {
        self.map(|v| v.clamp(lo, hi))
    }
}

impl Index<usize> for Spectrum {
    type Output = f32;
    #[inline]
    fn index(&self, i: usize) -> &f32 {
        match i {
            0 => &self.r,
            1 => &self.g,
            _ => &self.b,
        }
    }
}

macro_rules! binop {
    ($tr:ident, $f:ident, $op:tt) => {
        impl $tr for Spectrum {
            type Output = Spectrum;
            #[inline]
            fn $f(self, o: Spectrum) -> Spectrum {
                Spectrum::new(self.r $op o.r, self.g $op o.g, self.b $op o.b)
            }
        }
        impl $tr<f32> for Spectrum {
            type Output = Spectrum;
            #[inline]
            fn $f(self, o: f32) -> Spectrum {
                Spectrum::new(self.r $op o, self.g $op o, self.b $op o)
            }
        }
    };
}
binop!(Add, add, +);
binop!(Sub, sub, -);
binop!(Mul, mul, *);
binop!(Div, div, /);

impl Mul<Spectrum> for f32 {
    type Output = Spectrum;
    #[inline]
    fn mul(self, s: Spectrum) -> Spectrum {
        s * self
    }
}
impl AddAssign for Spectrum {
    #[inline]
    fn add_assign(&mut self, o: Spectrum) {
        *self = *self + o;
    }
}
impl MulAssign<f32> for Spectrum {
    #[inline]
    fn mul_assign(&mut self, o: f32) {
        *self = *self * o;
    }
}
impl MulAssign for Spectrum {
    #[inline]
    fn mul_assign(&mut self, o: Spectrum) {
        *self = *self * o;
    }
}
