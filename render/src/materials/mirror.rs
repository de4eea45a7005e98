//! `Material "mirror"` (pbrt-v3 `MirrorMaterial`): perfect specular reflection.

use super::create::MaterialParams;
use crate::bxdf::{Bsdf, BxDF, Fresnel, SpecularReflection};
use crate::interaction::SurfaceInteraction;
use crate::textures::{TexInput, TextureSet};
use farm_common::scene::Warning;
use farm_common::Spectrum;

/// A perfect mirror.
#[derive(Clone, Debug, PartialEq)]
pub struct Mirror {
    /// `Kr` (default 0.9).
    pub kr: TexInput<Spectrum>,
    /// `bumpmap`.
    pub bump: Option<TexInput<f32>>,
}

impl Mirror {
    /// The BSDF at `si`.
    pub fn bsdf(&self, si: &SurfaceInteraction, t: &TextureSet) -> Bsdf<'_> {
        let mut bsdf = Bsdf::new(si, 1.0);
        let r = t.eval(&self.kr, si).clamp(0.0, f32::INFINITY);
        if !r.is_black() {
            bsdf.add(BxDF::SpecularReflection(SpecularReflection { r, fresnel: Fresnel::NoOp }));
        }
        bsdf
    }
}

impl Mirror {
    /// A `Material "mirror"` with pbrt-v3's parameters and defaults (`CreateMirrorMaterial`).
    pub(super) fn create(m: MaterialParams, w: &mut Vec<Warning>) -> Self {
        Mirror { kr: m.s("Kr", 0.9, w), bump: m.bump }
    }
}
