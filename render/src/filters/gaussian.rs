//! The Gaussian filter (pbrt-v3 `filters/gaussian.cpp`):
//! `PixelFilter "gaussian" "float xwidth" [2] "float ywidth" [2] "float alpha" [2]`.

use farm_common::geometry::Vec2;
use farm_common::math;

/// A Gaussian shifted down to reach zero at the radius.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct GaussianFilter {
    /// Half-widths of the support.
    pub radius: Vec2,
    alpha: f32,
    exp_x: f32,
    exp_y: f32,
}

impl GaussianFilter {
    /// A Gaussian of falloff `alpha` truncated at `radius`.
    pub fn new(radius: Vec2, alpha: f32) -> Self {
        GaussianFilter {
            radius,
            alpha,
            exp_x: math::exp(-alpha * radius.x * radius.x),
            exp_y: math::exp(-alpha * radius.y * radius.y),
        }
    }

    #[inline]
    fn gaussian(&self, d: f32, expv: f32) -> f32 {
        (math::exp(-self.alpha * d * d) - expv).max(0.0)
    }

    /// The separable product of the two shifted Gaussians.
    #[inline]
    pub fn evaluate(&self, p: Vec2) -> f32 {
        self.gaussian(p.x, self.exp_x) * self.gaussian(p.y, self.exp_y)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn zero_at_radius_and_peak_at_centre() {
        let f = GaussianFilter::new(Vec2::new(2.0, 1.5), 2.0);
        assert_eq!(f.evaluate(Vec2::new(2.0, 0.0)), 0.0);
        assert_eq!(f.evaluate(Vec2::new(0.0, -1.5)), 0.0);
        let peak = (1.0 - math::exp(-8.0f32)) * (1.0 - math::exp(-4.5f32));
        assert!((f.evaluate(Vec2::ZERO) - peak).abs() < 1e-6);
        assert!(f.evaluate(Vec2::new(0.5, 0.5)) < f.evaluate(Vec2::ZERO));
    }
}
