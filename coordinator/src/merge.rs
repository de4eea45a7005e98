//! The film the coordinator assembles: tiles are added strictly in tile-index
//! order (early arrivals wait in a buffer), so the float sums — and so the
//! image's bits — do not depend on how many workers rendered it, how fast
//! they were, or in what order results came back.

use crate::error::Error;
use crate::estimate::{pixel_error, ErrorEstimate, Samples};
use farm_common::film::{FilmGeometry, FilmTile};
use farm_common::geometry::{Bounds2i, Point2i};
use farm_common::ids::TileId;
use farm_common::image::RgbImage;
use std::collections::BTreeMap;

/// Four floats as 16 little-endian bytes.
#[inline]
fn le_bytes(v: [f32; 4]) -> [u8; 16] {
    let mut out = [0u8; 16];
    for (d, x) in out.chunks_exact_mut(4).zip(v) {
        d.copy_from_slice(&x.to_le_bytes());
    }
    out
}

/// Appends `rows` to `out` (`count` values in all), each value as `f`
/// encodes it, written in place: one zero-fill of the room, no per-row or
/// per-value growth and no second copy.
fn append_rows<'a, T: 'a, const N: usize>(
    out: &mut Vec<u8>,
    count: usize,
    rows: impl Iterator<Item = &'a [T]>,
    f: impl Fn(&T) -> [u8; N],
) {
    let start = out.len();
    out.resize(start + count * N, 0);
    let (mut dst, _) = out[start..].as_chunks_mut::<N>();
    for row in rows {
        let (d, rest) = dst.split_at_mut(row.len().min(dst.len()));
        for (d, v) in d.iter_mut().zip(row) {
            *d = f(v);
        }
        dst = rest;
    }
    debug_assert!(dst.is_empty(), "rows fill the room");
}

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
    /// The pixels whose sums became complete, in the order they did: what
    /// a watcher needs to draw since it last looked, each pixel once. A
    /// tile merged in turn completes its final pixels; one that arrives
    /// early, its interior at once and the rest of its final pixels when
    /// merged. Never more than five regions a tile.
    changes: Vec<Bounds2i>,
    /// The estimate so far, kept for whoever asks (the dashboard).
    running: Running,
    /// Each tile's [`FilmGeometry::tile_final_pixels`] within the crop,
    /// worked out once: merging, the running estimate and every watcher
    /// ask for them.
    finals: Vec<Bounds2i>,
}

/// The error estimate of the merged tiles, brought up to date a tile at a
/// time when asked: each complete pixel's value as the error map shows it
/// (0 where a half has no samples or the pixel is not complete yet), the
/// sum and count of the values, and the tiles taken in so far.
#[derive(Debug, Default)]
struct Running {
    map: Vec<f32>,
    sum: f64,
    counted: usize,
    upto: u32,
}

impl Film {
    /// An empty film.
    pub fn new(geometry: FilmGeometry) -> Self {
        let sums = FilmTile::new(geometry.cropped_pixel_bounds);
        let crop = geometry.cropped_pixel_bounds;
        let finals = (0..geometry.tile_count())
            .map(|t| geometry.tile_final_pixels(TileId(t)).intersect(&crop))
            .collect();
        Film {
            geometry,
            sums,
            next: 0,
            pending: BTreeMap::new(),
            changes: Vec::new(),
            running: Running::default(),
            finals,
        }
    }

    /// The layout.
    pub fn geometry(&self) -> &FilmGeometry {
        &self.geometry
    }

    /// Tile `t`'s [`FilmGeometry::tile_final_pixels`] within the crop
    /// (empty past the last tile).
    pub fn final_pixels(&self, t: TileId) -> Bounds2i {
        self.finals.get(t.0 as usize).copied().unwrap_or_default()
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
        let g = &self.geometry;
        let crop = g.cropped_pixel_bounds;
        let early = id.0 != self.next;
        if early {
            let inside = g.tile_interior_pixels(id).intersect(&crop);
            self.changes.extend(Some(inside).filter(|r| !r.is_empty()));
        }
        self.pending.insert(id.0, tile);
        while let Some(t) = self.pending.remove(&self.next) {
            self.sums.merge(&t);
            let t = TileId(self.next);
            self.next += 1;
            let fin = self.finals[t.0 as usize];
            if t == id && !early {
                self.changes.extend(Some(fin).filter(|r| !r.is_empty()));
            } else {
                let shown = g.tile_interior_pixels(t);
                self.changes.extend(fin.minus(&shown).into_iter().filter(|r| !r.is_empty()));
            }
        }
    }

