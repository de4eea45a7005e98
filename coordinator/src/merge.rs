//! The film the coordinator assembles: tiles are added strictly in tile-index
//! order (early arrivals wait in a buffer), so the float sums — and so the
//! image's bits — do not depend on how many workers rendered it, how fast
//! they were, or in what order results came back.

use crate::error::Error;
use crate::estimate::{pixel_error, ErrorEstimate, Samples};
use farm_common::film::{FilmGeometry, FilmTile, Pixel};
use farm_common::geometry::{Bounds2i, Point2i};
use farm_common::ids::TileId;
use farm_common::image::RgbImage;
use std::collections::BTreeMap;

/// Whether a tile was used.
#[derive(Debug, PartialEq, Eq, Clone, Copy)]
pub enum Accepted {
    /// New: merged now or buffered until its turn.
    New,
    /// Already merged or buffered: ignored.
    Duplicate,
}

/// The image being assembled.
#[derive(Debug)]
pub struct Film {
    geometry: FilmGeometry,
    /// The whole image as one tile of sums over the cropped pixel bounds.
    sums: FilmTile,
    next: u32,
    pending: BTreeMap<u32, FilmTile>,
    /// The pixel bounds of each tile taken, in the order taken: what a
    /// watcher needs to redraw since it last looked (each tile is taken
    /// once, so this never outgrows the tile count).
    changes: Vec<Bounds2i>,
    /// The estimate so far, kept for whoever asks (the dashboard).
    running: Running,
}

/// The error estimate of the merged tiles, brought up to date a tile at a
/// time when asked: each pixel's value as last computed (NaN where a half
/// has no samples), their sum and count, and the tiles taken in so far.
#[derive(Debug, Default)]
struct Running {
    per_pixel: Vec<f64>,
    sum: f64,
    counted: usize,
    upto: u32,
}

impl Film {
    /// An empty film.
    pub fn new(geometry: FilmGeometry) -> Self {
        let sums = FilmTile::new(geometry.cropped_pixel_bounds);
        Film {
            geometry,
            sums,
            next: 0,
            pending: BTreeMap::new(),
            changes: Vec::new(),
            running: Running::default(),
        }
    }

    /// The layout.
    pub fn geometry(&self) -> &FilmGeometry {
        &self.geometry
    }

    /// Tiles merged so far (all tiles before this index are in).
    pub fn merged(&self) -> u32 {
        self.next
    }

    /// Whether `id` is merged or waiting to be.
    pub fn has(&self, id: TileId) -> bool {
        id.0 < self.next || self.pending.contains_key(&id.0)
    }

    /// Whether every tile is in.
    pub fn is_complete(&self) -> bool {
        self.next == self.geometry.tile_count()
    }

    /// Takes one tile result; validates it, ignores duplicates, and merges
    /// every tile whose turn has come.
    pub fn accept(&mut self, id: TileId, tile: FilmTile) -> Result<Accepted, Error> {
        let verdict = self.check(id, &tile)?;
        if verdict == Accepted::New {
            self.insert(id, tile);
        }
        Ok(verdict)
    }

    /// Whether a tile result would be taken, without taking it: it must be
    /// inside the film, the tile's size, and have sums a render can make.
    pub fn check(&self, id: TileId, tile: &FilmTile) -> Result<Accepted, Error> {
        let count = self.geometry.tile_count();
        if id.0 >= count {
            return Err(Error::UnknownTile(id.0, count));
        }
        let expected = self.geometry.tile_pixel_bounds(id);
        let expected_len = if expected.is_empty() { 0 } else { expected.area() };
        if (!expected.is_empty() && tile.pixel_bounds != expected)
            || tile.pixels.len() != expected_len
        {
            return Err(Error::WrongDimensions(id.0));
        }
        if let Some(problem) = bad_pixels(tile, self.geometry.signed_weights) {
            return Err(Error::BadPixels(id.0, problem));
        }
        if self.has(id) {
            return Ok(Accepted::Duplicate);
        }
        Ok(Accepted::New)
    }

    /// Takes a tile [`Film::check`] found new, and merges every tile whose
    /// turn has come.
    pub fn insert(&mut self, id: TileId, tile: FilmTile) {
        self.changes.push(tile.pixel_bounds.intersect(&self.geometry.cropped_pixel_bounds));
        self.pending.insert(id.0, tile);
        while let Some(t) = self.pending.remove(&self.next) {
            self.sums.merge(&t);
            self.next += 1;
        }
    }

