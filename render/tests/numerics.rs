//! Stiff and extreme cases for ray–shape intersection (issue 4): watertight
//! meshes hit at shared edges and vertices, grazing and in-plane rays,
//! degenerate and needle triangles, and spheres where a naive quadratic
//! loses all precision. Transforms, quaternions and intervals are in
//! `numerics_motion.rs`.

use farm_common::geometry::{DVec3, Mat4, Ray, Transform, Vec3};
use farm_common::math;
use farm_common::rng::Rng;
use farm_common::scene::{FileLoc, Param, ParamSet, ParamValue, Params, Warning};
use farm_render::primitive::{Aggregate, Primitive};
use farm_render::shapes::{self, Shape};

fn set(ps: Vec<(&str, ParamValue)>) -> ParamSet {
    let mut s = ParamSet::default();
    for (name, value) in ps {
        s.add(Param { name: name.into(), value, loc: FileLoc::default() });
    }
    s
}

fn make(name: &str, ps: Vec<(&str, ParamValue)>, t: &Transform) -> (Vec<Shape>, Vec<Warning>) {
    let s = set(ps);
    let mut w = vec![];
    let out = shapes::create(name, &Params::new(&s), t, false, &mut w);
    (out, w)
}

fn mesh(p: &[[f32; 3]], idx: &[i32], t: &Transform) -> Vec<Shape> {
    let (out, w) = make(
        "trianglemesh",
        vec![("P", ParamValue::Point3(p.to_vec())), ("indices", ParamValue::Int(idx.to_vec()))],
        t,
    );
    assert!(w.is_empty(), "{w:?}");
    out
}

fn unit(rng: &mut Rng) -> Vec3 {
    loop {
        let v = Vec3::new(rng.uniform_f32(), rng.uniform_f32(), rng.uniform_f32()) * 2.0 - 1.0;
        let l = v.length_squared();
        if l > 1e-4 && l <= 1.0 {
            return v / l.sqrt();
        }
    }
}

fn render_points(shapes: &[Shape]) -> Vec<Vec3> {
    match shapes.first() {
        Some(Shape::Triangle { mesh, .. }) => mesh.p.clone(),
        _ => panic!("not a mesh"),
    }
}

/// A closed, star-shaped latitude–longitude mesh with jittered radii around
/// the origin: poles 0 and 1, then `rings × segs` vertices.
fn closed_mesh(rng: &mut Rng, rings: usize, segs: usize) -> (Vec<[f32; 3]>, Vec<i32>) {
    let mut p = vec![[0.0, 0.0, 1.1], [0.0, 0.0, -0.93]];
    for i in 0..rings {
        let theta = std::f32::consts::PI * (i as f32 + 1.0) / (rings as f32 + 1.0);
        for j in 0..segs {
            let phi = 2.0 * std::f32::consts::PI * j as f32 / segs as f32;
            let r = 0.8 + 0.4 * rng.uniform_f32();
            p.push([
                r * math::sin(theta) * math::cos(phi),
                r * math::sin(theta) * math::sin(phi),
                r * math::cos(theta),
            ]);
        }
    }
    let v = |i: usize, j: usize| (2 + i * segs + j % segs) as i32;
    let mut idx = vec![];
    for j in 0..segs {
        idx.extend([0, v(0, j), v(0, j + 1)]);
        idx.extend([1, v(rings - 1, j + 1), v(rings - 1, j)]);
        for i in 0..rings - 1 {
            idx.extend([v(i, j), v(i + 1, j), v(i + 1, j + 1)]);
            idx.extend([v(i, j), v(i + 1, j + 1), v(i, j + 1)]);
        }
    }
    (p, idx)
}

