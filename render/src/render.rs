//! Rendering one 16×16 tile: the loop of pbrt-v3's
//! `SamplerIntegrator::Render` for a single tile, with the tile's sampler
//! seeded from the tile index so the result does not depend on which thread
//! or process renders it.

use crate::cameras::{self, Camera};
use crate::error::BuildError;
use crate::features::Features;
use crate::filters::{self, Filter};
use crate::integrator::{RayStats, Whitted};
use crate::sampler::{self, CameraDims, Sampler};
use crate::world::World;
use farm_common::film::{FilmGeometry, FilmTile, SampleRange, TILE_PARTS, TILE_SIZE};
use farm_common::geometry::{
    AnimatedTransform, Bounds2i, DMat4, DVec3, Point2i, RayDifferential, Transform, Vec2,
};
use farm_common::ids::TileId;
use farm_common::math;
use farm_common::scene::{Entity, FileLoc, Params, SceneDescription, Warning};
use farm_common::Spectrum;

mod parallel;

/// Entries per axis of the precomputed filter table (pbrt-v3's 16).
const FILTER_TABLE_SIZE: usize = 16;

/// The most samples [`Renderer::render_tile_parallel`] holds traced before
/// it splats them (28 bytes each): a 16×16 tile at 256 spp at once, a few
/// pixels at a time at thousands.
const PARALLEL_SAMPLES: usize = 65_536;

/// One traced sample, kept until it is splatted in its turn.
#[derive(Clone, Copy, Debug, Default)]
struct Traced {
    p_film: Vec2,
    l: Spectrum,
    weight: f32,
    second_half: bool,
}

/// Choices that override the scene file.
#[derive(Clone, Debug, Default, PartialEq, Eq)]
pub struct RenderOptions {
    /// Samples per pixel instead of the sampler's `pixelsamples`.
    pub spp: Option<u32>,
    /// Compute ray differentials and every camera-sample dimension even when
    /// the scene does not use them, and every sample pair Whitted ignores
    /// (the baseline of the benchmark that measures the saving, and of the
    /// tests that it changes no bit).
    pub all_paths: bool,
}

/// The film layout, the filter and the sampler of a scene. The layout is
/// `farm_common::film::layout`'s, which the coordinator tiles a job by, so
/// a tile id means the same pixels and samples on both sides.
pub fn film_and_sampler(
    desc: &SceneDescription,
    opts: &RenderOptions,
) -> (FilmGeometry, Filter, Sampler, Vec<Warning>) {
    let (film, mut warnings) = FilmGeometry::from_description(desc);
    let filter_entity =
        if desc.filter.name.is_empty() { Entity::named("box") } else { desc.filter.clone() };
    let filter = filters::create(&filter_entity, &mut warnings);
    debug_assert_eq!(filter.radius(), film.filter_radius);
    let sampler_entity =
        if desc.sampler.name.is_empty() { Entity::named("halton") } else { desc.sampler.clone() };
    let sampler =
        sampler::create(&sampler_entity, film.full_sample_bounds(), opts.spp, &mut warnings);
    (film, filter, sampler, warnings)
}

/// How many tiles a rayon pool of `threads` threads should be given at
/// once, when each may be [`Renderer::render_tile_parallel`]: twice its
/// threads. A stateless sampler's tile traces its pixels on every thread,
/// and a thread that waits for the rest of its tile takes other work
/// meanwhile, a whole other tile if one is queued. Its own tile then ends
/// only after that one, out of the order the film is merged in, and every
/// tile finished behind it waits in memory (on cornell-box at 2 threads,
/// up to 1,022 of its 1,024 tiles at once). With only the pool's threads
/// of tiles, renders ran up to 11% slower; with twice, within noise.
pub fn tiles_on_pool(threads: usize) -> usize {
    2 * threads.max(1)
}

/// The generator stream of a tile's pass that starts at sample `first` (not
/// 0). PCG32 streams whose increments differ only in high bits share the
/// low bits of their states, and their outputs correlate; the seed is
/// mixed (pbrt-v4's `MixBits`) so that every bit of the increment differs.
fn pass_stream(tile_seed: u64, first: u32) -> u64 {
    let mut v = tile_seed ^ (u64::from(first) << 32 | u64::from(first));
    v ^= v >> 31;
    v = v.wrapping_mul(0x7fb5_d329_728e_a185);
    v ^= v >> 27;
    v = v.wrapping_mul(0x81da_def4_bc2d_d44d);
    v ^ (v >> 33)
}

