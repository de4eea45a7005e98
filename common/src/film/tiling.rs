use super::SamplerKind;
use crate::geometry::{Bounds2i, Point2i, Vec2};
use crate::ids::TileId;
use crate::math;
use crate::scene::{Params, SceneDescription, Warning};
use serde::{Deserialize, Serialize};

/// Tiles are 16×16 samples' worth of pixels, as in pbrt-v3.
pub const TILE_SIZE: i32 = 16;

/// The parts a tile's samples split into (see
/// [`FilmGeometry::tile_part_sample_bounds`]): four bands of four rows.
pub const TILE_PARTS: u32 = 4;

/// How the two half-images of a film's samples relate, which sets how a
/// render turns their difference into an error estimate
/// (`farm_coordinator::estimate`). It is stored as one byte, as the `bool`
/// it replaces was, so a journal written before it still reads: `false`
/// was [`HalfImages::Spread`] and `true` [`HalfImages::Independent`].
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize, Deserialize)]
pub enum HalfImages {
    /// Two halves of one stratified or low-discrepancy set, split across
    /// its strata: the pixel samplers' one-shot renders.
    #[default]
    Spread,
    /// Two independent sets: the random sampler, and a render in passes of
    /// a sampler with state (each pass its own set).
    Independent,
    /// The first and second halves of one sequence: Halton and Sobol'.
    Sequence,
}

impl HalfImages {
    /// The halves of a one-shot render with sampler `kind`.
    pub fn of(kind: SamplerKind) -> HalfImages {
        match kind {
            SamplerKind::Random => HalfImages::Independent,
            SamplerKind::Halton | SamplerKind::Sobol => HalfImages::Sequence,
            _ => HalfImages::Spread,
        }
    }
}

/// Where the film's pixels and samples lie, and how they split into tiles.
/// The coordinator and every worker compute the same geometry from the same
/// description, so a tile id means the same pixels everywhere.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct FilmGeometry {
    /// `xresolution` × `yresolution`.
    pub full_resolution: Point2i,
    /// The pixels written to the image (after `cropwindow`/`pixelbounds`).
    pub cropped_pixel_bounds: Bounds2i,
    /// The filter's radius in pixels.
    pub filter_radius: Vec2,
    /// Pixels whose samples are taken: the cropped pixels grown by the filter.
    pub sample_bounds: Bounds2i,
    /// Number of tiles across and down. Tiles lie on the grid of the whole
    /// film's tiles, so a crop renders the tiles of the full render that
    /// reach it, exactly as the full render does (see `tile_sample_bounds`).
    pub n_tiles: Point2i,
    /// `scale` (multiplies the image when written).
    pub scale: f32,
    /// `maxsampleluminance`: samples brighter than this are scaled down.
    pub max_sample_luminance: f32,
    /// `filename` (default `pbrt.exr`).
    pub filename: String,
    /// `diagonal` in millimetres (used by the realistic camera only).
    pub diagonal: f32,
    /// How the two half-images of its samples relate: it sets how a render
    /// turns their difference into an error estimate.
    #[serde(default)]
    pub half_images: HalfImages,
    /// Whether the filter has negative lobes (`mitchell`, `sinc`), so a
    /// pixel's sum of weights may be negative; with any other filter a
    /// negative weight can only come from a broken or lying worker.
    #[serde(default)]
    pub signed_weights: bool,
}

