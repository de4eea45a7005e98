//! Live previews on the wire: pieces of a running job's image, each
//! checked on arrival against the image it claims to be part of.

use crate::error::{Error, Result};
use crate::v1;
use farm_common::film::resolve;
use farm_common::geometry::{Bounds2i, Point2i};
use farm_common::image::{ImagePiece, RgbImage};

/// The largest side of a preview piece a reader takes: a tile's pixels
/// (16 plus its filter's skirt each side), or 128 for a whole image sent
/// in pieces.
pub const PREVIEW_PIECE: i32 = 1024;

/// A preview region over `bounds` (image coordinates) carrying `sums` as
/// the coordinator's film writes them: per pixel, row by row, Σw·r, Σw·g,
/// Σw·b and Σw as little-endian f32.
pub fn preview_region(bounds: Bounds2i, sums: Vec<u8>) -> v1::PreviewRegion {
    v1::PreviewRegion {
        x0: bounds.min.x,
        y0: bounds.min.y,
        x1: bounds.max.x,
        y1: bounds.max.y,
        sums,
        error_map: Vec::new(),
    }
}

fn floats(bytes: &[u8]) -> impl Iterator<Item = f32> + '_ {
    bytes.chunks_exact(4).map(|b| f32::from_le_bytes([b[0], b[1], b[2], b[3]]))
}

/// The pieces of a preview of a `width`×`height` image, resolved to pixel
/// values with the preview's scale: each must lie in the image, be at
/// most [`PREVIEW_PIECE`] on a side and carry exactly its pixels (and an
/// error map of its size or none).
pub fn decode_preview(p: &v1::JobPreview, width: u32, height: u32) -> Result<Vec<ImagePiece>> {
    p.regions
        .iter()
        .map(|r| {
            let bad =
                || Error::PreviewPiece { x0: r.x0, y0: r.y0, x1: r.x1, y1: r.y1, width, height };
            let image =
                Bounds2i::new(Point2i::new(0, 0), Point2i::new(width as i32, height as i32));
            let b = Bounds2i::new(Point2i::new(r.x0, r.y0), Point2i::new(r.x1, r.y1));
            let inside = p.width == width
                && p.height == height
                && p.scale.is_finite()
                && r.x0 >= 0
                && r.y0 >= 0
                && r.x0 < r.x1
                && r.y0 < r.y1
                && b.intersect(&image) == b
                && b.width() <= PREVIEW_PIECE
                && b.height() <= PREVIEW_PIECE;
            if !inside {
                return Err(bad());
            }
            let n = b.area();
            if r.sums.len() != n * 16 || !(r.error_map.is_empty() || r.error_map.len() == n * 4) {
                return Err(bad());
            }
            let v: Vec<f32> = floats(&r.sums).collect();
            let pixels = v.chunks_exact(4).map(|s| resolve([s[0], s[1], s[2]], s[3], p.scale));
            let error = (!r.error_map.is_empty()).then(|| floats(&r.error_map).collect());
            let (w, h) = (b.width() as usize, b.height() as usize);
            let image = RgbImage { width: w, height: h, pixels: pixels.collect() };
            Ok(ImagePiece { bounds: b, image, error })
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A region whose pixel i sums to (2i, 1, -3) over weight 2, with an error map.
    fn region(x0: i32, y0: i32, x1: i32, y1: i32) -> v1::PreviewRegion {
        let b = Bounds2i::new(Point2i::new(x0, y0), Point2i::new(x1, y1));
        let sums = (0..b.area())
            .flat_map(|i| [2.0 * i as f32, 1.0, -3.0, 2.0])
            .flat_map(f32::to_le_bytes)
            .collect();
        let mut r = preview_region(b, sums);
        r.error_map = vec![0; b.area() * 4];
        r
    }

    #[test]
    fn pieces_resolve_with_the_scale_and_lies_are_refused() {
        let regions = vec![region(0, 0, 128, 128), region(128, 0, 200, 50)];
        let msg = v1::JobPreview { width: 200, height: 128, scale: 0.5, regions };
        let pieces = decode_preview(&msg, 200, 128).unwrap();
        assert_eq!(pieces[1].bounds, Bounds2i::new(Point2i::new(128, 0), Point2i::new(200, 50)));
        // (2i, 1, -3) / 2, clamped at zero, times 0.5.
        assert_eq!(pieces[1].image.pixels[3], [1.5, 0.25, 0.0]);
        assert_eq!(pieces[0].error.as_ref().map(Vec::len), Some(128 * 128));
        // Another image's size, a piece outside, bytes short, an odd error
        // map, an empty piece, a scale that is not a number.
        assert!(decode_preview(&msg, 201, 128).is_err());
        let mut m = msg.clone();
        m.regions[1].x1 = 201;
        assert!(decode_preview(&m, 200, 128).is_err());
        let mut m = msg.clone();
        m.regions[0].sums.pop();
        assert!(decode_preview(&m, 200, 128).is_err());
        let mut m = msg.clone();
        m.regions[0].error_map.truncate(4);
        assert!(decode_preview(&m, 200, 128).is_err());
        let mut m = msg.clone();
        m.regions[0].x1 = m.regions[0].x0;
        assert!(decode_preview(&m, 200, 128).is_err());
        let mut m = msg;
        m.scale = f32::NAN;
        assert!(decode_preview(&m, 200, 128).is_err());
    }
}
