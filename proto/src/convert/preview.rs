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

/// Adds a piece over `bounds` (image coordinates) to `preview`: its
/// bounds, and `write` appends its sums to the preview's buffer as the
/// coordinator's film writes them, per pixel, row by row, Σw·r, Σw·g,
/// Σw·b and Σw as little-endian f32.
pub fn push_piece(
    preview: &mut v1::JobPreview,
    bounds: Bounds2i,
    write: impl FnOnce(&mut Vec<u8>),
) {
    preview.bounds.extend([bounds.min.x, bounds.min.y, bounds.max.x, bounds.max.y]);
    write(&mut preview.sums);
}

fn piece_bounds(c: &[i32; 4]) -> Bounds2i {
    Bounds2i::new(Point2i::new(c[0], c[1]), Point2i::new(c[2], c[3]))
}

/// The pieces of a preview of a `width`×`height` image, resolved to pixel
/// values with the preview's scale: each must lie in the image and be at
/// most [`PREVIEW_PIECE`] on a side, and the buffer must carry exactly
/// their pixels.
pub fn decode_preview(p: &v1::JobPreview, width: u32, height: u32) -> Result<Vec<ImagePiece>> {
    let bad = |c: &[i32]| {
        let at = |i: usize| c.get(i).copied().unwrap_or(0);
        Error::PreviewPiece { x0: at(0), y0: at(1), x1: at(2), y1: at(3), width, height }
    };
    if p.width != width || p.height != height || !p.scale.is_finite() {
        return Err(bad(&p.bounds));
    }
    let image = Bounds2i::new(Point2i::new(0, 0), Point2i::new(width as i32, height as i32));
    let (pieces, rest) = p.bounds.as_chunks::<4>();
    if !rest.is_empty() {
        return Err(bad(rest));
    }
    // Every piece checked, and the buffer's length against theirs, before
    // anything is allocated for them.
    let mut total = 0usize;
    for c in pieces {
        let b = piece_bounds(c);
        let inside = c[0] >= 0
            && c[1] >= 0
            && c[0] < c[2]
            && c[1] < c[3]
            && b.intersect(&image) == b
            && b.width() <= PREVIEW_PIECE
            && b.height() <= PREVIEW_PIECE;
        if !inside {
            return Err(bad(c));
        }
        total = total.saturating_add(b.area() * 16);
    }
    if total != p.sums.len() {
        return Err(bad(pieces.last().map_or(&[], |c| &c[..])));
    }
    let (mut sums, _) = p.sums.as_chunks::<16>();
    let out = pieces.iter().map(|c| {
        let b = piece_bounds(c);
        let (mine, rest) = sums.split_at(b.area());
        sums = rest;
        let pixels = mine.iter().map(|px| {
            let f = |k: usize| f32::from_le_bytes([px[k], px[k + 1], px[k + 2], px[k + 3]]);
            resolve([f(0), f(4), f(8)], f(12), p.scale)
        });
        let (w, h) = (b.width() as usize, b.height() as usize);
        let image = RgbImage { width: w, height: h, pixels: pixels.collect() };
        ImagePiece { bounds: b, image, error: None }
    });
    Ok(out.collect())
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Adds a piece whose pixel i sums to (2i, 1, -3) over weight 2.
    fn piece(p: &mut v1::JobPreview, x0: i32, y0: i32, x1: i32, y1: i32) {
        let b = Bounds2i::new(Point2i::new(x0, y0), Point2i::new(x1, y1));
        push_piece(p, b, |out| {
            let sums = (0..b.area()).flat_map(|i| [2.0 * i as f32, 1.0, -3.0, 2.0]);
            out.extend(sums.flat_map(f32::to_le_bytes));
        });
    }

    #[test]
    fn pieces_resolve_with_the_scale_and_lies_are_refused() {
        let mut msg = v1::JobPreview { width: 200, height: 128, scale: 0.5, ..Default::default() };
        piece(&mut msg, 0, 0, 128, 128);
        piece(&mut msg, 128, 0, 200, 50);
        let pieces = decode_preview(&msg, 200, 128).unwrap();
        assert_eq!(pieces[1].bounds, Bounds2i::new(Point2i::new(128, 0), Point2i::new(200, 50)));
        // (2i, 1, -3) / 2, clamped at zero, times 0.5.
        assert_eq!(pieces[1].image.pixels[3], [1.5, 0.25, 0.0]);
        assert_eq!(pieces[0].image.pixels[5], [2.5, 0.25, 0.0]);
        // Another image's size, a piece outside, bytes short or over, a
        // bound missing, an empty piece, a scale that is not a number.
        assert!(decode_preview(&msg, 201, 128).is_err());
        let mut m = msg.clone();
        m.bounds[6] = 201;
        assert!(decode_preview(&m, 200, 128).is_err());
        let mut m = msg.clone();
        m.sums.pop();
        assert!(decode_preview(&m, 200, 128).is_err());
        let mut m = msg.clone();
        m.sums.extend([0; 16]);
        assert!(decode_preview(&m, 200, 128).is_err());
        let mut m = msg.clone();
        m.bounds.pop();
        assert!(decode_preview(&m, 200, 128).is_err());
        let mut m = msg.clone();
        m.bounds[2] = m.bounds[0];
        assert!(decode_preview(&m, 200, 128).is_err());
        let mut m = msg;
        m.scale = f32::NAN;
        assert!(decode_preview(&m, 200, 128).is_err());
    }
}
