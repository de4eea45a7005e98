//! `Material "metal"` (pbrt-v3 `MetalMaterial`): a rough conductor, copper
//! by default.

use super::create::MaterialParams;
use crate::bxdf::{
    roughness_to_alpha, Bsdf, BxDF, Fresnel, MicrofacetDistribution, MicrofacetReflection,
};
use crate::interaction::SurfaceInteraction;
use crate::textures::{TexInput, TextureSet};
use farm_common::cie::{copper_eta, copper_k};
use farm_common::scene::Warning;
use farm_common::Spectrum;

/// A conductor.
#[derive(Clone, Debug, PartialEq)]
pub struct Metal {
    /// `eta` (default copper).
    pub eta: TexInput<Spectrum>,
    /// `k` (default copper).
    pub k: TexInput<Spectrum>,
    /// `roughness` (default 0.01).
    pub roughness: TexInput<f32>,
    /// `uroughness`, overriding `roughness` along u.
    pub u_roughness: Option<TexInput<f32>>,
    /// `vroughness`, overriding `roughness` along v.
    pub v_roughness: Option<TexInput<f32>>,
    /// `remaproughness` (default true).
    pub remap_roughness: bool,
    /// `bumpmap`.
    pub bump: Option<TexInput<f32>>,
}

impl Metal {
    /// The BSDF at `si`.
    pub fn bsdf(&self, si: &SurfaceInteraction, t: &TextureSet) -> Bsdf<'_> {
        let mut bsdf = Bsdf::new(si, 1.0);
        let mut u = t.eval(self.u_roughness.as_ref().unwrap_or(&self.roughness), si);
        let mut v = t.eval(self.v_roughness.as_ref().unwrap_or(&self.roughness), si);
        if self.remap_roughness {
            u = roughness_to_alpha(u);
            v = roughness_to_alpha(v);
        }
        let fresnel = Fresnel::Conductor {
            eta_i: Spectrum::ONE,
            eta_t: t.eval(&self.eta, si),
            k: t.eval(&self.k, si),
        };
        bsdf.add(BxDF::MicrofacetReflection(MicrofacetReflection {
            r: Spectrum::ONE,
            distribution: MicrofacetDistribution::trowbridge_reitz(u, v),
            fresnel,
        }));
        bsdf
    }
}

impl Metal {
    /// A `Material "metal"` with pbrt-v3's parameters and defaults (`CreateMetalMaterial`).
    pub(super) fn create(m: MaterialParams, w: &mut Vec<Warning>) -> Self {
        Metal {
            eta: m.spectrum("eta", copper_eta(), w),
            k: m.spectrum("k", copper_k(), w),
            roughness: m.f("roughness", 0.01, w),
            u_roughness: m.opt("uroughness", w),
            v_roughness: m.opt("vroughness", w),
            remap_roughness: m.remap,
            bump: m.bump,
        }
    }
}