    /// The render's estimate of its own error (`None` at one sample per
    /// pixel): [`ErrorEstimate::from_pixels`] of the merged film, its
    /// pixels' errors summed tile by tile, as [`Film::running_estimate`]
    /// sums them, so a watched render (whose running estimate has taken in
    /// most tiles already) and an unwatched one give the same bits, and no
    /// pixel's error is computed twice.
    pub fn error_estimate(&mut self) -> Option<ErrorEstimate> {
        self.running_estimate()?;
        let b = self.geometry.cropped_pixel_bounds;
        let r = &self.running;
        Some(ErrorEstimate {
            width: b.width() as usize,
            height: b.height() as usize,
            per_pixel: r.map.clone(),
            rel_mse: r.sum / r.counted as f64,
        })
    }

    /// The estimate of [`Film::error_estimate`] over the pixels whose sums
    /// are complete ([`FilmGeometry::tile_final_pixels`] of the tiles
    /// merged so far), for a running job's display. Each pixel's error is
    /// computed once, when its last tile is merged, so asking often costs
    /// little (the first call allocates 4 bytes a pixel); once every tile
    /// is in, [`Film::error_estimate`] reads it off.
    pub fn running_estimate(&mut self) -> Option<f64> {
        let g = &self.geometry;
        let b = g.cropped_pixel_bounds;
        let samples = Samples::of(g.independent_samples);
        let r = &mut self.running;
        if r.map.len() != b.area() {
            r.map = vec![0.0; b.area()];
        }
        for t in r.upto..self.next {
            let fin = self.finals[t as usize];
            for y in fin.min.y..fin.max.y {
                let i = self.sums.pixel_bounds.offset(Point2i::new(fin.min.x, y));
                let n = fin.width() as usize;
                let out = &mut r.map[i..i + n];
                for (e, p) in out.iter_mut().zip(&self.sums.pixels[i..i + n]) {
                    if let Some(v) = pixel_error(p, g.scale, samples) {
                        *e = v as f32;
                        r.sum += v;
                        r.counted += 1;
                    }
                }
            }
        }
        r.upto = self.next;
        (r.counted > 0).then(|| r.sum.max(0.0) / r.counted as f64)
    }

    /// Whether [`Film::running_estimate`] was asked for.
    pub fn has_running_estimate(&self) -> bool {
        self.running.map.len() == self.geometry.cropped_pixel_bounds.area()
    }

    /// Appends the running estimate's per-pixel values over `region`
    /// (image coordinates, the crop's corner at 0, 0; 0 where there is
    /// none yet) to `out` as little-endian f32, and returns true; or
    /// returns false, appending nothing, before [`Film::running_estimate`]
    /// was first asked for.
    pub fn write_error_map(&self, region: Bounds2i, out: &mut Vec<u8>) -> bool {
        let b = self.geometry.cropped_pixel_bounds;
        let map = &self.running.map;
        if map.len() != b.area() {
            return false;
        }
        let w = b.width() as usize;
        let full = Bounds2i::new(Point2i::new(0, 0), Point2i::new(b.width(), b.height()));
        let r = region.intersect(&full);
        if r.is_empty() {
            return true;
        }
        let rows =
            (r.min.y..r.max.y).map(|y| &map[y as usize * w..][r.min.x as usize..r.max.x as usize]);
        append_rows(out, r.area(), rows, |e| e.to_le_bytes());
        true
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
        let sums = self.preview_sums(region);
        let b = sums.pixel_bounds;
        let scale = self.geometry.scale;
        let pixels = sums.pixels.iter().map(|p| p.resolve(scale)).collect();
        RgbImage { width: b.width() as usize, height: b.height() as usize, pixels }
    }

