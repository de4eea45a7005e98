//! The Lanczos-windowed sinc filter (pbrt-v3 `filters/sinc.cpp`):
//! `PixelFilter "sinc" "float xwidth" [4] "float ywidth" [4] "float tau" [3]`.

use farm_common::geometry::Vec2;
use farm_common::math;
use std::f32::consts::PI;

/// A sinc windowed by a wider sinc (Lanczos), zero beyond the radius.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct LanczosSincFilter {
    /// Half-widths of the support.
    pub radius: Vec2,
    tau: f32,
}

fn sinc(x: f32) -> f32 {
    let x = x.abs();
    if x < 1e-5 {
        return 1.0;
    }
    math::sin(PI * x) / (PI * x)
}

impl LanczosSincFilter {
    /// A windowed sinc over `radius` with `tau` lobes in the window.
    pub fn new(radius: Vec2, tau: f32) -> Self {
        LanczosSincFilter { radius, tau }
    }

    /// The 1D windowed sinc (pbrt-v3 `WindowedSinc`).
    #[inline]
    pub fn windowed_sinc(&self, x: f32, radius: f32) -> f32 {
        let x = x.abs();
        if x > radius {
            return 0.0;
        }
        sinc(x) * sinc(x / self.tau)
    }

    /// The product of the windowed sincs in x and y.
    #[inline]
    pub fn evaluate(&self, p: Vec2) -> f32 {
        self.windowed_sinc(p.x, self.radius.x) * self.windowed_sinc(p.y, self.radius.y)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn one_at_centre_zero_at_integers_and_outside() {
        let f = LanczosSincFilter::new(Vec2::splat(4.0), 3.0);
        assert_eq!(f.evaluate(Vec2::ZERO), 1.0);
        assert!(f.evaluate(Vec2::new(1.0, 0.0)).abs() < 1e-6);
        assert_eq!(f.evaluate(Vec2::new(4.5, 0.0)), 0.0);
    }
}