/// Rays aimed exactly at the vertices and shared edges of a closed mesh,
/// from inside and from outside through to inside, never slip through: a
/// million of them, each tested with both `intersect` and `intersect_p`
/// through the BVH, under a rotating, scaling, translating transform.
#[test]
fn closed_mesh_is_watertight_at_shared_edges_and_vertices() {
    let mut rng = Rng::new(4);
    let (p, idx) = closed_mesh(&mut rng, 23, 41);
    let xf = Transform::new(
        Mat4::from_translation(Vec3::new(13.7, -4.1, 250.3))
            * Mat4::from_axis_angle(Vec3::new(0.3, -0.8, 0.5).normalize(), 0.917)
            * Mat4::from_scale(Vec3::new(3.3, 2.9, 4.7)),
    );
    let shapes = mesh(&p, &idx, &xf);
    let rp = render_points(&shapes);
    let center = xf.point(Vec3::ZERO);
    let mut edges: Vec<(usize, usize)> = idx
        .chunks(3)
        .flat_map(|t| {
            let t = [t[0] as usize, t[1] as usize, t[2] as usize];
            [(t[0], t[1]), (t[1], t[2]), (t[2], t[0])]
        })
        .map(|(a, b)| (a.min(b), a.max(b)))
        .collect();
    edges.sort_unstable();
    edges.dedup();
    assert_eq!(edges.len() * 2, idx.len(), "every edge is shared by two triangles");
    let agg = Aggregate::new(
        shapes
            .into_iter()
            .map(|shape| Primitive { shape, material: None.into(), area_light: None.into() })
            .collect(),
        farm_render::accel::DEFAULT_MAX_PRIMS_IN_NODE,
    );
    let (mut rays, mut missed, mut leaked) = (0u64, 0u64, 0u64);
    let mut check = |o: Vec3, target: Vec3, inner: Option<Vec3>| {
        let ray = Ray::new(o, target - o, 0.0);
        rays += 1;
        let hit = agg.closest(&ray);
        if hit.is_none() || !agg.intersect_p(&ray) {
            missed += 1;
            return;
        }
        let (t, _) = hit.unwrap();
        // From outside, the first crossing comes before the inner point.
        if let Some(inner) = inner {
            if t > (inner - o).length() / (target - o).length() {
                leaked += 1;
            }
        }
    };
    let targets_per_vertex = 400;
    let targets_per_edge = 220;
    for &v in &rp {
        for n in 0..targets_per_vertex {
            let inner = center + 0.4 * rng.uniform_f32() * unit(&mut rng);
            if n % 2 == 0 {
                check(if n % 4 == 0 { center } else { inner }, v, None);
            } else {
                let o = v + (v - inner) * (0.5 + 2.0 * rng.uniform_f32());
                check(o, v, Some(inner));
            }
        }
    }
    for &(a, b) in &edges {
        for n in 0..targets_per_edge {
            let u = rng.uniform_f32();
            // Points on the edge as f32 computes them, and its midpoint.
            let target = if n == 0 { (rp[a] + rp[b]) * 0.5 } else { rp[a] + u * (rp[b] - rp[a]) };
            let inner = center + 0.4 * rng.uniform_f32() * unit(&mut rng);
            if n % 2 == 0 {
                check(inner, target, None);
            } else {
                let o = target + (target - inner) * (0.5 + 2.0 * rng.uniform_f32());
                check(o, target, Some(inner));
            }
        }
    }
    assert_eq!((missed, leaked), (0, 0), "of {rays} rays");
    assert!(rays > 1_000_000, "{rays}");
}

fn tri_hit_f64(p: [DVec3; 3], o: DVec3, d: DVec3) -> Option<(f64, [f64; 3])> {
    // Möller–Trumbore in double precision as the reference.
    let (e1, e2) = (p[1] - p[0], p[2] - p[0]);
    let h = d.cross(e2);
    let a = e1.dot(h);
    if a == 0.0 {
        return None;
    }
    let s = o - p[0];
    let u = s.dot(h) / a;
    let q = s.cross(e1);
    let v = d.dot(q) / a;
    let t = e2.dot(q) / a;
    Some((t, [1.0 - u - v, u, v]))
}