    /// The render's estimate of its own error (`None` at one sample per pixel).
    pub fn error_estimate(&self) -> Option<ErrorEstimate> {
        let g = &self.geometry;
        let samples = Samples::of(g.independent_samples);
        ErrorEstimate::from_pixels(g.cropped_pixel_bounds, &self.sums.pixels, g.scale, samples)
    }

    /// The estimate of [`Film::error_estimate`] over the tiles merged so
    /// far, for a running job's display. It is updated over the tiles
    /// merged since the last call only, so asking often costs little (the
    /// first call allocates 8 bytes a pixel). Equal to the final estimate
    /// up to the rounding of its running sum.
    pub fn running_estimate(&mut self) -> Option<f64> {
        let g = &self.geometry;
        let b = g.cropped_pixel_bounds;
        let samples = Samples::of(g.independent_samples);
        let r = &mut self.running;
        if r.per_pixel.len() != b.area() {
            r.per_pixel = vec![f64::NAN; b.area()];
        }
        for t in r.upto..self.next {
            for p in g.tile_pixel_bounds(TileId(t)).intersect(&b).iter() {
                let i = self.sums.pixel_bounds.offset(p);
                let old = r.per_pixel[i];
                if !old.is_nan() {
                    r.sum -= old;
                    r.counted -= 1;
                }
                let new = pixel_error(&self.sums.pixels[i], g.scale, samples);
                r.per_pixel[i] = new.unwrap_or(f64::NAN);
                if let Some(e) = new {
                    r.sum += e;
                    r.counted += 1;
                }
            }
        }
        r.upto = self.next;
        (r.counted > 0).then(|| r.sum.max(0.0) / r.counted as f64)
    }

    /// The running estimate's per-pixel values over `region` (image
    /// coordinates, the crop's corner at 0, 0; 0 where there is none yet),
    /// or `None` before [`Film::running_estimate`] was first asked for.
    pub fn running_error_map(&self, region: Bounds2i) -> Option<Vec<f32>> {
        let b = self.geometry.cropped_pixel_bounds;
        let per_pixel = &self.running.per_pixel;
        if per_pixel.len() != b.area() {
            return None;
        }
        let w = b.width() as usize;
        let full = Bounds2i::new(Point2i::new(0, 0), Point2i::new(b.width(), b.height()));
        let r = region.intersect(&full);
        let mut out = Vec::with_capacity(r.area());
        for y in r.min.y..r.max.y {
            let row = &per_pixel[y as usize * w..][r.min.x as usize..r.max.x as usize];
            out.extend(row.iter().map(|&e| if e.is_nan() { 0.0 } else { e as f32 }));
        }
        Some(out)
    }

    /// The regions changed since a watcher's `cursor` (0 at first), and
    /// the cursor to pass next time.
    pub fn changes_since(&self, cursor: usize) -> (&[Bounds2i], usize) {
        let from = cursor.min(self.changes.len());
        (&self.changes[from..], self.changes.len())
    }

    /// The film as it stands over `region` (clipped to the film), for
    /// display: the merged prefix plus the tiles that arrived early. The
    /// written image is [`Film::image`]; this one's sums may be added in
    /// another order, so it can differ from it in the last bits.
    pub fn preview(&self, region: Bounds2i) -> RgbImage {
        self.resolve(&self.preview_sums(region))
    }

    /// The sums behind [`Film::preview`]: the merged prefix plus the tiles
    /// that arrived early, over `region` clipped to the film (the pending
    /// tiles that meet it are few: a tile's bounds reach only its
    /// neighbours).
    pub fn preview_sums(&self, region: Bounds2i) -> FilmTile {
        let b = region.intersect(&self.geometry.cropped_pixel_bounds);
        if b.is_empty() {
            return FilmTile::new(Bounds2i::default());
        }
        let mut part = FilmTile::new(b);
        part.merge(&self.sums);
        for t in self.pending.values() {
            if !t.pixel_bounds.intersect(&b).is_empty() {
                part.merge(t);
            }
        }
        part
    }

