use super::*;
use crate::primitive::Primitive;
use crate::shapes::{Triangle, TriangleMesh};
use farm_common::geometry::{Ray, Vec3};
use farm_common::math;
use farm_common::rng::Rng;
use std::cell::Cell;
use std::sync::Arc;

thread_local! {
    /// Makes [`test`] decline every leaf, so that the aggregate's scalar
    /// loop can be compared with its four lanes (tests only).
    pub(super) static SCALAR_ONLY: Cell<bool> = const { Cell::new(false) };
}

/// Triangles `tris` (vertex triples) as one mesh's primitives.
fn prims(tris: &[[Vec3; 3]]) -> (Arc<TriangleMesh>, Vec<Primitive>) {
    let mesh = Arc::new(TriangleMesh {
        p: tris.iter().flatten().copied().collect(),
        ..TriangleMesh::default()
    });
    let prims = (0..tris.len() as u32)
        .map(|i| Primitive {
            shape: Shape::Triangle { mesh: mesh.clone(), v: [3 * i, 3 * i + 1, 3 * i + 2] },
            material: None.into(),
            area_light: None.into(),
        })
        .collect();
    (mesh, prims)
}

/// Checks every lane of the four-lane test against the scalar test, bit
/// for bit, the ray shortened lane by lane as the closest-hit walk does;
/// returns whether the four-lane test took the leaf.
fn agrees(tris: &[[Vec3; 3]], ray: &Ray) -> bool {
    let (mesh, prims) = prims(tris);
    let tr = TriRay::new(ray);
    let Some(q) = test(&prims, ray, &tr, false) else { return false };
    let any = test(&prims, ray, &tr, true).expect("no masks");
    assert_eq!(any.mask, q.mask, "the shadow test's lanes are the closest test's");
    let mut shortened = *ray;
    let mut scalar_hits = Vec::new();
    for k in 0..tris.len() {
        let tri = Triangle { mesh: &mesh, v: [3 * k as u32, 3 * k as u32 + 1, 3 * k as u32 + 2] };
        // Unshortened: the lane mask is the scalar test at the ray's t_max.
        let whole = tri.hit_barycentrics_prepared(ray, &tr, false);
        assert_eq!(whole.is_some(), q.mask & 1 << k != 0, "lane {k}: {tris:?} {ray:?}");
        let scalar = tri.hit_barycentrics_prepared(&shortened, &tr, false);
        let lane = (q.mask & 1 << k != 0 && q.within(k, shortened.t_max))
            .then(|| (q.t[k], q.barycentrics(k)));
        // A NaN's payload is left unspecified by Rust: NaN counts as NaN.
        let canon = |x: f32| if x.is_nan() { u32::MAX } else { x.to_bits() };
        let bits = |h: Option<(f32, [f32; 3])>| h.map(|(t, b)| (canon(t), b.map(canon)));
        assert_eq!(bits(lane), bits(scalar), "lane {k}: {tris:?} {ray:?}");
        if let Some((t, _)) = scalar {
            scalar_hits.push(k);
            shortened.t_max = shortened.t_max.min(t);
        }
    }
    // The leaf's loop: the same hits, in order, and the same end.
    let (mut by_lanes, mut lane_hits) = (*ray, Vec::new());
    assert_eq!(q.accept(&mut by_lanes, |k| lane_hits.push(k)), !scalar_hits.is_empty());
    assert_eq!(lane_hits, scalar_hits);
    assert_eq!(by_lanes.t_max.to_bits(), shortened.t_max.to_bits());
    true
}

fn v3(rng: &mut Rng, lo: f32, hi: f32) -> Vec3 {
    let mut u = || lo + (hi - lo) * rng.uniform_f32();
    Vec3::new(u(), u(), u())
}

/// Random leaves of three or four nearby triangles, and rays aimed at them,
/// at random and along the axes, at several scales: every lane agrees.
#[test]
fn lanes_have_the_scalar_tests_bits() {
    let mut rng = Rng::new(17);
    let (mut taken, mut hits) = (0, 0);
    for case in 0..20_000 {
        let scale = [1.0f32, 1e-6, 1e6, 3e-20, 1e18][case % 5];
        let n = 3 + case % 2;
        let centre = v3(&mut rng, -1.0, 1.0) * scale;
        let tris: Vec<[Vec3; 3]> = (0..n)
            .map(|_| {
                let c = centre + v3(&mut rng, -0.5, 0.5) * scale;
                [0, 1, 2].map(|_| c + v3(&mut rng, -0.3, 0.3) * scale)
            })
            .collect();
        let target = tris[case % n][0] * 0.4 + tris[case % n][1] * 0.3 + tris[case % n][2] * 0.3;
        // Every third ray leaves a point of the leaf's next triangle, a
        // hair off its surface, as a shadow ray does: hits so near that
        // the test's bound on t decides them.
        let o = if case % 3 == 0 {
            let [a, b, c] = tris[(case + 1) % n];
            let (u, w) = (rng.uniform_f32() * 0.5, rng.uniform_f32() * 0.5);
            let off = (b - a).cross(c - a).normalize_or_zero() * 1e-6 * rng.uniform_f32();
            a + u * (b - a) + w * (c - a) + off * scale
        } else {
            v3(&mut rng, -3.0, 3.0) * scale
        };
        let d = match case % 4 {
            0 => v3(&mut rng, -1.0, 1.0),
            1 => Vec3::X * if rng.uniform_f32() < 0.5 { 1.0 } else { -1.0 },
            _ => target - o + v3(&mut rng, -0.05, 0.05) * scale,
        };
        let t_max = if case % 7 == 0 { rng.uniform_f32() * 2.0 } else { f32::INFINITY };
        let mut ray = Ray::new(o, d, 0.0);
        ray.t_max = t_max;
        if agrees(&tris, &ray) {
            taken += 1;
            let (_, p) = prims(&tris);
            hits += (test(&p, &ray, &TriRay::new(&ray), false).unwrap().mask != 0) as usize;
        }
    }
    // The scalar fallback is for exact zeros, which random floats rarely give.
    assert!(taken > 19_000, "{taken} leaves taken");
    assert!(hits > 3_000, "{hits} leaves hit");
}

