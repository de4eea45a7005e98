//! `cargo bench -p farm-render --bench kernels`: micro-benchmarks of the
//! renderer's hot kernels. Every input set is fixed (a seeded PCG32) and made
//! once outside the timed loop; each timed iteration runs the whole set, so
//! the throughput column counts rays, BSDF evaluations or sample values and
//! the time column is per set. Inputs are built through the public
//! constructors the scene loader uses (`shapes::create`, `materials::build`,
//! `sampler::create`, `Aggregate::new`).

use divan::counter::ItemsCount;
use divan::{black_box, Bencher};
use farm_common::geometry::{Bounds2i, Bounds3f, Mat4, Point2i, Ray, Transform, Vec2, Vec3};
use farm_common::math;
use farm_common::rng::Rng;
use farm_common::scene::{Entity, FileLoc, MaterialEntity, Param, ParamValue, Params};
use farm_render::accel::Bvh;
use farm_render::bxdf::{Bsdf, BxDFType, TransportMode};
use farm_render::interaction::SurfaceInteraction;
use farm_render::materials;
use farm_render::primitive::{Aggregate, Primitive};
use farm_render::sampler;
use farm_render::sampling::{uniform_sample_hemisphere, uniform_sample_sphere};
use farm_render::shapes::{self, Shape};
use farm_render::textures::TextureSet;
use std::sync::LazyLock;

#[path = "kernels/dump.rs"]
mod dump;

fn main() {
    // For the Embree comparison: see `kernels/dump.rs`.
    if let Some(dir) = std::env::var_os("FARM_DUMP_DIR") {
        dump::run(std::path::Path::new(&dir));
        return;
    }
    divan::main();
}

/// Rays (or direction pairs) per set for the single-primitive kernels.
const N: usize = 4096;

fn v3(rng: &mut Rng, lo: f32, hi: f32) -> Vec3 {
    let mut c = || lo + (hi - lo) * rng.uniform_f32();
    Vec3::new(c(), c(), c())
}

fn u2(rng: &mut Rng) -> Vec2 {
    Vec2::new(rng.uniform_f32(), rng.uniform_f32())
}

fn entity(name: &str, params: Vec<(&str, ParamValue)>) -> Entity {
    let mut e = Entity::named(name);
    for (n, value) in params {
        e.params.add(Param { name: n.into(), value, loc: FileLoc::default() });
    }
    e
}

/// The rays of a `side` × `side` pinhole image from `eye` towards the
/// origin (z up; `half` the tangent of half the field of view), in raster
/// order, each through its pixel at the offset `at` gives (in [0, 1)²).
fn pinhole(eye: Vec3, half: f32, side: usize, mut at: impl FnMut() -> Vec2) -> Vec<Ray> {
    let forward = (-eye).normalize();
    let right = forward.cross(Vec3::Z).normalize();
    let up = right.cross(forward);
    let mut rays = Vec::with_capacity(side * side);
    for y in 0..side {
        for x in 0..side {
            let s = (Vec2::new(x as f32, y as f32) + at()) / side as f32;
            let d = forward + half * ((2.0 * s.x - 1.0) * right + (1.0 - 2.0 * s.y) * up);
            rays.push(Ray::new(eye, d.normalize(), 0.0));
        }
    }
    rays
}

/// Shapes from one `Shape` directive, exactly as the scene builds them.
fn make_shapes(name: &str, params: Vec<(&str, ParamValue)>, xf: &Transform) -> Vec<Shape> {
    let e = entity(name, params);
    let mut warnings = Vec::new();
    let shapes = shapes::create(name, &Params::new(&e.params), xf, false, &mut warnings);
    assert!(warnings.is_empty(), "{warnings:?}");
    shapes
}

/// Asserts that `hit` holds for 20–80% of `items`: the sets mix hits and
/// misses, which keeps branch prediction honest.
fn check_mixed<T>(what: &str, items: &[T], hit: impl Fn(&T) -> bool) {
    let f = items.iter().filter(|x| hit(x)).count() as f32 / items.len() as f32;
    assert!((0.2..=0.8).contains(&f), "{what}: hit fraction {f} is not mixed");
}

/// Ray–shape kernels: the watertight triangle test and the sphere quadric.
#[path = "kernels/shape.rs"]
mod shape;

/// Ray–box slab tests.
mod ray_box {
    use super::*;

    /// `N` random boxes, each with a ray aimed into the box grown 1.6×
    /// about its centre.
    fn boxes() -> Vec<(Bounds3f, Ray)> {
        let mut rng = Rng::new(3);
        let set: Vec<(Bounds3f, Ray)> = (0..N)
            .map(|_| {
                let b = Bounds3f::new(v3(&mut rng, -1.0, 1.0), v3(&mut rng, -1.0, 1.0));
                let target = b.centroid() + 0.8 * b.diagonal() * v3(&mut rng, -1.0, 1.0);
                let o = target + 4.0 * uniform_sample_sphere(u2(&mut rng));
                (b, Ray::new(o, (target - o).normalize(), 0.0))
            })
            .collect();
        check_mixed("box", &set, |(b, r)| b.intersect_p(r).is_some());
        set
    }

