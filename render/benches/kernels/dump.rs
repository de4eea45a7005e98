//! `FARM_DUMP_DIR=DIR cargo bench -p farm-render --bench kernels`: instead
//! of the micro-benchmarks, writes the BVH benches' triangles, rays and our
//! answers to DIR in the format of the Embree comparison tool
//! (`../shared/tools/embree-bench/`), with our single-thread times for the
//! same rays and our build times, so that tool prints the two side by side
//! and counts the rays on which the answers differ. `scripts/embree-compare`
//! does the whole comparison in one command.
//!
//! Scenes: the 100,352-triangle torus of the `bvh` benches with its camera
//! and shadow rays, and a sphere of 1,000,000 triangles with 1024² pinhole
//! rays and 2²⁰ incoherent ones (origins in and around it, directions
//! uniform). Triangles are written in BVH order, so a hit's primitive index
//! is the same number in both programs.

use super::*;
use farm_render::accel::closest_in_leaf;
use farm_render::shapes::{triangle4, TriRay};
use std::io::Write;
use std::path::Path;
use std::time::Instant;

/// Timed passes per kernel (the fastest counts), each of at least this many rays.
const PASSES: usize = 5;
const MIN_RAYS_PER_PASS: usize = 250_000;

struct Scene {
    name: &'static str,
    shapes: Vec<Shape>,
    sets: Vec<(&'static str, Vec<Ray>)>,
}

pub fn run(dir: &Path) {
    std::fs::create_dir_all(dir).expect("create the dump directory");
    let torus = Scene {
        name: "torus",
        shapes: bvh::torus(),
        sets: vec![("camera", bvh::SETUP.camera.clone()), ("shadow", bvh::SETUP.shadow.clone())],
    };
    let (sphere, rays) = sphere();
    let sphere = Scene { name: "sphere", shapes: sphere, sets: rays };
    let mut manifest = String::new();
    let mut results = String::from("scene\tset\tkernel\trays\treps\tns_per_ray\n");
    let mut builds = String::from("scene\ttriangles\tseconds\n");
    for scene in [torus, sphere] {
        let prims: Vec<Primitive> = scene
            .shapes
            .into_iter()
            .map(|shape| Primitive { shape, material: Some(0).into(), area_light: None.into() })
            .collect();
        let n = prims.len();
        let max = farm_render::accel::DEFAULT_MAX_PRIMS_IN_NODE;
        // Built three times, the fastest counting; the last one is traced.
        let mut build = f64::INFINITY;
        let mut aggregate = None;
        for _ in 0..3 {
            let p = prims.clone();
            let t = Instant::now();
            let a = Aggregate::new(p, max);
            build = build.min(t.elapsed().as_secs_f64());
            aggregate = Some(a);
        }
        let aggregate = aggregate.expect("built");
        // The same build over the same primitives (Aggregate::new's own
        // call), walked with the hit test alone, no surface interaction:
        // the bare traversal.
        let share = Aggregate::shares_leaf(prims.len());
        let (bare, ordered) = Bvh::build_over(prims, |p| p.shape.bounds(), share, max);
        let tris: Vec<farm_render::shapes::Triangle> =
            ordered.iter().map(|p| p.shape.triangle().expect("meshes only")).collect();
        builds.push_str(&format!("{}\t{n}\t{build:.6}\n", scene.name));
        let tri_file = format!("{}_tris.bin", scene.name);
        let mut out = Vec::with_capacity(8 + n * 36);
        out.extend((n as u64).to_le_bytes());
        for t in &tris {
            for v in t.v {
                out.extend(t.mesh.p[v as usize].to_array().iter().flat_map(|c| c.to_le_bytes()));
            }
        }
        std::fs::write(dir.join(&tri_file), out).expect("write triangles");
        for (set, rays) in &scene.sets {
            let (rays_file, farm_file) = (
                format!("{}_{set}_rays.bin", scene.name),
                format!("{}_{set}_farm.bin", scene.name),
            );
            let mut out = Vec::with_capacity(8 + rays.len() * 28);
            out.extend((rays.len() as u64).to_le_bytes());
            for r in rays {
                let v = [r.o.x, r.o.y, r.o.z, r.d.x, r.d.y, r.d.z, r.t_max];
                out.extend(v.iter().flat_map(|c| c.to_le_bytes()));
            }
            std::fs::write(dir.join(&rays_file), out).expect("write rays");
            let mut out = Vec::with_capacity(rays.len() * 12);
            for r in rays {
                let (prim, t) = match aggregate.closest(r) {
                    Some((t, si)) => (si.prim as i32, t),
                    None => (-1, f32::INFINITY),
                };
                out.extend(prim.to_le_bytes());
                out.extend(t.to_le_bytes());
                out.extend(i32::from(aggregate.intersect_p(r)).to_le_bytes());
            }
            std::fs::write(dir.join(&farm_file), out).expect("write answers");
            manifest
                .push_str(&format!("{} {tri_file} {set} {rays_file} {farm_file}\n", scene.name));
            let reps = MIN_RAYS_PER_PASS.div_ceil(rays.len());
            let mut time = |kernel: &str, f: &dyn Fn(&Ray) -> bool| {
                let mut best = f64::INFINITY;
                for _ in 0..PASSES {
                    let t = Instant::now();
                    for _ in 0..reps {
                        for r in rays {
                            black_box(f(black_box(r)));
                        }
                    }
                    best = best.min(t.elapsed().as_secs_f64());
                }
                let ns = best * 1e9 / (reps * rays.len()) as f64;
                println!("{:<7} {set:<11} {kernel:<18} {ns:8.1} ns/ray", scene.name);
                results.push_str(&format!(
                    "{}\t{set}\t{kernel}\t{}\t{reps}\t{ns:.3}\n",
                    scene.name,
                    rays.len()
                ));
            };
            time("closest_aggregate", &|r| aggregate.closest(r).is_some());
            // The ray's permutation and shear made once, as the aggregate
            // (and Embree) make them, not once per triangle tested.
            time("closest_bare", &|r| {
                let tr = TriRay::new(r);
                // A shared leaf four triangles at a time, as the aggregate
                // tests it; the rest one by one.
                bare.intersect_leaves(r, |prims, r| {
                    if let Some(q) = triangle4::test(&ordered[prims.clone()], r, &tr, false) {
                        return q.accept(r, |_| {});
                    }
                    closest_in_leaf(prims, r, |i, r| {
                        tris[i].hit_barycentrics_prepared(r, &tr, true).map(|(t, _)| t)
                    })
                })
            });
            time("any", &|r| aggregate.intersect_p(r));
        }
        println!("{:<7} build {n} triangles: {:.1} ms (best of 3)", scene.name, build * 1e3);
    }
    for (name, text) in
        [("manifest.txt", manifest), ("farm_results.tsv", results), ("farm_build.tsv", builds)]
    {
        std::fs::File::create(dir.join(name))
            .and_then(|mut f| f.write_all(text.as_bytes()))
            .expect("write the dump's index");
    }
    println!("wrote {}", dir.display());
}

/// A UV sphere of radius 1 about the origin, 500 rings × 1,000 segments
/// (1,000,000 triangles; those at the poles have no area), and its rays.
fn sphere() -> (Vec<Shape>, Vec<(&'static str, Vec<Ray>)>) {
    let (rings, segs) = (500usize, 1000usize);
    let mut p = Vec::with_capacity((rings + 1) * segs);
    for i in 0..=rings {
        let theta = std::f32::consts::PI * i as f32 / rings as f32;
        for j in 0..segs {
            let phi = std::f32::consts::TAU * j as f32 / segs as f32;
            let s = math::sin(theta);
            p.push([s * math::cos(phi), s * math::sin(phi), math::cos(theta)]);
        }
    }
    let mut indices = Vec::with_capacity(rings * segs * 6);
    for i in 0..rings {
        for j in 0..segs {
            let idx = |a: usize, b: usize| (a * segs + b % segs) as i32;
            let (a, b, c, d) = (idx(i, j), idx(i + 1, j), idx(i + 1, j + 1), idx(i, j + 1));
            indices.extend([a, b, c, a, c, d]);
        }
    }
    let shapes = make_shapes(
        "trianglemesh",
        vec![("indices", ParamValue::Int(indices)), ("P", ParamValue::Point3(p))],
        &Transform::default(),
    );
    // 1024² pinhole rays from 3.5 away, the sphere filling most of the image.
    let camera = pinhole(Vec3::new(0.3, -3.5, 0.8), 0.35, 1024, || Vec2::splat(0.5));
    // 2²⁰ rays from points in a box twice the sphere's size, in uniform directions.
    let mut rng = Rng::new(9);
    let incoherent = (0..1 << 20)
        .map(|_| Ray::new(v3(&mut rng, -2.0, 2.0), uniform_sample_sphere(u2(&mut rng)), 0.0))
        .collect();
    (shapes, vec![("camera", camera), ("incoherent", incoherent)])
}
