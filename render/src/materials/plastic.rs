//! `Material "plastic"` (pbrt-v3 `PlasticMaterial`): diffuse plus a glossy
//! dielectric coat (η = 1.5).

use super::create::MaterialParams;
use crate::bxdf::{
    roughness_to_alpha, Bsdf, BxDF, Fresnel, LambertianReflection, MicrofacetDistribution,
    MicrofacetReflection,
};
use crate::interaction::SurfaceInteraction;
use crate::textures::{TexInput, TextureSet};
use farm_common::scene::Warning;
use farm_common::Spectrum;

/// Diffuse and glossy reflection.
#[derive(Clone, Debug, PartialEq)]
pub struct Plastic {
    /// `Kd` (default 0.25).
    pub kd: TexInput<Spectrum>,
    /// `Ks` (default 0.25).
    pub ks: TexInput<Spectrum>,
    /// `roughness` (default 0.1).
    pub roughness: TexInput<f32>,
    /// `remaproughness` (default true).
    pub remap_roughness: bool,
    /// `bumpmap`.
    pub bump: Option<TexInput<f32>>,
}

impl Plastic {
    /// The BSDF at `si`.
    pub fn bsdf(&self, si: &SurfaceInteraction, t: &TextureSet) -> Bsdf<'_> {
        let mut bsdf = Bsdf::new(si, 1.0);
        let kd = t.eval(&self.kd, si).clamp(0.0, f32::INFINITY);
        if !kd.is_black() {
            bsdf.add(BxDF::LambertianReflection(LambertianReflection { r: kd }));
        }
        let ks = t.eval(&self.ks, si).clamp(0.0, f32::INFINITY);
        if !ks.is_black() {
            let mut rough = t.eval(&self.roughness, si);
            if self.remap_roughness {
                rough = roughness_to_alpha(rough);
            }
            bsdf.add(BxDF::MicrofacetReflection(MicrofacetReflection {
                r: ks,
                distribution: MicrofacetDistribution::trowbridge_reitz(rough, rough),
                fresnel: Fresnel::Dielectric { eta_i: 1.5, eta_t: 1.0 },
            }));
        }
        bsdf
    }
}

impl Plastic {
    /// A `Material "plastic"` with pbrt-v3's parameters and defaults (`CreatePlasticMaterial`).
    pub(super) fn create(m: MaterialParams, w: &mut Vec<Warning>) -> Self {
        Plastic {
            kd: m.s("Kd", 0.25, w),
            ks: m.s("Ks", 0.25, w),
            roughness: m.f("roughness", 0.1, w),
            remap_roughness: m.remap,
            bump: m.bump,
        }
    }
}