/// Needle triangles (aspect ratio up to 1e5), hit by rays at angles down
/// to 1e-4 radians from their plane: hits and misses agree with a
/// double-precision reference away from the edges (hits closer than
/// pbrt-v3's conservative t bound may be refused), and every hit point lies
/// on the triangle's plane to within its error bound (what spawned rays
/// rely on), near the exact intersection.
#[test]
fn needle_triangles_and_grazing_rays_match_double_precision() {
    let mut rng = Rng::new(9);
    let mut hits = 0;
    let mut rays = 0;
    for &(width, graze) in
        &[(1e-2f32, 1e-1f32), (1e-3, 1e-2), (1e-4, 1e-1), (1e-2, 1e-3), (0.5, 1e-4), (1e-5, 1.0)]
    {
        for _ in 0..20000 {
            let xf = Transform::new(
                Mat4::from_translation(Vec3::new(5.0, -2.0, 30.0) * rng.uniform_f32())
                    * Mat4::from_axis_angle(unit(&mut rng), 6.0 * rng.uniform_f32()),
            );
            let p = [[0.0, 0.0, 0.0], [1.0, 0.0, 0.0], [0.3 + 0.4 * rng.uniform_f32(), width, 0.0]];
            let shapes = mesh(&p, &[0, 1, 2], &xf);
            let rp = render_points(&shapes);
            let tri = shapes[0].triangle().expect("a triangle");
            // Aim at a random point of the triangle's neighbourhood.
            let b = [rng.uniform_f32() * 1.2 - 0.1, rng.uniform_f32() * 1.2 - 0.1];
            let target = rp[0] + b[0] * (rp[1] - rp[0]) + b[1] * (rp[2] - rp[0]);
            let n = (rp[1] - rp[0]).cross(rp[2] - rp[0]).normalize();
            let (tx, ty) = farm_common::geometry::coordinate_system(n);
            let phi = std::f32::consts::TAU * rng.uniform_f32();
            let elev = graze * (0.5 + rng.uniform_f32());
            let along = tx * math::cos(phi) + ty * math::sin(phi);
            let dir = (along * math::cos(elev) + n * math::sin(elev)).normalize();
            let o = target + dir * (0.5 + 2.0 * rng.uniform_f32());
            let ray = Ray::new(o, -dir, 0.0);
            let rd = [rp[0].as_dvec3(), rp[1].as_dvec3(), rp[2].as_dvec3()];
            let reference = tri_hit_f64(rd, o.as_dvec3(), ray.d.as_dvec3());
            let got = tri.intersect_with(&ray, true);
            assert_eq!(got.is_some(), shapes[0].intersect_p(&ray));
            rays += 1;
            let Some((t_ref, bary)) = reference else { continue };
            // Skip rays within rounding distance of an edge (a few ulps of the
            // vertices relative to the ray origin, over the needle's width as
            // the ray sees it): either answer is right.
            let scale = rd.iter().map(|v| (*v - o.as_dvec3()).length()).fold(0.0, f64::max);
            let margin = 5e-7 * scale / (width as f64 * graze as f64);
            let inside = bary.iter().all(|&x| x > margin);
            let outside = bary.iter().any(|&x| x < -margin);
            // pbrt-v3 accepts a hit only when t exceeds a conservative bound on
            // its error, ~γ₅·|p−o|²/|det| with det the triangle's area
            // projected along the ray: close grazing hits on needles can be
            // refused (never wrongly accepted). A clear hit must be found
            // when it is well beyond that bound.
            let det = (rd[1] - rd[0]).cross(rd[2] - rd[0]).dot(ray.d.as_dvec3().normalize());
            let t_bound = 12.0 * 3.0e-7 * scale * scale / det.abs();
            if inside && (got.is_some() || t_ref * ray.d.as_dvec3().length() > 4.0 * t_bound) {
                let Some((t, si)) = got else {
                    panic!("missed a clear hit: {width} {graze} {bary:?} margin {margin}")
                };
                hits += 1;
                assert!(t.is_finite() && si.p().is_finite() && si.n().is_finite());
                let exact = o.as_dvec3() + ray.d.as_dvec3() * t_ref;
                let nd = (rd[1] - rd[0]).cross(rd[2] - rd[0]).normalize();
                let off_plane = nd.dot(si.p().as_dvec3() - rd[0]).abs();
                let bound = nd.abs().dot(si.it.p_error.as_dvec3());
                assert!(off_plane <= bound, "off the plane by {off_plane} > {bound}");
                let along = (si.p().as_dvec3() - exact).length();
                // Barycentrics are known to about `margin`, times the edge length.
                let edge = (rd[1] - rd[0]).length().max((rd[2] - rd[0]).length());
                let tol = 2.0 * margin * edge + 1e-6 * scale / graze as f64;
                assert!(along <= tol, "{along} from the exact hit");
                let dt = (t as f64 - t_ref).abs() * ray.d.as_dvec3().length();
                assert!(dt <= tol, "t {t} vs {t_ref}");
            } else if outside {
                assert!(got.is_none(), "hit outside: bary {bary:?}");
            }
        }
    }
    assert!(hits * 10 > rays, "{hits} of {rays}");
}

