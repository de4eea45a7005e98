//! `Material "disney"` (pbrt-v3 `DisneyMaterial`): Burley's principled
//! BSDF, as pbrt-v3 assembles it from its lobes at each hit. A non-thin
//! surface with a `scatterdistance` also gets pbrt-v3's BSSRDF, which its
//! Whitted integrator ignores; its specular transmission lobe remains.

use super::create::MaterialParams;
use crate::bxdf::disney::schlick_r0_from_eta;
use crate::bxdf::{
    Bsdf, BxDF, DisneyClearcoat, DisneyDiffuse, DisneyFakeSS, DisneyRetro, DisneySheen, Fresnel,
    LambertianTransmission, MicrofacetDistribution, MicrofacetReflection, MicrofacetTransmission,
    SpecularTransmission, TransportMode,
};
use crate::interaction::SurfaceInteraction;
use crate::textures::{TexInput, TextureSet};
use farm_common::scene::Warning;
use farm_common::Spectrum;

/// The principled BSDF's parameters.
#[derive(Clone, Debug, PartialEq)]
pub struct Disney {
    /// `color` (default 0.5).
    pub color: TexInput<Spectrum>,
    /// `metallic` (0).
    pub metallic: TexInput<f32>,
    /// `eta` (1.5).
    pub eta: TexInput<f32>,
    /// `roughness` (0.5).
    pub roughness: TexInput<f32>,
    /// `speculartint` (0).
    pub specular_tint: TexInput<f32>,
    /// `anisotropic` (0).
    pub anisotropic: TexInput<f32>,
    /// `sheen` (0).
    pub sheen: TexInput<f32>,
    /// `sheentint` (0.5).
    pub sheen_tint: TexInput<f32>,
    /// `clearcoat` (0).
    pub clearcoat: TexInput<f32>,
    /// `clearcoatgloss` (1).
    pub clearcoat_gloss: TexInput<f32>,
    /// `spectrans` (0).
    pub spec_trans: TexInput<f32>,
    /// `scatterdistance` (0).
    pub scatter_distance: TexInput<Spectrum>,
    /// `thin` (false).
    pub thin: bool,
    /// `flatness` (0).
    pub flatness: TexInput<f32>,
    /// `difftrans` (1).
    pub diff_trans: TexInput<f32>,
    /// `bumpmap`.
    pub bump: Option<TexInput<f32>>,
}

fn lerp(t: f32, a: Spectrum, b: Spectrum) -> Spectrum {
    a * (1.0 - t) + b * t
}

