//! `"checkerboard"` (pbrt-v3 `Checkerboard2DTexture`, `Checkerboard3DTexture`):
//! alternating textures, the 2D one box-filtered in closed form by default.

use super::mapping::{Mapping2D, Mapping3D};
use super::{TexInput, TexValue, TextureSet};
use crate::interaction::SurfaceInteraction;
use farm_common::math;

/// Antialiasing of the 2D checkerboard (`"string aamode"`).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum AaMode {
    /// Point sampling (`"none"`).
    None,
    /// Closed-form box filtering (`"closedform"`, the default).
    ClosedForm,
}

/// A 2D checkerboard in (s, t).
#[derive(Clone, Debug, PartialEq)]
pub struct Checkerboard2D<T> {
    /// The 2D mapping.
    pub mapping: Mapping2D,
    /// Squares where ⌊s⌋ + ⌊t⌋ is even (default 1).
    pub tex1: TexInput<T>,
    /// The other squares (default 0).
    pub tex2: TexInput<T>,
    /// Antialiasing.
    pub aa: AaMode,
}

/// Integral of the 0/1 square wave of period 2 from 0 to `x`.
#[inline]
fn bump_int(x: f32) -> f32 {
    math::floor(x / 2.0) + 2.0 * (x / 2.0 - math::floor(x / 2.0) - 0.5).max(0.0)
}

impl<T: TexValue> Checkerboard2D<T> {
    /// The (filtered) value at `si`.
    pub fn evaluate(&self, set: &TextureSet, si: &SurfaceInteraction) -> T {
        let m = self.mapping.map(si);
        let (st, dstdx, dstdy) = (m.st, m.dstdx, m.dstdy);
        let point = || {
            if (math::floor(st.x) as i32).wrapping_add(math::floor(st.y) as i32) % 2 == 0 {
                set.eval(&self.tex1, si)
            } else {
                set.eval(&self.tex2, si)
            }
        };
        if self.aa == AaMode::None {
            return point();
        }
        let ds = dstdx.x.abs().max(dstdy.x.abs());
        let dt = dstdx.y.abs().max(dstdy.y.abs());
        let (s0, s1) = (st.x - ds, st.x + ds);
        let (t0, t1) = (st.y - dt, st.y + dt);
        if math::floor(s0) == math::floor(s1) && math::floor(t0) == math::floor(t1) {
            return point();
        }
        let sint = (bump_int(s1) - bump_int(s0)) / (2.0 * ds);
        let tint = (bump_int(t1) - bump_int(t0)) / (2.0 * dt);
        let mut area2 = sint + tint - 2.0 * sint * tint;
        if ds > 1.0 || dt > 1.0 {
            area2 = 0.5;
        }
        set.eval(&self.tex1, si) * (1.0 - area2) + set.eval(&self.tex2, si) * area2
    }
}

/// A solid checkerboard of unit cubes.
#[derive(Clone, Debug, PartialEq)]
pub struct Checkerboard3D<T> {
    /// The 3D mapping.
    pub mapping: Mapping3D,
    /// Cubes where ⌊x⌋ + ⌊y⌋ + ⌊z⌋ is even (default 1).
    pub tex1: TexInput<T>,
    /// The other cubes (default 0).
    pub tex2: TexInput<T>,
}

impl<T: TexValue> Checkerboard3D<T> {
    /// The value at `si`.
    pub fn evaluate(&self, set: &TextureSet, si: &SurfaceInteraction) -> T {
        let (p, _, _) = self.mapping.map(si);
        let sum = (math::floor(p.x) as i32)
            .wrapping_add(math::floor(p.y) as i32)
            .wrapping_add(math::floor(p.z) as i32);
        if sum % 2 == 0 {
            set.eval(&self.tex1, si)
        } else {
            set.eval(&self.tex2, si)
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use farm_common::geometry::Vec2;
    use farm_common::Spectrum;

    fn si(u: f32, v: f32, d: f32) -> SurfaceInteraction {
        SurfaceInteraction { uv: Vec2::new(u, v), dudx: d, dvdy: d, ..Default::default() }
    }

    #[test]
    fn closed_form_averages_under_huge_footprint_and_point_samples_small_ones() {
        let set = TextureSet::default();
        let c = Checkerboard2D {
            mapping: Mapping2D::Uv { su: 4.0, sv: 4.0, du: 0.0, dv: 0.0 },
            tex1: TexInput::Value(Spectrum::new(1.0, 0.0, 0.5)),
            tex2: TexInput::Value(Spectrum::new(0.0, 1.0, 0.5)),
            aa: AaMode::ClosedForm,
        };
        let avg = c.evaluate(&set, &si(0.3, 0.7, 100.0));
        assert_eq!(avg, Spectrum::new(0.5, 0.5, 0.5));
        // A moderate footprint straddling many squares is close to the mean too.
        let near = c.evaluate(&set, &si(0.3, 0.7, 0.2));
        assert!((near.r - 0.5).abs() < 0.1, "{near:?}");
        assert_eq!(c.evaluate(&set, &si(0.1, 0.1, 0.0)), Spectrum::new(1.0, 0.0, 0.5));
        assert_eq!(c.evaluate(&set, &si(0.3, 0.1, 0.001)), Spectrum::new(0.0, 1.0, 0.5));
        assert_eq!(c.evaluate(&set, &si(-0.1, 0.1, 0.0)), Spectrum::new(0.0, 1.0, 0.5));
    }
}
