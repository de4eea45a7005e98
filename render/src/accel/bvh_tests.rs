//! Tests of the BVH: its build against brute force, its structure, its
//! determinism and its edge cases.

use super::*;
use farm_common::rng::Rng;

/// A primitive for the tests: a box or a sphere.
#[derive(Clone, Copy)]
pub(super) enum Prim {
    Box(Bounds3f),
    Sphere(Vec3, f32),
}

impl Prim {
    pub(super) fn bounds(&self) -> Bounds3f {
        match *self {
            Prim::Box(b) => b,
            Prim::Sphere(c, r) => Bounds3f::new(c - Vec3::splat(r), c + Vec3::splat(r)),
        }
    }
    pub(super) fn hit(&self, r: &Ray) -> Option<f32> {
        let t = match *self {
            Prim::Box(b) => {
                let (t0, t1) = b.intersect_p(r)?;
                if t0 > 0.0 {
                    t0
                } else {
                    t1
                }
            }
            Prim::Sphere(c, rad) => {
                let oc = r.o - c;
                let (a, b, cc) = (r.d.dot(r.d), 2.0 * oc.dot(r.d), oc.dot(oc) - rad * rad);
                let disc = b * b - 4.0 * a * cc;
                if disc < 0.0 {
                    return None;
                }
                let (t0, t1) = ((-b - disc.sqrt()) / (2.0 * a), (-b + disc.sqrt()) / (2.0 * a));
                if t0 > 0.0 {
                    t0
                } else {
                    t1
                }
            }
        };
        (t > 0.0 && t < r.t_max).then_some(t)
    }
}

pub(super) fn v(rng: &mut Rng, s: f32) -> Vec3 {
    Vec3::new(rng.uniform_f32(), rng.uniform_f32(), rng.uniform_f32()) * 2.0 * s - Vec3::splat(s)
}

pub(super) fn random_prims(rng: &mut Rng, n: usize) -> Vec<Prim> {
    (0..n)
        .map(|i| {
            let c = v(rng, 10.0);
            if i % 2 == 0 {
                Prim::Box(Bounds3f::new(c, c + v(rng, 0.8)))
            } else {
                Prim::Sphere(c, 0.05 + rng.uniform_f32())
            }
        })
        .collect()
}

pub(super) fn random_ray(rng: &mut Rng, i: usize) -> Ray {
    let mut d = v(rng, 1.0);
    // Some rays are axis-aligned, with zero direction components.
    if i.is_multiple_of(7) {
        d = [Vec3::X, -Vec3::Y, Vec3::Z][i % 3];
    }
    let mut r = Ray::new(v(rng, 14.0), d, 0.0);
    if i.is_multiple_of(3) {
        r.t_max = 5.0 * rng.uniform_f32();
    }
    r
}

/// Compares closest and any hits with brute force over many rays.
pub(super) fn check_against_brute_force(prims: &[Prim], max_prims: usize, seed: u64) {
    let bounds: Vec<Bounds3f> = prims.iter().map(Prim::bounds).collect();
    let (bvh, order) = Bvh::build(&bounds, max_prims);
    let mut seen = vec![false; prims.len()];
    order.iter().for_each(|&i| seen[i as usize] = true);
    assert!(seen.iter().all(|&s| s), "order is a permutation");
    let ordered: Vec<Prim> = order.iter().map(|&i| prims[i as usize]).collect();
    // The walk for deep trees, with the stack any tree fits, on this one.
    let deep = Bvh { deep: true, ..bvh.clone() };
    let mut rng = Rng::new(seed);
    for i in 0..4000 {
        let ray = random_ray(&mut rng, i);
        let brute = prims.iter().filter_map(|p| p.hit(&ray)).fold(f32::INFINITY, f32::min);
        for bvh in [&bvh, &deep] {
            let mut closest = f32::INFINITY;
            let hit = bvh.intersect(&ray, |k, r| {
                let t = ordered[k].hit(r)?;
                closest = closest.min(t);
                Some(t)
            });
            assert_eq!(hit, brute.is_finite(), "ray {i}");
            assert_eq!(closest, brute, "ray {i}");
        }
        let any = bvh.intersect_any(&ray, |k, r| ordered[k].hit(r).is_some());
        assert_eq!(any, brute.is_finite(), "ray {i}");
    }
}

