//! Textured alpha masks on meshes, as pbrt-v3's `Triangle::Intersect` and
//! `IntersectP` apply them: `alpha` cuts hits for every ray, `shadowalpha`
//! for shadow rays only; a mask is zero or it is not (no blending).

use farm_common::geometry::{DMat4, Ray, Transform, Vec3};
use farm_common::scene::{
    Entity, FileLoc, Param, ParamSet, ParamValue, Params, TextureEntity, TextureKind, TextureRef,
};
use farm_render::shapes::{self, Shape};
use std::collections::BTreeMap;
use std::sync::Arc;

fn set(params: Vec<(&str, ParamValue)>) -> ParamSet {
    let mut s = ParamSet::default();
    for (name, value) in params {
        s.add(Param { name: name.into(), value, loc: FileLoc::default() });
    }
    s
}

/// A unit quad in z = 0 with a 2×1 checkerboard mask in u (left half 1,
/// right half 0) as `mask` ("alpha" or "shadowalpha").
fn quad(mask: &str) -> Vec<Shape> {
    let checks = TextureEntity {
        name: "c".into(),
        kind: TextureKind::Float,
        entity: Entity {
            name: "checkerboard".into(),
            params: set(vec![
                ("uscale", ParamValue::Float(vec![2.0])),
                ("vscale", ParamValue::Float(vec![1.0])),
                ("tex1", ParamValue::Float(vec![1.0])),
                ("tex2", ParamValue::Float(vec![0.0])),
            ]),
            loc: FileLoc::default(),
        },
        world_from_texture: DMat4::IDENTITY,
    };
    let mut w = Vec::new();
    let textures = Arc::new(farm_render::textures::build(
        &[checks],
        &Transform::default(),
        &BTreeMap::new(),
        &mut w,
    ));
    let params = set(vec![
        ("indices", ParamValue::Int(vec![0, 1, 2, 0, 2, 3])),
        (
            "P",
            ParamValue::Point3(vec![
                [0.0, 0.0, 0.0],
                [1.0, 0.0, 0.0],
                [1.0, 1.0, 0.0],
                [0.0, 1.0, 0.0],
            ]),
        ),
        ("uv", ParamValue::Point2(vec![[0.0, 0.0], [1.0, 0.0], [1.0, 1.0], [0.0, 1.0]])),
        (
            mask,
            ParamValue::Texture(TextureRef {
                name: "c".into(),
                float_id: Some(0),
                spectrum_id: None,
            }),
        ),
    ]);
    let p = Params::new(&params);
    let shapes = shapes::create_in(
        "trianglemesh",
        &p,
        &Transform::default(),
        false,
        Some(&textures),
        &mut w,
    );
    assert!(w.is_empty() && p.unused_warnings().is_empty(), "{w:?}");
    shapes
}

fn ray_at(x: f32) -> Ray {
    Ray::new(Vec3::new(x, 0.4, -1.0), Vec3::Z, 0.0)
}

fn hits(shapes: &[Shape], x: f32) -> (bool, bool) {
    let r = ray_at(x);
    (shapes.iter().any(|s| s.intersect(&r).is_some()), shapes.iter().any(|s| s.intersect_p(&r)))
}

#[test]
fn alpha_cuts_every_ray_and_shadowalpha_only_shadow_rays() {
    let alpha = quad("alpha");
    assert_eq!(hits(&alpha, 0.25), (true, true), "alpha 1");
    assert_eq!(hits(&alpha, 0.75), (false, false), "alpha 0");
    let shadow = quad("shadowalpha");
    assert_eq!(hits(&shadow, 0.25), (true, true), "shadowalpha 1");
    assert_eq!(hits(&shadow, 0.75), (true, false), "shadowalpha 0");
}
