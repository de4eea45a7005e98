//! `Material "mix"` (pbrt-v3 `MixMaterial`): the lobes of two materials,
//! scaled by `amount` and 1 − `amount`.

use super::Material;
use crate::bxdf::{Bsdf, TransportMode};
use crate::interaction::SurfaceInteraction;
use crate::textures::{TexInput, TextureSet};
use farm_common::Spectrum;

/// A blend of two materials.
#[derive(Clone, Debug, PartialEq)]
pub struct MixMaterial {
    /// Index of `namedmaterial1`, whose lobes pbrt-v3 scales by `amount`.
    pub m1: u32,
    /// Index of `namedmaterial2`, scaled by 1 − `amount`.
    pub m2: u32,
    /// `amount` (default 0.5).
    pub amount: TexInput<Spectrum>,
}

impl MixMaterial {
    /// The BSDF at `si`: `m1`'s frame and η, with `m2`'s lobes appended.
    pub(crate) fn bsdf<'m>(
        &self,
        si: &mut SurfaceInteraction,
        materials: &'m [Material],
        t: &TextureSet,
        mode: TransportMode,
        allow: bool,
        depth: u32,
    ) -> Bsdf<'m> {
        let s1 = t.eval(&self.amount, si).clamp(0.0, f32::INFINITY);
        let s2 = (Spectrum::ONE - s1).clamp(0.0, f32::INFINITY);
        let mut si2 = *si;
        let mut bsdf = match materials.get(self.m1 as usize) {
            Some(m) => m.compute_at_depth(si, materials, t, mode, allow, depth + 1),
            None => Bsdf::new(si, 1.0),
        };
        let b2 = match materials.get(self.m2 as usize) {
            Some(m) => m.compute_at_depth(&mut si2, materials, t, mode, allow, depth + 1),
            None => Bsdf::new(&si2, 1.0),
        };
        // pbrt-v3 scales material 1 by `amount` and material 2 by 1 − amount.
        bsdf.scale_all(s1);
        for (b, s) in b2.lobes() {
            bsdf.add_scaled(*b, *s * s2);
        }
        bsdf
    }
}