/// Grazing rays in a triangle's plane, rays through shared edges and
/// vertices, and degenerate, infinite and NaN triangles: every lane agrees
/// or the leaf goes to the scalar test, which redoes exact zeros in double
/// precision.
#[test]
fn edge_cases_agree_or_fall_back() {
    let (a, b, c, d) = (
        Vec3::new(0.0, 0.0, 0.0),
        Vec3::new(1.0, 0.0, 0.0),
        Vec3::new(0.0, 1.0, 0.0),
        Vec3::new(1.0, 1.0, 0.0),
    );
    let e = Vec3::new(2.0, 0.0, 0.0);
    let quad = [[a, b, c], [b, d, c], [b, e, d]];
    // Through the shared edge's midpoint and through a shared vertex: an
    // edge function is exactly zero, so the leaf is the scalar test's.
    for target in [Vec3::new(0.5, 0.5, 0.0), b] {
        let ray = Ray::new(target + Vec3::Z, -Vec3::Z, 0.0);
        assert!(!agrees(&quad, &ray), "an exact zero is redone in double precision");
    }
    // Off the edge: both lanes decided here, one hit.
    let ray = Ray::new(Vec3::new(0.3, 0.2, 1.0), Vec3::new(0.01, 0.02, -1.0), 0.0);
    assert!(agrees(&quad, &ray));
    let (_, p) = prims(&quad);
    assert_eq!(test(&p, &ray, &TriRay::new(&ray), false).unwrap().mask, 0b001);
    // In the plane, grazing: every sheared y is zero, and so is every edge
    // function.
    let graze = Ray::new(Vec3::new(-1.0, 0.25, 0.0), Vec3::new(1.0, 0.1, 0.0), 0.0);
    assert!(!agrees(&quad, &graze));
    // Two equal vertices: an edge function of exactly zero whatever the ray.
    let down = Ray::new(Vec3::new(0.2, 0.2, 1.0), Vec3::new(0.01, 0.02, -1.0), 0.0);
    assert!(!agrees(&[[a, a, b], [b, d, c], quad[2]], &down));
    let inf = f32::INFINITY;
    let mut taken = 0;
    let odd = [
        [a, b, Vec3::new(2.0, 0.0, 0.0)],
        [a, b, Vec3::new(0.0, inf, 0.0)],
        [a, Vec3::new(f32::NAN, 0.0, 0.0), c],
        [Vec3::splat(3e38), Vec3::new(-3e38, 3e38, 1.0), Vec3::new(3e38, -3e38, -1.0)],
    ];
    for t in odd {
        for ray in [
            Ray::new(Vec3::new(0.2, 0.2, 1.0), Vec3::new(0.01, 0.02, -1.0), 0.0),
            Ray::new(Vec3::new(0.2, 0.2, -1.0), Vec3::new(0.0, 0.0, 1.0), 0.0),
        ] {
            taken += agrees(&[t, [b, d, c], quad[2]], &ray) as usize;
            taken += agrees(&[[b, d, c], t, quad[0], quad[2]], &ray) as usize;
        }
    }
    // Infinite, NaN and collinear lanes beside ordinary ones were decided
    // by the four lanes, not all handed to the scalar test.
    assert!(taken >= 8, "{taken} of 16 odd leaves taken");
}

