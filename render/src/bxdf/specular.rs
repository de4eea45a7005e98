//! Perfectly specular lobes (pbrt-v3 `SpecularReflection`,
//! `SpecularTransmission`, `FresnelSpecular`). Their `f` and `pdf` are zero:
//! only sampling can find the delta direction.

use super::fresnel::{fr_dielectric, Fresnel};
use super::reflection::{abs_cos_theta, cos_theta, face_forward, refract};
use super::{BxDFSample, BxDFType, TransportMode};
use farm_common::geometry::{Vec2, Vec3};
use farm_common::Spectrum;

/// Mirror reflection scaled by `r` and a Fresnel term.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct SpecularReflection {
    /// Reflectance scale.
    pub r: Spectrum,
    /// Fresnel term.
    pub fresnel: Fresnel,
}

impl SpecularReflection {
    /// Zero: a delta lobe.
    #[inline]
    pub fn f(&self, _wo: Vec3, _wi: Vec3) -> Spectrum {
        Spectrum::ZERO
    }
    /// The mirror direction with probability one.
    #[inline]
    pub fn sample_f(&self, wo: Vec3, _u: Vec2, ty: BxDFType) -> Option<BxDFSample> {
        let wi = Vec3::new(-wo.x, -wo.y, wo.z);
        let f = self.fresnel.evaluate(cos_theta(wi)) * self.r / abs_cos_theta(wi);
        Some(BxDFSample { f, wi, pdf: 1.0, sampled_type: ty })
    }
    /// Zero: a delta lobe.
    #[inline]
    pub fn pdf(&self, _wo: Vec3, _wi: Vec3) -> f32 {
        0.0
    }
}

/// Refraction through a dielectric boundary between `eta_a` (outside, +z)
/// and `eta_b` (inside).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct SpecularTransmission {
    /// Transmittance scale.
    pub t: Spectrum,
    /// Index above the surface.
    pub eta_a: f32,
    /// Index below the surface.
    pub eta_b: f32,
    /// Radiance or importance (radiance is scaled by (ηi/ηt)²).
    pub mode: TransportMode,
}

impl SpecularTransmission {
    /// Zero: a delta lobe.
    #[inline]
    pub fn f(&self, _wo: Vec3, _wi: Vec3) -> Spectrum {
        Spectrum::ZERO
    }
    /// The refracted direction with probability one; `None` on total internal reflection.
    pub fn sample_f(&self, wo: Vec3, _u: Vec2, ty: BxDFType) -> Option<BxDFSample> {
        let entering = cos_theta(wo) > 0.0;
        let (eta_i, eta_t) =
            if entering { (self.eta_a, self.eta_b) } else { (self.eta_b, self.eta_a) };
        let wi = refract(wo, face_forward(Vec3::Z, wo), eta_i / eta_t)?;
        let fresnel = Fresnel::Dielectric { eta_i: self.eta_a, eta_t: self.eta_b };
        let mut ft = self.t * (Spectrum::ONE - fresnel.evaluate(cos_theta(wi)));
        if self.mode == TransportMode::Radiance {
            ft *= (eta_i * eta_i) / (eta_t * eta_t);
        }
        Some(BxDFSample { f: ft / abs_cos_theta(wi), wi, pdf: 1.0, sampled_type: ty })
    }
    /// Zero: a delta lobe.
    #[inline]
    pub fn pdf(&self, _wo: Vec3, _wi: Vec3) -> f32 {
        0.0
    }
}

/// Specular reflection or transmission, chosen in proportion to the
/// dielectric Fresnel reflectance.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct FresnelSpecular {
    /// Reflectance scale.
    pub r: Spectrum,
    /// Transmittance scale.
    pub t: Spectrum,
    /// Index above the surface.
    pub eta_a: f32,
    /// Index below the surface.
    pub eta_b: f32,
    /// Radiance or importance.
    pub mode: TransportMode,
}

impl FresnelSpecular {
    /// Zero: a delta lobe.
    #[inline]
    pub fn f(&self, _wo: Vec3, _wi: Vec3) -> Spectrum {
        Spectrum::ZERO
    }
    /// Reflects with probability F, otherwise refracts.
    pub fn sample_f(&self, wo: Vec3, u: Vec2, _ty: BxDFType) -> Option<BxDFSample> {
        let f = fr_dielectric(cos_theta(wo), self.eta_a, self.eta_b);
        if u.x < f {
            let wi = Vec3::new(-wo.x, -wo.y, wo.z);
            return Some(BxDFSample {
                f: self.r * f / abs_cos_theta(wi),
                wi,
                pdf: f,
                sampled_type: BxDFType::SPECULAR | BxDFType::REFLECTION,
            });
        }
        let entering = cos_theta(wo) > 0.0;
        let (eta_i, eta_t) =
            if entering { (self.eta_a, self.eta_b) } else { (self.eta_b, self.eta_a) };
        let wi = refract(wo, face_forward(Vec3::Z, wo), eta_i / eta_t)?;
        let mut ft = self.t * (1.0 - f);
        if self.mode == TransportMode::Radiance {
            ft *= (eta_i * eta_i) / (eta_t * eta_t);
        }
        let pdf = 1.0 - f;
        (pdf > 0.0).then(|| BxDFSample {
            f: ft / abs_cos_theta(wi),
            wi,
            pdf,
            sampled_type: BxDFType::SPECULAR | BxDFType::TRANSMISSION,
        })
    }
    /// Zero: a delta lobe.
    #[inline]
    pub fn pdf(&self, _wo: Vec3, _wi: Vec3) -> f32 {
        0.0
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn transmission_scales_radiance_by_eta_ratio() {
        let wo = Vec3::new(0.3, 0.2, 0.5).normalize();
        let mk = |mode| SpecularTransmission { t: Spectrum::ONE, eta_a: 1.0, eta_b: 1.5, mode };
        let ty = BxDFType::TRANSMISSION | BxDFType::SPECULAR;
        let r = mk(TransportMode::Radiance).sample_f(wo, Vec2::ZERO, ty).unwrap();
        let i = mk(TransportMode::Importance).sample_f(wo, Vec2::ZERO, ty).unwrap();
        assert!((r.f.g / i.f.g - 1.0 / 2.25).abs() < 1e-5);
        assert!(r.wi.z < 0.0 && r.pdf == 1.0);
        // The importance value is (1 - F) / |cos θi|.
        let f = fr_dielectric(r.wi.z, 1.0, 1.5);
        assert!((i.f.r - (1.0 - f) / r.wi.z.abs()).abs() < 1e-5);
    }

    #[test]
    fn fresnel_specular_chooses_by_reflectance() {
        let b = FresnelSpecular {
            r: Spectrum::ONE,
            t: Spectrum::ONE,
            eta_a: 1.0,
            eta_b: 1.5,
            mode: TransportMode::Radiance,
        };
        let wo = Vec3::Z;
        let refl = b.sample_f(wo, Vec2::new(0.01, 0.5), BxDFType::ALL).unwrap();
        assert!((refl.pdf - 0.04).abs() < 1e-5);
        assert!(refl.sampled_type.contains_any(BxDFType::REFLECTION));
        let tr = b.sample_f(wo, Vec2::new(0.5, 0.5), BxDFType::ALL).unwrap();
        assert!((tr.pdf - 0.96).abs() < 1e-5 && tr.wi.z < -0.999);
    }
}
