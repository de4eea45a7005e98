use crate::geometry::{Bounds2i, Point2i, Vec2};
use crate::ids::TileId;
use crate::scene::{Params, SceneDescription, Warning};
use serde::{Deserialize, Serialize};

/// Tiles are 16×16 samples' worth of pixels, as in pbrt-v3.
pub const TILE_SIZE: i32 = 16;

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
    /// Number of tiles across and down.
    pub n_tiles: Point2i,
    /// `scale` (multiplies the image when written).
    pub scale: f32,
    /// `maxsampleluminance`: samples brighter than this are scaled down.
    pub max_sample_luminance: f32,
    /// `filename` (default `pbrt.exr`).
    pub filename: String,
    /// `diagonal` in millimetres (used by the realistic camera only).
    pub diagonal: f32,
    /// Whether a pixel's samples are independent of each other (pbrt-v3's
    /// `random` sampler) rather than a low-discrepancy or stratified set.
    /// It sets how a render turns its half-images into an error estimate.
    #[serde(default)]
    pub independent_samples: bool,
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
                (xres as f32 * crop[0]).ceil() as i32,
                (yres as f32 * crop[2]).ceil() as i32,
            ),
            Point2i::new(
                (xres as f32 * crop[1]).ceil() as i32,
                (yres as f32 * crop[3]).ceil() as i32,
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
        film.independent_samples = desc.sampler.name == "random";
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
        let (c, r) = (cropped_pixel_bounds, filter_radius);
        let sample_bounds = Bounds2i::new(
            Point2i::new(
                (c.min.x as f32 + 0.5 - r.x).floor() as i32,
                (c.min.y as f32 + 0.5 - r.y).floor() as i32,
            ),
            Point2i::new(
                (c.max.x as f32 - 0.5 + r.x).ceil() as i32,
                (c.max.y as f32 - 0.5 + r.y).ceil() as i32,
            ),
        );
        let n_tiles = Point2i::new(
            (sample_bounds.width() + TILE_SIZE - 1) / TILE_SIZE,
            (sample_bounds.height() + TILE_SIZE - 1) / TILE_SIZE,
        );
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
            independent_samples: false,
            signed_weights: false,
        }
    }

    /// Number of tiles.
    pub fn tile_count(&self) -> u32 {
        (self.n_tiles.x * self.n_tiles.y) as u32
    }

    /// The pixels whose samples a tile takes.
    pub fn tile_sample_bounds(&self, id: TileId) -> Bounds2i {
        let i = id.0 as i32;
        let (tx, ty) = (i % self.n_tiles.x, i / self.n_tiles.x);
        let b = self.sample_bounds;
        let x0 = b.min.x + tx * TILE_SIZE;
        let y0 = b.min.y + ty * TILE_SIZE;
        Bounds2i::new(
            Point2i::new(x0, y0),
            Point2i::new((x0 + TILE_SIZE).min(b.max.x), (y0 + TILE_SIZE).min(b.max.y)),
        )
    }

    /// The image pixels a tile's samples can reach through the filter
    /// (pbrt-v3 `Film::GetFilmTile`).
    pub fn tile_pixel_bounds(&self, id: TileId) -> Bounds2i {
        let s = self.tile_sample_bounds(id);
        let r = self.filter_radius;
        let p0 = Point2i::new(
            (s.min.x as f32 - 0.5 - r.x).ceil() as i32,
            (s.min.y as f32 - 0.5 - r.y).ceil() as i32,
        );
        let p1 = Point2i::new(
            (s.max.x as f32 - 0.5 + r.x).floor() as i32 + 1,
            (s.max.y as f32 - 0.5 + r.y).floor() as i32 + 1,
        );
        Bounds2i::new(p0, p1).intersect(&self.cropped_pixel_bounds)
    }
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
}
