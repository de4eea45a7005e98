//! Tests of directive semantics: transforms, graphics-state scoping,
//! textures, named materials, instancing, includes and parameter types.

use super::{parse_file, parse_str};
use farm_common::scene::{ParamValue, Params, SceneDescription, Warning};
use glam::{DMat4, DVec3};
use std::path::Path;

fn parse(src: &str) -> (SceneDescription, Vec<Warning>) {
    parse_str(src, "t.pbrt", Path::new(".")).unwrap_or_else(|e| panic!("{e}"))
}

fn err(src: &str) -> String {
    parse_str(src, "t.pbrt", Path::new(".")).unwrap_err().to_string()
}

fn close(a: DMat4, b: DMat4) -> bool {
    a.abs_diff_eq(b, 1e-9)
}

#[test]
fn ctm_directives() {
    let (s, _) = parse("LookAt 0 0 5  0 0 0  0 1 0\nCamera \"perspective\"\nWorldBegin\nTranslate 1 2 3\nShape \"sphere\"\n");
    // world_from_camera maps the camera origin to the eye.
    let wc = s.camera.world_from_camera.start;
    assert!(wc.transform_point3(DVec3::ZERO).abs_diff_eq(DVec3::new(0.0, 0.0, 5.0), 1e-12));
    assert!(wc.transform_vector3(DVec3::Z).abs_diff_eq(DVec3::NEG_Z, 1e-12));
    assert!(close(
        s.shapes[0].world_from_object.start,
        DMat4::from_translation(DVec3::new(1.0, 2.0, 3.0))
    ));

    // Transform is column-major: the last four numbers hold the translation.
    let (s, _) = parse("WorldBegin Transform [1 0 0 0 0 1 0 0 0 0 1 0 4 5 6 1] Shape \"sphere\" ConcatTransform 2 0 0 0 0 2 0 0 0 0 2 0 0 0 0 1 Shape \"sphere\"");
    let m = s.shapes[0].world_from_object.start;
    assert_eq!(m.transform_point3(DVec3::ZERO), DVec3::new(4.0, 5.0, 6.0));
    assert_eq!(
        s.shapes[1].world_from_object.start.transform_point3(DVec3::ONE),
        DVec3::new(6.0, 7.0, 8.0)
    );

    // Rotate 90 about z then Scale: x -> 2y.
    let (s, _) = parse("WorldBegin Rotate 90 0 0 1 Scale 2 2 2 Shape \"sphere\"");
    let p = s.shapes[0].world_from_object.start.transform_point3(DVec3::X);
    assert!(p.abs_diff_eq(DVec3::new(0.0, 2.0, 0.0), 1e-12), "{p}");
}

#[test]
fn coord_sys_camera_and_attribute_scope() {
    let src = "Translate 0 0 -5\nCamera \"perspective\"\nWorldBegin\n\
AttributeBegin\n  CoordSysTransform \"camera\"\n  LightSource \"point\"\n  Material \"glass\"\n  ReverseOrientation\n  Shape \"sphere\"\nAttributeEnd\n\
TransformBegin Translate 1 0 0 TransformEnd\nShape \"sphere\"\nAttributeEnd\n";
    let (s, w) = parse(src);
    let camera = DMat4::from_translation(DVec3::new(0.0, 0.0, 5.0));
    assert!(close(s.camera.world_from_camera.start, camera));
    assert!(close(s.lights[0].world_from_light.start, camera));
    let (inner, outer) = (&s.shapes[0], &s.shapes[1]);
    assert!(inner.reverse_orientation && !outer.reverse_orientation);
    assert_eq!(s.materials[inner.material.unwrap() as usize].entity.name, "glass");
    assert_eq!(outer.material, Some(0));
    assert_eq!(outer.world_from_object.start, DMat4::IDENTITY);
    assert!(w.iter().any(|w| w.message.contains("Unmatched pbrtAttributeEnd")), "{w:?}");
}