/// Everything needed to render any tile of one scene.
#[derive(Debug)]
pub struct Renderer {
    /// The built scene.
    pub world: World,
    /// The camera.
    pub camera: Camera,
    /// The sampler every tile's sampler is cloned from.
    pub sampler: Sampler,
    /// Film layout.
    pub film: FilmGeometry,
    /// The integrator.
    pub integrator: Whitted,
    /// Pixels the integrator renders (`pixelbounds`, default all samples).
    pub pixel_bounds: Bounds2i,
    /// What the scene uses.
    pub features: Features,
    /// Whether camera rays carry differentials.
    differentials: bool,
    /// The camera-sample dimensions the camera reads.
    camera_dims: CameraDims,
    filter_table: [f32; FILTER_TABLE_SIZE * FILTER_TABLE_SIZE],
    inv_filter_radius: Vec2,
}

impl Renderer {
    /// Builds the scene, camera, sampler and filter of a description. The
    /// warnings say what was ignored (unknown types, unused parameters).
    pub fn new(
        mut desc: SceneDescription,
        opts: &RenderOptions,
    ) -> Result<(Renderer, Vec<Warning>), BuildError> {
        let desc = &mut desc;
        let (film, filter, sampler, mut warnings) = film_and_sampler(desc, opts);
        if film.cropped_pixel_bounds.is_empty() {
            return Err(BuildError::EmptyFilm);
        }

        // Render space: world translated so the camera (at shutter open) is at the origin.
        let wfc = desc.camera.world_from_camera;
        if wfc.start.determinant() == 0.0 {
            return Err(BuildError::SingularCamera);
        }
        let cam_pos = wfc.start.transform_point3(DVec3::ZERO);
        let render_from_world = DMat4::from_translation(-cam_pos);
        let start = Transform::from_dmat4(render_from_world * wfc.start);
        let end = Transform::from_dmat4(render_from_world * wfc.end);
        let render_from_camera = AnimatedTransform::new(start, wfc.start_time, end, wfc.end_time);
        let cam_entity = if desc.camera.entity.name.is_empty() {
            Entity::named("perspective")
        } else {
            desc.camera.entity.clone()
        };
        let camera =
            cameras::create(&cam_entity, render_from_camera, &film, &desc.assets, &mut warnings)
                .map_err(|why| BuildError::Camera {
                    loc: cam_entity.loc.clone(),
                    name: cam_entity.name.clone(),
                    why,
                })?;

        // The integrator: Whitted whatever the file asks for.
        let ip = Params::new(&desc.integrator.params);
        let iname = desc.integrator.name.as_str();
        // The parser's default: pbrt-v3's "path", at no place in the file.
        let no_directive =
            iname.is_empty() || iname == "path" && desc.integrator.loc == FileLoc::default();
        if no_directive && iname != "whitted" {
            warnings.push(Warning {
                loc: None,
                message: "no Integrator directive, and pbrt-v3's default \"path\" is not supported; rendering with \"whitted\"".into(),
            });
        } else if iname != "whitted" {
            warnings.push(Warning::at(
                &desc.integrator.loc,
                format!("Integrator \"{iname}\" is not supported; rendering with \"whitted\""),
            ));
        }
        let max_depth = ip.int("maxdepth", 5).max(0) as u32;
        let mut pixel_bounds = film.full_sample_bounds();
        if let Some(pb) = ip.ints("pixelbounds") {
            if pb.len() == 4 {
                pixel_bounds = pixel_bounds.intersect(&Bounds2i::new(
                    Point2i::new(pb[0], pb[2]),
                    Point2i::new(pb[1], pb[3]),
                ));
            }
        }
        if iname == "whitted" {
            warnings.extend(ip.unused_warnings());
        }
        let features = Features::of(desc);
        // The world takes the shapes: each one's parameters (a mesh's
        // arrays) are freed once it is built, before the BVH is.
        let shapes = std::mem::take(&mut desc.shapes);
        let world = World::build(desc, shapes, render_from_world, &mut warnings)?;
        let differentials = features.needs_differentials() || opts.all_paths;
        // Shutter time matters only if something moves, the lens point only
        // with a lens; the sampler passes over the others.
        let camera_dims = CameraDims {
            time: features.moving > 0 || features.moving_camera || opts.all_paths,
            lens: camera.uses_lens() || opts.all_paths,
        };

        // Filter values at the centres of a 16×16 grid over one quadrant.
        let r = filter.radius();
        let mut filter_table = [0.0f32; FILTER_TABLE_SIZE * FILTER_TABLE_SIZE];
        for y in 0..FILTER_TABLE_SIZE {
            for x in 0..FILTER_TABLE_SIZE {
                let p = Vec2::new(
                    (x as f32 + 0.5) * r.x / FILTER_TABLE_SIZE as f32,
                    (y as f32 + 0.5) * r.y / FILTER_TABLE_SIZE as f32,
                );
                filter_table[y * FILTER_TABLE_SIZE + x] = filter.evaluate(p);
            }
        }
        let renderer = Renderer {
            world,
            camera,
            sampler,
            film,
            integrator: Whitted { max_depth, pass_over: !opts.all_paths },
            pixel_bounds,
            features,
            differentials,
            camera_dims,
            filter_table,
            inv_filter_radius: Vec2::ONE / r,
        };
        Ok((renderer, warnings))
    }

