//! Image maps: pbrt-v3's MIP maps for filtered lookups (`core/mipmap.h`)
//! over images decoded by `farm_common::image`.

use farm_common::math;
use std::sync::LazyLock;
mod ewa;
mod mipmap;
mod texel;

pub use farm_common::image::{read_image, ImageError, RgbImage};
pub use mipmap::{MipMap, Texel, WrapMode};

/// pbrt-v3's `InverseGammaCorrect`: sRGB code value to linear. An 8-bit
/// image's values (`k as f32 / 255.0`, as `farm_common::image` decodes
/// them) come from a table made with the same formula, the same bits
/// without a `powf` per channel of every texel.
#[inline]
pub fn inverse_gamma_correct(v: f32) -> f32 {
    static EIGHT_BIT: LazyLock<[f32; 256]> =
        LazyLock::new(|| std::array::from_fn(|k| srgb_to_linear(k as f32 / 255.0)));
    let k = (v * 255.0 + 0.5) as usize;
    if k < 256 && (k as f32 / 255.0).to_bits() == v.to_bits() {
        return EIGHT_BIT[k];
    }
    srgb_to_linear(v)
}

fn srgb_to_linear(v: f32) -> f32 {
    if v <= 0.04045 {
        v * (1.0 / 12.92)
    } else {
        math::powf((v + 0.055) * (1.0 / 1.055), 2.4)
    }
}

#[cfg(test)]
mod tests {
    #[test]
    fn eight_bit_values_from_the_table_are_the_formulas() {
        for k in 0..=255u32 {
            let v = k as f32 / 255.0;
            assert_eq!(
                super::inverse_gamma_correct(v).to_bits(),
                super::srgb_to_linear(v).to_bits()
            );
            // A value beside a code value takes the formula.
            let near = f32::from_bits(v.to_bits() + 1);
            assert_eq!(
                super::inverse_gamma_correct(near).to_bits(),
                super::srgb_to_linear(near).to_bits()
            );
        }
    }

    #[test]
    fn inverse_gamma_is_the_srgb_curve() {
        assert!((super::inverse_gamma_correct(0.5) - 0.214_041).abs() < 1e-5);
        assert_eq!(super::inverse_gamma_correct(0.0), 0.0);
        assert!((super::inverse_gamma_correct(1.0) - 1.0).abs() < 1e-6);
    }
}