impl FilmGeometry {
    /// The film of `desc`, and warnings for unused `Film` parameters (see
    /// [`super::layout`] for the samples too).
    pub fn from_description(desc: &SceneDescription) -> (FilmGeometry, Vec<Warning>) {
        let fp = Params::new(&desc.film.params);
        let xres = fp.int("xresolution", 1280).max(1);
        let yres = fp.int("yresolution", 720).max(1);
        let mut crop = [0.0f32, 1.0, 0.0, 1.0];
        if let Some(c) = fp.floats("cropwindow") {
            if c.len() == 4 {
                crop = [c[0].min(c[1]), c[0].max(c[1]), c[2].min(c[3]), c[2].max(c[3])];
                for v in &mut crop {
                    *v = v.clamp(0.0, 1.0);
                }
            }
        }
        let mut cropped = Bounds2i::new(
            Point2i::new(
                math::ceil(xres as f32 * crop[0]) as i32,
                math::ceil(yres as f32 * crop[2]) as i32,
            ),
            Point2i::new(
                math::ceil(xres as f32 * crop[1]) as i32,
                math::ceil(yres as f32 * crop[3]) as i32,
            ),
        );
        if let Some(pb) = fp.ints("pixelbounds") {
            if pb.len() == 4 {
                let b = Bounds2i::new(Point2i::new(pb[0], pb[2]), Point2i::new(pb[1], pb[3]));
                let full = Bounds2i::new(Point2i::new(0, 0), Point2i::new(xres, yres));
                cropped = b.intersect(&full);
            }
        }
        let scale = fp.float("scale", 1.0);
        let max_sample_luminance = fp.float("maxsampleluminance", f32::INFINITY);
        let filename = fp.string("filename", "pbrt.exr");
        let diagonal = fp.float("diagonal", 35.0);
        let warnings = fp.unused_warnings();

        let filter_radius =
            super::filter_radius(&desc.filter.name, &Params::new(&desc.filter.params));
        let mut film = FilmGeometry::new(
            Point2i::new(xres, yres),
            cropped,
            filter_radius,
            scale,
            max_sample_luminance,
            filename,
            diagonal,
        );
        film.half_images = HalfImages::of(SamplerKind::named(&desc.sampler.name).0);
        film.signed_weights = matches!(desc.filter.name.as_str(), "mitchell" | "sinc");
        (film, warnings)
    }

    /// Geometry from explicit values.
    pub fn new(
        full_resolution: Point2i,
        cropped_pixel_bounds: Bounds2i,
        filter_radius: Vec2,
        scale: f32,
        max_sample_luminance: f32,
        filename: String,
        diagonal: f32,
    ) -> Self {
        let sample_bounds = grown(cropped_pixel_bounds, filter_radius);
        let full = grown(full_pixels(full_resolution), filter_radius);
        let n_tiles = if sample_bounds.is_empty() {
            Point2i::new(0, 0)
        } else {
            let (first, end) = grid_span(&full, &sample_bounds);
            Point2i::new(end.x - first.x, end.y - first.y)
        };
        FilmGeometry {
            full_resolution,
            cropped_pixel_bounds,
            filter_radius,
            sample_bounds,
            n_tiles,
            scale,
            max_sample_luminance,
            filename,
            diagonal,
            half_images: HalfImages::default(),
            signed_weights: false,
        }
    }

    /// Number of tiles.
    pub fn tile_count(&self) -> u32 {
        (self.n_tiles.x * self.n_tiles.y) as u32
    }

    /// The samples of the whole, uncropped film: the grid tiles lie on,
    /// and the bounds Halton's and Sobol's sequences are laid over, so a
    /// pixel's samples do not depend on the crop.
    pub fn full_sample_bounds(&self) -> Bounds2i {
        grown(full_pixels(self.full_resolution), self.filter_radius)
    }

    /// A tile's position on the whole film's grid of tiles.
    fn grid_cell(&self, id: TileId) -> Point2i {
        let i = id.0 as i32;
        let (first, _) = grid_span(&self.full_sample_bounds(), &self.sample_bounds);
        Point2i::new(first.x + i % self.n_tiles.x, first.y + i / self.n_tiles.x)
    }

    /// The pixels whose samples a tile takes: its cell of the whole film's
    /// grid, as the full render's tile there takes them. Without a crop
    /// this is pbrt-v3's tiling of the sample bounds. With one, the tiles
    /// at the crop's edges take samples beyond its sample bounds that a
    /// pixel sampler needs to reach the same state for the samples inside
    /// them (the renderer skips them where the sampler has no state), which
    /// makes a crop's pixels bit-identical to the full render's.
    pub fn tile_sample_bounds(&self, id: TileId) -> Bounds2i {
        let cell = self.grid_cell(id);
        let b = self.full_sample_bounds();
        let x0 = b.min.x + cell.x * TILE_SIZE;
        let y0 = b.min.y + cell.y * TILE_SIZE;
        Bounds2i::new(
            Point2i::new(x0, y0),
            Point2i::new((x0 + TILE_SIZE).min(b.max.x), (y0 + TILE_SIZE).min(b.max.y)),
        )
    }

