//! `Material "translucent"` (pbrt-v3 `TranslucentMaterial`): diffuse and
//! glossy reflection and transmission.

use super::create::MaterialParams;
use crate::bxdf::{
    roughness_to_alpha, Bsdf, BxDF, Fresnel, LambertianReflection, LambertianTransmission,
    MicrofacetDistribution, MicrofacetReflection, MicrofacetTransmission, TransportMode,
};
use crate::interaction::SurfaceInteraction;
use crate::textures::{TexInput, TextureSet};
use farm_common::scene::Warning;
use farm_common::Spectrum;

/// A thin translucent surface.
#[derive(Clone, Debug, PartialEq)]
pub struct Translucent {
    /// `Kd` (default 0.25).
    pub kd: TexInput<Spectrum>,
    /// `Ks` (default 0.25).
    pub ks: TexInput<Spectrum>,
    /// `reflect` (default 0.5).
    pub reflect: TexInput<Spectrum>,
    /// `transmit` (default 0.5).
    pub transmit: TexInput<Spectrum>,
    /// `roughness` (default 0.1).
    pub roughness: TexInput<f32>,
    /// `remaproughness` (default true).
    pub remap_roughness: bool,
    /// `bumpmap`.
    pub bump: Option<TexInput<f32>>,
}

impl Translucent {
    /// The BSDF at `si`.
    pub fn bsdf(&self, si: &SurfaceInteraction, t: &TextureSet, mode: TransportMode) -> Bsdf<'_> {
        let eta = 1.5;
        let mut bsdf = Bsdf::new(si, eta);
        let clamp = |s: Spectrum| s.clamp(0.0, f32::INFINITY);
        let r = clamp(t.eval(&self.reflect, si));
        let tr = clamp(t.eval(&self.transmit, si));
        if r.is_black() && tr.is_black() {
            return bsdf;
        }
        let kd = clamp(t.eval(&self.kd, si));
        if !kd.is_black() {
            if !r.is_black() {
                bsdf.add(BxDF::LambertianReflection(LambertianReflection { r: r * kd }));
            }
            if !tr.is_black() {
                bsdf.add(BxDF::LambertianTransmission(LambertianTransmission { t: tr * kd }));
            }
        }
        let ks = clamp(t.eval(&self.ks, si));
        if !ks.is_black() && (!r.is_black() || !tr.is_black()) {
            let mut rough = t.eval(&self.roughness, si);
            if self.remap_roughness {
                rough = roughness_to_alpha(rough);
            }
            let distribution = MicrofacetDistribution::trowbridge_reitz(rough, rough);
            if !r.is_black() {
                let fresnel = Fresnel::Dielectric { eta_i: 1.0, eta_t: eta };
                bsdf.add(BxDF::MicrofacetReflection(MicrofacetReflection {
                    r: r * ks,
                    distribution,
                    fresnel,
                }));
            }
            if !tr.is_black() {
                bsdf.add(BxDF::MicrofacetTransmission(MicrofacetTransmission {
                    t: tr * ks,
                    distribution,
                    eta_a: 1.0,
                    eta_b: eta,
                    mode,
                }));
            }
        }
        bsdf
    }
}

impl Translucent {
    /// A `Material "translucent"` with pbrt-v3's parameters and defaults (`CreateTranslucentMaterial`).
    pub(super) fn create(m: MaterialParams, w: &mut Vec<Warning>) -> Self {
        Translucent {
            kd: m.s("Kd", 0.25, w),
            ks: m.s("Ks", 0.25, w),
            reflect: m.s("reflect", 0.5, w),
            transmit: m.s("transmit", 0.5, w),
            roughness: m.f("roughness", 0.1, w),
            remap_roughness: m.remap,
            bump: m.bump,
        }
    }
}
