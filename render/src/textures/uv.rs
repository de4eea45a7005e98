//! `"uv"`: the fractional texture coordinates as red and green (pbrt-v3
//! `UVTexture`, spectrum only).

use super::mapping::Mapping2D;
use crate::interaction::SurfaceInteraction;
use farm_common::math;
use farm_common::Spectrum;

/// (s − ⌊s⌋, t − ⌊t⌋, 0).
#[derive(Clone, Debug, PartialEq)]
pub struct UvTexture {
    /// The 2D mapping.
    pub mapping: Mapping2D,
}

impl UvTexture {
    /// The colour at `si`.
    pub fn evaluate(&self, si: &SurfaceInteraction) -> Spectrum {
        let st = self.mapping.map(si).st;
        Spectrum::new(st.x - math::floor(st.x), st.y - math::floor(st.y), 0.0)
    }
}