    /// The pixels whose samples part `part` (below [`TILE_PARTS`]) of a
    /// tile takes: its block's rows `part × 4` to `part × 4 + 4` (fewer,
    /// or none, in a short block at the film's edge). A tile whose samples
    /// depend on the pixel alone (Halton, Sobol') sums its film a part at
    /// a time, each part's film started from zero and added in part order,
    /// so the parts rendered apart (on idle workers at the end of a frame)
    /// and added in that order give the same bits as the tile.
    pub fn tile_part_sample_bounds(&self, id: TileId, part: u32) -> Bounds2i {
        let block = self.tile_sample_bounds(id);
        let rows = TILE_SIZE / TILE_PARTS as i32;
        let y0 = (block.min.y + rows * part.min(TILE_PARTS) as i32).min(block.max.y);
        let y1 = (y0 + rows).min(block.max.y);
        Bounds2i::new(Point2i::new(block.min.x, y0), Point2i::new(block.max.x, y1))
    }

    /// The seed of a tile's sampler: its index in the whole film's grid
    /// (pbrt-v3 seeds each tile with its index), the same in a crop.
    pub fn tile_seed(&self, id: TileId) -> u64 {
        let cell = self.grid_cell(id);
        let across = (self.full_sample_bounds().width() + TILE_SIZE - 1) / TILE_SIZE;
        (cell.y * across + cell.x) as u64
    }

    /// The image pixels a tile's samples can reach through the filter
    /// (pbrt-v3 `Film::GetFilmTile`).
    pub fn tile_pixel_bounds(&self, id: TileId) -> Bounds2i {
        let s = self.tile_sample_bounds(id);
        let r = self.filter_radius;
        let p0 = Point2i::new(
            math::ceil(s.min.x as f32 - 0.5 - r.x) as i32,
            math::ceil(s.min.y as f32 - 0.5 - r.y) as i32,
        );
        let p1 = Point2i::new(
            math::floor(s.max.x as f32 - 0.5 + r.x) as i32 + 1,
            math::floor(s.max.y as f32 - 0.5 + r.y) as i32 + 1,
        );
        Bounds2i::new(p0, p1).intersect(&self.cropped_pixel_bounds)
    }

    /// The pixels whose sums are complete once tiles `0..=id` are merged in
    /// order: those of the tile's pixel bounds that no later tile reaches.
    /// Tiles go row by row and a later tile's pixels start no earlier than
    /// its neighbour's to the right or below, so this is a rectangle; over
    /// all tiles, these rectangles split the image's pixels exactly.
    pub fn tile_final_pixels(&self, id: TileId) -> Bounds2i {
        let mut b = self.tile_pixel_bounds(id);
        let (nx, ny) = (self.n_tiles.x as u32, self.n_tiles.y as u32);
        if nx == 0 {
            return b;
        }
        if id.0 % nx + 1 < nx {
            let right = self.tile_pixel_bounds(TileId(id.0 + 1));
            if !right.is_empty() {
                b.max.x = b.max.x.min(right.min.x);
            }
        }
        if id.0 / nx + 1 < ny {
            let below = self.tile_pixel_bounds(TileId(id.0 + nx));
            if !below.is_empty() {
                b.max.y = b.max.y.min(below.min.y);
            }
        }
        b
    }
}

