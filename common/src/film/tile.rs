use crate::geometry::{Bounds2i, Point2i};
use crate::spectrum::Spectrum;
use serde::{Deserialize, Serialize};

/// One pixel's running sums: Σ w·L (RGB) and Σ w over all samples, and
/// the same sums over the second half of each pixel's samples alone. The
/// first half (all minus second) and the second half are two estimates of
/// the pixel from which a render estimates its own error.
#[derive(Clone, Copy, Debug, Default, PartialEq, Serialize, Deserialize)]
#[repr(C)]
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

// SAFETY: `#[repr(C)]`, eight `f32` in wire order and no padding (sizes
// and offsets asserted below); every bit pattern is an `f32`.
unsafe impl bytemuck::Zeroable for Pixel {}
// SAFETY: as above; `Pixel` is `Copy` and holds no references.
unsafe impl bytemuck::Pod for Pixel {}
const _: () = assert!(
    std::mem::size_of::<Pixel>() == 32
        && std::mem::offset_of!(Pixel, weight) == 12
        && std::mem::offset_of!(Pixel, second_contrib) == 16
        && std::mem::offset_of!(Pixel, second_weight) == 28
);

impl Pixel {
    /// The eight sums in wire order: contrib, weight, second-half contrib and weight.
    pub fn to_array(&self) -> [f32; 8] {
        let [r, g, b] = self.contrib;
        let [or, og, ob] = self.second_contrib;
        [r, g, b, self.weight, or, og, ob, self.second_weight]
    }

    /// `pixels` as their sums' little-endian bytes in wire order
    /// ([`Pixel::to_array`], pixel after pixel) without a copy: on a
    /// little-endian host, where `#[repr(C)]` lays them out so; `None`
    /// elsewhere.
    pub fn wire_bytes(pixels: &[Pixel]) -> Option<&[u8]> {
        cfg!(target_endian = "little").then(|| bytemuck::cast_slice(pixels))
    }

    /// The pixel's value as the image shows it: see [`resolve`].
    #[inline]
    pub fn resolve(&self, scale: f32) -> [f32; 3] {
        resolve(self.contrib, self.weight, scale)
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

/// A pixel's value from its sums: the weighted sum over the weight,
/// clamped at zero, times the film's `scale` (pbrt-v3 `Film::WriteImage`).
#[inline]
pub fn resolve(contrib: [f32; 3], weight: f32, scale: f32) -> [f32; 3] {
    let mut rgb = contrib;
    if weight != 0.0 {
        let inv = 1.0 / weight;
        rgb = rgb.map(|v| (v * inv).max(0.0));
    }
    rgb.map(|v| v * scale)
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
        if overlap.is_empty() {
            return;
        }
        // Row by row: each pixel gets the same one addition per sum as
        // pixel by pixel, so the bits are the same.
        let n = overlap.width() as usize;
        for y in overlap.min.y..overlap.max.y {
            let row = Point2i::new(overlap.min.x, y);
            let (s, d) = (other.pixel_bounds.offset(row), self.pixel_bounds.offset(row));
            for (dst, src) in self.pixels[d..d + n].iter_mut().zip(&other.pixels[s..s + n]) {
                for c in 0..3 {
                    dst.contrib[c] += src.contrib[c];
                    dst.second_contrib[c] += src.second_contrib[c];
                }
                dst.weight += src.weight;
                dst.second_weight += src.second_weight;
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn tile(x0: i32, y0: i32, x1: i32, y1: i32, k: f32) -> FilmTile {
        let mut t = FilmTile::new(Bounds2i::new(Point2i::new(x0, y0), Point2i::new(x1, y1)));
        for p in t.pixel_bounds.iter() {
            let v = 0.1 + (p.x * 7 + p.y * 3) as f32 * 1e-3 * k;
            t.add(p, Spectrum::new(v, v / 3.0, 0.7), 0.3 + v, (p.x + p.y) % 2 == 0);
        }
        t
    }

    #[test]
    fn wire_bytes_are_the_sums_in_wire_order() {
        let t = tile(0, 0, 5, 3, 1.7);
        let mut expected = Vec::new();
        for p in &t.pixels {
            crate::le::extend_f32s(&mut expected, &p.to_array());
        }
        let bytes = Pixel::wire_bytes(&t.pixels);
        if cfg!(target_endian = "little") {
            assert_eq!(bytes, Some(expected.as_slice()));
        } else {
            assert_eq!(bytes, None);
        }
    }

    #[test]
    fn merge_adds_exactly_the_overlap_pixel_by_pixel() {
        let mut a = tile(0, 0, 20, 12, 1.0);
        let b = tile(14, -3, 40, 7, 2.9);
        let mut expected = a.clone();
        for p in a.pixel_bounds.intersect(&b.pixel_bounds).iter() {
            let (s, d) = (b.pixels[b.pixel_bounds.offset(p)], a.pixel_bounds.offset(p));
            let px = &mut expected.pixels[d];
            for c in 0..3 {
                px.contrib[c] += s.contrib[c];
                px.second_contrib[c] += s.second_contrib[c];
            }
            px.weight += s.weight;
            px.second_weight += s.second_weight;
        }
        a.merge(&b);
        let bits = |t: &FilmTile| -> Vec<u32> {
            t.pixels.iter().flat_map(|p| p.to_array().map(f32::to_bits)).collect()
        };
        assert_eq!(bits(&a), bits(&expected));
        let before = bits(&a);
        a.merge(&tile(30, 20, 40, 30, 1.0));
        assert_eq!(bits(&a), before, "no overlap, no change");
    }
}
