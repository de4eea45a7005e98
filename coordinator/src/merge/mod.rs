//! The film the coordinator assembles: tiles are added strictly in tile-index
//! order (early arrivals wait in a buffer), so the float sums — and so the
//! image's bits — do not depend on how many workers rendered it, how fast
//! they were, or in what order results came back.

use crate::error::Error;
use crate::estimate::{find_fireflies, levelled_errors, pixel_error, suspects, ErrorEstimate};
use farm_common::film::{resolve, FilmGeometry, FilmTile, HalfImages};
use farm_common::geometry::{Bounds2i, Point2i};
use farm_common::ids::TileId;
use farm_common::image::RgbImage;
use farm_common::le::extend_f32s;
use std::collections::BTreeMap;
use std::sync::Arc;
use sums::Sums;

mod sums;

/// Four floats as 16 little-endian bytes.
#[inline]
fn le_bytes(v: [f32; 4]) -> [u8; 16] {
    let mut out = [0u8; 16];
    for (d, x) in out.chunks_exact_mut(4).zip(v) {
        d.copy_from_slice(&x.to_le_bytes());
    }
    out
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
    /// The whole image's sums over the cropped pixel bounds.
    sums: Sums,
    next: u32,
    pending: BTreeMap<u32, Arc<FilmTile>>,
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
    /// False from [`Film::next_pass`] until the pass's first tile.
    pass_started: bool,
    /// How the halves of the pass under way relate.
    halves: HalfImages,
    /// The finished estimate (without its map, which `running` holds) and
    /// the samples per pixel it was made for, until the next tile comes
    /// in: a render in passes asks for it after its last pass and again
    /// when it finishes.
    finished: Option<(u32, ErrorEstimate)>,
}

