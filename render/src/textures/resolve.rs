//! Texture-or-value parameters, as pbrt-v3's `TextureParams::Get*Texture`
//! resolves them for textures and materials: a parameter naming an earlier
//! texture refers to it, otherwise its value (or the default) is a constant.

use super::{TexInput, TexValue, TextureSet};
use crate::image::inverse_gamma_correct;
use farm_common::scene::{Params, Warning};
use farm_common::Spectrum;

/// Resolution context: textures may only refer to textures before `limit`.
pub(crate) struct Resolver<'a> {
    pub set: &'a TextureSet,
    pub limit: usize,
}

impl Resolver<'_> {
    fn lookup<T: TexValue>(
        &self,
        p: &Params,
        name: &str,
        id: impl Fn(&farm_common::scene::TextureRef) -> Option<u32>,
        what: &str,
        warnings: &mut Vec<Warning>,
    ) -> Option<TexInput<T>> {
        let tr = p.texture(name)?;
        match id(tr) {
            Some(i)
                if (i as usize) < self.limit
                    && matches!(T::table(self.set).get(i as usize), Some(Some(_))) =>
            {
                Some(TexInput::Texture(i))
            }
            _ => {
                let loc = p.set().get(name).map(|q| q.loc.clone()).unwrap_or_default();
                warnings.push(Warning::at(
                    &loc,
                    format!(
                        "Couldn't find {what} texture named \"{}\" for parameter \"{name}\"",
                        tr.name
                    ),
                ));
                None
            }
        }
    }

    /// A float texture parameter or its value, else `default`.
    pub fn float(
        &self,
        p: &Params,
        name: &str,
        default: f32,
        w: &mut Vec<Warning>,
    ) -> TexInput<f32> {
        self.lookup(p, name, |t| t.float_id, "float", w)
            .unwrap_or_else(|| TexInput::Value(p.float(name, default)))
    }

    /// A float texture parameter or value, if given.
    pub fn float_or_none(
        &self,
        p: &Params,
        name: &str,
        w: &mut Vec<Warning>,
    ) -> Option<TexInput<f32>> {
        self.lookup(p, name, |t| t.float_id, "float", w)
            .or_else(|| p.floats(name).and_then(|v| v.first()).map(|v| TexInput::Value(*v)))
    }

    /// A spectrum texture parameter or value, if given.
    pub fn spectrum_or_none(
        &self,
        p: &Params,
        name: &str,
        w: &mut Vec<Warning>,
    ) -> Option<TexInput<Spectrum>> {
        self.lookup(p, name, |t| t.spectrum_id, "spectrum", w)
            .or_else(|| p.spectra(name).and_then(|v| v.first()).map(|v| TexInput::Value(*v)))
    }

    /// A spectrum texture parameter or its value, else `default`.
    pub fn spectrum(
        &self,
        p: &Params,
        name: &str,
        default: Spectrum,
        w: &mut Vec<Warning>,
    ) -> TexInput<Spectrum> {
        self.lookup(p, name, |t| t.spectrum_id, "spectrum", w)
            .unwrap_or_else(|| TexInput::Value(p.spectrum(name, default)))
    }

    /// A texture of either value type.
    pub(super) fn input<T: Param>(
        &self,
        p: &Params,
        name: &str,
        default: T,
        w: &mut Vec<Warning>,
    ) -> TexInput<T> {
        T::resolve(self, p, name, default, w)
    }
}

/// Reading a value-typed parameter (float or spectrum).
pub(super) trait Param: TexValue {
    fn resolve(
        r: &Resolver,
        p: &Params,
        name: &str,
        default: Self,
        w: &mut Vec<Warning>,
    ) -> TexInput<Self>;
    fn value(p: &Params, name: &str, default: Self) -> Self;
    fn from_image(rgb: Spectrum, scale: f32, gamma: bool) -> Self;
}

impl Param for f32 {
    fn resolve(
        r: &Resolver,
        p: &Params,
        name: &str,
        default: f32,
        w: &mut Vec<Warning>,
    ) -> TexInput<f32> {
        r.float(p, name, default, w)
    }
    fn value(p: &Params, name: &str, default: f32) -> f32 {
        p.float(name, default)
    }
    fn from_image(rgb: Spectrum, scale: f32, gamma: bool) -> f32 {
        let y = rgb.y();
        scale * if gamma { inverse_gamma_correct(y) } else { y }
    }
}

impl Param for Spectrum {
    fn resolve(
        r: &Resolver,
        p: &Params,
        name: &str,
        default: Spectrum,
        w: &mut Vec<Warning>,
    ) -> TexInput<Spectrum> {
        r.spectrum(p, name, default, w)
    }
    fn value(p: &Params, name: &str, default: Spectrum) -> Spectrum {
        p.spectrum(name, default)
    }
    fn from_image(rgb: Spectrum, scale: f32, gamma: bool) -> Spectrum {
        if gamma {
            rgb.map(inverse_gamma_correct) * scale
        } else {
            rgb * scale
        }
    }
}
