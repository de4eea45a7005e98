//! Tests of the walks themselves: the node tests' bits on every path, the
//! walk of a tree that needs a deep stack, and the stackless walk of a
//! tree of one node.

use super::tests::{check_against_brute_force, random_prims, random_ray, v, Prim};
use super::*;
use farm_common::rng::Rng;

/// The SSE and AVX node tests give the portable one's mask and distances,
/// bit for bit, on boxes that are flat, empty or unbounded and rays that lie in a
/// face's plane, start on one, or run along an axis (0·∞ slabs).
#[test]
fn the_vector_node_test_is_the_portable_one() {
    let mut rng = Rng::new(17);
    let mut pick = |v: &[f32]| v[(rng.uniform_u32() as usize) % v.len()];
    let planes = [-2.0, -1.0, -0.0, 0.0, 0.5, 1.0, 3.0, f32::INFINITY, f32::NEG_INFINITY];
    let dirs = [-1.0, -0.5, -0.0, 0.0, 1e-30, 0.25, 1.0, 7.0];
    let (mut hits, mut tested) = (0u32, 0u32);
    for _ in 0..200_000 {
        // Rows 0 … 2 the minima, 3 … 5 the maxima; some boxes flat.
        let mut b = [[0.0f32; WIDTH]; 6];
        let (mins, maxs) = b.split_at_mut(3);
        for (lo, hi) in mins.iter_mut().flatten().zip(maxs.iter_mut().flatten()) {
            let (x, y) = (pick(&planes), pick(&planes));
            *lo = x.min(y);
            *hi = if pick(&[0.0, 1.0]) == 0.0 { x.min(y) } else { x.max(y) };
        }
        let n = 1 + (pick(&[0.0, 1.0, 2.0, 3.0, 4.0, 5.0, 6.0, 7.0]) as u8);
        let node = Node { b, child: [0; WIDTH], count: [0; WIDTH], n };
        let o = Vec3::new(pick(&planes[..7]), pick(&planes[..7]), pick(&planes[..7]));
        let d = Vec3::new(pick(&dirs), pick(&dirs), pick(&dirs));
        let r = SlabRay::new(&Ray::new(o, d, 0.0));
        let t_max = pick(&[0.5, 2.0, f32::INFINITY]);
        let (pm, pt) = node.hit_portable(&r, t_max);
        // Distances count in the lanes in use only.
        let used = |t: [f32; WIDTH]| t.map(f32::to_bits)[..usize::from(n)].to_vec();
        for (m, t) in vector_hits(&node, &r, t_max) {
            assert_eq!(m, pm, "{b:?} {o:?} {d:?}");
            assert_eq!(used(t), used(pt), "{b:?} {o:?} {d:?}");
        }
        hits += pm.count_ones();
        tested += u32::from(n);
    }
    // Both hits and misses were tested.
    assert!(hits > 5_000 && tested - hits > 5_000, "{hits} of {tested}");
}

/// Each vector box test this CPU runs, on `node`.
fn vector_hits(node: &Node, r: &SlabRay, t_max: f32) -> Vec<(u32, [f32; WIDTH])> {
    #[allow(unused_mut)]
    let mut out = Vec::new();
    #[cfg(target_arch = "x86_64")]
    {
        out.push(node.hit_sse(r, t_max));
        if super::super::node::detected_simd() == super::super::node::Simd::Avx {
            // SAFETY: the CPU has AVX.
            out.push(unsafe { node.hit_avx(r, t_max) });
        }
    }
    out
}

/// A tree whose closest-hit walk may need more stack than most is marked
/// deep, and walked right: clusters of eight boxes, each level's a quarter
/// the distance and size of the last, so that every 8-wide node spends
/// seven lanes on a cluster and one on the levels within.
#[test]
fn a_tree_that_needs_a_deep_stack_is_walked_with_one() {
    let mut prims = Vec::new();
    for level in 0..60 {
        let d = 4f32.powi(-level) * 1e6;
        for k in 0..8 {
            let a = k as f32 * std::f32::consts::TAU / 8.0;
            let c = Vec3::new(
                d,
                d * 0.5 * farm_common::math::cos(a),
                d * 0.5 * farm_common::math::sin(a),
            );
            prims.push(Prim::Box(Bounds3f::new(c, c + Vec3::splat(d * 0.05))));
        }
    }
    let bounds: Vec<Bounds3f> = prims.iter().map(Prim::bounds).collect();
    let (bvh, _) = Bvh::build(&bounds, 1);
    let need = stack_need(&bvh.nodes, 0);
    assert!(bvh.deep && need > SHALLOW_STACK_SIZE, "needs {need}");
    check_against_brute_force(&prims, 1, 5);
}

