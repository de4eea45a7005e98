//! `Material "substrate"` (pbrt-v3 `SubstrateMaterial`): Ashikhmin–Shirley
//! coated diffuse.

use super::create::MaterialParams;
use crate::bxdf::{roughness_to_alpha, Bsdf, BxDF, FresnelBlend, MicrofacetDistribution};
use crate::interaction::SurfaceInteraction;
use crate::textures::{TexInput, TextureSet};
use farm_common::scene::Warning;
use farm_common::Spectrum;

/// A glossy coat over a diffuse base.
#[derive(Clone, Debug, PartialEq)]
pub struct Substrate {
    /// `Kd` (default 0.5).
    pub kd: TexInput<Spectrum>,
    /// `Ks` (default 0.5).
    pub ks: TexInput<Spectrum>,
    /// `uroughness` (default 0.1).
    pub u_roughness: TexInput<f32>,
    /// `vroughness` (default 0.1).
    pub v_roughness: TexInput<f32>,
    /// `remaproughness` (default true).
    pub remap_roughness: bool,
    /// `bumpmap`.
    pub bump: Option<TexInput<f32>>,
}

impl Substrate {
    /// The BSDF at `si`.
    pub fn bsdf(&self, si: &SurfaceInteraction, t: &TextureSet) -> Bsdf<'_> {
        let mut bsdf = Bsdf::new(si, 1.0);
        let d = t.eval(&self.kd, si).clamp(0.0, f32::INFINITY);
        let s = t.eval(&self.ks, si).clamp(0.0, f32::INFINITY);
        let mut u = t.eval(&self.u_roughness, si);
        let mut v = t.eval(&self.v_roughness, si);
        if !d.is_black() || !s.is_black() {
            if self.remap_roughness {
                u = roughness_to_alpha(u);
                v = roughness_to_alpha(v);
            }
            let distribution = MicrofacetDistribution::trowbridge_reitz(u, v);
            bsdf.add(BxDF::FresnelBlend(FresnelBlend { rd: d, rs: s, distribution }));
        }
        bsdf
    }
}

impl Substrate {
    /// A `Material "substrate"` with pbrt-v3's parameters and defaults (`CreateSubstrateMaterial`).
    pub(super) fn create(m: MaterialParams, w: &mut Vec<Warning>) -> Self {
        Substrate {
            kd: m.s("Kd", 0.5, w),
            ks: m.s("Ks", 0.5, w),
            u_roughness: m.f("uroughness", 0.1, w),
            v_roughness: m.f("vroughness", 0.1, w),
            remap_roughness: m.remap,
            bump: m.bump,
        }
    }
}