    /// Samples per pixel actually used.
    pub fn samples_per_pixel(&self) -> u32 {
        self.sampler.samples_per_pixel()
    }

    /// Renders one tile: its film tile of weighted sums and its ray counts.
    pub fn render_tile(&self, id: TileId) -> (FilmTile, RayStats) {
        self.render_samples(id, None)
    }

    /// Renders samples `range` of every pixel of one tile: one pass of a
    /// render in passes (see `farm_common::film::PassPlan`). Halton and
    /// Sobol' take samples `range.first..range.end` of each pixel's
    /// sequence; the samplers with state take a set of `range.len()`
    /// samples drawn on a stream of the tile's and the range's own. The
    /// range must pass [`SampleRange::check`] against
    /// [`Renderer::samples_per_pixel`].
    pub fn render_tile_samples(&self, id: TileId, range: SampleRange) -> (FilmTile, RayStats) {
        self.render_samples(id, Some(range))
    }

    /// Renders one tile, or samples `range` of its pixels, spreading its
    /// pixels over the current rayon pool's threads when the sampler is
    /// stateless (Halton, Sobol': [`Renderer::tiles_parallel`]). The bits
    /// are those of [`Renderer::render_tile`] and
    /// [`Renderer::render_tile_samples`]: each pixel draws the same samples
    /// and the samples are splatted in the same order, after all are
    /// traced. A sampler with state draws a tile's pixels from one
    /// generator in turn, so its tiles render on this thread alone.
    pub fn render_tile_parallel(
        &self,
        id: TileId,
        range: Option<SampleRange>,
    ) -> (FilmTile, RayStats) {
        if self.tiles_parallel() {
            self.render_pixels_parallel(id, range, 0..TILE_PARTS)
        } else {
            self.render_samples(id, range)
        }
    }

    /// Renders part `part` (below `TILE_PARTS`) of a tile whose sampler is
    /// stateless ([`Renderer::tiles_parallel`]), on the pool's threads: a
    /// film over the whole tile's pixel bounds with that part's samples.
    /// A zero film with the parts' films added in part order
    /// (`FilmTile::merge`) is the tile's film, bit for bit. `None` for a
    /// sampler with state, whose parts cannot be drawn apart.
    pub fn render_part(
        &self,
        id: TileId,
        range: Option<SampleRange>,
        part: u32,
    ) -> Option<(FilmTile, RayStats)> {
        (self.tiles_parallel() && part < TILE_PARTS)
            .then(|| self.render_pixels_parallel(id, range, part..part + 1))
    }

    /// Whether [`Renderer::render_tile_parallel`] spreads a tile's pixels
    /// over threads: whether each pixel's samples depend on the pixel
    /// alone.
    pub fn tiles_parallel(&self) -> bool {
        self.sampler.is_stateless()
    }

    /// Ray differentials are scaled for the job's samples per pixel (a
    /// pass render's cap), as a one-shot render of the job would be.
    fn diff_scale(&self) -> f32 {
        1.0 / (self.sampler.samples_per_pixel() as f32).sqrt()
    }

    /// Traces sample `index` of `pixel`: where it lands, its radiance
    /// (black when pbrt-v3 would drop it), its weight and its half.
    #[allow(clippy::too_many_arguments)]
    #[inline]
    fn trace(
        &self,
        sampler: &mut Sampler,
        pixel: Point2i,
        index: u32,
        range: Option<SampleRange>,
        halves: farm_common::film::Halves,
        diff_scale: f32,
        stats: &mut RayStats,
    ) -> Traced {
        let cs = sampler.camera_sample_for(pixel, self.camera_dims);
        let offset = cs.p_film - Vec2::new(pixel.x as f32, pixel.y as f32);
        let second_half = match range {
            Some(r) if !r.own_halves => index >= r.second_from,
            Some(r) => halves.is_second(index - r.first, offset),
            None => halves.is_second(index, offset),
        };
        let (weight, ray) = if self.differentials {
            let (weight, mut ray) = self.camera.generate_ray_differential(&cs);
            ray.scale_differentials(diff_scale);
            (weight, ray)
        } else {
            let (weight, ray) = self.camera.generate_ray(&cs);
            (weight, RayDifferential::new(ray))
        };
        stats.camera_rays += 1;
        let mut l = Spectrum::ZERO;
        if weight > 0.0 {
            l = self.integrator.li(&ray, &self.world, sampler, 0, stats);
        }
        // Guard the film against bad radiance, as pbrt-v3 does.
        if l.has_nan() {
            stats.nan_samples += 1;
            l = Spectrum::ZERO;
        } else if l.y() < -1e-5 {
            stats.negative_samples += 1;
            l = Spectrum::ZERO;
        } else if l.y().is_infinite() {
            stats.inf_samples += 1;
            l = Spectrum::ZERO;
        }
        Traced { p_film: cs.p_film, l, weight, second_half }
    }