impl FilmGeometry {
    /// The pixels no tile but `id` reaches: their sums are complete as soon
    /// as this tile is in, whatever has arrived before it. The tiles next
    /// to it reach furthest into it (a tile's pixel bounds grow with its
    /// column and row), so it is the tile's pixel bounds less theirs.
    pub fn tile_interior_pixels(&self, id: TileId) -> Bounds2i {
        let mut b = self.tile_pixel_bounds(id);
        let (nx, ny) = (self.n_tiles.x as u32, self.n_tiles.y as u32);
        if nx == 0 || b.is_empty() {
            return b;
        }
        let (col, row) = (id.0 % nx, id.0 / nx);
        let near = |t: u32| Some(self.tile_pixel_bounds(TileId(t))).filter(|n| !n.is_empty());
        if let Some(n) = (col > 0).then(|| near(id.0 - 1)).flatten() {
            b.min.x = b.min.x.max(n.max.x);
        }
        if let Some(n) = (col + 1 < nx).then(|| near(id.0 + 1)).flatten() {
            b.max.x = b.max.x.min(n.min.x);
        }
        if let Some(n) = (row > 0).then(|| near(id.0 - nx)).flatten() {
            b.min.y = b.min.y.max(n.max.y);
        }
        if let Some(n) = (row + 1 < ny).then(|| near(id.0 + nx)).flatten() {
            b.max.y = b.max.y.min(n.min.y);
        }
        if b.is_empty() {
            return Bounds2i::default();
        }
        b
    }
}

/// The pixels of a `res.x × res.y` film.
fn full_pixels(res: Point2i) -> Bounds2i {
    Bounds2i::new(Point2i::new(0, 0), res)
}

/// Pixels grown by a filter's radius: those whose samples reach `c`
/// (pbrt-v3 `Film::GetSampleBounds`).
fn grown(c: Bounds2i, r: Vec2) -> Bounds2i {
    Bounds2i::new(
        Point2i::new(
            math::floor(c.min.x as f32 + 0.5 - r.x) as i32,
            math::floor(c.min.y as f32 + 0.5 - r.y) as i32,
        ),
        Point2i::new(
            math::ceil(c.max.x as f32 - 0.5 + r.x) as i32,
            math::ceil(c.max.y as f32 - 0.5 + r.y) as i32,
        ),
    )
}

