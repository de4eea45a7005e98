//! `"mix"`: linear blend of two textures by a float texture (pbrt-v3 `MixTexture`).

use super::{TexInput, TexValue, TextureSet};
use crate::interaction::SurfaceInteraction;

/// `(1 − amount)·tex1 + amount·tex2`.
#[derive(Clone, Debug, PartialEq)]
pub struct Mix<T> {
    /// Value at amount 0 (default 0).
    pub tex1: TexInput<T>,
    /// Value at amount 1 (default 1).
    pub tex2: TexInput<T>,
    /// Blend weight (default 0.5).
    pub amount: TexInput<f32>,
}

impl<T: TexValue> Mix<T> {
    /// The blend at `si`.
    pub fn evaluate(&self, set: &TextureSet, si: &SurfaceInteraction) -> T {
        let t1 = set.eval(&self.tex1, si);
        let t2 = set.eval(&self.tex2, si);
        let amt = set.eval(&self.amount, si);
        t1 * (1.0 - amt) + t2 * amt
    }
}