/// Walks the tree checking links, containment, leaf sizes and depth.
fn check_structure(bvh: &Bvh, n: usize, max_leaf: usize) {
    let mut covered = vec![0u8; n];
    let lane_box = |node: &Node, l: usize| Bounds3f {
        min: Vec3::new(node.b[0][l], node.b[1][l], node.b[2][l]),
        max: Vec3::new(node.b[3][l], node.b[4][l], node.b[5][l]),
    };
    let mut stack = vec![(0usize, 0usize, bvh.bounds())];
    while let Some((i, depth, parent)) = stack.pop() {
        assert!(depth < STACK_SIZE);
        let node = &bvh.nodes[i];
        assert!((1..=WIDTH as u8).contains(&node.n));
        for l in 0..node.n as usize {
            let b = lane_box(node, l);
            assert_eq!(parent.union(&b), parent, "child box inside its parent's");
            if node.count[l] > 0 {
                assert!(node.count[l] as usize <= max_leaf);
                let start = node.child[l] as usize;
                (start..start + node.count[l] as usize).for_each(|k| covered[k] += 1);
            } else {
                stack.push((node.child[l] as usize, depth + 1, b));
            }
        }
    }
    assert!(covered.iter().all(|&c| c == 1));
}

#[test]
fn random_boxes_and_spheres_match_brute_force() {
    let mut rng = Rng::new(5);
    for (n, max_prims) in [(1, 4), (2, 4), (7, 1), (500, 4), (3000, 4), (3000, 16)] {
        let prims = random_prims(&mut rng, n);
        check_against_brute_force(&prims, max_prims, n as u64);
        let (bvh, _) = Bvh::build(&prims.iter().map(Prim::bounds).collect::<Vec<_>>(), max_prims);
        check_structure(&bvh, n, max_prims.max(2));
    }
}

/// A ray lying in the plane of a box face (its slab test is 0·∞) still
/// reaches the box's primitives, whichever axis the face is on.
#[test]
fn rays_in_a_face_plane_reach_the_box() {
    let unit = Bounds3f::new(Vec3::ZERO, Vec3::ONE);
    let (bvh, _) = Bvh::build(&[unit, Bounds3f::new(Vec3::splat(5.0), Vec3::splat(6.0))], 1);
    for axis in 0..3 {
        for face in [0.0, 1.0] {
            let along = (axis + 1) % 3;
            let mut o = Vec3::splat(0.5);
            o[axis] = face;
            o[along] = -1.0;
            let mut d = Vec3::ZERO;
            d[along] = 1.0;
            let ray = Ray::new(o, d, 0.0);
            let mut visited = Vec::new();
            assert!(bvh.intersect_any(&ray, |i, _| {
                visited.push(i);
                true
            }));
            assert!(bvh.intersect(&ray, |_, _| Some(1.0)), "axis {axis}, face {face}");
            assert_eq!(visited.len(), 1);
        }
    }
}

/// Gathering puts each place's item there, for permutations of every
/// cycle structure (the identity, one long cycle, swaps, random ones).
#[test]
fn gather_puts_each_item_in_its_place() {
    let mut rng = Rng::new(8);
    let mut orders: Vec<Vec<u32>> = vec![vec![], vec![0], (0..9).collect(), (0..9).rev().collect()];
    orders.push((1..50).chain([0]).collect());
    for n in [2u32, 17, 1000] {
        let mut o: Vec<u32> = (0..n).collect();
        for i in (1..o.len()).rev() {
            o.swap(i, rng.uniform_u32_below(i as u32 + 1) as usize);
        }
        orders.push(o);
    }
    for order in orders {
        let items: Vec<String> = (0..order.len()).map(|i| format!("item {i}")).collect();
        let expected: Vec<String> = order.iter().map(|&i| format!("item {i}")).collect();
        assert_eq!(gather(items, &order), expected);
    }
}

