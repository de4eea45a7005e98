//! `"scale"`: the product of two textures (pbrt-v3 `ScaleTexture`).

use super::{TexInput, TexValue, TextureSet};
use crate::interaction::SurfaceInteraction;

/// `tex1 × tex2`.
#[derive(Clone, Debug, PartialEq)]
pub struct Scale<T> {
    /// First factor (default 1).
    pub tex1: TexInput<T>,
    /// Second factor (default 1).
    pub tex2: TexInput<T>,
}

impl<T: TexValue> Scale<T> {
    /// The product at `si`.
    pub fn evaluate(&self, set: &TextureSet, si: &SurfaceInteraction) -> T {
        set.eval(&self.tex1, si) * set.eval(&self.tex2, si)
    }
}
