//! Tests of the triangle (`triangle.rs`).

use super::*;
use crate::shapes::Shape;
use farm_common::rng::Rng;

#[test]
fn a_prepared_ray_permutes_and_shears_as_pbrt_does() {
    // pbrt-v3: kz the largest |d| component (ties to the later axis
    // only when strictly larger), kx = kz + 1, ky = kx + 1 (mod 3).
    let dirs = [
        Vec3::new(0.9, -0.3, 0.2),
        Vec3::new(0.1, -0.8, 0.3),
        Vec3::new(-0.2, 0.3, -0.7),
        Vec3::new(0.5, 0.5, 0.1),
        Vec3::new(0.5, -0.2, -0.5),
        Vec3::new(0.3, 0.6, 0.6),
        Vec3::new(0.4, 0.4, 0.4),
    ];
    for d in dirs {
        let ad = d.abs();
        let kz = if ad.x > ad.y {
            if ad.x > ad.z {
                0
            } else {
                2
            }
        } else if ad.y > ad.z {
            1
        } else {
            2
        };
        let (kx, ky) = ((kz + 1) % 3, (kz + 2) % 3);
        let tr = TriRay::new(&Ray::new(Vec3::ZERO, d, 0.0));
        assert_eq!(tr.kz as usize, kz, "{d}");
        let want = [-d[kx] / d[kz], -d[ky] / d[kz], 1.0 / d[kz]];
        assert_eq!(tr.s.map(f32::to_bits), want.map(f32::to_bits), "{d}");
        let v = Vec3::new(1.0, 2.0, 3.0);
        assert_eq!(tr.permute(v), Vec3::new(v[kx], v[ky], v[kz]), "{d}");
    }
}

fn octahedron(scale: f32, offset: Vec3) -> Vec<Shape> {
    let p: Vec<Vec3> = [Vec3::X, -Vec3::X, Vec3::Y, -Vec3::Y, Vec3::Z, -Vec3::Z]
        .iter()
        .map(|&v| v * scale + offset)
        .collect();
    let mesh = Arc::new(TriangleMesh { p, ..Default::default() });
    let idx =
        [[0, 2, 4], [2, 1, 4], [1, 3, 4], [3, 0, 4], [2, 0, 5], [1, 2, 5], [3, 1, 5], [0, 3, 5]];
    idx.iter().map(|&v| Shape::Triangle { mesh: mesh.clone(), v }).collect()
}

fn views(shapes: &[Shape]) -> Vec<Triangle<'_>> {
    shapes.iter().map(|s| s.triangle().expect("a triangle")).collect()
}

/// Rays aimed exactly at shared edges and vertices of a closed mesh never slip through.
#[test]
fn watertight_at_edges_and_vertices() {
    let mut rng = Rng::new(5);
    for (scale, offset) in [(1.0, Vec3::ZERO), (3.7, Vec3::new(1e3, -250.0, 17.0))] {
        let shapes = octahedron(scale, offset);
        let tris = views(&shapes);
        let p = &tris[0].mesh.p;
        let edges = [
            (0, 2),
            (2, 1),
            (1, 3),
            (3, 0),
            (0, 4),
            (1, 4),
            (2, 4),
            (3, 4),
            (0, 5),
            (1, 5),
            (2, 5),
            (3, 5),
        ];
        for i in 0..20000 {
            let target = if i % 4 == 0 {
                p[(rng.uniform_u32() % 6) as usize]
            } else {
                let (a, b) = edges[(rng.uniform_u32() % 12) as usize];
                let s = rng.uniform_f32();
                p[a] + s * (p[b] - p[a])
            };
            let from_inside = i % 3 == 0;
            let o = if from_inside {
                offset
                    + 0.2
                        * scale
                        * Vec3::new(
                            rng.uniform_f32() - 0.5,
                            rng.uniform_f32() - 0.5,
                            rng.uniform_f32() - 0.5,
                        )
            } else {
                let w = crate::sampling::uniform_sample_sphere(Vec2::new(
                    rng.uniform_f32(),
                    rng.uniform_f32(),
                ));
                offset + w * scale * 5.0
            };
            let ray = Ray::new(o, target - o, 0.0);
            let n = tris.iter().filter(|t| t.intersect(&ray).is_some()).count();
            let np = tris.iter().filter(|t| t.intersect_p(&ray)).count();
            assert_eq!(n, np);
            if from_inside {
                assert!(n >= 1, "ray from inside escaped through {target:?}");
            }
        }
    }
}

#[test]
fn barycentric_hit_and_uv_defaults() {
    let shapes = octahedron(1.0, Vec3::ZERO);
    let tris = views(&shapes);
    let r = Ray::new(Vec3::new(0.2, 0.2, 5.0), -Vec3::Z, 0.0);
    let (t, si) = tris[0].intersect(&r).expect("hit");
    assert!((t - 4.4).abs() < 1e-5);
    assert!((si.p() - Vec3::new(0.2, 0.2, 0.6)).length() < 1e-5);
    assert!((si.n().abs() - Vec3::splat(1.0 / 3f32.sqrt())).length() < 1e-5);
    assert!(si.uv.x >= 0.0 && si.uv.x <= 1.0 && si.uv.y <= si.uv.x + 1e-6);
    assert!((tris[0].area() - 3f32.sqrt() / 2.0).abs() < 1e-5);
}

/// A sampled point's normal as pbrt-v3's `Triangle::Sample` orients it:
/// without shading normals, as a ray's hit at that point reports it
/// (flipped by reverse orientation XOR a handedness-swapping transform);
/// with them, turned to their side, whatever the flags (where pbrt-v3's
/// `Intersect` would flip it for reverse orientation: the two disagree
/// there, and farm renders what pbrt-v3 does).
#[test]
fn sampled_normals_face_as_pbrt_v3_samples_them() {
    let p = vec![Vec3::ZERO, Vec3::X, Vec3::Y];
    let tilted = |z: f32| Some(vec![Vec3::new(0.3, 0.0, z), Vec3::new(0.0, 0.2, z), Vec3::Z * z]);
    let mut flips = 0;
    for (rev, swap) in [(false, false), (true, false), (false, true), (true, true)] {
        for (n, side) in [(None, 0.0), (tilted(1.0), 1.0), (tilted(-1.0), -1.0)] {
            let mesh = Arc::new(TriangleMesh {
                p: p.clone(),
                n,
                reverse_orientation: rev,
                transform_swaps_handedness: swap,
                ..Default::default()
            });
            let shape = Shape::Triangle { mesh: mesh.clone(), v: [0, 1, 2] };
            let tri = shape.triangle().expect("a triangle");
            let u = Vec2::new(0.3, 0.6);
            let it = tri.sample_point(u);
            assert_eq!(it.n, tri.sample_point_facing(u, tri.geometric_normal()).n);
            let case = format!("reverse {rev}, swaps {swap}, shading side {side}");
            assert_eq!(it.n.z.abs(), 1.0, "{case}: the geometric normal, {}", it.n);
            if side == 0.0 {
                let ray = Ray::new(it.p + Vec3::Z, -Vec3::Z, 0.0);
                let (_, si) = shape.intersect_no_alpha(&ray).expect("the ray hits the point");
                assert_eq!(it.n.z, si.it.n.z, "{case}: sampled {} against hit {}", it.n, si.it.n);
            } else {
                assert_eq!(it.n.z, side, "{case}");
            }
            flips += usize::from(it.n.z < 0.0);
        }
    }
    // Both sides occur: the rule is not a constant.
    assert_eq!(flips, 6);
}