/// Subtrees of at most `max_prims` primitives are single leaves: every
/// interior lane of the 8-wide tree holds more than that.
#[test]
fn small_subtrees_are_single_leaves() {
    fn prims_under(bvh: &Bvh, node: usize) -> usize {
        let n = &bvh.nodes[node];
        (0..n.n as usize)
            .map(|l| match n.count[l] {
                0 => prims_under(bvh, n.child[l] as usize),
                c => c as usize,
            })
            .sum()
    }
    let mut rng = Rng::new(12);
    for max_prims in [1, 2, 4, 8] {
        let prims = random_prims(&mut rng, 3000);
        let (bvh, _) = Bvh::build(&prims.iter().map(Prim::bounds).collect::<Vec<_>>(), max_prims);
        assert_eq!(prims_under(&bvh, 0), 3000);
        let mut leaves = 0;
        for node in &bvh.nodes {
            for l in 0..node.n as usize {
                if node.count[l] == 0 {
                    assert!(prims_under(&bvh, node.child[l] as usize) > max_prims);
                } else {
                    leaves += 1;
                }
            }
        }
        assert!(leaves < 3000 || max_prims == 1, "leaves hold several primitives");
    }
}

/// Only primitives marked cheap share leaves: costly ones keep the
/// boxes pbrt-v3's SAH gives them.
#[test]
fn costly_primitives_keep_their_boxes() {
    let mut rng = Rng::new(13);
    let prims = random_prims(&mut rng, 3000);
    let build = |cheap: bool| Bvh::build_over(prims.clone(), Prim::bounds, |_| cheap, 4).0;
    let (shared, own) = (build(true), build(false));
    let (a, b) = (own.node_count(), shared.node_count());
    assert!(a > b * 3 / 2, "{a} nodes with a box each, {b} sharing leaves");
    check_structure(&own, 3000, 4);
}

/// `build_over` returns the items in exactly the order `build` reports.
#[test]
fn build_over_orders_items_as_build_does() {
    let mut rng = Rng::new(31);
    for n in [0, 1, 2, 5, 100, 3000] {
        let prims = random_prims(&mut rng, n);
        let bounds: Vec<Bounds3f> = prims.iter().map(Prim::bounds).collect();
        let (_, order) = Bvh::build(&bounds, 4);
        let (_, items) = Bvh::build_over((0..n).collect(), |&i| bounds[i], |_| true, 4);
        let expected: Vec<usize> = order.iter().map(|&i| i as usize).collect();
        assert_eq!(items, expected);
    }
}

#[test]
fn empty_and_single_primitive() {
    let (bvh, order) = Bvh::build(&[], 4);
    assert!(order.is_empty() && bvh.bounds().is_empty());
    let r = Ray::new(Vec3::ZERO, Vec3::X, 0.0);
    assert!(!bvh.intersect(&r, |_, _| panic!("no primitives")));
    assert!(!bvh.intersect_any(&r, |_, _| panic!("no primitives")));
    let b = Bounds3f::new(Vec3::new(1.0, -1.0, -1.0), Vec3::new(2.0, 1.0, 1.0));
    let (bvh, order) = Bvh::build(&[b], 4);
    assert_eq!((order, bvh.node_count(), bvh.bounds()), (vec![0], 1, b));
    assert!(bvh.intersect(&r, |i, _| Some(i as f32 + 1.0)));
    assert!(!bvh.intersect_any(&Ray::new(Vec3::ZERO, -Vec3::X, 0.0), |_, _| true));
}