    fn render_samples(&self, id: TileId, range: Option<SampleRange>) -> (FilmTile, RayStats) {
        let mut stats = RayStats::default();
        let seed = self.film.tile_seed(id);
        let stateless = self.sampler.is_stateless();
        let mut sampler = match range {
            // Each pass of a sampler with state draws on a stream of its own.
            Some(r) if !stateless && r.first > 0 => {
                self.sampler.with_spp(r.len()).clone_with_seed(pass_stream(seed, r.first))
            }
            Some(r) if !stateless => self.sampler.with_spp(r.len()).clone_with_seed(seed),
            _ => self.sampler.clone_with_seed(seed),
        };
        let bounds = self.film.tile_sample_bounds(id);
        // Outside the film's sample bounds (a crop's edge tiles) only a
        // sampler with state needs the samples, to reach the state it has
        // for the samples inside.
        let mut tile = FilmTile::new(self.film.tile_pixel_bounds(id));
        let diff_scale = self.diff_scale();
        let halves = sampler.halves();
        let (first, end) = range.map_or((0, u32::MAX), |r| (r.first, r.end));
        // A stateless sampler's tile sums a part (a band of rows) at a
        // time, as `render_pixels_parallel` and `render_part` do.
        let rows = TILE_SIZE / TILE_PARTS as i32;
        // (A sampler with state splats straight into the tile.)
        let mut part =
            FilmTile::new(if stateless { tile.pixel_bounds } else { Bounds2i::default() });
        let mut band = 0;
        for pixel in bounds.iter() {
            if stateless && (pixel.y - bounds.min.y) / rows != band {
                tile.merge(&part);
                part.pixels.fill(Default::default());
                band = (pixel.y - bounds.min.y) / rows;
            }
            if stateless && !self.film.sample_bounds.contains(pixel) {
                continue;
            }
            // As pbrt-v3: the pixel's samples are drawn before the
            // integrator's `pixelbounds` are checked.
            sampler.start_pixel(pixel);
            if !self.pixel_bounds.contains(pixel) {
                continue;
            }
            // A stateless sampler jumps to the range's first sample; one
            // with state made for the range starts its own set at 0.
            if stateless && first > 0 {
                sampler.set_sample_number(u64::from(first));
            }
            let mut index = first;
            loop {
                let t =
                    self.trace(&mut sampler, pixel, index, range, halves, diff_scale, &mut stats);
                let film = if stateless { &mut part } else { &mut tile };
                self.add_sample(film, t.p_film, t.l, t.weight, t.second_half);
                index += 1;
                if index >= end || !sampler.start_next_sample() {
                    break;
                }
            }
        }
        if stateless {
            tile.merge(&part);
        }
        (tile, stats)
    }

    /// Splats one sample onto the pixels its filter reaches (pbrt-v3
    /// `FilmTile::AddSample`); `second_half` says whether it belongs to the
    /// second half of its pixel's samples.
    #[inline]
    fn add_sample(
        &self,
        tile: &mut FilmTile,
        p_film: Vec2,
        mut l: Spectrum,
        sample_weight: f32,
        second_half: bool,
    ) {
        let y = l.y();
        if y > self.film.max_sample_luminance {
            l *= self.film.max_sample_luminance / y;
        }
        let r = self.film.filter_radius;
        let pd = p_film - Vec2::splat(0.5);
        let b = tile.pixel_bounds;
        let x0 = (math::ceil(pd.x - r.x) as i32).max(b.min.x);
        let y0 = (math::ceil(pd.y - r.y) as i32).max(b.min.y);
        let x1 = (math::floor(pd.x + r.x) as i32 + 1).min(b.max.x);
        let y1 = (math::floor(pd.y + r.y) as i32 + 1).min(b.max.y);
        let lw = l * sample_weight;
        let last = FILTER_TABLE_SIZE - 1;
        for py in y0..y1 {
            // pbrt-v3's floor of a magnitude: the cast truncates, the same.
            let fy = ((py as f32 - pd.y) * self.inv_filter_radius.y * FILTER_TABLE_SIZE as f32)
                .abs() as usize;
            let fy = fy.min(last);
            for px in x0..x1 {
                let fx = ((px as f32 - pd.x) * self.inv_filter_radius.x * FILTER_TABLE_SIZE as f32)
                    .abs() as usize;
                let w = self.filter_table[fy * FILTER_TABLE_SIZE + fx.min(last)];
                tile.add(Point2i::new(px, py), lw, w, second_half);
            }
        }
    }
}