/// Rays in a triangle's plane, along its edges and parallel to it never
/// hit it; zero-area triangles (collinear or coincident vertices) are never
/// hit by any ray; nothing produces NaN.
#[test]
fn in_plane_parallel_and_degenerate_triangles_are_never_hit() {
    let mut rng = Rng::new(21);
    let id = Transform::default();
    let tri = mesh(&[[0.0, 0.0, 0.0], [1.0, 0.0, 0.0], [0.2, 0.7, 0.0]], &[0, 1, 2], &id);
    let degenerate = [
        mesh(&[[0.0, 0.0, 0.0], [1.0, 1.0, 0.0], [0.5, 0.5, 0.0]], &[0, 1, 2], &id),
        mesh(&[[0.3, 0.1, 0.2]; 3], &[0, 1, 2], &id),
        mesh(&[[0.0, 0.0, 0.0], [2.0, 0.0, 1.0], [1.0, 0.0, 0.5]], &[0, 1, 2], &id),
    ];
    for _ in 0..100_000 {
        // Through the interior, within the plane z = 0.
        let target = Vec3::new(0.2 + 0.3 * rng.uniform_f32(), 0.1 + 0.2 * rng.uniform_f32(), 0.0);
        let phi = std::f32::consts::TAU * rng.uniform_f32();
        let d = Vec3::new(math::cos(phi), math::sin(phi), 0.0);
        let in_plane = Ray::new(target - 2.0 * d, d, 0.0);
        assert!(tri[0].intersect(&in_plane).is_none() && !tri[0].intersect_p(&in_plane));
        // Parallel to the plane just above it, and along the edges.
        let above = Ray::new(target - 2.0 * d + Vec3::new(0.0, 0.0, 1e-6), d, 0.0);
        assert!(tri[0].intersect(&above).is_none());
        let along_edge = Ray::new(Vec3::new(-1.0, 0.0, 0.0), Vec3::X, 0.0);
        assert!(tri[0].intersect(&along_edge).is_none());
        let e = Vec3::new(0.2, 0.7, 0.0);
        let along_edge2 = Ray::new(-e, e, 0.0);
        assert!(tri[0].intersect(&along_edge2).is_none());
        // Any ray at all toward a degenerate triangle.
        for deg in &degenerate {
            let o = 3.0 * unit(&mut rng);
            let aim = deg[0].bounds().centroid() + 0.1 * unit(&mut rng);
            let r = Ray::new(o, aim - o, 0.0);
            assert!(deg[0].intersect(&r).is_none() && !deg[0].intersect_p(&r));
            let b = deg[0].bounds();
            assert!(b.min.is_finite() && b.max.is_finite());
        }
    }
}