/// The build splits large subtrees over threads; the tree and the
/// order are the same whatever the pool, for shared leaves and costly
/// primitives alike.
#[test]
fn the_build_is_the_same_on_any_number_of_threads() {
    let mut rng = Rng::new(11);
    let prims = random_prims(&mut rng, 300_000);
    let items: Vec<(u32, Prim)> =
        prims.into_iter().enumerate().map(|(i, p)| (i as u32, p)).collect();
    let build = |threads: usize| {
        let pool = rayon::ThreadPoolBuilder::new().num_threads(threads).build().unwrap();
        pool.install(|| {
            let cheap = |(_, p): &(u32, Prim)| matches!(p, Prim::Box(_));
            let (bvh, ordered) = Bvh::build_over(items.clone(), |(_, p)| p.bounds(), cheap, 4);
            let order: Vec<u32> = ordered.iter().map(|(i, _)| *i).collect();
            (bvh.nodes, bvh.bounds, order)
        })
    };
    let one = build(1);
    assert!(one.0.len() > 1000);
    assert!(build(2) == one);
    assert!(build(3) == one);
}

#[test]
fn empty_and_nan_bounds_do_not_break_the_build() {
    let mut bounds = vec![Bounds3f::default(); 50];
    bounds.push(Bounds3f::new(Vec3::splat(f32::NAN), Vec3::ONE));
    bounds.push(Bounds3f::new(Vec3::new(2.0, -1.0, -1.0), Vec3::new(3.0, 1.0, 1.0)));
    let (bvh, order) = Bvh::build(&bounds, 4);
    assert_eq!(order.len(), bounds.len());
    let good = order.iter().position(|&i| i == 51).unwrap();
    let r = Ray::new(Vec3::ZERO, Vec3::X, 0.0);
    let mut seen = false;
    bvh.intersect(&r, |i, _| {
        seen |= i == good;
        None
    });
    assert!(seen);
}

#[test]
fn identical_centroids_split_by_count() {
    let mut rng = Rng::new(9);
    let c = Vec3::new(1.0, 2.0, 3.0);
    let prims: Vec<Prim> = (0..1000)
        .map(|i| {
            let h = Vec3::splat(0.01) + v(&mut rng, 1.0).abs();
            if i % 2 == 0 {
                Prim::Box(Bounds3f::new(c - h, c + h))
            } else {
                Prim::Sphere(c, h.x)
            }
        })
        .collect();
    check_against_brute_force(&prims, 4, 3);
    let (bvh, _) = Bvh::build(&prims.iter().map(Prim::bounds).collect::<Vec<_>>(), 4);
    check_structure(&bvh, prims.len(), 4);
}

/// Timing check (run with `--ignored --nocapture`, optimised).
#[test]
#[ignore]
fn builds_a_million_primitives_quickly() {
    let mut rng = Rng::new(17);
    let bounds: Vec<Bounds3f> = (0..1_000_000)
        .map(|_| {
            let c = v(&mut rng, 100.0);
            Bounds3f::new(c, c + v(&mut rng, 0.5))
        })
        .collect();
    let mut build = std::time::Duration::MAX;
    let (mut bvh, mut order) = (Bvh::default(), Vec::new());
    for _ in 0..3 {
        let start = std::time::Instant::now();
        (bvh, order) = Bvh::build(&bounds, 4);
        build = build.min(start.elapsed());
    }
    let ordered: Vec<Bounds3f> = order.iter().map(|&i| bounds[i as usize]).collect();
    let start = std::time::Instant::now();
    let mut hits = 0;
    for i in 0..100_000 {
        let r = random_ray(&mut rng, i);
        hits += bvh.intersect(&r, |k, r| ordered[k].intersect_p(r).map(|(t0, _)| t0)) as usize;
    }
    println!(
        "build {build:?}, {} nodes; 100K rays {:?}, {hits} hits",
        bvh.node_count(),
        start.elapsed()
    );
    assert!(build.as_secs_f32() < 1.0);
}

#[test]
fn large_parallel_build_matches_brute_force() {
    let mut rng = Rng::new(21);
    let prims = random_prims(&mut rng, 150_000);
    let bounds: Vec<Bounds3f> = prims.iter().map(Prim::bounds).collect();
    let (bvh, order) = Bvh::build(&bounds, 4);
    check_structure(&bvh, prims.len(), 4);
    let ordered: Vec<Prim> = order.iter().map(|&i| prims[i as usize]).collect();
    for i in 0..200 {
        let ray = random_ray(&mut rng, i);
        let brute = prims.iter().filter_map(|p| p.hit(&ray)).fold(f32::INFINITY, f32::min);
        let mut closest = f32::INFINITY;
        bvh.intersect(&ray, |k, r| {
            let t = ordered[k].hit(r)?;
            closest = closest.min(t);
            Some(t)
        });
        assert_eq!(closest, brute, "ray {i}");
    }
}

