use crate::geometry::{Bounds2i, Point2i};
use crate::spectrum::Spectrum;
use serde::{Deserialize, Serialize};

/// One pixel's running sums: Σ w·L (RGB) and Σ w.
#[derive(Clone, Copy, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct Pixel {
    /// Σ w·r, Σ w·g, Σ w·b.
    pub contrib: [f32; 3],
    /// Σ w.
    pub weight: f32,
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

    /// Adds `w·L` and `w` to pixel `p` (which must lie in the bounds).
    #[inline]
    pub fn add(&mut self, p: Point2i, l: Spectrum, w: f32) {
        let px = &mut self.pixels[self.pixel_bounds.offset(p)];
        px.contrib[0] += l.r * w;
        px.contrib[1] += l.g * w;
        px.contrib[2] += l.b * w;
        px.weight += w;
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
            }
            dst.weight += src.weight;
        }
    }
}