/// Leaves the scalar test must decide: a shape that is not a triangle, a
/// mesh with an alpha mask (a shadow-only one for shadow rays alone), and
/// leaves of one or two triangles.
#[test]
fn declines_what_only_the_scalar_test_decides() {
    let tris = [
        [Vec3::ZERO, Vec3::X, Vec3::Y],
        [Vec3::X, Vec3::new(1.0, 1.0, 0.0), Vec3::Y],
        [Vec3::X, Vec3::new(2.0, 0.0, 0.0), Vec3::new(1.0, 1.0, 0.0)],
    ];
    let ray = Ray::new(Vec3::new(0.21, 0.33, 1.0), Vec3::new(0.013, 0.007, -1.0), 0.0);
    let tr = TriRay::new(&ray);
    let (_, p) = prims(&tris);
    assert!(test(&p, &ray, &tr, false).is_some());
    assert!(test(&p[..2], &ray, &tr, false).is_none());
    assert!(test(&p[..1], &ray, &tr, false).is_none());
    let masked = |alpha: AlphaMask, shadow_alpha: AlphaMask| {
        let mesh = Arc::new(TriangleMesh {
            p: tris.iter().flatten().copied().collect(),
            alpha,
            shadow_alpha,
            ..TriangleMesh::default()
        });
        (0..3u32)
            .map(|i| Primitive {
                shape: Shape::Triangle { mesh: mesh.clone(), v: [3 * i, 3 * i + 1, 3 * i + 2] },
                material: None.into(),
                area_light: None.into(),
            })
            .collect::<Vec<_>>()
    };
    let p = masked(AlphaMask::Zero, AlphaMask::None);
    assert!(test(&p, &ray, &tr, false).is_none() && test(&p, &ray, &tr, true).is_none());
    let p = masked(AlphaMask::None, AlphaMask::Zero);
    assert!(test(&p, &ray, &tr, false).is_some() && test(&p, &ray, &tr, true).is_none());
    // A leaf of two meshes, the second masked: each mesh is looked at.
    let mut p = masked(AlphaMask::None, AlphaMask::None);
    p[2] = masked(AlphaMask::Zero, AlphaMask::None).swap_remove(2);
    assert!(test(&p, &ray, &tr, false).is_none());
    let mut p = masked(AlphaMask::None, AlphaMask::None);
    let identity =
        crate::shapes::Placement::new(&farm_common::geometry::Transform::default(), false);
    p[1].shape = Shape::Disk(Box::new(crate::shapes::Disk::new(identity, 0.0, 1.0, 0.0, 360.0)));
    assert!(test(&p, &ray, &tr, false).is_none());
}

/// The aggregate's walks with four lanes give the hits of its scalar loop,
/// bit for bit: the primitive, the distance and the interaction, on a mesh
/// large enough to share leaves (camera rays and rays leaving its
/// surface, closest and any hit).
#[test]
fn the_aggregate_finds_the_scalar_loops_hits() {
    use crate::primitive::{Aggregate, SHARED_LEAVES_FROM};
    // A torus of 128 × 128 quads: 2¹⁵ triangles, which share leaves.
    let n = 128u32;
    let mut p = Vec::new();
    for i in 0..n {
        for j in 0..n {
            let (u, v) = (i as f32 / n as f32 * 6.2831855, j as f32 / n as f32 * 6.2831855);
            let r = 1.0 + 0.35 * math::cos(v);
            p.push(Vec3::new(r * math::cos(u), r * math::sin(u), 0.35 * math::sin(v)));
        }
    }
    let mesh = Arc::new(TriangleMesh { p, ..TriangleMesh::default() });
    let idx = |i: u32, j: u32| (i % n) * n + j % n;
    let mut prims = Vec::new();
    for i in 0..n {
        for j in 0..n {
            let (a, b, c, d) = (idx(i, j), idx(i + 1, j), idx(i + 1, j + 1), idx(i, j + 1));
            for v in [[a, b, c], [a, c, d]] {
                let shape = Shape::Triangle { mesh: mesh.clone(), v };
                prims.push(Primitive { shape, material: None.into(), area_light: None.into() });
            }
        }
    }
    assert!(prims.len() >= SHARED_LEAVES_FROM);
    let agg = Aggregate::new(prims, 4);
    let mut rng = Rng::new(5);
    let (mut hits, mut leaving) = (0, Vec::new());
    let check = |ray: &Ray| {
        let trace = |scalar: bool| {
            SCALAR_ONLY.set(scalar);
            let hit = agg.closest(ray).map(|(t, si)| {
                let bits = |v: Vec3| v.to_array().map(f32::to_bits);
                (t.to_bits(), si.prim, bits(si.it.p), bits(si.it.n))
            });
            let blocked = agg.intersect_p(ray);
            SCALAR_ONLY.set(false);
            (hit, blocked)
        };
        let lanes = trace(false);
        assert_eq!(lanes, trace(true), "{ray:?}");
        lanes
    };
    for _ in 0..4000 {
        let o = v3(&mut rng, -3.0, 3.0) + Vec3::new(0.0, 0.0, 4.0);
        let ray = Ray::new(o, v3(&mut rng, -1.3, 1.3) - o, 0.0);
        if let (Some((t, ..)), _) = check(&ray) {
            hits += 1;
            leaving.push(ray.at(f32::from_bits(t)));
        }
    }
    for (k, from) in leaving.iter().enumerate() {
        let mut ray = Ray::new(*from, v3(&mut rng, -1.0, 1.0), 0.0);
        ray.t_max = if k % 2 == 0 { f32::INFINITY } else { 0.5 };
        check(&ray);
    }
    assert!(hits > 1000, "{hits} camera rays hit");
}
