//! Lambertian reflection and transmission (pbrt-v3 `LambertianReflection`,
//! `LambertianTransmission`).

use super::reflection::{abs_cos_theta, same_hemisphere};
use super::{cosine_pdf, cosine_sample, BxDFSample, BxDFType};
use farm_common::geometry::{Vec2, Vec3};
use farm_common::Spectrum;
use std::f32::consts::FRAC_1_PI;

/// Ideal diffuse reflection with albedo `r`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct LambertianReflection {
    /// Reflectance.
    pub r: Spectrum,
}

impl LambertianReflection {
    /// R/π.
    #[inline]
    pub fn f(&self, _wo: Vec3, _wi: Vec3) -> Spectrum {
        self.r * FRAC_1_PI
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

/// Ideal diffuse transmission with transmittance `t`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct LambertianTransmission {
    /// Transmittance.
    pub t: Spectrum,
}

impl LambertianTransmission {
    /// T/π.
    #[inline]
    pub fn f(&self, _wo: Vec3, _wi: Vec3) -> Spectrum {
        self.t * FRAC_1_PI
    }
    /// Cosine-weighted sampling on the side opposite `wo`.
    #[inline]
    pub fn sample_f(&self, wo: Vec3, u: Vec2, ty: BxDFType) -> Option<BxDFSample> {
        let mut wi = crate::sampling::cosine_sample_hemisphere(u);
        if wo.z > 0.0 {
            wi.z = -wi.z;
        }
        let pdf = self.pdf(wo, wi);
        (pdf > 0.0).then(|| BxDFSample { f: self.f(wo, wi), wi, pdf, sampled_type: ty })
    }
    /// Cosine density on the far side.
    #[inline]
    pub fn pdf(&self, wo: Vec3, wi: Vec3) -> f32 {
        if same_hemisphere(wo, wi) {
            0.0
        } else {
            abs_cos_theta(wi) * FRAC_1_PI
        }
    }
}
