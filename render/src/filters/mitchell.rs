//! The Mitchell–Netravali filter (pbrt-v3 `filters/mitchell.cpp`):
//! `PixelFilter "mitchell" "float xwidth" [2] "float ywidth" [2] "float B" [1/3] "float C" [1/3]`.

use farm_common::geometry::Vec2;

/// The separable Mitchell–Netravali cubic scaled to the radius.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct MitchellFilter {
    /// Half-widths of the support.
    pub radius: Vec2,
    inv_radius: Vec2,
    b: f32,
    c: f32,
}

impl MitchellFilter {
    /// The cubic with parameters `b` and `c` over `radius`.
    pub fn new(radius: Vec2, b: f32, c: f32) -> Self {
        MitchellFilter { radius, inv_radius: Vec2::ONE / radius, b, c }
    }

    /// The 1D cubic on `[-1, 1]` (pbrt-v3 `Mitchell1D`).
    #[inline]
    pub fn mitchell_1d(&self, x: f32) -> f32 {
        let (b, c) = (self.b, self.c);
        let x = (2.0 * x).abs();
        if x > 1.0 {
            ((-b - 6.0 * c) * x * x * x
                + (6.0 * b + 30.0 * c) * x * x
                + (-12.0 * b - 48.0 * c) * x
                + (8.0 * b + 24.0 * c))
                * (1.0 / 6.0)
        } else {
            ((12.0 - 9.0 * b - 6.0 * c) * x * x * x
                + (-18.0 + 12.0 * b + 6.0 * c) * x * x
                + (6.0 - 2.0 * b))
                * (1.0 / 6.0)
        }
    }

    /// The product of the 1D cubics at `p / radius`.
    #[inline]
    pub fn evaluate(&self, p: Vec2) -> f32 {
        self.mitchell_1d(p.x * self.inv_radius.x) * self.mitchell_1d(p.y * self.inv_radius.y)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn integrates_to_one_over_the_default_support() {
        let f = MitchellFilter::new(Vec2::splat(2.0), 1.0 / 3.0, 1.0 / 3.0);
        let n = 400;
        let h = 4.0 / n as f64;
        let mut sum = 0.0f64;
        for i in 0..n {
            for j in 0..n {
                let p = Vec2::new(
                    (-2.0 + (i as f64 + 0.5) * h) as f32,
                    (-2.0 + (j as f64 + 0.5) * h) as f32,
                );
                sum += f.evaluate(p) as f64 * h * h;
            }
        }
        assert!((sum - 1.0).abs() < 1e-3, "{sum}");
        assert!(f.mitchell_1d(1.0).abs() < 1e-6);
    }
}
