//! A bounding volume hierarchy over primitive bounds, built with the binned
//! surface area heuristic and flattened depth-first, after pbrt-v3's
//! `BVHAccel` (`accelerators/bvh.cpp`, split method `"sah"`):
//!
//! ```text
//! Accelerator "bvh" "integer maxnodeprims" 4
//! ```

use super::sah::{build_node, Extent, PrimInfo};
use farm_common::geometry::{gamma, Bounds3f, Ray, Vec3};

/// pbrt-v3's default `maxnodeprims`.
pub const DEFAULT_MAX_PRIMS_IN_NODE: usize = 4;

/// Depth of the traversal stack; the build keeps every leaf shallower.
pub(super) const STACK_SIZE: usize = 64;

/// One node of the flattened tree (pbrt-v3 `LinearBVHNode`, 32 bytes). An
/// interior node's first child follows it; `offset` is its second child.
/// A leaf's primitives are `offset..offset + n_prims` in the build order.
#[derive(Clone, Copy, Debug, PartialEq)]
#[repr(C, align(32))]
pub(super) struct LinearNode {
    /// `[min, max]`, so that `b[dir_is_neg]` picks the near corner.
    pub(super) b: [[f32; 3]; 2],
    pub(super) offset: u32,
    pub(super) n_prims: u16,
    pub(super) axis: u8,
}

const _: () = assert!(std::mem::size_of::<LinearNode>() == 32);

impl LinearNode {
    pub(super) fn new(bounds: &Bounds3f, offset: u32, n_prims: u16, axis: u8) -> Self {
        LinearNode { b: [bounds.min.to_array(), bounds.max.to_array()], offset, n_prims, axis }
    }

    /// pbrt-v3's slab test with precomputed reciprocal direction and signs;
    /// far distances are rounded up by 1 + 2γ₃ so that no hit is lost.
    #[inline(always)]
    fn hit(&self, o: Vec3, inv: Vec3, neg: &[usize; 3], ray_t_max: f32) -> bool {
        let b = &self.b;
        let up = 1.0 + 2.0 * gamma(3);
        let mut t_min = (b[neg[0]][0] - o.x) * inv.x;
        let mut t_max = (b[1 - neg[0]][0] - o.x) * inv.x * up;
        let ty_min = (b[neg[1]][1] - o.y) * inv.y;
        let ty_max = (b[1 - neg[1]][1] - o.y) * inv.y * up;
        if t_min > ty_max || ty_min > t_max {
            return false;
        }
        if ty_min > t_min {
            t_min = ty_min;
        }
        if ty_max < t_max {
            t_max = ty_max;
        }
        let tz_min = (b[neg[2]][2] - o.z) * inv.z;
        let tz_max = (b[1 - neg[2]][2] - o.z) * inv.z * up;
        if t_min > tz_max || tz_min > t_max {
            return false;
        }
        if tz_min > t_min {
            t_min = tz_min;
        }
        if tz_max < t_max {
            t_max = tz_max;
        }
        t_min < ray_t_max && t_max > 0.0
    }
}

/// The hierarchy. It stores only nodes; the caller keeps the primitives in
/// the order [`Bvh::build`] returns and tests them in the closures given to
/// [`Bvh::intersect`] and [`Bvh::intersect_any`].
#[derive(Clone, Debug, Default)]
pub struct Bvh {
    nodes: Vec<LinearNode>,
}

impl Bvh {
    /// Builds a BVH over `items` and returns them in the BVH's order, so the
    /// index the intersection closures receive indexes the returned vector.
    pub fn build_over<T>(
        items: Vec<T>,
        bounds: impl Fn(&T) -> Bounds3f,
        max_prims_in_node: usize,
    ) -> (Bvh, Vec<T>) {
        let b: Vec<Bounds3f> = items.iter().map(bounds).collect();
        let (bvh, order) = Bvh::build(&b, max_prims_in_node);
        let mut slots: Vec<Option<T>> = items.into_iter().map(Some).collect();
        let ordered = order.iter().filter_map(|&i| slots[i as usize].take()).collect();
        (bvh, ordered)
    }

