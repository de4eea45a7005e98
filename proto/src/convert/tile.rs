//! Film tiles travel as raw little-endian f32 bytes: eight per pixel (see
//! [`Pixel::to_array`]).

use crate::error::Error;
use crate::v1;
use farm_common::film::{FilmTile, Pixel};
use farm_common::geometry::{Bounds2i, Point2i};

/// Bytes of one pixel on the wire.
pub const PIXEL_BYTES: usize = 32;

impl From<&FilmTile> for v1::FilmTile {
    fn from(t: &FilmTile) -> Self {
        let mut pixels = Vec::with_capacity(t.pixels.len() * PIXEL_BYTES);
        for p in &t.pixels {
            for v in p.to_array() {
                pixels.extend_from_slice(&v.to_le_bytes());
            }
        }
        let b = t.pixel_bounds;
        v1::FilmTile { x0: b.min.x, y0: b.min.y, x1: b.max.x, y1: b.max.y, pixels }
    }
}

impl TryFrom<&v1::FilmTile> for FilmTile {
    type Error = Error;

    fn try_from(t: &v1::FilmTile) -> Result<Self, Self::Error> {
        let bad = Error::BadBounds { x0: t.x0, y0: t.y0, x1: t.x1, y1: t.y1 };
        let (w, h) = (t.x1 as i64 - t.x0 as i64, t.y1 as i64 - t.y0 as i64);
        if w < 0 || h < 0 || w * h > 1 << 24 {
            return Err(bad);
        }
        let n = (w * h) as usize;
        if t.pixels.len() != n * PIXEL_BYTES {
            return Err(Error::WrongSize { got: t.pixels.len(), want: n * PIXEL_BYTES });
        }
        let pixels = t
            .pixels
            .chunks_exact(PIXEL_BYTES)
            .map(|b| {
                let mut v = [0.0f32; 8];
                for (k, x) in v.iter_mut().enumerate() {
                    *x = f32::from_le_bytes([b[4 * k], b[4 * k + 1], b[4 * k + 2], b[4 * k + 3]]);
                }
                Pixel::from_array(v)
            })
            .collect();
        let pixel_bounds = Bounds2i::new(Point2i::new(t.x0, t.y0), Point2i::new(t.x1, t.y1));
        Ok(FilmTile { pixel_bounds, pixels })
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use farm_common::Spectrum;

    #[test]
    fn tiles_round_trip_bit_for_bit() {
        let mut t = FilmTile::new(Bounds2i::new(Point2i::new(-2, 3), Point2i::new(5, 7)));
        t.add(Point2i::new(0, 4), Spectrum::new(0.1, f32::MIN_POSITIVE, 1e30), 0.3, false);
        t.add(Point2i::new(1, 5), Spectrum::new(-2.0, 7.5, 1e-30), -0.25, true);
        let wire = v1::FilmTile::from(&t);
        assert_eq!(FilmTile::try_from(&wire), Ok(t));
    }

    #[test]
    fn wrong_sizes_and_bounds_are_refused() {
        let t = FilmTile::new(Bounds2i::new(Point2i::new(0, 0), Point2i::new(2, 2)));
        let mut wire = v1::FilmTile::from(&t);
        wire.pixels.pop();
        assert_eq!(FilmTile::try_from(&wire), Err(Error::WrongSize { got: 127, want: 128 }));
        wire.x1 = -5;
        assert!(matches!(FilmTile::try_from(&wire), Err(Error::BadBounds { .. })));
    }
}
