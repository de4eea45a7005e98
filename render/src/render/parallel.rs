//! A stateless sampler's tile (or part of one) traced on every thread of
//! the pool and splatted in pixel order after, a part at a time: the bits
//! of `Renderer::render_tile` on one thread.

use super::{Renderer, Traced, PARALLEL_SAMPLES};
use crate::integrator::RayStats;
use crate::sampler::Sampler;
use farm_common::film::{FilmTile, SampleRange, TILE_PARTS, TILE_SIZE};
use farm_common::geometry::Point2i;
use farm_common::ids::TileId;

impl Renderer {
    /// The tile's parts `parts`: their pixels traced on the pool's
    /// threads a run at a time, as one list, and splatted in pixel order,
    /// each part into a film of its own, added in part order into a zero
    /// film.
    pub(super) fn render_pixels_parallel(
        &self,
        id: TileId,
        range: Option<SampleRange>,
        parts: std::ops::Range<u32>,
    ) -> (FilmTile, RayStats) {
        let seed = self.film.tile_seed(id);
        let base = self.sampler.clone_with_seed(seed);
        let diff_scale = self.diff_scale();
        let (first, end) = range.map_or((0, u32::MAX), |r| (r.first, r.end));
        let block = self.film.tile_sample_bounds(id);
        let band_of = |p: Point2i| (p.y - block.min.y) / (TILE_SIZE / TILE_PARTS as i32);
        let pixels: Vec<Point2i> = parts
            .flat_map(|k| self.film.tile_part_sample_bounds(id, k).iter())
            .filter(|p| self.film.sample_bounds.contains(*p) && self.pixel_bounds.contains(*p))
            .collect();
        let mut tile = FilmTile::new(self.film.tile_pixel_bounds(id));
        let mut part = tile.clone();
        let mut band = pixels.first().map_or(0, |&p| band_of(p));
        let n = end.min(base.samples_per_pixel()).saturating_sub(first).max(1) as usize;
        // Traced and splatted a run of pixels at a time, so the samples
        // held stay within `PARALLEL_SAMPLES` whatever the count per pixel.
        let run = (PARALLEL_SAMPLES / n).clamp(1, pixels.len().max(1));
        let mut traced = vec![Traced::default(); run * n];
        let mut counts = vec![0usize; run];
        let mut stats = RayStats::default();
        for pixels in pixels.chunks(run) {
            let used = pixels.len();
            counts[..used].fill(0);
            let s = self.trace_run(
                &base,
                pixels,
                &mut traced[..used * n],
                &mut counts[..used],
                n,
                range,
                diff_scale,
            );
            stats.add(&s);
            let done = traced.chunks(n).zip(&counts[..used]).zip(pixels);
            for ((samples, &count), &pixel) in done {
                if band_of(pixel) != band {
                    tile.merge(&part);
                    part.pixels.fill(Default::default());
                    band = band_of(pixel);
                }
                for t in &samples[..count] {
                    self.add_sample(&mut part, t.p_film, t.l, t.weight, t.second_half);
                }
            }
        }
        tile.merge(&part);
        (tile, stats)
    }

    /// Traces every pixel of `pixels` on the pool's threads: `n` slots of
    /// `traced` a pixel, and how many it filled in `counts`.
    #[allow(clippy::too_many_arguments)]
    fn trace_run(
        &self,
        base: &Sampler,
        pixels: &[Point2i],
        traced: &mut [Traced],
        counts: &mut [usize],
        n: usize,
        range: Option<SampleRange>,
        diff_scale: f32,
    ) -> RayStats {
        use rayon::prelude::*;
        let halves = base.halves();
        let (first, end) = range.map_or((0, u32::MAX), |r| (r.first, r.end));
        traced
            .par_chunks_mut(n)
            .zip(counts.par_iter_mut())
            .zip(pixels.par_iter())
            .map_init(
                || base.clone(),
                |sampler, ((out, count), &pixel)| {
                    let mut stats = RayStats::default();
                    sampler.start_pixel(pixel);
                    if first > 0 {
                        sampler.set_sample_number(u64::from(first));
                    }
                    let mut index = first;
                    for slot in out.iter_mut() {
                        *slot = self
                            .trace(sampler, pixel, index, range, halves, diff_scale, &mut stats);
                        *count += 1;
                        index += 1;
                        if index >= end || !sampler.start_next_sample() {
                            break;
                        }
                    }
                    stats
                },
            )
            .reduce(RayStats::default, |mut a, b| {
                a.add(&b);
                a
            })
    }
}
