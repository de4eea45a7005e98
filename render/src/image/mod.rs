//! Image maps: pbrt-v3's MIP maps for filtered lookups (`core/mipmap.h`)
//! over images decoded by `farm_common::image`.

use farm_common::math;
mod mipmap;

pub use farm_common::image::{read_image, ImageError, RgbImage};
pub use mipmap::{MipMap, Texel, WrapMode};

/// pbrt-v3's `InverseGammaCorrect`: sRGB code value to linear.
#[inline]
pub fn inverse_gamma_correct(v: f32) -> f32 {
    if v <= 0.04045 {
        v * (1.0 / 12.92)
    } else {
        math::powf((v + 0.055) * (1.0 / 1.055), 2.4)
    }
}

#[cfg(test)]
mod tests {
    #[test]
    fn inverse_gamma_is_the_srgb_curve() {
        assert!((super::inverse_gamma_correct(0.5) - 0.214_041).abs() < 1e-5);
        assert_eq!(super::inverse_gamma_correct(0.0), 0.0);
        assert!((super::inverse_gamma_correct(1.0) - 1.0).abs() < 1e-6);
    }
}