/// A tree of one node is walked without a stack, visiting its leaves in
/// the general walks' order, ties included: the same primitives are tested
/// in the same order, so the same hit is kept (closest and any hit).
#[test]
fn a_one_node_tree_is_walked_in_the_general_order() {
    let mut rng = Rng::new(8);
    let mut one_node = 0;
    for n in 1..=8 {
        let mut prims = random_prims(&mut rng, n);
        // Copies: boxes entered at the same distance.
        if n > 3 {
            prims[1] = prims[0];
            prims[3] = prims[2];
        }
        let bounds: Vec<Bounds3f> = prims.iter().map(Prim::bounds).collect();
        let (bvh, order) = Bvh::build(&bounds, 1);
        if bvh.nodes.len() != 1 {
            continue;
        }
        one_node += 1;
        let ordered: Vec<Prim> = order.iter().map(|&i| prims[i as usize]).collect();
        for i in 0..2000 {
            let ray = random_ray(&mut rng, i);
            let mut walked = [Vec::new(), Vec::new()];
            let test = |seen: &mut Vec<usize>, k: usize, r: &Ray| {
                seen.push(k);
                ordered[k].hit(r)
            };
            let a = bvh.closest_one_node(&ray, |p, r| {
                closest_in_leaf(p, r, |k, r| test(&mut walked[0], k, r))
            });
            let b = bvh.closest::<_, WIDE_STACK_SIZE, _>(Inline::default(), &ray, |p, r| {
                closest_in_leaf(p, r, |k, r| test(&mut walked[1], k, r))
            });
            assert_eq!(a, b, "ray {i}");
            assert_eq!(walked[0], walked[1], "ray {i}, {n} primitives");
            // Any hit: the same leaves in the same order, up to the first hit.
            let mut walked = [Vec::new(), Vec::new()];
            let test = |seen: &mut Vec<usize>, k: usize, r: &Ray| {
                seen.push(k);
                ordered[k].hit(r).is_some()
            };
            let a =
                bvh.any_one_node(&ray, |p, r| any_in_leaf(p, r, |k, r| test(&mut walked[0], k, r)));
            let b = bvh.any(Inline::default(), &ray, |p, r| {
                any_in_leaf(p, r, |k, r| test(&mut walked[1], k, r))
            });
            assert_eq!(a, b, "ray {i}");
            assert_eq!(walked[0], walked[1], "ray {i}, {n} primitives, any hit");
        }
    }
    assert!(one_node >= 6, "{one_node} trees of one node");
}

/// No closest-hit walk holds more stack entries than `stack_need` says, on
/// random trees of several sizes and leaf sizes, and on boxes that a ray
/// through their middle hits all of (peaks of 38 entries against a bound
/// of 48). A stack smaller than its tree needs would panic, not
/// overwrite: this checks that trees are given a large enough one.
#[test]
fn the_stack_bound_holds() {
    let mut rng = Rng::new(12);
    let mut most = 0;
    let cases = [(9, 1), (60, 1), (500, 4), (3000, 1), (20_000, 1), (20_000, 8)];
    for (case, (n, max_prims)) in cases.into_iter().chain([(3000, 1), (400, 1)]).enumerate() {
        let mut prims = random_prims(&mut rng, n);
        if case >= cases.len() {
            // Large boxes about the origin, overlapping: a ray through the
            // middle hits every child of every node on its way.
            for p in &mut prims {
                let (c, h) = (v(&mut rng, 0.5), Vec3::splat(4.0 + 4.0 * rng.uniform_f32()));
                *p = Prim::Box(Bounds3f::new(c - h, c + h));
            }
        }
        let bounds: Vec<Bounds3f> = prims.iter().map(Prim::bounds).collect();
        let (bvh, order) = Bvh::build(&bounds, max_prims);
        let ordered: Vec<Prim> = order.iter().map(|&i| prims[i as usize]).collect();
        let need = stack_need(&bvh.nodes, 0);
        for i in 0..3000 {
            let mut ray = random_ray(&mut rng, i);
            if case >= cases.len() {
                // Through the middle of the boxes.
                ray.d = -ray.o;
            }
            STACK_PEAK.with(|p| p.set(0));
            bvh.closest::<_, WIDE_STACK_SIZE, _>(Inline::default(), &ray, |p, r| {
                closest_in_leaf(p, r, |k, r| ordered[k].hit(r))
            });
            let peak = STACK_PEAK.with(|p| p.get());
            assert!(peak <= need, "{n} primitives: {peak} entries, bound {need}");
            most = most.max(peak);
        }
    }
    // The walks did use the stack.
    assert!(most > 20, "at most {most} entries");
}
