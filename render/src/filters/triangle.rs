//! The triangle filter (pbrt-v3 `filters/triangle.cpp`):
//! `PixelFilter "triangle" "float xwidth" [2] "float ywidth" [2]`.

use farm_common::geometry::Vec2;

/// A tent falling linearly to zero at the radius.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct TriangleFilter {
    /// Half-widths of the support.
    pub radius: Vec2,
}

impl TriangleFilter {
    /// A tent of the given half-widths.
    pub fn new(radius: Vec2) -> Self {
        TriangleFilter { radius }
    }

    /// `max(0, rx - |x|) * max(0, ry - |y|)` (not normalised, as in pbrt-v3).
    #[inline]
    pub fn evaluate(&self, p: Vec2) -> f32 {
        (self.radius.x - p.x.abs()).max(0.0) * (self.radius.y - p.y.abs()).max(0.0)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn peaks_at_centre_and_vanishes_at_radius() {
        let f = TriangleFilter::new(Vec2::splat(2.0));
        assert_eq!(f.evaluate(Vec2::ZERO), 4.0);
        assert_eq!(f.evaluate(Vec2::new(2.0, 0.3)), 0.0);
        assert_eq!(f.evaluate(Vec2::new(1.0, -1.0)), 1.0);
    }
}
