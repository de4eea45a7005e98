//! `"dots"`: randomly placed polka dots (pbrt-v3 `DotsTexture`).

use super::mapping::Mapping2D;
use super::noise::noise;
use super::{TexInput, TexValue, TextureSet};
use crate::interaction::SurfaceInteraction;
use farm_common::math;

/// Dots of `inside` on a background of `outside`.
#[derive(Clone, Debug, PartialEq)]
pub struct Dots<T> {
    /// The 2D mapping.
    pub mapping: Mapping2D,
    /// Inside a dot (default 1).
    pub inside: TexInput<T>,
    /// Elsewhere (default 0).
    pub outside: TexInput<T>,
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
                return set.eval(&self.inside, si);
            }
        }
        set.eval(&self.outside, si)
    }
}