    /// Builds the hierarchy over `prim_bounds` with at most
    /// `max_prims_in_node` (capped at 255, as in pbrt-v3) primitives per leaf
    /// where the SAH allows. Returns the hierarchy and the primitive order:
    /// entry `i` is the index into `prim_bounds` of the `i`-th primitive,
    /// which is what the intersection closures receive. The result depends
    /// only on the input, not on thread scheduling.
    pub fn build(prim_bounds: &[Bounds3f], max_prims_in_node: usize) -> (Bvh, Vec<u32>) {
        let mut info: Vec<PrimInfo> = prim_bounds
            .iter()
            .enumerate()
            .map(|(i, b)| PrimInfo { bounds: *b, index: i as u32 })
            .collect();
        // A binary tree with non-empty leaves has at most 2n - 1 nodes.
        let mut nodes = Vec::with_capacity((2 * prim_bounds.len()).saturating_sub(1));
        if !info.is_empty() {
            let max_prims = max_prims_in_node.clamp(1, 255);
            let ext = Extent::of(&info);
            build_node(&mut info, 0, 0, max_prims, ext, &mut nodes);
        }
        (Bvh { nodes }, info.iter().map(|p| p.index).collect())
    }

    /// Bounds of everything (empty for an empty hierarchy).
    pub fn bounds(&self) -> Bounds3f {
        match self.nodes.first() {
            Some(n) => Bounds3f { min: Vec3::from(n.b[0]), max: Vec3::from(n.b[1]) },
            None => Bounds3f::default(),
        }
    }

    /// Number of nodes.
    pub fn node_count(&self) -> usize {
        self.nodes.len()
    }

    /// Closest hit: visits nodes front to back and calls `f(i, ray)` for
    /// each primitive `i` (in build order) whose leaf the ray reaches; `f`
    /// returns `Some(t)` when the primitive is hit at `t < ray.t_max`, after
    /// which the ray passed on is shortened to `t`. Returns whether
    /// anything was hit; the caller's closure keeps the hit itself.
    #[inline]
    pub fn intersect<F: FnMut(usize, &Ray) -> Option<f32>>(&self, ray: &Ray, mut f: F) -> bool {
        let mut shortened = *ray;
        let mut hit = false;
        self.traverse(ray, |range, t_max| {
            for i in range {
                shortened.t_max = *t_max;
                if let Some(t) = f(i, &shortened) {
                    hit = true;
                    if t < *t_max {
                        *t_max = t;
                    }
                }
            }
            false
        });
        hit
    }

    /// Any hit: like [`Bvh::intersect`] but stops at the first primitive
    /// for which `f` returns `true` (shadow rays).
    #[inline]
    pub fn intersect_any<F: FnMut(usize, &Ray) -> bool>(&self, ray: &Ray, mut f: F) -> bool {
        self.traverse(ray, |mut range, _| range.any(|i| f(i, ray)))
    }

