//! `"dots"`: randomly placed polka dots (pbrt-v3 `DotsTexture`).

use super::mapping::Mapping2D;
use super::noise::noise;
use super::{TexInput, TexValue, TextureSet};
use crate::interaction::SurfaceInteraction;
use farm_common::math;

/// Dots of one texture on a background of another.
///
/// pbrt-v3's `DotsTexture` constructor takes `(mapping, outsideDot,
/// insideDot)`, and both `CreateDots*Texture` pass `"inside"` first: so
/// the `"inside"` parameter (default 1) paints the background and
/// `"outside"` (default 0) the dots. Scenes written for pbrt-v3 were made
/// to look right with that, so farm keeps it: the fields below are named
/// for where they are drawn, [`create`](super::create) says which
/// parameter fills each.
#[derive(Clone, Debug, PartialEq)]
pub struct Dots<T> {
    /// The 2D mapping.
    pub mapping: Mapping2D,
    /// Inside a dot: the `"outside"` parameter (default 0).
    pub dot: TexInput<T>,
    /// Elsewhere: the `"inside"` parameter (default 1).
    pub background: TexInput<T>,
}

impl<T: TexValue> Dots<T> {
    /// The value at `si`.
    pub fn evaluate(&self, set: &TextureSet, si: &SurfaceInteraction) -> T {
        let st = self.mapping.map(si).st;
        let s_cell = math::floor(st.x + 0.5);
        let t_cell = math::floor(st.y + 0.5);
        if noise(s_cell + 0.5, t_cell + 0.5, 0.5) > 0.0 {
            let radius = 0.35;
            let max_shift = 0.5 - radius;
            let s_center = s_cell + max_shift * noise(s_cell + 1.5, t_cell + 2.8, 0.5);
            let t_center = t_cell + max_shift * noise(s_cell + 4.5, t_cell + 9.8, 0.5);
            let (ds, dt) = (st.x - s_center, st.y - t_center);
            if ds * ds + dt * dt < radius * radius {
                return set.eval(&self.dot, si);
            }
        }
        set.eval(&self.background, si)
    }
}