    /// pbrt-v3 `Bounds3::IntersectP`: reciprocals per call, returns (t0, t1).
    #[divan::bench]
    fn bounds_intersect_p(bencher: Bencher) {
        let set = boxes();
        bencher.counter(ItemsCount::new(N)).bench_local(|| {
            for (b, r) in black_box(&set) {
                black_box(b.intersect_p(r));
            }
        });
    }

    /// `Bounds3f::hit`: the vectorised slab test with a precomputed reciprocal.
    #[divan::bench]
    fn bounds_hit(bencher: Bencher) {
        let set: Vec<(Bounds3f, Vec3, Vec3, f32)> =
            boxes().into_iter().map(|(b, r)| (b, r.o, r.d.recip(), r.t_max)).collect();
        bencher.counter(ItemsCount::new(N)).bench_local(|| {
            for (b, o, inv, t_max) in black_box(&set) {
                black_box(b.hit(*o, *inv, *t_max));
            }
        });
    }

    /// The BVH's own node test (pbrt-v3's sign-indexed slab test, private to
    /// `accel::bvh`), reached through a one-node `Bvh` per box: includes the
    /// per-ray set-up every traversal pays (reciprocal, signs, stack).
    #[divan::bench]
    fn bvh_single_node(bencher: Bencher) {
        let set: Vec<(Bvh, Ray)> =
            boxes().into_iter().map(|(b, r)| (Bvh::build(&[b], 4).0, r)).collect();
        bencher.counter(ItemsCount::new(N)).bench_local(|| {
            for (bvh, r) in black_box(&set) {
                black_box(bvh.intersect_any(r, |_, _| true));
            }
        });
    }
}

/// BVH traversal through the scene's `Aggregate` over a ~100k-triangle mesh.
mod bvh {
    use super::*;

    /// Segments around the torus's major and minor circles: 224 × 224 quads,
    /// 100,352 triangles.
    const TORUS_SEGMENTS: usize = 224;
    /// Camera rays: a 64 × 64 jittered image of the torus, in raster order.
    const IMAGE: usize = 64;

    pub(crate) struct Setup {
        aggregate: Aggregate,
        pub(crate) camera: Vec<Ray>,
        pub(crate) shadow: Vec<Ray>,
    }

    /// The torus's triangles (R = 1, r = 0.35, about z), with normals and
    /// uvs like an exported mesh.
    pub(crate) fn torus() -> Vec<Shape> {
        let (n, big_r, small_r) = (TORUS_SEGMENTS, 1.0f32, 0.35f32);
        let (mut p, mut nrm, mut uv, mut indices) = (vec![], vec![], vec![], vec![]);
        for i in 0..n {
            for j in 0..n {
                let (u, v) = (i as f32 / n as f32, j as f32 / n as f32);
                let (phi, theta) = (u * std::f32::consts::TAU, v * std::f32::consts::TAU);
                let dir = Vec3::new(math::cos(phi), math::sin(phi), 0.0);
                let normal = math::cos(theta) * dir + math::sin(theta) * Vec3::Z;
                p.push((big_r * dir + small_r * normal).to_array());
                nrm.push(normal.to_array());
                uv.push([u, v]);
                let idx = |a: usize, b: usize| ((a % n) * n + b % n) as i32;
                let (a, b, c, d) = (idx(i, j), idx(i + 1, j), idx(i + 1, j + 1), idx(i, j + 1));
                indices.extend([a, b, c, a, c, d]);
            }
        }
        make_shapes(
            "trianglemesh",
            vec![
                ("indices", ParamValue::Int(indices)),
                ("P", ParamValue::Point3(p)),
                ("N", ParamValue::Normal(nrm)),
                ("uv", ParamValue::Point2(uv)),
            ],
            &Transform::default(),
        )
    }

