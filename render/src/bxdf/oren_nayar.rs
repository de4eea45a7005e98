//! Oren–Nayar rough diffuse reflection (pbrt-v3 `OrenNayar`).

use super::reflection::{abs_cos_theta, cos_phi, sin_phi, sin_theta};
use super::{cosine_pdf, cosine_sample, BxDFSample, BxDFType};
use farm_common::geometry::{Vec2, Vec3};
use farm_common::Spectrum;
use std::f32::consts::FRAC_1_PI;

/// Oren–Nayar reflection with reflectance `r` and precomputed A, B.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct OrenNayar {
    /// Reflectance.
    pub r: Spectrum,
    /// The model's A term.
    pub a: f32,
    /// The model's B term.
    pub b: f32,
}

impl OrenNayar {
    /// A lobe for facet-slope standard deviation `sigma_degrees`.
    pub fn new(r: Spectrum, sigma_degrees: f32) -> Self {
        let sigma = sigma_degrees.to_radians();
        let s2 = sigma * sigma;
        OrenNayar { r, a: 1.0 - s2 / (2.0 * (s2 + 0.33)), b: 0.45 * s2 / (s2 + 0.09) }
    }
    /// The Oren–Nayar value.
    pub fn f(&self, wo: Vec3, wi: Vec3) -> Spectrum {
        let sin_i = sin_theta(wi);
        let sin_o = sin_theta(wo);
        let mut max_cos = 0.0;
        if sin_i > 1e-4 && sin_o > 1e-4 {
            let d_cos = cos_phi(wi) * cos_phi(wo) + sin_phi(wi) * sin_phi(wo);
            max_cos = d_cos.max(0.0);
        }
        let (sin_alpha, tan_beta) = if abs_cos_theta(wi) > abs_cos_theta(wo) {
            (sin_o, sin_i / abs_cos_theta(wi))
        } else {
            (sin_i, sin_o / abs_cos_theta(wo))
        };
        self.r * FRAC_1_PI * (self.a + self.b * max_cos * sin_alpha * tan_beta)
    }
    /// Cosine-weighted sampling.
    #[inline]
    pub fn sample_f(&self, wo: Vec3, u: Vec2, ty: BxDFType) -> Option<BxDFSample> {
        let wi = cosine_sample(wo, u);
        let pdf = self.pdf(wo, wi);
        (pdf > 0.0).then(|| BxDFSample { f: self.f(wo, wi), wi, pdf, sampled_type: ty })
    }
    /// Cosine density.
    #[inline]
    pub fn pdf(&self, wo: Vec3, wi: Vec3) -> f32 {
        cosine_pdf(wo, wi)
    }
}
