//! `"imagemap"` (pbrt-v3 `ImageTexture`): a MIP-mapped image looked up with
//! the hit's texture-space footprint.

use super::mapping::Mapping2D;
use super::TexValue;
use crate::image::MipMap;
use crate::interaction::SurfaceInteraction;
use std::sync::Arc;

/// An image texture; identical (file, filtering) maps share one [`MipMap`].
#[derive(Clone, Debug)]
pub struct ImageMap<T: TexValue> {
    /// The 2D mapping.
    pub mapping: Mapping2D,
    /// The image pyramid (scale and gamma already applied).
    pub mipmap: Arc<MipMap<T>>,
}

impl<T: TexValue> ImageMap<T> {
    /// The filtered value at `si`.
    pub fn evaluate(&self, si: &SurfaceInteraction) -> T {
        let m = self.mapping.map(si);
        self.mipmap.lookup_ewa(m.st, m.dstdx, m.dstdy)
    }
}