    /// A torus (R = 1, r = 0.35, about z) with normals and uvs, like an
    /// exported mesh; camera rays from an eye above it; shadow rays from each
    /// camera hit (or, for a miss, a point in the torus's bounds) to a light.
    /// 37% of the camera rays hit and 46% of the shadow rays are blocked.
    /// Shadow rays start inside the mesh's nested boxes and more than half
    /// must walk every node they cross, so they cost more than camera rays
    /// whatever the traversal; `closest_hit_shadow_rays` shows that part.
    pub(crate) static SETUP: LazyLock<Setup> = LazyLock::new(|| {
        let shapes = torus();
        let prims = shapes
            .into_iter()
            .map(|shape| Primitive { shape, material: Some(0).into(), area_light: None.into() })
            .collect();
        let aggregate = Aggregate::new(prims, farm_render::accel::DEFAULT_MAX_PRIMS_IN_NODE);

        // A pinhole camera looking at the centre from above and to one side.
        let mut rng = Rng::new(4);
        let camera = pinhole(Vec3::new(0.5, -3.0, 2.5), 0.42, IMAGE, || u2(&mut rng));
        let light = Vec3::new(2.0, 1.0, 3.0);
        let b = aggregate.bounds();
        let shadow: Vec<Ray> = camera
            .iter()
            .map(|r| match aggregate.closest(r) {
                Some((_, si)) => si.it.spawn_ray_to_point(light),
                None => {
                    let o = b.min + b.diagonal() * v3(&mut rng, 0.0, 1.0);
                    Ray { o, d: light - o, t_max: 1.0, time: 0.0 }
                }
            })
            .collect();
        check_mixed("camera rays", &camera, |r| aggregate.intersect_p(r));
        check_mixed("shadow rays", &shadow, |r| aggregate.intersect_p(r));
        Setup { aggregate, camera, shadow }
    });

    /// `Aggregate::intersect` on the camera rays: front-to-back traversal,
    /// shortening the ray, and the surface interaction of the closest hit.
    #[divan::bench]
    fn closest_hit(bencher: Bencher) {
        let s = &*SETUP;
        bencher.counter(ItemsCount::new(s.camera.len())).bench_local(|| {
            for r in black_box(&s.camera) {
                black_box(s.aggregate.closest(r));
            }
        });
    }

    /// `Aggregate::intersect` on the shadow rays, to compare with `any_hit`.
    #[divan::bench]
    fn closest_hit_shadow_rays(bencher: Bencher) {
        let s = &*SETUP;
        bencher.counter(ItemsCount::new(s.shadow.len())).bench_local(|| {
            for r in black_box(&s.shadow) {
                black_box(s.aggregate.closest(r));
            }
        });
    }

    /// `Aggregate::intersect_p` on the shadow rays: stops at the first hit.
    #[divan::bench]
    fn any_hit(bencher: Bencher) {
        let s = &*SETUP;
        bencher.counter(ItemsCount::new(s.shadow.len())).bench_local(|| {
            for r in black_box(&s.shadow) {
                black_box(s.aggregate.intersect_p(r));
            }
        });
    }
}

/// `Bsdf::f` for the materials built by `materials::build` with pbrt-v3's
/// defaults: matte (Lambert, and Oren–Nayar at sigma 20), plastic (Lambert
/// plus a Trowbridge–Reitz dielectric lobe) and metal (a Trowbridge–Reitz
/// conductor, copper).
mod bsdf {
    use super::*;

    fn bsdf(name: &str) -> Bsdf<'static> {
        let e = match name {
            "oren_nayar" => entity("matte", vec![("sigma", ParamValue::Float(vec![20.0]))]),
            "lambert" => entity("matte", vec![]),
            other => entity(other, vec![]),
        };
        let textures = TextureSet::default();
        let mut warnings = Vec::new();
        let files = materials::MaterialFiles::none();
        let entity = [MaterialEntity { name: None, entity: e }];
        // The BSDF borrows its materials; a bench can keep them for good.
        let m = Vec::leak(materials::build(&entity, &textures, &files, &mut warnings));
        assert!(warnings.is_empty(), "{warnings:?}");
        // A hit whose shading frame is tilted away from the axes.
        let dpdu = Vec3::new(1.0, 0.2, -0.3);
        let dpdv = Vec3::new(0.1, 1.0, 0.4);
        let mut si = SurfaceInteraction::new(
            Vec3::ZERO,
            Vec3::ZERO,
            Vec2::new(0.3, 0.6),
            dpdu.cross(dpdv).normalize(),
            dpdu,
            dpdv,
            Vec3::ZERO,
            Vec3::ZERO,
            0.0,
            false,
        );
        m[0].compute_bsdf(&mut si, m, &textures, TransportMode::Radiance, false)
    }

    /// World-space (wo, wi) pairs above the surface; every eighth wi lies
    /// below it (a light behind the surface).
    fn pairs(b: &Bsdf) -> Vec<(Vec3, Vec3)> {
        let mut rng = Rng::new(5);
        (0..N)
            .map(|i| {
                let wo = uniform_sample_hemisphere(u2(&mut rng));
                let mut wi = uniform_sample_hemisphere(u2(&mut rng));
                if i % 8 == 7 {
                    wi.z = -wi.z;
                }
                (b.local_to_world(wo), b.local_to_world(wi))
            })
            .collect()
    }

    #[divan::bench(args = ["lambert", "oren_nayar", "plastic", "metal"])]
    fn f(bencher: Bencher, material: &str) {
        let b = bsdf(material);
        let set = pairs(&b);
        bencher.counter(ItemsCount::new(N)).bench_local(|| {
            let b = black_box(&b);
            for &(wo, wi) in black_box(&set) {
                black_box(b.f(wo, wi, BxDFType::ALL));
            }
        });
    }
}

