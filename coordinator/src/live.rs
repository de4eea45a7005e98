//! The film as it renders, for whoever watches it: `farm submit` and
//! `farm watch` (over `WatchJob`), the web dashboard and tev.
//!
//! A watcher keeps a [`LiveCursor`]. The film lists the pixel bounds of
//! each tile as it is taken ([`Film::changes_since`]); the cursor turns the
//! ones it has not seen into dirty 128×128 pieces of the image, and hands
//! out the dirty pieces as they stand ([`Film::preview_sums`]) when the
//! watcher is ready for more. What a watcher costs is bounded: a bit per
//! piece, and no more pieces per look than it asks for. A piece changed
//! many times between two looks is sent once.

use crate::merge::Film;
use farm_common::geometry::{Bounds2i, Point2i};
use farm_common::image::ImagePiece;

/// Side of the pieces the image is sent in (pbrt-v4 sends tev 128×128).
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

/// What one watcher has seen of a film.
#[derive(Clone, Debug, Default)]
pub struct LiveCursor {
    /// Into the film's list of changes.
    seen: usize,
    /// Pieces changed and not yet sent (sized on first use).
    dirty: Vec<bool>,
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
        LiveCursor { seen, dirty: Vec::new() }
    }

    /// How many of the film's changes this cursor has taken in.
    pub fn position(&self) -> usize {
        self.seen
    }

    /// Marks the pieces that changed since the last look.
    pub fn catch_up(&mut self, film: &Film) {
        let b = film.geometry().cropped_pixel_bounds;
        let (w, h) = (b.width(), b.height());
        let count = pieces(w, h, Bounds2i::new(Point2i::new(0, 0), Point2i::new(w, h))).count();
        if self.dirty.len() != count {
            self.dirty = vec![false; count];
        }
        let (changes, next) = film.changes_since(self.seen);
        for c in changes {
            let local = shift(*c, -b.min.x, -b.min.y);
            for (i, _) in pieces(w, h, local) {
                self.dirty[i] = true;
            }
        }
        self.seen = next;
    }

    /// Whether a piece waits to be sent.
    pub fn pending(&self) -> bool {
        self.dirty.iter().any(|&d| d)
    }

    /// Takes up to `max` dirty pieces, first by piece order, as they stand.
    /// The rest stay dirty for the next look.
    pub fn take(&mut self, film: &Film, max: usize) -> Vec<ImagePiece> {
        self.catch_up(film);
        let b = film.geometry().cropped_pixel_bounds;
        let (w, h) = (b.width(), b.height());
        let full = Bounds2i::new(Point2i::new(0, 0), Point2i::new(w, h));
        let mut out = Vec::new();
        for (i, p) in pieces(w, h, full) {
            if out.len() >= max {
                break;
            }
            if !std::mem::take(&mut self.dirty[i]) {
                continue;
            }
            let sums = film.preview_sums(shift(p, b.min.x, b.min.y));
            out.push(ImagePiece {
                bounds: p,
                image: film.resolve(&sums),
                error: film.error_map(&sums),
            });
        }
        out
    }
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
        assert!(live.take(&film, 8).is_empty(), "nothing rendered, nothing sent");
        // A tile of the last column arrives early: it shows before the merge reaches it.
        let last = g.tile_count() - 1;
        film.accept(TileId(last), lit(&g, last, 2.0)).unwrap();
        let r = live.take(&film, 8);
        assert_eq!(r.len(), 1);
        assert_eq!(r[0].bounds.min.x, 256);
        let b = g.tile_pixel_bounds(TileId(last));
        let inside = Point2i::new(b.max.x - 1 - 256, b.max.y - 1);
        assert_eq!(
            r[0].image.pixels[(inside.y * r[0].bounds.width() + inside.x) as usize],
            [2.0; 3]
        );
        assert!(live.take(&film, 8).is_empty(), "sent once");
        // Every tile: the pieces come out at most `max` a look, and the rest wait.
        for t in 0..last {
            film.accept(TileId(t), lit(&g, t, 1.0)).unwrap();
        }
        assert_eq!(live.take(&film, 2).len(), 2);
        assert!(live.pending());
        assert_eq!(live.take(&film, 8).len(), 1);
        assert!(!live.pending());
        // A stateless watcher at position 0 sees the whole image as the film has it.
        let mut fresh = LiveCursor::at(0);
        let all = fresh.take(&film, usize::MAX);
        let image = film.image();
        for reg in &all {
            for (i, p) in reg.bounds.iter().enumerate() {
                assert_eq!(reg.image.pixels[i], image.pixels[(p.y * 300 + p.x) as usize]);
            }
        }
        assert_eq!(all.iter().map(|r| r.bounds.area()).sum::<usize>(), 300 * 40);
    }
}
