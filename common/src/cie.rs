//! CIE colour matching and conversions of sampled spectra to RGB, as
//! pbrt-v3's `RGBSpectrum::FromSampled` does them, plus pbrt-v3's normalised
//! blackbody (the `"blackbody"` parameter type) and the copper constants
//! that `Material "metal"` defaults to.

#[path = "cie_data.rs"]
mod cie_data;

pub use cie_data::{
    CIE_LAMBDA_START, CIE_X, CIE_Y, CIE_Y_INTEGRAL, CIE_Z, COPPER_K, COPPER_N, COPPER_WAVELENGTHS,
    N_CIE_SAMPLES,
};

use crate::math;
use crate::spectrum::Spectrum;

/// The wavelength (nm) of CIE sample `i` (pbrt-v3 `CIE_lambda[i]`).
#[inline]
pub fn cie_lambda(i: usize) -> f32 {
    CIE_LAMBDA_START + i as f32
}

/// Piecewise-linear interpolation of samples at `l`, clamped at the ends
/// (pbrt-v3 `InterpolateSpectrumSamples`). `lambda` must be ascending.
pub fn interpolate_spectrum_samples(lambda: &[f32], values: &[f32], l: f32) -> f32 {
    let n = lambda.len().min(values.len());
    if n == 0 {
        return 0.0;
    }
    if l <= lambda[0] {
        return values[0];
    }
    if l >= lambda[n - 1] {
        return values[n - 1];
    }
    // Largest index with lambda[i] <= l, clamped to [0, n-2] (pbrt-v3 FindInterval).
    let i = lambda[..n].partition_point(|&x| x <= l).saturating_sub(1).min(n - 2);
    let t = (l - lambda[i]) / (lambda[i + 1] - lambda[i]);
    (1.0 - t) * values[i] + t * values[i + 1]
}

/// RGB of a spectrum given as samples `values` at wavelengths `lambda` (nm).
/// Unsorted samples are sorted first, as pbrt-v3 does.
pub fn sampled_to_rgb(lambda: &[f32], values: &[f32]) -> Spectrum {
    let n = lambda.len().min(values.len());
    let sorted = lambda[..n].windows(2).all(|w| w[0] <= w[1]);
    let (lam, val): (Vec<f32>, Vec<f32>) = if sorted {
        (lambda[..n].to_vec(), values[..n].to_vec())
    } else {
        let mut pairs: Vec<(f32, f32)> =
            lambda[..n].iter().copied().zip(values[..n].iter().copied()).collect();
        pairs.sort_by(|a, b| a.0.total_cmp(&b.0).then(a.1.total_cmp(&b.1)));
        pairs.into_iter().unzip()
    };
    let mut xyz = [0.0f32; 3];
    for i in 0..N_CIE_SAMPLES {
        let v = interpolate_spectrum_samples(&lam, &val, cie_lambda(i));
        xyz[0] += v * CIE_X[i];
        xyz[1] += v * CIE_Y[i];
        xyz[2] += v * CIE_Z[i];
    }
    let scale =
        (cie_lambda(N_CIE_SAMPLES - 1) - cie_lambda(0)) / (CIE_Y_INTEGRAL * N_CIE_SAMPLES as f32);
    xyz_to_rgb([xyz[0] * scale, xyz[1] * scale, xyz[2] * scale])
}

/// Emitted radiance of a blackbody at `temperature` kelvin for each
/// wavelength in nm (pbrt-v3 `Blackbody`, in single precision like pbrt-v3).
pub fn blackbody(lambda: &[f32], temperature: f32) -> Vec<f32> {
    if temperature <= 0.0 {
        return vec![0.0; lambda.len()];
    }
    let c: f32 = 299_792_458.0;
    let h: f32 = 6.626_069_6e-34;
    let kb: f32 = 1.380_648_8e-23;
    lambda
        .iter()
        .map(|&l_nm| {
            let l = l_nm * 1e-9;
            let lambda5 = (l * l) * (l * l) * l;
            (2.0 * h * c * c) / (lambda5 * (math::exp((h * c) / (l * kb * temperature)) - 1.0))
        })
        .collect()
}

/// [`blackbody`] divided by its value at the peak wavelength (Wien's law),
/// as pbrt-v3's `BlackbodyNormalized`.
pub fn blackbody_normalized(lambda: &[f32], temperature: f32) -> Vec<f32> {
    let mut le = blackbody(lambda, temperature);
    if temperature <= 0.0 {
        // pbrt-v3 divides 0 by 0 here; black is the sensible answer.
        return le;
    }
    let lambda_max = 2.897_772e-3 / temperature * 1e9;
    let max_l = blackbody(&[lambda_max], temperature)[0];
    for v in &mut le {
        *v /= max_l;
    }
    le
}

