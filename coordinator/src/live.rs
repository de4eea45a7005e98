//! The film as it renders, for whoever watches it: `farm submit` and
//! `farm watch` (over `WatchJob`), the web dashboard and tev.
//!
//! A watcher keeps a [`LiveCursor`]. The film lists the pixels whose sums
//! became complete, in the order they did ([`Film::changes_since`]: a
//! tile's interior as soon as it arrives, the rest of its pixels when the
//! merge reaches it); the cursor queues the regions it has not seen, and
//! hands them out when the watcher is ready for more, to be read as they
//! stand ([`Film::region_sums`], [`Film::preview`]). Over a whole render a
//! watcher is sent each pixel once, with its final sums, however often it
//! looks. What a watcher holds is bounded by the tile count.

use crate::merge::Film;
use farm_common::geometry::{Bounds2i, Point2i};
use farm_common::image::{ImagePiece, RgbImage};

/// Side of the pieces a whole image is sent in (pbrt-v4 sends tev 128×128).
pub const PIECE: i32 = 128;

/// The `PIECE`×`PIECE` pieces of a `width`×`height` image, numbered row by
/// row, that meet `r` (image coordinates).
pub fn pieces(width: i32, height: i32, r: Bounds2i) -> impl Iterator<Item = (usize, Bounds2i)> {
    let r = r.intersect(&Bounds2i::new(Point2i::new(0, 0), Point2i::new(width, height)));
    let cols = (width + PIECE - 1) / PIECE;
    let (x0, y0) = (r.min.x / PIECE, r.min.y / PIECE);
    let (x1, y1) = if r.is_empty() {
        (x0, y0)
    } else {
        ((r.max.x + PIECE - 1) / PIECE, (r.max.y + PIECE - 1) / PIECE)
    };
    (y0..y1).flat_map(move |py| {
        (x0..x1).map(move |px| {
            let min = Point2i::new(px * PIECE, py * PIECE);
            let max = Point2i::new((min.x + PIECE).min(width), (min.y + PIECE).min(height));
            ((py * cols + px) as usize, Bounds2i::new(min, max))
        })
    })
}

/// A whole image (and its per-pixel error map, if given) as
/// [`PIECE`]-sized pieces, as a finished image is sent to a display.
pub fn whole_pieces(image: &RgbImage, error: Option<&[f32]>) -> Vec<ImagePiece> {
    let (w, h) = (image.width as i32, image.height as i32);
    let full = Bounds2i::new(Point2i::new(0, 0), Point2i::new(w, h));
    pieces(w, h, full)
        .map(|(_, b)| {
            let idx: Vec<usize> = b.iter().map(|q| (q.y * w + q.x) as usize).collect();
            let pixels = idx.iter().map(|&i| image.pixels[i]).collect();
            let img = RgbImage { width: b.width() as usize, height: b.height() as usize, pixels };
            let err =
                error.map(|e| idx.iter().map(|&i| e.get(i).copied().unwrap_or(0.0)).collect());
            ImagePiece { bounds: b, image: img, error: err }
        })
        .collect()
}

/// What one watcher has seen of a film.
#[derive(Clone, Debug, Default)]
pub struct LiveCursor {
    /// Into the film's list of changes.
    seen: usize,
    /// Regions changed and not yet sent (image coordinates).
    pending: std::collections::VecDeque<Bounds2i>,
}

impl LiveCursor {
    /// A watcher that has seen nothing (so its first look covers every
    /// tile taken so far).
    pub fn new() -> Self {
        Self::default()
    }

    /// A cursor at `seen` changes (from [`LiveCursor::position`]), as a
    /// stateless watcher (a dashboard page) passes it back.
    pub fn at(seen: usize) -> Self {
        LiveCursor { seen, pending: Default::default() }
    }

    /// How many of the film's changes this cursor has taken in.
    pub fn position(&self) -> usize {
        self.seen
    }

    /// Queues the regions that changed since the last look.
    pub fn catch_up(&mut self, film: &Film) {
        let b = film.geometry().cropped_pixel_bounds;
        let (changes, next) = film.changes_since(self.seen);
        self.pending.extend(changes.iter().map(|c| shift(*c, -b.min.x, -b.min.y)));
        self.seen = next;
    }

    /// Whether a region waits to be sent.
    pub fn pending(&self) -> bool {
        !self.pending.is_empty()
    }

    /// Catches up with `film` and counts the pixels waiting to be sent.
    pub fn waiting(&mut self, film: &Film) -> usize {
        self.catch_up(film);
        self.pending.iter().map(Bounds2i::area).sum()
    }

    /// Takes changed regions (image coordinates), oldest first: at least
    /// one, and no more once they hold `max_pixels`. The rest wait for the
    /// next look. The caller reads them off the film as they stand now.
    pub fn take(&mut self, film: &Film, max_pixels: usize) -> Vec<Bounds2i> {
        self.catch_up(film);
        let mut n = 0;
        let mut pixels = 0usize;
        for r in &self.pending {
            if n > 0 && pixels.saturating_add(r.area()) > max_pixels {
                break;
            }
            pixels = pixels.saturating_add(r.area());
            n += 1;
        }
        strips(self.pending.drain(..n))
    }

    /// [`LiveCursor::take`], with each region's pixels as they stand, for
    /// a display in the same process.
    pub fn take_pieces(&mut self, film: &Film, max_pixels: usize) -> Vec<ImagePiece> {
        let b = film.geometry().cropped_pixel_bounds;
        self.take(film, max_pixels)
            .into_iter()
            .map(|r| ImagePiece {
                bounds: r,
                image: film.preview(shift(r, b.min.x, b.min.y)),
                error: None,
            })
            .collect()
    }
}

