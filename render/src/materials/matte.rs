//! `Material "matte"` (pbrt-v3 `MatteMaterial`): Lambertian, or Oren–Nayar
//! when `sigma` > 0.

use super::create::MaterialParams;
use crate::bxdf::{Bsdf, BxDF, LambertianReflection, OrenNayar};
use crate::interaction::SurfaceInteraction;
use crate::textures::{TexInput, TextureSet};
use farm_common::scene::Warning;
use farm_common::Spectrum;

/// Diffuse reflection.
#[derive(Clone, Debug, PartialEq)]
pub struct Matte {
    /// `Kd` (default 0.5).
    pub kd: TexInput<Spectrum>,
    /// `sigma` in degrees (default 0).
    pub sigma: TexInput<f32>,
    /// `bumpmap`.
    pub bump: Option<TexInput<f32>>,
}

impl Matte {
    /// The BSDF at `si`.
    pub fn bsdf(&self, si: &SurfaceInteraction, t: &TextureSet) -> Bsdf<'_> {
        let mut bsdf = Bsdf::new(si, 1.0);
        let r = t.eval(&self.kd, si).clamp(0.0, f32::INFINITY);
        let sig = t.eval(&self.sigma, si).clamp(0.0, 90.0);
        if !r.is_black() {
            if sig == 0.0 {
                bsdf.add(BxDF::LambertianReflection(LambertianReflection { r }));
            } else {
                bsdf.add(BxDF::OrenNayar(OrenNayar::new(r, sig)));
            }
        }
        bsdf
    }
}

impl Matte {
    /// A `Material "matte"` with pbrt-v3's parameters and defaults (`CreateMatteMaterial`).
    pub(super) fn create(m: MaterialParams, w: &mut Vec<Warning>) -> Self {
        Matte { kd: m.s("Kd", 0.5, w), sigma: m.f("sigma", 0.0, w), bump: m.bump }
    }
}