#[test]
fn animated_transforms_and_times() {
    let src = "TransformTimes 0 2\nWorldBegin\nActiveTransform EndTime\nTranslate 1 0 0\nActiveTransform All\nShape \"sphere\"\n";
    let (s, _) = parse(src);
    let x = s.shapes[0].world_from_object;
    assert_eq!((x.start_time, x.end_time), (0.0, 2.0));
    assert_eq!(x.start, DMat4::IDENTITY);
    assert_eq!(x.end.transform_point3(DVec3::ZERO), DVec3::X);
}

#[test]
fn texture_scoping_and_references() {
    let src = "WorldBegin\nTexture \"a\" \"float\" \"constant\" \"float value\" .5\n\
AttributeBegin\n Texture \"b\" \"color\" \"checkerboard\" \"texture tex1\" \"a\"\n Material \"matte\" \"texture Kd\" \"b\" \"texture sigma\" \"a\"\n Shape \"sphere\"\nAttributeEnd\n\
Material \"matte\" \"texture Kd\" \"b\"\nShape \"sphere\"\nWorldEnd\n";
    let (s, w) = parse(src);
    assert_eq!(s.textures.len(), 2);
    let tex1 = Params::new(&s.textures[1].entity.params).texture("tex1").cloned().unwrap();
    assert_eq!((tex1.float_id, tex1.spectrum_id), (Some(0), None));
    let m0 = Params::new(&s.materials[s.shapes[0].material.unwrap() as usize].entity.params)
        .texture("Kd")
        .cloned();
    assert_eq!(m0.unwrap().spectrum_id, Some(1));
    // Outside the block "b" is out of scope: pbrt-v3's error as a warning.
    let m1 = Params::new(&s.materials[s.shapes[1].material.unwrap() as usize].entity.params)
        .texture("Kd")
        .cloned();
    assert_eq!((m1.as_ref().unwrap().float_id, m1.unwrap().spectrum_id), (None, None));
    assert_eq!(w.len(), 1, "{w:?}");
    assert!(w[0].to_string().starts_with("t.pbrt:8:18: warning: Couldn't find"), "{}", w[0]);
}

#[test]
fn named_materials_and_mix() {
    let src = "WorldBegin\nMakeNamedMaterial \"red\" \"string type\" \"matte\" \"rgb Kd\" [.5 0 0]\n\
MakeNamedMaterial \"blue\" \"string type\" [\"plastic\"]\n\
MakeNamedMaterial \"both\" \"string type\" \"mix\" \"string namedmaterial1\" \"red\" \"string namedmaterial2\" \"blue\"\n\
NamedMaterial \"both\" Shape \"sphere\"\nNamedMaterial \"nope\" Shape \"sphere\"\n\
Material \"none\" Shape \"sphere\"\nAttributeBegin MakeNamedMaterial \"local\" \"string type\" \"glass\" AttributeEnd NamedMaterial \"local\"\nWorldEnd\n";
    let (s, w) = parse(src);
    assert_eq!(s.materials.len(), 5);
    assert_eq!(s.materials[1].name.as_deref(), Some("red"));
    assert!(s.materials[1].entity.params.get("type").is_none());
    let mix = &s.materials[3];
    assert_eq!(mix.entity.name, "mix");
    let p = Params::new(&mix.entity.params);
    assert_eq!((p.material("namedmaterial1"), p.material("namedmaterial2")), (Some(1), Some(2)));
    assert_eq!(s.shapes[0].material, Some(3));
    assert_eq!(s.shapes[1].material, Some(3), "unknown NamedMaterial keeps the current one");
    assert_eq!(s.shapes[2].material, None);
    assert_eq!(w.len(), 2, "{w:?}");
    assert!(w.iter().all(|w| w.message.contains("unknown")));
}