/// Sample generation over one 16 × 16 tile of a 640 × 480 film at 16 spp,
/// as `render.rs` drives it: `start_pixel`, then each sample's values, then
/// `start_next_sample`.
mod samplers {
    use super::*;

    const TILE: i32 = 16;
    const SPP: usize = 16;
    /// Dimensions drawn per sample by the `get_1d` and `get_2d` benches.
    const DIMS: usize = 8;

    fn tile_sampler(name: &str) -> (sampler::Sampler, Vec<Point2i>) {
        let film = Bounds2i::new(Point2i::new(0, 0), Point2i::new(640, 480));
        let e = entity(name, vec![("pixelsamples", ParamValue::Int(vec![SPP as i32]))]);
        let mut warnings = Vec::new();
        let s = sampler::create(&e, film, None, &mut warnings);
        assert!(warnings.is_empty(), "{warnings:?}");
        let tile = Bounds2i::new(Point2i::new(128, 96), Point2i::new(128 + TILE, 96 + TILE));
        (s.clone_with_seed(42), tile.iter().collect())
    }

    /// Runs `sample` for every sample of every pixel of the tile.
    fn bench_tile(
        bencher: Bencher,
        name: &str,
        per_sample: usize,
        mut sample: impl FnMut(&mut sampler::Sampler, Point2i),
    ) {
        let (mut s, pixels) = tile_sampler(name);
        bencher.counter(ItemsCount::new(pixels.len() * SPP * per_sample)).bench_local(|| {
            for &p in black_box(&pixels) {
                s.start_pixel(p);
                loop {
                    sample(&mut s, p);
                    if !s.start_next_sample() {
                        break;
                    }
                }
            }
        });
    }

    /// Camera samples (film point, time, lens point: five dimensions).
    #[divan::bench(args = ["halton", "sobol", "random"])]
    fn camera_sample(bencher: Bencher, name: &str) {
        bench_tile(bencher, name, 1, |s, p| {
            black_box(s.camera_sample(p));
        });
    }

    /// `DIMS` 1D values per sample; the counter counts values.
    #[divan::bench(args = ["halton", "sobol", "random"])]
    fn get_1d(bencher: Bencher, name: &str) {
        bench_tile(bencher, name, DIMS, |s, _| {
            for _ in 0..DIMS {
                black_box(s.get_1d());
            }
        });
    }

    /// `DIMS` 2D values per sample; the counter counts pairs.
    #[divan::bench(args = ["halton", "sobol", "random"])]
    fn get_2d(bencher: Bencher, name: &str) {
        bench_tile(bencher, name, DIMS, |s, _| {
            for _ in 0..DIMS {
                black_box(s.get_2d());
            }
        });
    }
}

/// EWA lookups in a MIP map.
#[path = "kernels/mipmap.rs"]
mod mipmap;

/// Perlin noise and the textures built on it: `N` points each, at
/// footprints that show every octave (fbm and turbulence at 8 octaves, the
/// default).
mod noise {
    use super::*;
    use farm_render::textures::{fbm_noise, noise, turbulence};

    fn points() -> Vec<Vec3> {
        let mut rng = Rng::new(21);
        (0..N).map(|_| v3(&mut rng, -40.0, 40.0)).collect()
    }

    #[divan::bench]
    fn perlin(bencher: Bencher) {
        let p = points();
        bencher.counter(ItemsCount::new(N)).bench_local(|| {
            for q in black_box(&p) {
                black_box(noise(q.x, q.y, q.z));
            }
        });
    }

    /// `fbm` and `turbulence` at a footprint of 2^-12, which shows all
    /// eight octaves, and `fbm` at one of 0.02, which shows 3.85 (so it
    /// takes the logarithm and the fractional octave's noise).
    #[divan::bench(args = ["fbm", "turbulence", "fbm-3.85"])]
    fn octaves(bencher: Bencher, name: &str) {
        let d = Vec3::splat(if name == "fbm-3.85" { 0.02 } else { 1.0 / 4096.0 });
        let p = points();
        let f = if name == "turbulence" { turbulence } else { fbm_noise };
        bencher.counter(ItemsCount::new(N)).bench_local(|| {
            for &q in black_box(&p) {
                black_box(f(q, d, d, 0.5, 8));
            }
        });
    }
}