/// Regions with neighbours in a row joined into strips (up to [`PIECE`]
/// wide): one region costs less than several.
pub fn strips(regions: impl IntoIterator<Item = Bounds2i>) -> Vec<Bounds2i> {
    let mut strips: Vec<Bounds2i> = Vec::new();
    for r in regions.into_iter().filter(|r| !r.is_empty()) {
        match strips.last_mut() {
            Some(s)
                if s.min.y == r.min.y
                    && s.max.y == r.max.y
                    && r.min.x <= s.max.x
                    && r.max.x >= s.min.x
                    && (s.max.x.max(r.max.x) - s.min.x.min(r.min.x)) <= PIECE =>
            {
                s.min.x = s.min.x.min(r.min.x);
                s.max.x = s.max.x.max(r.max.x);
            }
            _ => strips.push(r),
        }
    }
    strips
}

/// `r` moved by (dx, dy).
pub fn shift(r: Bounds2i, dx: i32, dy: i32) -> Bounds2i {
    Bounds2i::new(
        Point2i::new(r.min.x + dx, r.min.y + dy),
        Point2i::new(r.max.x + dx, r.max.y + dy),
    )
}

#[cfg(test)]
mod tests {
    use super::*;
    use farm_common::film::{FilmGeometry, FilmTile};
    use farm_common::geometry::Vec2;
    use farm_common::ids::TileId;

    #[test]
    fn pieces_cover_a_region_once() {
        let r = Bounds2i::new(Point2i::new(100, 0), Point2i::new(300, 10));
        let p: Vec<(usize, Bounds2i)> = pieces(300, 200, r).collect();
        assert_eq!(p.len(), 3);
        assert_eq!(p[2], (2, Bounds2i::new(Point2i::new(256, 0), Point2i::new(300, 128))));
        let below = Bounds2i::new(Point2i::new(0, 130), Point2i::new(10, 140));
        assert_eq!(pieces(300, 200, below).next().unwrap().0, 3);
        let outside = Bounds2i::new(Point2i::new(400, 0), Point2i::new(500, 5));
        assert_eq!(pieces(300, 200, outside).count(), 0);
    }

    fn geometry(w: i32, h: i32) -> FilmGeometry {
        let b = Bounds2i::new(Point2i::new(0, 0), Point2i::new(w, h));
        let r = Vec2::splat(1.5);
        FilmGeometry::new(Point2i::new(w, h), b, r, 1.0, f32::INFINITY, "x.exr".into(), 35.0)
    }

    fn lit(g: &FilmGeometry, id: u32, value: f32) -> FilmTile {
        let mut t = FilmTile::new(g.tile_pixel_bounds(TileId(id)));
        for p in t.pixel_bounds.iter() {
            t.add(p, farm_common::Spectrum::splat(value), 1.0, false);
            t.add(p, farm_common::Spectrum::splat(value), 1.0, true);
        }
        t
    }

    #[test]
    fn a_watcher_gets_each_changed_piece_as_it_stands_and_only_once() {
        let g = geometry(300, 40);
        let mut film = Film::new(g.clone());
        let mut live = LiveCursor::new();
        assert!(live.take(&film, usize::MAX).is_empty(), "nothing rendered, nothing sent");
        // A tile of the last column arrives early: it shows before the merge reaches it.
        let last = g.tile_count() - 1;
        film.accept(TileId(last), lit(&g, last, 2.0)).unwrap();
        let r = live.take_pieces(&film, usize::MAX);
        assert_eq!(r.len(), 1);
        let b = g.tile_interior_pixels(TileId(last));
        assert_eq!(r[0].bounds, b, "the pixels only it reaches (the film starts at 0, 0)");
        assert!(r[0].image.pixels.iter().all(|p| *p == [2.0; 3]));
        assert!(live.take(&film, usize::MAX).is_empty(), "sent once");
        // Every tile: the regions come out up to a budget a look, and the rest wait.
        for t in 0..last {
            film.accept(TileId(t), lit(&g, t, 1.0)).unwrap();
        }
        let (t0, t1) = (g.tile_final_pixels(TileId(0)), g.tile_final_pixels(TileId(1)));
        let strip = live.take(&film, t0.area() + t1.area());
        assert_eq!(strip.len(), 1, "a row's neighbours come out as one strip");
        assert_eq!(strip[0], Bounds2i::new(t0.min, Point2i::new(t1.max.x, t0.max.y)));
        assert_eq!(live.take(&film, 1).len(), 1, "at least one");
        assert!(live.pending());
        let rest = live.take(&film, usize::MAX);
        assert!(rest.iter().all(|r| r.width() <= PIECE));
        assert!(!live.pending());
        // A stateless watcher at position 0 sees the whole image as the film has it.
        let all = LiveCursor::at(0).take_pieces(&film, usize::MAX);
        let image = film.image();
        let mut covered = vec![false; 300 * 40];
        for reg in &all {
            for (i, p) in reg.bounds.iter().enumerate() {
                assert_eq!(reg.image.pixels[i], image.pixels[(p.y * 300 + p.x) as usize]);
                covered[(p.y * 300 + p.x) as usize] = true;
            }
        }
        assert!(covered.iter().all(|&c| c), "the regions cover the image");
    }
}
