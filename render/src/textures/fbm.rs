//! Solid noise textures: `"fbm"`, `"wrinkled"`, `"windy"` and `"marble"`
//! (pbrt-v3 `FBmTexture`, `WrinkledTexture`, `WindyTexture`,
//! `MarbleTexture`).

use super::mapping::Mapping3D;
use super::noise::{fbm, turbulence};
use crate::interaction::SurfaceInteraction;
use farm_common::math;
use farm_common::Spectrum;

/// Fractional Brownian motion.
#[derive(Clone, Debug, PartialEq)]
pub struct Fbm {
    /// The 3D mapping.
    pub mapping: Mapping3D,
    /// `"float roughness"` (default 0.5).
    pub omega: f32,
    /// `"integer octaves"` (default 8).
    pub octaves: i32,
}

impl Fbm {
    /// The value at `si`.
    pub fn evaluate(&self, si: &SurfaceInteraction) -> f32 {
        let (p, dx, dy) = self.mapping.map(si);
        fbm(p, dx, dy, self.omega, self.octaves)
    }
}

/// Turbulence.
#[derive(Clone, Debug, PartialEq)]
pub struct Wrinkled {
    /// The 3D mapping.
    pub mapping: Mapping3D,
    /// `"float roughness"` (default 0.5).
    pub omega: f32,
    /// `"integer octaves"` (default 8).
    pub octaves: i32,
}

impl Wrinkled {
    /// The value at `si`.
    pub fn evaluate(&self, si: &SurfaceInteraction) -> f32 {
        let (p, dx, dy) = self.mapping.map(si);
        turbulence(p, dx, dy, self.omega, self.octaves)
    }
}

/// Wind-blown waves.
#[derive(Clone, Debug, PartialEq)]
pub struct Windy {
    /// The 3D mapping.
    pub mapping: Mapping3D,
}

impl Windy {
    /// The value at `si`.
    pub fn evaluate(&self, si: &SurfaceInteraction) -> f32 {
        let (p, dx, dy) = self.mapping.map(si);
        let wind = fbm(0.1 * p, 0.1 * dx, 0.1 * dy, 0.5, 3);
        let wave = fbm(p, dx, dy, 0.5, 6);
        wind.abs() * wave
    }
}

/// pbrt-v3's marble colours: the control points of its cubic Bézier spline.
const MARBLE: [[f32; 3]; 9] = [
    [0.58, 0.58, 0.6],
    [0.58, 0.58, 0.6],
    [0.58, 0.58, 0.6],
    [0.5, 0.5, 0.5],
    [0.6, 0.59, 0.58],
    [0.58, 0.58, 0.6],
    [0.58, 0.58, 0.6],
    [0.2, 0.2, 0.33],
    [0.58, 0.58, 0.6],
];

/// Marble: bands in y perturbed by fBm, coloured by a spline (pbrt-v3
/// `MarbleTexture`, spectrum only).
#[derive(Clone, Debug, PartialEq)]
pub struct Marble {
    /// The 3D mapping.
    pub mapping: Mapping3D,
    /// `"integer octaves"` (default 8).
    pub octaves: i32,
    /// `"float roughness"` (default 0.5).
    pub omega: f32,
    /// `"float scale"` (default 1).
    pub scale: f32,
    /// `"float variation"` (default 0.2).
    pub variation: f32,
}

impl Marble {
    /// The colour at `si`.
    pub fn evaluate(&self, si: &SurfaceInteraction) -> Spectrum {
        let (p, dx, dy) = self.mapping.map(si);
        let p = p * self.scale;
        let marble = p.y
            + self.variation * fbm(p, self.scale * dx, self.scale * dy, self.omega, self.octaves);
        marble_spline(0.5 + 0.5 * math::sin(marble))
    }
}

/// pbrt-v3's spline lookup, kept as it is written there: the segment index
/// is clamped to at most 1 (not to the last segment), so values of `t`
/// past the second segment extrapolate its cubic.
fn marble_spline(t: f32) -> Spectrum {
    let nseg = (MARBLE.len() - 3) as f32;
    let first = (math::floor(t * nseg) as i32).min(1) as usize;
    let t = t * nseg - first as f32;
    let c = |i: usize| Spectrum::new(MARBLE[i][0], MARBLE[i][1], MARBLE[i][2]);
    let (c0, c1, c2, c3) = (c(first), c(first + 1), c(first + 2), c(first + 3));
    let mut s0 = c0 * (1.0 - t) + c1 * t;
    let mut s1 = c1 * (1.0 - t) + c2 * t;
    let s2 = c2 * (1.0 - t) + c3 * t;
    s0 = s0 * (1.0 - t) + s1 * t;
    s1 = s1 * (1.0 - t) + s2 * t;
    (s0 * (1.0 - t) + s1 * t) * 1.5
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The spline as pbrt-v3 evaluates it (× 1.5): at t = 0 the first
    /// control point; at t = 1/6 segment 1 starts, at its control point 1
    /// (a Bézier passes through its end points) and ends at 1/3 on control
    /// point 4; past 1/3 segment 1's cubic extrapolates, as pbrt-v3's clamp
    /// to segment 1 makes it.
    #[test]
    fn marble_spline_follows_pbrt_v3() {
        let close = |a: Spectrum, b: [f32; 3]| (0..3).all(|i| (a[i] - b[i]).abs() < 1e-5);
        assert!(close(marble_spline(0.0), [0.87, 0.87, 0.9]));
        assert!(close(marble_spline(1.0 / 6.0), [0.87, 0.87, 0.9]));
        assert!(close(marble_spline(1.0 / 3.0 - 1e-7), [0.9, 0.885, 0.87]));
        // t = 1: local 5 on segment 1's cubic, by de Casteljau with t = 5.
        let (c1, c2, c3, c4) = (0.58f32, 0.58f32, 0.5f32, 0.6f32);
        let l = |a: f32, b: f32| a * (1.0 - 5.0) + b * 5.0;
        let red = 1.5 * l(l(l(c1, c2), l(c2, c3)), l(l(c2, c3), l(c3, c4)));
        assert!((marble_spline(1.0).r - red).abs() < 1e-4, "{} vs {red}", marble_spline(1.0).r);
    }
}
