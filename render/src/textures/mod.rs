//! Textures (pbrt-v3 `core/texture.h` and `textures/`): float and spectrum
//! textures built once per scene into a [`TextureSet`], referring to earlier
//! textures by index, evaluated at surface hits in render space.

mod bilerp;
mod checkerboard;
mod create;
mod dots;
mod fbm;
mod imagemap;
mod mapping;
mod mix;
mod noise;
mod resolve;
mod scale;
mod uv;

pub use bilerp::Bilerp;
pub use checkerboard::{AaMode, Checkerboard2D, Checkerboard3D};
pub use create::{build, uses_differentials};
pub use dots::Dots;
pub use fbm::{Fbm, Marble, Windy, Wrinkled};
pub use imagemap::ImageMap;
pub use mapping::{Mapping2D, Mapping3D};
pub use mix::Mix;
pub use noise::{fbm as fbm_noise, noise, turbulence};
pub(crate) use resolve::Resolver;
pub use scale::Scale;
pub use uv::UvTexture;

use crate::image::Texel;
use crate::interaction::SurfaceInteraction;
use farm_common::Spectrum;
use std::ops::Mul;

/// A texture input: a constant or another texture of the same set.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum TexInput<T> {
    /// A constant value.
    Value(T),
    /// The texture at this index of the scene's texture list.
    Texture(u32),
}

/// Values textures produce: `f32` or [`Spectrum`].
pub trait TexValue:
    Texel + Mul<Self, Output = Self> + PartialEq + std::fmt::Debug + 'static
{
    /// This value type's textures in `set`.
    fn table(set: &TextureSet) -> &[Option<Texture<Self>>];
    /// From a float.
    fn splat(v: f32) -> Self;
    /// From RGB (floats take the luminance).
    fn from_spectrum(s: Spectrum) -> Self;
    /// The one channel of a value that has several, all with the same
    /// bits (a grey texel); `None` for anything else and for floats.
    fn grey(self) -> Option<f32>;
}

impl TexValue for f32 {
    fn table(set: &TextureSet) -> &[Option<Texture<f32>>] {
        &set.floats
    }
    fn splat(v: f32) -> f32 {
        v
    }
    fn from_spectrum(s: Spectrum) -> f32 {
        s.y()
    }
    fn grey(self) -> Option<f32> {
        None
    }
}

impl TexValue for Spectrum {
    fn table(set: &TextureSet) -> &[Option<Texture<Spectrum>>] {
        &set.spectra
    }
    fn splat(v: f32) -> Spectrum {
        Spectrum::splat(v)
    }
    fn from_spectrum(s: Spectrum) -> Spectrum {
        s
    }
    fn grey(self) -> Option<f32> {
        let r = self.r.to_bits();
        (r == self.g.to_bits() && r == self.b.to_bits()).then_some(self.r)
    }
}

/// One texture.
#[derive(Clone, Debug)]
pub enum Texture<T: TexValue> {
    /// `"constant"`: `"value"` (default 1).
    Constant(T),
    /// `"scale"`.
    Scale(Scale<T>),
    /// `"mix"`.
    Mix(Mix<T>),
    /// `"bilerp"`.
    Bilerp(Bilerp<T>),
    /// `"checkerboard"` with `"dimension" 2`.
    Checkerboard2D(Checkerboard2D<T>),
    /// `"checkerboard"` with `"dimension" 3`.
    Checkerboard3D(Checkerboard3D<T>),
    /// `"dots"`.
    Dots(Dots<T>),
    /// `"imagemap"`.
    ImageMap(ImageMap<T>),
    /// `"uv"` (spectrum only).
    Uv(UvTexture),
    /// `"fbm"`.
    Fbm(Fbm),
    /// `"wrinkled"`.
    Wrinkled(Wrinkled),
    /// `"windy"`.
    Windy(Windy),
    /// `"marble"` (spectrum only).
    Marble(Marble),
}

/// Every texture of a scene, by index into `SceneDescription::textures`
/// (an index holds a float or a spectrum texture, never both).
#[derive(Clone, Debug, Default)]
pub struct TextureSet {
    /// Float textures.
    pub floats: Vec<Option<Texture<f32>>>,
    /// Spectrum textures.
    pub spectra: Vec<Option<Texture<Spectrum>>>,
}

impl TextureSet {
    /// Evaluates an input at `si`.
    #[inline]
    pub fn eval<T: TexValue>(&self, input: &TexInput<T>, si: &SurfaceInteraction) -> T {
        match input {
            TexInput::Value(v) => *v,
            TexInput::Texture(i) => match T::table(self).get(*i as usize) {
                Some(Some(t)) => t.evaluate(self, si),
                _ => T::default(),
            },
        }
    }
}

impl<T: TexValue> Texture<T> {
    /// The texture's value at `si`.
    pub fn evaluate(&self, set: &TextureSet, si: &SurfaceInteraction) -> T {
        match self {
            Texture::Constant(v) => *v,
            Texture::Scale(t) => t.evaluate(set, si),
            Texture::Mix(t) => t.evaluate(set, si),
            Texture::Bilerp(t) => t.evaluate(si),
            Texture::Checkerboard2D(t) => t.evaluate(set, si),
            Texture::Checkerboard3D(t) => t.evaluate(set, si),
            Texture::Dots(t) => t.evaluate(set, si),
            Texture::ImageMap(t) => t.evaluate(si),
            Texture::Uv(t) => T::from_spectrum(t.evaluate(si)),
            Texture::Fbm(t) => T::splat(t.evaluate(si)),
            Texture::Wrinkled(t) => T::splat(t.evaluate(si)),
            Texture::Windy(t) => T::splat(t.evaluate(si)),
            Texture::Marble(t) => T::from_spectrum(t.evaluate(si)),
        }
    }

    /// Whether evaluating uses the hit's screen-space derivatives.
    pub fn uses_differentials(&self) -> bool {
        match self {
            Texture::Checkerboard2D(c) => c.aa == AaMode::ClosedForm,
            Texture::ImageMap(_)
            | Texture::Fbm(_)
            | Texture::Wrinkled(_)
            | Texture::Windy(_)
            | Texture::Marble(_) => true,
            _ => false,
        }
    }
}