/// Non-finite vertex positions, normals, tangents or uvs are rejected with a
/// warning that says what was dropped; every shape that is kept has finite
/// bounds and never returns a non-finite hit.
#[test]
fn non_finite_mesh_data_is_rejected_with_a_warning() {
    let id = Transform::default();
    let p =
        vec![[0.0, 0.0, 0.0], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [1.0, 1.0, 0.0], [2.0, 2.0, 0.0]];
    let idx = ParamValue::Int(vec![0, 1, 2, 1, 3, 2, 2, 3, 4]);
    for bad in [f32::NAN, f32::INFINITY, f32::NEG_INFINITY] {
        // Positions: the triangles touching vertex 4 go.
        let mut pb = p.clone();
        pb[4][1] = bad;
        let (out, w) = make(
            "trianglemesh",
            vec![("P", ParamValue::Point3(pb)), ("indices", idx.clone())],
            &id,
        );
        assert_eq!(out.len(), 2);
        assert!(w.iter().any(|w| w.message.contains("skipped 1 of 3 triangles")), "{w:?}");
        // Normals, tangents and uvs: the attribute goes, the triangles stay.
        let mut nb = vec![[0.0, 0.0, 1.0]; 5];
        nb[3][0] = bad;
        let mut uvb = vec![[0.0, 0.0]; 5];
        uvb[2][1] = bad;
        for (name, v) in [
            ("N", ParamValue::Normal(nb.clone())),
            ("S", ParamValue::Vector3(nb.clone())),
            ("uv", ParamValue::Point2(uvb)),
        ] {
            let (out, w) = make(
                "trianglemesh",
                vec![("P", ParamValue::Point3(p.clone())), ("indices", idx.clone()), (name, v)],
                &id,
            );
            assert_eq!(out.len(), 3, "{name}");
            assert!(w.iter().any(|w| w.message.contains(&format!("\"{name}\""))), "{name}: {w:?}");
            let mut rng = Rng::new(5);
            for _ in 0..2000 {
                let aim = Vec3::new(2.0 * rng.uniform_f32(), 2.0 * rng.uniform_f32(), 0.0);
                let o = aim + Vec3::new(0.1, -0.2, 1.0);
                let r = Ray::new(o, aim - o, 0.0);
                for s in &out {
                    if let Some((t, si)) = s.intersect(&r) {
                        assert!(t.is_finite() && si.p().is_finite(), "{name}");
                        assert!(si.shading.n.is_finite() && si.uv.is_finite(), "{name}");
                        assert!(si.shading.dpdu.is_finite(), "{name}");
                    }
                }
            }
        }
    }
}

fn sphere(radius: f32, xf: &Transform) -> Shape {
    let (mut out, w) = make("sphere", vec![("radius", ParamValue::Float(vec![radius]))], xf);
    assert!(w.is_empty(), "{w:?}");
    out.remove(0)
}

/// Double-precision entry and exit distances of a ray through a sphere,
/// computed in the well-conditioned form (distance from the centre to the
/// ray's closest point).
fn sphere_f64(center: DVec3, radius: f64, o: DVec3, d: DVec3) -> Option<(f64, f64)> {
    let d = d.normalize();
    let tc = (center - o).dot(d);
    let closest = o + d * tc - center;
    let h2 = radius * radius - closest.length_squared();
    (h2 >= 0.0).then(|| (tc - h2.sqrt(), tc + h2.sqrt()))
}

/// Rays from up to 1e5 radii away, where `b² − 4ac` in single precision is
/// pure rounding noise, still hit where the exact sphere is: t agrees with
/// the double-precision distance and the hit point lies on the surface.
#[test]
fn distant_rays_hit_spheres_where_the_naive_quadratic_fails() {
    let mut rng = Rng::new(12);
    let mut hits = 0;
    for &(radius, dist, center) in &[
        (1.0f32, 1e3f32, Vec3::ZERO),
        (1.0, 1e4, Vec3::ZERO),
        (1e-4, 1e1, Vec3::new(0.1, 0.2, -0.3)),
        (2.0, 2e5, Vec3::new(5.0, 0.0, 0.0)),
        (1e5, 1e7, Vec3::ZERO),
    ] {
        let xf = Transform::new(Mat4::from_translation(center));
        let s = sphere(radius, &xf);
        for _ in 0..20000 {
            let w = unit(&mut rng);
            let o = center + w * dist;
            // Aim inside the sphere's silhouette, well away from tangency.
            let (tx, ty) = farm_common::geometry::coordinate_system(w);
            let a = std::f32::consts::TAU * rng.uniform_f32();
            let r = 0.9 * radius * rng.uniform_f32().sqrt();
            let aim = center + r * (math::cos(a) * tx + math::sin(a) * ty);
            let ray = Ray::new(o, aim - o, 0.0);
            let (t0, _) =
                sphere_f64(center.as_dvec3(), radius as f64, o.as_dvec3(), ray.d.as_dvec3())
                    .expect("aimed inside");
            let (t, si) = s.intersect(&ray).expect("missed a distant sphere");
            assert!(s.intersect_p(&ray));
            hits += 1;
            let len = ray.d.as_dvec3().length();
            // The exact hit is known up to rounding of o and d (f32 at `dist`).
            // pbrt-v3 moves the object-space origin forward by its error
            // bound (≤ √3·γ₃·|o|), which t then excludes; the naive f32
            // quadratic is off by up to the radius (3e-5 of the distance at
            // 1e3 radii, 1e-4 at 1e4).
            let tol = 6e-7 * dist as f64 + 1e-6 * radius as f64;
            assert!((t as f64 * len - t0).abs() <= tol, "t {} vs {t0}", t as f64 * len);
            let p = si.p().as_dvec3();
            assert!(p.is_finite() && si.n().is_finite());
            let off = ((p - center.as_dvec3()).length() - radius as f64).abs();
            assert!(off <= 1e-5 * radius as f64 + 1e-6 * center.length() as f64, "{off}");
            assert!(
                (si.n().as_dvec3().dot((p - center.as_dvec3()).normalize()) - 1.0).abs() < 1e-4
            );
        }
    }
    assert_eq!(hits, 100_000);
}