impl Disney {
    /// The BSDF at `si` (pbrt-v3 `DisneyMaterial::ComputeScatteringFunctions`).
    pub fn bsdf(&self, si: &SurfaceInteraction, t: &TextureSet, mode: TransportMode) -> Bsdf<'_> {
        let mut bsdf = Bsdf::new(si, 1.0);
        let c = t.eval(&self.color, si).clamp(0.0, f32::INFINITY);
        let metallic = t.eval(&self.metallic, si);
        let e = t.eval(&self.eta, si);
        let strans = t.eval(&self.spec_trans, si);
        let diffuse_weight = (1.0 - metallic) * (1.0 - strans);
        // 0: all diffuse is reflected; 1: transmitted.
        let dt = t.eval(&self.diff_trans, si) / 2.0;
        let rough = t.eval(&self.roughness, si);
        let lum = c.y();
        let c_tint = if lum > 0.0 { c / lum } else { Spectrum::ONE };
        let sheen_weight = t.eval(&self.sheen, si);
        let c_sheen = if sheen_weight > 0.0 {
            lerp(t.eval(&self.sheen_tint, si), Spectrum::ONE, c_tint)
        } else {
            Spectrum::ZERO
        };
        if diffuse_weight > 0.0 {
            if self.thin {
                let flat = t.eval(&self.flatness, si);
                let r = c * (diffuse_weight * (1.0 - flat) * (1.0 - dt));
                bsdf.add(BxDF::DisneyDiffuse(DisneyDiffuse { r }));
                let r = c * (diffuse_weight * flat * (1.0 - dt));
                bsdf.add(BxDF::DisneyFakeSS(DisneyFakeSS { r, roughness: rough }));
            } else if t.eval(&self.scatter_distance, si).is_black() {
                bsdf.add(BxDF::DisneyDiffuse(DisneyDiffuse { r: c * diffuse_weight }));
            } else {
                bsdf.add(BxDF::SpecularTransmission(SpecularTransmission {
                    t: Spectrum::ONE,
                    eta_a: 1.0,
                    eta_b: e,
                    mode,
                }));
            }
            bsdf.add(BxDF::DisneyRetro(DisneyRetro { r: c * diffuse_weight, roughness: rough }));
            if sheen_weight > 0.0 {
                let r = c_sheen * (diffuse_weight * sheen_weight);
                bsdf.add(BxDF::DisneySheen(DisneySheen { r }));
            }
        }
        let aspect = (1.0 - t.eval(&self.anisotropic, si) * 0.9).sqrt();
        let distribution = disney_distribution(rough * rough, aspect, true);
        let spec_tint = t.eval(&self.specular_tint, si);
        let c_spec0 =
            lerp(metallic, lerp(spec_tint, Spectrum::ONE, c_tint) * schlick_r0_from_eta(e), c);
        bsdf.add(BxDF::MicrofacetReflection(MicrofacetReflection {
            r: Spectrum::ONE,
            distribution,
            fresnel: Fresnel::Disney { r0: c_spec0, metallic, eta: e },
        }));
        let cc = t.eval(&self.clearcoat, si);
        if cc > 0.0 {
            let g = t.eval(&self.clearcoat_gloss, si);
            let gloss = (1.0 - g) * 0.1 + g * 0.001;
            bsdf.add(BxDF::DisneyClearcoat(DisneyClearcoat { weight: cc, gloss }));
        }
        if strans > 0.0 {
            let tr = c.sqrt() * strans;
            let distribution = if self.thin {
                let rscaled = (0.65 * e - 0.35) * rough;
                disney_distribution(rscaled * rscaled, aspect, false)
            } else {
                distribution
            };
            bsdf.add(BxDF::MicrofacetTransmission(MicrofacetTransmission {
                t: tr,
                distribution,
                eta_a: 1.0,
                eta_b: e,
                mode,
            }));
        }
        if self.thin {
            bsdf.add(BxDF::LambertianTransmission(LambertianTransmission { t: c * dt }));
        }
        bsdf
    }

    /// A `Material "disney"` with pbrt-v3's parameters and defaults (`CreateDisneyMaterial`).
    pub(super) fn create(m: MaterialParams, w: &mut Vec<Warning>) -> Self {
        Disney {
            color: m.s("color", 0.5, w),
            metallic: m.f("metallic", 0.0, w),
            eta: m.f("eta", 1.5, w),
            roughness: m.f("roughness", 0.5, w),
            specular_tint: m.f("speculartint", 0.0, w),
            anisotropic: m.f("anisotropic", 0.0, w),
            sheen: m.f("sheen", 0.0, w),
            sheen_tint: m.f("sheentint", 0.5, w),
            clearcoat: m.f("clearcoat", 0.0, w),
            clearcoat_gloss: m.f("clearcoatgloss", 1.0, w),
            spec_trans: m.f("spectrans", 0.0, w),
            scatter_distance: m.s("scatterdistance", 0.0, w),
            thin: m.flag("thin", false),
            flatness: m.f("flatness", 0.0, w),
            diff_trans: m.f("difftrans", 1.0, w),
            bump: m.bump,
        }
    }
}

/// Trowbridge–Reitz with α = `alpha2` stretched by `aspect` (at least
/// 0.001 either way); `separable` for pbrt-v3's
/// `DisneyMicrofacetDistribution`, whose G is G1(ωo) G1(ωi).
fn disney_distribution(alpha2: f32, aspect: f32, separable: bool) -> MicrofacetDistribution {
    let ax = (alpha2 / aspect).max(0.001);
    let ay = (alpha2 * aspect).max(0.001);
    MicrofacetDistribution {
        separable_g: separable,
        ..MicrofacetDistribution::trowbridge_reitz(ax, ay)
    }
}
