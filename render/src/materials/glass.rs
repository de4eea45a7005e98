//! `Material "glass"` (pbrt-v3 `GlassMaterial`): specular or rough dielectric.

use super::create::MaterialParams;
use crate::bxdf::{
    roughness_to_alpha, Bsdf, BxDF, Fresnel, FresnelSpecular, MicrofacetDistribution,
    MicrofacetReflection, MicrofacetTransmission, SpecularReflection, SpecularTransmission,
    TransportMode,
};
use crate::interaction::SurfaceInteraction;
use crate::textures::{TexInput, TextureSet};
use farm_common::scene::Warning;
use farm_common::Spectrum;

/// A dielectric boundary.
#[derive(Clone, Debug, PartialEq)]
pub struct Glass {
    /// `Kr` (default 1).
    pub kr: TexInput<Spectrum>,
    /// `Kt` (default 1).
    pub kt: TexInput<Spectrum>,
    /// `eta`, or `index` (default 1.5).
    pub eta: TexInput<f32>,
    /// `uroughness` (default 0).
    pub u_roughness: TexInput<f32>,
    /// `vroughness` (default 0).
    pub v_roughness: TexInput<f32>,
    /// `remaproughness` (default true).
    pub remap_roughness: bool,
    /// `bumpmap`.
    pub bump: Option<TexInput<f32>>,
}

impl Glass {
    /// The BSDF at `si`. With `allow_multiple_lobes` false (Whitted),
    /// specular glass gets separate reflection and transmission lobes.
    pub fn bsdf(
        &self,
        si: &SurfaceInteraction,
        t: &TextureSet,
        mode: TransportMode,
        allow: bool,
    ) -> Bsdf<'_> {
        let eta = t.eval(&self.eta, si);
        let mut urough = t.eval(&self.u_roughness, si);
        let mut vrough = t.eval(&self.v_roughness, si);
        let r = t.eval(&self.kr, si).clamp(0.0, f32::INFINITY);
        let tr = t.eval(&self.kt, si).clamp(0.0, f32::INFINITY);
        let mut bsdf = Bsdf::new(si, eta);
        if r.is_black() && tr.is_black() {
            return bsdf;
        }
        let specular = urough == 0.0 && vrough == 0.0;
        if specular && allow {
            bsdf.add(BxDF::FresnelSpecular(FresnelSpecular {
                r,
                t: tr,
                eta_a: 1.0,
                eta_b: eta,
                mode,
            }));
            return bsdf;
        }
        if self.remap_roughness {
            urough = roughness_to_alpha(urough);
            vrough = roughness_to_alpha(vrough);
        }
        let distribution = MicrofacetDistribution::trowbridge_reitz(urough, vrough);
        if !r.is_black() {
            let fresnel = Fresnel::Dielectric { eta_i: 1.0, eta_t: eta };
            bsdf.add(if specular {
                BxDF::SpecularReflection(SpecularReflection { r, fresnel })
            } else {
                BxDF::MicrofacetReflection(MicrofacetReflection { r, distribution, fresnel })
            });
        }
        if !tr.is_black() {
            bsdf.add(if specular {
                BxDF::SpecularTransmission(SpecularTransmission {
                    t: tr,
                    eta_a: 1.0,
                    eta_b: eta,
                    mode,
                })
            } else {
                BxDF::MicrofacetTransmission(MicrofacetTransmission {
                    t: tr,
                    distribution,
                    eta_a: 1.0,
                    eta_b: eta,
                    mode,
                })
            });
        }
        bsdf
    }
}

impl Glass {
    /// A `Material "glass"` with pbrt-v3's parameters and defaults (`CreateGlassMaterial`).
    pub(super) fn create(m: MaterialParams, w: &mut Vec<Warning>) -> Self {
        Glass {
            kr: m.s("Kr", 1.0, w),
            kt: m.s("Kt", 1.0, w),
            eta: m.eta(w),
            u_roughness: m.f("uroughness", 0.0, w),
            v_roughness: m.f("vroughness", 0.0, w),
            remap_roughness: m.remap,
            bump: m.bump,
        }
    }
}