/// The cells of the grid of `TILE_SIZE` tiles laid from `full.min` that
/// `b` (inside `full`) touches: the first, and one past the last.
fn grid_span(full: &Bounds2i, b: &Bounds2i) -> (Point2i, Point2i) {
    let cell = |v: i32, o: i32| (v - o).div_euclid(TILE_SIZE);
    let first = Point2i::new(cell(b.min.x, full.min.x), cell(b.min.y, full.min.y));
    let end = Point2i::new(cell(b.max.x - 1, full.min.x) + 1, cell(b.max.y - 1, full.min.y) + 1);
    (first, end)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn film(w: i32, h: i32, r: f32) -> FilmGeometry {
        let b = Bounds2i::new(Point2i::new(0, 0), Point2i::new(w, h));
        FilmGeometry::new(
            Point2i::new(w, h),
            b,
            Vec2::splat(r),
            1.0,
            f32::INFINITY,
            "x.exr".into(),
            35.0,
        )
    }

    #[test]
    fn a_tiles_parts_split_its_samples_in_row_bands() {
        for (w, h) in [(64, 48), (37, 21), (3, 2)] {
            let g = film(w, h, 1.5);
            for t in 0..g.tile_count() {
                let block = g.tile_sample_bounds(TileId(t));
                let mut rows = block.min.y;
                for k in 0..TILE_PARTS {
                    let part = g.tile_part_sample_bounds(TileId(t), k);
                    assert_eq!((part.min.x, part.max.x), (block.min.x, block.max.x));
                    assert_eq!(part.min.y, rows, "tile {t} part {k}");
                    assert!(part.height() <= TILE_SIZE / TILE_PARTS as i32);
                    rows = part.max.y;
                }
                assert_eq!(rows, block.max.y, "the parts reach the block's end");
            }
        }
    }

    #[test]
    fn sample_bounds_grow_by_the_filter_as_in_pbrt() {
        // The reference README: a 256² image with a 2-pixel filter takes 260×260 samples.
        let f = film(256, 256, 2.0);
        assert_eq!(f.sample_bounds.width(), 260);
        assert_eq!(f.sample_bounds.min, Point2i::new(-2, -2));
        let b = film(500, 500, 0.5);
        assert_eq!(b.sample_bounds, Bounds2i::new(Point2i::new(0, 0), Point2i::new(500, 500)));
        assert_eq!(b.n_tiles, Point2i::new(32, 32));
    }

    #[test]
    fn tiles_cover_the_sample_bounds_exactly_once() {
        let f = film(37, 21, 1.5);
        let mut count = vec![0u8; f.sample_bounds.area()];
        for t in 0..f.tile_count() {
            for p in f.tile_sample_bounds(TileId(t)).iter() {
                count[f.sample_bounds.offset(p)] += 1;
            }
            let pb = f.tile_pixel_bounds(TileId(t));
            assert!(pb.is_empty() || f.cropped_pixel_bounds.intersect(&pb) == pb);
        }
        assert!(count.iter().all(|&c| c == 1));
    }

    fn cases() -> Vec<FilmGeometry> {
        let crop = |w: i32, h: i32, c: Bounds2i, r: f32| {
            FilmGeometry::new(
                Point2i::new(w, h),
                c,
                Vec2::new(r, r * 0.7),
                1.0,
                f32::INFINITY,
                "x.exr".into(),
                35.0,
            )
        };
        let whole = |w, h| Bounds2i::new(Point2i::new(0, 0), Point2i::new(w, h));
        let cases = [
            crop(37, 21, whole(37, 21), 1.5),
            crop(64, 48, whole(64, 48), 0.5),
            crop(50, 40, whole(50, 40), 2.0),
            crop(50, 40, whole(50, 40), 20.0),
            crop(70, 60, Bounds2i::new(Point2i::new(13, 7), Point2i::new(51, 33)), 1.5),
            crop(70, 60, Bounds2i::new(Point2i::new(16, 16), Point2i::new(17, 40)), 3.0),
        ];
        cases.into()
    }

    #[test]
    fn each_pixel_is_final_at_the_last_tile_that_reaches_it() {
        for f in cases() {
            let b = f.cropped_pixel_bounds;
            let mut last = vec![None; b.area()];
            let mut finals = vec![None; b.area()];
            for t in 0..f.tile_count() {
                for p in f.tile_pixel_bounds(TileId(t)).iter() {
                    last[b.offset(p)] = Some(t);
                }
                let fin = f.tile_final_pixels(TileId(t));
                assert!(fin.is_empty() || b.intersect(&fin) == fin);
                for p in fin.iter() {
                    assert_eq!(finals[b.offset(p)], None, "{p:?} final twice");
                    finals[b.offset(p)] = Some(t);
                }
            }
            assert!(last.iter().all(Option::is_some), "every pixel is reached");
            assert_eq!(finals, last, "final at the last tile that reaches it ({b:?})");
        }
    }

    #[test]
    fn a_tiles_interior_is_what_no_other_tile_reaches() {
        for f in cases() {
            let b = f.cropped_pixel_bounds;
            let mut reach = vec![Vec::new(); b.area()];
            for t in 0..f.tile_count() {
                for p in f.tile_pixel_bounds(TileId(t)).iter() {
                    reach[b.offset(p)].push(t);
                }
            }
            for t in 0..f.tile_count() {
                let inside = f.tile_interior_pixels(TileId(t));
                for p in b.iter() {
                    let only = reach[b.offset(p)] == [t];
                    assert_eq!(inside.contains(p), only, "{p:?}, tile {t}, {b:?}");
                }
                let fin = f.tile_final_pixels(TileId(t));
                assert!(inside.is_empty() || fin.intersect(&inside) == inside);
            }
        }
    }

    #[test]
    fn a_rectangle_less_another_is_what_lies_outside_it() {
        let r = |x0, y0, x1, y1| Bounds2i::new(Point2i::new(x0, y0), Point2i::new(x1, y1));
        let a = r(2, 3, 12, 9);
        for o in [r(4, 4, 8, 6), r(0, 0, 5, 20), r(2, 3, 12, 9), r(20, 20, 30, 30), r(5, 0, 6, 4)] {
            let parts = a.minus(&o);
            for p in r(0, 0, 14, 12).iter() {
                let n = parts.iter().filter(|q| q.contains(p)).count();
                let outside = a.contains(p) && !o.contains(p);
                assert_eq!(n, usize::from(outside), "{p:?} in {a:?} less {o:?}");
            }
        }
    }
}