/// The error estimate of the merged tiles, brought up to date a tile at a
/// time when asked: each complete pixel's value as the error map shows it
/// (0 where a half has no samples or the pixel is not complete yet), the
/// sum and count of the values, and the tiles taken in so far.
/// [`Film::error_estimate`] replaces it with the finished estimate.
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
        let geometry_halves = geometry.half_images;
        let sums = Sums::new(geometry.cropped_pixel_bounds);
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
            pass_started: true,
            halves: geometry_halves,
            finished: None,
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

    /// Starts the next pass of a render in passes, once every tile of this
    /// one is merged: the sums go on, the second half starts afresh (the
    /// next pass's samples are the second half of the render it
    /// completes), and every tile is awaited again. Watchers are sent each
    /// region again as the pass's tiles merge.
    ///
    /// The second half and the estimate are cleared (and the halves'
    /// relation changed, below) when the next pass's first tile comes in,
    /// so until then [`Film::error_estimate`] is still the finished pass's,
    /// fireflies and all.
    ///
    /// After the first pass of a sampler with state, whose halves spread
    /// over one set's strata, each pass is a set of its own: the halves are
    /// independent sets from then on.
    pub fn next_pass(&mut self) {
        debug_assert!(self.is_complete() && self.pending.is_empty());
        self.next = 0;
        self.pending.clear();
        self.pass_started = false;
    }

    /// Clears the second half and the estimate of the pass before, once,
    /// and makes the halves independent if they were spread.
    fn start_pass(&mut self) {
        if self.pass_started {
            return;
        }
        self.pass_started = true;
        if self.halves == HalfImages::Spread {
            self.halves = HalfImages::Independent;
        }
        self.sums.second.fill([0.0; 4]);
        let map = std::mem::take(&mut self.running.map);
        self.running = Running::default();
        if !map.is_empty() {
            self.running.map = vec![0.0; map.len()];
        }
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
    pub fn insert(&mut self, id: TileId, tile: impl Into<Arc<FilmTile>>) {
        self.finished = None;
        self.start_pass();
        let g = &self.geometry;
        let crop = g.cropped_pixel_bounds;
        let early = id.0 != self.next;
        if early {
            let inside = g.tile_interior_pixels(id).intersect(&crop);
            self.changes.extend(Some(inside).filter(|r| !r.is_empty()));
        }
        self.pending.insert(id.0, tile.into());
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
    /// pixel) once every tile is merged: each pixel's
    /// [`levelled_errors`](crate::estimate::levelled_errors), summed
    /// row-major, so a watched render and an unwatched one give the same
    /// bits. From then on the running estimate is this one.
    ///
    /// `spp` is the samples per pixel merged: it sets how far apart a
    /// firefly's halves must be ([`crate::estimate::fireflies::apart`]).
    pub fn error_estimate(&mut self, spp: u32) -> Option<ErrorEstimate> {
        if let Some((s, e)) = &self.finished {
            if *s == spp {
                let per_pixel = self.running.map.clone();
                return Some(ErrorEstimate { per_pixel, ..e.clone() });
            }
        }
        let b = self.geometry.cropped_pixel_bounds;
        let size = (b.width().max(0) as usize, b.height().max(0) as usize);
        let (scale, halves) = (self.geometry.scale, self.halves);
        let pixel = |i| self.sums.pixel(i);
        let suspects = suspects(size, pixel, scale, spp);
        let errors = levelled_errors(size, pixel, scale, halves, &suspects.fireflies);
        let (mut estimate, (sum, counted)) = ErrorEstimate::with_totals(b, &errors)?;
        estimate.fireflies =
            find_fireflies(size, pixel, scale, halves, suspects, &errors, (sum, counted));
        // The per-pixel buffers go before the map is copied, so no more than
        // two maps (4 bytes a pixel each) and the errors (8) are alive at
        // once beside the film.
        drop(errors);
        self.running.map = Vec::new();
        self.running = Running { map: estimate.per_pixel.clone(), sum, counted, upto: self.next };
        // Its map is the running one's until the next tile.
        // (Built field by field: `..estimate.clone()` copied the map to
        // drop it.)
        let kept = ErrorEstimate {
            per_pixel: Vec::new(),
            fireflies: estimate.fireflies.clone(),
            width: estimate.width,
            height: estimate.height,
            rel_mse: estimate.rel_mse,
        };
        self.finished = Some((spp, kept));
        Some(estimate)
    }

    /// The estimate a render in passes decides by after a pass:
    /// [`ErrorEstimate::upper`], which counts fireflies' error.
    pub fn pass_estimate(&mut self, spp: u32) -> Option<f64> {
        self.error_estimate(spp).map(|e| e.upper())
    }

    /// The estimate over the pixels whose sums are complete
    /// ([`FilmGeometry::tile_final_pixels`] of the tiles merged so far),
    /// each against its own value, for a running job's display. Each
    /// pixel's error is computed once, when its last tile is merged, so
    /// asking often costs little (the first call allocates 4 bytes a
    /// pixel); once [`Film::error_estimate`] has run, it holds the finished
    /// estimate.
    pub fn running_estimate(&mut self) -> Option<f64> {
        let g = &self.geometry;
        let b = g.cropped_pixel_bounds;
        let samples = self.halves;
        let r = &mut self.running;
        if r.map.len() != b.area() {
            r.map = vec![0.0; b.area()];
        }
        for t in r.upto..self.next {
            let fin = self.finals[t as usize];
            for y in fin.min.y..fin.max.y {
                let i = self.sums.offset(Point2i::new(fin.min.x, y));
                let n = fin.width() as usize;
                for (k, e) in r.map[i..i + n].iter_mut().enumerate() {
                    if let Some(v) = pixel_error(&self.sums.pixel(i + k), g.scale, samples) {
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
        out.reserve(r.area() * 4);
        for y in r.min.y..r.max.y {
            extend_f32s(out, &map[y as usize * w..][r.min.x as usize..r.max.x as usize]);
        }
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
        self.sums.add_into(&mut part);
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
        out.reserve(b.area() * 16);
        for y in b.min.y..b.max.y {
            let i = self.sums.offset(Point2i::new(b.min.x, y));
            extend_f32s(out, self.sums.value[i..i + n].as_flattened());
        }
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

    /// [`Film::image`] of a film that is done with, written over the
    /// film's own sums (`Sums::into_pixels`), after the running estimate's
    /// map (4 bytes a pixel) and the second half's sums are freed.
    pub fn into_image(mut self) -> RgbImage {
        self.running.map = Vec::new();
        let b = self.geometry.cropped_pixel_bounds;
        let scale = self.geometry.scale;
        let pixels = self.sums.into_pixels(|rgb, w| resolve(rgb, w, scale));
        RgbImage { width: b.width() as usize, height: b.height() as usize, pixels }
    }

    /// The image: weighted sums divided by weights, clamped at zero, times
    /// the film's `scale` (pbrt-v3 `Film::WriteImage`).
    pub fn image(&self) -> RgbImage {
        let b = self.geometry.cropped_pixel_bounds;
        let scale = self.geometry.scale;
        // Fresh pages, mapped in one call (`crate::pages`) rather than one
        // fault a page as the pixels are written.
        let mut pixels = crate::pages::mapped([0.0f32; 3], self.sums.value.len());
        for (p, &[r, g, b, w]) in pixels.iter_mut().zip(&self.sums.value) {
            *p = resolve([r, g, b], w, scale);
        }
        RgbImage { width: b.width() as usize, height: b.height() as usize, pixels }
    }
}

/// What is wrong with a tile's sums, if anything: every sum must be finite,
/// and the weights non-negative unless the filter has negative lobes. A
/// real render never sends anything else (the renderer drops NaN,
/// infinite and negative samples), so such a tile comes from a broken or
/// lying worker and must not reach the image.
fn bad_pixels(tile: &FilmTile, signed_weights: bool) -> Option<String> {
    // Every tile is checked, and nearly all are sound: one pass without
    // branches says so (the compiler makes it a few vector instructions a
    // pixel); only a tile that fails it is walked again for its first fault.
    let sound = tile.pixels.iter().fold(true, |ok, p| {
        let finite = p.to_array().iter().fold(true, |f, x| f & x.is_finite());
        ok & finite & (signed_weights | ((p.weight >= 0.0) & (p.second_weight >= 0.0)))
    });
    if sound {
        return None;
    }
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
mod tests;