    /// The sums over `region` (clipped to the film) as they stand: the
    /// merged prefix plus the tiles that arrived early.
    fn preview_sums(&self, region: Bounds2i) -> FilmTile {
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

    /// The film as it stands over `region` (clipped to the film; as
    /// [`Film::preview`] has it), unresolved: per pixel, row by row,
    /// Σw·r, Σw·g, Σw·b and Σw as little-endian f32, 16 bytes. A watcher
    /// resolves them ([`farm_common::film::resolve`] with the film's
    /// scale), so the coordinator only copies.
    pub fn region_sums(&self, region: Bounds2i) -> Vec<u8> {
        let mut out = Vec::new();
        self.write_region_sums(region, &mut out);
        out
    }

    /// [`Film::region_sums`], appended to `out`.
    pub fn write_region_sums(&self, region: Bounds2i, out: &mut Vec<u8>) {
        let b = region.intersect(&self.geometry.cropped_pixel_bounds);
        if b.is_empty() {
            return;
        }
        let n = b.width() as usize;
        let start = out.len();
        let rows = (b.min.y..b.max.y).map(|y| {
            let i = self.sums.pixel_bounds.offset(Point2i::new(b.min.x, y));
            &self.sums.pixels[i..i + n]
        });
        append_rows(out, b.area(), rows, |p| {
            let [r, g, bl] = p.contrib;
            le_bytes([r, g, bl, p.weight])
        });
        // Tiles that arrived early add where they overlap (in the order of
        // their ids; for display only).
        let (mine, _) = out[start..].as_chunks_mut::<16>();
        for t in self.pending.values() {
            let o = t.pixel_bounds.intersect(&b);
            if o.is_empty() {
                continue;
            }
            let m = o.width() as usize;
            for y in o.min.y..o.max.y {
                let row = Point2i::new(o.min.x, y);
                let (s, d) = (t.pixel_bounds.offset(row), b.offset(row));
                for (d, p) in mine[d..d + m].iter_mut().zip(&t.pixels[s..s + m]) {
                    let f = |k: usize| f32::from_le_bytes([d[k], d[k + 1], d[k + 2], d[k + 3]]);
                    let [r, g, bl] = p.contrib;
                    *d = le_bytes([f(0) + r, f(4) + g, f(8) + bl, f(12) + p.weight]);
                }
            }
        }
    }

    /// The image: weighted sums divided by weights, clamped at zero, times
    /// the film's `scale` (pbrt-v3 `Film::WriteImage`).
    pub fn image(&self) -> RgbImage {
        let b = self.geometry.cropped_pixel_bounds;
        let scale = self.geometry.scale;
        let pixels = self.sums.pixels.iter().map(|p| p.resolve(scale)).collect();
        RgbImage { width: b.width() as usize, height: b.height() as usize, pixels }
    }
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
        assert_eq!(changed, [g.tile_interior_pixels(TileId(1))]);
        let p = f.preview(all);
        let inside = changed[0].min;
        let offset = all.offset(inside);
        assert!(p.pixels[offset][0] > 0.0, "an early tile is shown");
        let t0 = g.tile_pixel_bounds(TileId(0));
        assert_eq!(p.pixels[all.offset(t0.min)], [0.0; 3], "a missing tile is black");
        for i in (0..n).filter(|&i| i != 1) {
            f.accept(TileId(i), tile(&g, i)).unwrap();
        }
        let (changed, end) = f.changes_since(cursor);
        assert_eq!(end, cursor + changed.len());
        assert!(f.changes_since(end).0.is_empty());
        // Once complete, the preview is the image.
        assert_eq!(f.preview(all), f.image());
        let corner = Bounds2i::new(Point2i::new(30, 10), Point2i::new(99, 99));
        let part = f.preview(corner);
        assert_eq!((part.width, part.height), (10, 10));
        assert_eq!(part.pixels[0], f.image().pixels[all.offset(Point2i::new(30, 10))]);
    }