/// RGB of pbrt-v3's normalised blackbody at `temperature` kelvin, times
/// `scale`: the blackbody is sampled at the CIE wavelengths and converted
/// with [`sampled_to_rgb`], as pbrt-v3's `"blackbody"` parameters are.
pub fn blackbody_rgb(temperature: f32, scale: f32) -> Spectrum {
    let lambda: Vec<f32> = (0..N_CIE_SAMPLES).map(cie_lambda).collect();
    let le = blackbody_normalized(&lambda, temperature);
    sampled_to_rgb(&lambda, &le) * scale
}

/// Linear sRGB-primaries RGB from CIE XYZ (pbrt-v3 `XYZToRGB`).
pub fn xyz_to_rgb(xyz: [f32; 3]) -> Spectrum {
    Spectrum::new(
        3.240479 * xyz[0] - 1.53715 * xyz[1] - 0.498535 * xyz[2],
        -0.969256 * xyz[0] + 1.875991 * xyz[1] + 0.041556 * xyz[2],
        0.055648 * xyz[0] - 0.204043 * xyz[1] + 1.057311 * xyz[2],
    )
}

/// Copper's index of refraction as RGB (`Material "metal"`'s default `eta`).
pub fn copper_eta() -> Spectrum {
    sampled_to_rgb(&COPPER_WAVELENGTHS, &COPPER_N)
}

/// Copper's absorption coefficient as RGB (`Material "metal"`'s default `k`).
pub fn copper_k() -> Spectrum {
    sampled_to_rgb(&COPPER_WAVELENGTHS, &COPPER_K)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn tables_integrate_to_pbrt_constant() {
        let sy: f32 = CIE_Y.iter().sum();
        assert!((sy - CIE_Y_INTEGRAL).abs() < 1e-3, "{sy}");
        // Equal-energy white: the three functions have (nearly) equal integrals.
        let sx: f32 = CIE_X.iter().sum();
        let sz: f32 = CIE_Z.iter().sum();
        assert!((sx / sy - 1.0).abs() < 1e-3, "{sx}");
        assert!((sz / sy - 1.0).abs() < 2e-3, "{sz}");
        assert_eq!(CIE_Z[N_CIE_SAMPLES - 1], 0.0);
    }

    #[test]
    fn constant_spectrum_is_equal_energy_white() {
        // A flat spectrum is CIE illuminant E: XYZ ≈ (1, 1, 1), whose sRGB
        // is not (1, 1, 1) but the row sums of the XYZ-to-RGB matrix.
        let rgb = sampled_to_rgb(&[400.0, 700.0], &[1.0, 1.0]);
        let e = xyz_to_rgb([1.0, 1.0, 1.0]);
        for (c, w) in rgb.to_array().into_iter().zip(e.to_array()) {
            assert!((c / w - 1.0).abs() < 0.01, "{rgb:?}");
        }
        assert!((rgb.y() - 1.0).abs() < 0.01, "{rgb:?}");
        let unsorted = sampled_to_rgb(&[700.0, 400.0, 550.0], &[2.0, 2.0, 2.0]);
        assert!((unsorted.g - 2.0 * rgb.g).abs() < 1e-4, "{unsorted:?}");
    }

    #[test]
    fn blackbody_6500_is_nearly_neutral() {
        let rgb = blackbody_rgb(6500.0, 1.0);
        let m = rgb.max_component();
        assert!(m > 0.5, "{rgb:?}");
        for c in rgb.to_array() {
            assert!((c / m) > 0.85, "{rgb:?}");
        }
        let warm = blackbody_rgb(2700.0, 1.0);
        assert!(warm.r > warm.g && warm.g > warm.b, "{warm:?}");
        assert_eq!(blackbody_rgb(0.0, 1.0), Spectrum::ZERO);
    }

    #[test]
    fn copper_is_reddish() {
        let eta = copper_eta();
        let k = copper_k();
        assert!(eta.r < eta.g && eta.g < eta.b, "{eta:?}");
        assert!(k.r > k.b, "{k:?}");
        // pbrt-v3's copper RGB: eta ≈ (0.2, 0.92, 1.1), k ≈ (3.9, 2.45, 2.14).
        assert!((eta.r - 0.2).abs() < 0.05 && (k.r - 3.9).abs() < 0.2, "{eta:?} {k:?}");
    }
}
