//! `"bilerp"`: bilinear interpolation of four corner values over (s, t)
//! (pbrt-v3 `BilerpTexture`).

use super::mapping::Mapping2D;
use super::TexValue;
use crate::interaction::SurfaceInteraction;

/// Corner values at (s, t) = (0,0), (0,1), (1,0), (1,1).
#[derive(Clone, Debug, PartialEq)]
pub struct Bilerp<T> {
    /// The 2D mapping.
    pub mapping: Mapping2D,
    /// Value at (0, 0) (default 0).
    pub v00: T,
    /// Value at (0, 1) (default 1).
    pub v01: T,
    /// Value at (1, 0) (default 0).
    pub v10: T,
    /// Value at (1, 1) (default 1).
    pub v11: T,
}

impl<T: TexValue> Bilerp<T> {
    /// The interpolated value at `si`.
    pub fn evaluate(&self, si: &SurfaceInteraction) -> T {
        let st = self.mapping.map(si).st;
        let (s, t) = (st.x, st.y);
        self.v00 * ((1.0 - s) * (1.0 - t))
            + self.v01 * ((1.0 - s) * t)
            + self.v10 * (s * (1.0 - t))
            + self.v11 * (s * t)
    }
}