    /// Sums (over their own bounds) resolved to pixel values, as the image is.
    pub fn resolve(&self, sums: &FilmTile) -> RgbImage {
        let b = sums.pixel_bounds;
        if b.is_empty() {
            return RgbImage { width: 0, height: 0, pixels: Vec::new() };
        }
        let scale = self.geometry.scale;
        let pixels = sums.pixels.iter().map(|p| resolve(p, scale)).collect();
        RgbImage { width: b.width() as usize, height: b.height() as usize, pixels }
    }

    /// The image: weighted sums divided by weights, clamped at zero, times
    /// the film's `scale` (pbrt-v3 `Film::WriteImage`).
    pub fn image(&self) -> RgbImage {
        let b = self.geometry.cropped_pixel_bounds;
        let scale = self.geometry.scale;
        let pixels = self.sums.pixels.iter().map(|p| resolve(p, scale)).collect();
        RgbImage { width: b.width() as usize, height: b.height() as usize, pixels }
    }
}

/// A pixel's value: its weighted sum over its weight, clamped at zero, times `scale`.
fn resolve(p: &Pixel, scale: f32) -> [f32; 3] {
    let mut rgb = p.contrib;
    if p.weight != 0.0 {
        let inv = 1.0 / p.weight;
        rgb = rgb.map(|v| (v * inv).max(0.0));
    }
    rgb.map(|v| v * scale)
}

/// What is wrong with a tile's sums, if anything: every sum must be finite,
/// and the weights non-negative unless the filter has negative lobes. A
/// real render never sends anything else (the renderer drops NaN,
/// infinite and negative samples), so such a tile comes from a broken or
/// lying worker and must not reach the image.
fn bad_pixels(tile: &FilmTile, signed_weights: bool) -> Option<String> {
    let b = tile.pixel_bounds;
    let at = |i: usize| {
        let w = b.width().max(1) as usize;
        (b.min.x + (i % w) as i32, b.min.y + (i / w) as i32)
    };
    for (i, p) in tile.pixels.iter().enumerate() {
        let v = p.to_array();
        if let Some(x) = v.iter().find(|x| !x.is_finite()) {
            let (px, py) = at(i);
            return Some(format!("pixel ({px}, {py}) has a non-finite sum {x}"));
        }
        if !signed_weights && (p.weight < 0.0 || p.second_weight < 0.0) {
            let (px, py) = at(i);
            return Some(format!(
                "pixel ({px}, {py}) has a negative weight {} with a non-negative filter",
                p.weight.min(p.second_weight)
            ));
        }
    }
    None
}

#[cfg(test)]
mod tests {
    use super::*;
    use farm_common::geometry::{Bounds2i, Point2i, Vec2};
    use farm_common::Spectrum;

    fn film() -> FilmGeometry {
        let b = Bounds2i::new(Point2i::new(0, 0), Point2i::new(40, 20));
        FilmGeometry::new(
            Point2i::new(40, 20),
            b,
            Vec2::splat(1.5),
            1.0,
            f32::INFINITY,
            "x.exr".into(),
            35.0,
        )
    }

    fn tile(g: &FilmGeometry, id: u32) -> FilmTile {
        let mut t = FilmTile::new(g.tile_pixel_bounds(TileId(id)));
        for p in t.pixel_bounds.iter() {
            let v = 0.1 + (p.x * 7 + p.y * 3 + id as i32) as f32 * 1e-3;
            t.add(p, Spectrum::new(v, 2.0 * v, 1.0 / 3.0), 0.7, p.x % 2 == 1);
        }
        t
    }

    #[test]
    fn arrival_order_does_not_change_a_bit() {
        let g = film();
        let n = g.tile_count();
        let mut a = Film::new(g.clone());
        for i in 0..n {
            a.accept(TileId(i), tile(&g, i)).unwrap();
        }
        let mut b = Film::new(g.clone());
        for i in (0..n).rev() {
            assert_eq!(b.accept(TileId(i), tile(&g, i)).unwrap(), Accepted::New);
            assert_eq!(b.accept(TileId(i), tile(&g, i)).unwrap(), Accepted::Duplicate);
        }
        assert!(a.is_complete() && b.is_complete());
        assert_eq!(a.image(), b.image());
    }