/// The shortcuts of the build find pbrt-v3's tree: a node's buckets
/// binned by its parent's partition, and a small node's choice made over
/// the buckets it fills, give the same tree and order as scanning all
/// twelve at every node, bit for bit. Over random boxes and spheres, a
/// coherent grid of thin boxes (a mesh's order), clusters of equal
/// centroids, and a row of boxes (more than a binned node's worth) whose
/// bounds mix +0 and -0 (which the fold of a minimum or maximum keeps
/// either of, by order), with NaN and infinite bounds among them. Nodes
/// are compared as printed, which tells -0 from +0.
#[test]
fn the_build_shortcuts_find_the_same_tree() {
    let mut rng = Rng::new(23);
    let mut prims = random_prims(&mut rng, 40_000);
    for i in 0..20_000 {
        let c = Vec3::new((i % 200) as f32, (i / 200) as f32 * 0.5, 0.0);
        prims.push(Prim::Box(Bounds3f::new(c, c + Vec3::new(1.0, 0.5, 0.0))));
    }
    for i in 0..2_000 {
        let c = v(&mut rng, 50.0) + Vec3::splat((i / 5) as f32 * 1e-3);
        let h = v(&mut rng, 0.5).abs();
        prims.push(Prim::Box(Bounds3f::new(c - h, c + h)));
        prims.push(Prim::Box(Bounds3f::new(c - 2.0 * h, c + 2.0 * h)));
    }
    let zero = |i: usize, k: usize| if (i / k).is_multiple_of(2) { 0.0 } else { -0.0 };
    for i in 0..40_000 {
        let x = 300.0 + (i % 20_000) as f32 * 0.01;
        let mut min = Vec3::new(x, zero(i, 1), zero(i, 3));
        let max = Vec3::new(x + 0.005, 1.0 + (i / 20_000) as f32, zero(i, 2));
        if i % 9_001 == 4_000 {
            min.y = f32::NAN;
        }
        if i % 13_001 == 6_000 {
            min.x = f32::NEG_INFINITY;
        }
        prims.push(Prim::Box(Bounds3f { min, max }));
    }
    // A row without -0, with NaN and infinite bounds among them.
    for i in 0..20_000 {
        let x = 600.0 + i as f32 * 0.01;
        let mut min = Vec3::new(x, 0.5, 0.5);
        if i % 997 == 500 {
            min.y = f32::NAN;
        }
        if i % 1_999 == 700 {
            min.z = f32::NEG_INFINITY;
        }
        prims.push(Prim::Box(Bounds3f { min, max: Vec3::new(x + 0.005, 1.0, 1.0) }));
    }
    for _ in 0..100 {
        let c = v(&mut rng, 10.0);
        prims.push(Prim::Box(Bounds3f::new(c, c + Vec3::ONE)));
    }
    let items: Vec<(u32, Prim)> =
        prims.into_iter().enumerate().map(|(i, p)| (i as u32, p)).collect();
    let build = |plain: bool| {
        let pool = rayon::ThreadPoolBuilder::new().num_threads(1).build().unwrap();
        pool.install(|| {
            crate::accel::sah::PLAIN.with(|s| s.set(plain));
            let cheap = |(_, p): &(u32, Prim)| matches!(p, Prim::Box(_));
            let (bvh, ordered) = Bvh::build_over(items.clone(), |(_, p)| p.bounds(), cheap, 4);
            let order: Vec<u32> = ordered.iter().map(|(i, _)| *i).collect();
            (format!("{:?}", bvh.nodes), format!("{:?}", bvh.bounds), order)
        })
    };
    let plain = build(true);
    assert!(plain.2.len() > 100_000 && plain.0.contains("-0.0"));
    assert!(build(false) == plain);
}
