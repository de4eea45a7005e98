//! What a MIP map stores, floats or RGB, and what its lookups need to know
//! of a texel.

use farm_common::Spectrum;
use std::ops::{Add, Mul};

/// Texels larger than this are not [`Texel::tame`].
const TAME: f32 = 1e28;

/// What a MIP map stores: floats or RGB.
pub trait Texel: Copy + Default + Add<Output = Self> + Mul<f32, Output = Self> {
    /// The value clamped below at zero.
    fn clamp_non_negative(self) -> Self;
    /// Whether every channel is finite and at most 10²⁸ in size, so that
    /// an EWA sum of up to 10¹⁰ weighted texels stays finite (a lookup
    /// that takes one level sums a few thousand at most).
    fn tame(self) -> bool;
    /// Whether a channel is −0, the one value that adding +0 changes.
    fn has_negative_zero(self) -> bool;
}

impl Texel for f32 {
    #[inline]
    fn clamp_non_negative(self) -> Self {
        self.max(0.0)
    }
    #[inline]
    fn tame(self) -> bool {
        self.abs() <= TAME
    }
    #[inline]
    fn has_negative_zero(self) -> bool {
        self == 0.0 && self.is_sign_negative()
    }
}

impl Texel for Spectrum {
    #[inline]
    fn clamp_non_negative(self) -> Self {
        self.map(|v| v.max(0.0))
    }
    #[inline]
    fn tame(self) -> bool {
        self.r.tame() && self.g.tame() && self.b.tame()
    }
    #[inline]
    fn has_negative_zero(self) -> bool {
        self.r.has_negative_zero() || self.g.has_negative_zero() || self.b.has_negative_zero()
    }
}