    #[test]
    fn the_preview_shows_early_tiles_and_ends_as_the_image() {
        let g = film();
        let n = g.tile_count();
        let mut f = Film::new(g.clone());
        let all = g.cropped_pixel_bounds;
        // Tile 1 arrives first: it waits for tile 0, but the preview shows it.
        f.accept(TileId(1), tile(&g, 1)).unwrap();
        assert_eq!(f.merged(), 0);
        let (changed, cursor) = f.changes_since(0);
        assert_eq!(changed, [g.tile_pixel_bounds(TileId(1)).intersect(&all)]);
        let p = f.preview(all);
        let t1 = g.tile_pixel_bounds(TileId(1));
        let inside = t1.min;
        let offset = all.offset(inside);
        assert!(p.pixels[offset][0] > 0.0, "an early tile is shown");
        let t0 = g.tile_pixel_bounds(TileId(0));
        assert_eq!(p.pixels[all.offset(t0.min)], [0.0; 3], "a missing tile is black");
        for i in (0..n).filter(|&i| i != 1) {
            f.accept(TileId(i), tile(&g, i)).unwrap();
        }
        let (changed, end) = f.changes_since(cursor);
        assert_eq!((changed.len(), end), (n as usize - 1, n as usize));
        assert!(f.changes_since(end).0.is_empty());
        // Once complete, the preview is the image.
        assert_eq!(f.preview(all), f.image());
        let corner = Bounds2i::new(Point2i::new(30, 10), Point2i::new(99, 99));
        let part = f.preview(corner);
        assert_eq!((part.width, part.height), (10, 10));
        assert_eq!(part.pixels[0], f.image().pixels[all.offset(Point2i::new(30, 10))]);
    }

    #[test]
    fn bad_tiles_are_refused() {
        let g = film();
        let mut f = Film::new(g.clone());
        let n = g.tile_count();
        assert!(
            matches!(f.accept(TileId(999), tile(&g, 0)), Err(Error::UnknownTile(999, c)) if c == n)
        );
        assert!(matches!(f.accept(TileId(1), tile(&g, 0)), Err(Error::WrongDimensions(1))));
        let mut t = tile(&g, 0);
        t.pixels.pop();
        assert!(matches!(f.accept(TileId(0), t), Err(Error::WrongDimensions(0))));
        for (k, v) in [(0, f32::NAN), (3, f32::INFINITY), (5, f32::NEG_INFINITY), (3, -0.5)] {
            let mut t = tile(&g, 2);
            let mut a = t.pixels[7].to_array();
            a[k] = v;
            t.pixels[7] = farm_common::film::Pixel::from_array(a);
            let e = f.accept(TileId(2), t).unwrap_err();
            assert!(matches!(e, Error::BadPixels(2, _)), "{e}");
        }
        assert!(!f.has(TileId(2)), "no bad tile is kept");
        // With a filter that has negative lobes, a negative weight is real.
        let mut signed = g.clone();
        signed.signed_weights = true;
        let mut f = Film::new(signed);
        let mut t = tile(&g, 2);
        t.pixels[7].weight = -0.5;
        assert_eq!(f.accept(TileId(2), t).unwrap(), Accepted::New);
    }

    #[test]
    fn the_running_estimate_follows_the_merge_and_ends_on_the_final_one() {
        let g = film();
        let mut f = Film::new(g.clone());
        assert_eq!(f.running_estimate(), None, "nothing merged");
        let n = g.tile_count();
        let halves = |id: u32| {
            let mut t = tile(&g, id);
            for p in t.pixel_bounds.iter() {
                let v = 0.2 + ((p.x * 13 + p.y * 5) % 11) as f32 * 0.03;
                t.add(p, Spectrum::new(v, v, 2.0 * v), 0.5, p.x % 2 == 0);
            }
            t
        };
        for id in 0..n {
            f.accept(TileId(id), halves(id)).unwrap();
            if id == n / 2 {
                // Half-way: the estimate of the merged sums as they stand.
                let direct = ErrorEstimate::from_pixels(
                    g.cropped_pixel_bounds,
                    &f.sums.pixels,
                    g.scale,
                    Samples::of(g.independent_samples),
                )
                .unwrap()
                .rel_mse;
                let running = f.running_estimate().unwrap();
                assert!((running - direct).abs() <= 1e-12 * direct, "{running} vs {direct}");
            }
        }
        let running = f.running_estimate().unwrap();
        let last = f.error_estimate().unwrap().rel_mse;
        assert!((running - last).abs() <= 1e-12 * last, "{running} vs {last}");
    }
}
