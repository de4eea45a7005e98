//! CIE colour matching and conversions of sampled spectra to RGB, as
//! pbrt-v3's `RGBSpectrum::FromSampled` does them.
//! PLACEHOLDER SIGNATURES: the implementation is being written.

use crate::spectrum::Spectrum;

/// RGB of a spectrum given as samples `values` at wavelengths `lambda` (nm, ascending).
pub fn sampled_to_rgb(lambda: &[f32], values: &[f32]) -> Spectrum {
    let _ = lambda;
    Spectrum::splat(values.iter().sum::<f32>() / values.len().max(1) as f32)
}

/// RGB of pbrt-v3's normalised blackbody at `temperature` kelvin, times `scale`.
pub fn blackbody_rgb(temperature: f32, scale: f32) -> Spectrum {
    let _ = temperature;
    Spectrum::splat(scale)
}

/// Linear sRGB-primaries RGB from CIE XYZ (pbrt-v3 `XYZToRGB`).
pub fn xyz_to_rgb(xyz: [f32; 3]) -> Spectrum {
    Spectrum::new(
        3.240479 * xyz[0] - 1.537150 * xyz[1] - 0.498535 * xyz[2],
        -0.969256 * xyz[0] + 1.875991 * xyz[1] + 0.041556 * xyz[2],
        0.055648 * xyz[0] - 0.204043 * xyz[1] + 1.057311 * xyz[2],
    )
}
