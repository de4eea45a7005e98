use crate::geometry::{Bounds2i, Point2i};
use crate::spectrum::Spectrum;
use serde::{Deserialize, Serialize};

/// One pixel's running sums: Σ w·L (RGB) and Σ w over all samples, and
/// the same sums over the second half of each pixel's samples alone. The
/// first half (all minus second) and the second half are two estimates of
/// the pixel from which a render estimates its own error.
#[derive(Clone, Copy, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct Pixel {
    /// Σ w·r, Σ w·g, Σ w·b.
    pub contrib: [f32; 3],
    /// Σ w.
    pub weight: f32,
    /// Σ w·r, Σ w·g, Σ w·b over the second half of each pixel's samples.
    pub second_contrib: [f32; 3],
    /// Σ w over the second half of each pixel's samples.
    pub second_weight: f32,
}

impl Pixel {
    /// The eight sums in wire order: contrib, weight, second-half contrib and weight.
    pub fn to_array(&self) -> [f32; 8] {
        let [r, g, b] = self.contrib;
        let [or, og, ob] = self.second_contrib;
        [r, g, b, self.weight, or, og, ob, self.second_weight]
    }

    /// The inverse of [`Pixel::to_array`].
    pub fn from_array(v: [f32; 8]) -> Self {
        Pixel {
            contrib: [v[0], v[1], v[2]],
            weight: v[3],
            second_contrib: [v[4], v[5], v[6]],
            second_weight: v[7],
        }
    }
}

/// The filtered samples of one tile: weighted sums over the tile's pixel
/// bounds (its samples' pixels grown by the filter radius, clipped to the
/// image). Division happens only when the image is written.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct FilmTile {
    /// The pixels this tile holds, in image coordinates.
    pub pixel_bounds: Bounds2i,
    /// Row-major over `pixel_bounds`.
    pub pixels: Vec<Pixel>,
}

impl FilmTile {
    /// A tile of zero sums.
    pub fn new(pixel_bounds: Bounds2i) -> Self {
        FilmTile { pixel_bounds, pixels: vec![Pixel::default(); pixel_bounds.area()] }
    }

    /// Adds `w·L` and `w` to pixel `p` (which must lie in the bounds), and
    /// to its second-half sums too when `second_half` is set.
    #[inline]
    pub fn add(&mut self, p: Point2i, l: Spectrum, w: f32, second_half: bool) {
        let px = &mut self.pixels[self.pixel_bounds.offset(p)];
        let c = [l.r * w, l.g * w, l.b * w];
        for (k, v) in c.iter().enumerate() {
            px.contrib[k] += v;
        }
        px.weight += w;
        if second_half {
            for (k, v) in c.iter().enumerate() {
                px.second_contrib[k] += v;
            }
            px.second_weight += w;
        }
    }

    /// Adds another tile's sums where the two overlap, in a fixed order (the
    /// caller's), so the result does not depend on timing.
    pub fn merge(&mut self, other: &FilmTile) {
        let overlap = self.pixel_bounds.intersect(&other.pixel_bounds);
        for p in overlap.iter() {
            let src = other.pixels[other.pixel_bounds.offset(p)];
            let dst = &mut self.pixels[self.pixel_bounds.offset(p)];
            for c in 0..3 {
                dst.contrib[c] += src.contrib[c];
                dst.second_contrib[c] += src.second_contrib[c];
            }
            dst.weight += src.weight;
            dst.second_weight += src.second_weight;
        }
    }
}