    #[test]
    fn watchers_are_shown_each_pixel_once_when_its_sums_are_complete() {
        let g = film();
        let n = g.tile_count();
        let all = g.cropped_pixel_bounds;
        let mut whole = Film::new(g.clone());
        for i in 0..n {
            whole.accept(TileId(i), tile(&g, i)).unwrap();
        }
        // In order, backwards, and shuffled (a fixed multiplicative walk).
        let orders: [Vec<u32>; 3] =
            [(0..n).collect(), (0..n).rev().collect(), (0..n).map(|i| (i * 5 + 3) % n).collect()];
        assert!(!n.is_multiple_of(5), "the walk visits every tile");
        for order in orders {
            let mut f = Film::new(g.clone());
            let (mut cursor, mut times) = (0, vec![0u32; all.area()]);
            for i in order {
                f.accept(TileId(i), tile(&g, i)).unwrap();
                let (changed, next) = f.changes_since(cursor);
                for r in changed {
                    // Shown as they will be in the image, to the bit.
                    assert_eq!(f.region_sums(*r), whole.region_sums(*r), "{r:?} after {i}");
                    for p in r.iter() {
                        times[all.offset(p)] += 1;
                    }
                }
                cursor = next;
            }
            assert!(times.iter().all(|&t| t == 1), "each pixel shown once");
        }
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
        let mut unwatched = Film::new(g.clone());
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
        let b = g.cropped_pixel_bounds;
        let samples = Samples::of(g.independent_samples);
        for id in 0..n {
            f.accept(TileId(id), halves(id)).unwrap();
            unwatched.accept(TileId(id), halves(id)).unwrap();
            if id == n / 2 || id == 2 {
                // Mid-render: the mean error of the pixels no later tile reaches.
                let later: Vec<Bounds2i> =
                    (id + 1..n).map(|t| g.tile_pixel_bounds(TileId(t))).collect();
                let done = |p: Point2i| later.iter().all(|l| l.intersect(&single(p)).is_empty());
                let errors: Vec<f64> = b
                    .iter()
                    .filter(|&p| done(p))
                    .filter_map(|p| pixel_error(&f.sums.pixels[b.offset(p)], g.scale, samples))
                    .collect();
                let direct = errors.iter().sum::<f64>() / errors.len() as f64;
                let running = f.running_estimate().unwrap();
                assert!((running - direct).abs() <= 1e-12 * direct, "{running} vs {direct}");
                let mut map = Vec::new();
                assert!(f.write_error_map(b, &mut map));
                let shown = map.chunks_exact(4).filter(|c| c != &[0; 4]).count();
                assert_eq!(shown, errors.len(), "the map shows the complete pixels");
            }
        }
        let running = f.running_estimate().unwrap();
        let watched = f.error_estimate().unwrap();
        let plain = unwatched.error_estimate().unwrap();
        assert_eq!(watched.rel_mse.to_bits(), plain.rel_mse.to_bits(), "the same bits");
        assert_eq!(watched, plain);
        assert!((running - plain.rel_mse).abs() <= 1e-12 * plain.rel_mse);
        // The estimate of the whole film at once: the same per-pixel values,
        // and the same mean but for the order of the sum.
        let direct = ErrorEstimate::from_pixels(b, &f.sums.pixels, g.scale, samples).unwrap();
        let bits = |e: &ErrorEstimate| e.per_pixel.iter().map(|v| v.to_bits()).collect::<Vec<_>>();
        assert_eq!(bits(&plain), bits(&direct));
        assert_eq!((plain.width, plain.height), (direct.width, direct.height));
        assert!((direct.rel_mse - plain.rel_mse).abs() <= 1e-12 * plain.rel_mse);
        // One sample per pixel: no estimate.
        let mut one = Film::new(g.clone());
        for id in 0..n {
            let mut t = FilmTile::new(g.tile_pixel_bounds(TileId(id)));
            for p in t.pixel_bounds.iter() {
                t.add(p, Spectrum::new(0.5, 0.5, 0.5), 1.0, false);
            }
            one.accept(TileId(id), t).unwrap();
        }
        assert!(one.error_estimate().is_none());
    }

    fn single(p: Point2i) -> Bounds2i {
        Bounds2i::new(p, Point2i::new(p.x + 1, p.y + 1))
    }

    #[test]
    fn sums_for_a_watcher_resolve_to_the_preview() {
        let g = film();
        let mut f = Film::new(g.clone());
        // Tile 0 merged, tiles 2 and 3 early: all show.
        f.accept(TileId(0), tile(&g, 0)).unwrap();
        f.accept(TileId(2), tile(&g, 2)).unwrap();
        f.accept(TileId(3), tile(&g, 3)).unwrap();
        // The whole film, and regions beside the early tiles (rows in
        // common, no pixel in common).
        let beside = [TileId(0), TileId(2)].map(|t| g.tile_pixel_bounds(t));
        for b in [g.cropped_pixel_bounds, beside[0], beside[1]] {
            let bytes = f.region_sums(b);
            assert_eq!(bytes.len(), b.area() * 16);
            let v: Vec<f32> =
                bytes.chunks_exact(4).map(|c| f32::from_le_bytes(c.try_into().unwrap())).collect();
            let resolved: Vec<[f32; 3]> = v
                .chunks_exact(4)
                .map(|s| farm_common::film::resolve([s[0], s[1], s[2]], s[3], g.scale))
                .collect();
            assert_eq!(resolved, f.preview(b).pixels);
        }
        let all = f.preview(g.cropped_pixel_bounds).pixels;
        let early = g.tile_pixel_bounds(TileId(3));
        assert!(
            all[g.cropped_pixel_bounds.offset(Point2i::new(early.max.x - 1, early.max.y - 1))][0]
                > 0.0
        );
    }
}
