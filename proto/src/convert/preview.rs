//! Live previews on the wire: pieces of a running job's image, each
//! checked on arrival against the image it claims to be part of.

use crate::error::{Error, Result};
use crate::v1;
use farm_common::geometry::{Bounds2i, Point2i};
use farm_common::image::{ImagePiece, RgbImage};

/// The largest side of a preview piece a reader takes: a tile's pixels
/// (16 plus its filter's skirt each side), or 128 for a whole image sent
/// in pieces.
pub const PREVIEW_PIECE: i32 = 1024;

/// The preview event of `pieces` of a `width`×`height` image.
pub fn encode_preview(width: u32, height: u32, pieces: &[ImagePiece]) -> v1::JobPreview {
    let regions = pieces
        .iter()
        .map(|p| v1::PreviewRegion {
            x0: p.bounds.min.x,
            y0: p.bounds.min.y,
            x1: p.bounds.max.x,
            y1: p.bounds.max.y,
            rgb: p.image.pixels.iter().flatten().flat_map(|v| v.to_le_bytes()).collect(),
            error_map: p.error.iter().flatten().flat_map(|v| v.to_le_bytes()).collect(),
        })
        .collect();
    v1::JobPreview { width, height, regions }
}

fn floats(bytes: &[u8]) -> impl Iterator<Item = f32> + '_ {
    bytes.chunks_exact(4).map(|b| f32::from_le_bytes([b[0], b[1], b[2], b[3]]))
}

/// The pieces of a preview of a `width`×`height` image: each must lie in
/// the image, be at most [`PREVIEW_PIECE`] on a side and carry exactly its
/// pixels (and an error map of its size or none).
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
            if r.rgb.len() != n * 12 || !(r.error_map.is_empty() || r.error_map.len() == n * 4) {
                return Err(bad());
            }
            let v: Vec<f32> = floats(&r.rgb).collect();
            let pixels = v.chunks_exact(3).map(|c| [c[0], c[1], c[2]]).collect();
            let error = (!r.error_map.is_empty()).then(|| floats(&r.error_map).collect());
            let image = RgbImage { width: b.width() as usize, height: b.height() as usize, pixels };
            Ok(ImagePiece { bounds: b, image, error })
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    fn piece(x0: i32, y0: i32, x1: i32, y1: i32) -> ImagePiece {
        let b = Bounds2i::new(Point2i::new(x0, y0), Point2i::new(x1, y1));
        let pixels = (0..b.area()).map(|i| [i as f32, 0.5, -1.0]).collect();
        let image = RgbImage { width: b.width() as usize, height: b.height() as usize, pixels };
        ImagePiece { bounds: b, image, error: Some(vec![0.25; b.area()]) }
    }

    #[test]
    fn pieces_round_trip_and_lies_are_refused() {
        let pieces = vec![piece(0, 0, 128, 128), piece(128, 0, 200, 50)];
        let msg = encode_preview(200, 128, &pieces);
        assert_eq!(decode_preview(&msg, 200, 128).unwrap(), pieces);
        // Another image's size, a piece outside, bytes short, an odd error map.
        assert!(decode_preview(&msg, 201, 128).is_err());
        let mut m = msg.clone();
        m.regions[1].x1 = 201;
        assert!(decode_preview(&m, 200, 128).is_err());
        let mut m = msg.clone();
        m.regions[0].rgb.pop();
        assert!(decode_preview(&m, 200, 128).is_err());
        let mut m = msg.clone();
        m.regions[0].error_map.truncate(4);
        assert!(decode_preview(&m, 200, 128).is_err());
        let mut m = msg;
        m.regions[0].x1 = m.regions[0].x0;
        assert!(decode_preview(&m, 200, 128).is_err());
    }
}
