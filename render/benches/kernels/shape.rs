//! Ray–shape kernels: the watertight triangle test, the sphere and the
//! other quadrics.

use super::*;

/// `N` random triangles in one mesh (positions only), each paired with a
/// ray from a random direction aimed at a point of the triangle's
/// parallelogram: half of the rays hit.
fn triangles() -> (Vec<Shape>, Vec<Ray>) {
    let mut rng = Rng::new(1);
    let (mut p, mut rays) = (Vec::new(), Vec::new());
    for _ in 0..N {
        let p0 = v3(&mut rng, -1.0, 1.0);
        let (e1, e2) = (v3(&mut rng, -0.5, 0.5), v3(&mut rng, -0.5, 0.5));
        let u = u2(&mut rng);
        let target = p0 + u.x * e1 + u.y * e2;
        let o = target + 5.0 * uniform_sample_sphere(u2(&mut rng));
        rays.push(Ray::new(o, (target - o).normalize(), 0.0));
        p.extend([p0, p0 + e1, p0 + e2].map(|v| v.to_array()));
    }
    let indices = (0..3 * N as i32).collect();
    let tris = make_shapes(
        "trianglemesh",
        vec![("indices", ParamValue::Int(indices)), ("P", ParamValue::Point3(p))],
        &Transform::default(),
    );
    check_mixed("triangle", &tris.iter().zip(&rays).collect::<Vec<_>>(), |(t, r)| t.intersect_p(r));
    (tris, rays)
}

/// A full sphere of radius 1.5 placed by a translation, and rays from 6
/// units away aimed into a 4-unit cube around its centre.
fn sphere() -> (Shape, Vec<Ray>) {
    let c = Vec3::new(1.0, 2.0, 3.0);
    let xf = Transform::new(Mat4::from_translation(c));
    let s = make_shapes("sphere", vec![("radius", ParamValue::Float(vec![1.5]))], &xf);
    let mut rng = Rng::new(2);
    let rays: Vec<Ray> = (0..N)
        .map(|_| {
            let o = c + 6.0 * uniform_sample_sphere(u2(&mut rng));
            let target = c + v3(&mut rng, -2.0, 2.0);
            Ray::new(o, (target - o).normalize(), 0.0)
        })
        .collect();
    check_mixed("sphere", &rays, |r| s[0].intersect_p(r));
    (s[0].clone(), rays)
}

/// `Shape::intersect`: the hit test plus the surface interaction.
#[divan::bench]
fn triangle_intersect(bencher: Bencher) {
    let (tris, rays) = triangles();
    bencher.counter(ItemsCount::new(N)).bench_local(|| {
        for (t, r) in black_box(&tris).iter().zip(black_box(&rays)) {
            black_box(t.intersect(r));
        }
    });
}

/// `Shape::intersect_p`: the hit test alone (shadow rays).
#[divan::bench]
fn triangle_intersect_p(bencher: Bencher) {
    let (tris, rays) = triangles();
    bencher.counter(ItemsCount::new(N)).bench_local(|| {
        for (t, r) in black_box(&tris).iter().zip(black_box(&rays)) {
            black_box(t.intersect_p(r));
        }
    });
}

#[divan::bench]
fn sphere_intersect(bencher: Bencher) {
    let (s, rays) = sphere();
    bencher.counter(ItemsCount::new(N)).bench_local(|| {
        for r in black_box(&rays) {
            black_box(black_box(&s).intersect(r));
        }
    });
}

#[divan::bench]
fn sphere_intersect_p(bencher: Bencher) {
    let (s, rays) = sphere();
    bencher.counter(ItemsCount::new(N)).bench_local(|| {
        for r in black_box(&rays) {
            black_box(black_box(&s).intersect_p(r));
        }
    });
}

/// Rays spawned off the sphere's own hits, half leaving it (a mirror's
/// reflection, which misses it) and half entering it (glass), tested
/// against it again, as every specular bounce does.
#[divan::bench]
fn sphere_spawned(bencher: Bencher) {
    let (s, rays) = sphere();
    let mut rng = Rng::new(3);
    let spawned: Vec<Ray> = rays
        .iter()
        .filter_map(|r| s.intersect(r))
        .enumerate()
        .map(|(i, (_, si))| {
            let w = uniform_sample_sphere(u2(&mut rng));
            let out = if w.dot(si.it.n) >= 0.0 { w } else { -w };
            si.spawn_ray(if i % 2 == 0 { out } else { -out })
        })
        .collect();
    check_mixed("spawned", &spawned, |r| s.intersect_p(r));
    bencher.counter(ItemsCount::new(spawned.len())).bench_local(|| {
        for r in black_box(&spawned) {
            black_box(black_box(&s).intersect(r));
        }
    });
}

/// A quadric clipped as all-shapes clips them (φ to 270°; the hyperboloid
/// swept from a slanted segment), placed by a translation, and rays from 6 units
/// away aimed into its box grown by 30%: many meet its quadric only where
/// it is clipped away, or miss it.
fn quadric(name: &str) -> (Shape, Vec<Ray>) {
    let c = Vec3::new(1.0, 2.0, 3.0);
    let xf = Transform::new(Mat4::from_translation(c));
    let phi = ("phimax", ParamValue::Float(vec![270.0]));
    let params = match name {
        "hyperboloid" => vec![
            ("p1", ParamValue::Point3(vec![[1.0, 0.0, -1.0]])),
            ("p2", ParamValue::Point3(vec![[0.5, 0.5, 1.0]])),
            phi,
        ],
        _ => vec![phi],
    };
    let s = make_shapes(name, params, &xf);
    // Its box, grown by 30%.
    let b = s[0].bounds();
    let (mid, half) = ((b.min + b.max) * 0.5, (b.max - b.min) * 0.65);
    let mut rng = Rng::new(4);
    let rays: Vec<Ray> = (0..N)
        .map(|_| {
            let o = mid + 6.0 * uniform_sample_sphere(u2(&mut rng));
            let target = mid + half * v3(&mut rng, -1.0, 1.0);
            Ray::new(o, (target - o).normalize(), 0.0)
        })
        .collect();
    check_mixed(name, &rays, |r| s[0].intersect_p(r));
    (s[0].clone(), rays)
}

/// `Shape::intersect_p` on the quadrics that solve pbrt-v3's quadratic.
#[divan::bench(args = ["cylinder", "cone", "paraboloid", "hyperboloid"])]
fn quadric_intersect_p(bencher: Bencher, name: &str) {
    let (s, rays) = quadric(name);
    bencher.counter(ItemsCount::new(N)).bench_local(|| {
        for r in black_box(&rays) {
            black_box(black_box(&s).intersect_p(r));
        }
    });
}
