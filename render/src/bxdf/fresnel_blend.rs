//! Ashikhmin–Shirley's diffuse substrate under a glossy coat (pbrt-v3
//! `FresnelBlend`), used by `Material "substrate"`.

use super::microfacet::MicrofacetDistribution;
use super::reflection::{abs_cos_theta, reflect, same_hemisphere, ONE_MINUS_EPSILON};
use super::{cosine_sample, BxDFSample, BxDFType};
use farm_common::geometry::{Vec2, Vec3};
use farm_common::Spectrum;
use std::f32::consts::{FRAC_1_PI, PI};

/// Diffuse `rd` under a glossy layer of normal-incidence reflectance `rs`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct FresnelBlend {
    /// Diffuse reflectance.
    pub rd: Spectrum,
    /// Specular reflectance at normal incidence.
    pub rs: Spectrum,
    /// Distribution of the glossy layer.
    pub distribution: MicrofacetDistribution,
}

#[inline]
fn pow5(v: f32) -> f32 {
    (v * v) * (v * v) * v
}

impl FresnelBlend {
    /// Schlick's approximation of the coat's Fresnel reflectance.
    #[inline]
    pub fn schlick_fresnel(&self, cos_theta: f32) -> Spectrum {
        self.rs + (Spectrum::ONE - self.rs) * pow5(1.0 - cos_theta)
    }
    /// Diffuse plus glossy value.
    pub fn f(&self, wo: Vec3, wi: Vec3) -> Spectrum {
        let diffuse = self.rd
            * (Spectrum::ONE - self.rs)
            * (28.0 / (23.0 * PI))
            * (1.0 - pow5(1.0 - 0.5 * abs_cos_theta(wi)))
            * (1.0 - pow5(1.0 - 0.5 * abs_cos_theta(wo)));
        let wh = wi + wo;
        if wh == Vec3::ZERO {
            return Spectrum::ZERO;
        }
        let wh = wh.normalize();
        let specular = self.schlick_fresnel(wi.dot(wh))
            * (self.distribution.d(wh)
                / (4.0 * wi.dot(wh).abs() * abs_cos_theta(wi).max(abs_cos_theta(wo))));
        diffuse + specular
    }
    /// Half the samples cosine-weighted, half from the microfacet distribution.
    pub fn sample_f(&self, wo: Vec3, u: Vec2, ty: BxDFType) -> Option<BxDFSample> {
        let wi = if u.x < 0.5 {
            cosine_sample(wo, Vec2::new((2.0 * u.x).min(ONE_MINUS_EPSILON), u.y))
        } else {
            let u2 = Vec2::new((2.0 * (u.x - 0.5)).min(ONE_MINUS_EPSILON), u.y);
            let wh = self.distribution.sample_wh(wo, u2);
            let wi = reflect(wo, wh);
            if !same_hemisphere(wo, wi) {
                return None;
            }
            wi
        };
        let pdf = self.pdf(wo, wi);
        (pdf > 0.0).then(|| BxDFSample { f: self.f(wo, wi), wi, pdf, sampled_type: ty })
    }
    /// The mixture's density.
    pub fn pdf(&self, wo: Vec3, wi: Vec3) -> f32 {
        if !same_hemisphere(wo, wi) {
            return 0.0;
        }
        let wh = (wo + wi).normalize();
        let pdf_wh = self.distribution.pdf(wo, wh);
        0.5 * (abs_cos_theta(wi) * FRAC_1_PI + pdf_wh / (4.0 * wo.dot(wh)))
    }
}