/// Rays spawned on the surface of tiny, huge and far-away spheres: outward
/// rays never re-hit the sphere they leave, inward rays hit the far side at
/// the chord length; tangent rays just outside miss, just inside hit, and
/// exactly tangent ones return either answer but never a non-finite hit.
#[test]
fn rays_from_the_surface_and_tangent_rays() {
    let mut rng = Rng::new(33);
    for &(radius, center) in &[
        (1.0f32, Vec3::ZERO),
        (1e-4, Vec3::new(1e-3, 0.0, 0.0)),
        (1e5, Vec3::new(0.0, -1e5, 0.0)),
        (10.0, Vec3::new(3e3, 1e3, -2e3)),
    ] {
        let xf = Transform::new(Mat4::from_translation(center));
        let s = sphere(radius, &xf);
        for _ in 0..20000 {
            let w = unit(&mut rng);
            let o = center + w * radius * 3.0;
            let ray = Ray::new(o, center + 0.5 * radius * unit(&mut rng) - o, 0.0);
            let Some((_, si)) = s.intersect(&ray) else { panic!("missed") };
            let n = si.it.n;
            let mut d = unit(&mut rng);
            if d.dot(n) < 0.0 {
                d = -d;
            }
            if d.dot(n) > 1e-3 {
                let out = si.it.spawn_ray(d);
                assert!(!s.intersect_p(&out), "outward ray re-hit r={radius}");
                let inward = si.it.spawn_ray(-d);
                let (t, far) = s.intersect(&inward).expect("inward ray missed the far side");
                // The exit of the exact sphere along the spawned ray.
                let (_, chord) = sphere_f64(
                    center.as_dvec3(),
                    radius as f64,
                    inward.o.as_dvec3(),
                    inward.d.as_dvec3(),
                )
                .expect("the spawned ray starts inside");
                let got = (t * inward.d.length()) as f64;
                // pbrt-v3 moves the object-space origin forward by its error
                // bound, which rounds it by up to an ulp sideways; a short
                // chord (length c) changes by 4r·δ/c for a sideways shift δ.
                let m = inward.o.abs().max_element().max(center.abs().max_element()).max(radius);
                let ulp = 1.2e-7 * m as f64;
                let tol = 1e-5 * chord + 4.0 * radius as f64 * ulp / chord + 8.0 * ulp;
                assert!((got - chord).abs() <= tol, "chord {got} vs {chord}");
                assert!(far.p().is_finite());
            }
            // Tangent rays through the point at distance `radius·(1 ± ε)` from the centre.
            let side = unit(&mut rng).cross(w).normalize();
            for (k, expect) in [(1.0 + 1e-3, Some(false)), (1.0 - 1e-3, Some(true)), (1.0, None)] {
                let p = center + w * radius * k;
                let r = Ray::new(p - side * radius * 4.0, side, 0.0);
                let hit = s.intersect(&r);
                if let Some(expect) = expect {
                    assert_eq!(hit.is_some(), expect, "r={radius} k={k}");
                    assert_eq!(s.intersect_p(&r), expect);
                }
                if let Some((t, si)) = hit {
                    assert!(t.is_finite() && si.p().is_finite() && si.n().is_finite());
                }
            }
        }
    }
}