    /// Walks the nodes the ray reaches, nearer child first, with a fixed
    /// stack; `leaf` gets each leaf's primitive range and the current
    /// `t_max`, which it may shorten, and returns `true` to stop.
    #[inline(always)]
    fn traverse<L: FnMut(std::ops::Range<usize>, &mut f32) -> bool>(
        &self,
        ray: &Ray,
        mut leaf: L,
    ) -> bool {
        if self.nodes.is_empty() {
            return false;
        }
        let inv = Vec3::new(1.0 / ray.d.x, 1.0 / ray.d.y, 1.0 / ray.d.z);
        let neg = [(inv.x < 0.0) as usize, (inv.y < 0.0) as usize, (inv.z < 0.0) as usize];
        let mut t_max = ray.t_max;
        let mut stack = [0u32; STACK_SIZE];
        let mut sp = 0usize;
        let mut current = 0usize;
        loop {
            let node = &self.nodes[current];
            if node.hit(ray.o, inv, &neg, t_max) {
                if node.n_prims > 0 {
                    let start = node.offset as usize;
                    if leaf(start..start + node.n_prims as usize, &mut t_max) {
                        return true;
                    }
                } else {
                    // Visit the child on the near side of the split first.
                    let (near, far) = if neg[node.axis as usize] == 1 {
                        (node.offset as usize, current + 1)
                    } else {
                        (current + 1, node.offset as usize)
                    };
                    stack[sp] = far as u32;
                    sp += 1;
                    current = near;
                    continue;
                }
            }
            if sp == 0 {
                return false;
            }
            sp -= 1;
            current = stack[sp] as usize;
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use farm_common::rng::Rng;

    /// A primitive for the tests: a box or a sphere.
    #[derive(Clone, Copy)]
    enum Prim {
        Box(Bounds3f),
        Sphere(Vec3, f32),
    }

    impl Prim {
        fn bounds(&self) -> Bounds3f {
            match *self {
                Prim::Box(b) => b,
                Prim::Sphere(c, r) => Bounds3f::new(c - Vec3::splat(r), c + Vec3::splat(r)),
            }
        }
        fn hit(&self, r: &Ray) -> Option<f32> {
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

    fn v(rng: &mut Rng, s: f32) -> Vec3 {
        Vec3::new(rng.uniform_f32(), rng.uniform_f32(), rng.uniform_f32()) * 2.0 * s
            - Vec3::splat(s)
    }

    fn random_prims(rng: &mut Rng, n: usize) -> Vec<Prim> {
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

    fn random_ray(rng: &mut Rng, i: usize) -> Ray {
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
    fn check_against_brute_force(prims: &[Prim], max_prims: usize, seed: u64) {
        let bounds: Vec<Bounds3f> = prims.iter().map(Prim::bounds).collect();
        let (bvh, order) = Bvh::build(&bounds, max_prims);
        let mut seen = vec![false; prims.len()];
        order.iter().for_each(|&i| seen[i as usize] = true);
        assert!(seen.iter().all(|&s| s), "order is a permutation");
        let ordered: Vec<Prim> = order.iter().map(|&i| prims[i as usize]).collect();
        let mut rng = Rng::new(seed);
        for i in 0..4000 {
            let ray = random_ray(&mut rng, i);
            let brute = prims.iter().filter_map(|p| p.hit(&ray)).fold(f32::INFINITY, f32::min);
            let mut closest = f32::INFINITY;
            let hit = bvh.intersect(&ray, |k, r| {
                let t = ordered[k].hit(r)?;
                closest = closest.min(t);
                Some(t)
            });
            assert_eq!(hit, brute.is_finite(), "ray {i}");
            assert_eq!(closest, brute, "ray {i}");
            let any = bvh.intersect_any(&ray, |k, r| ordered[k].hit(r).is_some());
            assert_eq!(any, brute.is_finite(), "ray {i}");
        }
    }

    /// Walks the tree checking links, containment and leaf sizes.
    fn check_structure(bvh: &Bvh, n: usize, max_leaf: usize) {
        let mut covered = vec![0u8; n];
        let mut stack = vec![(0usize, 0usize)];
        while let Some((i, depth)) = stack.pop() {
            assert!(depth < STACK_SIZE);
            let node = &bvh.nodes[i];
            let b = Bounds3f { min: Vec3::from(node.b[0]), max: Vec3::from(node.b[1]) };
            if node.n_prims > 0 {
                assert!(node.n_prims as usize <= max_leaf);
                (0..node.n_prims as usize).for_each(|k| covered[node.offset as usize + k] += 1);
            } else {
                for c in [i + 1, node.offset as usize] {
                    let cb = Bounds3f {
                        min: Vec3::from(bvh.nodes[c].b[0]),
                        max: Vec3::from(bvh.nodes[c].b[1]),
                    };
                    assert_eq!(b.union(&cb), b);
                    stack.push((c, depth + 1));
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
            let (bvh, _) =
                Bvh::build(&prims.iter().map(Prim::bounds).collect::<Vec<_>>(), max_prims);
            check_structure(&bvh, n, max_prims.max(2));
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

    #[test]
    fn parallel_build_is_deterministic() {
        let mut rng = Rng::new(13);
        let bounds: Vec<Bounds3f> = (0..200_000)
            .map(|_| {
                let c = v(&mut rng, 100.0);
                Bounds3f::new(c, c + v(&mut rng, 1.0))
            })
            .collect();
        let (a, oa) = Bvh::build(&bounds, 4);
        let (b, ob) = Bvh::build(&bounds, 4);
        assert_eq!((a.nodes, oa), (b.nodes, ob));
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
}
