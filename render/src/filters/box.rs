//! The box filter (pbrt-v3 `filters/box.cpp`):
//! `PixelFilter "box" "float xwidth" [0.5] "float ywidth" [0.5]`.

use farm_common::geometry::Vec2;

/// Equal weight everywhere in its support.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct BoxFilter {
    /// Half-widths of the support.
    pub radius: Vec2,
}

impl BoxFilter {
    /// A box of the given half-widths.
    pub fn new(radius: Vec2) -> Self {
        BoxFilter { radius }
    }

    /// Always one (the film only asks inside the radius).
    #[inline]
    pub fn evaluate(&self, _p: Vec2) -> f32 {
        1.0
    }
}
