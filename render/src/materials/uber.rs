//! `Material "uber"` (pbrt-v3 `UberMaterial`): diffuse, glossy, specular
//! reflection and transmission, with partial opacity.

use super::create::MaterialParams;
use crate::bxdf::{
    roughness_to_alpha, Bsdf, BxDF, Fresnel, LambertianReflection, MicrofacetDistribution,
    MicrofacetReflection, SpecularReflection, SpecularTransmission, TransportMode,
};
use crate::interaction::SurfaceInteraction;
use crate::textures::{TexInput, TextureSet};
use farm_common::scene::Warning;
use farm_common::Spectrum;

/// The kitchen-sink material.
#[derive(Clone, Debug, PartialEq)]
pub struct Uber {
    /// `Kd` (default 0.25).
    pub kd: TexInput<Spectrum>,
    /// `Ks` (default 0.25).
    pub ks: TexInput<Spectrum>,
    /// `Kr` (default 0).
    pub kr: TexInput<Spectrum>,
    /// `Kt` (default 0).
    pub kt: TexInput<Spectrum>,
    /// `roughness` (default 0.1).
    pub roughness: TexInput<f32>,
    /// `uroughness`.
    pub u_roughness: Option<TexInput<f32>>,
    /// `vroughness`.
    pub v_roughness: Option<TexInput<f32>>,
    /// `opacity` (default 1).
    pub opacity: TexInput<Spectrum>,
    /// `eta`, or `index` (default 1.5).
    pub eta: TexInput<f32>,
    /// `remaproughness` (default true).
    pub remap_roughness: bool,
    /// `bumpmap`.
    pub bump: Option<TexInput<f32>>,
}

impl Uber {
    /// The BSDF at `si`.
    pub fn bsdf(&self, si: &SurfaceInteraction, t: &TextureSet, mode: TransportMode) -> Bsdf<'_> {
        let clamp = |s: Spectrum| s.clamp(0.0, f32::INFINITY);
        let e = t.eval(&self.eta, si);
        let op = clamp(t.eval(&self.opacity, si));
        let tr = clamp(Spectrum::ONE - op);
        let mut bsdf;
        if !tr.is_black() {
            bsdf = Bsdf::new(si, 1.0);
            bsdf.add(BxDF::SpecularTransmission(SpecularTransmission {
                t: tr,
                eta_a: 1.0,
                eta_b: 1.0,
                mode,
            }));
        } else {
            bsdf = Bsdf::new(si, e);
        }
        let kd = op * clamp(t.eval(&self.kd, si));
        if !kd.is_black() {
            bsdf.add(BxDF::LambertianReflection(LambertianReflection { r: kd }));
        }
        let ks = op * clamp(t.eval(&self.ks, si));
        if !ks.is_black() {
            let mut u = t.eval(self.u_roughness.as_ref().unwrap_or(&self.roughness), si);
            let mut v = t.eval(self.v_roughness.as_ref().unwrap_or(&self.roughness), si);
            if self.remap_roughness {
                u = roughness_to_alpha(u);
                v = roughness_to_alpha(v);
            }
            bsdf.add(BxDF::MicrofacetReflection(MicrofacetReflection {
                r: ks,
                distribution: MicrofacetDistribution::trowbridge_reitz(u, v),
                fresnel: Fresnel::Dielectric { eta_i: 1.0, eta_t: e },
            }));
        }
        let kr = op * clamp(t.eval(&self.kr, si));
        if !kr.is_black() {
            let fresnel = Fresnel::Dielectric { eta_i: 1.0, eta_t: e };
            bsdf.add(BxDF::SpecularReflection(SpecularReflection { r: kr, fresnel }));
        }
        let kt = op * clamp(t.eval(&self.kt, si));
        if !kt.is_black() {
            bsdf.add(BxDF::SpecularTransmission(SpecularTransmission {
                t: kt,
                eta_a: 1.0,
                eta_b: e,
                mode,
            }));
        }
        bsdf
    }
}

impl Uber {
    /// A `Material "uber"` with pbrt-v3's parameters and defaults (`CreateUberMaterial`).
    pub(super) fn create(m: MaterialParams, w: &mut Vec<Warning>) -> Self {
        Uber {
            kd: m.s("Kd", 0.25, w),
            ks: m.s("Ks", 0.25, w),
            kr: m.s("Kr", 0.0, w),
            kt: m.s("Kt", 0.0, w),
            roughness: m.f("roughness", 0.1, w),
            u_roughness: m.opt("uroughness", w),
            v_roughness: m.opt("vroughness", w),
            eta: m.eta(w),
            opacity: m.s("opacity", 1.0, w),
            remap_roughness: m.remap,
            bump: m.bump,
        }
    }
}