#[test]
fn object_instancing() {
    let src = "WorldBegin\nTranslate 0 0 1\nObjectBegin \"o\"\n AreaLightSource \"diffuse\" \"rgb L\" [1 1 1]\n Translate 1 0 0\n Shape \"sphere\"\nObjectEnd\n\
Shape \"disk\"\nAttributeBegin Translate 0 5 0 ObjectInstance \"o\" AttributeEnd\nObjectInstance \"p\"\n\
ObjectBegin \"empty\" ObjectEnd ObjectInstance \"empty\"\n";
    let (s, w) = parse(src);
    assert_eq!(s.objects.len(), 2);
    let o = &s.objects[0];
    assert_eq!(o.shapes.len(), 1);
    // pbrt-v3 keeps the light on the shape (it emits but lights nothing).
    assert_eq!(o.shapes[0].area_light.as_ref().map(|a| a.name.as_str()), Some("diffuse"));
    // pbrt-v3's convention: the object's shape keeps the full CTM.
    assert_eq!(
        o.shapes[0].world_from_object.start.transform_point3(DVec3::ZERO),
        DVec3::new(1.0, 0.0, 1.0)
    );
    assert_eq!(s.instances.len(), 1);
    assert_eq!(
        s.instances[0].world_from_instance.start.transform_point3(DVec3::ZERO),
        DVec3::new(0.0, 5.0, 1.0)
    );
    // ObjectEnd restored the state: the disk has no area light.
    assert_eq!(s.shapes.len(), 1);
    assert!(s.shapes[0].area_light.is_none());
    let msgs: Vec<_> = w.iter().map(|w| w.message.as_str()).collect();
    assert!(msgs.contains(&"Area lights not supported with object instancing"), "{msgs:?}");
    assert!(msgs.contains(&"Unable to find instance named \"p\""), "{msgs:?}");
}

#[test]
fn defaults_aliases_and_spectra() {
    let (s, w) = parse("WorldBegin\nLightSource \"exinfinite\" \"blackbody L\" [6500 1] \"xyz scale\" [1 1 1] \"bool flag\" true\nWorldEnd\n# done\n");
    assert_eq!(s.camera.entity.name, "perspective");
    assert_eq!(
        (s.sampler.name.as_str(), s.film.name.as_str(), s.filter.name.as_str()),
        ("halton", "image", "box")
    );
    assert_eq!((s.integrator.name.as_str(), s.accelerator.name.as_str()), ("path", "bvh"));
    assert_eq!(s.materials.len(), 1);
    assert_eq!(s.lights[0].entity.name, "exinfinite");
    let p = Params::new(&s.lights[0].entity.params);
    assert_eq!(
        p.spectrum("L", farm_common::Spectrum::ZERO),
        farm_common::cie::blackbody_rgb(6500.0, 1.0)
    );
    assert_eq!(
        p.spectrum("scale", farm_common::Spectrum::ZERO),
        farm_common::cie::xyz_to_rgb([1.0, 1.0, 1.0])
    );
    assert!(p.bool("flag", false));
    assert!(w.is_empty(), "{w:?}");
    // What follows a WorldEnd is another scene, as in pbrt-v3.
    let (_, w) = parse("WorldBegin WorldEnd Shape \"sphere\"");
    assert_eq!(w.len(), 1);
    assert!(w[0].message.contains("describes 2 scenes"), "{w:?}");
}

#[test]
fn include_is_relative_to_including_file_and_assets_load() {
    let dir = std::env::temp_dir().join(format!("farm-parser-inc-{}", std::process::id()));
    std::fs::create_dir_all(dir.join("sub/deeper")).unwrap();
    std::fs::write(dir.join("sub/a.pbrt"), "Include \"deeper/b.pbrt\"\n").unwrap();
    std::fs::write(dir.join("sub/deeper/b.pbrt"), "Shape \"sphere\" \"float radius\" 3\n").unwrap();
    std::fs::write(dir.join("sky.exr"), b"EXR").unwrap();
    let main = dir.join("main.pbrt");
    std::fs::write(&main, "WorldBegin\nLightSource \"infinite\" \"string mapname\" \"sky.exr\"\nInclude \"sub/a.pbrt\"\nWorldEnd\n").unwrap();
    let (s, w) = parse_file(&main).unwrap();
    assert!(w.is_empty(), "{w:?}");
    assert_eq!(s.name, "main");
    assert_eq!(s.shapes.len(), 1);
    assert_eq!(s.shapes[0].entity.loc.line, 1);
    assert!(s.shapes[0].entity.loc.file.ends_with("deeper/b.pbrt"));
    let key = Params::new(&s.lights[0].entity.params).string("mapname", "");
    assert_eq!(key, "sky.exr");
    assert_eq!(s.assets[&key], b"EXR");
    std::fs::remove_dir_all(dir).ok();
}

