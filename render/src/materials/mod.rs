//! Materials (pbrt-v3 `core/material.h` and `materials/`): each turns the
//! textures at a hit into a [`Bsdf`], after optional bump mapping.

mod bump;
mod create;
mod disney;
mod fourier;
mod glass;
mod hair;
mod matte;
mod metal;
mod mirror;
mod mix;
mod plastic;
mod substrate;
mod subsurface;
mod translucent;
mod uber;

pub use bump::bump;
pub use create::{build, derive, shape_may_set_material};
pub use disney::Disney;
pub use fourier::{Fourier, MaterialFiles};
pub use glass::Glass;
pub use hair::Hair;
pub use matte::Matte;
pub use metal::Metal;
pub use mirror::Mirror;
pub use mix::MixMaterial;
pub use plastic::Plastic;
pub use substrate::Substrate;
pub use translucent::Translucent;
pub use uber::Uber;

use crate::bxdf::{Bsdf, TransportMode};
use crate::interaction::SurfaceInteraction;
use crate::textures::{TexInput, TextureSet};

/// A material.
#[derive(Clone, Debug, PartialEq)]
pub enum Material {
    /// `"matte"`.
    Matte(Matte),
    /// `"plastic"`.
    Plastic(Plastic),
    /// `"mirror"`.
    Mirror(Mirror),
    /// `"glass"`.
    Glass(Glass),
    /// `"metal"`.
    Metal(Metal),
    /// `"uber"`.
    Uber(Uber),
    /// `"substrate"`.
    Substrate(Substrate),
    /// `"translucent"`.
    Translucent(Translucent),
    /// `"mix"`.
    Mix(MixMaterial),
    /// `"disney"`.
    Disney(Box<Disney>),
    /// `"hair"`.
    Hair(Box<Hair>),
    /// `"fourier"`.
    Fourier(Fourier),
}

/// Deepest nesting of mix materials followed (the parser only lets a mix
/// refer to earlier materials, so real scenes never get near it).
const MAX_MIX_DEPTH: u32 = 32;

impl Material {
    /// The `"bumpmap"` texture, if any.
    fn bump_map(&self) -> Option<&TexInput<f32>> {
        match self {
            Material::Matte(m) => m.bump.as_ref(),
            Material::Plastic(m) => m.bump.as_ref(),
            Material::Mirror(m) => m.bump.as_ref(),
            Material::Glass(m) => m.bump.as_ref(),
            Material::Metal(m) => m.bump.as_ref(),
            Material::Uber(m) => m.bump.as_ref(),
            Material::Substrate(m) => m.bump.as_ref(),
            Material::Translucent(m) => m.bump.as_ref(),
            Material::Mix(_) => None,
            Material::Disney(m) => m.bump.as_ref(),
            Material::Hair(_) => None,
            Material::Fourier(m) => m.bump.as_ref(),
        }
    }

    /// The BSDF at `si` (pbrt-v3 `ComputeScatteringFunctions`). Bump mapping
    /// first perturbs `si`'s shading geometry. Whitted passes
    /// `allow_multiple_lobes = false`.
    pub fn compute_bsdf<'m>(
        &'m self,
        si: &mut SurfaceInteraction,
        materials: &'m [Material],
        textures: &TextureSet,
        mode: TransportMode,
        allow_multiple_lobes: bool,
    ) -> Bsdf<'m> {
        self.compute_at_depth(si, materials, textures, mode, allow_multiple_lobes, 0)
    }

    pub(crate) fn compute_at_depth<'m>(
        &'m self,
        si: &mut SurfaceInteraction,
        materials: &'m [Material],
        t: &TextureSet,
        mode: TransportMode,
        allow: bool,
        depth: u32,
    ) -> Bsdf<'m> {
        if let Some(b) = self.bump_map() {
            bump(b, si, t);
        }
        match self {
            Material::Matte(m) => m.bsdf(si, t),
            Material::Plastic(m) => m.bsdf(si, t),
            Material::Mirror(m) => m.bsdf(si, t),
            Material::Glass(m) => m.bsdf(si, t, mode, allow),
            Material::Metal(m) => m.bsdf(si, t),
            Material::Uber(m) => m.bsdf(si, t, mode),
            Material::Substrate(m) => m.bsdf(si, t),
            Material::Translucent(m) => m.bsdf(si, t, mode),
            Material::Disney(m) => m.bsdf(si, t, mode),
            Material::Hair(m) => m.bsdf(si, t),
            Material::Fourier(m) => m.bsdf(si, mode),
            Material::Mix(m) if depth < MAX_MIX_DEPTH => {
                m.bsdf(si, materials, t, mode, allow, depth)
            }
            Material::Mix(_) => Bsdf::new(si, 1.0),
        }
    }
}
