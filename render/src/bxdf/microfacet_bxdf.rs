//! Microfacet reflection (Torrance–Sparrow) and transmission (Walter et
//! al.), pbrt-v3 `MicrofacetReflection` and `MicrofacetTransmission`.

use super::fresnel::Fresnel;
use super::microfacet::MicrofacetDistribution;
use super::reflection::{
    abs_cos_theta, cos_theta, face_forward, reflect, refract, same_hemisphere,
};
use super::{BxDFSample, BxDFType, TransportMode};
use farm_common::geometry::{Vec2, Vec3};
use farm_common::Spectrum;

/// Glossy reflection from a rough interface.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct MicrofacetReflection {
    /// Reflectance scale.
    pub r: Spectrum,
    /// Microfacet distribution.
    pub distribution: MicrofacetDistribution,
    /// Fresnel term.
    pub fresnel: Fresnel,
}

impl MicrofacetReflection {
    /// D G F / (4 cos θo cos θi).
    pub fn f(&self, wo: Vec3, wi: Vec3) -> Spectrum {
        let cos_o = abs_cos_theta(wo);
        let cos_i = abs_cos_theta(wi);
        let wh = wi + wo;
        if cos_i == 0.0 || cos_o == 0.0 {
            return Spectrum::ZERO;
        }
        if wh == Vec3::ZERO {
            return Spectrum::ZERO;
        }
        let wh = wh.normalize();
        let f = self.fresnel.evaluate(wi.dot(face_forward(wh, Vec3::Z)));
        self.r * (self.distribution.d(wh) * self.distribution.g(wo, wi)) * f / (4.0 * cos_i * cos_o)
    }
    /// Samples a microfacet normal and reflects `wo` about it.
    pub fn sample_f(&self, wo: Vec3, u: Vec2, ty: BxDFType) -> Option<BxDFSample> {
        if wo.z == 0.0 {
            return None;
        }
        let wh = self.distribution.sample_wh(wo, u);
        if wo.dot(wh) < 0.0 {
            return None;
        }
        let wi = reflect(wo, wh);
        if !same_hemisphere(wo, wi) {
            return None;
        }
        let pdf = self.distribution.pdf(wo, wh) / (4.0 * wo.dot(wh));
        (pdf > 0.0).then(|| BxDFSample { f: self.f(wo, wi), wi, pdf, sampled_type: ty })
    }
    /// Density of [`Self::sample_f`].
    pub fn pdf(&self, wo: Vec3, wi: Vec3) -> f32 {
        if !same_hemisphere(wo, wi) {
            return 0.0;
        }
        let wh = (wo + wi).normalize();
        self.distribution.pdf(wo, wh) / (4.0 * wo.dot(wh))
    }
}

/// Glossy transmission through a rough dielectric between `eta_a` (outside)
/// and `eta_b` (inside).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct MicrofacetTransmission {
    /// Transmittance scale.
    pub t: Spectrum,
    /// Microfacet distribution.
    pub distribution: MicrofacetDistribution,
    /// Index above the surface.
    pub eta_a: f32,
    /// Index below the surface.
    pub eta_b: f32,
    /// Radiance or importance.
    pub mode: TransportMode,
}

impl MicrofacetTransmission {
    /// Walter et al.'s BTDF.
    pub fn f(&self, wo: Vec3, wi: Vec3) -> Spectrum {
        if same_hemisphere(wo, wi) {
            return Spectrum::ZERO;
        }
        let cos_o = cos_theta(wo);
        let cos_i = cos_theta(wi);
        if cos_i == 0.0 || cos_o == 0.0 {
            return Spectrum::ZERO;
        }
        let eta =
            if cos_theta(wo) > 0.0 { self.eta_b / self.eta_a } else { self.eta_a / self.eta_b };
        let mut wh = (wo + wi * eta).normalize();
        if wh.z < 0.0 {
            wh = -wh;
        }
        if wo.dot(wh) * wi.dot(wh) > 0.0 {
            return Spectrum::ZERO;
        }
        let fresnel = Fresnel::Dielectric { eta_i: self.eta_a, eta_t: self.eta_b };
        let f = fresnel.evaluate(wo.dot(wh));
        let sqrt_denom = wo.dot(wh) + eta * wi.dot(wh);
        let factor = if self.mode == TransportMode::Radiance { 1.0 / eta } else { 1.0 };
        let d = self.distribution;
        (Spectrum::ONE - f)
            * self.t
            * (d.d(wh)
                * d.g(wo, wi)
                * eta
                * eta
                * wi.dot(wh).abs()
                * wo.dot(wh).abs()
                * factor
                * factor
                / (cos_i * cos_o * sqrt_denom * sqrt_denom))
                .abs()
    }
    /// Samples a microfacet normal and refracts `wo` through it.
    pub fn sample_f(&self, wo: Vec3, u: Vec2, ty: BxDFType) -> Option<BxDFSample> {
        if wo.z == 0.0 {
            return None;
        }
        let wh = self.distribution.sample_wh(wo, u);
        if wo.dot(wh) < 0.0 {
            return None;
        }
        let eta =
            if cos_theta(wo) > 0.0 { self.eta_a / self.eta_b } else { self.eta_b / self.eta_a };
        let wi = refract(wo, wh, eta)?;
        let pdf = self.pdf(wo, wi);
        (pdf > 0.0).then(|| BxDFSample { f: self.f(wo, wi), wi, pdf, sampled_type: ty })
    }
    /// Density of [`Self::sample_f`].
    pub fn pdf(&self, wo: Vec3, wi: Vec3) -> f32 {
        if same_hemisphere(wo, wi) {
            return 0.0;
        }
        let eta =
            if cos_theta(wo) > 0.0 { self.eta_b / self.eta_a } else { self.eta_a / self.eta_b };
        let wh = (wo + wi * eta).normalize();
        if wo.dot(wh) * wi.dot(wh) > 0.0 {
            return 0.0;
        }
        let sqrt_denom = wo.dot(wh) + eta * wi.dot(wh);
        let dwh_dwi = ((eta * eta * wi.dot(wh)) / (sqrt_denom * sqrt_denom)).abs();
        self.distribution.pdf(wo, wh) * dwh_dwi
    }
}