#[test]
fn asset_keys_are_relative_and_mark_files_outside_the_scene_folder() {
    let dir = std::env::temp_dir().join(format!("farm-parser-keys-{}", std::process::id()));
    std::fs::create_dir_all(dir.join("scene/tex")).unwrap();
    std::fs::create_dir_all(dir.join("secret")).unwrap();
    std::fs::write(dir.join("scene/tex/a.png"), b"A").unwrap();
    std::fs::write(dir.join("secret/key.png"), b"K").unwrap();
    let main = dir.join("scene/main.pbrt");
    let tex = |n: &str, f: &str| {
        format!("Texture \"{n}\" \"spectrum\" \"imagemap\" \"string filename\" \"{f}\"\n")
    };
    let abs = dir.join("secret/key.png");
    let text = format!(
        "WorldBegin\n{}{}{}{}WorldEnd\n",
        tex("a", "tex/a.png"),
        tex("b", "tex/../tex/a.png"),
        tex("c", "../secret/key.png"),
        tex("d", &abs.to_string_lossy()),
    );
    std::fs::write(&main, text).unwrap();
    let (s, _) = parse_file(&main).unwrap();
    let keys: Vec<String> = s.assets.keys().cloned().collect();
    assert_eq!(keys, vec!["../secret/key.png".to_string(), "tex/a.png".to_string()]);
    assert!(keys.iter().all(|k| !Path::new(k).is_absolute()));
    assert!(crate::is_outside(&keys[0]) && !crate::is_outside(&keys[1]));
    std::fs::remove_dir_all(dir).ok();
}

#[test]
fn parameter_values_match_declared_types() {
    let (s, _) = parse("WorldBegin Shape \"curve\" \"point3 P\" [0 0 0 1 1 1] \"normal N\" [0 0 1] \"point2 uv\" [1 2] \"vector2 d\" [3 4] \"vector v\" [1 0 0] \"string type\" \"flat\" \"integer degree\" 2");
    let set = &s.shapes[0].entity.params;
    assert_eq!(set.get("P").unwrap().value, ParamValue::Point3(vec![[0.0; 3], [1.0; 3]]));
    assert_eq!(set.get("uv").unwrap().value, ParamValue::Point2(vec![[1.0, 2.0]]));
    assert_eq!(set.get("degree").unwrap().value, ParamValue::Int(vec![2]));
    assert_eq!(set.get("type").unwrap().value, ParamValue::String(vec!["flat".into()]));
    assert!(err("WorldBegin Shape \"x\" \"string s\" 1").contains("expected a quoted string"));
    assert!(err("WorldBegin Shape \"x\" \"spectrum s\" [\"a\" 1]").contains("mixed"));
    assert!(err("WorldBegin Shape \"x\" \"texture t\" [\"a\" \"b\"]")
        .contains("exactly one texture name"));
}

/// Each light knows how many top-level shapes came before it (pbrt-v3
/// lists lights in directive order, area lights among them), shapes in
/// object definitions not counted; `--cat` writes it back in place.
#[test]
fn lights_know_the_shapes_before_them() {
    let src = "WorldBegin\nLightSource \"point\"\nAreaLightSource \"diffuse\"\nShape \"disk\"\n\
ObjectBegin \"o\" Shape \"sphere\" ObjectEnd\nLightSource \"spot\"\nShape \"sphere\"\nShape \"sphere\"\nLightSource \"distant\"\n";
    let (s, _) = parse(src);
    let before: Vec<u32> = s.lights.iter().map(|l| l.shapes_before).collect();
    assert_eq!(before, [0, 1, 3]);
    let text = crate::write_scene(&s, crate::Meshes::Inline).unwrap();
    let (again, _) = parse(&text);
    let after: Vec<u32> = again.lights.iter().map(|l| l.shapes_before).collect();
    assert_eq!(after, before, "{text}");
}
